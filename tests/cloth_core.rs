//! Accuracy tests of the cloth core against analytic results and conservation laws, without
//! an App.

use std::f32::consts::PI;

use bevy::math::{Vec3, Vec3A};
use bevy_drape::cloth::{
    ClothModel, ClothSolver, DampingMode, EdgeKind, GridDesc, SolverMethod, SolverSettings,
};
use bevy_drape::error::{ClothError, ClothWarning};
use drape_scenes::scenes::{GRAVITY, HangingCloth, lowest_height};
use drape_scenes::study::sag;

const DT: f32 = 1.0 / 60.0;

/// No damping and no long-range constraints (one edge or one particle needs none, and a
/// single iteration may not have them).
fn undamped(substeps: u32, iterations: u32) -> SolverSettings {
    SolverSettings {
        substeps,
        iterations,
        damping: 0.0,
        long_range_attachments: false,
        ..Default::default()
    }
}

fn free_grid(n: u32) -> ClothSolver {
    let grid = GridDesc::square(1.0, n, Vec3::new(-0.5, 2.0, -0.5));
    ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap())
}

/// Times at which `signal` crosses zero upward, linearly interpolated.
fn upward_crossings(times: &[f32], signal: &[f32]) -> Vec<f32> {
    let mut out = Vec::new();
    for k in 1..signal.len() {
        if signal[k - 1] < 0.0 && signal[k] >= 0.0 {
            let f = -signal[k - 1] / (signal[k] - signal[k - 1]);
            out.push(times[k - 1] + f * (times[k] - times[k - 1]));
        }
    }
    out
}

fn mean_period(crossings: &[f32]) -> f32 {
    assert!(crossings.len() >= 3, "too few oscillations: {crossings:?}");
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f32
}

#[test]
fn free_fall_follows_the_parabola_and_keeps_its_shape_under_rigid_damping() {
    let mut sim = free_grid(9);
    let settings = SolverSettings {
        damping: 2.0,
        damping_mode: DampingMode::Rigid,
        ..Default::default()
    };
    let y0 = sim.rigid_motion().unwrap().center_of_mass.y;
    let rest: Vec<Vec3A> = sim.state().positions.clone();
    for _ in 0..60 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let com = sim.rigid_motion().unwrap().center_of_mass;
    let expected = y0 - 0.5 * 9.81 * 1.0;
    println!("rigid damping: y = {}, expected {expected}", com.y);
    assert!(
        (com.y - expected).abs() < 1e-4,
        "y = {}, expected {expected}",
        com.y
    );
    // The shape is the rest shape, translated.
    let shift = sim.state().positions[0] - rest[0];
    for (p, r) in sim.state().positions.iter().zip(&rest) {
        assert!((*p - *r - shift).length() < 1e-5);
    }

    // Plain damping slows the fall itself.
    let mut plain = free_grid(9);
    let settings = SolverSettings {
        damping_mode: DampingMode::Plain,
        ..settings
    };
    for _ in 0..60 {
        plain.step(&settings, GRAVITY, DT).unwrap();
    }
    let y_plain = plain.rigid_motion().unwrap().center_of_mass.y;
    println!("plain damping: y = {y_plain}, expected {expected}");
    assert!(
        y_plain - expected > 0.5,
        "plain damping should slow the fall"
    );
}

#[test]
fn a_spinning_free_cloth_keeps_its_angular_momentum_under_rigid_damping_only() {
    // Centred on the origin: f32 positions far from it add rounding noise to the rotation.
    // What remains is the O(h) angular-momentum loss of projecting a rotating particle back
    // onto its constraints (0.7% over 2 s at 20 substeps, 1.6% at 8).
    let spin = |mode: DampingMode| {
        let grid = GridDesc::square(1.0, 9, Vec3::new(-0.5, 0.0, -0.5));
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
        let omega = Vec3A::new(0.3, 2.0, 0.0);
        let com = sim.rigid_motion().unwrap().center_of_mass;
        let state = sim.state_mut();
        for (v, x) in state.velocities.iter_mut().zip(&state.positions) {
            *v = omega.cross(*x - com);
        }
        let l0 = sim.rigid_motion().unwrap().angular_momentum;
        let settings = SolverSettings {
            substeps: 20,
            damping: 1.0,
            damping_mode: mode,
            ..Default::default()
        };
        for _ in 0..120 {
            sim.step(&settings, Vec3::ZERO, DT).unwrap();
        }
        let l1 = sim.rigid_motion().unwrap().angular_momentum;
        (l1 - l0).length() / l0.length()
    };
    let rigid = spin(DampingMode::Rigid);
    let plain = spin(DampingMode::Plain);
    println!("relative change of L over 2 s: rigid {rigid}, plain {plain}");
    assert!(rigid < 0.01, "rigid damping changed L by {rigid}");
    assert!(
        plain > 0.5,
        "plain damping should drain L, changed by {plain}"
    );
}

#[test]
fn pendulum_period_matches_small_amplitude_theory() {
    let length = 1.0;
    let amplitude = 3.0f32.to_radians();
    let positions = [
        Vec3::ZERO,
        Vec3::new(length * amplitude.sin(), -length * amplitude.cos(), 0.0),
    ];
    let model = ClothModel::from_particles(&positions, &[0.0, 1.0], &[[0, 1]]).unwrap();
    let mut sim = ClothSolver::new(model);
    sim.set_pins(&[0]).unwrap();
    let settings = undamped(20, 1);
    let (mut times, mut xs) = (Vec::new(), Vec::new());
    for frame in 1..=60 * 12 {
        sim.step(&settings, GRAVITY, DT).unwrap();
        times.push(frame as f32 * DT);
        xs.push(sim.state().positions[1].x);
    }
    let period = mean_period(&upward_crossings(&times, &xs));
    let theory = 2.0 * PI * (length / 9.81).sqrt();
    println!("pendulum period {period} s, theory {theory} s");
    assert!((period - theory).abs() / theory < 0.005);
}

#[test]
fn compliant_constraint_oscillates_like_a_spring_of_stiffness_one_over_compliance() {
    let (mass, stiffness, rest) = (0.1f32, 40.0f32, 0.5f32);
    let positions = [Vec3::ZERO, Vec3::new(0.0, -rest, 0.0)];
    let model = ClothModel::from_particles(&positions, &[0.0, mass], &[[0, 1]]).unwrap();
    let mut sim = ClothSolver::new(model);
    sim.set_pins(&[0]).unwrap();
    let settings = SolverSettings {
        stretch_compliance: 1.0 / stiffness,
        ..undamped(20, 1)
    };
    let equilibrium = -(rest + mass * 9.81 / stiffness);
    let (mut times, mut ys) = (Vec::new(), Vec::new());
    for frame in 1..=120 {
        sim.step(&settings, GRAVITY, DT).unwrap();
        times.push(frame as f32 * DT);
        ys.push(sim.state().positions[1].y - equilibrium);
    }
    let period = mean_period(&upward_crossings(&times, &ys));
    let theory = 2.0 * PI * (mass / stiffness).sqrt();
    println!("spring period {period} s, theory {theory} s");
    assert!((period - theory).abs() / theory < 0.01);
}

/// Sag of the S1 cloth (N = 16) at rest with stretch compliance 0.05 m/N.
fn s1_sag(method: SolverMethod, iterations: u32) -> f32 {
    sag(method, iterations, 0.05)
}

#[test]
fn xpbd_sag_does_not_depend_on_iterations_but_pbd_sag_does() {
    let spread = |sags: &[f32]| {
        let max = sags.iter().copied().fold(f32::MIN, f32::max);
        let min = sags.iter().copied().fold(f32::MAX, f32::min);
        (max - min) / min
    };
    let xpbd: Vec<f32> = [5, 10, 20]
        .map(|it| s1_sag(SolverMethod::Xpbd, it))
        .to_vec();
    let pbd: Vec<f32> = [5, 10, 20]
        .map(|it| s1_sag(SolverMethod::Pbd { stiffness: 0.05 }, it))
        .to_vec();
    let inextensible = sag(SolverMethod::Xpbd, 20, 0.0);
    println!("sag at 5/10/20 iterations: XPBD {xpbd:?}, PBD {pbd:?}, inextensible {inextensible}");
    // The compliance is visible: the cloth hangs centimetres lower than an inextensible one.
    assert!(xpbd[0] > inextensible + 0.03);
    assert!(spread(&xpbd) < 0.05, "XPBD sag spread {}", spread(&xpbd));
    assert!(
        spread(&pbd) > 3.0 * spread(&xpbd),
        "PBD sag spread {} vs XPBD {}",
        spread(&pbd),
        spread(&xpbd)
    );
}

#[test]
fn s1_at_n32_with_compliance_zero_stays_below_one_percent_strain() {
    // The budget: the defaults, 8 substeps x 2 iterations per 1/60 s frame, long-range
    // attachments and stretch limits on.
    let settings = SolverSettings::default();
    assert_eq!((settings.substeps, settings.iterations), (8, 2));
    let run = HangingCloth { n: 32 }.run(&settings, 120);
    let max_strain = run.trajectory.end_strain();
    println!(
        "S1 N=32 8x2: max strain {max_strain}, mean {}",
        run.mean_strain
    );
    assert!(run.finite);
    assert!(max_strain < 0.01, "max strain {max_strain}");
    // The cloth did fall: the free corner left its start (1, 1, 1).
    let corner = *run.trajectory.corner.last().unwrap();
    assert!(corner.distance(Vec3::ONE) > 0.3);
}

#[test]
fn tethers_bound_the_stretch_of_a_pinned_cloth() {
    let scene = HangingCloth { n: 24 };
    let sim = |tethers: bool| {
        let settings = SolverSettings {
            substeps: 2,
            iterations: 2,
            long_range_attachments: tethers,
            ..Default::default()
        };
        scene.run(&settings, 60).trajectory.end_strain()
    };
    let (with, without) = (sim(true), sim(false));
    println!("max strain at a small budget: with tethers {with}, without {without}");
    assert!(with < 0.5 * without);
}

#[test]
fn mesh_cloth_mass_is_density_times_area() {
    // A non-uniform mesh: a quad split unevenly plus a far triangle.
    let positions = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 1.0),
        Vec3::new(0.3, 0.0, 1.0),
        Vec3::new(3.0, 1.0, 0.5),
    ];
    let indices = [0, 3, 2, 0, 2, 1, 1, 2, 4];
    let model = ClothModel::from_triangles(&positions, &indices, 0.25).unwrap();
    let area = 0.5 * (2.0 * 1.0 + 1.7 * 1.0)
        + 0.5
            * (positions[2] - positions[1])
                .cross(positions[4] - positions[1])
                .length();
    assert!(
        (model.area() - area).abs() < 1e-5,
        "{} vs {area}",
        model.area()
    );
    assert!((model.total_mass() - 0.25 * area).abs() < 1e-6);
    // Edges are de-duplicated and bending pairs found once.
    assert_eq!(model.edges.len(), 7);
    assert_eq!(model.bending_pairs.len(), 2);
}

#[test]
fn grid_edges_are_tagged_and_counted() {
    let n = 5;
    let model = ClothModel::grid(&GridDesc::square(1.0, n, Vec3::ZERO), 0.1).unwrap();
    let structural = model
        .edges
        .iter()
        .filter(|e| e.kind == EdgeKind::Structural)
        .count();
    let shear = model.edges.len() - structural;
    assert_eq!(structural as u32, 2 * n * (n - 1));
    assert_eq!(shear as u32, (n - 1) * (n - 1));
    // Interior edges: every edge but the 4 (n - 1) boundary ones.
    assert_eq!(
        model.bending_pairs.len(),
        model.edges.len() - 4 * (n as usize - 1)
    );
    for pair in &model.bending_pairs {
        assert!(pair.rest_angle.abs() < 1e-6);
    }
}

#[test]
fn bad_input_gives_typed_errors_and_warnings() {
    let quad = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z];
    let ok = [0, 3, 2, 0, 2, 1];
    assert_eq!(
        ClothModel::from_triangles(&quad, &[], 0.1).unwrap_err(),
        ClothError::NoTriangles
    );
    let mut nan = quad;
    nan[2].y = f32::NAN;
    assert_eq!(
        ClothModel::from_triangles(&nan, &ok, 0.1).unwrap_err(),
        ClothError::NonFinitePosition { vertex: 2 }
    );
    assert_eq!(
        ClothModel::from_triangles(&quad, &ok, -1.0).unwrap_err(),
        ClothError::InvalidDensity(-1.0)
    );
    assert_eq!(
        ClothModel::from_triangles(&quad, &[0, 1, 7], 0.1).unwrap_err(),
        ClothError::IndexOutOfRange {
            index: 7,
            vertex_count: 4
        }
    );
    assert_eq!(
        ClothModel::from_triangles(&quad, &[0, 1], 0.1).unwrap_err(),
        ClothError::IndexCountNotTriangles(2)
    );
    // A zero-area triangle is dropped with a warning; the rest is built.
    let collinear = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::Z];
    let model = ClothModel::from_triangles(&collinear, &[0, 1, 2, 0, 3, 1], 0.1).unwrap();
    assert_eq!(model.triangles.len(), 1);
    assert!(
        model
            .warnings
            .contains(&ClothWarning::DegenerateTriangle { triangle: 0 })
    );
    // Only zero-area triangles: no cloth.
    assert_eq!(
        ClothModel::from_triangles(&collinear, &[0, 1, 2], 0.1).unwrap_err(),
        ClothError::NoTriangles
    );
    // Pins out of range.
    let mut sim = ClothSolver::new(ClothModel::from_triangles(&quad, &ok, 0.1).unwrap());
    assert!(matches!(
        sim.set_pins(&[9]),
        Err(ClothError::VertexOutOfRange { vertex: 9, .. })
    ));
    // A NaN pin target is refused.
    sim.set_pins(&[0]).unwrap();
    assert!(!sim.set_pin_target(0, Vec3::NAN));
    // Settings out of range.
    let bad = SolverSettings {
        substeps: 0,
        ..Default::default()
    };
    assert!(bad.validate().is_err());
    let one_sweep = SolverSettings {
        iterations: 1,
        ..Default::default()
    };
    assert!(matches!(
        one_sweep.validate(),
        Err(ClothError::InvalidSetting {
            name: "iterations",
            ..
        })
    ));
    let one_sweep_no_long_range = SolverSettings {
        long_range_attachments: false,
        ..one_sweep
    };
    assert!(one_sweep_no_long_range.validate().is_ok());
    // An exact edge solve without a step or an iteration is refused, and the step with it
    // leaves the cloth as it was.
    let no_solve = SolverSettings {
        exact_edges: Some(bevy_drape::cloth::ExactEdges {
            newton_steps: 1,
            cg_iterations: 0,
        }),
        ..Default::default()
    };
    assert!(matches!(
        no_solve.validate(),
        Err(ClothError::InvalidSetting {
            name: "exact_edges",
            ..
        })
    ));
    let before = sim.state().positions.clone();
    assert!(sim.step(&no_solve, Vec3::NEG_Y, 1.0 / 60.0).is_err());
    assert_eq!(sim.state().positions, before);
}

#[test]
fn moving_pins_drag_the_cloth_and_reset_restores_the_start() {
    let scene = HangingCloth { n: 8 };
    let mut sim = scene.build();
    let start = sim.state().clone();
    let settings = SolverSettings::default();
    for frame in 1..=60 {
        for pin in scene.pins() {
            let rest = sim.model().rest_positions[pin as usize];
            sim.set_pin_target(pin, rest + Vec3::X * (frame as f32 * 0.01));
        }
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    for pin in scene.pins() {
        let rest = sim.model().rest_positions[pin as usize];
        let now = Vec3::from(sim.state().positions[pin as usize]);
        assert!(now.distance(rest + Vec3::X * 0.6) < 1e-5);
    }
    let com = sim.rigid_motion().unwrap().center_of_mass;
    assert!(com.x > 0.5 + 0.3, "the cloth followed its pins: {com}");
    sim.reset();
    assert_eq!(sim.state(), &start);
}

#[test]
fn pins_set_or_released_between_steps_hold_or_let_go() {
    // The solver keeps per-step copies of the inverse masses; changing the pins between steps
    // must reach every constraint.
    let mut sim = free_grid(8);
    let settings = SolverSettings::default();
    for _ in 0..10 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let corner = 0;
    sim.set_pins(&[corner]).unwrap();
    let held = sim.state().positions[corner as usize];
    for _ in 0..60 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    assert_eq!(sim.state().positions[corner as usize], held);
    // The rest of the cloth hangs below the corner, not falling away.
    let com = sim.rigid_motion().unwrap().center_of_mass;
    assert!(com.y < held.y && held.y - com.y < 1.0, "{com} below {held}");
    assert!(sim.strain().max < 0.05, "{:?}", sim.strain());
    // Released, the corner falls with the rest.
    sim.set_pins(&[]).unwrap();
    for _ in 0..30 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let fell = held.y - sim.state().positions[corner as usize].y;
    let free_fall = 0.5 * GRAVITY.length() * (30.0 * DT).powi(2);
    assert!(fell > 0.5 * free_fall, "fell {fell} m");
}

#[test]
fn ground_plane_holds_a_dropped_cloth_at_its_thickness() {
    let mut sim = free_grid(10);
    sim.set_colliders(&[bevy_drape::collide::SolverCollider::ground(
        0.0,
        Default::default(),
    )])
    .unwrap();
    let settings = SolverSettings::default();
    for _ in 0..180 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    for p in &sim.state().positions {
        assert!(p.y >= settings.thickness - 1e-5, "{p}");
        assert!(p.y < settings.thickness + 1e-3, "{p}");
    }
    assert!(sim.kinetic_energy() < 1e-6);
}

#[test]
fn the_step_is_deterministic() {
    let run = || {
        let mut sim = HangingCloth { n: 16 }.build();
        sim.set_colliders(&[bevy_drape::collide::SolverCollider::ground(
            0.2,
            Default::default(),
        )])
        .unwrap();
        let settings = SolverSettings::default();
        for _ in 0..60 {
            sim.step(&settings, GRAVITY, DT).unwrap();
        }
        sim.state()
            .positions
            .iter()
            .chain(&sim.state().velocities)
            .flat_map(|v| v.to_array())
            .map(f32::to_bits)
            .collect::<Vec<u32>>()
    };
    assert_eq!(run(), run());
}

/// Tip sag of a clamped horizontal strip held up by its bending stiffness.
fn cantilever_sag(isometric: bool, bend_compliance: f32) -> f32 {
    let grid = GridDesc {
        size: bevy::math::Vec2::new(0.15, 0.1),
        vertices: bevy::math::UVec2::new(7, 5),
        orientation: bevy::math::Quat::IDENTITY,
        origin: Vec3::new(0.0, 1.0, 0.0),
    };
    let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
    let clamped: Vec<u32> = (0..5)
        .flat_map(|j| [grid.index(0, j), grid.index(1, j)])
        .collect();
    sim.set_pins(&clamped).unwrap();
    let settings = SolverSettings {
        substeps: 32,
        iterations: 2,
        bend_compliance,
        isometric_bending: isometric,
        damping: 8.0,
        damping_mode: DampingMode::Plain,
        ..Default::default()
    };
    for _ in 0..180 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let tip = (0..5)
        .map(|j| sim.state().positions[grid.index(6, j) as usize].y)
        .sum::<f32>()
        / 5.0;
    1.0 - tip
}

#[test]
fn isometric_and_dihedral_bending_hold_a_cantilever_alike() {
    let stiff_iso = cantilever_sag(true, 10.0);
    let stiff_dihedral = cantilever_sag(false, 10.0);
    let soft_iso = cantilever_sag(true, 1000.0);
    let soft_dihedral = cantilever_sag(false, 1000.0);
    println!(
        "cantilever sag: compliance 10: isometric {stiff_iso}, dihedral {stiff_dihedral}; \
         compliance 1000: isometric {soft_iso}, dihedral {soft_dihedral}"
    );
    // Bending is what holds the strip: a softer one sags clearly more.
    assert!(soft_dihedral > 5.0 * stiff_dihedral);
    for (iso, dihedral) in [(stiff_iso, stiff_dihedral), (soft_iso, soft_dihedral)] {
        assert!(
            (iso - dihedral).abs() < 0.03 * dihedral,
            "isometric {iso} vs dihedral {dihedral}"
        );
    }
}

#[test]
fn a_falling_particle_keeps_its_kinetic_plus_potential_energy() {
    // Thrown up and sideways from 1 m: E = m v^2 / 2 + m g y, constant along the parabola.
    let model = ClothModel::from_particles(&[Vec3::Y], &[2.0], &[]).unwrap();
    let mut sim = ClothSolver::new(model);
    sim.state_mut().velocities[0] = Vec3::new(1.0, 3.0, 0.0).into();
    let settings = undamped(8, 1);
    let energy = |sim: &ClothSolver| sim.kinetic_energy() + sim.potential_energy(GRAVITY);
    let start = energy(&sim);
    assert!(
        (start - (0.5 * 2.0 * 10.0 + 2.0 * 9.81 * 1.0)).abs() < 1e-4,
        "{start}"
    );
    for _ in 0..60 {
        sim.step(&settings, GRAVITY, DT).unwrap();
        // The velocity is the end-of-step one, so the sum holds to rounding.
        assert!(
            (energy(&sim) - start).abs() < 1e-3 * start,
            "{} vs {start}",
            energy(&sim)
        );
    }
    assert!(sim.state().positions[0].y < 1.0, "it came down again");
}

#[test]
fn the_core_refuses_bad_input_and_never_writes_a_non_finite_state() {
    use bevy_drape::collide::{RigidPose, SolverCollider, SolverShape};
    // Settings with one field made bad at random, gravity and steps that are not finite: each
    // step either runs and leaves a finite state, or is refused with an error and changes
    // nothing.
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0];
    let mut seed = 23u32;
    let mut next = || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (seed >> 8) as usize
    };
    let mut sim = HangingCloth { n: 8 }.build();
    let (mut refused, mut stepped) = (0, 0);
    for _ in 0..400 {
        let mut settings = SolverSettings::default();
        let mut gravity = GRAVITY;
        let mut dt = DT;
        let value = bad[next() % bad.len()];
        match next() % 8 {
            0 => settings.stretch_compliance = value,
            1 => settings.bend_compliance = value,
            2 => settings.damping = value,
            3 => settings.friction = value,
            4 => settings.thickness = value,
            5 => gravity.y = value,
            6 => dt = value,
            _ => {}
        }
        let before = sim.state().clone();
        match sim.step(&settings, gravity, dt) {
            Ok(()) => {
                stepped += 1;
                assert!(sim.is_finite());
            }
            Err(err) => {
                refused += 1;
                assert!(matches!(err, ClothError::InvalidSetting { .. }), "{err}");
                assert_eq!(sim.state().positions, before.positions);
                assert_eq!(sim.state().velocities, before.velocities);
            }
        }
    }
    println!("{stepped} steps run, {refused} refused");
    assert!(stepped > 0 && refused > 0);
    assert_eq!(sim.step(&SolverSettings::default(), GRAVITY, 0.0), Ok(()));

    // A collider with a non-finite velocity or pose is left out with an error; the valid one
    // next to it is kept and the cloth steps on.
    let ground = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
    let mut spinning = SolverCollider::fixed(
        SolverShape::Sphere { radius: 0.2 },
        RigidPose {
            translation: Vec3A::new(0.5, 0.5, 0.5),
            ..RigidPose::IDENTITY
        },
    );
    spinning.angular_velocity = Vec3A::new(0.0, f32::NAN, 0.0);
    assert!(sim.set_colliders(&[ground.clone(), spinning]).is_err());
    assert_eq!(sim.colliders(), &[ground]);
    for _ in 0..60 {
        sim.step(&SolverSettings::default(), GRAVITY, DT).unwrap();
    }
    assert!(sim.is_finite());
}

/// The sag `a cosh(S / 2a) - a` of a catenary of length `length` hung between two points
/// `span` apart at the same height, with `2 a sinh(S / 2a) = length` solved by bisection.
fn catenary_sag(span: f32, length: f32) -> f32 {
    let (mut lo, mut hi) = (1e-3f64, 1e3f64);
    let (s, l) = (span as f64, length as f64);
    for _ in 0..200 {
        let a = 0.5 * (lo + hi);
        if 2.0 * a * (s / (2.0 * a)).sinh() > l {
            lo = a;
        } else {
            hi = a;
        }
    }
    let a = 0.5 * (lo + hi);
    (a * (s / (2.0 * a)).cosh() - a) as f32
}

#[test]
fn a_rope_built_as_a_v_hangs_into_its_catenary_with_long_range_attachments_on() {
    // 50 equal segments pinned at both ends 1 m apart, 1.2 m long, built with both arms
    // straight (a V, its tip 0.33 m below the pins): the tethers to the pins are as long as
    // the rope between (not the straight line across the V), so nothing holds the V.
    for (segments, tip_side) in [(50u32, 0.5f32), (40, 0.3)] {
        let (span, length) = (1.0f32, 1.2f32);
        // The V's tip at `tip_side` of the span, both arms straight.
        let tip_x = tip_side * span;
        let depth = {
            // Arms of lengths l1 + l2 = length from (0, 0) and (span, 0) to (tip_x, -depth).
            let (mut lo, mut hi) = (0.0f32, length);
            for _ in 0..100 {
                let d = 0.5 * (lo + hi);
                let total =
                    (tip_x * tip_x + d * d).sqrt() + ((span - tip_x).powi(2) + d * d).sqrt();
                if total > length { hi = d } else { lo = d }
            }
            0.5 * (lo + hi)
        };
        let tip = Vec3::new(tip_x, -depth, 0.0);
        let first_arm = tip.length();
        let n = segments as usize + 1;
        // Particles at equal arc length along the V.
        let positions: Vec<Vec3> = (0..n)
            .map(|k| {
                let s = length * k as f32 / segments as f32;
                if s <= first_arm {
                    tip * (s / first_arm)
                } else {
                    tip + (Vec3::new(span, 0.0, 0.0) - tip).normalize() * (s - first_arm)
                }
            })
            .collect();
        let edges: Vec<[u32; 2]> = (0..segments).map(|k| [k, k + 1]).collect();
        let model = ClothModel::from_particles(&positions, &vec![0.01; n], &edges).unwrap();
        let mut sim = ClothSolver::new(model);
        sim.set_pins(&[0, segments]).unwrap();
        let settings = SolverSettings {
            damping: 2.0,
            ..Default::default()
        };
        for _ in 0..600 {
            sim.step(&settings, GRAVITY, DT).unwrap();
        }
        let lowest = lowest_height(&sim);
        let expected = catenary_sag(span, length);
        println!(
            "{segments} segments, V tip at {tip_side}: sag {:.4} m, catenary {expected:.4} m, V {depth:.4} m",
            -lowest
        );
        // Within 0.5% of the span of the catenary (the beads make it a discrete one), and
        // the V's tip came up.
        assert!(
            (-lowest - expected).abs() < 0.005 * span,
            "{} vs {expected}",
            -lowest
        );
    }
}

/// A small deterministic generator (a 64-bit LCG) in [0, 1), for meshes nobody designed.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Quad patterns of random size and cell shape, each quad cut along a random diagonal, their
/// vertices shuffled (so no grid is recognised) and the whole turned at random: exactly the
/// diagonals are shear edges. A mesh of equilateral triangles has none.
#[test]
fn the_diagonals_of_any_quad_pattern_are_its_shear_edges() {
    let mut rng = Lcg(0x2545_f491_4f6c_dd1d);
    for case in 0..4 {
        let (nx, nz) = (
            3 + (rng.next() * 5.0) as usize,
            3 + (rng.next() * 5.0) as usize,
        );
        let (dx, dz) = (0.05 + 0.25 * rng.next(), 0.05 + 0.25 * rng.next());
        let turn = bevy::math::Quat::from_euler(
            bevy::math::EulerRot::XYZ,
            rng.next() * 6.0,
            rng.next() * 6.0,
            rng.next() * 6.0,
        );
        // A random permutation of the vertices.
        let mut order: Vec<usize> = (0..nx * nz).collect();
        for i in (1..order.len()).rev() {
            order.swap(i, (rng.next() * (i + 1) as f32) as usize % (i + 1));
        }
        let mut positions = vec![Vec3::ZERO; nx * nz];
        for j in 0..nz {
            for i in 0..nx {
                positions[order[j * nx + i]] = turn * Vec3::new(i as f32 * dx, 0.0, j as f32 * dz);
            }
        }
        let mut indices = Vec::new();
        for j in 0..nz - 1 {
            for i in 0..nx - 1 {
                let [a, b, c, d] = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                    .map(|(i, j)| order[j * nx + i] as u32);
                if rng.next() < 0.5 {
                    indices.extend([a, b, c, a, c, d]);
                } else {
                    indices.extend([a, b, d, b, c, d]);
                }
            }
        }
        let model = ClothModel::from_triangles(&positions, &indices, 0.2).unwrap();
        assert_eq!(model.grid, None, "case {case}");
        let diagonal = (dx * dx + dz * dz).sqrt();
        let shear: Vec<_> = model
            .edges
            .iter()
            .filter(|e| e.kind == EdgeKind::Shear)
            .collect();
        assert_eq!(shear.len(), (nx - 1) * (nz - 1), "case {case}");
        for edge in &model.edges {
            let expected = if edge.kind == EdgeKind::Shear {
                diagonal
            } else if (edge.rest_length - dx).abs() < (edge.rest_length - dz).abs() {
                dx
            } else {
                dz
            };
            assert!(
                (edge.rest_length - expected).abs() < 1e-4,
                "case {case}: a {:?} edge of {} m",
                edge.kind,
                edge.rest_length
            );
        }
    }

    // Equilateral triangles in strips.
    let (rows, cols) = (4, 6);
    let h = 3f32.sqrt() / 2.0;
    let positions: Vec<Vec3> = (0..rows)
        .flat_map(|j| {
            (0..cols)
                .map(move |i| Vec3::new(i as f32 + 0.5 * (j % 2) as f32, 0.0, j as f32 * h) * 0.1)
        })
        .collect();
    let mut indices = Vec::new();
    for j in 0..rows - 1 {
        for i in 0..cols - 1 {
            let v = |i: usize, j: usize| (j * cols + i) as u32;
            if j % 2 == 0 {
                indices.extend([v(i, j), v(i + 1, j), v(i, j + 1)]);
                indices.extend([v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
            } else {
                indices.extend([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
                indices.extend([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            }
        }
    }
    let model = ClothModel::from_triangles(&positions, &indices, 0.2).unwrap();
    assert!(model.edges.iter().all(|e| e.kind == EdgeKind::Structural));
}

/// One square quad hanging in a vertical plane from its two top corners, its lower edge pushed
/// sideways: with free shear it swings as a parallelogram, each lower corner a pendulum of the
/// quad's side (period `2 pi sqrt(L / g)`); with a shear compliance `alpha` the diagonal is a
/// spring of stiffness `1 / alpha` that shortens by `L theta / sqrt(2)`, so
/// `omega^2 = g / L + 1 / (2 alpha (m_2 + m_3))`; with rigid shear it does not move. Random
/// sizes, planes and compliances; bad compliances are refused.
#[test]
fn a_quad_shears_as_its_shear_compliance_says() {
    let mut rng = Lcg(0x9e37_79b9_7f4a_7c15);
    for case in 0..3 {
        let side = 0.3 + 0.7 * rng.next();
        let plane = bevy::math::Quat::from_rotation_y(rng.next() * 6.0);
        let amplitude = 0.05f32;
        let swung = Vec3::new(side * amplitude.sin(), -side * amplitude.cos(), 0.0);
        let positions = [
            Vec3::ZERO,
            Vec3::new(side, 0.0, 0.0),
            swung,
            Vec3::new(side, 0.0, 0.0) + swung,
        ];
        let rest = [
            Vec3::ZERO,
            Vec3::new(side, 0.0, 0.0),
            Vec3::new(0.0, -side, 0.0),
            Vec3::new(side, -side, 0.0),
        ];
        let indices = [0, 2, 1, 1, 2, 3];
        let model = ClothModel::from_triangles(&rest.map(|p| plane * p), &indices, 0.3).unwrap();
        let shear = model.edges.iter().filter(|e| e.kind == EdgeKind::Shear);
        assert_eq!(shear.count(), 1, "case {case}: the diagonal");
        let mut sim = ClothSolver::new(model);
        sim.set_pins(&[0, 1]).unwrap();
        let w = &sim.state().inverse_masses;
        let lower_mass = 1.0 / w[2] + 1.0 / w[3];
        // Free, then a diagonal as stiff as gravity, then one three times as stiff.
        let stiffness_ratio = [0.0, 1.0, 3.0][case];
        let compliance = if stiffness_ratio == 0.0 {
            f32::INFINITY
        } else {
            side / (2.0 * lower_mass * 9.81 * stiffness_ratio)
        };
        let settings = SolverSettings {
            shear_compliance: compliance,
            ..undamped(20, 2)
        };
        for (p, x) in sim.state_mut().positions.iter_mut().zip(positions) {
            *p = (plane * x).into();
        }
        let (mut times, mut xs) = (Vec::new(), Vec::new());
        let along = plane * Vec3::X;
        for frame in 1..=60 * 6 {
            sim.step(&settings, GRAVITY, DT).unwrap();
            let x = &sim.state().positions;
            times.push(frame as f32 * DT);
            xs.push(Vec3::from(x[2]).dot(along));
            let tilt = (x[2].y - x[3].y).abs();
            assert!(
                tilt < 1e-3 * side,
                "case {case}: the lower edge tilts {tilt}"
            );
        }
        let period = mean_period(&upward_crossings(&times, &xs));
        let omega2 = 9.81 / side
            + if compliance.is_finite() {
                1.0 / (2.0 * compliance * lower_mass)
            } else {
                0.0
            };
        let theory = 2.0 * PI / omega2.sqrt() * (1.0 + amplitude * amplitude / 16.0);
        println!("case {case}: period {period} s, theory {theory} s");
        assert!(
            (period - theory).abs() / theory < 0.01,
            "case {case}: period {period} s, theory {theory} s"
        );

        // Rigid shear: back to the square at once, and there it stays.
        let mut sim = ClothSolver::new(
            ClothModel::from_triangles(&rest.map(|p| plane * p), &indices, 0.3).unwrap(),
        );
        sim.set_pins(&[0, 1]).unwrap();
        for (p, x) in sim.state_mut().positions.iter_mut().zip(positions) {
            *p = (plane * x).into();
        }
        for _ in 0..60 {
            sim.step(&undamped(20, 2), GRAVITY, DT).unwrap();
        }
        let off = Vec3::from(sim.state().positions[2]).distance(plane * rest[2]);
        assert!(off < 1e-3 * side, "case {case}: rigid shear moved {off} m");
    }

    let mut sim =
        ClothSolver::new(ClothModel::grid(&GridDesc::square(1.0, 3, Vec3::ZERO), 0.1).unwrap());
    for bad in [f32::NAN, -1.0] {
        let settings = SolverSettings {
            shear_compliance: bad,
            ..Default::default()
        };
        assert!(matches!(
            sim.step(&settings, GRAVITY, DT),
            Err(ClothError::InvalidSetting {
                name: "shear_compliance",
                ..
            })
        ));
    }
    assert!(sim.is_finite());
}

/// The bending stiffness `B` (N m: energy per area `B kappa^2 / 2` at curvature `kappa`) of a
/// grid whose bending pairs each store `theta^2 / 2` per unit of stiffness (compliance 1): the
/// grid wrapped isometrically round cylinders of random radius, across its grid lines and
/// along either diagonal, the energy summed over the model's own bending pairs. `B` is
/// `1 / bend_compliance` in every direction, the figure the S2 scene's bending is chosen with
/// (`Drape::BEND_COMPLIANCE`).
#[test]
fn a_grid_bends_with_one_over_the_bend_compliance_in_every_direction() {
    let mut rng = Lcg(0x9e37_79b9_7f4a_7c15);
    for _ in 0..4 {
        let n = 32 + (rng.next() * 32.0) as u32;
        let radius = 0.3 + rng.next();
        let model = ClothModel::grid(&GridDesc::square(1.0, n, Vec3::ZERO), 0.1).unwrap();
        // Bent with its lines (`diagonal` 0) or a diagonal (+1 or -1) round the curve.
        let stiffness = |diagonal: f32| {
            // Unrolled length `u` along the curve, `w` along the cylinder's axis.
            let wrapped: Vec<Vec3> = model
                .rest_positions
                .iter()
                .map(|p| {
                    let (u, w) = if diagonal != 0.0 {
                        (
                            (p.x + diagonal * p.z) / 2f32.sqrt(),
                            (p.z - diagonal * p.x) / 2f32.sqrt(),
                        )
                    } else {
                        (p.x, p.z)
                    };
                    let angle = u / radius;
                    Vec3::new(radius * angle.sin(), radius * (1.0 - angle.cos()), w)
                })
                .collect();
            let energy: f64 = model
                .bending_pairs
                .iter()
                .map(|pair| {
                    let [a, b, c, d] = pair.particles.map(|i| wrapped[i as usize]);
                    let n1 = (b - a).cross(c - a);
                    let n2 = (d - a).cross(b - a);
                    let theta = n1.cross(n2).length().atan2(n1.dot(n2)) as f64;
                    0.5 * theta * theta
                })
                .sum();
            // Unit area, curvature 1 / radius.
            2.0 * energy * (radius as f64).powi(2)
        };
        for diagonal in [0.0, 1.0, -1.0] {
            let b = stiffness(diagonal);
            println!("n {n}, radius {radius:.2}, diagonal {diagonal}: B {b:.4}");
            // The pairs along the border are missing: within 2 / n of the interior's value.
            assert!((b - 1.0).abs() < 0.01 + 2.0 / n as f64, "{b}");
        }
    }
}
