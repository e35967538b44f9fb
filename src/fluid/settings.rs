//! The fluid's parameters.

use bevy::reflect::Reflect;

use crate::error::FluidError;

/// The parameters of a [`FluidSolver`](super::FluidSolver) (Position Based Fluids, Macklin
/// and Müller 2013). The particles are spaced `2 particle_radius` apart at rest and see their
/// neighbours within the smoothing radius `4 particle_radius`.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct FluidSettings {
    /// Half the particles' spacing at rest, metres; also how far they are kept from
    /// colliders and from the cloth.
    pub particle_radius: f32,
    /// The density the fluid is held at, kg/m^3 (water: 1000).
    pub rest_density: f32,
    /// Substeps per fixed step (each a prediction, the density projection and the velocity
    /// update).
    pub substeps: u32,
    /// Jacobi iterations of the density constraint per substep.
    pub iterations: u32,
    /// Constraint-force mixing: the density constraint's `epsilon` relative to the sum of
    /// its squared gradients for a particle with a full neighbourhood at rest. Larger is
    /// softer and steadier.
    pub relaxation: f32,
    /// The tensile-instability correction's strength `k` in
    /// `s_corr = -k (W(r) / W(0.2 h))^4`, as a density error's worth of push: a small
    /// repulsion at short range that keeps particles from clumping in pairs.
    pub artificial_pressure: f32,
    /// Vorticity confinement `epsilon`, m/s: puts back the swirl the projection damps
    /// (`f = epsilon N x omega`). 0 turns it off.
    pub vorticity: f32,
    /// XSPH viscosity `c` in [0, 1]: each particle's velocity moves this fraction towards
    /// its neighbours' kernel-weighted mean.
    pub viscosity: f32,
}

impl Default for FluidSettings {
    fn default() -> Self {
        Self {
            particle_radius: 0.01,
            rest_density: 1000.0,
            substeps: 6,
            iterations: 4,
            relaxation: 0.01,
            artificial_pressure: 0.01,
            vorticity: 0.0,
            viscosity: 0.01,
        }
    }
}

impl FluidSettings {
    /// The smoothing radius `h = 4 particle_radius`, metres.
    pub fn smoothing_radius(&self) -> f32 {
        4.0 * self.particle_radius
    }

    /// The spacing of the particles at rest, `2 particle_radius`, metres.
    pub fn spacing(&self) -> f32 {
        2.0 * self.particle_radius
    }

    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<(), FluidError> {
        let checks = [
            (
                "particle_radius",
                self.particle_radius,
                self.particle_radius.is_finite() && self.particle_radius > 1e-4,
                "finite and above 0.1 mm",
            ),
            (
                "rest_density",
                self.rest_density,
                self.rest_density.is_finite() && self.rest_density > 0.0,
                "finite and positive",
            ),
            (
                "substeps",
                self.substeps as f32,
                (1..=64).contains(&self.substeps),
                "from 1 to 64",
            ),
            (
                "iterations",
                self.iterations as f32,
                (1..=64).contains(&self.iterations),
                "from 1 to 64",
            ),
            (
                "relaxation",
                self.relaxation,
                self.relaxation.is_finite() && self.relaxation >= 0.0,
                "finite and not negative",
            ),
            (
                "artificial_pressure",
                self.artificial_pressure,
                self.artificial_pressure.is_finite() && self.artificial_pressure >= 0.0,
                "finite and not negative",
            ),
            (
                "vorticity",
                self.vorticity,
                self.vorticity.is_finite() && self.vorticity >= 0.0,
                "finite and not negative",
            ),
            (
                "viscosity",
                self.viscosity,
                (0.0..=1.0).contains(&self.viscosity),
                "from 0 to 1",
            ),
        ];
        for (name, value, ok, reason) in checks {
            if !ok {
                return Err(FluidError::InvalidSetting {
                    name,
                    value,
                    reason,
                });
            }
        }
        Ok(())
    }
}
