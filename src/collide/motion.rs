//! The rigid motion of a frame (a character, a collider, the entity a cloth follows) over
//! one fixed step, with teleports told apart from motion.
//!
//! A [`FrameTracker`] is fed the frame's world pose once per fixed step and returns a
//! [`FrameStep`]: the pose at the start and at the end of the step (a collider is swept from
//! one to the other through the substeps) and the frame's linear and angular velocity at the
//! end of the step. The finite difference of the pose over a step is the velocity half a
//! step earlier; the tracker extrapolates the last two of them to the end of the step
//! (second order, `3/2 v(t - h/2) - 1/2 v(t - 3h/2)`), so a turning or accelerating frame's
//! velocity is not half a step late. A pose
//! change larger than a [`Teleport`] threshold is a jump, not motion: the step is marked
//! [`FrameStep::jumped`] and keeps the velocity of the step before, turned as the frame
//! turned (the motion goes on where the frame reappears, in its new heading); what moves
//! with a frame that jumped sweeps through the step from where the frame reappeared (`end`
//! less the step's motion at those velocities, [`FrameStep::sweep_start`]), so nothing is
//! swept through the space between and nothing stands still for a step either.
//!
//! A step also carries points, directions and poses with a fraction of its motion: how a
//! cloth is carried along by the entity it follows (see
//! [`ClothSolver::follow_frame`](crate::cloth::ClothSolver::follow_frame)).

use bevy::math::{Quat, Vec3A};
use bevy::reflect::Reflect;

use super::pose::RigidPose;

/// When a frame's pose change over one fixed step counts as a jump (a teleport, a respawn)
/// rather than motion.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
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
    pub(crate) fn is_jump(&self, start: &RigidPose, end: &RigidPose) -> bool {
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
    pub start: RigidPose,
    /// The pose at the end of the step.
    pub end: RigidPose,
    /// Velocity of the frame's origin at the end of the step, m/s (world frame).
    pub linear_velocity: Vec3A,
    /// Angular velocity at the end of the step, rad/s (world frame, axis times rate).
    pub angular_velocity: Vec3A,
    /// Whether the frame jumped this step (a [`Teleport`]).
    pub jumped: bool,
    /// Where something moving with the frame starts its sweep through the step: `start`, or
    /// after a jump where the frame reappeared, `end` less the step's motion at the kept
    /// velocities.
    pub sweep_start: RigidPose,
}

impl FrameStep {
    /// A frame at rest at `pose`.
    pub(crate) fn at_rest(pose: RigidPose) -> Self {
        Self {
            start: pose,
            end: pose,
            linear_velocity: Vec3A::ZERO,
            angular_velocity: Vec3A::ZERO,
            jumped: false,
            sweep_start: pose,
        }
    }

    /// The velocity of the world point `p` moving with the frame, at the end of the step.
    pub(crate) fn velocity_at(&self, p: Vec3A) -> Vec3A {
        self.linear_velocity + self.angular_velocity.cross(p - self.end.translation)
    }

    /// The rigid map that moves the world with `fraction` of the step's pose change: its
    /// rotation is `fraction` of the turn, about the frame's origin at the start, and the
    /// origin goes `fraction` of the way to its end. `1` maps `start` onto `end`, `0` is the
    /// identity.
    pub(crate) fn carry(&self, fraction: f32) -> RigidMap {
        Self::map_between(&self.start, &self.end, fraction)
    }

    /// The rigid map that moves the world with a jump: `start` onto
    /// [`FrameStep::sweep_start`], where the frame reappeared.
    pub(crate) fn jump_carry(&self) -> RigidMap {
        Self::map_between(&self.start, &self.sweep_start, 1.0)
    }

    fn map_between(from: &RigidPose, to: &RigidPose, fraction: f32) -> RigidMap {
        let turn = (to.rotation * from.rotation.inverse()).normalize();
        let rotation = Quat::IDENTITY.slerp(turn, fraction).normalize();
        RigidMap {
            rotation,
            pivot: from.translation,
            to: from.translation.lerp(to.translation, fraction),
        }
    }
}

/// A rigid map of the world: `p -> rotation (p - pivot) + to`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RigidMap {
    /// The rotation.
    pub rotation: Quat,
    /// The point the rotation turns about.
    pub pivot: Vec3A,
    /// Where the pivot goes.
    pub to: Vec3A,
}

impl RigidMap {
    /// Whether the map moves nothing.
    pub(crate) fn is_identity(&self) -> bool {
        self.rotation == Quat::IDENTITY && self.pivot == self.to
    }

    /// A point moved by the map.
    pub(crate) fn point(&self, p: Vec3A) -> Vec3A {
        self.rotation * (p - self.pivot) + self.to
    }

    /// A direction (a velocity) turned by the map.
    pub(crate) fn vector(&self, v: Vec3A) -> Vec3A {
        self.rotation * v
    }

    /// A pose moved by the map.
    pub(crate) fn pose(&self, pose: &RigidPose) -> RigidPose {
        RigidPose {
            translation: self.point(pose.translation),
            rotation: (self.rotation * pose.rotation).normalize(),
        }
    }
}

/// Follows a frame from one fixed step to the next (see the [module docs](self)).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameTracker {
    last: Option<FrameStep>,
    /// The mean linear and angular velocity over the last step, if it was motion.
    last_mean: Option<(Vec3A, Vec3A)>,
}

impl FrameTracker {
    /// The frame is at `pose` at the end of a step of `dt` seconds: its motion over the step.
    /// With `teleport`, a pose change past its thresholds is a jump; a non-finite or
    /// non-positive `dt` is treated as no time passing (the frame is at rest).
    pub fn step(&mut self, pose: RigidPose, dt: f32, teleport: Option<&Teleport>) -> FrameStep {
        let (step, mean) = match self.last {
            None => (FrameStep::at_rest(pose), None),
            Some(_) if !(dt > 0.0 && dt.is_finite()) => (FrameStep::at_rest(pose), None),
            Some(last) => {
                let start = last.end;
                if teleport.is_some_and(|t| t.is_jump(&start, &pose)) {
                    // The motion goes on in the frame's new heading: the velocities of the
                    // step before, turned as the frame turned, over the whole step.
                    let turn = (pose.rotation * start.rotation.inverse()).normalize();
                    let linear = turn * last.linear_velocity;
                    let angular = turn * last.angular_velocity;
                    let sweep_start = RigidPose {
                        translation: pose.translation - linear * dt,
                        rotation: (Quat::from_scaled_axis((-angular * dt).into()) * pose.rotation)
                            .normalize(),
                    };
                    let jump = FrameStep {
                        start,
                        end: pose,
                        linear_velocity: linear,
                        angular_velocity: angular,
                        jumped: true,
                        sweep_start,
                    };
                    (jump, None)
                } else {
                    // The mean velocity over this step is the velocity half a step ago; with
                    // the one of the step before, the velocity now to second order:
                    // v(t) = 3/2 v(t - dt/2) - 1/2 v(t - 3 dt/2).
                    let (linear, angular) = start.velocity_to(&pose, dt);
                    let (linear_velocity, angular_velocity) = match self.last_mean {
                        Some((l, a)) => (1.5 * linear - 0.5 * l, 1.5 * angular - 0.5 * a),
                        None => (linear, angular),
                    };
                    let motion = FrameStep {
                        start,
                        end: pose,
                        linear_velocity,
                        angular_velocity,
                        jumped: false,
                        sweep_start: start,
                    };
                    (motion, Some((linear, angular)))
                }
            }
        };
        self.last = Some(step);
        self.last_mean = mean;
        step
    }

    /// Forgets the frame: the next step starts at rest.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// The frame could not be seen this step (its transform not finite): where it was last
    /// seen is kept, at rest, so its return is a motion from there (a jump past the teleport
    /// thresholds, which carries what follows it along) and not a new start.
    pub fn lose_sight(&mut self) {
        if let Some(last) = self.last {
            self.last = Some(FrameStep::at_rest(last.end));
        }
        self.last_mean = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn pose(x: f32, yaw: f32) -> RigidPose {
        RigidPose {
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
        assert_eq!(jump.start, walk.end);
        assert_eq!(jump.linear_velocity, walk.linear_velocity);
        // It reappears a step's motion short of its end.
        let reappeared = jump.end.translation - jump.linear_velocity * dt;
        assert!(jump.sweep_start.translation.distance(reappeared) < 1e-5);
        // Without a threshold the same change is motion.
        let mut free = FrameTracker::default();
        free.step(pose(0.12, 0.05), dt, None);
        let fast = free.step(pose(10.12, 0.05), dt, None);
        assert!(!fast.jumped && (fast.linear_velocity.x - 100.0).abs() < 1e-3);
        // A turn past 60 degrees is a jump too.
        let turned = tracker.step(pose(10.12, 0.05 + 1.2), dt, Some(&teleport));
        assert!(turned.jumped);
        // Its kept velocity turned with it.
        let expected = Quat::from_rotation_y(1.2) * walk.linear_velocity;
        assert!(
            turned.linear_velocity.distance(expected) < 1e-4,
            "{turned:?}"
        );
    }

    #[test]
    fn a_frame_lost_from_sight_returns_from_where_it_was_last_seen() {
        let teleport = Teleport::default();
        let dt = 0.1;
        let mut tracker = FrameTracker::default();
        tracker.step(pose(0.0, 0.0), dt, Some(&teleport));
        let walked = tracker.step(pose(0.12, 0.0), dt, Some(&teleport));
        tracker.lose_sight();
        tracker.lose_sight();
        // Back far away: a jump from the last pose seen, carrying what follows it along.
        let mut far = tracker;
        let back = far.step(pose(50.0, 0.0), dt, Some(&teleport));
        assert!(back.jumped);
        assert_eq!(back.start, walked.end);
        // Back nearby: a motion from there, its velocity from this step alone.
        let near = tracker.step(pose(0.22, 0.0), dt, Some(&teleport));
        assert!(!near.jumped && near.start == walked.end);
        assert!((near.linear_velocity.x - 1.0).abs() < 1e-4, "{near:?}");
        // Never seen: lost is a fresh start.
        let mut never = FrameTracker::default();
        never.lose_sight();
        assert_eq!(never, FrameTracker::default());
    }

    /// A smooth random motion: a circle with a wobble, turning about a tilted axis at a
    /// varying rate; its pose and exact velocities at `t`.
    fn smooth_motion(seed: u32, t: f32) -> (RigidPose, Vec3A, Vec3A) {
        let mut rng = Rng(seed.into());
        let mut next = || rng.uniform();
        let (r, w, bob, spin, accel) = (
            0.5 + 2.0 * next(),
            0.3 + 2.0 * next(),
            0.2 * next(),
            -3.0 + 6.0 * next(),
            -2.0 + 4.0 * next(),
        );
        let axis = Vec3A::new(0.3 * next(), 1.0, 0.3 * next()).normalize();
        let translation = Vec3A::new(
            r * (w * t).cos(),
            bob * (3.0 * w * t).sin(),
            r * (w * t).sin(),
        );
        let velocity = Vec3A::new(
            -r * w * (w * t).sin(),
            3.0 * w * bob * (3.0 * w * t).cos(),
            r * w * (w * t).cos(),
        );
        let angle = spin * t + 0.5 * accel * t * t;
        let rotation = Quat::from_axis_angle(axis.into(), angle);
        (
            RigidPose {
                translation,
                rotation,
            },
            velocity,
            axis * (spin + accel * t),
        )
    }

    #[test]
    fn the_velocity_is_the_rate_at_the_end_of_the_step_to_second_order() {
        for seed in 0..20 {
            let worst = |dt: f32| {
                let mut tracker = FrameTracker::default();
                let mut worst = 0.0f32;
                let steps = (1.0 / dt) as u32;
                for n in 0..steps {
                    let t = n as f32 * dt;
                    let (pose, v, w) = smooth_motion(seed, t);
                    let step = tracker.step(pose, dt, Some(&Teleport::default()));
                    if n >= 2 {
                        worst = worst
                            .max((step.linear_velocity - v).length() / v.length())
                            .max((step.angular_velocity - w).length() / w.length().max(0.5));
                    }
                }
                worst
            };
            let at_60_hz = worst(1.0 / 60.0);
            assert!(at_60_hz < 0.01, "seed {seed}: {at_60_hz}");
            // Second order: half the step, a quarter of the error (at steps long enough for
            // the error to stand above f32's rounding).
            let (coarse, fine) = (worst(1.0 / 8.0), worst(1.0 / 16.0));
            assert!(fine < 0.35 * coarse, "seed {seed}: {coarse} then {fine}");
        }
    }

    #[test]
    fn the_whole_carry_maps_start_onto_end_and_none_is_the_identity() {
        let step = FrameStep {
            start: pose(1.0, 0.3),
            end: RigidPose {
                translation: Vec3A::new(2.0, 0.5, -1.0),
                rotation: Quat::from_rotation_y(1.1) * Quat::from_rotation_x(0.2),
            },
            linear_velocity: Vec3A::ZERO,
            angular_velocity: Vec3A::ZERO,
            jumped: true,
            sweep_start: pose(1.5, 0.7),
        };
        let jump = step.jump_carry().pose(&step.start);
        assert!(jump.translation.distance(step.sweep_start.translation) < 1e-5);
        assert!(jump.rotation.angle_between(step.sweep_start.rotation) < 1e-3);
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
