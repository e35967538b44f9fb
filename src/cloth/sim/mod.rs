//! [`ClothSolver`]: one cloth's model, state, pins and solver scratch, and its fixed step. The
//! substep pipeline every solver method runs through is in `step.rs`, made of the passes in
//! `passes.rs`; what can be read off a cloth is in `diagnostics.rs`.

use bevy::math::{Vec3, Vec3A, Vec4};

use super::air::{GustField, WindField, air_accelerations};
use super::batch::PairBatches;
use super::constraints::Tether;
use super::fast_projection::FastProjection;
use super::isometric_bending::{IsometricPair, PreparedIsometric};
use super::mass_spring::SpringSet;
use super::model::{BendingPair, ClothModel, Edge, EdgeKind};
use super::ordering::{apply_order, colour_order};
use super::rest_paths::RestPaths;
use super::rims::{Rim, find_rims, find_rings};
use super::self_collision::SelfCollision;
use super::settings::{AdaptiveSubsteps, SolverMethod, SolverSettings};
use super::state::{ClothState, inverse_mass};
use super::stretch_limits::straight_line_limits;
use super::volume::VolumeConstraint;
use crate::collide::contact::{Contact, ContactScratch};
use crate::collide::edge_contacts::EdgeContacts;
use crate::collide::thin::ThinFeatureContacts;
use crate::collide::{FrameStep, SolverCollider};
use crate::error::{ClothError, ColliderError};

pub(crate) mod diagnostics;
mod halves;
pub(crate) mod parallel;
mod passes;
mod step;
mod timings;

use halves::Halves;
pub use parallel::{Join, OneThread, with_helper};
use passes::JacobiScratch;
use timings::Laps;
pub use timings::StepTimings;

/// How many nearest pinned particles each free particle is tethered to.
const TETHERS_PER_PARTICLE: usize = 4;

/// A pinned particle: inverse mass 0, moved along a straight line from `start` to `end` over
/// the next step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pin {
    /// The particle.
    pub particle: u32,
    /// Where it is at the start of the step.
    pub start: Vec3A,
    /// Where it is at the end of the step.
    pub end: Vec3A,
}

/// The springs of the mass-spring and hybrid methods, and their scratch memory, built the
/// first time one of those methods steps.
#[derive(Clone, Debug)]
struct SpringScratch {
    set: SpringSet,
    forces: Vec<Vec3A>,
    /// Multipliers of the hybrid method's structural constraints.
    lambdas: Vec<f32>,
}

/// One simulated cloth: its [`ClothModel`], its [`ClothState`], its pins and the solver's
/// scratch memory. [`ClothSolver::step`] advances it by one fixed step without allocating.
#[derive(Clone, Debug)]
pub struct ClothSolver {
    model: ClothModel,
    state: ClothState,
    pins: Vec<Pin>,
    tethers: Vec<Tether>,
    /// `tethers` in batches of four, each naming its pin by its place in `tether_pins`.
    tether_batches: PairBatches,
    /// The pins the tethers hold to...
    tether_pins: Vec<u32>,
    /// ...and their positions in the current substep (the tethers read them from here).
    tether_anchors: Vec<Vec3A>,
    /// The batched constraints split in two halves for two threads (`halves.rs`), made the
    /// first time a step gets a parallel [`Join`] (`None` inside if the cloth does not
    /// split), and made again when the tethers or the inverse masses change.
    halves: Option<Option<Halves>>,
    /// The long-range stretch limits along the straight lines of the rest shape
    /// (`stretch_limits.rs`), in batches of four.
    limit_batches: PairBatches,
    /// Multipliers of the order-free (Jacobi) edge projection, one per edge.
    edge_lambdas: Vec<f32>,
    /// The model's edges in batches of four, in their sorted order (the structural ones only
    /// while `shear_apart`).
    edge_batches: PairBatches,
    /// Multipliers of `edge_batches`, one lane per edge.
    edge_batch_lambdas: Vec<Vec4>,
    /// Whether the shear edges are left out of `edge_batches` and projected from
    /// `shear_batches` with their own compliance ([`SolverSettings::shear_compliance`]).
    shear_apart: bool,
    /// The model's shear edges in batches of four.
    shear_batches: PairBatches,
    /// Multipliers of `shear_batches`, one lane per edge.
    shear_batch_lambdas: Vec<Vec4>,
    isometric_pairs: Vec<IsometricPair>,
    /// The isometric pairs' factors for `weights_seen` and `bend_alpha_prepared`.
    isometric_prepared: PreparedIsometric,
    /// The inverse masses (bits) the batches' weights, `free_masses` and
    /// `isometric_prepared` were made from: they are made again when these change.
    weights_seen: Vec<u32>,
    /// The bending `alpha~` (bits) `isometric_prepared` was made for (NaN: not made).
    bend_alpha_prepared: u32,
    /// Per particle, its mass if it is free, 0 if pinned.
    free_masses: Vec<f32>,
    /// The bending pairs that are not flat at rest (dihedral even with isometric bending).
    curved_pairs: Vec<BendingPair>,
    /// The bending multipliers of the current substep: one per dihedral pair projected...
    dihedral_lambdas: Vec<f32>,
    /// ...and one per prepared isometric pair.
    isometric_lambdas: Vec<Vec3A>,
    springs: Option<SpringScratch>,
    last_substeps: u32,
    colliders: Vec<SolverCollider>,
    contacts: ContactScratch,
    thin_contacts: ThinFeatureContacts,
    /// The cloth's edges against thin spheres and capsules.
    edge_contacts: EdgeContacts,
    /// The particle being dragged, moved like a pin.
    drag: Option<Pin>,
    /// Built the first time a step asks for a volume constraint (or its error).
    volume: Option<Result<VolumeConstraint, ClothError>>,
    /// The rims of the cloth's holes and the rings next to them, their lengths limited
    /// (`rims.rs`).
    rims: Vec<Rim>,
    /// Distances along the cloth at rest, built the first time tethers are made.
    rest_paths: Option<RestPaths>,
    /// The fast projection of the structural edges, built the first time a step asks for it
    /// ([`SolverSettings::exact_edges`]).
    fast_projection: Option<FastProjection>,
    /// Built the first time a step asks for self-collision.
    self_collision: Option<SelfCollision>,
    self_contacts: usize,
    /// The substep count [`SolverSettings::adaptive`] chose for the next step (0: not yet).
    adaptive_substeps: u32,
    /// Steps in a row below the adaptive budget's lower bound.
    adaptive_calm: u32,
    /// The state before an adaptive step, to undo it.
    adaptive_backup: ClothState,
    /// The contacts before an adaptive step (friction's anchors move with the colliders'
    /// surfaces in every substep), to undo them with the state.
    adaptive_contacts_backup: ContactScratch,
    /// Buffers of the order-free edge projection (closed cloth).
    jacobi: JacobiScratch,
    /// The wind at each particle, from the last [`ClothSolver::set_wind`].
    particle_wind: Vec<Vec3A>,
    /// The air's acceleration of each particle over the current step.
    air_acceleration: Vec<Vec3A>,
    /// Wall time of the last step's parts.
    timings: StepTimings,
    /// The carried share of the followed frame's motion over the coming step
    /// ([`ClothSolver::follow_frame`]): the state's velocities are relative to it, so the
    /// wind is too.
    carried: Option<(FrameStep, f32)>,
    /// The wind relative to the carried motion, per particle (scratch).
    relative_wind: Vec<Vec3A>,
}

impl ClothSolver {
    /// A cloth at rest in its model's rest shape, with no pins.
    pub fn new(mut model: ClothModel) -> Self {
        let state = ClothState::at_rest(&model);
        let n = model.particle_count();
        // Lines run along structural edges only: a woven cloth stretches along its bias
        // (the grid diagonals), so limiting the diagonals would hold it too tight. Measured on
        // S1 at N = 64, 8 x 2: 6.2 ms and 0.98% max strain, against 7.3 ms and 0.96% with
        // diagonal lines too.
        let structural: Vec<_> = model
            .edges
            .iter()
            .copied()
            .filter(|e| e.kind == EdgeKind::Structural)
            .collect();
        let stretch_limits = straight_line_limits(&model.rest_positions, &structural);
        let mut rims = find_rims(&model.rest_positions, &model.triangles);
        let pairs: Vec<[u32; 2]> = structural.iter().map(|e| e.particles).collect();
        let rings = find_rings(&model.rest_positions, &pairs, &rims);
        rims.extend(rings);
        let limit_batches = PairBatches::new(
            stretch_limits.iter().map(|l| (l.particles, l.length)),
            n,
            true,
        );
        let shear_batches = edge_batches(&model.edges, n, |kind| kind == EdgeKind::Shear);
        let edge_batches = edge_batches(&model.edges, n, |_| true);
        // Edges and limits keep their sorted order, batched four at a time with each constraint
        // a few places from where it was ([`PairBatches`]): a lexicographic Gauss-Seidel sweep
        // carries a correction across the whole sheet in its direction, which a colour order
        // does not (measured on S1 at N = 64, 8 x 2, before the limits overlapped: max strain
        // 1.35% sorted, 1.7% with coloured edges, 2.3% with coloured edges and limits, for a
        // 13% shorter frame).
        // Bending pairs are soft and gain from overlapping more than from the sweep order (see
        // [`super::ordering`]).
        let pair_particles: Vec<[u32; 4]> =
            model.bending_pairs.iter().map(|p| p.particles).collect();
        apply_order(&mut model.bending_pairs, &colour_order(&pair_particles, n));
        let mut isometric_pairs = Vec::new();
        let mut curved_pairs = Vec::new();
        for pair in &model.bending_pairs {
            let rest = pair.particles.map(|i| model.rest_positions[i as usize]);
            match IsometricPair::new(pair.particles, rest) {
                Some(iso) => isometric_pairs.push(iso),
                None => curved_pairs.push(*pair),
            }
        }
        let edge_contacts = EdgeContacts::new(
            model.edges.iter().map(|e| e.particles).collect(),
            model
                .edges
                .iter()
                .map(|e| e.rest_length)
                .fold(0.0f32, f32::max),
        );
        Self {
            limit_batches,
            edge_lambdas: vec![0.0; model.edges.len()],
            edge_batch_lambdas: vec![Vec4::ZERO; edge_batches.len()],
            edge_batches,
            shear_apart: false,
            shear_batch_lambdas: vec![Vec4::ZERO; shear_batches.len()],
            shear_batches,
            tether_batches: PairBatches::default(),
            tether_pins: Vec::new(),
            tether_anchors: Vec::new(),
            halves: None,
            isometric_prepared: PreparedIsometric::default(),
            dihedral_lambdas: Vec::with_capacity(model.bending_pairs.len()),
            isometric_lambdas: Vec::with_capacity(model.bending_pairs.len()),
            weights_seen: Vec::new(),
            bend_alpha_prepared: f32::NAN.to_bits(),
            free_masses: Vec::new(),
            isometric_pairs,
            curved_pairs,
            model,
            state,
            pins: Vec::new(),
            tethers: Vec::new(),
            springs: None,
            last_substeps: 0,
            colliders: Vec::new(),
            contacts: ContactScratch::default(),
            thin_contacts: ThinFeatureContacts::default(),
            edge_contacts,
            drag: None,
            volume: None,
            rest_paths: None,
            fast_projection: None,
            rims,
            self_collision: None,
            self_contacts: 0,
            adaptive_substeps: 0,
            adaptive_calm: 0,
            adaptive_backup: ClothState::default(),
            adaptive_contacts_backup: ContactScratch::default(),
            jacobi: JacobiScratch::default(),
            particle_wind: vec![Vec3A::ZERO; n],
            air_acceleration: vec![Vec3A::ZERO; n],
            timings: StepTimings::default(),
            carried: None,
            relative_wind: vec![Vec3A::ZERO; n],
        }
    }

    /// Where the last step spent its time ([`StepTimings`]).
    pub fn last_timings(&self) -> &StepTimings {
        &self.timings
    }

    /// Samples `wind` at time `t` (seconds) at every particle for the coming steps (the air
    /// of [`SolverSettings::air`] moves with it). Until it is called the air is still. Gusts
    /// are taken as a linear field over the cloth (see `cloth/air.rs`).
    pub fn set_wind(&mut self, wind: &WindField, t: f32) {
        let x = &self.state.positions;
        let base = Vec3A::from(wind.velocity);
        let base = if base.is_finite() { base } else { Vec3A::ZERO };
        let gusts = GustField::over(&wind.gusts, x, t);
        if gusts.is_none() && wind.sources.is_empty() {
            self.particle_wind.fill(base);
            return;
        }
        for (sample, &p) in self.particle_wind.iter_mut().zip(x) {
            let mut v = base;
            if let Some(gusts) = &gusts {
                v += gusts.at(p);
            }
            for source in &wind.sources {
                v += Vec3A::from(source.velocity_at(p.into()));
            }
            *sample = if v.is_finite() { v } else { Vec3A::ZERO };
        }
    }

    /// Grabs `particle`: from now on it is held like a pin (inverse mass 0) and moved to
    /// [`ClothSolver::drag_to`]'s goal over each step, until [`ClothSolver::release`]. Grabbing
    /// another particle releases the first. Returns `false` if the particle does not exist.
    pub fn grab(&mut self, particle: u32) -> bool {
        let Some(&p) = self.state.positions.get(particle as usize) else {
            return false;
        };
        self.release();
        self.drag = Some(Pin {
            particle,
            start: p,
            end: p,
        });
        self.refresh_masses();
        // The grabbed particle is held like a pin: tether the cloth to it too, so a hard yank
        // pulls the whole cloth along instead of stretching the edges next to it.
        self.rebuild_tethers();
        true
    }

    /// Sets where the grabbed particle must be at the end of the next step (ignored if
    /// nothing is grabbed or the goal is not finite). The goal is kept within the particle's
    /// rest distance of every pin, so a drag cannot tear a pinned cloth apart.
    pub fn drag_to(&mut self, goal: Vec3) {
        let Some(drag) = self.drag else {
            return;
        };
        if !goal.is_finite() {
            return;
        }
        let rest = &self.model.rest_positions;
        let mut goal = Vec3A::from(goal);
        // Alternating projections onto the spheres around the pins.
        for _ in 0..8 {
            for pin in &self.pins {
                let reach = rest[drag.particle as usize].distance(rest[pin.particle as usize]);
                let d = goal - pin.end;
                let len = d.length();
                if len > reach && len > 0.0 {
                    goal = pin.end + d * (reach / len);
                }
            }
        }
        if let Some(drag) = &mut self.drag {
            drag.end = goal;
        }
    }

    /// The grabbed particle, if any.
    pub fn grabbed(&self) -> Option<u32> {
        self.drag.map(|d| d.particle)
    }

    /// Lets go of the grabbed particle; it gets its mass back (unless it is pinned).
    pub fn release(&mut self) {
        if self.drag.take().is_some() {
            self.refresh_masses();
            self.rebuild_tethers();
        }
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

    /// The springs of the mass-spring and hybrid methods, built now if they are not yet
    /// (feature `internals`).
    #[cfg(feature = "internals")]
    pub fn springs_mut(&mut self) -> &mut SpringSet {
        &mut self.spring_scratch().set
    }

    fn spring_scratch(&mut self) -> &mut SpringScratch {
        let model = &self.model;
        self.springs.get_or_insert_with(|| {
            let set = SpringSet::new(model);
            SpringScratch {
                forces: vec![Vec3A::ZERO; model.particle_count()],
                lambdas: vec![0.0; set.structural_edges.len()],
                set,
            }
        })
    }

    /// The substeps the last [`ClothSolver::step`] took (more than `settings.substeps` with
    /// automatic substeps; with [`SolverSettings::adaptive`], every substep run, those of an
    /// undone attempt included).
    pub fn last_substeps(&self) -> u32 {
        self.last_substeps
    }

    /// The model.
    pub fn model(&self) -> &ClothModel {
        &self.model
    }

    /// The state.
    pub fn state(&self) -> &ClothState {
        &self.state
    }

    /// The state, for setting positions or velocities directly. Inverse masses are managed by
    /// the sim (pins, density): change them through [`ClothSolver::set_pins`] and
    /// [`ClothSolver::set_density`]. The contacts of the last step and the points static
    /// friction held particles at are forgotten.
    pub fn state_mut(&mut self) -> &mut ClothState {
        self.contacts.forget();
        &mut self.state
    }

    /// The pins.
    pub fn pins(&self) -> &[Pin] {
        &self.pins
    }

    /// The long-range attachments currently built (feature `internals`).
    #[cfg(feature = "internals")]
    pub fn tethers(&self) -> &[Tether] {
        &self.tethers
    }

    /// Pins `particles` where they are now (replacing any earlier pins) and rebuilds the
    /// long-range attachments.
    pub fn set_pins(&mut self, particles: &[u32]) -> Result<(), ClothError> {
        let n = self.model.particle_count();
        if let Some(&vertex) = particles.iter().find(|&&p| p as usize >= n) {
            return Err(ClothError::VertexOutOfRange {
                vertex,
                vertex_count: n,
            });
        }
        let mut sorted = particles.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        self.pins = sorted
            .iter()
            .map(|&particle| {
                let p = self.state.positions[particle as usize];
                Pin {
                    particle,
                    start: p,
                    end: p,
                }
            })
            .collect();
        self.refresh_masses();
        self.rebuild_tethers();
        Ok(())
    }

    /// Sets where pinned particle `particle` must be at the end of the next step; it moves
    /// there along a straight line over the substeps. Returns `false` if it is not pinned or
    /// the target is not finite.
    pub fn set_pin_target(&mut self, particle: u32, target: Vec3) -> bool {
        if !target.is_finite() {
            return false;
        }
        match self.pins.binary_search_by_key(&particle, |p| p.particle) {
            Ok(k) => {
                self.pins[k].end = target.into();
                true
            }
            Err(_) => false,
        }
    }

    /// Changes the areal density; masses and inverse masses follow.
    pub fn set_density(&mut self, density: f32) -> Result<(), ClothError> {
        self.model.set_density(density)?;
        self.refresh_masses();
        Ok(())
    }

    /// Puts the cloth back in its rest shape, at rest, pins at their rest positions, nothing
    /// grabbed.
    pub fn reset(&mut self) {
        self.state = ClothState::at_rest(&self.model);
        self.contacts.forget();
        self.adaptive_substeps = 0;
        self.adaptive_calm = 0;
        if self.drag.take().is_some() {
            self.rebuild_tethers();
        }
        for pin in &mut self.pins {
            let p = self.state.positions[pin.particle as usize];
            pin.start = p;
            pin.end = p;
        }
        self.refresh_masses();
    }

    /// Recomputes inverse masses from the model: `1 / mass`, or 0 for pinned and massless
    /// particles.
    fn refresh_masses(&mut self) {
        for (i, w) in self.state.inverse_masses.iter_mut().enumerate() {
            *w = inverse_mass(self.model.mass(i));
        }
        for pin in self.pins.iter().chain(self.drag.as_ref()) {
            self.state.inverse_masses[pin.particle as usize] = 0.0;
        }
    }

    /// Tethers every free particle to its nearest pinned particles along the cloth (at most
    /// `TETHERS_PER_PARTICLE`), each as long as the distance along the cloth in its rest
    /// shape (`cloth/rest_paths.rs`): the straight distance on a flat piece where the
    /// straight line stays on the cloth, the shortest path over the edges elsewhere, so a
    /// tether never holds the cloth tighter than its edges would.
    fn rebuild_tethers(&mut self) {
        self.tethers.clear();
        self.tether_pins.clear();
        self.tether_anchors.clear();
        self.tether_batches = PairBatches::default();
        self.halves = None;
        if self.pins.is_empty() && self.drag.is_none() {
            return;
        }
        let rest = &self.model.rest_positions;
        let paths = self
            .rest_paths
            .get_or_insert_with(|| RestPaths::new(&self.model));
        let anchors: Vec<u32> = self
            .pins
            .iter()
            .chain(self.drag.as_ref())
            .map(|pin| pin.particle)
            .collect();
        let mut along = Vec::new();
        let mut lengths: Vec<Vec<f32>> = Vec::with_capacity(anchors.len());
        for &anchor in &anchors {
            paths.from(rest, anchor, &mut along);
            lengths.push(along.clone());
        }
        // (length, the pin's place in `anchors`).
        let mut nearest: Vec<(f32, u32)> = Vec::with_capacity(anchors.len());
        let mut slots = Vec::new();
        for (i, &w) in self.state.inverse_masses.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            nearest.clear();
            nearest.extend(
                lengths
                    .iter()
                    .enumerate()
                    .map(|(slot, l)| (l[i], slot as u32))
                    .filter(|(l, _)| l.is_finite()),
            );
            let k = TETHERS_PER_PARTICLE.min(nearest.len());
            if k == 0 {
                continue;
            }
            if nearest.len() > k {
                nearest.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
            }
            for &(length, slot) in &nearest[..k] {
                slots.push(slot);
                self.tethers.push(Tether {
                    particle: i as u32,
                    anchor: anchors[slot as usize],
                    length,
                });
            }
        }
        // Grouped by pin: consecutive tethers of different particles do not wait for each
        // other.
        let mut order: Vec<usize> = (0..self.tethers.len()).collect();
        order.sort_by_key(|&k| slots[k]);
        self.tethers = order.iter().map(|&k| self.tethers[k]).collect();
        self.tether_batches = PairBatches::new(
            self.tethers
                .iter()
                .zip(order.iter().map(|&k| slots[k]))
                .map(|(t, slot)| ([t.particle, slot], t.length)),
            self.state.positions.len(),
            false,
        );
        self.tether_anchors = vec![Vec3A::ZERO; anchors.len()];
        self.tether_pins = anchors;
        self.tether_batches.set_weights(&self.state.inverse_masses);
    }

    /// Advances the cloth by `dt` seconds under the constant acceleration `acceleration`
    /// (gravity plus any external acceleration) with `settings.method`, in
    /// `settings.substeps` substeps (more with `settings.auto_substeps` for the spring
    /// methods; as many as [`SolverSettings::adaptive`] needs if set), each of them through
    /// one pipeline (`sim/step.rs`): predict, project `settings.iterations` times (long-range
    /// constraints, edges, volume, bending, self-collision, colliders: each method projects
    /// its share of them), velocities, contact response, damping.
    ///
    /// For XPBD and PBD, prediction and velocities are symplectic Euler on the half-step
    /// velocity `(x - x_prev) / h`, started consistently (velocity Verlet), so a free particle
    /// follows `x0 + v0 t + a t^2 / 2` exactly, whatever the step; mass-spring and the hybrid
    /// integrate the spring forces with symplectic Euler.
    ///
    /// Bad input is refused, not stepped, so that nothing non-finite reaches the state: settings
    /// out of range ([`SolverSettings::validate`]), a non-finite acceleration, or a negative or
    /// non-finite `dt` return the error and leave the cloth as it was; `dt = 0` does nothing.
    ///
    /// One thread; [`ClothSolver::step_with`] splits a large cloth over two.
    pub fn step(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
    ) -> Result<(), ClothError> {
        self.step_with(settings, acceleration, dt, &OneThread)
    }

    /// [`ClothSolver::step`], with the sweeps of XPBD and PBD (edges, stretch limits, tethers,
    /// isometric bending) run in two halves at once through `join` when it is parallel
    /// ([`with_helper`]) and the cloth splits (`sim/halves.rs`: at least 2048 particles,
    /// numbered so that its middle index cuts it along a short seam, as a grid's rows are).
    /// The result is the same on every run and whichever thread runs which half, and
    /// differs from one thread's by the order of the sweep (the seam's constraints after the
    /// halves).
    pub fn step_with(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
        join: &dyn Join,
    ) -> Result<(), ClothError> {
        self.step_coupled(settings, acceleration, dt, join, None)
    }

    /// [`ClothSolver::step_with`], with `coupling` stepped inside the cloth's substeps (see
    /// [`SubstepCoupling`]); with a coupling the substep count is fixed
    /// ([`SolverSettings::adaptive`] would redo steps the coupling has taken).
    pub(crate) fn step_coupled(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
        join: &dyn Join,
        coupling: Option<&mut dyn SubstepCoupling>,
    ) -> Result<(), ClothError> {
        settings.validate()?;
        if let Some(&value) = acceleration.to_array().iter().find(|a| !a.is_finite()) {
            return Err(ClothError::InvalidSetting {
                name: "acceleration",
                value,
                reason: "finite",
            });
        }
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(ClothError::InvalidSetting {
                name: "dt",
                value: dt,
                reason: "finite and >= 0",
            });
        }
        if dt == 0.0 {
            return Ok(());
        }
        if settings.volume.is_some() && self.volume.is_none() {
            self.volume = Some(VolumeConstraint::new(&self.model));
        }
        self.sync_weights();
        self.sync_shear(settings);
        let carried = self.carried.take();
        self.timings = StepTimings::default();
        let mut laps = Laps::start();
        if let Some(air) = settings.air.filter(|air| air.is_active()) {
            let state = &self.state;
            // Velocities are relative to the carried share of the followed frame's motion:
            // so must the wind be.
            let wind = match carried {
                Some((frame, s)) => {
                    for ((relative, &wind), &p) in self
                        .relative_wind
                        .iter_mut()
                        .zip(&self.particle_wind)
                        .zip(&state.positions)
                    {
                        *relative = wind - frame.velocity_at(p) * s;
                    }
                    &self.relative_wind
                }
                None => &self.particle_wind,
            };
            air_accelerations(
                &air,
                &self.model.triangles,
                &state.positions,
                &state.velocities,
                &state.inverse_masses,
                wind,
                self.model.density,
                dt,
                &mut self.air_acceleration,
            );
            self.timings.air = laps.lap();
        }
        self.self_contacts = 0;
        if settings.self_collision {
            self.find_self_contacts(acceleration, dt);
            self.timings.self_collision = laps.lap();
        }
        match settings
            .adaptive
            .filter(|_| settings.method != SolverMethod::MassSpring && coupling.is_none())
        {
            Some(budget) => self.step_adaptive(settings, &budget, acceleration, dt, join),
            None => self.step_substeps(settings, acceleration, dt, join, coupling),
        }
        for pin in self.pins.iter_mut().chain(self.drag.as_mut()) {
            pin.start = pin.end;
        }
        Ok(())
    }

    /// Whether [`ClothSolver::step_with`] splits this cloth over two threads with `settings`:
    /// XPBD or PBD without a volume constraint or a soft shear
    /// ([`SolverSettings::shear_compliance`]), at least 2048 particles numbered so that the
    /// middle index cuts the cloth along a short seam (at most a tenth of its constraints
    /// across it). Makes the split the first time it is asked (and again after the pins or
    /// the masses change).
    pub fn splits_in_two(&mut self, settings: &SolverSettings) -> bool {
        let method = matches!(
            settings.method,
            SolverMethod::Xpbd | SolverMethod::Pbd { .. }
        );
        if !method || settings.volume.is_some() || settings.projects_shear_apart() {
            return false;
        }
        let halves = self.halves.get_or_insert_with(|| {
            Halves::new(
                &self.state.inverse_masses,
                &self.edge_batches,
                &self.limit_batches,
                &self.tether_batches,
                &self.tether_pins,
                &self.isometric_pairs,
            )
        });
        halves.is_some()
    }

    /// Copies the inverse masses into the batches if they changed since the last step (they
    /// do not change within a step), and marks the bending factors for remaking.
    fn sync_weights(&mut self) {
        let w = &self.state.inverse_masses;
        let seen = &mut self.weights_seen;
        if !seen.iter().copied().eq(w.iter().map(|m| m.to_bits())) {
            self.halves = None;
            self.edge_batches.set_weights(w);
            self.shear_batches.set_weights(w);
            self.limit_batches.set_weights(w);
            self.tether_batches.set_weights(w);
            seen.clear();
            seen.extend(w.iter().map(|m| m.to_bits()));
            self.free_masses.clear();
            self.free_masses
                .extend(w.iter().map(|&w| if w > 0.0 { 1.0 / w } else { 0.0 }));
            self.bend_alpha_prepared = f32::NAN.to_bits();
        }
    }

    /// Batches the edges again if `settings` projects the shear edges apart and the batches
    /// were made otherwise, or the other way round.
    fn sync_shear(&mut self, settings: &SolverSettings) {
        let apart = settings.projects_shear_apart();
        if apart != self.shear_apart {
            self.shear_apart = apart;
            let n = self.model.particle_count();
            self.edge_batches = edge_batches(&self.model.edges, n, |kind| {
                !apart || kind == EdgeKind::Structural
            });
            self.edge_batches.set_weights(&self.state.inverse_masses);
            self.edge_batch_lambdas = vec![Vec4::ZERO; self.edge_batches.len()];
            self.halves = None;
        }
    }

    /// One fixed step under [`SolverSettings::adaptive`]: the step runs at the chosen count;
    /// if it ends above the target strain it is undone (the state, and the contacts with
    /// friction's anchors, which every substep moves with the colliders' surfaces) and run
    /// again with more substeps (up to the maximum), so every step that can meet the target
    /// does. The count then goes down as [`AdaptiveSubsteps::next`] says.
    /// [`ClothSolver::last_substeps`] counts every substep run, undone ones included (the
    /// step's cost).
    fn step_adaptive(
        &mut self,
        settings: &SolverSettings,
        budget: &AdaptiveSubsteps,
        acceleration: Vec3,
        dt: f32,
        join: &dyn Join,
    ) {
        let (lo, hi) = (
            budget.min_substeps.max(1),
            budget.max_substeps.max(budget.min_substeps.max(1)),
        );
        let mut chosen = *settings;
        chosen.substeps = match self.adaptive_substeps {
            0 => settings.substeps,
            n => n,
        }
        .clamp(lo, hi);
        self.adaptive_backup.clone_from(&self.state);
        self.adaptive_contacts_backup.clone_from(&self.contacts);
        let mut run = 0;
        loop {
            self.step_substeps(&chosen, acceleration, dt, join, None);
            run += chosen.substeps;
            let strain = self.strain().max;
            let next = budget.next(chosen.substeps, strain, &mut self.adaptive_calm);
            if next > chosen.substeps && strain.is_finite() {
                // Over the target: undo the step and run it again with more.
                self.state.clone_from(&self.adaptive_backup);
                self.contacts.clone_from(&self.adaptive_contacts_backup);
                chosen.substeps = next;
                continue;
            }
            self.adaptive_substeps = next;
            break;
        }
        self.last_substeps = run;
    }

    /// Builds the volume constraint now (it is otherwise built by the first step with
    /// [`SolverSettings::volume`]) and returns the rest volume, or
    /// [`ClothError::OpenSurface`] if the cloth does not close.
    pub fn enable_volume(&mut self) -> Result<f32, ClothError> {
        let built = self
            .volume
            .get_or_insert_with(|| VolumeConstraint::new(&self.model));
        match built {
            Ok(c) => Ok(c.rest_volume()),
            Err(e) => Err(e.clone()),
        }
    }

    /// Why the volume constraint could not be built, once a step asked for it.
    pub fn volume_error(&self) -> Option<&ClothError> {
        self.volume.as_ref().and_then(|v| v.as_ref().err())
    }

    /// The enclosed volume now and at rest, m^3, once the volume constraint is built.
    pub fn volume(&self) -> Option<(f32, f32)> {
        match self.volume.as_ref() {
            Some(Ok(c)) => Some((c.volume(&self.state.positions), c.rest_volume())),
            _ => None,
        }
    }

    /// Finds the self-contact candidates of the coming step (building the tables the first
    /// time): pairs that may close in to the self-collision distance within `dt`.
    fn find_self_contacts(&mut self, acceleration: Vec3, dt: f32) {
        if self.self_collision.is_none() {
            self.self_collision = SelfCollision::new(&self.model, None);
        }
        let Some(sc) = self.self_collision.as_mut() else {
            return;
        };
        sc.find_pairs(
            &self.state.positions,
            &self.state.velocities,
            dt,
            acceleration.length(),
        );
    }

    /// How many pairs of particles were held apart by self-collision in the last step's last
    /// iteration (the most in any substep).
    pub fn self_contact_count(&self) -> usize {
        self.self_contacts
    }
}

/// The edges of a cloth of `n` particles whose kind `keep` accepts, in batches of four, in
/// their sorted order.
fn edge_batches(edges: &[Edge], n: usize, keep: impl Fn(EdgeKind) -> bool) -> PairBatches {
    PairBatches::new(
        edges
            .iter()
            .filter(|e| keep(e.kind))
            .map(|e| (e.particles, e.rest_length)),
        n,
        true,
    )
}

/// Something stepped inside a cloth's substeps, in the same iterations as the cloth's
/// constraints (a fluid, `fluid/cloth_coupling.rs`): it predicts when a substep begins,
/// projects its own constraints and its contacts with the cloth's particles in each
/// iteration (after the colliders, before the cloth's own constraints, which then carry its
/// pushes on), and updates its velocities when the substep ends, over the same `h`.
pub(crate) trait SubstepCoupling {
    /// A substep of length `h` begins; `x` are the cloth's predicted positions.
    fn begin_substep(&mut self, x: &[Vec3A], triangles: &[[u32; 3]], h: f32);
    /// One iteration: the cloth's positions `x` (at `x_prev` when the substep began) and
    /// inverse masses `w`, to be moved by the contacts.
    fn iterate(&mut self, x: &mut [Vec3A], x_prev: &[Vec3A], w: &[f32], triangles: &[[u32; 3]]);
    /// The substep ends.
    fn end_substep(&mut self, h: f32);
}
