//! What a cloth's step costs. Sleeping: a still cloth stops being solved and gets
//! `ClothSleeping`; it wakes in the same fixed step for each thing that could move it (its
//! followed entity, a pin target, a collider near it, the wind, a drag, its settings, the
//! gravity) and goes on as if it had never slept; a collider moving far from it, or nothing
//! at all, leaves it asleep. Level of detail: fewer substeps, frozen or hidden by the
//! distance from a viewer, with no jolt when the level changes.

use std::time::Duration;

use bevy::prelude::*;
use bevy_drape::cloth::plugin::{ClothLevelOfDetail, ClothSleeping};
use bevy_drape::cloth::{LodBudget, LodLevel, SleepSettings};
use bevy_drape::prelude::*;
use bevy_drape::schedule::DrapeSettings;

/// A cloth that comes to rest within a few seconds: strongly damped.
fn settings() -> ClothSettings {
    ClothSettings {
        solver: SolverSettings {
            damping: 6.0,
            ..default()
        },
        ..default()
    }
}

/// A carrier entity at `at` and a 0.6 m cloth worn by it, hanging from two corners attached
/// to it, with a sphere collider 1 cm behind the cloth's lower half.
struct Scene {
    cloth: Entity,
    carrier: Entity,
    ball: Entity,
}

fn spawn(app: &mut App, at: Vec3, settings: ClothSettings) -> Scene {
    let n = 10;
    // Upright in the XY plane, its top edge at the carrier's height, centred on it.
    let mut grid = GridDesc::square(0.6, n, Vec3::new(-0.3, -0.6, 0.0));
    grid.orientation = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(grid_mesh(&grid));
    let carrier = app.world_mut().spawn(Transform::from_translation(at)).id();
    let rest = grid.mesh().positions;
    let mut cloth = Cloth::worn_by(carrier);
    for vertex in [grid.index(0, n - 1), grid.index(n - 1, n - 1)] {
        cloth = cloth.with_attachment(VertexAttachment {
            vertex,
            target: carrier,
            offset: rest[vertex as usize],
        });
    }
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            cloth,
            settings,
            Transform::from_translation(at),
        ))
        .id();
    let ball = app
        .world_mut()
        .spawn((
            ClothCollider::sphere(0.1),
            Transform::from_translation(at + Vec3::new(0.0, -0.45, -0.115)),
        ))
        .id();
    Scene {
        cloth,
        carrier,
        ball,
    }
}

fn positions(app: &App, cloth: Entity) -> Vec<Vec3> {
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    let positions = &simulation.solver().state().positions;
    positions.iter().map(|&p| p.into()).collect()
}

fn asleep(app: &App, cloth: Entity) -> bool {
    let slept = app
        .world()
        .get::<ClothSimulation>(cloth)
        .unwrap()
        .is_asleep();
    let marked = app.world().get::<ClothSleeping>(cloth).is_some();
    assert_eq!(slept, marked, "the marker shows the state");
    slept
}

/// Steps until the cloth sleeps (at most 20 s); the steps it took.
fn until_asleep(app: &mut App, cloth: Entity) -> usize {
    for k in 0..20 * 64 {
        app.update();
        if app.world().get::<ClothSimulation>(cloth).is_some() && asleep(app, cloth) {
            return k;
        }
    }
    panic!("the cloth did not fall asleep within 20 s");
}

fn largest_move(a: &[Vec3], b: &[Vec3]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max)
}

#[test]
fn a_still_cloth_sleeps_and_costs_nothing_until_something_moves() {
    let mut app = crate::common::app();
    let scene = spawn(&mut app, Vec3::new(0.3, 1.5, 0.2), settings());
    until_asleep(&mut app, scene.cloth);
    let before = positions(&app, scene.cloth);
    // A collider moving 10 m away does not wake it.
    let far = app
        .world_mut()
        .spawn((
            ClothCollider::sphere(0.2),
            Transform::from_xyz(10.0, 1.0, 0.0),
        ))
        .id();
    for k in 0..64 {
        app.world_mut()
            .get_mut::<Transform>(far)
            .unwrap()
            .translation
            .y = 1.0 + 0.01 * k as f32;
        app.update();
        assert!(asleep(&app, scene.cloth), "step {k}");
        let timings = *app
            .world()
            .get::<ClothSimulation>(scene.cloth)
            .unwrap()
            .solver()
            .last_timings();
        assert_eq!(timings.total(), Duration::ZERO, "not solved while asleep");
    }
    assert_eq!(positions(&app, scene.cloth), before, "its pose is kept");
}

/// What wakes a sleeping cloth, done to the world between two updates.
#[derive(Clone, Copy, Debug)]
enum Cause {
    CarrierMoves,
    CarrierCreeps,
    ColliderGrows,
    ColliderComes,
    ColliderGoes,
    PinTargetMoves,
    ColliderNearMoves,
    Wind,
    Drag,
    SettingsChange,
    GravityChange,
}

fn disturb(app: &mut App, scene: &Scene, cause: Cause) {
    if let Cause::CarrierCreeps = cause {
        // 1 um a step, too little to see in any one step: the cloth wakes once the carrier
        // has crept 0.1 mm from where it was when the cloth fell asleep.
        for _ in 0..200 {
            let world = app.world_mut();
            world
                .get_mut::<Transform>(scene.carrier)
                .unwrap()
                .translation
                .x += 1e-6;
            app.update();
            if !asleep(app, scene.cloth) {
                return;
            }
        }
        panic!("the creeping carrier did not wake the cloth");
    }
    let world = app.world_mut();
    match cause {
        Cause::CarrierCreeps => unreachable!(),
        Cause::ColliderGrows => {
            world.get_mut::<ClothCollider>(scene.ball).unwrap().shape =
                ColliderShape::Sphere { radius: 0.14 };
        }
        Cause::ColliderComes => {
            let at = world.get::<Transform>(scene.ball).unwrap().translation;
            world.spawn((
                ClothCollider::sphere(0.06),
                Transform::from_translation(at + Vec3::new(0.15, 0.1, 0.1)),
            ));
        }
        Cause::ColliderGoes => {
            world.despawn(scene.ball);
        }
        Cause::CarrierMoves => {
            world
                .get_mut::<Transform>(scene.carrier)
                .unwrap()
                .translation
                .x += 0.02;
        }
        Cause::PinTargetMoves => {
            // Where an attachment holds its corner on the carrier.
            let mut cloth = world.get_mut::<Cloth>(scene.cloth).unwrap();
            cloth.attachments[0].offset.x -= 0.02;
        }
        Cause::ColliderNearMoves => {
            world
                .get_mut::<Transform>(scene.ball)
                .unwrap()
                .translation
                .z += 0.05;
        }
        Cause::Wind => {
            world.insert_resource(Wind {
                velocity: Vec3::new(0.0, 0.0, 5.0),
                gusts: Gusts::default(),
            });
        }
        Cause::Drag => {
            let mut simulation = world.get_mut::<ClothSimulation>(scene.cloth).unwrap();
            let solver = simulation.solver_mut();
            // A bottom corner.
            let at = Vec3::from(solver.state().positions[0]);
            assert!(solver.grab(0));
            solver.drag_to(at + Vec3::new(0.0, 0.0, 0.05));
        }
        Cause::SettingsChange => {
            // A stretchier cloth sags.
            let mut settings = world.get_mut::<ClothSettings>(scene.cloth).unwrap();
            settings.solver.stretch_compliance = 1e-2;
        }
        Cause::GravityChange => {
            world.resource_mut::<DrapeSettings>().gravity = Vec3::new(3.0, -9.81, 0.0);
        }
    }
}

#[test]
fn a_sleeping_cloth_wakes_in_the_same_fixed_step_for_each_cause() {
    for cause in [
        Cause::CarrierMoves,
        Cause::CarrierCreeps,
        Cause::ColliderGrows,
        Cause::ColliderComes,
        Cause::ColliderGoes,
        Cause::PinTargetMoves,
        Cause::ColliderNearMoves,
        Cause::Wind,
        Cause::Drag,
        Cause::SettingsChange,
        Cause::GravityChange,
    ] {
        let mut app = crate::common::app();
        let scene = spawn(&mut app, Vec3::new(-0.2, 1.4, 0.5), settings());
        until_asleep(&mut app, scene.cloth);
        // Asleep for a while first.
        for _ in 0..10 {
            app.update();
        }
        assert!(asleep(&app, scene.cloth), "{cause:?}: still asleep");
        let before = positions(&app, scene.cloth);
        disturb(&mut app, &scene, cause);
        app.update();
        assert!(
            !asleep(&app, scene.cloth),
            "{cause:?}: awake after the next fixed step"
        );
        let solved = app
            .world()
            .get::<ClothSimulation>(scene.cloth)
            .unwrap()
            .solver()
            .last_timings()
            .total();
        assert!(solved > Duration::ZERO, "{cause:?}: solved in that step");
        if !matches!(cause, Cause::ColliderGoes | Cause::CarrierCreeps) {
            // (A collider gone from behind the sheet that hung clear of it, or a creep,
            // need not move it.)
            let moved = largest_move(&positions(&app, scene.cloth), &before);
            assert!(
                moved > 1e-5,
                "{cause:?}: stepped in that fixed step ({moved} m)"
            );
        }
    }
}

#[test]
fn a_woken_cloth_goes_on_as_if_it_had_never_slept() {
    // The same scene with and without sleep; once the first sleeps, the carrier of both sets
    // off at 1 m/s along x. The woken cloth follows the never-sleeping one within the
    // trembling sleep allows, and no particle of it moves faster than the other's fastest.
    let at = Vec3::new(1.0, 1.2, -0.4);
    let mut sleeping = crate::common::app();
    let a = spawn(&mut sleeping, at, settings());
    let mut awake = crate::common::app();
    let b = spawn(
        &mut awake,
        at,
        ClothSettings {
            sleep: None,
            ..settings()
        },
    );
    let steps = until_asleep(&mut sleeping, a.cloth);
    for _ in 0..=steps {
        awake.update();
    }
    assert!(!asleep(&awake, b.cloth));
    let sleep = SleepSettings::default();
    let gap = largest_move(&positions(&sleeping, a.cloth), &positions(&awake, b.cloth));
    assert!(gap <= sleep.distance, "asleep where the other is: {gap} m");
    let speeds = |app: &App, cloth: Entity| {
        let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
        let v = &simulation.solver().state().velocities;
        v.iter().map(|v| v.length()).fold(0.0f32, f32::max)
    };
    for k in 1..=64 {
        for (app, scene) in [(&mut sleeping, &a), (&mut awake, &b)] {
            app.world_mut()
                .get_mut::<Transform>(scene.carrier)
                .unwrap()
                .translation
                .x = at.x + k as f32 / 64.0;
            app.update();
        }
        assert!(!asleep(&sleeping, a.cloth), "step {k}: awake while moving");
        let gap = largest_move(&positions(&sleeping, a.cloth), &positions(&awake, b.cloth));
        assert!(gap <= 2.0 * sleep.distance, "step {k}: {gap} m apart");
        let (woken, never) = (speeds(&sleeping, a.cloth), speeds(&awake, b.cloth));
        assert!(
            woken <= never + 0.05,
            "step {k}: no velocity spike ({woken} m/s against {never} m/s)"
        );
    }
}

#[test]
fn bad_sleep_settings_are_warned_about_and_the_defaults_used() {
    crate::common::warnings::capture_warnings();
    let mut app = crate::common::app();
    let scene = spawn(
        &mut app,
        Vec3::new(0.0, 1.5, 0.0),
        ClothSettings {
            sleep: Some(SleepSettings {
                distance: f32::NAN,
                seconds: -1.0,
            }),
            ..settings()
        },
    );
    // Stepped (not refused), finite, asleep with the default settings in time, and asleep
    // it stays (the NaN setting does not count as a change every step).
    until_asleep(&mut app, scene.cloth);
    for k in 0..128 {
        app.update();
        assert!(asleep(&app, scene.cloth), "step {k}");
    }
    assert!(positions(&app, scene.cloth).iter().all(|p| p.is_finite()));
    let name = scene.cloth.to_string();
    let warnings = crate::common::warnings::WARNINGS.lock().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains(&name) && w.contains("sleep distance")),
        "warned about, naming {name}"
    );
}

fn two_levels() -> ClothLevelOfDetail {
    ClothLevelOfDetail {
        viewer: None,
        levels: vec![
            LodLevel {
                beyond: 2.0,
                budget: LodBudget::Substeps(2),
            },
            LodLevel {
                beyond: 4.0,
                budget: LodBudget::Frozen,
            },
        ],
    }
}

#[test]
fn level_of_detail_changes_leave_no_velocity_spike() {
    // A sheet worn by a carrier that walks along x, speeding up from 0.5 m/s to 1 m/s while
    // its sheet is frozen; the viewer steps away (fewer substeps, then frozen) and back. The
    // same scene without levels of detail is the reference: the sheet with them never moves
    // faster relative to its carrier than the reference's fastest plus 5 cm/s (it settles
    // into the stretch of each substep count: 2.8 cm/s at most here), and rides rigidly on
    // the carrier while frozen.
    let at = Vec3::new(0.0, 1.5, 0.0);
    let mut apps = Vec::new();
    for lod in [true, false] {
        let mut app = crate::common::app();
        let scene = spawn(
            &mut app,
            at,
            ClothSettings {
                sleep: None,
                ..settings()
            },
        );
        let viewer = app.world_mut().spawn(Transform::from_translation(at)).id();
        if lod {
            app.insert_resource(ClothLevelOfDetail {
                viewer: Some(viewer),
                ..two_levels()
            });
        }
        apps.push((app, scene, viewer));
    }
    // Smoothly from 0.5 to 1 m/s between steps 176 and 208, while the sheet is frozen.
    let speed_at = |k: u32| 0.5 + 0.5 * ((k as f32 - 176.0) / 32.0).clamp(0.0, 1.0);
    let mut x = at.x;
    let mut worst = [0.0f32; 2];
    let mut last: [Option<Vec<Vec3>>; 2] = [None, None];
    let mut frozen_relative: Option<Vec<Vec3>> = None;
    for k in 0..320u32 {
        let speed = speed_at(k);
        x += speed / 64.0;
        // The viewer: near, 3 m off (fewer substeps) from step 128, 10 m off (frozen) from
        // step 160, near again from step 224.
        let off = match k {
            128..160 => 3.0,
            160..224 => 10.0,
            _ => 0.0,
        };
        for (i, (app, scene, viewer)) in apps.iter_mut().enumerate() {
            let world = app.world_mut();
            world
                .get_mut::<Transform>(scene.carrier)
                .unwrap()
                .translation
                .x = x;
            world.get_mut::<Transform>(*viewer).unwrap().translation = Vec3::new(x, at.y, off);
            app.update();
            // How fast the particles move relative to the carrier over the step (from
            // where they are, not the state's velocities, whose offset of half a substep of
            // gravity changes with the substep count).
            if let Some(before) = &last[i] {
                let now = positions(app, scene.cloth);
                let moved = now
                    .iter()
                    .zip(before)
                    .map(|(a, b)| (*a - *b - Vec3::new(speed / 64.0, 0.0, 0.0)).length() * 64.0);
                if k >= 128 {
                    worst[i] = worst[i].max(moved.fold(0.0, f32::max));
                }
            }
            last[i] = app
                .world()
                .get::<ClothSimulation>(scene.cloth)
                .map(|_| positions(app, scene.cloth));
        }
        let (app, scene, _) = &apps[0];
        let Some(simulation) = app.world().get::<ClothSimulation>(scene.cloth) else {
            assert!(k < 2, "built in the first steps");
            continue;
        };
        let level = simulation.level_of_detail();
        let expected = match k {
            128..160 => 1,
            160..224 => 2,
            _ => 0,
        };
        assert_eq!(level, expected, "step {k}");
        // Frozen: the sheet keeps its shape in the carrier's frame.
        let carrier = Vec3::new(x, at.y, at.z);
        let relative: Vec<Vec3> = positions(app, scene.cloth)
            .iter()
            .map(|p| *p - carrier)
            .collect();
        if level == 2 {
            if let Some(before) = &frozen_relative {
                let drift = largest_move(before, &relative);
                assert!(drift < 1e-4, "step {k}: frozen sheet drifted {drift} m");
            }
            frozen_relative = Some(relative);
        }
    }
    assert!(
        worst[0] <= worst[1] + 0.05,
        "relative speed with levels of detail {} m/s, without {} m/s",
        worst[0],
        worst[1]
    );
}

#[test]
fn a_hidden_cloth_is_not_drawn_and_comes_back_as_it_was() {
    let mut app = crate::common::app();
    let scene = spawn(&mut app, Vec3::new(0.0, 1.5, 0.0), settings());
    app.world_mut()
        .entity_mut(scene.cloth)
        .insert(Visibility::Visible);
    let viewer = app.world_mut().spawn(Transform::default()).id();
    app.insert_resource(ClothLevelOfDetail {
        viewer: Some(viewer),
        levels: vec![LodLevel {
            beyond: 5.0,
            budget: LodBudget::Hidden,
        }],
    });
    let visibility = |app: &App| *app.world().get::<Visibility>(scene.cloth).unwrap();
    for _ in 0..4 {
        app.update();
    }
    assert_eq!(visibility(&app), Visibility::Visible);
    app.world_mut()
        .get_mut::<Transform>(viewer)
        .unwrap()
        .translation
        .z = 20.0;
    app.update();
    app.update();
    assert_eq!(visibility(&app), Visibility::Hidden);
    app.world_mut()
        .get_mut::<Transform>(viewer)
        .unwrap()
        .translation
        .z = 0.0;
    app.update();
    app.update();
    assert_eq!(visibility(&app), Visibility::Visible);
}

#[test]
fn bad_level_of_detail_input_is_warned_about_and_the_full_budget_kept() {
    crate::common::warnings::capture_warnings();
    // Levels that are not increasing.
    let mut app = crate::common::app();
    let scene = spawn(&mut app, Vec3::new(0.0, 1.5, 0.0), settings());
    let viewer = app
        .world_mut()
        .spawn(Transform::from_xyz(50.0, 0.0, 0.0))
        .id();
    let mut lod = two_levels();
    lod.viewer = Some(viewer);
    lod.levels[1].beyond = 1.0;
    app.insert_resource(lod);
    for _ in 0..8 {
        app.update();
    }
    let simulation = app.world().get::<ClothSimulation>(scene.cloth).unwrap();
    assert_eq!(simulation.level_of_detail(), 0, "full budget");
    assert!(simulation.solver().last_timings().total() > Duration::ZERO);
    // A viewer that does not exist: warned about by its id, no camera to fall back on.
    let gone = app.world_mut().spawn_empty().id();
    app.world_mut().despawn(gone);
    app.insert_resource(ClothLevelOfDetail {
        viewer: Some(gone),
        ..two_levels()
    });
    for _ in 0..8 {
        app.update();
    }
    let simulation = app.world().get::<ClothSimulation>(scene.cloth).unwrap();
    assert_eq!(simulation.level_of_detail(), 0, "full budget");
    assert!(simulation.solver().last_timings().total() > Duration::ZERO);
    assert!(positions(&app, scene.cloth).iter().all(|p| p.is_finite()));
    let warnings = crate::common::warnings::WARNINGS.lock().unwrap();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("ClothLevelOfDetail") && w.contains("larger than")),
        "the levels are warned about"
    );
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("ClothLevelOfDetail") && w.contains(&gone.to_string())),
        "the viewer is named"
    );
}
