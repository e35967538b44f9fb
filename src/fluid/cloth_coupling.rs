//! Fluid and cloth stepped together, in the same substeps and iterations, so that each
//! feels the other's inertia and the cloth's constraints carry the fluid's weight within
//! the step ([`FluidSolver::step_with_cloth`](super::FluidSolver::step_with_cloth)).
//!
//! The fluid runs inside the cloth's step (`cloth/sim/step.rs`, `SubstepCoupling`): when a
//! cloth substep of length `h` begins the fluid predicts over `h`, the cloth's triangles
//! are sorted into a hashed grid at their predicted positions (a counting sort), and each
//! fluid particle's candidates are the triangles whose bounds, grown by twice its radius,
//! hold its predicted position; in each of the cloth's
//! iterations, after its colliders and before its own constraints, the fluid projects its
//! share of its density sweeps (its budget per step spread over the cloth's iterations, at
//! least one per substep), its colliders, then the contacts with the cloth's triangles; when the
//! substep ends both take their velocities from their positions over the same `h`.
//!
//! A contact: a fluid particle of radius `r` whose projection onto a triangle's plane lies
//! inside the triangle (barycentric `b_k`), nearer the plane than `r` on the side it was on
//! when the substep began (or across it: it went through during the sweep, and is counted
//! in [`ClothContacts::crossings`]), is separated to distance `r` on that side as one
//! constraint between the particle and the triangle's three particles, by their inverse
//! masses: `dl = depth / (w_f + sum_k b_k^2 w_k)`, the fluid particle moves `w_f dl n`, each
//! cloth particle `-b_k w_k dl n`. The masses' moments cancel (`sum_k b_k = 1`), so the
//! momentum of cloth and fluid together is kept, pinned particles absorbing their share. So
//! a fine fluid cannot pass between the particles of a coarse cloth, and a light cloth is
//! pushed by heavy water only as far as its own constraints, projected right after in the
//! same iteration, let it go.

use bevy::math::Vec3A;

use super::neighbours::{bucket, cell_of};

/// The contacts between a fluid and a cloth: the cloth's triangles in a hashed grid, each
/// fluid particle's candidate triangles for the substep, and what the last step did.
#[derive(Clone, Debug, Default)]
pub struct ClothContacts {
    cell: f32,
    mask: u32,
    /// The triangles of hashed cell `b` are `entries[start[b]..start[b + 1]]`.
    start: Vec<u32>,
    entries: Vec<u32>,
    /// Each triangle's grown bounds, while sorting.
    bounds: Vec<(Vec3A, Vec3A)>,
    /// The candidate triangles of fluid particle `i` are
    /// `candidates[candidate_start[i]..candidate_start[i + 1]]`.
    candidate_start: Vec<u32>,
    candidates: Vec<u32>,
    /// Each triangle's normal (unnormalised) and first corner when the substep began, filled
    /// at the substep's first iteration.
    start_planes: Vec<(Vec3A, Vec3A)>,
    start_planes_ready: bool,
    /// Fluid particles found across a triangle and put back, in the last step.
    crossings: usize,
    /// The impulse the fluid gave the cloth in the last step, N s.
    impulse: Vec3A,
    /// The fluid particles' mass and radius, and the substep's length.
    pub(super) mass: f32,
    pub(super) radius: f32,
    pub(super) h: f32,
}

impl ClothContacts {
    /// Fluid particles found across one of the cloth's triangles and put back in the last
    /// step (each time counted).
    pub fn crossings(&self) -> usize {
        self.crossings
    }

    /// The impulse the fluid gave the cloth in the last step, N s (the water's weight times
    /// the step when it rests on the cloth).
    pub fn impulse(&self) -> Vec3A {
        self.impulse
    }

    pub(crate) fn begin_step(&mut self) {
        self.crossings = 0;
        self.impulse = Vec3A::ZERO;
    }

    /// Sorts the triangles at the cloth's positions `x` into the grid, each over its bounds
    /// grown by `2 r` (the cloth and the fluid move a little within the substep), and finds
    /// each fluid particle's (at `xf`) candidate triangles.
    pub(super) fn find_candidates(&mut self, xf: &[Vec3A], x: &[Vec3A], triangles: &[[u32; 3]]) {
        let r = self.radius;
        let mut longest = 0.0f32;
        for t in triangles {
            for k in 0..3 {
                let d = x[t[k] as usize].distance(x[t[(k + 1) % 3] as usize]);
                if d.is_finite() {
                    longest = longest.max(d);
                }
            }
        }
        self.cell = longest.max(4.0 * r);
        let inv = 1.0 / self.cell;
        let grow = Vec3A::splat(2.0 * r);
        // The cells each triangle covers (none for a non-finite or a huge one).
        let cells = |(lo, hi): (Vec3A, Vec3A)| {
            let (c0, c1) = (cell_of(lo, inv), cell_of(hi, inv));
            let fits = lo.is_finite() && hi.is_finite() && (0..3).all(|k| c1[k] - c0[k] <= 8);
            fits.then_some((c0, c1))
        };
        let each_cell = |(c0, c1): ([i32; 3], [i32; 3]), f: &mut dyn FnMut([i32; 3])| {
            for cz in c0[2]..=c1[2] {
                for cy in c0[1]..=c1[1] {
                    for cx in c0[0]..=c1[0] {
                        f([cx, cy, cz]);
                    }
                }
            }
        };
        self.bounds.clear();
        let mut count = 0usize;
        for t in triangles {
            let [a, b, c] = t.map(|k| x[k as usize]);
            let bounds = (a.min(b).min(c) - grow, a.max(b).max(c) + grow);
            if let Some(range) = cells(bounds) {
                each_cell(range, &mut |_| count += 1);
            }
            self.bounds.push(bounds);
        }
        // A counting sort by bucket, triangle by triangle, so that a triangle met twice in
        // one bucket (two of its cells hashed alike) is listed twice in a row.
        self.mask = (2 * count).next_power_of_two().max(64) as u32 - 1;
        let buckets = self.mask as usize + 1;
        let mask = self.mask;
        self.start.clear();
        self.start.resize(buckets + 1, 0);
        for &bounds in &self.bounds {
            if let Some(range) = cells(bounds) {
                each_cell(range, &mut |c| {
                    self.start[bucket(c, mask) as usize + 1] += 1
                });
            }
        }
        for b in 0..buckets {
            self.start[b + 1] += self.start[b];
        }
        self.entries.clear();
        self.entries.resize(count, 0);
        for (ti, &bounds) in self.bounds.iter().enumerate() {
            if let Some(range) = cells(bounds) {
                each_cell(range, &mut |c| {
                    let slot = &mut self.start[bucket(c, mask) as usize];
                    self.entries[*slot as usize] = ti as u32;
                    *slot += 1;
                });
            }
        }
        // `start[b]` now holds bucket b's end, that is bucket b + 1's start.
        self.start.rotate_right(1);
        self.start[0] = 0;
        // Each particle's candidates: the triangles of its bucket whose bounds hold it.
        self.candidate_start.clear();
        self.candidates.clear();
        self.candidate_start.push(0);
        for &p in xf {
            let cell = bucket(cell_of(p, inv), self.mask) as usize;
            if let Some(range) = self.start.get(cell..cell + 2) {
                let mut last = u32::MAX;
                for &ti in &self.entries[range[0] as usize..range[1] as usize] {
                    let (lo, hi) = self.bounds[ti as usize];
                    if ti != last && p.cmpge(lo).all() && p.cmple(hi).all() {
                        self.candidates.push(ti);
                    }
                    last = ti;
                }
            }
            self.candidate_start.push(self.candidates.len() as u32);
        }
        self.start_planes_ready = false;
    }

    /// Separates the fluid particles `xf` (at `xf_prev` when the substep began) from the
    /// cloth's triangles (particles `x`, at `x_prev`, inverse masses `w`), both ways (see the
    /// module docs).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn project(
        &mut self,
        xf: &mut [Vec3A],
        xf_prev: &[Vec3A],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        w: &[f32],
        triangles: &[[u32; 3]],
    ) {
        if self.candidate_start.len() != xf.len() + 1 || self.mass.is_nan() || self.mass <= 0.0 {
            return;
        }
        if !self.start_planes_ready {
            self.start_planes.clear();
            self.start_planes.extend(triangles.iter().map(|t| {
                let [a, b, c] = t.map(|k| x_prev[k as usize]);
                ((b - a).cross(c - a), a)
            }));
            self.start_planes_ready = true;
        }
        let (r, wf) = (self.radius, 1.0 / self.mass);
        for (i, (pf, &pf_prev)) in xf.iter_mut().zip(xf_prev).enumerate() {
            let range = self.candidate_start[i] as usize..self.candidate_start[i + 1] as usize;
            for &ti in &self.candidates[range] {
                let [a, b, c] = triangles[ti as usize].map(|k| k as usize);
                let (p0, p1, p2) = (x[a], x[b], x[c]);
                let normal = (p1 - p0).cross(p2 - p0);
                let area2 = normal.length();
                if area2.is_nan() || area2 <= 1e-12 {
                    continue;
                }
                let n = normal / area2;
                let d = n.dot(*pf - p0);
                // The side the particle was on when the substep began.
                let (n_prev, q0) = self.start_planes[ti as usize];
                let side = if n_prev.dot(pf_prev - q0) >= 0.0 {
                    1.0
                } else {
                    -1.0
                };
                let depth = r - side * d;
                if depth <= 0.0 {
                    continue;
                }
                // Only over the triangle: the projection onto the plane inside it.
                let q = *pf - n * d;
                let inv_area = 1.0 / (area2 * area2);
                let u = (p1 - q).cross(p2 - q).dot(normal) * inv_area;
                let v = (p2 - q).cross(p0 - q).dot(normal) * inv_area;
                let bw = 1.0 - u - v;
                if u < 0.0 || v < 0.0 || bw < 0.0 {
                    continue;
                }
                if side * d < 0.0 {
                    self.crossings += 1;
                }
                let weights = wf + u * u * w[a] + v * v * w[b] + bw * bw * w[c];
                let dl = depth / weights;
                let push = n * (side * dl);
                *pf += push * wf;
                x[a] -= push * (u * w[a]);
                x[b] -= push * (v * w[b]);
                x[c] -= push * (bw * w[c]);
                self.impulse -= push / self.h;
            }
        }
    }
}
