//! The standard scenes every figure of the crate comes from (see `docs/benchmarks.md`), built on
//! the pure cores so they run without an App: the `scenes` example, the benches and the
//! accuracy tests all use these.

use std::time::Instant;

use bevy::math::{Quat, UVec2, Vec2, Vec3, Vec3A};

use bevy::tasks::TaskPool;
use bevy_drape::cloth::internals::SelfCollision;
use bevy_drape::cloth::{
    AdaptiveSubsteps, AirSettings, ClothModel, ClothSolver, Divergence, DivergenceBounds, GridDesc,
    Gusts, SolverSettings, WindField, with_helper,
};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape};

/// Frame rate of the standard scenes, Hz.
pub const FRAME_RATE: f32 = 60.0;
/// Gravity of the standard scenes, m/s^2.
pub const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);
/// Areal density of the standard sheet, kg/m^2.
pub const DENSITY: f32 = 0.1;

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

/// The sheet drop of the self-collision example: the S1 sheet (`n` x `n` vertices, 1 m
/// square), unpinned, hanging nearly vertical (tilted [`SheetDrop::TILT`] from the vertical)
/// with its lower edge [`SheetDrop::HEIGHT`] above the ground; it falls, hits the ground and
/// folds onto itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SheetDrop {
    /// Vertices per side.
    pub n: u32,
}

impl SheetDrop {
    /// Height of the lower edge at the start, m.
    pub const HEIGHT: f32 = 0.3;
    /// Tilt from the vertical, radians.
    pub const TILT: f32 = 0.2;
    /// Friction of the ground.
    pub const FRICTION: f32 = 0.5;
    /// Bending compliance, 1/(N m): a soft, drapey cloth that piles up in folds (at the
    /// default 500 the sheet falls over and lies flat).
    pub const BEND_COMPLIANCE: f32 = 1.0e4;

    /// The scene's solver settings, with self-collision on or off.
    pub fn settings(self_collision: bool) -> SolverSettings {
        SolverSettings {
            bend_compliance: Self::BEND_COMPLIANCE,
            self_collision,
            ..SolverSettings::default()
        }
    }

    /// The grid: vertex row 0 is the lower edge.
    pub fn grid(&self) -> GridDesc {
        let mut grid = GridDesc::square(1.0, self.n, Vec3::new(0.0, Self::HEIGHT, 0.0));
        grid.orientation =
            bevy::math::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2 + Self::TILT);
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
        for _ in 0..frames {
            let start = Instant::now();
            sim.step(settings, GRAVITY, dt)
                .expect("the scene runs with valid settings");
            frame_seconds.push(start.elapsed().as_secs_f64());
            finite &= sim.is_finite();
        }
        let spacing = 1.0 / (self.n - 1) as f32;
        SheetDropRun {
            frame_seconds,
            closest_gap: closest_non_adjacent(&sim, spacing).unwrap_or(f32::INFINITY) / spacing,
            max_strain: sim.strain().max,
            finite,
            sim,
        }
    }
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
    /// Whether every position stayed finite.
    pub finite: bool,
    /// The cloth at the end.
    pub sim: ClothSolver,
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

/// The median of `values` (0 for none).
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let mid = v.len() / 2;
    if v.len() % 2 == 1 {
        v[mid]
    } else {
        0.5 * (v[mid - 1] + v[mid])
    }
}

/// The height of the cloth's lowest particle, m.
pub fn lowest_height(sim: &ClothSolver) -> f32 {
    sim.state()
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::MAX, f32::min)
}
