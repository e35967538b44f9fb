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
    /// `[x0, x1, x2, x3]`, as in [`super::BendingPair`].
    pub particles: [u32; 4],
    /// The cotangent weights `K`.
    pub weights: [f32; 4],
    /// `|C| / theta` for a small fold: the pair's compliance is the cloth's bending
    /// compliance times this squared.
    pub compliance_scale: f32,
}

/// Rest dihedral angles below this (radians) count as flat.
pub const FLAT_ANGLE: f32 = 1e-3;

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

/// An isometric pair's factors for one step, which do not change within it: the inverse
/// masses times the weights, and the inverse of the denominator. With them a projection is
/// four multiply-adds and no division.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PreparedIsometric {
    /// `w_i K_i`.
    pub move_by: [f32; 4],
    /// `1 / (sum_i w_i K_i^2 + alpha~)`, or 0 if no particle of the pair is free.
    pub inverse: f32,
    /// The pair's time-step-scaled compliance `alpha~` (already times `compliance_scale^2`).
    pub alpha_tilde: f32,
}

impl PreparedIsometric {
    /// The factors of `pair` for inverse masses `w` and the pair's time-step-scaled
    /// compliance `alpha_tilde`.
    pub fn new(pair: &IsometricPair, w: &[f32], alpha_tilde: f32) -> Self {
        let k = pair.weights;
        let ws = pair.particles.map(|i| w[i as usize]);
        let weight =
            ws[0] * k[0] * k[0] + ws[1] * k[1] * k[1] + ws[2] * k[2] * k[2] + ws[3] * k[3] * k[3];
        Self {
            move_by: std::array::from_fn(|i| ws[i] * k[i]),
            inverse: if weight > 0.0 {
                1.0 / (weight + alpha_tilde)
            } else {
                0.0
            },
            alpha_tilde,
        }
    }
}

/// Projects an isometric pair with its [`PreparedIsometric`] factors: `C = sum_i K_i x_i`
/// towards zero, the accumulated multiplier `lambda` updated.
#[inline(always)]
pub fn project_isometric_prepared(
    x: &mut [Vec3A],
    pair: &IsometricPair,
    prepared: &PreparedIsometric,
    lambda: &mut Vec3A,
) {
    let [i0, i1, i2, i3] = pair.particles.map(|i| i as usize);
    let k = pair.weights;
    let m = prepared.move_by;
    let c = x[i0] * k[0] + x[i1] * k[1] + x[i2] * k[2] + x[i3] * k[3];
    let dl = (-c - *lambda * prepared.alpha_tilde) * prepared.inverse;
    *lambda += dl;
    x[i0] += dl * m[0];
    x[i1] += dl * m[1];
    x[i2] += dl * m[2];
    x[i3] += dl * m[3];
}

/// Projects an isometric pair: `C = sum_i K_i x_i` towards zero with the time-step-scaled
/// compliance `alpha_tilde` (already multiplied by the pair's `compliance_scale^2`), the
/// accumulated multiplier `lambda` updated.
#[inline(always)]
pub fn project_isometric(
    x: &mut [Vec3A],
    w: &[f32],
    pair: &IsometricPair,
    alpha_tilde: f32,
    lambda: &mut Vec3A,
) {
    let prepared = PreparedIsometric::new(pair, w, alpha_tilde);
    project_isometric_prepared(x, pair, &prepared, lambda);
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
    fn a_curved_rest_pair_is_refused() {
        let mut rest = pair();
        rest[3].y = 0.3;
        assert!(IsometricPair::new([0, 1, 2, 3], rest).is_none());
    }
}
