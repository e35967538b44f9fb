//! Characters in a headless App: a skeleton playing a clip file, inverse kinematics on top of
//! the clip, bone colliders attached by name to any hierarchy.

use crate::common;

use std::time::Duration;

use bevy::prelude::*;
use bevy_drape::collide::plugin::ColliderState;
use bevy_drape::prelude::*;
use bevy_drape::skeleton::clip::ClipDesc;
use bevy_drape::skeleton::plugin::{
    BoneEntity, BoneProxyOf, ClipAsset, SkeletonBones, SkeletonPose,
};
use common::app;

#[test]
fn a_skeleton_plays_a_clip_file_poses_its_bones_and_publishes_their_velocities() {
    let mut app = app();
    let clip: Handle<ClipAsset> = app
        .world()
        .resource::<AssetServer>()
        .load("clips/walk.clip.ron");
    let rig = std::sync::Arc::new(humanoid());
    let character = app
        .world_mut()
        .spawn((Skeleton { rig: rig.clone() }, ClipPlayer::new(clip.clone())))
        .id();
    // Wait for the file.
    for _ in 0..200 {
        app.update();
        if app
            .world()
            .resource::<Assets<ClipAsset>>()
            .get(&clip)
            .is_some()
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(
        app.world()
            .resource::<Assets<ClipAsset>>()
            .get(&clip)
            .is_some()
    );
    let bones = app.world().get::<SkeletonBones>(character).unwrap().clone();
    assert_eq!(bones.entities().len(), 19);
    // A capsule on the left shin, halfway down it.
    let shin = bones.get("shin_l").unwrap();
    let proxy = app
        .world_mut()
        .spawn((
            ClothCollider::capsule(0.05, 0.15),
            Transform::from_xyz(0.0, -0.21, 0.0),
            ChildOf(shin),
        ))
        .id();
    for _ in 0..20 {
        app.update();
    }
    let pose = app.world().get::<SkeletonPose>(character).unwrap().clone();
    // The bone entities carry the forward kinematics of the sampled pose: composing their
    // local transforms of this fixed step from the pelvis down gives the FK positions. (Their
    // `Transform`s show the step before, interpolated for rendering.)
    for name in ["foot_l", "hand_r", "head"] {
        let index = rig.find(name).unwrap();
        let mut chain = vec![index];
        while let Some(p) = rig.bones()[*chain.last().unwrap()].parent {
            chain.push(p);
        }
        let mut world = Transform::IDENTITY;
        for &b in chain.iter().rev() {
            let bone = app
                .world()
                .get::<BoneEntity>(bones.entity(b).unwrap())
                .unwrap();
            world = world * bone.current();
        }
        let fk = pose.bones[index].translation;
        assert!(
            world.translation.distance(fk) < 1e-5,
            "{name}: {} vs {fk}",
            world.translation
        );
    }
    // The swinging shin has a velocity, and the proxy hanging from it moves with it.
    let shin_state = pose.bones[rig.find("shin_l").unwrap()];
    assert!(shin_state.angular_velocity.length() > 0.1);
    let collider = app
        .world()
        .get::<ColliderState>(proxy)
        .unwrap()
        .collider()
        .cloned()
        .unwrap();
    let expected = shin_state.point_velocity(Vec3::from(collider.end.translation));
    assert!(
        (Vec3::from(collider.linear_velocity) - expected).length() < 0.05 * expected.length(),
        "{} vs {expected}",
        collider.linear_velocity
    );
}

/// The wrist: the end of the forearm, in its frame.
const WRIST: Vec3 = Vec3::new(0.0, -0.25, 0.0);

/// The walk clip, added to the App's clips.
fn walk_clip(app: &mut App) -> Handle<ClipAsset> {
    app.world_mut()
        .resource_mut::<Assets<ClipAsset>>()
        .add(ClipAsset(
            ClipDesc::from_ron(include_str!("../assets/clips/walk.clip.ron")).unwrap(),
        ))
}

/// A goal putting the wrist at the end of the three-bone chain ending at `end` on `target`.
fn wrist_goal(end: &str, target: IkTarget) -> IkGoal {
    IkGoal {
        end_bone: end.into(),
        length: 3,
        effector: WRIST,
        target,
        settings: IkSettings::default(),
        weight: 1.0,
        max_speed: IkGoal::DEFAULT_MAX_SPEED,
        joint_limits: Vec::new(),
    }
}

#[test]
fn inverse_kinematics_puts_both_wrists_on_their_targets_on_top_of_the_clip() {
    let mut app = app();
    let clip = walk_clip(&mut app);
    let rig = std::sync::Arc::new(humanoid());
    let marker = app
        .world_mut()
        .spawn(Transform::from_xyz(-0.3, 1.2, 2.35))
        .id();
    let character = app
        .world_mut()
        .spawn((
            Skeleton { rig: rig.clone() },
            ClipPlayer::new(clip),
            InverseKinematics {
                goals: vec![
                    // Entity and point targets, 2 m forward of the origin where the character
                    // stands.
                    wrist_goal("forearm_r", IkTarget::Entity(marker)),
                    wrist_goal("forearm_l", IkTarget::Point(Vec3::new(0.35, 1.1, 2.3))),
                    wrist_goal("tail", IkTarget::Point(Vec3::ZERO)),
                ],
                results: Vec::new(),
            },
            Transform::from_xyz(0.0, 0.0, 2.0),
        ))
        .id();
    for _ in 0..30 {
        app.update();
    }
    let ik = app.world().get::<InverseKinematics>(character).unwrap();
    let pose = app.world().get::<SkeletonPose>(character).unwrap();
    assert_eq!(ik.results.len(), 3);
    assert!(ik.results[2].is_none(), "the bad goal is skipped");
    for (g, (bone, target)) in [
        ("forearm_r", Vec3::new(-0.3, 1.2, 2.35)),
        ("forearm_l", Vec3::new(0.35, 1.1, 2.3)),
    ]
    .into_iter()
    .enumerate()
    {
        let result = ik.results[g].unwrap();
        assert!(result.reached, "{bone}: {result:?}");
        let b = pose.bones[rig.find(bone).unwrap()];
        let wrist = b.translation + b.rotation * WRIST + Vec3::Z * 2.0;
        assert!(wrist.distance(target) < 1e-3, "{bone}: {wrist} vs {target}");
    }
}

#[test]
fn inverse_kinematics_keeps_the_wrist_on_the_ik_circle_examples_moving_target() {
    // The `ik_circle` example's path: the humanoid walks in place by its clip while its right
    // wrist follows a point going round a circle in front of the right shoulder (centre
    // (-0.22, 1.3, 0.32), a turn in 2 s), here at random radii and starting phases: once the
    // arm has reached the circle, every fixed step ends with the wrist on the step's target.
    const CENTRE: Vec3 = Vec3::new(-0.22, 1.3, 0.32);
    const PERIOD: f32 = 2.0;
    let mut rng = common::Rng(29);
    for _ in 0..3 {
        let (radius, phase) = (rng.range(0.03, 0.09), rng.range(0.0, PERIOD));
        let target_at = |t: f32| {
            let a = std::f32::consts::TAU * (t + phase) / PERIOD;
            CENTRE + Vec3::new(a.cos(), a.sin(), 0.0) * radius
        };
        let mut app = app();
        let clip = walk_clip(&mut app);
        let rig = std::sync::Arc::new(humanoid());
        let character = app
            .world_mut()
            .spawn((
                Skeleton { rig: rig.clone() },
                ClipPlayer::new(clip),
                InverseKinematics {
                    goals: vec![wrist_goal("forearm_r", IkTarget::Point(target_at(0.0)))],
                    results: Vec::new(),
                },
                Transform::default(),
            ))
            .id();
        let forearm = rig.find("forearm_r").unwrap();
        let (mut worst, mut measured, mut reached) = (0.0f32, 0, 0);
        for step in 0..192 {
            // One 1/64 s fixed step per update: the target of the step it ends.
            let t = (step + 1) as f32 / 64.0;
            let target = target_at(t);
            if let Some(mut ik) = app.world_mut().get_mut::<InverseKinematics>(character) {
                ik.goals[0].target = IkTarget::Point(target);
            }
            app.update();
            let b = app.world().get::<SkeletonPose>(character).unwrap().bones[forearm];
            let wrist = b.translation + b.rotation * WRIST;
            let ik = app.world().get::<InverseKinematics>(character).unwrap();
            if t > 0.5 {
                let result = ik.results[0].expect("the goal is solved");
                measured += 1;
                // Where the solver says it reached the step's target, the wrist is on it.
                if result.reached {
                    reached += 1;
                    worst = worst.max(wrist.distance(target));
                }
            }
        }
        // The circle is within the arm's reach through most of the walk (the shoulder swings
        // part of it out of reach, more of a larger circle: 139 of 160 steps reach it at
        // 0.08 m; the example shows the trace leaving the circle there).
        assert!(
            reached * 4 >= measured * 3,
            "radius {radius}: reached in {reached} of {measured} steps"
        );
        assert!(
            worst < 1e-3,
            "radius {radius}, phase {phase}: the wrist {worst} m off the circle"
        );
    }
}

#[test]
fn bone_colliders_attach_by_name_to_any_hierarchy_once_it_is_there() {
    // A hierarchy of the game's own (as a glTF scene spawns it, some frames late): the root
    // with `BoneColliders` first, the joints after. A name found twice takes the shallower
    // joint; a proxy on a joint the hierarchy does not have is skipped.
    let mut app = app();
    let mut colliders = BoneColliders::humanoid();
    colliders
        .proxies
        .retain(|p| p.bone == "pelvis" || p.bone == "spine");
    let mut tail = colliders.proxies[0].clone();
    tail.bone = "tail".into();
    colliders.proxies.push(tail);
    let root = app
        .world_mut()
        .spawn((colliders.clone(), Transform::default()))
        .id();
    let proxies_of = |app: &mut App| {
        let world = app.world_mut();
        let mut found: Vec<(String, Entity, f32)> = world
            .query::<(&Name, &ClothCollider, &BoneProxyOf, &ChildOf)>()
            .iter(world)
            .filter(|(_, _, of, _)| of.0 == root)
            .map(|(name, c, _, parent)| {
                let radius = match c.shape {
                    ColliderShape::Capsule { radius, .. } => radius,
                    _ => panic!("proxies are capsules"),
                };
                (name.to_string(), parent.parent(), radius)
            })
            .collect();
        found.sort_by(|a, b| a.0.cmp(&b.0));
        found
    };
    for _ in 0..3 {
        app.update();
    }
    assert!(proxies_of(&mut app).is_empty(), "nothing to attach to yet");
    let world = app.world_mut();
    let pelvis = world
        .spawn((Name::new("pelvis"), Transform::default(), ChildOf(root)))
        .id();
    let spine = world
        .spawn((Name::new("spine"), Transform::default(), ChildOf(pelvis)))
        .id();
    world.spawn((Name::new("pelvis"), Transform::default(), ChildOf(spine)));
    app.update();
    app.update();
    let found = proxies_of(&mut app);
    let pelvis_proxies = colliders
        .proxies
        .iter()
        .filter(|p| p.bone == "pelvis")
        .count();
    assert_eq!(found.len(), colliders.proxies.len() - 1, "{found:?}");
    assert!(
        found
            .iter()
            .filter(|f| f.0 == "pelvis proxy")
            .all(|f| f.1 == pelvis)
    );
    assert_eq!(
        found.iter().filter(|f| f.1 == pelvis).count(),
        pelvis_proxies
    );
    assert!(
        found
            .iter()
            .filter(|f| f.0 == "spine proxy")
            .all(|f| f.1 == spine)
    );
    // An edit (an inspector's, a file's): the proxies are spawned again from it, once.
    app.world_mut()
        .get_mut::<BoneColliders>(root)
        .unwrap()
        .proxies[0]
        .radius = 0.25;
    app.update();
    app.update();
    let again = proxies_of(&mut app);
    assert_eq!(again.len(), found.len());
    assert_eq!(again.iter().filter(|f| f.2 == 0.25).count(), 1);
    // The scene spawned anew (its file reloaded): the old joints go with their proxies, and
    // the proxies are attached to the new joints, none left over.
    app.world_mut().entity_mut(pelvis).despawn();
    app.update();
    assert!(proxies_of(&mut app).is_empty());
    let world = app.world_mut();
    let new_pelvis = world
        .spawn((Name::new("pelvis"), Transform::default(), ChildOf(root)))
        .id();
    let new_spine = world
        .spawn((
            Name::new("spine"),
            Transform::default(),
            ChildOf(new_pelvis),
        ))
        .id();
    app.update();
    let respawned = proxies_of(&mut app);
    assert_eq!(respawned.len(), found.len(), "{respawned:?}");
    assert!(
        respawned
            .iter()
            .all(|f| (f.1 == new_pelvis) == (f.0 == "pelvis proxy") && f.1 != pelvis)
    );
    assert_eq!(
        respawned.iter().filter(|f| f.1 == new_spine).count(),
        found.len() - pelvis_proxies
    );
}
