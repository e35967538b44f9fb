//! Random triangle-mesh models the way scans come, for tests and benches of mesh colliders:
//! a jittered head with two thin ears (closed slabs or single-sided sheets, at random places
//! and angles) and its bottom cut open, or a closed rock with deep dents. Each comes with the
//! geometry a check needs and the solver never sees: the head closed again, the ears' triangles.

use std::f32::consts::{PI, TAU};

use bevy::math::Vec3;

/// The small deterministic random generator of the crate's tests (`bevy_drape::rng`).
pub use bevy_drape::rng::Rng;

/// A model like a scan: a jittered head of radius about `radius` at the origin, open below,
/// with two thin ears on top.
pub struct Scan {
    /// The collider mesh's vertices (head, open at the bottom or not, and ears).
    pub vertices: Vec<Vec3>,
    /// Its triangles, three indices each, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
    /// The head closed (its bottom cap kept): the ground truth for "inside".
    pub head: Vec<[Vec3; 3]>,
    /// The ears' triangles.
    pub ears: Vec<[Vec3; 3]>,
    /// The head's radius before jitter, metres.
    pub radius: f32,
}

/// What [`scan`] makes: `noise` the relative radial jitter of the head's vertices; `open`
/// cuts the bottom off; `ears` adds them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kind {
    /// The relative radial jitter of the head's vertices.
    pub noise: f32,
    /// Whether the bottom is cut off.
    pub open: bool,
    /// Whether it has ears.
    pub ears: bool,
}

/// A scan-like model: thin ears and an open bottom.
pub const SCAN: Kind = Kind {
    noise: 0.04,
    open: true,
    ears: true,
};

/// A closed rock: a head with deep dents and bumps (not convex), nothing else.
pub const ROCK: Kind = Kind {
    noise: 0.25,
    open: false,
    ears: false,
};

/// The model of `seed`: a head of radius 0.3 m at the origin (0.6 m across).
pub fn scan(seed: u64, kind: Kind) -> Scan {
    let mut rng = Rng(seed);
    let radius = 0.3;
    let rings = 8 + (rng.uniform() * 10.0) as u32;
    let segments = 12 + (rng.uniform() * 16.0) as u32;
    let mut vertices = Vec::new();
    // Poles, then the rings.
    let jitter = |rng: &mut Rng| radius * (1.0 + rng.range(-kind.noise, kind.noise));
    vertices.push(Vec3::Y * jitter(&mut rng));
    vertices.push(-Vec3::Y * jitter(&mut rng));
    for r in 1..rings {
        let theta = PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = TAU * s as f32 / segments as f32;
            let dir = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            vertices.push(dir * jitter(&mut rng));
        }
    }
    let ring = |r: u32, s: u32| 2 + (r - 1) * segments + s % segments;
    let mut closed = Vec::new();
    for s in 0..segments {
        closed.push([0, ring(1, s + 1), ring(1, s)]);
        closed.push([1, ring(rings - 1, s), ring(rings - 1, s + 1)]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (
                ring(r, s),
                ring(r, s + 1),
                ring(r + 1, s),
                ring(r + 1, s + 1),
            );
            closed.push([a, b, d]);
            closed.push([a, d, c]);
        }
    }
    let head: Vec<[Vec3; 3]> = closed
        .iter()
        .map(|t| t.map(|i| vertices[i as usize]))
        .collect();
    // The scan's hole: everything whose vertices are all low.
    let mut indices: Vec<u32> = closed
        .iter()
        .filter(|t| !kind.open || t.iter().any(|&i| vertices[i as usize].y > -0.85 * radius))
        .flatten()
        .copied()
        .collect();
    let mut ears = Vec::new();
    for side in [-1.0f32, 1.0].into_iter().filter(|_| kind.ears) {
        // Where on the head, which way it leans, how big, how thick.
        let azimuth = rng.range(-0.6, 0.6) + if side < 0.0 { PI } else { 0.0 };
        let polar = rng.range(0.35, 0.8);
        let out = Vec3::new(
            polar.sin() * azimuth.cos(),
            polar.cos(),
            polar.sin() * azimuth.sin(),
        );
        let lean = Vec3::new(rng.range(-0.3, 0.3), 1.0, rng.range(-0.3, 0.3));
        let up = (out + lean).normalize();
        let across = up
            .cross(Vec3::new(rng.range(-1.0, 1.0), 0.0, 1.0))
            .normalize();
        let facing = across.cross(up);
        let (height, half_width) = (rng.range(0.12, 0.22), rng.range(0.02, 0.045));
        let thickness = if rng.uniform() < 0.5 { 0.0 } else { 0.004 };
        let base = out * (radius * 0.9);

        let levels = 3;
        // The rim of one face of the ear: left and right edges narrowing to the tip.
        let outline = |offset: f32| {
            let mut rim = Vec::new();
            for l in 0..levels {
                let f = l as f32 / levels as f32;
                let w = half_width * (1.0 - f);
                let c = base + up * (height * f) + facing * offset;
                rim.push((c - across * w, c + across * w));
            }
            (rim, base + up * height + facing * offset)
        };
        let mut sheet = |offset: f32, flip: bool, indices: &mut Vec<u32>| {
            let (rim, tip) = outline(offset);
            let start = vertices.len() as u32;
            for &(l, r) in &rim {
                vertices.push(l);
                vertices.push(r);
            }
            vertices.push(tip);
            let tip_index = start + 2 * levels;
            let mut tris = Vec::new();
            for l in 0..levels - 1 {
                let (a, b, c, d) = (
                    start + 2 * l,
                    start + 2 * l + 1,
                    start + 2 * l + 2,
                    start + 2 * l + 3,
                );
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
            let last = start + 2 * (levels - 1);
            tris.push([last, last + 1, tip_index]);
            for mut t in tris {
                if flip {
                    t.swap(1, 2);
                }
                indices.extend_from_slice(&t);
            }
            start
        };
        if thickness == 0.0 {
            sheet(0.0, false, &mut indices);
        } else {
            let front = sheet(thickness * 0.5, false, &mut indices);
            let back = sheet(-thickness * 0.5, true, &mut indices);
            // The rim between the two faces: left edges, right edges, to the tips.
            for l in 0..levels {
                for (column, flip) in [(0, true), (1, false)] {
                    let (a, b) = (front + 2 * l + column, back + 2 * l + column);
                    let (c, d) = if l + 1 < levels {
                        (front + 2 * (l + 1) + column, back + 2 * (l + 1) + column)
                    } else {
                        (front + 2 * levels, back + 2 * levels)
                    };
                    let quad = [[a, b, d], [a, d, c]];
                    for mut t in quad {
                        if flip {
                            t.swap(1, 2);
                        }
                        indices.extend_from_slice(&t);
                    }
                }
            }
        }
    }
    for t in indices.chunks_exact(3) {
        let tri = [0, 1, 2].map(|k| vertices[t[k] as usize]);
        // The ears are the triangles after the head's.
        if t.iter()
            .all(|&i| i as usize >= 2 + (rings as usize - 1) * segments as usize)
        {
            ears.push(tri);
        }
    }
    Scan {
        vertices,
        indices,
        head,
        ears,
        radius,
    }
}
