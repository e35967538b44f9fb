//! Self-collision in a headless App: the sheet-drop scene with and without it.

use crate::common;

use bevy::prelude::*;
use bevy_drape::prelude::*;
use common::{Headless, add_grid};
use drape_scenes::scenes::{SheetDrop, closest_non_adjacent};

/// Drops the sheet for 3 s in an App and returns, over every frame, the closest two particles
/// that share no edge came, in grid spacings (infinite if never within one spacing), and the
/// most pairs held apart in a step. The whole run counts, not its last frame: the folds the
/// sheet makes when it lands may slide out flat again later, or not, depending on the last
/// bits of the arithmetic.
fn drop_sheet(self_collision: bool) -> (f32, usize) {
    let mut app = Headless::new().seconds_per_update(1.0 / 60.0).build();
    let scene = SheetDrop { n: 20 };
    let mesh = add_grid(&mut app, &scene.grid());
    let settings = ClothSettings {
        solver: SheetDrop::settings(self_collision),
        ..default()
    };
    let cloth = app
        .world_mut()
        .spawn((Mesh3d(mesh), Cloth::default(), settings))
        .id();
    app.world_mut().spawn(
        ClothCollider::plane()
            .with_friction(SheetDrop::FRICTION)
            .with_margin(0.0),
    );
    let spacing = 1.0 / (scene.n - 1) as f32;
    let (mut gap, mut contacts) = (f32::INFINITY, 0);
    for _ in 0..181 {
        app.update();
        let Some(sim) = app
            .world()
            .get::<ClothSimulation>(cloth)
            .map(|c| c.solver())
        else {
            continue;
        };
        let g = closest_non_adjacent(sim, spacing).unwrap_or(f32::INFINITY) / spacing;
        gap = gap.min(g);
        contacts = contacts.max(sim.self_contact_count());
    }
    let sim = app.world().get::<ClothSimulation>(cloth).unwrap().solver();
    assert!(sim.is_finite());
    (gap, contacts)
}

#[test]
fn with_self_collision_the_folds_of_a_dropped_sheet_stay_apart_and_without_it_they_pass_through() {
    let (gap_on, contacts_on) = drop_sheet(true);
    let (gap_off, _) = drop_sheet(false);
    // The folds touch: particles are held apart, at nearly one spacing, all the way.
    assert!(contacts_on > 0, "the sheet piles up onto itself");
    assert!(
        gap_on > 0.5,
        "self-collision on: closest gap {gap_on} spacings"
    );
    assert!(
        gap_off < 0.5,
        "self-collision off: closest gap {gap_off} spacings"
    );
}
