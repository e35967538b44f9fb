//! FABRIK inverse kinematics (Aristidou and Lasenby 2011) on chains of hinge bones.
//!
//! A chain is a run of bones of a [`Rig`], each a child of the one before, from its first
//! bone (whose parent stays where the pose puts it) to its end bone, with an end effector at a
//! fixed point of the end bone. The joints are the bones' origins; the distinct points of the
//! chain are the first bone's origin, every later bone's origin that is not on top of the one
//! before (a zero offset makes two hinges at one joint), and the effector. Each iteration:
//!
//! 1. **Backward** (from the target): the effector is put on the target, and every point in
//!    turn is moved along the line to the point after it until it is at its segment's length
//!    from it (unconstrained, as in FABRIK).
//! 2. **Forward** (from the base), with the hinges: the first point stays; then each bone in
//!    order turns about its hinge axis only, within its limits, so that the next distinct point
//!    it carries lies as close as its hinge allows to the line from its joint toward that
//!    point's backward position: with `A` the hinge axis in the world, `v` the direction to the
//!    carried point at angle 0 and `u` the wanted direction, both projected on the plane normal
//!    to `A`, the angle is `atan2(A . (v x u), v . u)`, clamped to the limits. The new angle
//!    then places everything after it (forward kinematics), so the result is a pose with every
//!    bone turned about its own hinge and nothing else.
//!
//! 3. **Sweep**: from the end bone back to the first, each hinge turns (within its limits)
//!    so the effector comes as close to the target as that hinge alone can bring it (the
//!    cyclic-coordinate step). Without it the two passes settle slowly, or short of the
//!    target, when the hinge planes and the target disagree (measured on a shoulder of two
//!    hinges and an elbow: 6.5% of 1000 reachable targets within 1 mm in 50 iterations).
//!
//! It stops when the effector is within the tolerance of the target or at the iteration cap.
//! When an iteration improves the error by less than 1% twice in a row (a stall, at a limit
//! or a singular pose), it restarts from other angles within the limits (a fixed
//! pseudo-random sequence, so solves are repeatable); restarts count toward the cap. The best
//! pose found is returned, so an unreachable target gets the chain reaching as far toward it
//! as the hinges allow.

use bevy::math::{Quat, Vec3};
use bevy::reflect::Reflect;

use super::rig::{Pose, Rig};

/// Why a chain cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IkError {
    /// The end bone is not in the rig.
    #[error("the chain's end bone `{0}` is not a bone of the rig")]
    UnknownBone(String),
    /// The chain would include the root, whose pose IK does not change, or has no bones.
    #[error("a chain of {length} bones ending at `{end}` does not fit below the root")]
    TooLong {
        /// The end bone.
        end: String,
        /// The length asked for.
        length: usize,
    },
    /// The effector offset or the target is not finite.
    #[error("the effector or the target is not finite")]
    NonFinite,
}

/// A chain of hinge bones with an effector on its last bone.
#[derive(Clone, Debug, PartialEq)]
pub struct IkChain {
    /// Bone indices from the first (nearest the root) to the end bone.
    pub bones: Vec<usize>,
    /// The effector, in the end bone's frame, metres.
    pub effector: Vec3,
}

impl IkChain {
    /// The chain of the `length` bones ending at `end` (`end` and its `length - 1` nearest
    /// ancestors), with the effector at `effector` in the end bone's frame.
    pub fn new(rig: &Rig, end: &str, length: usize, effector: Vec3) -> Result<Self, IkError> {
        let mut b = rig
            .find(end)
            .ok_or_else(|| IkError::UnknownBone(end.to_string()))?;
        if !effector.is_finite() {
            return Err(IkError::NonFinite);
        }
        let too_long = || IkError::TooLong {
            end: end.to_string(),
            length,
        };
        if length == 0 {
            return Err(too_long());
        }
        let mut bones = vec![b];
        while bones.len() < length {
            b = rig.bones()[b].parent.ok_or_else(too_long)?;
            bones.push(b);
        }
        if rig.bones()[*bones.last().unwrap_or(&0)].parent.is_none() {
            return Err(too_long());
        }
        bones.reverse();
        Ok(Self { bones, effector })
    }
}

/// When a solve stops.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct IkSettings {
    /// Distance from the target that counts as reached, metres. Default: `0.001`.
    pub tolerance: f32,
    /// Most iterations (restarts included). Default: `50`.
    pub max_iterations: u32,
    /// Whether a stalled solve may restart from other angles. A restart can land on a
    /// different solution far from the start; a solve that starts from the last step's
    /// solution to track a moving target should not (`InverseKinematics` turns it off then,
    /// so a limb never jumps between solutions). Default: `true`.
    pub restarts: bool,
}

impl Default for IkSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-3,
            max_iterations: 50,
            restarts: true,
        }
    }
}

/// What a solve did.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct IkResult {
    /// Iterations used.
    pub iterations: u32,
    /// Distance from the effector to the target at the end, metres.
    pub error: f32,
    /// Whether the error is within the tolerance.
    pub reached: bool,
    /// Restarts made.
    pub restarts: u32,
}

/// Reusable memory for [`solve`].
#[derive(Clone, Debug, Default)]
pub struct IkScratch {
    /// Distinct points: chain position (bone index in the chain, or `len` for the effector).
    points: Vec<usize>,
    targets: Vec<Vec3>,
    lengths: Vec<f32>,
    best: Vec<f32>,
    joints: Vec<Vec3>,
    rotations: Vec<Quat>,
    path: Vec<usize>,
}

/// A bone's hinge angle clamped to its limits.
fn clamp(rig: &Rig, bone: usize, angle: f32) -> f32 {
    match rig.bones()[bone].limits {
        Some((lo, hi)) => angle.clamp(lo, hi),
        None => angle,
    }
}

/// World rotation and position of the first bone's parent.
fn base(rig: &Rig, chain: &IkChain, pose: &Pose, path: &mut Vec<usize>) -> (Quat, Vec3) {
    // Forward kinematics down to the parent of the chain's first bone.
    let first = chain.bones[0];
    path.clear();
    let mut b = rig.bones()[first].parent;
    while let Some(p) = b {
        path.push(p);
        b = rig.bones()[p].parent;
    }
    let (mut rotation, mut position) = (pose.root_rotation, pose.root_translation);
    for &p in path.iter().rev() {
        let bone = &rig.bones()[p];
        if bone.parent.is_some() {
            position += rotation * bone.offset;
            let angle = clamp(rig, p, pose.angles[p]);
            rotation = (rotation * rig.local_rotation(p, angle)).normalize();
        }
    }
    (rotation, position)
}

/// Positions of the chain's joints (by chain position) and of the effector (last), and the
/// rotation of every bone, from the base pose.
fn chain_fk(
    rig: &Rig,
    chain: &IkChain,
    pose: &Pose,
    (base_rotation, base_position): (Quat, Vec3),
    joints: &mut Vec<Vec3>,
    rotations: &mut Vec<Quat>,
) {
    joints.clear();
    rotations.clear();
    let (mut rotation, mut position) = (base_rotation, base_position);
    for &b in &chain.bones {
        position += rotation * rig.bones()[b].offset;
        rotation = (rotation * rig.local_rotation(b, clamp(rig, b, pose.angles[b]))).normalize();
        joints.push(position);
        rotations.push(rotation);
    }
    joints.push(position + rotation * chain.effector);
}

/// Solves `chain` for the effector to reach `target` (world), changing only the chain's
/// angles in `pose`.
pub fn solve(
    rig: &Rig,
    chain: &IkChain,
    pose: &mut Pose,
    target: Vec3,
    settings: &IkSettings,
    scratch: &mut IkScratch,
) -> IkResult {
    let n = chain.bones.len();
    let bones = rig.bones();
    let IkScratch {
        points,
        targets,
        lengths,
        best,
        joints,
        rotations,
        path,
    } = scratch;
    let base_frame = base(rig, chain, pose, path);
    chain_fk(rig, chain, pose, base_frame, joints, rotations);
    if !target.is_finite() || chain.bones.iter().any(|&b| !pose.angles[b].is_finite()) {
        let error = joints[n].distance(target);
        return IkResult {
            iterations: 0,
            error: if error.is_finite() { error } else { f32::MAX },
            reached: false,
            restarts: 0,
        };
    }
    for &b in &chain.bones {
        pose.angles[b] = clamp(rig, b, pose.angles[b]);
    }
    // Distinct points: the first joint, later joints that are not at the previous one, the
    // effector.
    points.clear();
    points.push(0);
    for k in 1..=n {
        let offset = if k < n {
            bones[chain.bones[k]].offset
        } else {
            chain.effector
        };
        if offset.length_squared() > 1e-12 {
            points.push(k);
        }
    }
    let m = points.len();
    lengths.clear();
    for w in 0..m - 1 {
        let (a, b) = (points[w], points[w + 1]);
        lengths.push(joints[a].distance(joints[b]));
    }
    best.clear();
    best.extend(chain.bones.iter().map(|&b| pose.angles[b]));
    let mut best_error = joints[n].distance(target);
    let mut error = best_error;
    let mut iterations = 0;
    let mut restarts = 0;
    let mut stalls = 0;
    let mut seed = 0x9E37_79B9u32;
    while iterations < settings.max_iterations && best_error > settings.tolerance {
        iterations += 1;
        // 1. Backward, unconstrained.
        targets.clear();
        targets.extend(points.iter().map(|&k| joints[k]));
        targets[m - 1] = target;
        for w in (1..m - 1).rev() {
            let next = targets[w + 1];
            let dir = (targets[w] - next).normalize_or_zero();
            targets[w] = next + dir * lengths[w];
        }
        // 2. Forward, each bone about its own hinge.
        let (mut parent_rotation, mut position) = base_frame;
        let mut w = 0; // the distinct point at or before the current joint
        for (k, &b) in chain.bones.iter().enumerate() {
            position += parent_rotation * bones[b].offset;
            if points.get(w + 1) == Some(&k) {
                w += 1;
            }
            // The next distinct point this bone carries, and the vector to it in this bone's
            // frame with the later bones at the same joint at their current angles.
            let next_point = points.get(w + 1).copied().unwrap_or(n);
            let mut carried = if next_point < n {
                bones[chain.bones[next_point]].offset
            } else {
                chain.effector
            };
            for j in (k + 1..next_point.min(n)).rev() {
                let bj = chain.bones[j];
                carried = rig.local_rotation(bj, pose.angles[bj]) * carried;
            }
            let axis = parent_rotation * bones[b].axis;
            let v0 = parent_rotation * carried;
            let u = targets.get(w + 1).copied().unwrap_or(target) - position;
            let (vp, up) = (v0 - axis * axis.dot(v0), u - axis * axis.dot(u));
            if vp.length_squared() > 1e-12 && up.length_squared() > 1e-12 {
                let angle = axis.dot(vp.cross(up)).atan2(vp.dot(up));
                pose.angles[b] = clamp(rig, b, angle);
            }
            parent_rotation = (parent_rotation * rig.local_rotation(b, pose.angles[b])).normalize();
        }
        chain_fk(rig, chain, pose, base_frame, joints, rotations);
        // 3. One sweep from the end bone back: each hinge turns the effector as close to the
        //    target as it can (the FABRIK passes alone settle slowly where the hinge planes
        //    and the target disagree).
        for k in (0..n).rev() {
            let b = chain.bones[k];
            let parent_rotation = if k == 0 {
                base_frame.0
            } else {
                rotations[k - 1]
            };
            let axis = parent_rotation * bones[b].axis;
            let (v, u) = (joints[n] - joints[k], target - joints[k]);
            let (vp, up) = (v - axis * axis.dot(v), u - axis * axis.dot(u));
            if vp.length_squared() > 1e-12 && up.length_squared() > 1e-12 {
                let turn = axis.dot(vp.cross(up)).atan2(vp.dot(up));
                pose.angles[b] = clamp(rig, b, pose.angles[b] + turn);
                chain_fk(rig, chain, pose, base_frame, joints, rotations);
            }
        }
        let new_error = joints[n].distance(target);
        if new_error < best_error {
            best_error = new_error;
            for (slot, &b) in best.iter_mut().zip(&chain.bones) {
                *slot = pose.angles[b];
            }
        }
        stalls = if new_error > error * 0.99 {
            stalls + 1
        } else {
            0
        };
        error = new_error;
        if stalls >= 2 && best_error > settings.tolerance && !settings.restarts {
            break;
        }
        if stalls >= 2 && best_error > settings.tolerance {
            // Restart from other angles within the limits.
            restarts += 1;
            stalls = 0;
            for &b in &chain.bones {
                seed ^= seed << 13;
                seed ^= seed >> 17;
                seed ^= seed << 5;
                let r = seed as f32 / u32::MAX as f32;
                let (lo, hi) = bones[b]
                    .limits
                    .unwrap_or((-std::f32::consts::PI, std::f32::consts::PI));
                pose.angles[b] = lo + (hi - lo) * r;
            }
            chain_fk(rig, chain, pose, base_frame, joints, rotations);
            error = joints[n].distance(target);
        }
    }
    for (&b, &angle) in chain.bones.iter().zip(best.iter()) {
        pose.angles[b] = angle;
    }
    IkResult {
        iterations,
        error: best_error,
        reached: best_error <= settings.tolerance,
        restarts,
    }
}

/// Keeps a chain's IK continuous while it tracks a moving target, step after step: each solve
/// starts from the last step's angles, without restarts (a target out of reach holds the limb
/// at its closest pose rather than sending it to another solution), and the angles move
/// towards each new solution at most a given angle per step.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct IkTracking {
    /// The chain's angles at the last step (chain order), empty before the first.
    last: Vec<f32>,
}

impl IkTracking {
    /// Puts the last step's angles of `chain` into `pose` (if there was a last step) and
    /// returns the settings to solve with: `settings`, without restarts once warm.
    pub(crate) fn warm_start(
        &self,
        chain: &IkChain,
        pose: &mut Pose,
        settings: &IkSettings,
    ) -> IkSettings {
        let warm = self.last.len() == chain.bones.len();
        if warm {
            for (&b, &angle) in chain.bones.iter().zip(&self.last) {
                pose.angles[b] = angle;
            }
        }
        IkSettings {
            restarts: settings.restarts && !warm,
            ..*settings
        }
    }

    /// Moves `chain`'s angles in `pose` (a solution) to within `max_step` radians of the last
    /// step's, and keeps them for the next step.
    pub(crate) fn follow(&mut self, chain: &IkChain, pose: &mut Pose, max_step: f32) {
        if self.last.len() == chain.bones.len() && max_step.is_finite() {
            let max_step = max_step.max(0.0);
            for (&b, from) in chain.bones.iter().zip(&self.last) {
                let to = &mut pose.angles[b];
                *to = from + (*to - from).clamp(-max_step, max_step);
            }
        }
        self.last.clear();
        self.last
            .extend(chain.bones.iter().map(|&b| pose.angles[b]));
    }

    /// Forgets the last step (the chain changed).
    pub(crate) fn forget(&mut self) {
        self.last.clear();
    }
}

/// The rates of a pose's angles from their last values, with no lag: the derivative at the
/// newest of the parabola through the last three (second order), or the last difference while
/// there are only two.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct AngleRates {
    /// The angles of the last two steps, the last first.
    history: [Vec<f32>; 2],
    /// How many of `history` are filled in.
    filled: usize,
}

impl AngleRates {
    /// The rate of angle `b` if it is `angle` now, `dt` seconds after the last step; `None`
    /// with no history.
    pub(crate) fn rate(&self, b: usize, angle: f32, dt: f32) -> Option<f32> {
        let [last, before] = &self.history;
        let no_time = dt.is_nan() || dt <= 0.0;
        if no_time || self.filled == 0 || b >= last.len() {
            return None;
        }
        Some(if self.filled >= 2 && b < before.len() {
            (3.0 * angle - 4.0 * last[b] + before[b]) / (2.0 * dt)
        } else {
            (angle - last[b]) / dt
        })
    }

    /// Remembers this step's angles.
    pub(crate) fn push(&mut self, angles: &[f32]) {
        self.history.swap(0, 1);
        self.history[0].clear();
        self.history[0].extend_from_slice(angles);
        self.filled = (self.filled + 1).min(2);
    }
}

/// The effector's world position for `pose`.
pub fn effector_position(rig: &Rig, chain: &IkChain, pose: &Pose) -> Vec3 {
    let (mut joints, mut rotations, mut path) = (Vec::new(), Vec::new(), Vec::new());
    let frame = base(rig, chain, pose, &mut path);
    chain_fk(rig, chain, pose, frame, &mut joints, &mut rotations);
    joints[chain.bones.len()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::rig::BoneDesc;

    #[test]
    fn angle_rates_are_exact_for_a_parabola_and_second_order_otherwise() {
        let dt = 1.0 / 60.0;
        // theta(t) = 0.3 + 2 t - 5 t^2: the rate at the newest sample is exact.
        let theta = |t: f32| 0.3 + 2.0 * t - 5.0 * t * t;
        let mut rates = AngleRates::default();
        assert_eq!(rates.rate(0, 0.0, dt), None);
        for n in 0..3 {
            let t = n as f32 * dt;
            if n == 2 {
                let rate = rates.rate(0, theta(t), dt).unwrap();
                assert!((rate - (2.0 - 10.0 * t)).abs() < 1e-3, "{rate}");
            }
            rates.push(&[theta(t)]);
        }
        // sin(w t): the error falls with the square of the step.
        let error = |dt: f32| {
            let mut rates = AngleRates::default();
            let mut worst = 0.0f32;
            for n in 0..40 {
                let t = n as f32 * dt;
                if let Some(rate) = rates.rate(0, (3.0 * t).sin(), dt).filter(|_| n >= 2) {
                    worst = worst.max((rate - 3.0 * (3.0 * t).cos()).abs());
                }
                rates.push(&[(3.0 * t).sin()]);
            }
            worst
        };
        let (coarse, fine) = (error(0.05), error(0.025));
        assert!(fine < 0.3 * coarse, "{coarse} then {fine}");
    }

    #[test]
    fn tracking_starts_from_the_last_step_without_restarts_and_limits_each_step() {
        let rig = Rig::new(&[
            BoneDesc {
                name: "root".into(),
                parent: None,
                offset: [0.0; 3],
                axis: [1.0, 0.0, 0.0],
                limits: None,
            },
            BoneDesc {
                name: "arm".into(),
                parent: Some("root".into()),
                offset: [0.0; 3],
                axis: [0.0, 0.0, 1.0],
                limits: None,
            },
        ])
        .unwrap();
        let chain = IkChain::new(&rig, "arm", 1, Vec3::X).unwrap();
        let arm = chain.bones[0];
        let mut tracking = IkTracking::default();
        let mut pose = rig.rest_pose();
        // Cold: the settings as given, the pose untouched.
        let cold = tracking.warm_start(&chain, &mut pose, &IkSettings::default());
        assert!(cold.restarts);
        pose.angles[arm] = 1.0;
        tracking.follow(&chain, &mut pose, 0.1);
        assert_eq!(pose.angles[arm], 1.0, "the first step is not limited");
        // Warm: from the last angles, no restarts, at most 0.1 rad further.
        let mut next = rig.rest_pose();
        let warm = tracking.warm_start(&chain, &mut next, &IkSettings::default());
        assert!(!warm.restarts);
        assert_eq!(next.angles[arm], 1.0);
        next.angles[arm] = -2.0;
        tracking.follow(&chain, &mut next, 0.1);
        assert!((next.angles[arm] - 0.9).abs() < 1e-6);
        tracking.forget();
        assert!(
            tracking
                .warm_start(&chain, &mut next, &IkSettings::default())
                .restarts
        );
    }
}
