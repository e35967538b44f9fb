//! Triangle-mesh colliders: a bounding-volume hierarchy over the triangles and the closest
//! point query on it.

use bevy::math::{Vec3, Vec3A};

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

    /// Whether `p` is inside (boundary included).
    #[inline(always)]
    pub(crate) fn contains(&self, p: Vec3A) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
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

/// A triangle mesh with a bounding-volume hierarchy (median split along the longest axis of
/// the triangle centroids), for closest-point queries.
#[derive(Clone, Debug, PartialEq)]
pub struct TriMesh {
    vertices: Vec<Vec3A>,
    triangles: Vec<[u32; 3]>,
    /// Unit face normals (counter-clockwise front).
    normals: Vec<Vec3A>,
    nodes: Vec<Node>,
}

/// The closest point of a [`TriMesh`] to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ClosestPoint {
    /// The point on the mesh.
    pub point: Vec3A,
    /// The triangle it is on.
    pub triangle: u32,
    /// That triangle's unit normal.
    pub normal: Vec3A,
    /// The distance from the query point.
    pub distance: f32,
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
        let vertices: Vec<Vec3A> = vertices.iter().map(|&v| v.into()).collect();
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
            nodes: Vec::new(),
        };
        mesh.build();
        Ok(mesh)
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
                    let [a, b, c] = self.triangles[t as usize].map(|i| self.vertices[i as usize]);
                    let q = closest_point_on_triangle(p, a, b, c);
                    let d_sq = q.distance_squared(p);
                    if d_sq <= best_sq {
                        best_sq = d_sq;
                        best = Some(ClosestPoint {
                            point: q,
                            triangle: t,
                            normal: self.normals[t as usize],
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
}

/// The point of triangle `abc` closest to `p` (Ericson, Real-Time Collision Detection,
/// section 5.1.5: the Voronoi regions of the vertices, then the edges, then the face).
pub(crate) fn closest_point_on_triangle(p: Vec3A, a: Vec3A, b: Vec3A, c: Vec3A) -> Vec3A {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let mut seed = 12345u32;
        let mut rand = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        for _ in 0..500 {
            let p = Vec3A::new(rand() * 1.4 - 0.2, rand() * 0.8 - 0.4, rand() * 1.4 - 0.2);
            let brute = idx
                .chunks_exact(3)
                .map(|t| {
                    let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3A::from(v[i as usize]));
                    closest_point_on_triangle(p, a, b, c).distance(p)
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
            let q = closest_point_on_triangle(p, a, b, c);
            assert!(q.distance(expected) < 1e-6, "{p}: {q} vs {expected}");
        }
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
