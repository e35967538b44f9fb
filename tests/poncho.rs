//! The main scene (S3) in a headless App: the poncho on the waving character, walking in
//! place, walking through the world, jogging and teleported, 10 s each.

use bevy_drape::cloth::{PonchoDesc, to_obj};
use bevy_drape::poncho::{CharacterMotion, PonchoScene, run_headless};
use bevy_drape::prelude::*;

#[test]
fn the_poncho_stays_on_the_character_in_every_motion() {
    let margin = BoneColliders::humanoid().margin;
    for (motion, least_travel) in [
        (CharacterMotion::InPlace, 0.0),
        (CharacterMotion::Walk, 3.0),
        (CharacterMotion::Jog, 6.0),
        (CharacterMotion::Teleport, 9.9),
    ] {
        let run = run_headless(
            PonchoScene {
                motion,
                ..PonchoScene::default()
            },
            600,
        );
        assert_eq!(run.steps, 600);
        assert!(run.particles > 1000, "the poncho was built from its file");
        if let Err(why) = run.check(margin) {
            panic!("{why}");
        }
        assert!(
            run.travelled >= least_travel,
            "{}: the character went only {} m",
            motion.name(),
            run.travelled
        );
    }
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
