//! Cloths stepped together in one solve, so that they collide with each other: a
//! [`LayerSolver`] holds one [`ClothSolver`] over all of them side by side
//! ([`ClothModel::side_by_side`]), and each step copies the cloths' states and pins into it and
//! its result back out.

use std::ops::Range;

use bevy::math::{Vec3, Vec3A};

use super::{ClothSolver, Join, Pin};
use crate::cloth::model::ClothModel;
use crate::cloth::rims::Rim;
use crate::cloth::settings::{SelfCollisionMethod, SolverSettings};
use crate::error::ClothError;

/// Cloths (layers) stepped in one solve: every particle of one is kept on its side of the
/// others' triangles near it by the triangle method's vertex-triangle constraint
/// ([`SelfCollisionMethod::Triangles`]), on the side it started on, and each cloth's
/// triangles and its own particles are handled alike, so a contact moves both cloths by their
/// masses and neither always wins.
///
/// Each step: [`LayerSolver::gather`] every cloth (its state, pins and dragged particle),
/// then set the colliders, the followed frame and the wind on [`LayerSolver::solver_mut`] as
/// on one cloth, [`LayerSolver::step`], and [`LayerSolver::scatter`] every cloth.
#[derive(Clone, Debug)]
pub struct LayerSolver {
    solver: ClothSolver,
    /// Where each cloth's particles are in `solver`.
    ranges: Vec<Range<usize>>,
    /// The pins gathered for the coming step, in `solver`'s numbering.
    pins: Vec<Pin>,
    /// The particles pinned in `solver` (sorted), to rebuild its pins only when they change.
    pinned: Vec<u32>,
    /// The dragged particle gathered for the coming step.
    drag: Option<Pin>,
}

impl LayerSolver {
    /// One solve over `cloths`, innermost first, built from their models (their rest shapes
    /// and masses) and started from their current states.
    ///
    /// Errors: no cloths.
    pub fn new(cloths: &[&ClothSolver]) -> Result<Self, ClothError> {
        let models: Vec<&ClothModel> = cloths.iter().map(|c| c.model()).collect();
        let mut solver = ClothSolver::new(ClothModel::side_by_side(&models)?);
        let mut ranges = Vec::with_capacity(cloths.len());
        let mut start = 0;
        for cloth in cloths {
            let end = start + cloth.model().particle_count();
            ranges.push(start..end);
            start = end;
        }
        solver.parts.clone_from(&ranges);
        // Each cloth's own rims: found on the cloths together, one's outline would count as a
        // hole of the other's.
        solver.rims = cloths
            .iter()
            .zip(&ranges)
            .flat_map(|(cloth, range)| {
                cloth.rims.iter().map(|rim| Rim {
                    particles: rim
                        .particles
                        .iter()
                        .map(|&p| p + range.start as u32)
                        .collect(),
                    rest_length: rim.rest_length,
                })
            })
            .collect();
        let mut layers = Self {
            solver,
            ranges,
            pins: Vec::new(),
            pinned: Vec::new(),
            drag: None,
        };
        for (k, cloth) in cloths.iter().enumerate() {
            layers.gather(k, cloth)?;
        }
        layers.settle_pins();
        Ok(layers)
    }

    /// The solve over all the cloths.
    pub fn solver(&self) -> &ClothSolver {
        &self.solver
    }

    /// The solve over all the cloths, to set its colliders, followed frame and wind before
    /// [`LayerSolver::step`].
    pub fn solver_mut(&mut self) -> &mut ClothSolver {
        &mut self.solver
    }

    /// Copies cloth `k`'s state, pins (with their targets) and dragged particle into the
    /// solve. Call for every cloth, in their order (`k` = 0, 1, ...), before each step: the
    /// first starts the step's pins afresh, the last makes them the solve's.
    ///
    /// Errors: no cloth `k`, or a cloth whose particle count is not the one the solve was
    /// built with.
    pub fn gather(&mut self, k: usize, cloth: &ClothSolver) -> Result<(), ClothError> {
        let range = self.checked_range(k, cloth)?;
        if k == 0 {
            self.pins.clear();
            self.drag = None;
        }
        let offset = range.start as u32;
        let (from, to) = (cloth.state(), &mut self.solver.state);
        to.positions[range.clone()].copy_from_slice(&from.positions);
        to.previous_positions[range.clone()].copy_from_slice(&from.previous_positions);
        to.velocities[range.clone()].copy_from_slice(&from.velocities);
        to.inverse_masses[range].copy_from_slice(&from.inverse_masses);
        let moved = |pin: &Pin| Pin {
            particle: pin.particle + offset,
            ..*pin
        };
        self.pins.extend(cloth.pins.iter().map(moved));
        if let Some(drag) = &cloth.drag {
            self.drag = Some(moved(drag));
        }
        if k + 1 == self.ranges.len() {
            self.settle_pins();
        }
        Ok(())
    }

    /// Makes the solve's pins and dragged particle those gathered (rebuilding its
    /// attachments only when the pinned particles changed), with their targets.
    fn settle_pins(&mut self) {
        let pinned_now = self
            .pins
            .iter()
            .map(|p| p.particle)
            .eq(self.pinned.iter().copied());
        let grabbed = self.drag.map(|d| d.particle);
        if !pinned_now {
            self.pinned.clear();
            self.pinned.extend(self.pins.iter().map(|p| p.particle));
            // Pins are sorted per cloth and the cloths come in order: sorted throughout.
            let _ = self.solver.set_pins(&self.pinned);
        }
        if self.solver.grabbed() != grabbed {
            match grabbed {
                Some(particle) => {
                    self.solver.grab(particle);
                }
                None => self.solver.release(),
            }
        }
        self.solver.pins.copy_from_slice(&self.pins);
        self.solver.drag = self.drag;
    }

    /// Steps the solve as [`ClothSolver::step_with`] does, with the triangle method of
    /// self-collision whatever `settings` says (it is what keeps the layers apart).
    pub fn step(
        &mut self,
        settings: &SolverSettings,
        acceleration: Vec3,
        dt: f32,
        join: &dyn Join,
    ) -> Result<(), ClothError> {
        let settings = SolverSettings {
            self_collision: SelfCollisionMethod::Triangles,
            ..*settings
        };
        self.solver.step_with(&settings, acceleration, dt, join)
    }

    /// Copies cloth `k`'s part of the solve's state back into it, its pins at their targets,
    /// the colliders the step met, and the solve's timings into the first cloth's (the
    /// others' are zero).
    ///
    /// Errors: as [`LayerSolver::gather`].
    pub fn scatter(&self, k: usize, cloth: &mut ClothSolver) -> Result<(), ClothError> {
        let range = self.checked_range(k, cloth)?;
        let (from, to) = (&self.solver.state, &mut cloth.state);
        to.positions.copy_from_slice(&from.positions[range.clone()]);
        to.previous_positions
            .copy_from_slice(&from.previous_positions[range.clone()]);
        to.velocities.copy_from_slice(&from.velocities[range]);
        for pin in cloth.pins.iter_mut().chain(cloth.drag.as_mut()) {
            pin.start = pin.end;
        }
        cloth.carried = None;
        cloth.colliders.clone_from(&self.solver.colliders);
        cloth.timings = if k == 0 {
            self.solver.timings
        } else {
            Default::default()
        };
        cloth.self_contacts = if k == 0 { self.solver.self_contacts } else { 0 };
        Ok(())
    }

    /// The pairs of cloths `(inner, outer)` (by their places) that pass through each other
    /// now: an edge of one through a triangle of the other. Built cloths should have none;
    /// those that do are kept as they start, tangled.
    pub fn tangled_layers(&self) -> Vec<(usize, usize)> {
        let x = &self.solver.state.positions;
        let model = &self.solver.model;
        let layer_of = |p: u32| self.ranges.iter().position(|r| r.contains(&(p as usize)));
        let mut tangled = Vec::new();
        for corners in &model.triangles {
            let Some(lt) = layer_of(corners[0]) else {
                continue;
            };
            let [a, b, c] = corners.map(|i| x[i as usize]);
            let (low, high) = (a.min(b).min(c), a.max(b).max(c));
            for edge in &model.edges {
                let [p, q] = edge.particles.map(|i| x[i as usize]);
                let Some(le) = layer_of(edge.particles[0]) else {
                    continue;
                };
                let pair = (le.min(lt), le.max(lt));
                if le == lt
                    || tangled.contains(&pair)
                    || p.min(q).cmpgt(high).any()
                    || p.max(q).cmplt(low).any()
                {
                    continue;
                }
                if segment_through_triangle(p, q, [a, b, c]) {
                    tangled.push(pair);
                }
            }
        }
        tangled.sort_unstable();
        tangled
    }

    fn checked_range(&self, k: usize, cloth: &ClothSolver) -> Result<Range<usize>, ClothError> {
        let range = self
            .ranges
            .get(k)
            .cloned()
            .ok_or(ClothError::LayerChanged { layer: k })?;
        if range.len() != cloth.model().particle_count() {
            return Err(ClothError::LayerChanged { layer: k });
        }
        Ok(range)
    }
}

/// Whether the segment `p`-`q` passes through the triangle `[a, b, c]` (its ends on either side
/// of the triangle's plane, where it meets the plane inside the triangle).
fn segment_through_triangle(p: Vec3A, q: Vec3A, [a, b, c]: [Vec3A; 3]) -> bool {
    let normal = (b - a).cross(c - a);
    let (hp, hq) = ((p - a).dot(normal), (q - a).dot(normal));
    if hp * hq >= 0.0 {
        return false;
    }
    let hit = p + (q - p) * (hp / (hp - hq));
    // The hit on the inner side of all three edges.
    let inside = |u: Vec3A, v: Vec3A| (v - u).cross(hit - u).dot(normal) >= 0.0;
    inside(a, b) && inside(b, c) && inside(c, a)
}
