//! The humanoid rig of the examples: 19 bones, hierarchy depth 7, y up, facing +z.
//!
//! | bone | parent | hinge axis | moves |
//! |---|---|---|---|
//! | `pelvis` | (root) | | root translation and rotation |
//! | `spine` | pelvis | x | bends forward (+) and back |
//! | `chest` | spine | y | twists |
//! | `neck` | chest | x | nods |
//! | `head` | neck | y | turns |
//! | `shoulder_l`, `shoulder_r` | chest | z | raise the arm sideways (left +, right -) |
//! | `upper_arm_l`, `upper_arm_r` | shoulder | x | swing the arm (forward -) |
//! | `forearm_l`, `forearm_r` | upper arm | x | elbow (bend -) |
//! | `hand_l`, `hand_r` | forearm | z | wrist |
//! | `thigh_l`, `thigh_r` | pelvis | x | hip (forward -) |
//! | `shin_l`, `shin_r` | thigh | x | knee (bend +) |
//! | `foot_l`, `foot_r` | shin | x | ankle |
//!
//! The shoulder is two hinges at one point (`shoulder_*` about z, then `upper_arm_*` about x).
//! Lengths (metres): pelvis to hips 0.05 down, thighs and shins 0.42, spine 0.1, chest 0.2,
//! neck 0.22, head 0.1, shoulders 0.18 out and 0.18 up from the chest, upper arms 0.28,
//! forearms 0.25. The pelvis stands 0.93 m above the soles at rest.

use bevy::math::{Quat, Vec3};
use bevy::reflect::Reflect;

use super::rig::{BoneDesc, Rig};

/// Limb radii for collision proxies and meshes, metres.
pub(crate) mod radius {
    /// Upper and lower arms.
    pub(crate) const ARM: f32 = 0.04;
    /// Thighs.
    pub(crate) const THIGH: f32 = 0.07;
    /// Shins.
    pub(crate) const SHIN: f32 = 0.055;
    /// Torso (spine and chest).
    pub(crate) const TORSO: f32 = 0.12;
    /// Head (a sphere).
    pub(crate) const HEAD: f32 = 0.11;
}

/// Height of the pelvis above the soles at rest, metres.
#[cfg(test)]
const PELVIS_HEIGHT: f32 = 0.93;

/// The bone descriptions of the humanoid.
pub(crate) fn humanoid_bones() -> Vec<BoneDesc> {
    let bone =
        |name: &str, parent: Option<&str>, offset: [f32; 3], axis: [f32; 3], limits| BoneDesc {
            name: name.into(),
            parent: parent.map(Into::into),
            offset,
            axis,
            limits,
        };
    let (x, y, z) = ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
    let mut bones = vec![
        bone("pelvis", None, [0.0; 3], x, None),
        bone(
            "spine",
            Some("pelvis"),
            [0.0, 0.1, 0.0],
            x,
            Some((-0.5, 0.8)),
        ),
        bone(
            "chest",
            Some("spine"),
            [0.0, 0.2, 0.0],
            y,
            Some((-0.8, 0.8)),
        ),
        bone(
            "neck",
            Some("chest"),
            [0.0, 0.22, 0.0],
            x,
            Some((-0.6, 0.6)),
        ),
        bone("head", Some("neck"), [0.0, 0.1, 0.0], y, Some((-1.2, 1.2))),
    ];
    for (side, s) in [("l", 1.0f32), ("r", -1.0)] {
        let name = |n: &str| format!("{n}_{side}");
        let lim = |a: f32, b: f32| Some((a.min(b), a.max(b)));
        bones.extend([
            bone(
                &name("shoulder"),
                Some("chest"),
                [0.18 * s, 0.18, 0.0],
                z,
                lim(-0.3 * s, 2.8 * s),
            ),
            bone(
                &name("upper_arm"),
                Some(&name("shoulder")),
                [0.0; 3],
                x,
                Some((-2.8, 1.0)),
            ),
            bone(
                &name("forearm"),
                Some(&name("upper_arm")),
                [0.0, -0.28, 0.0],
                x,
                Some((-2.5, 0.0)),
            ),
            bone(
                &name("hand"),
                Some(&name("forearm")),
                [0.0, -0.25, 0.0],
                z,
                Some((-0.8, 0.8)),
            ),
            bone(
                &name("thigh"),
                Some("pelvis"),
                [0.1 * s, -0.05, 0.0],
                x,
                Some((-1.8, 0.8)),
            ),
            bone(
                &name("shin"),
                Some(&name("thigh")),
                [0.0, -0.42, 0.0],
                x,
                Some((0.0, 2.4)),
            ),
            bone(
                &name("foot"),
                Some(&name("shin")),
                [0.0, -0.42, 0.0],
                x,
                Some((-0.8, 0.8)),
            ),
        ]);
    }
    bones
}

/// The humanoid rig.
pub fn humanoid() -> Rig {
    Rig::new(&humanoid_bones()).expect("the humanoid rig is valid by construction")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_walk_and_wave_clips_bind_to_the_humanoid() {
        use crate::skeleton::clip::{Clip, ClipDesc};
        let rig = humanoid();
        for text in [
            include_str!("../../assets/clips/walk.clip.ron"),
            include_str!("../../assets/clips/wave.clip.ron"),
        ] {
            let desc = ClipDesc::from_ron(text).unwrap();
            assert!(desc.times.len() >= 5);
            let spacing: Vec<f32> = desc.times.windows(2).map(|w| w[1] - w[0]).collect();
            assert!(
                spacing.iter().any(|&d| (d - spacing[0]).abs() > 1e-3),
                "non-uniform"
            );
            let clip = Clip::new(&desc, &rig).unwrap();
            assert!(clip.looping());
        }
    }

    #[test]
    fn the_humanoid_has_19_bones_and_depth_7() {
        let rig = humanoid();
        assert_eq!(rig.bones().len(), 19);
        let depth = |mut b: usize| {
            let mut d = 1;
            while let Some(p) = rig.bones()[b].parent {
                b = p;
                d += 1;
            }
            d
        };
        let deepest = (0..rig.bones().len()).map(depth).max().unwrap();
        assert_eq!(deepest, 7);
        // At rest the soles are PELVIS_HEIGHT below the pelvis.
        let mut out = Vec::new();
        rig.forward(&rig.rest_pose(), None, &mut out);
        let foot = out[rig.find("foot_l").unwrap()].translation;
        assert!((foot.y + PELVIS_HEIGHT - 0.04).abs() < 1e-6, "{foot}");
    }
}

/// A collision proxy on a bone: a capsule (a sphere when `half_length` is 0) in the bone's
/// frame.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct BoneProxy {
    /// The bone's name.
    pub bone: String,
    /// Radius, metres.
    pub radius: f32,
    /// Half the length of the capsule's axis segment, metres (0 for a sphere).
    pub half_length: f32,
    /// The capsule's centre in the bone's frame.
    pub centre: Vec3,
    /// The direction of the capsule's axis in the bone's frame.
    pub axis: Vec3,
}

impl BoneProxy {
    /// The proxy's rotation in the bone's frame: local Y (the capsule axis) onto `axis`.
    pub fn rotation(&self) -> Quat {
        Quat::from_rotation_arc(Vec3::Y, self.axis.normalize_or(Vec3::Y))
    }
}

/// The humanoid's collision proxies: capsules on the pelvis, spine, chest, across the
/// shoulders, on the neck, arms and legs, spheres on the head and hands. No feet: cloth does
/// not reach them. The examples draw the body with these same shapes.
pub fn humanoid_proxies() -> Vec<BoneProxy> {
    let capsule =
        |bone: &str, radius: f32, half_length: f32, centre: [f32; 3], axis: Vec3| BoneProxy {
            bone: bone.into(),
            radius,
            half_length,
            centre: centre.into(),
            axis,
        };
    let mut proxies = vec![
        capsule("pelvis", 0.11, 0.05, [0.0, 0.0, 0.0], Vec3::Y),
        capsule("spine", 0.12, 0.025, [0.0, 0.05, 0.0], Vec3::Y),
        capsule("chest", radius::TORSO, 0.06, [0.0, 0.08, 0.0], Vec3::Y),
        // From one shoulder joint to the other, so cloth rests on the shoulders.
        capsule("chest", 0.06, 0.16, [0.0, 0.17, 0.0], Vec3::X),
        capsule("neck", 0.045, 0.03, [0.0, 0.04, 0.0], Vec3::Y),
        capsule("head", radius::HEAD, 0.0, [0.0, 0.1, 0.0], Vec3::Y),
    ];
    for side in ["l", "r"] {
        let name = |n: &str| format!("{n}_{side}");
        proxies.extend([
            capsule(
                &name("upper_arm"),
                radius::ARM,
                0.095,
                [0.0, -0.14, 0.0],
                Vec3::Y,
            ),
            capsule(
                &name("forearm"),
                radius::ARM * 0.9,
                0.085,
                [0.0, -0.125, 0.0],
                Vec3::Y,
            ),
            capsule(&name("hand"), 0.045, 0.0, [0.0, -0.05, 0.0], Vec3::Y),
            capsule(
                &name("thigh"),
                radius::THIGH,
                0.14,
                [0.0, -0.21, 0.0],
                Vec3::Y,
            ),
            capsule(
                &name("shin"),
                radius::SHIN,
                0.155,
                [0.0, -0.21, 0.0],
                Vec3::Y,
            ),
        ]);
    }
    proxies
}
