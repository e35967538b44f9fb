//! Inverse kinematics on a character without a `Skeleton`: the glTF humanoid
//! (`assets/characters/humanoid.glb`, animated by Bevy's `AnimationPlayer`) and a hand-made
//! hierarchy, their chains found by joint name and solved as ball joints.
//!
//! - While the glTF character walks through the world, its right wrist reaches random targets
//!   around its shoulder (a seeded generator): at every fixed step after a settling time (as
//!   the cloth's colliders see the arm) and as drawn (`GlobalTransform`), and the forearm's
//!   collision proxy is where the solved joint puts it.
//! - Bad goals (a joint the character does not have, a chain longer than the joints above its
//!   end, a target that is not a number, limits that are not ordered) are each warned about
//!   once and skipped; the good goal beside them is solved and every transform stays finite.
//! - On a hierarchy nothing animates, IK's rotation is not taken for the animated one: with
//!   the weight back at 0 the joints return to where they were.

use crate::common;

use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;
use bevy_drape::prelude::*;
use bevy_drape::schedule::StepColliders;
use bevy_drape::skeleton::ik::JointLimits;
use drape_scenes::gltf_character::{GltfCharacter, GltfCharacterScene, headless_app};
use drape_scenes::poncho::{CharacterMotion, WRIST};

use common::warnings::{WARNINGS, capture_warnings, warnings_with};
use common::{Rng, an_animation_plays, update_until_loaded};

/// The glTF character walking through the world, its scene spawned and its walk playing.
fn walking_character() -> (App, Entity) {
    let mut app = headless_app(GltfCharacterScene {
        motion: CharacterMotion::Walk,
        ..default()
    });
    update_until_loaded(&mut app, |world| {
        an_animation_plays(world)
            && world
                .query::<&Name>()
                .iter(world)
                .any(|n| n.as_str() == "forearm_r")
    });
    let world = app.world_mut();
    let character = world
        .query_filtered::<Entity, With<GltfCharacter>>()
        .single(world)
        .unwrap();
    (app, character)
}

/// The right arm's goal: the wrist on `target` (in the character's frame), the shoulder
/// (`upper_arm_r`) a free ball joint, the elbow a hinge about its x axis.
fn right_arm(target: Vec3) -> IkGoal {
    IkGoal {
        end_bone: "forearm_r".into(),
        length: 2,
        effector: WRIST,
        target: IkTarget::CharacterPoint(target),
        settings: IkSettings::default(),
        weight: 1.0,
        max_speed: IkGoal::DEFAULT_MAX_SPEED,
        joint_limits: vec![JointLimits::hinge_x(-2.5, 0.0)],
    }
}

/// The first entity named `name`.
fn named(world: &mut World, name: &str) -> Entity {
    world
        .query::<(Entity, &Name)>()
        .iter(world)
        .find(|(_, n)| n.as_str() == name)
        .map(|(e, _)| e)
        .unwrap_or_else(|| panic!("no entity {name}"))
}

/// `point` (world) in the frame of `character` as drawn.
fn in_character(world: &World, character: Entity, point: Vec3) -> Vec3 {
    let frame = world.get::<GlobalTransform>(character).unwrap();
    frame.affine().inverse().transform_point3(point)
}

/// At each fixed step, after the colliders are gathered: the right wrist in the character's
/// frame, and how far the forearm's proxy, as the cloth sees it, is from where the joints put
/// it.
#[derive(Resource, Default)]
struct FixedSteps(Vec<(Vec3, f32)>);

fn record_fixed_step(
    characters: Query<Entity, With<GltfCharacter>>,
    names: Query<(Entity, &Name)>,
    transforms: TransformHelper,
    colliders: Res<StepColliders>,
    mut steps: ResMut<FixedSteps>,
) {
    let find = |name: &str| {
        names
            .iter()
            .find(|(_, n)| n.as_str() == name)
            .map(|(e, _)| e)
    };
    let (Ok(character), Some(forearm), Some(proxy)) = (
        characters.single(),
        find("forearm_r"),
        find("forearm_r proxy"),
    ) else {
        return;
    };
    let global = |e| transforms.compute_global_transform(e).unwrap();
    let wrist = global(forearm).transform_point(WRIST);
    let wrist = global(character).affine().inverse().transform_point3(wrist);
    let gap = colliders
        .entities
        .iter()
        .position(|&e| e == proxy)
        .map_or(f32::INFINITY, |k| {
            let seen = Vec3::from(colliders.colliders[k].end.translation);
            seen.distance(global(proxy).translation())
        });
    steps.0.push((wrist, gap));
}

#[test]
fn the_gltf_characters_wrist_reaches_random_targets_while_it_walks() {
    let (mut app, character) = walking_character();
    app.init_resource::<FixedSteps>().add_systems(
        FixedPostUpdate,
        record_fixed_step.after(DrapeSystems::Colliders),
    );
    // Around the shoulder as the walk starts: 0.2 to 0.42 m from it (the arm reaches 0.53 m
    // straight and 0.17 m bent to its limit; the walk moves the shoulder a few centimetres).
    app.update();
    let world = app.world_mut();
    let upper_arm = named(world, "upper_arm_r");
    let shoulder = world
        .get::<GlobalTransform>(upper_arm)
        .unwrap()
        .translation();
    let shoulder = in_character(world, character, shoulder);
    let mut rng = Rng(7);
    let targets: Vec<Vec3> = (0..12)
        .map(|_| {
            let direction = rng.unit_vector();
            shoulder + direction * rng.range(0.2, 0.42)
        })
        .collect();
    world.entity_mut(character).insert(InverseKinematics {
        goals: vec![right_arm(targets[0])],
        results: Vec::new(),
    });
    let forearm = named(world, "forearm_r");
    // Each target for 1.5 s: 1 s to settle (at most 10 rad/s from the last solution), then
    // the wrist is checked at every fixed step and as drawn.
    let (mut worst_fixed, mut worst_drawn, mut worst_gap) = (0.0f32, 0.0f32, 0.0f32);
    for (t, &target) in targets.iter().enumerate() {
        let mut ik = app
            .world_mut()
            .get_mut::<InverseKinematics>(character)
            .unwrap();
        ik.goals[0].target = IkTarget::CharacterPoint(target);
        for _ in 0..60 {
            app.update();
        }
        app.world_mut().resource_mut::<FixedSteps>().0.clear();
        for _ in 0..30 {
            app.update();
            let world = app.world();
            let drawn = world
                .get::<GlobalTransform>(forearm)
                .unwrap()
                .transform_point(WRIST);
            let drawn = in_character(world, character, drawn);
            worst_drawn = worst_drawn.max(drawn.distance(target));
            assert!(
                drawn.distance(target) < 0.002,
                "target {t} at {target}: the wrist is drawn at {drawn}"
            );
        }
        let steps = &app.world().resource::<FixedSteps>().0;
        assert_eq!(steps.len(), 30, "one fixed step per update");
        for &(wrist, gap) in steps {
            worst_fixed = worst_fixed.max(wrist.distance(target));
            worst_gap = worst_gap.max(gap);
            assert!(
                wrist.distance(target) < 0.002,
                "target {t} at {target}: the wrist is at {wrist} at a fixed step"
            );
            assert!(gap < 1e-4, "the forearm's proxy is {gap} m off its joint");
        }
        let ik = app.world().get::<InverseKinematics>(character).unwrap();
        assert!(ik.results[0].is_some_and(|r| r.reached), "{:?}", ik.results);
    }
    println!(
        "wrist from its target: {:.2} mm at fixed steps, {:.2} mm drawn; proxy {worst_gap} m",
        worst_fixed * 1e3,
        worst_drawn * 1e3
    );
    // The character walked and turned through the world meanwhile.
    let moved = app.world().get::<Transform>(character).unwrap().translation;
    assert!(moved.length() > 1.0, "the character stood at {moved}");
}

#[test]
fn bad_goals_on_a_gltf_character_are_warned_about_once_and_skipped() {
    capture_warnings();
    let (mut app, character) = walking_character();
    let nan = Vec3::new(f32::NAN, 1.0, 0.0);
    let mut missing = right_arm(Vec3::new(-0.3, 1.5, 0.2));
    missing.end_bone = "tail_of_the_gltf_humanoid".into();
    let mut too_long = right_arm(Vec3::new(-0.3, 1.5, 0.2));
    too_long.length = 12;
    let mut not_a_number = right_arm(nan);
    not_a_number.target = IkTarget::Point(nan);
    let mut unordered = right_arm(Vec3::new(-0.3, 1.5, 0.2));
    unordered.joint_limits = vec![JointLimits {
        x: (0.0, -2.5),
        ..JointLimits::FREE
    }];
    let mut left = right_arm(Vec3::new(0.3, 1.2, 0.3));
    left.end_bone = "forearm_l".into();
    app.world_mut()
        .entity_mut(character)
        .insert(InverseKinematics {
            goals: vec![missing, too_long, not_a_number, unordered, left],
            results: Vec::new(),
        });
    for _ in 0..120 {
        app.update();
    }
    let id = format!("character {character}");
    for (goal, why) in [
        (
            "IK goal 0 on joint \"tail_of_the_gltf_humanoid\"",
            "no joint",
        ),
        (
            "IK goal 1 on joint \"forearm_r\"",
            "fewer than 11 ancestors",
        ),
        ("IK goal 2 on joint \"forearm_r\"", "target is not finite"),
        (
            "IK goal 3 on joint \"forearm_r\"",
            "limits that are not finite",
        ),
    ] {
        assert_eq!(
            warnings_with(&[&id, goal, why]),
            1,
            "{goal}: {why}; {:?}",
            WARNINGS.lock().unwrap()
        );
    }
    let world = app.world_mut();
    let ik = world.get::<InverseKinematics>(character).unwrap();
    assert_eq!(&ik.results[..4], &[None, None, None, None]);
    assert!(ik.results[4].is_some_and(|r| r.reached), "{:?}", ik.results);
    let bad = world
        .query::<(&Name, &Transform, &GlobalTransform)>()
        .iter(world)
        .filter(|(_, t, g)| {
            !(t.translation.is_finite() && t.rotation.is_finite() && g.affine().is_finite())
        })
        .map(|(n, _, _)| n.to_string())
        .collect::<Vec<_>>();
    assert!(bad.is_empty(), "transforms not finite: {bad:?}");
}

#[test]
fn joints_nothing_animates_return_to_their_pose_when_the_weight_goes_back_to_zero() {
    let mut app = common::app();
    // A root, a shoulder 1 m up turned a little, an elbow 0.3 m along the arm, bent.
    let (shoulder_rest, elbow_rest) = (Quat::from_rotation_z(0.3), Quat::from_rotation_x(-0.4));
    let root = app
        .world_mut()
        .spawn(Transform::from_xyz(2.0, 0.0, 0.0))
        .id();
    let shoulder = app
        .world_mut()
        .spawn((
            Name::new("shoulder"),
            Transform::from_xyz(0.0, 1.0, 0.0).with_rotation(shoulder_rest),
            ChildOf(root),
        ))
        .id();
    let elbow = app
        .world_mut()
        .spawn((
            Name::new("elbow"),
            Transform::from_xyz(0.0, -0.3, 0.0).with_rotation(elbow_rest),
            ChildOf(shoulder),
        ))
        .id();
    let target = Vec3::new(2.2, 1.1, 0.3);
    let mut goal = right_arm(target);
    goal.end_bone = "elbow".into();
    goal.target = IkTarget::Point(target);
    app.world_mut().entity_mut(root).insert(InverseKinematics {
        goals: vec![goal],
        results: Vec::new(),
    });
    for _ in 0..64 {
        app.update();
    }
    let wrist = app
        .world()
        .get::<GlobalTransform>(elbow)
        .unwrap()
        .transform_point(WRIST);
    assert!(wrist.distance(target) < 0.002, "{wrist}");
    app.world_mut()
        .get_mut::<InverseKinematics>(root)
        .unwrap()
        .goals[0]
        .weight = 0.0;
    for _ in 0..4 {
        app.update();
    }
    let rotation = |e| app.world().get::<Transform>(e).unwrap().rotation;
    assert!(rotation(shoulder).angle_between(shoulder_rest) < 1e-5);
    assert!(rotation(elbow).angle_between(elbow_rest) < 1e-5);
}
