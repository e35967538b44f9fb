//! What the integration tests share: the headless App, the random generator and a few
//! helpers to spawn a grid cloth and read it back. The integration binary (`tests/main.rs`) and
//! the `avian` binary each compile it (`mod common;`); the tests reach it as `crate::common`.
// The avian binary uses only some of these items.
#![allow(dead_code, unused_imports)]

use std::time::{Duration, Instant};

use bevy::app::Plugins;
use bevy::asset::AssetPlugin;
use bevy::mesh::{Mesh, MeshPlugin, MeshVertexAttribute, VertexAttributeValues};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_drape::cloth::{ClothModel, ClothSolver};
use bevy_drape::prelude::*;

/// The one random generator of the crate's tests (`bevy_drape::rng`: the library's `internals`
/// feature, which the harness `drape_scenes` turns on).
pub(crate) use bevy_drape::rng::Rng;

pub(crate) mod moving;
pub(crate) mod warnings;

/// Updates `app` with time standing still until `ready` (a scene file loaded, its animation
/// playing), at most 60 s of wall time, then lets time run at 1/60 s per update.
pub(crate) fn update_until_loaded(app: &mut App, mut ready: impl FnMut(&mut World) -> bool) {
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        app.update();
        if ready(app.world_mut()) {
            break;
        }
        assert!(Instant::now() < deadline, "the scene did not load");
        std::thread::sleep(Duration::from_millis(2));
    }
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
}

/// Whether any `AnimationPlayer` in `world` is playing an animation.
pub(crate) fn an_animation_plays(world: &mut World) -> bool {
    world
        .query::<&AnimationPlayer>()
        .iter(world)
        .any(|p| p.playing_animations().next().is_some())
}

/// A free 1 m square of `n` x `n` particles, 0.1 kg/m², flat at 2 m, centred on the Y axis.
pub(crate) fn free_grid(n: u32) -> ClothSolver {
    let grid = GridDesc::square(1.0, n, Vec3::new(-0.5, 2.0, -0.5));
    ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap())
}

/// A headless App as the tests build it: `MinimalPlugins`, `TransformPlugin`, an
/// `AssetPlugin`, `MeshPlugin` and the crate's plugins, with time advancing by a fixed
/// duration per update (the first update has a zero delta).
///
/// ```ignore
/// let app = Headless::new().seconds_per_update(1.0 / 60.0).fixed_hz(60.0).build();
/// ```
pub(crate) struct Headless {
    seconds_per_update: f64,
    fixed_hz: Option<f64>,
    assets: AssetPlugin,
    drape: DrapePlugins,
}

impl Default for Headless {
    /// 1/64 s per update, Bevy's fixed timestep, the default `AssetPlugin` (files under
    /// `assets/`), `DrapePlugins::default()`.
    fn default() -> Self {
        Self {
            seconds_per_update: 1.0 / 64.0,
            fixed_hz: None,
            assets: AssetPlugin::default(),
            drape: DrapePlugins::default(),
        }
    }
}

impl Headless {
    /// The defaults: see [`Headless::default`].
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Time advances by `seconds` per update.
    pub(crate) fn seconds_per_update(mut self, seconds: f64) -> Self {
        self.seconds_per_update = seconds;
        self
    }

    /// The fixed timestep at `hz` steps per second (`Time::<Fixed>::from_hz`).
    pub(crate) fn fixed_hz(mut self, hz: f64) -> Self {
        self.fixed_hz = Some(hz);
        self
    }

    /// Asset files read under `root`.
    pub(crate) fn asset_root(mut self, root: impl Into<String>) -> Self {
        self.assets = AssetPlugin {
            file_path: root.into(),
            ..default()
        };
        self
    }

    /// The crate's plugins as given (another simulation schedule, say).
    pub(crate) fn drape(mut self, drape: DrapePlugins) -> Self {
        self.drape = drape;
        self
    }

    /// The App.
    pub(crate) fn build(self) -> App {
        self.build_with((), ())
    }

    /// The App with `before` added just before the crate's plugins and `after` just after
    /// them.
    pub(crate) fn build_with<B, A>(self, before: impl Plugins<B>, after: impl Plugins<A>) -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, TransformPlugin, self.assets, MeshPlugin))
            .add_plugins(before)
            .add_plugins(self.drape)
            .add_plugins(after);
        if let Some(hz) = self.fixed_hz {
            app.insert_resource(Time::<Fixed>::from_hz(hz));
        }
        app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
            self.seconds_per_update,
        )));
        app
    }
}

/// A headless App with the crate's default plugins, stepping 1/64 s per update.
pub(crate) fn app() -> App {
    Headless::new().build()
}

/// A headless App with `drape`, stepping 1/64 s per update.
pub(crate) fn app_with(drape: DrapePlugins) -> App {
    Headless::new().drape(drape).build()
}

/// Adds the grid's mesh to the App's meshes.
pub(crate) fn add_grid(app: &mut App, grid: &GridDesc) -> Handle<Mesh> {
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(grid_mesh(grid))
}

/// Spawns the grid as a cloth entity.
pub(crate) fn spawn_cloth(
    app: &mut App,
    grid: &GridDesc,
    cloth: Cloth,
    transform: Transform,
) -> Entity {
    let mesh = add_grid(app, grid);
    app.world_mut().spawn((Mesh3d(mesh), cloth, transform)).id()
}

/// A `Float32x3` attribute of the entity's mesh.
pub(crate) fn attribute(app: &App, entity: Entity, name: MeshVertexAttribute) -> Vec<Vec3> {
    let handle = &app.world().get::<Mesh3d>(entity).unwrap().0;
    let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
    match mesh.attribute(name).unwrap() {
        VertexAttributeValues::Float32x3(p) => p.iter().map(|&p| Vec3::from_array(p)).collect(),
        _ => panic!("Float32x3"),
    }
}

/// The drawn positions of the entity's mesh.
pub(crate) fn positions(app: &App, entity: Entity) -> Vec<Vec3> {
    attribute(app, entity, Mesh::ATTRIBUTE_POSITION)
}

/// The particles of the entity's built cloth, as the solver holds them.
pub(crate) fn particles(app: &App, cloth: Entity) -> Vec<Vec3> {
    app.world()
        .get::<ClothSimulation>(cloth)
        .expect("the cloth was built")
        .solver()
        .state()
        .positions
        .iter()
        .map(|&p| p.into())
        .collect()
}

/// The signed dihedral angle, radians in (-pi, pi], of the triangles `(x0, x1, x2)` and
/// `(x1, x0, x3)` of `x` for `particles = [x0, x1, x2, x3]` (a bending pair as
/// `ClothModel::bending_pairs` lists it), computed here rather than by the solver.
pub(crate) fn dihedral_angle(x: &[Vec3A], particles: [u32; 4]) -> f32 {
    let [x0, x1, x2, x3] = particles.map(|i| Vec3::from(x[i as usize]));
    let e = x1 - x0;
    let m1 = e.cross(x2 - x0);
    let m2 = (x0 - x1).cross(x3 - x1);
    m1.cross(m2).dot(e.normalize()).atan2(m1.dot(m2))
}

/// The mean of `|theta - rest angle|` over the cloth's bending pairs, radians.
pub(crate) fn bending_error(sim: &ClothSolver) -> f32 {
    let pairs = &sim.model().bending_pairs;
    let x = &sim.state().positions;
    let total: f32 = pairs
        .iter()
        .map(|p| (dihedral_angle(x, p.particles) - p.rest_angle).abs())
        .sum();
    total / pairs.len() as f32
}

/// Rolls a cloth lying flat in a horizontal plane round a cylinder of `radius` with its axis
/// along Z (lengths along X kept as arc lengths from the cloth's edge at the smallest X), and
/// stops it.
pub(crate) fn roll(sim: &mut ClothSolver, radius: f32) {
    let state = sim.state_mut();
    let start = state.positions.iter().map(|p| p.x).fold(f32::MAX, f32::min);
    for p in &mut state.positions {
        let angle = (p.x - start) / radius;
        p.x = start + radius * angle.sin();
        p.y += radius * (1.0 - angle.cos());
    }
    state.previous_positions.clone_from(&state.positions);
    state.velocities.fill(Vec3A::ZERO);
}
