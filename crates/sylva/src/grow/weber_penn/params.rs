//! The Weber–Penn parameter set (WeberPenn1995 Table 1, in snake case) with its
//! defaults (the paper's quaking aspen) and the checks that name the bad key.

use super::{MAX_CURVE_RES, MAX_LEAVES, MAX_PER_STEM, MAX_STEMS};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// The Weber–Penn parameter set. Field names are the paper's in snake case; per-level
/// parameters (`nX` in the paper) are arrays indexed by level 0–3 and named without the
/// `n` prefix's digit (`n_length[1]` is the paper's `1Length`). Missing recipe keys
/// take the [`Default`] values, which are the paper's quaking aspen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct WeberPennParams {
    /// `Shape` 0–8: the envelope of level-1 stem lengths along the trunk (0 conical,
    /// 1 spherical, 2 hemispherical, 3 cylindrical, 4 tapered cylindrical, 5 flame,
    /// 6 inverse conical, 7 tend flame, 8 the pruning envelope).
    pub shape: u32,
    /// `BaseSize`: fraction of the trunk without branches.
    pub base_size: f64,
    /// `Scale`: tree size in metres (the trunk length before `n_length[0]`).
    pub scale: f64,
    /// `ScaleV`: variation of `scale` (uniform ±).
    pub scale_v: f64,
    /// `ZScale`: vertical stretch of the finished tree.
    pub z_scale: f64,
    /// `ZScaleV`: variation of `z_scale`.
    pub z_scale_v: f64,
    /// `Levels` 1–4: stem levels (1 = a trunk only).
    pub levels: u32,
    /// `Ratio`: trunk radius / trunk length.
    pub ratio: f64,
    /// `RatioPower`: child radius = parent radius · (child length / parent length)^RatioPower.
    pub ratio_power: f64,
    /// `Lobes`: lobes of the trunk's cross-section (recorded per stem for meshers).
    pub lobes: u32,
    /// `LobeDepth`: relative depth of the lobes.
    pub lobe_depth: f64,
    /// `Flare`: extra trunk radius at the base (radius × (1 + Flare) at the ground).
    pub flare: f64,
    /// `0BaseSplits`: clones made at the end of the trunk's first segment, spread evenly
    /// around the vertical.
    pub base_splits: u32,
    /// `nScale`: `n_scale[0]` is the paper's `0Scale`, a factor on the trunk radius;
    /// the other levels are not used by the paper and are ignored.
    pub n_scale: [f64; 4],
    /// `nScaleV`: variation of `n_scale` (only level 0 is used).
    pub n_scale_v: [f64; 4],
    /// `nLength`: trunk length / scale (level 0); largest child length relative to its
    /// parent (levels 1–3).
    pub n_length: [f64; 4],
    /// `nLengthV`: variation of `n_length`.
    pub n_length_v: [f64; 4],
    /// `nTaper` 0–3: 0–1 conical (1 = a point), 1–2 spherical end, 2–3 periodic.
    pub n_taper: [f64; 4],
    /// `nCurveRes`: segments per stem (≥ 1 for every used level).
    pub n_curve_res: [u32; 4],
    /// `nCurve`: total curvature of a stem in degrees (first half when `n_curve_back` ≠ 0).
    pub n_curve: [f64; 4],
    /// `nCurveV`: random curvature in degrees; negative values make the stem a helix
    /// whose tangent leans `|nCurveV|` degrees from the stem axis (must be > −90).
    pub n_curve_v: [f64; 4],
    /// `nCurveBack`: curvature of the second half of the stem (an S-curve when opposite).
    pub n_curve_back: [f64; 4],
    /// `nSegSplits`: clones per segment end (fractions accumulate: 0.25 = one split
    /// every four segment ends).
    pub n_seg_splits: [f64; 4],
    /// `nSplitAngle`: angle between a split's clones in degrees.
    pub n_split_angle: [f64; 4],
    /// `nSplitAngleV`: variation of `n_split_angle`.
    pub n_split_angle_v: [f64; 4],
    /// `nBranches`: child stems on the trunk (`n_branches[1]`) or the most children of a
    /// level-(n−1) stem; `n_branches[0]` is not used (one trunk).
    pub n_branches: [u32; 4],
    /// `nDownAngle`: angle between a child and its parent in degrees.
    pub n_down_angle: [f64; 4],
    /// `nDownAngleV`: variation of `n_down_angle`; negative values vary it along the
    /// parent instead (children near the base lean out by `|nDownAngleV|` more).
    pub n_down_angle_v: [f64; 4],
    /// `nRotate`: rotation about the parent between successive children in degrees;
    /// negative values alternate the children on two sides (`±(180 + nRotate)`).
    pub n_rotate: [f64; 4],
    /// `nRotateV`: variation of `n_rotate`.
    pub n_rotate_v: [f64; 4],
    /// `Leaves`: leaves per last-level stem (scaled along the parent); negative values
    /// put `|Leaves|` leaves in a fan at each stem tip. Leaves take their down and
    /// rotate angles from level `min(levels, 3)`.
    pub leaves: i32,
    /// `LeafShape` 0–8: 0 ellipse, 1 ovate, 2 linear, 3 cordate, 4 maple, 5 palmate,
    /// 6 spiky oak, 7 rounded oak, 8 triangle.
    pub leaf_shape: u32,
    /// `LeafScale`: leaf length in metres.
    pub leaf_scale: f64,
    /// `LeafScaleX`: leaf width / leaf length.
    pub leaf_scale_x: f64,
    /// `LeafBend` 0–1: how far leaves turn to face outward and up.
    pub leaf_bend: f64,
    /// `LeafQuality` (Arbaro's extension, not in the paper's table), in (0, 1]: the
    /// leaf count is multiplied by it and the leaf size divided by its square root, so
    /// the foliage area stays the same with fewer, larger leaves.
    pub leaf_quality: f64,
    /// `AttractionUp`: bending of stems of level ≥ 2 toward the sky (negative: down).
    pub attraction_up: f64,
    /// `PruneRatio` 0–1: how much of the pruning is applied (0 = none).
    pub prune_ratio: f64,
    /// `PruneWidth`: envelope radius / tree height at its widest.
    pub prune_width: f64,
    /// `PruneWidthPeak` 0–1: height of the widest point above the crown base, as a
    /// fraction of the crown height.
    pub prune_width_peak: f64,
    /// `PrunePowerLow`: curvature of the envelope below its peak.
    pub prune_power_low: f64,
    /// `PrunePowerHigh`: curvature of the envelope above its peak.
    pub prune_power_high: f64,
}

impl Default for WeberPennParams {
    /// The paper's quaking aspen (as transcribed by Arbaro and Blender's Sapling).
    fn default() -> Self {
        WeberPennParams {
            shape: 7,
            base_size: 0.4,
            scale: 13.0,
            scale_v: 3.0,
            z_scale: 1.0,
            z_scale_v: 0.0,
            levels: 3,
            ratio: 0.015,
            ratio_power: 1.2,
            lobes: 5,
            lobe_depth: 0.07,
            flare: 0.6,
            base_splits: 0,
            n_scale: [1.0; 4],
            n_scale_v: [0.2, 0.0, 0.0, 0.0],
            n_length: [1.0, 0.3, 0.6, 0.0],
            n_length_v: [0.0; 4],
            n_taper: [1.0; 4],
            n_curve_res: [3, 5, 3, 1],
            n_curve: [0.0, -40.0, -40.0, 0.0],
            n_curve_v: [20.0, 50.0, 75.0, 0.0],
            n_curve_back: [0.0; 4],
            n_seg_splits: [0.0; 4],
            n_split_angle: [0.0; 4],
            n_split_angle_v: [0.0; 4],
            n_branches: [1, 50, 30, 10],
            n_down_angle: [0.0, 60.0, 45.0, 45.0],
            n_down_angle_v: [0.0, -50.0, 10.0, 10.0],
            n_rotate: [0.0, 140.0, 140.0, 77.0],
            n_rotate_v: [0.0; 4],
            leaves: 25,
            leaf_shape: 0,
            leaf_scale: 0.17,
            leaf_scale_x: 1.0,
            leaf_bend: 0.3,
            leaf_quality: 1.0,
            attraction_up: 0.5,
            prune_ratio: 0.0,
            prune_width: 0.5,
            prune_width_peak: 0.5,
            prune_power_low: 0.5,
            prune_power_high: 0.5,
        }
    }
}

impl WeberPennParams {
    /// Checks every value: finite numbers, ranges, and the budgets a tree can be refused
    /// on before it grows. Errors are [`Error::Recipe`] naming the key
    /// (`generator.n_branches[2]`).
    pub fn validate(&self) -> Result<()> {
        let bad = |key: &str, why: String| Err(Error::Recipe(format!("`generator.{key}` {why}")));
        let scalars = [
            ("base_size", self.base_size),
            ("scale", self.scale),
            ("scale_v", self.scale_v),
            ("z_scale", self.z_scale),
            ("z_scale_v", self.z_scale_v),
            ("ratio", self.ratio),
            ("ratio_power", self.ratio_power),
            ("lobe_depth", self.lobe_depth),
            ("flare", self.flare),
            ("leaf_scale", self.leaf_scale),
            ("leaf_scale_x", self.leaf_scale_x),
            ("leaf_bend", self.leaf_bend),
            ("leaf_quality", self.leaf_quality),
            ("attraction_up", self.attraction_up),
            ("prune_ratio", self.prune_ratio),
            ("prune_width", self.prune_width),
            ("prune_width_peak", self.prune_width_peak),
            ("prune_power_low", self.prune_power_low),
            ("prune_power_high", self.prune_power_high),
        ];
        for (k, v) in scalars {
            if !v.is_finite() {
                return bad(k, format!("must be a finite number, got {v}"));
            }
        }
        let arrays = [
            ("n_scale", &self.n_scale),
            ("n_scale_v", &self.n_scale_v),
            ("n_length", &self.n_length),
            ("n_length_v", &self.n_length_v),
            ("n_taper", &self.n_taper),
            ("n_curve", &self.n_curve),
            ("n_curve_v", &self.n_curve_v),
            ("n_curve_back", &self.n_curve_back),
            ("n_seg_splits", &self.n_seg_splits),
            ("n_split_angle", &self.n_split_angle),
            ("n_split_angle_v", &self.n_split_angle_v),
            ("n_down_angle", &self.n_down_angle),
            ("n_down_angle_v", &self.n_down_angle_v),
            ("n_rotate", &self.n_rotate),
            ("n_rotate_v", &self.n_rotate_v),
        ];
        for (k, a) in arrays {
            for (i, v) in a.iter().enumerate() {
                if !v.is_finite() {
                    return bad(&format!("{k}[{i}]"), format!("must be a finite number, got {v}"));
                }
            }
        }
        if self.shape > 8 {
            return bad("shape", format!("must be in 0..=8, got {}", self.shape));
        }
        if !(1..=4).contains(&self.levels) {
            return bad("levels", format!("must be in 1..=4, got {}", self.levels));
        }
        if self.leaf_shape > 8 {
            return bad("leaf_shape", format!("must be in 0..=8, got {}", self.leaf_shape));
        }
        if !(0.0..=1.0).contains(&self.base_size) {
            return bad("base_size", format!("must be in [0, 1], got {}", self.base_size));
        }
        if self.scale <= 0.0 || self.scale > 1e5 {
            return bad("scale", format!("must be in (0, 100000] metres, got {}", self.scale));
        }
        if self.scale_v < 0.0 || self.scale_v > self.scale {
            return bad("scale_v", format!("must be in [0, scale = {}], got {}", self.scale, self.scale_v));
        }
        if self.z_scale <= 0.0 || self.z_scale > 1e3 {
            return bad("z_scale", format!("must be in (0, 1000], got {}", self.z_scale));
        }
        if self.z_scale_v < 0.0 || self.z_scale_v >= self.z_scale {
            return bad(
                "z_scale_v",
                format!("must be in [0, z_scale = {}), got {}", self.z_scale, self.z_scale_v),
            );
        }
        for (k, v) in [
            ("ratio", self.ratio),
            ("lobe_depth", self.lobe_depth),
            ("leaf_scale", self.leaf_scale),
            ("leaf_scale_x", self.leaf_scale_x),
            ("prune_width", self.prune_width),
            ("prune_power_low", self.prune_power_low),
            ("prune_power_high", self.prune_power_high),
        ] {
            if v < 0.0 {
                return bad(k, format!("must be ≥ 0, got {v}"));
            }
        }
        for (k, v) in
            [("ratio", self.ratio), ("leaf_scale", self.leaf_scale), ("leaf_scale_x", self.leaf_scale_x)]
        {
            if v > 1e3 {
                return bad(k, format!("must be at most 1000, got {v}"));
            }
        }
        for l in 0..4 {
            if self.n_length[l] > 1e3 || self.n_scale[l] > 1e3 {
                let k = if self.n_length[l] > 1e3 { "n_length" } else { "n_scale" };
                return bad(&format!("{k}[{l}]"), "must be at most 1000".into());
            }
        }
        if !(self.leaf_quality > 0.0 && self.leaf_quality <= 1.0) {
            return bad("leaf_quality", format!("must be in (0, 1], got {}", self.leaf_quality));
        }
        if self.flare <= -1.0 {
            return bad("flare", format!("must be > -1, got {}", self.flare));
        }
        if self.lobes > 1000 {
            return bad("lobes", format!("must be at most 1000, got {}", self.lobes));
        }
        for (k, v) in [
            ("prune_ratio", self.prune_ratio),
            ("prune_width_peak", self.prune_width_peak),
            ("leaf_bend", self.leaf_bend),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(k, format!("must be in [0, 1], got {v}"));
            }
        }
        if self.leaves.unsigned_abs() > MAX_PER_STEM {
            return bad("leaves", format!("must be within ±{MAX_PER_STEM}, got {}", self.leaves));
        }
        if self.base_splits > 64 {
            return bad("base_splits", format!("must be at most 64, got {}", self.base_splits));
        }
        let levels = self.levels as usize;
        for l in 0..4 {
            let used = l < levels;
            if self.n_branches[l] > MAX_PER_STEM {
                return bad(
                    &format!("n_branches[{l}]"),
                    format!("must be at most {MAX_PER_STEM}, got {}", self.n_branches[l]),
                );
            }
            if !(0.0..=3.0).contains(&self.n_taper[l]) {
                return bad(&format!("n_taper[{l}]"), format!("must be in [0, 3], got {}", self.n_taper[l]));
            }
            for (k, v) in [
                ("n_length", self.n_length[l]),
                ("n_length_v", self.n_length_v[l]),
                ("n_scale", self.n_scale[l]),
                ("n_scale_v", self.n_scale_v[l]),
                ("n_seg_splits", self.n_seg_splits[l]),
            ] {
                if v < 0.0 {
                    return bad(&format!("{k}[{l}]"), format!("must be ≥ 0, got {v}"));
                }
            }
            if self.n_seg_splits[l] > 64.0 {
                return bad(
                    &format!("n_seg_splits[{l}]"),
                    format!("must be at most 64, got {}", self.n_seg_splits[l]),
                );
            }
            if self.n_curve_v[l] <= -90.0 {
                return bad(
                    &format!("n_curve_v[{l}]"),
                    format!("must be > -90 (a negative value is the helix angle), got {}", self.n_curve_v[l]),
                );
            }
            if used && !(1..=MAX_CURVE_RES).contains(&self.n_curve_res[l]) {
                return bad(
                    &format!("n_curve_res[{l}]"),
                    format!("must be in 1..={MAX_CURVE_RES}, got {}", self.n_curve_res[l]),
                );
            }
        }
        if self.n_scale_v[0] > self.n_scale[0] {
            return bad("n_scale_v[0]", format!("must be at most n_scale[0] = {}", self.n_scale[0]));
        }
        // Budgets, refused before growing. Clones of one stem: each segment end adds
        // nSegSplits clones per path on average.
        for l in 0..levels {
            let res = self.n_curve_res[l].max(1) as f64;
            let base = if l == 0 { 1.0 + self.base_splits as f64 } else { 1.0 };
            let clones = base * (1.0 + self.n_seg_splits[l]).powf(res - 1.0);
            if clones > MAX_STEMS as f64 {
                let key = if l == 0 && self.n_seg_splits[0] == 0.0 {
                    "base_splits".into()
                } else {
                    format!("n_seg_splits[{l}]")
                };
                return bad(
                    &key,
                    format!(
                        "would split one level-{l} stem into about {clones:.3e} clones (budget {MAX_STEMS} stems); \
                         lower it or n_curve_res[{l}]"
                    ),
                );
            }
        }
        // Stems: level 1 gets exactly n_branches[1]; a deeper stem at least 0.2 of its
        // level's n_branches (the paper's child count), so this lower bound is already too many.
        let mut at_least = 1.0f64;
        for l in 1..levels {
            at_least *= self.n_branches[l] as f64 * if l >= 2 { 0.2 } else { 1.0 };
            if at_least > MAX_STEMS as f64 {
                return bad(
                    &format!("n_branches[{l}]"),
                    format!(
                        "would grow at least {at_least:.3e} level-{l} stems (budget {MAX_STEMS}); lower the branch counts"
                    ),
                );
            }
        }
        let leaves_at_least = at_least * self.leaves.unsigned_abs() as f64 * 0.5 * self.leaf_quality;
        if leaves_at_least > MAX_LEAVES as f64 {
            return bad(
                "leaves",
                format!("would place at least {leaves_at_least:.3e} leaves (budget {MAX_LEAVES}); lower it or n_branches"),
            );
        }
        Ok(())
    }

    /// Index of the parameters leaves use (the level after the last stem level).
    pub(super) fn leaf_level(&self) -> usize {
        (self.levels as usize).min(3)
    }
}
