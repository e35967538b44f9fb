//! Constraint functions and their projections, on plain slices.
//!
//! Every projection here is one XPBD update (Macklin, Mueller and Chentanez 2016): for a
//! constraint `C(x) = 0` with gradients `grad_i C`, inverse masses `w_i`, compliance `alpha`
//! (the inverse stiffness) and substep `h`,
//!
//! ```text
//! alpha~   = alpha / h^2
//! dlambda  = (-C - alpha~ lambda) / (sum_i w_i |grad_i C|^2 + alpha~)
//! lambda  += dlambda
//! x_i     += w_i grad_i C dlambda
//! ```
//!
//! `lambda` accumulates over the iterations of one substep and is reset to zero at the start
//! of each substep. With `alpha = 0` the update is the plain PBD projection with stiffness 1.
//!
//! Plain PBD (Mueller et al. 2006) instead scales each projection by a stiffness `k` in
//! (0, 1] and has no `lambda`; its effective stiffness depends on the iteration count and the
//! time step, which is what XPBD fixes. [`Projection`] selects one or the other.

use bevy::math::Vec3A;

/// How a constraint is projected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// XPBD with the given time-step-scaled compliance `alpha / h^2`.
    Xpbd {
        /// `alpha / h^2`.
        alpha_tilde: f32,
    },
    /// Plain PBD with the per-iteration stiffness `k'` in (0, 1].
    Pbd {
        /// The per-iteration stiffness.
        stiffness: f32,
    },
}

impl Projection {
    /// The multiplier update for a constraint value `c`, the weighted squared gradient norm
    /// `weight = sum_i w_i |grad_i C|^2`, and the accumulated multiplier `lambda` (updated).
    #[inline(always)]
    pub fn delta_lambda(self, c: f32, weight: f32, lambda: &mut f32) -> f32 {
        match self {
            Projection::Xpbd { alpha_tilde } => {
                let d = (-c - alpha_tilde * *lambda) / (weight + alpha_tilde);
                *lambda += d;
                d
            }
            Projection::Pbd { stiffness } => -stiffness * c / weight,
        }
    }
}

/// Projects the distance constraint `C = |x_a - x_b| - rest`.
#[inline(always)]
pub fn project_distance(
    x: &mut [Vec3A],
    w: &[f32],
    [a, b]: [u32; 2],
    rest: f32,
    projection: Projection,
    lambda: &mut f32,
) {
    let (a, b) = (a as usize, b as usize);
    let (wa, wb) = (w[a], w[b]);
    let weight = wa + wb;
    if weight == 0.0 {
        return;
    }
    let d = x[a] - x[b];
    let len = d.length();
    if len <= f32::EPSILON * rest {
        return;
    }
    let dl = projection.delta_lambda(len - rest, weight, lambda);
    let correction = d * (dl / len);
    x[a] += correction * wa;
    x[b] -= correction * wb;
}

/// A long-range attachment (Kim, Chentanez and Mueller 2012): particle `particle` may be at
/// most `length` from the pinned particle `anchor`. Only the free particle moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tether {
    /// The free particle.
    pub particle: u32,
    /// The pinned particle.
    pub anchor: u32,
    /// The largest allowed distance, metres.
    pub length: f32,
}

/// Coulomb friction on positions (Macklin et al. 2014, "Unified particle physics", eq. 24):
/// of a contact's `relative` displacement over the substep, the tangential part (across the
/// unit `normal`) that friction removes: all of it if it is within `limit` (friction times
/// the penetration; static), else `limit` of its length (kinetic).
pub(crate) fn friction_removed(relative: Vec3A, normal: Vec3A, limit: f32) -> Vec3A {
    let tangential = relative - normal * normal.dot(relative);
    let slip = tangential.length();
    if slip <= limit {
        tangential
    } else {
        tangential * (limit / slip)
    }
}

// For the scalar batch kernels (`batch/scalar.rs`), built off `x86_64` and in the tests.
#[cfg(any(test, not(all(target_arch = "x86_64", target_feature = "sse2"))))]
/// Projects the unilateral tether constraint `|x_p - x_anchor| <= length` (stiffness 1).
#[inline(always)]
pub(crate) fn project_tether(x: &mut [Vec3A], w: &[f32], tether: &Tether) {
    let p = tether.particle as usize;
    // A particle held in place for now (grabbed) is not pulled back.
    if w[p] == 0.0 {
        return;
    }
    let anchor = x[tether.anchor as usize];
    let d = x[p] - anchor;
    let len_sq = d.length_squared();
    if len_sq > tether.length * tether.length {
        let len = len_sq.sqrt();
        x[p] = anchor + d * (tether.length / len);
    }
}

/// The signed dihedral angle of the triangles `(x0, x1, x2)` and `(x1, x0, x3)` about their
/// shared edge `x0`-`x1`, in (-pi, pi]: 0 when flat, positive when the triangles fold toward
/// their front faces. `None` if a triangle is degenerate.
#[inline(always)]
pub(crate) fn dihedral_angle(x0: Vec3A, x1: Vec3A, x2: Vec3A, x3: Vec3A) -> Option<f32> {
    dihedral_angle_and_gradients(x0, x1, x2, x3).map(|(theta, _)| theta)
}

/// The signed dihedral angle (see [`dihedral_angle`]) and its gradients with respect to
/// `x0..x3`.
///
/// With `e = x1 - x0`, unit normals `n1` of `(x0, x1, x2)` and `n2` of `(x1, x0, x3)`, heights
/// `h1`, `h2` of `x2`, `x3` above the edge line, and `s2`, `s3` the positions of the feet of
/// those heights along `e` (0 at `x0`, 1 at `x1`):
///
/// ```text
/// theta      = atan2((n1 x n2) . e/|e|, n1 . n2)
/// d theta/dx2 = -n1 / h1          d theta/dx3 = -n2 / h2
/// d theta/dx0 = -(1 - s2) d theta/dx2 - (1 - s3) d theta/dx3
/// d theta/dx1 = -s2 d theta/dx2 - s3 d theta/dx3
/// ```
///
/// (the opposite vertices turn their triangle about the edge; the edge vertices take the
/// reaction in proportion to the lever arms, so the gradients sum to zero and exert no net
/// torque). The atan2 form has no singularity at the flat state, unlike the `acos(n1 . n2)`
/// form of Mueller et al. 2006, whose gradient is undefined there.
#[inline(always)]
pub(crate) fn dihedral_angle_and_gradients(
    x0: Vec3A,
    x1: Vec3A,
    x2: Vec3A,
    x3: Vec3A,
) -> Option<(f32, [Vec3A; 4])> {
    let e = x1 - x0;
    let e_len_sq = e.length_squared();
    let m1 = e.cross(x2 - x0);
    let m2 = (x0 - x1).cross(x3 - x1);
    let m1_len_sq = m1.length_squared();
    let m2_len_sq = m2.length_squared();
    let tiny = 1e-12 * e_len_sq * e_len_sq;
    if e_len_sq == 0.0 || m1_len_sq <= tiny || m2_len_sq <= tiny {
        return None;
    }
    let e_len = e_len_sq.sqrt();
    // atan2 is scale invariant, so the unnormalised normals m1, m2 give the angle directly.
    let theta = fast_atan2(m1.cross(m2).dot(e) / e_len, m1.dot(m2));
    // |m| = 2 area = h |e|, so n / h = m |e| / |m|^2.
    let g2 = -m1 * (e_len / m1_len_sq);
    let g3 = -m2 * (e_len / m2_len_sq);
    let s2 = (x2 - x0).dot(e) / e_len_sq;
    let s3 = (x3 - x0).dot(e) / e_len_sq;
    let g0 = -(1.0 - s2) * g2 - (1.0 - s3) * g3;
    let g1 = -s2 * g2 - s3 * g3;
    Some((theta, [g0, g1, g2, g3]))
}

/// `atan2(y, x)` within 2e-5 rad, about four times faster than the libm call: octant
/// reduction to `z` in [0, 1] and an odd degree-11 polynomial for `atan(z)`.
#[inline(always)]
pub(crate) fn fast_atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if den == 0.0 {
        return 0.0;
    }
    let z = num / den;
    let z2 = z * z;
    let mut r = z
        * (0.999_977_26
            + z2 * (-0.332_623_47
                + z2 * (0.193_543_46
                    + z2 * (-0.116_432_87 + z2 * (0.052_653_32 + z2 * -0.011_721_2)))));
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 { -r } else { r }
}

/// Wraps an angle difference into (-pi, pi].
#[inline(always)]
fn wrap_angle(a: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    if a > PI {
        a - TAU
    } else if a <= -PI {
        a + TAU
    } else {
        a
    }
}

/// Projects the dihedral bending constraint `C = theta - rest_angle` of the bending pair
/// `particles` (see [`dihedral_angle_and_gradients`]).
#[inline(always)]
pub(crate) fn project_bending(
    x: &mut [Vec3A],
    w: &[f32],
    particles: [u32; 4],
    rest_angle: f32,
    projection: Projection,
    lambda: &mut f32,
) {
    let [i0, i1, i2, i3] = particles.map(|i| i as usize);
    let Some((theta, g)) = dihedral_angle_and_gradients(x[i0], x[i1], x[i2], x[i3]) else {
        return;
    };
    let ws = [w[i0], w[i1], w[i2], w[i3]];
    let weight = ws[0] * g[0].length_squared()
        + ws[1] * g[1].length_squared()
        + ws[2] * g[2].length_squared()
        + ws[3] * g[3].length_squared();
    if weight <= 0.0 {
        return;
    }
    let dl = projection.delta_lambda(wrap_angle(theta - rest_angle), weight, lambda);
    x[i0] += g[0] * (ws[0] * dl);
    x[i1] += g[1] * (ws[1] * dl);
    x[i2] += g[2] * (ws[2] * dl);
    x[i3] += g[3] * (ws[3] * dl);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic gradients of the dihedral angle match central differences.
    #[test]
    fn dihedral_gradients_match_finite_differences() {
        let base = [
            Vec3A::new(0.1, -0.2, 0.05),
            Vec3A::new(1.0, 0.1, -0.1),
            Vec3A::new(0.4, 0.9, 0.3),
            Vec3A::new(0.6, -0.8, 0.5),
        ];
        let angle = |x: &[Vec3A; 4]| dihedral_angle(x[0], x[1], x[2], x[3]).unwrap();
        let (theta, grads) = dihedral_angle_and_gradients(base[0], base[1], base[2], base[3])
            .expect("not degenerate");
        assert!(theta.abs() > 0.1);
        let eps = 1e-3;
        for v in 0..4 {
            for axis in 0..3 {
                let mut plus = base;
                let mut minus = base;
                plus[v][axis] += eps;
                minus[v][axis] -= eps;
                let numeric = (angle(&plus) - angle(&minus)) / (2.0 * eps);
                let analytic = grads[v][axis];
                assert!(
                    (numeric - analytic).abs() < 2e-3 * (1.0 + analytic.abs()),
                    "vertex {v} axis {axis}: numeric {numeric}, analytic {analytic}"
                );
            }
        }
    }

    #[test]
    fn fast_atan2_matches_the_library_within_2e_5_rad() {
        let mut worst = 0.0f32;
        for i in 0..720 {
            let a = (i as f32 + 0.37) * std::f32::consts::TAU / 720.0;
            for r in [1e-3f32, 0.5, 1.0, 7.0, 1e4] {
                let (y, x) = (r * a.sin(), r * a.cos());
                worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
            }
        }
        for (y, x) in [(0.0, 1.0), (1.0, 0.0), (0.0, -1.0), (-1.0, 0.0), (1.0, 1.0)] {
            let y: f32 = y;
            worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
        }
        assert!(worst < 2e-5, "worst error {worst}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }

    #[test]
    fn flat_pair_has_zero_angle_and_folding_up_is_positive() {
        let x0 = Vec3A::ZERO;
        let x1 = Vec3A::X;
        // Triangle (x0, x1, x2) faces +Y when x2 is on the -Z side.
        let x2 = Vec3A::new(0.5, 0.0, -1.0);
        let x3 = Vec3A::new(0.5, 0.0, 1.0);
        assert!(dihedral_angle(x0, x1, x2, x3).unwrap().abs() < 1e-6);
        let up = dihedral_angle(x0, x1, x2, Vec3A::new(0.5, 0.5, 1.0)).unwrap();
        let down = dihedral_angle(x0, x1, x2, Vec3A::new(0.5, -0.5, 1.0)).unwrap();
        assert!(up * down < 0.0);
        assert!(dihedral_angle(x0, x1, x0, x3).is_none());
    }

    #[test]
    fn a_distance_projection_with_zero_compliance_restores_the_rest_length() {
        let mut x = [Vec3A::ZERO, Vec3A::new(2.0, 0.0, 0.0)];
        let mut lambda = 0.0;
        project_distance(
            &mut x,
            &[1.0, 3.0],
            [0, 1],
            1.0,
            Projection::Xpbd { alpha_tilde: 0.0 },
            &mut lambda,
        );
        assert!((x[0].distance(x[1]) - 1.0).abs() < 1e-6);
        // Momentum: the heavier particle (w = 1) moved a third as far as the lighter one.
        assert!((x[0].x - 0.25).abs() < 1e-6 && (x[1].x - 1.25).abs() < 1e-6);
    }
}
