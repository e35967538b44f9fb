//! The solver's step allocates nothing: every buffer is made when the cloth is built.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use bevy_drape::cloth::SolverSettings;
use drape_scenes::scenes::{GRAVITY, HangingCloth};

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Whether this thread's allocations count: only the test's own thread, so that the test
    /// harness allocating on its threads does not count.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: forwards to the system allocator, only counting calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn stepping_allocates_nothing() {
    let scene = HangingCloth { n: 12 };
    let mut sim = scene.build();
    sim.set_colliders(&[bevy_drape::collide::SolverCollider::ground(
        0.5,
        Default::default(),
    )])
    .unwrap();
    let settings = SolverSettings::default();
    sim.step(&settings, GRAVITY, 1.0 / 60.0).unwrap();
    COUNTING.with(|c| c.set(true));
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for frame in 0..30 {
        for pin in scene.pins() {
            let target = sim.model().rest_positions[pin as usize];
            sim.set_pin_target(pin, target + bevy::math::Vec3::X * (frame as f32 * 0.01));
        }
        sim.step(&settings, GRAVITY, 1.0 / 60.0).unwrap();
    }
    let _ = sim.strain();
    let after = ALLOCATIONS.load(Ordering::Relaxed);
    COUNTING.with(|c| c.set(false));
    assert_eq!(after, before);
}

#[test]
fn stepping_in_gusty_wind_with_sources_allocates_nothing() {
    use bevy_drape::cloth::{AirSettings, Falloff, Gusts, WindField, WindShape, WindSourceDesc};
    let scene = HangingCloth { n: 12 };
    let mut sim = scene.build();
    let settings = SolverSettings {
        air: Some(AirSettings::default()),
        ..SolverSettings::default()
    };
    let wind = WindField {
        velocity: bevy::math::Vec3::new(0.0, 0.0, 6.0),
        gusts: Gusts {
            strength: 2.0,
            ..Gusts::default()
        },
        sources: vec![WindSourceDesc {
            position: bevy::math::Vec3::new(0.5, 1.0, -1.0),
            shape: WindShape::Directional {
                direction: bevy::math::Vec3::Z,
            },
            speed: 5.0,
            radius: 2.0,
            falloff: Falloff::Smooth,
        }],
    };
    sim.set_wind(&wind, 0.0);
    sim.step(&settings, GRAVITY, 1.0 / 60.0).unwrap();
    COUNTING.with(|c| c.set(true));
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for frame in 1..30 {
        sim.set_wind(&wind, frame as f32 / 60.0);
        sim.step(&settings, GRAVITY, 1.0 / 60.0).unwrap();
    }
    let after = ALLOCATIONS.load(Ordering::Relaxed);
    COUNTING.with(|c| c.set(false));
    assert_eq!(after, before);
    assert!(sim.is_finite());
}
