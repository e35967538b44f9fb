//! Collider entities in a headless App: degenerate ones left out with an error, one on a
//! child entity posed from its transform chain, a box read from an OBJ file.

use crate::common;

use bevy::mesh::{Mesh, PrimitiveTopology};
use bevy::prelude::*;
use bevy_drape::collide::plugin::ColliderState;
use bevy_drape::prelude::*;
use bevy_drape::schedule::StepColliders;
use common::{app, positions, spawn_cloth};

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
