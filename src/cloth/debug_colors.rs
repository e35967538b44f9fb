//! Debug colours: a colour per cloth particle (strain, speed, collider contact, pinned state)
//! or per triangle (area strain), or the user's own colours or values per particle or per
//! triangle ([`ClothPaint`]).

use crate::cloth::model::EdgeKind;
use crate::cloth::sim::ClothSolver;
use bevy::ecs::component::Component;
use bevy::ecs::reflect::ReflectComponent;
use bevy::reflect::Reflect;

/// What the debug colours show.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum DebugColorMode {
    /// No debug colours: the material's colour.
    #[default]
    Off,
    /// Per particle: the largest strain of the structural edges at each particle: blue 0,
    /// green 1%, red 2% or more.
    Strain,
    /// Per particle: speed: blue at rest, green 1 m/s, red 2 m/s or more.
    Speed,
    /// Per particle: red where the particle touched a collider in the last substep, grey
    /// elsewhere.
    Contact,
    /// Per particle: red for pinned or grabbed particles, grey for free ones.
    Pinned,
    /// Per triangle: how much its area differs from its rest area, `|A / A0 - 1|`: blue 0,
    /// green 1%, red 2% or more (each triangle in one flat colour).
    AreaStrain,
    /// The cloth's own [`ClothPaint`], per particle or per triangle; grey on a cloth without
    /// one.
    Custom,
}

impl DebugColorMode {
    /// The next mode, wrapping around (for a key that cycles them).
    pub fn next(self) -> Self {
        match self {
            Self::Off => Self::Strain,
            Self::Strain => Self::Speed,
            Self::Speed => Self::Contact,
            Self::Contact => Self::Pinned,
            Self::Pinned => Self::AreaStrain,
            Self::AreaStrain => Self::Custom,
            Self::Custom => Self::Off,
        }
    }
}

/// What a list of debug colours colours: one per particle, or one per triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Reflect)]
pub enum PaintTarget {
    /// One colour per particle, blended across each triangle.
    #[default]
    Particles,
    /// One flat colour per triangle (of [`ClothModel::triangles`](crate::cloth::ClothModel)).
    Triangles,
}

/// What a [`ClothPaint`] holds.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub enum PaintSource {
    /// Linear RGBA colours, one per particle or triangle.
    Colors(Vec<[f32; 4]>),
    /// Values, one per particle or triangle, on the debug ramp: blue at `min`, green halfway,
    /// red at `max` or beyond (a non-finite value is red).
    Values {
        /// One value per particle or triangle.
        values: Vec<f32>,
        /// The value shown blue.
        min: f32,
        /// The value shown red.
        max: f32,
    },
}

impl Default for PaintSource {
    fn default() -> Self {
        Self::Colors(Vec::new())
    }
}

/// A cloth's own debug colours, shown while [`DebugColorMode::Custom`] is on: fill it from any
/// system (a value of the solver's state read through
/// [`ClothSimulation::solver`](crate::cloth::plugin::ClothSimulation::solver), a selection, a test's
/// result) and the cloth's mesh shows it. A list of the wrong length is reported once, by
/// entity, and shown grey.
#[derive(Component, Clone, Debug, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct ClothPaint {
    /// Whether the list is per particle or per triangle.
    pub target: PaintTarget,
    /// The colours or values.
    pub source: PaintSource,
}

impl ClothPaint {
    /// One colour per particle.
    pub fn particle_colors(colors: Vec<[f32; 4]>) -> Self {
        Self {
            target: PaintTarget::Particles,
            source: PaintSource::Colors(colors),
        }
    }

    /// One colour per triangle.
    pub fn triangle_colors(colors: Vec<[f32; 4]>) -> Self {
        Self {
            target: PaintTarget::Triangles,
            source: PaintSource::Colors(colors),
        }
    }

    /// One value per particle or triangle, shown on the ramp from `min` (blue) to `max` (red).
    pub fn values(target: PaintTarget, values: Vec<f32>, min: f32, max: f32) -> Self {
        Self {
            target,
            source: PaintSource::Values { values, min, max },
        }
    }

    fn len(&self) -> usize {
        match &self.source {
            PaintSource::Colors(c) => c.len(),
            PaintSource::Values { values, .. } => values.len(),
        }
    }
}

/// A [`ClothPaint`] whose list does not match its cloth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct PaintMismatch {
    /// What the list colours.
    pub target: PaintTarget,
    /// The cloth's particle or triangle count.
    pub expected: usize,
    /// The list's length.
    pub found: usize,
}

/// Blue (0) to green (0.5) to red (1), clamped; red for a non-finite value.
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

/// The colour of what has no value to show (a particle or triangle a paint does not cover).
pub(crate) const GREY: [f32; 4] = [0.6, 0.6, 0.6, 1.0];
const RED: [f32; 4] = [0.95, 0.15, 0.1, 1.0];

/// Fills `out` with the colours of `mode` for `sim` (empty for `Off`) and says whether they are
/// per particle or per triangle. `paint` is the cloth's own, for [`DebugColorMode::Custom`]: a
/// list of the wrong length gives grey and the mismatch.
pub(crate) fn debug_colors(
    sim: &ClothSolver,
    mode: DebugColorMode,
    paint: Option<&ClothPaint>,
    out: &mut Vec<[f32; 4]>,
) -> (PaintTarget, Option<PaintMismatch>) {
    out.clear();
    let state = sim.state();
    let n = state.len();
    let model = sim.model();
    match mode {
        DebugColorMode::Off => {}
        DebugColorMode::Strain => {
            let mut strain = vec![0.0f32; n];
            let x = &state.positions;
            for e in model
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
        DebugColorMode::AreaStrain => {
            let x = &state.positions;
            let rest = &model.rest_positions;
            out.extend(model.triangles.iter().map(|t| {
                let [a, b, c] = t.map(|i| i as usize);
                let area = (x[b] - x[a]).cross(x[c] - x[a]).length();
                let rest_area = (rest[b] - rest[a]).cross(rest[c] - rest[a]).length();
                ramp((area / rest_area - 1.0).abs() / 0.02)
            }));
            return (PaintTarget::Triangles, None);
        }
        DebugColorMode::Custom => {
            let Some(paint) = paint else {
                out.resize(n, GREY);
                return (PaintTarget::Particles, None);
            };
            let expected = match paint.target {
                PaintTarget::Particles => n,
                PaintTarget::Triangles => model.triangles.len(),
            };
            if paint.len() != expected {
                out.resize(expected, GREY);
                let mismatch = PaintMismatch {
                    target: paint.target,
                    expected,
                    found: paint.len(),
                };
                return (paint.target, Some(mismatch));
            }
            match &paint.source {
                PaintSource::Colors(colors) => out.extend(colors.iter().map(|c| {
                    if c.iter().all(|v| v.is_finite()) {
                        c.map(|v| v.clamp(0.0, 1.0))
                    } else {
                        RED
                    }
                })),
                PaintSource::Values { values, min, max } => {
                    let span = max - min;
                    out.extend(values.iter().map(|&v| {
                        if span.abs() > 0.0 && span.is_finite() {
                            ramp((v - min) / span)
                        } else {
                            ramp(if v >= *max { 1.0 } else { 0.0 })
                        }
                    }))
                }
            }
            return (paint.target, None);
        }
    }
    (PaintTarget::Particles, None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::model::{ClothModel, GridDesc};
    use crate::cloth::sim::ClothSolver;
    use bevy::math::Vec3;

    #[test]
    fn every_mode_gives_one_finite_colour_per_particle_or_triangle_and_pins_are_red() {
        let grid = GridDesc::square(1.0, 6, Vec3::Y);
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
        let pins = [grid.index(0, 0), grid.index(5, 0)];
        sim.set_pins(&pins).unwrap();
        let triangles = sim.model().triangles.len();
        let mut out = Vec::new();
        let mut mode = DebugColorMode::Strain;
        while mode != DebugColorMode::Off {
            let (target, mismatch) = debug_colors(&sim, mode, None, &mut out);
            assert!(mismatch.is_none());
            let expected = match target {
                PaintTarget::Particles => 36,
                PaintTarget::Triangles => triangles,
            };
            assert_eq!(out.len(), expected, "{mode:?}");
            assert!(
                out.iter()
                    .flatten()
                    .all(|c| c.is_finite() && (0.0..=1.0).contains(c))
            );
            mode = mode.next();
        }
        debug_colors(&sim, DebugColorMode::Pinned, None, &mut out);
        for pin in pins {
            assert_eq!(out[pin as usize], RED);
        }
        assert_eq!(out[grid.index(5, 5) as usize], GREY);
        debug_colors(&sim, DebugColorMode::Off, None, &mut out);
        assert!(out.is_empty());
    }

    #[test]
    fn area_strain_is_zero_at_rest_and_grows_with_a_stretched_triangle() {
        let grid = GridDesc::square(1.0, 4, Vec3::Y);
        let mut sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
        let mut out = Vec::new();
        debug_colors(&sim, DebugColorMode::AreaStrain, None, &mut out);
        assert!(out.iter().all(|&c| c == ramp(0.0)));
        // Lift one particle out of the sheet: the triangles touching it grow, no other.
        let corner = grid.index(2, 1) as usize;
        sim.state_mut().positions[corner].y += 0.05;
        debug_colors(&sim, DebugColorMode::AreaStrain, None, &mut out);
        let touching: Vec<bool> = sim
            .model()
            .triangles
            .iter()
            .map(|t| t.contains(&(corner as u32)))
            .collect();
        for (c, &t) in out.iter().zip(&touching) {
            assert_eq!(*c != ramp(0.0), t);
        }
    }

    #[test]
    fn custom_paint_shows_its_colours_and_values_and_reports_a_wrong_length() {
        let grid = GridDesc::square(1.0, 3, Vec3::Y);
        let sim = ClothSolver::new(ClothModel::grid(&grid, 0.1).unwrap());
        let triangles = sim.model().triangles.len();
        let mut out = Vec::new();
        let colours: Vec<[f32; 4]> = (0..triangles)
            .map(|t| [t as f32 / triangles as f32, 0.5, 0.25, 1.0])
            .collect();
        let paint = ClothPaint::triangle_colors(colours.clone());
        let (target, mismatch) = debug_colors(&sim, DebugColorMode::Custom, Some(&paint), &mut out);
        assert_eq!((target, mismatch), (PaintTarget::Triangles, None));
        assert_eq!(out, colours);
        let values = ClothPaint::values(
            PaintTarget::Particles,
            (0..9).map(|i| i as f32).collect(),
            0.0,
            8.0,
        );
        debug_colors(&sim, DebugColorMode::Custom, Some(&values), &mut out);
        assert_eq!(out.len(), 9);
        assert_eq!(out[0], ramp(0.0));
        assert_eq!(out[4], ramp(0.5));
        assert_eq!(out[8], ramp(1.0));
        let short = ClothPaint::particle_colors(vec![[1.0; 4]; 4]);
        let (_, mismatch) = debug_colors(&sim, DebugColorMode::Custom, Some(&short), &mut out);
        assert_eq!(
            mismatch,
            Some(PaintMismatch {
                target: PaintTarget::Particles,
                expected: 9,
                found: 4
            })
        );
        assert!(out.len() == 9 && out.iter().all(|&c| c == GREY));
        // NaN colours and values show red, never NaN.
        let bad = ClothPaint::values(PaintTarget::Particles, vec![f32::NAN; 9], 0.0, 1.0);
        debug_colors(&sim, DebugColorMode::Custom, Some(&bad), &mut out);
        assert!(out.iter().all(|&c| c == RED || c == ramp(1.0)));
    }
}
