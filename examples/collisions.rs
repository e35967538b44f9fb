//! A mass-spring cloth thrown into a box: it bounces off the walls and lands on two resting
//! spheres and one sweeping back and forth (the `collisions` scene of the scenes runner, `crates/drape_scenes/src/scenes/collisions.rs`).
//!
//! ```text
//! cargo run --features egui --example collisions
//! ```
//!
//! Space throws it again, P pauses; drag with the mouse to orbit or to pull the cloth.

mod common;

use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use bevy_drape::cloth::SolverMethod;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

/// The box's corners (the ground is its floor).
const BOX: (Vec3, Vec3) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
/// The contact material of every collider.
const MATERIAL: ContactMaterial = ContactMaterial {
    friction: 0.3,
    restitution: 0.4,
};

/// The spheres at time `t` (centre, radius): two at rest and one sweeping along X.
fn spheres_at(t: f32) -> [(Vec3, f32); 3] {
    let (amplitude, omega) = (0.45, 1.0 / 0.45);
    [
        (Vec3::new(0.0, 0.25, 0.1), 0.25),
        (Vec3::new(0.5, 0.2, -0.3), 0.2),
        (Vec3::new(amplitude * (omega * t).sin(), 0.18, 0.45), 0.18),
    ]
}

/// Marks the sweeping sphere.
#[derive(Component)]
struct Sweeping;

fn main() {
    if !common::has_graphics_adapter("collisions") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .add_systems(Startup, setup)
        .add_systems(FixedUpdate, sweep)
        .add_systems(Update, (throw, keys))
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
        Vec3::new(0.2, 0.3, 0.0),
        2.6,
    );
    // The box: its floor and walls as plane colliders facing in.
    for wall in ClothCollider::inside_box(BOX.0, BOX.1) {
        commands.spawn(wall);
    }
    let material = MATERIAL;
    let grid = GridDesc::square(0.8, 24, Vec3::ZERO);
    commands.spawn((
        Name::new("cloth"),
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.2, 0.45, 0.75))),
        Cloth::default(),
        ClothSettings {
            // Mass-spring at its stable step.
            solver: SolverSettings {
                method: SolverMethod::MassSpring,
                auto_substeps: true,
                ..default()
            },
            ..default()
        },
        Transform::from_xyz(-0.9, 1.2, -0.4),
    ));
    let ball = materials.add(Color::srgb(0.8, 0.75, 0.6));
    for (k, (centre, radius)) in spheres_at(0.0).into_iter().enumerate() {
        let mut sphere = commands.spawn((
            Mesh3d(meshes.add(Sphere::new(radius - 0.005))),
            MeshMaterial3d(ball.clone()),
            ClothCollider::sphere(radius)
                .with_friction(material.friction)
                .with_restitution(material.restitution),
            Transform::from_translation(centre),
        ));
        if k == 2 {
            sphere.insert(Sweeping);
        }
    }
    // The box's walls as thin glass panes (the ground is the stage's).
    let glass = materials.add(StandardMaterial {
        base_color: Color::srgba(0.7, 0.8, 0.9, 0.15),
        alpha_mode: AlphaMode::Blend,
        ..default()
    });
    let (min, max) = BOX;
    let size = max - min;
    let centre = (min + max) / 2.0;
    for (offset, extent) in [
        (
            Vec3::new(-size.x / 2.0, 0.0, 0.0),
            Vec3::new(0.01, size.y, size.z),
        ),
        (
            Vec3::new(size.x / 2.0, 0.0, 0.0),
            Vec3::new(0.01, size.y, size.z),
        ),
        (
            Vec3::new(0.0, 0.0, -size.z / 2.0),
            Vec3::new(size.x, size.y, 0.01),
        ),
        (
            Vec3::new(0.0, 0.0, size.z / 2.0),
            Vec3::new(size.x, size.y, 0.01),
        ),
    ] {
        commands.spawn((
            Mesh3d(meshes.add(Cuboid::from_size(extent))),
            MeshMaterial3d(glass.clone()),
            Transform::from_translation(centre + offset),
            NotShadowCaster,
        ));
    }
}

/// Moves the sweeping sphere along its path; the colliders take its velocity from the motion.
fn sweep(time: Res<Time>, mut spheres: Query<&mut Transform, With<Sweeping>>) {
    let (centre, _) = spheres_at(time.elapsed_secs())[2];
    for mut transform in &mut spheres {
        transform.translation = centre;
    }
}

/// Gives a newly built (or reset) cloth the scene's throw: 2 m/s along +X.
fn throw(mut cloths: Query<&mut ClothSimulation, Added<ClothSimulation>>) {
    for mut cloth in &mut cloths {
        for v in &mut cloth.solver_mut().state_mut().velocities {
            *v = Vec3::new(2.0, 0.0, 0.0).into();
        }
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
            for v in &mut cloth.solver_mut().state_mut().velocities {
                *v = Vec3::new(2.0, 0.0, 0.0).into();
            }
        }
    }
}
