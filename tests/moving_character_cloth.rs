//! A cloth in the frame of a character that moves through the world: carried rigidly with no
//! inertia and left where it is with full inertia, feeling its inertia's share of the frame's
//! motion and keeping it when the frame stops, taken along by a teleport and drawn on the
//! character, its speed relative to the frame limited. The characters' proxy velocities are in `tests/moving_character_velocities.rs`.

use crate::common;

use bevy::prelude::*;
use bevy_drape::cloth::{ClothModel, ClothSolver};
use bevy_drape::prelude::*;
use common::add_grid;
use common::moving::{Mover, MoverAt, app};

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
                sweep_start: pose(at),
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

/// A character at the origin wearing a cape (a 0.6 m sheet pinned at two corners, its entity a
/// child of the character's and following it), after 30 updates standing.
fn caped_character() -> (App, Entity, Entity) {
    let mut app = app(MoverAt::FixedUpdate);
    let character = app.world_mut().spawn(Transform::default()).id();
    let grid = GridDesc::square(0.6, 7, Vec3::new(-0.3, 1.2, -0.3));
    let mesh = add_grid(&mut app, &grid);
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::pinned([0, 6]).following(character),
            Transform::default(),
            ChildOf(character),
        ))
        .id();
    for _ in 0..30 {
        app.update();
    }
    (app, character, cloth)
}

#[test]
fn a_teleported_character_takes_its_cloth_along_and_the_cloth_is_drawn_on_it() {
    let (mut app, character, cloth) = caped_character();
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

#[test]
fn the_speed_limit_cuts_each_particles_speed_relative_to_its_frame_and_nothing_else() {
    use bevy::math::Vec3A;
    use bevy_drape::collide::{FrameTracker, RigidPose};
    use common::Rng;
    let dt = 1.0 / 60.0;
    let mut rng = Rng(41);
    for seed in 30..36 {
        let mover = Mover::random(seed, true);
        let pose_at = |t: f32| {
            let t = mover.transform_at(t);
            RigidPose {
                translation: t.translation.into(),
                rotation: t.rotation,
            }
        };
        let mut tracker = FrameTracker::default();
        let t0 = rng.range(0.5, 3.0);
        tracker.step(pose_at(t0 - dt), dt, None);
        let frame = tracker.step(pose_at(t0), dt, None);
        let inertia = [1.0, 0.5, 0.0][rng.below(3)];
        let limit = rng.range(0.5, 4.0);
        let grid = GridDesc::square(0.5, 6, Vec3::new(-0.25, 1.0, -0.25));
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
        sim.set_pins(&[0]).unwrap();
        for v in sim.state_mut().velocities.iter_mut() {
            *v = Vec3A::from(rng.vec3(-8.0, 8.0));
        }
        sim.follow_frame(&frame, inertia);
        let before = sim.state().clone();
        sim.limit_speed_relative_to(&frame, limit);
        let after = sim.state();
        // The frame's velocity field as the cloth feels it: its inertia's share.
        let (mut cut, mut kept) = (0, 0);
        for i in 0..after.len() {
            let p = before.positions[i];
            let body = (frame.linear_velocity
                + frame.angular_velocity.cross(p - frame.end.translation))
                * inertia;
            let (v0, v1) = (before.velocities[i], after.velocities[i]);
            let relative = v0 - body;
            if i == 0 || relative.length() <= limit {
                // Pinned, or within the limit: untouched.
                assert_eq!(v1, v0, "seed {seed}, particle {i}");
                kept += 1;
            } else if inertia == 0.0 {
                // With no inertia the cloth feels none of the frame's motion: nothing to cut.
                assert_eq!(v1, v0);
                kept += 1;
            } else {
                let new = v1 - body;
                assert!(
                    (new.length() - limit).abs() < 1e-4 * limit.max(1.0),
                    "{new}"
                );
                assert!(new.normalize().dot(relative.normalize()) > 0.9999);
                cut += 1;
            }
        }
        assert!(
            kept > 0 && (cut > 0 || inertia == 0.0),
            "seed {seed}: {cut} cut, {kept} kept"
        );
        assert_eq!(after.positions, before.positions);
    }
}

#[test]
fn a_character_carried_at_1000_m_s_or_sent_to_nan_leaves_its_cloth_finite() {
    common::warnings::capture_warnings();
    let (mut app, character, cloth) = caped_character();
    let finite_everywhere = |app: &App, what: &str| {
        let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
        assert!(sim.is_finite(), "{what}: the solver's state");
        let handle = &app.world().get::<Mesh3d>(cloth).unwrap().0;
        let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
        for attribute in [Mesh::ATTRIBUTE_POSITION, Mesh::ATTRIBUTE_NORMAL] {
            match mesh.attribute(attribute) {
                Some(bevy::mesh::VertexAttributeValues::Float32x3(v)) => assert!(
                    v.iter().flatten().all(|c| c.is_finite()),
                    "{what}: the mesh's {}",
                    attribute.name
                ),
                other => panic!("{what}: {} is {other:?}", attribute.name),
            }
        }
        assert!(
            app.world()
                .get::<GlobalTransform>(cloth)
                .unwrap()
                .translation()
                .is_finite()
                || what == "sent to NaN",
            "{what}: the cloth's transform"
        );
    };
    // A platform at 1000 m/s: 16.7 m a step, every step beyond the teleport distance, so the
    // cloth is taken along as by a respawn, unstretched.
    for k in 1..=60 {
        let x = k as f32 * 1000.0 / 60.0;
        app.world_mut()
            .get_mut::<Transform>(character)
            .unwrap()
            .translation = Vec3::new(x, 0.0, 0.0);
        app.update();
        finite_everywhere(&app, "at 1000 m/s");
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(sim.followed().unwrap().jumped);
    assert!(
        sim.solver().strain().max < 0.05,
        "{}",
        sim.solver().strain().max
    );
    let before: Vec<_> = sim.solver().state().positions.clone();
    // A jump to NaN: the cloth stays where it was, simulated in the world alone, with one
    // warning naming it.
    app.world_mut()
        .get_mut::<Transform>(character)
        .unwrap()
        .translation = Vec3::NAN;
    for _ in 0..10 {
        app.update();
        finite_everywhere(&app, "sent to NaN");
    }
    let after = &app
        .world()
        .get::<ClothSimulation>(cloth)
        .unwrap()
        .solver()
        .state()
        .positions;
    let moved = before
        .iter()
        .zip(after)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    assert!(moved < 0.5, "the cloth moved {moved} m");
    assert_eq!(
        common::warnings::warnings_with(&[
            &format!("cloth {cloth} follows {character}"),
            "no valid transform"
        ]),
        1
    );
    // Back on its feet at a finite place: taken along again.
    app.world_mut()
        .get_mut::<Transform>(character)
        .unwrap()
        .translation = Vec3::new(5.0, 0.0, 0.0);
    for _ in 0..30 {
        app.update();
        finite_everywhere(&app, "back");
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    let centroid = Vec3::from(
        sim.state()
            .positions
            .iter()
            .copied()
            .sum::<bevy::math::Vec3A>(),
    ) / sim.state().len() as f32;
    assert!(
        centroid.distance(Vec3::new(5.0, 1.0, 0.0)) < 1.0,
        "the cloth is at {centroid}"
    );
}
