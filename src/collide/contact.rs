//! Particle contacts with [`SolverCollider`]s: the position projection with Coulomb friction,
//! and the velocity response with restitution, relative to the collider's surface velocity.
//!
//! In each substep of length `h` (collider poses taken at the end of the substep, so a
//! collider moves along its motion through the step):
//!
//! 1. **Position.** A free particle closer to a collider's surface than `reach = margin +
//!    thickness` (or inside it) is moved out along the surface normal `n` to `reach`, by
//!    `depth`. XPBD, PBD and the hybrid do this at the start of each of their iterations,
//!    before the cloth's own constraints (an inequality constraint), and once more after
//!    the last iteration with `reach = 0` (the closing pass: nothing is left inside a
//!    collider, and no friction); mass-spring does it once at the end of the substep. The
//!    first time a particle touches a collider in the substep, its pre-contact normal
//!    velocity relative to the surface is recorded: `approach = n . (v + h a - v_surface)`
//!    with `v` the velocity at the start of the substep (XPBD, `h a` the external
//!    acceleration's share) or after the explicit update (mass-spring, no `h a`);
//!    `v_surface = v_lin + omega x r`.
//! 2. **Friction** (the methods whose velocities come from positions: XPBD, PBD, hybrid), in
//!    the same projection, as a position constraint (Macklin et al. 2014, "Unified particle
//!    physics for real-time applications"): the particle's displacement relative to the
//!    surface (`s = x - r`, its tangential part `s_t`) is undone entirely if
//!    `|s_t| <= mu d` (static friction), else shortened by `mu d` (kinetic). `d` is the normal
//!    motion the contact removed in this projection: `depth`, plus, the first time in the
//!    substep, the share of the external acceleration the prediction left out
//!    (`h^2 / 2 max(0, -n . a)`: velocity Verlet moves by `h^2 a / 2` while the velocity
//!    changes by `h a`). The reference `r` is the particle's **anchor** on this collider:
//!    the point where friction last left it (held there, or where it slid to), carried by the
//!    surface velocity (`r += h v_surface` once per substep) and by a followed frame; a
//!    particle without one (first touch) measures from the start of the substep,
//!    `r = x_prev + h v_surface`. Each iteration thus compares the tangential pull of that
//!    iteration with the normal push of that iteration, which is Coulomb's law whatever the
//!    iteration count.
//!
//!    Why this order: the cloth's constraints come after the colliders in every iteration, so
//!    an iteration ends with the edges met. When the colliders came last (the earlier order),
//!    each push out of a collider and each friction correction undid part of what the edges
//!    had just done, and the two settled with the edges stretched: a strip over a bar, its
//!    particles held by friction, kept a stretch that friction itself preserved (a fixed
//!    point: edges shorten the strip, friction puts the particles back, every iteration),
//!    and a larger budget made S3 worse. Now the last iteration's edges can slide a held
//!    particle a little; the anchor keeps that slide from adding up (the next projection
//!    measures from the anchor, not from where the edges left the particle), and the velocity
//!    of a held particle comes from its anchor (step 3), so it does not carry the slide on.
//!    Measured on S3 (`cargo run --release --example scenes -- s3 --motion M`, default
//!    8 x 2, against the earlier order in alternating runs): the median step's largest
//!    strain 2.8-3.1% to 1.5-1.7%, the 99.9th percentile edge 3.2-3.9% to 1.6-1.9%, the worst
//!    step 12-19% to 4.2-5.2%; at 16 x 4 (the study, `examples/speed_accuracy/`) 0.2-0.3%,
//!    0.3-0.6% and 1.1-4.3%.
//! 3. **Velocity**, after the solver's own velocity update, in the collider's frame
//!    (`u = v - v_surface`, split into `u_n = n . u` and `u_t`):
//!    - `u_n' = -epsilon approach` if the particle approached faster than `2 |a| h`, else 0
//!      (a resting contact does not bounce; the projection adds no velocity of its own, and
//!      a particle pushed in by the cloth's own constraints comes to rest on the surface, as
//!      in Mueller et al. 2020: keeping a separating particle's pre-contact velocity instead
//!      feeds energy into a cloth pressed onto a curved collider);
//!    - XPBD, PBD, hybrid: `v = v_surface + n u_n' + u_t` (the tangential velocity, derived
//!      from the positions, already has the friction); for a particle static friction held
//!      in its last projection, `u_t` is that of `(r - x_prev) / h + h a / 2 - v_surface`
//!      with its anchor `r`: it moves as the surface it sticks to;
//!    - mass-spring, whose velocities are its own: with the normal velocity change the
//!      contact made, `dv_n = u_n' - u_n`, the tangential velocity loses at most `mu dv_n`
//!      (it stops if `|u_t| <= mu dv_n`, else shrinks by `mu dv_n`), and the tangential
//!      displacement over the substep becomes `h` times the new tangential velocity.

use bevy::math::Vec3A;

use super::pose::RigidPose;
use super::shapes::SolverCollider;
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
    /// The pre-contact normal velocity relative to the surface, m/s (negative approaching).
    pub approach: f32,
    /// The surface velocity at the contact, m/s.
    pub surface_velocity: Vec3A,
}

impl Contact {
    const EMPTY: Self = Self {
        collider: NONE,
        normal: Vec3A::ZERO,
        approach: 0.0,
        surface_velocity: Vec3A::ZERO,
    };

    /// Whether there is a contact.
    pub(crate) fn is_some(&self) -> bool {
        self.collider != NONE
    }
}

/// Which pass over the colliders a projection is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum ContactPass {
    /// A solver iteration's: a particle closer than `margin + thickness` to a collider's
    /// surface moves out to that distance, with friction on the positions when
    /// `friction_step` holds the substep's length.
    Iteration {
        /// The substep's length, if friction acts on the positions.
        friction_step: Option<f32>,
    },
    /// The closing pass after the last iteration: a particle inside a collider moves out onto
    /// its surface, without friction.
    Closing,
}

/// Where static friction holds a particle: a point that moves with its collider's surface
/// (world, advanced by the surface velocity every substep), and the collider.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Anchor {
    /// The collider's index, or `u32::MAX` for none.
    collider: u32,
    /// The point the particle sticks to.
    point: Vec3A,
    /// Whether the particle's latest friction projection held it there (static), rather than
    /// letting it slide (kinetic: the point is then where it slid to).
    holding: bool,
}

impl Anchor {
    const NONE: Self = Self {
        collider: NONE,
        point: Vec3A::ZERO,
        holding: false,
    };
}

/// Per-particle contacts and per-collider poses and bounds, reused every step.
#[derive(Clone, Debug, Default)]
pub(crate) struct ContactScratch {
    contacts: Vec<Contact>,
    /// Per particle, the normal of its latest contact (this substep's or the last one's),
    /// zero if it had none.
    held: Vec<Vec3A>,
    /// Per particle, where static friction holds it (see [`Anchor`]).
    anchors: Vec<Anchor>,
    /// The cloth's thickness in the current step.
    thickness: f32,
    /// The colliders' poses at the start and the end of the current substep.
    start_poses: Vec<RigidPose>,
    poses: Vec<RigidPose>,
    bounds: Vec<Option<Aabb>>,
    /// The colliders whose swept bounds meet the cloth's in the current substep (a crowd's
    /// other characters are left out before any particle is looked at).
    near: Vec<u32>,
    /// The particles each sphere and capsule can reach in the current step, collider by
    /// collider (see [`Self::begin_step`]) ...
    candidates: Vec<u32>,
    /// ... per collider the range of `candidates` that are its own, `None` for the shapes
    /// whose every particle is looked at.
    candidate_ranges: Vec<Option<(u32, u32)>>,
}

/// Metres added to the distance within which a particle is a sphere's or a capsule's
/// candidate for a step, for the moves the constraints make beyond the particles' own.
const CANDIDATE_SLACK: f32 = 0.01;

impl ContactScratch {
    /// The contacts of the last substep, one per particle.
    pub(crate) fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Prepares a step: the colliders' swept bounds grown by their reach, and for each sphere
    /// and capsule the particles it can reach in the step. `x` are the positions at the start
    /// of the step and `travel` the farthest any particle can move in it: a particle farther
    /// from the collider's surface at the start than the reach plus twice that travel plus how
    /// far the collider's core moves ([`SolverCollider::core_motion`]) is left out of its
    /// passes for the step.
    pub(crate) fn begin_step(
        &mut self,
        colliders: &[SolverCollider],
        x: &[Vec3A],
        travel: f32,
        thickness: f32,
    ) {
        let particles = x.len();
        self.thickness = thickness;
        self.contacts.resize(particles, Contact::EMPTY);
        self.held.resize(particles, Vec3A::ZERO);
        self.anchors.resize(particles, Anchor::NONE);
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
        self.candidates.clear();
        self.candidate_ranges.clear();
        for c in colliders {
            let range = c.core_motion().filter(|m| m.is_finite()).map(|motion| {
                let first = self.candidates.len() as u32;
                let limit = c.margin + thickness + 2.0 * travel + motion + CANDIDATE_SLACK;
                self.candidates.extend((0..particles as u32).filter(|&i| {
                    let local = c.start.inverse_transform_point(x[i as usize]);
                    c.shape.signed_distance(local, limit).is_some()
                }));
                (first, self.candidates.len() as u32)
            });
            self.candidate_ranges.push(range);
        }
    }

    /// Prepares a substep from a fraction `t_start` to `t_end` of the step: poses at both,
    /// no contacts, and the colliders near the cloth. `x` are the predicted positions, `x_prev`
    /// those at the start of the substep: the cloth's box spans both, grown by the largest move
    /// between them, which the constraints do not carry a particle beyond.
    pub(crate) fn begin_substep(
        &mut self,
        colliders: &[SolverCollider],
        t_start: f32,
        t_end: f32,
        x: &[Vec3A],
        x_prev: &[Vec3A],
    ) {
        for ((start, end), c) in self
            .start_poses
            .iter_mut()
            .zip(self.poses.iter_mut())
            .zip(colliders)
        {
            *start = c.pose_at(t_start);
            *end = c.pose_at(t_end);
        }
        for ((held, anchor), c) in self
            .held
            .iter_mut()
            .zip(&mut self.anchors)
            .zip(&self.contacts)
        {
            *held = c.normal;
            if anchor.collider != c.collider {
                *anchor = Anchor::NONE;
            }
        }
        self.contacts.fill(Contact::EMPTY);
        let (mut cloth, mut travel) = (Aabb::EMPTY, 0.0f32);
        for (&p, &q) in x.iter().zip(x_prev) {
            cloth = cloth.grown(p).grown(q);
            travel = travel.max(p.distance_squared(q));
        }
        let grow = Vec3A::splat(travel.sqrt());
        let cloth = Aabb {
            min: cloth.min - grow,
            max: cloth.max + grow,
        };
        self.near.clear();
        self.near.extend(
            self.bounds
                .iter()
                .enumerate()
                .filter(|(_, b)| b.is_none_or(|b| b.overlaps(&cloth)))
                .map(|(k, _)| k as u32),
        );
    }

    /// The colliders' poses at the start and the end of the current substep.
    pub(crate) fn substep_poses(&self) -> (&[RigidPose], &[RigidPose]) {
        (&self.start_poses, &self.poses)
    }

    /// Moves every free particle out of every collider (step 1 of the [module docs](self)) to
    /// the reach of `pass`, with the cloth's thickness given to [`Self::begin_step`], and
    /// with friction on the positions when the pass has a substep length for it (step 2).
    /// `v` are the velocities the approach speed is measured from, `h_a` the external
    /// acceleration's velocity change over the substep still to come (zero if `v` has it).
    /// `x_prev` are the positions at the start of the substep: a particle whose move since
    /// then, relative to a triangle mesh, crossed one of its triangles is put back on the
    /// side it came from ([`SolverShape::swept_signed_distance`](super::SolverShape)).
    /// Returns the deepest push out of a collider, metres (friction's moves not counted).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn project(
        &mut self,
        colliders: &[SolverCollider],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        v: &[Vec3A],
        w: &[f32],
        h_a: Vec3A,
        pass: ContactPass,
    ) -> f32 {
        let mut deepest = 0.0f32;
        let friction_step = match pass {
            ContactPass::Iteration { friction_step } => friction_step,
            ContactPass::Closing => None,
        };
        for &k in &self.near {
            let k = k as usize;
            let collider = &colliders[k];
            let pose = self.poses[k];
            let start_pose = self.start_poses[k];
            let bounds = self.bounds[k];
            let reach = match pass {
                ContactPass::Iteration { .. } => collider.margin + self.thickness,
                ContactPass::Closing => 0.0,
            };
            let swept = matches!(collider.shape, super::SolverShape::TriangleMesh(_));
            // A sphere's or a capsule's candidates, or every particle.
            let (listed, rest) = match self.candidate_ranges.get(k).copied().flatten() {
                Some((first, end)) => (&self.candidates[first as usize..end as usize], 0..0),
                None => (&[][..], 0..x.len() as u32),
            };
            for i in listed.iter().copied().chain(rest) {
                let i = i as usize;
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
                deepest = deepest.max(depth);
                x[i] += n * depth;
                let contact = &mut self.contacts[i];
                let mut normal_motion = depth;
                if contact.collider != k as u32 {
                    let surface_velocity = collider.velocity_at(&pose, x[i]);
                    *contact = Contact {
                        collider: k as u32,
                        normal: n,
                        approach: n.dot(v[i] + h_a - surface_velocity),
                        surface_velocity,
                    };
                    // The share of the external acceleration the prediction left out
                    // (velocity Verlet moves by h^2/2 a, the velocity changes by h a); an
                    // anchor on this collider moves with its surface over the substep.
                    if let Some(h) = friction_step {
                        normal_motion += (-0.5 * h * n.dot(h_a)).max(0.0);
                        let anchor = &mut self.anchors[i];
                        if anchor.collider == k as u32 {
                            anchor.point += surface_velocity * h;
                        }
                    }
                }
                contact.normal = n;
                self.held[i] = n;
                if let Some(h) = friction_step {
                    // Friction on the displacement relative to the surface since static
                    // friction last held the particle (its anchor on this collider), or
                    // since the substep began.
                    let anchor = &mut self.anchors[i];
                    let anchored = anchor.collider == k as u32 && anchor.point.is_finite();
                    let reference = if anchored {
                        anchor.point
                    } else {
                        x_prev[i] + contact.surface_velocity * h
                    };
                    let slip = x[i] - reference;
                    let slip_t = slip - n * n.dot(slip);
                    let length = slip_t.length();
                    let budget = collider.material.friction * normal_motion;
                    let holding = length <= budget;
                    x[i] -= if holding {
                        slip_t
                    } else {
                        slip_t * (budget / length)
                    };
                    if !(anchored && holding) {
                        anchor.collider = k as u32;
                        anchor.point = x[i];
                    }
                    anchor.holding = holding;
                    // Along a triangle mesh's surface the slide can end inside another of its
                    // faces: that one pushes it out again, without friction.
                    if swept
                        && let Some((d, n_local)) = collider
                            .shape
                            .signed_distance(pose.inverse_transform_point(x[i]), reach)
                        && d < reach
                    {
                        x[i] += pose.rotation * n_local * (reach - d);
                    }
                }
            }
        }
        deepest
    }

    /// The velocity response (step 3 of the [module docs](self)); `bounce_threshold` is the
    /// approach speed below which nothing bounces (`2 |a| h`). With `friction_in_positions`
    /// (the projection applied friction) only the normal velocity changes; otherwise
    /// (mass-spring) friction acts on the velocity and the tangential part of the particle's
    /// displacement over the substep (`x - x_prev`) becomes `h` times its new tangential
    /// velocity.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn respond(
        &self,
        colliders: &[SolverCollider],
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        v: &mut [Vec3A],
        h: f32,
        h_a: Vec3A,
        bounce_threshold: f32,
        friction_in_positions: bool,
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
            if friction_in_positions {
                // The projection applied friction to the positions, so the tangential
                // velocity derived from them already has it; but a particle static friction
                // holds moves as its anchor does (`x - x_prev` with the anchor for `x`), not
                // by what the cloth's constraints slid it after the colliders' pass.
                let anchor = self.anchors[i];
                let ut = if anchor.holding
                    && anchor.collider == c.collider
                    && anchor.point.is_finite()
                {
                    let u = (anchor.point - x_prev[i]) / h + 0.5 * h_a - c.surface_velocity;
                    u - n * n.dot(u)
                } else {
                    ut
                };
                v[i] = c.surface_velocity + n * un_new + ut;
                continue;
            }
            let budget = material.friction * (un_new - un).max(0.0);
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

    /// Per particle, the normal of its latest contact, zero if none.
    pub(crate) fn held(&self) -> &[Vec3A] {
        &self.held
    }

    /// The cloth's thickness in the current (or last) step.
    pub(crate) fn thickness(&self) -> f32 {
        self.thickness
    }

    /// Moves the friction anchors with the cloth when it is carried (a followed frame).
    pub(crate) fn carry_anchors(&mut self, map: impl Fn(Vec3A) -> Vec3A) {
        for anchor in self.anchors.iter_mut().filter(|a| a.collider != NONE) {
            anchor.point = map(anchor.point);
        }
    }

    /// Forgets every contact, held normal and anchor (a reset cloth, or colliders renumbered).
    pub(crate) fn forget(&mut self) {
        self.contacts.fill(Contact::EMPTY);
        self.held.fill(Vec3A::ZERO);
        self.anchors.fill(Anchor::NONE);
    }

    /// Whether any particle touched a collider in the current (or last) substep.
    pub(crate) fn touching(&self) -> bool {
        self.contacts.iter().any(|c| c.is_some())
    }

    /// How many particles touched a collider in the last substep.
    pub(crate) fn count(&self) -> usize {
        self.contacts.iter().filter(|c| c.is_some()).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::{ContactMaterial, SolverShape};
    use crate::rng::Rng;
    use bevy::math::Quat;

    /// A sphere or a capsule at a random pose, moved and turned (up to half a turn) at random
    /// over a step of `dt`.
    fn random_rounded_collider(rng: &mut Rng, dt: f32) -> SolverCollider {
        let radius = rng.range(0.03, 0.15);
        let shape = if rng.uniform() < 0.3 {
            SolverShape::Sphere { radius }
        } else {
            SolverShape::Capsule {
                radius,
                half_length: rng.range(0.0, 0.2),
            }
        };
        let random_turn = |rng: &mut Rng, most: f32| {
            Quat::from_axis_angle(rng.unit_vector(), rng.range(-most, most))
        };
        let start = RigidPose {
            translation: rng.vec3(-0.3, 0.3).into(),
            rotation: random_turn(rng, std::f32::consts::PI),
        };
        let end = RigidPose {
            translation: start.translation + Vec3A::from(rng.vec3(-0.1, 0.1)),
            rotation: random_turn(rng, 0.5 * std::f32::consts::PI) * start.rotation,
        };
        let mut collider = SolverCollider::fixed(shape, start);
        collider.end = end;
        (collider.linear_velocity, collider.angular_velocity) = start.velocity_to(&end, dt);
        collider
    }

    /// No point of a sphere's or a capsule's core moves farther over the step than
    /// `SolverCollider::core_motion`, at any pose between the start and the end.
    #[test]
    fn no_core_point_moves_farther_than_the_core_motion() {
        let mut rng = Rng(11);
        for _ in 0..300 {
            let c = random_rounded_collider(&mut rng, 1.0 / 60.0);
            let bound = c.core_motion().unwrap();
            let half_length = match c.shape {
                SolverShape::Capsule { half_length, .. } => half_length,
                _ => 0.0,
            };
            for _ in 0..20 {
                let local = Vec3A::Y * rng.range(-half_length, half_length);
                let at = c.pose_at(rng.uniform()).transform_point(local);
                let moved = at.distance(c.start.transform_point(local));
                assert!(moved <= bound + 1e-5, "{moved} > {bound}");
            }
        }
        let plane = SolverCollider::ground(0.0, ContactMaterial::default());
        assert_eq!(plane.core_motion(), None);
    }

    /// Random particles outside random moving spheres and capsules (and a ground), moving at
    /// random velocities: the passes over each collider's candidates move every particle
    /// exactly as passes over every particle do, substep after substep.
    #[test]
    fn the_candidates_give_the_contacts_every_particle_would() {
        let mut rng = Rng(5);
        let dt = 1.0 / 60.0;
        let substeps = 4;
        let h = dt / substeps as f32;
        let thickness = 0.005;
        let mut touched = 0;
        for _ in 0..40 {
            let mut colliders: Vec<SolverCollider> = (0..4)
                .map(|_| random_rounded_collider(&mut rng, dt))
                .collect();
            colliders.push(SolverCollider::ground(-0.35, ContactMaterial::default()));
            let reach = |c: &SolverCollider| c.margin + thickness;
            let outside = |p: Vec3A| {
                colliders.iter().all(|c| {
                    let local = c.start.inverse_transform_point(p);
                    c.shape.signed_distance(local, reach(c)).is_none()
                })
            };
            let mut x = Vec::new();
            while x.len() < 200 {
                let p = Vec3A::from(rng.vec3(-0.5, 0.5));
                if outside(p) {
                    x.push(p);
                }
            }
            let v: Vec<Vec3A> = x.iter().map(|_| Vec3A::from(rng.vec3(-3.0, 3.0))).collect();
            let w = vec![1.0; x.len()];
            let speed = v.iter().fold(0.0f32, |m, v| m.max(v.length()));
            let (mut listed, mut every) = (ContactScratch::default(), ContactScratch::default());
            listed.begin_step(&colliders, &x, speed * dt, thickness);
            every.begin_step(&colliders, &x, speed * dt, thickness);
            // Every particle looked at for every collider.
            every.candidate_ranges.fill(None);
            let (mut xa, mut xb) = (x.clone(), x.clone());
            for s in 0..substeps {
                let x_prev = xa.clone();
                assert_eq!(xa, xb);
                for ((a, b), v) in xa.iter_mut().zip(&mut xb).zip(&v) {
                    *a += *v * h;
                    *b += *v * h;
                }
                let (t0, t1) = (s as f32 / substeps as f32, (s + 1) as f32 / substeps as f32);
                for (scratch, x) in [(&mut listed, &mut xa), (&mut every, &mut xb)] {
                    scratch.begin_substep(&colliders, t0, t1, x, &x_prev);
                    for pass in [
                        ContactPass::Iteration {
                            friction_step: Some(h),
                        },
                        ContactPass::Closing,
                    ] {
                        scratch.project(&colliders, x, &x_prev, &v, &w, Vec3A::ZERO, pass);
                    }
                }
                assert_eq!(xa, xb, "substep {s}");
                assert_eq!(listed.contacts(), every.contacts());
                // The contacts with the spheres and capsules (the ground is the fifth).
                touched += listed.contacts().iter().filter(|c| c.collider < 4).count();
            }
            assert!(listed.candidates.len() < 4 * x.len());
        }
        // The particles met the colliders often enough for the comparison to mean something.
        assert!(touched > 300, "{touched} contacts");
    }
}
