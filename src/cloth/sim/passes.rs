//! The projection and velocity passes the steps of [`ClothSolver`](super::ClothSolver) are made of,
//! over plain slices.

use bevy::math::Vec3A;

use super::parallel::Join;
use crate::cloth::constraints::{Projection, project_distance};
use std::ops::Range;

use crate::cloth::damping::{damp_plain, damp_rigid, damp_rigid_halves};
use crate::cloth::model::{Edge, EdgeKind};
use crate::cloth::settings::{DampingMode, SolverSettings};

/// Edges and stretch limits are swept as this many interleaved streams, each a contiguous
/// part of the sorted list: consecutive projections then touch distant particles and overlap
/// in the processor, while each stream keeps its lexicographic order (see `ClothSolver::new`).
/// Measured on S1 at N = 64, 8 x 4, before the limits overlapped: 1 stream 15.6 ms per frame
/// and 0.89% max strain, 2 streams 12.9 ms and 0.92%, 4 streams 12.5 ms and 1.35%.
pub(super) const STREAMS: usize = 2;

/// Calls `f` on the indices of [`STREAMS`] interleaved contiguous streams over `0..len`:
/// `0, c, 2c, .., 1, c + 1, ..` with `c = len / STREAMS` rounded up. The last stream may run
/// past `len`; `f` skips those indices. (Plain loops: an iterator chain here cost 12% of the
/// frame.)
#[inline(always)]
pub(super) fn for_each_interleaved(len: usize, mut f: impl FnMut(usize)) {
    let chunk = len.div_ceil(STREAMS);
    for i in 0..chunk {
        for stream in 0..STREAMS {
            f(i + stream * chunk);
        }
    }
}

/// Projects the distance constraints of `edges` (interleaved), with their multipliers.
#[inline(always)]
pub(super) fn project_edges(
    edges: &[Edge],
    lambdas: &mut [f32],
    x: &mut [Vec3A],
    w: &[f32],
    stretch: Projection,
) {
    for_each_interleaved(edges.len(), |k| {
        if let (Some(e), Some(lambda)) = (edges.get(k), lambdas.get_mut(k)) {
            project_distance(x, w, e.particles, e.rest_length, stretch, lambda);
        }
    });
}

/// The relaxation of the order-free edge projection: each particle moves by this over its
/// edge count times the sum of its edges' corrections (Macklin et al. 2014, section 4.2).
pub(super) const JACOBI_RELAXATION: f32 = 1.5;

/// Buffers of the order-free (Jacobi) edge projection a closed cloth uses.
///
/// A Gauss-Seidel sweep leaves its residual biased along the sweep order. On an open cloth
/// that is harmless, but a pressurised closed cloth keeps its skin far from rest every
/// substep, and friction turned the biased tangential motion of its contact patch into a push
/// on the whole body: measured, a balloon at twice its rest volume on ground with friction 0.6
/// crept 26 m in 3 s with the sorted sweep, 8 m with the sweep reversed on every other
/// iteration, and 4 mm with this projection.
#[derive(Clone, Debug, Default)]
pub(super) struct JacobiScratch {
    start: Vec<Vec3A>,
    delta: Vec<Vec3A>,
    /// Per particle: `JACOBI_RELAXATION / (edges at the particle)`.
    share: Vec<f32>,
    /// The edge count the shares were computed for.
    edges: usize,
}

impl JacobiScratch {
    /// Sizes the buffers for `edges` over `particles` particles (allocates only when they
    /// change).
    fn prepare(&mut self, edges: &[Edge], particles: usize) {
        if self.share.len() == particles && self.edges == edges.len() {
            return;
        }
        let mut count = vec![0u32; particles];
        for e in edges {
            for p in e.particles {
                if let Some(c) = count.get_mut(p as usize) {
                    *c += 1;
                }
            }
        }
        self.share = count
            .iter()
            .map(|&c| {
                if c > 0 {
                    JACOBI_RELAXATION / c as f32
                } else {
                    0.0
                }
            })
            .collect();
        self.start = vec![Vec3A::ZERO; particles];
        self.delta = vec![Vec3A::ZERO; particles];
        self.edges = edges.len();
    }
}

/// Projects the distance constraints of `edges` all from the same positions (Jacobi) and
/// moves every particle by its share of the sum of their corrections, so that no order is
/// favoured (see [`JacobiScratch`]).
pub(super) fn project_edges_jacobi(
    edges: &[Edge],
    lambdas: &mut [f32],
    x: &mut [Vec3A],
    w: &[f32],
    stretch: Projection,
    scratch: &mut JacobiScratch,
) {
    scratch.prepare(edges, x.len());
    scratch.start.copy_from_slice(x);
    scratch.delta.fill(Vec3A::ZERO);
    for (e, lambda) in edges.iter().zip(lambdas.iter_mut()) {
        let [a, b] = e.particles.map(|i| i as usize);
        let (Some(&wa), Some(&wb)) = (w.get(a), w.get(b)) else {
            continue;
        };
        let mut pair = [scratch.start[a], scratch.start[b]];
        project_distance(&mut pair, &[wa, wb], [0, 1], e.rest_length, stretch, lambda);
        scratch.delta[a] += pair[0] - scratch.start[a];
        scratch.delta[b] += pair[1] - scratch.start[b];
    }
    for ((xi, d), &share) in x.iter_mut().zip(&scratch.delta).zip(&scratch.share) {
        *xi += *d * share;
    }
}

/// Damps the velocities by the fraction `k` as [`SolverSettings::damping_mode`] says.
/// `masses` are the free particles' masses (0 for pinned ones), `w` the inverse masses. With
/// `middle`, the two halves split there are damped at the same time through `join`. With
/// `parts` (cloths solved together as layers), each part's rigid motion is its own.
#[allow(clippy::too_many_arguments)]
pub(super) fn damp(
    settings: &SolverSettings,
    k: f32,
    x: &[Vec3A],
    v: &mut [Vec3A],
    w: &[f32],
    masses: &[f32],
    join: &dyn Join,
    middle: Option<usize>,
    parts: &[Range<usize>],
) {
    if k <= 0.0 {
        return;
    }
    if settings.damping_mode == DampingMode::Rigid && !parts.is_empty() {
        let n = v.len().min(masses.len()).min(x.len());
        for part in parts.iter().filter(|p| p.end <= n) {
            damp_rigid(
                &x[part.clone()],
                &mut v[part.clone()],
                &masses[part.clone()],
                k,
            );
        }
        return;
    }
    let middle = middle.filter(|&m| m <= v.len() && w.len() == v.len());
    match (settings.damping_mode, middle) {
        (DampingMode::Plain, None) => damp_plain(v, w, k),
        (DampingMode::Plain, Some(m)) => {
            let (va, vb) = v.split_at_mut(m);
            let (wa, wb) = w.split_at(m);
            join.join(&mut || damp_plain(va, wa, k), &mut || damp_plain(vb, wb, k));
        }
        (DampingMode::Rigid, None) => damp_rigid(x, v, masses, k),
        (DampingMode::Rigid, Some(m)) => damp_rigid_halves(join, m, x, v, masses, k),
    }
}

/// Projects the structural edges with a particle a collider holds (`held[i]` its latest
/// contact normal, zero if none), a held particle that the edge would push into its surface
/// moving only along it: the edge is met by moving the other end further, as if the held one
/// were infinitely heavy along its normal (`W = w (I - n n^T)`); one the edge lifts off moves
/// freely. In the plain sweep an edge pulling a held particle into its
/// collider spends part of its correction on a motion the contact undoes right after, and the
/// two settle with the edge stretched; here that part goes to the other end.
///
/// Measured with `cargo run --release --example scenes -- s3 --motion M` (default 8 x 2,
/// 600 steps), this pass and the position-level friction of `collide/contact.rs` together,
/// against the velocity-level friction and contact tethers they replaced, in one run: the
/// median step's largest strain 26% to 22% in place, 37% to 26% walking, 32% to 26% jogging;
/// its 99.9th percentile edge 17.6-19.4% to 14.8-15.5%; the cost within noise. (A version
/// that also held particles the edge lifts off the surface could not lift a sheet off the
/// ground: `tests/interaction.rs`.)
pub(super) fn project_held_edges(edges: &[Edge], x: &mut [Vec3A], w: &[f32], held: &[Vec3A]) {
    for edge in edges.iter().filter(|e| e.kind != EdgeKind::Shear) {
        let [a, b] = edge.particles.map(|i| i as usize);
        let (na, nb) = (held[a], held[b]);
        if na == Vec3A::ZERO && nb == Vec3A::ZERO {
            continue;
        }
        let d = x[a] - x[b];
        let len = d.length();
        if len <= f32::EPSILON * edge.rest_length {
            continue;
        }
        let u = d / len;
        let c = len - edge.rest_length;
        // Each end moves along -c u (a) or +c u (b); a held end loses the part of that motion
        // that goes into its surface, and keeps the part that lifts it off.
        let slide = |n: Vec3A, motion: Vec3A| {
            if n.dot(motion) < 0.0 {
                u - n * n.dot(u)
            } else {
                u
            }
        };
        let ga = slide(na, -u * c) * w[a];
        let gb = slide(nb, u * c) * w[b];
        let denom = ga.dot(u) + gb.dot(u);
        if denom <= 1e-6 * (w[a] + w[b]) {
            continue;
        }
        let dl = -c / denom;
        x[a] += ga * dl;
        x[b] -= gb * dl;
    }
}
