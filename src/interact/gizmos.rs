//! Collider gizmos (feature `render`): every [`ClothCollider`] drawn as lines, on while
//! [`ColliderGizmos::enabled`].

use bevy::prelude::*;
use bevy::transform::TransformSystems;

use crate::collide::plugin::{ClothCollider, ColliderShape};

/// Whether collider gizmos are drawn. Default: off.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ColliderGizmos {
    /// Draw them.
    pub enabled: bool,
}

/// Draws every collider's shape with gizmos while [`ColliderGizmos::enabled`].
pub struct ColliderGizmoPlugin;

impl Plugin for ColliderGizmoPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ColliderGizmos>().add_systems(
            PostUpdate,
            draw_colliders.after(TransformSystems::Propagate),
        );
    }
}

fn draw_colliders(
    settings: Res<ColliderGizmos>,
    colliders: Query<(&ClothCollider, &GlobalTransform)>,
    mut gizmos: Gizmos,
) {
    if !settings.enabled {
        return;
    }
    let colour = Color::srgb(0.1, 0.9, 0.4);
    for (collider, global) in &colliders {
        let (_, rotation, translation) = global.to_scale_rotation_translation();
        let at = Isometry3d::new(translation, rotation);
        match &collider.shape {
            ColliderShape::Sphere { radius } => {
                gizmos.sphere(at, *radius, colour);
            }
            ColliderShape::Capsule {
                radius,
                half_length,
            } => {
                gizmos.primitive_3d(&Capsule3d::new(*radius, 2.0 * half_length), at, colour);
            }
            ColliderShape::Plane => {
                // The surface is the local XZ plane: a 2 m square on it, and the normal.
                let flat = Isometry3d::new(
                    translation,
                    rotation * Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
                );
                gizmos.rect(flat, Vec2::splat(2.0), colour);
                gizmos.arrow(translation, translation + rotation * Vec3::Y * 0.3, colour);
            }
            ColliderShape::TriangleMesh(_) => {
                gizmos.cube(
                    Transform::from_translation(translation)
                        .with_rotation(rotation)
                        .with_scale(Vec3::splat(0.05)),
                    colour,
                );
            }
        }
    }
}
