//! Rendering with no display: the window plugins off, every camera drawing into an image, a
//! fixed simulated time per rendered frame, and the image saved as PNG frames.
//!
//! Environment variables:
//! - `DRAPE_OFFSCREEN_DIR`: where the frames go (default `target/<example>_frames`);
//! - `DRAPE_OFFSCREEN_FRAMES`: how many frames to save (default 6);
//! - `DRAPE_OFFSCREEN_EVERY`: rendered frames between two saved ones (default 30, 1 s).

use std::path::PathBuf;
use std::time::Duration;

use bevy::app::{AppExit, PluginGroupBuilder, ScheduleRunnerPlugin};
use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy::time::TimeUpdateStrategy;
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;

/// Simulated time per rendered frame.
const FRAME: Duration = Duration::from_nanos(1_000_000_000 / 30);

/// Whether there is a display to open a window on.
pub(crate) fn has_display() -> bool {
    ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .any(|v| std::env::var(v).is_ok_and(|s| !s.is_empty()))
}

/// `DefaultPlugins` with no window and no event loop.
pub(crate) fn headless_default_plugins() -> PluginGroupBuilder {
    DefaultPlugins
        .set(WindowPlugin {
            primary_window: None,
            exit_condition: ExitCondition::DontExit,
            ..default()
        })
        .set(RenderPlugin {
            synchronous_pipeline_compilation: true,
            ..default()
        })
        .disable::<WinitPlugin>()
}

/// Renders every camera into an image and saves frames of it (see the module docs).
pub(crate) struct OffscreenPlugin {
    /// Where the frames go.
    pub dir: PathBuf,
    /// Frames to save.
    pub frames: u32,
    /// Rendered frames between two saved ones.
    pub every: u32,
    /// Image size, pixels.
    pub size: UVec2,
}

impl OffscreenPlugin {
    /// The settings from the environment, frames in `target/<name>_frames` by default.
    pub(crate) fn from_env(name: &str) -> Self {
        let number = |var: &str, default: u32| {
            std::env::var(var)
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(default)
        };
        Self {
            dir: std::env::var("DRAPE_OFFSCREEN_DIR")
                .map(PathBuf::from)
                .unwrap_or_else(|_| PathBuf::from(format!("target/{name}_frames"))),
            frames: number("DRAPE_OFFSCREEN_FRAMES", 6),
            every: number("DRAPE_OFFSCREEN_EVERY", 30).max(1),
            size: UVec2::new(960, 540),
        }
    }
}

#[derive(Resource)]
struct Offscreen {
    dir: PathBuf,
    frames: u32,
    every: u32,
    size: UVec2,
    image: Option<Handle<Image>>,
    frame: u32,
    saved: u32,
}

impl Plugin for OffscreenPlugin {
    fn build(&self, app: &mut App) {
        if let Err(e) = std::fs::create_dir_all(&self.dir) {
            error!("cannot create {}: {e}", self.dir.display());
        }
        app.add_plugins(ScheduleRunnerPlugin::run_loop(Duration::ZERO))
            .insert_resource(TimeUpdateStrategy::ManualDuration(FRAME))
            .insert_resource(Offscreen {
                dir: self.dir.clone(),
                frames: self.frames,
                every: self.every,
                size: self.size,
                image: None,
                frame: 0,
                saved: 0,
            })
            .add_systems(Last, (target_image, save_frames).chain());
    }
}

/// Points every camera at the image (made on the first frame).
fn target_image(
    mut commands: Commands,
    mut offscreen: ResMut<Offscreen>,
    mut images: ResMut<Assets<Image>>,
    cameras: Query<(Entity, Option<&RenderTarget>), With<Camera>>,
) {
    let size = offscreen.size;
    let image = offscreen
        .image
        .get_or_insert_with(|| {
            let mut image =
                Image::new_target_texture(size.x, size.y, TextureFormat::Rgba8UnormSrgb, None);
            image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
            images.add(image)
        })
        .clone();
    for (camera, target) in &cameras {
        if !matches!(target, Some(RenderTarget::Image(_))) {
            commands
                .entity(camera)
                .insert(RenderTarget::Image(image.clone().into()));
        }
    }
}

fn save_frames(
    mut commands: Commands,
    mut offscreen: ResMut<Offscreen>,
    mut exit: MessageWriter<AppExit>,
) {
    offscreen.frame += 1;
    let Some(image) = offscreen.image.clone() else {
        return;
    };
    if offscreen.saved < offscreen.frames && offscreen.frame.is_multiple_of(offscreen.every) {
        let path = offscreen
            .dir
            .join(format!("frame_{:04}.png", offscreen.frame));
        commands
            .spawn(Screenshot::image(image))
            .observe(save_to_disk(path));
        offscreen.saved += 1;
    }
    // Saving takes a few frames.
    if offscreen.saved == offscreen.frames
        && offscreen.frame == offscreen.every * offscreen.frames + 10
    {
        println!(
            "saved {} frames into {}",
            offscreen.frames,
            offscreen.dir.display()
        );
        exit.write(AppExit::Success);
    }
}
