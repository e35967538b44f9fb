//! Random sheets on colliders: far colliders change nothing, the exact edges act only in
//! contact, a collider thinner than the edges does not pass between two particles, an undone
//! adaptive step leaves no trace in the contacts.

use crate::common;

use bevy::math::{Quat, Vec2, Vec3, Vec3A};
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverMethod, SolverSettings};
use bevy_drape::collide::{RigidPose, SolverCollider, SolverShape};
use common::Rng;
use drape_scenes::scenes::{DENSITY, FRAME_RATE, GRAVITY};

const DT: f32 = 1.0 / FRAME_RATE;

/// A crowd's other characters: colliders whose swept bounds never meet the cloth's are left
/// out before any particle is looked at, so they change nothing, bit for bit, while near ones
/// (one resting, one sweeping in from 2 m away within a step) are met as before.
#[test]
fn colliders_far_from_the_cloth_change_nothing() {
    let mut rng = Rng(0x5eed_c0de);
    for case in 0..4 {
        let n = 10 + 4 * case;
        let grid = GridDesc::square(1.0, n, Vec3::new(-0.5, 0.8, -0.5));
        let model = ClothModel::grid(&grid, DENSITY).unwrap();
        let pose = |x: f32, y: f32, z: f32, turn: f32| RigidPose {
            translation: Vec3A::new(x, y, z),
            rotation: Quat::from_rotation_z(turn),
        };
        let resting = SolverCollider::fixed(
            SolverShape::Sphere { radius: 0.3 },
            pose(0.0, 0.3, 0.0, 0.0),
        );
        // Far away at the start of the step, through the sheet's corner by its end.
        // Wider than the sheet's triangles, so that its particles (not only its edges, see
        // `a_collider_thinner_than_the_edges_does_not_pass_between_two_particles`) touch it.
        let mut sweeping = SolverCollider::fixed(
            SolverShape::Capsule {
                radius: 0.1,
                half_length: 0.2,
            },
            pose(2.3, 0.79, 0.3, rng.range(0.0, 3.0)),
        );
        sweeping.end.translation = Vec3A::new(0.3, 0.79, 0.3);
        sweeping.linear_velocity = (sweeping.end.translation - sweeping.start.translation) / DT;
        let near = vec![resting, sweeping];
        let mut crowd = Vec::new();
        for _ in 0..40 {
            // At least 3 m from the sheet in x or z, at random heights, sizes and turns.
            let side = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
            let (a, b) = (side * rng.range(3.5, 20.0), rng.range(-20.0, 20.0));
            let (x, z) = if rng.uniform() < 0.5 { (a, b) } else { (b, a) };
            let shape = if rng.uniform() < 0.5 {
                SolverShape::Sphere {
                    radius: rng.range(0.05, 0.5),
                }
            } else {
                SolverShape::Capsule {
                    radius: rng.range(0.03, 0.2),
                    half_length: rng.range(0.05, 0.5),
                }
            };
            let (y, turn) = (rng.range(0.0, 2.0), rng.range(0.0, 3.0));
            crowd.push(SolverCollider::fixed(shape, pose(x, y, z, turn)));
        }
        // The crowd first, so that the near colliders' indices differ between the runs.
        let with_crowd: Vec<SolverCollider> = crowd.iter().chain(&near).cloned().collect();
        let settings = SolverSettings::default();
        let run = |colliders: &[SolverCollider]| {
            let mut sim = ClothSolver::new(model.clone());
            let mut contacts = 0;
            for step in 0..40 {
                // The capsule sweeps in on the third step only and stays in the sheet after.
                let mut colliders = colliders.to_vec();
                if step != 2 {
                    let last = colliders.last_mut().unwrap();
                    let at = if step < 2 { last.start } else { last.end };
                    *last = SolverCollider::fixed(last.shape.clone(), at);
                }
                sim.set_colliders(&colliders).unwrap();
                sim.step(&settings, GRAVITY, DT).unwrap();
                contacts += sim.contact_count();
                if step == 2 {
                    // The capsule that swept in from 2 m away holds the sheet, nothing inside.
                    let capsule = colliders.last().unwrap();
                    let d: Vec<f32> = sim
                        .state()
                        .positions
                        .iter()
                        .filter_map(|&p| capsule.signed_distance(p, 0.05))
                        .collect();
                    let touching = d.iter().filter(|&&d| d < 0.02).count();
                    let deepest = d.iter().fold(0.0f32, |m, &d| m.max(-d));
                    assert!(touching > 0 && deepest <= 1e-5, "{touching} {deepest}");
                }
            }
            (sim, contacts)
        };
        let (alone, contacts) = run(&near);
        let (among, _) = run(&with_crowd);
        assert!(contacts > 0, "case {case}: the near colliders were met");
        assert_eq!(
            alone.state().positions,
            among.state().positions,
            "case {case}: the far colliders changed the cloth"
        );
        assert_eq!(alone.state().velocities, among.state().velocities);
    }
}

/// The structural edges are solved exactly (`SolverSettings::exact_edges`, on by default) only
/// in the substeps in which the cloth touches a collider: random sheets hanging from two
/// corners, with no collider or with one they never reach, step bit for bit as without the
/// exact edges (the long-range attachments hold them, at no extra cost); the same sheets
/// dropped onto a sphere do not, and end with their edges nearer their rest lengths, unless
/// their edges are meant to stretch (a compliance above zero, or PBD below stiffness 1).
#[test]
fn exact_edges_act_only_while_the_cloth_touches_a_collider() {
    let mut rng = Rng(0xe8ac_7ed9);
    for case in 0..4 {
        let n = 6 + (rng.uniform() * 14.0) as u32;
        let size = rng.range(0.4, 1.2);
        let grid = GridDesc::square(size, n, Vec3::new(-size / 2.0, 1.0, -size / 2.0));
        let model = ClothModel::grid(&grid, rng.range(0.05, 0.4)).unwrap();
        let with = SolverSettings::default();
        let without = SolverSettings {
            exact_edges: None,
            ..with
        };
        assert!(with.exact_edges.is_some());
        let far = SolverCollider::fixed(
            SolverShape::Sphere { radius: 0.3 },
            RigidPose {
                translation: Vec3A::new(0.0, -5.0, 0.0),
                rotation: Quat::IDENTITY,
            },
        );
        let under = SolverCollider::fixed(
            SolverShape::Sphere {
                radius: rng.range(0.15, 0.3),
            },
            RigidPose {
                translation: Vec3A::new(rng.range(-0.05, 0.05), 0.5, rng.range(-0.05, 0.05)),
                rotation: Quat::IDENTITY,
            },
        );
        let run = |settings: &SolverSettings, colliders: &[SolverCollider], pinned: bool| {
            let mut sim = ClothSolver::new(model.clone());
            if pinned {
                sim.set_pins(&[0, n - 1]).unwrap();
            }
            sim.set_colliders(colliders).unwrap();
            let mut contacts = 0;
            for _ in 0..90 {
                sim.step(settings, GRAVITY, DT).unwrap();
                contacts += sim.contact_count();
            }
            assert!(sim.is_finite());
            (sim, contacts)
        };
        for colliders in [&[][..], std::slice::from_ref(&far)] {
            let (a, contacts) = run(&with, colliders, true);
            let (b, _) = run(&without, colliders, true);
            assert_eq!(contacts, 0);
            assert_eq!(a.state().positions, b.state().positions, "case {case}");
            assert_eq!(a.state().velocities, b.state().velocities, "case {case}");
        }
        for soft in [
            SolverSettings {
                stretch_compliance: 1e-3,
                ..with
            },
            SolverSettings {
                method: SolverMethod::Pbd { stiffness: 0.5 },
                ..with
            },
        ] {
            let soft_without = SolverSettings {
                exact_edges: None,
                ..soft
            };
            let (a, contacts) = run(&soft, std::slice::from_ref(&under), false);
            let (b, _) = run(&soft_without, std::slice::from_ref(&under), false);
            assert!(contacts > 0, "case {case}: the sheet missed the sphere");
            assert_eq!(a.state().positions, b.state().positions, "case {case}");
        }
        let (a, contacts) = run(&with, std::slice::from_ref(&under), false);
        let (b, _) = run(&without, std::slice::from_ref(&under), false);
        assert!(contacts > 0, "case {case}: the sheet missed the sphere");
        let strain = |sim: &ClothSolver| sim.edge_strains().fold(0.0f32, f32::max);
        eprintln!(
            "case {case}: {n} x {n}, {size:.2} m: largest strain at the end {:.5} with the \
             exact edges, {:.5} without",
            strain(&a),
            strain(&b)
        );
        assert!(strain(&a) < strain(&b), "case {case}");
    }
}

/// A sphere or a capsule thinner than the cloth's edges, under the middle of one of its
/// triangles (the longest edge's midpoint, at least 0.63 edge lengths from every particle, so
/// that the particle contacts alone let it through): a falling sheet of random size and
/// resolution is caught by that edge and rests on it, every edge kept outside the collider
/// throughout, rather than falling past it with the collider between two of its particles.
#[test]
fn a_collider_thinner_than_the_edges_does_not_pass_between_two_particles() {
    let mut rng = Rng(0x7b1d_5eed);
    for case in 0..6 {
        // An even number of particles a side: the sheet's centre is the middle of a cell's
        // diagonal, where the sheet balances on the collider.
        let n = 6 + 2 * (rng.uniform() * 3.0) as u32;
        let size = rng.range(0.8, 1.2);
        let spacing = size / (n - 1) as f32;
        let grid = GridDesc::square(size, n, Vec3::new(-size / 2.0, 1.0, -size / 2.0));
        let model = ClothModel::grid(&grid, DENSITY).unwrap();
        // The triangle nearest the sheet's centre, and the midpoint of its longest edge.
        let x = &model.rest_positions;
        let centre = Vec3::new(0.0, 1.0, 0.0);
        let triangle = model
            .triangles
            .iter()
            .min_by(|a, b| {
                let d = |t: &[u32; 3]| {
                    (t.iter().map(|&i| x[i as usize]).sum::<Vec3>() / 3.0).distance(centre)
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        let [a, b] = [0, 1, 2]
            .map(|k| [triangle[k], triangle[(k + 1) % 3]])
            .into_iter()
            .max_by(|p, q| {
                let l = |e: &[u32; 2]| x[e[0] as usize].distance(x[e[1] as usize]);
                l(p).total_cmp(&l(q))
            })
            .unwrap();
        let middle = (x[a as usize] + x[b as usize]) / 2.0;
        let radius = rng.range(0.25, 0.35) * spacing;
        let top = middle
            + Vec3::new(
                rng.range(-0.05, 0.05) * spacing,
                -0.1,
                rng.range(-0.05, 0.05) * spacing,
            );
        let settings = SolverSettings::default();
        let reach = settings.thickness;
        let nearest = x
            .iter()
            .map(|p| p.distance(middle))
            .fold(f32::MAX, f32::min);
        assert!(nearest > 0.6 * spacing && radius + reach + 0.1 * spacing < nearest);
        let (shape, pose) = if case % 2 == 0 {
            let pose = RigidPose {
                translation: Vec3A::from(top - Vec3::Y * radius),
                rotation: Quat::IDENTITY,
            };
            (SolverShape::Sphere { radius }, pose)
        } else {
            // Standing, tilted up to 20 degrees, its upper end under the sheet.
            let half_length = rng.range(0.05, 0.3);
            let rotation = Quat::from_axis_angle(
                Vec3::new(rng.range(-1.0, 1.0), 0.0, rng.range(-1.0, 1.0)).normalize(),
                rng.range(0.0, 0.35),
            );
            let axis = rotation * Vec3::Y;
            let pose = RigidPose {
                translation: Vec3A::from(top - Vec3::Y * radius - axis * half_length),
                rotation,
            };
            let shape = SolverShape::Capsule {
                radius,
                half_length,
            };
            (shape, pose)
        };
        let collider = SolverCollider::fixed(shape.clone(), pose);
        // The collider's core as a segment, for the distance of every edge to it.
        let half = match shape {
            SolverShape::Capsule { half_length, .. } => half_length,
            _ => 0.0,
        };
        let axis = Vec3::from(pose.rotation * Vec3A::Y);
        let core = |t: f32| Vec3::from(pose.translation) + axis * t;
        let mut sim = ClothSolver::new(model.clone());
        sim.set_colliders(std::slice::from_ref(&collider)).unwrap();
        let mut closest_edge = f32::MAX;
        let mut held = f32::MIN;
        for step in 0..60 {
            sim.step(&settings, GRAVITY, DT).unwrap();
            assert!(sim.is_finite(), "case {case}");
            let p = &sim.state().positions;
            if step == 30 {
                held = p.iter().map(|p| p.y).fold(f32::MIN, f32::max);
            }
            for edge in &model.edges {
                let (e0, e1) = (
                    Vec3::from(p[edge.particles[0] as usize]),
                    Vec3::from(p[edge.particles[1] as usize]),
                );
                // Distance of the segment to the core by a dense search along it.
                for k in 0..=64 {
                    let q = e0.lerp(e1, k as f32 / 64.0);
                    let t = (q - core(0.0)).dot(axis).clamp(-half, half);
                    closest_edge = closest_edge.min(q.distance(core(t)) - radius);
                }
            }
        }
        eprintln!(
            "case {case}: {n} x {n}, edges {spacing:.3} m, {} of radius {radius:.3}: highest \
             particle after 0.5 s {held:.3} m (top of the collider {:.3} m), nearest edge \
             {closest_edge:.5} m outside it",
            if case % 2 == 0 { "sphere" } else { "capsule" },
            top.y,
        );
        // Caught, the edge's ends a little below the top: a sheet that falls through is over
        // a metre below it by then (a caught one may tip over and slide off later, as a sheet
        // balanced on a point does).
        assert!(
            held > top.y - 0.1,
            "case {case}: the sheet fell past the collider"
        );
        assert!(
            closest_edge > -1e-3,
            "case {case}: an edge passed through the collider"
        );
        let strain = sim.edge_strains().fold(0.0f32, f32::max);
        assert!(strain < 0.02, "case {case}: {strain}");
    }
}

/// A step the adaptive budget undoes and runs again is the step it would have been at the
/// count it ends with: friction's anchors, which move with the collider's surface in every
/// substep, are undone with the positions. A cloth of random size rests on a capsule that
/// slides and turns at random speeds; a budget whose target no step meets runs every step at
/// 1, 2, 3 and 4 substeps in turn and keeps the last, bit for bit the same as 4 alone.
#[test]
fn an_undone_adaptive_step_leaves_no_trace_in_the_contacts() {
    use bevy_drape::cloth::AdaptiveSubsteps;
    let mut rng = Rng(0x2f6b_1d3a_9c47_e805);
    let mut next = move || rng.uniform();
    for case in 0..3 {
        let size = 0.3 + 0.3 * next();
        let cells = 6 + (8.0 * next()) as u32;
        let grid = GridDesc {
            size: Vec2::splat(size),
            vertices: bevy::math::UVec2::splat(cells + 1),
            orientation: Quat::IDENTITY,
            origin: Vec3::new(-size / 2.0, 0.12, -size / 2.0),
        };
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, DENSITY).unwrap());
        let speed = Vec3A::new(0.5 + next(), 0.0, next() - 0.5);
        let spin = Vec3A::new(0.0, 0.0, 2.0 * next() - 1.0);
        let mut capsule = SolverCollider::fixed(
            SolverShape::Capsule {
                radius: 0.1,
                half_length: 0.4,
            },
            RigidPose {
                translation: Vec3A::ZERO,
                rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            },
        );
        capsule.material.friction = 0.5 + 0.3 * next();
        capsule.linear_velocity = speed;
        capsule.angular_velocity = spin;
        let fixed = SolverSettings {
            substeps: 4,
            iterations: 2,
            ..SolverSettings::default()
        };
        let adaptive = SolverSettings {
            substeps: 1,
            adaptive: Some(AdaptiveSubsteps {
                target_strain: f32::MIN_POSITIVE,
                min_substeps: 1,
                max_substeps: 4,
                ..AdaptiveSubsteps::default()
            }),
            ..fixed
        };
        let mut move_capsule = |sim: &mut ClothSolver, step: u32| {
            let pose = |t: f32| RigidPose {
                translation: speed * t,
                rotation: Quat::from_scaled_axis((spin * t).into())
                    * Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            };
            capsule.start = pose(step as f32 * DT);
            capsule.end = pose((step + 1) as f32 * DT);
            sim.set_colliders(std::slice::from_ref(&capsule)).unwrap();
        };
        for step in 0..20 {
            move_capsule(&mut sim, step);
            sim.step(&fixed, GRAVITY, DT).unwrap();
        }
        assert!(
            sim.contact_count() > 0,
            "case {case}: the cloth rests on the capsule"
        );
        for step in 20..40 {
            move_capsule(&mut sim, step);
            // A copy that has never stepped adaptively starts from `substeps`, 1.
            let mut redone = sim.clone();
            sim.step(&fixed, GRAVITY, DT).unwrap();
            redone.step(&adaptive, GRAVITY, DT).unwrap();
            assert_eq!(redone.last_substeps(), 1 + 2 + 3 + 4);
            let (a, b) = (sim.state(), redone.state());
            let apart = a
                .positions
                .iter()
                .zip(&b.positions)
                .chain(a.velocities.iter().zip(&b.velocities))
                .map(|(p, q)| p.distance(*q))
                .fold(0.0f32, f32::max);
            assert!(
                a.positions == b.positions && a.velocities == b.velocities,
                "case {case}, step {step}: apart by up to {apart}"
            );
        }
    }
}
