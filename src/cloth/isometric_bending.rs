//! Isometric bending (Bergou, Wardetzky, Harmon, Zorin and Grinspun 2006) for bending pairs
//! whose rest shape is flat, as an exact XPBD constraint.
//!
//! For a pair with shared edge `x0`-`x1` and opposite vertices `x2`, `x3`, the quadratic
//! bending energy of an isometric deformation of a flat surface is
//! `E = 3 / (2 (A0 + A1)) k |sum_i K_i x_i|^2`, with the cotangent weights
//!
//! ```text
//! K = [c03 + c04, c01 + c02, -c01 - c03, -c02 - c04]
//! ```
//!
//! where `c01`, `c02` are the cotangents of the angles at `x0` in the two triangles and `c03`,
//! `c04` those at `x1`. The vector `C = sum_i K_i x_i` is zero for any flat placement and
//! linear in the positions, so XPBD treats it as three linear constraints with one
//! denominator `sum_i w_i K_i^2 + alpha~`: no square root, no angle, one division. That makes
//! it about four times cheaper than the dihedral projection.
//!
//! The compliance is calibrated per pair so that a small fold costs the same energy as the
//! dihedral constraint with the cloth's `bend_compliance` would: `C` grows as `r theta` for a
//! fold of angle `theta` (`r` measured at build by folding the rest pair), so the pair's
//! compliance is `bend_compliance r^2`. Pairs whose rest shape is not flat keep the dihedral
//! constraint.

use bevy::math::{Quat, Vec3, Vec3A};

/// A flat bending pair in isometric form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsometricPair {
    /// `[x0, x1, x2, x3]`, as in the model's bending pairs.
    pub particles: [u32; 4],
    /// The cotangent weights `K`.
    pub weights: [f32; 4],
    /// `|C| / theta` for a small fold: the pair's compliance is the cloth's bending
    /// compliance times this squared.
    pub compliance_scale: f32,
}

/// Rest dihedral angles below this (radians) count as flat.
pub(crate) const FLAT_ANGLE: f32 = 1e-3;

fn cot(a: Vec3, b: Vec3) -> f32 {
    a.dot(b) / a.cross(b).length().max(f32::MIN_POSITIVE)
}

fn weights(x: [Vec3; 4]) -> [f32; 4] {
    let e0 = x[1] - x[0];
    let c01 = cot(e0, x[2] - x[0]);
    let c02 = cot(e0, x[3] - x[0]);
    let c03 = cot(-e0, x[2] - x[1]);
    let c04 = cot(-e0, x[3] - x[1]);
    [c03 + c04, c01 + c02, -c01 - c03, -c02 - c04]
}

fn curvature_vector(weights: &[f32; 4], x: [Vec3; 4]) -> Vec3 {
    weights.iter().zip(x).map(|(&k, p)| p * k).sum()
}

impl IsometricPair {
    /// The isometric form of the pair `particles` with rest positions `rest`, or `None` if
    /// the rest shape is not flat or a triangle is degenerate.
    pub fn new(particles: [u32; 4], rest: [Vec3; 4]) -> Option<Self> {
        let e = rest[1] - rest[0];
        let n1 = e.cross(rest[2] - rest[0]);
        let n2 = (rest[0] - rest[1]).cross(rest[3] - rest[1]);
        if e.length_squared() == 0.0 || n1.length_squared() == 0.0 || n2.length_squared() == 0.0 {
            return None;
        }
        let angle = super::constraints::dihedral_angle(
            rest[0].into(),
            rest[1].into(),
            rest[2].into(),
            rest[3].into(),
        )?;
        if angle.abs() > FLAT_ANGLE {
            return None;
        }
        let weights = weights(rest);
        if weights.iter().any(|w| !w.is_finite()) {
            return None;
        }
        // Fold the second triangle by a small angle about the edge and see how C grows.
        let fold = 1e-2;
        let turn = Quat::from_axis_angle(e.normalize(), fold);
        let mut folded = rest;
        folded[3] = rest[0] + turn * (rest[3] - rest[0]);
        let scale =
            (curvature_vector(&weights, folded) - curvature_vector(&weights, rest)).length() / fold;
        (scale.is_finite() && scale > 0.0).then_some(Self {
            particles,
            weights,
            compliance_scale: scale,
        })
    }
}

/// Isometric pairs ready for their projections.
///
/// The XPBD step of a pair is `dl = -(C + alpha~ lambda) / (sum_i w_i K_i^2 + alpha~)` and
/// `x_i += w_i K_i dl`, which with `g_i = -w_i K_i / (sum_j w_j K_j^2 + alpha~)` is
/// `x_i += g_i (C + alpha~ lambda)`. The factors `g_i` depend only on the inverse masses and
/// `alpha~`, so they are computed once ([`PreparedIsometric::prepare`]) and a projection is
/// a few multiply-adds and no division; the multiplier `lambda` (a vector, as `C` is) is
/// accumulated over a substep's iterations.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct PreparedIsometric {
    pairs: Vec<PreparedPair>,
    /// One more than the largest particle index of `pairs`.
    bound: usize,
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct PreparedPair {
    particles: [u32; 4],
    weights: [f32; 4],
    /// `g_i`.
    move_by: [f32; 4],
    /// The pair's `alpha~` (with its `compliance_scale^2`).
    alpha_tilde: f32,
    /// `-1 / (sum_j w_j K_j^2 + alpha~)`.
    step: f32,
}

impl PreparedIsometric {
    /// Computes the factors of `pairs` for inverse masses `w` and the time-step-scaled
    /// compliance `alpha_tilde` (each pair's is `alpha_tilde` times its `compliance_scale^2`).
    /// Pairs with no free particle (they would move nothing), that name a particle twice,
    /// or that name a particle `w` does not hold, are left out.
    pub(crate) fn prepare(&mut self, pairs: &[IsometricPair], w: &[f32], alpha_tilde: f32) {
        self.pairs.clear();
        self.bound = 0;
        for pair in pairs {
            let k = pair.weights;
            let [p0, p1, p2, p3] = pair.particles;
            let repeated = p0 == p1 || p0 == p2 || p0 == p3 || p1 == p2 || p1 == p3 || p2 == p3;
            if repeated || pair.particles.iter().any(|&i| i as usize >= w.len()) {
                continue;
            }
            let ws = pair.particles.map(|i| w[i as usize]);
            let weight: f32 = (0..4).map(|i| ws[i] * k[i] * k[i]).sum();
            let at = alpha_tilde * pair.compliance_scale * pair.compliance_scale;
            if weight <= 0.0 {
                continue;
            }
            let inverse = 1.0 / (weight + at);
            let move_by = std::array::from_fn(|i| -ws[i] * k[i] * inverse);
            if !move_by.iter().all(|g: &f32| g.is_finite()) {
                continue;
            }
            self.bound = self
                .bound
                .max(pair.particles.iter().max().map_or(0, |&i| i as usize + 1));
            self.pairs.push(PreparedPair {
                particles: pair.particles,
                weights: k,
                move_by,
                alpha_tilde: at,
                step: -inverse,
            });
        }
    }

    /// How many pairs were prepared (the length [`PreparedIsometric::project`] wants of its
    /// multipliers).
    pub(crate) fn len(&self) -> usize {
        self.pairs.len()
    }

    /// Projects every pair once, in order, with its multiplier `lambdas[k]` accumulated
    /// (XPBD: `dl = -(C + alpha~ lambda) / (sum_j w_j K_j^2 + alpha~)`, so repeated
    /// iterations converge to the compliance's answer rather than stiffening; zero the
    /// multipliers at the start of each substep). Does nothing if `x` does not hold every
    /// particle the pairs name or `lambdas` is not one per pair.
    pub(crate) fn project(&self, x: &mut [Vec3A], lambdas: &mut [Vec3A]) {
        if x.len() < self.bound || lambdas.len() != self.pairs.len() {
            return;
        }
        for (pair, lambda) in self.pairs.iter().zip(lambdas) {
            let [i0, i1, i2, i3] = pair.particles.map(|i| i as usize);
            let k = pair.weights;
            let g = pair.move_by;
            // SAFETY: every index is below `self.bound` (`prepare`), which `x` holds.
            unsafe {
                // The four particles of a pair are distinct (`prepare`): each is read once
                // and written once.
                let p = [i0, i1, i2, i3].map(|i| *x.get_unchecked(i));
                // C = sum_i K_i x_i with sum_i K_i = 0, taken relative to x_0: the same
                // value, without the rounding of K's sum times the absolute position (a
                // force that grows with the distance from the origin and drifts a cloth far
                // from it).
                let c = (p[1] - p[0]) * k[1]
                    + (p[2] - p[0]) * k[2]
                    + (p[3] - p[0]) * k[3]
                    + *lambda * pair.alpha_tilde;
                *lambda += c * pair.step;
                *x.get_unchecked_mut(i0) = p[0] + c * g[0];
                *x.get_unchecked_mut(i1) = p[1] + c * g[1];
                *x.get_unchecked_mut(i2) = p[2] + c * g[2];
                *x.get_unchecked_mut(i3) = p[3] + c * g[3];
            }
        }
    }
}

#[cfg(test)]
/// Projects an isometric pair: `C = sum_i K_i x_i` towards zero with the time-step-scaled
/// compliance `alpha_tilde` (already multiplied by the pair's `compliance_scale^2`), the
/// accumulated multiplier `lambda` updated.
#[inline(always)]
pub(crate) fn project_isometric(
    x: &mut [Vec3A],
    w: &[f32],
    pair: &IsometricPair,
    alpha_tilde: f32,
    lambda: &mut Vec3A,
) {
    let [i0, i1, i2, i3] = pair.particles.map(|i| i as usize);
    let k = pair.weights;
    let weight =
        w[i0] * k[0] * k[0] + w[i1] * k[1] * k[1] + w[i2] * k[2] * k[2] + w[i3] * k[3] * k[3];
    if weight <= 0.0 {
        return;
    }
    let c = (x[i1] - x[i0]) * k[1] + (x[i2] - x[i0]) * k[2] + (x[i3] - x[i0]) * k[3];
    let dl = (-c - *lambda * alpha_tilde) / (weight + alpha_tilde);
    *lambda += dl;
    x[i0] += dl * (w[i0] * k[0]);
    x[i1] += dl * (w[i1] * k[1]);
    x[i2] += dl * (w[i2] * k[2]);
    x[i3] += dl * (w[i3] * k[3]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::constraints::dihedral_angle;

    fn pair() -> [Vec3; 4] {
        [
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.1),
            Vec3::new(0.3, 0.0, -0.8),
            Vec3::new(0.6, 0.0, 1.1),
        ]
    }

    #[test]
    fn flat_placements_have_zero_curvature_vector() {
        let rest = pair();
        let iso = IsometricPair::new([0, 1, 2, 3], rest).unwrap();
        let moved = rest.map(|p| Quat::from_rotation_z(0.7) * p + Vec3::new(3.0, -1.0, 2.0));
        assert!(curvature_vector(&iso.weights, moved).length() < 1e-5);
    }

    #[test]
    fn small_folds_cost_the_dihedral_energy() {
        let rest = pair();
        let iso = IsometricPair::new([0, 1, 2, 3], rest).unwrap();
        for angle in [0.01f32, 0.05, -0.1] {
            let e = (rest[1] - rest[0]).normalize();
            let mut folded = rest;
            folded[2] = rest[0] + Quat::from_axis_angle(e, angle) * (rest[2] - rest[0]);
            let theta = dihedral_angle(
                folded[0].into(),
                folded[1].into(),
                folded[2].into(),
                folded[3].into(),
            )
            .unwrap();
            let c = curvature_vector(&iso.weights, folded).length();
            // Energy with compliance alpha r^2 equals the dihedral energy with alpha.
            let ratio = (c / iso.compliance_scale) / theta.abs();
            assert!((ratio - 1.0).abs() < 0.02, "angle {angle}: ratio {ratio}");
        }
    }

    #[test]
    fn a_prepared_projection_is_the_first_xpbd_projection() {
        let rest = pair();
        let iso = IsometricPair::new([0, 1, 2, 3], rest).unwrap();
        // Folded, one particle pinned, the others of different masses.
        let mut folded = rest.map(Vec3A::from);
        folded[2].y += 0.2;
        let w = [0.0, 2.0, 1.0, 0.5];
        let alpha_tilde = 0.3;
        let mut general = folded;
        let mut lambda = Vec3A::ZERO;
        let at = alpha_tilde * iso.compliance_scale * iso.compliance_scale;
        project_isometric(&mut general, &w, &iso, at, &mut lambda);
        let mut prepared = PreparedIsometric::default();
        // A pair naming a particle `w` does not hold is left out.
        let outside = IsometricPair {
            particles: [0, 1, 2, 9],
            ..iso
        };
        prepared.prepare(&[iso, outside], &w, alpha_tilde);
        assert_eq!(prepared.len(), 1);
        let mut fast = folded;
        let mut lambdas = [Vec3A::ZERO];
        prepared.project(&mut fast, &mut lambdas);
        for (a, b) in fast.iter().zip(&general) {
            assert!(a.distance(*b) < 1e-6, "{a} {b}");
        }
        assert!(lambdas[0].distance(lambda) < 1e-6);
        assert_eq!(fast[0], folded[0]);
        assert!(fast[2].distance(folded[2]) > 1e-3, "the fold was corrected");
        // And every later projection is the general one's with the multiplier it accumulated.
        for _ in 0..5 {
            project_isometric(&mut general, &w, &iso, at, &mut lambda);
            prepared.project(&mut fast, &mut lambdas);
            for (a, b) in fast.iter().zip(&general) {
                assert!(a.distance(*b) < 1e-5, "{a} {b}");
            }
            assert!(lambdas[0].distance(lambda) < 1e-5);
        }
    }

    #[test]
    fn a_curved_rest_pair_is_refused() {
        let mut rest = pair();
        rest[3].y = 0.3;
        assert!(IsometricPair::new([0, 1, 2, 3], rest).is_none());
    }
}
