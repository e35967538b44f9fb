//! Where a cloth's step spends its time, by part of the substep pipeline (`step.rs`).

use std::time::{Duration, Instant};

use bevy::reflect::Reflect;

/// Wall time of the parts of a cloth's last step (every substep's share summed; an adaptive
/// step's undone tries included). The clock is read a few times per iteration, which costs
/// about a microsecond per step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Reflect)]
pub struct StepTimings {
    /// Drag and lift from the air, once per step.
    pub air: Duration,
    /// Prediction, pins, velocities and damping: the passes over every particle.
    pub predict: Duration,
    /// Long-range constraints, edges, rims, volume and bending.
    pub constraints: Duration,
    /// Finding the self-contact candidates and projecting them.
    pub self_collision: Duration,
    /// Collider contacts: the colliders near the cloth, the projection with friction, the
    /// velocity response.
    pub contacts: Duration,
}

impl StepTimings {
    /// The whole step: the sum of the parts.
    pub fn total(&self) -> Duration {
        self.air + self.predict + self.constraints + self.self_collision + self.contacts
    }

    /// Adds `other`'s parts to these (the parts of several cloths, or several steps).
    pub fn add(&mut self, other: &Self) {
        self.air += other.air;
        self.predict += other.predict;
        self.constraints += other.constraints;
        self.self_collision += other.self_collision;
        self.contacts += other.contacts;
    }
}

/// A stopwatch read in laps: each lap is the time since the last one.
pub(super) struct Laps(Instant);

impl Laps {
    /// Starts the first lap.
    pub(super) fn start() -> Self {
        Self(Instant::now())
    }

    /// The time since the last lap (or the start); starts the next lap.
    pub(super) fn lap(&mut self) -> Duration {
        let now = Instant::now();
        let lap = now - self.0;
        self.0 = now;
        lap
    }
}
