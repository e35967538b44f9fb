//! Reading a Bevy [`Mesh`] asset as triangles, for cloths and triangle-mesh colliders alike.

use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};

use crate::error::MeshError;

/// The vertex positions and triangle indices of a triangle-list mesh.
pub fn mesh_triangles(mesh: &Mesh) -> Result<(Vec<Vec3>, Vec<u32>), MeshError> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(MeshError::NotTriangleList);
    }
    let positions = match mesh.try_attribute_option(Mesh::ATTRIBUTE_POSITION) {
        Err(_) => return Err(MeshError::MeshDataUnavailable),
        Ok(Some(VertexAttributeValues::Float32x3(p))) => {
            p.iter().map(|&p| Vec3::from_array(p)).collect::<Vec<_>>()
        }
        Ok(_) => return Err(MeshError::MissingPositions),
    };
    let indices = match mesh.try_indices_option() {
        Err(_) => return Err(MeshError::MeshDataUnavailable),
        Ok(Some(Indices::U16(i))) => i.iter().map(|&i| i as u32).collect(),
        Ok(Some(Indices::U32(i))) => i.clone(),
        // A non-indexed triangle list: every three vertices are a triangle.
        Ok(None) => (0..positions.len() as u32).collect(),
    };
    Ok((positions, indices))
}
