//! [`ClothSolver`]: one cloth's model, state, pins and solver scratch, and its fixed step. The
//! substep pipeline every solver method runs through is in `step.rs`, made of the passes in
//! `passes.rs`; the adaptive step is in `adaptive.rs`; the pins, the dragged particle and the
//! tethers are in `pins.rs`; the colliders and the followed frame in `colliders.rs`; the wind
//! in `wind.rs`; the volume constraint in `volume.rs`; what can be read off a cloth is in
//! `diagnostics.rs`.

use bevy::math::{Vec3, Vec3A, Vec4};

use super::air::air_accelerations;
use super::batch::PairBatches;
use super::constraints::Tether;
use super::fast_projection::FastProjection;
use super::isometric_bending::{IsometricPair, PreparedIsometric};
use super::mass_spring::SpringSet;
use super::model::{BendingPair, ClothModel, Edge, EdgeKind};
use super::ordering::{apply_order, colour_order};
use super::rest_paths::RestPaths;
use super::rims::{Rim, find_rims, find_rings};
use super::settings::{SelfCollisionMethod, SolverMethod, SolverSettings};
use super::state::ClothState;
use super::stretch_limits::straight_line_limits;
use super::volume::VolumeConstraint;
use crate::collide::contact::ContactScratch;
use crate::collide::edge_contacts::EdgeContacts;
use crate::collide::vertex_contacts::MeshVertexContacts;
use crate::collide::{FrameStep, SolverCollider};
use crate::error::ClothError;

mod adaptive;
mod colliders;
pub(crate) mod diagnostics;
mod halves;
mod layers;
mod origin;
pub(crate) mod parallel;
mod passes;
mod pins;
mod self_contacts;
mod sleep;
mod step;
mod timings;
mod volume;
mod wind;

use halves::Halves;
pub use layers::LayerSolver;
pub use origin::ORIGIN_GRID;
pub use parallel::{Join, OneThread, with_helper};
use passes::JacobiScratch;
pub use sleep::SleepSettings;
pub(crate) use sleep::{CREEP, SleepClock, colliders_move_near, frame_moves};
use timings::Laps;
pub use timings::StepTimings;

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

/// The largest velocity change one [`ClothSolver::step`] takes from its acceleration,
/// `|acceleration| * dt`, m/s: 1e4 m/s, a thousand g for a whole second. A larger one (a
/// gravity of 1e30) is refused with a [`ClothError`].
pub const MAX_SPEED_CHANGE: f32 = 1.0e4;

/// The longest step [`ClothSolver::step`] takes, s; a longer one is refused with a
/// [`ClothError`].
pub const MAX_STEP: f32 = 10.0;

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
    vertex_contacts: MeshVertexContacts,
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
    /// Built the first time a step asks for self-collision, with the method it asks for.
    self_collision: Option<self_contacts::SelfContacts>,
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
    /// The exact edges' warm start before an adaptive step, to undo it with the state.
    adaptive_projection_backup: Vec<f32>,
    /// The colliders' start and end translations before the step moved them near the origin
    /// (`origin.rs`), put back as they were.
    unmoved_colliders: Vec<[Vec3A; 2]>,
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
    /// The cloths a [`LayerSolver`] solves together, each a range of particles (empty: one
    /// cloth); each is damped about its own rigid motion.
    parts: Vec<std::ops::Range<usize>>,
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
            vertex_contacts: MeshVertexContacts::default(),
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
            adaptive_projection_backup: Vec::new(),
            unmoved_colliders: Vec::new(),
            jacobi: JacobiScratch::default(),
            particle_wind: vec![Vec3A::ZERO; n],
            air_acceleration: vec![Vec3A::ZERO; n],
            timings: StepTimings::default(),
            carried: None,
            relative_wind: vec![Vec3A::ZERO; n],
            parts: Vec::new(),
        }
    }

    /// Where the last step spent its time ([`StepTimings`]).
    pub fn last_timings(&self) -> &StepTimings {
        &self.timings
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
        if let Some(projection) = self.fast_projection.as_mut() {
            projection.forget_warm_start();
        }
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
    /// out of range ([`SolverSettings::validate`]), a non-finite acceleration, a negative or
    /// non-finite `dt`, or finite ones too large to step ([`MAX_SPEED_CHANGE`], [`MAX_STEP`])
    /// return the error and leave the cloth as it was; `dt = 0` does nothing.
    ///
    /// A cloth far from the world's origin is stepped near it, moved by a multiple of
    /// [`ORIGIN_GRID`] and back, so that it rests as still 200 m out as at the origin.
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
        // A finite but extreme acceleration or step (gravity 1e30) would overflow the
        // positions' squares within the step: refused like a non-finite one.
        let speed_change = acceleration.length() * dt;
        if speed_change.is_nan() || speed_change > MAX_SPEED_CHANGE {
            return Err(ClothError::InvalidSetting {
                name: "acceleration * dt",
                value: speed_change,
                reason: "at most MAX_SPEED_CHANGE (1e4 m/s in one step)",
            });
        }
        if dt > MAX_STEP {
            return Err(ClothError::InvalidSetting {
                name: "dt",
                value: dt,
                reason: "at most MAX_STEP (10 s)",
            });
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
        if settings.self_collision != SelfCollisionMethod::Off {
            self.find_self_contacts(settings, acceleration, dt);
            self.timings.self_collision = laps.lap();
        }
        // Far from the world's origin, stepped near it (`origin.rs`); a coupling's own
        // particles are in world coordinates, so a coupled cloth is stepped where it is.
        let origin = match coupling {
            None => self.step_origin(),
            Some(_) => Vec3A::ZERO,
        };
        self.move_to_origin(origin);
        match settings
            .adaptive
            .filter(|_| settings.method != SolverMethod::MassSpring && coupling.is_none())
        {
            Some(budget) => self.step_adaptive(settings, &budget, acceleration, dt, join),
            None => self.step_substeps(settings, acceleration, dt, join, coupling),
        }
        self.move_back_from(origin);
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
