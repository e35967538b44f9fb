//! The cloth core's model and input, without an App: masses and edges built from meshes,
//! shear edges found in any quad pattern, typed errors for bad input, pins moved, set and
//! released.

use crate::common;

use bevy::math::{Vec3, Vec3A};
use bevy_drape::cloth::{
    ClothModel, ClothSolver, EdgeKind, GridDesc, SolverMethod, SolverSettings,
};
use bevy_drape::error::{ClothError, ClothWarning};
use common::{Rng, free_grid};
use drape_scenes::scenes::{GRAVITY, HangingCloth};

const DT: f32 = 1.0 / 60.0;

#[test]
fn mesh_cloth_mass_is_density_times_area() {
    // A non-uniform mesh: a quad split unevenly plus a far triangle.
    let positions = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 1.0),
        Vec3::new(0.3, 0.0, 1.0),
        Vec3::new(3.0, 1.0, 0.5),
    ];
    let indices = [0, 3, 2, 0, 2, 1, 1, 2, 4];
    let model = ClothModel::from_triangles(&positions, &indices, 0.25).unwrap();
    let area = 0.5 * (2.0 * 1.0 + 1.7 * 1.0)
        + 0.5
            * (positions[2] - positions[1])
                .cross(positions[4] - positions[1])
                .length();
    assert!(
        (model.area() - area).abs() < 1e-5,
        "{} vs {area}",
        model.area()
    );
    assert!((model.total_mass() - 0.25 * area).abs() < 1e-6);
    // Edges are de-duplicated and bending pairs found once.
    assert_eq!(model.edges.len(), 7);
    assert_eq!(model.bending_pairs.len(), 2);
}

#[test]
fn grid_edges_are_tagged_and_counted() {
    let n = 5;
    let model = ClothModel::grid(&GridDesc::square(1.0, n, Vec3::ZERO), 0.1).unwrap();
    let structural = model
        .edges
        .iter()
        .filter(|e| e.kind == EdgeKind::Structural)
        .count();
    let shear = model.edges.len() - structural;
    assert_eq!(structural as u32, 2 * n * (n - 1));
    assert_eq!(shear as u32, (n - 1) * (n - 1));
    // Interior edges: every edge but the 4 (n - 1) boundary ones.
    assert_eq!(
        model.bending_pairs.len(),
        model.edges.len() - 4 * (n as usize - 1)
    );
    for pair in &model.bending_pairs {
        assert!(pair.rest_angle.abs() < 1e-6);
    }
}

/// Quad patterns of random size and cell shape, each quad cut along a random diagonal, their
/// vertices shuffled (so no grid is recognised) and the whole turned at random: exactly the
/// diagonals are shear edges. A mesh of equilateral triangles has none.
#[test]
fn the_diagonals_of_any_quad_pattern_are_its_shear_edges() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    for case in 0..4 {
        let (nx, nz) = (
            3 + (rng.uniform() * 5.0) as usize,
            3 + (rng.uniform() * 5.0) as usize,
        );
        let (dx, dz) = (0.05 + 0.25 * rng.uniform(), 0.05 + 0.25 * rng.uniform());
        let turn = bevy::math::Quat::from_euler(
            bevy::math::EulerRot::XYZ,
            rng.uniform() * 6.0,
            rng.uniform() * 6.0,
            rng.uniform() * 6.0,
        );
        // A random permutation of the vertices.
        let mut order: Vec<usize> = (0..nx * nz).collect();
        rng.shuffle(&mut order);
        let mut positions = vec![Vec3::ZERO; nx * nz];
        for j in 0..nz {
            for i in 0..nx {
                positions[order[j * nx + i]] = turn * Vec3::new(i as f32 * dx, 0.0, j as f32 * dz);
            }
        }
        let mut indices = Vec::new();
        for j in 0..nz - 1 {
            for i in 0..nx - 1 {
                let [a, b, c, d] = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                    .map(|(i, j)| order[j * nx + i] as u32);
                if rng.uniform() < 0.5 {
                    indices.extend([a, b, c, a, c, d]);
                } else {
                    indices.extend([a, b, d, b, c, d]);
                }
            }
        }
        let model = ClothModel::from_triangles(&positions, &indices, 0.2).unwrap();
        assert_eq!(model.grid, None, "case {case}");
        let diagonal = (dx * dx + dz * dz).sqrt();
        let shear: Vec<_> = model
            .edges
            .iter()
            .filter(|e| e.kind == EdgeKind::Shear)
            .collect();
        assert_eq!(shear.len(), (nx - 1) * (nz - 1), "case {case}");
        for edge in &model.edges {
            let expected = if edge.kind == EdgeKind::Shear {
                diagonal
            } else if (edge.rest_length - dx).abs() < (edge.rest_length - dz).abs() {
                dx
            } else {
                dz
            };
            assert!(
                (edge.rest_length - expected).abs() < 1e-4,
                "case {case}: a {:?} edge of {} m",
                edge.kind,
                edge.rest_length
            );
        }
    }

    // Equilateral triangles in strips.
    let (rows, cols) = (4, 6);
    let h = 3f32.sqrt() / 2.0;
    let positions: Vec<Vec3> = (0..rows)
        .flat_map(|j| {
            (0..cols)
                .map(move |i| Vec3::new(i as f32 + 0.5 * (j % 2) as f32, 0.0, j as f32 * h) * 0.1)
        })
        .collect();
    let mut indices = Vec::new();
    for j in 0..rows - 1 {
        for i in 0..cols - 1 {
            let v = |i: usize, j: usize| (j * cols + i) as u32;
            if j % 2 == 0 {
                indices.extend([v(i, j), v(i + 1, j), v(i, j + 1)]);
                indices.extend([v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
            } else {
                indices.extend([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
                indices.extend([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            }
        }
    }
    let model = ClothModel::from_triangles(&positions, &indices, 0.2).unwrap();
    assert!(model.edges.iter().all(|e| e.kind == EdgeKind::Structural));
}

#[test]
fn bad_input_gives_typed_errors_and_warnings() {
    let quad = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, 1.0), Vec3::Z];
    let ok = [0, 3, 2, 0, 2, 1];
    assert_eq!(
        ClothModel::from_triangles(&quad, &[], 0.1).unwrap_err(),
        ClothError::NoTriangles
    );
    let mut nan = quad;
    nan[2].y = f32::NAN;
    assert_eq!(
        ClothModel::from_triangles(&nan, &ok, 0.1).unwrap_err(),
        ClothError::NonFinitePosition { vertex: 2 }
    );
    assert_eq!(
        ClothModel::from_triangles(&quad, &ok, -1.0).unwrap_err(),
        ClothError::InvalidDensity(-1.0)
    );
    assert_eq!(
        ClothModel::from_triangles(&quad, &[0, 1, 7], 0.1).unwrap_err(),
        ClothError::IndexOutOfRange {
            index: 7,
            vertex_count: 4
        }
    );
    assert_eq!(
        ClothModel::from_triangles(&quad, &[0, 1], 0.1).unwrap_err(),
        ClothError::IndexCountNotTriangles(2)
    );
    // A zero-area triangle is dropped with a warning; the rest is built.
    let collinear = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::Z];
    let model = ClothModel::from_triangles(&collinear, &[0, 1, 2, 0, 3, 1], 0.1).unwrap();
    assert_eq!(model.triangles.len(), 1);
    assert!(
        model
            .warnings
            .contains(&ClothWarning::DegenerateTriangle { triangle: 0 })
    );
    // Only zero-area triangles: no cloth.
    assert_eq!(
        ClothModel::from_triangles(&collinear, &[0, 1, 2], 0.1).unwrap_err(),
        ClothError::NoTriangles
    );
    // Pins out of range.
    let mut sim = ClothSolver::new(ClothModel::from_triangles(&quad, &ok, 0.1).unwrap());
    assert!(matches!(
        sim.set_pins(&[9]),
        Err(ClothError::VertexOutOfRange { vertex: 9, .. })
    ));
    // A NaN pin target is refused.
    sim.set_pins(&[0]).unwrap();
    assert!(!sim.set_pin_target(0, Vec3::NAN));
    // Settings out of range.
    let bad = SolverSettings {
        substeps: 0,
        ..Default::default()
    };
    assert!(bad.validate().is_err());
    let one_sweep = SolverSettings {
        iterations: 1,
        ..Default::default()
    };
    assert!(matches!(
        one_sweep.validate(),
        Err(ClothError::InvalidSetting {
            name: "iterations",
            ..
        })
    ));
    let one_sweep_no_long_range = SolverSettings {
        long_range_attachments: false,
        ..one_sweep
    };
    assert!(one_sweep_no_long_range.validate().is_ok());
    // The panel's iterations slider starts at `fewest_iterations`: for every method, with and
    // without the long-range attachments, that many validate and one fewer is refused.
    for method in [
        SolverMethod::Xpbd,
        SolverMethod::Pbd { stiffness: 1.0 },
        SolverMethod::MassSpring,
        SolverMethod::Hybrid { long_range: false },
        SolverMethod::Hybrid { long_range: true },
    ] {
        for long_range_attachments in [false, true] {
            let mut settings = SolverSettings {
                method,
                long_range_attachments,
                ..Default::default()
            };
            settings.iterations = settings.fewest_iterations();
            assert!(settings.validate().is_ok(), "{settings:?}");
            settings.iterations -= 1;
            assert!(settings.validate().is_err(), "{settings:?}");
        }
    }
    // An exact edge solve without a step or an iteration is refused, and the step with it
    // leaves the cloth as it was.
    let no_solve = SolverSettings {
        exact_edges: Some(bevy_drape::cloth::ExactEdges {
            newton_steps: 1,
            cg_iterations: 0,
            ..Default::default()
        }),
        ..Default::default()
    };
    assert!(matches!(
        no_solve.validate(),
        Err(ClothError::InvalidSetting {
            name: "exact_edges",
            ..
        })
    ));
    let before = sim.state().positions.clone();
    assert!(sim.step(&no_solve, Vec3::NEG_Y, 1.0 / 60.0).is_err());
    assert_eq!(sim.state().positions, before);
    // So is a closing tolerance that is not a finite distance of at least zero.
    for tolerance in [f32::NAN, f32::INFINITY, -0.001] {
        let bad_tolerance = SolverSettings {
            exact_edges: Some(bevy_drape::cloth::ExactEdges {
                closing_tolerance: tolerance,
                ..Default::default()
            }),
            ..Default::default()
        };
        assert!(matches!(
            bad_tolerance.validate(),
            Err(ClothError::InvalidSetting {
                name: "exact_edges.closing_tolerance",
                ..
            })
        ));
        assert!(sim.step(&bad_tolerance, Vec3::NEG_Y, 1.0 / 60.0).is_err());
        assert_eq!(sim.state().positions, before);
    }
}

#[test]
fn the_core_refuses_bad_input_and_never_writes_a_non_finite_state() {
    use bevy_drape::collide::{RigidPose, SolverCollider, SolverShape};
    // Settings with one field made bad at random, gravity and steps that are not finite: each
    // step either runs and leaves a finite state, or is refused with an error and changes
    // nothing.
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0];
    let mut rng = Rng(23);
    let mut sim = HangingCloth { n: 8 }.build();
    let (mut refused, mut stepped) = (0, 0);
    for _ in 0..400 {
        let mut settings = SolverSettings::default();
        let mut gravity = GRAVITY;
        let mut dt = DT;
        let value = bad[rng.below(bad.len())];
        match rng.below(8) {
            0 => settings.stretch_compliance = value,
            1 => settings.bend_compliance = value,
            2 => settings.damping = value,
            3 => settings.friction = value,
            4 => settings.thickness = value,
            5 => gravity.y = value,
            6 => dt = value,
            _ => {}
        }
        let before = sim.state().clone();
        match sim.step(&settings, gravity, dt) {
            Ok(()) => {
                stepped += 1;
                assert!(sim.is_finite());
            }
            Err(err) => {
                refused += 1;
                assert!(matches!(err, ClothError::InvalidSetting { .. }), "{err}");
                assert_eq!(sim.state().positions, before.positions);
                assert_eq!(sim.state().velocities, before.velocities);
            }
        }
    }
    println!("{stepped} steps run, {refused} refused");
    assert!(stepped > 0 && refused > 0);
    assert_eq!(sim.step(&SolverSettings::default(), GRAVITY, 0.0), Ok(()));

    // A collider with a non-finite velocity or pose is left out with an error; the valid one
    // next to it is kept and the cloth steps on.
    let ground = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
    let mut spinning = SolverCollider::fixed(
        SolverShape::Sphere { radius: 0.2 },
        RigidPose {
            translation: Vec3A::new(0.5, 0.5, 0.5),
            ..RigidPose::IDENTITY
        },
    );
    spinning.angular_velocity = Vec3A::new(0.0, f32::NAN, 0.0);
    assert!(sim.set_colliders(&[ground.clone(), spinning]).is_err());
    assert_eq!(sim.colliders(), &[ground]);
    for _ in 0..60 {
        sim.step(&SolverSettings::default(), GRAVITY, DT).unwrap();
    }
    assert!(sim.is_finite());
}

#[test]
fn moving_pins_drag_the_cloth_and_reset_restores_the_start() {
    let scene = HangingCloth { n: 8 };
    let mut sim = scene.build();
    let start = sim.state().clone();
    let settings = SolverSettings::default();
    for frame in 1..=60 {
        for pin in scene.pins() {
            let rest = sim.model().rest_positions[pin as usize];
            sim.set_pin_target(pin, rest + Vec3::X * (frame as f32 * 0.01));
        }
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    for pin in scene.pins() {
        let rest = sim.model().rest_positions[pin as usize];
        let now = Vec3::from(sim.state().positions[pin as usize]);
        assert!(now.distance(rest + Vec3::X * 0.6) < 1e-5);
    }
    let com = sim.rigid_motion().unwrap().center_of_mass;
    assert!(com.x > 0.5 + 0.3, "the cloth followed its pins: {com}");
    sim.reset();
    assert_eq!(sim.state(), &start);
}

#[test]
fn pins_set_or_released_between_steps_hold_or_let_go() {
    // The solver keeps per-step copies of the inverse masses; changing the pins between steps
    // must reach every constraint.
    let mut sim = free_grid(8);
    let settings = SolverSettings::default();
    for _ in 0..10 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let corner = 0;
    sim.set_pins(&[corner]).unwrap();
    let held = sim.state().positions[corner as usize];
    for _ in 0..60 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    assert_eq!(sim.state().positions[corner as usize], held);
    // The rest of the cloth hangs below the corner, not falling away.
    let com = sim.rigid_motion().unwrap().center_of_mass;
    assert!(com.y < held.y && held.y - com.y < 1.0, "{com} below {held}");
    assert!(sim.strain().max < 0.05, "{:?}", sim.strain());
    // Released, the corner falls with the rest.
    sim.set_pins(&[]).unwrap();
    for _ in 0..30 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let fell = held.y - sim.state().positions[corner as usize].y;
    let free_fall = 0.5 * GRAVITY.length() * (30.0 * DT).powi(2);
    assert!(fell > 0.5 * free_fall, "fell {fell} m");
}

#[test]
fn finite_but_extreme_input_is_refused_and_the_state_stays_finite() {
    use bevy_drape::cloth::{MAX_SPEED_CHANGE, MAX_STEP};
    use bevy_drape::collide::{MAX_COORDINATE, RigidPose, SolverCollider, SolverShape};
    use bevy_drape::error::ColliderError;
    // Gravity, steps, pin targets and colliders drawn from every magnitude up to f32::MAX:
    // each step runs and leaves a finite state, or the input is refused and changes nothing.
    let scene = HangingCloth { n: 8 };
    let mut sim = scene.build();
    let pin = scene.pins()[0];
    let mut rng = Rng(29);
    let magnitude = |rng: &mut Rng| {
        let sign = if rng.below(2) == 0 { -1.0 } else { 1.0 };
        sign * 10f32.powf(rng.range(-3.0, 38.5)).min(f32::MAX)
    };
    let (mut refused, mut stepped) = (0, 0);
    for _ in 0..400 {
        let mut gravity = GRAVITY;
        let mut dt = DT;
        let value = magnitude(&mut rng);
        let before = sim.state().clone();
        let mut accepted = true;
        match rng.below(4) {
            0 => gravity = Vec3::new(0.0, value, 0.0),
            1 => dt = value.abs(),
            2 => {
                let target = Vec3::new(value, 1.0, 0.0);
                accepted = sim.set_pin_target(pin, target);
                assert_eq!(
                    accepted,
                    value.abs() <= MAX_COORDINATE,
                    "pin target {value}"
                );
            }
            _ => {
                let far = SolverCollider::fixed(
                    SolverShape::Sphere { radius: 0.2 },
                    RigidPose {
                        translation: Vec3A::new(0.0, value, 0.0),
                        ..RigidPose::IDENTITY
                    },
                );
                let result = sim.set_colliders(&[far]);
                accepted = result.is_ok();
                if !accepted {
                    assert_eq!(result, Err(ColliderError::PoseOutOfRange));
                    assert!(value.abs() > MAX_COORDINATE);
                }
            }
        }
        match sim.step(&SolverSettings::default(), gravity, dt) {
            Ok(()) => {
                stepped += 1;
                assert!(sim.is_finite(), "gravity {gravity}, dt {dt}");
            }
            Err(err) => {
                refused += 1;
                assert!(matches!(err, ClothError::InvalidSetting { .. }), "{err}");
                let speed_change = gravity.length() * dt;
                assert!(speed_change > MAX_SPEED_CHANGE || dt > MAX_STEP, "{err}");
                assert_eq!(sim.state().positions, before.positions);
                assert_eq!(sim.state().velocities, before.velocities);
            }
        }
        if !accepted {
            refused += 1;
        }
        // Back home for the next draw.
        sim.set_pin_target(pin, sim.model().rest_positions[pin as usize]);
        sim.set_colliders(&[]).unwrap();
        if rng.below(20) == 0 {
            sim.reset();
        }
    }
    println!("{stepped} steps run, {refused} inputs refused");
    assert!(stepped > 100 && refused > 100);
    // Gravity 1e30 in particular.
    let before = sim.state().clone();
    assert!(
        sim.step(&SolverSettings::default(), Vec3::new(0.0, -1e30, 0.0), DT)
            .is_err()
    );
    assert_eq!(sim.state(), &before);
}
