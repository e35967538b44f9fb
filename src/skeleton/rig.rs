//! A rig of hinge-jointed bones and its forward kinematics, with velocities.
//!
//! Bone 0 is the root: its pose is the root translation and rotation. Every other bone hangs
//! from its parent at `offset` (in the parent's frame) and turns about its hinge `axis` (a unit
//! vector in the parent's frame) by its angle:
//!
//! ```text
//! R_b = R_parent * rot(axis_b, theta_b)        p_b = p_parent + R_parent * offset_b
//! ```
//!
//! A joint with more than one degree of freedom is several bones at the same point, each with
//! one hinge (a zero offset). Given the pose's time derivative (root velocity and angular
//! velocity, hinge rates), the bones' velocities follow down the chain:
//!
//! ```text
//! omega_b = omega_parent + theta_b' (R_parent * axis_b)
//! v_b     = v_parent + omega_parent x (p_b - p_parent)
//! ```
//!
//! and a point `r` fixed to bone `b` moves at `v_b + omega_b x (r - p_b)`.

use bevy::math::{Quat, Vec3};

/// Why a rig cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RigError {
    /// The rig has no bones.
    #[error("the rig has no bones")]
    Empty,
    /// Two bones share a name.
    #[error("two bones are named `{0}`")]
    DuplicateName(String),
    /// A bone's parent is not in the rig.
    #[error("bone `{bone}` has the parent `{parent}`, which does not exist")]
    UnknownParent {
        /// The bone.
        bone: String,
        /// Its parent's name.
        parent: String,
    },
    /// Not exactly one bone without a parent.
    #[error("the rig has {0} bones without a parent; it needs exactly one root")]
    RootCount(usize),
    /// The parent links form a cycle.
    #[error("bone `{0}` is its own ancestor (a cycle)")]
    Cycle(String),
    /// A hinge axis has zero length or an offset is not finite.
    #[error("bone `{0}` has a zero or non-finite hinge axis or offset")]
    BadGeometry(String),
    /// A bone's angle limits are not ordered or not finite.
    #[error("bone `{0}` has limits that are not finite and ordered (min <= max)")]
    BadLimits(String),
}

/// One bone as written in a rig description.
#[derive(Clone, Debug, PartialEq, serde::Deserialize, serde::Serialize)]
pub struct BoneDesc {
    /// Its name.
    pub name: String,
    /// Its parent's name; `None` for the root.
    #[serde(default)]
    pub parent: Option<String>,
    /// Where it hangs from its parent, in the parent's frame, metres.
    #[serde(default)]
    pub offset: [f32; 3],
    /// Its hinge axis in the parent's frame (normalised when built). Ignored for the root.
    #[serde(default = "default_axis")]
    pub axis: [f32; 3],
    /// Optional angle limits `(min, max)`, radians.
    #[serde(default)]
    pub limits: Option<(f32, f32)>,
}

fn default_axis() -> [f32; 3] {
    [1.0, 0.0, 0.0]
}

/// A bone of a built [`Rig`].
#[derive(Clone, Debug, PartialEq)]
pub struct Bone {
    /// Its name.
    pub name: String,
    /// Its parent's index (smaller than its own); `None` for the root (index 0).
    pub parent: Option<usize>,
    /// Where it hangs from its parent, in the parent's frame, metres.
    pub offset: Vec3,
    /// Unit hinge axis in the parent's frame.
    pub axis: Vec3,
    /// Angle limits `(min, max)`, radians.
    pub limits: Option<(f32, f32)>,
}

/// Bones ordered so that every parent comes before its children, bone 0 the root.
#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    bones: Vec<Bone>,
}

/// A pose: the root's translation and rotation and one angle per bone (the root's is unused).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pose {
    /// Root translation, metres.
    pub root_translation: Vec3,
    /// Root rotation.
    pub root_rotation: Quat,
    /// Hinge angles by bone index, radians.
    pub angles: Vec<f32>,
}

/// The time derivative of a [`Pose`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseRate {
    /// Root velocity, m/s.
    pub root_velocity: Vec3,
    /// Root angular velocity (world frame), rad/s.
    pub root_angular_velocity: Vec3,
    /// Hinge rates by bone index, rad/s.
    pub angle_rates: Vec<f32>,
}

/// A bone's world transform and velocity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BoneState {
    /// Position of the bone's origin (its joint), metres.
    pub translation: Vec3,
    /// Orientation.
    pub rotation: Quat,
    /// Velocity of the bone's origin, m/s.
    pub linear_velocity: Vec3,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vec3,
}

impl BoneState {
    /// The velocity of the world point `point` fixed to this bone.
    pub fn point_velocity(&self, point: Vec3) -> Vec3 {
        self.linear_velocity + self.angular_velocity.cross(point - self.translation)
    }
}

impl Rig {
    /// Builds a rig from bone descriptions in any order. Errors: no bones, duplicate names,
    /// an unknown parent, not exactly one root, a cycle, a zero axis, bad limits.
    pub fn new(descs: &[BoneDesc]) -> Result<Self, RigError> {
        if descs.is_empty() {
            return Err(RigError::Empty);
        }
        let mut names: Vec<(&str, usize)> = descs
            .iter()
            .enumerate()
            .map(|(i, d)| (d.name.as_str(), i))
            .collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(RigError::DuplicateName(w[0].0.to_string()));
        }
        let find = |name: &str| {
            names
                .binary_search_by(|(n, _)| (*n).cmp(name))
                .ok()
                .map(|k| names[k].1)
        };
        let mut parents = Vec::with_capacity(descs.len());
        for d in descs {
            parents.push(match &d.parent {
                None => None,
                Some(p) => Some(find(p).ok_or_else(|| RigError::UnknownParent {
                    bone: d.name.clone(),
                    parent: p.clone(),
                })?),
            });
        }
        let roots: Vec<usize> = (0..descs.len()).filter(|&i| parents[i].is_none()).collect();
        if roots.len() != 1 {
            // A cycle with no root at all shows up here as zero roots.
            if roots.is_empty()
                && let Some(i) = (0..descs.len()).find(|&i| in_cycle(&parents, i))
            {
                return Err(RigError::Cycle(descs[i].name.clone()));
            }
            return Err(RigError::RootCount(roots.len()));
        }
        if let Some(i) = (0..descs.len()).find(|&i| in_cycle(&parents, i)) {
            return Err(RigError::Cycle(descs[i].name.clone()));
        }
        // Order: breadth first from the root, so parents come first.
        let mut order = vec![roots[0]];
        let mut k = 0;
        while k < order.len() {
            let p = order[k];
            order.extend((0..descs.len()).filter(|&c| parents[c] == Some(p)));
            k += 1;
        }
        let mut index_of = vec![0; descs.len()];
        for (new, &old) in order.iter().enumerate() {
            index_of[old] = new;
        }
        let mut bones = Vec::with_capacity(descs.len());
        for &old in &order {
            let d = &descs[old];
            let is_root = parents[old].is_none();
            let (offset, axis) = (Vec3::from_array(d.offset), Vec3::from_array(d.axis));
            let axis_ok = is_root || (axis.is_finite() && axis.length() > 1e-6);
            if !offset.is_finite() || !axis_ok {
                return Err(RigError::BadGeometry(d.name.clone()));
            }
            if let Some((lo, hi)) = d.limits
                && !(lo.is_finite() && hi.is_finite() && lo <= hi)
            {
                return Err(RigError::BadLimits(d.name.clone()));
            }
            bones.push(Bone {
                name: d.name.clone(),
                parent: parents[old].map(|p| index_of[p]),
                offset,
                axis: if is_root { Vec3::X } else { axis.normalize() },
                limits: d.limits,
            });
        }
        Ok(Self { bones })
    }

    /// The bones, parents first.
    pub fn bones(&self) -> &[Bone] {
        &self.bones
    }

    /// Sets where `bone` hangs from its parent (a rig standing for a hierarchy whose joints
    /// move, as a [`BallChain`](super::ik::BallChain) does); a non-finite offset or a bone
    /// that is not there is ignored.
    pub(crate) fn set_offset(&mut self, bone: usize, offset: Vec3) {
        if let Some(b) = self.bones.get_mut(bone)
            && offset.is_finite()
        {
            b.offset = offset;
        }
    }

    /// The index of the bone named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.bones.iter().position(|b| b.name == name)
    }

    /// The rest pose: root at the origin, unrotated, every angle 0.
    pub fn rest_pose(&self) -> Pose {
        Pose {
            root_translation: Vec3::ZERO,
            root_rotation: Quat::IDENTITY,
            angles: vec![0.0; self.bones.len()],
        }
    }

    /// The bone's rotation relative to its parent for angle `angle`.
    pub(crate) fn local_rotation(&self, bone: usize, angle: f32) -> Quat {
        Quat::from_axis_angle(self.bones[bone].axis, angle)
    }

    /// Forward kinematics: every bone's world transform, and with `rate` its velocity (zero
    /// without), into `out` (resized). Angles beyond a bone's limits are clamped.
    pub fn forward(&self, pose: &Pose, rate: Option<&PoseRate>, out: &mut Vec<BoneState>) {
        out.clear();
        for (b, bone) in self.bones.iter().enumerate() {
            let raw = pose.angles.get(b).copied().unwrap_or(0.0);
            let angle = match bone.limits {
                Some((lo, hi)) => raw.clamp(lo, hi),
                None => raw,
            };
            // A hinge held at its limit does not move.
            let theta_rate = rate
                .and_then(|r| r.angle_rates.get(b).copied())
                .filter(|_| angle == raw)
                .unwrap_or(0.0);
            let state = match bone.parent {
                None => BoneState {
                    translation: pose.root_translation,
                    rotation: pose.root_rotation,
                    linear_velocity: rate.map_or(Vec3::ZERO, |r| r.root_velocity),
                    angular_velocity: rate.map_or(Vec3::ZERO, |r| r.root_angular_velocity),
                },
                Some(p) => {
                    let parent = out[p];
                    let translation = parent.translation + parent.rotation * bone.offset;
                    let world_axis = parent.rotation * bone.axis;
                    BoneState {
                        translation,
                        rotation: (parent.rotation * self.local_rotation(b, angle)).normalize(),
                        linear_velocity: parent.linear_velocity
                            + parent
                                .angular_velocity
                                .cross(translation - parent.translation),
                        angular_velocity: parent.angular_velocity + world_axis * theta_rate,
                    }
                }
            };
            out.push(state);
        }
    }
}

/// Whether following parents from `start` comes back to it.
fn in_cycle(parents: &[Option<usize>], start: usize) -> bool {
    let mut at = start;
    for _ in 0..parents.len() {
        match parents[at] {
            None => return false,
            Some(p) if p == start => return true,
            Some(p) => at = p,
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bone(name: &str, parent: Option<&str>, offset: Vec3, axis: Vec3) -> BoneDesc {
        BoneDesc {
            name: name.into(),
            parent: parent.map(Into::into),
            offset: offset.to_array(),
            axis: axis.to_array(),
            limits: None,
        }
    }

    /// A shoulder at the origin turning about z, an upper arm of 0.3 m along x, an elbow about
    /// z, a forearm of 0.25 m, a hand bone at its end.
    fn arm() -> Rig {
        Rig::new(&[
            bone("hand", Some("forearm"), Vec3::new(0.25, 0.0, 0.0), Vec3::Y),
            bone("root", None, Vec3::ZERO, Vec3::X),
            bone("upper", Some("root"), Vec3::ZERO, Vec3::Z),
            bone("forearm", Some("upper"), Vec3::new(0.3, 0.0, 0.0), Vec3::Z),
        ])
        .unwrap()
    }

    #[test]
    fn a_two_bone_arm_puts_the_hand_where_trigonometry_does() {
        let rig = arm();
        assert_eq!(rig.bones()[0].name, "root");
        let (a, b) = (0.7f32, -1.1f32);
        let mut pose = rig.rest_pose();
        pose.angles[rig.find("upper").unwrap()] = a;
        pose.angles[rig.find("forearm").unwrap()] = b;
        let mut out = Vec::new();
        rig.forward(&pose, None, &mut out);
        let hand = out[rig.find("hand").unwrap()].translation;
        let expected = Vec3::new(
            0.3 * a.cos() + 0.25 * (a + b).cos(),
            0.3 * a.sin() + 0.25 * (a + b).sin(),
            0.0,
        );
        assert!((hand - expected).length() < 1e-6, "{hand} vs {expected}");
    }

    #[test]
    fn bone_velocities_match_finite_differences_of_forward_kinematics() {
        let rig = arm();
        let n = rig.bones().len();
        let pose = Pose {
            root_translation: Vec3::new(0.1, 0.9, -0.2),
            root_rotation: Quat::from_euler(bevy::math::EulerRot::YXZ, 0.4, -0.3, 0.2),
            angles: vec![0.0, 0.5, -0.8, 0.3],
        };
        let rate = PoseRate {
            root_velocity: Vec3::new(0.3, -0.1, 0.7),
            root_angular_velocity: Vec3::new(0.2, 1.1, -0.4),
            angle_rates: vec![0.0, 2.0, -1.5, 3.0],
        };
        let at = |dt: f32| Pose {
            root_translation: pose.root_translation + rate.root_velocity * dt,
            root_rotation: (Quat::from_scaled_axis(rate.root_angular_velocity * dt)
                * pose.root_rotation)
                .normalize(),
            angles: (0..n)
                .map(|b| pose.angles[b] + rate.angle_rates[b] * dt)
                .collect(),
        };
        let (mut now, mut plus, mut minus) = (Vec::new(), Vec::new(), Vec::new());
        rig.forward(&pose, Some(&rate), &mut now);
        let h = 1e-3;
        rig.forward(&at(h), None, &mut plus);
        rig.forward(&at(-h), None, &mut minus);
        for b in 0..n {
            let v = (plus[b].translation - minus[b].translation) / (2.0 * h);
            let turn = plus[b].rotation * minus[b].rotation.inverse();
            let w = turn.to_scaled_axis() / (2.0 * h);
            let (ve, we) = (now[b].linear_velocity, now[b].angular_velocity);
            assert!(
                (v - ve).length() <= 1e-3 * ve.length().max(1.0),
                "bone {b}: {v} vs {ve}"
            );
            assert!(
                (w - we).length() <= 1e-3 * we.length().max(1.0),
                "bone {b}: {w} vs {we}"
            );
        }
        // A point on the hand: v + omega x r.
        let hand = rig.find("hand").unwrap();
        let local = Vec3::new(0.05, 0.02, 0.0);
        let p = |s: &[BoneState]| s[hand].translation + s[hand].rotation * local;
        let numeric = (p(&plus) - p(&minus)) / (2.0 * h);
        let analytic = now[hand].point_velocity(p(&now));
        assert!((numeric - analytic).length() <= 1e-3 * analytic.length().max(1.0));
    }

    #[test]
    fn bad_rigs_are_refused() {
        assert_eq!(Rig::new(&[]), Err(RigError::Empty));
        let root = bone("root", None, Vec3::ZERO, Vec3::X);
        assert!(matches!(
            Rig::new(&[root.clone(), bone("a", Some("nobody"), Vec3::ZERO, Vec3::X)]),
            Err(RigError::UnknownParent { .. })
        ));
        assert!(matches!(
            Rig::new(&[root.clone(), root.clone()]),
            Err(RigError::DuplicateName(_))
        ));
        assert!(matches!(
            Rig::new(&[
                root.clone(),
                bone("a", Some("b"), Vec3::ZERO, Vec3::X),
                bone("b", Some("a"), Vec3::ZERO, Vec3::X),
            ]),
            Err(RigError::Cycle(_))
        ));
        assert!(matches!(
            Rig::new(&[
                bone("a", Some("b"), Vec3::ZERO, Vec3::X),
                bone("b", Some("a"), Vec3::ZERO, Vec3::X),
            ]),
            Err(RigError::Cycle(_))
        ));
        assert!(matches!(
            Rig::new(&[root.clone(), bone("c", None, Vec3::ZERO, Vec3::X)]),
            Err(RigError::RootCount(2))
        ));
        assert!(matches!(
            Rig::new(&[
                root.clone(),
                bone("a", Some("root"), Vec3::ZERO, Vec3::ZERO)
            ]),
            Err(RigError::BadGeometry(_))
        ));
        let mut limited = bone("a", Some("root"), Vec3::ZERO, Vec3::X);
        limited.limits = Some((1.0, -1.0));
        assert!(matches!(
            Rig::new(&[root, limited]),
            Err(RigError::BadLimits(_))
        ));
    }
}
