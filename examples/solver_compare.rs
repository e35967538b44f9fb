//! Mass-spring, hybrid and XPBD side by side on the hanging cloth (scene S1 at N = 20), with
//! the same substeps, density and damping. Make the substep longer or the springs stiffer
//! until mass-spring goes unstable: the divergence is caught, reported on screen and in the
//! log, and that cloth is frozen, while XPBD holds at any step.
//!
//! ```text
//! cargo run --features render --example solver_compare [-- --substeps 128]
//! ```
//!
//! Keys: Left / Right halve / double the substeps (the time step), Down / Up halve / double
//! the spring stiffnesses, A toggles automatic substeps for the spring methods, R resets all
//! three, P pauses. Drag with the mouse to orbit, scroll to zoom. A frozen cloth steps again
//! when a setting changes.

mod common;

use bevy::prelude::*;
use bevy::text::FontSize;
use bevy_drape::cloth::SolverMethod;
use bevy_drape::cloth::plugin::ClothDiverged;
use bevy_drape::prelude::*;
use common::{ExamplePlugin, OrbitCamera, cloth_material, spawn_stage};

const N: u32 = 20;
const HEIGHT: f32 = 1.5;
const SPACING: f32 = 1.6;

fn main() {
    if !common::has_graphics_adapter("solver_compare") {
        return;
    }
    let substeps = std::env::args()
        .skip_while(|a| a != "--substeps")
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(128u32);
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .insert_resource(Shared {
            substeps,
            stiffness_scale: 1.0,
            auto_substeps: false,
        })
        .init_resource::<LastDivergence>()
        .add_systems(Startup, (setup, face_the_row).chain())
        .add_systems(
            Update,
            (keys, apply_shared, record_divergence, labels).chain(),
        )
        .run();
}

/// The parameters the three cloths share, changed with the keys.
#[derive(Resource)]
struct Shared {
    substeps: u32,
    stiffness_scale: f32,
    auto_substeps: bool,
}

/// The last divergence of each cloth, for the labels.
#[derive(Resource, Default)]
struct LastDivergence(Vec<ClothDiverged>);

/// One of the three cloths.
#[derive(Component)]
struct Column {
    method: SolverMethod,
    index: usize,
}

/// The label of column `0`.
#[derive(Component)]
struct Label(usize);

const METHODS: [SolverMethod; 3] = [
    SolverMethod::MassSpring,
    SolverMethod::Hybrid { long_range: false },
    SolverMethod::Xpbd,
];

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(SPACING + 0.5, 0.9, 0.3),
        5.2,
    );
    commands.spawn((ClothCollider::plane(), Transform::default()));
    let grid = GridDesc::square(1.0, N, Vec3::ZERO);
    let mesh = meshes.add(grid_mesh(&grid));
    let colours = [
        Color::srgb(0.8, 0.55, 0.15),
        Color::srgb(0.2, 0.5, 0.75),
        Color::srgb(0.75, 0.2, 0.15),
    ];
    let post = meshes.add(Cylinder::new(0.015, HEIGHT));
    let steel = materials.add(Color::srgb(0.3, 0.3, 0.35));
    for (index, method) in METHODS.into_iter().enumerate() {
        let x = index as f32 * SPACING;
        commands.spawn((
            Mesh3d(mesh.clone()),
            MeshMaterial3d(cloth_material(&mut materials, colours[index])),
            Cloth::pinned([grid.index(0, 0), grid.index(N - 1, 0)]),
            settings(method, 128, 1.0, false),
            Column { method, index },
            Transform::from_xyz(x, HEIGHT, 0.0),
        ));
        for post_x in [x, x + 1.0] {
            commands.spawn((
                Mesh3d(post.clone()),
                MeshMaterial3d(steel.clone()),
                Transform::from_xyz(post_x, HEIGHT / 2.0, -0.02),
            ));
        }
    }
    // Labels: a row of three columns, left to right as the cloths stand.
    commands
        .spawn(Node {
            width: Val::Percent(100.0),
            padding: UiRect::all(Val::Px(10.0)),
            flex_direction: FlexDirection::Column,
            ..default()
        })
        .with_children(|root| {
            root.spawn((
                Text::new(""),
                TextFont::from_font_size(FontSize::Px(17.0)),
                Label(usize::MAX),
            ));
            root.spawn(Node {
                width: Val::Percent(100.0),
                justify_content: JustifyContent::SpaceAround,
                margin: UiRect::top(Val::Px(8.0)),
                ..default()
            })
            .with_children(|row| {
                for index in 0..METHODS.len() {
                    row.spawn((
                        Text::new(""),
                        TextFont::from_font_size(FontSize::Px(16.0)),
                        Node {
                            width: Val::Percent(30.0),
                            ..default()
                        },
                        Label(index),
                    ));
                }
            });
        });
}

/// Turns the camera to face the row of cloths.
fn face_the_row(mut cameras: Query<&mut OrbitCamera>) {
    for mut orbit in &mut cameras {
        orbit.yaw = 0.15;
        orbit.pitch = 0.25;
    }
}

/// The settings of one column: the method, the shared substeps, stiffnesses scaled from the
/// defaults, a ground plane.
fn settings(method: SolverMethod, substeps: u32, scale: f32, auto_substeps: bool) -> ClothSettings {
    let mut settings = ClothSettings { ..default() };
    settings.solver.method = method;
    settings.solver.substeps = substeps;
    settings.solver.auto_substeps = auto_substeps;
    let springs = &mut settings.solver.springs;
    for constants in [
        &mut springs.structural,
        &mut springs.shear,
        &mut springs.bend,
    ] {
        constants.stiffness *= scale;
    }
    settings
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut shared: ResMut<Shared>,
    mut drape: ResMut<DrapeSettings>,
    mut cloths: Query<&mut ClothSimulation>,
    mut last: ResMut<LastDivergence>,
) {
    if input.just_pressed(KeyCode::ArrowLeft) {
        shared.substeps = (shared.substeps / 2).max(1);
    }
    if input.just_pressed(KeyCode::ArrowRight) {
        shared.substeps = (shared.substeps * 2).min(4096);
    }
    if input.just_pressed(KeyCode::ArrowUp) {
        shared.stiffness_scale *= 2.0;
    }
    if input.just_pressed(KeyCode::ArrowDown) {
        shared.stiffness_scale *= 0.5;
    }
    if input.just_pressed(KeyCode::KeyA) {
        shared.auto_substeps = !shared.auto_substeps;
    }
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyR) {
        last.0.clear();
        for mut cloth in &mut cloths {
            cloth.reset();
            cloth.unfreeze();
        }
    }
}

fn apply_shared(shared: Res<Shared>, mut cloths: Query<(&Column, &mut ClothSettings)>) {
    if !shared.is_changed() {
        return;
    }
    for (column, mut current) in &mut cloths {
        let wanted = settings(
            column.method,
            shared.substeps,
            shared.stiffness_scale,
            shared.auto_substeps,
        );
        current.set_if_neq(wanted);
    }
}

fn record_divergence(
    mut messages: MessageReader<ClothDiverged>,
    mut last: ResMut<LastDivergence>,
    columns: Query<&Column>,
) {
    for message in messages.read() {
        let column = columns.get(message.cloth).map(|c| c.index).unwrap_or(0);
        warn!(
            "column {column} ({}) diverged: {}",
            message.method.name(),
            message.divergence
        );
        last.0.retain(|m| m.cloth != message.cloth);
        last.0.push(*message);
    }
}

fn labels(
    shared: Res<Shared>,
    cloths: Query<(Entity, &Column, &ClothSimulation)>,
    last: Res<LastDivergence>,
    mut texts: Query<(&Label, &mut Text, &mut TextColor)>,
) {
    for (label, mut text, mut colour) in &mut texts {
        if label.0 == usize::MAX {
            text.0 = format!(
                "{} substeps per 1/64 s step ({:.2} ms), springs x{} (k_structural {} N/m), \
                 automatic substeps {}\n\
                 Left/Right: substeps   Down/Up: stiffness   A: automatic substeps   \
                 R: reset   P: pause",
                shared.substeps,
                1000.0 / 64.0 / shared.substeps as f32,
                shared.stiffness_scale,
                1000.0 * shared.stiffness_scale,
                if shared.auto_substeps { "on" } else { "off" },
            );
            continue;
        }
        let Some((entity, column, simulation)) = cloths.iter().find(|(_, c, _)| c.index == label.0)
        else {
            continue;
        };
        let sim = simulation.solver();
        let mut line = format!(
            "{}\n{} substeps, max strain {:.2}%",
            column.method.name().to_uppercase(),
            sim.last_substeps(),
            sim.strain().max * 100.0
        );
        if simulation.is_frozen() {
            let why = last
                .0
                .iter()
                .find(|m| m.cloth == entity)
                .map(|m| m.divergence.to_string())
                .unwrap_or_default();
            line.push_str(&format!("\nDIVERGED ({why}): frozen"));
            colour.0 = Color::srgb(1.0, 0.35, 0.3);
        } else {
            colour.0 = Color::WHITE;
        }
        text.0 = line;
    }
}
