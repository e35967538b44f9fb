//! The Bevy side of the fluid: a [`Fluid`] component (its settings and where its particles
//! come from), built into a [`FluidSimulation`] and stepped in the fixed-step schedule's
//! [`DrapeSystems::Step`] set. A `Fluid` on a cloth's entity is water in that cloth: the
//! cloth's step runs it inside its own substeps ([`FluidSolver::step_with_cloth`]); on any
//! other entity it steps alone. Either way it is kept out of the world's colliders. A changed
//! `Fluid::settings` reaches the solver at the next step, its particles kept; a new source
//! takes effect when the `FluidSimulation` is removed (it is built again).

use bevy::prelude::*;

use super::{FluidJet, FluidSettings, FluidSolver, JetEmitter};
use crate::cloth::{ClothSolver, SolverSettings};
use crate::collide::SolverCollider;
use crate::error::ClothError;
use crate::schedule::{
    ClothCoupling, DrapeSchedule, DrapeSettings, DrapeSystems, IsCloth, StepColliders,
};

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
    /// A round jet, emitting every step until it has made its count.
    Jet(FluidJet),
}

/// A body of fluid particles (Position Based Fluids). On a [`Cloth`](crate::cloth::plugin::Cloth)'s entity, it is water
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
    solver: FluidSolver,
    /// What a jet carries from step to step.
    emitter: JetEmitter,
}

impl FluidSimulation {
    /// The solver.
    pub fn solver(&self) -> &FluidSolver {
        &self.solver
    }
}

/// Water in a cloth steps inside the cloth's substeps, kept out of the same colliders.
impl ClothCoupling for FluidSimulation {
    fn step_with_cloth(
        &mut self,
        entity: Entity,
        cloth: &mut ClothSolver,
        settings: &SolverSettings,
        colliders: &[SolverCollider],
        gravity: Vec3,
        dt: f32,
    ) -> Result<(), ClothError> {
        if let Err(err) = self.solver.set_colliders(colliders) {
            warn!("the fluid in cloth {entity}: its colliders are left out: {err}");
            let _ = self.solver.set_colliders(&[]);
        }
        self.solver.step_with_cloth(cloth, settings, gravity, dt)
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
                (build_fluids, apply_fluid_settings, emit_fluids)
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
            emitter: JetEmitter::default(),
        });
    }
}

/// Hands a changed [`Fluid::settings`] to its solver (the particles stay); a bad setting is
/// logged with the entity, and the solver keeps the settings it had.
fn apply_fluid_settings(mut fluids: Query<(Entity, &Fluid, &mut FluidSimulation), Changed<Fluid>>) {
    for (entity, fluid, mut simulation) in &mut fluids {
        if *simulation.solver.settings() == fluid.settings {
            continue;
        }
        if let Err(err) = simulation.solver.set_settings(fluid.settings) {
            warn!("fluid {entity} keeps its previous settings: {err}");
        }
    }
}

/// A jet's particles for this step.
fn emit_fluids(mut fluids: Query<(Entity, &Fluid, &mut FluidSimulation)>, time: Res<Time>) {
    for (entity, fluid, mut simulation) in &mut fluids {
        let FluidSource::Jet(jet) = &fluid.source else {
            continue;
        };
        let simulation = &mut *simulation;
        if let Err(err) = simulation
            .emitter
            .emit(jet, &mut simulation.solver, time.delta_secs())
        {
            warn!("fluid {entity}: its jet adds nothing: {err}");
        }
    }
}

/// Steps every fluid that is not in a cloth (those step with their cloth).
fn step_lone_fluids(
    mut fluids: Query<(Entity, &mut FluidSimulation), Without<IsCloth>>,
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
