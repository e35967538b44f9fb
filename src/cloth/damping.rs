//! Velocity damping.
//!
//! - [`damp_plain`]: every velocity shrinks by the same factor. Simple, but it also slows a
//!   cloth that falls or spins as a whole, so it changes the free-fall trajectory and drains
//!   angular momentum.
//! - [`damp_rigid`]: the damping of Mueller et al. 2006, section 3.5. The particles' velocities
//!   are split into the best-fitting rigid motion (the centre-of-mass velocity `v_cm` plus a
//!   rotation `omega x r`, with `omega = I^-1 L` from the angular momentum `L` and the inertia
//!   tensor `I` about the centre of mass) and the rest; only the rest is damped:
//!   `v_i += k (v_cm + omega x r_i - v_i)`. Linear and angular momentum of the free particles
//!   are unchanged, so a falling or spinning cloth is not slowed; flapping and stretching
//!   waves are.
//!
//! Both take `k` in [0, 1], the fraction of the damped part removed in one call; the solver
//! uses `k = 1 - exp(-rate h)` for a rate in 1/s and a substep `h`, so the damping does not
//! depend on the substep count. Particles with inverse mass 0 (pinned) are left alone and do
//! not count in the rigid fit.

use bevy::math::{Mat3A, Vec3A};

/// Multiplies every free particle's velocity by `1 - k`.
pub fn damp_plain(v: &mut [Vec3A], inverse_masses: &[f32], k: f32) {
    let factor = 1.0 - k;
    for (v, &w) in v.iter_mut().zip(inverse_masses) {
        if w > 0.0 {
            *v *= factor;
        }
    }
}

/// Removes the fraction `k` of every free particle's velocity relative to the rigid motion
/// that best fits all of them (see the module docs).
pub fn damp_rigid(x: &[Vec3A], v: &mut [Vec3A], inverse_masses: &[f32], k: f32) {
    let Some(motion) = RigidMotion::fit(x, v, inverse_masses) else {
        return;
    };
    for ((x, v), &w) in x.iter().zip(v.iter_mut()).zip(inverse_masses) {
        if w > 0.0 {
            let rigid = motion.velocity_at(*x);
            *v += (rigid - *v) * k;
        }
    }
}

/// The rigid motion that best fits the velocities of a set of particles (in the least-squares,
/// mass-weighted sense): it has their linear and angular momentum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMotion {
    /// Centre of mass, metres.
    pub center_of_mass: Vec3A,
    /// Centre-of-mass velocity, m/s.
    pub linear_velocity: Vec3A,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vec3A,
    /// Angular momentum about the centre of mass, kg m^2/s.
    pub angular_momentum: Vec3A,
    /// Total mass of the particles with a positive inverse mass, kg.
    pub mass: f32,
}

impl RigidMotion {
    /// Fits the motion to the particles with a positive inverse mass; `None` if there are none.
    pub fn fit(x: &[Vec3A], v: &[Vec3A], inverse_masses: &[f32]) -> Option<Self> {
        let mut mass = 0.0;
        let mut mx = Vec3A::ZERO;
        let mut mv = Vec3A::ZERO;
        for ((x, v), &w) in x.iter().zip(v).zip(inverse_masses) {
            if w > 0.0 {
                let m = 1.0 / w;
                mass += m;
                mx += *x * m;
                mv += *v * m;
            }
        }
        if mass <= 0.0 {
            return None;
        }
        let center_of_mass = mx / mass;
        let linear_velocity = mv / mass;
        let mut angular_momentum = Vec3A::ZERO;
        // Inertia tensor sum m (|r|^2 Id - r r^T), accumulated as its six distinct entries.
        let (mut ixx, mut iyy, mut izz, mut ixy, mut ixz, mut iyz) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for ((x, v), &w) in x.iter().zip(v).zip(inverse_masses) {
            if w > 0.0 {
                let m = 1.0 / w;
                let r = *x - center_of_mass;
                angular_momentum += r.cross(*v - linear_velocity) * m;
                ixx += m * (r.y * r.y + r.z * r.z);
                iyy += m * (r.x * r.x + r.z * r.z);
                izz += m * (r.x * r.x + r.y * r.y);
                ixy -= m * r.x * r.y;
                ixz -= m * r.x * r.z;
                iyz -= m * r.y * r.z;
            }
        }
        let inertia = Mat3A::from_cols(
            Vec3A::new(ixx, ixy, ixz),
            Vec3A::new(ixy, iyy, iyz),
            Vec3A::new(ixz, iyz, izz),
        );
        let trace = ixx + iyy + izz;
        // A line of particles (a rope) has a singular inertia tensor: regularise it slightly,
        // which leaves the rotation about the line undetermined (zero) as it should be.
        let det = inertia.determinant();
        let angular_velocity = if trace <= 0.0 {
            Vec3A::ZERO
        } else if det.abs() > 1e-9 * trace * trace * trace {
            inertia.inverse() * angular_momentum
        } else {
            (inertia + Mat3A::from_diagonal((Vec3A::ONE * 1e-6 * trace).into())).inverse()
                * angular_momentum
        };
        Some(Self {
            center_of_mass,
            linear_velocity,
            angular_velocity,
            angular_momentum,
            mass,
        })
    }

    /// The rigid velocity at point `x`.
    #[inline]
    pub fn velocity_at(&self, x: Vec3A) -> Vec3A {
        self.linear_velocity + self.angular_velocity.cross(x - self.center_of_mass)
    }
}
