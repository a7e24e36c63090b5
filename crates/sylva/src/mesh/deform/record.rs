//! The branch record the GPU reads (Skjermo2008-spec §3, the WGSL struct's layout) and
//! the control polygon of a branch (Skjermo2008 D §2.1, property 12).

use super::{DeformError, NO_AXIS};
use crate::model::CurveSegment;
use glam::{DMat3, DVec3, Vec3};
use std::fmt::Debug;

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
    /// P₁ − P₀ takes [`fallback_axis`](super::fallback_axis).
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
    /// Index of the axis in [`BranchCurves::axes`](crate::model::BranchCurves::axes), or [`NO_AXIS`].
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
