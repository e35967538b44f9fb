//! The main scene: a poncho drapes over a character that walks in place and now and then
//! waves its right hand (inverse kinematics on top of the walk clip). Capsule and sphere
//! proxies on the bones hold the cloth; self-collision keeps its folds apart.
//!
//! ```text
//! cargo run --release --features render --example poncho
//! ```
//!
//! With no display (no `DISPLAY` or `WAYLAND_DISPLAY`) it renders offscreen into a few PNG
//! frames (see `examples/common/offscreen.rs` for where and how many), then prints the scene's
//! S3 figures.
//!
//! W toggles the wave, S self-collision, R resets the poncho, P pauses, C cycles the debug
//! colours; drag the poncho with the left mouse button, orbit with the right one, scroll to
//! zoom.

mod common;

use bevy::prelude::*;
use bevy_drape::poncho::{Poncho, PonchoScene, PonchoScenePlugin, run_headless};
use bevy_drape::prelude::*;
use common::offscreen::{OffscreenPlugin, has_display, headless_default_plugins};
use common::{ExamplePlugin, cloth_material, dress_humanoids, spawn_stage};

fn main() {
    let mut app = App::new();
    let windowed = has_display();
    if windowed {
        app.add_plugins((DefaultPlugins, ExamplePlugin));
    } else {
        println!("no display: rendering offscreen");
        app.add_plugins((
            headless_default_plugins(),
            OffscreenPlugin::from_env("poncho"),
        ));
    }
    app.add_plugins((DrapePlugins::default(), PonchoScenePlugin))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .add_systems(Startup, setup)
        .add_systems(Update, (dress_humanoids, dress_poncho, keys, label));
    app.run();
    if !windowed {
        print_s3_figures();
    }
}

/// Runs the scene headless for 10 s and prints its S3 figures (as `cargo run --release
/// --example scenes -- s3` does).
fn print_s3_figures() {
    let scene = PonchoScene::default();
    let solver = scene.solver;
    let run = run_headless(scene, 600);
    println!("S3 (10 s headless): {}", run.json(&solver));
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
        Vec3::new(0.0, 1.0, 0.0),
        2.4,
    );
    commands.spawn((
        Text::new(""),
        TextFont::from_font_size(FontSize::Px(16.0)),
        Node {
            position_type: PositionType::Absolute,
            bottom: Val::Px(10.0),
            right: Val::Px(10.0),
            ..default()
        },
        Label,
    ));
}

/// Gives the poncho its material once it is spawned.
fn dress_poncho(
    mut commands: Commands,
    ponchos: Query<Entity, Added<Poncho>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    for poncho in &ponchos {
        commands
            .entity(poncho)
            .insert(MeshMaterial3d(cloth_material(
                &mut materials,
                Color::srgb(0.75, 0.25, 0.2),
            )));
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut drape: ResMut<DrapeSettings>,
    mut scene: ResMut<PonchoScene>,
    mut ponchos: Query<(&mut ClothSimulation, &mut ClothSettings), With<Poncho>>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyW) {
        scene.wave = !scene.wave;
    }
    for (mut simulation, mut settings) in &mut ponchos {
        if input.just_pressed(KeyCode::KeyR) {
            simulation.sim_mut().reset();
        }
        if input.just_pressed(KeyCode::KeyS) {
            settings.solver.self_collision = !settings.solver.self_collision;
        }
    }
}

fn label(
    timings: Res<DrapeTimings>,
    scene: Res<PonchoScene>,
    ponchos: Query<(&ClothSimulation, &ClothSettings), With<Poncho>>,
    mut labels: Query<&mut Text, With<Label>>,
) {
    let Ok((simulation, settings)) = ponchos.single() else {
        return;
    };
    let sim = simulation.sim();
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    for mut text in &mut labels {
        text.0 = format!(
            "poncho: {} particles, {} x {} XPBD, self-collision {} (S), wave {} (W)\n\
             fixed step {:.2} ms: animation {:.2}, IK {:.2}, colliders {:.2}, cloth {:.2}\n\
             max strain {:.1}%, {} collider contacts, {} self-contacts",
            sim.state().len(),
            settings.solver.substeps,
            settings.solver.iterations,
            if settings.solver.self_collision {
                "on"
            } else {
                "off"
            },
            if scene.wave { "on" } else { "off" },
            ms(timings.total()),
            ms(timings.animation),
            ms(timings.inverse_kinematics),
            ms(timings.colliders),
            ms(timings.cloth),
            100.0 * sim.strain().max,
            sim.contact_count(),
            sim.self_contact_count(),
        );
    }
}
