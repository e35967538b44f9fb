//! Bevy's `AnimationPlayer` stepped with the cloth (feature `animation`).
//!
//! Bevy advances and applies animations once per rendered frame, in `PostUpdate`, while the
//! cloth steps at the fixed rate: in a frame with several fixed steps a character animated by
//! Bevy would move in one of them and stand still in the others, and its colliders' velocities
//! would jump from step to step (a slow machine renders few frames, so this is where it
//! breaks). With [`FixedStepAnimation`] on a character's root (a glTF scene's entity), every
//! animation player at or below it is advanced by the fixed step's time and applied to its
//! joints in [`DrapeSystems::Animate`], before the
//! colliders are read. In `PostUpdate` Bevy's own advance is undone for these players and
//! they are drawn between their last two fixed steps, at the fixed clock's overstep fraction,
//! as the cloth is (evaluated at that time, not blended), so body and cloth move together at
//! any frame rate.
//!
//! A playing animation keeps its speed and pause state; a repeating one wraps at its clip's
//! end, one that does not repeat holds its last pose; a time set by the game (`seek_to`)
//! between fixed steps is taken up. Transitions and animation events are still Bevy's, once
//! per frame.

use bevy::animation::graph::{
    AnimationGraph, AnimationGraphHandle, AnimationNodeIndex, AnimationNodeType,
};
use bevy::animation::{
    AnimationClip, AnimationPlayer, RepeatAnimation, advance_animations, animate_targets,
};
use bevy::prelude::*;

use crate::schedule::{DrapeSchedule, DrapeSystems};

/// On a character's root: its animation players (on it or below it) are advanced with the
/// cloth, every fixed step (see the [module docs](self)).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct FixedStepAnimation;

/// An animation player stepped in the fixed schedule, with its animations' times.
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct FixedStepPlayer {
    animations: Vec<FixedStepTime>,
}

/// One animation's clock in the fixed schedule.
#[derive(Clone, Copy, Debug)]
struct FixedStepTime {
    node: AnimationNodeIndex,
    /// The time at the last fixed step.
    time: f32,
    /// How far the last fixed step moved it (speed times the step).
    advance: f32,
    /// The clip's length and whether it repeats, for wrapping.
    duration: f32,
    repeats: bool,
    /// The time it was last drawn at (set in `PostUpdate`); another time found there was set
    /// by the game.
    drawn: f32,
}

impl FixedStepTime {
    /// `t` wrapped into the clip (repeating) or held at its ends.
    fn wrap(&self, t: f32) -> f32 {
        match (self.repeats, self.duration > 0.0) {
            (true, true) => t.rem_euclid(self.duration),
            (true, false) => 0.0,
            (false, _) => t.clamp(0.0, self.duration.max(0.0)),
        }
    }
}

/// Steps the animation players under [`FixedStepAnimation`] with the cloth; needs Bevy's
/// `AnimationPlugin` (without it, it does nothing). Part of [`crate::DrapePlugins`].
#[derive(Default)]
pub struct FixedStepAnimationPlugin;

impl Plugin for FixedStepAnimationPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<FixedStepAnimation>();
    }

    fn finish(&self, app: &mut App) {
        if !app.is_plugin_added::<bevy::animation::AnimationPlugin>() {
            return;
        }
        let schedule = DrapeSchedule::of(app);
        app.add_systems(PreUpdate, find_fixed_step_players)
            .add_systems(
                schedule,
                // Bevy's `animate_targets` poses every player's targets, so it runs here only
                // while some player is stepped with the cloth.
                (advance_fixed_step_players, animate_targets)
                    .chain()
                    .in_set(DrapeSystems::Animate)
                    .run_if(any_with_component::<FixedStepPlayer>),
            )
            .add_systems(
                PostUpdate,
                (
                    remember_fixed_step_times.before(advance_animations),
                    restore_fixed_step_times
                        .after(advance_animations)
                        .before(animate_targets),
                ),
            );
    }
}

/// Marks every animation player at or below a [`FixedStepAnimation`] root (a scene's players
/// appear some frames after the scene is asked for), and unmarks those no longer under one.
fn find_fixed_step_players(
    mut commands: Commands,
    players: Query<(Entity, Has<FixedStepPlayer>), With<AnimationPlayer>>,
    parents: Query<&ChildOf>,
    roots: Query<(), With<FixedStepAnimation>>,
) {
    for (player, marked) in &players {
        let under_root =
            roots.contains(player) || parents.iter_ancestors(player).any(|a| roots.contains(a));
        if under_root && !marked {
            commands.entity(player).insert(FixedStepPlayer::default());
        } else if marked && !under_root {
            commands.entity(player).remove::<FixedStepPlayer>();
        }
    }
}

/// Advances every playing, unpaused animation of the marked players by the fixed step, from
/// its time at the last fixed step.
fn advance_fixed_step_players(
    time: Res<Time>,
    clips: Res<Assets<AnimationClip>>,
    graphs: Res<Assets<AnimationGraph>>,
    mut players: Query<(
        &mut AnimationPlayer,
        &AnimationGraphHandle,
        &mut FixedStepPlayer,
    )>,
) {
    let dt = time.delta_secs();
    for (mut player, graph, mut fixed) in &mut players {
        let Some(graph) = graphs.get(graph) else {
            continue;
        };
        let fixed = &mut *fixed;
        for (node, animation) in player.playing_animations_mut() {
            let Some(AnimationNodeType::Clip(clip)) = graph.get(*node).map(|n| &n.node_type) else {
                continue;
            };
            let Some(duration) = clips.get(clip).map(AnimationClip::duration) else {
                continue;
            };
            let at = fixed.animations.iter().position(|a| a.node == *node);
            // From the last fixed step's time, unless the game set another since it was drawn.
            let start = at
                .map(|k| fixed.animations[k])
                .filter(|clock| clock.drawn == animation.seek_time())
                .map_or(animation.seek_time(), |clock| clock.time);
            let moving = !animation.is_paused() && !animation.is_finished();
            let advance = if moving { dt * animation.speed() } else { 0.0 };
            let mut clock = FixedStepTime {
                node: *node,
                time: start,
                advance,
                duration,
                repeats: animation.repeat_mode() != RepeatAnimation::Never,
                drawn: start,
            };
            let t = clock.wrap(start + advance);
            if !t.is_finite() {
                continue;
            }
            clock.time = t;
            clock.drawn = t;
            animation.seek_to(t);
            match at {
                Some(k) => fixed.animations[k] = clock,
                None => fixed.animations.push(clock),
            }
        }
    }
}

/// Before Bevy advances animations in `PostUpdate`: a time the game set since the last frame
/// becomes the animation's fixed-step time; animations no longer playing are forgotten.
fn remember_fixed_step_times(mut players: Query<(&AnimationPlayer, &mut FixedStepPlayer)>) {
    for (player, mut fixed) in &mut players {
        fixed
            .animations
            .retain(|a| player.animation(a.node).is_some());
        for clock in &mut fixed.animations {
            if let Some(animation) = player.animation(clock.node)
                && animation.seek_time() != clock.drawn
            {
                clock.time = animation.seek_time();
                clock.advance = 0.0;
            }
        }
    }
}

/// After Bevy's advance: the marked players' times set between their last two fixed steps at
/// the fixed clock's overstep fraction, so they move with the fixed step only and are drawn
/// where the cloth is.
fn restore_fixed_step_times(
    fixed_time: Res<Time<Fixed>>,
    mut players: Query<(&mut AnimationPlayer, &mut FixedStepPlayer)>,
) {
    let behind = 1.0 - fixed_time.overstep_fraction().clamp(0.0, 1.0);
    for (mut player, mut fixed) in &mut players {
        for clock in &mut fixed.animations {
            let drawn = clock.wrap(clock.time - behind * clock.advance);
            if let Some(animation) = player.animation_mut(clock.node)
                && drawn.is_finite()
            {
                animation.seek_to(drawn);
                clock.drawn = drawn;
            }
        }
    }
}
