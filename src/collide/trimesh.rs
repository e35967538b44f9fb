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
//! *Thin* vertices are where the mesh is thinner than any cloth is fine: the vertices of the
//! boundary of an open mesh and those where an incident face turns more than about 73 degrees
//! away from the vertex's pseudo-normal (the tip of an ear or a cone, the ridge of a fin). The
//! cloth tests its triangles against them (`collide/contact.rs`), so a feature narrower than
//! the cloth's particle spacing cannot pass between its particles.

use bevy::math::{Vec3, Vec3A};

use crate::cloth::weld::{default_tolerance, weld};
use crate::error::ColliderError;

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

#[derive(Clone, Copy, Debug, PartialEq)]
struct Node {
    bounds: Aabb,
    /// Leaf: first triangle in `order`; inner node: index of the left child (the right one
    /// follows the whole left subtree, at `right`).
    start: u32,
    /// Leaf: triangle count; inner node: 0.
    count: u32,
    /// Inner node: index of the right child.
    right: u32,
}

/// Triangles per leaf, at most.
const LEAF_SIZE: usize = 4;

/// Cosine of the largest angle between an incident face's normal and a vertex's pseudo-normal
/// for the vertex to count as smooth (not thin): about 73 degrees.
const THIN_COSINE: f32 = 0.3;

/// A triangle mesh with a bounding-volume hierarchy (median split along the longest axis of
/// the triangle centroids), for closest-point and crossing queries, with the pseudo-normals
/// that tell inside from outside on a closed mesh: the closest feature's (face, edge or
/// vertex) angle-weighted normal says which side a point is on. A mesh is closed when every
/// edge joins exactly two triangles running along it in opposite directions; an open one has
/// no inside. Its *thin* vertices (an open rim, a tip or ridge where an incident face turns
/// more than about 73 degrees from the vertex's normal) are tested against the cloth's
/// triangles, so a feature finer than the cloth cannot pass between its particles.
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
    /// The thin vertices, sorted.
    thin_vertices: Vec<u32>,
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
            thin_vertices: Vec::new(),
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

    /// The number of thin vertices (see [`TriMesh`]).
    pub fn thin_vertex_count(&self) -> usize {
        self.thin_vertices.len()
    }

    /// The thin vertices' positions, in the mesh's frame.
    pub(crate) fn thin_vertices(&self) -> impl ExactSizeIterator<Item = Vec3A> + '_ {
        self.thin_vertices
            .iter()
            .map(|&v| self.vertices[v as usize])
    }

    /// The edge and vertex pseudo-normals, whether the mesh is closed, its thin vertices.
    fn find_pseudo_normals(&mut self) {
        use std::collections::HashMap;
        // Directed edges: how many triangles run along each.
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        let mut edge_sums: HashMap<(u32, u32), (Vec3A, u32)> = HashMap::new();
        let mut vertex_sums = vec![Vec3A::ZERO; self.vertices.len()];
        for (t, tri) in self.triangles.iter().enumerate() {
            let n = self.normals[t];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                *directed.entry((a, b)).or_default() += 1;
                let sum = edge_sums.entry((a.min(b), a.max(b))).or_default();
                sum.0 += n;
                sum.1 += 1;
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
        let mut boundary = vec![false; self.vertices.len()];
        for (&(a, b), &(_, count)) in &edge_sums {
            if count != 2 {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
            }
        }
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
                        .0
                        .try_normalize()
                        .unwrap_or(self.normals[t])
                })
            })
            .collect();
        // A vertex is thin where an incident face turns far from its pseudo-normal.
        let mut thin = boundary;
        for (t, tri) in self.triangles.iter().enumerate() {
            for &v in tri {
                if self.vertex_normals[v as usize].dot(self.normals[t]) < THIN_COSINE {
                    thin[v as usize] = true;
                }
            }
        }
        let mut used = vec![false; self.vertices.len()];
        for &v in self.triangles.iter().flatten() {
            used[v as usize] = true;
        }
        self.thin_vertices = (0..self.vertices.len() as u32)
            .filter(|&v| thin[v as usize] && used[v as usize])
            .collect();
    }

    /// The bounds of the whole mesh.
    pub(crate) fn bounds(&self) -> Aabb {
        self.nodes[0].bounds
    }

    fn triangle_bounds(&self, t: usize) -> Aabb {
        self.triangles[t]
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.grown(self.vertices[i as usize]))
    }

    fn build(&mut self) {
        let centroids: Vec<Vec3A> = self
            .triangles
            .iter()
            .map(|t| t.iter().map(|&i| self.vertices[i as usize]).sum::<Vec3A>() / 3.0)
            .collect();
        let mut order: Vec<u32> = (0..self.triangles.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * self.triangles.len() / LEAF_SIZE + 1);
        self.build_node(&mut nodes, &mut order, 0, &centroids);
        // Store the triangles in leaf order so a leaf is a contiguous range.
        self.triangles = order.iter().map(|&t| self.triangles[t as usize]).collect();
        self.normals = order.iter().map(|&t| self.normals[t as usize]).collect();
        self.nodes = nodes;
    }

    fn build_node(
        &self,
        nodes: &mut Vec<Node>,
        order: &mut [u32],
        start: usize,
        centroids: &[Vec3A],
    ) -> u32 {
        let bounds = order.iter().fold(Aabb::EMPTY, |b, &t| {
            b.union(self.triangle_bounds(t as usize))
        });
        let index = nodes.len() as u32;
        nodes.push(Node {
            bounds,
            start: start as u32,
            count: order.len() as u32,
            right: 0,
        });
        if order.len() <= LEAF_SIZE {
            return index;
        }
        let spread = order
            .iter()
            .fold(Aabb::EMPTY, |b, &t| b.grown(centroids[t as usize]));
        let extent = spread.max - spread.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        let (left, right) = order.split_at_mut(mid);
        let left_index = self.build_node(nodes, left, start, centroids);
        let right_index = self.build_node(nodes, right, start + mid, centroids);
        nodes[index as usize].start = left_index;
        nodes[index as usize].count = 0;
        nodes[index as usize].right = right_index;
        index
    }

    /// The closest point of the mesh to `p` within `max_distance`, if any.
    pub(crate) fn closest_point(&self, p: Vec3A, max_distance: f32) -> Option<ClosestPoint> {
        let mut best: Option<ClosestPoint> = None;
        let mut best_sq = max_distance * max_distance;
        // A fixed stack: the tree is balanced, so its depth is about log2(triangles / 4).
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if node.bounds.distance_squared(p) > best_sq {
                continue;
            }
            if node.count > 0 {
                for t in node.start..node.start + node.count {
                    let tri = self.triangles[t as usize];
                    let [a, b, c] = tri.map(|i| self.vertices[i as usize]);
                    let (q, feature) = closest_point_on_triangle(p, a, b, c);
                    let d_sq = q.distance_squared(p);
                    if d_sq <= best_sq {
                        best_sq = d_sq;
                        let normal = match feature {
                            TriangleFeature::Face => self.normals[t as usize],
                            TriangleFeature::Edge(k) => self.edge_normals[t as usize][k as usize],
                            TriangleFeature::Vertex(k) => {
                                self.vertex_normals[tri[k as usize] as usize]
                            }
                        };
                        best = Some(ClosestPoint {
                            point: q,
                            triangle: t,
                            normal,
                            distance: d_sq.sqrt(),
                        });
                    }
                }
            } else if top + 2 <= stack.len() {
                // Visit the nearer child first.
                let (l, r) = (node.start, node.right);
                let dl = self.nodes[l as usize].bounds.distance_squared(p);
                let dr = self.nodes[r as usize].bounds.distance_squared(p);
                let (near, far) = if dl <= dr { (l, r) } else { (r, l) };
                stack[top] = far;
                stack[top + 1] = near;
                top += 2;
            }
        }
        best
    }

    /// The first triangle the segment from `from` to `to` crosses, if any; with `front_only`,
    /// only a crossing from a triangle's front to its back counts (entering a closed mesh,
    /// not leaving it).
    pub(crate) fn first_crossing(
        &self,
        from: Vec3A,
        to: Vec3A,
        front_only: bool,
    ) -> Option<Crossing> {
        let dir = to - from;
        let segment = Aabb::EMPTY.grown(from).grown(to);
        let mut best: Option<(f32, u32)> = None;
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if !node.bounds.overlaps(&segment) {
                continue;
            }
            if node.count > 0 {
                for t in node.start..node.start + node.count {
                    let n = self.normals[t as usize];
                    let approach = dir.dot(n);
                    if approach == 0.0 || (front_only && approach > 0.0) {
                        continue;
                    }
                    let [a, b, c] = self.triangles[t as usize].map(|i| self.vertices[i as usize]);
                    if let Some(s) = segment_crosses_triangle(from, dir, a, b, c)
                        && best.is_none_or(|(s_best, _)| s < s_best)
                    {
                        best = Some((s, t));
                    }
                }
            } else if top + 2 <= stack.len() {
                stack[top] = node.right;
                stack[top + 1] = node.start;
                top += 2;
            }
        }
        best.map(|(_, t)| {
            let n = self.normals[t as usize];
            Crossing {
                triangle: t,
                normal: if dir.dot(n) < 0.0 { n } else { -n },
                plane_point: self.vertices[self.triangles[t as usize][0] as usize],
            }
        })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// A closed box mesh of `n` x `n` quads per face would do; a bumpy grid is enough here.
    fn bumpy_grid(n: u32) -> (Vec<Vec3>, Vec<u32>) {
        let mut v = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, z) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
                v.push(Vec3::new(x, 0.1 * (7.0 * x).sin() * (5.0 * z).cos(), z));
            }
        }
        let mut idx = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = j * n + i;
                idx.extend_from_slice(&[a, a + n, a + 1, a + 1, a + n, a + n + 1]);
            }
        }
        (v, idx)
    }

    #[test]
    fn the_hierarchy_finds_the_same_closest_point_as_brute_force() {
        let (v, idx) = bumpy_grid(17);
        let mesh = TriMesh::new(&v, &idx).unwrap();
        let mut rng = Rng(12345);
        let mut rand = || rng.uniform();
        for _ in 0..500 {
            let p = Vec3A::new(rand() * 1.4 - 0.2, rand() * 0.8 - 0.4, rand() * 1.4 - 0.2);
            let brute = idx
                .chunks_exact(3)
                .map(|t| {
                    let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3A::from(v[i as usize]));
                    closest_point_on_triangle(p, a, b, c).0.distance(p)
                })
                .fold(f32::MAX, f32::min);
            let found = mesh.closest_point(p, 10.0).unwrap();
            assert!(
                (found.distance - brute).abs() < 1e-5,
                "{p}: {found:?} vs {brute}"
            );
            // Within a bound smaller than the distance, nothing is found.
            assert!(mesh.closest_point(p, brute * 0.99 - 1e-6).is_none() || brute < 1e-5);
        }
    }

    #[test]
    fn closest_point_on_a_triangle_covers_every_region() {
        let (a, b, c) = (Vec3A::ZERO, Vec3A::X, Vec3A::Y);
        let cases = [
            (Vec3A::new(0.2, 0.2, 1.0), Vec3A::new(0.2, 0.2, 0.0)),
            (Vec3A::new(-1.0, -1.0, 0.0), a),
            (Vec3A::new(2.0, -0.5, 0.0), b),
            (Vec3A::new(-0.5, 2.0, 0.0), c),
            (Vec3A::new(0.5, -1.0, 0.3), Vec3A::new(0.5, 0.0, 0.0)),
            (Vec3A::new(-1.0, 0.5, 0.0), Vec3A::new(0.0, 0.5, 0.0)),
            (Vec3A::new(1.0, 1.0, 0.0), Vec3A::new(0.5, 0.5, 0.0)),
        ];
        for (p, expected) in cases {
            let (q, _) = closest_point_on_triangle(p, a, b, c);
            assert!(q.distance(expected) < 1e-6, "{p}: {q} vs {expected}");
        }
    }

    /// A point uniform in the cube of half side `half` about the origin.
    fn point(rng: &mut Rng, half: f32) -> Vec3A {
        rng.vec3(-half, half).into()
    }

    /// A closed UV sphere of radius about 1 with each vertex's radius jittered by `noise`
    /// (dented, not convex, for large noise).
    fn dented_sphere(
        rng: &mut Rng,
        rings: u32,
        segments: u32,
        noise: f32,
    ) -> (Vec<Vec3>, Vec<u32>) {
        let mut jitter = || 1.0 + noise * rng.range(-1.0, 1.0);
        let mut v = vec![Vec3::Y * jitter(), -Vec3::Y * jitter()];
        for r in 1..rings {
            let theta = std::f32::consts::PI * r as f32 / rings as f32;
            for s in 0..segments {
                let phi = std::f32::consts::TAU * s as f32 / segments as f32;
                let dir = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                v.push(dir * jitter());
            }
        }
        let ring = |r: u32, s: u32| 2 + (r - 1) * segments + s % segments;
        let mut idx = Vec::new();
        for s in 0..segments {
            idx.extend_from_slice(&[0, ring(1, s + 1), ring(1, s)]);
            idx.extend_from_slice(&[1, ring(rings - 1, s), ring(rings - 1, s + 1)]);
            for r in 1..rings - 1 {
                let (a, b, c, d) = (
                    ring(r, s),
                    ring(r, s + 1),
                    ring(r + 1, s),
                    ring(r + 1, s + 1),
                );
                idx.extend_from_slice(&[a, b, d, a, d, c]);
            }
        }
        (v, idx)
    }

    /// Inside by the parity of a ray's crossings, brute force.
    fn inside_by_parity(v: &[Vec3], idx: &[u32], p: Vec3A) -> bool {
        let dir = Vec3A::new(0.31, 0.17, 0.93).normalize() * 10.0;
        idx.chunks_exact(3)
            .filter(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3A::from(v[i as usize]));
                segment_crosses_triangle(p, dir, a, b, c).is_some()
            })
            .count()
            % 2
            == 1
    }

    #[test]
    fn inside_by_pseudo_normals_is_inside_by_ray_parity_on_random_dented_closed_meshes() {
        let mut rng = Rng(99);
        let (mut checked, mut face_normal_wrong) = (0, 0);
        for (rings, segments) in [(6, 9), (9, 14), (14, 23)] {
            let (v, idx) = dented_sphere(&mut rng, rings, segments, 0.3);
            let mesh = TriMesh::new(&v, &idx).unwrap();
            assert!(mesh.is_closed());
            let shape =
                crate::collide::SolverShape::TriangleMesh(std::sync::Arc::new(mesh.clone()));
            for _ in 0..3000 {
                let p = point(&mut rng, 1.4);
                let Some((d, n)) = shape.signed_distance(p, 0.15) else {
                    continue;
                };
                let inside = inside_by_parity(&v, &idx, p);
                assert_eq!(d < 0.0, inside, "{p}: {d}");
                // The normal points out: a small step along it goes away from the inside.
                assert!((n.length() - 1.0).abs() < 1e-4);
                checked += 1;
                // What the closest triangle's own face normal would have said.
                let closest = mesh.closest_point(p, 0.15).unwrap();
                let t = closest.triangle as usize;
                if ((p - closest.point).dot(mesh.normals[t]) < 0.0) != inside {
                    face_normal_wrong += 1;
                }
            }
        }
        println!(
            "{checked} points near the surface: the closest face's normal misjudged \
             {face_normal_wrong}, the pseudo-normals none"
        );
        assert!(checked > 1000);
    }

    #[test]
    fn a_mesh_is_closed_only_when_every_edge_joins_two_opposite_triangles() {
        let mut rng = Rng(5);
        let (v, idx) = dented_sphere(&mut rng, 7, 10, 0.1);
        assert!(TriMesh::new(&v, &idx).unwrap().is_closed());
        // A hole.
        assert!(!TriMesh::new(&v, &idx[3..]).unwrap().is_closed());
        // One triangle turned over.
        let mut flipped = idx.clone();
        flipped.swap(7, 8);
        assert!(!TriMesh::new(&v, &flipped).unwrap().is_closed());
        // A closed sphere has no thin vertex; an open sheet's rim is thin.
        assert_eq!(TriMesh::new(&v, &idx).unwrap().thin_vertex_count(), 0);
        let (g, gi) = bumpy_grid(9);
        assert_eq!(TriMesh::new(&g, &gi).unwrap().thin_vertex_count(), 4 * 8);
    }

    #[test]
    fn meshes_split_at_their_seams_are_welded_into_one_closed_surface() {
        // Bevy's cuboid: four vertices of its own per face (24 in all, no edge shared).
        let cuboid = bevy::mesh::Mesh::from(bevy::math::primitives::Cuboid::new(1.0, 2.0, 0.5));
        let (v, idx) = crate::mesh::mesh_triangles(&cuboid).unwrap();
        assert_eq!(v.len(), 24);
        let mesh = TriMesh::new(&v, &idx).unwrap();
        assert!(mesh.is_closed());
        assert_eq!(mesh.thin_vertex_count(), 0);
        let shape = crate::collide::SolverShape::TriangleMesh(std::sync::Arc::new(mesh));
        let (d, n) = shape
            .signed_distance(Vec3A::new(0.3, 0.9, 0.0), 1.0)
            .unwrap();
        assert!(
            (d + 0.1).abs() < 1e-5 && n.abs_diff_eq(Vec3A::Y, 1e-5),
            "{d} {n}"
        );
        // A UV sphere, split along its seam and at its poles.
        let sphere = bevy::mesh::Mesh::from(bevy::math::primitives::Sphere::new(0.5));
        let (v, idx) = crate::mesh::mesh_triangles(&sphere).unwrap();
        assert!(TriMesh::new(&v, &idx).unwrap().is_closed());
    }

    #[test]
    fn an_open_mesh_has_no_inside() {
        let mut rng = Rng(8);
        let (v, idx) = dented_sphere(&mut rng, 10, 16, 0.05);
        // Cut the bottom cap off: points inside are behind the nearest triangle, not inside.
        let open: Vec<u32> = idx
            .chunks_exact(3)
            .filter(|t| t.iter().any(|&i| v[i as usize].y > -0.5))
            .flatten()
            .copied()
            .collect();
        let shape = crate::collide::SolverShape::TriangleMesh(std::sync::Arc::new(
            TriMesh::new(&v, &open).unwrap(),
        ));
        let mut found = 0;
        for _ in 0..2000 {
            let p = point(&mut rng, 1.0);
            if let Some((d, _)) = shape.signed_distance(p, 0.2) {
                assert!(d >= 0.0, "{p}: {d}");
                found += 1;
            }
        }
        assert!(found > 100);
    }

    #[test]
    fn a_cone_tip_and_a_fin_ridge_are_thin() {
        // A closed cone, 10 degrees half-angle: its tip is thin, its base is not.
        let segments = 12;
        let mut v = vec![Vec3::Y, Vec3::ZERO];
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            v.push(Vec3::new(phi.cos(), 0.0, phi.sin()) * 10f32.to_radians().tan());
        }
        let mut idx = Vec::new();
        for s in 0..segments {
            let (a, b) = (2 + s, 2 + (s + 1) % segments);
            idx.extend_from_slice(&[0, b, a, 1, a, b]);
        }
        let cone = TriMesh::new(&v, &idx).unwrap();
        assert!(cone.is_closed());
        let thin: Vec<Vec3A> = cone.thin_vertices().collect();
        assert!(thin.contains(&Vec3A::Y), "{thin:?}");
        assert!(!thin.contains(&Vec3A::ZERO));
    }

    #[test]
    fn the_first_crossing_is_the_nearest_a_brute_force_search_finds() {
        let (v, idx) = bumpy_grid(13);
        let mesh = TriMesh::new(&v, &idx).unwrap();
        let mut rng = Rng(77);
        let mut hits = 0;
        for _ in 0..2000 {
            let from = point(&mut rng, 0.7) + Vec3A::new(0.5, 0.0, 0.5);
            let to = point(&mut rng, 0.7) + Vec3A::new(0.5, 0.0, 0.5);
            let brute = idx
                .chunks_exact(3)
                .filter_map(|t| {
                    let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3A::from(v[i as usize]));
                    segment_crosses_triangle(from, to - from, a, b, c)
                })
                .fold(None, |best: Option<f32>, s| {
                    Some(best.map_or(s, |b| b.min(s)))
                });
            let found = mesh.first_crossing(from, to, false);
            assert_eq!(brute.is_some(), found.is_some(), "{from} -> {to}");
            if let (Some(s), Some(crossing)) = (brute, found) {
                hits += 1;
                // The crossing's plane meets the segment where brute force did, and its
                // normal faces where the segment came from.
                let point = from + (to - from) * s;
                assert!((point - crossing.plane_point).dot(crossing.normal).abs() < 1e-4);
                assert!((from - point).dot(crossing.normal) >= -1e-6);
            }
        }
        assert!(hits > 100, "{hits}");
    }

    #[test]
    fn bad_meshes_are_refused() {
        assert_eq!(TriMesh::new(&[], &[]), Err(ColliderError::EmptyMesh));
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(matches!(
            TriMesh::new(&v, &[0, 1, 5]),
            Err(ColliderError::IndexOutOfRange { index: 5, .. })
        ));
        assert!(matches!(
            TriMesh::new(&[Vec3::NAN, Vec3::X, Vec3::Y], &[0, 1, 2]),
            Err(ColliderError::NonFiniteVertex { vertex: 0 })
        ));
        assert_eq!(
            TriMesh::new(&[Vec3::ZERO, Vec3::X, Vec3::X * 2.0], &[0, 1, 2]),
            Err(ColliderError::EmptyMesh)
        );
    }
}
