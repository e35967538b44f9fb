//! Scene S3, the main scene: a poncho drapes over the humanoid while it walks in place and, now
//! and then, waves its right hand (inverse kinematics on top of the walk clip).
//!
//! [`PonchoScenePlugin`] spawns everything but what is drawn: the character ([`Skeleton`] with
//! the walk clip, [`BoneColliders::humanoid`] proxies and an IK goal for the wave), a ground
//! plane collider and the poncho cloth ([`Poncho`]), from `meshes/poncho.obj` (written by
//! `cargo run --example generate_poncho`) or generated in memory. Add materials and meshes to
//! the [`Poncho`] and the bones to see it; the `poncho` example does. It runs headless with
//! `MinimalPlugins` as well (the `scenes` runner's `s3` and the tests).

use std::f32::consts::TAU;
use std::sync::Arc;

use bevy::prelude::*;

use crate::cloth::PonchoDesc;
use crate::cloth::mesh::grid_mesh_from;
use crate::cloth::plugin::{Cloth, ClothSettings};
use crate::cloth::settings::SolverSettings;
use crate::collide::plugin::ClothCollider;
use crate::schedule::DrapeTimings;
use crate::skeleton::humanoid::humanoid;
use crate::skeleton::ik::IkSettings;
use crate::skeleton::plugin::{
    BoneColliders, ClipPlayer, IkGoal, IkTarget, InverseKinematics, Skeleton,
};

/// Where the poncho comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum PonchoSource {
    /// An OBJ file in the assets folder, loaded with the asset server (needs
    /// [`bevy_obj::ObjPlugin`], which [`PonchoScenePlugin`] adds).
    Asset(String),
    /// A pattern generated in memory.
    Pattern(PonchoDesc),
}

/// The scene's parameters, read when it is spawned.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct PonchoScene {
    /// The poncho mesh. Default: `meshes/poncho.obj`.
    pub source: PonchoSource,
    /// The poncho's solver settings. Default: XPBD, 8 substeps x 2 iterations,
    /// self-collision on.
    pub solver: SolverSettings,
    /// Areal density of the poncho, kg/m^2. Default: `0.25`.
    pub density: f32,
    /// Height of the flat poncho when the scene starts, metres (the shoulders are at 1.46 m).
    /// Default: `1.5`.
    pub start_height: f32,
    /// Whether the character waves with its right hand. Default: `true`.
    pub wave: bool,
}

impl Default for PonchoScene {
    fn default() -> Self {
        Self {
            source: PonchoSource::Asset("meshes/poncho.obj".into()),
            solver: SolverSettings {
                self_collision: true,
                ..SolverSettings::default()
            },
            density: 0.25,
            start_height: 1.5,
            wave: true,
        }
    }
}

/// Marks the poncho cloth.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct Poncho;

/// Marks the character.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct Character;

/// Spawns the poncho scene at `Startup` (with the [`PonchoScene`] resource, default if
/// absent) and moves the wave's IK target.
pub struct PonchoScenePlugin;

impl Plugin for PonchoScenePlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<bevy_obj::ObjPlugin>() {
            app.add_plugins(bevy_obj::ObjPlugin);
        }
        app.init_resource::<PonchoScene>()
            .add_systems(Startup, spawn_poncho_scene)
            .add_systems(FixedUpdate, wave);
    }
}

/// The wrist in the forearm's frame.
const WRIST: Vec3 = Vec3::new(0.0, -0.25, 0.0);
/// The wave's cycle: the hand rises at 2 s, waves and comes down at 6 s, every 8 s.
const WAVE_CYCLE: f32 = 8.0;
const WAVE_FROM: f32 = 2.0;
const WAVE_TO: f32 = 6.0;

/// The IK goal's weight and target at time `t` of the scene: the right hand raised beside the
/// head, swinging sideways once a second.
pub fn wave_at(t: f32) -> (f32, Vec3) {
    let phase = t.rem_euclid(WAVE_CYCLE);
    let ramp = |x: f32| {
        let x = x.clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    };
    let weight = ramp((phase - WAVE_FROM) / 0.6) * ramp((WAVE_TO - phase) / 0.6);
    let swing = (TAU * t).sin();
    (weight, Vec3::new(-0.38 + 0.1 * swing, 1.72, 0.12))
}

fn spawn_poncho_scene(
    mut commands: Commands,
    scene: Res<PonchoScene>,
    assets: Option<Res<AssetServer>>,
    mut meshes: ResMut<Assets<Mesh>>,
) {
    let mesh = match &scene.source {
        PonchoSource::Asset(path) => match &assets {
            Some(assets) => assets.load(path.clone()),
            None => {
                error!("poncho scene: no asset server to load {path}; using the default pattern");
                meshes.add(poncho_mesh(&PonchoDesc::default()))
            }
        },
        PonchoSource::Pattern(desc) => meshes.add(poncho_mesh(desc)),
    };
    let character = commands
        .spawn((
            Name::new("character"),
            Character,
            Skeleton {
                rig: Arc::new(humanoid()),
            },
            BoneColliders::humanoid(),
            InverseKinematics {
                goals: vec![IkGoal {
                    end_bone: "forearm_r".into(),
                    length: 3,
                    effector: WRIST,
                    target: IkTarget::Point(wave_at(0.0).1),
                    settings: IkSettings::default(),
                    weight: 0.0,
                }],
                results: Vec::new(),
            },
            Transform::default(),
        ))
        .id();
    if let Some(assets) = &assets {
        commands
            .entity(character)
            .insert(ClipPlayer::new(assets.load("clips/walk.clip.ron")));
    }
    commands.spawn((
        Name::new("ground"),
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    commands.spawn((
        Name::new("poncho"),
        Poncho,
        Mesh3d(mesh),
        Cloth::default(),
        ClothSettings {
            density: scene.density,
            solver: scene.solver,
            ..default()
        },
        Transform::from_xyz(0.0, scene.start_height, 0.0),
    ));
}

fn wave(
    scene: Res<PonchoScene>,
    time: Res<Time>,
    mut characters: Query<&mut InverseKinematics, With<Character>>,
) {
    for mut ik in &mut characters {
        if let Some(goal) = ik.goals.first_mut() {
            let (weight, target) = if scene.wave {
                wave_at(time.elapsed_secs())
            } else {
                (0.0, goal_point(&goal.target))
            };
            goal.weight = weight;
            goal.target = IkTarget::Point(target);
        }
    }
}

fn goal_point(target: &IkTarget) -> Vec3 {
    match target {
        IkTarget::Point(p) => *p,
        _ => Vec3::ZERO,
    }
}

/// The poncho pattern as a mesh, or the default one if `desc` makes no poncho (logged).
pub fn poncho_mesh(desc: &PonchoDesc) -> Mesh {
    match desc.mesh() {
        Ok(m) => grid_mesh_from(&m),
        Err(e) => {
            error!("poncho scene: {e}; using the default pattern");
            grid_mesh_from(
                &PonchoDesc::default()
                    .mesh()
                    .expect("the default poncho is valid by construction"),
            )
        }
    }
}

/// The figures of one headless run of the scene (scene S3 of `BENCHMARKS.md`).
#[derive(Clone, Debug, Default)]
pub struct PonchoRun {
    /// Wall time of every fixed step, by stage (see [`DrapeTimings`]), milliseconds:
    /// `[animation, inverse kinematics, colliders, cloth]`.
    pub stage_ms: Vec<[f64; 4]>,
    /// The deepest any particle was inside any capsule or sphere proxy after any step, metres
    /// (measured from the proxy's surface, without its margin; 0 if none was).
    pub deepest_penetration: f32,
    /// Largest structural strain after any step.
    pub max_strain: f32,
    /// The farthest the poncho's centroid was from the chest bone after any step, metres.
    pub max_centroid_offset: f32,
    /// Whether every position stayed finite.
    pub finite: bool,
    /// Particles in the poncho.
    pub particles: usize,
    /// Fixed steps run.
    pub steps: u32,
}

impl PonchoRun {
    /// The run's figures as one JSON object (the `scenes` runner's `s3` line), with the
    /// solver settings it ran with.
    pub fn json(&self, solver: &SolverSettings) -> String {
        format!(
            "{{\"scene\":\"s3\",\"particles\":{},\"method\":\"{}\",\"self_collision\":{},\"substeps\":{},\"iterations\":{},\"frames\":{},\"ms_per_frame\":{:.4},\"ms_animation\":{:.4},\"ms_ik\":{:.4},\"ms_colliders\":{:.4},\"ms_cloth\":{:.4},\"deepest_penetration\":{:.6},\"max_strain\":{:.6},\"max_centroid_offset\":{:.4},\"finite\":{}}}",
            self.particles,
            solver.method.name(),
            solver.self_collision,
            solver.substeps,
            solver.iterations,
            self.steps,
            self.median_ms(4),
            self.median_ms(0),
            self.median_ms(1),
            self.median_ms(2),
            self.median_ms(3),
            self.deepest_penetration,
            self.max_strain,
            self.max_centroid_offset,
            self.finite
        )
    }

    /// The median of one stage's times (`0..4`, see [`PonchoRun::stage_ms`]), or of the whole
    /// step (`4`), milliseconds.
    pub fn median_ms(&self, stage: usize) -> f64 {
        let values: Vec<f64> = self
            .stage_ms
            .iter()
            .map(|s| if stage < 4 { s[stage] } else { s.iter().sum() })
            .collect();
        crate::scenes::median(&values)
    }
}

/// A headless App (`MinimalPlugins`, transforms, assets, meshes) with [`crate::DrapePlugins`]
/// and the scene, stepping one 1/60 s fixed step per update.
pub fn headless_app(scene: PonchoScene) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        bevy::mesh::MeshPlugin,
        crate::DrapePlugins::default(),
        PonchoScenePlugin,
    ))
    .insert_resource(scene)
    .insert_resource(Time::<Fixed>::from_hz(60.0));
    app
}

/// Runs the scene headless for `steps` fixed steps at 60 Hz (after waiting for its files to
/// load) and measures it after every step.
pub fn run_headless(scene: PonchoScene, steps: u32) -> PonchoRun {
    use bevy::time::TimeUpdateStrategy;
    use std::time::Duration;

    let mut app = headless_app(scene);
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    // Wait (with time standing still) until the poncho is built and the clip is playing.
    for _ in 0..2000 {
        app.update();
        let world = app.world_mut();
        let built = world
            .query_filtered::<(), (With<Poncho>, With<crate::cloth::plugin::ClothSimulation>)>()
            .iter(world)
            .next()
            .is_some();
        let clip_loaded = {
            let clips = world.resource::<Assets<crate::skeleton::plugin::ClipAsset>>();
            !clips.is_empty()
        };
        let failed = world
            .query_filtered::<(), (With<Poncho>, With<crate::cloth::plugin::ClothBuildError>)>()
            .iter(world)
            .next()
            .is_some();
        if (built && clip_loaded) || failed {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
    let mut run = PonchoRun {
        finite: true,
        ..default()
    };
    let mut last_step = app.world().resource::<DrapeTimings>().steps;
    // The first update after the wait has a zero delta.
    app.update();
    while run.steps < steps {
        app.update();
        let timings = app.world().resource::<DrapeTimings>().clone();
        if timings.steps == last_step {
            continue;
        }
        last_step = timings.steps;
        run.steps += 1;
        let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
        run.stage_ms.push([
            ms(timings.animation),
            ms(timings.inverse_kinematics),
            ms(timings.colliders),
            ms(timings.cloth),
        ]);
        measure(&mut app, &mut run);
    }
    run
}

fn measure(app: &mut App, run: &mut PonchoRun) {
    use crate::collide::Shape;
    let world = app.world_mut();
    let chest = world
        .query_filtered::<&crate::skeleton::plugin::SkeletonBones, With<Character>>()
        .iter(world)
        .next()
        .and_then(|bones| bones.get("chest"));
    let chest = chest
        .and_then(|e| world.get::<GlobalTransform>(e))
        .map(|g| g.translation());
    let mut ponchos =
        world.query_filtered::<&crate::cloth::plugin::ClothSimulation, With<Poncho>>();
    for simulation in ponchos.iter(world) {
        let sim = simulation.sim();
        let x = &sim.state().positions;
        run.particles = x.len();
        run.finite &= sim.is_finite();
        run.max_strain = run.max_strain.max(sim.strain().max);

        for c in sim.colliders() {
            if matches!(c.shape, Shape::Plane) {
                continue;
            }
            for &p in x {
                if let Some(d) = c.signed_distance(p, 0.0) {
                    run.deepest_penetration = run.deepest_penetration.max(-d);
                }
            }
        }
        if let Some(chest) = chest
            && !x.is_empty()
        {
            let centroid: Vec3 =
                Vec3::from(x.iter().copied().sum::<bevy::math::Vec3A>()) / x.len() as f32;
            run.max_centroid_offset = run.max_centroid_offset.max(centroid.distance(chest));
        }
    }
}
