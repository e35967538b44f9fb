//! Two sheets dropped one above the other onto a sphere: stepped apart they pass through each
//! other, stepped as layers of one solve ([`LayerSolver`]) they drape one over the other.

use std::time::Instant;

use bevy::math::{Quat, Vec3, Vec3A};
use bevy_drape::cloth::{
    ClothModel, ClothSolver, GridDesc, LayerSolver, OneThread, SolverSettings, TwoPoses,
    count_crossings_between, count_self_crossings,
};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape};

use super::common::{DENSITY, FRAME_RATE, GRAVITY};

/// Two `n` x `n` sheets, 1 m square, held flat `gap` apart above a sphere of radius
/// [`LayeredDrop::RADIUS`] resting on the ground, the upper one turned `turn` about the
/// vertical and moved `shift` sideways; both fall onto the sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayeredDrop {
    /// Vertices per side of each sheet.
    pub n: u32,
    /// Height between the two sheets at the start, m.
    pub gap: f32,
    /// Turn of the upper sheet about the vertical, radians.
    pub turn: f32,
    /// Sideways shift of the upper sheet (x, z), m.
    pub shift: [f32; 2],
    /// Tilt of both sheets about the x axis, radians.
    pub tilt: f32,
}

impl LayeredDrop {
    /// The sphere's radius, m.
    pub const RADIUS: f32 = 0.3;
    /// Height of the lower sheet's centre at the start, m.
    pub const HEIGHT: f32 = 0.9;
    /// Friction of the sphere and the ground.
    pub const FRICTION: f32 = 0.5;
    /// Frames until both sheets have landed on the sphere (1 s).
    pub const LANDED: u32 = 60;

    /// The example's drop: the upper sheet 5 cm above, turned 45 degrees.
    pub fn new(n: u32) -> Self {
        Self {
            n,
            gap: 0.05,
            turn: std::f32::consts::FRAC_PI_4,
            shift: [0.0, 0.0],
            tilt: 0.0,
        }
    }

    /// A drop generated from `seed`: the sheets 2-10 cm apart, the upper one turned anyhow
    /// and shifted up to 20 cm, both tilted up to 0.3 rad.
    pub fn generated(n: u32, seed: u64) -> Self {
        let mut rng = bevy_drape::rng::Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
        Self {
            n,
            gap: rng.range(0.02, 0.1),
            turn: rng.range(0.0, std::f32::consts::TAU),
            shift: [rng.range(-0.2, 0.2), rng.range(-0.2, 0.2)],
            tilt: rng.range(-0.3, 0.3),
        }
    }

    /// The scene's solver settings: the library's, with a soft bending that lets the sheets
    /// fold round the sphere.
    pub fn settings() -> SolverSettings {
        SolverSettings {
            bend_compliance: 1.0e3,
            ..SolverSettings::default()
        }
    }

    /// The two sheets' grids, lower first.
    pub fn grids(&self) -> [GridDesc; 2] {
        let sheet = |height: f32, turn: f32, shift: [f32; 2]| {
            let spin = Quat::from_rotation_x(self.tilt) * Quat::from_rotation_y(turn);
            let centre = Vec3::new(shift[0], height, shift[1]);
            let mut grid = GridDesc::square(1.0, self.n, Vec3::ZERO);
            grid.orientation = spin;
            // The grid's origin is its corner: put its centre at `centre`.
            grid.origin = centre - spin * Vec3::new(0.5, 0.0, 0.5);
            grid
        };
        [
            sheet(Self::HEIGHT, 0.0, [0.0, 0.0]),
            sheet(Self::HEIGHT + self.gap, self.turn, self.shift),
        ]
    }

    /// The sphere and the ground.
    pub fn colliders(&self) -> [SolverCollider; 2] {
        let material = ContactMaterial {
            friction: Self::FRICTION,
            restitution: 0.0,
        };
        let mut ground = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
        let mut sphere = SolverCollider::fixed(
            SolverShape::Sphere {
                radius: Self::RADIUS,
            },
            RigidPose {
                translation: Vec3A::Y * Self::RADIUS,
                ..RigidPose::IDENTITY
            },
        );
        for c in [&mut ground, &mut sphere] {
            c.material = material;
        }
        [ground, sphere]
    }

    /// The two sheets at rest, the colliders set.
    pub fn build(&self) -> [ClothSolver; 2] {
        self.grids().map(|grid| {
            let model = ClothModel::grid(&grid, DENSITY)
                .expect("the standard grid is valid by construction");
            let mut sim = ClothSolver::new(model);
            sim.set_colliders(&self.colliders())
                .expect("the scene's colliders are valid");
            sim
        })
    }

    /// Runs `frames` frames at [`FRAME_RATE`], the sheets stepped as layers of one solve or
    /// each alone.
    pub fn run(&self, settings: &SolverSettings, frames: u32, layered: bool) -> LayeredDropRun {
        let [mut lower, mut upper] = self.build();
        let mut layers = layered.then(|| {
            let mut layers = LayerSolver::new(&[&lower, &upper]).expect("two cloths");
            layers
                .solver_mut()
                .set_colliders(&self.colliders())
                .expect("the scene's colliders are valid");
            layers
        });
        let dt = 1.0 / FRAME_RATE;
        let mut frame_seconds = Vec::with_capacity(frames as usize);
        let (mut finite, mut between, mut own) = (true, 0, 0);
        let mut before = [
            lower.state().positions.clone(),
            upper.state().positions.clone(),
        ];
        let (lower_tris, upper_tris) = (
            lower.model().triangles.clone(),
            upper.model().triangles.clone(),
        );
        // The upper sheet's centroid relative to the lower's, once the two have landed.
        let offset = |upper: &ClothSolver, lower: &ClothSolver| {
            let centroid = |sim: &ClothSolver| {
                let x = &sim.state().positions;
                x.iter().copied().sum::<Vec3A>() / x.len().max(1) as f32
            };
            let d = centroid(upper) - centroid(lower);
            Vec3A::new(d.x, 0.0, d.z)
        };
        let landed = Self::LANDED.min(frames / 2);
        let mut at_landing = Vec3A::ZERO;
        for frame in 0..frames {
            if frame == landed {
                at_landing = offset(&upper, &lower);
            }
            let start = Instant::now();
            match &mut layers {
                Some(layers) => {
                    layers.gather(0, &lower).expect("the same cloths");
                    layers.gather(1, &upper).expect("the same cloths");
                    layers
                        .step(settings, GRAVITY, dt, &OneThread)
                        .expect("the scene runs with valid settings");
                    layers.scatter(0, &mut lower).expect("the same cloths");
                    layers.scatter(1, &mut upper).expect("the same cloths");
                }
                None => {
                    for sim in [&mut lower, &mut upper] {
                        sim.step(settings, GRAVITY, dt)
                            .expect("the scene runs with valid settings");
                    }
                }
            }
            frame_seconds.push(start.elapsed().as_secs_f64());
            finite &= lower.is_finite() && upper.is_finite();
            // Counted outside the timed step.
            let a = TwoPoses {
                before: &before[0],
                after: &lower.state().positions,
            };
            let b = TwoPoses {
                before: &before[1],
                after: &upper.state().positions,
            };
            between += count_crossings_between(a, b, &upper_tris, settings.thickness)
                + count_crossings_between(b, a, &lower_tris, settings.thickness);
            own += count_self_crossings(a, &lower_tris, settings.thickness)
                + count_self_crossings(b, &upper_tris, settings.thickness);
            before[0].clone_from(&lower.state().positions);
            before[1].clone_from(&upper.state().positions);
        }
        LayeredDropRun {
            frame_seconds,
            crossings_between: between,
            crossings_own: own,
            max_strain: lower.strain().max.max(upper.strain().max),
            closest: closest_between(&upper, &lower),
            slide: offset(&upper, &lower).distance(at_landing),
            finite,
        }
    }
}

/// The distance between the closest particle of `upper` and one of `lower`, m.
fn closest_between(upper: &ClothSolver, lower: &ClothSolver) -> f32 {
    let below = &lower.state().positions;
    let mut lowest = f32::INFINITY;
    for &p in &upper.state().positions {
        let nearest = below
            .iter()
            .min_by(|a, b| a.distance_squared(p).total_cmp(&b.distance_squared(p)));
        if let Some(&q) = nearest {
            let d: Vec3A = p - q;
            lowest = lowest.min(d.length());
        }
    }
    lowest
}

/// The outcome of one layered drop.
#[derive(Clone, Debug)]
pub struct LayeredDropRun {
    /// Wall time of every frame, s.
    pub frame_seconds: Vec<f64>,
    /// How many times a particle of one sheet went through a triangle of the other between
    /// two frames ([`count_crossings_between`]), over the run.
    pub crossings_between: usize,
    /// How many times a particle went through its own sheet's triangles.
    pub crossings_own: usize,
    /// Largest structural strain of either sheet at the end.
    pub max_strain: f32,
    /// The closest any particle of the upper sheet is to one of the lower at the end, m.
    pub closest: f32,
    /// How far the upper sheet slid over the lower after landing on it (from
    /// [`LayeredDrop::LANDED`] frames, or half the run if it is shorter, to the end): the
    /// horizontal move of its centroid relative to the lower's, m.
    pub slide: f32,
    /// Whether every position stayed finite.
    pub finite: bool,
}
