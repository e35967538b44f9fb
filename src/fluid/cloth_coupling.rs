//! Fluid against cloth, both ways: the fluid's particles are kept off the cloth's triangles
//! (not only its particles, so a fine fluid cannot pass between the particles of a coarse
//! cloth), and every push a triangle gives a fluid particle is given back to the triangle's
//! particles, so momentum moves between them.
//!
//! A [`ClothBoundary`] follows one cloth: after each of the cloth's steps it keeps the
//! triangles where the step began and where it ended. The fluid's step that follows sees
//! each triangle move between the two through its substeps, and in every density iteration
//! (after the colliders) a fluid particle of radius `r` whose projection onto a triangle's
//! plane lies inside the triangle is moved out along the normal to distance `r`, on the side
//! it was on at the start of the substep; one that was found across (it passed through in
//! the sweep) is put back and counted ([`ClothBoundary::crossings`]). The push `dx` of a
//! particle of mass `m` is an impulse `m dx / h` over the substep `h`; the cloth's particles
//! get its opposite in the proportions of the contact point's barycentric coordinates, as a
//! force over the cloth's next step ([`ClothBoundary::give_impulses`]): the total momentum
//! of cloth and fluid is kept (pinned particles absorb their share).
//!
//! Limitation (measured): the exchange is partitioned, one step behind, so it holds light
//! contacts (a splash on a sheet, momentum kept to round-off) but not water resting on a
//! much lighter cloth: 2 kg of water in a 0.06 kg bag hung from one pin tears through it
//! within a second, and a sheet held at its corners does not carry the water's weight. That
//! needs the contacts projected in the same iterations as the cloth's constraints.

use bevy::math::Vec3A;

use super::neighbours::{bucket, cell_of};
use crate::cloth::ClothSolver;

/// A hashed uniform grid of the cloth's triangles over a step's motion.
#[derive(Clone, Debug, Default)]
struct TriangleGrid {
    cell: f32,
    mask: u32,
    start: Vec<u32>,
    entries: Vec<u32>,
    /// (bucket, triangle) while building.
    pairs: Vec<(u32, u32)>,
}

/// One cloth as the fluid sees it over one step.
#[derive(Clone, Debug, Default)]
pub struct ClothBoundary {
    triangles: Vec<[u32; 3]>,
    /// The cloth's positions at the start and the end of its last step.
    start: Vec<Vec3A>,
    end: Vec<Vec3A>,
    inverse_masses: Vec<f32>,
    /// Per cloth particle, the impulse the fluid gave it in the fluid's last step, N s.
    impulses: Vec<Vec3A>,
    grid: TriangleGrid,
    /// Fluid particles found across a triangle and put back, in the fluid's last step.
    crossings: usize,
    /// The total of `impulses` when they were last given to the cloth.
    given: Vec3A,
    tracked: bool,
}

impl ClothBoundary {
    /// A boundary that follows `cloth`, starting where it is now.
    pub fn new(cloth: &ClothSolver) -> Self {
        let mut boundary = Self::default();
        boundary.track(cloth);
        boundary
    }

    /// Records where `cloth` is after its step (the end of the last one is this one's
    /// start). Call it after every step of the cloth, before the fluid's step.
    pub fn track(&mut self, cloth: &ClothSolver) {
        let x = &cloth.state().positions;
        let changed = self.end.len() != x.len();
        if changed || !self.tracked {
            self.triangles.clone_from(&cloth.model().triangles);
            self.start.clone_from(x);
        } else {
            std::mem::swap(&mut self.start, &mut self.end);
        }
        self.end.clone_from(x);
        self.inverse_masses
            .clone_from(&cloth.state().inverse_masses);
        self.impulses.clear();
        self.impulses.resize(x.len(), Vec3A::ZERO);
        self.tracked = true;
    }

    /// Fluid particles found across one of the cloth's triangles and put back in the
    /// fluid's last step (each time counted).
    pub fn crossings(&self) -> usize {
        self.crossings
    }

    /// The total impulse the fluid gave the cloth in its last step, N s (kept after
    /// [`ClothBoundary::give_impulses`]).
    pub fn total_impulse(&self) -> Vec3A {
        self.given
    }

    /// Gives the cloth the impulses of the fluid's last step (of length `dt`), spread over
    /// its next step as a force, and clears them.
    pub fn give_impulses(&mut self, cloth: &mut ClothSolver, dt: f32) {
        self.given = self.impulses.iter().copied().sum();
        cloth.push_over_next_step(&self.impulses, dt);
        self.impulses.fill(Vec3A::ZERO);
    }

    /// Builds the triangle grid for a fluid of particle radius `r` (cells at least `4 r`).
    pub(crate) fn begin_step(&mut self, r: f32) {
        self.crossings = 0;
        let mut longest = 0.0f32;
        for t in &self.triangles {
            for k in 0..3 {
                let a = self.end[t[k] as usize];
                let b = self.end[t[(k + 1) % 3] as usize];
                longest = longest.max(a.distance(b));
            }
        }
        let cell = longest.max(4.0 * r);
        let inv = 1.0 / cell;
        let grid = &mut self.grid;
        grid.cell = cell;
        grid.pairs.clear();
        let mut count = 0usize;
        // Count first to size the table, then fill.
        for pass in 0..2 {
            for (ti, t) in self.triangles.iter().enumerate() {
                let mut lo = Vec3A::splat(f32::INFINITY);
                let mut hi = Vec3A::splat(f32::NEG_INFINITY);
                for &k in t {
                    for p in [self.start[k as usize], self.end[k as usize]] {
                        lo = lo.min(p);
                        hi = hi.max(p);
                    }
                }
                if !(lo.is_finite() && hi.is_finite()) {
                    continue;
                }
                let (c0, c1) = (
                    cell_of(lo - Vec3A::splat(r), inv),
                    cell_of(hi + Vec3A::splat(r), inv),
                );
                // A triangle swept across more than 64 cells a side moved too far to matter.
                if (0..3).any(|a| c1[a] - c0[a] > 64) {
                    continue;
                }
                for z in c0[2]..=c1[2] {
                    for y in c0[1]..=c1[1] {
                        for x in c0[0]..=c1[0] {
                            if pass == 0 {
                                count += 1;
                            } else {
                                grid.pairs.push((bucket([x, y, z], grid.mask), ti as u32));
                            }
                        }
                    }
                }
            }
            if pass == 0 {
                let buckets = (2 * count).next_power_of_two().max(64);
                grid.mask = buckets as u32 - 1;
            }
        }
        grid.pairs.sort_unstable();
        grid.pairs.dedup();
        let buckets = grid.mask as usize + 1;
        grid.start.clear();
        grid.start.resize(buckets + 1, 0);
        for &(b, _) in &grid.pairs {
            grid.start[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            grid.start[b + 1] += grid.start[b];
        }
        grid.entries.clear();
        grid.entries.extend(grid.pairs.iter().map(|&(_, t)| t));
    }

    /// Keeps the fluid's particles `x` (at `x_prev` when the substep began, a fraction
    /// `t_prev` through the step; now at `t`) off the triangles, each of mass `mass`, radius
    /// `r`, over a substep of length `h` (see the module docs).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn project(
        &mut self,
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        t_prev: f32,
        t: f32,
        r: f32,
        mass: f32,
        h: f32,
    ) {
        if self.triangles.is_empty() || self.grid.start.is_empty() {
            return;
        }
        let inv = 1.0 / self.grid.cell;
        for (xi, &pi) in x.iter_mut().zip(x_prev) {
            let b = bucket(cell_of(*xi, inv), self.grid.mask) as usize;
            let range = self.grid.start[b] as usize..self.grid.start[b + 1] as usize;
            for &ti in &self.grid.entries[range] {
                let [a, b, c] = self.triangles[ti as usize].map(|k| k as usize);
                let at = |k: usize, s: f32| self.start[k].lerp(self.end[k], s);
                let (p0, p1, p2) = (at(a, t), at(b, t), at(c, t));
                let normal = (p1 - p0).cross(p2 - p0);
                let area2 = normal.length();
                if area2.is_nan() || area2 <= 1e-12 {
                    continue;
                }
                let n = normal / area2;
                let d = n.dot(*xi - p0);
                // The side the particle was on when the substep began.
                let q0 = at(a, t_prev);
                let n_prev = (at(b, t_prev) - q0).cross(at(c, t_prev) - q0);
                let side = if n_prev.dot(pi - q0) >= 0.0 {
                    1.0
                } else {
                    -1.0
                };
                let depth = r - side * d;
                if depth <= 0.0 {
                    continue;
                }
                // Only over the triangle: its projection onto the plane inside it.
                let (u, v, w) = barycentric(*xi - n * d, p0, p1, p2, normal, area2);
                if u < 0.0 || v < 0.0 || w < 0.0 {
                    continue;
                }
                if side * d < 0.0 {
                    self.crossings += 1;
                }
                let dx = n * (side * depth);
                *xi += dx;
                let impulse = dx * (mass / h);
                self.impulses[a] -= impulse * u;
                self.impulses[b] -= impulse * v;
                self.impulses[c] -= impulse * w;
            }
        }
    }
}

/// Barycentric coordinates of `q` (in the plane of `p0 p1 p2`, whose unnormalised normal is
/// `normal` of length `area2`).
#[inline(always)]
fn barycentric(
    q: Vec3A,
    p0: Vec3A,
    p1: Vec3A,
    p2: Vec3A,
    normal: Vec3A,
    area2: f32,
) -> (f32, f32, f32) {
    let inv = 1.0 / (area2 * area2);
    let u = (p1 - q).cross(p2 - q).dot(normal) * inv;
    let v = (p2 - q).cross(p0 - q).dot(normal) * inv;
    (u, v, 1.0 - u - v)
}
