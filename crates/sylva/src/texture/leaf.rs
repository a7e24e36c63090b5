//! The leaf atlas (issue 23): six cells of 3 × 2 on one RGBA image — ovate,
//! lanceolate, lobed (maple-like, palmate veins), compound (pinnate leaflets on a
//! rachis), a needle tuft and a twig of seven ovate leaves for cluster cards — drawn
//! with anti-aliased outlines (tiny-skia), veins and colour noise, alpha 0 outside.
//!
//! Every cell stands its leaf on its base: the petiole at the bottom centre, the tip at
//! the top, so a card whose UVs run from [`AtlasCell::base`] to [`AtlasCell::tip`] has
//! its midrib along +v. Outside a leaf the colour is the leaf's own (alpha 0), so
//! filtering and mipmaps do not bleed a dark fringe into alpha-cut edges.

use super::{srgb_byte, Image};
use crate::noise::TileNoise;
use glam::Vec2;
use rayon::prelude::*;
use tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// A leaf shape of the atlas (`leaves.shape`; serde uses the names of [`LeafShape::NAMES`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LeafShape {
    /// Egg-shaped, widest below the middle (aspen, beech, tupelo).
    Ovate,
    /// Long and narrow (willow, poplar).
    Lanceolate,
    /// Five palmate lobes (maple, sassafras, oak-like).
    Lobed,
    /// Pinnate leaflets on a rachis (ash, walnut, ferns).
    Compound,
    /// A tuft of needles (pine, fir, larch).
    Needles,
    /// A twig of seven ovate leaves (cards for groups of leaves).
    Cluster,
}

impl LeafShape {
    /// The recipe names, in the order of the variants (and of the atlas cells).
    pub const NAMES: [&'static str; 6] = ["ovate", "lanceolate", "lobed", "compound", "needles", "cluster"];

    /// The shape named `name`.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::NAMES.iter().position(|&n| n == name).map(|i| Self::ALL[i])
    }

    /// Every shape, in atlas order.
    pub const ALL: [LeafShape; 6] = [
        LeafShape::Ovate,
        LeafShape::Lanceolate,
        LeafShape::Lobed,
        LeafShape::Compound,
        LeafShape::Needles,
        LeafShape::Cluster,
    ];

    /// The shape's recipe name.
    pub fn name(&self) -> &'static str {
        Self::NAMES[*self as usize]
    }
}

/// Where one shape lies in the atlas, in mesh texture coordinates (origin bottom left).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AtlasCell {
    /// The shape drawn there.
    pub shape: LeafShape,
    /// Lower-left corner of the cell.
    pub min: Vec2,
    /// Upper-right corner of the cell.
    pub max: Vec2,
    /// The petiole's end (base of the midrib).
    pub base: Vec2,
    /// The leaf's tip.
    pub tip: Vec2,
}

/// The atlas image and its cells (in [`LeafShape::ALL`] order).
#[derive(Debug, Clone, PartialEq)]
pub struct LeafAtlas {
    /// RGBA, colour sRGB, alpha coverage.
    pub image: Image,
    /// One cell per shape.
    pub cells: Vec<AtlasCell>,
}

impl LeafAtlas {
    /// The cell of `shape`.
    pub fn cell(&self, shape: LeafShape) -> &AtlasCell {
        &self.cells[shape as usize]
    }
}

/// One blade in a cell, in pixels of the cell: from `origin` along `dir` for `length`.
#[derive(Debug, Clone, Copy)]
struct Blade {
    origin: Vec2,
    dir: Vec2,
    length: f32,
    half_width: f32,
    profile: Profile,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Profile {
    Ovate,
    Lanceolate,
    Needle,
}

impl Blade {
    /// Half-width at fraction `t` of the length, relative to `half_width`.
    fn width(&self, t: f32) -> f32 {
        if !(0.0..=1.0).contains(&t) {
            return 0.0;
        }
        let s = (std::f32::consts::PI * t.powf(0.8)).sin().max(0.0);
        match self.profile {
            Profile::Ovate => s.powf(0.75),
            Profile::Lanceolate => s.powf(1.1),
            Profile::Needle => (1.0 - t).powf(0.3),
        }
    }

    /// (t along, a across in half-widths) of pixel `p`.
    fn local(&self, p: Vec2) -> (f32, f32) {
        let d = p - self.origin;
        let along = d.dot(self.dir) / self.length;
        let across = d.perp_dot(self.dir) / self.half_width.max(1e-3);
        (along, across)
    }

    /// The outline, tip and base included, as a closed polygon.
    fn outline(&self, pb: &mut PathBuilder) {
        let n = 48;
        let side = self.dir.perp();
        let at = |t: f32, s: f32| {
            self.origin + self.dir * (t * self.length) + side * (s * self.half_width * self.width(t))
        };
        let start = at(0.0, 0.0);
        pb.move_to(start.x, start.y);
        for i in 1..=n {
            let p = at(i as f32 / n as f32, 1.0);
            pb.line_to(p.x, p.y);
        }
        for i in (0..n).rev() {
            let p = at(i as f32 / n as f32, -1.0);
            pb.line_to(p.x, p.y);
        }
        pb.close();
    }
}

/// The blades of a cell `w` × `h` pixels (image coordinates, y down), and the maple
/// outline for [`LeafShape::Lobed`].
fn blades(shape: LeafShape, w: f32, h: f32) -> Vec<Blade> {
    let base = Vec2::new(0.5 * w, 0.96 * h);
    let up = Vec2::new(0.0, -1.0);
    let len = 0.9 * h;
    let rot = |deg: f32| Vec2::from_angle(deg.to_radians()).rotate(up);
    let b = |origin, dir, length, half_width, profile| Blade { origin, dir, length, half_width, profile };
    match shape {
        LeafShape::Ovate => vec![b(base, up, len, 0.46 * w, Profile::Ovate)],
        LeafShape::Lanceolate => vec![b(base, up, len, 0.2 * w, Profile::Lanceolate)],
        // The lobed leaf's blades are its five veins (used for shading, not outline).
        LeafShape::Lobed => {
            let centre = base + up * (0.42 * len);
            [0.0f32, -62.0, 62.0, -125.0, 125.0]
                .iter()
                .map(|&a| {
                    b(centre, rot(a), 0.5 * len * (1.0 - a.abs() / 400.0), 0.08 * w, Profile::Lanceolate)
                })
                .collect()
        }
        LeafShape::Compound => {
            let mut v = vec![b(base + up * (0.62 * len), up, 0.38 * len, 0.13 * w, Profile::Ovate)];
            for (k, t) in [0.18f32, 0.36, 0.54].iter().enumerate() {
                let l = 0.34 * len * (1.0 - 0.1 * k as f32);
                for side in [-1.0f32, 1.0] {
                    v.push(b(base + up * (t * len), rot(side * 58.0), l, 0.11 * w, Profile::Ovate));
                }
            }
            v
        }
        LeafShape::Needles => (0..9)
            .map(|i| {
                let a = -36.0 + 9.0 * i as f32;
                b(base, rot(a), len * (0.8 + 0.2 * (1.0 - (a / 36.0).abs())), 0.012 * w, Profile::Needle)
            })
            .collect(),
        // A twig of seven ovate leaves: three alternating pairs up the stem and one at
        // its end, so a card for a group of leaves covers most of its cell.
        LeafShape::Cluster => {
            let mut v: Vec<Blade> =
                [(0.16f32, -52.0f32), (0.3, 52.0), (0.44, -48.0), (0.56, 48.0), (0.66, -40.0), (0.72, 40.0)]
                    .iter()
                    .map(|&(t, a)| b(base + up * (t * len), rot(a), 0.36 * len, 0.17 * w, Profile::Ovate))
                    .collect();
            v.push(b(base + up * (0.7 * len), up, 0.3 * len, 0.16 * w, Profile::Ovate));
            v
        }
    }
}

/// The maple outline: five pointed lobes around a centre, petiole notch at the bottom.
fn maple_outline(pb: &mut PathBuilder, w: f32, h: f32) {
    let centre = Vec2::new(0.5 * w, 0.96 * h - 0.42 * 0.9 * h);
    let r = 0.47 * w;
    let n = 200;
    for i in 0..=n {
        // θ from straight down (the petiole) round through the sides to the top.
        let th = std::f32::consts::TAU * i as f32 / n as f32;
        let phi = th - std::f32::consts::PI; // 0 at the top lobe
        let lobes = (2.5 * phi).cos().abs().powf(2.5);
        let notch = 1.0 - 0.75 * (-(phi.abs() - std::f32::consts::PI).powi(2) * 8.0).exp();
        let rr = r * (0.42 + 0.58 * lobes) * notch.max(0.15);
        let p = centre + Vec2::new(-th.sin(), th.cos()) * rr * Vec2::new(1.0, 1.35);
        if i == 0 {
            pb.move_to(p.x, p.y);
        } else {
            pb.line_to(p.x, p.y);
        }
    }
    pb.close();
}

/// The atlas's cells at `size` × `size` pixels without drawing it (the leaf-card
/// mesher needs the layout; the texture stage draws the image).
pub fn atlas_layout(size: u32) -> LeafAtlas {
    let size = size.max(6);
    let (cols, rows) = (3u32, 2u32);
    let (cw, ch) = (size / cols, size / rows);
    let cells = LeafShape::ALL
        .iter()
        .enumerate()
        .map(|(k, &shape)| {
            cell_of(shape, k as u32 % cols, k as u32 / cols, cw as f32, ch as f32, size as f32)
        })
        .collect();
    LeafAtlas { image: Image::default(), cells }
}

/// The texture coordinates of a cell at column `col`, row `row` (v up: image row 0 is
/// v = 1), cells `w` × `h` pixels in an atlas of `size`.
fn cell_of(shape: LeafShape, col: u32, row: u32, w: f32, h: f32, size: f32) -> AtlasCell {
    let uv = |px: f32, py: f32| Vec2::new((col as f32 * w + px) / size, 1.0 - (row as f32 * h + py) / size);
    AtlasCell {
        shape,
        min: uv(0.0, h),
        max: uv(w, 0.0),
        base: uv(0.5 * w, 0.995 * h),
        tip: uv(0.5 * w, 0.06 * h),
    }
}

/// Draws the atlas at `size` × `size` pixels in `colour` (linear RGB) for `seed`.
pub fn leaf_atlas(size: u32, colour: [f32; 3], seed: u64) -> LeafAtlas {
    let size = size.max(6);
    let (cols, rows) = (3u32, 2u32);
    let (cw, ch) = (size / cols, size / rows);
    let mut image = Image::new(size, size, 4);
    let noise = TileNoise::new(seed ^ 0x1eaf);
    // The cells are the layout's; only the drawing happens here.
    let cells = atlas_layout(size).cells;
    for (k, &shape) in LeafShape::ALL.iter().enumerate() {
        // A cancelled drawing ([`crate::cancel`]) stops between cells; the caller drops it.
        if crate::cancel::cancelled() {
            break;
        }
        let (col, row) = (k as u32 % cols, k as u32 / cols);
        let (w, h) = (cw as f32, ch as f32);
        let bl = blades(shape, w, h);
        // Coverage from the outlines (a cell is at least 2 × 3 pixels: `size` ≥ 6).
        let Some(mut mask) = Pixmap::new(cw, ch) else { continue };
        let mut paint = Paint::default();
        paint.set_color_rgba8(255, 255, 255, 255);
        paint.anti_alias = true;
        let mut pb = PathBuilder::new();
        if shape == LeafShape::Lobed {
            maple_outline(&mut pb, w, h);
        } else {
            bl.iter().for_each(|b| b.outline(&mut pb));
        }
        if let Some(path) = pb.finish() {
            mask.fill_path(&path, &paint, FillRule::Winding, Transform::identity(), None);
        }
        // Petiole, and the compound leaf's rachis.
        let stem_top = match shape {
            LeafShape::Compound => 0.66,
            LeafShape::Lobed => 0.42,
            LeafShape::Cluster => 0.75,
            _ => 0.05,
        };
        let mut pb = PathBuilder::new();
        pb.move_to(0.5 * w, 0.995 * h);
        pb.line_to(0.5 * w, 0.96 * h - stem_top * 0.9 * h);
        if let Some(path) = pb.finish() {
            let stroke = Stroke { width: (0.014 * w).max(2.5), ..Default::default() };
            mask.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
        }
        let (x0, y0) = ((col * cw) as usize, (row * ch) as usize);
        let width = size as usize;
        let flat = colour.map(|c| srgb_byte(c * 0.9));
        let token = crate::cancel::current();
        let cell_rows: Vec<(usize, Vec<u8>)> = (0..ch as usize)
            .into_par_iter()
            .map(|y| {
                let mut out = vec![0u8; 4 * cw as usize];
                if token.as_ref().is_some_and(crate::cancel::Cancel::is_cancelled) {
                    return (y, out);
                }
                for x in 0..cw as usize {
                    let p = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let alpha = mask.pixel(x as u32, y as u32).map_or(0, |c| c.alpha());
                    if alpha == 0 {
                        // Outside: the plain leaf colour, so filtering does not darken edges.
                        for c in 0..3 {
                            out[4 * x + c] = flat[c];
                        }
                        continue;
                    }
                    // Veins: the nearest blade's midrib and its side veins.
                    let mut vein = 0.0f32;
                    let mut edge = 1.0f32;
                    for b in &bl {
                        let (t, a) = b.local(p);
                        let wt = b.width(t);
                        if wt <= 0.0 || a.abs() > wt.max(0.05) * 1.05 {
                            continue;
                        }
                        let rel = (a.abs() / wt.max(1e-3)).min(1.0);
                        edge = edge.min(1.0 - rel);
                        let mid = (1.0 - a.abs() * b.half_width / (0.006 * w + 0.8)).max(0.0);
                        let side = if b.profile == Profile::Needle {
                            0.0
                        } else {
                            let phase = (t - 0.35 * rel) * 9.0;
                            let d = (phase - phase.round()).abs();
                            (1.0 - d / 0.06).max(0.0) * (1.0 - rel) * 0.7
                        };
                        vein = vein.max(mid.max(side));
                    }
                    let (s, tt) = ((x0 + x) as f32 / width as f32, (y0 + y) as f32 / width as f32);
                    let grain = noise.fbm(s * 12.0, tt * 12.0, 12, 12, 3, 0.5);
                    let shade = (0.9 + 0.12 * grain - 0.18 * (1.0 - edge).powi(3)).max(0.0);
                    let vein_col = [colour[0] * 1.35 + 0.05, colour[1] * 1.3 + 0.05, colour[2] * 0.9];
                    for c in 0..3 {
                        let lin = (colour[c] * shade) * (1.0 - 0.6 * vein) + vein_col[c] * 0.6 * vein;
                        out[4 * x + c] = srgb_byte(lin);
                    }
                    out[4 * x + 3] = alpha;
                }
                (y, out)
            })
            .collect();
        for (y, row_px) in cell_rows {
            let i = ((y0 + y) * width + x0) * 4;
            image.data[i..i + row_px.len()].copy_from_slice(&row_px);
        }
    }
    LeafAtlas { image, cells }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atlas_has_every_shape_with_alpha_and_upright_cells() {
        let a = leaf_atlas(192, [0.1, 0.3, 0.05], 1);
        assert_eq!(a.cells.len(), 6);
        assert_eq!((a.image.width, a.image.height, a.image.channels), (192, 192, 4));
        for c in &a.cells {
            // Base below tip on the same vertical: the midrib runs along +v.
            assert!((c.base.x - c.tip.x).abs() < 1e-6 && c.tip.y > c.base.y, "{c:?}");
            assert!(c.min.x < c.max.x && c.min.y < c.max.y);
            // The cell has opaque and transparent texels.
            let (mut on, mut off) = (0, 0);
            for y in 0..16 {
                for x in 0..16 {
                    let u = c.min.x + (c.max.x - c.min.x) * (x as f32 + 0.5) / 16.0;
                    let v = c.min.y + (c.max.y - c.min.y) * (y as f32 + 0.5) / 16.0;
                    if a.image.sample(u, v)[3] > 0.5 {
                        on += 1;
                    } else {
                        off += 1;
                    }
                }
            }
            assert!(on > 4 && off > 16, "{:?}: {on} opaque, {off} clear of 256", c.shape);
            // The midrib just above the base is opaque.
            let m = c.base + (c.tip - c.base) * 0.1;
            assert!(a.image.sample(m.x, m.y)[3] > 0.5, "{:?}: no petiole", c.shape);
        }
        assert_eq!(a, leaf_atlas(192, [0.1, 0.3, 0.05], 1));
        for name in LeafShape::NAMES {
            assert_eq!(LeafShape::from_name(name).unwrap().name(), name);
        }
    }
}
