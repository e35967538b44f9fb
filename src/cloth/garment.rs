//! Garment patterns: the poncho (a square with a round neck hole in the middle) and a writer
//! for Wavefront OBJ, so a pattern can be saved into `assets/` and loaded like any model
//! (`cargo run --example generate_poncho` writes `assets/meshes/poncho.obj`).

use bevy::reflect::Reflect;
use std::fmt::Write;

use bevy::math::{Vec2, Vec3};

use super::model::{GridDesc, GridMesh};
use crate::error::ClothError;

/// A poncho: a `size` x `size` square of `vertices` x `vertices` grid vertices, flat in the XZ
/// plane facing +Y, centred on the origin, with the triangles that have a vertex within
/// `neck_radius` of the centre cut out. The vertices left on the hole's edge within half a
/// spacing of the circle are moved in onto it, so the hole is rounder than the grid's steps.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct PonchoDesc {
    /// Side of the square, metres. Default: `1.3`.
    pub size: f32,
    /// Grid vertices per side (odd puts a vertex at the centre). Default: `41`.
    pub vertices: u32,
    /// Radius of the neck hole, metres. Default: `0.1`.
    pub neck_radius: f32,
}

impl Default for PonchoDesc {
    fn default() -> Self {
        Self {
            size: 1.3,
            vertices: 41,
            neck_radius: 0.10,
        }
    }
}

impl PonchoDesc {
    /// The grid spacing, metres.
    pub(crate) fn spacing(&self) -> f32 {
        self.size / (self.vertices.max(2) - 1) as f32
    }

    /// The poncho's vertices, triangles and texture coordinates (no shear edges: the pattern
    /// is a general mesh once cut).
    pub fn mesh(&self) -> Result<GridMesh, ClothError> {
        let finite_positive = |v: f32| v.is_finite() && v > 0.0;
        if !(finite_positive(self.size) && self.neck_radius.is_finite() && self.neck_radius >= 0.0)
        {
            return Err(ClothError::InvalidPattern(format!(
                "size {} m and neck radius {} m must be finite and positive",
                self.size, self.neck_radius
            )));
        }
        if self.vertices < 3 || 2.0 * self.neck_radius >= self.size - 2.0 * self.spacing() {
            return Err(ClothError::InvalidPattern(format!(
                "a {} m poncho of {} vertices per side cannot have a neck hole of radius {} m",
                self.size, self.vertices, self.neck_radius
            )));
        }
        let half = self.size / 2.0;
        let grid = GridDesc::square(self.size, self.vertices, Vec3::new(-half, 0.0, -half)).mesh();
        // Cut away every triangle with a vertex inside the hole; the vertices left on its edge
        // within half a spacing of the circle are then moved onto it.
        let inside: Vec<bool> = grid
            .positions
            .iter()
            .map(|p| Vec2::new(p.x, p.z).length() < self.neck_radius)
            .collect();
        let mut kept = Vec::with_capacity(grid.indices.len());
        let mut on_hole = vec![false; grid.positions.len()];
        for tri in grid.indices.chunks_exact(3) {
            if tri.iter().any(|&v| inside[v as usize]) {
                for &v in tri {
                    on_hole[v as usize] = true;
                }
            } else {
                kept.extend_from_slice(tri);
            }
        }
        let snap_within = self.neck_radius + 0.5 * self.spacing();
        // Keep only vertices some triangle uses, in their grid order.
        let mut used = vec![false; grid.positions.len()];
        for &v in &kept {
            used[v as usize] = true;
        }
        let mut new_index = vec![u32::MAX; grid.positions.len()];
        let mut positions = Vec::new();
        let mut uvs = Vec::new();
        for (i, &p) in grid.positions.iter().enumerate() {
            if !used[i] {
                continue;
            }
            new_index[i] = positions.len() as u32;
            let mut p = p;
            if on_hole[i] {
                let radial = Vec2::new(p.x, p.z);
                let length = radial.length();
                if length > 0.0 && length < snap_within {
                    let out = radial * (self.neck_radius / length);
                    p = Vec3::new(out.x, p.y, out.y);
                }
            }
            positions.push(p);
            uvs.push([p.x / self.size + 0.5, p.z / self.size + 0.5]);
        }
        let indices = kept.iter().map(|&v| new_index[v as usize]).collect();
        Ok(GridMesh {
            positions,
            indices,
            uvs,
            shear_edges: Vec::new(),
        })
    }
}

/// `mesh` as Wavefront OBJ text: `v`, `vt` and `f v/vt` lines, one object, 1-based indices,
/// counter-clockwise faces.
pub fn to_obj(mesh: &GridMesh, name: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "o {name}");
    for p in &mesh.positions {
        let _ = writeln!(out, "v {:.6} {:.6} {:.6}", p.x, p.y, p.z);
    }
    for uv in &mesh.uvs {
        let _ = writeln!(out, "vt {:.6} {:.6}", uv[0], uv[1]);
    }
    let with_uvs = mesh.uvs.len() == mesh.positions.len();
    for tri in mesh.indices.chunks_exact(3) {
        out.push('f');
        for &v in tri {
            if with_uvs {
                let _ = write!(out, " {0}/{0}", v + 1);
            } else {
                let _ = write!(out, " {}", v + 1);
            }
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::model::ClothModel;

    #[test]
    fn the_poncho_has_a_round_hole_an_intact_outline_and_no_flipped_triangle() {
        let desc = PonchoDesc::default();
        let mesh = desc.mesh().unwrap();
        let r = desc.neck_radius;
        // Nothing inside the hole; its edge on the circle.
        let nearest = mesh
            .positions
            .iter()
            .map(|p| Vec2::new(p.x, p.z).length())
            .fold(f32::INFINITY, f32::min);
        assert!(
            (nearest - r).abs() < 1e-5,
            "nearest vertex at {nearest}, hole {r}"
        );
        // Every triangle faces up with a sensible area.
        let cell = desc.spacing() * desc.spacing() / 2.0;
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[tri[k] as usize]);
            let area = (b - a).cross(c - a).y / 2.0;
            assert!(area > 0.1 * cell, "triangle {tri:?} area {area}");
        }
        // The area is the square less about the hole.
        let area: f32 = mesh
            .indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [0, 1, 2].map(|k| mesh.positions[t[k] as usize]);
                (b - a).cross(c - a).length() / 2.0
            })
            .sum();
        let expected = desc.size * desc.size - std::f32::consts::PI * r * r;
        assert!(
            (area - expected).abs() < 0.02 * expected,
            "{area} vs {expected}"
        );
        // One piece with one hole: Euler characteristic V - E + F = 0 for an annulus.
        let model = ClothModel::from_triangles(&mesh.positions, &mesh.indices, 0.1).unwrap();
        let euler =
            model.particle_count() as i64 - model.edges.len() as i64 + model.triangles.len() as i64;
        assert_eq!(euler, 0);
    }

    #[test]
    fn the_obj_text_reads_back_as_the_same_mesh() {
        let mesh = PonchoDesc {
            vertices: 13,
            ..Default::default()
        }
        .mesh()
        .unwrap();
        let text = to_obj(&mesh, "poncho");
        let back = bevy_obj::mesh::load_obj_as_mesh(text.as_bytes(), &Default::default()).unwrap();
        let (positions, indices) = crate::mesh::mesh_triangles(&back).unwrap();
        assert_eq!(positions.len(), mesh.positions.len());
        assert_eq!(indices.len(), mesh.indices.len());
        // The same triangles, whatever order the loader numbered the vertices in.
        for (tri, orig) in indices.chunks_exact(3).zip(mesh.indices.chunks_exact(3)) {
            for k in 0..3 {
                let p = positions[tri[k] as usize];
                let q = mesh.positions[orig[k] as usize];
                assert!(p.distance(q) < 1e-5);
            }
        }
    }

    #[test]
    fn a_hole_wider_than_the_poncho_is_refused() {
        let desc = PonchoDesc {
            neck_radius: 0.7,
            ..Default::default()
        };
        assert!(matches!(desc.mesh(), Err(ClothError::InvalidPattern(_))));
    }
}
