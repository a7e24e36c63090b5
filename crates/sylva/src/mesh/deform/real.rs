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

impl Real for f32 {
    fn of(x: f32) -> f32 {
        x
    }
    fn sin(self) -> f32 {
        f32::sin(self)
    }
    fn cos(self) -> f32 {
        f32::cos(self)
    }
    fn powf(self, e: f32) -> f32 {
        f32::powf(self, e)
    }
    fn exp(self) -> f32 {
        f32::exp(self)
    }
    fn to_f32(self) -> f32 {
        self
    }
}

impl Real for f64 {
    fn of(x: f32) -> f64 {
        x as f64
    }
    fn sin(self) -> f64 {
        f64::sin(self)
    }
    fn cos(self) -> f64 {
        f64::cos(self)
    }
    fn powf(self, e: f64) -> f64 {
        f64::powf(self, e)
    }
    fn exp(self) -> f64 {
        f64::exp(self)
    }
    fn to_f32(self) -> f32 {
        self as f32
    }
}

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

impl Vector for Vec3 {
    type S = f32;
    const ZERO: Vec3 = Vec3::ZERO;
    const X: Vec3 = Vec3::X;
    const Y: Vec3 = Vec3::Y;
    const Z: Vec3 = Vec3::Z;
    fn of(v: Vec3) -> Vec3 {
        v
    }
    fn to_vec3(self) -> Vec3 {
        self
    }
    fn components(self) -> [f32; 3] {
        self.to_array()
    }
    fn dot(self, o: Vec3) -> f32 {
        Vec3::dot(self, o)
    }
    fn cross(self, o: Vec3) -> Vec3 {
        Vec3::cross(self, o)
    }
    fn lerp(self, o: Vec3, t: f32) -> Vec3 {
        Vec3::lerp(self, o, t)
    }
    fn length_squared(self) -> f32 {
        Vec3::length_squared(self)
    }
    fn normalize(self) -> Vec3 {
        Vec3::normalize(self)
    }
    fn abs(self) -> Vec3 {
        Vec3::abs(self)
    }
}

impl Vector for DVec3 {
    type S = f64;
    const ZERO: DVec3 = DVec3::ZERO;
    const X: DVec3 = DVec3::X;
    const Y: DVec3 = DVec3::Y;
    const Z: DVec3 = DVec3::Z;
    fn of(v: Vec3) -> DVec3 {
        v.as_dvec3()
    }
    fn to_vec3(self) -> Vec3 {
        self.as_vec3()
    }
    fn components(self) -> [f64; 3] {
        self.to_array()
    }
    fn dot(self, o: DVec3) -> f64 {
        DVec3::dot(self, o)
    }
    fn cross(self, o: DVec3) -> DVec3 {
        DVec3::cross(self, o)
    }
    fn lerp(self, o: DVec3, t: f64) -> DVec3 {
        DVec3::lerp(self, o, t)
    }
    fn length_squared(self) -> f64 {
        DVec3::length_squared(self)
    }
    fn normalize(self) -> DVec3 {
        DVec3::normalize(self)
    }
    fn abs(self) -> DVec3 {
        DVec3::abs(self)
    }
}
