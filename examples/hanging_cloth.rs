//! The hanging cloth (scene S1): a 1 m x 1 m sheet, horizontal at the start, two adjacent
//! corners pinned, swinging down under gravity over a ground plane.
//!
//! ```text
//! cargo run --features render --example hanging_cloth
//! ```
//!
//! Drag with the mouse to orbit, scroll to zoom, space to reset, P to pause.
//!
//! The cloth takes its settings from `assets/settings/hanging_cloth.cloth.ron`: edit the file
//! while it runs (substeps, compliances, damping, density, ...) and the cloth changes as you
//! save it.

mod common;

use bevy::prelude::*;
use bevy_drape::cloth::plugin::ClothSettingsFile;
use bevy_drape::cloth::plugin::DefaultClothSettings;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

const N: u32 = 32;
const HEIGHT: f32 = 1.5;

fn main() {
    if !common::has_graphics_adapter("hanging_cloth") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .insert_resource(DefaultClothSettings(ClothSettings { ..default() }))
        .add_systems(Startup, setup)
        .add_systems(Update, keys)
        .run();
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    server: Res<AssetServer>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.5, 0.9, 0.3),
        3.2,
    );
    commands.spawn((ClothCollider::plane(), Transform::default()));
    // The S1 sheet: x, z in [0, 1], pinned at (0, h, 0) and (1, h, 0).
    let grid = GridDesc::square(1.0, N, Vec3::ZERO);
    commands.spawn((
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.75, 0.2, 0.15))),
        Cloth::pinned([grid.index(0, 0), grid.index(N - 1, 0)]),
        ClothSettingsFile::new(server.load("settings/hanging_cloth.cloth.ron")),
        Transform::from_xyz(0.0, HEIGHT, 0.0),
    ));
    // Two posts to show where the corners hang from.
    let post = meshes.add(Cylinder::new(0.015, HEIGHT));
    let steel = materials.add(Color::srgb(0.3, 0.3, 0.35));
    for x in [0.0, 1.0] {
        commands.spawn((
            Mesh3d(post.clone()),
            MeshMaterial3d(steel.clone()),
            Transform::from_xyz(x, HEIGHT / 2.0, -0.02),
        ));
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut drape: ResMut<DrapeSettings>,
    mut cloths: Query<&mut ClothSimulation>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::Space) {
        for mut cloth in &mut cloths {
            cloth.reset();
        }
    }
}
