//! A glTF character wears the poncho: `assets/characters/humanoid.glb` (the crate's humanoid
//! written as a skinned model with its walk, `cargo run --example generate_character`) is
//! loaded as a scene and animated by Bevy's `AnimationPlayer`, like any model from a file.
//! `BoneColliders::humanoid()` on the scene's root attaches capsules to its joints by name;
//! the poncho is worn by the root, which walks through the world and, as in the main scene,
//! waves its right hand by inverse kinematics on the file's joints (raised between 2 s and 6 s
//! of every 8 s).
//!
//! ```text
//! cargo run --release --features render --example gltf_character
//! ```
//!
//! `setup` and `put_on_poncho` below spawn the character, its IK goal and its poncho with the
//! crate's API; giving the `GltfCharacter` the file's scene and playing its walk (from one load
//! of the file), moving the character through the world and moving the wave's target and
//! weight (a game's controller) come from the measuring harness
//! (`drape_scenes::gltf_character::GltfWalkPlugin`, which waves every `Waving` entity).
//!
//! R resets the poncho; orbit with the right mouse button, scroll to zoom. With no display it
//! renders a few PNG frames offscreen; with no graphics adapter it runs the scene headless and
//! prints where the poncho ended.

mod common;

use bevy::prelude::*;
use bevy_drape::interact::adapter::find_graphics_adapter;
use bevy_drape::prelude::*;
use bevy_drape::skeleton::ik::JointLimits;
use bevy_drape::skeleton::plugin::BoneProxyOf;
use common::offscreen::{OffscreenPlugin, has_display, headless_default_plugins};
use common::{ExamplePlugin, cloth_material, follow_with_camera, spawn_ground_tiles, spawn_stage};
use drape_scenes::gltf_character::{
    GltfCharacter, GltfCharacterScene, GltfWalkPlugin, walk_controller,
};
use drape_scenes::poncho::{CharacterMotion, Poncho, WRIST, Waving, wave_at};

fn main() {
    if let Err(reason) = find_graphics_adapter() {
        println!("gltf_character: {reason}; running the scene headless instead");
        run_headless();
        return;
    }
    let mut app = App::new();
    if has_display() {
        app.add_plugins((DefaultPlugins, ExamplePlugin));
    } else {
        println!("no display: rendering offscreen");
        app.add_plugins((
            headless_default_plugins(),
            OffscreenPlugin::from_env("gltf_character"),
        ));
    }
    app.add_plugins((
        DrapePlugins::default(),
        bevy_drape::bevy_obj::ObjPlugin,
        GltfWalkPlugin,
    ))
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .add_systems(Startup, setup)
    .add_systems(
        Update,
        (put_on_poncho, keys, follow_with_camera::<GltfCharacter>),
    )
    .run();
}

/// Ten seconds of the scene without a renderer; prints the poncho's centroid and the
/// character's position.
fn run_headless() {
    let mut app = drape_scenes::gltf_character::headless_app(GltfCharacterScene::default());
    for _ in 0..900 {
        app.update();
    }
    let world = app.world_mut();
    let character = world
        .query_filtered::<&Transform, With<GltfCharacter>>()
        .single(world)
        .map(|t| t.translation);
    let centroid = world
        .query_filtered::<&ClothSimulation, With<Poncho>>()
        .single(world)
        .map(|s| {
            s.solver()
                .state()
                .positions
                .iter()
                .copied()
                .sum::<bevy::math::Vec3A>()
                / s.solver().state().len().max(1) as f32
        });
    println!("character at {character:?}, poncho centroid at {centroid:?}");
}

/// The stage, a ground collider, and the character: the glTF scene (given by `GltfWalkPlugin`
/// once the file has loaded), capsule proxies on its
/// joints found by name, its animation stepped with the cloth, and the wave's IK goal on its
/// right arm.
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
        Name::new("ground"),
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    commands.spawn((
        Name::new("character"),
        GltfCharacter,
        BoneColliders::humanoid(),
        FixedStepAnimation,
        walk_controller(CharacterMotion::Tour),
        wave_goal(),
        Waving,
        Transform::default(),
    ));
}

/// The wave: the right wrist on a target in the character's frame, on the file's joints found
/// by name. Each joint is a ball joint: `upper_arm_r` is the whole shoulder (the file's
/// `shoulder_r` is a node at the same point), the elbow a hinge about its x axis. The weight
/// and target are moved by the harness's wave (`drape_scenes::poncho::wave_at`).
fn wave_goal() -> InverseKinematics {
    InverseKinematics {
        goals: vec![IkGoal {
            end_bone: "forearm_r".into(),
            length: 2,
            effector: WRIST,
            target: IkTarget::CharacterPoint(wave_at(0.0).1),
            settings: IkSettings::default(),
            weight: 0.0,
            max_speed: IkGoal::DEFAULT_MAX_SPEED,
            // From the end joint up: the elbow bends one way only; the shoulder is free.
            joint_limits: vec![JointLimits::hinge_x(-2.5, 0.0)],
        }],
        results: Vec::new(),
    }
}

/// Puts the poncho on the character once its proxies are on its joints (the scene has spawned),
/// so it does not fall through a body that is not there yet.
fn put_on_poncho(
    mut commands: Commands,
    server: Res<AssetServer>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    characters: Query<(Entity, &Transform, Has<Dressed>), With<GltfCharacter>>,
    proxies: Query<&BoneProxyOf>,
) {
    for (character, transform, dressed) in &characters {
        if dressed || !proxies.iter().any(|of| of.0 == character) {
            continue;
        }
        commands.entity(character).insert(Dressed);
        commands.spawn((
            Name::new("poncho"),
            Poncho,
            Mesh3d(server.load("meshes/poncho.obj")),
            ClothSimulationMesh(server.load("meshes/poncho_coarse.obj")),
            MeshMaterial3d(cloth_material(&mut materials, Color::srgb(0.75, 0.25, 0.2))),
            Cloth::worn_by(character),
            ClothSettings::default(),
            Transform::from_translation(transform.translation + 1.5 * Vec3::Y)
                .with_rotation(transform.rotation),
        ));
    }
}

/// A character wearing its poncho.
#[derive(Component)]
struct Dressed;

fn keys(input: Res<ButtonInput<KeyCode>>, mut ponchos: Query<&mut ClothSimulation, With<Poncho>>) {
    if input.just_pressed(KeyCode::KeyR) {
        for mut simulation in &mut ponchos {
            simulation.reset();
        }
    }
}
