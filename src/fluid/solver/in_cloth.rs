//! A fluid stepped inside a cloth's substeps ([`FluidSolver::step_with_cloth`]): the fluid as
//! the cloth's step sees it, a [`SubstepCoupling`].

use bevy::math::{Vec3, Vec3A};

use super::FluidSolver;
use crate::cloth::SubstepCoupling;
use crate::cloth::{ClothSolver, OneThread, SolverSettings};
use crate::error::ClothError;

impl FluidSolver {
    /// Advances the fluid and `cloth` together by `dt` seconds under `gravity`, in the
    /// cloth's substeps (`cloth_settings`, at a fixed count): in each of the cloth's
    /// iterations its share of the density sweeps (the fluid's own budget of
    /// `substeps x iterations` sweeps per step spread over the cloth's iterations, at least
    /// one in each cloth substep), its colliders and its contacts with the cloth's
    /// triangles, both ways (`cloth_coupling.rs`), before the cloth's own constraints. A
    /// bad setting or `dt` is refused by the cloth, and nothing moves.
    pub fn step_with_cloth(
        &mut self,
        cloth: &mut ClothSolver,
        cloth_settings: &SolverSettings,
        gravity: Vec3,
        dt: f32,
    ) -> Result<(), ClothError> {
        // The cloth's step checks its settings and `dt` before anything moves; building the
        // neighbours first changes no particle.
        if !self.begin_step(gravity, dt) {
            return cloth.step(cloth_settings, gravity, dt);
        }
        // The fluid's own budget of `substeps x iterations` density sweeps per step, at
        // least one in every cloth substep.
        let budget = self.settings.substeps.max(1) * self.settings.iterations.max(1);
        let substeps = cloth_settings.substeps.max(1);
        let sweeps = budget.div_ceil(substeps);
        let mut coupling = FluidInCloth {
            fluid: self,
            sweeps,
            iterations: cloth_settings.iterations.max(1),
            iteration: 0,
            substep: 0,
            substeps: cloth_settings.substeps.max(1),
        };
        coupling.fluid.cloth_contacts.begin_step();
        let result =
            cloth.step_coupled(cloth_settings, gravity, dt, &OneThread, Some(&mut coupling));
        self.recover_non_finite();
        result
    }
}

/// The fluid as the cloth's step sees it (`SubstepCoupling`).
pub(crate) struct FluidInCloth<'a> {
    pub(crate) fluid: &'a mut FluidSolver,
    /// Density sweeps per cloth substep, spread over its iterations.
    pub(crate) sweeps: u32,
    /// The cloth's iterations per substep, and the current one.
    pub(crate) iterations: u32,
    pub(crate) iteration: u32,
    /// The current substep, and how many the cloth takes.
    pub(crate) substep: u32,
    pub(crate) substeps: u32,
}
impl SubstepCoupling for FluidInCloth<'_> {
    fn begin_substep(&mut self, x: &[Vec3A], triangles: &[[u32; 3]], h: f32) {
        self.fluid.predict(h);
        let (radius, mass) = (
            self.fluid.settings().particle_radius,
            self.fluid.particle_mass(),
        );
        let (xf, _, contacts) = self.fluid.contact_parts();
        contacts.radius = radius;
        contacts.mass = mass;
        contacts.h = h;
        contacts.find_candidates(xf, x, triangles);
        self.iteration = 0;
    }

    fn iterate(&mut self, x: &mut [Vec3A], x_prev: &[Vec3A], w: &[f32], triangles: &[[u32; 3]]) {
        let t = (self.substep + 1) as f32 / self.substeps as f32;
        // Iteration k of n takes ceil((k + 1) s / n) - ceil(k s / n) of the substep's s
        // sweeps: the first iteration one at least, the rest spread evenly.
        let (k, n) = (self.iteration, self.iterations.max(1));
        let due = ((k + 1) * self.sweeps).div_ceil(n) - (k * self.sweeps).div_ceil(n);
        self.iteration += 1;
        for _ in 0..due {
            self.fluid.project_density();
        }
        self.fluid.project_colliders(t);
        let (xf, xf_prev, contacts) = self.fluid.contact_parts();
        contacts.project(xf, xf_prev, x, x_prev, w, triangles);
    }

    fn end_substep(&mut self, h: f32) {
        self.fluid.end_substep(h);
        self.substep += 1;
    }
}
