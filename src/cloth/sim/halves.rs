//! One cloth projected on two threads: [`Halves`] splits the particles at the middle index
//! (a grid's middle row) and each list of batched constraints into the part inside the first
//! half, the part inside the second, and the seam between them. In every iteration the two
//! halves are swept at once, each in its own slice of the positions (`split_at_mut`: the
//! borrow checker sees that they share nothing), and then the seam on one thread. Tethers
//! read their pins from each half's own copy of them, so every tether belongs to the half of
//! the particle it holds and none is in the seam.
//!
//! The halves keep each list's sweep order; what changes against one thread's sweep is only
//! that the seam's constraints come after both halves instead of among them, so the result
//! differs from one thread's (by the order of a Gauss-Seidel sweep) but is the same on every
//! run and whichever thread takes which half.

use std::ops::Range;

use bevy::math::{Vec3A, Vec4};

use super::parallel::Join;
use crate::cloth::batch::PairBatches;
use crate::cloth::constraints::Projection;
use crate::cloth::isometric_bending::{IsometricPair, PreparedIsometric};

/// Cloths with fewer particles are not split: their sweeps are shorter than a join's cost.
pub(super) const MIN_PARTICLES: usize = 2048;

/// A split whose seam would hold more than this share of the constraints is not made: the
/// seam runs on one thread (a cloth whose particles are not numbered along the sheet, as a
/// grid's rows are, has no short seam at its middle index).
const MAX_SEAM_SHARE: f32 = 0.1;

/// The constraints of one part: the particles of a half (indices from its first particle), or
/// the seam (indices into the whole cloth).
#[derive(Clone, Debug, Default)]
struct Part {
    /// The part's particles (the seam: every particle).
    range: Range<usize>,
    edges: PairBatches,
    edge_lambdas: Vec<Vec4>,
    limits: PairBatches,
    tethers: PairBatches,
    /// The pins the tethers hold to, and their positions in the current substep.
    pins: Vec<u32>,
    anchors: Vec<Vec3A>,
    isometric_pairs: Vec<IsometricPair>,
    isometric: PreparedIsometric,
    isometric_lambdas: Vec<Vec3A>,
}

/// What one iteration projects (see `step.rs`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Sweep {
    /// Stretch limits and tethers.
    pub long_range: bool,
    /// The edges' projection.
    pub stretch: Projection,
    /// Whether the isometric bending pairs are projected.
    pub isometric: bool,
    /// Whether this is the substep's first iteration (the multipliers start at zero).
    pub first: bool,
}

impl Part {
    fn project(&mut self, x: &mut [Vec3A], sweep: Sweep) {
        // Zeroed by the thread that uses them, so that they stay in its cache.
        if sweep.first {
            self.edge_lambdas.fill(Vec4::ZERO);
            self.isometric_lambdas.fill(Vec3A::ZERO);
        }
        if sweep.long_range {
            self.limits.project_limits(x);
            self.tethers.project_tethers(x, &self.anchors);
        }
        self.edges
            .project_distances(&mut self.edge_lambdas, x, sweep.stretch);
        if sweep.isometric {
            self.isometric.project(x, &mut self.isometric_lambdas);
        }
    }

    fn set_weights(&mut self, w: &[f32]) {
        let w = &w[self.range.clone()];
        self.edges.set_weights(w);
        self.limits.set_weights(w);
        self.tethers.set_weights(w);
    }
}

/// A cloth's batched constraints split in two halves and a seam (see the module
/// documentation).
#[derive(Clone, Debug, Default)]
pub(super) struct Halves {
    parts: [Part; 2],
    seam: Part,
    /// The bending `alpha~` (bits) the isometric pairs were prepared for (NaN: not yet).
    bend_alpha_prepared: u32,
}

/// Which half of a cloth of `n` particles split at `middle` holds `i`.
fn half(i: u32, middle: usize) -> usize {
    usize::from(i as usize >= middle)
}

impl Halves {
    /// Splits the constraints of a cloth of `n` particles at its middle index: its `edges`,
    /// stretch `limits` and `tethers` (as batched by the solver; the tethers' second index
    /// names one of `pins`) and its isometric bending pairs; inverse masses from `w`. `None`
    /// if the cloth is too small to gain from it or the seam would be long (see
    /// [`MAX_SEAM_SHARE`]).
    pub(super) fn new(
        w: &[f32],
        edges: &PairBatches,
        limits: &PairBatches,
        tethers: &PairBatches,
        pins: &[u32],
        isometric: &[IsometricPair],
    ) -> Option<Self> {
        let n = w.len();
        if n < MIN_PARTICLES {
            return None;
        }
        let middle = n / 2;
        let ranges = [0..middle, middle..n];
        let mut parts: [Part; 2] = ranges.clone().map(|range| Part {
            range,
            ..Part::default()
        });
        let mut seam = Part {
            range: 0..n,
            ..Part::default()
        };
        let mut total = 0usize;
        let mut seam_count = 0usize;
        // Each two-particle list, split: a pair inside one half, in that half's indices.
        let mut split_pairs = |list: &PairBatches| {
            let mut inside: [Vec<([u32; 2], f32)>; 2] = Default::default();
            let mut across = Vec::new();
            for ([a, b], length) in list.pairs() {
                total += 1;
                let (ha, hb) = (half(a, middle), half(b, middle));
                if ha == hb {
                    let offset = ranges[ha].start as u32;
                    inside[ha].push(([a - offset, b - offset], length));
                } else {
                    seam_count += 1;
                    across.push(([a, b], length));
                }
            }
            (inside, across)
        };
        let ([edges0, edges1], edges_across) = split_pairs(edges);
        let ([limits0, limits1], limits_across) = split_pairs(limits);
        for (part, (edges, limits)) in parts.iter_mut().zip([(edges0, limits0), (edges1, limits1)])
        {
            let len = part.range.len();
            part.edges = PairBatches::new(edges, len, true);
            part.limits = PairBatches::new(limits, len, true);
        }
        seam.edges = PairBatches::new(edges_across, n, true);
        seam.limits = PairBatches::new(limits_across, n, true);
        // Tethers go with the particle they hold; each half numbers its own pins.
        let mut half_tethers: [Vec<([u32; 2], f32)>; 2] = Default::default();
        for ([p, slot], length) in tethers.pairs() {
            let Some(&pin) = pins.get(slot as usize) else {
                continue;
            };
            total += 1;
            let h = half(p, middle);
            let part = &mut parts[h];
            let local_slot = match part.pins.iter().position(|&q| q == pin) {
                Some(k) => k,
                None => {
                    part.pins.push(pin);
                    part.pins.len() - 1
                }
            };
            let offset = part.range.start as u32;
            half_tethers[h].push(([p - offset, local_slot as u32], length));
        }
        for (part, tethers) in parts.iter_mut().zip(half_tethers) {
            part.tethers = PairBatches::new(tethers, part.range.len(), false);
            part.anchors = vec![Vec3A::ZERO; part.pins.len()];
        }
        for pair in isometric {
            total += 1;
            let h = half(pair.particles[0], middle);
            if pair.particles.iter().all(|&i| half(i, middle) == h) {
                let offset = ranges[h].start as u32;
                parts[h].isometric_pairs.push(IsometricPair {
                    particles: pair.particles.map(|i| i - offset),
                    ..*pair
                });
            } else {
                seam_count += 1;
                seam.isometric_pairs.push(*pair);
            }
        }
        if seam_count as f32 > MAX_SEAM_SHARE * total as f32 {
            return None;
        }
        let mut halves = Self {
            parts,
            seam,
            bend_alpha_prepared: f32::NAN.to_bits(),
        };
        for part in halves.all_parts() {
            part.set_weights(w);
            part.edge_lambdas = vec![Vec4::ZERO; part.edges.len()];
        }
        Some(halves)
    }

    fn all_parts(&mut self) -> impl Iterator<Item = &mut Part> {
        self.parts.iter_mut().chain([&mut self.seam])
    }

    /// Prepares the isometric pairs for the inverse masses `w` and `alpha_tilde` (only when
    /// `alpha_tilde` changed since the last call).
    pub(super) fn prepare_bending(&mut self, w: &[f32], alpha_tilde: f32) {
        if self.bend_alpha_prepared == alpha_tilde.to_bits() {
            return;
        }
        for part in self.all_parts() {
            let w = &w[part.range.clone()];
            part.isometric
                .prepare(&part.isometric_pairs, w, alpha_tilde);
            part.isometric_lambdas = vec![Vec3A::ZERO; part.isometric.len()];
        }
        self.bend_alpha_prepared = alpha_tilde.to_bits();
    }

    /// Starts a substep: copies the pins' positions (placed for the substep).
    pub(super) fn begin_substep(&mut self, x: &[Vec3A]) {
        for part in self.all_parts() {
            for (anchor, &pin) in part.anchors.iter_mut().zip(&part.pins) {
                if let Some(&p) = x.get(pin as usize) {
                    *anchor = p;
                }
            }
        }
    }

    /// The first particle of the second half.
    pub(super) fn middle(&self) -> usize {
        self.parts[1].range.start
    }

    /// One iteration's sweep: both halves at once through `join`, then the seam.
    pub(super) fn project(&mut self, x: &mut [Vec3A], sweep: Sweep, join: &dyn Join) {
        let [first, second] = &mut self.parts;
        if x.len() != second.range.end {
            return;
        }
        // The seam's long-range limits first, so that the halves' edges after them spread
        // what they move: projected after the edges, a limit crossing the middle left its
        // correction on the edge at its end (measured on S1 at N = 128, 8 x 2: 2.1% max
        // strain, on the rows where those limits end, against 1.2% on one thread).
        if sweep.long_range {
            self.seam.limits.project_limits(x);
        }
        let (x0, x1) = x.split_at_mut(second.range.start);
        join.join(&mut || first.project(x0, sweep), &mut || {
            second.project(x1, sweep)
        });
        self.seam.project(
            x,
            Sweep {
                long_range: false,
                ..sweep
            },
        );
    }
}

#[cfg(test)]
mod tests {
    use bevy::math::Vec3;

    use super::*;
    use crate::cloth::model::{ClothModel, GridDesc};
    use crate::rng::Rng;

    /// The edges of an `n` x `n` grid as batches, their particles renumbered by `order`.
    fn grid_edges(n: u32, order: &[u32]) -> (Vec<f32>, PairBatches) {
        let model = ClothModel::grid(&GridDesc::square(1.0, n, Vec3::ZERO), 0.1).unwrap();
        let pairs = model
            .edges
            .iter()
            .map(|e| (e.particles.map(|i| order[i as usize]), e.rest_length));
        let count = model.particle_count();
        (vec![1.0; count], PairBatches::new(pairs, count, true))
    }

    #[test]
    fn a_grid_splits_at_its_middle_row_and_a_shuffled_grid_or_a_small_one_does_not() {
        let n = 64u32;
        let identity: Vec<u32> = (0..n * n).collect();
        let (w, edges) = grid_edges(n, &identity);
        let none = PairBatches::default();
        let halves = Halves::new(&w, &edges, &none, &none, &[], &[]).expect("a grid splits");
        // Every edge is in exactly one part, and the seam holds those across the middle row.
        let counts: Vec<usize> = halves
            .parts
            .iter()
            .chain([&halves.seam])
            .map(|p| p.edges.pair_count())
            .collect();
        assert_eq!(counts.iter().sum::<usize>(), edges.pair_count());
        let middle = (n * n / 2) as usize;
        assert_eq!(halves.middle(), middle);
        for ([a, b], _) in halves.seam.edges.pairs() {
            assert!(((a as usize) < middle) != ((b as usize) < middle));
        }
        // Across one row: its vertical and diagonal edges only.
        assert!(counts[2] <= 3 * n as usize, "seam of {}", counts[2]);

        // The same grid numbered at random: the middle index cuts it everywhere.
        let mut order = identity.clone();
        Rng(5).shuffle(&mut order);
        let (w, shuffled) = grid_edges(n, &order);
        assert!(Halves::new(&w, &shuffled, &none, &none, &[], &[]).is_none());

        let small: Vec<u32> = (0..16 * 16).collect();
        let (w, edges) = grid_edges(16, &small);
        assert!(Halves::new(&w, &edges, &none, &none, &[], &[]).is_none());
    }
}
