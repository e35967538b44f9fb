//! The volume constraint of a closed [`ClothSolver`], built the first time it is asked for.

use super::ClothSolver;
use crate::cloth::volume::VolumeConstraint;
use crate::error::ClothError;

impl ClothSolver {
    /// Builds the volume constraint now (it is otherwise built by the first step with
    /// [`SolverSettings::volume`](crate::cloth::SolverSettings::volume)) and returns the rest volume, or
    /// [`ClothError::OpenSurface`] if the cloth does not close.
    pub fn enable_volume(&mut self) -> Result<f32, ClothError> {
        let built = self
            .volume
            .get_or_insert_with(|| VolumeConstraint::new(&self.model));
        match built {
            Ok(c) => Ok(c.rest_volume()),
            Err(e) => Err(e.clone()),
        }
    }

    /// Why the volume constraint could not be built, once a step asked for it.
    pub fn volume_error(&self) -> Option<&ClothError> {
        self.volume.as_ref().and_then(|v| v.as_ref().err())
    }

    /// The enclosed volume now and at rest, m^3, once the volume constraint is built.
    pub fn volume(&self) -> Option<(f32, f32)> {
        match self.volume.as_ref() {
            Some(Ok(c)) => Some((c.volume(&self.state.positions), c.rest_volume())),
            _ => None,
        }
    }
}
