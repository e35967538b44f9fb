//! Mouse dragging of cloth (with the `render` feature): press the left button on a cloth to
//! grab the particle nearest the cursor's ray, move the mouse to drag it in the plane through
//! the grab point facing the camera, release to let go.

use bevy::camera::Camera;
use bevy::math::Vec3;
use bevy::prelude::*;
use bevy::window::PrimaryWindow;

use super::pick::{drag_point, pick_particle};
use crate::cloth::plugin::ClothSimulation;

/// The drag in progress, if any (read it to keep camera controls still while dragging).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct ClothDrag {
    /// The cloth and particle held, and the point the drag plane goes through.
    pub held: Option<(Entity, u32, Vec3)>,
    /// The pointer is over a user interface that takes it (set by the `egui` panel): no new
    /// drag starts.
    pub pointer_over_ui: bool,
}

impl ClothDrag {
    /// Whether a particle is held.
    pub fn is_active(&self) -> bool {
        self.held.is_some()
    }
}

/// Adds mouse dragging of every cloth, seen through the first camera that renders to the
/// primary window.
pub struct ClothDragPlugin;

impl Plugin for ClothDragPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<ClothDrag>()
            .add_systems(Update, drag_cloth);
    }
}

/// How far from the cursor's ray a particle can be picked, as a fraction of its distance from
/// the camera.
const PICK_FRACTION: f32 = 0.02;

fn drag_cloth(
    buttons: Res<ButtonInput<MouseButton>>,
    windows: Query<&Window, With<PrimaryWindow>>,
    cameras: Query<(&Camera, &GlobalTransform)>,
    mut cloths: Query<(Entity, &mut ClothSimulation)>,
    mut drag: ResMut<ClothDrag>,
) {
    let Some((camera, camera_transform)) = cameras.iter().find(|(c, _)| c.is_active) else {
        return;
    };
    let ray = windows
        .single()
        .ok()
        .and_then(|w| w.cursor_position())
        .and_then(|cursor| camera.viewport_to_world(camera_transform, cursor).ok());
    if buttons.just_released(MouseButton::Left) {
        if let Some((entity, _, _)) = drag.held.take()
            && let Ok((_, mut simulation)) = cloths.get_mut(entity)
        {
            simulation.solver_mut().release();
        }
        return;
    }
    let Some(ray) = ray else {
        return;
    };
    if buttons.just_pressed(MouseButton::Left) && !drag.pointer_over_ui {
        // The nearest hit over every cloth, with a pick radius growing with distance.
        let mut best: Option<(Entity, u32, f32)> = None;
        for (entity, simulation) in &cloths {
            let positions = &simulation.solver().state().positions;
            let far = positions
                .iter()
                .map(|p| Vec3::from(*p).distance(ray.origin))
                .fold(0.0, f32::max);
            if let Some(hit) =
                pick_particle(positions, ray.origin, *ray.direction, PICK_FRACTION * far)
                && best.is_none_or(|(_, _, depth)| hit.depth < depth)
            {
                best = Some((entity, hit.particle, hit.depth));
            }
        }
        if let Some((entity, particle, _)) = best
            && let Ok((_, mut simulation)) = cloths.get_mut(entity)
            && simulation.solver_mut().grab(particle)
        {
            let at = Vec3::from(simulation.solver().state().positions[particle as usize]);
            drag.held = Some((entity, particle, at));
        }
    }
    if let Some((entity, _, anchor)) = drag.held {
        let view = *camera_transform.forward();
        if let Some(point) = drag_point(ray.origin, *ray.direction, anchor, view)
            && let Ok((_, mut simulation)) = cloths.get_mut(entity)
        {
            simulation.solver_mut().drag_to(point);
        }
    }
}
