//! A cloth hung by five vertices of its top edge from a bar that moves along a keyframed path
//! (a looping non-uniform Catmull-Rom spline through six keys): the attachments follow the
//! bar, the cloth swings behind it.
//!
//! ```text
//! cargo run --features render --example attachments
//! ```
//!
//! P pauses; press on the cloth and drag to pull it; drag elsewhere to orbit.

mod common;

use bevy::prelude::*;
use bevy_drape::cloth::plugin::DefaultClothSettings;
use bevy_drape::prelude::*;
use bevy_drape::skeleton::spline::KeySpline;
use common::{ExamplePlugin, cloth_material, spawn_stage};

const N: u32 = 25;
const WIDTH: f32 = 1.2;

fn main() {
    if !common::has_graphics_adapter("attachments") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .insert_resource(DefaultClothSettings(ClothSettings { ..default() }))
        .add_systems(Startup, setup)
        .add_systems(FixedUpdate, move_bar)
        .add_systems(Update, (keys, draw_path))
        .run();
}

/// The bar's keyframed path.
#[derive(Component)]
struct Path(KeySpline<Vec3>);

fn path() -> KeySpline<Vec3> {
    let times = [0.0, 1.2, 2.0, 3.5, 4.2, 6.0];
    let points = [
        Vec3::new(-0.8, 1.8, 0.0),
        Vec3::new(0.0, 2.1, -0.6),
        Vec3::new(0.8, 1.7, -0.2),
        Vec3::new(0.7, 1.9, 0.7),
        Vec3::new(-0.1, 1.6, 0.8),
        Vec3::new(-0.8, 1.8, 0.0),
    ];
    KeySpline::new(&times, &points, true).expect("valid keys")
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
        Vec3::new(0.0, 1.2, 0.0),
        4.2,
    );
    commands.spawn((ClothCollider::plane(), Transform::default()));
    let bar = commands
        .spawn((
            Mesh3d(meshes.add(Cylinder::new(0.02, WIDTH + 0.2))),
            MeshMaterial3d(materials.add(Color::srgb(0.3, 0.3, 0.35))),
            Transform::from_translation(path().sample(0.0).0)
                .with_rotation(Quat::from_rotation_z(std::f32::consts::FRAC_PI_2)),
            Path(path()),
        ))
        .id();
    // The sheet hangs in the XY plane below the bar: vertex (i, 0) is on the top edge.
    let grid = GridDesc {
        orientation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        ..GridDesc::square(WIDTH, N, Vec3::new(-WIDTH / 2.0, 0.0, 0.0))
    };
    let mut cloth = Cloth::default();
    for k in 0..5 {
        let i = k * (N - 1) / 4;
        // Along the bar's local y (it is a cylinder turned to lie along x).
        let offset = Vec3::new(0.0, WIDTH / 2.0 - i as f32 * WIDTH / (N - 1) as f32, 0.0);
        cloth = cloth.with_attachment(VertexAttachment {
            vertex: grid.index(i, 0),
            target: bar,
            offset,
        });
    }
    commands.spawn((
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.2, 0.45, 0.7))),
        cloth,
        Transform::from_translation(path().sample(0.0).0),
    ));
}

/// Moves the bar along its path in the fixed schedule, before the cloth steps.
fn move_bar(mut bars: Query<(&Path, &mut Transform)>, time: Res<Time>) {
    for (path, mut transform) in &mut bars {
        transform.translation = path.0.sample(time.elapsed_secs()).0;
    }
}

fn draw_path(mut gizmos: Gizmos, bars: Query<&Path>) {
    for path in &bars {
        let points = (0..=120).map(|k| path.0.sample(k as f32 * 0.05).0);
        gizmos.linestrip(points, Color::srgb(0.9, 0.8, 0.2));
        for &t in path.0.times() {
            gizmos.sphere(
                Isometry3d::from_translation(path.0.sample(t).0),
                0.03,
                Color::WHITE,
            );
        }
    }
}

fn keys(input: Res<ButtonInput<KeyCode>>, mut drape: ResMut<DrapeSettings>) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
}
