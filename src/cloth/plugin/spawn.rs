//! Building a cloth's simulation from its mesh, the first fixed step after the mesh loads.

use bevy::asset::{AssetServer, Assets, LoadState};
use bevy::ecs::query::QueryData;
use bevy::log::{error, warn};
use bevy::math::Vec3;
use bevy::mesh::{Mesh, Mesh3d, VertexAttributeValues};
use bevy::prelude::*;
use bevy::transform::helper::TransformHelper;

use super::components::{
    Cloth, ClothBuildError, ClothSettings, ClothSimulation, DefaultClothSettings,
};
use crate::cloth::flat_layout::FlatLayout;
use crate::cloth::model::ClothModel;
use crate::cloth::render_mesh::{ClothSimulationMesh, EmbeddedRender};
use crate::cloth::sim::ClothSolver;
use crate::collide::FrameTracker;
use crate::collide::skin::DrawnColliders;
use crate::error::ClothError;
use crate::mesh::mesh_triangles;
use crate::schedule::world_pose;
use crate::weld::{default_tolerance, weld};

/// Builds the simulation of `mesh`, drawn with `render` if that is another mesh.
fn build_simulation(
    mesh: &Mesh,
    render: Option<&Mesh>,
    cloth: &Cloth,
    global: &GlobalTransform,
    density: f32,
) -> Result<(ClothSimulation, Vec<String>), ClothError> {
    let (local, indices) = mesh_triangles(mesh)?;
    // Vertices split at seams (texture coordinates, normals) become one particle.
    let welded = weld(&local, &indices, default_tolerance(&local));
    let world: Vec<Vec3> = welded
        .positions
        .iter()
        .map(|&p| global.transform_point(p))
        .collect();
    let model = ClothModel::from_triangles(&world, &welded.indices, density)?;
    let warnings: Vec<String> = model.warnings.iter().map(ToString::to_string).collect();
    if welded.merged_any() {
        debug!(
            "{} mesh vertices welded into {} particles",
            local.len(),
            welded.positions.len()
        );
    }
    let mut sim = ClothSolver::new(model);
    let mut pinned = Vec::new();
    for &v in cloth
        .pinned_vertices
        .iter()
        .chain(cloth.attachments.iter().map(|a| &a.vertex))
    {
        match welded.vertex_to_particle.get(v as usize) {
            Some(&p) => pinned.push(p),
            None => {
                return Err(ClothError::VertexOutOfRange {
                    vertex: v,
                    vertex_count: local.len(),
                });
            }
        }
    }
    sim.set_pins(&pinned)?;
    let render = render
        .map(|render| EmbeddedRender::new(render, &welded.positions, &sim.model().triangles))
        .transpose()?;
    let render_from = sim.state().positions.clone();
    Ok((
        ClothSimulation {
            sim,
            local_rest: local,
            vertex_to_particle: welded.vertex_to_particle,
            render_from,
            normals: Vec::new(),
            colors: Vec::new(),
            vertex_colors: Vec::new(),
            local_positions: Vec::new(),
            drawn_world: Vec::new(),
            drawn_poses: Vec::new(),
            skin: DrawnColliders::default(),
            base_colors: Vec::new(),
            flat: FlatLayout::default(),
            warned_paint: false,
            colliders: Vec::new(),
            warned_invalid_settings: false,
            warned_step_input: false,
            warned_volume: false,
            frozen_with: None,
            follow: FrameTracker::default(),
            followed: None,
            built_in_frame: None,
            warned_follow: false,
            render,
            sleep: Default::default(),
            slept_with: None,
            warned_sleep: false,
            drawn_asleep: None,
            lod_level: 0,
            lod_frozen: false,
            lod_hidden: false,
            hidden_from: None,
        },
        warnings,
    ))
}

/// A cloth not built yet (with the filter `Without<ClothSimulation>, Without<ClothBuildError>`).
#[derive(QueryData)]
pub(super) struct NewCloth {
    entity: Entity,
    cloth: &'static Cloth,
    mesh: &'static Mesh3d,
    simulated: Option<&'static ClothSimulationMesh>,
    settings: Option<&'static ClothSettings>,
}

/// Builds the simulation of every new cloth whose mesh is loaded.
pub(super) fn build_cloths(
    mut commands: Commands,
    new_cloths: Query<NewCloth, (Without<ClothSimulation>, Without<ClothBuildError>)>,
    mut meshes: ResMut<Assets<Mesh>>,
    defaults: Res<DefaultClothSettings>,
    transforms: TransformHelper,
    asset_server: Option<Res<AssetServer>>,
) {
    for item in &new_cloths {
        let (entity, cloth, mesh3d, settings) = (item.entity, item.cloth, item.mesh, item.settings);
        // The mesh simulated, and the one drawn if that is another.
        let handles = match item.simulated {
            Some(simulated) => [&simulated.0, &mesh3d.0],
            None => [&mesh3d.0, &mesh3d.0],
        };
        let (Some(mesh), Some(drawn)) = (meshes.get(handles[0]), meshes.get(handles[1])) else {
            // A file that will never load: say which, once.
            if let Some(server) = &asset_server
                && let Some((handle, err)) =
                    handles.iter().find_map(|h| match server.load_state(*h) {
                        LoadState::Failed(err) => Some((h, err)),
                        _ => None,
                    })
            {
                let path = server
                    .get_path(*handle)
                    .map_or_else(|| "(no path)".to_string(), |p| p.to_string());
                let error = ClothError::MeshLoadFailed {
                    path,
                    reason: err.to_string(),
                };
                error!("cloth {entity} cannot be built: {error}");
                commands.entity(entity).insert(ClothBuildError(error));
            }
            continue;
        };
        let render = item.simulated.is_some().then_some(drawn);
        let density = settings.unwrap_or(&defaults.0).density;
        let global = transforms
            .compute_global_transform(entity)
            .unwrap_or_default();
        match build_simulation(mesh, render, cloth, &global, density) {
            Ok((mut simulation, warnings)) => {
                simulation.built_in_frame = cloth
                    .follow
                    .and_then(|e| transforms.compute_global_transform(e).ok())
                    .and_then(|g| world_pose(&g));
                for warning in warnings {
                    warn!("cloth {entity}: {warning}");
                }
                // The cloth writes into its mesh, so it gets a copy of its own, with vertex
                // colours from the start (the mesh's own, or white): debug colours then only
                // change values, never the vertex layout the renderer was prepared for.
                let mut own_mesh = drawn.clone();
                let vertices = simulation.render.as_ref().map_or(
                    simulation.vertex_to_particle.len(),
                    EmbeddedRender::vertex_count,
                );
                simulation.base_colors = match own_mesh.attribute(Mesh::ATTRIBUTE_COLOR) {
                    Some(VertexAttributeValues::Float32x4(c)) if c.len() == vertices => c.clone(),
                    _ => vec![[1.0; 4]; vertices],
                };
                own_mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, simulation.base_colors.clone());
                let own_mesh = meshes.add(own_mesh);
                commands
                    .entity(entity)
                    .insert((simulation, Mesh3d(own_mesh)));
            }
            Err(err) => {
                error!("cloth {entity} cannot be simulated: {err}");
                commands.entity(entity).insert(ClothBuildError(err));
            }
        }
    }
}
