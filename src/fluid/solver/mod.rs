//! The Position Based Fluids step (Macklin and Müller 2013), for one set of particles.
//!
//! Once per fixed step the neighbour lists are built (`neighbours.rs`): two particles are
//! neighbours if they are closer than the smoothing radius `h` plus how far each can travel
//! in the step relative to the fluid's typical velocity (the median of each component;
//! `|v - v_typical| dt + g dt^2 / 2`, at most `h / 2`), so a fluid carried along searches no
//! further than one at rest, and the particles at rest in a pool no further than their
//! kernel while a jet falls into it. Then, in each of `substeps` substeps of length `dt_s`:
//!
//! 1. **Predict**: `v += dt_s g`, `x* = x + dt_s v`.
//! 2. **Density constraint**, `iterations` Jacobi sweeps. Each particle's density is
//!    `rho_i = m sum_j W_poly6(x_i - x_j)` (itself included) and its constraint
//!    `C_i = max(rho_i / rho_0 - 1, 0)`: one-sided, so a free surface (where the kernel
//!    is cut off) is not pulled together. With the spiky kernel's gradient `grad W_ij`,
//!    `lambda_i = -C_i / (sum_k |grad_k C_i|^2 + epsilon)` and every particle moves by
//!    `dx_i = m / rho_0 sum_j (lambda_i + lambda_j + s_corr) grad W_ij`, where
//!    `s_corr = -k (W(x_ij) / W(0.2 h))^4 / D_0` is the artificial pressure (a short-range
//!    repulsion). The mass `m` makes a particle inside a cubic lattice of spacing `2 r`
//!    exactly `rho_0` dense, `D_0` is that particle's `sum_k |grad_k C|^2` (so `k` pushes
//!    as a density error of `k` would; the paper's `s_corr` has no unit of its own and
//!    its `k = 0.1` holds only for its units), and `epsilon` is
//!    [`FluidSettings::relaxation`] times `D_0`.
//!    After each sweep every particle closer to a collider than its radius is moved out to
//!    it along the surface normal.
//! 3. **Velocities**: `v = (x* - x) / dt_s`; vorticity confinement
//!    (`omega_i = sum_j m / rho_j v_ij x grad W_ij`, `f_i = epsilon N x omega_i` with `N` the
//!    direction in which `|omega|` grows) and XSPH viscosity
//!    (`v_i += c sum_j 2 m / (rho_i + rho_j) (v_j - v_i) W_ij`, symmetric in `i` and `j`,
//!    so momentum is kept); `x = x*`.
//!
//! [`FluidSolver::step_with_cloth`] runs the same substep inside a cloth's substeps instead
//! (`in_cloth.rs`, the contacts in `cloth_coupling.rs`), with the cloth's substep length and
//! its contacts with the cloth.
//!
//! A particle whose state is not finite after a step (a collider that moved by a huge
//! amount, say) is put back where the step began, at rest, and counted
//! ([`FluidSolver::divergences`]).

use bevy::math::{Vec3, Vec3A};

use super::cloth_coupling::ClothContacts;
use super::kernels::Kernels;
use super::neighbours::Neighbours;
use super::settings::FluidSettings;
use crate::collide::SolverCollider;
use crate::error::FluidError;

mod in_cloth;

/// The artificial pressure's reference distance, as a fraction of `h`.
const CORRECTION_AT: f32 = 0.2;
/// The artificial pressure's exponent.
const CORRECTION_EXPONENT: i32 = 4;

/// The density error of a fluid: how far its particles are compressed past the rest density.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DensityError {
    /// The mean over the particles of `max(rho / rho_0 - 1, 0)`.
    pub mean: f32,
    /// The largest.
    pub max: f32,
}

/// One body of fluid particles: their state, settings, colliders and the step's scratch
/// memory. [`FluidSolver::step`] advances it by one fixed step.
#[derive(Clone, Debug)]
pub struct FluidSolver {
    settings: FluidSettings,
    kernels: Kernels,
    /// Each particle's mass, kg.
    mass: f32,
    /// The density constraint's `epsilon`.
    epsilon: f32,
    /// `1 / W(0.2 h)`.
    inv_correction_w: f32,
    /// The artificial pressure's unit: `1 / sum_k |grad_k C|^2` of a particle inside the
    /// rest lattice, so that `k` is a density error's worth of push.
    correction_unit: f32,
    positions: Vec<Vec3A>,
    velocities: Vec<Vec3A>,
    /// Positions at the start of the current substep.
    previous: Vec<Vec3A>,
    densities: Vec<f32>,
    lambdas: Vec<f32>,
    /// Per-particle scratch: position corrections, then vorticities.
    scratch: Vec<Vec3A>,
    /// Per-particle scratch: velocities after viscosity, `|omega|`.
    scratch_velocities: Vec<Vec3A>,
    scratch_scalars: Vec<f32>,
    neighbours: Neighbours,
    colliders: Vec<SolverCollider>,
    /// The contacts with a cloth (`cloth_coupling.rs`), their scratch memory kept.
    cloth_contacts: ClothContacts,
    /// The acceleration of the current step.
    gravity: Vec3A,
    divergences: usize,
}

impl FluidSolver {
    /// An empty fluid with `settings`.
    pub fn new(settings: FluidSettings) -> Result<Self, FluidError> {
        settings.validate()?;
        let mut solver = Self {
            settings,
            kernels: Kernels::new(settings.smoothing_radius()),
            mass: 0.0,
            epsilon: 0.0,
            inv_correction_w: 0.0,
            correction_unit: 0.0,
            positions: Vec::new(),
            velocities: Vec::new(),
            previous: Vec::new(),
            densities: Vec::new(),
            lambdas: Vec::new(),
            scratch: Vec::new(),
            scratch_velocities: Vec::new(),
            scratch_scalars: Vec::new(),
            neighbours: Neighbours::default(),
            colliders: Vec::new(),
            cloth_contacts: ClothContacts::default(),
            gravity: Vec3A::ZERO,
            divergences: 0,
        };
        solver.derive_constants();
        Ok(solver)
    }

    /// The mass, the relaxation and the artificial pressure's scale, from the settings.
    fn derive_constants(&mut self) {
        let s = self.settings.spacing();
        let kernels = Kernels::new(self.settings.smoothing_radius());
        // A particle inside a cubic lattice: its kernel sum and its constraint gradients.
        let reach = (kernels.h / s).ceil() as i32;
        let (mut sum_w, mut grad_sum, mut grad_sq) = (0.0f32, Vec3A::ZERO, 0.0f32);
        for i in -reach..=reach {
            for j in -reach..=reach {
                for k in -reach..=reach {
                    let r = Vec3A::new(i as f32, j as f32, k as f32) * s;
                    sum_w += kernels.poly6(r.length_squared());
                    let g = kernels.spiky_gradient(r);
                    grad_sum += g;
                    grad_sq += g.length_squared();
                }
            }
        }
        self.kernels = kernels;
        self.mass = self.settings.rest_density / sum_w;
        let scale = self.mass / self.settings.rest_density;
        let full = scale * scale * (grad_sum.length_squared() + grad_sq);
        self.epsilon = self.settings.relaxation * full;
        self.correction_unit = 1.0 / full;
        let at = CORRECTION_AT * kernels.h;
        self.inv_correction_w = 1.0 / kernels.poly6(at * at);
    }

    /// The settings.
    pub fn settings(&self) -> &FluidSettings {
        &self.settings
    }

    /// Changes the settings (the particles stay).
    pub fn set_settings(&mut self, settings: FluidSettings) -> Result<(), FluidError> {
        settings.validate()?;
        self.settings = settings;
        self.derive_constants();
        Ok(())
    }

    /// Adds particles at `positions`, all moving at `velocity`.
    pub fn add_particles(&mut self, positions: &[Vec3], velocity: Vec3) -> Result<(), FluidError> {
        if !velocity.is_finite() {
            return Err(FluidError::NonFiniteParticle { particle: 0 });
        }
        if let Some(particle) = positions.iter().position(|p| !p.is_finite()) {
            return Err(FluidError::NonFiniteParticle { particle });
        }
        self.positions
            .extend(positions.iter().map(|&p| Vec3A::from(p)));
        self.velocities
            .extend(std::iter::repeat_n(Vec3A::from(velocity), positions.len()));
        self.resize_scratch();
        Ok(())
    }

    /// Fills the box from `min` to `max` with particles at rest on a cubic lattice of the
    /// rest spacing (the first a particle radius inside each face); returns how many.
    pub fn add_box(&mut self, min: Vec3, max: Vec3) -> Result<usize, FluidError> {
        let r = self.settings.particle_radius;
        let s = self.settings.spacing();
        let counts = ((max - min) / s).floor();
        let empty = FluidError::EmptyBox {
            min: min.to_array(),
            max: max.to_array(),
        };
        if !counts.is_finite() || counts.min_element() < 1.0 {
            return Err(empty);
        }
        if counts.x * counts.y * counts.z > 4.0e6 {
            return Err(empty);
        }
        let [nx, ny, nz] = counts.to_array().map(|c| c as u32);
        let mut positions = Vec::with_capacity((nx * ny * nz) as usize);
        for j in 0..ny {
            for k in 0..nz {
                for i in 0..nx {
                    positions
                        .push(min + Vec3::splat(r) + Vec3::new(i as f32, j as f32, k as f32) * s);
                }
            }
        }
        self.add_particles(&positions, Vec3::ZERO)?;
        Ok(positions.len())
    }

    /// Removes every particle.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.velocities.clear();
        self.resize_scratch();
    }

    fn resize_scratch(&mut self) {
        let n = self.positions.len();
        self.previous.resize(n, Vec3A::ZERO);
        self.densities.resize(n, self.settings.rest_density);
        self.lambdas.resize(n, 0.0);
        self.scratch.resize(n, Vec3A::ZERO);
        self.scratch_velocities.resize(n, Vec3A::ZERO);
        self.scratch_scalars.resize(n, 0.0);
    }

    /// Sets the colliders the particles are kept out of (their poses over the next step).
    pub fn set_colliders(&mut self, colliders: &[SolverCollider]) -> Result<(), FluidError> {
        for (index, c) in colliders.iter().enumerate() {
            c.validate()
                .map_err(|source| FluidError::InvalidCollider { index, source })?;
        }
        self.colliders.clear();
        self.colliders.extend_from_slice(colliders);
        Ok(())
    }

    /// Positions, positions at the substep's start, and the contacts' scratch, for the
    /// coupling.
    pub(crate) fn contact_parts(&mut self) -> (&mut [Vec3A], &[Vec3A], &mut ClothContacts) {
        (
            &mut self.positions,
            &self.previous,
            &mut self.cloth_contacts,
        )
    }

    /// The particles' positions, metres.
    pub fn positions(&self) -> &[Vec3A] {
        &self.positions
    }

    /// The particles' velocities, m/s.
    pub fn velocities(&self) -> &[Vec3A] {
        &self.velocities
    }

    /// The particles' densities after the last step, kg/m^3.
    pub fn densities(&self) -> &[f32] {
        &self.densities
    }

    /// Each particle's mass, kg.
    pub fn particle_mass(&self) -> f32 {
        self.mass
    }

    /// How many particles there are.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// How many particles were put back because their state stopped being finite.
    pub fn divergences(&self) -> usize {
        self.divergences
    }

    /// The compression past the rest density after the last step.
    pub fn density_error(&self) -> DensityError {
        let rho0 = self.settings.rest_density;
        let mut error = DensityError::default();
        for &rho in &self.densities {
            let e = (rho / rho0 - 1.0).max(0.0);
            error.mean += e;
            error.max = error.max.max(e);
        }
        if !self.densities.is_empty() {
            error.mean /= self.densities.len() as f32;
        }
        error
    }

    /// The total momentum, kg m/s.
    pub fn momentum(&self) -> Vec3 {
        Vec3::from(self.velocities.iter().copied().sum::<Vec3A>() * self.mass)
    }

    /// The kinetic energy, J.
    pub fn kinetic_energy(&self) -> f32 {
        0.5 * self.mass
            * self
                .velocities
                .iter()
                .map(|v| v.length_squared())
                .sum::<f32>()
    }

    /// Advances the fluid by `dt` seconds under the acceleration `gravity`, alone (kept out
    /// of its colliders; [`FluidSolver::step_with_cloth`] steps it with a cloth).
    pub fn step(&mut self, gravity: Vec3, dt: f32) {
        if !self.begin_step(gravity, dt) {
            return;
        }
        let substeps = self.settings.substeps.max(1);
        let h = dt / substeps as f32;
        for s in 0..substeps {
            self.predict(h);
            let t_end = (s + 1) as f32 / substeps as f32;
            for _ in 0..self.settings.iterations.max(1) {
                self.project_density();
                self.project_colliders(t_end);
            }
            self.end_substep(h);
        }
        self.recover_non_finite();
    }

    /// The contacts with a cloth of the last [`FluidSolver::step_with_cloth`].
    pub fn cloth_contacts(&self) -> &ClothContacts {
        &self.cloth_contacts
    }

    /// Starts a step (neighbours, scratch); false if there is nothing to step or the input
    /// is not finite.
    fn begin_step(&mut self, gravity: Vec3, dt: f32) -> bool {
        if self.positions.is_empty() || !(dt > 0.0 && dt.is_finite()) || !gravity.is_finite() {
            return false;
        }
        self.gravity = Vec3A::from(gravity);
        self.build_neighbours(self.gravity, dt);
        true
    }

    /// A substep's prediction: `v += h g`, `x += h v`.
    pub(crate) fn predict(&mut self, h: f32) {
        let g = self.gravity;
        for ((x, x_prev), v) in self
            .positions
            .iter_mut()
            .zip(self.previous.iter_mut())
            .zip(self.velocities.iter_mut())
        {
            *x_prev = *x;
            *v += g * h;
            *x += *v * h;
        }
    }

    /// A substep's end: velocities from the positions, densities, vorticity confinement
    /// and viscosity.
    pub(crate) fn end_substep(&mut self, h: f32) {
        // v = (x - x_prev) / h, computed as v + (x - x_pred) / h with the prediction
        // `x_prev + v h` recomputed bit for bit (as the cloth does): a particle no constraint
        // moved keeps its velocity exactly, and the momentum a correction adds is that of the
        // correction alone, not the rounding of two nearly equal positions far from the origin.
        let inv_h = 1.0 / h;
        for ((v, &x), &x_prev) in self
            .velocities
            .iter_mut()
            .zip(&self.positions)
            .zip(&self.previous)
        {
            let predicted = x_prev + *v * h;
            *v += (x - predicted) * inv_h;
        }
        self.update_densities();
        if self.settings.vorticity > 0.0 {
            self.confine_vorticity(h);
        }
        if self.settings.viscosity > 0.0 {
            self.apply_viscosity();
        }
    }

    /// The neighbour lists for this step (see the module docs).
    fn build_neighbours(&mut self, g: Vec3A, dt: f32) {
        // The fluid's typical velocity: the median of each component (a jet falling into a
        // pool at rest leaves the pool's particles at rest relative to it).
        let n = self.positions.len();
        let typical = Vec3A::from_array(std::array::from_fn(|k| {
            let values = &mut self.scratch_scalars[..n];
            for (value, v) in values.iter_mut().zip(&self.velocities) {
                *value = v[k];
            }
            *values.select_nth_unstable_by(n / 2, f32::total_cmp).1
        }));
        let h = self.kernels.h;
        let floor = 0.5 * g.length() * dt * dt;
        for (margin, v) in self.scratch_scalars.iter_mut().zip(&self.velocities) {
            *margin = ((*v - typical).length() * dt + floor).min(0.5 * h);
        }
        self.neighbours
            .build(&self.positions, h, &self.scratch_scalars[..n]);
    }

    /// `rho_i` for every particle at the current positions.
    fn update_densities(&mut self) {
        let k = &self.kernels;
        let self_w = k.poly6(0.0);
        for i in 0..self.positions.len() {
            let p = self.positions[i];
            let mut sum = self_w;
            for &j in self.neighbours.of(i) {
                sum += k.poly6((p - self.positions[j as usize]).length_squared());
            }
            self.densities[i] = self.mass * sum;
        }
    }

    /// One Jacobi sweep of the density constraint.
    pub(crate) fn project_density(&mut self) {
        self.update_densities();
        let k = self.kernels;
        let rho0 = self.settings.rest_density;
        let scale = self.mass / rho0;
        for i in 0..self.positions.len() {
            let c = self.densities[i] / rho0 - 1.0;
            if c <= 0.0 {
                self.lambdas[i] = 0.0;
                continue;
            }
            let p = self.positions[i];
            let (mut sum, mut sq) = (Vec3A::ZERO, 0.0f32);
            for &j in self.neighbours.of(i) {
                let g = k.spiky_gradient(p - self.positions[j as usize]) * scale;
                sum += g;
                sq += g.length_squared();
            }
            self.lambdas[i] = -c / (sum.length_squared() + sq + self.epsilon);
        }
        let strength = self.settings.artificial_pressure * self.correction_unit;
        for i in 0..self.positions.len() {
            let p = self.positions[i];
            let li = self.lambdas[i];
            let mut dx = Vec3A::ZERO;
            for &j in self.neighbours.of(i) {
                let r = p - self.positions[j as usize];
                let r2 = r.length_squared();
                let s_corr = if strength > 0.0 {
                    let ratio = k.poly6(r2) * self.inv_correction_w;
                    -strength * ratio.powi(CORRECTION_EXPONENT)
                } else {
                    0.0
                };
                dx += k.spiky_gradient(r) * (li + self.lambdas[j as usize] + s_corr);
            }
            self.scratch[i] = dx * scale;
        }
        for (x, dx) in self.positions.iter_mut().zip(&self.scratch) {
            *x += *dx;
        }
    }

    /// Moves every particle closer than its radius to a collider (posed a fraction `t`
    /// through the step) out to that distance.
    pub(crate) fn project_colliders(&mut self, t: f32) {
        let r = self.settings.particle_radius;
        for c in &self.colliders {
            let pose = c.pose_at(t);
            let reach = r + c.margin;
            for x in &mut self.positions {
                let local = pose.inverse_transform_point(*x);
                if let Some((d, n)) = c.shape.signed_distance(local, reach)
                    && d < reach
                {
                    *x += pose.rotation * n * (reach - d);
                }
            }
        }
    }

    /// Vorticity confinement (see the module docs) as a velocity change over `h`.
    fn confine_vorticity(&mut self, h: f32) {
        let k = self.kernels;
        let n = self.positions.len();
        for i in 0..n {
            let p = self.positions[i];
            let v = self.velocities[i];
            let mut omega = Vec3A::ZERO;
            for &j in self.neighbours.of(i) {
                let j = j as usize;
                let g = k.spiky_gradient(p - self.positions[j]);
                omega += (self.velocities[j] - v).cross(-g) * (self.mass / self.densities[j]);
            }
            self.scratch[i] = omega;
            self.scratch_scalars[i] = omega.length();
        }
        let epsilon = self.settings.vorticity;
        for i in 0..n {
            let p = self.positions[i];
            let mut eta = Vec3A::ZERO;
            for &j in self.neighbours.of(i) {
                let j = j as usize;
                let g = k.spiky_gradient(p - self.positions[j]);
                eta += g
                    * ((self.scratch_scalars[j] - self.scratch_scalars[i]) * self.mass
                        / self.densities[j]);
            }
            // The SPH gradient of |omega|: where it grows.
            let length = eta.length();
            if length > 1e-9 {
                let f = (eta / length).cross(self.scratch[i]) * epsilon;
                self.velocities[i] += f * h;
            }
        }
    }

    /// XSPH viscosity (see the module docs).
    fn apply_viscosity(&mut self) {
        let k = self.kernels;
        let c = self.settings.viscosity;
        for i in 0..self.positions.len() {
            let p = self.positions[i];
            let v = self.velocities[i];
            let mut dv = Vec3A::ZERO;
            for &j in self.neighbours.of(i) {
                let j = j as usize;
                let w = k.poly6((p - self.positions[j]).length_squared());
                let volume = 2.0 * self.mass / (self.densities[i] + self.densities[j]);
                dv += (self.velocities[j] - v) * (w * volume);
            }
            self.scratch_velocities[i] = v + dv * c;
        }
        std::mem::swap(&mut self.velocities, &mut self.scratch_velocities);
    }

    /// Puts a particle whose state is not finite back where its substep began, at rest.
    fn recover_non_finite(&mut self) {
        for i in 0..self.positions.len() {
            if !(self.positions[i].is_finite() && self.velocities[i].is_finite()) {
                self.positions[i] = if self.previous[i].is_finite() {
                    self.previous[i]
                } else {
                    Vec3A::ZERO
                };
                self.velocities[i] = Vec3A::ZERO;
                self.divergences += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn bad_settings_and_particles_are_refused_and_bad_steps_change_nothing() {
        for bad in [
            FluidSettings {
                particle_radius: f32::NAN,
                ..FluidSettings::default()
            },
            FluidSettings {
                rest_density: -1.0,
                ..FluidSettings::default()
            },
            FluidSettings {
                iterations: 0,
                ..FluidSettings::default()
            },
            FluidSettings {
                viscosity: 2.0,
                ..FluidSettings::default()
            },
        ] {
            assert!(matches!(
                FluidSolver::new(bad),
                Err(FluidError::InvalidSetting { .. })
            ));
        }
        let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
        assert_eq!(
            fluid.add_particles(&[Vec3::ZERO, Vec3::NAN], Vec3::ZERO),
            Err(FluidError::NonFiniteParticle { particle: 1 })
        );
        assert!(fluid.is_empty());
        assert!(matches!(
            fluid.add_box(Vec3::ZERO, Vec3::new(1.0, 0.001, 1.0)),
            Err(FluidError::EmptyBox { .. })
        ));
        assert_eq!(fluid.add_box(Vec3::ZERO, Vec3::splat(0.1)).unwrap(), 125);
        let before = fluid.positions().to_vec();
        fluid.step(Vec3::NAN, 1.0 / 60.0);
        fluid.step(Vec3::ZERO, f32::INFINITY);
        assert_eq!(fluid.positions(), &before[..]);
    }

    /// A random cloud falling freely (no colliders) with vorticity off: the density
    /// projection and the viscosity move particles in equal and opposite pairs, so the
    /// momentum changes by the weight's impulse alone.
    #[test]
    fn a_falling_cloud_keeps_its_momentum_but_for_gravity() {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut fluid = FluidSolver::new(FluidSettings::default()).unwrap();
        let points: Vec<Vec3> = (0..400).map(|_| rng.vec3(-0.5, 0.5) * 0.12).collect();
        fluid
            .add_particles(&points, Vec3::new(0.3, 1.0, 0.0))
            .unwrap();
        let g = Vec3::new(0.0, -9.81, 0.0);
        let mass = fluid.particle_mass() * fluid.len() as f32;
        let start = fluid.momentum();
        for step in 1..=30 {
            fluid.step(g, 1.0 / 60.0);
            let expected = start + g * mass * step as f32 / 60.0;
            // f32 round-off: positions of a metre change by millimetres per substep.
            let error = (fluid.momentum() - expected).length();
            assert!(
                error <= 1e-4 * expected.length(),
                "step {step}: {error} of {expected}"
            );
        }
        assert!(fluid.density_error().max > 0.0 || fluid.kinetic_energy() > 0.0);
    }
}
