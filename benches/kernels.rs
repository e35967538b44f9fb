//! One Gauss-Seidel sweep of scene S1's edge distance constraints at N = 64 (12 033 edges)
//! on the hanging cloth, three ways: scalar in sorted order, scalar as two interleaved
//! streams (consecutive projections independent), and batched four-wide
//! ([`PairBatches`]); then one batched sweep of its stretch limits and of its tethers. Each
//! iteration starts from the same positions.

use bevy::math::{Vec3A, Vec4};
use bevy_drape::cloth::SolverSettings;
use bevy_drape::cloth::internals::{
    PairBatches, Projection, project_distance, straight_line_limits,
};
use bevy_drape::cloth::{Edge, EdgeKind};
use criterion::{Criterion, criterion_group, criterion_main};
use drape_scenes::scenes::{FRAME_RATE, GRAVITY, HangingCloth};

fn edge_sweep(c: &mut Criterion) {
    let mut sim = HangingCloth { n: 64 }.build();
    for _ in 0..60 {
        sim.step(&SolverSettings::default(), GRAVITY, 1.0 / FRAME_RATE)
            .expect("valid step input");
    }
    let x0: Vec<Vec3A> = sim.state().positions.clone();
    let w = sim.state().inverse_masses.clone();
    let edges = &sim.model().edges;
    let pairs: Vec<[u32; 2]> = edges.iter().map(|e| e.particles).collect();
    let lengths: Vec<f32> = edges.iter().map(|e| e.rest_length).collect();
    let projection = Projection::Xpbd { alpha_tilde: 0.0 };
    let mut group = c.benchmark_group("edge_sweep_n64");
    group.sample_size(30);
    let mut x = x0.clone();
    let mut lambdas = vec![0.0; pairs.len()];
    group.bench_function("scalar_sorted", |b| {
        b.iter(|| {
            x.copy_from_slice(&x0);
            for ((p, l), lambda) in pairs.iter().zip(&lengths).zip(&mut lambdas) {
                project_distance(&mut x, &w, *p, *l, projection, lambda);
            }
        })
    });
    let half = pairs.len().div_ceil(2);
    group.bench_function("scalar_two_streams", |b| {
        b.iter(|| {
            x.copy_from_slice(&x0);
            for i in 0..half {
                for k in [i, i + half] {
                    if k < pairs.len() {
                        project_distance(
                            &mut x,
                            &w,
                            pairs[k],
                            lengths[k],
                            projection,
                            &mut lambdas[k],
                        );
                    }
                }
            }
        })
    });
    let mut batches = PairBatches::new(
        pairs.iter().copied().zip(lengths.iter().copied()),
        x0.len(),
        true,
    );
    batches.set_weights(&w);
    let mut batch_lambdas = vec![Vec4::ZERO; batches.len()];
    group.bench_function("batched", |b| {
        b.iter(|| {
            x.copy_from_slice(&x0);
            batches.project_distances(&mut batch_lambdas, &mut x, projection);
        })
    });
    group.bench_function("copy_only", |b| b.iter(|| x.copy_from_slice(&x0)));
    group.finish();

    // The long-range constraints of the same cloth: stretch limits (along the straight lines
    // of the structural edges, as the solver builds them) and tethers.
    let structural: Vec<Edge> = edges
        .iter()
        .copied()
        .filter(|e| e.kind == EdgeKind::Structural)
        .collect();
    let mut limits = PairBatches::new(
        straight_line_limits(&sim.model().rest_positions, &structural)
            .iter()
            .map(|l| (l.particles, l.length)),
        x0.len(),
        true,
    );
    limits.set_weights(&w);
    // Tethers read their anchors (the pins) from a list of their own.
    let mut pins: Vec<u32> = sim.tethers().iter().map(|t| t.anchor).collect();
    pins.sort_unstable();
    pins.dedup();
    let anchors: Vec<Vec3A> = pins.iter().map(|&p| x0[p as usize]).collect();
    let slot = |anchor: u32| pins.binary_search(&anchor).unwrap_or(0) as u32;
    let mut tethers = PairBatches::new(
        sim.tethers()
            .iter()
            .map(|t| ([t.particle, slot(t.anchor)], t.length)),
        x0.len(),
        false,
    );
    tethers.set_weights(&w);
    let mut group = c.benchmark_group("long_range_sweep_n64");
    group.sample_size(30);
    group.bench_function("limits_batched", |b| {
        b.iter(|| {
            x.copy_from_slice(&x0);
            limits.project_limits(&mut x);
        })
    });
    group.bench_function("tethers_batched", |b| {
        b.iter(|| {
            x.copy_from_slice(&x0);
            tethers.project_tethers(&mut x, &anchors);
        })
    });
    group.finish();
}

mod group {
    #![allow(missing_docs)]
    use super::*;
    criterion_group!(benches, edge_sweep);
}

criterion_main!(group::benches);
