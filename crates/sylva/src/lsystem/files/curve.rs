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
//! Conventions chosen where cpfg's manual is terse: `t ∈ [0, 1]` is the **normalised arc
//! length** (clamped), evaluated on a table of 64 samples per spline segment with linear
//! interpolation between them; `curveGAL(id)` is the arc length of that table ("get arc
//! length"); `size`, `contact`, `heading` and `up` (used when cpfg draws the contour as a
//! generalized cylinder section) do not change these values.

use super::TextFile;
use crate::input::excerpt;
use crate::lsystem::source::{ErrorKind, LsystemError};
use glam::DVec3;

/// Samples per cubic segment of the arc-length table.
const SAMPLES: usize = 64;
/// Largest number of control points (after multiplicities) a curve may have.
const MAX_POINTS: usize = 100_000;

/// A curve read from a `.con` file, tabulated by arc length.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Points along the curve.
    pub points: Vec<DVec3>,
    /// Arc length from the start to each point; the last entry is the curve's length.
    pub arc: Vec<f64>,
}

impl Curve {
    /// Total arc length (`curveGAL`).
    pub fn length(&self) -> f64 {
        self.arc.last().copied().unwrap_or(0.0)
    }

    /// The point at normalised arc length `t` (clamped to [0, 1]); NaN `t` gives the start.
    pub fn at(&self, t: f64) -> DVec3 {
        let n = self.points.len();
        if n == 1 || self.length() <= 0.0 {
            return self.points[0];
        }
        let s = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) * self.length() };
        let k = self.arc.partition_point(|&a| a < s).clamp(1, n - 1);
        let (a0, a1) = (self.arc[k - 1], self.arc[k]);
        let f = if a1 > a0 { (s - a0) / (a1 - a0) } else { 0.0 };
        self.points[k - 1].lerp(self.points[k], f)
    }
}

/// Parses the text of a `.con` file named `name` (for error messages).
pub fn parse(name: &str, text: &str) -> Result<Curve, Box<LsystemError>> {
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
    Ok(tabulate(&control))
}

/// Tabulates the uniform cubic B-spline of `control` by arc length.
fn tabulate(control: &[DVec3]) -> Curve {
    // Pad short lists by repeating the ends so there is at least one segment.
    let mut c = control.to_vec();
    while c.len() < 4 {
        let last = *c.last().unwrap_or(&DVec3::ZERO);
        c.push(last);
    }
    let mut points = Vec::with_capacity((c.len() - 3) * SAMPLES + 1);
    for seg in 0..c.len() - 3 {
        let [p0, p1, p2, p3] = [c[seg], c[seg + 1], c[seg + 2], c[seg + 3]];
        let last = seg + 4 == c.len();
        for k in 0..SAMPLES + usize::from(last) {
            let t = k as f64 / SAMPLES as f64;
            let (t2, t3) = (t * t, t * t * t);
            let b0 = (1.0 - t).powi(3) / 6.0;
            let b1 = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
            let b2 = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
            let b3 = t3 / 6.0;
            points.push(p0 * b0 + p1 * b1 + p2 * b2 + p3 * b3);
        }
    }
    let mut arc = Vec::with_capacity(points.len());
    let mut total = 0.0;
    for (i, p) in points.iter().enumerate() {
        if i > 0 {
            total += p.distance(points[i - 1]);
        }
        arc.push(total);
    }
    Curve { points, arc }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clamped_line_has_its_length_and_arc_length_parameter() {
        let c = parse("line.con", "points: 2\ntype: bspline\n0 0 0 3\n2 0 0 3\n").unwrap();
        assert!((c.length() - 2.0).abs() < 1e-9, "{}", c.length());
        for t in [0.0, 0.25, 0.5, 1.0] {
            assert!((c.at(t) - DVec3::new(2.0 * t, 0.0, 0.0)).length() < 1e-9, "t {t}: {}", c.at(t));
        }
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
