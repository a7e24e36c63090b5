//! Gradient noise, the one noise of the engine (Perlin2002): a lattice of pseudo-random
//! unit gradients, each corner's gradient dotted with the offset to the point, blended
//! with the quintic fade `6t⁵ − 15t⁴ + 10t³` so the field has continuous second
//! derivatives. Two lattices feed the same blend ([`gradient2`]):
//!
//! - [`Perlin`] (f64, 2D and 3D): Perlin's permutation table, shuffled from a seed, for
//!   the unbounded fields of the magnetic curves (Xu2015 §7.2.4, Fig. 7.5).
//! - [`TileNoise`] (f32, 2D): a hash of the wrapped lattice point, periodic with integer
//!   periods, so textures over \[0, 1)² meet themselves at the edges; with its fractal sum
//!   and cellular (Worley) noise for the bark and leaf maps.
//!
//! Both are deterministic on every platform: the same seed gives the same values.

mod perlin;
mod tile;

pub use perlin::Perlin;
pub use tile::TileNoise;

use std::ops::{Add, Mul, Sub};

/// The float types the noise is computed in (f32 for textures, f64 for curves).
pub(crate) trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + From<f32>
{
}

impl Real for f32 {}
impl Real for f64 {}

/// Perlin's quintic fade `6t⁵ − 15t⁴ + 10t³` (zero first and second derivatives at 0
/// and 1).
#[inline]
pub(crate) fn fade<T: Real>(t: T) -> T {
    t * t * t * (t * (t * T::from(6.0) - T::from(15.0)) + T::from(10.0))
}

/// `a + t·(b − a)`.
#[inline]
pub(crate) fn lerp<T: Real>(t: T, a: T, b: T) -> T {
    a + t * (b - a)
}

/// 2D gradient noise in a unit cell, unscaled: `(tx, ty)` is the point's offset in the
/// cell (in \[0, 1)²) and `gradient(i, j)` the gradient at corner `(i, j)` ∈ {0, 1}²
/// of the cell. Zero at the corners; at most √½ in magnitude for unit gradients.
#[inline]
pub(crate) fn gradient2<T: Real>(tx: T, ty: T, gradient: impl Fn(u8, u8) -> (T, T)) -> T {
    let one = T::from(1.0);
    let dot = |i: u8, j: u8, dx: T, dy: T| {
        let (gx, gy) = gradient(i, j);
        gx * dx + gy * dy
    };
    let n00 = dot(0, 0, tx, ty);
    let n10 = dot(1, 0, tx - one, ty);
    let n01 = dot(0, 1, tx, ty - one);
    let n11 = dot(1, 1, tx - one, ty - one);
    let (u, v) = (fade(tx), fade(ty));
    lerp(v, lerp(u, n00, n10), lerp(u, n01, n11))
}
