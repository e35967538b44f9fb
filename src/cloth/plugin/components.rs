//! The cloth's components and resources: what a game spawns and reads.

use bevy::math::{Vec3, Vec3A};
use bevy::prelude::*;

use crate::cloth::debug_colors::DebugColorMode;
use crate::cloth::flat_layout::FlatLayout;
use crate::cloth::lod::LodLevel;
use crate::cloth::render_mesh::EmbeddedRender;
use crate::cloth::settings::{DivergenceBounds, SolverMethod, SolverSettings};
use crate::cloth::sim::diagnostics::Divergence;
use crate::cloth::sim::{CREEP, ClothSolver, SleepClock, SleepSettings};
use crate::collide::skin::DrawnColliders;
use crate::collide::{FrameStep, FrameTracker, RigidPose, SolverCollider};
use crate::error::ClothError;
use crate::files::{FileValue, FromFile};
use crate::schedule::IsCloth;

/// Makes an entity with a [`Mesh3d`] a cloth. The simulation is built from the mesh (in world
/// space, through the entity's transform) in the first fixed step after the mesh is loaded;
/// the entity then gets a [`ClothSimulation`] and a mesh of its own, which the cloth writes
/// into every frame.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_drape::prelude::*;
/// fn spawn(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>) {
///     let grid = GridDesc::square(1.0, 32, Vec3::ZERO);
///     commands.spawn((
///         Mesh3d(meshes.add(grid_mesh(&grid))),
///         Cloth::pinned([grid.index(0, 0), grid.index(31, 0)]),
///         Transform::from_xyz(0.0, 1.0, 0.0),
///     ));
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
#[require(Transform, IsCloth)]
pub struct Cloth {
    /// Vertices held at their rest position relative to this entity's transform: moving the
    /// entity moves them.
    pub pinned_vertices: Vec<u32>,
    /// Vertices held at a point fixed to another entity.
    pub attachments: Vec<VertexAttachment>,
    /// The entity the cloth is worn by or follows (a character): a jump of it past
    /// [`DrapeSettings::teleport`](crate::schedule::DrapeSettings::teleport) carries the cloth along rigidly, [`ClothSettings::inertia`]
    /// scales how much of its world motion the cloth feels, and the cloth is drawn in its
    /// frame between fixed steps. Default: `None` (the cloth lives in the world alone).
    pub follow: Option<Entity>,
}

impl Cloth {
    /// A cloth with the given vertices pinned.
    pub fn pinned(vertices: impl IntoIterator<Item = u32>) -> Self {
        Self {
            pinned_vertices: vertices.into_iter().collect(),
            ..default()
        }
    }

    /// A cloth worn by (following) `entity`, see [`Cloth::follow`].
    pub fn worn_by(entity: Entity) -> Self {
        Self {
            follow: Some(entity),
            ..default()
        }
    }

    /// Follows `entity` (see [`Cloth::follow`]).
    pub fn following(mut self, entity: Entity) -> Self {
        self.follow = Some(entity);
        self
    }

    /// Adds an attachment.
    pub fn with_attachment(mut self, attachment: VertexAttachment) -> Self {
        self.attachments.push(attachment);
        self
    }
}

/// A cloth vertex held at `offset` in the local frame of the entity `target`.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct VertexAttachment {
    /// The cloth vertex.
    pub vertex: u32,
    /// The entity it hangs from (any entity with a [`Transform`], a bone for instance).
    pub target: Entity,
    /// Where on that entity, in its local frame, metres.
    pub offset: Vec3,
}

/// Cloth parameters of one cloth entity. A cloth without this component uses
/// [`DefaultClothSettings`]. A change takes effect at the next fixed step without rebuilding
/// the cloth.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_drape::prelude::*;
/// // A heavy, stiff canvas that keeps its shape, with more solver work per step.
/// let canvas = ClothSettings {
///     density: 0.4, // kg/m^2
///     solver: SolverSettings {
///         substeps: 16,
///         iterations: 4,
///         bend_compliance: 1.0,
///         ..default()
///     },
///     ..default()
/// };
/// assert!(canvas.solver.validate().is_ok());
/// ```
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothSettings {
    /// Areal density, kg/m^2. Default: `0.1`.
    pub density: f32,
    /// Solver parameters (substeps, iterations, compliances, damping, thickness, friction).
    pub solver: SolverSettings,
    /// When the cloth counts as diverged, checked after every fixed step.
    pub divergence: DivergenceBounds,
    /// What happens to a diverged cloth. Default: [`OnDivergence::Freeze`].
    pub on_divergence: OnDivergence,
    /// How much of the followed entity's ([`Cloth::follow`]) world motion the cloth feels:
    /// `1` is physical, `0` as if the cloth lived in that entity's frame (it still feels the
    /// joints' motion, gravity and its colliders); in between scales the inertia of walking,
    /// turning and stopping. Default: `1.0`.
    pub inertia: f32,
    /// The largest speed of a particle relative to the followed entity ([`Cloth::follow`]),
    /// m/s: beyond it a particle's speed relative to the entity's motion is cut at each fixed
    /// step (`ClothSolver::limit_speed_relative_to`), so a character that stops dead, turns
    /// round or lands keeps its cloth on. `None`: no limit. Default: `Some(`[`ClothSettings::DEFAULT_SPEED_LIMIT`]`)`.
    pub speed_limit: Option<f32>,
    /// Whether the cloth feels the [`Wind`](crate::cloth::wind_plugin::Wind) and every
    /// [`WindSource`](crate::cloth::wind_plugin::WindSource). While any blows, a cloth whose
    /// [`SolverSettings::air`] is `None` meets the air with the default [`AirSettings`]; with
    /// no wind about it pays nothing for it. `false` keeps the cloth in still air (a garment
    /// under another). Default: `true`.
    ///
    /// [`AirSettings`]: crate::cloth::AirSettings
    pub wind: bool,
    /// When the cloth sleeps: still for a while (its free particles within
    /// [`SleepSettings::distance`] of where they were [`SleepSettings::seconds`] ago, as a root
    /// mean square, none farther than [`SleepSettings::TREMBLE`] times it) with nothing about
    /// it moving,
    /// it stops being solved and gets a [`ClothSleeping`] marker; it wakes in the fixed step
    /// its followed entity, a pin or attachment target, a collider near it, the wind, a drag
    /// ([`ClothSimulation::solver_mut`]), these settings or the gravity change. `None`: it never
    /// sleeps. A cloth stepped with a coupling (water in it) never sleeps. Default:
    /// `Some(SleepSettings::default())`.
    pub sleep: Option<SleepSettings>,
}

impl Default for ClothSettings {
    fn default() -> Self {
        Self {
            density: 0.1,
            solver: SolverSettings::default(),
            wind: true,
            divergence: DivergenceBounds::default(),
            on_divergence: OnDivergence::Freeze,
            inertia: 1.0,
            speed_limit: Some(Self::DEFAULT_SPEED_LIMIT),
            sleep: Some(SleepSettings::default()),
        }
    }
}

impl ClothSettings {
    /// The default [`ClothSettings::speed_limit`], m/s.
    pub const DEFAULT_SPEED_LIMIT: f32 = 1.5;
}

/// What happens to a cloth that diverges. Either way a [`ClothDiverged`] message is sent and
/// the mesh never receives the diverged positions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum OnDivergence {
    /// Put the cloth back where it was before the diverging step, at rest, and stop stepping
    /// it until its [`ClothSettings`] change (or [`ClothSimulation::unfreeze`]).
    #[default]
    Freeze,
    /// Put the cloth back in its rest shape, at rest, and keep stepping.
    Reset,
}

/// Sent when a cloth diverges (see [`DivergenceBounds`]).
#[derive(Message, Clone, Copy, Debug, PartialEq)]
pub struct ClothDiverged {
    /// The cloth entity.
    pub cloth: Entity,
    /// The method it was stepped with.
    pub method: SolverMethod,
    /// What went wrong.
    pub divergence: Divergence,
    /// What was done about it.
    pub response: OnDivergence,
}

/// On a cloth that sleeps (see [`ClothSettings::sleep`]): it is not solved, its pose is kept
/// and its mesh is not rewritten until it wakes; the marker goes when it does. Added and
/// removed by the cloth's step.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Component)]
pub struct ClothSleeping;

/// Level of detail: every cloth's budget by its distance from a viewer, for crowds. A cloth
/// farther than a level's [`LodLevel::beyond`] gets that level's
/// [`LodBudget`](crate::cloth::LodBudget): fewer substeps, frozen (carried rigidly with the
/// entity it follows, not solved) or hidden too. A cloth leaves a level for a nearer one
/// [`LOD_MARGIN`](crate::cloth::LOD_MARGIN) inside its distance, so one walking along the
/// line does not switch at every step; a frozen cloth comes back from rest in its followed
/// entity's frame, its speed relative to that entity limited in its first step (no jolt).
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy_drape::cloth::{LodBudget, LodLevel};
/// # use bevy_drape::cloth::plugin::ClothLevelOfDetail;
/// // Half the substeps beyond 15 m from the active camera, frozen beyond 40 m, hidden beyond
/// // 80 m.
/// let lod = ClothLevelOfDetail {
///     viewer: None,
///     levels: vec![
///         LodLevel { beyond: 15.0, budget: LodBudget::Substeps(4) },
///         LodLevel { beyond: 40.0, budget: LodBudget::Frozen },
///         LodLevel { beyond: 80.0, budget: LodBudget::Hidden },
///     ],
/// };
/// App::new().insert_resource(lod);
/// ```
#[derive(Resource, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct ClothLevelOfDetail {
    /// The entity distances are measured from. `None` (default): the first active camera.
    /// An entity without a transform is warned about (with its id) and the camera used.
    pub viewer: Option<Entity>,
    /// The levels, by increasing distance. Empty (default): every cloth at its full budget.
    /// Levels that are not increasing, or a substep count of 0, are warned about and no
    /// level of detail is used until they are fixed.
    pub levels: Vec<LodLevel>,
}

/// The [`ClothSettings`] of every cloth that has none of its own.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct DefaultClothSettings(pub ClothSettings);

/// The debug colours every cloth's mesh shows (vertex colours, multiplied with its
/// material's colour; off shows the mesh's own vertex colours, or white). Default: off. While
/// a per-triangle mode is on ([`DebugColorMode::AreaStrain`], a [`ClothPaint`](crate::cloth::ClothPaint) per triangle)
/// the mesh is drawn with one vertex per triangle corner, so each triangle has one flat
/// colour; the shared mesh comes back when the mode goes off.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource)]
pub struct ClothDebugColors(pub DebugColorMode);

/// The simulation of one cloth entity, added by `bevy_drape` once its mesh is loaded: the
/// entity's [`ClothSolver`] (the core that steps it, free of ECS types) and how its mesh's
/// vertices map to the solver's particles.
#[derive(Component, Debug)]
pub struct ClothSimulation {
    pub(super) sim: ClothSolver,
    /// Mesh-space rest positions of the mesh's vertices, for pins that follow the entity.
    pub(super) local_rest: Vec<Vec3>,
    /// The particle of every mesh vertex (vertices split at seams share one).
    pub(super) vertex_to_particle: Vec<u32>,
    /// Positions at the end of the previous fixed step, for interpolation.
    pub(super) render_from: Vec<Vec3A>,
    pub(super) normals: Vec<Vec3>,
    pub(super) colors: Vec<[f32; 4]>,
    /// `colors` per mesh vertex.
    pub(super) vertex_colors: Vec<[f32; 4]>,
    /// Interpolated particle positions in the mesh's frame, for the normals.
    pub(super) local_positions: Vec<[f32; 3]>,
    /// Interpolated particle positions in the world, kept outside the colliders.
    pub(super) drawn_world: Vec<Vec3A>,
    /// The colliders' poses as drawn.
    pub(super) drawn_poses: Vec<RigidPose>,
    /// The colliders near the drawn cloth (`collide/skin.rs`).
    pub(super) skin: DrawnColliders,
    /// The mesh's own vertex colours (white if it had none), shown when debug colours are off.
    pub(super) base_colors: Vec<[f32; 4]>,
    /// Whether the mesh is drawn with a vertex per triangle corner (per-triangle colours).
    pub(super) flat: FlatLayout,
    /// Whether a [`ClothPaint`](crate::cloth::ClothPaint) of the wrong length was reported (until it fits again).
    pub(super) warned_paint: bool,
    /// The colliders this cloth meets in a step (the world's and its own planes).
    pub(super) colliders: Vec<SolverCollider>,
    pub(super) warned_invalid_settings: bool,
    /// Whether a refused step was reported (until a step succeeds again).
    pub(super) warned_step_input: bool,
    pub(super) warned_volume: bool,
    /// The settings the cloth diverged with, while it is frozen.
    pub(super) frozen_with: Option<ClothSettings>,
    /// The followed entity's motion ([`Cloth::follow`]).
    pub(super) follow: FrameTracker,
    /// Its motion over the last fixed step, for drawing in its frame.
    pub(super) followed: Option<FrameStep>,
    /// Its pose when the cloth was built, for resets.
    pub(super) built_in_frame: Option<RigidPose>,
    pub(super) warned_follow: bool,
    /// The drawn mesh, when it is not the simulated one ([`ClothSimulationMesh`]).
    pub(super) render: Option<EmbeddedRender>,
    /// How long the cloth has been still, and whether it sleeps ([`ClothSettings::sleep`]).
    pub(super) sleep: SleepClock,
    /// The settings and the gravity the cloth fell asleep with.
    pub(super) slept_with: Option<Slept>,
    pub(super) warned_sleep: bool,
    /// What the mesh was last drawn from while the cloth sleeps (the cloth's and the followed
    /// entity's drawn poses): the same again is not redrawn.
    pub(super) drawn_asleep: Option<(GlobalTransform, Option<RigidPose>, AssetId<Mesh>)>,
    /// The cloth's level of detail (0: full budget, `k`: [`ClothLevelOfDetail::levels`]`[k - 1]`).
    pub(super) lod_level: usize,
    /// Whether its level of detail froze it in the last step.
    pub(super) lod_frozen: bool,
    /// Whether its level of detail hides it, and its visibility before it was hidden.
    pub(super) lod_hidden: bool,
    pub(super) hidden_from: Option<Visibility>,
}

impl ClothSimulation {
    /// Whether the cloth is frozen after diverging ([`OnDivergence::Freeze`]).
    pub fn is_frozen(&self) -> bool {
        self.frozen_with.is_some()
    }

    /// Lets a frozen cloth step again.
    pub fn unfreeze(&mut self) {
        self.frozen_with = None;
    }

    /// The particle that mesh vertex `vertex` became (vertices split at seams are welded
    /// into one particle).
    pub fn particle_of_vertex(&self, vertex: u32) -> Option<u32> {
        self.vertex_to_particle.get(vertex as usize).copied()
    }

    /// The cloth's solver: its model, state, pins and colliders.
    pub fn solver(&self) -> &ClothSolver {
        &self.sim
    }

    /// The cloth's solver, to read or change its state directly. A sleeping cloth wakes
    /// (whatever is done to it is stepped from the next fixed step).
    pub fn solver_mut(&mut self) -> &mut ClothSolver {
        self.wake();
        &mut self.sim
    }

    /// The cloth's level of detail: 0 at its full budget, `k` at
    /// [`ClothLevelOfDetail::levels`]`[k - 1]`.
    pub fn level_of_detail(&self) -> usize {
        self.lod_level
    }

    /// Whether the cloth sleeps ([`ClothSettings::sleep`]).
    pub fn is_asleep(&self) -> bool {
        self.sleep.is_asleep()
    }

    /// Wakes the cloth if it sleeps: it is stepped again from the next fixed step, as if it
    /// had never slept.
    pub fn wake(&mut self) {
        self.sleep.wake();
        self.slept_with = None;
        self.drawn_asleep = None;
    }

    /// The followed entity's ([`Cloth::follow`]) motion over the last fixed step.
    pub fn followed(&self) -> Option<&FrameStep> {
        self.followed.as_ref()
    }

    /// Puts the cloth back in its rest shape, at rest: where it was built or, if it follows
    /// an entity, where that shape is in the entity's frame now.
    pub fn reset(&mut self) {
        self.wake();
        self.sim.reset();
        if let (Some(built), Some(now)) = (self.built_in_frame, self.followed) {
            let moved = FrameStep {
                start: built,
                ..now
            }
            .carry(1.0);
            let state = self.sim.state_mut();
            for p in state
                .positions
                .iter_mut()
                .chain(state.previous_positions.iter_mut())
            {
                *p = moved.point(*p);
            }
        }
        self.render_from.clone_from(&self.sim.state().positions);
    }
}

/// Added instead of a [`ClothSimulation`] when a cloth cannot be built; the error is also
/// logged with the entity.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct ClothBuildError(pub ClothError);

impl FileValue for ClothSettings {
    const EXTENSION: &'static str = "cloth.ron";
}

/// On a cloth: its [`ClothSettings`] from a `.cloth.ron` file
/// (`ClothSettingsFile::new(server.load("settings/x.cloth.ron"))`).
pub type ClothSettingsFile = FromFile<ClothSettings>;

/// What a cloth fell asleep with: its settings, the gravity and where its followed entity was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Slept {
    pub(crate) settings: ClothSettings,
    pub(crate) gravity: Vec3,
    pub(crate) followed: Option<RigidPose>,
}

impl Slept {
    /// Whether the settings and the gravity are those the cloth fell asleep with (a field
    /// that is not a number counts as unchanged, so NaN settings do not wake it every step)
    /// and its followed entity has not crept away from where it was (by [`CREEP`]).
    pub(crate) fn still(
        &self,
        settings: &ClothSettings,
        gravity: Vec3,
        frame: Option<&FrameStep>,
    ) -> bool {
        let same_settings =
            self.settings == *settings || format!("{:?}", self.settings) == format!("{settings:?}");
        let in_place = match (self.followed, frame) {
            (None, None) => true,
            (Some(then), Some(now)) => {
                then.translation.distance(now.end.translation) <= CREEP
                    && then.rotation.angle_between(now.end.rotation) <= CREEP
            }
            _ => false,
        };
        same_settings && self.gravity == gravity && in_place
    }
}
