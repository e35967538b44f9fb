//! The main scene: a poncho drapes over a character that walks through the world (walks,
//! stops, turns, jogs and comes back) and now and then waves its right hand (inverse
//! kinematics on top of the walk clip). Capsule and sphere proxies on the bones hold the
//! cloth; self-collision keeps its folds apart; the camera follows the character.
//!
//! ```text
//! cargo run --features egui --example poncho
//! cargo run --features egui --example poncho -- --shawl   # with the shawl under the poncho
//! ```
//!
//! `spawn_character_and_poncho` below spawns both with the crate's API; the walking, jogging
//! and turning (a game's character controller) and the headless figures come from the
//! measuring harness (`drape_scenes`). With no display it renders offscreen into a few PNG
//! frames (`examples/common/offscreen.rs`), then prints the scene's S3 figures; with no graphics
//! adapter it says so, runs the scene headless and prints its figures.
//!
//! 1 to 5 switch the motion (in place, walk, jog, teleport, the tour), W the wave, B a gusting
//! breeze, S cycles the self-collision method, L puts a shawl under the poncho (the two
//! stepped as layers) or takes it away, R resets the poncho, P pauses, C cycles the debug colours; drag the
//! poncho with the left mouse button, orbit with the right one, scroll to zoom.

mod common;

use std::sync::Arc;

use bevy::prelude::*;
use bevy_drape::cloth::DivergenceBounds;
use bevy_drape::interact::adapter::find_graphics_adapter;
use bevy_drape::prelude::*;
use bevy_drape::schedule::DrapeTimings;
use common::offscreen::{OffscreenPlugin, has_display, headless_default_plugins};
use common::{
    ExamplePlugin, cloth_material, dress_humanoids, follow_with_camera, spawn_ground_tiles,
    spawn_stage,
};
use drape_scenes::poncho::{
    Character, CharacterController, CharacterMotion, CharacterMotionPlugin, LAYER_GAP, PonchoScene,
    SHAWL, WRIST, Waving, poncho_mesh, run_headless,
};

/// Marks the poncho.
#[derive(Component)]
struct Poncho;

/// Marks the shawl under the poncho (L).
#[derive(Component)]
struct Shawl;

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
    app.add_plugins((
        DrapePlugins::default(),
        bevy_drape::bevy_obj::ObjPlugin,
        CharacterMotionPlugin,
    ))
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(Wind::default())
    .insert_resource(ShawlAtStart(std::env::args().any(|a| a == "--shawl")))
    .add_systems(Startup, (setup, spawn_character_and_poncho))
    .add_systems(
        Update,
        (
            dress_humanoids,
            keys,
            toggle_shawl,
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

/// The character: the humanoid rig playing the walk clip, capsule and sphere proxies on its
/// bones, an IK goal on its right arm (its weight and target moved by the wave), and a
/// controller that moves it through the world. The poncho: drawn with 41 x 41 vertices,
/// simulated on 17 x 17, worn by the character, on a ground collider.
fn spawn_character_and_poncho(
    mut commands: Commands,
    mut materials: ResMut<Assets<StandardMaterial>>,
    assets: Res<AssetServer>,
) {
    commands.spawn((
        Name::new("ground"),
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    let character = commands
        .spawn((
            Name::new("character"),
            Skeleton {
                rig: Arc::new(humanoid()),
            },
            BoneColliders::humanoid(),
            ClipPlayer::new(assets.load("clips/walk.clip.ron")),
            InverseKinematics {
                goals: vec![IkGoal {
                    end_bone: "forearm_r".into(),
                    length: 3, // the shoulder's two hinges and the elbow
                    effector: WRIST,
                    target: IkTarget::CharacterPoint(Vec3::new(-0.38, 1.72, 0.12)),
                    settings: IkSettings::default(),
                    weight: 0.0,
                    max_speed: IkGoal::DEFAULT_MAX_SPEED,
                    joint_limits: Vec::new(),
                }],
                results: Vec::new(),
            },
            (Character, CharacterController::new(START_MOTION), Waving),
            Transform::default(),
        ))
        .id();
    commands.spawn(poncho(&mut materials, &assets, character, 1.5));
}

/// The poncho worn by `character`, flat at `height` above it: drawn with 41 x 41 vertices,
/// simulated on 17 x 17.
fn poncho(
    materials: &mut Assets<StandardMaterial>,
    assets: &AssetServer,
    character: Entity,
    height: f32,
) -> impl Bundle {
    (
        Name::new("poncho"),
        Poncho,
        Mesh3d(assets.load("meshes/poncho.obj")),
        ClothSimulationMesh(assets.load("meshes/poncho_coarse.obj")),
        MeshMaterial3d(cloth_material(materials, Color::srgb(0.75, 0.25, 0.2))),
        Cloth::worn_by(character),
        poncho_settings(),
        Transform::from_xyz(0.0, height, 0.0),
    )
}

/// The poncho's settings: the scene S3 measures (`scenes -- s3`), in air (B turns a breeze
/// on). The shawl under it (L) has the same.
fn poncho_settings() -> ClothSettings {
    ClothSettings {
        density: 0.25,
        solver: SolverSettings {
            self_collision: SelfCollisionMethod::Particles,
            shear_compliance: 0.1,
            air: Some(AirSettings::default()),
            ..default()
        },
        divergence: DivergenceBounds {
            max_strain: 2.0,
            ..default()
        },
        ..default()
    }
}

/// The poncho and the shawl.
type Garments<'w, 's> = Query<'w, 's, Entity, Or<(With<Poncho>, With<Shawl>)>>;

/// `--shawl`: the scene starts with the shawl under the poncho, as if L was pressed.
#[derive(Resource)]
struct ShawlAtStart(bool);

/// L: a shawl under the poncho, or none. Both garments are dropped again from above the
/// character, the shawl first, and stepped as layers of one solve (`ClothLayers`).
#[allow(clippy::too_many_arguments)]
fn toggle_shawl(
    input: Res<ButtonInput<KeyCode>>,
    mut at_start: ResMut<ShawlAtStart>,
    mut commands: Commands,
    characters: Query<(Entity, &Transform, Has<ClothLayers>), With<Character>>,
    garments: Garments,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    assets: Res<AssetServer>,
) {
    if !(input.just_pressed(KeyCode::KeyL) || std::mem::take(&mut at_start.0)) {
        return;
    }
    let Ok((character, transform, layered)) = characters.single() else {
        return;
    };
    for garment in &garments {
        commands.entity(garment).despawn();
    }
    // Above the character, turned as it is (its entity is what the garments follow).
    let place = |height: f32| {
        Transform::from_translation(transform.translation + Vec3::Y * height)
            .with_rotation(transform.rotation)
    };
    if layered {
        commands.entity(character).remove::<ClothLayers>();
        commands
            .spawn(poncho(&mut materials, &assets, character, 0.0))
            .insert(place(1.5));
        return;
    }
    let shawl = commands
        .spawn((
            Name::new("shawl"),
            Shawl,
            Mesh3d(meshes.add(poncho_mesh(&SHAWL))),
            MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.85, 0.75, 0.3))),
            Cloth::worn_by(character),
            poncho_settings(),
            place(1.5),
        ))
        .id();
    let outer = commands
        .spawn(poncho(&mut materials, &assets, character, 0.0))
        .insert(place(1.5 + LAYER_GAP))
        .id();
    commands
        .entity(character)
        .insert(ClothLayers(vec![shawl, outer]));
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
    spawn_ground_tiles(&mut commands, &mut meshes, &mut materials);
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
    mut commands: Commands,
    mut drape: ResMut<DrapeSettings>,
    mut characters: Query<(Entity, &mut CharacterController, Has<Waving>)>,
    mut ponchos: Query<(&mut ClothSimulation, &mut ClothSettings), With<Poncho>>,
    mut wind: ResMut<Wind>,
) {
    use KeyCode::{Digit1, Digit2, Digit3, Digit4, Digit5};
    let motion_keys = [Digit1, Digit2, Digit3, Digit4, Digit5];
    for (key, motion) in motion_keys.into_iter().zip(CharacterMotion::ALL) {
        for (_, mut controller, _) in &mut characters {
            if input.just_pressed(key) {
                controller.switch_to(motion);
            }
        }
    }
    for (character, _, waving) in &characters {
        if input.just_pressed(KeyCode::KeyW) {
            match waving {
                true => commands.entity(character).remove::<Waving>(),
                false => commands.entity(character).insert(Waving),
            };
        }
    }
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
    for (mut simulation, mut settings) in &mut ponchos {
        if input.just_pressed(KeyCode::KeyR) {
            simulation.reset();
        }
        if input.just_pressed(KeyCode::KeyS) {
            // The next method: off, particles, triangles.
            let methods = SelfCollisionMethod::ALL;
            let at = methods
                .iter()
                .position(|&m| m == settings.solver.self_collision);
            settings.solver.self_collision = methods[at.map_or(0, |i| (i + 1) % methods.len())];
        }
    }
}

fn label(
    timings: Res<DrapeTimings>,
    ponchos: Query<(&ClothSimulation, &ClothSettings), With<Poncho>>,
    controllers: Query<(&CharacterController, Has<Waving>, Has<ClothLayers>)>,
    mut labels: Query<&mut Text, With<Label>>,
) {
    let (motion, speed, waving, layered) = controllers
        .single()
        .map_or(("-", 0.0, false, false), |(c, w, l)| {
            (c.motion.name(), c.speed, w, l)
        });
    let Ok((simulation, settings)) = ponchos.single() else {
        return;
    };
    let sim = simulation.solver();
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
    for mut text in &mut labels {
        text.0 = format!(
            "motion {motion} (1-5), {speed:.1} m/s\n\
             poncho: {} particles, {} x {} XPBD, self-collision {} (S), wave {} (W), shawl {} (L)\n\
             fixed step {:.2} ms: animation {:.2}, IK {:.2}, colliders {:.2}, cloth {:.2}\n\
             max strain {:.1}%, {} collider contacts, {} self-contacts",
            sim.state().len(),
            settings.solver.substeps,
            settings.solver.iterations,
            settings.solver.self_collision.name(),
            if waving { "on" } else { "off" },
            if layered { "under it" } else { "off" },
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
