//! Self-collision's cost against its crossings: the generated sheet drops
//! ([`SheetDrop::generated`]) run with each [`SelfCollisionMethod`] at each substep count.

use bevy_drape::cloth::SelfCollisionMethod;

use crate::scenes::SheetDrop;

/// One self-collision method at one substep count, over a set of generated sheet drops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossingsPoint {
    /// The method.
    pub method: SelfCollisionMethod,
    /// Substeps per 1/60 s frame (2 iterations each).
    pub substeps: u32,
    /// The median cost of a frame over all the drops' frames, ms.
    pub ms_per_frame: f64,
    /// The crossings of the cloth through itself, summed over the drops.
    pub crossings: usize,
    /// How many drops ran.
    pub drops: usize,
    /// Whether every drop stayed finite.
    pub finite: bool,
}

/// The substep counts the study tries each method at.
pub const CROSSINGS_SUBSTEPS: [u32; 3] = [4, 8, 16];

/// Runs the drops of `seeds` (`n` x `n` sheets, [`SheetDrop::generated`]) for `frames` frames
/// with every method at every substep count of `substeps`, the scene's settings otherwise.
pub fn crossings_against_cost(
    n: u32,
    seeds: std::ops::Range<u64>,
    frames: u32,
    substeps: &[u32],
) -> Vec<CrossingsPoint> {
    let mut points = Vec::new();
    for method in SelfCollisionMethod::ALL {
        for &count in substeps {
            let mut settings = SheetDrop::settings(method);
            settings.substeps = count;
            settings.auto_substeps = false;
            let mut frame_seconds = Vec::new();
            let (mut crossings, mut finite) = (0, true);
            for seed in seeds.clone() {
                let run = SheetDrop::generated(n, seed).run(&settings, frames);
                frame_seconds.extend(run.frame_seconds);
                crossings += run.crossings;
                finite &= run.finite;
            }
            frame_seconds.sort_by(f64::total_cmp);
            let median = frame_seconds.get(frame_seconds.len() / 2).copied();
            points.push(CrossingsPoint {
                method,
                substeps: count,
                ms_per_frame: 1e3 * median.unwrap_or(f64::NAN),
                crossings,
                drops: seeds.clone().count(),
                finite,
            });
        }
    }
    points
}
