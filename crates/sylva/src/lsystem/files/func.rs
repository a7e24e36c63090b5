//! cpfg function files (`*.func`) and function sets (`*.fset`): curves y(x) on \[0, 1\]
//! edited with vlab's `funcedit`, read by the L-system's `func(id, x)`.
//!
//! Part of the model-folder support of issue 3. A function is a **clamped uniform cubic
//! B-spline** (order 4) through its control points (x, y): with n + 1 control points
//! the knots are 0,0,0,0,1,2,…,n−3,n−2,n−2,n−2,n−2, so the curve starts at the first
//! point and ends at the last (cpfg `SplineFunction::P`). The value at x is the y of
//! the curve point whose x equals x, found as cpfg finds it: by bisection on the curve
//! parameter, stopping once the curve's x is within 0.001 of x
//! ([`Function::eval_bisected`]; [`Function::eval_exact`] bisects to full precision),
//! which assumes x grows along the curve, as funcedit enforces. Coordinates are read
//! as 32-bit floats, as cpfg reads them. Arguments outside \[0, 1\] are clamped (NaN is 0).
//!
//! # Formats
//!
//! Current (`fver 1 1`):
//!
//! ```text
//! fver 1 1
//! name: br_ang
//! samples: 10          precompute this many values (≤ 2: evaluate exactly)
//! flip: off            ignored (cpfg ignores it too)
//! points: 4
//! 0.000000 0.531316 1  x y [multiplicity: the point is repeated that many times]
//! …
//! ```
//!
//! Between `samples:` and `points:` any other header line (`flip:`, `background…`) is
//! ignored; `markers: k` skips the k marker lines that follow.
//!
//! Old (`range:`): `range: lo hi` (cpfg ignores the range and uses \[0, 1\]; so does
//! sylva), `points: n` and n lines `x y`. Its samples come from the view file's
//! `function: file samples` line ([`Function::set_samples`]).
//!
//! A function set (`*.fset`) is `funcgalleryver 1 1`, `items: k` and k functions in the
//! `fver` format; the functions keep the set's order.
//!
//! # Sampling
//!
//! Like cpfg, when `samples` > 2 the function is tabulated at `samples` evenly spaced
//! x (each by cpfg's bisection) and [`Function::eval`] interpolates that table
//! linearly, so values equal cpfg's; [`Function::eval_exact`] evaluates the curve
//! itself. At least four point lines are
//! required (cpfg's rule); multiplicities must be 1 to 16 and `samples` at most 65536.

use super::{number, tokens, TextFile};
use crate::input::excerpt;
use crate::lsystem::source::LsystemError;

/// How close cpfg's bisection brings the curve's x to the argument before it stops
/// ([`Function::eval_bisected`]).
pub const BISECTION_ERROR: f64 = 0.001;

/// The most samples a function may ask for.
pub const MAX_SAMPLES: u32 = 65_536;

/// Which header a function file had.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FunctionFormat {
    /// `fver 1 1`, with name and samples in the file.
    Fver,
    /// The old `range: lo hi` format.
    Range,
}

/// A cpfg function: a clamped cubic B-spline y(x) on \[0, 1\].
#[derive(Debug, Clone, PartialEq)]
pub struct Function {
    /// The `name:` of the function (`fver` format), if any.
    pub name: Option<String>,
    /// The header format.
    pub format: FunctionFormat,
    /// Control points (x, y), with multiplicities expanded.
    pub points: Vec<[f64; 2]>,
    /// Samples for the precomputed table, when more than 2.
    pub samples: Option<u32>,
    /// The `flip:` flag (cpfg ignores it).
    pub flip: bool,
    /// The `range:` of the old format (ignored for evaluation, as in cpfg).
    pub range: Option<[f64; 2]>,
    table: Vec<f64>,
}

impl Function {
    /// A function through the given control points (at least 4), evaluated exactly.
    /// Returns `None` when there are fewer than 4 points or a coordinate is not finite.
    pub fn from_points(points: Vec<[f64; 2]>) -> Option<Function> {
        if points.len() < 4 || points.iter().any(|p| !p[0].is_finite() || !p[1].is_finite()) {
            return None;
        }
        Some(Function {
            name: None,
            format: FunctionFormat::Fver,
            points,
            samples: None,
            flip: false,
            range: None,
            table: Vec::new(),
        })
    }

    /// cpfg's default for a function it cannot read: control points (0,0), (0,0),
    /// (0,0), (1,0), so y = 0 everywhere.
    pub fn cpfg_default() -> Function {
        let mut f = blank();
        f.points = vec![[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [1.0, 0.0]];
        f
    }

    /// Sets the number of precomputed samples (`None` or ≤ 2: evaluate exactly) and
    /// recomputes the table. Values above [`MAX_SAMPLES`] are clamped.
    pub fn set_samples(&mut self, samples: Option<u32>) {
        self.samples = samples.filter(|&s| s > 2).map(|s| s.min(MAX_SAMPLES));
        self.table.clear();
        if let Some(s) = self.samples {
            self.table = (0..s).map(|i| self.eval_bisected(i as f64 / (s - 1) as f64)).collect();
        }
    }

    /// The value at `x` as cpfg computes it: `x` clamped to \[0, 1\]; the linear
    /// interpolation of the sample table when there is one, else
    /// [`Function::eval_bisected`] (issue 46 item 8: cpfg's values, not the exact curve's).
    pub fn eval(&self, x: f64) -> f64 {
        let x = clamp01(x);
        let n = self.table.len();
        if n > 2 {
            let index = x * (n - 1) as f64;
            let i = (index.floor() as usize).min(n - 1);
            if i == n - 1 {
                return self.table[i];
            }
            let w = index - i as f64;
            return (1.0 - w) * self.table[i] + w * self.table[i + 1];
        }
        self.eval_bisected(x)
    }

    /// cpfg's `SplineFunction::_Value` without a table: bisection on the curve parameter
    /// t in \[0, 1\] (t = (lo + hi) / 2, then the half whose end the curve's x passes),
    /// stopping at the first t whose x is within [`BISECTION_ERROR`] (0.001) of `x`, and
    /// returning that point's y. So values are cpfg's, not the exact curve's: up to
    /// 0.001 × the slope away (`herb-lily`, `Ridley`). Gives up after 200 halvings
    /// (cpfg would loop forever) with the last point's y.
    pub fn eval_bisected(&self, x: f64) -> f64 {
        let x = clamp01(x);
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut p;
        let mut n = 0;
        loop {
            let mid = 0.5 * (lo + hi);
            p = self.point_at(mid);
            if p[0] > x {
                hi = mid;
            } else {
                lo = mid;
            }
            n += 1;
            if (p[0] - x).abs() <= BISECTION_ERROR || n >= 200 {
                return p[1];
            }
        }
    }

    /// The y of the curve point whose x is `x` (clamped to \[0, 1\]), found by bisection
    /// on the curve parameter to full precision (60 halvings).
    pub fn eval_exact(&self, x: f64) -> f64 {
        let x = clamp01(x);
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut p = self.point_at(0.5);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            p = self.point_at(mid);
            if p[0] > x {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        // Snap to the ends so that f(0) and f(1) are the end points exactly.
        if hi <= f64::EPSILON {
            return self.point_at(0.0)[1];
        }
        if lo >= 1.0 - f64::EPSILON {
            return self.point_at(1.0)[1];
        }
        p[1]
    }

    /// The curve point at parameter `t` in \[0, 1\] (clamped), by de Boor's algorithm.
    pub fn point_at(&self, t: f64) -> [f64; 2] {
        let pts = &self.points;
        if pts.len() < 4 {
            return pts.first().copied().unwrap_or([0.0, 0.0]);
        }
        let n = pts.len() - 1;
        let umax = (n - 2) as f64;
        let u = clamp01(t) * umax;
        let knot = |j: usize| -> f64 {
            if j < 4 {
                0.0
            } else if j > n {
                umax
            } else {
                (j - 3) as f64
            }
        };
        let k = ((u.floor() as usize) + 3).min(n);
        let mut d = [pts[k - 3], pts[k - 2], pts[k - 1], pts[k]];
        for r in 1..=3 {
            for j in (r..=3).rev() {
                let i = j + k - 3;
                let denom = knot(i + 4 - r) - knot(i);
                let a = if denom > 0.0 { (u - knot(i)) / denom } else { 0.0 };
                d[j] = [(1.0 - a) * d[j - 1][0] + a * d[j][0], (1.0 - a) * d[j - 1][1] + a * d[j][1]];
            }
        }
        d[3]
    }
}

/// A function with no points, to be filled in.
fn blank() -> Function {
    Function {
        name: None,
        format: FunctionFormat::Fver,
        points: Vec::new(),
        samples: None,
        flip: false,
        range: None,
        table: Vec::new(),
    }
}

fn clamp01(x: f64) -> f64 {
    if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0)
    }
}

/// A function set (`*.fset`): named functions in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct FunctionSet {
    /// (name, function) pairs; a function without `name:` is called `function<k>`
    /// (k counted from 1).
    pub functions: Vec<(String, Function)>,
}

/// Non-empty lines with their byte offsets.
struct Lines<'a> {
    lines: Vec<(usize, &'a str)>,
    next: usize,
    end: usize,
}

impl<'a> Lines<'a> {
    fn new(text: &'a str) -> Self {
        let mut lines = Vec::new();
        let mut at = 0;
        for raw in text.split_inclusive('\n') {
            let line = raw.trim_end_matches(['\n', '\r']);
            if !line.trim().is_empty() {
                lines.push((at, line));
            }
            at += raw.len();
        }
        Lines { lines, next: 0, end: text.len() }
    }

    fn next(&mut self) -> Option<(usize, &'a str)> {
        let l = self.lines.get(self.next).copied();
        self.next += 1;
        l
    }

    fn peek(&self) -> Option<(usize, &'a str)> {
        self.lines.get(self.next).copied()
    }
}

/// Splits `key: rest` (key compared case-insensitively); `None` if the line has no such key.
fn key_value<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    let t = line.trim_start();
    let colon = t.find(':')?;
    if t[..colon].trim().eq_ignore_ascii_case(key) {
        Some(&t[colon + 1..])
    } else {
        None
    }
}

/// Offset of `sub` (a slice of `line`) in the file, given the line's offset.
fn offset_in(line_at: usize, line: &str, sub: &str) -> usize {
    line_at + (sub.as_ptr() as usize).saturating_sub(line.as_ptr() as usize)
}

fn parse_count(
    file: &TextFile,
    line_at: usize,
    line: &str,
    value: &str,
    what: &str,
) -> Result<u64, Box<LsystemError>> {
    let at = offset_in(line_at, line, value);
    let toks = tokens(value, at, char::is_whitespace);
    match toks.first() {
        Some((o, t)) => t.parse::<u64>().map_err(|_| {
            file.error(
                *o,
                t.len(),
                &format!("invalid {what}: expected a whole number, found `{}`", excerpt(t)),
                "here",
            )
        }),
        None => Err(file.error(at, 1, &format!("`{what}:` needs a whole number"), "value missing")),
    }
}

fn parse_one(file: &TextFile, lines: &mut Lines) -> Result<Function, Box<LsystemError>> {
    let Some((at, first)) = lines.next() else {
        return Err(file.error(lines.end, 1, "expected a function (`fver 1 1` or `range:`)", "end of file"));
    };
    let mut f = blank();
    let mut samples: Option<(usize, u64)> = None;
    if let Some(v) = key_value(first, "range") {
        f.format = FunctionFormat::Range;
        let toks = tokens(v, offset_in(at, first, v), char::is_whitespace);
        let nums: Vec<Option<f64>> = toks.iter().take(2).map(|(_, t)| number(t)).collect();
        match nums.as_slice() {
            [Some(lo), Some(hi)] => f.range = Some([*lo, *hi]),
            _ => {
                return Err(file.error(at, first.len(), "`range:` needs two numbers", "malformed range"));
            }
        }
    } else if first.trim_start().starts_with("fver") {
        let toks = tokens(first, at, char::is_whitespace);
        let version: Vec<&str> = toks.iter().skip(1).map(|(_, t)| *t).collect();
        if version != ["1", "1"] {
            return Err(file.error(
                at,
                first.len(),
                &format!("unsupported function format `{}` (sylva reads `fver 1 1`)", excerpt(first.trim())),
                "version",
            ));
        }
        f.format = FunctionFormat::Fver;
    } else {
        return Err(file.error(
            at,
            first.len(),
            "expected `fver 1 1` or `range: lo hi` at the start of a function",
            "not a function header",
        ));
    }
    // Header lines up to `points:`.
    let count = loop {
        let Some((at, line)) = lines.next() else {
            return Err(file.error(lines.end, 1, "the function has no `points:` line", "end of file"));
        };
        if let Some(v) = key_value(line, "points") {
            break (at, parse_count(file, at, line, v, "points")?);
        } else if let Some(v) = key_value(line, "name") {
            let name = v.trim();
            f.name = (!name.is_empty()).then(|| name.to_string());
        } else if let Some(v) = key_value(line, "samples") {
            samples = Some((at, parse_count(file, at, line, v, "samples")?));
        } else if let Some(v) = key_value(line, "flip") {
            f.flip = v.trim().eq_ignore_ascii_case("on");
        } else if let Some(v) = key_value(line, "markers") {
            let k = parse_count(file, at, line, v, "markers")?;
            for _ in 0..k {
                if lines.next().is_none() {
                    break;
                }
            }
        } else if line.trim_start().starts_with("fver") || line.trim_start().starts_with("funcgalleryver") {
            return Err(file.error(
                at,
                line.len(),
                "the function has no `points:` line",
                "next function starts",
            ));
        }
        // Any other header line (background image, …) is ignored, as in cpfg.
    };
    let (points_at, n) = count;
    if n < 4 {
        return Err(file.error(
            points_at,
            1,
            &format!("a function needs at least 4 points, found {n}"),
            "too few points",
        ));
    }
    for k in 0..n {
        let Some((at, line)) = lines.next() else {
            return Err(file.error(
                lines.end,
                1,
                &format!("the file ends after {k} of the {n} points"),
                "end of file",
            ));
        };
        let toks = tokens(line, at, char::is_whitespace);
        if toks.len() < 2 || toks.len() > 3 {
            return Err(file.error(
                at,
                line.len(),
                "a point is `x y` or `x y multiplicity`",
                "malformed point",
            ));
        }
        let coord = |i: usize| -> Result<f64, Box<LsystemError>> {
            let (o, t) = toks[i];
            number(t).ok_or_else(|| {
                file.error(o, t.len(), &format!("expected a number, found `{}`", excerpt(t)), "not a number")
            })
        };
        let (x, y) = (coord(0)?, coord(1)?);
        let mult = match toks.get(2) {
            None => 1,
            Some((o, t)) => match number(t) {
                Some(m) if (1.0..=16.0).contains(&m) => m as usize,
                _ => {
                    return Err(file.error(
                        *o,
                        t.len(),
                        &format!("the multiplicity must be 1 to 16, found `{}`", excerpt(t)),
                        "multiplicity",
                    ));
                }
            },
        };
        // cpfg reads the coordinates as 32-bit floats (issue 46 item 8).
        let (x, y) = (x as f32 as f64, y as f32 as f64);
        for _ in 0..mult {
            f.points.push([x, y]);
        }
    }
    if let Some((at, s)) = samples {
        if s > MAX_SAMPLES as u64 {
            return Err(file.error(
                at,
                1,
                &format!("`samples: {s}` is more than {MAX_SAMPLES}"),
                "too many samples",
            ));
        }
        f.set_samples(Some(s as u32));
    }
    Ok(f)
}

/// Parses a function file (`fver 1 1` or old `range:` format). `name` is used in
/// error messages.
pub fn parse(name: &str, text: &str) -> Result<Function, Box<LsystemError>> {
    let file = TextFile::new(name, text);
    let mut lines = Lines::new(text);
    parse_one(&file, &mut lines)
}

/// Parses a function set file (`funcgalleryver 1 1`, `items: k`, k functions).
pub fn parse_set(name: &str, text: &str) -> Result<FunctionSet, Box<LsystemError>> {
    let file = TextFile::new(name, text);
    let mut lines = Lines::new(text);
    let Some((at, first)) = lines.next() else {
        return Err(file.error(0, 1, "empty function set (expected `funcgalleryver 1 1`)", "empty"));
    };
    if !first.trim_start().starts_with("funcgalleryver") {
        return Err(file.error(
            at,
            first.len(),
            "expected `funcgalleryver 1 1` at the start of a function set",
            "header",
        ));
    }
    let items = match lines.next() {
        Some((at, line)) => match key_value(line, "items") {
            Some(v) => parse_count(&file, at, line, v, "items")?,
            None => return Err(file.error(at, line.len(), "expected `items: k`", "items")),
        },
        None => return Err(file.error(lines.end, 1, "expected `items: k`", "end of file")),
    };
    let mut functions = Vec::new();
    for k in 0..items {
        if lines.peek().is_none() {
            return Err(file.error(
                lines.end,
                1,
                &format!("the set ends after {k} of its {items} functions"),
                "end of file",
            ));
        }
        let f = parse_one(&file, &mut lines)?;
        let name = f.name.clone().unwrap_or_else(|| format!("function{}", k + 1));
        functions.push((name, f));
    }
    Ok(FunctionSet { functions })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LINEAR: &str = "fver 1 1\nname: lin\nsamples: 0\nflip: off\npoints: 4\n0 0\n0.333333333333 0.333333333333\n0.666666666667 0.666666666667\n1 1\n";

    #[test]
    fn linear_function_is_linear() {
        let f = parse("lin.func", LINEAR).unwrap();
        assert_eq!(f.name.as_deref(), Some("lin"));
        for i in 0..=20 {
            let x = i as f64 / 20.0;
            // cpfg's bisection stops within 0.001 of x; the exact curve is x.
            assert!((f.eval(x) - x).abs() <= 1e-3, "f({x}) = {}", f.eval(x));
            assert!((f.eval_exact(x) - x).abs() < 1e-6, "f({x}) = {}", f.eval_exact(x));
        }
        assert_eq!(f.eval(-3.0), f.eval(0.0));
        assert_eq!(f.eval(7.0), f.eval(1.0));
        assert_eq!(f.eval(f64::NAN), f.eval(0.0));
    }

    #[test]
    fn end_points_interpolate_and_samples_agree() {
        let text = "fver 1 1\nname: rho\nsamples: 100\nflip: off\npoints: 4\n0.000000 0.317237 1\n0.413651 0.322316 1\n0.786984 0.192792 1\n1.000000 0.124221 1\n";
        let f = parse("rho.func", text).unwrap();
        assert!((f.eval_exact(0.0) - 0.317237f32 as f64).abs() < 1e-12);
        assert!((f.eval_exact(1.0) - 0.124221f32 as f64).abs() < 1e-12);
        assert!((f.eval(0.0) - 0.317237).abs() < 1e-4 && (f.eval(1.0) - 0.124221).abs() < 1e-3);
        for i in 0..=37 {
            let x = i as f64 / 37.0;
            assert!((f.eval(x) - f.eval_exact(x)).abs() < 1e-3);
        }
    }

    /// cpfg's bisection (issue 46 item 8): it stops at the first curve parameter whose x
    /// is within 0.001 of the argument, so at 0.3 on y = x² – like curves it returns
    /// that point's y, not the exact value; the table interpolates such values.
    #[test]
    fn bisection_stops_within_a_thousandth_as_cpfgs() {
        let f = parse("lin.func", LINEAR).unwrap();
        // x = 0.3: t = 0.5 (x 0.5), 0.25 (x 0.25), 0.375, 0.3125, 0.28125, 0.296875,
        // 0.3046875, 0.30078125 (|x − 0.3| = 0.00078 ≤ 0.001): stops there.
        assert!((f.eval_bisected(0.3) - 0.30078125).abs() < 1e-6, "{}", f.eval_bisected(0.3));
        assert!((f.eval_exact(0.3) - 0.3).abs() < 1e-6);
    }

    /// cpfg's recursive Cox–de Boor definition (`SplineFunction::N`).
    fn cpfg_point(pts: &[[f64; 2]], d: f64) -> [f64; 2] {
        let n = pts.len() as i64 - 1;
        let t = 4;
        let uk = |j: i64| -> i64 {
            if j < t {
                0
            } else if j > n {
                n - t + 2
            } else {
                j - t + 1
            }
        };
        fn nkt(k: i64, t: i64, u: f64, uk: &dyn Fn(i64) -> i64) -> f64 {
            if t == 1 {
                return if uk(k) as f64 <= u && u < uk(k + 1) as f64 { 1.0 } else { 0.0 };
            }
            let mut sum = 0.0;
            let div = uk(k + t - 1) - uk(k);
            if div != 0 {
                sum = (u - uk(k) as f64) / div as f64 * nkt(k, t - 1, u, uk);
            }
            let div = uk(k + t) - uk(k + 1);
            if div != 0 {
                sum += (uk(k + t) as f64 - u) / div as f64 * nkt(k + 1, t - 1, u, uk);
            }
            sum
        }
        let u = d * (n - t + 2) as f64;
        let mut s = [0.0, 0.0];
        for (k, p) in pts.iter().enumerate() {
            let w = nkt(k as i64, t, u, &uk);
            s[0] += p[0] * w;
            s[1] += p[1] * w;
        }
        s
    }

    #[test]
    fn de_boor_matches_cpfg_basis() {
        let pts = vec![[0.0, 0.0], [0.1, 0.5], [0.3, -0.2], [0.5, 0.9], [0.52, 0.1], [0.8, 0.3], [1.0, 1.0]];
        let f = Function::from_points(pts.clone()).unwrap();
        for i in 0..200 {
            let d = i as f64 / 200.0;
            let a = f.point_at(d);
            let b = cpfg_point(&pts, d);
            assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12, "{d}: {a:?} {b:?}");
        }
        assert_eq!(f.point_at(1.0), [1.0, 1.0]);
    }

    #[test]
    fn old_format_and_multiplicity() {
        let f = parse("a.func", "range: 0.0 1.0\npoints: 4\n0 0\n0.2 1\n0.8 1\n1 0\n").unwrap();
        assert_eq!(f.format, FunctionFormat::Range);
        assert_eq!(f.samples, None);
        let g = parse(
            "b.func",
            "fver 1 1\nname: b\nsamples: 10\nflip: off\npoints: 4\n0 0 1\n0.5 1 2\n1 0 1\n1 0\n",
        )
        .unwrap();
        assert_eq!(g.points.len(), 5);
    }

    #[test]
    fn function_set() {
        let text = "funcgalleryver 1 1\nitems: 2\nfver 1 1\nname: A\nsamples: 100\nflip: off\npoints: 4\n0 0\n0.3 0.3\n0.6 0.6\n1 1\nfver 1 1\nname: B\nsamples: 100\nflip: off\npoints: 4\n0 1\n0.3 1\n0.6 1\n1 1\n";
        let s = parse_set("s.fset", text).unwrap();
        assert_eq!(s.functions.len(), 2);
        assert_eq!(s.functions[1].0, "B");
        assert!((s.functions[1].1.eval(0.4) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn errors_are_located_and_garbage_is_safe() {
        let e = parse("x.func", "fver 1 1\nname: x\nsamples: 10\nflip: off\npoints: 4\n0 0\n0.5 zz\n")
            .unwrap_err();
        assert!(e.message.starts_with("x.func:7:5"), "{}", e.message);
        let e = parse("x.func", "fver 1 1\npoints: 3\n0 0\n1 1\n1 1\n").unwrap_err();
        assert!(e.message.contains("at least 4"), "{}", e.message);
        let e = parse("x.func", "range: 0 1\npoints: 5\n0 0\n1 1\n").unwrap_err();
        assert!(e.message.contains("after 2 of the 5"), "{}", e.message);
        for text in [
            "",
            "fver",
            "fver 1 1",
            "range:",
            "points: 99999999999999999999",
            "fver 1 1\npoints: 18446744073709551615\n",
            "funcgalleryver 1 1\nitems: 4000000000\n",
        ] {
            let _ = parse("g.func", text);
            let _ = parse_set("g.fset", text);
        }
    }
}
