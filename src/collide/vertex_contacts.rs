//! The cloth's triangles against the vertices of triangle-mesh colliders, so that a feature
//! narrower than the cloth's particle spacing (the tip of an ear, the ridge of a fin, the rim
//! of an open mesh, the curve of a head under a coarse sheet) cannot pass between its
//! particles: the particle contacts alone keep the particles outside while the mesh comes
//! through the middle of the cloth's triangles.
//!
//! Candidates are found once per fixed step: for each cloth triangle, its bounds at the start,
//! grown by how far its particles can move in the step, are taken into the collider's frame
//! (at the start and the end pose) and grown by the contact reach; the mesh's vertices inside
//! them (a query of its bounding-volume hierarchy) are its candidates. In every solver
//! iteration, for each candidate, with `q` the vertex at the end of the substep,
//! `p = sum b_i x_i` the point of the cloth triangle's plane below it (barycentric `b`, which
//! must lie within the triangle), `n` the triangle's unit normal and `s = +-1` the side of
//! the triangle the vertex was on at the start of the substep (measured the same way from
//! `x_prev` and the start pose): `C = s n . (q - p) - reach >= 0`. Where it is violated the
//! triangle moves away from the vertex, which does not move (a collider is kinematic):
//! `dx_i = w_i b_i C s n / sum w_j b_j^2`, so that `p` moves by exactly `C s n`. A vertex that
//! crossed the triangle within the substep is put back on its side. Friction acts on
//! positions, as in Macklin et al. 2014's unified particles: the contact point's sliding over
//! the vertex in the substep (tangential, relative to the vertex's own motion) is taken away
//! up to `mu` times the normal corrections of the substep so far, less what friction has
//! already taken (all of it below that: static), distributed in the same way. Velocities
//! follow from the positions. The closing pass after the exact edges projects to half the
//! reach: to the full reach it undid the exact edges round every point of support (a sheet
//! hanging from the bunny's ear kept 2.7% strain on the edges round the tip; 0.2% at half),
//! and to none, as the particle contacts do, it left the vertex on the triangle's plane, its
//! side at the next substep a matter of rounding (the random scans' ears then came through
//! the sheet by 2 to 3 cm, `tests/mesh_colliders.rs`).
//!
//! Measured (`cargo run --release --example scenes -- mesh-drop --mesh M`, a 16 x 16 sheet
//! dropped on a 0.6 m mesh): with the thin vertices alone (the tips, ridges and rims where a
//! face turns more than 73 degrees from the vertex's normal) the bunny's head came through
//! the sheet's triangles by up to 10 mm and the sheet's edges cut 20 mm into it
//! (`tests/mesh_colliders.rs`); with every vertex, neither, for about 1.4 times the step's
//! cost on the bunny (2.2 to 3.0 ms per frame; see `docs/colliders.md`).

use bevy::math::Vec3A;

use super::contact::ContactScratch;
use super::shapes::{SolverCollider, SolverShape};
use super::trimesh::Aabb;

/// A vertex of a triangle-mesh collider that may touch a cloth triangle during the step.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    collider: u32,
    /// The vertex, in the collider's frame.
    vertex: Vec3A,
    triangle: u32,
}

/// What a candidate has pushed and held in the current substep.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Held {
    /// The normal corrections so far, metres.
    depth: f32,
    /// The sliding friction has taken away so far, metres.
    friction: f32,
}

/// The candidate pairs of the current step, reused every step.
#[derive(Clone, Debug, Default)]
pub(crate) struct MeshVertexContacts {
    candidates: Vec<Candidate>,
    held: Vec<Held>,
    /// Per triangle, its bounds at the start of the step grown by its reach and motion.
    triangle_bounds: Vec<Aabb>,
    /// The vertices of a mesh found near one triangle.
    found: Vec<u32>,
}

impl MeshVertexContacts {
    /// Whether there are candidate pairs this step (only then is there anything to project).
    pub(crate) fn has_candidates(&self) -> bool {
        !self.candidates.is_empty()
    }

    /// Finds the candidate pairs of a step of `dt` seconds: the cloth at `x` moving at `v`
    /// under the acceleration `a` (none, at no cost, when no collider is a triangle mesh).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn begin_step(
        &mut self,
        colliders: &[SolverCollider],
        triangles: &[[u32; 3]],
        x: &[Vec3A],
        v: &[Vec3A],
        a: Vec3A,
        dt: f32,
        thickness: f32,
    ) {
        self.candidates.clear();
        self.triangle_bounds.clear();
        let meshes = |c: &SolverCollider| matches!(&c.shape, SolverShape::TriangleMesh(_));
        if !colliders.iter().any(meshes) {
            return;
        }
        let fall = 0.5 * a.length() * dt * dt;
        let mut cloth = Aabb::EMPTY;
        self.triangle_bounds.extend(triangles.iter().map(|t| {
            let mut b = Aabb::EMPTY;
            let mut motion = 0.0f32;
            for &i in t {
                b = b.grown(x[i as usize]);
                motion = motion.max(v[i as usize].length() * dt);
            }
            b = b.padded(motion + fall);
            cloth = cloth.union(b);
            b
        }));
        for (k, collider) in colliders.iter().enumerate() {
            let SolverShape::TriangleMesh(mesh) = &collider.shape else {
                continue;
            };
            let reach = collider.margin + thickness;
            let Some(path) = collider.swept_bounds(reach) else {
                continue;
            };
            if !path.overlaps(&cloth) {
                continue;
            }
            for (t, b) in self.triangle_bounds.iter().enumerate() {
                if !b.overlaps(&path) {
                    continue;
                }
                // The triangle's box in the collider's frame, at the start and at the end of
                // the step, grown by the reach.
                let local = b.in_frames(&[collider.start, collider.end]).padded(reach);
                self.found.clear();
                mesh.vertices_in(&local, &mut self.found);
                self.found.sort_unstable();
                self.found.dedup();
                for &i in &self.found {
                    self.candidates.push(Candidate {
                        collider: k as u32,
                        vertex: mesh.vertex(i),
                        triangle: t as u32,
                    });
                }
            }
        }
    }

    /// How many candidates pushed their triangle in the current (or last) substep.
    pub(crate) fn count(&self) -> usize {
        self.held.iter().filter(|held| held.depth > 0.0).count()
    }

    /// Starts a substep: nothing pushed or held yet.
    pub(crate) fn begin_substep(&mut self) {
        self.held.clear();
        self.held.resize(self.candidates.len(), Held::default());
    }

    /// Projects every candidate (see the [module docs](self)), with the colliders' poses of
    /// the current substep from `contacts`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn project(
        &mut self,
        colliders: &[SolverCollider],
        contacts: &ContactScratch,
        triangles: &[[u32; 3]],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        w: &[f32],
        reach: impl Fn(&SolverCollider) -> f32,
    ) {
        let (start_poses, end_poses) = contacts.substep_poses();
        for (index, c) in self.candidates.iter().enumerate() {
            let k = c.collider as usize;
            let reach = reach(&colliders[k]);
            let [i0, i1, i2] = triangles[c.triangle as usize].map(|i| i as usize);
            let q = end_poses[k].transform_point(c.vertex);
            let Some((b, n, height)) = plane_coordinates(q, x[i0], x[i1], x[i2]) else {
                continue;
            };
            // Within the triangle (a little slack so that a vertex over an edge is held by
            // both triangles rather than by neither), and near its plane.
            if b.min_element() < -0.05 || height.abs() > 2.0 * reach {
                continue;
            }
            let q_prev = start_poses[k].transform_point(c.vertex);
            let side = match plane_coordinates(q_prev, x_prev[i0], x_prev[i1], x_prev[i2]) {
                Some((_, _, h)) if h != 0.0 => h.signum(),
                _ => height.signum(),
            };
            let constraint = side * height - reach;
            if constraint >= 0.0 {
                continue;
            }
            let b = b.max(Vec3A::ZERO);
            let b = b / (b.x + b.y + b.z);
            let denominator = w[i0] * b.x * b.x + w[i1] * b.y * b.y + w[i2] * b.z * b.z;
            if denominator <= 0.0 {
                continue;
            }
            let mut shift = n * (side * constraint);
            // Friction: the contact point's sliding over the vertex this substep loses up to
            // `mu` times the depth just corrected (all of it below that: static).
            let p = x[i0] * b.x + x[i1] * b.y + x[i2] * b.z + shift;
            let p_prev = x_prev[i0] * b.x + x_prev[i1] * b.y + x_prev[i2] * b.z;
            let slide = (p - p_prev) - (q - q_prev);
            let slide = slide - n * n.dot(slide);
            let length = slide.length();
            let held = &mut self.held[index];
            held.depth -= constraint;
            let budget = (colliders[k].material.friction * held.depth - held.friction).max(0.0);
            if length > 0.0 {
                let removed = length.min(budget);
                shift -= slide * (removed / length);
                held.friction += removed;
            }
            let step = shift / denominator;
            x[i0] += step * (w[i0] * b.x);
            x[i1] += step * (w[i1] * b.y);
            x[i2] += step * (w[i2] * b.z);
        }
    }
}

/// The barycentric coordinates of `q`'s projection onto the plane of triangle `abc`, the
/// triangle's unit normal and `q`'s height above the plane along it; `None` for a degenerate
/// triangle.
#[inline]
pub(crate) fn plane_coordinates(
    q: Vec3A,
    a: Vec3A,
    b: Vec3A,
    c: Vec3A,
) -> Option<(Vec3A, Vec3A, f32)> {
    let ab = b - a;
    let ac = c - a;
    let cross = ab.cross(ac);
    let area_sq = cross.length_squared();
    if area_sq < 1e-20 {
        return None;
    }
    let n = cross / area_sq.sqrt();
    let aq = q - a;
    let height = aq.dot(n);
    let in_plane = aq - n * height;
    // Barycentric coordinates from the sub-triangles' signed areas.
    let u = in_plane.cross(ac).dot(cross) / area_sq;
    let v = ab.cross(in_plane).dot(cross) / area_sq;
    Some((Vec3A::new(1.0 - u - v, u, v), n, height))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_coordinates_rebuild_the_point() {
        let (a, b, c) = (
            Vec3A::new(0.1, 0.0, 0.2),
            Vec3A::new(1.0, 0.3, 0.0),
            Vec3A::new(0.2, 0.1, 1.1),
        );
        for q in [
            Vec3A::new(0.4, 0.5, 0.4),
            Vec3A::new(-1.0, -0.2, 3.0),
            Vec3A::new(0.3, 0.05, 0.3),
        ] {
            let (bary, n, h) = plane_coordinates(q, a, b, c).unwrap();
            let rebuilt = a * bary.x + b * bary.y + c * bary.z + n * h;
            assert!(rebuilt.distance(q) < 1e-5, "{q}: {rebuilt}");
            assert!((bary.x + bary.y + bary.z - 1.0).abs() < 1e-6);
        }
    }
}
