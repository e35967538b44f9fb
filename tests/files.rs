//! Settings as RON files: cloth settings and a character's colliders written and read back
//! field for field, the shipped file read, and in an App a cloth taking its settings from a
//! file, again when the file changes, keeping them when a file does not parse, and a
//! character's proxies spawned again when its colliders file changes.

use crate::common;

use std::time::Duration;

use bevy::asset::AssetServer;
use bevy::prelude::*;
use bevy_drape::cloth::SolverMethod;
use bevy_drape::cloth::plugin::{ClothSettingsFile, OnDivergence};
use bevy_drape::files::FileAsset;
use bevy_drape::files::{from_ron, to_ron};
use bevy_drape::prelude::*;
use bevy_drape::skeleton::plugin::{BoneCollidersFile, BoneProxyOf};
use common::{Headless, add_grid};

fn app(assets: &std::path::Path) -> App {
    Headless::new()
        .asset_root(assets.to_string_lossy().into_owned())
        .build()
}

/// Settings far from the defaults in every part.
fn unusual() -> ClothSettings {
    let mut settings = ClothSettings {
        density: 0.37,
        wind: false,
        on_divergence: OnDivergence::Reset,
        inertia: 0.4,
        ..Default::default()
    };
    settings.solver.substeps = 13;
    settings.solver.iterations = 3;
    settings.solver.method = SolverMethod::Hybrid { long_range: true };
    settings.solver.friction = 0.8;
    settings.solver.self_collision = SelfCollisionMethod::Triangles;
    settings.solver.exact_edges = Some(bevy_drape::cloth::ExactEdges {
        newton_steps: 2,
        cg_iterations: 30,
        closing_rounds: 2,
        closing_tolerance: 0.002,
    });
    settings
}

#[test]
fn settings_and_colliders_written_as_ron_read_back_field_for_field_and_the_shipped_file_reads() {
    let registry = AppTypeRegistry::default();
    registry.write().register::<ClothSettings>();
    registry.write().register::<BoneColliders>();
    let registry = registry.read();
    let mut colliders = BoneColliders::humanoid();
    colliders.proxies[3].radius = 0.123;
    colliders.margin = 0.02;
    let text = to_ron(&colliders, &registry).unwrap();
    assert_eq!(
        from_ron::<BoneColliders>(&text, &registry).unwrap(),
        colliders
    );
    for settings in [ClothSettings::default(), unusual()] {
        let text = to_ron(&settings, &registry).unwrap();
        assert_eq!(
            from_ron::<ClothSettings>(&text, &registry).unwrap(),
            settings,
            "{text}"
        );
    }
    let shipped = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/settings/hanging_cloth.cloth.ron"
    ))
    .unwrap();
    let read = from_ron::<ClothSettings>(&shipped, &registry).unwrap();
    // The file names every field: written again, it reads the same.
    let again = to_ron(&read, &registry).unwrap();
    assert_eq!(from_ron::<ClothSettings>(&again, &registry).unwrap(), read);
    assert!(from_ron::<ClothSettings>("(density: 1.0)", &registry).is_err());
    assert!(from_ron::<ClothSettings>("not ron at all", &registry).is_err());
}

#[test]
fn a_cloth_takes_its_settings_from_a_file_again_when_it_changes_and_keeps_them_when_it_breaks() {
    let dir = std::env::temp_dir().join(format!("bevy_drape_settings_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let registry = AppTypeRegistry::default();
    registry.write().register::<ClothSettings>();
    let text = to_ron(&unusual(), &registry.read()).unwrap();
    std::fs::write(dir.join("garment.cloth.ron"), text).unwrap();
    std::fs::write(dir.join("broken.cloth.ron"), "(density: oops").unwrap();
    let mut app = app(&dir);
    let grid = GridDesc::square(1.0, 8, Vec3::ZERO);
    let mesh = add_grid(&mut app, &grid);
    let file = app
        .world()
        .resource::<AssetServer>()
        .load::<FileAsset<ClothSettings>>("garment.cloth.ron");
    let broken = app
        .world()
        .resource::<AssetServer>()
        .load::<FileAsset<ClothSettings>>("broken.cloth.ron");
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh.clone()),
            Cloth::pinned([0, 7]),
            ClothSettingsFile::new(file.clone()),
            Transform::from_xyz(0.0, 1.0, 0.0),
        ))
        .id();
    let kept = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::pinned([0, 7]),
            ClothSettings {
                density: 0.2,
                ..Default::default()
            },
            ClothSettingsFile::new(broken),
            Transform::from_xyz(2.0, 1.0, 0.0),
        ))
        .id();
    let settings = |app: &App, e| app.world().get::<ClothSettings>(e).copied();
    for _ in 0..200 {
        app.update();
        if settings(&app, cloth) == Some(unusual()) {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(settings(&app, cloth), Some(unusual()));
    for _ in 0..5 {
        app.update();
    }
    // The cloth steps with them.
    let substeps = app
        .world()
        .get::<ClothSimulation>(cloth)
        .unwrap()
        .solver()
        .last_substeps();
    assert_eq!(substeps, 13);
    // The file changes (what the file watcher's reload does to the asset): so do the settings.
    app.world_mut()
        .resource_mut::<Assets<FileAsset<ClothSettings>>>()
        .get_mut(&file)
        .unwrap()
        .0
        .solver
        .substeps = 5;
    app.update();
    app.update();
    assert_eq!(settings(&app, cloth).unwrap().solver.substeps, 5);
    // The broken file: a warning, and the cloth keeps its own settings and runs on.
    assert_eq!(settings(&app, kept).unwrap().density, 0.2);
    assert!(app.world().get::<ClothSimulation>(kept).is_some());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_characters_proxies_are_spawned_again_when_its_colliders_file_changes() {
    let dir = std::env::temp_dir().join(format!("bevy_drape_colliders_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let registry = AppTypeRegistry::default();
    registry.write().register::<BoneColliders>();
    let mut colliders = BoneColliders::humanoid();
    colliders.proxies.truncate(5);
    colliders.proxies[0].radius = 0.2;
    let text = to_ron(&colliders, &registry.read()).unwrap();
    std::fs::write(dir.join("character.colliders.ron"), text).unwrap();
    let mut app = app(&dir);
    let file = app
        .world()
        .resource::<AssetServer>()
        .load::<FileAsset<BoneColliders>>("character.colliders.ron");
    let character = app
        .world_mut()
        .spawn((
            Skeleton {
                rig: std::sync::Arc::new(humanoid()),
            },
            BoneCollidersFile::new(file.clone()),
            Transform::default(),
        ))
        .id();
    let radii = |app: &mut App| {
        let world = app.world_mut();
        let mut r: Vec<f32> = world
            .query::<(&ClothCollider, &BoneProxyOf)>()
            .iter(world)
            .filter(|(_, of)| of.0 == character)
            .map(|(c, _)| match c.shape {
                ColliderShape::Capsule { radius, .. } => radius,
                _ => panic!("proxies are capsules"),
            })
            .collect();
        r.sort_by(f32::total_cmp);
        r
    };
    for _ in 0..200 {
        app.update();
        if !radii(&mut app).is_empty() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    app.update();
    let mut expected: Vec<f32> = colliders.proxies.iter().map(|p| p.radius).collect();
    expected.sort_by(f32::total_cmp);
    assert_eq!(radii(&mut app), expected);
    // The file changes: the old proxies go, the new ones come, as many as it lists.
    {
        let mut files = app
            .world_mut()
            .resource_mut::<Assets<FileAsset<BoneColliders>>>();
        let asset = &mut files.get_mut(&file).unwrap().0;
        asset.proxies.truncate(3);
        asset.proxies[1].radius = 0.31;
    }
    for _ in 0..3 {
        app.update();
    }
    let mut expected: Vec<f32> = colliders.proxies[..3].iter().map(|p| p.radius).collect();
    expected[1] = 0.31;
    expected.sort_by(f32::total_cmp);
    assert_eq!(radii(&mut app), expected);
    std::fs::remove_dir_all(&dir).ok();
}
