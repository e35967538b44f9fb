//! Solver settings: plain data shared by the core and the Bevy components.

use super::air::AirSettings;
use super::mass_spring::SpringSettings;
use super::volume::VolumeSettings;
use crate::error::ClothError;
use bevy::reflect::Reflect;

/// The constraint solver a cloth uses.
#[derive(Clone, Copy, Debug, PartialEq, Default, Reflect)]
pub enum SolverMethod {
    /// XPBD (Macklin, Mueller and Chentanez 2016): compliant constraints with accumulated
    /// Lagrange multipliers; the material stiffness does not depend on the iteration count.
    #[default]
    Xpbd,
    /// Plain PBD (Mueller et al. 2006): every projection is scaled by a stiffness in (0, 1],
    /// so the effective material stiffness grows with the iteration count and the substep
    /// count. This is the behaviour XPBD removes; it is here as the reference to compare
    /// with. Compliances are ignored.
    Pbd {
        /// Stiffness in (0, 1].
        stiffness: f32,
    },
    /// Mass-spring cloth (structural, shear and bend springs, see
    /// `cloth/mass_spring.rs`) integrated with symplectic Euler: cheap per step, but
    /// stable only below a step set by the stiffest spring and the lightest particle. Uses
    /// [`SolverSettings::springs`]; `iterations`, compliances and long-range attachments are
    /// ignored.
    MassSpring,
    /// XPBD distance constraints on the structural edges only (with `stretch_compliance`),
    /// shear and bend springs explicit, from [`SolverSettings::springs`]. The long-range
    /// attachments (tethers and stretch limits, see
    /// [`SolverSettings::long_range_attachments`]) are an extra the hybrid takes only with
    /// `long_range: true`; `SolverSettings::long_range_attachments` does not apply to it.
    Hybrid {
        /// Whether to project the long-range attachments too. `false` is the method as
        /// defined: constraints on the structural edges and nothing else.
        long_range: bool,
    },
}

impl SolverMethod {
    /// A short name: `xpbd`, `pbd`, `mass-spring` or `hybrid`.
    pub fn name(&self) -> &'static str {
        match self {
            SolverMethod::Xpbd => "xpbd",
            SolverMethod::Pbd { .. } => "pbd",
            SolverMethod::MassSpring => "mass-spring",
            SolverMethod::Hybrid { long_range: false } => "hybrid",
            SolverMethod::Hybrid { long_range: true } => "hybrid-long-range",
        }
    }

    /// Whether the method is [`SolverMethod::Hybrid`], with or without long-range attachments.
    pub(crate) fn is_hybrid(&self) -> bool {
        matches!(self, SolverMethod::Hybrid { .. })
    }
}

/// When a cloth counts as diverged (checked after every fixed step by
/// [`crate::cloth::ClothSolver::divergence`]); a non-finite position or velocity always does.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct DivergenceBounds {
    /// Largest structural strain `|len - rest| / rest` allowed. Default: `1.0` (an edge
    /// stretched to twice its length).
    pub max_strain: f32,
    /// Largest particle speed allowed, m/s: a bound on each particle's kinetic energy per
    /// kilogram, `v^2 / 2`. Default: `500.0`: a cloth yanked 2 m in one 1/60 s step by a
    /// drag moves at over 100 m/s for that step, while a diverging explicit method passes any
    /// bound within a few steps (its growth is exponential).
    pub max_speed: f32,
}

impl Default for DivergenceBounds {
    fn default() -> Self {
        Self {
            max_strain: 1.0,
            max_speed: 500.0,
        }
    }
}

/// How velocities are damped (see `cloth/damping.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Reflect)]
pub enum DampingMode {
    /// Damps only the motion that is not rigid (Mueller et al. 2006, section 3.5): a falling or
    /// spinning cloth keeps its momentum.
    #[default]
    Rigid,
    /// Damps every velocity alike.
    Plain,
}

/// How a cloth keeps from passing through itself ([`SolverSettings::self_collision`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Reflect)]
pub enum SelfCollisionMethod {
    /// Nothing: the cloth passes through itself freely.
    #[default]
    Off,
    /// Particles that share no edge are kept at least the mean structural rest length apart
    /// (`cloth/self_collision.rs`): cheap, but a particle can slip between the corners of a
    /// triangle when the spacing is large against the motion.
    Particles,
    /// Every particle is kept on its side of the cloth's own triangles near it, at
    /// [`SolverSettings::thickness`] (`cloth/triangle_collision.rs`): the layers of a fold
    /// lie a thickness apart, and a particle does not pass between a triangle's corners.
    Triangles,
}

impl SelfCollisionMethod {
    /// Every method, in the order of their cost.
    pub const ALL: [Self; 3] = [Self::Off, Self::Particles, Self::Triangles];

    /// The method's name: `off`, `particles` or `triangles`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Particles => "particles",
            Self::Triangles => "triangles",
        }
    }

    /// The method of a [`Self::name`].
    ///
    /// ```
    /// use bevy_drape::cloth::SelfCollisionMethod;
    /// assert_eq!(
    ///     SelfCollisionMethod::from_name("triangles"),
    ///     Some(SelfCollisionMethod::Triangles)
    /// );
    /// assert_eq!(SelfCollisionMethod::from_name("on"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Everything the solver needs to know about one cloth besides its model and state.
///
/// Units are SI. Compliances are inverse stiffnesses per constraint: `stretch_compliance` in
/// m/N (a distance constraint behaves as a spring of stiffness `1 / stretch_compliance`),
/// `bend_compliance` in 1/(N m) (per bending pair, on the dihedral angle in radians).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct SolverSettings {
    /// The constraint solver. Default: [`SolverMethod::Xpbd`].
    pub method: SolverMethod,
    /// Substeps per fixed step. Default: `8`.
    pub substeps: u32,
    /// Constraint iterations per substep. Default: `2`, the least allowed with
    /// `long_range_attachments`: a single Gauss-Seidel sweep of long-range and edge
    /// constraints per substep gains energy on a hanging cloth, two hold it. Without them one
    /// iteration is allowed, and substeps are worth more than iterations for accuracy
    /// (Macklin et al. 2019, "Small Steps").
    pub iterations: u32,
    /// Compliance of the edge (stretch) constraints, m/N. Default: `0.0` (inextensible).
    pub stretch_compliance: f32,
    /// Compliance of the shear constraints, m/N: the diagonals of a quad pattern
    /// ([`EdgeKind::Shear`](crate::cloth::EdgeKind::Shear)), which a woven cloth barely
    /// resists (it shears along its bias), while `stretch_compliance` holds its threads.
    /// `0.0` makes them as stiff as the threads; `f32::INFINITY` leaves them out, so the
    /// cloth shears freely and only its bending resists. A soft shear lets a cloth lie on a
    /// curved body without stretching its threads. XPBD without a volume constraint (other
    /// methods and a closed cloth project the diagonals with the threads). Default: `0.0`
    /// (also when a settings file leaves it out).
    #[reflect(default)]
    pub shear_compliance: f32,
    /// Compliance of the dihedral bending constraints, 1/(N m). Default: `500.0`.
    pub bend_compliance: f32,
    /// Damping rate, 1/s: the damped part of the velocity decays as `exp(-damping t)`.
    /// Default: `0.5`.
    pub damping: f32,
    /// What the damping acts on. Default: [`DampingMode::Rigid`].
    pub damping_mode: DampingMode,
    /// Distance kept between particles and planes, metres. Default: `0.005`.
    pub thickness: f32,
    /// Coulomb friction coefficient against planes and between layers of the cloth
    /// ([`SolverSettings::self_collision`]). Default: `0.5`.
    pub friction: f32,
    /// Long-range constraints that keep an inextensible cloth from stretching at a small
    /// substep count: tethers from every free particle to its nearest pinned particles (Kim,
    /// Chentanez and Mueller 2012), as long as the distance along the cloth at rest
    /// (`cloth/rest_paths.rs`), and stretch limits along the straight lines of the rest
    /// shape (`cloth/stretch_limits.rs`). Both only refuse lengthening beyond the rest
    /// shape, so turn them off for a stretchy cloth (`stretch_compliance > 0`). For XPBD
    /// and PBD; mass-spring never takes them and the hybrid only with
    /// `SolverMethod::Hybrid { long_range: true }`. Default: `true`.
    pub long_range_attachments: bool,
    /// Bend pairs whose rest shape is flat with the isometric model
    /// (`cloth/isometric_bending.rs`), calibrated to the same stiffness as the
    /// dihedral constraint and about four times cheaper; curved pairs keep the dihedral
    /// constraint. Default: `true`.
    pub isometric_bending: bool,
    /// Spring constants of [`SolverMethod::MassSpring`] and [`SolverMethod::Hybrid`].
    pub springs: SpringSettings,
    /// For [`SolverMethod::MassSpring`] and [`SolverMethod::Hybrid`]: raise the substep count
    /// above `substeps` as far as the explicit stability bound needs
    /// (`cloth/mass_spring.rs`). Default: `false`.
    pub auto_substeps: bool,
    /// How the cloth keeps from passing through itself. Default:
    /// [`SelfCollisionMethod::Off`].
    pub self_collision: SelfCollisionMethod,
    /// Hold the volume a closed cloth encloses (a balloon) at `pressure` times its rest
    /// volume (`cloth/volume.rs`; XPBD, PBD and hybrid). An open cloth asked for it is
    /// stepped without it and reports [`crate::cloth::ClothSolver::volume_error`]. Default:
    /// `None`.
    pub volume: Option<VolumeSettings>,
    /// Pick the substep count per fixed step from a target strain instead of using
    /// `substeps` throughout (XPBD, PBD and hybrid; see [`AdaptiveSubsteps`]). `substeps` is
    /// where the count starts. Default: `None`.
    pub adaptive: Option<AdaptiveSubsteps>,
    /// Bring every structural edge to its rest length at the end of each substep in which the
    /// cloth touches a collider, after the iterations, by a global solve instead of more
    /// Gauss-Seidel sweeps (inextensible edges only; see [`ExactEdges`]). `None` leaves the
    /// edges to the iterations. Default: `Some(ExactEdges::default())`.
    pub exact_edges: Option<ExactEdges>,
    /// Drag and lift from the air on every triangle, moved by the wind the solver is given
    /// ([`crate::cloth::ClothSolver::set_wind`]; the plugins give it the [`Wind`] resource
    /// and the [`WindSource`] entities); every method. `None` is vacuum. Default: `None`.
    ///
    /// [`Wind`]: crate::cloth::wind_plugin::Wind
    /// [`WindSource`]: crate::cloth::wind_plugin::WindSource
    pub air: Option<AirSettings>,
}

/// The fast projection of the structural edges (Goldenthal et al. 2007,
/// `cloth/fast_projection.rs`): `newton_steps` Gauss-Newton steps on the edge constraints, each
/// solved with at most `cg_iterations` preconditioned conjugate-gradient iterations, moving
/// every free particle by the smallest mass-weighted amount that meets them. Tension then
/// travels the whole cloth in one solve, which Gauss-Seidel carries one edge per sweep: a cloth
/// hanging from the body it rests on stays inextensible at 8 x 2.
///
/// It runs only in the substeps in which the cloth touches a collider: a cloth hanging from
/// pins is held by the long-range attachments at no extra cost, and is stepped bit for bit as
/// without it. It runs only on inextensible edges (XPBD and the hybrid at `stretch_compliance`
/// 0, PBD at stiffness 1, no [`SolverSettings::volume`]): edges meant to give are left to the
/// iterations; mass-spring never runs it. Its cost grows with the particle count times the
/// iterations, and the iterations a large sheet needs grow with its size: it pays on a
/// garment of hundreds of particles (the
/// poncho at 8 x 2 with it costs less than at 16 x 4 without it, and strains less), not on a
/// sheet of thousands resting on a collider (S2's 4096 particles on a sphere: 2.4 times the
/// cost of adaptive substeps for the same strain; set `exact_edges: None` there).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct ExactEdges {
    /// Gauss-Newton steps per substep. Default: `1`.
    pub newton_steps: u32,
    /// Conjugate-gradient iterations per step at most: the solve starts from the last one's
    /// multipliers and stops early once every edge's linearised residual is within 0.01% of
    /// its rest length. Default: `20`.
    pub cg_iterations: u32,
    /// How many times more the edges are solved in a substep after the closing pass (which
    /// moves what the solve left inside a collider onto its surface) pushed a particle
    /// farther than [`ExactEdges::closing_tolerance`]: each time with the pushed particles
    /// ten times as heavy, so that the cloth around them gives way rather than they go back
    /// in, and then the closing pass again. A fold pinched between a swinging hand and the
    /// thigh is what needs it: 4 rounds take the worst step of the main scene's tour over
    /// 100,000 steps from 13.9% to 1.0% strain at no measurable cost. The rounds move the
    /// cloth without friction, though: a sheet resting on another over a ball slid 1.9 cm
    /// in 20 s with them, 0.2 cm without. `0`: solved once. Default: `0` (also when a
    /// settings file leaves it out).
    #[reflect(default = "ExactEdges::default_closing_rounds")]
    pub closing_rounds: u32,
    /// The push of the closing pass, metres, beyond which the edges are solved again (see
    /// [`ExactEdges::closing_rounds`]). Default: `0.001` (also when a settings file leaves it
    /// out).
    #[reflect(default = "ExactEdges::default_closing_tolerance")]
    pub closing_tolerance: f32,
}

impl Default for ExactEdges {
    fn default() -> Self {
        Self {
            newton_steps: 1,
            cg_iterations: 20,
            closing_rounds: Self::default_closing_rounds(),
            closing_tolerance: Self::default_closing_tolerance(),
        }
    }
}

impl ExactEdges {
    /// The default [`ExactEdges::closing_rounds`].
    pub fn default_closing_rounds() -> u32 {
        0
    }

    /// The default [`ExactEdges::closing_tolerance`], metres.
    pub fn default_closing_tolerance() -> f32 {
        0.001
    }
}

/// An adaptive substep budget: the fewest substeps per fixed step that keep the cloth's largest
/// structural strain below `target_strain`.
///
/// After every fixed step the solver measures the largest strain
/// ([`crate::cloth::ClothSolver::strain`]). Above the target, the next step takes `1 + grow`
/// times as many substeps (at least one more); below `lower_fraction` of the target for
/// `calm_steps` steps in a row, `1 + grow` times fewer (at least one fewer), so that a count
/// raised for a brief peak of strain comes back down as fast as it went up. Between the two
/// the count holds (the hysteresis
/// band), so it does not flip between two counts every step. The count stays within
/// `min_substeps ..= max_substeps`; [`crate::cloth::ClothSolver::last_substeps`] reports the one
/// used. The first step uses [`SolverSettings::substeps`].
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct AdaptiveSubsteps {
    /// The largest structural strain `|len - rest| / rest` to allow. Default: `0.01`.
    pub target_strain: f32,
    /// The fewest substeps per fixed step. Default: `1`.
    pub min_substeps: u32,
    /// The most substeps per fixed step. Default: `64`.
    pub max_substeps: u32,
    /// The fraction added to the count when the strain is over the target. Default: `0.5`.
    pub grow: f32,
    /// Below this fraction of the target the count may go down. Default: `0.7`.
    pub lower_fraction: f32,
    /// Fixed steps in a row below the lower bound before the count goes down by one.
    /// Default: `5`.
    pub calm_steps: u32,
}

impl AdaptiveSubsteps {
    /// A budget that holds `target_strain` with the default bounds.
    pub fn target(target_strain: f32) -> Self {
        Self {
            target_strain,
            ..Self::default()
        }
    }

    /// The count for the step after one that used `current` substeps and ended with the
    /// largest strain `strain`; `calm` counts the steps in a row below the lower bound.
    pub fn next(&self, current: u32, strain: f32, calm: &mut u32) -> u32 {
        let (lo, hi) = (self.min_substeps.max(1), self.max_substeps.max(1));
        let current = current.clamp(lo, hi);
        if strain.is_nan() || strain > self.target_strain {
            // Over the target (or not finite): more, at once.
            *calm = 0;
            let more = (current as f32 * self.grow).floor() as u32;
            return (current + more.max(1)).min(hi);
        }
        if strain < self.lower_fraction * self.target_strain {
            *calm += 1;
            if *calm >= self.calm_steps.max(1) {
                *calm = 0;
                let fewer = (current as f32 * self.grow / (1.0 + self.grow)).floor() as u32;
                return current.saturating_sub(fewer.max(1)).max(lo);
            }
        } else {
            *calm = 0;
        }
        current
    }
}

impl Default for AdaptiveSubsteps {
    fn default() -> Self {
        Self {
            target_strain: 0.01,
            min_substeps: 1,
            max_substeps: 64,
            grow: 0.5,
            lower_fraction: 0.7,
            calm_steps: 5,
        }
    }
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            method: SolverMethod::Xpbd,
            substeps: 8,
            iterations: 2,
            stretch_compliance: 0.0,
            shear_compliance: 0.0,
            bend_compliance: 500.0,
            damping: 0.5,
            damping_mode: DampingMode::Rigid,
            thickness: 0.005,
            friction: 0.5,
            long_range_attachments: true,
            isometric_bending: true,
            springs: SpringSettings::default(),
            auto_substeps: false,
            self_collision: SelfCollisionMethod::Off,
            volume: None,
            adaptive: None,
            exact_edges: Some(ExactEdges::default()),
            air: None,
        }
    }
}

impl SolverSettings {
    /// Whether the method projects the long-range attachments: XPBD and PBD when
    /// [`SolverSettings::long_range_attachments`] is on, the hybrid when asked for in
    /// [`SolverMethod::Hybrid`], mass-spring never.
    pub(crate) fn projects_long_range(&self) -> bool {
        match self.method {
            SolverMethod::Xpbd | SolverMethod::Pbd { .. } => self.long_range_attachments,
            SolverMethod::Hybrid { long_range } => long_range,
            SolverMethod::MassSpring => false,
        }
    }

    /// The fewest iterations the settings accept: 2 where the method projects the long-range
    /// attachments (one sweep of them and the edges per substep gains energy), else 1. The
    /// panel's iterations slider starts here.
    pub fn fewest_iterations(&self) -> u32 {
        if self.projects_long_range() { 2 } else { 1 }
    }

    /// The exact solve of the structural edges the step runs while the cloth touches a
    /// collider: [`SolverSettings::exact_edges`] when the edges are inextensible (XPBD and
    /// the hybrid at `stretch_compliance` 0, PBD at stiffness 1) and no volume is held; none
    /// otherwise, since edges meant to give (a rubber skin, a soft PBD cloth, a balloon's
    /// pressure) would be pulled back to their rest lengths.
    pub(crate) fn exact_edge_solve(&self) -> Option<ExactEdges> {
        let inextensible = match self.method {
            SolverMethod::Xpbd | SolverMethod::Hybrid { .. } => self.stretch_compliance == 0.0,
            SolverMethod::Pbd { stiffness } => stiffness >= 1.0,
            SolverMethod::MassSpring => false,
        };
        self.exact_edges
            .filter(|_| inextensible && self.volume.is_none())
    }

    /// Whether the shear constraints are projected apart from the threads, with
    /// [`SolverSettings::shear_compliance`] (XPBD without a volume constraint, a compliance
    /// above zero).
    pub(crate) fn projects_shear_apart(&self) -> bool {
        self.method == SolverMethod::Xpbd && self.volume.is_none() && self.shear_compliance > 0.0
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ClothError> {
        let checks: [(&'static str, f32, bool, &'static str); 9] = [
            (
                "substeps",
                self.substeps as f32,
                self.substeps >= 1,
                "at least 1",
            ),
            (
                "iterations",
                self.iterations as f32,
                self.iterations >= 1,
                "at least 1",
            ),
            (
                "stretch_compliance",
                self.stretch_compliance,
                self.stretch_compliance.is_finite() && self.stretch_compliance >= 0.0,
                "finite and >= 0",
            ),
            (
                "shear_compliance",
                self.shear_compliance,
                self.shear_compliance >= 0.0,
                ">= 0 (infinite: no shear constraint)",
            ),
            (
                "bend_compliance",
                self.bend_compliance,
                self.bend_compliance.is_finite() && self.bend_compliance >= 0.0,
                "finite and >= 0",
            ),
            (
                "damping",
                self.damping,
                self.damping.is_finite() && self.damping >= 0.0,
                "finite and >= 0",
            ),
            (
                "thickness",
                self.thickness,
                self.thickness.is_finite() && self.thickness >= 0.0,
                "finite and >= 0",
            ),
            (
                "friction",
                self.friction,
                self.friction.is_finite() && self.friction >= 0.0,
                "finite and >= 0",
            ),
            match self.method {
                SolverMethod::Xpbd => ("method", 0.0, true, ""),
                SolverMethod::Pbd { stiffness } => (
                    "stiffness",
                    stiffness,
                    stiffness > 0.0 && stiffness <= 1.0,
                    "in (0, 1]",
                ),
                SolverMethod::MassSpring | SolverMethod::Hybrid { .. } => ("method", 0.0, true, ""),
            },
        ];
        if let Some(air) = self.air {
            air.validate()?;
        }
        if let Some(volume) = self.volume {
            if !(volume.pressure.is_finite() && volume.pressure > 0.0) {
                return Err(ClothError::InvalidSetting {
                    name: "volume.pressure",
                    value: volume.pressure,
                    reason: "finite and > 0",
                });
            }
            if !(volume.compliance.is_finite() && volume.compliance >= 0.0) {
                return Err(ClothError::InvalidSetting {
                    name: "volume.compliance",
                    value: volume.compliance,
                    reason: "finite and >= 0",
                });
            }
        }
        if let Some(exact) = self.exact_edges
            && (exact.newton_steps < 1 || exact.cg_iterations < 1)
        {
            return Err(ClothError::InvalidSetting {
                name: "exact_edges",
                value: exact.newton_steps.min(exact.cg_iterations) as f32,
                reason: "newton_steps and cg_iterations at least 1",
            });
        }
        if let Some(exact) = self.exact_edges
            && !(exact.closing_tolerance.is_finite() && exact.closing_tolerance >= 0.0)
        {
            return Err(ClothError::InvalidSetting {
                name: "exact_edges.closing_tolerance",
                value: exact.closing_tolerance,
                reason: "finite and >= 0",
            });
        }
        if let Some(adaptive) = self.adaptive {
            if !(adaptive.target_strain.is_finite() && adaptive.target_strain > 0.0) {
                return Err(ClothError::InvalidSetting {
                    name: "adaptive.target_strain",
                    value: adaptive.target_strain,
                    reason: "finite and > 0",
                });
            }
            if !(adaptive.grow.is_finite() && adaptive.grow >= 0.0) {
                return Err(ClothError::InvalidSetting {
                    name: "adaptive.grow",
                    value: adaptive.grow,
                    reason: "finite and >= 0",
                });
            }
            if !(adaptive.lower_fraction >= 0.0 && adaptive.lower_fraction <= 1.0) {
                return Err(ClothError::InvalidSetting {
                    name: "adaptive.lower_fraction",
                    value: adaptive.lower_fraction,
                    reason: "in [0, 1]",
                });
            }
            if adaptive.min_substeps < 1 || adaptive.max_substeps < adaptive.min_substeps {
                return Err(ClothError::InvalidSetting {
                    name: "adaptive.max_substeps",
                    value: adaptive.max_substeps as f32,
                    reason: "at least adaptive.min_substeps, which is at least 1",
                });
            }
        }
        for (name, value) in self.springs.named() {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ClothError::InvalidSetting {
                    name,
                    value,
                    reason: "finite and >= 0",
                });
            }
        }
        if self.iterations < self.fewest_iterations() {
            // Measured on S1: one sweep of long-range and edge constraints per substep pumps
            // energy into a hanging cloth (max strain 67% at N = 32 and 16 substeps, 414% at
            // N = 64 and 8), while two sweeps hold it below 1%.
            return Err(ClothError::InvalidSetting {
                name: "iterations",
                value: self.iterations as f32,
                reason: "at least 2 with long_range_attachments (one sweep gains energy)",
            });
        }
        for (name, value, ok, reason) in checks {
            if !ok {
                return Err(ClothError::InvalidSetting {
                    name,
                    value,
                    reason,
                });
            }
        }
        Ok(())
    }
}
