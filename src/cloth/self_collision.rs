//! Self-collision: particles of one cloth that are not joined by an edge are kept at least a
//! distance `d` apart (by default the mean rest length of the structural edges), the
//! particle-spacing method of Müller's "Ten Minute Physics" cloth self-collision.
//!
//! Candidates are found once per fixed step: pairs closer than `d` plus how far the two can
//! close in on each other during the step. That is `t_i + t_j`, with `t_i` how far particle
//! `i` travels relative to the cloth's common motion (its speed relative to the centre of the
//! velocities' bounding box, times the step, plus the acceleration's share; at most `d`), so a
//! cloth carried along by its character searches no further than one at rest, and a cloth at
//! rest with one fast corner looks far only around that corner. The search sorts the
//! particles into a grid of cells `d + 2 max t` wide. At the start of every substep the
//! candidates are narrowed to those that can touch within it (closer than their minimum
//! distance plus the substep's share of `t_i + t_j` plus `d / 10` for the solver's own
//! corrections), and those are projected in every solver iteration of the substep like any
//! inequality constraint: with `x_ij = x_i - x_j` and `C = |x_ij| - d_ij <= 0`, the particles
//! move apart along `x_ij` in the ratio of their
//! inverse masses. `d_ij = min(d, |X_i - X_j|)` with `X` the rest positions, so the constraint
//! never pushes apart two particles that were closer than `d` in the rest shape.
//!
//! Particles closer than `d` slide over each other without friction. The spacing alone leaks
//! when a particle crosses a triangle between its vertices faster than `d` per fixed step;
//! the cloth's own speed limit against this is the query reach.

use bevy::math::Vec3A;

use super::constraints::friction_removed;
use super::grid::{Grid, relative_travel, sort_into_cells};
use super::model::ClothModel;
use super::model::EdgeKind;

/// A pair of particles that may come closer than their minimum distance during a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelfContactPair {
    /// The two particles, smaller index first.
    pub particles: [u32; 2],
    /// The distance they are kept apart, metres.
    pub min_distance: f32,
}

/// The self-collision tables of one cloth: the edges' adjacency, the grid and the
/// candidate pairs of the current step. Built once; stepping reuses its memory (the pair list
/// grows to the largest count seen).
#[derive(Clone, Debug)]
pub struct SelfCollision {
    distance: f32,
    rest: Vec<Vec3A>,
    /// The square of the longest edge's length in `rest`.
    longest_edge2: f32,
    /// Compressed adjacency: the neighbours of `i` are
    /// `adjacency[adjacency_start[i]..adjacency_start[i + 1]]`, sorted.
    adjacency_start: Vec<u32>,
    adjacency: Vec<u32>,
    cell_start: Vec<u32>,
    cell_entries: Vec<u32>,
    cell_of: Vec<u32>,
    /// Where each particle is in `cell_entries`.
    slot_of: Vec<u32>,
    pairs: Vec<SelfContactPair>,
    /// How far each particle can travel relative to the others in the current step, metres.
    travel: Vec<f32>,
    /// The candidates that can touch within the current substep.
    near: Vec<SelfContactPair>,
}

impl SelfCollision {
    /// The tables for `model`, keeping particles `distance` apart (`None`: the mean rest length
    /// of the structural edges). `None` when the model has no particles or no usable distance.
    pub fn new(model: &ClothModel, distance: Option<f32>) -> Option<Self> {
        let n = model.particle_count();
        let distance = match distance {
            Some(d) => d,
            None => {
                let (sum, count) = model
                    .edges
                    .iter()
                    .filter(|e| e.kind == EdgeKind::Structural)
                    .fold((0.0, 0usize), |(s, c), e| (s + e.rest_length, c + 1));
                if count == 0 {
                    return None;
                }
                sum / count as f32
            }
        };
        if n == 0 || !(distance > 0.0 && distance.is_finite()) {
            return None;
        }
        let mut degree = vec![0u32; n + 1];
        for edge in &model.edges {
            degree[edge.particles[0] as usize] += 1;
            degree[edge.particles[1] as usize] += 1;
        }
        let mut adjacency_start = vec![0u32; n + 1];
        for i in 0..n {
            adjacency_start[i + 1] = adjacency_start[i] + degree[i];
        }
        let mut fill = adjacency_start.clone();
        let mut adjacency = vec![0u32; adjacency_start[n] as usize];
        for edge in &model.edges {
            let [a, b] = edge.particles;
            adjacency[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            adjacency[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        for i in 0..n {
            adjacency[adjacency_start[i] as usize..adjacency_start[i + 1] as usize].sort_unstable();
        }
        let rest: Vec<Vec3A> = model.rest_positions.iter().map(|&p| p.into()).collect();
        let longest_edge2 = model
            .edges
            .iter()
            .map(|e| rest[e.particles[0] as usize].distance_squared(rest[e.particles[1] as usize]))
            .fold(0.0, f32::max);
        Some(Self {
            distance,
            rest,
            longest_edge2,
            adjacency_start,
            adjacency,
            cell_start: Vec::with_capacity(MAX_CELLS_PER_PARTICLE * n + 2),
            cell_entries: vec![0; n],
            cell_of: vec![0; n],
            slot_of: vec![0; n],
            pairs: Vec::with_capacity(8 * n),
            travel: vec![0.0; n],
            near: Vec::with_capacity(n),
        })
    }

    /// The distance particles are kept apart, metres.
    pub fn distance(&self) -> f32 {
        self.distance
    }

    /// The candidate pairs of the current step.
    pub fn pairs(&self) -> &[SelfContactPair] {
        &self.pairs
    }

    /// Narrows the step's candidates to those that can touch within one of its `substeps`
    /// substeps, seen from the positions `x` at the substep's start (after the prediction):
    /// pairs closer than their minimum distance plus the substep's share of how far the two
    /// travel in the step plus a tenth of the distance, the room left for the solver's
    /// corrections.
    pub fn begin_substep(&mut self, x: &[Vec3A], substeps: u32) {
        let share = 1.0 / substeps.max(1) as f32;
        let margin = 0.1 * self.distance;
        let travel = &self.travel;
        self.near.clear();
        self.near.extend(self.pairs.iter().filter(|pair| {
            let [i, j] = pair.particles.map(|p| p as usize);
            let reach = pair.min_distance + margin + (travel[i] + travel[j]) * share;
            x[i].distance_squared(x[j]) < reach * reach
        }));
    }

    /// Whether particles `a` and `b` share an edge (adjacent particles are never pushed apart).
    pub fn adjacent(&self, a: u32, b: u32) -> bool {
        let (a, b) = (a as usize, b as usize);
        if a + 1 >= self.adjacency_start.len() {
            return false;
        }
        let neighbours =
            &self.adjacency[self.adjacency_start[a] as usize..self.adjacency_start[a + 1] as usize];
        neighbours.binary_search(&(b as u32)).is_ok()
    }

    /// Finds the pairs of non-adjacent particles of `x` (velocities `v`) that can come closer
    /// than the distance within `dt` under an acceleration of magnitude `acceleration`: those
    /// closer than the distance plus both particles' travel (see the module's description).
    ///
    /// The particles are sorted into a dense grid over their bounding box, cells at least the
    /// largest query radius wide (wider when the box would need more than
    /// eight cells per particle); every particle looks at the rest of its
    /// own cell and the 13 cells ahead of it (half of the 26 around it, so each pair is seen
    /// once). The cells of one grid row are consecutive in the sorted order, so that is five
    /// runs of particles each. The pairs come particle by particle, in the particles' order
    /// (the order the edges are swept in). Non-finite particles are in no cell and in no pair.
    pub fn find_pairs(&mut self, x: &[Vec3A], v: &[Vec3A], dt: f32, acceleration: f32) {
        self.pairs.clear();
        self.near.clear();
        let n = x.len().min(v.len()).min(self.rest.len());
        if n == 0 {
            return;
        }
        let max_travel =
            relative_travel(&mut self.travel, &v[..n], dt, acceleration, self.distance);
        let radius = self.distance + 2.0 * max_travel;
        let Some(grid) = Grid::new(&x[..n], radius, MAX_CELLS_PER_PARTICLE * n) else {
            return;
        };
        let cells = (
            &mut self.cell_of[..],
            &mut self.cell_start,
            &mut self.cell_entries[..],
        );
        sort_into_cells(&grid, &x[..n], cells, Some(&mut self.slot_of));
        let [nx, ny, nz] = grid.dims;
        // Particle by particle, so that the pairs come in the order the edges are swept.
        for i in 0..n {
            let c = self.cell_of[i];
            if c == u32::MAX {
                continue;
            }
            let slot = self.slot_of[i];
            let [cx, cy, cz] = grid.coords(c);
            // The rest of this cell and the next one in the row.
            let row_end = c + u32::from(cx + 1 < nx) + 1;
            let mut runs = [(0u32, 0u32); 5];
            runs[0] = (slot + 1, self.cell_start[row_end as usize]);
            // The rows ahead: (y + 1, z) and (y - 1 ..= y + 1, z + 1), three cells each.
            let mut count = 1;
            for (dy, dz) in [(1i32, 0i32), (-1, 1), (0, 1), (1, 1)] {
                let (y, z) = (cy as i32 + dy, cz as i32 + dz);
                if y < 0 || y >= ny as i32 || z < 0 || z >= nz as i32 {
                    continue;
                }
                let row = grid.index([0, y as u32, z as u32]);
                let first = row + cx.saturating_sub(1);
                let last = row + (cx + 1).min(nx - 1);
                runs[count] = (
                    self.cell_start[first as usize],
                    self.cell_start[last as usize + 1],
                );
                count += 1;
            }
            for &(from, to) in &runs[..count] {
                for k in from..to {
                    let j = self.cell_entries[k as usize] as usize;
                    let reach = self.distance + self.travel[i] + self.travel[j];
                    if x[i].distance_squared(x[j]) > reach * reach {
                        continue;
                    }
                    // Only pairs no farther apart in rest than the longest edge can share one.
                    let rest2 = self.rest[i].distance_squared(self.rest[j]);
                    if rest2 <= self.longest_edge2 && self.adjacent(i as u32, j as u32) {
                        continue;
                    }
                    let min_distance = self.distance.min(rest2.sqrt());
                    self.pairs.push(SelfContactPair {
                        particles: [i.min(j) as u32, i.max(j) as u32],
                        min_distance,
                    });
                }
            }
        }
    }

    /// Pushes apart every pair of the substep's candidates ([`Self::begin_substep`]) closer
    /// than its minimum distance, in the ratio of the
    /// inverse masses `w`, and applies Coulomb friction on positions (Macklin et al. 2014,
    /// "Unified particle physics", eq. 24): the pair's relative tangential displacement over
    /// the substep (`x - x_prev`) is removed entirely if it is below `friction` times the
    /// penetration (static), else shortened by that much (kinetic).
    ///
    /// With `velocities`, each correction `dx` also adds `dx * inv_h` to the particle's
    /// velocity (for solvers that do not derive velocities from positions).
    /// Returns how many pairs were in contact.
    pub fn project(
        &self,
        x: &mut [Vec3A],
        x_prev: &[Vec3A],
        w: &[f32],
        friction: f32,
        mut velocities: Option<(&mut [Vec3A], f32)>,
    ) -> usize {
        let mut contacts = 0;
        for pair in &self.near {
            let [i, j] = pair.particles.map(|p| p as usize);
            let wsum = w[i] + w[j];
            if wsum <= 0.0 {
                continue;
            }
            let d = x[i] - x[j];
            let len2 = d.length_squared();
            if len2 >= pair.min_distance * pair.min_distance || len2 <= 1e-18 {
                continue;
            }
            contacts += 1;
            let len = len2.sqrt();
            let normal = d / len;
            let penetration = pair.min_distance - len;
            let mut correction = normal * (penetration / wsum);
            if friction > 0.0 {
                let relative = (x[i] - x_prev[i]) - (x[j] - x_prev[j]);
                correction -= friction_removed(relative, normal, friction * penetration) / wsum;
            }
            x[i] += correction * w[i];
            x[j] -= correction * w[j];
            if let Some((v, inv_h)) = velocities.as_mut() {
                v[i] += correction * (w[i] * *inv_h);
                v[j] -= correction * (w[j] * *inv_h);
            }
        }
        contacts
    }

    /// The closest pair of non-adjacent particles of `x` among the candidates, and its
    /// distance, for diagnostics.
    pub fn closest_pair(&self, x: &[Vec3A]) -> Option<(SelfContactPair, f32)> {
        self.pairs
            .iter()
            .map(|p| {
                let [i, j] = p.particles.map(|q| q as usize);
                (*p, x[i].distance(x[j]))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }
}

/// Most grid cells per particle: a cloth spread thinly over a large box gets wider cells.
const MAX_CELLS_PER_PARTICLE: usize = 8;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::model::GridDesc;
    use bevy::math::Vec3;

    /// Every non-adjacent pair closer than the distance plus both particles' travel.
    fn brute_force(sc: &SelfCollision, x: &[Vec3A]) -> Vec<[u32; 2]> {
        let mut out = Vec::new();
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                let reach = sc.distance() + sc.travel[i] + sc.travel[j];
                if x[i].distance(x[j]) <= reach && !sc.adjacent(i as u32, j as u32) {
                    out.push([i as u32, j as u32]);
                }
            }
        }
        out
    }

    fn found(sc: &SelfCollision) -> Vec<[u32; 2]> {
        let mut found: Vec<[u32; 2]> = sc.pairs().iter().map(|p| p.particles).collect();
        found.sort_unstable();
        found
    }

    #[test]
    fn the_grid_finds_exactly_the_pairs_a_brute_force_search_finds() {
        let model =
            ClothModel::grid(&GridDesc::square(1.0, 13, Vec3::new(-0.5, 0.0, -0.5)), 0.1).unwrap();
        let mut sc = SelfCollision::new(&model, None).unwrap();
        // Crumple the sheet: fold it onto itself around a wavy line.
        let x: Vec<Vec3A> = model
            .rest_positions
            .iter()
            .map(|p| {
                let fold = (p.x * 7.0).sin() * 0.2 + (p.z * 5.0).cos() * 0.05;
                Vec3A::new(p.x.abs() * 0.3, fold, p.z)
            })
            .collect();
        // At rest under an acceleration that moves every particle 1 cm in the step.
        let v = vec![Vec3A::ZERO; x.len()];
        sc.find_pairs(&x, &v, 1.0, 0.02);
        assert!(sc.travel.iter().all(|&t| (t - 0.01).abs() < 1e-6));
        let expected = brute_force(&sc, &x);
        assert!(expected.len() > 50, "the test shape has overlaps");
        assert_eq!(found(&sc), expected);
    }

    #[test]
    fn random_clouds_give_exactly_the_brute_force_pairs_whatever_their_spread() {
        let model =
            ClothModel::grid(&GridDesc::square(1.0, 9, Vec3::new(-0.5, 0.0, -0.5)), 0.1).unwrap();
        let mut sc = SelfCollision::new(&model, None).unwrap();
        let mut rng = crate::rng::Rng(7);
        // From a ball a few distances wide (dense cells) to a box far wider than the grid may
        // cover with cells of the query radius (the cells grow), and a cloud with one far
        // outlier and non-finite input.
        for (case, spread) in [0.2f32, 1.0, 30.0, 1.0e4].into_iter().enumerate() {
            for speed in [0.0, 3.0, 100.0] {
                let mut x: Vec<Vec3A> = (0..model.particle_count())
                    .map(|_| {
                        Vec3A::new(
                            rng.range(-spread, spread),
                            rng.range(-spread, spread) * 0.1,
                            rng.range(-spread, spread),
                        )
                    })
                    .collect();
                // A common drift plus a random part of up to `speed`.
                let mut v: Vec<Vec3A> = (0..x.len())
                    .map(|_| {
                        Vec3A::new(5.0, 0.0, 0.0)
                            + speed
                                * Vec3A::new(
                                    rng.range(-1.0, 1.0),
                                    rng.range(-1.0, 1.0),
                                    rng.range(-1.0, 1.0),
                                )
                    })
                    .collect();
                if case == 3 {
                    // A tight cluster near the origin, one particle far off, one NaN position
                    // and one infinite velocity.
                    for p in x.iter_mut().take(60) {
                        *p *= 1.0e-5;
                    }
                    x[70] = Vec3A::new(f32::NAN, 0.0, 0.0);
                    v[5] = Vec3A::new(0.0, f32::INFINITY, 0.0);
                }
                sc.find_pairs(&x, &v, 1.0 / 60.0, 9.81);
                assert!(sc.travel.iter().all(|t| (0.0..=sc.distance()).contains(t)));
                let expected = brute_force(&sc, &x);
                assert_eq!(found(&sc), expected, "spread {spread}, speed {speed}");
                if spread < 1.0 || case == 3 {
                    assert!(
                        !expected.is_empty(),
                        "spread {spread}: the cloud has close pairs"
                    );
                }
            }
        }
    }

    #[test]
    fn pairs_left_out_cannot_touch_within_the_step() {
        // Random particles in free flight (a common drift, random relative velocities, the
        // same acceleration), and some pinned (no acceleration): every pair the search leaves
        // out stays farther apart than the distance over the whole step.
        let model =
            ClothModel::grid(&GridDesc::square(1.0, 9, Vec3::new(-0.5, 0.0, -0.5)), 0.1).unwrap();
        let mut sc = SelfCollision::new(&model, None).unwrap();
        let d = sc.distance();
        let mut rng = crate::rng::Rng(11);
        let dt = 1.0 / 60.0;
        let g = Vec3A::new(0.0, -9.81, 0.0);
        for _ in 0..20 {
            let x: Vec<Vec3A> = (0..model.particle_count())
                .map(|_| {
                    Vec3A::new(
                        rng.range(-0.4, 0.4),
                        rng.range(-0.4, 0.4),
                        rng.range(0.0, 0.2),
                    )
                })
                .collect();
            let v: Vec<Vec3A> = (0..x.len())
                .map(|_| {
                    Vec3A::new(1.5, 0.0, 0.0)
                        + rng.range(0.0, 4.0)
                            * Vec3A::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0)
                })
                .collect();
            let pinned: Vec<bool> = (0..x.len()).map(|_| rng.uniform() < 0.1).collect();
            sc.find_pairs(&x, &v, dt, g.length());
            let listed = found(&sc);
            let at = |i: usize, t: f32| {
                let a = if pinned[i] { Vec3A::ZERO } else { g };
                x[i] + v[i] * t + 0.5 * a * t * t
            };
            let mut left_out = 0;
            for i in 0..x.len() {
                for j in i + 1..x.len() {
                    if sc.adjacent(i as u32, j as u32)
                        || listed.binary_search(&[i as u32, j as u32]).is_ok()
                    {
                        continue;
                    }
                    left_out += 1;
                    for k in 0..=32 {
                        let t = dt * k as f32 / 32.0;
                        let gap = at(i, t).distance(at(j, t));
                        assert!(gap > d, "pair {i}-{j} left out came {gap} close (d {d})");
                    }
                }
            }
            assert!(left_out > 1000);
            assert!(listed.len() > 10);
        }
    }

    #[test]
    fn projection_separates_two_layers_and_keeps_momentum() {
        let model =
            ClothModel::grid(&GridDesc::square(1.0, 7, Vec3::new(-0.5, 0.0, -0.5)), 0.1).unwrap();
        let mut sc = SelfCollision::new(&model, None).unwrap();
        let d = sc.distance();
        // Fold the sheet in half along x = 0: the two halves lie 0.1 d apart.
        let mut x: Vec<Vec3A> = model
            .rest_positions
            .iter()
            .map(|p| Vec3A::new(p.x.abs(), if p.x < 0.0 { 0.1 * d } else { 0.0 }, p.z))
            .collect();
        let w = vec![1.0; x.len()];
        let before: Vec3A = x.iter().copied().sum();
        let x_prev = x.clone();
        sc.find_pairs(&x, &vec![Vec3A::ZERO; x.len()], 1.0 / 60.0, 0.0);
        sc.begin_substep(&x, 1);
        for _ in 0..20 {
            sc.project(&mut x, &x_prev, &w, 0.0, None);
        }
        let after: Vec3A = x.iter().copied().sum();
        assert!((after - before).length() < 1e-4, "no net push");
        let (_, closest) = sc.closest_pair(&x).unwrap();
        assert!(closest > 0.95 * d, "closest {closest} vs {d}");
    }
}
