//! `bevy-inspector-egui` on the crate's components, headless: its entity and resource views
//! drawn into an egui context without a window show every component and setting a designer
//! tunes (cloth settings, colliders, a character's proxies, clip player, the world settings)
//! without an unregistered-type error, and edits made the way the inspector makes them (through
//! the type registry's `ReflectComponent`, or the resource as a reflected value, a field at a
//! time) take effect
//! in the running App.

use std::sync::Arc;
use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::ecs::reflect::{AppTypeRegistry, ReflectComponent};
use bevy::mesh::MeshPlugin;
use bevy::prelude::*;
use bevy::reflect::{GetPath, PartialReflect};
use bevy::time::TimeUpdateStrategy;
use bevy::transform::TransformPlugin;
use bevy_drape::prelude::*;
use bevy_drape::schedule::StepColliders;
use bevy_drape::skeleton::plugin::BoneProxyOf;
use bevy_inspector_egui::DefaultInspectorConfigPlugin;
use bevy_inspector_egui::bevy_inspector::{ui_for_entity, ui_for_resource};
use bevy_inspector_egui::egui;

struct Scene {
    app: App,
    cloth: Entity,
    ball: Entity,
    character: Entity,
}

fn scene() -> Scene {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
        DrapePlugins::default(),
        DefaultInspectorConfigPlugin,
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / 64.0,
    )));
    let grid = GridDesc::square(1.0, 12, Vec3::ZERO);
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(grid_mesh(&grid));
    let cloth = app
        .world_mut()
        .spawn((
            Name::new("sheet"),
            Mesh3d(mesh),
            Cloth::default(),
            ClothSettings::default(),
            Transform::from_xyz(0.0, 2.0, 0.0),
        ))
        .id();
    let ball = app
        .world_mut()
        .spawn((
            Name::new("ball"),
            ClothCollider::sphere(0.2),
            Transform::from_xyz(3.0, 0.5, 0.0),
        ))
        .id();
    let character = app
        .world_mut()
        .spawn((
            Name::new("character"),
            Skeleton {
                rig: Arc::new(humanoid()),
            },
            BoneColliders::humanoid(),
            Transform::from_xyz(-3.0, 0.0, 0.0),
        ))
        .id();
    for _ in 0..3 {
        app.update();
    }
    Scene {
        app,
        cloth,
        ball,
        character,
    }
}

/// Every piece of text in the shapes egui drew.
fn texts(output: &egui::FullOutput) -> Vec<String> {
    fn collect(shape: &egui::Shape, out: &mut Vec<String>) {
        match shape {
            egui::Shape::Text(text) => out.push(text.galley.text().to_string()),
            egui::Shape::Vec(shapes) => shapes.iter().for_each(|s| collect(s, out)),
            _ => {}
        }
    }
    let mut out = Vec::new();
    for clipped in &output.shapes {
        collect(&clipped.shape, &mut out);
    }
    out
}

/// Draws the inspector's view of `entities` and of `DrapeSettings` (two frames, so that
/// egui lays out what it measured in the first).
fn inspector_text(world: &mut World, entities: &[Entity]) -> Vec<String> {
    let ctx = egui::Context::default();
    let mut output = None;
    for _ in 0..2 {
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(1200.0, 8000.0),
            )),
            ..default()
        };
        output = Some(ctx.run_ui(input, |ui| {
            for &entity in entities {
                ui_for_entity(world, entity, ui);
            }
            ui_for_resource::<DrapeSettings>(world, ui);
        }));
    }
    texts(&output.expect("two frames were drawn"))
}

#[test]
fn the_inspector_shows_the_crates_components_and_settings() {
    let mut scene = scene();
    let proxy = {
        let world = scene.app.world_mut();
        world
            .query_filtered::<Entity, With<BoneProxyOf>>()
            .iter(world)
            .next()
            .expect("the character's proxies were spawned")
    };
    let entities = [scene.cloth, scene.ball, scene.character, proxy];
    let text = inspector_text(scene.app.world_mut(), &entities).join("\n");
    for name in [
        "ClothSettings",
        "ClothCollider",
        "BoneColliders",
        "Cloth",
        "BoneProxyOf",
    ] {
        assert!(
            text.contains(name),
            "the inspector does not show {name}:\n{text}"
        );
    }
    // The world settings' fields, drawn as the resource's editor.
    for field in ["gravity", "paused", "teleport"] {
        assert!(
            text.contains(field),
            "DrapeSettings has no {field}:\n{text}"
        );
    }
    // None of the components a designer edits is unknown to the type registry.
    for line in text.lines() {
        let unregistered = line.contains("not registered") || line.contains("not reflect");
        let ours = ["ClothSettings", "ClothCollider", "BoneColliders", "Cloth"]
            .iter()
            .any(|n| line.contains(n));
        assert!(!(unregistered && ours), "{line}");
    }
}

/// Sets field `path` of component `C` of `entity` through the type registry, the way the
/// inspector writes an edited value.
fn edit_component<C: Component>(
    world: &mut World,
    entity: Entity,
    path: &str,
    value: &dyn PartialReflect,
) {
    let registry = world.resource::<AppTypeRegistry>().clone();
    let registry = registry.read();
    let reflect = registry
        .get_type_data::<ReflectComponent>(std::any::TypeId::of::<C>())
        .expect("the component is registered with ReflectComponent");
    let mut component = reflect
        .reflect_mut(world.entity_mut(entity))
        .expect("the entity has the component");
    component
        .reflect_path_mut(path)
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .apply(value);
}

#[test]
fn edits_made_the_inspectors_way_take_effect_while_it_runs() {
    let mut scene = scene();
    let app = &mut scene.app;
    // The cloth's substeps.
    edit_component::<ClothSettings>(app.world_mut(), scene.cloth, "solver.substeps", &3u32);
    app.update();
    let substeps = app
        .world()
        .get::<ClothSimulation>(scene.cloth)
        .unwrap()
        .solver()
        .last_substeps();
    assert_eq!(substeps, 3);
    // A collider's friction.
    edit_component::<ClothCollider>(app.world_mut(), scene.ball, "material.friction", &0.9f32);
    app.update();
    let colliders = app.world().resource::<StepColliders>();
    let at = colliders
        .entities
        .iter()
        .position(|&e| e == scene.ball)
        .unwrap();
    assert_eq!(colliders.colliders[at].material.friction, 0.9);
    // A proxy's radius: the character's proxies are spawned again.
    edit_component::<BoneColliders>(
        app.world_mut(),
        scene.character,
        "proxies[0].radius",
        &0.3f32,
    );
    app.update();
    let world = app.world_mut();
    let radii: Vec<f32> = world
        .query::<(&ClothCollider, &BoneProxyOf)>()
        .iter(world)
        .filter(|(_, of)| of.0 == scene.character)
        .filter_map(|(c, _)| match c.shape {
            ColliderShape::Capsule { radius, .. } => Some(radius),
            _ => None,
        })
        .collect();
    assert_eq!(radii.len(), BoneColliders::humanoid().proxies.len());
    assert_eq!(radii.iter().filter(|&&r| r == 0.3).count(), 1);
    // The world's gravity, through ReflectResource: upward, the free sheet rises.
    let height = |app: &App| {
        let sim = app.world().get::<ClothSimulation>(scene.cloth).unwrap();
        let x = &sim.solver().state().positions;
        x.iter().map(|p| p.y).sum::<f32>() / x.len() as f32
    };
    // The inspector edits a resource as a `&mut dyn Reflect` and marks it changed.
    app.world_mut()
        .resource_mut::<DrapeSettings>()
        .reflect_path_mut("gravity.y")
        .unwrap()
        .apply(&5.0f32);
    let before = height(app);
    for _ in 0..32 {
        app.update();
    }
    assert!(height(app) > before + 0.1, "the sheet did not rise");
}
