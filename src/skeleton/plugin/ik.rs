//! Inverse kinematics ([`InverseKinematics`]) on the skeletons' hinge chains, and on the
//! joints of any other hierarchy found by name (a glTF scene's), as ball joints.

use bevy::ecs::query::QueryData;
use bevy::ecs::system::SystemParam;

use bevy::log::warn;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use crate::skeleton::ik::{
    BallChain, IkChain, IkResult, IkScratch, IkTracking, JointLimits, solve, solve_with,
};
use crate::skeleton::rig::Pose;

use super::components::*;

/// A character with IK goals.
#[derive(QueryData)]
#[query_data(mutable)]
pub(super) struct IkCharacter {
    entity: Entity,
    skeleton: &'static Skeleton,
    ik: &'static mut InverseKinematics,
    pose: &'static mut SkeletonPose,
    state: &'static mut IkState,
}

/// Solves every character's IK goals on top of its keyframed pose.
pub(super) fn solve_ik(
    mut characters: Query<IkCharacter>,
    transforms: TransformHelper,
    time: Res<Time>,
) {
    let dt = time.delta_secs();
    for item in &mut characters {
        let (entity, skeleton, mut ik, mut state, mut ik_state) =
            (item.entity, item.skeleton, item.ik, item.pose, item.state);
        let state = &mut *state;
        let Some(character) = state.global else {
            continue;
        };
        let to_local = character.affine().inverse();
        let rig = &skeleton.rig;
        let ik = &mut *ik;
        let ik_state = &mut *ik_state;
        ik.results.resize(ik.goals.len(), None);
        ik_state.chains.resize(ik.goals.len(), None);
        let keyframed = state.pose.angles.clone();
        for (g, goal) in ik.goals.iter().enumerate() {
            ik.results[g] = None;
            let key = (goal.end_bone.clone(), goal.length, goal.effector);
            if ik_state.chains[g]
                .as_ref()
                .is_none_or(|(built, _)| *built != key)
            {
                let chain = IkChain::new(rig, &goal.end_bone, goal.length, goal.effector);
                if let Err(err) = &chain {
                    warn!("character {entity}: IK goal {g} is ignored: {err}");
                }
                ik_state.chains[g] = Some((key, chain));
                if let Some(tracking) = ik_state.tracking.get_mut(g) {
                    tracking.forget();
                }
            }
            let Some((_, Ok(chain))) = &ik_state.chains[g] else {
                continue;
            };
            let target = match goal.target {
                IkTarget::Point(p) => Some(to_local.transform_point3(p)),
                IkTarget::CharacterPoint(p) => Some(p),
                IkTarget::Entity(e) => transforms
                    .compute_global_transform(e)
                    .ok()
                    .map(|t| to_local.transform_point3(t.translation())),
            };
            let Some(target) = target.filter(|t| t.is_finite()) else {
                continue;
            };
            // Start from this goal's last solution (a solve from nearby converges to the nearby
            // solution, so the arm does not flip to another one between steps), or from the
            // keyframes the first time.
            ik_state.solved.clone_from(&state.pose);
            ik_state
                .tracking
                .resize(ik.goals.len(), IkTracking::default());
            let settings =
                ik_state.tracking[g].warm_start(chain, &mut ik_state.solved, &goal.settings);
            let result = solve(
                rig,
                chain,
                &mut ik_state.solved,
                target,
                &settings,
                &mut ik_state.scratch,
            );
            // Towards the solution at most `max_speed`; the next solve starts from here.
            ik_state.tracking[g].follow(chain, &mut ik_state.solved, goal.max_speed * dt);
            let weight = goal.weight.clamp(0.0, 1.0);
            for &b in &chain.bones {
                let (from, to) = (state.pose.angles[b], ik_state.solved.angles[b]);
                state.pose.angles[b] = from + (to - from) * weight;
            }
            ik.results[g] = Some(result);
        }
        // Hinge rates of the bones IK moved: the rates of their final angles at this step.
        for (b, (&angle, &keyed)) in state.pose.angles.iter().zip(&keyframed).enumerate() {
            if angle != keyed
                && let Some(rate) = ik_state.rates.rate(b, angle, dt)
                && let Some(slot) = state.rate.angle_rates.get_mut(b)
            {
                *slot = rate;
            }
        }
        ik_state.rates.push(&state.pose.angles);
    }
}

/// The hierarchy the chains of named joints are found in and written to.
#[derive(SystemParam)]
pub(super) struct Joints<'w, 's> {
    transforms: Query<'w, 's, &'static mut Transform>,
    children: Query<'w, 's, &'static Children>,
    parents: Query<'w, 's, &'static ChildOf>,
    names: Query<'w, 's, &'static Name>,
}

impl Joints<'_, '_> {
    /// The world transform of `entity` from its own and its ancestors' `Transform`s as they
    /// are now (`GlobalTransform` is only propagated once per frame); `None` if one has none.
    fn global(&self, entity: Entity) -> Option<GlobalTransform> {
        let mut global = GlobalTransform::from(*self.transforms.get(entity).ok()?);
        let mut at = entity;
        while let Ok(parent) = self.parents.get(at) {
            at = parent.parent();
            global = GlobalTransform::from(*self.transforms.get(at).ok()?) * global;
        }
        Some(global)
    }
}

/// Memory reused by every goal's solve.
#[derive(Default)]
pub(super) struct NamedScratch {
    /// Each joint's offset and animated rotation, for [`BallChain::set_pose`].
    joints: Vec<(Vec3, Quat)>,
    /// Each joint's rotation to write.
    rotations: Vec<Quat>,
}

/// Solves the IK goals of every character without a [`Skeleton`] on its joints found by name
/// (see [`InverseKinematics`]), on top of the pose the animation gave them at this step.
pub(super) fn solve_ik_by_name(
    mut characters: Query<(Entity, &mut InverseKinematics, &mut IkState), Without<Skeleton>>,
    mut joints: Joints,
    time: Res<Time>,
    mut scratch: Local<NamedScratch>,
) {
    let dt = time.delta_secs();
    for (entity, mut ik, mut state) in &mut characters {
        let (ik, state) = (&mut *ik, &mut *state);
        ik.results.resize(ik.goals.len(), None);
        state.named.resize_with(ik.goals.len(), Default::default);
        let character = joints.global(entity);
        for (g, goal) in ik.goals.iter().enumerate() {
            let named = &mut state.named[g];
            let solved = solve_named(
                entity,
                goal,
                named,
                &mut joints,
                character,
                dt,
                (&mut state.scratch, &mut state.solved, &mut scratch),
            );
            ik.results[g] = solved.as_ref().ok().copied();
            match solved {
                Ok(_) => named.warned = None,
                Err(Some(problem)) if named.warned != Some(problem) => {
                    warn_named(entity, g, goal, named, problem);
                    named.warned = Some(problem);
                }
                Err(_) => {}
            }
        }
    }
}

/// The warning for a goal on named joints that is skipped.
fn warn_named(entity: Entity, g: usize, goal: &IkGoal, named: &NamedChain, problem: NamedProblem) {
    let end = &goal.end_bone;
    let why = match problem {
        NamedProblem::Chain => match &named.ball {
            Some(Err(err)) if goal.length > 0 => format!("its chain cannot be built: {err}"),
            _ => "a chain of 0 joints".to_string(),
        },
        NamedProblem::NoJoint => "the character has no joint of that name".to_string(),
        NamedProblem::TooLong => format!(
            "the joint has fewer than {} ancestors below the character, for a chain of {} \
             joints",
            goal.length.saturating_sub(1),
            goal.length
        ),
        NamedProblem::Transform => "a joint's transform or the effector is not finite".to_string(),
        NamedProblem::Target => "its target is not finite or has no transform".to_string(),
        NamedProblem::Weight => "its weight is not finite".to_string(),
    };
    warn!("character {entity}: IK goal {g} on joint {end:?} is skipped: {why}");
}

/// Solves one goal on named joints and writes the joints' rotations; `Err(None)` while there
/// is nothing to solve yet (the scene has not spawned, a joint has just gone).
fn solve_named(
    entity: Entity,
    goal: &IkGoal,
    named: &mut NamedChain,
    joints: &mut Joints,
    character: Option<GlobalTransform>,
    dt: f32,
    (scratch, solved, buffers): (&mut IkScratch, &mut Pose, &mut NamedScratch),
) -> Result<IkResult, Option<NamedProblem>> {
    // The chain as ball joints, rebuilt when the goal's chain changes.
    let same = named.key.as_ref().is_some_and(|(end, length, limits)| {
        *end == goal.end_bone && *length == goal.length && *limits == goal.joint_limits
    });
    if !same {
        // `joint_limits` is from the end joint up; the chain from the first joint down.
        let limits: Vec<JointLimits> = (0..goal.length)
            .rev()
            .map(|k| goal.joint_limits.get(k).copied().unwrap_or_default())
            .collect();
        named.ball = Some(BallChain::new(&limits));
        named.key = Some((
            goal.end_bone.clone(),
            goal.length,
            goal.joint_limits.clone(),
        ));
        named.joints.clear();
        named.warned = None;
    }
    let Some(Ok(ball)) = &mut named.ball else {
        return Err(Some(NamedProblem::Chain));
    };
    // The joints: found again if one has gone or moved in the hierarchy.
    let valid = !named.joints.is_empty()
        && named.joints.iter().all(|&j| joints.transforms.contains(j))
        && joints
            .names
            .get(named.joints[named.joints.len() - 1])
            .is_ok_and(|n| n.as_str() == goal.end_bone)
        && named.joints.iter().enumerate().all(|(k, &j)| {
            let parent = joints.parents.get(j).ok().map(ChildOf::parent);
            parent
                == if k == 0 {
                    named.base
                } else {
                    Some(named.joints[k - 1])
                }
        });
    if !valid {
        named.joints.clear();
        named.written.clear();
        named.tracking.forget();
        let (chain, base) = find_chain(entity, goal, joints)?;
        named.joints = chain;
        named.base = Some(base);
    }
    let n = named.joints.len();
    let Some(base) = named.base.and_then(|b| joints.global(b)) else {
        named.joints.clear();
        return Err(None);
    };
    // The joints' world frames with their animated rotations: the rotation in the `Transform`,
    // unless it is still the one IK wrote (nothing animated it since), then the animated one
    // from before.
    let (_, base_rotation, base_position) = base.to_scale_rotation_translation();
    let (mut frame, mut rotation, mut position) = (base, base_rotation, base_position);
    buffers.joints.clear();
    for (k, &joint) in named.joints.iter().enumerate() {
        let Ok(local) = joints.transforms.get(joint) else {
            named.joints.clear();
            return Err(None);
        };
        let animated = match named.written.get(k) {
            Some(w) if w.written == local.rotation => w.animated,
            _ => local.rotation,
        };
        frame = frame.mul_transform(Transform {
            rotation: animated,
            ..*local
        });
        let (_, r, p) = frame.to_scale_rotation_translation();
        buffers
            .joints
            .push((rotation.inverse() * (p - position), animated));
        (rotation, position) = (r, p);
    }
    let effector = rotation.inverse() * (frame.transform_point(goal.effector) - position);
    let target = match goal.target {
        IkTarget::Point(p) => Some(p),
        IkTarget::CharacterPoint(p) => character.map(|c| c.transform_point(p)),
        IkTarget::Entity(e) => joints.global(e).map(|t| t.translation()),
    };
    let Some(target) = target.filter(|t| t.is_finite()) else {
        return Err(Some(NamedProblem::Target));
    };
    if !goal.weight.is_finite() {
        return Err(Some(NamedProblem::Weight));
    }
    if !ball.set_pose(
        solved,
        (base_rotation, base_position),
        &buffers.joints,
        effector,
    ) {
        return Err(Some(NamedProblem::Transform));
    }
    // As on a skeleton: from the last solution, towards the new one at most `max_speed`.
    let (settings, swing) = named.tracking.warm_start(ball, solved, &goal.settings);
    let result = solve_with(
        &ball.rig,
        &ball.chain,
        solved,
        target,
        &settings,
        scratch,
        swing,
    );
    named.tracking.follow(ball, solved, goal.max_speed * dt);
    let weight = goal.weight.clamp(0.0, 1.0);
    buffers.rotations.clear();
    for (k, &(_, animated)) in buffers.joints.iter().enumerate() {
        let rotation = match weight > 0.0 {
            true => animated.slerp(ball.rotation(solved, k), weight).normalize(),
            false => animated,
        };
        buffers.rotations.push(rotation);
    }
    if !buffers.rotations.iter().all(|r| r.is_finite()) {
        named.tracking.forget();
        return Err(Some(NamedProblem::Transform));
    }
    if named.written.len() != n {
        named.written = buffers
            .rotations
            .iter()
            .map(|&r| WrittenJoint {
                animated: r,
                written: r,
                previous: (r, weight > 0.0),
                current: (r, weight > 0.0),
            })
            .collect();
    }
    for (k, &joint) in named.joints.iter().enumerate() {
        let (rotation, animated) = (buffers.rotations[k], buffers.joints[k].1);
        if let Ok(mut transform) = joints.transforms.get_mut(joint)
            && transform.rotation != rotation
        {
            transform.rotation = rotation;
        }
        let w = &mut named.written[k];
        w.animated = animated;
        w.written = rotation;
        w.previous = w.current;
        w.current = (rotation, weight > 0.0);
    }
    Ok(result)
}

/// The chain of `goal` below `entity`: the first descendant named `end_bone` and its
/// `length - 1` nearest ancestors (first to end), with the first one's parent.
fn find_chain(
    entity: Entity,
    goal: &IkGoal,
    joints: &Joints,
) -> Result<(Vec<Entity>, Entity), Option<NamedProblem>> {
    let mut descendants = false;
    let mut end = None;
    for d in joints.children.iter_descendants(entity) {
        descendants = true;
        if joints
            .names
            .get(d)
            .is_ok_and(|n| n.as_str() == goal.end_bone)
        {
            end = Some(d);
            break;
        }
    }
    // No descendants at all: the scene has not spawned yet.
    let end = end.ok_or(descendants.then_some(NamedProblem::NoJoint))?;
    let mut chain = vec![end];
    let mut at = end;
    loop {
        let parent = joints.parents.get(at).map(ChildOf::parent).ok();
        match parent {
            Some(p) if chain.len() == goal.length => {
                chain.reverse();
                return Ok((chain, p));
            }
            Some(p) if p != entity => {
                chain.push(p);
                at = p;
            }
            _ => return Err(Some(NamedProblem::TooLong)),
        }
    }
}

/// Between fixed steps, shows every joint IK moves between its last two solved rotations
/// (after Bevy's animation has drawn the scene's joints).
pub(super) fn interpolate_ik_joints(
    mut characters: Query<&mut IkState, Without<Skeleton>>,
    mut transforms: Query<&mut Transform>,
    fixed: Res<Time<Fixed>>,
) {
    let alpha = fixed.overstep_fraction().clamp(0.0, 1.0);
    for mut state in &mut characters {
        for named in &mut state.named {
            for (&joint, w) in named.joints.iter().zip(&mut named.written) {
                if !(w.previous.1 || w.current.1) {
                    continue;
                }
                let rotation = w.previous.0.slerp(w.current.0, alpha);
                if let Ok(mut transform) = transforms.get_mut(joint)
                    && rotation.is_finite()
                {
                    transform.rotation = rotation;
                    w.written = rotation;
                }
            }
        }
    }
}
