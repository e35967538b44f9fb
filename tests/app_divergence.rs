//! A cloth entity in a headless App whose solver diverges (reported, then frozen or reset) or
//! changes method on the way.

use crate::common;

use bevy::ecs::message::MessageCursor;
use bevy::prelude::*;
use bevy_drape::cloth::SolverMethod;
use bevy_drape::cloth::plugin::{ClothDiverged, OnDivergence};
use bevy_drape::prelude::*;
use common::{add_grid, app, positions};

fn spawn_mass_spring_cloth(app: &mut App, settings: ClothSettings) -> (Entity, GridDesc) {
    let grid = GridDesc::square(1.0, 8, Vec3::ZERO);
    let mesh = add_grid(app, &grid);
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::pinned([grid.index(0, 0), grid.index(7, 0)]),
            settings,
            Transform::from_xyz(0.0, 1.0, 0.0),
        ))
        .id();
    (cloth, grid)
}

/// Reads the [`ClothDiverged`] messages sent since the cursor last read.
fn read_diverged(app: &App, cursor: &mut MessageCursor<ClothDiverged>) -> Vec<ClothDiverged> {
    let messages = app.world().resource::<Messages<ClothDiverged>>();
    cursor.read(messages).copied().collect()
}

/// Stiff springs at one substep per fixed step: far past the explicit stability bound.
fn unstable_settings(on_divergence: OnDivergence) -> ClothSettings {
    let mut settings = ClothSettings {
        on_divergence,
        ..Default::default()
    };
    settings.solver.method = SolverMethod::MassSpring;
    settings.solver.substeps = 1;
    settings.solver.springs.structural.stiffness = 1e5;
    settings
}

#[test]
fn a_diverging_cloth_is_reported_frozen_and_stepped_again_when_its_settings_change() {
    let mut app = app();
    let (cloth, _) = spawn_mass_spring_cloth(&mut app, unstable_settings(OnDivergence::Freeze));
    let mut cursor = MessageCursor::default();
    let mut seen = Vec::new();
    for _ in 0..6 {
        app.update();
        seen.extend(read_diverged(&app, &mut cursor));
    }
    assert_eq!(seen.len(), 1, "reported once, then frozen: {seen:?}");
    let first = seen[0];
    assert_eq!(first.cloth, cloth);
    assert_eq!(first.method, SolverMethod::MassSpring);
    assert_eq!(first.response, OnDivergence::Freeze);
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(simulation.is_frozen());
    assert!(simulation.solver().is_finite());
    let frozen = positions(&app, cloth);
    assert!(frozen.iter().all(|p| p.is_finite()));
    app.update();
    assert_eq!(
        positions(&app, cloth),
        frozen,
        "a frozen cloth does not move"
    );

    // Automatic substeps make the same springs stable: the cloth steps again.
    app.world_mut()
        .get_mut::<ClothSettings>(cloth)
        .unwrap()
        .solver
        .auto_substeps = true;
    let mut later = Vec::new();
    for _ in 0..30 {
        app.update();
        later.extend(read_diverged(&app, &mut cursor));
    }
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(!simulation.is_frozen());
    assert!(simulation.solver().last_substeps() > 1);
    assert_ne!(positions(&app, cloth), frozen);
    assert!(later.is_empty(), "no new divergence: {later:?}");
}

#[test]
fn a_diverging_cloth_set_to_reset_goes_back_to_its_rest_shape() {
    let mut app = app();
    let (cloth, grid) = spawn_mass_spring_cloth(&mut app, unstable_settings(OnDivergence::Reset));
    let mut cursor = MessageCursor::default();
    let mut seen = Vec::new();
    for _ in 0..3 {
        app.update();
        seen.extend(read_diverged(&app, &mut cursor));
    }
    assert!(seen.iter().any(|m| m.response == OnDivergence::Reset));
    let simulation = app.world().get::<ClothSimulation>(cloth).unwrap();
    assert!(!simulation.is_frozen());
    let sim = simulation.solver();
    let rest = grid.mesh().positions;
    // Reset after the last step: the state is the rest shape, 1 m up.
    let worst = sim
        .state()
        .positions
        .iter()
        .zip(&rest)
        .map(|(p, r)| Vec3::from(*p).distance(*r + Vec3::Y))
        .fold(0.0, f32::max);
    assert!(worst < 1e-5, "{worst}");
}

#[test]
fn switching_the_method_of_a_cloth_entity_keeps_its_motion() {
    let mut app = app();
    let (cloth, _) = spawn_mass_spring_cloth(&mut app, ClothSettings::default());
    for _ in 0..33 {
        app.update();
    }
    let state = |app: &App| {
        app.world()
            .get::<ClothSimulation>(cloth)
            .unwrap()
            .solver()
            .state()
            .clone()
    };
    let before = state(&app);
    let speed = before
        .velocities
        .iter()
        .map(|v| v.length())
        .fold(0.0, f32::max);
    {
        let mut settings = app.world_mut().get_mut::<ClothSettings>(cloth).unwrap();
        settings.solver.method = SolverMethod::Hybrid { long_range: false };
        settings.solver.auto_substeps = true;
    }
    let mut cursor = MessageCursor::default();
    app.update();
    let after = state(&app);
    let dt = 1.0 / 64.0;
    let worst = after
        .positions
        .iter()
        .zip(&before.positions)
        .zip(&before.velocities)
        .map(|((x1, x0), v0)| x1.distance(*x0 + *v0 * dt))
        .fold(0.0, f32::max);
    assert!(speed > 0.1);
    assert!(
        worst < 0.2 * speed * dt,
        "{worst} against v dt {}",
        speed * dt
    );
    assert!(read_diverged(&app, &mut cursor).is_empty());
}
