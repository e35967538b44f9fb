//! Fast projection (Goldenthal, Harmon, Fattal, Bercovier and Grinspun 2007): every edge
//! brought to its rest length at once, by Gauss-Newton steps on the edge constraints, each a
//! linear solve with preconditioned conjugate gradients.
//!
//! For edges `e = (a, b)` with `C_e = |x_a - x_b| - L_e` and unit directions `n_e`, one step
//! solves `(J W J^T) lambda = C` (`J` the constraints' gradient, `W` the inverse masses) and
//! moves `dx = -W J^T lambda`: the smallest mass-weighted move that meets the linearised
//! constraints, so tension travels the whole cloth in one solve instead of one edge per
//! Gauss-Seidel sweep. The product with `J W J^T` is formed edge by edge (no matrix is
//! stored); edges whose particles are both fixed are left out.

use bevy::math::Vec3A;

use super::model::Edge;

/// The largest relative error of an edge for which the projection acts (see
/// [`FastProjection::project`]): a cloth yanked 2 m in one step had its largest strain in the
/// following second go from 48% to 81% with the projection and without this limit
/// (`tests/interaction.rs`); resting on a body (S3) no edge comes near it.
const LINEAR_RANGE: f32 = 0.25;

/// Scratch memory of the projection, reused every call.
#[derive(Clone, Debug, Default)]
pub(crate) struct FastProjection {
    edges: Vec<([u32; 2], f32)>,
    normals: Vec<Vec3A>,
    rhs: Vec<f32>,
    lambda: Vec<f32>,
    residual: Vec<f32>,
    direction: Vec<f32>,
    product: Vec<f32>,
    diagonal: Vec<f32>,
    particles: Vec<Vec3A>,
    start: Vec<Vec3A>,
}

impl FastProjection {
    /// A projection of `edges` between `particles` particles, its scratch memory made here so
    /// that no projection allocates.
    pub(crate) fn new<'a>(edges: impl Iterator<Item = &'a Edge>, particles: usize) -> Self {
        let edges: Vec<_> = edges.map(|e| (e.particles, e.rest_length)).collect();
        let m = edges.len();
        Self {
            edges,
            normals: vec![Vec3A::ZERO; m],
            rhs: vec![0.0; m],
            lambda: vec![0.0; m],
            residual: vec![0.0; m],
            direction: vec![0.0; m],
            product: vec![0.0; m],
            diagonal: vec![0.0; m],
            particles: vec![Vec3A::ZERO; particles],
            start: Vec::with_capacity(particles),
        }
    }

    /// `newton` Gauss-Newton steps of at most `cg` conjugate-gradient iterations each;
    /// particles with `w = 0` stay. Each step's move is halved while it leaves the largest
    /// error larger, up to 4 times, and dropped (ending the projection) if it still does; none
    /// is taken while an edge is off by more than [`LINEAR_RANGE`] of its rest length.
    pub(crate) fn project(&mut self, x: &mut [Vec3A], w: &[f32], newton: u32, cg: u32) {
        let m = self.edges.len();
        let n = x.len();
        self.normals.resize(m, Vec3A::ZERO);
        for v in [
            &mut self.rhs,
            &mut self.lambda,
            &mut self.residual,
            &mut self.direction,
            &mut self.product,
            &mut self.diagonal,
        ] {
            v.clear();
            v.resize(m, 0.0);
        }
        self.particles.clear();
        self.particles.resize(n, Vec3A::ZERO);
        for _ in 0..newton {
            let mut worst = 0.0f32;
            for (k, &([a, b], rest)) in self.edges.iter().enumerate() {
                let d = x[a as usize] - x[b as usize];
                let len = d.length();
                let weight = w[a as usize] + w[b as usize];
                if len <= f32::EPSILON * rest || weight == 0.0 {
                    self.normals[k] = Vec3A::ZERO;
                    self.rhs[k] = 0.0;
                    self.diagonal[k] = 1.0;
                    continue;
                }
                self.normals[k] = d / len;
                self.rhs[k] = len - rest;
                self.diagonal[k] = weight;
                worst = worst.max((len - rest).abs() / rest);
            }
            // A cloth torn about (an edge off by a quarter of its length) is left to the
            // iterations: the linearisation would move it far, and the move becomes velocity.
            if worst > LINEAR_RANGE {
                break;
            }
            // Preconditioned CG from lambda = 0.
            self.lambda.fill(0.0);
            self.residual.copy_from_slice(&self.rhs);
            for k in 0..m {
                self.direction[k] = self.residual[k] / self.diagonal[k];
            }
            let mut rz: f32 = (0..m)
                .map(|k| self.residual[k] * self.residual[k] / self.diagonal[k])
                .sum();
            let start = rz;
            for _ in 0..cg {
                // Converged, or nothing finite to go on (the lambdas so far stay finite).
                if !(rz > start * 1e-12 && rz.is_finite()) {
                    break;
                }
                self.apply(w);
                let pap: f32 = (0..m).map(|k| self.direction[k] * self.product[k]).sum();
                if !(pap > 0.0 && pap.is_finite()) {
                    break;
                }
                let alpha = rz / pap;
                for k in 0..m {
                    self.lambda[k] += alpha * self.direction[k];
                    self.residual[k] -= alpha * self.product[k];
                }
                let rz_new: f32 = (0..m)
                    .map(|k| self.residual[k] * self.residual[k] / self.diagonal[k])
                    .sum();
                let beta = rz_new / rz;
                rz = rz_new;
                for k in 0..m {
                    self.direction[k] =
                        self.residual[k] / self.diagonal[k] + beta * self.direction[k];
                }
            }
            // dx = -W J^T lambda, halved while it leaves the largest error larger.
            self.particles.fill(Vec3A::ZERO);
            for (k, &([a, b], _)) in self.edges.iter().enumerate() {
                let push = self.normals[k] * self.lambda[k];
                self.particles[a as usize] -= push * w[a as usize];
                self.particles[b as usize] += push * w[b as usize];
            }
            self.start.clear();
            self.start.extend_from_slice(x);
            let mut scale = 1.0;
            let mut improved = false;
            for _ in 0..4 {
                for ((x, &x0), &dx) in x.iter_mut().zip(&self.start).zip(&self.particles) {
                    *x = x0 + dx * scale;
                }
                if self.largest_error(x) <= worst {
                    improved = true;
                    break;
                }
                scale *= 0.5;
            }
            // Far from the solution the linearisation can lead nowhere better: no move then.
            if !improved {
                x.copy_from_slice(&self.start);
                break;
            }
        }
    }

    /// The largest `|C_e| / L_e`.
    fn largest_error(&self, x: &[Vec3A]) -> f32 {
        self.edges
            .iter()
            .map(|&([a, b], rest)| ((x[a as usize] - x[b as usize]).length() - rest).abs() / rest)
            .fold(0.0, f32::max)
    }

    /// `product = J W J^T direction`.
    fn apply(&mut self, w: &[f32]) {
        self.particles.fill(Vec3A::ZERO);
        for (k, &([a, b], _)) in self.edges.iter().enumerate() {
            let t = self.normals[k] * self.direction[k];
            self.particles[a as usize] += t;
            self.particles[b as usize] -= t;
        }
        for (p, &w) in self.particles.iter_mut().zip(w) {
            *p *= w;
        }
        for (k, &([a, b], _)) in self.edges.iter().enumerate() {
            self.product[k] =
                self.normals[k].dot(self.particles[a as usize] - self.particles[b as usize]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::model::{ClothModel, EdgeKind, GridDesc};
    use crate::rng::Rng;
    use bevy::math::{Quat, UVec2, Vec2, Vec3};

    /// Random grids, stretched and jittered at random, one corner pinned or none: a few steps
    /// bring every edge to its rest length, and with nothing pinned the centre of mass stays.
    #[test]
    fn random_stretched_grids_come_back_to_their_rest_lengths() {
        let mut rng = Rng(0x51f1_5ee7_c0ff_ee11);
        for case in 0..8 {
            let cols = 3 + (rng.uniform() * 20.0) as u32;
            let rows = 3 + (rng.uniform() * 20.0) as u32;
            let grid = GridDesc {
                size: Vec2::new(0.2 + rng.uniform(), 0.2 + rng.uniform()),
                vertices: UVec2::new(cols, rows),
                orientation: Quat::IDENTITY,
                origin: Vec3::ZERO,
            };
            let model = ClothModel::grid(&grid, 0.2).unwrap();
            let stretch = 1.0 + 0.05 * rng.uniform();
            let edge = (grid.size.x / (cols - 1) as f32).min(grid.size.y / (rows - 1) as f32);
            let mut x: Vec<Vec3A> = model
                .rest_positions
                .iter()
                .map(|&p| {
                    let jitter = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5;
                    Vec3A::from(p * stretch + jitter * 0.02 * edge)
                })
                .collect();
            let mut w = vec![1.0f32; x.len()];
            let pinned = case % 2 == 0;
            if pinned {
                w[0] = 0.0;
            }
            let before: Vec3A = x.iter().copied().sum::<Vec3A>();
            let pin = x[0];
            let mut fp = FastProjection::new(
                model
                    .edges
                    .iter()
                    .filter(|e| e.kind == EdgeKind::Structural),
                x.len(),
            );
            fp.project(&mut x, &w, 6, 200);
            let worst = model
                .edges
                .iter()
                .filter(|e| e.kind == EdgeKind::Structural)
                .map(|e| {
                    let [a, b] = e.particles.map(|i| i as usize);
                    ((x[a] - x[b]).length() - e.rest_length).abs() / e.rest_length
                })
                .fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "case {case} ({cols} x {rows}): {worst}");
            if pinned {
                assert_eq!(x[0], pin);
            } else {
                let after: Vec3A = x.iter().copied().sum::<Vec3A>();
                assert!(
                    (after - before).length() / (x.len() as f32) < 1e-5,
                    "case {case}: the centre moved"
                );
            }
        }
    }
}
