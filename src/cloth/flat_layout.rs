//! A cloth's mesh drawn with one vertex per triangle corner, for per-triangle debug colours:
//! a vertex shared by several triangles can only have one colour, so while a per-triangle
//! mode is on the mesh's vertices are duplicated (`Mesh::duplicate_vertices`) and every corner
//! follows its particle; when the mode goes off the shared mesh comes back.

use bevy::mesh::Mesh;

/// No model triangle (a degenerate mesh triangle the cloth left out).
const NONE: u32 = u32::MAX;

/// Whether a cloth's mesh is drawn flat, and how its corners map onto the cloth.
#[derive(Clone, Debug, Default)]
pub(crate) struct FlatLayout {
    /// The mesh as it was (shared vertices), while it is drawn flat.
    shared: Option<Mesh>,
    /// The particle of every corner.
    corner_to_particle: Vec<u32>,
    /// The model triangle of every mesh triangle (`NONE` for one the cloth left out).
    mesh_to_model_triangle: Vec<u32>,
}

impl FlatLayout {
    /// The particle of every vertex while the mesh is flat (one vertex per corner).
    pub(crate) fn corner_to_particle(&self) -> Option<&[u32]> {
        self.shared
            .is_some()
            .then_some(self.corner_to_particle.as_slice())
    }

    /// The model triangle of the triangle of `corner`, while the mesh is flat.
    pub(crate) fn model_triangle(&self, corner: usize) -> Option<usize> {
        match self.mesh_to_model_triangle.get(corner / 3) {
            Some(&t) if t != NONE => Some(t as usize),
            _ => None,
        }
    }

    /// Makes `mesh` flat or shared. `vertex_to_particle` maps the shared mesh's vertices onto
    /// particles and `model_triangles` are the cloth's triangles (the mesh's, in order, less
    /// the degenerate ones). A mesh without indices is left as it is.
    pub(crate) fn set(
        &mut self,
        mesh: &mut Mesh,
        flat: bool,
        vertex_to_particle: &[u32],
        model_triangles: &[[u32; 3]],
    ) {
        match (flat, self.shared.take()) {
            (true, Some(shared)) => self.shared = Some(shared),
            (true, None) => {
                let Some(indices) = mesh.indices() else {
                    return;
                };
                self.corner_to_particle.clear();
                self.corner_to_particle.extend(
                    indices
                        .iter()
                        .map(|v| vertex_to_particle.get(v).copied().unwrap_or(0)),
                );
                // The cloth kept the mesh's triangles in order, leaving degenerate ones out.
                self.mesh_to_model_triangle.clear();
                let mut next = 0;
                for corners in self.corner_to_particle.chunks_exact(3) {
                    if model_triangles
                        .get(next)
                        .is_some_and(|t| t[..] == corners[..])
                    {
                        self.mesh_to_model_triangle.push(next as u32);
                        next += 1;
                    } else {
                        self.mesh_to_model_triangle.push(NONE);
                    }
                }
                self.shared = Some(mesh.clone());
                mesh.duplicate_vertices();
            }
            (false, Some(shared)) => *mesh = shared,
            (false, None) => {}
        }
    }
}
