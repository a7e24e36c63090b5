//! cpfg curve files (`.con`, listed as `curve: file` in the view file) for the
//! expression functions `curveX(id, t)`, `curveY(id, t)`, `curveZ(id, t)` and
//! `curveGAL(id)` (issue 3; used by the vlab phyllotaxis models of Ridley).
//!
//! The format, as the corpus writes it (the version line and the `contact:` … `type:`
//! header are optional; unknown header keys are ignored):
//!
//! ```text
//! version: 1.4
//! contact: 0 0 0
//! end: 0 0 0
//! heading: 0 1 0
//! up: 0 0 -1
//! size: 1
//! points: 4
//! range: 0.0 1.0
//! dimension: 4
//! type: bspline
//! 0.269398 -0.447751 0 3        # x y z multiplicity
//! ...
//! ```
//!
//! Each control point is repeated `multiplicity` times and the result is a uniform cubic
//! B-spline (a multiplicity of 3 at the ends makes it pass through its end points).
//! Evaluated as cpfg 6.6 does (vlab `cpfg/curveXYZ.cpp`, issue 46): the curve's parameter
//! u ∈ [0, 1] maps to the knot range [3, n − 3.000001] (n control points after
//! multiplicities); the view file's `curve: file [samples]` (default 100) samples it at
//! u = i/(samples − 1); the chords between the samples give the arc length table,
//! normalised to [0, 1], and `curveGAL(id)` is its total. `curveX/Y/Z(id, t)` clamp t to
//! [0, 1], find t's interval in the table by bisection, interpolate u linearly inside it
//! and evaluate the B-spline exactly at that u. `size`, `contact`, `heading` and `up`
//! (used when cpfg draws the contour as a generalized cylinder section) do not change
//! these values.

use super::TextFile;
use crate::input::excerpt;
use crate::lsystem::source::{ErrorKind, LsystemError};
use glam::DVec3;

/// Samples of the arc-length table when the view file's `curve:` line gives none (cpfg).
pub const DEFAULT_SAMPLES: usize = 100;
/// Largest number of control points (after multiplicities) a curve may have.
const MAX_POINTS: usize = 100_000;
/// Largest number of samples a `curve:` line may ask for.
pub const MAX_SAMPLES: usize = 1_000_000;

/// A curve read from a `.con` file, with cpfg's arc-length table.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// The control points, each repeated by its multiplicity (at least 4).
    pub control: Vec<DVec3>,
    /// The samples at u = i/(samples − 1).
    pub points: Vec<DVec3>,
    /// Arc length (sum of chords) from the start to each sample; the last entry is the
    /// curve's length.
    pub arc: Vec<f64>,
}

impl Curve {
    /// Total arc length (`curveGAL`): the chords of the samples.
    pub fn length(&self) -> f64 {
        self.arc.last().copied().unwrap_or(0.0)
    }

    /// The B-spline at parameter u ∈ [0, 1] (cpfg's `calcPValue`).
    pub fn at_parameter(&self, u: f64) -> DVec3 {
        let n = self.control.len();
        let span = n as f64 - 3.000001;
        let x = 3.0 + u * span;
        let i = (3 + (u * span) as usize).min(n - 1);
        let t = x - i as f64;
        let (t2, t3) = (t * t, t * t * t);
        let b0 = (1.0 - t).powi(3) / 6.0;
        let b1 = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
        let b2 = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
        let b3 = t3 / 6.0;
        let c = &self.control;
        c[i - 3] * b0 + c[i - 2] * b1 + c[i - 1] * b2 + c[i] * b3
    }

    /// The point at normalised arc length `t` (clamped to [0, 1]; NaN gives the start),
    /// as cpfg's `curveX/Y/Z` find it.
    pub fn at(&self, t: f64) -> DVec3 {
        let n = self.points.len();
        let total = self.length();
        if n < 2 || total <= 0.0 {
            return self.points[0];
        }
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let l = |k: usize| self.arc[k] / total;
        let (mut lo, mut hi) = (0, n - 1);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if l(mid) > t {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let gap = l(hi) - l(lo);
        let f = if gap > 0.0 { (t - l(lo)) / gap } else { 0.0 };
        self.at_parameter((lo as f64 + f) / (n - 1) as f64)
    }
}

/// Parses the text of a `.con` file named `name` (for error messages), tabulated with
/// [`DEFAULT_SAMPLES`].
pub fn parse(name: &str, text: &str) -> Result<Curve, Box<LsystemError>> {
    parse_with_samples(name, text, DEFAULT_SAMPLES)
}

/// [`parse`] with the arc-length table of `samples` samples (the view file's
/// `curve: file samples`; clamped to 2..=[`MAX_SAMPLES`]).
pub fn parse_with_samples(name: &str, text: &str, samples: usize) -> Result<Curve, Box<LsystemError>> {
    let src = TextFile::new(name, text);
    let mut declared: Option<usize> = None;
    let mut control: Vec<DVec3> = Vec::new();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let at = offset;
        offset += line.len();
        let body = line.trim();
        if body.is_empty() || body.starts_with('#') || body.starts_with("//") {
            continue;
        }
        let err = |what: &str| src.error(at, line.trim_end().len(), what, "here");
        if let Some((key, value)) = body.split_once(':') {
            match key.trim() {
                "points" => {
                    let n: usize = value.trim().parse().map_err(|_| err("`points:` needs a whole number"))?;
                    declared = Some(n);
                }
                "type" if !matches!(value.trim(), "bspline" | "b-spline") => {
                    let mut e = src.error(
                        at,
                        line.trim_end().len(),
                        &format!("unsupported: curve type `{}` (only `bspline`)", excerpt(value.trim())),
                        "here",
                    );
                    e.kind = ErrorKind::Unsupported;
                    return Err(e);
                }
                _ => {}
            }
            continue;
        }
        let nums: Vec<f64> = body
            .split_whitespace()
            .map(|w| w.parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|_| err("a control point is `x y z [multiplicity]`"))?;
        if !(2..=4).contains(&nums.len()) || nums.iter().any(|v| !v.is_finite()) {
            return Err(err("a control point is `x y z [multiplicity]` with finite numbers"));
        }
        let p = DVec3::new(nums[0], nums[1], nums.get(2).copied().unwrap_or(0.0));
        let mult = nums.get(3).copied().unwrap_or(1.0);
        if !(1.0..=16.0).contains(&mult) || mult.fract() != 0.0 {
            return Err(err("a multiplicity is a whole number in 1..=16"));
        }
        for _ in 0..mult as usize {
            control.push(p);
        }
        if control.len() > MAX_POINTS {
            return Err(err(&format!("more than {MAX_POINTS} control points")));
        }
    }
    if control.is_empty() {
        return Err(src.error(0, 0, "the curve has no control points", "here"));
    }
    let _ = declared; // cpfg's count; the points actually listed win
    Ok(tabulate(&control, samples.clamp(2, MAX_SAMPLES)))
}

/// Tabulates the uniform cubic B-spline of `control` by arc length with `samples`
/// samples, as cpfg's `createAPoints`.
fn tabulate(control: &[DVec3], samples: usize) -> Curve {
    // Pad short lists by repeating the ends so there is at least one segment.
    let mut c = control.to_vec();
    while c.len() < 4 {
        let last = *c.last().unwrap_or(&DVec3::ZERO);
        c.push(last);
    }
    let mut curve =
        Curve { control: c, points: Vec::with_capacity(samples), arc: Vec::with_capacity(samples) };
    let mut total = 0.0;
    for i in 0..samples {
        let p = curve.at_parameter(i as f64 / (samples - 1) as f64);
        if let Some(q) = curve.points.last() {
            total += p.distance(*q);
        }
        curve.points.push(p);
        curve.arc.push(total);
    }
    curve
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clamped_line_has_its_length_and_arc_length_parameter() {
        let c = parse("line.con", "points: 2\ntype: bspline\n0 0 0 3\n2 0 0 3\n").unwrap();
        // cpfg's parameter ends at 3.000001 short of the last knot: the end is 1e-6 away.
        assert!((c.length() - 2.0).abs() < 1e-5, "{}", c.length());
        for t in [0.0, 0.25, 0.5, 1.0] {
            // Interpolating the parameter between 100 samples: within 1e-4 of the line.
            assert!((c.at(t) - DVec3::new(2.0 * t, 0.0, 0.0)).length() < 1e-4, "t {t}: {}", c.at(t));
        }
        // On a sample the point is the B-spline's there, exactly.
        assert_eq!(c.at(c.arc[10] / c.length()), c.points[10]);
        assert_eq!(c.at(-1.0), c.at(0.0));
        assert_eq!(c.at(f64::NAN), c.at(0.0));
    }

    #[test]
    fn the_corpus_profile_passes_through_its_end_points() {
        let text = "version: 1.4\ncontact: 0 0 0\nend: 0 0 0\nheading: 0 1 0\nup: 0 0 -1\nsize: 1\npoints: 4\n\
                    range: 0.0 1.0\ndimension: 4\ntype: bspline\n0.269398 -0.447751 0 3\n0.274471 -0.109864 0 1\n\
                    0.165305 0.175183 0 1\n-0.001478 0.202475 0 3\n";
        let c = parse("profile.con", text).unwrap();
        assert!((c.at(0.0) - DVec3::new(0.269398, -0.447751, 0.0)).length() < 1e-12);
        assert!((c.at(1.0) - DVec3::new(-0.001478, 0.202475, 0.0)).length() < 1e-12);
        // Longer than the chord, shorter than the control polygon.
        let chord = c.at(0.0).distance(c.at(1.0));
        assert!(c.length() > chord && c.length() < 0.34 + 0.31 + 0.17 + 1e-3, "{}", c.length());
        // Arc-length parameter: half the length is reached at t = 0.5.
        let mid = c.at(0.5);
        let k = c.points.iter().position(|p| *p == mid);
        assert!(k.is_none() || (c.arc[k.unwrap()] - c.length() / 2.0).abs() < 1e-9);
    }

    #[test]
    fn bad_files_are_located_errors() {
        for (text, what) in [
            ("points: x\n", "whole number"),
            ("type: bezier\n0 0 0\n", "unsupported: curve type"),
            ("0 0 zero\n", "control point"),
            ("0 0 0 0.5\n", "multiplicity"),
            ("points: 0\n", "no control points"),
        ] {
            let e = parse("bad.con", text).unwrap_err();
            assert!(e.to_string().contains(what), "{text:?}: {e}");
        }
    }
}
