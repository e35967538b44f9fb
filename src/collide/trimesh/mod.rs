//! Triangle-mesh colliders: a bounding-volume hierarchy over the triangles, the closest point
//! query on it, the first triangle a segment crosses, and what tells inside from outside.
//!
//! Inside and outside come from angle-weighted pseudo-normals (Baerentzen and Aanaes 2005):
//! the closest point of the mesh lies on a face, an edge or a vertex, and the point queried is
//! outside where it lies in front of that feature's pseudo-normal (the face normal; the sum of
//! the two faces' normals for an edge; the incident faces' normals weighted by their angles at
//! a vertex). Unlike the face normal of whichever triangle happened to be closest, this is
//! exact on a closed mesh, at its edges and corners too. A mesh is *closed* when every edge
//! joins exactly two triangles that run along it in opposite directions; an open mesh (a scan
//! with holes, a single-sided sheet) has no inside, and a point is never inside it, whatever
//! side of a triangle it is on: the cloth is kept on the side it came from by the crossing
//! test ([`TriMesh::first_crossing`]) instead.
//!
//! A mesh's vertices are also tested against the cloth's triangles (`collide/vertex_contacts.rs`),
//! so that a feature narrower than the cloth's particle spacing (an ear, a fin, the curve of a
//! head under a coarse sheet) cannot pass between its particles.
//!
//! The hierarchy's boxes and nodes are in `tree.rs`, its build and its queries in `bvh.rs`;
//! the triangle-level queries and the pseudo-normals are here.

use bevy::math::{Vec3, Vec3A};

use crate::error::ColliderError;
use crate::weld::{default_tolerance, weld};

mod bvh;
#[cfg(test)]
mod tests;
mod tree;

pub(crate) use tree::Aabb;
use tree::Node;

/// A triangle mesh with a bounding-volume hierarchy (median split along the longest axis of
/// the triangle centroids), for closest-point and crossing queries, with the pseudo-normals
/// that tell inside from outside on a closed mesh: the closest feature's (face, edge or
/// vertex) angle-weighted normal says which side a point is on. A mesh is closed when every
/// edge joins exactly two triangles running along it in opposite directions; an open one has
/// no inside. Its vertices are tested against the cloth's triangles, so a feature finer than
/// the cloth cannot pass between its particles.
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    vertices: Vec<Vec3A>,
    triangles: Vec<[u32; 3]>,
    /// Unit face normals (counter-clockwise front).
    normals: Vec<Vec3A>,
    /// Per triangle, the unit pseudo-normals of its edges `ab`, `bc`, `ca`.
    edge_normals: Vec<[Vec3A; 3]>,
    /// Per vertex, the unit angle-weighted pseudo-normal.
    vertex_normals: Vec<Vec3A>,
    /// Every edge joins exactly two triangles running along it in opposite directions.
    closed: bool,
    nodes: Vec<Node>,
}

/// Where on a triangle its closest point to a query lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TriangleFeature {
    /// Inside the face.
    Face,
    /// On edge `k` (`0`: `ab`, `1`: `bc`, `2`: `ca`).
    Edge(u8),
    /// At vertex `k` (`0`: `a`, `1`: `b`, `2`: `c`).
    Vertex(u8),
}

/// The closest point of a [`TriMesh`] to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ClosestPoint {
    /// The point on the mesh.
    pub point: Vec3A,
    /// The triangle it is on.
    pub triangle: u32,
    /// The unit pseudo-normal of the feature the point lies on (see the [module docs](self)).
    pub normal: Vec3A,
    /// The distance from the query point.
    pub distance: f32,
}

/// A segment's first crossing of a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Crossing {
    /// The triangle crossed.
    pub triangle: u32,
    /// Its unit normal, turned to the side the segment came from.
    pub normal: Vec3A,
    /// A point of the triangle's plane.
    pub plane_point: Vec3A,
}

impl TriMesh {
    /// The signed distance of `p` from the surface (negative inside a closed mesh) and the
    /// outward normal, if the surface is within `reach`.
    pub(crate) fn signed_distance(&self, p: Vec3A, reach: f32) -> Option<(f32, Vec3A)> {
        Some(mesh_distance(self, p, &self.closest_point(p, reach)?))
    }

    /// Builds the hierarchy. Degenerate (zero-area) triangles are left out. Errors: no
    /// triangles left, an index out of range, a non-finite vertex.
    pub fn new(vertices: &[Vec3], indices: &[u32]) -> Result<Self, ColliderError> {
        if let Some(vertex) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(ColliderError::NonFiniteVertex { vertex });
        }
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(ColliderError::IndexOutOfRange {
                index,
                vertex_count: vertices.len(),
            });
        }
        // Meshes split a vertex wherever its normals or texture coordinates differ (every
        // corner of Bevy's `Cuboid`, a UV sphere's seam): merged, the topology (closed or not,
        // the pseudo-normals) is the surface's, not its shading's.
        let welded = weld(vertices, indices, default_tolerance(vertices));
        let indices = &welded.indices;
        let vertices: Vec<Vec3A> = welded.positions.iter().map(|&v| v.into()).collect();
        let mut triangles = Vec::with_capacity(indices.len() / 3);
        let mut normals = Vec::with_capacity(indices.len() / 3);
        for t in indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| vertices[i as usize]);
            let n = (b - a).cross(c - a);
            if n.length_squared() > 1e-20 {
                triangles.push([t[0], t[1], t[2]]);
                normals.push(n.normalize());
            }
        }
        if triangles.is_empty() {
            return Err(ColliderError::EmptyMesh);
        }
        let mut mesh = Self {
            vertices,
            triangles,
            normals,
            edge_normals: Vec::new(),
            vertex_normals: Vec::new(),
            closed: false,
            nodes: Vec::new(),
        };
        mesh.build();
        mesh.find_pseudo_normals();
        Ok(mesh)
    }

    /// Whether the mesh is closed: every edge joins exactly two triangles that run along it
    /// in opposite directions. Only a closed mesh has an inside.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// The edge and vertex pseudo-normals, and whether the mesh is closed.
    fn find_pseudo_normals(&mut self) {
        use std::collections::HashMap;
        // Directed edges: how many triangles run along each.
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        let mut edge_sums: HashMap<(u32, u32), Vec3A> = HashMap::new();
        let mut vertex_sums = vec![Vec3A::ZERO; self.vertices.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            let n = self.normals[t];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                *directed.entry((a, b)).or_default() += 1;
                *edge_sums.entry((a.min(b), a.max(b))).or_default() += n;
                // The angle at corner k.
                let p = self.vertices[a as usize];
                let e1 = self.vertices[b as usize] - p;
                let e2 = self.vertices[tri[(k + 2) % 3] as usize] - p;
                let angle = e1.angle_between(e2);
                if angle.is_finite() {
                    vertex_sums[a as usize] += n * angle;
                }
            }
        }
        self.closed = directed
            .iter()
            .all(|(&(a, b), &count)| count == 1 && directed.get(&(b, a)) == Some(&1));
        self.vertex_normals = vertex_sums
            .iter()
            .map(|s| s.try_normalize().unwrap_or(Vec3A::ZERO))
            .collect();
        self.edge_normals = self
            .triangles
            .iter()
            .enumerate()
            .map(|(t, tri)| {
                [0, 1, 2].map(|k| {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    edge_sums[&(a.min(b), a.max(b))]
                        .try_normalize()
                        .unwrap_or(self.normals[t])
                })
            })
            .collect();
    }
}

/// Where along `from + s dir`, `s` in `[0, 1]`, the segment meets triangle `abc`, if it does
/// (Moller and Trumbore 1997).
fn segment_crosses_triangle(from: Vec3A, dir: Vec3A, a: Vec3A, b: Vec3A, c: Vec3A) -> Option<f32> {
    let e1 = b - a;
    let e2 = c - a;
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = from - a;
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = dir.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let s = e2.dot(qv) * inv;
    (0.0..=1.0).contains(&s).then_some(s)
}

/// The point of triangle `abc` closest to `p` and the feature it lies on (Ericson, Real-Time
/// Collision Detection, section 5.1.5: the Voronoi regions of the vertices, then the edges,
/// then the face).
pub(crate) fn closest_point_on_triangle(
    p: Vec3A,
    a: Vec3A,
    b: Vec3A,
    c: Vec3A,
) -> (Vec3A, TriangleFeature) {
    use TriangleFeature::{Edge, Face, Vertex};
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (a + ab * (d1 / (d1 - d3)), Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (a + ac * (d2 / (d2 - d6)), Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))), Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    (a + ab * (vb * denom) + ac * (vc * denom), Face)
}

/// The signed distance and outward normal of `p` from its closest point on `mesh` (see
/// [`SolverShape::signed_distance`](super::SolverShape::signed_distance)).
#[inline]
pub(crate) fn mesh_distance(mesh: &TriMesh, p: Vec3A, closest: &ClosestPoint) -> (f32, Vec3A) {
    let offset = p - closest.point;
    let inside = mesh.is_closed() && offset.dot(closest.normal) < 0.0;
    let n = if closest.distance <= 1e-7 {
        closest.normal
    } else if inside {
        -offset / closest.distance
    } else {
        offset / closest.distance
    };
    let d = if inside {
        -closest.distance
    } else {
        closest.distance
    };
    (d, n)
}
