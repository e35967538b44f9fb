//! Whether Bevy's renderer can start here: a graphics adapter for the backends it would try.
//!
//! Bevy's renderer panics ("Unable to find a GPU!") when wgpu finds no adapter, for example
//! on a machine with no GPU and no Vulkan driver. [`find_graphics_adapter`] asks wgpu the same
//! question first, so an App can say why and do something else (run headless) instead.

/// The adapter wgpu finds for the backends Bevy's renderer would use (`WGPU_BACKEND`
/// respected, all native backends otherwise): its name and backend, or, if there is none,
/// the reason in one line with what to install for software rendering.
pub fn find_graphics_adapter() -> Result<String, String> {
    let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all());
    let descriptor = wgpu::InstanceDescriptor {
        backends,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    }
    .with_env();
    let instance = wgpu::Instance::new(descriptor);
    let adapters = bevy::tasks::block_on(instance.enumerate_adapters(backends));
    match adapters.first() {
        Some(adapter) => {
            let info = adapter.get_info();
            Ok(format!("{} ({:?})", info.name, info.backend))
        }
        None => Err(
            "no graphics adapter found (no GPU, no Vulkan driver): for software \
                     rendering install Mesa's Vulkan driver (Debian, Ubuntu: apt-get install \
                     mesa-vulkan-drivers)"
                .to_string(),
        ),
    }
}
