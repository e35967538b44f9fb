//! Sleeping: a cloth that has been still for a while stops being solved until something that
//! could move it does ([`SleepSettings`], [`SleepClock`]), and what "could move it" means for
//! the solver's own inputs (pins, the dragged particle) and for the colliders and the
//! followed frame around it.

use bevy::math::Vec3A;
use bevy::reflect::Reflect;

use super::ClothSolver;
use crate::cloth::state::ClothState;
use crate::collide::trimesh::Aabb;
use crate::collide::{FrameStep, SolverCollider};
use crate::error::ClothError;

/// When a still cloth falls asleep: its particles within `distance` of where they were
/// `seconds` ago (the root mean square of their distances), none farther than
/// [`SleepSettings::TREMBLE`] times that, with nothing about it moving. Where the particles
/// are, not their velocities, is what counts, and the cloth as a whole rather than its
/// liveliest particle: a cloth at rest on a body keeps a few particles trembling by a fraction
/// of a millimetre a step, and wandering by a few millimetres a second where it is pressed
/// between colliders, which is not motion anyone sees. The price: a large cloth whose small
/// part still sways by less than `TREMBLE * distance` (1 cm at the defaults) in `seconds`
/// sleeps with it, where a small cloth swaying as much stays awake; lower `distance` for
/// such a cloth. A sleeping cloth keeps its pose, at
/// rest, and costs nothing to step; it wakes in the step anything that could move it moves
/// (see `ClothSleeping` in the plugin).
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct SleepSettings {
    /// How far the particles may move over `seconds` (the root mean square of their distances)
    /// and still count as still, metres. Default: `0.002`.
    pub distance: f32,
    /// How long the cloth must stay still before it sleeps, seconds. Default: `1.0`.
    pub seconds: f32,
}

impl Default for SleepSettings {
    fn default() -> Self {
        Self {
            distance: 0.002,
            seconds: 1.0,
        }
    }
}

impl SleepSettings {
    /// How many times [`SleepSettings::distance`] a single particle may move over `seconds`
    /// while the cloth counts as still.
    pub const TREMBLE: f32 = 5.0;

    /// The speed that counts as still, m/s: `distance` over `seconds`. A collider or a
    /// followed entity moving faster disturbs the cloth.
    pub fn speed(&self) -> f32 {
        if self.seconds > 0.0 {
            self.distance / self.seconds
        } else {
            0.0
        }
    }

    /// Checks that the distance and the time are finite and not negative.
    pub fn validate(&self) -> Result<(), ClothError> {
        ClothError::require_non_negative(&[
            ("sleep distance", self.distance),
            ("sleep seconds", self.seconds),
        ])
    }
}

/// How long a cloth has been still, and whether it sleeps.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct SleepClock {
    still_for: f32,
    asleep: bool,
    /// Where the particles were when the still time started.
    reference: Vec<Vec3A>,
}

impl SleepClock {
    /// Whether the cloth sleeps.
    pub(crate) fn is_asleep(&self) -> bool {
        self.asleep
    }

    /// Wakes the cloth and starts the still time again.
    pub(crate) fn wake(&mut self) {
        self.asleep = false;
        self.still_for = 0.0;
        self.reference.clear();
    }

    /// After a step of `dt` seconds that left the cloth in `state` (`disturbed`: something
    /// about the cloth moved): whether the cloth falls asleep now. The pinned particles
    /// (inverse mass 0) do not count in the mean: they would make a mostly pinned cloth look
    /// still.
    pub(crate) fn observe(
        &mut self,
        state: &ClothState,
        disturbed: bool,
        dt: f32,
        settings: &SleepSettings,
    ) -> bool {
        if self.asleep {
            return false;
        }
        let positions = &state.positions;
        let limit = settings.distance * settings.distance;
        let cap = limit * SleepSettings::TREMBLE * SleepSettings::TREMBLE;
        let still = !disturbed && self.reference.len() == positions.len() && {
            let (mut sum, mut free) = (0.0f32, 0u32);
            let mut within_cap = true;
            for ((p, r), &w) in positions
                .iter()
                .zip(&self.reference)
                .zip(&state.inverse_masses)
            {
                let d2 = p.distance_squared(*r);
                if w > 0.0 {
                    sum += d2;
                    free += 1;
                }
                within_cap &= d2 <= cap;
            }
            // (NaN compares false: a cloth with a NaN in it is never still.)
            within_cap && sum <= limit * free as f32
        };
        if still {
            self.still_for += dt;
        } else {
            self.still_for = 0.0;
            self.reference.clear();
            self.reference.extend_from_slice(positions);
        }
        self.asleep = still && self.still_for >= settings.seconds;
        self.asleep
    }
}

/// How far a collider or the followed entity may have crept from where it was when the cloth
/// fell asleep before the cloth wakes, metres.
pub(crate) const CREEP: f32 = 1e-4;

/// The distance from `origin` to the farthest corner of the box `[min, max]`: how far from a
/// body's origin a point of the cloth can be.
fn farthest_corner(origin: Vec3A, min: Vec3A, max: Vec3A) -> f32 {
    (origin - min).abs().max((max - origin).abs()).length()
}

/// Whether the frame moved over the step, or moves at its end faster than `speed` anywhere in
/// the cloth's box `[min, max]`.
pub(crate) fn frame_moves(frame: &FrameStep, speed: f32, min: Vec3A, max: Vec3A) -> bool {
    let radius = farthest_corner(frame.end.translation, min, max);
    let tolerance = speed * 1e-3;
    frame.jumped
        || moved(&frame.start, &frame.end, radius, tolerance)
        || frame.linear_velocity.length() + frame.angular_velocity.length() * radius > speed
}

/// Whether the colliders that could reach the cloth's box `[min, max]` (grown by `reach` and
/// each collider's margin) are not those the cloth was last solved with (`solved_with`): one
/// of them moves over the step or its surface moves faster than `speed` anywhere in the box,
/// one came or went, changed its shape, margin or material, or crept more than [`CREEP`] from
/// where it was. Planes reach everything.
pub(crate) fn colliders_move_near(
    colliders: &[SolverCollider],
    solved_with: &[SolverCollider],
    min: Vec3A,
    max: Vec3A,
    reach: f32,
    speed: f32,
) -> bool {
    let cloth = Aabb {
        min: min - Vec3A::splat(reach),
        max: max + Vec3A::splat(reach),
    };
    let near = |c: &&SolverCollider| {
        c.swept_bounds(c.margin)
            .is_none_or(|bounds| bounds.overlaps(&cloth))
    };
    let tolerance = speed * 1e-3;
    let moving = colliders.iter().filter(near).any(|c| {
        let radius = farthest_corner(c.end.translation, cloth.min, cloth.max);
        moved(&c.start, &c.end, radius, tolerance)
            || c.linear_velocity.length() + c.angular_velocity.length() * radius > speed
    });
    if moving {
        return true;
    }
    // The solver keeps the valid ones only.
    let (mut now, mut then) = (
        colliders
            .iter()
            .filter(|c| c.validate().is_ok())
            .filter(near),
        solved_with.iter().filter(near),
    );
    loop {
        match (now.next(), then.next()) {
            (None, None) => return false,
            (Some(a), Some(b)) => {
                let radius = farthest_corner(b.end.translation, cloth.min, cloth.max);
                if a.shape != b.shape
                    || a.margin != b.margin
                    || a.material != b.material
                    || moved(&b.end, &a.end, radius, CREEP)
                {
                    return true;
                }
            }
            _ => return true,
        }
    }
}

/// Whether a body of `radius` about its origin moved more than `tolerance` from `start` to
/// `end`.
fn moved(
    start: &crate::collide::RigidPose,
    end: &crate::collide::RigidPose,
    radius: f32,
    tolerance: f32,
) -> bool {
    let turn = end.rotation * start.rotation.inverse();
    start.translation.distance(end.translation) + 2.0 * turn.xyz().length() * radius > tolerance
}

impl ClothSolver {
    /// Whether the solver's own inputs hold the cloth still: no particle is grabbed and every
    /// pin's target is where the pin is, to 10 um (a few of `f32`'s steps 30 m from the
    /// origin; a pin creeping that much a step moves at 0.6 mm/s).
    pub fn pins_hold_still(&self) -> bool {
        const TOLERANCE: f32 = 1e-5;
        self.drag.is_none()
            && self.pins.iter().all(|pin| {
                self.state
                    .positions
                    .get(pin.particle as usize)
                    .is_some_and(|&p| p.distance(pin.end) <= TOLERANCE)
            })
    }

    /// The box around every particle.
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let positions = &self.state.positions;
        positions.iter().fold(
            (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    }

    /// Puts the cloth to sleep where it is: every particle at rest, its last step's timings
    /// zero.
    pub fn fall_asleep(&mut self) {
        let state = &mut self.state;
        state.velocities.fill(Vec3A::ZERO);
        state.previous_positions.clone_from(&state.positions);
        self.timings = Default::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::{RigidPose, SolverShape};
    use bevy::math::Quat;

    #[test]
    fn the_clock_sleeps_after_the_still_time_and_restarts_on_motion() {
        let settings = SleepSettings {
            distance: 0.01,
            seconds: 0.5,
        };
        let mut clock = SleepClock::default();
        let dt = 0.1;
        let at = |x: f32| state(vec![Vec3A::new(x, 0.0, 0.0), Vec3A::ONE]);
        // Trembling by less than the distance counts as still; moving past it, or a
        // disturbance, starts the count again.
        assert!(!clock.observe(&at(0.0), false, dt, &settings));
        for k in 0..3 {
            assert!(!clock.observe(&at(0.004 * (k % 2) as f32), false, dt, &settings));
        }
        assert!(!clock.observe(&at(0.02), false, dt, &settings));
        assert!(!clock.observe(&at(0.02), true, dt, &settings));
        for k in 0..5 {
            let fell = clock.observe(&at(0.02 + 0.009 * (k % 2) as f32), false, dt, &settings);
            assert_eq!(fell, k == 4, "step {k}");
        }
        assert!(clock.is_asleep());
        clock.wake();
        assert!(!clock.is_asleep());
        // A slow creep never sleeps if it passes the distance within the time.
        for k in 0..50 {
            assert!(!clock.observe(&at(0.03 * k as f32), false, dt, &settings));
        }
    }

    #[test]
    fn a_few_wandering_particles_count_as_still_one_leaving_does_not() {
        let settings = SleepSettings {
            distance: 0.002,
            seconds: 0.5,
        };
        let dt = 0.1;
        // 100 particles, `wandering` of them moved by `by` from the start.
        let at = |wandering: usize, by: f32| {
            state(
                (0..100)
                    .map(|i| Vec3A::new(i as f32, if i < wandering { by } else { 0.0 }, 0.0))
                    .collect(),
            )
        };
        let sleeps_after = |wandering: usize, by: f32| {
            let mut clock = SleepClock::default();
            (0..20).position(|k| {
                let moved = if k % 2 == 1 { by } else { 0.0 };
                clock.observe(&at(wandering, moved), false, dt, &settings)
            })
        };
        // Four wander 8 mm (the root mean square 1.6 mm): still.
        assert_eq!(sleeps_after(4, 0.008), Some(5));
        // Thirty do: moving.
        assert_eq!(sleeps_after(30, 0.008), None);
        // One leaves by more than five times the distance: moving.
        assert_eq!(sleeps_after(1, 0.011), None);
        // A NaN is never still.
        assert_eq!(sleeps_after(1, f32::NAN), None);
        // Pinned particles do not count in the mean: two of four free particles wandering
        // 2.5 mm (the root mean square 1.8 mm) are still, 4 mm (2.8 mm) are not, however many
        // pinned particles lie still beside them (96 here).
        let pinned_sleeps_after = |by: f32| {
            let mut clock = SleepClock::default();
            (0..20).position(|k| {
                let mut s = at(2, if k % 2 == 1 { by } else { 0.0 });
                s.inverse_masses[4..].fill(0.0);
                clock.observe(&s, false, dt, &settings)
            })
        };
        assert_eq!(pinned_sleeps_after(0.0025), Some(5));
        let fell = pinned_sleeps_after(0.004);
        assert_eq!(fell, None, "two of four free particles moving 4 mm");
    }

    /// A state of particles at `positions`, every one free (inverse mass 1).
    fn state(positions: Vec<Vec3A>) -> ClothState {
        ClothState {
            previous_positions: positions.clone(),
            velocities: vec![Vec3A::ZERO; positions.len()],
            inverse_masses: vec![1.0; positions.len()],
            positions,
        }
    }

    #[test]
    fn bad_sleep_settings_are_refused() {
        for (distance, seconds) in [(f32::NAN, 1.0), (-1.0, 1.0), (0.01, f32::INFINITY)] {
            assert!(SleepSettings { distance, seconds }.validate().is_err());
        }
        assert!(SleepSettings::default().validate().is_ok());
    }

    #[test]
    fn only_a_moving_or_changed_collider_within_reach_disturbs() {
        let pose = |x: f32| RigidPose {
            translation: Vec3A::new(x, 0.0, 0.0),
            rotation: Quat::IDENTITY,
        };
        let sphere = SolverShape::Sphere { radius: 0.1 };
        let still = SolverCollider::fixed(sphere.clone(), pose(0.0));
        let mut moving = still.clone();
        moving.end = pose(0.01);
        let mut spinning = still.clone();
        spinning.angular_velocity = Vec3A::new(0.0, 1.0, 0.0);
        let (min, max) = (Vec3A::splat(-0.5), Vec3A::splat(0.5));
        let speed = 0.005;
        let near = |now: &SolverCollider, then: &SolverCollider, reach: f32| {
            colliders_move_near(
                std::slice::from_ref(now),
                std::slice::from_ref(then),
                min,
                max,
                reach,
                speed,
            )
        };
        assert!(!near(&still, &still, 0.0));
        assert!(near(&moving, &still, 0.0));
        assert!(near(&spinning, &spinning, 0.0));
        // Grown, or come or gone, since the cloth was solved.
        let mut grown = still.clone();
        grown.shape = SolverShape::Sphere { radius: 0.12 };
        assert!(near(&grown, &still, 0.0));
        let one = std::slice::from_ref(&still);
        assert!(colliders_move_near(one, &[], min, max, 0.0, speed));
        assert!(colliders_move_near(&[], one, min, max, 0.0, speed));
        // Crept by 0.5 mm in steps too small to see one at a time.
        let mut crept = still.clone();
        crept.start = pose(5e-4);
        crept.end = pose(5e-4);
        assert!(near(&crept, &still, 0.0));
        // The same motion 10 m away.
        let far = |c: &SolverCollider| {
            let mut c = c.clone();
            c.start.translation.x += 10.0;
            c.end.translation.x += 10.0;
            c
        };
        assert!(!near(&far(&moving), &far(&still), 0.1));
        assert!(near(&far(&moving), &far(&still), 10.0));
    }
}
