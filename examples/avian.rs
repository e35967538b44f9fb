//! Cloth with Avian physics (`--features avian`): boxes and balls, Avian rigid bodies, fall on
//! a table cloth lying on an Avian table, press it down and roll it about; a kinematic Avian
//! pillar sweeps back and forth through the hem of a curtain. Nothing of this crate is on the
//! bodies: their Avian colliders are the cloth's colliders, their velocities and friction
//! Avian's. The coupling is one way (the cloth does not push the bodies): the table, not the
//! cloth, holds the bodies up.
//!
//! ```text
//! cargo run --features avian,render --example avian
//! ```
//!
//! R drops the bodies again, P pauses; drag with the mouse to orbit, scroll to zoom.

mod common;

use avian3d::prelude::*;
use bevy::prelude::*;
use bevy_drape::collide::avian::NoClothCollision;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

fn main() {
    if !common::has_graphics_adapter("avian") {
        return;
    }
    App::new()
        .add_plugins((
            DefaultPlugins,
            PhysicsPlugins::default(),
            DrapePlugins::default(),
            ExamplePlugin,
        ))
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, sweep_pillar))
        .run();
}

/// A body that falls on the table, with where it starts.
#[derive(Component)]
struct Dropped(Transform);

/// The pillar sweeping through the curtain.
#[derive(Component)]
struct Pillar;

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(-0.9, 0.6, 0.0),
        4.4,
    );
    // The ground: a static Avian body, and so a cloth collider too.
    commands.spawn((
        RigidBody::Static,
        Collider::half_space(Vec3::Y),
        Transform::default(),
    ));

    // The table: 1.2 x 0.8 m, its top 0.8 m up, and its cloth. With one-way coupling a body
    // resting on the cloth would squeeze it into the table, so Avian's table is 3 cm taller
    // than the cloth's: the table's own `ClothCollider` (its drawn box) overrides the one its
    // Avian collider would give, and the bodies rest on the cloth's thickness (twice the cloth's reach,
    // margin plus thickness, 1 cm each, and some slack).
    let wood = materials.add(Color::srgb(0.45, 0.3, 0.2));
    let table = meshes.add(Cuboid::new(1.2, 0.8, 0.8));
    commands.spawn((
        Mesh3d(table.clone()),
        MeshMaterial3d(wood),
        ClothCollider::mesh(table).with_friction(0.6),
        Transform::from_xyz(-1.0, 0.4, 0.0),
    ));
    commands.spawn((
        RigidBody::Static,
        Collider::cuboid(1.2, 0.86, 0.8),
        NoClothCollision,
        Transform::from_xyz(-1.0, 0.43, 0.0),
    ));
    let grid = GridDesc::square(1.6, 40, Vec3::new(-0.8, 0.0, -0.8));
    commands.spawn((
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.2, 0.45, 0.7))),
        Cloth::default(),
        Transform::from_xyz(-1.0, 0.9, 0.0),
    ));
    // Boxes and balls above it, dropped one after another.
    let grey = materials.add(Color::srgb(0.7, 0.68, 0.62));
    let red = materials.add(Color::srgb(0.75, 0.25, 0.2));
    for k in 0..6 {
        let at = Transform::from_xyz(
            -1.0 + 0.35 * ((k % 3) as f32 - 1.0),
            1.6 + 0.6 * k as f32,
            0.3 * ((k / 3) as f32 - 0.5),
        )
        .with_rotation(Quat::from_euler(EulerRot::XYZ, 0.3 * k as f32, 0.5, 0.2));
        let (mesh, collider, material) = if k % 2 == 0 {
            (
                meshes.add(Cuboid::new(0.25, 0.25, 0.25)),
                Collider::cuboid(0.25, 0.25, 0.25),
                grey.clone(),
            )
        } else {
            (
                meshes.add(Sphere::new(0.14).mesh().uv(32, 16)),
                Collider::sphere(0.14),
                red.clone(),
            )
        };
        commands.spawn((
            Mesh3d(mesh),
            MeshMaterial3d(material),
            RigidBody::Dynamic,
            collider,
            Friction::new(0.6),
            at,
            Dropped(at),
        ));
    }

    // The curtain: 1.4 m wide, 1.6 m tall, pinned along its top, 2 m up.
    let (columns, rows) = (28, 32);
    let curtain = GridDesc {
        size: Vec2::new(1.4, 1.6),
        vertices: UVec2::new(columns, rows),
        orientation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        origin: Vec3::new(-0.7, 0.0, 0.0),
    };
    let top: Vec<u32> = (0..columns).map(|i| curtain.index(i, 0)).collect();
    commands.spawn((
        Mesh3d(meshes.add(grid_mesh(&curtain))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.8, 0.6, 0.2))),
        Cloth::pinned(top),
        Transform::from_xyz(1.2, 2.0, 0.0),
    ));
    // The pillar: a kinematic Avian cylinder as tall as the curtain's lowest 0.5 m.
    commands.spawn((
        Mesh3d(meshes.add(Cylinder::new(0.15, 0.9))),
        MeshMaterial3d(grey),
        RigidBody::Kinematic,
        Collider::cylinder(0.15, 0.9),
        Friction::new(0.4),
        LinearVelocity(Vec3::new(0.0, 0.0, 0.5)),
        Transform::from_xyz(1.2, 0.45, -0.7),
        Pillar,
    ));
}

/// Turns the pillar round at either end of its sweep.
fn sweep_pillar(mut pillars: Query<(&Transform, &mut LinearVelocity), With<Pillar>>) {
    for (transform, mut velocity) in &mut pillars {
        let z = transform.translation.z;
        if (z > 0.7 && velocity.z > 0.0) || (z < -0.7 && velocity.z < 0.0) {
            velocity.z = -velocity.z;
        }
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut drape: ResMut<DrapeSettings>,
    mut cloths: Query<&mut ClothSimulation>,
    mut bodies: Query<(
        &Dropped,
        &mut Transform,
        &mut LinearVelocity,
        &mut AngularVelocity,
    )>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyR) {
        for mut cloth in &mut cloths {
            cloth.reset();
        }
        for (dropped, mut transform, mut linear, mut angular) in &mut bodies {
            *transform = dropped.0;
            linear.0 = Vec3::ZERO;
            angular.0 = Vec3::ZERO;
        }
    }
}
