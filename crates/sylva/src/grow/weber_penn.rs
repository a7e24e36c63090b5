//! Weber–Penn parametric trees: Weber & Penn 1995, "Creation and Rendering of Realistic
//! Trees" (SIGGRAPH '95, pp. 119–128), issue 6 item 1. Skjermo2008 §B (the GPU branch
//! deformer) consumes the per-stem cubic Bézier curves and taper/flare/lobe parameters
//! this module records.
//!
//! # The model
//!
//! A tree is a recursion of *stems* over `levels` (0 = trunk). Each stem is `nCurveRes`
//! straight segments whose directions turn by `nCurve` (or `nCurve` then `nCurveBack`),
//! with random variation `nCurveV` (a helix when `nCurveV < 0`). At each segment end a
//! stem may *split* (`nSegSplits`, `BaseSplits` for the trunk's first segment) into
//! clones that share its length, radius and taper. Child stems of the next level grow
//! along it (`nBranches`, spaced evenly), turned about the parent by `nRotate` and away
//! from it by `nDownAngle`; their length follows the tree's `Shape` envelope (level 1)
//! or the parent's remaining length (level ≥ 2); their radius follows `Ratio` and
//! `RatioPower`. The last level bears `Leaves`. Optional pruning shortens stems that
//! leave an envelope; `AttractionUp` bends stems of level ≥ 2 toward (or away from) the
//! sky. Comments name the paper's formula each step implements (as Arbaro and Blender's
//! Sapling transcribe them) and say where sylva reads it differently.
//!
//! # Conventions (see `docs/weber-penn.md`)
//!
//! - The paper works with +Z up; the geometry is computed that way in `f64` and written
//!   to the [`Skeleton`] with +Y up: paper `(x, y, z)` → sylva `(x, z·ZScale, −y)`.
//!   `Scale` is in metres, so every length is in metres.
//! - Every stem is one axis of skeleton nodes, `order` = its level. The trunk starts at
//!   a root node at the origin; every other stem starts at a node *on its parent's
//!   axis*, inserted there at the child's offset, so a child's base lies exactly on the
//!   parent's axis; a child within two parent radii of a node already on the axis (a
//!   segment end, or another child's base) hangs on that node and starts there, so no
//!   internode is shorter than the radii around it. Split clones start at the parent
//!   path's segment-end node.
//! - Nodes are written at every segment end, plus extra stations where the radius
//!   profile needs them (the trunk flare, spherical ends, periodic taper) and eight per
//!   helix turn.
//! - Every random number comes from `rand_pcg::Pcg64`: one tree generator seeded by the
//!   seed draws per-stem seeds, and each stem re-seeds its own generator, so pruning can
//!   rebuild a stem identically at a shorter length.
//!
//! Cost: O(nodes + leaves), budgets [`MAX_STEMS`], [`MAX_LEAVES`] and [`MAX_NODES`] are
//! checked before and while growing.

use crate::error::{Error, Result};
use crate::model::{BranchCurve, BranchCurves, CurveSegment};
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DQuat, DVec3, Vec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};
use std::ops::Range;
use std::time::{Duration, Instant};

/// Most stems (clones included) a tree may have.
pub const MAX_STEMS: usize = 2_000_000;
/// Most leaves a tree may have.
pub const MAX_LEAVES: usize = 2_000_000;
/// Most skeleton nodes a tree may have.
pub const MAX_NODES: usize = 4_000_000;
/// Largest `n_curve_res` accepted.
pub const MAX_CURVE_RES: u32 = 1000;
/// Largest `n_branches` (per stem) and `|leaves|` accepted.
pub const MAX_PER_STEM: u32 = 1_000_000;
/// Nodes per helix turn (one turn per segment when `n_curve_v < 0`).
const HELIX_STEPS: usize = 8;
/// A child whose offset falls within this many parent radii (at the offset) of a node
/// on the parent's axis hangs on that node instead of a new one: an internode shorter
/// than the radii on both sides lies inside the joint, and the joint meshers fold there.
const SNAP_RADII: f64 = 2.0;
/// Most radius-profile stations on one stem (periodic taper).
const MAX_STATIONS: usize = 4096;

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

/// One stem (or one split clone of a stem) as the paper defines it, with its curve and
/// the shape parameters a parametric branch mesher (Skjermo2008 §B) needs.
///
/// A split stem is recorded as several `Stem`s: the original (`clone_of == None`), which
/// runs from the stem's base to its tip, and one per clone, which runs from its split
/// point (`start`) to its own tip. All of them share `length`, the radii and the taper,
/// so the radius anywhere is [`Stem::radius_at`] of the distance from the stem's base.
#[derive(Debug, Clone, PartialEq)]
pub struct Stem {
    /// Level: 0 trunk, 1 its children, …
    pub level: u8,
    /// The stem record whose axis this one starts on: the parent stem for a child, the
    /// record it split from for a clone; `None` for the trunk.
    pub parent_stem: Option<u32>,
    /// For a clone: the record of the original stem it belongs to.
    pub clone_of: Option<u32>,
    /// Where the stem grows out of its parent, as a distance along the parent (metres).
    pub offset: f32,
    /// Where this record's curve starts, as a distance from the stem's base (0 for an
    /// original, the split point for a clone).
    pub start: f32,
    /// Length of the stem from base to tip (metres; after pruning).
    pub length: f32,
    /// The centreline as cubic Bézier segments (one per segment, eight per helix turn).
    pub curve: Vec<BezierSegment>,
    /// Radius at the base before flare (metres).
    pub radius_base: f32,
    /// Radius at the tip (metres).
    pub radius_tip: f32,
    /// `nTaper` of the stem's level.
    pub taper: f32,
    /// `Flare` (trunk only, 0 elsewhere).
    pub flare: f32,
    /// `Lobes` (trunk only, 0 elsewhere); the cross-section radius is multiplied by
    /// `1 + lobe_depth · sin(lobes · θ)`. The tube mesher ignores it for now.
    pub lobes: u32,
    /// `LobeDepth` (trunk only, 0 elsewhere).
    pub lobe_depth: f32,
    /// The skeleton nodes of this record's axis (its base node is the parent's node
    /// for every record but the trunk's).
    pub nodes: Range<u32>,
}

impl Stem {
    /// The radius at distance `dist` from the stem's base (taper and flare, no lobes),
    /// in metres; the skeleton's node radii are this function.
    pub fn radius_at(&self, dist: f64) -> f64 {
        let len = self.length as f64;
        let z = if len > 0.0 { (dist / len).clamp(0.0, 1.0) } else { 0.0 };
        taper_radius(self.taper as f64, self.radius_base as f64, len, z) * flare_factor(self.flare as f64, z)
    }
}

/// What [`grow`] built.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WeberPennReport {
    /// Stems per level (originals; clones are counted in `clones_per_level`).
    pub stems_per_level: [usize; 4],
    /// Split clones per level.
    pub clones_per_level: [usize; 4],
    /// Leaves placed.
    pub leaves: usize,
    /// Skeleton nodes.
    pub nodes: usize,
    /// The tree's scale after `ScaleV` (`scale_tree`, metres): the pruning envelope's height.
    pub scale_tree: f64,
    /// Time spent growing.
    pub elapsed: Duration,
}

/// A grown Weber–Penn tree.
#[derive(Debug, Clone)]
pub struct WeberPennTree {
    /// The skeleton, with leaves as [`OrganKind::Polygon`] organs.
    pub skeleton: Skeleton,
    /// Every stem record in creation order (parents before children, originals before
    /// their clones).
    pub stems: Vec<Stem>,
    /// What was built.
    pub report: WeberPennReport,
}

/// The tree's stems as the model's branch curves: each stem record's own Bézier chain,
/// with radii from [`Stem::radius_at`] at the knots (distance along the stem measured by
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
fn flare_factor(flare: f64, z: f64) -> f64 {
    if flare == 0.0 {
        return 1.0;
    }
    let y = (1.0 - 8.0 * z).max(0.0);
    1.0 + flare * (100f64.powf(y) - 1.0) / 100.0
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
    fn leaf_level(&self) -> usize {
        (self.levels as usize).min(3)
    }
}

/// Grows the tree of `params` with `seed`. Deterministic: the same parameters and seed
/// give the same tree, bit for bit.
///
/// Errors: [`Error::Recipe`] for invalid parameters or a tree over the budgets
/// ([`MAX_STEMS`], [`MAX_LEAVES`], [`MAX_NODES`]), naming the key to lower.
pub fn grow(params: &WeberPennParams, seed: u64) -> Result<WeberPennTree> {
    let t0 = Instant::now();
    params.validate()?;
    let mut rng = Pcg64::seed_from_u64(seed);
    let scale_tree = params.scale + var(&mut rng, params.scale_v);
    let z_scale = params.z_scale + var(&mut rng, params.z_scale_v);
    // The paper: length_trunk = (0Length ± 0LengthV)·scale_tree; radius = length·Ratio·(0Scale ± 0ScaleV).
    let trunk_length = ((params.n_length[0] + var(&mut rng, params.n_length_v[0])) * scale_tree).max(0.0);
    let trunk_radius =
        trunk_length * params.ratio * (params.n_scale[0] + var(&mut rng, params.n_scale_v[0])).max(0.0);
    let mut g = Grower {
        p: params,
        levels: params.levels as usize,
        scale_tree,
        z_scale,
        min_len: 1e-5 * scale_tree.max(1e-9),
        skeleton: Skeleton::new(),
        stems: Vec::new(),
        report: WeberPennReport { scale_tree, ..Default::default() },
        split_err: [0.0; 4],
        child_err: [0.0; 4],
        leaf_err: 0.0,
        outline: leaf_outline(params.leaf_shape),
    };
    let trunk = Task {
        level: 0,
        parent_stem: None,
        base_node: NO_PARENT,
        origin: DVec3::ZERO,
        frame: Frame::IDENTITY,
        offset: 0.0,
        length: trunk_length,
        // The trunk's radius is given: r = r0·(L/L)^p, limited to r0.
        parent_length: trunk_length,
        parent_radius: trunk_radius,
        radius_limit: trunk_radius,
        length_max: params.n_length[0],
        build_seed: rng.random::<u64>(),
        place_seed: rng.random::<u64>(),
    };
    let mut stack = vec![trunk];
    let mut paths = Vec::new();
    while let Some(task) = stack.pop() {
        g.process(task, &mut stack, &mut paths)?;
    }
    // Everything above is finite by construction; this is the last line of defence
    // against a NaN reaching a file.
    g.skeleton.validate()?;
    g.report.nodes = g.skeleton.len();
    g.report.leaves = g.skeleton.organs.len();
    g.report.elapsed = t0.elapsed();
    Ok(WeberPennTree { skeleton: g.skeleton, stems: g.stems, report: g.report })
}

/// A uniform random number in \[−x, x\] (the paper's `±`).
fn var(rng: &mut Pcg64, x: f64) -> f64 {
    x * (2.0 * rng.random::<f64>() - 1.0)
}

/// Error-diffused rounding (Floyd–Steinberg style, as Arbaro does for fractional counts).
fn diffuse(err: &mut f64, x: f64) -> usize {
    let n = (x + *err + 0.5).floor().max(0.0);
    *err -= n - x;
    n as usize
}

/// An orthonormal frame in the paper's coordinates: `z` is the heading, `x × y = z`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Frame {
    x: DVec3,
    y: DVec3,
    z: DVec3,
}

impl Frame {
    const IDENTITY: Frame = Frame { x: DVec3::X, y: DVec3::Y, z: DVec3::Z };

    /// Rotates the frame about a world axis by `deg` degrees (right-handed).
    fn rot_world(self, axis: DVec3, deg: f64) -> Frame {
        if deg == 0.0 {
            return self;
        }
        let q = DQuat::from_axis_angle(axis, deg.to_radians());
        Frame { x: q * self.x, y: q * self.y, z: q * self.z }
    }

    /// About the local x axis: positive angles turn `z` toward `−y` (down for a child).
    fn rot_x(self, deg: f64) -> Frame {
        self.rot_world(self.x, deg)
    }

    fn rot_y(self, deg: f64) -> Frame {
        self.rot_world(self.y, deg)
    }

    fn rot_z(self, deg: f64) -> Frame {
        self.rot_world(self.z, deg)
    }

    /// Re-orthonormalizes against rounding drift.
    fn orthonormalized(self) -> Frame {
        let z = self.z.normalize_or(DVec3::Z);
        let x = (self.x - z * self.x.dot(z)).normalize_or(z.any_orthonormal_vector());
        Frame { x, y: z.cross(x), z }
    }
}

/// A stem waiting to be grown.
#[derive(Debug, Clone)]
struct Task {
    level: usize,
    parent_stem: Option<u32>,
    base_node: u32,
    origin: DVec3,
    frame: Frame,
    /// Offset along the parent.
    offset: f64,
    /// Length before pruning.
    length: f64,
    parent_length: f64,
    /// The parent's base radius (RatioPower's reference).
    parent_radius: f64,
    /// The parent's radius at the offset (the child radius limit).
    radius_limit: f64,
    /// `length_child_max` this stem's length was computed with (the children count uses it).
    length_max: f64,
    build_seed: u64,
    place_seed: u64,
}

/// A point of a path after its start.
#[derive(Debug, Clone, Copy)]
struct Pt {
    pos: DVec3,
    dist: f64,
    /// Global segment index.
    seg: u32,
    /// A segment end (or a helix step): a Bézier knot.
    knot: bool,
}

/// One centreline of a stem: the original or a clone.
#[derive(Debug, Clone, Default)]
struct Path {
    /// (path, point index) of the split point; `None` for the original.
    parent: Option<(usize, usize)>,
    start_pos: DVec3,
    start_dist: f64,
    first_seg: usize,
    /// Frame and start position of each segment from `first_seg`.
    frames: Vec<Frame>,
    seg_start: Vec<DVec3>,
    pts: Vec<Pt>,
}

/// A path waiting to grow its next segments.
struct Work {
    path: usize,
    seg: usize,
    frame: Frame,
    pos: DVec3,
    correction: f64,
}

/// Something placed on a stem at a distance: a child's base or a leaf.
#[derive(Debug, Clone, Copy)]
struct Placement {
    path: usize,
    dist: f64,
    pos: DVec3,
    /// The segment frame there.
    seg_frame: Frame,
}

struct Grower<'a> {
    p: &'a WeberPennParams,
    levels: usize,
    scale_tree: f64,
    z_scale: f64,
    min_len: f64,
    skeleton: Skeleton,
    stems: Vec<Stem>,
    report: WeberPennReport,
    split_err: [f64; 4],
    child_err: [f64; 4],
    leaf_err: f64,
    outline: LeafOutline,
}

impl Grower<'_> {
    fn res(&self, level: usize) -> usize {
        self.p.n_curve_res[level].max(1) as usize
    }

    /// paper (x, y, z) → sylva (x, z·ZScale, −y).
    fn to_world(&self, p: DVec3) -> Vec3 {
        Vec3::new(p.x as f32, (p.z * self.z_scale) as f32, (-p.y) as f32)
    }

    /// A direction (tangent) under the same map, normalized.
    fn dir_to_world(&self, d: DVec3) -> Vec3 {
        DVec3::new(d.x, d.z * self.z_scale, -d.y).normalize_or(DVec3::Y).as_vec3()
    }

    /// A normal: the inverse transpose keeps it perpendicular to mapped tangents.
    fn normal_to_world(&self, n: DVec3) -> Vec3 {
        DVec3::new(n.x, n.z / self.z_scale, -n.y).normalize_or(DVec3::X).as_vec3()
    }

    /// The pruning envelope test (the paper's pruning): inside when
    /// `r / scale_tree < PruneWidth · ShapeRatio(8, (scale_tree − z) / (scale_tree·(1 − BaseSize)))`.
    fn inside_envelope(&self, p: DVec3) -> bool {
        let r = (p.x * p.x + p.y * p.y).sqrt();
        let ratio = (self.scale_tree - p.z) / (self.scale_tree * (1.0 - self.p.base_size));
        r / self.scale_tree < self.p.prune_width * shape_ratio(8, ratio, self.p)
    }

    /// The stem's base radius after pruning: the paper's Ratio, RatioPower and the parent limit.
    fn stem_radius(&self, task: &Task, length: f64) -> f64 {
        if task.level == 0 {
            return task.radius_limit;
        }
        let r = task.parent_radius * (length / task.parent_length).powf(self.p.ratio_power);
        if r.is_finite() {
            r.min(task.radius_limit).max(0.0)
        } else {
            task.radius_limit.max(0.0)
        }
    }

    /// Distances along a stem where the radius profile needs a node between segment
    /// ends: the flare zone, a spherical end, periodic bulges.
    fn stations(&self, level: usize, length: f64, radius: f64) -> Vec<f64> {
        let mut st = Vec::new();
        if length <= 0.0 {
            return st;
        }
        if level == 0 && self.p.flare != 0.0 {
            st.extend([1.0 / 32.0, 1.0 / 16.0, 3.0 / 32.0, 1.0 / 8.0].map(|f| f * length));
        }
        let taper = self.p.n_taper[level];
        if taper > 1.0 && radius > 0.0 {
            let unit = if taper <= 2.0 { 2.0 - taper } else { 0.0 };
            let r_end = radius * (1.0 - unit);
            if taper <= 2.0 || r_end * 2.0 >= length {
                // A spherical end of radius ≈ r_end.
                for k in 1..=6 {
                    st.push(length - r_end * (1.0 - (k as f64 * PI / 12.0).cos()));
                }
                st.push(length - r_end);
            } else {
                // Periodic bulges of period 2r, measured from the tip.
                let step = (r_end / 4.0).max(length / MAX_STATIONS as f64);
                let mut d = step;
                while d < length && st.len() < MAX_STATIONS + 8 {
                    st.push(length - d);
                    d += step;
                }
            }
        }
        st.retain(|d| *d > 0.0 && *d < length);
        st.sort_by(f64::total_cmp);
        st.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * length);
        st
    }

    /// Curving of segment `s` (the paper's curvature): `nCurve/nCurveRes` (or `2·nCurve`, `2·nCurveBack`
    /// per half), plus the split correction, plus a random turn of `nCurveV/nCurveRes`
    /// about a random axis across the stem, plus vertical attraction for levels ≥ 2.
    fn new_direction(&self, f: Frame, s: usize, correction: f64, level: usize, rng: &mut Pcg64) -> Frame {
        let res = self.res(level);
        let resf = res as f64;
        let curve = self.p.n_curve[level];
        let back = self.p.n_curve_back[level];
        let curve_v = self.p.n_curve_v[level];
        // Always draw, so the stream does not depend on the branch taken.
        let dv = var(rng, curve_v.max(0.0)) / resf;
        let rho = (180.0 + var(rng, 180.0)).to_radians();
        if s == 0 {
            return f;
        }
        let mut delta = if back == 0.0 {
            curve / resf
        } else if s < res.div_ceil(2) {
            curve * 2.0 / resf
        } else {
            back * 2.0 / resf
        };
        delta += correction;
        let mut f = f.rot_x(delta);
        if curve_v > 0.0 {
            let axis = (f.x * rho.cos() + f.y * rho.sin()).normalize_or(f.x);
            f = f.rot_world(axis, dv);
        }
        if self.p.attraction_up != 0.0 && level >= 2 {
            // Vertical attraction: curve_up = AttractionUp · declination / nCurveRes, applied in the
            // vertical plane of the heading (the paper's cos(orientation) factor
            // depends on the frame's arbitrary roll; Arbaro drops it too) and never
            // turning past the vertical.
            let decl = f.z.z.clamp(-1.0, 1.0).acos();
            let mut a = self.p.attraction_up * decl / resf;
            a = if a > 0.0 { a.min(decl) } else { a.max(-(PI - decl)) };
            let axis = f.z.cross(DVec3::Z);
            if axis.length_squared() > 1e-18 {
                f = f.rot_world(axis.normalize(), a.to_degrees());
            }
        }
        f.orthonormalized()
    }

    /// The split of one path at the end of segment `s` (the paper's stem splitting): every clone and the
    /// original turn by `max(0, nSplitAngle ± V − declination)` about their x axis, and
    /// the remaining segments turn back by the same total (the split correction);
    /// clones then spread about the vertical: evenly for the trunk's base splits, by
    /// `±(20 + 0.75·(30 + |declination − 90|)·r²)` otherwise.
    #[allow(clippy::too_many_arguments)]
    fn split(
        &self,
        f: Frame,
        s_angle: f64,
        s: usize,
        level: usize,
        base_split: bool,
        correction: &mut f64,
        rng: &mut Pcg64,
    ) -> Frame {
        let remaining = (self.res(level) - s - 1).max(1) as f64;
        let decl = f.z.z.clamp(-1.0, 1.0).acos().to_degrees();
        let angle = (self.p.n_split_angle[level] + var(rng, self.p.n_split_angle_v[level]) - decl).max(0.0);
        let mut f = f.rot_x(angle);
        *correction -= angle / remaining;
        let r = (var(rng, 1.0) + 1.0) / 2.0;
        let side = var(rng, 1.0);
        let spread = var(rng, self.p.n_split_angle_v[level]);
        if s_angle > 0.0 {
            let diverge = if base_split {
                s_angle + spread
            } else {
                let d = 20.0 + 0.75 * (30.0 + (decl - 90.0).abs()) * r * r;
                if side >= 0.0 {
                    -d
                } else {
                    d
                }
            };
            f = f.rot_world(DVec3::Z, diverge);
        }
        f.orthonormalized()
    }

    /// A point of segment `s` (start `start`, frame `f`) at fraction `t`: straight, or
    /// on one helix turn of radius `helix` about the segment.
    fn seg_point(start: DVec3, f: &Frame, seg_len: f64, helix: f64, t: f64) -> DVec3 {
        let mut p = start + f.z * (t * seg_len);
        if helix > 0.0 {
            let a = TAU * t;
            p += (f.x * (a.cos() - 1.0) + f.y * a.sin()) * helix;
        }
        p
    }

    /// Builds the paths (original and clones) of one stem at `length`. With `prune`,
    /// returns the first segment whose points leave the envelope (Arbaro's reading of
    /// the paper's pruning: the test stops there).
    fn build(
        &self,
        task: &Task,
        length: f64,
        prune: bool,
        split_err: &mut f64,
        paths: &mut Vec<Path>,
    ) -> Result<Option<usize>> {
        let level = task.level;
        let res = self.res(level);
        let seg_len = length / res as f64;
        let curve_v = self.p.n_curve_v[level];
        // One helix turn per segment, its tangent leaning |nCurveV| from the axis.
        let helix = if curve_v < 0.0 { (-curve_v).to_radians().tan() * seg_len / TAU } else { 0.0 };
        let radius = self.stem_radius(task, length);
        let stations = self.stations(level, length, radius);
        let nss = self.p.n_seg_splits[level];
        let mut rng = Pcg64::seed_from_u64(task.build_seed);
        paths.clear();
        paths.push(Path { start_pos: task.origin, ..Default::default() });
        let mut work = vec![Work { path: 0, seg: 0, frame: task.frame, pos: task.origin, correction: 0.0 }];
        let mut points = 0usize;
        let mut fractions: Vec<f64> = Vec::new();
        while let Some(w) = work.pop() {
            let Work { path, seg: mut s, mut frame, mut pos, mut correction } = w;
            loop {
                frame = self.new_direction(frame, s, correction, level, &mut rng);
                let s0 = s as f64 * seg_len;
                fractions.clear();
                let lo = stations.partition_point(|d| *d <= s0);
                let hi = stations.partition_point(|d| *d < s0 + seg_len);
                fractions.extend(stations[lo..hi].iter().map(|d| (d - s0) / seg_len));
                if helix > 0.0 {
                    fractions.extend((1..HELIX_STEPS).map(|k| k as f64 / HELIX_STEPS as f64));
                    fractions.sort_by(f64::total_cmp);
                }
                let first_new = paths[path].pts.len();
                {
                    let pa = &mut paths[path];
                    pa.frames.push(frame);
                    pa.seg_start.push(pos);
                    for &t in &fractions {
                        if t <= 1e-6 || t >= 1.0 - 1e-6 {
                            continue;
                        }
                        let knot = helix > 0.0
                            && ((t * HELIX_STEPS as f64).round() - t * HELIX_STEPS as f64).abs() < 1e-9;
                        pa.pts.push(Pt {
                            pos: Self::seg_point(pos, &frame, seg_len, helix, t),
                            dist: s0 + t * seg_len,
                            seg: s as u32,
                            knot,
                        });
                    }
                    let end = Self::seg_point(pos, &frame, seg_len, helix, 1.0);
                    pa.pts.push(Pt { pos: end, dist: s0 + seg_len, seg: s as u32, knot: true });
                    points += pa.pts.len() - first_new;
                }
                if points > MAX_NODES {
                    return Err(Error::Recipe(format!(
                        "`generator.n_curve_res[{level}]`: one level-{level} stem needs more than {MAX_NODES} \
                         skeleton nodes; lower n_curve_res, n_seg_splits or the tapers that add nodes"
                    )));
                }
                if prune && paths[path].pts[first_new..].iter().any(|pt| !self.inside_envelope(pt.pos)) {
                    return Ok(Some(s));
                }
                let end = paths[path].pts.last().map(|p| p.pos).unwrap_or(pos);
                if s + 1 >= res {
                    break;
                }
                let base_split = level == 0 && s == 0 && self.p.base_splits > 0;
                let k = if base_split { self.p.base_splits as usize } else { diffuse(split_err, nss) };
                if k == 0 {
                    pos = end;
                    s += 1;
                    continue;
                }
                if paths.len() + k > MAX_STEMS {
                    let key =
                        if base_split { "base_splits".into() } else { format!("n_seg_splits[{level}]") };
                    return Err(Error::Recipe(format!(
                        "`generator.{key}`: one level-{level} stem splits into more than {MAX_STEMS} clones; lower it"
                    )));
                }
                let s_angle = 360.0 / (k + 1) as f64;
                let split_pt = paths[path].pts.len() - 1;
                let mut clones = Vec::with_capacity(k);
                for i in 1..=k {
                    let mut c = correction;
                    let cf = self.split(frame, s_angle * i as f64, s, level, base_split, &mut c, &mut rng);
                    paths.push(Path {
                        parent: Some((path, split_pt)),
                        start_pos: end,
                        start_dist: s0 + seg_len,
                        first_seg: s + 1,
                        ..Default::default()
                    });
                    clones.push(Work {
                        path: paths.len() - 1,
                        seg: s + 1,
                        frame: cf,
                        pos: end,
                        correction: c,
                    });
                }
                frame = self.split(frame, 0.0, s, level, base_split, &mut correction, &mut rng);
                work.push(Work { path, seg: s + 1, frame, pos: end, correction });
                work.extend(clones.into_iter().rev());
                break;
            }
        }
        Ok(None)
    }

    /// Grows one stem: pruning, the final build, its children and leaves, and its nodes.
    fn process(&mut self, task: Task, stack: &mut Vec<Task>, paths: &mut Vec<Path>) -> Result<()> {
        let level = task.level;
        let res = self.res(level);
        let mut length = task.length;
        if length <= self.min_len {
            return Ok(());
        }
        // Pruning: rebuild the same stem (same random numbers) shorter until every
        // point is inside the envelope, then blend with the original by PruneRatio.
        if level >= 1 && self.p.prune_ratio > 0.0 {
            let orig = length;
            let mut len = length;
            loop {
                let mut e = self.split_err[level];
                match self.build(&task, len, true, &mut e, paths)? {
                    None => break,
                    Some(seg) => {
                        let seg_len = len / res as f64;
                        let next = (seg_len * seg as f64).max(len / 2.0).min(len - orig / 15.0);
                        if next <= self.min_len {
                            len = 0.0;
                            break;
                        }
                        len = next;
                    }
                }
            }
            length = orig - (orig - len) * self.p.prune_ratio;
            if length <= self.min_len {
                return Ok(());
            }
        }
        let mut err = self.split_err[level];
        self.build(&task, length, false, &mut err, paths)?;
        self.split_err[level] = err;
        let radius = self.stem_radius(&task, length);
        let seg_len = length / res as f64;
        let helix = {
            let cv = self.p.n_curve_v[level];
            if cv < 0.0 {
                (-cv).to_radians().tan() * seg_len / TAU
            } else {
                0.0
            }
        };
        let flare = if level == 0 { self.p.flare } else { 0.0 };
        let taper = self.p.n_taper[level];
        let radius_at = |d: f64| {
            let z = if length > 0.0 { d / length } else { 0.0 };
            taper_radius(taper, radius, length, z) * flare_factor(flare, z)
        };

        // Segment instances: the paths that cover each segment index.
        let mut instances: Vec<Vec<usize>> = vec![Vec::new(); res];
        for (pi, pa) in paths.iter().enumerate() {
            for (s, inst) in instances.iter_mut().enumerate().skip(pa.first_seg) {
                if s < pa.first_seg + pa.frames.len() {
                    inst.push(pi);
                }
            }
        }
        let mut rr = vec![0usize; res];
        let place = |t: f64, rr: &mut Vec<usize>| -> Placement {
            let s = ((t / seg_len).floor().max(0.0) as usize).min(res - 1);
            let inst = &instances[s];
            let path = inst[rr[s] % inst.len()];
            rr[s] += 1;
            let pa = &paths[path];
            let i = s - pa.first_seg;
            let f = pa.frames[i];
            let frac = ((t - s as f64 * seg_len) / seg_len).clamp(0.0, 1.0);
            Placement {
                path,
                dist: t,
                pos: Self::seg_point(pa.seg_start[i], &f, seg_len, helix, frac),
                seg_frame: f,
            }
        };
        let mut prng = Pcg64::seed_from_u64(task.place_seed);
        let start = if level == 0 { self.p.base_size * length } else { task.radius_limit.min(0.5 * length) };
        let span = (length - start).max(0.0);

        // Children: the paper's count, spacing, rotation, down angle, length and radius.
        let mut children: Vec<(Placement, Task)> = Vec::new();
        if level + 1 < self.levels {
            let cl = level + 1;
            let lcm = (self.p.n_length[cl] + var(&mut prng, self.p.n_length_v[cl])).max(0.0);
            let stems_max = self.p.n_branches[cl] as f64;
            let n = if level == 0 {
                stems_max
            } else if task.length_max > 0.0 && task.parent_length > 0.0 {
                stems_max * (0.2 + 0.8 * (length / task.parent_length) / task.length_max)
            } else {
                0.2 * stems_max
            };
            let count = diffuse(&mut self.child_err[cl], n);
            let base_len = self.p.base_size * self.scale_tree;
            let mut rot = RotateState::default();
            for k in 0..count {
                let t = start + (k as f64 + 0.5) * span / count as f64;
                let pl = place(t, &mut rr);
                let angle = rot.next(self.p.n_rotate[cl], self.p.n_rotate_v[cl], &mut prng);
                let down = self.down_angle(cl, level, length, t, &mut prng);
                let child_len = if cl == 1 {
                    let denom = length - base_len;
                    let ratio = if denom > 0.0 { ((length - t) / denom).clamp(0.0, 1.0) } else { 0.0 };
                    length * lcm * shape_ratio(self.p.shape, ratio, self.p)
                } else {
                    lcm * (length - 0.6 * t)
                }
                .max(0.0);
                let build_seed = prng.random::<u64>();
                let place_seed = prng.random::<u64>();
                if child_len <= self.min_len {
                    continue;
                }
                let frame = pl.seg_frame.rot_z(angle).rot_x(down).orthonormalized();
                children.push((
                    pl,
                    Task {
                        level: cl,
                        parent_stem: None,
                        base_node: NO_PARENT,
                        origin: pl.pos,
                        frame,
                        offset: t,
                        length: child_len,
                        parent_length: length,
                        parent_radius: radius,
                        radius_limit: radius_at(t),
                        length_max: lcm,
                        build_seed,
                        place_seed,
                    },
                ));
            }
        }

        // Leaves on the last level (the paper's Leaves, placed like children).
        let mut leaves: Vec<(Placement, Frame)> = Vec::new();
        if level + 1 == self.levels && self.p.leaves != 0 {
            let ll = self.p.leaf_level();
            let per = self.p.leaves.unsigned_abs() as f64
                * self.p.leaf_quality
                * if level == 0 || task.parent_length <= 0.0 {
                    1.0
                } else {
                    shape_ratio(4, (task.offset / task.parent_length).clamp(0.0, 1.0), self.p)
                };
            if self.p.leaves > 0 {
                let count = diffuse(&mut self.leaf_err, per);
                self.leaf_budget(count)?;
                let mut rot = RotateState::default();
                for k in 0..count {
                    let t = start + (k as f64 + 0.5) * span / count as f64;
                    let pl = place(t, &mut rr);
                    let angle = rot.next(self.p.n_rotate[ll], self.p.n_rotate_v[ll], &mut prng);
                    let down = self.down_angle(ll, level, length, t, &mut prng);
                    leaves.push((pl, pl.seg_frame.rot_z(angle).rot_x(down)));
                }
            } else {
                // A fan at every tip (each path's last segment end).
                let cnt = (per + 0.5).floor() as usize;
                self.leaf_budget(cnt.saturating_mul(paths.len()))?;
                let dist_angle = if cnt > 0 { self.p.n_rotate[ll] / cnt as f64 } else { 0.0 };
                let var_angle = if cnt > 0 { self.p.n_rotate_v[ll] / cnt as f64 } else { 0.0 };
                for (pi, pa) in paths.iter().enumerate() {
                    let (Some(f), Some(tip)) = (pa.frames.last(), pa.pts.last()) else { continue };
                    let pl = Placement { path: pi, dist: length, pos: tip.pos, seg_frame: *f };
                    let offset_angle = if cnt % 2 == 1 {
                        leaves.push((pl, *f));
                        dist_angle
                    } else {
                        dist_angle / 2.0
                    };
                    for s in 0..cnt / 2 {
                        for side in [1.0, -1.0] {
                            let a = side * (offset_angle + s as f64 * dist_angle + var(&mut prng, var_angle));
                            let down = self.p.n_down_angle[ll] + var(&mut prng, self.p.n_down_angle_v[ll]);
                            leaves.push((pl, f.rot_y(a).rot_x(down)));
                        }
                    }
                }
            }
        }

        // Nodes: every path's points merged with the child bases on it.
        let stem_records = self.stems.len() as u32;
        if self.stems.len() + paths.len() > MAX_STEMS {
            return Err(Error::Recipe(format!(
                "`generator.n_branches[{level}]`: the tree would have more than {MAX_STEMS} stems; lower the \
                 branch counts or n_seg_splits"
            )));
        }
        let total_pts: usize = paths.iter().map(|p| p.pts.len()).sum::<usize>() + children.len() + 1;
        if self.skeleton.len() + total_pts > MAX_NODES {
            return Err(Error::Recipe(format!(
                "`generator.n_branches[{level}]`: the tree would have more than {MAX_NODES} skeleton nodes; lower \
                 the branch counts or n_curve_res"
            )));
        }
        let mut by_path: Vec<Vec<usize>> = vec![Vec::new(); paths.len()];
        for (ci, (pl, _)) in children.iter().enumerate() {
            by_path[pl.path].push(ci);
        }
        let mut child_node = vec![NO_PARENT; children.len()];
        // Where each child's base ends up: a child within `snap` of a node on its path
        // hangs on that node and starts there (no stub internodes, which lie inside the
        // joint and fold the meshers' tubes).
        let mut child_origin: Vec<Option<(DVec3, f64)>> = vec![None; children.len()];
        let snap = |d: f64| SNAP_RADII * radius_at(d);
        // Per path: (distance, node) of every node on it, base included.
        let mut path_nodes: Vec<Vec<(f64, u32)>> = Vec::with_capacity(paths.len());
        let mut point_node: Vec<Vec<u32>> = Vec::with_capacity(paths.len());
        let eps = 1e-9 * length.max(1e-12);
        for (pi, pa) in paths.iter().enumerate() {
            let first = self.skeleton.len() as u32;
            let base = match pa.parent {
                None if level == 0 => {
                    let up = self.normal_to_world(task.frame.y);
                    self.skeleton.push(self.to_world(task.origin), radius_at(0.0) as f32, NO_PARENT, up, 0)
                }
                None => task.base_node,
                Some((pp, pt)) => point_node[pp][pt],
            };
            let mut nodes = vec![(pa.start_dist, base)];
            let mut pn = Vec::with_capacity(pa.pts.len());
            let mut list = std::mem::take(&mut by_path[pi]);
            list.sort_by(|a, b| children[*a].0.dist.total_cmp(&children[*b].0.dist));
            let mut li = 0;
            let mut pt_i = 0;
            let mut prev = base;
            let mut prev_dist = pa.start_dist;
            let mut prev_pos = match pa.parent {
                None => task.origin,
                Some((pp, pt)) => paths[pp].pts[pt].pos,
            };
            loop {
                let child_dist = list.get(li).map(|&c| children[c].0.dist);
                let pt = pa.pts.get(pt_i);
                let child_first = match (pt, child_dist) {
                    (None, None) => break,
                    (None, Some(_)) => true,
                    (Some(_), None) => false,
                    // A child just before the next point waits for it when nearer to
                    // it than to the previous node.
                    (Some(pt), Some(cd)) => {
                        cd < pt.dist - eps && (cd < pt.dist - snap(cd) || cd - prev_dist <= pt.dist - cd)
                    }
                };
                if child_first {
                    let ci = list[li];
                    let pl = children[ci].0;
                    if pl.dist <= prev_dist + snap(pl.dist).max(eps) {
                        child_node[ci] = prev;
                        child_origin[ci] = Some((prev_pos, prev_dist));
                    } else {
                        let up = self.normal_to_world(pl.seg_frame.y);
                        let n = self.skeleton.push(
                            self.to_world(pl.pos),
                            radius_at(pl.dist) as f32,
                            prev,
                            up,
                            level as u16,
                        );
                        nodes.push((pl.dist, n));
                        prev = n;
                        prev_dist = pl.dist;
                        prev_pos = pl.pos;
                        child_node[ci] = n;
                    }
                    li += 1;
                    continue;
                }
                let Some(pt) = pt else { break };
                let f = pa.frames[pt.seg as usize - pa.first_seg];
                let up = self.normal_to_world(f.y);
                let n = self.skeleton.push(
                    self.to_world(pt.pos),
                    radius_at(pt.dist) as f32,
                    prev,
                    up,
                    level as u16,
                );
                pn.push(n);
                nodes.push((pt.dist, n));
                prev = n;
                prev_dist = pt.dist;
                prev_pos = pt.pos;
                pt_i += 1;
                // Children at this very point (or waiting for it) hang on it.
                while li < list.len() && children[list[li]].0.dist <= pt.dist + eps {
                    child_node[list[li]] = n;
                    child_origin[list[li]] = Some((pt.pos, pt.dist));
                    li += 1;
                }
            }
            let last = self.skeleton.len() as u32;
            // The record.
            let stem_index = self.stems.len() as u32;
            let parent_stem = match pa.parent {
                None => task.parent_stem,
                Some((pp, _)) => Some(stem_records + pp as u32),
            };
            self.stems.push(Stem {
                level: level as u8,
                parent_stem,
                clone_of: if pi == 0 { None } else { Some(stem_records) },
                offset: task.offset as f32,
                start: pa.start_dist as f32,
                length: length as f32,
                curve: self.bezier(pa),
                radius_base: radius as f32,
                radius_tip: taper_radius(taper, radius, length, 1.0) as f32,
                taper: taper as f32,
                flare: flare as f32,
                lobes: if level == 0 { self.p.lobes } else { 0 },
                lobe_depth: if level == 0 { self.p.lobe_depth as f32 } else { 0.0 },
                nodes: first..last,
            });
            debug_assert_eq!(stem_index, stem_records + pi as u32);
            if pi == 0 {
                self.report.stems_per_level[level] += 1;
            } else {
                self.report.clones_per_level[level] += 1;
            }
            path_nodes.push(nodes);
            point_node.push(pn);
        }

        // Leaves as organs.
        for (pl, frame) in leaves {
            let nodes = &path_nodes[pl.path];
            // The last node at or before the leaf, never the parent's node the path
            // starts on when the path has nodes of its own.
            let k = nodes.partition_point(|(d, _)| *d <= pl.dist + eps).max(2) - 1;
            let node = nodes[k.min(nodes.len() - 1)].1;
            let f = self.bend_leaf(frame, pl.pos);
            let organ = self.leaf_organ(&f, pl.pos, node);
            self.skeleton.organs.push(organ);
        }

        // Children, pushed so that they pop in order (depth first, parents first).
        for (ci, (pl, mut t)) in children.into_iter().enumerate().rev() {
            t.base_node = child_node[ci];
            if let Some((origin, dist)) = child_origin[ci] {
                // Hung on a node further up: limited by the parent's radius there.
                t.origin = origin;
                t.radius_limit = t.radius_limit.min(radius_at(dist));
            }
            t.parent_stem = Some(stem_records + pl.path as u32);
            stack.push(t);
        }
        Ok(())
    }

    /// Refuses `more` leaves beyond [`MAX_LEAVES`] before they are made.
    fn leaf_budget(&self, more: usize) -> Result<()> {
        if self.skeleton.organs.len().saturating_add(more) > MAX_LEAVES {
            return Err(Error::Recipe(format!(
                "`generator.leaves`: the tree would have more than {MAX_LEAVES} leaves; lower leaves, \
                 leaf_quality or n_branches"
            )));
        }
        Ok(())
    }

    /// `nDownAngle ± nDownAngleV`, or for negative `nDownAngleV` the paper's variation
    /// along the parent: `nDownAngle + nDownAngleV·(1 − 2·ShapeRatio(0, (L − t)/(L − base)))`.
    fn down_angle(&self, cl: usize, level: usize, length: f64, t: f64, rng: &mut Pcg64) -> f64 {
        let d = self.p.n_down_angle[cl];
        let v = self.p.n_down_angle_v[cl];
        let r = var(rng, v.abs());
        if v >= 0.0 {
            return d + r;
        }
        let len = if level == 0 { length * (1.0 - self.p.base_size) } else { length };
        let ratio = if len > 0.0 { ((length - t) / len).clamp(0.0, 1.0) } else { 0.0 };
        d + v * (1.0 - 2.0 * shape_ratio(0, ratio, self.p))
    }

    /// LeafBend: turn the leaf about the vertical so its normal faces away from
    /// the trunk, then tilt the normal toward the sky, each by the fraction LeafBend.
    fn bend_leaf(&self, f: Frame, pos: DVec3) -> Frame {
        let b = self.p.leaf_bend;
        if b == 0.0 {
            return f;
        }
        // The signed angle from the normal's azimuth to the position's, in (−π, π].
        let n = f.y;
        let t = (n.x * pos.y - n.y * pos.x).atan2(n.x * pos.x + n.y * pos.y);
        let f = f.rot_world(DVec3::Z, (b * t).to_degrees());
        let n = f.y;
        let phi = n.z.clamp(-1.0, 1.0).acos();
        let axis = n.cross(DVec3::Z);
        if axis.length_squared() > 1e-18 {
            f.rot_world(axis.normalize(), (b * phi).to_degrees())
        } else {
            f
        }
    }

    /// A leaf organ: the outline of `LeafShape` in the leaf frame (midrib along `z`,
    /// width along `x`, normal `y`), scaled by LeafScale and LeafScaleX.
    fn leaf_organ(&self, f: &Frame, pos: DVec3, node: u32) -> Organ {
        let len = self.p.leaf_scale / self.p.leaf_quality.sqrt();
        let wid = len * self.p.leaf_scale_x;
        let map = |(u, w): (f64, f64)| self.to_world(pos + f.x * (u * wid) + f.z * (w * len));
        let mut verts = Vec::with_capacity(self.outline.points.len() + 2);
        if let Some(c) = self.outline.center {
            verts.push(map(c));
            verts.extend(self.outline.points.iter().map(|p| map(*p)));
            if let Some(p0) = self.outline.points.first() {
                verts.push(map(*p0));
            }
        } else {
            verts.extend(self.outline.points.iter().map(|p| map(*p)));
        }
        Organ {
            kind: OrganKind::Polygon(verts),
            node,
            position: self.to_world(pos),
            heading: self.dir_to_world(f.z),
            up: self.normal_to_world(f.y),
            size: len as f32,
            material: 0,
        }
    }

    /// The path's centreline as cubic Bézier segments through its knots (segment ends,
    /// or helix steps), with Catmull–Rom tangents (one-sided at the ends).
    fn bezier(&self, pa: &Path) -> Vec<BezierSegment> {
        let mut k: Vec<DVec3> = Vec::with_capacity(pa.pts.len() + 1);
        k.push(pa.start_pos);
        k.extend(pa.pts.iter().filter(|p| p.knot).map(|p| p.pos));
        let n = k.len();
        let mut out = Vec::with_capacity(n.saturating_sub(1));
        if n < 2 {
            return out;
        }
        let tangent = |i: usize| -> DVec3 {
            let (a, b) = if i == 0 {
                (k[0], k[1])
            } else if i == n - 1 {
                (k[n - 2], k[n - 1])
            } else {
                (k[i - 1], k[i + 1])
            };
            (b - a).normalize_or_zero()
        };
        for i in 0..n - 1 {
            let h = k[i].distance(k[i + 1]) / 3.0;
            let p1 = k[i] + tangent(i) * h;
            let p2 = k[i + 1] - tangent(i + 1) * h;
            out.push(BezierSegment {
                points: [self.to_world(k[i]), self.to_world(p1), self.to_world(p2), self.to_world(k[i + 1])],
            });
        }
        out
    }
}

/// The running rotation of successive children about their parent (the paper's nRotate): `nRotate`
/// accumulates; a negative `nRotate` alternates sides by `±(180 + nRotate)`.
#[derive(Debug, Default)]
struct RotateState {
    angle: f64,
    side: f64,
}

impl RotateState {
    fn next(&mut self, rotate: f64, rotate_v: f64, rng: &mut Pcg64) -> f64 {
        let v = var(rng, rotate_v);
        if rotate >= 0.0 {
            self.angle = (self.angle + rotate + v).rem_euclid(360.0);
            self.angle
        } else {
            self.side = if self.side == -1.0 { 1.0 } else { -1.0 };
            self.side * (180.0 + rotate + v)
        }
    }
}

/// A leaf outline in leaf units: `u` across (width 1 = LeafScaleX·LeafScale), `w` along
/// the midrib from the petiole (0) to the tip (1). Concave outlines carry a `center`
/// from which they are star-shaped: the organ polygon then starts at it, so its fan
/// triangulation covers the outline exactly.
#[derive(Debug, Clone)]
struct LeafOutline {
    center: Option<(f64, f64)>,
    points: Vec<(f64, f64)>,
}

/// Builds a symmetric outline from its right half (base to tip, `u ≥ 0`).
fn mirrored(center: Option<(f64, f64)>, right: &[(f64, f64)]) -> LeafOutline {
    let mut points: Vec<(f64, f64)> = right.to_vec();
    let on_axis = |p: &(f64, f64)| p.0.abs() < 1e-12;
    let inner: Vec<(f64, f64)> = right.iter().rev().filter(|p| !on_axis(p)).map(|&(u, w)| (-u, w)).collect();
    points.extend(inner);
    LeafOutline { center, points }
}

/// The outline of `LeafShape` (0–8).
fn leaf_outline(shape: u32) -> LeafOutline {
    match shape {
        // Ovate: widest below the middle.
        1 => mirrored(None, &[(0.0, 0.0), (0.32, 0.08), (0.5, 0.3), (0.45, 0.55), (0.3, 0.78), (0.0, 1.0)]),
        // Linear (lanceolate): long, parallel sides.
        2 => mirrored(None, &[(0.0, 0.0), (0.35, 0.06), (0.5, 0.2), (0.5, 0.75), (0.3, 0.92), (0.0, 1.0)]),
        // Cordate: a notch at the petiole.
        3 => mirrored(
            Some((0.0, 0.45)),
            &[(0.0, 0.12), (0.2, 0.0), (0.42, 0.08), (0.5, 0.3), (0.42, 0.55), (0.24, 0.8), (0.0, 1.0)],
        ),
        // Maple: five pointed lobes.
        4 => mirrored(
            Some((0.0, 0.4)),
            &[
                (0.0, 0.08),
                (0.1, 0.02),
                (0.42, 0.12),
                (0.22, 0.3),
                (0.5, 0.56),
                (0.16, 0.58),
                (0.18, 0.8),
                (0.0, 1.0),
            ],
        ),
        // Palmate: narrow fingers spreading from the petiole.
        5 => mirrored(
            Some((0.0, 0.22)),
            &[(0.0, 0.0), (0.08, 0.1), (0.5, 0.42), (0.12, 0.4), (0.34, 0.9), (0.06, 0.55), (0.0, 1.0)],
        ),
        // Spiky oak: pointed lobes.
        6 => mirrored(
            Some((0.0, 0.5)),
            &[
                (0.0, 0.0),
                (0.12, 0.06),
                (0.36, 0.12),
                (0.2, 0.3),
                (0.5, 0.42),
                (0.24, 0.52),
                (0.44, 0.68),
                (0.18, 0.76),
                (0.26, 0.9),
                (0.0, 1.0),
            ],
        ),
        // Rounded oak: rounded lobes.
        7 => mirrored(
            Some((0.0, 0.5)),
            &[
                (0.0, 0.0),
                (0.16, 0.08),
                (0.34, 0.18),
                (0.24, 0.3),
                (0.46, 0.4),
                (0.48, 0.5),
                (0.26, 0.58),
                (0.4, 0.7),
                (0.36, 0.8),
                (0.18, 0.86),
                (0.2, 0.95),
                (0.0, 1.0),
            ],
        ),
        // Triangle (deltoid).
        8 => mirrored(None, &[(0.0, 0.0), (0.5, 0.04), (0.0, 1.0)]),
        // Ellipse, as a hexagon (Sapling's "hex" leaf).
        _ => {
            let right: Vec<(f64, f64)> = (0..=3)
                .map(|k| {
                    let a = k as f64 * PI / 3.0;
                    (0.5 * a.sin(), 0.5 - 0.5 * a.cos())
                })
                .collect();
            mirrored(None, &right)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> WeberPennParams {
        WeberPennParams {
            scale: 10.0,
            scale_v: 0.0,
            levels: 2,
            n_branches: [1, 12, 0, 0],
            n_curve_v: [0.0; 4],
            n_scale_v: [0.0; 4],
            leaves: 0,
            ..Default::default()
        }
    }

    #[test]
    fn shape_ratios_match_the_paper() {
        let p = WeberPennParams::default();
        assert!((shape_ratio(0, 0.5, &p) - 0.6).abs() < 1e-12);
        assert!((shape_ratio(1, 0.5, &p) - 1.0).abs() < 1e-12);
        assert!((shape_ratio(2, 1.0, &p) - 1.0).abs() < 1e-12);
        assert_eq!(shape_ratio(3, 0.3, &p), 1.0);
        assert_eq!(shape_ratio(4, 0.0, &p), 0.5);
        assert!((shape_ratio(5, 0.7, &p) - 1.0).abs() < 1e-12);
        assert!((shape_ratio(5, 1.0, &p)).abs() < 1e-12);
        assert!((shape_ratio(6, 1.0, &p) - 0.2).abs() < 1e-12);
        assert!((shape_ratio(7, 0.7, &p) - 1.0).abs() < 1e-12);
        // The envelope peaks at 1 at ratio = 1 − peak, is 0 at both ends and outside.
        assert!((shape_ratio(8, 0.5, &p) - 1.0).abs() < 1e-12);
        assert_eq!(shape_ratio(8, 0.0, &p), 0.0);
        assert_eq!(shape_ratio(8, 1.0, &p), 0.0);
        assert_eq!(shape_ratio(8, 1.5, &p), 0.0);
        assert_eq!(shape_ratio(8, f64::NAN, &p), 0.0);
    }

    #[test]
    fn diffusion_keeps_the_total() {
        let mut e = 0.0;
        let total: usize = (0..100).map(|_| diffuse(&mut e, 0.3)).sum();
        assert_eq!(total, 30);
    }

    #[test]
    fn frames_rotate_right_handed() {
        let f = Frame::IDENTITY.rot_x(90.0);
        assert!(f.z.distance(-DVec3::Y) < 1e-12, "rot_x turns z toward -y");
        let f = Frame::IDENTITY.rot_z(90.0);
        assert!(f.x.distance(DVec3::Y) < 1e-12);
    }

    #[test]
    fn leaf_outlines_are_star_shaped() {
        for shape in 0..=8 {
            let o = leaf_outline(shape);
            let c = o.center.unwrap_or(o.points[0]);
            let pts = &o.points;
            let n = pts.len();
            let mut sign = 0.0f64;
            let range: Vec<usize> = if o.center.is_some() { (0..n).collect() } else { (1..n - 1).collect() };
            for i in range {
                let (a, b) = (pts[i], pts[(i + 1) % n]);
                let cross = (a.0 - c.0) * (b.1 - c.1) - (a.1 - c.1) * (b.0 - c.0);
                assert!(cross.abs() > 1e-9, "shape {shape}: degenerate fan triangle {i}");
                if sign == 0.0 {
                    sign = cross.signum();
                }
                assert_eq!(cross.signum(), sign, "shape {shape}: fan triangle {i} flips");
            }
        }
    }

    #[test]
    fn validation_names_the_key() {
        let mut p = small();
        p.n_branches[2] = 2_000_000;
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("generator.n_branches[2]"), "{e}");
        let mut p = small();
        p.n_length[1] = f64::NAN;
        assert!(p.validate().unwrap_err().to_string().contains("generator.n_length[1]"));
        let mut p = small();
        p.levels = 5;
        assert!(p.validate().unwrap_err().to_string().contains("generator.levels"));
        let mut p = small();
        p.n_seg_splits[0] = 3.0;
        p.n_curve_res[0] = 20;
        assert!(p.validate().unwrap_err().to_string().contains("generator.n_seg_splits[0]"));
        let mut p = small();
        p.levels = 4;
        p.n_branches = [1, 1000, 1000, 1000];
        assert!(p.validate().unwrap_err().to_string().contains("generator.n_branches[3]"));
        let mut p = small();
        p.n_curve_v[1] = -90.0;
        assert!(p.validate().unwrap_err().to_string().contains("generator.n_curve_v[1]"));
    }

    #[test]
    fn children_start_on_parent_nodes() {
        let t = grow(&small(), 3).unwrap();
        t.skeleton.validate().unwrap();
        for s in t.stems.iter().filter(|s| s.level == 1) {
            let first = s.nodes.start as usize;
            let base = t.skeleton.parent[first];
            assert_ne!(base, NO_PARENT);
            assert_eq!(t.skeleton.order[base as usize], 0, "a level-1 stem starts on the trunk");
            assert!(s.curve[0].points[0].distance(t.skeleton.position[base as usize]) < 1e-4);
        }
    }
}
