//! The scalar kernels, lane by lane: the kernels off `x86_64`, and in the crate's tests
//! everywhere, where they are compared with the SIMD kernels (`tests.rs`).

use bevy::math::{Vec3A, Vec4};

use super::{Batch, LANES};
use crate::cloth::constraints::{Projection, Tether, project_distance, project_tether};
use crate::cloth::stretch_limits::{StretchLimit, project_stretch_limit};

/// Calls `f(k, [x_a, x_b], [w_a, w_b])` on each live lane `k` of `batch`, in order, and
/// writes the pair back.
fn each_lane(batch: &Batch, x: &mut [Vec3A], mut f: impl FnMut(usize, &mut [Vec3A], &[f32])) {
    for k in 0..LANES {
        if batch.is_padding(k) {
            continue;
        }
        let (a, b) = (batch.a()[k] as usize, batch.b()[k] as usize);
        let mut pair = [x[a], x[b]];
        f(k, &mut pair, &[batch.wa[k], batch.wb[k]]);
        [x[a], x[b]] = pair;
    }
}

/// Safe in fact; `unsafe` to match the SIMD kernels. `XPBD` only matches their
/// signature: the scalar projection reads the method from `projection`.
pub(super) unsafe fn sweep_distances<const XPBD: bool>(
    batches: &[Batch],
    _waits: &[bool],
    lambdas: &mut [Vec4],
    x: &mut [Vec3A],
    projection: Projection,
) {
    for (batch, lambda) in batches.iter().zip(lambdas.iter_mut()) {
        let mut lanes = lambda.to_array();
        each_lane(batch, x, |k, pair, w| {
            let rest = batch.length[k];
            project_distance(pair, w, [0, 1], rest, projection, &mut lanes[k]);
        });
        *lambda = Vec4::from_array(lanes);
    }
}

/// # Safety
/// As the SIMD kernel's.
pub(super) unsafe fn sweep_limits<const MOVES_B: bool>(
    batches: &[Batch],
    _waits: &[bool],
    x: *mut [Vec3A],
    xb: *const [Vec3A],
) {
    // SAFETY: the caller's promise.
    let x = unsafe { &mut *x };
    for batch in batches {
        if MOVES_B {
            each_lane(batch, x, |k, pair, w| {
                let limit = StretchLimit {
                    particles: [0, 1],
                    length: batch.length[k],
                };
                project_stretch_limit(pair, w, &limit);
            });
        } else {
            for k in 0..LANES {
                if batch.is_padding(k) {
                    continue;
                }
                let a = batch.a()[k] as usize;
                // SAFETY: the caller's promise.
                let anchor = unsafe { (*xb)[batch.b()[k] as usize] };
                let mut pair = [x[a], anchor];
                let tether = Tether {
                    particle: 0,
                    anchor: 1,
                    length: batch.length[k],
                };
                project_tether(&mut pair, &[batch.wa[k], 0.0], &tether);
                x[a] = pair[0];
            }
        }
    }
}
