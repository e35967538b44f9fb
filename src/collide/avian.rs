//! Avian interop (crate feature `avian`, avian3d 0.7): every entity with an Avian [`Collider`]
//! is a cloth collider, with no component of this crate on it.
//!
//! [`AvianColliderPlugin`] gives such an entity a [`ClothCollider`] of the same shape (and
//! [`FromAvian`] to say where it came from) when its `Collider` appears or changes, and takes
//! it away when the `Collider` goes or [`NoClothCollision`] is added. A ball is a sphere, a
//! capsule along local Y about the origin a capsule, a half-space facing up a plane; a cuboid,
//! a cylinder, a cone, any other capsule, a convex hull and a triangle mesh become a triangle
//! mesh collider (a [`Mesh`] asset kept in the main world only), closed ones wound outward.
//! Other shapes (compounds, height fields, voxels, polylines, rounded shapes, ...) are
//! reported once per entity as unsupported. Every fixed step, before the colliders are read,
//! the collider's velocity is taken from Avian's [`LinearVelocity`] and [`AngularVelocity`]
//! (as an [`AnimatedVelocity`]) and its material from Avian's [`Friction`] (the dynamic
//! coefficient) and [`Restitution`].
//!
//! The coupling is one way: cloth follows Avian's bodies, it does not push them.

use avian3d::parry::shape::TypedShape;
use avian3d::prelude::{AngularVelocity, Collider, Friction, LinearVelocity, Restitution};
use bevy::asset::RenderAssetUsages;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology};
use bevy::prelude::*;

use super::components::{AnimatedVelocity, ClothCollider, ColliderShape};
use crate::schedule::{DrapeSchedule, DrapeSystems};

/// Leaves an entity with an Avian [`Collider`] out of the cloths' colliders.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Component)]
pub struct NoClothCollision;

/// On a [`ClothCollider`] made from the entity's Avian [`Collider`]: it is rebuilt when that
/// changes and removed with it. An entity with a `ClothCollider` of its own (without this
/// marker) keeps it, whatever Avian collider it has.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Component)]
pub struct FromAvian;

/// Makes every Avian collider a cloth collider (see the [module docs](self)).
#[derive(Default)]
pub struct AvianColliderPlugin;

impl Plugin for AvianColliderPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        // In the same schedule as Avian (both default to `FixedPostUpdate`), the cloth sees
        // the bodies where this physics step left them.
        app.configure_sets(
            schedule,
            DrapeSystems::Prepare.after(avian3d::schedule::PhysicsSystems::Last),
        )
        .register_type::<(NoClothCollision, FromAvian)>()
        .add_systems(
            schedule,
            (adopt_avian_colliders, follow_avian_bodies)
                .chain()
                .in_set(DrapeSystems::Prepare),
        );
    }
}

/// The cloth collider shape of an Avian collider's shape, or the name of the kind of shape
/// that has none. Mesh shapes add a [`Mesh`] asset.
fn cloth_shape(collider: &Collider, meshes: &mut Assets<Mesh>) -> Result<ColliderShape, String> {
    let triangles = |vertices: Vec<Vec3>, indices: Vec<[u32; 3]>, meshes: &mut Assets<Mesh>| {
        let mut mesh = Mesh::new(
            PrimitiveTopology::TriangleList,
            RenderAssetUsages::MAIN_WORLD,
        );
        mesh.insert_attribute(
            Mesh::ATTRIBUTE_POSITION,
            vertices.iter().map(|v| v.to_array()).collect::<Vec<_>>(),
        );
        mesh.insert_indices(Indices::U32(indices.into_iter().flatten().collect()));
        ColliderShape::TriangleMesh(meshes.add(mesh))
    };
    let v = |p: avian3d::parry::math::Vector| Vec3::new(p.x, p.y, p.z);
    let closed = |(vertices, indices): (Vec<avian3d::parry::math::Vector>, Vec<[u32; 3]>),
                  meshes: &mut Assets<Mesh>| {
        let vertices: Vec<Vec3> = vertices.into_iter().map(v).collect();
        let indices = wound_outward(&vertices, indices);
        triangles(vertices, indices, meshes)
    };
    const SEGMENTS: u32 = 24;
    Ok(match collider.shape().as_typed_shape() {
        TypedShape::Ball(ball) => ColliderShape::Sphere {
            radius: ball.radius,
        },
        TypedShape::Capsule(capsule) => {
            let (a, b) = (v(capsule.segment.a), v(capsule.segment.b));
            let on_y = a.x.abs() + a.z.abs() + b.x.abs() + b.z.abs() < 1e-6;
            if on_y && (a + b).length() < 1e-6 {
                ColliderShape::Capsule {
                    radius: capsule.radius,
                    half_length: a.y.abs(),
                }
            } else {
                closed(capsule.to_trimesh(SEGMENTS, SEGMENTS / 2), meshes)
            }
        }
        TypedShape::HalfSpace(half) if v(half.normal).abs_diff_eq(Vec3::Y, 1e-6) => {
            ColliderShape::Plane
        }
        TypedShape::Cuboid(cuboid) => closed(cuboid.to_trimesh(), meshes),
        TypedShape::Cylinder(cylinder) => closed(cylinder.to_trimesh(SEGMENTS), meshes),
        TypedShape::Cone(cone) => closed(cone.to_trimesh(SEGMENTS), meshes),
        TypedShape::ConvexPolyhedron(hull) => closed(hull.to_trimesh(), meshes),
        TypedShape::TriMesh(mesh) => triangles(
            mesh.vertices().iter().copied().map(v).collect(),
            mesh.indices().to_vec(),
            meshes,
        ),
        other => return Err(shape_name(&other).to_string()),
    })
}

/// The kind of an Avian shape, for the unsupported-shape warning.
fn shape_name(shape: &TypedShape) -> &'static str {
    match shape {
        TypedShape::Segment(_) => "segment",
        TypedShape::Triangle(_) => "triangle",
        TypedShape::Voxels(_) => "voxels",
        TypedShape::Polyline(_) => "polyline",
        TypedShape::HalfSpace(_) => "half-space not facing up",
        TypedShape::HeightField(_) => "height field",
        TypedShape::Compound(_) => "compound",
        TypedShape::RoundCuboid(_)
        | TypedShape::RoundTriangle(_)
        | TypedShape::RoundCylinder(_)
        | TypedShape::RoundCone(_)
        | TypedShape::RoundConvexPolyhedron(_) => "rounded shape",
        TypedShape::Custom(_) => "custom shape",
        _ => "shape",
    }
}

/// The triangles of a closed mesh, turned over if they were wound inward (a negative
/// enclosed volume), so that their fronts face out.
fn wound_outward(vertices: &[Vec3], mut indices: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
    let volume: f32 = indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            a.dot(b.cross(c))
        })
        .sum();
    if volume < 0.0 {
        for t in &mut indices {
            t.swap(1, 2);
        }
    }
    indices
}

/// Gives every Avian collider that changed its cloth collider, and takes it from those that
/// lost theirs or opted out.
#[allow(clippy::type_complexity)]
fn adopt_avian_colliders(
    mut commands: Commands,
    changed: Query<
        (Entity, &Collider, Has<ClothCollider>, Has<FromAvian>),
        (Changed<Collider>, Without<NoClothCollision>),
    >,
    opted_out: Query<Entity, (With<FromAvian>, Added<NoClothCollision>)>,
    mut removed: RemovedComponents<Collider>,
    adopted: Query<(), With<FromAvian>>,
    mut meshes: ResMut<Assets<Mesh>>,
) {
    for (entity, collider, has_own, from_avian) in &changed {
        if has_own && !from_avian {
            continue;
        }
        match cloth_shape(collider, &mut meshes) {
            Ok(shape) => {
                commands.entity(entity).insert((
                    ClothCollider {
                        shape,
                        ..ClothCollider::sphere(1.0)
                    },
                    FromAvian,
                    AnimatedVelocity::default(),
                ));
            }
            Err(kind) => {
                warn!("entity {entity}: its Avian collider (a {kind}) cannot be a cloth collider");
                if from_avian {
                    commands
                        .entity(entity)
                        .remove::<(ClothCollider, FromAvian)>();
                }
            }
        }
    }
    for entity in opted_out.iter().chain(removed.read()) {
        if adopted.contains(entity) {
            commands
                .entity(entity)
                .remove::<(ClothCollider, FromAvian)>();
        }
    }
}

/// Avian's velocities and material onto the cloth colliders made from its colliders.
#[allow(clippy::type_complexity)]
fn follow_avian_bodies(
    mut colliders: Query<
        (
            &mut ClothCollider,
            &mut AnimatedVelocity,
            Option<&LinearVelocity>,
            Option<&AngularVelocity>,
            Option<&Friction>,
            Option<&Restitution>,
        ),
        With<FromAvian>,
    >,
) {
    for (mut collider, mut velocity, linear, angular, friction, restitution) in &mut colliders {
        let linear = linear.map_or(Vec3::ZERO, |v| Vec3::new(v.0.x, v.0.y, v.0.z));
        let angular = angular.map_or(Vec3::ZERO, |v| Vec3::new(v.0.x, v.0.y, v.0.z));
        if linear.is_finite() && angular.is_finite() {
            velocity.set_if_neq(AnimatedVelocity { linear, angular });
        }
        let material = collider.material;
        let friction = friction.map_or(material.friction, |f| f.dynamic_coefficient);
        let restitution = restitution.map_or(material.restitution, |r| r.coefficient);
        if (friction, restitution) != (material.friction, material.restitution) {
            collider.material.friction = friction;
            collider.material.restitution = restitution;
        }
    }
}
