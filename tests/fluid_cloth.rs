//! Fluid and cloth coupled both ways: momentum kept in free fall.

use bevy::math::{Quat, UVec2, Vec2, Vec3, Vec3A};
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverSettings};
use bevy_drape::fluid::{ClothBoundary, FluidSettings, FluidSolver};

const DT: f32 = 1.0 / 60.0;
const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);

/// A small deterministic generator (xorshift) in [0, 1).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// One fixed step of the pair: the cloth, then the fluid against where the cloth went, then
/// the fluid's impulses to the cloth.
fn step(
    cloth: &mut ClothSolver,
    settings: &SolverSettings,
    boundary: &mut ClothBoundary,
    fluid: &mut FluidSolver,
    gravity: Vec3,
) {
    cloth.step(settings, gravity, DT).unwrap();
    boundary.track(cloth);
    fluid.step(gravity, DT, std::slice::from_mut(boundary));
    boundary.give_impulses(cloth, DT);
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
/// weight's impulse alone, to f32 round-off, while they collide and exchange it.
#[test]
fn cloth_and_fluid_falling_together_keep_their_momentum() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    for case in 0..3 {
        let settings = SolverSettings {
            damping: 0.0,
            ..SolverSettings::default()
        };
        let mut cloth = sheet(0.4, 9 + case, Vec3::ZERO, 0.2 + rng.next());
        let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
        let lo = Vec3::new(-0.1, 0.03 + 0.05 * rng.next(), -0.1);
        fluid.add_box(lo, lo + Vec3::new(0.16, 0.1, 0.16)).unwrap();
        let thrown = Vec3::new(rng.next() - 0.5, -1.0 - 2.0 * rng.next(), rng.next() - 0.5);
        let x: Vec<Vec3> = fluid.positions().iter().map(|p| Vec3::from(*p)).collect();
        fluid.clear();
        fluid.add_particles(&x, thrown).unwrap();
        let mut boundary = ClothBoundary::new(&cloth);
        let total_mass = cloth_mass(&cloth) + fluid.particle_mass() * fluid.len() as f32;
        let start = Vec3::from(cloth_momentum(&cloth)) + fluid.momentum();
        let mut exchanged = 0.0f32;
        for k in 1..=40 {
            step(&mut cloth, &settings, &mut boundary, &mut fluid, GRAVITY);
            exchanged = exchanged.max(boundary.total_impulse().length());
            let expected = start + GRAVITY * total_mass * k as f32 * DT;
            // The impulse given to the cloth reaches it over its next step.
            let pending = Vec3::from(boundary.total_impulse());
            let total = Vec3::from(cloth_momentum(&cloth)) + fluid.momentum() + pending;
            let error = (total - expected).length();
            assert!(
                error <= 5e-4 * expected.length(),
                "case {case}, step {k}: momentum off by {error} of {expected}"
            );
        }
        eprintln!("case {case}: largest impulse of a step {exchanged:.4} N s");
        assert!(
            exchanged > 0.0,
            "case {case}: the fluid never touched the cloth"
        );
        assert!(cloth.is_finite());
    }
}
