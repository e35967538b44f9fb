//! The Bevy side of the fluid: a [`Fluid`] component (its settings and where its particles
//! come from), built into a [`FluidSimulation`] and stepped in the fixed-step schedule's
//! [`DrapeSystems::Step`] set. A `Fluid` on a cloth's entity is water in that cloth: the
//! cloth's step runs it inside its own substeps ([`FluidSolver::step_with_cloth`]); on any
//! other entity it steps alone. Either way it is kept out of the world's colliders.

use bevy::prelude::*;

use super::{FluidSettings, FluidSolver};
use crate::cloth::plugin::{Cloth, DrapeSettings};
use crate::collide::plugin::StepColliders;
use crate::schedule::{DrapeSchedule, DrapeSystems};

/// Where a fluid's particles come from.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum FluidSource {
    /// A box of particles at rest, filled once (world coordinates).
    Block {
        /// The box's smallest corner.
        min: Vec3,
        /// Its largest corner.
        max: Vec3,
    },
    /// A round jet: `rate` particles per second leave a disc of `radius` at `origin` with
    /// `velocity` (the disc faces it), until the fluid has `max_particles`.
    Jet {
        /// The disc's centre (world).
        origin: Vec3,
        /// The particles' velocity, m/s.
        velocity: Vec3,
        /// The disc's radius, metres.
        radius: f32,
        /// Particles per second.
        rate: f32,
        /// The most particles the jet makes.
        max_particles: usize,
    },
}

/// A body of fluid particles (Position Based Fluids). On a [`Cloth`]'s entity, it is water
/// in that cloth, stepped with it.
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component)]
pub struct Fluid {
    /// The solver's parameters.
    pub settings: FluidSettings,
    /// Where its particles come from.
    pub source: FluidSource,
}

/// The simulated fluid of a [`Fluid`], made at its first step.
#[derive(Component, Debug)]
pub struct FluidSimulation {
    pub(crate) solver: FluidSolver,
    /// Particles owed by a jet (fractions carried from step to step).
    owed: f32,
    /// Where the jet's next particles go round its disc (a golden-angle spiral).
    spiral: u32,
}

impl FluidSimulation {
    /// The solver.
    pub fn solver(&self) -> &FluidSolver {
        &self.solver
    }

    /// Emits this step's share of a jet (`dt` long).
    fn emit(&mut self, source: &FluidSource, dt: f32) {
        let FluidSource::Jet {
            origin,
            velocity,
            radius,
            rate,
            max_particles,
        } = *source
        else {
            return;
        };
        self.owed += rate.max(0.0) * dt;
        let room = max_particles.saturating_sub(self.solver.len());
        let count = (self.owed.floor() as usize).min(room);
        self.owed -= count as f32;
        if count == 0 {
            self.owed = self.owed.min(1.0);
            return;
        }
        let axis = velocity.normalize_or(Vec3::NEG_Y);
        let (u, v) = axis.any_orthonormal_pair();
        let mut points = Vec::with_capacity(count);
        for _ in 0..count {
            // Sunflower spiral over the disc.
            let k = self.spiral as f32 + 0.5;
            let r = radius * (k / 64.0).fract().sqrt();
            let a = k * 2.399_963;
            points.push(origin + (u * a.cos() + v * a.sin()) * r);
            self.spiral = self.spiral.wrapping_add(1);
        }
        if let Err(err) = self.solver.add_particles(&points, velocity) {
            warn!("fluid jet: {err}");
        }
    }
}

/// Builds, fills and steps [`Fluid`]s.
pub struct FluidPlugin;

impl Plugin for FluidPlugin {
    fn build(&self, app: &mut App) {
        let schedule = DrapeSchedule::of(app);
        app.register_type::<Fluid>()
            .add_systems(
                schedule,
                (build_fluids, emit_fluids)
                    .chain()
                    .in_set(DrapeSystems::Prepare),
            )
            .add_systems(schedule, step_lone_fluids.in_set(DrapeSystems::Step));
    }
}

/// Makes the simulation of every new [`Fluid`] (a bad setting is logged with the entity,
/// and the fluid left out).
fn build_fluids(
    mut commands: Commands,
    new: Query<(Entity, &Fluid), Without<FluidSimulation>>,
    mut refused: Local<bevy::platform::collections::HashSet<Entity>>,
) {
    for (entity, fluid) in &new {
        if refused.contains(&entity) {
            continue;
        }
        let mut solver = match FluidSolver::new(fluid.settings) {
            Ok(solver) => solver,
            Err(err) => {
                warn!("fluid {entity} is left out: {err}");
                refused.insert(entity);
                continue;
            }
        };
        if let FluidSource::Block { min, max } = fluid.source
            && let Err(err) = solver.add_box(min, max)
        {
            warn!("fluid {entity}: {err}");
        }
        commands.entity(entity).insert(FluidSimulation {
            solver,
            owed: 0.0,
            spiral: 0,
        });
    }
}

/// A jet's particles for this step.
fn emit_fluids(mut fluids: Query<(&Fluid, &mut FluidSimulation)>, time: Res<Time>) {
    for (fluid, mut simulation) in &mut fluids {
        simulation.emit(&fluid.source, time.delta_secs());
    }
}

/// Steps every fluid that is not in a cloth (those step with their cloth).
fn step_lone_fluids(
    mut fluids: Query<(Entity, &mut FluidSimulation), Without<Cloth>>,
    colliders: Option<Res<StepColliders>>,
    drape: Res<DrapeSettings>,
    time: Res<Time>,
) {
    if drape.paused {
        return;
    }
    let colliders = colliders.as_deref().map_or(&[][..], |c| &c.colliders);
    for (entity, mut simulation) in &mut fluids {
        if let Err(err) = simulation.solver.set_colliders(colliders) {
            warn!("fluid {entity}: its colliders are left out: {err}");
            let _ = simulation.solver.set_colliders(&[]);
        }
        simulation.solver.step(drape.gravity, time.delta_secs());
    }
}
