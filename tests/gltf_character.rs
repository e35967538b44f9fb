//! A glTF character: the humanoid written as a `.glb` (`drape_scenes::gltf_export`), loaded as
//! a scene and animated by Bevy's `AnimationPlayer`, wearing the poncho through
//! `BoneColliders` attached to its joints by name.
//!
//! - The file in `assets/` is what the generator writes.
//! - The loaded joints follow the crate's own forward kinematics of the walk clip at the
//!   player's time, between the file's samples too (a converged reference: the file samples
//!   the clip at 60 Hz), at every fixed step of frames three steps long
//!   (`FixedStepAnimation`); without it they stand still in two steps of three.
//! - The poncho drapes on the character while it walks through the world: no particle deeper
//!   in a proxy than the margin, finite, the centroid over the chest.

use crate::common;

use std::time::Duration;

use bevy::animation::AnimationPlayer;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy_drape::cloth::plugin::ClothSimulation;
use bevy_drape::collide::SolverShape;
use bevy_drape::prelude::*;
use bevy_drape::skeleton::clip::{Clip, ClipDesc};
use bevy_drape::skeleton::plugin::BoneProxyOf;
use bevy_drape::skeleton::rig::Rig;
use bevy_drape::skeleton::rig::{Pose, PoseRate};
use common::{an_animation_plays, update_until_loaded};
use drape_scenes::gltf_character::{GltfCharacter, GltfCharacterScene, headless_app};
use drape_scenes::poncho::{CharacterController, CharacterMotion, Poncho};

#[test]
fn the_character_file_is_what_the_generator_writes() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/characters/humanoid.glb"
    );
    let file = std::fs::read(path).unwrap();
    assert!(
        file == drape_scenes::gltf_export::humanoid_glb(),
        "assets/characters/humanoid.glb is stale: run `cargo run --example generate_character`"
    );
}

/// Updates with time standing still until the scene has spawned, its walk is playing and the
/// poncho's mesh has loaded.
fn wait_for_the_scene(app: &mut App) {
    update_until_loaded(app, |world| {
        let meshes: Vec<AssetId<Mesh>> = world
            .query_filtered::<&Mesh3d, With<Poncho>>()
            .iter(world)
            .map(|m| m.0.id())
            .collect();
        an_animation_plays(world)
            && !meshes.is_empty()
            && meshes
                .iter()
                .all(|&id| world.resource::<Assets<Mesh>>().get(id).is_some())
    });
}

/// The world transform of the first entity named `name`.
fn joint(world: &mut World, name: &str) -> GlobalTransform {
    let mut q = world.query::<(&Name, &GlobalTransform)>();
    q.iter(world)
        .find(|(n, _)| n.as_str() == name)
        .map(|(_, g)| *g)
        .unwrap_or_else(|| panic!("no joint {name}"))
}

/// The rig's own forward kinematics of the walk clip, the reference the loaded joints are
/// checked against.
struct WalkReference {
    rig: Rig,
    clip: Clip,
    pose: Pose,
    rate: PoseRate,
    states: Vec<bevy_drape::skeleton::rig::BoneState>,
}

impl WalkReference {
    fn new() -> Self {
        let rig = humanoid();
        let desc = ClipDesc::from_ron(include_str!("../assets/clips/walk.clip.ron")).unwrap();
        let clip = Clip::new(&desc, &rig).unwrap();
        let pose = Pose {
            angles: vec![0.0; rig.bones().len()],
            ..default()
        };
        Self {
            rig,
            clip,
            pose,
            rate: PoseRate::default(),
            states: Vec::new(),
        }
    }

    /// Every bone's transform in the character's frame at time `t` of the walk.
    fn bones_at(&mut self, t: f32) -> Vec<bevy_drape::skeleton::rig::BoneState> {
        self.clip.sample(t, &mut self.pose, &mut self.rate);
        self.rig.forward(&self.pose, None, &mut self.states);
        self.states.clone()
    }
}

/// The walk's time and every bone's world transform, at each fixed step, as the cloth's
/// colliders see them (after the animation set, before the colliders are read).
#[derive(Resource, Default)]
struct Recorded(Vec<(f32, Vec<GlobalTransform>)>);

fn record_joints(
    players: Query<&AnimationPlayer>,
    names: Query<(Entity, &Name)>,
    transforms: bevy::transform::helper::TransformHelper,
    mut recorded: ResMut<Recorded>,
) {
    let Some(time) = players
        .iter()
        .find_map(|p| p.playing_animations().next().map(|(_, a)| a.seek_time()))
    else {
        return;
    };
    let rig = humanoid();
    let mut joints = Vec::new();
    for bone in rig
        .bones()
        .iter()
        .map(|b| b.name.as_str())
        .chain(["humanoid"])
    {
        let Some((entity, _)) = names.iter().find(|(_, n)| n.as_str() == bone) else {
            return;
        };
        joints.push(transforms.compute_global_transform(entity).unwrap());
    }
    recorded.0.push((time, joints));
}

/// Plays the walk at `speed` with three fixed steps per update (a slow machine's frames),
/// with or without `FixedStepAnimation` on the character, and records each fixed step.
fn walk_in_slow_frames(fixed_step: bool, speed: f32) -> Vec<(f32, Vec<GlobalTransform>)> {
    let mut app = headless_app(GltfCharacterScene {
        motion: CharacterMotion::InPlace,
        ..default()
    });
    app.init_resource::<Recorded>().add_systems(
        FixedPostUpdate,
        record_joints
            .after(DrapeSystems::Animate)
            .before(DrapeSystems::Colliders),
    );
    wait_for_the_scene(&mut app);
    let world = app.world_mut();
    let character = world
        .query_filtered::<Entity, With<GltfCharacter>>()
        .single(world)
        .unwrap();
    // No controller: the test sets the walk's speed.
    world.entity_mut(character).remove::<CharacterController>();
    if !fixed_step {
        world.entity_mut(character).remove::<FixedStepAnimation>();
    }
    for mut player in world.query::<&mut AnimationPlayer>().iter_mut(world) {
        for (_, animation) in player.playing_animations_mut() {
            animation.set_speed(speed);
        }
    }
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        3.0 / 60.0,
    )));
    app.update();
    app.world_mut().resource_mut::<Recorded>().0.clear();
    for _ in 0..60 {
        app.update();
    }
    std::mem::take(&mut app.world_mut().resource_mut::<Recorded>().0)
}

#[test]
fn the_loaded_joints_follow_the_rigs_forward_kinematics_at_every_fixed_step() {
    let mut walk = WalkReference::new();
    let (rig, clip) = (walk.rig.clone(), walk.clip.clone());
    // At 0.73 of its speed the walk's times fall between the file's 60 Hz samples.
    let speed = 0.73;
    let steps = walk_in_slow_frames(true, speed);
    assert_eq!(steps.len(), 180, "three fixed steps per update");
    let (mut worst_distance, mut worst_angle) = (0.0f32, 0.0f32);
    for (k, (time, joints)) in steps.iter().enumerate() {
        let states = walk.bones_at(*time);
        let root = joints[rig.bones().len()];
        for (b, got) in joints[..rig.bones().len()].iter().enumerate() {
            let want = root.mul_transform(
                Transform::from_translation(states[b].translation)
                    .with_rotation(states[b].rotation),
            );
            worst_distance = worst_distance.max(got.translation().distance(want.translation()));
            worst_angle = worst_angle.max(got.rotation().angle_between(want.rotation()));
        }
        // The walk moved by the fixed step at every step, wrapping at the clip's end.
        if k > 0 {
            let advanced = (time - steps[k - 1].0).rem_euclid(clip.duration());
            assert!(
                (advanced - speed / 60.0).abs() < 1e-4,
                "step {k}: the walk advanced {advanced} s"
            );
        }
    }
    eprintln!(
        "joints against the rig: {worst_distance} m, {} degrees at worst",
        worst_angle.to_degrees()
    );
    assert!(steps.iter().any(|s| s.0 < 0.1) && steps.iter().any(|s| s.0 > 0.9));
    assert!(
        worst_distance < 2e-3,
        "a joint was {worst_distance} m from the rig's"
    );
    assert!(
        worst_angle < 0.25f32.to_radians(),
        "a joint turned {} degrees from the rig's",
        worst_angle.to_degrees()
    );
}

#[test]
fn without_fixed_step_animation_the_joints_stand_still_in_most_fixed_steps() {
    // Bevy's own schedule: the pose changes once per rendered frame, in one fixed step of
    // three; with `FixedStepAnimation` the left hand moves in every step.
    let hand = humanoid().find("hand_l").unwrap();
    let still = |steps: &[(f32, Vec<GlobalTransform>)]| {
        steps
            .windows(2)
            .filter(|w| w[0].1[hand].translation() == w[1].1[hand].translation())
            .count()
    };
    let fixed = walk_in_slow_frames(true, 1.0);
    let per_frame = walk_in_slow_frames(false, 1.0);
    assert_eq!(still(&fixed), 0);
    assert!(
        still(&per_frame) >= per_frame.len() / 2,
        "{} of {} steps still",
        still(&per_frame),
        per_frame.len()
    );
}

#[test]
fn between_fixed_steps_the_character_is_drawn_at_the_frames_time() {
    // Frames half a fixed step long (a 120 Hz display): the walk is drawn between its last two
    // fixed steps, as the cloth is, so its time moves half a step every frame instead of a
    // whole step every other frame, and the drawn joints are the rig's at that time.
    let mut app = headless_app(GltfCharacterScene {
        motion: CharacterMotion::InPlace,
        ..default()
    });
    wait_for_the_scene(&mut app);
    let world = app.world_mut();
    let character = world
        .query_filtered::<Entity, With<GltfCharacter>>()
        .single(world)
        .unwrap();
    world.entity_mut(character).remove::<CharacterController>();
    app.insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        0.5 / 60.0,
    )));
    for _ in 0..3 {
        app.update();
    }
    let mut walk = WalkReference::new();
    let (rig, clip) = (walk.rig.clone(), walk.clip.clone());
    let mut times: Vec<f32> = Vec::new();
    let mut worst_distance = 0.0f32;
    for _ in 0..120 {
        app.update();
        let world = app.world_mut();
        let time = world
            .query::<&AnimationPlayer>()
            .iter(world)
            .find_map(|p| p.playing_animations().next().map(|(_, a)| a.seek_time()))
            .unwrap();
        let states = walk.bones_at(time);
        let root = joint(world, "humanoid");
        for (b, bone) in rig.bones().iter().enumerate() {
            let want = root.transform_point(states[b].translation);
            worst_distance =
                worst_distance.max(joint(world, &bone.name).translation().distance(want));
        }
        times.push(time);
    }
    for pair in times.windows(2) {
        let advanced = (pair[1] - pair[0]).rem_euclid(clip.duration());
        assert!(
            (advanced - 0.5 / 60.0).abs() < 1e-4,
            "the walk moved {advanced} s in a frame of half a step"
        );
    }
    assert!(
        worst_distance < 2e-3,
        "a drawn joint was {worst_distance} m from the rig's at its time"
    );
}

#[test]
fn the_poncho_drapes_on_the_gltf_character_walking_through_the_world() {
    let mut app = headless_app(GltfCharacterScene::default());
    wait_for_the_scene(&mut app);
    let margin = BoneColliders::humanoid().margin;
    let proxies = BoneColliders::humanoid().proxies.len();
    let start = Vec3::ZERO;
    let (mut deepest, mut worst_offset, mut travelled, mut steps) = (0.0f32, 0.0f32, 0.0f32, 0);
    for step in 0..600 {
        app.update();
        let world = app.world_mut();
        let attached = world.query::<&BoneProxyOf>().iter(world).count();
        if step > 0 {
            assert_eq!(
                attached, proxies,
                "every proxy is on its joint (step {step})"
            );
        }
        let chest = joint(world, "chest").translation();
        let character = world
            .query_filtered::<&Transform, With<GltfCharacter>>()
            .single(world)
            .unwrap()
            .translation;
        travelled = travelled.max(character.distance(start));
        let mut q = world.query_filtered::<&ClothSimulation, With<Poncho>>();
        let Ok(simulation) = q.single(world) else {
            continue;
        };
        let sim = simulation.solver();
        let x = &sim.state().positions;
        if x.is_empty() {
            continue;
        }
        assert!(sim.is_finite(), "step {step}: a position went non-finite");
        assert!(!simulation.is_frozen(), "step {step}: the poncho froze");
        for c in sim.colliders() {
            if matches!(c.shape, SolverShape::Plane) {
                continue;
            }
            for &p in x {
                if let Some(d) = c.signed_distance(p, 0.0) {
                    deepest = deepest.max(-d);
                }
            }
        }
        if step >= 120 {
            let centroid =
                Vec3::from(x.iter().copied().sum::<bevy::math::Vec3A>()) / x.len() as f32;
            worst_offset = worst_offset.max((centroid - chest).with_y(0.0).length());
            // Resting on the shoulders, not fallen to the ground.
            assert!(centroid.y > 0.9, "step {step}: the poncho is at {centroid}");
        }
        steps += 1;
    }
    eprintln!(
        "{steps} steps: deepest {deepest} m, centroid at most {worst_offset} m from the chest, \
         walked {travelled} m"
    );
    assert!(steps > 590, "the poncho was built: {steps} steps");
    assert!(travelled > 3.0, "the character walked {travelled} m");
    assert!(
        deepest <= margin,
        "a particle was {deepest} m inside a proxy (margin {margin})"
    );
    assert!(
        worst_offset < 0.3,
        "the centroid went {worst_offset} m from the chest"
    );
}

#[test]
fn several_gltf_characters_keep_their_ponchos_when_they_teleport() {
    // Three characters side by side, each jumping 10 m and turning a quarter every 3 s after
    // the first 2 s: each poncho goes with its own character.
    let mut app = headless_app(GltfCharacterScene {
        motion: CharacterMotion::Teleport,
        characters: 3,
        ..default()
    });
    wait_for_the_scene(&mut app);
    let margin = BoneColliders::humanoid().margin;
    let proxies = BoneColliders::humanoid().proxies.len();
    let (mut deepest, mut worst_offset, mut jumps) = (0.0f32, 0.0f32, 0);
    let mut last_positions: Vec<Vec3> = Vec::new();
    for step in 0..600 {
        app.update();
        let world = app.world_mut();
        let characters: Vec<(Entity, Vec3)> = world
            .query_filtered::<(Entity, &Transform), With<GltfCharacter>>()
            .iter(world)
            .map(|(e, t)| (e, t.translation))
            .collect();
        assert_eq!(characters.len(), 3);
        if !last_positions.is_empty() {
            jumps += characters
                .iter()
                .zip(&last_positions)
                .filter(|((_, now), before)| now.distance(**before) > 5.0)
                .count();
        }
        last_positions = characters.iter().map(|c| c.1).collect();
        let mut ponchos = world.query_filtered::<(&Cloth, &ClothSimulation), With<Poncho>>();
        let ponchos: Vec<(Entity, Vec<bevy::math::Vec3A>, bool, Vec<f32>)> = ponchos
            .iter(world)
            .map(|(cloth, simulation)| {
                let sim = simulation.solver();
                let depths = sim
                    .colliders()
                    .iter()
                    .filter(|c| !matches!(c.shape, SolverShape::Plane))
                    .flat_map(|c| {
                        sim.state()
                            .positions
                            .iter()
                            .filter_map(|&p| c.signed_distance(p, 0.0))
                    })
                    .collect();
                (
                    cloth.follow.unwrap(),
                    sim.state().positions.clone(),
                    sim.is_finite(),
                    depths,
                )
            })
            .collect();
        if ponchos.len() < 3 || ponchos.iter().any(|p| p.1.is_empty()) {
            continue;
        }
        for (character, x, finite, depths) in &ponchos {
            assert!(*finite, "step {step}: a poncho went non-finite");
            deepest = depths.iter().fold(deepest, |d, &s| d.max(-s));
            let attached = world
                .query::<&BoneProxyOf>()
                .iter(world)
                .filter(|of| of.0 == *character)
                .count();
            assert_eq!(attached, proxies, "each character has its own proxies");
            if step >= 120 {
                let chest = chest_of(world, *character);
                let centroid =
                    Vec3::from(x.iter().copied().sum::<bevy::math::Vec3A>()) / x.len() as f32;
                worst_offset = worst_offset.max((centroid - chest).with_y(0.0).length());
            }
        }
    }
    eprintln!(
        "{jumps} jumps: deepest {deepest} m, a centroid at most {worst_offset} m from its chest"
    );
    assert!(jumps >= 6, "each character jumped twice: {jumps} jumps");
    assert!(
        deepest <= margin,
        "a particle was {deepest} m inside a proxy"
    );
    assert!(
        worst_offset < 0.3,
        "a centroid went {worst_offset} m from its character's chest"
    );
}

/// The world position of the joint named `chest` under `character`.
fn chest_of(world: &mut World, character: Entity) -> Vec3 {
    let mut children = world.query::<&Children>();
    let mut queue = vec![character];
    while let Some(e) = queue.pop() {
        if world.get::<Name>(e).is_some_and(|n| n.as_str() == "chest") {
            return world.get::<GlobalTransform>(e).unwrap().translation();
        }
        if let Ok(c) = children.get(world, e) {
            queue.extend(c.iter());
        }
    }
    panic!("character {character} has no chest")
}
