//! How a cloth entity is drawn in a headless App: debug colours, per-triangle paint, a fine
//! mesh drawn over a coarse simulation, a cloth on a sphere drawn outside it.

use crate::common;

use bevy::mesh::{Mesh, VertexAttributeValues};
use bevy::prelude::*;
use bevy_drape::cloth::plugin::ClothDebugColors;
use bevy_drape::cloth::{ClothPaint, DebugColorMode, PaintTarget};
use bevy_drape::prelude::*;
use common::{app, attribute, positions, spawn_cloth};

#[test]
fn debug_colours_are_written_into_the_mesh_and_white_when_off() {
    let mut app = app();
    let grid = GridDesc::square(1.0, 6, Vec3::ZERO);
    let cloth = spawn_cloth(
        &mut app,
        &grid,
        Cloth::pinned([0, 5]),
        Transform::from_xyz(0.0, 1.0, 0.0),
    );
    let colours = |app: &App| {
        let handle = &app.world().get::<Mesh3d>(cloth).unwrap().0;
        let mesh = app.world().resource::<Assets<Mesh>>().get(handle).unwrap();
        match mesh.attribute(Mesh::ATTRIBUTE_COLOR) {
            Some(VertexAttributeValues::Float32x4(c)) => Some(c.clone()),
            _ => None,
        }
    };
    for _ in 0..5 {
        app.update();
    }
    // The cloth's mesh has white vertex colours from the start (a constant vertex layout).
    let white = vec![[1.0f32; 4]; 36];
    assert_eq!(colours(&app), Some(white.clone()));
    app.insert_resource(ClothDebugColors(DebugColorMode::Pinned));
    app.update();
    let c = colours(&app).expect("colours written");
    assert_eq!(c.len(), 36);
    assert_ne!(c[0], c[7], "a pin and a free vertex differ");
    app.insert_resource(ClothDebugColors(DebugColorMode::Strain));
    app.update();
    assert!(
        colours(&app)
            .unwrap()
            .iter()
            .flatten()
            .all(|v| v.is_finite())
    );
    app.insert_resource(ClothDebugColors(DebugColorMode::Off));
    app.update();
    assert_eq!(colours(&app), Some(white));
}

#[test]
fn per_triangle_paint_draws_flat_colours_and_off_brings_the_shared_mesh_back() {
    let mut app = app();
    let grid = GridDesc::square(1.0, 5, Vec3::ZERO);
    let cloth = spawn_cloth(
        &mut app,
        &grid,
        Cloth::pinned([0, 4]),
        Transform::from_xyz(0.0, 1.0, 0.0),
    );
    let mesh = |app: &App| {
        let handle = &app.world().get::<Mesh3d>(cloth).unwrap().0;
        app.world()
            .resource::<Assets<Mesh>>()
            .get(handle)
            .unwrap()
            .clone()
    };
    let attribute3 = |m: &Mesh, a| match m.attribute(a) {
        Some(VertexAttributeValues::Float32x3(v)) => v.clone(),
        _ => panic!("no attribute"),
    };
    let colours = |m: &Mesh| match m.attribute(Mesh::ATTRIBUTE_COLOR) {
        Some(VertexAttributeValues::Float32x4(c)) => c.clone(),
        _ => panic!("no colours"),
    };
    for _ in 0..3 {
        app.update();
    }
    let shared = mesh(&app);
    assert_eq!(shared.count_vertices(), 25);
    let triangles = 32;
    // A colour of its own for every triangle, from a value nobody designed for it.
    let paint: Vec<[f32; 4]> = (0..triangles)
        .map(|t| {
            let u = ((t * 7919) % 97) as f32 / 97.0;
            [u, 1.0 - u, 0.5 * u, 1.0]
        })
        .collect();
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothPaint::triangle_colors(paint.clone()));
    app.insert_resource(ClothDebugColors(DebugColorMode::Custom));
    for _ in 0..3 {
        app.update();
    }
    let flat = mesh(&app);
    assert_eq!(flat.count_vertices(), 3 * triangles);
    let c = colours(&flat);
    for (corner, colour) in c.iter().enumerate() {
        assert_eq!(*colour, paint[corner / 3], "corner {corner}");
    }
    // Every corner is drawn where its particle is: the flat mesh's positions are the shared
    // mesh's vertices, gathered by the indices, as the cloth moves on.
    let positions = attribute3(&flat, Mesh::ATTRIBUTE_POSITION);
    let solver = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    let model = solver.model();
    for (t, tri) in model.triangles.iter().enumerate() {
        for k in 0..3 {
            let particle = solver.state().positions[tri[k] as usize];
            let drawn = Vec3::from(positions[3 * t + k]) + Vec3::Y;
            assert!(
                drawn.distance(particle.into()) < 0.05,
                "{drawn} vs {particle}"
            );
        }
    }
    // Per particle: one colour per vertex, the shared mesh again.
    let values: Vec<f32> = (0..25).map(|i| i as f32).collect();
    app.world_mut().entity_mut(cloth).insert(ClothPaint::values(
        PaintTarget::Particles,
        values,
        0.0,
        24.0,
    ));
    app.update();
    let shared_again = mesh(&app);
    assert_eq!(shared_again.count_vertices(), 25);
    assert_eq!(shared_again.indices(), shared.indices());
    let c = colours(&shared_again);
    assert_ne!(c[0], c[24]);
    // A list of the wrong length: grey, a warning, the app keeps running.
    app.world_mut()
        .entity_mut(cloth)
        .insert(ClothPaint::triangle_colors(vec![[1.0; 4]; 3]));
    app.update();
    assert_eq!(mesh(&app).count_vertices(), 3 * triangles);
    assert!(
        colours(&mesh(&app))
            .iter()
            .all(|c| c.iter().all(|v| v.is_finite()))
    );
    // Area strain is per triangle too; off gives the shared mesh and white back.
    app.insert_resource(ClothDebugColors(DebugColorMode::AreaStrain));
    app.update();
    assert_eq!(mesh(&app).count_vertices(), 3 * triangles);
    app.insert_resource(ClothDebugColors(DebugColorMode::Off));
    app.update();
    let off = mesh(&app);
    assert_eq!(off.count_vertices(), 25);
    assert_eq!(colours(&off), vec![[1.0f32; 4]; 25]);
}

/// The largest angle between the normals of two triangles that share an edge, radians.
fn sharpest_crease(positions: &[Vec3], indices: &[u32]) -> f32 {
    let triangles: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let normal = |t: [u32; 3]| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        (b - a).cross(c - a).normalize()
    };
    let mut by_edge = std::collections::HashMap::<[u32; 2], Vec<usize>>::new();
    for (k, t) in triangles.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            by_edge.entry([a.min(b), a.max(b)]).or_default().push(k);
        }
    }
    by_edge
        .values()
        .filter(|ts| ts.len() == 2)
        .map(|ts| {
            normal(triangles[ts[0]])
                .dot(normal(triangles[ts[1]]))
                .clamp(-1.0, 1.0)
                .acos()
        })
        .fold(0.0, f32::max)
}

/// A cloth simulated on a coarse mesh and drawn with a finer one (`ClothSimulationMesh`).
#[test]
fn a_fine_mesh_drawn_over_a_coarse_simulation_follows_it_smoothly() {
    let mut app = app();
    // A 1 m sheet simulated with 7 x 7 particles, drawn with 37 x 37 vertices: every 6th
    // drawn vertex lies on a particle at rest.
    let coarse = GridDesc::square(1.0, 7, Vec3::ZERO);
    let fine = GridDesc::square(1.0, 37, Vec3::ZERO);
    let (coarse_mesh, fine_mesh) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (meshes.add(grid_mesh(&coarse)), meshes.add(grid_mesh(&fine)))
    };
    let pins = [coarse.index(0, 0), coarse.index(6, 0)];
    let cloth = app
        .world_mut()
        .spawn((
            Mesh3d(fine_mesh),
            ClothSimulationMesh(coarse_mesh),
            Cloth::pinned(pins),
            Transform::from_xyz(0.0, 1.0, 0.0),
        ))
        .id();
    for _ in 0..81 {
        app.update();
    }
    // Paused, the cloth is drawn at its last state rather than between the last two.
    app.world_mut().resource_mut::<DrapeSettings>().paused = true;
    for _ in 0..3 {
        app.update();
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    assert_eq!(sim.state().positions.len(), 49);
    let particles = sim.state().positions.clone();
    let drawn = attribute(&app, cloth, Mesh::ATTRIBUTE_POSITION);
    let normals = attribute(&app, cloth, Mesh::ATTRIBUTE_NORMAL);
    assert_eq!(drawn.len(), 37 * 37);
    assert!(drawn.iter().chain(&normals).all(|p| p.is_finite()));
    assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
    // The drawn vertices on particles are at the particles (the entity is at y = 1).
    for j in 0..7 {
        for i in 0..7 {
            let particle = Vec3::from(particles[coarse.index(i, j) as usize]);
            let vertex = drawn[fine.index(6 * i, 6 * j) as usize] + Vec3::Y;
            assert!(
                particle.distance(vertex) < 1e-4,
                "particle ({i}, {j}) at {particle}, its vertex at {vertex}"
            );
        }
    }
    // The sheet hung down and is drawn smoother than its simulated facets.
    assert!(particles.iter().any(|p| p.y < 0.5));
    let fine_indices = fine.mesh().indices;
    let coarse_positions: Vec<Vec3> = particles.iter().map(|&p| p.into()).collect();
    let (drawn_crease, simulated_crease) = (
        sharpest_crease(&drawn, &fine_indices),
        sharpest_crease(&coarse_positions, &coarse.mesh().indices),
    );
    assert!(
        drawn_crease < 0.5 * simulated_crease,
        "drawn crease {drawn_crease} rad, simulated {simulated_crease} rad"
    );
}

/// Sheets draped over a sphere, one drawn with its own mesh and one simulated on a coarse mesh
/// and drawn with a finer one: the particles end a step anywhere from the sphere's surface out
/// to the contact distance, and the coarse mesh's chords cut into it, but every drawn vertex
/// is at least the contact distance from the sphere (`collide/skin.rs`), and those of the
/// sheet that is its own mesh stay within it of their particles.
#[test]
fn a_cloth_on_a_sphere_is_drawn_outside_it() {
    let mut app = app();
    let radius = 0.3;
    app.world_mut()
        .spawn((ClothCollider::sphere(radius), Transform::default()));
    let own = GridDesc::square(1.0, 24, Vec3::new(-0.5, radius + 0.05, -0.5));
    let coarse = GridDesc::square(1.0, 7, Vec3::new(-0.5, radius + 0.05, -0.5));
    let fine = GridDesc::square(1.0, 37, Vec3::new(-0.5, radius + 0.05, -0.5));
    let own_cloth = spawn_cloth(&mut app, &own, Cloth::default(), Transform::default());
    let (coarse_mesh, fine_mesh) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (meshes.add(grid_mesh(&coarse)), meshes.add(grid_mesh(&fine)))
    };
    let coarse_cloth = app
        .world_mut()
        .spawn((
            Mesh3d(fine_mesh),
            ClothSimulationMesh(coarse_mesh),
            Cloth::default(),
            Transform::default(),
        ))
        .id();
    // The contact distance: the sphere's margin and the cloth's thickness.
    let reach = SolverSettings::default().thickness + ClothCollider::sphere(radius).margin;
    let (mut closest_particle, mut deepest_chord) = (f32::INFINITY, f32::INFINITY);
    for update in 0..90 {
        app.update();
        if update < 30 {
            continue;
        }
        for cloth in [own_cloth, coarse_cloth] {
            let drawn = positions(&app, cloth);
            assert!(drawn.iter().all(|p| p.is_finite()));
            for p in &drawn {
                assert!(
                    p.length() - radius >= reach - 1e-4,
                    "a drawn vertex {} m from the sphere",
                    p.length() - radius
                );
            }
            let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
            let x: Vec<Vec3> = sim.state().positions.iter().map(|&p| p.into()).collect();
            closest_particle = x
                .iter()
                .map(|p| p.length() - radius)
                .fold(closest_particle, f32::min);
            if cloth == coarse_cloth {
                for t in &sim.model().triangles {
                    for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                        let middle = (x[a as usize] + x[b as usize]) * 0.5;
                        deepest_chord = deepest_chord.min(middle.length() - radius);
                    }
                }
            }
        }
    }
    // Paused, a cloth is drawn at its last state: the sheet drawn with its own mesh has a
    // vertex per particle, moved no further than out to the contact distance.
    app.world_mut().resource_mut::<DrapeSettings>().paused = true;
    for _ in 0..3 {
        app.update();
    }
    let sim = app
        .world()
        .get::<ClothSimulation>(own_cloth)
        .unwrap()
        .solver();
    let drawn = positions(&app, own_cloth);
    assert_eq!(drawn.len(), sim.state().positions.len());
    for (p, &q) in drawn.iter().zip(&sim.state().positions) {
        assert!(p.distance(q.into()) <= reach + 1e-4, "{p} drawn for {q}");
    }
    println!(
        "closest particle {closest_particle:.2e} m from the sphere, the coarse mesh's chords \
         {deepest_chord:.3} m"
    );
    assert!(closest_particle >= -1e-5 && closest_particle < reach);
    assert!(deepest_chord < -0.005, "{deepest_chord}");
}
