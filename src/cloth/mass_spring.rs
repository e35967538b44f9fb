//! Mass-spring cloth: the springs, their forces, and the explicit stability bound.
//!
//! # Which springs
//!
//! [`SpringSet::new`] lays springs over a [`ClothModel`] in one of two ways:
//!
//! - a regular grid ([`ClothModel::grid`] is set): the usual springs of a grid cloth
//!   (Provot 1995): **structural** along the grid lines (the grid edges), **shear** along
//!   both diagonals of every quad, **bend** between vertices two apart along the grid lines;
//! - any other triangle mesh: **structural** on every mesh edge, **shear** on the far
//!   diagonal across every shared edge (the opposite vertices `x2`-`x3` of every
//!   [`BendingPair`](super::model::BendingPair), unless they already share an edge), and one
//!   **bend** spring per bending pair acting on its dihedral angle.
//!
//! A linear spring between `a` and `b` with stiffness `k` (N/m), damping `c` (N s/m) and rest
//! length `L` pushes `b` with `-(k (|d| - L) + c (v_b - v_a) . d^) d^`, `d = x_b - x_a`, and
//! `a` with the opposite force. A dihedral bend spring has the energy
//! `k L_e^2 (theta - theta_0)^2 / 2` and the damping moment `c L_e^2 dtheta/dt`, with `L_e` the
//! rest length of the shared edge, so its `k` and `c` keep the units of the linear springs;
//! the force on vertex `i` is `-(k L_e^2 (theta - theta_0) + c L_e^2 dtheta/dt) grad_i theta`
//! (gradients of [`dihedral_angle_and_gradients`]).
//!
//! # The stability bound
//!
//! Symplectic Euler (`v += h M^-1 f(x, v)`, then `x += h v`) on the linearised system
//! `x'' = -K x - C x'` is stable while, for every mode with frequency `omega` and damping rate
//! `gamma`, `h^2 omega^2 + 2 h gamma <= 4` (the trace condition of the step's 2x2
//! amplification matrix, whose determinant is `1 - h gamma`), that is
//!
//! ```text
//! h <= h_max = (sqrt(gamma^2 + 4 omega^2) - gamma) / omega^2     (= 2 / omega without damping)
//! ```
//!
//! `omega_max^2`, the largest eigenvalue of `M^-1 K`, is bounded with Gershgorin's theorem on
//! the 3x3 blocks of the rest-state stiffness matrix: a linear spring contributes a block of
//! norm `k` to the diagonal of each end and to the off-diagonal between them, so row `i` is
//! bounded by `2 sum k / m_i` over the springs at `i`; a bend spring contributes
//! `k L_e^2 |grad_i theta| sum_j |grad_j theta|`. The same bound on `M^-1 C` bounds `gamma`.
//! Both maxima over the free particles are used together, which can only overestimate. The
//! geometric stiffness of stretched springs (`k (1 - L/|d|)`, below `k` while the strain is
//! small) is left out. [`SpringSet::stable_step`] returns `h_max`; automatic substeps keep
//! the substep below [`AUTO_SUBSTEP_SAFETY`] of it.

use bevy::math::Vec3A;
use bevy::reflect::Reflect;

use super::constraints::dihedral_angle_and_gradients;
use super::model::{ClothModel, Edge, EdgeKind};

/// The fraction of the stable step [`SpringSet::stable_step`] that automatic substeps stay
/// below.
pub(crate) const AUTO_SUBSTEP_SAFETY: f32 = 0.9;

/// The most substeps automatic substepping chooses per fixed step.
pub(crate) const MAX_AUTO_SUBSTEPS: u32 = 4096;

/// Stiffness and damping of one family of springs.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct SpringConstants {
    /// Stiffness `k`, N/m.
    pub stiffness: f32,
    /// Damping `c` along the spring, N s/m.
    pub damping: f32,
}

/// The constants of the three spring families.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct SpringSettings {
    /// Structural springs. Default: `k = 1000`, `c = 0.02`.
    pub structural: SpringConstants,
    /// Shear springs. Default: `k = 300`, `c = 0.01`.
    pub shear: SpringConstants,
    /// Bend springs. Default: `k = 20`, `c = 0.001`.
    pub bend: SpringConstants,
}

impl Default for SpringSettings {
    fn default() -> Self {
        Self {
            structural: SpringConstants {
                stiffness: 1000.0,
                damping: 0.02,
            },
            shear: SpringConstants {
                stiffness: 300.0,
                damping: 0.01,
            },
            bend: SpringConstants {
                stiffness: 20.0,
                damping: 0.001,
            },
        }
    }
}

impl SpringSettings {
    /// Every constant with its name, for validation.
    pub(crate) fn named(&self) -> [(&'static str, f32); 6] {
        [
            ("structural stiffness", self.structural.stiffness),
            ("structural damping", self.structural.damping),
            ("shear stiffness", self.shear.stiffness),
            ("shear damping", self.shear.damping),
            ("bend stiffness", self.bend.stiffness),
            ("bend damping", self.bend.damping),
        ]
    }

    fn of(&self, family: SpringFamily) -> SpringConstants {
        match family {
            SpringFamily::Structural => self.structural,
            SpringFamily::Shear => self.shear,
            SpringFamily::Bend => self.bend,
        }
    }
}

/// The family a spring belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpringFamily {
    /// Along the threads (grid edges, or mesh edges).
    Structural,
    /// Across the threads (quad diagonals, or far diagonals).
    Shear,
    /// Against folding.
    Bend,
}

/// A linear spring.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spring {
    /// The two particles.
    pub particles: [u32; 2],
    /// Rest length, metres.
    pub rest_length: f32,
    /// Its family.
    pub family: SpringFamily,
}

/// A bend spring on the dihedral angle of a bending pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AngleSpring {
    /// `[x0, x1, x2, x3]` as in [`super::model::BendingPair`].
    pub particles: [u32; 4],
    /// Rest dihedral angle, radians.
    pub rest_angle: f32,
    /// Rest length of the shared edge squared, m^2: the spring's moment stiffness is
    /// `k` times this.
    pub edge_length_sq: f32,
}

/// The springs of one cloth (see `mass_spring.rs`) and the per-particle sums the
/// stability bound needs.
#[derive(Clone, Debug, PartialEq)]
pub struct SpringSet {
    /// The linear springs, structural ones first.
    pub springs: Vec<Spring>,
    /// The dihedral bend springs (meshes that are not grids).
    pub angle_springs: Vec<AngleSpring>,
    /// The structural edges of the model, for the hybrid method's constraints.
    pub structural_edges: Vec<Edge>,
    /// Per particle and family, the Gershgorin row weight: the row bound is the sum over
    /// families of `k` times this.
    row_weights: Vec<[f32; 3]>,
}

fn family_index(family: SpringFamily) -> usize {
    match family {
        SpringFamily::Structural => 0,
        SpringFamily::Shear => 1,
        SpringFamily::Bend => 2,
    }
}

impl SpringSet {
    /// Lays springs over `model` (see `mass_spring.rs`).
    pub fn new(model: &ClothModel) -> Self {
        let x = &model.rest_positions;
        let n = model.particle_count();
        let spring = |a: u32, b: u32, family| Spring {
            particles: [a.min(b), a.max(b)],
            rest_length: x[a as usize].distance(x[b as usize]),
            family,
        };
        let mut springs = Vec::new();
        let mut angle_springs = Vec::new();
        // The threads are structural (the hybrid's constraints); the diagonals of a grid or
        // of a quad pattern (`EdgeKind::Shear`) are shear springs, never its constraints.
        let structural_edges: Vec<Edge> = model
            .edges
            .iter()
            .copied()
            .filter(|e| e.kind == EdgeKind::Structural)
            .collect();
        springs.extend(
            structural_edges
                .iter()
                .map(|e| spring(e.particles[0], e.particles[1], SpringFamily::Structural)),
        );
        if let Some(grid) = model.grid {
            let (nx, nz) = (grid.x, grid.y);
            let index = |i: u32, j: u32| j * nx + i;
            for j in 0..nz - 1 {
                for i in 0..nx - 1 {
                    springs.push(spring(
                        index(i, j),
                        index(i + 1, j + 1),
                        SpringFamily::Shear,
                    ));
                    springs.push(spring(
                        index(i + 1, j),
                        index(i, j + 1),
                        SpringFamily::Shear,
                    ));
                }
            }
            for j in 0..nz {
                for i in 0..nx {
                    if i + 2 < nx {
                        springs.push(spring(index(i, j), index(i + 2, j), SpringFamily::Bend));
                    }
                    if j + 2 < nz {
                        springs.push(spring(index(i, j), index(i, j + 2), SpringFamily::Bend));
                    }
                }
            }
        } else {
            springs.extend(
                model
                    .edges
                    .iter()
                    .filter(|e| e.kind == EdgeKind::Shear)
                    .map(|e| spring(e.particles[0], e.particles[1], SpringFamily::Shear)),
            );
            let mut far: Vec<[u32; 2]> = model
                .bending_pairs
                .iter()
                .map(|p| {
                    let [_, _, a, b] = p.particles;
                    [a.min(b), a.max(b)]
                })
                .filter(|key| {
                    model
                        .edges
                        .binary_search_by_key(key, |e| e.particles)
                        .is_err()
                })
                .collect();
            far.sort_unstable();
            far.dedup();
            springs.extend(far.iter().map(|&[a, b]| spring(a, b, SpringFamily::Shear)));
            angle_springs.extend(model.bending_pairs.iter().map(|p| {
                let [a, b, _, _] = p.particles;
                AngleSpring {
                    particles: p.particles,
                    rest_angle: p.rest_angle,
                    edge_length_sq: x[a as usize].distance_squared(x[b as usize]),
                }
            }));
        }

        let mut row_weights = vec![[0.0f32; 3]; n];
        for s in &springs {
            for p in s.particles {
                row_weights[p as usize][family_index(s.family)] += 2.0;
            }
        }
        for s in &angle_springs {
            let p = s.particles.map(|i| Vec3A::from(x[i as usize]));
            if let Some((_, g)) = dihedral_angle_and_gradients(p[0], p[1], p[2], p[3]) {
                let norms = g.map(|g| g.length());
                let total: f32 = norms.iter().sum();
                for (k, &i) in s.particles.iter().enumerate() {
                    row_weights[i as usize][2] += s.edge_length_sq * norms[k] * total;
                }
            }
        }
        Self {
            springs,
            angle_springs,
            structural_edges,
            row_weights,
        }
    }

    /// Adds the spring forces at positions `x` and velocities `v` to `forces` (N). With
    /// `structural` false the structural springs are left out (the hybrid method holds them
    /// with constraints instead).
    pub fn add_forces(
        &self,
        constants: &SpringSettings,
        structural: bool,
        x: &[Vec3A],
        v: &[Vec3A],
        forces: &mut [Vec3A],
    ) {
        for s in &self.springs {
            if !structural && s.family == SpringFamily::Structural {
                continue;
            }
            let SpringConstants { stiffness, damping } = constants.of(s.family);
            let [a, b] = s.particles.map(|i| i as usize);
            let d = x[b] - x[a];
            let len = d.length();
            if len <= 1e-9 * s.rest_length {
                continue;
            }
            let dir = d / len;
            let f = stiffness * (len - s.rest_length) + damping * (v[b] - v[a]).dot(dir);
            forces[a] += dir * f;
            forces[b] -= dir * f;
        }
        let SpringConstants { stiffness, damping } = constants.bend;
        for s in &self.angle_springs {
            let [i0, i1, i2, i3] = s.particles.map(|i| i as usize);
            let Some((theta, g)) = dihedral_angle_and_gradients(x[i0], x[i1], x[i2], x[i3]) else {
                continue;
            };
            let rate = g[0].dot(v[i0]) + g[1].dot(v[i1]) + g[2].dot(v[i2]) + g[3].dot(v[i3]);
            let mut angle = theta - s.rest_angle;
            if angle > std::f32::consts::PI {
                angle -= std::f32::consts::TAU;
            } else if angle <= -std::f32::consts::PI {
                angle += std::f32::consts::TAU;
            }
            let moment = -s.edge_length_sq * (stiffness * angle + damping * rate);
            for (k, i) in [i0, i1, i2, i3].into_iter().enumerate() {
                forces[i] += g[k] * moment;
            }
        }
    }

    /// Gershgorin bounds `(omega_max, gamma_max)` over the particles with inverse mass
    /// `w > 0`, for the springs [`SpringSet::add_forces`] applies with the same `structural`.
    pub fn frequency_bounds(
        &self,
        constants: &SpringSettings,
        structural: bool,
        w: &[f32],
    ) -> (f32, f32) {
        let on = if structural { 1.0 } else { 0.0 };
        let (st, sh, be) = (constants.structural, constants.shear, constants.bend);
        let k = [on * st.stiffness, sh.stiffness, be.stiffness];
        let c = [on * st.damping, sh.damping, be.damping];
        let mut omega_sq = 0.0f32;
        let mut gamma = 0.0f32;
        for (row, &wi) in self.row_weights.iter().zip(w) {
            if wi > 0.0 {
                omega_sq = omega_sq.max(wi * (k[0] * row[0] + k[1] * row[1] + k[2] * row[2]));
                gamma = gamma.max(wi * (c[0] * row[0] + c[1] * row[1] + c[2] * row[2]));
            }
        }
        (omega_sq.sqrt(), gamma)
    }

    /// The largest stable symplectic Euler step for these springs (see the
    /// module docs of `mass_spring.rs`); infinite without springs or free particles.
    pub fn stable_step(&self, constants: &SpringSettings, structural: bool, w: &[f32]) -> f32 {
        let (omega, gamma) = self.frequency_bounds(constants, structural, w);
        stable_step(omega, gamma)
    }
}

/// `h_max = (sqrt(gamma^2 + 4 omega^2) - gamma) / omega^2`: the largest symplectic Euler step
/// that keeps a mode of frequency `omega` (rad/s) and damping rate `gamma` (1/s) bounded.
pub(crate) fn stable_step(omega: f32, gamma: f32) -> f32 {
    if omega <= 0.0 {
        return if gamma > 0.0 {
            2.0 / gamma
        } else {
            f32::INFINITY
        };
    }
    ((gamma * gamma + 4.0 * omega * omega).sqrt() - gamma) / (omega * omega)
}

/// The fewest substeps of `dt` that keep each below `AUTO_SUBSTEP_SAFETY * h_max`, at least
/// `minimum`, at most [`MAX_AUTO_SUBSTEPS`].
pub(crate) fn auto_substeps(dt: f32, h_max: f32, minimum: u32) -> u32 {
    let needed = (dt / (AUTO_SUBSTEP_SAFETY * h_max)).ceil();
    if needed.is_finite() {
        (needed as u32).clamp(minimum.max(1), MAX_AUTO_SUBSTEPS.max(minimum))
    } else {
        minimum.max(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::model::GridDesc;
    use bevy::math::Vec3;

    #[test]
    fn grid_gets_the_usual_springs() {
        let n = 5u32;
        let model = ClothModel::grid(&GridDesc::square(1.0, n, Vec3::ZERO), 0.1).unwrap();
        assert_eq!(model.grid, Some(bevy::math::UVec2::splat(n)));
        let set = SpringSet::new(&model);
        let count = |f| set.springs.iter().filter(|s| s.family == f).count() as u32;
        assert_eq!(count(SpringFamily::Structural), 2 * n * (n - 1));
        assert_eq!(count(SpringFamily::Shear), 2 * (n - 1) * (n - 1));
        assert_eq!(count(SpringFamily::Bend), 2 * n * (n - 2));
        assert!(set.angle_springs.is_empty());
    }

    #[test]
    fn mesh_gets_far_diagonals_and_angle_springs() {
        // Two triangles sharing an edge, not a grid.
        let x = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.5, 0.0, -0.8),
            Vec3::new(0.4, 0.0, 0.9),
        ];
        let model = ClothModel::from_triangles(&x, &[0, 1, 2, 1, 0, 3], 0.1).unwrap();
        assert_eq!(model.grid, None);
        let set = SpringSet::new(&model);
        assert_eq!(set.springs.len(), 5 + 1);
        assert_eq!(set.springs[5].particles, [2, 3]);
        assert_eq!(set.angle_springs.len(), 1);
    }

    #[test]
    fn stable_step_without_damping_is_two_over_omega() {
        assert!((stable_step(100.0, 0.0) - 0.02).abs() < 1e-7);
        assert!(stable_step(100.0, 10.0) < 0.02);
        assert_eq!(auto_substeps(0.1, 0.01, 1), 12);
        assert_eq!(auto_substeps(0.1, f32::INFINITY, 3), 3);
    }
}
