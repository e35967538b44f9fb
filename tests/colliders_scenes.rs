//! The standard collision scenes: S2, a sheet draped on a sphere (woven, and with rigid
//! diagonals), and a mass-spring cloth thrown at spheres, the ground and walls.

use bevy::math::{Vec2, Vec3};
use bevy_drape::cloth::{ClothSolver, SolverSettings};
use drape_scenes::scenes::{Drape, lowest_height};

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
