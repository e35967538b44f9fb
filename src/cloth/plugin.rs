//! The Bevy side of the cloth: components, resources and the thin systems that build, step and
//! draw [`ClothSolver`]s.

use bevy::app::{App, Plugin, PostUpdate};
use bevy::asset::{AssetServer, Assets, LoadState};
use bevy::ecs::query::QueryData;
use bevy::log::{error, warn};
use bevy::math::{Vec3, Vec3A};
use bevy::mesh::{Mesh, Mesh3d, VertexAttributeValues};
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use super::debug_colors::{ClothPaint, DebugColorMode, GREY, PaintTarget, debug_colors};
use super::flat_layout::FlatLayout;
use super::mesh::{vertex_normals, write_colors, write_normals};
use super::model::ClothModel;
use super::render_mesh::{ClothSimulationMesh, EmbeddedRender};
use super::settings::{DivergenceBounds, SolverMethod, SolverSettings};
use super::sim::diagnostics::Divergence;
use super::sim::{ClothSolver, Join, OneThread, StepTimings, with_helper};
use crate::collide::skin::{DrawnColliders, drawn_poses};
use crate::collide::{ContactMaterial, FrameStep, FrameTracker, RigidPose, SolverCollider};
use crate::error::ClothError;
use crate::files::{FileValue, FromFile};
use crate::mesh::mesh_triangles;
use crate::schedule::{
    ClothCoupling, ClothCouplingInstalled, DrapeSchedule, DrapeSettings, DrapeSystems,
    DrapeTimings, IsCloth, NoCoupling, StepColliders, StepWind, world_pose,
};
use crate::weld::{default_tolerance, weld};

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
    /// [`DrapeSettings::teleport`] carries the cloth along rigidly, [`ClothSettings::inertia`]
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
    /// Height of a ground plane (`y >= ground`), metres, if any. Default: `None`.
    pub ground: Option<f32>,
    /// An axis-aligned box `(min, max)` the particles stay inside, if any. Default: `None`.
    pub container: Option<(Vec3, Vec3)>,
    /// When the cloth counts as diverged, checked after every fixed step.
    pub divergence: DivergenceBounds,
    /// What happens to a diverged cloth. Default: [`OnDivergence::Freeze`].
    pub on_divergence: OnDivergence,
    /// How much of the followed entity's ([`Cloth::follow`]) world motion the cloth feels:
    /// `1` is physical, `0` as if the cloth lived in that entity's frame (it still feels the
    /// joints' motion, gravity and its colliders); in between scales the inertia of walking,
    /// turning and stopping. Default: `1.0`.
    pub inertia: f32,
}

impl Default for ClothSettings {
    fn default() -> Self {
        Self {
            density: 0.1,
            solver: SolverSettings::default(),
            ground: None,
            container: None,
            divergence: DivergenceBounds::default(),
            on_divergence: OnDivergence::Freeze,
            inertia: 1.0,
        }
    }
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

impl ClothSettings {
    /// The ground and the container's walls as colliders, with the solver's friction.
    fn plane_colliders(&self, out: &mut Vec<SolverCollider>) {
        let material = ContactMaterial {
            friction: self.solver.friction,
            restitution: 0.0,
        };
        if let Some(height) = self.ground {
            out.push(SolverCollider::ground(height, material));
        }
        if let Some((min, max)) = self.container {
            out.extend(SolverCollider::box_walls(min.into(), max.into(), material));
        }
    }
}

/// The [`ClothSettings`] of every cloth that has none of its own.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct DefaultClothSettings(pub ClothSettings);

/// The debug colours every cloth's mesh shows (vertex colours, multiplied with its
/// material's colour; off shows the mesh's own vertex colours, or white). Default: off. While
/// a per-triangle mode is on ([`DebugColorMode::AreaStrain`], a [`ClothPaint`] per triangle)
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
    sim: ClothSolver,
    /// Mesh-space rest positions of the mesh's vertices, for pins that follow the entity.
    local_rest: Vec<Vec3>,
    /// The particle of every mesh vertex (vertices split at seams share one).
    vertex_to_particle: Vec<u32>,
    /// Positions at the end of the previous fixed step, for interpolation.
    render_from: Vec<Vec3A>,
    normals: Vec<Vec3>,
    colors: Vec<[f32; 4]>,
    /// `colors` per mesh vertex.
    vertex_colors: Vec<[f32; 4]>,
    /// Interpolated particle positions in the mesh's frame, for the normals.
    local_positions: Vec<[f32; 3]>,
    /// Interpolated particle positions in the world, kept outside the colliders.
    drawn_world: Vec<Vec3A>,
    /// The colliders' poses as drawn.
    drawn_poses: Vec<RigidPose>,
    /// The colliders near the drawn cloth (`collide/skin.rs`).
    skin: DrawnColliders,
    /// The mesh's own vertex colours (white if it had none), shown when debug colours are off.
    base_colors: Vec<[f32; 4]>,
    /// Whether the mesh is drawn with a vertex per triangle corner (per-triangle colours).
    flat: FlatLayout,
    /// Whether a [`ClothPaint`] of the wrong length was reported (until it fits again).
    warned_paint: bool,
    /// The colliders this cloth meets in a step (the world's and its own planes).
    colliders: Vec<SolverCollider>,
    warned_invalid_settings: bool,
    /// Whether a refused step was reported (until a step succeeds again).
    warned_step_input: bool,
    /// Whether a ground or container left out was reported (until all are valid again).
    warned_planes: bool,
    warned_volume: bool,
    /// The settings the cloth diverged with, while it is frozen.
    frozen_with: Option<ClothSettings>,
    /// The followed entity's motion ([`Cloth::follow`]).
    follow: FrameTracker,
    /// Its motion over the last fixed step, for drawing in its frame.
    followed: Option<FrameStep>,
    /// Its pose when the cloth was built, for resets.
    built_in_frame: Option<RigidPose>,
    warned_follow: bool,
    /// The drawn mesh, when it is not the simulated one ([`ClothSimulationMesh`]).
    render: Option<EmbeddedRender>,
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

    /// The cloth's solver, to read or change its state directly.
    pub fn solver_mut(&mut self) -> &mut ClothSolver {
        &mut self.sim
    }

    /// The followed entity's ([`Cloth::follow`]) motion over the last fixed step.
    pub fn followed(&self) -> Option<&FrameStep> {
        self.followed.as_ref()
    }

    /// Puts the cloth back in its rest shape, at rest: where it was built or, if it follows
    /// an entity, where that shape is in the entity's frame now.
    pub fn reset(&mut self) {
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

/// Steps every [`Cloth`] in the drape schedule and writes it into its mesh every frame.
#[derive(Default)]
pub struct ClothPlugin;

impl Plugin for ClothPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        crate::files::add_file_type::<ClothSettings, _>(app, schedule, build_cloths);
        app.register_type::<(
            Cloth,
            ClothSimulationMesh,
            ClothSettings,
            DefaultClothSettings,
            ClothDebugColors,
            ClothPaint,
        )>()
        .init_resource::<DefaultClothSettings>()
        .init_resource::<ClothDebugColors>()
        .add_message::<ClothDiverged>()
        .add_systems(
            schedule,
            step_cloths::<NoCoupling>
                .in_set(DrapeSystems::Step)
                .run_if(not(resource_exists::<ClothCouplingInstalled>)),
        )
        .add_systems(
            PostUpdate,
            write_back_meshes.in_set(DrapeSystems::Writeback),
        );
    }
}

/// Steps every cloth with the coupling `C` on its entity (if any) inside its substeps: water
/// in a cloth (`DrapePlugins` adds it for the fluid plugin's `FluidSimulation`). Without
/// it, the cloths step alone. One coupling type per App.
pub struct ClothCouplingPlugin<C>(std::marker::PhantomData<fn() -> C>);

impl<C> Default for ClothCouplingPlugin<C> {
    fn default() -> Self {
        Self(std::marker::PhantomData)
    }
}

impl<C: ClothCoupling> Plugin for ClothCouplingPlugin<C> {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        app.init_resource::<ClothCouplingInstalled>()
            .add_systems(schedule, step_cloths::<C>.in_set(DrapeSystems::Step));
    }
}

/// Builds the simulation of `mesh`, drawn with `render` if that is another mesh.
fn build_simulation(
    mesh: &Mesh,
    render: Option<&Mesh>,
    cloth: &Cloth,
    global: &GlobalTransform,
    density: f32,
) -> Result<(ClothSimulation, Vec<String>), ClothError> {
    let (local, indices) = mesh_triangles(mesh)?;
    // Vertices split at seams (texture coordinates, normals) become one particle.
    let welded = weld(&local, &indices, default_tolerance(&local));
    let world: Vec<Vec3> = welded
        .positions
        .iter()
        .map(|&p| global.transform_point(p))
        .collect();
    let model = ClothModel::from_triangles(&world, &welded.indices, density)?;
    let warnings: Vec<String> = model.warnings.iter().map(ToString::to_string).collect();
    if welded.merged_any() {
        debug!(
            "{} mesh vertices welded into {} particles",
            local.len(),
            welded.positions.len()
        );
    }
    let mut sim = ClothSolver::new(model);
    let mut pinned = Vec::new();
    for &v in cloth
        .pinned_vertices
        .iter()
        .chain(cloth.attachments.iter().map(|a| &a.vertex))
    {
        match welded.vertex_to_particle.get(v as usize) {
            Some(&p) => pinned.push(p),
            None => {
                return Err(ClothError::VertexOutOfRange {
                    vertex: v,
                    vertex_count: local.len(),
                });
            }
        }
    }
    sim.set_pins(&pinned)?;
    let render = render
        .map(|render| EmbeddedRender::new(render, &welded.positions, &sim.model().triangles))
        .transpose()?;
    let render_from = sim.state().positions.clone();
    Ok((
        ClothSimulation {
            sim,
            local_rest: local,
            vertex_to_particle: welded.vertex_to_particle,
            render_from,
            normals: Vec::new(),
            colors: Vec::new(),
            vertex_colors: Vec::new(),
            local_positions: Vec::new(),
            drawn_world: Vec::new(),
            drawn_poses: Vec::new(),
            skin: DrawnColliders::default(),
            base_colors: Vec::new(),
            flat: FlatLayout::default(),
            warned_paint: false,
            colliders: Vec::new(),
            warned_invalid_settings: false,
            warned_step_input: false,
            warned_planes: false,
            warned_volume: false,
            frozen_with: None,
            follow: FrameTracker::default(),
            followed: None,
            built_in_frame: None,
            warned_follow: false,
            render,
        },
        warnings,
    ))
}

/// A cloth not built yet (with the filter `Without<ClothSimulation>, Without<ClothBuildError>`).
#[derive(QueryData)]
struct NewCloth {
    entity: Entity,
    cloth: &'static Cloth,
    mesh: &'static Mesh3d,
    simulated: Option<&'static ClothSimulationMesh>,
    settings: Option<&'static ClothSettings>,
}

/// Builds the simulation of every new cloth whose mesh is loaded.
fn build_cloths(
    mut commands: Commands,
    new_cloths: Query<NewCloth, (Without<ClothSimulation>, Without<ClothBuildError>)>,
    mut meshes: ResMut<Assets<Mesh>>,
    defaults: Res<DefaultClothSettings>,
    transforms: TransformHelper,
    asset_server: Option<Res<AssetServer>>,
) {
    for item in &new_cloths {
        let (entity, cloth, mesh3d, settings) = (item.entity, item.cloth, item.mesh, item.settings);
        // The mesh simulated, and the one drawn if that is another.
        let handles = match item.simulated {
            Some(simulated) => [&simulated.0, &mesh3d.0],
            None => [&mesh3d.0, &mesh3d.0],
        };
        let (Some(mesh), Some(drawn)) = (meshes.get(handles[0]), meshes.get(handles[1])) else {
            // A file that will never load: say which, once.
            if let Some(server) = &asset_server
                && let Some((handle, err)) =
                    handles.iter().find_map(|h| match server.load_state(*h) {
                        LoadState::Failed(err) => Some((h, err)),
                        _ => None,
                    })
            {
                let path = server
                    .get_path(*handle)
                    .map_or_else(|| "(no path)".to_string(), |p| p.to_string());
                let error = ClothError::MeshLoadFailed {
                    path,
                    reason: err.to_string(),
                };
                error!("cloth {entity} cannot be built: {error}");
                commands.entity(entity).insert(ClothBuildError(error));
            }
            continue;
        };
        let render = item.simulated.is_some().then_some(drawn);
        let density = settings.unwrap_or(&defaults.0).density;
        let global = transforms
            .compute_global_transform(entity)
            .unwrap_or_default();
        match build_simulation(mesh, render, cloth, &global, density) {
            Ok((mut simulation, warnings)) => {
                simulation.built_in_frame = cloth
                    .follow
                    .and_then(|e| transforms.compute_global_transform(e).ok())
                    .and_then(|g| world_pose(&g));
                for warning in warnings {
                    warn!("cloth {entity}: {warning}");
                }
                // The cloth writes into its mesh, so it gets a copy of its own, with vertex
                // colours from the start (the mesh's own, or white): debug colours then only
                // change values, never the vertex layout the renderer was prepared for.
                let mut own_mesh = drawn.clone();
                let vertices = simulation.render.as_ref().map_or(
                    simulation.vertex_to_particle.len(),
                    EmbeddedRender::vertex_count,
                );
                simulation.base_colors = match own_mesh.attribute(Mesh::ATTRIBUTE_COLOR) {
                    Some(VertexAttributeValues::Float32x4(c)) if c.len() == vertices => c.clone(),
                    _ => vec![[1.0; 4]; vertices],
                };
                own_mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, simulation.base_colors.clone());
                let own_mesh = meshes.add(own_mesh);
                commands
                    .entity(entity)
                    .insert((simulation, Mesh3d(own_mesh)));
            }
            Err(err) => {
                error!("cloth {entity} cannot be simulated: {err}");
                commands.entity(entity).insert(ClothBuildError(err));
            }
        }
    }
}

/// Moves pins and attachments to this step's targets, steps every cloth and checks it for
/// divergence: one cloth after another on this thread, or with [`DrapeSettings::max_threads`]
/// above one, independent cloths at the same time on Bevy's compute task pool (each cloth is
/// stepped exactly as on one thread, so the result does not depend on the thread count).
#[allow(clippy::type_complexity)]
fn step_cloths<C: ClothCoupling>(
    mut cloths: Query<(
        Entity,
        &Cloth,
        &mut ClothSimulation,
        Option<&ClothSettings>,
        Option<&mut C>,
    )>,
    defaults: Res<DefaultClothSettings>,
    drape: Res<DrapeSettings>,
    time: Res<Time>,
    transforms: TransformHelper,
    mut diverged: MessageWriter<ClothDiverged>,
    (colliders, wind, timings): (
        Option<Res<StepColliders>>,
        Option<Res<StepWind>>,
        Option<ResMut<DrapeTimings>>,
    ),
) {
    let context = StepContext {
        defaults: &defaults.0,
        drape: &drape,
        dt: time.delta_secs(),
        elapsed: time.elapsed_secs(),
        transforms: &transforms,
        colliders: colliders.as_deref().map_or(&[], |c| &c.colliders),
        wind: wind.as_deref().map(|w| &w.0),
    };
    let pool = bevy::tasks::ComputeTaskPool::try_get();
    // The scope's own thread works too.
    let available = pool.map_or(1, |p| p.thread_num() + 1);
    let allowed = drape
        .max_threads
        .map_or(available, |cap| cap.get().min(available));
    let count = cloths.iter().len();
    let threads = allowed.min(count);
    match pool {
        // One cloth that splits, two threads: its sweeps in two halves at once
        // (`ClothSolver::step_with`).
        Some(pool)
            if count == 1
                && allowed > 1
                && cloths
                    .iter_mut()
                    .all(|(_, _, mut simulation, settings, _)| {
                        let settings = settings.unwrap_or(context.defaults);
                        simulation.sim.splits_in_two(&settings.solver)
                    }) =>
        {
            for (entity, cloth, mut simulation, settings, mut coupled) in &mut cloths {
                let coupled = coupled.as_deref_mut();
                let stepped = with_helper(pool, |join| {
                    step_cloth(
                        entity,
                        cloth,
                        &mut simulation,
                        settings,
                        coupled,
                        &context,
                        join,
                    )
                });
                if let Some(d) = stepped {
                    diverged.write(d);
                }
            }
        }
        Some(pool) if threads > 1 => {
            // `threads` workers take the cloths one at a time from a shared queue, the
            // costliest (by its last step) first so that the last ones to finish are short:
            // the scope's thread starts at once and the pool's join as they wake, so a late
            // thread costs no more than the cloth it would have stepped. Each cloth's step is
            // the same whichever thread runs it; the messages go out in the query's order.
            let mut all: Vec<_> = cloths.iter_mut().enumerate().collect();
            all.sort_by_key(|(_, (_, _, simulation, _, _))| {
                std::cmp::Reverse(simulation.sim.last_timings().total())
            });
            let queue = std::sync::Mutex::new(all.iter_mut().map(|(k, item)| (*k, item)));
            let (queue, context) = (&queue, &context);
            let results = pool.scope(|scope| {
                for _ in 0..threads {
                    scope.spawn(async move {
                        let mut diverged = Vec::new();
                        loop {
                            let next = queue.lock().map(|mut q| q.next());
                            let Ok(Some((k, (entity, cloth, simulation, settings, coupled)))) =
                                next
                            else {
                                break;
                            };
                            if let Some(d) = step_cloth(
                                *entity,
                                cloth,
                                simulation,
                                *settings,
                                coupled.as_deref_mut(),
                                context,
                                &OneThread,
                            ) {
                                diverged.push((k, d));
                            }
                        }
                        diverged
                    });
                }
            });
            let mut results: Vec<_> = results.into_iter().flatten().collect();
            results.sort_unstable_by_key(|(k, _)| *k);
            diverged.write_batch(results.into_iter().map(|(_, d)| d));
        }
        _ => {
            for (entity, cloth, mut simulation, settings, mut coupled) in &mut cloths {
                if let Some(d) = step_cloth(
                    entity,
                    cloth,
                    &mut simulation,
                    settings,
                    coupled.as_deref_mut(),
                    &context,
                    &OneThread,
                ) {
                    diverged.write(d);
                }
            }
        }
    }
    if let Some(mut timings) = timings {
        let mut parts = StepTimings::default();
        for (_, _, simulation, _, _) in &cloths {
            parts.add(simulation.sim.last_timings());
        }
        timings.cloth_parts = parts;
    }
}

/// What every cloth's step reads from the world.
struct StepContext<'a> {
    defaults: &'a ClothSettings,
    drape: &'a DrapeSettings,
    dt: f32,
    elapsed: f32,
    transforms: &'a TransformHelper<'a, 'a>,
    colliders: &'a [SolverCollider],
    wind: Option<&'a super::air::WindField>,
}

/// Steps one cloth (see [`step_cloths`]); what it diverged with, if it did.
fn step_cloth<C: ClothCoupling>(
    entity: Entity,
    cloth: &Cloth,
    simulation: &mut ClothSimulation,
    settings: Option<&ClothSettings>,
    coupled: Option<&mut C>,
    context: &StepContext,
    join: &dyn Join,
) -> Option<ClothDiverged> {
    let dt = context.dt;
    let settings = settings.unwrap_or(context.defaults);
    let sim = &mut simulation.sim;
    simulation.render_from.clone_from(&sim.state().positions);
    if context.drape.paused {
        return None;
    }
    if let Some(frozen_with) = &simulation.frozen_with {
        if frozen_with == settings {
            return None;
        }
        info!("cloth {entity}: settings changed, stepping again");
        simulation.frozen_with = None;
    }
    if let Err(err) = settings.solver.validate() {
        if !simulation.warned_invalid_settings {
            warn!("cloth {entity} is not stepped: {err}");
            simulation.warned_invalid_settings = true;
        }
        return None;
    }
    simulation.warned_invalid_settings = false;
    if settings.density != sim.model().density
        && let Err(err) = sim.set_density(settings.density)
    {
        warn!(
            "cloth {entity}: {err}; keeping density {}",
            sim.model().density
        );
    }
    // The world's colliders, then this cloth's ground and container.
    simulation.colliders.clear();
    simulation.colliders.extend_from_slice(context.colliders);
    settings.plane_colliders(&mut simulation.colliders);
    // The world's colliders were checked when gathered (each reported with its entity);
    // what is left out here is this cloth's own ground or container.
    match sim.set_colliders(&simulation.colliders) {
        Err(err) if !simulation.warned_planes => {
            warn!("cloth {entity}: its ground or container is left out: {err}");
            simulation.warned_planes = true;
        }
        Err(_) => {}
        Ok(()) => simulation.warned_planes = false,
    }

    if let Ok(global) = context.transforms.compute_global_transform(entity) {
        for &v in &cloth.pinned_vertices {
            if let (Some(&rest), Some(&p)) = (
                simulation.local_rest.get(v as usize),
                simulation.vertex_to_particle.get(v as usize),
            ) {
                sim.set_pin_target(p, global.transform_point(rest));
            }
        }
    }
    for attachment in &cloth.attachments {
        match context
            .transforms
            .compute_global_transform(attachment.target)
        {
            Ok(target) => {
                if let Some(&p) = simulation
                    .vertex_to_particle
                    .get(attachment.vertex as usize)
                {
                    sim.set_pin_target(p, target.transform_point(attachment.offset));
                }
            }
            Err(err) => warn!(
                "cloth {entity}: attachment of vertex {} to {}: {err}",
                attachment.vertex, attachment.target
            ),
        }
    }

    // The entity the cloth follows: its motion over this step, a share of it carried.
    simulation.followed = None;
    if let Some(target) = cloth.follow {
        match context
            .transforms
            .compute_global_transform(target)
            .ok()
            .and_then(|g| world_pose(&g))
        {
            Some(pose) => {
                let frame = simulation
                    .follow
                    .step(pose, dt, context.drape.teleport.as_ref());
                sim.follow_frame(&frame, settings.inertia);
                simulation.followed = Some(frame);
                simulation.warned_follow = false;
            }
            None => {
                if !simulation.warned_follow {
                    warn!(
                        "cloth {entity} follows {target}, which has no valid transform: \
                         simulated in the world alone"
                    );
                    simulation.warned_follow = true;
                }
                simulation.follow.reset();
            }
        }
    }

    if settings.solver.air.is_some()
        && let Some(wind) = context.wind
    {
        sim.set_wind(wind, context.elapsed);
    }
    // What is coupled to the cloth (water in it) steps inside the cloth's substeps.
    let stepped = match coupled {
        Some(coupled) => coupled.step_with_cloth(
            entity,
            sim,
            &settings.solver,
            &simulation.colliders,
            context.drape.gravity,
            dt,
        ),
        None => sim.step_with(&settings.solver, context.drape.gravity, dt, join),
    };
    if let Err(err) = stepped {
        if !simulation.warned_step_input {
            warn!("cloth {entity} is not stepped: {err}");
            simulation.warned_step_input = true;
        }
        return None;
    }
    simulation.warned_step_input = false;
    if settings.solver.volume.is_some()
        && let Some(err) = sim.volume_error()
        && !simulation.warned_volume
    {
        warn!("cloth {entity}: {err}; stepped without it");
        simulation.warned_volume = true;
    }

    if let Some(divergence) = sim.divergence(&settings.divergence) {
        let method = settings.solver.method;
        match settings.on_divergence {
            OnDivergence::Freeze => {
                error!(
                    "cloth {entity} diverged with {} ({divergence}); frozen at the previous \
                     step until its settings change",
                    method.name()
                );
                let state = sim.state_mut();
                state.positions.clone_from(&simulation.render_from);
                state.previous_positions.clone_from(&simulation.render_from);
                state.velocities.fill(Vec3A::ZERO);
                simulation.frozen_with = Some(*settings);
            }
            OnDivergence::Reset => {
                error!(
                    "cloth {entity} diverged with {} ({divergence}); reset to its rest shape",
                    method.name()
                );
                simulation.reset();
            }
        }
        return Some(ClothDiverged {
            cloth: entity,
            method,
            divergence,
            response: settings.on_divergence,
        });
    }
    None
}

/// Writes every cloth into its mesh, interpolated between the last two fixed steps: in the
/// world, or, for a cloth that follows an entity, in that entity's frame (so the cloth is
/// drawn on the entity wherever the entity is drawn, interpolated or not).
#[allow(clippy::type_complexity)]
fn write_back_meshes(
    mut cloths: Query<(
        Entity,
        &mut ClothSimulation,
        &Cloth,
        &Mesh3d,
        &GlobalTransform,
        Option<&ClothPaint>,
    )>,
    followed: Query<&GlobalTransform>,
    mut meshes: ResMut<Assets<Mesh>>,
    fixed: Res<Time<Fixed>>,
    debug: Res<ClothDebugColors>,
    timings: Option<ResMut<DrapeTimings>>,
) {
    let start = std::time::Instant::now();
    let alpha = fixed.overstep_fraction().clamp(0.0, 1.0);
    for (entity, mut simulation, cloth, mesh3d, global, paint) in &mut cloths {
        let simulation = &mut *simulation;
        let Some(mut mesh) = meshes.get_mut(&mesh3d.0) else {
            continue;
        };
        // Debug colours first: per-triangle colours draw the mesh with a vertex per corner.
        let (target, mismatch) =
            debug_colors(&simulation.sim, debug.0, paint, &mut simulation.colors);
        match mismatch {
            Some(m) if !simulation.warned_paint => {
                warn!(
                    "cloth {entity}: its ClothPaint has {} entries for {} {} (shown grey)",
                    m.found,
                    m.expected,
                    match m.target {
                        PaintTarget::Particles => "particles",
                        PaintTarget::Triangles => "triangles",
                    }
                );
                simulation.warned_paint = true;
            }
            Some(_) => {}
            None => simulation.warned_paint = false,
        }
        let per_triangle = !simulation.colors.is_empty() && target == PaintTarget::Triangles;
        let to_local = global.affine().inverse();
        // The followed entity's poses at the last two fixed steps and as drawn now.
        let frame = simulation.followed.zip(
            cloth
                .follow
                .and_then(|e| followed.get(e).ok())
                .and_then(world_pose),
        );
        let current = &simulation.sim.state().positions;
        if current.len() != simulation.render_from.len() {
            continue;
        }
        // Interpolated particle positions in the world, then the colliders as drawn near
        // them, which every drawn point is kept outside (`collide/skin.rs`): the particles
        // here, a finer render mesh's vertices as it is written.
        simulation.drawn_world.clear();
        simulation
            .drawn_world
            .extend(
                simulation
                    .render_from
                    .iter()
                    .zip(current)
                    .map(|(&from, &to)| match &frame {
                        Some((step, drawn)) => drawn.transform_point(
                            step.start
                                .inverse_transform_point(from)
                                .lerp(step.end.inverse_transform_point(to), alpha),
                        ),
                        None => from.lerp(to, alpha),
                    }),
            );
        let colliders = simulation.sim.colliders();
        drawn_poses(
            colliders,
            alpha,
            frame.as_ref().map(|(step, drawn)| (step, drawn)),
            &mut simulation.drawn_poses,
        );
        simulation.skin.prepare(
            colliders,
            &simulation.drawn_poses,
            simulation.sim.contact_thickness(),
            &simulation.drawn_world,
        );
        let skin = &simulation.skin;
        simulation.local_positions.clear();
        simulation
            .local_positions
            .extend(simulation.drawn_world.iter().map(|&world| {
                to_local
                    .transform_point3a(skin.push_out(colliders, world))
                    .to_array()
            }));
        let triangles = &simulation.sim.model().triangles;
        vertex_normals(
            &simulation.local_positions,
            triangles,
            &mut simulation.normals,
        );
        if let Some(render) = simulation.render.as_mut() {
            // A finer mesh drawn over the simulated one.
            let colors =
                (!simulation.colors.is_empty()).then_some((&simulation.colors[..], target));
            let to_world = global.affine();
            render.write(
                &mut mesh,
                &simulation.local_positions,
                &simulation.normals,
                triangles,
                colors,
                &mut simulation.vertex_colors,
                |p| {
                    let world = skin.push_out(colliders, to_world.transform_point3a(p.into()));
                    to_local.transform_point3a(world).into()
                },
            );
            let colors = if colors.is_some() {
                &simulation.vertex_colors
            } else {
                &simulation.base_colors
            };
            write_colors(&mut mesh, colors);
            continue;
        }
        simulation.flat.set(
            &mut mesh,
            per_triangle,
            &simulation.vertex_to_particle,
            triangles,
        );
        let map = simulation
            .flat
            .corner_to_particle()
            .unwrap_or(&simulation.vertex_to_particle);
        let Ok(Some(VertexAttributeValues::Float32x3(positions))) =
            mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_POSITION)
        else {
            continue;
        };
        if positions.len() != map.len() || map.iter().any(|&p| p as usize >= current.len()) {
            continue;
        }
        for (out, &p) in positions.iter_mut().zip(map) {
            let at = simulation.local_positions[p as usize];
            if at.iter().all(|c| c.is_finite()) {
                *out = at;
            }
        }
        // Normals per particle (smooth across welded seams), then per vertex.
        let normals = map
            .iter()
            .map(|&p| simulation.normals[p as usize].to_array());
        write_normals(&mut mesh, normals);
        let colors = if simulation.colors.is_empty() {
            &simulation.base_colors
        } else {
            simulation.vertex_colors.clear();
            if per_triangle {
                let flat = &simulation.flat;
                let colors = &simulation.colors;
                simulation
                    .vertex_colors
                    .extend((0..map.len()).map(|corner| {
                        flat.model_triangle(corner)
                            .and_then(|t| colors.get(t))
                            .copied()
                            .unwrap_or(GREY)
                    }));
            } else {
                simulation
                    .vertex_colors
                    .extend(map.iter().map(|&p| simulation.colors[p as usize]));
            }
            &simulation.vertex_colors
        };
        write_colors(&mut mesh, colors);
    }
    if let Some(mut timings) = timings {
        timings.write_back = start.elapsed();
    }
}

impl FileValue for ClothSettings {
    const EXTENSION: &'static str = "cloth.ron";
}

/// On a cloth: its [`ClothSettings`] from a `.cloth.ron` file
/// (`ClothSettingsFile::new(server.load("settings/x.cloth.ron"))`).
pub type ClothSettingsFile = FromFile<ClothSettings>;
