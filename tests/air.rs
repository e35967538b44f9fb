//! Air and wind against the drag law and the symmetries of the thin-plate model: terminal
//! velocity, an edge-on fall, a cloth moving with the air, a flag in steady and gusty wind,
//! and the wind resource and sources in an App.

use crate::common;

use bevy::math::Vec3A;
use bevy::prelude::*;
use bevy_drape::cloth::{
    AirSettings, ClothModel, ClothSolver, GridDesc, Gusts, SolverMethod, SolverSettings, WindField,
};
use bevy_drape::prelude::*;
use common::{Rng, add_grid, app};
use drape_scenes::scenes::{FRAME_RATE, Flag, GRAVITY};

const DT: f32 = 1.0 / FRAME_RATE;

fn sheet(orientation: Quat, density: f32) -> ClothSolver {
    let grid = GridDesc {
        orientation,
        ..GridDesc::square(0.5, 8, Vec3::new(0.0, 10.0, 0.0))
    };
    ClothSolver::new(ClothModel::grid(&grid, density).unwrap())
}

/// The velocity of the centre of mass: momentum over mass (the arithmetic mean of the
/// particles' velocities is not conserved by internal forces when their masses differ).
fn mean_velocity(sim: &ClothSolver) -> Vec3 {
    let state = sim.state();
    let (mut momentum, mut mass) = (Vec3::ZERO, 0.0);
    for (v, &w) in state.velocities.iter().zip(&state.inverse_masses) {
        if w > 0.0 {
            momentum += Vec3::from(*v) / w;
            mass += 1.0 / w;
        }
    }
    momentum / mass
}

#[test]
fn a_flat_sheet_falls_at_the_terminal_velocity_of_the_drag_law() {
    // Every method, several densities and drag coefficients: face down, mg = 1/2 rho C_d A v^2
    // gives v = sqrt(2 sigma g / (rho C_d)), whatever the area.
    for method in [
        SolverMethod::Xpbd,
        SolverMethod::Pbd { stiffness: 1.0 },
        SolverMethod::MassSpring,
        SolverMethod::Hybrid { long_range: false },
    ] {
        for (density, drag) in [(0.1, 1.0), (0.3, 1.4), (0.05, 0.7)] {
            let air = AirSettings {
                drag,
                ..AirSettings::default()
            };
            // The spring methods at their stable step (this fine, light sheet needs more than
            // 8 substeps with their default stiffness).
            let settings = SolverSettings {
                method,
                air: Some(air),
                auto_substeps: true,
                ..SolverSettings::default()
            };
            let mut sim = sheet(Quat::IDENTITY, density);
            for _ in 0..240 {
                sim.step(&settings, GRAVITY, DT).unwrap();
            }
            let expected = (2.0 * density * 9.81 / (air.density * drag)).sqrt();
            let v = mean_velocity(&sim);
            println!("{method:?} sigma {density} C_d {drag}: {v} against -{expected}");
            assert!(sim.is_finite());
            assert!(
                (-v.y - expected).abs() <= 0.05 * expected,
                "{method:?}: {} m/s, the drag law gives {expected}",
                -v.y
            );
            // It falls straight: a flat plate falling face down is unstable, and its flutter
            // grows from the rounding (0.002% to 0.5% of the fall's speed sideways, wherever
            // the sheet starts), but it does not tumble or glide off: under 1%.
            assert!(v.with_y(0.0).length() < 1e-2 * expected);
        }
    }
}

#[test]
fn edge_on_a_sheet_falls_as_without_air() {
    // Vertical sheets at random headings: the flow runs along them.
    let mut rng = Rng(11);
    for _ in 0..5 {
        let heading = rng.range(0.0, std::f32::consts::TAU);
        let orientation =
            Quat::from_rotation_y(heading) * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2);
        let mut with_air = sheet(orientation, 0.1);
        let mut vacuum = with_air.clone();
        let air = SolverSettings {
            air: Some(AirSettings::default()),
            ..SolverSettings::default()
        };
        for _ in 0..30 {
            with_air.step(&air, GRAVITY, DT).unwrap();
            vacuum
                .step(&SolverSettings::default(), GRAVITY, DT)
                .unwrap();
        }
        let worst = with_air
            .state()
            .positions
            .iter()
            .zip(&vacuum.state().positions)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f32::max);
        // Free fall for 0.5 s: 1.2 m. Edge on there is no force; only the rounding of the
        // normal can start the tumble a falling sheet takes (edge-on is unstable).
        println!("heading {heading}: {worst} m from the fall in vacuum");
        assert!(
            worst < 1e-3,
            "heading {heading}: {worst} m from the fall in vacuum"
        );
        assert!((mean_velocity(&with_air).y + 0.5 * 9.81).abs() < 0.005 * 9.81);
    }
}

#[test]
fn a_cloth_moving_with_the_air_feels_no_force_and_one_against_it_slows() {
    let settings = SolverSettings {
        air: Some(AirSettings::default()),
        ..SolverSettings::default()
    };
    let velocity = Vec3::new(3.0, -1.0, 2.0);
    let orientation = Quat::from_rotation_z(0.4) * Quat::from_rotation_x(0.3);
    let run = |wind: Vec3| {
        let mut sim = sheet(orientation, 0.1);
        for v in &mut sim.state_mut().velocities {
            *v = velocity.into();
        }
        let field = WindField {
            velocity: wind,
            ..WindField::default()
        };
        for frame in 0..60 {
            sim.set_wind(&field, frame as f32 * DT);
            sim.step(&settings, Vec3::ZERO, DT).unwrap();
        }
        mean_velocity(&sim)
    };
    let with_the_air = run(velocity);
    // Within the resolution of f32 velocities taken from positions 10 m from the origin
    // (an ulp of 1e-6 m over a substep of 1/480 s is 5e-4 m/s).
    assert!(
        (with_the_air - velocity).length() < 1e-3,
        "moving with the wind: {with_the_air}, started at {velocity}"
    );
    let in_still_air = run(Vec3::ZERO);
    assert!(
        in_still_air.length() < 0.9 * velocity.length(),
        "{in_still_air}"
    );
}

fn azimuth_error_degrees(direction: Vec3, wind: Vec3) -> f32 {
    let a = direction.with_y(0.0).normalize();
    let b = wind.with_y(0.0).normalize();
    a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
}

#[test]
fn a_flag_in_steady_wind_streams_downwind() {
    // Winds from random headings at 6 to 14 m/s; after 4 s the flag's mean direction over
    // the last second points downwind in the horizontal to within a few degrees.
    let mut rng = Rng(5);
    let mut next = || rng.uniform();
    for _ in 0..4 {
        let heading = next() * std::f32::consts::TAU;
        let speed = 6.0 + 8.0 * next();
        let wind = Vec3::new(heading.cos(), 0.0, heading.sin()) * speed;
        let flag = Flag {
            n: 15,
            wind,
            gusts: Gusts::default(),
        };
        let run = flag.run(&Flag::settings(), 300);
        let direction = run.mean_direction(60);
        let error = azimuth_error_degrees(direction, wind);
        let droop = direction
            .y
            .atan2(direction.with_y(0.0).length())
            .to_degrees();
        println!("wind {wind} ({speed} m/s): {error:.2} degrees off, droop {droop:.1} degrees");
        assert!(run.finite);
        assert!(
            error < 4.0,
            "wind {wind}: the flag points {error} degrees off"
        );
        // It flies: its centre is well out from the pole, not hanging down.
        assert!(direction.with_y(0.0).length() > 0.4, "{direction}");
    }
}

#[test]
fn a_flag_in_a_30_m_s_gale_with_gusts_stays_finite_for_10000_steps() {
    let flag = Flag {
        n: 12,
        wind: Vec3::new(30.0, 0.0, 4.0),
        gusts: Gusts {
            strength: 8.0,
            frequency: 1.0,
            ..Gusts::default()
        },
    };
    let mut sim = flag.build();
    let wind = flag.wind_field();
    let settings = Flag::settings();
    let mut worst_speed = 0.0f32;
    for step in 0..10_000 {
        sim.set_wind(&wind, step as f32 * DT);
        sim.step(&settings, GRAVITY, DT).unwrap();
        assert!(sim.is_finite(), "not finite at step {step}");
        let speed = sim
            .state()
            .velocities
            .iter()
            .map(|v| v.length())
            .fold(0.0, f32::max);
        worst_speed = worst_speed.max(speed);
    }
    println!("fastest particle over 10,000 steps: {worst_speed} m/s");
    assert!(worst_speed < 200.0);
    assert!(azimuth_error_degrees(flag.direction(&sim), flag.wind) < 30.0);
}

/// The flag's centroid after 2 s in an App with `setup` run first.
fn flag_in_app(setup: impl FnOnce(&mut App)) -> Vec3 {
    let mut app = app();
    setup(&mut app);
    let flag = Flag {
        n: 10,
        wind: Vec3::ZERO,
        gusts: Gusts::default(),
    };
    let grid = flag.grid();
    let mesh = add_grid(&mut app, &grid);
    let entity = app
        .world_mut()
        .spawn((
            Mesh3d(mesh),
            Cloth::pinned(flag.pins()),
            ClothSettings {
                solver: Flag::settings(),
                density: Flag::DENSITY,
                ..default()
            },
            Transform::default(),
        ))
        .id();
    for _ in 0..130 {
        app.update();
    }
    let simulation = app.world().get::<ClothSimulation>(entity).unwrap();
    let x = &simulation.solver().state().positions;
    x.iter().map(|&p| Vec3::from(p)).sum::<Vec3>() / x.len() as f32
}

#[test]
fn the_wind_resource_and_a_fan_blow_a_cloth_in_an_app() {
    let still = flag_in_app(|_| {});
    let windy = flag_in_app(|app| {
        app.insert_resource(Wind {
            velocity: Vec3::new(0.0, 0.0, 8.0),
            gusts: Gusts::default(),
        });
    });
    // A fan in front of the flag blowing at it along -Z (its forward, unturned).
    let fanned = flag_in_app(|app| {
        app.world_mut().spawn((
            WindSource::fan(10.0, 3.0),
            Transform::from_xyz(0.6, 1.6, 1.0),
        ));
    });
    // A source that is not finite is ignored, with a warning, and the app runs on.
    let broken = flag_in_app(|app| {
        app.world_mut().spawn((
            WindSource {
                speed: f32::NAN,
                ..WindSource::fan(10.0, 3.0)
            },
            Transform::default(),
        ));
    });
    println!("centroid: still {still}, wind +Z {windy}, fan -Z {fanned}, broken {broken}");
    assert!(windy.z - still.z > 0.2, "{windy} against {still}");
    assert!(still.z - fanned.z > 0.1, "{fanned} against {still}");
    assert!((broken - still).length() < 1e-5);
}

#[test]
fn a_cloth_carried_by_the_frame_it_follows_feels_the_air_it_moves_through() {
    use bevy_drape::collide::{FrameStep, RigidPose};
    // The same sheet moving at `u` through still air: simulated in the world, and carried
    // wholly (inertia 0) by a frame moving at `u`, its state at rest relative to the frame.
    // The air's pull must be the same.
    let settings = SolverSettings {
        air: Some(AirSettings::default()),
        ..SolverSettings::default()
    };
    let u = Vec3::new(4.0, 0.0, -3.0);
    let orientation = Quat::from_rotation_z(0.7);
    let mut world = sheet(orientation, 0.1);
    for v in &mut world.state_mut().velocities {
        *v = u.into();
    }
    let mut carried = sheet(orientation, 0.1);
    let start = RigidPose::IDENTITY;
    let frame = FrameStep {
        start,
        end: RigidPose {
            translation: (u * DT).into(),
            ..start
        },
        linear_velocity: u.into(),
        angular_velocity: Vec3A::ZERO,
        jumped: false,
        sweep_start: start,
    };
    carried.follow_frame(&frame, 0.0);
    world.step(&settings, Vec3::ZERO, DT).unwrap();
    carried.step(&settings, Vec3::ZERO, DT).unwrap();
    let world_change = mean_velocity(&world) - u;
    let carried_change = mean_velocity(&carried);
    println!("velocity change: in the world {world_change}, carried {carried_change}");
    assert!(world_change.length() > 0.05);
    assert!(
        (world_change - carried_change).length() < 1e-3 * world_change.length(),
        "{world_change} against {carried_change}"
    );
}
