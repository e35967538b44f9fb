//! The Bevy side of skeletons: clip assets (`*.clip.ron`), the [`Skeleton`] and
//! [`ClipPlayer`] components, bone entities, and the thin systems that sample clips in the
//! fixed schedule, write bone transforms and publish bone velocities for colliders.

mod components;
mod ik;
mod pose;
mod proxies;

pub use components::*;
use ik::{interpolate_ik_joints, solve_ik, solve_ik_by_name};
use pose::{interpolate_bones, play_clips, pose_bones, spawn_bones, track_skeletons};
use proxies::{attach_proxies_by_name, detach_from_lost_joints, respawn_changed_proxies};

use bevy::app::{AnimationSystems, App, Plugin, PostUpdate, PreUpdate};
use bevy::asset::AssetApp;
use bevy::prelude::*;
use bevy::transform::TransformSystems;

use crate::schedule::{DrapeSchedule, DrapeSystems};

/// Spawns bone entities (in `PreUpdate`), samples clips in [`DrapeSystems::Animate`], solves
/// IK and poses the bones in [`DrapeSystems::InverseKinematics`] (IK on the named joints of
/// characters without a [`Skeleton`] too), and interpolates bone and IK joint transforms for
/// rendering.
#[derive(Default)]
pub struct SkeletonPlugin;

impl Plugin for SkeletonPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        // A colliders file is applied first, then proxies are spawned (again) from it, or
        // again on a scene spawned anew.
        crate::files::add_file_type::<BoneColliders, _>(
            app,
            PreUpdate,
            (
                detach_from_lost_joints,
                respawn_changed_proxies,
                attach_proxies_by_name,
                spawn_bones,
            )
                .chain(),
        );
        app.register_type::<(BoneColliders, BoneProxyOf, ClipPlayer, InverseKinematics)>()
            .init_asset::<ClipAsset>()
            .init_asset_loader::<ClipLoader>()
            .add_systems(
                schedule,
                (track_skeletons, play_clips)
                    .chain()
                    .in_set(DrapeSystems::Animate),
            )
            .add_systems(
                schedule,
                ((solve_ik, pose_bones).chain(), solve_ik_by_name)
                    .in_set(DrapeSystems::InverseKinematics),
            )
            .add_systems(
                PostUpdate,
                (
                    interpolate_bones,
                    // On top of what Bevy's animation drew.
                    interpolate_ik_joints.after(AnimationSystems),
                )
                    .before(TransformSystems::Propagate),
            );
    }
}
