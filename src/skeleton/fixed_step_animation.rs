//! Bevy's `AnimationPlayer` stepped with the cloth (feature `animation`).
//!
//! Bevy advances and applies animations once per rendered frame, in `PostUpdate`, while the
//! cloth steps at the fixed rate: in a frame with several fixed steps a character animated by
//! Bevy would move in one of them and stand still in the others, and its colliders' velocities
//! would jump from step to step (a slow machine renders few frames, so this is where it
//! breaks). With [`FixedStepAnimation`] on a character's root (a glTF scene's entity), every
//! animation player at or below it is advanced by the fixed step's time and applied to its
//! joints in [`DrapeSystems::Animate`], before the
//! colliders are read; in `PostUpdate` Bevy's own advance leaves these players' times alone
//! (their pose is drawn as the last fixed step left it).
//!
//! A playing animation keeps its speed and pause state; a repeating one wraps at its clip's
//! end, one that does not repeat holds its last pose. Transitions and animation events are
//! still Bevy's, once per frame.

use bevy::animation::graph::{AnimationGraph, AnimationGraphHandle, AnimationNodeType};
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

/// An animation player stepped in the fixed schedule, with its animations' times as the last
/// fixed step left them.
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct FixedStepPlayer {
    times: Vec<(bevy::animation::graph::AnimationNodeIndex, f32)>,
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
                (advance_fixed_step_players, animate_targets)
                    .chain()
                    .in_set(DrapeSystems::Animate),
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

/// Advances every playing, unpaused animation of the marked players by the fixed step.
fn advance_fixed_step_players(
    time: Res<Time>,
    clips: Res<Assets<AnimationClip>>,
    graphs: Res<Assets<AnimationGraph>>,
    mut players: Query<(&mut AnimationPlayer, &AnimationGraphHandle), With<FixedStepPlayer>>,
) {
    let dt = time.delta_secs();
    for (mut player, graph) in &mut players {
        let Some(graph) = graphs.get(graph) else {
            continue;
        };
        for (node, animation) in player.playing_animations_mut() {
            if animation.is_paused() || animation.is_finished() {
                continue;
            }
            let Some(AnimationNodeType::Clip(clip)) = graph.get(*node).map(|n| &n.node_type) else {
                continue;
            };
            let Some(duration) = clips.get(clip).map(AnimationClip::duration) else {
                continue;
            };
            let t = animation.seek_time() + dt * animation.speed();
            let t = match animation.repeat_mode() {
                RepeatAnimation::Never => t.clamp(0.0, duration),
                _ if duration > 0.0 => t.rem_euclid(duration),
                _ => 0.0,
            };
            if t.is_finite() {
                animation.seek_to(t);
            }
        }
    }
}

/// Before Bevy advances animations in `PostUpdate`: the marked players' times.
fn remember_fixed_step_times(mut players: Query<(&AnimationPlayer, &mut FixedStepPlayer)>) {
    for (player, mut remembered) in &mut players {
        remembered.times.clear();
        remembered.times.extend(
            player
                .playing_animations()
                .map(|(node, animation)| (*node, animation.seek_time())),
        );
    }
}

/// After Bevy's advance: the marked players' times put back, so they move with the fixed
/// step only.
fn restore_fixed_step_times(mut players: Query<(&mut AnimationPlayer, &FixedStepPlayer)>) {
    for (mut player, remembered) in &mut players {
        for &(node, time) in &remembered.times {
            if let Some(animation) = player.animation_mut(node) {
                animation.seek_to(time);
            }
        }
    }
}
