//! One FABRIK solve on hinge chains of 3, 4 and 7 joints, to random reachable targets (made
//! by forward kinematics from random chain angles within the limits), starting from the rest
//! pose.
//! Before timing, each chain's iterations to reach 1 mm are printed.

use bevy::math::Vec3;
use bevy_drape::skeleton::humanoid::humanoid;
use bevy_drape::skeleton::ik::{IkChain, IkScratch, IkSettings, effector_position, solve};
use bevy_drape::skeleton::rig::{BoneDesc, Pose, Rig};
use criterion::{Criterion, criterion_group, criterion_main};

/// A snake of seven hinges alternating between the x and z axes, 0.15 m apart.
fn snake() -> Rig {
    let mut bones = vec![BoneDesc {
        name: "root".into(),
        parent: None,
        offset: [0.0; 3],
        axis: [1.0, 0.0, 0.0],
        limits: None,
    }];
    for i in 0..7 {
        bones.push(BoneDesc {
            name: format!("j{i}"),
            parent: Some(if i == 0 {
                "root".into()
            } else {
                format!("j{}", i - 1)
            }),
            offset: if i == 0 { [0.0; 3] } else { [0.0, 0.15, 0.0] },
            axis: if i % 2 == 0 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 0.0, 1.0]
            },
            limits: Some((-1.2, 1.2)),
        });
    }
    Rig::new(&bones).expect("valid")
}

/// The rest pose with the chain's angles random within their limits.
fn random_pose(rig: &Rig, chain: &IkChain, seed: &mut u64) -> Pose {
    let mut pose = rig.rest_pose();
    for &b in &chain.bones {
        if let Some((lo, hi)) = rig.bones()[b].limits {
            *seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            pose.angles[b] = lo + (hi - lo) * ((*seed >> 40) as f32 / (1u64 << 24) as f32);
        }
    }
    pose
}

fn ik(c: &mut Criterion) {
    let body = humanoid();
    let chains: [(&str, Rig, &str, usize, Vec3); 3] = [
        (
            "3_joints_arm",
            body.clone(),
            "forearm_r",
            3,
            Vec3::new(0.0, -0.25, 0.0),
        ),
        (
            "4_joints_arm_hand",
            body,
            "hand_r",
            4,
            Vec3::new(0.0, -0.08, 0.0),
        ),
        (
            "7_joints_snake",
            snake(),
            "j6",
            7,
            Vec3::new(0.0, 0.15, 0.0),
        ),
    ];
    let mut group = c.benchmark_group("ik_solve");
    for (name, rig, end, length, effector) in chains {
        let chain = IkChain::new(&rig, end, length, effector).expect("valid chain");
        let mut seed = 1u64;
        let targets: Vec<Vec3> = (0..256)
            .map(|_| effector_position(&rig, &chain, &random_pose(&rig, &chain, &mut seed)))
            .collect();
        let settings = IkSettings::default();
        let mut scratch = IkScratch::default();
        let mut iterations: Vec<u32> = targets
            .iter()
            .map(|&t| {
                let mut pose = rig.rest_pose();
                let r = solve(&rig, &chain, &mut pose, t, &settings, &mut scratch);
                if r.reached { r.iterations } else { u32::MAX }
            })
            .collect();
        iterations.sort_unstable();
        let reached = iterations.iter().filter(|&&i| i != u32::MAX).count();
        println!(
            "{name}: {reached}/256 within 1 mm; iterations median {}, 90th percentile {}",
            iterations[128], iterations[230]
        );
        let mut k = 0;
        group.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) % targets.len();
                let mut pose = rig.rest_pose();
                solve(&rig, &chain, &mut pose, targets[k], &settings, &mut scratch)
            })
        });
    }
    group.finish();
}

mod group {
    #![allow(missing_docs)]
    use super::*;
    criterion_group!(benches, ik);
}

criterion_main!(group::benches);
