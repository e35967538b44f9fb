//! The volume (pressure) constraint of a closed cloth (Müller et al. 2006, section 4.4, in
//! XPBD form): `C = V - k V0`, where `V` is the volume the surface encloses, the sum over its
//! triangles of the signed tetrahedra they span with a reference point `c`,
//! `V = sum (x_a - c) x (x_b - c) . (x_c - c) / 6`, `V0` the rest volume and `k` the pressure
//! factor (1 keeps the rest volume, 2 doubles it). On a closed surface `V` does not depend on
//! `c`, and neither does its gradient: for particle `i`,
//! `dV/dx_i = sum over its triangles (a, b, c) ordered to start at i of (x_b - c) x (x_c - c) / 6`.
//! The projection is the usual XPBD one with `alpha~ = compliance / h^2` and an accumulated
//! multiplier, once per iteration.

use bevy::math::Vec3A;
use bevy::reflect::Reflect;

use super::model::ClothModel;
use crate::error::ClothError;

/// Settings of the volume constraint.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct VolumeSettings {
    /// The target volume as a multiple of the rest volume. Default: `1.0`.
    pub pressure: f32,
    /// Compliance of the constraint, 1/Pa (m^3 per N m). Default: `0.0` (exact).
    pub compliance: f32,
}

impl Default for VolumeSettings {
    fn default() -> Self {
        Self {
            pressure: 1.0,
            compliance: 0.0,
        }
    }
}

/// The volume constraint of one closed cloth.
#[derive(Clone, Debug)]
pub(crate) struct VolumeConstraint {
    triangles: Vec<[u32; 3]>,
    rest_volume: f32,
    gradients: Vec<Vec3A>,
    lambda: f32,
}

/// Whether `triangles` form a closed, consistently oriented surface: every edge is shared by
/// exactly two triangles that run along it in opposite directions.
pub(crate) fn check_closed(triangles: &[[u32; 3]]) -> Result<(), ClothError> {
    let mut directed: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .collect();
    directed.sort_unstable();
    let mut open = 0usize;
    for &(a, b) in &directed {
        // Each directed edge needs its reverse exactly once, and itself only once.
        let reverse = directed.binary_search(&(b, a)).is_ok();
        let count =
            directed.partition_point(|&e| e <= (a, b)) - directed.partition_point(|&e| e < (a, b));
        if !reverse || count != 1 {
            open += 1;
        }
    }
    if open > 0 {
        return Err(ClothError::OpenSurface {
            boundary_edges: open,
        });
    }
    Ok(())
}

/// The volume `triangles` enclose over `x` (positive for triangles counter-clockwise seen
/// from outside), m^3.
pub(crate) fn enclosed_volume(x: &[Vec3A], triangles: &[[u32; 3]]) -> f32 {
    let Some(&c) = triangles.first().map(|t| &x[t[0] as usize]) else {
        return 0.0;
    };
    triangles
        .iter()
        .map(|&[a, b, d]| {
            let (pa, pb, pd) = (x[a as usize] - c, x[b as usize] - c, x[d as usize] - c);
            pa.cross(pb).dot(pd)
        })
        .sum::<f32>()
        / 6.0
}

impl VolumeConstraint {
    /// The constraint of `model`'s surface at its rest shape, or
    /// [`ClothError::OpenSurface`] if the surface is not closed.
    pub(crate) fn new(model: &ClothModel) -> Result<Self, ClothError> {
        if model.triangles.is_empty() {
            return Err(ClothError::NoTriangles);
        }
        check_closed(&model.triangles)?;
        let rest: Vec<Vec3A> = model.rest_positions.iter().map(|&p| p.into()).collect();
        let mut triangles = model.triangles.clone();
        let mut rest_volume = enclosed_volume(&rest, &triangles);
        if rest_volume < 0.0 {
            // Inward-facing triangles: turn them around.
            for t in &mut triangles {
                t.swap(1, 2);
            }
            rest_volume = -rest_volume;
        }
        Ok(Self {
            triangles,
            rest_volume,
            gradients: vec![Vec3A::ZERO; rest.len()],
            lambda: 0.0,
        })
    }

    /// The rest volume, m^3.
    pub(crate) fn rest_volume(&self) -> f32 {
        self.rest_volume
    }

    /// The enclosed volume of `x`, m^3.
    pub(crate) fn volume(&self, x: &[Vec3A]) -> f32 {
        enclosed_volume(x, &self.triangles)
    }

    /// Starts a substep: the multiplier goes back to zero.
    pub(crate) fn reset_multiplier(&mut self) {
        self.lambda = 0.0;
    }

    /// One XPBD projection towards `pressure * rest volume` with `alpha_tilde`.
    pub(crate) fn project(&mut self, x: &mut [Vec3A], w: &[f32], pressure: f32, alpha_tilde: f32) {
        if self.gradients.len() != x.len() || self.triangles.is_empty() {
            return;
        }
        let c = x[self.triangles[0][0] as usize];
        self.gradients.fill(Vec3A::ZERO);
        let mut volume = 0.0;
        for &[a, b, d] in &self.triangles {
            let (pa, pb, pd) = (x[a as usize] - c, x[b as usize] - c, x[d as usize] - c);
            volume += pa.cross(pb).dot(pd);
            self.gradients[a as usize] += pb.cross(pd);
            self.gradients[b as usize] += pd.cross(pa);
            self.gradients[d as usize] += pa.cross(pb);
        }
        volume /= 6.0;
        let constraint = volume - pressure * self.rest_volume;
        let mut weight = 0.0;
        for (g, &wi) in self.gradients.iter_mut().zip(w) {
            *g /= 6.0;
            weight += wi * g.length_squared();
        }
        if weight + alpha_tilde <= 0.0 {
            return;
        }
        let delta = (-constraint - alpha_tilde * self.lambda) / (weight + alpha_tilde);
        if !delta.is_finite() {
            return;
        }
        self.lambda += delta;
        for ((xi, g), &wi) in x.iter_mut().zip(&self.gradients).zip(w) {
            *xi += *g * (wi * delta);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Vec3;

    /// A unit cube's 12 triangles, counter-clockwise from outside.
    fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|q: &[u32; 4]| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        (p, t)
    }

    #[test]
    fn the_cube_encloses_one_cubic_metre_and_the_gradient_is_the_derivative() {
        let (p, t) = cube();
        let x: Vec<Vec3A> = p.iter().map(|&v| v.into()).collect();
        assert!((enclosed_volume(&x, &t) - 1.0).abs() < 1e-6);
        check_closed(&t).unwrap();
        let model = ClothModel::from_triangles(&p, &t.concat(), 1.0).unwrap();
        let mut vc = VolumeConstraint::new(&model).unwrap();
        // A projection towards twice the volume moves along the gradient; check it against a
        // finite difference of the volume.
        let w = vec![1.0; 8];
        let mut y = x.clone();
        vc.project(&mut y, &w, 2.0, 0.0);
        let step = 1e-3;
        for i in 0..8 {
            let g = (y[i] - x[i]).normalize();
            let mut z = x.clone();
            z[i] += g * step;
            let dv = (enclosed_volume(&z, &t) - 1.0) / step;
            assert!(dv > 0.0, "moving {i} along its correction grows the volume");
        }
        let grown = enclosed_volume(&y, &t);
        assert!(grown > 1.5, "{grown}");
    }

    #[test]
    fn an_open_box_is_refused_with_its_boundary() {
        let (_, t) = cube();
        match check_closed(&t[2..]) {
            Err(ClothError::OpenSurface { boundary_edges }) => assert_eq!(boundary_edges, 4),
            other => panic!("{other:?}"),
        }
    }
}
