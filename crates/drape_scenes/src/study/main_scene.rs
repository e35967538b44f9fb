//! The main scene (S3) in the study: the poncho's strain against the cloth's cost, for each
//! budget and each motion of [`CharacterMotion`], from headless runs of the scene.

use bevy_drape::cloth::SolverSettings;

use crate::poncho::{CharacterMotion, PonchoScene, run_headless};
use crate::scenes::FRAME_RATE;

/// A budget of the S3 study.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MainSceneBudget {
    /// Substeps per fixed step.
    pub substeps: u32,
    /// Iterations per substep.
    pub iterations: u32,
    /// Whether the structural edges are solved exactly while the poncho touches the body
    /// ([`SolverSettings::exact_edges`], the default).
    pub exact_edges: bool,
}

/// One S3 run at one budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MainScenePoint {
    /// The character's motion.
    pub motion: CharacterMotion,
    /// The budget.
    pub budget: MainSceneBudget,
    /// The cloth stage's median step time times the frame rate: milliseconds of one core per
    /// simulated second.
    pub ms_per_second: f64,
    /// The median over the steps of each step's largest strain.
    pub step_max_strain_median: f32,
    /// The largest strain of any step.
    pub step_max_strain_max: f32,
    /// The 99.9th percentile of every edge's strain after every step.
    pub edge_strain_p999: f32,
    /// Whether the run stayed finite and never diverged.
    pub stable: bool,
}

/// The study's S3 budgets: from 4 x 2 to 32 x 4 without exact edges, and 4 x 2 to 32 x 2 with
/// them.
pub fn main_scene_budgets() -> Vec<MainSceneBudget> {
    let without = [
        (4, 2),
        (8, 2),
        (16, 2),
        (32, 2),
        (4, 4),
        (8, 4),
        (16, 4),
        (32, 4),
    ]
    .map(|(substeps, iterations)| MainSceneBudget {
        substeps,
        iterations,
        exact_edges: false,
    });
    let with = [4, 8, 16, 32].map(|substeps| MainSceneBudget {
        substeps,
        iterations: 2,
        exact_edges: true,
    });
    without.into_iter().chain(with).collect()
}

/// Runs S3 (the default [`PonchoScene`], XPBD) for `steps` fixed steps at every budget and
/// motion; the first [`crate::poncho::SETTLE_SECONDS`] are left out of the figures.
pub fn main_scene_points(
    budgets: &[MainSceneBudget],
    motions: &[CharacterMotion],
    steps: u32,
) -> Result<Vec<MainScenePoint>, String> {
    let mut points = Vec::with_capacity(budgets.len() * motions.len());
    for &motion in motions {
        for &budget in budgets {
            let default = PonchoScene::default().solver;
            let scene = PonchoScene {
                solver: SolverSettings {
                    substeps: budget.substeps,
                    iterations: budget.iterations,
                    exact_edges: default.exact_edges.filter(|_| budget.exact_edges),
                    ..default
                },
                motion,
                ..PonchoScene::default()
            };
            let run = run_headless(scene, steps)?;
            points.push(MainScenePoint {
                motion,
                budget,
                ms_per_second: run.median_ms(3) * FRAME_RATE as f64,
                step_max_strain_median: run.step_strain_median(),
                step_max_strain_max: run.step_strain_max(),
                edge_strain_p999: run.edge_strain_percentile(0.999),
                stable: run.finite && run.divergences == 0,
            });
        }
    }
    Ok(points)
}
