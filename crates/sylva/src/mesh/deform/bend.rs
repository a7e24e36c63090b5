//! Sloan's moving frame at P₀, P₁, P₂ (Skjermo2008 D Eq. 8, property 15) and the
//! deformer: the generalized de Casteljau map and its normals (D §3.3–§3.5, Eqs. 7,
//! 9–16; properties 13, 14, 17, 18).
//!
//! 2. **handles** ([`sloan_frames`]): Sloan's moving frame {Lᵢ, Sᵢ, Tᵢ} at P₀, P₁, P₂ (D
//!    Eq. 8) with S₀, T₁, T₂ normalized and the world axis least aligned with L₀ standing
//!    in for O where L₀ ∥ O;
//! 3. **bending** ([`BranchDeformer::q`]): the generalized de Casteljau map
//!    `Q(u, a, b) = Σ B³ᵢ(u) Pᵢ + a Σ B²ᵢ(u) Sᵢ + b Σ B²ᵢ(u) Tᵢ` (D Eqs. 7, 9) at
//!    `X(v, θ) = Q(v, sin θ R, cos θ R)`, and the outward normal `normalize(X_θ × X_v)`
//!    from the corrected derivatives (D Eqs. 10–16), the centreline tangent where that
//!    cross product vanishes (the tip of a taper to 0, and v = 0 for 0 < t < 1).

use super::radius::{radius, Radius};
use super::real::{Real, Vector};
use super::record::BranchRecord;
use super::{NORMAL_SQ, PARALLEL_SQ, TINY_SQ};
use glam::Vec3;
use std::fmt::Debug;

// ---------------------------------------------------------------------------------------
// Handles: Sloan's moving frame (D Eq. 8, property 15).

/// `x > limit`, false where either is NaN (so a NaN takes the fallback).
fn exceeds<S: Real>(x: S, limit: S) -> bool {
    x > limit
}

/// `v` normalized, or `fallback` where `|v|² ≤` [`TINY_SQ`].
pub fn unit_or<V: Vector>(v: V, fallback: V) -> V {
    if v.length_squared() > V::S::of(TINY_SQ) {
        v.normalize()
    } else {
        fallback
    }
}

/// The world axis least aligned with `l` (smallest `|l · e|`; ties go to X, then Y): what
/// stands in for O where L₀ ∥ O, and the parent direction of a root axis.
pub fn fallback_axis<V: Vector>(l: V) -> V {
    let [x, y, z] = l.abs().components();
    if x <= y && x <= z {
        V::X
    } else if y <= z {
        V::Y
    } else {
        V::Z
    }
}

/// The handles at P₀, P₁, P₂: Lᵢ the leg directions, Sᵢ and Tᵢ the frame's other two
/// axes. Each {Lᵢ, Sᵢ, Tᵢ} is orthonormal with `Sᵢ = Lᵢ × Tᵢ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Handles<V> {
    /// L₀, L₁, L₂.
    pub l: [V; 3],
    /// S₀, S₁, S₂.
    pub s: [V; 3],
    /// T₀, T₁, T₂.
    pub t: [V; 3],
    /// Whether L₀ ∥ O (or O = 0) took [`fallback_axis`].
    pub fallback: bool,
}

/// Sloan's frame (D Eq. 8) with Skjermo2008-spec's normalisations:
/// `Lᵢ = normalize(Pᵢ₊₁ − Pᵢ)`, `S₀ = normalize(L₀ × O)`, `T₀ = S₀ × L₀`,
/// `T₁ = normalize(S₀ × L₁)`, `S₁ = L₁ × T₁`, `T₂ = normalize(S₁ × L₂)`, `S₂ = L₂ × T₂`.
/// Degenerate cases never give NaN: O ∥ L₀ (within [`PARALLEL_SQ`]) or O = 0 uses
/// [`fallback_axis`]`(L₀)` for O; a zero leg takes the previous leg's direction (L₀ the
/// chord P₃ − P₀, then +X); a zero T₁ or T₂ (a joint of 90°) the previous T.
pub fn sloan_frames<V: Vector>(p: &[V; 4], o: V) -> Handles<V> {
    let l0 = unit_or(p[1] - p[0], unit_or(p[3] - p[0], V::X));
    let l1 = unit_or(p[2] - p[1], l0);
    let l2 = unit_or(p[3] - p[2], l1);
    let s0 = l0.cross(o);
    let fallback = !exceeds(s0.length_squared(), V::S::of(PARALLEL_SQ));
    let s0 = if fallback { l0.cross(fallback_axis(l0)).normalize() } else { s0.normalize() };
    let t0 = s0.cross(l0);
    let t1 = unit_or(s0.cross(l1), t0);
    let s1 = l1.cross(t1);
    let t2 = unit_or(s1.cross(l2), t1);
    let s2 = l2.cross(t2);
    Handles { l: [l0, l1, l2], s: [s0, s1, s2], t: [t0, t1, t2], fallback }
}

// ---------------------------------------------------------------------------------------
// The deformer (D §3.3–3.5, properties 13, 14, 17, 18).

/// A surface point of a deformed branch with what shading needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint<V: Vector> {
    /// X(v, θ) = Q(v, sin θ R, cos θ R).
    pub position: V,
    /// Outward unit normal `normalize(X_θ × X_v)`, or the centreline tangent where
    /// `degenerate`.
    pub normal: V,
    /// X_v = Q_u + Q_a sin θ R_v + Q_b cos θ R_v (where R_v is infinite, v = 0 with
    /// 0 < t < 1, only Q_u).
    pub tangent_v: V,
    /// X_θ = Q_a (cos θ R + sin θ R_θ) + Q_b (−sin θ R + cos θ R_θ).
    pub tangent_theta: V,
    /// The centreline point Q(v, 0, 0).
    pub centre: V,
    /// R, R_v, R_θ.
    pub radius: Radius<V::S>,
    /// Whether the normal fell back to the centreline tangent (R = 0, the tapered tip; or
    /// v = 0 with 0 < t < 1, where R_v is infinite).
    pub degenerate: bool,
}

/// One branch ready to deform: the record, its points in precision `V` and its handles
/// (computed once; the GPU recomputes them per vertex, identically).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BranchDeformer<V: Vector> {
    /// The record.
    pub record: BranchRecord,
    /// P₀…P₃.
    pub points: [V; 4],
    /// Sloan's frame.
    pub handles: Handles<V>,
}

/// The deformer in `f32`, the GPU's precision.
pub type Deformer = BranchDeformer<Vec3>;

impl<V: Vector> BranchDeformer<V> {
    /// Converts the record's points and parent direction and builds the handles.
    pub fn new(record: &BranchRecord) -> BranchDeformer<V> {
        let points = record.points().map(V::of);
        let handles = sloan_frames(&points, V::of(record.parent_dir));
        BranchDeformer { record: *record, points, handles }
    }

    /// The generalized de Casteljau map (D Eq. 9):
    /// `R⁰ᵢ = lerp(Pᵢ, Pᵢ₊₁, u) + a Sᵢ + b Tᵢ`, `R¹ᵢ = lerp(R⁰ᵢ, R⁰ᵢ₊₁, u)`,
    /// `Q = lerp(R¹₀, R¹₁, u)`; `Q(u, 0, 0)` is the cubic Bézier.
    pub fn q(&self, u: V::S, a: V::S, b: V::S) -> V {
        let (p, s, t) = (&self.points, &self.handles.s, &self.handles.t);
        let r00 = p[0].lerp(p[1], u) + s[0] * a + t[0] * b;
        let r10 = p[1].lerp(p[2], u) + s[1] * a + t[1] * b;
        let r20 = p[2].lerp(p[3], u) + s[2] * a + t[2] * b;
        let r01 = r00.lerp(r10, u);
        let r11 = r10.lerp(r20, u);
        r01.lerp(r11, u)
    }

    /// `[Q_u, Q_a, Q_b]` (D Eqs. 15–16 corrected, errata 5–6): with the hodographs
    /// `L′ᵢ = 3(Pᵢ₊₁ − Pᵢ)`, `S′ᵢ = 2(Sᵢ₊₁ − Sᵢ)`, `T′ᵢ = 2(Tᵢ₊₁ − Tᵢ)`,
    /// `Q_u = lerp(lerp(L′₀, L′₁, u), lerp(L′₁, L′₂, u), u) + a lerp(S′₀, S′₁, u) + b lerp(T′₀, T′₁, u)`,
    /// `Q_a = lerp(lerp(S₀, S₁, u), lerp(S₁, S₂, u), u)`, `Q_b` likewise with T.
    pub fn q_derivatives(&self, u: V::S, a: V::S, b: V::S) -> [V; 3] {
        let (p, s, t) = (&self.points, &self.handles.s, &self.handles.t);
        let (two, three) = (V::S::of(2.0), V::S::of(3.0));
        let dl = [(p[1] - p[0]) * three, (p[2] - p[1]) * three, (p[3] - p[2]) * three];
        let ds = [(s[1] - s[0]) * two, (s[2] - s[1]) * two];
        let dt = [(t[1] - t[0]) * two, (t[2] - t[1]) * two];
        let q_u = dl[0].lerp(dl[1], u).lerp(dl[1].lerp(dl[2], u), u)
            + ds[0].lerp(ds[1], u) * a
            + dt[0].lerp(dt[1], u) * b;
        let q_a = s[0].lerp(s[1], u).lerp(s[1].lerp(s[2], u), u);
        let q_b = t[0].lerp(t[1], u).lerp(t[1].lerp(t[2], u), u);
        [q_u, q_a, q_b]
    }

    /// The unit tangent of the centreline at `u` (the middle leg's direction L₁ where the
    /// Bézier's derivative vanishes).
    pub fn centreline_tangent(&self, u: V::S) -> V {
        let [q_u, _, _] = self.q_derivatives(u, V::S::of(0.0), V::S::of(0.0));
        unit_or(q_u, self.handles.l[1])
    }

    /// X(v, θ) = Q(v, sin θ R(v, θ), cos θ R(v, θ)) (D Eqs. 6, 9).
    pub fn position(&self, v: V::S, theta: V::S) -> V {
        let r = radius(&self.record, v, theta).r;
        self.q(v, theta.sin() * r, theta.cos() * r)
    }

    /// The surface point at (v, θ) with its tangents and outward normal (D §3.4–3.5 as
    /// corrected by Skjermo2008-spec §3, errata 4–6).
    pub fn evaluate(&self, v: V::S, theta: V::S) -> SurfacePoint<V> {
        let zero = V::S::of(0.0);
        let rad = radius(&self.record, v, theta);
        let (sn, cs) = (theta.sin(), theta.cos());
        let (a, b) = (sn * rad.r, cs * rad.r);
        let position = self.q(v, a, b);
        let centre = self.q(v, zero, zero);
        let [q_u, q_a, q_b] = self.q_derivatives(v, a, b);
        let t = self.record.taper;
        // R_v is infinite at v = 0 for 0 < t < 1: keep only the centreline part.
        let base_kink = v <= zero && t > 0.0 && t < 1.0 && self.record.radius != self.record.tip_radius;
        let tangent_v = if base_kink { q_u } else { q_u + q_a * (sn * rad.dv) + q_b * (cs * rad.dv) };
        let tangent_theta = q_a * (cs * rad.r + sn * rad.dtheta) + q_b * (cs * rad.dtheta - sn * rad.r);
        let n = tangent_theta.cross(tangent_v);
        let scale = tangent_theta.length_squared() * tangent_v.length_squared();
        let degenerate = base_kink || !exceeds(n.length_squared(), V::S::of(NORMAL_SQ) * scale);
        let normal = if degenerate { self.centreline_tangent(v) } else { n.normalize() };
        SurfacePoint { position, normal, tangent_v, tangent_theta, centre, radius: rad, degenerate }
    }
}

/// The deformed position and outward unit normal of `record` at (v, θ), in `f32`.
pub fn deform(record: &BranchRecord, v: f32, theta: f32) -> (Vec3, Vec3) {
    let p = Deformer::new(record).evaluate(v, theta);
    (p.position, p.normal)
}
