//! The preview rasterizer: z-buffered triangles with 8-bit sub-pixel fixed-point edge
//! functions and the top-left fill rule, Lambert shading with a sky/ground ambient,
//! texture sampling with alpha cut, and the supersampled resolve in linear light (sRGB).
//!
//! - **Rasterization**: z-buffered triangles (faces fan-triangulated) with 8-bit
//!   sub-pixel fixed-point edge functions and the top-left fill rule, row spans solved
//!   analytically so long thin slivers (twigs) cost only the pixels they cover.
//!   Anti-aliasing: `supersample`² samples per pixel, box-filtered in linear light.
//! - **Shading**: Lambert with a camera-relative key light from the upper left, plus a
//!   sky/ground ambient term; per-pixel interpolated normals from the mesh's normal
//!   channel when present, else face normals; two-sided (a back-facing triangle has its
//!   normals flipped, so open leaf blades shade right). Material base colours are
//!   linear and encoded to sRGB; the background is a vertical sRGB gradient.

use super::camera::Camera;
use super::{Image, PreviewOptions, SUBPIXEL};
use crate::model::Model;
use glam::Vec3;

/// The supersampled frame: inverse depth (0 = empty) and shaded sRGB colour with a
/// coverage flag in alpha.
pub(super) struct Target {
    w: i64,
    h: i64,
    depth: Vec<f32>,
    color: Vec<[u8; 4]>,
}

impl Target {
    pub(super) fn new(w: i64, h: i64) -> Target {
        let n = (w * h) as usize;
        Target { w, h, depth: vec![0.0; n], color: vec![[0; 4]; n] }
    }
}

/// Entries of the linear → sRGB encoding table.
const ENCODE_LUT: usize = 4096;

fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        x * 12.92
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

fn srgb_decode(x: f32) -> f32 {
    if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear ↔ 8-bit sRGB lookup tables.
pub(super) struct Srgb {
    pub(super) encode: Vec<u8>,
    pub(super) decode: Vec<f32>,
}

impl Srgb {
    pub(super) fn new() -> Srgb {
        let last = (ENCODE_LUT - 1) as f32;
        Srgb {
            encode: (0..ENCODE_LUT)
                .map(|i| (srgb_encode(i as f32 / last) * 255.0 + 0.5).clamp(0.0, 255.0) as u8)
                .collect(),
            decode: (0..256).map(|i| srgb_decode(i as f32 / 255.0)).collect(),
        }
    }

    #[inline]
    pub(super) fn encode(&self, linear: f32) -> u8 {
        let last = (ENCODE_LUT - 1) as f32;
        // `as usize` of the clamped value cannot go out of range (NaN maps to 0).
        let i = (linear * last + 0.5).clamp(0.0, last) as usize;
        self.encode.get(i).copied().unwrap_or(0)
    }
}

/// The light and the colour encoding.
struct Shader<'a> {
    light: Vec3,
    srgb: &'a Srgb,
}

impl Shader<'_> {
    /// Shaded sRGB colour (alpha 255 = covered) of a surface point with unit normal `n`
    /// facing the viewer.
    #[inline]
    fn shade(&self, n: Vec3, base: Vec3) -> [u8; 4] {
        let diffuse = n.dot(self.light).max(0.0);
        let sky = 0.5 + 0.5 * n.y; // ambient: brighter facing the sky than the ground
        let l = base * (0.20 + 0.22 * sky + 0.78 * diffuse);
        [self.srgb.encode(l.x), self.srgb.encode(l.y), self.srgb.encode(l.z), 255]
    }
}

/// Projects every part, fits the projected extent into the frame and rasterizes.
pub(super) fn draw_model(model: &Model, cam: &Camera, fit: Option<Vec<Vec3>>, srgb: &Srgb, t: &mut Target) {
    let mut projected: Vec<Vec<Vec3>> = Vec::with_capacity(model.parts.len());
    let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
    for part in &model.parts {
        let p: Vec<Vec3> = part.mesh.positions.iter().map(|&x| cam.project(x)).collect();
        if fit.is_none() {
            for q in &p {
                lo = lo.min(q.truncate());
                hi = hi.max(q.truncate());
            }
        }
        projected.push(p);
    }
    // A given frame is fitted by its corners.
    for q in fit.iter().flatten().map(|&x| cam.project(x)) {
        lo = lo.min(q.truncate());
        hi = hi.max(q.truncate());
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return;
    }
    let (wf, hf) = (t.w as f32, t.h as f32);
    let margin = 0.05;
    let span = hi - lo;
    let sx = if span.x > 0.0 { wf * (1.0 - 2.0 * margin) / span.x } else { f32::INFINITY };
    let sy = if span.y > 0.0 { hf * (1.0 - 2.0 * margin) / span.y } else { f32::INFINITY };
    let mut scale = sx.min(sy);
    if !scale.is_finite() {
        scale = 1.0;
    }
    let mid = (lo + hi) * 0.5;
    // Screen coordinates in fixed point, y down, plus 1/depth.
    let to_screen = |p: &Vec3| {
        let x = (wf * 0.5 + (p.x - mid.x) * scale) * SUBPIXEL as f32;
        let y = (hf * 0.5 - (p.y - mid.y) * scale) * SUBPIXEL as f32;
        // Every vertex lands inside the frame (or, with a given frame, may lie outside and
        // is clipped by the rasterizer); `as` saturates anything odd.
        ScreenVertex { x: (x + 0.5) as i64, y: (y + 0.5) as i64, iz: p.z }
    };
    let screen: Vec<Vec<ScreenVertex>> =
        projected.iter().map(|part| part.iter().map(to_screen).collect()).collect();
    drop(projected);

    // Key light from the upper left, in front of the model.
    let light = (cam.up * 0.65 - cam.right * 0.45 - cam.fwd * 0.6).normalize();
    let shader = Shader { light, srgb };
    for (part, screen) in model.parts.iter().zip(&screen) {
        let m = &part.mesh;
        let paint = Paint::new(part, &model.images);
        for cs in m.fan_corners() {
            let vi = cs.map(|c| m.face_indices[c] as usize);
            let world = vi.map(|v| m.positions[v]);
            let face_n = (world[1] - world[0]).cross(world[2] - world[0]).normalize_or_zero();
            let ns = paint.normals(cs, || face_n);
            draw_triangle(
                t,
                &shader,
                vi.map(|v| screen[v]),
                ns,
                face_n,
                paint.base,
                paint.texture(cs).as_ref(),
            );
        }
    }
}

/// How a screen triangle covers a frame's samples, set up once for both rasterizers:
/// its edges (edge k opposite corner k), their top-left fill biases, the change of each
/// edge value per sample to the right, and the clamped box of samples it may touch. A
/// triangle thinner than one sample (its smallest height, area / longest edge, is below
/// 1; a twig seen from afar) is dilated by half a sample on every side so it shows as a
/// hairline instead of vanishing.
pub(super) struct Coverage {
    /// Edge k runs between the two corners other than k.
    pub(super) edges: [((i64, i64), (i64, i64)); 3],
    /// Added to an edge value before the inside test.
    pub(super) bias: [i64; 3],
    /// Change of each edge value one sample to the right.
    pub(super) step: [i64; 3],
    /// Whether the triangle is dilated as a hairline.
    pub(super) thin: bool,
    /// First and last sample column and row touched.
    pub(super) x0: i64,
    pub(super) x1: i64,
    pub(super) y0: i64,
    pub(super) y1: i64,
}

impl Coverage {
    /// Sets up corners `p` (clockwise on screen, twice-area `area` > 0) in a `w × h`
    /// frame; `None` when the triangle misses the frame.
    pub(super) fn new(p: [(i64, i64); 3], area: i64, w: i64, h: i64) -> Option<Coverage> {
        // Edge k is opposite vertex k; its value is vertex k's barycentric weight × area.
        let edges = [(p[1], p[2]), (p[2], p[0]), (p[0], p[1])];
        let len2 = edges.map(|(a, b)| {
            let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
            dx * dx + dy * dy
        });
        let area_f = area as f64;
        let thin = area_f * area_f < len2.iter().cloned().fold(0.0, f64::max) * (SUBPIXEL * SUBPIXEL) as f64;
        let bias: [i64; 3] = if thin {
            len2.map(|l| (l.sqrt() * (SUBPIXEL / 2) as f64) as i64)
        } else {
            // Top-left rule (clockwise on screen): top edges run right, left edges run up.
            edges.map(|(a, b)| {
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                if dy < 0 || (dy == 0 && dx > 0) {
                    0
                } else {
                    -1
                }
            })
        };
        let grow = if thin { SUBPIXEL / 2 } else { 0 };
        let xmin = p.iter().map(|q| q.0).min().unwrap_or(0) - grow;
        let xmax = p.iter().map(|q| q.0).max().unwrap_or(0) + grow;
        let ymin = p.iter().map(|q| q.1).min().unwrap_or(0) - grow;
        let ymax = p.iter().map(|q| q.1).max().unwrap_or(0) + grow;
        if xmax < 0 || ymax < 0 || (xmin >> 8) >= w || (ymin >> 8) >= h {
            return None;
        }
        Some(Coverage {
            edges,
            bias,
            step: edges.map(|(a, b)| -(b.1 - a.1) * SUBPIXEL),
            thin,
            x0: (xmin >> 8).clamp(0, w - 1),
            x1: (xmax >> 8).clamp(0, w - 1),
            y0: (ymin >> 8).clamp(0, h - 1),
            y1: (ymax >> 8).clamp(0, h - 1),
        })
    }

    /// The edge values at the centre of the first sample (column `x0`) of row `py`.
    pub(super) fn row_start(&self, py: i64) -> [i64; 3] {
        let half = SUBPIXEL / 2;
        let (cx, cy) = (self.x0 * SUBPIXEL + half, py * SUBPIXEL + half);
        self.edges.map(|(a, b)| edge(a, b, cx, cy))
    }

    /// The column offsets `k0..=k1` (from `x0`) of the row whose edge values at `x0` are
    /// `e` that lie inside every biased edge, solving `e + bias + step·j ≥ 0` for `j`;
    /// `None` when none do.
    pub(super) fn span(&self, e: [i64; 3]) -> Option<(i64, i64)> {
        let (mut k0, mut k1) = (0i64, self.x1 - self.x0);
        for (k, ek) in e.into_iter().enumerate() {
            let v = ek + self.bias[k];
            let st = self.step[k];
            if st > 0 {
                if v < 0 {
                    k0 = k0.max((-v + st - 1) / st); // ceil(−v / st)
                }
            } else if st < 0 {
                if v < 0 {
                    k1 = -1;
                } else {
                    k1 = k1.min(v / -st);
                }
            } else if v < 0 {
                k1 = -1;
            }
        }
        (k0 <= k1).then_some((k0, k1))
    }
}

/// What the rasterizers read of one part: its base colour (clamped to [0, 1]), its
/// normals, and its colour map with the UVs that place it, where it has both (UVs with
/// one index per face corner; the file's look: issue 23).
pub(super) struct Paint<'a> {
    /// The material's base colour.
    pub(super) base: Vec3,
    normals: Option<&'a crate::geometry::FaceVarying<Vec3>>,
    map: Option<(&'a crate::model::ModelImage, &'a crate::geometry::FaceVarying<glam::Vec2>)>,
    cutoff: Option<f32>,
}

impl<'a> Paint<'a> {
    /// The paint of `part`, its colour map taken from `images`.
    pub(super) fn new(part: &'a crate::model::Part, images: &'a [crate::model::ModelImage]) -> Paint<'a> {
        let c = part.material.base_color;
        let ch = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
        let m = &part.mesh;
        Paint {
            base: Vec3::new(ch(c[0]), ch(c[1]), ch(c[2])),
            normals: m.normals.as_ref(),
            map: part
                .material
                .maps
                .base_color
                .and_then(|i| images.get(i as usize))
                .zip(m.uvs.as_ref().filter(|u| u.indices.len() == m.face_indices.len())),
            cutoff: part.material.alpha_cutoff,
        }
    }

    /// The normals at corners `cs` (indices into the face-varying indices); `flat()` at
    /// each when the part has none.
    pub(super) fn normals(&self, cs: [usize; 3], flat: impl FnOnce() -> Vec3) -> [Vec3; 3] {
        match self.normals {
            Some(fv) => cs.map(|c| fv.values[fv.indices[c] as usize]),
            None => [flat(); 3],
        }
    }

    /// The colour map over the triangle of corners `cs`, where the part has one.
    pub(super) fn texture(&self, cs: [usize; 3]) -> Option<Texture<'a>> {
        self.map.map(|(im, uv)| Texture {
            image: &im.image,
            uv: cs.map(|c| uv.values.get(uv.indices[c] as usize).copied().unwrap_or_default()),
            cutoff: self.cutoff,
        })
    }
}

/// `E_ab(p)`: twice the signed area of (a, b, p) in fixed point, y down.
#[inline]
pub(super) fn edge(a: (i64, i64), b: (i64, i64), px: i64, py: i64) -> i64 {
    (b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0)
}

/// A projected vertex: fixed-point sample coordinates (y down) and 1/depth.
#[derive(Debug, Clone, Copy)]
pub(super) struct ScreenVertex {
    pub(super) x: i64,
    pub(super) y: i64,
    pub(super) iz: f32,
}

/// A triangle's colour map: the image, its corners' UVs and the alpha cut-off.
#[derive(Clone, Copy)]
pub(super) struct Texture<'a> {
    pub(super) image: &'a Image,
    pub(super) uv: [glam::Vec2; 3],
    pub(super) cutoff: Option<f32>,
}

impl Texture<'_> {
    /// The linear colour at barycentric `w` (nearest texel, screen-affine UVs), or
    /// `None` where the alpha cut-off removes the sample.
    #[inline]
    fn colour(&self, w: [f32; 3], srgb: &Srgb) -> Option<Vec3> {
        let uv = self.uv[0] * w[0] + self.uv[1] * w[1] + self.uv[2] * w[2];
        let im = self.image;
        let x = (uv.x * im.width as f32).floor() as i64;
        let y = ((1.0 - uv.y) * im.height as f32).floor() as i64;
        let c = im.texel(x, y);
        if self.cutoff.is_some_and(|cut| c[3] < cut) {
            return None;
        }
        let dec = |v: f32| srgb.decode[((v * 255.0 + 0.5) as usize).min(255)];
        Some(Vec3::new(dec(c[0]), dec(c[1]), dec(c[2])))
    }
}

/// Rasterizes one triangle given in screen space with per-corner normals, coloured by
/// `base` or by its colour map.
#[allow(clippy::too_many_arguments)]
fn draw_triangle(
    t: &mut Target,
    sh: &Shader,
    s: [ScreenVertex; 3],
    n: [Vec3; 3],
    face_n: Vec3,
    base: Vec3,
    tex: Option<&Texture>,
) {
    let mut tex = tex.copied();
    let mut p = s.map(|v| (v.x, v.y));
    let (mut s, mut n) = (s, n);
    let mut area = edge(p[0], p[1], p[2].0, p[2].1);
    if area == 0 {
        return;
    }
    // Counter-clockwise in the world (front-facing) is negative here (y points down).
    let back = area > 0;
    if area < 0 {
        p.swap(1, 2);
        s.swap(1, 2);
        n.swap(1, 2);
        if let Some(t) = tex.as_mut() {
            t.uv.swap(1, 2);
        }
        area = -area;
    }
    let flip = if back { -1.0 } else { 1.0 };
    let face_n = face_n * flip;
    let n = n.map(|v| v * flip);

    let Some(c) = Coverage::new(p, area, t.w, t.h) else { return };
    let (step, thin, x0) = (c.step, c.thin, c.x0);
    let inv_area = 1.0 / area as f32;
    let iz = [s[0].iz, s[1].iz, s[2].iz];
    for py in c.y0..=c.y1 {
        let e = c.row_start(py);
        let Some((k0, k1)) = c.span(e) else { continue };
        let row = (py * t.w) as usize;
        for j in k0..=k1 {
            let mut w = [
                (e[0] + step[0] * j) as f32 * inv_area,
                (e[1] + step[1] * j) as f32 * inv_area,
                (e[2] + step[2] * j) as f32 * inv_area,
            ];
            if thin {
                // Outside the true triangle: clamp to its nearest barycentric point.
                w = w.map(|x| x.max(0.0));
                let sum = w[0] + w[1] + w[2];
                if sum <= 0.0 {
                    continue;
                }
                w = w.map(|x| x / sum);
            }
            let z = w[0] * iz[0] + w[1] * iz[1] + w[2] * iz[2];
            let idx = row + (x0 + j) as usize;
            if z <= t.depth[idx] {
                continue;
            }
            let colour = match &tex {
                Some(tx) => match tx.colour(w, sh.srgb) {
                    Some(c) => c,
                    None => continue, // cut away by the alpha mask
                },
                None => base,
            };
            t.depth[idx] = z;
            let nn = (n[0] * w[0] + n[1] * w[1] + n[2] * w[2]).normalize_or(face_n);
            t.color[idx] = sh.shade(nn, colour);
        }
    }
}

/// Box-filters the frame down to the output size over the background gradient.
pub(super) fn resolve(t: &Target, w: u32, h: u32, ss: u32, opts: &PreviewOptions, srgb: &Srgb) -> Image {
    let mut rgba = vec![0u8; w as usize * h as usize * 4];
    let n = (ss * ss) as f32;
    for y in 0..h {
        let bg = super::background_row(opts.background, opts.background_top, y, h);
        let bg_lin = bg.map(|v| srgb.decode[v as usize]);
        for x in 0..w {
            let mut sum = [0.0f32; 3];
            let mut hits = 0u32;
            for sy in 0..ss {
                let row = ((y * ss + sy) as i64 * t.w) as usize;
                for sx in 0..ss {
                    let c = t.color[row + (x * ss + sx) as usize];
                    if c[3] != 0 {
                        hits += 1;
                        for k in 0..3 {
                            sum[k] += srgb.decode[c[k] as usize];
                        }
                    }
                }
            }
            let o = (y as usize * w as usize + x as usize) * 4;
            let px = if hits == 0 {
                bg
            } else {
                let miss = (ss * ss - hits) as f32;
                std::array::from_fn(|k| srgb.encode((sum[k] + miss * bg_lin[k]) / n))
            };
            rgba[o..o + 3].copy_from_slice(&px);
            rgba[o + 3] = 255;
        }
    }
    Image::from_rgba(w, h, rgba)
}

// ---------------------------------------------------------------------------------------
// Orthographic layer renders (issue 24: the LOD chain's impostor atlas).
