//! The Bevy side of the cloth: components, resources and the thin systems that build, step and
//! draw [`ClothSolver`](crate::cloth::ClothSolver)s.

mod budget;
mod components;
mod layers;
mod spawn;
mod step;
mod write_back;

pub use components::{
    Cloth, ClothBuildError, ClothDebugColors, ClothDiverged, ClothLevelOfDetail, ClothSettings,
    ClothSettingsFile, ClothSimulation, ClothSleeping, DefaultClothSettings, OnDivergence,
    VertexAttachment,
};
pub use layers::ClothLayers;

use bevy::app::{App, Plugin, PostUpdate};
use bevy::prelude::*;

use crate::cloth::debug_colors::ClothPaint;
use crate::cloth::render_mesh::ClothSimulationMesh;
use crate::schedule::{
    ClothCoupling, ClothCouplingInstalled, DrapeSchedule, DrapeSystems, NoCoupling,
};
use budget::mark_cloths;
use layers::build_layers;
use spawn::build_cloths;
use step::step_cloths;
use write_back::write_back_meshes;

/// Steps every [`Cloth`] in the drape schedule and writes it into its mesh every frame.
#[derive(Default)]
pub struct ClothPlugin;

impl Plugin for ClothPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        crate::files::add_file_type::<ClothSettings, _>(app, schedule, build_cloths);
        app.register_type::<(
            Cloth,
            ClothSimulationMesh,
            ClothSettings,
            DefaultClothSettings,
            ClothDebugColors,
            ClothPaint,
            ClothSleeping,
            ClothLevelOfDetail,
            ClothLayers,
        )>()
        .init_resource::<DefaultClothSettings>()
        .init_resource::<ClothLevelOfDetail>()
        .init_resource::<ClothDebugColors>()
        .add_message::<ClothDiverged>()
        .add_systems(
            schedule,
            step_cloths::<NoCoupling>
                .in_set(DrapeSystems::Step)
                .run_if(not(resource_exists::<ClothCouplingInstalled>)),
        )
        .add_systems(
            schedule,
            build_layers.after(build_cloths).before(DrapeSystems::Step),
        )
        .add_systems(schedule, mark_cloths.after(DrapeSystems::Step))
        .add_systems(
            PostUpdate,
            write_back_meshes.in_set(DrapeSystems::Writeback),
        );
    }
}

/// Steps every cloth with the coupling `C` on its entity (if any) inside its substeps: water
/// in a cloth (`DrapePlugins` adds it for the fluid plugin's `FluidSimulation`). Without
/// it, the cloths step alone. One coupling type per App.
pub struct ClothCouplingPlugin<C>(std::marker::PhantomData<fn() -> C>);

impl<C> Default for ClothCouplingPlugin<C> {
    fn default() -> Self {
        Self(std::marker::PhantomData)
    }
}

impl<C: ClothCoupling> Plugin for ClothCouplingPlugin<C> {
    fn build(&self, app: &mut App) {
        assert!(
            app.is_plugin_added::<ClothPlugin>(),
            "ClothCouplingPlugin<{}> steps the cloths of ClothPlugin: add ClothPlugin before it \
             (DrapePlugins has both)",
            std::any::type_name::<C>()
        );
        let schedule = DrapeSchedule::of(app);
        app.init_resource::<ClothCouplingInstalled>()
            .add_systems(schedule, step_cloths::<C>.in_set(DrapeSystems::Step));
    }
}
