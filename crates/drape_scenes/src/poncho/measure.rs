//! What the headless run of the main scene measures after every step (`run.rs`): the
//! ponchos' strain, penetration, centroid, hem and crossings, and those between each shawl
//! and the poncho over it.

use bevy::prelude::*;

use super::run::{PonchoRun, STRAIN_BIN};
use super::{Poncho, PonchoScene, SETTLE_SECONDS, Shawl};

/// Adds to [`PonchoRun::crossings`] those of `poncho` (simulated by `sim`) since the last step.
fn count_crossings(
    run: &mut PonchoRun,
    poncho: Entity,
    sim: &bevy_drape::cloth::ClothSolver,
    thickness: f32,
) {
    use bevy_drape::cloth::{TwoPoses, count_self_crossings};
    let x = &sim.state().positions;
    let k = match run
        .previous_positions
        .iter()
        .position(|(e, _)| *e == poncho)
    {
        Some(k) => k,
        None => {
            run.previous_positions.push((poncho, x.clone()));
            return;
        }
    };
    let before = &mut run.previous_positions[k].1;
    if before.len() == x.len() {
        run.crossings += count_self_crossings(
            TwoPoses { before, after: x },
            &sim.model().triangles,
            thickness,
        );
    }
    before.clone_from(x);
}

/// Adds to [`PonchoRun::layer_crossings`] those between each shawl and the poncho over it
/// since the last step, and takes the shawls' strain.
fn measure_layers(world: &mut World, run: &mut PonchoRun) {
    use bevy_drape::cloth::plugin::{Cloth, ClothSimulation};
    use bevy_drape::cloth::{TwoPoses, count_crossings_between};
    let thickness = world
        .get_resource::<PonchoScene>()
        .map_or(0.0, |scene| scene.solver.thickness);
    let mut shawls = world.query_filtered::<(Entity, &Cloth, &ClothSimulation), With<Shawl>>();
    let mut ponchos = world.query_filtered::<(&Cloth, &ClothSimulation), With<Poncho>>();
    for (shawl, cloth, inner) in shawls.iter(world) {
        let Some((_, outer)) = ponchos
            .iter(world)
            .find(|(c, _)| c.follow.is_some() && c.follow == cloth.follow)
        else {
            continue;
        };
        let (inner, outer) = (inner.solver(), outer.solver());
        run.finite &= inner.is_finite();
        if run.steps > 60 {
            run.shawl_strain_max_after_first_second = run
                .shawl_strain_max_after_first_second
                .max(inner.strain().max);
        }
        let now = [&inner.state().positions, &outer.state().positions];
        let Some(k) = run.previous_layers.iter().position(|(e, _)| *e == shawl) else {
            run.previous_layers
                .push((shawl, [now[0].clone(), now[1].clone()]));
            continue;
        };
        let before = &mut run.previous_layers[k].1;
        if before[0].len() == now[0].len() && before[1].len() == now[1].len() {
            let a = TwoPoses {
                before: &before[0],
                after: now[0],
            };
            let b = TwoPoses {
                before: &before[1],
                after: now[1],
            };
            run.layer_crossings +=
                count_crossings_between(a, b, &outer.model().triangles, thickness)
                    + count_crossings_between(b, a, &inner.model().triangles, thickness);
        }
        before[0].clone_from(now[0]);
        before[1].clone_from(now[1]);
    }
}

impl PonchoRun {
    /// Measures the scene after a step into these figures.
    pub(super) fn measure(&mut self, app: &mut App) {
        measure(app, self);
    }
}

fn measure(app: &mut App, run: &mut PonchoRun) {
    use bevy_drape::collide::SolverShape;
    let settled = run.steps as f32 / 60.0 > SETTLE_SECONDS;
    let world = app.world_mut();
    measure_layers(world, run);
    run.divergences += world
        .resource_mut::<Messages<bevy_drape::cloth::plugin::ClothDiverged>>()
        .drain()
        .count() as u32;
    // Every poncho is measured against the chest of the character wearing it.
    let mut transforms =
        bevy::ecs::system::SystemState::<bevy::transform::helper::TransformHelper>::new(world);
    let wearers: Vec<(Entity, Option<Entity>)> = world
        .query_filtered::<(Entity, &bevy_drape::cloth::plugin::Cloth), With<Poncho>>()
        .iter(world)
        .map(|(poncho, cloth)| (poncho, cloth.follow))
        .collect();
    let chests: Vec<(Entity, Option<Vec3>)> = wearers
        .iter()
        .map(|&(poncho, wearer)| {
            let chest = (|| {
                let bone = world
                    .get::<bevy_drape::skeleton::plugin::SkeletonBones>(wearer?)?
                    .get("chest")?;
                let helper = transforms.get(world).ok()?;
                helper
                    .compute_global_transform(bone)
                    .ok()
                    .map(|g| g.translation())
            })();
            (poncho, chest)
        })
        .collect();
    let thickness = world
        .get_resource::<PonchoScene>()
        .map_or(0.0, |scene| scene.solver.thickness);
    let mut ponchos =
        world.query_filtered::<&bevy_drape::cloth::plugin::ClothSimulation, With<Poncho>>();
    run.asleep = ponchos.iter(world).filter(|s| s.is_asleep()).count();
    for (poncho, chest) in chests {
        let Ok(simulation) = ponchos.get(world, poncho) else {
            continue;
        };
        let sim = simulation.solver();
        let x = &sim.state().positions;
        run.particles = x.len();
        count_crossings(run, poncho, sim, thickness);
        run.finite &= sim.is_finite();
        run.frozen |= simulation.is_frozen();

        for c in sim.colliders() {
            if matches!(c.shape, SolverShape::Plane) {
                continue;
            }
            for &p in x {
                if let Some(d) = c.signed_distance(p, 0.0) {
                    run.deepest_penetration = run.deepest_penetration.max(-d);
                }
            }
        }
        if run.steps > 60 {
            run.strain_max_after_first_second =
                run.strain_max_after_first_second.max(sim.strain().max);
        }
        if !settled {
            continue;
        }
        let (mut stretch, mut compression) = (0.0f32, 0.0f32);
        for extension in sim.edge_extensions() {
            stretch = stretch.max(extension);
            compression = compression.max(-extension);
            let bin = ((extension.abs() / STRAIN_BIN) as usize).min(run.strain_histogram.len() - 1);
            run.strain_histogram[bin] += 1;
        }
        run.step_max_strain.push(stretch.max(compression));
        run.step_max_stretch.push(stretch);
        run.step_max_compression.push(compression);
        run.max_kinetic_energy = run.max_kinetic_energy.max(sim.kinetic_energy());
        let rest = &sim.model().rest_positions;
        let half_side = rest
            .iter()
            .fold(0.0f32, |m, p| m.max(p.x.abs()).max(p.z.abs()));
        let (sum, count) = rest
            .iter()
            .zip(x)
            .filter(|(r, _)| r.x.abs().max(r.z.abs()) > half_side - 1e-3)
            .fold((0.0, 0), |(sum, count), (_, p)| (sum + p.y, count + 1));
        if count > 0 {
            run.hem_heights.push(sum / count as f32);
        }
        if let Some(chest) = chest
            && !x.is_empty()
        {
            let centroid: Vec3 =
                Vec3::from(x.iter().copied().sum::<bevy::math::Vec3A>()) / x.len() as f32;
            let offset = (centroid - chest).with_y(0.0).length();
            run.max_centroid_offset = run.max_centroid_offset.max(offset);
            run.centroid_offsets.push(offset);
        }
    }
}
