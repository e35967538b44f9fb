//! Cloth for the [Bevy](https://bevyengine.org) 0.19 game engine that drapes over keyframed,
//! hinge-jointed characters: XPBD cloth (with mass-spring and hybrid solvers beside it) on
//! capsule and sphere proxies of a character's bones, self-collision, wind, water, stepped in
//! Bevy's fixed timestep and drawn interpolated between fixed steps.
//!
//! # Quick start
//!
//! Add [`DrapePlugins`] and give any entity with a triangle-list [`Mesh3d`](bevy::mesh::Mesh3d)
//! a [`Cloth`](prelude::Cloth). Colliders are entities with a
//! [`ClothCollider`](prelude::ClothCollider).
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_drape::prelude::*;
//!
//! fn main() {
//!     App::new()
//!         .add_plugins((DefaultPlugins, DrapePlugins::default()))
//!         .add_systems(Startup, spawn_cloth)
//!         .run();
//! }
//!
//! fn spawn_cloth(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>) {
//!     // A 1 m square of 32 x 32 vertices, pinned at two corners, 1.5 m up, over a ground.
//!     let grid = GridDesc::square(1.0, 32, Vec3::ZERO);
//!     commands.spawn((
//!         Mesh3d(meshes.add(grid_mesh(&grid))),
//!         Cloth::pinned([grid.index(0, 0), grid.index(31, 0)]),
//!         Transform::from_xyz(0.0, 1.5, 0.0),
//!     ));
//!     commands.spawn((ClothCollider::plane(), Transform::default()));
//! }
//! ```
//!
//! # Headless: tests and servers
//!
//! The crate needs no renderer and no window: [`MinimalPlugins`](bevy::MinimalPlugins) with
//! [`TransformPlugin`](bevy::transform::TransformPlugin),
//! [`AssetPlugin`](bevy::asset::AssetPlugin) and [`MeshPlugin`](bevy::mesh::MeshPlugin) are
//! all it asks for. Give time a fixed advance per update so a test is repeatable (the first
//! update has a zero delta):
//!
//! ```
//! use std::time::Duration;
//!
//! use bevy::asset::AssetPlugin;
//! use bevy::mesh::MeshPlugin;
//! use bevy::prelude::*;
//! use bevy::time::TimeUpdateStrategy;
//! use bevy::transform::TransformPlugin;
//! use bevy_drape::prelude::*;
//!
//! let mut app = App::new();
//! app.add_plugins((
//!     MinimalPlugins,
//!     TransformPlugin,
//!     AssetPlugin::default(),
//!     MeshPlugin,
//!     DrapePlugins::default(),
//! ))
//! .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / 64.0)));
//!
//! let grid = GridDesc::square(1.0, 12, Vec3::ZERO);
//! let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(grid_mesh(&grid));
//! let sheet = app
//!     .world_mut()
//!     .spawn((Mesh3d(mesh), Cloth::default(), Transform::from_xyz(0.0, 1.0, 0.0)))
//!     .id();
//! app.world_mut().spawn((ClothCollider::plane(), Transform::default()));
//!
//! // Two seconds at 64 Hz: the sheet falls and lies on the ground.
//! for _ in 0..129 {
//!     app.update();
//! }
//! let simulation = app.world().get::<ClothSimulation>(sheet).expect("the cloth was built");
//! let state = simulation.solver().state();
//! assert!(state.positions.iter().all(|p| p.is_finite()));
//! assert!(state.positions.iter().all(|p| p.y > -0.01 && p.y < 0.05));
//! ```
//!
//! # A character wearing a cloth
//!
//! A [`Skeleton`](prelude::Skeleton) is a rig of hinge-jointed bones posed by a clip
//! ([`ClipPlayer`](prelude::ClipPlayer)) and inverse kinematics
//! ([`InverseKinematics`](prelude::InverseKinematics)); [`BoneColliders`](prelude::BoneColliders)
//! puts capsules and spheres on its bones, by name, and works as well on the joints of a glTF
//! character animated by Bevy's `AnimationPlayer` (feature `animation`). A cloth worn by a
//! character ([`Cloth::worn_by`](prelude::Cloth::worn_by)) is carried along when it teleports
//! and drawn in its frame between fixed steps. `examples/poncho.rs` (the main scene) and
//! `examples/gltf_character.rs` show both kinds of character.
//!
//! ```
//! # use std::sync::Arc;
//! # use bevy::prelude::*;
//! # use bevy_drape::prelude::*;
//! fn spawn(mut commands: Commands, assets: Res<AssetServer>) {
//!     let character = commands
//!         .spawn((
//!             Skeleton { rig: Arc::new(humanoid()) },
//!             BoneColliders::humanoid(), // capsules on the limbs and torso, a sphere on the head
//!             ClipPlayer::new(assets.load("clips/walk.clip.ron")),
//!             Transform::default(),
//!         ))
//!         .id();
//!     commands.spawn((
//!         // Drawn with the fine mesh, simulated on the coarse one (OBJ files need
//!         // `bevy_drape::bevy_obj::ObjPlugin`).
//!         Mesh3d(assets.load("meshes/poncho.obj")),
//!         ClothSimulationMesh(assets.load("meshes/poncho_coarse.obj")),
//!         Cloth::worn_by(character),
//!         ClothSettings { density: 0.25, ..default() },
//!         Transform::from_xyz(0.0, 1.5, 0.0),
//!     ));
//! }
//! # bevy::ecs::system::assert_is_system(spawn);
//! ```
//!
//! # The parts
//!
//! | what | where |
//! |---|---|
//! | the plugins, and the schedule they run in | [`DrapePlugins`], [`schedule`] |
//! | a cloth and its settings | [`Cloth`](prelude::Cloth), [`ClothSettings`](prelude::ClothSettings), [`SolverSettings`](prelude::SolverSettings), [`ClothSimulation`](prelude::ClothSimulation) |
//! | settings every cloth shares (pause, teleport distance, threads) | [`DrapeSettings`](prelude::DrapeSettings) |
//! | colliders | [`ClothCollider`](prelude::ClothCollider), [`ColliderShape`](prelude::ColliderShape), with Avian: `collide::avian` (feature `avian`) |
//! | characters | [`Skeleton`](prelude::Skeleton), [`ClipPlayer`](prelude::ClipPlayer), [`BoneColliders`](prelude::BoneColliders), [`InverseKinematics`](prelude::InverseKinematics) |
//! | air | [`Wind`](prelude::Wind), [`WindSource`](prelude::WindSource), [`AirSettings`](prelude::AirSettings) |
//! | water in a cloth | [`Fluid`](prelude::Fluid) |
//! | settings and rigs as RON files, hot reloaded | [`files`] |
//! | picking, dragging, the egui panel, debug colours | [`interact`] (features `render`, `egui`) |
//! | the solvers without an App (plain data, no ECS) | [`cloth`], [`collide`], [`skeleton`], [`fluid`] |
//!
//! The crate's features: `render` (Bevy's renderer and window, for the examples), `egui` (the
//! settings panel), `avian` (Avian colliders are cloth colliders), `animation` (Bevy's
//! `AnimationPlayer` stepped with the cloth, for glTF characters). With none of them the
//! crate builds against a minimal Bevy.
//!
//! The repository's `README.md` lists the examples; its `docs/` folder holds the measurements
//! (every figure with the command that makes it), the methods and the architecture.

// The README's code compiles with the crate's tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

pub mod cloth;
/// OBJ files as [`bevy::mesh::Mesh`] assets: add [`bevy_obj::ObjPlugin`] to an App to load
/// `.obj` files with the asset server (cloth and collider meshes alike), or call
/// [`bevy_obj::mesh::load_obj_as_mesh`] on the bytes of one.
pub use bevy_obj;
pub mod collide;
pub mod error;
pub mod files;
pub mod fluid;
pub mod interact;
pub mod mesh;
// The crate's tests' and harness's random generator, not part of the API.
#[cfg(any(test, feature = "internals"))]
#[doc(hidden)]
pub mod rng;
pub mod schedule;
pub mod skeleton;
pub(crate) mod weld;

use bevy::app::{PluginGroup, PluginGroupBuilder};
use bevy::ecs::intern::Interned;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::FixedPostUpdate;

use cloth::plugin::ClothPlugin;
use cloth::wind_plugin::WindPlugin;
use collide::plugin::ColliderPlugin;
use fluid::plugin::FluidPlugin;
use schedule::DrapeSchedulePlugin;
use skeleton::plugin::SkeletonPlugin;

/// The names a game writes: the plugins, a cloth and its settings, colliders, characters,
/// inverse kinematics, wind and water. Everything else by its module path: the solvers and
/// their settings in [`cloth`], [`collide`], [`skeleton`] and [`fluid`]; the sub-plugins in
/// each module's `plugin`; errors in [`error`]; settings files in [`files`].
pub mod prelude {
    pub use crate::DrapePlugins;
    pub use crate::cloth::mesh::grid_mesh;
    pub use crate::cloth::plugin::{
        Cloth, ClothLayers, ClothSettings, ClothSimulation, VertexAttachment,
    };
    pub use crate::cloth::render_mesh::ClothSimulationMesh;
    pub use crate::cloth::wind_plugin::{Wind, WindSource};
    pub use crate::cloth::{AirSettings, GridDesc, Gusts, SelfCollisionMethod, SolverSettings};
    pub use crate::collide::ContactMaterial;
    pub use crate::collide::plugin::{ClothCollider, ColliderShape, KinematicVelocity};
    pub use crate::fluid::plugin::{Fluid, FluidSource};
    pub use crate::schedule::{DrapeSettings, DrapeSystems};
    #[cfg(feature = "animation")]
    pub use crate::skeleton::fixed_step_animation::FixedStepAnimation;
    pub use crate::skeleton::humanoid::humanoid;
    pub use crate::skeleton::ik::IkSettings;
    pub use crate::skeleton::plugin::{
        BoneColliders, ClipPlayer, IkGoal, IkTarget, InverseKinematics, Skeleton,
    };
}

/// All of `bevy_drape`'s plugins, simulating in [`FixedPostUpdate`] by default.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_drape::prelude::*;
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, bevy::transform::TransformPlugin))
///     .add_plugins((bevy::asset::AssetPlugin::default(), bevy::mesh::MeshPlugin))
///     // The cloth stepped in `FixedUpdate` with the game's own physics, at 60 Hz.
///     .add_plugins(DrapePlugins::new(FixedUpdate))
///     .insert_resource(Time::<Fixed>::from_hz(60.0));
/// app.update();
/// assert!(app.world().contains_resource::<DrapeSettings>());
/// ```
///
/// | plugin | what it does |
/// |---|---|
/// | [`DrapeSchedulePlugin`] | orders the [`schedule::DrapeSystems`] sets |
/// | [`SkeletonPlugin`] | loads clips, spawns bone entities, plays clips on [`skeleton::plugin::Skeleton`]s |
/// | [`ColliderPlugin`] | moves kinematic colliders and hands every [`collide::plugin::ClothCollider`] to the cloths |
/// | [`WindPlugin`] | gathers the [`cloth::wind_plugin::Wind`] and every [`cloth::wind_plugin::WindSource`] for the cloths' air |
/// | [`ClothPlugin`] | builds, steps and draws every [`cloth::plugin::Cloth`] |
/// | `collide::avian::AvianColliderPlugin` | with the `avian` feature: every Avian `Collider` is a cloth collider |
/// | `skeleton::fixed_step_animation::FixedStepAnimationPlugin` | with the `animation` feature: Bevy's animation players under a `FixedStepAnimation` root stepped with the cloth |
pub struct DrapePlugins {
    schedule: Interned<dyn ScheduleLabel>,
}

impl DrapePlugins {
    /// Simulates in `schedule` (a fixed-timestep schedule such as `FixedUpdate`).
    pub fn new(schedule: impl ScheduleLabel) -> Self {
        Self {
            schedule: schedule.intern(),
        }
    }
}

impl Default for DrapePlugins {
    fn default() -> Self {
        Self::new(FixedPostUpdate)
    }
}

impl PluginGroup for DrapePlugins {
    fn build(self) -> PluginGroupBuilder {
        let group = PluginGroupBuilder::start::<Self>()
            .add(DrapeSchedulePlugin {
                schedule: self.schedule,
            })
            .add(SkeletonPlugin)
            .add(ColliderPlugin)
            .add(WindPlugin)
            .add(ClothPlugin)
            .add(FluidPlugin)
            .add(cloth::plugin::ClothCouplingPlugin::<
                fluid::plugin::FluidSimulation,
            >::default());
        #[cfg(feature = "avian")]
        let group = group.add(collide::avian::AvianColliderPlugin);
        #[cfg(feature = "animation")]
        let group = group.add(skeleton::fixed_step_animation::FixedStepAnimationPlugin);
        group
    }
}
