//! Writing every cloth into its mesh once per rendered frame, interpolated between fixed
//! steps.

use bevy::asset::Assets;
use bevy::log::warn;
use bevy::mesh::{Mesh, Mesh3d, VertexAttributeValues};
use bevy::prelude::*;

use super::components::{Cloth, ClothDebugColors, ClothSimulation};
use crate::cloth::debug_colors::{ClothPaint, DebugColorMode, GREY, PaintTarget, debug_colors};
use crate::cloth::mesh::{vertex_normals, write_colors, write_normals};
use crate::collide::skin::drawn_poses;
use crate::schedule::{DrapeTimings, world_pose};

/// Writes every cloth into its mesh, interpolated between the last two fixed steps: in the
/// world, or, for a cloth that follows an entity, in that entity's frame (so the cloth is
/// drawn on the entity wherever the entity is drawn, interpolated or not).
#[allow(clippy::type_complexity)]
pub(super) fn write_back_meshes(
    mut cloths: Query<(
        Entity,
        &mut ClothSimulation,
        &Cloth,
        &Mesh3d,
        &GlobalTransform,
        Option<&ClothPaint>,
    )>,
    followed: Query<&GlobalTransform>,
    mut meshes: ResMut<Assets<Mesh>>,
    fixed: Res<Time<Fixed>>,
    debug: Res<ClothDebugColors>,
    timings: Option<ResMut<DrapeTimings>>,
) {
    let start = std::time::Instant::now();
    let alpha = fixed.overstep_fraction().clamp(0.0, 1.0);
    for (entity, mut simulation, cloth, mesh3d, global, paint) in &mut cloths {
        let simulation = &mut *simulation;
        // A sleeping cloth drawn from the same poses as last time is drawn already.
        let drawn_from = (
            *global,
            cloth
                .follow
                .and_then(|e| followed.get(e).ok())
                .and_then(world_pose),
            mesh3d.0.id(),
        );
        let asleep = simulation.sleep.is_asleep() && debug.0 == DebugColorMode::Off;
        if asleep && simulation.drawn_asleep == Some(drawn_from) {
            continue;
        }
        // Set again once the mesh is written.
        simulation.drawn_asleep = None;
        let Some(mut mesh) = meshes.get_mut(&mesh3d.0) else {
            continue;
        };
        // Debug colours first: per-triangle colours draw the mesh with a vertex per corner.
        let (target, mismatch) =
            debug_colors(&simulation.sim, debug.0, paint, &mut simulation.colors);
        match mismatch {
            Some(m) if !simulation.warned_paint => {
                warn!(
                    "cloth {entity}: its ClothPaint has {} entries for {} {} (shown grey)",
                    m.found,
                    m.expected,
                    match m.target {
                        PaintTarget::Particles => "particles",
                        PaintTarget::Triangles => "triangles",
                    }
                );
                simulation.warned_paint = true;
            }
            Some(_) => {}
            None => simulation.warned_paint = false,
        }
        let per_triangle = !simulation.colors.is_empty() && target == PaintTarget::Triangles;
        let to_local = global.affine().inverse();
        // The followed entity's poses at the last two fixed steps and as drawn now.
        let frame = simulation.followed.zip(drawn_from.1);
        // Drawn at the cloth's last positions (a sleeping cloth's `render_from` is those).
        let alpha = if asleep { 1.0 } else { alpha };
        let current = &simulation.sim.state().positions;
        if current.len() != simulation.render_from.len() {
            continue;
        }
        // Interpolated particle positions in the world, then the colliders as drawn near
        // them, which every drawn point is kept outside (`collide/skin.rs`): the particles
        // here, a finer render mesh's vertices as it is written.
        simulation.drawn_world.clear();
        simulation
            .drawn_world
            .extend(
                simulation
                    .render_from
                    .iter()
                    .zip(current)
                    .map(|(&from, &to)| match &frame {
                        Some((step, drawn)) => drawn.transform_point(
                            step.start
                                .inverse_transform_point(from)
                                .lerp(step.end.inverse_transform_point(to), alpha),
                        ),
                        None => from.lerp(to, alpha),
                    }),
            );
        let colliders = simulation.sim.colliders();
        drawn_poses(
            colliders,
            alpha,
            frame.as_ref().map(|(step, drawn)| (step, drawn)),
            &mut simulation.drawn_poses,
        );
        simulation.skin.prepare(
            colliders,
            &simulation.drawn_poses,
            simulation.sim.contact_thickness(),
            &simulation.drawn_world,
        );
        let skin = &simulation.skin;
        simulation.local_positions.clear();
        simulation
            .local_positions
            .extend(simulation.drawn_world.iter().map(|&world| {
                to_local
                    .transform_point3a(skin.push_out(colliders, world))
                    .to_array()
            }));
        let triangles = &simulation.sim.model().triangles;
        vertex_normals(
            &simulation.local_positions,
            triangles,
            &mut simulation.normals,
        );
        if let Some(render) = simulation.render.as_mut() {
            // A finer mesh drawn over the simulated one.
            let colors =
                (!simulation.colors.is_empty()).then_some((&simulation.colors[..], target));
            let to_world = global.affine();
            render.write(
                &mut mesh,
                &simulation.local_positions,
                &simulation.normals,
                triangles,
                colors,
                &mut simulation.vertex_colors,
                |p| {
                    let world = skin.push_out(colliders, to_world.transform_point3a(p.into()));
                    to_local.transform_point3a(world).into()
                },
            );
            let colors = if colors.is_some() {
                &simulation.vertex_colors
            } else {
                &simulation.base_colors
            };
            write_colors(&mut mesh, colors);
            simulation.drawn_asleep = asleep.then_some(drawn_from);
            continue;
        }
        simulation.flat.set(
            &mut mesh,
            per_triangle,
            &simulation.vertex_to_particle,
            triangles,
        );
        let map = simulation
            .flat
            .corner_to_particle()
            .unwrap_or(&simulation.vertex_to_particle);
        let Ok(Some(VertexAttributeValues::Float32x3(positions))) =
            mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_POSITION)
        else {
            continue;
        };
        if positions.len() != map.len() || map.iter().any(|&p| p as usize >= current.len()) {
            continue;
        }
        for (out, &p) in positions.iter_mut().zip(map) {
            let at = simulation.local_positions[p as usize];
            if at.iter().all(|c| c.is_finite()) {
                *out = at;
            }
        }
        // Normals per particle (smooth across welded seams), then per vertex.
        let normals = map
            .iter()
            .map(|&p| simulation.normals[p as usize].to_array());
        write_normals(&mut mesh, normals);
        let colors = if simulation.colors.is_empty() {
            &simulation.base_colors
        } else {
            simulation.vertex_colors.clear();
            if per_triangle {
                let flat = &simulation.flat;
                let colors = &simulation.colors;
                simulation
                    .vertex_colors
                    .extend((0..map.len()).map(|corner| {
                        flat.model_triangle(corner)
                            .and_then(|t| colors.get(t))
                            .copied()
                            .unwrap_or(GREY)
                    }));
            } else {
                simulation
                    .vertex_colors
                    .extend(map.iter().map(|&p| simulation.colors[p as usize]));
            }
            &simulation.vertex_colors
        };
        write_colors(&mut mesh, colors);
        simulation.drawn_asleep = asleep.then_some(drawn_from);
    }
    if let Some(mut timings) = timings {
        timings.write_back = start.elapsed();
    }
}
