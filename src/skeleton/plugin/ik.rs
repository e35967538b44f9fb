//! Inverse kinematics on the skeletons' hinge chains ([`InverseKinematics`]).

use bevy::ecs::query::QueryData;

use bevy::log::warn;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use crate::skeleton::ik::{IkChain, IkTracking, solve};

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
