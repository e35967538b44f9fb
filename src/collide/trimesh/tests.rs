use super::*;
use crate::rng::Rng;

/// A closed box mesh of `n` x `n` quads per face would do; a bumpy grid is enough here.
fn bumpy_grid(n: u32) -> (Vec<Vec3>, Vec<u32>) {
    let mut v = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let (x, z) = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
            v.push(Vec3::new(x, 0.1 * (7.0 * x).sin() * (5.0 * z).cos(), z));
        }
    }
    let mut idx = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            idx.extend_from_slice(&[a, a + n, a + 1, a + 1, a + n, a + n + 1]);
        }
    }
    (v, idx)
}

#[test]
fn the_hierarchy_finds_the_same_closest_point_as_brute_force() {
    let (v, idx) = bumpy_grid(17);
    let mesh = TriMesh::new(&v, &idx).unwrap();
    let mut rng = Rng(12345);
    let mut rand = || rng.uniform();
    for _ in 0..500 {
        let p = Vec3A::new(rand() * 1.4 - 0.2, rand() * 0.8 - 0.4, rand() * 1.4 - 0.2);
        let brute = idx
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3A::from(v[i as usize]));
                closest_point_on_triangle(p, a, b, c).0.distance(p)
            })
            .fold(f32::MAX, f32::min);
        let found = mesh.closest_point(p, 10.0).unwrap();
        assert!(
            (found.distance - brute).abs() < 1e-5,
            "{p}: {found:?} vs {brute}"
        );
        // Within a bound smaller than the distance, nothing is found.
        assert!(mesh.closest_point(p, brute * 0.99 - 1e-6).is_none() || brute < 1e-5);
    }
}

#[test]
fn closest_point_on_a_triangle_covers_every_region() {
    let (a, b, c) = (Vec3A::ZERO, Vec3A::X, Vec3A::Y);
    let cases = [
        (Vec3A::new(0.2, 0.2, 1.0), Vec3A::new(0.2, 0.2, 0.0)),
        (Vec3A::new(-1.0, -1.0, 0.0), a),
        (Vec3A::new(2.0, -0.5, 0.0), b),
        (Vec3A::new(-0.5, 2.0, 0.0), c),
        (Vec3A::new(0.5, -1.0, 0.3), Vec3A::new(0.5, 0.0, 0.0)),
        (Vec3A::new(-1.0, 0.5, 0.0), Vec3A::new(0.0, 0.5, 0.0)),
        (Vec3A::new(1.0, 1.0, 0.0), Vec3A::new(0.5, 0.5, 0.0)),
    ];
    for (p, expected) in cases {
        let (q, _) = closest_point_on_triangle(p, a, b, c);
        assert!(q.distance(expected) < 1e-6, "{p}: {q} vs {expected}");
    }
}

/// A point uniform in the cube of half side `half` about the origin.
fn point(rng: &mut Rng, half: f32) -> Vec3A {
    rng.vec3(-half, half).into()
}

/// A closed UV sphere of radius about 1 with each vertex's radius jittered by `noise`
/// (dented, not convex, for large noise).
fn dented_sphere(rng: &mut Rng, rings: u32, segments: u32, noise: f32) -> (Vec<Vec3>, Vec<u32>) {
    let mut jitter = || 1.0 + noise * rng.range(-1.0, 1.0);
    let mut v = vec![Vec3::Y * jitter(), -Vec3::Y * jitter()];
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let dir = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            v.push(dir * jitter());
        }
    }
    let ring = |r: u32, s: u32| 2 + (r - 1) * segments + s % segments;
    let mut idx = Vec::new();
    for s in 0..segments {
        idx.extend_from_slice(&[0, ring(1, s + 1), ring(1, s)]);
        idx.extend_from_slice(&[1, ring(rings - 1, s), ring(rings - 1, s + 1)]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (
                ring(r, s),
                ring(r, s + 1),
                ring(r + 1, s),
                ring(r + 1, s + 1),
            );
            idx.extend_from_slice(&[a, b, d, a, d, c]);
        }
    }
    (v, idx)
}

/// Inside by the parity of a ray's crossings, brute force.
fn inside_by_parity(v: &[Vec3], idx: &[u32], p: Vec3A) -> bool {
    let dir = Vec3A::new(0.31, 0.17, 0.93).normalize() * 10.0;
    idx.chunks_exact(3)
        .filter(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3A::from(v[i as usize]));
            segment_crosses_triangle(p, dir, a, b, c).is_some()
        })
        .count()
        % 2
        == 1
}

#[test]
fn inside_by_pseudo_normals_is_inside_by_ray_parity_on_random_dented_closed_meshes() {
    let mut rng = Rng(99);
    let (mut checked, mut face_normal_wrong) = (0, 0);
    for (rings, segments) in [(6, 9), (9, 14), (14, 23)] {
        let (v, idx) = dented_sphere(&mut rng, rings, segments, 0.3);
        let mesh = TriMesh::new(&v, &idx).unwrap();
        assert!(mesh.is_closed());
        let shape = mesh.clone();
        for _ in 0..3000 {
            let p = point(&mut rng, 1.4);
            let Some((d, n)) = shape.signed_distance(p, 0.15) else {
                continue;
            };
            let inside = inside_by_parity(&v, &idx, p);
            assert_eq!(d < 0.0, inside, "{p}: {d}");
            // The normal points out: a small step along it goes away from the inside.
            assert!((n.length() - 1.0).abs() < 1e-4);
            checked += 1;
            // What the closest triangle's own face normal would have said.
            let closest = mesh.closest_point(p, 0.15).unwrap();
            let t = closest.triangle as usize;
            if ((p - closest.point).dot(mesh.normals[t]) < 0.0) != inside {
                face_normal_wrong += 1;
            }
        }
    }
    println!(
        "{checked} points near the surface: the closest face's normal misjudged \
         {face_normal_wrong}, the pseudo-normals none"
    );
    assert!(checked > 1000);
}

#[test]
fn a_mesh_is_closed_only_when_every_edge_joins_two_opposite_triangles() {
    let mut rng = Rng(5);
    let (v, idx) = dented_sphere(&mut rng, 7, 10, 0.1);
    assert!(TriMesh::new(&v, &idx).unwrap().is_closed());
    // A hole.
    assert!(!TriMesh::new(&v, &idx[3..]).unwrap().is_closed());
    // One triangle turned over.
    let mut flipped = idx.clone();
    flipped.swap(7, 8);
    assert!(!TriMesh::new(&v, &flipped).unwrap().is_closed());
}

#[test]
fn meshes_split_at_their_seams_are_welded_into_one_closed_surface() {
    // Bevy's cuboid: four vertices of its own per face (24 in all, no edge shared).
    let cuboid = bevy::mesh::Mesh::from(bevy::math::primitives::Cuboid::new(1.0, 2.0, 0.5));
    let (v, idx) = crate::mesh::mesh_triangles(&cuboid).unwrap();
    assert_eq!(v.len(), 24);
    let mesh = TriMesh::new(&v, &idx).unwrap();
    assert!(mesh.is_closed());
    let shape = mesh;
    let (d, n) = shape
        .signed_distance(Vec3A::new(0.3, 0.9, 0.0), 1.0)
        .unwrap();
    assert!(
        (d + 0.1).abs() < 1e-5 && n.abs_diff_eq(Vec3A::Y, 1e-5),
        "{d} {n}"
    );
    // A UV sphere, split along its seam and at its poles.
    let sphere = bevy::mesh::Mesh::from(bevy::math::primitives::Sphere::new(0.5));
    let (v, idx) = crate::mesh::mesh_triangles(&sphere).unwrap();
    assert!(TriMesh::new(&v, &idx).unwrap().is_closed());
}

#[test]
fn an_open_mesh_has_no_inside() {
    let mut rng = Rng(8);
    let (v, idx) = dented_sphere(&mut rng, 10, 16, 0.05);
    // Cut the bottom cap off: points inside are behind the nearest triangle, not inside.
    let open: Vec<u32> = idx
        .chunks_exact(3)
        .filter(|t| t.iter().any(|&i| v[i as usize].y > -0.5))
        .flatten()
        .copied()
        .collect();
    let shape = TriMesh::new(&v, &open).unwrap();
    let mut found = 0;
    for _ in 0..2000 {
        let p = point(&mut rng, 1.0);
        if let Some((d, _)) = shape.signed_distance(p, 0.2) {
            assert!(d >= 0.0, "{p}: {d}");
            found += 1;
        }
    }
    assert!(found > 100);
}

#[test]
fn the_vertices_in_a_box_are_those_a_brute_force_search_finds() {
    let mut rng = Rng(21);
    let (v, idx) = dented_sphere(&mut rng, 9, 14, 0.1);
    let mesh = TriMesh::new(&v, &idx).unwrap();
    let mut found = Vec::new();
    let mut nonempty = 0;
    for _ in 0..200 {
        let centre = point(&mut rng, 1.2);
        let half = Vec3A::new(
            rng.range(0.01, 0.5),
            rng.range(0.01, 0.5),
            rng.range(0.01, 0.5),
        );
        let bounds = Aabb {
            min: centre - half,
            max: centre + half,
        };
        found.clear();
        mesh.vertices_in(&bounds, &mut found);
        found.sort_unstable();
        found.dedup();
        let expected: Vec<u32> = (0..mesh.vertices.len() as u32)
            .filter(|&i| bounds.contains(mesh.vertex(i)))
            .filter(|&i| mesh.triangles.iter().flatten().any(|&j| j == i))
            .collect();
        assert_eq!(found, expected, "{bounds:?}");
        nonempty += usize::from(!found.is_empty());
    }
    assert!(nonempty > 50, "{nonempty}");
}

#[test]
fn the_first_crossing_is_the_nearest_a_brute_force_search_finds() {
    let (v, idx) = bumpy_grid(13);
    let mesh = TriMesh::new(&v, &idx).unwrap();
    let mut rng = Rng(77);
    let mut hits = 0;
    for _ in 0..2000 {
        let from = point(&mut rng, 0.7) + Vec3A::new(0.5, 0.0, 0.5);
        let to = point(&mut rng, 0.7) + Vec3A::new(0.5, 0.0, 0.5);
        let brute = idx
            .chunks_exact(3)
            .filter_map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3A::from(v[i as usize]));
                segment_crosses_triangle(from, to - from, a, b, c)
            })
            .fold(None, |best: Option<f32>, s| {
                Some(best.map_or(s, |b| b.min(s)))
            });
        let found = mesh.first_crossing(from, to, false);
        assert_eq!(brute.is_some(), found.is_some(), "{from} -> {to}");
        if let (Some(s), Some(crossing)) = (brute, found) {
            hits += 1;
            // The crossing's plane meets the segment where brute force did, and its
            // normal faces where the segment came from.
            let point = from + (to - from) * s;
            assert!((point - crossing.plane_point).dot(crossing.normal).abs() < 1e-4);
            assert!((from - point).dot(crossing.normal) >= -1e-6);
        }
    }
    assert!(hits > 100, "{hits}");
}

#[test]
fn bad_meshes_are_refused() {
    assert_eq!(TriMesh::new(&[], &[]), Err(ColliderError::EmptyMesh));
    let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
    assert!(matches!(
        TriMesh::new(&v, &[0, 1, 5]),
        Err(ColliderError::IndexOutOfRange { index: 5, .. })
    ));
    assert!(matches!(
        TriMesh::new(&[Vec3::NAN, Vec3::X, Vec3::Y], &[0, 1, 2]),
        Err(ColliderError::NonFiniteVertex { vertex: 0 })
    ));
    assert_eq!(
        TriMesh::new(&[Vec3::ZERO, Vec3::X, Vec3::X * 2.0], &[0, 1, 2]),
        Err(ColliderError::EmptyMesh)
    );
}
