//! Runs a standard scene headless and prints one JSON line.
//!
//! ```text
//! cargo run --release --example scenes -- s1|s2|s3|drop --n 64 [--substeps 8] [--iterations 1]
//!     [--method xpbd|pbd|mass-spring|hybrid|hybrid-long-range] [--stiffness 0.5] [--stretch-compliance 0]
//!     [--shear-compliance inf] [--bend-compliance 500] [--no-tethers] [--dihedral] [--damping 0.5]
//!     [--friction 0.5]
//!     [--k-structural 1000] [--k-shear 300] [--k-bend 20] [--auto-substeps]
//!     [--runs 3] [--frames 120] [--motion in-place|walk|jog|teleport|tour|sprint|hop|set-off|turn-around|zigzag|carried|stand]
//!     [--inertia 1] [--speed-limit 1.5|none] [--neck-radius 0.1]
//!     [--simulate-n 15] [--simulate-drawn] [--wind 10] [--gusts 0] [--threads 2]
//!     [--adaptive 0.01] [--fixed-substeps] [--exact-edges 20] [--no-exact-edges]
//! cargo run --release --example scenes -- crowd [--characters 8] [--standing 0] [--threads 2] [--frames 600]
//!     [--warmup 0] [--lod] [--runs 3]
//! cargo run --release --example scenes -- mesh-drop --mesh bunny|duck|spider|PATH.obj [--n 16] [--frames 180]
//! cargo run --release --example scenes -- pour [--substeps 16] [--iterations 4] [--frames 360] [--runs 3]
//! cargo run --release --example scenes -- layers [--n 32] [--seed S] [--apart] [--frames 180]
//! ```
//!
//! `s3 --motion` moves the character through the world (see
//! `drape_scenes::poncho::CharacterMotion`); `--inertia` and `--speed-limit` are the poncho's
//! `ClothSettings::inertia` and `ClothSettings::speed_limit`; `--neck-radius` (or `--n`) makes the poncho from its pattern
//! (`PonchoDesc`) instead of the shipped OBJ. The poncho is simulated on the coarse pattern
//! (`meshes/poncho_coarse.obj`, `ClothSimulationMesh`) and drawn with the fine one;
//! `--simulate-n` simulates it on the pattern with that many vertices per side instead,
//! `--simulate-drawn` (or `--n` alone) simulates what it draws. Its line counts `crossings`:
//! how many times a particle went through one of its poncho's triangles between two steps.
//! `--layers 2` puts a shawl under every poncho (`PonchoScene::layers`, `ClothLayers`): the
//! line adds `layer_crossings` (particles of one through the other's triangles) and the
//! shawl's worst strain after the first second.
//!
//! `layers` drops two `--n` x `--n` sheets one above the other onto a sphere
//! (`LayeredDrop`; `--seed S` generates their gap, turn, shift and tilt), stepped as layers of
//! one solve (`LayerSolver`) or, with `--apart`, each alone: the cost, the crossings between
//! them (`crossings`) and of each through itself (`crossings_own`), the closest two particles
//! of the two sheets at the end (`closest`, m), how far the upper sheet slid over the lower
//! after landing on it (`slide`, m) and the worst strain.
//!
//! `s1 --threads N` runs S1 a second time with every step split over its thread and a helper
//! task (`ClothSolver::step_with`, `with_helper`) and adds that run's ms per frame, its ratio
//! to one thread's (`speedup`) and its strain.
//!
//! `crowd` is S3 with `--characters` characters in ponchos in a row, walking, jogging, walking
//! on the spot and teleporting (`PonchoScene::characters`), the last `--standing` of them
//! standing still (`PonchoScene::standing`), stepped on one thread and on `--threads`
//! (`DrapeSettings::max_threads`) in turn, `--runs` times each: the ms per fixed step of both
//! (the median over the runs of each run's median) and per character, their ratio, how many
//! ponchos were asleep at the end (`slept`), and whether every run gave the same figures bit
//! for bit. `--warmup S` runs S seconds before the `--frames` that are timed (standing
//! characters' ponchos take 10-14 s to come to rest after the drop and fall asleep). `--lod`
//! measures from a viewer 4 m before the first character (`ClothLevelOfDetail`): 4 substeps
//! beyond 12 m, frozen beyond 30 m.
//!
//! `s2` drops the sheet as a woven fabric (`Drape::settings`: free shear, a light fabric's
//! bending, the substep count adapted to hold 1% strain from 8 x 2); `--fixed-substeps` keeps
//! `--substeps` throughout, `--adaptive T` holds strain `T` instead. It reports the strain at
//! the end (`max_strain`) and the largest after any frame (`largest_strain`), and the mean
//! substep count.
//!
//! `--exact-edges CG` (any scene) solves the structural edges exactly at the end of every
//! substep in which the cloth touches a collider with one Gauss-Newton step of at most `CG`
//! conjugate-gradient iterations (`SolverSettings::exact_edges`; on by default, with 20, in
//! every scene but S2); `--no-exact-edges` leaves them to the iterations.
//!
//! `drop` is the self-collision example's sheet dropped onto the ground so that it folds onto
//! itself (`SheetDrop`, self-collision off unless `--self-collision particles|triangles`;
//! `--seed S` drops it from a tilt, height and turn generated from `S`, `SheetDrop::generated`): besides the cost and
//! strain, the closest gap between two particles that share no edge at the end, in grid
//! spacings (`closest_gap`), and how many times a particle went through one of the sheet's
//! triangles between two frames over the run (`crossings`, `bevy_drape::cloth::count_self_crossings`).
//!
//! `pour` is the `water` example's scene (`drape_scenes::water::Pour`): a jet of 600
//! particles poured into a sheet hung from four posts, cloth and water stepped together
//! (`--substeps` and `--iterations` are the cloth's, 16 x 4 by default). It reports the
//! coupled step's cost and a dry sheet's (stepped alongside), the density error
//! (`max(rho / rho0 - 1, 0)`: the mean and largest over the last second, the largest over
//! the run), the particles found below the sheet after a step (the most, and in how many
//! steps), those the step found across a triangle and put back (`crossings`), the force the
//! water pushes on the sheet with and the weight of the water in it (the last half second),
//! the sheet's strain, and the momentum of sheet and water falling freely together (1 s):
//! its largest relative difference from the weight's impulse.
//!
//! `collisions` throws a mass-spring sheet into a box with three spheres, one moving (which
//! colliders it touched, in the order spheres, then the walls -X, +X, ground, top, -Z, +Z).
//!
//! `wind` is the flag (hanging in the XY plane) in a wind of `--wind` m/s across it, along
//! +Z, with `--gusts` m/s of gusts; it
//! reports the frame's cost with air and, stepped from the same states, without.
//!
//! `--k-*` set the spring stiffnesses (N/m) of the mass-spring and hybrid methods;
//! `--auto-substeps` lets them raise the substep count to their stability bound.
//!
//! `ms_per_frame` is the median over all frames of all runs (model build excluded); the other
//! figures come from the last run (every run is identical: the solver is deterministic).

use bevy::math::Vec3;
use bevy::transform::components::Transform;
use bevy_drape::cloth::plugin::{ClothLevelOfDetail, ClothSettings};
use bevy_drape::cloth::{
    AdaptiveSubsteps, ExactEdges, Gusts, LodBudget, LodLevel, PonchoDesc, SelfCollisionMethod,
    SolverMethod, SolverSettings,
};
use bevy_drape::schedule::DrapeSettings;
use drape_scenes::poncho::{
    COARSE_PONCHO_VERTICES, CharacterMotion, PonchoScene, PonchoSource, headless_app, run_app,
    run_headless,
};
use drape_scenes::scenes::{
    Collisions, Drape, FRAME_RATE, Flag, FlagRun, HangingCloth, LayeredDrop, MeshDrop, SheetDrop,
    median,
};
use drape_scenes::water::Pour;

fn main() {
    if let Err(message) = run() {
        eprintln!("scenes: {message}");
        std::process::exit(2);
    }
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let scene = args.next().ok_or("missing scene name (s1, s2, s3, drop)")?;
    let mut n = 32u32;
    let mut seed: Option<u64> = None;
    let mut runs = 3u32;
    let mut frames: Option<u32> = None;
    let mut settings = match scene.as_str() {
        "drop" => SheetDrop::settings(SelfCollisionMethod::Off),
        "layers" => LayeredDrop::settings(),
        "s3" | "crowd" => PonchoScene::default().solver,
        "wind" => Flag::settings(),
        "collisions" => Collisions::settings(),
        "s2" => Drape::settings(),
        "pour" => Pour::default().cloth,
        _ => SolverSettings::default(),
    };
    let mut wave = true;
    let mut motion = CharacterMotion::InPlace;
    let mut inertia = 1.0f32;
    let mut speed_limit = ClothSettings::default().speed_limit;
    let mut wind_speed = 10.0f32;
    let mut gusts = 0.0f32;
    let mut neck_radius: Option<f32> = None;
    let mut mesh_path: Option<String> = None;
    let mut simulate_n: Option<u32> = None;
    let mut simulate_drawn = false;
    let mut characters = 8u32;
    let mut standing = 0u32;
    let mut warmup = 0.0f32;
    let mut lod = false;
    let mut apart = false;
    let mut layers = 1u32;
    let mut threads: Option<usize> = None;
    let n_given = std::env::args().any(|a| a == "--n");
    let mut method = if scene == "collisions" {
        "mass-spring"
    } else {
        "xpbd"
    }
    .to_string();
    let mut stiffness = 1.0f32;
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--n" => n = parse(&value()?)?,
            "--seed" => seed = Some(parse(&value()?)?),
            "--runs" => runs = parse(&value()?)?,
            "--frames" => frames = Some(parse(&value()?)?),
            "--substeps" => settings.substeps = parse(&value()?)?,
            "--iterations" => settings.iterations = parse(&value()?)?,
            "--stretch-compliance" => settings.stretch_compliance = parse(&value()?)?,
            "--shear-compliance" => settings.shear_compliance = parse(&value()?)?,
            "--bend-compliance" => settings.bend_compliance = parse(&value()?)?,
            "--damping" => settings.damping = parse(&value()?)?,
            "--friction" => settings.friction = parse(&value()?)?,
            "--stiffness" => stiffness = parse(&value()?)?,
            "--method" => method = value()?,
            "--k-structural" => settings.springs.structural.stiffness = parse(&value()?)?,
            "--k-shear" => settings.springs.shear.stiffness = parse(&value()?)?,
            "--k-bend" => settings.springs.bend.stiffness = parse(&value()?)?,
            "--auto-substeps" => settings.auto_substeps = true,
            "--adaptive" => {
                settings.adaptive = Some(AdaptiveSubsteps::target(parse(&value()?)?));
            }
            "--fixed-substeps" => settings.adaptive = None,
            "--exact-edges" => {
                settings.exact_edges = Some(ExactEdges {
                    cg_iterations: parse(&value()?)?,
                    ..settings.exact_edges.unwrap_or_default()
                });
            }
            "--no-exact-edges" => settings.exact_edges = None,
            "--no-tethers" => settings.long_range_attachments = false,
            "--dihedral" => settings.isometric_bending = false,
            "--self-collision" => {
                let name = value()?;
                settings.self_collision = SelfCollisionMethod::from_name(&name).ok_or(format!(
                    "unknown self-collision method {name} (off, particles, triangles)"
                ))?;
            }
            "--no-wave" => wave = false,
            "--motion" => {
                let name = value()?;
                motion = CharacterMotion::from_name(&name).ok_or(format!(
                    "unknown motion {name} (in-place, walk, jog, teleport, tour, sprint, hop, \
                     set-off, turn-around, zigzag, carried)"
                ))?;
            }
            "--inertia" => inertia = parse(&value()?)?,
            "--speed-limit" => {
                speed_limit = match value()?.as_str() {
                    "none" => None,
                    limit => Some(parse(limit)?),
                }
            }
            "--wind" => wind_speed = parse(&value()?)?,
            "--gusts" => gusts = parse(&value()?)?,
            "--mesh" => mesh_path = Some(value()?),
            "--neck-radius" => neck_radius = Some(parse(&value()?)?),
            "--simulate-n" => simulate_n = Some(parse(&value()?)?),
            "--simulate-drawn" => simulate_drawn = true,
            "--no-air" => settings.air = None,
            "--characters" => characters = parse(&value()?)?,
            "--standing" => standing = parse(&value()?)?,
            "--warmup" => warmup = parse(&value()?)?,
            "--lod" => lod = true,
            "--apart" => apart = true,
            "--layers" => layers = parse(&value()?)?,
            "--threads" => threads = Some(parse(&value()?)?),
            other => return Err(format!("unknown option {other}")),
        }
    }
    settings.method = match method.as_str() {
        "xpbd" => SolverMethod::Xpbd,
        "pbd" => SolverMethod::Pbd { stiffness },
        "mass-spring" => SolverMethod::MassSpring,
        "hybrid" => SolverMethod::Hybrid { long_range: false },
        "hybrid-long-range" => SolverMethod::Hybrid { long_range: true },
        other => {
            return Err(format!(
                "unknown method {other} (xpbd, pbd, mass-spring, hybrid, hybrid-long-range)"
            ));
        }
    };
    settings.validate().map_err(|e| e.to_string())?;
    let frames = frames.unwrap_or(match scene.as_str() {
        "s3" | "crowd" => 600,
        "s2" | "layers" => 180,
        "pour" => 360,
        _ => 120,
    });
    if n < 2 {
        return Err("--n must be at least 2".into());
    }
    match scene.as_str() {
        "s1" => {
            let scene = HangingCloth { n };
            let pool = threads.filter(|&t| t > 1).map(|t| {
                bevy::tasks::TaskPoolBuilder::new()
                    .num_threads(t - 1)
                    .build()
            });
            // With --threads, each run is followed by the same run split over a helper task
            // (alternating, so that both see the same machine): its ms per frame, the ratio
            // of the medians, and the strain the split sweep ends at.
            let mut all_frames = Vec::new();
            let mut split_frames = Vec::new();
            let mut last = None;
            for _ in 0..runs.max(1) {
                let one = scene.run(&settings, frames);
                all_frames.extend_from_slice(&one.trajectory.frame_seconds);
                let many = pool.as_ref().map(|pool| {
                    let many = scene.run_on(&settings, frames, Some(pool));
                    split_frames.extend_from_slice(&many.trajectory.frame_seconds);
                    many
                });
                last = Some((one, many));
            }
            let Some((run, split_run)) = last else {
                return Err("no run".into());
            };
            let split = match (split_run, &pool) {
                (Some(split_run), Some(pool)) => {
                    let (one, many) = (median(&all_frames), median(&split_frames));
                    format!(
                        ",\"threads\":{},\"ms_per_frame_n\":{:.4},\"speedup\":{:.3},\"max_strain_n\":{:.6},\"finite_n\":{}",
                        pool.thread_num() + 1,
                        many * 1e3,
                        one / many,
                        split_run.sim.strain().max,
                        split_run.finite && split_run.divergence.is_none()
                    )
                }
                _ => String::new(),
            };
            let vec = |v: bevy::math::Vec3| format!("[{:.5},{:.5},{:.5}]", v.x, v.y, v.z);
            let frames = run.sample_frames();
            let at = |track: &[bevy::math::Vec3]| -> Vec<String> {
                frames.iter().map(|&f| vec(track[f as usize - 1])).collect()
            };
            let (corner, center) = (at(&run.trajectory.corner), at(&run.trajectory.center));
            let times: Vec<String> = frames
                .iter()
                .map(|&f| format!("{:.3}", f as f32 / FRAME_RATE))
                .collect();
            println!(
                "{{\"scene\":\"s1\",\"n\":{n},\"method\":\"{method}\",\"substeps\":{},\"substeps_used\":{},\"iterations\":{},\"long_range\":{},\"bending\":\"{}\",\"ms_per_frame\":{:.4},\"runs\":{runs},\"max_strain\":{:.6},\"mean_strain\":{:.6},\"times\":[{}],\"corner\":[{}],\"center\":[{}],\"finite\":{},\"diverged\":{}{split}}}",
                settings.substeps,
                run.trajectory.substeps.iter().max().unwrap_or(&0),
                settings.iterations,
                settings.long_range_attachments,
                if settings.isometric_bending {
                    "isometric"
                } else {
                    "dihedral"
                },
                median(&all_frames) * 1e3,
                run.sim.strain().max,
                run.mean_strain,
                times.join(","),
                corner.join(","),
                center.join(","),
                run.finite,
                match run.divergence {
                    Some((frame, d)) => format!("{{\"frame\":{frame},\"why\":\"{d}\"}}"),
                    None => "null".into(),
                }
            );
            Ok(())
        }
        "s2" => {
            let scene = Drape { n };
            let (run, all_frames) =
                repeat(runs, || scene.run(&settings, frames), |r| &r.frame_seconds);
            let x = &run.sim.state().positions;
            let centre = x[(n / 2 * n + n / 2) as usize];
            println!(
                "{{\"scene\":\"s2\",\"n\":{n},\"method\":\"{method}\",\"substeps\":{},\"iterations\":{},\"adaptive_target\":{},\"mean_substeps\":{:.1},\"shear_compliance\":{},\"bend_compliance\":{},\"ms_per_frame\":{:.4},\"runs\":{runs},\"frames\":{frames},\"deepest_penetration\":{:.6},\"max_strain\":{:.6},\"largest_strain\":{:.6},\"contacts\":{},\"centre\":[{:.4},{:.4},{:.4}],\"finite\":{}}}",
                settings.substeps,
                settings.iterations,
                settings
                    .adaptive
                    .map_or("null".to_string(), |a| a.target_strain.to_string()),
                run.mean_substeps,
                json_number(settings.shear_compliance),
                settings.bend_compliance,
                median(&all_frames) * 1e3,
                run.deepest_penetration,
                run.max_strain,
                run.largest_strain,
                run.sim.contact_count(),
                centre.x,
                centre.y,
                centre.z,
                run.finite
            );
            Ok(())
        }
        "mesh-drop" => {
            let path = mesh_path.ok_or("mesh-drop needs --mesh bunny|duck|spider|PATH.obj")?;
            let path = match path.as_str() {
                "bunny" | "duck" | "spider" => {
                    format!("{}/assets/meshes/{path}.obj", env!("CARGO_MANIFEST_DIR"))
                }
                _ => path,
            };
            let obj = std::fs::read_to_string(&path).map_err(|e| format!("{path}: {e}"))?;
            let scene = MeshDrop::from_obj(n, &obj, 0.0).map_err(|e| format!("{path}: {e}"))?;
            let mut last = None;
            let mut all_frames = Vec::new();
            for _ in 0..runs.max(1) {
                let run = scene.run(&settings, frames)?;
                all_frames.extend_from_slice(&run.frame_seconds);
                last = Some(run);
            }
            let run = last.ok_or("no run")?;
            println!(
                "{{\"scene\":\"mesh-drop\",\"mesh\":\"{path}\",\"closed\":{},\"n\":{n},\"ms_per_frame\":{:.4},\"runs\":{runs},\"frames\":{frames},\"max_strain\":{:.6},\"largest_strain\":{:.6},\"deepest\":{:.6},\"contacts\":{},\"finite\":{}}}",
                scene.mesh.is_closed(),
                median(&all_frames) * 1e3,
                run.max_strain,
                run.largest_strain,
                run.deepest,
                run.sim.contact_count(),
                run.finite
            );
            Ok(())
        }
        "drop" => {
            let scene = seed.map_or(SheetDrop::new(n), |seed| SheetDrop::generated(n, seed));
            let (run, all_frames) =
                repeat(runs, || scene.run(&settings, frames), |r| &r.frame_seconds);
            println!(
                "{{\"scene\":\"drop\",\"n\":{n},\"seed\":{},\"method\":\"{method}\",\"self_collision\":\"{}\",\"substeps\":{},\"iterations\":{},\"ms_per_frame\":{:.4},\"runs\":{runs},\"frames\":{frames},\"closest_gap\":{:.4},\"self_contacts\":{},\"crossings\":{},\"max_strain\":{:.6},\"finite\":{}}}",
                seed.map_or("null".to_string(), |s| s.to_string()),
                settings.self_collision.name(),
                settings.substeps,
                settings.iterations,
                median(&all_frames) * 1e3,
                run.closest_gap,
                run.sim.self_contact_count(),
                run.crossings,
                run.max_strain,
                run.finite
            );
            Ok(())
        }
        "layers" => {
            let scene = seed.map_or(LayeredDrop::new(n), |seed| LayeredDrop::generated(n, seed));
            let (run, all_frames) = repeat(
                runs,
                || scene.run(&settings, frames, !apart),
                |r| &r.frame_seconds,
            );
            println!(
                "{{\"scene\":\"layers\",\"n\":{n},\"seed\":{},\"layered\":{},\"substeps\":{},\"iterations\":{},\"ms_per_frame\":{:.4},\"runs\":{runs},\"frames\":{frames},\"crossings\":{},\"crossings_own\":{},\"closest\":{:.4},\"slide\":{:.4},\"max_strain\":{:.6},\"finite\":{}}}",
                seed.map_or("null".to_string(), |s| s.to_string()),
                !apart,
                settings.substeps,
                settings.iterations,
                median(&all_frames) * 1e3,
                run.crossings_between,
                run.crossings_own,
                run.closest,
                run.slide,
                run.max_strain,
                run.finite
            );
            Ok(())
        }
        "s3" => {
            let mut scene = PonchoScene {
                solver: settings,
                wave,
                motion,
                inertia,
                speed_limit,
                layers,
                ..PonchoScene::default()
            };
            // Drawn: the shipped OBJ, or the pattern with `--n` vertices and `--neck-radius`.
            // Simulated: the shipped coarse OBJ, or the pattern with `--simulate-n` vertices,
            // or with `--n` alone what is drawn.
            let pattern = |vertices: u32| {
                let default = PonchoDesc::default();
                PonchoSource::Pattern(PonchoDesc {
                    vertices,
                    neck_radius: neck_radius.unwrap_or(default.neck_radius),
                    ..default
                })
            };
            if n_given || neck_radius.is_some() {
                scene.source = pattern(if n_given {
                    n
                } else {
                    PonchoDesc::default().vertices
                });
            }
            scene.simulated = match (simulate_n, n_given || simulate_drawn, neck_radius) {
                (Some(vertices), _, _) => Some(pattern(vertices)),
                (None, true, _) => None,
                (None, false, Some(_)) => Some(pattern(COARSE_PONCHO_VERTICES)),
                (None, false, None) => PonchoScene::default().simulated,
            };
            let run = run_headless(scene, frames)
                .map_err(|e| format!("{e} (is the working directory the repository root?)"))?;
            println!("{}", run.json(&settings));
            Ok(())
        }
        "crowd" => {
            if !(warmup.is_finite() && warmup >= 0.0) {
                return Err("--warmup must be a number of seconds, at least 0".into());
            }
            let warmup_steps = (warmup * 60.0).round() as u32;
            let threads = std::num::NonZeroUsize::new(threads.unwrap_or(2))
                .ok_or("--threads must be at least 1")?;
            // One thread and `threads` in turn, `runs` times each, so that both see the
            // machine in the same state.
            let mut one_runs = Vec::new();
            let mut many_runs = Vec::new();
            for _ in 0..runs.max(1) {
                for (max_threads, into) in [
                    (std::num::NonZeroUsize::MIN, &mut one_runs),
                    (threads, &mut many_runs),
                ] {
                    let mut app = headless_app(PonchoScene {
                        solver: settings,
                        characters,
                        standing,
                        ..PonchoScene::default()
                    });
                    app.insert_resource(DrapeSettings {
                        max_threads: Some(max_threads),
                        ..DrapeSettings::default()
                    });
                    if lod {
                        let viewer = app
                            .world_mut()
                            .spawn(Transform::from_xyz(-4.0, 1.6, 0.0))
                            .id();
                        app.insert_resource(ClothLevelOfDetail {
                            viewer: Some(viewer),
                            levels: vec![
                                LodLevel {
                                    beyond: 12.0,
                                    budget: LodBudget::Substeps(4),
                                },
                                LodLevel {
                                    beyond: 30.0,
                                    budget: LodBudget::Frozen,
                                },
                            ],
                        });
                    }
                    into.push(run_app(app, warmup_steps + frames).map_err(|e| {
                        format!("{e} (is the working directory the repository root?)")
                    })?);
                }
            }
            let one = &one_runs[0];
            let same = one_runs.iter().chain(&many_runs).all(|run| {
                run.step_max_strain == one.step_max_strain
                    && run.centroid_offsets == one.centroid_offsets
            });
            // Medians over the runs of each run's median step.
            let ms = |runs: &[drape_scenes::poncho::PonchoRun], stage: usize| {
                median(
                    &runs
                        .iter()
                        .map(|run| run.median_ms_after(stage, warmup_steps as usize))
                        .collect::<Vec<_>>(),
                )
            };
            let (one_ms, one_cloth) = (ms(&one_runs, 4), ms(&one_runs, 3));
            let (many_ms, many_cloth) = (ms(&many_runs, 4), ms(&many_runs, 3));
            let all = || one_runs.iter().chain(&many_runs);
            println!(
                "{{\"scene\":\"crowd\",\"characters\":{characters},\"particles_each\":{},\"substeps\":{},\"iterations\":{},\"frames\":{frames},\"warmup\":{warmup},\"runs\":{runs},\"threads\":{threads},\"standing\":{standing},\"lod\":{lod},\"ms_per_frame_1\":{one_ms:.4},\"ms_cloth_1\":{one_cloth:.4},\"ms_per_frame_n\":{many_ms:.4},\"ms_cloth_n\":{many_cloth:.4},\"ms_per_character_1\":{:.4},\"ms_per_character_n\":{:.4},\"slept\":{},\"speedup\":{:.3},\"cloth_speedup\":{:.3},\"same_result\":{same},\"step_max_strain_median\":{:.6},\"deepest_penetration\":{:.6},\"divergences\":{},\"finite\":{}}}",
                one.particles,
                settings.substeps,
                settings.iterations,
                one_ms / characters.max(1) as f64,
                many_ms / characters.max(1) as f64,
                one.asleep,
                one_ms / many_ms,
                one_cloth / many_cloth,
                one.step_strain_median(),
                all().map(|run| run.deepest_penetration).fold(0.0, f32::max),
                all().map(|run| run.divergences).sum::<u32>(),
                all().all(|run| run.finite),
            );
            Ok(())
        }
        "wind" => {
            let scene = Flag {
                n,
                wind: Vec3::new(0.0, 0.0, wind_speed),
                gusts: Gusts {
                    strength: gusts,
                    ..Gusts::default()
                },
            };
            let mut with_air = Vec::new();
            let mut without = Vec::new();
            let mut air = Vec::new();
            let mut last: Option<FlagRun> = None;
            for _ in 0..runs.max(1) {
                let run = scene.run(&settings, frames);
                with_air.extend_from_slice(&run.frame_seconds);
                without.extend_from_slice(&run.no_air_seconds);
                air.extend_from_slice(&run.air_seconds);
                last = Some(run);
            }
            let run = last.expect("at least one run");
            let (ms, ms_still) = (median(&with_air) * 1e3, median(&without) * 1e3);
            let direction = run.mean_direction(60);
            let heading = direction.z.atan2(direction.x).to_degrees();
            let droop = direction
                .y
                .atan2(direction.with_y(0.0).length())
                .to_degrees();
            println!(
                "{{\"scene\":\"wind\",\"n\":{n},\"particles\":{},\"method\":\"{method}\",\"substeps\":{},\"iterations\":{},\"wind\":{wind_speed},\"gusts\":{gusts},\"ms_per_frame\":{ms:.4},\"ms_without_air\":{ms_still:.4},\"ms_air\":{:.4},\"air_share\":{:.4},\"runs\":{runs},\"frames\":{frames},\"heading_deg\":{heading:.2},\"droop_deg\":{droop:.2},\"strain_median\":{:.6},\"strain_max\":{:.6},\"finite\":{}}}",
                run.sim.state().positions.len(),
                settings.substeps,
                settings.iterations,
                median(&air) * 1e3,
                run.air_share(),
                run.strain().0,
                run.strain().1,
                run.finite
            );
            Ok(())
        }
        "collisions" => {
            let scene = Collisions { n };
            let (run, all_frames) =
                repeat(runs, || scene.run(&settings, frames), |r| &r.frame_seconds);
            let touched: Vec<String> = run.touched.iter().map(|t| t.to_string()).collect();
            println!(
                "{{\"scene\":\"collisions\",\"n\":{n},\"method\":\"{method}\",\"substeps_used\":{},\"ms_per_frame\":{:.4},\"runs\":{runs},\"frames\":{frames},\"touched\":[{}],\"deepest_penetration\":{:.6},\"finite\":{}}}",
                run.sim.last_substeps(),
                median(&all_frames) * 1e3,
                touched.join(","),
                run.deepest_penetration,
                run.finite
            );
            Ok(())
        }
        "pour" => {
            let scene = Pour {
                cloth: settings,
                ..Pour::default()
            };
            let (mut all_frames, mut dry_frames) = (Vec::new(), Vec::new());
            let mut run = scene.run(frames);
            for k in 0..runs.max(1) {
                if k > 0 {
                    run = scene.run(frames);
                }
                all_frames.extend_from_slice(&run.frame_seconds);
                dry_frames.extend_from_slice(&run.dry_seconds);
            }
            let (ms, ms_dry) = (median(&all_frames) * 1e3, median(&dry_frames) * 1e3);
            // At rest: the last second.
            let rest = run.last(FRAME_RATE as usize);
            let last_half = run.last(FRAME_RATE as usize / 2);
            let mean = |values: &mut dyn Iterator<Item = f32>| {
                let (sum, count) = values.fold((0.0, 0), |(s, c), v| (s + v, c + 1));
                sum / count.max(1) as f32
            };
            let end = run.frames.last().copied().unwrap_or_default();
            let (momentum_error, exchanged) = scene.free_fall(60);
            println!(
                "{{\"scene\":\"pour\",\"particles\":{},\"cloth_particles\":{},\"substeps\":{},\"iterations\":{},\"fluid_substeps\":{},\"fluid_iterations\":{},\"ms_per_frame\":{ms:.4},\"ms_dry_cloth\":{ms_dry:.4},\"runs\":{runs},\"frames\":{frames},\"density_error_mean\":{:.5},\"density_error_max\":{:.5},\"density_error_max_run\":{:.5},\"below_sheet_max\":{},\"below_sheet_steps\":{},\"crossings\":{},\"carried_n\":{:.4},\"weight_on_sheet_n\":{:.4},\"strain_max_rest\":{:.5},\"free_fall_momentum_error\":{momentum_error:.3e},\"free_fall_exchanged\":{exchanged:.4},\"errors\":{},\"divergences\":{},\"finite\":{}}}",
                end.particles,
                scene.vertices * scene.vertices,
                scene.cloth.substeps,
                scene.cloth.iterations,
                scene.fluid.substeps,
                scene.fluid.iterations,
                mean(&mut rest.iter().map(|f| f.density_error_mean)),
                rest.iter().map(|f| f.density_error_max).fold(0.0, f32::max),
                run.frames
                    .iter()
                    .map(|f| f.density_error_max)
                    .fold(0.0, f32::max),
                run.frames.iter().map(|f| f.below).max().unwrap_or(0),
                run.frames.iter().filter(|f| f.below > 0).count(),
                run.frames.iter().map(|f| f.crossings).sum::<usize>(),
                mean(&mut last_half.iter().map(|f| f.carried)),
                mean(&mut last_half.iter().map(|f| f.weight_on_sheet)),
                rest.iter().map(|f| f.strain).fold(0.0, f32::max),
                run.errors.len(),
                run.divergences,
                run.finite,
            );
            Ok(())
        }
        other => Err(format!(
            "unknown scene {other} (s1, s2, s3, drop, layers, wind, collisions, crowd, pour)"
        )),
    }
}

/// Runs a scene `runs` times (at least once): the last run, and every frame's wall time of
/// all of them (`frame_seconds` picks a run's).
fn repeat<R>(
    runs: u32,
    run: impl Fn() -> R,
    frame_seconds: impl Fn(&R) -> &[f64],
) -> (R, Vec<f64>) {
    let mut all = Vec::new();
    let mut last = run();
    all.extend_from_slice(frame_seconds(&last));
    for _ in 1..runs.max(1) {
        last = run();
        all.extend_from_slice(frame_seconds(&last));
    }
    (last, all)
}

fn parse<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    s.parse().map_err(|_| format!("cannot parse {s:?}"))
}

/// `x` as a JSON value: a number, or `null` if it is not finite (as the `s3` line writes an
/// infinite shear compliance).
fn json_number(x: f32) -> String {
    if x.is_finite() {
        x.to_string()
    } else {
        "null".into()
    }
}
