//! Ray picking of particles, and the plane a picked particle is dragged in.

use bevy::math::primitives::InfinitePlane3d;
use bevy::math::{Dir3, Ray3d, Vec3, Vec3A};

/// A particle hit by a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleHit {
    /// The particle.
    pub particle: u32,
    /// Its distance along the ray from the origin, metres.
    pub depth: f32,
    /// Its distance from the ray, metres.
    pub miss: f32,
}

/// The particle closest to the ray from `origin` along `direction` (any length) among those
/// within `radius` of it and in front of the origin; the nearest along the ray breaks ties
/// between particles about equally close to it (within a tenth of `radius`). `None` if the ray
/// passes no particle that closely, or the ray is degenerate.
pub fn pick_particle(
    positions: &[Vec3A],
    origin: Vec3,
    direction: Vec3,
    radius: f32,
) -> Option<ParticleHit> {
    let dir = Vec3A::from(direction.try_normalize()?);
    let origin = Vec3A::from(origin);
    if !(origin.is_finite() && radius.is_finite() && radius > 0.0) {
        return None;
    }
    let mut best: Option<ParticleHit> = None;
    for (i, &p) in positions.iter().enumerate() {
        let d = p - origin;
        let depth = d.dot(dir);
        if depth <= 0.0 {
            continue;
        }
        let miss = (d - dir * depth).length();
        if miss > radius {
            continue;
        }
        let better = match best {
            None => true,
            Some(b) => {
                if (miss - b.miss).abs() <= 0.1 * radius {
                    depth < b.depth
                } else {
                    miss < b.miss
                }
            }
        };
        if better {
            best = Some(ParticleHit {
                particle: i as u32,
                depth,
                miss,
            });
        }
    }
    best
}

/// Where a drag takes the particle held: the point where the ray from `origin` along
/// `direction` meets the drag plane, the plane through `anchor` (where the particle was
/// grabbed) facing `view` (the camera's forward direction), so the particle follows the
/// cursor at the depth it was grabbed at. `None` for a ray along the plane, one pointing away
/// from it, or non-finite input.
pub fn drag_point(origin: Vec3, direction: Vec3, anchor: Vec3, view: Vec3) -> Option<Vec3> {
    let ray = Ray3d::new(origin, Dir3::new(direction).ok()?);
    let plane = InfinitePlane3d {
        normal: Dir3::new(view).ok()?,
    };
    ray.plane_intersection_point(anchor, plane)
        .filter(|p| p.is_finite())
}
