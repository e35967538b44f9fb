//! Characters that move through the world, as a game moves them: a system moves the
//! character's entity (or a parent of it) every fixed step while the clip plays in place.
//!
//! - Every proxy's published velocity is the whole motion of the proxy: the entity chain's
//!   motion plus the joints' (clip and IK), at the step's instant. The reference is the
//!   five-point central finite difference of the proxy's world pose as the cloth sees it,
//!   over the two steps before and after; the half-step-late finite difference over the last
//!   step is shown to miss it, so the check can tell the two apart.
//! - The moving system may run before the drape sets (`FixedPreUpdate`, `FixedUpdate`) or
//!   after them (`FixedPostUpdate` after `DrapeSystems::Step`, `FixedLast`).
//!
//! A cloth in a moving frame is in `tests/moving_character_cloth.rs`; the main scene in every
//! motion is in `tests/poncho.rs`.

use crate::common;

use std::f32::consts::TAU;
use std::sync::Arc;

use bevy::prelude::*;
use bevy_drape::collide::plugin::ColliderState;
use bevy_drape::prelude::*;
use bevy_drape::skeleton::clip::ClipDesc;
use bevy_drape::skeleton::humanoid::humanoid_proxies;
use bevy_drape::skeleton::plugin::{BoneProxyOf, ClipAsset};
use common::moving::{HZ, Mover, MoverAt, app};

/// What is spawned.
struct Case {
    /// The character moves.
    character: Option<Mover>,
    /// A parent above the character moves.
    parent: Option<Mover>,
    /// The right forearm reaches by IK for a point circling in the character's frame.
    ik: bool,
}

/// One proxy's pose and published velocity after every fixed step, with the clip's time.
#[derive(Default)]
struct Track {
    poses: Vec<(Vec3, Quat)>,
    velocities: Vec<(Vec3, Vec3)>,
    clip_times: Vec<f32>,
    /// Points on the proxy's surface in its own frame: the tips of its axis and the ends of
    /// two diameters across it.
    surface: Vec<Vec3>,
}

/// The walk clip's key times (its loop is 1 s long).
const KEY_TIMES: [f32; 5] = [0.0, 0.2, 0.5, 0.7, 1.0];

/// Whether a key time of the clip lies between `from` and `to` (clip times, looped). The
/// clip's splines are C1 (velocities continuous) but not C2: the acceleration of a
/// Catmull-Rom spline jumps at its keys, so a finite difference across a key is no reference
/// for the velocity there.
fn straddles_a_key(from: f32, to: f32) -> bool {
    let (from, to) = if to < from {
        (from, to + 1.0)
    } else {
        (from, to)
    };
    KEY_TIMES
        .iter()
        .flat_map(|&k| [k, k + 1.0])
        .any(|k| from < k && k < to)
}

/// The IK target: a circle in front of the right shoulder, in the character's frame.
#[derive(Component)]
struct CirclingTarget;

fn circle_ik_target(
    mut characters: Query<&mut InverseKinematics, With<CirclingTarget>>,
    time: Res<Time>,
) {
    let t = time.elapsed_secs();
    for mut ik in &mut characters {
        let a = TAU * 0.4 * t;
        ik.goals[0].target =
            IkTarget::CharacterPoint(Vec3::new(-0.3 + 0.08 * a.cos(), 1.15 + 0.08 * a.sin(), 0.3));
    }
}

/// Runs `case` for `steps` fixed steps and tracks every proxy.
fn run(case: &Case, mover_at: MoverAt, steps: usize) -> Vec<Track> {
    let mut app = app(mover_at);
    app.add_systems(FixedUpdate, circle_ik_target);
    let clip = app
        .world_mut()
        .resource_mut::<Assets<ClipAsset>>()
        .add(ClipAsset(
            ClipDesc::from_ron(include_str!("../assets/clips/walk.clip.ron")).unwrap(),
        ));
    let parent = case
        .parent
        .map(|m| app.world_mut().spawn((m, m.transform_at(0.0))).id());
    let mut character = app.world_mut().spawn((
        Skeleton {
            rig: Arc::new(humanoid()),
        },
        BoneColliders::humanoid(),
        ClipPlayer::new(clip),
        Transform::default(),
    ));
    if let Some(m) = case.character {
        character.insert((m, m.transform_at(0.0)));
    }
    if let Some(p) = parent {
        character.insert(ChildOf(p));
    }
    if case.ik {
        character.insert((
            InverseKinematics {
                goals: vec![IkGoal {
                    end_bone: "forearm_r".into(),
                    length: 3,
                    effector: Vec3::new(0.0, -0.25, 0.0),
                    target: IkTarget::CharacterPoint(Vec3::new(-0.22, 1.15, 0.3)),
                    // Converged tightly: a 1 mm tolerance is 1 mm of noise in the pose from
                    // step to step, which a finite difference turns into velocity.
                    settings: IkSettings {
                        tolerance: 1e-5,
                        max_iterations: 200,
                        ..IkSettings::default()
                    },
                    weight: 1.0,
                    max_speed: IkGoal::DEFAULT_MAX_SPEED,
                    joint_limits: Vec::new(),
                }],
                results: Vec::new(),
            },
            CirclingTarget,
        ));
    }
    let character = character.id();
    let mut proxies: Vec<Entity> = Vec::new();
    let mut tracks: Vec<Track> = Vec::new();
    for _ in 0..steps + 2 {
        app.update();
        if proxies.is_empty() {
            let world = app.world_mut();
            proxies = world
                .query_filtered::<Entity, With<BoneProxyOf>>()
                .iter(world)
                .collect();
            tracks = proxies.iter().map(|_| Track::default()).collect();
        }
        let clip_time = app.world().get::<ClipPlayer>(character).unwrap().time;
        for (track, &proxy) in tracks.iter_mut().zip(&proxies) {
            let state = app.world().get::<ColliderState>(proxy).unwrap();
            if let Some(c) = state.collider() {
                track.clip_times.push(clip_time);
                if track.surface.is_empty() {
                    let (r, l) = match c.shape {
                        bevy_drape::collide::SolverShape::Capsule {
                            radius,
                            half_length,
                        } => (radius, half_length),
                        bevy_drape::collide::SolverShape::Sphere { radius } => (radius, 0.0),
                        _ => (0.0, 0.0),
                    };
                    track.surface = vec![
                        Vec3::Y * (l + r),
                        -Vec3::Y * (l + r),
                        Vec3::X * r,
                        -Vec3::X * r,
                        Vec3::Z * r,
                        -Vec3::Z * r,
                    ];
                }
                track
                    .poses
                    .push((Vec3::from(c.end.translation), c.end.rotation));
                track.velocities.push((
                    Vec3::from(c.linear_velocity),
                    Vec3::from(c.angular_velocity),
                ));
            }
        }
    }
    assert_eq!(proxies.len(), humanoid_proxies().len());
    tracks
}

/// The velocity at step `k` from the poses around it: the five-point central difference
/// (error of order `h^4`), of positions and of rotation vectors relative to step `k`.
fn centred_velocity(poses: &[(Vec3, Quat)], k: usize, h: f32) -> (Vec3, Vec3) {
    let rotation_vector = |j: usize| {
        let turn = poses[j].1 * poses[k].1.inverse();
        // The short way round (q and -q are the same rotation).
        let turn = if turn.w < 0.0 { -turn } else { turn };
        turn.to_scaled_axis()
    };
    let stencil = |f: &dyn Fn(usize) -> Vec3| {
        (-f(k + 2) + 8.0 * f(k + 1) - 8.0 * f(k - 1) + f(k - 2)) / (12.0 * h)
    };
    (stencil(&|j| poses[j].0), stencil(&rotation_vector))
}

/// The velocity over the last step (the step's finite difference: half a step late).
fn late_velocity(poses: &[(Vec3, Quat)], k: usize, h: f32) -> (Vec3, Vec3) {
    let turn = poses[k].1 * poses[k - 1].1.inverse();
    let turn = if turn.w < 0.0 { -turn } else { turn };
    ((poses[k].0 - poses[k - 1].0) / h, turn.to_scaled_axis() / h)
}

/// The worst relative error, over every surface point of every proxy and every step (after the
/// first few), of the velocity published for it (`v + omega x r`) against the centred
/// difference of the poses (`centred`) or against the last step's difference.
fn worst_error(tracks: &[Track], centred: bool) -> f32 {
    let h = (1.0 / HZ) as f32;
    let mut worst = 0.0f32;
    for track in tracks {
        let n = track.poses.len();
        assert!(n > 20, "the proxy was seen in {n} steps");
        for k in 4..n - 2 {
            // The clip's splines are smooth between keys only: no difference across one.
            if straddles_a_key(track.clip_times[k - 2], track.clip_times[k + 2]) {
                continue;
            }
            let (linear, angular) = if centred {
                centred_velocity(&track.poses, k, h)
            } else {
                late_velocity(&track.poses, k, h)
            };
            let (v, w) = track.velocities[k];
            // The velocity of each surface point, relative to its speed (at least 0.2 m/s).
            let rotation = track.poses[k].1;
            let e = track
                .surface
                .iter()
                .map(|&local| {
                    let r = rotation * local;
                    let reference = linear + angular.cross(r);
                    (v + w.cross(r) - reference).length() / reference.length().max(0.2)
                })
                .fold(0.0, f32::max);
            if e > worst && std::env::var("DEBUG_VEL").is_ok() {
                eprintln!("k {k}: v {v} vs {linear}, w {w} vs {angular}");
            }
            worst = worst.max(e);
        }
    }
    worst
}

#[test]
fn proxy_velocities_are_the_whole_motion_of_the_proxy() {
    let cases = [
        (
            "clip only",
            Case {
                character: None,
                parent: None,
                ik: false,
            },
        ),
        (
            "moving and turning character",
            Case {
                character: Some(Mover::random(1, false)),
                parent: None,
                ik: false,
            },
        ),
        (
            "IK on a moving character",
            Case {
                character: Some(Mover::random(2, false)),
                parent: None,
                ik: true,
            },
        ),
        (
            "a moving, tilting parent above a moving character",
            Case {
                character: Some(Mover::random(3, false)),
                parent: Some(Mover::random(4, true)),
                ik: true,
            },
        ),
    ];
    for (name, case) in &cases {
        let tracks = run(case, MoverAt::FixedUpdate, 96);
        let centred = worst_error(&tracks, true);
        eprintln!(
            "{name}: {:.3}% (late {:.3}%)",
            100.0 * centred,
            100.0 * worst_error(&tracks, false)
        );
        assert!(centred < 0.01, "{name}: {:.2}% off", 100.0 * centred);
        if case.character.is_some() {
            // The check can tell a velocity half a step late from the right one.
            let late = worst_error(&tracks, false);
            assert!(
                late > 0.02,
                "{name}: the late difference is only {:.2}% off",
                100.0 * late
            );
        }
    }
}

#[test]
fn random_motions_and_any_schedule_of_the_mover_give_the_same_velocities() {
    for seed in 10..14 {
        for mover_at in [
            MoverAt::FixedPreUpdate,
            MoverAt::FixedUpdate,
            MoverAt::AfterStep,
            MoverAt::FixedLast,
        ] {
            let case = Case {
                character: Some(Mover::random(seed, false)),
                parent: (seed % 2 == 0).then(|| Mover::random(seed + 100, true)),
                ik: seed % 2 == 1,
            };
            let tracks = run(&case, mover_at, 64);
            let worst = worst_error(&tracks, true);
            assert!(
                worst < 0.01,
                "seed {seed}, mover in {mover_at:?}: {:.2}% off",
                100.0 * worst
            );
        }
    }
}
