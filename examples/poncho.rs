//! The main scene: a poncho drapes over a character that walks through the world (walks,
//! stops, turns, jogs and comes back) and now and then waves its right hand (inverse
//! kinematics on top of the walk clip). Capsule and sphere proxies on the bones hold the
//! cloth; self-collision keeps its folds apart; the camera follows the character.
//!
//! ```text
//! cargo run --release --features render --example poncho
//! ```
//!
//! With no display (no `DISPLAY` or `WAYLAND_DISPLAY`) it renders offscreen into a few PNG
//! frames (see `examples/common/offscreen.rs` for where and how many), then prints the scene's
//! S3 figures. With no graphics adapter at all (no GPU, no Vulkan driver) it says so, runs the
//! scene headless and prints its figures.
//!
//! 1 to 5 switch the motion (in place, walk, jog, teleport, the tour), W toggles the wave, B
//! a gusting breeze (the poncho meets the air, `SolverSettings::air`), S
//! self-collision, R resets the poncho, P pauses, C cycles the debug colours; drag the poncho
//! with the left mouse button, orbit with the right one, scroll to zoom.

mod common;

use bevy::prelude::*;
use bevy_drape::interact::adapter::find_graphics_adapter;
use bevy_drape::prelude::*;
use common::offscreen::{OffscreenPlugin, has_display, headless_default_plugins};
use common::{
    ExamplePlugin, dress_humanoids, dress_ponchos, follow_with_camera, spawn_stage, switch_motion,
};
use drape_scenes::poncho::{
    Character, CharacterController, CharacterMotion, Poncho, PonchoScene, PonchoScenePlugin,
    run_headless,
};

/// The wind the B key turns on and off: 3 m/s from the character's left, gusting.
const BREEZE: Wind = Wind {
    velocity: Vec3::new(3.0, 0.0, 0.0),
    gusts: Gusts {
        strength: 1.0,
        frequency: 0.5,
        length: 4.0,
        seed: 3,
    },
};

/// The motion the example starts with.
const START_MOTION: CharacterMotion = CharacterMotion::Tour;

fn main() {
    if let Err(reason) = find_graphics_adapter() {
        println!("poncho: {reason}; running the scene headless instead");
        print_s3_figures();
        return;
    }
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
        .insert_resource(PonchoScene {
            motion: START_MOTION,
            // The poncho meets the air (the S3 figures are in vacuum); B turns a breeze on.
            solver: SolverSettings {
                air: Some(AirSettings::default()),
                ..PonchoScene::default().solver
            },
            ..default()
        })
        .insert_resource(Wind::default())
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (
                dress_humanoids,
                dress_ponchos,
                keys,
                switch_motion,
                label,
                follow_with_camera::<Character>,
            ),
        );
    app.run();
    if !windowed {
        print_s3_figures();
    }
}

/// Runs the scene headless for 10 s and prints its S3 figures (as `cargo run --release
/// --example scenes -- s3 --motion walk` does).
fn print_s3_figures() {
    let scene = PonchoScene {
        motion: CharacterMotion::Walk,
        ..default()
    };
    let solver = scene.solver;
    match run_headless(scene, 600) {
        Ok(run) => println!("S3 (10 s headless): {}", run.json(&solver)),
        Err(e) => println!("S3: {e}"),
    }
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
        3.2,
    );
    // A checkerboard of 1 m tiles on the ground, so the walk shows against it.
    let tile = meshes.add(Plane3d::default().mesh().size(1.0, 1.0));
    let dark = materials.add(StandardMaterial {
        base_color: Color::srgb(0.45, 0.48, 0.43),
        perceptual_roughness: 0.9,
        ..default()
    });
    for i in -12..12 {
        for j in -12..12 {
            if (i + j) % 2 == 0 {
                commands.spawn((
                    Mesh3d(tile.clone()),
                    MeshMaterial3d(dark.clone()),
                    Transform::from_xyz(i as f32 + 0.5, 0.002, j as f32 + 0.5),
                ));
            }
        }
    }
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

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut drape: ResMut<DrapeSettings>,
    mut scene: ResMut<PonchoScene>,
    mut ponchos: Query<(&mut ClothSimulation, &mut ClothSettings), With<Poncho>>,
    mut wind: ResMut<Wind>,
) {
    if input.just_pressed(KeyCode::KeyB) {
        *wind = if wind.velocity == Vec3::ZERO {
            BREEZE
        } else {
            Wind::default()
        };
    }
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyW) {
        scene.wave = !scene.wave;
    }
    for (mut simulation, mut settings) in &mut ponchos {
        if input.just_pressed(KeyCode::KeyR) {
            simulation.reset();
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
    controllers: Query<&CharacterController>,
    mut labels: Query<&mut Text, With<Label>>,
) {
    let (motion, speed) = controllers
        .single()
        .map_or(("-", 0.0), |c| (c.motion.name(), c.speed));
    let Ok((simulation, settings)) = ponchos.single() else {
        return;
    };
    let sim = simulation.solver();
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    for mut text in &mut labels {
        text.0 = format!(
            "motion {motion} (1-5), {speed:.1} m/s\n\
             poncho: {} particles, {} x {} XPBD, self-collision {} (S), wave {} (W)\n\
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
