//! The GPU branch deformer's CPU reference (issue 25, item 1): Skjermo2008 D §2–§3.5
//! (Skjermo's 2006 vertex-shader deformer) as Skjermo2008-spec §3 corrects it, with the
//! checks of Skjermo2008-spec §10, properties 12–19. `docs/deformer.md` has the formulas
//! and the table of tests; the GPU crate ports this module line for line to WGSL and must
//! match it within 10⁻⁴ of the branch radius (property 19).
//!
//! A branch is one [`BranchRecord`] (`record.rs`). A vertex of a (v, θ) [`Grids`] level
//! (`grid.rs`) becomes a surface point by its [`radius`] (`radius.rs`), Sloan's handles
//! ([`sloan_frames`]) and the bending map ([`BranchDeformer::q`], `bend.rs`), generic over
//! the precision ([`Real`], [`Vector`]); [`branch_records`] (`curves.rs`) makes one record
//! per curve segment of a model's branch curves, in the order of the wind rig's branches.

use std::fmt::{self, Debug};

mod bend;
mod curves;
mod grid;
mod radius;
mod real;
mod record;

pub use self::bend::{
    deform, fallback_axis, sloan_frames, unit_or, BranchDeformer, Deformer, Handles, SurfacePoint,
};
pub use self::curves::branch_records;
pub use self::grid::{branch_mesh, grid, GridLod, GridVertex, Grids};
pub use self::radius::{
    bulges, bulges_dv, flare, flare_dv, lobes, lobes_dtheta, lobes_dv, radius, taper, taper_dv, Radius,
};
pub use self::real::{Real, Vector};
pub use self::record::{control_polygon, BranchRecord, FlareMode};

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
/// [`BranchRecord::axis`] of a record that did not come from [`BranchCurves`](crate::model::BranchCurves).
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};

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
