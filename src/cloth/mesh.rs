//! Between Bevy's [`Mesh`] asset and the cloth core: building the grid (or a garment pattern)
//! as a mesh, and the normals written back into it (reading triangles out of any mesh is
//! [`crate::mesh::mesh_triangles`]).

use bevy::asset::RenderAssetUsages;
use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology};

use super::model::{GridDesc, GridMesh};

/// The grid of `desc` as a mesh with positions, normals, texture coordinates and indices,
/// kept in the main world so the cloth can write into it.
pub fn grid_mesh(desc: &GridDesc) -> Mesh {
    let grid = desc.mesh();
    let normal = (desc.orientation * Vec3::Y).to_array();
    let positions: Vec<[f32; 3]> = grid.positions.iter().map(|p| p.to_array()).collect();
    let normals = vec![normal; positions.len()];
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, grid.uvs)
    .with_inserted_indices(Indices::U32(grid.indices))
}

/// A [`GridMesh`] (a grid or a garment pattern) as a mesh with positions, normals, texture
/// coordinates and indices, kept in the main world so the cloth can write into it.
pub fn grid_mesh_from(grid: &GridMesh) -> Mesh {
    let positions: Vec<[f32; 3]> = grid.positions.iter().map(|p| p.to_array()).collect();
    let triangles: Vec<[u32; 3]> = grid
        .indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let mut normals = Vec::new();
    compute_normals(&positions, &triangles, &mut normals);
    let normals: Vec<[f32; 3]> = normals.iter().map(|n| n.to_array()).collect();
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, grid.uvs.clone())
    .with_inserted_indices(Indices::U32(grid.indices.clone()))
}

/// Area-weighted vertex normals of `triangles` over `positions`, written into `normals`
/// (resized to match). Vertices in no triangle get +Y.
pub(crate) fn compute_normals(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    normals: &mut Vec<Vec3>,
) {
    normals.clear();
    normals.resize(positions.len(), Vec3::ZERO);
    for &[a, b, c] in triangles {
        let pa = Vec3::from_array(positions[a as usize]);
        let pb = Vec3::from_array(positions[b as usize]);
        let pc = Vec3::from_array(positions[c as usize]);
        let n = (pb - pa).cross(pc - pa);
        normals[a as usize] += n;
        normals[b as usize] += n;
        normals[c as usize] += n;
    }
    for n in normals.iter_mut() {
        *n = n.normalize_or(Vec3::Y);
    }
}
