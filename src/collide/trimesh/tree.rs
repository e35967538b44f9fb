//! The boxes and the nodes of a [`TriMesh`](super::TriMesh)'s bounding-volume hierarchy.

use bevy::math::Vec3A;

use crate::collide::pose::RigidPose;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Aabb {
    /// Lower corner.
    pub min: Vec3A,
    /// Upper corner.
    pub max: Vec3A,
}

impl Aabb {
    /// The empty box (contains nothing; growing it by a point gives that point).
    pub(crate) const EMPTY: Self = Self {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    /// The box grown to contain `p`.
    pub(crate) fn grown(self, p: Vec3A) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The union of two boxes.
    pub(crate) fn union(self, other: Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The box grown by `by` on every side.
    pub(crate) fn padded(self, by: f32) -> Self {
        Self {
            min: self.min - Vec3A::splat(by),
            max: self.max + Vec3A::splat(by),
        }
    }

    /// The box holding this (world) box's corners seen from each of `poses`: in their frames.
    pub(crate) fn in_frames(&self, poses: &[RigidPose]) -> Self {
        let mut out = Self::EMPTY;
        for corner in 0..8 {
            let p = Vec3A::new(
                if corner & 1 == 0 {
                    self.min.x
                } else {
                    self.max.x
                },
                if corner & 2 == 0 {
                    self.min.y
                } else {
                    self.max.y
                },
                if corner & 4 == 0 {
                    self.min.z
                } else {
                    self.max.z
                },
            );
            for pose in poses {
                out = out.grown(pose.inverse_transform_point(p));
            }
        }
        out
    }

    /// Whether `p` is inside (boundary included).
    #[inline(always)]
    pub(crate) fn contains(&self, p: Vec3A) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Whether the two boxes share a point.
    #[inline(always)]
    pub(crate) fn overlaps(&self, other: &Self) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline(always)]
    pub(crate) fn distance_squared(&self, p: Vec3A) -> f32 {
        let d = (self.min - p).max(p - self.max).max(Vec3A::ZERO);
        d.length_squared()
    }
}

/// A node of the hierarchy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Node {
    pub(super) bounds: Aabb,
    /// Leaf: first triangle in `order`; inner node: index of the left child (the right one
    /// follows the whole left subtree, at `right`).
    pub(super) start: u32,
    /// Leaf: triangle count; inner node: 0.
    pub(super) count: u32,
    /// Inner node: index of the right child.
    pub(super) right: u32,
}
