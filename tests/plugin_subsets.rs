//! Every subset of the drape sub-plugins, added alone to a headless App, builds, runs its
//! systems in the ordered drape sets (`Prepare` -> `Animate` -> `InverseKinematics` -> `Colliders` ->
//! `Step`) of one schedule, and steps what it has; a plugin added without the one it needs fails
//! at build with a message naming it.

use std::sync::Arc;
use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_drape::cloth::plugin::{ClothCouplingPlugin, ClothPlugin};
use bevy_drape::cloth::wind_plugin::WindPlugin;
use bevy_drape::collide::plugin::ColliderPlugin;
use bevy_drape::fluid::plugin::{FluidPlugin, FluidSimulation};
use bevy_drape::fluid::{FluidJet, FluidSettings};
use bevy_drape::prelude::*;
use bevy_drape::schedule::{DrapeSchedulePlugin, DrapeSystems};
use bevy_drape::skeleton::plugin::SkeletonPlugin;

/// The sets in the order they must run.
const SETS: [DrapeSystems; 5] = [
    DrapeSystems::Prepare,
    DrapeSystems::Animate,
    DrapeSystems::InverseKinematics,
    DrapeSystems::Colliders,
    DrapeSystems::Step,
];

/// The sets as they ran, in order, one list per fixed step.
#[derive(Resource, Default)]
struct Ran(Vec<Vec<DrapeSystems>>);

/// The sub-plugins, by bit.
const NAMES: [&str; 5] = ["skeleton", "colliders", "wind", "cloth", "fluid"];

fn add_subset(app: &mut App, bits: u32) {
    if bits & 1 != 0 {
        app.add_plugins(SkeletonPlugin);
    }
    if bits & 2 != 0 {
        app.add_plugins(ColliderPlugin);
    }
    if bits & 4 != 0 {
        app.add_plugins(WindPlugin);
    }
    if bits & 8 != 0 {
        app.add_plugins(ClothPlugin);
    }
    if bits & 16 != 0 {
        app.add_plugins(FluidPlugin);
        if bits & 8 != 0 {
            app.add_plugins(ClothCouplingPlugin::<FluidSimulation>::default());
        }
    }
}

fn headless() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 64.0,
    )));
    app
}

/// Records each set as it runs, in `schedule`.
fn probe_sets(app: &mut App, schedule: impl bevy::ecs::schedule::ScheduleLabel + Clone) {
    app.init_resource::<Ran>();
    // Registered in reverse, so the order they run in comes from the sets' order alone.
    for set in SETS.into_iter().rev() {
        let record = move |mut ran: ResMut<Ran>| {
            if set == DrapeSystems::Prepare {
                ran.0.push(Vec::new());
            }
            if let Some(step) = ran.0.last_mut() {
                step.push(set);
            }
        };
        app.add_systems(schedule.clone(), record.in_set(set));
    }
}

fn spawn_scene(app: &mut App, bits: u32) -> Option<Entity> {
    let world = app.world_mut();
    if bits & 1 != 0 {
        world.spawn((
            Skeleton {
                rig: Arc::new(humanoid()),
            },
            BoneColliders::humanoid(),
            // Beside the cloth, not under it.
            Transform::from_xyz(-2.0, 0.0, 0.0),
        ));
    }
    if bits & 2 != 0 {
        world.spawn((ClothCollider::plane(), Transform::default()));
    }
    if bits & 4 != 0 {
        world.insert_resource(Wind {
            velocity: Vec3::new(4.0, 0.0, 0.0),
            ..default()
        });
    }
    if bits & 16 != 0 {
        world.spawn((
            Fluid {
                settings: FluidSettings::default(),
                source: FluidSource::Jet(FluidJet {
                    origin: Vec3::new(3.0, 1.0, 0.0),
                    velocity: Vec3::new(0.0, -1.0, 0.0),
                    radius: 0.04,
                    rate: 100.0,
                    max_particles: 20,
                }),
            },
            Transform::default(),
        ));
    }
    (bits & 8 != 0).then(|| {
        let grid = GridDesc::square(0.5, 6, Vec3::ZERO);
        let mesh = world.resource_mut::<Assets<Mesh>>().add(grid_mesh(&grid));
        world
            .spawn((
                Mesh3d(mesh),
                Cloth::default(),
                Transform::from_xyz(0.0, 0.5, 0.0),
            ))
            .id()
    })
}

#[test]
fn every_subset_of_the_sub_plugins_runs_its_sets_in_order_and_steps_its_cloth() {
    for bits in 1..32u32 {
        let names: Vec<&str> = (0..5)
            .filter(|k| bits & (1 << k) != 0)
            .map(|k| NAMES[k])
            .collect();
        let mut app = headless();
        add_subset(&mut app, bits);
        probe_sets(&mut app, FixedPostUpdate);
        let cloth = spawn_scene(&mut app, bits);
        for _ in 0..33 {
            app.update();
        }
        let ran = &app.world().resource::<Ran>().0;
        assert!(ran.len() >= 30, "{names:?}: {} fixed steps", ran.len());
        for step in ran {
            assert_eq!(step, &SETS, "{names:?}: the sets ran out of order");
        }
        if let Some(cloth) = cloth {
            let simulation = app
                .world()
                .get::<ClothSimulation>(cloth)
                .unwrap_or_else(|| panic!("{names:?}: the cloth was not built"));
            let state = simulation.solver().state();
            assert!(state.positions.iter().all(|p| p.is_finite()), "{names:?}");
            // Half a second of fall, or resting on the plane.
            let lowest = state.positions.iter().map(|p| p.y).fold(f32::MAX, f32::min);
            assert!(lowest < 0.4, "{names:?}: the cloth did not step ({lowest})");
            if bits & 2 != 0 {
                assert!(
                    lowest > -0.01,
                    "{names:?}: the plane did not hold ({lowest})"
                );
            }
        }
    }
}

#[test]
fn the_schedule_plugin_added_first_moves_every_subset_to_its_schedule() {
    for bits in [8u32, 1 | 2 | 8, 31] {
        let mut app = headless();
        app.add_plugins(DrapeSchedulePlugin::new(FixedUpdate));
        add_subset(&mut app, bits);
        probe_sets(&mut app, FixedUpdate);
        let cloth = spawn_scene(&mut app, bits);
        for _ in 0..17 {
            app.update();
        }
        let ran = &app.world().resource::<Ran>().0;
        assert!(ran.len() >= 15 && ran.iter().all(|s| s == &SETS));
        let cloth = app.world().get::<ClothSimulation>(cloth.unwrap()).unwrap();
        let highest = cloth
            .solver()
            .state()
            .positions
            .iter()
            .map(|p| p.y)
            .fold(f32::MIN, f32::max);
        assert!(highest < 0.45, "{bits}: {highest}");
    }
}

#[test]
fn the_fluid_coupling_without_the_cloth_plugin_fails_at_build_naming_it() {
    let mut app = headless();
    app.add_plugins(FluidPlugin);
    let built = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        app.add_plugins(ClothCouplingPlugin::<FluidSimulation>::default());
    }));
    let text = panic_text(built.expect_err("it needs the cloth plugin"));
    assert!(text.contains("ClothPlugin"), "{text}");
}

fn panic_text(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default()
}

#[test]
fn the_schedule_plugin_added_after_a_sub_plugin_is_refused_at_build() {
    let mut app = headless();
    app.add_plugins(ClothPlugin);
    let added = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        app.add_plugins(DrapeSchedulePlugin::new(FixedUpdate));
    }));
    let text = panic_text(added.expect_err("two schedules for one crate"));
    assert!(text.contains("DrapeSchedulePlugin"), "{text}");
}
