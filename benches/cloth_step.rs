//! One fixed step (1/60 s) of scene S1 at N = 32 and 64, at the default budget.

use bevy_drape::cloth::SolverSettings;
use bevy_drape::scenes::{FRAME_RATE, GRAVITY, HangingCloth};
use criterion::{Criterion, criterion_group, criterion_main};

fn s1_step(c: &mut Criterion) {
    let settings = SolverSettings::default();
    for n in [32, 64] {
        let scene = HangingCloth { n };
        let mut sim = scene.build();
        // Let it fall first, so the step works on a hanging cloth rather than a flat one.
        for _ in 0..60 {
            sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE);
        }
        c.bench_function(&format!("s1_step_n{n}"), |b| {
            b.iter(|| sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE))
        });
    }
}

mod group {
    #![allow(missing_docs)]
    use super::*;
    criterion_group!(benches, s1_step);
}

criterion_main!(group::benches);
