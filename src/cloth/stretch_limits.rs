//! Long-range stretch limits along the straight lines of a mesh.
//!
//! Gauss-Seidel moves tension about one edge per sweep, so a hanging cloth whose weight must
//! travel half the sheet to its pins stretches unless it gets tens of sweeps per substep.
//! Long-range attachments to the pins (Kim, Chentanez and Mueller 2012; [`super::Tether`])
//! fix the particles that hang straight below a pin, but not the middle of a sheet hung from
//! two corners, which sags between them.
//!
//! A stretch limit is the same idea applied inside the cloth: where a run of edges forms a
//! straight line in the rest shape (every row, column and diagonal of a grid), two particles
//! `k` edges apart on that line can never be farther apart than the `k` rest lengths between
//! them without stretching some edge of the run. So the unilateral constraint
//! `|x_i - x_j| <= L_ij` is exact: it never holds an unstretched cloth back (the line may bend
//! and fold freely, only lengthening is refused), and a single projection of it moves tension
//! `k` edges at once. Limits are made at the scales `k` = 2, 4, 8, ... along every line,
//! starting every `k / 2` edges so that no point of a line is a boundary at every scale, and
//! a sweep carries tension across the cloth in about `log2(n)` projections. Measured on S1 at
//! N = 64, 8 substeps x 2 iterations: max strain 1.39% with starts every `k` edges (the rows
//! at multiples of 16 and 32 stretched most), 0.95% with starts every `k / 2`.
//!
//! Lines are found from the rest shape: an edge `a -> b` continues with the edge `b -> c`
//! that points the same way within [`STRAIGHT_COS`]. On a curved or irregular mesh there are
//! few such runs, and few limits.

use bevy::math::Vec3;

use super::model::Edge;

/// Two edges continue a straight line when the cosine of the angle between them is above this.
pub(crate) const STRAIGHT_COS: f32 = 0.9999;

/// `|x_a - x_b| <= length`, both particles weighted by their inverse masses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StretchLimit {
    /// The two particles.
    pub particles: [u32; 2],
    /// The rest length of the straight run of edges between them, metres.
    pub length: f32,
}

// For the scalar batch kernels (`batch/scalar.rs`), built off `x86_64` and in the tests.
#[cfg(any(test, not(all(target_arch = "x86_64", target_feature = "sse2"))))]
/// Projects a stretch limit (stiffness 1; nothing happens while the pair is not stretched).
#[inline(always)]
pub(crate) fn project_stretch_limit(x: &mut [bevy::math::Vec3A], w: &[f32], limit: &StretchLimit) {
    let [a, b] = limit.particles.map(|i| i as usize);
    let d = x[a] - x[b];
    let len_sq = d.length_squared();
    if len_sq <= limit.length * limit.length {
        return;
    }
    let (wa, wb) = (w[a], w[b]);
    let weight = wa + wb;
    if weight == 0.0 {
        return;
    }
    let len = len_sq.sqrt();
    let correction = d * ((len - limit.length) / (len * weight));
    x[a] -= correction * wa;
    x[b] += correction * wb;
}

/// The stretch limits of a mesh with rest positions `rest` and edges `edges`.
pub fn straight_line_limits(rest: &[Vec3], edges: &[Edge]) -> Vec<StretchLimit> {
    let n = rest.len();
    // Adjacency in compressed rows: neighbours of v are adj[start[v]..start[v + 1]].
    let mut start = vec![0u32; n + 1];
    for e in edges {
        for p in e.particles {
            start[p as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; start[n] as usize];
    for e in edges {
        let [a, b] = e.particles;
        adj[fill[a as usize] as usize] = b;
        fill[a as usize] += 1;
        adj[fill[b as usize] as usize] = a;
        fill[b as usize] += 1;
    }
    let neighbours = |v: u32| &adj[start[v as usize] as usize..start[v as usize + 1] as usize];
    // The straight continuation of a -> b, if any.
    let next = |a: u32, b: u32| -> Option<u32> {
        let dir = (rest[b as usize] - rest[a as usize]).normalize_or_zero();
        neighbours(b)
            .iter()
            .copied()
            .filter(|&c| c != a)
            .map(|c| {
                (
                    c,
                    dir.dot((rest[c as usize] - rest[b as usize]).normalize_or_zero()),
                )
            })
            .filter(|&(_, cos)| cos > STRAIGHT_COS)
            .max_by(|x, y| x.1.total_cmp(&y.1))
            .map(|(c, _)| c)
    };

    let mut limits = Vec::new();
    let mut line = Vec::new();
    let mut cumulative = Vec::new();
    for e in edges {
        for (a, b) in [
            (e.particles[0], e.particles[1]),
            (e.particles[1], e.particles[0]),
        ] {
            // Start only where the line begins: a has no straight predecessor before it.
            if next(b, a).is_some() {
                continue;
            }
            line.clear();
            line.push(a);
            line.push(b);
            while line.len() <= n {
                let len = line.len();
                match next(line[len - 2], line[len - 1]) {
                    Some(c) => line.push(c),
                    None => break,
                }
            }
            // Each line is found from both ends; keep one direction.
            if line.len() < 3 || line[0] > line[line.len() - 1] {
                continue;
            }
            cumulative.clear();
            cumulative.push(0.0f32);
            for pair in line.windows(2) {
                let step = rest[pair[0] as usize].distance(rest[pair[1] as usize]);
                cumulative.push(cumulative.last().copied().unwrap_or(0.0) + step);
            }
            let edges_on_line = line.len() - 1;
            let mut k = 2;
            while k <= edges_on_line {
                // Starts every k/2 edges, so no point of the line is a boundary at every scale.
                let mut last_end = 0;
                let mut i = 0;
                while i + k <= edges_on_line {
                    limits.push(StretchLimit {
                        particles: [line[i], line[i + k]],
                        length: cumulative[i + k] - cumulative[i],
                    });
                    last_end = i + k;
                    i += k / 2;
                }
                if last_end < edges_on_line {
                    let j = edges_on_line - k;
                    limits.push(StretchLimit {
                        particles: [line[j], line[edges_on_line]],
                        length: cumulative[edges_on_line] - cumulative[j],
                    });
                }
                k *= 2;
            }
        }
    }
    // Coarse to fine: long limits first, so the shorter ones inside them follow; within a
    // scale, in the order of their first particle, so that on a mesh numbered row by row the
    // sweep runs across the sheet (from a pinned edge when that edge comes first) and visits
    // particles near each other in a row. Measured on S1 at N = 64, 8 x 2: 3.11 ms per frame
    // and 0.94% max strain, against 3.35 ms and 0.98% in the order the lines were found
    // (rows, then columns).
    limits.sort_by(|a, b| {
        let first = |l: &StretchLimit| l.particles[0].min(l.particles[1]);
        b.length.total_cmp(&a.length).then(first(a).cmp(&first(b)))
    });
    limits
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::model::{ClothModel, GridDesc};
    use bevy::math::Vec3A;

    #[test]
    fn a_grid_gets_limits_along_rows_columns_and_diagonals_with_exact_lengths() {
        let n = 9;
        let grid = GridDesc::square(1.0, n, Vec3::ZERO);
        let model = ClothModel::grid(&grid, 0.1).unwrap();
        let limits = straight_line_limits(&model.rest_positions, &model.edges);
        assert!(!limits.is_empty());
        for l in &limits {
            let [a, b] = l.particles.map(|i| model.rest_positions[i as usize]);
            // On a flat grid every line is straight: the limit is the rest distance.
            assert!((a.distance(b) - l.length).abs() < 1e-5);
        }
        // Row 0 from (0, 0) to (8, 0) is limited at scale 8.
        let row = [grid.index(0, 0), grid.index(8, 0)];
        assert!(limits.iter().any(|l| l.particles == row));
        // A column too.
        let col = [grid.index(3, 0), grid.index(3, 4)];
        assert!(limits.iter().any(|l| l.particles == col));
    }

    #[test]
    fn a_bent_line_gets_no_limit_across_the_bend() {
        // An L: 0-1-2 along x, then 2-3-4 along z.
        let rest = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::X * 2.0,
            Vec3::new(2.0, 0.0, 1.0),
            Vec3::new(2.0, 0.0, 2.0),
        ];
        let model = ClothModel::from_particles(&rest, &[1.0; 5], &[[0, 1], [1, 2], [2, 3], [3, 4]])
            .unwrap();
        let limits = straight_line_limits(&model.rest_positions, &model.edges);
        let pairs: Vec<[u32; 2]> = limits.iter().map(|l| l.particles).collect();
        assert_eq!(pairs, vec![[0, 2], [2, 4]]);
    }

    #[test]
    fn projection_only_shortens() {
        let limit = StretchLimit {
            particles: [0, 1],
            length: 1.0,
        };
        let mut x = [Vec3A::ZERO, Vec3A::new(0.5, 0.0, 0.0)];
        project_stretch_limit(&mut x, &[1.0, 1.0], &limit);
        assert_eq!(x[1].x, 0.5);
        let mut x = [Vec3A::ZERO, Vec3A::new(3.0, 0.0, 0.0)];
        project_stretch_limit(&mut x, &[1.0, 1.0], &limit);
        assert!((x[0].x - 1.0).abs() < 1e-6 && (x[1].x - 2.0).abs() < 1e-6);
    }
}
