//! The egui panel (feature `egui`): the selected cloth's solver settings as sliders, the
//! world's gravity, wind, time scale, pause, single step and reset, live readouts of the fixed
//! step's cost by stage, strain, energy and contacts, each fluid's settings and density error,
//! the debug colours and collider gizmos.
//!
//! Add [`DrapePanelPlugin`] next to `DefaultPlugins` and [`crate::DrapePlugins`]; the panel
//! edits the same components and resources a game would ([`ClothSettings`], [`Fluid`],
//! [`DrapeSettings`], [`ClothDebugColors`], [`ColliderGizmos`], `Time<Virtual>`), so whatever
//! it changes behaves as it would from code: a new density recomputes the masses, a new method
//! keeps the positions, a fluid's new settings keep its particles.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};

use super::gizmos::ColliderGizmos;
use crate::cloth::air::AirSettings;
use crate::cloth::debug_colors::DebugColorMode;
use crate::cloth::plugin::{
    ClothDebugColors, ClothSettings, ClothSimulation, DefaultClothSettings,
};
use crate::cloth::settings::{DampingMode, ExactEdges, SelfCollisionMethod, SolverMethod};
use crate::cloth::wind_plugin::Wind;
use crate::collide::plugin::ClothCollider;
use crate::fluid::FluidSettings;
use crate::fluid::plugin::{Fluid, FluidSimulation};
use crate::schedule::{DrapeSchedule, DrapeSettings, DrapeTimings};

/// Adds the panel (and `EguiPlugin` if the App has none).
pub struct DrapePanelPlugin;

impl Plugin for DrapePanelPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<EguiPlugin>() {
            app.add_plugins(EguiPlugin::default());
        }
        if !app.is_plugin_added::<super::gizmos::ColliderGizmoPlugin>() {
            app.add_plugins(super::gizmos::ColliderGizmoPlugin);
        }
        app.init_resource::<DrapePanel>()
            .add_systems(EguiPrimaryContextPass, panel)
            .add_systems(Last, single_step);
    }
}

/// The panel's state.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct DrapePanel {
    /// The cloth the settings apply to (the first one if none or gone).
    pub selected: Option<Entity>,
    /// Run one fixed step at the end of this frame (while paused).
    pub step_requested: bool,
    /// Collider friction and restitution to apply to every collider when changed.
    collider_material: Option<(f32, f32)>,
}

type Cloths<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        Option<&'static Name>,
        &'static mut ClothSimulation,
        Option<&'static mut ClothSettings>,
    ),
>;

#[allow(clippy::too_many_arguments)]
fn panel(
    mut contexts: EguiContexts,
    mut state: ResMut<DrapePanel>,
    mut commands: Commands,
    mut cloths: Cloths,
    defaults: Res<DefaultClothSettings>,
    mut drape: ResMut<DrapeSettings>,
    mut time: ResMut<Time<Virtual>>,
    timings: Res<DrapeTimings>,
    mut debug: ResMut<ClothDebugColors>,
    mut gizmos: ResMut<ColliderGizmos>,
    mut colliders: Query<&mut ClothCollider>,
    drag: Option<ResMut<super::drag::ClothDrag>>,
    wind: Option<ResMut<Wind>>,
    mut fluids: Query<(Entity, Option<&Name>, &mut Fluid, Option<&FluidSimulation>)>,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    if let Some(mut drag) = drag {
        let over = ctx.egui_wants_pointer_input() || ctx.is_pointer_over_egui();
        if drag.pointer_over_ui != over {
            drag.pointer_over_ui = over;
        }
    }
    let names: Vec<(Entity, String)> = cloths
        .iter()
        .map(|(e, name, _, _)| {
            (
                e,
                name.map_or_else(|| format!("cloth {e}"), |n| n.to_string()),
            )
        })
        .collect();
    if state
        .selected
        .is_none_or(|e| !names.iter().any(|(n, _)| *n == e))
    {
        state.selected = names.first().map(|(e, _)| *e);
    }
    let (friction0, restitution0) = state.collider_material.unwrap_or_else(|| {
        colliders.iter().next().map_or((0.5, 0.0), |c| {
            (c.material.friction, c.material.restitution)
        })
    });
    let (mut collider_friction, mut collider_restitution) = (friction0, restitution0);

    // As tall as the window lets it be, scrolled when it is taller.
    let height = (ctx.content_rect().height() - 40.0).max(200.0);
    egui::Window::new("bevy_drape")
        .default_width(280.0)
        .default_height(height)
        .vscroll(true)
        .show(ctx, |ui| {
            // World.
            ui.horizontal(|ui| {
                let paused = time.is_paused();
                if ui.button(if paused { "run" } else { "pause" }).clicked() {
                    if paused {
                        time.unpause();
                    } else {
                        time.pause();
                    }
                }
                if ui.add_enabled(paused, egui::Button::new("step")).clicked() {
                    state.step_requested = true;
                }
                if ui.button("reset all").clicked() {
                    for (_, _, mut simulation, _) in &mut cloths {
                        simulation.reset();
                    }
                }
            });
            let mut speed = time.relative_speed();
            if ui
                .add(egui::Slider::new(&mut speed, 0.05..=2.0).text("time scale"))
                .changed()
            {
                time.set_relative_speed(speed);
            }
            ui.add(egui::Slider::new(&mut drape.gravity.y, -20.0..=0.0).text("gravity y, m/s²"));
            ui.horizontal(|ui| {
                let mut on = drape.teleport.is_some();
                ui.checkbox(&mut on, "teleports");
                match (on, drape.teleport.as_mut()) {
                    (true, Some(teleport)) => {
                        ui.add(
                            egui::Slider::new(&mut teleport.distance, 0.05..=10.0)
                                .logarithmic(true)
                                .text("beyond, m/step"),
                        );
                    }
                    (true, None) => drape.teleport = Some(Default::default()),
                    (false, _) => drape.teleport = None,
                }
            });

            wind_controls(ui, &mut commands, wind);

            ui.separator();
            ui.label(format!(
                "fixed step {:.2} ms: animation {:.2}, IK {:.2}, colliders {:.2}, cloth {:.2}",
                ms(timings.total()),
                ms(timings.animation),
                ms(timings.inverse_kinematics),
                ms(timings.colliders),
                ms(timings.cloth)
            ));
            let parts = &timings.cloth_parts;
            ui.label(format!(
                "cloth: predict {:.2}, constraints {:.2}, self-collision {:.2}, contacts {:.2}, \
                 air {:.2}; write-back {:.2} ms",
                ms(parts.predict),
                ms(parts.constraints),
                ms(parts.self_collision),
                ms(parts.contacts),
                ms(parts.air),
                ms(timings.write_back)
            ));

            for (entity, name, mut fluid, simulation) in &mut fluids {
                ui.separator();
                let label =
                    name.map_or_else(|| format!("fluid {entity}"), |n| format!("fluid: {n}"));
                egui::CollapsingHeader::new(label)
                    .default_open(true)
                    .show(ui, |ui| {
                        let mut edited = fluid.settings;
                        fluid_controls(ui, &mut edited);
                        if edited != fluid.settings {
                            fluid.settings = edited;
                        }
                        if let Some(simulation) = simulation {
                            let solver = simulation.solver();
                            let error = solver.density_error();
                            ui.label(format!(
                                "{} particles, density error mean {:.2}%, max {:.2}%",
                                solver.len(),
                                100.0 * error.mean,
                                100.0 * error.max
                            ));
                            if ui.button("refill").clicked() {
                                commands.entity(entity).remove::<FluidSimulation>();
                            }
                        }
                    });
            }

            ui.separator();
            let selected_name = names
                .iter()
                .find(|(e, _)| Some(*e) == state.selected)
                .map_or("none".to_string(), |(_, n)| n.clone());
            egui::ComboBox::from_label("cloth")
                .selected_text(selected_name)
                .show_ui(ui, |ui| {
                    for (e, name) in &names {
                        ui.selectable_value(&mut state.selected, Some(*e), name);
                    }
                });
            if let Some(selected) = state.selected
                && let Ok((entity, _, mut simulation, settings)) = cloths.get_mut(selected)
            {
                let mut edited = settings.as_deref().copied().unwrap_or(defaults.0);
                cloth_controls(ui, &mut edited);
                if ui.button("reset cloth").clicked() {
                    simulation.reset();
                }
                let sim = simulation.solver();
                let strain = sim.strain();
                ui.label(format!(
                    "max strain {:.2}%, mean {:.3}%\nenergy {:.4} J (kinetic {:.4})\n\
                     {} collider contacts, {} self-contacts, {} substeps{}",
                    100.0 * strain.max,
                    100.0 * strain.mean,
                    sim.kinetic_energy() + sim.potential_energy(drape.gravity),
                    sim.kinetic_energy(),
                    sim.contact_count(),
                    sim.self_contact_count(),
                    sim.last_substeps(),
                    if simulation.is_frozen() {
                        "; frozen (diverged)"
                    } else {
                        ""
                    }
                ));
                match settings {
                    Some(mut current) => {
                        if *current != edited {
                            *current = edited;
                        }
                    }
                    None => {
                        if edited != defaults.0 {
                            commands.entity(entity).insert(edited);
                        }
                    }
                }
            }

            ui.separator();
            ui.label("colliders (all)");
            ui.add(egui::Slider::new(&mut collider_friction, 0.0..=1.5).text("friction"));
            ui.add(egui::Slider::new(&mut collider_restitution, 0.0..=1.0).text("restitution"));
            ui.checkbox(&mut gizmos.enabled, "show collider gizmos");
            egui::ComboBox::from_label("debug colours")
                .selected_text(format!("{:?}", debug.0))
                .show_ui(ui, |ui| {
                    for mode in [
                        DebugColorMode::Off,
                        DebugColorMode::Strain,
                        DebugColorMode::Speed,
                        DebugColorMode::Contact,
                        DebugColorMode::Pinned,
                        DebugColorMode::AreaStrain,
                        DebugColorMode::Custom,
                    ] {
                        ui.selectable_value(&mut debug.0, mode, format!("{mode:?}"));
                    }
                });
        });

    if (collider_friction, collider_restitution) != (friction0, restitution0) {
        for mut collider in &mut colliders {
            collider.material.friction = collider_friction;
            collider.material.restitution = collider_restitution;
        }
        state.collider_material = Some((collider_friction, collider_restitution));
    }
    Ok(())
}

/// The sliders of one cloth's settings.
fn cloth_controls(ui: &mut egui::Ui, settings: &mut ClothSettings) {
    let solver = &mut settings.solver;
    let method_name = solver.method.name();
    egui::ComboBox::from_label("method")
        .selected_text(method_name)
        .show_ui(ui, |ui| {
            for method in [
                SolverMethod::Xpbd,
                SolverMethod::Pbd { stiffness: 1.0 },
                SolverMethod::MassSpring,
                SolverMethod::Hybrid { long_range: false },
            ] {
                let is = std::mem::discriminant(&solver.method) == std::mem::discriminant(&method);
                if ui.selectable_label(is, method.name()).clicked() && !is {
                    solver.method = method;
                }
            }
        });
    ui.add(
        egui::Slider::new(&mut solver.substeps, 1..=256)
            .logarithmic(true)
            .text("substeps"),
    );
    // One sweep with long-range constraints gains energy: the settings refuse it.
    let fewest = solver.fewest_iterations();
    solver.iterations = solver.iterations.max(fewest);
    ui.add(egui::Slider::new(&mut solver.iterations, fewest..=20).text("iterations"));
    match &mut solver.method {
        SolverMethod::Xpbd | SolverMethod::Hybrid { .. } => {
            ui.add(
                egui::Slider::new(&mut solver.stretch_compliance, 0.0..=1e-2)
                    .logarithmic(true)
                    .text("stretch compliance, m/N"),
            );
        }
        SolverMethod::Pbd { stiffness } => {
            ui.add(egui::Slider::new(stiffness, 0.01..=1.0).text("PBD stiffness"));
        }
        SolverMethod::MassSpring => {}
    }
    if solver.method == SolverMethod::Xpbd {
        // Free shear: no shear constraint at all (an infinite compliance).
        let mut free = solver.shear_compliance.is_infinite();
        ui.checkbox(&mut free, "free shear");
        if free {
            solver.shear_compliance = f32::INFINITY;
        } else {
            if solver.shear_compliance.is_infinite() {
                solver.shear_compliance = 0.0;
            }
            ui.add(
                egui::Slider::new(&mut solver.shear_compliance, 0.0..=1.0)
                    .logarithmic(true)
                    .text("shear compliance, m/N"),
            );
        }
    }
    match solver.method {
        SolverMethod::Xpbd | SolverMethod::Pbd { .. } => {
            ui.add(
                egui::Slider::new(&mut solver.bend_compliance, 1.0..=1e5)
                    .logarithmic(true)
                    .text("bend compliance, 1/(N m)"),
            );
        }
        SolverMethod::MassSpring | SolverMethod::Hybrid { .. } => {
            let springs = &mut solver.springs;
            for (name, constants) in [
                ("structural k, N/m", &mut springs.structural),
                ("shear k, N/m", &mut springs.shear),
                ("bend k, N/m", &mut springs.bend),
            ] {
                ui.add(
                    egui::Slider::new(&mut constants.stiffness, 0.1..=1e5)
                        .logarithmic(true)
                        .text(name),
                );
            }
            ui.checkbox(&mut solver.auto_substeps, "automatic substeps");
        }
    }
    ui.add(
        egui::Slider::new(&mut settings.density, 0.01..=2.0)
            .logarithmic(true)
            .text("density, kg/m²"),
    );
    ui.horizontal(|ui| {
        ui.add(egui::Slider::new(&mut solver.damping, 0.0..=10.0).text("damping, 1/s"));
        ui.selectable_value(&mut solver.damping_mode, DampingMode::Rigid, "rigid");
        ui.selectable_value(&mut solver.damping_mode, DampingMode::Plain, "plain");
    });
    ui.add(egui::Slider::new(&mut solver.thickness, 0.0..=0.05).text("thickness, m"));
    ui.add(egui::Slider::new(&mut solver.friction, 0.0..=1.5).text("friction"));
    ui.horizontal(|ui| {
        ui.label("self-collision");
        for method in SelfCollisionMethod::ALL {
            ui.selectable_value(&mut solver.self_collision, method, method.name());
        }
    });
    // The hybrid takes long-range attachments only when its method says so.
    match &mut solver.method {
        SolverMethod::Hybrid { long_range } => {
            ui.checkbox(
                long_range,
                "long-range attachments (an extra for the hybrid)",
            );
        }
        SolverMethod::MassSpring => {}
        _ => {
            ui.checkbox(&mut solver.long_range_attachments, "long-range attachments");
        }
    }
    if solver.method != SolverMethod::MassSpring {
        let mut exact = solver.exact_edges.is_some();
        ui.checkbox(&mut exact, "exact edges while touching a collider");
        if exact != solver.exact_edges.is_some() {
            solver.exact_edges = exact.then(ExactEdges::default);
        }
    }
    ui.add(
        egui::Slider::new(&mut settings.inertia, 0.0..=1.0)
            .text("inertia (of the followed entity's motion)"),
    );
    let mut air_on = solver.air.is_some();
    ui.checkbox(&mut air_on, "air (drag and lift)");
    match (air_on, solver.air.as_mut()) {
        (true, Some(air)) => {
            ui.add(egui::Slider::new(&mut air.drag, 0.0..=3.0).text("drag coefficient"));
            ui.add(egui::Slider::new(&mut air.lift, 0.0..=3.0).text("lift coefficient"));
            ui.add(egui::Slider::new(&mut air.density, 0.0..=3.0).text("air density, kg/m³"));
        }
        (true, None) => solver.air = Some(AirSettings::default()),
        (false, _) => solver.air = None,
    }
}

/// The sliders of one fluid's settings (the particle radius is left as built: changing it
/// under a body of water would compress or burst it).
fn fluid_controls(ui: &mut egui::Ui, settings: &mut FluidSettings) {
    ui.add(egui::Slider::new(&mut settings.substeps, 1..=16).text("substeps"));
    ui.add(egui::Slider::new(&mut settings.iterations, 1..=16).text("iterations"));
    ui.add(
        egui::Slider::new(&mut settings.rest_density, 100.0..=2000.0).text("rest density, kg/m³"),
    );
    ui.add(
        egui::Slider::new(&mut settings.relaxation, 1e-4..=1.0)
            .logarithmic(true)
            .text("relaxation"),
    );
    ui.add(
        egui::Slider::new(&mut settings.artificial_pressure, 0.0..=0.1).text("artificial pressure"),
    );
    ui.add(egui::Slider::new(&mut settings.vorticity, 0.0..=2.0).text("vorticity, m/s"));
    ui.add(egui::Slider::new(&mut settings.viscosity, 0.0..=0.5).text("XSPH viscosity"));
}

/// The wind's speed and heading in the horizontal and its gusts; a button adds a [`Wind`] if
/// the App has none.
fn wind_controls(ui: &mut egui::Ui, commands: &mut Commands, wind: Option<ResMut<Wind>>) {
    let Some(mut wind) = wind else {
        if ui.button("add wind").clicked() {
            commands.insert_resource(Wind::default());
        }
        return;
    };
    let v = wind.velocity;
    let (mut speed, mut heading) = (
        v.with_y(0.0).length(),
        v.z.atan2(v.x).to_degrees().rem_euclid(360.0),
    );
    let mut gusts = wind.gusts;
    ui.add(egui::Slider::new(&mut speed, 0.0..=30.0).text("wind, m/s"));
    ui.add(egui::Slider::new(&mut heading, 0.0..=360.0).text("wind heading, degrees"));
    ui.add(egui::Slider::new(&mut gusts.strength, 0.0..=15.0).text("gusts, m/s"));
    ui.add(
        egui::Slider::new(&mut gusts.frequency, 0.05..=4.0)
            .logarithmic(true)
            .text("gusts per second"),
    );
    let radians = heading.to_radians();
    let velocity = Vec3::new(speed * radians.cos(), v.y, speed * radians.sin());
    // Written back only when a slider moved, so that the resource is not marked changed
    // every frame (and the round trip through the heading does not drift it).
    if (velocity - v).length() > 1e-4 {
        wind.velocity = velocity;
    }
    if gusts != wind.gusts {
        wind.gusts = gusts;
    }
}

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Runs the drape schedule's fixed main schedule once, with the fixed clock, when the panel
/// asked for a single step.
fn single_step(world: &mut World) {
    let requested = world
        .get_resource::<DrapePanel>()
        .is_some_and(|p| p.step_requested);
    if !requested {
        return;
    }
    if let Some(mut panel) = world.get_resource_mut::<DrapePanel>() {
        panel.step_requested = false;
    }
    let label = world
        .get_resource::<DrapeSchedule>()
        .map(|s| s.0)
        .unwrap_or_else(|| FixedPostUpdate.intern());
    // A clock advanced by one fixed timestep, as the fixed schedule sees it.
    let mut fixed = Time::<()>::default();
    fixed.advance_by(world.resource::<Time<Fixed>>().timestep());
    let previous = std::mem::replace(&mut *world.resource_mut::<Time>(), fixed);
    // Everything the fixed step runs: animation, IK, colliders and cloth all live in the
    // drape schedule, which FixedMain runs.
    if world.try_run_schedule(bevy::app::FixedMain).is_err() {
        let _ = world.try_run_schedule(label);
    }
    *world.resource_mut::<Time>() = previous;
}
