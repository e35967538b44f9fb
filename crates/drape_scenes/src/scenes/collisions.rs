//! The collision scene: a mass-spring sheet thrown into a box with moving spheres.

use std::time::Instant;

use bevy::math::Vec3;
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverSettings};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape};

use super::common::{DENSITY, FRAME_RATE, GRAVITY};

/// The collision scene: a mass-spring sheet of `n` x `n` vertices (0.8 m square, 0.1 kg/m^2)
/// thrown sideways at 2 m/s from 1.2 m up into a box 2 m wide and 1.5 m high, onto two
/// resting spheres and one that sweeps back and forth along X (1 m/s peak), the ground and the
/// walls bouncing (restitution 0.4, friction 0.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Collisions {
    /// Vertices per side.
    pub n: u32,
}

impl Collisions {
    /// The box's corners.
    pub const BOX: (Vec3, Vec3) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    /// The contact material of every collider.
    pub const MATERIAL: ContactMaterial = ContactMaterial {
        friction: 0.3,
        restitution: 0.4,
    };

    /// The solver settings: mass-spring at its stable step.
    pub fn settings() -> SolverSettings {
        SolverSettings {
            method: bevy_drape::cloth::SolverMethod::MassSpring,
            auto_substeps: true,
            ..SolverSettings::default()
        }
    }

    /// The spheres at time `t`: two at rest and one sweeping along X, with its velocity.
    pub fn spheres(t: f32) -> [(Vec3, f32, Vec3); 3] {
        let (amplitude, omega) = (0.45, 1.0 / 0.45);
        [
            (Vec3::new(0.0, 0.25, 0.1), 0.25, Vec3::ZERO),
            (Vec3::new(0.5, 0.2, -0.3), 0.2, Vec3::ZERO),
            (
                Vec3::new(amplitude * (omega * t).sin(), 0.18, 0.45),
                0.18,
                Vec3::new(amplitude * omega * (omega * t).cos(), 0.0, 0.0),
            ),
        ]
    }

    /// Every collider over the step from `t` to `t + dt`: the spheres, the ground and the
    /// walls.
    pub fn colliders(t: f32, dt: f32) -> Vec<SolverCollider> {
        let at = |p: Vec3| RigidPose {
            translation: p.into(),
            ..RigidPose::IDENTITY
        };
        let mut all: Vec<SolverCollider> = Self::spheres(t)
            .iter()
            .zip(Self::spheres(t + dt))
            .map(|(&(start, radius, _), (end, _, velocity))| SolverCollider {
                start: at(start),
                end: at(end),
                linear_velocity: velocity.into(),
                material: Self::MATERIAL,
                ..SolverCollider::fixed(SolverShape::Sphere { radius }, at(end))
            })
            .collect();
        all.extend(SolverCollider::box_walls(
            Self::BOX.0.into(),
            Self::BOX.1.into(),
            Self::MATERIAL,
        ));
        all
    }

    /// The sheet, thrown.
    pub fn build(&self) -> ClothSolver {
        let grid = GridDesc::square(0.8, self.n, Vec3::new(-0.9, 1.2, -0.4));
        let model = ClothModel::grid(&grid, DENSITY).expect("the grid is valid by construction");
        let mut sim = ClothSolver::new(model);
        for v in &mut sim.state_mut().velocities {
            *v = bevy::math::Vec3A::new(2.0, 0.0, 0.0);
        }
        sim
    }

    /// Runs `frames` frames at [`FRAME_RATE`].
    pub fn run(&self, settings: &SolverSettings, frames: u32) -> CollisionsRun {
        let mut sim = self.build();
        let dt = 1.0 / FRAME_RATE;
        let count = Self::colliders(0.0, dt).len();
        let mut run = CollisionsRun {
            frame_seconds: Vec::with_capacity(frames as usize),
            touched: vec![false; count],
            deepest_penetration: 0.0,
            finite: true,
            sim: sim.clone(),
        };
        for frame in 0..frames {
            let t = frame as f32 * dt;
            let colliders = Self::colliders(t, dt);
            let start = Instant::now();
            sim.set_colliders(&colliders)
                .expect("the scene's colliders are valid");
            sim.step(settings, GRAVITY, dt)
                .expect("the scene runs with valid settings");
            run.frame_seconds.push(start.elapsed().as_secs_f64());
            run.finite &= sim.is_finite();
            let reach = settings.thickness + 1e-3;
            for (k, c) in colliders.iter().enumerate() {
                for &p in &sim.state().positions {
                    if let Some(d) = c.signed_distance(p, reach) {
                        run.deepest_penetration = run.deepest_penetration.max(-d);
                        run.touched[k] |= d <= reach;
                    }
                }
            }
        }
        run.sim = sim;
        run
    }
}

/// The outcome of one collision-scene run.
#[derive(Clone, Debug)]
pub struct CollisionsRun {
    /// Wall time of every frame, s.
    pub frame_seconds: Vec<f64>,
    /// Per collider ([`Collisions::colliders`]' order: three spheres, then the walls
    /// `-X, +X, ground, top, -Z, +Z`), whether the cloth ever touched it.
    pub touched: Vec<bool>,
    /// The deepest any particle was inside any collider after any frame, metres.
    pub deepest_penetration: f32,
    /// Whether the state stayed finite throughout.
    pub finite: bool,
    /// The cloth at the end.
    pub sim: ClothSolver,
}
