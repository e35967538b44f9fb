//! The headless run of the main scene (S3) and its figures: what the `scenes` runner's `s3`
//! line, the poncho example without a graphics adapter and the tests report.

use bevy::prelude::*;

use bevy_drape::cloth::SolverSettings;
use bevy_drape::cloth::plugin::ClothBuildError;
use bevy_drape::schedule::DrapeTimings;
use bevy_drape::skeleton::plugin::{ClipAsset, ClipPlayer};

#[cfg(doc)]
use super::SETTLE_SECONDS;
use super::{Character, CharacterMotion, Poncho, PonchoScene, PonchoScenePlugin};

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
    /// The cloth stage of every fixed step by part, summed over the ponchos
    /// ([`DrapeTimings::cloth_parts`]).
    pub cloth_parts: Vec<bevy_drape::cloth::StepTimings>,
    /// Wall time of writing the ponchos into their meshes in the frame after every fixed
    /// step ([`DrapeTimings::write_back`]; not part of the fixed step), milliseconds.
    pub write_back_ms: Vec<f64>,
    /// The deepest any particle was inside any capsule or sphere proxy after any step, metres
    /// (measured from the proxy's surface, without its margin; 0 if none was).
    pub deepest_penetration: f32,
    /// The largest structural strain of every step after the first [`SETTLE_SECONDS`].
    pub step_max_strain: Vec<f32>,
    /// The largest structural strain of any step after the first second (the poncho has
    /// landed on the character; the other figures start at [`SETTLE_SECONDS`]).
    pub strain_max_after_first_second: f32,
    /// The largest stretch (`(len - rest) / rest`, 0 if no edge is longer than at rest) of
    /// every step after the first [`SETTLE_SECONDS`].
    pub step_max_stretch: Vec<f32>,
    /// The largest compression (`(rest - len) / rest`, 0 if no edge is shorter than at rest)
    /// of every step after the first [`SETTLE_SECONDS`]. Each step's largest strain is the
    /// larger of the two.
    pub step_max_compression: Vec<f32>,
    /// Every structural edge's strain after every step after the first [`SETTLE_SECONDS`],
    /// as a histogram of [`STRAIN_BIN`]-wide bins (the last bin holds everything above).
    pub strain_histogram: Vec<u64>,
    /// The farthest the poncho's centroid was from the chest bone horizontally after any
    /// step after the first [`SETTLE_SECONDS`], metres.
    pub max_centroid_offset: f32,
    /// The poncho's centroid's horizontal distance from the chest bone after every step after
    /// the first [`SETTLE_SECONDS`], metres.
    pub centroid_offsets: Vec<f32>,
    /// The mean height of the hem (the particles on the outline of the square at rest) after
    /// every step after the first [`SETTLE_SECONDS`], metres above the ground.
    pub hem_heights: Vec<f32>,
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
    /// How many ponchos were asleep after the last step
    /// ([`bevy_drape::cloth::plugin::ClothSleeping`]).
    pub asleep: usize,
    /// Fixed steps run.
    pub steps: u32,
    /// How many times a particle went through one of its own poncho's triangles between two
    /// steps ([`bevy_drape::cloth::count_self_crossings`]), every poncho over the whole run.
    pub crossings: usize,
    /// Each poncho's positions after the last step, for the crossings.
    pub(super) previous_positions: Vec<(Entity, Vec<bevy::math::Vec3A>)>,
    /// Garments per character ([`PonchoScene::layers`]).
    pub layers: u32,
    /// How many times a particle of a shawl went through a triangle of the poncho over it, or
    /// the other way, between two steps ([`bevy_drape::cloth::count_crossings_between`]), every
    /// character over the whole run (with [`PonchoScene::layers`] = 2).
    pub layer_crossings: usize,
    /// The largest structural strain of any shawl in any step after the first second.
    pub shawl_strain_max_after_first_second: f32,
    /// Each shawl's and its poncho's positions after the last step, for the crossings
    /// between them.
    pub(super) previous_layers: Vec<(Entity, [Vec<bevy::math::Vec3A>; 2])>,
}

/// The `s3` line of the `scenes` runner (field order is the line's).
#[derive(serde::Serialize)]
struct S3Line {
    scene: &'static str,
    motion: &'static str,
    particles: usize,
    method: &'static str,
    self_collision: &'static str,
    substeps: u32,
    iterations: u32,
    /// `null` when infinite (free shear).
    shear_compliance: f32,
    frames: u32,
    ms_per_frame: f64,
    ms_animation: f64,
    ms_ik: f64,
    ms_colliders: f64,
    ms_cloth: f64,
    ms_predict: f64,
    ms_constraints: f64,
    ms_self_collision: f64,
    ms_contacts: f64,
    self_collision_share: f64,
    ms_write_back: f64,
    deepest_penetration: f32,
    crossings: usize,
    layers: u32,
    layer_crossings: usize,
    shawl_strain_max_after_first_second: f32,
    step_max_strain_median: f32,
    step_max_strain_max: f32,
    worst_step: usize,
    strain_max_after_first_second: f32,
    step_max_stretch_median: f32,
    step_max_compression_median: f32,
    edge_strain_p999: f32,
    max_centroid_offset: f32,
    centroid_offset_median: f32,
    hem_height_median: f32,
    max_kinetic_energy: f32,
    travelled: f32,
    divergences: u32,
    frozen: bool,
    finite: bool,
}

/// The median of `values`.
fn median_f32(values: &[f32]) -> f32 {
    let values: Vec<f64> = values.iter().map(|&s| s as f64).collect();
    crate::scenes::median(&values) as f32
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
            self_collision: solver.self_collision.name(),
            substeps: solver.substeps,
            iterations: solver.iterations,
            shear_compliance: solver.shear_compliance,
            frames: self.steps,
            ms_per_frame: self.median_ms(4),
            ms_animation: self.median_ms(0),
            ms_ik: self.median_ms(1),
            ms_colliders: self.median_ms(2),
            ms_cloth: self.median_ms(3),
            ms_predict: self.median_part_ms(|p| p.predict),
            ms_constraints: self.median_part_ms(|p| p.constraints),
            ms_self_collision: self.median_part_ms(|p| p.self_collision),
            ms_contacts: self.median_part_ms(|p| p.contacts),
            self_collision_share: self.median_part_ms(|p| p.self_collision)
                / self.median_part_ms(|p| p.total()),
            ms_write_back: crate::scenes::median(&self.write_back_ms),
            deepest_penetration: self.deepest_penetration,
            crossings: self.crossings,
            layers: self.layers.max(1),
            layer_crossings: self.layer_crossings,
            shawl_strain_max_after_first_second: self.shawl_strain_max_after_first_second,
            step_max_strain_median: self.step_strain_median(),
            step_max_strain_max: self.step_strain_max(),
            worst_step: self.worst_step(),
            strain_max_after_first_second: self.strain_max_after_first_second,
            step_max_stretch_median: median_f32(&self.step_max_stretch),
            step_max_compression_median: median_f32(&self.step_max_compression),
            edge_strain_p999: self.edge_strain_percentile(0.999),
            max_centroid_offset: self.max_centroid_offset,
            centroid_offset_median: median_f32(&self.centroid_offsets),
            hem_height_median: median_f32(&self.hem_heights),
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
        self.median_ms_after(stage, 0)
    }

    /// [`PonchoRun::median_ms`] over the steps after the first `skip`.
    pub fn median_ms_after(&self, stage: usize, skip: usize) -> f64 {
        let values: Vec<f64> = self
            .stage_ms
            .iter()
            .skip(skip)
            .map(|s| if stage < 4 { s[stage] } else { s.iter().sum() })
            .collect();
        crate::scenes::median(&values)
    }

    /// The median over the steps of one part of the cloth stage ([`PonchoRun::cloth_parts`]),
    /// milliseconds.
    pub fn median_part_ms(
        &self,
        part: impl Fn(&bevy_drape::cloth::StepTimings) -> std::time::Duration,
    ) -> f64 {
        let values: Vec<f64> = self
            .cloth_parts
            .iter()
            .map(|p| part(p).as_secs_f64() * 1e3)
            .collect();
        crate::scenes::median(&values)
    }

    /// The median over the steps of each step's largest strain.
    pub fn step_strain_median(&self) -> f32 {
        median_f32(&self.step_max_strain)
    }

    /// The largest strain of any step.
    pub fn step_strain_max(&self) -> f32 {
        self.step_max_strain.iter().copied().fold(0.0, f32::max)
    }

    /// The fixed step (counted from 1) whose strain is [`PonchoRun::step_strain_max`]: run
    /// the scene for that many frames to look at it (0 if no step was measured).
    pub fn worst_step(&self) -> usize {
        let settle = self.steps.saturating_sub(self.step_max_strain.len() as u32) as usize;
        self.step_max_strain
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(i, _)| settle + i + 1)
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
    run_app(headless_app(scene), steps)
}

/// [`run_headless`] on an app [`headless_app`] made (with, say, other
/// [`DrapeSettings`](bevy_drape::schedule::DrapeSettings)).
pub fn run_app(mut app: App, steps: u32) -> Result<PonchoRun, String> {
    use bevy::time::TimeUpdateStrategy;
    use std::time::{Duration, Instant};

    let (motion, layers) = app
        .world()
        .get_resource::<PonchoScene>()
        .map_or((default(), 1), |scene| (scene.motion, scene.layers));
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
        layers,
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
        run.cloth_parts.push(timings.cloth_parts);
        run.stage_ms.push([
            ms(timings.animation),
            ms(timings.inverse_kinematics),
            ms(timings.colliders),
            ms(timings.cloth),
        ]);
        run.write_back_ms.push(ms(timings.write_back));
        run.measure(&mut app);
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
