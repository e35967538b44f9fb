//! Drawing a cloth with a finer mesh than it is simulated on: the [`ClothSimulationMesh`]
//! component, and the render mesh written from the simulated surface through an
//! [`Embedding`] every frame.

use bevy::asset::Handle;
use bevy::math::Vec3;
use bevy::mesh::{Mesh, VertexAttributeValues};
use bevy::prelude::{Component, ReflectComponent};
use bevy::reflect::Reflect;

use super::debug_colors::{GREY, PaintTarget};
use super::embedding::Embedding;
use super::mesh::{vertex_normals, write_normals};
use crate::error::ClothError;
use crate::mesh::mesh_triangles;
use crate::weld::{default_tolerance, weld};

/// Simulates a [`Cloth`](super::plugin::Cloth) on this mesh while the entity's own `Mesh3d`,
/// finer, is what is drawn: each drawn vertex follows the simulated triangle it lies on at
/// rest, over a smooth (curved PN) surface, so a coarse simulation is drawn smooth. Both
/// meshes are in the entity's frame and should cover the same cloth at rest; pinned and
/// attached vertices ([`Cloth::pinned_vertices`](super::plugin::Cloth)) are vertices of
/// this mesh. Colliders, self-collision and strain are those of the simulated mesh.
///
/// ```no_run
/// # use bevy::prelude::*;
/// # use bevy_drape::prelude::*;
/// fn spawn(mut commands: Commands, server: Res<AssetServer>) {
///     commands.spawn((
///         Mesh3d(server.load("meshes/poncho.obj")),
///         ClothSimulationMesh(server.load("meshes/poncho_coarse.obj")),
///         Cloth::default(),
///     ));
/// }
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothSimulationMesh(pub Handle<Mesh>);

/// A render mesh embedded in the simulated one, and the scratch its write-back uses.
#[derive(Clone, Debug)]
pub(crate) struct EmbeddedRender {
    embedding: Embedding,
    /// The render mesh's triangles over its welded points (seams joined, so its normals are
    /// smooth across them).
    triangles: Vec<[u32; 3]>,
    /// The welded point of every render vertex.
    vertex_to_point: Vec<u32>,
    points: Vec<Vec3>,
    normals: Vec<Vec3>,
}

impl EmbeddedRender {
    /// Embeds `render` in the simulated mesh: its particles' rest positions in the entity's
    /// frame, `particles_local`, and the model's triangles over them.
    pub(crate) fn new(
        render: &Mesh,
        particles_local: &[Vec3],
        triangles: &[[u32; 3]],
    ) -> Result<Self, ClothError> {
        let (positions, indices) = mesh_triangles(render)?;
        let welded = weld(&positions, &indices, default_tolerance(&positions));
        let embedding = Embedding::new(particles_local, triangles, &welded.positions)?;
        Ok(Self {
            embedding,
            triangles: welded
                .indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
            vertex_to_point: welded.vertex_to_particle,
            points: Vec::new(),
            normals: Vec::new(),
        })
    }

    /// How many vertices the render mesh has.
    pub(crate) fn vertex_count(&self) -> usize {
        self.vertex_to_point.len()
    }

    /// Writes positions and normals into `mesh` from the simulated particles' positions in
    /// the entity's frame and their normals, over the model's `triangles`, every render
    /// vertex passed through `push_out` (kept outside the colliders, `collide/skin.rs`);
    /// `colors` (per particle or per simulated triangle) become per render vertex in
    /// `vertex_colors`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn write(
        &mut self,
        mesh: &mut Mesh,
        particles: &[[f32; 3]],
        particle_normals: &[Vec3],
        triangles: &[[u32; 3]],
        colors: Option<(&[[f32; 4]], PaintTarget)>,
        vertex_colors: &mut Vec<[f32; 4]>,
        push_out: impl Fn(Vec3) -> Vec3,
    ) {
        self.embedding
            .place(particles, particle_normals, triangles, &mut self.points);
        for p in &mut self.points {
            *p = push_out(*p);
        }
        vertex_normals(&self.points, &self.triangles, &mut self.normals);
        let map = &self.vertex_to_point;
        if let Ok(Some(VertexAttributeValues::Float32x3(out))) =
            mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_POSITION)
            && out.len() == map.len()
        {
            for (out, &p) in out.iter_mut().zip(map) {
                *out = self.points[p as usize].to_array();
            }
        }
        let normals = map.iter().map(|&p| self.normals[p as usize].to_array());
        write_normals(mesh, normals);
        vertex_colors.clear();
        let Some((colors, target)) = colors else {
            return;
        };
        let embedded = self.embedding.vertices();
        vertex_colors.extend(map.iter().map(|&p| {
            let Some(vertex) = embedded.get(p as usize) else {
                return GREY;
            };
            match target {
                PaintTarget::Triangles => colors
                    .get(vertex.triangle as usize)
                    .copied()
                    .unwrap_or(GREY),
                PaintTarget::Particles => {
                    let Some(corners) = triangles.get(vertex.triangle as usize) else {
                        return GREY;
                    };
                    let mut blended = [0.0; 4];
                    for (&c, &w) in corners.iter().zip(&vertex.weights) {
                        let color = colors.get(c as usize).copied().unwrap_or(GREY);
                        for k in 0..4 {
                            blended[k] += w * color[k];
                        }
                    }
                    blended
                }
            }
        }));
    }
}
