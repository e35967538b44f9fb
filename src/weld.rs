//! Welding: mesh files split a vertex wherever its texture coordinates or normals differ (an
//! OBJ's seams, a UV sphere's meridian and poles), which as a cloth would be separate
//! particles and let it fall apart along the seams. [`weld`] merges vertices that share a
//! position (within a tolerance) into one particle and keeps the map back to the mesh's
//! vertices, so the renderer still gets its split vertices.

use std::collections::HashMap;

use bevy::math::Vec3;

/// A mesh with coincident vertices merged.
#[derive(Clone, Debug, PartialEq)]
pub struct Welded {
    /// One position per particle (the first vertex's of each merged group).
    pub positions: Vec<Vec3>,
    /// The triangles over the particles.
    pub indices: Vec<u32>,
    /// The particle of every input vertex.
    pub vertex_to_particle: Vec<u32>,
}

impl Welded {
    /// Whether any vertices were merged.
    pub fn merged_any(&self) -> bool {
        self.positions.len() < self.vertex_to_particle.len()
    }
}

/// Merges the vertices of `positions` closer than `tolerance` (metres; at most the first
/// vertex of a group within that distance of each) and renumbers `indices`. Indices out of
/// range are kept as they are (for the model to refuse); non-finite positions are never
/// merged. The result does not depend on anything but the input order.
pub fn weld(positions: &[Vec3], indices: &[u32], tolerance: f32) -> Welded {
    let tolerance = if tolerance.is_finite() && tolerance > 0.0 {
        tolerance
    } else {
        0.0
    };
    let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut kept: Vec<Vec3> = Vec::with_capacity(positions.len());
    let mut map = Vec::with_capacity(positions.len());
    let cell_of = |p: Vec3| {
        let c = if tolerance > 0.0 {
            (p / tolerance).floor()
        } else {
            p
        };
        [c.x as i64, c.y as i64, c.z as i64]
    };
    for &p in positions {
        if !p.is_finite() {
            map.push(kept.len() as u32);
            kept.push(p);
            continue;
        }
        let c = cell_of(p);
        let mut found = None;
        'search: for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(candidates) = cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                        continue;
                    };
                    for &k in candidates {
                        if kept[k as usize].distance(p) <= tolerance {
                            found = Some(k);
                            break 'search;
                        }
                    }
                }
            }
        }
        let particle = found.unwrap_or_else(|| {
            let k = kept.len() as u32;
            kept.push(p);
            cells.entry(c).or_default().push(k);
            k
        });
        map.push(particle);
    }
    let indices = indices
        .iter()
        .map(|&i| {
            map.get(i as usize)
                .copied()
                .unwrap_or(i.max(kept.len() as u32))
        })
        .collect();
    Welded {
        positions: kept,
        indices,
        vertex_to_particle: map,
    }
}

/// The welding tolerance for a mesh: a millionth of its bounding box's diagonal, at least
/// 1e-7 m.
pub(crate) fn default_tolerance(positions: &[Vec3]) -> f32 {
    let (lo, hi) = positions
        .iter()
        .filter(|p| p.is_finite())
        .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), &p| {
            (lo.min(p), hi.max(p))
        });
    let diagonal = if lo.cmple(hi).all() {
        lo.distance(hi)
    } else {
        0.0
    };
    (diagonal * 1e-6).max(1e-7)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_corners_merge_and_the_triangles_follow() {
        // Two triangles of a quad, each with its own copy of the shared edge's vertices.
        let positions = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::X,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::Y + Vec3::splat(1e-9),
        ];
        let welded = weld(&positions, &[0, 1, 2, 3, 4, 5], 1e-6);
        assert_eq!(welded.positions.len(), 4);
        assert_eq!(welded.vertex_to_particle, vec![0, 1, 2, 1, 3, 2]);
        assert_eq!(welded.indices, vec![0, 1, 2, 1, 3, 2]);
        assert!(welded.merged_any());
    }

    #[test]
    fn out_of_range_indices_stay_out_of_range_and_nan_is_never_merged() {
        let positions = [Vec3::ZERO, Vec3::NAN, Vec3::NAN];
        let welded = weld(&positions, &[0, 1, 7], 1e-6);
        assert_eq!(welded.positions.len(), 3);
        assert!(welded.indices[2] as usize >= welded.positions.len());
    }
}
