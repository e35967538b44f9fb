//! The mass-spring and hybrid steps of [`ClothSim`]: spring forces with symplectic Euler,
//! the hybrid's structural edges projected in XPBD form.

use bevy::math::{Vec3, Vec3A};

use super::ClothSim;
use super::passes::{damp, project_edges, project_edges_jacobi};
use crate::cloth::constraints::{Projection, project_mutual_tether};
use crate::cloth::mass_spring::auto_substeps;
use crate::cloth::settings::SolverSettings;
use crate::cloth::state::ClothState;

impl ClothSim {
    /// One fixed step of [`SolverMethod::MassSpring`]: in each substep of length `h`, with the
    /// spring forces `f` at the substep's start,
    /// 1. symplectic Euler: `v += h (a + f / m)`, then `x += h v` (free particles); pins move
    ///    to their interpolated targets with the velocity of their straight path;
    /// 2. contacts with the colliders (planes included), found at the end of the substep
    ///    (`collide/contact.rs`);
    /// 3. damping ([`SolverSettings::damping`], on top of the springs' own).
    pub(super) fn step_mass_spring(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
    ) {
        self.step_springs(settings, acceleration, dt, false);
    }

    /// One fixed step of [`SolverMethod::Hybrid`]: in each substep of length `h`, with the
    /// shear and bend spring forces `f` at the substep's start,
    /// 1. predict: `x_prev = x`, `v += h (a + f / m)`, `x += h v` (free particles); pins move
    ///    to their interpolated targets;
    /// 2. project, `iterations` times: the long-range attachments (if on), the structural
    ///    edges as XPBD distance constraints with `stretch_compliance`, the colliders;
    /// 3. `v = (x - x_prev) / h`; contacts and damping as in XPBD.
    pub(super) fn step_hybrid(&mut self, settings: &SolverSettings, acceleration: Vec3, dt: f32) {
        self.step_springs(settings, acceleration, dt, true);
    }

    fn step_springs(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
        hybrid: bool,
    ) {
        if !(dt > 0.0 && dt.is_finite()) {
            return;
        }
        self.spring_scratch();
        self.sync_weights();
        let Some(springs) = self.springs.as_mut() else {
            return;
        };
        let ClothState {
            positions: x,
            previous_positions: x_prev,
            velocities: v,
            inverse_masses: w,
        } = &mut self.state;
        let mut substeps = settings.substeps.max(1);
        if settings.auto_substeps {
            let h_max = springs.set.stable_step(&settings.springs, !hybrid, w);
            substeps = auto_substeps(dt, h_max, substeps);
        }
        self.last_substeps = substeps;
        let iterations = settings.iterations.max(1);
        let h = dt / substeps as f32;
        let inv_h = 1.0 / h;
        let a = Vec3A::from(acceleration);
        let stretch = Projection::Xpbd {
            alpha_tilde: settings.stretch_compliance / (h * h),
        };
        let damping_k = 1.0 - (-settings.damping * h).exp();
        let pin_velocity = 1.0 / dt;
        let colliders = &self.colliders;
        self.contacts
            .begin_step(colliders, x.len(), settings.thickness);
        let bounce_threshold = 2.0 * a.length() * h;
        let self_collision = self
            .self_collision
            .as_ref()
            .filter(|_| settings.self_collision);
        let mut self_contacts = 0;

        for s in 0..substeps {
            springs.forces.fill(Vec3A::ZERO);
            springs
                .set
                .add_forces(&settings.springs, !hybrid, x, v, &mut springs.forces);
            for i in 0..x.len() {
                x_prev[i] = x[i];
                if w[i] > 0.0 {
                    v[i] += (a + springs.forces[i] * w[i]) * h;
                    x[i] += v[i] * h;
                }
            }
            let t_end = (s + 1) as f32 / substeps as f32;
            for pin in self.pins.iter().chain(self.drag.as_ref()) {
                let p = pin.particle as usize;
                x[p] = pin.start.lerp(pin.end, t_end);
                v[p] = (pin.end - pin.start) * pin_velocity;
            }

            if !colliders.is_empty() {
                self.contacts.begin_substep(colliders, t_end);
            }
            if hybrid {
                springs.lambdas.fill(0.0);
                let mut volume = match (settings.volume, self.volume.as_mut()) {
                    (Some(v), Some(Ok(constraint))) => {
                        constraint.reset_multiplier();
                        Some((v, constraint))
                    }
                    _ => None,
                };
                for _ in 0..iterations {
                    if settings.long_range_attachments {
                        self.limit_batches.project_limits(x);
                        self.tether_batches.project_limits(x);
                        for tether in &self.contact_tethers {
                            project_mutual_tether(x, w, tether);
                        }
                    }
                    let edges = &springs.set.structural_edges;
                    if volume.is_some() {
                        project_edges_jacobi(
                            edges,
                            &mut springs.lambdas,
                            x,
                            w,
                            stretch,
                            &mut self.jacobi,
                        );
                    } else {
                        project_edges(edges, &mut springs.lambdas, x, w, stretch);
                    }
                    if let Some((v, constraint)) = volume.as_mut() {
                        constraint.project(x, w, v.pressure, v.compliance / (h * h));
                    }
                    if let Some(sc) = self_collision {
                        self_contacts =
                            self_contacts.max(sc.project(x, x_prev, w, settings.friction, None));
                    }
                    if !colliders.is_empty() {
                        self.contacts
                            .project(colliders, x, v, w, Vec3A::ZERO, settings.thickness);
                    }
                }
                for i in 0..x.len() {
                    v[i] = (x[i] - x_prev[i]) * inv_h;
                }
            } else {
                if let Some(sc) = self_collision {
                    // Discrete: the correction also changes the velocity.
                    self_contacts = self_contacts.max(sc.project(
                        x,
                        x_prev,
                        w,
                        settings.friction,
                        Some((v, inv_h)),
                    ));
                }
                if !colliders.is_empty() {
                    self.contacts
                        .project(colliders, x, v, w, Vec3A::ZERO, settings.thickness);
                }
            }
            if !colliders.is_empty() {
                self.contacts.respond(
                    colliders,
                    x,
                    x_prev,
                    v,
                    if hybrid { inv_h } else { 0.0 },
                    h,
                    bounce_threshold,
                );
            }
            damp(settings, damping_k, x, v, w, &self.free_masses);
        }
        self.self_contacts = self_contacts;
    }
}
