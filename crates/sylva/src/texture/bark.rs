//! Bark maps (issue 23): albedo (sRGB), tangent-space normal and occlusion-roughness-
//! metallic (glTF's ORM packing: R occlusion, G roughness, B metallic) of one square
//! tile that repeats seamlessly around (u, image x) and along (v, image y) a branch.
//!
//! Each style is a height field over the tile built from periodic noise
//! ([`super::noise`]); the normal map is its gradient (central differences with wrap),
//! the occlusion its cavities, the albedo a colour ramp over height plus colour noise:
//!
//! - `smooth`: gentle mottling (beech, young stems, palms);
//! - `furrowed`: ridges and deep furrows running along the branch (oak, elm, willow);
//! - `plated`: cells cracked apart, longer than wide (pine, larch, fir);
//! - `birch`: pale bark with dark lenticels running around the stem and dark patches
//!   (birch, aspen).
//!
//! The normal map follows glTF's convention: +X towards +u, +Y towards +v of the mesh
//! (up in the image), +Z out of the surface.

use super::{srgb_byte, to_byte, Image};
use crate::noise::TileNoise;
use rayon::prelude::*;

/// A bark style (`textures.bark`; serde uses the names of [`BarkStyle::NAMES`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BarkStyle {
    /// Gentle mottling.
    Smooth,
    /// Ridges and furrows along the branch.
    Furrowed,
    /// Cracked plates.
    Plated,
    /// Pale bark with lenticels.
    Birch,
}

impl BarkStyle {
    /// The recipe names, in the order of the variants.
    pub const NAMES: [&'static str; 4] = ["smooth", "furrowed", "plated", "birch"];

    /// The style named `name` (`textures.bark`).
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "smooth" => BarkStyle::Smooth,
            "furrowed" => BarkStyle::Furrowed,
            "plated" => BarkStyle::Plated,
            "birch" => BarkStyle::Birch,
            _ => return None,
        })
    }

    /// The style's recipe name.
    pub fn name(&self) -> &'static str {
        Self::NAMES[*self as usize]
    }

    /// Bump depth as a fraction of the tile's width (the normal map's strength).
    fn depth(&self) -> f32 {
        match self {
            BarkStyle::Smooth => 0.006,
            BarkStyle::Furrowed => 0.03,
            BarkStyle::Plated => 0.025,
            BarkStyle::Birch => 0.008,
        }
    }
}

/// The three bark maps of one style and seed, shared: the texture cache and the models
/// that use them (a session keeps a copy per stage) copy no pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct BarkMaps {
    /// The style they show.
    pub style: BarkStyle,
    /// Base colour, sRGB, RGB.
    pub albedo: std::sync::Arc<Image>,
    /// Tangent-space normal, RGB (linear).
    pub normal: std::sync::Arc<Image>,
    /// Occlusion (R), roughness (G), metallic (B), linear.
    pub orm: std::sync::Arc<Image>,
}

/// Linear colours of a style's ramp: (cavity, mid, top).
fn palette(style: BarkStyle) -> [[f32; 3]; 3] {
    match style {
        BarkStyle::Smooth => [[0.10, 0.085, 0.07], [0.24, 0.21, 0.17], [0.36, 0.33, 0.28]],
        BarkStyle::Furrowed => [[0.035, 0.025, 0.018], [0.13, 0.095, 0.065], [0.26, 0.22, 0.18]],
        BarkStyle::Plated => [[0.03, 0.02, 0.015], [0.20, 0.09, 0.045], [0.33, 0.18, 0.10]],
        BarkStyle::Birch => [[0.02, 0.02, 0.02], [0.55, 0.53, 0.49], [0.80, 0.78, 0.73]],
    }
}

/// Smooth Hermite step of `x` between `a` and `b`.
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Height (0 cavity … 1 top), colour shift (−1 … 1) and roughness at tile point (s, t).
fn sample(style: BarkStyle, n: &TileNoise, s: f32, t: f32) -> (f32, f32, f32) {
    match style {
        BarkStyle::Smooth => {
            // Mottled patches, faint rings around the stem and fine grain.
            let patches = n.fbm(s * 4.0, t * 4.0, 4, 4, 3, 0.55);
            let rings = n.layer(5).perlin(s * 2.0, t * 28.0, 2, 28);
            let grain = n.layer(6).perlin(s * 48.0, t * 24.0, 48, 24);
            let h = (0.55 + 0.35 * patches + 0.08 * rings + 0.08 * grain).clamp(0.0, 1.0);
            let c = 1.6 * patches + 0.4 * grain;
            (h, c, 0.72 + 0.12 * h)
        }
        BarkStyle::Furrowed => {
            // Ridges along the branch (low frequency in t), wandering sideways.
            let warp = n.layer(3).fbm(s * 3.0, t * 3.0, 3, 3, 2, 0.5);
            let ridge = 1.0 - n.fbm(s * 9.0 + 1.8 * warp, t * 2.0, 9, 2, 3, 0.45).abs();
            let fine = n.layer(5).perlin(s * 24.0, t * 12.0, 24, 12);
            let h = (ridge * ridge * 0.85 + 0.15 * (0.5 + 0.5 * fine)).clamp(0.0, 1.0);
            (h, 0.6 * fine, 0.92 - 0.05 * h)
        }
        BarkStyle::Plated => {
            let warp = n.layer(3).fbm(s * 4.0, t * 4.0, 4, 4, 2, 0.5);
            let (f1, f2, id) = n.worley(s * 5.0 + 0.6 * warp, t * 3.0, 5, 3);
            let crack = smoothstep(0.02, 0.12, f2 - f1);
            let plate = n.layer(5).fbm(s * 20.0, t * 12.0, 20, 12, 2, 0.5);
            let tint = ((id >> 8) & 255) as f32 / 255.0 - 0.5;
            let h = crack * (0.75 + 0.15 * plate + 0.1 * (1.0 - f1).clamp(0.0, 1.0));
            (h.clamp(0.0, 1.0), 0.8 * tint + 0.3 * plate, 0.88)
        }
        BarkStyle::Birch => {
            let lent = lenticel(n, s, t);
            let patch = smoothstep(0.35, 0.55, n.layer(9).fbm(s * 3.0, t * 5.0, 3, 5, 3, 0.55));
            let fine = n.layer(5).perlin(s * 16.0, t * 16.0, 16, 16);
            let h = (0.8 - 0.55 * lent - 0.25 * patch + 0.05 * fine).clamp(0.0, 1.0);
            // Lenticels and patches are dark: push them to the cavity colour.
            let c = 0.3 * fine - 1.6 * lent.max(patch);
            (h, c, 0.55 + 0.35 * lent.max(patch))
        }
    }
}

/// Birch lenticels: short dark dashes running around the stem (along s), one chance per
/// cell of an 8 × 36 grid, wrapping in both directions. 0 … 1 (1 inside a dash).
fn lenticel(n: &TileNoise, s: f32, t: f32) -> f32 {
    let (cols, rows) = (8, 36);
    let (x, y) = (s * cols as f32, t * rows as f32);
    let (ix, iy) = (x.floor() as i32, y.floor() as i32);
    let mut best = 0.0f32;
    for dx in -1..=1 {
        let cx = ix + dx;
        let h = n.layer(11).cell_hash(cx, iy, cols, rows);
        if h & 3 == 0 {
            continue; // no dash in one cell of four
        }
        let centre = cx as f32 + ((h >> 4) & 255) as f32 / 255.0;
        let half = 0.25 + 0.6 * ((h >> 12) & 255) as f32 / 255.0;
        let yc = iy as f32 + 0.3 + 0.4 * ((h >> 20) & 255) as f32 / 255.0;
        let (du, dv) = ((x - centre).abs() / half, (y - yc).abs() / 0.09);
        if du < 1.0 {
            best = best.max((1.0 - du * du) * (1.0 - smoothstep(0.5, 1.0, dv)));
        }
    }
    best
}

/// Generates the maps of `style` at `size` × `size` pixels for `seed`. Deterministic:
/// rows are computed in parallel but each pixel depends only on its position.
pub fn bark_maps(style: BarkStyle, size: u32, seed: u64) -> BarkMaps {
    let n = TileNoise::new(seed ^ 0xba4c_0000 ^ style as u64);
    let w = size.max(1) as usize;
    let inv = 1.0 / w as f32;
    // Height, colour shift and roughness per pixel, rows top to bottom (t = 1 − y).
    let mut fields = vec![(0.0f32, 0.0f32, 0.0f32); w * w];
    // A cancelled drawing ([`crate::cancel`]) skips its remaining rows: its maps are
    // partial and the caller drops them.
    let token = crate::cancel::current();
    let stop = || token.as_ref().is_some_and(crate::cancel::Cancel::is_cancelled);
    fields.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        if stop() {
            return;
        }
        let t = 1.0 - (y as f32 + 0.5) * inv;
        for (x, px) in row.iter_mut().enumerate() {
            *px = sample(style, &n, (x as f32 + 0.5) * inv, t);
        }
    });
    let pal = palette(style);
    let depth = style.depth() * w as f32;
    let mut albedo = Image::new(w as u32, w as u32, 3);
    let mut normal = Image::new(w as u32, w as u32, 3);
    let mut orm = Image::new(w as u32, w as u32, 3);
    let at = |x: usize, y: usize| fields[(y % w) * w + (x % w)].0;
    albedo
        .data
        .par_chunks_mut(3 * w)
        .zip(normal.data.par_chunks_mut(3 * w))
        .zip(orm.data.par_chunks_mut(3 * w))
        .enumerate()
        .for_each(|(y, ((a, nm), o))| {
            if stop() {
                return;
            }
            for x in 0..w {
                let (h, c, rough) = fields[y * w + x];
                let (lo, hi) = if h < 0.5 { (pal[0], pal[1]) } else { (pal[1], pal[2]) };
                let k = if h < 0.5 { h * 2.0 } else { h * 2.0 - 1.0 };
                let shade = 1.0 + 0.18 * c;
                for ch in 0..3 {
                    let lin = (lo[ch] + (hi[ch] - lo[ch]) * k) * shade;
                    a[3 * x + ch] = srgb_byte(lin);
                }
                // Gradient in tile units per pixel; image y runs against +v.
                let dhdx = (at(x + 1, y) - at(x + w - 1, y)) * 0.5;
                let dhdy_img = (at(x, y + 1) - at(x, y + w - 1)) * 0.5;
                let v = glam::Vec3::new(-depth * dhdx, depth * dhdy_img, 1.0).normalize();
                nm[3 * x] = to_byte(0.5 + 0.5 * v.x);
                nm[3 * x + 1] = to_byte(0.5 + 0.5 * v.y);
                nm[3 * x + 2] = to_byte(0.5 + 0.5 * v.z);
                o[3 * x] = to_byte(0.45 + 0.55 * h.sqrt());
                o[3 * x + 1] = to_byte(rough);
                o[3 * x + 2] = 0;
            }
        });
    BarkMaps { style, albedo: albedo.into(), normal: normal.into(), orm: orm.into() }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Largest byte step between opposite edges of an image, against the largest step
    /// between neighbouring columns inside it: a seamless tile's wrap step is no larger
    /// than its ordinary steps.
    fn seam_steps(im: &Image) -> (i32, i32) {
        let (w, h, c) = (im.width as usize, im.height as usize, im.channels as usize);
        let px = |x: usize, y: usize, k: usize| im.data[(y * w + x) * c + k] as i32;
        let (mut wrap, mut inner) = (0, 0);
        for y in 0..h {
            for k in 0..c {
                wrap = wrap.max((px(0, y, k) - px(w - 1, y, k)).abs());
                for x in 1..w {
                    inner = inner.max((px(x, y, k) - px(x - 1, y, k)).abs());
                }
            }
        }
        for x in 0..w {
            for k in 0..c {
                wrap = wrap.max((px(x, 0, k) - px(x, h - 1, k)).abs());
            }
        }
        (wrap, inner)
    }

    #[test]
    fn every_style_tiles_seamlessly_and_differs_by_seed() {
        for name in BarkStyle::NAMES {
            let style = BarkStyle::from_name(name).unwrap();
            assert_eq!(style.name(), name);
            let m = bark_maps(style, 64, 3);
            for im in [&m.albedo, &m.normal, &m.orm] {
                assert_eq!(im.data.len(), 64 * 64 * 3);
                let (wrap, inner) = seam_steps(im);
                assert!(wrap <= inner.max(8), "{name}: wrap step {wrap} > inner {inner}");
            }
            assert_ne!(m.albedo, bark_maps(style, 64, 4).albedo, "{name}: seed changes nothing");
            assert_eq!(m, bark_maps(style, 64, 3), "{name}: not deterministic");
            // Normals point out of the surface; metallic is zero.
            assert!(m.normal.data.chunks(3).all(|p| p[2] >= 128));
            assert!(m.orm.data.chunks(3).all(|p| p[2] == 0));
        }
    }

    #[test]
    fn birch_is_pale_and_furrowed_is_dark() {
        let mean =
            |m: &BarkMaps| m.albedo.data.iter().map(|&b| b as f64).sum::<f64>() / m.albedo.data.len() as f64;
        let birch = mean(&bark_maps(BarkStyle::Birch, 64, 1));
        let furrowed = mean(&bark_maps(BarkStyle::Furrowed, 64, 1));
        assert!(birch > 150.0 && furrowed < 110.0, "birch {birch}, furrowed {furrowed}");
    }
}
