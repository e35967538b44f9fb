//! The main scene with `bevy-inspector-egui` on the right (the poncho's `ClothSettings`,
//! `DrapeSettings` and the world view its `quick` plugins open, drawn here in the crate's egui
//! context so that the inspector needs none of Bevy's rendering types) and the crate's panel on
//! the left, one egui for both: every component of the crate is reflected, so the inspector shows and
//! edits them while the scene runs. Open the poncho for its `ClothSettings` (substeps,
//! iterations, compliances, density; a change rebuilds nothing and takes effect the next fixed
//! step), the `ground` for its `ClothCollider`, the `character` for its `BoneColliders` (a
//! proxy's radius edited spawns the proxies again), `ClipPlayer` (speed, time) and
//! `InverseKinematics`.
//!
//! ```text
//! cargo run --release --features egui --example inspector
//! ```

mod common;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use bevy_egui::{EguiContext, EguiPrimaryContextPass, PrimaryEguiContext, egui};
use bevy_inspector_egui::DefaultInspectorConfigPlugin;
use bevy_inspector_egui::bevy_inspector::{ui_for_resource, ui_for_value, ui_for_world};
use common::{ExamplePlugin, dress_humanoids, dress_ponchos, spawn_stage};
use drape_scenes::poncho::{CharacterMotion, Poncho, PonchoScene, PonchoScenePlugin};

fn main() {
    App::new()
        .add_plugins((DefaultPlugins, ExamplePlugin))
        .add_plugins((DrapePlugins::default(), PonchoScenePlugin))
        .add_plugins(DefaultInspectorConfigPlugin)
        .add_systems(EguiPrimaryContextPass, inspector)
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(PonchoScene {
            motion: CharacterMotion::InPlace,
            ..default()
        })
        .add_systems(Startup, setup)
        .add_systems(Update, (dress_humanoids, dress_ponchos))
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.0, 1.1, 0.0),
        3.0,
    );
}

/// The inspector, on the right: the poncho's `ClothSettings`, `DrapeSettings` and the whole
/// world (every entity, the character's `BoneColliders`, `ClipPlayer` and
/// `InverseKinematics`, the colliders), each drawn by `bevy-inspector-egui`.
fn inspector(world: &mut World) {
    let Ok(context) = world
        .query_filtered::<&mut EguiContext, With<PrimaryEguiContext>>()
        .single(world)
    else {
        return;
    };
    let mut context = context.clone();
    let poncho = world
        .query_filtered::<Entity, With<Poncho>>()
        .iter(world)
        .next();
    egui::Window::new("Inspector")
        .anchor(egui::Align2::RIGHT_TOP, egui::vec2(-10.0, 10.0))
        .default_width(330.0)
        .show(context.get_mut(), |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                egui::CollapsingHeader::new("poncho: ClothSettings")
                    .default_open(true)
                    .show(ui, |ui| {
                        // Edited as a copy, written back when the inspector changed it.
                        let Some(mut settings) =
                            poncho.and_then(|p| world.get::<ClothSettings>(p).copied())
                        else {
                            return;
                        };
                        if ui_for_value(&mut settings, ui, world)
                            && let Some(p) = poncho
                        {
                            world.entity_mut(p).insert(settings);
                        }
                    });
                egui::CollapsingHeader::new("DrapeSettings")
                    .default_open(true)
                    .show(ui, |ui| ui_for_resource::<DrapeSettings>(world, ui));
                egui::CollapsingHeader::new("World").show(ui, |ui| ui_for_world(world, ui));
            });
        });
}
