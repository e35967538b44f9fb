//! The wind acts on every cloth with no per-cloth switch: a cloth without air settings meets
//! the air while a wind or a wind source blows, keeps still with `ClothSettings::wind` off, and
//! steps exactly as before (no air at all) when nothing blows.

use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_drape::prelude::*;

fn headless() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
        DrapePlugins::default(),
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 64.0,
    )));
    app
}

/// A 1 m flag hung by its edge on the Y axis, 2 m up, in the XY plane; its settings.
fn spawn_flag(app: &mut App, settings: ClothSettings) -> Entity {
    let mut grid = GridDesc::square(1.0, 12, Vec3::ZERO);
    grid.orientation = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let pole: Vec<u32> = (0..12).map(|j| grid.index(0, j)).collect();
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(grid_mesh(&grid));
    app.world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::pinned(pole),
            settings,
            Transform::from_xyz(0.0, 2.0, 0.0),
        ))
        .id()
}

fn positions(app: &App, cloth: Entity) -> Vec<Vec3> {
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    simulation
        .solver()
        .state()
        .positions
        .iter()
        .map(|&p| p.into())
        .collect()
}

fn mean_z(positions: &[Vec3]) -> f32 {
    positions.iter().map(|p| p.z).sum::<f32>() / positions.len() as f32
}

fn run(app: &mut App, updates: usize) {
    for _ in 0..updates {
        app.update();
    }
}

#[test]
fn a_cloth_without_air_settings_is_blown_by_the_wind_unless_it_opts_out() {
    let mut app = headless();
    app.insert_resource(Wind {
        velocity: Vec3::new(0.0, 0.0, 8.0),
        gusts: Gusts::default(),
    });
    assert!(ClothSettings::default().solver.air.is_none());
    let blown = spawn_flag(&mut app, ClothSettings::default());
    let sheltered = spawn_flag(
        &mut app,
        ClothSettings {
            wind: false,
            ..default()
        },
    );
    run(&mut app, 129);
    let blown = mean_z(&positions(&app, blown));
    let sheltered = mean_z(&positions(&app, sheltered));
    assert!(blown > 0.2, "the wind blows the flag out along +Z: {blown}");
    assert!(
        sheltered.abs() < 0.01,
        "the sheltered flag hangs in still air: {sheltered}"
    );
}

#[test]
fn a_wind_source_alone_blows_a_cloth_without_air_settings() {
    let mut app = headless();
    let flag = spawn_flag(&mut app, ClothSettings::default());
    // A fan 1 m in front of the flag (-Z side), blowing along +Z towards it.
    app.world_mut().spawn((
        WindSource::fan(10.0, 3.0),
        Transform::from_xyz(0.5, 1.5, -1.0).looking_to(Vec3::Z, Vec3::Y),
    ));
    run(&mut app, 129);
    let z = mean_z(&positions(&app, flag));
    assert!(z > 0.1, "the fan blows the flag along +Z: {z}");
}

#[test]
fn with_no_wind_about_a_cloth_steps_exactly_as_without_air() {
    // No wind resource; a still wind resource; and no wind with the opt-out: the same steps,
    // bit for bit (the air is not stepped at all).
    let mut runs = Vec::new();
    for (still_wind, feels) in [(false, true), (true, true), (true, false)] {
        let mut app = headless();
        if still_wind {
            app.insert_resource(Wind::default());
        }
        let flag = spawn_flag(
            &mut app,
            ClothSettings {
                wind: feels,
                ..default()
            },
        );
        // A swing, so the still air would damp it if it were stepped.
        run(&mut app, 2);
        for v in &mut app
            .world_mut()
            .get_mut::<ClothSimulation>(flag)
            .unwrap()
            .solver_mut()
            .state_mut()
            .velocities
        {
            *v = Vec3::new(0.0, 0.0, 3.0).into();
        }
        run(&mut app, 64);
        runs.push(positions(&app, flag));
    }
    assert_eq!(runs[0], runs[1]);
    assert_eq!(runs[0], runs[2]);
    // And the same cloth with air settings of its own in still air does differ (drag).
    let mut app = headless();
    let flag = spawn_flag(
        &mut app,
        ClothSettings {
            solver: SolverSettings {
                air: Some(AirSettings::default()),
                ..default()
            },
            ..default()
        },
    );
    run(&mut app, 2);
    for v in &mut app
        .world_mut()
        .get_mut::<ClothSimulation>(flag)
        .unwrap()
        .solver_mut()
        .state_mut()
        .velocities
    {
        *v = Vec3::new(0.0, 0.0, 3.0).into();
    }
    run(&mut app, 64);
    assert_ne!(runs[0], positions(&app, flag));
}
