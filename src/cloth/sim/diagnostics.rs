//! What can be read off a [`ClothSolver`]: strain, finiteness and divergence, its rigid motion,
//! its energies.

use bevy::math::{Vec3, Vec3A};

use super::ClothSolver;
use crate::cloth::damping::RigidMotion;
use crate::cloth::model::EdgeKind;
use crate::cloth::settings::DivergenceBounds;

/// Strain statistics over the structural edges.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StrainStats {
    /// Largest `|len - rest| / rest`.
    pub max: f32,
    /// Mean `|len - rest| / rest`.
    pub mean: f32,
}

/// Why a cloth counts as diverged (see [`ClothSolver::divergence`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Divergence {
    /// A position or velocity is NaN or infinite.
    NonFinite,
    /// A structural edge is strained past [`DivergenceBounds::max_strain`].
    Strain {
        /// The largest strain.
        strain: f32,
    },
    /// A particle moves faster than [`DivergenceBounds::max_speed`], m/s.
    Speed {
        /// The largest speed, m/s.
        speed: f32,
    },
}

impl std::fmt::Display for Divergence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Divergence::NonFinite => write!(f, "a position or velocity is not finite"),
            Divergence::Strain { strain } => write!(f, "max strain {:.0}%", strain * 100.0),
            Divergence::Speed { speed } => write!(f, "a particle moves at {speed:.0} m/s"),
        }
    }
}

impl ClothSolver {
    /// The strain `|len - rest| / rest` of every structural edge, in the model's order.
    pub fn edge_strains(&self) -> impl Iterator<Item = f32> + '_ {
        self.edge_extensions().map(f32::abs)
    }

    /// The signed strain `(len - rest) / rest` of every structural edge, in the model's
    /// order: positive stretched, negative compressed.
    pub fn edge_extensions(&self) -> impl Iterator<Item = f32> + '_ {
        let x = &self.state.positions;
        self.model
            .edges
            .iter()
            .filter(|e| e.kind == EdgeKind::Structural)
            .map(move |edge| {
                let [a, b] = edge.particles;
                (x[a as usize].distance(x[b as usize]) - edge.rest_length) / edge.rest_length
            })
    }

    /// The distance the solver keeps particles from its colliders besides their margins:
    /// the cloth's thickness in the last step.
    pub(crate) fn contact_thickness(&self) -> f32 {
        self.contacts.thickness()
    }

    /// Strain `|len - rest| / rest` over the structural edges.
    pub fn strain(&self) -> StrainStats {
        let mut stats = StrainStats::default();
        let mut count = 0usize;
        for strain in self.edge_strains() {
            stats.max = stats.max.max(strain);
            stats.mean += strain;
            count += 1;
        }
        if count > 0 {
            stats.mean /= count as f32;
        }
        stats
    }

    /// Whether every position and velocity is finite.
    pub fn is_finite(&self) -> bool {
        self.state.positions.iter().all(|p| p.is_finite())
            && self.state.velocities.iter().all(|v| v.is_finite())
    }

    /// Whether the cloth has diverged: a non-finite position or velocity, a structural strain
    /// past `bounds.max_strain`, or a particle faster than `bounds.max_speed`.
    pub fn divergence(&self, bounds: &DivergenceBounds) -> Option<Divergence> {
        if !self.is_finite() {
            return Some(Divergence::NonFinite);
        }
        let max_speed_sq = self
            .state
            .velocities
            .iter()
            .map(|v| v.length_squared())
            .fold(0.0, f32::max);
        if max_speed_sq > bounds.max_speed * bounds.max_speed {
            return Some(Divergence::Speed {
                speed: max_speed_sq.sqrt(),
            });
        }
        let strain = self.strain().max;
        if strain > bounds.max_strain {
            return Some(Divergence::Strain { strain });
        }
        None
    }

    /// The rigid motion that fits the free particles (centre of mass, linear and angular
    /// momentum); `None` if every particle is pinned.
    pub fn rigid_motion(&self) -> Option<RigidMotion> {
        RigidMotion::fit(
            &self.state.positions,
            &self.state.velocities,
            &self.state.inverse_masses,
        )
    }

    /// Gravitational potential energy of the free particles in the field `gravity` (m/s^2),
    /// zero at the origin, J: `-sum m g . x`.
    pub fn potential_energy(&self, gravity: Vec3) -> f32 {
        let g = Vec3A::from(gravity);
        self.state
            .positions
            .iter()
            .zip(&self.state.inverse_masses)
            .filter(|&(_, &w)| w > 0.0)
            .map(|(x, &w)| -g.dot(*x) / w)
            .sum()
    }

    /// Kinetic energy of the free particles, J.
    pub fn kinetic_energy(&self) -> f32 {
        self.state
            .velocities
            .iter()
            .zip(&self.state.inverse_masses)
            .filter(|&(_, &w)| w > 0.0)
            .map(|(v, &w)| 0.5 * v.length_squared() / w)
            .sum()
    }
}
