//! Water poured into a cloth hammock: a jet fills a sheet hung from four posts, the sheet
//! sags under the water's weight, and what it cannot hold spills over its rim. The water is
//! Position Based Fluids stepped inside the cloth's substeps (`bevy_drape::fluid`), every
//! particle drawn as a small sphere.
//!
//! ```text
//! cargo run --features render --example water
//! ```
//!
//! Space pours again, P pauses; drag to orbit or to pull the hammock, scroll to zoom. With no
//! display it renders offscreen into a few PNG frames (`examples/common/offscreen.rs`).

mod common;

use bevy::prelude::*;
use bevy_drape::fluid::plugin::FluidSimulation;
use bevy_drape::fluid::{FluidJet, FluidSettings};
use bevy_drape::prelude::*;
use common::offscreen::{OffscreenPlugin, has_display, headless_default_plugins};
use common::{ExamplePlugin, OrbitCamera, cloth_material, spawn_stage};

/// The hammock's side (m), vertices per side, the posts' height (m), and how far in from the
/// corners the posts stand (as a share of the side): the `pour` scene of the scenes runner.
const SIDE: f32 = 0.8;
const VERTICES: u32 = 21;
const HEIGHT: f32 = 0.9;
const SPAN: f32 = 0.7;

fn main() {
    if !common::has_graphics_adapter("water") {
        return;
    }
    let mut app = App::new();
    if has_display() {
        app.add_plugins((DefaultPlugins, ExamplePlugin));
    } else {
        println!("no display: rendering offscreen");
        app.add_plugins((
            headless_default_plugins(),
            OffscreenPlugin::from_env("water"),
        ));
    }
    app.add_plugins(DrapePlugins::default())
        .add_systems(Startup, (setup, look_into_the_hammock).chain())
        .add_systems(Update, (keys, draw_water))
        .run();
}

/// The spheres the water is drawn with: one per particle, sharing a mesh and a material.
#[derive(Component, Default)]
struct Drops(Vec<Entity>);

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    spawn_stage(
        &mut commands,
        &mut meshes,
        &mut materials,
        Vec3::new(0.0, 0.6, 0.0),
        2.4,
    );
    commands.spawn((ClothCollider::plane(), Transform::default()));
    // A sheet hung by its corners from four posts standing in from them, and a jet over it.
    let n = VERTICES;
    let grid = GridDesc::square(SIDE, n, Vec3::new(-SIDE / 2.0, HEIGHT, -SIDE / 2.0));
    let posts = [0, n - 1, n * (n - 1), n * n - 1].map(|k| {
        let (i, j) = ((k % n) as f32, (k / n) as f32);
        let corner = Vec3::new(i / (n - 1) as f32 - 0.5, 0.0, j / (n - 1) as f32 - 0.5) * SIDE;
        (k, corner * SPAN + Vec3::Y * HEIGHT)
    });
    let wood = materials.add(StandardMaterial {
        base_color: Color::srgb(0.45, 0.32, 0.2),
        perceptual_roughness: 0.8,
        ..default()
    });
    let post_mesh = meshes.add(Cylinder::new(0.02, HEIGHT));
    let mut cloth = Cloth::default();
    for (vertex, top) in posts {
        commands.spawn((
            Mesh3d(post_mesh.clone()),
            MeshMaterial3d(wood.clone()),
            Transform::from_translation(top - Vec3::Y * HEIGHT / 2.0),
        ));
        let top = commands.spawn(Transform::from_translation(top)).id();
        cloth = cloth.with_attachment(VertexAttachment {
            vertex,
            target: top,
            offset: Vec3::ZERO,
        });
    }
    commands.spawn((
        Name::new("hammock"),
        Mesh3d(meshes.add(grid_mesh(&grid))),
        MeshMaterial3d(cloth_material(
            &mut materials,
            Color::srgb(0.85, 0.75, 0.55),
        )),
        cloth,
        ClothSettings {
            density: 0.2,
            // Water is 30 to 40 times heavier than the cloth that holds it: the cloth needs
            // the iterations to carry it.
            solver: SolverSettings {
                substeps: 16,
                iterations: 4,
                ..default()
            },
            ..default()
        },
        Fluid {
            settings: FluidSettings::default(),
            // 200 particles a second, 600 at most, falling from 1.5 m at 1 m/s.
            source: FluidSource::Jet(FluidJet {
                origin: Vec3::new(0.0, 1.5, 0.0),
                velocity: Vec3::new(0.0, -1.0, 0.0),
                radius: 0.04,
                rate: 200.0,
                max_particles: 600,
            }),
        },
        Drops::default(),
    ));
}

/// Looks down into the hammock, to see the water in it.
fn look_into_the_hammock(mut cameras: Query<(&mut OrbitCamera, &mut Transform)>) {
    for (mut orbit, mut transform) in &mut cameras {
        orbit.pitch = 0.75;
        *transform = orbit.transform();
    }
}

/// Keeps one sphere per water particle where the particle is.
fn draw_water(
    mut commands: Commands,
    mut water: Query<(&FluidSimulation, &mut Drops)>,
    mut transforms: Query<&mut Transform>,
    mut look: Local<Option<(Handle<Mesh>, Handle<StandardMaterial>)>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    for (simulation, mut drops) in &mut water {
        let fluid = simulation.solver();
        let (mesh, material) = look
            .get_or_insert_with(|| {
                let r = fluid.settings().particle_radius;
                (
                    meshes.add(Sphere::new(r).mesh().ico(1).unwrap()),
                    materials.add(StandardMaterial {
                        base_color: Color::srgb(0.15, 0.4, 0.85),
                        perceptual_roughness: 0.15,
                        ..default()
                    }),
                )
            })
            .clone();
        let positions = fluid.positions();
        while drops.0.len() < positions.len() {
            let p = positions[drops.0.len()];
            let drop = commands
                .spawn((
                    Mesh3d(mesh.clone()),
                    MeshMaterial3d(material.clone()),
                    Transform::from_translation(p.into()),
                ))
                .id();
            drops.0.push(drop);
        }
        while drops.0.len() > positions.len() {
            if let Some(drop) = drops.0.pop() {
                commands.entity(drop).despawn();
            }
        }
        for (&drop, &p) in drops.0.iter().zip(positions) {
            if let Ok(mut transform) = transforms.get_mut(drop) {
                transform.translation = p.into();
            }
        }
    }
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut drape: ResMut<DrapeSettings>,
    mut commands: Commands,
    hammocks: Query<Entity, With<Fluid>>,
) {
    if input.just_pressed(KeyCode::KeyP) {
        drape.paused = !drape.paused;
    }
    if input.just_pressed(KeyCode::Space) {
        // A new simulation of the same fluid: the jet pours again.
        for entity in &hammocks {
            commands.entity(entity).remove::<FluidSimulation>();
        }
    }
}
