//! The collide plugin's components: what other plugins spawn (the skeleton's bone proxies)
//! and read. ECS data only, no systems.

use std::sync::Arc;

use bevy::asset::{AssetId, Handle};
use bevy::math::Vec3;
use bevy::mesh::Mesh;
use bevy::prelude::*;

use super::motion::FrameTracker;
use super::shapes::{ContactMaterial, SolverCollider};
use super::trimesh::TriMesh;
use crate::error::ColliderError;

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

    /// The six walls of the box from `min` to `max` as plane colliders facing into it, each
    /// with its transform: spawn them to keep cloth inside the box (its floor is a ground).
    ///
    /// ```
    /// # use bevy::prelude::*;
    /// # use bevy_drape::prelude::*;
    /// fn spawn_box(mut commands: Commands) {
    ///     let walls = ClothCollider::inside_box(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    ///     for wall in walls {
    ///         commands.spawn(wall);
    ///     }
    /// }
    /// # bevy::ecs::system::assert_is_system(spawn_box);
    /// ```
    pub fn inside_box(min: Vec3, max: Vec3) -> [(Self, Transform); 6] {
        let wall = |at: Vec3, normal: Vec3| {
            let rotation = Quat::from_rotation_arc(Vec3::Y, normal);
            (
                Self::plane(),
                Transform::from_translation(at).with_rotation(rotation),
            )
        };
        [
            wall(min, Vec3::X),
            wall(max, Vec3::NEG_X),
            wall(min, Vec3::Y),
            wall(max, Vec3::NEG_Y),
            wall(min, Vec3::Z),
            wall(max, Vec3::NEG_Z),
        ]
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
    pub(crate) motion: FrameTracker,
    pub(crate) current: Option<SolverCollider>,
    pub(crate) mesh: Option<(AssetId<Mesh>, Vec3, Arc<TriMesh>)>,
    pub(crate) error: Option<ColliderError>,
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
