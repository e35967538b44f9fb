//! The pins of a [`ClothSolver`]: pinning particles and moving them to their targets, the
//! dragged particle (held like a pin), the inverse masses the pins zero and the long-range
//! attachments (tethers) from every free particle to its nearest pins.

use bevy::math::{Vec3, Vec3A};

use super::{ClothSolver, Pin};
use crate::cloth::batch::PairBatches;
use crate::cloth::constraints::Tether;
use crate::cloth::rest_paths::RestPaths;
use crate::cloth::state::inverse_mass;
use crate::error::ClothError;

/// How many nearest pinned particles each free particle is tethered to.
const TETHERS_PER_PARTICLE: usize = 4;

impl ClothSolver {
    /// Grabs `particle`: from now on it is held like a pin (inverse mass 0) and moved to
    /// [`ClothSolver::drag_to`]'s goal over each step, until [`ClothSolver::release`]. Grabbing
    /// another particle releases the first. Returns `false` if the particle does not exist.
    pub fn grab(&mut self, particle: u32) -> bool {
        let Some(&p) = self.state.positions.get(particle as usize) else {
            return false;
        };
        self.release();
        self.drag = Some(Pin {
            particle,
            start: p,
            end: p,
        });
        self.refresh_masses();
        // The grabbed particle is held like a pin: tether the cloth to it too, so a hard yank
        // pulls the whole cloth along instead of stretching the edges next to it.
        self.rebuild_tethers();
        true
    }

    /// Sets where the grabbed particle must be at the end of the next step (ignored if
    /// nothing is grabbed or the goal is not finite). The goal is kept within the particle's
    /// rest distance of every pin, so a drag cannot tear a pinned cloth apart.
    pub fn drag_to(&mut self, goal: Vec3) {
        let Some(drag) = self.drag else {
            return;
        };
        if !goal.is_finite() {
            return;
        }
        let rest = &self.model.rest_positions;
        let mut goal = Vec3A::from(goal);
        // Alternating projections onto the spheres around the pins.
        for _ in 0..8 {
            for pin in &self.pins {
                let reach = rest[drag.particle as usize].distance(rest[pin.particle as usize]);
                let d = goal - pin.end;
                let len = d.length();
                if len > reach && len > 0.0 {
                    goal = pin.end + d * (reach / len);
                }
            }
        }
        if let Some(drag) = &mut self.drag {
            drag.end = goal;
        }
    }

    /// The grabbed particle, if any.
    pub fn grabbed(&self) -> Option<u32> {
        self.drag.map(|d| d.particle)
    }

    /// Lets go of the grabbed particle; it gets its mass back (unless it is pinned).
    pub fn release(&mut self) {
        if self.drag.take().is_some() {
            self.refresh_masses();
            self.rebuild_tethers();
        }
    }

    /// The pins.
    pub fn pins(&self) -> &[Pin] {
        &self.pins
    }

    /// The long-range attachments currently built (feature `internals`).
    #[cfg(feature = "internals")]
    pub fn tethers(&self) -> &[Tether] {
        &self.tethers
    }

    /// Pins `particles` where they are now (replacing any earlier pins) and rebuilds the
    /// long-range attachments.
    pub fn set_pins(&mut self, particles: &[u32]) -> Result<(), ClothError> {
        let n = self.model.particle_count();
        if let Some(&vertex) = particles.iter().find(|&&p| p as usize >= n) {
            return Err(ClothError::VertexOutOfRange {
                vertex,
                vertex_count: n,
            });
        }
        let mut sorted = particles.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        self.pins = sorted
            .iter()
            .map(|&particle| {
                let p = self.state.positions[particle as usize];
                Pin {
                    particle,
                    start: p,
                    end: p,
                }
            })
            .collect();
        self.refresh_masses();
        self.rebuild_tethers();
        Ok(())
    }

    /// Sets where pinned particle `particle` must be at the end of the next step; it moves
    /// there along a straight line over the substeps. Returns `false` if it is not pinned or
    /// the target is not finite or beyond [`MAX_COORDINATE`](crate::collide::MAX_COORDINATE).
    pub fn set_pin_target(&mut self, particle: u32, target: Vec3) -> bool {
        if !(target.is_finite() && target.abs().max_element() <= crate::collide::MAX_COORDINATE) {
            return false;
        }
        match self.pins.binary_search_by_key(&particle, |p| p.particle) {
            Ok(k) => {
                self.pins[k].end = target.into();
                true
            }
            Err(_) => false,
        }
    }

    /// Recomputes inverse masses from the model: `1 / mass`, or 0 for pinned and massless
    /// particles.
    pub(super) fn refresh_masses(&mut self) {
        for (i, w) in self.state.inverse_masses.iter_mut().enumerate() {
            *w = inverse_mass(self.model.mass(i));
        }
        for pin in self.pins.iter().chain(self.drag.as_ref()) {
            self.state.inverse_masses[pin.particle as usize] = 0.0;
        }
    }

    /// Tethers every free particle to its nearest pinned particles along the cloth (at most
    /// `TETHERS_PER_PARTICLE`), each as long as the distance along the cloth in its rest
    /// shape (`cloth/rest_paths.rs`): the straight distance on a flat piece where the
    /// straight line stays on the cloth, the shortest path over the edges elsewhere, so a
    /// tether never holds the cloth tighter than its edges would.
    pub(super) fn rebuild_tethers(&mut self) {
        self.tethers.clear();
        self.tether_pins.clear();
        self.tether_anchors.clear();
        self.tether_batches = PairBatches::default();
        self.halves = None;
        if self.pins.is_empty() && self.drag.is_none() {
            return;
        }
        let rest = &self.model.rest_positions;
        let paths = self
            .rest_paths
            .get_or_insert_with(|| RestPaths::new(&self.model));
        let anchors: Vec<u32> = self
            .pins
            .iter()
            .chain(self.drag.as_ref())
            .map(|pin| pin.particle)
            .collect();
        let mut along = Vec::new();
        let mut lengths: Vec<Vec<f32>> = Vec::with_capacity(anchors.len());
        for &anchor in &anchors {
            paths.from(rest, anchor, &mut along);
            lengths.push(along.clone());
        }
        // (length, the pin's place in `anchors`).
        let mut nearest: Vec<(f32, u32)> = Vec::with_capacity(anchors.len());
        let mut slots = Vec::new();
        for (i, &w) in self.state.inverse_masses.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            nearest.clear();
            nearest.extend(
                lengths
                    .iter()
                    .enumerate()
                    .map(|(slot, l)| (l[i], slot as u32))
                    .filter(|(l, _)| l.is_finite()),
            );
            let k = TETHERS_PER_PARTICLE.min(nearest.len());
            if k == 0 {
                continue;
            }
            if nearest.len() > k {
                nearest.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
            }
            for &(length, slot) in &nearest[..k] {
                slots.push(slot);
                self.tethers.push(Tether {
                    particle: i as u32,
                    anchor: anchors[slot as usize],
                    length,
                });
            }
        }
        // Grouped by pin: consecutive tethers of different particles do not wait for each
        // other.
        let mut order: Vec<usize> = (0..self.tethers.len()).collect();
        order.sort_by_key(|&k| slots[k]);
        self.tethers = order.iter().map(|&k| self.tethers[k]).collect();
        self.tether_batches = PairBatches::new(
            self.tethers
                .iter()
                .zip(order.iter().map(|&k| slots[k]))
                .map(|(t, slot)| ([t.particle, slot], t.length)),
            self.state.positions.len(),
            false,
        );
        self.tether_anchors = vec![Vec3A::ZERO; anchors.len()];
        self.tether_pins = anchors;
        self.tether_batches.set_weights(&self.state.inverse_masses);
    }
}
