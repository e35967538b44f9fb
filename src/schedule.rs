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
use bevy::prelude::{ResMut, Resource};
use bevy::transform::TransformSystems;
use std::time::{Duration, Instant};

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

/// Wall time of the stages of the last fixed step, measured between the [`DrapeSystems`]
/// sets: keyframed animation, inverse kinematics, collider gathering, cloth stepping (the
/// cloth's own build in [`DrapeSystems::Prepare`] is not counted).
#[derive(Resource, Debug, Clone, Default, PartialEq)]
pub struct DrapeTimings {
    /// [`DrapeSystems::Animate`].
    pub animation: Duration,
    /// [`DrapeSystems::InverseKinematics`].
    pub inverse_kinematics: Duration,
    /// [`DrapeSystems::Colliders`].
    pub colliders: Duration,
    /// [`DrapeSystems::Step`].
    pub cloth: Duration,
    /// Fixed steps measured so far.
    pub steps: u64,
    marks: [Option<Instant>; 4],
}

impl DrapeTimings {
    /// The whole fixed step: the sum of the stages.
    pub fn total(&self) -> Duration {
        self.animation + self.inverse_kinematics + self.colliders + self.cloth
    }

    fn mark(&mut self, stage: usize) {
        let now = Instant::now();
        if stage < self.marks.len() {
            self.marks[stage] = Some(now);
        }
        if stage == 0 {
            return;
        }
        let since = |mark: Option<Instant>| mark.map_or(Duration::ZERO, |m| now - m);
        match stage {
            1 => self.animation = since(self.marks[0]),
            2 => self.inverse_kinematics = since(self.marks[1]),
            3 => self.colliders = since(self.marks[2]),
            _ => {
                self.cloth = since(self.marks[3]);
                self.steps += 1;
            }
        }
    }
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
            .init_resource::<DrapeTimings>()
            .init_resource::<crate::cloth::plugin::DrapeSettings>();
        let sets = [
            DrapeSystems::Prepare,
            DrapeSystems::Animate,
            DrapeSystems::InverseKinematics,
            DrapeSystems::Colliders,
            DrapeSystems::Step,
        ];
        for stage in 0..4 {
            app.add_systems(
                self.schedule,
                (move |mut timings: ResMut<DrapeTimings>| timings.mark(stage))
                    .after(sets[stage])
                    .before(sets[stage + 1]),
            );
        }
        app.add_systems(
            self.schedule,
            (|mut timings: ResMut<DrapeTimings>| timings.mark(4)).after(DrapeSystems::Step),
        )
        .configure_sets(
            PostUpdate,
            DrapeSystems::Writeback.after(TransformSystems::Propagate),
        );
    }
}
