//! Scene S1, the hanging cloth, and what its runs record.

use std::time::Instant;

use bevy::math::Vec3;
use bevy::tasks::TaskPool;
use bevy_drape::cloth::{
    ClothModel, ClothSolver, Divergence, DivergenceBounds, GridDesc, SolverSettings, with_helper,
};

use super::common::{DENSITY, FRAME_RATE, GRAVITY, median};

/// Scene S1, the hanging cloth: a 1 m x 1 m sheet of `n` x `n` vertices, flat at y = 1 m over
/// x, z in [0, 1], pinned at (0, 1, 0) and (1, 1, 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HangingCloth {
    /// Vertices per side.
    pub n: u32,
}

impl HangingCloth {
    /// The grid.
    pub fn grid(&self) -> GridDesc {
        GridDesc::square(1.0, self.n, Vec3::new(0.0, 1.0, 0.0))
    }

    /// The pinned vertices.
    pub fn pins(&self) -> [u32; 2] {
        let g = self.grid();
        [g.index(0, 0), g.index(self.n - 1, 0)]
    }

    /// The free corner diagonal to a pinned one, starting at (1, 1, 1).
    pub fn corner(&self) -> u32 {
        self.grid().index(self.n - 1, self.n - 1)
    }

    /// The centre vertex `(n/2, n/2)`.
    pub fn center(&self) -> u32 {
        self.grid().index(self.n / 2, self.n / 2)
    }

    /// The cloth, pinned, at rest.
    pub fn build(&self) -> ClothSolver {
        let model = ClothModel::grid(&self.grid(), DENSITY)
            .expect("the standard grid is valid by construction");
        let mut sim = ClothSolver::new(model);
        sim.set_pins(&self.pins())
            .expect("the standard pins are in range by construction");
        sim
    }

    /// Runs `frames` frames at [`FRAME_RATE`] and records every frame: the run behind S1's
    /// figures, the speed-against-accuracy study and the tests. The run stops early if the
    /// cloth diverges ([`DivergenceBounds::default`]).
    pub fn run(&self, settings: &SolverSettings, frames: u32) -> SceneRun {
        self.run_on(settings, frames, None)
    }

    /// [`HangingCloth::run`], each step split over the step's thread and a helper on `pool`
    /// ([`with_helper`]) if one is given.
    pub fn run_on(
        &self,
        settings: &SolverSettings,
        frames: u32,
        pool: Option<&TaskPool>,
    ) -> SceneRun {
        let mut sim = self.build();
        let dt = 1.0 / FRAME_RATE;
        let mut run = Trajectory::default();
        let mut finite = true;
        let mut divergence = None;
        for frame in 1..=frames {
            let start = Instant::now();
            match pool {
                Some(pool) => with_helper(pool, |join| sim.step_with(settings, GRAVITY, dt, join)),
                None => sim.step(settings, GRAVITY, dt),
            }
            .expect("the scene runs with valid settings");
            run.frame_seconds.push(start.elapsed().as_secs_f64());
            run.substeps.push(sim.last_substeps());
            finite &= sim.is_finite();
            if let Some(d) = sim.divergence(&DivergenceBounds::default()) {
                divergence = Some((frame, d));
                run.diverged = true;
                break;
            }
            run.strain.push(sim.strain().max);
            let x = &sim.state().positions;
            run.corner.push(x[self.corner() as usize].into());
            run.center.push(x[self.center() as usize].into());
        }
        SceneRun {
            mean_strain: sim.strain().mean,
            trajectory: run,
            finite,
            divergence,
            sim,
        }
    }
}

/// Every frame of a run of S1.
#[derive(Clone, Debug, Default)]
pub struct Trajectory {
    /// The free corner's position after each frame.
    pub corner: Vec<Vec3>,
    /// The centre vertex's position after each frame.
    pub center: Vec<Vec3>,
    /// Wall time of each frame, seconds.
    pub frame_seconds: Vec<f64>,
    /// Substeps each frame used.
    pub substeps: Vec<u32>,
    /// Largest structural strain after each frame.
    pub strain: Vec<f32>,
    /// Whether the run diverged ([`DivergenceBounds::default`]); it stops there.
    pub diverged: bool,
}

impl Trajectory {
    /// Milliseconds of wall time per simulated second: the median frame times the frame rate.
    pub fn ms_per_second(&self) -> f64 {
        median(&self.frame_seconds) * 1e3 * FRAME_RATE as f64
    }

    /// The largest strain at the end of the run.
    pub fn end_strain(&self) -> f32 {
        self.strain.last().copied().unwrap_or(f32::INFINITY)
    }

    /// The mean substep count per frame.
    pub fn mean_substeps(&self) -> f32 {
        self.substeps.iter().sum::<u32>() as f32 / self.substeps.len().max(1) as f32
    }
}

/// The outcome of one S1 run.
#[derive(Clone, Debug)]
pub struct SceneRun {
    /// What every frame measured.
    pub trajectory: Trajectory,
    /// Mean structural strain at the end.
    pub mean_strain: f32,
    /// Whether the state stayed finite throughout.
    pub finite: bool,
    /// The frame (from 1) at which the cloth diverged and how; the run stopped there.
    pub divergence: Option<(u32, Divergence)>,
    /// The cloth at the end.
    pub sim: ClothSolver,
}

impl SceneRun {
    /// Median wall time per frame, ms.
    pub fn median_ms_per_frame(&self) -> f64 {
        median(&self.trajectory.frame_seconds) * 1e3
    }

    /// The frames S1 reports positions at (t = 0.5, 1 and 2 s, those reached, and the last),
    /// counted from 1.
    pub fn sample_frames(&self) -> Vec<u32> {
        let last = self.trajectory.corner.len() as u32;
        let mut frames: Vec<u32> = [30, 60, 120]
            .into_iter()
            .filter(|&f| f < last)
            .chain((last > 0).then_some(last))
            .collect();
        frames.dedup();
        frames
    }
}
