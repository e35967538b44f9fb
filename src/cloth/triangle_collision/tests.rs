//! Tests of the triangle method of self-collision.

use super::*;
use crate::cloth::crossings::{TwoPoses, count_self_crossings};
use crate::cloth::model::{ClothModel, GridDesc};
use crate::rng::Rng;
use bevy::math::Vec3;

const H: f32 = 0.005;

/// Every (particle, triangle) pair within the search's distance, by brute force.
fn brute_force(tc: &TriangleSelfCollision, x: &[Vec3A]) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for q in 0..x.len() {
        for (t, &[a, b, c]) in tc.triangles.iter().enumerate() {
            if [a, b, c].contains(&(q as u32)) {
                continue;
            }
            let [pa, pb, pc] = [a, b, c].map(|i| x[i as usize]);
            let Some(frame) = TriangleFrame::new(pa, pb, pc) else {
                continue;
            };
            let corner_travel = [a, b, c]
                .map(|i| tc.travel[i as usize])
                .into_iter()
                .fold(0.0, f32::max);
            if frame.within(x[q], tc.thickness + corner_travel + tc.travel[q]) {
                out.push((q as u32, t as u32));
            }
        }
    }
    out
}

#[test]
fn the_grid_finds_exactly_the_pairs_a_brute_force_search_finds() {
    let model =
        ClothModel::grid(&GridDesc::square(1.0, 11, Vec3::new(-0.5, 0.0, -0.5)), 0.1).unwrap();
    let mut rng = Rng(5);
    for spread in [0.05f32, 0.3, 3.0] {
        let mut tc = TriangleSelfCollision::new(&model.rest_positions, &model.triangles).unwrap();
        // A crumpled sheet: random positions near a wavy fold, random velocities.
        let x: Vec<Vec3A> = model
            .rest_positions
            .iter()
            .map(|p| {
                let fold = (p.x * 7.0).sin() * 0.05 + rng.range(-spread, spread) * 0.1;
                Vec3A::new(p.x.abs() * 0.3, fold, p.z + rng.range(-0.01, 0.01))
            })
            .collect();
        let v: Vec<Vec3A> = (0..x.len())
            .map(|_| Vec3A::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), 0.0))
            .collect();
        tc.find_pairs(&x, &v, 1.0 / 60.0, 9.81, H);
        let mut found: Vec<(u32, u32)> = tc
            .candidates()
            .iter()
            .map(|p| (p.particle, p.triangle))
            .collect();
        found.sort_unstable();
        let expected = brute_force(&tc, &x);
        assert!(
            expected.len() > 20,
            "spread {spread}: the shape has overlaps"
        );
        assert_eq!(found, expected, "spread {spread}");
    }
}

/// One step of `dt` in `[substeps, iterations]` of particles in free flight held by `tc`
/// alone (its candidates found already), velocities from positions.
fn free_flight(
    tc: &mut TriangleSelfCollision,
    (x, v, w): (&mut [Vec3A], &mut [Vec3A], &[f32]),
    dt: f32,
    [substeps, iterations]: [u32; 2],
    friction: f32,
) {
    let h = dt / substeps as f32;
    for _ in 0..substeps {
        let x_prev = x.to_vec();
        for (p, v) in x.iter_mut().zip(&*v) {
            *p += *v * h;
        }
        tc.begin_substep(&x_prev, substeps);
        for _ in 0..iterations {
            tc.project(x, &x_prev, w, friction, None);
        }
        for ((v, p), p0) in v.iter_mut().zip(&*x).zip(&x_prev) {
            *v = (*p - *p0) / h;
        }
    }
}

/// One triangle 2 cm wide in the plane y = 0 (corners 0-2, inverse mass `w_tri`), one
/// particle (3)
/// moving down through it at `speed`.
fn falling_particle(speed: f32, w_tri: f32, steps: u32) -> (Vec<Vec3A>, Vec3A, usize, f32) {
    let mut x = vec![
        Vec3A::new(0.0, 0.0, 0.0),
        Vec3A::new(0.0, 0.0, 0.02),
        Vec3A::new(0.02, 0.0, 0.0),
        Vec3A::new(0.005, 0.02, 0.005),
    ];
    let w = vec![w_tri, w_tri, w_tri, 1.0];
    let mut v = vec![Vec3A::ZERO; 4];
    v[3].y = -speed;
    let rest: Vec<Vec3> = x.iter().map(|&p| p.into()).collect();
    let mut tc = TriangleSelfCollision::new(&rest, &[[0, 1, 2]]).unwrap();
    let dt = 1.0 / 60.0;
    let substeps = 4;
    let momentum_before: Vec3A = v.iter().zip(&w).map(|(v, w)| *v / *w).sum();
    let mut crossings = 0;
    for _ in 0..steps {
        tc.find_pairs(&x, &v, dt, 0.0, H);
        let start = x.clone();
        free_flight(&mut tc, (&mut x, &mut v, &w), dt, [substeps, 2], 0.0);
        crossings += count_self_crossings(
            TwoPoses {
                before: &start,
                after: &x,
            },
            &[[0, 1, 2]],
            H,
        );
    }
    let momentum_after: Vec3A = v.iter().zip(&w).map(|(v, w)| *v / *w).sum();
    (x, momentum_after - momentum_before, crossings, tc.thickness)
}

#[test]
fn a_fast_particle_stops_on_its_side_of_a_triangle_with_momentum_kept() {
    // From 1 m/s to 30 m/s: 50 cm a step, fifteen times the gap in one substep.
    for speed in [1.0f32, 5.0, 30.0] {
        for w_tri in [0.0f32, 1.0, 4.0] {
            let (x, momentum, crossings, gap) = falling_particle(speed, w_tri, 20);
            let plane = x[0].y;
            assert_eq!(crossings, 0, "speed {speed}, w {w_tri}");
            assert!(
                x[3].y - plane > 0.9 * gap,
                "speed {speed}, w {w_tri}: {} above the plane",
                x[3].y - plane
            );
            if w_tri > 0.0 {
                assert!(momentum.length() < 1e-3 * speed, "momentum {momentum}");
            }
        }
    }
}

#[test]
fn a_particle_going_round_an_edge_takes_the_new_side_one_pushed_through_goes_back() {
    let tri = [
        Vec3A::new(0.0, 0.0, 0.0),
        Vec3A::new(0.0, 0.0, 0.02),
        Vec3A::new(0.02, 0.0, 0.0),
    ];
    let rest: Vec<Vec3> = tri.iter().map(|&p| p.into()).collect::<Vec<_>>();
    let rest = [rest[0], rest[1], rest[2], Vec3::new(0.006, 0.003, 0.006)];
    let w = [0.0, 0.0, 0.0, 1.0];
    let held_at = |start: Vec3A, middle: Vec3A, end: Vec3A| {
        let mut tc = TriangleSelfCollision::new(&rest, &[[0, 1, 2]]).unwrap();
        let mut x = [tri[0], tri[1], tri[2], start];
        tc.find_pairs(&x, &[Vec3A::ZERO; 4], 1.0 / 60.0, 0.0, H);
        // Two substeps: start -> middle -> end.
        for target in [middle, end] {
            let x_prev = x;
            x[3] = target;
            tc.begin_substep(&x_prev, 2);
            tc.project(&mut x, &x_prev, &w, 0.0, None);
        }
        (x[3], tc.thickness)
    };
    // Beside the triangle just under its plane, then round the edge over it from below:
    // kept below.
    let (end, gap) = held_at(
        Vec3A::new(-0.004, 0.002, 0.006),
        Vec3A::new(-0.003, -0.002, 0.006),
        Vec3A::new(0.004, -0.002, 0.006),
    );
    assert!(end.y <= -0.9 * gap, "below: {end}");
    // Over the triangle just above it, pushed 2 mm through: back above.
    let (end, gap) = held_at(
        Vec3A::new(0.006, 0.003, 0.006),
        Vec3A::new(0.006, 0.001, 0.006),
        Vec3A::new(0.006, -0.002, 0.006),
    );
    assert!(end.y >= 0.9 * gap, "above: {end}");
}

#[test]
fn random_sheets_pressed_together_stay_apart_and_keep_momentum() {
    // Two random sheets of one cloth, the upper one smaller and turned (its vertices over
    // the lower one's triangles anywhere, its rim inside the lower one's), pressed together
    // at random speeds with random masses: no particle crosses, the momentum is kept.
    let mut rng = Rng(23);
    for round in 0..6 {
        let n = 4 + round as u32;
        let gap = rng.range(0.003, 0.02);
        let size = rng.range(0.1, 0.4);
        let lower = GridDesc::square(size, n, Vec3::ZERO).mesh();
        let inset = rng.range(0.1, 0.2) * size;
        let mut upper = GridDesc::square(size - 3.0 * inset, n + 1, Vec3::ZERO);
        upper.orientation = bevy::math::Quat::from_rotation_y(rng.range(-0.3, 0.3));
        upper.origin = Vec3::new(1.5 * inset, gap, 1.5 * inset);
        let upper = upper.mesh();
        let count = lower.positions.len();
        let rest: Vec<Vec3> = lower
            .positions
            .iter()
            .chain(&upper.positions)
            .copied()
            .collect();
        let triangles: Vec<[u32; 3]> = lower
            .indices
            .chunks(3)
            .map(|t| [t[0], t[1], t[2]])
            .chain(
                upper
                    .indices
                    .chunks(3)
                    .map(|t| [t[0], t[1], t[2]].map(|i| i + count as u32)),
            )
            .collect();
        let mut tc = TriangleSelfCollision::new(&rest, &triangles).unwrap();
        let mut x: Vec<Vec3A> = rest
            .iter()
            .map(|&p| Vec3A::from(p) + Vec3A::new(rng.range(-1.0, 1.0), 0.0, 0.0) * 0.002)
            .collect();
        let w: Vec<f32> = (0..x.len()).map(|_| rng.range(0.5, 2.0)).collect();
        // Each particle moves at most 1.5 edges a step: the search looks 2 edges ahead.
        let speed = rng.range(0.2, 1.5) * size / (n - 1) as f32 * 60.0;
        let mut v: Vec<Vec3A> = (0..x.len())
            .map(|i| Vec3A::new(0.0, if i < count { speed } else { -speed }, 0.0))
            .collect();
        let momentum = |v: &[Vec3A]| -> Vec3A { v.iter().zip(&w).map(|(v, w)| *v / *w).sum() };
        let before = momentum(&v);
        let (dt, substeps) = (1.0 / 60.0, 4);
        let mut crossings = 0;
        for _ in 0..10 {
            tc.find_pairs(&x, &v, dt, 0.0, H);
            let start = x.clone();
            free_flight(&mut tc, (&mut x, &mut v, &w), dt, [substeps, 4], 0.3);
            crossings += count_self_crossings(
                TwoPoses {
                    before: &start,
                    after: &x,
                },
                &triangles,
                H,
            );
        }
        assert_eq!(crossings, 0, "round {round}: gap {gap}, speed {speed}");
        let drift = (momentum(&v) - before).length();
        assert!(
            drift < 1e-3 * speed * x.len() as f32,
            "round {round}: {drift}"
        );
        assert!(x.iter().all(|p| p.is_finite()));
    }
}

#[test]
fn a_grids_border_edges_are_its_rim() {
    for n in [2u32, 3, 7] {
        let model = ClothModel::grid(&GridDesc::square(1.0, n, Vec3::ZERO), 0.1).unwrap();
        let border = border_edges(&model.triangles);
        let count: u32 = border.iter().map(|b| b.count_ones()).sum();
        assert_eq!(count, 4 * (n - 1), "n {n}");
        // Each flagged edge joins two particles on the rim.
        let on_rim = |i: u32| {
            let (row, col) = (i / n, i % n);
            row == 0 || col == 0 || row == n - 1 || col == n - 1
        };
        for (t, &bits) in model.triangles.iter().zip(&border) {
            for k in (0..3).filter(|k| bits & (1 << k) != 0) {
                assert!(on_rim(t[(k + 1) % 3]) && on_rim(t[(k + 2) % 3]));
            }
        }
    }
}

#[test]
fn a_particle_passing_a_border_edge_is_kept_the_thickness_from_it() {
    // A random fixed triangle (alone: its edges are all on the border) and a particle driven
    // past one of its edges on a random straight path through the triangle's plane that
    // comes closer than the thickness: wherever it is beyond the edge, it ends each substep
    // at least the thickness from it.
    let mut rng = Rng(41);
    let mut beyond_count = 0;
    for round in 0..40 {
        let mut corner = |z: f32| {
            Vec3A::new(
                rng.range(-0.02, 0.02),
                rng.range(-0.005, 0.005),
                z + rng.range(0.0, 0.01),
            )
        };
        let (a, b, c) = (corner(0.0), corner(0.0), corner(0.03));
        let rest: Vec<Vec3> = [a, b, c, Vec3A::ZERO].map(Vec3::from).to_vec();
        let mut tc = TriangleSelfCollision::new(&rest, &[[0, 1, 2]]).unwrap();
        let h = tc.least_gap.max(H);
        // The path: past edge a-b on the side away from c, at a random offset in the plane,
        // from 2 thicknesses above the plane to 2 below.
        let edge = (b - a).normalize();
        let normal = (b - a).cross(c - a).normalize();
        let mut outward = edge.cross(normal);
        if outward.dot(c - a) > 0.0 {
            outward = -outward;
        }
        let mid = a.lerp(b, rng.range(0.3, 0.7));
        let offset = rng.range(0.1, 0.6) * h;
        let start = mid + outward * offset + normal * 2.0 * h;
        let end = mid + outward * offset - normal * 2.0 * h;
        let w = [0.0, 0.0, 0.0, 1.0];
        let mut x = [a, b, c, start];
        let dt = 1.0 / 60.0;
        let v = [Vec3A::ZERO, Vec3A::ZERO, Vec3A::ZERO, (end - start) / dt];
        tc.find_pairs(&x, &v, dt, 0.0, H);
        let substeps = 8;
        for s in 1..=substeps {
            let x_prev = x;
            x[3] = start.lerp(end, s as f32 / substeps as f32);
            tc.begin_substep(&x_prev, substeps);
            for _ in 0..2 {
                tc.project(&mut x, &x_prev, &w, 0.0, None);
            }
            let t = ((x[3] - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            let from_edge = x[3].distance(a.lerp(b, t));
            if (x[3] - a).dot(outward) > 0.0 {
                beyond_count += 1;
                assert!(
                    from_edge >= 0.999 * h,
                    "round {round}, substep {s}: {from_edge} from the edge, thickness {h}"
                );
            }
        }
        assert!(x.iter().all(|p| p.is_finite()));
    }
    assert!(
        beyond_count > 100,
        "{beyond_count} substeps beyond the edge"
    );
}

/// A particle resting on a fixed triangle `size` wide, tilted `slope` radians, under gravity,
/// with the triangle's friction `mu`; after each substep's projections a constraint slides it
/// `nudge` down the slope (as a cloth's edges move a particle after its contacts). Returns
/// how far it moved along the triangle in `seconds`, m.
fn resting_slide(size: f32, slope: f32, mu: f32, nudge: f32, seconds: f32) -> f32 {
    let down = Vec3A::new(slope.cos(), -slope.sin(), 0.0);
    let normal = Vec3A::new(slope.sin(), slope.cos(), 0.0);
    let across = Vec3A::Z;
    let mut x = vec![
        (down * -0.5 + across * -0.5) * size,
        (down * -0.5 + across * 0.5) * size,
        down * (0.5 * size),
        Vec3A::ZERO,
    ];
    let triangles = [[0, 1, 2]];
    let rest: Vec<Vec3> = x.iter().map(|&p| p.into()).collect();
    let mut tc = TriangleSelfCollision::new(&rest, &triangles).unwrap();
    // On the triangle at the gap it keeps (the particle is no corner of it).
    tc.find_pairs(&x, &[Vec3A::ZERO; 4], 0.0, 0.0, H);
    x[3] = normal * tc.thickness;
    let w = [0.0, 0.0, 0.0, 1.0];
    let mut v = vec![Vec3A::ZERO; 4];
    let (dt, substeps, g) = (1.0 / 60.0, 8, Vec3A::new(0.0, -9.81, 0.0));
    let h = dt / substeps as f32;
    let start = x[3];
    for _ in 0..(seconds / dt).round() as u32 {
        tc.find_pairs(&x, &v, dt, 9.81, H);
        for _ in 0..substeps {
            let x_prev = x.clone();
            v[3] += g * h;
            x[3] += v[3] * h;
            tc.begin_substep(&x_prev, substeps);
            for _ in 0..2 {
                tc.project(&mut x, &x_prev, &w, mu, None);
            }
            x[3] += down * nudge;
            v[3] = (x[3] - x_prev[3]) / h;
        }
    }
    assert!(x[3].is_finite());
    let moved = x[3] - start;
    (moved - normal * normal.dot(moved)).length()
}

/// Friction holds a resting particle on a slope gentler than `atan(mu)`, however often the
/// cloth's constraints slide it a little (each slide is undone from its anchor: without the
/// anchor the slides add up, 1.9 mm in 2 s here); on a steeper slope it slides on as Coulomb
/// friction says (`(sin - mu cos) g t^2 / 2`).
#[test]
fn friction_holds_a_resting_particle_against_small_slides_and_lets_a_steep_slope_go() {
    for slope in [0.1f32, 0.3] {
        let held = resting_slide(0.05, slope, 0.5, 2e-6, 2.0);
        assert!(held < 1e-4, "slope {slope}: slid {held} m");
    }
    let (slope, mu, t) = (0.6f32, 0.3f32, 1.0f32);
    let expected = 0.5 * 9.81 * (slope.sin() - mu * slope.cos()) * t * t;
    let slid = resting_slide(10.0, slope, mu, 0.0, t);
    assert!(
        (slid - expected).abs() < 0.1 * expected,
        "slid {slid} m, Coulomb says {expected} m"
    );
}
