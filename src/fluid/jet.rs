//! A round jet of fluid: particles leave a disc at a steady rate, placed on a sunflower
//! spiral so that those of one step spread over the disc.

use bevy::math::Vec3;
use bevy::reflect::Reflect;

use super::solver::FluidSolver;
use crate::error::FluidError;

/// A round jet: `rate` particles per second leave a disc of `radius` at `origin` with
/// `velocity` (the disc faces it), until the fluid has `max_particles`.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct FluidJet {
    /// The disc's centre (world).
    pub origin: Vec3,
    /// The particles' velocity, m/s.
    pub velocity: Vec3,
    /// The disc's radius, metres.
    pub radius: f32,
    /// Particles per second.
    pub rate: f32,
    /// The most particles the jet makes.
    pub max_particles: usize,
}

/// What a jet carries from one step to the next: the fraction of a particle it owes and
/// where on its spiral the next particle goes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct JetEmitter {
    owed: f32,
    spiral: u32,
}

impl JetEmitter {
    /// Adds to `fluid` the particles `jet` makes in `dt` seconds: how many.
    pub fn emit(
        &mut self,
        jet: &FluidJet,
        fluid: &mut FluidSolver,
        dt: f32,
    ) -> Result<usize, FluidError> {
        let rate = if jet.rate.is_finite() { jet.rate } else { 0.0 };
        self.owed += rate.max(0.0) * dt.max(0.0);
        let room = jet.max_particles.saturating_sub(fluid.len());
        let count = (self.owed.floor() as usize).min(room);
        self.owed -= count as f32;
        if count == 0 {
            // Nothing owed piles up while the fluid is full.
            self.owed = self.owed.min(1.0);
            return Ok(0);
        }
        let axis = jet.velocity.normalize_or(Vec3::NEG_Y);
        let (u, v) = axis.any_orthonormal_pair();
        let points: Vec<Vec3> = (0..count)
            .map(|_| {
                let k = self.spiral as f32 + 0.5;
                let r = jet.radius * (k / 64.0).fract().sqrt();
                let a = k * 2.399_963; // the golden angle
                self.spiral = self.spiral.wrapping_add(1);
                jet.origin + (u * a.cos() + v * a.sin()) * r
            })
            .collect();
        fluid.add_particles(&points, jet.velocity)?;
        Ok(count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::settings::FluidSettings;

    /// Over whole seconds the jet makes `rate` particles a second, whatever the step, stops
    /// at its count, and puts every particle on its disc.
    #[test]
    fn a_jet_keeps_its_rate_and_its_count() {
        for (rate, dt) in [(200.0, 1.0 / 60.0), (37.5, 1.0 / 144.0), (1000.0, 0.05)] {
            let jet = FluidJet {
                origin: Vec3::new(0.3, 1.0, -0.2),
                velocity: Vec3::new(0.5, -2.0, 0.1),
                radius: 0.05,
                rate,
                max_particles: 10_000,
            };
            let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
            let mut emitter = JetEmitter::default();
            let steps = (2.0f32 / dt).round() as usize;
            let made: usize = (0..steps)
                .map(|_| emitter.emit(&jet, &mut fluid, dt).unwrap())
                .sum();
            assert_eq!(made, fluid.len());
            assert!(
                (made as f32 - 2.0 * rate).abs() <= 1.0,
                "{made} particles in 2 s at {rate}/s"
            );
            let axis = jet.velocity.normalize();
            for p in fluid.positions() {
                let d = Vec3::from(*p) - jet.origin;
                assert!(d.dot(axis).abs() < 1e-5 && d.length() <= jet.radius + 1e-5);
            }
            let full = FluidJet {
                max_particles: 50,
                ..jet
            };
            let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
            let mut emitter = JetEmitter::default();
            for _ in 0..steps {
                emitter.emit(&full, &mut fluid, dt).unwrap();
            }
            assert_eq!(fluid.len(), 50);
        }
    }

    /// A jet with a non-finite velocity adds nothing and says why.
    #[test]
    fn a_jet_with_a_non_finite_velocity_is_refused() {
        let jet = FluidJet {
            origin: Vec3::ZERO,
            velocity: Vec3::new(f32::NAN, 0.0, 0.0),
            radius: 0.05,
            rate: 100.0,
            max_particles: 100,
        };
        let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
        assert!(JetEmitter::default().emit(&jet, &mut fluid, 0.1).is_err());
        assert!(fluid.is_empty());
    }
}
