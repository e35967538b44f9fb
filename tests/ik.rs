//! FABRIK on hinge chains: reachable targets are reached, bones turn about their hinges only
//! and within their limits, unreachable targets are approached as well as the hinges allow.

use crate::common;

use bevy::math::{Quat, Vec3};
use bevy_drape::skeleton::ik::{IkChain, IkScratch, IkSettings, effector_position, solve};
use bevy_drape::skeleton::rig::{BoneDesc, Pose, Rig};
use common::Rng;

fn bone(
    name: &str,
    parent: Option<&str>,
    offset: [f32; 3],
    axis: [f32; 3],
    limits: Option<(f32, f32)>,
) -> BoneDesc {
    BoneDesc {
        name: name.into(),
        parent: parent.map(Into::into),
        offset,
        axis,
        limits,
    }
}

/// A shoulder of two hinges at one point (yaw about y, pitch about x) and an elbow about x:
/// three hinges with non-parallel axes; the effector is 0.25 m down the forearm.
fn arm() -> (Rig, IkChain) {
    let rig = Rig::new(&[
        bone("root", None, [0.0; 3], [1.0, 0.0, 0.0], None),
        bone(
            "yaw",
            Some("root"),
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            Some((-2.5, 2.5)),
        ),
        bone(
            "pitch",
            Some("yaw"),
            [0.0; 3],
            [1.0, 0.0, 0.0],
            Some((-1.5, 1.5)),
        ),
        bone(
            "elbow",
            Some("pitch"),
            [0.0, 0.0, 0.3],
            [1.0, 0.0, 0.0],
            Some((-2.5, 0.0)),
        ),
    ])
    .unwrap();
    let chain = IkChain::new(&rig, "elbow", 3, Vec3::new(0.0, 0.0, 0.25)).unwrap();
    (rig, chain)
}

/// The rest pose of `rig` with every limited angle uniform within its limits.
fn random_pose(random: &mut Rng, rig: &Rig) -> Pose {
    let mut pose = rig.rest_pose();
    for (b, bone) in rig.bones().iter().enumerate() {
        if let Some((lo, hi)) = bone.limits {
            pose.angles[b] = random.range(lo, hi);
        }
    }
    pose
}

#[test]
fn a_three_hinge_chain_reaches_random_reachable_targets_within_a_millimetre() {
    let (rig, chain) = arm();
    let mut random = Rng(7);
    let mut scratch = IkScratch::default();
    let settings = IkSettings::default();
    let mut histogram = [0u32; 6]; // iterations: 1-5, 6-10, 11-20, 21-30, 31-50, failed
    let mut reached = 0;
    let trials = 1000;
    for _ in 0..trials {
        let target = effector_position(&rig, &chain, &random_pose(&mut random, &rig));
        let mut pose = rig.rest_pose();
        let result = solve(&rig, &chain, &mut pose, target, &settings, &mut scratch);
        // The returned pose really puts the effector there.
        let error = effector_position(&rig, &chain, &pose).distance(target);
        assert!((error - result.error).abs() < 1e-5);
        let bin = if !result.reached {
            5
        } else {
            match result.iterations {
                0..=5 => 0,
                6..=10 => 1,
                11..=20 => 2,
                21..=30 => 3,
                _ => 4,
            }
        };
        histogram[bin] += 1;
        if result.reached && result.iterations <= 50 {
            reached += 1;
        }
    }
    println!(
        "{trials} targets: reached in 1-5 iterations {}, 6-10 {}, 11-20 {}, 21-30 {}, 31-50 {}, not reached {}",
        histogram[0], histogram[1], histogram[2], histogram[3], histogram[4], histogram[5]
    );
    assert!(
        reached as f32 >= 0.99 * trials as f32,
        "{reached} of {trials}"
    );
}

#[test]
fn solved_bones_turn_about_their_hinges_only_and_within_their_limits() {
    let (rig, chain) = arm();
    let mut random = Rng(11);
    let mut scratch = IkScratch::default();
    let mut states = Vec::new();
    for _ in 0..200 {
        // Reachable and unreachable targets alike.
        let target = Vec3::new(
            random.uniform() - 0.5,
            0.5 + random.uniform(),
            random.uniform() - 0.5,
        ) * 1.6;
        let mut pose = random_pose(&mut random, &rig);
        solve(
            &rig,
            &chain,
            &mut pose,
            target,
            &IkSettings::default(),
            &mut scratch,
        );
        rig.forward(&pose, None, &mut states);
        for &b in &chain.bones {
            let bone = &rig.bones()[b];
            let parent = states[bone.parent.unwrap()].rotation;
            let relative = parent.inverse() * states[b].rotation;
            let (axis, angle) = relative.to_axis_angle();
            // The relative rotation is about the hinge axis (or none at all).
            let off_axis = if angle.abs() < 1e-6 {
                0.0
            } else {
                axis.cross(bone.axis).length() * angle.abs()
            };
            assert!(
                off_axis < 1e-4,
                "bone {}: rotation about {axis} by {angle}",
                bone.name
            );
            let (lo, hi) = bone.limits.unwrap();
            assert!(pose.angles[b] >= lo && pose.angles[b] <= hi);
            let expected = Quat::from_axis_angle(bone.axis, pose.angles[b]);
            assert!(relative.dot(expected).abs() > 1.0 - 1e-6);
        }
    }
}

#[test]
fn an_unreachable_target_is_approached_as_well_as_the_best_of_many_random_poses() {
    let (rig, chain) = arm();
    let mut random = Rng(3);
    let mut scratch = IkScratch::default();
    for target in [
        Vec3::new(0.0, 1.0, 2.0),
        Vec3::new(0.0, 3.0, 0.0),
        Vec3::new(-0.05, 1.0, -1.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.3, 0.2, -0.4),
    ] {
        let mut pose = rig.rest_pose();
        let result = solve(
            &rig,
            &chain,
            &mut pose,
            target,
            &IkSettings::default(),
            &mut scratch,
        );
        assert!(pose.angles.iter().all(|a| a.is_finite()) && result.error.is_finite());
        let best_random = (0..10_000)
            .map(|_| {
                effector_position(&rig, &chain, &random_pose(&mut random, &rig)).distance(target)
            })
            .fold(f32::MAX, f32::min);
        println!(
            "target {target}: IK {:.4} m in {} iterations ({} restarts), best of 10,000 random poses {best_random:.4} m",
            result.error, result.iterations, result.restarts
        );
        assert!(result.error <= best_random + 1e-4);
    }
}

/// A random hinge chain: 3 to 7 hinges below a root, each with a random unit axis, a random
/// offset from its parent (0 to 0.3 m; a third of them at the joint before, two hinges at
/// one point as in a shoulder), limits tight (0.3 to 1 rad wide) or loose (up to 5.5 rad) or
/// none, and an effector 0.05 to 0.3 m along a random direction of the last bone.
fn random_chain(random: &mut Rng) -> (Rig, IkChain) {
    let hinges = 3 + (random.uniform() * 5.0) as usize;
    let mut descs = vec![bone("root", None, [0.0; 3], [1.0, 0.0, 0.0], None)];
    let unit = |random: &mut Rng| random.unit_vector();
    for k in 0..hinges {
        let name = format!("h{k}");
        let parent = if k == 0 {
            "root".to_string()
        } else {
            format!("h{}", k - 1)
        };
        let offset = if k > 0 && random.uniform() < 0.33 {
            Vec3::ZERO
        } else {
            unit(random) * (0.05 + 0.25 * random.uniform())
        };
        let kind = random.uniform();
        let limits = if kind < 0.4 {
            let width = 0.3 + 0.7 * random.uniform();
            let centre = (random.uniform() - 0.5) * 2.0;
            Some((centre - width / 2.0, centre + width / 2.0))
        } else if kind < 0.9 {
            let width = 1.0 + 4.5 * random.uniform();
            let lo = -width * random.uniform();
            Some((lo, lo + width))
        } else {
            None
        };
        descs.push(bone(
            &name,
            Some(&parent),
            offset.to_array(),
            unit(random).to_array(),
            limits,
        ));
    }
    let rig = Rig::new(&descs).unwrap();
    let effector = unit(random) * (0.05 + 0.25 * random.uniform());
    let chain = IkChain::new(&rig, &format!("h{}", hinges - 1), hinges, effector).unwrap();
    (rig, chain)
}

#[test]
fn random_chains_reach_random_reachable_targets_from_the_rest_pose() {
    // 40 random chains x 250 targets: angles drawn within the limits, the target their
    // forward kinematics, every solve from the rest pose with the default settings.
    let mut random = Rng(0x5EED);
    let mut scratch = IkScratch::default();
    let mut solving = std::time::Duration::ZERO;
    let mut iterations_used = 0u64;
    let (mut reached, mut total) = (0usize, 0usize);
    let mut errors = Vec::new();
    for _ in 0..40 {
        let (rig, chain) = random_chain(&mut random);
        for _ in 0..250 {
            let goal = effector_position(&rig, &chain, &random_pose(&mut random, &rig));
            let mut pose = rig.rest_pose();
            let settings = IkSettings::default();
            let started = std::time::Instant::now();
            let result = solve(&rig, &chain, &mut pose, goal, &settings, &mut scratch);
            solving += started.elapsed();
            iterations_used += result.iterations as u64;
            // The angles stay within their limits.
            for &b in &chain.bones {
                if let Some((lo, hi)) = rig.bones()[b].limits {
                    assert!(pose.angles[b] >= lo - 1e-6 && pose.angles[b] <= hi + 1e-6);
                }
            }
            let error = effector_position(&rig, &chain, &pose).distance(goal);
            assert!((error - result.error).abs() < 1e-4);
            total += 1;
            reached += result.reached as usize;
            errors.push(error);
        }
    }
    errors.sort_by(|a, b| a.total_cmp(b));
    let share = reached as f64 / total as f64;
    println!(
        "{reached} of {total} reached ({:.2}%) in {:.1} us per solve, {:.1} iterations, 99th percentile error {:.2e} m, worst {:.2e} m",
        100.0 * share,
        solving.as_secs_f64() * 1e6 / total as f64,
        iterations_used as f64 / total as f64,
        errors[total * 99 / 100],
        errors[total - 1]
    );
    assert!(share >= 0.999, "{reached} of {total}");
}
