//! Named thresholds and the scale-relative tolerance the meshers and the mesh checker
//! share (issue 22: one rule, written once). Plain data: this module imports no stage.
//!
//! Geometry in sylva spans five orders of magnitude (a 30 m tree with 2 mm twigs), so a
//! length test is never against a fixed epsilon but against a [`Tolerance`] made from
//! the size of what is tested: a mesh's bounding-box diagonal or a skeleton's extent.
//! Shape tests (a sliver) are scale-free ratios. The joint meshers' radius floor is the
//! one absolute length: below it their junction boxes, hull loops and hexagon templates
//! stop being resolvable in `f32` for trees of ordinary size (Pieterse2012 §2.1, Skjermo2008
//! §2.2).

use glam::Vec3;

/// The joint meshers' radius floor in model units (metres for the presets): the default
/// `min_radius` of `[mesh.sweep]`, `[mesh.quad]`, `[fit.decollide]` and `[fit.clear]`,
/// so de-collision raises radii to exactly the floor the meshers then assume.
pub const RADIUS_FLOOR: f64 = 0.005;

/// A face is a sliver when its area is at most this times the square of its longest
/// edge (the mesh checker's degenerate-face rule, which the hull mesher's edge flips
/// must agree with).
pub const SLIVER_RATIO: f64 = 1e-7;

/// A length is zero when it is at most this times the scale of its [`Tolerance`]
/// (about eight `f32` ulps of the largest coordinate).
pub const ZERO_LENGTH_RATIO: f64 = 1e-6;

/// A face is degenerate when its longest edge is at most this times the scale of its
/// [`Tolerance`] (a few `f32` ulps: the face cannot be told from a point).
pub const TINY_EDGE_RATIO: f64 = 1e-7;

/// True for a sliver: area `area` at most [`SLIVER_RATIO`] times the squared longest
/// edge `longest_edge_sq`; a NaN area is a sliver too.
pub fn is_sliver(area: f64, longest_edge_sq: f64) -> bool {
    is_sliver_at(SLIVER_RATIO, area, longest_edge_sq)
}

/// [`is_sliver`] with a ratio of its own (the mesh checker's `CheckOptions::sliver`).
pub fn is_sliver_at(ratio: f64, area: f64, longest_edge_sq: f64) -> bool {
    area.is_nan() || area <= ratio * longest_edge_sq
}

/// Length tolerances relative to the size of the geometry they test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// The characteristic size: a bounding-box diagonal or an extent, never below 1e-30.
    pub scale: f64,
}

impl Tolerance {
    /// A tolerance for geometry of size `scale` (non-finite or non-positive sizes give
    /// the smallest scale, so every test stays well defined).
    pub fn new(scale: f64) -> Self {
        Self { scale: if scale.is_finite() { scale.max(1e-30) } else { 1e-30 } }
    }

    /// A tolerance from the bounding-box diagonal of `points` (non-finite points are
    /// skipped; no points give the smallest scale).
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Self {
        let (lo, hi) = points
            .into_iter()
            .filter(|p| p.is_finite())
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        Self::new(if lo.x <= hi.x { (hi - lo).as_dvec3().length() } else { 0.0 })
    }

    /// Lengths at most this are zero ([`ZERO_LENGTH_RATIO`] · scale).
    pub fn zero_length(&self) -> f64 {
        ZERO_LENGTH_RATIO * self.scale
    }

    /// Edges at most this long make a face degenerate ([`TINY_EDGE_RATIO`] · scale).
    pub fn tiny_edge(&self) -> f64 {
        TINY_EDGE_RATIO * self.scale
    }

    /// True when length `d` is zero at this scale (NaN is zero: it measures nothing).
    pub fn is_zero(&self, d: f64) -> bool {
        d.is_nan() || d <= self.zero_length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sliver_rule_is_scale_free() {
        // A triangle with base 1 and height h has area h/2.
        for s in [1e-3, 1.0, 1e3] {
            assert!(is_sliver(0.5 * 1e-8 * s * s, s * s), "flat at scale {s}");
            assert!(!is_sliver(0.5 * 1e-3 * s * s, s * s), "proper at scale {s}");
            assert!(is_sliver_at(1e-2, 0.5 * 1e-3 * s * s, s * s), "own ratio at scale {s}");
        }
        assert!(is_sliver(f64::NAN, 1.0));
    }

    #[test]
    fn every_joint_stage_defaults_to_the_one_radius_floor() {
        assert_eq!(crate::fit::decollide::DecollideOptions::default().min_radius, RADIUS_FLOOR);
        assert_eq!(crate::fit::clear::ClearOptions::default().min_radius, RADIUS_FLOOR);
        assert_eq!(crate::mesh::sweep::SweepOptions::default().min_radius, RADIUS_FLOOR);
        assert_eq!(crate::mesh::quad::QuadOptions::default().min_radius, RADIUS_FLOOR as f32);
        assert_eq!(crate::mesh::check::CheckOptions::default().sliver, SLIVER_RATIO);
    }

    #[test]
    fn tolerance_follows_the_bounding_box() {
        let pts = [Vec3::ZERO, Vec3::new(3.0, 4.0, 0.0), Vec3::NAN];
        let t = Tolerance::of_points(&pts);
        assert!((t.scale - 5.0).abs() < 1e-12);
        assert!(t.is_zero(4e-6) && !t.is_zero(6e-6) && t.is_zero(f64::NAN));
        assert!((t.tiny_edge() - 5e-7).abs() < 1e-18);
        assert_eq!(Tolerance::of_points(&[]).scale, 1e-30);
        assert_eq!(Tolerance::new(f64::INFINITY).scale, 1e-30);
    }
}
