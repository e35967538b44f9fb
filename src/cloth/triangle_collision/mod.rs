//! Triangle self-collision: every particle of a cloth is kept on its side of the cloth's own
//! triangles near it, at the cloth's thickness `h`, by the vertex-triangle constraint of
//! Müller et al. 2006 ("Position based dynamics", section 4.4). With `q` the particle, `p_k`
//! the triangle's corners, `n` its unit normal and `b_k` the barycentric coordinates of `q`'s
//! projection onto its plane,
//!
//! `C = s n . (q - p_1) - h >= 0`, gradients `s n` for `q` and `-s b_k n` for `p_k`,
//!
//! projected like any inequality constraint: `lambda = -C / (w_q + sum_k w_k b_k^2)`, `q` moved
//! by `w_q lambda s n` and `p_k` by `-w_k b_k lambda s n` (the momentum moved is
//! `lambda s n (1 - sum_k b_k) = 0`). It acts only while the projection lies over the triangle.
//! The cloth's rim is rounded by the thickness: a particle beyond a border edge of the
//! triangle (an edge of no other triangle) is kept `h` from that edge, the particle and the
//! edge's ends moved apart along the line between them, so that it cannot slip round the rim
//! closer than that (within one step, a slip round the rim is a pass through the triangle).
//!
//! `s` is the side the particle is kept on, and it is not read off the current positions: a
//! fold that brings a particle through a triangle within one substep would flip it. A pair
//! found for the first time takes the side the particle is on when the step starts, and a pair
//! already found in the step before keeps the side it had then. At the start of every substep
//! a particle not over its triangle takes the side it is on (it may have gone round the
//! triangle's edge). A particle found over its triangle on the other side went through it if
//! it was on that side at the substep's start already (a crossing not yet put right), or if
//! its straight path since then met the moving plane over the triangle (or within a quarter of
//! it, [`THROUGH_SLACK`]): it is brought back to the side it came from. Otherwise it went
//! round the triangle's edge within the substep, and takes the side it is on.
//!
//! Candidates are found once per fixed step: a particle and a triangle it is not a corner of,
//! the particle within `h` plus both their travels of the triangle's plane and of the
//! triangle's edges (`t_i`, how far particle `i` moves relative to the cloth's common motion
//! in the step, as the particle method finds it, at most twice the longest edge). The particles are
//! sorted into a grid (`grid.rs`) and each triangle looks at the cells its grown box covers.
//! At the start of each substep the candidates are narrowed to those that can come within `h`
//! of their triangle in it, and those are projected in every iteration.
//!
//! Friction between the particle and the triangle is Coulomb friction on positions (Macklin
//! et al. 2014), measured from an **anchor**: the point of the triangle, in its barycentric
//! coordinates, where friction last held the particle. In every projection the particle's
//! tangential offset from its anchor is undone if it is within what the substep's friction
//! has left (`mu` times the normal push the pair has had in the substep so far, less what
//! friction took already in it: static), else shortened by that much (kinetic), and a pair
//! that slid takes the point it starts the next substep from as its anchor. A pair touching
//! for the first time anchors where the particle began the substep. The anchor moves with the
//! triangle and is kept from step to step while the two touch (a particle near a shared edge
//! keeps its anchor on both triangles: forgetting it whenever the particle's projection left
//! a triangle let a sheet resting on another creep off it), so the small slides the cloth's
//! own constraints give a resting particle after each projection do not add up, and a
//! substep's pushes count together whichever iteration gave them. A pair that parts (more
//! than [`PARTED`] times the thickness apart, or out of reach), changes side or whose
//! triangle is degenerate forgets its anchor.

use bevy::math::Vec3A;

use super::constraints::friction_removed;
use super::grid::{Grid, relative_travel, sort_into_cells};
use crate::collide::vertex_contacts::plane_coordinates;

/// A particle kept on one side of a triangle of its own cloth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexTriangle {
    /// The particle.
    pub particle: u32,
    /// The triangle's index in the model's triangles.
    pub triangle: u32,
    /// `1` or `-1`: the side of the triangle's plane the particle is kept on, along the
    /// normal `(p_2 - p_1) x (p_3 - p_1)`.
    pub side: f32,
    /// Where on the triangle friction holds the particle: the barycentric coordinates
    /// `(b_2, b_3)` of its anchor, carried with the triangle (see the module docs); `None`
    /// once the two have parted, after a slide, and before their first touch.
    pub anchor: Option<[f32; 2]>,
    /// The normal push the pair's projections gave in the current substep, m.
    pushed: f32,
    /// The tangential motion friction has taken away in the current substep, m.
    spent: f32,
    /// Whether friction let the particle slide in the pair's last projection.
    slid: bool,
}

impl VertexTriangle {
    fn key(&self) -> u64 {
        (u64::from(self.particle) << 32) | u64::from(self.triangle)
    }
}

/// The least distance kept between a particle and a triangle, in mean edge lengths of the
/// cloth's triangles: a coarse cloth's corrections within a substep (its edges', its bending's)
/// move particles a good part of an edge, and a thinner gap lets them through.
pub(crate) const GAP_PER_EDGE: f32 = 0.375;

/// Most grid cells per particle.
const MAX_CELLS_PER_PARTICLE: usize = 8;

/// How far outside its triangle (in barycentric coordinates) a particle's projection may be
/// and still be held: a particle over a shared edge is held by both triangles.
const OVER_SLACK: f32 = 1e-3;

/// How far outside its triangle (in barycentric coordinates) a particle that changes side may
/// pass and still be taken to have gone through it: a particle passing the shared edge of two
/// triangles goes through one or the other, and counts for both.
const THROUGH_SLACK: f32 = 0.25;

/// How far apart, in thicknesses, a particle and a triangle have parted: the pair forgets its
/// friction anchor. A resting particle is pushed to the thickness and left a little over it by
/// the constraints after the push: it still touches.
const PARTED: f32 = 1.25;

/// The triangle self-collision tables of one cloth: its triangles, the grid and the candidate
/// pairs of the current step, with their sides. Built once; stepping reuses its memory.
#[derive(Clone, Debug)]
pub struct TriangleSelfCollision {
    triangles: Vec<[u32; 3]>,
    /// Per triangle, bit `k` set when its edge opposite corner `k` is on the cloth's border
    /// (in no other triangle).
    border: Vec<u8>,
    longest_edge: f32,
    /// [`GAP_PER_EDGE`] times the mean edge length.
    least_gap: f32,
    thickness: f32,
    travel: Vec<f32>,
    cell_start: Vec<u32>,
    cell_entries: Vec<u32>,
    cell_of: Vec<u32>,
    /// The current step's candidates, sorted by particle, then triangle.
    candidates: Vec<VertexTriangle>,
    /// The step before's, to carry the sides and the friction anchors over.
    previous: Vec<VertexTriangle>,
    /// The candidates that can come within the thickness in the current substep (indices
    /// into `candidates`).
    near: Vec<u32>,
    /// Each triangle's plane at the start of the current substep (`None`: degenerate).
    planes: Vec<Option<Plane>>,
}

impl TriangleSelfCollision {
    /// The tables for a cloth of `particles` particles and these `triangles` (rest positions
    /// `rest`, for the longest edge). `None` when there is no particle or no triangle.
    pub fn new(rest: &[bevy::math::Vec3], triangles: &[[u32; 3]]) -> Option<Self> {
        let n = rest.len();
        let triangles: Vec<[u32; 3]> = triangles
            .iter()
            .copied()
            .filter(|t| t.iter().all(|&i| (i as usize) < n))
            .collect();
        if n == 0 || triangles.is_empty() {
            return None;
        }
        let (longest_edge, sum, count) = triangles
            .iter()
            .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
            .map(|(i, j)| rest[i as usize].distance(rest[j as usize]))
            .filter(|l| l.is_finite())
            .fold((0.0f32, 0.0, 0usize), |(longest, sum, count), l| {
                (longest.max(l), sum + l, count + 1)
            });
        // Each inner edge is counted twice, which leaves the mean as it is on a regular mesh.
        let least_gap = GAP_PER_EDGE * sum / count.max(1) as f32;
        let border = border_edges(&triangles);
        Some(Self {
            triangles,
            border,
            longest_edge,
            least_gap,
            thickness: 0.0,
            travel: vec![0.0; n],
            cell_start: Vec::with_capacity(MAX_CELLS_PER_PARTICLE * n + 2),
            cell_entries: vec![0; n],
            cell_of: vec![0; n],
            candidates: Vec::with_capacity(4 * n),
            previous: Vec::with_capacity(4 * n),
            near: Vec::with_capacity(n),
            planes: Vec::new(),
        })
    }

    /// The candidate pairs of the current step, sorted by particle, then triangle.
    pub fn candidates(&self) -> &[VertexTriangle] {
        &self.candidates
    }

    /// Finds the pairs of the coming step from the positions `x` and velocities `v` at its
    /// start, for a step of `dt` under an acceleration of magnitude `acceleration`, with the
    /// particles kept `thickness` from the triangles (see the module docs). Non-finite
    /// particles and triangles are in no pair.
    pub fn find_pairs(
        &mut self,
        x: &[Vec3A],
        v: &[Vec3A],
        dt: f32,
        acceleration: f32,
        thickness: f32,
    ) {
        std::mem::swap(&mut self.previous, &mut self.candidates);
        self.candidates.clear();
        self.near.clear();
        self.thickness = if thickness.is_finite() {
            thickness.max(self.least_gap)
        } else {
            self.least_gap
        };
        let n = x.len().min(v.len()).min(self.travel.len());
        if n == 0 {
            return;
        }
        let cap = 2.0 * self.longest_edge;
        let max_travel = relative_travel(&mut self.travel, &v[..n], dt, acceleration, cap);
        let reach = self.thickness + 2.0 * max_travel;
        let Some(grid) = Grid::new(
            &x[..n],
            self.longest_edge.max(reach),
            MAX_CELLS_PER_PARTICLE * n,
        ) else {
            return;
        };
        let cells = (
            &mut self.cell_of[..],
            &mut self.cell_start,
            &mut self.cell_entries[..],
        );
        sort_into_cells(&grid, &x[..n], cells, None);
        let dims = bevy::math::UVec3::from_array(grid.dims);
        for (index, &corners) in self.triangles.iter().enumerate() {
            let [a, b, c] = corners.map(|i| i as usize);
            if a >= n || b >= n || c >= n {
                continue;
            }
            let (pa, pb, pc) = (x[a], x[b], x[c]);
            let Some(frame) = TriangleFrame::new(pa, pb, pc) else {
                continue;
            };
            let corner_travel = self.travel[a].max(self.travel[b]).max(self.travel[c]);
            let grow = self.thickness + corner_travel + max_travel;
            let low = pa.min(pb).min(pc) - Vec3A::splat(grow);
            let high = pa.max(pb).max(pc) + Vec3A::splat(grow);
            let cell_of = |p: Vec3A| {
                ((p - grid.origin) * grid.inv_cell)
                    .max(Vec3A::ZERO)
                    .floor()
                    .as_uvec3()
                    .min(dims - 1)
            };
            let (first, last) = (cell_of(low), cell_of(high));
            for cz in first.z..=last.z {
                for cy in first.y..=last.y {
                    let row = grid.index([0, cy, cz]);
                    let from = self.cell_start[(row + first.x) as usize];
                    let to = self.cell_start[(row + last.x) as usize + 1];
                    for &q in &self.cell_entries[from as usize..to as usize] {
                        let qi = q as usize;
                        if corners.contains(&q) {
                            continue;
                        }
                        let r = self.thickness + corner_travel + self.travel[qi];
                        if frame.within(x[qi], r) {
                            self.candidates.push(VertexTriangle {
                                particle: q,
                                triangle: index as u32,
                                side: 0.0,
                                anchor: None,
                                pushed: 0.0,
                                spent: 0.0,
                                slid: false,
                            });
                        }
                    }
                }
            }
        }
        self.candidates.sort_unstable_by_key(VertexTriangle::key);
        // The sides and anchors: carried over from the step before, else the side the particle
        // is on now (and no anchor).
        let mut previous = self.previous.iter().peekable();
        for pair in &mut self.candidates {
            let key = pair.key();
            while previous.next_if(|p| p.key() < key).is_some() {}
            if let Some(p) = previous.next_if(|p| p.key() == key) {
                pair.side = p.side;
                pair.anchor = p.anchor;
                pair.slid = p.slid;
            } else {
                let [a, b, c] = self.triangles[pair.triangle as usize].map(|i| x[i as usize]);
                pair.side = side_of(x[pair.particle as usize], a, b, c).unwrap_or(1.0);
            }
        }
    }

    /// A substep begins from the positions `x_prev`: a particle not over its triangle takes
    /// the side it is on (it may have gone round the triangle's edge), and the pairs that can
    /// come within the thickness in this substep (one of `substeps`), or are on the other
    /// side, are kept for [`Self::project`].
    pub fn begin_substep(&mut self, x_prev: &[Vec3A], substeps: u32) {
        let share = 1.0 / substeps.max(1) as f32;
        let h = self.thickness;
        self.near.clear();
        // Each triangle's plane once: a triangle is in several pairs.
        self.planes.clear();
        self.planes.extend(self.triangles.iter().map(|t| {
            let [a, b, c] = t.map(|i| x_prev.get(i as usize).copied().unwrap_or(Vec3A::NAN));
            Plane::new(a, b, c)
        }));
        for (index, pair) in self.candidates.iter_mut().enumerate() {
            let q = pair.particle as usize;
            pair.pushed = 0.0;
            pair.spent = 0.0;
            if std::mem::take(&mut pair.slid) {
                pair.anchor = None;
            }
            let Some(plane) = &self.planes[pair.triangle as usize] else {
                pair.anchor = None;
                continue;
            };
            let height = plane.height(x_prev[q]);
            // The substep's share of the two's travel, twice (the particle and the corners
            // closing in), and half the thickness for the constraints' own moves.
            let corners = self.triangles[pair.triangle as usize].map(|i| self.travel[i as usize]);
            let travel = self.travel[q] + corners[0].max(corners[1]).max(corners[2]);
            let reach = 1.5 * h + 2.0 * share * travel;
            if pair.side * height >= reach {
                // On its side and out of reach: its side is the one it is on already.
                pair.anchor = None;
                continue;
            }
            let bary = plane.barycentric(x_prev[q], height);
            if bary.min_element() < -OVER_SLACK && height != 0.0 {
                if pair.side != height.signum() {
                    pair.anchor = None;
                }
                pair.side = height.signum();
            }
            // Over the triangle, or outside its edges by no more than it can come in this
            // substep (`-b_k` times the corner's altitude, at least `|cross| / longest`).
            // A border edge holds particles beyond it too, up to the thickness.
            let margin = if self.border[pair.triangle as usize] == 0 {
                0.5 * h
            } else {
                1.5 * h
            };
            let outside = (2.0 * share * travel + margin) * self.longest_edge / plane.length;
            if pair.side * height < reach && bary.min_element() > -outside.max(OVER_SLACK) {
                self.near.push(index as u32);
            }
        }
    }

    /// Projects the substep's pairs (see the module docs): every particle over its triangle
    /// and closer than the thickness on its side (or on the other side) is moved out, the
    /// particle and the triangle's corners in the ratio of their inverse masses `w`, with
    /// Coulomb friction on the particle's offset from its anchor on the triangle (or, at a
    /// first touch, on the relative motion since the substep began, `x_prev`). With
    /// `velocities`, each correction `dx` also adds `dx * inv_h` to the velocity (for solvers
    /// that do not derive velocities from positions). Returns how many pairs were held.
    pub fn project(
        &mut self,
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        w: &[f32],
        friction: f32,
        mut velocities: Option<(&mut [Vec3A], f32)>,
    ) -> usize {
        let h = self.thickness;
        let mut held = 0;
        for &index in &self.near {
            let pair = &mut self.candidates[index as usize];
            let q = pair.particle as usize;
            let corners = self.triangles[pair.triangle as usize].map(|i| i as usize);
            let [a, b, c] = corners;
            let Some(plane) = Plane::new(x[a], x[b], x[c]) else {
                continue;
            };
            let height = plane.height(x[q]);
            let mut distance = pair.side * height;
            if distance >= h {
                if distance >= PARTED * h {
                    pair.anchor = None;
                }
                continue;
            }
            let bary = plane.barycentric(x[q], height);
            if bary.min_element() < -OVER_SLACK {
                let border = self.border[pair.triangle as usize];
                let Some((correction, ends)) = round_border(x, w, q, corners, bary, border, h)
                else {
                    continue;
                };
                held += 1;
                for (k, share) in [(q, 1.0)].into_iter().chain(ends) {
                    x[k] += correction * (w[k] * share);
                    if let Some((v, inv_h)) = velocities.as_mut() {
                        v[k] += correction * (w[k] * share * *inv_h);
                    }
                }
                continue;
            }
            let normal = plane.normal;
            if distance < 0.0 && !went_through(pair.side, [q, a, b, c].map(|i| (x_prev[i], x[i]))) {
                // Round the triangle's edge within the substep: held on the side it is on.
                pair.side = -pair.side;
                pair.anchor = None;
                distance = -distance;
            }
            let side = pair.side;
            let weights = [bary.x, bary.y, bary.z];
            let wsum = w[q]
                + w[a] * weights[0] * weights[0]
                + w[b] * weights[1] * weights[1]
                + w[c] * weights[2] * weights[2];
            if wsum <= 0.0 {
                continue;
            }
            held += 1;
            let push = normal * side;
            let penetration = h - distance;
            // The correction of the particle per unit of its inverse mass; the corners take
            // `-b_k` times it per unit of theirs.
            let mut correction = push * (penetration / wsum);
            pair.pushed += penetration;
            if friction > 0.0 {
                // The anchor, or where the particle began the substep over the triangle (on
                // the triangle's plane at the substep's start, made in `begin_substep`).
                let anchor = pair.anchor.or_else(|| {
                    let plane = self.planes[pair.triangle as usize].as_ref()?;
                    let bary = plane.barycentric(x_prev[q], plane.height(x_prev[q]));
                    bary.is_finite().then_some([bary.y, bary.z])
                });
                if let Some([u, v]) = anchor {
                    let relative = x[q] - (x[a] * (1.0 - u - v) + x[b] * u + x[c] * v);
                    // What the substep's pushes allow, less what friction took already.
                    let limit = (friction * pair.pushed - pair.spent).max(0.0);
                    let removed = friction_removed(relative, push, limit);
                    let slip = relative - push * push.dot(relative);
                    pair.slid = slip.length_squared() > limit * limit;
                    pair.spent += removed.length();
                    pair.anchor = anchor;
                    correction -= removed / wsum;
                }
            }
            x[q] += correction * w[q];
            for (&k, &b) in corners.iter().zip(&weights) {
                x[k] -= correction * (w[k] * b);
            }
            if let Some((v, inv_h)) = velocities.as_mut() {
                v[q] += correction * (w[q] * *inv_h);
                for (&k, &b) in corners.iter().zip(&weights) {
                    v[k] -= correction * (w[k] * b * *inv_h);
                }
            }
        }
        held
    }
}

/// Per triangle, the bits of its edges on the border (bit `k`: the edge opposite corner `k`).
fn border_edges(triangles: &[[u32; 3]]) -> Vec<u8> {
    let key = |i: u32, j: u32| (u64::from(i.min(j)) << 32) | u64::from(i.max(j));
    let mut edges: Vec<u64> = triangles
        .iter()
        .flat_map(|&[a, b, c]| [key(b, c), key(c, a), key(a, b)])
        .collect();
    edges.sort_unstable();
    let shared = |e: u64| {
        let first = edges.partition_point(|&x| x < e);
        edges.get(first + 1) == Some(&e)
    };
    triangles
        .iter()
        .map(|&[a, b, c]| {
            [key(b, c), key(c, a), key(a, b)]
                .iter()
                .enumerate()
                .filter(|&(_, &e)| !shared(e))
                .fold(0u8, |bits, (k, _)| bits | (1 << k))
        })
        .collect()
}

/// Keeps particle `q`, beyond a border edge of its triangle (`corners`, `bary` the
/// barycentric coordinates of its projection, `border` the triangle's border bits), at least
/// `h` from that edge: the cloth's border is rounded by its thickness, so a particle cannot
/// slip round it closer than that. The edge beyond which `q` lies farthest is the one held;
/// Returns the correction of `q` per unit of its inverse mass, and the edge's ends with their
/// shares of it (negative: they move the other way), for the caller to apply; `None` when `q`
/// is beyond no border edge or far enough from it.
fn round_border(
    x: &mut [Vec3A],
    w: &[f32],
    q: usize,
    corners: [usize; 3],
    bary: Vec3A,
    border: u8,
    h: f32,
) -> Option<(Vec3A, [(usize, f32); 2])> {
    if border == 0 {
        return None;
    }
    let bary = bary.to_array();
    // The nearest of the border edges `q` lies beyond: where on it (`t` from its first end)
    // and `q`'s offset from there.
    let (i, j, t, away) = (0..3)
        .filter(|&k| border & (1 << k) != 0 && bary[k] < -OVER_SLACK)
        .filter_map(|k| {
            let (i, j) = (corners[(k + 1) % 3], corners[(k + 2) % 3]);
            let edge = x[j] - x[i];
            let length_sq = edge.length_squared();
            (length_sq > 1e-20).then(|| {
                let t = ((x[q] - x[i]).dot(edge) / length_sq).clamp(0.0, 1.0);
                (i, j, t, x[q] - (x[i] + edge * t))
            })
        })
        .min_by(|p, r| p.3.length_squared().total_cmp(&r.3.length_squared()))?;
    let distance = away.length();
    let wsum = w[q] + w[i] * (1.0 - t) * (1.0 - t) + w[j] * t * t;
    if distance >= h || distance <= 1e-9 || wsum <= 0.0 {
        return None;
    }
    let correction = away * ((h - distance) / (distance * wsum));
    Some((correction, [(i, t - 1.0), (j, -t)]))
}

/// A triangle's plane, for a particle's height over it and, only when needed, where over
/// the triangle it is (`plane_coordinates` in two parts: most pairs are out of reach by their
/// height alone).
#[derive(Clone, Copy, Debug)]
struct Plane {
    a: Vec3A,
    ab: Vec3A,
    ac: Vec3A,
    cross: Vec3A,
    area_sq: f32,
    /// `|cross|`, twice the area.
    length: f32,
    normal: Vec3A,
}

impl Plane {
    /// The plane of `a`, `b`, `c`, if they span one.
    #[inline(always)]
    fn new(a: Vec3A, b: Vec3A, c: Vec3A) -> Option<Self> {
        let (ab, ac) = (b - a, c - a);
        let cross = ab.cross(ac);
        let area_sq = cross.length_squared();
        (area_sq >= 1e-20).then(|| {
            let length = area_sq.sqrt();
            Self {
                a,
                ab,
                ac,
                cross,
                area_sq,
                length,
                normal: cross / length,
            }
        })
    }

    /// The signed height of `q` over the plane, along the normal.
    #[inline(always)]
    fn height(&self, q: Vec3A) -> f32 {
        (q - self.a).dot(self.normal)
    }

    /// The barycentric coordinates of `q` (at `height`) projected onto the plane.
    #[inline(always)]
    fn barycentric(&self, q: Vec3A, height: f32) -> Vec3A {
        let in_plane = q - self.a - self.normal * height;
        let u = in_plane.cross(self.ac).dot(self.cross) / self.area_sq;
        let v = self.ab.cross(in_plane).dot(self.cross) / self.area_sq;
        Vec3A::new(1.0 - u - v, u, v)
    }
}

/// Whether a particle kept on `side` of a triangle, now over it on the other side, went
/// through the triangle: `[q, a, b, c]` are the particle's and the corners' positions at the
/// substep's start and now. If it was on the other side at the start already, it was over the
/// triangle then (else its side would have been taken then) and went through (a crossing not
/// yet put right); else it went through if where its straight path met the moving plane lies
/// over the triangle (within [`THROUGH_SLACK`]).
fn went_through(side: f32, [q, a, b, c]: [(Vec3A, Vec3A); 4]) -> bool {
    let height = |t: f32| {
        let at = |(start, now): (Vec3A, Vec3A)| start.lerp(now, t);
        plane_coordinates(at(q), at(a), at(b), at(c))
    };
    let Some((_, _, start)) = height(0.0) else {
        return true;
    };
    let (Some((_, _, now)), true) = (height(1.0), side * start > 0.0) else {
        return true;
    };
    let tau = start / (start - now);
    height(tau).is_none_or(|(bary, _, _)| bary.min_element() >= -THROUGH_SLACK)
}

/// The side of the plane of `a, b, c` that `q` is on: `Some(1.0)` along the normal
/// `(b - a) x (c - a)`, `Some(-1.0)` against it, `None` for a degenerate triangle or a point in
/// the plane.
fn side_of(q: Vec3A, a: Vec3A, b: Vec3A, c: Vec3A) -> Option<f32> {
    let height = (q - a).dot((b - a).cross(c - a));
    (height != 0.0 && height.is_finite()).then(|| height.signum())
}

/// A triangle's plane and edges, to tell whether a point is within a distance of it.
struct TriangleFrame {
    corners: [Vec3A; 3],
    low: Vec3A,
    high: Vec3A,
    normal: Vec3A,
    /// Per edge `k` (from corner `k` to corner `k + 1`): its in-plane inward normal.
    inward: [Vec3A; 3],
}

impl TriangleFrame {
    fn new(a: Vec3A, b: Vec3A, c: Vec3A) -> Option<Self> {
        let cross = (b - a).cross(c - a);
        let normal = cross.try_normalize()?;
        let corners = [a, b, c];
        let inward = [0, 1, 2].map(|k| {
            let edge = corners[(k + 1) % 3] - corners[k];
            normal.cross(edge).normalize_or_zero()
        });
        Some(Self {
            corners,
            low: a.min(b).min(c),
            high: a.max(b).max(c),
            normal,
            inward,
        })
    }

    /// Whether `q` is within `r` of the triangle's plane, no farther than `r` outside any of
    /// its edges (a prism round the triangle, grown by `r`) and within its box grown by `r`.
    fn within(&self, q: Vec3A, r: f32) -> bool {
        let [a, ..] = self.corners;
        let grow = Vec3A::splat(r);
        q.cmpge(self.low - grow).all()
            && q.cmple(self.high + grow).all()
            && (q - a).dot(self.normal).abs() <= r
            && (0..3).all(|k| (q - self.corners[k]).dot(self.inward[k]) >= -r)
    }
}

#[cfg(test)]
mod tests;
