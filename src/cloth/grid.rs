//! A dense grid of cubic cells over the bounding box of a cloth's particles, for the
//! neighbour searches of self-collision (`self_collision.rs`, `triangle_collision.rs`).

use bevy::math::{UVec3, Vec3A};

/// A dense grid of cubic cells over the bounding box of the finite particles, cells numbered
/// x fastest.
pub(crate) struct Grid {
    pub(crate) origin: Vec3A,
    pub(crate) inv_cell: f32,
    pub(crate) dims: [u32; 3],
}

impl Grid {
    /// Cells at least `min_cell` wide and at most `max_cells` of them (at least one); `None`
    /// when no particle is finite.
    pub(crate) fn new(x: &[Vec3A], min_cell: f32, max_cells: usize) -> Option<Self> {
        let (low, high) = x
            .iter()
            .filter(|p| p.is_finite())
            .fold((Vec3A::MAX, Vec3A::MIN), |(low, high), p| {
                (low.min(*p), high.max(*p))
            });
        if low.x > high.x {
            return None;
        }
        let extent = high - low;
        let mut cell = min_cell
            .max(extent.max_element() * 1.0e-6)
            .max(f32::MIN_POSITIVE);
        loop {
            let dims = (extent / cell).floor().as_uvec3() + 1;
            let cells = dims.x as u64 * dims.y as u64 * dims.z as u64;
            if cells <= max_cells.max(1) as u64 {
                return Some(Self {
                    origin: low,
                    inv_cell: 1.0 / cell,
                    dims: dims.to_array(),
                });
            }
            cell *= 1.25;
        }
    }

    pub(crate) fn cells(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    pub(crate) fn index(&self, [x, y, z]: [u32; 3]) -> u32 {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    pub(crate) fn coords(&self, cell: u32) -> [u32; 3] {
        let [nx, ny, _] = self.dims;
        [cell % nx, (cell / nx) % ny, cell / (nx * ny)]
    }

    /// The cell of `p`; `None` when `p` is not finite.
    pub(crate) fn cell(&self, p: Vec3A) -> Option<u32> {
        if !p.is_finite() {
            return None;
        }
        let c = ((p - self.origin) * self.inv_cell).floor().as_uvec3();
        let c = c.min(UVec3::from_array(self.dims) - 1);
        Some(self.index(c.to_array()))
    }
}

/// Sets `travel[i]`, how far particle `i` of velocity `v[i]` travels relative to the cloth's
/// common motion (the centre of the velocities' bounding box) within `dt` under an
/// acceleration of magnitude `acceleration`, at most `cap` (zero for non-finite input), and
/// returns the largest.
pub(crate) fn relative_travel(
    travel: &mut [f32],
    v: &[Vec3A],
    dt: f32,
    acceleration: f32,
    cap: f32,
) -> f32 {
    let (low, high) = v
        .iter()
        .filter(|v| v.is_finite())
        .fold((Vec3A::MAX, Vec3A::MIN), |(low, high), v| {
            (low.min(*v), high.max(*v))
        });
    let centre = 0.5 * (low + high);
    let fall = 0.5 * acceleration * dt * dt;
    let mut largest = 0.0f32;
    for (travel, v) in travel.iter_mut().zip(v) {
        let t = (*v - centre).length() * dt + fall;
        *travel = if t.is_finite() {
            t.clamp(0.0, cap)
        } else {
            0.0
        };
        largest = largest.max(*travel);
    }
    largest
}

/// Counting sort of the finite particles of `x` by their cell of `grid`: `cell_of[i]` is
/// particle `i`'s cell (`u32::MAX` if not finite), the particles of cell `c` are
/// `cell_entries[cell_start[c]..cell_start[c + 1]]` in their order, and `slot_of[i]`, if
/// asked for, is where particle `i` is in `cell_entries`.
pub(crate) fn sort_into_cells(
    grid: &Grid,
    x: &[Vec3A],
    (cell_of, cell_start, cell_entries): (&mut [u32], &mut Vec<u32>, &mut [u32]),
    mut slot_of: Option<&mut [u32]>,
) {
    cell_start.clear();
    cell_start.resize(grid.cells() + 2, 0);
    for (p, cell) in x.iter().zip(cell_of.iter_mut()) {
        *cell = grid.cell(*p).unwrap_or(u32::MAX);
        if *cell != u32::MAX {
            cell_start[*cell as usize] += 1;
        }
    }
    let mut running = 0;
    for count in cell_start.iter_mut() {
        running += *count;
        *count = running;
    }
    for i in (0..x.len()).rev() {
        let c = cell_of[i];
        if c != u32::MAX {
            cell_start[c as usize] -= 1;
            let slot = cell_start[c as usize];
            cell_entries[slot as usize] = i as u32;
            if let Some(slot_of) = slot_of.as_deref_mut() {
                slot_of[i] = slot;
            }
        }
    }
}
