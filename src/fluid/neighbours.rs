//! Neighbour lists from a uniform grid: the particles are sorted into cubic cells as wide as
//! the longest search distance (a counting sort over a hashed cell table), and each
//! particle's neighbours are the particles of the 27 cells around its own that are close
//! enough: `i` and `j` are neighbours if they are closer than `h + m_i + m_j`, where `m_i` is
//! how far particle `i` may move in the step (so a particle at rest among others at rest
//! lists only its kernel's neighbours, and a fast one all it can reach). Built once per fixed
//! step; every list reuses its memory.

use bevy::math::Vec3A;

/// Every particle's neighbours within a radius, as one flat list.
#[derive(Clone, Debug, Default)]
pub(crate) struct Neighbours {
    /// The neighbours of `i` are `list[start[i]..start[i + 1]]` (never `i` itself).
    start: Vec<u32>,
    list: Vec<u32>,
    /// Per hashed cell, where its particles begin in `sorted` (one more entry at the end).
    cell_start: Vec<u32>,
    /// The particles by cell.
    sorted: Vec<u32>,
    /// Each particle's hashed cell.
    cell_of: Vec<u32>,
}

/// A cell's integer coordinates hashed into `mask + 1` buckets.
#[inline(always)]
pub(crate) fn bucket(c: [i32; 3], mask: u32) -> u32 {
    let h = (c[0].wrapping_mul(92_837_111))
        ^ (c[1].wrapping_mul(689_287_499))
        ^ (c[2].wrapping_mul(283_923_481));
    (h as u32) & mask
}

/// The integer coordinates of the cell of width `1 / inv` that holds `p`.
#[inline(always)]
pub(crate) fn cell_of(p: Vec3A, inv: f32) -> [i32; 3] {
    let c = (p * inv).floor();
    [c.x as i32, c.y as i32, c.z as i32]
}

impl Neighbours {
    /// Finds, for every position in `x`, the others closer than `h + margins[i] +
    /// margins[j]` (`h` > 0, margins finite and non-negative, one per position). Positions
    /// must be finite.
    pub(crate) fn build(&mut self, x: &[Vec3A], h: f32, margins: &[f32]) {
        let n = x.len();
        debug_assert_eq!(margins.len(), n);
        let widest = margins.iter().copied().fold(0.0f32, f32::max);
        let radius = h + 2.0 * widest;
        let buckets = (2 * n).next_power_of_two().max(64);
        let mask = buckets as u32 - 1;
        let inv = 1.0 / radius;
        self.cell_start.clear();
        self.cell_start.resize(buckets + 1, 0);
        self.cell_of.clear();
        for &p in x {
            let b = bucket(cell_of(p, inv), mask);
            self.cell_of.push(b);
            self.cell_start[b as usize + 1] += 1;
        }
        for b in 0..buckets {
            self.cell_start[b + 1] += self.cell_start[b];
        }
        self.sorted.clear();
        self.sorted.resize(n, 0);
        // Fill from each bucket's end down, leaving `cell_start` as the bucket starts.
        for (i, &b) in self.cell_of.iter().enumerate().rev() {
            let end = &mut self.cell_start[b as usize + 1];
            *end -= 1;
            self.sorted[*end as usize] = i as u32;
        }
        // `cell_start[b + 1]` now holds bucket b's start: shift back by one.
        self.cell_start.rotate_left(1);
        self.cell_start[buckets] = n as u32;
        self.start.clear();
        self.list.clear();
        self.start.push(0);
        let mut seen = [u32::MAX; 27];
        for (i, &p) in x.iter().enumerate() {
            let c = cell_of(p, inv);
            let reach = h + margins[i];
            let mut buckets_seen = 0;
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let b = bucket([c[0] + dx, c[1] + dy, c[2] + dz], mask);
                        // Two neighbouring cells may hash to one bucket: visit it once.
                        if seen[..buckets_seen].contains(&b) {
                            continue;
                        }
                        seen[buckets_seen] = b;
                        buckets_seen += 1;
                        let range = self.cell_start[b as usize] as usize
                            ..self.cell_start[b as usize + 1] as usize;
                        for &j in &self.sorted[range] {
                            let r = reach + margins[j as usize];
                            if j as usize != i && x[j as usize].distance_squared(p) < r * r {
                                self.list.push(j);
                            }
                        }
                    }
                }
            }
            self.start.push(self.list.len() as u32);
        }
    }

    /// The neighbours of particle `i`.
    #[inline(always)]
    pub(crate) fn of(&self, i: usize) -> &[u32] {
        &self.list[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// How many neighbour entries there are (each pair counted from both sides).
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.list.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    #[test]
    fn the_grid_finds_exactly_the_pairs_a_brute_force_search_finds() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        let mut grid = Neighbours::default();
        for case in 0..6 {
            let n = 50 + 150 * case;
            // Clustered and spread clouds, some at negative coordinates and far from the origin.
            let spread = 0.05 + 0.3 * rng.uniform();
            let offset = Vec3A::new(rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform()) * 40.0;
            let x: Vec<Vec3A> = (0..n)
                .map(|_| offset + Vec3A::from(rng.vec3(-0.5, 0.5)) * spread)
                .collect();
            let h = 0.02 + 0.05 * rng.uniform();
            // Margins of all sizes, most at rest (0), some up to h / 2.
            let margins: Vec<f32> = (0..n).map(|_| (rng.uniform() - 0.5).max(0.0) * h).collect();
            grid.build(&x, h, &margins);
            let mut pairs = 0;
            for i in 0..n {
                let mut found: Vec<u32> = grid.of(i).to_vec();
                found.sort_unstable();
                let expected: Vec<u32> = (0..n as u32)
                    .filter(|&j| {
                        let r = h + margins[i] + margins[j as usize];
                        j as usize != i && x[j as usize].distance_squared(x[i]) < r * r
                    })
                    .collect();
                assert_eq!(found, expected, "case {case}, particle {i}");
                pairs += expected.len();
            }
            assert_eq!(grid.len(), pairs);
        }
    }
}
