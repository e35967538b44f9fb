//! Cloths that collide with each other: [`ClothLayers`] names them, and each group is
//! stepped as one solve ([`LayerSolver`]) built here once all its cloths are built.

use bevy::log::warn;
use bevy::prelude::*;

use super::components::{Cloth, ClothBuildError, ClothSimulation};
use crate::cloth::sim::{ClothSolver, LayerSolver};

/// Cloths that collide with each other, innermost first: a shirt under a poncho, a cape over
/// both. They are stepped together as layers of one solve, every particle of one kept on its
/// side of the others' triangles near it (the vertex-triangle constraint of
/// [`SelfCollisionMethod::Triangles`](crate::cloth::SelfCollisionMethod::Triangles), which
/// also holds each cloth apart from itself), so a contact moves both cloths by their masses.
///
/// Put it on any entity, typically the character that wears them. The solve takes the first
/// (innermost) cloth's solver settings, colliders, followed entity and wind for all of them;
/// each cloth keeps its own pins, attachments, mass and mesh. Spawn the layers in their order
/// (each outside the one before, apart by at least [`SolverSettings::thickness`]): a particle
/// is kept on the side it starts on. Layered cloths neither sleep nor freeze at a level of
/// detail, and water in one of them is not stepped.
///
/// A listed entity that is not a cloth (or no longer exists), a cloth that cannot be built, a
/// cloth listed twice or in two groups is left out with a warning naming it; with fewer than
/// two cloths left, each steps alone.
///
/// [`SolverSettings::thickness`]: crate::cloth::SolverSettings::thickness
///
/// ```
/// use bevy::prelude::*;
/// use bevy_drape::prelude::*;
///
/// fn dress(mut commands: Commands, character: Entity, shirt: Entity, poncho: Entity) {
///     commands
///         .entity(character)
///         .insert(ClothLayers(vec![shirt, poncho]));
/// }
/// # bevy::ecs::system::assert_is_system(|commands: Commands| {
/// #     dress(commands, Entity::PLACEHOLDER, Entity::PLACEHOLDER, Entity::PLACEHOLDER)
/// # });
/// ```
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothLayers(pub Vec<Entity>);

/// The solve of a [`ClothLayers`] (on the same entity).
#[derive(Component, Debug, Default)]
pub(crate) struct LayeredSolve {
    /// The list the solve was made for.
    listed: Vec<Entity>,
    /// The cloths in the solve, innermost first.
    pub(crate) members: Vec<Entity>,
    /// The solve, with at least two cloths built.
    pub(crate) solver: Option<LayerSolver>,
}

/// A listed cloth and whether it is built.
type ListedCloth<'a> = (
    Option<Ref<'a, ClothSimulation>>,
    Has<ClothBuildError>,
    Has<Cloth>,
);

/// Builds the solve of every [`ClothLayers`] whose cloths are built, again when its list or
/// one of its cloths changes; warns (once per change) about what is left out.
pub(super) fn build_layers(
    mut commands: Commands,
    mut groups: Query<(Entity, Ref<ClothLayers>, Option<&mut LayeredSolve>)>,
    cloths: Query<ListedCloth>,
    unlisted: Query<Entity, (With<LayeredSolve>, Without<ClothLayers>)>,
    // (cloth, its group) so far, and one group's cloths built now: kept, so that a step
    // allocates nothing while the layers are as they were.
    mut claimed: Local<Vec<(Entity, Entity)>>,
    mut members: Local<Vec<Entity>>,
) {
    // A group whose list was taken away: its cloths step alone again.
    for group in &unlisted {
        commands.entity(group).remove::<LayeredSolve>();
    }
    claimed.clear();
    for (group, layers, solve) in &mut groups {
        let mut left_out = Vec::new();
        members.clear();
        let (mut waiting, mut rebuilt) = (false, false);
        for &cloth in &layers.0 {
            if members.contains(&cloth) {
                left_out.push(format!(
                    "cloth {cloth} is listed twice (its first place counts)"
                ));
                continue;
            }
            if let Some((_, other)) = claimed.iter().find(|(c, _)| *c == cloth) {
                left_out.push(format!("cloth {cloth} is a layer of {other} already"));
                continue;
            }
            match cloths.get(cloth) {
                Ok((Some(simulation), _, true)) => {
                    rebuilt |= simulation.is_added();
                    members.push(cloth);
                }
                Ok((None, false, true)) => waiting = true,
                Ok((_, true, true)) => left_out.push(format!("cloth {cloth} cannot be built")),
                _ => left_out.push(format!("{cloth} is not a cloth (or no longer exists)")),
            }
        }
        claimed.extend(members.iter().map(|&m| (m, group)));
        // A new group's solve is built in this step already: its cloths are not stepped
        // alone first.
        let mut fresh = None;
        let solve = match solve {
            Some(solve) => solve.into_inner(),
            None => fresh.insert(LayeredSolve::default()),
        };
        update_solve(
            group,
            &layers.0,
            solve,
            (&members, left_out),
            (waiting, rebuilt),
            &cloths,
        );
        if let Some(solve) = fresh {
            commands.entity(group).insert(solve);
        }
    }
}

/// Updates the solve of the group `group` listing `listed` to its cloths built now
/// (`members`, and what is `left_out`): built again when its cloths changed, once none is
/// `waiting` to be built; warned about once per change.
fn update_solve(
    group: Entity,
    listed: &[Entity],
    solve: &mut LayeredSolve,
    (members, left_out): (&[Entity], Vec<String>),
    (waiting, rebuilt): (bool, bool),
    cloths: &Query<ListedCloth>,
) {
    let changed = listed != solve.listed || members != solve.members.as_slice();
    if changed && !left_out.is_empty() {
        warn!(
            "cloth layers {group}: {}; left out of the layers",
            left_out.join("; ")
        );
    }
    if changed {
        solve.listed.clear();
        solve.listed.extend_from_slice(listed);
        solve.members.clear();
        solve.members.extend_from_slice(members);
        solve.solver = None;
    }
    if waiting || !(changed || rebuilt || solve.solver.is_none()) {
        return;
    }
    solve.solver = None;
    if members.len() < 2 {
        if changed {
            warn!(
                "cloth layers {group}: {} cloth(s) to layer; each steps alone",
                members.len()
            );
        }
        return;
    }
    let solvers: Vec<&ClothSolver> = members
        .iter()
        .filter_map(|&m| {
            cloths
                .get(m)
                .ok()
                .and_then(|(s, ..)| s.map(|s| &s.into_inner().sim))
        })
        .collect();
    match LayerSolver::new(&solvers) {
        Ok(solver) => {
            for (a, b) in solver.tangled_layers() {
                warn!(
                    "cloth layers {group}: cloths {} and {} start through each other; \
                     each particle is kept on the side it starts on",
                    members[a], members[b]
                );
            }
            solve.solver = Some(solver);
        }
        Err(err) => warn!("cloth layers {group}: {err}; each cloth steps alone"),
    }
}
