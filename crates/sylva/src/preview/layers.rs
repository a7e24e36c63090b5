//! Layer rendering for impostors and billboards: a model's colour and normal seen
//! along given view directions, one rasterization per view, written to layered texture
//! maps ([`render_layers`]).

use super::raster::{edge, Coverage, Paint, ScreenVertex, Srgb, Texture};
use super::{Image, MAX_SIZE, SUBPIXEL};
use crate::error::{Error, Result};
use glam::Vec3;

/// One orthographic view of [`render_layers`]: a square of side `2 · half_extent`
/// centred on `centre`, seen from direction `toward`, its axes [`view_basis`]`(toward)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerView {
    /// Centre of the view square (model space, metres).
    pub centre: Vec3,
    /// Unit direction from the centre toward the viewer.
    pub toward: Vec3,
    /// Half the side of the view square, metres.
    pub half_extent: f32,
}

/// What [`render_layers`] draws for one view: unlit surface colour with coverage, and
/// the surface normal in the view's frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layers {
    /// Width and height in pixels.
    pub size: u32,
    /// `size² × 4` bytes, rows top to bottom: the unlit base colour (sRGB, the material's
    /// colour or its colour map, averaged over the covered samples; black where nothing
    /// is) and the covered fraction of the pixel's samples in alpha.
    pub albedo: Vec<u8>,
    /// `size² × 3` bytes: the unit normal facing the viewer as `(n·right, n·up,
    /// n·toward) · 0.5 + 0.5` with [`view_basis`] (a tangent-space normal map of a quad
    /// facing the view); `(128, 128, 255)` where nothing is.
    pub normal: Vec<u8>,
}

/// The screen axes (right, up) of a view from `toward` (a unit vector from the scene
/// toward the viewer): right is horizontal, up is as close to +Y as right allows; a view
/// straight down (or up) takes +X as right. The same frame as [`render`](super::render)'s camera.
pub fn view_basis(toward: Vec3) -> (Vec3, Vec3) {
    let fwd = -toward;
    let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
    (right, right.cross(fwd))
}

/// Renders `parts` (their colour maps from `images`, indexed by
/// [`crate::model::MaterialMaps`]) orthographically from each of `views` into
/// `size × size` [`Layers`], with `supersample²` samples per pixel. Coverage follows
/// [`render`](super::render)'s rules (top-left fill, triangles thinner than a sample drawn as
/// hairlines, the alpha cut of colour-mapped materials), except that the back faces of
/// single-sided materials are culled as a glTF viewer culls them; there is no lighting. Views are
/// drawn in parallel; the result is deterministic. Instanced organs must be flattened
/// by the caller ([`Model::flattened`](crate::model::Model::flattened)).
///
/// Errors: [`Error::InvalidGeometry`] for a size outside `1..=8192`, `supersample`
/// outside `1..=4`, a view with a non-finite centre, a direction that is not a unit
/// vector or a half extent that is not positive, or a part whose mesh fails
/// [`crate::Mesh::validate`].
pub fn render_layers(
    parts: &[crate::model::Part],
    images: &[crate::model::ModelImage],
    views: &[LayerView],
    size: u32,
    supersample: u32,
) -> Result<Vec<Layers>> {
    use rayon::prelude::*;
    let bad = |why: String| Error::InvalidGeometry { what: "layer render".into(), why };
    if !(1..=MAX_SIZE).contains(&size) {
        return Err(bad(format!("size is {size}; it must be in 1..={MAX_SIZE}")));
    }
    if !(1..=4).contains(&supersample) {
        return Err(bad(format!("supersample is {supersample}; it must be in 1..=4")));
    }
    for (k, v) in views.iter().enumerate() {
        let ok = v.centre.is_finite()
            && v.toward.is_finite()
            && (v.toward.length() - 1.0).abs() < 1e-3
            && v.half_extent.is_finite()
            && v.half_extent > 0.0;
        if !ok {
            return Err(bad(format!(
                "view {k} (centre {}, toward {}, half extent {}) needs a finite centre, a unit direction and a positive half extent",
                v.centre, v.toward, v.half_extent
            )));
        }
    }
    for part in parts {
        part.mesh.validate().map_err(|why| Error::InvalidGeometry {
            what: format!("layer render of part `{}`", part.name),
            why,
        })?;
    }
    let srgb = Srgb::new();
    // A view's texel is many texels of a full-size map: sample box-filtered copies at most
    // twice the frame's sample count across (less aliasing, and far fewer cache misses).
    // Only the colour maps the parts use are reduced.
    let most = (2 * size * supersample).max(16);
    let used: Vec<u32> = parts.iter().filter_map(|p| p.material.maps.base_color).collect();
    let reduced: Vec<crate::model::ModelImage> = images
        .iter()
        .enumerate()
        .map(|(i, im)| {
            let image = if used.contains(&(i as u32)) { reduce(&im.image, most) } else { Default::default() };
            crate::model::ModelImage { image: image.into(), name: String::new(), repeat: im.repeat }
        })
        .collect();
    let samples = (size * supersample) as usize;
    Ok(views
        .par_iter()
        .map_init(
            || LayerTarget::new(samples * samples),
            |target, v| layer_view(parts, &reduced, v, size, supersample, &srgb, target),
        )
        .collect())
}

/// The per-sample buffers of a layer view (reused across the views one thread draws).
struct LayerTarget {
    depth: Vec<f32>,
    colour: Vec<Vec3>,
    normal: Vec<Vec3>,
}

impl LayerTarget {
    pub(super) fn new(n: usize) -> LayerTarget {
        LayerTarget {
            depth: vec![f32::NEG_INFINITY; n],
            colour: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
        }
    }
}

/// `image` box-filtered (colour weighted by alpha) by the smallest power of two that
/// brings both sides to at most `most` pixels (and divides them).
fn reduce(image: &Image, most: u32) -> Image {
    let c = image.channels as usize;
    let mut f = 1u32;
    while (image.width / f > most || image.height / f > most)
        && image.width.is_multiple_of(2 * f)
        && image.height.is_multiple_of(2 * f)
    {
        f *= 2;
    }
    if f == 1 || c < 3 {
        return image.clone();
    }
    let (w, h, fu) = ((image.width / f) as usize, (image.height / f) as usize, f as usize);
    let mut out = Image::new(w as u32, h as u32, image.channels);
    let mut sum = vec![[0u64; 4]; w];
    for y in 0..h {
        sum.iter_mut().for_each(|s| *s = [0; 4]);
        for sy in 0..fu {
            let row = &image.data[(y * fu + sy) * image.width as usize * c..][..image.width as usize * c];
            for (x, px) in row.chunks_exact(c).enumerate() {
                let a = if c == 4 { px[3] as u64 } else { 255 };
                let s = &mut sum[x / fu];
                s[0] += px[0] as u64 * a;
                s[1] += px[1] as u64 * a;
                s[2] += px[2] as u64 * a;
                s[3] += a;
            }
        }
        for (x, s) in sum.iter().enumerate() {
            let o = (y * w + x) * c;
            for k in 0..3 {
                out.data[o + k] = (s[k] + s[3] / 2).checked_div(s[3]).unwrap_or(0) as u8;
            }
            if c == 4 {
                out.data[o + 3] = ((s[3] + (f * f / 2) as u64) / (f * f) as u64) as u8;
            }
        }
    }
    out
}

/// One view of [`render_layers`].
fn layer_view(
    parts: &[crate::model::Part],
    images: &[crate::model::ModelImage],
    view: &LayerView,
    size: u32,
    ss: u32,
    srgb: &Srgb,
    target: &mut LayerTarget,
) -> Layers {
    let side = (size * ss) as i64;
    target.depth.fill(f32::NEG_INFINITY);
    let LayerTarget { depth, colour, normal } = target;
    let (right, up) = view_basis(view.toward);
    // Model units → fixed-point samples (y down).
    let scale = side as f32 * 0.5 / view.half_extent;
    let half = side as f32 * 0.5;
    let to_screen = |p: Vec3| {
        let d = p - view.centre;
        let x = (half + d.dot(right) * scale) * SUBPIXEL as f32;
        let y = (half - d.dot(up) * scale) * SUBPIXEL as f32;
        ScreenVertex { x: (x + 0.5) as i64, y: (y + 0.5) as i64, iz: d.dot(view.toward) }
    };
    for part in parts {
        let m = &part.mesh;
        let paint = Paint::new(part, images);
        let screen: Vec<ScreenVertex> = m.positions.iter().map(|&p| to_screen(p)).collect();
        // Single-sided materials show their front faces only (glTF's back-face culling).
        let cull = !part.material.double_sided;
        for cs in m.fan_corners() {
            let vi = cs.map(|c| m.face_indices[c] as usize);
            let s = vi.map(|v| screen[v]);
            let area = edge((s[0].x, s[0].y), (s[1].x, s[1].y), s[2].x, s[2].y);
            // Nothing to draw, or a culled back face (y points down: front is negative).
            if area == 0 || (cull && area > 0) {
                continue;
            }
            let world = vi.map(|v| m.positions[v]);
            let face_normal = || (world[1] - world[0]).cross(world[2] - world[0]).normalize_or(view.toward);
            let ns = paint.normals(cs, face_normal);
            let tex = paint.texture(cs);
            for_each_sample(side, side, s, cull, |idx, z, back, w| {
                if z <= depth[idx] {
                    return;
                }
                let w = w.get();
                let c = match &tex {
                    Some(t) => match t.colour_fast(w, srgb) {
                        Some(c) => c,
                        None => return,
                    },
                    None => paint.base,
                };
                let flip = if back { -1.0 } else { 1.0 };
                depth[idx] = z;
                colour[idx] = c;
                // Normalized per pixel, after the box filter.
                let nn = ns[0] * w[0] + ns[1] * w[1] + ns[2] * w[2];
                normal[idx] = if nn.length_squared() > 1e-12 { nn } else { face_normal() } * flip;
            });
        }
    }
    // Box filter down to `size`.
    let px = size as usize * size as usize;
    let (mut albedo, mut normal_map) = (vec![0u8; px * 4], vec![0u8; px * 3]);
    let samples = (ss * ss) as f32;
    let enc = |x: f32| ((x * 0.5 + 0.5) * 255.0 + 0.5).clamp(0.0, 255.0) as u8;
    for y in 0..size as usize {
        for x in 0..size as usize {
            let (mut sum_c, mut sum_n, mut hits) = (Vec3::ZERO, Vec3::ZERO, 0u32);
            for sy in 0..ss as usize {
                let row = (y * ss as usize + sy) * side as usize;
                for sx in 0..ss as usize {
                    let i = row + x * ss as usize + sx;
                    if depth[i] > f32::NEG_INFINITY {
                        hits += 1;
                        sum_c += colour[i];
                        sum_n += normal[i];
                    }
                }
            }
            let o = y * size as usize + x;
            let nn = sum_n.normalize_or(view.toward);
            if hits > 0 {
                let c = sum_c / hits as f32;
                albedo[o * 4..o * 4 + 3].copy_from_slice(&[
                    srgb.encode(c.x),
                    srgb.encode(c.y),
                    srgb.encode(c.z),
                ]);
                albedo[o * 4 + 3] = ((hits as f32 / samples) * 255.0 + 0.5) as u8;
            }
            let t = [nn.dot(right), nn.dot(up), nn.dot(view.toward)].map(enc);
            normal_map[o * 3..o * 3 + 3].copy_from_slice(&if hits > 0 { t } else { [128, 128, 255] });
        }
    }
    Layers { size, albedo, normal: normal_map }
}

/// `⌊x⌋` as an integer without a libm call (saturating outside the i64 range).
#[inline]
fn floor_i64(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) > x {
        t - 1
    } else {
        t
    }
}

impl Texture<'_> {
    /// [`Texture::colour`] (the same texel, the same cut), with the wrap and the alpha
    /// test done on integers: the layer renders sample it millions of times.
    #[inline]
    fn colour_fast(&self, w: [f32; 3], srgb: &Srgb) -> Option<Vec3> {
        let uv = self.uv[0] * w[0] + self.uv[1] * w[1] + self.uv[2] * w[2];
        let im = self.image;
        let (wi, hi) = (im.width.max(1) as i64, im.height.max(1) as i64);
        let mut x = floor_i64(uv.x * im.width as f32);
        let mut y = floor_i64((1.0 - uv.y) * im.height as f32);
        if !(0..wi).contains(&x) {
            x = x.rem_euclid(wi);
        }
        if !(0..hi).contains(&y) {
            y = y.rem_euclid(hi);
        }
        let c = im.channels as usize;
        let i = (y as usize * wi as usize + x as usize) * c;
        let p = im.data.get(i..i + c)?;
        if c == 4 && self.cutoff.is_some_and(|cut| (p[3] as f32) < cut * 255.0) {
            return None;
        }
        Some(Vec3::new(srgb.decode[p[0] as usize], srgb.decode[p[1] as usize], srgb.decode[p[2] as usize]))
    }
}

/// The barycentric weights of a fragment of [`for_each_sample`], worked out only when
/// asked for (most fragments fail the depth test first).
#[derive(Clone, Copy)]
struct Weights {
    /// Edge values at the fragment, in working order.
    e: [i64; 3],
    inv_area: f32,
    thin: bool,
    /// The input corner of each working corner.
    perm: [usize; 3],
}

impl Weights {
    /// The weights of the input corners `s[0], s[1], s[2]`.
    #[inline]
    pub(super) fn get(&self) -> [f32; 3] {
        let mut w = self.e.map(|e| e as f32 * self.inv_area);
        if self.thin {
            // Outside the true triangle: its nearest barycentric point.
            w = w.map(|x| x.max(0.0));
            let sum = w[0] + w[1] + w[2];
            w = if sum > 0.0 {
                let inv = 1.0 / sum;
                w.map(|x| x * inv)
            } else {
                [1.0 / 3.0; 3]
            };
        }
        let mut out = [0.0f32; 3];
        for k in 0..3 {
            out[self.perm[k]] = w[k];
        }
        out
    }
}

/// Calls `frag(sample index, depth, back-facing, weights)` for every sample of a
/// `w × h` frame that the screen triangle `s` covers (none when it faces away and `cull`
/// is set), with [`draw_triangle`]'s coverage rules (top-left fill; a triangle thinner
/// than a sample dilated by half a sample so it shows as a hairline). The depth is the
/// corners' `iz` interpolated (clamped to their range on a dilated hairline).
fn for_each_sample(
    w: i64,
    h: i64,
    s: [ScreenVertex; 3],
    cull: bool,
    mut frag: impl FnMut(usize, f32, bool, Weights),
) {
    let mut p = s.map(|v| (v.x, v.y));
    let mut iz = s.map(|v| v.iz);
    // Which input corner each working corner is.
    let mut perm = [0usize, 1, 2];
    let mut area = edge(p[0], p[1], p[2].0, p[2].1);
    if area == 0 {
        return;
    }
    // Counter-clockwise in the world (front-facing) is negative here (y points down).
    let back = area > 0;
    if back && cull {
        return;
    }
    if area < 0 {
        p.swap(1, 2);
        iz.swap(1, 2);
        perm.swap(1, 2);
        area = -area;
    }
    let Some(c) = Coverage::new(p, area, w, h) else { return };
    let (step, bias, thin, x0) = (c.step, c.bias, c.thin, c.x0);
    let inv_area = 1.0 / area as f32;
    // Depth is affine in the edge values: z = Σ iz_k · e_k / area.
    let dz = (0..3).map(|k| iz[k] * step[k] as f32).sum::<f32>() * inv_area;
    let (zlo, zhi) = (iz[0].min(iz[1]).min(iz[2]), iz[0].max(iz[1]).max(iz[2]));
    // Narrow boxes (most triangles of a distant tree) test every sample; wide ones solve
    // each row's span (a few divisions instead of a test per sample).
    let narrow = c.x1 - c.x0 < 16;
    for py in c.y0..c.y1 + 1 {
        let e = c.row_start(py);
        let (k0, k1) = if narrow {
            (0, c.x1 - c.x0)
        } else {
            match c.span(e) {
                Some(span) => span,
                None => continue,
            }
        };
        let z_row = (0..3).map(|k| iz[k] * e[k] as f32).sum::<f32>() * inv_area;
        let row = (py * w) as usize;
        for j in k0..k1 + 1 {
            let ej = [0, 1, 2].map(|k| e[k] + step[k] * j);
            if narrow && (ej[0] + bias[0] < 0 || ej[1] + bias[1] < 0 || ej[2] + bias[2] < 0) {
                continue;
            }
            let mut z = z_row + dz * j as f32;
            if thin {
                z = z.clamp(zlo, zhi);
            }
            frag(row + (x0 + j) as usize, z, back, Weights { e: ej, inv_area, thin, perm });
        }
    }
}
