//! A glTF character wears the poncho: `assets/characters/humanoid.glb` (the crate's humanoid
//! written as a skinned model with its walk, `cargo run --example generate_character`) is
//! loaded as a scene and animated by Bevy's `AnimationPlayer`, like any model from a file.
//! `BoneColliders::humanoid()` on the scene's root attaches capsules to its joints by name;
//! the poncho is worn by the root, which walks through the world.
//!
//! ```text
//! cargo run --release --features render --example gltf_character
//! ```
//!
//! 1 to 5 switch the motion (in place, walk, jog, teleport, the tour), R resets the poncho;
//! orbit with the right mouse button, scroll to zoom. With no display it renders a few PNG
//! frames offscreen; with no graphics adapter it runs the scene headless and prints where the
//! poncho ended.

mod common;

use bevy::prelude::*;
use bevy_drape::interact::adapter::find_graphics_adapter;
use bevy_drape::prelude::*;
use common::offscreen::{OffscreenPlugin, has_display, headless_default_plugins};
use common::{ExamplePlugin, dress_ponchos, follow_with_camera, spawn_stage, switch_motion};
use drape_scenes::gltf_character::{GltfCharacter, GltfCharacterPlugin, GltfCharacterScene};
use drape_scenes::poncho::{CharacterMotion, Poncho};

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
    app.add_plugins((DrapePlugins::default(), GltfCharacterPlugin))
        .insert_resource(Time::<Fixed>::from_hz(60.0))
        .insert_resource(GltfCharacterScene {
            motion: CharacterMotion::Tour,
            ..default()
        })
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (
                dress_ponchos,
                keys,
                switch_motion,
                follow_with_camera::<GltfCharacter>,
            ),
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
}

fn keys(input: Res<ButtonInput<KeyCode>>, mut ponchos: Query<&mut ClothSimulation, With<Poncho>>) {
    if input.just_pressed(KeyCode::KeyR) {
        for mut simulation in &mut ponchos {
            simulation.reset();
        }
    }
}
