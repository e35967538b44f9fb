//! Where and in which order `bevy_drape`'s systems run.
//!
//! All simulation runs in one fixed-timestep schedule (by default [`FixedPostUpdate`]; pick
//! another with [`DrapePlugins::new`](crate::DrapePlugins::new)), in the chained sets
//! [`DrapeSystems::Prepare`] -> [`DrapeSystems::Animate`] ->
//! [`DrapeSystems::InverseKinematics`] -> [`DrapeSystems::Colliders`] ->
//! [`DrapeSystems::Step`]. Writing the cloth into its mesh happens once per rendered frame in
//! [`DrapeSystems::Writeback`], in [`PostUpdate`] after transform propagation, interpolated
//! between the last two fixed states.

use crate::cloth::sim::StepTimings;
use bevy::app::{App, Plugin, PostUpdate};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::{IntoScheduleConfigs, ScheduleLabel, SystemSet};
use bevy::prelude::FixedPostUpdate;
use bevy::prelude::{ReflectResource, ResMut, Resource};
use bevy::reflect::Reflect;
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
#[derive(Resource, Debug, Clone, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct DrapeTimings {
    /// [`DrapeSystems::Animate`].
    pub animation: Duration,
    /// [`DrapeSystems::InverseKinematics`].
    pub inverse_kinematics: Duration,
    /// [`DrapeSystems::Colliders`].
    pub colliders: Duration,
    /// [`DrapeSystems::Step`].
    pub cloth: Duration,
    /// The parts of the cloth stage, summed over the cloths (CPU time: with cloths stepped on
    /// several threads, [`DrapeSettings::max_threads`](crate::cloth::plugin::DrapeSettings),
    /// the sum can exceed [`DrapeTimings::cloth`]).
    pub cloth_parts: StepTimings,
    /// Writing the cloths into their meshes ([`DrapeSystems::Writeback`]), in the last
    /// rendered frame.
    pub write_back: Duration,
    /// Fixed steps measured so far.
    pub steps: u64,
    /// When the set before the stage being timed ended.
    #[reflect(ignore)]
    stage_start: Option<Instant>,
}

impl DrapeTimings {
    /// The whole fixed step: the sum of the stages.
    pub fn total(&self) -> Duration {
        self.animation + self.inverse_kinematics + self.colliders + self.cloth
    }

    /// The set `ended` has just finished: its stage's time is the time since the set before
    /// it ended.
    fn set_ended(&mut self, ended: DrapeSystems) {
        let now = Instant::now();
        let elapsed = self.stage_start.map_or(Duration::ZERO, |start| now - start);
        match ended {
            DrapeSystems::Prepare | DrapeSystems::Writeback => {}
            DrapeSystems::Animate => self.animation = elapsed,
            DrapeSystems::InverseKinematics => self.inverse_kinematics = elapsed,
            DrapeSystems::Colliders => self.colliders = elapsed,
            DrapeSystems::Step => {
                self.cloth = elapsed;
                self.steps += 1;
            }
        }
        self.stage_start = Some(now);
    }
}

/// The schedule `bevy_drape` simulates in, as a resource: the one label every drape plugin
/// adds its fixed-step systems to (set by [`DrapeSchedulePlugin`], [`FixedPostUpdate`] if it
/// is absent).
#[derive(bevy::prelude::Resource, Debug, Clone, Copy)]
pub(crate) struct DrapeSchedule(pub(crate) Interned<dyn ScheduleLabel>);

impl DrapeSchedule {
    /// The drape schedule of `app`.
    pub(crate) fn of(app: &App) -> Interned<dyn ScheduleLabel> {
        app.world()
            .get_resource::<DrapeSchedule>()
            .map_or_else(|| FixedPostUpdate.intern(), |s| s.0)
    }
}

/// Configures [`DrapeSystems`] in the simulation schedule and in [`PostUpdate`].
pub struct DrapeSchedulePlugin {
    /// The simulation schedule.
    pub schedule: Interned<dyn ScheduleLabel>,
}

impl DrapeSchedulePlugin {
    /// Simulates in `schedule`, which should be a fixed-timestep schedule.
    pub(crate) fn new(schedule: impl ScheduleLabel) -> Self {
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
            .register_type::<(DrapeTimings, crate::cloth::plugin::DrapeSettings)>()
            .init_resource::<DrapeTimings>()
            .init_resource::<crate::cloth::plugin::DrapeSettings>();
        // A mark after each set times the stage that set ran.
        let sets = [
            DrapeSystems::Prepare,
            DrapeSystems::Animate,
            DrapeSystems::InverseKinematics,
            DrapeSystems::Colliders,
            DrapeSystems::Step,
        ];
        for (k, set) in sets.into_iter().enumerate() {
            let mark = move |mut timings: ResMut<DrapeTimings>| timings.set_ended(set);
            match sets.get(k + 1) {
                Some(&next) => app.add_systems(self.schedule, mark.after(set).before(next)),
                None => app.add_systems(self.schedule, mark.after(set)),
            };
        }
        app.configure_sets(
            PostUpdate,
            DrapeSystems::Writeback.after(TransformSystems::Propagate),
        );
    }
}
