//! Fluid and cloth stepped together: momentum kept in free fall, a sheet held at its corners
//! carries the water's weight, a closed cloth bag holds its water.

use crate::common;

use bevy::math::{Quat, UVec2, Vec2, Vec3, Vec3A};
use bevy::prelude::{Mesh, Meshable, Sphere};
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverSettings, weld};
use bevy_drape::fluid::{FluidSettings, FluidSolver};
use bevy_drape::mesh::mesh_triangles;
use common::Rng;
use drape_scenes::water::particles_below_sheet;

const DT: f32 = 1.0 / 60.0;
const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);

/// The cloth's budget under water: 16 x 4. Water is 30 to 40 times heavier than the cloth
/// that holds it, and the contacts and the cloth's edges meet over the iterations: at the
/// default 8 x 2 the sheet below carries 28% of the water's weight and lets it spill (8 x 4
/// 65%, 16 x 2 96%, 16 x 4 96%; the bag stretches 40% and leaks at 8 x 2, holds at 16 x 4).
fn water_budget() -> SolverSettings {
    SolverSettings {
        substeps: 16,
        iterations: 4,
        ..SolverSettings::default()
    }
}

fn cloth_momentum(cloth: &ClothSolver) -> Vec3A {
    let s = cloth.state();
    s.velocities
        .iter()
        .zip(&s.inverse_masses)
        .map(|(v, &w)| *v / w)
        .sum()
}

fn cloth_mass(cloth: &ClothSolver) -> f32 {
    cloth.state().inverse_masses.iter().map(|w| 1.0 / w).sum()
}

/// A horizontal square sheet of side `size` centred on `centre`, `n` x `n` particles.
fn sheet(size: f32, n: u32, centre: Vec3, density: f32) -> ClothSolver {
    let grid = GridDesc {
        size: Vec2::splat(size),
        vertices: UVec2::splat(n),
        orientation: Quat::IDENTITY,
        origin: centre - Vec3::new(size / 2.0, 0.0, size / 2.0),
    };
    ClothSolver::new(ClothModel::grid(&grid, density).unwrap())
}

/// Random blocks of fluid thrown at random speeds onto a free sheet, everything falling with
/// no collider and no damping: the momentum of cloth and fluid together changes by the
/// weight's impulse alone, to f32 round-off (1e-4 of it over 2 s), while they collide and
/// exchange it.
#[test]
fn cloth_and_fluid_falling_together_keep_their_momentum() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    for case in 0..3 {
        let settings = SolverSettings {
            damping: 0.0,
            ..SolverSettings::default()
        };
        let mut cloth = sheet(0.4, 9 + case, Vec3::ZERO, 0.2 + rng.uniform());
        let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
        let lo = Vec3::new(-0.1, 0.03 + 0.05 * rng.uniform(), -0.1);
        fluid.add_box(lo, lo + Vec3::new(0.16, 0.1, 0.16)).unwrap();
        let thrown = Vec3::new(
            rng.uniform() - 0.5,
            -1.0 - 2.0 * rng.uniform(),
            rng.uniform() - 0.5,
        );
        let x: Vec<Vec3> = fluid.positions().iter().map(|p| Vec3::from(*p)).collect();
        fluid.clear();
        fluid.add_particles(&x, thrown).unwrap();
        let total_mass = cloth_mass(&cloth) + fluid.particle_mass() * fluid.len() as f32;
        let start = Vec3::from(cloth_momentum(&cloth)) + fluid.momentum();
        let (mut exchanged, mut worst) = (0.0f32, 0.0f32);
        for k in 1..=120 {
            fluid
                .step_with_cloth(&mut cloth, &settings, GRAVITY, DT)
                .unwrap();
            exchanged = exchanged.max(fluid.cloth_contacts().impulse().length());
            let expected = start + GRAVITY * total_mass * k as f32 * DT;
            let total = Vec3::from(cloth_momentum(&cloth)) + fluid.momentum();
            let error = (total - expected).length();
            worst = worst.max(error / expected.length());
            assert!(
                error <= 1e-4 * expected.length(),
                "case {case}, step {k}: momentum off by {error} of {expected}"
            );
        }
        eprintln!(
            "case {case}: largest impulse of a step {exchanged:.4} N s, momentum off by {worst:.1e} at worst"
        );
        assert!(
            exchanged > 0.0,
            "case {case}: the fluid never touched the cloth"
        );
        assert!(cloth.is_finite());
    }
}

/// A sheet held at its four corners, pulled in to 70% of its width so that it hangs as a
/// bowl, with a block of water dropped into it: after 3 s the fluid pushes on the cloth with
/// the water's weight (the impulse per step against `M g dt`, over the last half second,
/// within 10%), the sheet hangs lower than without the water, and no fluid particle is below
/// the sheet where it lies over it.
#[test]
fn a_sheet_held_at_its_corners_carries_the_waters_weight() {
    let settings = water_budget();
    let n = 15;
    let size = 0.6;
    let make = || {
        let mut c = sheet(size, n, Vec3::new(0.0, 0.5, 0.0), 0.2);
        let corners = [0, n - 1, n * (n - 1), n * n - 1];
        c.set_pins(&corners).unwrap();
        for k in corners {
            let p = Vec3::from(c.state().positions[k as usize]);
            let inward = Vec3::new(p.x * 0.7, p.y, p.z * 0.7);
            c.set_pin_target(k, inward);
        }
        c
    };
    let mut dry = make();
    for _ in 0..180 {
        dry.step(&settings, GRAVITY, DT).unwrap();
    }
    let mut cloth = make();
    let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
    fluid
        .add_box(Vec3::new(-0.06, 0.5, -0.06), Vec3::new(0.06, 0.6, 0.06))
        .unwrap();
    let weight = fluid.particle_mass() * fluid.len() as f32 * 9.81;
    let mut carried = 0.0f32;
    for k in 0..180 {
        fluid
            .step_with_cloth(&mut cloth, &settings, GRAVITY, DT)
            .unwrap();
        if k >= 150 {
            carried += -fluid.cloth_contacts().impulse().y / DT / 30.0;
        }
    }
    let lowest = |c: &ClothSolver| {
        c.state()
            .positions
            .iter()
            .map(|p| p.y)
            .fold(f32::MAX, f32::min)
    };
    let below = particles_below_sheet(
        &cloth.state().positions,
        &cloth.model().triangles,
        fluid.positions(),
    );
    eprintln!(
        "{} particles, weight {weight:.3} N, carried {carried:.3} N; lowest point {:.3} m \
         (dry {:.3} m); {below} particles below the sheet; largest strain {:.4}",
        fluid.len(),
        lowest(&cloth),
        lowest(&dry),
        cloth.strain().max
    );
    assert!(
        (carried / weight - 1.0).abs() <= 0.1,
        "carried {carried} of {weight}"
    );
    assert!(lowest(&cloth) < lowest(&dry) - 0.005);
    assert_eq!(below, 0);
    assert!(cloth.is_finite() && fluid.positions().iter().all(|p| p.is_finite()));
}

/// Whether `p` is inside the closed triangle mesh (a ray crosses it an odd number of times;
/// the ray is tilted so that it misses edges and vertices).
fn inside(p: Vec3A, x: &[Vec3A], triangles: &[[u32; 3]]) -> bool {
    let dir = Vec3A::new(1.0, 0.0123, 0.0071).normalize();
    let mut crossings = 0;
    for t in triangles {
        let [a, b, c] = t.map(|k| x[k as usize]);
        let (e1, e2) = (b - a, c - a);
        let pv = dir.cross(e2);
        let det = e1.dot(pv);
        if det.abs() < 1e-12 {
            continue;
        }
        let tv = p - a;
        let u = tv.dot(pv) / det;
        let qv = tv.cross(e1);
        let v = dir.dot(qv) / det;
        let s = e2.dot(qv) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && s > 0.0 {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// A closed bag of cloth (a welded UV sphere whose edges are about three times the fluid's
/// spacing) hung from its top, half filled with water that falls and sloshes as the pin
/// catches the bag: over 10 s no fluid particle is ever outside it.
#[test]
fn a_closed_cloth_bag_holds_its_water_for_ten_seconds() {
    let radius = 0.15;
    let mesh: Mesh = Sphere::new(radius).mesh().uv(16, 10);
    let (positions, indices) = mesh_triangles(&mesh).unwrap();
    let welded = weld(&positions, &indices, 1e-6);
    let centre = Vec3::new(0.0, 0.6, 0.0);
    let lifted: Vec<Vec3> = welded.positions.iter().map(|p| *p + centre).collect();
    let model = ClothModel::from_triangles(&lifted, &welded.indices, 0.2).unwrap();
    let top = (0..lifted.len())
        .max_by(|&a, &b| lifted[a].y.total_cmp(&lifted[b].y))
        .unwrap() as u32;
    let mut cloth = ClothSolver::new(model);
    cloth.set_pins(&[top]).unwrap();
    let settings = water_budget();
    let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
    let half = radius * 0.55;
    fluid
        .add_box(
            centre - Vec3::new(half, half, half),
            centre + Vec3::new(half, 0.0, half),
        )
        .unwrap();
    let outside = |cloth: &ClothSolver, fluid: &FluidSolver| {
        let x = &cloth.state().positions;
        fluid
            .positions()
            .iter()
            .filter(|p| !inside(**p, x, &cloth.model().triangles))
            .count()
    };
    assert_eq!(outside(&cloth, &fluid), 0, "at the start");
    let mut worst = 0usize;
    for _ in 0..600 {
        fluid
            .step_with_cloth(&mut cloth, &settings, GRAVITY, DT)
            .unwrap();
        let out = outside(&cloth, &fluid);
        worst = worst.max(out);
    }
    eprintln!(
        "{} fluid particles in a bag of {} triangles: at most {worst} outside; largest strain \
         at the end {:.4}",
        fluid.len(),
        cloth.model().triangles.len(),
        cloth.strain().max
    );
    assert_eq!(worst, 0);
    assert!(cloth.is_finite() && fluid.positions().iter().all(|p| p.is_finite()));
}
