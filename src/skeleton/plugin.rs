//! The Bevy side of skeletons: clip assets (`*.clip.ron`), the [`Skeleton`] and
//! [`ClipPlayer`] components, bone entities, and the thin systems that sample clips in the
//! fixed schedule, write bone transforms and publish bone velocities for colliders.

use bevy::ecs::query::QueryData;
use std::sync::Arc;

use bevy::app::{App, Plugin, PostUpdate, PreUpdate};
use bevy::asset::io::Reader;
use bevy::asset::{Asset, AssetApp, AssetId, AssetLoader, Assets, Handle, LoadContext};
use bevy::log::{error, warn};
use bevy::math::{Quat, Vec3};
use bevy::prelude::*;
use bevy::reflect::TypePath;
use bevy::transform::TransformSystems;
use bevy::transform::helper::TransformHelper;

use super::clip::{Clip, ClipDesc, ClipError};
use super::humanoid::{BoneProxy, humanoid_proxies};
use super::ik::{AngleRates, IkChain, IkError, IkResult, IkScratch, IkSettings, IkTracking, solve};
use super::rig::{BoneState, Pose, PoseRate, Rig};
use crate::collide::components::{AnimatedVelocity, ClothCollider};
use crate::collide::{ContactMaterial, FrameStep, FrameTracker};
use crate::files::{FileValue, FromFile};
use crate::schedule::{DrapeSchedule, DrapeSettings, DrapeSystems, world_pose};

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

/// A character: its rig. `bevy_drape` spawns one child entity per bone (see
/// [`SkeletonBones`]) in the hierarchy of the rig, so meshes and colliders can hang from them.
#[derive(Component, Clone, Debug)]
#[require(Transform)]
pub struct Skeleton {
    /// The rig.
    pub rig: Arc<Rig>,
}

/// Collision proxies for the cloth on a character's bones, by bone name: each proxy becomes a
/// [`ClothCollider`] capsule (or sphere) on a child entity of its bone, moving with it.
///
/// - With a [`Skeleton`] on the same entity, the bones are the rig's: the proxies are spawned
///   with the bone entities and take their velocity from the joints' ([`AnimatedVelocity`]).
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
    entities: Vec<Entity>,
    rig: Arc<Rig>,
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
    previous: Transform,
    current: Transform,
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
    tracker: FrameTracker,
    /// The character's world transform at this fixed step (`None` if it has no valid one).
    global: Option<GlobalTransform>,
    warned_transform: bool,
    bound: Option<(AssetId<ClipAsset>, Result<Clip, ClipError>)>,
}

/// Spawns bone entities (in `PreUpdate`), samples clips in [`DrapeSystems::Animate`], solves
/// IK and poses the bones in [`DrapeSystems::InverseKinematics`], and interpolates bone
/// transforms for rendering.
#[derive(Default)]
pub struct SkeletonPlugin;

impl Plugin for SkeletonPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        // A colliders file is applied first, then proxies are spawned (again) from it.
        crate::files::add_file_type::<BoneColliders, _>(
            app,
            PreUpdate,
            (respawn_changed_proxies, attach_proxies_by_name, spawn_bones).chain(),
        );
        app.register_type::<(BoneColliders, BoneProxyOf, ClipPlayer, InverseKinematics)>()
            .init_asset::<ClipAsset>()
            .init_asset_loader::<ClipLoader>()
            .add_systems(
                schedule,
                (track_skeletons, play_clips)
                    .chain()
                    .in_set(DrapeSystems::Animate),
            )
            .add_systems(
                schedule,
                (solve_ik, pose_bones)
                    .chain()
                    .in_set(DrapeSystems::InverseKinematics),
            )
            .add_systems(
                PostUpdate,
                interpolate_bones.before(TransformSystems::Propagate),
            );
    }
}

fn local_transform(rig: &Rig, bone: usize, pose: &Pose) -> Transform {
    let b = &rig.bones()[bone];
    match b.parent {
        None => {
            Transform::from_translation(pose.root_translation).with_rotation(pose.root_rotation)
        }
        Some(_) => {
            let angle = pose.angles.get(bone).copied().unwrap_or(0.0);
            let angle = b.limits.map_or(angle, |(lo, hi)| angle.clamp(lo, hi));
            Transform::from_translation(b.offset).with_rotation(rig.local_rotation(bone, angle))
        }
    }
}

/// Marks an entity without a [`Skeleton`] whose [`BoneColliders`] have been attached to its
/// descendants by name.
#[derive(Component, Clone, Copy, Debug, Default)]
pub(crate) struct ProxiesAttachedByName;

/// Spawns the collision proxies of `colliders` (of character `entity`) on the bone entities
/// `bone` finds by name.
fn spawn_proxies(
    commands: &mut Commands,
    entity: Entity,
    colliders: &BoneColliders,
    bone: impl Fn(&str) -> Option<Entity>,
) {
    for proxy in &colliders.proxies {
        let Some(bone) = bone(&proxy.bone) else {
            warn!(
                "character {entity}: collision proxy on bone {:?}, which it does not have",
                proxy.bone
            );
            continue;
        };
        let mut collider = ClothCollider::capsule(proxy.radius, proxy.half_length);
        collider.material = colliders.material;
        collider.margin = colliders.margin;
        commands.spawn((
            Name::new(format!("{} proxy", proxy.bone)),
            collider,
            Transform::from_translation(proxy.centre).with_rotation(proxy.rotation()),
            BoneProxyOf(entity),
            ChildOf(bone),
        ));
    }
}

/// Characters whose [`BoneColliders`] changed after their proxies were spawned.
type ChangedAfterSpawn = (
    Changed<BoneColliders>,
    Or<(With<SkeletonBones>, With<ProxiesAttachedByName>)>,
);

/// Characters without a [`Skeleton`] whose proxies are not attached yet.
type NotYetAttached = (Without<Skeleton>, Without<ProxiesAttachedByName>);

/// Spawns the proxies again of every character whose [`BoneColliders`] changed after they were
/// spawned (a colliders file reloaded, an inspector's edit): at once on a skeleton, through
/// [`attach_proxies_by_name`] on any other entity.
fn respawn_changed_proxies(
    mut commands: Commands,
    characters: Query<(Entity, &BoneColliders, Option<&SkeletonBones>), ChangedAfterSpawn>,
    proxies: Query<(Entity, &BoneProxyOf)>,
) {
    for (entity, colliders, bones) in &characters {
        for (proxy, of) in &proxies {
            if of.0 == entity {
                commands.entity(proxy).despawn();
            }
        }
        match bones {
            Some(bones) => spawn_proxies(&mut commands, entity, colliders, |name| bones.get(name)),
            None => {
                commands.entity(entity).remove::<ProxiesAttachedByName>();
            }
        }
    }
}

/// Attaches the [`BoneColliders`] of every entity without a [`Skeleton`] to its descendants
/// by [`Name`], once one of them has a proxy's bone name (a scene spawns some frames after it
/// is asked for). An entity whose descendants have none of the names is reported once.
fn attach_proxies_by_name(
    mut commands: Commands,
    characters: Query<(Entity, &BoneColliders), NotYetAttached>,
    children: Query<&Children>,
    names: Query<&Name>,
    mut reported: Local<Vec<Entity>>,
) {
    for (entity, colliders) in &characters {
        let mut bones: Vec<(&str, Entity)> = Vec::new();
        let mut descendants = 0usize;
        for descendant in children.iter_descendants(entity) {
            descendants += 1;
            let Ok(name) = names.get(descendant) else {
                continue;
            };
            let name = name.as_str();
            if !bones.iter().any(|(n, _)| *n == name)
                && colliders.proxies.iter().any(|p| p.bone == name)
            {
                bones.push((name, descendant));
            }
        }
        if bones.is_empty() {
            if descendants > 0 && !colliders.proxies.is_empty() && !reported.contains(&entity) {
                warn!(
                    "character {entity}: none of its {descendants} descendants is named like a \
                     bone of its BoneColliders (the first is {:?})",
                    colliders.proxies[0].bone
                );
                reported.push(entity);
            }
            continue;
        }
        reported.retain(|&e| e != entity);
        spawn_proxies(&mut commands, entity, colliders, |name| {
            bones.iter().find(|(n, _)| *n == name).map(|&(_, e)| e)
        });
        commands.entity(entity).insert(ProxiesAttachedByName);
    }
}

/// Spawns the bone entities of every new skeleton, in its rest pose.
fn spawn_bones(
    mut commands: Commands,
    skeletons: Query<(Entity, &Skeleton, Option<&BoneColliders>), Without<SkeletonBones>>,
) {
    for (entity, skeleton, proxies) in &skeletons {
        let rig = &skeleton.rig;
        let pose = rig.rest_pose();
        let mut entities: Vec<Entity> = Vec::with_capacity(rig.bones().len());
        for (i, bone) in rig.bones().iter().enumerate() {
            let parent = bone.parent.map_or(entity, |p| entities[p]);
            let local = local_transform(rig, i, &pose);
            let id = commands
                .spawn((
                    Name::new(bone.name.clone()),
                    local,
                    BoneEntity {
                        index: i,
                        previous: local,
                        current: local,
                    },
                    AnimatedVelocity::default(),
                    ChildOf(parent),
                ))
                .id();
            entities.push(id);
        }
        if let Some(proxies) = proxies {
            spawn_proxies(&mut commands, entity, proxies, |name| {
                rig.find(name).map(|i| entities[i])
            });
        }
        let mut bones = Vec::new();
        rig.forward(&pose, None, &mut bones);
        commands.entity(entity).insert((
            SkeletonBones {
                entities,
                rig: rig.clone(),
            },
            SkeletonPose {
                rate: PoseRate {
                    root_velocity: Vec3::ZERO,
                    root_angular_velocity: Vec3::ZERO,
                    angle_rates: vec![0.0; rig.bones().len()],
                },
                pose,
                bones,
                frame: FrameStep::at_rest(crate::collide::RigidPose::IDENTITY),
                tracker: FrameTracker::default(),
                global: None,
                warned_transform: false,
                bound: None,
            },
        ));
    }
}

/// Reads every character's world transform at this fixed step (its whole chain, whatever
/// moved it) and its motion since the last step; the rest of the step uses this one.
fn track_skeletons(
    mut skeletons: Query<(Entity, &mut SkeletonPose)>,
    transforms: TransformHelper,
    time: Res<Time>,
    drape: Option<Res<DrapeSettings>>,
) {
    let dt = time.delta_secs();
    let teleport = drape.map_or(Some(Default::default()), |d| d.teleport);
    for (entity, mut state) in &mut skeletons {
        let state = &mut *state;
        let global = transforms.compute_global_transform(entity).ok();
        match global.and_then(|g| Some((g, world_pose(&g)?))) {
            Some((global, pose)) => {
                state.frame = state.tracker.step(pose, dt, teleport.as_ref());
                state.global = Some(global);
                state.warned_transform = false;
            }
            None => {
                if !state.warned_transform {
                    warn!("skeleton {entity} has no valid transform: its bones are not posed");
                    state.warned_transform = true;
                }
                state.tracker.reset();
                state.global = None;
            }
        }
    }
}

/// A character playing a clip.
#[derive(QueryData)]
#[query_data(mutable)]
struct Player {
    entity: Entity,
    skeleton: &'static Skeleton,
    player: &'static mut ClipPlayer,
    pose: &'static mut SkeletonPose,
}

/// Advances every clip player and samples its clip into the skeleton's pose and rate.
fn play_clips(mut players: Query<Player>, clips: Res<Assets<ClipAsset>>, time: Res<Time>) {
    let dt = time.delta_secs();
    for item in &mut players {
        let (entity, skeleton, mut player, mut state) =
            (item.entity, item.skeleton, item.player, item.pose);
        let state = &mut *state;
        let Some(asset) = clips.get(&player.clip) else {
            continue;
        };
        let id = player.clip.id();
        if state.bound.as_ref().is_none_or(|(bound, _)| *bound != id) {
            let bound = Clip::new(&asset.0, &skeleton.rig);
            if let Err(err) = &bound {
                error!("skeleton {entity} cannot play its clip: {err}");
            }
            state.bound = Some((id, bound));
        }
        let Some((_, Ok(clip))) = &state.bound else {
            continue;
        };
        if player.speed.is_finite() && dt.is_finite() {
            player.time += dt * player.speed;
            if clip.looping() && clip.duration() > 0.0 {
                player.time = player.time.rem_euclid(clip.duration());
            }
        }
        clip.sample(player.time, &mut state.pose, &mut state.rate);
        for r in &mut state.rate.angle_rates {
            *r *= player.speed;
        }
        state.rate.root_velocity *= player.speed;
        state.rate.root_angular_velocity *= player.speed;
    }
}

/// One IK goal of a character: a chain, where its effector should be, and how much IK
/// overrides the keyframes.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct IkGoal {
    /// The chain's last bone.
    pub end_bone: String,
    /// How many bones the chain has (the end bone and its nearest ancestors).
    pub length: usize,
    /// The effector in the end bone's frame, metres.
    pub effector: Vec3,
    /// Where the effector should go.
    pub target: IkTarget,
    /// Tolerance and iteration cap.
    pub settings: IkSettings,
    /// 0 keeps the keyframed angles, 1 the IK ones; in between blends them.
    pub weight: f32,
    /// The fastest the IK angles may turn, rad/s: each step they move towards the solution
    /// by at most this much, so a target that jumps, or a solve that lands on another
    /// solution, moves the limb instead of teleporting it through the cloth. Default in
    /// [`IkGoal::DEFAULT_MAX_SPEED`].
    pub max_speed: f32,
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

/// Inverse kinematics on a [`Skeleton`]: the goals are solved in order in
/// [`DrapeSystems::InverseKinematics`], after the clip, before the colliders. The hinge rates
/// of the bones it moves (for the colliders' velocities) are the rates of the solved angles
/// at this step, from a second-order one-sided difference of the last three solves. Each solve
/// starts from the goal's last solution without restarts, and the angles move towards it at
/// most [`IkGoal::max_speed`], so a limb follows its target continuously.
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
    chains: Vec<Option<(ChainKey, Result<IkChain, IkError>)>>,
    scratch: IkScratch,
    solved: Pose,
    /// The final angles of the last steps, for the hinge rates.
    rates: AngleRates,
    /// Each goal's last solution, where the next solve starts.
    tracking: Vec<IkTracking>,
}

/// A character with IK goals.
#[derive(QueryData)]
#[query_data(mutable)]
struct IkCharacter {
    entity: Entity,
    skeleton: &'static Skeleton,
    ik: &'static mut InverseKinematics,
    pose: &'static mut SkeletonPose,
    state: &'static mut IkState,
}

/// Solves every character's IK goals on top of its keyframed pose.
fn solve_ik(mut characters: Query<IkCharacter>, transforms: TransformHelper, time: Res<Time>) {
    let dt = time.delta_secs();
    for item in &mut characters {
        let (entity, skeleton, mut ik, mut state, mut ik_state) =
            (item.entity, item.skeleton, item.ik, item.pose, item.state);
        let state = &mut *state;
        let Some(character) = state.global else {
            continue;
        };
        let to_local = character.affine().inverse();
        let rig = &skeleton.rig;
        let ik = &mut *ik;
        let ik_state = &mut *ik_state;
        ik.results.resize(ik.goals.len(), None);
        ik_state.chains.resize(ik.goals.len(), None);
        let keyframed = state.pose.angles.clone();
        for (g, goal) in ik.goals.iter().enumerate() {
            ik.results[g] = None;
            let key = (goal.end_bone.clone(), goal.length, goal.effector);
            if ik_state.chains[g]
                .as_ref()
                .is_none_or(|(built, _)| *built != key)
            {
                let chain = IkChain::new(rig, &goal.end_bone, goal.length, goal.effector);
                if let Err(err) = &chain {
                    warn!("character {entity}: IK goal {g} is ignored: {err}");
                }
                ik_state.chains[g] = Some((key, chain));
                if let Some(tracking) = ik_state.tracking.get_mut(g) {
                    tracking.forget();
                }
            }
            let Some((_, Ok(chain))) = &ik_state.chains[g] else {
                continue;
            };
            let target = match goal.target {
                IkTarget::Point(p) => Some(to_local.transform_point3(p)),
                IkTarget::CharacterPoint(p) => Some(p),
                IkTarget::Entity(e) => transforms
                    .compute_global_transform(e)
                    .ok()
                    .map(|t| to_local.transform_point3(t.translation())),
            };
            let Some(target) = target.filter(|t| t.is_finite()) else {
                continue;
            };
            // Start from this goal's last solution (a solve from nearby converges to the nearby
            // solution, so the arm does not flip to another one between steps), or from the
            // keyframes the first time.
            ik_state.solved.clone_from(&state.pose);
            ik_state
                .tracking
                .resize(ik.goals.len(), IkTracking::default());
            let settings =
                ik_state.tracking[g].warm_start(chain, &mut ik_state.solved, &goal.settings);
            let result = solve(
                rig,
                chain,
                &mut ik_state.solved,
                target,
                &settings,
                &mut ik_state.scratch,
            );
            // Towards the solution at most `max_speed`; the next solve starts from here.
            ik_state.tracking[g].follow(chain, &mut ik_state.solved, goal.max_speed * dt);
            let weight = goal.weight.clamp(0.0, 1.0);
            for &b in &chain.bones {
                let (from, to) = (state.pose.angles[b], ik_state.solved.angles[b]);
                state.pose.angles[b] = from + (to - from) * weight;
            }
            ik.results[g] = Some(result);
        }
        // Hinge rates of the bones IK moved: the rates of their final angles at this step.
        for (b, (&angle, &keyed)) in state.pose.angles.iter().zip(&keyframed).enumerate() {
            if angle != keyed
                && let Some(rate) = ik_state.rates.rate(b, angle, dt)
                && let Some(slot) = state.rate.angle_rates.get_mut(b)
            {
                *slot = rate;
            }
        }
        ik_state.rates.push(&state.pose.angles);
    }
}

/// Runs forward kinematics on every skeleton's pose, writes its bone transforms and publishes
/// the bones' world velocities: the character entity's own motion (its transform chain at
/// this fixed step against the last) plus the joints' motion turned into the world.
fn pose_bones(
    mut skeletons: Query<(&Skeleton, &SkeletonBones, &mut SkeletonPose)>,
    mut bones: Query<(&mut Transform, &mut BoneEntity, &mut AnimatedVelocity)>,
) {
    for (skeleton, skeleton_bones, mut state) in &mut skeletons {
        let state = &mut *state;
        skeleton
            .rig
            .forward(&state.pose, Some(&state.rate), &mut state.bones);
        let Some(global) = state.global else {
            continue;
        };
        let frame = state.frame;
        let (scale, rotation, _) = global.to_scale_rotation_translation();
        let rotation: Quat = rotation.normalize();
        for (i, &bone_entity) in skeleton_bones.entities().iter().enumerate() {
            let Ok((mut transform, mut bone, mut velocity)) = bones.get_mut(bone_entity) else {
                continue;
            };
            let local = local_transform(&skeleton.rig, i, &state.pose);
            if !(local.translation.is_finite() && local.rotation.is_finite()) {
                continue;
            }
            bone.previous = bone.current;
            bone.current = local;
            *transform = local;
            let b = state.bones[i];
            let at = global.transform_point(b.translation);
            velocity.linear =
                Vec3::from(frame.velocity_at(at.into())) + rotation * (scale * b.linear_velocity);
            velocity.angular = Vec3::from(frame.angular_velocity) + rotation * b.angular_velocity;
        }
    }
}

/// Between fixed steps, shows every bone between its last two poses.
fn interpolate_bones(mut bones: Query<(&mut Transform, &BoneEntity)>, fixed: Res<Time<Fixed>>) {
    let alpha = fixed.overstep_fraction().clamp(0.0, 1.0);
    for (mut transform, bone) in &mut bones {
        transform.translation = bone
            .previous
            .translation
            .lerp(bone.current.translation, alpha);
        transform.rotation = bone.previous.rotation.slerp(bone.current.rotation, alpha);
    }
}

impl FileValue for BoneColliders {
    const EXTENSION: &'static str = "colliders.ron";
}

/// On a character: its [`BoneColliders`] from a `.colliders.ron` file
/// (`BoneCollidersFile::new(server.load("x.colliders.ron"))`).
pub type BoneCollidersFile = FromFile<BoneColliders>;
