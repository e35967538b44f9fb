//! Helpers shared by the rendering examples: an orbit camera, mouse dragging of cloth, C to
//! cycle debug colours, and a "run N frames, save a screenshot, exit" switch for smoke tests
//! and pictures.
//!
//! In the `Custom` debug colours every cloth shows a value computed by `paint_folds` here, the
//! way a game paints any value of its own: how far each triangle turns from the horizontal.
//!
//! Environment variables:
//! - `DRAPE_FRAMES=N`: after N rendered frames, save a screenshot and exit;
//! - `DRAPE_SCREENSHOT=path.png`: where to save it (default `screenshot.png`);
//! - `DRAPE_DEBUG_COLORS=mode`: start with these debug colours (`Strain`, `AreaStrain`,
//!   `Custom`, ...).

#[allow(dead_code)]
pub(crate) mod offscreen;

use bevy::app::AppExit;
use bevy::input::mouse::{AccumulatedMouseMotion, AccumulatedMouseScroll};
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy_drape::cloth::plugin::ClothDebugColors;
use bevy_drape::cloth::{ClothPaint, DebugColorMode, PaintTarget};
use bevy_drape::prelude::ClothSimulation;

/// Whether Bevy's renderer will find a graphics adapter here. If not, says so in one line
/// naming `example` and what to install, and the example should return (exit 0): without an
/// adapter Bevy's renderer would panic.
// The poncho and gltf_character examples run their scene headless instead.
#[allow(dead_code)]
pub(crate) fn has_graphics_adapter(example: &str) -> bool {
    match bevy_drape::interact::adapter::find_graphics_adapter() {
        Ok(_) => true,
        Err(reason) => {
            println!("{example}: {reason}; nothing to show without one");
            false
        }
    }
}

/// Adds the orbit camera controls and the screenshot-and-exit switch.
pub(crate) struct ExamplePlugin;

impl Plugin for ExamplePlugin {
    fn build(&self, app: &mut App) {
        let frames = std::env::var("DRAPE_FRAMES")
            .ok()
            .and_then(|v| v.parse::<u32>().ok());
        let path = std::env::var("DRAPE_SCREENSHOT").unwrap_or_else(|_| "screenshot.png".into());
        app.insert_resource(SmokeRun {
            frames,
            path,
            frame: 0,
        })
        .add_plugins((
            bevy_drape::interact::drag::ClothDragPlugin,
            bevy_drape::interact::gizmos::ColliderGizmoPlugin,
        ))
        .add_systems(
            Update,
            (orbit_camera, smoke_run, cycle_debug_colors, paint_folds),
        );
        if let Ok(name) = std::env::var("DRAPE_DEBUG_COLORS") {
            let mut mode = DebugColorMode::Off.next();
            while format!("{mode:?}") != name && mode != DebugColorMode::Off {
                mode = mode.next();
            }
            app.insert_resource(ClothDebugColors(mode));
        }
        // The settings panel, with `--features egui`.
        #[cfg(feature = "egui")]
        app.add_plugins(bevy_drape::interact::panel::DrapePanelPlugin);
    }
}

/// A camera that orbits `focus`: drag with the left or right mouse button to turn (the left
/// one drags cloth when pressed on a cloth), scroll to zoom.
#[derive(Component, Clone, Copy, Debug)]
pub(crate) struct OrbitCamera {
    /// The point looked at.
    pub focus: Vec3,
    /// Distance from the focus, metres.
    pub radius: f32,
    /// Angle about the vertical, radians.
    pub yaw: f32,
    /// Angle above the horizontal, radians.
    pub pitch: f32,
}

impl OrbitCamera {
    /// The camera transform for this orbit.
    pub(crate) fn transform(&self) -> Transform {
        let rotation = Quat::from_euler(EulerRot::YXZ, self.yaw, -self.pitch, 0.0);
        let position = self.focus + rotation * Vec3::Z * self.radius;
        Transform::from_translation(position).looking_at(self.focus, Vec3::Y)
    }
}

fn orbit_camera(
    mut cameras: Query<(&mut OrbitCamera, &mut Transform)>,
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    scroll: Res<AccumulatedMouseScroll>,
    drag: Res<bevy_drape::interact::drag::ClothDrag>,
) {
    for (mut orbit, mut transform) in &mut cameras {
        // The left button drags cloth when it is pressed on one (and turns the view when not).
        if buttons.any_pressed([MouseButton::Left, MouseButton::Right])
            && !drag.is_active()
            && !drag.pointer_over_ui
        {
            orbit.yaw -= motion.delta.x * 0.005;
            orbit.pitch = (orbit.pitch + motion.delta.y * 0.005).clamp(-1.5, 1.5);
        }
        if !drag.pointer_over_ui {
            orbit.radius = (orbit.radius * (1.0 - scroll.delta.y * 0.1)).clamp(0.3, 50.0);
        }
        *transform = orbit.transform();
    }
}

/// C cycles the cloths' debug colours: off, strain, speed, contact, pinned, area strain,
/// custom.
fn cycle_debug_colors(input: Res<ButtonInput<KeyCode>>, mut colors: ResMut<ClothDebugColors>) {
    if input.just_pressed(KeyCode::KeyC) {
        colors.0 = colors.0.next();
        info!("debug colours: {:?}", colors.0);
    }
}

/// The custom debug colours: per triangle, `1 - |n . up|` on the ramp, blue where the cloth
/// lies flat, red where it hangs straight down (its folds and its sides).
fn paint_folds(
    mut commands: Commands,
    debug: Res<ClothDebugColors>,
    mut cloths: Query<(Entity, &ClothSimulation, Option<&mut ClothPaint>)>,
) {
    if debug.0 != DebugColorMode::Custom {
        return;
    }
    for (entity, simulation, paint) in &mut cloths {
        let solver = simulation.solver();
        let x = &solver.state().positions;
        let values = solver
            .model()
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| x[i as usize]);
                1.0 - (b - a).cross(c - a).normalize_or_zero().y.abs()
            })
            .collect();
        let painted = ClothPaint::values(PaintTarget::Triangles, values, 0.0, 1.0);
        match paint {
            Some(mut paint) => *paint = painted,
            None => {
                commands.entity(entity).insert(painted);
            }
        }
    }
}

#[derive(Resource)]
struct SmokeRun {
    frames: Option<u32>,
    path: String,
    frame: u32,
}

fn smoke_run(mut commands: Commands, mut run: ResMut<SmokeRun>, mut exit: MessageWriter<AppExit>) {
    let Some(frames) = run.frames else {
        return;
    };
    run.frame += 1;
    if run.frame == frames {
        info!("saving a screenshot to {}", run.path);
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(run.path.clone()));
    }
    // Saving takes a few frames.
    if run.frame == frames + 10 {
        exit.write(AppExit::Success);
    }
}

/// A ground square, a light and an orbit camera looking at `focus`.
pub(crate) fn spawn_stage(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
    focus: Vec3,
    radius: f32,
) {
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(40.0, 40.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.55, 0.58, 0.52),
            perceptual_roughness: 0.9,
            ..default()
        })),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 9000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(3.0, 6.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    let orbit = OrbitCamera {
        focus,
        radius,
        yaw: 0.6,
        pitch: 0.35,
    };
    commands.spawn((Camera3d::default(), orbit.transform(), orbit));
}

/// A checkerboard of 1 m tiles on the ground, 24 m square, so a walk shows against it.
#[allow(dead_code)]
pub(crate) fn spawn_ground_tiles(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
) {
    let tile = meshes.add(Plane3d::default().mesh().size(1.0, 1.0));
    let dark = materials.add(StandardMaterial {
        base_color: Color::srgb(0.45, 0.48, 0.43),
        perceptual_roughness: 0.9,
        ..default()
    });
    for i in -12..12 {
        for j in -12..12 {
            if (i + j) % 2 == 0 {
                commands.spawn((
                    Mesh3d(tile.clone()),
                    MeshMaterial3d(dark.clone()),
                    Transform::from_xyz(i as f32 + 0.5, 0.002, j as f32 + 0.5),
                ));
            }
        }
    }
}

/// A double-sided cloth material.
#[allow(dead_code)]
pub(crate) fn cloth_material(
    materials: &mut Assets<StandardMaterial>,
    color: Color,
) -> Handle<StandardMaterial> {
    materials.add(StandardMaterial {
        base_color: color,
        perceptual_roughness: 0.8,
        double_sided: true,
        cull_mode: None,
        ..default()
    })
}

/// Rigid body parts for the humanoid's bones: the collision proxies themselves
/// (`bevy_drape::skeleton::humanoid::humanoid_proxies`, capsules and spheres) and boxes for
/// the feet, each a child of its bone entity, so what you see is what the cloth touches. Add
/// as an `Update` system; it dresses every skeleton once.
#[allow(dead_code)]
pub(crate) fn dress_humanoids(
    mut commands: Commands,
    skeletons: Query<
        (Entity, &bevy_drape::skeleton::plugin::SkeletonBones),
        Added<bevy_drape::skeleton::plugin::SkeletonBones>,
    >,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    for (skeleton, bones) in &skeletons {
        // The library has no renderer, so its bone entities carry no visibility; the meshes
        // hung from them need it up the hierarchy, the character's entity included.
        commands.entity(skeleton).insert(Visibility::default());
        for &bone in bones.entities() {
            commands.entity(bone).insert(Visibility::default());
        }
        let skin = materials.add(StandardMaterial {
            base_color: Color::srgb(0.82, 0.68, 0.58),
            perceptual_roughness: 0.7,
            ..default()
        });
        let dark = materials.add(Color::srgb(0.2, 0.22, 0.28));
        let is_dark = |bone: &str| {
            bone == "pelvis"
                || bone.starts_with("thigh")
                || bone.starts_with("shin")
                || bone.starts_with("foot")
        };
        let mut parts: Vec<(String, Mesh, Transform)> =
            bevy_drape::skeleton::humanoid::humanoid_proxies()
                .into_iter()
                .map(|p| {
                    let mesh: Mesh = if p.half_length > 0.0 {
                        Capsule3d::new(p.radius, 2.0 * p.half_length).mesh().into()
                    } else {
                        Sphere::new(p.radius).mesh().into()
                    };
                    let at = Transform::from_translation(p.centre).with_rotation(p.rotation());
                    (p.bone, mesh, at)
                })
                .collect();
        for side in ["l", "r"] {
            parts.push((
                format!("foot_{side}"),
                Cuboid::new(0.09, 0.05, 0.22).mesh().into(),
                Transform::from_xyz(0.0, -0.015, 0.05),
            ));
        }
        for (bone, mesh, at) in parts {
            let Some(entity) = bones.get(&bone) else {
                continue;
            };
            commands.spawn((
                Mesh3d(meshes.add(mesh)),
                MeshMaterial3d(if is_dark(&bone) {
                    dark.clone()
                } else {
                    skin.clone()
                }),
                at,
                ChildOf(entity),
            ));
        }
    }
}

/// The orbit camera's focus follows the entity with `C` (smoothly), 1 m above its origin; the
/// orbit keeps its angles and distance (the mouse turns and zooms it in a window).
#[allow(dead_code)]
pub(crate) fn follow_with_camera<C: Component>(
    followed: Query<&GlobalTransform, With<C>>,
    mut cameras: Query<(&mut OrbitCamera, &mut Transform)>,
    time: Res<Time>,
) {
    let Ok(followed) = followed.single() else {
        return;
    };
    let goal = followed.translation() + Vec3::Y;
    let blend = 1.0 - (-4.0 * time.delta_secs()).exp();
    for (mut orbit, mut transform) in &mut cameras {
        orbit.focus = orbit.focus.lerp(goal, blend);
        *transform = orbit.transform();
    }
}
