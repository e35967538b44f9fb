//! Avian interop (`--features avian`): Avian colliders become cloth colliders of the same
//! shape, follow Avian's bodies and materials, and cloth drapes on them and is carried by them,
//! in a headless App running Avian's physics and the crate's plugins.
#![cfg(feature = "avian")]

mod common;

use avian3d::prelude::*;
use bevy::math::Vec3A;
use bevy::mesh::Mesh;
use bevy::prelude::*;
use bevy_drape::collide::avian::{FromAvian, NoClothCollision};
use bevy_drape::collide::plugin::AnimatedVelocity;
use bevy_drape::collide::{SolverShape, TriMesh};
use bevy_drape::mesh::mesh_triangles;
use bevy_drape::prelude::*;
use common::{Headless, Rng, add_grid, particles};

/// A headless App with Avian and the crate, one fixed step of 1/64 s per update.
fn app() -> App {
    let mut app = Headless::new().build_with(PhysicsPlugins::default(), ());
    // Avian sets some of its resources up when the plugins finish (`App::run` does this).
    app.finish();
    app.cleanup();
    app
}

/// The triangle mesh a mesh-shaped cloth collider was given, as the solver sees it.
fn collider_mesh(app: &App, entity: Entity) -> TriMesh {
    let Some(ClothCollider {
        shape: ColliderShape::TriangleMesh(handle),
        ..
    }) = app.world().get::<ClothCollider>(entity)
    else {
        panic!("{entity} has no triangle-mesh cloth collider");
    };
    let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
    let (vertices, indices) = mesh_triangles(mesh).unwrap();
    TriMesh::new(&vertices, &indices).unwrap()
}

#[test]
fn avian_colliders_become_cloth_colliders_of_the_same_shape_until_they_go_or_opt_out() {
    let mut app = app();
    let world = app.world_mut();
    let ball = world.spawn((RigidBody::Static, Collider::sphere(0.3))).id();
    let capsule = world
        .spawn((RigidBody::Static, Collider::capsule(0.2, 1.0)))
        .id();
    let cuboid = world
        .spawn((RigidBody::Static, Collider::cuboid(1.0, 0.4, 2.0)))
        .id();
    let cylinder = world
        .spawn((RigidBody::Static, Collider::cylinder(0.3, 0.8)))
        .id();
    // A hull of points nobody placed by hand.
    let mut rng = Rng(17);
    let points: Vec<Vec3> = (0..40).map(|_| rng.vec3(-0.5, 0.5)).collect();
    let hull = world
        .spawn((
            RigidBody::Static,
            Collider::convex_hull(points).expect("a hull of 40 random points"),
        ))
        .id();
    let compound = world
        .spawn((
            RigidBody::Static,
            Collider::compound(vec![
                (Vec3::ZERO, Quat::IDENTITY, Collider::sphere(0.1)),
                (Vec3::X, Quat::IDENTITY, Collider::sphere(0.1)),
            ]),
        ))
        .id();
    let opted_out = world
        .spawn((RigidBody::Static, Collider::sphere(0.2), NoClothCollision))
        .id();
    let own = world
        .spawn((
            RigidBody::Static,
            Collider::sphere(0.2),
            ClothCollider::capsule(0.1, 0.5),
        ))
        .id();
    for _ in 0..3 {
        app.update();
    }
    let shape = |app: &App, e| app.world().get::<ClothCollider>(e).map(|c| c.shape.clone());
    assert_eq!(
        shape(&app, ball),
        Some(ColliderShape::Sphere { radius: 0.3 })
    );
    assert_eq!(
        shape(&app, capsule),
        Some(ColliderShape::Capsule {
            radius: 0.2,
            half_length: 0.5
        })
    );
    // The mesh-shaped ones are closed and wound outward: their centre is inside, a point
    // beyond their bounds outside.
    for e in [cuboid, cylinder, hull] {
        let mesh = collider_mesh(&app, e);
        assert!(mesh.is_closed(), "{e}");
        let shape = SolverShape::TriangleMesh(std::sync::Arc::new(mesh));
        let (d, _) = shape.signed_distance(Vec3A::ZERO, 10.0).unwrap();
        assert!(d < 0.0, "{e}: the centre is {d} from the surface");
        let (d, _) = shape.signed_distance(Vec3A::splat(3.0), 10.0).unwrap();
        assert!(d > 0.0);
    }
    // The cuboid's faces lie where Avian's are.
    let box_mesh = SolverShape::TriangleMesh(std::sync::Arc::new(collider_mesh(&app, cuboid)));
    let (d, _) = box_mesh
        .signed_distance(Vec3A::new(0.0, 0.3, 0.0), 1.0)
        .unwrap();
    assert!((d - 0.1).abs() < 1e-5, "{d}");
    assert_eq!(shape(&app, compound), None);
    assert_eq!(shape(&app, opted_out), None);
    assert_eq!(
        shape(&app, own),
        Some(ColliderShape::Capsule {
            radius: 0.1,
            half_length: 0.5
        })
    );
    assert!(!app.world().entity(own).contains::<FromAvian>());
    // The Avian collider goes, or the entity opts out: the cloth collider goes with it.
    app.world_mut().entity_mut(ball).remove::<Collider>();
    app.world_mut().entity_mut(capsule).insert(NoClothCollision);
    app.update();
    app.update();
    assert_eq!(shape(&app, ball), None);
    assert_eq!(shape(&app, capsule), None);
    // A changed Avian shape changes the cloth collider.
    app.world_mut()
        .entity_mut(cylinder)
        .insert(Collider::sphere(0.7));
    app.update();
    app.update();
    assert_eq!(
        shape(&app, cylinder),
        Some(ColliderShape::Sphere { radius: 0.7 })
    );
}

/// A 1 m cloth of 16 x 16 particles, flat, its corner `(0, 0)` at `origin`.
fn spawn_cloth(app: &mut App, origin: Vec3) -> Entity {
    let grid = GridDesc::square(1.0, 16, Vec3::ZERO);
    let mesh = add_grid(app, &grid);
    app.world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::default(),
            Transform::from_translation(origin),
        ))
        .id()
}

#[test]
fn cloth_rests_on_a_static_avian_box_and_rides_a_kinematic_avian_body() {
    let mut app = app();
    // A static table, 1.2 m square, its top at 0.5 m.
    app.world_mut().spawn((
        RigidBody::Static,
        Collider::cuboid(1.2, 0.2, 1.2),
        Transform::from_xyz(0.0, 0.4, 0.0),
    ));
    let on_table = spawn_cloth(&mut app, Vec3::new(-0.5, 0.7, -0.5));
    // A kinematic slab moving along +x at 0.5 m/s with high friction, a cloth on it.
    let slab = app
        .world_mut()
        .spawn((
            RigidBody::Kinematic,
            Collider::cuboid(1.4, 0.2, 1.4),
            Friction::new(1.2),
            LinearVelocity(Vec3::new(0.5, 0.0, 0.0)),
            Transform::from_xyz(0.0, 0.4, 5.0),
        ))
        .id();
    let riding = spawn_cloth(&mut app, Vec3::new(-0.5, 0.7, 4.5));
    for _ in 0..3 {
        app.update();
    }
    let start = particles(&app, riding).iter().sum::<Vec3>() / 256.0;
    let slab_start = app.world().get::<Transform>(slab).unwrap().translation.x;
    let steps = 192;
    let mut deepest = 0.0f32;
    for _ in 0..steps {
        app.update();
        let slab_x = app.world().get::<Transform>(slab).unwrap().translation.x;
        for (cloth, centre) in [
            (on_table, Vec3::new(0.0, 0.4, 0.0)),
            (riding, Vec3::new(slab_x, 0.4, 5.0)),
        ] {
            for p in particles(&app, cloth) {
                let local = (p - centre).abs();
                let half = if cloth == on_table { 0.6 } else { 0.7 };
                if local.x < half && local.z < half && local.y < 0.1 {
                    deepest = deepest.max(0.1 - local.y);
                }
            }
        }
    }
    let collider = app.world().get::<ClothCollider>(slab).unwrap();
    assert_eq!(collider.material.friction, 1.2);
    let velocity = app.world().get::<AnimatedVelocity>(slab).unwrap();
    assert_eq!(velocity.linear, Vec3::new(0.5, 0.0, 0.0));
    println!("deepest inside a box: {:.2} mm", deepest * 1000.0);
    assert!(
        deepest <= ClothCollider::sphere(1.0).margin,
        "{deepest} m deep"
    );
    // The cloth on the table lies on its top.
    let table = particles(&app, on_table);
    let centre = table[8 * 16 + 8];
    assert!((centre.y - 0.5).abs() < 0.02, "{centre}");
    // The riding cloth moved with the slab: 0.5 m/s for 3 s.
    let end = particles(&app, riding).iter().sum::<Vec3>() / 256.0;
    let slab_moved = app.world().get::<Transform>(slab).unwrap().translation.x - slab_start;
    println!(
        "slab moved {slab_moved:.3} m, the cloth on it {:.3} m",
        end.x - start.x
    );
    assert!(slab_moved > 1.4);
    assert!((end.x - start.x - slab_moved).abs() < 0.1);
}
