//! The bounding-volume hierarchy of a [`TriMesh`]: its build (median split along the longest
//! axis of the triangle centroids, the triangles stored in leaf order) and its queries (the
//! closest point within a distance, the first triangle a segment crosses).

use bevy::math::Vec3A;

use super::tree::{Aabb, Node};
use super::{
    ClosestPoint, Crossing, TriMesh, TriangleFeature, closest_point_on_triangle,
    segment_crosses_triangle,
};

/// Triangles per leaf, at most.
const LEAF_SIZE: usize = 4;

impl TriMesh {
    /// The bounds of the whole mesh.
    pub(crate) fn bounds(&self) -> Aabb {
        self.nodes[0].bounds
    }

    fn triangle_bounds(&self, t: usize) -> Aabb {
        self.triangles[t]
            .iter()
            .fold(Aabb::EMPTY, |b, &i| b.grown(self.vertices[i as usize]))
    }

    pub(super) fn build(&mut self) {
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

    /// Appends to `out` the index of every vertex inside `bounds` (a vertex of several
    /// triangles may come more than once).
    pub(crate) fn vertices_in(&self, bounds: &Aabb, out: &mut Vec<u32>) {
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = self.nodes[stack[top] as usize];
            if !node.bounds.overlaps(bounds) {
                continue;
            }
            if node.count > 0 {
                for t in node.start..node.start + node.count {
                    for i in self.triangles[t as usize] {
                        if bounds.contains(self.vertices[i as usize]) {
                            out.push(i);
                        }
                    }
                }
            } else if top + 2 <= stack.len() {
                stack[top] = node.right;
                stack[top + 1] = node.start;
                top += 2;
            }
        }
    }

    /// The position of vertex `i`.
    pub(crate) fn vertex(&self, i: u32) -> Vec3A {
        self.vertices[i as usize]
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
