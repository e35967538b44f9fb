//! Between Bevy's [`Mesh`] asset and the cloth core: building the grid (or a garment pattern)
//! as a mesh, and the normals written back into it (reading triangles out of any mesh is
//! [`crate::mesh::mesh_triangles`]).

use bevy::asset::RenderAssetUsages;
use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};

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
    vertex_normals(&positions, &triangles, &mut normals);
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

/// Area-weighted unit vertex normals of `triangles` over `positions`, written into `normals`
/// (resized to match). A vertex in no triangle (or only degenerate ones) gets +Y.
pub fn vertex_normals<P: Copy + Into<Vec3>>(
    positions: &[P],
    triangles: &[[u32; 3]],
    normals: &mut Vec<Vec3>,
) {
    normals.clear();
    normals.resize(positions.len(), Vec3::ZERO);
    for &[a, b, c] in triangles {
        let [pa, pb, pc]: [Vec3; 3] = [a, b, c].map(|i| positions[i as usize].into());
        let n = (pb - pa).cross(pc - pa);
        normals[a as usize] += n;
        normals[b as usize] += n;
        normals[c as usize] += n;
    }
    for n in normals.iter_mut() {
        *n = n.normalize_or(Vec3::Y);
    }
}

/// Writes per-vertex normals into `mesh`: in place where it has a normal of each, otherwise
/// as a new attribute.
pub(crate) fn write_normals(mesh: &mut Mesh, normals: impl ExactSizeIterator<Item = [f32; 3]>) {
    match mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_NORMAL) {
        Ok(Some(VertexAttributeValues::Float32x3(out))) if out.len() == normals.len() => {
            for (out, n) in out.iter_mut().zip(normals) {
                *out = n;
            }
        }
        _ => {
            let normals: Vec<[f32; 3]> = normals.collect();
            mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
        }
    }
}

/// Writes vertex colours into `mesh` if they changed and fit its vertex count.
pub(crate) fn write_colors(mesh: &mut Mesh, colors: &[[f32; 4]]) {
    if let Ok(Some(VertexAttributeValues::Float32x4(out))) =
        mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_COLOR)
        && out.len() == colors.len()
        && out.as_slice() != colors
    {
        out.copy_from_slice(colors);
    }
}
