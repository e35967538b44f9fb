//! Where and in which order `bevy_drape`'s systems run.
//!
//! All simulation runs in one fixed-timestep schedule (by default [`FixedPostUpdate`]; pick
//! another with [`DrapePlugins::new`](crate::DrapePlugins::new)), in the chained sets
//! [`DrapeSystems::Prepare`] -> [`DrapeSystems::Animate`] ->
//! [`DrapeSystems::InverseKinematics`] -> [`DrapeSystems::Colliders`] ->
//! [`DrapeSystems::Step`]. Writing the cloth into its mesh happens once per rendered frame in
//! [`DrapeSystems::Writeback`], in [`PostUpdate`] after transform propagation, interpolated
//! between the last two fixed states.

use bevy::app::{App, Plugin, PostUpdate};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::{IntoScheduleConfigs, ScheduleLabel, SystemSet};
use bevy::prelude::FixedPostUpdate;
use bevy::transform::TransformSystems;

/// The system sets of `bevy_drape`, in the order they run.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DrapeSystems {
    /// New cloths are built from their meshes; settings are read.
    Prepare,
    /// Keyframed animation poses the skeletons.
    Animate,
    /// Inverse kinematics adjusts the poses.
    InverseKinematics,
    /// Collider poses and velocities are gathered for this step.
    Colliders,
    /// Cloths are stepped.
    Step,
    /// Cloth positions and normals are written into their meshes (in [`PostUpdate`], once
    /// per rendered frame).
    Writeback,
}

/// The schedule `bevy_drape` simulates in, as a resource.
#[derive(bevy::prelude::Resource, Debug, Clone, Copy)]
pub struct DrapeSchedule(pub Interned<dyn ScheduleLabel>);

/// Configures [`DrapeSystems`] in the simulation schedule and in [`PostUpdate`].
pub struct DrapeSchedulePlugin {
    /// The simulation schedule.
    pub schedule: Interned<dyn ScheduleLabel>,
}

impl DrapeSchedulePlugin {
    /// Simulates in `schedule`, which should be a fixed-timestep schedule.
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        Self {
            schedule: schedule.intern(),
        }
    }
}

impl Default for DrapeSchedulePlugin {
    fn default() -> Self {
        Self::new(FixedPostUpdate)
    }
}

impl Plugin for DrapeSchedulePlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(DrapeSchedule(self.schedule))
            .configure_sets(
                self.schedule,
                (
                    DrapeSystems::Prepare,
                    DrapeSystems::Animate,
                    DrapeSystems::InverseKinematics,
                    DrapeSystems::Colliders,
                    DrapeSystems::Step,
                )
                    .chain(),
            )
            .configure_sets(
                PostUpdate,
                DrapeSystems::Writeback.after(TransformSystems::Propagate),
            );
    }
}
