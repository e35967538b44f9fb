//! A rigid pose (rotation, then translation): where a collider, a bone or a followed frame is.

use bevy::math::{Quat, Vec3A};

/// A rigid pose: rotation, then translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidPose {
    /// Position of the local origin, metres.
    pub translation: Vec3A,
    /// Orientation (unit quaternion).
    pub rotation: Quat,
}

impl RigidPose {
    /// The identity pose.
    pub const IDENTITY: Self = Self {
        translation: Vec3A::ZERO,
        rotation: Quat::IDENTITY,
    };

    /// A local point in the world.
    #[inline(always)]
    pub fn transform_point(&self, p: Vec3A) -> Vec3A {
        self.translation + self.rotation * p
    }

    /// A world point in the local frame.
    #[inline(always)]
    pub fn inverse_transform_point(&self, p: Vec3A) -> Vec3A {
        self.rotation.inverse() * (p - self.translation)
    }

    /// A pose given in this pose's frame, in the world: `self * local`.
    pub(crate) fn then(&self, local: &Self) -> Self {
        Self {
            translation: self.transform_point(local.translation),
            rotation: (self.rotation * local.rotation).normalize(),
        }
    }

    /// This pose seen from `frame`: `frame^-1 * self`.
    pub(crate) fn relative_to(&self, frame: &Self) -> Self {
        Self {
            translation: frame.inverse_transform_point(self.translation),
            rotation: (frame.rotation.inverse() * self.rotation).normalize(),
        }
    }

    /// The pose a fraction `t` of the way to `to`: translation lerped, rotation slerped.
    pub(crate) fn interpolate(&self, to: &Self, t: f32) -> Self {
        Self {
            translation: self.translation.lerp(to.translation, t),
            rotation: self.rotation.slerp(to.rotation, t),
        }
    }

    /// The constant linear and angular velocity (world frame) that carries this pose to `to`
    /// in `dt` seconds; zero for `dt <= 0`.
    pub(crate) fn velocity_to(&self, to: &Self, dt: f32) -> (Vec3A, Vec3A) {
        if dt.is_nan() || dt <= 0.0 {
            return (Vec3A::ZERO, Vec3A::ZERO);
        }
        let turn = to.rotation * self.rotation.inverse();
        // The short way round: q and -q are the same rotation.
        let turn = if turn.w < 0.0 { -turn } else { turn };
        (
            (to.translation - self.translation) / dt,
            Vec3A::from(turn.to_scaled_axis()) / dt,
        )
    }

    /// Whether the translation and rotation are finite and the rotation is a unit quaternion.
    pub(crate) fn is_valid(&self) -> bool {
        self.translation.is_finite() && self.rotation.is_finite() && self.rotation.is_normalized()
    }
}
