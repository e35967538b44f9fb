//! Cloth dropped on colliders: a ground plane, three spheres and a capsule. One sphere moves
//! at a constant velocity and carries its cloth along; one spins about a horizontal axis and
//! drags its cloth off sideways by friction with its surface.
//!
//! ```text
//! cargo run --features render --example obstacles
//! ```
//!
//! R resets, P pauses; drag with the mouse to orbit, scroll to zoom.

mod common;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

const N: u32 = 24;
const SIZE: f32 = 0.9;
const RADIUS: f32 = 0.3;
const SPACING: f32 = 1.3;

fn main() {
    if !common::has_graphics_adapter("obstacles") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .add_systems(Startup, setup)
        .add_systems(Update, keys)
        .run();
}

/// Where a collider starts, for the reset key.
#[derive(Component)]
struct Start(Transform);

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.0, 0.3, 0.0),
        4.6,
    );
    // The ground the stage draws is a collider too.
    commands.spawn((
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));

    let ball = meshes.add(Sphere::new(RADIUS).mesh().uv(48, 24));
    let grey = materials.add(Color::srgb(0.45, 0.47, 0.5));
    let marker = meshes.add(Cuboid::new(0.05, 0.05, 0.05));
    let dark = materials.add(Color::srgb(0.1, 0.1, 0.12));
    let centre = Vec3::new(0.0, RADIUS, 0.0);
    let xs = [-1.5 * SPACING, -0.5 * SPACING, 0.5 * SPACING, 1.5 * SPACING];

    // A sphere at rest.
    let still = Transform::from_translation(centre + Vec3::X * xs[0]);
    commands.spawn((
        Mesh3d(ball.clone()),
        MeshMaterial3d(grey.clone()),
        ClothCollider::sphere(RADIUS).with_friction(0.6),
        still,
        Start(still),
    ));
    // A sphere moving at 0.15 m/s along +z, carrying its cloth.
    let moving = Transform::from_translation(centre + Vec3::X * xs[1]);
    commands.spawn((
        Mesh3d(ball.clone()),
        MeshMaterial3d(grey.clone()),
        ClothCollider::sphere(RADIUS).with_friction(0.6),
        KinematicVelocity {
            linear: Vec3::new(0.0, 0.0, 0.15),
            angular: Vec3::ZERO,
        },
        moving,
        Start(moving),
    ));
    // A sphere spinning about the horizontal z axis at 4 rad/s: its top moves along +x at
    // 1.2 m/s and drags the cloth that way. Markers on its surface show the spin.
    let spinning = Transform::from_translation(centre + Vec3::X * xs[2]);
    commands
        .spawn((
            Mesh3d(ball),
            MeshMaterial3d(grey.clone()),
            ClothCollider::sphere(RADIUS).with_friction(0.9),
            KinematicVelocity {
                linear: Vec3::ZERO,
                angular: Vec3::new(0.0, 0.0, -4.0),
            },
            spinning,
            Start(spinning),
        ))
        .with_children(|sphere| {
            for k in 0..8 {
                let angle = k as f32 * std::f32::consts::TAU / 8.0;
                sphere.spawn((
                    Mesh3d(marker.clone()),
                    MeshMaterial3d(dark.clone()),
                    Transform::from_xyz(angle.cos() * RADIUS, angle.sin() * RADIUS, 0.0),
                ));
            }
        });
    // A capsule lying along z.
    let lying = Transform::from_translation(Vec3::new(xs[3], 0.2, 0.0))
        .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
    commands.spawn((
        Mesh3d(meshes.add(Capsule3d::new(0.2, 0.6).mesh())),
        MeshMaterial3d(grey),
        ClothCollider::capsule(0.2, 0.3).with_friction(0.6),
        lying,
        Start(lying),
    ));

    // One cloth over each obstacle, 0.4 m above its top.
    let colours = [
        Color::srgb(0.75, 0.2, 0.15),
        Color::srgb(0.2, 0.5, 0.75),
        Color::srgb(0.85, 0.6, 0.15),
        Color::srgb(0.3, 0.6, 0.3),
    ];
    let grid = GridDesc::square(SIZE, N, Vec3::new(-SIZE / 2.0, 0.0, -SIZE / 2.0));
    let sheet = meshes.add(grid_mesh(&grid));
    for (x, colour) in xs.into_iter().zip(colours) {
        commands.spawn((
            Mesh3d(sheet.clone()),
            MeshMaterial3d(cloth_material(&mut materials, colour)),
            Cloth::default(),
            Transform::from_xyz(x, 2.0 * RADIUS + 0.4, 0.0),
        ));
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut drape: ResMut<DrapeSettings>,
    mut cloths: Query<&mut ClothSimulation>,
    mut colliders: Query<(&Start, &mut Transform)>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyR) {
        for mut cloth in &mut cloths {
            cloth.reset();
        }
        for (start, mut transform) in &mut colliders {
            *transform = start.0;
        }
    }
}
