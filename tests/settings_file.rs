//! Cloth settings as RON assets: written and read back field for field, the shipped file read,
//! and in an App a cloth taking its settings from a file, again when the file changes, and
//! keeping them when a file does not parse.

use std::time::Duration;

use bevy::asset::{AssetPlugin, AssetServer};
use bevy::mesh::{Mesh, MeshPlugin};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_drape::cloth::settings_file::{settings_from_ron, settings_to_ron};
use bevy_drape::prelude::*;

fn app(assets: &std::path::Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin {
            file_path: assets.to_string_lossy().into_owned(),
            ..Default::default()
        },
        MeshPlugin,
        DrapePlugins::default(),
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 64.0,
    )));
    app
}

/// Settings far from the defaults in every part.
fn unusual() -> ClothSettings {
    let mut settings = ClothSettings {
        density: 0.37,
        ground: Some(-0.25),
        container: Some((Vec3::new(-1.0, 0.0, -2.0), Vec3::new(1.0, 3.0, 2.0))),
        on_divergence: OnDivergence::Reset,
        inertia: 0.4,
        ..Default::default()
    };
    settings.solver.substeps = 13;
    settings.solver.iterations = 3;
    settings.solver.method = SolverMethod::Hybrid { long_range: true };
    settings.solver.friction = 0.8;
    settings.solver.self_collision = true;
    settings
}

#[test]
fn settings_written_as_ron_read_back_field_for_field_and_the_shipped_file_reads() {
    let registry = AppTypeRegistry::default();
    registry.write().register::<ClothSettings>();
    let registry = registry.read();
    for settings in [ClothSettings::default(), unusual()] {
        let text = settings_to_ron(&settings, &registry).unwrap();
        assert_eq!(
            settings_from_ron(&text, &registry).unwrap(),
            settings,
            "{text}"
        );
    }
    let shipped = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/settings/hanging_cloth.cloth.ron"
    ))
    .unwrap();
    let read = settings_from_ron(&shipped, &registry).unwrap();
    // The file names every field: written again, it reads the same.
    let again = settings_to_ron(&read, &registry).unwrap();
    assert_eq!(settings_from_ron(&again, &registry).unwrap(), read);
    assert!(settings_from_ron("(density: 1.0)", &registry).is_err());
    assert!(settings_from_ron("not ron at all", &registry).is_err());
}

#[test]
fn a_cloth_takes_its_settings_from_a_file_again_when_it_changes_and_keeps_them_when_it_breaks() {
    let dir = std::env::temp_dir().join(format!("bevy_drape_settings_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let registry = AppTypeRegistry::default();
    registry.write().register::<ClothSettings>();
    let text = settings_to_ron(&unusual(), &registry.read()).unwrap();
    std::fs::write(dir.join("garment.cloth.ron"), text).unwrap();
    std::fs::write(dir.join("broken.cloth.ron"), "(density: oops").unwrap();
    let mut app = app(&dir);
    let grid = GridDesc::square(1.0, 8, Vec3::ZERO);
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(grid_mesh(&grid));
    let file = app
        .world()
        .resource::<AssetServer>()
        .load::<ClothSettingsAsset>("garment.cloth.ron");
    let broken = app
        .world()
        .resource::<AssetServer>()
        .load::<ClothSettingsAsset>("broken.cloth.ron");
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh.clone()),
            Cloth::pinned([0, 7]),
            ClothSettingsFile(file.clone()),
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
            ClothSettingsFile(broken),
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
        .resource_mut::<Assets<ClothSettingsAsset>>()
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
