//! The skeleton's components, resources and assets: what a game spawns and reads.

use std::sync::Arc;

use bevy::asset::io::Reader;
use bevy::asset::{Asset, AssetId, AssetLoader, Handle, LoadContext};
use bevy::math::Vec3;
use bevy::prelude::*;
use bevy::reflect::TypePath;

use crate::collide::{ContactMaterial, FrameStep, FrameTracker};
use crate::files::{FileValue, FromFile};
use crate::skeleton::clip::{Clip, ClipDesc, ClipError};
use crate::skeleton::humanoid::{BoneProxy, humanoid_proxies};
use crate::skeleton::ik::{
    AngleRates, BallChain, BallTracking, IkChain, IkError, IkResult, IkScratch, IkSettings,
    IkTracking, JointLimits,
};
use crate::skeleton::rig::{BoneState, Pose, PoseRate, Rig};

/// A clip file, as loaded; bound to a rig when a [`ClipPlayer`] plays it.
#[derive(Asset, TypePath, Clone, Debug, PartialEq)]
pub struct ClipAsset(pub ClipDesc);

/// Loads `*.clip.ron` files as [`ClipAsset`]s.
#[derive(Default, TypePath)]
pub(crate) struct ClipLoader;

impl AssetLoader for ClipLoader {
    type Asset = ClipAsset;
    type Settings = ();
    type Error = ClipLoadError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        _context: &mut LoadContext<'_>,
    ) -> Result<ClipAsset, ClipLoadError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        let text = std::str::from_utf8(&bytes).map_err(|e| ClipError::Parse(e.to_string()))?;
        Ok(ClipAsset(ClipDesc::from_ron(text)?))
    }

    fn extensions(&self) -> &[&str] {
        &["clip.ron"]
    }
}

/// A character: its rig. `bevy_drape` spawns one child entity per bone (see
/// [`SkeletonBones`]) in the hierarchy of the rig, so meshes and colliders can hang from them.
#[derive(Component, Clone, Debug)]
#[require(Transform)]
pub struct Skeleton {
    /// The rig.
    pub rig: Arc<Rig>,
}

/// Collision proxies for the cloth on a character's bones, by bone name: each proxy becomes a
/// [`ClothCollider`](crate::collide::plugin::ClothCollider) capsule (or sphere) on a child entity of its bone, moving with it.
///
/// - With a [`Skeleton`] on the same entity, the bones are the rig's: the proxies are spawned
///   with the bone entities and take their velocity from the joints' ([`AnimatedVelocity`](crate::collide::plugin::AnimatedVelocity)).
/// - On any other entity (the root of a glTF scene animated by Bevy's `AnimationPlayer`, a
///   hierarchy of your own), a proxy's bone is the first descendant whose [`Name`] is the
///   proxy's bone name. The proxies are attached as soon as a descendant has one of the names
///   (a scene spawns after its file loads) and take their velocity from their own motion
///   over each fixed step (see [`crate::collide::motion`]).
///
/// A proxy naming a bone that is not there is skipped with a warning naming the entity. When
/// the component changes (a colliders file reloaded, an inspector's edit) the proxies are
/// spawned again.
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
/// # use std::sync::Arc;
/// # use bevy_drape::skeleton::plugin::BoneProxyOf;
/// let mut app = headless();
/// // Slimmer arms than the humanoid's, and more friction on every proxy.
/// let mut colliders = BoneColliders::humanoid();
/// for proxy in colliders.proxies.iter_mut().filter(|p| p.bone.starts_with("upper_arm")) {
///     proxy.radius *= 0.8;
/// }
/// colliders.material.friction = 0.9;
/// let proxies = colliders.proxies.len();
/// let character = app
///     .world_mut()
///     .spawn((Skeleton { rig: Arc::new(humanoid()) }, colliders, Transform::default()))
///     .id();
/// app.update();
/// app.update();
/// // One collider per proxy, each on a child of its bone.
/// let world = app.world_mut();
/// let spawned = world.query::<(&BoneProxyOf, &ClothCollider)>().iter(world).count();
/// assert_eq!(spawned, proxies);
/// # let _ = character;
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
pub struct BoneColliders {
    /// The proxies.
    pub proxies: Vec<BoneProxy>,
    /// Friction and restitution of every proxy.
    pub material: ContactMaterial,
    /// Margin of every proxy, metres.
    pub margin: f32,
}

impl BoneColliders {
    /// The humanoid's proxies ([`humanoid_proxies`]) with friction 0.6, no restitution and a
    /// 5 mm margin.
    pub fn humanoid() -> Self {
        Self {
            proxies: humanoid_proxies(),
            material: ContactMaterial {
                friction: 0.6,
                restitution: 0.0,
            },
            margin: 0.005,
        }
    }
}

/// Marks an entity spawned for a [`BoneColliders`] proxy.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
pub struct BoneProxyOf(pub Entity);

/// Plays a clip on the [`Skeleton`] of the same entity.
#[derive(Component, Clone, Debug, Reflect)]
#[reflect(Component)]
pub struct ClipPlayer {
    /// The clip.
    pub clip: Handle<ClipAsset>,
    /// Time into the clip, seconds.
    pub time: f32,
    /// Playback speed (1 = real time).
    pub speed: f32,
}

impl ClipPlayer {
    /// Plays `clip` from its start at normal speed.
    pub fn new(clip: Handle<ClipAsset>) -> Self {
        Self {
            clip,
            time: 0.0,
            speed: 1.0,
        }
    }
}

/// The bone entities of a [`Skeleton`], by bone index; added by `bevy_drape`.
#[derive(Component, Clone, Debug)]
pub struct SkeletonBones {
    pub(super) entities: Vec<Entity>,
    pub(super) rig: Arc<Rig>,
}

impl SkeletonBones {
    /// The entity of bone `index`.
    pub fn entity(&self, index: usize) -> Option<Entity> {
        self.entities.get(index).copied()
    }

    /// The entity of the bone named `name`.
    pub fn get(&self, name: &str) -> Option<Entity> {
        self.rig.find(name).and_then(|i| self.entity(i))
    }

    /// Every bone entity, by bone index.
    pub fn entities(&self) -> &[Entity] {
        &self.entities
    }
}

/// A bone entity: its index in the rig and its local transforms at the last two fixed steps,
/// for rendering in between.
#[derive(Component, Clone, Debug)]
pub struct BoneEntity {
    /// The bone's index in the rig.
    pub index: usize,
    pub(super) previous: Transform,
    pub(super) current: Transform,
}

impl BoneEntity {
    /// The local transform at the last fixed step (its `Transform` is this one during the
    /// fixed step, and between this and the one before while rendering).
    pub fn current(&self) -> Transform {
        self.current
    }
}

/// The pose a skeleton was given at the last fixed step, with its rate, the bones' states
/// in the character's frame and the character entity's own motion in the world.
#[derive(Component, Clone, Debug)]
pub struct SkeletonPose {
    /// The pose.
    pub pose: Pose,
    /// Its time derivative.
    pub rate: PoseRate,
    /// Every bone's transform and velocity in the character's frame.
    pub bones: Vec<BoneState>,
    /// The character entity's world motion over the last fixed step (its whole transform
    /// chain, parents included), from its pose change; see [`crate::collide::motion`].
    pub frame: FrameStep,
    pub(super) tracker: FrameTracker,
    /// The character's world transform at this fixed step (`None` if it has no valid one).
    pub(super) global: Option<GlobalTransform>,
    pub(super) warned_transform: bool,
    pub(super) bound: Option<(AssetId<ClipAsset>, Result<Clip, ClipError>)>,
}

/// One IK goal of a character: a chain, where its effector should be, and how much IK
/// overrides the animation. It works on both kinds of character (see [`InverseKinematics`]):
///
/// - on a [`Skeleton`], the chain is `end_bone` and its `length - 1` nearest ancestors in the
///   rig, each bone one hinge (the rig's axis and limits; the humanoid's shoulder is two
///   bones, so its arm is `length: 3`);
/// - on any other entity (a glTF scene's root), the chain is the first descendant whose
///   [`Name`] is `end_bone` and its `length - 1` nearest ancestors, each a ball joint turning
///   about its local x, y and z axes within [`IkGoal::joint_limits`] (the glTF humanoid's
///   shoulder is two nodes at one point, so one ball joint, `upper_arm_r`, is the whole
///   shoulder and its arm is `length: 2`).
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct IkGoal {
    /// The chain's last bone (joint).
    pub end_bone: String,
    /// How many bones the chain has (the end bone and its nearest ancestors).
    pub length: usize,
    /// The effector in the end bone's frame, metres.
    pub effector: Vec3,
    /// Where the effector should go.
    pub target: IkTarget,
    /// Tolerance and iteration cap.
    pub settings: IkSettings,
    /// 0 keeps the animated pose (the clip's angles, the joints' animated rotations), 1 the
    /// IK one; in between blends them.
    pub weight: f32,
    /// The fastest the IK angles may turn, rad/s: each step they move towards the solution
    /// by at most this much, so a target that jumps, or a solve that lands on another
    /// solution, moves the limb instead of teleporting it through the cloth. Default in
    /// [`IkGoal::DEFAULT_MAX_SPEED`].
    pub max_speed: f32,
    /// On a character without a [`Skeleton`]: the limits of the chain's ball joints, from the
    /// end bone up (`[0]` the end bone's, `[1]` its parent's, ...); a joint without an entry
    /// is free ([`JointLimits::FREE`]). Ignored on a `Skeleton`, whose bones have the rig's
    /// limits.
    pub joint_limits: Vec<JointLimits>,
}

impl IkGoal {
    /// The default [`IkGoal::max_speed`], rad/s (a fast human arm).
    pub const DEFAULT_MAX_SPEED: f32 = 10.0;
}

/// Where an [`IkGoal`]'s effector should go.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum IkTarget {
    /// A world point.
    Point(Vec3),
    /// A point in the character's own frame (it moves with the character).
    CharacterPoint(Vec3),
    /// The origin of an entity (its transform chain at the current fixed step).
    Entity(Entity),
}

/// Inverse kinematics on a character: the goals are solved in order in
/// [`DrapeSystems::InverseKinematics`](crate::schedule::DrapeSystems::InverseKinematics), after the animation, before the colliders. It works on
/// both kinds of character:
///
/// - **A [`Skeleton`]**: the goals turn the rig's hinges on top of the clip's pose. The hinge
///   rates of the bones it moves (for the colliders' velocities) are the rates of the solved
///   angles at this step, from a second-order one-sided difference of the last three solves.
/// - **Any other entity** (the root of a glTF scene animated by Bevy's `AnimationPlayer`, with
///   `FixedStepAnimation` so it is posed at each fixed step; a hierarchy of your own): a
///   goal's chain is found by [`Name`] below the entity, each joint a ball joint
///   ([`IkGoal::joint_limits`], modelled as in [`BallChain`](crate::skeleton::ik::BallChain)). It is solved from the joints'
///   `Transform`s as the animation has posed them at this step, and the rotations, blended
///   from the animated ones by [`IkGoal::weight`], are written into the joints' `Transform`s,
///   so what hangs from them (the [`BoneColliders`] proxies, a skinned mesh) follows; a joint
///   that nothing animates keeps its own rotation as the animated one. Between fixed steps the
///   joints IK moves are drawn between their last two solved rotations (after Bevy's
///   animation in `PostUpdate`), as the cloth is.
///
/// Each solve starts from the goal's last solution without restarts, and the angles move
/// towards it at most [`IkGoal::max_speed`], so a limb follows its target continuously. A goal
/// that cannot be solved (an end bone the character does not have, a chain longer than the
/// bones above it, a target or weight that is not finite, bad limits) is skipped, its result
/// `None`, with a warning naming the character and the bone (once, until it is solved again).
/// `tests/gltf_ik.rs` checks the glTF humanoid's wrist on random targets while it walks.
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
/// # use std::sync::Arc;
/// let mut app = headless();
/// let target = Vec3::new(-0.3, 1.2, 0.35); // in front of the right hip, within reach
/// let walk = app.world().resource::<AssetServer>().load("clips/walk.clip.ron");
/// let character = app
///     .world_mut()
///     .spawn((
///         Skeleton { rig: Arc::new(humanoid()) },
///         ClipPlayer::new(walk), // IK on top of the walk
///         InverseKinematics {
///             goals: vec![IkGoal {
///                 end_bone: "forearm_r".into(),
///                 length: 3, // the shoulder's two hinges and the elbow
///                 effector: Vec3::new(0.0, -0.25, 0.0), // the wrist, in the forearm's frame
///                 target: IkTarget::Point(target),
///                 settings: IkSettings::default(),
///                 weight: 1.0,
///                 max_speed: IkGoal::DEFAULT_MAX_SPEED,
///                 joint_limits: Vec::new(), // the rig's own limits
///             }],
///             results: Vec::new(),
///         },
///         Transform::default(),
///     ))
///     .id();
/// // One second: the arm turns at most `max_speed` towards the solution.
/// for _ in 0..65 {
///     app.update();
/// }
/// let ik = app.world().get::<InverseKinematics>(character).unwrap();
/// let reached = ik.results[0].as_ref().expect("the target is within reach");
/// assert!(reached.error < 0.01, "{reached:?}");
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
#[require(IkState)]
pub struct InverseKinematics {
    /// The goals.
    pub goals: Vec<IkGoal>,
    /// The last solve of each goal (`None` where a goal could not be solved).
    pub results: Vec<Option<IkResult>>,
}

/// What a chain is built from.
type ChainKey = (String, usize, Vec3);

/// Built chains of an [`InverseKinematics`], cached by goal.
#[derive(Component, Clone, Debug, Default)]
pub struct IkState {
    pub(super) chains: Vec<Option<(ChainKey, Result<IkChain, IkError>)>>,
    pub(super) scratch: IkScratch,
    pub(super) solved: Pose,
    /// The final angles of the last steps, for the hinge rates.
    pub(super) rates: AngleRates,
    /// Each goal's last solution, where the next solve starts.
    pub(super) tracking: Vec<IkTracking>,
    /// Each goal's chain of named joints, on a character without a [`Skeleton`].
    pub(super) named: Vec<NamedChain>,
}

/// What a chain of named joints is built from: the end bone, the length, the limits.
pub(super) type NamedKey = (String, usize, Vec<JointLimits>);

/// Why a goal on named joints is skipped (each warned about once).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum NamedProblem {
    /// The chain cannot be built (no joints, bad limits).
    Chain,
    /// No descendant has the end bone's name.
    NoJoint,
    /// The chain reaches above the character.
    TooLong,
    /// A joint's or the character's transform is not finite, or the effector is not.
    Transform,
    /// The target is not finite (or its entity has no transform).
    Target,
    /// The weight is not finite.
    Weight,
}

/// A goal's chain of named joints, on a character without a [`Skeleton`].
#[derive(Clone, Debug, Default)]
pub(super) struct NamedChain {
    /// What `ball` was built from.
    pub(super) key: Option<NamedKey>,
    /// The chain as ball joints.
    pub(super) ball: Option<Result<BallChain, IkError>>,
    /// The joints' entities, first to end (empty until found), and the first one's parent.
    pub(super) joints: Vec<Entity>,
    pub(super) base: Option<Entity>,
    /// Per joint: what IK did to its rotation at the last fixed steps.
    pub(super) written: Vec<WrittenJoint>,
    /// The last solution, where the next solve starts.
    pub(super) tracking: BallTracking,
    /// The problem last warned about (cleared by a solve).
    pub(super) warned: Option<NamedProblem>,
}

/// A joint's rotations as IK left them.
#[derive(Clone, Copy, Debug)]
pub(super) struct WrittenJoint {
    /// The animated rotation at the last fixed step (before IK).
    pub(super) animated: Quat,
    /// The rotation last written into its `Transform` (at a fixed step or drawn between).
    pub(super) written: Quat,
    /// The rotations written at the last two fixed steps, and whether IK moved it there
    /// (a weight above 0).
    pub(super) previous: (Quat, bool),
    pub(super) current: (Quat, bool),
}

impl FileValue for BoneColliders {
    const EXTENSION: &'static str = "colliders.ron";
}

/// Why a clip file failed to load.
#[derive(Debug, thiserror::Error)]
pub(crate) enum ClipLoadError {
    /// The file could not be read.
    #[error("cannot read the clip file: {0}")]
    Io(#[from] std::io::Error),
    /// The file is not a clip.
    #[error(transparent)]
    Clip(#[from] ClipError),
}

/// On a character: its [`BoneColliders`] from a `.colliders.ron` file
/// (`BoneCollidersFile::new(server.load("x.colliders.ron"))`).
pub type BoneCollidersFile = FromFile<BoneColliders>;
