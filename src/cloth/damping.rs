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

use bevy::math::{Mat3A, Vec3A, Vec3Swizzles};

/// Multiplies every free particle's velocity by `1 - k`.
pub(crate) fn damp_plain(v: &mut [Vec3A], inverse_masses: &[f32], k: f32) {
    let factor = 1.0 - k;
    for (v, &w) in v.iter_mut().zip(inverse_masses) {
        if w > 0.0 {
            *v *= factor;
        }
    }
}

/// Removes the fraction `k` of every free particle's velocity relative to the rigid motion
/// that best fits all of them (see the module docs). Takes the particles' masses (0 for
/// particles that do not count, as pinned ones): no division per particle.
pub(crate) fn damp_rigid(x: &[Vec3A], v: &mut [Vec3A], masses: &[f32], k: f32) {
    let Some(motion) = RigidMotion::fit_masses(x, v, masses.iter().copied()) else {
        return;
    };
    apply_rigid(&motion, x, v, masses, k);
}

/// [`damp_rigid`] on two halves split at `middle`, their sums and their updates each run
/// through `join` (the same fit, its sums added in another order).
pub(crate) fn damp_rigid_halves(
    join: &dyn crate::cloth::sim::parallel::Join,
    middle: usize,
    x: &[Vec3A],
    v: &mut [Vec3A],
    masses: &[f32],
    k: f32,
) {
    let Some(first) = masses.iter().position(|&m| m > 0.0) else {
        return;
    };
    let (Some(&x0), Some(&v0)) = (x.get(first), v.get(first)) else {
        return;
    };
    if middle > x.len() || v.len() != x.len() || masses.len() != x.len() {
        return;
    }
    let (xa, xb) = x.split_at(middle);
    let (ma, mb) = masses.split_at(middle);
    let (mut sums_a, mut sums_b) = (MomentSums::default(), MomentSums::default());
    {
        let (va, vb) = v.split_at(middle);
        join.join(
            &mut || sums_a = MomentSums::over(xa, va, ma.iter().copied(), x0, v0),
            &mut || sums_b = MomentSums::over(xb, vb, mb.iter().copied(), x0, v0),
        );
    }
    let Some(motion) = sums_a.add(&sums_b).motion(x0, v0) else {
        return;
    };
    let (va, vb) = v.split_at_mut(middle);
    join.join(&mut || apply_rigid(&motion, xa, va, ma, k), &mut || {
        apply_rigid(&motion, xb, vb, mb, k)
    });
}

/// The mass-weighted sums a rigid fit is made of, taken about a reference position `x0` and
/// velocity `v0` (so that they stay of the cloth's own size in `f32`).
#[derive(Clone, Copy, Debug, Default)]
struct MomentSums {
    mass: f32,
    mr_sum: Vec3A,
    mu_sum: Vec3A,
    moment: Vec3A,
    /// sum m r r^T, as its six distinct entries: the diagonal (xx, yy, zz) and the rest
    /// (xy, yz, zx).
    diagonal: Vec3A,
    off_diagonal: Vec3A,
}

impl MomentSums {
    fn over(
        x: &[Vec3A],
        v: &[Vec3A],
        masses: impl Iterator<Item = f32>,
        x0: Vec3A,
        v0: Vec3A,
    ) -> Self {
        let mut s = Self::default();
        for ((x, v), m) in x.iter().zip(v).zip(masses) {
            if m > 0.0 {
                let r = *x - x0;
                let u = *v - v0;
                let mr = r * m;
                s.mass += m;
                s.mr_sum += mr;
                s.mu_sum += u * m;
                s.moment += mr.cross(u);
                s.diagonal += mr * r;
                s.off_diagonal += mr * r.yzx();
            }
        }
        s
    }

    fn add(&self, other: &Self) -> Self {
        Self {
            mass: self.mass + other.mass,
            mr_sum: self.mr_sum + other.mr_sum,
            mu_sum: self.mu_sum + other.mu_sum,
            moment: self.moment + other.moment,
            diagonal: self.diagonal + other.diagonal,
            off_diagonal: self.off_diagonal + other.off_diagonal,
        }
    }

    /// The rigid motion of the sums (taken about `x0`, `v0`); `None` if they hold no mass.
    fn motion(&self, x0: Vec3A, v0: Vec3A) -> Option<RigidMotion> {
        let Self {
            mass,
            mr_sum,
            mu_sum,
            moment,
            diagonal,
            off_diagonal,
        } = *self;
        if mass <= 0.0 {
            return None;
        }
        let c = mr_sum / mass;
        let vc = mu_sum / mass;
        let center_of_mass = x0 + c;
        let linear_velocity = v0 + vc;
        let angular_momentum = moment - c.cross(vc) * mass;
        // The second moments about the centre of mass, then the inertia tensor
        // sum m (|r|^2 Id - r r^T).
        let (qxx, qyy, qzz) = (diagonal.x, diagonal.y, diagonal.z);
        let (qxy, qyz, qxz) = (off_diagonal.x, off_diagonal.y, off_diagonal.z);
        let (cxx, cyy, czz) = (
            qxx - mass * c.x * c.x,
            qyy - mass * c.y * c.y,
            qzz - mass * c.z * c.z,
        );
        let (cxy, cxz, cyz) = (
            qxy - mass * c.x * c.y,
            qxz - mass * c.x * c.z,
            qyz - mass * c.y * c.z,
        );
        let (ixx, iyy, izz) = (cyy + czz, cxx + czz, cxx + cyy);
        let (ixy, ixz, iyz) = (-cxy, -cxz, -cyz);
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
        Some(RigidMotion {
            center_of_mass,
            linear_velocity,
            angular_velocity,
            angular_momentum,
            mass,
        })
    }
}

/// `v_i += k (rigid velocity at x_i - v_i)` for the particles whose `weights` (inverse masses
/// or masses) are positive.
fn apply_rigid(motion: &RigidMotion, x: &[Vec3A], v: &mut [Vec3A], weights: &[f32], k: f32) {
    for ((x, v), &w) in x.iter().zip(v.iter_mut()).zip(weights) {
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
    ///
    /// One pass: the sums are taken about the first free particle's position and velocity
    /// (so that they stay of the cloth's own size in `f32`), then shifted to the centre of
    /// mass: `L = sum m r x u - M c x v_c`, `sum m (r - c)(r - c)^T = sum m r r^T - M c c^T`.
    pub(crate) fn fit(x: &[Vec3A], v: &[Vec3A], inverse_masses: &[f32]) -> Option<Self> {
        Self::fit_masses(
            x,
            v,
            inverse_masses
                .iter()
                .map(|&w| if w > 0.0 { 1.0 / w } else { 0.0 }),
        )
    }

    /// [`RigidMotion::fit`] with the particles' masses (0 for particles that do not count).
    pub(crate) fn fit_masses(
        x: &[Vec3A],
        v: &[Vec3A],
        masses: impl Iterator<Item = f32> + Clone,
    ) -> Option<Self> {
        let first = masses.clone().position(|m| m > 0.0)?;
        let (x0, v0) = (*x.get(first)?, *v.get(first)?);
        MomentSums::over(x, v, masses, x0, v0).motion(x0, v0)
    }

    /// The rigid velocity at point `x`.
    #[inline]
    pub(crate) fn velocity_at(&self, x: Vec3A) -> Vec3A {
        self.linear_velocity + self.angular_velocity.cross(x - self.center_of_mass)
    }
}
