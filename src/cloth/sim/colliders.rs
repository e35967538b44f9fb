//! The colliders of a [`ClothSolver`]: setting them, carrying the cloth and them with the
//! frame it follows, and reading the contacts.

use super::ClothSolver;
use crate::collide::contact::Contact;
use crate::collide::{FrameStep, SolverCollider};
use crate::error::ColliderError;

impl ClothSolver {
    /// Replaces the colliders the cloth meets in the next steps (see [`crate::collide`]).
    /// A collider that is not valid ([`SolverCollider::validate`]: a bad dimension or
    /// material, a non-finite pose or velocity) is left out, and the first such error is
    /// returned; the valid ones are kept either way.
    pub fn set_colliders(&mut self, colliders: &[SolverCollider]) -> Result<(), ColliderError> {
        let count = self.colliders.len();
        self.colliders.clear();
        let mut first_error = None;
        for collider in colliders {
            match collider.validate() {
                Ok(()) => self.colliders.push(collider.clone()),
                Err(e) => {
                    first_error.get_or_insert(e);
                }
            }
        }
        if self.colliders.len() != count || first_error.is_some() {
            // The contacts name colliders by index.
            self.contacts.forget();
        }
        first_error.map_or(Ok(()), Err)
    }

    /// Carries the cloth along with the frame it follows (a character) over the coming step,
    /// so that it feels only `inertia` of the frame's world motion: `1` is physical (nothing
    /// is carried), `0` simulates the cloth as if it lived in the frame. Call after
    /// [`ClothSolver::set_colliders`] and the pin targets, before [`ClothSolver::step`].
    ///
    /// The carried part, `s = 1 - inertia` of the step's pose change (see [`FrameStep`]),
    /// moves positions, previous positions and pins rigidly and turns velocities, so the
    /// state's velocities are relative to the carried motion and nothing is created or lost.
    /// The colliders are seen in the same way: their start poses are carried too and
    /// `s` times the frame's velocity field (`v + omega x r`) is taken off theirs. A jump
    /// ([`FrameStep::jumped`], a teleport) carries the cloth with all of it, whatever the
    /// inertia; the colliders then start where they end already.
    pub fn follow_frame(&mut self, frame: &FrameStep, inertia: f32) {
        let s = if inertia.is_finite() {
            1.0 - inertia.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let map = frame.carry(if frame.jumped { 1.0 } else { s });
        self.carried = (s > 0.0 && !frame.jumped).then_some((*frame, s));
        if !(map.rotation.is_finite() && map.to.is_finite() && map.pivot.is_finite()) {
            return;
        }
        if !map.is_identity() {
            let state = &mut self.state;
            for p in state
                .positions
                .iter_mut()
                .chain(state.previous_positions.iter_mut())
            {
                *p = map.point(*p);
            }
            for v in &mut state.velocities {
                *v = map.vector(*v);
            }
            for pin in self.pins.iter_mut().chain(self.drag.as_mut()) {
                pin.start = map.point(pin.start);
            }
            self.contacts.carry_anchors(|p| map.point(p));
        }
        for c in &mut self.colliders {
            if !frame.jumped {
                c.start = map.pose(&c.start);
            }
            if s > 0.0 {
                c.linear_velocity -= frame.velocity_at(c.end.translation) * s;
                c.angular_velocity -= frame.angular_velocity * s;
            }
        }
    }

    /// The colliders.
    pub fn colliders(&self) -> &[SolverCollider] {
        &self.colliders
    }

    /// Every particle's collider contact in the last substep.
    pub(crate) fn contacts(&self) -> &[Contact] {
        self.contacts.contacts()
    }

    /// How many particles touched a collider in the last substep.
    pub fn contact_count(&self) -> usize {
        self.contacts.count()
    }
}
