//! Where and in which order `bevy_drape`'s systems run.
//!
//! All simulation runs in one fixed-timestep schedule (by default [`FixedPostUpdate`]; pick
//! another with [`DrapePlugins::new`](crate::DrapePlugins::new)), in the chained sets
//! [`DrapeSystems::Prepare`] -> [`DrapeSystems::Animate`] ->
//! [`DrapeSystems::InverseKinematics`] -> [`DrapeSystems::Colliders`] ->
//! [`DrapeSystems::Step`]. Writing the cloth into its mesh happens once per rendered frame in
//! [`DrapeSystems::Writeback`], in [`PostUpdate`] after transform propagation, interpolated
//! between the last two fixed states.

use std::time::{Duration, Instant};

use bevy::app::{App, Plugin, PostUpdate};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::{IntoScheduleConfigs, ScheduleLabel, SystemSet};
use bevy::prelude::FixedPostUpdate;
use bevy::prelude::{Component, Entity, GlobalTransform, Vec3};
use bevy::prelude::{ReflectResource, ResMut, Resource};
use bevy::reflect::Reflect;
use bevy::transform::TransformSystems;

use crate::cloth::sim::StepTimings;
use crate::cloth::{ClothSolver, SolverSettings, WindField};
use crate::collide::{RigidPose, SolverCollider, Teleport};
use crate::error::ClothError;

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
    /// several threads, [`DrapeSettings::max_threads`](DrapeSettings),
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
/// adds its fixed-step systems to (set by [`DrapeSchedulePlugin`]).
#[derive(bevy::prelude::Resource, Debug, Clone, Copy)]
pub(crate) struct DrapeSchedule(pub(crate) Interned<dyn ScheduleLabel>);

impl DrapeSchedule {
    /// The drape schedule of `app`, for a drape plugin adding its systems: the one of the
    /// [`DrapeSchedulePlugin`] added before, or [`FixedPostUpdate`] with the plugin added now
    /// (so any subset of the drape plugins runs in the same ordered sets). To simulate in
    /// another schedule, add `DrapeSchedulePlugin::new(schedule)` (or
    /// [`DrapePlugins::new`](crate::DrapePlugins::new)) before the other drape plugins; added
    /// after them, Bevy refuses it as added twice.
    pub(crate) fn of(app: &mut App) -> Interned<dyn ScheduleLabel> {
        if !app.is_plugin_added::<DrapeSchedulePlugin>() {
            app.add_plugins(DrapeSchedulePlugin::default());
        }
        app.world().resource::<DrapeSchedule>().0
    }
}

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
            .register_type::<(DrapeTimings, DrapeSettings)>()
            .init_resource::<DrapeTimings>()
            .init_resource::<DrapeSettings>();
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

/// World-wide simulation parameters.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct DrapeSettings {
    /// Gravity, m/s^2. Default: `(0, -9.81, 0)`.
    pub gravity: Vec3,
    /// When true, no cloth is stepped. Default: `false`.
    pub paused: bool,
    /// When a character, a collider or a followed entity moves so far in one fixed step that
    /// it counts as a jump (a teleport, a respawn) rather than motion: colliders are then not
    /// swept through the space between, and cloths following it ([`Cloth::follow`](crate::cloth::plugin::Cloth::follow)) are
    /// carried along rigidly. `None` takes every pose change as motion. Default:
    /// [`Teleport::default`] (1 m or 60 degrees in one step).
    pub teleport: Option<Teleport>,
    /// The most threads that step cloths at once. `1` steps them one after another on the
    /// schedule's thread; more step independent cloths at the same time on Bevy's
    /// [`ComputeTaskPool`](bevy::tasks::ComputeTaskPool) (its threads and the caller's), each
    /// of them stepped as on one thread, so that several cloths give the same result
    /// whatever the count. A single cloth is instead split over two threads
    /// ([`ClothSolver::step_with`](crate::cloth::ClothSolver::step_with): at least 2048
    /// particles, numbered so that the middle index cuts it along a short seam): its result
    /// then differs from one thread's by the order of its sweeps, and is the same on every
    /// run. `None` uses every thread of the pool. Default: `None`.
    pub max_threads: Option<std::num::NonZeroUsize>,
}
impl Default for DrapeSettings {
    fn default() -> Self {
        Self {
            gravity: Vec3::new(0.0, -9.81, 0.0),
            paused: false,
            teleport: Some(Teleport::default()),
            max_threads: None,
        }
    }
}

/// Every valid collider at the current fixed step, as the cloths see them.
#[derive(Resource, Clone, Debug, Default)]
pub struct StepColliders {
    /// The colliders.
    pub colliders: Vec<SolverCollider>,
    /// Their entities, in the same order.
    pub entities: Vec<Entity>,
}
/// The rigid pose (translation and rotation, scale left out) of a global transform, if it is
/// finite.
pub(crate) fn world_pose(global: &GlobalTransform) -> Option<RigidPose> {
    let (scale, rotation, translation) = global.to_scale_rotation_translation();
    (scale.is_finite() && rotation.is_finite() && translation.is_finite()).then(|| RigidPose {
        translation: translation.into(),
        rotation: rotation.normalize(),
    })
}

/// The wind of the current fixed step, for the cloths.
#[derive(Resource, Clone, Debug, Default)]
pub struct StepWind(pub WindField);

/// A component stepped inside the substeps of the cloth on its entity (the fluid plugin's
/// `FluidSimulation`): the cloth plugin calls it instead of stepping the cloth alone.
pub trait ClothCoupling: Component<Mutability = bevy::ecs::component::Mutable> {
    /// Steps `cloth` by `dt` with this coupled in, kept out of `colliders`.
    fn step_with_cloth(
        &mut self,
        entity: Entity,
        cloth: &mut ClothSolver,
        settings: &SolverSettings,
        colliders: &[SolverCollider],
        gravity: Vec3,
        dt: f32,
    ) -> Result<(), ClothError>;
}
/// No coupling: the cloth plugin's own instance of its step (never on an entity).
#[derive(Component)]
pub struct NoCoupling(std::convert::Infallible);
impl ClothCoupling for NoCoupling {
    fn step_with_cloth(
        &mut self,
        _: Entity,
        _: &mut ClothSolver,
        _: &SolverSettings,
        _: &[SolverCollider],
        _: Vec3,
        _: f32,
    ) -> Result<(), ClothError> {
        match self.0 {}
    }
}
/// Present once a `ClothCouplingPlugin` steps the cloths (the plain step then stands down).
#[derive(Resource, Default)]
pub(crate) struct ClothCouplingInstalled;
/// On every cloth's entity (required by `Cloth`), for plugins that must not name `Cloth`.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct IsCloth;
