//! Stepping a cloth far from the world's origin near it instead.
//!
//! An `f32` coordinate 40 m out has steps of 4 um, and a substep's velocity
//! (`(x - x_pred) / h`, `h` about 2 ms) inherits that step over `h`: millimetres per second of
//! noise, so that a cloth at rest 40 m out creeps by millimetres a step and one 200 m out by a
//! centimetre. [`ClothSolver::step`] therefore moves everything it steps (positions, pins,
//! colliders, held contact points) by the multiple of [`ORIGIN_GRID`] nearest the cloth, steps
//! there, and moves it back. Moving by a power of two's multiple loses nothing for the
//! coordinates within half a cell of it (their difference is exact), so a cloth within
//! `ORIGIN_GRID / 2` of the origin is stepped exactly as it would be without the move, and one
//! farther out is rounded once a step, where it is stored, rather than in every sum.

use bevy::math::Vec3A;

use super::ClothSolver;

/// The spacing (m) of the points a cloth far from the origin is stepped around: a power of two,
/// so that moving a coordinate near one of them and back is exact.
pub const ORIGIN_GRID: f32 = 16.0;

/// The multiple of [`ORIGIN_GRID`] nearest `point` on each axis (zero within half a cell of
/// the origin, and for a point that is not finite).
pub(super) fn local_origin(point: Vec3A) -> Vec3A {
    let snapped = (point * (1.0 / ORIGIN_GRID)).round() * ORIGIN_GRID;
    if snapped.is_finite() {
        snapped
    } else {
        Vec3A::ZERO
    }
}

impl ClothSolver {
    /// The point the next step is taken around: the grid point nearest the first particle.
    pub(super) fn step_origin(&self) -> Vec3A {
        self.state
            .positions
            .first()
            .map_or(Vec3A::ZERO, |&p| local_origin(p))
    }

    /// Moves every point the step reads or writes by `-origin`: the particles, the pins and
    /// the dragged particle, the colliders' poses and the contacts' held points. Velocities,
    /// normals and the model's rest shape do not depend on where the origin is.
    pub(super) fn move_to_origin(&mut self, origin: Vec3A) {
        if origin == Vec3A::ZERO {
            return;
        }
        self.move_points(origin);
        self.unmoved_colliders.clear();
        for c in &mut self.colliders {
            self.unmoved_colliders
                .push([c.start.translation, c.end.translation]);
            c.start.translation -= origin;
            c.end.translation -= origin;
        }
    }

    /// Undoes [`Self::move_to_origin`]: the points the step wrote moved back by `origin`, the
    /// colliders put back exactly as they were (one far from the cloth, a plane's point say,
    /// would come back rounded).
    pub(super) fn move_back_from(&mut self, origin: Vec3A) {
        if origin == Vec3A::ZERO {
            return;
        }
        self.move_points(-origin);
        for (c, &[start, end]) in self.colliders.iter_mut().zip(&self.unmoved_colliders) {
            c.start.translation = start;
            c.end.translation = end;
        }
    }

    /// The particles, pins and held contact points moved by `-offset`.
    fn move_points(&mut self, offset: Vec3A) {
        self.state.map_points(|p| p - offset);
        for pin in self.pins.iter_mut().chain(self.drag.as_mut()) {
            pin.start -= offset;
            pin.end -= offset;
        }
        self.contacts.carry_anchors(|p| p - offset);
    }
}
