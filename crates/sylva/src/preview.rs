//! CPU preview renderer: draws a [`Model`] into an RGBA image and writes it as a PNG.
//!
//! This is what `--preview out.png` runs, so a user can look at one picture and
//! recognise the tree; it is the architecture's `preview (PNG)` stage and needs no GPU.
//!
//! - **Camera**: auto-framed from the model bounds. A model much thinner along one axis
//!   than the others (an L-system tree drawn in the y–z plane, a 2D curve in the x–y
//!   plane) is viewed straight along that axis; anything else gets a three-quarter
//!   view (25° azimuth, 15° elevation). A 30° perspective is placed to see the bounding
//!   sphere, then the projected extent of every vertex is fitted to the image with a
//!   5 % margin.
//! - **Rasterization**: z-buffered triangles (faces fan-triangulated) with 8-bit
//!   sub-pixel fixed-point edge functions and the top-left fill rule, row spans solved
//!   analytically so long thin slivers (twigs) cost only the pixels they cover.
//!   Anti-aliasing: `supersample`² samples per pixel, box-filtered in linear light.
//! - **Shading**: Lambert with a camera-relative key light from the upper left, plus a
//!   sky/ground ambient term; per-pixel interpolated normals from the mesh's normal
//!   channel when present, else face normals; two-sided (a back-facing triangle has its
//!   normals flipped, so open leaf blades shade right). Material base colours are
//!   linear and encoded to sRGB; the background is a vertical sRGB gradient.
//!
//! Cost: O(vertices + triangles + covered samples), single-threaded; a 1M-triangle tree
//! at 1024² takes a fraction of a second in release builds.

use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::model::Model;
use glam::Vec3;
use std::path::Path;

/// Largest accepted image width or height, in pixels.
pub const MAX_SIZE: u32 = 8192;

/// Most samples the supersampled frame may hold; above it the supersampling factor is
/// lowered (down to 1) to bound memory.
const MAX_SAMPLES: u64 = 64 << 20;

/// Sub-pixel precision of the rasterizer: 8 fractional bits.
const SUBPIXEL: i64 = 256;

/// A view direction around the model's centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewAngles {
    /// Rotation of the camera about +Y, in degrees; 0 looks from +Z towards −Z, 90 from
    /// +X towards −X.
    pub azimuth_deg: f32,
    /// Height of the camera above the horizontal, in degrees (−89..=89).
    pub elevation_deg: f32,
}

/// Options of [`render`].
#[derive(Debug, Clone, PartialEq)]
pub struct PreviewOptions {
    /// Image width in pixels, `1..=8192` (default 1024).
    pub width: u32,
    /// Image height in pixels, `1..=8192` (default 1024).
    pub height: u32,
    /// Background colour (sRGB) at the bottom of the image.
    pub background: [u8; 3],
    /// Background colour (sRGB) at the top of the image; set it equal to `background`
    /// for a flat background.
    pub background_top: [u8; 3],
    /// Samples per pixel along each axis, `1..=4` (default 2: 4 samples per pixel).
    pub supersample: u32,
    /// Vertical field of view in degrees, `1..=120` (default 30).
    pub fov_deg: f32,
    /// Fixed view direction; `None` (default) chooses one from the model's shape.
    pub view: Option<ViewAngles>,
    /// Bounds (min, max) to frame instead of the model's, so several models (two leaf
    /// modes, frames of an animation) are drawn with one camera; `None` (default) frames
    /// the model. Geometry outside is clipped.
    pub frame: Option<(Vec3, Vec3)>,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        PreviewOptions {
            width: 1024,
            height: 1024,
            background: [236, 233, 225],
            background_top: [190, 208, 226],
            supersample: 2,
            fov_deg: 30.0,
            view: None,
            frame: None,
        }
    }
}

/// An 8-bit RGBA image, rows top to bottom.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height × 4` bytes, row-major from the top-left pixel.
    pub rgba: Vec<u8>,
}

impl Image {
    /// The pixel at column `x`, row `y` (0 = top), or `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y as usize * self.width as usize + x as usize) * 4;
        let p = self.rgba.get(i..i + 4)?;
        Some([p[0], p[1], p[2], p[3]])
    }
}

/// Renders `model` (see the module docs for camera, shading and anti-aliasing).
///
/// Errors: [`Error::InvalidGeometry`] for a width or height outside `1..=8192`, a bad
/// `supersample` or `fov_deg`, or a part whose mesh fails [`crate::Mesh::validate`]
/// (non-finite coordinates, indices out of range). An empty model gives a
/// background-only image. Deterministic.
pub fn render(model: &Model, opts: &PreviewOptions) -> Result<Image> {
    // Instanced organs are drawn as the copies they stand for.
    let model = &*model.flattened();
    let bad = |why: String| Error::InvalidGeometry { what: "preview".into(), why };
    for (name, v) in [("width", opts.width), ("height", opts.height)] {
        if !(1..=MAX_SIZE).contains(&v) {
            return Err(bad(format!("image {name} is {v}; it must be in 1..={MAX_SIZE}")));
        }
    }
    if !(1..=4).contains(&opts.supersample) {
        return Err(bad(format!("supersample is {}; it must be in 1..=4", opts.supersample)));
    }
    if !(1.0..=120.0).contains(&opts.fov_deg) {
        return Err(bad(format!("fov_deg is {}; it must be in 1..=120", opts.fov_deg)));
    }
    if let Some(v) = opts.view {
        let ok = v.azimuth_deg.is_finite() && (-89.0..=89.0).contains(&v.elevation_deg);
        if !ok {
            return Err(bad(format!(
                "view angles ({}, {}) must be finite with elevation in -89..=89",
                v.azimuth_deg, v.elevation_deg
            )));
        }
    }
    for part in &model.parts {
        part.mesh.validate().map_err(|why| Error::InvalidGeometry {
            what: format!("preview of part `{}`", part.name),
            why,
        })?;
    }

    let (w, h) = (opts.width, opts.height);
    let mut ss = opts.supersample;
    while ss > 1 && (w as u64 * h as u64 * (ss * ss) as u64) > MAX_SAMPLES {
        ss -= 1;
    }
    let mut target = Target::new((w * ss) as i64, (h * ss) as i64);
    let srgb = Srgb::new();
    if let Some((lo, hi)) = opts.frame.or_else(|| model.bounds()) {
        let angles = opts.view.unwrap_or_else(|| auto_view(lo, hi));
        let cam = Camera::new(lo, hi, angles, opts.fov_deg);
        let corners = opts.frame.map(|_| {
            (0..8)
                .map(|k| Vec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), hi, lo))
                .collect()
        });
        draw_model(model, &cam, corners, &srgb, &mut target);
    }
    Ok(resolve(&target, w, h, ss, opts, &srgb))
}

/// Writes `image` as an 8-bit RGBA PNG at `path`, atomically.
///
/// Errors: [`Error::InvalidGeometry`] when the pixel buffer does not match the size;
/// [`Error::Write`] when the file cannot be written.
pub fn write_png(image: &Image, path: &Path) -> Result<()> {
    check_image(image)?;
    write_atomic(path, |w| encode_png(image, w))
}

/// [`write_png`], staged into `set` (written to a temporary that reaches `path` when the
/// set is committed with the run's other outputs, [`crate::fsutil::OutputSet`]).
pub fn stage_png(image: &Image, path: &Path, set: &mut crate::fsutil::OutputSet) -> Result<()> {
    check_image(image)?;
    set.stage(path, |w| encode_png(image, w))
}

/// Checks that `image`'s pixel buffer matches its size.
fn check_image(image: &Image) -> Result<()> {
    let expected = image.width as u64 * image.height as u64 * 4;
    if image.width == 0 || image.height == 0 || image.rgba.len() as u64 != expected {
        return Err(Error::InvalidGeometry {
            what: "preview image".into(),
            why: format!(
                "{}×{} image has {} bytes, expected {expected}",
                image.width,
                image.height,
                image.rgba.len()
            ),
        });
    }
    Ok(())
}

/// Encodes `image` as an 8-bit RGBA PNG into `w`.
fn encode_png(image: &Image, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    let mut enc = png::Encoder::new(w, image.width, image.height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    let mut writer = enc.write_header().map_err(std::io::Error::other)?;
    writer.write_image_data(&image.rgba).map_err(std::io::Error::other)?;
    writer.finish().map_err(std::io::Error::other)
}

/// The view for a model with bounds `lo..hi`: straight along an axis the model is flat
/// in (extent ≤ 15 % of the next larger one), else three-quarter.
fn auto_view(lo: Vec3, hi: Vec3) -> ViewAngles {
    let e = (hi - lo).to_array();
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| e[a].total_cmp(&e[b])); // stable: X before Y before Z on ties
    let (thin, mid) = (idx[0], idx[1]);
    let flat = e[mid] > 0.0 && e[thin] <= 0.15 * e[mid];
    let (azimuth_deg, elevation_deg) = match (flat, thin) {
        (true, 0) => (90.0, 0.0),  // y–z planar: look along −X
        (true, 2) => (0.0, 0.0),   // x–y planar: look along −Z
        (true, _) => (20.0, 65.0), // flat on the ground: look down
        _ => (25.0, 15.0),
    };
    ViewAngles { azimuth_deg, elevation_deg }
}

/// A perspective camera with an image-plane fit.
struct Camera {
    eye: Vec3,
    right: Vec3,
    up: Vec3,
    fwd: Vec3,
}

impl Camera {
    fn new(lo: Vec3, hi: Vec3, a: ViewAngles, fov_deg: f32) -> Camera {
        let centre = (lo + hi) * 0.5;
        let mut radius = (hi - lo).length() * 0.5;
        if !(radius > 0.0 && radius.is_finite()) {
            radius = 1.0;
        }
        let (az, el) = (a.azimuth_deg.to_radians(), a.elevation_deg.to_radians());
        let to_cam = Vec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos());
        let dist = radius / (fov_deg.to_radians() * 0.5).sin() * 1.05;
        let fwd = -to_cam;
        let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
        let up = right.cross(fwd);
        Camera { eye: centre + to_cam * dist, right, up, fwd }
    }

    /// Image-plane coordinates (x/z, y/z) and 1/z of a world point.
    #[inline]
    fn project(&self, p: Vec3) -> Vec3 {
        let d = p - self.eye;
        let iz = 1.0 / d.dot(self.fwd).max(1e-20);
        Vec3::new(d.dot(self.right) * iz, d.dot(self.up) * iz, iz)
    }
}

/// The supersampled frame: inverse depth (0 = empty) and shaded sRGB colour with a
/// coverage flag in alpha.
struct Target {
    w: i64,
    h: i64,
    depth: Vec<f32>,
    color: Vec<[u8; 4]>,
}

impl Target {
    fn new(w: i64, h: i64) -> Target {
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
struct Srgb {
    encode: Vec<u8>,
    decode: Vec<f32>,
}

impl Srgb {
    fn new() -> Srgb {
        let last = (ENCODE_LUT - 1) as f32;
        Srgb {
            encode: (0..ENCODE_LUT)
                .map(|i| (srgb_encode(i as f32 / last) * 255.0 + 0.5).clamp(0.0, 255.0) as u8)
                .collect(),
            decode: (0..256).map(|i| srgb_decode(i as f32 / 255.0)).collect(),
        }
    }

    #[inline]
    fn encode(&self, linear: f32) -> u8 {
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
fn draw_model(model: &Model, cam: &Camera, fit: Option<Vec<Vec3>>, srgb: &Srgb, t: &mut Target) {
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
        let c = part.material.base_color;
        let ch = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
        let base = Vec3::new(ch(c[0]), ch(c[1]), ch(c[2]));
        let normals = m.normals.as_ref();
        // The colour map, where the part has UVs (the file's look: issue 23).
        let map = part
            .material
            .maps
            .base_color
            .and_then(|i| model.images.get(i as usize))
            .zip(m.uvs.as_ref().filter(|u| u.indices.len() == m.face_indices.len()));
        for f in 0..m.face_count() {
            let corners = m.corners(f);
            if corners.len() < 3 {
                continue;
            }
            let c0 = corners.start;
            for c1 in c0 + 1..corners.end - 1 {
                let cs = [c0, c1, c1 + 1];
                let vi = cs.map(|c| m.face_indices[c] as usize);
                let world = vi.map(|v| m.positions[v]);
                let face_n = (world[1] - world[0]).cross(world[2] - world[0]).normalize_or_zero();
                let ns = match normals {
                    Some(fv) => cs.map(|c| fv.values[fv.indices[c] as usize]),
                    None => [face_n; 3],
                };
                let tex = map.map(|(im, uv)| Texture {
                    image: &im.image,
                    uv: cs.map(|c| uv.values.get(uv.indices[c] as usize).copied().unwrap_or_default()),
                    cutoff: part.material.alpha_cutoff,
                });
                draw_triangle(t, &shader, vi.map(|v| screen[v]), ns, face_n, base, tex.as_ref());
            }
        }
    }
}

/// `E_ab(p)`: twice the signed area of (a, b, p) in fixed point, y down.
#[inline]
fn edge(a: (i64, i64), b: (i64, i64), px: i64, py: i64) -> i64 {
    (b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0)
}

/// A projected vertex: fixed-point sample coordinates (y down) and 1/depth.
#[derive(Debug, Clone, Copy)]
struct ScreenVertex {
    x: i64,
    y: i64,
    iz: f32,
}

/// A triangle's colour map: the image, its corners' UVs and the alpha cut-off.
#[derive(Clone, Copy)]
struct Texture<'a> {
    image: &'a crate::texture::Image,
    uv: [glam::Vec2; 3],
    cutoff: Option<f32>,
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

    // Edge k is opposite vertex k; its value is vertex k's barycentric weight × area.
    let edges = [(p[1], p[2]), (p[2], p[0]), (p[0], p[1])];
    let len2 = edges.map(|(a, b)| {
        let (dx, dy) = ((b.0 - a.0) as f64, (b.1 - a.1) as f64);
        dx * dx + dy * dy
    });
    // A triangle thinner than one sample (its smallest height, area / longest edge, is
    // below 1; a twig seen from afar) is dilated by half a sample on every side so it
    // shows as a hairline instead of vanishing.
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
    if xmax < 0 || ymax < 0 || (xmin >> 8) >= t.w || (ymin >> 8) >= t.h {
        return;
    }
    let x0 = (xmin >> 8).clamp(0, t.w - 1);
    let x1 = (xmax >> 8).clamp(0, t.w - 1);
    let y0 = (ymin >> 8).clamp(0, t.h - 1);
    let y1 = (ymax >> 8).clamp(0, t.h - 1);

    let step = edges.map(|(a, b)| -(b.1 - a.1) * SUBPIXEL);
    let inv_area = 1.0 / area as f32;
    let iz = [s[0].iz, s[1].iz, s[2].iz];
    let half = SUBPIXEL / 2;
    for py in y0..=y1 {
        let cy = py * SUBPIXEL + half;
        let cx = x0 * SUBPIXEL + half;
        let mut e = [0i64; 3];
        let (mut k0, mut k1) = (0i64, x1 - x0);
        for k in 0..3 {
            let (a, b) = edges[k];
            e[k] = edge(a, b, cx, cy);
            let v = e[k] + bias[k];
            let st = step[k];
            // Solve v + st·j ≥ 0 for the column offset j.
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
        if k0 > k1 {
            continue;
        }
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
fn resolve(t: &Target, w: u32, h: u32, ss: u32, opts: &PreviewOptions, srgb: &Srgb) -> Image {
    let mut rgba = vec![0u8; w as usize * h as usize * 4];
    let n = (ss * ss) as f32;
    for y in 0..h {
        let f = if h > 1 { y as f32 / (h - 1) as f32 } else { 1.0 };
        let bg: [u8; 3] = std::array::from_fn(|c| {
            let (a, b) = (opts.background_top[c] as f32, opts.background[c] as f32);
            (a + (b - a) * f + 0.5).clamp(0.0, 255.0) as u8
        });
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
    Image { width: w, height: h, rgba }
}

// ---------------------------------------------------------------------------------------
// Orthographic layer renders (issue 24: the LOD chain's impostor atlas).

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
/// straight down (or up) takes +X as right. The same frame as [`render`]'s camera.
pub fn view_basis(toward: Vec3) -> (Vec3, Vec3) {
    let fwd = -toward;
    let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
    (right, right.cross(fwd))
}

/// Renders `parts` (their colour maps from `images`, indexed by
/// [`crate::model::MaterialMaps`]) orthographically from each of `views` into
/// `size × size` [`Layers`], with `supersample²` samples per pixel. Coverage follows
/// [`render`]'s rules (top-left fill, triangles thinner than a sample drawn as
/// hairlines, the alpha cut of colour-mapped materials), except that the back faces of
/// single-sided materials are culled as a glTF viewer culls them; there is no lighting. Views are
/// drawn in parallel; the result is deterministic. Instanced organs must be flattened
/// by the caller ([`Model::flattened`]).
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
            crate::model::ModelImage { image, name: String::new(), repeat: im.repeat }
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
    fn new(n: usize) -> LayerTarget {
        LayerTarget {
            depth: vec![f32::NEG_INFINITY; n],
            colour: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
        }
    }
}

/// `image` box-filtered (colour weighted by alpha) by the smallest power of two that
/// brings both sides to at most `most` pixels (and divides them).
fn reduce(image: &crate::texture::Image, most: u32) -> crate::texture::Image {
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
    let mut out = crate::texture::Image::new(w as u32, h as u32, image.channels);
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
        let c = part.material.base_color;
        let ch = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
        let base = Vec3::new(ch(c[0]), ch(c[1]), ch(c[2]));
        let normals = m.normals.as_ref();
        let map = part
            .material
            .maps
            .base_color
            .and_then(|i| images.get(i as usize))
            .zip(m.uvs.as_ref().filter(|u| u.indices.len() == m.face_indices.len()));
        let screen: Vec<ScreenVertex> = m.positions.iter().map(|&p| to_screen(p)).collect();
        // Single-sided materials show their front faces only (glTF's back-face culling).
        let cull = !part.material.double_sided;
        for f in 0..m.face_count() {
            let corners = m.corners(f);
            if corners.len() < 3 {
                continue;
            }
            let c0 = corners.start;
            for c1 in c0 + 1..corners.end - 1 {
                let cs = [c0, c1, c1 + 1];
                let vi = cs.map(|c| m.face_indices[c] as usize);
                let s = vi.map(|v| screen[v]);
                let area = edge((s[0].x, s[0].y), (s[1].x, s[1].y), s[2].x, s[2].y);
                // Nothing to draw, or a culled back face (y points down: front is negative).
                if area == 0 || (cull && area > 0) {
                    continue;
                }
                let world = vi.map(|v| m.positions[v]);
                let face_normal =
                    || (world[1] - world[0]).cross(world[2] - world[0]).normalize_or(view.toward);
                let ns = match normals {
                    Some(fv) => cs.map(|c| fv.values[fv.indices[c] as usize]),
                    None => [face_normal(); 3],
                };
                let tex = map.map(|(im, uv)| Texture {
                    image: &im.image,
                    uv: cs.map(|c| uv.values.get(uv.indices[c] as usize).copied().unwrap_or_default()),
                    cutoff: part.material.alpha_cutoff,
                });
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
                        None => base,
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
    fn get(&self) -> [f32; 3] {
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
        return;
    }
    let x0 = (xmin >> 8).clamp(0, w - 1);
    let x1 = (xmax >> 8).clamp(0, w - 1);
    let y0 = (ymin >> 8).clamp(0, h - 1);
    let y1 = (ymax >> 8).clamp(0, h - 1);
    let step = edges.map(|(a, b)| -(b.1 - a.1) * SUBPIXEL);
    let inv_area = 1.0 / area as f32;
    // Depth is affine in the edge values: z = Σ iz_k · e_k / area.
    let dz = (0..3).map(|k| iz[k] * step[k] as f32).sum::<f32>() * inv_area;
    let (zlo, zhi) = (iz[0].min(iz[1]).min(iz[2]), iz[0].max(iz[1]).max(iz[2]));
    let half = SUBPIXEL / 2;
    // Narrow boxes (most triangles of a distant tree) test every sample; wide ones solve
    // each row's span (a few divisions instead of a test per sample).
    let narrow = x1 - x0 < 16;
    for py in y0..y1 + 1 {
        let cy = py * SUBPIXEL + half;
        let cx = x0 * SUBPIXEL + half;
        let e = [0, 1, 2].map(|k| edge(edges[k].0, edges[k].1, cx, cy));
        let (mut k0, mut k1) = (0i64, x1 - x0);
        if !narrow {
            for k in 0..3 {
                let v = e[k] + bias[k];
                let st = step[k];
                if st > 0 {
                    if v < 0 {
                        k0 = k0.max((-v + st - 1) / st);
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
            if k0 > k1 {
                continue;
            }
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Mesh;
    use crate::mesh::tube::{tube_mesh, TubeOptions};
    use crate::model::{Material, Part};
    use crate::skeleton::{Skeleton, NO_PARENT};

    fn fork_skeleton() -> Skeleton {
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.12, NO_PARENT, Vec3::X, 0);
        let a = s.push(Vec3::new(0.0, 1.0, 0.0), 0.09, r, Vec3::X, 0);
        let b = s.push(Vec3::new(0.1, 1.8, 0.05), 0.06, a, Vec3::X, 0);
        s.push(Vec3::new(0.15, 2.4, 0.0), 0.03, b, Vec3::X, 0);
        let c = s.push(Vec3::new(-0.6, 1.6, 0.2), 0.05, a, Vec3::Z, 1);
        s.push(Vec3::new(-0.9, 2.1, 0.3), 0.025, c, Vec3::Z, 1);
        s.push(Vec3::new(0.5, 2.0, -0.3), 0.03, b, Vec3::Z, 1);
        s
    }

    fn model_of(mesh: Mesh, material: Material) -> Model {
        Model {
            parts: vec![Part { name: "bark".into(), mesh, material, ..Default::default() }],
            ..Default::default()
        }
    }

    fn tube_model() -> Model {
        let t = tube_mesh(&fork_skeleton(), &TubeOptions::default()).unwrap();
        model_of(t.mesh, Material::bark())
    }

    fn small() -> PreviewOptions {
        PreviewOptions { width: 96, height: 128, ..Default::default() }
    }

    /// The background (gradient) image for `opts`.
    fn background(opts: &PreviewOptions) -> Image {
        render(&Model::default(), opts).unwrap()
    }

    /// Number of pixels that differ from the background.
    fn model_pixels(img: &Image, bg: &Image, xs: std::ops::Range<u32>, ys: std::ops::Range<u32>) -> usize {
        ys.flat_map(|y| xs.clone().map(move |x| (x, y)))
            .filter(|&(x, y)| img.pixel(x, y) != bg.pixel(x, y))
            .count()
    }

    #[test]
    fn tube_model_fills_the_centre_not_the_corners() {
        let opts = small();
        let img = render(&tube_model(), &opts).unwrap();
        assert_eq!((img.width, img.height), (96, 128));
        assert_eq!(img.rgba.len(), 96 * 128 * 4);
        // The trunk runs through the middle of the frame.
        let bg = background(&opts);
        let centre_hits = model_pixels(&img, &bg, 40..56, 50..78);
        assert!(centre_hits > 20, "only {centre_hits} model pixels near the centre");
        for (x, y) in [(0, 0), (95, 0), (0, 127), (95, 127)] {
            assert_eq!(img.pixel(x, y), bg.pixel(x, y), "corner ({x}, {y})");
        }
        assert_eq!(img.pixel(0, 0), Some([190, 208, 226, 255]));
        assert_eq!(img.pixel(0, 127), Some([236, 233, 225, 255]));
    }

    #[test]
    fn rendering_is_deterministic() {
        let a = render(&tube_model(), &small()).unwrap();
        let b = render(&tube_model(), &small()).unwrap();
        assert_eq!(a, b);
    }

    #[test]
    fn empty_model_is_background_only() {
        let opts = PreviewOptions { width: 7, height: 5, ..Default::default() };
        let img = render(&Model::default(), &opts).unwrap();
        assert_eq!(img.rgba.len(), 7 * 5 * 4);
        for y in 0..5 {
            let row = img.pixel(0, y).unwrap();
            assert!((0..7).all(|x| img.pixel(x, y) == Some(row)));
        }
        // A part with no faces also renders.
        let mut m = Mesh::new();
        m.positions.push(Vec3::ONE);
        let img2 = render(&model_of(m, Material::bark()), &opts).unwrap();
        assert_eq!(img, img2);
    }

    #[test]
    fn bad_options_and_geometry_are_errors() {
        let model = tube_model();
        for (w, h) in [(0, 10), (10, 0), (8193, 10), (10, 9000)] {
            let opts = PreviewOptions { width: w, height: h, ..Default::default() };
            assert!(matches!(render(&model, &opts), Err(Error::InvalidGeometry { .. })));
        }
        for supersample in [0, 5] {
            let opts = PreviewOptions { supersample, ..small() };
            assert!(render(&model, &opts).is_err());
        }
        let opts = PreviewOptions { fov_deg: f32::NAN, ..small() };
        assert!(render(&model, &opts).is_err());
        let mut bad = model.clone();
        bad.parts[0].mesh.positions[3].y = f32::INFINITY;
        let e = render(&bad, &small()).unwrap_err();
        assert!(e.to_string().contains("bark"), "{e}");
        let mut bad = model;
        bad.parts[0].mesh.face_indices[0] = u32::MAX;
        assert!(render(&bad, &small()).is_err());
    }

    /// A square of side 2 in the x–y plane, as two triangles.
    fn square(flip: bool) -> Mesh {
        let mut m = Mesh::new();
        m.positions = vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        if flip {
            m.push_face(&[0, 2, 1]);
            m.push_face(&[0, 3, 2]);
        } else {
            m.push_face(&[0, 1, 2]);
            m.push_face(&[0, 2, 3]);
        }
        m
    }

    #[test]
    fn shared_edges_leave_no_cracks_and_both_sides_are_lit() {
        let opts = PreviewOptions { width: 64, height: 64, supersample: 1, ..Default::default() };
        let front = render(&model_of(square(false), Material::leaf()), &opts).unwrap();
        let back = render(&model_of(square(true), Material::leaf()), &opts).unwrap();
        // x–y planar: seen straight on, the square fills the frame inside the margin.
        let bg = background(&opts);
        assert_eq!(model_pixels(&front, &bg, 4..60, 4..60), 56 * 56);
        // Two-sided lighting: the flipped square shades the same as the front one.
        assert_eq!(front, back);
    }

    #[test]
    fn thin_slivers_still_draw() {
        // A 30 m tall, 1 cm wide blade next to a big square: far thinner than a pixel.
        let mut m = square(false);
        let b = m.positions.len() as u32;
        m.positions.extend([
            Vec3::new(3.0, -15.0, 0.0),
            Vec3::new(3.01, -15.0, 0.0),
            Vec3::new(3.01, 15.0, 0.0),
            Vec3::new(3.0, 15.0, 0.0),
        ]);
        m.push_face(&[b, b + 1, b + 2, b + 3]);
        let opts = PreviewOptions { width: 200, height: 200, ..Default::default() };
        let img = render(&model_of(m, Material::bark()), &opts).unwrap();
        let bg = background(&opts);
        let drawn = (0..200).filter(|&y| model_pixels(&img, &bg, 106..130, y..y + 1) > 0).count();
        assert!(drawn > 150, "sliver drawn on {drawn} rows");
    }

    /// The preview samples a part's colour map and drops what the alpha cut removes
    /// (issue 23: the preview looks like the file).
    #[test]
    fn colour_maps_are_sampled_and_alpha_cut() {
        use crate::geometry::FaceVarying;
        use crate::model::{MaterialMaps, ModelImage};
        let mut quad = square(false);
        let uv = [glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::ONE, glam::Vec2::Y];
        quad.uvs = Some(FaceVarying { values: uv.to_vec(), indices: vec![0, 1, 2, 0, 2, 3] });
        // Left texel opaque red, right texel transparent.
        let mut image = crate::texture::Image::new(2, 1, 4);
        image.data = vec![255, 0, 0, 255, 0, 0, 255, 0];
        let opts = PreviewOptions { width: 64, height: 64, supersample: 1, ..Default::default() };
        let bg = background(&opts);
        let draw = |cutoff: Option<f32>| {
            let material = Material {
                maps: MaterialMaps { base_color: Some(0), ..Default::default() },
                alpha_cutoff: cutoff,
                ..Material::bark()
            };
            let mut model = model_of(quad.clone(), material);
            model.images.push(ModelImage { name: "t".into(), image: image.clone(), repeat: false });
            render(&model, &opts).unwrap()
        };
        let (full, cut) = (draw(None), draw(Some(0.5)));
        let (all, kept) = (model_pixels(&full, &bg, 0..64, 0..64), model_pixels(&cut, &bg, 0..64, 0..64));
        assert!(
            all > 1000 && (kept as f64) > 0.4 * all as f64 && (kept as f64) < 0.6 * all as f64,
            "{kept} of {all}"
        );
        let (left, right) = (model_pixels(&cut, &bg, 0..32, 0..64), model_pixels(&cut, &bg, 32..64, 0..64));
        assert!(left.min(right) * 10 < left.max(right), "one half cut away: {left} / {right}");
        // Kept pixels are the map's red, not the bark's brown.
        let red = (0..64)
            .flat_map(|y| (0..64).map(move |x| (x, y)))
            .filter(|&(x, y)| cut.pixel(x, y) != bg.pixel(x, y))
            .filter_map(|(x, y)| cut.pixel(x, y))
            .all(|p| p[0] > 3 * p[1].max(p[2]).max(8));
        assert!(red, "colours come from the map");
    }

    #[test]
    fn planar_models_are_seen_face_on() {
        let v = auto_view(Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 3.0, 1.0));
        assert_eq!((v.azimuth_deg, v.elevation_deg), (90.0, 0.0));
        let v = auto_view(Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 3.0, 0.01));
        assert_eq!((v.azimuth_deg, v.elevation_deg), (0.0, 0.0));
        let v = auto_view(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0));
        assert_eq!(v.elevation_deg, 65.0);
        let v = auto_view(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 3.0, 1.0));
        assert_eq!((v.azimuth_deg, v.elevation_deg), (25.0, 15.0));
        // A tube tree drawn in the y–z plane renders visibly.
        let mut s = fork_skeleton();
        for p in &mut s.position {
            *p = Vec3::new(0.0, p.y, p.x + p.z);
        }
        let t = tube_mesh(&s, &TubeOptions::default()).unwrap();
        let img = render(&model_of(t.mesh, Material::bark()), &small()).unwrap();
        let hits = model_pixels(&img, &background(&small()), 0..96, 0..128);
        assert!(hits > 300, "{hits}");
    }

    #[test]
    fn write_png_round_trips() {
        let img = render(&tube_model(), &small()).unwrap();
        let dir = std::env::temp_dir().join(format!("sylva-preview-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("fork.png");
        write_png(&img, &path).unwrap();
        let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (96, 128));
        assert_eq!(info.color_type, png::ColorType::Rgba);
        assert_eq!(&buf[..info.buffer_size()], &img.rgba[..]);
        std::fs::remove_dir_all(&dir).unwrap();
        // A buffer that does not match its size is refused.
        let broken = Image { width: 2, height: 2, rgba: vec![0; 3] };
        assert!(write_png(&broken, &dir.join("x.png")).is_err());
    }

    /// Speed check: `cargo test --release -p sylva preview::tests::throughput -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn throughput() {
        let s = crate::mesh::tube::tests::binary_tree(14, 4);
        let t = tube_mesh(&s, &TubeOptions::default()).unwrap();
        let model = model_of(t.mesh, Material::bark());
        let opts = PreviewOptions::default();
        let t0 = std::time::Instant::now();
        let img = render(&model, &opts).unwrap();
        println!("{} triangles at 1024²: {:.1} ms", model.triangle_count(), t0.elapsed().as_secs_f64() * 1e3);
        write_png(&img, &std::env::temp_dir().join("sylva-preview-big.png")).unwrap();
    }
}
