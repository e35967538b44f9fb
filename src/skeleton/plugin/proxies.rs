//! The collision proxies of a character's bones ([`BoneColliders`]): spawned with the
//! bones of a `Skeleton`, or attached by name to the joints of any hierarchy (a glTF scene).

use bevy::log::warn;
use bevy::prelude::*;

use crate::collide::components::ClothCollider;

use super::components::*;

/// Marks an entity without a [`Skeleton`] whose [`BoneColliders`] have been attached to its
/// descendants by name: the joints they hang from.
#[derive(Component, Clone, Debug, Default)]
pub(crate) struct ProxiesAttachedByName(Vec<Entity>);

/// Spawns the collision proxies of `colliders` (of character `entity`) on the bone entities
/// `bone` finds by name.
pub(super) fn spawn_proxies(
    commands: &mut Commands,
    entity: Entity,
    colliders: &BoneColliders,
    bone: impl Fn(&str) -> Option<Entity>,
) {
    for proxy in &colliders.proxies {
        let Some(bone) = bone(&proxy.bone) else {
            warn!(
                "character {entity}: collision proxy on bone {:?}, which it does not have",
                proxy.bone
            );
            continue;
        };
        let mut collider = ClothCollider::capsule(proxy.radius, proxy.half_length);
        collider.material = colliders.material;
        collider.margin = colliders.margin;
        commands.spawn((
            Name::new(format!("{} proxy", proxy.bone)),
            collider,
            Transform::from_translation(proxy.centre).with_rotation(proxy.rotation()),
            BoneProxyOf(entity),
            ChildOf(bone),
        ));
    }
}

/// Characters whose [`BoneColliders`] changed after their proxies were spawned.
type ChangedAfterSpawn = (
    Changed<BoneColliders>,
    Or<(With<SkeletonBones>, With<ProxiesAttachedByName>)>,
);

/// Characters without a [`Skeleton`] whose proxies are not attached yet.
type NotYetAttached = (Without<Skeleton>, Without<ProxiesAttachedByName>);

/// Spawns the proxies again of every character whose [`BoneColliders`] changed after they were
/// spawned (a colliders file reloaded, an inspector's edit): at once on a skeleton, through
/// [`attach_proxies_by_name`] on any other entity.
pub(super) fn respawn_changed_proxies(
    mut commands: Commands,
    characters: Query<(Entity, &BoneColliders, Option<&SkeletonBones>), ChangedAfterSpawn>,
    proxies: Query<(Entity, &BoneProxyOf)>,
) {
    for (entity, colliders, bones) in &characters {
        for (proxy, of) in &proxies {
            if of.0 == entity {
                commands.entity(proxy).despawn();
            }
        }
        match bones {
            Some(bones) => spawn_proxies(&mut commands, entity, colliders, |name| bones.get(name)),
            None => {
                commands.entity(entity).remove::<ProxiesAttachedByName>();
            }
        }
    }
}

/// Lets the proxies of a character without a [`Skeleton`] be attached again when a joint they
/// hung from is gone: a scene spawned again (its file reloaded, a second load of the same
/// file finishing late) has new joint entities, and the old ones took their proxies with
/// them. The proxies left are despawned, [`attach_proxies_by_name`] attaches them all anew.
pub(super) fn detach_from_lost_joints(
    mut commands: Commands,
    characters: Query<(Entity, &ProxiesAttachedByName)>,
    joints: Query<()>,
    proxies: Query<(Entity, &BoneProxyOf)>,
) {
    for (entity, attached) in &characters {
        if attached.0.iter().all(|&joint| joints.contains(joint)) {
            continue;
        }
        for (proxy, of) in &proxies {
            if of.0 == entity {
                commands.entity(proxy).despawn();
            }
        }
        commands.entity(entity).remove::<ProxiesAttachedByName>();
    }
}

/// Attaches the [`BoneColliders`] of every entity without a [`Skeleton`] to its descendants
/// by [`Name`], once one of them has a proxy's bone name (a scene spawns some frames after it
/// is asked for). An entity whose descendants have none of the names is reported once.
pub(super) fn attach_proxies_by_name(
    mut commands: Commands,
    characters: Query<(Entity, &BoneColliders), NotYetAttached>,
    children: Query<&Children>,
    names: Query<&Name>,
    mut reported: Local<Vec<Entity>>,
) {
    for (entity, colliders) in &characters {
        let mut bones: Vec<(&str, Entity)> = Vec::new();
        let mut descendants = 0usize;
        for descendant in children.iter_descendants(entity) {
            descendants += 1;
            let Ok(name) = names.get(descendant) else {
                continue;
            };
            let name = name.as_str();
            if !bones.iter().any(|(n, _)| *n == name)
                && colliders.proxies.iter().any(|p| p.bone == name)
            {
                bones.push((name, descendant));
            }
        }
        if bones.is_empty() {
            if descendants > 0 && !colliders.proxies.is_empty() && !reported.contains(&entity) {
                warn!(
                    "character {entity}: none of its {descendants} descendants is named like a \
                     bone of its BoneColliders (the first is {:?})",
                    colliders.proxies[0].bone
                );
                reported.push(entity);
            }
            continue;
        }
        reported.retain(|&e| e != entity);
        spawn_proxies(&mut commands, entity, colliders, |name| {
            bones.iter().find(|(n, _)| *n == name).map(|&(_, e)| e)
        });
        let joints = bones.iter().map(|&(_, joint)| joint).collect();
        commands
            .entity(entity)
            .insert(ProxiesAttachedByName(joints));
    }
}
