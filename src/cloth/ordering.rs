//! Constraint order for speed: greedy graph colouring.
//!
//! Gauss-Seidel projects constraints one after another. When two consecutive constraints
//! share a particle, the second waits for the first's result, and the processor runs the
//! sweep at the latency of one projection (a square root and a division) per constraint.
//! Ordering the constraints by colour, where no two constraints of one colour share a
//! particle, lets consecutive projections overlap. The order is still a fixed, deterministic
//! Gauss-Seidel order (a "multi-colour" sweep), and each colour is a batch that could run in
//! parallel.

/// A permutation of `items` (each the particles one constraint touches) that groups them by
/// greedy colour, keeping the original order within a colour.
pub(crate) fn colour_order<const K: usize>(items: &[[u32; K]], particle_count: usize) -> Vec<u32> {
    let mut used = vec![0u64; particle_count];
    let mut colours = Vec::with_capacity(items.len());
    for item in items {
        let taken = item.iter().fold(0u64, |m, &p| m | used[p as usize]);
        let colour = (!taken).trailing_zeros().min(63);
        for &p in item {
            used[p as usize] |= 1 << colour;
        }
        colours.push(colour);
    }
    let mut order: Vec<u32> = (0..items.len() as u32).collect();
    order.sort_by_key(|&i| colours[i as usize]);
    order
}

/// Reorders `values` by `order` (from [`colour_order`]).
pub(crate) fn apply_order<T: Copy>(values: &mut Vec<T>, order: &[u32]) {
    let reordered: Vec<T> = order.iter().map(|&i| values[i as usize]).collect();
    *values = reordered;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_two_neighbours_in_the_order_of_one_colour_share_a_particle() {
        // A chain 0-1-2-3-4: two colours, alternating edges.
        let edges = [[0, 1], [1, 2], [2, 3], [3, 4]];
        let order = colour_order(&edges, 5);
        assert_eq!(order, vec![0, 2, 1, 3]);
    }
}
