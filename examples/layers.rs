//! Layers: on the left a soft sheet dropped edge-first folds onto itself, kept from passing
//! through its own triangles by the triangle method of self-collision; on the right two
//! sheets dropped one above the other onto a ball drape one over the other, stepped as layers
//! of one solve (`ClothLayers`). T turns the left sheet's self-collision off and on, L the
//! right sheets' layering: without it they fall through each other.
//!
//! ```text
//! cargo run --features render --example layers
//! ```
//!
//! R drops the sheets again, P pauses; drag a sheet with the left mouse button, orbit with the
//! right one, scroll to zoom.

mod common;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

/// Vertices per side of every sheet.
const N: u32 = 32;
/// The ball's radius and where it rests.
const BALL_RADIUS: f32 = 0.3;
const BALL_AT: Vec3 = Vec3::new(0.8, BALL_RADIUS, 0.0);

fn main() {
    if !common::has_graphics_adapter("layers") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, label))
        .run();
}

/// The sheet that folds onto itself.
#[derive(Component)]
struct Folding;

/// The entity holding the two layered sheets' `ClothLayers`, and the sheets, inner first.
#[derive(Resource)]
struct Layered {
    group: Entity,
    sheets: [Entity; 2],
}

#[derive(Component)]
struct Label;

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
        3.0,
    );
    commands.spawn((
        ClothCollider::plane().with_friction(0.5).with_margin(0.0),
        Transform::default(),
    ));
    // A soft, drapey cloth that piles up in folds.
    let soft = |self_collision| ClothSettings {
        solver: SolverSettings {
            bend_compliance: 1.0e4,
            self_collision,
            ..default()
        },
        ..default()
    };
    // Left: a 1 m square whose lower edge is 0.3 m up, tilted 0.2 rad from the vertical.
    let mut grid = GridDesc::square(1.0, N, Vec3::new(-1.3, 0.3, -0.2));
    grid.orientation = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2 + 0.2);
    commands.spawn((
        Folding,
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.2, 0.5, 0.8))),
        Cloth::default(),
        soft(SelfCollisionMethod::Triangles),
    ));
    // Right: a ball, and two flat 1 m squares over it, 5 cm apart, the upper turned 45 degrees.
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(BALL_RADIUS * 0.97).mesh().uv(48, 24))),
        MeshMaterial3d(materials.add(Color::srgb(0.8, 0.8, 0.75))),
        ClothCollider::sphere(BALL_RADIUS).with_friction(0.5),
        Transform::from_translation(BALL_AT),
    ));
    let layer = |height: f32, turn: f32| {
        let spin = Quat::from_rotation_y(turn);
        let mut grid = GridDesc::square(1.0, N, Vec3::ZERO);
        grid.orientation = spin;
        grid.origin = BALL_AT.with_y(height) - spin * Vec3::new(0.5, 0.0, 0.5);
        grid
    };
    let mut sheets = [Entity::PLACEHOLDER; 2];
    for (k, (grid, colour)) in [
        (layer(0.9, 0.0), Color::srgb(0.85, 0.75, 0.3)),
        (
            layer(0.95, std::f32::consts::FRAC_PI_4),
            Color::srgb(0.75, 0.25, 0.2),
        ),
    ]
    .into_iter()
    .enumerate()
    {
        sheets[k] = commands
            .spawn((
                Mesh3d(meshes.add(grid_mesh(&grid))),
                MeshMaterial3d(cloth_material(&mut materials, colour)),
                Cloth::default(),
                ClothSettings {
                    solver: SolverSettings {
                        bend_compliance: 1.0e3,
                        ..default()
                    },
                    ..default()
                },
            ))
            .id();
    }
    let group = commands.spawn(ClothLayers(sheets.to_vec())).id();
    commands.insert_resource(Layered { group, sheets });
    commands.spawn((
        Text::new(""),
        TextFont::from_font_size(FontSize::Px(18.0)),
        Node {
            position_type: PositionType::Absolute,
            top: Val::Px(12.0),
            left: Val::Px(12.0),
            ..default()
        },
        Label,
    ));
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut commands: Commands,
    mut drape: ResMut<DrapeSettings>,
    mut cloths: Query<&mut ClothSimulation>,
    mut folding: Query<&mut ClothSettings, With<Folding>>,
    layered: Res<Layered>,
    groups: Query<(), With<ClothLayers>>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyR) {
        for mut cloth in &mut cloths {
            cloth.reset();
        }
    }
    if input.just_pressed(KeyCode::KeyT) {
        for mut settings in &mut folding {
            settings.solver.self_collision = match settings.solver.self_collision {
                SelfCollisionMethod::Off => SelfCollisionMethod::Triangles,
                _ => SelfCollisionMethod::Off,
            };
        }
    }
    if input.just_pressed(KeyCode::KeyL) {
        let mut group = commands.entity(layered.group);
        match groups.contains(layered.group) {
            true => group.remove::<ClothLayers>(),
            false => group.insert(ClothLayers(layered.sheets.to_vec())),
        };
    }
}

fn label(
    folding: Query<(&ClothSettings, Option<&ClothSimulation>), With<Folding>>,
    layered: Res<Layered>,
    groups: Query<(), With<ClothLayers>>,
    mut labels: Query<&mut Text, With<Label>>,
) {
    let Ok((settings, simulation)) = folding.single() else {
        return;
    };
    let contacts = simulation.map_or(0, |s| s.solver().self_contact_count());
    let layers = groups.contains(layered.group);
    for mut text in &mut labels {
        text.0 = format!(
            "left: self-collision {} (T), {contacts} pairs held apart\n\
             right: two sheets {} (L)\n\
             R drops them again, P pauses",
            settings.solver.self_collision.name(),
            if layers {
                "stepped as layers of one solve"
            } else {
                "stepped apart, passing through each other"
            },
        );
    }
}
