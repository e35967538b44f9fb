//! The batched sweeps against the scalar projections, lane by lane.

use super::*;
use crate::cloth::constraints::{Tether, project_distance, project_tether};
use crate::cloth::stretch_limits::{StretchLimit, project_stretch_limit};

/// A grid's edges (rows, columns, one diagonal per quad), sorted.
fn grid(n: u32) -> (Vec<Vec3A>, Vec<[u32; 2]>) {
    let id = |i: u32, j: u32| i * (n + 1) + j;
    let mut edges = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            if j < n {
                edges.push([id(i, j), id(i, j + 1)]);
            }
            if i < n {
                edges.push([id(i, j), id(i + 1, j)]);
            }
            if i < n && j < n {
                edges.push([id(i, j), id(i + 1, j + 1)]);
            }
        }
    }
    edges.sort();
    // Positions scattered about the grid, so that every constraint has work to do.
    let positions = (0..(n + 1) * (n + 1))
        .map(|k| {
            let (i, j) = ((k / (n + 1)) as f32, (k % (n + 1)) as f32);
            let wobble = (k as f32 * 1.7).sin() * 0.3;
            Vec3A::new(
                j * 0.1 + wobble * 0.05,
                wobble * 0.1,
                i * 0.1 - wobble * 0.02,
            )
        })
        .collect();
    (positions, edges)
}

/// Each pair with its length.
fn zipped<'a>(
    pairs: &'a [[u32; 2]],
    lengths: &'a [f32],
) -> impl Iterator<Item = ([u32; 2], f32)> + 'a {
    pairs.iter().copied().zip(lengths.iter().copied())
}

/// The scalar sweep the batches stand for: `project(x, batch, k)` on every live lane, in
/// batch order, from `x0`.
fn scalar_reference(
    batched: &PairBatches,
    x0: &[Vec3A],
    mut project: impl FnMut(&mut [Vec3A], &Batch, usize),
) -> Vec<Vec3A> {
    let mut x = x0.to_vec();
    for batch in batched.batches() {
        for k in (0..LANES).filter(|&k| !batch.is_padding(k)) {
            project(&mut x, batch, k);
        }
    }
    x
}

fn inverse_masses(count: usize) -> Vec<f32> {
    // Two pins, the rest of varied mass.
    (0..count)
        .map(|k| {
            if k == 0 || k == 5 {
                0.0
            } else {
                1.0 + (k % 3) as f32
            }
        })
        .collect()
}

#[test]
fn batches_hold_every_pair_once_and_no_batch_moves_a_particle_twice() {
    let (x, edges) = grid(20);
    let lengths = vec![0.1; edges.len()];
    let batched = PairBatches::new(zipped(&edges, &lengths), x.len(), true);
    let mut seen: Vec<[u32; 2]> = Vec::new();
    for batch in batched.batches() {
        let mut particles = Vec::new();
        for k in 0..LANES {
            if batch.is_padding(k) {
                continue;
            }
            seen.push([batch.a()[k], batch.b()[k]]);
            particles.extend([batch.a()[k], batch.b()[k]]);
        }
        let count = particles.len();
        particles.sort();
        particles.dedup();
        assert_eq!(particles.len(), count, "a batch moves a particle twice");
    }
    seen.sort();
    assert_eq!(seen, edges);
    assert_eq!(batched.pair_count(), edges.len());
    // Nearly every batch is full.
    assert!(
        batched.len() * LANES < edges.len() * 11 / 10,
        "{}",
        batched.len()
    );
}

#[test]
fn batches_close_together_touch_no_particle_another_moves_unless_they_wait() {
    // A grid, and a fan of many pairs on one particle that forces batches to wait.
    let (x, mut pairs) = grid(12);
    pairs.extend((1..40).map(|k| [0, k]));
    let lengths = vec![0.1; pairs.len()];
    let batched = PairBatches::new(zipped(&pairs, &lengths), x.len(), true);
    let batches = batched.batches();
    let touched = |b: &Batch| -> Vec<u32> { b.a().into_iter().chain(b.b()).collect() };
    let mut waiting = 0;
    for k in 1..batches.len() {
        if batched.waits()[k] {
            waiting += 1;
            continue;
        }
        let here = touched(&batches[k]);
        let earlier = k.saturating_sub(SEPARATION as usize - 1);
        for (j, before) in batches[earlier..k].iter().enumerate() {
            // Only a batch that waits may follow one it depends on; further back, the
            // separation holds unless a batch in between waited.
            if batched.waits()[earlier + j + 1..=k].iter().any(|&w| w) {
                continue;
            }
            assert!(
                touched(before).iter().all(|p| !here.contains(p)),
                "batches {} and {k} share a particle",
                earlier + j
            );
        }
    }
    assert!(waiting > 0, "the fan never made a batch wait");
}

#[test]
fn a_fan_of_pairs_on_one_particle_projects_as_the_scalar_sweep_does() {
    let x0: Vec<Vec3A> = (0..30)
        .map(|k| {
            Vec3A::new(
                (k as f32 * 0.7).cos(),
                (k as f32 * 0.7).sin(),
                k as f32 * 0.01,
            )
        })
        .collect();
    let w = inverse_masses(x0.len());
    let pairs: Vec<[u32; 2]> = (1..30)
        .map(|k| [k, 0])
        .chain((1..29).map(|k| [k, k + 1]))
        .collect();
    let lengths: Vec<f32> = (0..pairs.len()).map(|k| 0.3 + 0.01 * k as f32).collect();
    let mut batched = PairBatches::new(zipped(&pairs, &lengths), x0.len(), true);
    batched.set_weights(&w);
    let mut x = x0.clone();
    let mut lambdas = vec![Vec4::ZERO; batched.len()];
    let projection = Projection::Xpbd { alpha_tilde: 0.0 };
    batched.project_distances(&mut lambdas, &mut x, projection);
    let reference = scalar_reference(&batched, &x0, |x, batch, k| {
        let pair = [batch.a()[k], batch.b()[k]];
        project_distance(x, &w, pair, batch.length[k], projection, &mut 0.0);
    });
    for (p, q) in x.iter().zip(&reference) {
        assert!(p.distance(*q) < 1e-5, "{p} against {q}");
    }
}

#[test]
fn batches_stay_close_to_the_list_order() {
    let (x, edges) = grid(20);
    let lengths = vec![0.1; edges.len()];
    let batched = PairBatches::new(zipped(&edges, &lengths), x.len(), true);
    let mut worst = 0usize;
    for (i, batch) in batched.batches().iter().enumerate() {
        for k in 0..LANES {
            let place = edges
                .iter()
                .position(|e| *e == [batch.a()[k], batch.b()[k]])
                .unwrap();
            worst = worst.max(place.abs_diff(i * LANES + k));
        }
    }
    assert!(worst <= 2 * LOOK_AHEAD, "a pair moved {worst} places");
}

#[test]
fn batched_distances_match_the_scalar_sweep_in_the_batch_order() {
    let (x0, edges) = grid(9);
    let w = inverse_masses(x0.len());
    let lengths: Vec<f32> = (0..edges.len())
        .map(|k| 0.08 + 0.01 * (k % 5) as f32)
        .collect();
    let mut batched = PairBatches::new(zipped(&edges, &lengths), x0.len(), true);
    batched.set_weights(&w);
    for projection in [
        Projection::Xpbd { alpha_tilde: 0.0 },
        Projection::Xpbd { alpha_tilde: 3.0 },
        Projection::Pbd { stiffness: 0.5 },
    ] {
        let mut x = x0.clone();
        let mut lambdas = vec![Vec4::ZERO; batched.len()];
        let mut reference = x0.clone();
        let mut reference_lambdas = vec![[0.0f32; LANES]; batched.len()];
        for _ in 0..3 {
            batched.project_distances(&mut lambdas, &mut x, projection);
            for (batch, lambdas) in batched.batches().iter().zip(&mut reference_lambdas) {
                for (k, lambda) in lambdas.iter_mut().enumerate() {
                    if !batch.is_padding(k) {
                        let pair = [batch.a()[k], batch.b()[k]];
                        let rest = batch.length[k];
                        project_distance(&mut reference, &w, pair, rest, projection, lambda);
                    }
                }
            }
        }
        for (p, q) in x.iter().zip(&reference) {
            assert!(p.distance(*q) < 1e-6, "{projection:?}: {p} against {q}");
        }
        for (batch, (l, r)) in batched
            .batches()
            .iter()
            .zip(lambdas.iter().zip(&reference_lambdas))
        {
            for k in 0..LANES {
                if !batch.is_padding(k) {
                    assert!((l[k] - r[k]).abs() < 1e-5 * (1.0 + r[k].abs()), "{l} {r:?}");
                }
            }
        }
    }
}

#[test]
fn batched_limits_and_tethers_match_the_scalar_projections() {
    let (x0, edges) = grid(9);
    let w = inverse_masses(x0.len());
    // Limits two and three edges long, shorter than some current distances.
    let limits: Vec<[u32; 2]> = edges.iter().map(|&[a, b]| [a, (b + 1).min(99)]).collect();
    let lengths: Vec<f32> = (0..limits.len())
        .map(|k| 0.05 + 0.02 * (k % 7) as f32)
        .collect();
    let mut batched = PairBatches::new(zipped(&limits, &lengths), x0.len(), true);
    batched.set_weights(&w);
    assert!(batched.pair_count() + 2 >= limits.len());
    let mut x = x0.clone();
    batched.project_limits(&mut x);
    let reference = scalar_reference(&batched, &x0, |x, batch, k| {
        let limit = StretchLimit {
            particles: [batch.a()[k], batch.b()[k]],
            length: batch.length[k],
        };
        project_stretch_limit(x, &w, &limit);
    });
    for (p, q) in x.iter().zip(&reference) {
        assert!(p.distance(*q) < 1e-6, "limits: {p} against {q}");
    }
    assert!(
        x.iter().zip(&x0).any(|(p, q)| p.distance(*q) > 1e-3),
        "nothing moved"
    );

    // Tethers of every particle to both pins, read from the anchor list [x0, x5]: the pins
    // are shared between lanes.
    let pins = [0u32, 5];
    let anchors: Vec<Vec3A> = pins.iter().map(|&p| x0[p as usize]).collect();
    let mut tethers = Vec::new();
    let mut tether_lengths = Vec::new();
    for slot in [0u32, 1] {
        for p in 0..x0.len() as u32 {
            if w[p as usize] > 0.0 {
                tethers.push([p, slot]);
                tether_lengths.push(0.2);
            }
        }
    }
    let mut batched = PairBatches::new(zipped(&tethers, &tether_lengths), x0.len(), false);
    batched.set_weights(&w);
    assert!(
        batched.len() * LANES < tethers.len() + LANES,
        "tethers fill every lane"
    );
    let mut x = x0.clone();
    batched.project_tethers(&mut x, &anchors);
    let reference = scalar_reference(&batched, &x0, |x, batch, k| {
        let tether = Tether {
            particle: batch.a()[k],
            anchor: pins[batch.b()[k] as usize],
            length: batch.length[k],
        };
        project_tether(x, &w, &tether);
    });
    for (p, q) in x.iter().zip(&reference) {
        assert!(p.distance(*q) < 1e-6, "tethers: {p} against {q}");
    }
    assert!(
        x.iter().zip(&x0).any(|(p, q)| p.distance(*q) > 1e-3),
        "no tether pulled"
    );
    assert_eq!(x[0], x0[0]);
    assert_eq!(x[5], x0[5]);
    // Too short an anchor list, or limits asked to project as tethers: nothing moves.
    let mut y = x0.clone();
    batched.project_tethers(&mut y, &anchors[..1]);
    batched.project_limits(&mut y);
    assert_eq!(y, x0);
}

#[test]
fn bad_pairs_are_left_out() {
    let pairs = [[0, 1], [2, 2], [1, 7], [3, 2]];
    let mut batched = PairBatches::new(zipped(&pairs, &[1.0; 4]), 4, true);
    assert_eq!(batched.pair_count(), 2);
    let mut x = vec![Vec3A::ZERO, Vec3A::X * 2.0, Vec3A::Y, Vec3A::Z];
    let w = [1.0; 4];
    batched.set_weights(&w);
    batched.project_limits(&mut x);
    assert!((x[0].distance(x[1]) - 1.0).abs() < 1e-6);
    assert!(x.iter().all(|p| p.is_finite()));
}

/// The scalar kernels (`scalar.rs`, the sweep off `x86_64`) give the SIMD kernels' positions
/// and multipliers on random lists of pairs (random particles, lengths and inverse masses,
/// pins among them, many pairs on one particle so that batches wait): distances (XPBD, stiff
/// and compliant, and PBD), limits and tethers.
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
#[test]
fn the_scalar_kernels_match_the_simd_kernels_on_random_batches() {
    let mut rng = crate::rng::Rng(0x5ca1_ab1e);
    let mut compared = 0;
    for _ in 0..20 {
        let n = 8 + rng.below(120);
        let x0: Vec<Vec3A> = (0..n).map(|_| Vec3A::from(rng.vec3(-1.0, 1.0))).collect();
        let w: Vec<f32> = (0..n)
            .map(|_| {
                if rng.uniform() < 0.1 {
                    0.0
                } else {
                    rng.range(0.2, 5.0)
                }
            })
            .collect();
        let count = n + rng.below(3 * n);
        let pairs: Vec<[u32; 2]> = (0..count)
            .map(|_| [rng.below(n) as u32, rng.below(n) as u32])
            .collect();
        let lengths: Vec<f32> = (0..count).map(|_| rng.range(0.05, 1.5)).collect();
        let close = |simd: &[Vec3A], scalar: &[Vec3A], what: &str| {
            for (p, q) in simd.iter().zip(scalar) {
                assert!(p.distance(*q) < 2e-5, "{what}: SIMD {p} against scalar {q}");
            }
            assert!(
                simd.iter().zip(&x0).any(|(p, q)| p.distance(*q) > 1e-3),
                "{what}: nothing moved"
            );
        };

        let mut batched = PairBatches::new(zipped(&pairs, &lengths), n, true);
        batched.set_weights(&w);
        let (batches, waits) = (batched.batches(), batched.waits());
        let alpha_tilde = rng.range(0.01, 2.0);
        for projection in [
            Projection::Xpbd { alpha_tilde: 0.0 },
            Projection::Xpbd { alpha_tilde },
            Projection::Pbd { stiffness: 0.7 },
        ] {
            let (mut simd, mut scalar) = (x0.clone(), x0.clone());
            let mut simd_lambdas = vec![Vec4::ZERO; batches.len()];
            let mut scalar_lambdas = simd_lambdas.clone();
            // Two sweeps: the second starts from the multipliers of the first.
            for _ in 0..2 {
                batched.project_distances(&mut simd_lambdas, &mut simd, projection);
                // SAFETY: every index of the batches is below `n` (`PairBatches::new`), and
                // there is one multiplier per batch.
                unsafe {
                    match projection {
                        Projection::Xpbd { .. } => scalar::sweep_distances::<true>(
                            batches,
                            waits,
                            &mut scalar_lambdas,
                            &mut scalar,
                            projection,
                        ),
                        Projection::Pbd { .. } => scalar::sweep_distances::<false>(
                            batches,
                            waits,
                            &mut scalar_lambdas,
                            &mut scalar,
                            projection,
                        ),
                    }
                }
            }
            close(&simd, &scalar, &format!("{projection:?}"));
            for (batch, (l, r)) in batches.iter().zip(simd_lambdas.iter().zip(&scalar_lambdas)) {
                for k in (0..LANES).filter(|&k| !batch.is_padding(k)) {
                    assert!(
                        (l[k] - r[k]).abs() <= 2e-5 * (1.0 + r[k].abs()),
                        "{projection:?}: multiplier {} (SIMD) against {} (scalar)",
                        l[k],
                        r[k]
                    );
                }
            }
            compared += 1;
        }

        let (mut simd, mut scalar) = (x0.clone(), x0.clone());
        batched.project_limits(&mut simd);
        let xp: *mut [Vec3A] = scalar.as_mut_slice();
        // SAFETY: as above; the limits read their `b` from the positions they move.
        unsafe { scalar::sweep_limits::<true>(batches, waits, xp, xp) };
        close(&simd, &scalar, "limits");

        // Tethers to a few pins, read from an anchor list of their own.
        let anchors: Vec<Vec3A> = (0..3).map(|_| Vec3A::from(rng.vec3(-1.0, 1.0))).collect();
        let tethers: Vec<[u32; 2]> = (0..count)
            .map(|_| [rng.below(n) as u32, rng.below(anchors.len()) as u32])
            .collect();
        let mut tethered = PairBatches::new(zipped(&tethers, &lengths), n, false);
        tethered.set_weights(&w);
        let (mut simd, mut scalar) = (x0.clone(), x0.clone());
        tethered.project_tethers(&mut simd, &anchors);
        // SAFETY: every particle index is below `n`, every anchor index below 3, and the
        // anchors do not overlap the positions.
        unsafe {
            scalar::sweep_limits::<false>(
                tethered.batches(),
                tethered.waits(),
                scalar.as_mut_slice(),
                anchors.as_slice(),
            );
        }
        close(&simd, &scalar, "tethers");
    }
    assert_eq!(compared, 60);
}
