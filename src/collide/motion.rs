//! The rigid motion of a frame (a character, a collider, the entity a cloth follows) over
//! one fixed step, with teleports told apart from motion.
//!
//! A [`FrameTracker`] is fed the frame's world pose once per fixed step and returns a
//! [`FrameStep`]: the pose at the start and at the end of the step and the constant linear
//! and angular velocity that carries one to the other (the finite difference of the pose, so
//! a collider swept from `start` to `end` through the substeps moves exactly at it). A pose
//! change larger than a [`Teleport`] threshold is a jump, not motion: the step is marked
//! [`FrameStep::jumped`] and keeps the velocity of the step before (the motion goes on where
//! the frame reappears); a collider that jumped starts the step where it ends
//! ([`FrameStep::sweep_start`]), so nothing is swept through the space between.
//!
//! [`FrameStep::carry`] moves points, directions and poses with a fraction of the step's
//! motion: how a cloth is carried along by the entity it follows (see
//! [`ClothSim::follow_frame`](crate::cloth::ClothSim::follow_frame)).

use bevy::math::{Quat, Vec3A};

use super::shapes::Pose;

/// When a frame's pose change over one fixed step counts as a jump (a teleport, a respawn)
/// rather than motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Teleport {
    /// A move of the frame's origin farther than this in one step is a jump, metres.
    /// Default: `1.0` (60 m/s at 60 Hz).
    pub distance: f32,
    /// A turn larger than this in one step is a jump, radians. Default: `PI / 3` (60 degrees,
    /// 10 turns a second at 60 Hz).
    pub angle: f32,
}

impl Default for Teleport {
    fn default() -> Self {
        Self {
            distance: 1.0,
            angle: std::f32::consts::FRAC_PI_3,
        }
    }
}

impl Teleport {
    /// Whether going from `start` to `end` in one step is a jump.
    pub fn is_jump(&self, start: &Pose, end: &Pose) -> bool {
        let turn = (end.rotation * start.rotation.inverse()).normalize();
        let angle = 2.0 * turn.w.abs().min(1.0).acos();
        start.translation.distance(end.translation) > self.distance || angle > self.angle
    }
}

/// A frame's motion over one fixed step (see the [module docs](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameStep {
    /// The pose at the start of the step (the end of the last one; equal to `end` on the
    /// first step).
    pub start: Pose,
    /// The pose at the end of the step.
    pub end: Pose,
    /// Velocity of the frame's origin, m/s (world frame).
    pub linear_velocity: Vec3A,
    /// Angular velocity, rad/s (world frame, axis times rate).
    pub angular_velocity: Vec3A,
    /// Whether the frame jumped this step (a [`Teleport`]).
    pub jumped: bool,
}

impl FrameStep {
    /// A frame at rest at `pose`.
    pub fn at_rest(pose: Pose) -> Self {
        Self {
            start: pose,
            end: pose,
            linear_velocity: Vec3A::ZERO,
            angular_velocity: Vec3A::ZERO,
            jumped: false,
        }
    }

    /// Where something moving with the frame starts its sweep through the step: `start`, or
    /// `end` after a jump.
    pub fn sweep_start(&self) -> Pose {
        if self.jumped { self.end } else { self.start }
    }

    /// The velocity of the world point `p` moving with the frame, at the end of the step.
    pub fn velocity_at(&self, p: Vec3A) -> Vec3A {
        self.linear_velocity + self.angular_velocity.cross(p - self.end.translation)
    }

    /// The rigid map that moves the world with `fraction` of the step's pose change: its
    /// rotation is `fraction` of the turn, about the frame's origin at the start, and the
    /// origin goes `fraction` of the way to its end. `1` maps `start` onto `end`, `0` is the
    /// identity.
    pub fn carry(&self, fraction: f32) -> RigidMap {
        let turn = (self.end.rotation * self.start.rotation.inverse()).normalize();
        let rotation = Quat::IDENTITY.slerp(turn, fraction).normalize();
        RigidMap {
            rotation,
            pivot: self.start.translation,
            to: self.start.translation.lerp(self.end.translation, fraction),
        }
    }
}

/// A rigid map of the world: `p -> rotation (p - pivot) + to`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMap {
    /// The rotation.
    pub rotation: Quat,
    /// The point the rotation turns about.
    pub pivot: Vec3A,
    /// Where the pivot goes.
    pub to: Vec3A,
}

impl RigidMap {
    /// Whether the map moves nothing.
    pub fn is_identity(&self) -> bool {
        self.rotation == Quat::IDENTITY && self.pivot == self.to
    }

    /// A point moved by the map.
    pub fn point(&self, p: Vec3A) -> Vec3A {
        self.rotation * (p - self.pivot) + self.to
    }

    /// A direction (a velocity) turned by the map.
    pub fn vector(&self, v: Vec3A) -> Vec3A {
        self.rotation * v
    }

    /// A pose moved by the map.
    pub fn pose(&self, pose: &Pose) -> Pose {
        Pose {
            translation: self.point(pose.translation),
            rotation: (self.rotation * pose.rotation).normalize(),
        }
    }
}

/// Follows a frame from one fixed step to the next (see the [module docs](self)).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameTracker {
    last: Option<FrameStep>,
}

impl FrameTracker {
    /// The frame is at `pose` at the end of a step of `dt` seconds: its motion over the step.
    /// With `teleport`, a pose change past its thresholds is a jump; a non-finite or
    /// non-positive `dt` is treated as no time passing (the frame is at rest).
    pub fn step(&mut self, pose: Pose, dt: f32, teleport: Option<&Teleport>) -> FrameStep {
        let step = match self.last {
            None => FrameStep::at_rest(pose),
            Some(_) if !(dt > 0.0 && dt.is_finite()) => FrameStep::at_rest(pose),
            Some(last) => {
                let start = last.end;
                if teleport.is_some_and(|t| t.is_jump(&start, &pose)) {
                    FrameStep {
                        start,
                        end: pose,
                        jumped: true,
                        ..last
                    }
                } else {
                    let (linear_velocity, angular_velocity) = start.velocity_to(&pose, dt);
                    FrameStep {
                        start,
                        end: pose,
                        linear_velocity,
                        angular_velocity,
                        jumped: false,
                    }
                }
            }
        };
        self.last = Some(step);
        step
    }

    /// The last step, if there was one.
    pub fn last(&self) -> Option<&FrameStep> {
        self.last.as_ref()
    }

    /// Forgets the frame: the next step starts at rest.
    pub fn reset(&mut self) {
        self.last = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f32, yaw: f32) -> Pose {
        Pose {
            translation: Vec3A::new(x, 0.0, 0.0),
            rotation: Quat::from_rotation_y(yaw),
        }
    }

    #[test]
    fn motion_is_the_finite_difference_and_a_jump_keeps_the_last_velocity() {
        let mut tracker = FrameTracker::default();
        let teleport = Teleport::default();
        let dt = 0.1;
        assert_eq!(
            tracker
                .step(pose(0.0, 0.0), dt, Some(&teleport))
                .linear_velocity,
            Vec3A::ZERO
        );
        let walk = tracker.step(pose(0.12, 0.05), dt, Some(&teleport));
        assert!(!walk.jumped);
        assert!((walk.linear_velocity.x - 1.2).abs() < 1e-5);
        assert!((walk.angular_velocity.y - 0.5).abs() < 1e-4);
        let jump = tracker.step(pose(10.12, 0.05), dt, Some(&teleport));
        assert!(jump.jumped);
        assert_eq!(jump.sweep_start(), jump.end);
        assert_eq!(jump.start, walk.end);
        assert_eq!(jump.linear_velocity, walk.linear_velocity);
        // Without a threshold the same change is motion.
        let mut free = FrameTracker::default();
        free.step(pose(0.12, 0.05), dt, None);
        let fast = free.step(pose(10.12, 0.05), dt, None);
        assert!(!fast.jumped && (fast.linear_velocity.x - 100.0).abs() < 1e-3);
        // A turn past 60 degrees is a jump too.
        let turned = tracker.step(pose(10.12, 0.05 + 1.2), dt, Some(&teleport));
        assert!(turned.jumped);
    }

    #[test]
    fn the_whole_carry_maps_start_onto_end_and_none_is_the_identity() {
        let step = FrameStep {
            start: pose(1.0, 0.3),
            end: Pose {
                translation: Vec3A::new(2.0, 0.5, -1.0),
                rotation: Quat::from_rotation_y(1.1) * Quat::from_rotation_x(0.2),
            },
            linear_velocity: Vec3A::ZERO,
            angular_velocity: Vec3A::ZERO,
            jumped: true,
        };
        let whole = step.carry(1.0).pose(&step.start);
        assert!(whole.translation.distance(step.end.translation) < 1e-5);
        assert!(whole.rotation.angle_between(step.end.rotation) < 1e-3);
        let none = step.carry(0.0);
        let p = Vec3A::new(0.3, -0.7, 2.0);
        assert!(none.point(p).distance(p) < 1e-6);
        // Half the carry, twice, is the whole carry (for a rotation about the pivot).
        let half = step.carry(0.5);
        let q = half.rotation * half.rotation;
        assert!(q.angle_between(step.carry(1.0).rotation) < 1e-3);
    }
}
