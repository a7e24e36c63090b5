//! [`TileNoise`]: periodic noise for textures that tile — 2D gradient noise, its fractal
//! sum and cellular (Worley) noise, each periodic in both axes with integer periods, so
//! a texture sampled over \[0, 1)² with `x = s · period` meets itself at the edges
//! exactly. Hash-based (no tables).

use super::gradient2;

/// Noise of one seed.
#[derive(Debug, Clone, Copy)]
pub struct TileNoise {
    seed: u32,
}

/// A 32-bit integer hash of a lattice point and a seed (a PCG-style output mix).
#[inline]
fn hash(x: i32, y: i32, seed: u32) -> u32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841) ^ seed;
    h = (h ^ (h >> 16)).wrapping_mul(0x7feb_352d);
    h = (h ^ (h >> 15)).wrapping_mul(0x846c_a68b);
    h ^ (h >> 16)
}

/// `v` wrapped into `0..period` (period ≥ 1); the common case (already inside, or one
/// period off) without a division.
#[inline]
fn wrap(v: i32, period: i32) -> i32 {
    if (0..period).contains(&v) {
        v
    } else if (period..2 * period).contains(&v) {
        v - period
    } else if (-period..0).contains(&v) {
        v + period
    } else {
        v.rem_euclid(period)
    }
}

/// The eight unit-ish gradient directions of 2D Perlin noise.
const GRADIENTS: [(f32, f32); 8] = [
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 1.0),
    (0.0, -1.0),
    (std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2),
    (-std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2),
    (std::f32::consts::FRAC_1_SQRT_2, -std::f32::consts::FRAC_1_SQRT_2),
    (-std::f32::consts::FRAC_1_SQRT_2, -std::f32::consts::FRAC_1_SQRT_2),
];

impl TileNoise {
    /// Noise for `seed` (any 64-bit seed; the two halves are mixed).
    pub fn new(seed: u64) -> Self {
        TileNoise { seed: (seed as u32) ^ ((seed >> 32) as u32).rotate_left(13) ^ 0x5bd1_e995 }
    }

    /// The same noise with a different stream (for independent layers of one texture).
    pub fn layer(&self, k: u32) -> Self {
        TileNoise { seed: hash(k as i32, 0x0123_4567, self.seed) }
    }

    /// A hash of integer cell (x, y), periodic with (`px`, `py`) (per-cell random choices).
    pub fn cell_hash(&self, x: i32, y: i32, px: i32, py: i32) -> u32 {
        hash(wrap(x, px), wrap(y, py), self.seed ^ 0x2545_f491)
    }

    /// Gradient noise at (x, y), periodic with integer periods (`px`, `py`) ≥ 1;
    /// values in about \[−1, 1\].
    pub fn perlin(&self, x: f32, y: f32, px: i32, py: i32) -> f32 {
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = (x - fx, y - fy);
        let (ix, iy) = (fx as i32, fy as i32);
        let (x0, y0) = (wrap(ix, px), wrap(iy, py));
        let x1 = if x0 + 1 == px { 0 } else { x0 + 1 };
        let y1 = if y0 + 1 == py { 0 } else { y0 + 1 };
        let n = gradient2(tx, ty, |i, j| {
            let (gx, gy) = (if i == 0 { x0 } else { x1 }, if j == 0 { y0 } else { y1 });
            GRADIENTS[(hash(gx, gy, self.seed) & 7) as usize]
        });
        n * std::f32::consts::SQRT_2
    }

    /// Fractal sum of `octaves` gradient-noise octaves, each of twice the frequency (and
    /// period) and `gain` times the amplitude of the one before, normalized to about
    /// \[−1, 1\]. Periodic with (`px`, `py`) like [`TileNoise::perlin`].
    pub fn fbm(&self, x: f32, y: f32, px: i32, py: i32, octaves: u32, gain: f32) -> f32 {
        let (mut sum, mut amp, mut norm, mut f) = (0.0, 1.0, 0.0, 1);
        for o in 0..octaves {
            let n = self.layer(o).perlin(x * f as f32, y * f as f32, px * f, py * f);
            sum += amp * n;
            norm += amp;
            amp *= gain;
            f *= 2;
        }
        sum / norm.max(1e-6)
    }

    /// Cellular noise at (x, y), periodic with (`px`, `py`): one feature point per unit
    /// cell; returns the distances to the nearest and second-nearest points and a hash
    /// of the nearest point's cell (for per-cell colour).
    pub fn worley(&self, x: f32, y: f32, px: i32, py: i32) -> (f32, f32, u32) {
        let (ix, iy) = (x.floor() as i32, y.floor() as i32);
        let (mut f1, mut f2, mut id) = (f32::MAX, f32::MAX, 0);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (cx, cy) = (ix + dx, iy + dy);
                let h = hash(wrap(cx, px), wrap(cy, py), self.seed ^ 0x9e37_79b9);
                let ox = (h & 0xffff) as f32 / 65535.0;
                let oy = (h >> 16) as f32 / 65535.0;
                let (qx, qy) = (cx as f32 + ox - x, cy as f32 + oy - y);
                let d = (qx * qx + qy * qy).sqrt();
                if d < f1 {
                    f2 = f1;
                    f1 = d;
                    id = h;
                } else if d < f2 {
                    f2 = d;
                }
            }
        }
        (f1, f2, id)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_periodic_and_bounded() {
        let n = TileNoise::new(42);
        for i in 0..50 {
            let (x, y) = (i as f32 * 0.37, i as f32 * 0.61);
            let a = n.perlin(x, y, 5, 3);
            assert!((a - n.perlin(x + 5.0, y, 5, 3)).abs() < 1e-4, "x period");
            assert!((a - n.perlin(x, y + 3.0, 5, 3)).abs() < 1e-4, "y period");
            assert!(a.abs() <= 1.01, "{a}");
            let f = n.fbm(x, y, 4, 2, 4, 0.5);
            assert!((f - n.fbm(x + 4.0, y + 2.0, 4, 2, 4, 0.5)).abs() < 1e-4);
            let (f1, f2, id) = n.worley(x, y, 6, 4);
            let (g1, g2, jd) = n.worley(x + 6.0, y - 4.0, 6, 4);
            assert!((f1 - g1).abs() < 1e-4 && (f2 - g2).abs() < 1e-4 && id == jd);
            assert!(f1 <= f2);
        }
    }

    #[test]
    fn seeds_differ_and_repeat() {
        let (a, b) = (TileNoise::new(1), TileNoise::new(2));
        let va: Vec<f32> = (0..20).map(|i| a.perlin(i as f32 * 0.3 + 0.1, 0.7, 8, 8)).collect();
        let vb: Vec<f32> = (0..20).map(|i| b.perlin(i as f32 * 0.3 + 0.1, 0.7, 8, 8)).collect();
        assert_ne!(va, vb);
        let again: Vec<f32> =
            (0..20).map(|i| TileNoise::new(1).perlin(i as f32 * 0.3 + 0.1, 0.7, 8, 8)).collect();
        assert_eq!(va, again);
    }
}
