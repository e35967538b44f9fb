//! One IK solve (a FABRIK pass, then damped least squares) on hinge chains of 3, 4 and 7
//! joints ([`drape_scenes::study::ik_chains`]), to random reachable targets (made by forward kinematics from random chain angles within
//! the limits), starting from the rest pose.
//! Before timing, each chain's iterations to reach 1 mm are printed.

use bevy::math::Vec3;
use bevy_drape::skeleton::ik::{IkChain, IkScratch, IkSettings, effector_position, solve};
use criterion::{Criterion, criterion_group, criterion_main};
use drape_scenes::study::{ik_chains, random_pose};

fn ik(c: &mut Criterion) {
    let chains = ik_chains();
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
