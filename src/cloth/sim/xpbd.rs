//! The XPBD (and plain PBD) step of [`ClothSim`]: the substep loop of predictions,
//! constraint iterations, velocities, contact response and damping.

use bevy::math::{Vec3, Vec3A, Vec4};

use super::ClothSim;
use super::passes::{damp, project_edges_jacobi};
use crate::cloth::constraints::{Projection, project_bending, project_mutual_tether};
use crate::cloth::settings::{SolverMethod, SolverSettings};
use crate::cloth::state::ClothState;

impl ClothSim {
    pub(super) fn step_constraints(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
    ) {
        let substeps = settings.substeps.max(1);
        self.last_substeps = substeps;
        let iterations = settings.iterations.max(1);
        let h = dt / substeps as f32;
        let a = Vec3A::from(acceleration);
        let (stretch, bend) = match settings.method {
            SolverMethod::Xpbd => (
                Projection::Xpbd {
                    alpha_tilde: settings.stretch_compliance / (h * h),
                },
                Projection::Xpbd {
                    alpha_tilde: settings.bend_compliance / (h * h),
                },
            ),
            SolverMethod::Pbd { stiffness } => {
                (Projection::Pbd { stiffness }, Projection::Pbd { stiffness })
            }
            SolverMethod::MassSpring | SolverMethod::Hybrid => return,
        };
        let isometric = match bend {
            Projection::Xpbd { alpha_tilde } if settings.isometric_bending => Some(alpha_tilde),
            // Plain PBD has no compliance to calibrate: it keeps the dihedral form.
            _ => None,
        };
        // With zero compliance an XPBD step is PBD's with stiffness 1: the batched edges then
        // skip their multipliers.
        let batch_stretch = match stretch {
            Projection::Xpbd { alpha_tilde: 0.0 } => Projection::Pbd { stiffness: 1.0 },
            other => other,
        };
        let damping_k = 1.0 - (-settings.damping * h).exp();
        if let Some(alpha_tilde) = isometric
            && self.bend_alpha_prepared != alpha_tilde.to_bits()
        {
            self.isometric_prepared.prepare(
                &self.isometric_pairs,
                &self.state.inverse_masses,
                alpha_tilde,
            );
            self.bend_alpha_prepared = alpha_tilde.to_bits();
        }
        let ClothState {
            positions: x,
            previous_positions: x_prev,
            velocities: v,
            inverse_masses: w,
        } = &mut self.state;
        let colliders = &self.colliders;
        self.contacts
            .begin_step(colliders, x.len(), settings.thickness);
        let bounce_threshold = 2.0 * a.length() * h;

        for s in 0..substeps {
            // 1. Predict.
            let half_h2_a = a * (0.5 * h * h);
            for (((x, x_prev), v), &w) in x.iter_mut().zip(x_prev.iter_mut()).zip(&*v).zip(&*w) {
                *x_prev = *x;
                if w > 0.0 {
                    *x += *v * h + half_h2_a;
                }
            }
            let t_end = (s + 1) as f32 / substeps as f32;
            for pin in self.pins.iter().chain(self.drag.as_ref()) {
                x[pin.particle as usize] = pin.start.lerp(pin.end, t_end);
            }

            // 2. Project.
            if !colliders.is_empty() {
                self.contacts.begin_substep(colliders, t_end);
            }
            let mut volume = match (settings.volume, self.volume.as_mut()) {
                (Some(v), Some(Ok(constraint))) => {
                    constraint.reset_multiplier();
                    Some((v, constraint))
                }
                _ => None,
            };
            if volume.is_some() {
                self.edge_lambdas.fill(0.0);
            } else if matches!(batch_stretch, Projection::Xpbd { .. }) {
                self.edge_batch_lambdas.fill(Vec4::ZERO);
            }
            for iteration in 0..iterations {
                if settings.long_range_attachments {
                    self.limit_batches.project_limits(x);
                    self.tether_batches.project_limits(x);
                    for tether in &self.contact_tethers {
                        project_mutual_tether(x, w, tether);
                    }
                }
                if volume.is_some() {
                    project_edges_jacobi(
                        &self.model.edges,
                        &mut self.edge_lambdas,
                        x,
                        w,
                        stretch,
                        &mut self.jacobi,
                    );
                } else {
                    self.edge_batches.project_distances(
                        &mut self.edge_batch_lambdas,
                        x,
                        batch_stretch,
                    );
                }
                if let Some((v, constraint)) = volume.as_mut() {
                    let alpha_tilde = match settings.method {
                        SolverMethod::Pbd { .. } => 0.0,
                        _ => v.compliance / (h * h),
                    };
                    constraint.project(x, w, v.pressure, alpha_tilde);
                }
                // Bending is soft: once per substep, so its multipliers start at zero each
                // time and need no storing.
                if iteration == 0 {
                    if isometric.is_some() {
                        self.isometric_prepared.project(x);
                    }
                    let dihedral = if isometric.is_some() {
                        &self.curved_pairs
                    } else {
                        &self.model.bending_pairs
                    };
                    for pair in dihedral {
                        let mut lambda = 0.0;
                        project_bending(x, w, pair.particles, pair.rest_angle, bend, &mut lambda);
                    }
                }
                // Self-collision before the colliders, so that pushing layers apart never
                // leaves a particle inside a collider.
                if let Some(sc) = self
                    .self_collision
                    .as_ref()
                    .filter(|_| settings.self_collision)
                {
                    let touching = sc.project(x, x_prev, w, settings.friction, None);
                    if iteration + 1 == iterations {
                        self.self_contacts = self.self_contacts.max(touching);
                    }
                }
                if !colliders.is_empty() {
                    self.contacts
                        .project(colliders, x, v, w, a * h, settings.thickness);
                }
            }

            // 3. Velocities: v = (x - x_prev) / h + h/2 a, computed as v + h a + (x - x_pred) / h
            //    with the prediction x_pred recomputed bit for bit, so that an unconstrained
            //    particle's velocity carries no rounding from the difference of two nearly
            //    equal positions (in f32 that difference loses millimetres per second of fall).
            let inv_h = 1.0 / h;
            let h_a = a * h;
            for (((x, x_prev), v), &w) in x.iter().zip(&*x_prev).zip(v.iter_mut()).zip(&*w) {
                if w > 0.0 {
                    let predicted = *x_prev + (*v * h + half_h2_a);
                    *v += h_a + (*x - predicted) * inv_h;
                } else {
                    *v = (*x - *x_prev) * inv_h;
                }
            }

            // 4. Contacts: restitution and friction relative to each collider's surface (see
            //    `crate::collide::contact`), then damping.
            if !colliders.is_empty() {
                self.contacts
                    .respond(colliders, x, x_prev, v, inv_h, h, bounce_threshold);
            }
            damp(settings, damping_k, x, v, w, &self.free_masses);
        }
    }
}
