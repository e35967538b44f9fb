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
mod tests;
