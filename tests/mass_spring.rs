//! Mass-spring and hybrid cloth against analytic results: the oscillator, its damping, the
//! explicit stability bound, automatic substeps, hybrid against mass-spring on S1, the
//! hybrid's springs on a triangle mesh, and mass-spring's contact velocities.

use crate::common;

use std::f32::consts::{PI, TAU};

use bevy::math::{Vec3, Vec3A};
use bevy_drape::cloth::{
    ClothModel, ClothSolver, DivergenceBounds, GridDesc, SolverMethod, SolverSettings,
    SpringConstants, SpringSettings,
};
use drape_scenes::scenes::{DENSITY, FRAME_RATE, GRAVITY, HangingCloth, lowest_height};

const MASS: f32 = 0.5;
const K: f32 = 100.0;
const REST: f32 = 1.0;
const STRETCH: f32 = 0.05;

/// One particle of mass `MASS` hanging (without gravity) on a spring of stiffness `K` and
/// damping `c` from a fixed particle, released stretched by `STRETCH` along the spring.
fn oscillator() -> ClothSolver {
    let model = ClothModel::from_particles(
        &[Vec3::ZERO, Vec3::new(0.0, -REST, 0.0)],
        &[0.0, MASS],
        &[[0, 1]],
    )
    .unwrap();
    let mut sim = ClothSolver::new(model);
    sim.state_mut().positions[1] = Vec3A::new(0.0, -REST - STRETCH, 0.0);
    sim
}

fn spring_settings(method: SolverMethod, c: f32, substeps: u32) -> SolverSettings {
    let mut s = SolverSettings {
        method,
        substeps,
        iterations: 1,
        damping: 0.0,
        long_range_attachments: false,
        stretch_compliance: 1.0 / K,
        ..Default::default()
    };
    s.springs.structural = SpringConstants {
        stiffness: K,
        damping: c,
    };
    s
}

/// Displacement from rest along the spring.
fn displacement(sim: &ClothSolver) -> f32 {
    -sim.state().positions[1].y - REST
}

/// Runs `steps` steps of `dt` and returns `(t, displacement)` after each.
fn trace(
    sim: &mut ClothSolver,
    settings: &SolverSettings,
    dt: f32,
    steps: usize,
) -> Vec<(f32, f32)> {
    (1..=steps)
        .map(|i| {
            sim.step(settings, Vec3::ZERO, dt).unwrap();
            (i as f32 * dt, displacement(sim))
        })
        .collect()
}

#[test]
fn one_spring_oscillates_with_the_period_two_pi_sqrt_m_over_k() {
    let settings = spring_settings(SolverMethod::MassSpring, 0.0, 100);
    let mut sim = oscillator();
    let samples = trace(&mut sim, &settings, 1.0 / 60.0, 180);
    // Upward zero crossings, linearly interpolated.
    let crossings: Vec<f32> = samples
        .windows(2)
        .filter(|w| w[0].1 < 0.0 && w[1].1 >= 0.0)
        .map(|w| w[0].0 + (w[1].0 - w[0].0) * (-w[0].1) / (w[1].1 - w[0].1))
        .collect();
    assert!(crossings.len() >= 5, "{crossings:?}");
    let measured = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f32;
    let expected = TAU * (MASS / K).sqrt();
    let error = (measured - expected).abs() / expected;
    println!("period {measured:.5} s, analytic {expected:.5} s, error {error:.2e}");
    assert!(error < 0.01);
}

#[test]
fn a_damped_spring_decays_like_the_analytic_damped_oscillator() {
    let c = 0.5;
    let settings = spring_settings(SolverMethod::MassSpring, c, 100);
    let mut sim = oscillator();
    let dt = 1.0 / 600.0;
    let samples = trace(&mut sim, &settings, dt, 1800);
    // x'' = -(k/m) x - (c/m) x': extremes at omega_d t = j pi with |x| = A exp(-gamma t / 2).
    let gamma = c / MASS;
    let omega_d = (K / MASS - gamma * gamma / 4.0).sqrt();
    let mut checked = 0;
    for j in 1..=8 {
        let t = j as f32 * PI / omega_d;
        // The sampled extreme nearest the analytic one.
        let near = samples
            .iter()
            .filter(|(ts, _)| (ts - t).abs() < 0.1 * PI / omega_d)
            .map(|&(_, x)| x.abs())
            .fold(0.0, f32::max);
        let expected = STRETCH * (-gamma * t / 2.0).exp();
        let error = (near - expected).abs() / expected;
        println!("extreme {j} at {t:.3} s: {near:.5} m, analytic {expected:.5} m ({error:.2e})");
        assert!(error < 0.05);
        checked += 1;
    }
    assert_eq!(checked, 8);
    // And it did decay: a sanity check on the setup.
    assert!(samples.last().unwrap().1.abs() < 0.2 * STRETCH);
}

#[test]
fn symplectic_euler_is_stable_below_two_over_omega_and_diverges_above_it() {
    let omega = (K / MASS).sqrt();
    let critical = 2.0 / omega;
    let bounds = DivergenceBounds::default();
    let steps = |dt: f32| (10.0 / dt).ceil() as usize;

    // The Gershgorin estimate never lets a step above the true bound through.
    let mut sim = oscillator();
    let settings = spring_settings(SolverMethod::MassSpring, 0.0, 1);
    let w = sim.state().inverse_masses.clone();
    let estimate = sim.springs_mut().stable_step(&settings.springs, true, &w);
    println!("h_max: analytic {critical:.4} s, Gershgorin estimate {estimate:.4} s");
    assert!(estimate <= critical && estimate > 0.5 * critical);

    // 0.9 x 2/omega: bounded for 10 s.
    let dt = 0.9 * critical;
    let mut sim = oscillator();
    let mut largest = 0.0f32;
    for _ in 0..steps(dt) {
        sim.step(&settings, Vec3::ZERO, dt).unwrap();
        largest = largest.max(displacement(&sim).abs());
        assert_eq!(sim.divergence(&bounds), None);
    }
    println!("0.9 x 2/omega: largest displacement {largest:.4} m over 10 s");
    assert!(largest < 5.0 * STRETCH);

    // 1.1 x 2/omega: diverges, and the check catches it within a second.
    let dt = 1.1 * critical;
    let mut sim = oscillator();
    let caught = (1..=steps(dt)).find_map(|i| {
        sim.step(&settings, Vec3::ZERO, dt).unwrap();
        sim.divergence(&bounds).map(|d| (i, d))
    });
    println!("1.1 x 2/omega: {caught:?}");
    let (step, _) = caught.expect("divergence detected");
    assert!(step as f32 * dt < 1.0);

    // XPBD with the same stiffness (compliance 1/k) at ten times that step stays bounded.
    let dt = 11.0 * critical;
    let settings = spring_settings(SolverMethod::Xpbd, 0.0, 1);
    let mut sim = oscillator();
    for _ in 0..steps(dt) {
        sim.step(&settings, Vec3::ZERO, dt).unwrap();
        assert_eq!(sim.divergence(&bounds), None);
        assert!(displacement(&sim).abs() <= STRETCH * 1.0001);
    }
}

fn stiff_cloth_settings(auto_substeps: bool) -> SolverSettings {
    let mut settings = SolverSettings {
        method: SolverMethod::MassSpring,
        auto_substeps,
        ..Default::default()
    };
    settings.springs.structural.stiffness = 1e4;
    settings.springs.shear.stiffness = 1e4;
    settings
}

/// Runs S1 at `n` for `frames` frames; returns the frame it diverged at, if it did.
fn run_s1(n: u32, settings: &SolverSettings, frames: u32) -> (ClothSolver, Option<u32>) {
    let run = HangingCloth { n }.run(settings, frames);
    (run.sim, run.divergence.map(|(frame, _)| frame))
}

#[test]
fn automatic_substeps_keep_a_stiff_cloth_stable() {
    // Without them the 1 m cloth with k = 1e4 N/m diverges at the default 8 substeps.
    let (_, diverged) = run_s1(16, &stiff_cloth_settings(false), 120);
    assert!(diverged.is_some());
    let settings = stiff_cloth_settings(true);
    let mut sim = HangingCloth { n: 16 }.build();
    let mut diverged = None;
    let mut lowest = f32::MAX;
    for frame in 1..=120 {
        sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE).unwrap();
        if sim.divergence(&DivergenceBounds::default()).is_some() {
            diverged = Some(frame);
        }
        let x = &sim.state().positions;
        lowest = lowest.min(x.iter().map(|p| p.y).sum::<f32>() / x.len() as f32);
    }
    println!(
        "auto substeps: {} per frame, max strain {:.3}%",
        sim.last_substeps(),
        sim.strain().max * 100.0
    );
    assert_eq!(diverged, None);
    assert!(sim.is_finite());
    assert!(sim.last_substeps() > 8);
    assert!(sim.strain().max < 0.01);
    // The cloth swung down: its centre of mass fell from 1 m to about 0.5 m.
    assert!(lowest < 0.6, "centre of mass no lower than {lowest}");
}

#[test]
fn hybrid_holds_s1_at_least_five_times_tighter_than_mass_spring_at_the_same_budget() {
    // 200 substeps per frame: above mass-spring's stability bound with the default springs
    // at N = 32.
    let base = SolverSettings {
        substeps: 200,
        ..Default::default()
    };
    let mass_spring = SolverSettings {
        method: SolverMethod::MassSpring,
        ..base
    };
    let hybrid = SolverSettings {
        method: SolverMethod::Hybrid { long_range: false },
        ..base
    };
    let (ms, ms_diverged) = run_s1(32, &mass_spring, 60);
    let (hy, hy_diverged) = run_s1(32, &hybrid, 60);
    let (ms_strain, hy_strain) = (ms.strain().max, hy.strain().max);
    println!(
        "S1 N = 32, 200 substeps, 1 s: max strain mass-spring {:.3}%, hybrid {:.4}%",
        ms_strain * 100.0,
        hy_strain * 100.0
    );
    assert_eq!((ms_diverged, hy_diverged), (None, None));
    assert!(ms_strain > 0.0 && hy_strain * 5.0 <= ms_strain);
}

#[test]
fn switching_the_method_keeps_positions_and_velocities() {
    let scene = HangingCloth { n: 12 };
    let mut sim = scene.build();
    let dt = 1.0 / FRAME_RATE;
    let xpbd = SolverSettings::default();
    for _ in 0..30 {
        sim.step(&xpbd, GRAVITY, dt).unwrap();
    }
    let before = sim.state().clone();
    let speed = before
        .velocities
        .iter()
        .map(|v| v.length())
        .fold(0.0, f32::max);
    assert!(speed > 0.1, "the cloth is moving");
    for method in [
        SolverMethod::MassSpring,
        SolverMethod::Hybrid { long_range: false },
    ] {
        let mut switched = sim.clone();
        let settings = SolverSettings {
            method,
            auto_substeps: true,
            ..Default::default()
        };
        switched.step(&settings, GRAVITY, dt).unwrap();
        // Continuing from the same state: every particle ends near x + v dt.
        let worst = switched
            .state()
            .positions
            .iter()
            .zip(&before.positions)
            .zip(&before.velocities)
            .map(|((x1, x0), v0)| x1.distance(*x0 + *v0 * dt))
            .fold(0.0, f32::max);
        println!(
            "{}: worst departure from x + v dt {worst:.2e} m (largest v dt {:.2e} m)",
            method.name(),
            speed * dt
        );
        // Losing the velocities would leave a particle v dt behind.
        assert!(worst < 0.2 * speed * dt);
    }
    // The mass of a cloth is the same for every method; the model is shared.
    assert!((sim.model().total_mass() - DENSITY).abs() < 1e-6);
}

#[test]
fn mass_spring_and_hybrid_cloths_rest_on_the_ground_without_sinking() {
    for method in [
        SolverMethod::MassSpring,
        SolverMethod::Hybrid { long_range: false },
    ] {
        let grid = bevy_drape::cloth::GridDesc::square(0.5, 10, Vec3::new(0.0, 0.3, 0.0));
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, DENSITY).unwrap());
        sim.set_colliders(&[bevy_drape::collide::SolverCollider::ground(
            0.0,
            Default::default(),
        )])
        .unwrap();
        let settings = SolverSettings {
            method,
            auto_substeps: true,
            ..Default::default()
        };
        for _ in 0..120 {
            sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE).unwrap();
        }
        let lowest = lowest_height(&sim);
        let fastest = sim
            .state()
            .velocities
            .iter()
            .map(|v| v.length())
            .fold(0.0, f32::max);
        println!(
            "{}: lowest {lowest:.5} m, fastest {fastest:.2e} m/s",
            method.name()
        );
        // The thickness is 5 mm: nothing below it, and the cloth lies still.
        assert!(lowest >= settings.thickness - 1e-5 && lowest < 0.01);
        assert!(fastest < 1e-2);
    }
}

#[test]
fn the_hybrid_holds_its_structural_edges_only_unless_its_method_asks_for_long_range() {
    // S1 at N = 16, 1 s at 96 substeps (above the hybrid's stability bound).
    let frames = 60;
    let with_flag = |long_range_attachments: bool, long_range: bool| SolverSettings {
        method: SolverMethod::Hybrid { long_range },
        substeps: 96,
        long_range_attachments,
        ..Default::default()
    };
    // The settings' flag is XPBD's and PBD's: the hybrid runs the same either way.
    let (a, a_diverged) = run_s1(16, &with_flag(true, false), frames);
    let (b, _) = run_s1(16, &with_flag(false, false), frames);
    assert_eq!(a_diverged, None);
    assert_eq!(a.state().positions, b.state().positions);
    // With long-range attachments it is a different, stiffer cloth.
    let (c, c_diverged) = run_s1(16, &with_flag(false, true), frames);
    assert_eq!(c_diverged, None);
    assert_ne!(a.state().positions, c.state().positions);
    let (plain, extra) = (a.strain().max, c.strain().max);
    println!("hybrid at N = 16, 96 substeps: strain {plain:.4} alone, {extra:.4} with long range");
    assert!(extra < plain, "{extra} against {plain}");
}

/// An irregular triangulation of a 1 m square, flat at 1 m: an `n` x `n` lattice, every
/// vertex but the border's jittered by up to a quarter spacing, each quad cut along a random
/// diagonal. No grid, and no quad diagonals (no right angles).
fn irregular_sheet(rng: &mut common::Rng, n: u32) -> ClothModel {
    let spacing = 1.0 / (n - 1) as f32;
    let index = |i: u32, j: u32| j * n + i;
    let positions: Vec<Vec3> = (0..n * n)
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let border = i == 0 || j == 0 || i == n - 1 || j == n - 1;
            let jitter = if border { 0.0 } else { 0.25 * spacing };
            Vec3::new(
                i as f32 * spacing + rng.range(-jitter, jitter),
                1.0,
                j as f32 * spacing + rng.range(-jitter, jitter),
            )
        })
        .collect();
    let mut indices = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let [a, b, c, d] = [
                index(i, j),
                index(i + 1, j),
                index(i + 1, j + 1),
                index(i, j + 1),
            ];
            if rng.uniform() < 0.5 {
                indices.extend([a, c, b, a, d, c]);
            } else {
                indices.extend([a, d, b, b, d, c]);
            }
        }
    }
    ClothModel::from_triangles(&positions, &indices, DENSITY).unwrap()
}

/// The hybrid on a triangle mesh that is not a grid (`SpringSet::new`'s mesh springs): its
/// explicit shear and bend springs exist and act. A rolled sheet, released, unrolls with
/// either family alone and stays rolled with neither.
#[test]
fn the_hybrids_shear_and_bend_springs_unroll_a_triangle_mesh() {
    let model = irregular_sheet(&mut common::Rng(7), 9);
    assert_eq!(model.grid, None);
    assert!(model.warnings.is_empty(), "{:?}", model.warnings);
    let rolled = || {
        let mut sim = ClothSolver::new(model.clone());
        common::roll(&mut sim, 0.4);
        sim
    };
    // The mesh's springs (`mass_spring.rs`): a bend spring per bending pair, and shear
    // springs on the far diagonals across the shared edges, besides one per mesh edge.
    let mut sim = rolled();
    let springs = sim.springs_mut();
    assert_eq!(springs.angle_springs.len(), model.bending_pairs.len());
    assert_eq!(springs.structural_edges.len(), model.edges.len());
    let shear = springs.springs.len() - springs.structural_edges.len();
    assert!(
        shear * 2 > model.bending_pairs.len(),
        "{shear} shear springs"
    );

    // Released at rest without gravity: the hybrid holds its edges with constraints, so only
    // its shear and bend springs can unroll it. The smallest mean bending error over 1 s, as a
    // fraction of the rolled sheet's.
    let start = common::bending_error(&rolled());
    let unrolled = |shear: f32, bend: f32| {
        let mut settings = SolverSettings {
            method: SolverMethod::Hybrid { long_range: false },
            auto_substeps: true,
            ..Default::default()
        };
        settings.springs.shear.stiffness = shear;
        settings.springs.bend.stiffness = bend;
        let mut sim = rolled();
        let mut least = f32::MAX;
        for _ in 0..60 {
            sim.step(&settings, Vec3::ZERO, 1.0 / FRAME_RATE).unwrap();
            least = least.min(common::bending_error(&sim) / start);
        }
        assert!(sim.strain().max < 0.01, "{}", sim.strain().max);
        least
    };
    let defaults = SpringSettings::default();
    let neither = unrolled(0.0, 0.0);
    let shear_alone = unrolled(defaults.shear.stiffness, 0.0);
    let bend_alone = unrolled(0.0, defaults.bend.stiffness);
    println!(
        "least bending error over 1 s of the rolled sheet's {start:.3} rad: no springs \
         {neither:.3}, shear springs {shear_alone:.3}, bend springs {bend_alone:.3}"
    );
    assert!(
        neither > 0.9,
        "without springs the sheet unrolled to {neither}"
    );
    assert!(shear_alone < 0.5, "the shear springs left {shear_alone}");
    assert!(bend_alone < 0.5, "the bend springs left {bend_alone}");
}

/// A quad pattern cut into triangles (as a modelling tool exports an OBJ; not a grid): the
/// hybrid holds its threads with constraints and its quad diagonals with shear springs, so
/// a sheet sheared in its plane springs back, and without the shear springs it keeps its shear
/// (with the diagonals as constraints, as before, it could not shear at all).
#[test]
fn the_hybrid_shears_a_quad_pattern_mesh_with_springs_not_constraints() {
    // A 7 x 7 quad pattern with random cell sizes, each quad split along a random diagonal.
    let mut rng = common::Rng(11);
    let n = 7u32;
    let mut xs = vec![0.0f32];
    let mut zs = vec![0.0f32];
    for _ in 1..n {
        xs.push(xs.last().unwrap() + rng.range(0.05, 0.1));
        zs.push(zs.last().unwrap() + rng.range(0.05, 0.1));
    }
    let positions: Vec<Vec3> = (0..n * n)
        .map(|k| Vec3::new(xs[(k % n) as usize], 0.0, zs[(k / n) as usize]))
        .collect();
    let mut indices = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let (a, b, c, d) = (
                j * n + i,
                j * n + i + 1,
                (j + 1) * n + i + 1,
                (j + 1) * n + i,
            );
            if rng.uniform() < 0.5 {
                indices.extend([a, d, b, b, d, c]);
            } else {
                indices.extend([a, d, c, a, c, b]);
            }
        }
    }
    let model = ClothModel::from_triangles(&positions, &indices, DENSITY).unwrap();
    assert_eq!(model.grid, None);
    let diagonals = model
        .edges
        .iter()
        .filter(|e| e.kind == bevy_drape::cloth::EdgeKind::Shear)
        .count();
    assert_eq!(
        diagonals,
        ((n - 1) * (n - 1)) as usize,
        "every quad's diagonal is a shear edge"
    );
    let mut sim = ClothSolver::new(model.clone());
    let springs = sim.springs_mut();
    assert_eq!(
        springs.structural_edges.len(),
        model.edges.len() - diagonals
    );
    assert!(
        springs
            .structural_edges
            .iter()
            .all(|e| e.kind == bevy_drape::cloth::EdgeKind::Structural)
    );
    // Sheared in its plane (x += 0.3 z) and released without gravity: the shear springs pull
    // it back towards square, the threads' constraints alone do not.
    let sheared = || {
        let mut sim = ClothSolver::new(model.clone());
        for p in &mut sim.state_mut().positions {
            p.x += 0.3 * p.z;
        }
        let rest = sim.state().positions.clone();
        sim.state_mut().previous_positions = rest;
        sim
    };
    let shear_left = |shear: f32| {
        let mut settings = SolverSettings {
            method: SolverMethod::Hybrid { long_range: false },
            auto_substeps: true,
            ..Default::default()
        };
        settings.springs.shear.stiffness = shear;
        let mut sim = sheared();
        for _ in 0..240 {
            sim.step(&settings, Vec3::ZERO, 1.0 / FRAME_RATE).unwrap();
        }
        // The angle between the first row and the first column, against a right angle
        // (whatever the sheet turned as a whole).
        let x = &sim.state().positions;
        let row = x[(n - 1) as usize] - x[0];
        let column = x[(n * (n - 1)) as usize] - x[0];
        (row.angle_between(column) - std::f32::consts::FRAC_PI_2).abs()
    };
    let (without, with) = (
        shear_left(0.0),
        shear_left(SpringSettings::default().shear.stiffness),
    );
    // Sheared by atan(0.3) = 0.29 rad at the start.
    println!("shear left after 4 s: {without:.3} rad without shear springs, {with:.3} with");
    assert!(
        without > 0.2,
        "the threads alone unsheared it to {without} rad"
    );
    assert!(
        with < 0.25 * without,
        "the shear springs left {with} of {without} rad"
    );
}

/// Mass-spring's contact velocity update (`ContactScratch::respond`): its velocities are its
/// own, not derived from positions, so a sheet landing on the ground would keep falling into
/// it (pushed back out every substep) without it. Every particle on the ground at the end of a
/// step moves into it at under 1% of the landing speed.
#[test]
fn a_mass_spring_sheet_landing_on_the_ground_keeps_no_velocity_into_it() {
    let height = 0.2;
    let grid = GridDesc::square(0.5, 10, Vec3::new(-0.25, height, -0.25));
    let mut sim = ClothSolver::new(ClothModel::grid(&grid, DENSITY).unwrap());
    sim.set_colliders(&[bevy_drape::collide::SolverCollider::ground(
        0.0,
        Default::default(),
    )])
    .unwrap();
    let settings = SolverSettings {
        method: SolverMethod::MassSpring,
        auto_substeps: true,
        ..Default::default()
    };
    let landing = (2.0 * GRAVITY.length() * height).sqrt();
    let (mut touching, mut fastest_in) = (0, 0.0f32);
    for _ in 0..45 {
        sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE).unwrap();
        let state = sim.state();
        for (x, v) in state.positions.iter().zip(&state.velocities) {
            if x.y <= settings.thickness + 1e-4 {
                touching += 1;
                fastest_in = fastest_in.max(-v.y);
            }
        }
    }
    println!(
        "{touching} particle-steps on the ground, fastest into it {fastest_in:.2e} m/s \
         (landing at {landing:.2} m/s)"
    );
    assert!(touching > 100, "the sheet landed");
    assert!(
        fastest_in < 0.01 * landing,
        "a particle on the ground moves into it at {fastest_in} m/s"
    );
}
