#![doc = include_str!("../README.md")]

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
pub mod schedule;
pub mod skeleton;

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

/// Everything most users import.
pub mod prelude {
    pub use crate::DrapePlugins;
    pub use crate::cloth::mesh::grid_mesh;
    pub use crate::cloth::plugin::{
        Cloth, ClothBuildError, ClothDebugColors, ClothDiverged, ClothPlugin, ClothSettings,
        ClothSimulation, DefaultClothSettings, DrapeSettings, OnDivergence, VertexAttachment,
    };
    pub use crate::cloth::render_mesh::ClothSimulationMesh;
    pub use crate::cloth::wind_plugin::{Wind, WindPlugin, WindSource};
    pub use crate::cloth::{
        AirSettings, ClothModel, ClothSolver, DampingMode, Divergence, DivergenceBounds, GridDesc,
        Gusts, SolverMethod, SolverSettings, SpringConstants, SpringSettings, VolumeSettings,
    };
    pub use crate::cloth::{ClothPaint, DebugColorMode, PaintSource, PaintTarget};
    pub use crate::collide::ContactMaterial;
    pub use crate::collide::plugin::{
        AnimatedVelocity, ClothCollider, ColliderPlugin, ColliderShape, ColliderState,
        KinematicVelocity, StepColliders,
    };
    pub use crate::error::{ClothError, ClothWarning, ColliderError, MeshError};
    pub use crate::files::{BoneCollidersFile, ClothSettingsFile, FileAsset, FromFile};
    pub use crate::fluid::plugin::{Fluid, FluidPlugin, FluidSimulation, FluidSource};
    pub use crate::fluid::{FluidJet, FluidSettings, FluidSolver};
    pub use crate::schedule::{DrapeSystems, DrapeTimings};
    pub use crate::skeleton::clip::{Clip, ClipDesc, ClipError};
    #[cfg(feature = "animation")]
    pub use crate::skeleton::fixed_step_animation::FixedStepAnimation;
    pub use crate::skeleton::humanoid::{BoneProxy, humanoid, humanoid_proxies};
    pub use crate::skeleton::ik::{IkChain, IkError, IkResult, IkSettings};
    pub use crate::skeleton::plugin::{
        BoneColliders, BoneEntity, BoneProxyOf, ClipAsset, ClipPlayer, IkGoal, IkTarget,
        InverseKinematics, Skeleton, SkeletonBones, SkeletonPlugin, SkeletonPose,
    };
    pub use crate::skeleton::rig::{BoneDesc, Rig, RigError};
}

/// All of `bevy_drape`'s plugins, simulating in [`FixedPostUpdate`] by default.
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
            .add(FluidPlugin);
        #[cfg(feature = "avian")]
        let group = group.add(collide::avian::AvianColliderPlugin);
        #[cfg(feature = "animation")]
        let group = group.add(skeleton::fixed_step_animation::FixedStepAnimationPlugin);
        group
    }
}
