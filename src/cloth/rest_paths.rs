//! Distances along a cloth in its rest shape, for the tethers to pins: an inextensible cloth
//! can never be farther from a pin than along the cloth, so a tether of exactly that length
//! only forbids what the edges forbid, from any rest shape.
//!
//! On a flat mesh whose outline is one convex loop the distance along the cloth is the
//! straight one. On a flat mesh with holes or a concave outline it is the straight one
//! where the straight segment crosses no boundary edge. Elsewhere (a hole or a notch in the
//! way, a curved or folded rest shape, a chain of edges without triangles) it is the shortest
//! path over the edges (Dijkstra), which is never shorter than the distance along the
//! cloth: the tether is then looser than it could be, never tighter (a rope built as a V
//! and pinned at both ends hangs into its catenary).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use bevy::math::{Vec2, Vec3};

use super::model::{ClothModel, boundary_edges};

/// Where the straight rest distance is the distance along the cloth.
#[derive(Clone, Debug)]
enum Straight {
    /// Everywhere: a flat mesh with one convex outline.
    Always,
    /// Where the segment crosses none of these boundary edges (particle pairs; the
    /// particles' positions in the mesh's plane are `flat`).
    Unless {
        boundary: Vec<[u32; 2]>,
        flat: Vec<Vec2>,
    },
    /// Nowhere: not flat, or no triangles.
    Never,
}

/// The mesh's edges as an adjacency list, and where straight distances hold.
#[derive(Clone, Debug)]
pub(crate) struct RestPaths {
    /// Neighbours of particle `v`: `neighbours[start[v]..start[v + 1]]`, with edge lengths.
    start: Vec<u32>,
    neighbours: Vec<(u32, f32)>,
    straight: Straight,
}

impl RestPaths {
    /// The rest paths of `model`.
    pub(crate) fn new(model: &ClothModel) -> Self {
        let rest = &model.rest_positions;
        let n = rest.len();
        let mut start = vec![0u32; n + 1];
        for e in &model.edges {
            for p in e.particles {
                start[p as usize + 1] += 1;
            }
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        let mut fill = start.clone();
        let mut neighbours = vec![(0u32, 0.0f32); start[n] as usize];
        for e in &model.edges {
            let [a, b] = e.particles;
            neighbours[fill[a as usize] as usize] = (b, e.rest_length);
            fill[a as usize] += 1;
            neighbours[fill[b as usize] as usize] = (a, e.rest_length);
            fill[b as usize] += 1;
        }
        let straight = straight_segments(model);
        Self {
            start,
            neighbours,
            straight,
        }
    }

    /// The distance along the cloth in its rest shape `rest` from `source` to every particle
    /// (infinite for particles no edge path reaches), into `out`.
    pub(crate) fn from(&self, rest: &[Vec3], source: u32, out: &mut Vec<f32>) {
        let n = rest.len();
        out.clear();
        out.resize(n, f32::INFINITY);
        if source as usize >= n {
            return;
        }
        // Dijkstra; non-negative f32 order as their bits do.
        let mut heap = BinaryHeap::new();
        out[source as usize] = 0.0;
        heap.push(Reverse((0u32, source)));
        while let Some(Reverse((bits, v))) = heap.pop() {
            let d = f32::from_bits(bits);
            if d > out[v as usize] {
                continue;
            }
            let range = self.start[v as usize] as usize..self.start[v as usize + 1] as usize;
            for &(u, length) in &self.neighbours[range] {
                let through = d + length;
                if through < out[u as usize] {
                    out[u as usize] = through;
                    heap.push(Reverse((through.to_bits(), u)));
                }
            }
        }
        let s = rest[source as usize];
        for (i, d) in out.iter_mut().enumerate() {
            if !d.is_finite() {
                continue;
            }
            let straight = match &self.straight {
                Straight::Always => true,
                Straight::Never => false,
                Straight::Unless { boundary, flat } => {
                    !crosses_boundary(flat[source as usize], flat[i], boundary, flat)
                }
            };
            if straight {
                // The distance along a flat cloth where the straight line stays on it.
                *d = s.distance(rest[i]);
            }
        }
    }
}

/// Whether the segment `a b` crosses the boundary: through the inside of a boundary edge, or
/// through a boundary vertex whose two boundary edges lie on opposite sides of it (passing
/// by a vertex, or running along an edge, is not crossing).
fn crosses_boundary(a: Vec2, b: Vec2, boundary: &[[u32; 2]], flat: &[Vec2]) -> bool {
    let length = (b - a).length();
    if length <= 0.0 {
        return false;
    }
    let eps = 1e-6 * length;
    // Signed distance from the line a b, and where along the segment (0 at a, 1 at b).
    let side = |p: Vec2| (b - a).perp_dot(p - a) / length;
    let along = |p: Vec2| (p - a).dot(b - a) / (length * length);
    let on_segment = |p: Vec2| side(p).abs() <= eps && along(p) > 1e-6 && along(p) < 1.0 - 1e-6;
    for &[i, j] in boundary {
        let (c, d) = (flat[i as usize], flat[j as usize]);
        let (sc, sd) = (side(c), side(d));
        if (sc > eps && sd < -eps) || (sc < -eps && sd > eps) {
            // The edge's line crosses a b's: inside the segment a b and inside the edge?
            let t = sc / (sc - sd);
            let x = c + (d - c) * t;
            let u = along(x);
            if u > 1e-6 && u < 1.0 - 1e-6 {
                return true;
            }
        }
    }
    // Through a vertex: its boundary neighbours on both sides.
    for &[i, j] in boundary {
        for (v, w) in [(i, j), (j, i)] {
            if !on_segment(flat[v as usize]) {
                continue;
            }
            let sw = side(flat[w as usize]);
            let opposite = boundary.iter().any(|&[p, q]| {
                let other = if p == v {
                    q
                } else if q == v {
                    p
                } else {
                    return false;
                };
                other != w && side(flat[other as usize]) * sw < -eps * eps
            });
            if opposite {
                return true;
            }
        }
    }
    false
}

/// Where straight rest distances are distances along the cloth (see the module docs).
fn straight_segments(model: &ClothModel) -> Straight {
    let rest = &model.rest_positions;
    let none = Straight::Never;
    // The plane of the largest triangle; flat if every particle is within a thousandth of
    // the mesh's size of it.
    let Some(&[a, b, c]) = model.triangles.iter().max_by(|s, t| {
        let area = |[a, b, c]: [u32; 3]| {
            let p = [a, b, c].map(|i| rest[i as usize]);
            (p[1] - p[0]).cross(p[2] - p[0]).length_squared()
        };
        area(**s).total_cmp(&area(**t))
    }) else {
        return none;
    };
    let (p0, p1, p2) = (rest[a as usize], rest[b as usize], rest[c as usize]);
    let normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
    if normal == Vec3::ZERO {
        return none;
    }
    let x = (p1 - p0).normalize();
    let y = normal.cross(x);
    let size = rest
        .iter()
        .map(|p| p.distance(p0))
        .fold(0.0f32, f32::max)
        .max(1e-6);
    if rest
        .iter()
        .any(|p| (*p - p0).dot(normal).abs() > 1e-3 * size)
    {
        return none;
    }
    let at = |p: Vec3| Vec2::new((p - p0).dot(x), (p - p0).dot(y));
    let boundary: Vec<[u32; 2]> = boundary_edges(&model.triangles)
        .into_iter()
        .map(|(side, _)| side)
        .collect();
    let flat: Vec<Vec2> = rest.iter().map(|&p| at(p)).collect();
    let segments: Vec<[Vec2; 2]> = boundary
        .iter()
        .map(|&[a, b]| [flat[a as usize], flat[b as usize]])
        .collect();
    // One convex outline: every boundary vertex on one side of every boundary edge (a hole's
    // edge has the outline on both sides).
    let vertices: Vec<Vec2> = segments.iter().flatten().copied().collect();
    let convex = segments.iter().all(|&[c, d]| {
        let eps = 1e-5 * size * (d - c).length();
        let (mut left, mut right) = (false, false);
        for &v in &vertices {
            let o = (d - c).perp_dot(v - c);
            left |= o > eps;
            right |= o < -eps;
        }
        !(left && right)
    });
    if convex {
        Straight::Always
    } else {
        Straight::Unless { boundary, flat }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::garment::PonchoDesc;
    use crate::cloth::model::GridDesc;

    fn lengths_from(model: &ClothModel, source: u32) -> Vec<f32> {
        let mut out = Vec::new();
        RestPaths::new(model).from(&model.rest_positions, source, &mut out);
        out
    }

    #[test]
    fn on_a_flat_grid_the_distance_along_the_cloth_is_the_straight_one() {
        let grid = GridDesc::square(1.0, 9, Vec3::new(0.3, 1.0, -0.2));
        let model = ClothModel::grid(&grid, 0.1).unwrap();
        for source in [0, 40, 8] {
            let along = lengths_from(&model, source);
            for (i, d) in along.iter().enumerate() {
                let straight =
                    model.rest_positions[source as usize].distance(model.rest_positions[i]);
                assert_eq!(*d, straight);
            }
        }
    }

    #[test]
    fn across_a_hole_the_distance_goes_round_it_and_never_below_the_geodesic() {
        // The poncho: a 1.3 m square with a hole of radius 0.3 m in the middle.
        let mesh = PonchoDesc {
            neck_radius: 0.3,
            ..PonchoDesc::default()
        }
        .mesh()
        .unwrap();
        let model = ClothModel::from_triangles(&mesh.positions, &mesh.indices, 0.25).unwrap();
        let rest = &model.rest_positions;
        // The particles nearest (-0.4, 0) and (0.4, 0): the hole lies between them.
        let nearest = |x: f32| {
            (0..rest.len())
                .min_by(|&a, &b| {
                    let d = |i: usize| rest[i].distance(Vec3::new(x, 0.0, 0.0));
                    d(a).total_cmp(&d(b))
                })
                .unwrap()
        };
        let (a, b) = (nearest(-0.4), nearest(0.4));
        let along = lengths_from(&model, a as u32);
        let straight = rest[a].distance(rest[b]);
        // Round the hole: at least the straight lines to the circle's tangent points and
        // the arc between them, for a hole of radius 0.3 seen from 0.4 away on each side.
        let (r, d) = (0.3f32, rest[a].length().min(rest[b].length()));
        let tangent = (d * d - r * r).sqrt();
        let arc = r * (std::f32::consts::PI - 2.0 * (r / d).acos());
        let geodesic_lower_bound = 2.0 * tangent + arc;
        assert!(
            along[b] >= geodesic_lower_bound * 0.999,
            "{} < {geodesic_lower_bound}",
            along[b]
        );
        assert!(
            along[b] > straight * 1.3,
            "{} vs straight {straight}",
            along[b]
        );
        // Where nothing is in the way it is still the straight distance: along an edge row.
        let c = nearest(-0.6);
        assert_eq!(along[c], rest[a].distance(rest[c]));
    }

    #[test]
    fn a_chain_and_a_folded_sheet_take_the_path_over_their_edges() {
        // A V of 4 edges of length 1: the distance from one end to the other is 4.
        let h = 3f32.sqrt() / 2.0;
        let v = [
            Vec3::ZERO,
            Vec3::new(0.5, -h, 0.0),
            Vec3::new(1.0, -2.0 * h, 0.0),
            Vec3::new(1.5, -h, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
        ];
        let edges: Vec<[u32; 2]> = (0..4).map(|k| [k, k + 1]).collect();
        let chain = ClothModel::from_particles(&v, &[1.0; 5], &edges).unwrap();
        let along = lengths_from(&chain, 0);
        assert!((along[4] - 4.0).abs() < 1e-5, "{along:?}");
        // A grid folded along its middle row into a right angle: not flat, so corner to
        // corner across the fold goes over the edges, longer than the straight line.
        let grid = GridDesc::square(1.0, 5, Vec3::ZERO);
        let mut model = ClothModel::grid(&grid, 0.1).unwrap();
        for p in &mut model.rest_positions {
            if p.z > 0.5 {
                *p = Vec3::new(p.x, p.z - 0.5, 0.5);
            }
        }
        let along = lengths_from(&model, 0);
        let far = grid.index(0, 4) as usize;
        let straight = model.rest_positions[0].distance(model.rest_positions[far]);
        assert!(
            (along[far] - 1.0).abs() < 1e-5 && straight < 0.75,
            "{} {straight}",
            along[far]
        );
    }
}
