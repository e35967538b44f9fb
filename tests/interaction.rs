//! Dragging and picking, headless: a grabbed particle goes to its goal and the cloth stays
//! finite and bounded even when yanked 2 m in one step; density and reset; ray picking.

use bevy::math::{Vec3, Vec3A};
use bevy_drape::cloth::{
    ClothModel, ClothSolver, DivergenceBounds, GridDesc, SolverMethod, SolverSettings,
};
use bevy_drape::interact::pick::{drag_point, pick_particle};
use drape_scenes::scenes::{DENSITY, FRAME_RATE, GRAVITY, HangingCloth, lowest_height};

const DT: f32 = 1.0 / FRAME_RATE;

#[test]
fn a_dragged_particle_reaches_its_goal_and_the_cloth_stays_bounded_when_yanked() {
    // A free sheet lying on the ground, grabbed at its centre and yanked 2 m up and sideways
    // in one step, then held there. (Mass-spring with its default 1000 N/m springs stretches
    // 800% under such a yank and is reported as diverged, and the hybrid without long-range
    // attachments 180%, its structural edges alone carrying the sheet from one particle:
    // they get a 0.3 m drag instead.)
    for (method, yank) in [
        (SolverMethod::Xpbd, Vec3::new(1.2, 1.6, 0.0)),
        (
            SolverMethod::Hybrid { long_range: true },
            Vec3::new(1.2, 1.6, 0.0),
        ),
        (
            SolverMethod::Hybrid { long_range: false },
            Vec3::new(0.0, 0.3, 0.0),
        ),
        (SolverMethod::MassSpring, Vec3::new(0.0, 0.3, 0.0)),
    ] {
        let grid = GridDesc::square(1.0, 16, Vec3::new(0.0, 0.01, 0.0));
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, DENSITY).unwrap());
        sim.set_colliders(&[bevy_drape::collide::SolverCollider::ground(
            0.0,
            Default::default(),
        )])
        .unwrap();
        let settings = SolverSettings {
            method,
            auto_substeps: true,
            ..Default::default()
        };
        for _ in 0..10 {
            sim.step(&settings, GRAVITY, DT).unwrap();
        }
        let centre = grid.index(8, 8);
        let mass_before = sim.state().inverse_masses[centre as usize];
        assert!(sim.grab(centre));
        assert_eq!(sim.state().inverse_masses[centre as usize], 0.0);
        let start = Vec3::from(sim.state().positions[centre as usize]);
        let goal = start + yank;
        sim.drag_to(goal);
        sim.step(&settings, GRAVITY, DT).unwrap();
        let at = Vec3::from(sim.state().positions[centre as usize]);
        assert!(
            at.distance(goal) < 1e-5,
            "{}: {at} vs {goal}",
            method.name()
        );
        let mut worst_strain = 0.0f32;
        for _ in 0..60 {
            sim.step(&settings, GRAVITY, DT).unwrap();
            assert!(sim.is_finite());
            assert_eq!(
                sim.divergence(&DivergenceBounds::default()),
                None,
                "{}",
                method.name()
            );
            worst_strain = worst_strain.max(sim.strain().max);
        }
        let settled = sim.strain().max;
        println!(
            "{}: worst strain in the second after the yank {:.1}%, at its end {:.2}%",
            method.name(),
            worst_strain * 100.0,
            settled * 100.0
        );
        assert!(worst_strain < 0.5 && settled < 0.1);
        // The sheet hangs from the grabbed particle (or, lifted 0.3 m, lies around it).
        let lowest = lowest_height(&sim);
        assert!(lowest > goal.y - 0.8, "{lowest}");
        sim.release();
        assert_eq!(sim.grabbed(), None);
        assert_eq!(sim.state().inverse_masses[centre as usize], mass_before);
    }
}

#[test]
fn changing_density_changes_the_total_mass_and_reset_restores_the_initial_state() {
    let scene = HangingCloth { n: 12 };
    let mut sim = scene.build();
    let initial = sim.state().clone();
    assert!((sim.model().total_mass() - DENSITY).abs() < 1e-6);
    sim.set_density(0.35).unwrap();
    assert!((sim.model().total_mass() - 0.35).abs() < 1e-6);
    assert!(sim.set_density(-1.0).is_err());
    let settings = SolverSettings::default();
    sim.grab(5);
    for _ in 0..20 {
        sim.step(&settings, GRAVITY, DT).unwrap();
    }
    assert_ne!(sim.state().positions, initial.positions);
    sim.set_density(DENSITY).unwrap();
    sim.reset();
    assert_eq!(sim.state(), &initial);
    assert_eq!(sim.grabbed(), None);
}

#[test]
fn a_ray_through_a_particle_picks_it_and_a_ray_that_misses_picks_nothing() {
    let positions: Vec<Vec3A> = (0..25)
        .map(|i| Vec3A::new((i % 5) as f32 * 0.1, 1.0, (i / 5) as f32 * 0.1))
        .collect();
    // Straight down through particle 7 from above.
    let hit = pick_particle(&positions, Vec3::new(0.2, 3.0, 0.1), Vec3::NEG_Y, 0.03).unwrap();
    assert_eq!(hit.particle, 7);
    assert!((hit.depth - 2.0).abs() < 1e-5);
    // Slanted through particle 18 from a camera off to the side.
    let target = Vec3::from(positions[18]);
    let eye = Vec3::new(-1.0, 2.5, 2.0);
    let hit = pick_particle(&positions, eye, target - eye, 0.03).unwrap();
    assert_eq!(hit.particle, 18);
    // Beside the sheet, or pointing away: nothing.
    assert!(pick_particle(&positions, Vec3::new(2.0, 3.0, 0.1), Vec3::NEG_Y, 0.03).is_none());
    assert!(pick_particle(&positions, Vec3::new(0.2, 3.0, 0.1), Vec3::Y, 0.03).is_none());
    assert!(pick_particle(&positions, Vec3::new(0.2, 3.0, 0.1), Vec3::ZERO, 0.03).is_none());
}

#[test]
fn a_drag_moves_the_particle_in_the_plane_through_its_grab_point_facing_the_camera() {
    // Random cameras looking at random grab points, the cursor's ray through random points
    // of the view: the drag point lies on the ray and in the plane through the grab point at
    // right angles to the view, so it keeps the depth the particle was grabbed at.
    let mut rng = crate::common::Rng(17);
    let mut checked = 0;
    for _ in 0..500 {
        let mut v = || {
            Vec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            )
        };
        let (eye, anchor, aim, cursor) = (v(), v(), v() * 0.1, v());
        if (anchor + aim - eye).length() < 0.1 {
            continue;
        }
        let view = (anchor + aim - eye).normalize();
        let direction = cursor - eye;
        match drag_point(eye, direction, anchor, view) {
            Some(p) => {
                // On the ray, in front of the eye, at the grab point's depth.
                // (Relative to the distance: a ray nearly along the plane meets it far away.)
                let along = (p - eye).dot(direction.normalize());
                let tolerance = 1e-4 * (1.0 + along);
                assert!(along >= 0.0);
                let off = (p - eye).reject_from(direction).length();
                assert!(off < tolerance, "{p} {off} m off the ray");
                let depth = (p - eye).dot(view) - (anchor - eye).dot(view);
                assert!(depth.abs() < tolerance, "{p} {depth} m off the plane");
                checked += 1;
            }
            // Only a ray that points away from the plane (or along it) misses it.
            None => assert!(direction.dot(view) * (anchor - eye).dot(view) <= 1e-6),
        }
    }
    assert!(checked > 200, "{checked}");
    // Straight through the grab point, the point is the grab point; along the plane, none.
    let eye = Vec3::new(0.0, 1.0, 5.0);
    let anchor = Vec3::new(0.3, 1.2, 0.0);
    let p = drag_point(eye, anchor - eye, anchor, Vec3::NEG_Z).unwrap();
    assert!(p.distance(anchor) < 1e-5);
    assert!(drag_point(eye, Vec3::X, anchor, Vec3::NEG_Z).is_none());
    assert!(drag_point(eye, Vec3::X, anchor, Vec3::ZERO).is_none());
    assert!(drag_point(Vec3::NAN, Vec3::NEG_Z, anchor, Vec3::NEG_Z).is_none());
}

#[test]
fn a_drag_cannot_pull_a_pinned_cloth_apart() {
    let scene = HangingCloth { n: 16 };
    let mut sim = scene.build();
    let settings = SolverSettings::default();
    let corner = scene.corner();
    sim.grab(corner);
    let mut worst = 0.0f32;
    for k in 0..120 {
        // Pull ever farther away from the pins, to 6 m.
        sim.drag_to(Vec3::new(1.0 + 0.05 * k as f32, 1.0, 1.0 + 0.05 * k as f32));
        sim.step(&settings, GRAVITY, DT).unwrap();
        worst = worst.max(sim.strain().max);
        assert_eq!(sim.divergence(&DivergenceBounds::default()), None);
    }
    // The corner stops where the cloth is taut: its rest distance from the nearer pin.
    let at = Vec3::from(sim.state().positions[corner as usize]);
    let pin = Vec3::from(sim.state().positions[scene.pins()[1] as usize]);
    println!(
        "corner {:.4} m from the pin (rest 1 m), worst strain {:.2}%",
        at.distance(pin),
        worst * 100.0
    );
    assert!(at.distance(pin) <= 1.0 + 1e-4);
    assert!(worst < 0.05);
}
