//! The main scene (S3) in a headless App: the poncho on the walking, waving character.

use bevy_drape::cloth::{PonchoDesc, to_obj};
use bevy_drape::poncho::{PonchoScene, run_headless};
use bevy_drape::prelude::*;

#[test]
fn over_ten_seconds_of_walking_the_poncho_stays_on_outside_every_proxy_and_finite() {
    // The scene as the example runs it, from assets/meshes/poncho.obj.
    let run = run_headless(PonchoScene::default(), 600);
    assert_eq!(run.steps, 600);
    assert!(run.particles > 1000, "the poncho was built from its file");
    assert!(run.finite);
    assert!(
        run.max_centroid_offset < 0.3,
        "the poncho's centroid went {} m from the chest",
        run.max_centroid_offset
    );
    let margin = BoneColliders::humanoid().margin;
    assert!(
        run.deepest_penetration <= margin,
        "a particle was {} m inside a proxy",
        run.deepest_penetration
    );
}

#[test]
fn the_poncho_file_is_what_the_generator_writes() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/meshes/poncho.obj");
    let file = std::fs::read_to_string(path).unwrap();
    let body: String = file
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| format!("{l}\n"))
        .collect();
    let mesh = PonchoDesc::default().mesh().unwrap();
    assert!(
        body == to_obj(&mesh, "poncho"),
        "assets/meshes/poncho.obj is stale: run `cargo run --example generate_poncho`"
    );
}
