//! Posing the skeletons: bone entities, clips, the character's motion, bone transforms and
//! their interpolation between fixed steps.

use bevy::asset::Assets;
use bevy::ecs::query::QueryData;
use bevy::log::{error, warn};
use bevy::math::{Quat, Vec3};
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use crate::collide::components::AnimatedVelocity;
use crate::collide::{FrameStep, FrameTracker};
use crate::schedule::{DrapeSettings, world_pose};
use crate::skeleton::clip::Clip;
use crate::skeleton::rig::{Pose, PoseRate, Rig};

use super::components::*;
use super::proxies::spawn_proxies;

pub(super) fn local_transform(rig: &Rig, bone: usize, pose: &Pose) -> Transform {
    let b = &rig.bones()[bone];
    match b.parent {
        None => {
            Transform::from_translation(pose.root_translation).with_rotation(pose.root_rotation)
        }
        Some(_) => {
            let angle = pose.angles.get(bone).copied().unwrap_or(0.0);
            let angle = b.limits.map_or(angle, |(lo, hi)| angle.clamp(lo, hi));
            Transform::from_translation(b.offset).with_rotation(rig.local_rotation(bone, angle))
        }
    }
}

/// Spawns the bone entities of every new skeleton, in its rest pose.
pub(super) fn spawn_bones(
    mut commands: Commands,
    skeletons: Query<(Entity, &Skeleton, Option<&BoneColliders>), Without<SkeletonBones>>,
) {
    for (entity, skeleton, proxies) in &skeletons {
        let rig = &skeleton.rig;
        let pose = rig.rest_pose();
        let mut entities: Vec<Entity> = Vec::with_capacity(rig.bones().len());
        for (i, bone) in rig.bones().iter().enumerate() {
            let parent = bone.parent.map_or(entity, |p| entities[p]);
            let local = local_transform(rig, i, &pose);
            let id = commands
                .spawn((
                    Name::new(bone.name.clone()),
                    local,
                    BoneEntity {
                        index: i,
                        previous: local,
                        current: local,
                    },
                    AnimatedVelocity::default(),
                    ChildOf(parent),
                ))
                .id();
            entities.push(id);
        }
        if let Some(proxies) = proxies {
            spawn_proxies(&mut commands, entity, proxies, |name| {
                rig.find(name).map(|i| entities[i])
            });
        }
        let mut bones = Vec::new();
        rig.forward(&pose, None, &mut bones);
        commands.entity(entity).insert((
            SkeletonBones {
                entities,
                rig: rig.clone(),
            },
            SkeletonPose {
                rate: PoseRate {
                    root_velocity: Vec3::ZERO,
                    root_angular_velocity: Vec3::ZERO,
                    angle_rates: vec![0.0; rig.bones().len()],
                },
                pose,
                bones,
                frame: FrameStep::at_rest(crate::collide::RigidPose::IDENTITY),
                tracker: FrameTracker::default(),
                global: None,
                warned_transform: false,
                bound: None,
            },
        ));
    }
}

/// Reads every character's world transform at this fixed step (its whole chain, whatever
/// moved it) and its motion since the last step; the rest of the step uses this one.
pub(super) fn track_skeletons(
    mut skeletons: Query<(Entity, &mut SkeletonPose)>,
    transforms: TransformHelper,
    time: Res<Time>,
    drape: Option<Res<DrapeSettings>>,
) {
    let dt = time.delta_secs();
    let teleport = drape.map_or(Some(Default::default()), |d| d.teleport);
    for (entity, mut state) in &mut skeletons {
        let state = &mut *state;
        let global = transforms.compute_global_transform(entity).ok();
        match global.and_then(|g| Some((g, world_pose(&g)?))) {
            Some((global, pose)) => {
                state.frame = state.tracker.step(pose, dt, teleport.as_ref());
                state.global = Some(global);
                state.warned_transform = false;
            }
            None => {
                if !state.warned_transform {
                    warn!("skeleton {entity} has no valid transform: its bones are not posed");
                    state.warned_transform = true;
                }
                state.tracker.lose_sight();
                state.global = None;
            }
        }
    }
}

/// A character playing a clip.
#[derive(QueryData)]
#[query_data(mutable)]
pub(super) struct Player {
    entity: Entity,
    skeleton: &'static Skeleton,
    player: &'static mut ClipPlayer,
    pose: &'static mut SkeletonPose,
}

/// Advances every clip player and samples its clip into the skeleton's pose and rate.
pub(super) fn play_clips(
    mut players: Query<Player>,
    clips: Res<Assets<ClipAsset>>,
    time: Res<Time>,
) {
    let dt = time.delta_secs();
    for item in &mut players {
        let (entity, skeleton, mut player, mut state) =
            (item.entity, item.skeleton, item.player, item.pose);
        let state = &mut *state;
        let Some(asset) = clips.get(&player.clip) else {
            continue;
        };
        let id = player.clip.id();
        if state.bound.as_ref().is_none_or(|(bound, _)| *bound != id) {
            let bound = Clip::new(&asset.0, &skeleton.rig);
            if let Err(err) = &bound {
                error!("skeleton {entity} cannot play its clip: {err}");
            }
            state.bound = Some((id, bound));
        }
        let Some((_, Ok(clip))) = &state.bound else {
            continue;
        };
        if player.speed.is_finite() && dt.is_finite() {
            player.time += dt * player.speed;
            if clip.looping() && clip.duration() > 0.0 {
                player.time = player.time.rem_euclid(clip.duration());
            }
        }
        clip.sample(player.time, &mut state.pose, &mut state.rate);
        for r in &mut state.rate.angle_rates {
            *r *= player.speed;
        }
        state.rate.root_velocity *= player.speed;
        state.rate.root_angular_velocity *= player.speed;
    }
}

/// Runs forward kinematics on every skeleton's pose, writes its bone transforms and publishes
/// the bones' world velocities: the character entity's own motion (its transform chain at
/// this fixed step against the last) plus the joints' motion turned into the world.
pub(super) fn pose_bones(
    mut skeletons: Query<(&Skeleton, &SkeletonBones, &mut SkeletonPose)>,
    mut bones: Query<(&mut Transform, &mut BoneEntity, &mut AnimatedVelocity)>,
) {
    for (skeleton, skeleton_bones, mut state) in &mut skeletons {
        let state = &mut *state;
        skeleton
            .rig
            .forward(&state.pose, Some(&state.rate), &mut state.bones);
        let Some(global) = state.global else {
            continue;
        };
        let frame = state.frame;
        let (scale, rotation, _) = global.to_scale_rotation_translation();
        let rotation: Quat = rotation.normalize();
        for (i, &bone_entity) in skeleton_bones.entities().iter().enumerate() {
            let Ok((mut transform, mut bone, mut velocity)) = bones.get_mut(bone_entity) else {
                continue;
            };
            let local = local_transform(&skeleton.rig, i, &state.pose);
            if !(local.translation.is_finite() && local.rotation.is_finite()) {
                continue;
            }
            bone.previous = bone.current;
            bone.current = local;
            *transform = local;
            let b = state.bones[i];
            let at = global.transform_point(b.translation);
            velocity.linear =
                Vec3::from(frame.velocity_at(at.into())) + rotation * (scale * b.linear_velocity);
            velocity.angular = Vec3::from(frame.angular_velocity) + rotation * b.angular_velocity;
        }
    }
}

/// Between fixed steps, shows every bone between its last two poses.
pub(super) fn interpolate_bones(
    mut bones: Query<(&mut Transform, &BoneEntity)>,
    fixed: Res<Time<Fixed>>,
) {
    let alpha = fixed.overstep_fraction().clamp(0.0, 1.0);
    for (mut transform, bone) in &mut bones {
        transform.translation = bone
            .previous
            .translation
            .lerp(bone.current.translation, alpha);
        transform.rotation = bone.previous.rotation.slerp(bone.current.rotation, alpha);
    }
}
