//! The moving part of a cloth, in structure-of-arrays form.

use bevy::math::Vec3A;

use super::model::ClothModel;

/// Positions, previous positions, velocities and inverse masses of every particle, one array
/// each, indexed by particle.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClothState {
    /// Positions, metres.
    pub positions: Vec<Vec3A>,
    /// Positions at the start of the last substep, metres.
    pub previous_positions: Vec<Vec3A>,
    /// Velocities, m/s.
    pub velocities: Vec<Vec3A>,
    /// Inverse masses, 1/kg; 0 for pinned (or massless) particles, which only move as they
    /// are told.
    pub inverse_masses: Vec<f32>,
}

impl ClothState {
    /// The model's rest shape, at rest, inverse masses from the model's masses.
    pub(crate) fn at_rest(model: &ClothModel) -> Self {
        let positions: Vec<Vec3A> = model.rest_positions.iter().map(|&p| p.into()).collect();
        let inverse_masses = (0..model.particle_count())
            .map(|i| inverse_mass(model.mass(i)))
            .collect();
        Self {
            previous_positions: positions.clone(),
            velocities: vec![Vec3A::ZERO; positions.len()],
            positions,
            inverse_masses,
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Moves every position and previous position by `map` (a rigid motion, or a move of the
    /// origin); the velocities are left to the caller.
    pub(crate) fn map_points(&mut self, map: impl Fn(Vec3A) -> Vec3A) {
        for p in self
            .positions
            .iter_mut()
            .chain(self.previous_positions.iter_mut())
        {
            *p = map(*p);
        }
    }
}

/// `1 / mass`, or 0 (held in place) for a particle without mass.
pub(crate) fn inverse_mass(mass: f32) -> f32 {
    if mass > 0.0 { 1.0 / mass } else { 0.0 }
}
