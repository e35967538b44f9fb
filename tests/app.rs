//! The plugin in a headless App: `MinimalPlugins`, manual time, no window.

use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::ecs::message::MessageCursor;
use bevy::mesh::{Indices, Mesh, MeshPlugin, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_drape::prelude::*;

fn app() -> App {
    app_with(DrapePlugins::default())
}

/// A headless App with `drape`, stepping 1/64 s per update.
fn app_with(drape: DrapePlugins) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
        drape,
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 64.0,
    )));
    app
}

fn add_grid(app: &mut App, grid: &GridDesc) -> Handle<Mesh> {
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(grid_mesh(grid))
}

/// Spawns the grid as a cloth entity.
fn spawn_cloth(app: &mut App, grid: &GridDesc, cloth: Cloth, transform: Transform) -> Entity {
    let mesh = add_grid(app, grid);
    app.world_mut().spawn((Mesh3d(mesh), cloth, transform)).id()
}

fn positions(app: &App, entity: Entity) -> Vec<Vec3> {
    attribute(app, entity, Mesh::ATTRIBUTE_POSITION)
}

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

fn spawn_mass_spring_cloth(app: &mut App, settings: ClothSettings) -> (Entity, GridDesc) {
    let grid = GridDesc::square(1.0, 8, Vec3::ZERO);
    let mesh = add_grid(app, &grid);
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::pinned([grid.index(0, 0), grid.index(7, 0)]),
            settings,
            Transform::from_xyz(0.0, 1.0, 0.0),
        ))
        .id();
    (cloth, grid)
}

/// Reads the [`ClothDiverged`] messages sent since the cursor last read.
fn read_diverged(app: &App, cursor: &mut MessageCursor<ClothDiverged>) -> Vec<ClothDiverged> {
    let messages = app.world().resource::<Messages<ClothDiverged>>();
    cursor.read(messages).copied().collect()
}

/// Stiff springs at one substep per fixed step: far past the explicit stability bound.
fn unstable_settings(on_divergence: OnDivergence) -> ClothSettings {
    let mut settings = ClothSettings {
        on_divergence,
        ..Default::default()
    };
    settings.solver.method = SolverMethod::MassSpring;
    settings.solver.substeps = 1;
    settings.solver.springs.structural.stiffness = 1e5;
    settings
}

#[test]
fn a_diverging_cloth_is_reported_frozen_and_stepped_again_when_its_settings_change() {
    let mut app = app();
    let (cloth, _) = spawn_mass_spring_cloth(&mut app, unstable_settings(OnDivergence::Freeze));
    let mut cursor = MessageCursor::default();
    let mut seen = Vec::new();
    for _ in 0..6 {
        app.update();
        seen.extend(read_diverged(&app, &mut cursor));
    }
    assert_eq!(seen.len(), 1, "reported once, then frozen: {seen:?}");
    let first = seen[0];
    assert_eq!(first.cloth, cloth);
    assert_eq!(first.method, SolverMethod::MassSpring);
    assert_eq!(first.response, OnDivergence::Freeze);
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(simulation.is_frozen());
    assert!(simulation.solver().is_finite());
    let frozen = positions(&app, cloth);
    assert!(frozen.iter().all(|p| p.is_finite()));
    app.update();
    assert_eq!(
        positions(&app, cloth),
        frozen,
        "a frozen cloth does not move"
    );

    // Automatic substeps make the same springs stable: the cloth steps again.
    app.world_mut()
        .get_mut::<ClothSettings>(cloth)
        .unwrap()
        .solver
        .auto_substeps = true;
    let mut later = Vec::new();
    for _ in 0..30 {
        app.update();
        later.extend(read_diverged(&app, &mut cursor));
    }
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(!simulation.is_frozen());
    assert!(simulation.solver().last_substeps() > 1);
    assert_ne!(positions(&app, cloth), frozen);
    assert!(later.is_empty(), "no new divergence: {later:?}");
}

#[test]
fn a_diverging_cloth_set_to_reset_goes_back_to_its_rest_shape() {
    let mut app = app();
    let (cloth, grid) = spawn_mass_spring_cloth(&mut app, unstable_settings(OnDivergence::Reset));
    let mut cursor = MessageCursor::default();
    let mut seen = Vec::new();
    for _ in 0..3 {
        app.update();
        seen.extend(read_diverged(&app, &mut cursor));
    }
    assert!(seen.iter().any(|m| m.response == OnDivergence::Reset));
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(!simulation.is_frozen());
    let sim = simulation.solver();
    let rest = grid.mesh().positions;
    // Reset after the last step: the state is the rest shape, 1 m up.
    let worst = sim
        .state()
        .positions
        .iter()
        .zip(&rest)
        .map(|(p, r)| Vec3::from(*p).distance(*r + Vec3::Y))
        .fold(0.0, f32::max);
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn switching_the_method_of_a_cloth_entity_keeps_its_motion() {
    let mut app = app();
    let (cloth, _) = spawn_mass_spring_cloth(&mut app, ClothSettings::default());
    for _ in 0..33 {
        app.update();
    }
    let state = |app: &App| {
        app.world()
            .get::<ClothSimulation>(cloth)
            .unwrap()
            .solver()
            .state()
            .clone()
    };
    let before = state(&app);
    let speed = before
        .velocities
        .iter()
        .map(|v| v.length())
        .fold(0.0, f32::max);
    {
        let mut settings = app.world_mut().get_mut::<ClothSettings>(cloth).unwrap();
        settings.solver.method = SolverMethod::Hybrid { long_range: false };
        settings.solver.auto_substeps = true;
    }
    let mut cursor = MessageCursor::default();
    app.update();
    let after = state(&app);
    let dt = 1.0 / 64.0;
    let worst = after
        .positions
        .iter()
        .zip(&before.positions)
        .zip(&before.velocities)
        .map(|((x1, x0), v0)| x1.distance(*x0 + *v0 * dt))
        .fold(0.0, f32::max);
    assert!(speed > 0.1);
    assert!(
        worst < 0.2 * speed * dt,
        "{worst} against v dt {}",
        speed * dt
    );
    assert!(read_diverged(&app, &mut cursor).is_empty());
}

#[test]
fn degenerate_colliders_are_ignored_with_an_error_and_the_cloth_keeps_stepping() {
    let mut app = app();
    let empty = app.world_mut().resource_mut::<Assets<Mesh>>().add(
        Mesh::new(
            PrimitiveTopology::TriangleList,
            bevy::asset::RenderAssetUsages::default(),
        )
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, Vec::<[f32; 3]>::new()),
    );
    let bad = [
        app.world_mut().spawn(ClothCollider::sphere(0.0)).id(),
        app.world_mut()
            .spawn(ClothCollider::capsule(-0.1, 0.2))
            .id(),
        app.world_mut()
            .spawn((
                ClothCollider::sphere(0.2),
                Transform::from_xyz(f32::NAN, 0.0, 0.0),
            ))
            .id(),
        app.world_mut().spawn(ClothCollider::mesh(empty)).id(),
        app.world_mut()
            .spawn(ClothCollider::plane().with_restitution(2.0))
            .id(),
    ];
    let good = app
        .world_mut()
        .spawn((ClothCollider::plane(), Transform::from_xyz(0.0, 0.5, 0.0)))
        .id();
    let grid = GridDesc::square(1.0, 8, Vec3::ZERO);
    let cloth = spawn_cloth(
        &mut app,
        &grid,
        Cloth::default(),
        Transform::from_xyz(0.0, 1.0, 0.0),
    );
    for _ in 0..60 {
        app.update();
    }
    for entity in bad {
        let state = app.world().get::<ColliderState>(entity).unwrap();
        assert!(state.error().is_some(), "{entity} refused");
        assert!(state.collider().is_none());
    }
    let world = app.world().resource::<StepColliders>();
    assert_eq!(world.entities, vec![good]);
    // The cloth fell onto the good plane and stayed finite.
    let after = positions(&app, cloth);
    assert!(after.iter().all(|p| p.is_finite()));
    let lowest = after.iter().map(|p| p.y).fold(f32::MAX, f32::min);
    assert!((lowest + 1.0 - 0.5).abs() < 0.02, "local {lowest}");
}

#[test]
fn a_collider_on_a_child_entity_is_posed_from_its_transform_chain_with_its_velocity() {
    let mut app = app();
    // A "bone": the sphere is a child of a parent that moves 1 cm per fixed step along x.
    let parent = app
        .world_mut()
        .spawn(Transform::from_xyz(0.0, 0.0, 0.0))
        .id();
    let sphere = app
        .world_mut()
        .spawn((
            ClothCollider::sphere(0.1),
            Transform::from_xyz(0.0, 1.0, 0.0),
            ChildOf(parent),
        ))
        .id();
    let spinner = app
        .world_mut()
        .spawn((
            ClothCollider::sphere(0.1),
            KinematicVelocity {
                linear: Vec3::new(0.0, 0.0, 0.64),
                angular: Vec3::new(0.0, 2.0, 0.0),
            },
        ))
        .id();
    for step in 0..10 {
        app.world_mut()
            .get_mut::<Transform>(parent)
            .unwrap()
            .translation
            .x = 0.01 * step as f32;
        app.update();
    }
    let collider = |entity| {
        app.world()
            .get::<ColliderState>(entity)
            .unwrap()
            .collider()
            .cloned()
            .unwrap()
    };
    let c = collider(sphere);
    assert!((c.end.translation - Vec3A::new(0.09, 1.0, 0.0)).length() < 1e-5);
    assert!((c.start.translation - Vec3A::new(0.08, 1.0, 0.0)).length() < 1e-5);
    // Velocity from the pose change over the 1/64 s step: 0.64 m/s.
    assert!((c.linear_velocity - Vec3A::new(0.64, 0.0, 0.0)).length() < 1e-3);
    let k = collider(spinner);
    assert_eq!(k.linear_velocity, Vec3A::new(0.0, 0.0, 0.64));
    assert_eq!(k.angular_velocity, Vec3A::new(0.0, 2.0, 0.0));
    // The kinematic collider moved itself: 9 fixed steps of 1/64 s (the first update has no
    // fixed step).
    let z = app.world().get::<Transform>(spinner).unwrap().translation.z;
    assert!((z - 0.09).abs() < 1e-4, "{z}");
}

#[test]
fn cloth_drapes_over_a_box_collider_read_from_an_obj_file() {
    let mut app = app();
    let obj = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/meshes/box.obj"
    ))
    .unwrap();
    let box_mesh = bevy_drape::bevy_obj::mesh::load_obj_as_mesh(&obj, &Default::default()).unwrap();
    let box_mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(box_mesh);
    app.world_mut().spawn(ClothCollider::mesh(box_mesh));
    app.world_mut().spawn(ClothCollider::plane());
    let grid = GridDesc::square(1.0, 16, Vec3::new(-0.5, 0.0, -0.5));
    let cloth = spawn_cloth(
        &mut app,
        &grid,
        Cloth::default(),
        Transform::from_xyz(0.0, 1.0, 0.0),
    );
    for _ in 0..129 {
        app.update();
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    let x = &sim.state().positions;
    assert!(sim.is_finite());
    // The middle of the sheet rests on the box's top, margin + thickness above it.
    let middle = x[grid.index(8, 8) as usize];
    assert!((middle.y - 0.61).abs() < 0.005, "{middle}");
    // Nothing inside the box.
    let inside = x
        .iter()
        .filter(|p| p.x.abs() < 0.29 && p.z.abs() < 0.29 && p.y > 0.01 && p.y < 0.59)
        .count();
    assert_eq!(inside, 0);
    // The rim hangs down over the box's sides.
    let lowest = x.iter().map(|p| p.y).fold(f32::MAX, f32::min);
    assert!(lowest < 0.5, "{lowest}");
}

#[test]
fn a_skeleton_plays_a_clip_file_poses_its_bones_and_publishes_their_velocities() {
    let mut app = app();
    let clip: Handle<ClipAsset> = app
        .world()
        .resource::<AssetServer>()
        .load("clips/walk.clip.ron");
    let rig = std::sync::Arc::new(humanoid());
    let character = app
        .world_mut()
        .spawn((Skeleton { rig: rig.clone() }, ClipPlayer::new(clip.clone())))
        .id();
    // Wait for the file.
    for _ in 0..200 {
        app.update();
        if app
            .world()
            .resource::<Assets<ClipAsset>>()
            .get(&clip)
            .is_some()
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(
        app.world()
            .resource::<Assets<ClipAsset>>()
            .get(&clip)
            .is_some()
    );
    let bones = app.world().get::<SkeletonBones>(character).unwrap().clone();
    assert_eq!(bones.entities().len(), 19);
    // A capsule on the left shin, halfway down it.
    let shin = bones.get("shin_l").unwrap();
    let proxy = app
        .world_mut()
        .spawn((
            ClothCollider::capsule(0.05, 0.15),
            Transform::from_xyz(0.0, -0.21, 0.0),
            ChildOf(shin),
        ))
        .id();
    for _ in 0..20 {
        app.update();
    }
    let pose = app.world().get::<SkeletonPose>(character).unwrap().clone();
    // The bone entities carry the forward kinematics of the sampled pose: composing their
    // local transforms of this fixed step from the pelvis down gives the FK positions. (Their
    // `Transform`s show the step before, interpolated for rendering.)
    for name in ["foot_l", "hand_r", "head"] {
        let index = rig.find(name).unwrap();
        let mut chain = vec![index];
        while let Some(p) = rig.bones()[*chain.last().unwrap()].parent {
            chain.push(p);
        }
        let mut world = Transform::IDENTITY;
        for &b in chain.iter().rev() {
            let bone = app
                .world()
                .get::<BoneEntity>(bones.entity(b).unwrap())
                .unwrap();
            world = world * bone.current();
        }
        let fk = pose.bones[index].translation;
        assert!(
            world.translation.distance(fk) < 1e-5,
            "{name}: {} vs {fk}",
            world.translation
        );
    }
    // The swinging shin has a velocity, and the proxy hanging from it moves with it.
    let shin_state = pose.bones[rig.find("shin_l").unwrap()];
    assert!(shin_state.angular_velocity.length() > 0.1);
    let collider = app
        .world()
        .get::<ColliderState>(proxy)
        .unwrap()
        .collider()
        .cloned()
        .unwrap();
    let expected = shin_state.point_velocity(Vec3::from(collider.end.translation));
    assert!(
        (Vec3::from(collider.linear_velocity) - expected).length() < 0.05 * expected.length(),
        "{} vs {expected}",
        collider.linear_velocity
    );
}

#[test]
fn inverse_kinematics_puts_both_wrists_on_their_targets_on_top_of_the_clip() {
    let mut app = app();
    let clip = app
        .world_mut()
        .resource_mut::<Assets<ClipAsset>>()
        .add(ClipAsset(
            ClipDesc::from_ron(include_str!("../assets/clips/walk.clip.ron")).unwrap(),
        ));
    let rig = std::sync::Arc::new(humanoid());
    let marker = app
        .world_mut()
        .spawn(Transform::from_xyz(-0.3, 1.2, 2.35))
        .id();
    let goal = |end: &str, target| IkGoal {
        end_bone: end.into(),
        length: 3,
        effector: Vec3::new(0.0, -0.25, 0.0),
        target,
        settings: IkSettings::default(),
        weight: 1.0,
        max_speed: IkGoal::DEFAULT_MAX_SPEED,
    };
    let character = app
        .world_mut()
        .spawn((
            Skeleton { rig: rig.clone() },
            ClipPlayer::new(clip),
            InverseKinematics {
                goals: vec![
                    // Entity and point targets, 2 m forward of the origin where the character
                    // stands.
                    goal("forearm_r", IkTarget::Entity(marker)),
                    goal("forearm_l", IkTarget::Point(Vec3::new(0.35, 1.1, 2.3))),
                    goal("tail", IkTarget::Point(Vec3::ZERO)),
                ],
                results: Vec::new(),
            },
            Transform::from_xyz(0.0, 0.0, 2.0),
        ))
        .id();
    for _ in 0..30 {
        app.update();
    }
    let ik = app.world().get::<InverseKinematics>(character).unwrap();
    let pose = app.world().get::<SkeletonPose>(character).unwrap();
    assert_eq!(ik.results.len(), 3);
    assert!(ik.results[2].is_none(), "the bad goal is skipped");
    for (g, (bone, target)) in [
        ("forearm_r", Vec3::new(-0.3, 1.2, 2.35)),
        ("forearm_l", Vec3::new(0.35, 1.1, 2.3)),
    ]
    .into_iter()
    .enumerate()
    {
        let result = ik.results[g].unwrap();
        assert!(result.reached, "{bone}: {result:?}");
        let b = pose.bones[rig.find(bone).unwrap()];
        let wrist = b.translation + b.rotation * Vec3::new(0.0, -0.25, 0.0) + Vec3::Z * 2.0;
        assert!(wrist.distance(target) < 1e-3, "{bone}: {wrist} vs {target}");
    }
}

#[test]
fn debug_colours_are_written_into_the_mesh_and_white_when_off() {
    let mut app = app();
    let grid = GridDesc::square(1.0, 6, Vec3::ZERO);
    let cloth = spawn_cloth(
        &mut app,
        &grid,
        Cloth::pinned([0, 5]),
        Transform::from_xyz(0.0, 1.0, 0.0),
    );
    let colours = |app: &App| {
        let handle = &app.world().get::<Mesh3d>(cloth).unwrap().0;
        let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
        match mesh.attribute(Mesh::ATTRIBUTE_COLOR) {
            Some(VertexAttributeValues::Float32x4(c)) => Some(c.clone()),
            _ => None,
        }
    };
    for _ in 0..5 {
        app.update();
    }
    // The cloth's mesh has white vertex colours from the start (a constant vertex layout).
    let white = vec![[1.0f32; 4]; 36];
    assert_eq!(colours(&app), Some(white.clone()));
    app.insert_resource(ClothDebugColors(DebugColorMode::Pinned));
    app.update();
    let c = colours(&app).expect("colours written");
    assert_eq!(c.len(), 36);
    assert_ne!(c[0], c[7], "a pin and a free vertex differ");
    app.insert_resource(ClothDebugColors(DebugColorMode::Strain));
    app.update();
    assert!(
        colours(&app)
            .unwrap()
            .iter()
            .flatten()
            .all(|v| v.is_finite())
    );
    app.insert_resource(ClothDebugColors(DebugColorMode::Off));
    app.update();
    assert_eq!(colours(&app), Some(white));
}

#[test]
fn per_triangle_paint_draws_flat_colours_and_off_brings_the_shared_mesh_back() {
    let mut app = app();
    let grid = GridDesc::square(1.0, 5, Vec3::ZERO);
    let cloth = spawn_cloth(
        &mut app,
        &grid,
        Cloth::pinned([0, 4]),
        Transform::from_xyz(0.0, 1.0, 0.0),
    );
    let mesh = |app: &App| {
        let handle = &app.world().get::<Mesh3d>(cloth).unwrap().0;
        app.world()
            .resource::<Assets<Mesh>>()
            .get(handle)
            .unwrap()
            .clone()
    };
    let attribute3 = |m: &Mesh, a| match m.attribute(a) {
        Some(VertexAttributeValues::Float32x3(v)) => v.clone(),
        _ => panic!("no attribute"),
    };
    let colours = |m: &Mesh| match m.attribute(Mesh::ATTRIBUTE_COLOR) {
        Some(VertexAttributeValues::Float32x4(c)) => c.clone(),
        _ => panic!("no colours"),
    };
    for _ in 0..3 {
        app.update();
    }
    let shared = mesh(&app);
    assert_eq!(shared.count_vertices(), 25);
    let triangles = 32;
    // A colour of its own for every triangle, from a value nobody designed for it.
    let paint: Vec<[f32; 4]> = (0..triangles)
        .map(|t| {
            let u = ((t * 7919) % 97) as f32 / 97.0;
            [u, 1.0 - u, 0.5 * u, 1.0]
        })
        .collect();
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothPaint::triangle_colors(paint.clone()));
    app.insert_resource(ClothDebugColors(DebugColorMode::Custom));
    for _ in 0..3 {
        app.update();
    }
    let flat = mesh(&app);
    assert_eq!(flat.count_vertices(), 3 * triangles);
    let c = colours(&flat);
    for (corner, colour) in c.iter().enumerate() {
        assert_eq!(*colour, paint[corner / 3], "corner {corner}");
    }
    // Every corner is drawn where its particle is: the flat mesh's positions are the shared
    // mesh's vertices, gathered by the indices, as the cloth moves on.
    let positions = attribute3(&flat, Mesh::ATTRIBUTE_POSITION);
    let solver = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    let model = solver.model();
    for (t, tri) in model.triangles.iter().enumerate() {
        for k in 0..3 {
            let particle = solver.state().positions[tri[k] as usize];
            let drawn = Vec3::from(positions[3 * t + k]) + Vec3::Y;
            assert!(
                drawn.distance(particle.into()) < 0.05,
                "{drawn} vs {particle}"
            );
        }
    }
    // Per particle: one colour per vertex, the shared mesh again.
    let values: Vec<f32> = (0..25).map(|i| i as f32).collect();
    app.world_mut().entity_mut(cloth).insert(ClothPaint::values(
        PaintTarget::Particles,
        values,
        0.0,
        24.0,
    ));
    app.update();
    let shared_again = mesh(&app);
    assert_eq!(shared_again.count_vertices(), 25);
    assert_eq!(shared_again.indices(), shared.indices());
    let c = colours(&shared_again);
    assert_ne!(c[0], c[24]);
    // A list of the wrong length: grey, a warning, the app keeps running.
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothPaint::triangle_colors(vec![[1.0; 4]; 3]));
    app.update();
    assert_eq!(mesh(&app).count_vertices(), 3 * triangles);
    assert!(
        colours(&mesh(&app))
            .iter()
            .all(|c| c.iter().all(|v| v.is_finite()))
    );
    // Area strain is per triangle too; off gives the shared mesh and white back.
    app.insert_resource(ClothDebugColors(DebugColorMode::AreaStrain));
    app.update();
    assert_eq!(mesh(&app).count_vertices(), 3 * triangles);
    app.insert_resource(ClothDebugColors(DebugColorMode::Off));
    app.update();
    let off = mesh(&app);
    assert_eq!(off.count_vertices(), 25);
    assert_eq!(colours(&off), vec![[1.0f32; 4]; 25]);
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

#[test]
fn bone_colliders_attach_by_name_to_any_hierarchy_once_it_is_there() {
    // A hierarchy of the game's own (as a glTF scene spawns it, some frames late): the root
    // with `BoneColliders` first, the joints after. A name found twice takes the shallower
    // joint; a proxy on a joint the hierarchy does not have is skipped.
    let mut app = app();
    let mut colliders = BoneColliders::humanoid();
    colliders
        .proxies
        .retain(|p| p.bone == "pelvis" || p.bone == "spine");
    let mut tail = colliders.proxies[0].clone();
    tail.bone = "tail".into();
    colliders.proxies.push(tail);
    let root = app
        .world_mut()
        .spawn((colliders.clone(), Transform::default()))
        .id();
    let proxies_of = |app: &mut App| {
        let world = app.world_mut();
        let mut found: Vec<(String, Entity, f32)> = world
            .query::<(&Name, &ClothCollider, &BoneProxyOf, &ChildOf)>()
            .iter(world)
            .filter(|(_, _, of, _)| of.0 == root)
            .map(|(name, c, _, parent)| {
                let radius = match c.shape {
                    ColliderShape::Capsule { radius, .. } => radius,
                    _ => panic!("proxies are capsules"),
                };
                (name.to_string(), parent.parent(), radius)
            })
            .collect();
        found.sort_by(|a, b| a.0.cmp(&b.0));
        found
    };
    for _ in 0..3 {
        app.update();
    }
    assert!(proxies_of(&mut app).is_empty(), "nothing to attach to yet");
    let world = app.world_mut();
    let pelvis = world
        .spawn((Name::new("pelvis"), Transform::default(), ChildOf(root)))
        .id();
    let spine = world
        .spawn((Name::new("spine"), Transform::default(), ChildOf(pelvis)))
        .id();
    world.spawn((Name::new("pelvis"), Transform::default(), ChildOf(spine)));
    app.update();
    app.update();
    let found = proxies_of(&mut app);
    let pelvis_proxies = colliders
        .proxies
        .iter()
        .filter(|p| p.bone == "pelvis")
        .count();
    assert_eq!(found.len(), colliders.proxies.len() - 1, "{found:?}");
    assert!(
        found
            .iter()
            .filter(|f| f.0 == "pelvis proxy")
            .all(|f| f.1 == pelvis)
    );
    assert_eq!(
        found.iter().filter(|f| f.1 == pelvis).count(),
        pelvis_proxies
    );
    assert!(
        found
            .iter()
            .filter(|f| f.0 == "spine proxy")
            .all(|f| f.1 == spine)
    );
    // An edit (an inspector's, a file's): the proxies are spawned again from it, once.
    app.world_mut()
        .get_mut::<BoneColliders>(root)
        .unwrap()
        .proxies[0]
        .radius = 0.25;
    app.update();
    app.update();
    let again = proxies_of(&mut app);
    assert_eq!(again.len(), found.len());
    assert_eq!(again.iter().filter(|f| f.2 == 0.25).count(), 1);
}

/// A `Float32x3` attribute of the entity's mesh.
fn attribute(app: &App, entity: Entity, name: bevy::mesh::MeshVertexAttribute) -> Vec<Vec3> {
    let handle = &app.world().get::<Mesh3d>(entity).unwrap().0;
    let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
    match mesh.attribute(name).unwrap() {
        VertexAttributeValues::Float32x3(p) => p.iter().map(|&p| Vec3::from_array(p)).collect(),
        _ => panic!("Float32x3"),
    }
}

/// The largest angle between the normals of two triangles that share an edge, radians.
fn sharpest_crease(positions: &[Vec3], indices: &[u32]) -> f32 {
    let triangles: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let normal = |t: [u32; 3]| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        (b - a).cross(c - a).normalize()
    };
    let mut by_edge = std::collections::HashMap::<[u32; 2], Vec<usize>>::new();
    for (k, t) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            by_edge.entry([a.min(b), a.max(b)]).or_default().push(k);
        }
    }
    by_edge
        .values()
        .filter(|ts| ts.len() == 2)
        .map(|ts| {
            normal(triangles[ts[0]])
                .dot(normal(triangles[ts[1]]))
                .clamp(-1.0, 1.0)
                .acos()
        })
        .fold(0.0, f32::max)
}

/// A cloth simulated on a coarse mesh and drawn with a finer one (`ClothSimulationMesh`).
#[test]
fn a_fine_mesh_drawn_over_a_coarse_simulation_follows_it_smoothly() {
    let mut app = app();
    // A 1 m sheet simulated with 7 x 7 particles, drawn with 37 x 37 vertices: every 6th
    // drawn vertex lies on a particle at rest.
    let coarse = GridDesc::square(1.0, 7, Vec3::ZERO);
    let fine = GridDesc::square(1.0, 37, Vec3::ZERO);
    let (coarse_mesh, fine_mesh) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (meshes.add(grid_mesh(&coarse)), meshes.add(grid_mesh(&fine)))
    };
    let pins = [coarse.index(0, 0), coarse.index(6, 0)];
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(fine_mesh),
            ClothSimulationMesh(coarse_mesh),
            Cloth::pinned(pins),
            Transform::from_xyz(0.0, 1.0, 0.0),
        ))
        .id();
    for _ in 0..81 {
        app.update();
    }
    // Paused, the cloth is drawn at its last state rather than between the last two.
    app.world_mut().resource_mut::<DrapeSettings>().paused = true;
    for _ in 0..3 {
        app.update();
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    assert_eq!(sim.state().positions.len(), 49);
    let particles = sim.state().positions.clone();
    let drawn = attribute(&app, cloth, Mesh::ATTRIBUTE_POSITION);
    let normals = attribute(&app, cloth, Mesh::ATTRIBUTE_NORMAL);
    assert_eq!(drawn.len(), 37 * 37);
    assert!(drawn.iter().chain(&normals).all(|p| p.is_finite()));
    assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
    // The drawn vertices on particles are at the particles (the entity is at y = 1).
    for j in 0..7 {
        for i in 0..7 {
            let particle = Vec3::from(particles[coarse.index(i, j) as usize]);
            let vertex = drawn[fine.index(6 * i, 6 * j) as usize] + Vec3::Y;
            assert!(
                particle.distance(vertex) < 1e-4,
                "particle ({i}, {j}) at {particle}, its vertex at {vertex}"
            );
        }
    }
    // The sheet hung down and is drawn smoother than its simulated facets.
    assert!(particles.iter().any(|p| p.y < 0.5));
    let fine_indices = fine.mesh().indices;
    let coarse_positions: Vec<Vec3> = particles.iter().map(|&p| p.into()).collect();
    let (drawn_crease, simulated_crease) = (
        sharpest_crease(&drawn, &fine_indices),
        sharpest_crease(&coarse_positions, &coarse.mesh().indices),
    );
    assert!(
        drawn_crease < 0.5 * simulated_crease,
        "drawn crease {drawn_crease} rad, simulated {simulated_crease} rad"
    );
}

/// Sheets draped over a sphere, one drawn with its own mesh and one simulated on a coarse mesh
/// and drawn with a finer one: the particles end a step anywhere from the sphere's surface out
/// to the contact distance, and the coarse mesh's chords cut into it, but every drawn vertex
/// is at least the contact distance from the sphere (`collide/skin.rs`), and those of the
/// sheet that is its own mesh stay within it of their particles.
#[test]
fn a_cloth_on_a_sphere_is_drawn_outside_it() {
    let mut app = app();
    let radius = 0.3;
    app.world_mut()
        .spawn((ClothCollider::sphere(radius), Transform::default()));
    let own = GridDesc::square(1.0, 24, Vec3::new(-0.5, radius + 0.05, -0.5));
    let coarse = GridDesc::square(1.0, 7, Vec3::new(-0.5, radius + 0.05, -0.5));
    let fine = GridDesc::square(1.0, 37, Vec3::new(-0.5, radius + 0.05, -0.5));
    let own_cloth = spawn_cloth(&mut app, &own, Cloth::default(), Transform::default());
    let (coarse_mesh, fine_mesh) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (meshes.add(grid_mesh(&coarse)), meshes.add(grid_mesh(&fine)))
    };
    let coarse_cloth = app
        .world_mut()
        .spawn((
            Mesh3d(fine_mesh),
            ClothSimulationMesh(coarse_mesh),
            Cloth::default(),
            Transform::default(),
        ))
        .id();
    // The contact distance: the sphere's margin and the cloth's thickness.
    let reach = SolverSettings::default().thickness + ClothCollider::sphere(radius).margin;
    let (mut closest_particle, mut deepest_chord) = (f32::INFINITY, f32::INFINITY);
    for update in 0..90 {
        app.update();
        if update < 30 {
            continue;
        }
        for cloth in [own_cloth, coarse_cloth] {
            let drawn = positions(&app, cloth);
            assert!(drawn.iter().all(|p| p.is_finite()));
            for p in &drawn {
                assert!(
                    p.length() - radius >= reach - 1e-4,
                    "a drawn vertex {} m from the sphere",
                    p.length() - radius
                );
            }
            let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
            let x: Vec<Vec3> = sim.state().positions.iter().map(|&p| p.into()).collect();
            closest_particle = x
                .iter()
                .map(|p| p.length() - radius)
                .fold(closest_particle, f32::min);
            if cloth == coarse_cloth {
                for t in &sim.model().triangles {
                    for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                        let middle = (x[a as usize] + x[b as usize]) * 0.5;
                        deepest_chord = deepest_chord.min(middle.length() - radius);
                    }
                }
            }
        }
    }
    // Paused, a cloth is drawn at its last state: the sheet drawn with its own mesh has a
    // vertex per particle, moved no further than out to the contact distance.
    app.world_mut().resource_mut::<DrapeSettings>().paused = true;
    for _ in 0..3 {
        app.update();
    }
    let sim = app
        .world()
        .get::<ClothSimulation>(own_cloth)
        .unwrap()
        .solver();
    let drawn = positions(&app, own_cloth);
    assert_eq!(drawn.len(), sim.state().positions.len());
    for (p, &q) in drawn.iter().zip(&sim.state().positions) {
        assert!(p.distance(q.into()) <= reach + 1e-4, "{p} drawn for {q}");
    }
    println!(
        "closest particle {closest_particle:.2e} m from the sphere, the coarse mesh's chords \
         {deepest_chord:.3} m"
    );
    assert!(closest_particle >= -1e-5 && closest_particle < reach);
    assert!(deepest_chord < -0.005, "{deepest_chord}");
}

/// Independent cloths stepped on Bevy's compute task pool (`DrapeSettings::max_threads`)
/// end where they end stepped one after another, bit for bit.
#[test]
fn cloths_stepped_on_several_threads_end_where_one_thread_leaves_them() {
    let run = |threads: usize| {
        let mut app = app();
        app.insert_resource(DrapeSettings {
            max_threads: std::num::NonZeroUsize::new(threads),
            ..DrapeSettings::default()
        });
        app.world_mut().spawn((
            ClothCollider::sphere(0.25),
            Transform::from_xyz(0.0, -0.4, 0.0),
        ));
        let cloths: Vec<Entity> = (0..5u32)
            .map(|i| {
                let n = 6 + 2 * i;
                let grid = GridDesc::square(0.8, n, Vec3::new(-0.4, 0.0, -0.4));
                let pins = if i % 2 == 0 { vec![0] } else { vec![] };
                spawn_cloth(
                    &mut app,
                    &grid,
                    Cloth::pinned(pins),
                    Transform::from_xyz(0.1 * i as f32, 0.0, 0.0),
                )
            })
            .collect();
        for _ in 0..40 {
            app.update();
        }
        cloths
            .iter()
            .map(|&e| positions(&app, e))
            .collect::<Vec<_>>()
    };
    let one = run(1);
    let two = run(2);
    assert!(one.iter().flatten().all(|p| p.is_finite()));
    // They fell (and the pinned ones kept their pin).
    assert!(one.iter().all(|c| c.iter().any(|p| p.y < -0.1)));
    assert_eq!(one, two);
}

/// A single large cloth is split over two threads (`ClothSolver::step_with`): it falls as it
/// does on one thread, within millimetres, and stays finite; with one thread it is stepped
/// as the core steps it alone.
#[test]
fn a_single_large_cloth_steps_on_two_threads_where_one_thread_leaves_it() {
    let n = 64;
    let grid = GridDesc::square(1.0, n, Vec3::new(-0.5, 0.0, -0.5));
    let pins = [grid.index(0, 0), grid.index(n - 1, 0)];
    let run = |threads: usize| {
        let mut app = app();
        app.insert_resource(DrapeSettings {
            max_threads: std::num::NonZeroUsize::new(threads),
            ..DrapeSettings::default()
        });
        let cloth = spawn_cloth(&mut app, &grid, Cloth::pinned(pins), Transform::IDENTITY);
        for _ in 0..40 {
            app.update();
        }
        positions(&app, cloth)
    };
    let (one, two) = (run(1), run(2));
    assert!(two.iter().all(|p| p.is_finite()));
    let corner = grid.index(n - 1, n - 1) as usize;
    assert!(one[corner].y < -0.3, "the cloth fell: {}", one[corner]);
    let apart = one
        .iter()
        .zip(&two)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    println!("one and two threads at most {apart} m apart");
    assert!(apart < 5e-3, "{apart} m apart");
    let pool = bevy::tasks::ComputeTaskPool::get();
    if pool.thread_num() > 0 {
        assert!(apart > 0.0, "the cloth was not split");
    } else {
        println!("the compute pool has no thread of its own: nothing to split over");
    }
}
