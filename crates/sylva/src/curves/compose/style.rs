//! Styles: a layer's [`StyleSpec`] merged over the composition's, resolved and
//! checked, then applied to raw curves as tapered widths and colours (Xu2015 §7.3,
//! §8.1 on thickness at branchings).

use super::Raw;
use crate::curves::magnetic::Field;
use crate::curves::render::{parse_color, Curve, Paint, Rgba};
use crate::error::{Error, Result};
use rand::RngExt;
use rand_pcg::Pcg64;
use serde::Deserialize;

/// Drawing style; every key optional, merged layer over composition over defaults.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StyleSpec {
    /// Stroke width at a root curve's start (drawing units; default 3).
    pub width: Option<f64>,
    /// End width as a fraction of the start width (default 0.2; 1 = no taper).
    pub taper: Option<f64>,
    /// Width factor per branch generation (default 0.7).
    pub child_width: Option<f64>,
    /// Narrowest stroke (default 0.4).
    pub min_width: Option<f64>,
    /// Length of the blend from a parent's width, in parent widths (default 4).
    pub join: Option<f64>,
    /// Body colour `#rrggbb` (default `#202020`).
    pub color: Option<String>,
    /// Outline colour (no outline when absent).
    pub outline: Option<String>,
    /// Outline width on each side (default 1 when `outline` is set).
    pub outline_width: Option<f64>,
    /// Colours for `color_by = "depth" | "index" | "random"`.
    pub palette: Option<Vec<String>>,
    /// `solid` (default), `depth`, `index`, `random` (a palette entry, or uniform RGB
    /// when the palette is empty) or `noise` (Fig. 7.6: one channel from the local
    /// noise, the others 0).
    pub color_by: Option<String>,
    /// Channel for `color_by = "noise"`: `red`, `green`, `blue` or `random` per curve.
    pub noise_channel: Option<String>,
}

impl StyleSpec {
    pub(super) fn over(&self, base: &StyleSpec) -> StyleSpec {
        StyleSpec {
            width: self.width.or(base.width),
            taper: self.taper.or(base.taper),
            child_width: self.child_width.or(base.child_width),
            min_width: self.min_width.or(base.min_width),
            join: self.join.or(base.join),
            color: self.color.clone().or_else(|| base.color.clone()),
            outline: self.outline.clone().or_else(|| base.outline.clone()),
            outline_width: self.outline_width.or(base.outline_width),
            palette: self.palette.clone().or_else(|| base.palette.clone()),
            color_by: self.color_by.clone().or_else(|| base.color_by.clone()),
            noise_channel: self.noise_channel.clone().or_else(|| base.noise_channel.clone()),
        }
    }

    fn resolve(&self, what: &str) -> Result<Style> {
        let width = self.width.unwrap_or(3.0);
        let taper = self.taper.unwrap_or(0.2);
        let child_width = self.child_width.unwrap_or(0.7);
        let min_width = self.min_width.unwrap_or(0.4);
        let join = self.join.unwrap_or(4.0);
        for (k, v) in [
            ("width", width),
            ("taper", taper),
            ("child_width", child_width),
            ("min_width", min_width),
            ("join", join),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::Recipe(format!("{what}: style.{k} = {v} must be a number ≥ 0")));
            }
        }
        let color = parse_color(self.color.as_deref().unwrap_or("#202020"), &format!("{what}: style.color"))?;
        let outline = match &self.outline {
            Some(c) => {
                let w = self.outline_width.unwrap_or(1.0);
                if !(w.is_finite() && w >= 0.0) {
                    return Err(Error::Recipe(format!("{what}: style.outline_width = {w} must be ≥ 0")));
                }
                Some((parse_color(c, &format!("{what}: style.outline"))?, w))
            }
            None => None,
        };
        let palette = self
            .palette
            .iter()
            .flatten()
            .map(|c| parse_color(c, &format!("{what}: style.palette")))
            .collect::<Result<Vec<_>>>()?;
        let color_by = match self.color_by.as_deref().unwrap_or("solid") {
            "solid" => ColorBy::Solid,
            "depth" => ColorBy::Depth,
            "index" => ColorBy::Index,
            "random" => ColorBy::Random,
            "noise" => ColorBy::Noise,
            other => {
                return Err(Error::Recipe(format!(
                    "{what}: style.color_by = `{other}`; use solid, depth, index, random or noise"
                )))
            }
        };
        if matches!(color_by, ColorBy::Depth | ColorBy::Index) && palette.is_empty() {
            return Err(Error::Recipe(format!("{what}: style.color_by = depth/index needs a style.palette")));
        }
        let channel = match self.noise_channel.as_deref().unwrap_or("red") {
            "red" => Some(0),
            "green" => Some(1),
            "blue" => Some(2),
            "random" => None,
            other => {
                return Err(Error::Recipe(format!(
                    "{what}: style.noise_channel = `{other}`; use red, green, blue or random"
                )))
            }
        };
        Ok(Style { width, taper, child_width, min_width, join, color, outline, palette, color_by, channel })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ColorBy {
    Solid,
    Depth,
    Index,
    Random,
    Noise,
}

/// A resolved style.
#[derive(Debug, Clone, PartialEq)]
struct Style {
    width: f64,
    taper: f64,
    child_width: f64,
    min_width: f64,
    join: f64,
    color: Rgba,
    outline: Option<(Rgba, f64)>,
    palette: Vec<Rgba>,
    color_by: ColorBy,
    channel: Option<usize>,
}

/// Applies widths and colours to a layer's raw curves. `offset` is the index of the
/// layer's first curve in the drawing (parents are layer-local in `raws`).
pub(super) fn style_curves(
    raws: &[Raw],
    layer_style: &StyleSpec,
    what: &str,
    field: Option<&Field>,
    rng: &mut Pcg64,
    offset: usize,
) -> Result<Vec<Curve>> {
    let base = layer_style.resolve(what)?;
    let mut out: Vec<Curve> = Vec::with_capacity(raws.len());
    for (i, r) in raws.iter().enumerate() {
        let style = match &r.style {
            Some(s) => s.over(layer_style).resolve(what)?,
            None => base.clone(),
        };
        let n = r.points.len();
        let mut cum = Vec::with_capacity(n);
        let mut s = 0.0;
        for (j, p) in r.points.iter().enumerate() {
            if j > 0 {
                s += r.points[j - 1].distance(*p);
            }
            cum.push(s);
        }
        let total = s.max(1e-12);
        let (w0, taper) = if r.magnetic {
            (style.width * style.child_width.powi(r.depth as i32), style.taper)
        } else {
            (style.width, if layer_style.taper.is_some() { style.taper } else { 1.0 })
        };
        let attach = r.parent.and_then(|(p, k)| out.get(p).and_then(|c| c.widths.get(k)).copied());
        let mut widths = Vec::with_capacity(n);
        for &c in &cum {
            let u = c / total;
            let mut w = w0 * (1.0 - u * (1.0 - taper));
            if let Some(wa) = attach {
                // Blend from the parent's width with a smoothstep over `join` widths.
                let l = (style.join * wa).max(1e-9);
                let x = (c / l).min(1.0);
                let sm = x * x * (3.0 - 2.0 * x);
                w = wa * (1.0 - sm) + w * sm;
            }
            widths.push(w.max(style.min_width));
        }
        let paint = match (r.color, style.color_by) {
            (Some(c), _) => Paint::Solid(c),
            (None, ColorBy::Solid) => Paint::Solid(style.color),
            (None, ColorBy::Depth) => Paint::Solid(style.palette[r.depth as usize % style.palette.len()]),
            (None, ColorBy::Index) => Paint::Solid(style.palette[i % style.palette.len()]),
            (None, ColorBy::Random) => {
                if style.palette.is_empty() {
                    let c = [rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>()];
                    Paint::Solid([
                        (c[0] * 255.0).round() as u8,
                        (c[1] * 255.0).round() as u8,
                        (c[2] * 255.0).round() as u8,
                        255,
                    ])
                } else {
                    let k = ((rng.random::<f64>() * style.palette.len() as f64) as usize)
                        .min(style.palette.len() - 1);
                    Paint::Solid(style.palette[k])
                }
            }
            (None, ColorBy::Noise) => {
                let channel = style.channel.unwrap_or_else(|| ((rng.random::<f64>() * 3.0) as usize).min(2));
                let colors = r
                    .points
                    .iter()
                    .map(|p| {
                        let v = field.map_or(0.0, |f| f.noise(*p));
                        let mut c = [0u8, 0, 0, 255];
                        // Perlin values rarely leave ±0.6: stretch them so the channel
                        // spans most of [0, 255].
                        c[channel] = (0.5 * (1.0 + 1.6 * v) * 255.0).round().clamp(0.0, 255.0) as u8;
                        c
                    })
                    .collect();
                Paint::PerPoint(colors)
            }
        };
        out.push(Curve {
            points: r.points.clone(),
            widths,
            paint,
            outline: style.outline,
            magnetic: r.magnetic,
            parent: r.parent.map(|(p, k)| (p + offset, k)),
            depth: r.depth,
        });
    }
    Ok(out)
}
