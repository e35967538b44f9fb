//! The humanoid walking in place under a poncho, with `bevy-inspector-egui` on the right (the poncho's `ClothSettings`,
//! `DrapeSettings` and the world view its `quick` plugins open, drawn here in the crate's egui
//! context so that the inspector needs none of Bevy's rendering types) and the crate's panel on
//! the left, one egui for both: every component of the crate is reflected, so the inspector shows and
//! edits them while the scene runs. Open the poncho for its `ClothSettings` (substeps,
//! iterations, compliances, density; a change rebuilds nothing and takes effect the next fixed
//! step), the `ground` for its `ClothCollider`, the `character` for its `BoneColliders` (a
//! proxy's radius edited spawns the proxies again) and its `ClipPlayer` (speed, time).
//!
//! ```text
//! cargo run -p drape_inspector --features egui --example inspector
//! ```

#[path = "../../../examples/common/mod.rs"]
mod common;

use std::sync::Arc;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use bevy_egui::{EguiContext, EguiPrimaryContextPass, PrimaryEguiContext, egui};
use bevy_inspector_egui::DefaultInspectorConfigPlugin;
use bevy_inspector_egui::bevy_inspector::{ui_for_resource, ui_for_value, ui_for_world};
use common::{ExamplePlugin, cloth_material, dress_humanoids, spawn_stage};

/// Marks the poncho, the cloth the inspector opens first.
#[derive(Component)]
struct Poncho;

fn main() {
    // Without an adapter Bevy's renderer would panic: say so and exit 0.
    if let Err(reason) = bevy_drape::interact::adapter::find_graphics_adapter() {
        println!("inspector: {reason}; nothing to show without one");
        return;
    }
    App::new()
        // The crate's assets (the clip and the poncho), wherever this package is run from.
        .add_plugins((
            DefaultPlugins.set(AssetPlugin {
                file_path: concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets").into(),
                ..default()
            }),
            ExamplePlugin,
        ))
        .add_plugins((DrapePlugins::default(), bevy_drape::bevy_obj::ObjPlugin))
        .add_plugins(DefaultInspectorConfigPlugin)
        .add_systems(EguiPrimaryContextPass, inspector)
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .add_systems(Startup, setup)
        .add_systems(Update, dress_humanoids)
        .run();
}

/// The stage, a ground collider, the humanoid walking in place on its proxies and a poncho
/// worn by it.
fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    assets: Res<AssetServer>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.0, 1.1, 0.0),
        3.0,
    );
    commands.spawn((
        Name::new("ground"),
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    let character = commands
        .spawn((
            Name::new("character"),
            Skeleton {
                rig: Arc::new(humanoid()),
            },
            BoneColliders::humanoid(),
            ClipPlayer::new(assets.load("clips/walk.clip.ron")),
            Transform::default(),
        ))
        .id();
    commands.spawn((
        Name::new("poncho"),
        Poncho,
        Mesh3d(assets.load("meshes/poncho.obj")),
        ClothSimulationMesh(assets.load("meshes/poncho_coarse.obj")),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.75, 0.25, 0.2))),
        Cloth::worn_by(character),
        ClothSettings {
            density: 0.25,
            ..default()
        },
        Transform::from_xyz(0.0, 1.5, 0.0),
    ));
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
