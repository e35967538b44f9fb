//! Closed cloth and mesh files: a balloon (a UV sphere welded at its seams, held at a volume
//! by the pressure constraint) dropped on the ground, tied there by its knot where it lands,
//! and squashed by a capsule coming down on it; and a sheet draped over a stool read from
//! `assets/meshes/stool.obj` as a mesh collider.
//!
//! ```text
//! cargo run --features render --example balloon
//! ```
//!
//! Up and Down inflate and deflate the balloon, R resets, P pauses; drag cloth with the left
//! mouse button, orbit with the right one, scroll to zoom.

mod common;

use bevy::prelude::*;
use bevy_drape::cloth::VolumeSettings;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

const BALLOON_X: f32 = -0.8;
const STOOL_X: f32 = 0.8;

fn main() {
    if !common::has_graphics_adapter("balloon") {
        return;
    }
    App::new()
        .add_plugins((
            DefaultPlugins,
            DrapePlugins::default(),
            bevy_drape::bevy_obj::ObjPlugin,
            ExamplePlugin,
        ))
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, label))
        .init_resource::<KnotTied>()
        .add_systems(FixedUpdate, (roll_capsule, tie_knot))
        .run();
}

#[derive(Component)]
struct Balloon;

#[derive(Component)]
struct Roller;

/// Whether the balloon's knot is tied to the ground yet.
#[derive(Resource, Default)]
struct KnotTied(bool);

#[derive(Component)]
struct Label;

/// A rubber skin at `pressure` times its rest volume.
fn balloon_settings(pressure: f32) -> ClothSettings {
    ClothSettings {
        solver: SolverSettings {
            stretch_compliance: 1e-3,
            long_range_attachments: false,
            iterations: 4,
            volume: Some(VolumeSettings {
                pressure,
                compliance: 0.0,
            }),
            ..default()
        },
        ..default()
    }
}

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
        Vec3::new(0.0, 0.35, 0.0),
        3.2,
    );
    commands.spawn((
        ClothCollider::plane().with_friction(0.5),
        Transform::default(),
    ));
    let grey = materials.add(Color::srgb(0.45, 0.47, 0.5));

    // The balloon, and a capsule that comes down on it and goes back up.
    commands.spawn((
        Balloon,
        Mesh3d(meshes.add(Sphere::new(0.3).mesh().uv(32, 16))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.85, 0.2, 0.25))),
        Cloth::default(),
        balloon_settings(1.0),
        Transform::from_xyz(BALLOON_X, 0.9, 0.0),
    ));
    commands.spawn((
        Roller,
        Mesh3d(meshes.add(Capsule3d::new(0.12, 0.8).mesh())),
        MeshMaterial3d(grey.clone()),
        ClothCollider::capsule(0.12, 0.4).with_friction(0.4),
        Transform::from_xyz(BALLOON_X, 1.6, 0.0)
            .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)),
    ));

    // The stool, drawn and collided from the same OBJ file, and a sheet over it.
    let stool: Handle<Mesh> = assets.load("meshes/stool.obj");
    commands.spawn((
        Mesh3d(stool.clone()),
        MeshMaterial3d(grey),
        ClothCollider::mesh(stool).with_friction(0.5),
        Transform::from_xyz(STOOL_X, 0.0, 0.0),
    ));
    let grid = GridDesc::square(0.9, 32, Vec3::new(-0.45, 0.0, -0.45));
    commands.spawn((
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.2, 0.5, 0.75))),
        Cloth::default(),
        Transform::from_xyz(STOOL_X, 0.8, 0.0),
    ));

    commands.spawn((
        Text::new(""),
        Node {
            position_type: PositionType::Absolute,
            bottom: Val::Px(10.0),
            right: Val::Px(10.0),
            ..default()
        },
        Label,
    ));
}

/// The capsule comes down onto the balloon from 2 s to 6 s (squashing it to a little over
/// half its resting height) and goes back up, every 8 s.
fn roll_capsule(time: Res<Time>, mut rollers: Query<&mut Transform, With<Roller>>) {
    let t = time.elapsed_secs() % 8.0;
    let squash = if (2.0..6.0).contains(&t) {
        (std::f32::consts::PI * (t - 2.0) / 4.0).sin()
    } else {
        0.0
    };
    for mut transform in &mut rollers {
        transform.translation = Vec3::new(BALLOON_X, 1.6 - 1.15 * squash, 0.0);
    }
}

/// Ties the balloon's lowest particle (its knot) to the ground where it first touches it, so
/// that the capsule squashes the balloon in place: a convex press rolls anything the least off
/// centre out sideways.
/// A reset (R, or the panel) puts the knot back in the air: it is untied, and tied again where
/// the balloon lands.
fn tie_knot(mut tied: ResMut<KnotTied>, mut balloons: Query<&mut ClothSimulation, With<Balloon>>) {
    for mut balloon in &mut balloons {
        let sim = balloon.solver();
        if tied.0 {
            let knot_in_air = sim
                .pins()
                .iter()
                .any(|pin| sim.state().positions[pin.particle as usize].y > 0.1);
            if knot_in_air {
                tied.0 = balloon.solver_mut().set_pins(&[]).is_err();
            }
            continue;
        }
        let lowest = balloon
            .solver()
            .state()
            .positions
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.y.total_cmp(&b.1.y))
            .map(|(i, p)| (i as u32, p.y));
        if let Some((knot, height)) = lowest
            && height < 0.05
        {
            tied.0 = balloon.solver_mut().set_pins(&[knot]).is_ok();
        }
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut drape: ResMut<DrapeSettings>,
    mut balloons: Query<&mut ClothSettings, With<Balloon>>,
    mut cloths: Query<&mut ClothSimulation>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyR) {
        for mut cloth in &mut cloths {
            cloth.reset();
        }
    }
    let change = if input.just_pressed(KeyCode::ArrowUp) {
        0.1
    } else if input.just_pressed(KeyCode::ArrowDown) {
        -0.1
    } else {
        return;
    };
    for mut settings in &mut balloons {
        if let Some(volume) = settings.solver.volume.as_mut() {
            volume.pressure = (volume.pressure + change).clamp(0.2, 3.0);
        }
    }
}

fn label(
    balloons: Query<(&ClothSettings, Option<&ClothSimulation>), With<Balloon>>,
    mut labels: Query<&mut Text, With<Label>>,
) {
    for (settings, simulation) in &balloons {
        let pressure = settings.solver.volume.map_or(0.0, |v| v.pressure);
        let volume = simulation.and_then(|s| s.solver().volume());
        for mut text in &mut labels {
            text.0 = match volume {
                Some((now, rest)) => format!(
                    "balloon: pressure {pressure:.1} x rest volume (Up/Down), volume {:.1} L of {:.1} L",
                    now * 1e3,
                    pressure * rest * 1e3
                ),
                None => format!("balloon: pressure {pressure:.1}"),
            };
        }
    }
}
