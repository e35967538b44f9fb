//! Self-collision in a headless App: the sheet-drop scene with and without it; mass-spring's
//! discrete self-collision on two layers.

use crate::common;

use bevy::prelude::*;
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverMethod, SolverSettings};
use bevy_drape::prelude::*;
use common::{Headless, add_grid};
use drape_scenes::scenes::{SheetDrop, closest_non_adjacent};

/// Drops the sheet for 3 s in an App and returns, over every frame, the closest two particles
/// that share no edge came, in grid spacings (infinite if never within one spacing), and the
/// most pairs held apart in a step. The whole run counts, not its last frame: the folds the
/// sheet makes when it lands may slide out flat again later, or not, depending on the last
/// bits of the arithmetic.
fn drop_sheet(self_collision: SelfCollisionMethod) -> (f32, usize) {
    let mut app = Headless::new().seconds_per_update(1.0 / 60.0).build();
    let scene = SheetDrop::new(20);
    let mesh = add_grid(&mut app, &scene.grid());
    let settings = ClothSettings {
        solver: SheetDrop::settings(self_collision),
        ..default()
    };
    let cloth = app
        .world_mut()
        .spawn((Mesh3d(mesh), Cloth::default(), settings))
        .id();
    app.world_mut().spawn(
        ClothCollider::plane()
            .with_friction(SheetDrop::FRICTION)
            .with_margin(0.0),
    );
    let spacing = 1.0 / (scene.n - 1) as f32;
    let (mut gap, mut contacts) = (f32::INFINITY, 0);
    for _ in 0..181 {
        app.update();
        let Some(sim) = app
            .world()
            .get::<ClothSimulation>(cloth)
            .map(|c| c.solver())
        else {
            continue;
        };
        let g = closest_non_adjacent(sim, spacing).unwrap_or(f32::INFINITY) / spacing;
        gap = gap.min(g);
        contacts = contacts.max(sim.self_contact_count());
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    assert!(sim.is_finite());
    (gap, contacts)
}

#[test]
fn with_self_collision_the_folds_of_a_dropped_sheet_stay_apart_and_without_it_they_pass_through() {
    let (gap_on, contacts_on) = drop_sheet(SelfCollisionMethod::Particles);
    let (gap_off, _) = drop_sheet(SelfCollisionMethod::Off);
    // The folds touch: particles are held apart, at nearly one spacing, all the way.
    assert!(contacts_on > 0, "the sheet piles up onto itself");
    assert!(
        gap_on > 0.5,
        "self-collision on: closest gap {gap_on} spacings"
    );
    assert!(
        gap_off < 0.5,
        "self-collision off: closest gap {gap_off} spacings"
    );
}

/// Mass-spring's self-collision is discrete (`SelfCollision::project` with velocities): each
/// push apart also changes the velocities, which are mass-spring's own. Two parallel layers of
/// one cloth (no gravity), closing at 2 m/s, have their approach velocity removed once they
/// touch, and stay about one spacing apart.
#[test]
fn mass_spring_self_collision_removes_the_approach_velocity_of_two_layers() {
    let (n, spacing, gap) = (6u32, 0.1f32, 0.16f32);
    let layer = |y: f32| GridDesc::square(spacing * (n - 1) as f32, n, Vec3::new(0.0, y, 0.0));
    let (lower, upper) = (layer(1.0).mesh(), layer(1.0 + gap).mesh());
    let count = lower.positions.len() as u32;
    let positions: Vec<Vec3> = lower
        .positions
        .iter()
        .chain(&upper.positions)
        .copied()
        .collect();
    let indices: Vec<u32> = lower
        .indices
        .iter()
        .copied()
        .chain(upper.indices.iter().map(|&i| i + count))
        .collect();
    let model = ClothModel::from_triangles(&positions, &indices, 0.1).unwrap();
    let mut sim = ClothSolver::new(model);
    let speed = 1.0;
    for (i, v) in sim.state_mut().velocities.iter_mut().enumerate() {
        v.y = if (i as u32) < count { speed } else { -speed };
    }
    let settings = SolverSettings {
        method: SolverMethod::MassSpring,
        self_collision: SelfCollisionMethod::Particles,
        auto_substeps: true,
        damping: 0.0,
        ..Default::default()
    };
    let (mut touched, mut closest, mut worst) = (None, f32::MAX, 0.0f32);
    for frame in 0..20 {
        sim.step(&settings, Vec3::ZERO, 1.0 / 60.0).unwrap();
        let state = sim.state();
        // Each particle of the upper layer against the one below it.
        let (mut nearest, mut approach) = (f32::MAX, 0.0f32);
        for i in 0..count as usize {
            let j = i + count as usize;
            nearest = nearest.min(state.positions[j].y - state.positions[i].y);
            approach = approach.max(state.velocities[i].y - state.velocities[j].y);
        }
        closest = closest.min(nearest);
        if touched.is_none() && nearest < spacing * 1.01 {
            touched = Some(frame);
        } else if touched.is_some() {
            worst = worst.max(approach);
        }
    }
    println!(
        "layers touched in frame {touched:?}, closest {closest:.4} m, fastest approach after \
         {worst:.2e} m/s (from {:.1} m/s)",
        2.0 * speed
    );
    assert!(touched.is_some_and(|f| f < 10), "the layers met");
    assert!(closest > 0.9 * spacing, "the layers came {closest} m close");
    assert!(
        worst < 0.02 * speed,
        "the layers still approach at {worst} m/s after touching"
    );
}

/// The triangle method on generated drops (tilt, height and turn from the seed): a coarse
/// sheet that folds onto itself never has a particle through one of its triangles, where the
/// same drops without self-collision cross it hundreds of times, and its edges stay within
/// 1% when it comes to rest.
#[test]
fn generated_drops_fold_without_crossings_with_the_triangle_method() {
    let (mut crossings_off, mut folded) = (0, 0);
    for seed in 1..=4 {
        let scene = SheetDrop::generated(12, seed);
        let off = scene.run(&SheetDrop::settings(SelfCollisionMethod::Off), 150);
        crossings_off += off.crossings;
        let on = scene.run(&SheetDrop::settings(SelfCollisionMethod::Triangles), 150);
        assert!(on.finite, "seed {seed}");
        assert_eq!(on.crossings, 0, "seed {seed}: {scene:?}");
        assert!(
            on.max_strain < 0.01,
            "seed {seed}: strain {}",
            on.max_strain
        );
        folded += usize::from(on.sim.self_contact_count() > 0);
    }
    assert!(
        crossings_off > 100,
        "the drops fold: {crossings_off} crossings without"
    );
    assert!(folded >= 2, "the layers touched in {folded} drops");
}
