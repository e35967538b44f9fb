//! Position Based Fluids against measurements: columns of fluid at rest in boxes, and the
//! dam break of Martin and Moyce (1952).

use crate::common;

use bevy::math::{Vec3, Vec3A};
use bevy_drape::collide::{ContactMaterial, SolverCollider};
use bevy_drape::fluid::{FluidSettings, FluidSolver};
use common::Rng;

const DT: f32 = 1.0 / 60.0;
const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);

/// The six walls of a box, without friction.
fn walls(min: Vec3, max: Vec3) -> [SolverCollider; 6] {
    let material = ContactMaterial {
        friction: 0.0,
        restitution: 0.0,
    };
    SolverCollider::box_walls(Vec3A::from(min), Vec3A::from(max), material)
}

/// Columns of random width, depth and height (up to 40 particles tall), at random particle
/// sizes, released in boxes that fit them: after 3 s each is compressed by at most 1% on
/// mean and 5% at its most compressed particle, over the whole last second, and its kinetic
/// energy has decayed (the last second's largest below a tenth of the first second's, and
/// below the second before it). (Measured with `cargo test --release --test fluid --
/// --nocapture`.)
#[test]
fn a_column_of_fluid_settles_at_its_rest_density() {
    let mut rng = Rng(0x853c_49e6_748f_ea9b);
    for case in 0..3 {
        let settings = FluidSettings {
            particle_radius: 0.008 + 0.004 * rng.uniform(),
            ..FluidSettings::default()
        };
        let s = settings.spacing();
        let size = Vec3::new(
            s * (6.0 + 8.0 * rng.uniform()).floor(),
            s * (15.0 + 25.0 * rng.uniform()).floor(),
            s * (6.0 + 8.0 * rng.uniform()).floor(),
        );
        let mut fluid = FluidSolver::new(settings).unwrap();
        let count = fluid.add_box(Vec3::ZERO, size).unwrap();
        let top = Vec3::new(size.x, 2.0 * size.y, size.z);
        fluid.set_colliders(&walls(Vec3::ZERO, top)).unwrap();
        let mut energy = [0.0f32; 4];
        let (mut mean, mut max) = (0.0f32, 0.0f32);
        for step in 0..240 {
            fluid.step(GRAVITY, DT);
            let second = step / 60;
            energy[second] = energy[second].max(fluid.kinetic_energy());
            if second == 3 {
                let error = fluid.density_error();
                mean = mean.max(error.mean);
                max = max.max(error.max);
            }
        }
        eprintln!(
            "case {case}: {count} particles, radius {:.4}, column {size}: density error mean \
             {mean:.4}, max {max:.4}; largest kinetic energy per second {energy:?}",
            settings.particle_radius
        );
        assert!(fluid.positions().iter().all(|p| p.is_finite()));
        assert_eq!(fluid.divergences(), 0);
        assert!(mean <= 0.01, "case {case}: mean density error {mean}");
        assert!(max <= 0.05, "case {case}: largest density error {max}");
        assert!(
            energy[3] < 0.1 * energy[0] && energy[3] < energy[2],
            "{energy:?}"
        );
    }
}

/// The surge front of a collapsing column `a` wide and `2 a` high (Martin and Moyce 1952,
/// Figure 3, `n^2 = 2`, the column 2.25 in wide; digitised as `z / a` against
/// `t sqrt(2 g / a)`), here `a = 0.2 m` across a quasi-two-dimensional tank four particles
/// deep with walls without friction, 16 particles across the column: over the first second
/// (`t sqrt(2 g / a)` up to 9.9) the front is within 10% of every measured point.
#[test]
fn a_dam_break_front_runs_as_martin_and_moyce_measured() {
    const MEASURED: [(f32, f32); 15] = [
        (0.832, 1.217),
        (1.219, 1.474),
        (1.997, 2.292),
        (2.547, 2.995),
        (3.345, 4.134),
        (4.034, 4.944),
        (4.418, 5.881),
        (5.091, 6.980),
        (5.685, 7.945),
        (6.306, 8.966),
        (6.822, 9.986),
        (7.439, 10.963),
        (8.031, 11.977),
        (8.633, 13.005),
        (9.237, 13.970),
    ];
    let a = 0.2;
    let settings = FluidSettings {
        particle_radius: a / 32.0,
        ..FluidSettings::default()
    };
    let mut fluid = FluidSolver::new(settings).unwrap();
    let depth = 4.0 * settings.spacing();
    let tank = Vec3::new(3.5, 1.0, depth);
    fluid
        .add_box(Vec3::ZERO, Vec3::new(a, 2.0 * a, depth))
        .unwrap();
    fluid.set_colliders(&walls(Vec3::ZERO, tank)).unwrap();
    let scale = (2.0 * 9.81 / a).sqrt();
    // (T, Z) after every step.
    let mut track = vec![(0.0f32, 1.0f32)];
    for step in 0..60 {
        fluid.step(GRAVITY, DT);
        let front = fluid.positions().iter().map(|p| p.x).fold(0.0f32, f32::max);
        track.push(((step + 1) as f32 * DT * scale, front / a));
    }
    let mut worst = 0.0f32;
    for (t, z) in MEASURED {
        let k = track
            .partition_point(|&(tt, _)| tt < t)
            .clamp(1, track.len() - 1);
        let (t0, z0) = track[k - 1];
        let (t1, z1) = track[k];
        let simulated = z0 + (z1 - z0) * (t - t0) / (t1 - t0);
        let error = simulated / z - 1.0;
        eprintln!(
            "T {t:.3}: measured Z {z:.3}, simulated {simulated:.3} ({:+.1}%)",
            100.0 * error
        );
        worst = worst.max(error.abs());
    }
    assert!(worst <= 0.10, "the front is {:.1}% off", 100.0 * worst);
    assert!(fluid.positions().iter().all(|p| p.is_finite()));
}
