//! The adaptive step of a [`ClothSolver`] ([`SolverSettings::adaptive`]): a step undone and
//! run again with more substeps while it ends above the target strain.

use bevy::math::Vec3;

use super::ClothSolver;
use super::parallel::Join;
use crate::cloth::settings::{AdaptiveSubsteps, SolverSettings};

impl ClothSolver {
    /// One fixed step under [`SolverSettings::adaptive`]: the step runs at the chosen count;
    /// if it ends above the target strain it is undone (the state, the contacts with
    /// friction's anchors, which every substep moves with the colliders' surfaces, and the
    /// exact edges' warm start) and run
    /// again with more substeps (up to the maximum), so every step that can meet the target
    /// does. The count then goes down as [`AdaptiveSubsteps::next`] says.
    /// [`ClothSolver::last_substeps`] counts every substep run, undone ones included (the
    /// step's cost).
    pub(super) fn step_adaptive(
        &mut self,
        settings: &SolverSettings,
        budget: &AdaptiveSubsteps,
        acceleration: Vec3,
        dt: f32,
        join: &dyn Join,
    ) {
        let (lo, hi) = (
            budget.min_substeps.max(1),
            budget.max_substeps.max(budget.min_substeps.max(1)),
        );
        let mut chosen = *settings;
        chosen.substeps = match self.adaptive_substeps {
            0 => settings.substeps,
            n => n,
        }
        .clamp(lo, hi);
        self.adaptive_backup.clone_from(&self.state);
        self.adaptive_contacts_backup.clone_from(&self.contacts);
        self.adaptive_projection_backup.clear();
        if let Some(projection) = &self.fast_projection {
            self.adaptive_projection_backup
                .extend_from_slice(projection.warm_start());
        }
        let mut run = 0;
        loop {
            self.step_substeps(&chosen, acceleration, dt, join, None);
            run += chosen.substeps;
            let strain = self.strain().max;
            let next = budget.next(chosen.substeps, strain, &mut self.adaptive_calm);
            if next > chosen.substeps && strain.is_finite() {
                // Over the target: undo the step and run it again with more.
                self.state.clone_from(&self.adaptive_backup);
                self.contacts.clone_from(&self.adaptive_contacts_backup);
                if let Some(projection) = self.fast_projection.as_mut() {
                    projection.restore_warm_start(&self.adaptive_projection_backup);
                }
                chosen.substeps = next;
                continue;
            }
            self.adaptive_substeps = next;
            break;
        }
        self.last_substeps = run;
    }
}
