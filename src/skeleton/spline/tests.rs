use super::*;
use crate::rng::Rng;
use bevy::math::cubic_splines::{CubicCardinalSpline, CubicGenerator, CyclicCubicGenerator};

const TIMES: [f32; 6] = [0.0, 0.3, 0.45, 1.2, 1.5, 2.4];

/// The angle between two rotations, accurate for small angles (unlike `acos` of the dot
/// product in f32).
fn angle(a: Quat, b: Quat) -> f32 {
    log(a.inverse() * b).length()
}

#[test]
fn linear_motion_at_non_uniform_times_is_exact_and_passes_through_the_keys() {
    let f = |t: f32| Vec3::new(0.1 + 0.2 * t, -0.1 + 0.05 * t, 0.3 * t);
    let values: Vec<Vec3> = TIMES.iter().map(|&t| f(t)).collect();
    let spline = KeySpline::new(&TIMES, &values, false).unwrap();
    for k in 0..=240 {
        let t = k as f32 * 0.01;
        let (p, v) = spline.sample(t);
        assert!((p - f(t)).length() < 1e-6, "t {t}: {p} vs {}", f(t));
        assert!(
            (v - Vec3::new(0.2, 0.05, 0.3)).length() < 1e-5,
            "t {t}: {v}"
        );
    }
    for (&t, &p) in TIMES.iter().zip(&values) {
        assert!((spline.sample(t).0 - p).length() < 1e-6);
    }
}

/// The largest jump of the velocity across any interior key.
fn velocity_jump(spline: &KeySpline<f32>) -> f32 {
    TIMES[1..TIMES.len() - 1]
        .iter()
        .map(|&t| (spline.sample(t + 1e-4).1 - spline.sample(t - 1e-4).1).abs())
        .fold(0.0, f32::max)
}

#[test]
fn velocity_is_continuous_at_non_uniform_keys_and_the_uniform_formula_is_not() {
    let values = [0.0f32, 1.0, 0.2, -0.7, 0.4, 1.1];
    let good = KeySpline::new(&TIMES, &values, false).unwrap();
    let bad = KeySpline::new_uniform(&TIMES, &values, false).unwrap();
    let (good_jump, bad_jump) = (velocity_jump(&good), velocity_jump(&bad));
    println!(
        "largest velocity jump at a key: non-uniform {good_jump:.4}, uniform {bad_jump:.4} per s"
    );
    // (Sampled 0.1 ms either side of the key, so curvature alone gives a few 0.01.)
    assert!(good_jump < 0.05);
    assert!(bad_jump > 1.0);
    // On quadratic motion the non-uniform tangent is exact at the keys too; the uniform
    // one is visibly wrong there.
    let f = |t: f32| 1.0 - 2.0 * t + 1.5 * t * t;
    let q: Vec<f32> = TIMES.iter().map(|&t| f(t)).collect();
    let good = KeySpline::new(&TIMES, &q, false).unwrap();
    let bad = KeySpline::new_uniform(&TIMES, &q, false).unwrap();
    let t = TIMES[2];
    let exact = -2.0 + 3.0 * t;
    println!(
        "velocity at t = {t}: exact {exact:.4}, non-uniform {:.4}, uniform {:.4}",
        good.sample(t).1,
        bad.sample(t).1
    );
    assert!((good.sample(t).1 - exact).abs() < 1e-4);
    assert!((bad.sample(t).1 - exact).abs() > 0.3);
}

#[test]
fn uniform_times_reproduce_bevys_catmull_rom() {
    let points = [0.0f32, 1.0, 0.2, -0.7, 0.4, 1.1].map(|y| Vec3::new(y, 2.0 * y, -y));
    let times: Vec<f32> = (0..points.len()).map(|i| i as f32 * 0.5).collect();
    let ours = KeySpline::new(&times, &points, false).unwrap();
    // Bevy's Catmull-Rom makes segments between the inner points; compare there, with its
    // parameter in key units (one unit = 0.5 s).
    let curve = CubicCardinalSpline::new_catmull_rom(points)
        .to_curve()
        .unwrap();
    for k in 0..=300 {
        let u = 1.0 + 3.0 * k as f32 / 300.0;
        let t = u * 0.5;
        let (p, v) = ours.sample(t);
        let expected = curve.position(u);
        let expected_v = curve.velocity(u) / 0.5;
        assert!((p - expected).length() < 1e-5, "u {u}: {p} vs {expected}");
        assert!(
            (v - expected_v).length() < 1e-4,
            "u {u}: {v} vs {expected_v}"
        );
    }
    // Looping agrees with Bevy's cyclic Catmull-Rom.
    let ring = [0.0f32, 1.0, 0.2, -0.7].map(|y| Vec3::new(y, 1.0 - y, 0.5 * y));
    let mut closed = ring.to_vec();
    closed.push(ring[0]);
    let times: Vec<f32> = (0..closed.len()).map(|i| i as f32).collect();
    let ours = KeySpline::new(&times, &closed, true).unwrap();
    let cyclic = CubicCardinalSpline::new_catmull_rom(ring)
        .to_curve_cyclic()
        .unwrap();
    for k in 0..=80 {
        let u = 4.0 * k as f32 / 80.0;
        let (p, _) = ours.sample(u + 8.0);
        assert!((p - cyclic.position(u)).length() < 1e-4, "u {u}");
    }
}

#[test]
fn the_quaternion_spline_is_unit_passes_through_the_keys_and_takes_the_short_way() {
    let keys = [
        Quat::IDENTITY,
        Quat::from_euler(bevy::math::EulerRot::YXZ, 1.0, 0.3, -0.2),
        // The same rotation as the previous key region, given on the far hemisphere.
        -Quat::from_euler(bevy::math::EulerRot::YXZ, 1.6, -0.4, 0.5),
        Quat::from_rotation_z(2.5),
        Quat::from_rotation_x(-1.0),
        Quat::from_rotation_y(0.2),
    ];
    let spline = QuatSpline::new(&TIMES, &keys, false).unwrap();
    for (&t, &q) in TIMES.iter().zip(&keys) {
        let (s, _) = spline.sample(t);
        assert!(angle(s, q) < 1e-4, "key at {t}");
    }
    let mut previous = spline.sample(0.0).0;
    for k in 1..=2400 {
        let t = k as f32 * 0.001;
        let (q, omega) = spline.sample(t);
        assert!((q.length() - 1.0).abs() < 1e-5);
        // Short way: consecutive samples 1 ms apart turn by little.
        assert!(angle(q, previous) < 0.02, "t {t}");
        // The angular velocity matches the turn over a small step.
        let (next, _) = spline.sample(t + 1e-3);
        let (before, _) = spline.sample(t - 1e-3);
        let numeric = log(next * before.inverse()) / 2e-3;
        if TIMES.iter().all(|&key| (key - t).abs() > 2e-3) {
            assert!(
                (numeric - omega).length() < 1e-2 * (1.0 + omega.length()),
                "t {t}: {omega} vs {numeric}"
            );
        }
        previous = q;
    }
    // Rotations about one axis are the scalar spline of the angle.
    let angles = [0.0f32, 0.5, 1.4, 0.9, -0.3, 0.1];
    let about_y: Vec<Quat> = angles.iter().map(|&a| Quat::from_rotation_y(a)).collect();
    let q = QuatSpline::new(&TIMES, &about_y, false).unwrap();
    let a = KeySpline::new(&TIMES, &angles, false).unwrap();
    for k in 0..=240 {
        let t = k as f32 * 0.01;
        let ((rot, omega), (theta, rate)) = (q.sample(t), a.sample(t));
        assert!(
            angle(rot, Quat::from_rotation_y(theta)) < 1e-4,
            "t {t}: {rot} vs {theta}"
        );
        assert!((omega - Vec3::Y * rate).length() < 1e-3);
    }
}

#[test]
fn the_angular_velocity_is_continuous_at_every_key_for_random_keys_and_times() {
    // Random rotations at random times (spacings from 0.1 to 1.1 s), clamped and looping:
    // the angular velocity just before and just after every key agree, and between keys
    // it is the derivative of the rotation.
    let mut rng = Rng(17);
    let mut next = || rng.uniform();
    let (mut worst_jump, mut worst_derivative) = (0.0f32, 0.0f32);
    for _ in 0..200 {
        let n = 3 + (next() * 6.0) as usize;
        let mut times = vec![0.0f32];
        for _ in 1..n {
            let last = *times.last().unwrap();
            times.push(last + 0.1 + next());
        }
        let keys: Vec<Quat> = (0..n)
            .map(|_| {
                let mut a = || (2.0 * next() - 1.0) * 2.5;
                Quat::from_euler(bevy::math::EulerRot::YXZ, a(), 0.5 * a(), a())
            })
            .collect();
        for looping in [false, true] {
            let mut keys = keys.clone();
            if looping {
                keys[n - 1] = keys[0];
            }
            let spline = QuatSpline::new(&times, &keys, looping).unwrap();
            // One-sided limits, extrapolated linearly from two samples on each side so
            // that the (discontinuous) angular acceleration drops out.
            let eps = 1e-4;
            let wrap = |t: f32| {
                if t < times[0] {
                    t + (times[n - 1] - times[0])
                } else if t > times[n - 1] {
                    t - (times[n - 1] - times[0])
                } else {
                    t
                }
            };
            let interior = if looping { 0..n - 1 } else { 1..n - 1 };
            for k in interior {
                let t = times[k];
                let w = |dt: f32| spline.sample(wrap(t + dt)).1;
                let before = w(-eps) * 2.0 - w(-2.0 * eps);
                let after = w(eps) * 2.0 - w(2.0 * eps);
                let jump = (before - after).length() / (1.0 + before.length().max(after.length()));
                worst_jump = worst_jump.max(jump);
            }
            for j in 0..50 {
                let t = times[0] + (times[n - 1] - times[0]) * (j as f32 + 0.5) / 50.0;
                if times.iter().any(|&key| (key - t).abs() < 2e-3) {
                    continue;
                }
                let (_, omega) = spline.sample(t);
                let (a, b) = (spline.sample(t - 1e-3).0, spline.sample(t + 1e-3).0);
                let numeric = log(b * a.inverse()) / 2e-3;
                worst_derivative =
                    worst_derivative.max((numeric - omega).length() / (1.0 + omega.length()));
            }
        }
    }
    println!(
        "worst velocity jump at a key {worst_jump}, worst derivative error {worst_derivative}"
    );
    assert!(
        worst_jump < 2e-3,
        "the angular velocity jumps by {worst_jump} at a key"
    );
    assert!(worst_derivative < 1e-2, "{worst_derivative}");
}

#[test]
fn the_inverse_right_jacobian_inverts_the_right_jacobian() {
    let mut rng = Rng(5);
    let mut next = || rng.range(-1.0, 1.0);
    for _ in 0..1000 {
        let scale = if next() > 0.0 { 3.0 } else { 1e-5 };
        let r = Vec3::new(next(), next(), next()) * scale;
        let w = Vec3::new(next(), next(), next());
        let back = right_jacobian_times(r, inverse_right_jacobian_times(r, w));
        assert!((back - w).length() < 1e-4, "r {r}: {back} vs {w}");
    }
}

#[test]
fn bad_keys_are_refused() {
    assert_eq!(
        KeySpline::new(&[0.0], &[1.0f32], false),
        Err(SplineError::TooFewKeys(1))
    );
    assert!(matches!(
        KeySpline::new(&[0.0, 1.0, 1.0], &[1.0f32, 2.0, 3.0], false),
        Err(SplineError::NotIncreasing { index: 2, .. })
    ));
    assert!(matches!(
        KeySpline::new(&[0.0, 2.0, 1.0], &[1.0f32, 2.0, 3.0], false),
        Err(SplineError::NotIncreasing { index: 2, .. })
    ));
    assert!(matches!(
        KeySpline::new(&[0.0, 1.0], &[1.0f32], false),
        Err(SplineError::LengthMismatch { .. })
    ));
    assert!(matches!(
        QuatSpline::new(
            &[0.0, 1.0],
            &[Quat::IDENTITY, Quat::from_xyzw(0.0, 0.0, 0.0, 0.0)],
            false
        ),
        Err(SplineError::NonFinite(1))
    ));
}
