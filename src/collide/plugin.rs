//! The Bevy side of the colliders: the [`ClothCollider`] component, kinematic and animated
//! velocities, and the thin systems that hand every collider's pose and velocity at the
//! current fixed step to the cloths.

use bevy::ecs::query::QueryData;
use std::sync::Arc;

use bevy::app::{App, Plugin};
use bevy::asset::Assets;
use bevy::log::warn;
use bevy::math::{Quat, Vec3, Vec3A};
use bevy::mesh::Mesh;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

pub use super::components::{
    AnimatedVelocity, ClothCollider, ColliderShape, ColliderState, KinematicVelocity,
};
use super::shapes::{SolverCollider, SolverShape};
use super::trimesh::TriMesh;
use crate::error::ColliderError;
use crate::mesh::mesh_triangles;
use crate::schedule::{DrapeSchedule, DrapeSettings, DrapeSystems, StepColliders, world_pose};

/// Moves kinematic colliders and gathers every [`ClothCollider`] into the [`StepColliders`]
/// in [`DrapeSystems::Colliders`].
#[derive(Default)]
pub struct ColliderPlugin;

impl Plugin for ColliderPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        app.register_type::<(ClothCollider, KinematicVelocity, AnimatedVelocity)>()
            .init_resource::<StepColliders>()
            .add_systems(
                schedule,
                (move_kinematic_colliders, gather_colliders)
                    .chain()
                    .in_set(DrapeSystems::Colliders),
            );
    }
}

fn move_kinematic_colliders(
    mut colliders: Query<(&KinematicVelocity, &mut Transform), With<ClothCollider>>,
    time: Res<Time>,
) {
    let dt = time.delta_secs();
    for (velocity, mut transform) in &mut colliders {
        let moved = transform.translation + velocity.linear * dt;
        let turned =
            (Quat::from_scaled_axis(velocity.angular * dt) * transform.rotation).normalize();
        if moved.is_finite() && turned.is_finite() {
            transform.translation = moved;
            transform.rotation = turned;
        }
    }
}

/// A collider's shape at `scale`, or `None` while its mesh loads.
fn scaled_shape(
    shape: &ColliderShape,
    scale: Vec3,
    state: &mut ColliderState,
    meshes: &Assets<Mesh>,
) -> Result<Option<SolverShape>, ColliderError> {
    let scale = scale.abs();
    Ok(Some(match shape {
        ColliderShape::Sphere { radius } => SolverShape::Sphere {
            radius: radius * scale.max_element(),
        },
        ColliderShape::Capsule {
            radius,
            half_length,
        } => SolverShape::Capsule {
            radius: radius * scale.x.max(scale.z),
            half_length: half_length * scale.y,
        },
        ColliderShape::Plane => SolverShape::Plane,
        ColliderShape::TriangleMesh(handle) => {
            let id = handle.id();
            if let Some((built_id, built_scale, mesh)) = &state.mesh
                && *built_id == id
                && *built_scale == scale
            {
                return Ok(Some(SolverShape::TriangleMesh(mesh.clone())));
            }
            let Some(mesh) = meshes.get(id) else {
                return Ok(None);
            };
            let (vertices, indices) = mesh_triangles(mesh)?;
            let scaled: Vec<Vec3> = vertices.iter().map(|&v| v * scale).collect();
            let built = Arc::new(TriMesh::new(&scaled, &indices)?);
            state.mesh = Some((id, scale, built.clone()));
            SolverShape::TriangleMesh(built)
        }
    }))
}

/// A collider, with what its velocity may come from.
#[derive(QueryData)]
#[query_data(mutable)]
struct ColliderItem {
    entity: Entity,
    collider: &'static ClothCollider,
    state: &'static mut ColliderState,
    kinematic: Option<&'static KinematicVelocity>,
    animated: Option<&'static AnimatedVelocity>,
    child_of: Option<&'static ChildOf>,
}

fn gather_colliders(
    mut colliders: Query<ColliderItem>,
    animated_parents: Query<&AnimatedVelocity, Without<ClothCollider>>,
    mut world: ResMut<StepColliders>,
    meshes: Res<Assets<Mesh>>,
    transforms: TransformHelper,
    time: Res<Time>,
    drape: Option<Res<DrapeSettings>>,
) {
    let dt = time.delta_secs();
    let teleport = drape.map_or(Some(Default::default()), |d| d.teleport);
    world.colliders.clear();
    world.entities.clear();
    for item in &mut colliders {
        let (entity, collider, mut state, kinematic, animated, child_of) = (
            item.entity,
            item.collider,
            item.state,
            item.kinematic,
            item.animated,
            item.child_of,
        );
        let state = &mut *state;
        let result = (|| -> Result<Option<SolverCollider>, ColliderError> {
            let global = transforms
                .compute_global_transform(entity)
                .map_err(|_| ColliderError::NonFinitePose)?;
            let end = world_pose(&global).ok_or(ColliderError::NonFinitePose)?;
            let Some(shape) = scaled_shape(&collider.shape, global.scale(), state, &meshes)? else {
                return Ok(None);
            };
            // The pose change over the step; after a jump (a teleport) the collider starts
            // where it reappeared instead of sweeping through the space between.
            let motion = state.motion.step(end, dt, teleport.as_ref());
            let start = motion.sweep_start;
            let (linear, angular) = if let Some(k) = kinematic {
                (Vec3A::from(k.linear), Vec3A::from(k.angular))
            } else if let Some(a) = animated {
                (Vec3A::from(a.linear), Vec3A::from(a.angular))
            } else if let Some((parent, a)) =
                child_of.and_then(|c| Some((c.parent(), animated_parents.get(c.parent()).ok()?)))
            {
                // A proxy hanging from an animated bone moves with the bone:
                // v = v_bone + omega x (origin - bone origin).
                let bone = transforms
                    .compute_global_transform(parent)
                    .map_err(|_| ColliderError::NonFinitePose)?;
                let r = end.translation - Vec3A::from(bone.translation());
                let omega = Vec3A::from(a.angular);
                (Vec3A::from(a.linear) + omega.cross(r), omega)
            } else {
                (motion.linear_velocity, motion.angular_velocity)
            };
            let solver_collider = SolverCollider {
                shape,
                material: collider.material,
                margin: collider.margin,
                start,
                end,
                linear_velocity: linear,
                angular_velocity: angular,
            };
            solver_collider.validate()?;
            Ok(Some(solver_collider))
        })();
        match result {
            Ok(Some(c)) => {
                state.error = None;
                world.colliders.push(c.clone());
                world.entities.push(entity);
                state.current = Some(c);
            }
            Ok(None) => state.current = None,
            Err(err) => {
                if state.error.as_ref() != Some(&err) {
                    warn!("collider {entity} is ignored: {err}");
                }
                state.error = Some(err);
                state.current = None;
                state.motion.reset();
            }
        }
    }
}
