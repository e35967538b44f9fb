//! Fluid and cloth stepped together, in the same substeps and iterations, so that each
//! feels the other's inertia and the cloth's constraints carry the fluid's weight within
//! the step ([`FluidSolver::step_with_cloth`](super::FluidSolver::step_with_cloth)).
//!
//! The fluid runs inside the cloth's step (`cloth/sim/step.rs`, `SubstepCoupling`): when a
//! cloth substep of length `h` begins the fluid predicts over `h` and the cloth's triangles
//! are sorted into a hashed grid at their predicted positions; in each of the cloth's
//! iterations, after its colliders and before its own constraints, the fluid projects its
//! density constraint, its colliders, then the contacts with the cloth's triangles; when the
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

use super::FluidSolver;
use super::neighbours::{bucket, cell_of};
use crate::cloth::SubstepCoupling;

/// The contacts between a fluid and a cloth: the cloth's triangles in a hashed grid, and
/// what the last step did.
#[derive(Clone, Debug, Default)]
pub struct ClothContacts {
    cell: f32,
    mask: u32,
    start: Vec<u32>,
    entries: Vec<u32>,
    /// (bucket, triangle) while building.
    pairs: Vec<(u32, u32)>,
    /// Fluid particles found across a triangle and put back, in the last step.
    crossings: usize,
    /// The impulse the fluid gave the cloth in the last step, N s.
    impulse: Vec3A,
    /// The fluid particles' mass and radius, and the substep's length.
    mass: f32,
    radius: f32,
    h: f32,
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
    /// grown by `2 r` (the cloth and the fluid move a little within the substep).
    fn sort(&mut self, x: &[Vec3A], triangles: &[[u32; 3]]) {
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
        self.pairs.clear();
        let mut count = 0usize;
        for pass in 0..2 {
            for (ti, t) in triangles.iter().enumerate() {
                let [a, b, c] = t.map(|k| x[k as usize]);
                let (lo, hi) = (a.min(b).min(c) - grow, a.max(b).max(c) + grow);
                if !(lo.is_finite() && hi.is_finite()) {
                    continue;
                }
                let (c0, c1) = (cell_of(lo, inv), cell_of(hi, inv));
                if (0..3).any(|k| c1[k] - c0[k] > 8) {
                    continue;
                }
                for cz in c0[2]..=c1[2] {
                    for cy in c0[1]..=c1[1] {
                        for cx in c0[0]..=c1[0] {
                            if pass == 0 {
                                count += 1;
                            } else {
                                self.pairs
                                    .push((bucket([cx, cy, cz], self.mask), ti as u32));
                            }
                        }
                    }
                }
            }
            if pass == 0 {
                self.mask = (2 * count).next_power_of_two().max(64) as u32 - 1;
            }
        }
        self.pairs.sort_unstable();
        self.pairs.dedup();
        let buckets = self.mask as usize + 1;
        self.start.clear();
        self.start.resize(buckets + 1, 0);
        for &(b, _) in &self.pairs {
            self.start[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            self.start[b + 1] += self.start[b];
        }
        self.entries.clear();
        self.entries.extend(self.pairs.iter().map(|&(_, t)| t));
    }

    /// Separates the fluid particles `xf` (at `xf_prev` when the substep began) from the
    /// cloth's triangles (particles `x`, at `x_prev`, inverse masses `w`), both ways (see the
    /// module docs).
    #[allow(clippy::too_many_arguments)]
    fn project(
        &mut self,
        xf: &mut [Vec3A],
        xf_prev: &[Vec3A],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        w: &[f32],
        triangles: &[[u32; 3]],
    ) {
        if self.start.is_empty() || self.mass.is_nan() || self.mass <= 0.0 {
            return;
        }
        let (r, wf) = (self.radius, 1.0 / self.mass);
        let inv = 1.0 / self.cell;
        for (pf, &pf_prev) in xf.iter_mut().zip(xf_prev) {
            let cell = bucket(cell_of(*pf, inv), self.mask) as usize;
            let Some(range) = self.start.get(cell..cell + 2) else {
                continue;
            };
            for &ti in &self.entries[range[0] as usize..range[1] as usize] {
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
                let q0 = x_prev[a];
                let n_prev = (x_prev[b] - q0).cross(x_prev[c] - q0);
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

/// The fluid as the cloth's step sees it (`SubstepCoupling`).
pub(crate) struct FluidInCloth<'a> {
    pub(crate) fluid: &'a mut FluidSolver,
    /// Density sweeps per cloth iteration.
    pub(crate) sweeps: u32,
    /// The current substep, and how many the cloth takes.
    pub(crate) substep: u32,
    pub(crate) substeps: u32,
}

impl SubstepCoupling for FluidInCloth<'_> {
    fn begin_substep(&mut self, x: &[Vec3A], triangles: &[[u32; 3]], h: f32) {
        self.fluid.predict(h);
        let (radius, mass) = (
            self.fluid.settings().particle_radius,
            self.fluid.particle_mass(),
        );
        let (_, _, contacts) = self.fluid.contact_parts();
        contacts.radius = radius;
        contacts.mass = mass;
        contacts.h = h;
        contacts.sort(x, triangles);
    }

    fn iterate(&mut self, x: &mut [Vec3A], x_prev: &[Vec3A], w: &[f32], triangles: &[[u32; 3]]) {
        let t = (self.substep + 1) as f32 / self.substeps as f32;
        for _ in 0..self.sweeps {
            self.fluid.project_density();
        }
        self.fluid.project_colliders(t);
        let (xf, xf_prev, contacts) = self.fluid.contact_parts();
        contacts.project(xf, xf_prev, x, x_prev, w, triangles);
    }

    fn end_substep(&mut self, h: f32) {
        self.fluid.end_substep(h);
        self.substep += 1;
    }
}
