//! Self-collision: particles of one cloth that are not joined by an edge are kept at least a
//! distance `d` apart (by default the mean rest length of the structural edges), the
//! particle-spacing method of Müller's "Ten Minute Physics" cloth self-collision.
//!
//! Candidates are found once per fixed step through a spatial hash of cell size `r`, the query
//! radius `d` plus how far two particles can close in on each other during the step (capped at
//! `3 d`): every particle looks at the 3 x 3 x 3 cells around its own. The pairs found are then
//! projected in every solver iteration like any inequality constraint: with `x_ij = x_i - x_j`
//! and `C = |x_ij| - d_ij <= 0`, the particles move apart along `x_ij` in the ratio of their
//! inverse masses. `d_ij = min(d, |X_i - X_j|)` with `X` the rest positions, so the constraint
//! never pushes apart two particles that were closer than `d` in the rest shape.
//!
//! Particles closer than `d` slide over each other without friction. The spacing alone leaks
//! when a particle crosses a triangle between its vertices faster than `d` per fixed step;
//! the cloth's own speed limit against this is the query reach.

use bevy::math::Vec3A;

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

/// The self-collision tables of one cloth: the edges' adjacency, the spatial hash and the
/// candidate pairs of the current step. Built once; stepping reuses its memory (the pair list
/// grows to the largest count seen).
#[derive(Clone, Debug)]
pub struct SelfCollision {
    distance: f32,
    rest: Vec<Vec3A>,
    /// Compressed adjacency: the neighbours of `i` are
    /// `adjacency[adjacency_start[i]..adjacency_start[i + 1]]`, sorted.
    adjacency_start: Vec<u32>,
    adjacency: Vec<u32>,
    cell_start: Vec<u32>,
    cell_entries: Vec<u32>,
    cell_of: Vec<u32>,
    coords: Vec<Option<[i32; 3]>>,
    pairs: Vec<SelfContactPair>,
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
        let table = 2 * n;
        Some(Self {
            distance,
            rest: model.rest_positions.iter().map(|&p| p.into()).collect(),
            adjacency_start,
            adjacency,
            cell_start: vec![0; table + 1],
            cell_entries: vec![0; n],
            cell_of: vec![0; n],
            coords: vec![None; n],
            pairs: Vec::with_capacity(8 * n),
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

    /// Finds the pairs of non-adjacent particles of `x` closer than the distance plus `reach`
    /// (how far two particles can close in on each other before the next search; capped at
    /// twice the distance).
    pub fn find_pairs(&mut self, x: &[Vec3A], reach: f32) {
        self.pairs.clear();
        let n = x.len().min(self.rest.len());
        if n == 0 {
            return;
        }
        let reach = if reach.is_finite() {
            reach.max(0.0)
        } else {
            0.0
        };
        let radius = self.distance + reach.min(2.0 * self.distance);
        let inv_cell = 1.0 / radius;
        let table = self.cell_start.len() - 1;
        // Counting sort of the particles by cell hash.
        self.cell_start.fill(0);
        for ((p, coords), cell_of) in x[..n].iter().zip(&mut self.coords).zip(&mut self.cell_of) {
            *coords = cell_coords(*p, inv_cell);
            let h = match *coords {
                Some(c) => hash(c, table),
                None => table as u32, // non-finite: in no cell
            };
            *cell_of = h;
            if (h as usize) < table {
                self.cell_start[h as usize] += 1;
            }
        }
        let mut running = 0;
        for count in &mut self.cell_start {
            running += *count;
            *count = running;
        }
        for i in (0..n).rev() {
            let h = self.cell_of[i] as usize;
            if h < table {
                self.cell_start[h] -= 1;
                self.cell_entries[self.cell_start[h] as usize] = i as u32;
            }
        }
        let radius2 = radius * radius;
        for i in 0..n {
            let Some(c) = self.coords[i] else {
                continue;
            };
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let cell = [c[0] + dx, c[1] + dy, c[2] + dz];
                        let h = hash(cell, table) as usize;
                        let (start, end) = (self.cell_start[h], self.cell_start[h + 1]);
                        for k in start..end {
                            let j = self.cell_entries[k as usize] as usize;
                            if j <= i || x[i].distance_squared(x[j]) > radius2 {
                                continue;
                            }
                            // Several cells can hash to one bucket: count each pair once, when
                            // visiting `j`'s own cell.
                            if self.coords[j] != Some(cell) {
                                continue;
                            }
                            if self.adjacent(i as u32, j as u32) {
                                continue;
                            }
                            let min_distance =
                                self.distance.min(self.rest[i].distance(self.rest[j]));
                            self.pairs.push(SelfContactPair {
                                particles: [i as u32, j as u32],
                                min_distance,
                            });
                        }
                    }
                }
            }
        }
    }

    /// Pushes apart every candidate pair closer than its minimum distance, in the ratio of the
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
        for pair in &self.pairs {
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
                let tangential = relative - normal * normal.dot(relative);
                let slip = tangential.length();
                let limit = friction * penetration;
                let removed = if slip <= limit {
                    tangential
                } else {
                    tangential * (limit / slip)
                };
                correction -= removed / wsum;
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

fn cell_coords(p: Vec3A, inv_cell: f32) -> Option<[i32; 3]> {
    let c = (p * inv_cell).floor();
    // Far outside any scene (or non-finite): no cell.
    if c.is_nan() || c.abs().max_element() >= 1.0e8 {
        return None;
    }
    Some([c.x as i32, c.y as i32, c.z as i32])
}

fn hash(c: [i32; 3], table: usize) -> u32 {
    let h = (c[0].wrapping_mul(92_837_111))
        ^ (c[1].wrapping_mul(689_287_499))
        ^ (c[2].wrapping_mul(283_923_481));
    (h.unsigned_abs() as usize % table) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::model::GridDesc;
    use bevy::math::Vec3;

    fn brute_force(sc: &SelfCollision, x: &[Vec3A], radius: f32) -> Vec<[u32; 2]> {
        let mut out = Vec::new();
        for i in 0..x.len() {
            for j in i + 1..x.len() {
                if x[i].distance(x[j]) <= radius && !sc.adjacent(i as u32, j as u32) {
                    out.push([i as u32, j as u32]);
                }
            }
        }
        out
    }

    #[test]
    fn the_hash_finds_exactly_the_pairs_a_brute_force_search_finds() {
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
        sc.find_pairs(&x, 0.01);
        let mut found: Vec<[u32; 2]> = sc.pairs().iter().map(|p| p.particles).collect();
        found.sort_unstable();
        let expected = brute_force(&sc, &x, sc.distance() + 0.01);
        assert!(expected.len() > 50, "the test shape has overlaps");
        assert_eq!(found, expected);
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
        sc.find_pairs(&x, 0.0);
        for _ in 0..20 {
            sc.project(&mut x, &x_prev, &w, 0.0, None);
        }
        let after: Vec3A = x.iter().copied().sum();
        assert!((after - before).length() < 1e-4, "no net push");
        let (_, closest) = sc.closest_pair(&x).unwrap();
        assert!(closest > 0.95 * d, "closest {closest} vs {d}");
    }
}
