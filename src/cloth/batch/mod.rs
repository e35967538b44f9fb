//! Distance-type constraints projected four at a time.
//!
//! A Gauss-Seidel sweep projects constraints one after another; written one at a time, each
//! projection waits for a square root and a division, and the sweep runs at 16 to 23 ns per
//! constraint here (`benches/kernels.rs`; about 5 ns batched). [`PairBatches`] groups a list of two-particle constraints into batches of
//! [`LANES`] that share no particle they move, so that one batch is projected with four-wide
//! arithmetic (SSE on `x86_64`: one square root and one division for four constraints), and
//! the sweep stays a plain sequential Gauss-Seidel sweep: batches run one after another, and
//! the four constraints of a batch, touching different particles, give the same result in
//! any order.
//!
//! Consecutive batches also share no particle that one moves and another reads
//! ([`SEPARATION`]), so the sweep is pipelined: the next batch's positions are read and its
//! lengths computed before the current batch's corrections are written, so the processor
//! works on two batches at once instead of waiting for each one's square root and division.
//! What bounds the sweep then is its instruction count, most of it gathering and scattering
//! the particles of four constraints.
//!
//! The batches follow the list's order as closely as they can: a batch takes the earliest
//! constraints that fit (those waiting from earlier batches first, then up to [`LOOK_AHEAD`]
//! new ones), so a constraint runs at most a few places earlier or later than in the list.
//! That keeps what a sorted sweep is for (a correction carried across the whole sheet in
//! the sweep's direction in one pass), which a full colour order loses (see
//! [`super::ordering`]).
//!
//! The kernels are the projections of [`super::constraints::project_distance`],
//! [`super::stretch_limits::project_stretch_limit`] and [`super::constraints::project_tether`];
//! off `x86_64` they are those scalar functions, lane by lane (`scalar.rs`, built in the
//! tests on `x86_64` too, where the two are compared). Inverse masses are copied into the
//! batches by [`PairBatches::set_weights`] (once per step: they do not change within one).
//!
//! Tethers ([`PairBatches::project_tethers`]) read their anchors from a list of their own
//! rather than from the particles they move: a part of the cloth swept on one thread then
//! reads the pins of another part from its own copy, not from particles another thread
//! writes.

use bevy::math::{Vec3A, Vec4};

use super::constraints::Projection;

/// Constraints per batch.
pub(crate) const LANES: usize = 4;

/// How many constraints past the last one taken a batch looks at to fill its lanes.
pub(crate) const LOOK_AHEAD: usize = 64;

/// Batches in a row that share no particle one of them moves or reads. The sweep needs two
/// (it overlaps a batch with the next); four leave the processor more room. Measured on S1
/// at N = 64, 8 x 2: 4.2 ms per frame with two, 4.1 ms with four.
pub(crate) const SEPARATION: u32 = 4;

/// One batch: the particles of [`LANES`] constraints, their lengths and inverse masses. A
/// batch with fewer constraints repeats its first lane (the repeated lane computes and
/// stores the same values).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Batch {
    /// The first particle of each lane (always moved), as the byte offset of its position
    /// (index times [`POSITION_BYTES`]): the kernels address a particle in one instruction.
    a_at: [u32; LANES],
    /// The second particle of each lane, as a byte offset.
    b_at: [u32; LANES],
    /// The rest length (distance constraints) or largest length (limits) of each lane.
    pub length: Vec4,
    /// The inverse masses of the `a` particles, from [`PairBatches::set_weights`].
    pub wa: Vec4,
    /// The inverse masses of the `b` particles (zero for anchors that are only read).
    pub wb: Vec4,
}

/// The size of one position (`Vec3A`), bytes.
pub(crate) const POSITION_BYTES: u32 = std::mem::size_of::<Vec3A>() as u32;

/// Particles a batch can name: their byte offsets fit in a `u32`.
pub(crate) const MAX_PARTICLES: usize = (u32::MAX / POSITION_BYTES) as usize;

impl Batch {
    /// The first particle of each lane (always moved).
    #[inline(always)]
    pub fn a(&self) -> [u32; LANES] {
        self.a_at.map(|at| at / POSITION_BYTES)
    }

    /// The second particle of each lane (moved, or an anchor that is only read).
    #[inline(always)]
    pub fn b(&self) -> [u32; LANES] {
        self.b_at.map(|at| at / POSITION_BYTES)
    }

    /// Whether lane `k` repeats lane 0 to fill the batch.
    #[inline(always)]
    pub fn is_padding(&self, k: usize) -> bool {
        k > 0 && self.a_at[k] == self.a_at[0] && self.b_at[k] == self.b_at[0]
    }
}

/// A list of two-particle constraints grouped into batches of `LANES` (see the module
/// documentation).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PairBatches {
    batches: Vec<Batch>,
    /// Per batch: whether it reads a particle the previous batch moves (only where a list
    /// has no other choice, as many pairs on one particle); the sweep then finishes the
    /// previous batch before reading this one. Kept apart from the batches, which stay at
    /// 80 bytes.
    waits: Vec<bool>,
    pairs: usize,
    /// One past the largest particle index the batches name (`a` and, if it moves, `b`).
    particles: usize,
    /// One past the largest anchor index (`b` of tethers, which do not move it), or 0.
    anchors: usize,
    /// Whether `b` particles move (limits, distances) or are anchors that are only read.
    moves_b: bool,
}

impl PairBatches {
    /// Batches `pairs` (particle indices, each with its length), keeping the list's order as
    /// closely as batches allow. With `moves_b` false, the second index of a pair names an
    /// anchor in a list of its own that is only read (a pin, as for tethers:
    /// [`PairBatches::project_tethers`]), so pairs may share it. Pairs with an index at or
    /// past `particle_count` (or `MAX_PARTICLES`), or with both ends the same particle, are
    /// left out (they constrain nothing). Inverse masses start at zero: call
    /// [`PairBatches::set_weights`] before projecting.
    pub fn new(
        pairs: impl IntoIterator<Item = ([u32; 2], f32)>,
        particle_count: usize,
        moves_b: bool,
    ) -> Self {
        let particle_count = particle_count.min(MAX_PARTICLES);
        let (pairs, lengths): (Vec<[u32; 2]>, Vec<f32>) = pairs
            .into_iter()
            .filter(|&([a, b], _)| {
                (a != b || !moves_b)
                    && (a as usize) < particle_count
                    && (b as usize) < particle_count
            })
            .unzip();
        // The batch that last moved each particle; ids start at SEPARATION, so that a
        // particle never moved (0) is free.
        let mut moved = vec![0u32; particle_count];
        let mut waiting: Vec<usize> = Vec::new();
        let mut still_waiting: Vec<usize> = Vec::new();
        let mut next = 0;
        let mut batches = Vec::with_capacity(pairs.len().div_ceil(LANES));
        let mut batch_waits = Vec::with_capacity(pairs.len().div_ceil(LANES));
        while next < pairs.len() || !waiting.is_empty() {
            let id = batches.len() as u32 + SEPARATION;
            let mut lanes: Vec<usize> = Vec::with_capacity(LANES);
            // A pair fits if neither of its particles was moved in this batch or the last
            // SEPARATION - 1 ones (whether it moves `b` or only reads it).
            let mut try_take = |k: usize, lanes: &mut Vec<usize>| -> bool {
                let [a, b] = pairs[k];
                // An anchor is never moved: only a particle `b` that moves can be busy.
                let free = lanes.len() < LANES
                    && moved[a as usize] + SEPARATION <= id
                    && (!moves_b || moved[b as usize] + SEPARATION <= id);
                if free {
                    moved[a as usize] = id;
                    if moves_b {
                        moved[b as usize] = id;
                    }
                    lanes.push(k);
                }
                free
            };
            still_waiting.clear();
            for &k in &waiting {
                if !try_take(k, &mut lanes) {
                    still_waiting.push(k);
                }
            }
            let mut scanned = 0;
            while lanes.len() < LANES && next < pairs.len() && scanned < LOOK_AHEAD {
                let k = next;
                next += 1;
                scanned += 1;
                if !try_take(k, &mut lanes) {
                    still_waiting.push(k);
                }
            }
            std::mem::swap(&mut waiting, &mut still_waiting);
            let mut waits = false;
            if lanes.is_empty() {
                // Every candidate touches a particle the last batch moved: the oldest one
                // waits for it.
                let k = waiting.remove(0);
                let [a, b] = pairs[k];
                moved[a as usize] = id;
                if moves_b {
                    moved[b as usize] = id;
                }
                lanes.push(k);
                waits = true;
            }
            let first = lanes[0];
            let lane = |i: usize| lanes.get(i).copied().unwrap_or(first);
            batches.push(Batch {
                a_at: std::array::from_fn(|i| pairs[lane(i)][0] * POSITION_BYTES),
                b_at: std::array::from_fn(|i| pairs[lane(i)][1] * POSITION_BYTES),
                length: Vec4::from_array(std::array::from_fn(|i| lengths[lane(i)])),
                wa: Vec4::ZERO,
                wb: Vec4::ZERO,
            });
            batch_waits.push(waits);
        }
        let bound = |indices: &mut dyn Iterator<Item = u32>| {
            indices.map(|i| i as usize + 1).max().unwrap_or(0)
        };
        let particles = bound(&mut batches.iter().flat_map(|b| b.a()));
        let b_bound = bound(&mut batches.iter().flat_map(|b| b.b()));
        let (particles, anchors) = if moves_b {
            (particles.max(b_bound), 0)
        } else {
            (particles, b_bound)
        };
        Self {
            batches,
            waits: batch_waits,
            pairs: pairs.len(),
            particles,
            anchors,
            moves_b,
        }
    }

    /// Copies the inverse masses `w` into the batches (for anchors that are only read, zero).
    /// Does nothing if `w` does not hold every particle the batches move.
    pub fn set_weights(&mut self, w: &[f32]) {
        if w.len() < self.particles {
            return;
        }
        for batch in &mut self.batches {
            // Padding lanes get no weight, so that they move nothing.
            let live: [bool; LANES] = std::array::from_fn(|k| !batch.is_padding(k));
            let (a, b) = (batch.a(), batch.b());
            let wa = std::array::from_fn(|k| if live[k] { w[a[k] as usize] } else { 0.0 });
            let wb = std::array::from_fn(|k| {
                if live[k] && self.moves_b {
                    w[b[k] as usize]
                } else {
                    0.0
                }
            });
            batch.wa = Vec4::from_array(wa);
            batch.wb = Vec4::from_array(wb);
        }
    }

    /// The batches, in sweep order.
    pub fn batches(&self) -> &[Batch] {
        &self.batches
    }

    /// The constraints, `([a, b], length)`, in sweep order (padding lanes left out).
    pub fn pairs(&self) -> impl Iterator<Item = ([u32; 2], f32)> + '_ {
        self.batches.iter().flat_map(|batch| {
            (0..LANES)
                .filter(|&k| !batch.is_padding(k))
                .map(|k| ([batch.a()[k], batch.b()[k]], batch.length[k]))
        })
    }

    /// Per batch, whether it waits for the previous one (see the module documentation).
    pub fn waits(&self) -> &[bool] {
        &self.waits
    }

    /// How many constraints the batches hold.
    pub fn pair_count(&self) -> usize {
        self.pairs
    }

    /// How many batches there are.
    pub fn len(&self) -> usize {
        self.batches.len()
    }

    /// Whether there are no batches.
    pub fn is_empty(&self) -> bool {
        self.batches.is_empty()
    }

    /// Projects every batch as the distance constraints `|x_a - x_b| = length` (see
    /// [`super::constraints::project_distance`]), with one multiplier per lane in `lambdas`
    /// (one entry per batch, reset by the caller at the start of each substep). Does nothing
    /// if `x` or `lambdas` is too short.
    pub fn project_distances(&self, lambdas: &mut [Vec4], x: &mut [Vec3A], projection: Projection) {
        if x.len() < self.particles || lambdas.len() < self.batches.len() {
            return;
        }
        // SAFETY: every index in the batches is below `self.particles` (`new`), and `x`
        // holds that many particles.
        unsafe {
            match projection {
                Projection::Xpbd { .. } => lanes::sweep_distances::<true>(
                    &self.batches,
                    &self.waits,
                    lambdas,
                    x,
                    projection,
                ),
                Projection::Pbd { .. } => lanes::sweep_distances::<false>(
                    &self.batches,
                    &self.waits,
                    lambdas,
                    x,
                    projection,
                ),
            }
        };
    }

    /// Projects every batch as the unilateral limits `|x_a - x_b| <= length` (stiffness 1,
    /// see `stretch_limits.rs`), both ends moved by their inverse masses. A pair whose
    /// inverse masses sum to zero is left alone. Does nothing if `x` is too short or the
    /// batches were made for tethers.
    pub fn project_limits(&self, x: &mut [Vec3A]) {
        if x.len() < self.particles || !self.moves_b {
            return;
        }
        let xp: *mut [Vec3A] = x;
        // SAFETY: as in `project_distances`; the limits read their `b` from `x`.
        unsafe { lanes::sweep_limits::<true>(&self.batches, &self.waits, xp, xp) }
    }

    /// Projects every batch as a tether `|x_a - anchors_b| <= length` (stiffness 1, see
    /// `constraints.rs`): only `a` moves, towards its anchor, read from `anchors` (the pins'
    /// positions, copied by the caller). Does nothing if `x` or `anchors` is too short or
    /// the batches were made for two moving particles.
    pub fn project_tethers(&self, x: &mut [Vec3A], anchors: &[Vec3A]) {
        if x.len() < self.particles || anchors.len() < self.anchors || self.moves_b {
            return;
        }
        // SAFETY: as in `project_distances`, and every anchor index is below
        // `self.anchors`, which `anchors` holds; `anchors` is only read.
        unsafe { lanes::sweep_limits::<false>(&self.batches, &self.waits, x, anchors) }
    }
}

/// Runs `finish(batch k)` after `start(batch k + 1)` unless batch k + 1 waits for batch k:
/// the two-stage pipeline of a sweep. `finish` gets the batch's index.
#[cfg_attr(
    not(all(target_arch = "x86_64", target_feature = "sse2")),
    allow(dead_code)
)]
#[inline(always)]
fn pipelined<S>(
    batches: &[Batch],
    waits: &[bool],
    mut start: impl FnMut(&Batch) -> S,
    mut finish: impl FnMut(usize, &Batch, S),
) {
    let Some(first) = batches.first() else {
        return;
    };
    let mut started = start(first);
    for next in 1..batches.len() {
        let current = next - 1;
        if waits.get(next).copied().unwrap_or(true) {
            finish(current, &batches[current], started);
            started = start(&batches[next]);
        } else {
            let next_started = start(&batches[next]);
            finish(current, &batches[current], started);
            started = next_started;
        }
    }
    let last = batches.len() - 1;
    finish(last, &batches[last], started);
}

#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
mod lanes {
    //! The four-wide kernels, in SSE. Each lane's difference vector stays a 3-vector: the
    //! squared lengths are summed across a transpose, the scalar factors computed four-wide,
    //! and each lane's factor broadcast back onto its vector.
    //!
    //! Safety: SSE and SSE2 are part of the `x86_64` baseline (this module is only built with
    //! `target_feature = "sse2"`), so the intrinsics, none of which touches memory, are sound
    //! to call; particle indices are read without bounds checks, which the callers make
    //! sound by checking every index of the batches against `x` once per sweep.
    use core::arch::x86_64::*;

    use bevy::math::{Vec3A, Vec4};

    use super::{Batch, LANES, pipelined};
    use crate::cloth::constraints::Projection;

    /// The position at byte offset `at` in `x`.
    ///
    /// # Safety
    /// `at / POSITION_BYTES` is below `x.len()` (offsets are multiples of it).
    #[inline(always)]
    unsafe fn at(x: *const [Vec3A], at: u32) -> *mut Vec3A {
        // SAFETY: the caller's promise.
        unsafe { x.cast::<u8>().add(at as usize).cast::<Vec3A>().cast_mut() }
    }

    /// `xa[a_k] - xb[b_k]` for each lane, and the squared lengths as four lanes.
    ///
    /// # Safety
    /// Every `a` of `batch` is in `xa`, every `b` in `xb`, and both can be read.
    #[inline(always)]
    unsafe fn differences(
        xa: *const [Vec3A],
        xb: *const [Vec3A],
        batch: &Batch,
    ) -> ([__m128; LANES], __m128) {
        let d: [__m128; LANES] = std::array::from_fn(|k| {
            // SAFETY: the caller's promise.
            let (a, b) = unsafe { (*at(xa, batch.a_at[k]), *at(xb, batch.b_at[k])) };
            __m128::from(a - b)
        });
        // SAFETY: baseline intrinsics (module documentation).
        let len_sq = unsafe {
            let sq = d.map(|v| _mm_mul_ps(v, v));
            let t0 = _mm_unpacklo_ps(sq[0], sq[1]); // x0 x1 y0 y1
            let t1 = _mm_unpacklo_ps(sq[2], sq[3]); // x2 x3 y2 y3
            let t2 = _mm_unpackhi_ps(sq[0], sq[1]); // z0 z1 . .
            let t3 = _mm_unpackhi_ps(sq[2], sq[3]); // z2 z3 . .
            _mm_add_ps(
                _mm_add_ps(_mm_movelh_ps(t0, t1), _mm_movehl_ps(t1, t0)),
                _mm_movelh_ps(t2, t3),
            )
        };
        (d, len_sq)
    }

    /// `x[p_k] += d_k * f_k` for each lane, with `p_k` at byte offset `offsets[k]`.
    ///
    /// # Safety
    /// Every offset names a particle in `x`.
    #[inline(always)]
    unsafe fn move_along(x: &mut [Vec3A], offsets: [u32; LANES], d: &[__m128; LANES], f: __m128) {
        // SAFETY: baseline intrinsics (module documentation).
        let f = unsafe {
            [
                _mm_shuffle_ps::<0x00>(f, f),
                _mm_shuffle_ps::<0x55>(f, f),
                _mm_shuffle_ps::<0xAA>(f, f),
                _mm_shuffle_ps::<0xFF>(f, f),
            ]
        };
        for k in 0..LANES {
            // SAFETY: the caller's promise; baseline intrinsics.
            unsafe {
                *at(x, offsets[k]) += Vec3A::from(_mm_mul_ps(d[k], f[k]));
            }
        }
    }

    /// # Safety
    /// Every index of the batches is below `x.len()`, and `lambdas` has one entry per batch.
    #[inline(always)]
    pub(super) unsafe fn sweep_distances<const XPBD: bool>(
        batches: &[Batch],
        waits: &[bool],
        lambdas: &mut [Vec4],
        x: &mut [Vec3A],
        projection: Projection,
    ) {
        let xp = x as *mut [Vec3A];
        // XPBD: dl = (-C - alpha~ lambda) / (w + alpha~); PBD: dl = -k C / w, no multipliers.
        let (stiffness, alpha_tilde) = match projection {
            Projection::Xpbd { alpha_tilde } => (1.0, alpha_tilde),
            Projection::Pbd { stiffness } => (stiffness, 0.0),
        };
        // SAFETY: baseline intrinsics.
        let (k_stiffness, at, eps, zero) = unsafe {
            (
                _mm_set1_ps(stiffness),
                _mm_set1_ps(alpha_tilde),
                _mm_set1_ps(f32::EPSILON),
                _mm_setzero_ps(),
            )
        };
        pipelined(
            batches,
            waits,
            |batch| {
                // SAFETY: the caller's promise; `xp` is `x`, used by one closure at a time.
                unsafe {
                    let (d, len_sq) = differences(xp, xp, batch);
                    (d, _mm_sqrt_ps(len_sq))
                }
            },
            |k, batch, (d, len)| {
                // SAFETY: the caller's promise; baseline intrinsics; `xp` as above.
                unsafe {
                    let (wa, wb) = (__m128::from(batch.wa), __m128::from(batch.wb));
                    let rest = __m128::from(batch.length);
                    let weight = _mm_add_ps(wa, wb);
                    let c = _mm_sub_ps(len, rest);
                    let num = if XPBD {
                        let lam = __m128::from(*lambdas.get_unchecked(k));
                        _mm_sub_ps(zero, _mm_add_ps(c, _mm_mul_ps(at, lam)))
                    } else {
                        _mm_sub_ps(zero, _mm_mul_ps(k_stiffness, c))
                    };
                    // Lanes with no free particle, or with the two particles at one place,
                    // do nothing.
                    let active = _mm_and_ps(
                        _mm_cmpgt_ps(weight, zero),
                        _mm_cmpgt_ps(len, _mm_mul_ps(eps, rest)),
                    );
                    // s = dl / len.
                    let s = _mm_and_ps(
                        active,
                        _mm_div_ps(num, _mm_mul_ps(_mm_add_ps(weight, at), len)),
                    );
                    if XPBD {
                        let lambda = lambdas.get_unchecked_mut(k);
                        *lambda = Vec4::from(_mm_add_ps(__m128::from(*lambda), _mm_mul_ps(s, len)));
                    }
                    let x = &mut *xp;
                    move_along(x, batch.a_at, &d, _mm_mul_ps(s, wa));
                    move_along(x, batch.b_at, &d, _mm_sub_ps(zero, _mm_mul_ps(s, wb)));
                }
            },
        );
    }

    /// `MOVES_B`: whether `b` moves too (a limit between two particles, read from and
    /// written to `x`) or is an anchor read from `xb` (a tether: only `a` moves).
    ///
    /// # Safety
    /// Every `a` of the batches is below `x.len()` and every `b` below `xb.len()`; `x` is
    /// valid for writes and used by no one else; with `MOVES_B`, `xb` is `x`; without, `xb`
    /// is valid for reads and does not overlap `x`.
    #[inline(always)]
    pub(super) unsafe fn sweep_limits<const MOVES_B: bool>(
        batches: &[Batch],
        waits: &[bool],
        x: *mut [Vec3A],
        xb: *const [Vec3A],
    ) {
        let xp = x;
        pipelined(
            batches,
            waits,
            |batch| {
                // SAFETY: the caller's promise; baseline intrinsics; `xp` is `x`, used by one
                // closure at a time.
                unsafe {
                    let (d, len_sq) = differences(xp, xb, batch);
                    let limit = __m128::from(batch.length);
                    let stretched = _mm_cmpgt_ps(len_sq, _mm_mul_ps(limit, limit));
                    (d, len_sq, stretched)
                }
            },
            |_, batch, (d, len_sq, stretched)| {
                // SAFETY: as above.
                unsafe {
                    if _mm_movemask_ps(stretched) == 0 {
                        return;
                    }
                    let zero = _mm_setzero_ps();
                    let limit = __m128::from(batch.length);
                    let (wa, wb) = (__m128::from(batch.wa), __m128::from(batch.wb));
                    let weight = _mm_add_ps(wa, wb);
                    let active = _mm_and_ps(stretched, _mm_cmpgt_ps(weight, zero));
                    let len = _mm_sqrt_ps(len_sq);
                    // s = (len - limit) / (len weight), only where active.
                    let s = _mm_and_ps(
                        active,
                        _mm_div_ps(_mm_sub_ps(len, limit), _mm_mul_ps(len, weight)),
                    );
                    let x = &mut *xp;
                    move_along(x, batch.a_at, &d, _mm_sub_ps(zero, _mm_mul_ps(s, wa)));
                    if MOVES_B {
                        move_along(x, batch.b_at, &d, _mm_mul_ps(s, wb));
                    }
                }
            },
        );
    }
}

// The scalar kernels: the sweep's off `x86_64`; compiled in the tests everywhere, to be
// compared with the SIMD kernels.
#[cfg(any(test, not(all(target_arch = "x86_64", target_feature = "sse2"))))]
mod scalar;
#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
use scalar as lanes;

#[cfg(test)]
mod tests;
