//! Rim limits: the rim of a hole in the cloth (a collar, a cuff, the end of a sleeve), and the
//! two rings of cloth next to it, are never longer than at rest.
//!
//! A ring of cloth that rests on a dome or a cone (a collar on the shoulders) carries the
//! weight below it as hoop tension. Stretched uniformly, the ring must move towards its axis
//! to recover, but each edge projection moves its two particles almost along the ring: a
//! Gauss-Seidel sweep passes the error round the ring and takes out only a fraction of order
//! `(pi / n)^2` of it per sweep for a ring of `n` edges, while the contact pushes the ring
//! out again in every iteration. The rim slides down the dome until its edges are stretched
//! enough to hold it.
//!
//! The rim limit is the constraint on that slow mode alone: the rim's length, the sum of its
//! edges, at most the sum of their rest lengths. It is exact (an unstretched cloth always
//! meets it; the rim may fold and twist freely), unilateral, and projected as a scaling of
//! the rim about its centre of mass, which is the direction its length changes fastest for a
//! round rim and moves no particle along the rim: one projection puts a uniformly stretched
//! round rim back to its rest length, wherever the contact left it.
//!
//! Rims are the boundary loops of the mesh that bound a hole: at rest, the cloth next to the
//! loop lies away from the loop's centroid (or beside it, for the end of a tube). The outer
//! boundary of a sheet, with the cloth inside the loop, has none: contracting it would pull
//! the sheet's edge into the cloth.

use bevy::math::{Vec3, Vec3A};

use super::model::boundary_edges;

/// The mean cosine between the inside of a boundary loop (in its plane, to the left of each
/// edge as the loop is walked) and the direction into the cloth beside the edge, above which
/// the loop encloses the cloth and is no rim.
const ENCLOSES_COS: f32 = 0.5;

/// Rings parallel to each rim that are limited too ([`find_rings`]). Measured with a collar on
/// a capsule's dome (`tests/contact_strain.rs`, an earlier draw of its random cases), its
/// largest strain after the first second at 8 x 2: no ring 6.0-7.3%, one 3.4-4.9%, two or
/// three 3.3-4.9%, all 3.3-4.9%; at 16 x 4: 1.8-2.3%, then 0.45-0.83% with any. With every
/// ring (seven) the flat ring of cloth on a dome, whose outer rings hang folded round the
/// capsule, left its dome at 16 x 4 through the capsule; with up to three it stays.
const RINGS_PER_RIM: u32 = 2;

/// No particle moves farther than this times the rim's excess length in one projection (a
/// round rim moves each by about `1 / (2 pi)` of it; a rim folded onto itself, or held along
/// a surface that leaves it little room, has a short lever and would otherwise jump).
const MAX_MOVE: f32 = 0.5;

/// A closed loop of the cloth's edges, its length limited to its rest length: the boundary
/// round a hole ([`find_rims`]) or a ring next to it ([`find_rings`]).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Rim {
    /// The loop's particles, in order round it.
    pub(crate) particles: Vec<u32>,
    /// The sum of the rest lengths of its edges, metres.
    pub(crate) rest_length: f32,
}

/// The rims of a mesh with rest positions `rest` and `triangles`: every closed boundary loop
/// that bounds a hole (see the [module docs](self)). Loops through a vertex with more than two
/// boundary edges (two holes meeting at a point) are left out.
pub(crate) fn find_rims(rest: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Rim> {
    let n = rest.len();
    // Per vertex, its boundary neighbours and the triangle beside each boundary edge.
    let mut next: Vec<Vec<(u32, u32)>> = vec![Vec::new(); n];
    for ([a, b], t) in boundary_edges(triangles) {
        if (b as usize) < n {
            next[a as usize].push((b, t));
            next[b as usize].push((a, t));
        }
    }
    let mut visited = vec![false; n];
    let mut rims = Vec::new();
    for start in 0..n {
        if visited[start] || next[start].len() != 2 {
            continue;
        }
        // Walk round the loop until it closes, or stops at a vertex that is not on exactly
        // two boundary edges.
        visited[start] = true;
        let mut loop_particles = vec![start as u32];
        let (mut current, first) = next[start][0];
        let mut beside = vec![first];
        let mut previous = start as u32;
        let closed = loop {
            if current as usize == start {
                break true;
            }
            let links = &next[current as usize];
            if visited[current as usize] || links.len() != 2 {
                break false;
            }
            visited[current as usize] = true;
            loop_particles.push(current);
            let (to, t) = if links[0].0 == previous {
                links[1]
            } else {
                links[0]
            };
            beside.push(t);
            previous = current;
            current = to;
        };
        if !closed || loop_particles.len() < 3 {
            continue;
        }
        let points: Vec<Vec3> = loop_particles.iter().map(|&i| rest[i as usize]).collect();
        // The loop's plane, oriented by the walk: the inside of the loop lies to the left of
        // each edge, `normal x (q - p)`. The cloth beside a rim lies to its right (a hole in a
        // sheet) or out of its plane (the end of a tube); beside the outer edge of a sheet,
        // to its left, whatever the sheet's shape (a long strip too).
        let area: Vec3 = (0..points.len())
            .map(|k| points[k].cross(points[(k + 1) % points.len()]))
            .sum();
        let normal = area.normalize_or_zero();
        let mut cos_sum = 0.0;
        for (k, &t) in beside.iter().enumerate() {
            let (p, q) = (points[k], points[(k + 1) % points.len()]);
            let mid = (p + q) * 0.5;
            let tri = triangles[t as usize].map(|i| rest[i as usize]);
            // Across the edge only: beside a long thin triangle the centroid lies mostly along it.
            let along = (q - p).normalize_or_zero();
            let into = (tri[0] + tri[1] + tri[2]) / 3.0 - mid;
            let inward = (into - along * along.dot(into)).normalize_or_zero();
            // Each edge's vote counts as far as its triangle lies in the loop's plane: the
            // triangles beside a tube's end stand across it, however skewed their cells.
            let flat = (tri[1] - tri[0])
                .cross(tri[2] - tri[0])
                .normalize_or_zero()
                .dot(normal)
                .powi(2);
            cos_sum += flat * normal.cross(along).normalize_or_zero().dot(inward);
        }
        if cos_sum / beside.len() as f32 > ENCLOSES_COS {
            continue;
        }
        let rest_length = loop_length(rest, &loop_particles);
        rims.push(Rim {
            particles: loop_particles,
            rest_length,
        });
    }
    rims
}

/// The rings of cloth parallel to each rim: the particles `k` edges from it (`k` = 1 to
/// [`RINGS_PER_RIM`]) when they form one closed loop of edges, every particle of it joined to
/// exactly two others of it (the rings of a tube or a collar next to its rim). Each is limited
/// like a rim: a collar resting on a dome carries its hoop tension in the rim and the rings
/// just below it, whose hoop mode the sweep barely moves either (see the [module docs](self));
/// the limit is exact for any closed loop of edges. The search round a rim stops at the first
/// ring that is no single loop (a corner of a square pattern, a ring that meets the outer edge).
pub(crate) fn find_rings(rest: &[Vec3], edges: &[[u32; 2]], rims: &[Rim]) -> Vec<Rim> {
    let n = rest.len();
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &[a, b] in edges {
        if (a as usize) < n && (b as usize) < n && a != b {
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
        }
    }
    for list in &mut neighbours {
        list.sort_unstable();
        list.dedup();
    }
    let mut rings = Vec::new();
    let mut level = vec![u32::MAX; n];
    // The rims' own particles count as limited already (a short tube's ring can be its other rim).
    let mut ringed = vec![false; n];
    for &i in rims.iter().flat_map(|r| &r.particles) {
        if let Some(r) = ringed.get_mut(i as usize) {
            *r = true;
        }
    }
    for rim in rims {
        level.fill(u32::MAX);
        let mut front: Vec<u32> = rim.particles.clone();
        for &i in &front {
            level[i as usize] = 0;
        }
        for k in 1..=RINGS_PER_RIM {
            let mut ring = Vec::new();
            for &i in &front {
                for &j in &neighbours[i as usize] {
                    if level[j as usize] == u32::MAX {
                        level[j as usize] = k;
                        ring.push(j);
                    }
                }
            }
            let Some(ordered) = ordered_loop(&ring, &neighbours, &level, k) else {
                break;
            };
            // A ring between two rims (a tube's) is found from both: kept once.
            if ordered.iter().any(|&i| ringed[i as usize]) {
                break;
            }
            for &i in &ordered {
                ringed[i as usize] = true;
            }
            let rest_length = loop_length(rest, &ordered);
            rings.push(Rim {
                particles: ordered,
                rest_length,
            });
            front = ring;
        }
    }
    rings
}

/// The length of the closed loop through `particles` at the positions `rest`.
fn loop_length(rest: &[Vec3], particles: &[u32]) -> f32 {
    (0..particles.len())
        .map(|m| {
            let (a, b) = (particles[m], particles[(m + 1) % particles.len()]);
            rest[a as usize].distance(rest[b as usize])
        })
        .sum()
}

/// `ring`'s particles in order round it, if each is joined to exactly two others at `level`
/// `k` and they form one loop of at least three.
fn ordered_loop(ring: &[u32], neighbours: &[Vec<u32>], level: &[u32], k: u32) -> Option<Vec<u32>> {
    if ring.len() < 3 {
        return None;
    }
    let beside = |i: u32| {
        neighbours[i as usize]
            .iter()
            .copied()
            .filter(move |&j| level[j as usize] == k)
    };
    if ring.iter().any(|&i| beside(i).count() != 2) {
        return None;
    }
    let mut ordered = vec![ring[0]];
    let (mut previous, mut current) = (ring[0], beside(ring[0]).next()?);
    while current != ring[0] {
        if ordered.len() >= ring.len() {
            return None;
        }
        ordered.push(current);
        let next = beside(current).find(|&j| j != previous)?;
        previous = current;
        current = next;
    }
    (ordered.len() == ring.len()).then_some(ordered)
}

/// Projects the rim limit of `rim` (stiffness 1; nothing happens while the rim is no longer
/// than at rest): its free particles are scaled towards their centre of mass `c`,
/// `x_i -= s (x_i - c)`, with `s` chosen so that the rim's length to first order comes back
/// to its rest length (exactly, for a rim that is a scaled copy of its rest shape), and no
/// particle moves farther than [`MAX_MOVE`] times the excess length. A scaling about the
/// centre of mass keeps the linear and angular momentum, and the rim's shape: moving each
/// particle by its own inverse mass, as a distance projection does, would make neighbours of
/// different masses zigzag.
pub(crate) fn project_rim(x: &mut [Vec3A], w: &[f32], rim: &Rim) {
    let p = &rim.particles;
    let len = p.len();
    if len < 3 {
        return;
    }
    let at = |x: &[Vec3A], k: usize| x[p[k % len] as usize];
    let mut length = 0.0;
    let mut moment = Vec3A::ZERO;
    let mut mass = 0.0;
    for k in 0..len {
        length += at(x, k).distance(at(x, k + 1));
        let wi = w[p[k] as usize];
        if wi > 0.0 {
            moment += at(x, k) / wi;
            mass += 1.0 / wi;
        }
    }
    let excess = length - rim.rest_length;
    if excess <= 0.0 || mass <= 0.0 {
        return;
    }
    let centre = moment / mass;
    // dC/ds along the move: the sum over free particles of grad_i C . (x_i - c).
    let mut rate = 0.0;
    let mut reach = 0.0f32;
    for k in 0..len {
        if w[p[k] as usize] <= 0.0 {
            continue;
        }
        let (before, here, after) = (at(x, k + len - 1), at(x, k), at(x, k + 1));
        let grad = (here - before).normalize_or_zero() - (after - here).normalize_or_zero();
        rate += grad.dot(here - centre);
        reach = reach.max((here - centre).length());
    }
    // A rim that is not finite, or has no lever to contract with, is left alone.
    if rate.is_nan() || rate <= f32::EPSILON * length * reach {
        return;
    }
    let s = (excess / rate).min(MAX_MOVE * excess / reach);
    for &i in p {
        let i = i as usize;
        if w[i] > 0.0 {
            x[i] -= (x[i] - centre) * s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::garment::PonchoDesc;
    use crate::cloth::model::GridDesc;
    use crate::rng::Rng;
    use bevy::math::Quat;

    fn triangles(indices: &[u32]) -> Vec<[u32; 3]> {
        indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect()
    }

    fn length(x: &[Vec3A], p: &[u32]) -> f32 {
        (0..p.len())
            .map(|k| x[p[k] as usize].distance(x[p[(k + 1) % p.len()] as usize]))
            .sum()
    }

    #[test]
    fn a_sheet_has_no_rim_and_a_poncho_has_its_collar() {
        let sheet = GridDesc::square(1.0, 9, Vec3::ZERO).mesh();
        assert!(find_rims(&sheet.positions, &triangles(&sheet.indices)).is_empty());
        // Long strips of random proportions and orientation: their edge encloses the cloth
        // however far the ends are from the centroid (a test by the centroid's direction
        // took a strip of 5 x 49 for a rim, and its limit pulled the strip into a bar).
        let mut rng = Rng(0x1234_5678_9abc_def1);
        for _ in 0..20 {
            let across = 2 + (rng.uniform() * 6.0) as u32;
            let along = 10 + (rng.uniform() * 90.0) as u32;
            let grid = GridDesc {
                size: bevy::math::Vec2::new(0.05 + rng.uniform(), 1.0 + 3.0 * rng.uniform()),
                vertices: bevy::math::UVec2::new(across, along),
                orientation: Quat::from_euler(
                    bevy::math::EulerRot::XYZ,
                    rng.uniform() * 6.0,
                    rng.uniform() * 6.0,
                    rng.uniform() * 6.0,
                ),
                origin: Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()),
            };
            let strip = grid.mesh();
            let rims = find_rims(&strip.positions, &triangles(&strip.indices));
            assert!(rims.is_empty(), "{across} x {along}: {} rims", rims.len());
        }
        // Tubes of random size and orientation (a sleeve): both ends are rims, the cloth
        // beside them out of their plane.
        for _ in 0..10 {
            let (sectors, rings) = (
                6 + (rng.uniform() * 30.0) as u32,
                2 + (rng.uniform() * 20.0) as u32,
            );
            let (radius, length) = (0.02 + rng.uniform(), 0.05 + rng.uniform());
            let turn = Quat::from_euler(
                bevy::math::EulerRot::XYZ,
                rng.uniform() * 6.0,
                rng.uniform() * 6.0,
                rng.uniform() * 6.0,
            );
            let mut positions = Vec::new();
            for r in 0..rings {
                for k in 0..sectors {
                    let a = k as f32 / sectors as f32 * std::f32::consts::TAU;
                    let y = length * r as f32 / (rings - 1) as f32;
                    positions.push(turn * Vec3::new(radius * a.cos(), y, radius * a.sin()));
                }
            }
            let mut indices = Vec::new();
            for r in 0..rings - 1 {
                for k in 0..sectors {
                    let (a, b) = (r * sectors + k, r * sectors + (k + 1) % sectors);
                    indices.extend([a, a + sectors, b, b, a + sectors, b + sectors]);
                }
            }
            let rims = find_rims(&positions, &triangles(&indices));
            assert_eq!(rims.len(), 2, "tube of {sectors} x {rings}");
        }
        let desc = PonchoDesc::default();
        let poncho = desc.mesh().unwrap();
        let rims = find_rims(&poncho.positions, &triangles(&poncho.indices));
        assert_eq!(rims.len(), 1);
        for &i in &rims[0].particles {
            let p = poncho.positions[i as usize];
            let r = (p.x * p.x + p.z * p.z).sqrt();
            assert!(r < desc.neck_radius + 1.5 * desc.spacing(), "{r}");
        }
    }

    /// Random round rims, tilted and stretched uniformly, with random masses: one projection
    /// gives back the rest length (a circle scaled about any point is a circle, whose length
    /// is linear in the scale), conserves the linear momentum, and a rim at or below its rest
    /// length is not moved.
    #[test]
    fn the_rings_next_to_a_tubes_rims_are_closed_loops_of_its_edges() {
        let mut rng = Rng(0x0bad_cafe_1234_5678);
        for _ in 0..40 {
            let (sectors, rings) = (
                5 + (rng.uniform() * 30.0) as u32,
                2 + (rng.uniform() * 10.0) as u32,
            );
            let radius = 0.05 + rng.uniform();
            // Cells from a twentieth as tall as they are wide to half again as tall.
            let height =
                std::f32::consts::TAU * radius / sectors as f32 * (0.05 + 1.45 * rng.uniform());
            let mut positions = Vec::new();
            for r in 0..rings {
                let turn = 0.5 * rng.uniform();
                for k in 0..sectors {
                    let a = (k as f32 + turn) / sectors as f32 * std::f32::consts::TAU;
                    positions.push(Vec3::new(
                        radius * a.cos(),
                        height * r as f32,
                        radius * a.sin(),
                    ));
                }
            }
            let mut indices = Vec::new();
            for r in 0..rings - 1 {
                for k in 0..sectors {
                    let (a, b) = (r * sectors + k, r * sectors + (k + 1) % sectors);
                    indices.extend([a, a + sectors, b, b, a + sectors, b + sectors]);
                }
            }
            let tris = triangles(&indices);
            let edges: Vec<[u32; 2]> = tris
                .iter()
                .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
                .collect();
            let rims = find_rims(&positions, &tris);
            assert_eq!(rims.len(), 2, "{sectors} x {rings}, radius {radius}");
            let found = find_rings(&positions, &edges, &rims);
            // Two from each end, none twice, none a rim.
            assert_eq!(
                found.len() as u32,
                (2 * RINGS_PER_RIM).min(rings - 2),
                "{sectors} x {rings}"
            );
            let mut seen = std::collections::HashSet::new();
            for ring in &found {
                assert_eq!(ring.particles.len() as u32, sectors);
                let level = ring.particles[0] / sectors;
                assert!(level > 0 && level < rings - 1);
                let mut length = 0.0;
                for (m, &a) in ring.particles.iter().enumerate() {
                    assert!(seen.insert(a), "particle {a} in two rings");
                    assert_eq!(a / sectors, level, "a ring stays on its level");
                    let b = ring.particles[(m + 1) % ring.particles.len()];
                    assert!(
                        edges.contains(&[a, b]) || edges.contains(&[b, a]),
                        "{a}-{b} is no edge"
                    );
                    length += positions[a as usize].distance(positions[b as usize]);
                }
                assert!((length - ring.rest_length).abs() < 1e-5 * length);
            }
        }
        // A square sheet with a round hole: the ring next to the staircase rim is no single
        // loop (its corners), so none is limited; the search stops there.
        let desc = PonchoDesc::default();
        let poncho = desc.mesh().unwrap();
        let tris = triangles(&poncho.indices);
        let edges: Vec<[u32; 2]> = tris
            .iter()
            .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
            .collect();
        let rims = find_rims(&poncho.positions, &tris);
        for ring in find_rings(&poncho.positions, &edges, &rims) {
            for (m, &a) in ring.particles.iter().enumerate() {
                let b = ring.particles[(m + 1) % ring.particles.len()];
                assert!(edges.contains(&[a, b]) || edges.contains(&[b, a]));
            }
        }
    }

    #[test]
    fn one_projection_restores_a_stretched_round_rim_and_conserves_momentum() {
        let mut rng = Rng(0x2545_f491_4f6c_dd1d);
        for _ in 0..50 {
            let n = 3 + (rng.uniform() * 60.0) as usize;
            let radius = 0.02 + rng.uniform();
            let tilt = Quat::from_rotation_x(rng.uniform() * 3.0)
                * Quat::from_rotation_z(rng.uniform() * 3.0);
            let centre = Vec3A::new(rng.uniform(), rng.uniform(), rng.uniform());
            let circle: Vec<Vec3A> = (0..n)
                .map(|k| {
                    let a = k as f32 / n as f32 * std::f32::consts::TAU;
                    centre + Vec3A::from(tilt * Vec3::new(radius * a.cos(), 0.0, radius * a.sin()))
                })
                .collect();
            let particles: Vec<u32> = (0..n as u32).collect();
            let rim = Rim {
                rest_length: length(&circle, &particles),
                particles,
            };
            let w: Vec<f32> = (0..n).map(|_| 0.1 + 10.0 * rng.uniform()).collect();
            let stretch = 1.0 + 0.3 * rng.uniform();
            let mut x: Vec<Vec3A> = circle
                .iter()
                .map(|&p| centre + (p - centre) * stretch)
                .collect();
            let before = x.clone();
            project_rim(&mut x, &w, &rim);
            let after = length(&x, &rim.particles);
            assert!(
                (after - rim.rest_length).abs() < 1e-4 * rim.rest_length,
                "{n} particles: {after} against {}",
                rim.rest_length
            );
            let momentum: Vec3A = (0..n).map(|i| (x[i] - before[i]) / w[i]).sum();
            let scale: f32 = (0..n).map(|i| (x[i] - before[i]).length() / w[i]).sum();
            // Plus the rounding of the positions, about 1 m from the origin: a stretch of a few
            // parts in 1e5 moves them by micrometres, where f32 keeps 0.1 micrometre.
            let roundoff: f32 = (0..n).map(|i| f32::EPSILON * x[i].length() / w[i]).sum();
            assert!(
                momentum.length() <= 1e-4 * scale + roundoff,
                "{momentum} of {scale}"
            );
            let mut rest = circle.clone();
            project_rim(&mut rest, &w, &rim);
            let mut shorter: Vec<Vec3A> = circle
                .iter()
                .map(|&p| centre + (p - centre) * 0.9)
                .collect();
            let copy = shorter.clone();
            project_rim(&mut shorter, &w, &rim);
            assert!(rest.iter().zip(&circle).all(|(a, b)| a.distance(*b) < 1e-6));
            assert_eq!(shorter, copy);
        }
    }
}
