//! The cloth's self-collision tables, whichever method [`SolverSettings::self_collision`]
//! names: the particle spacing (`self_collision.rs`) or the vertex-triangle constraint
//! (`triangle_collision.rs`), behind one face for the substep pipeline.

use bevy::math::{Vec3, Vec3A};

use super::ClothSolver;
use crate::cloth::self_collision::SelfCollision;
use crate::cloth::settings::{SelfCollisionMethod, SolverSettings};
use crate::cloth::triangle_collision::TriangleSelfCollision;

/// One cloth's self-collision tables.
#[derive(Clone, Debug)]
pub(super) enum SelfContacts {
    /// [`SelfCollisionMethod::Particles`].
    Particles(SelfCollision),
    /// [`SelfCollisionMethod::Triangles`].
    Triangles(TriangleSelfCollision),
}

impl SelfContacts {
    fn method(&self) -> SelfCollisionMethod {
        match self {
            Self::Particles(_) => SelfCollisionMethod::Particles,
            Self::Triangles(_) => SelfCollisionMethod::Triangles,
        }
    }

    /// A substep begins: `x_prev` at its start, `x` predicted; one of `substeps`.
    pub(super) fn begin_substep(&mut self, x: &[Vec3A], x_prev: &[Vec3A], substeps: u32) {
        match self {
            Self::Particles(sc) => sc.begin_substep(x, substeps),
            Self::Triangles(tc) => tc.begin_substep(x_prev, substeps),
        }
    }

    /// One projection of the substep's contacts; returns how many were held.
    pub(super) fn project(
        &mut self,
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        w: &[f32],
        friction: f32,
        velocities: Option<(&mut [Vec3A], f32)>,
    ) -> usize {
        match self {
            Self::Particles(sc) => sc.project(x, x_prev, w, friction, velocities),
            Self::Triangles(tc) => tc.project(x, x_prev, w, friction, velocities),
        }
    }

    /// After the iterations (not for mass-spring): the triangle method projects its
    /// contacts once more, without friction, so that the constraints the iterations ended
    /// with leave no particle through a triangle; the particle method, whose spacing is an
    /// edge wide, does nothing.
    pub(super) fn close(&mut self, x: &mut [Vec3A], x_prev: &[Vec3A], w: &[f32]) {
        if let Self::Triangles(tc) = self {
            tc.project(x, x_prev, w, 0.0, None);
        }
    }
}

impl ClothSolver {
    /// Finds the self-contact candidates of the coming step with the method `settings` names
    /// (building its tables the first time, and again when the method changes): pairs that
    /// may come into contact within `dt`.
    pub(super) fn find_self_contacts(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
    ) {
        let method = settings.self_collision;
        if self.self_collision.as_ref().map(SelfContacts::method) != Some(method) {
            self.self_collision = match method {
                SelfCollisionMethod::Off => None,
                SelfCollisionMethod::Particles => {
                    SelfCollision::new(&self.model, None).map(SelfContacts::Particles)
                }
                SelfCollisionMethod::Triangles => {
                    TriangleSelfCollision::new(&self.model.rest_positions, &self.model.triangles)
                        .map(SelfContacts::Triangles)
                }
            };
        }
        let (x, v) = (&self.state.positions, &self.state.velocities);
        match self.self_collision.as_mut() {
            None => {}
            Some(SelfContacts::Particles(sc)) => sc.find_pairs(x, v, dt, acceleration.length()),
            Some(SelfContacts::Triangles(tc)) => {
                tc.find_pairs(x, v, dt, acceleration.length(), settings.thickness);
            }
        }
    }

    /// How many pairs were held apart by self-collision in the last step's last iteration
    /// (the most in any substep): pairs of particles, or particles and triangles.
    pub fn self_contact_count(&self) -> usize {
        self.self_contacts
    }
}
