//! Collider shapes and the per-step view of a collider the solvers use.

use bevy::reflect::Reflect;
use std::sync::Arc;

use bevy::math::{Quat, Vec3A};

use super::pose::RigidPose;
use super::trimesh::{Aabb, TriMesh, mesh_distance};
use crate::error::ColliderError;

/// The largest coordinate the solvers take, metres (and the largest collider speed, m/s and
/// rad/s): 1e6, where `f32` still resolves 6 cm. A pin target or collider beyond it is
/// refused, so that no distance's square overflows.
pub const MAX_COORDINATE: f32 = 1.0e6;

/// The geometry of a collider, in its local frame.
#[derive(Clone, Debug, PartialEq)]
pub enum SolverShape {
    /// A ball of `radius` about the origin.
    Sphere {
        /// Radius, metres.
        radius: f32,
    },
    /// The points within `radius` of the segment from `(0, -half_length, 0)` to
    /// `(0, half_length, 0)`.
    Capsule {
        /// Radius, metres.
        radius: f32,
        /// Half the length of the axis segment (local Y), metres.
        half_length: f32,
    },
    /// The half-space `y <= 0`; the surface is the local XZ plane, the normal local +Y.
    Plane,
    /// A triangle mesh. Closed (watertight), it has an inside: the back of its triangles
    /// (counter-clockwise is the front). Open (a scan with holes, a sheet), it has none: the
    /// cloth is kept on whichever side of it it came from. See [`TriMesh`].
    TriangleMesh(Arc<TriMesh>),
}

impl SolverShape {
    /// Checks the dimensions.
    pub fn validate(&self) -> Result<(), ColliderError> {
        let positive = |name, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ColliderError::InvalidDimension { name, value: v })
            }
        };
        match self {
            SolverShape::Sphere { radius } => positive("radius", *radius),
            SolverShape::Capsule {
                radius,
                half_length,
            } => {
                positive("radius", *radius)?;
                if half_length.is_finite() && *half_length >= 0.0 {
                    Ok(())
                } else {
                    Err(ColliderError::InvalidDimension {
                        name: "half_length",
                        value: *half_length,
                    })
                }
            }
            SolverShape::Plane | SolverShape::TriangleMesh(_) => Ok(()),
        }
    }

    /// The signed distance of the local point `p` to the surface (negative inside) and the
    /// unit outward normal at the closest surface point, if `p` is within `reach` of the
    /// surface or inside. A closed triangle mesh counts a point as inside when it is behind
    /// the pseudo-normal of the closest feature, up to `reach` deep; an open one never does
    /// (the distance is then unsigned and the normal points from the surface to `p`).
    #[inline]
    pub fn signed_distance(&self, p: Vec3A, reach: f32) -> Option<(f32, Vec3A)> {
        match self {
            SolverShape::Sphere { radius } => sphere_distance(p, *radius, reach),
            SolverShape::Capsule {
                radius,
                half_length,
            } => {
                let axis_point = Vec3A::new(0.0, p.y.clamp(-half_length, *half_length), 0.0);
                sphere_distance(p - axis_point, *radius, reach)
            }
            SolverShape::Plane => (p.y < reach).then_some((p.y, Vec3A::Y)),
            SolverShape::TriangleMesh(mesh) => mesh.signed_distance(p, reach),
        }
    }

    /// As [`SolverShape::signed_distance`] for a point that moved from `from` to `p` (both
    /// local): where the move crossed a triangle of a mesh (entering a closed mesh, or either
    /// way through an open one), the distance of `p` to that triangle's plane, negative, with
    /// the normal turned to the side it came from, so that the point is put back there, what
    /// the closest triangle says. Other shapes ignore `from`.
    #[inline]
    pub(crate) fn swept_signed_distance(
        &self,
        from: Vec3A,
        p: Vec3A,
        reach: f32,
    ) -> Option<(f32, Vec3A)> {
        let SolverShape::TriangleMesh(mesh) = self else {
            return self.signed_distance(p, reach);
        };
        // Every point of the move is within `motion` of `p`: a surface farther away than that
        // cannot have been crossed, and the crossing test is left out (a resting particle).
        let motion = p.distance(from);
        let closest = mesh.closest_point(p, reach.max(motion))?;
        if closest.distance <= motion
            && let Some(crossing) = mesh.first_crossing(from, p, mesh.is_closed())
        {
            let d = (p - crossing.plane_point).dot(crossing.normal);
            return Some((d.min(0.0), crossing.normal));
        }
        let (d, n) = mesh_distance(mesh, p, &closest);
        (d < reach).then_some((d, n))
    }

    /// The sphere round the local bounds at `pose`, grown by `reach`: its centre (world) and
    /// radius; `None` for the (infinite) plane.
    pub(crate) fn bounding_sphere(&self, pose: &RigidPose, reach: f32) -> Option<(Vec3A, f32)> {
        let local = self.local_bounds()?;
        Some((
            pose.transform_point((local.min + local.max) * 0.5),
            (local.max - local.min).length() * 0.5 + reach,
        ))
    }

    /// The local bounds, `None` for the (infinite) plane.
    pub(crate) fn local_bounds(&self) -> Option<Aabb> {
        match self {
            SolverShape::Sphere { radius } => Some(Aabb {
                min: Vec3A::splat(-radius),
                max: Vec3A::splat(*radius),
            }),
            SolverShape::Capsule {
                radius,
                half_length,
            } => Some(Aabb {
                min: -Vec3A::new(*radius, radius + half_length, *radius),
                max: Vec3A::new(*radius, radius + half_length, *radius),
            }),
            SolverShape::Plane => None,
            SolverShape::TriangleMesh(mesh) => Some(mesh.bounds()),
        }
    }
}

#[inline(always)]
fn sphere_distance(d: Vec3A, radius: f32, reach: f32) -> Option<(f32, Vec3A)> {
    let len_sq = d.length_squared();
    let limit = radius + reach;
    if len_sq >= limit * limit {
        return None;
    }
    let len = len_sq.sqrt();
    let n = if len > 1e-9 { d / len } else { Vec3A::Y };
    Some((len - radius, n))
}

/// Friction and restitution of a contact.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct ContactMaterial {
    /// Coulomb friction coefficient `mu`. Default: `0.5`.
    pub friction: f32,
    /// Restitution `epsilon` in [0, 1]: the fraction of the approaching normal velocity
    /// returned. Default: `0.0` (cloth does not bounce).
    pub restitution: f32,
}

impl Default for ContactMaterial {
    fn default() -> Self {
        Self {
            friction: 0.5,
            restitution: 0.0,
        }
    }
}

impl ContactMaterial {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), ColliderError> {
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(ColliderError::InvalidDimension {
                name: "friction",
                value: self.friction,
            });
        }
        if !(0.0..=1.0).contains(&self.restitution) {
            return Err(ColliderError::InvalidDimension {
                name: "restitution",
                value: self.restitution,
            });
        }
        Ok(())
    }
}

/// A collider as the solver sees it over one fixed step: its shape, its material, and its
/// motion from `start` to `end` with the velocity used for contacts.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverCollider {
    /// The geometry.
    pub shape: SolverShape,
    /// Friction and restitution.
    pub material: ContactMaterial,
    /// Particles are kept this far outside the surface, on top of the cloth's thickness,
    /// metres.
    pub margin: f32,
    /// The pose at the start of the step.
    pub start: RigidPose,
    /// The pose at the end of the step.
    pub end: RigidPose,
    /// Linear velocity of the local origin, m/s (world frame).
    pub linear_velocity: Vec3A,
    /// Angular velocity, rad/s (world frame).
    pub angular_velocity: Vec3A,
}

impl SolverCollider {
    /// A collider at rest at `pose`.
    pub fn fixed(shape: SolverShape, pose: RigidPose) -> Self {
        Self {
            shape,
            material: ContactMaterial::default(),
            margin: 0.0,
            start: pose,
            end: pose,
            linear_velocity: Vec3A::ZERO,
            angular_velocity: Vec3A::ZERO,
        }
    }

    /// A fixed plane through `point` with unit normal `normal` (particles stay on its side):
    /// the ground or a wall.
    pub fn plane(point: Vec3A, normal: Vec3A, material: ContactMaterial) -> Self {
        let normal = normal.normalize_or(Vec3A::Y);
        Self {
            material,
            ..Self::fixed(
                SolverShape::Plane,
                RigidPose {
                    translation: point,
                    rotation: Quat::from_rotation_arc(Vec3A::Y.into(), normal.into()),
                },
            )
        }
    }

    /// The ground: particles stay at `y >= height`.
    pub fn ground(height: f32, material: ContactMaterial) -> Self {
        Self::plane(Vec3A::new(0.0, height, 0.0), Vec3A::Y, material)
    }

    /// The six inward-facing walls of the axis-aligned box from `min` to `max`.
    pub fn box_walls(min: Vec3A, max: Vec3A, material: ContactMaterial) -> [Self; 6] {
        [
            Self::plane(min, Vec3A::X, material),
            Self::plane(max, -Vec3A::X, material),
            Self::plane(min, Vec3A::Y, material),
            Self::plane(max, -Vec3A::Y, material),
            Self::plane(min, Vec3A::Z, material),
            Self::plane(max, -Vec3A::Z, material),
        ]
    }

    /// For a sphere or a capsule, how far any point of its core (the centre, the axis
    /// segment) can be at a pose of the step ([`Self::pose_at`]: translation interpolated,
    /// rotation slerped) from where it is at the start: the origin's move plus the segment
    /// end's swing, `2 sin(theta / 2)` of the half length for a turn by `theta`. `None` for
    /// the other shapes.
    pub(crate) fn core_motion(&self) -> Option<f32> {
        let half_length = match self.shape {
            SolverShape::Sphere { .. } => 0.0,
            SolverShape::Capsule { half_length, .. } => half_length,
            SolverShape::Plane | SolverShape::TriangleMesh(_) => return None,
        };
        let turn = self.end.rotation * self.start.rotation.inverse();
        let swing = 2.0 * turn.xyz().length();
        Some(self.start.translation.distance(self.end.translation) + half_length * swing)
    }

    /// The pose a fraction `t` in [0, 1] through the step.
    #[inline]
    pub(crate) fn pose_at(&self, t: f32) -> RigidPose {
        if t >= 1.0 {
            self.end
        } else {
            self.start.interpolate(&self.end, t)
        }
    }

    /// The velocity of the collider's material point at world position `point` when the
    /// collider is at `pose`: `v + omega x (point - origin)`.
    #[inline]
    pub(crate) fn velocity_at(&self, pose: &RigidPose, point: Vec3A) -> Vec3A {
        self.linear_velocity + self.angular_velocity.cross(point - pose.translation)
    }

    /// World bounds over the whole step, grown by `reach`; `None` for a plane.
    pub(crate) fn swept_bounds(&self, reach: f32) -> Option<Aabb> {
        // The bounding sphere at both ends of the step: rotation-proof.
        let mut bounds = Aabb::EMPTY;
        for pose in [self.start, self.end] {
            let (c, radius) = self.shape.bounding_sphere(&pose, reach)?;
            bounds = bounds.union(Aabb {
                min: c - Vec3A::splat(radius),
                max: c + Vec3A::splat(radius),
            });
        }
        Some(bounds)
    }

    /// The signed distance of the world point `p` to the surface at the end of the step (see
    /// [`SolverShape::signed_distance`]).
    pub fn signed_distance(&self, p: Vec3A, reach: f32) -> Option<f32> {
        let local = self.end.inverse_transform_point(p);
        self.shape.signed_distance(local, reach).map(|(d, _)| d)
    }

    /// Checks the shape, the material, the margin and the poses.
    pub fn validate(&self) -> Result<(), ColliderError> {
        self.shape.validate()?;
        self.material.validate()?;
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(ColliderError::InvalidDimension {
                name: "margin",
                value: self.margin,
            });
        }
        if !(self.start.is_valid()
            && self.end.is_valid()
            && self.linear_velocity.is_finite()
            && self.angular_velocity.is_finite())
        {
            return Err(ColliderError::NonFinitePose);
        }
        // Finite but extreme: the contact distances' squares would overflow.
        let far = |p: &RigidPose| p.translation.abs().max_element() > MAX_COORDINATE;
        if far(&self.start)
            || far(&self.end)
            || self.linear_velocity.abs().max_element() > MAX_COORDINATE
            || self.angular_velocity.abs().max_element() > MAX_COORDINATE
        {
            return Err(ColliderError::PoseOutOfRange);
        }
        Ok(())
    }
}
