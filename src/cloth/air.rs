//! Air: drag and lift on every triangle of a cloth from the velocity of the air relative to
//! it, and the wind that moves the air.
//!
//! **The force on a triangle** (the thin-plate model; both faces alike). With `u` the
//! triangle's mean velocity minus the mean wind at its corners, `A` its area, `n` its unit
//! normal turned to face along `u` and `c = |n . u| / |u|` (the cosine between flow and
//! normal):
//!
//! - drag, along `-u`: `1/2 rho C_d A |u|^2 c`;
//! - lift, across the flow in the plane of `u` and `n`, away from the face the air meets:
//!   `1/2 rho C_l A |u|^2 c s` with `s = sqrt(1 - c^2)`, along `-(n - c u / |u|) / s`.
//!
//! A face-on triangle feels drag only, an edge-on one nothing; with `C_l = C_d` the two add
//! up to a pressure `1/2 rho C_d |u|^2 c` on the face along `-n`. A third of the force goes
//! to each corner.
//!
//! **When.** The forces are taken once per fixed step, from the velocities and positions at
//! its start, and act as a constant acceleration on each particle through the substeps. A
//! triangle's force is scaled down, if it must be, so that over the step it cannot change the
//! velocity of a plate of the triangle's own mass by more than `|u|`: drag can bring a triangle
//! to rest in the air but never throw it back, whatever the wind speed or the step (at 30 m/s
//! a 0.1 kg/m^2 cloth's drag relaxes in 5 ms, a third of a 60 Hz step). At equilibrium
//! (terminal velocity, a flag flying steadily) the forces are exact.
//!
//! **Wind** ([`WindField`]): a base velocity, gusts (a smooth, seeded sum of travelling
//! waves in time and space with a given strength and frequency) and local sources (a fan
//! blowing one way within a radius, or a blast blowing outward), summed.

use std::f32::consts::TAU;

use bevy::math::{Mat3A, Vec3, Vec3A};
use bevy::reflect::Reflect;

use crate::error::ClothError;

/// How a cloth meets the air: the coefficients of the thin-plate model (see the module docs
/// of `cloth/air.rs`) and the air's density.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct AirSettings {
    /// Drag coefficient `C_d`. Default: `1.0`.
    pub drag: f32,
    /// Lift coefficient `C_l`. Default: `0.8`.
    pub lift: f32,
    /// Air density, kg/m^3; `0` turns the air off. Default: `1.2` (sea level, 20 C).
    pub density: f32,
}

impl Default for AirSettings {
    fn default() -> Self {
        Self {
            drag: 1.0,
            lift: 0.8,
            density: 1.2,
        }
    }
}

impl AirSettings {
    /// Checks that every coefficient is finite and not negative.
    pub(crate) fn validate(&self) -> Result<(), ClothError> {
        ClothError::require_non_negative(&[
            ("air.drag", self.drag),
            ("air.lift", self.lift),
            ("air.density", self.density),
        ])
    }

    /// Whether the air pushes at all.
    pub(crate) fn is_active(&self) -> bool {
        self.density > 0.0 && (self.drag > 0.0 || self.lift > 0.0)
    }
}

/// The aerodynamic force on one triangle whose edges' cross product is `cross` (its length
/// twice the area, its direction the normal), moving at `relative_velocity` through the air.
/// Zero for a degenerate or edge-on triangle, no relative motion, or anything not finite.
///
/// With `k = cross . u` the module docs' forces are, without normalising anything,
/// drag `-(rho C_d / 4) |k| u` and lift
/// `-(rho C_l / 4) k (|u|^2 cross - k u) / (|cross| |u|)`: one root per triangle.
#[inline]
pub(crate) fn triangle_force(air: &AirSettings, cross: Vec3A, relative_velocity: Vec3A) -> Vec3A {
    let u = relative_velocity;
    let k = cross.dot(u);
    let u2 = u.length_squared();
    let c2 = cross.length_squared();
    let denominator = (c2 * u2).sqrt();
    if !(denominator > 1e-20 && denominator.is_finite()) {
        return Vec3A::ZERO;
    }
    let drag = u * (-0.25 * air.density * air.drag * k.abs());
    let lift = (cross * u2 - u * k) * (-0.25 * air.density * air.lift * k / denominator);
    let force = drag + lift;
    if force.is_finite() {
        force
    } else {
        Vec3A::ZERO
    }
}

/// A smooth, seeded variation of the wind in time and space: a sum of travelling waves whose
/// velocity has root-mean-square magnitude `strength`.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct Gusts {
    /// Root-mean-square gust speed, m/s; `0` for a steady wind. Default: `0.0`.
    pub strength: f32,
    /// How often gusts come, Hz (the waves' frequencies spread from half to one and a half
    /// times this). Default: `0.5`.
    pub frequency: f32,
    /// The size of a gust, metres (half the waves' wavelength). Default: `4.0`.
    pub length: f32,
    /// Picks the waves: the same seed gives the same gusts. Default: `1`.
    pub seed: u32,
}

impl Default for Gusts {
    fn default() -> Self {
        WindField::STILL.gusts
    }
}

/// The number of travelling waves gusts are made of.
const GUST_WAVES: u32 = 6;

impl Gusts {
    #[cfg(test)]
    /// The gust velocity at `p` at time `t`.
    pub(crate) fn velocity_at(&self, p: Vec3, t: f32) -> Vec3 {
        self.waves(t)
            .map_or(Vec3::ZERO, |waves| waves.velocity_at(p))
    }

    /// The waves at time `t`, for sampling many points; `None` without gusts.
    fn waves(&self, t: f32) -> Option<GustWaves> {
        if !(self.strength > 0.0 && self.strength.is_finite()) {
            return None;
        }
        // A gust is half a wave.
        let wavenumber = if self.length > 0.0 {
            std::f32::consts::PI / self.length
        } else {
            0.0
        };
        // Each wave's mean square is 1/2: the sum's is GUST_WAVES / 2.
        let amplitude = self.strength / (GUST_WAVES as f32 / 2.0).sqrt();
        let waves = std::array::from_fn(|k| {
            let r = |j: u32| unit_random(self.seed, k as u32 * 8 + j);
            let frequency = self.frequency * (0.5 + r(4));
            GustWave {
                wavevector: unit_vector(r(0), r(1)) * wavenumber,
                along: unit_vector(r(2), r(3)) * amplitude,
                phase: TAU * (frequency * t + r(5)),
            }
        });
        Some(GustWaves(waves))
    }
}

/// One travelling wave of [`Gusts`] at a given time.
#[derive(Clone, Copy, Debug)]
struct GustWave {
    wavevector: Vec3,
    along: Vec3,
    phase: f32,
}

/// The waves of [`Gusts`] at a given time.
#[derive(Clone, Copy, Debug)]
struct GustWaves([GustWave; GUST_WAVES as usize]);

impl GustWaves {
    fn velocity_at(&self, p: Vec3) -> Vec3 {
        let v = self
            .0
            .iter()
            .map(|w| w.along * (w.phase - w.wavevector.dot(p)).sin())
            .sum::<Vec3>();
        if v.is_finite() { v } else { Vec3::ZERO }
    }
}

/// A number in `[0, 1)` from a seed and an index (a 32-bit integer hash).
fn unit_random(seed: u32, index: u32) -> f32 {
    let mut h = seed.wrapping_mul(0x9E37_79B9) ^ index.wrapping_mul(0x85EB_CA6B);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7FEB_352D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846C_A68B);
    h ^= h >> 16;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// The unit vector of two numbers in `[0, 1)`, uniform on the sphere.
fn unit_vector(a: f32, b: f32) -> Vec3 {
    let z = 2.0 * a - 1.0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * b;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Gusts over one cloth as a linear field: their value at the centre of the cloth's bounds
/// and their gradient there (central differences a tenth of a gust's length apart), at a
/// few multiply-adds per particle. Over a 1 m cloth in gusts 4 m long the error is 4% of
/// the gusts' strength (root mean square; 17% at worst): the cloth feels the gust's front
/// pass over it, not its finer shape. The variation it adds is capped at the strength, so a
/// cloth larger than a gust gets no extrapolated wind at its far end.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GustField {
    centre: Vec3A,
    value: Vec3A,
    gradient: Mat3A,
    cap: f32,
}

impl GustField {
    /// The gusts at time `t` over the bounds of `x`; `None` if there are no gusts or no finite
    /// positions.
    pub(crate) fn over(gusts: &Gusts, x: &[Vec3A], t: f32) -> Option<Self> {
        let waves = gusts.waves(t)?;
        let (mut min, mut max) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        for p in x.iter().filter(|p| p.is_finite()) {
            min = min.min(*p);
            max = max.max(*p);
        }
        if !(min.is_finite() && max.is_finite()) {
            return None;
        }
        let centre = (min + max) * 0.5;
        let delta = (gusts.length * 0.1).max(1e-3);
        let at = |p: Vec3A| Vec3A::from(waves.velocity_at(p.into()));
        let column =
            |axis: Vec3A| (at(centre + axis * delta) - at(centre - axis * delta)) / (2.0 * delta);
        Some(Self {
            centre,
            value: at(centre),
            gradient: Mat3A::from_cols(column(Vec3A::X), column(Vec3A::Y), column(Vec3A::Z)),
            cap: gusts.strength,
        })
    }

    /// The gust at `p`.
    #[inline]
    pub(crate) fn at(&self, p: Vec3A) -> Vec3A {
        self.value + (self.gradient * (p - self.centre)).clamp_length_max(self.cap)
    }
}

/// How a local wind source weakens from its centre to its radius.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum Falloff {
    /// Full strength out to the radius.
    Constant,
    /// Linearly to zero at the radius.
    Linear,
    /// Smoothly (`1 - 3 r^2 + 2 r^3` of the fraction of the radius) to zero at the radius.
    #[default]
    Smooth,
}

impl Falloff {
    /// The strength at `fraction` of the radius (0 at and past the radius).
    pub(crate) fn at(self, fraction: f32) -> f32 {
        if !(0.0..1.0).contains(&fraction) {
            return 0.0;
        }
        match self {
            Self::Constant => 1.0,
            Self::Linear => 1.0 - fraction,
            Self::Smooth => 1.0 - fraction * fraction * (3.0 - 2.0 * fraction),
        }
    }
}

/// Which way a local wind source blows.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum WindShape {
    /// Along one direction (a fan), within the source's radius.
    Directional {
        /// The direction it blows (normalised when used).
        direction: Vec3,
    },
    /// Outward from the source's position (a blast), within its radius.
    Radial,
}

/// A local wind source, in world space.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct WindSourceDesc {
    /// Where it is.
    pub position: Vec3,
    /// Which way it blows.
    pub shape: WindShape,
    /// Its speed at the centre, m/s.
    pub speed: f32,
    /// How far it reaches, metres.
    pub radius: f32,
    /// How it weakens towards its radius.
    pub falloff: Falloff,
}

impl WindSourceDesc {
    /// The velocity it adds at `p`.
    pub(crate) fn velocity_at(&self, p: Vec3) -> Vec3 {
        if !(self.radius > 0.0 && self.speed.is_finite()) {
            return Vec3::ZERO;
        }
        let offset = p - self.position;
        let strength = self.speed * self.falloff.at(offset.length() / self.radius);
        if strength == 0.0 {
            return Vec3::ZERO;
        }
        let direction = match self.shape {
            WindShape::Directional { direction } => direction.normalize_or_zero(),
            WindShape::Radial => offset.normalize_or_zero(),
        };
        direction * strength
    }
}

/// The wind over the world: a base velocity, gusts and local sources, summed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WindField {
    /// The wind everywhere, m/s.
    pub velocity: Vec3,
    /// Its variation in time and space.
    pub gusts: Gusts,
    /// Local sources.
    pub sources: Vec<WindSourceDesc>,
}

impl WindField {
    /// No wind anywhere.
    pub const STILL: Self = Self {
        velocity: Vec3::ZERO,
        gusts: Gusts {
            strength: 0.0,
            frequency: 0.5,
            length: 4.0,
            seed: 1,
        },
        sources: Vec::new(),
    };

    /// Whether the air is still everywhere: no wind, no gusts, no source.
    pub fn is_still(&self) -> bool {
        self.velocity == Vec3::ZERO && self.gusts.strength == 0.0 && self.sources.is_empty()
    }

    #[cfg(test)]
    /// The wind velocity at `p` at time `t` (finite: a source or gust that is not gives
    /// nothing).
    pub(crate) fn velocity_at(&self, p: Vec3, t: f32) -> Vec3 {
        let mut v = self.velocity + self.gusts.velocity_at(p, t);
        for source in &self.sources {
            v += source.velocity_at(p);
        }
        if v.is_finite() { v } else { Vec3::ZERO }
    }
}

/// The acceleration the air gives every particle over the coming step of length `dt`, into
/// `acceleration` (one per particle): the forces of the module docs, from positions `x`,
/// velocities `v` and the wind at each particle (`wind`; a triangle's is its corners' mean), limited
/// as described there, divided by the particle masses (inverse masses `w`; pinned particles
/// get none). `density` is the cloth's areal density, for the limit.
#[allow(clippy::too_many_arguments)]
pub(crate) fn air_accelerations(
    air: &AirSettings,
    triangles: &[[u32; 3]],
    x: &[Vec3A],
    v: &[Vec3A],
    w: &[f32],
    wind: &[Vec3A],
    density: f32,
    dt: f32,
    acceleration: &mut [Vec3A],
) {
    acceleration.fill(Vec3A::ZERO);
    // A plate's mass is `density |cross| / 2`: the limit `|F| dt <= |u| m`, squared.
    let limit_factor = (0.5 * density / dt) * (0.5 * density / dt);
    for t in triangles {
        let [a, b, c] = t.map(|i| i as usize);
        let cross = (x[b] - x[a]).cross(x[c] - x[a]);
        let relative = (v[a] + v[b] + v[c] - wind[a] - wind[b] - wind[c]) * (1.0 / 3.0);
        let force = triangle_force(air, cross, relative);
        let f2 = force.length_squared();
        let limit2 = relative.length_squared() * cross.length_squared() * limit_factor;
        // Branch-free: whether a triangle is limited changes from one to the next.
        let scale = (limit2 / f2.max(f32::MIN_POSITIVE)).sqrt().min(1.0);
        let share = force * (scale * (1.0 / 3.0));
        acceleration[a] += share;
        acceleration[b] += share;
        acceleration[c] += share;
    }
    for (a, &w) in acceleration.iter_mut().zip(w) {
        *a *= w;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn random_vector(rng: &mut Rng) -> Vec3A {
        rng.vec3(-1.0, 1.0).into()
    }

    #[test]
    fn the_force_reverses_with_the_flow_ignores_the_side_and_lifts_across() {
        let air = AirSettings::default();
        let mut rng = Rng(7);
        for _ in 0..1000 {
            let cross = random_vector(&mut rng);
            let u = random_vector(&mut rng) * 20.0;
            let f = triangle_force(&air, cross, u);
            assert!(f.is_finite());
            // Reversed flow, reversed force.
            assert!((triangle_force(&air, cross, -u) + f).length() <= 1e-4 * (1.0 + f.length()));
            // The other face towards the flow: the same force.
            assert!((triangle_force(&air, -cross, u) - f).length() <= 1e-4 * (1.0 + f.length()));
            // The drag opposes the flow; the lift is perpendicular to it.
            let flow = u.normalize();
            let drag = flow * f.dot(flow);
            let lift = f - drag;
            assert!(f.dot(flow) <= 1e-6);
            assert!(lift.dot(flow).abs() <= 1e-4 * (1.0 + lift.length()));
            // Its size: drag 1/2 rho C_d A u^2 c, lift 1/2 rho C_l A u^2 c s.
            let area = 0.5 * cross.length();
            let c = cross.normalize().dot(flow).abs();
            let s = (1.0 - c * c).max(0.0).sqrt();
            let q = 0.5 * air.density * area * u.length_squared();
            assert!((drag.length() - q * air.drag * c).abs() <= 1e-3 * (1.0 + q));
            assert!((lift.length() - q * air.lift * c * s).abs() <= 1e-3 * (1.0 + q));
        }
    }

    #[test]
    fn no_relative_motion_edge_on_degenerate_or_not_finite_gives_no_force() {
        let air = AirSettings::default();
        let cross = Vec3A::new(0.0, 2.0, 0.0);
        assert_eq!(triangle_force(&air, cross, Vec3A::ZERO), Vec3A::ZERO);
        // Edge on.
        assert!(triangle_force(&air, cross, Vec3A::new(5.0, 0.0, 3.0)).length() < 1e-6);
        assert_eq!(
            triangle_force(&air, Vec3A::ZERO, Vec3A::X * 10.0),
            Vec3A::ZERO
        );
        for bad in [f32::NAN, f32::INFINITY] {
            assert_eq!(triangle_force(&air, cross, Vec3A::splat(bad)), Vec3A::ZERO);
            assert_eq!(
                triangle_force(&air, Vec3A::splat(bad), Vec3A::X),
                Vec3A::ZERO
            );
        }
        // No air.
        let vacuum = AirSettings {
            density: 0.0,
            ..air
        };
        assert_eq!(triangle_force(&vacuum, cross, Vec3A::Y * 10.0), Vec3A::ZERO);
    }

    #[test]
    fn gusts_are_smooth_seeded_and_as_strong_as_asked() {
        let gusts = Gusts {
            strength: 3.0,
            ..Gusts::default()
        };
        // Root mean square over time at one point, and over points at one time.
        let n = 20_000;
        let rms_time = (0..n)
            .map(|i| {
                gusts
                    .velocity_at(Vec3::ZERO, i as f32 * 0.01)
                    .length_squared()
            })
            .sum::<f32>()
            / n as f32;
        assert!((rms_time.sqrt() - 3.0).abs() < 0.45, "{}", rms_time.sqrt());
        // Smooth: a small step in time or space changes it little.
        for i in 0..1000 {
            let (p, t) = (
                Vec3::new(i as f32 * 0.37, 1.0, -(i as f32) * 0.11),
                i as f32 * 0.13,
            );
            let a = gusts.velocity_at(p, t);
            assert!((gusts.velocity_at(p, t + 1e-3) - a).length() < 0.1);
            assert!((gusts.velocity_at(p + Vec3::X * 1e-3, t) - a).length() < 0.1);
        }
        // Deterministic, and the seed matters.
        let other = Gusts { seed: 2, ..gusts };
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(gusts.velocity_at(p, 4.0), gusts.velocity_at(p, 4.0));
        assert_ne!(gusts.velocity_at(p, 4.0), other.velocity_at(p, 4.0));
        // None asked, none given.
        assert_eq!(Gusts::default().velocity_at(p, 4.0), Vec3::ZERO);
    }

    #[test]
    fn the_linear_gust_field_follows_the_gusts_over_a_cloth_smaller_than_a_gust() {
        // A 1 m cloth of random points, gusts 4 m long, at random times and places.
        let gusts = Gusts {
            strength: 5.0,
            ..Gusts::default()
        };
        let mut rng = Rng(3);
        let (mut worst, mut sum_squares, mut count) = (0.0f32, 0.0f32, 0);
        for _ in 0..200 {
            let centre = random_vector(&mut rng) * 20.0;
            let t = random_vector(&mut rng).x.abs() * 100.0;
            let x: Vec<Vec3A> = (0..50)
                .map(|_| centre + random_vector(&mut rng) * 0.5)
                .collect();
            let field = GustField::over(&gusts, &x, t).unwrap();
            for &p in &x {
                let exact = Vec3A::from(gusts.velocity_at(p.into(), t));
                let error = (field.at(p) - exact).length();
                worst = worst.max(error);
                sum_squares += error * error;
                count += 1;
            }
        }
        // Second order in the cloth's size over the gust's: a fraction of the strength.
        let rms = (sum_squares / count as f32).sqrt();
        println!("linear gust field over a 1 m cloth, 4 m gusts: rms error {rms}, worst {worst}");
        assert!(rms < 0.1 * gusts.strength, "{rms}");
        assert!(worst < 0.4 * gusts.strength, "{worst}");
        assert!(GustField::over(&Gusts::default(), &[Vec3A::ZERO], 0.0).is_none());
        assert!(GustField::over(&gusts, &[Vec3A::splat(f32::NAN)], 0.0).is_none());
    }

    #[test]
    fn sources_blow_their_way_within_their_radius() {
        let fan = WindSourceDesc {
            position: Vec3::ZERO,
            shape: WindShape::Directional {
                direction: Vec3::X * 2.0,
            },
            speed: 5.0,
            radius: 2.0,
            falloff: Falloff::Linear,
        };
        assert!((fan.velocity_at(Vec3::Y) - Vec3::X * 2.5).length() < 1e-5);
        assert_eq!(fan.velocity_at(Vec3::Y * 3.0), Vec3::ZERO);
        let blast = WindSourceDesc {
            shape: WindShape::Radial,
            falloff: Falloff::Constant,
            ..fan
        };
        assert!((blast.velocity_at(Vec3::Z) - Vec3::Z * 5.0).length() < 1e-5);
        assert_eq!(blast.velocity_at(Vec3::ZERO), Vec3::ZERO);
        let field = WindField {
            velocity: Vec3::new(1.0, 0.0, 0.0),
            sources: vec![fan, blast],
            ..WindField::default()
        };
        let p = Vec3::Z;
        assert!(
            (field.velocity_at(p, 0.0) - (Vec3::X + Vec3::X * 2.5 + Vec3::Z * 5.0)).length() < 1e-5
        );
        for f in [Falloff::Constant, Falloff::Linear, Falloff::Smooth] {
            assert_eq!(f.at(0.0), 1.0);
            assert_eq!(f.at(1.0), 0.0);
            assert_eq!(f.at(f32::NAN), 0.0);
        }
    }
}
