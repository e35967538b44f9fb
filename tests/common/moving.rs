//! Characters moved through the world as a game moves them: a system moves an entity along a
//! smooth random motion every fixed step, in the schedule a test chooses.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use bevy_drape::prelude::*;

use super::{Headless, Rng};

/// Fixed steps per second.
pub(crate) const HZ: f64 = 64.0;

/// A smooth random motion of an entity: a circle of random radius and rate, a bob, and a
/// turn at a varying rate about a slightly tilted axis (for a parent) or about +Y.
#[derive(Component, Clone, Copy, Debug)]
pub(crate) struct Mover {
    centre: Vec3,
    radius: f32,
    rate: f32,
    bob: f32,
    spin: f32,
    spin_change: f32,
    tilt: Vec3,
}

impl Mover {
    /// A motion drawn from `seed`, its turn about a tilted axis if `tilted`.
    pub(crate) fn random(seed: u32, tilted: bool) -> Self {
        let mut rng = Rng(seed.into());
        let mut next = || rng.uniform();
        Self {
            centre: Vec3::new(next() - 0.5, 0.0, next() - 0.5),
            radius: 0.5 + 2.0 * next(),
            // Walking to jogging pace along the circle.
            rate: 0.4 + 1.2 * next(),
            bob: 0.05 * next(),
            spin: -2.0 + 4.0 * next(),
            spin_change: -1.0 + 2.0 * next(),
            tilt: if tilted {
                Vec3::new(0.2 * next(), 1.0, 0.2 * next()).normalize()
            } else {
                Vec3::Y
            },
        }
    }

    /// The entity's transform at time `t`, s.
    pub(crate) fn transform_at(&self, t: f32) -> Transform {
        let a = self.rate * t;
        let translation = self.centre
            + Vec3::new(
                self.radius * a.cos(),
                self.bob * (3.0 * a).sin(),
                self.radius * a.sin(),
            );
        let turn = self.spin * t + 0.5 * self.spin_change * t * t;
        Transform::from_translation(translation)
            .with_rotation(Quat::from_axis_angle(self.tilt, turn))
    }
}

/// Moves every [`Mover`] to where its motion is at the elapsed time.
pub(crate) fn move_movers(mut movers: Query<(&Mover, &mut Transform)>, time: Res<Time>) {
    for (mover, mut transform) in &mut movers {
        *transform = mover.transform_at(time.elapsed_secs());
    }
}

/// Where the moving system runs.
#[derive(Clone, Copy, Debug)]
pub(crate) enum MoverAt {
    FixedPreUpdate,
    FixedUpdate,
    AfterStep,
    FixedLast,
}

/// A headless App stepping `1 / HZ` s per update at `HZ` fixed steps per second, with the
/// moving system in `mover_at`.
pub(crate) fn app(mover_at: MoverAt) -> App {
    let mut app = Headless::new()
        .seconds_per_update(1.0 / HZ)
        .fixed_hz(HZ)
        .build();
    match mover_at {
        MoverAt::FixedPreUpdate => app.add_systems(FixedPreUpdate, move_movers),
        MoverAt::FixedUpdate => app.add_systems(FixedUpdate, move_movers),
        MoverAt::AfterStep => {
            app.add_systems(FixedPostUpdate, move_movers.after(DrapeSystems::Step))
        }
        MoverAt::FixedLast => app.add_systems(FixedLast.intern(), move_movers),
    };
    app
}
