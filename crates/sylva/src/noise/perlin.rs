//! [`Perlin`]: Ken Perlin's "improved noise" (Perlin2002) over a permutation table of
//! 256 entries shuffled by a seeded PCG generator, in 2D (the eight gradients every 45°)
//! and 3D (the twelve cube-edge gradients). Values are scaled so the theoretical
//! extremes are ±1 and clamped to `[-1, 1]`, so `0.5·(1 + noise)` lies in `[0, 1]`
//! (Xu2015 Fig. 7.5: `B_z = 0.5·(1 + noise(x/50, y/50))`). One table look-up per
//! lattice corner and no allocation.

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::{fade, gradient2, lerp};

/// A seeded Perlin noise generator (2D and 3D share one permutation table).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Perlin {
    /// The permutation of 0..256, repeated twice so corner hashes never wrap.
    perm: Box<[u8; 512]>,
}

/// 1/√(1/2): the largest magnitude of 2D Perlin noise with unit gradients is √(1/2).
const SCALE_2D: f64 = std::f64::consts::SQRT_2;

/// The eight unit gradient directions of the 2D noise (every 45°).
const GRAD2: [(f64, f64); 8] = [
    (1.0, 0.0),
    (std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2),
    (0.0, 1.0),
    (-std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2),
    (-1.0, 0.0),
    (-std::f64::consts::FRAC_1_SQRT_2, -std::f64::consts::FRAC_1_SQRT_2),
    (0.0, -1.0),
    (std::f64::consts::FRAC_1_SQRT_2, -std::f64::consts::FRAC_1_SQRT_2),
];

impl Perlin {
    /// A noise generator whose permutation comes from `seed` (Fisher–Yates shuffle
    /// driven by `Pcg64`). The same seed always gives the same noise.
    pub fn new(seed: u64) -> Self {
        let mut rng = Pcg64::seed_from_u64(seed ^ 0x5EED_F9E7u64);
        let mut p = [0u8; 256];
        for (i, v) in p.iter_mut().enumerate() {
            *v = i as u8;
        }
        for i in (1..256usize).rev() {
            let j = (rng.random::<u64>() % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        let mut perm = Box::new([0u8; 512]);
        for i in 0..512 {
            perm[i] = p[i & 255];
        }
        Perlin { perm }
    }

    #[inline]
    fn hash(&self, i: usize) -> usize {
        self.perm[i & 511] as usize
    }

    /// 2D noise at `p`, in `[-1, 1]`; 0 at integer lattice points. Non-finite input
    /// gives 0.
    pub fn noise2(&self, p: DVec2) -> f64 {
        if !p.is_finite() {
            return 0.0;
        }
        let (fx, fy) = (p.x.floor(), p.y.floor());
        // Wrap the lattice cell into the 256-periodic table; rem_euclid keeps negative
        // coordinates continuous.
        let xi = (fx.rem_euclid(256.0)) as usize;
        let yi = (fy.rem_euclid(256.0)) as usize;
        let (x, y) = (p.x - fx, p.y - fy);
        let n = gradient2(x, y, |i, j| GRAD2[self.hash(self.hash(xi + i as usize) + yi + j as usize) & 7]);
        (n * SCALE_2D).clamp(-1.0, 1.0)
    }

    /// 3D noise at `p`, in `[-1, 1]` (Perlin's twelve cube-edge gradients); 0 at integer
    /// lattice points. Non-finite input gives 0.
    pub fn noise3(&self, p: DVec3) -> f64 {
        if !p.is_finite() {
            return 0.0;
        }
        let f = p.floor();
        let xi = f.x.rem_euclid(256.0) as usize;
        let yi = f.y.rem_euclid(256.0) as usize;
        let zi = f.z.rem_euclid(256.0) as usize;
        let d = p - f;
        let (u, v, w) = (fade(d.x), fade(d.y), fade(d.z));
        let a = self.hash(xi) + yi;
        let aa = self.hash(a) + zi;
        let ab = self.hash(a + 1) + zi;
        let b = self.hash(xi + 1) + yi;
        let ba = self.hash(b) + zi;
        let bb = self.hash(b + 1) + zi;
        let (x, y, z) = (d.x, d.y, d.z);
        let r = lerp(
            w,
            lerp(
                v,
                lerp(u, grad3(self.hash(aa), x, y, z), grad3(self.hash(ba), x - 1.0, y, z)),
                lerp(u, grad3(self.hash(ab), x, y - 1.0, z), grad3(self.hash(bb), x - 1.0, y - 1.0, z)),
            ),
            lerp(
                v,
                lerp(
                    u,
                    grad3(self.hash(aa + 1), x, y, z - 1.0),
                    grad3(self.hash(ba + 1), x - 1.0, y, z - 1.0),
                ),
                lerp(
                    u,
                    grad3(self.hash(ab + 1), x, y - 1.0, z - 1.0),
                    grad3(self.hash(bb + 1), x - 1.0, y - 1.0, z - 1.0),
                ),
            ),
        );
        r.clamp(-1.0, 1.0)
    }
}

/// Perlin 2002's gradient selection: the 12 edge midpoints of the cube (4 repeated).
#[inline]
fn grad3(hash: usize, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_bounded_and_zero_on_lattice() {
        let a = Perlin::new(7);
        let b = Perlin::new(7);
        let c = Perlin::new(8);
        let mut differs = false;
        for i in 0..2000 {
            let p = DVec2::new(i as f64 * 0.173 - 50.0, (i * 7 % 101) as f64 * 0.311 - 9.0);
            let v = a.noise2(p);
            assert!((-1.0..=1.0).contains(&v));
            assert_eq!(v, b.noise2(p));
            differs |= v != c.noise2(p);
            let q = DVec3::new(p.x, p.y, i as f64 * 0.05);
            assert!((-1.0..=1.0).contains(&a.noise3(q)));
        }
        assert!(differs);
        assert_eq!(a.noise2(DVec2::new(3.0, -4.0)), 0.0);
        assert_eq!(a.noise3(DVec3::new(3.0, -4.0, 9.0)), 0.0);
        assert_eq!(a.noise2(DVec2::new(f64::NAN, 0.0)), 0.0);
    }

    #[test]
    fn continuous() {
        let n = Perlin::new(3);
        for i in 0..500 {
            let p = DVec2::new(i as f64 * 0.0371, i as f64 * 0.0193 + 0.5);
            let d = (n.noise2(p) - n.noise2(p + DVec2::splat(1e-7))).abs();
            assert!(d < 1e-5, "{d}");
        }
    }
}
