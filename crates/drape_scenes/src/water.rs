//! The `pour` scene (water poured into a cloth hammock, the `water` example's scene on the
//! pure cores) and measures of water in cloth, for the water tests and the scenes runner.

use std::time::Instant;

use bevy::math::{Vec2, Vec3, Vec3A};
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverSettings};
use bevy_drape::collide::{ContactMaterial, SolverCollider};
use bevy_drape::fluid::{FluidJet, FluidSettings, FluidSolver, JetEmitter};

use crate::scenes::{FRAME_RATE, GRAVITY, median};

/// The heights of the triangles of a sheet of cloth (particles `x`, `triangles`) that a
/// vertical line through `p` meets.
fn sheet_heights_at<'a>(
    x: &'a [Vec3A],
    triangles: &'a [[u32; 3]],
    p: Vec3A,
) -> impl Iterator<Item = f32> + 'a {
    let flat = |v: Vec3A| Vec2::new(v.x, v.z);
    let pp = flat(p);
    triangles.iter().filter_map(move |t| {
        let [a, b, c] = t.map(|k| x[k as usize]);
        let (pa, pb, pc) = (flat(a), flat(b), flat(c));
        let area = (pb - pa).perp_dot(pc - pa);
        if area.abs() < 1e-12 {
            return None;
        }
        let u = (pb - pp).perp_dot(pc - pp) / area;
        let v = (pc - pp).perp_dot(pa - pp) / area;
        let w = 1.0 - u - v;
        (u >= 0.0 && v >= 0.0 && w >= 0.0).then(|| u * a.y + v * b.y + w * c.y)
    })
}

/// How many fluid particles are below a sheet of cloth that hangs as a height field
/// (particles `x`, `triangles`): those whose vertical line meets one of its triangles above
/// them. Water that spilled over the rim and fell outside the sheet's outline is not counted.
pub fn particles_below_sheet(x: &[Vec3A], triangles: &[[u32; 3]], fluid: &[Vec3A]) -> usize {
    fluid
        .iter()
        .filter(|p| sheet_heights_at(x, triangles, **p).any(|h| p.y < h))
        .count()
}

/// How many fluid particles are in a sheet of cloth that hangs as a height field: over its
/// outline and above every triangle their vertical line meets.
pub fn particles_on_sheet(x: &[Vec3A], triangles: &[[u32; 3]], fluid: &[Vec3A]) -> usize {
    fluid
        .iter()
        .filter(|p| {
            let mut heights = sheet_heights_at(x, triangles, **p).peekable();
            heights.peek().is_some() && heights.all(|h| p.y >= h)
        })
        .count()
}

/// The `pour` scene, and the `water` example's: a square sheet of cloth hung by its corners
/// from four posts standing in from them (so that it hangs as a bowl), over a ground, and a
/// jet of water poured into it from above. Cloth and water are stepped together
/// ([`FluidSolver::step_with_cloth`]) at [`FRAME_RATE`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pour {
    /// The sheet's side, metres.
    pub side: f32,
    /// Its vertices along a side.
    pub vertices: u32,
    /// Its areal density, kg/m^2.
    pub density: f32,
    /// Where the posts stand: this fraction of the way from the centre to the corners.
    pub span: f32,
    /// The posts' height, metres: the sheet starts flat at it.
    pub height: f32,
    /// The cloth's solver settings.
    pub cloth: SolverSettings,
    /// The water's.
    pub fluid: FluidSettings,
    /// The jet.
    pub jet: FluidJet,
}

impl Default for Pour {
    fn default() -> Self {
        Self {
            side: 0.8,
            vertices: 21,
            density: 0.2,
            span: 0.7,
            height: 0.9,
            // Water is 30 to 40 times heavier than the cloth that holds it: the cloth needs
            // the iterations to carry it (tests/fluid_cloth.rs).
            cloth: SolverSettings {
                substeps: 16,
                iterations: 4,
                ..SolverSettings::default()
            },
            fluid: FluidSettings::default(),
            jet: FluidJet {
                origin: Vec3::new(0.0, 1.5, 0.0),
                velocity: Vec3::new(0.0, -1.0, 0.0),
                radius: 0.04,
                rate: 200.0,
                max_particles: 600,
            },
        }
    }
}

impl Pour {
    /// The sheet, flat at the posts' height.
    pub fn grid(&self) -> GridDesc {
        let half = self.side / 2.0;
        GridDesc::square(
            self.side,
            self.vertices,
            Vec3::new(-half, self.height, -half),
        )
    }

    /// The corner vertices, each with the top of the post it hangs from.
    pub fn posts(&self) -> [(u32, Vec3); 4] {
        let n = self.vertices;
        [0, n - 1, n * (n - 1), n * n - 1].map(|k| {
            let (i, j) = (k % n, k / n);
            let corner = Vec3::new(
                (i as f32 / (n - 1) as f32 - 0.5) * self.side,
                0.0,
                (j as f32 / (n - 1) as f32 - 0.5) * self.side,
            );
            (k, corner * self.span + Vec3::Y * self.height)
        })
    }

    /// The ground, for the cloth and the water.
    pub fn ground(&self) -> SolverCollider {
        SolverCollider::ground(0.0, ContactMaterial::default())
    }

    /// The sheet, its corners pinned and on their way to the posts, over the ground.
    pub fn build_cloth(&self) -> ClothSolver {
        let model = ClothModel::grid(&self.grid(), self.density)
            .expect("the scene's grid is valid by construction");
        let mut cloth = ClothSolver::new(model);
        let posts = self.posts();
        cloth
            .set_pins(&posts.map(|(k, _)| k))
            .expect("the corners are in range by construction");
        for (k, top) in posts {
            cloth.set_pin_target(k, top);
        }
        cloth
            .set_colliders(&[self.ground()])
            .expect("a ground is a valid collider");
        cloth
    }

    /// The water, empty, over the ground.
    pub fn build_fluid(&self) -> FluidSolver {
        let mut fluid = FluidSolver::new(self.fluid).expect("the scene's settings are valid");
        fluid
            .set_colliders(&[self.ground()])
            .expect("a ground is a valid collider");
        fluid
    }

    /// Pours for `frames` frames, with a dry sheet stepped alongside (to time the cloth
    /// alone on the same machine in the same moments), and measures every frame.
    pub fn run(&self, frames: u32) -> PourRun {
        let dt = 1.0 / FRAME_RATE;
        let mut cloth = self.build_cloth();
        let mut dry = self.build_cloth();
        let mut fluid = self.build_fluid();
        let mut jet = JetEmitter::default();
        let mut run = PourMeasures::default();
        for _ in 0..frames {
            let start = Instant::now();
            if let Err(err) = jet.emit(&self.jet, &mut fluid, dt) {
                run.errors.push(err.to_string());
            }
            if let Err(err) = fluid.step_with_cloth(&mut cloth, &self.cloth, GRAVITY, dt) {
                run.errors.push(err.to_string());
            }
            run.frame_seconds.push(start.elapsed().as_secs_f64());
            let start = Instant::now();
            if let Err(err) = dry.step(&self.cloth, GRAVITY, dt) {
                run.errors.push(err.to_string());
            }
            run.dry_seconds.push(start.elapsed().as_secs_f64());

            let (x, triangles) = (&cloth.state().positions, &cloth.model().triangles);
            let error = fluid.density_error();
            let weight = fluid.particle_mass() * -GRAVITY.y;
            run.frames.push(PourFrame {
                particles: fluid.len(),
                density_error_mean: error.mean,
                density_error_max: error.max,
                below: particles_below_sheet(x, triangles, fluid.positions()),
                crossings: fluid.cloth_contacts().crossings(),
                carried: -fluid.cloth_contacts().impulse().y / dt,
                weight_on_sheet: particles_on_sheet(x, triangles, fluid.positions()) as f32
                    * weight,
                strain: cloth.strain().max,
            });
        }
        PourRun {
            finite: cloth.is_finite() && fluid.positions().iter().all(|p| p.is_finite()),
            divergences: fluid.divergences(),
            frames: run.frames,
            frame_seconds: run.frame_seconds,
            dry_seconds: run.dry_seconds,
            errors: run.errors,
            cloth,
            fluid,
        }
    }

    /// The sheet, free, and a block of water thrown down onto it, falling together for
    /// `frames` frames with no ground and no damping: the largest difference over the
    /// frames between their total momentum and what the weight alone gives, relative to
    /// the latter, and the largest momentum one step moved between them, N s.
    pub fn free_fall(&self, frames: u32) -> (f32, f32) {
        let dt = 1.0 / FRAME_RATE;
        let settings = SolverSettings {
            damping: 0.0,
            ..self.cloth
        };
        let model = ClothModel::grid(&self.grid(), self.density)
            .expect("the scene's grid is valid by construction");
        let mut cloth = ClothSolver::new(model);
        let mut fluid = FluidSolver::new(self.fluid).expect("the scene's settings are valid");
        let quarter = self.side / 4.0;
        let low = Vec3::new(-quarter, self.height + 0.03, -quarter);
        let high = low + Vec3::new(2.0 * quarter, 0.1, 2.0 * quarter);
        let block = FluidSolver::new(self.fluid)
            .and_then(|mut f| f.add_box(low, high).map(|_| f))
            .expect("the block is not empty");
        let block: Vec<Vec3> = block.positions().iter().map(|&p| p.into()).collect();
        fluid
            .add_particles(&block, Vec3::new(0.3, -2.0, 0.1))
            .expect("the block is finite");
        let cloth_momentum = |cloth: &ClothSolver| -> Vec3 {
            let s = cloth.state();
            let p: Vec3A = (s.velocities.iter().zip(&s.inverse_masses))
                .map(|(v, &w)| *v / w)
                .sum();
            p.into()
        };
        let mass = cloth
            .state()
            .inverse_masses
            .iter()
            .map(|w| 1.0 / w)
            .sum::<f32>()
            + fluid.particle_mass() * fluid.len() as f32;
        let start = cloth_momentum(&cloth) + fluid.momentum();
        let (mut worst, mut exchanged) = (0.0f32, 0.0f32);
        for k in 1..=frames {
            if fluid
                .step_with_cloth(&mut cloth, &settings, GRAVITY, dt)
                .is_err()
            {
                return (f32::INFINITY, exchanged);
            }
            exchanged = exchanged.max(fluid.cloth_contacts().impulse().length());
            let expected = start + GRAVITY * mass * k as f32 * dt;
            let total = cloth_momentum(&cloth) + fluid.momentum();
            worst = worst.max((total - expected).length() / expected.length());
        }
        (worst, exchanged)
    }
}

/// What one frame of [`Pour::run`] measured, after the frame's step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PourFrame {
    /// Fluid particles.
    pub particles: usize,
    /// The mean over the particles of `max(rho / rho_0 - 1, 0)`.
    pub density_error_mean: f32,
    /// Its largest.
    pub density_error_max: f32,
    /// Particles below the sheet ([`particles_below_sheet`]).
    pub below: usize,
    /// Particles found across a triangle and put back in the step.
    pub crossings: usize,
    /// The force the water pushed down on the sheet with, over the step, N.
    pub carried: f32,
    /// The weight of the particles in the sheet ([`particles_on_sheet`]), N.
    pub weight_on_sheet: f32,
    /// The cloth's largest edge strain.
    pub strain: f32,
}

/// What [`Pour::run`] gathers frame by frame.
#[derive(Default)]
struct PourMeasures {
    frames: Vec<PourFrame>,
    frame_seconds: Vec<f64>,
    dry_seconds: Vec<f64>,
    errors: Vec<String>,
}

/// A run of [`Pour`].
#[derive(Clone, Debug)]
pub struct PourRun {
    /// The sheet at the end.
    pub cloth: ClothSolver,
    /// The water at the end.
    pub fluid: FluidSolver,
    /// Every frame's measures.
    pub frames: Vec<PourFrame>,
    /// Every frame's wall time of the jet and the coupled step, seconds.
    pub frame_seconds: Vec<f64>,
    /// Every frame's wall time of the dry sheet's step, seconds.
    pub dry_seconds: Vec<f64>,
    /// Errors the steps returned (none is expected).
    pub errors: Vec<String>,
    /// Whether the cloth and the water ended finite.
    pub finite: bool,
    /// Fluid particles the solver put back after a step went non-finite.
    pub divergences: usize,
}

impl PourRun {
    /// The median frame's cost, ms, with the water and of the dry sheet.
    pub fn median_ms(&self) -> (f64, f64) {
        (
            median(&self.frame_seconds) * 1e3,
            median(&self.dry_seconds) * 1e3,
        )
    }

    /// The last `count` frames (all of them if there are fewer).
    pub fn last(&self, count: usize) -> &[PourFrame] {
        &self.frames[self.frames.len().saturating_sub(count)..]
    }
}
