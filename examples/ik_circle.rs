//! The humanoid walks in place by its keyframes while inverse kinematics (FABRIK on the
//! shoulder's two hinges and the elbow) keeps its right wrist on a circle in front of it. The
//! gizmos draw the target circle (yellow) and the wrist's actual trace (red): where they part,
//! the arm cannot reach.
//!
//! ```text
//! cargo run --features render --example ik_circle
//! ```
//!
//! Up / Down change the circle's radius. P pauses; drag to orbit, scroll to zoom.

mod common;

use std::sync::Arc;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use bevy_drape::skeleton::plugin::SkeletonPose;
use common::{ExamplePlugin, dress_humanoids, spawn_stage};

/// The circle's centre in front of the right shoulder, metres.
const CENTRE: Vec3 = Vec3::new(-0.22, 1.3, 0.32);
/// Seconds per turn.
const PERIOD: f32 = 2.0;
/// The wrist: the end of the forearm.
const WRIST: Vec3 = Vec3::new(0.0, -0.25, 0.0);

fn main() {
    if !common::has_graphics_adapter("ik_circle") {
        return;
    }
    App::new()
        .add_plugins((DefaultPlugins, DrapePlugins::default(), ExamplePlugin))
        .insert_resource(Circle { radius: 0.12 })
        .init_resource::<Trace>()
        .add_systems(Startup, setup)
        .add_systems(Update, (dress_humanoids, keys, label))
        .add_systems(FixedUpdate, move_target)
        .add_systems(
            PostUpdate,
            draw.after(bevy::transform::TransformSystems::Propagate),
        )
        .run();
}

#[derive(Resource)]
struct Circle {
    radius: f32,
}

/// The wrist's recent positions.
#[derive(Resource, Default)]
struct Trace(Vec<Vec3>);

#[derive(Component)]
struct Label;

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
        Vec3::new(0.0, 1.1, 0.0),
        2.6,
    );
    commands.spawn((
        Skeleton {
            rig: Arc::new(humanoid()),
        },
        ClipPlayer::new(assets.load("clips/walk.clip.ron")),
        InverseKinematics {
            goals: vec![IkGoal {
                end_bone: "forearm_r".into(),
                length: 3,
                effector: WRIST,
                target: IkTarget::Point(CENTRE),
                settings: IkSettings::default(),
                weight: 1.0,
                max_speed: IkGoal::DEFAULT_MAX_SPEED,
                joint_limits: Vec::new(),
            }],
            results: Vec::new(),
        },
        Transform::default(),
        Visibility::default(),
    ));
    commands.spawn((
        Text::new(""),
        Node {
            position_type: PositionType::Absolute,
            top: Val::Px(10.0),
            left: Val::Px(10.0),
            ..default()
        },
        Label,
    ));
}

fn target_at(t: f32, radius: f32) -> Vec3 {
    let a = std::f32::consts::TAU * t / PERIOD;
    CENTRE + Vec3::new(a.cos(), a.sin(), 0.0) * radius
}

/// Moves the IK target along the circle, and records where the wrist is.
fn move_target(
    mut characters: Query<(&mut InverseKinematics, &Skeleton, &SkeletonPose)>,
    circle: Res<Circle>,
    time: Res<Time>,
    mut trace: ResMut<Trace>,
) {
    for (mut ik, skeleton, pose) in &mut characters {
        if let Some(goal) = ik.goals.first_mut() {
            goal.target = IkTarget::Point(target_at(time.elapsed_secs(), circle.radius));
        }
        if let Some(forearm) = skeleton.rig.find("forearm_r")
            && let Some(b) = pose.bones.get(forearm)
        {
            trace.0.push(b.translation + b.rotation * WRIST);
            if trace.0.len() > 200 {
                trace.0.remove(0);
            }
        }
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut circle: ResMut<Circle>,
    mut drape: ResMut<DrapeSettings>,
    mut trace: ResMut<Trace>,
) {
    if input.just_pressed(KeyCode::ArrowUp) {
        circle.radius = (circle.radius + 0.04).min(0.6);
        trace.0.clear();
    }
    if input.just_pressed(KeyCode::ArrowDown) {
        circle.radius = (circle.radius - 0.04).max(0.02);
        trace.0.clear();
    }
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
}

fn draw(mut gizmos: Gizmos, circle: Res<Circle>, trace: Res<Trace>) {
    gizmos.circle(
        Isometry3d::from_translation(CENTRE),
        circle.radius,
        Color::srgb(1.0, 0.85, 0.1),
    );
    gizmos.linestrip(trace.0.iter().copied(), Color::srgb(0.9, 0.15, 0.1));
}

fn label(
    characters: Query<&InverseKinematics>,
    circle: Res<Circle>,
    mut labels: Query<&mut Text, With<Label>>,
) {
    let Some(result) = characters
        .iter()
        .next()
        .and_then(|ik| ik.results.first().copied().flatten())
    else {
        return;
    };
    for mut text in &mut labels {
        text.0 = format!(
            "circle radius {:.2} m (Up/Down)\nIK: {:.2} mm from the target after {} iterations{}",
            circle.radius,
            result.error * 1000.0,
            result.iterations,
            if result.reached {
                ""
            } else {
                " (out of reach)"
            }
        );
    }
}
