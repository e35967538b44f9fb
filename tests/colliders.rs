//! Collider contacts against analytic results: restitution, the friction threshold and the
//! sliding acceleration on an incline, a spinning sphere's surface velocity, a fast collider,
//! and scene S2.

use std::sync::Arc;

use bevy::math::{Quat, Vec2, Vec3, Vec3A};
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverMethod, SolverSettings};
use bevy_drape::collide::{ContactMaterial, RigidPose, SolverCollider, SolverShape, TriMesh};
use drape_scenes::scenes::{DENSITY, Drape, FRAME_RATE, GRAVITY, lowest_height};

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

/// How far the middles of the sheet's four sides hang out from the sphere's surface,
/// horizontally: the largest of the four, m.
fn side_middles_off_the_sphere(scene: &Drape, sim: &ClothSolver) -> f32 {
    let n = scene.n as usize;
    let centre = scene.sphere_centre();
    [n / 2, (n / 2) * n, (n / 2) * n + n - 1, (n - 1) * n + n / 2]
        .into_iter()
        .map(|i| {
            let p = Vec3::from(sim.state().positions[i]);
            Vec2::new(p.x - centre.x, p.z - centre.z).length() - Drape::RADIUS
        })
        .fold(0.0, f32::max)
}

#[test]
fn s2_the_woven_sheet_drapes_the_sphere_below_two_percent_strain_without_penetration() {
    let scene = Drape { n: 64 };
    let run = scene.run(&Drape::settings(), 180);
    let sim = &run.sim;
    let centre = scene.sphere_centre();
    let lowest = lowest_height(sim);
    let off = side_middles_off_the_sphere(&scene, sim);
    println!(
        "S2 N = 64: deepest {:.2e} m, strain at the end {:.2}%, largest after any frame {:.2}%, \
         {:.1} substeps per frame, lowest particle {lowest:.3} m, side middles {off:.3} m off \
         the sphere",
        run.deepest_penetration,
        run.max_strain * 100.0,
        run.largest_strain * 100.0,
        run.mean_substeps,
    );
    assert!(run.finite);
    assert!(run.deepest_penetration <= 1e-5);
    assert!(run.max_strain <= 0.02 && run.largest_strain <= 0.02);
    // The cloth draped and stayed: it rests on the sphere, hangs close around it below its
    // equator and reaches the ground.
    let top = sim
        .state()
        .positions
        .iter()
        .map(|p| Vec3::from(*p).distance(centre))
        .fold(f32::MAX, f32::min);
    assert!(top < Drape::RADIUS + 0.02, "{top}");
    assert!(lowest < 0.05, "{lowest}");
    assert!(off < 0.05, "{off}");
    let centre_particle = sim.state().positions[32 * 64 + 32];
    assert!(
        (centre_particle.y - 2.0 * Drape::RADIUS).abs() < 0.02,
        "{centre_particle}"
    );
}

/// The library's default cloth, whose diagonals keep their length as the threads do, cannot
/// lie on the sphere (`Drape`'s docs): the sides stand out from it and their hem is
/// compressed, however small the substep.
#[test]
fn s2_a_sheet_with_rigid_diagonals_stands_out_from_the_sphere() {
    let scene = Drape { n: 64 };
    let settings = SolverSettings {
        substeps: 16,
        iterations: 4,
        ..SolverSettings::default()
    };
    let run = scene.run(&settings, 180);
    let off = side_middles_off_the_sphere(&scene, &run.sim);
    println!(
        "rigid diagonals, 16 x 4: strain at the end {:.2}%, side middles {off:.3} m off the sphere",
        run.max_strain * 100.0
    );
    assert!(run.finite);
    assert!(off > 0.1, "{off}");
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

#[test]
fn a_thrown_mass_spring_cloth_hits_every_sphere_the_ground_and_the_walls_and_stays_out() {
    use drape_scenes::scenes::Collisions;
    let scene = Collisions { n: 16 };
    let settings = Collisions::settings();
    let run = scene.run(&settings, 240);
    println!(
        "touched {:?}, deepest {} m, {} substeps",
        run.touched,
        run.deepest_penetration,
        run.sim.last_substeps()
    );
    assert!(run.finite);
    // The three spheres (the moving one too), the +X wall it is thrown at, and the ground.
    for k in [0, 1, 2, 4, 5] {
        assert!(
            run.touched[k],
            "collider {k} never touched: {:?}",
            run.touched
        );
    }
    // Never deeper inside anything than the cloth's thickness.
    assert!(
        run.deepest_penetration <= settings.thickness,
        "{} m deep",
        run.deepest_penetration
    );
}

/// A crowd's other characters: colliders whose swept bounds never meet the cloth's are left
/// out before any particle is looked at, so they change nothing, bit for bit, while near ones
/// (one resting, one sweeping in from 2 m away within a step) are met as before.
#[test]
fn colliders_far_from_the_cloth_change_nothing() {
    let mut rng = drape_scenes::scan::Rng(0x5eed_c0de);
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
    let mut rng = drape_scenes::scan::Rng(0xe8ac_7ed9);
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
    let mut rng = drape_scenes::scan::Rng(0x7b1d_5eed);
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

/// A step the adaptive budget undoes and runs again is the step it would have been at the
/// count it ends with: friction's anchors, which move with the collider's surface in every
/// substep, are undone with the positions. A cloth of random size rests on a capsule that
/// slides and turns at random speeds; a budget whose target no step meets runs every step at
/// 1, 2, 3 and 4 substeps in turn and keeps the last, bit for bit the same as 4 alone.
#[test]
fn an_undone_adaptive_step_leaves_no_trace_in_the_contacts() {
    use bevy_drape::cloth::AdaptiveSubsteps;
    let mut seed = 0x2f6b_1d3a_9c47_e805u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
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
