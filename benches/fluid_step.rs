//! One fixed step (1/60 s) of water: a column of 4096 particles at rest in a box on its own
//! (`FluidSolver::step`, the default budget of 6 x 4), and the `pour` scene's 600 particles at
//! rest in the hammock stepped with it (`FluidSolver::step_with_cloth`, the cloth at 16 x 4),
//! beside the same hammock's step with no water.

use bevy::math::{Vec3, Vec3A};
use bevy_drape::collide::{ContactMaterial, SolverCollider};
use bevy_drape::fluid::{FluidSettings, FluidSolver};
use criterion::{Criterion, criterion_group, criterion_main};
use drape_scenes::scenes::{FRAME_RATE, GRAVITY};
use drape_scenes::water::Pour;

/// A column of `16 x 16 x 16` particles in a box of six planes, settled for a second.
fn column() -> FluidSolver {
    let settings = FluidSettings::default();
    let mut fluid = FluidSolver::new(settings).expect("default settings are valid");
    let side = 16.0 * settings.spacing();
    let walls: Vec<SolverCollider> = [
        (Vec3A::ZERO, Vec3A::Y),
        (Vec3A::new(-side / 2.0, 0.0, 0.0), Vec3A::X),
        (Vec3A::new(side / 2.0, 0.0, 0.0), Vec3A::NEG_X),
        (Vec3A::new(0.0, 0.0, -side / 2.0), Vec3A::Z),
        (Vec3A::new(0.0, 0.0, side / 2.0), Vec3A::NEG_Z),
    ]
    .into_iter()
    .map(|(point, normal)| SolverCollider::plane(point, normal, ContactMaterial::default()))
    .collect();
    fluid.set_colliders(&walls).expect("planes are valid");
    fluid
        .add_box(
            Vec3::new(-side / 2.0, 0.0, -side / 2.0),
            Vec3::new(side / 2.0, side, side / 2.0),
        )
        .expect("the box is not empty");
    for _ in 0..60 {
        fluid.step(GRAVITY, 1.0 / FRAME_RATE);
    }
    fluid
}

fn fluid_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("fluid_step");
    group.sample_size(20);
    let mut fluid = column();
    assert_eq!(fluid.len(), 4096);
    group.bench_function("column_4096", |b| {
        b.iter(|| fluid.step(GRAVITY, 1.0 / FRAME_RATE))
    });
    let scene = Pour::default();
    let run = scene.run(240);
    let (mut cloth, mut water) = (run.cloth.clone(), run.fluid);
    assert!(run.finite && water.len() == scene.jet.max_particles);
    group.bench_function("pour_600_with_cloth", |b| {
        b.iter(|| water.step_with_cloth(&mut cloth, &scene.cloth, GRAVITY, 1.0 / FRAME_RATE))
    });
    let mut dry = run.cloth;
    group.bench_function("pour_cloth_alone", |b| {
        b.iter(|| dry.step(&scene.cloth, GRAVITY, 1.0 / FRAME_RATE))
    });
    group.finish();
}

mod group {
    #![allow(missing_docs)]
    use super::*;
    criterion_group!(benches, fluid_step);
}

criterion_main!(group::benches);
