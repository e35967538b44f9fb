//! The colliders of a [`ClothSolver`]: setting them, carrying the cloth and them with the
//! frame it follows, and reading the contacts.

use bevy::math::Vec3A;

use super::ClothSolver;
use crate::collide::contact::Contact;
use crate::collide::{FrameStep, SolverCollider};
use crate::error::ColliderError;

impl ClothSolver {
    /// The farthest a particle can move in a step of `dt` seconds under the acceleration `a`
    /// and the air's (`air`, per particle): at the largest speed, or with the fastest pin.
    /// The contacts look no farther for the particles a sphere or a capsule can reach.
    pub(super) fn step_travel(&self, a: Vec3A, dt: f32, air: Option<&[Vec3A]>) -> f32 {
        let largest = |v: &[Vec3A]| v.iter().fold(0.0f32, |m, v| m.max(v.length()));
        let pushed = a.length() + air.map_or(0.0, largest);
        let travel = largest(&self.state.velocities) * dt + 0.5 * pushed * dt * dt;
        self.pins
            .iter()
            .chain(self.drag.as_ref())
            .fold(travel, |m, pin| m.max(pin.start.distance(pin.end)))
    }

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
        // The step far from the origin keeps their poses here (`origin.rs`): made now, so
        // that the step allocates nothing.
        self.unmoved_colliders.clear();
        self.unmoved_colliders.reserve(self.colliders.len());
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
    /// inertia, to where the frame reappeared ([`FrameStep::sweep_start`]); the colliders
    /// then start there already.
    pub fn follow_frame(&mut self, frame: &FrameStep, inertia: f32) {
        let s = if inertia.is_finite() {
            1.0 - inertia.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let map = if frame.jumped {
            frame.jump_carry()
        } else {
            frame.carry(s)
        };
        self.carried = (s > 0.0 && !frame.jumped).then_some((*frame, s));
        if !(map.rotation.is_finite() && map.to.is_finite() && map.pivot.is_finite()) {
            return;
        }
        if !map.is_identity() {
            self.state.map_points(|p| map.point(p));
            for v in &mut self.state.velocities {
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

    /// Carries the whole cloth rigidly with the frame's motion over the step, without solving
    /// it: positions, previous positions and pins moved by the step's pose change (all of it,
    /// or the jump of a teleport), and every free particle given the frame's velocity field
    /// at its new position, so that when it is stepped again it goes on from rest in the
    /// frame. A cloth held at a distant level of detail rides on its character this way; its
    /// last step's timings are zero. A frame that is not finite leaves the cloth as it is.
    pub fn carry_rigidly(&mut self, frame: &FrameStep) {
        self.timings = Default::default();
        let map = if frame.jumped {
            frame.jump_carry()
        } else {
            frame.carry(1.0)
        };
        if !(map.rotation.is_finite()
            && map.to.is_finite()
            && map.pivot.is_finite()
            && frame.linear_velocity.is_finite()
            && frame.angular_velocity.is_finite())
        {
            return;
        }
        self.state.map_points(|p| map.point(p));
        let state = &mut self.state;
        for ((v, &p), &w) in state
            .velocities
            .iter_mut()
            .zip(&state.positions)
            .zip(&state.inverse_masses)
        {
            *v = if w == 0.0 {
                Vec3A::ZERO
            } else {
                frame.velocity_at(p)
            };
        }
        for pin in self.pins.iter_mut().chain(self.drag.as_mut()) {
            pin.start = map.point(pin.start);
            pin.end = map.point(pin.end);
        }
        self.contacts.carry_anchors(|p| map.point(p));
    }

    /// Limits every free particle's speed relative to the frame it follows to `max_speed`,
    /// m/s: the part of its velocity beyond the frame's velocity field at the particle
    /// (`v + omega x r`, the share the cloth feels after [`ClothSolver::follow_frame`]) is
    /// shortened to `max_speed`, its direction kept. A character that stops dead, turns round
    /// or lands from a hop then takes its cloth with it instead of throwing it off: the kinetic
    /// energy beyond the limit is taken out, as game engines' cloth does (a movement speed
    /// limit). Call after [`ClothSolver::follow_frame`]; a limit that is not a positive finite
    /// number, or a frame that is not finite, leaves the cloth as it is.
    pub fn limit_speed_relative_to(&mut self, frame: &FrameStep, max_speed: f32) {
        if !(max_speed.is_finite() && max_speed > 0.0) {
            return;
        }
        if !(frame.linear_velocity.is_finite()
            && frame.angular_velocity.is_finite()
            && frame.end.translation.is_finite())
        {
            return;
        }
        // Velocities are relative to the carried share of the frame's motion.
        let felt = self.carried.map_or(1.0, |(_, s)| 1.0 - s);
        if felt <= 0.0 {
            return;
        }
        let state = &mut self.state;
        let max_sq = max_speed * max_speed;
        for ((v, &p), &w) in state
            .velocities
            .iter_mut()
            .zip(&state.positions)
            .zip(&state.inverse_masses)
        {
            if w == 0.0 {
                continue;
            }
            let body = frame.velocity_at(p) * felt;
            let relative = *v - body;
            let sq = relative.length_squared();
            if sq > max_sq {
                *v = body + relative * (max_speed / sq.sqrt());
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

    /// How many vertices of triangle-mesh colliders pushed a cloth triangle in the last
    /// substep (a vertex under two triangles counts twice): a cloth resting on a mesh's
    /// ridges and tips is held by these rather than by its particles' contacts.
    pub fn mesh_vertex_contact_count(&self) -> usize {
        self.vertex_contacts.count()
    }
}
