//! Cloth resting on colliders keeps its length: rings of cloth on a capsule's dome, strips
//! hanging over a bar.

use crate::common;

use bevy::math::{Quat, Vec3, Vec3A};
use bevy::math::{UVec2, Vec2};
use bevy_drape::cloth::{ClothModel, ClothSolver, GridDesc, SolverSettings};
use bevy_drape::collide::{RigidPose, SolverCollider, SolverShape};
use common::Rng;

const DT: f32 = 1.0 / 60.0;
const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);

/// Steps `sim` on `collider` for 4 s at the default settings and returns the largest strain
/// after the first second; the state stays finite.
fn settle(sim: &mut ClothSolver, collider: &SolverCollider) -> f32 {
    settle_with(sim, collider, &SolverSettings::default())
}

/// An upright capsule of `radius`, its centre at the origin and its dome's centre at y = 0.3.
fn upright_capsule(radius: f32, friction: f32) -> SolverCollider {
    let mut capsule = SolverCollider::fixed(
        SolverShape::Capsule {
            radius,
            half_length: 0.3,
        },
        RigidPose {
            translation: Vec3A::ZERO,
            rotation: Quat::IDENTITY,
        },
    );
    capsule.material.friction = friction;
    capsule
}

/// A flat annulus in the XZ plane at height `y`: `rings` rings of `sectors` particles from
/// radius `inner` to `outer` (see [`collar`]).
fn annulus(
    inner: f32,
    outer: f32,
    rings: u32,
    sectors: u32,
    y: f32,
    rng: &mut Rng,
) -> (Vec<Vec3>, Vec<u32>) {
    let profile: Vec<(f32, f32)> = (0..rings)
        .map(|r| (inner + (outer - inner) * r as f32 / (rings - 1) as f32, y))
        .collect();
    collar(&profile, sectors, rng)
}

/// Annuli of random size dropped onto vertical capsules of random radius and friction (0.5 to
/// 0.7: with less, a ring whose hole is near the capsule's width may tip over the top of the
/// dome and slide off, as 15 of 393 random rings at friction 0.3 to 0.45 did), their holes
/// narrower than the capsule: at the default budget each rests on the dome with its skirt
/// hanging round the capsule, and no edge is ever stretched past 7% after the first second
/// (over 393 random rings, up to 6.2%, the most with the narrowest holes). (Measured with
/// `cargo test --release --test contact_strain -- --nocapture` on the three cases an earlier
/// generator drew: their largest strain 3.5%, 4.3% and 4.1% with the structural edges solved
/// exactly while touching (the default); 7.5%, 6.7% and 6.3% without; the outer rings must fold
/// to hang round the capsule, which is why `a_collar_rests_on_a_dome_without_stretching` is the
/// garment that fits; 7.9%, 7.1% and 8.5% with the colliders projected last in each iteration;
/// without the rim limit of `rims.rs`, 20%, 23% and 53%.)
#[test]
fn a_ring_of_cloth_rests_on_a_dome_without_stretching() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    for case in 0..3 {
        let radius = 0.1 + 0.04 * rng.uniform();
        let inner = radius * (0.55 + 0.25 * rng.uniform());
        let top = 0.3 + radius;
        let (positions, indices) = annulus(inner, inner + 0.15, 8, 40, top + 0.02, &mut rng);
        let model = ClothModel::from_triangles(&positions, &indices, 0.25).unwrap();
        let mut sim = ClothSolver::new(model);
        let capsule = upright_capsule(radius, 0.5 + 0.2 * rng.uniform());
        let worst = settle(&mut sim, &capsule);
        let rim_height = sim.state().positions[..40].iter().map(|p| p.y).sum::<f32>() / 40.0;
        eprintln!(
            "case {case}: capsule radius {radius:.3}, hole {inner:.3}, friction {:.2}: \
             largest strain {worst:.4}, rim at {rim_height:.3} (dome top {top:.3})",
            capsule.material.friction
        );
        assert!(
            rim_height > 0.3 && rim_height < top,
            "case {case}: the rim at {rim_height} left the dome"
        );
        assert!(worst < 0.07, "case {case}: strain {worst}");
    }
}

/// Strips of random width and density dropped across horizontal capsule bars of random radius
/// and friction, off centre by a random amount (the longer side never heavier than the capstan
/// friction holds): at the default budget each comes to rest hanging over the bar, and no edge
/// is ever stretched past 2% after the first second. (Measured as above, on the three strips an
/// earlier generator drew: the largest strain 0.67%, 0.17% and 0.20%; without the structural
/// edges solved exactly while touching ([`SolverSettings::exact_edges`] `None`), 3.3%, 2.7% and
/// 4.4%, its worst edges compressed where the strip wraps the bar, bending against contact;
/// 16 x 2 without them 2.6%, 1.2% and 1.6%, 24 x 2 1.5%, 0.9% and 1.3%; 5.0%, 6.3% and 6.8% with
/// the colliders projected last in each iteration. A strip may slide towards its longer side
/// before it stops: it lands flat, and the friction that holds it grows with the angle it wraps
/// round the bar, `exp(mu theta)`, as its ends fall.)
#[test]
fn a_strip_hangs_over_a_bar_without_stretching() {
    for (case, worst) in hang_strips(&SolverSettings::default())
        .into_iter()
        .enumerate()
    {
        assert!(worst < 0.02, "case {case}: strain {worst}");
    }
}

/// Drops the three random strips on their bars at `settings`; each must come to rest on its
/// bar. Returns each one's largest strain after the first second.
fn hang_strips(settings: &SolverSettings) -> Vec<f32> {
    let mut rng = Rng(0x5851_f42d_4c95_7f2d);
    let mut strains = Vec::new();
    for case in 0..3 {
        let radius = 0.03 + 0.05 * rng.uniform();
        let friction = 0.4 + 0.4 * rng.uniform();
        let width = 0.08 + 0.06 * rng.uniform();
        let length = 1.2;
        let offset = (rng.uniform() - 0.5) * 0.2;
        let top = radius + 0.02;
        let grid = GridDesc {
            size: Vec2::new(width, length),
            vertices: UVec2::new(5, 49),
            orientation: Quat::IDENTITY,
            origin: Vec3::new(-width / 2.0, top, -length / 2.0 + offset),
        };
        let density = 0.05 + 0.2 * rng.uniform();
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, density).unwrap());
        let mut bar = SolverCollider::fixed(
            SolverShape::Capsule {
                radius,
                half_length: 0.5,
            },
            RigidPose {
                translation: Vec3A::ZERO,
                rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            },
        );
        bar.material.friction = friction;
        let worst = settle_with(&mut sim, &bar, settings);
        let x = &sim.state().positions;
        let highest = x.iter().map(|p| p.y).fold(f32::MIN, f32::max);
        let lowest = x.iter().map(|p| p.y).fold(f32::MAX, f32::min);
        let end = sim.edge_strains().fold(0.0, f32::max);
        eprintln!(
            "case {case}: bar radius {radius:.3}, friction {friction:.2}, width {width:.3}, \
             offset {offset:.3}, density {density:.3}: largest strain {worst:.4}, at the end \
             {end:.4}; the strip from {lowest:.3} to {highest:.3}"
        );
        assert!(
            highest > 0.0 && highest < top + 0.01,
            "case {case}: fell off"
        );
        strains.push(worst);
    }
    strains
}

/// A collar: `sectors` particles round each ring of the profile `(radius, height)`, each ring
/// turned by a random angle and its particles (but the top rim's) jittered along it.
fn collar(profile: &[(f32, f32)], sectors: u32, rng: &mut Rng) -> (Vec<Vec3>, Vec<u32>) {
    let mut positions = Vec::new();
    for (r, &(radius, y)) in profile.iter().enumerate() {
        let turn = rng.uniform() * std::f32::consts::TAU / sectors as f32 * 0.5;
        for s in 0..sectors {
            let jitter = if r == 0 {
                0.0
            } else {
                (rng.uniform() - 0.5) * 0.3
            };
            let a = (s as f32 + jitter) / sectors as f32 * std::f32::consts::TAU + turn;
            positions.push(Vec3::new(radius * a.cos(), y, radius * a.sin()));
        }
    }
    let rings = profile.len() as u32;
    let mut indices = Vec::new();
    for r in 0..rings - 1 {
        for s in 0..sectors {
            let a = r * sectors + s;
            let b = r * sectors + (s + 1) % sectors;
            indices.extend([a, a + sectors, b, b, a + sectors, b + sectors]);
        }
    }
    (positions, indices)
}

/// Steps `sim` on `collider` for 4 s at `settings` and returns the largest strain after the
/// first second; the state stays finite.
fn settle_with(sim: &mut ClothSolver, collider: &SolverCollider, settings: &SolverSettings) -> f32 {
    sim.set_colliders(std::slice::from_ref(collider)).unwrap();
    let mut worst = 0.0f32;
    for step in 0..240 {
        sim.step(settings, GRAVITY, DT).unwrap();
        if step >= 60 {
            worst = worst.max(sim.edge_strains().fold(0.0, f32::max));
        }
    }
    assert!(sim.is_finite());
    worst
}

/// A collar that fits the body: a cone band touching a capsule's dome along a circle at a
/// random polar angle, turning into a tube 5% wider than the capsule, 2.5 cm edges (a flat
/// ring cannot hang round a capsule without folding: its outer rings must shrink by half).
/// It rests on the dome carrying the tube's weight as hoop tension in the rings next to its
/// rim. Measured (`cargo test --release --test contact_strain -- --nocapture`): the largest
/// strain after the first second at the default budget (8 x 2, the structural edges solved
/// exactly while touching, [`SolverSettings::exact_edges`]) 0.25-0.43%, held below 2%.
/// Without the exact edges, the rings next to the rim limited as it is (`rims.rs`) hold it at
/// 3.8-4.6% at 8 x 2 and 0.58-0.69% at 16 x 4; with only the rim limited, 5.4% and 1.9%
/// (case 0). (Those figures on the three cases an earlier generator drew; over 393 random
/// collars, 0.09-1.6% at the default budget, 2.6-7.3% without the exact edges at 8 x 2, the
/// most where the collar touches the dome lowest, at 35 to 45 degrees, held below 8%, and
/// 0.41-1.3% at 16 x 4.)
#[test]
fn a_collar_rests_on_a_dome_without_stretching() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let iterated = SolverSettings {
        exact_edges: None,
        ..SolverSettings::default()
    };
    let more_iterated = SolverSettings {
        substeps: 16,
        iterations: 4,
        ..iterated
    };
    for case in 0..3 {
        let radius = 0.1 + 0.04 * rng.uniform();
        let polar = (35.0 + 25.0 * rng.uniform()).to_radians();
        let friction = 0.3 + 0.4 * rng.uniform();
        let edge = 0.025;
        let (s, c) = polar.sin_cos();
        // The cone touching the dome (centre at y = 0.3) along the circle at `polar`, from one
        // edge above that circle down to the tube's radius, 1 cm above the dome.
        let touch = (radius * s, 0.3 + radius * c);
        let tube = radius * 1.05 + 0.02;
        let down = (tube - touch.0) / c;
        let mut profile = Vec::new();
        let mut t = -edge;
        while t < down {
            profile.push((touch.0 + c * t, touch.1 - s * t + 0.01));
            t += edge;
        }
        let start = profile.last().map_or(touch.1, |p| p.1);
        profile.extend((1..=12).map(|k| (tube, start - edge * k as f32)));
        let sectors = (std::f32::consts::TAU * radius / edge) as u32;
        let (positions, indices) = collar(&profile, sectors, &mut rng);
        let capsule = upright_capsule(radius, friction);
        for (settings, bound) in [
            (SolverSettings::default(), 0.02),
            (iterated, 0.08),
            (more_iterated, 0.015),
        ] {
            let model = ClothModel::from_triangles(&positions, &indices, 0.25).unwrap();
            let mut sim = ClothSolver::new(model);
            let worst = settle_with(&mut sim, &capsule, &settings);
            let top = sim.state().positions[..sectors as usize]
                .iter()
                .map(|p| p.y)
                .fold(f32::MIN, f32::max);
            eprintln!(
                "collar {case}: capsule radius {radius:.3}, touching at {:.0} deg, friction \
                 {friction:.2}, {} x {}{}: largest strain {worst:.4}, rim up to {top:.3}",
                polar.to_degrees(),
                settings.substeps,
                settings.iterations,
                if settings.exact_edges.is_some() {
                    ", exact edges"
                } else {
                    ""
                },
            );
            assert!(
                top > 0.3 && top < 0.3 + radius + 0.02,
                "case {case}: left the dome"
            );
            assert!(
                worst < bound,
                "case {case}, {} x {}: strain {worst}",
                settings.substeps,
                settings.iterations
            );
        }
    }
}
