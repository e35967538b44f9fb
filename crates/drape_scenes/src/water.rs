//! Measures of water in cloth, for the water tests and the `pour` scene.

use bevy::math::{Vec2, Vec3A};

/// How many fluid particles are below a sheet of cloth that hangs as a height field
/// (particles `x`, `triangles`): those whose vertical line meets one of its triangles above
/// them. Water that spilled over the rim and fell outside the sheet's outline is not counted.
pub fn particles_below_sheet(x: &[Vec3A], triangles: &[[u32; 3]], fluid: &[Vec3A]) -> usize {
    fluid
        .iter()
        .filter(|p| {
            triangles.iter().any(|t| {
                let [a, b, c] = t.map(|k| x[k as usize]);
                let flat = |v: Vec3A| Vec2::new(v.x, v.z);
                let (pa, pb, pc, pp) = (flat(a), flat(b), flat(c), flat(**p));
                let area = (pb - pa).perp_dot(pc - pa);
                if area.abs() < 1e-12 {
                    return false;
                }
                let u = (pb - pp).perp_dot(pc - pp) / area;
                let v = (pc - pp).perp_dot(pa - pp) / area;
                let w = 1.0 - u - v;
                u >= 0.0 && v >= 0.0 && w >= 0.0 && p.y < u * a.y + v * b.y + w * c.y
            })
        })
        .count()
}
