//! Rendering magnetic curves: tapered strokes with outlines and per-curve or per-point
//! colours, turned into filled polygons that both the SVG writer
//! ([`crate::curves::svg`]) and the anti-aliased PNG rasterizer (`tiny-skia`) draw
//! (Xu2015 §7.3: "each curve has a thickness and the outer contour has a different
//! colour"; Xu2015-spec §3.8).
//!
//! # From curves to shapes
//!
//! A [`Drawing`] holds curves in drawing units with **y up** (the particle's plane).
//! [`picture`] turns each curve into one or more [`Shape`]s — closed polygons in
//! picture coordinates (y down, the same units) with a solid colour:
//!
//! 1. Width varies along the curve (`widths`, the full width at each point). The
//!    outline polygon is the left offset `p + n·w/2` forwards, a round cap, the right
//!    offset backwards and a round start cap. At each point the half width is clamped
//!    to 0.9 times the local radius of curvature (magnetic curves) so the inner offset
//!    never folds back on itself at a spiral's centre; drawn polylines use mitred
//!    joins instead. Every polygon winds the same way, so the non-zero fill rule
//!    paints the union of a curve that crosses itself without holes.
//! 2. An outline colour draws the same stroke `2·outline` wider first, then the body on
//!    top, curve after curve, so crossing strands look layered (the hair of Fig. 7.10).
//! 3. Per-point colours (Fig. 7.6, coloured from the local noise) split the stroke into
//!    runs of [`RUN`] segments, each filled with the colour at its middle; runs overlap
//!    by one segment so anti-aliasing leaves no seams.
//! 4. Before offsetting, each centre line is simplified ([`simplify`], one pass) to half
//!    the caller's `tolerance` in drawing units — the one explicit accuracy parameter;
//!    the writers pass 0.2 output pixels — so a curve traced at one point per unit does
//!    not cost one edge per unit at a small output size.
//!
//! The same shapes go to SVG (`<path>` per shape: paths, not pixels) and to the PNG
//! rasterizer, so both outputs agree.

use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use glam::{DVec2, Vec2};
use std::path::Path;

use super::magnetic::curvature;

/// Segments per colour run of a per-point coloured curve.
pub const RUN: usize = 6;

/// Largest raster the PNG writer makes (either side, pixels).
pub const MAX_PIXELS_SIDE: u32 = 16_384;

/// Most pixels of one raster (64 Mpx, 256 MiB of RGBA).
pub const MAX_PIXELS: u64 = 1 << 26;

/// An sRGB colour with alpha, 8 bits per channel.
pub type Rgba = [u8; 4];

/// How a curve's body is coloured.
#[derive(Debug, Clone, PartialEq)]
pub enum Paint {
    /// One colour.
    Solid(Rgba),
    /// One colour per point.
    PerPoint(Vec<Rgba>),
}

/// One curve to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// Points in drawing units, y up.
    pub points: Vec<DVec2>,
    /// Full stroke width at each point (same length as `points`).
    pub widths: Vec<f64>,
    /// Body colour.
    pub paint: Paint,
    /// Outline colour and width added on each side, if any.
    pub outline: Option<(Rgba, f64)>,
    /// A traced magnetic curve (true) or a drawn polyline such as a hairline or a
    /// window frame (false; mitred joins, not counted as a curve).
    pub magnetic: bool,
    /// `(parent curve, point index)` for branches.
    pub parent: Option<(usize, usize)>,
    /// Branch generation (0 for roots).
    pub depth: u32,
}

/// A composition's output: curves on a canvas.
#[derive(Debug, Clone, PartialEq)]
pub struct Drawing {
    /// Canvas width in drawing units.
    pub width: f64,
    /// Canvas height in drawing units.
    pub height: f64,
    /// Background colour; `None` leaves it transparent.
    pub background: Option<Rgba>,
    /// The curves, in drawing order.
    pub curves: Vec<Curve>,
}

impl Drawing {
    /// The number of magnetic curves (what Table 7.1 counts).
    pub fn magnetic_count(&self) -> usize {
        self.curves.iter().filter(|c| c.magnetic).count()
    }

    /// Total number of points of all curves.
    pub fn point_count(&self) -> usize {
        self.curves.iter().map(|c| c.points.len()).sum()
    }
}

/// A filled polygon of a [`Picture`].
#[derive(Debug, Clone, PartialEq)]
pub struct Shape {
    /// Closed outline, picture coordinates (y down).
    pub polygon: Vec<Vec2>,
    /// Fill colour.
    pub color: Rgba,
}

/// Filled shapes ready for SVG or raster output.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    /// Width in drawing units.
    pub width: f64,
    /// Height in drawing units.
    pub height: f64,
    /// Background colour.
    pub background: Option<Rgba>,
    /// Shapes, painted in order.
    pub shapes: Vec<Shape>,
}

/// The tolerance the writers use: 0.2 output pixels, in drawing units, for a drawing
/// `width_px` pixels wide.
pub fn tolerance_for(drawing: &Drawing, width_px: u32) -> f64 {
    0.2 * drawing.width / width_px.max(1) as f64
}

/// Turns a drawing into filled shapes (see the module docs), simplifying outlines to
/// `tolerance` drawing units (0 keeps every point). Curves with fewer than two distinct
/// points, or with non-finite numbers, are skipped.
pub fn picture(drawing: &Drawing, tolerance: f64) -> Picture {
    let mut shapes = Vec::new();
    let h = drawing.height;
    let tol = if tolerance.is_finite() { tolerance.max(0.0) } else { 0.0 };
    for c in &drawing.curves {
        let Some(stroke) = Stroke::new(c, tol) else { continue };
        if let Some((color, ow)) = c.outline {
            if ow > 0.0 && ow.is_finite() {
                let o = stroke.offsets(ow, c.magnetic);
                shapes.push(Shape { polygon: o.polygon(0, o.len() - 1, h, true), color });
            }
        }
        let o = stroke.offsets(0.0, c.magnetic);
        match &stroke.colors {
            None => shapes.push(Shape { polygon: o.polygon(0, o.len() - 1, h, true), color: stroke.solid }),
            Some(colors) => {
                let n = o.len();
                let mut a = 0;
                while a + 1 < n {
                    let b = (a + RUN).min(n - 1);
                    let color = colors[(a + b) / 2];
                    // Overlap the previous run by one segment.
                    shapes.push(Shape { polygon: o.polygon(a.saturating_sub(1), b, h, a == 0), color });
                    a = b;
                }
            }
        }
    }
    Picture { width: drawing.width, height: drawing.height, background: drawing.background, shapes }
}

/// A curve's points with duplicates removed, and their widths and colours.
struct Stroke {
    points: Vec<DVec2>,
    /// Signed curvature per point (magnetic curves only).
    kappa: Vec<f64>,
    half: Vec<f64>,
    colors: Option<Vec<Rgba>>,
    solid: Rgba,
}

/// Left and right offset polylines plus cap data.
struct Offsets {
    points: Vec<DVec2>,
    left: Vec<DVec2>,
    right: Vec<DVec2>,
    half: Vec<f64>,
    tangent_start: DVec2,
    tangent_end: DVec2,
}

impl Stroke {
    fn new(c: &Curve, tol: f64) -> Option<Stroke> {
        let mut points = Vec::with_capacity(c.points.len());
        let mut half = Vec::with_capacity(c.points.len());
        let per_point = match &c.paint {
            Paint::PerPoint(v) if v.len() == c.points.len() => Some(v),
            _ => None,
        };
        let mut colors = per_point.map(|_| Vec::with_capacity(c.points.len()));
        for (i, &p) in c.points.iter().enumerate() {
            let w = c.widths.get(i).copied().unwrap_or(1.0);
            if !p.is_finite() || !w.is_finite() {
                return None;
            }
            if points.last().is_some_and(|q: &DVec2| q.distance_squared(p) < 1e-18) {
                continue;
            }
            points.push(p);
            half.push(0.5 * w.max(0.0));
            if let (Some(cs), Some(v)) = (colors.as_mut(), per_point) {
                cs.push(v[i]);
            }
        }
        if points.len() < 2 {
            return None;
        }
        let solid = match &c.paint {
            Paint::Solid(s) => *s,
            Paint::PerPoint(v) => v.first().copied().unwrap_or([0, 0, 0, 255]),
        };
        let kappa = if c.magnetic { curvature(&points) } else { Vec::new() };
        let mut stroke = Stroke { points, kappa, half, colors, solid };
        stroke.simplify(tol);
        Some(stroke)
    }

    /// Drops centre-line points within `tol / 2` of the kept polyline (and whose width
    /// is within `tol / 2` of the run's); a kept point's curvature becomes the largest
    /// of its run, so the width clamp stays conservative.
    fn simplify(&mut self, tol: f64) {
        if tol <= 0.0 {
            return;
        }
        let mut keep = Vec::new();
        // Per-point colours change along the curve: keep runs short enough for them.
        let max_run = if self.colors.is_some() { 8 } else { MAX_RUN };
        simplify_with(&self.points, Some(&self.half), 0.5 * tol, max_run, &mut keep);
        if keep.len() == self.points.len() {
            return;
        }
        let pick = |v: &[DVec2]| keep.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let points = pick(&self.points);
        let half = keep.iter().map(|&i| self.half[i]).collect();
        let kappa = if self.kappa.is_empty() {
            Vec::new()
        } else {
            let mut k = Vec::with_capacity(keep.len());
            let mut prev = 0;
            for &i in &keep {
                let run = &self.kappa[prev..=i];
                k.push(run.iter().fold(0.0f64, |m, x| m.max(x.abs())));
                prev = i;
            }
            k
        };
        let colors = self.colors.as_ref().map(|c| keep.iter().map(|&i| c[i]).collect());
        (self.points, self.half, self.kappa, self.colors) = (points, half, kappa, colors);
    }

    /// Offsets at half width + `extra`.
    fn offsets(&self, extra: f64, magnetic: bool) -> Offsets {
        let p = &self.points;
        let n = p.len();
        let kappa = &self.kappa;
        let mut left = Vec::with_capacity(n);
        let mut right = Vec::with_capacity(n);
        let mut half = Vec::with_capacity(n);
        let dir = |a: DVec2, b: DVec2| (b - a).normalize_or(DVec2::X);
        for i in 0..n {
            let t_in = if i > 0 { dir(p[i - 1], p[i]) } else { dir(p[0], p[1]) };
            let t_out = if i + 1 < n { dir(p[i], p[i + 1]) } else { t_in };
            let t = (t_in + t_out).normalize_or(t_out);
            let normal = t.perp();
            let mut hw = self.half[i] + extra;
            if magnetic {
                let k = kappa[i].abs();
                if k > 0.0 {
                    hw = hw.min(0.9 / k);
                }
            } else {
                // Mitre: keep the stroke's thickness at a corner, clamped at 2×.
                let c = t.dot(t_out).abs().max(0.5);
                hw /= c;
            }
            left.push(p[i] + normal * hw);
            right.push(p[i] - normal * hw);
            half.push(hw);
        }
        Offsets {
            points: p.clone(),
            left,
            right,
            half,
            tangent_start: dir(p[0], p[1]),
            tangent_end: dir(p[n - 2], p[n - 1]),
        }
    }
}

impl Offsets {
    fn len(&self) -> usize {
        self.points.len()
    }

    /// The closed outline of points `a..=b`, with a round cap at the curve's end when
    /// `b` is the last point and at its start when `a` is 0 and `start_cap` holds, in
    /// picture coordinates (y flipped about `height`).
    fn polygon(&self, a: usize, b: usize, height: f64, start_cap: bool) -> Vec<Vec2> {
        let n = self.len();
        let mut out = Vec::with_capacity(2 * (b - a + 1) + 34);
        let flip = |p: DVec2| Vec2::new(p.x as f32, (height - p.y) as f32);
        out.extend(self.left[a..=b].iter().map(|&p| flip(p)));
        if b == n - 1 {
            cap(&mut out, self.points[b], self.tangent_end, self.half[b], true, &flip);
        }
        out.extend(self.right[a..=b].iter().rev().map(|&p| flip(p)));
        if a == 0 && start_cap {
            cap(&mut out, self.points[a], self.tangent_start, self.half[a], false, &flip);
        }
        out
    }
}

/// Longest run of points one kept segment may replace in [`simplify`].
pub const MAX_RUN: usize = 64;

/// Polyline simplification in one pass: the indices of `pts` to keep so that no dropped
/// point lies farther than `tol` from the kept segment that replaces it (first and last
/// always kept), in increasing order. From each kept point it keeps the cone of
/// directions that pass within `tol` of every point so far (a sleeve / cone-intersection
/// method) and ends the segment at the last point inside the cone; runs are at most
/// [`MAX_RUN`] points and must move away from their anchor. O(n), a square root per
/// point.
pub fn simplify(pts: &[DVec2], tol: f64, keep: &mut Vec<usize>) {
    simplify_with(pts, None, tol, MAX_RUN, keep);
}

/// [`simplify`] with runs of at most `max_run` points that also end when `extra` (e.g.
/// a half width) changes by more than `tol` from the run's anchor.
fn simplify_with(pts: &[DVec2], extra: Option<&[f64]>, tol: f64, max_run: usize, keep: &mut Vec<usize>) {
    keep.clear();
    let n = pts.len();
    if n <= 2 || tol.is_nan() || tol <= 0.0 {
        keep.extend(0..n);
        return;
    }
    keep.push(0);
    let mut a = 0;
    loop {
        let pa = pts[a];
        let (mut left, mut right, mut first) = (DVec2::ZERO, DVec2::ZERO, DVec2::ZERO);
        let mut have_cone = false;
        let mut rmax: f64 = 0.0;
        let mut j = a + 1;
        while j < n {
            if j - a > max_run || extra.is_some_and(|e| (e[j] - e[a]).abs() > tol) {
                break;
            }
            let v = pts[j] - pa;
            let r = v.length();
            if r <= tol {
                j += 1;
                continue;
            }
            let u = v / r;
            if have_cone
                && (right.perp_dot(u) < 0.0
                    || u.perp_dot(left) < 0.0
                    || r < rmax - tol
                    || u.dot(first) <= 0.0)
            {
                break;
            }
            // The directions within asin(tol / r) of u reach within tol of this point.
            let sn = tol / r;
            let cs = (1.0 - sn * sn).max(0.0).sqrt();
            let bl = u * cs + u.perp() * sn;
            let br = u * cs - u.perp() * sn;
            if !have_cone {
                (left, right, first, have_cone) = (bl, br, u, true);
            } else {
                if left.perp_dot(bl) < 0.0 {
                    left = bl;
                }
                if right.perp_dot(br) > 0.0 {
                    right = br;
                }
            }
            rmax = rmax.max(r);
            j += 1;
        }
        if j >= n {
            keep.push(n - 1);
            return;
        }
        // j failed; j − 1 is the last point the segment can reach.
        a = (j - 1).max(a + 1);
        if a >= n - 1 {
            keep.push(n - 1);
            return;
        }
        keep.push(a);
    }
}

/// Appends the interior points of a half-circle cap from the left offset to the right
/// one (`end`) or from the right to the left (start).
fn cap(out: &mut Vec<Vec2>, c: DVec2, t: DVec2, h: f64, end: bool, flip: &impl Fn(DVec2) -> Vec2) {
    if h < 0.05 {
        return;
    }
    let k = ((h * std::f64::consts::PI / 1.5).ceil() as usize).clamp(2, 16);
    let n = t.perp();
    for j in 1..k {
        let phi = std::f64::consts::PI * j as f64 / k as f64;
        let (s, co) = phi.sin_cos();
        let v = if end { n * co + t * s } else { -n * co - t * s };
        out.push(flip(c + v * h));
    }
}

/// The raster [`rasterize`] returns: the one image type, RGB (3 channels) over an opaque
/// background, else RGBA, not premultiplied; rows top to bottom.
pub type Raster = crate::image::Image;

/// Pixel size for a picture drawn `width_px` wide (height from the aspect ratio).
pub fn pixel_size(picture: &Picture, width_px: u32) -> Result<(u32, u32)> {
    if width_px == 0 || width_px > MAX_PIXELS_SIDE {
        return Err(Error::Recipe(format!("image size {width_px} px must be in 1..={MAX_PIXELS_SIDE}")));
    }
    if !(picture.width > 0.0
        && picture.height > 0.0
        && picture.width.is_finite()
        && picture.height.is_finite())
    {
        return Err(Error::InvalidGeometry {
            what: "curves drawing".into(),
            why: format!("canvas {} × {} must be positive", picture.width, picture.height),
        });
    }
    let h = (width_px as f64 * picture.height / picture.width).round().max(1.0);
    if h > MAX_PIXELS_SIDE as f64 {
        return Err(Error::Recipe(format!(
            "image height {h} px exceeds {MAX_PIXELS_SIDE}; lower the size or change the canvas aspect"
        )));
    }
    if width_px as f64 * h > MAX_PIXELS as f64 {
        return Err(Error::Recipe(format!(
            "a {width_px} × {h} image has more than {MAX_PIXELS} pixels; lower the size"
        )));
    }
    Ok((width_px, h as u32))
}

/// Horizontal bands rasterized in parallel. A fixed count, so the pixels never depend on
/// the number of threads.
const BANDS: u32 = 4;

/// Rasterizes `picture` `width_px` pixels wide with anti-aliasing (tiny-skia, non-zero
/// fill rule). The canvas is cut into `BANDS` horizontal bands drawn in parallel
/// (rayon), each with every path shifted up by the band's first row; coverage is
/// computed per pixel, so the bands meet seamlessly.
pub fn rasterize(picture: &Picture, width_px: u32) -> Result<Raster> {
    use rayon::prelude::*;
    use tiny_skia::{Color, FillRule, Paint as SkPaint, Path, PathBuilder, Pixmap, Transform};
    let (w, h) = pixel_size(picture, width_px)?;
    let sx = w as f32 / picture.width as f32;
    let sy = h as f32 / picture.height as f32;
    let paths: Vec<(Path, [u8; 4])> = picture
        .shapes
        .iter()
        .filter(|s| s.polygon.len() >= 3)
        .filter_map(|s| {
            let mut pb = PathBuilder::with_capacity(s.polygon.len() + 1, s.polygon.len());
            pb.move_to(s.polygon[0].x, s.polygon[0].y);
            for p in &s.polygon[1..] {
                pb.line_to(p.x, p.y);
            }
            pb.close();
            Some((pb.finish()?, s.color))
        })
        .collect();
    let band_h = h.div_ceil(BANDS).max(1);
    let bands: Vec<(u32, u32)> = (0..h).step_by(band_h as usize).map(|y0| (y0, band_h.min(h - y0))).collect();
    // Over an opaque background every pixel is opaque, and premultiplied equals straight:
    // the raster is RGB. Each band converts its own pixels.
    let opaque = picture.background.is_some_and(|c| c[3] == 255);
    let drawn: Vec<Option<Vec<u8>>> = bands
        .par_iter()
        .map(|&(y0, bh)| {
            let mut pixmap = Pixmap::new(w, bh)?;
            if let Some([r, g, b, a]) = picture.background {
                pixmap.fill(Color::from_rgba8(r, g, b, a));
            }
            let transform = Transform::from_scale(sx, sy).post_translate(0.0, -(y0 as f32));
            let mut paint = SkPaint { anti_alias: true, ..Default::default() };
            for (path, [r, g, b, a]) in &paths {
                paint.set_color_rgba8(*r, *g, *b, *a);
                pixmap.fill_path(path, &paint, FillRule::Winding, transform, None);
            }
            Some(if opaque {
                pixmap.data().chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect()
            } else {
                let straight = pixmap.pixels().iter().map(|px| px.demultiply());
                straight.flat_map(|c| [c.red(), c.green(), c.blue(), c.alpha()]).collect()
            })
        })
        .collect();
    let channels = if opaque { 3 } else { 4 };
    let mut data = Vec::with_capacity(w as usize * h as usize * channels as usize);
    for band in drawn {
        let band = band.ok_or_else(|| Error::InvalidGeometry {
            what: "curves raster".into(),
            why: format!("cannot allocate {w} × {band_h} pixels"),
        })?;
        data.extend_from_slice(&band);
    }
    Ok(Raster { width: w, height: h, channels, data })
}

/// Encodes a raster as an 8-bit PNG (RGB when it is opaque, RGBA otherwise) with the
/// "Up" filter and fdeflate's fastest mode: flat backgrounds and long strokes compress
/// well at a fraction of the adaptive filter's cost.
pub fn encode_png(raster: &Raster, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    raster.encode_png_with(w, png::Compression::Fastest)
}

/// Rasterizes `picture` `width_px` wide and writes it as a PNG, atomically.
pub fn write_png(picture: &Picture, path: &Path, width_px: u32) -> Result<()> {
    let raster = rasterize(picture, width_px)?;
    write_atomic(path, |w| encode_png(&raster, w))
}

/// Parses `#rgb`, `#rrggbb` or `#rrggbbaa`; `what` names the value in messages.
pub fn parse_color(s: &str, what: &str) -> Result<Rgba> {
    let bad = || Error::Recipe(format!("{what}: `{s}` is not a colour; write #rrggbb, #rrggbbaa or #rgb"));
    let hex = s.trim().strip_prefix('#').ok_or_else(bad)?;
    if !hex.bytes().all(|c| c.is_ascii_hexdigit()) {
        return Err(bad());
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).map_err(|_| bad());
    match hex.len() {
        3 => {
            let d = |i: usize| u8::from_str_radix(&hex[i..i + 1], 16).map(|v| v * 17).map_err(|_| bad());
            Ok([d(0)?, d(1)?, d(2)?, 255])
        }
        6 => Ok([byte(0)?, byte(2)?, byte(4)?, 255]),
        8 => Ok([byte(0)?, byte(2)?, byte(4)?, byte(6)?]),
        _ => Err(bad()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(magnetic: bool) -> Drawing {
        Drawing {
            width: 100.0,
            height: 50.0,
            background: Some([255, 255, 255, 255]),
            curves: vec![Curve {
                points: vec![DVec2::new(10.0, 25.0), DVec2::new(50.0, 25.0), DVec2::new(90.0, 25.0)],
                widths: vec![10.0, 10.0, 10.0],
                paint: Paint::Solid([255, 0, 0, 255]),
                outline: Some(([0, 0, 0, 255], 2.0)),
                magnetic,
                parent: None,
                depth: 0,
            }],
        }
    }

    #[test]
    fn bands_meet_without_seams() {
        // A vertical stroke through every band: each row of pixels must be the same,
        // including the rows on either side of a band boundary.
        let mut d = line(false);
        d.curves[0].points = vec![DVec2::new(50.3, -5.0), DVec2::new(50.3, 25.0), DVec2::new(50.3, 55.0)];
        d.curves[0].outline = None;
        let r = rasterize(&picture(&d, 0.0), 100).unwrap();
        assert_eq!((r.width, r.height), (100, 50));
        let stride = 100 * r.channels as usize;
        let row = |y: usize| &r.data[y * stride..(y + 1) * stride];
        assert!((0..100).any(|x| r.pixel(x, 0).unwrap()[1] < 128), "the stroke is drawn");
        for y in 1..50 {
            assert_eq!(row(y), row(0), "row {y} differs (band height {})", 50u32.div_ceil(BANDS));
        }
    }

    #[test]
    fn bands_place_shapes_at_their_rows() {
        // Band height 13 for a 50-row image: a stroke centred on the band boundary y = 13
        // covers rows 11..15 symmetrically, and one at y = 37.5 lands in its own rows.
        let mut d = line(false);
        d.curves[0].outline = None;
        d.curves[0].widths = vec![4.0; 3];
        d.curves[0].points = vec![DVec2::new(10.0, 13.0), DVec2::new(50.0, 13.0), DVec2::new(90.0, 13.0)];
        let mut low = d.curves[0].clone();
        low.points.iter_mut().for_each(|p| p.y = 37.5);
        d.curves.push(low);
        let r = rasterize(&picture(&d, 0.0), 100).unwrap();
        let px = |x: u32, y: u32| r.pixel(x, y).unwrap();
        // Pixel centres sit at half-integers, so the stroke at 13 covers [10.5, 14.5]: rows
        // 11–13 fully (across the boundary), rows 10 and 14 half.
        let green: Vec<u8> = (0..50).map(|y| px(50, y)[1]).collect();
        assert_eq!(&green[11..14], &[0, 0, 0], "{green:?}");
        assert!(
            (green[10] as i32 - green[14] as i32).abs() <= 1 && (100..156).contains(&green[10]),
            "{green:?}"
        );
        // The lower stroke, [35.5, 39.5], lands in its own rows, not one band up.
        assert_eq!(&green[35..39], &[0, 0, 0, 0], "{green:?}");
        assert!(green[15..35].iter().all(|&g| g == 255), "{green:?}");
    }

    #[test]
    fn stroke_covers_its_centre_line() {
        let pic = picture(&line(true), 0.0);
        assert_eq!(pic.shapes.len(), 2);
        let r = rasterize(&pic, 100).unwrap();
        assert_eq!((r.width, r.height), (100, 50));
        let px = |x: u32, y: u32| r.pixel(x, y).unwrap();
        assert_eq!(px(50, 25), [255, 0, 0, 255]);
        assert_eq!(px(50, 5), [255, 255, 255, 255]);
        // The outline ring: 5..7 px from the centre line.
        assert_eq!(px(50, 19), [0, 0, 0, 255]);
    }

    #[test]
    fn simplify_keeps_shape_within_tolerance() {
        let pts: Vec<DVec2> =
            (0..200).map(|i| DVec2::new(i as f64, (i as f64 * 0.05).sin() * 20.0)).collect();
        let mut keep = Vec::new();
        simplify(&pts, 0.1, &mut keep);
        assert!(keep.len() < 60 && keep.len() > 5, "{}", keep.len());
        assert_eq!((keep[0], *keep.last().unwrap()), (0, 199));
        for w in keep.windows(2) {
            let (a, b) = (pts[w[0]], pts[w[1]]);
            for p in &pts[w[0]..=w[1]] {
                let t = ((*p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                assert!((a + (b - a) * t).distance(*p) <= 0.1 + 1e-12);
            }
        }
        simplify(&pts, 0.0, &mut keep);
        assert_eq!(keep.len(), 200);
    }

    #[test]
    fn colours_parse() {
        assert_eq!(parse_color("#ff8000", "c").unwrap(), [255, 128, 0, 255]);
        assert_eq!(parse_color("#f80", "c").unwrap(), [255, 136, 0, 255]);
        assert_eq!(parse_color("#ff800080", "c").unwrap(), [255, 128, 0, 128]);
        assert!(parse_color("ff8000", "c").is_err());
        assert!(parse_color("#ff80", "c").is_err());
        assert!(parse_color("#ééé", "c").is_err());
    }
}
