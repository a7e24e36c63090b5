//! The precisions the deformer runs in: [`Real`] (`f32` as the GPU, `f64` for checks by
//! finite differences) and [`Vector`] (`Vec3`, `DVec3`).

use glam::{DVec3, Vec3};
use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

// ---------------------------------------------------------------------------------------
// Precision.

/// A scalar the deformer runs in: `f32` (what the GPU runs) or `f64` (for checks by
/// finite differences).
pub trait Real:
    Copy
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// `x` in this precision (exact).
    fn of(x: f32) -> Self;
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// `selfᵉ`.
    fn powf(self, e: Self) -> Self;
    /// `eˢᵉˡᶠ`.
    fn exp(self) -> Self;
    /// Rounded to `f32`.
    fn to_f32(self) -> f32;
}

/// [`Real`] for the float type `$t` by its own methods; `$x => $of` makes one from an
/// `f32`, `$s => $to` rounds one to `f32`.
macro_rules! real {
    ($t:ident, $x:ident => $of:expr, $s:ident => $to:expr) => {
        impl Real for $t {
            fn of($x: f32) -> $t {
                $of
            }
            fn sin(self) -> $t {
                $t::sin(self)
            }
            fn cos(self) -> $t {
                $t::cos(self)
            }
            fn powf(self, e: $t) -> $t {
                $t::powf(self, e)
            }
            fn exp(self) -> $t {
                $t::exp(self)
            }
            fn to_f32(self) -> f32 {
                let $s = self;
                $to
            }
        }
    };
}

real!(f32, x => x, s => s);
real!(f64, x => x as f64, s => s as f32);

/// A 3-vector the deformer runs in: `Vec3` (scalar `f32`) or `DVec3` (scalar `f64`). The
/// methods are glam's (WGSL's `dot`, `cross`, `mix`, `normalize`).
pub trait Vector:
    Copy + Debug + PartialEq + Add<Output = Self> + Sub<Output = Self> + Mul<<Self as Vector>::S, Output = Self>
{
    /// The scalar.
    type S: Real;
    /// (0, 0, 0).
    const ZERO: Self;
    /// +X.
    const X: Self;
    /// +Y.
    const Y: Self;
    /// +Z.
    const Z: Self;
    /// `v` in this precision (exact).
    fn of(v: Vec3) -> Self;
    /// Rounded to `Vec3`.
    fn to_vec3(self) -> Vec3;
    /// The components.
    fn components(self) -> [Self::S; 3];
    /// Dot product.
    fn dot(self, o: Self) -> Self::S;
    /// Cross product.
    fn cross(self, o: Self) -> Self;
    /// `self + (o − self) t`.
    fn lerp(self, o: Self, t: Self::S) -> Self;
    /// Squared length.
    fn length_squared(self) -> Self::S;
    /// Unit vector of the same direction.
    fn normalize(self) -> Self;
    /// Component-wise absolute value.
    fn abs(self) -> Self;
}

/// [`Vector`] for glam's `$t` of scalar `$r` by glam's own methods; `$v => $of` makes
/// one from a `Vec3`, `$s => $to` rounds one to `Vec3`.
macro_rules! vector {
    ($t:ident, $r:ident, $v:ident => $of:expr, $s:ident => $to:expr) => {
        impl Vector for $t {
            type S = $r;
            const ZERO: $t = $t::ZERO;
            const X: $t = $t::X;
            const Y: $t = $t::Y;
            const Z: $t = $t::Z;
            fn of($v: Vec3) -> $t {
                $of
            }
            fn to_vec3(self) -> Vec3 {
                let $s = self;
                $to
            }
            fn components(self) -> [$r; 3] {
                self.to_array()
            }
            fn dot(self, o: $t) -> $r {
                $t::dot(self, o)
            }
            fn cross(self, o: $t) -> $t {
                $t::cross(self, o)
            }
            fn lerp(self, o: $t, t: $r) -> $t {
                $t::lerp(self, o, t)
            }
            fn length_squared(self) -> $r {
                $t::length_squared(self)
            }
            fn normalize(self) -> $t {
                $t::normalize(self)
            }
            fn abs(self) -> $t {
                $t::abs(self)
            }
        }
    };
}

vector!(Vec3, f32, v => v, s => s);
vector!(DVec3, f64, v => v.as_dvec3(), s => s.as_vec3());
