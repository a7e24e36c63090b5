//! The branch records of a model's [`BranchCurves`](crate::model::BranchCurves): one
//! per curve segment, in the order of the wind rig's branches, each hanging from its
//! parent's direction at the point it attaches to.

use super::bend::{fallback_axis, sloan_frames, unit_or};
use super::record::BranchRecord;
use crate::model::{BranchCurves, CurveSegment};
use glam::Vec3;

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
