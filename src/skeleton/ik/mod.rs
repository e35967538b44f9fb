//! Inverse kinematics on chains of hinge bones: a FABRIK pass (Aristidou and Lasenby 2011),
//! then damped least squares.
//!
//! A chain is a run of bones of a [`Rig`], each a child of the one before, from its first
//! bone (whose parent stays where the pose puts it) to its end bone, with an end effector at a
//! fixed point of the end bone. The joints are the bones' origins; the distinct points of the
//! chain are the first bone's origin, every later bone's origin that is not on top of the one
//! before (a zero offset makes two hinges at one joint), and the effector. A solve:
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
//!    cyclic-coordinate step).
//! 4. **Damped least squares** (Levenberg-Marquardt) from the best pose so far, every hinge at
//!    once: `dtheta = J^T (J J^T + mu^2 I)^-1 r` with `J` the effector's Jacobian, a hinge at a
//!    limit that the step would push past held out of it, until the effector is within the
//!    tolerance or the descent stalls (less than 5% gained over two steps).
//!
//! Steps 1 to 3 run once, swinging the chain toward the target as a whole; step 4 then
//! converges. After a stall (a local minimum at the limits) step 4 restarts from other angles
//! within the limits (a fixed pseudo-random sequence, so solves are repeatable) until the
//! iteration cap; the best pose found is returned, so an unreachable target gets the chain
//! reaching as far toward it as the hinges allow. Measured on 10,000 random reachable targets
//! of 40 random chains (3 to 7 hinges, random axes and offsets, limits tight, loose or none;
//! `tests/ik.rs`), from the rest pose, release build: 99.97% within 1 mm, 2.8 us per solve on
//! average; FABRIK's passes with the sweep and restarts alone reached 90.2% in 50 iterations
//! (16.9 us) and 94.0% in 100: near a limit, one hinge at a time cannot agree on the last
//! centimetres, and clamping a least-squares step instead of holding the hinge out of it
//! loses that part of the step every time (98.6%).

use bevy::math::{Quat, Vec3};
use bevy::reflect::Reflect;

use super::rig::{Pose, Rig};

mod ball;

pub(crate) use ball::BallTracking;
pub use ball::{BallChain, JointLimits};

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
    /// A joint's [`JointLimits`] are not finite and ordered (min <= max).
    #[error("joint {0} of the chain has limits that are not finite and ordered (min <= max)")]
    BadLimits(usize),
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
    /// Most iterations: the FABRIK pass and each damped-least-squares step count one each,
    /// restarts included. Default: `100`.
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
            max_iterations: 100,
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
    saved: Vec<f32>,
    held: Vec<bool>,
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
    solve_with(rig, chain, pose, target, settings, scratch, true)
}

/// [`solve`], with the FABRIK pass and sweep (steps 1 to 3) only if `swing`: without them
/// the solve is damped least squares from the angles in `pose` alone, which stays with the
/// nearby solution (tracking a target from the last step's solution; a FABRIK pass sets
/// every angle afresh and may land on another solution).
pub(crate) fn solve_with(
    rig: &Rig,
    chain: &IkChain,
    pose: &mut Pose,
    target: Vec3,
    settings: &IkSettings,
    scratch: &mut IkScratch,
    swing: bool,
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
        saved,
        held,
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
    let mut iterations = 0;
    let mut restarts = 0;
    let mut seed = 0x9E37_79B9u32;
    let keep = |best: &mut Vec<f32>, best_error: &mut f32, pose: &Pose, error: f32| {
        if error < *best_error {
            *best_error = error;
            for (slot, &b) in best.iter_mut().zip(&chain.bones) {
                *slot = pose.angles[b];
            }
        }
    };
    if swing && iterations < settings.max_iterations && best_error > settings.tolerance {
        // 1.-3. One FABRIK pass and sweep: the chain swings toward the target as a whole.
        iterations += 1;
        fabrik_pass(
            rig, chain, pose, target, base_frame, points, lengths, targets, joints, rotations,
        );
        keep(best, &mut best_error, pose, joints[n].distance(target));
    }
    // 4. Damped least squares from the best pose so far, to the target or a stall; after a
    //    stall, again from other angles within the limits, the best pose kept.
    for (&b, &angle) in chain.bones.iter().zip(best.iter()) {
        pose.angles[b] = angle;
    }
    while iterations < settings.max_iterations && best_error > settings.tolerance {
        let (steps, error) = damped_least_squares(
            rig,
            chain,
            pose,
            target,
            base_frame,
            settings.tolerance,
            settings.max_iterations - iterations,
            joints,
            rotations,
            (saved, held),
        );
        iterations += steps.max(1);
        keep(best, &mut best_error, pose, error);
        if best_error <= settings.tolerance || !settings.restarts {
            break;
        }
        restarts += 1;
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

/// One FABRIK iteration with its sweep (steps 1 to 3 of the [module docs](self)) from the
/// angles in `pose`; `joints` and `rotations` end as the new pose's forward kinematics.
#[allow(clippy::too_many_arguments)]
fn fabrik_pass(
    rig: &Rig,
    chain: &IkChain,
    pose: &mut Pose,
    target: Vec3,
    base_frame: (Quat, Vec3),
    points: &[usize],
    lengths: &[f32],
    targets: &mut Vec<Vec3>,
    joints: &mut Vec<Vec3>,
    rotations: &mut Vec<Quat>,
) {
    let n = chain.bones.len();
    let m = points.len();
    let bones = rig.bones();
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
    //    target as it can.
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
}

/// Damped least squares (Levenberg-Marquardt) on the chain's angles from `pose`, at most
/// `max_steps` steps or until the effector is within `tolerance`: with `J` the 3 x n Jacobian
/// of the effector (column `k` is `a_k x (e - p_k)`, the hinge's world axis across the lever
/// from its joint to the effector) and `r` the error to the target, each step tries
/// `dtheta = J^T (J J^T + mu^2 I)^-1 r`, clamped to the limits; a step that does not reduce the
/// error is undone and `mu` raised four times, one that does is kept and `mu` halved. Returns
/// the steps taken and the error at the end; `pose` holds the best angles found, and `joints`
/// and `rotations` their forward kinematics (`saved` and `held` are scratch).
#[allow(clippy::too_many_arguments)]
fn damped_least_squares(
    rig: &Rig,
    chain: &IkChain,
    pose: &mut Pose,
    target: Vec3,
    base_frame: (Quat, Vec3),
    tolerance: f32,
    max_steps: u32,
    joints: &mut Vec<Vec3>,
    rotations: &mut Vec<Quat>,
    (saved, held): (&mut Vec<f32>, &mut Vec<bool>),
) -> (u32, f32) {
    let n = chain.bones.len();
    let bones = rig.bones();
    chain_fk(rig, chain, pose, base_frame, joints, rotations);
    let mut error = joints[n].distance(target);
    // The damping in metres: a tenth of the chain's reach to start with.
    let reach: f32 = joints.windows(2).map(|w| w[0].distance(w[1])).sum();
    let mut mu = 0.1 * reach.max(1e-3);
    let mut steps = 0;
    // The error two steps back: less than 5% gained over two steps is a stall.
    let (mut back1, mut back2) = (f32::INFINITY, f32::INFINITY);
    while steps < max_steps && error > tolerance {
        if error > 0.95 * back2 {
            break;
        }
        back2 = back1;
        back1 = error;
        steps += 1;
        let effector = joints[n];
        let r = target - effector;
        let column = |k: usize| -> Vec3 {
            let parent = if k == 0 {
                base_frame.0
            } else {
                rotations[k - 1]
            };
            (parent * bones[chain.bones[k]].axis).cross(effector - joints[k])
        };
        // A hinge at a limit that the step would push past is held out of the step (its
        // column left out), and the step taken again with the others: clamping it instead
        // would lose that part of the step every time.
        let at_limit = |k: usize, turn: f32| -> bool {
            let b = chain.bones[k];
            bones[b].limits.is_some_and(|(lo, hi)| {
                let a = pose.angles[b];
                (a <= lo + 1e-6 && turn < 0.0) || (a >= hi - 1e-6 && turn > 0.0)
            })
        };
        held.clear();
        held.resize(n, false);
        let mut y = Vec3::ZERO;
        for _ in 0..2 {
            // J J^T + mu^2 I over the hinges not held, as three columns.
            let mut jjt = [Vec3::ZERO; 3];
            for k in (0..n).filter(|&k| !held[k]) {
                let c = column(k);
                jjt[0] += c * c.x;
                jjt[1] += c * c.y;
                jjt[2] += c * c.z;
            }
            let damped = bevy::math::Mat3::from_cols(
                jjt[0] + Vec3::X * mu * mu,
                jjt[1] + Vec3::Y * mu * mu,
                jjt[2] + Vec3::Z * mu * mu,
            );
            y = damped.inverse() * r;
            let mut newly = false;
            for (k, held) in held.iter_mut().enumerate() {
                if !*held && at_limit(k, column(k).dot(y)) {
                    *held = true;
                    newly = true;
                }
            }
            if !newly {
                break;
            }
        }
        if !y.is_finite() {
            break;
        }
        saved.clear();
        saved.extend(chain.bones.iter().map(|&b| pose.angles[b]));
        for k in (0..n).filter(|&k| !held[k]) {
            let b = chain.bones[k];
            pose.angles[b] = clamp(rig, b, pose.angles[b] + column(k).dot(y));
        }
        chain_fk(rig, chain, pose, base_frame, joints, rotations);
        let new_error = joints[n].distance(target);
        if new_error < error {
            error = new_error;
            mu *= 0.5;
        } else {
            for (&b, &angle) in chain.bones.iter().zip(saved.iter()) {
                pose.angles[b] = angle;
            }
            chain_fk(rig, chain, pose, base_frame, joints, rotations);
            mu *= 4.0;
        }
    }
    (steps, error)
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
mod tests;
