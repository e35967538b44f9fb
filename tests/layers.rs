//! Cloths stepped as layers of one solve (`LayerSolver`, `ClothLayers`): two sheets dropped
//! on a sphere stay apart, the solve is the cloths' own physics where they do not touch,
//! contacts between them keep momentum, and bad layer lists are warned about.

use crate::common;

use bevy::math::Vec3A;
use bevy::prelude::*;
use bevy_drape::cloth::{
    ClothModel, ClothSolver, GridDesc, LayerSolver, OneThread, SolverSettings, TwoPoses,
    count_crossings_between,
};
use bevy_drape::prelude::*;
use common::warnings::{capture_warnings, warnings_with};
use common::{Headless, add_grid};
use drape_scenes::scenes::{FRAME_RATE, GRAVITY, LayeredDrop};

/// Generated drops of two coarse sheets on a sphere: stepped apart they pass through each
/// other hundreds of times; as layers, never, with their edges within 2%.
#[test]
fn two_sheets_dropped_on_a_sphere_as_layers_never_cross_and_apart_they_do() {
    let settings = LayeredDrop::settings();
    let mut crossings_apart = 0;
    for seed in 1..=4 {
        let scene = LayeredDrop::generated(12, seed);
        crossings_apart += scene.run(&settings, 120, false).crossings_between;
        let layered = scene.run(&settings, 120, true);
        println!(
            "seed {seed}: strain {}, closest {} m",
            layered.max_strain, layered.closest
        );
        assert!(layered.finite, "seed {seed}");
        assert_eq!(layered.crossings_between, 0, "seed {seed}: {scene:?}");
        assert!(layered.max_strain < 0.02, "seed {seed}: {layered:?}");
    }
    assert!(crossings_apart > 100, "apart: {crossings_apart} crossings");
}

/// Two sheets hanging from their top corners far apart (no contact between them), swayed by
/// their pins, move the same stepped as layers of one solve as each stepped alone: the first
/// to rounding (within ten times where a nudge of 1e-6 m takes it), the second within 0.5% of
/// its motion (its constraints are swept in another order: batches of four start elsewhere,
/// the bending pairs are coloured with the first's). The solve adds nothing but the contacts.
#[test]
fn layers_that_do_not_touch_move_as_each_cloth_alone() {
    let settings = SolverSettings {
        self_collision: SelfCollisionMethod::Triangles,
        ..SolverSettings::default()
    };
    let n = 9;
    let top = |x: f32| Vec3::new(x, 1.0, 0.0);
    let sheet = |x: f32| {
        let mut grid = GridDesc::square(0.5, n, top(x));
        // Rows hang down from the top one.
        grid.orientation = Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.2).expect("a valid grid"));
        sim.set_pins(&[0, n - 1]).expect("pins in range");
        sim
    };
    let (mut a, mut b) = (sheet(0.0), sheet(2.0));
    let (mut alone_a, mut alone_b) = (a.clone(), b.clone());
    // The same, one particle moved by 1e-6 m: how far rounding alone takes each cloth.
    let (mut nudged_a, mut nudged_b) = (a.clone(), b.clone());
    nudged_a.state_mut().positions[40].x += 1e-6;
    nudged_b.state_mut().positions[40].x += 1e-6;
    let mut layers = LayerSolver::new(&[&a, &b]).expect("two cloths");
    let dt = 1.0 / FRAME_RATE;
    for step in 0..120 {
        let sway = Vec3::new(0.0, 0.0, 0.15 * (step as f32 * 0.08).sin());
        for (sim, x) in [
            (&mut a, 0.0),
            (&mut b, 2.0),
            (&mut alone_a, 0.0),
            (&mut alone_b, 2.0),
            (&mut nudged_a, 0.0),
            (&mut nudged_b, 2.0),
        ] {
            sim.set_pin_target(0, top(x) + sway);
            sim.set_pin_target(n - 1, top(x) + sway + Vec3::X * 0.5);
        }
        layers.gather(0, &a).unwrap();
        layers.gather(1, &b).unwrap();
        layers.step(&settings, GRAVITY, dt, &OneThread).unwrap();
        layers.scatter(0, &mut a).unwrap();
        layers.scatter(1, &mut b).unwrap();
        alone_a.step(&settings, GRAVITY, dt).unwrap();
        alone_b.step(&settings, GRAVITY, dt).unwrap();
        nudged_a.step(&settings, GRAVITY, dt).unwrap();
        nudged_b.step(&settings, GRAVITY, dt).unwrap();
    }
    let farthest = |p: &ClothSolver, q: &ClothSolver| {
        p.state()
            .positions
            .iter()
            .zip(&q.state().positions)
            .map(|(p, q)| p.distance(*q))
            .fold(0.0f32, f32::max)
    };
    for (k, (layered, alone, nudged)) in [(&a, &alone_a, &nudged_a), (&b, &alone_b, &nudged_b)]
        .into_iter()
        .enumerate()
    {
        let rounding = farthest(nudged, alone);
        let apart = farthest(layered, alone);
        // How far the cloth moved from its rest shape.
        let moved = layered
            .state()
            .positions
            .iter()
            .zip(&layered.model().rest_positions)
            .map(|(p, &q)| p.distance(q.into()))
            .fold(0.0f32, f32::max);
        println!("cloth {k}: {apart} m from alone, rounding {rounding} m, moved {moved} m");
        assert!(moved > 0.05, "cloth {k} moved {moved} m");
        if k == 0 {
            assert!(apart < 10.0 * rounding, "cloth {k}: {apart} m");
        }
        assert!(apart < 0.005 * moved, "cloth {k}: {apart} m");
        assert!(layered.pins()[0].start.distance(layered.pins()[0].end) < 1e-6);
    }
}

/// Two sheets thrown at each other in zero gravity (random velocities toward each other, no
/// colliders, no damping): the contacts between the layers push both, and the total
/// momentum stays what it was.
#[test]
fn layers_thrown_at_each_other_keep_their_momentum() {
    let settings = SolverSettings {
        damping: 0.0,
        air: None,
        ..SolverSettings::default()
    };
    let mut rng = bevy_drape::rng::Rng(7);
    let sheet = |y: f32| {
        ClothSolver::new(
            ClothModel::grid(&GridDesc::square(0.6, 10, Vec3::new(0.0, y, 0.0)), 0.2)
                .expect("a valid grid"),
        )
    };
    let (mut lower, mut upper) = (sheet(0.0), sheet(0.03));
    for (sim, towards) in [(&mut lower, 1.0), (&mut upper, -1.0)] {
        for v in &mut sim.state_mut().velocities {
            *v = Vec3A::new(
                rng.range(-0.2, 0.2),
                towards * rng.range(0.5, 1.5),
                rng.range(-0.2, 0.2),
            );
        }
    }
    let momentum = |sims: [&ClothSolver; 2]| {
        sims.iter()
            .flat_map(|s| {
                (0..s.state().velocities.len()).map(|i| s.state().velocities[i] * s.model().mass(i))
            })
            .sum::<Vec3A>()
    };
    let before = momentum([&lower, &upper]);
    // The momentum of the whole at 1 m/s.
    let scale: f32 = [&lower, &upper]
        .iter()
        .map(|s| s.model().total_mass())
        .sum();
    let mut layers = LayerSolver::new(&[&lower, &upper]).unwrap();
    let mut crossings = 0;
    for _ in 0..30 {
        let start = [
            lower.state().positions.clone(),
            upper.state().positions.clone(),
        ];
        layers.gather(0, &lower).unwrap();
        layers.gather(1, &upper).unwrap();
        layers
            .step(&settings, Vec3::ZERO, 1.0 / FRAME_RATE, &OneThread)
            .unwrap();
        layers.scatter(0, &mut lower).unwrap();
        layers.scatter(1, &mut upper).unwrap();
        crossings += count_crossings_between(
            TwoPoses {
                before: &start[0],
                after: &lower.state().positions,
            },
            TwoPoses {
                before: &start[1],
                after: &upper.state().positions,
            },
            &upper.model().triangles,
            settings.thickness,
        );
    }
    let after = momentum([&lower, &upper]);
    assert_eq!(crossings, 0, "the lower sheet went through the upper one");
    assert!(
        (after - before).length() < 1e-3 * scale,
        "momentum {before} became {after}"
    );
    // They met: each layer's mean vertical velocity turned.
    let mean_y = |s: &ClothSolver| {
        s.state().velocities.iter().map(|v| v.y).sum::<f32>() / s.state().velocities.len() as f32
    };
    assert!(mean_y(&lower) < 0.5 && mean_y(&upper) > -0.5);
}

/// In an App: two sheets listed in `ClothLayers` (with a dead entity and one of them twice,
/// both warned about) drop onto a sphere without passing through each other.
#[test]
fn cloth_layers_in_an_app_keep_two_sheets_apart_and_warn_about_a_bad_list() {
    capture_warnings();
    let mut app = Headless::new().seconds_per_update(1.0 / 60.0).build();
    let scene = LayeredDrop::new(10);
    let settings = ClothSettings {
        solver: LayeredDrop::settings(),
        ..default()
    };
    let sheets = scene.grids().map(|grid| {
        let mesh = add_grid(&mut app, &grid);
        app.world_mut()
            .spawn((Mesh3d(mesh), Cloth::default(), settings))
            .id()
    });
    app.world_mut().spawn((
        ClothCollider::sphere(LayeredDrop::RADIUS),
        Transform::from_xyz(0.0, LayeredDrop::RADIUS, 0.0),
    ));
    app.world_mut().spawn(ClothCollider::plane());
    let gone = app.world_mut().spawn_empty().id();
    app.world_mut().despawn(gone);
    app.world_mut()
        .spawn(ClothLayers(vec![sheets[0], gone, sheets[1], sheets[0]]));
    let positions = |app: &App, k: usize| {
        app.world()
            .get::<ClothSimulation>(sheets[k])
            .map(|c| c.solver().state().positions.clone())
    };
    let triangles = |app: &App, k: usize| {
        app.world()
            .get::<ClothSimulation>(sheets[k])
            .map(|c| c.solver().model().triangles.clone())
            .unwrap_or_default()
    };
    let mut crossings = 0;
    let mut before = [positions(&app, 0), positions(&app, 1)];
    for _ in 0..150 {
        app.update();
        let now = [positions(&app, 0), positions(&app, 1)];
        if let ([Some(b0), Some(b1)], [Some(n0), Some(n1)]) = (&before, &now) {
            let (a, b) = (
                TwoPoses {
                    before: b0,
                    after: n0,
                },
                TwoPoses {
                    before: b1,
                    after: n1,
                },
            );
            crossings += count_crossings_between(a, b, &triangles(&app, 1), 0.005)
                + count_crossings_between(b, a, &triangles(&app, 0), 0.005);
        }
        before = now;
    }
    let lower = positions(&app, 0).expect("built");
    assert!(lower.iter().all(|p| p.is_finite()));
    // It fell onto the sphere (from 30 cm above its top; a fold held up by the upper sheet's
    // friction may stand a few centimetres over it after 2.5 s).
    let top = lower.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    assert!(top < 2.0 * LayeredDrop::RADIUS + 0.1, "top {top}");
    assert_eq!(crossings, 0);
    assert_eq!(warnings_with(&["cloth layers", "no longer exists"]), 1);
    assert_eq!(warnings_with(&["cloth layers", "listed twice"]), 1);
}

/// The main scene with a shawl under the poncho (`PonchoScene::layers` = 2), walking and
/// jogging for 10 s: neither garment passes through the other, both stay within 2% strain
/// after the first second, and the poncho stays on the character.
#[test]
fn a_shawl_under_the_poncho_stays_under_it_walking_and_jogging() {
    use drape_scenes::poncho::{CharacterMotion, PonchoScene, run_headless};
    let margin = BoneColliders::humanoid().margin;
    for motion in [CharacterMotion::Walk, CharacterMotion::Jog] {
        let scene = PonchoScene {
            motion,
            layers: 2,
            ..PonchoScene::default()
        };
        let run = run_headless(scene, 600).unwrap();
        let name = motion.name();
        println!(
            "{name}: {} layer crossings, strain {} (poncho) {} (shawl)",
            run.layer_crossings,
            run.strain_max_after_first_second,
            run.shawl_strain_max_after_first_second
        );
        assert_eq!(run.layer_crossings, 0, "{name}");
        assert!(run.strain_max_after_first_second <= 0.02, "{name}");
        assert!(
            run.shawl_strain_max_after_first_second > 0.0
                && run.shawl_strain_max_after_first_second <= 0.02,
            "{name}: the shawl's strain {}",
            run.shawl_strain_max_after_first_second
        );
        if let Err(why) = run.check(margin) {
            panic!("{name}: {why}");
        }
    }
}

/// Two flat sheets one above the other are not tangled; the same with the upper one tilted
/// through the lower one are, and the solve says which.
#[test]
fn sheets_that_start_through_each_other_are_found_tangled() {
    let sheet = |y: f32, tilt: f32| {
        let mut grid = GridDesc::square(1.0, 8, Vec3::new(-0.5, y, -0.5));
        grid.orientation = Quat::from_rotation_x(tilt);
        ClothSolver::new(ClothModel::grid(&grid, 0.2).expect("a valid grid"))
    };
    // Tilted 0.3 rad from 15 cm below: through the lower sheet along its middle.
    let (lower, above, through) = (sheet(0.0, 0.0), sheet(0.05, 0.0), sheet(-0.15, -0.3));
    let apart = LayerSolver::new(&[&lower, &above]).unwrap();
    assert!(apart.tangled_layers().is_empty());
    let tangled = LayerSolver::new(&[&lower, &through]).unwrap();
    assert_eq!(tangled.tangled_layers(), vec![(0, 1)]);
}

/// The upper of two sheets laid on a sphere stays where it landed on the lower one for 20 s
/// with the default friction between the layers (its friction anchored on the lower sheet's
/// triangles: measured from the substep's start, the edges' small slides added up and it
/// crept off the ball), and slides off without friction.
#[test]
fn a_sheet_resting_on_another_stays_put_with_friction_and_slides_off_without() {
    let scene = LayeredDrop::new(12);
    let settings = LayeredDrop::settings();
    let held = scene.run(&settings, 1200, true);
    println!("friction {}: slid {} m", settings.friction, held.slide);
    assert!(held.finite && held.crossings_between == 0);
    assert!(held.slide < 0.01, "slid {} m with friction", held.slide);
    let slippery = SolverSettings {
        friction: 0.0,
        ..settings
    };
    let slid = scene.run(&slippery, 1200, true);
    assert!(
        slid.slide > 0.1,
        "slid only {} m without friction",
        slid.slide
    );
}
