//! The humanoid (19 hinge bones, depth 7) walking by its keyframed clip, on a circle.
//!
//! ```text
//! cargo run --features render --example skeleton
//! ```
//!
//! G toggles the ghosts: the clip's keyframe poses as stick figures and the pelvis's path.
//! W switches between the walk and the wave. P pauses; drag to orbit, scroll to zoom.

mod common;

use std::sync::Arc;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use bevy_drape::skeleton::clip::Clip;
use bevy_drape::skeleton::plugin::{ClipAsset, SkeletonBones};
use common::{ExamplePlugin, dress_humanoids, spawn_stage};

/// Radius of the circle the character walks on, metres.
const CIRCLE: f32 = 1.5;
/// Walking speed along the circle, m/s (about one stride per clip cycle).
const SPEED: f32 = 0.9;

fn main() {
    if !common::has_graphics_adapter("skeleton") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .insert_resource(Ghosts(true))
        .init_resource::<Trail>()
        .add_systems(Startup, setup)
        .add_systems(Update, (dress_humanoids, keys))
        // After transform propagation, so the ghosts stand where the character is drawn.
        .add_systems(
            PostUpdate,
            draw_ghosts.after(bevy::transform::TransformSystems::Propagate),
        )
        .add_systems(FixedUpdate, walk_the_circle)
        .run();
}

#[derive(Resource)]
struct Ghosts(bool);

/// The pelvis's recent world positions.
#[derive(Resource, Default)]
struct Trail(Vec<Vec3>);

#[derive(Resource)]
struct Clips {
    walk: Handle<ClipAsset>,
    wave: Handle<ClipAsset>,
}

#[derive(Component)]
struct Walker {
    angle: f32,
    walking: bool,
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
        Vec3::new(0.0, 0.8, 0.0),
        5.0,
    );
    let clips = Clips {
        walk: assets.load("clips/walk.clip.ron"),
        wave: assets.load("clips/wave.clip.ron"),
    };
    commands.spawn((
        Skeleton {
            rig: Arc::new(humanoid()),
        },
        ClipPlayer::new(clips.walk.clone()),
        Walker {
            angle: 0.0,
            walking: true,
        },
        Transform::from_xyz(CIRCLE, 0.0, 0.0),
        Visibility::default(),
    ));
    commands.insert_resource(clips);
}

/// Moves the character along the circle, facing its direction of travel.
fn walk_the_circle(mut walkers: Query<(&mut Walker, &mut Transform)>, time: Res<Time>) {
    for (mut walker, mut transform) in &mut walkers {
        if walker.walking {
            walker.angle += SPEED / CIRCLE * time.delta_secs();
        }
        let a = walker.angle;
        transform.translation = Vec3::new(CIRCLE * a.cos(), 0.0, -CIRCLE * a.sin());
        // Counter-clockwise seen from above: the travel direction is (-sin, 0, -cos).
        transform.rotation = Quat::from_rotation_y(a + std::f32::consts::PI);
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut ghosts: ResMut<Ghosts>,
    mut drape: ResMut<DrapeSettings>,
    clips: Res<Clips>,
    mut players: Query<(&mut ClipPlayer, &mut Walker)>,
) {
    if input.just_pressed(KeyCode::KeyG) {
        ghosts.0 = !ghosts.0;
    }
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::KeyW) {
        for (mut player, mut walker) in &mut players {
            walker.walking = !walker.walking;
            let clip = if walker.walking {
                &clips.walk
            } else {
                &clips.wave
            };
            *player = ClipPlayer::new(clip.clone());
        }
    }
}

/// Stick figures of the clip's keyframe poses at the character, and the pelvis's path.
fn draw_ghosts(
    mut gizmos: Gizmos,
    ghosts: Res<Ghosts>,
    mut trail: ResMut<Trail>,
    characters: Query<(&Skeleton, &ClipPlayer, &GlobalTransform, &SkeletonBones)>,
    bones: Query<&GlobalTransform>,
    clips: Res<Assets<ClipAsset>>,
) {
    for (skeleton, player, global, skeleton_bones) in &characters {
        if let Some(pelvis) = skeleton_bones.get("pelvis").and_then(|e| bones.get(e).ok())
            && pelvis.translation().y > 0.5
        {
            trail.0.push(pelvis.translation());
            if trail.0.len() > 600 {
                trail.0.remove(0);
            }
        }
        if !ghosts.0 {
            continue;
        }
        gizmos.linestrip(trail.0.iter().copied(), Color::srgb(0.9, 0.8, 0.2));
        let Some(asset) = clips.get(&player.clip) else {
            continue;
        };
        let Ok(clip) = Clip::new(&asset.0, &skeleton.rig) else {
            continue;
        };
        let rig = &skeleton.rig;
        let mut pose = rig.rest_pose();
        let mut rate = bevy_drape::skeleton::rig::PoseRate {
            root_velocity: Vec3::ZERO,
            root_angular_velocity: Vec3::ZERO,
            angle_rates: Vec::new(),
        };
        let mut states = Vec::new();
        let keys = asset.0.times.len();
        for (k, &t) in asset.0.times.iter().enumerate() {
            clip.sample(t - asset.0.times[0], &mut pose, &mut rate);
            rig.forward(&pose, None, &mut states);
            let hue = 360.0 * k as f32 / keys as f32;
            let colour = Color::hsla(hue, 0.8, 0.6, 0.7);
            for (b, bone) in rig.bones().iter().enumerate() {
                if let Some(p) = bone.parent {
                    gizmos.line(
                        global.transform_point(states[p].translation),
                        global.transform_point(states[b].translation),
                        colour,
                    );
                }
            }
        }
    }
}
