//! The GPU branch deformer's CPU reference (issue 25, item 1): Skjermo2008 D §2–§3.5
//! (Skjermo's 2006 vertex-shader deformer) as Skjermo2008-spec §3 corrects it, with the checks of
//! Skjermo2008-spec §10, properties 12–19. `docs/deformer.md` has the formulas and the table of
//! tests; the GPU crate ports this file line for line to WGSL and must match it within
//! 10⁻⁴ of the branch radius (property 19).
//!
//! A branch is one [`BranchRecord`]: four Bézier control points P₀…P₃, the unit parent
//! direction O and the shape parameters. A vertex of a (v, θ) [`Grids`] level becomes a
//! surface point in three steps:
//!
//! 1. **radius** ([`radius`]): R(v, θ) = f_taper · f_flare · f_bulges · f_lobes (D Eqs.
//!    2–5) with the spec's errata — t = 0 means no taper, the Weber–Penn flare
//!    `f (100^max(0, 1−8v) − 1)/100 + 1` by default ([`FlareMode`]), the lobes' `l_t` a
//!    fade toward the tip — and sylva's tip radius, `f_taper = r − (r − r_tip) vᵗ`
//!    (the seed's `r (1 − vᵗ)` when `r_tip = 0`), so a curve segment with a radius at each
//!    end is one record;
//! 2. **handles** ([`sloan_frames`]): Sloan's moving frame {Lᵢ, Sᵢ, Tᵢ} at P₀, P₁, P₂ (D
//!    Eq. 8) with S₀, T₁, T₂ normalized and the world axis least aligned with L₀ standing
//!    in for O where L₀ ∥ O;
//! 3. **bending** ([`BranchDeformer::q`]): the generalized de Casteljau map
//!    `Q(u, a, b) = Σ B³ᵢ(u) Pᵢ + a Σ B²ᵢ(u) Sᵢ + b Σ B²ᵢ(u) Tᵢ` (D Eqs. 7, 9) at
//!    `X(v, θ) = Q(v, sin θ R, cos θ R)`, and the outward normal `normalize(X_θ × X_v)`
//!    from the corrected derivatives (D Eqs. 10–16), the centreline tangent where that
//!    cross product vanishes (the tip of a taper to 0, and v = 0 for 0 < t < 1).
//!
//! The code is generic over the precision ([`Vector`]: `Vec3` with `f32`, what the GPU
//! runs, or `DVec3` with `f64`, which the tests difference); [`Deformer`] and [`deform`]
//! are the `f32` path. [`branch_records`] turns a model's [`BranchCurves`] into one record
//! per curve segment (in the order of the wind rig's branches), [`Grids`] builds the
//! shared vertex list of several LOD grids and [`branch_mesh`] deforms one grid per record
//! into a [`Mesh`], what the GPU's instanced draw will show.

use crate::geometry::{FaceVarying, Mesh};
use crate::model::{BranchCurves, CurveSegment};
use glam::{DMat3, DVec3, Vec2, Vec3};
use std::fmt::{self, Debug};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Squared length below which a vector counts as zero (a control-polygon leg, T₁, T₂).
pub const TINY_SQ: f32 = 1e-12;
/// `|L₀ × O|²` at or below which L₀ counts as parallel to O (an angle under 10⁻³ rad):
/// the frame then takes [`fallback_axis`] for O.
pub const PARALLEL_SQ: f32 = 1e-6;
/// `|X_θ × X_v|² ≤ NORMAL_SQ · |X_θ|² |X_v|²` (the tangents within 10⁻⁵ rad of parallel,
/// or one of them zero) makes the normal fall back to the centreline tangent.
pub const NORMAL_SQ: f32 = 1e-10;
/// ln 100: `100^y` is evaluated as `exp(LN_100 · y)` on both sides.
pub const LN_100: f32 = 4.605_170_2;
/// The Weber–Penn flare is exactly 1 from `v = FLARE_END` on (`y = max(0, 1 − 8v)`).
pub const FLARE_END: f32 = 0.125;
/// [`BranchRecord::axis`] of a record that did not come from [`BranchCurves`].
pub const NO_AXIS: u32 = u32::MAX;
/// The default LOD grids as (rings, sides), finest first: each coarser level's (v, θ)
/// samples are a subset of the finer ones', so shared samples deform to the same point.
pub const DEFAULT_LODS: [(u32, u32); 4] = [(25, 16), (13, 8), (7, 4), (4, 4)];

/// What the deformer rejects.
#[derive(Debug, Clone, PartialEq)]
pub enum DeformError {
    /// The branch length of [`control_polygon`] is not a positive finite number.
    Length(f32),
    /// A joint of the control polygon bends by 90° or more (D §2.1, §3.3.2: Sloan's
    /// frame needs each angle between successive legs below 90°). `joint` is 1 (at P₁)
    /// or 2 (at P₂).
    JointAngle {
        /// 1 for the joint at P₁, 2 for the one at P₂.
        joint: usize,
        /// The angle between the legs meeting there.
        degrees: f32,
    },
    /// A shape parameter out of range.
    Parameter {
        /// The record field (or argument).
        name: &'static str,
        /// Its value.
        value: f32,
        /// What it must be.
        expected: &'static str,
    },
    /// A grid needs at least 2 rings and 3 sides.
    Grid {
        /// Rings asked for.
        rings: u32,
        /// Sides asked for.
        sides: u32,
    },
}

impl fmt::Display for DeformError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeformError::Length(l) => write!(f, "branch length {l} is not a positive finite number"),
            DeformError::JointAngle { joint, degrees } => write!(
                f,
                "the control polygon bends by {degrees}° at joint {joint}; the deformer needs less than 90° \
                 between successive legs (seed 003 D §3.3.2)"
            ),
            DeformError::Parameter { name, value, expected } => {
                write!(f, "branch parameter `{name}` = {value}: expected {expected}")
            }
            DeformError::Grid { rings, sides } => {
                write!(f, "a grid of {rings} rings and {sides} sides: needs at least 2 rings and 3 sides")
            }
        }
    }
}

impl std::error::Error for DeformError {}

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

// ---------------------------------------------------------------------------------------
// The branch record.

/// Which flare formula (Skjermo2008-spec §3, "Flare").
#[repr(u32)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum FlareMode {
    /// Weber–Penn 1995: `f (100^y − 1)/100 + 1` with `y = max(0, 1 − 8v)`: 1 + 0.99 f at
    /// the base, exactly 1 from v = 1/8 on (a slope kink there). Weber–Penn flare values
    /// mean the same here as in the generator.
    #[default]
    WeberPenn = 0,
    /// The seed's printed Eq. 3: `(f/100) 100^(1−8v) + 1`: 1 + f at the base, smooth,
    /// never exactly 1.
    Printed = 1,
}

/// One branch as the GPU deformer reads it: 112 bytes, `#[repr(C)]`, laid out exactly as
/// the WGSL struct with the same fields in the same order (each `Vec3` at a 16-byte
/// offset with a 4-byte scalar after it; `flare_mode` and the last three fields are
/// `u32`). [`BranchRecord::to_words`] gives the bytes as `u32`s.
///
/// | offset | field | | offset | field |
/// |---|---|---|---|---|
/// | 0 | `p0: vec3<f32>` | | 12 | `radius: f32` |
/// | 16 | `p1: vec3<f32>` | | 28 | `tip_radius: f32` |
/// | 32 | `p2: vec3<f32>` | | 44 | `taper: f32` |
/// | 48 | `p3: vec3<f32>` | | 60 | `flare: f32` |
/// | 64 | `parent_dir: vec3<f32>` | | 76 | `flare_mode: u32` |
/// | 80 | `bulge_depth: f32` | | 84 | `bulge_count: f32` |
/// | 88 | `lobe_depth: f32` | | 92 | `lobe_count: f32` |
/// | 96 | `lobe_fade: f32` | | 100 | `order: u32` |
/// | 104 | `axis: u32` | | 108 | `segment: u32` |
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BranchRecord {
    /// Control point P₀, the branch's base (metres).
    pub p0: Vec3,
    /// Base radius r (metres): `f_taper(0)`.
    pub radius: f32,
    /// Control point P₁.
    pub p1: Vec3,
    /// Radius the taper reaches at v = 1 (sylva's; 0 is the seed's Eq. 2, a point).
    pub tip_radius: f32,
    /// Control point P₂.
    pub p2: Vec3,
    /// Taper exponent t ≥ 0: `f_taper = r − (r − r_tip) vᵗ`; 0 means no taper
    /// (`f_taper = r`), 1 a linear blend, larger values keep the radius longer.
    pub taper: f32,
    /// Control point P₃, the branch's tip.
    pub p3: Vec3,
    /// Flare f ≥ 0 (seed examples 0, 0.1, 0.33).
    pub flare: f32,
    /// Unit direction O of the parent at the branching point (D §2.4); zero or parallel to
    /// P₁ − P₀ takes [`fallback_axis`].
    pub parent_dir: Vec3,
    /// Which flare formula.
    pub flare_mode: FlareMode,
    /// Bulge depth b_d (|b_d| < 1).
    pub bulge_depth: f32,
    /// Number of bulges b_n along the branch.
    pub bulge_count: f32,
    /// Lobe depth l_d.
    pub lobe_depth: f32,
    /// Number of lobes l_n around the branch.
    pub lobe_count: f32,
    /// Lobe fade toward the tip l_t: lobes scale by `1 − v l_t` (0 full lobes at the
    /// tip, 1 none; the seed's text says the opposite of its formula, Skjermo2008-spec §3).
    pub lobe_fade: f32,
    /// Branch order (0 for a trunk), for per-level materials; the deformer ignores it.
    pub order: u32,
    /// Index of the axis in [`BranchCurves::axes`], or [`NO_AXIS`].
    pub axis: u32,
    /// Index of the segment on its axis.
    pub segment: u32,
}

const _: () = assert!(std::mem::size_of::<BranchRecord>() == BranchRecord::SIZE);

impl BranchRecord {
    /// Size in bytes (the storage buffer's stride).
    pub const SIZE: usize = 112;
    /// Size in 32-bit words.
    pub const WORDS: usize = BranchRecord::SIZE / 4;

    /// A cylinder of radius `radius` along the Bézier `points`, hanging on a parent of
    /// direction `parent_dir` (normalized here; zero for none): no taper, flare, bulges or
    /// lobes; tip radius 0, so setting [`BranchRecord::taper`] gives the seed's Eq. 2.
    pub fn new(points: [Vec3; 4], parent_dir: Vec3, radius: f32) -> BranchRecord {
        BranchRecord {
            p0: points[0],
            radius,
            p1: points[1],
            tip_radius: 0.0,
            p2: points[2],
            taper: 0.0,
            p3: points[3],
            flare: 0.0,
            parent_dir: parent_dir.normalize_or_zero(),
            flare_mode: FlareMode::WeberPenn,
            bulge_depth: 0.0,
            bulge_count: 0.0,
            lobe_depth: 0.0,
            lobe_count: 0.0,
            lobe_fade: 0.0,
            order: 0,
            axis: NO_AXIS,
            segment: 0,
        }
    }

    /// The record of one curve segment: its control points, `radius = radii[0]`,
    /// `tip_radius = radii[1]` and taper t = 1, so the radius blends linearly from one end
    /// to the other (`f_taper = r0 − (r0 − r1) v`); no flare (a generator's flare is
    /// already in its knot radii), bulges or lobes.
    pub fn from_segment(segment: &CurveSegment, parent_dir: Vec3) -> BranchRecord {
        BranchRecord {
            tip_radius: segment.radii[1],
            taper: 1.0,
            ..BranchRecord::new(segment.points, parent_dir, segment.radii[0])
        }
    }

    /// P₀…P₃.
    pub fn points(&self) -> [Vec3; 4] {
        [self.p0, self.p1, self.p2, self.p3]
    }

    /// Replaces P₀…P₃ (the wind pass moves them).
    pub fn set_points(&mut self, points: [Vec3; 4]) {
        [self.p0, self.p1, self.p2, self.p3] = points;
    }

    /// The record as the GPU reads it: 28 little-endian-agnostic `u32` words (`f32` bits
    /// for the float fields), in the layout of the type's table.
    pub fn to_words(&self) -> [u32; BranchRecord::WORDS] {
        let f = |x: f32| x.to_bits();
        let v = |p: Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
        let mut w = [0u32; BranchRecord::WORDS];
        let rows = [
            (v(self.p0), f(self.radius)),
            (v(self.p1), f(self.tip_radius)),
            (v(self.p2), f(self.taper)),
            (v(self.p3), f(self.flare)),
            (v(self.parent_dir), self.flare_mode as u32),
        ];
        for (i, (xyz, last)) in rows.iter().enumerate() {
            w[4 * i..4 * i + 3].copy_from_slice(xyz);
            w[4 * i + 3] = *last;
        }
        w[20..28].copy_from_slice(&[
            f(self.bulge_depth),
            f(self.bulge_count),
            f(self.lobe_depth),
            f(self.lobe_count),
            f(self.lobe_fade),
            self.order,
            self.axis,
            self.segment,
        ]);
        w
    }

    /// The angles between successive legs of the control polygon at P₁ and P₂, in degrees
    /// (0 where a leg has zero length).
    pub fn joint_angles(&self) -> [f32; 2] {
        let p = self.points();
        let angle = |a: Vec3, b: Vec3| match (a.try_normalize(), b.try_normalize()) {
            (Some(a), Some(b)) => a.dot(b).clamp(-1.0, 1.0).acos().to_degrees(),
            _ => 0.0,
        };
        [angle(p[1] - p[0], p[2] - p[1]), angle(p[2] - p[1], p[3] - p[2])]
    }

    /// Checks what the deformer assumes: finite numbers, joint angles below 90°, radii,
    /// taper and flare ≥ 0, bulge depth below 1, lobes that keep the radius positive
    /// (`|l_d| max(1, |1 − l_t|) < 1`) and a parent direction that is unit or zero. The
    /// deformer runs on any record (never NaN for finite input); this says whether the
    /// surface is the one the seed means.
    pub fn check(&self) -> Result<(), DeformError> {
        let bad = |name, value, expected| Err(DeformError::Parameter { name, value, expected });
        for (name, p) in [
            ("p0", self.p0),
            ("p1", self.p1),
            ("p2", self.p2),
            ("p3", self.p3),
            ("parent_dir", self.parent_dir),
        ] {
            if !p.is_finite() {
                return bad(name, p.x + p.y + p.z, "finite coordinates");
            }
        }
        let scalars = [
            ("radius", self.radius),
            ("tip_radius", self.tip_radius),
            ("taper", self.taper),
            ("flare", self.flare),
            ("bulge_depth", self.bulge_depth),
            ("bulge_count", self.bulge_count),
            ("lobe_depth", self.lobe_depth),
            ("lobe_count", self.lobe_count),
            ("lobe_fade", self.lobe_fade),
        ];
        for (name, x) in scalars {
            if !x.is_finite() {
                return bad(name, x, "a finite number");
            }
        }
        for (name, x) in [
            ("radius", self.radius),
            ("tip_radius", self.tip_radius),
            ("taper", self.taper),
            ("flare", self.flare),
        ] {
            if x < 0.0 {
                return bad(name, x, "≥ 0");
            }
        }
        if self.bulge_depth.abs() >= 1.0 {
            return bad("bulge_depth", self.bulge_depth, "|b_d| < 1");
        }
        if self.lobe_depth.abs() * (1.0 - self.lobe_fade).abs().max(1.0) >= 1.0 {
            return bad("lobe_depth", self.lobe_depth, "|l_d| · max(1, |1 − l_t|) < 1");
        }
        let o = self.parent_dir.length();
        if o != 0.0 && (o - 1.0).abs() > 1e-4 {
            return bad("parent_dir", o, "a unit vector or zero (its length is shown)");
        }
        for (k, degrees) in self.joint_angles().into_iter().enumerate() {
            if degrees >= 90.0 {
                return Err(DeformError::JointAngle { joint: k + 1, degrees });
            }
        }
        Ok(())
    }

    /// R, R_v and R_θ at (v, θ) in `f32` (see [`radius`]).
    pub fn radius(&self, v: f32, theta: f32) -> Radius<f32> {
        radius(self, v, theta)
    }
}

// ---------------------------------------------------------------------------------------
// Control polygon (D §2.1, property 12).

/// The control points of a branch of length `length` bent by `angles` = [roll₁, bend₁,
/// roll₂, bend₂] (radians), in the branch's own space (D §2.1): the legs are `length/3`
/// long; the first runs from P₀ = 0 along +X; at P₁ and at P₂ the frame turns by the roll
/// about the current leg's direction (local X), then by the bend about the new local Z,
/// and the next leg runs along the new local X. The angle between successive legs is
/// `|bend|`, which must be below 90° ([`DeformError::JointAngle`]). Transform the points
/// into place in the tree afterwards. The Bézier's arc length is at most `length`, equal
/// only when both bends are 0.
pub fn control_polygon(length: f32, angles: [f32; 4]) -> Result<[Vec3; 4], DeformError> {
    if !(length.is_finite() && length > 0.0) {
        return Err(DeformError::Length(length));
    }
    for (i, a) in angles.iter().enumerate() {
        if !a.is_finite() {
            let name = ["roll at P1", "bend at P1", "roll at P2", "bend at P2"][i];
            return Err(DeformError::Parameter { name, value: *a, expected: "a finite angle" });
        }
    }
    for (k, bend) in [angles[1], angles[3]].into_iter().enumerate() {
        if bend.abs() >= std::f32::consts::FRAC_PI_2 {
            return Err(DeformError::JointAngle { joint: k + 1, degrees: bend.abs().to_degrees() });
        }
    }
    let leg = length as f64 / 3.0;
    let mut frame = DMat3::IDENTITY;
    let mut p = [DVec3::ZERO; 4];
    p[1] = frame.x_axis * leg;
    for k in 0..2 {
        frame = frame
            * DMat3::from_rotation_x(angles[2 * k] as f64)
            * DMat3::from_rotation_z(angles[2 * k + 1] as f64);
        p[k + 2] = p[k + 1] + frame.x_axis * leg;
    }
    Ok(p.map(|q| q.as_vec3()))
}

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

// ---------------------------------------------------------------------------------------
// Records of a model's branch curves.

/// The unit tangent of a segment at `t` (the chord's direction where the derivative
/// vanishes; `None` for a segment of zero size).
fn segment_tangent(seg: &CurveSegment, t: f32) -> Option<Vec3> {
    let p = &seg.points;
    let s = 1.0 - t;
    let d = (p[1] - p[0]) * (3.0 * s * s) + (p[2] - p[1]) * (6.0 * s * t) + (p[3] - p[2]) * (3.0 * t * t);
    d.try_normalize().or((p[3] - p[0]).try_normalize())
}

/// The parent's direction where axis `axis` hangs: where the parent chain follows its
/// nodes (fitted curves), the end of the parent segment that ends at the axis's base node;
/// else (a generator's own Béziers) the parent chain's point nearest the axis's first
/// point, over 33 samples per segment — the wind rig's attach point.
fn hang_direction(curves: &BranchCurves, axis: usize) -> Option<Vec3> {
    let (k, t) = curves.attach(axis)?;
    let parent = &curves.axes[curves.axes[axis].parent? as usize];
    segment_tangent(parent.segments.get(k)?, t)
}

/// One record per curve segment of `curves` (axes in order, each base to tip: the order
/// of `wind::WindRig`'s branches, so record `i` is wind branch `i`), via
/// [`BranchRecord::from_segment`] with `order`, `axis` and `segment` filled. The parent
/// direction O of an axis's first segment is its parent's tangent where it hangs (the
/// point the wind rig attaches it to), and [`fallback_axis`] of its first leg for a root;
/// a later segment's O is the previous segment's end handle T₂, which makes its S₀, T₀
/// the previous S₂, T₂ wherever the chain is C¹, so the frame runs on across knots
/// without a twist (the previous segment's direction would be ∥ L₀).
pub fn branch_records(curves: &BranchCurves) -> Vec<BranchRecord> {
    let mut out = Vec::with_capacity(curves.axes.iter().map(|a| a.segments.len()).sum());
    for (ai, axis) in curves.axes.iter().enumerate() {
        let mut o = hang_direction(curves, ai);
        for (k, seg) in axis.segments.iter().enumerate() {
            let p = &seg.points;
            let dir = o.unwrap_or_else(|| fallback_axis(unit_or(p[1] - p[0], unit_or(p[3] - p[0], Vec3::X))));
            let mut rec = BranchRecord::from_segment(seg, dir);
            rec.order = axis.order as u32;
            rec.axis = ai as u32;
            rec.segment = k as u32;
            o = Some(sloan_frames(&rec.points(), rec.parent_dir).t[2]);
            out.push(rec);
        }
    }
    out
}

// ---------------------------------------------------------------------------------------
// Grids (D §2.3) and the CPU mesher.

/// One vertex of an input grid (16 bytes, `#[repr(C)]`; WGSL `struct { v: f32, theta:
/// f32, uv: vec2<f32> }`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridVertex {
    /// Position along the branch, 0 at P₀, 1 at P₃.
    pub v: f32,
    /// Angle around the branch in [0, 2π); the seam column repeats θ = 0.
    pub theta: f32,
    /// Texture coordinates: (θ/2π, v), u = 1 on the seam column.
    pub uv: Vec2,
}

/// Where one LOD grid lies in [`Grids`]' shared vertex and index lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridLod {
    /// Rings of vertices along v (v = i / (rings − 1)).
    pub rings: u32,
    /// Quads around the branch (θ = 2π j / sides); each ring has `sides + 1` vertices.
    pub sides: u32,
    /// First vertex in [`Grids::vertices`].
    pub first_vertex: u32,
    /// `rings × (sides + 1)`.
    pub vertex_count: u32,
    /// First index in [`Grids::indices`].
    pub first_index: u32,
    /// `6 (rings − 1) sides`.
    pub index_count: u32,
}

/// Several (v, θ) grids sharing one vertex list and one index list (D §2.3: one VBO, one
/// index range per LOD): a triangle list, counter-clockwise seen from outside, indices
/// absolute into [`Grids::vertices`] (draw with base vertex 0). Within a level vertices
/// run ring by ring from v = 0, each ring from θ = 0 to the seam column (θ stored as 0
/// again so the seam's positions coincide bit for bit with the first column's, texture u
/// = 1). Quad (i, j) is the triangles (i,j) (i,j+1) (i+1,j+1) and (i,j) (i+1,j+1) (i+1,j).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Grids {
    /// Every level's vertices.
    pub vertices: Vec<GridVertex>,
    /// Every level's triangles.
    pub indices: Vec<u32>,
    /// The levels, in the order asked for.
    pub lods: Vec<GridLod>,
}

impl Grids {
    /// The grids of `levels`, each `(rings, sides)` with rings ≥ 2 and sides ≥ 3. Keep
    /// the bulge count below half the finest level's rings − 1 and the lobe count below
    /// half its sides (D §3.2.3).
    pub fn new(levels: &[(u32, u32)]) -> Result<Grids, DeformError> {
        let mut g = Grids::default();
        for &(rings, sides) in levels {
            if rings < 2 || sides < 3 {
                return Err(DeformError::Grid { rings, sides });
            }
            let first_vertex = g.vertices.len() as u32;
            let first_index = g.indices.len() as u32;
            let cols = sides + 1;
            for i in 0..rings {
                let v = i as f32 / (rings - 1) as f32;
                for j in 0..cols {
                    let along = j as f32 / sides as f32;
                    let theta = if j == sides { 0.0 } else { along * std::f32::consts::TAU };
                    g.vertices.push(GridVertex { v, theta, uv: Vec2::new(along, v) });
                }
            }
            for i in 0..rings - 1 {
                for j in 0..sides {
                    let at = |i: u32, j: u32| first_vertex + i * cols + j;
                    let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
                    g.indices.extend_from_slice(&[a, b, c, a, c, d]);
                }
            }
            g.lods.push(GridLod {
                rings,
                sides,
                first_vertex,
                vertex_count: rings * cols,
                first_index,
                index_count: 6 * (rings - 1) * sides,
            });
        }
        Ok(g)
    }

    /// The [`DEFAULT_LODS`] grids.
    pub fn standard() -> Grids {
        Grids::new(&DEFAULT_LODS).expect("the default levels are valid")
    }

    /// The vertices of level `lod`.
    pub fn lod_vertices(&self, lod: usize) -> &[GridVertex] {
        let l = &self.lods[lod];
        &self.vertices[l.first_vertex as usize..(l.first_vertex + l.vertex_count) as usize]
    }

    /// The indices of level `lod` (absolute into [`Grids::vertices`]).
    pub fn lod_indices(&self, lod: usize) -> &[u32] {
        let l = &self.lods[lod];
        &self.indices[l.first_index as usize..(l.first_index + l.index_count) as usize]
    }
}

/// A single grid of `rings` rings and `sides` sides (see [`Grids::new`]).
pub fn grid(rings: u32, sides: u32) -> Result<Grids, DeformError> {
    Grids::new(&[(rings, sides)])
}

/// Every record deformed over level `lod` of `grids` (the coarsest level where `lod` is
/// past the last; an empty mesh when there are no levels), as the GPU's instanced draw
/// will show them: per record the level's vertices in order (seam column included, so the
/// mesh is open along the seam), its triangles, per-vertex UVs and normals as
/// face-varying channels indexed like the faces.
pub fn branch_mesh(records: &[BranchRecord], grids: &Grids, lod: usize) -> Mesh {
    let mut mesh = Mesh::new();
    if grids.lods.is_empty() {
        return mesh;
    }
    let lod = lod.min(grids.lods.len() - 1);
    let level = grids.lods[lod];
    let (verts, idx) = (grids.lod_vertices(lod), grids.lod_indices(lod));
    let n = records.len() * verts.len();
    mesh.positions.reserve(n);
    let (mut normals, mut uvs) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for rec in records {
        let d = Deformer::new(rec);
        let base = mesh.positions.len() as u32;
        for gv in verts {
            let s = d.evaluate(gv.v, gv.theta);
            mesh.positions.push(s.position);
            normals.push(s.normal);
            uvs.push(gv.uv);
        }
        for tri in idx.chunks_exact(3) {
            mesh.push_face(&[tri[0], tri[1], tri[2]].map(|i| i - level.first_vertex + base));
        }
    }
    mesh.uvs = Some(FaceVarying { values: uvs, indices: mesh.face_indices.clone() });
    mesh.normals = Some(FaceVarying { values: normals, indices: mesh.face_indices.clone() });
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn record_layout_matches_the_wgsl_struct() {
        use std::mem::offset_of;
        assert_eq!(std::mem::size_of::<BranchRecord>(), 112);
        assert_eq!(std::mem::size_of::<GridVertex>(), 16);
        let offsets = [
            offset_of!(BranchRecord, p0),
            offset_of!(BranchRecord, radius),
            offset_of!(BranchRecord, p1),
            offset_of!(BranchRecord, tip_radius),
            offset_of!(BranchRecord, p2),
            offset_of!(BranchRecord, taper),
            offset_of!(BranchRecord, p3),
            offset_of!(BranchRecord, flare),
            offset_of!(BranchRecord, parent_dir),
            offset_of!(BranchRecord, flare_mode),
            offset_of!(BranchRecord, bulge_depth),
            offset_of!(BranchRecord, bulge_count),
            offset_of!(BranchRecord, lobe_depth),
            offset_of!(BranchRecord, lobe_count),
            offset_of!(BranchRecord, lobe_fade),
            offset_of!(BranchRecord, order),
            offset_of!(BranchRecord, axis),
            offset_of!(BranchRecord, segment),
        ];
        assert_eq!(offsets, [0, 12, 16, 28, 32, 44, 48, 60, 64, 76, 80, 84, 88, 92, 96, 100, 104, 108]);
        // The words are the struct's bytes.
        let mut r = BranchRecord::new([Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE], Vec3::Y, 0.5);
        r.flare_mode = FlareMode::Printed;
        r.lobe_fade = 0.25;
        r.segment = 7;
        let w = r.to_words();
        // SAFETY: BranchRecord is repr(C), 112 bytes of 4-byte fields with no padding.
        let bytes: [u32; 28] = unsafe { std::mem::transmute(r) };
        assert_eq!(w, bytes);
        assert_eq!((w[3], w[19], w[24], w[27]), (0.5f32.to_bits(), 1, 0.25f32.to_bits(), 7));
    }

    #[test]
    fn t_zero_is_no_taper_and_flare_forms_agree_below_one_eighth() {
        assert_eq!(taper(0.3f32, 0.0, 0.0, 0.7), 0.3);
        assert_eq!(taper_dv(0.3f32, 0.0, 0.0, 0.7), 0.0);
        assert_eq!(taper(0.3f32, 0.1, 1.0, 1.0), 0.1);
        for v in [0.0f64, 0.05, 0.1] {
            let (a, b) = (flare_dv(0.33, FlareMode::WeberPenn, v), flare_dv(0.33, FlareMode::Printed, v));
            assert!((a - b).abs() < 1e-12);
        }
        assert_eq!(flare(0.33f64, FlareMode::WeberPenn, 0.2), 1.0);
        assert!((flare(0.33f64, FlareMode::WeberPenn, 0.0) - (1.0 + 0.99 * 0.33)).abs() < 1e-6);
        assert!((flare(0.33f64, FlareMode::Printed, 0.0) - 1.33).abs() < 1e-6);
    }

    #[test]
    fn grid_counts_and_seam() {
        let g = Grids::new(&[(3, 4), (2, 3)]).unwrap();
        assert_eq!(g.lods[0].vertex_count, 15);
        assert_eq!(g.lods[1].first_vertex, 15);
        assert_eq!(g.lods[1].index_count, 18);
        assert_eq!(g.lod_vertices(0)[4].theta, 0.0);
        assert_eq!(g.lod_vertices(0)[4].uv, Vec2::new(1.0, 0.0));
        assert!(g.indices.iter().all(|&i| (i as usize) < g.vertices.len()));
        assert_eq!(grid(1, 8), Err(DeformError::Grid { rings: 1, sides: 8 }));
    }
}
