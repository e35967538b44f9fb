//! The poncho on a glTF character: the humanoid loaded from `characters/humanoid.glb` (see
//! [`crate::gltf_export`]) as a scene, animated by Bevy's `AnimationPlayer` playing the file's
//! `walk` animation, wearing the poncho with [`BoneColliders::humanoid`] attached to its joints
//! by name (the poncho is put on once they are there) and `FixedStepAnimation`, so the
//! player is stepped with the cloth. A [`CharacterController`] moves the scene's root through the world and sets the
//! animation's speed so the feet do not skate.
//!
//! [`GltfWalkPlugin`] gives each [`GltfCharacter`] the file's scene and plays its walk, from one
//! load of the file. [`GltfCharacterPlugin`] spawns everything but what is drawn; the `gltf_character` example
//! adds the camera and materials, [`headless_app`] runs it with `MinimalPlugins`.

use bevy::animation::graph::{AnimationGraph, AnimationGraphHandle, AnimationNodeIndex};
use bevy::animation::{AnimationClip, AnimationPlayer};
use bevy::gltf::Gltf;
use bevy::prelude::*;
use bevy::world_serialization::WorldAssetRoot;

use bevy_drape::cloth::plugin::{Cloth, ClothSettings};
use bevy_drape::cloth::render_mesh::ClothSimulationMesh;
use bevy_drape::collide::plugin::ClothCollider;
use bevy_drape::prelude::{FixedStepAnimation, humanoid};
use bevy_drape::schedule::DrapeSystems;
use bevy_drape::skeleton::clip::{Clip, ClipDesc};
use bevy_drape::skeleton::plugin::{BoneColliders, BoneProxyOf};

use crate::poncho::{CharacterController, CharacterMotion, Poncho, WavePlugin};

/// The character's file in the assets folder.
pub const CHARACTER_FILE: &str = "characters/humanoid.glb";

/// What [`GltfCharacterPlugin`] spawns.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct GltfCharacterScene {
    /// How the character moves.
    pub motion: CharacterMotion,
    /// Where the poncho starts above the character's root, metres.
    pub start_height: f32,
    /// How many characters, each in its poncho, side by side 2.5 m apart along x.
    pub characters: usize,
}

impl Default for GltfCharacterScene {
    fn default() -> Self {
        Self {
            motion: CharacterMotion::Walk,
            start_height: 1.5,
            characters: 1,
        }
    }
}

/// Marks the root entity of the glTF character (the one with the scene, the colliders and the
/// controller); [`GltfWalkPlugin`] gives it the file's scene.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct GltfCharacter;

/// The walk animation, once the file has loaded.
#[derive(Resource)]
struct Walk {
    file: Handle<Gltf>,
    graph: Option<(Handle<AnimationGraph>, AnimationNodeIndex)>,
}

/// Spawns the glTF character, the ground and the poncho, plays the walk and moves the
/// character (see the [module docs](self)).
#[derive(Default)]
pub struct GltfCharacterPlugin;

impl Plugin for GltfCharacterPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<bevy_obj::ObjPlugin>() {
            app.add_plugins(bevy_obj::ObjPlugin);
        }
        if !app.is_plugin_added::<GltfWalkPlugin>() {
            app.add_plugins(GltfWalkPlugin);
        }
        app.init_resource::<GltfCharacterScene>()
            .add_systems(Startup, spawn)
            .add_systems(Update, dress);
    }
}

/// The motion of every [`GltfCharacter`]: plays the file's `walk` animation on the players of
/// its scene and moves it by its [`CharacterController`] (the animation's speed following the
/// character's, so the feet do not skate), and waves the right hand of a
/// [`Waving`](crate::poncho::Waving) one by IK ([`WavePlugin`]); what a game's controller
/// does, not the crate's.
#[derive(Default)]
pub struct GltfWalkPlugin;

impl Plugin for GltfWalkPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<WavePlugin>() {
            app.add_plugins(WavePlugin);
        }
        app.add_systems(Startup, load_walk)
            .add_systems(Update, (give_scenes, play_walk))
            .add_systems(FixedUpdate, drive.before(DrapeSystems::Prepare));
    }
}

/// A controller for the glTF humanoid doing `motion`, its no-skate speed that of the file's
/// walk (the crate's walk clip).
pub fn walk_controller(motion: CharacterMotion) -> CharacterController {
    let mut controller = CharacterController::new(motion);
    let rig = humanoid();
    let feet: Vec<usize> = ["foot_l", "foot_r"]
        .iter()
        .filter_map(|f| rig.find(f))
        .collect();
    controller.stance_speed =
        ClipDesc::from_ron(include_str!("../../../assets/clips/walk.clip.ron"))
            .ok()
            .and_then(|desc| Clip::new(&desc, &rig).ok())
            .and_then(|clip| clip.stance_speed(&rig, &feet, Vec3::Z));
    controller
}

/// Gives every [`GltfCharacter`] without a scene the file's first scene, once the file has
/// loaded: the scene and the walk come from one load of the file. (A second load of the same
/// file, `GltfAssetLabel::Scene(0)` beside the whole file, parses it twice; the parse that
/// finishes last counts as a change of the scene, and Bevy spawns the scene anew.)
fn give_scenes(
    mut commands: Commands,
    walk: Option<Res<Walk>>,
    files: Res<Assets<Gltf>>,
    characters: Query<Entity, (With<GltfCharacter>, Without<WorldAssetRoot>)>,
) {
    let Some(scene) = walk
        .and_then(|walk| files.get(&walk.file))
        .and_then(|file| file.scenes.first())
    else {
        return;
    };
    for character in &characters {
        commands
            .entity(character)
            .insert(WorldAssetRoot(scene.clone()));
    }
}

fn load_walk(mut commands: Commands, server: Res<AssetServer>) {
    commands.insert_resource(Walk {
        file: server.load(CHARACTER_FILE),
        graph: None,
    });
}

/// A headless App (`MinimalPlugins`, transforms, assets, meshes, scenes, glTF and animation)
/// with [`bevy_drape::DrapePlugins`] and the scene, assets from the crate's folder, stepping
/// one 1/60 s fixed step per update.
pub fn headless_app(scene: GltfCharacterScene) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        bevy::transform::TransformPlugin,
        AssetPlugin {
            file_path: concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets").into(),
            ..default()
        },
        bevy::mesh::MeshPlugin,
        bevy::world_serialization::WorldSerializationPlugin,
        bevy::gltf::GltfPlugin::default(),
        bevy::animation::AnimationPlugin,
        bevy_drape::DrapePlugins::default(),
        GltfCharacterPlugin,
    ))
    .insert_resource(scene)
    .insert_resource(Time::<Fixed>::from_hz(60.0))
    .insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
        std::time::Duration::from_secs_f64(1.0 / 60.0),
    ));
    app.finish();
    app.cleanup();
    app
}

fn spawn(mut commands: Commands, scene: Res<GltfCharacterScene>) {
    let controller = walk_controller(scene.motion);
    for k in 0..scene.characters {
        commands.spawn((
            Name::new(format!("character {k}")),
            GltfCharacter,
            BoneColliders::humanoid(),
            // Its animation stepped with the cloth, not once per rendered frame.
            FixedStepAnimation,
            controller.clone(),
            Transform::from_xyz(2.5 * k as f32, 0.0, 0.0),
        ));
    }
    commands.spawn((
        Name::new("ground"),
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
}

/// Puts the poncho on each character once its proxies are on its joints (the scene spawns
/// some frames after it is asked for; a cloth dropped before would fall through the body),
/// `start_height` above the character's root.
fn dress(
    mut commands: Commands,
    scene: Res<GltfCharacterScene>,
    server: Res<AssetServer>,
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
            Cloth::worn_by(character),
            ClothSettings::default(),
            Transform::from_translation(transform.translation + Vec3::Y * scene.start_height)
                .with_rotation(transform.rotation),
        ));
    }
}

/// Marks a character that has its poncho.
#[derive(Component)]
struct Dressed;

/// Starts the file's `walk` on every animation player of the scene, looping, once the file
/// and the scene are there.
fn play_walk(
    mut commands: Commands,
    walk: Option<ResMut<Walk>>,
    files: Res<Assets<Gltf>>,
    mut graphs: ResMut<Assets<AnimationGraph>>,
    mut players: Query<(Entity, &mut AnimationPlayer), Without<AnimationGraphHandle>>,
) {
    let Some(mut walk) = walk else {
        return;
    };
    if walk.graph.is_none() {
        let Some(clip) = files
            .get(&walk.file)
            .and_then(|file| file.named_animations.get("walk"))
        else {
            return;
        };
        let (graph, node) = AnimationGraph::from_clip(Handle::<AnimationClip>::clone(clip));
        walk.graph = Some((graphs.add(graph), node));
    }
    let Some((graph, node)) = &walk.graph else {
        return;
    };
    for (entity, mut player) in &mut players {
        player.play(*node).repeat();
        commands
            .entity(entity)
            .insert(AnimationGraphHandle(graph.clone()));
    }
}

/// Moves each character along its motion and plays its walk at the matching speed.
fn drive(
    mut characters: Query<(Entity, &mut CharacterController, &mut Transform), With<GltfCharacter>>,
    children: Query<&Children>,
    mut players: Query<&mut AnimationPlayer>,
    time: Res<Time>,
) {
    for (entity, mut controller, mut transform) in &mut characters {
        let Some(player) = children
            .iter_descendants(entity)
            .find(|&e| players.contains(e))
        else {
            // The scene has not spawned yet: the character waits.
            continue;
        };
        let speed = controller.advance(time.delta_secs(), &mut transform);
        if let Ok(mut player) = players.get_mut(player) {
            for (_, animation) in player.playing_animations_mut() {
                animation.set_speed(speed);
            }
        }
    }
}
