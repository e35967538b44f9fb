//! A cloth entity in a headless App (`MinimalPlugins`, manual time, no window): it falls and
//! writes its mesh, moves with its entity and its attachments, refuses bad meshes, follows
//! its settings, steps in the schedule chosen, and is reflected for an inspector.

use crate::common;

use bevy::mesh::{Indices, Mesh, PrimitiveTopology};
use bevy::prelude::*;
use bevy_drape::cloth::plugin::ClothBuildError;
use bevy_drape::error::ClothError;
use bevy_drape::prelude::*;
use common::{add_grid, app, app_with, positions, spawn_cloth};

#[test]
fn a_cloth_entity_falls_writes_its_mesh_and_keeps_its_pins() {
    let mut app = app();
    let grid = GridDesc::square(1.0, 12, Vec3::ZERO);
    let mesh = add_grid(&mut app, &grid);
    let pins = [grid.index(0, 0), grid.index(11, 0)];
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh.clone()),
            Cloth::pinned(pins),
            Transform::from_xyz(0.0, 1.0, 0.0),
        ))
        .id();
    let before = grid.mesh().positions;
    // The first update has a zero delta: 121 updates give 120 fixed steps at 64 Hz.
    for _ in 0..121 {
        app.update();
    }
    assert!(app.world().get::<ClothSimulation>(cloth).is_some());
    // The cloth got a mesh of its own; the shared one is untouched.
    assert_ne!(app.world().get::<Mesh3d>(cloth).unwrap().0, mesh);
    let after = positions(&app, cloth);
    assert!(after.iter().all(|p| p.is_finite()));
    let moved = after
        .iter()
        .zip(&before)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f32::max);
    assert!(moved > 0.3, "the cloth fell: largest move {moved}");
    for pin in pins {
        let d = after[pin as usize].distance(before[pin as usize]);
        assert!(d < 1e-5, "pinned vertex {pin} moved {d}");
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    assert!(sim.strain().max < 0.05);
}

#[test]
fn moving_the_cloth_entity_moves_its_pins_and_an_attachment_follows_its_target() {
    let mut app = app();
    let grid = GridDesc::square(1.0, 6, Vec3::ZERO);
    let mesh = add_grid(&mut app, &grid);
    let bar = app
        .world_mut()
        .spawn(Transform::from_xyz(1.0, 2.0, 0.0))
        .id();
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::pinned([0]).with_attachment(VertexAttachment {
                vertex: grid.index(5, 0),
                target: bar,
                offset: Vec3::ZERO,
            }),
            Transform::from_xyz(0.0, 2.0, 0.0),
        ))
        .id();
    for _ in 0..11 {
        app.update();
    }
    app.world_mut()
        .get_mut::<Transform>(cloth)
        .unwrap()
        .translation
        .x += 0.25;
    app.world_mut()
        .get_mut::<Transform>(bar)
        .unwrap()
        .translation
        .z += 0.5;
    for _ in 0..30 {
        app.update();
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    let x = &sim.state().positions;
    assert!(Vec3::from(x[0]).distance(Vec3::new(0.25, 2.0, 0.0)) < 1e-5);
    let attached = Vec3::from(x[grid.index(5, 0) as usize]);
    assert!(
        attached.distance(Vec3::new(1.0, 2.0, 0.5)) < 1e-5,
        "{attached}"
    );
}

#[test]
fn bad_meshes_are_refused_with_an_error_component_and_the_app_keeps_running() {
    let mut app = app();
    let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
    let no_triangles = meshes.add(
        Mesh::new(PrimitiveTopology::TriangleList, default())
            .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32; 3]; 3])
            .with_inserted_indices(Indices::U32(vec![])),
    );
    let nan = meshes.add(
        Mesh::new(PrimitiveTopology::TriangleList, default())
            .with_inserted_attribute(
                Mesh::ATTRIBUTE_POSITION,
                vec![[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 0.0, 1.0]],
            )
            .with_inserted_indices(Indices::U32(vec![0, 2, 1])),
    );
    let out_of_range = meshes.add(
        Mesh::new(PrimitiveTopology::TriangleList, default())
            .with_inserted_attribute(
                Mesh::ATTRIBUTE_POSITION,
                vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            )
            .with_inserted_indices(Indices::U32(vec![0, 2, 5])),
    );
    let good = meshes.add(grid_mesh(&GridDesc::square(1.0, 4, Vec3::ZERO)));
    let other = meshes.add(grid_mesh(&GridDesc::square(1.0, 4, Vec3::ZERO)));
    let fine = meshes.add(grid_mesh(&GridDesc::square(1.0, 9, Vec3::ZERO)));
    let bad_settings = ClothSettings {
        density: -1.0,
        ..default()
    };
    let world = app.world_mut();
    let a = world.spawn((Mesh3d(no_triangles), Cloth::default())).id();
    let b = world.spawn((Mesh3d(nan.clone()), Cloth::default())).id();
    let c = world.spawn((Mesh3d(out_of_range), Cloth::default())).id();
    let d = world
        .spawn((Mesh3d(good.clone()), Cloth::default(), bad_settings))
        .id();
    let e = world
        .spawn((Mesh3d(good.clone()), Cloth::pinned([99])))
        .id();
    // Simulated on another mesh: that mesh is checked, and pins name its vertices (16 here,
    // though 81 are drawn).
    let f = world
        .spawn((
            Mesh3d(fine.clone()),
            ClothSimulationMesh(nan),
            Cloth::default(),
        ))
        .id();
    let g = world
        .spawn((
            Mesh3d(fine.clone()),
            ClothSimulationMesh(good.clone()),
            Cloth::pinned([40]),
        ))
        .id();
    let ok = world.spawn((Mesh3d(other), Cloth::default())).id();
    let ok_drawn_finer = world
        .spawn((Mesh3d(fine), ClothSimulationMesh(good), Cloth::default()))
        .id();
    for _ in 0..20 {
        app.update();
    }
    let error = |entity| {
        app.world()
            .get::<ClothBuildError>(entity)
            .map(|e| e.0.clone())
    };
    assert_eq!(error(a), Some(ClothError::NoTriangles));
    assert_eq!(error(b), Some(ClothError::NonFinitePosition { vertex: 1 }));
    assert_eq!(
        error(c),
        Some(ClothError::IndexOutOfRange {
            index: 5,
            vertex_count: 3
        })
    );
    assert_eq!(error(d), Some(ClothError::InvalidDensity(-1.0)));
    assert!(matches!(
        error(e),
        Some(ClothError::VertexOutOfRange { vertex: 99, .. })
    ));
    assert_eq!(error(f), Some(ClothError::NonFinitePosition { vertex: 1 }));
    assert_eq!(
        error(g),
        Some(ClothError::VertexOutOfRange {
            vertex: 40,
            vertex_count: 16
        })
    );
    // The good cloths next to them simulate.
    let sim = app.world().get::<ClothSimulation>(ok).unwrap().solver();
    assert!(sim.is_finite());
    assert!(sim.state().positions[0].y < -0.1);
    let drawn = positions(&app, ok_drawn_finer);
    assert_eq!(drawn.len(), 81);
    assert!(drawn.iter().all(|p| p.is_finite() && p.y < -0.1));
}

#[test]
fn changing_density_changes_the_mass_and_pausing_stops_the_cloth() {
    let mut app = app();
    let mesh = add_grid(&mut app, &GridDesc::square(2.0, 5, Vec3::ZERO));
    let cloth = app
        .world_mut()
        .spawn((Mesh3d(mesh), Cloth::default(), ClothSettings::default()))
        .id();
    for _ in 0..3 {
        app.update();
    }
    let mass = |app: &App| {
        app.world()
            .get::<ClothSimulation>(cloth)
            .unwrap()
            .solver()
            .model()
            .total_mass()
    };
    assert!((mass(&app) - 0.1 * 4.0).abs() < 1e-5);
    app.world_mut()
        .get_mut::<ClothSettings>(cloth)
        .unwrap()
        .density = 0.3;
    app.update();
    app.update();
    assert!((mass(&app) - 0.3 * 4.0).abs() < 1e-5);

    app.world_mut().resource_mut::<DrapeSettings>().paused = true;
    app.update();
    let frozen = app
        .world()
        .get::<ClothSimulation>(cloth)
        .unwrap()
        .solver()
        .state()
        .clone();
    for _ in 0..5 {
        app.update();
    }
    let now = app
        .world()
        .get::<ClothSimulation>(cloth)
        .unwrap()
        .solver()
        .state();
    assert_eq!(now, &frozen);
}

#[test]
fn the_simulation_schedule_can_be_chosen() {
    let mut app = app_with(DrapePlugins::new(FixedUpdate));
    let mesh = add_grid(&mut app, &GridDesc::square(1.0, 4, Vec3::ZERO));
    let cloth = app.world_mut().spawn((Mesh3d(mesh), Cloth::default())).id();
    for _ in 0..11 {
        app.update();
    }
    // 10 fixed steps of free fall from rest: y = -g t^2 / 2 at t = 10/64 s.
    let t = 10.0 / 64.0;
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    let y = sim.rigid_motion().unwrap().center_of_mass.y;
    assert!((y + 0.5 * 9.81 * t * t).abs() < 1e-4, "y = {y}");
}

#[test]
fn settings_and_components_are_reflected_so_an_inspector_can_edit_them() {
    use bevy::ecs::reflect::{ReflectComponent, ReflectResource};
    use bevy::reflect::GetPath;
    let mut app = app();
    let grid = GridDesc::square(1.0, 4, Vec3::ZERO);
    let cloth = spawn_cloth(&mut app, &grid, Cloth::default(), Transform::default());
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothSettings::default());
    app.update();
    let registry = app.world().resource::<AppTypeRegistry>().clone();
    let registry = registry.read();
    // Every component and resource a game edits is registered with its reflected data.
    for (name, component) in [
        ("Cloth", true),
        ("ClothSettings", true),
        ("ClothCollider", true),
        ("KinematicVelocity", true),
        ("ClipPlayer", true),
        ("InverseKinematics", true),
        ("BoneColliders", true),
        ("DrapeSettings", false),
        ("DefaultClothSettings", false),
        ("DrapeTimings", false),
        ("ClothPaint", true),
    ] {
        let registration = registry
            .get_with_short_type_path(name)
            .unwrap_or_else(|| panic!("{name} is not registered"));
        if component {
            assert!(registration.data::<ReflectComponent>().is_some(), "{name}");
        } else {
            assert!(registration.data::<ReflectResource>().is_some(), "{name}");
        }
    }
    // An edit through reflection, as an inspector makes it, reaches the component.
    let reflect = registry
        .get_with_short_type_path("ClothSettings")
        .unwrap()
        .data::<ReflectComponent>()
        .unwrap()
        .clone();
    drop(registry);
    let mut entity = app.world_mut().entity_mut(cloth);
    let mut settings = reflect.reflect_mut(&mut entity).unwrap();
    *settings
        .reflect_path_mut("solver.substeps")
        .unwrap()
        .try_downcast_mut::<u32>()
        .unwrap() = 13;
    assert_eq!(
        app.world()
            .get::<ClothSettings>(cloth)
            .unwrap()
            .solver
            .substeps,
        13
    );
}
