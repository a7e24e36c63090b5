//! The radius functions R(v, θ) = f_taper · f_flare · f_bulges · f_lobes and their
//! derivatives (Skjermo2008 D §3.2, Eqs. 2–5, 10, 11, with Skjermo2008-spec's errata).
//!
//! 1. **radius** ([`radius`]): R(v, θ) = f_taper · f_flare · f_bulges · f_lobes (D Eqs.
//!    2–5) with the spec's errata — t = 0 means no taper, the Weber–Penn flare
//!    `f (100^max(0, 1−8v) − 1)/100 + 1` by default ([`FlareMode`]), the lobes' `l_t` a
//!    fade toward the tip — and sylva's tip radius, `f_taper = r − (r − r_tip) vᵗ`
//!    (the seed's `r (1 − vᵗ)` when `r_tip = 0`), so a curve segment with a radius at each
//!    end is one record;

use super::real::Real;
use super::record::{BranchRecord, FlareMode};
use super::LN_100;
use std::fmt::Debug;

// ---------------------------------------------------------------------------------------
// Radius functions (D §3.2, Eqs. 2–5, 10, 11 with the errata).

/// R(v, θ) and its partial derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Radius<S> {
    /// R = f_taper f_flare f_bulges f_lobes.
    pub r: S,
    /// ∂R/∂v (product rule; ±∞ at v = 0 for 0 < t < 1 and r ≠ r_tip).
    pub dv: S,
    /// ∂R/∂θ = f_taper f_flare f_bulges ∂f_lobes/∂θ.
    pub dtheta: S,
}

/// `f_taper(v) = r (1 − vᵗ) + r_tip vᵗ` (= r − (r − r_tip) vᵗ, exactly r at v = 0 and
/// r_tip at v = 1; the seed's Eq. 2 for r_tip = 0), and `r` for t = 0 (no taper: the
/// seed's formula would make t = 0 a radius of 0).
pub fn taper<S: Real>(r: S, r_tip: S, t: S, v: S) -> S {
    if t == S::of(0.0) {
        r
    } else {
        let w = v.powf(t);
        r * (S::of(1.0) - w) + r_tip * w
    }
}

/// `∂f_taper/∂v = −t (r − r_tip) v^(t−1)` (erratum 1: the seed drops the sign); 0 for
/// t = 0 or r = r_tip; ±∞ at v = 0 for 0 < t < 1.
pub fn taper_dv<S: Real>(r: S, r_tip: S, t: S, v: S) -> S {
    if t == S::of(0.0) || r == r_tip {
        S::of(0.0)
    } else {
        -t * (r - r_tip) * v.powf(t - S::of(1.0))
    }
}

/// `100^y`, as `exp(ln 100 · y)`.
fn hundred_pow<S: Real>(y: S) -> S {
    (S::of(LN_100) * y).exp()
}

/// `f_flare(v)`: Weber–Penn `f (100^max(0, 1−8v) − 1)/100 + 1` or the printed
/// `(f/100) 100^(1−8v) + 1`.
pub fn flare<S: Real>(f: S, mode: FlareMode, v: S) -> S {
    let y = S::of(1.0) - S::of(8.0) * v;
    match mode {
        FlareMode::WeberPenn => {
            let y = if y > S::of(0.0) { y } else { S::of(0.0) };
            f * (hundred_pow(y) - S::of(1.0)) / S::of(100.0) + S::of(1.0)
        }
        FlareMode::Printed => f / S::of(100.0) * hundred_pow(y) + S::of(1.0),
    }
}

/// `∂f_flare/∂v = −(f/100) · 8 ln 100 · 100^(1−8v)` for both forms (erratum 2), and 0 for
/// the Weber–Penn form from v = 1/8 on (its right derivative at the kink).
pub fn flare_dv<S: Real>(f: S, mode: FlareMode, v: S) -> S {
    let y = S::of(1.0) - S::of(8.0) * v;
    if mode == FlareMode::WeberPenn && y <= S::of(0.0) {
        return S::of(0.0);
    }
    -(f / S::of(100.0)) * S::of(8.0) * S::of(LN_100) * hundred_pow(y)
}

/// `f_bulges(v) = 1 + b_d sin(2π b_n v)` (Eq. 4).
pub fn bulges<S: Real>(depth: S, count: S, v: S) -> S {
    S::of(1.0) + depth * (S::of(std::f32::consts::TAU) * count * v).sin()
}

/// `∂f_bulges/∂v = 2π b_d b_n cos(2π b_n v)`.
pub fn bulges_dv<S: Real>(depth: S, count: S, v: S) -> S {
    S::of(std::f32::consts::TAU) * depth * count * (S::of(std::f32::consts::TAU) * count * v).cos()
}

/// `f_lobes(v, θ) = 1 + l_d sin(l_n θ)(1 − v l_t)` (Eq. 5, implemented as printed).
pub fn lobes<S: Real>(depth: S, count: S, fade: S, v: S, theta: S) -> S {
    S::of(1.0) + depth * (count * theta).sin() * (S::of(1.0) - v * fade)
}

/// `∂f_lobes/∂v = −l_d l_t sin(l_n θ)`.
pub fn lobes_dv<S: Real>(depth: S, count: S, fade: S, theta: S) -> S {
    -depth * fade * (count * theta).sin()
}

/// `∂f_lobes/∂θ = l_d l_n cos(l_n θ)(1 − v l_t)` (erratum 3: the seed drops l_d in the
/// second term).
pub fn lobes_dtheta<S: Real>(depth: S, count: S, fade: S, v: S, theta: S) -> S {
    depth * count * (count * theta).cos() * (S::of(1.0) - v * fade)
}

/// R(v, θ), R_v and R_θ of `record` in precision `S` (the record's `f32` fields converted
/// exactly).
pub fn radius<S: Real>(record: &BranchRecord, v: S, theta: S) -> Radius<S> {
    let (r, r_tip, t) = (S::of(record.radius), S::of(record.tip_radius), S::of(record.taper));
    let (f, mode) = (S::of(record.flare), record.flare_mode);
    let (bd, bn) = (S::of(record.bulge_depth), S::of(record.bulge_count));
    let (ld, ln, lt) = (S::of(record.lobe_depth), S::of(record.lobe_count), S::of(record.lobe_fade));
    let ft = taper(r, r_tip, t, v);
    let ff = flare(f, mode, v);
    let fb = bulges(bd, bn, v);
    let fl = lobes(ld, ln, lt, v, theta);
    let dft = taper_dv(r, r_tip, t, v);
    let dff = flare_dv(f, mode, v);
    let dfb = bulges_dv(bd, bn, v);
    let dfl = lobes_dv(ld, ln, lt, theta);
    Radius {
        r: ft * ff * fb * fl,
        dv: dft * ff * fb * fl + ft * dff * fb * fl + ft * ff * dfb * fl + ft * ff * fb * dfl,
        dtheta: ft * ff * fb * lobes_dtheta(ld, ln, lt, v, theta),
    }
}

impl BranchRecord {
    /// R, R_v and R_θ at (v, θ) in `f32` (see [`radius`]).
    pub fn radius(&self, v: f32, theta: f32) -> Radius<f32> {
        radius(self, v, theta)
    }
}
