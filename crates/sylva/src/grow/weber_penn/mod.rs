//! Weber–Penn parametric trees (WeberPenn1995): a recursion of stems over `levels`, with
//! splits, child stems along their parent, pruning and attraction, written to a
//! [`Skeleton`] with +Y up and recorded per stem as cubic Bézier chains with taper, flare
//! and lobes for the GPU branch deformer (Skjermo2008 §B). `params.rs` holds the
//! parameter set, `grow.rs` the growth, `curves.rs` the shape functions and branch
//! curves, `leaf.rs` the leaf outlines. `docs/weber-penn.md` states the model and the
//! conventions (axes, nodes, random streams) in full; comments name the paper's formula
//! each step implements (as Arbaro and Blender's Sapling transcribe them).
//!
//! Cost: O(nodes + leaves), budgets [`MAX_STEMS`], [`MAX_LEAVES`] and [`MAX_NODES`] are
//! checked before and while growing.

use crate::skeleton::Skeleton;
use std::ops::Range;
use std::time::Duration;

mod curves;
mod grow;
mod leaf;
mod params;

use self::curves::flare_factor;
pub use self::curves::{branch_curves, shape_ratio, taper_radius, BezierSegment};
pub use self::grow::grow;
pub use self::params::WeberPennParams;

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
    /// The skeleton, with leaves as [`OrganKind::Polygon`](crate::skeleton::OrganKind::Polygon) organs.
    pub skeleton: Skeleton,
    /// Every stem record in creation order (parents before children, originals before
    /// their clones).
    pub stems: Vec<Stem>,
    /// What was built.
    pub report: WeberPennReport,
}

#[cfg(test)]
mod tests {
    use super::grow::{diffuse, Frame};
    use super::leaf::leaf_outline;
    use super::*;
    use crate::skeleton::NO_PARENT;
    use glam::DVec3;

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
