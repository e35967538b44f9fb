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

use bevy_drape::cloth::PonchoDesc;
use bevy_drape::cloth::mesh::grid_mesh_from;
use bevy_drape::cloth::plugin::{Cloth, ClothLayers, ClothSettings};
use bevy_drape::cloth::render_mesh::ClothSimulationMesh;
use bevy_drape::cloth::{DivergenceBounds, ExactEdges, SelfCollisionMethod, SolverSettings};
use bevy_drape::collide::plugin::ClothCollider;
use bevy_drape::schedule::DrapeSystems;
use bevy_drape::skeleton::humanoid::humanoid;
use bevy_drape::skeleton::ik::IkSettings;
use bevy_drape::skeleton::plugin::{
    BoneColliders, ClipPlayer, IkGoal, IkTarget, InverseKinematics, Skeleton,
};

mod measure;
mod motion;
mod run;

pub use motion::{CROWD_MOTIONS, CharacterController, CharacterMotion, SETTLE_SECONDS};
pub use run::{LOAD_TIMEOUT, PonchoRun, STRAIN_BIN, headless_app, run_app, run_headless};

/// Vertices per side of the coarse poncho the scene simulates (`meshes/poncho_coarse.obj`):
/// it drapes like the drawn 41 x 41 one (the hem's height and the centroid's offset from the
/// chest within 3 cm in every motion) at a ninth of its cost, and unlike 15 x 15 it stays on
/// the character at 4 x 2.
pub const COARSE_PONCHO_VERTICES: u32 = 17;

/// Where the poncho comes from.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub enum PonchoSource {
    /// An OBJ file in the assets folder, loaded with the asset server (needs
    /// [`bevy_obj::ObjPlugin`], which [`PonchoScenePlugin`] adds).
    Asset(String),
    /// A pattern generated in memory.
    Pattern(PonchoDesc),
}

/// The scene's parameters, read when it is spawned.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct PonchoScene {
    /// The poncho mesh drawn (and simulated, unless `simulated` names another). Default:
    /// `meshes/poncho.obj`.
    pub source: PonchoSource,
    /// The mesh the poncho is simulated on, if not `source` ([`ClothSimulationMesh`]).
    /// Default: `meshes/poncho_coarse.obj` (the same pattern with [`COARSE_PONCHO_VERTICES`]
    /// per side).
    pub simulated: Option<PonchoSource>,
    /// The poncho's solver settings. Default: the library's ([`SolverSettings::default`]:
    /// XPBD, 8 substeps x 2 iterations, the structural edges solved exactly while the cloth
    /// touches a collider), self-collision on, a soft shear
    /// (`shear_compliance` 0.1 m/N: the pattern's quad diagonals give, as a woven cloth's bias
    /// does; left out entirely, the cloth folds so readily that at 8 x 4 the waving arm traps
    /// folds in self-contact, stretched 12%), and the exact edges solved again after a deep
    /// closing push ([`ExactEdges::closing_rounds`] 4: the hem pinched between a swinging hand
    /// and the thigh stretched an edge 13.9% in 100,000 steps of the tour without it, 1.0%
    /// with it).
    pub solver: SolverSettings,
    /// Areal density of the poncho, kg/m^2. Default: `0.25`.
    pub density: f32,
    /// Height of the flat poncho when the scene starts, metres (the shoulders are at 1.46 m).
    /// Default: `1.5`.
    pub start_height: f32,
    /// Whether the character waves with its right hand. Default: `true`.
    pub wave: bool,
    /// How the character moves through the world. Default: [`CharacterMotion::InPlace`].
    pub motion: CharacterMotion,
    /// The poncho's [`ClothSettings::inertia`]. Default: `1.0`.
    pub inertia: f32,
    /// The poncho's [`ClothSettings::speed_limit`]. Default: the cloth's default.
    pub speed_limit: Option<f32>,
    /// Characters in ponchos, standing in a row along +X 4 m apart: the first makes
    /// `motion`, the others [`CROWD_MOTIONS`] in turn (the `crowd` scene). Default: `1`.
    pub characters: u32,
    /// How many of the crowd's characters (the last ones in the row) stand still
    /// ([`CharacterMotion::Stand`], no wave) instead of making their motion. Default: `0`.
    pub standing: u32,
    /// Garments on each character: `1`, the poncho; `2`, a [`Shawl`] under it, the two
    /// stepped as layers of one solve ([`ClothLayers`]). Default: `1`.
    pub layers: u32,
    /// When the poncho counts as diverged. Default: strain 200%, speed 500 m/s. Walking, its
    /// collar can snag on the neck and stretch one edge past 100% for a few steps (the
    /// largest seen in 100,000 steps of walking was 134%, after which it let go); a method
    /// that blows up passes any bound within a few steps.
    pub divergence: DivergenceBounds,
}

impl Default for PonchoScene {
    fn default() -> Self {
        Self {
            source: PonchoSource::Asset("meshes/poncho.obj".into()),
            simulated: Some(PonchoSource::Asset("meshes/poncho_coarse.obj".into())),
            solver: SolverSettings {
                self_collision: SelfCollisionMethod::Particles,
                shear_compliance: 0.1,
                exact_edges: Some(ExactEdges {
                    closing_rounds: 4,
                    ..ExactEdges::default()
                }),
                ..SolverSettings::default()
            },
            density: 0.25,
            start_height: 1.5,
            wave: true,
            motion: CharacterMotion::InPlace,
            inertia: 1.0,
            speed_limit: ClothSettings::default().speed_limit,
            characters: 1,
            standing: 0,
            layers: 1,
            divergence: DivergenceBounds {
                max_strain: 2.0,
                ..DivergenceBounds::default()
            },
        }
    }
}

/// Marks the poncho cloth.
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct Poncho;

/// Marks the shawl, the inner layer under the poncho ([`PonchoScene::layers`] = 2).
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct Shawl;

/// The shawl's pattern: a 0.8 m square of 11 x 11 vertices (8 cm apart, as the coarse
/// poncho's) with the poncho's neck hole. It covers the shoulders, the upper arms and the
/// chest, under the poncho.
pub const SHAWL: PonchoDesc = PonchoDesc {
    size: 0.8,
    vertices: 11,
    neck_radius: 0.1,
};

/// How far above the shawl the poncho starts, metres: just farther apart than the gap the
/// layers are kept at (3.5 cm for these patterns), so that each starts on its side. The
/// second garment's landing is the run's worst moment: the worst edge after the first second
/// was 0.75-1.4% (walk, jog, the tour) starting 4 cm apart, 0.25-2.0% at 5 cm, 0.5-2.5% at
/// 8 cm.
pub const LAYER_GAP: f32 = 0.04;

/// Marks the character.
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct Character;

/// How far apart the characters of a crowd stand, metres.
const CROWD_SPACING: f32 = 4.0;

/// Spawns the poncho scene at `Startup` (with the [`PonchoScene`] resource, default if
/// absent), with the characters' motion of [`CharacterMotionPlugin`].
pub struct PonchoScenePlugin;

impl Plugin for PonchoScenePlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<bevy_obj::ObjPlugin>() {
            app.add_plugins(bevy_obj::ObjPlugin);
        }
        if !app.is_plugin_added::<CharacterMotionPlugin>() {
            app.add_plugins(CharacterMotionPlugin);
        }
        app.register_type::<(PonchoScene, Poncho, Shawl)>()
            .init_resource::<PonchoScene>()
            .add_systems(Startup, spawn_poncho_scene);
    }
}

/// Moves every [`Character`] by its [`CharacterController`] (its clip's pace following its
/// speed) and raises the right hand of every [`Waving`] one by its IK goal: the motion a game's
/// controller gives its characters, spawned by [`PonchoScenePlugin`] or by an example itself.
pub struct CharacterMotionPlugin;

impl Plugin for CharacterMotionPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<WavePlugin>() {
            app.add_plugins(WavePlugin);
        }
        app.register_type::<(Character, CharacterController)>()
            // As a game's controller would, in `FixedUpdate`; ordered before the drape sets
            // should the drape schedule be `FixedUpdate` too.
            .add_systems(FixedUpdate, drive_characters.before(DrapeSystems::Prepare));
    }
}

/// Raises the right hand of every [`Waving`] entity by the first goal of its
/// `InverseKinematics` ([`wave_at`]), and lowers it (weight 0) on a [`Character`] that is not
/// waving: a [`Skeleton`] character or a glTF one alike.
pub struct WavePlugin;

impl Plugin for WavePlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<Waving>()
            .add_systems(FixedUpdate, wave.before(DrapeSystems::Prepare));
    }
}

/// An entity whose first IK goal waves its right hand now and then ([`wave_at`]); a
/// [`Character`] without it has the goal's weight at 0 and the clip moves the arm.
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct Waving;

/// The wrist in the forearm's frame (the wave's IK effector).
pub const WRIST: Vec3 = Vec3::new(0.0, -0.25, 0.0);
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

/// Moves every character with a [`CharacterController`] and sets its clip's speed.
fn drive_characters(
    mut characters: Query<(
        &Skeleton,
        &mut CharacterController,
        &mut Transform,
        Option<&mut ClipPlayer>,
    )>,
    clips: Res<Assets<bevy_drape::skeleton::plugin::ClipAsset>>,
    time: Res<Time>,
) {
    for (skeleton, mut controller, mut transform, player) in &mut characters {
        let Some(mut player) = player else {
            continue;
        };
        if controller.stance_speed.is_none()
            && let Some(asset) = clips.get(&player.clip)
        {
            let rig = &skeleton.rig;
            let feet: Vec<usize> = ["foot_l", "foot_r"]
                .iter()
                .filter_map(|f| rig.find(f))
                .collect();
            controller.stance_speed = bevy_drape::skeleton::clip::Clip::new(&asset.0, rig)
                .ok()
                .and_then(|clip| clip.stance_speed(rig, &feet, Vec3::Z));
        }
        if controller.stance_speed.is_none() && !controller.motion.legs().is_empty() {
            // The clip is not loaded yet: wait with the motion too.
            continue;
        }
        player.speed = controller.advance(time.delta_secs(), &mut transform);
    }
}

fn spawn_poncho_scene(
    mut commands: Commands,
    scene: Res<PonchoScene>,
    assets: Option<Res<AssetServer>>,
    mut meshes: ResMut<Assets<Mesh>>,
) {
    let mut mesh_of = |source: &PonchoSource| match source {
        PonchoSource::Asset(path) => match &assets {
            Some(assets) => assets.load(path.clone()),
            None => {
                error!("poncho scene: no asset server to load {path}; using the default pattern");
                meshes.add(poncho_mesh(&PonchoDesc::default()))
            }
        },
        PonchoSource::Pattern(desc) => meshes.add(poncho_mesh(desc)),
    };
    let mesh = mesh_of(&scene.source);
    let simulated = scene.simulated.as_ref().map(&mut mesh_of);
    let shawl_mesh = mesh_of(&PonchoSource::Pattern(SHAWL));
    commands.spawn((
        Name::new("ground"),
        ClothCollider::plane().with_friction(0.6),
        Transform::default(),
    ));
    let characters = scene.characters.max(1);
    for i in 0..characters {
        let motion = match i {
            i if i + scene.standing >= characters => CharacterMotion::Stand,
            0 => scene.motion,
            i => CROWD_MOTIONS[(i as usize - 1) % CROWD_MOTIONS.len()],
        };
        let at = Vec3::X * (i as f32 * CROWD_SPACING);
        let character = commands
            .spawn((
                Name::new(numbered("character", i)),
                Character,
                CharacterController::new(motion),
                Skeleton {
                    rig: Arc::new(humanoid()),
                },
                BoneColliders::humanoid(),
                InverseKinematics {
                    goals: vec![IkGoal {
                        end_bone: "forearm_r".into(),
                        length: 3,
                        effector: WRIST,
                        target: IkTarget::CharacterPoint(wave_at(0.0).1),
                        settings: IkSettings::default(),
                        weight: 0.0,
                        max_speed: IkGoal::DEFAULT_MAX_SPEED,
                        joint_limits: Vec::new(),
                    }],
                    results: Vec::new(),
                },
                Transform::from_translation(at),
            ))
            .id();
        if let Some(assets) = &assets {
            commands
                .entity(character)
                .insert(ClipPlayer::new(assets.load("clips/walk.clip.ron")));
        }
        let settings = ClothSettings {
            density: scene.density,
            solver: scene.solver,
            inertia: scene.inertia,
            speed_limit: scene.speed_limit,
            divergence: scene.divergence,
            ..default()
        };
        let layered = scene.layers >= 2;
        let lift = if layered { LAYER_GAP } else { 0.0 };
        let mut poncho = commands.spawn((
            Name::new(numbered("poncho", i)),
            Poncho,
            Mesh3d(mesh.clone()),
            Cloth::worn_by(character),
            settings,
            Transform::from_translation(at + Vec3::Y * (scene.start_height + lift)),
        ));
        if let Some(simulated) = &simulated {
            poncho.insert(ClothSimulationMesh(simulated.clone()));
        }
        let poncho = poncho.id();
        if layered {
            let shawl = commands
                .spawn((
                    Name::new(numbered("shawl", i)),
                    Shawl,
                    Mesh3d(shawl_mesh.clone()),
                    Cloth::worn_by(character),
                    settings,
                    Transform::from_translation(at + Vec3::Y * scene.start_height),
                ))
                .id();
            commands
                .entity(character)
                .insert(ClothLayers(vec![shawl, poncho]));
        }
        if scene.wave && motion != CharacterMotion::Stand {
            commands.entity(character).insert(Waving);
        }
    }
}

/// `name`, then `name 1`, `name 2`, ... for the crowd's other characters.
fn numbered(name: &str, i: u32) -> String {
    match i {
        0 => name.to_string(),
        i => format!("{name} {i}"),
    }
}

/// The characters whose first IK goal [`wave`] drives: the scene's, and any marked [`Waving`].
type WaveGoals<'w, 's> = Query<
    'w,
    's,
    (&'static mut InverseKinematics, Has<Waving>),
    Or<(With<Character>, With<Waving>)>,
>;

fn wave(time: Res<Time>, mut characters: WaveGoals) {
    for (mut ik, waving) in &mut characters {
        if let Some(goal) = ik.goals.first_mut() {
            if waving {
                let (weight, target) = wave_at(time.elapsed_secs());
                goal.weight = weight;
                goal.target = IkTarget::CharacterPoint(target);
            } else {
                goal.weight = 0.0;
            }
        }
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
