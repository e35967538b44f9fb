//! The wind scene: a flag on a pole in gusty wind, and the air's share of its frame.

use std::time::Instant;

use bevy::math::{Quat, UVec2, Vec2, Vec3};
use bevy_drape::cloth::{
    AirSettings, ClothModel, ClothSolver, GridDesc, Gusts, SolverSettings, WindField,
};

use super::common::{FRAME_RATE, GRAVITY, median};

/// The wind scene: a flag of `n` x `2n/3` vertices (1.2 m x 0.8 m, 0.15 kg/m^2) hanging from
/// a pole along its left edge (the pole's top at (0, 2, 0), the flag in the XY plane, all of
/// that edge pinned), in the wind `wind` with `gusts`; the crate's default solver with air.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Flag {
    /// Vertices along the flag's length.
    pub n: u32,
    /// The mean wind, m/s.
    pub wind: Vec3,
    /// Its gusts.
    pub gusts: Gusts,
}

impl Flag {
    /// Length and height, metres.
    pub const SIZE: Vec2 = Vec2::new(1.2, 0.8);
    /// Areal density, kg/m^2.
    pub const DENSITY: f32 = 0.15;

    /// The grid: vertical, hanging down from the pole's top.
    pub fn grid(&self) -> GridDesc {
        let rows = (self.n * 2).div_ceil(3).max(2);
        GridDesc {
            size: Self::SIZE,
            vertices: UVec2::new(self.n.max(2), rows),
            orientation: Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
            origin: Vec3::new(0.0, 2.0, 0.0),
        }
    }

    /// The pinned vertices: the edge along the pole.
    pub fn pins(&self) -> Vec<u32> {
        let g = self.grid();
        (0..g.vertices.y).map(|j| g.index(0, j)).collect()
    }

    /// The solver settings: the defaults with air.
    pub fn settings() -> SolverSettings {
        SolverSettings {
            air: Some(AirSettings::default()),
            ..SolverSettings::default()
        }
    }

    /// The wind.
    pub fn wind_field(&self) -> WindField {
        WindField {
            velocity: self.wind,
            gusts: self.gusts,
            sources: Vec::new(),
        }
    }

    /// The flag, pinned, at rest.
    pub fn build(&self) -> ClothSolver {
        let model = ClothModel::grid(&self.grid(), Self::DENSITY)
            .expect("the flag grid is valid by construction");
        let mut sim = ClothSolver::new(model);
        sim.set_pins(&self.pins())
            .expect("the flag's pins are in range by construction");
        sim
    }

    /// The flag's mean direction from the pole: its centroid minus the mean of the pinned
    /// particles.
    pub fn direction(&self, sim: &ClothSolver) -> Vec3 {
        let x = &sim.state().positions;
        let pins = self.pins();
        let pole: Vec3 = pins
            .iter()
            .map(|&p| Vec3::from(x[p as usize]))
            .sum::<Vec3>()
            / pins.len() as f32;
        let centroid: Vec3 = x.iter().map(|&p| Vec3::from(p)).sum::<Vec3>() / x.len() as f32;
        centroid - pole
    }

    /// Runs `frames` frames at [`FRAME_RATE`] with `settings`, giving the solver the wind at
    /// every frame, and times the air (sampling the wind and the forces). Each frame is also
    /// stepped from the same state without air (on a copy, not kept): that step differs by
    /// the air's cost and by what the air changes in the rest of the step (a flag pulled taut
    /// has more long-range constraints active).
    pub fn run(&self, settings: &SolverSettings, frames: u32) -> FlagRun {
        let mut sim = self.build();
        let wind = self.wind_field();
        let dt = 1.0 / FRAME_RATE;
        let still = SolverSettings {
            air: None,
            ..*settings
        };
        let mut run = FlagRun {
            frame_seconds: Vec::with_capacity(frames as usize),
            no_air_seconds: Vec::with_capacity(frames as usize),
            air_seconds: Vec::with_capacity(frames as usize),
            directions: Vec::with_capacity(frames as usize),
            finite: true,
            strains: Vec::with_capacity(frames as usize),
            sim: sim.clone(),
        };
        let mut copy = sim.clone();
        for frame in 0..frames {
            copy.clone_from(&sim);
            let start = Instant::now();
            copy.step(&still, GRAVITY, dt).expect("valid step input");
            run.no_air_seconds.push(start.elapsed().as_secs_f64());
            let start = Instant::now();
            sim.set_wind(&wind, frame as f32 * dt);
            let wind_seconds = start.elapsed().as_secs_f64();
            sim.step(settings, GRAVITY, dt)
                .expect("the scene runs with valid settings");
            run.frame_seconds.push(start.elapsed().as_secs_f64());
            run.air_seconds
                .push(wind_seconds + sim.last_timings().air.as_secs_f64());
            run.finite &= sim.is_finite();
            run.strains.push(sim.strain().max);
            run.directions.push(self.direction(&sim));
        }
        run.sim = sim;
        run
    }
}

/// The outcome of one wind-scene run.
#[derive(Clone, Debug)]
pub struct FlagRun {
    /// Wall time of every frame (sampling the wind and the step), s.
    pub frame_seconds: Vec<f64>,
    /// Wall time of the same frames stepped without air, s.
    pub no_air_seconds: Vec<f64>,
    /// Wall time of every frame's air: sampling the wind and the forces, s.
    pub air_seconds: Vec<f64>,
    /// The flag's mean direction from the pole after every frame ([`Flag::direction`]).
    pub directions: Vec<Vec3>,
    /// Whether the state stayed finite throughout.
    pub finite: bool,
    /// The largest structural strain after every frame.
    pub strains: Vec<f32>,
    /// The flag at the end.
    pub sim: ClothSolver,
}

impl FlagRun {
    /// The air's share of the frame: the median time of its wind sampling and forces over
    /// the median frame.
    pub fn air_share(&self) -> f64 {
        let with = median(&self.frame_seconds);
        if with > 0.0 {
            median(&self.air_seconds) / with
        } else {
            0.0
        }
    }

    /// The median and the largest of the frames' largest strains.
    pub fn strain(&self) -> (f32, f32) {
        let values: Vec<f64> = self.strains.iter().map(|&s| s as f64).collect();
        (
            median(&values) as f32,
            self.strains.iter().copied().fold(0.0, f32::max),
        )
    }

    /// The mean of the flag's direction over the last `frames` frames.
    pub fn mean_direction(&self, frames: usize) -> Vec3 {
        let tail = &self.directions[self.directions.len().saturating_sub(frames)..];
        tail.iter().copied().sum::<Vec3>() / tail.len().max(1) as f32
    }
}
