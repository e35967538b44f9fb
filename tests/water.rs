//! Water in a headless App (`MinimalPlugins`): a `Fluid` on a cloth's entity is stepped with
//! the cloth, a lone jet fills a box, bad settings are refused with the app running on.

use crate::common;

use bevy::prelude::*;
use bevy_drape::fluid::plugin::FluidSimulation;
use bevy_drape::fluid::{FluidJet, FluidSettings};
use bevy_drape::prelude::*;
use common::{Headless, add_grid};
use drape_scenes::water::particles_below_sheet;

/// A headless App stepping 1/60 s per update.
fn app() -> App {
    Headless::new()
        .seconds_per_update(1.0 / 60.0)
        .fixed_hz(60.0)
        .build()
}

/// A sheet hung by its corners from four posts 70% of the way out, with a block of water
/// over it, on one entity: the water lands in it and stays above it, the sheet carries its
/// weight, all finite.
#[test]
fn water_on_a_cloths_entity_falls_into_it_and_stays() {
    let mut app = app();
    let n = 13;
    let grid = GridDesc::square(0.6, n, Vec3::new(-0.3, 0.0, -0.3));
    let mesh = add_grid(&mut app, &grid);
    let corners = [0, n - 1, n * (n - 1), n * n - 1];
    let settings = ClothSettings {
        density: 0.2,
        solver: SolverSettings {
            substeps: 16,
            iterations: 4,
            ..SolverSettings::default()
        },
        ..ClothSettings::default()
    };
    // Each corner hangs from a post 70% of the way out: the sheet hangs as a bowl.
    let mut cloth = Cloth::default();
    for k in corners {
        let i = k % n;
        let j = k / n;
        let corner = Vec3::new(
            i as f32 / (n - 1) as f32 - 0.5,
            0.0,
            j as f32 / (n - 1) as f32 - 0.5,
        ) * 0.6;
        let post = app
            .world_mut()
            .spawn(Transform::from_translation(corner * 0.7 + Vec3::Y * 0.5))
            .id();
        cloth = cloth.with_attachment(VertexAttachment {
            vertex: k,
            target: post,
            offset: Vec3::ZERO,
        });
    }
    let entity = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            cloth,
            settings,
            Transform::from_xyz(0.0, 0.5, 0.0),
            Fluid {
                settings: FluidSettings::default(),
                source: FluidSource::Block {
                    min: Vec3::new(-0.06, 0.55, -0.06),
                    max: Vec3::new(0.06, 0.65, 0.06),
                },
            },
        ))
        .id();
    let mut carried = 0.0f32;
    for k in 0..121 {
        app.update();
        let world = app.world();
        let (Some(fluid), Some(cloth)) = (
            world.get::<FluidSimulation>(entity),
            world.get::<ClothSimulation>(entity),
        ) else {
            continue;
        };
        let (fluid, cloth) = (fluid.solver(), cloth.solver());
        let below = particles_below_sheet(
            &cloth.state().positions,
            &cloth.model().triangles,
            fluid.positions(),
        );
        assert_eq!(below, 0, "update {k}: {below} particles went through");
        if k > 90 {
            carried += -fluid.cloth_contacts().impulse().y * 60.0 / 30.0;
        }
    }
    let world = app.world();
    let fluid = world
        .get::<FluidSimulation>(entity)
        .expect("the fluid is built")
        .solver();
    let cloth = world.get::<ClothSimulation>(entity).unwrap().solver();
    let x = &cloth.state().positions;
    let lowest_cloth = x.iter().map(|p| p.y).fold(f32::MAX, f32::min);
    // The water still in the sheet, and the weight of it the sheet carries (over the last
    // half second).
    let r = fluid.settings().particle_radius;
    let kept = fluid
        .positions()
        .iter()
        .filter(|p| p.y > lowest_cloth - r)
        .count();
    let weight = fluid.particle_mass() * kept as f32 * 9.81;
    eprintln!(
        "{kept} of {} particles in the sheet (lowest point {lowest_cloth:.3} m): weight \
         {weight:.3} N, carried {carried:.3} N",
        fluid.len()
    );
    assert!(kept * 10 >= fluid.len() * 9, "most of the water spilled");
    assert!(
        (carried / weight - 1.0).abs() < 0.1,
        "{carried} of {weight}"
    );
    assert!(fluid.positions().iter().all(|p| p.is_finite()));
    assert!(x.iter().all(|p| p.is_finite()));
}

/// A jet on an entity of its own pours into a box of plane colliders: it stops at its
/// largest count, nothing leaves the box, all finite.
#[test]
fn a_jet_fills_a_box_and_stops_at_its_count() {
    let mut app = app();
    let walls = [
        (Vec3::ZERO, Vec3::Y),
        (Vec3::new(-0.15, 0.0, 0.0), Vec3::X),
        (Vec3::new(0.15, 0.0, 0.0), Vec3::NEG_X),
        (Vec3::new(0.0, 0.0, -0.15), Vec3::Z),
        (Vec3::new(0.0, 0.0, 0.15), Vec3::NEG_Z),
    ];
    for (point, normal) in walls {
        app.world_mut().spawn((
            ClothCollider::plane(),
            Transform::from_translation(point)
                .with_rotation(Quat::from_rotation_arc(Vec3::Y, normal)),
        ));
    }
    let jet = app
        .world_mut()
        .spawn(Fluid {
            settings: FluidSettings::default(),
            source: FluidSource::Jet(FluidJet {
                origin: Vec3::new(0.0, 0.4, 0.0),
                velocity: Vec3::new(0.0, -1.0, 0.0),
                radius: 0.03,
                rate: 600.0,
                max_particles: 400,
            }),
        })
        .id();
    for _ in 0..121 {
        app.update();
    }
    let fluid = app.world().get::<FluidSimulation>(jet).unwrap().solver();
    assert_eq!(fluid.len(), 400);
    for p in fluid.positions() {
        assert!(p.is_finite());
        assert!(
            p.y > -1e-3 && p.x.abs() < 0.15 + 1e-3 && p.z.abs() < 0.15 + 1e-3,
            "{p}"
        );
    }
}

/// A fluid with a bad setting is left out (a warning names it); the app steps on.
#[test]
fn a_fluid_with_bad_settings_is_left_out() {
    let mut app = app();
    let bad = app
        .world_mut()
        .spawn(Fluid {
            settings: FluidSettings {
                particle_radius: f32::NAN,
                ..FluidSettings::default()
            },
            source: FluidSource::Block {
                min: Vec3::ZERO,
                max: Vec3::ONE,
            },
        })
        .id();
    for _ in 0..10 {
        app.update();
    }
    assert!(app.world().get::<FluidSimulation>(bad).is_none());
}

/// Settings changed on a running fluid reach its solver with the particles kept; a bad one
/// leaves the solver as it was and the app running.
#[test]
fn changed_fluid_settings_reach_the_solver_and_bad_ones_are_refused() {
    let mut app = app();
    let fluid = app
        .world_mut()
        .spawn(Fluid {
            settings: FluidSettings::default(),
            source: FluidSource::Block {
                min: Vec3::new(-0.05, 0.0, -0.05),
                max: Vec3::new(0.05, 0.1, 0.05),
            },
        })
        .id();
    for _ in 0..3 {
        app.update();
    }
    let count = app
        .world()
        .get::<FluidSimulation>(fluid)
        .unwrap()
        .solver()
        .len();
    assert!(count > 0);
    let changed = FluidSettings {
        viscosity: 0.1,
        iterations: 7,
        rest_density: 900.0,
        ..FluidSettings::default()
    };
    app.world_mut().get_mut::<Fluid>(fluid).unwrap().settings = changed;
    app.update();
    let solver = app.world().get::<FluidSimulation>(fluid).unwrap().solver();
    assert_eq!(*solver.settings(), changed);
    assert_eq!(solver.len(), count);
    app.world_mut()
        .get_mut::<Fluid>(fluid)
        .unwrap()
        .settings
        .relaxation = f32::NAN;
    for _ in 0..5 {
        app.update();
    }
    let solver = app.world().get::<FluidSimulation>(fluid).unwrap().solver();
    assert_eq!(*solver.settings(), changed);
    assert_eq!(solver.len(), count);
    assert!(solver.positions().iter().all(|p| p.is_finite()));
}
