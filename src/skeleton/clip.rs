//! Keyframed clips: key times, root translation and rotation, and hinge angles by bone name,
//! as data ([`ClipDesc`], read from RON), bound to a [`Rig`] ([`Clip`]) and sampled with
//! [`super::spline`] into a [`Pose`] and its [`PoseRate`].
//!
//! A clip file (`assets/clips/*.clip.ron`):
//!
//! ```text
//! (
//!     looping: true,
//!     times: [0.0, 0.3, 0.5, 0.8, 1.0],
//!     root_translation: [(0.0, 0.95, 0.0), (0.0, 0.93, 0.3), ...],   // optional
//!     root_rotation: [(0.0, 0.0, 0.0, 1.0), ...],                    // optional, x y z w
//!     angles: { "thigh_l": [0.4, 0.0, -0.4, 0.0, 0.4], ... },
//! )
//! ```
//!
//! Every track has one value per key time. A looping clip's last key closes the loop (its
//! values should equal the first key's).

use std::collections::BTreeMap;

use bevy::math::{Quat, Vec3};

use super::rig::{Pose, PoseRate, Rig};
use super::spline::{KeySpline, QuatSpline, SplineError, check_times};

/// Why a clip cannot be read or bound to a rig.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ClipError {
    /// The file is not a valid clip description.
    #[error("the clip cannot be parsed: {0}")]
    Parse(String),
    /// The key times or a track's keys are unusable.
    #[error("track `{track}`: {error}")]
    Keys {
        /// `times`, `root_translation`, `root_rotation` or a bone's name.
        track: String,
        /// What is wrong.
        error: SplineError,
    },
    /// A track names a bone the rig does not have.
    #[error("the clip animates `{0}`, which is not a bone of the rig")]
    UnknownBone(String),
    /// A track animates the root bone's hinge, which it does not have.
    #[error(
        "the clip gives angles to the root bone `{0}`; animate the root with root_translation and root_rotation"
    )]
    RootAngles(String),
}

/// A clip as written in a file.
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize, serde::Serialize)]
pub struct ClipDesc {
    /// Whether it loops. Default: `false` (it holds its last pose).
    #[serde(default)]
    pub looping: bool,
    /// Key times, seconds, strictly increasing.
    pub times: Vec<f32>,
    /// The root's position at each key, metres; empty for none.
    #[serde(default)]
    pub root_translation: Vec<[f32; 3]>,
    /// The root's rotation at each key (`x, y, z, w`); empty for none.
    #[serde(default)]
    pub root_rotation: Vec<[f32; 4]>,
    /// Hinge angles at each key by bone name, radians.
    #[serde(default)]
    pub angles: BTreeMap<String, Vec<f32>>,
}

impl ClipDesc {
    /// Reads a clip from RON text.
    pub fn from_ron(text: &str) -> Result<Self, ClipError> {
        ron::from_str(text).map_err(|e| ClipError::Parse(e.to_string()))
    }
}

/// A clip bound to a rig: splines per track, bone indices resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    looping: bool,
    start: f32,
    end: f32,
    root_translation: Option<KeySpline<Vec3>>,
    root_rotation: Option<QuatSpline>,
    tracks: Vec<(usize, KeySpline<f32>)>,
}

impl Clip {
    /// Binds `desc` to `rig`. Errors: fewer than two keys, unsorted or duplicate times, a
    /// track with the wrong number of values or a non-finite one, a bone the rig does not
    /// have, angles for the root.
    pub fn new(desc: &ClipDesc, rig: &Rig) -> Result<Self, ClipError> {
        let keys = |track: &str| {
            let track = track.to_string();
            move |error| ClipError::Keys { track, error }
        };
        check_times(&desc.times, desc.times.len()).map_err(keys("times"))?;
        let looping = desc.looping;
        let root_translation = (!desc.root_translation.is_empty())
            .then(|| {
                let values: Vec<Vec3> = desc
                    .root_translation
                    .iter()
                    .map(|&v| Vec3::from_array(v))
                    .collect();
                finite(values.iter().map(|v| v.is_finite()))
                    .and_then(|()| KeySpline::new(&desc.times, &values, looping))
                    .map_err(keys("root_translation"))
            })
            .transpose()?;
        let root_rotation = (!desc.root_rotation.is_empty())
            .then(|| {
                let values: Vec<Quat> = desc
                    .root_rotation
                    .iter()
                    .map(|&[x, y, z, w]| Quat::from_xyzw(x, y, z, w))
                    .collect();
                QuatSpline::new(&desc.times, &values, looping).map_err(keys("root_rotation"))
            })
            .transpose()?;
        let mut tracks = Vec::with_capacity(desc.angles.len());
        for (name, values) in &desc.angles {
            let bone = rig
                .find(name)
                .ok_or_else(|| ClipError::UnknownBone(name.clone()))?;
            if rig.bones()[bone].parent.is_none() {
                return Err(ClipError::RootAngles(name.clone()));
            }
            let spline = finite(values.iter().map(|v| v.is_finite()))
                .and_then(|()| KeySpline::new(&desc.times, values, looping))
                .map_err(keys(name))?;
            tracks.push((bone, spline));
        }
        Ok(Self {
            looping,
            start: desc.times[0],
            end: desc.times[desc.times.len() - 1],
            root_translation,
            root_rotation,
            tracks,
        })
    }

    /// The clip's length, seconds.
    pub fn duration(&self) -> f32 {
        self.end - self.start
    }

    /// Whether it loops.
    pub fn looping(&self) -> bool {
        self.looping
    }

    /// The pose and its rate at time `t` (seconds from the first key): bones without a track
    /// keep angle 0, a root without tracks stays at the origin, unrotated.
    pub fn sample(&self, t: f32, pose: &mut Pose, rate: &mut PoseRate) {
        let t = self.start + t;
        let n = pose.angles.len();
        pose.angles.fill(0.0);
        rate.angle_rates.resize(n, 0.0);
        rate.angle_rates.fill(0.0);
        (pose.root_translation, rate.root_velocity) = self
            .root_translation
            .as_ref()
            .map_or((Vec3::ZERO, Vec3::ZERO), |s| s.sample(t));
        (pose.root_rotation, rate.root_angular_velocity) = self
            .root_rotation
            .as_ref()
            .map_or((Quat::IDENTITY, Vec3::ZERO), |s| s.sample(t));
        for (bone, spline) in &self.tracks {
            if *bone < n {
                (pose.angles[*bone], rate.angle_rates[*bone]) = spline.sample(t);
            }
        }
    }
}

impl Clip {
    /// The ground speed at which a character playing this clip at normal speed does not
    /// skate, m/s: the mean speed, over one cycle, at which the stance foot moves backwards
    /// in the character's frame (at each instant, whichever of `feet` moves backwards, against
    /// `forward`, the fastest). A clip that walks in place carries its stance foot back by one
    /// stride per stance; a character moving forwards at this speed puts the foot down and
    /// lifts it at the same place in the world. Play the clip at `ground_speed / stance_speed`
    /// to match a character controller. `None` without feet, for a clip of zero length, or if
    /// no foot ever moves backwards.
    pub fn stance_speed(&self, rig: &Rig, feet: &[usize], forward: Vec3) -> Option<f32> {
        const SAMPLES: usize = 240;
        let usable = self.duration() > 0.0 && forward.is_finite() && forward != Vec3::ZERO;
        if !usable || feet.is_empty() || feet.iter().any(|&f| f >= rig.bones().len()) {
            return None;
        }
        let forward = forward.normalize();
        let (mut pose, mut rate) = (rig.rest_pose(), PoseRate::default());
        let mut bones = Vec::new();
        let mut sum = 0.0;
        for k in 0..SAMPLES {
            self.sample(
                self.duration() * k as f32 / SAMPLES as f32,
                &mut pose,
                &mut rate,
            );
            rig.forward(&pose, Some(&rate), &mut bones);
            let backwards = feet
                .iter()
                .map(|&f| -bones[f].linear_velocity.dot(forward))
                .fold(0.0f32, f32::max);
            sum += backwards;
        }
        let speed = sum / SAMPLES as f32;
        (speed > 0.0).then_some(speed)
    }
}

fn finite(mut checks: impl Iterator<Item = bool>) -> Result<(), SplineError> {
    match checks.position(|ok| !ok) {
        Some(i) => Err(SplineError::NonFinite(i)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::rig::BoneDesc;

    fn rig() -> Rig {
        Rig::new(&[
            BoneDesc {
                name: "pelvis".into(),
                parent: None,
                offset: [0.0; 3],
                axis: [1.0, 0.0, 0.0],
                limits: None,
            },
            BoneDesc {
                name: "thigh".into(),
                parent: Some("pelvis".into()),
                offset: [0.1, 0.0, 0.0],
                axis: [1.0, 0.0, 0.0],
                limits: None,
            },
        ])
        .unwrap()
    }

    const CLIP: &str = r#"(
        looping: true,
        times: [0.0, 0.3, 0.5, 1.0],
        root_translation: [(0.0, 1.0, 0.0), (0.0, 1.0, 0.3), (0.0, 1.0, 0.5), (0.0, 1.0, 0.0)],
        angles: { "thigh": [0.4, 0.0, -0.4, 0.4] },
    )"#;

    #[test]
    fn a_clip_reads_binds_and_samples_through_its_keys() {
        let desc = ClipDesc::from_ron(CLIP).unwrap();
        let rig = rig();
        let clip = Clip::new(&desc, &rig).unwrap();
        let mut pose = rig.rest_pose();
        let mut rate = PoseRate {
            root_velocity: Vec3::ZERO,
            root_angular_velocity: Vec3::ZERO,
            angle_rates: vec![],
        };
        clip.sample(0.5, &mut pose, &mut rate);
        assert!((pose.angles[1] + 0.4).abs() < 1e-6);
        assert!((pose.root_translation.z - 0.5).abs() < 1e-6);
        // Looping: one period later, the same pose.
        clip.sample(1.5, &mut pose, &mut rate);
        assert!((pose.angles[1] + 0.4).abs() < 1e-5);
    }

    #[test]
    fn bad_clips_are_refused() {
        let rig = rig();
        let bind = |text: &str| ClipDesc::from_ron(text).and_then(|d| Clip::new(&d, &rig));
        assert!(matches!(
            bind("(times: [0.0, oops])"),
            Err(ClipError::Parse(_))
        ));
        assert!(matches!(
            bind(r#"(times: [0.0], angles: { "thigh": [0.0] })"#),
            Err(ClipError::Keys {
                error: SplineError::TooFewKeys(1),
                ..
            })
        ));
        assert!(matches!(
            bind(r#"(times: [0.0, 0.5, 0.5], angles: { "thigh": [0.0, 1.0, 2.0] })"#),
            Err(ClipError::Keys {
                error: SplineError::NotIncreasing { .. },
                ..
            })
        ));
        assert!(matches!(
            bind(r#"(times: [0.0, 0.6, 0.5], angles: { "thigh": [0.0, 1.0, 2.0] })"#),
            Err(ClipError::Keys {
                error: SplineError::NotIncreasing { .. },
                ..
            })
        ));
        assert!(matches!(
            bind(r#"(times: [0.0, 1.0], angles: { "tail": [0.0, 1.0] })"#),
            Err(ClipError::UnknownBone(b)) if b == "tail"
        ));
        assert!(matches!(
            bind(r#"(times: [0.0, 1.0], angles: { "thigh": [0.0] })"#),
            Err(ClipError::Keys {
                error: SplineError::LengthMismatch { .. },
                ..
            })
        ));
        assert!(matches!(
            bind(r#"(times: [0.0, 1.0], angles: { "pelvis": [0.0, 1.0] })"#),
            Err(ClipError::RootAngles(_))
        ));
    }
}
