//! One fixed step (1/60 s) of scene S1 at N = 32 and 64: XPBD at the default budget, and
//! mass-spring and hybrid with automatic substeps (the fewest substeps their explicit springs
//! are stable with, at the default spring constants). And a 32 x 32 sheet resting on a
//! scan-like triangle mesh (thin ears, open bottom) and on a closed dented rock.

use std::sync::Arc;

use bevy::math::Vec3;
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverMethod, SolverSettings};
use bevy_drape::collide::{RigidPose, SolverCollider, SolverShape, TriMesh};
use criterion::{Criterion, criterion_group, criterion_main};
use drape_scenes::scan::{ROCK, SCAN, scan};
use drape_scenes::scenes::{DENSITY, FRAME_RATE, GRAVITY, HangingCloth};

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

fn mesh_collider_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("mesh_collider_step");
    group.sample_size(20);
    let settings = SolverSettings::default();
    for (name, kind) in [("scan", SCAN), ("rock", ROCK)] {
        let model = scan(1, kind);
        let mesh = TriMesh::new(&model.vertices, &model.indices).expect("a valid mesh");
        let mut collider = SolverCollider::fixed(
            SolverShape::TriangleMesh(Arc::new(mesh)),
            RigidPose::IDENTITY,
        );
        collider.margin = 0.01;
        let grid = GridDesc::square(0.9, 32, Vec3::new(-0.45, 0.6, -0.45));
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, DENSITY).expect("a valid grid"));
        sim.set_colliders(std::slice::from_ref(&collider))
            .expect("a valid collider");
        // Settle on the model first.
        for _ in 0..120 {
            sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE)
                .expect("valid step input");
        }
        group.bench_function(format!("sheet_on_{name}"), |b| {
            b.iter(|| sim.step(&settings, GRAVITY, 1.0 / FRAME_RATE))
        });
    }
    group.finish();
}

mod group {
    #![allow(missing_docs)]
    use super::*;
    criterion_group!(benches, s1_step, mesh_collider_step);
}

criterion_main!(group::benches);
