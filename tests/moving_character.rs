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
//! The main scene in every motion is in `tests/poncho.rs`.

use std::f32::consts::TAU;
use std::sync::Arc;
use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_drape::prelude::*;

/// Fixed steps per second.
const HZ: f64 = 64.0;

/// A smooth random motion of an entity: a circle of random radius and rate, a bob, and a
/// turn at a varying rate about a slightly tilted axis (for a parent) or about +Y.
#[derive(Component, Clone, Copy, Debug)]
struct Mover {
    centre: Vec3,
    radius: f32,
    rate: f32,
    bob: f32,
    spin: f32,
    spin_change: f32,
    tilt: Vec3,
}

impl Mover {
    fn random(seed: u32, tilted: bool) -> Self {
        let mut state = seed.wrapping_mul(2_654_435_761).wrapping_add(12_345);
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        Self {
            centre: Vec3::new(next() - 0.5, 0.0, next() - 0.5),
            radius: 0.5 + 2.0 * next(),
            // Walking to jogging pace along the circle.
            rate: 0.4 + 1.2 * next(),
            bob: 0.05 * next(),
            spin: -2.0 + 4.0 * next(),
            spin_change: -1.0 + 2.0 * next(),
            tilt: if tilted {
                Vec3::new(0.2 * next(), 1.0, 0.2 * next()).normalize()
            } else {
                Vec3::Y
            },
        }
    }

    fn transform_at(&self, t: f32) -> Transform {
        let a = self.rate * t;
        let translation = self.centre
            + Vec3::new(
                self.radius * a.cos(),
                self.bob * (3.0 * a).sin(),
                self.radius * a.sin(),
            );
        let turn = self.spin * t + 0.5 * self.spin_change * t * t;
        Transform::from_translation(translation)
            .with_rotation(Quat::from_axis_angle(self.tilt, turn))
    }
}

fn move_movers(mut movers: Query<(&Mover, &mut Transform)>, time: Res<Time>) {
    for (mover, mut transform) in &mut movers {
        *transform = mover.transform_at(time.elapsed_secs());
    }
}

/// Where the moving system runs.
#[derive(Clone, Copy, Debug)]
enum MoverAt {
    FixedPreUpdate,
    FixedUpdate,
    AfterStep,
    FixedLast,
}

fn app(mover_at: MoverAt) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
        DrapePlugins::default(),
    ))
    .insert_resource(Time::<Fixed>::from_hz(HZ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / HZ,
    )));
    match mover_at {
        MoverAt::FixedPreUpdate => app.add_systems(FixedPreUpdate, move_movers),
        MoverAt::FixedUpdate => app.add_systems(FixedUpdate, move_movers),
        MoverAt::AfterStep => {
            app.add_systems(FixedPostUpdate, move_movers.after(DrapeSystems::Step))
        }
        MoverAt::FixedLast => app.add_systems(FixedLast.intern(), move_movers),
    };
    app
}

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

/// A free sheet, no gravity, carried by a frame moving along `mover` with `inertia`; the
/// sheet's particles in the frame's coordinates and in the world, after `steps` steps.
fn carried_sheet(mover: &Mover, inertia: f32, steps: usize) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec3>) {
    use bevy_drape::collide::{FrameTracker, RigidPose};
    let grid = GridDesc::square(0.5, 6, Vec3::new(-0.25, 1.0, -0.25));
    let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
    let start: Vec<Vec3> = sim.state().positions.iter().map(|&p| p.into()).collect();
    let mut tracker = FrameTracker::default();
    let dt = 1.0 / 60.0;
    let pose_at = |t: f32| {
        let t = mover.transform_at(t);
        RigidPose {
            translation: t.translation.into(),
            rotation: t.rotation,
        }
    };
    let first = pose_at(0.0);
    tracker.step(first, dt, None);
    let mut last = first;
    for n in 1..=steps {
        let frame = tracker.step(pose_at(n as f32 * dt), dt, None);
        sim.follow_frame(&frame, inertia);
        sim.step(&SolverSettings::default(), Vec3::ZERO, dt)
            .unwrap();
        last = frame.end;
    }
    let world: Vec<Vec3> = sim.state().positions.iter().map(|&p| p.into()).collect();
    let local = world
        .iter()
        .map(|&p| Vec3::from(last.inverse_transform_point(p.into())))
        .collect();
    // Where the sheet started, in the frame's coordinates at the start.
    let start_local = start
        .iter()
        .map(|&p| Vec3::from(first.inverse_transform_point(p.into())))
        .collect();
    (local, start_local, world)
}

#[test]
fn with_no_inertia_a_cloth_moves_rigidly_with_its_frame_and_with_full_inertia_not_at_all() {
    for seed in 20..26 {
        let mover = Mover::random(seed, true);
        // Inertia 0: the sheet keeps its place in the frame, however the frame moves, to
        // within what f32 rounding of positions a few metres from the origin leaves (the
        // constraints turn it into velocities of millimetres per second).
        let (local, start_local, _) = carried_sheet(&mover, 0.0, 120);
        let drift = local
            .iter()
            .zip(&start_local)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        assert!(drift < 0.01, "seed {seed}: drifted {drift} m in the frame");
        // Inertia 1: the world frame's motion is not felt; the sheet stays where it was.
        let grid = GridDesc::square(0.5, 6, Vec3::new(-0.25, 1.0, -0.25));
        let (_, _, world) = carried_sheet(&mover, 1.0, 120);
        let moved = world
            .iter()
            .zip(grid.mesh().positions)
            .map(|(a, b)| a.distance(b))
            .fold(0.0, f32::max);
        assert!(
            moved < 1e-4,
            "seed {seed}: moved {moved} m with full inertia"
        );
    }
}

#[test]
fn a_cloth_feels_the_inertia_share_of_its_frame_motion_and_keeps_it_when_the_frame_stops() {
    use bevy_drape::collide::{FrameStep, RigidPose};
    let dt = 1.0 / 60.0;
    let velocity = Vec3::new(1.5, 0.0, -0.5);
    for inertia in [0.0, 0.25, 0.5, 1.0] {
        let grid = GridDesc::square(0.5, 5, Vec3::ZERO);
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
        let x0 = sim.state().positions[0];
        // The frame moves at a constant velocity for 1 s, then stops.
        let mut at = Vec3::ZERO;
        for n in 0..120 {
            let (linear, next) = if n < 60 {
                (velocity, at + velocity * dt)
            } else {
                (Vec3::ZERO, at)
            };
            let pose = |p: Vec3| RigidPose {
                translation: p.into(),
                rotation: Quat::IDENTITY,
            };
            let frame = FrameStep {
                start: pose(at),
                end: pose(next),
                linear_velocity: linear.into(),
                angular_velocity: Vec3::ZERO.into(),
                jumped: false,
            };
            at = next;
            sim.follow_frame(&frame, inertia);
            sim.step(&SolverSettings::default(), Vec3::ZERO, dt)
                .unwrap();
        }
        // Carried by (1 - inertia) of the motion while the frame moves; when it stops, the
        // carried share stops with it (as a cloth simulated in the frame with its inertial
        // forces scaled by `inertia` would), and the cloth, never pushed in the world, is at
        // rest there.
        let moved = Vec3::from(sim.state().positions[0] - x0);
        let expected = velocity * (1.0 - inertia);
        assert!(
            moved.distance(expected) < 0.02 * velocity.length() + 1e-4,
            "inertia {inertia}: moved {moved}, expected {expected}"
        );
    }
}

#[test]
fn a_teleported_character_takes_its_cloth_along_and_the_cloth_is_drawn_on_it() {
    let mut app = app(MoverAt::FixedUpdate);
    let character = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 0.0, 0.0))
        .id();
    let grid = GridDesc::square(0.6, 7, Vec3::new(-0.3, 1.2, -0.3));
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(grid_mesh(&grid));
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            // A cape pinned to the character (its entity a child of it) and following it.
            Cloth::pinned([0, 6]).following(character),
            Transform::default(),
            ChildOf(character),
        ))
        .id();
    for _ in 0..30 {
        app.update();
    }
    let centroid = |app: &App| {
        let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
        let x = &sim.state().positions;
        Vec3::from(x.iter().copied().sum::<bevy::math::Vec3A>()) / x.len() as f32
    };
    let drawn = |app: &App| {
        let handle = &app.world().get::<Mesh3d>(cloth).unwrap().0;
        let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
        // The mesh is in the cloth entity's frame (which is the character's here).
        let global = app.world().get::<GlobalTransform>(cloth).unwrap();
        match mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap() {
            bevy::mesh::VertexAttributeValues::Float32x3(p) => {
                p.iter()
                    .map(|&p| global.transform_point(Vec3::from_array(p)))
                    .sum::<Vec3>()
                    / p.len() as f32
            }
            _ => unreachable!(),
        }
    };
    let before = centroid(&app);
    let strain_before = app
        .world()
        .get::<ClothSimulation>(cloth)
        .unwrap()
        .solver()
        .strain()
        .max;
    // A respawn: 10 m away and turned a quarter turn, in one step.
    let jump = Transform::from_xyz(10.0, 0.0, -3.0).with_rotation(Quat::from_rotation_y(1.5));
    *app.world_mut().get_mut::<Transform>(character).unwrap() = jump;
    app.update();
    let after = centroid(&app);
    let expected = jump.transform_point(before);
    assert!(
        after.distance(expected) < 0.05,
        "the cloth is at {after}, the character took it to {expected}"
    );
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(sim.followed().unwrap().jumped);
    assert!(
        sim.solver().strain().max < strain_before + 0.01,
        "the jump stretched the cloth"
    );
    // Drawn in the character's frame: on the character, not smeared across the jump.
    assert!(
        drawn(&app).distance(expected) < 0.05,
        "drawn at {}, the cloth is at {expected}",
        drawn(&app)
    );
    // Pins and the cloth go on with the character.
    for _ in 0..30 {
        app.update();
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    assert!(sim.is_finite() && sim.strain().max < 0.05);
}
