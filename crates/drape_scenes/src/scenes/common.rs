//! What every standard scene shares: the frame rate, gravity, the sheet's density, and a few
//! measures of a run.

use bevy::math::Vec3;
use bevy_drape::cloth::ClothSolver;

/// Frame rate of the standard scenes, Hz.
pub const FRAME_RATE: f32 = 60.0;
/// Gravity of the standard scenes, m/s^2.
pub const GRAVITY: Vec3 = Vec3::new(0.0, -9.81, 0.0);
/// Areal density of the standard sheet, kg/m^2.
pub const DENSITY: f32 = 0.1;

/// The median of `values` (0 for none).
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let mid = v.len() / 2;
    if v.len() % 2 == 1 {
        v[mid]
    } else {
        0.5 * (v[mid - 1] + v[mid])
    }
}

/// The height of the cloth's lowest particle, m.
pub fn lowest_height(sim: &ClothSolver) -> f32 {
    sim.state()
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::MAX, f32::min)
}
