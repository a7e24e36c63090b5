//! The stem's shape functions: the `Shape` envelope ratio, the taper and flare radius
//! profile (WeberPenn1995 §4.3–§4.5), and the per-stem cubic Bézier chains recorded as
//! the model's branch curves for the GPU deformer (Skjermo2008 §B).

use super::params::WeberPennParams;
use super::WeberPennTree;
use crate::model::{BranchCurve, BranchCurves, CurveSegment};
use glam::Vec3;
use std::f64::consts::PI;

/// One cubic Bézier segment of a stem's centreline (sylva coordinates, +Y up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BezierSegment {
    /// The control points P0…P3; P0 and P3 lie on the stem.
    pub points: [Vec3; 4],
}

impl BezierSegment {
    /// The point at parameter `t` in \[0, 1\].
    pub fn eval(&self, t: f32) -> Vec3 {
        crate::geometry::cubic_bezier(&self.points, t)
    }
}

/// The tree's stems as the model's branch curves: each stem record's own Bézier chain,
/// with radii from [`Stem::radius_at`](super::Stem::radius_at) at the knots (distance along the stem measured by
/// the chords between knots, from the record's start). The parent of a record is its
/// `parent_stem`.
pub fn branch_curves(tree: &WeberPennTree) -> BranchCurves {
    let axes = tree
        .stems
        .iter()
        .map(|st| {
            let mut dist = st.start as f64;
            let segments = st
                .curve
                .iter()
                .map(|seg| {
                    let r0 = st.radius_at(dist) as f32;
                    dist += seg.points[0].distance(seg.points[3]) as f64;
                    CurveSegment { points: seg.points, radii: [r0, st.radius_at(dist) as f32] }
                })
                .collect();
            BranchCurve {
                segments,
                parent: st.parent_stem,
                order: st.level as u16,
                nodes: st.nodes.clone().collect(),
            }
        })
        .collect();
    BranchCurves { axes }
}

/// The paper's ShapeRatio (its table of shapes): the envelope of child lengths at `ratio`
/// (0 at the top of the crown, 1 at its base). Shape 8 is the pruning envelope; its
/// lower half divides by `PruneWidthPeak` (the printed `1 − PruneWidthPeak` would make
/// it discontinuous at the peak).
pub fn shape_ratio(shape: u32, ratio: f64, p: &WeberPennParams) -> f64 {
    match shape {
        0 => 0.2 + 0.8 * ratio,
        1 => 0.2 + 0.8 * (PI * ratio).sin(),
        2 => 0.2 + 0.8 * (0.5 * PI * ratio).sin(),
        4 => 0.5 + 0.5 * ratio,
        5 => {
            if ratio <= 0.7 {
                ratio / 0.7
            } else {
                (1.0 - ratio) / 0.3
            }
        }
        6 => 1.0 - 0.8 * ratio,
        7 => {
            if ratio <= 0.7 {
                0.5 + 0.5 * ratio / 0.7
            } else {
                0.5 + 0.5 * (1.0 - ratio) / 0.3
            }
        }
        8 => {
            if !(0.0..=1.0).contains(&ratio) {
                return 0.0;
            }
            let peak = p.prune_width_peak;
            if ratio < 1.0 - peak {
                (ratio / (1.0 - peak)).powf(p.prune_power_high)
            } else if peak > 0.0 {
                ((1.0 - ratio) / peak).powf(p.prune_power_low)
            } else {
                1.0
            }
        }
        _ => 1.0,
    }
}

/// The paper's stem radius profile (`nTaper`): radius at `z` = distance / length in \[0, 1\]
/// of a stem with base radius `radius`, length `length` and taper `taper` (0–3).
/// 0 < taper ≤ 1 is a cone to `radius·(1 − taper)`; 1 < taper < 2 a cone ending in a
/// sphere; taper = 2 a cylinder with a hemispherical end; 2 < taper ≤ 3 periodic
/// bulges of period 2·radius measured from the tip, pinched by `taper − 2`.
pub fn taper_radius(taper: f64, radius: f64, length: f64, z: f64) -> f64 {
    let z = z.clamp(0.0, 1.0);
    let unit = if taper <= 1.0 {
        taper
    } else if taper <= 2.0 {
        2.0 - taper
    } else {
        0.0
    };
    let tz = radius * (1.0 - unit * z);
    if taper <= 1.0 || tz <= 0.0 {
        return tz.max(0.0);
    }
    let z2 = (1.0 - z) * length;
    let depth = if taper < 2.0 || z2 < tz { 1.0 } else { taper - 2.0 };
    let z3 = if taper < 2.0 { z2 } else { (z2 - 2.0 * tz * (z2 / (2.0 * tz) + 0.5).floor()).abs() };
    if taper < 2.0 && z3 >= tz {
        return tz;
    }
    (1.0 - depth) * tz + depth * (tz * tz - (z3 - tz) * (z3 - tz)).max(0.0).sqrt()
}

/// The trunk flare factor at `z` (the paper's Flare): `1 + Flare·(100^y − 1)/100`, `y = max(0, 1 − 8z)`.
pub(super) fn flare_factor(flare: f64, z: f64) -> f64 {
    if flare == 0.0 {
        return 1.0;
    }
    let y = (1.0 - 8.0 * z).max(0.0);
    1.0 + flare * (100f64.powf(y) - 1.0) / 100.0
}
