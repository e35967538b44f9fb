//! The cloth's edges against the rounded colliders (spheres and capsules) thin enough to pass
//! between two of its particles: a hand or a forearm that the particle contacts alone let
//! through the middle of a triangle, leaving the two ends of one edge on opposite sides of
//! the proxy and the edge stretched around it.
//!
//! A rounded collider is the set of points within `radius` of its core (the sphere's centre,
//! the capsule's axis segment). With particle contacts alone it passes through a triangle
//! whose vertices all stay out of its reach, which needs `radius` below about half the
//! triangle's longest edge (a grid's right triangles: half the diagonal). So only colliders
//! with `radius < 0.6 L` take part, `L` the longest edge at rest (20% of stretch allowed
//! for), against every edge of the triangles (a grid's diagonals included): the torso of a
//! character, wider than the cloth's triangles, costs nothing here.
//!
//! Candidates are found once per fixed step: an edge's bounds at the start of the step, grown
//! by how far its particles can move in the step, against the collider's swept bounds grown by
//! its reach. In the last solver iteration of every substep and in the closing pass (see
//! `contact.rs`), for each candidate, with the collider at the end of the substep:
//! `p = (1 - s) x_a + s x_b` the edge's point closest to the core, `c` the core's point
//! closest to it, `d = p - c`. Where the closest point lies inside the edge (`0 < s < 1`; at
//! an end, the particle contact of that end acts) and `|d| < radius + reach`, the edge moves
//! out along `n` by `depth = radius + reach - n . d`, its two particles in proportion to their
//! share of `p`: `dx_a = w_a (1 - s) depth n / (w_a (1 - s)^2 + w_b s^2)`, likewise `dx_b`
//! with `s`, so that `p` moves by exactly `depth n` and the edge keeps its length. `n` is
//! `d / |d|`, unless the edge crossed the core within the substep (`d` turned against
//! `d_prev`, the same vector from the positions and the pose at the start of the substep):
//! then `n = d_prev / |d_prev|`, and the edge goes back to the side it came from. An edge
//! already deep across the core when the substep began (`|d_prev| < radius / 2`: a teleport,
//! a cloth put on around a limb) is left to the particle contacts, which do not care which
//! side it is on. No friction acts here: the particles' own contacts carry it. An edge that
//! touched counts as the cloth touching a collider for the exact edges
//! ([`SolverSettings::exact_edges`](crate::cloth::SolverSettings::exact_edges)).
//!
//! Measured on S3 (`cargo run --release --example scenes -- s3 --motion M`, the four motions,
//! each also with the shear compliance moved by 1e-5 to 5e-5, which changes nothing but the
//! rounding: 24 runs): the largest strain of any step after the first second was above 5% in
//! 6 runs and above 2% in 12 without the edge contacts (up to 15%: the hand through the
//! poncho), in none with them (at most 1.5%), for 35% more time per step.

use bevy::math::Vec3A;

use super::contact::ContactScratch;
use super::pose::RigidPose;
use super::shapes::{SolverCollider, SolverShape};
use super::trimesh::Aabb;

/// The share of the cloth's longest edge a collider's radius must stay below to take part.
const THIN_RADIUS_SHARE: f32 = 0.6;

/// An edge that may touch a rounded collider during the step.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    collider: u32,
    /// The edge's two particles.
    particles: [u32; 2],
}

/// The cloth's edges and the candidate pairs of the current step, reused every step.
#[derive(Clone, Debug, Default)]
pub(crate) struct EdgeContacts {
    /// Every edge of the cloth's triangles.
    edges: Vec<[u32; 2]>,
    /// The radius below which a rounded collider takes part: `0.6 L`.
    thin_radius: f32,
    candidates: Vec<Candidate>,
    /// Per edge, its bounds at the start of the step grown by its motion.
    edge_bounds: Vec<Aabb>,
    /// Per edge, how far its particles can move in the step.
    edge_motion: Vec<f32>,
    /// Per collider, its core in the world at the start and the end of the current substep.
    cores: Vec<[Core; 2]>,
    /// Whether an edge touched a collider in the current substep.
    touched: bool,
}

/// A rounded collider's core in the world: the points `centre + t axis`, `t` in
/// `[-half_length, half_length]` (`axis` a unit vector), and its radius.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Core {
    centre: Vec3A,
    axis: Vec3A,
    half_length: f32,
    radius: f32,
}

impl Core {
    /// The core of `shape` at `pose`, `None` if the shape is not rounded.
    fn of(shape: &SolverShape, pose: &RigidPose) -> Option<Self> {
        let (radius, half_length) = match shape {
            SolverShape::Sphere { radius } => (*radius, 0.0),
            SolverShape::Capsule {
                radius,
                half_length,
            } => (*radius, *half_length),
            SolverShape::Plane | SolverShape::TriangleMesh(_) => return None,
        };
        Some(Self {
            centre: pose.translation,
            axis: pose.rotation * Vec3A::Y,
            half_length,
            radius,
        })
    }

    /// For the segment `a`-`b`: the parameter `s` of its point `p = a + s (b - a)` closest to
    /// the core, and `p - c`, with `c` the core's point closest to `p`.
    fn closest(&self, a: Vec3A, b: Vec3A) -> (f32, Vec3A) {
        let (a, b) = (a - self.centre, b - self.centre);
        let (s, t) = closest_parameters(a, b, self.axis, self.half_length);
        (s, a + (b - a) * s - self.axis * t)
    }
}

impl EdgeContacts {
    /// The contacts of a cloth's `edges` (every edge of its triangles).
    pub(crate) fn new(edges: Vec<[u32; 2]>, longest: f32) -> Self {
        Self {
            edge_bounds: Vec::with_capacity(edges.len()),
            edges,
            thin_radius: THIN_RADIUS_SHARE * longest,
            ..Self::default()
        }
    }

    /// Whether there are candidate pairs this step (only then is there anything to project).
    pub(crate) fn has_candidates(&self) -> bool {
        !self.candidates.is_empty()
    }

    /// Finds the candidate pairs of a step of `dt` seconds: the edges of the cloth at `x`
    /// moving at `v` under the acceleration `a`.
    pub(crate) fn begin_step(
        &mut self,
        colliders: &[SolverCollider],
        x: &[Vec3A],
        v: &[Vec3A],
        a: Vec3A,
        dt: f32,
        thickness: f32,
    ) {
        self.candidates.clear();
        self.edge_bounds.clear();
        let limit = self.thin_radius;
        let thin = |c: &SolverCollider| core_radius(&c.shape).is_some_and(|r| r < limit);
        if !colliders.iter().any(thin) {
            return;
        }
        let fall = 0.5 * a.length() * dt * dt;
        let mut cloth = Aabb::EMPTY;
        self.edge_motion.clear();
        for &[i, j] in &self.edges {
            let (xi, xj) = (x[i as usize], x[j as usize]);
            let motion = (v[i as usize].length().max(v[j as usize].length())) * dt + fall;
            let b = Aabb::EMPTY.grown(xi).grown(xj).padded(motion);
            cloth = cloth.union(b);
            self.edge_bounds.push(b);
            self.edge_motion.push(motion);
        }
        for (k, collider) in colliders.iter().enumerate() {
            if !thin(collider) {
                continue;
            }
            let reach = collider.margin + thickness;
            let Some(path) = collider.swept_bounds(reach) else {
                continue;
            };
            if !path.overlaps(&cloth) {
                continue;
            }
            let Some(core) = Core::of(&collider.shape, &collider.start) else {
                continue;
            };
            // An edge the collider's core cannot come within its radius plus the reach of in
            // this step: its distance at the start, less how far the core and the edge move.
            let core_motion = collider.core_motion().unwrap_or(f32::INFINITY);
            for ((&particles, b), &motion) in self
                .edges
                .iter()
                .zip(&self.edge_bounds)
                .zip(&self.edge_motion)
            {
                if !b.overlaps(&path) {
                    continue;
                }
                let [i, j] = particles.map(|p| x[p as usize]);
                let limit = core.radius + reach + core_motion + motion;
                if core.closest(i, j).1.length_squared() <= limit * limit {
                    self.candidates.push(Candidate {
                        collider: k as u32,
                        particles,
                    });
                }
            }
        }
    }

    /// Whether an edge touched a collider in the current substep.
    pub(crate) fn touched(&self) -> bool {
        self.touched
    }

    /// Starts a substep: the colliders' cores at the poses of the substep from `contacts`.
    pub(crate) fn begin_substep(
        &mut self,
        colliders: &[SolverCollider],
        contacts: &ContactScratch,
    ) {
        self.touched = false;
        if self.candidates.is_empty() {
            return;
        }
        let (start_poses, end_poses) = contacts.substep_poses();
        self.cores.clear();
        self.cores
            .extend(colliders.iter().zip(start_poses.iter().zip(end_poses)).map(
                |(c, (start, end))| {
                    [start, end].map(|pose| Core::of(&c.shape, pose).unwrap_or_default())
                },
            ));
    }

    /// Projects every candidate (see the [module docs](self)) to `reach` beyond the surface,
    /// with the colliders' cores of the current substep. Returns the farthest it moved a
    /// particle, metres.
    pub(crate) fn project(
        &mut self,
        colliders: &[SolverCollider],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        w: &[f32],
        reach: impl Fn(&SolverCollider) -> f32,
    ) -> f32 {
        let mut farthest = 0.0f32;
        for c in &self.candidates {
            let k = c.collider as usize;
            let [start, core] = self.cores[k];
            let radius = core.radius;
            let [a, b] = c.particles.map(|i| i as usize);
            let (wa, wb) = (w[a], w[b]);
            if wa + wb <= 0.0 {
                continue;
            }
            let limit = radius + reach(&colliders[k]);
            let (s, d) = core.closest(x[a], x[b]);
            if s <= 0.0 || s >= 1.0 || d.length_squared() >= limit * limit {
                continue;
            }
            // The same vector at the start of the substep (the collider turns little within
            // one: the two are compared in the world).
            let (_, d_prev) = start.closest(x_prev[a], x_prev[b]);
            let prev_length = d_prev.length();
            if prev_length < 0.5 * radius {
                continue;
            }
            let length = d.length();
            let n = if d.dot(d_prev) > 0.0 && length > 1e-6 * radius {
                d / length
            } else {
                d_prev / prev_length
            };
            let depth = limit - n.dot(d);
            if depth <= 0.0 {
                continue;
            }
            let (ta, tb) = (1.0 - s, s);
            let denominator = wa * ta * ta + wb * tb * tb;
            if denominator <= 0.0 {
                continue;
            }
            self.touched = true;
            let shift = n * (depth / denominator);
            x[a] += shift * (wa * ta);
            x[b] += shift * (wb * tb);
            farthest = farthest.max(shift.length() * (wa * ta).max(wb * tb));
        }
        farthest
    }
}

/// The radius of a rounded collider about its core, `None` for the other shapes.
fn core_radius(shape: &SolverShape) -> Option<f32> {
    match shape {
        SolverShape::Sphere { radius } | SolverShape::Capsule { radius, .. } => Some(*radius),
        SolverShape::Plane | SolverShape::TriangleMesh(_) => None,
    }
}

/// The parameters of the closest points of the segment `a`-`b` (`s` in `[0, 1]`) and the
/// segment of the points `t u` (`u` a unit vector, `t` in `[-h, h]`; the origin for `h = 0`),
/// as in Ericson's "Real-Time Collision Detection" (5.1.9).
fn closest_parameters(a: Vec3A, b: Vec3A, u: Vec3A, h: f32) -> (f32, f32) {
    let e = b - a;
    let ee = e.length_squared();
    let ea = e.dot(a);
    let ru = a.dot(u);
    if ee <= 1e-20 {
        return (0.0, ru.clamp(-h, h));
    }
    if h <= 0.0 {
        return ((-ea / ee).clamp(0.0, 1.0), 0.0);
    }
    let eu = e.dot(u);
    let denominator = ee - eu * eu;
    let mut s = if denominator > 1e-12 * ee {
        ((eu * ru - ea) / denominator).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = ru + eu * s;
    if t < -h || t > h {
        t = t.clamp(-h, h);
        s = ((t * eu - ea) / ee).clamp(0.0, 1.0);
    }
    (s, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// The closest parameters against a dense search along the segment (the closest point of
    /// the axis to each of its points is exact), on random segments and axes.
    #[test]
    fn closest_parameters_match_a_dense_search() {
        let mut rng = Rng(7);
        let mut random = move || rng.range(-1.0, 1.0);
        for _ in 0..200 {
            let a = Vec3A::new(random(), random(), random());
            let b = Vec3A::new(random(), random(), random());
            let h = (random() + 1.0) * 0.4;
            let u = Vec3A::new(random(), random(), random()).normalize_or(Vec3A::Y);
            let (s, t) = closest_parameters(a, b, u, h);
            let found = (a + (b - a) * s).distance(u * t);
            let mut best = f32::INFINITY;
            for i in 0..=400 {
                let p = a + (b - a) * (i as f32 / 400.0);
                best = best.min(p.distance(u * p.dot(u).clamp(-h, h)));
            }
            assert!(found <= best + 1e-4, "{a} {b} {h}: {found} > {best}");
            let (s0, _) = closest_parameters(a, b, u, 0.0);
            let point = (a + (b - a) * s0).length();
            let best_point = (0..=400)
                .map(|i| (a + (b - a) * (i as f32 / 400.0)).length())
                .fold(f32::INFINITY, f32::min);
            assert!(
                point <= best_point + 1e-4,
                "{a} {b}: {point} > {best_point}"
            );
        }
    }

    /// Random edges outside random moving thin capsules and spheres, moving at random
    /// velocities: the step's candidates move every particle exactly as every pair of an edge
    /// and a thin collider does, substep after substep.
    #[test]
    fn the_candidates_give_the_contacts_every_edge_would() {
        use crate::collide::contact::ContactScratch;
        use crate::collide::{ContactMaterial, SolverShape};
        use bevy::math::Quat;
        let mut rng = Rng(3);
        let (dt, substeps, thickness, length) = (1.0 / 60.0, 4, 0.005, 0.08);
        let h = dt / substeps as f32;
        let mut moved = 0;
        for _ in 0..40 {
            let colliders: Vec<SolverCollider> = (0..4)
                .map(|k| {
                    let radius = rng.range(0.02, 0.045);
                    let shape = if k == 0 {
                        SolverShape::Sphere { radius }
                    } else {
                        SolverShape::Capsule {
                            radius,
                            half_length: rng.range(0.0, 0.2),
                        }
                    };
                    let start = RigidPose {
                        translation: rng.vec3(-0.2, 0.2).into(),
                        rotation: Quat::from_axis_angle(rng.unit_vector(), rng.range(-3.0, 3.0)),
                    };
                    let end = RigidPose {
                        translation: start.translation + Vec3A::from(rng.vec3(-0.1, 0.1)),
                        rotation: Quat::from_axis_angle(rng.unit_vector(), rng.range(-1.5, 1.5))
                            * start.rotation,
                    };
                    let mut c = SolverCollider::fixed(shape, start);
                    c.end = end;
                    c.material = ContactMaterial::default();
                    c
                })
                .collect();
            let clear = |p: Vec3A| {
                colliders.iter().all(|c| {
                    let local = c.start.inverse_transform_point(p);
                    c.shape
                        .signed_distance(local, c.margin + thickness)
                        .is_none()
                })
            };
            let mut x = Vec::new();
            while x.len() < 300 {
                let a = Vec3A::from(rng.vec3(-0.4, 0.4));
                let b = a + Vec3A::from(rng.unit_vector()) * length;
                let free = (0..=8).all(|i| clear(a.lerp(b, i as f32 / 8.0)));
                if free {
                    x.extend([a, b]);
                }
            }
            let edges: Vec<[u32; 2]> = (0..x.len() as u32 / 2)
                .map(|e| [2 * e, 2 * e + 1])
                .collect();
            let v: Vec<Vec3A> = x.iter().map(|_| Vec3A::from(rng.vec3(-3.0, 3.0))).collect();
            let w = vec![1.0; x.len()];
            let mut contacts = ContactScratch::default();
            contacts.begin_step(&colliders, &x, 0.0, thickness);
            let mut listed = EdgeContacts::new(edges.clone(), length);
            listed.begin_step(&colliders, &x, &v, Vec3A::ZERO, dt, thickness);
            let mut every = listed.clone();
            every.candidates = (0..colliders.len() as u32)
                .flat_map(|k| {
                    edges.iter().map(move |&particles| Candidate {
                        collider: k,
                        particles,
                    })
                })
                .collect();
            assert!(listed.candidates.len() < every.candidates.len());
            let (mut xa, mut xb) = (x.clone(), x.clone());
            for s in 0..substeps {
                let x_prev = xa.clone();
                for ((a, b), v) in xa.iter_mut().zip(&mut xb).zip(&v) {
                    *a += *v * h;
                    *b += *v * h;
                }
                let (t0, t1) = (s as f32 / substeps as f32, (s + 1) as f32 / substeps as f32);
                contacts.begin_substep(&colliders, t0, t1, &xa, &x_prev);
                let before = xa.clone();
                for (edge_contacts, x) in [(&mut listed, &mut xa), (&mut every, &mut xb)] {
                    edge_contacts.begin_substep(&colliders, &contacts);
                    edge_contacts.project(&colliders, x, &x_prev, &w, |c| c.margin + thickness);
                }
                assert_eq!(xa, xb, "substep {s}");
                moved += xa.iter().zip(&before).filter(|(a, b)| a != b).count();
            }
        }
        // The edges met the colliders often enough for the comparison to mean something.
        assert!(moved > 200, "{moved} particles moved");
    }
}
