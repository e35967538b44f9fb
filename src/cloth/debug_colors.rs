//! Debug colours: a colour per cloth vertex showing strain, speed, collider contact or pinned
//! state.

use crate::cloth::{ClothSolver, EdgeKind};
use bevy::reflect::Reflect;

/// What the debug colours show.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum DebugColorMode {
    /// No debug colours: the material's colour.
    #[default]
    Off,
    /// The largest strain of the structural edges at each vertex: blue 0, green 1%, red 2% or
    /// more.
    Strain,
    /// Speed: blue at rest, green 1 m/s, red 2 m/s or more.
    Speed,
    /// Red where the particle touched a collider in the last substep, grey elsewhere.
    Contact,
    /// Red for pinned or grabbed particles, grey for free ones.
    Pinned,
}

impl DebugColorMode {
    /// The next mode, wrapping around (for a key that cycles them).
    pub fn next(self) -> Self {
        match self {
            Self::Off => Self::Strain,
            Self::Strain => Self::Speed,
            Self::Speed => Self::Contact,
            Self::Contact => Self::Pinned,
            Self::Pinned => Self::Off,
        }
    }
}

/// Blue (0) to green (0.5) to red (1), clamped.
fn ramp(t: f32) -> [f32; 4] {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        1.0
    };
    if t < 0.5 {
        let u = t * 2.0;
        [0.1, 0.2 + 0.7 * u, 0.9 - 0.8 * u, 1.0]
    } else {
        let u = (t - 0.5) * 2.0;
        [0.1 + 0.85 * u, 0.9 - 0.75 * u, 0.1, 1.0]
    }
}

const GREY: [f32; 4] = [0.6, 0.6, 0.6, 1.0];
const RED: [f32; 4] = [0.95, 0.15, 0.1, 1.0];

/// Fills `out` with one colour per particle of `sim` for `mode` (empty for `Off`).
pub(crate) fn debug_colors(sim: &ClothSolver, mode: DebugColorMode, out: &mut Vec<[f32; 4]>) {
    out.clear();
    let state = sim.state();
    let n = state.len();
    match mode {
        DebugColorMode::Off => {}
        DebugColorMode::Strain => {
            let mut strain = vec![0.0f32; n];
            let x = &state.positions;
            for e in sim
                .model()
                .edges
                .iter()
                .filter(|e| e.kind == EdgeKind::Structural)
            {
                let [a, b] = e.particles.map(|i| i as usize);
                let s = (x[a].distance(x[b]) - e.rest_length).abs() / e.rest_length;
                strain[a] = strain[a].max(s);
                strain[b] = strain[b].max(s);
            }
            out.extend(strain.iter().map(|&s| ramp(s / 0.02)));
        }
        DebugColorMode::Speed => {
            out.extend(state.velocities.iter().map(|v| ramp(v.length() / 2.0)));
        }
        DebugColorMode::Contact => {
            let contacts = sim.contacts();
            out.extend((0..n).map(|i| match contacts.get(i) {
                Some(c) if c.is_some() => RED,
                _ => GREY,
            }));
        }
        DebugColorMode::Pinned => {
            out.extend(
                state
                    .inverse_masses
                    .iter()
                    .map(|&w| if w == 0.0 { RED } else { GREY }),
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::{ClothModel, ClothSolver, GridDesc};
    use bevy::math::Vec3;

    #[test]
    fn every_mode_gives_one_finite_colour_per_vertex_and_pins_are_red() {
        let grid = GridDesc::square(1.0, 6, Vec3::Y);
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
        let pins = [grid.index(0, 0), grid.index(5, 0)];
        sim.set_pins(&pins).unwrap();
        let mut out = Vec::new();
        let mut mode = DebugColorMode::Strain;
        while mode != DebugColorMode::Off {
            debug_colors(&sim, mode, &mut out);
            assert_eq!(out.len(), 36);
            assert!(
                out.iter()
                    .flatten()
                    .all(|c| c.is_finite() && (0.0..=1.0).contains(c))
            );
            mode = mode.next();
        }
        debug_colors(&sim, DebugColorMode::Pinned, &mut out);
        for pin in pins {
            assert_eq!(out[pin as usize], RED);
        }
        assert_eq!(out[grid.index(5, 5) as usize], GREY);
        debug_colors(&sim, DebugColorMode::Off, &mut out);
        assert!(out.is_empty());
    }
}
