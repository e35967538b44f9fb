//! One fixed step (1/60 s) of scene S1 at N = 32 and 64: XPBD at the default budget, and
//! mass-spring and hybrid with automatic substeps (the fewest substeps their explicit springs
//! are stable with, at the default spring constants).

use bevy_drape::cloth::{SolverMethod, SolverSettings};
use criterion::{Criterion, criterion_group, criterion_main};
use drape_scenes::scenes::{FRAME_RATE, GRAVITY, HangingCloth};

fn s1_step(c: &mut Criterion) {
    let methods = [
        ("xpbd", SolverMethod::Xpbd),
        ("mass_spring", SolverMethod::MassSpring),
        ("hybrid", SolverMethod::Hybrid { long_range: false }),
    ];
    let mut group = c.benchmark_group("s1_step");
    group.sample_size(20);
    for n in [32, 64] {
        for (name, method) in methods {
            let settings = SolverSettings {
                method,
                auto_substeps: method != SolverMethod::Xpbd,
                ..Default::default()
            };
            let scene = HangingCloth { n };
            let mut sim = scene.build();
            // Let it fall first, so the step works on a hanging cloth rather than a flat one.
            for _ in 0..60 {
                sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE)
                    .expect("valid step input");
            }
            assert!(sim.is_finite(), "{name} at N = {n} diverged");
            group.bench_function(format!("{name}_n{n}"), |b| {
                b.iter(|| sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE))
            });
        }
    }
    group.finish();
}

mod group {
    #![allow(missing_docs)]
    use super::*;
    criterion_group!(benches, s1_step);
}

criterion_main!(group::benches);
