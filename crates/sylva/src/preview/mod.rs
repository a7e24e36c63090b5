//! CPU preview renderer: draws a [`Model`] into an RGBA image and writes it as a PNG.
//!
//! This is what `--preview out.png` runs, so a user can look at one picture and
//! recognise the tree; it is the architecture's `preview (PNG)` stage and needs no GPU.
//! `camera.rs` frames the model (a planar model face-on, anything else in a three-quarter
//! view), `raster.rs` draws z-buffered, supersampled, Lambert-shaded triangles two-sided
//! in linear light and resolves them to sRGB, `layers.rs` renders impostor layers, and
//! [`animation`] writes the wind clip as a GIF or APNG.
//!
//! Cost: O(vertices + triangles + covered samples), single-threaded; a 1M-triangle tree
//! at 1024² takes a fraction of a second in release builds.

use crate::error::{Error, Result};
use crate::fsutil::write_atomic;
use crate::model::Model;
use glam::Vec3;
use std::path::Path;

pub mod animation;
mod camera;
mod layers;
mod raster;

use self::camera::{auto_view, Camera};
pub use self::layers::{render_layers, view_basis, LayerView, Layers};
use self::raster::{draw_model, resolve, Srgb, Target};
/// The image [`render`] returns (4 channels, RGBA) and [`write_png`] writes.
pub use crate::image::Image;

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

/// Writes `image` as an 8-bit PNG (RGBA, or RGB for a 3-channel image) at `path`,
/// atomically.
///
/// Errors: [`Error::InvalidGeometry`] when the pixel buffer does not match the size;
/// [`Error::Write`] when the file cannot be written.
pub fn write_png(image: &Image, path: &Path) -> Result<()> {
    image.check("preview image")?;
    write_atomic(path, |w| image.encode_png(w))
}

/// [`write_png`], staged into `set` (written to a temporary that reaches `path` when the
/// set is committed with the run's other outputs, [`crate::fsutil::OutputSet`]).
pub fn stage_png(image: &Image, path: &Path, set: &mut crate::fsutil::OutputSet) -> Result<()> {
    image.check("preview image")?;
    set.stage(path, |w| image.encode_png(w))
}

/// The sRGB background colour of row `y` (0 = top) of a picture `height` rows tall:
/// `top` on the first row, `bottom` on the last, a gradient in sRGB bytes between — what
/// [`render`] and the GPU renderer paint behind the model.
pub fn background_row(bottom: [u8; 3], top: [u8; 3], y: u32, height: u32) -> [u8; 3] {
    let f = if height > 1 { y as f32 / (height - 1) as f32 } else { 1.0 };
    std::array::from_fn(|c| {
        let (a, b) = (top[c] as f32, bottom[c] as f32);
        (a + (b - a) * f + 0.5).clamp(0.0, 255.0) as u8
    })
}

/// Pixels of `image` that differ from the background gradient (see [`background_row`])
/// in any colour channel by more than `tolerance`: the silhouette of what was drawn,
/// row-major. Compares renderers (CPU preview, GPU) that paint the same background.
pub fn silhouette(image: &Image, background: [u8; 3], background_top: [u8; 3], tolerance: u8) -> Vec<bool> {
    let (w, c) = (image.width as usize, image.channels.max(1) as usize);
    if w == 0 {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(w * image.height as usize);
    for (y, row) in image.data.chunks_exact(w * c).enumerate() {
        let bg = background_row(background, background_top, y as u32, image.height);
        out.extend(row.chunks_exact(c).map(|p| (0..3).any(|k| p[k].abs_diff(bg[k]) > tolerance)));
    }
    out
}

/// Intersection over union of two silhouettes of the same size (1 where both are empty).
pub fn iou(a: &[bool], b: &[bool]) -> f64 {
    let inter = a.iter().zip(b).filter(|(x, y)| **x && **y).count();
    let union = a.iter().zip(b).filter(|(x, y)| **x || **y).count();
    if union == 0 {
        1.0
    } else {
        inter as f64 / union as f64
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
        assert_eq!(img.data.len(), 96 * 128 * 4);
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
        assert_eq!(img.data.len(), 7 * 5 * 4);
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
        let mut image = Image::new(2, 1, 4);
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
            model.images.push(ModelImage { name: "t".into(), image: image.clone().into(), repeat: false });
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
        assert_eq!(&buf[..info.buffer_size()], &img.data[..]);
        std::fs::remove_dir_all(&dir).unwrap();
        // A buffer that does not match its size is refused.
        let broken = Image::from_rgba(2, 2, vec![0; 3]);
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
