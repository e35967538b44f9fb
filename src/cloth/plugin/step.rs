//! Stepping every cloth in the drape schedule: pins, colliders, the followed entity, the
//! wind, the step, divergence.

use bevy::log::{error, warn};
use bevy::math::Vec3A;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use super::budget::{LodWarnings, disturbance, lod_viewer, sleep_settings};
use super::components::{
    Cloth, ClothDiverged, ClothLevelOfDetail, ClothSettings, ClothSimulation, DefaultClothSettings,
    OnDivergence, Slept,
};
use super::layers::LayeredSolve;
use crate::cloth::SolverSettings;
use crate::cloth::air::{AirSettings, WindField};
use crate::cloth::lod::{LodBudget, LodLevel, level_at};
use crate::cloth::sim::{ClothSolver, Join, OneThread, SleepSettings, StepTimings, with_helper};
use crate::collide::{FrameStep, SolverCollider};

/// The air of a cloth that does not feel the wind.
static STILL_AIR: WindField = WindField::STILL;
use crate::schedule::{
    ClothCoupling, DrapeSettings, DrapeTimings, StepColliders, StepWind, world_pose,
};

/// Every cloth with what steps it: its settings and what is coupled to it.
type SteppedCloths<'w, 's, C> = Query<
    'w,
    's,
    (
        Entity,
        &'static Cloth,
        &'static mut ClothSimulation,
        Option<&'static ClothSettings>,
        Option<&'static mut C>,
    ),
>;

/// Moves pins and attachments to this step's targets, steps every cloth and checks it for
/// divergence: one cloth after another on this thread, or with [`DrapeSettings::max_threads`]
/// above one, independent cloths at the same time on Bevy's compute task pool (each cloth is
/// stepped exactly as on one thread, so the result does not depend on the thread count).
#[allow(clippy::type_complexity)]
pub(super) fn step_cloths<C: ClothCoupling>(
    mut cloths: SteppedCloths<C>,
    defaults: Res<DefaultClothSettings>,
    drape: Res<DrapeSettings>,
    time: Res<Time>,
    transforms: TransformHelper,
    mut diverged: MessageWriter<ClothDiverged>,
    (colliders, wind, timings, lod, cameras, mut lod_warnings, mut layers, mut layered): (
        Option<Res<StepColliders>>,
        Option<Res<StepWind>>,
        Option<ResMut<DrapeTimings>>,
        Res<ClothLevelOfDetail>,
        Query<(&Camera, &GlobalTransform)>,
        Local<LodWarnings>,
        Query<&mut LayeredSolve>,
        Local<Vec<Entity>>,
    ),
) {
    let lod = lod_viewer(&lod, &cameras, &transforms, &mut lod_warnings);
    let context = StepContext {
        lod,
        defaults: &defaults.0,
        drape: &drape,
        dt: time.delta_secs(),
        elapsed: time.elapsed_secs(),
        transforms: &transforms,
        colliders: colliders.as_deref().map_or(&[], |c| &c.colliders),
        wind: wind.as_deref().map(|w| &w.0),
    };
    // The cloths stepped as layers, stepped after the others.
    layered.clear();
    for solve in &layers {
        if solve.solver.is_some() {
            layered.extend_from_slice(&solve.members);
        }
    }
    layered.sort_unstable();
    let alone = |entity: &Entity| layered.binary_search(entity).is_err();
    let pool = bevy::tasks::ComputeTaskPool::try_get();
    // The scope's own thread works too.
    let available = pool.map_or(1, |p| p.thread_num() + 1);
    let allowed = drape
        .max_threads
        .map_or(available, |cap| cap.get().min(available));
    let count = cloths.iter().filter(|(e, ..)| alone(e)).count();
    let threads = allowed.min(count);
    match pool {
        // One cloth that splits, two threads: its sweeps in two halves at once
        // (`ClothSolver::step_with`).
        Some(pool)
            if count == 1
                && allowed > 1
                && cloths.iter_mut().filter(|(e, ..)| alone(e)).all(
                    |(_, _, mut simulation, settings, _)| {
                        let settings = settings.unwrap_or(context.defaults);
                        simulation.sim.splits_in_two(&settings.solver)
                    },
                ) =>
        {
            for (entity, cloth, mut simulation, settings, mut coupled) in &mut cloths {
                if !alone(&entity) {
                    continue;
                }
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
            let mut all: Vec<_> = cloths
                .iter_mut()
                .filter(|(e, ..)| alone(e))
                .enumerate()
                .collect();
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
                if !alone(&entity) {
                    continue;
                }
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
    for mut solve in &mut layers {
        step_layers(&mut solve, &mut cloths, &context, &mut diverged);
    }
    if let Some(mut timings) = timings {
        let mut parts = StepTimings::default();
        for (_, _, simulation, _, _) in &cloths {
            parts.add(simulation.sim.last_timings());
        }
        timings.cloth_parts = parts;
    }
}

/// Steps the cloths of one [`LayeredSolve`] together: each prepared as a layer (its pins'
/// targets, its followed entity), the solve set up with the innermost's colliders, frame and
/// wind and stepped with its settings, each cloth's part copied back and checked. Nothing
/// steps if one of them is not to be solved this step (paused, frozen, settings not valid).
fn step_layers<C: ClothCoupling>(
    solve: &mut LayeredSolve,
    cloths: &mut SteppedCloths<C>,
    context: &StepContext,
    diverged: &mut MessageWriter<ClothDiverged>,
) {
    let LayeredSolve {
        members, solver, ..
    } = solve;
    let Some(layers) = solver else {
        return;
    };
    let mut lead = None;
    for (k, &member) in members.iter().enumerate() {
        let Ok((entity, cloth, mut simulation, settings, _)) = cloths.get_mut(member) else {
            return;
        };
        let settings = settings.unwrap_or(context.defaults);
        let Some(ready) = prepare_step(
            entity,
            cloth,
            &mut simulation,
            settings,
            false,
            context,
            true,
        ) else {
            return;
        };
        if let Err(err) = layers.gather(k, &simulation.sim) {
            warn!("cloth layers with {entity}: {err}; built again");
            *solver = None;
            return;
        }
        if k == 0 {
            lead = Some((entity, *settings, ready));
        }
    }
    let Some((lead, settings, ready)) = lead else {
        return;
    };
    let Ok((_, _, simulation, ..)) = cloths.get(lead) else {
        return;
    };
    let solver_settings = set_up_solver(
        layers.solver_mut(),
        &simulation.colliders,
        &ready,
        &settings,
        lead,
    );
    if let Err(err) = layers.step(
        &solver_settings,
        context.drape.gravity,
        context.dt,
        &OneThread,
    ) {
        warn!("cloth layers with {lead} are not stepped: {err}");
        return;
    }
    for (k, &member) in members.iter().enumerate() {
        let Ok((entity, _, mut simulation, settings, _)) = cloths.get_mut(member) else {
            continue;
        };
        let settings = settings.unwrap_or(context.defaults);
        let _ = layers.scatter(k, &mut simulation.sim);
        if let Some(d) = finish_step(entity, &mut simulation, settings, context, &ready) {
            diverged.write(d);
        }
    }
}

/// The budget of level `level` (`None`: full).
fn budget_of(lod: Option<(&[LodLevel], Vec3A)>, level: usize) -> Option<LodBudget> {
    let (levels, _) = lod?;
    level
        .checked_sub(1)
        .and_then(|k| levels.get(k))
        .map(|l| l.budget)
}

/// What every cloth's step reads from the world.
pub(super) struct StepContext<'a> {
    defaults: &'a ClothSettings,
    drape: &'a DrapeSettings,
    dt: f32,
    elapsed: f32,
    transforms: &'a TransformHelper<'a, 'a>,
    colliders: &'a [SolverCollider],
    wind: Option<&'a crate::cloth::air::WindField>,
    /// The levels of detail and where the viewer is, if any.
    lod: Option<(&'a [LodLevel], Vec3A)>,
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
    let settings = settings.unwrap_or(context.defaults);
    let ready = prepare_step(
        entity,
        cloth,
        simulation,
        settings,
        coupled.is_some(),
        context,
        false,
    )?;
    let solver = set_up_solver(
        &mut simulation.sim,
        &simulation.colliders,
        &ready,
        settings,
        entity,
    );
    let sim = &mut simulation.sim;
    // What is coupled to the cloth (water in it) steps inside the cloth's substeps.
    let stepped = match coupled {
        Some(coupled) => coupled.step_with_cloth(
            entity,
            sim,
            &solver,
            &simulation.colliders,
            context.drape.gravity,
            context.dt,
        ),
        None => sim.step_with(&solver, context.drape.gravity, context.dt, join),
    };
    if let Err(err) = stepped {
        if !simulation.warned_step_input {
            warn!("cloth {entity} is not stepped: {err}");
            simulation.warned_step_input = true;
        }
        return None;
    }
    simulation.warned_step_input = false;
    finish_step(entity, simulation, settings, context, &ready)
}

/// What a cloth's step needs once [`prepare_step`] has found it is to be solved.
pub(super) struct ReadyStep<'a> {
    /// The followed entity's motion over the step.
    pub(super) frame: Option<FrameStep>,
    /// The wind blowing on the cloth, if any.
    pub(super) wind: Option<&'a WindField>,
    /// Its level of detail's budget (`None`: full).
    pub(super) budget: Option<LodBudget>,
    /// Whether it comes back from a frozen level of detail.
    thawed: bool,
    /// The time of the wind, s.
    elapsed: f32,
    /// Its sleep settings, if it may sleep, and what disturbs it.
    sleep: Option<(SleepSettings, Option<&'static str>)>,
}

/// Everything of a cloth's step before its solver is set up: its pins' targets, the world's
/// colliders, the followed entity's motion, the wind, its level of detail and its sleep.
/// `None` if it is not solved this step (paused, frozen, asleep, settings not valid). A
/// cloth stepped as a layer (`layered`) neither sleeps nor freezes at a level of detail: its
/// layers are solved together.
pub(super) fn prepare_step<'a>(
    entity: Entity,
    cloth: &Cloth,
    simulation: &mut ClothSimulation,
    settings: &ClothSettings,
    coupled: bool,
    context: &StepContext<'a>,
    layered: bool,
) -> Option<ReadyStep<'a>> {
    let dt = context.dt;
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
    // The world's colliders, each checked when gathered (and reported with its entity).
    simulation.colliders.clear();
    simulation.colliders.extend_from_slice(context.colliders);

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

    // The entity the cloth follows: its motion over this step.
    simulation.followed = None;
    let mut frame = None;
    if let Some(target) = cloth.follow {
        match context
            .transforms
            .compute_global_transform(target)
            .ok()
            .and_then(|g| world_pose(&g))
        {
            Some(pose) => {
                frame = Some(
                    simulation
                        .follow
                        .step(pose, dt, context.drape.teleport.as_ref()),
                );
                simulation.followed = frame;
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
                simulation.follow.lose_sight();
            }
        }
    }

    // The air: the cloth's own settings, or the default ones while the wind blows on it.
    let wind = context.wind.filter(|w| settings.wind && !w.is_still());

    // The level of detail: fewer substeps, or frozen (carried with the followed entity).
    let was_frozen = simulation.lod_frozen;
    simulation.lod_level = match context.lod {
        Some((levels, viewer)) => {
            let (min, max) = simulation.sim.bounds();
            level_at(
                levels,
                viewer.distance(0.5 * (min + max)),
                simulation.lod_level,
            )
        }
        None => 0,
    };
    let budget = budget_of(context.lod, simulation.lod_level);
    simulation.lod_hidden = budget == Some(LodBudget::Hidden);
    // A cloth that follows nothing is frozen where it is, unless its pins move: then it is
    // solved (a frozen pin would jump to its target when thawed).
    let frozen = !layered
        && budget.is_some_and(|b| b.is_frozen())
        && (frame.is_some() || simulation.sim.pins_hold_still());
    simulation.lod_frozen = frozen;
    if frozen {
        let sim = &mut simulation.sim;
        match &frame {
            Some(frame) => sim.carry_rigidly(frame),
            None => sim.fall_asleep(),
        }
        simulation.sleep.wake();
        simulation.slept_with = None;
        return None;
    }
    let thawed = was_frozen;

    let sleep = match layered {
        true => None,
        false => sleep_settings(entity, settings, &mut simulation.warned_sleep),
    };
    let disturbance = sleep.map(|sleep| {
        disturbance(
            &simulation.sim,
            &simulation.colliders,
            frame.as_ref(),
            wind.is_some(),
            coupled,
            &sleep,
        )
    });
    let sim = &mut simulation.sim;
    if simulation.sleep.is_asleep() {
        let changed = !simulation
            .slept_with
            .as_ref()
            .is_some_and(|slept| slept.still(settings, context.drape.gravity, frame.as_ref()));
        match (disturbance, changed) {
            (Some(None), false) => {
                sim.fall_asleep();
                return None;
            }
            (cause, _) => {
                debug!(
                    "cloth {entity} wakes: {}",
                    match cause {
                        _ if changed => {
                            "its settings or the gravity changed, or its followed entity crept"
                        }
                        Some(Some(cause)) => cause,
                        _ => "it may not sleep",
                    }
                );
                simulation.sleep.wake();
                simulation.slept_with = None;
                simulation.drawn_asleep = None;
            }
        }
    }

    Some(ReadyStep {
        frame,
        wind,
        budget,
        thawed,
        elapsed: context.elapsed,
        sleep: sleep.zip(disturbance),
    })
}

/// Sets up `sim` for the step `ready` describes, with the colliders gathered for it (left out
/// with an error naming `entity` if one is not valid), and returns the solver settings the
/// step takes (the level of detail's substeps, the air while the wind blows).
pub(super) fn set_up_solver(
    sim: &mut ClothSolver,
    colliders: &[SolverCollider],
    ready: &ReadyStep,
    settings: &ClothSettings,
    entity: Entity,
) -> SolverSettings {
    if let Err(err) = sim.set_colliders(colliders) {
        error!("cloth {entity}: the colliders are left out: {err}");
        let _ = sim.set_colliders(&[]);
    }
    // A share of the followed entity's motion carried.
    if let Some(frame) = &ready.frame {
        sim.follow_frame(frame, settings.inertia);
        if let Some(limit) = settings.speed_limit {
            sim.limit_speed_relative_to(frame, limit);
        }
    }
    let mut solver = settings.solver;
    if let Some(LodBudget::Substeps(n)) = ready.budget {
        solver.substeps = solver.substeps.min(n.max(1));
    }
    if solver.air.is_none() && ready.wind.is_some() {
        solver.air = Some(AirSettings::default());
    }
    if solver.air.is_some() {
        sim.set_wind(ready.wind.unwrap_or(&STILL_AIR), ready.elapsed);
    }
    solver
}

/// Everything of a cloth's step after it was solved: its speed after a thaw, its volume's
/// error, divergence (what it diverged with, if it did) and falling asleep.
pub(super) fn finish_step(
    entity: Entity,
    simulation: &mut ClothSimulation,
    settings: &ClothSettings,
    context: &StepContext,
    ready: &ReadyStep,
) -> Option<ClothDiverged> {
    let dt = context.dt;
    let sim = &mut simulation.sim;
    let (thawed, frame) = (ready.thawed, ready.frame);
    if thawed && let Some(frame) = &frame {
        // Back from a frozen level: whatever the contacts had to undo after the ride (the
        // joints moved under the carried cloth) does not fling it off.
        let limit = settings
            .speed_limit
            .unwrap_or(ClothSettings::DEFAULT_SPEED_LIMIT);
        sim.limit_speed_relative_to(frame, limit);
    }
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
    if let Some((sleep, disturbance)) = ready.sleep
        && simulation
            .sleep
            .observe(sim.state(), disturbance.is_some(), dt, &sleep)
    {
        sim.fall_asleep();
        simulation.slept_with = Some(Slept {
            settings: *settings,
            gravity: context.drape.gravity,
            followed: frame.map(|f| f.end),
        });
    }
    None
}
