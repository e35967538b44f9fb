//! The Bevy side of the colliders: the [`ClothCollider`] component, kinematic and animated
//! velocities, and the thin systems that hand every collider's pose and velocity at the
//! current fixed step to the cloths.

use bevy::ecs::query::QueryData;
use std::sync::Arc;

use bevy::app::{App, Plugin};
use bevy::asset::{AssetId, Assets, Handle};
use bevy::log::warn;
use bevy::math::{Quat, Vec3, Vec3A};
use bevy::mesh::Mesh;
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use super::motion::FrameTracker;
use super::shapes::{ContactMaterial, RigidPose, SolverCollider, SolverShape};
use super::trimesh::TriMesh;
use crate::cloth::plugin::DrapeSettings;
use crate::error::ColliderError;
use crate::mesh::mesh_triangles;
use crate::schedule::{DrapeSchedule, DrapeSystems};

/// The geometry of a [`ClothCollider`], in the entity's local frame (scaled by its
/// transform's scale: spheres by the largest axis, capsules' radius by the largest of X and
/// Z and their length by Y, meshes exactly).
#[derive(Clone, Debug, PartialEq, Reflect)]
pub enum ColliderShape {
    /// A ball of `radius` about the origin.
    Sphere {
        /// Radius, metres.
        radius: f32,
    },
    /// A capsule along local Y: the points within `radius` of the segment from
    /// `(0, -half_length, 0)` to `(0, half_length, 0)`.
    Capsule {
        /// Radius, metres.
        radius: f32,
        /// Half the length of the axis segment, metres.
        half_length: f32,
    },
    /// The infinite plane through the origin with normal local +Y; cloth stays above it.
    Plane,
    /// A triangle mesh (any triangle-list [`Mesh`] asset, an OBJ loaded as one included).
    /// Closed, cloth stays outside it (in front of its counter-clockwise faces); open (a scan
    /// with holes, a single-sided sheet), on whichever side it came from. See [`TriMesh`].
    TriangleMesh(Handle<Mesh>),
}

/// Makes any entity (a bone included) a collider for every cloth.
///
/// Its pose is taken from its transform chain at each fixed step; its velocity from a
/// [`KinematicVelocity`], else an [`AnimatedVelocity`] on it or on its parent (a bone), else
/// the change of its pose over the step.
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
/// // A 1 m square centred over the origin (`GridDesc` starts at its corner).
/// let grid = GridDesc::square(1.0, 16, Vec3::new(-0.5, 0.0, -0.5));
/// let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(grid_mesh(&grid));
/// let sheet = app
///     .world_mut()
///     .spawn((Mesh3d(mesh), Cloth::default(), Transform::from_xyz(0.0, 0.5, 0.0)))
///     .id();
/// // A ball under the sheet's middle, and the ground.
/// app.world_mut().spawn((
///     ClothCollider::sphere(0.2).with_friction(0.8),
///     Transform::from_xyz(0.0, 0.2, 0.0),
/// ));
/// app.world_mut().spawn((ClothCollider::plane(), Transform::default()));
/// for _ in 0..65 {
///     app.update();
/// }
/// // The sheet lies over the ball: its middle on the ball's top, nothing inside the ball.
/// let state = app.world().get::<ClothSimulation>(sheet).unwrap().solver().state();
/// let centre = Vec3::new(0.0, 0.2, 0.0);
/// assert!(state.positions.iter().all(|p| Vec3::from(*p).distance(centre) > 0.2));
/// let highest = state.positions.iter().map(|p| p.y).fold(0.0, f32::max);
/// assert!(highest > 0.38 && highest < 0.45, "{highest}");
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(Transform, ColliderState)]
pub struct ClothCollider {
    /// The geometry.
    pub shape: ColliderShape,
    /// Friction and restitution. Default: friction 0.5, restitution 0.
    pub material: ContactMaterial,
    /// Particles are kept this far outside the surface (plus the cloth's thickness), metres.
    /// Default: `0.005`.
    pub margin: f32,
}

impl ClothCollider {
    /// The default margin, metres.
    pub(crate) const DEFAULT_MARGIN: f32 = 0.005;

    /// A collider of `shape` with the default material and margin.
    pub(crate) fn new(shape: ColliderShape) -> Self {
        Self {
            shape,
            material: ContactMaterial::default(),
            margin: Self::DEFAULT_MARGIN,
        }
    }

    /// A sphere.
    pub fn sphere(radius: f32) -> Self {
        Self::new(ColliderShape::Sphere { radius })
    }

    /// A capsule along local Y.
    pub fn capsule(radius: f32, half_length: f32) -> Self {
        Self::new(ColliderShape::Capsule {
            radius,
            half_length,
        })
    }

    /// The plane through the origin with normal local +Y.
    pub fn plane() -> Self {
        Self::new(ColliderShape::Plane)
    }

    /// A triangle mesh.
    pub fn mesh(mesh: Handle<Mesh>) -> Self {
        Self::new(ColliderShape::TriangleMesh(mesh))
    }

    /// With this friction coefficient.
    pub fn with_friction(mut self, friction: f32) -> Self {
        self.material.friction = friction;
        self
    }

    /// With this restitution.
    pub fn with_restitution(mut self, restitution: f32) -> Self {
        self.material.restitution = restitution;
        self
    }

    /// With this margin, metres.
    pub fn with_margin(mut self, margin: f32) -> Self {
        self.margin = margin;
        self
    }
}

/// A constant velocity the collider moves with: every fixed step its [`Transform`] moves by
/// `linear dt` and turns by `angular dt` (both in its parent's frame), and contacts use it.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct KinematicVelocity {
    /// Linear velocity, m/s.
    pub linear: Vec3,
    /// Angular velocity, rad/s (axis times rate).
    pub angular: Vec3,
}

/// The world-frame velocity of the entity's origin at the current fixed step, written by an
/// animation system (the skeleton's forward kinematics) before the colliders are read.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct AnimatedVelocity {
    /// Linear velocity, m/s.
    pub linear: Vec3,
    /// Angular velocity, rad/s.
    pub angular: Vec3,
}

/// What the solver saw of a collider at the last fixed step (added with [`ClothCollider`]).
#[derive(Component, Clone, Debug, Default)]
pub struct ColliderState {
    motion: FrameTracker,
    current: Option<SolverCollider>,
    mesh: Option<(AssetId<Mesh>, Vec3, Arc<TriMesh>)>,
    error: Option<ColliderError>,
}

impl ColliderState {
    /// The collider as the cloths saw it in the last fixed step; `None` before the first step,
    /// while its mesh loads, or if it is invalid.
    pub fn collider(&self) -> Option<&SolverCollider> {
        self.current.as_ref()
    }

    /// Why the collider is ignored, if it is.
    pub fn error(&self) -> Option<&ColliderError> {
        self.error.as_ref()
    }
}

/// Every valid collider at the current fixed step, as the cloths see them.
#[derive(Resource, Clone, Debug, Default)]
pub struct StepColliders {
    /// The colliders.
    pub colliders: Vec<SolverCollider>,
    /// Their entities, in the same order.
    pub entities: Vec<Entity>,
}

/// The rigid pose (translation and rotation, scale left out) of a global transform, if it is
/// finite.
pub(crate) fn world_pose(global: &GlobalTransform) -> Option<RigidPose> {
    let (scale, rotation, translation) = global.to_scale_rotation_translation();
    (scale.is_finite() && rotation.is_finite() && translation.is_finite()).then(|| RigidPose {
        translation: translation.into(),
        rotation: rotation.normalize(),
    })
}

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
            // where it ends instead of sweeping through the space between.
            let motion = state.motion.step(end, dt, teleport.as_ref());
            let start = motion.sweep_start();
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
