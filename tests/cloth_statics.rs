//! The cloth core at rest against analytic shapes and bounds, without an App: sag and strain
//! of a hanging cloth, tethers, the ground, a cantilever, a catenary, the bending stiffness of
//! a grid.

use crate::common;

use bevy::math::{Vec3, Vec3A};
use bevy_drape::cloth::{
    ClothModel, ClothSolver, DampingMode, GridDesc, SolverMethod, SolverSettings,
};
use bevy_drape::collide::{RigidPose, SolverCollider, SolverShape};
use common::{Rng, free_grid};
use drape_scenes::scenes::{GRAVITY, HangingCloth, lowest_height};
use drape_scenes::study::sag;

const DT: f32 = 1.0 / 60.0;

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

/// The bending stiffness `B` (N m: energy per area `B kappa^2 / 2` at curvature `kappa`) of a
/// grid whose bending pairs each store `theta^2 / 2` per unit of stiffness (compliance 1): the
/// grid wrapped isometrically round cylinders of random radius, across its grid lines and
/// along either diagonal, the energy summed over the model's own bending pairs. `B` is
/// `1 / bend_compliance` in every direction, the figure the S2 scene's bending is chosen with
/// (`Drape::BEND_COMPLIANCE`).
#[test]
fn a_grid_bends_with_one_over_the_bend_compliance_in_every_direction() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for _ in 0..4 {
        let n = 32 + (rng.uniform() * 32.0) as u32;
        let radius = 0.3 + rng.uniform();
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

/// The mean bending error left by one step of one substep at `iterations` (0: none) of a
/// cloth at rest in `positions`, pinned at `pins`, without gravity, with stiff bending
/// (compliance 0), isometric or dihedral.
fn bending_left(
    model: &ClothModel,
    positions: &[Vec3A],
    pins: &[u32],
    iterations: u32,
    isometric_bending: bool,
) -> f32 {
    let mut sim = ClothSolver::new(model.clone());
    sim.set_pins(pins).unwrap();
    let state = sim.state_mut();
    state.positions.copy_from_slice(positions);
    state.previous_positions.clone_from(&state.positions);
    let settings = SolverSettings {
        substeps: 1,
        iterations,
        bend_compliance: 0.0,
        isometric_bending,
        damping: 0.0,
        // (They would ask for 2 iterations at least.)
        long_range_attachments: false,
        ..Default::default()
    };
    if iterations > 0 {
        sim.step(&settings, Vec3::ZERO, DT).unwrap();
    }
    common::bending_error(&sim)
}

/// XPBD projects bending in every iteration of a substep, its multipliers accumulated over
/// them (`sim/step.rs`), not in the first iteration alone: stiff bending (compliance 0), one
/// step of one substep from rest, no gravity.
///
/// Two triangles on a held hinge, one folded 1.2 rad, dihedral bending: a projection moves
/// the wing tips along the angle's gradient, a straight line where the tips turn on circles,
/// so one iteration leaves a tenth of the fold (the angle turns by `2 atan(1.2 / 2)` = 1.08
/// rad where the gradient step meant 1.2 rad), and each further one squares what is left:
/// at 4 iterations the fold is gone, where bending in the first alone would leave the tenth.
///
/// A strip of three quads held at one end, folded 1 rad along the line between the first two,
/// isometric and dihedral bending: its pairs share particles, and the edges the bending
/// stretches pull the strip back into a fold; 1 iteration leaves more than the fold's mean
/// error, 16 a fifth of that at most (about a tenth).
#[test]
fn bending_is_projected_in_every_iteration_not_in_the_first_alone() {
    let fold = 1.2f32;
    let flat = [
        Vec3::ZERO,
        Vec3::Z,
        Vec3::new(-0.8, 0.0, 0.5),
        Vec3::new(0.8, 0.0, 0.5),
    ];
    let hinge = ClothModel::from_triangles(&flat, &[0, 1, 2, 1, 0, 3], 0.1).unwrap();
    assert_eq!(hinge.bending_pairs.len(), 1);
    let mut folded: Vec<Vec3A> = flat.iter().map(|&p| p.into()).collect();
    folded[3] = Vec3A::new(0.8 * fold.cos(), 0.8 * fold.sin(), 0.5);
    assert!((bending_left(&hinge, &folded, &[0, 1], 0, false) - fold).abs() < 1e-5);
    let expected = fold - 2.0 * (fold / 2.0).atan();
    let [one, four] = [1, 4].map(|it| bending_left(&hinge, &folded, &[0, 1], it, false));
    println!(
        "hinge: {fold} rad folded, left at 1 iteration {one:.2e} rad (expected \
         {expected:.2e}), at 4 {four:.2e} rad"
    );
    assert!((one - expected).abs() < 0.01, "1 iteration left {one} rad");
    assert!(
        four < 1e-3 * one,
        "4 iterations left {four} rad, 1 iteration {one} rad"
    );

    let grid = GridDesc {
        size: bevy::math::Vec2::new(1.5, 0.5),
        vertices: bevy::math::UVec2::new(4, 2),
        orientation: bevy::math::Quat::IDENTITY,
        origin: Vec3::ZERO,
    };
    let strip = ClothModel::grid(&grid, 0.1).unwrap();
    let fold = 1.0f32;
    let folded: Vec<Vec3A> = strip
        .rest_positions
        .iter()
        .map(|p| match p.x - 0.5 {
            out if out > 0.0 => Vec3A::new(0.5 + out * fold.cos(), out * fold.sin(), p.z),
            _ => Vec3A::from(*p),
        })
        .collect();
    let held = [grid.index(0, 0), grid.index(0, 1)];
    for isometric in [true, false] {
        let start = bending_left(&strip, &folded, &held, 0, isometric);
        let [one, sixteen] = [1, 16].map(|it| bending_left(&strip, &folded, &held, it, isometric));
        println!(
            "strip, isometric {isometric}: mean bending error {start:.3} rad folded, left at 1 \
             iteration {one:.2e} rad, at 16 {sixteen:.2e} rad"
        );
        assert!(one > 0.5 * start, "1 iteration left {one} rad");
        assert!(
            sixteen < 0.2 * one,
            "16 iterations left {sixteen} rad, 1 iteration {one} rad"
        );
    }
}

/// The largest distance any particle of a 1 m sheet draped on a ball moves in one step, over
/// the second second after 20 s (the folds still settle, by a fraction of a millimetre a step),
/// with the sheet and the ball built around `offset`.
fn draped_motion(offset: Vec3) -> f32 {
    let n = 16;
    let grid = GridDesc::square(1.0, n, offset + Vec3::new(-0.5, 0.8, -0.5));
    let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
    let ball = SolverCollider::fixed(
        SolverShape::Sphere { radius: 0.3 },
        RigidPose {
            translation: Vec3A::from(offset + Vec3::new(0.0, 0.3, 0.0)),
            rotation: bevy::math::Quat::IDENTITY,
        },
    );
    sim.set_colliders(&[ball]).unwrap();
    let settings = SolverSettings::default();
    for _ in 0..1200 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let mut largest = 0.0f32;
    for _ in 0..60 {
        let before = sim.state().positions.clone();
        sim.step(&settings, GRAVITY, DT).unwrap();
        for (a, b) in before.iter().zip(&sim.state().positions) {
            largest = largest.max(a.distance(*b));
        }
    }
    assert!(sim.is_finite());
    largest
}

#[test]
fn a_cloth_far_from_the_origin_settles_as_it_does_at_the_origin() {
    // In f32 a coordinate 500 m out moves in steps of 31 um, and a substep's velocity is a
    // difference of positions over 2 ms: stepped where it is, such a cloth would jitter by
    // millimetres a step (ten times as much as at the origin 200 m out).
    let at_origin = draped_motion(Vec3::ZERO);
    let mut rng = Rng(5);
    for _ in 0..3 {
        let direction = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-0.2, 0.2),
            rng.range(-1.0, 1.0),
        );
        let offset = direction.normalize() * rng.range(100.0, 1000.0);
        let far = draped_motion(offset);
        println!("at the origin {at_origin:.2e} m a step, {offset} out {far:.2e}");
        // Storing the positions rounds them once a step: half a step of f32 there.
        let rounding = 0.5 * offset.abs().max_element() * f32::EPSILON;
        assert!(
            far <= 3.0 * at_origin + 2.0 * rounding,
            "{far} m a step {offset} out, {at_origin} at the origin"
        );
    }
}
