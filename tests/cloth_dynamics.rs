//! The cloth core in motion against analytic results and conservation laws, without an App:
//! free fall, angular momentum, pendulums and springs, energy, a shearing quad, a repeatable
//! step.

use crate::common;

use std::f32::consts::PI;

use bevy::math::{Vec3, Vec3A};
use bevy_drape::cloth::{ClothModel, ClothSolver, DampingMode, EdgeKind, GridDesc, SolverSettings};
use bevy_drape::error::ClothError;
use common::{Rng, free_grid};
use drape_scenes::scenes::{GRAVITY, HangingCloth};

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

/// One square quad hanging in a vertical plane from its two top corners, its lower edge pushed
/// sideways: with free shear it swings as a parallelogram, each lower corner a pendulum of the
/// quad's side (period `2 pi sqrt(L / g)`); with a shear compliance `alpha` the diagonal is a
/// spring of stiffness `1 / alpha` that shortens by `L theta / sqrt(2)`, so
/// `omega^2 = g / L + 1 / (2 alpha (m_2 + m_3))`; with rigid shear it does not move. Random
/// sizes, planes and compliances; bad compliances are refused.
#[test]
fn a_quad_shears_as_its_shear_compliance_says() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for case in 0..3 {
        let side = 0.3 + 0.7 * rng.uniform();
        let plane = bevy::math::Quat::from_rotation_y(rng.uniform() * 6.0);
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
