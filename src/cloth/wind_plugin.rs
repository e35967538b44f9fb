//! The wind as an app sets it: the [`Wind`] resource (everywhere, with gusts) and
//! [`WindSource`] entities (fans and blasts), gathered once per fixed step into the
//! [`WindField`](crate::cloth::WindField) that every cloth with air ([`crate::cloth::SolverSettings::air`]) is given.

use std::collections::HashSet;

use bevy::prelude::*;

use super::air::{Falloff, Gusts, WindShape, WindSourceDesc};
use crate::schedule::{DrapeSchedule, DrapeSystems, StepWind};

/// The wind everywhere: a velocity and its gusts. Absent, the air is still (but for
/// [`WindSource`]s). A cloth feels the air when its [`SolverSettings::air`] is set.
///
/// [`SolverSettings::air`]: crate::cloth::SolverSettings::air
///
/// ```
/// # use std::time::Duration;
/// # use bevy::prelude::*;
/// # use bevy_drape::prelude::*;
/// # fn headless() -> App {
/// #     let mut app = App::new();
/// #     app.add_plugins((
/// #         MinimalPlugins,
/// #         bevy::transform::TransformPlugin,
/// #         bevy::asset::AssetPlugin::default(),
/// #         bevy::mesh::MeshPlugin,
/// #         DrapePlugins::default(),
/// #     ))
/// #     .insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
/// #         Duration::from_secs_f64(1.0 / 64.0),
/// #     ));
/// #     app
/// # }
/// let mut app = headless();
/// app.insert_resource(Wind {
///     velocity: Vec3::new(0.0, 0.0, 8.0), // 8 m/s along +Z
///     gusts: Gusts::default(),
/// });
/// // A flag hung by its left edge, in the air.
/// let grid = GridDesc::square(1.0, 12, Vec3::ZERO);
/// let pole: Vec<u32> = (0..12).map(|j| grid.index(0, j)).collect();
/// let mut flag = GridDesc::square(1.0, 12, Vec3::ZERO);
/// flag.orientation = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
/// let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(grid_mesh(&flag));
/// let cloth = app
///     .world_mut()
///     .spawn((
///         Mesh3d(mesh),
///         Cloth::pinned(pole),
///         ClothSettings {
///             solver: SolverSettings { air: Some(AirSettings::default()), ..default() },
///             ..default()
///         },
///         Transform::from_xyz(0.0, 2.0, 0.0),
///     ))
///     .id();
/// for _ in 0..129 {
///     app.update();
/// }
/// // The wind has blown the flag out along +Z.
/// let state = app.world().get::<ClothSimulation>(cloth).unwrap().solver().state();
/// let mean_z = state.positions.iter().map(|p| p.z).sum::<f32>() / state.len() as f32;
/// assert!(mean_z > 0.2, "{mean_z}");
/// ```
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct Wind {
    /// The mean wind, m/s.
    pub velocity: Vec3,
    /// Its variation in time and space.
    pub gusts: Gusts,
}

/// A local wind source on an entity: a fan blowing along the entity's forward direction
/// (`-Z` of its transform) or a blast blowing outward from it, within `radius`.
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(Transform)]
pub struct WindSource {
    /// Which way it blows; a directional source's direction is in the entity's frame.
    pub shape: WindShape,
    /// Its speed at the centre, m/s.
    pub speed: f32,
    /// How far it reaches, metres.
    pub radius: f32,
    /// How it weakens towards its radius.
    pub falloff: Falloff,
}

impl WindSource {
    /// A fan: `speed` m/s along the entity's forward (`-Z`), out to `radius`, smooth falloff.
    pub fn fan(speed: f32, radius: f32) -> Self {
        Self {
            shape: WindShape::Directional {
                direction: Vec3::NEG_Z,
            },
            speed,
            radius,
            falloff: Falloff::Smooth,
        }
    }

    /// A blast: `speed` m/s outward from the entity, out to `radius`, smooth falloff.
    pub fn blast(speed: f32, radius: f32) -> Self {
        Self {
            shape: WindShape::Radial,
            speed,
            radius,
            falloff: Falloff::Smooth,
        }
    }
}

/// Gathers [`Wind`] and every [`WindSource`] once per fixed step, for the cloths.
#[derive(Default)]
pub struct WindPlugin;

impl Plugin for WindPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        app.register_type::<(Wind, WindSource)>()
            .init_resource::<StepWind>()
            .add_systems(schedule, gather_wind.in_set(DrapeSystems::Colliders));
    }
}

fn gather_wind(
    wind: Option<Res<Wind>>,
    sources: Query<(Entity, &WindSource, &GlobalTransform)>,
    mut step: ResMut<StepWind>,
    mut warned: Local<HashSet<Entity>>,
) {
    let field = &mut step.0;
    let wind = wind.as_deref().copied().unwrap_or_default();
    if wind.velocity.is_finite() && wind.gusts.strength.is_finite() {
        field.velocity = wind.velocity;
        field.gusts = wind.gusts;
    } else {
        if warned.insert(Entity::PLACEHOLDER) {
            warn!("the Wind resource is not finite ({wind:?}); the air is still");
        }
        field.velocity = Vec3::ZERO;
        field.gusts = Gusts::default();
    }
    field.sources.clear();
    for (entity, source, global) in &sources {
        let position = global.translation();
        let shape = match source.shape {
            WindShape::Directional { direction } => WindShape::Directional {
                direction: global.rotation() * direction,
            },
            WindShape::Radial => WindShape::Radial,
        };
        let finite = position.is_finite()
            && source.speed.is_finite()
            && source.radius.is_finite()
            && source.radius >= 0.0
            && match shape {
                WindShape::Directional { direction } => direction.is_finite(),
                WindShape::Radial => true,
            };
        if !finite {
            if warned.insert(entity) {
                warn!("wind source {entity} is not finite or has a negative radius; ignored");
            }
            continue;
        }
        warned.remove(&entity);
        field.sources.push(WindSourceDesc {
            position,
            shape,
            speed: source.speed,
            radius: source.radius,
            falloff: source.falloff,
        });
    }
}
