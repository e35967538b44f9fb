//! Cloth entities in a headless App stepped on several threads.

use crate::common;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use common::{app, positions, spawn_cloth};

/// Independent cloths stepped on Bevy's compute task pool (`DrapeSettings::max_threads`)
/// end where they end stepped one after another, bit for bit.
#[test]
fn cloths_stepped_on_several_threads_end_where_one_thread_leaves_them() {
    let run = |threads: usize| {
        let mut app = app();
        app.insert_resource(DrapeSettings {
            max_threads: std::num::NonZeroUsize::new(threads),
            ..DrapeSettings::default()
        });
        app.world_mut().spawn((
            ClothCollider::sphere(0.25),
            Transform::from_xyz(0.0, -0.4, 0.0),
        ));
        let cloths: Vec<Entity> = (0..5u32)
            .map(|i| {
                let n = 6 + 2 * i;
                let grid = GridDesc::square(0.8, n, Vec3::new(-0.4, 0.0, -0.4));
                let pins = if i % 2 == 0 { vec![0] } else { vec![] };
                spawn_cloth(
                    &mut app,
                    &grid,
                    Cloth::pinned(pins),
                    Transform::from_xyz(0.1 * i as f32, 0.0, 0.0),
                )
            })
            .collect();
        for _ in 0..40 {
            app.update();
        }
        cloths
            .iter()
            .map(|&e| positions(&app, e))
            .collect::<Vec<_>>()
    };
    let one = run(1);
    let two = run(2);
    assert!(one.iter().flatten().all(|p| p.is_finite()));
    // They fell (and the pinned ones kept their pin).
    assert!(one.iter().all(|c| c.iter().any(|p| p.y < -0.1)));
    assert_eq!(one, two);
}

/// A single large cloth is split over two threads (`ClothSolver::step_with`): it falls as it
/// does on one thread, within millimetres, and stays finite; with one thread it is stepped
/// as the core steps it alone.
#[test]
fn a_single_large_cloth_steps_on_two_threads_where_one_thread_leaves_it() {
    let n = 64;
    let grid = GridDesc::square(1.0, n, Vec3::new(-0.5, 0.0, -0.5));
    let pins = [grid.index(0, 0), grid.index(n - 1, 0)];
    let run = |threads: usize| {
        let mut app = app();
        app.insert_resource(DrapeSettings {
            max_threads: std::num::NonZeroUsize::new(threads),
            ..DrapeSettings::default()
        });
        let cloth = spawn_cloth(&mut app, &grid, Cloth::pinned(pins), Transform::IDENTITY);
        for _ in 0..40 {
            app.update();
        }
        positions(&app, cloth)
    };
    let (one, two) = (run(1), run(2));
    assert!(two.iter().all(|p| p.is_finite()));
    let corner = grid.index(n - 1, n - 1) as usize;
    assert!(one[corner].y < -0.3, "the cloth fell: {}", one[corner]);
    let apart = one
        .iter()
        .zip(&two)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    println!("one and two threads at most {apart} m apart");
    assert!(apart < 5e-3, "{apart} m apart");
    let pool = bevy::tasks::ComputeTaskPool::get();
    if pool.thread_num() > 0 {
        assert!(apart > 0.0, "the cloth was not split");
    } else {
        println!("the compute pool has no thread of its own: nothing to split over");
    }
}
