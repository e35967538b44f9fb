//! The substep pipeline of [`ClothSolver::step`], one sequence for every solver method. Each
//! substep of length `h`:
//!
//! 1. predict: the air's acceleration (`air.rs`, taken once per step) as a kick
//!    `v += h a_air`; then XPBD and PBD `x += h v + h^2/2 a` (velocity Verlet); the spring methods take
//!    the spring forces `f` at the substep's start, `v += h (a + f / m)`, `x += h v`
//!    (symplectic Euler; the hybrid's springs are the shear and bend ones only). Pins move to
//!    their interpolated targets.
//! 2. project, `iterations` times (once for mass-spring), in this order: colliders (planes
//!    included; the vertices of triangle meshes against the cloth's triangles,
//!    `collide/vertex_contacts.rs`; in the last iteration also the cloth's edges against the spheres and capsules
//!    thin enough to pass between two particles, `collide/edge_contacts.rs`) with friction on
//!    the positions and then self-collision, first in every
//!    iteration for all but mass-spring (`collide/contact.rs`: the constraints after them carry
//!    each push on within the iteration, and an iteration ends with the edges met); the
//!    long-range constraints (stretch limits and tethers: XPBD and PBD if on, the hybrid only
//!    if its method asks for them, never mass-spring), edges (XPBD and PBD all of them,
//!    batched, then once more the structural edges of particles a collider holds, each held
//!    particle moving along its surface only (`passes.rs`); or Jacobi for a closed cloth; the
//!    hybrid its structural edges; mass-spring none: its edges are springs), the rim limits of
//!    the cloth's holes (with the long-range constraints, `rims.rs`), volume, bending pairs
//!    (XPBD and PBD, their multipliers accumulated over the substep's iterations); for
//!    mass-spring, self-collision and the colliders last. After the last iteration, with
//!    [`SolverSettings::exact_edges`] and while the cloth touches a collider, the structural
//!    edges are solved exactly (`fast_projection.rs`); then the closing collider pass moves
//!    anything left inside a collider onto its surface (the particles, the mesh vertices
//!    against the triangles to half their reach, then the edges against thin colliders);
//!    while it pushes a particle farther than [`ExactEdges::closing_tolerance`], the edges
//!    are solved again with the pushed particles made heavy, and closed again (at most
//!    [`ExactEdges::closing_rounds`] times). Bending in every iteration rather than the
//!    first alone costs 28% more per frame on S1 at N = 64, 8 x 2 (1.38 to 1.77 ms), and
//!    holds it tighter at equal cost (0.74% max strain, against 0.82% for the first
//!    iteration alone at 10 x 2, 1.92 ms); the first alone also left a floor of 0.6 to 0.8%
//!    whatever the budget (12 x 2 0.61%, 16 x 2 0.71%, 32 x 2 0.78%; now 0.49%, 0.43%,
//!    0.50%). Bending in the last iteration alone costs what the first did and holds S1 as
//!    well, but leaves S2 with S1's cloth at N = 64 stretched 75% (bending after the edges
//!    pushes the sheet into the sphere every substep).
//! 3. velocities: XPBD and PBD `v = (x - x_prev) / h + h/2 a`; the hybrid
//!    `v = (x - x_prev) / h` (both computed from the prediction, so that an unconstrained
//!    particle's velocity carries no rounding); mass-spring keeps the integrated ones (its
//!    self-collision and contacts correct them directly).
//! 4. contacts: restitution relative to each collider's surface, and for mass-spring Coulomb
//!    friction on the velocities (`collide/contact.rs`); then damping.
//!
//! [`ExactEdges::closing_tolerance`]: crate::cloth::ExactEdges::closing_tolerance
//! [`ExactEdges::closing_rounds`]: crate::cloth::ExactEdges::closing_rounds

use bevy::math::{Vec3, Vec3A, Vec4};

use super::halves::{Halves, Sweep};
use super::parallel::{Join, per_half};
use super::passes::{damp, project_edges, project_edges_jacobi, project_held_edges};
use super::timings::{Laps, StepTimings};
use super::{ClothSolver, SubstepCoupling};
use crate::cloth::constraints::{Projection, project_bending};
use crate::cloth::fast_projection::FastProjection;
use crate::cloth::mass_spring::auto_substeps;
use crate::cloth::model::EdgeKind;
use crate::cloth::rims::project_rim;
use crate::cloth::settings::{SelfCollisionMethod, SolverMethod, SolverSettings};
use crate::cloth::state::ClothState;
use crate::collide::SolverCollider;
use crate::collide::contact::{ContactPass, ContactScratch};
use crate::collide::edge_contacts::EdgeContacts;
use crate::collide::vertex_contacts::MeshVertexContacts;

/// What a solver method projects, per substep of length `h`.
struct Projections {
    /// The edges' distance projection (none for mass-spring, whose edges are springs).
    stretch: Option<Projection>,
    /// The shear edges' projection when they are projected apart
    /// ([`SolverSettings::projects_shear_apart`]) and their compliance is finite.
    shear: Option<Projection>,
    /// The dihedral bending projection (XPBD and PBD; the spring methods bend with springs).
    bend: Option<Projection>,
    /// The time-step-scaled compliance of the isometric bending pairs, if they are used.
    isometric: Option<f32>,
    /// The volume constraint's time-step-scaled compliance.
    volume_alpha: f32,
}

impl Projections {
    fn of(settings: &SolverSettings, h: f32) -> Self {
        let xpbd = |compliance: f32| Projection::Xpbd {
            alpha_tilde: compliance / (h * h),
        };
        let volume_alpha = settings.volume.map_or(0.0, |v| v.compliance / (h * h));
        let (stretch, bend, volume_alpha) = match settings.method {
            SolverMethod::Xpbd => (
                Some(xpbd(settings.stretch_compliance)),
                Some(xpbd(settings.bend_compliance)),
                volume_alpha,
            ),
            SolverMethod::Pbd { stiffness } => (
                Some(Projection::Pbd { stiffness }),
                Some(Projection::Pbd { stiffness }),
                0.0,
            ),
            SolverMethod::Hybrid { .. } => {
                (Some(xpbd(settings.stretch_compliance)), None, volume_alpha)
            }
            SolverMethod::MassSpring => (None, None, 0.0),
        };
        let isometric = match bend {
            Some(Projection::Xpbd { alpha_tilde }) if settings.isometric_bending => {
                Some(alpha_tilde)
            }
            // Plain PBD has no compliance to calibrate: it keeps the dihedral form.
            _ => None,
        };
        let shear = Some(xpbd(settings.shear_compliance))
            .filter(|_| settings.projects_shear_apart())
            .filter(|p| matches!(p, Projection::Xpbd { alpha_tilde } if alpha_tilde.is_finite()));
        Self {
            stretch,
            shear,
            bend,
            isometric,
            volume_alpha,
        }
    }
}

impl ClothSolver {
    /// One fixed step of `settings.method` at `settings.substeps` (more with automatic
    /// substeps), through the pipeline of the module docs.
    pub(super) fn step_substeps(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
        join: &dyn Join,
        mut coupling: Option<&mut dyn SubstepCoupling>,
    ) {
        let method = settings.method;
        let hybrid = method.is_hybrid();
        let uses_springs = hybrid || method == SolverMethod::MassSpring;
        let mass_spring = method == SolverMethod::MassSpring;
        if uses_springs {
            self.spring_scratch();
        }
        let mut substeps = settings.substeps.max(1);
        if let Some(springs) = self.springs.as_ref().filter(|_| uses_springs)
            && settings.auto_substeps
        {
            let h_max =
                springs
                    .set
                    .stable_step(&settings.springs, !hybrid, &self.state.inverse_masses);
            substeps = auto_substeps(dt, h_max, substeps);
        }
        self.last_substeps = substeps;
        let iterations = if mass_spring {
            1
        } else {
            settings.iterations.max(1)
        };
        let h = dt / substeps as f32;
        let inv_h = 1.0 / h;
        let a = Vec3A::from(acceleration);
        let projections = Projections::of(settings, h);
        // With zero compliance an XPBD step is PBD's with stiffness 1: the batched edges then
        // skip their multipliers.
        let batch_stretch = match projections.stretch {
            Some(Projection::Xpbd { alpha_tilde: 0.0 }) => Projection::Pbd { stiffness: 1.0 },
            other => other.unwrap_or(Projection::Pbd { stiffness: 1.0 }),
        };
        if let Some(alpha_tilde) = projections.isometric
            && self.bend_alpha_prepared != alpha_tilde.to_bits()
        {
            self.isometric_prepared.prepare(
                &self.isometric_pairs,
                &self.state.inverse_masses,
                alpha_tilde,
            );
            self.bend_alpha_prepared = alpha_tilde.to_bits();
        }
        let long_range = settings.projects_long_range();
        // Two halves at once (`halves.rs`).
        let splits = join.is_parallel() && self.splits_in_two(settings);
        let air = settings
            .air
            .is_some_and(|air| air.is_active())
            .then_some(&self.air_acceleration);
        let travel = self.step_travel(a, dt, air.map(Vec::as_slice));
        let mut halves = self
            .halves
            .as_mut()
            .and_then(Option::as_mut)
            .filter(|_| splits);
        if let (Some(halves), Some(alpha_tilde)) = (halves.as_deref_mut(), projections.isometric) {
            halves.prepare_bending(&self.state.inverse_masses, alpha_tilde);
        }
        // XPBD and PBD let a contact remove the substep's gravity as the particle rests; the
        // spring methods have already integrated it into the velocity.
        let contact_push = if uses_springs { Vec3A::ZERO } else { a * h };
        // The methods that derive velocities from positions apply friction to the positions,
        // in every iteration; mass-spring to its velocities after the substep.
        let friction_step = (!mass_spring).then_some(h);
        let damping_k = 1.0 - (-settings.damping * h).exp();
        let pin_velocity = 1.0 / dt;
        let bounce_threshold = 2.0 * a.length() * h;

        let ClothState {
            positions: x,
            previous_positions: x_prev,
            velocities: v,
            inverse_masses: w,
        } = &mut self.state;
        let mut springs = self.springs.as_mut().filter(|_| uses_springs);
        let colliders = &self.colliders;
        let mut self_collision = self
            .self_collision
            .as_mut()
            .filter(|_| settings.self_collision != SelfCollisionMethod::Off);
        let mut laps = Laps::start();
        self.contacts
            .begin_step(colliders, x, travel, settings.thickness);
        self.vertex_contacts.begin_step(
            colliders,
            &self.model.triangles,
            x,
            v,
            a,
            dt,
            settings.thickness,
        );
        self.edge_contacts
            .begin_step(colliders, x, v, a, dt, settings.thickness);
        // The exact edges' scratch memory, made before any step that may use it.
        if settings.exact_edge_solve().is_some()
            && !colliders.is_empty()
            && self.fast_projection.is_none()
        {
            let structural = self
                .model
                .edges
                .iter()
                .filter(|e| e.kind == EdgeKind::Structural);
            self.fast_projection = Some(FastProjection::new(structural, x.len()));
        }
        let collider_pass = ColliderPass {
            colliders,
            triangles: &self.model.triangles,
            h_a: contact_push,
            thickness: settings.thickness,
            mesh_vertices: self.vertex_contacts.has_candidates(),
            edges: self.edge_contacts.has_candidates(),
        };
        let mut t = StepTimings {
            contacts: laps.lap(),
            ..StepTimings::default()
        };

        for s in 0..substeps {
            // 1. Predict (the air's share first, as a kick: it is constant over the step).
            let half_h2_a = a * (0.5 * h * h);
            let middle = halves.as_deref().map(Halves::middle);
            match springs.as_deref_mut() {
                None => per_half(join, middle, x, x_prev, v, w, |p| match air {
                    Some(air) => {
                        let air = air.get(p.first..).unwrap_or(&[]);
                        for ((((x, x_prev), v), &w), &air) in
                            p.x.iter_mut()
                                .zip(p.x_prev.iter_mut())
                                .zip(p.v.iter_mut())
                                .zip(p.w)
                                .zip(air)
                        {
                            *x_prev = *x;
                            if w > 0.0 {
                                *v += air * h;
                                *x += *v * h + half_h2_a;
                            }
                        }
                    }
                    None => {
                        for (((x, x_prev), v), &w) in
                            p.x.iter_mut().zip(p.x_prev.iter_mut()).zip(&*p.v).zip(p.w)
                        {
                            *x_prev = *x;
                            if w > 0.0 {
                                *x += *v * h + half_h2_a;
                            }
                        }
                    }
                }),
                Some(springs) => {
                    if let Some(air) = air {
                        for ((v, &air), &w) in v.iter_mut().zip(air).zip(&*w) {
                            if w > 0.0 {
                                *v += air * h;
                            }
                        }
                    }
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
                }
            }
            let t_end = (s + 1) as f32 / substeps as f32;
            for pin in self.pins.iter().chain(self.drag.as_ref()) {
                let p = pin.particle as usize;
                x[p] = pin.start.lerp(pin.end, t_end);
                if uses_springs {
                    v[p] = (pin.end - pin.start) * pin_velocity;
                }
            }
            for (anchor, &pin) in self.tether_anchors.iter_mut().zip(&self.tether_pins) {
                *anchor = x[pin as usize];
            }
            if let Some(halves) = halves.as_deref_mut() {
                halves.begin_substep(x);
            }

            t.predict += laps.lap();
            if let Some(coupling) = coupling.as_deref_mut() {
                coupling.begin_substep(x, &self.model.triangles, h);
            }

            // 2. Project.
            if let Some(sc) = self_collision.as_deref_mut() {
                sc.begin_substep(x, x_prev, substeps);
                t.self_collision += laps.lap();
            }
            if !colliders.is_empty() {
                self.contacts.begin_substep(
                    colliders,
                    s as f32 / substeps as f32,
                    t_end,
                    x,
                    x_prev,
                );
                self.vertex_contacts.begin_substep();
                self.edge_contacts.begin_substep(colliders, &self.contacts);
                t.contacts += laps.lap();
            }
            let mut volume = match (settings.volume, self.volume.as_mut()) {
                (Some(v), Some(Ok(constraint))) if !mass_spring => {
                    constraint.reset_multiplier();
                    Some((v, constraint))
                }
                _ => None,
            };
            match springs.as_deref_mut() {
                Some(springs) => springs.lambdas.fill(0.0),
                None if volume.is_some() => self.edge_lambdas.fill(0.0),
                // The halves zero their own.
                None if matches!(batch_stretch, Projection::Xpbd { .. }) && halves.is_none() => {
                    self.edge_batch_lambdas.fill(Vec4::ZERO);
                }
                None => {}
            }
            if self.shear_apart {
                self.shear_batch_lambdas.fill(Vec4::ZERO);
            }
            if projections.bend.is_some() {
                let dihedral = if projections.isometric.is_some() {
                    self.curved_pairs.len()
                } else {
                    self.model.bending_pairs.len()
                };
                self.dihedral_lambdas.clear();
                self.dihedral_lambdas.resize(dihedral, 0.0);
                self.isometric_lambdas.clear();
                if halves.is_none() {
                    self.isometric_lambdas
                        .resize(self.isometric_prepared.len(), Vec3A::ZERO);
                }
            }
            for iteration in 0..iterations {
                // The colliders and self-collision first (all but mass-spring), so that the
                // cloth's constraints after them carry every push on to the rest of the cloth
                // within the iteration (see the module docs).
                if !mass_spring {
                    if !colliders.is_empty() {
                        // The edges against thin colliders in the last iteration only.
                        let pass = ColliderPass {
                            edges: collider_pass.edges && iteration + 1 == iterations,
                            ..collider_pass
                        };
                        pass.project(
                            &mut self.contacts,
                            &mut self.vertex_contacts,
                            &mut self.edge_contacts,
                            (x, x_prev, v, w),
                            ContactPass::Iteration { friction_step },
                        );
                        t.contacts += laps.lap();
                    }
                    if let Some(coupling) = coupling.as_deref_mut() {
                        coupling.iterate(x, x_prev, w, &self.model.triangles);
                    }
                    if let Some(sc) = self_collision.as_deref_mut() {
                        let touching = sc.project(x, x_prev, w, settings.friction, None);
                        if iteration + 1 == iterations {
                            self.self_contacts = self.self_contacts.max(touching);
                        }
                        t.self_collision += laps.lap();
                    }
                }
                if let Some(halves) = halves.as_deref_mut() {
                    let sweep = Sweep {
                        long_range,
                        stretch: batch_stretch,
                        isometric: projections.isometric.is_some(),
                        first: iteration == 0,
                    };
                    halves.project(x, sweep, join);
                    if !colliders.is_empty() {
                        project_held_edges(&self.model.edges, x, w, self.contacts.held());
                    }
                } else if long_range {
                    self.limit_batches.project_limits(x);
                    self.tether_batches.project_tethers(x, &self.tether_anchors);
                }
                if let Some(stretch) = projections.stretch.filter(|_| halves.is_none()) {
                    let (edges, lambdas) = match springs.as_deref_mut() {
                        Some(springs) => (&springs.set.structural_edges, &mut springs.lambdas),
                        None => (&self.model.edges, &mut self.edge_lambdas),
                    };
                    if volume.is_some() {
                        project_edges_jacobi(edges, lambdas, x, w, stretch, &mut self.jacobi);
                    } else if hybrid {
                        project_edges(edges, lambdas, x, w, stretch);
                    } else {
                        self.edge_batches.project_distances(
                            &mut self.edge_batch_lambdas,
                            x,
                            batch_stretch,
                        );
                        if let Some(shear) = projections.shear.filter(|_| self.shear_apart) {
                            self.shear_batches.project_distances(
                                &mut self.shear_batch_lambdas,
                                x,
                                shear,
                            );
                        }
                        if !colliders.is_empty() {
                            project_held_edges(&self.model.edges, x, w, self.contacts.held());
                        }
                    }
                }
                // Rim limits after the edges, with the other long-range constraints' condition
                // (exact for an inextensible cloth only).
                if long_range {
                    for rim in &self.rims {
                        project_rim(x, w, rim);
                    }
                }
                if let Some((v, constraint)) = volume.as_mut() {
                    constraint.project(x, w, v.pressure, projections.volume_alpha);
                }
                // Bending in every iteration, its multipliers accumulated over the substep's
                // iterations, as XPBD prescribes.
                if let Some(bend) = projections.bend {
                    if projections.isometric.is_some() && halves.is_none() {
                        self.isometric_prepared
                            .project(x, &mut self.isometric_lambdas);
                    }
                    let dihedral = if projections.isometric.is_some() {
                        &self.curved_pairs
                    } else {
                        &self.model.bending_pairs
                    };
                    for (pair, lambda) in dihedral.iter().zip(&mut self.dihedral_lambdas) {
                        project_bending(x, w, pair.particles, pair.rest_angle, bend, lambda);
                    }
                }
                t.constraints += laps.lap();
                // Mass-spring (one iteration, no constraints of its own): self-collision, then
                // the colliders, so that pushing layers apart never leaves a particle inside a
                // collider. Its self-collision is discrete: the correction also changes the
                // velocity.
                if mass_spring {
                    if let Some(sc) = self_collision.as_deref_mut() {
                        let discrete = Some((v.as_mut_slice(), inv_h));
                        let touching = sc.project(x, x_prev, w, settings.friction, discrete);
                        self.self_contacts = self.self_contacts.max(touching);
                        t.self_collision += laps.lap();
                    }
                    if !colliders.is_empty() {
                        collider_pass.project(
                            &mut self.contacts,
                            &mut self.vertex_contacts,
                            &mut self.edge_contacts,
                            (x, x_prev, v, w),
                            ContactPass::Iteration {
                                friction_step: None,
                            },
                        );
                        t.contacts += laps.lap();
                    }
                }
            }
            // The triangles held once more after the iterations' last constraints, before the
            // exact edges, which move the particles least.
            if let Some(sc) = self_collision.as_deref_mut().filter(|_| !mass_spring) {
                sc.close(x, x_prev, w);
                t.self_collision += laps.lap();
            }
            // The structural edges solved exactly (`fast_projection.rs`), while the cloth
            // touches a collider (the long-range attachments hold a cloth hanging from pins).
            let touching = !colliders.is_empty()
                && (self.contacts.touching()
                    || self.vertex_contacts.has_candidates()
                    || self.edge_contacts.touched());
            let mut exact = settings
                .exact_edge_solve()
                .filter(|_| touching)
                .zip(self.fast_projection.as_mut());
            if let Some((exact, projection)) = exact.as_mut() {
                projection.project(x, w, exact.newton_steps, exact.cg_iterations);
                t.constraints += laps.lap();
            }
            // The closing pass: nothing left inside a collider. While it pushes a particle
            // deep, the exact edges again with the pushed particles made heavy, and the
            // closing pass after them.
            let rounds = exact.as_ref().map_or(0, |(exact, _)| exact.closing_rounds);
            for round in (0..=rounds).filter(|_| !mass_spring && !colliders.is_empty()) {
                if let Some((_, projection)) = exact.as_mut().filter(|_| rounds > 0) {
                    projection.remember(x);
                }
                let pushed = collider_pass.project(
                    &mut self.contacts,
                    &mut self.vertex_contacts,
                    &mut self.edge_contacts,
                    (x, x_prev, v, w),
                    ContactPass::Closing,
                );
                t.contacts += laps.lap();
                let Some((exact, projection)) = exact
                    .as_mut()
                    .filter(|(e, _)| round < rounds && pushed > e.closing_tolerance)
                else {
                    break;
                };
                projection.project_after_push(x, w, exact.newton_steps, exact.cg_iterations);
                t.constraints += laps.lap();
            }

            // 3. Velocities. XPBD and PBD: v = (x - x_prev) / h + h/2 a, computed as
            //    v + h a + (x - x_pred) / h with the prediction x_pred recomputed bit for bit,
            //    so that an unconstrained particle's velocity carries no rounding from the
            //    difference of two nearly equal positions (in f32 that difference loses
            //    millimetres per second of fall).
            if hybrid {
                // v = (x - x_prev) / h, computed as v + (x - x_pred) / h with the prediction
                // recomputed bit for bit, as for XPBD below.
                for i in 0..x.len() {
                    if w[i] > 0.0 {
                        let predicted = x_prev[i] + v[i] * h;
                        v[i] += (x[i] - predicted) * inv_h;
                    } else {
                        v[i] = (x[i] - x_prev[i]) * inv_h;
                    }
                }
            } else if !mass_spring {
                let h_a = a * h;
                let middle = halves.as_deref().map(Halves::middle);
                per_half(join, middle, x, x_prev, v, w, |p| {
                    for (((x, x_prev), v), &w) in
                        p.x.iter().zip(&*p.x_prev).zip(p.v.iter_mut()).zip(p.w)
                    {
                        if w > 0.0 {
                            let predicted = *x_prev + (*v * h + half_h2_a);
                            *v += h_a + (*x - predicted) * inv_h;
                        } else {
                            *v = (*x - *x_prev) * inv_h;
                        }
                    }
                });
            }

            t.predict += laps.lap();

            // 4. Contacts: restitution (and mass-spring's friction) relative to each collider's
            //    surface, then damping.
            if !colliders.is_empty() {
                self.contacts.respond(
                    colliders,
                    x,
                    x_prev,
                    v,
                    h,
                    contact_push,
                    bounce_threshold,
                    friction_step.is_some(),
                );
                t.contacts += laps.lap();
            }
            let middle = halves.as_deref().map(Halves::middle);
            damp(
                settings,
                damping_k,
                x,
                v,
                w,
                &self.free_masses,
                join,
                middle,
                &self.parts,
            );
            t.predict += laps.lap();
            if let Some(coupling) = coupling.as_deref_mut() {
                coupling.end_substep(h);
            }
        }
        self.timings.add(&t);
    }
}

/// What a pass over the colliders needs besides the particles, fixed over a step.
#[derive(Clone, Copy)]
struct ColliderPass<'a> {
    colliders: &'a [SolverCollider],
    /// The cloth's triangles, for the vertices of triangle-mesh colliders.
    triangles: &'a [[u32; 3]],
    /// The external acceleration's velocity change over the substep (see
    /// `ContactScratch::project`).
    h_a: Vec3A,
    /// The cloth's thickness, for the mesh vertices (the particle contacts keep their own).
    thickness: f32,
    /// Whether a mesh collider's vertex may touch the cloth this step.
    mesh_vertices: bool,
    /// Whether the cloth's edges are to be projected against the thin spheres and capsules
    /// (some may touch them this step; in the last iteration and the closing pass).
    edges: bool,
}

impl ColliderPass<'_> {
    /// Projects the particle contacts, then the mesh vertices against the cloth's triangles,
    /// then the cloth's edges against the thin spheres and capsules. Returns the farthest the
    /// particle and edge contacts pushed a particle, metres.
    fn project(
        &self,
        contacts: &mut ContactScratch,
        vertices: &mut MeshVertexContacts,
        edges: &mut EdgeContacts,
        (x, x_prev, v, w): (&mut [Vec3A], &[Vec3A], &[Vec3A], &[f32]),
        pass: ContactPass,
    ) -> f32 {
        let c = self.colliders;
        let mut pushed = contacts.project(c, x, x_prev, v, w, self.h_a, pass);
        let reach = |collider: &SolverCollider| match pass {
            ContactPass::Iteration { .. } => collider.margin + self.thickness,
            ContactPass::Closing => 0.0,
        };
        if self.mesh_vertices {
            // Half the reach in the closing pass (see `collide/vertex_contacts.rs`).
            let vertex_reach = |collider: &SolverCollider| match pass {
                ContactPass::Iteration { .. } => collider.margin + self.thickness,
                ContactPass::Closing => 0.5 * (collider.margin + self.thickness),
            };
            vertices.project(c, contacts, self.triangles, x, x_prev, w, vertex_reach);
        }
        if self.edges {
            pushed = pushed.max(edges.project(c, x, x_prev, w, reach));
        }
        pushed
    }
}
