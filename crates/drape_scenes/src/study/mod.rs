//! The speed-against-accuracy study of `docs/benchmarks.md` ("Speed against accuracy"): the
//! measurements behind the charts the `speed_accuracy` example draws, as plain functions on
//! the pure cores, so that tests can run them on tiny budgets.
//!
//! - [`error_against_cost`]: scene S1 ([`HangingCloth`]) at [`STUDY_N`] for each method at
//!   each budget, against a reference run ([`reference()`]): cost in milliseconds per simulated
//!   second, the RMS position error of the free corner and the centre over the first
//!   [`TRAJECTORY_FRAMES`] frames (the hanging cloth is chaotic: equivalent kernels drift
//!   apart later, so only the start of the run is a trajectory to compare), and the largest
//!   strain at the end of a 2 s run. A budget whose run diverges is reported as unstable, with
//!   no error.
//!
//! # How far the reference can be trusted
//!
//! An inextensible sheet has no converged trajectory to compare with at this resolution: with
//! compliance 0 the edges act as springs whose stiffness grows as `1 / h^2`, so every step
//! size keeps its own unresolved stretch vibrations (started when the falling sheet snaps
//! taut), and the folds that follow grow from them. Measured on S1 at N = 16 in `f64`, the
//! difference between the reference at `s` and `2 s` substeps over the first 0.5 s is
//! 2.4 mm at 32 vs 64, 3.6 mm at 64 vs 128, and 1.1 to 1.5 cm from 128 on, more iterations
//! and stronger rigid damping changing little. The charts draw that difference (1024 against
//! 512 substeps) as the reference floor: errors near it are not resolved.
//! - [`stability_map`]: the largest stable substep against spring stiffness, for mass-spring
//!   (found by bisection on the substep count) beside its analytic bound, and for XPBD with
//!   the compliance `1 / k`.
//! - [`equal_cost_splits`] and [`sag`]: XPBD's iterations against substeps at equal cost,
//!   and XPBD against plain PBD as the iteration count grows.
//! - [`fabrik_residuals`]: FABRIK's distance to the target after each iteration count.
//! - [`spline_errors`]: interpolation error against key spacing for both tangent formulas.
//! - [`main_scene_points`]: the main scene's (S3) per-step strain against cost for each budget
//!   and motion.
//! - [`crossings_against_cost`]: the generated sheet drops' crossings through themselves
//!   against the cost of a frame, for each self-collision method and substep count.

use std::time::Instant;

mod main_scene;
mod self_collision;
mod skeleton;

pub use main_scene::{MainSceneBudget, MainScenePoint, main_scene_budgets, main_scene_points};
pub use self_collision::{CROSSINGS_SUBSTEPS, CrossingsPoint, crossings_against_cost};

pub use skeleton::{
    FabrikCurve, SplineRow, fabrik_residuals, ik_chains, key_times, random_pose, smooth_motion,
    snake, spline_error, spline_errors,
};

use crate::scenes::{FRAME_RATE, GRAVITY, HangingCloth, Trajectory};
use bevy_drape::cloth::internals::{IsometricPair, SpringSet};
use bevy_drape::cloth::{
    AdaptiveSubsteps, DampingMode, DivergenceBounds, EdgeKind, SolverMethod, SolverSettings,
    SpringConstants, SpringSettings,
};

/// Vertices per side of the study's S1 sheet.
pub const STUDY_N: u32 = 32;
/// Frames (at 60 Hz) over which trajectories are compared: the first 0.5 s.
pub const TRAJECTORY_FRAMES: u32 = 30;
/// Frames of the early comparison: the first 1/6 s, before the folds grow.
pub const EARLY_FRAMES: u32 = 10;
/// Frames of a study run: 2 s, the strain is taken at the end.
pub const RUN_FRAMES: u32 = 120;
/// Substeps per frame of the reference run (XPBD, 2 iterations).
pub const REFERENCE_SUBSTEPS: u32 = 1024;

/// A method at a budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// The solver.
    pub method: SolverMethod,
    /// Substeps per 1/60 s frame.
    pub substeps: u32,
    /// Constraint iterations per substep (ignored by mass-spring).
    pub iterations: u32,
}

impl Budget {
    /// `method` at `substeps` x `iterations`.
    pub fn new(method: SolverMethod, substeps: u32, iterations: u32) -> Self {
        Self {
            method,
            substeps,
            iterations,
        }
    }

    /// The crate's default settings (rigid damping included, as in the reference) with this
    /// method and budget, automatic substeps off so that the budget is what runs.
    pub fn settings(&self) -> SolverSettings {
        SolverSettings {
            method: self.method,
            substeps: self.substeps,
            iterations: self.iterations,
            auto_substeps: false,
            ..SolverSettings::default()
        }
    }
}

/// The reference run of S1 at `n`: XPBD in `f64` with `substeps` per frame (the study uses
/// [`REFERENCE_SUBSTEPS`]) and 2 iterations, over [`TRAJECTORY_FRAMES`] frames: inextensible
/// edges, the crate's isometric bending (the same weights and compliance) and its default
/// rigid damping.
///
/// `f64`, because in `f32` a step this fine cannot hold its own corrections: a position near
/// 1 m has an ulp of 1.2e-7 m, so a constraint's correction (a fraction of `g h^2`, 4e-8 m at
/// 1024 substeps per frame) is rounded away and the velocity `(x - x_prev) / h` picks up
/// 1e-3 m/s of noise per substep.
pub fn reference(n: u32, substeps: u32) -> Trajectory {
    reference_with(n, substeps, 2, SolverSettings::default().damping)
}

/// Rigid damping (Mueller et al. 2006, section 3.5) in `f64`: every free particle's velocity
/// moves the fraction `k` towards the rigid motion that fits the free particles.
fn damp_rigid_f64(
    x: &[bevy::math::DVec3],
    v: &mut [bevy::math::DVec3],
    m: &[f64],
    w: &[f64],
    k: f64,
) {
    use bevy::math::{DMat3, DVec3};
    let (mut mass, mut mx, mut mv) = (0.0, DVec3::ZERO, DVec3::ZERO);
    for i in 0..x.len() {
        if w[i] > 0.0 {
            mass += m[i];
            mx += x[i] * m[i];
            mv += v[i] * m[i];
        }
    }
    if mass <= 0.0 {
        return;
    }
    let (c, vc) = (mx / mass, mv / mass);
    let (mut l, mut inertia) = (DVec3::ZERO, DMat3::ZERO);
    for i in 0..x.len() {
        if w[i] > 0.0 {
            let r = x[i] - c;
            l += r.cross(v[i] - vc) * m[i];
            inertia += (DMat3::from_diagonal(DVec3::splat(r.length_squared()))
                - DMat3::from_cols(r * r.x, r * r.y, r * r.z))
                * m[i];
        }
    }
    let omega = if inertia.determinant().abs() > 1e-18 {
        inertia.inverse() * l
    } else {
        DVec3::ZERO
    };
    for i in 0..x.len() {
        if w[i] > 0.0 {
            let rigid = vc + omega.cross(x[i] - c);
            v[i] += (rigid - v[i]) * k;
        }
    }
}

/// [`reference()`] with `iterations` Gauss-Seidel sweeps of the edges per substep and the rigid
/// damping rate `damping`, 1/s.
pub fn reference_with(n: u32, substeps: u32, iterations: u32, damping: f32) -> Trajectory {
    use bevy::math::DVec3;
    let scene = HangingCloth { n };
    let sim = scene.build();
    let model = sim.model();
    let settings = SolverSettings::default();
    let w: Vec<f64> = sim
        .state()
        .inverse_masses
        .iter()
        .map(|&w| w as f64)
        .collect();
    let mut x: Vec<DVec3> = model.rest_positions.iter().map(|p| p.as_dvec3()).collect();
    let edges: Vec<(usize, usize, f64)> = model
        .edges
        .iter()
        .map(|e| {
            let [a, b] = e.particles.map(|i| i as usize);
            (a, b, x[a].distance(x[b]))
        })
        .collect();
    let pairs: Vec<([usize; 4], [f64; 4], f64)> = model
        .bending_pairs
        .iter()
        .filter_map(|p| {
            let rest = p.particles.map(|i| model.rest_positions[i as usize]);
            IsometricPair::new(p.particles, rest).map(|iso| {
                (
                    iso.particles.map(|i| i as usize),
                    iso.weights.map(|k| k as f64),
                    (iso.compliance_scale as f64).powi(2),
                )
            })
        })
        .collect();
    let masses: Vec<f64> = (0..x.len()).map(|i| model.mass(i) as f64).collect();
    let mut v = vec![DVec3::ZERO; x.len()];
    let mut x_prev = x.clone();
    let mut edge_lambdas = vec![0.0f64; edges.len()];
    let a = GRAVITY.as_dvec3();
    let h = 1.0 / (FRAME_RATE as f64 * substeps as f64);
    let bend_alpha = settings.bend_compliance as f64 / (h * h);
    let damping_k = 1.0 - (-(damping as f64) * h).exp();
    let mut run = Trajectory::default();
    for _ in 0..TRAJECTORY_FRAMES {
        let start = Instant::now();
        for _ in 0..substeps {
            for i in 0..x.len() {
                x_prev[i] = x[i];
                if w[i] > 0.0 {
                    x[i] += v[i] * h + a * (0.5 * h * h);
                }
            }
            edge_lambdas.fill(0.0);
            for iteration in 0..iterations.max(1) {
                for &(i, j, rest) in &edges {
                    let d = x[j] - x[i];
                    let len = d.length();
                    let wsum = w[i] + w[j];
                    if len <= 0.0 || wsum <= 0.0 {
                        continue;
                    }
                    let dl = -(len - rest) / wsum;
                    let n = d / len;
                    x[i] -= n * (w[i] * dl);
                    x[j] += n * (w[j] * dl);
                }
                if iteration == 0 {
                    for (p, k, scale) in &pairs {
                        let weight: f64 = (0..4).map(|m| w[p[m]] * k[m] * k[m]).sum();
                        if weight <= 0.0 {
                            continue;
                        }
                        let c: DVec3 = (0..4).map(|m| x[p[m]] * k[m]).sum();
                        // One projection per substep: the multiplier starts at zero.
                        let alpha = bend_alpha * scale;
                        let dl = -c / (weight + alpha);
                        for m in 0..4 {
                            x[p[m]] += dl * (w[p[m]] * k[m]);
                        }
                    }
                }
            }
            // The crate's velocity: the half-step velocity plus the other half of the
            // acceleration's share (velocity Verlet), for free particles.
            for i in 0..x.len() {
                v[i] = if w[i] > 0.0 {
                    (x[i] - x_prev[i]) / h + a * (0.5 * h)
                } else {
                    DVec3::ZERO
                };
            }
            if damping_k > 0.0 {
                damp_rigid_f64(&x, &mut v, &masses, &w, damping_k);
            }
        }
        run.frame_seconds.push(start.elapsed().as_secs_f64());
        run.substeps.push(substeps);
        run.corner.push(x[scene.corner() as usize].as_vec3());
        run.center.push(x[scene.center() as usize].as_vec3());
    }
    let strain = model
        .edges
        .iter()
        .zip(&edges)
        .filter(|(e, _)| e.kind == EdgeKind::Structural)
        .map(|(_, &(i, j, rest))| ((x[i].distance(x[j]) - rest) / rest).abs() as f32)
        .fold(0.0, f32::max);
    run.strain.push(strain);
    run
}

/// RMS distance between `run` and `reference` over the corner and centre positions of the
/// frames both have, metres; infinite if `run` diverged.
pub fn trajectory_error(reference: &Trajectory, run: &Trajectory) -> f32 {
    trajectory_error_over(reference, run, usize::MAX)
}

/// [`trajectory_error`] over the first `frames` frames only.
pub fn trajectory_error_over(reference: &Trajectory, run: &Trajectory, frames: usize) -> f32 {
    if run.diverged {
        return f32::INFINITY;
    }
    let k = frames.min(reference.corner.len()).min(run.corner.len());
    let pairs = reference.corner[..k]
        .iter()
        .zip(&run.corner[..k])
        .chain(reference.center[..k].iter().zip(&run.center[..k]));
    let (sum, count) = pairs.fold((0.0f64, 0usize), |(s, c), (a, b)| {
        (s + a.distance_squared(*b) as f64, c + 1)
    });
    if count == 0 {
        return f32::INFINITY;
    }
    (sum / count as f64).sqrt() as f32
}

/// One point of the error-against-cost chart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StudyPoint {
    /// The method and budget.
    pub budget: Budget,
    /// Whether the 2 s run stayed bounded.
    pub stable: bool,
    /// Milliseconds per simulated second (median frame).
    pub ms_per_second: f64,
    /// RMS error of the corner and centre over the first 0.5 s, metres.
    pub error: f32,
    /// RMS error of the corner and centre over the first 1/6 s ([`EARLY_FRAMES`]), metres.
    pub early_error: f32,
    /// Largest strain at the end of the run.
    pub end_strain: f32,
    /// Mean substeps per frame (the budget's, or what an adaptive budget chose).
    pub mean_substeps: f32,
}

/// Measures `settings` (labelled `budget`) on S1 with `n` vertices per side against
/// `reference`, over `frames` frames.
pub fn measure(
    n: u32,
    budget: Budget,
    settings: &SolverSettings,
    reference: &Trajectory,
    frames: u32,
) -> StudyPoint {
    let run = HangingCloth { n }.run(settings, frames).trajectory;
    StudyPoint {
        budget,
        stable: !run.diverged,
        ms_per_second: run.ms_per_second(),
        error: trajectory_error(reference, &run),
        early_error: trajectory_error_over(reference, &run, EARLY_FRAMES as usize),
        end_strain: if run.diverged {
            f32::INFINITY
        } else {
            run.end_strain()
        },
        mean_substeps: run.mean_substeps(),
    }
}

/// The budgets of the error-against-cost chart: XPBD and hybrid at 2 iterations and 1 to 64
/// substeps, mass-spring at 16 to 2048 substeps (below its stability bound it diverges).
pub fn study_budgets() -> Vec<Budget> {
    let mut budgets = Vec::new();
    for method in [
        SolverMethod::Xpbd,
        SolverMethod::Hybrid { long_range: false },
    ] {
        for s in [1, 2, 4, 8, 16, 32, 64] {
            budgets.push(Budget::new(method, s, 2));
        }
    }
    for s in [16, 32, 64, 128, 256, 512, 1024, 2048] {
        budgets.push(Budget::new(SolverMethod::MassSpring, s, 1));
    }
    budgets
}

/// Every budget of `budgets` measured on S1 at `n` against `reference`.
pub fn error_against_cost(
    n: u32,
    budgets: &[Budget],
    reference: &Trajectory,
    frames: u32,
) -> Vec<StudyPoint> {
    budgets
        .iter()
        .map(|&b| measure(n, b, &b.settings(), reference, frames))
        .collect()
}

/// XPBD with [`AdaptiveSubsteps`] for `target_strain` on S1 at `n` (starting from the
/// default 8 substeps), against `reference`; its budget reports the mean substeps run per
/// frame, undone attempts included.
pub fn adaptive_point(
    n: u32,
    target_strain: f32,
    reference: &Trajectory,
    frames: u32,
) -> StudyPoint {
    let budget = Budget::new(SolverMethod::Xpbd, 8, 2);
    let settings = SolverSettings {
        adaptive: Some(AdaptiveSubsteps::target(target_strain)),
        ..budget.settings()
    };
    let mut point = measure(n, budget, &settings, reference, frames);
    point.budget.substeps = point.mean_substeps.round() as u32;
    point
}

/// The chart curve of `method` in `points`: `(cost, error)` of its stable budgets only (a
/// budget that diverged has no error to plot; the CSV keeps it, marked unstable); `early`
/// picks [`StudyPoint::early_error`].
pub fn curve(points: &[StudyPoint], method: SolverMethod, early: bool) -> Vec<(f64, f64)> {
    points
        .iter()
        .filter(|p| p.budget.method == method && p.stable && p.error.is_finite())
        .map(|p| {
            let e = if early { p.early_error } else { p.error };
            (p.ms_per_second, e as f64)
        })
        .collect()
}

/// Springs of stiffness `k` (structural), `0.3 k` (shear) and `0.02 k` (bend), with the
/// default damping per unit stiffness.
pub fn springs_of_stiffness(k: f32) -> SpringSettings {
    let d = SpringSettings::default();
    let scale = |c: SpringConstants, f: f32| SpringConstants {
        stiffness: k * f,
        damping: c.damping / c.stiffness * k * f,
    };
    SpringSettings {
        structural: scale(d.structural, 1.0),
        shear: scale(d.shear, 0.3),
        bend: scale(d.bend, 0.02),
    }
}

/// What counts as a blow-up in the stability map: a non-finite state, a particle faster than
/// 500 m/s, or an edge stretched to eleven times its length. (Softer bounds would count a
/// soft cloth that merely stretches a lot as unstable; an explicit integrator above its
/// bound grows exponentially and passes any of them within a few frames.)
pub const BLOW_UP: DivergenceBounds = DivergenceBounds {
    max_strain: 10.0,
    max_speed: 500.0,
};

/// Whether `settings` keeps S1 at `n` within [`BLOW_UP`] for `frames` frames.
pub fn is_stable(n: u32, settings: &SolverSettings, frames: u32) -> bool {
    let scene = HangingCloth { n };
    let mut sim = scene.build();
    let dt = 1.0 / FRAME_RATE;
    for _ in 0..frames {
        sim.step(settings, GRAVITY, dt)
            .expect("the scene runs with valid settings");
        if !sim.is_finite() || sim.divergence(&BLOW_UP).is_some() {
            return false;
        }
    }
    true
}

/// The fewest substeps per frame in `1..=max_substeps` at which `settings` (its substep
/// count replaced) keeps S1 at `n` bounded for `frames` frames, by bisection (stability is
/// taken to hold from some count on); `None` if even `max_substeps` diverges.
pub fn fewest_stable_substeps(
    n: u32,
    settings: &SolverSettings,
    max_substeps: u32,
    frames: u32,
) -> Option<u32> {
    let with = |s: u32| SolverSettings {
        substeps: s,
        ..*settings
    };
    if is_stable(n, &with(1), frames) {
        return Some(1);
    }
    if max_substeps <= 1 || !is_stable(n, &with(max_substeps), frames) {
        return None;
    }
    // 1 is unstable, `max_substeps` stable.
    let (mut lo, mut hi) = (1u32, max_substeps);
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if is_stable(n, &with(mid), frames) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

/// One row of the stability map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StabilityRow {
    /// Structural spring stiffness, N/m (XPBD: compliance `1 / k`).
    pub stiffness: f32,
    /// The largest stable mass-spring substep found, seconds (`None`: none up to the
    /// search's limit).
    pub mass_spring: Option<f32>,
    /// The analytic bound with damping, `(sqrt(gamma^2 + 4 omega^2) - gamma) / omega^2`
    /// (Gershgorin bounds on omega and gamma), seconds.
    pub bound: f32,
    /// The undamped bound `2 / omega_max`, seconds.
    pub bound_undamped: f32,
    /// The largest stable XPBD substep found (capped at one substep per frame), seconds.
    pub xpbd: Option<f32>,
}

/// The stability map on S1 at `n` for each stiffness in `stiffnesses`: mass-spring searched up
/// to `max_substeps` per frame, XPBD (compliance `1 / k`, no long-range attachments) from one
/// substep per frame; each run lasts `frames` frames.
pub fn stability_map(
    n: u32,
    stiffnesses: &[f32],
    max_substeps: u32,
    frames: u32,
) -> Vec<StabilityRow> {
    let dt = 1.0 / FRAME_RATE;
    let sim = HangingCloth { n }.build();
    let set = SpringSet::new(sim.model());
    let w = &sim.state().inverse_masses;
    stiffnesses
        .iter()
        .map(|&k| {
            let springs = springs_of_stiffness(k);
            let (omega, _) = set.frequency_bounds(&springs, true, w);
            let explicit = SolverSettings {
                method: SolverMethod::MassSpring,
                springs,
                auto_substeps: false,
                ..SolverSettings::default()
            };
            let xpbd = SolverSettings {
                stretch_compliance: 1.0 / k,
                long_range_attachments: false,
                ..SolverSettings::default()
            };
            StabilityRow {
                stiffness: k,
                mass_spring: fewest_stable_substeps(n, &explicit, max_substeps, frames)
                    .map(|s| dt / s as f32),
                bound: set.stable_step(&springs, true, w),
                bound_undamped: 2.0 / omega,
                xpbd: fewest_stable_substeps(n, &xpbd, max_substeps, frames).map(|s| dt / s as f32),
            }
        })
        .collect()
}

/// The `(substeps, iterations)` splits of `total` projections per frame, iterations 1, 2,
/// 4, ... up to `total`.
pub fn equal_cost_splits(total: u32) -> Vec<(u32, u32)> {
    (0..)
        .map(|p| 1u32 << p)
        .take_while(|&i| i <= total)
        .filter(|&i| total.is_multiple_of(i))
        .map(|i| (total / i, i))
        .collect()
}

/// Plain XPBD (compliance 0, no long-range attachments: the setting of Macklin et al. 2019)
/// at `substeps` x `iterations`.
pub fn plain_xpbd(substeps: u32, iterations: u32) -> SolverSettings {
    SolverSettings {
        long_range_attachments: false,
        ..Budget::new(SolverMethod::Xpbd, substeps, iterations).settings()
    }
}

/// Sag of S1 at N = 16 at rest under `method` with `iterations` per substep (8 substeps,
/// stretch compliance `stretch_compliance`, strong plain damping, 4 s): how far below the
/// pins its centre of mass settles, metres. A compliant XPBD cloth sags the same whatever the
/// iteration count; plain PBD's effective stiffness grows with it.
pub fn sag(method: SolverMethod, iterations: u32, stretch_compliance: f32) -> f32 {
    let mut sim = HangingCloth { n: 16 }.build();
    let settings = SolverSettings {
        method,
        substeps: 8,
        iterations,
        stretch_compliance,
        // Plain damping: rigid damping would leave the swing about the pins undamped.
        damping: 6.0,
        damping_mode: DampingMode::Plain,
        long_range_attachments: false,
        ..SolverSettings::default()
    };
    for _ in 0..240 {
        sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE)
            .expect("valid step input");
    }
    sim.rigid_motion()
        .map_or(f32::NAN, |m| 1.0 - m.center_of_mass.y)
}

/// The fewest substeps per frame with which `settings` (its substep count replaced) keeps
/// the strain of S1 at `n` at or below `target` in at least `fraction` of its `frames` frames
/// and at the end (searched over `1..=max_substeps`); `None` if none does.
pub fn fewest_fixed_substeps_for_strain(
    n: u32,
    settings: &SolverSettings,
    target: f32,
    fraction: f32,
    frames: u32,
    max_substeps: u32,
) -> Option<u32> {
    (1..=max_substeps).find(|&s| {
        let settings = SolverSettings {
            substeps: s,
            adaptive: None,
            exact_edges: None,
            ..*settings
        };
        meets_strain(
            &HangingCloth { n }.run(&settings, frames).trajectory,
            target,
            fraction,
        )
    })
}

/// Whether `run` kept its strain at or below `target` in at least `fraction` of its frames
/// and at the end.
pub fn meets_strain(run: &Trajectory, target: f32, fraction: f32) -> bool {
    if run.diverged || run.strain.is_empty() {
        return false;
    }
    let within = run.strain.iter().filter(|&&s| s <= target).count();
    within as f32 >= fraction * run.strain.len() as f32 && run.end_strain() <= target
}
