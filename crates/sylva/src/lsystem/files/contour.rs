//! cpfg contour files (`.con`, listed as `contour: N file.con` in the view file): the
//! cross-sections of generalized cylinders selected with `@#(N)` (issue 26).
//!
//! This implements the contour reader of cpfg's `generalized cylinders` code (vlab 5,
//! formats `cver 1 1` to `cver 1 3`), as the corpus writes it:
//!
//! ```text
//! cver 1 3
//! name: leaf.con
//! points: 11 15          # n distinct control points, m counting multiplicities
//! type: or               # o|c (open|closed), r|e (regular|end-point B-spline)
//! samples: 8             # cver 1 3 only
//! -8.517361 -0.402775 0.000000 3     # x y z multiplicity
//! ...
//! ```
//!
//! Reading, where cpfg's format is terse:
//!
//! - `points: n m`: exactly `n` point lines must follow and their multiplicities must
//!   add up to `m`; either mismatch is an error (cpfg would read garbage).
//! - `type:` (cver 1 2 and 1 3): the first letter is `o` (open) or `c` (closed). The
//!   second letter is `r` (regular) or `e` (end-point interpolating); cpfg reads `e` as
//!   `r` ("end point interpolation not supported, regular assumed") and so does sylva.
//!   Either way the curve is the **uniform cubic B-spline** of the control points, each
//!   repeated `multiplicity` times; an end point of multiplicity 3 makes an open curve
//!   start (or end) exactly there, which is how the corpus's leaf contours reach their
//!   tips. cver 1 1 writes `type: open` / `type: closed`.
//! - `samples:` is read and must be a positive whole number, but, as in cpfg, it does
//!   not set the resolution: the drawn cross-section is [`Contour::sample`]d by arc
//!   length into the view file's `contour sides` (cpfg's `cylinder_sides`) pieces.
//! - An open curve has `m − 3` cubic segments (so `m ≥ 4`), a closed one `m` (its
//!   control points wrap around; `m ≥ 3`). The z coordinate is read and must be finite
//!   but is not used: the contour lies in its x–y plane.
//! - cpfg's oldest layout, without a `cver` line (issue 46 item 10), is read as cpfg's
//!   `_ReadContour0000` reads it: a first line `num dim type` (`closed`, or any other
//!   word for open), then `num` points of `dim` (2 or 3) coordinates separated by any
//!   white space, each of multiplicity 1; text after them is ignored.
//! - The `background:` / `markers:` lines some editors write are `unsupported:` errors.
//!
//! Errors name the file, the line and why (a bad number, a missing header key, a count
//! that does not match, a contour of zero length).

use super::TextFile;
use crate::input::excerpt;
use crate::lsystem::source::{ErrorKind, LsystemError};
use glam::{DVec2, DVec3};

/// Largest number of control points (after multiplicities) a contour may have.
const MAX_POINTS: usize = 10_000;
/// Largest multiplicity of one control point.
const MAX_MULTIPLICITY: u32 = 16;
/// Samples per cubic segment of the arc-length table used by [`Contour::sample`].
const TABLE: usize = 32;
/// Most pieces a contour may be sampled into.
pub const MAX_SIDES: usize = 1024;

/// A contour read from a `.con` file: a planar uniform cubic B-spline.
#[derive(Debug, Clone, PartialEq)]
pub struct Contour {
    /// The `name:` line's value, when present.
    pub name: Option<String>,
    /// Whether the curve is closed (`type: c…`).
    pub closed: bool,
    /// Whether the type's second letter was `e` (read as regular, as cpfg does).
    pub end_point: bool,
    /// The `samples:` value (cver 1 3), recorded but not used for drawing.
    pub samples: Option<u32>,
    /// Number of distinct control points (`points: n`).
    pub distinct: usize,
    /// The control points, each repeated by its multiplicity (`points: … m` of them).
    pub control: Vec<DVec3>,
}

impl Contour {
    /// Number of cubic segments: `m − 3` when open, `m` when closed.
    pub fn segments(&self) -> usize {
        if self.closed {
            self.control.len()
        } else {
            self.control.len().saturating_sub(3)
        }
    }

    /// The curve's point at parameter `t` in `[0, segments]` (x and y only).
    pub fn at(&self, t: f64) -> DVec2 {
        let m = self.control.len();
        let segs = self.segments().max(1);
        let t = if t.is_finite() { t.clamp(0.0, segs as f64) } else { 0.0 };
        let k = (t.floor() as usize).min(segs - 1);
        let f = t - k as f64;
        let (f2, f3) = (f * f, f * f * f);
        let w = [
            (1.0 - f).powi(3) / 6.0,
            (3.0 * f3 - 6.0 * f2 + 4.0) / 6.0,
            (-3.0 * f3 + 3.0 * f2 + 3.0 * f + 1.0) / 6.0,
            f3 / 6.0,
        ];
        let mut p = DVec2::ZERO;
        for (j, wj) in w.iter().enumerate() {
            p += self.control[(k + j) % m].truncate() * *wj;
        }
        p
    }

    /// The curve sampled at `sides` equal steps of arc length: `sides + 1` points from
    /// start to end when open, `sides` points (the start not repeated) when closed.
    /// `sides` is clamped to `1..=`[`MAX_SIDES`] (`3..` when closed).
    pub fn sample(&self, sides: usize) -> Vec<DVec2> {
        let sides = sides.clamp(if self.closed { 3 } else { 1 }, MAX_SIDES);
        let segs = self.segments().max(1);
        let n = segs * TABLE;
        let mut pts = Vec::with_capacity(n + 1);
        let mut arc = Vec::with_capacity(n + 1);
        let mut total = 0.0;
        for i in 0..=n {
            let p = self.at(i as f64 / TABLE as f64);
            if let Some(&q) = pts.last() {
                total += p.distance(q);
            }
            pts.push(p);
            arc.push(total);
        }
        let count = if self.closed { sides } else { sides + 1 };
        (0..count)
            .map(|i| {
                let s = total * i as f64 / sides as f64;
                let k = arc.partition_point(|&a| a < s).clamp(1, n);
                let (a0, a1) = (arc[k - 1], arc[k]);
                let f = if a1 > a0 { (s - a0) / (a1 - a0) } else { 0.0 };
                pts[k - 1].lerp(pts[k], f)
            })
            .collect()
    }

    /// The curve's length (in the x–y plane), from a table of 32 points per segment.
    pub fn length(&self) -> f64 {
        let n = self.segments().max(1) * TABLE;
        (1..=n)
            .map(|i| self.at(i as f64 / TABLE as f64).distance(self.at((i - 1) as f64 / TABLE as f64)))
            .sum()
    }
}

/// Parses the text of a `.con` contour file named `name` (for error messages).
pub fn parse(name: &str, text: &str) -> Result<Contour, Box<LsystemError>> {
    let src = TextFile::new(name, text);
    let mut lines = Vec::new();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let body = line.trim();
        if !body.is_empty() {
            lines.push((offset + (line.len() - line.trim_start().len()), body));
        }
        offset += line.len();
    }
    let err = |at: usize, len: usize, what: &str| src.error(at, len, what, "here");
    let unsupported = |at: usize, len: usize, what: &str| {
        let mut e = src.error(at, len, &format!("unsupported: {what}"), "here");
        e.kind = ErrorKind::Unsupported;
        e
    };
    let Some(&(at0, first)) = lines.first() else {
        return Err(err(0, 0, "the contour file is empty (it should start with `cver 1 3`)"));
    };
    let version: Vec<&str> = first.split_whitespace().collect();
    let minor = match version.as_slice() {
        ["cver", "1", m] => match m.parse::<u32>() {
            Ok(m @ 1..=3) => m,
            _ => {
                return Err(unsupported(
                    at0,
                    first.len(),
                    &format!("contour format `{}` (cver 1 1 to 1 3)", excerpt(first)),
                ))
            }
        },
        ["cver", ..] => {
            return Err(unsupported(
                at0,
                first.len(),
                &format!("contour format `{}` (cver 1 1 to 1 3)", excerpt(first)),
            ))
        }
        _ => return headerless(&src, &lines),
    };
    // Header keys, in any order, up to the first line that starts with a number.
    let (mut cname, mut counts, mut closed, mut end_point, mut samples) = (None, None, None, false, None);
    let mut k = 1;
    while k < lines.len() {
        let (at, body) = lines[k];
        if body.starts_with(|c: char| c.is_ascii_digit() || matches!(c, '-' | '+' | '.')) {
            break;
        }
        let Some((key, value)) = body.split_once(':') else {
            return Err(err(at, body.len(), "expected a `key: value` header line or a control point"));
        };
        let value = value.trim();
        let vat = at + body.len() - body[key.len() + 1..].trim_start().len();
        match key.trim() {
            "name" => cname = Some(value.to_string()),
            "points" => {
                let nums: Vec<Option<usize>> = value.split_whitespace().map(|w| w.parse().ok()).collect();
                match nums.as_slice() {
                    [Some(n), Some(m)] => counts = Some((*n, *m, at, body.len())),
                    _ => {
                        return Err(err(
                            vat,
                            value.len(),
                            "`points:` needs two whole numbers `n m` (distinct points, with multiplicities)",
                        ))
                    }
                }
            }
            "type" => {
                let t = value.split_whitespace().next().unwrap_or("");
                let bad = || {
                    err(vat, value.len().max(1), &format!("contour type `{}`: expected `or`, `oe`, `cr` or `ce` (`open` or `closed` in cver 1 1)", excerpt(value)))
                };
                if minor == 1 {
                    closed = Some(match t {
                        "open" => false,
                        "closed" => true,
                        _ => return Err(bad()),
                    });
                } else {
                    let b = t.as_bytes();
                    if b.len() != 2 {
                        return Err(bad());
                    }
                    closed = Some(match b[0] {
                        b'o' => false,
                        b'c' => true,
                        _ => return Err(bad()),
                    });
                    end_point = match b[1] {
                        b'r' => false,
                        b'e' => true,
                        _ => return Err(bad()),
                    };
                }
            }
            "samples" => match value.parse::<u32>() {
                Ok(s) if s > 0 => samples = Some(s),
                _ => return Err(err(vat, value.len().max(1), "`samples:` needs a positive whole number")),
            },
            "background" | "markers" => {
                return Err(unsupported(
                    at,
                    body.len(),
                    &format!("the contour header key `{}`", excerpt(key.trim())),
                ))
            }
            other => {
                return Err(err(at, body.len(), &format!("unknown contour header key `{}`", excerpt(other))))
            }
        }
        k += 1;
    }
    let end_of_header = lines.get(k - 1).map(|&(a, b)| (a, b.len())).unwrap_or((at0, first.len()));
    let Some((n, m, pat, plen)) = counts else {
        return Err(err(end_of_header.0, end_of_header.1, "the contour header has no `points: n m` line"));
    };
    let Some(closed) = closed else {
        return Err(err(end_of_header.0, end_of_header.1, "the contour header has no `type:` line"));
    };
    if minor == 3 && samples.is_none() {
        return Err(err(
            end_of_header.0,
            end_of_header.1,
            "a cver 1 3 contour header needs a `samples:` line",
        ));
    }
    if m > MAX_POINTS || n > m {
        return Err(err(pat, plen, &format!("`points: {n} {m}`: at most {MAX_POINTS} points, and n ≤ m")));
    }
    let need = if closed { 3 } else { 4 };
    if m < need {
        return Err(err(
            pat,
            plen,
            &format!(
                "a{} contour needs at least {need} control points counting multiplicities (it has {m})",
                if closed { " closed" } else { "n open" }
            ),
        ));
    }
    let mut control = Vec::with_capacity(m);
    let mut distinct = 0;
    for &(at, body) in &lines[k..] {
        let nums: Vec<Option<f64>> = body.split_whitespace().map(super::number).collect();
        let p = match nums.as_slice() {
            [Some(x), Some(y), Some(z), Some(mult)] => {
                if mult.fract() != 0.0 || *mult < 1.0 || *mult > MAX_MULTIPLICITY as f64 {
                    return Err(err(
                        at,
                        body.len(),
                        &format!("a multiplicity is a whole number in 1..={MAX_MULTIPLICITY}"),
                    ));
                }
                (DVec3::new(*x, *y, *z), *mult as usize)
            }
            _ => {
                return Err(err(
                    at,
                    body.len(),
                    "a control point is `x y z multiplicity` (four finite numbers)",
                ))
            }
        };
        distinct += 1;
        if distinct > n {
            return Err(err(
                at,
                body.len(),
                &format!("more control points than the {n} of `points: {n} {m}`"),
            ));
        }
        control.extend(std::iter::repeat_n(p.0, p.1));
        if control.len() > m {
            return Err(err(
                at,
                body.len(),
                &format!("the multiplicities add up to more than the {m} of `points: {n} {m}`"),
            ));
        }
    }
    let last = lines.last().map(|&(a, b)| (a, b.len())).unwrap_or((0, 0));
    if distinct < n || control.len() < m {
        return Err(err(
            last.0,
            last.1,
            &format!(
                "the file ends after {distinct} control points ({} with multiplicities); `points: {n} {m}` promised more",
                control.len()
            ),
        ));
    }
    let c = Contour { name: cname, closed, end_point, samples, distinct, control };
    let length = c.length();
    if length.is_nan() || length <= 1e-12 {
        return Err(err(pat, plen, "the contour has zero length (all its control points coincide)"));
    }
    Ok(c)
}

/// cpfg's oldest contour layout, without a `cver` line (its `_ReadContour0000`): a
/// first line `num dim type` (`type` is `closed` for a closed curve, any other word
/// open), then `num` control points of `dim` coordinates (2: `x y`, 3: `x y z`),
/// separated by any white space, each of multiplicity 1. What follows them is ignored,
/// as cpfg ignores it.
fn headerless(src: &TextFile, lines: &[(usize, &str)]) -> Result<Contour, Box<LsystemError>> {
    let err = |at: usize, len: usize, what: &str| src.error(at, len, what, "here");
    let (at0, first) = lines[0];
    let words: Vec<&str> = first.split_whitespace().collect();
    let (num, dim, kind) = match words.as_slice() {
        [n, d, t, ..] => match (n.parse::<usize>(), d.parse::<usize>()) {
            (Ok(n), Ok(d)) => (n, d, *t),
            _ => (0, 0, ""),
        },
        _ => (0, 0, ""),
    };
    if kind.is_empty() {
        return Err(err(
            at0,
            first.len(),
            &format!(
                "`{}`: a contour file starts with `cver 1 N` or, in cpfg's oldest layout, with `num dim                  open|closed` (whole numbers: control points, coordinates per point)",
                excerpt(first)
            ),
        ));
    }
    if !(2..=3).contains(&dim) {
        return Err(err(at0, first.len(), &format!("a contour's points have 2 or 3 coordinates, not {dim}")));
    }
    let closed = kind == "closed";
    let need = if closed { 3 } else { 4 };
    if num > MAX_POINTS || num < need {
        return Err(err(
            at0,
            first.len(),
            &format!(
                "a{} contour needs {need} to {MAX_POINTS} control points (it says {num})",
                if closed { " closed" } else { "n open" }
            ),
        ));
    }
    // The numbers after the first line, with their places.
    let mut numbers = lines[1..].iter().flat_map(|&(at, body)| {
        body.split_whitespace().map(move |w| (at + (w.as_ptr() as usize - body.as_ptr() as usize), w))
    });
    let mut control = Vec::with_capacity(num);
    let mut last = (at0, first.len());
    for i in 0..num {
        let mut p = [0.0; 3];
        for c in p.iter_mut().take(dim) {
            let Some((at, w)) = numbers.next() else {
                return Err(err(
                    last.0,
                    last.1,
                    &format!("the file ends in control point {} of the {num} its first line promises", i + 1),
                ));
            };
            last = (at, w.len());
            *c = super::number(w).ok_or_else(|| {
                err(at, w.len(), &format!("`{}` in control point {}: not a finite number", excerpt(w), i + 1))
            })?;
        }
        control.push(DVec3::from(p));
    }
    let c = Contour { name: None, closed, end_point: false, samples: None, distinct: num, control };
    let length = c.length();
    if length.is_nan() || length <= 1e-12 {
        return Err(err(at0, first.len(), "the contour has zero length (all its control points coincide)"));
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LINE: &str = "cver 1 3\nname: l\npoints: 2 6\ntype: or\nsamples: 4\n0 0 0 3\n2 0 0 3\n";

    #[test]
    fn an_open_clamped_line_is_sampled_by_arc_length() {
        let c = parse("line.con", LINE).unwrap();
        assert!(!c.closed && c.control.len() == 6 && c.distinct == 2 && c.segments() == 3);
        assert!((c.length() - 2.0).abs() < 1e-9);
        let s = c.sample(4);
        assert_eq!(s.len(), 5);
        for (i, p) in s.iter().enumerate() {
            assert!((*p - DVec2::new(0.5 * i as f64, 0.0)).length() < 1e-6, "{i}: {p}");
        }
    }

    #[test]
    fn a_closed_square_wraps_and_is_symmetric() {
        let t = "cver 1 2\nname: sq\npoints: 4 4\ntype: cr\n1 0 0 1\n0 1 0 1\n-1 0 0 1\n0 -1 0 1\n";
        let c = parse("sq.con", t).unwrap();
        assert!(c.closed && c.segments() == 4);
        let s = c.sample(8);
        assert_eq!(s.len(), 8);
        // The B-spline of a diamond is a rounded diamond, centred on the origin.
        let centre: DVec2 = s.iter().copied().sum::<DVec2>() / 8.0;
        assert!(centre.length() < 1e-6, "{centre}");
        assert!(s.iter().all(|p| (p.length() - 0.6).abs() < 0.1), "{s:?}");
    }

    /// cpfg's oldest layout: `num dim type`, then the points, one multiplicity each.
    #[test]
    fn the_headerless_layout_is_read_as_cpfg_reads_it() {
        let c = parse("old.con", "4 2 closed\n1 0\n0 1 -1 0\n\n0 -1\n# ignored after the points\n").unwrap();
        assert!(c.closed && c.distinct == 4 && c.segments() == 4 && c.name.is_none());
        assert_eq!(c.control[1], DVec3::new(0.0, 1.0, 0.0));
        let same = "cver 1 2\nname: sq\npoints: 4 4\ntype: cr\n1 0 0 1\n0 1 0 1\n-1 0 0 1\n0 -1 0 1\n";
        assert_eq!(c.sample(8), parse("sq.con", same).unwrap().sample(8));
        let o = parse("old.con", "6 3 open\n0 0 0\n0 0 0\n0 0 0\n2 0 5\n2 0 5\n2 0 5\n").unwrap();
        assert!(!o.closed && o.segments() == 3);
        assert_eq!(o.sample(4), parse("line.con", LINE).unwrap().sample(4));
    }

    #[test]
    fn bad_files_are_located_errors() {
        for (text, what, line) in [
            ("", "empty", 1),
            ("cver\n", "unsupported: contour format", 1),
            ("points: 3\n", "starts with `cver 1 N`", 1),
            ("5 2 open\n0 0 1 1\n", "ends in control point 3", 2),
            ("4 4 open\n", "2 or 3 coordinates", 1),
            ("2 2 open\n0 0 1 1\n", "needs 4 to", 1),
            ("4 2 open\n0 0 1 x 0 0 0 0\n", "`x` in control point 2", 2),
            ("cver 2 0\n", "unsupported: contour format", 1),
            ("cver 1 3\npoints: 2\n", "two whole numbers", 2),
            ("cver 1 3\npoints: 2 6\ntype: xr\n", "contour type", 3),
            ("cver 1 3\npoints: 2 6\ntype: or\n0 0 0 3\n", "samples:", 3),
            ("cver 1 2\npoints: 2 6\ntype: or\n0 0 0 3\n1 0 0 2\n", "ends after 2", 5),
            ("cver 1 2\npoints: 2 6\ntype: or\n0 0 0 3\n1 0 nan 3\n", "four finite numbers", 5),
            ("cver 1 2\npoints: 2 6\ntype: or\n0 0 0 3\n1 0 0 4\n", "add up to more", 5),
            ("cver 1 2\npoints: 2 6\ntype: or\n0 0 0 3\n1 0 0 1.5\n", "multiplicity", 5),
            ("cver 1 2\npoints: 1 6\ntype: or\n0 0 0 3\n1 0 0 3\n", "more control points", 5),
            ("cver 1 2\npoints: 2 3\ntype: or\n0 0 0 2\n1 0 0 1\n", "at least 4", 2),
            ("cver 1 2\npoints: 1 4\ntype: or\n1 1 0 4\n", "zero length", 2),
            ("cver 1 2\nfoo: 1\n", "unknown contour header key", 2),
            ("cver 1 2\npoints: 2 6\n0 0 0 3\n", "no `type:`", 2),
        ] {
            let e = parse("bad.con", text).unwrap_err();
            assert!(e.message.contains(what), "{text:?}: {}", e.message);
            assert!(e.message.starts_with(&format!("bad.con:{line}:")), "{text:?}: {}", e.message);
        }
    }
}
