//! A small deterministic random generator for the crate's own tests, its integration tests
//! and its measuring harness (`drape_scenes`): inputs nobody designed (random meshes, clouds,
//! motions), the same on every machine and every run for a given seed.
//!
//! Not for games: it is a 64-bit linear congruential generator (Knuth's MMIX constants) whose
//! output is the high half of its state, fast and good enough for test inputs, neither
//! cryptographic nor of high statistical quality. Built with the crate's tests and with the
//! `internals` feature only.
//!
//! ```
//! use bevy_drape::rng::Rng;
//!
//! let mut rng = Rng(7);
//! let x = rng.range(-1.0, 1.0);
//! assert!((-1.0..1.0).contains(&x));
//! assert!(rng.below(10) < 10);
//! assert!((rng.unit_vector().length() - 1.0).abs() < 1e-5);
//! // The same seed, the same sequence.
//! assert_eq!(Rng(7).range(-1.0, 1.0), x);
//! ```

use bevy::math::Vec3;

/// The generator: its state is the tuple's field, any `u64` (zero included) a valid seed.
/// Not `Copy`, so that a draw never advances a copy by mistake.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rng(pub u64);

impl Rng {
    /// The next 32 bits: the high half of the state after one step.
    pub fn next_u32(&mut self) -> u32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 32) as u32
    }

    /// Uniform in [0, 1): the top 24 bits of [`next_u32`](Self::next_u32), every value a
    /// multiple of 2^-24 (exact in an `f32`).
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 / (1u32 << 24) as f32
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.uniform()
    }

    /// An integer uniform in [0, n) (`n` at least 1, at most 2^32), without the bias of a
    /// remainder of the low bits.
    pub fn below(&mut self, n: usize) -> usize {
        assert!(n > 0, "Rng::below(0)");
        ((self.next_u32() as u64 * n as u64) >> 32) as usize
    }

    /// An integer uniform in [lo, hi) (`hi` above `lo`).
    pub fn range_int(&mut self, lo: u32, hi: u32) -> u32 {
        assert!(hi > lo, "Rng::range_int({lo}, {hi})");
        lo + self.below((hi - lo) as usize) as u32
    }

    /// Each coordinate uniform in [lo, hi), drawn in the order x, y, z.
    pub fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        let x = self.range(lo, hi);
        let y = self.range(lo, hi);
        let z = self.range(lo, hi);
        Vec3::new(x, y, z)
    }

    /// A unit vector uniform over the sphere (points of the cube drawn until one lies in the
    /// ball and not too near its centre, then normalised).
    pub fn unit_vector(&mut self) -> Vec3 {
        loop {
            let v = self.vec3(-1.0, 1.0);
            let length_squared = v.length_squared();
            if (1e-4..=1.0).contains(&length_squared) {
                return v / length_squared.sqrt();
            }
        }
    }

    /// Shuffles `items` in place, every order equally likely (Fisher-Yates).
    pub fn shuffle<T>(&mut self, items: &mut [T]) {
        for i in (1..items.len()).rev() {
            items.swap(i, self.below(i + 1));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_draws_stay_in_their_ranges_and_cover_them() {
        let mut rng = Rng(0);
        let mut buckets = [0u32; 10];
        let mut seen = [false; 7];
        for _ in 0..10_000 {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            buckets[(u * 10.0) as usize] += 1;
            let x = rng.range(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&x));
            seen[rng.below(7)] = true;
            assert!((3..9).contains(&rng.range_int(3, 9)));
            let v = rng.vec3(-0.5, 0.5);
            assert!(v.abs().max_element() <= 0.5);
            assert!((rng.unit_vector().length() - 1.0).abs() < 1e-5);
        }
        assert!(seen.iter().all(|&s| s));
        // Ten buckets of about 1000 draws each.
        assert!(
            buckets.iter().all(|&b| (850..1150).contains(&b)),
            "{buckets:?}"
        );
    }

    #[test]
    fn a_shuffle_is_a_permutation_and_a_seed_repeats_its_sequence() {
        let mut items: Vec<u32> = (0..100).collect();
        Rng(5).shuffle(&mut items);
        assert_ne!(items, (0..100).collect::<Vec<u32>>());
        let mut sorted = items.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..100).collect::<Vec<u32>>());
        let (mut a, mut b) = (Rng(42), Rng(42));
        assert!((0..100).all(|_| a.next_u32() == b.next_u32()));
    }
}
