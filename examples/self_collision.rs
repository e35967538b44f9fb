//! Self-collision: two soft sheets dropped edge-first onto the ground side by side. They pile
//! up in folds; the left one has self-collision off and its folds pass through each other, the
//! right one keeps its layers apart. The labels count the pairs of particles held apart.
//!
//! ```text
//! cargo run --features render --example self_collision
//! ```
//!
//! R drops the sheets again, P pauses; drag a sheet with the left mouse button, orbit with the
//! right one, scroll to zoom.

mod common;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, cloth_material, spawn_stage};

const N: u32 = 32;

fn main() {
    if !common::has_graphics_adapter("self_collision") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, labels))
        .run();
}

/// Which sheet a label reads.
#[derive(Component)]
struct Label(Entity);

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.0, 0.05, 0.35),
        2.3,
    );
    commands.spawn((
        ClothCollider::plane().with_friction(0.5).with_margin(0.0),
        Transform::default(),
    ));
    // A 1 m square whose lower edge is 0.3 m up, tilted 0.2 rad from the vertical.
    let mut grid = GridDesc::square(1.0, N, Vec3::new(0.0, 0.3, 0.0));
    grid.orientation = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2 + 0.2);
    let sheet = meshes.add(grid_mesh(&grid));
    let row = commands
        .spawn(Node {
            width: Val::Percent(100.0),
            padding: UiRect::all(Val::Px(12.0)),
            justify_content: JustifyContent::SpaceAround,
            ..default()
        })
        .id();
    for (x, on, colour) in [
        (-1.25, false, Color::srgb(0.8, 0.3, 0.2)),
        (0.25, true, Color::srgb(0.2, 0.5, 0.8)),
    ] {
        let cloth = commands
            .spawn((
                Mesh3d(sheet.clone()),
                MeshMaterial3d(cloth_material(&mut materials, colour)),
                Cloth::default(),
                ClothSettings {
                    // A soft, drapey cloth that piles up in folds.
                    solver: SolverSettings {
                        bend_compliance: 1.0e4,
                        self_collision: if on {
                            SelfCollisionMethod::Particles
                        } else {
                            SelfCollisionMethod::Off
                        },
                        ..default()
                    },
                    ..default()
                },
                Transform::from_xyz(x, 0.0, 0.0),
            ))
            .id();
        commands.spawn((
            Text::new(""),
            TextFont::from_font_size(FontSize::Px(18.0)),
            Label(cloth),
            ChildOf(row),
        ));
    }
}

fn labels(
    cloths: Query<(&ClothSettings, Option<&ClothSimulation>)>,
    mut texts: Query<(&Label, &mut Text)>,
) {
    for (label, mut text) in &mut texts {
        let Ok((settings, simulation)) = cloths.get(label.0) else {
            continue;
        };
        let contacts = simulation.map_or(0, |s| s.solver().self_contact_count());
        text.0 = if settings.solver.self_collision != SelfCollisionMethod::Off {
            format!("self-collision on: {contacts} pairs held apart")
        } else {
            "self-collision off".to_string()
        };
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
    if input.just_pressed(KeyCode::KeyR) {
        for mut cloth in &mut cloths {
            cloth.reset();
        }
    }
}
