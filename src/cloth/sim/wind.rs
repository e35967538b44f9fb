//! The wind a [`ClothSolver`]'s air moves with, sampled at every particle.

use bevy::math::Vec3A;

use super::ClothSolver;
use crate::cloth::air::{GustField, WindField};

impl ClothSolver {
    /// Samples `wind` at time `t` (seconds) at every particle for the coming steps (the air
    /// of [`SolverSettings::air`](crate::cloth::SolverSettings::air) moves with it). Until it is called the air is still. Gusts
    /// are taken as a linear field over the cloth (see `cloth/air.rs`).
    pub fn set_wind(&mut self, wind: &WindField, t: f32) {
        let x = &self.state.positions;
        let base = Vec3A::from(wind.velocity);
        let base = if base.is_finite() { base } else { Vec3A::ZERO };
        let gusts = GustField::over(&wind.gusts, x, t);
        if gusts.is_none() && wind.sources.is_empty() {
            self.particle_wind.fill(base);
            return;
        }
        for (sample, &p) in self.particle_wind.iter_mut().zip(x) {
            let mut v = base;
            if let Some(gusts) = &gusts {
                v += gusts.at(p);
            }
            for source in &wind.sources {
                v += Vec3A::from(source.velocity_at(p.into()));
            }
            *sample = if v.is_finite() { v } else { Vec3A::ZERO };
        }
    }
}
