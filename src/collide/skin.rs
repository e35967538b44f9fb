//! A drawn cloth kept outside its colliders.
//!
//! The solver keeps particles at the contact distance (`margin + thickness`) from a collider,
//! but the surface drawn between them is not: a coarse simulation mesh's chord between two
//! particles 8 cm apart on a 6 cm capsule sags 1.5 cm into it, and a finer render mesh
//! embedded in the simulated one (`cloth/embedding.rs`) follows that chord. A body drawn as its
//! proxies then shows through the cloth. The plugin draws every point (particle or render
//! vertex) through [`DrawnColliders::push_out`]: a point closer to a collider, at its pose as
//! drawn, than the contact distance moves out to it along the surface normal. Only drawing
//! changes; the simulation does not.

use bevy::math::Vec3A;

use super::motion::FrameStep;
use super::pose::RigidPose;
use super::shapes::SolverCollider;
use super::trimesh::Aabb;

/// How far beyond its particles a drawn cloth's points may lie (a render mesh's offsets from
/// the simulated surface and its curved triangles' bulge), metres.
const DRAWN_BOUNDS_MARGIN: f32 = 0.1;

/// A collider near a drawn cloth.
#[derive(Clone, Copy, Debug)]
struct Near {
    /// Its index among the cloth's colliders.
    index: u32,
    /// Its pose as drawn.
    pose: RigidPose,
    /// The contact distance (its margin plus the cloth's thickness).
    reach: f32,
    /// A sphere round it grown by `reach` (the centre, world, and the radius squared; an
    /// infinite radius for a plane): points outside it are left alone at once.
    centre: Vec3A,
    radius_squared: f32,
}

/// The colliders near a drawn cloth, at their drawn poses, and how far out each keeps it.
#[derive(Clone, Debug, Default)]
pub(crate) struct DrawnColliders {
    near: Vec<Near>,
}

impl DrawnColliders {
    /// Prepares to draw a cloth whose particles are drawn at `particles` (world): the
    /// colliders at `poses` (one per collider) whose shape comes within the contact distance
    /// (`margin + thickness`) of the particles' bounds grown by [`DRAWN_BOUNDS_MARGIN`].
    pub(crate) fn prepare(
        &mut self,
        colliders: &[SolverCollider],
        poses: &[RigidPose],
        thickness: f32,
        particles: &[Vec3A],
    ) {
        self.near.clear();
        let bounds = particles
            .iter()
            .filter(|p| p.is_finite())
            .fold(Aabb::EMPTY, |b, &p| b.grown(p));
        let bounds = Aabb {
            min: bounds.min - Vec3A::splat(DRAWN_BOUNDS_MARGIN),
            max: bounds.max + Vec3A::splat(DRAWN_BOUNDS_MARGIN),
        };
        for (k, (collider, pose)) in colliders.iter().zip(poses).enumerate() {
            let reach = collider.margin + thickness;
            if !(reach.is_finite() && pose.translation.is_finite() && pose.rotation.is_finite()) {
                continue;
            }
            let (centre, radius_squared) = match collider.shape.bounding_sphere(pose, reach) {
                None => (pose.translation, f32::INFINITY),
                Some((centre, radius)) => (centre, radius * radius),
            };
            if bounds.distance_squared(centre) <= radius_squared {
                self.near.push(Near {
                    index: k as u32,
                    pose: *pose,
                    reach,
                    centre,
                    radius_squared,
                });
            }
        }
    }

    /// `p` (world) moved out of every prepared collider to its contact distance, along the
    /// surface normal; `p` itself if it is outside them all, not finite, or the move would
    /// not be finite.
    pub(crate) fn push_out(&self, colliders: &[SolverCollider], mut p: Vec3A) -> Vec3A {
        if !p.is_finite() {
            return p;
        }
        for near in &self.near {
            if p.distance_squared(near.centre) > near.radius_squared {
                continue;
            }
            let Some(collider) = colliders.get(near.index as usize) else {
                continue;
            };
            let (pose, reach) = (near.pose, near.reach);
            let local = pose.inverse_transform_point(p);
            if let Some((d, n)) = collider.shape.signed_distance(local, reach)
                && d < reach
            {
                let moved = p + pose.rotation * n * (reach - d);
                if moved.is_finite() {
                    p = moved;
                }
            }
        }
        p
    }
}

/// The colliders' poses as drawn, into `out` (one per collider): a fraction `alpha` through
/// the last fixed step in the world, or, for a cloth drawn in a followed frame (`frame`: the
/// frame's step and its pose as drawn now), interpolated in that frame and carried with it,
/// as the plugin draws the particles.
pub(crate) fn drawn_poses(
    colliders: &[SolverCollider],
    alpha: f32,
    frame: Option<(&FrameStep, &RigidPose)>,
    out: &mut Vec<RigidPose>,
) {
    out.clear();
    out.extend(colliders.iter().map(|c| {
        match frame {
            None => c.pose_at(alpha),
            Some((step, drawn)) => drawn.then(
                &c.start
                    .relative_to(&step.start)
                    .interpolate(&c.end.relative_to(&step.end), alpha),
            ),
        }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::SolverShape;
    use bevy::math::Quat;

    use crate::rng::Rng;

    /// A random vector in the cube of half side `scale`.
    fn vec(rng: &mut Rng, scale: f32) -> Vec3A {
        Vec3A::new(
            rng.range(-scale, scale),
            rng.range(-scale, scale),
            rng.range(-scale, scale),
        )
    }

    fn random_colliders(rng: &mut Rng) -> Vec<SolverCollider> {
        (0..4)
            .map(|k| {
                let shape = if k % 2 == 0 {
                    SolverShape::Capsule {
                        radius: 0.03 + 0.1 * rng.uniform(),
                        half_length: 0.2 * rng.uniform(),
                    }
                } else {
                    SolverShape::Sphere {
                        radius: 0.05 + 0.1 * rng.uniform(),
                    }
                };
                let pose = RigidPose {
                    translation: vec(rng, 0.3),
                    rotation: Quat::from_scaled_axis(vec(rng, 3.0).into()),
                };
                let mut c = SolverCollider::fixed(shape, pose);
                c.margin = 0.01 * rng.uniform();
                c
            })
            .collect()
    }

    /// Random points round random capsules and spheres: every point pushed out ends at least
    /// the contact distance from every collider (to round-off, and unless two colliders
    /// overlap, where the last one wins), a point already that far is not moved, and a
    /// non-finite point is returned as it came.
    #[test]
    fn pushed_points_end_outside_every_collider_and_the_others_do_not_move() {
        let mut rng = Rng(0x853c_49e6_748f_ea9b);
        let thickness = 0.005;
        let (mut moved, mut kept) = (0, 0);
        for _ in 0..50 {
            let colliders = random_colliders(&mut rng);
            let poses: Vec<RigidPose> = colliders.iter().map(|c| c.end).collect();
            let mut skin = DrawnColliders::default();
            let corners = [Vec3A::splat(-1.0), Vec3A::splat(1.0)];
            skin.prepare(&colliders, &poses, thickness, &corners);
            for _ in 0..200 {
                let p = vec(&mut rng, 0.5);
                let q = skin.push_out(&colliders, p);
                let distance = |c: &SolverCollider, x: Vec3A| {
                    c.signed_distance(x, 10.0).unwrap() - c.margin - thickness
                };
                let was_outside = colliders.iter().all(|c| distance(c, p) >= 0.0);
                if was_outside {
                    assert_eq!(q, p);
                    kept += 1;
                    continue;
                }
                moved += 1;
                // Only the last collider that moved it is sure to be cleared when colliders
                // overlap; apart, all are.
                let inside: Vec<f32> = colliders
                    .iter()
                    .map(|c| distance(c, q))
                    .filter(|&d| d < -1e-5)
                    .collect();
                let overlapping = colliders.iter().enumerate().any(|(i, a)| {
                    colliders[i + 1..].iter().any(|b| {
                        a.end.translation.distance(b.end.translation)
                            < bound_radius(a) + bound_radius(b) + 2.0 * thickness
                    })
                });
                assert!(inside.is_empty() || overlapping, "{p} -> {q}: {inside:?}");
            }
            let nan = Vec3A::new(f32::NAN, 0.0, 0.0);
            assert!(skin.push_out(&colliders, nan).x.is_nan());
        }
        assert!(moved > 100 && kept > 100, "{moved} moved, {kept} kept");
    }

    fn bound_radius(c: &SolverCollider) -> f32 {
        c.shape.bounding_sphere(&c.end, c.margin).unwrap().1
    }

    /// A collider far from the cloth's bounds is left out; a plane never is.
    #[test]
    fn only_colliders_near_the_bounds_are_prepared() {
        let far = SolverCollider::fixed(
            SolverShape::Sphere { radius: 0.1 },
            RigidPose {
                translation: Vec3A::new(5.0, 0.0, 0.0),
                rotation: Quat::IDENTITY,
            },
        );
        let ground = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
        let colliders = [far, ground];
        let poses = [colliders[0].end, colliders[1].end];
        let mut skin = DrawnColliders::default();
        let corners = [Vec3A::splat(-1.0), Vec3A::splat(1.0)];
        skin.prepare(&colliders, &poses, 0.01, &corners);
        assert_eq!(skin.near.len(), 1);
        assert_eq!(skin.near[0].index, 1);
        // A point under the ground comes up to the contact distance.
        let q = skin.push_out(&colliders, Vec3A::new(0.2, -0.3, 0.1));
        assert!((q - Vec3A::new(0.2, 0.01, 0.1)).length() < 1e-6, "{q}");
    }

    /// Drawn in a followed frame, a collider that moved with the frame is drawn where the
    /// frame is drawn; in the world, `alpha` of the way through the step.
    #[test]
    fn drawn_poses_follow_the_frame_or_interpolate_in_the_world() {
        let start = RigidPose::IDENTITY;
        let end = RigidPose {
            translation: Vec3A::new(1.0, 0.0, 0.0),
            rotation: Quat::from_rotation_y(0.5),
        };
        let offset = RigidPose {
            translation: Vec3A::new(0.0, 1.0, 0.2),
            rotation: Quat::from_rotation_x(0.3),
        };
        let mut c = SolverCollider::fixed(SolverShape::Sphere { radius: 0.1 }, start.then(&offset));
        c.end = end.then(&offset);
        let mut out = Vec::new();
        drawn_poses(std::slice::from_ref(&c), 0.5, None, &mut out);
        assert_eq!(out[0], c.start.interpolate(&c.end, 0.5));
        let step = FrameStep {
            start,
            end,
            linear_velocity: Vec3A::ZERO,
            angular_velocity: Vec3A::ZERO,
            jumped: false,
            sweep_start: start,
        };
        let drawn = RigidPose {
            translation: Vec3A::new(3.0, 0.0, -1.0),
            rotation: Quat::from_rotation_z(1.0),
        };
        drawn_poses(
            std::slice::from_ref(&c),
            0.3,
            Some((&step, &drawn)),
            &mut out,
        );
        let expected = drawn.then(&offset);
        assert!(out[0].translation.distance(expected.translation) < 1e-5);
        assert!(out[0].rotation.angle_between(expected.rotation) < 1e-3);
    }
}
