//! The SPH smoothing kernels of Müller et al. 2003 that Position Based Fluids uses: poly6
//! for the density, the spiky kernel's gradient for the density constraint's gradients
//! (poly6's gradient vanishes at the centre, so particles that close in would not push
//! apart).

use std::f32::consts::PI;

use bevy::math::Vec3A;

/// The kernels for one smoothing radius `h`, their constants computed once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Kernels {
    /// The smoothing radius, metres.
    pub h: f32,
    h2: f32,
    poly6: f32,
    spiky_gradient: f32,
}

impl Kernels {
    /// The kernels with smoothing radius `h` (> 0).
    pub(crate) fn new(h: f32) -> Self {
        Self {
            h,
            h2: h * h,
            poly6: 315.0 / (64.0 * PI * h.powi(9)),
            spiky_gradient: -45.0 / (PI * h.powi(6)),
        }
    }

    /// `W_poly6(r) = 315 / (64 pi h^9) (h^2 - r^2)^3` for `r < h`, else 0; from `r^2`.
    #[inline(always)]
    pub(crate) fn poly6(&self, r2: f32) -> f32 {
        if r2 >= self.h2 {
            return 0.0;
        }
        let d = self.h2 - r2;
        self.poly6 * d * d * d
    }

    /// `grad W_spiky(r) = -45 / (pi h^6) (h - |r|)^2 r / |r|` for `0 < |r| < h`, else 0.
    #[inline(always)]
    pub(crate) fn spiky_gradient(&self, r: Vec3A) -> Vec3A {
        let len2 = r.length_squared();
        if len2 >= self.h2 || len2 <= 1e-24 {
            return Vec3A::ZERO;
        }
        let len = len2.sqrt();
        let d = self.h - len;
        r * (self.spiky_gradient * d * d / len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn poly6_integrates_to_one_and_the_spiky_gradient_is_minus_its_kernels_slope() {
        for h in [0.02f32, 0.1, 0.7] {
            let k = Kernels::new(h);
            // The integral over the ball, by shells: 4 pi r^2 W(r) dr.
            let n = 20_000;
            let dr = h / n as f32;
            let integral: f64 = (0..n)
                .map(|i| {
                    let r = (i as f32 + 0.5) * dr;
                    4.0 * PI as f64 * (r * r) as f64 * k.poly6(r * r) as f64 * dr as f64
                })
                .sum();
            assert!((integral - 1.0).abs() < 1e-4, "h {h}: {integral}");
            // The spiky kernel 15 / (pi h^6) (h - r)^3 differentiated numerically.
            let spiky = |r: f32| 15.0 / (PI * h.powi(6)) * (h - r).powi(3);
            let mut rng = Rng(0x1234_5678_9abc_def1 ^ h.to_bits() as u64);
            for _ in 0..50 {
                let dir = Vec3A::from(rng.unit_vector());
                let r = h * (0.05 + 0.9 * rng.uniform());
                let e = h * 1e-3;
                let slope = (spiky(r + e) - spiky(r - e)) / (2.0 * e);
                let g = k.spiky_gradient(dir * r);
                assert!(
                    (g - dir * slope).length() <= 1e-3 * slope.abs(),
                    "{g} {slope}"
                );
            }
            assert_eq!(k.poly6(h * h), 0.0);
            assert_eq!(k.spiky_gradient(Vec3A::ZERO), Vec3A::ZERO);
            assert_eq!(k.spiky_gradient(Vec3A::X * h * 1.01), Vec3A::ZERO);
        }
    }
}
