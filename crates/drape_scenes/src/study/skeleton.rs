//! The skeleton half of the study: FABRIK's residual against its iteration count on the IK
//! test chains, and the splines' interpolation error against key spacing for both tangent
//! formulas.

use bevy::math::Vec3;

use bevy_drape::skeleton::humanoid::humanoid;
use bevy_drape::skeleton::ik::{IkChain, IkScratch, IkSettings, effector_position, solve};
use bevy_drape::skeleton::rig::{BoneDesc, Pose, Rig};
use bevy_drape::skeleton::spline::KeySpline;

/// A snake of seven hinges alternating between the x and z axes, 0.15 m apart, each
/// limited to +-1.2 rad.
pub fn snake() -> Rig {
    let mut bones = vec![BoneDesc {
        name: "root".into(),
        parent: None,
        offset: [0.0; 3],
        axis: [1.0, 0.0, 0.0],
        limits: None,
    }];
    for i in 0..7 {
        bones.push(BoneDesc {
            name: format!("j{i}"),
            parent: Some(if i == 0 {
                "root".into()
            } else {
                format!("j{}", i - 1)
            }),
            offset: if i == 0 { [0.0; 3] } else { [0.0, 0.15, 0.0] },
            axis: if i % 2 == 0 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 0.0, 1.0]
            },
            limits: Some((-1.2, 1.2)),
        });
    }
    Rig::new(&bones).expect("the snake's bones are valid by construction")
}

/// The rest pose of `rig` with `chain`'s angles random within their limits (the generator
/// [`Rng`](crate::scan::Rng) on `seed`, which is left where the generator ends).
pub fn random_pose(rig: &Rig, chain: &IkChain, seed: &mut u64) -> Pose {
    let mut rng = crate::scan::Rng(*seed);
    let mut pose = rig.rest_pose();
    for &b in &chain.bones {
        if let Some((lo, hi)) = rig.bones()[b].limits {
            pose.angles[b] = rng.range(lo, hi);
        }
    }
    *seed = rng.0;
    pose
}

/// The IK test chains: a name, the rig, the chain's last bone, its length in bones and the
/// effector offset: the humanoid's right arm (3 hinges), arm and hand (4), and the
/// [`snake`] (7).
pub fn ik_chains() -> Vec<(&'static str, Rig, &'static str, usize, Vec3)> {
    let body = humanoid();
    vec![
        (
            "3_joints_arm",
            body.clone(),
            "forearm_r",
            3,
            Vec3::new(0.0, -0.25, 0.0),
        ),
        (
            "4_joints_arm_hand",
            body,
            "hand_r",
            4,
            Vec3::new(0.0, -0.08, 0.0),
        ),
        (
            "7_joints_snake",
            snake(),
            "j6",
            7,
            Vec3::new(0.0, 0.15, 0.0),
        ),
    ]
}

/// FABRIK's residual against iterations for one chain.
#[derive(Clone, Debug, PartialEq)]
pub struct FabrikCurve {
    /// The chain's name.
    pub chain: &'static str,
    /// For 1, 2, ... iterations: the median distance to the target, metres.
    pub median: Vec<f32>,
    /// For 1, 2, ... iterations: the 90th percentile distance, metres.
    pub p90: Vec<f32>,
}

/// For each of [`ik_chains`]: `targets` reachable targets (forward kinematics of random
/// poses within the limits), solved from the rest pose with at most 1 to `max_iterations`
/// iterations and no tolerance; the median and 90th percentile residual at each count.
pub fn fabrik_residuals(targets: usize, max_iterations: u32) -> Vec<FabrikCurve> {
    let mut scratch = IkScratch::default();
    ik_chains()
        .into_iter()
        .filter_map(|(name, rig, end, length, effector)| {
            let chain = IkChain::new(&rig, end, length, effector).ok()?;
            let mut seed = 1u64;
            let goals: Vec<Vec3> = (0..targets)
                .map(|_| effector_position(&rig, &chain, &random_pose(&rig, &chain, &mut seed)))
                .collect();
            let mut curve = FabrikCurve {
                chain: name,
                median: Vec::new(),
                p90: Vec::new(),
            };
            for k in 1..=max_iterations {
                let settings = IkSettings {
                    tolerance: 0.0,
                    max_iterations: k,
                    ..IkSettings::default()
                };
                let mut errors: Vec<f32> = goals
                    .iter()
                    .map(|&goal| {
                        let mut pose = rig.rest_pose();
                        solve(&rig, &chain, &mut pose, goal, &settings, &mut scratch).error
                    })
                    .collect();
                errors.sort_by(f32::total_cmp);
                curve.median.push(errors[errors.len() / 2]);
                curve.p90.push(errors[errors.len() * 9 / 10]);
            }
            Some(curve)
        })
        .collect()
}

/// The known smooth motion the spline study interpolates: one period of
/// `sin(2 pi t) + 0.3 cos(4 pi t)` on `t` in [0, 1].
pub fn smooth_motion(t: f32) -> f32 {
    let tau = std::f32::consts::TAU;
    (tau * t).sin() + 0.3 * (2.0 * tau * t).cos()
}

/// One row of the spline study.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplineRow {
    /// Mean key spacing, seconds.
    pub spacing: f32,
    /// Largest error with equally spaced keys (both tangent formulas agree there).
    pub equal: f32,
    /// Largest error with unequally spaced keys, the non-uniform tangent formula.
    pub unequal_nonuniform: f32,
    /// Largest error with unequally spaced keys, the uniform tangent formula.
    pub unequal_uniform: f32,
}

/// Key times on [0, 1] with `count` segments: equal, or each interior key moved by up to
/// `jitter` of a spacing (a fixed pseudo-random pattern).
pub fn key_times(count: u32, jitter: f32) -> Vec<f32> {
    let mut seed = 7u64;
    let d = 1.0 / count as f32;
    (0..=count)
        .map(|i| {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0;
            if i == 0 || i == count {
                i as f32 * d
            } else {
                (i as f32 + jitter * u) * d
            }
        })
        .collect()
}

/// The largest error of a looping spline through [`smooth_motion`] at `times`, sampled at
/// 4000 points; `uniform` picks the uniform tangent formula.
pub fn spline_error(times: &[f32], uniform: bool) -> f32 {
    let values: Vec<f32> = times.iter().map(|&t| smooth_motion(t)).collect();
    let spline = if uniform {
        KeySpline::new_uniform(times, &values, true)
    } else {
        KeySpline::new(times, &values, true)
    };
    let Ok(spline) = spline else {
        return f32::INFINITY;
    };
    (0..4000)
        .map(|i| {
            let t = i as f32 / 4000.0;
            (spline.sample(t).0 - smooth_motion(t)).abs()
        })
        .fold(0.0, f32::max)
}

/// The spline study for each segment count in `counts` (keys `1 / count` apart on average,
/// unequal keys moved by up to 40% of a spacing).
pub fn spline_errors(counts: &[u32]) -> Vec<SplineRow> {
    counts
        .iter()
        .map(|&count| {
            let equal = key_times(count, 0.0);
            let unequal = key_times(count, 0.4);
            SplineRow {
                spacing: 1.0 / count as f32,
                equal: spline_error(&equal, false),
                unequal_nonuniform: spline_error(&unequal, false),
                unequal_uniform: spline_error(&unequal, true),
            }
        })
        .collect()
}
