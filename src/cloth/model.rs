//! Cloth topology, rest state and masses: everything about a cloth that does not change while
//! it moves.
//!
//! A [`ClothModel`] is built once, from a triangle mesh ([`ClothModel::from_triangles`]), from
//! the grid generator ([`ClothModel::grid`], see [`GridDesc`]) or from raw particles joined by
//! distance constraints ([`ClothModel::from_particles`], for ropes, chains and tests).
//!
//! - Particle mass = areal density x one third of the area of every triangle around the
//!   particle, plus an optional point mass.
//! - Every edge appears once ([`Edge`]), whichever triangles share it.
//! - Every pair of triangles that share an edge gives one [`BendingPair`], found once.
//!
//! Building is deterministic (sorting, no hash maps), so two builds of the same input give the
//! same constraint order and therefore the same simulation.

use bevy::math::{Quat, UVec2, Vec2, Vec3};

use crate::error::{ClothError, ClothWarning};

/// What an edge stands for. The solvers constrain every edge; strain is measured on the
/// structural ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeKind {
    /// A warp or weft thread: a grid edge, or any edge of a general triangle mesh.
    Structural,
    /// A diagonal of a quad: of a grid, or an interior edge opposite a right angle in both
    /// of its triangles (a quad pattern cut into triangles, as a modelling tool exports it).
    Shear,
}

/// A distance constraint between two particles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// The two particles, smaller index first.
    pub particles: [u32; 2],
    /// Rest length, metres.
    pub rest_length: f32,
    /// What the edge stands for.
    pub kind: EdgeKind,
}

/// Two triangles sharing an edge: `(x0, x1, x2)` and `(x1, x0, x3)`, where `x0`-`x1` is the
/// shared edge and `x2`, `x3` are the opposite vertices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BendingPair {
    /// `[x0, x1, x2, x3]`.
    pub particles: [u32; 4],
    /// The signed dihedral angle of the rest shape, radians (0 for a flat rest shape).
    pub rest_angle: f32,
}

/// The parts of a cloth that do not change while it moves.
#[derive(Clone, Debug)]
pub struct ClothModel {
    /// Rest positions, metres.
    pub rest_positions: Vec<Vec3>,
    /// Triangles, counter-clockwise seen from the front. Empty for a model built from
    /// particles.
    pub triangles: Vec<[u32; 3]>,
    /// De-duplicated edges.
    pub edges: Vec<Edge>,
    /// One bending pair per interior (manifold) edge.
    pub bending_pairs: Vec<BendingPair>,
    /// Per particle, one third of the area of the triangles around it, m^2.
    pub area_shares: Vec<f32>,
    /// Per particle, a mass added to the area mass, kg.
    pub point_masses: Vec<f32>,
    /// Areal density, kg/m^2.
    pub density: f32,
    /// `Some((nx, nz))` when the mesh is a regular grid of `nx` x `nz` vertices laid out as
    /// [`GridDesc::mesh`] lays it out (recognised by [`ClothModel::from_triangles`]); its quad
    /// diagonals are then [`EdgeKind::Shear`].
    pub grid: Option<UVec2>,
    /// What was left out while building.
    pub warnings: Vec<ClothWarning>,
}

/// A rectangular grid of particles, the cloth of the standard scenes.
///
/// Vertex `(i, j)` (with `i < vertices.x`, `j < vertices.y`) has index `j * vertices.x + i`
/// and sits at `origin + orientation * (i dx, 0, j dz)` with `dx = size.x / (vertices.x - 1)`
/// and `dz = size.y / (vertices.y - 1)`: the grid is laid out in the local XZ plane, facing
/// +Y, then rotated and moved. Quads are split along alternating diagonals, so the cloth has
/// no preferred shear direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridDesc {
    /// Side lengths along the grid's local X and Z, metres.
    pub size: Vec2,
    /// Vertices along each side (at least 2 each).
    pub vertices: UVec2,
    /// Rotation of the grid; identity lays it flat, facing up.
    pub orientation: Quat,
    /// Position of vertex `(0, 0)`.
    pub origin: Vec3,
}

impl GridDesc {
    /// A `size` x `size` square with `n` x `n` vertices, flat, facing up, vertex `(0, 0)` at
    /// `origin`.
    pub fn square(size: f32, n: u32, origin: Vec3) -> Self {
        Self {
            size: Vec2::splat(size),
            vertices: UVec2::splat(n),
            orientation: Quat::IDENTITY,
            origin,
        }
    }

    /// The index of vertex `(i, j)`.
    pub fn index(&self, i: u32, j: u32) -> u32 {
        j * self.vertices.x + i
    }

    /// Vertex positions, triangle indices and texture coordinates of the grid.
    pub fn mesh(&self) -> GridMesh {
        let nx = self.vertices.x.max(2);
        let nz = self.vertices.y.max(2);
        let dx = self.size.x / (nx - 1) as f32;
        let dz = self.size.y / (nz - 1) as f32;
        let mut positions = Vec::with_capacity((nx * nz) as usize);
        let mut uvs = Vec::with_capacity((nx * nz) as usize);
        for j in 0..nz {
            for i in 0..nx {
                let local = Vec3::new(i as f32 * dx, 0.0, j as f32 * dz);
                positions.push(self.origin + self.orientation * local);
                uvs.push([i as f32 / (nx - 1) as f32, j as f32 / (nz - 1) as f32]);
            }
        }
        let mut indices = Vec::with_capacity(((nx - 1) * (nz - 1) * 6) as usize);
        let mut shear = Vec::with_capacity(((nx - 1) * (nz - 1)) as usize);
        for j in 0..nz - 1 {
            for i in 0..nx - 1 {
                let p00 = j * nx + i;
                let p10 = p00 + 1;
                let p01 = p00 + nx;
                let p11 = p01 + 1;
                if (i + j) % 2 == 0 {
                    indices.extend_from_slice(&[p00, p01, p11, p00, p11, p10]);
                    shear.push([p00, p11]);
                } else {
                    indices.extend_from_slice(&[p00, p01, p10, p10, p01, p11]);
                    shear.push([p10.min(p01), p10.max(p01)]);
                }
            }
        }
        GridMesh {
            positions,
            indices,
            uvs,
            shear_edges: shear,
        }
    }
}

/// The output of [`GridDesc::mesh`].
#[derive(Clone, Debug)]
pub struct GridMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangle indices, counter-clockwise seen from the front.
    pub indices: Vec<u32>,
    /// Texture coordinates in `[0, 1]^2`.
    pub uvs: Vec<[f32; 2]>,
    /// The quad diagonals, smaller index first.
    pub shear_edges: Vec<[u32; 2]>,
}

fn check_positions(positions: &[Vec3]) -> Result<(), ClothError> {
    match positions.iter().position(|p| !p.is_finite()) {
        Some(vertex) => Err(ClothError::NonFinitePosition { vertex }),
        None => Ok(()),
    }
}

fn check_density(density: f32) -> Result<(), ClothError> {
    if density.is_finite() && density > 0.0 {
        Ok(())
    } else {
        Err(ClothError::InvalidDensity(density))
    }
}

/// Twice the area below which a triangle counts as degenerate, relative to its longest edge
/// squared.
const DEGENERATE_RELATIVE_AREA: f32 = 1e-6;

/// Recognises a mesh laid out as [`GridDesc::mesh`] lays it out: vertex `(i, j)` at index
/// `j nx + i` on a regular lattice, every grid edge present, one diagonal per quad and two
/// triangles per quad. `edges` must be sorted by their particles. Returns `(nx, nz)`.
/// The boundary edges of `triangles` (those on one triangle only), each as its two particles,
/// smaller index first, with the index of its triangle; sorted by particles.
pub(crate) fn boundary_edges(triangles: &[[u32; 3]]) -> Vec<([u32; 2], u32)> {
    let mut sides: Vec<([u32; 2], u32)> = triangles
        .iter()
        .enumerate()
        .flat_map(|(t, &[a, b, c])| [[a, b], [b, c], [c, a]].map(|side| (side, t as u32)))
        .map(|([a, b], t)| ([a.min(b), a.max(b)], t))
        .collect();
    sides.sort_unstable();
    let mut boundary = Vec::new();
    let mut k = 0;
    while k < sides.len() {
        let mut j = k + 1;
        while j < sides.len() && sides[j].0 == sides[k].0 {
            j += 1;
        }
        if j - k == 1 {
            boundary.push(sides[k]);
        }
        k = j;
    }
    boundary
}

fn recognise_grid(positions: &[Vec3], triangle_count: usize, edges: &[Edge]) -> Option<UVec2> {
    let n = positions.len();
    let has_edge = |a: usize, b: usize| {
        edges
            .binary_search_by_key(&[a as u32, b as u32], |e| e.particles)
            .is_ok()
    };
    (2..=n / 2)
        .filter(|nx| n.is_multiple_of(*nx))
        .find_map(|nx| {
            let nz = n / nx;
            let quads = (nx - 1) * (nz - 1);
            if triangle_count != 2 * quads
                || edges.len() != (nx - 1) * nz + nx * (nz - 1) + quads
                || !has_edge(0, 1)
                || !has_edge(0, nx)
            {
                return None;
            }
            let origin = positions[0];
            let (di, dj) = (positions[1] - origin, positions[nx] - origin);
            let tolerance = 1e-4 * di.length().max(dj.length());
            let on_lattice = (0..n).all(|k| {
                let (i, j) = ((k % nx) as f32, (k / nx) as f32);
                positions[k].distance(origin + di * i + dj * j) <= tolerance
            });
            let all_grid_edges = (0..n).all(|k| {
                (k % nx == nx - 1 || has_edge(k, k + 1)) && (k + nx >= n || has_edge(k, k + nx))
            });
            (on_lattice && all_grid_edges).then_some(UVec2::new(nx as u32, nz as u32))
        })
}

impl ClothModel {
    /// Builds a cloth from a triangle mesh: `indices` holds three vertex indices per triangle.
    ///
    /// Errors: no triangles, an index count that is not a multiple of 3, an index out of
    /// range, a non-finite position, a density that is not finite and positive. Zero-area
    /// triangles are dropped, non-manifold edges get no bending constraint and vertices in no
    /// triangle are held in place; each is recorded in [`ClothModel::warnings`].
    pub fn from_triangles(
        positions: &[Vec3],
        indices: &[u32],
        density: f32,
    ) -> Result<Self, ClothError> {
        check_density(density)?;
        check_positions(positions)?;
        if !indices.len().is_multiple_of(3) {
            return Err(ClothError::IndexCountNotTriangles(indices.len()));
        }
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= positions.len()) {
            return Err(ClothError::IndexOutOfRange {
                index,
                vertex_count: positions.len(),
            });
        }
        let mut warnings = Vec::new();
        let mut triangles = Vec::with_capacity(indices.len() / 3);
        let mut area_shares = vec![0.0; positions.len()];
        for (t, tri) in indices.chunks_exact(3).enumerate() {
            let [a, b, c] = [tri[0], tri[1], tri[2]];
            let (pa, pb, pc) = (
                positions[a as usize],
                positions[b as usize],
                positions[c as usize],
            );
            let twice_area = (pb - pa).cross(pc - pa).length();
            let longest = (pb - pa)
                .length_squared()
                .max((pc - pb).length_squared())
                .max((pa - pc).length_squared());
            if a == b || b == c || a == c || twice_area <= DEGENERATE_RELATIVE_AREA * longest {
                warnings.push(ClothWarning::DegenerateTriangle { triangle: t });
                continue;
            }
            for v in [a, b, c] {
                area_shares[v as usize] += twice_area / 6.0;
            }
            triangles.push([a, b, c]);
        }
        if triangles.is_empty() {
            return Err(ClothError::NoTriangles);
        }
        let isolated = area_shares.iter().filter(|&&s| s == 0.0).count();
        if isolated > 0 {
            warnings.push(ClothWarning::IsolatedVertices { count: isolated });
        }

        // Every (edge, triangle) incidence, sorted by edge: runs of equal keys are one edge.
        let mut incidences: Vec<([u32; 2], [u32; 3])> = Vec::with_capacity(triangles.len() * 3);
        for &[a, b, c] in &triangles {
            for (p, q, o) in [(a, b, c), (b, c, a), (c, a, b)] {
                incidences.push(([p.min(q), p.max(q)], [p, q, o]));
            }
        }
        incidences.sort_unstable_by_key(|&(key, oriented)| (key, oriented));
        let mut edges = Vec::with_capacity(incidences.len() / 2 + 1);
        let mut bending_pairs = Vec::with_capacity(incidences.len() / 2);
        let mut start = 0;
        while start < incidences.len() {
            let key = incidences[start].0;
            let mut end = start + 1;
            while end < incidences.len() && incidences[end].0 == key {
                end += 1;
            }
            let [a, b] = key;
            edges.push(Edge {
                particles: key,
                rest_length: positions[a as usize].distance(positions[b as usize]),
                kind: EdgeKind::Structural,
            });
            match end - start {
                1 => {}
                2 => {
                    let [p, q, o1] = incidences[start].1;
                    let o2 = incidences[start + 1].1[2];
                    let particles = [p, q, o1, o2];
                    let x = particles.map(|i| positions[i as usize]);
                    let rest_angle = super::constraints::dihedral_angle(
                        x[0].into(),
                        x[1].into(),
                        x[2].into(),
                        x[3].into(),
                    )
                    .unwrap_or(0.0);
                    bending_pairs.push(BendingPair {
                        particles,
                        rest_angle,
                    });
                    if is_quad_diagonal(x)
                        && let Some(edge) = edges.last_mut()
                    {
                        edge.kind = EdgeKind::Shear;
                    }
                }
                n => warnings.push(ClothWarning::NonManifoldEdge { a, b, triangles: n }),
            }
            start = end;
        }

        let grid = recognise_grid(positions, triangles.len(), &edges);
        if grid.is_some() {
            for edge in &mut edges {
                let [a, b] = edge.particles;
                if b - a != 1 && grid.is_some_and(|g| b - a != g.x) {
                    edge.kind = EdgeKind::Shear;
                }
            }
        }
        Ok(Self {
            rest_positions: positions.to_vec(),
            triangles,
            edges,
            bending_pairs,
            area_shares,
            point_masses: vec![0.0; positions.len()],
            density,
            grid,
            warnings,
        })
    }

    /// Builds the grid cloth of [`GridDesc`]: grid edges are [`EdgeKind::Structural`], quad
    /// diagonals [`EdgeKind::Shear`], and [`ClothModel::grid`] is set.
    pub fn grid(desc: &GridDesc, density: f32) -> Result<Self, ClothError> {
        let mesh = desc.mesh();
        Self::from_triangles(&mesh.positions, &mesh.indices, density)
    }

    /// Builds a model of point masses joined by distance constraints (ropes, chains, tests):
    /// no triangles, no bending, rest lengths from `positions`. A particle of mass 0 is held in
    /// place.
    pub fn from_particles(
        positions: &[Vec3],
        masses: &[f32],
        constraints: &[[u32; 2]],
    ) -> Result<Self, ClothError> {
        check_positions(positions)?;
        let mut point_masses = vec![0.0; positions.len()];
        for (particle, (&m, slot)) in masses.iter().zip(&mut point_masses).enumerate() {
            if !(m.is_finite() && m >= 0.0) {
                return Err(ClothError::InvalidMass { particle, mass: m });
            }
            *slot = m;
        }
        let mut edges = Vec::with_capacity(constraints.len());
        for (constraint, &[a, b]) in constraints.iter().enumerate() {
            for index in [a, b] {
                if index as usize >= positions.len() {
                    return Err(ClothError::IndexOutOfRange {
                        index,
                        vertex_count: positions.len(),
                    });
                }
            }
            let rest_length = positions[a as usize].distance(positions[b as usize]);
            if a == b || rest_length <= 0.0 {
                return Err(ClothError::DegenerateConstraint { constraint, a, b });
            }
            edges.push(Edge {
                particles: [a.min(b), a.max(b)],
                rest_length,
                kind: EdgeKind::Structural,
            });
        }
        Ok(Self {
            rest_positions: positions.to_vec(),
            triangles: Vec::new(),
            edges,
            bending_pairs: Vec::new(),
            area_shares: vec![0.0; positions.len()],
            point_masses,
            density: 1.0,
            grid: None,
            warnings: Vec::new(),
        })
    }

    /// One model holding `parts` side by side: the particles of part `k` follow those of the
    /// parts before it, in their order, and its triangles, edges and bending pairs name them
    /// there. The masses are each part's own (the first part's density, the others' told
    /// apart by point masses); the rest shapes are each part's, so the parts are not joined.
    ///
    /// Errors: no parts.
    pub fn side_by_side(parts: &[&ClothModel]) -> Result<Self, ClothError> {
        let density = parts.first().ok_or(ClothError::NoLayers)?.density;
        let mut merged = Self {
            rest_positions: Vec::new(),
            triangles: Vec::new(),
            edges: Vec::new(),
            bending_pairs: Vec::new(),
            area_shares: Vec::new(),
            point_masses: Vec::new(),
            density,
            grid: None,
            warnings: Vec::new(),
        };
        for part in parts {
            let offset = merged.rest_positions.len() as u32;
            merged
                .rest_positions
                .extend_from_slice(&part.rest_positions);
            merged
                .triangles
                .extend(part.triangles.iter().map(|t| t.map(|i| i + offset)));
            merged.edges.extend(part.edges.iter().map(|e| Edge {
                particles: e.particles.map(|i| i + offset),
                ..*e
            }));
            merged
                .bending_pairs
                .extend(part.bending_pairs.iter().map(|b| BendingPair {
                    particles: b.particles.map(|i| i + offset),
                    ..*b
                }));
            merged.area_shares.extend_from_slice(&part.area_shares);
            merged
                .point_masses
                .extend((0..part.particle_count()).map(|i| {
                    part.point_masses[i] + (part.density - density) * part.area_shares[i]
                }));
        }
        Ok(merged)
    }

    /// Number of particles.
    pub(crate) fn particle_count(&self) -> usize {
        self.rest_positions.len()
    }

    /// Mass of particle `i`, kg: density x area share + point mass.
    pub fn mass(&self, i: usize) -> f32 {
        self.density * self.area_shares[i] + self.point_masses[i]
    }

    /// Total mass, kg.
    pub fn total_mass(&self) -> f32 {
        (0..self.particle_count()).map(|i| self.mass(i)).sum()
    }

    /// Total area of the triangles, m^2.
    pub fn area(&self) -> f32 {
        self.area_shares.iter().sum()
    }

    /// Changes the areal density (kg/m^2); masses follow.
    pub(crate) fn set_density(&mut self, density: f32) -> Result<(), ClothError> {
        check_density(density)?;
        self.density = density;
        Ok(())
    }
}

/// How far from a right angle (its cosine) the corners facing a quad's diagonal may be: about
/// 1.1 degrees.
const RIGHT_ANGLE_COSINE: f32 = 0.02;

/// Whether the edge `x[0]`-`x[1]`, shared by the triangles with third corners `x[2]` and
/// `x[3]`, is the diagonal of a quad: both corners facing it are right angles.
fn is_quad_diagonal(x: [Vec3; 4]) -> bool {
    x[2..].iter().all(|&o| {
        let (u, v) = (x[0] - o, x[1] - o);
        let lengths = u.length() * v.length();
        lengths > 0.0 && (u.dot(v) / lengths).abs() < RIGHT_ANGLE_COSINE
    })
}
