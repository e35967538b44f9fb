//! What a cloth's step costs: whether it sleeps ([`ClothSettings::sleep`]) and its level of
//! detail ([`ClothLevelOfDetail`]), and the markers and visibility that show both.

use bevy::log::warn;
use bevy::math::Vec3A;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use super::components::{ClothLevelOfDetail, ClothSettings, ClothSimulation, ClothSleeping};
use crate::cloth::lod::{LodLevel, validate_levels};
use crate::cloth::sim::{ClothSolver, SleepSettings, colliders_move_near, frame_moves};
use crate::collide::{FrameStep, SolverCollider};

/// Gives every sleeping cloth a [`ClothSleeping`] marker and takes it from every awake one;
/// hides every cloth its level of detail hides and shows it again as it was when it comes
/// nearer.
pub(super) fn mark_cloths(
    mut cloths: Query<(
        Entity,
        &mut ClothSimulation,
        Has<ClothSleeping>,
        Option<&mut Visibility>,
    )>,
    mut commands: Commands,
) {
    for (entity, mut simulation, marked, visibility) in &mut cloths {
        match (simulation.is_asleep(), marked) {
            (true, false) => {
                commands.entity(entity).try_insert(ClothSleeping);
            }
            (false, true) => {
                commands.entity(entity).try_remove::<ClothSleeping>();
            }
            _ => {}
        }
        let Some(mut visibility) = visibility else {
            continue;
        };
        match (simulation.lod_hidden, simulation.hidden_from) {
            (true, None) => {
                simulation.hidden_from = Some(*visibility);
                *visibility = Visibility::Hidden;
            }
            (false, Some(before)) => {
                *visibility = before;
                simulation.hidden_from = None;
            }
            _ => {}
        }
    }
}

/// Warnings about the level of detail already given (each once until it is fixed).
#[derive(Default)]
pub(super) struct LodWarnings {
    levels: bool,
    viewer: Option<Entity>,
    camera: bool,
}

/// The levels of detail in use and where the viewer is, if any: `None` without levels, with
/// levels that are not valid (warned once), or with no viewer (the given entity without a
/// transform is warned about once and the first active camera used).
pub(super) fn lod_viewer<'a>(
    lod: &'a ClothLevelOfDetail,
    cameras: &Query<(&Camera, &GlobalTransform)>,
    transforms: &TransformHelper,
    warned: &mut LodWarnings,
) -> Option<(&'a [LodLevel], Vec3A)> {
    if lod.levels.is_empty() {
        return None;
    }
    if let Err(err) = validate_levels(&lod.levels) {
        if !warned.levels {
            warn!("ClothLevelOfDetail: {err}; every cloth keeps its full budget");
            warned.levels = true;
        }
        return None;
    }
    warned.levels = false;
    let given = lod
        .viewer
        .and_then(|viewer| match transforms.compute_global_transform(viewer) {
            Ok(global) if global.translation().is_finite() => {
                warned.viewer = None;
                Some(global.translation_vec3a())
            }
            _ => {
                if warned.viewer != Some(viewer) {
                    warn!(
                        "ClothLevelOfDetail: the viewer {viewer} has no valid transform; \
                         distances are measured from the active camera"
                    );
                    warned.viewer = Some(viewer);
                }
                None
            }
        });
    let at = given.or_else(|| {
        cameras
            .iter()
            .find(|(camera, _)| camera.is_active)
            .map(|(_, global)| global.translation_vec3a())
    });
    match at {
        Some(at) => {
            warned.camera = false;
            Some((&lod.levels, at))
        }
        None => {
            if !warned.camera {
                warn!(
                    "ClothLevelOfDetail: no viewer and no active camera; every cloth keeps its \
                     full budget"
                );
                warned.camera = true;
            }
            None
        }
    }
}

/// The cloth's sleep settings, if it may sleep: `None` if it never sleeps, the default ones
/// (warned once) if its own are not valid.
pub(super) fn sleep_settings(
    entity: Entity,
    settings: &ClothSettings,
    warned: &mut bool,
) -> Option<SleepSettings> {
    let sleep = settings.sleep?;
    match sleep.validate() {
        Ok(()) => {
            *warned = false;
            Some(sleep)
        }
        Err(err) => {
            if !*warned {
                warn!("cloth {entity}: {err}; it sleeps with the default sleep settings");
                *warned = true;
            }
            Some(SleepSettings::default())
        }
    }
}

/// What would move a still cloth this step, if anything: a pin or attachment target or the
/// drag, its followed entity, a collider near it (or one come, gone or changed since it was
/// last solved), the wind, or a coupling.
pub(super) fn disturbance(
    sim: &ClothSolver,
    colliders: &[SolverCollider],
    frame: Option<&FrameStep>,
    wind: bool,
    coupled: bool,
    sleep: &SleepSettings,
) -> Option<&'static str> {
    /// How far beyond the cloth a moving collider counts, metres.
    const REACH: f32 = 0.05;
    if coupled {
        return Some("it is coupled");
    }
    if wind {
        return Some("the wind blows");
    }
    if !sim.pins_hold_still() {
        return Some("a pin or the dragged particle moves");
    }
    let (min, max) = sim.bounds();
    if let Some(frame) = frame
        && frame_moves(frame, sleep.speed(), min, max)
    {
        return Some("its followed entity moves");
    }
    if colliders_move_near(
        colliders,
        sim.colliders(),
        min,
        max,
        REACH + sim.contact_thickness(),
        sleep.speed(),
    ) {
        return Some("a collider near it moves");
    }
    None
}
