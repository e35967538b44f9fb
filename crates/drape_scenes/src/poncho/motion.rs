//! The scene's stand-in for a game's character controller: the motions the characters make
//! (walking, jogging, teleports, and the hard ones: sprints with dead stops, hops, setting off
//! at a run, turning round at a run, zigzags, being carried on a platform).

use bevy::prelude::*;

/// How the scene's character moves through the world. Its entity is moved by
/// [`CharacterController`] in `FixedUpdate`, as a game's character controller would, while the
/// walk clip plays in place at the speed that matches the ground speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum CharacterMotion {
    /// Walks on the spot (the clip alone).
    #[default]
    InPlace,
    /// After standing for [`SETTLE_SECONDS`], walks a closed loop at 1.2 m/s: a straight, a
    /// stop, a half turn to the left of 1 m radius, and back.
    Walk,
    /// After standing for [`SETTLE_SECONDS`], jogs 3 m/s straight ahead, stops, turns round
    /// on the spot and jogs back.
    Jog,
    /// Walks on the spot; every 3 s after [`SETTLE_SECONDS`] jumps 10 m sideways and turns a
    /// quarter turn in one step (a respawn), then back.
    Teleport,
    /// After standing for [`SETTLE_SECONDS`], a tour of all of it: walks, stops, turns left,
    /// walks, turns left, jogs and stops, then the same again, which brings it back.
    Tour,
    /// Hard: sprints at 6 m/s for 1.5 s and stops dead for 1 s, again and again; the speed
    /// changes in one step each way.
    Sprint,
    /// Hard: hops on the spot, 0.3 m high (0.49 s in the air, landing at 2.4 m/s), a hop a
    /// second.
    Hop,
    /// Hard: from standing straight into a 3 m/s jog in one step, 2.5 s, then a stop over
    /// 0.75 s and 1.5 s standing.
    SetOff,
    /// Hard: runs at 4 m/s and turns round (180 degrees) in one step every 1.5 s, carrying
    /// on at 4 m/s the other way.
    TurnAround,
    /// Hard: runs at 4 m/s and turns a quarter turn left or right in one step every 0.75 s.
    Zigzag,
    /// Hard: stands (the clip paused) on a platform that carries it to and fro along x,
    /// 3 m either way every 4 s (4.7 m/s at most, 7.4 m/s^2) and bobs 0.1 m up and down.
    Carried,
    /// Stands still: the clip paused, the character not moved (a crowd's idle characters,
    /// whose ponchos fall asleep).
    Stand,
}

impl CharacterMotion {
    /// Every motion, in the order the `poncho` example's keys cycle them.
    pub const ALL: [Self; 12] = [
        Self::InPlace,
        Self::Walk,
        Self::Jog,
        Self::Teleport,
        Self::Tour,
        Self::Sprint,
        Self::Hop,
        Self::SetOff,
        Self::TurnAround,
        Self::Zigzag,
        Self::Carried,
        Self::Stand,
    ];

    /// The hard motions (speed, height or heading changed in one step).
    pub const HARD: [Self; 6] = [
        Self::Sprint,
        Self::Hop,
        Self::SetOff,
        Self::TurnAround,
        Self::Zigzag,
        Self::Carried,
    ];

    /// Its name on the command line (`in-place`, `walk`, `jog`, `teleport`, `tour`, `sprint`,
    /// `hop`, `set-off`, `turn-around`, `zigzag`, `carried`, `stand`).
    pub fn name(&self) -> &'static str {
        match self {
            Self::InPlace => "in-place",
            Self::Walk => "walk",
            Self::Jog => "jog",
            Self::Teleport => "teleport",
            Self::Tour => "tour",
            Self::Sprint => "sprint",
            Self::Hop => "hop",
            Self::SetOff => "set-off",
            Self::TurnAround => "turn-around",
            Self::Zigzag => "zigzag",
            Self::Carried => "carried",
            Self::Stand => "stand",
        }
    }

    /// The motion named `name` (see [`CharacterMotion::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The controller's script: legs of (seconds, speed m/s, turn rate rad/s), looped. Each
    /// script turns the character by half a turn in all, so running it twice brings the
    /// character back to where it started.
    pub(super) fn legs(&self) -> &'static [Leg] {
        use std::f32::consts::PI;
        const fn leg(seconds: f32, speed: f32, turn_rate: f32) -> Leg {
            Leg {
                seconds,
                speed,
                turn_rate,
                acceleration: ACCELERATION,
                turn: 0.0,
                hop: 0.0,
            }
        }
        // Reaches its speed in one step.
        const fn sharp(seconds: f32, speed: f32, turn: f32) -> Leg {
            Leg {
                acceleration: f32::INFINITY,
                turn,
                ..leg(seconds, speed, 0.0)
            }
        }
        // In the air for the whole leg, `height` high at the top (a ballistic arc under
        // 9.81 m/s^2 when the leg lasts 2 sqrt(2 height / g)).
        const fn hop(seconds: f32, height: f32) -> Leg {
            Leg {
                hop: height,
                ..sharp(seconds, 0.0, 0.0)
            }
        }
        // A half turn of 1 m radius at 1.2 m/s takes pi / 1.2 s.
        const WALK_TURN: f32 = PI / 1.2;
        const WALK: [Leg; 8] = [
            leg(1.5, 1.2, 0.0),
            leg(1.5, 0.0, 0.0),
            leg(1.5, 1.2, 0.0),
            leg(WALK_TURN, 1.2, 1.2),
            leg(1.5, 1.2, 0.0),
            leg(1.5, 0.0, 0.0),
            leg(1.5, 1.2, 0.0),
            leg(WALK_TURN, 1.2, 1.2),
        ];
        const JOG: [Leg; 4] = [
            leg(2.5, 3.0, 0.0),
            leg(1.0, 0.0, 0.0),
            leg(1.0, 0.0, PI),
            leg(0.3, 0.0, 0.0),
        ];
        // A quarter turn at 1.2 rad/s.
        const QUARTER: f32 = PI / 2.0 / 1.2;
        const TOUR: [Leg; 7] = [
            leg(2.5, 1.2, 0.0),
            leg(1.0, 0.0, 0.0),
            leg(QUARTER, 1.2, 1.2),
            leg(1.5, 1.2, 0.0),
            leg(QUARTER, 1.2, 1.2),
            leg(2.0, 3.0, 0.0),
            leg(1.2, 0.0, 0.0),
        ];
        const SPRINT: [Leg; 2] = [sharp(1.5, 6.0, 0.0), sharp(1.0, 0.0, 0.0)];
        // 2 sqrt(2 x 0.3 / 9.81) s in the air.
        const HOP: [Leg; 2] = [hop(0.4946, 0.3), sharp(0.5054, 0.0, 0.0)];
        const SET_OFF: [Leg; 3] = [
            sharp(2.5, 3.0, 0.0),
            leg(0.75, 0.0, 0.0),
            leg(1.5, 0.0, 0.0),
        ];
        const TURN_AROUND: [Leg; 1] = [sharp(1.5, 4.0, PI)];
        const ZIGZAG: [Leg; 2] = [sharp(0.75, 4.0, PI / 2.0), sharp(0.75, 4.0, -PI / 2.0)];
        match self {
            Self::InPlace | Self::Teleport | Self::Carried | Self::Stand => &[],
            Self::Walk => &WALK,
            Self::Jog => &JOG,
            Self::Tour => &TOUR,
            Self::Sprint => &SPRINT,
            Self::Hop => &HOP,
            Self::SetOff => &SET_OFF,
            Self::TurnAround => &TURN_AROUND,
            Self::Zigzag => &ZIGZAG,
        }
    }
}

/// The motions of the characters after the first in a crowd ([`PonchoScene::characters`](super::PonchoScene::characters)),
/// in turn.
pub const CROWD_MOTIONS: [CharacterMotion; 4] = [
    CharacterMotion::Walk,
    CharacterMotion::Jog,
    CharacterMotion::InPlace,
    CharacterMotion::Teleport,
];

/// The character stands this long before it starts to move (walk, jog) or jump (teleport),
/// so the poncho settles on it first, seconds.
pub const SETTLE_SECONDS: f32 = 2.0;

/// How fast the controller changes speed, m/s^2.
const ACCELERATION: f32 = 4.0;

/// One leg of a [`CharacterMotion`]'s script.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Leg {
    seconds: f32,
    speed: f32,
    turn_rate: f32,
    /// How fast the speed changes towards `speed`, m/s^2 (infinite: in one step).
    acceleration: f32,
    /// A turn made in one step as the leg starts, radians.
    turn: f32,
    /// The top of a hop that lasts the leg, metres (0: on the ground).
    hop: f32,
}

impl Leg {
    /// The height above the ground `at` seconds into the leg.
    fn height(&self, at: f32) -> f32 {
        if self.hop == 0.0 {
            return 0.0;
        }
        let tau = (at / self.seconds).clamp(0.0, 1.0);
        4.0 * self.hop * tau * (1.0 - tau)
    }
}

/// The leg of `legs` at `moving` seconds into the script: its index in the whole run (the
/// loops counted), the leg, and the seconds into it.
fn leg_at(legs: &[Leg], moving: f32) -> (u64, Leg, f32) {
    let cycle: f32 = legs.iter().map(|l| l.seconds).sum();
    let loops = (moving / cycle).floor();
    let mut at = moving - loops * cycle;
    let mut index = loops as u64 * legs.len() as u64;
    let mut current = legs[0];
    for leg in legs {
        current = *leg;
        if at < leg.seconds {
            break;
        }
        at -= leg.seconds;
        index += 1;
    }
    (index, current, at)
}

/// The platform of [`CharacterMotion::Carried`]: its offset from where it started `t` seconds
/// into the motion.
fn platform(t: f32) -> Vec3 {
    use std::f32::consts::TAU;
    let w = TAU / 4.0;
    Vec3::new(3.0 * (w * t).sin(), 0.1 * (2.0 * w * t).sin(), 0.0)
}

/// A stand-in for a game's character controller: moves the character entity's [`Transform`]
/// every fixed step along its [`CharacterMotion`] (speed changed at 4 m/s^2 at most, turns at
/// a set rate) and plays the walk clip at the speed that matches its ground speed
/// ([`Clip::stance_speed`](bevy_drape::skeleton::clip::Clip::stance_speed)), so the feet do not
/// skate.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
pub struct CharacterController {
    /// The motion.
    pub motion: CharacterMotion,
    /// Seconds since the motion started.
    pub time: f32,
    /// Current ground speed, m/s.
    pub speed: f32,
    /// Heading, radians about +Y (0 faces +Z).
    pub heading: f32,
    /// Jumps made so far ([`CharacterMotion::Teleport`]).
    pub jumps: u32,
    /// The clip's no-skate ground speed at normal playback, m/s, once known.
    pub stance_speed: Option<f32>,
}

impl CharacterController {
    /// A controller for `motion`, starting at rest.
    pub fn new(motion: CharacterMotion) -> Self {
        Self {
            motion,
            time: 0.0,
            speed: 0.0,
            heading: 0.0,
            jumps: 0,
            stance_speed: None,
        }
    }

    /// Switches to `motion` at once (no standing first); the character slows down or speeds
    /// up from where it is.
    pub fn switch_to(&mut self, motion: CharacterMotion) {
        self.motion = motion;
        self.time = SETTLE_SECONDS;
        self.jumps = 0;
    }

    /// Advances the controller by `dt` and moves `transform` (translation in the ground
    /// plane, heading about +Y). Returns the clip playback speed for the new ground speed.
    pub fn advance(&mut self, dt: f32, transform: &mut Transform) -> f32 {
        self.time += dt;
        let moving = self.time - SETTLE_SECONDS;
        if self.motion == CharacterMotion::Teleport {
            let jumps = (moving / 3.0).floor().max(0.0) as u32;
            if jumps > self.jumps {
                self.jumps = jumps;
                let sign = if jumps % 2 == 1 { 1.0 } else { -1.0 };
                transform.translation.x += 10.0 * sign;
                self.heading += sign * std::f32::consts::FRAC_PI_2;
            }
        }
        if self.motion == CharacterMotion::Stand {
            return 0.0;
        }
        if self.motion == CharacterMotion::Carried {
            let before = (moving - dt).max(0.0);
            if moving > 0.0 {
                transform.translation += platform(moving) - platform(before);
            }
            return 0.0;
        }
        let legs = self.motion.legs();
        let (target, turn_rate, acceleration) = if moving < 0.0 || legs.is_empty() {
            (0.0, 0.0, ACCELERATION)
        } else {
            let (index, current, at) = leg_at(legs, moving);
            // A turn in one step as a leg starts; a hop's height within its leg.
            let (before, previous, previous_at) = leg_at(legs, (moving - dt).max(0.0));
            if index != before || moving - dt < 0.0 {
                self.heading += current.turn;
            }
            let rise = if index == before {
                current.height(at) - previous.height(previous_at)
            } else {
                current.height(at) - previous.height(previous.seconds)
            };
            transform.translation.y += rise;
            (current.speed, current.turn_rate, current.acceleration)
        };
        let change = if acceleration.is_infinite() {
            target - self.speed
        } else {
            (target - self.speed).clamp(-acceleration * dt, acceleration * dt)
        };
        let speed = self.speed + change;
        // The mean of the speeds at both ends of the step: the distance is exact for a
        // constant acceleration.
        let distance = 0.5 * (self.speed + speed) * dt;
        self.speed = speed;
        let half_turn = 0.5 * turn_rate * dt;
        let forward = Quat::from_rotation_y(self.heading + half_turn) * Vec3::Z;
        transform.translation += forward * distance;
        self.heading += turn_rate * dt;
        transform.rotation = Quat::from_rotation_y(self.heading);
        if legs.is_empty() {
            // On the spot: the clip at its own pace.
            return 1.0;
        }
        match self.stance_speed {
            Some(stance) if stance > 0.0 => self.speed / stance,
            _ => 0.0,
        }
    }
}
