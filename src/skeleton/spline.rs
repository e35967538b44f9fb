//! Keyframe splines at non-uniform times: cubic Hermite segments with Catmull-Rom tangents,
//! for scalars and vectors ([`KeySpline`]) and unit quaternions ([`QuatSpline`]). Sampling
//! returns the value and its time derivative.
//!
//! # The tangent at unequal spacing
//!
//! Between keys `(t_i, p_i)` and `(t_{i+1}, p_{i+1})`, with `d = t_{i+1} - t_i` and
//! `s = (t - t_i) / d` in [0, 1], the cubic Hermite segment is
//!
//! ```text
//! p(t) = h00(s) p_i + h10(s) d m_i + h01(s) p_{i+1} + h11(s) d m_{i+1}
//! h00 = 2s^3 - 3s^2 + 1,  h10 = s^3 - 2s^2 + s,  h01 = -2s^3 + 3s^2,  h11 = s^3 - s^2
//! ```
//!
//! where `m_i` is the tangent **in units of value per second**: the basis works in `s`, so the
//! tangents enter multiplied by the segment's duration `d` (`dp/ds = d dp/dt`), and the
//! derivative is `dp/dt = (dp/ds) / d`. With `m_i` shared by the two segments that meet at key
//! `i`, the velocity is continuous there whatever the spacing.
//!
//! The tangent at an interior key is the derivative at `t_i` of the parabola through the key
//! and its two neighbours. With `d0 = t_i - t_{i-1}` and `d1 = t_{i+1} - t_i`:
//!
//! ```text
//! m_i = (d1 (p_i - p_{i-1}) / d0 + d0 (p_{i+1} - p_i) / d1) / (d0 + d1)
//! ```
//!
//! (write the parabola as `p_i + b (t - t_i) + c (t - t_i)^2`, put in the two neighbours and
//! solve for `b`). It weighs each side's slope by the *other* side's length, so it is exact for
//! linear and quadratic motion at any spacing, and for equal spacing it is the familiar
//! Catmull-Rom tangent `(p_{i+1} - p_{i-1}) / (2 d)`. The uniform formula used per unit of
//! key index, `(p_{i+1} - p_{i-1}) / 2`, and then scaled by each segment's own duration,
//! gives a tangent that jumps at every key whose neighbouring segments differ in length
//! ([`uniform_tangent`] keeps it for comparison).
//!
//! # Ends and loops
//!
//! A clamped spline's first and last tangents are the one-sided slopes
//! `(p_1 - p_0) / (t_1 - t_0)` and `(p_{n-1} - p_{n-2}) / (t_{n-1} - t_{n-2})`, so linear motion
//! stays exact to the ends; outside `[t_0, t_{n-1}]` the value holds at the end key with zero
//! velocity. A looping spline's last key closes the loop (its value is the first key's), the
//! period is `t_{n-1} - t_0`, and the tangents at both ends use the wrapped neighbours
//! (`p_{n-2}` at `t_{n-2} - period` before the first key, `p_1` at `t_1 + period` after the
//! last), so the loop is velocity-continuous too.
//!
//! # Rotations
//!
//! [`QuatSpline`] first flips each key into the hemisphere of the one before (`q` and `-q` are
//! the same rotation; the flip makes every segment take the short way). Each key `i` gets one
//! angular velocity `w_i`, in its own frame (body frame), shared by the two segments that meet
//! there: the non-uniform tangent above taken in the key's tangent space, on the rotation
//! vectors `log(q_i^-1 q_{i-1})`, `0`, `log(q_i^-1 q_{i+1})` (one-sided at a clamped end, wrapped
//! in a loop). A segment runs a Hermite cubic on the rotation vector `r(t)` relative to its
//! first key, `q(t) = q_i exp(r(t))`, from `r = 0` to `R = log(q_i^-1 q_{i+1})`, with end slopes
//! `dr/dt = w_i` (at `r = 0` the body angular velocity is `dr/dt`) and
//! `dr/dt = J_r(R)^-1 w_{i+1}` (`J_r` the right Jacobian of the exponential map: the body
//! angular velocity is `J_r(r) dr/dt`). Both segments meeting at a key therefore end and start
//! with the key's rotation and the same angular velocity: the spline is C1 at every key, at
//! any spacing. It is always a unit quaternion, passes through every key, and for rotations
//! about one fixed axis is exactly the scalar spline of the angle. The world angular velocity
//! is `q (J_r(r) dr/dt)`.

use bevy::math::{Quat, Vec3};

/// Values a [`KeySpline`] can interpolate.
pub trait SplineValue:
    Copy
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<f32, Output = Self>
{
    /// The zero value.
    const ZERO: Self;
}

impl SplineValue for f32 {
    const ZERO: Self = 0.0;
}

impl SplineValue for Vec3 {
    const ZERO: Self = Vec3::ZERO;
}

/// Why keys cannot make a spline.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SplineError {
    /// Fewer than two keys.
    #[error("{0} keys: a spline needs at least two")]
    TooFewKeys(usize),
    /// Key times and values differ in number.
    #[error("{times} key times but {values} values")]
    LengthMismatch {
        /// How many times.
        times: usize,
        /// How many values.
        values: usize,
    },
    /// Key times are not strictly increasing (unsorted or duplicate).
    #[error("key time {time} at key {index} does not come after the one before")]
    NotIncreasing {
        /// The offending key.
        index: usize,
        /// Its time.
        time: f32,
    },
    /// A key time or value is NaN or infinite.
    #[error("key {0} is not finite")]
    NonFinite(usize),
}

/// Checks key times: at least two, finite, strictly increasing, as many as `values`.
pub(crate) fn check_times(times: &[f32], values: usize) -> Result<(), SplineError> {
    if times.len() != values {
        return Err(SplineError::LengthMismatch {
            times: times.len(),
            values,
        });
    }
    if times.len() < 2 {
        return Err(SplineError::TooFewKeys(times.len()));
    }
    if let Some(i) = times.iter().position(|t| !t.is_finite()) {
        return Err(SplineError::NonFinite(i));
    }
    if let Some(i) = (1..times.len()).find(|&i| times[i] <= times[i - 1]) {
        return Err(SplineError::NotIncreasing {
            index: i,
            time: times[i],
        });
    }
    Ok(())
}

/// Cubic Hermite basis values and their `s` derivatives at `s`.
#[inline]
fn hermite(s: f32) -> ([f32; 4], [f32; 4]) {
    let s2 = s * s;
    let s3 = s2 * s;
    (
        [
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        ],
        [
            6.0 * s2 - 6.0 * s,
            3.0 * s2 - 4.0 * s + 1.0,
            -6.0 * s2 + 6.0 * s,
            3.0 * s2 - 2.0 * s,
        ],
    )
}

/// The non-uniform Catmull-Rom tangent at a key with neighbours `(t0, p0)` before and
/// `(t2, p2)` after (see the [module docs](self)).
#[inline]
pub fn tangent<T: SplineValue>(t0: f32, p0: T, t1: f32, p1: T, t2: f32, p2: T) -> T {
    let (d0, d1) = (t1 - t0, t2 - t1);
    ((p1 - p0) * (d1 / d0) + (p2 - p1) * (d0 / d1)) * (1.0 / (d0 + d1))
}

/// The uniform Catmull-Rom tangent `(p2 - p0) / 2`, per unit of key index: correct only for
/// equally spaced keys (kept to show what it gets wrong).
#[inline]
pub fn uniform_tangent<T: SplineValue>(p0: T, p2: T) -> T {
    (p2 - p0) * 0.5
}

/// Where `t` falls: the segment index, its start time, its duration, and `t` wrapped into the
/// spline's range (looping) or clamped (not looping; `None` outside the range).
fn locate(times: &[f32], looping: bool, t: f32) -> (usize, f32, bool) {
    let (first, last) = (times[0], times[times.len() - 1]);
    let mut t = if t.is_finite() { t } else { first };
    let mut outside = false;
    if looping {
        let period = last - first;
        t = first + (t - first).rem_euclid(period);
    } else if t < first || t > last {
        outside = true;
        t = t.clamp(first, last);
    }
    let i = match times.partition_point(|&k| k <= t) {
        0 => 0,
        k => (k - 1).min(times.len() - 2),
    };
    (i, t, outside)
}

/// Scalar or vector keys at non-uniform times (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct KeySpline<T> {
    times: Vec<f32>,
    values: Vec<T>,
    tangents: Vec<T>,
    looping: bool,
    /// Tangents per unit of key index (the uniform formula) rather than per second.
    per_index: bool,
}

impl<T: SplineValue> KeySpline<T> {
    /// A spline through `values` at `times`. Errors: fewer than two keys, a length mismatch,
    /// times not finite or not strictly increasing.
    pub fn new(times: &[f32], values: &[T], looping: bool) -> Result<Self, SplineError> {
        check_times(times, values.len())?;
        let tangents = key_tangents(times, values, looping, tangent);
        Ok(Self {
            times: times.to_vec(),
            values: values.to_vec(),
            tangents,
            looping,
            per_index: false,
        })
    }

    /// The same keys with the uniform Catmull-Rom tangents `(p_{i+1} - p_{i-1}) / 2` per unit
    /// of key index, each segment parametrised by its index as if all keys were one second
    /// apart: right for equally spaced keys, wrong in its velocity otherwise (the two segments
    /// meeting at a key turn the same per-index tangent into different velocities). For
    /// comparisons.
    pub fn new_uniform(times: &[f32], values: &[T], looping: bool) -> Result<Self, SplineError> {
        check_times(times, values.len())?;
        let tangents = key_tangents(times, values, looping, |_, p0, _, _, _, p2| {
            uniform_tangent(p0, p2)
        });
        Ok(Self {
            times: times.to_vec(),
            values: values.to_vec(),
            tangents,
            looping,
            per_index: true,
        })
    }

    /// The key times.
    pub fn times(&self) -> &[f32] {
        &self.times
    }

    /// The value and its time derivative at `t`.
    pub fn sample(&self, t: f32) -> (T, T) {
        let (i, t, outside) = locate(&self.times, self.looping, t);
        if outside {
            let k = if t <= self.times[0] {
                0
            } else {
                self.values.len() - 1
            };
            // (Only reached outside the keys' range.)
            return (self.values[k], T::ZERO);
        }
        let d = self.times[i + 1] - self.times[i];
        let s = (t - self.times[i]) / d;
        let (h, dh) = hermite(s);
        let (p0, p1) = (self.values[i], self.values[i + 1]);
        let scale = if self.per_index { 1.0 } else { d };
        let (m0, m1) = (self.tangents[i] * scale, self.tangents[i + 1] * scale);
        let value = p0 * h[0] + m0 * h[1] + p1 * h[2] + m1 * h[3];
        let rate = (p0 * dh[0] + m0 * dh[1] + p1 * dh[2] + m1 * dh[3]) * (1.0 / d);
        (value, rate)
    }
}

/// The tangent at every key, with `f(t_prev, p_prev, t, p, t_next, p_next)`; ends are
/// one-sided (clamped) or use the wrapped neighbours (looping).
fn key_tangents<T: SplineValue>(
    times: &[f32],
    values: &[T],
    looping: bool,
    f: impl Fn(f32, T, f32, T, f32, T) -> T,
) -> Vec<T> {
    let n = times.len();
    let period = times[n - 1] - times[0];
    (0..n)
        .map(|i| {
            let (t, p) = (times[i], values[i]);
            let before = if i > 0 {
                Some((times[i - 1], values[i - 1]))
            } else if looping && n > 2 {
                Some((times[n - 2] - period, values[n - 2]))
            } else {
                None
            };
            let after = if i + 1 < n {
                Some((times[i + 1], values[i + 1]))
            } else if looping && n > 2 {
                Some((times[1] + period, values[1]))
            } else {
                None
            };
            match (before, after) {
                (Some((t0, p0)), Some((t2, p2))) => f(t0, p0, t, p, t2, p2),
                // One-sided slopes at the ends of a clamped spline (per second; the uniform
                // variant has no per-second meaning and uses the same per-index slope).
                (None, Some((t2, p2))) => (p2 - p) * (1.0 / (t2 - t)),
                (Some((t0, p0)), None) => (p - p0) * (1.0 / (t - t0)),
                (None, None) => T::ZERO,
            }
        })
        .collect()
}

/// Unit-quaternion keys at non-uniform times (see the [module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct QuatSpline {
    times: Vec<f32>,
    keys: Vec<Quat>,
    /// Each key's angular velocity in its own frame, rad/s.
    rates: Vec<Vec3>,
    looping: bool,
}

/// The rotation vector of a unit quaternion (axis times angle, angle in [0, pi] for `w >= 0`).
fn log(q: Quat) -> Vec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let v = Vec3::new(q.x, q.y, q.z);
    let s = v.length();
    if s < 1e-7 {
        return v * 2.0;
    }
    v * (2.0 * s.atan2(q.w) / s)
}

/// The unit quaternion of a rotation vector.
fn exp(r: Vec3) -> Quat {
    let angle = r.length();
    if angle < 1e-7 {
        return Quat::from_xyzw(0.5 * r.x, 0.5 * r.y, 0.5 * r.z, 1.0).normalize();
    }
    Quat::from_axis_angle(r / angle, angle)
}

/// The right Jacobian of the exponential map: `d/dt exp(r) = exp(r) [J_r(r) dr/dt]`.
fn right_jacobian_times(r: Vec3, dr: Vec3) -> Vec3 {
    let theta = r.length();
    if theta < 1e-4 {
        return dr - 0.5 * r.cross(dr);
    }
    let k = r.cross(dr);
    let kk = r.cross(k);
    dr - k * ((1.0 - theta.cos()) / (theta * theta))
        + kk * ((theta - theta.sin()) / (theta * theta * theta))
}

/// The inverse of the right Jacobian: `J_r(r)^-1 w`, the rate of `r` that gives the body
/// angular velocity `w` at `exp(r)`.
fn inverse_right_jacobian_times(r: Vec3, w: Vec3) -> Vec3 {
    let theta = r.length();
    let k = r.cross(w);
    let kk = r.cross(k);
    if theta < 1e-4 {
        return w + 0.5 * k + kk * (1.0 / 12.0);
    }
    let half = 0.5 * theta;
    w + 0.5 * k + kk * ((1.0 - half * half.cos() / half.sin()) / (theta * theta))
}

impl QuatSpline {
    /// A spline through the rotations `keys` at `times` (normalised, flipped into one
    /// hemisphere). Errors as [`KeySpline::new`], and for a key that is not finite or has zero
    /// length.
    pub fn new(times: &[f32], keys: &[Quat], looping: bool) -> Result<Self, SplineError> {
        check_times(times, keys.len())?;
        let mut fixed: Vec<Quat> = Vec::with_capacity(keys.len());
        for (i, q) in keys.iter().enumerate() {
            if !q.is_finite() || q.length_squared() < 1e-12 {
                return Err(SplineError::NonFinite(i));
            }
            let mut q = q.normalize();
            if let Some(prev) = fixed.last()
                && prev.dot(q) < 0.0
            {
                q = -q;
            }
            fixed.push(q);
        }
        let n = fixed.len();
        let period = times[n - 1] - times[0];
        // A key's neighbour at offset -1 or +1, wrapped in a loop: its time and rotation.
        let neighbour = |i: usize, next: bool| -> Option<(f32, Quat)> {
            match (next, i) {
                (false, 0) => (looping && n > 2).then(|| (times[n - 2] - period, fixed[n - 2])),
                (false, i) => Some((times[i - 1], fixed[i - 1])),
                (true, i) if i + 1 == n => {
                    (looping && n > 2).then(|| (times[1] + period, fixed[1]))
                }
                (true, i) => Some((times[i + 1], fixed[i + 1])),
            }
        };
        let rates = (0..n)
            .map(|i| {
                let (ti, inv) = (times[i], fixed[i].inverse());
                let chart = |(t, q): (f32, Quat)| (t, log(inv * q));
                match (
                    neighbour(i, false).map(chart),
                    neighbour(i, true).map(chart),
                ) {
                    (Some((t0, r0)), Some((t2, r2))) => tangent(t0, r0, ti, Vec3::ZERO, t2, r2),
                    (None, Some((t2, r2))) => r2 / (t2 - ti),
                    (Some((t0, r0)), None) => -r0 / (ti - t0),
                    (None, None) => Vec3::ZERO,
                }
            })
            .collect();
        Ok(Self {
            times: times.to_vec(),
            keys: fixed,
            rates,
            looping,
        })
    }

    /// The rotation and the angular velocity (world frame, rad/s) at `t`.
    pub fn sample(&self, t: f32) -> (Quat, Vec3) {
        let (i, t, outside) = locate(&self.times, self.looping, t);
        let n = self.keys.len();
        if outside {
            let k = if t <= self.times[0] { 0 } else { n - 1 };
            return (self.keys[k], Vec3::ZERO);
        }
        let base = self.keys[i];
        let end = log(base.inverse() * self.keys[i + 1]);
        let d = self.times[i + 1] - self.times[i];
        let start_rate = self.rates[i];
        let end_rate = inverse_right_jacobian_times(end, self.rates[i + 1]);
        let s = (t - self.times[i]) / d;
        let (h, dh) = hermite(s);
        let r = start_rate * (d * h[1]) + end * h[2] + end_rate * (d * h[3]);
        let dr = (start_rate * (d * dh[1]) + end * dh[2] + end_rate * (d * dh[3])) / d;
        let q = (base * exp(r)).normalize();
        let omega = q * right_jacobian_times(r, dr);
        (q, omega)
    }
}

#[cfg(test)]
mod tests {
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
                    let jump =
                        (before - after).length() / (1.0 + before.length().max(after.length()));
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
}
