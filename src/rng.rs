//! Counter-based random numbers: a value is a hash of its coordinates (seed, view, scale, pass,
//! iteration, pixel, ...), so results never depend on thread scheduling or processing order.
//! `shaders/shared/rng.wgsl` implements the same functions bit for bit (u32 arithmetic only).

/// PCG-style 32-bit integer hash (permuted congruential step + output mix).
pub fn pcg_hash(input: u32) -> u32 {
    let state = input.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28).wrapping_add(4))) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// Hashes a list of coordinates into one 32-bit key.
pub fn hash_coords(coords: &[u32]) -> u32 {
    coords
        .iter()
        .fold(0x9e37_79b9u32, |h, &c| pcg_hash(h ^ pcg_hash(c)))
}

/// A uniform number in [0, 1) from a key (24 bits of precision, exact in f32).
pub fn uniform01(key: u32) -> f32 {
    (pcg_hash(key) >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A stream of uniform numbers for one set of coordinates.
#[derive(Clone, Debug)]
pub struct Stream {
    key: u32,
    counter: u32,
}

impl Stream {
    pub fn new(coords: &[u32]) -> Stream {
        Stream {
            key: hash_coords(coords),
            counter: 0,
        }
    }

    /// Next number in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        let v = uniform01(self.key ^ pcg_hash(self.counter));
        self.counter = self.counter.wrapping_add(1);
        v
    }

    /// A standard normal sample (Box-Muller).
    pub fn next_gaussian(&mut self) -> f32 {
        let u1 = self.next_f32().max(1e-7);
        let u2 = self.next_f32();
        (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_coordinates_same_numbers() {
        let mut a = Stream::new(&[7, 1, 2, 3]);
        let mut b = Stream::new(&[7, 1, 2, 3]);
        let mut c = Stream::new(&[7, 1, 2, 4]);
        let va: Vec<f32> = (0..8).map(|_| a.next_f32()).collect();
        let vb: Vec<f32> = (0..8).map(|_| b.next_f32()).collect();
        let vc: Vec<f32> = (0..8).map(|_| c.next_f32()).collect();
        assert_eq!(va, vb);
        assert_ne!(va, vc);
    }

    #[test]
    fn uniform_is_roughly_uniform() {
        let mut s = Stream::new(&[1]);
        let mut bins = [0u32; 10];
        for _ in 0..100_000 {
            let v = s.next_f32();
            assert!((0.0..1.0).contains(&v));
            bins[(v * 10.0) as usize] += 1;
        }
        // Each bin expects 10000; binomial sd is ~95, so 500 is > 5 sd.
        for b in bins {
            assert!((9_500..10_500).contains(&b), "{bins:?}");
        }
    }

    #[test]
    fn gaussian_has_unit_variance() {
        let mut s = Stream::new(&[2]);
        let n = 50_000;
        let xs: Vec<f32> = (0..n).map(|_| s.next_gaussian()).collect();
        let mean = xs.iter().sum::<f32>() / n as f32;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / n as f32;
        assert!(mean.abs() < 0.02, "{mean}");
        assert!((var - 1.0).abs() < 0.03, "{var}");
    }
}
