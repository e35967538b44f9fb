//! Counting cloth crossings: how many times, between two poses of a cloth, a particle went
//! through one of its triangles (or through another cloth's), the failure self-collision and
//! layered garments exist to prevent.
//!
//! A particle `q` crosses a triangle `t` (not one of its own) when its signed distance from
//! the triangle's plane changes sign between the two poses, `d0 d1 < 0`, and at the moment the
//! straight-line motion of both brings it to the plane, `tau = d0 / (d0 - d1)`, it lies over
//! the triangle (its barycentric coordinates there at least `-BARYCENTRIC_SLACK`) and within
//! [`CROSSING_REACH`] thicknesses of its plane (the plane moves too, so `d(tau)` is only
//! nearly zero; a point far from a triangle that turns over changes side without coming near
//! it, and is not counted). A particle resting in the plane (`d = 0`) has no side and does not
//! count.
//!
//! The count is a measurement, run between fixed steps (the `scenes` runner, the tests), not
//! part of the step: every particle against every triangle whose box, swept between the two
//! poses, meets the particle's swept box.

use bevy::math::Vec3A;

use crate::collide::vertex_contacts::plane_coordinates;

/// How many thicknesses from the triangle's plane a particle may be at the interpolated
/// moment of crossing and still count (see the module docs).
pub const CROSSING_REACH: f32 = 3.0;

/// How far outside its triangle (in barycentric coordinates) a crossing may be: a particle
/// through a shared edge counts for one of the two triangles at least.
const BARYCENTRIC_SLACK: f32 = 1e-4;

/// A cloth's particles at two moments.
#[derive(Clone, Copy, Debug)]
pub struct TwoPoses<'a> {
    /// The earlier positions.
    pub before: &'a [Vec3A],
    /// The later positions, one per earlier one.
    pub after: &'a [Vec3A],
}

/// The crossings of a cloth through its own triangles between two poses: every particle
/// against every triangle it is not a corner of. Particles or corners out of range, and
/// positions that are not finite, are left out.
pub fn count_self_crossings(cloth: TwoPoses, triangles: &[[u32; 3]], thickness: f32) -> usize {
    count(cloth, cloth, triangles, thickness, true)
}

/// The crossings of the particles of one cloth (`particles`) through the triangles of
/// another (`surface`, with its `triangles`) between two poses.
pub fn count_crossings_between(
    particles: TwoPoses,
    surface: TwoPoses,
    triangles: &[[u32; 3]],
    thickness: f32,
) -> usize {
    count(particles, surface, triangles, thickness, false)
}

/// The box of `points` grown by `margin`.
fn bounds(points: impl IntoIterator<Item = Vec3A>, margin: f32) -> (Vec3A, Vec3A) {
    let (min, max) = points.into_iter().fold(
        (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY)),
        |(min, max), p| (min.min(p), max.max(p)),
    );
    (min - Vec3A::splat(margin), max + Vec3A::splat(margin))
}

fn count(
    particles: TwoPoses,
    surface: TwoPoses,
    triangles: &[[u32; 3]],
    thickness: f32,
    own: bool,
) -> usize {
    let reach = CROSSING_REACH * thickness.max(0.0);
    let n = particles.before.len().min(particles.after.len());
    let corners = surface.before.len().min(surface.after.len());
    let mut crossings = 0;
    for &[a, b, c] in triangles {
        let ids = [a as usize, b as usize, c as usize];
        if ids.iter().any(|&i| i >= corners) {
            continue;
        }
        let t0 = ids.map(|i| surface.before[i]);
        let t1 = ids.map(|i| surface.after[i]);
        if !t0.iter().chain(&t1).all(|p| p.is_finite()) {
            continue;
        }
        let (min, max) = bounds(t0.iter().chain(&t1).copied(), reach);
        for q in 0..n {
            if own && ids.contains(&q) {
                continue;
            }
            let (q0, q1) = (particles.before[q], particles.after[q]);
            if !(q0.is_finite() && q1.is_finite()) {
                continue;
            }
            let (q_min, q_max) = (q0.min(q1), q0.max(q1));
            if q_max.cmplt(min).any() || q_min.cmpgt(max).any() {
                continue;
            }
            if crosses(q0, q1, t0, t1, reach) {
                crossings += 1;
            }
        }
    }
    crossings
}

/// Whether `q` moving from `q0` to `q1` goes through the triangle moving from `t0` to `t1`
/// (see the module docs). A degenerate triangle has no sides.
fn crosses(q0: Vec3A, q1: Vec3A, t0: [Vec3A; 3], t1: [Vec3A; 3], reach: f32) -> bool {
    let height = |q: Vec3A, [a, b, c]: [Vec3A; 3]| plane_coordinates(q, a, b, c);
    let (Some((_, _, d0)), Some((_, _, d1))) = (height(q0, t0), height(q1, t1)) else {
        return false;
    };
    if d0 * d1 >= 0.0 {
        return false;
    }
    let tau = d0 / (d0 - d1);
    let t = [0, 1, 2].map(|k| t0[k].lerp(t1[k], tau));
    height(q0.lerp(q1, tau), t).is_some_and(|(barycentric, _, d)| {
        d.abs() <= reach.max(1e-6) && barycentric.min_element() >= -BARYCENTRIC_SLACK
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    const H: f32 = 0.005;

    /// One triangle in the plane z = 0 (corners 0, 1, 2) and one particle (3).
    fn scene(q0: Vec3A, q1: Vec3A) -> usize {
        let tri = [
            Vec3A::new(0.0, 0.0, 0.0),
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
        ];
        let before = [tri[0], tri[1], tri[2], q0];
        let after = [tri[0], tri[1], tri[2], q1];
        count_self_crossings(
            TwoPoses {
                before: &before,
                after: &after,
            },
            &[[0, 1, 2]],
            H,
        )
    }

    #[test]
    fn a_particle_through_a_triangle_counts_one_beside_it_or_resting_none() {
        let at = |x: f32, y: f32, z: f32| Vec3A::new(x, y, z);
        // Straight through, slowly and fast (8 cm in a step).
        assert_eq!(scene(at(0.2, 0.2, 0.002), at(0.2, 0.2, -0.002)), 1);
        assert_eq!(scene(at(0.2, 0.2, 0.04), at(0.25, 0.2, -0.04)), 1);
        // Beside the triangle, through its plane.
        assert_eq!(scene(at(0.8, 0.8, 0.01), at(0.8, 0.8, -0.01)), 0);
        // Approaching, resting on it, leaving on the side it came from.
        assert_eq!(scene(at(0.2, 0.2, 0.01), at(0.2, 0.2, 0.001)), 0);
        assert_eq!(scene(at(0.2, 0.2, 0.0), at(0.2, 0.2, -0.01)), 0);
        // Not finite: left out.
        assert_eq!(scene(at(0.2, 0.2, 0.01), at(f32::NAN, 0.2, -0.01)), 0);
    }

    #[test]
    fn a_triangle_turning_over_away_from_a_particle_is_no_crossing() {
        // The particle stays 0.5 m above the triangle's centre while the triangle turns over
        // (its normal reverses): the side changes, but nothing came near.
        let before = [
            Vec3A::new(0.0, 0.0, 0.0),
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
            Vec3A::new(0.3, 0.3, 0.5),
        ];
        let mut after = before;
        after.swap(1, 2);
        let poses = TwoPoses {
            before: &before,
            after: &after,
        };
        assert_eq!(count_self_crossings(poses, &[[0, 1, 2]], H), 0);
        // The triangle turns a quarter over about its edge on the x axis while the particle
        // moves from 10 cm in front of it to 30 cm behind: the straight-line motions bring it
        // over the triangle but still 5 cm from its plane at the moment the sides swap, which
        // is not coming within reach.
        let before = [
            Vec3A::new(0.0, 0.0, 0.0),
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(0.0, 1.0, 0.0),
            Vec3A::new(0.2, 0.2, 0.1),
        ];
        let after = [
            Vec3A::new(0.0, 0.0, 0.0),
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(0.0, 0.0, 1.0),
            Vec3A::new(0.2, 0.3, 0.2),
        ];
        let poses = TwoPoses {
            before: &before,
            after: &after,
        };
        assert_eq!(count_self_crossings(poses, &[[0, 1, 2]], H), 0);
        // Within reach (a thickness of 2 cm: 6 cm of reach), it counts.
        assert_eq!(count_self_crossings(poses, &[[0, 1, 2]], 0.02), 1);
    }

    #[test]
    fn random_sheets_passing_through_each_other_count_each_particle_over_the_other_once() {
        // A flat n x n sheet moved straight through another at a random offset that keeps its
        // particles off the other's grid lines and diagonals: every particle over the other
        // sheet's square crosses exactly one triangle, the rest none; stopping short, none.
        let mut rng = Rng(3);
        let n = 6;
        let spacing = 0.1;
        let sheet = |offset: Vec3A| {
            (0..n * n)
                .map(|k| offset + Vec3A::new((k % n) as f32, (k / n) as f32, 0.0) * spacing)
                .collect::<Vec<_>>()
        };
        let mut triangles = Vec::new();
        for j in 0..n as u32 - 1 {
            for i in 0..n as u32 - 1 {
                let k = j * n as u32 + i;
                triangles.push([k, k + 1, k + n as u32]);
                triangles.push([k + 1, k + n as u32 + 1, k + n as u32]);
            }
        }
        let surface = sheet(Vec3A::ZERO);
        let side = (n - 1) as f32 * spacing;
        for case in 0..8 {
            // Whole cells plus a fraction in [0.2, 0.4] of one on each axis: the fractions sum
            // to under 1, away from the diagonal x + y = 1 each cell is cut along.
            let cells = |rng: &mut Rng| rng.range(-3.0, 3.0).round() + rng.range(0.2, 0.4);
            let offset = Vec3A::new(cells(&mut rng), cells(&mut rng), 0.0) * spacing;
            let start = sheet(offset + Vec3A::new(0.0, 0.0, 0.02));
            let drop = rng.range(0.021, 0.1);
            let through = sheet(offset + Vec3A::new(0.0, 0.0, 0.02 - drop));
            let short = sheet(offset + Vec3A::new(0.0, 0.0, 0.001));
            let count = |after: &[Vec3A]| {
                count_crossings_between(
                    TwoPoses {
                        before: &start,
                        after,
                    },
                    TwoPoses {
                        before: &surface,
                        after: &surface,
                    },
                    &triangles,
                    H,
                )
            };
            let over = start
                .iter()
                .filter(|p| p.x > 0.0 && p.y > 0.0 && p.x < side && p.y < side)
                .count();
            assert!(over > 0, "case {case}: the sheets do not overlap");
            assert_eq!(count(&through), over, "case {case}");
            assert_eq!(count(&short), 0, "case {case}");
        }
    }
}
