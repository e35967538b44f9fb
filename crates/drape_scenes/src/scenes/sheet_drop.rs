//! The sheet drop of the self-collision example, and how close the cloth comes to itself.

use std::time::Instant;

use bevy::math::{Vec3, Vec3A};
use bevy_drape::cloth::internals::SelfCollision;
use bevy_drape::cloth::{
    ClothModel, ClothSolver, GridDesc, SelfCollisionMethod, SolverSettings, TwoPoses,
    count_self_crossings,
};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape};

use super::common::{DENSITY, FRAME_RATE, GRAVITY};

/// The sheet drop of the self-collision example: the S1 sheet (`n` x `n` vertices, 1 m
/// square), unpinned, hanging nearly vertical (tilted `tilt` from the vertical, [`SheetDrop::TILT`]
/// in the example) with its lower edge `height` above the ground ([`SheetDrop::HEIGHT`]); it
/// falls, hits the ground and folds onto itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SheetDrop {
    /// Vertices per side.
    pub n: u32,
    /// Tilt from the vertical, radians.
    pub tilt: f32,
    /// Height of the lower edge at the start, m.
    pub height: f32,
    /// Turn of the sheet about the vertical, radians.
    pub turn: f32,
}

impl SheetDrop {
    /// The example's drop: tilted [`Self::TILT`], [`Self::HEIGHT`] above the ground.
    pub fn new(n: u32) -> Self {
        Self {
            n,
            tilt: Self::TILT,
            height: Self::HEIGHT,
            turn: 0.0,
        }
    }

    /// A drop generated from `seed`: tilted 0.05-0.35 rad, its lower edge 0.1-0.6 m up, turned
    /// anyhow about the vertical (it lands on its lower edge and folds onto itself).
    pub fn generated(n: u32, seed: u64) -> Self {
        let mut rng = bevy_drape::rng::Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
        Self {
            n,
            tilt: rng.range(0.05, 0.35),
            height: rng.range(0.1, 0.6),
            turn: rng.range(0.0, std::f32::consts::TAU),
        }
    }

    /// The example's height of the lower edge at the start, m.
    pub const HEIGHT: f32 = 0.3;
    /// The example's tilt from the vertical, radians.
    pub const TILT: f32 = 0.2;
    /// Friction of the ground.
    pub const FRICTION: f32 = 0.5;
    /// Bending compliance, 1/(N m): a soft, drapey cloth that piles up in folds (at the
    /// default 500 the sheet falls over and lies flat).
    pub const BEND_COMPLIANCE: f32 = 1.0e4;

    /// The scene's solver settings, with a self-collision method.
    pub fn settings(self_collision: SelfCollisionMethod) -> SolverSettings {
        SolverSettings {
            bend_compliance: Self::BEND_COMPLIANCE,
            self_collision,
            ..SolverSettings::default()
        }
    }

    /// The grid: vertex row 0 is the lower edge.
    pub fn grid(&self) -> GridDesc {
        let mut grid = GridDesc::square(1.0, self.n, Vec3::new(0.0, self.height, 0.0));
        grid.orientation = bevy::math::Quat::from_rotation_y(self.turn)
            * bevy::math::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2 + self.tilt);
        grid
    }

    /// The ground.
    pub fn ground(&self) -> SolverCollider {
        let mut ground = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
        ground.material = ContactMaterial {
            friction: Self::FRICTION,
            restitution: 0.0,
        };
        ground.margin = 0.0;
        ground
    }

    /// The cloth at rest, with the ground set.
    pub fn build(&self) -> ClothSolver {
        let model = ClothModel::grid(&self.grid(), DENSITY)
            .expect("the standard grid is valid by construction");
        let mut sim = ClothSolver::new(model);
        sim.set_colliders(&[self.ground()]).unwrap();
        sim
    }

    /// Runs `frames` frames at [`FRAME_RATE`].
    pub fn run(&self, settings: &SolverSettings, frames: u32) -> SheetDropRun {
        let mut sim = self.build();
        let dt = 1.0 / FRAME_RATE;
        let mut frame_seconds = Vec::with_capacity(frames as usize);
        let mut finite = true;
        let mut crossings = 0;
        let mut before = sim.state().positions.clone();
        for _ in 0..frames {
            let start = Instant::now();
            sim.step(settings, GRAVITY, dt)
                .expect("the scene runs with valid settings");
            frame_seconds.push(start.elapsed().as_secs_f64());
            finite &= sim.is_finite();
            // Counted outside the timed step.
            let after = &sim.state().positions;
            crossings += count_self_crossings(
                TwoPoses {
                    before: &before,
                    after,
                },
                &sim.model().triangles,
                settings.thickness,
            );
            before.clone_from(after);
        }
        let spacing = 1.0 / (self.n - 1) as f32;
        SheetDropRun {
            frame_seconds,
            closest_gap: closest_non_adjacent(&sim, spacing).unwrap_or(f32::INFINITY) / spacing,
            max_strain: sim.strain().max,
            crossings,
            finite,
            sim,
        }
    }
}

/// The outcome of one sheet-drop run.
#[derive(Clone, Debug)]
pub struct SheetDropRun {
    /// Wall time of every frame, s.
    pub frame_seconds: Vec<f64>,
    /// The distance between the closest two particles that share no edge at the end, in grid
    /// spacings (infinite if none are within one spacing).
    pub closest_gap: f32,
    /// Largest structural strain at the end.
    pub max_strain: f32,
    /// How many times a particle went through one of the sheet's triangles between two
    /// frames ([`count_self_crossings`]), over the run.
    pub crossings: usize,
    /// Whether every position stayed finite.
    pub finite: bool,
    /// The cloth at the end.
    pub sim: ClothSolver,
}

/// The distance between the closest two particles of `sim` that share no edge, if any are
/// within `within` of each other.
pub fn closest_non_adjacent(sim: &ClothSolver, within: f32) -> Option<f32> {
    let mut tables = SelfCollision::new(sim.model(), Some(within))?;
    let x = &sim.state().positions;
    // At rest: the pairs within `within` now.
    tables.find_pairs(x, &vec![Vec3A::ZERO; x.len()], 0.0, 0.0);
    tables.closest_pair(x).map(|(_, d)| d)
}
