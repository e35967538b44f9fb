//! Level of detail: the budget a cloth gets by its distance from a viewer ([`LodLevel`]),
//! with a margin so that a cloth at a level's distance does not switch back and forth.

use bevy::reflect::Reflect;

use crate::error::ClothError;

/// What a cloth gets at one level of detail.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub enum LodBudget {
    /// At most this many substeps per fixed step (the cloth's own count if that is lower);
    /// the iterations, compliances and contacts stay as they are.
    Substeps(u32),
    /// Not solved: carried rigidly with the entity it follows (or kept where it is), so it
    /// rides on a character that walks on; stepped again from rest in that entity's frame
    /// when it comes nearer.
    Frozen,
    /// [`LodBudget::Frozen`], and not drawn (its `Visibility` hidden until it comes nearer).
    Hidden,
}

impl LodBudget {
    /// Whether the cloth is not solved at this budget.
    pub fn is_frozen(&self) -> bool {
        matches!(self, Self::Frozen | Self::Hidden)
    }
}

/// One level of detail: the budget of a cloth farther than `beyond` from the viewer.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct LodLevel {
    /// The distance from the viewer beyond which the level applies, metres.
    pub beyond: f32,
    /// What the cloth gets there.
    pub budget: LodBudget,
}

/// How far inside a level's distance a cloth must come back before it leaves that level, as
/// a share of the distance: a cloth walking to and fro across the line does not switch at
/// every step.
pub const LOD_MARGIN: f32 = 0.05;

/// Checks a list of levels: distances finite, not negative and increasing, substep counts
/// at least 1.
pub(crate) fn validate_levels(levels: &[LodLevel]) -> Result<(), ClothError> {
    let mut last = -1.0f32;
    for level in levels {
        if !(level.beyond.is_finite() && level.beyond >= 0.0 && level.beyond > last) {
            return Err(ClothError::InvalidSetting {
                name: "level of detail distance",
                value: level.beyond,
                reason: "finite, not negative, and larger than the nearer level's",
            });
        }
        if let LodBudget::Substeps(0) = level.budget {
            return Err(ClothError::InvalidSetting {
                name: "level of detail substeps",
                value: 0.0,
                reason: "at least 1",
            });
        }
        last = level.beyond;
    }
    Ok(())
}

/// The level (0: full budget, `k`: `levels[k - 1]`) of a cloth at `distance` from the viewer
/// that was at level `current`: farther levels are taken as soon as their distance is
/// passed, nearer ones once the cloth is [`LOD_MARGIN`] inside the distance it crossed. A
/// distance that is not a number keeps the current level.
pub(crate) fn level_at(levels: &[LodLevel], distance: f32, current: usize) -> usize {
    if distance.is_nan() {
        return current.min(levels.len());
    }
    let passed = levels.iter().filter(|l| distance > l.beyond).count();
    let current = current.min(levels.len());
    if passed >= current {
        return passed;
    }
    // Nearer: only as far in as the margin allows.
    levels
        .iter()
        .filter(|l| distance > l.beyond * (1.0 - LOD_MARGIN))
        .count()
        .min(current)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn levels() -> Vec<LodLevel> {
        vec![
            LodLevel {
                beyond: 10.0,
                budget: LodBudget::Substeps(4),
            },
            LodLevel {
                beyond: 30.0,
                budget: LodBudget::Frozen,
            },
        ]
    }

    #[test]
    fn levels_are_taken_going_out_and_left_inside_the_margin_coming_back() {
        let levels = levels();
        assert_eq!(level_at(&levels, 5.0, 0), 0);
        assert_eq!(level_at(&levels, 10.5, 0), 1);
        assert_eq!(level_at(&levels, 45.0, 0), 2);
        // Back across 30 m: level 2 until 28.5 m.
        assert_eq!(level_at(&levels, 29.0, 2), 2);
        assert_eq!(level_at(&levels, 28.0, 2), 1);
        // A jump from far to near goes all the way.
        assert_eq!(level_at(&levels, 1.0, 2), 0);
        assert_eq!(level_at(&levels, 9.8, 1), 1);
        assert_eq!(level_at(&levels, f32::NAN, 1), 1);
        assert_eq!(level_at(&[], 100.0, 3), 0);
    }

    #[test]
    fn random_walks_switch_only_across_a_margin() {
        // Along any walk, a switch to a nearer level happens only inside the margin of the
        // distance crossed, and every level is the farthest passed or one kept by the margin.
        let levels = levels();
        let mut seed = 0x2545_f491_u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        let mut distance = 20.0f32;
        let mut level = 0;
        for _ in 0..10_000 {
            distance = (distance + (next() - 0.5) * 4.0).clamp(0.0, 50.0);
            let new = level_at(&levels, distance, level);
            let passed = levels.iter().filter(|l| distance > l.beyond).count();
            assert!(new >= passed, "at {distance} m: level {new} < {passed}");
            if new > passed {
                let kept = &levels[new - 1];
                assert!(distance > kept.beyond * (1.0 - LOD_MARGIN));
            }
            level = new;
        }
    }

    #[test]
    fn bad_levels_are_refused() {
        let mut bad = levels();
        bad[1].beyond = 5.0;
        assert!(validate_levels(&bad).is_err());
        for beyond in [f32::NAN, -1.0, f32::INFINITY] {
            let mut bad = levels();
            bad[0].beyond = beyond;
            assert!(validate_levels(&bad).is_err(), "{beyond}");
        }
        let mut bad = levels();
        bad[0].budget = LodBudget::Substeps(0);
        assert!(validate_levels(&bad).is_err());
        assert!(validate_levels(&levels()).is_ok());
        assert!(validate_levels(&[]).is_ok());
    }
}
