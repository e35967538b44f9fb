//! Ball joints (the joints of any hierarchy, a glTF scene's nodes) as chains of hinges for
//! [`solve`](super::solve), and their tracking of a moving target.

use std::f32::consts::PI;

use bevy::math::{EulerRot, Quat, Vec3};
use bevy::reflect::Reflect;

use super::{IkChain, IkError, IkSettings, clamp};
use crate::skeleton::rig::{BoneDesc, Pose, Rig};

/// The angle limits of a ball joint of a [`BallChain`], radians: `(min, max)` of each of its
/// three turns (the joint's local rotation is `Rx(x) Ry(y) Rz(z)`, see [`BallChain`]). A range
/// of zero width holds the turn there (`(0.0, 0.0)` about y and z makes the joint a hinge
/// about x); one from -pi to pi (or wider) is no limit at all, the angle free to wind past
/// +-pi. Default: [`JointLimits::FREE`].
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct JointLimits {
    /// The turn about the joint's local x axis (its parent's x: the first turn).
    pub x: (f32, f32),
    /// The turn about the joint's y axis after the x turn.
    pub y: (f32, f32),
    /// The turn about the joint's z axis after the x and y turns (the joint's own z).
    pub z: (f32, f32),
}

impl JointLimits {
    /// Every turn free within +-pi.
    pub const FREE: Self = Self {
        x: (-PI, PI),
        y: (-PI, PI),
        z: (-PI, PI),
    };

    /// A hinge about the joint's local x axis within `(min, max)`: the y and z turns held at 0
    /// (an elbow, a knee).
    pub const fn hinge_x(min: f32, max: f32) -> Self {
        Self {
            x: (min, max),
            y: (0.0, 0.0),
            z: (0.0, 0.0),
        }
    }
}

impl Default for JointLimits {
    fn default() -> Self {
        Self::FREE
    }
}

/// A chain of ball joints (the joints of any hierarchy, a glTF scene's nodes: each turns about
/// its origin in three dimensions) as a chain of hinge bones for [`solve`](super::solve): each joint is
/// three hinges at its origin, about its local x axis, then y, then z, so that its local
/// rotation is `Rx(x) Ry(y) Rz(z)` (intrinsic x-y-z Euler angles, glam's `EulerRot::XYZ`),
/// each angle within its [`JointLimits`]. The rig's root stands for the first joint's parent.
///
/// Each solve is set up with [`BallChain::set_pose`] from the hierarchy's current frames (the
/// parent's world frame, every joint's offset and local rotation, the effector), which also
/// turns the rotations into angles; [`BallChain::rotation`] gives a joint's local rotation back
/// from a solved pose. Gimbal lock (y at +-pi/2, where x and z turn about the same axis) is no
/// trouble for the solver: its damped least-squares step takes any direction the other hinges
/// give.
#[derive(Clone, Debug, PartialEq)]
pub struct BallChain {
    /// The hinge rig: the root, then the x, y and z hinges of every joint in turn.
    pub rig: Rig,
    /// Every hinge of the rig, with the effector (on the end joint's z hinge).
    pub chain: IkChain,
}

impl BallChain {
    /// A chain of `limits.len()` ball joints, `limits` from the first joint (nearest the root)
    /// to the end joint. Errors: no joints ([`IkError::TooLong`] with length 0), limits not
    /// finite and ordered ([`IkError::BadLimits`]).
    pub fn new(limits: &[JointLimits]) -> Result<Self, IkError> {
        if limits.is_empty() {
            return Err(IkError::TooLong {
                end: String::new(),
                length: 0,
            });
        }
        let mut descs = vec![BoneDesc {
            name: "base".into(),
            parent: None,
            offset: [0.0; 3],
            axis: [1.0, 0.0, 0.0],
            limits: None,
        }];
        for (j, l) in limits.iter().enumerate() {
            let ok = |(lo, hi): (f32, f32)| lo.is_finite() && hi.is_finite() && lo <= hi;
            if !(ok(l.x) && ok(l.y) && ok(l.z)) {
                return Err(IkError::BadLimits(j));
            }
            for (axis, (lo, hi)) in [(Vec3::X, l.x), (Vec3::Y, l.y), (Vec3::Z, l.z)] {
                let parent = descs.last().map(|d| d.name.clone());
                descs.push(BoneDesc {
                    name: format!("{}", descs.len()),
                    parent,
                    offset: [0.0; 3],
                    axis: axis.to_array(),
                    // A whole turn or more is no limit: the angle may wind past +-pi.
                    limits: (lo > -PI || hi < PI).then_some((lo, hi)),
                });
            }
        }
        let rig = Rig::new(&descs).map_err(|_| IkError::BadLimits(0))?;
        // A single run from the root: the rig keeps the bones in order.
        let bones = (1..rig.bones().len()).collect();
        Ok(Self {
            rig,
            chain: IkChain {
                bones,
                effector: Vec3::ZERO,
            },
        })
    }

    /// How many joints the chain has.
    pub fn joints(&self) -> usize {
        self.chain.bones.len() / 3
    }

    /// Sets the chain up for a solve: `base` is the world rotation and position of the first
    /// joint's parent, `joints` each joint's offset from the joint before (in that joint's
    /// frame; the first's in the base's) and local rotation, first to end, and `effector` the
    /// effector in the end joint's frame. Writes the base and the joints' angles into `pose`
    /// (the chain's rig's pose). Returns false, changing nothing, if `joints` is not one entry
    /// per joint or a value is not finite.
    pub fn set_pose(
        &mut self,
        pose: &mut Pose,
        (base_rotation, base_position): (Quat, Vec3),
        joints: &[(Vec3, Quat)],
        effector: Vec3,
    ) -> bool {
        let finite = base_rotation.is_finite()
            && base_position.is_finite()
            && effector.is_finite()
            && joints
                .iter()
                .all(|(offset, rotation)| offset.is_finite() && rotation.is_finite());
        if !finite || joints.len() != self.joints() || base_rotation.length_squared() < 1e-12 {
            return false;
        }
        pose.root_rotation = base_rotation.normalize();
        pose.root_translation = base_position;
        pose.angles.resize(self.rig.bones().len(), 0.0);
        for (j, &(offset, rotation)) in joints.iter().enumerate() {
            let first = 1 + 3 * j;
            self.rig.set_offset(first, offset);
            let (x, y, z) = rotation.normalize().to_euler(EulerRot::XYZ);
            pose.angles[first..first + 3].copy_from_slice(&[x, y, z]);
        }
        self.chain.effector = effector;
        true
    }

    /// Joint `j`'s local rotation in `pose` (its angles clamped to their limits).
    pub fn rotation(&self, pose: &Pose, j: usize) -> Quat {
        let angle = |b: usize| clamp(&self.rig, b, pose.angles.get(b).copied().unwrap_or(0.0));
        let first = 1 + 3 * j;
        Quat::from_euler(
            EulerRot::XYZ,
            angle(first),
            angle(first + 1),
            angle(first + 2),
        )
    }
}

/// Keeps a [`BallChain`]'s IK continuous while it tracks a moving target, as [`IkTracking`]
/// does for hinges, with the speed limit on each joint's whole rotation: each solve starts
/// from the last step's angles by damped least squares alone (no FABRIK pass, no restarts,
/// so it stays with the nearby solution), and each joint turns towards the new solution by
/// at most a given angle per step (its three angles moved by the same fraction of the way:
/// near gimbal lock a small turn of the joint can be a large change of two of its angles).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct BallTracking {
    /// The chain's angles at the last step (chain order), empty before the first.
    last: Vec<f32>,
}

impl BallTracking {
    /// Puts the last step's angles of `ball` into `pose` (if there was a last step) and
    /// returns the settings to solve with and whether the solve swings the chain first (the
    /// argument of [`solve_with`](super::solve_with)): `settings` and a swing, or without restarts and swing once
    /// warm.
    pub(crate) fn warm_start(
        &self,
        ball: &BallChain,
        pose: &mut Pose,
        settings: &IkSettings,
    ) -> (IkSettings, bool) {
        let warm = self.last.len() == ball.chain.bones.len();
        if warm {
            for (&b, &angle) in ball.chain.bones.iter().zip(&self.last) {
                pose.angles[b] = angle;
            }
        }
        let settings = IkSettings {
            restarts: settings.restarts && !warm,
            ..*settings
        };
        (settings, !warm)
    }

    /// Turns each joint of `ball` in `pose` (a solution) to within `max_step` radians of its
    /// rotation at the last step, and keeps the angles for the next step.
    pub(crate) fn follow(&mut self, ball: &BallChain, pose: &mut Pose, max_step: f32) {
        let bones = &ball.chain.bones;
        if self.last.len() == bones.len() && max_step.is_finite() {
            let max_step = max_step.max(0.0);
            let mut last = ball.rig.rest_pose();
            for (&b, &angle) in bones.iter().zip(&self.last) {
                last.angles[b] = angle;
            }
            for j in 0..ball.joints() {
                let turn = ball
                    .rotation(&last, j)
                    .angle_between(ball.rotation(pose, j));
                if turn > max_step {
                    let fraction = max_step / turn;
                    let joint = 3 * j..3 * j + 3;
                    for (&b, &from) in bones[joint.clone()].iter().zip(&self.last[joint]) {
                        let to = &mut pose.angles[b];
                        *to = from + (*to - from) * fraction;
                    }
                }
            }
        }
        self.last.clear();
        self.last.extend(bones.iter().map(|&b| pose.angles[b]));
    }

    /// Forgets the last step (the chain changed).
    pub(crate) fn forget(&mut self) {
        self.last.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::ik::{IkScratch, effector_position, solve};

    #[test]
    fn a_ball_chain_gives_back_the_rotations_it_was_set_with_and_keeps_its_limits() {
        let mut ball =
            BallChain::new(&[JointLimits::FREE, JointLimits::hinge_x(-2.5, 0.0)]).unwrap();
        assert_eq!(ball.joints(), 2);
        let mut pose = ball.rig.rest_pose();
        let shoulder = Quat::from_euler(EulerRot::YXZ, 0.7, -1.2, 0.4);
        let elbow = Quat::from_rotation_x(-1.1);
        let (offset, effector) = (Vec3::new(0.0, -0.28, 0.0), Vec3::new(0.0, -0.25, 0.0));
        let base = (Quat::from_rotation_y(0.3), Vec3::new(0.1, 1.4, 0.0));
        assert!(ball.set_pose(
            &mut pose,
            base,
            &[(Vec3::ZERO, shoulder), (offset, elbow)],
            effector
        ));
        // (Compared by the axes they turn: `angle_between`'s acos loses 1e-3 rad near 0 in f32.)
        let apart = |a: Quat, b: Quat| {
            [Vec3::X, Vec3::Y, Vec3::Z]
                .into_iter()
                .map(|v| (a * v).distance(b * v))
                .fold(0.0, f32::max)
        };
        assert!(apart(ball.rotation(&pose, 0), shoulder) < 1e-5);
        assert!(apart(ball.rotation(&pose, 1), elbow) < 1e-5);
        // The hinges' forward kinematics is the hierarchy's.
        let wrist = base.1 + base.0 * (shoulder * (offset + elbow * effector));
        assert!(effector_position(&ball.rig, &ball.chain, &pose).distance(wrist) < 1e-5);
        // A bent elbow the limits forbid comes back inside them.
        pose.angles[4] = 0.5;
        pose.angles[5] = 0.3;
        assert!(apart(ball.rotation(&pose, 1), Quat::IDENTITY) < 1e-6);
        // A target within reach is reached, the elbow a hinge within its limits.
        let target = base.1 + Vec3::new(-0.2, 0.25, 0.2);
        let result = solve(
            &ball.rig,
            &ball.chain,
            &mut pose,
            target,
            &IkSettings::default(),
            &mut IkScratch::default(),
        );
        assert!(result.reached, "{result:?}");
        assert!((-2.5..=0.0).contains(&pose.angles[4]));
        assert_eq!((pose.angles[5], pose.angles[6]), (0.0, 0.0));
        assert!(!ball.set_pose(&mut pose, base, &[(Vec3::ZERO, shoulder)], effector));
        assert!(!ball.set_pose(
            &mut pose,
            base,
            &[(Vec3::ZERO, shoulder), (Vec3::NAN, elbow)],
            effector
        ));
        assert_eq!(
            BallChain::new(&[JointLimits {
                y: (1.0, -1.0),
                ..JointLimits::FREE
            }]),
            Err(IkError::BadLimits(0))
        );
        assert!(BallChain::new(&[]).is_err());
    }
}
