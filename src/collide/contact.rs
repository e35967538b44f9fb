//! Particle contacts with [`SolverCollider`]s: the position projection and the velocity response
//! with restitution and Coulomb friction, relative to the collider's surface velocity.
//!
//! In each substep of length `h` (collider poses taken at the end of the substep, so a
//! collider moves along its motion through the step):
//!
//! 1. **Position.** A free particle closer to a collider's surface than `reach = margin +
//!    thickness` (or inside it) is moved out along the surface normal to `reach`. XPBD repeats
//!    this inside its iterations (an inequality constraint); mass-spring does it once at the
//!    end of the substep. The first time a particle touches a collider in the substep, its
//!    pre-contact normal velocity relative to the surface is recorded:
//!    `approach = n . (v + h a - v_surface)` with `v` the velocity at the start of the substep
//!    (XPBD, `h a` the external acceleration's share) or after the explicit update
//!    (mass-spring, no `h a`); `v_surface = v_lin + omega x r` at the contact.
//! 2. **Velocity**, after the solver's own velocity update, in the collider's frame
//!    (`u = v - v_surface`, split into `u_n = n . u` and `u_t`):
//!    - `u_n' = -epsilon approach` if the particle approached faster than `2 |a| h`, else 0
//!      (a resting contact does not bounce; the projection adds no velocity of its own, and
//!      a particle pushed in by the cloth's own constraints comes to rest on the surface, as
//!      in Mueller et al. 2020: keeping a separating particle's pre-contact velocity instead
//!      feeds energy into a cloth pressed onto a curved collider);
//!    - friction: with the normal velocity change the contact made, `dv_n = u_n' - u_free`
//!      (`u_free` the normal velocity the particle would have had without the contact:
//!      after the XPBD or hybrid solve the velocity minus the push over `h`, so the cloth's
//!      tension pressing it onto the surface counts as normal force; the push is the deepest
//!      single projection of the substep, not their sum: where the edges pull a particle into
//!      a curved collider again in every iteration, the sum counts the same pull once per
//!      iteration, and static friction grew with the budget and held stretched edges where
//!      they were), the tangential velocity
//!      loses at most `mu dv_n`: it stops if `|u_t| <= mu dv_n` (static friction), else
//!      shrinks by `mu dv_n` (kinetic);
//!    - `v = v_surface + n u_n' + u_t'`;
//!    - the tangential displacement over the substep becomes `h` times the new tangential
//!      velocity, so static friction holds positions too: a particle held by it moves with
//!      the surface, whatever the prediction and the cloth's constraints did to it in the
//!      substep. (Undoing only the prediction's share, or only the friction's velocity change,
//!      leaves part of the constraints' corrections as sliding: measured, a 0.9 m cloth
//!      resting on a sphere crept off it within 15 s.)

use bevy::math::Vec3A;

use super::shapes::{RigidPose, SolverCollider};
use super::trimesh::Aabb;

/// No collider.
const NONE: u32 = u32::MAX;

/// One particle's contact in the current substep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Contact {
    /// The collider's index, or `u32::MAX` for none.
    pub collider: u32,
    /// The outward surface normal at the contact (world).
    pub normal: Vec3A,
    /// The deepest single push out of the collider this substep, metres (the normal
    /// displacement friction is measured against).
    pub push: f32,
    /// The pre-contact normal velocity relative to the surface, m/s (negative approaching).
    pub approach: f32,
    /// The surface velocity at the contact, m/s.
    pub surface_velocity: Vec3A,
}

impl Contact {
    const EMPTY: Self = Self {
        collider: NONE,
        normal: Vec3A::ZERO,
        push: 0.0,
        approach: 0.0,
        surface_velocity: Vec3A::ZERO,
    };

    /// Whether there is a contact.
    pub(crate) fn is_some(&self) -> bool {
        self.collider != NONE
    }
}

/// Per-particle contacts and per-collider poses and bounds, reused every step.
#[derive(Clone, Debug, Default)]
pub(crate) struct ContactScratch {
    contacts: Vec<Contact>,
    /// The colliders' poses at the start and the end of the current substep.
    start_poses: Vec<RigidPose>,
    poses: Vec<RigidPose>,
    bounds: Vec<Option<Aabb>>,
}

impl ContactScratch {
    /// The contacts of the last substep, one per particle.
    pub(crate) fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Prepares a step: the colliders' swept bounds grown by their reach.
    pub(crate) fn begin_step(
        &mut self,
        colliders: &[SolverCollider],
        particles: usize,
        thickness: f32,
    ) {
        self.contacts.resize(particles, Contact::EMPTY);
        self.bounds.clear();
        self.bounds.extend(
            colliders
                .iter()
                .map(|c| c.swept_bounds(c.margin + thickness)),
        );
        self.poses.clear();
        self.poses.extend(colliders.iter().map(|c| c.end));
        self.start_poses.clear();
        self.start_poses.extend(colliders.iter().map(|c| c.start));
    }

    /// Prepares a substep from a fraction `t_start` to `t_end` of the step: poses at both,
    /// no contacts.
    pub(crate) fn begin_substep(&mut self, colliders: &[SolverCollider], t_start: f32, t_end: f32) {
        for ((start, end), c) in self
            .start_poses
            .iter_mut()
            .zip(self.poses.iter_mut())
            .zip(colliders)
        {
            *start = c.pose_at(t_start);
            *end = c.pose_at(t_end);
        }
        self.contacts.fill(Contact::EMPTY);
    }

    /// The colliders' poses at the start and the end of the current substep.
    pub(crate) fn substep_poses(&self) -> (&[RigidPose], &[RigidPose]) {
        (&self.start_poses, &self.poses)
    }

    /// Moves every free particle out of every collider (step 1 of the [module docs](self)).
    /// `v` are the velocities the approach speed is measured from, `h_a` the external
    /// acceleration's velocity change over the substep still to come (zero if `v` has it).
    /// `x_prev` are the positions at the start of the substep: a particle whose move since
    /// then, relative to a triangle mesh, crossed one of its triangles is put back on the
    /// side it came from ([`SolverShape::swept_signed_distance`](super::SolverShape)).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn project(
        &mut self,
        colliders: &[SolverCollider],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        v: &[Vec3A],
        w: &[f32],
        h_a: Vec3A,
        thickness: f32,
    ) {
        for (k, collider) in colliders.iter().enumerate() {
            let pose = self.poses[k];
            let start_pose = self.start_poses[k];
            let bounds = self.bounds[k];
            let reach = collider.margin + thickness;
            let swept = matches!(collider.shape, super::SolverShape::TriangleMesh(_));
            for i in 0..x.len() {
                if w[i] <= 0.0 || bounds.is_some_and(|b| !b.contains(x[i])) {
                    continue;
                }
                let local = pose.inverse_transform_point(x[i]);
                let found = if swept {
                    let from = start_pose.inverse_transform_point(x_prev[i]);
                    collider.shape.swept_signed_distance(from, local, reach)
                } else {
                    collider.shape.signed_distance(local, reach)
                };
                let Some((d, n_local)) = found else {
                    continue;
                };
                if d >= reach {
                    continue;
                }
                let n = pose.rotation * n_local;
                let depth = reach - d;
                x[i] += n * depth;
                let contact = &mut self.contacts[i];
                if contact.collider != k as u32 {
                    let surface_velocity = collider.velocity_at(&pose, x[i]);
                    *contact = Contact {
                        collider: k as u32,
                        normal: n,
                        push: 0.0,
                        approach: n.dot(v[i] + h_a - surface_velocity),
                        surface_velocity,
                    };
                }
                contact.normal = n;
                contact.push = contact.push.max(depth);
            }
        }
    }

    /// The velocity response (step 2 of the [module docs](self)); `bounce_threshold` is the
    /// approach speed below which nothing bounces (`2 |a| h`). `push_velocity` converts the
    /// distance a particle was pushed into the velocity that push gave it: `1 / h` when the
    /// solver derives velocities from positions (XPBD, hybrid), 0 when it does not
    /// (mass-spring). Then the tangential part of the particle's displacement over the
    /// substep (`x - x_prev`) becomes `h` times its new tangential velocity.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn respond(
        &self,
        colliders: &[SolverCollider],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        v: &mut [Vec3A],
        push_velocity: f32,
        h: f32,
        bounce_threshold: f32,
    ) {
        for (i, c) in self.contacts.iter().enumerate() {
            let Some(collider) = colliders.get(c.collider as usize) else {
                continue;
            };
            let material = collider.material;
            let n = c.normal;
            let u = v[i] - c.surface_velocity;
            let un = n.dot(u);
            let ut = u - n * un;
            let un_new = if -c.approach > bounce_threshold {
                -material.restitution * c.approach
            } else {
                0.0
            };
            // The normal velocity the particle would have had without the contact: gravity,
            // the cloth's own constraints pressing it on the surface, its momentum.
            let un_free = un - c.push * push_velocity;
            let budget = material.friction * (un_new - un_free).max(0.0);
            let speed = ut.length();
            let ut_new = if speed <= budget {
                Vec3A::ZERO
            } else {
                ut * (1.0 - budget / speed)
            };
            let v_new = c.surface_velocity + n * un_new + ut_new;
            v[i] = v_new;
            let dx = x[i] - x_prev[i];
            x[i] = x_prev[i] + n * n.dot(dx) + (v_new - n * n.dot(v_new)) * h;
        }
    }

    /// How many particles touched a collider in the last substep.
    pub(crate) fn count(&self) -> usize {
        self.contacts.iter().filter(|c| c.is_some()).count()
    }
}
