//! [`ClothSim`]: one cloth's model, state, pins and solver scratch, and the XPBD step.

use bevy::math::{Vec3, Vec3A, Vec4};

use super::batch::PairBatches;
use super::constraints::{
    Plane, Projection, Tether, project_bending, project_distance, project_mutual_tether,
    project_plane,
};
use super::damping::{RigidMotion, damp_plain, damp_rigid_masses};
use super::isometric_bending::{IsometricPair, PreparedIsometric};
use super::mass_spring::{SpringSet, auto_substeps};
use super::model::{BendingPair, ClothModel, Edge, EdgeKind};
use super::ordering::{apply_order, colour_order};
use super::self_collision::SelfCollision;
use super::settings::{
    AdaptiveSubsteps, DampingMode, DivergenceBounds, SolverMethod, SolverSettings,
};
use super::state::{ClothState, inverse_mass};
use super::stretch_limits::{StretchLimit, straight_line_limits};
use super::volume::VolumeConstraint;
use crate::collide::{Collider, Contact, ContactScratch, FrameStep};
use crate::error::ClothError;

/// Edges and stretch limits are swept as this many interleaved streams, each a contiguous
/// part of the sorted list: consecutive projections then touch distant particles and overlap
/// in the processor, while each stream keeps its lexicographic order (see `ClothSim::new`).
/// Measured on S1 at N = 64, 8 x 4, before the limits overlapped: 1 stream 15.6 ms per frame
/// and 0.89% max strain, 2 streams 12.9 ms and 0.92%, 4 streams 12.5 ms and 1.35%.
const STREAMS: usize = 2;

/// Calls `f` on the indices of [`STREAMS`] interleaved contiguous streams over `0..len`:
/// `0, c, 2c, .., 1, c + 1, ..` with `c = len / STREAMS` rounded up. The last stream may run
/// past `len`; `f` skips those indices. (Plain loops: an iterator chain here cost 12% of the
/// frame.)
#[inline(always)]
fn for_each_interleaved(len: usize, mut f: impl FnMut(usize)) {
    let chunk = len.div_ceil(STREAMS);
    for i in 0..chunk {
        for stream in 0..STREAMS {
            f(i + stream * chunk);
        }
    }
}

/// Projects the distance constraints of `edges` (interleaved), with their multipliers.
#[inline(always)]
fn project_edges(
    edges: &[Edge],
    lambdas: &mut [f32],
    x: &mut [Vec3A],
    w: &[f32],
    stretch: Projection,
) {
    for_each_interleaved(edges.len(), |k| {
        if let (Some(e), Some(lambda)) = (edges.get(k), lambdas.get_mut(k)) {
            project_distance(x, w, e.particles, e.rest_length, stretch, lambda);
        }
    });
}

/// The relaxation of the order-free edge projection: each particle moves by this over its
/// edge count times the sum of its edges' corrections (Macklin et al. 2014, section 4.2).
const JACOBI_RELAXATION: f32 = 1.5;

/// Buffers of the order-free (Jacobi) edge projection a closed cloth uses.
///
/// A Gauss-Seidel sweep leaves its residual biased along the sweep order. On an open cloth
/// that is harmless, but a pressurised closed cloth keeps its skin far from rest every
/// substep, and friction turned the biased tangential motion of its contact patch into a push
/// on the whole body: measured, a balloon at twice its rest volume on ground with friction 0.6
/// crept 26 m in 3 s with the sorted sweep, 8 m with the sweep reversed on every other
/// iteration, and 4 mm with this projection.
#[derive(Clone, Debug, Default)]
struct JacobiScratch {
    start: Vec<Vec3A>,
    delta: Vec<Vec3A>,
    /// Per particle: `JACOBI_RELAXATION / (edges at the particle)`.
    share: Vec<f32>,
    /// The edge count the shares were computed for.
    edges: usize,
}

impl JacobiScratch {
    /// Sizes the buffers for `edges` over `particles` particles (allocates only when they
    /// change).
    fn prepare(&mut self, edges: &[Edge], particles: usize) {
        if self.share.len() == particles && self.edges == edges.len() {
            return;
        }
        let mut count = vec![0u32; particles];
        for e in edges {
            for p in e.particles {
                if let Some(c) = count.get_mut(p as usize) {
                    *c += 1;
                }
            }
        }
        self.share = count
            .iter()
            .map(|&c| {
                if c > 0 {
                    JACOBI_RELAXATION / c as f32
                } else {
                    0.0
                }
            })
            .collect();
        self.start = vec![Vec3A::ZERO; particles];
        self.delta = vec![Vec3A::ZERO; particles];
        self.edges = edges.len();
    }
}

/// Projects the distance constraints of `edges` all from the same positions (Jacobi) and
/// moves every particle by its share of the sum of their corrections, so that no order is
/// favoured (see [`JacobiScratch`]).
fn project_edges_jacobi(
    edges: &[Edge],
    lambdas: &mut [f32],
    x: &mut [Vec3A],
    w: &[f32],
    stretch: Projection,
    scratch: &mut JacobiScratch,
) {
    scratch.prepare(edges, x.len());
    scratch.start.copy_from_slice(x);
    scratch.delta.fill(Vec3A::ZERO);
    for (e, lambda) in edges.iter().zip(lambdas.iter_mut()) {
        let [a, b] = e.particles.map(|i| i as usize);
        let (Some(&wa), Some(&wb)) = (w.get(a), w.get(b)) else {
            continue;
        };
        let mut pair = [scratch.start[a], scratch.start[b]];
        project_distance(&mut pair, &[wa, wb], [0, 1], e.rest_length, stretch, lambda);
        scratch.delta[a] += pair[0] - scratch.start[a];
        scratch.delta[b] += pair[1] - scratch.start[b];
    }
    for ((xi, d), &share) in x.iter_mut().zip(&scratch.delta).zip(&scratch.share) {
        *xi += *d * share;
    }
}

/// Projects every free particle out of every plane, adding how far it was pushed to `push`.
#[inline(always)]
fn project_planes(planes: &[Plane], x: &mut [Vec3A], w: &[f32], thickness: f32, push: &mut [f32]) {
    for plane in planes {
        for i in 0..x.len() {
            if w[i] > 0.0 {
                push[i] += project_plane(&mut x[i], plane, thickness);
            }
        }
    }
}

/// Contact velocities for the particles pushed by a plane this substep (`push > 0`, the
/// distance pushed): the approaching normal velocity is removed and the tangential velocity
/// reduced by Coulomb friction, by at most `mu` times the normal velocity change `push / h`.
fn contact_velocities(
    planes: &[Plane],
    x: &[Vec3A],
    v: &mut [Vec3A],
    push: &[f32],
    settings: &SolverSettings,
    inv_h: f32,
) {
    for plane in planes {
        for i in 0..x.len() {
            if push[i] > 0.0 && plane.normal.dot(x[i]) <= plane.offset + settings.thickness * 1.001
            {
                let vn = plane.normal * plane.normal.dot(v[i]).max(0.0);
                let vt = v[i] - vn;
                let speed = vt.length();
                let max_change = settings.friction * push[i] * inv_h;
                v[i] = vn
                    + if speed <= max_change {
                        Vec3A::ZERO
                    } else {
                        vt * (1.0 - max_change / speed)
                    };
            }
        }
    }
}

/// Damps the velocities by the fraction `k` as [`SolverSettings::damping_mode`] says.
/// `masses` are the free particles' masses (0 for pinned ones), `w` the inverse masses.
fn damp(
    settings: &SolverSettings,
    k: f32,
    x: &[Vec3A],
    v: &mut [Vec3A],
    w: &[f32],
    masses: &[f32],
) {
    if k > 0.0 {
        match settings.damping_mode {
            DampingMode::Plain => damp_plain(v, w, k),
            DampingMode::Rigid => damp_rigid_masses(x, v, masses, k),
        }
    }
}

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

/// Strain statistics over the structural edges.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StrainStats {
    /// Largest `|len - rest| / rest`.
    pub max: f32,
    /// Mean `|len - rest| / rest`.
    pub mean: f32,
}

/// Why a cloth counts as diverged (see [`ClothSim::divergence`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Divergence {
    /// A position or velocity is NaN or infinite.
    NonFinite,
    /// A structural edge is strained past [`DivergenceBounds::max_strain`].
    Strain {
        /// The largest strain.
        strain: f32,
    },
    /// A particle moves faster than [`DivergenceBounds::max_speed`], m/s.
    Speed {
        /// The largest speed, m/s.
        speed: f32,
    },
}

impl std::fmt::Display for Divergence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Divergence::NonFinite => write!(f, "a position or velocity is not finite"),
            Divergence::Strain { strain } => write!(f, "max strain {:.0}%", strain * 100.0),
            Divergence::Speed { speed } => write!(f, "a particle moves at {speed:.0} m/s"),
        }
    }
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
/// scratch memory. [`ClothSim::step`] advances it by one fixed step without allocating.
#[derive(Clone, Debug)]
pub struct ClothSim {
    model: ClothModel,
    state: ClothState,
    pins: Vec<Pin>,
    tethers: Vec<Tether>,
    /// `tethers` in batches of four.
    tether_batches: PairBatches,
    stretch_limits: Vec<StretchLimit>,
    /// `stretch_limits` in batches of four.
    limit_batches: PairBatches,
    planes: Vec<Plane>,
    /// Multipliers of the order-free (Jacobi) edge projection, one per edge.
    edge_lambdas: Vec<f32>,
    /// The model's edges in batches of four, in their sorted order.
    edge_batches: PairBatches,
    /// Multipliers of `edge_batches`, one lane per edge.
    edge_batch_lambdas: Vec<Vec4>,
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
    contact_push: Vec<f32>,
    springs: Option<SpringScratch>,
    last_substeps: u32,
    colliders: Vec<Collider>,
    contacts: ContactScratch,
    /// The particle being dragged, moved like a pin.
    drag: Option<Pin>,
    /// Tethers from free particles to the particles colliders held in the last step.
    contact_tethers: Vec<Tether>,
    anchors: Vec<u32>,
    /// Built the first time a step asks for a volume constraint (or its error).
    volume: Option<Result<VolumeConstraint, ClothError>>,
    /// Built the first time a step asks for self-collision.
    self_collision: Option<SelfCollision>,
    self_contacts: usize,
    /// The substep count [`SolverSettings::adaptive`] chose for the next step (0: not yet).
    adaptive_substeps: u32,
    /// Steps in a row below the adaptive budget's lower bound.
    adaptive_calm: u32,
    /// The state before an adaptive step, to undo it.
    adaptive_backup: ClothState,
    /// Buffers of the order-free edge projection (closed cloth).
    jacobi: JacobiScratch,
}

impl ClothSim {
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
        let limit_batches = PairBatches::new(
            stretch_limits.iter().map(|l| (l.particles, l.length)),
            n,
            true,
        );
        let edge_batches = PairBatches::new(
            model.edges.iter().map(|e| (e.particles, e.rest_length)),
            n,
            true,
        );
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
        Self {
            stretch_limits,
            limit_batches,
            edge_lambdas: vec![0.0; model.edges.len()],
            edge_batch_lambdas: vec![Vec4::ZERO; edge_batches.len()],
            edge_batches,
            tether_batches: PairBatches::default(),
            isometric_prepared: PreparedIsometric::default(),
            weights_seen: Vec::new(),
            bend_alpha_prepared: f32::NAN.to_bits(),
            free_masses: Vec::new(),
            isometric_pairs,
            curved_pairs,
            contact_push: vec![0.0; n],
            model,
            state,
            pins: Vec::new(),
            tethers: Vec::new(),
            planes: Vec::new(),
            springs: None,
            last_substeps: 0,
            colliders: Vec::new(),
            contacts: ContactScratch::default(),
            drag: None,
            contact_tethers: Vec::new(),
            anchors: Vec::new(),
            volume: None,
            self_collision: None,
            self_contacts: 0,
            adaptive_substeps: 0,
            adaptive_calm: 0,
            adaptive_backup: ClothState::default(),
            jacobi: JacobiScratch::default(),
        }
    }

    /// Grabs `particle`: from now on it is held like a pin (inverse mass 0) and moved to
    /// [`ClothSim::drag_to`]'s goal over each step, until [`ClothSim::release`]. Grabbing
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
    pub fn set_colliders(&mut self, colliders: &[Collider]) {
        self.colliders.clear();
        self.colliders.extend_from_slice(colliders);
    }

    /// Carries the cloth along with the frame it follows (a character) over the coming step,
    /// so that it feels only `inertia` of the frame's world motion: `1` is physical (nothing
    /// is carried), `0` simulates the cloth as if it lived in the frame. Call after
    /// [`ClothSim::set_colliders`] and the pin targets, before [`ClothSim::step`].
    ///
    /// The carried part, `s = 1 - inertia` of the step's pose change ([`FrameStep::carry`]),
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
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// Every particle's collider contact in the last substep.
    pub fn contacts(&self) -> &[Contact] {
        self.contacts.contacts()
    }

    /// How many particles touched a collider in the last substep.
    pub fn contact_count(&self) -> usize {
        self.contacts.count()
    }

    /// The springs of the mass-spring and hybrid methods, once one of them has stepped (or
    /// [`ClothSim::springs_mut`] has been called).
    pub fn springs(&self) -> Option<&SpringSet> {
        self.springs.as_ref().map(|s| &s.set)
    }

    /// The springs of the mass-spring and hybrid methods, built now if they are not yet.
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

    /// The substeps the last [`ClothSim::step`] took (more than `settings.substeps` with
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
    /// the sim (pins, density): change them through [`ClothSim::set_pins`] and
    /// [`ClothSim::set_density`].
    pub fn state_mut(&mut self) -> &mut ClothState {
        &mut self.state
    }

    /// The pins.
    pub fn pins(&self) -> &[Pin] {
        &self.pins
    }

    /// The long-range attachments currently built.
    pub fn tethers(&self) -> &[Tether] {
        &self.tethers
    }

    /// The long-range stretch limits along the straight lines of the rest shape.
    pub fn stretch_limits(&self) -> &[StretchLimit] {
        &self.stretch_limits
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

    /// Replaces the planes (ground, container walls) particles stay on the allowed side of.
    pub fn set_planes(&mut self, planes: &[Plane]) {
        self.planes.clear();
        self.planes.extend_from_slice(planes);
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

    /// Tethers every free particle to its nearest pinned particles (at most
    /// `TETHERS_PER_PARTICLE`), with the straight-line rest distance as the length. That
    /// length is the geodesic one for a flat piece whose straight line to the pin stays on the
    /// cloth (every grid); across a hole or a curved rest shape it is shorter than the
    /// geodesic and holds the cloth tighter than its edges would.
    fn rebuild_tethers(&mut self) {
        self.tethers.clear();
        if self.pins.is_empty() && self.drag.is_none() {
            return;
        }
        let rest = &self.model.rest_positions;
        let mut nearest: Vec<(f32, u32)> = Vec::with_capacity(self.pins.len() + 1);
        for (i, &w) in self.state.inverse_masses.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            nearest.clear();
            nearest.extend(
                self.pins
                    .iter()
                    .chain(self.drag.as_ref())
                    .map(|pin| (rest[i].distance(rest[pin.particle as usize]), pin.particle)),
            );
            let k = TETHERS_PER_PARTICLE.min(nearest.len());
            if nearest.len() > k {
                nearest.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
            }
            for &(length, anchor) in &nearest[..k] {
                self.tethers.push(Tether {
                    particle: i as u32,
                    anchor,
                    length,
                });
            }
        }
        // Consecutive tethers of different particles do not wait for each other.
        self.tethers.sort_by_key(|t| t.anchor);
        self.tether_batches = PairBatches::new(
            self.tethers
                .iter()
                .map(|t| ([t.particle, t.anchor], t.length)),
            self.state.positions.len(),
            false,
        );
        self.tether_batches.set_weights(&self.state.inverse_masses);
    }

    /// Advances the cloth by `dt` seconds under the constant acceleration `acceleration`
    /// (gravity plus any external acceleration) with `settings.method`, in
    /// `settings.substeps` substeps (more with `settings.auto_substeps` for the spring
    /// methods; as many as [`SolverSettings::adaptive`] needs if set).
    ///
    /// [`SolverMethod::MassSpring`] is described in [`ClothSim::step_mass_spring`],
    /// [`SolverMethod::Hybrid`] in [`ClothSim::step_hybrid`]. XPBD and PBD take
    /// `settings.iterations` constraint iterations per substep; each substep of length `h`:
    /// 1. predict: `x_prev = x`, `x += h v + h^2/2 a` for free particles; pins move to their
    ///    interpolated targets;
    /// 2. project, `iterations` times, in this order: stretch limits and tethers (the
    ///    long-range constraints), edges, bending pairs (first iteration only: bending is soft
    ///    and its projection costs about ten distance projections), planes (multipliers reset
    ///    first);
    /// 3. velocities: `v = (x - x_prev) / h + h/2 a`;
    /// 4. contacts with planes: the approaching normal velocity is removed and the tangential
    ///    one reduced by Coulomb friction (by at most `mu` times the normal velocity change the
    ///    contact made, `push / h`); then damping.
    ///
    /// Steps 1 and 3 are symplectic Euler on the half-step velocity `(x - x_prev) / h`, started
    /// consistently (velocity Verlet), so a free particle follows `x0 + v0 t + a t^2 / 2`
    /// exactly, whatever the step.
    pub fn step(&mut self, settings: &SolverSettings, acceleration: Vec3, dt: f32) {
        if !(dt > 0.0 && dt.is_finite()) {
            return;
        }
        self.build_contact_tethers(settings);
        if settings.volume.is_some() && self.volume.is_none() {
            self.volume = Some(VolumeConstraint::new(&self.model));
        }
        self.sync_weights();
        self.self_contacts = 0;
        if settings.self_collision {
            self.find_self_contacts(acceleration, dt);
        }
        match settings
            .adaptive
            .filter(|_| settings.method != SolverMethod::MassSpring)
        {
            Some(budget) => self.step_adaptive(settings, &budget, acceleration, dt),
            None => self.step_method(settings, acceleration, dt),
        }
        for pin in self.pins.iter_mut().chain(self.drag.as_mut()) {
            pin.start = pin.end;
        }
    }

    /// Copies the inverse masses into the batches if they changed since the last step (they
    /// do not change within a step), and marks the bending factors for remaking.
    fn sync_weights(&mut self) {
        let w = &self.state.inverse_masses;
        let seen = &mut self.weights_seen;
        if !seen.iter().copied().eq(w.iter().map(|m| m.to_bits())) {
            self.edge_batches.set_weights(w);
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

    fn step_method(&mut self, settings: &SolverSettings, acceleration: Vec3, dt: f32) {
        match settings.method {
            SolverMethod::Xpbd | SolverMethod::Pbd { .. } => {
                self.step_constraints(settings, acceleration, dt)
            }
            SolverMethod::MassSpring => self.step_mass_spring(settings, acceleration, dt),
            SolverMethod::Hybrid => self.step_hybrid(settings, acceleration, dt),
        }
    }

    /// One fixed step under [`SolverSettings::adaptive`]: the step runs at the chosen count;
    /// if it ends above the target strain it is undone and run again with more substeps
    /// (up to the maximum), so every step that can meet the target does. The count then
    /// goes down as [`AdaptiveSubsteps::next`] says. [`ClothSim::last_substeps`] counts every
    /// substep run, undone ones included (the step's cost).
    fn step_adaptive(
        &mut self,
        settings: &SolverSettings,
        budget: &AdaptiveSubsteps,
        acceleration: Vec3,
        dt: f32,
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
        let mut run = 0;
        loop {
            self.step_method(&chosen, acceleration, dt);
            run += chosen.substeps;
            let strain = self.strain().max;
            let next = budget.next(chosen.substeps, strain, &mut self.adaptive_calm);
            if next > chosen.substeps && strain.is_finite() {
                // Over the target: undo the step and run it again with more.
                self.state.clone_from(&self.adaptive_backup);
                chosen.substeps = next;
                continue;
            }
            self.adaptive_substeps = next;
            break;
        }
        self.last_substeps = run;
    }

    fn step_constraints(&mut self, settings: &SolverSettings, acceleration: Vec3, dt: f32) {
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
            self.contact_push.fill(0.0);
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
                project_planes(
                    &self.planes,
                    x,
                    w,
                    settings.thickness,
                    &mut self.contact_push,
                );
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

            // 4. Contacts: planes (no bounce, Coulomb friction), colliders (restitution and
            //    friction relative to the surface, see `crate::collide::contact`), then damping.
            contact_velocities(&self.planes, x, v, &self.contact_push, settings, inv_h);
            if !colliders.is_empty() {
                self.contacts
                    .respond(colliders, x, x_prev, v, inv_h, h, bounce_threshold);
            }
            damp(settings, damping_k, x, v, w, &self.free_masses);
        }
    }

    /// One fixed step of [`SolverMethod::MassSpring`]: in each substep of length `h`, with the
    /// spring forces `f` at the substep's start,
    /// 1. symplectic Euler: `v += h (a + f / m)`, then `x += h v` (free particles); pins move
    ///    to their interpolated targets with the velocity of their straight path;
    /// 2. contacts, found at the end of the substep: a particle behind a plane is put back on
    ///    it (plus the thickness), its approaching normal velocity removed and its tangential
    ///    velocity reduced by Coulomb friction (by at most `mu` times the normal velocity
    ///    removed);
    /// 3. damping ([`SolverSettings::damping`], on top of the springs' own).
    pub fn step_mass_spring(&mut self, settings: &SolverSettings, acceleration: Vec3, dt: f32) {
        self.step_springs(settings, acceleration, dt, false);
    }

    /// One fixed step of [`SolverMethod::Hybrid`]: in each substep of length `h`, with the
    /// shear and bend spring forces `f` at the substep's start,
    /// 1. predict: `x_prev = x`, `v += h (a + f / m)`, `x += h v` (free particles); pins move
    ///    to their interpolated targets;
    /// 2. project, `iterations` times: the long-range attachments (if on), the structural
    ///    edges as XPBD distance constraints with `stretch_compliance`, the planes;
    /// 3. `v = (x - x_prev) / h`; contacts and damping as in XPBD.
    pub fn step_hybrid(&mut self, settings: &SolverSettings, acceleration: Vec3, dt: f32) {
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

            self.contact_push.fill(0.0);
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
                    project_planes(
                        &self.planes,
                        x,
                        w,
                        settings.thickness,
                        &mut self.contact_push,
                    );
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
                contact_velocities(&self.planes, x, v, &self.contact_push, settings, inv_h);
            } else {
                // Discrete contacts: the velocity removed is the approaching normal velocity.
                for plane in &self.planes {
                    for i in 0..x.len() {
                        if w[i] > 0.0 && project_plane(&mut x[i], plane, settings.thickness) > 0.0 {
                            let approach = (-plane.normal.dot(v[i])).max(0.0);
                            self.contact_push[i] = approach * h;
                            v[i] += plane.normal * approach;
                        }
                    }
                }
                contact_velocities(&self.planes, x, v, &self.contact_push, settings, inv_h);
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

    /// Rebuilds the contact tethers for the coming step: every free particle that no collider
    /// touched in the last substep is tied to the nearest (in the rest shape) particle a
    /// collider did touch, by their rest distance. An inextensible cloth can never be longer
    /// between two of its points than along the cloth, so these only refuse stretch, like the
    /// tethers to pins (Kim, Chentanez and Mueller 2012); unlike those, both ends move (in the
    /// ratio of their inverse masses), so momentum is kept and a cloth cannot drift toward its
    /// anchors. The rest distance is the straight one, which for a flat pattern is the
    /// distance along the cloth unless a hole lies between the two. At most 128 held particles
    /// (evenly spread over the contacts) serve as anchors.
    ///
    /// Measured with `cargo run --release --example scenes`: S2 at N = 64, 8 x 2, max strain
    /// 20.9% without, 14.4% with; the poncho scene (S3) 55% without, 41% with.
    fn build_contact_tethers(&mut self, settings: &SolverSettings) {
        const MAX_ANCHORS: usize = 128;
        self.contact_tethers.clear();
        if !settings.long_range_attachments || self.colliders.is_empty() {
            return;
        }
        let w = &self.state.inverse_masses;
        let contacts = self.contacts.contacts();
        if contacts.len() != w.len() {
            return;
        }
        let held = |i: usize| contacts[i].collider != u32::MAX && w[i] > 0.0;
        self.anchors.clear();
        let count = (0..w.len()).filter(|&i| held(i)).count();
        if count == 0 {
            return;
        }
        let stride = count.div_ceil(MAX_ANCHORS);
        self.anchors.extend(
            (0..w.len())
                .filter(|&i| held(i))
                .step_by(stride)
                .map(|i| i as u32),
        );
        let rest = &self.model.rest_positions;
        for i in 0..w.len() {
            if w[i] == 0.0 || held(i) {
                continue;
            }
            let mut best = (f32::INFINITY, u32::MAX);
            for &a in &self.anchors {
                let d = rest[i].distance_squared(rest[a as usize]);
                if d < best.0 {
                    best = (d, a);
                }
            }
            if best.1 != u32::MAX {
                self.contact_tethers.push(Tether {
                    particle: i as u32,
                    anchor: best.1,
                    length: best.0.sqrt(),
                });
            }
        }
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

    /// The tethers to particles held by colliders, rebuilt every step (see
    /// [`SolverSettings::long_range_attachments`]).
    pub fn contact_tethers(&self) -> &[Tether] {
        &self.contact_tethers
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
        let x = &self.state.positions;
        let v = &self.state.velocities;
        let max_speed = v
            .iter()
            .map(|v| v.length_squared())
            .fold(0.0f32, f32::max)
            .sqrt();
        // Two particles close in at most twice the fastest particle's travel.
        let travel = max_speed * dt + 0.5 * acceleration.length() * dt * dt;
        sc.find_pairs(x, 2.0 * travel);
    }

    /// The self-collision tables, once a step has run with
    /// [`SolverSettings::self_collision`] on.
    pub fn self_collision(&self) -> Option<&SelfCollision> {
        self.self_collision.as_ref()
    }

    /// How many pairs of particles were held apart by self-collision in the last step's last
    /// iteration (the most in any substep).
    pub fn self_contact_count(&self) -> usize {
        self.self_contacts
    }

    /// The strain `|len - rest| / rest` of every structural edge, in the model's order.
    pub fn edge_strains(&self) -> impl Iterator<Item = f32> + '_ {
        let x = &self.state.positions;
        self.model
            .edges
            .iter()
            .filter(|e| e.kind == EdgeKind::Structural)
            .map(move |edge| {
                let [a, b] = edge.particles;
                (x[a as usize].distance(x[b as usize]) - edge.rest_length).abs() / edge.rest_length
            })
    }

    /// Strain `|len - rest| / rest` over the structural edges.
    pub fn strain(&self) -> StrainStats {
        let mut stats = StrainStats::default();
        let mut count = 0usize;
        for strain in self.edge_strains() {
            stats.max = stats.max.max(strain);
            stats.mean += strain;
            count += 1;
        }
        if count > 0 {
            stats.mean /= count as f32;
        }
        stats
    }

    /// Whether every position and velocity is finite.
    pub fn is_finite(&self) -> bool {
        self.state.positions.iter().all(|p| p.is_finite())
            && self.state.velocities.iter().all(|v| v.is_finite())
    }

    /// Whether the cloth has diverged: a non-finite position or velocity, a structural strain
    /// past `bounds.max_strain`, or a particle faster than `bounds.max_speed`.
    pub fn divergence(&self, bounds: &DivergenceBounds) -> Option<Divergence> {
        if !self.is_finite() {
            return Some(Divergence::NonFinite);
        }
        let max_speed_sq = self
            .state
            .velocities
            .iter()
            .map(|v| v.length_squared())
            .fold(0.0, f32::max);
        if max_speed_sq > bounds.max_speed * bounds.max_speed {
            return Some(Divergence::Speed {
                speed: max_speed_sq.sqrt(),
            });
        }
        let strain = self.strain().max;
        if strain > bounds.max_strain {
            return Some(Divergence::Strain { strain });
        }
        None
    }

    /// The rigid motion that fits the free particles (centre of mass, linear and angular
    /// momentum); `None` if every particle is pinned.
    pub fn rigid_motion(&self) -> Option<RigidMotion> {
        RigidMotion::fit(
            &self.state.positions,
            &self.state.velocities,
            &self.state.inverse_masses,
        )
    }

    /// Gravitational potential energy of the free particles in the field `gravity` (m/s^2),
    /// zero at the origin, J: `-sum m g . x`.
    pub fn potential_energy(&self, gravity: Vec3) -> f32 {
        let g = Vec3A::from(gravity);
        self.state
            .positions
            .iter()
            .zip(&self.state.inverse_masses)
            .filter(|&(_, &w)| w > 0.0)
            .map(|(x, &w)| -g.dot(*x) / w)
            .sum()
    }

    /// Kinetic energy of the free particles, J.
    pub fn kinetic_energy(&self) -> f32 {
        self.state
            .velocities
            .iter()
            .zip(&self.state.inverse_masses)
            .filter(|&(_, &w)| w > 0.0)
            .map(|(v, &w)| 0.5 * v.length_squared() / w)
            .sum()
    }
}
