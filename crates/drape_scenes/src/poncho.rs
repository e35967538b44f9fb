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
use bevy_drape::cloth::plugin::{Cloth, ClothBuildError, ClothSettings};
use bevy_drape::cloth::{DivergenceBounds, SolverSettings};
use bevy_drape::collide::plugin::ClothCollider;
use bevy_drape::schedule::{DrapeSystems, DrapeTimings};
use bevy_drape::skeleton::humanoid::humanoid;
use bevy_drape::skeleton::ik::IkSettings;
use bevy_drape::skeleton::plugin::{
    BoneColliders, ClipAsset, ClipPlayer, IkGoal, IkTarget, InverseKinematics, Skeleton,
};

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
    /// How the character moves through the world. Default: [`CharacterMotion::InPlace`].
    pub motion: CharacterMotion,
    /// The poncho's [`ClothSettings::inertia`]. Default: `1.0`.
    pub inertia: f32,
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
            solver: SolverSettings {
                self_collision: true,
                ..SolverSettings::default()
            },
            density: 0.25,
            start_height: 1.5,
            wave: true,
            motion: CharacterMotion::InPlace,
            inertia: 1.0,
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

/// Marks the character.
#[derive(Component, Clone, Copy, Debug, Default, Reflect)]
#[reflect(Component)]
pub struct Character;

/// How the scene's character moves through the world. Its entity is moved by
/// [`CharacterController`] in `FixedUpdate`, as a game's character controller would, while the
/// walk clip plays in place at the speed that matches the ground speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum CharacterMotion {
    /// Walks on the spot (the clip alone).
    #[default]
    InPlace,
    /// After standing for [`SETTLE_SECONDS`], walks a closed loop at 1.2 m/s: a straight, a
    /// stop, a half turn to the left of 1 m radius, and back.
    Walk,
    /// After standing for [`SETTLE_SECONDS`], jogs 3 m/s straight ahead, stops, turns round
    /// on the spot and jogs back.
    Jog,
    /// Walks on the spot; every 3 s after [`SETTLE_SECONDS`] jumps 10 m sideways and turns a
    /// quarter turn in one step (a respawn), then back.
    Teleport,
    /// After standing for [`SETTLE_SECONDS`], a tour of all of it: walks, stops, turns left,
    /// walks, turns left, jogs and stops, then the same again, which brings it back.
    Tour,
}

impl CharacterMotion {
    /// Every motion, in the order the `poncho` example's keys cycle them.
    pub const ALL: [Self; 5] = [
        Self::InPlace,
        Self::Walk,
        Self::Jog,
        Self::Teleport,
        Self::Tour,
    ];

    /// Its name on the command line (`in-place`, `walk`, `jog`, `teleport`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::InPlace => "in-place",
            Self::Walk => "walk",
            Self::Jog => "jog",
            Self::Teleport => "teleport",
            Self::Tour => "tour",
        }
    }

    /// The motion named `name` (see [`CharacterMotion::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The controller's script: legs of (seconds, speed m/s, turn rate rad/s), looped. Each
    /// script turns the character by half a turn in all, so running it twice brings the
    /// character back to where it started.
    fn legs(&self) -> &'static [Leg] {
        use std::f32::consts::PI;
        const fn leg(seconds: f32, speed: f32, turn_rate: f32) -> Leg {
            Leg {
                seconds,
                speed,
                turn_rate,
            }
        }
        // A half turn of 1 m radius at 1.2 m/s takes pi / 1.2 s.
        const WALK_TURN: f32 = PI / 1.2;
        const WALK: [Leg; 8] = [
            leg(1.5, 1.2, 0.0),
            leg(1.5, 0.0, 0.0),
            leg(1.5, 1.2, 0.0),
            leg(WALK_TURN, 1.2, 1.2),
            leg(1.5, 1.2, 0.0),
            leg(1.5, 0.0, 0.0),
            leg(1.5, 1.2, 0.0),
            leg(WALK_TURN, 1.2, 1.2),
        ];
        const JOG: [Leg; 4] = [
            leg(2.5, 3.0, 0.0),
            leg(1.0, 0.0, 0.0),
            leg(1.0, 0.0, PI),
            leg(0.3, 0.0, 0.0),
        ];
        // A quarter turn at 1.2 rad/s.
        const QUARTER: f32 = PI / 2.0 / 1.2;
        const TOUR: [Leg; 7] = [
            leg(2.5, 1.2, 0.0),
            leg(1.0, 0.0, 0.0),
            leg(QUARTER, 1.2, 1.2),
            leg(1.5, 1.2, 0.0),
            leg(QUARTER, 1.2, 1.2),
            leg(2.0, 3.0, 0.0),
            leg(1.2, 0.0, 0.0),
        ];
        match self {
            Self::InPlace | Self::Teleport => &[],
            Self::Walk => &WALK,
            Self::Jog => &JOG,
            Self::Tour => &TOUR,
        }
    }
}

/// The character stands this long before it starts to move (walk, jog) or jump (teleport),
/// so the poncho settles on it first, seconds.
pub const SETTLE_SECONDS: f32 = 2.0;

/// How fast the controller changes speed, m/s^2.
const ACCELERATION: f32 = 4.0;

/// One leg of a [`CharacterMotion`]'s script.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Leg {
    seconds: f32,
    speed: f32,
    turn_rate: f32,
}

/// A stand-in for a game's character controller: moves the character entity's [`Transform`]
/// every fixed step along its [`CharacterMotion`] (speed changed at 4 m/s^2 at most, turns at
/// a set rate) and plays the walk clip at the speed that matches its ground speed
/// ([`Clip::stance_speed`](bevy_drape::skeleton::clip::Clip::stance_speed)), so the feet do not
/// skate.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
pub struct CharacterController {
    /// The motion.
    pub motion: CharacterMotion,
    /// Seconds since the motion started.
    pub time: f32,
    /// Current ground speed, m/s.
    pub speed: f32,
    /// Heading, radians about +Y (0 faces +Z).
    pub heading: f32,
    /// Jumps made so far ([`CharacterMotion::Teleport`]).
    pub jumps: u32,
    /// The clip's no-skate ground speed at normal playback, m/s, once known.
    pub stance_speed: Option<f32>,
}

impl CharacterController {
    /// A controller for `motion`, starting at rest.
    pub fn new(motion: CharacterMotion) -> Self {
        Self {
            motion,
            time: 0.0,
            speed: 0.0,
            heading: 0.0,
            jumps: 0,
            stance_speed: None,
        }
    }

    /// Switches to `motion` at once (no standing first); the character slows down or speeds
    /// up from where it is.
    pub fn switch_to(&mut self, motion: CharacterMotion) {
        self.motion = motion;
        self.time = SETTLE_SECONDS;
        self.jumps = 0;
    }

    /// Advances the controller by `dt` and moves `transform` (translation in the ground
    /// plane, heading about +Y). Returns the clip playback speed for the new ground speed.
    pub fn advance(&mut self, dt: f32, transform: &mut Transform) -> f32 {
        self.time += dt;
        let moving = self.time - SETTLE_SECONDS;
        if self.motion == CharacterMotion::Teleport {
            let jumps = (moving / 3.0).floor().max(0.0) as u32;
            if jumps > self.jumps {
                self.jumps = jumps;
                let sign = if jumps % 2 == 1 { 1.0 } else { -1.0 };
                transform.translation.x += 10.0 * sign;
                self.heading += sign * std::f32::consts::FRAC_PI_2;
            }
        }
        let legs = self.motion.legs();
        let (target, turn_rate) = if moving < 0.0 || legs.is_empty() {
            (0.0, 0.0)
        } else {
            let cycle: f32 = legs.iter().map(|l| l.seconds).sum();
            let mut at = moving.rem_euclid(cycle);
            let mut current = legs[0];
            for leg in legs {
                current = *leg;
                if at < leg.seconds {
                    break;
                }
                at -= leg.seconds;
            }
            (current.speed, current.turn_rate)
        };
        let change = (target - self.speed).clamp(-ACCELERATION * dt, ACCELERATION * dt);
        let speed = self.speed + change;
        // The mean of the speeds at both ends of the step: the distance is exact for a
        // constant acceleration.
        let distance = 0.5 * (self.speed + speed) * dt;
        self.speed = speed;
        let half_turn = 0.5 * turn_rate * dt;
        let forward = Quat::from_rotation_y(self.heading + half_turn) * Vec3::Z;
        transform.translation += forward * distance;
        self.heading += turn_rate * dt;
        transform.rotation = Quat::from_rotation_y(self.heading);
        if legs.is_empty() {
            // On the spot: the clip at its own pace.
            return 1.0;
        }
        match self.stance_speed {
            Some(stance) if stance > 0.0 => self.speed / stance,
            _ => 0.0,
        }
    }
}

/// Spawns the poncho scene at `Startup` (with the [`PonchoScene`] resource, default if
/// absent) and moves the wave's IK target.
pub struct PonchoScenePlugin;

impl Plugin for PonchoScenePlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<bevy_obj::ObjPlugin>() {
            app.add_plugins(bevy_obj::ObjPlugin);
        }
        app.register_type::<(PonchoScene, Poncho, Character, CharacterController)>()
            .init_resource::<PonchoScene>()
            .add_systems(Startup, spawn_poncho_scene)
            // As a game's controller would, in `FixedUpdate`; ordered before the drape sets
            // should the drape schedule be `FixedUpdate` too.
            .add_systems(
                FixedUpdate,
                (drive_characters, wave).before(DrapeSystems::Prepare),
            );
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
            CharacterController::new(scene.motion),
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
        Cloth::worn_by(character),
        ClothSettings {
            density: scene.density,
            solver: scene.solver,
            inertia: scene.inertia,
            divergence: scene.divergence,
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
            if scene.wave {
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

/// The figures of one headless run of the scene (scene S3 of `docs/benchmarks.md`). Strain,
/// centroid and energy figures are taken over the steps after the first
/// [`SETTLE_SECONDS`] (the poncho falling onto the character is left out).
#[derive(Clone, Debug, Default)]
pub struct PonchoRun {
    /// The motion the character made.
    pub motion: CharacterMotion,
    /// Wall time of every fixed step, by stage (see [`DrapeTimings`]), milliseconds:
    /// `[animation, inverse kinematics, colliders, cloth]`.
    pub stage_ms: Vec<[f64; 4]>,
    /// The deepest any particle was inside any capsule or sphere proxy after any step, metres
    /// (measured from the proxy's surface, without its margin; 0 if none was).
    pub deepest_penetration: f32,
    /// The largest structural strain of every step after the first [`SETTLE_SECONDS`].
    pub step_max_strain: Vec<f32>,
    /// Every structural edge's strain after every step after the first [`SETTLE_SECONDS`],
    /// as a histogram of [`STRAIN_BIN`]-wide bins (the last bin holds everything above).
    pub strain_histogram: Vec<u64>,
    /// The farthest the poncho's centroid was from the chest bone horizontally after any
    /// step after the first [`SETTLE_SECONDS`], metres.
    pub max_centroid_offset: f32,
    /// The largest kinetic energy of the poncho after any step after the first
    /// [`SETTLE_SECONDS`], J.
    pub max_kinetic_energy: f32,
    /// How far the character's entity went from where it started, metres.
    pub travelled: f32,
    /// Whether every position stayed finite.
    pub finite: bool,
    /// How many times the poncho diverged ([`bevy_drape::cloth::plugin::ClothDiverged`]).
    pub divergences: u32,
    /// Whether the poncho was frozen after any step.
    pub frozen: bool,
    /// Particles in the poncho.
    pub particles: usize,
    /// Fixed steps run.
    pub steps: u32,
}

/// The `s3` line of the `scenes` runner (field order is the line's).
#[derive(serde::Serialize)]
struct S3Line {
    scene: &'static str,
    motion: &'static str,
    particles: usize,
    method: &'static str,
    self_collision: bool,
    substeps: u32,
    iterations: u32,
    frames: u32,
    ms_per_frame: f64,
    ms_animation: f64,
    ms_ik: f64,
    ms_colliders: f64,
    ms_cloth: f64,
    deepest_penetration: f32,
    step_max_strain_median: f32,
    step_max_strain_max: f32,
    edge_strain_p999: f32,
    max_centroid_offset: f32,
    max_kinetic_energy: f32,
    travelled: f32,
    divergences: u32,
    frozen: bool,
    finite: bool,
}

/// The width of a bin of [`PonchoRun::strain_histogram`].
pub const STRAIN_BIN: f32 = 1e-4;
/// The bins of [`PonchoRun::strain_histogram`] (strains up to 200%).
const STRAIN_BINS: usize = 20_000;

impl PonchoRun {
    /// The run's figures as one JSON object (the `scenes` runner's `s3` line), with the
    /// solver settings it ran with.
    pub fn json(&self, solver: &SolverSettings) -> String {
        let line = S3Line {
            scene: "s3",
            motion: self.motion.name(),
            particles: self.particles,
            method: solver.method.name(),
            self_collision: solver.self_collision,
            substeps: solver.substeps,
            iterations: solver.iterations,
            frames: self.steps,
            ms_per_frame: self.median_ms(4),
            ms_animation: self.median_ms(0),
            ms_ik: self.median_ms(1),
            ms_colliders: self.median_ms(2),
            ms_cloth: self.median_ms(3),
            deepest_penetration: self.deepest_penetration,
            step_max_strain_median: self.step_strain_median(),
            step_max_strain_max: self.step_strain_max(),
            edge_strain_p999: self.edge_strain_percentile(0.999),
            max_centroid_offset: self.max_centroid_offset,
            max_kinetic_energy: self.max_kinetic_energy,
            travelled: self.travelled,
            divergences: self.divergences,
            frozen: self.frozen,
            finite: self.finite,
        };
        serde_json::to_string(&line).expect("the figures are plain numbers and names")
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

    /// The median over the steps of each step's largest strain.
    pub fn step_strain_median(&self) -> f32 {
        let values: Vec<f64> = self.step_max_strain.iter().map(|&s| s as f64).collect();
        crate::scenes::median(&values) as f32
    }

    /// The largest strain of any step.
    pub fn step_strain_max(&self) -> f32 {
        self.step_max_strain.iter().copied().fold(0.0, f32::max)
    }

    /// The strain that fraction `q` of all edge samples are at or below (to within
    /// [`STRAIN_BIN`], the upper edge of its bin).
    pub fn edge_strain_percentile(&self, q: f64) -> f32 {
        let total: u64 = self.strain_histogram.iter().sum();
        if total == 0 {
            return 0.0;
        }
        let wanted = (q * total as f64).ceil() as u64;
        let mut seen = 0;
        for (bin, &count) in self.strain_histogram.iter().enumerate() {
            seen += count;
            if seen >= wanted {
                return (bin + 1) as f32 * STRAIN_BIN;
            }
        }
        self.strain_histogram.len() as f32 * STRAIN_BIN
    }

    /// Whether the run holds what the main scene promises in every motion: finite, never
    /// diverged or frozen, no particle deeper in a proxy than `margin`, the centroid within
    /// 0.3 m of the chest horizontally; the reason if not.
    pub fn check(&self, margin: f32) -> Result<(), String> {
        let motion = self.motion.name();
        if !self.finite {
            return Err(format!("{motion}: a position went non-finite"));
        }
        if self.divergences > 0 || self.frozen {
            return Err(format!(
                "{motion}: diverged {} times, frozen {}",
                self.divergences, self.frozen
            ));
        }
        if self.deepest_penetration > margin {
            return Err(format!(
                "{motion}: a particle was {} m inside a proxy",
                self.deepest_penetration
            ));
        }
        if self.max_centroid_offset >= 0.3 {
            return Err(format!(
                "{motion}: the centroid went {} m from the chest",
                self.max_centroid_offset
            ));
        }
        Ok(())
    }
}

/// A headless App (`MinimalPlugins`, transforms, assets, meshes) with [`bevy_drape::DrapePlugins`]
/// and the scene, stepping one 1/60 s fixed step per update.
pub fn headless_app(scene: PonchoScene) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        bevy::mesh::MeshPlugin,
        bevy_drape::DrapePlugins::default(),
        PonchoScenePlugin,
    ))
    .insert_resource(scene)
    .insert_resource(Time::<Fixed>::from_hz(60.0));
    app
}

/// How long [`run_headless`] waits for the scene's files (the poncho mesh and the walk clip)
/// to load before it gives up.
pub const LOAD_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(30);

/// Runs the scene headless for `steps` fixed steps at 60 Hz, once its files have loaded, and
/// measures it after every step. Fails if the poncho could not be built or the files did not
/// load within [`LOAD_TIMEOUT`].
pub fn run_headless(scene: PonchoScene, steps: u32) -> Result<PonchoRun, String> {
    use bevy::time::TimeUpdateStrategy;
    use std::time::{Duration, Instant};

    let motion = scene.motion;
    let mut app = headless_app(scene);
    // Time stands still until the poncho is built and the clip is playing; the files load on
    // the asset server's threads meanwhile.
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::ZERO));
    let deadline = Instant::now() + LOAD_TIMEOUT;
    loop {
        app.update();
        match scene_ready(app.world_mut()) {
            Ok(true) => break,
            Ok(false) if Instant::now() < deadline => std::thread::yield_now(),
            Ok(false) => {
                return Err(format!(
                    "the poncho scene's files did not load within {LOAD_TIMEOUT:?}"
                ));
            }
            Err(e) => return Err(e),
        }
    }
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 60.0,
    )));
    let mut run = PonchoRun {
        motion,
        finite: true,
        strain_histogram: vec![0; STRAIN_BINS],
        ..default()
    };
    let start = character_position(&mut app);
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
        if let (Some(a), Some(b)) = (start, character_position(&mut app)) {
            run.travelled = run.travelled.max(a.distance(b));
        }
        if run.particles == 0
            && let Some(error) = build_error(app.world_mut())
        {
            return Err(error);
        }
    }
    Ok(run)
}

/// Whether the poncho's mesh and the walk clip are loaded (the cloth is built from them in the
/// first fixed step); the reason if one of them failed to load.
fn scene_ready(world: &mut World) -> Result<bool, String> {
    let server = world.resource::<AssetServer>().clone();
    let meshes: Vec<AssetId<Mesh>> = world
        .query_filtered::<&Mesh3d, With<Poncho>>()
        .iter(world)
        .map(|mesh| mesh.0.id())
        .collect();
    let clips: Vec<AssetId<ClipAsset>> = world
        .query_filtered::<&ClipPlayer, With<Character>>()
        .iter(world)
        .map(|player| player.clip.id())
        .collect();
    let untyped = meshes.iter().map(|id| id.untyped());
    for id in untyped.chain(clips.iter().map(|id| id.untyped())) {
        if let Some(bevy::asset::LoadState::Failed(error)) = server.get_load_state(id) {
            return Err(format!("a file of the poncho scene did not load: {error}"));
        }
    }
    let mesh_assets = world.resource::<Assets<Mesh>>();
    let clip_assets = world.resource::<Assets<ClipAsset>>();
    Ok(!meshes.is_empty()
        && !clips.is_empty()
        && meshes.iter().all(|&id| mesh_assets.get(id).is_some())
        && clips.iter().all(|&id| clip_assets.get(id).is_some()))
}

/// The reason the poncho could not be built, if it could not.
fn build_error(world: &mut World) -> Option<String> {
    world
        .query_filtered::<&ClothBuildError, With<Poncho>>()
        .iter(world)
        .next()
        .map(|error| format!("the poncho could not be built: {}", error.0))
}

fn character_position(app: &mut App) -> Option<Vec3> {
    let world = app.world_mut();
    world
        .query_filtered::<&Transform, With<Character>>()
        .iter(world)
        .next()
        .map(|t| t.translation)
}

fn measure(app: &mut App, run: &mut PonchoRun) {
    use bevy_drape::collide::SolverShape;
    let settled = run.steps as f32 / 60.0 > SETTLE_SECONDS;
    let world = app.world_mut();
    run.divergences += world
        .resource_mut::<Messages<bevy_drape::cloth::plugin::ClothDiverged>>()
        .drain()
        .count() as u32;
    let chest = world
        .query_filtered::<&bevy_drape::skeleton::plugin::SkeletonBones, With<Character>>()
        .iter(world)
        .next()
        .and_then(|bones| bones.get("chest"));
    let mut transforms =
        bevy::ecs::system::SystemState::<bevy::transform::helper::TransformHelper>::new(world);
    let chest = chest
        .and_then(|e| {
            transforms
                .get(world)
                .ok()
                .and_then(|t| t.compute_global_transform(e).ok())
        })
        .map(|g| g.translation());
    let mut ponchos =
        world.query_filtered::<&bevy_drape::cloth::plugin::ClothSimulation, With<Poncho>>();
    for simulation in ponchos.iter(world) {
        let sim = simulation.solver();
        let x = &sim.state().positions;
        run.particles = x.len();
        run.finite &= sim.is_finite();
        run.frozen |= simulation.is_frozen();

        for c in sim.colliders() {
            if matches!(c.shape, SolverShape::Plane) {
                continue;
            }
            for &p in x {
                if let Some(d) = c.signed_distance(p, 0.0) {
                    run.deepest_penetration = run.deepest_penetration.max(-d);
                }
            }
        }
        if !settled {
            continue;
        }
        let mut step_max = 0.0f32;
        for strain in sim.edge_strains() {
            step_max = step_max.max(strain);
            let bin = ((strain / STRAIN_BIN) as usize).min(run.strain_histogram.len() - 1);
            run.strain_histogram[bin] += 1;
        }
        run.step_max_strain.push(step_max);
        run.max_kinetic_energy = run.max_kinetic_energy.max(sim.kinetic_energy());
        if let Some(chest) = chest
            && !x.is_empty()
        {
            let centroid: Vec3 =
                Vec3::from(x.iter().copied().sum::<bevy::math::Vec3A>()) / x.len() as f32;
            let offset = (centroid - chest).with_y(0.0).length();
            run.max_centroid_offset = run.max_centroid_offset.max(offset);
        }
    }
}
