//! A flag on a pole in gusty wind: drag and lift on every triangle of the cloth
//! (`SolverSettings::air`), the wind from the `Wind` resource.
//!
//! ```text
//! cargo run --features egui --example flag
//! ```
//!
//! Up and down change the wind's speed, left and right turn it, G toggles the gusts; the
//! panel (with `--features egui`) has the same as sliders, and the flag's air settings.
//! Drag with the mouse to orbit or to pull the flag, scroll to zoom, space resets, P pauses.

mod common;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

/// Vertices along the flag's length and height.
const VERTICES: UVec2 = UVec2::new(36, 24);
/// The flag's length and height, metres.
const SIZE: Vec2 = Vec2::new(1.5, 1.0);
/// The pole's height, metres.
const POLE: f32 = 2.6;
/// The gusts the G key turns on.
const GUSTS: Gusts = Gusts {
    strength: 3.0,
    frequency: 0.6,
    length: 4.0,
    seed: 7,
};

fn main() {
    if !common::has_graphics_adapter("flag") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .insert_resource(Wind {
            velocity: Vec3::new(0.0, 0.0, 8.0),
            gusts: GUSTS,
        })
        .add_systems(Startup, setup)
        .add_systems(Update, keys)
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
        Vec3::new(-0.6, POLE - 0.9, 1.2),
        4.2,
    );
    commands.spawn((ClothCollider::plane(), Transform::default()));
    // The flag hangs in the pole's plane (XY), its left edge along the pole, pinned.
    let grid = GridDesc {
        size: SIZE,
        vertices: VERTICES,
        orientation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        origin: Vec3::ZERO,
    };
    let pinned = (0..VERTICES.y).map(|j| grid.index(0, j));
    commands.spawn((
        Name::new("flag"),
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.78, 0.12, 0.1))),
        Cloth::pinned(pinned),
        ClothSettings {
            density: 0.15,
            solver: SolverSettings {
                air: Some(AirSettings::default()),
                ..default()
            },
            ..default()
        },
        Transform::from_xyz(0.0, POLE - 0.05, 0.0),
    ));
    let steel = materials.add(StandardMaterial {
        base_color: Color::srgb(0.75, 0.75, 0.78),
        metallic: 0.8,
        perceptual_roughness: 0.35,
        ..default()
    });
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.025, POLE))),
        MeshMaterial3d(steel.clone()),
        Transform::from_xyz(-0.03, POLE / 2.0, 0.0),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(0.045))),
        MeshMaterial3d(steel),
        Transform::from_xyz(-0.03, POLE + 0.02, 0.0),
    ));
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    mut wind: ResMut<Wind>,
    mut flags: Query<&mut ClothSimulation>,
    mut drape: ResMut<DrapeSettings>,
) {
    let dt = time.delta_secs();
    let v = wind.velocity;
    let (mut speed, mut heading) = (v.with_y(0.0).length(), v.z.atan2(v.x));
    if input.pressed(KeyCode::ArrowUp) {
        speed = (speed + 5.0 * dt).min(30.0);
    }
    if input.pressed(KeyCode::ArrowDown) {
        speed = (speed - 5.0 * dt).max(0.0);
    }
    if input.pressed(KeyCode::ArrowLeft) {
        heading -= dt;
    }
    if input.pressed(KeyCode::ArrowRight) {
        heading += dt;
    }
    let velocity = Vec3::new(speed * heading.cos(), v.y, speed * heading.sin());
    if (velocity - v).length() > 1e-4 {
        wind.velocity = velocity;
    }
    if input.just_pressed(KeyCode::KeyG) {
        wind.gusts.strength = if wind.gusts.strength > 0.0 {
            0.0
        } else {
            GUSTS.strength
        };
    }
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::Space) {
        for mut flag in &mut flags {
            flag.reset();
        }
    }
}
