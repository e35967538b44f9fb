//! Collider contacts against analytic results: restitution, the friction threshold and the
//! sliding acceleration on an incline, a spinning sphere's surface velocity, a fast collider,
//! a triangle mesh as the plane it tiles, static friction's anchor.

use std::sync::Arc;

use bevy::math::{Quat, Vec3, Vec3A};
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverMethod, SolverSettings};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape, TriMesh};
use drape_scenes::scenes::{DENSITY, FRAME_RATE, GRAVITY};

const DT: f32 = 1.0 / FRAME_RATE;

fn particle(at: Vec3) -> ClothSolver {
    ClothSolver::new(ClothModel::from_particles(&[at], &[0.01], &[]).unwrap())
}

fn settings(method: SolverMethod) -> SolverSettings {
    SolverSettings {
        method,
        damping: 0.0,
        thickness: 0.0,
        ..Default::default()
    }
}

fn plane(rotation: Quat, material: ContactMaterial) -> SolverCollider {
    let mut c = SolverCollider::fixed(
        SolverShape::Plane,
        RigidPose {
            translation: Vec3A::ZERO,
            rotation,
        },
    );
    c.material = material;
    c
}

#[test]
fn a_particle_bounces_to_epsilon_squared_times_its_drop_height() {
    let drop = 1.0;
    for method in [SolverMethod::Xpbd, SolverMethod::MassSpring] {
        for restitution in [0.5, 0.8] {
            let mut sim = particle(Vec3::new(0.0, drop, 0.0));
            sim.set_colliders(&[plane(
                Quat::IDENTITY,
                ContactMaterial {
                    friction: 0.5,
                    restitution,
                },
            )])
            .unwrap();
            let settings = settings(method);
            // Fall, bounce once, and record the top of the first rebound.
            let mut bounced = false;
            let mut top = 0.0f32;
            for _ in 0..180 {
                sim.step(&settings, GRAVITY, DT).unwrap();
                let (y, vy) = (sim.state().positions[0].y, sim.state().velocities[0].y);
                if !bounced && vy > 0.0 {
                    bounced = true;
                }
                if bounced {
                    top = top.max(y);
                    if vy < 0.0 && y < 0.5 * top {
                        break;
                    }
                }
            }
            let expected = restitution * restitution * drop;
            let error = (top - expected).abs() / expected;
            println!(
                "{} epsilon {restitution}: rebound {top:.4} m, epsilon^2 h = {expected:.4} m ({:.2}%)",
                method.name(),
                error * 100.0
            );
            assert!(error < 0.05);
        }
    }
}

/// Slides a particle and a small cloth patch on a plane inclined by `angle` with friction
/// `mu` for 1 s; returns the distance each moved down the slope.
fn slide(angle: f32, mu: f32) -> (f32, f32) {
    let rotation = Quat::from_rotation_z(angle);
    let material = ContactMaterial {
        friction: mu,
        restitution: 0.0,
    };
    let settings = settings(SolverMethod::Xpbd);
    let down = rotation * Vec3::NEG_X;
    let start = Vec3::new(0.0, 0.0, 0.0);

    let mut one = particle(start);
    one.set_colliders(&[plane(rotation, material)]).unwrap();

    let grid = GridDesc {
        orientation: rotation,
        ..GridDesc::square(0.1, 4, start)
    };
    let mut patch = ClothSolver::new(ClothModel::grid(&grid, DENSITY).unwrap());
    patch.set_colliders(&[plane(rotation, material)]).unwrap();
    let centre = |sim: &ClothSolver| {
        let x = &sim.state().positions;
        Vec3::from(x.iter().copied().sum::<Vec3A>() / x.len() as f32)
    };
    let (c0, p0) = (centre(&patch), centre(&one));
    for _ in 0..FRAME_RATE as usize {
        one.step(&settings, GRAVITY, DT).unwrap();
        patch.step(&settings, GRAVITY, DT).unwrap();
    }
    (
        (centre(&one) - p0).dot(down),
        (centre(&patch) - c0).dot(down),
    )
}

#[test]
fn on_an_incline_a_particle_and_a_patch_stay_below_the_friction_angle_and_slide_above_it() {
    let mu = 0.5;
    let g = GRAVITY.length();
    for tan in [0.3f32, 0.45] {
        let (particle, patch) = slide(tan.atan(), mu);
        println!("tan {tan}: moved {particle:.2e} m (particle), {patch:.2e} m (patch)");
        assert!(particle.abs() < 1e-4 && patch.abs() < 1e-4);
    }
    for tan in [0.6f32, 0.8, 1.2] {
        let angle = tan.atan();
        let (particle, patch) = slide(angle, mu);
        let expected = g * (angle.sin() - mu * angle.cos());
        for (what, s) in [("particle", particle), ("patch", patch)] {
            // s = a t^2 / 2 at t = 1 s.
            let a = 2.0 * s;
            let error = (a - expected).abs() / expected;
            println!(
                "tan {tan}: {what} slides at {a:.4} m/s^2, g (sin - mu cos) = {expected:.4} ({:.2}%)",
                error * 100.0
            );
            assert!(error < 0.05);
        }
    }
}

#[test]
fn a_spinning_sphere_carries_a_particle_resting_on_top_along_omega_cross_r() {
    let radius = 0.5;
    let omega = Vec3A::new(0.0, 0.0, -2.0);
    let mut sphere = SolverCollider::fixed(SolverShape::Sphere { radius }, RigidPose::IDENTITY);
    sphere.angular_velocity = omega;
    sphere.material.friction = 0.8;
    let top = Vec3A::new(0.0, radius, 0.0);
    let expected = omega.cross(top).normalize();
    let mut sim = particle(top.into());
    sim.set_colliders(&[sphere]).unwrap();
    let settings = settings(SolverMethod::Xpbd);
    for _ in 0..6 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    let p = sim.state().positions[0];
    let v = sim.state().velocities[0];
    println!("after 0.1 s: at {p}, velocity {v}, omega x r direction {expected}");
    assert!(p.dot(expected) > 0.02, "carried along omega x r");
    assert!(v.normalize().dot(expected) > 0.99);
    // Until it reaches the surface speed |omega| r = 1 m/s, kinetic friction accelerates it at
    // mu g.
    let analytic = 0.8 * GRAVITY.length() * 0.1;
    let error = (v.length() - analytic).abs() / analytic;
    println!(
        "speed {:.4} m/s, mu g t = {analytic:.4} m/s ({:.2}%)",
        v.length(),
        error * 100.0
    );
    assert!(error < 0.05);
}

#[test]
fn a_fast_collider_leaves_no_particle_inside_it() {
    let radius = 0.3;
    let per_step = 0.5;
    let grid = GridDesc::square(1.0, 24, Vec3::new(0.0, 0.3, 0.0));
    let mut sim = ClothSolver::new(ClothModel::grid(&grid, DENSITY).unwrap());
    sim.set_pins(&[grid.index(0, 0), grid.index(23, 0)])
        .unwrap();
    let settings = SolverSettings::default();
    let mut deepest = 0.0f32;
    let mut contacts = 0;
    for step in 0..8 {
        // Sweeps through the sheet along x, 0.5 m per fixed step (30 m/s).
        let start = Vec3A::new(-0.6 + per_step * step as f32, 0.3, 0.5);
        let end = start + Vec3A::X * per_step;
        let mut sphere = SolverCollider::fixed(
            SolverShape::Sphere { radius },
            RigidPose {
                translation: start,
                rotation: Quat::IDENTITY,
            },
        );
        sphere.end.translation = end;
        sphere.linear_velocity = Vec3A::X * per_step / DT;
        sim.set_colliders(std::slice::from_ref(&sphere)).unwrap();
        sim.step(&settings, Vec3::ZERO, DT).unwrap();
        contacts += sim.contact_count();
        for &p in &sim.state().positions {
            if let Some(d) = sphere.signed_distance(p, 0.0) {
                deepest = deepest.max(-d);
            }
        }
        assert!(sim.is_finite());
    }
    println!("deepest inside the moving sphere: {deepest:.2e} m, {contacts} contacts");
    assert!(contacts > 0);
    assert!(deepest <= 1e-5);
}

#[test]
fn a_triangle_mesh_collider_holds_a_particle_like_the_plane_it_tiles() {
    // A flat square of two triangles facing up, 1 m across.
    let v = [
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
    ];
    let mesh = Arc::new(TriMesh::new(&v, &[0, 1, 2, 0, 2, 3]).unwrap());
    let mut sim = particle(Vec3::new(0.1, 0.5, 0.2));
    let mut floor = SolverCollider::fixed(SolverShape::TriangleMesh(mesh), RigidPose::IDENTITY);
    floor.margin = 0.01;
    sim.set_colliders(&[floor]).unwrap();
    for _ in 0..120 {
        sim.step(&settings(SolverMethod::Xpbd), GRAVITY, DT)
            .unwrap();
    }
    let p = sim.state().positions[0];
    println!("resting on the mesh at {p}");
    assert!((p.y - 0.01).abs() < 1e-4);
}

/// Static friction holds a particle at its anchor, the point on the collider where friction
/// last held it; a particle moved by hand (`ClothSolver::state_mut`) or carried with a reset
/// starts afresh where it is put, and is not pulled back towards where it rested before.
#[test]
fn a_resting_particle_moved_by_hand_rests_where_it_is_put() {
    let plane = SolverCollider::fixed(SolverShape::Plane, RigidPose::IDENTITY);
    for method in [SolverMethod::Xpbd, SolverMethod::Pbd { stiffness: 1.0 }] {
        let reach = plane.margin + settings(method).thickness;
        let mut sim = particle(Vec3::new(0.3, reach, -0.2));
        sim.set_colliders(std::slice::from_ref(&plane)).unwrap();
        let settings = settings(method);
        for _ in 0..30 {
            sim.step(&settings, GRAVITY, DT).unwrap();
        }
        let rested = sim.state().positions[0];
        let put = Vec3A::new(-0.7, rested.y, 0.4);
        let state = sim.state_mut();
        state.positions[0] = put;
        state.velocities[0] = Vec3A::ZERO;
        for _ in 0..30 {
            sim.step(&settings, GRAVITY, DT).unwrap();
        }
        let now = sim.state().positions[0];
        println!(
            "{}: rested at {rested}, put at {put}, now at {now}",
            method.name()
        );
        assert!(
            (now - put).length() < 1e-5,
            "{}: moved to {now}",
            method.name()
        );
    }
}
