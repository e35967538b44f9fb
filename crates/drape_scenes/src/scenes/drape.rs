//! Scene S2, the drape: the S1 sheet falling onto a sphere on the ground.

use std::time::Instant;

use bevy::math::Vec3;
use bevy_drape::cloth::{AdaptiveSubsteps, ClothModel, ClothSolver, GridDesc, SolverSettings};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape};

use super::common::{DENSITY, FRAME_RATE, GRAVITY};

/// Scene S2, the drape: the S1 sheet (`n` x `n` vertices, 1 m square), unpinned, flat, 0.5 m
/// above a sphere of radius 0.3 m that rests on the ground plane; friction 0.3.
///
/// The sheet is a woven fabric ([`Drape::settings`]): its diagonals shear freely and it bends
/// as a light fabric does. S1's cloth (the library's default settings: diagonals as stiff as
/// the threads, `bend_compliance` 500) cannot lie on a sphere: a triangle mesh whose every edge
/// keeps its length has about as many constraints as its particles have degrees of freedom,
/// so it stands out from the sphere as a stiff cone and its hem stays compressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drape {
    /// Vertices per side.
    pub n: u32,
}

impl Drape {
    /// Sphere radius, m.
    pub const RADIUS: f32 = 0.3;
    /// Friction of the sphere and the ground.
    pub const FRICTION: f32 = 0.3;
    /// Margin of both colliders, m.
    pub const MARGIN: f32 = 0.005;
    /// The sheet's bending compliance, 1/(N m): a bending stiffness of `1 / compliance` =
    /// 1e-5 N m in every direction (`tests/cloth_statics.rs` wraps the grid round cylinders), a
    /// bending length `(B / (rho g))^(1/3)` of 2.2 cm at 0.1 kg/m^2, a light fabric's; the
    /// `MuJoCo` and Newton cloths the S1 comparison runs bend with 0.9e-5 and 1e-5 N m. The
    /// library's default, 500, is 200 times stiffer (a bending length of 13 cm, a thin
    /// card's).
    pub const BEND_COMPLIANCE: f32 = 1e5;
    /// The largest strain the substep count is raised to hold
    /// ([`SolverSettings::adaptive`]).
    pub const TARGET_STRAIN: f32 = 0.01;

    /// The sheet's settings: XPBD from 8 x 2, free shear
    /// ([`SolverSettings::shear_compliance`] infinite), [`Drape::BEND_COMPLIANCE`], and the
    /// substep count raised and lowered to hold [`Drape::TARGET_STRAIN`] (the impact on the
    /// sphere needs about three times the substeps the resting sheet does), without the exact
    /// edges ([`SolverSettings::exact_edges`]: on 4096 particles their 20 conjugate-gradient
    /// iterations neither converge nor pay; with them the run held the same strain at 2.4
    /// times the cost, 24 against 9.9 ms per frame at N = 64).
    pub fn settings() -> SolverSettings {
        SolverSettings {
            shear_compliance: f32::INFINITY,
            bend_compliance: Self::BEND_COMPLIANCE,
            adaptive: Some(AdaptiveSubsteps::target(Self::TARGET_STRAIN)),
            exact_edges: None,
            ..SolverSettings::default()
        }
    }

    /// The sphere's centre: on the ground under the sheet's centre.
    pub fn sphere_centre(&self) -> Vec3 {
        Vec3::new(0.5, Self::RADIUS, 0.5)
    }

    /// The sphere and the ground.
    pub fn colliders(&self) -> [SolverCollider; 2] {
        let material = ContactMaterial {
            friction: Self::FRICTION,
            restitution: 0.0,
        };
        let at = |translation: Vec3| RigidPose {
            translation: translation.into(),
            ..RigidPose::IDENTITY
        };
        let mut sphere = SolverCollider::fixed(
            SolverShape::Sphere {
                radius: Self::RADIUS,
            },
            at(self.sphere_centre()),
        );
        let mut ground = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
        for c in [&mut sphere, &mut ground] {
            c.material = material;
            c.margin = Self::MARGIN;
        }
        [sphere, ground]
    }

    /// The cloth at rest above the sphere, with the colliders set.
    pub fn build(&self) -> ClothSolver {
        let height = 2.0 * Self::RADIUS + 0.5;
        let grid = GridDesc::square(1.0, self.n, Vec3::new(0.0, height, 0.0));
        let model =
            ClothModel::grid(&grid, DENSITY).expect("the standard grid is valid by construction");
        let mut sim = ClothSolver::new(model);
        sim.set_colliders(&self.colliders()).unwrap();
        sim
    }

    /// Runs `frames` frames at [`FRAME_RATE`]; the deepest penetration is measured after
    /// every frame.
    pub fn run(&self, settings: &SolverSettings, frames: u32) -> DrapeRun {
        let mut sim = self.build();
        let colliders = self.colliders();
        let dt = 1.0 / FRAME_RATE;
        let mut frame_seconds = Vec::with_capacity(frames as usize);
        let mut deepest = 0.0f32;
        let mut largest_strain = 0.0f32;
        let mut substeps = 0u32;
        let mut finite = true;
        for _ in 0..frames {
            let start = Instant::now();
            sim.step(settings, GRAVITY, dt)
                .expect("the scene runs with valid settings");
            frame_seconds.push(start.elapsed().as_secs_f64());
            finite &= sim.is_finite();
            largest_strain = largest_strain.max(sim.strain().max);
            substeps += sim.last_substeps();
            for &p in &sim.state().positions {
                for c in &colliders {
                    if let Some(d) = c.signed_distance(p, 0.0) {
                        deepest = deepest.max(-d);
                    }
                }
            }
        }
        let strain = sim.strain();
        DrapeRun {
            frame_seconds,
            deepest_penetration: deepest,
            max_strain: strain.max,
            largest_strain,
            mean_substeps: substeps as f32 / frames.max(1) as f32,
            finite,
            sim,
        }
    }
}

/// The outcome of one S2 run.
#[derive(Clone, Debug)]
pub struct DrapeRun {
    /// Wall time of every frame, s.
    pub frame_seconds: Vec<f64>,
    /// The deepest any particle was inside the sphere or the ground after any frame, m (0 if
    /// none was).
    pub deepest_penetration: f32,
    /// Largest structural strain at the end.
    pub max_strain: f32,
    /// Largest structural strain after any frame.
    pub largest_strain: f32,
    /// Substeps per frame, on average.
    pub mean_substeps: f32,
    /// Whether the state stayed finite throughout.
    pub finite: bool,
    /// The cloth at the end.
    pub sim: ClothSolver,
}
