//! The impostor: the chain's LOD0 drawn by the CPU preview renderer into a
//! hemi-octahedral atlas of views (albedo with alpha coverage, and a normal map), and
//! crossed billboards that show the atlas's side and top views.
//!
//! Atlas layout (`n × n` frames of `⌊size / n⌋` pixels; frame `(i, j)` is column `i`
//! from the left, row `j` from the top): the frame's grid point is
//! `g = (2i / (n − 1) − 1, 2j / (n − 1) − 1)` and its view direction (toward the viewer,
//! +Y up) is the hemi-octahedral decode
//! `normalize(a, 1 − |a| − |b|, b)` with `a = (gx + gy) / 2`, `b = (gx − gy) / 2`.
//! The corners and edges of the grid are the horizon (the corners look from +X, +Z, −X
//! and −Z), its middle looks straight down. Every frame is an orthographic view of the
//! same square, `2R` on a side around the model's centre (R: the largest distance of a
//! vertex from the centre of its bounds), with [`crate::preview::view_basis`] as its
//! axes.

use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use crate::image::Image;
use crate::model::{Material, MaterialMaps, ModelImage, Part};
use crate::preview::{render_layers, view_basis, LayerView};
use glam::{Vec2, Vec3};

/// Samples per pixel along each axis of an atlas frame.
const SUPERSAMPLE: u32 = 1;

/// Rounds of colour padding around each frame's silhouette (texels that bilinear
/// filtering and mip-mapping read from outside the alpha cut).
const PADDING: usize = 2;

/// Azimuths (degrees, 0 = from +Z, 90 = from +X) of the vertical billboards: each also
/// shows the opposite side (double-sided), so four cover the eight side directions.
const BILLBOARD_AZIMUTHS: [f32; 4] = [0.0, 45.0, 90.0, 135.0];

/// The grid point in \[−1, 1\]² of frame `(i, j)` of an `n × n` atlas.
fn grid(i: u32, j: u32, n: u32) -> Vec2 {
    let m = (n.max(2) - 1) as f32;
    Vec2::new(2.0 * i as f32 / m - 1.0, 2.0 * j as f32 / m - 1.0)
}

/// The view direction (unit, toward the viewer, y ≥ 0) of frame `(i, j)` of an
/// `n × n` hemi-octahedral atlas (see the module docs).
pub fn frame_direction(i: u32, j: u32, n: u32) -> Vec3 {
    let g = grid(i, j, n);
    let (a, b) = ((g.x + g.y) * 0.5, (g.x - g.y) * 0.5);
    Vec3::new(a, (1.0 - a.abs() - b.abs()).max(0.0), b).normalize_or(Vec3::Y)
}

/// The frame `(i, j)` of an `n × n` atlas whose grid point is nearest the
/// hemi-octahedral encoding of `d` (below the horizon is folded onto it).
pub fn frame_of(d: Vec3, n: u32) -> (u32, u32) {
    let d = Vec3::new(d.x, d.y.max(0.0), d.z);
    let s = d.x.abs() + d.y + d.z.abs();
    let (a, b) = if s > 0.0 { (d.x / s, d.z / s) } else { (0.0, 0.0) };
    let m = (n.max(2) - 1) as f32;
    let idx = |g: f32| (((g + 1.0) * 0.5 * m).round().clamp(0.0, m)) as u32;
    (idx(a + b), idx(a - b))
}

/// What [`build`] makes: the two atlas images and the billboards part.
pub struct Impostor {
    /// `impostor_albedo` (RGBA, alpha = coverage) and `impostor_normal` (RGB).
    pub images: Vec<ModelImage>,
    /// The crossed billboards, material `impostor`.
    pub part: Part,
}

/// Renders `parts` (colour maps from `images`) into an `n × n` atlas of `size` pixels
/// and builds the billboards; the material's maps are `image_base` (albedo) and
/// `image_base + 1` (normal). Errors: no geometry to draw, or the renderer's.
pub fn build(parts: &[Part], images: &[ModelImage], n: u32, size: u32, image_base: u32) -> Result<Impostor> {
    let bad = |why: String| Error::InvalidGeometry { what: "LOD impostor".into(), why };
    let bounds = parts
        .iter()
        .filter(|p| p.mesh.face_count() > 0)
        .filter_map(|p| p.mesh.bounds())
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
        .ok_or_else(|| bad("LOD0 has no faces to draw".into()))?;
    let centre = (bounds.0 + bounds.1) * 0.5;
    let radius =
        parts.iter().flat_map(|p| p.mesh.positions.iter()).map(|p| p.distance(centre)).fold(0.0f32, f32::max)
            * 1.01;
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(bad(format!("LOD0 has no extent (radius {radius})")));
    }
    let frame = size / n;
    if frame == 0 {
        return Err(bad(format!("{n} frames do not fit in {size} pixels")));
    }
    // What is smaller than half a frame pixel cannot show: the opaque parts (bark) are
    // simplified that far first; alpha-cut cards are drawn as they are.
    let pixel = 2.0 * radius / frame as f32;
    let coarse: Vec<Part> = parts
        .iter()
        .map(|p| {
            if p.material.alpha_cutoff.is_some() {
                return Ok(p.clone());
            }
            let mesh = super::simplify::simplify_within(&p.mesh, 0.5 * pixel, "LOD impostor")?;
            Ok(Part { mesh, ..p.clone() })
        })
        .collect::<Result<_>>()?;
    let parts = &coarse[..];
    let views: Vec<LayerView> = (0..n * n)
        .map(|k| LayerView { centre, toward: frame_direction(k % n, k / n, n), half_extent: radius })
        .collect();
    crate::cancel::check()?;
    let layers = render_layers(parts, images, &views, frame, SUPERSAMPLE)?;
    let mut albedo = Image::new(size, size, 4);
    let mut normal = Image::new(size, size, 3);
    // Flat normal (facing the viewer) where no frame is.
    for px in normal.data.chunks_exact_mut(3) {
        px.copy_from_slice(&[128, 128, 255]);
    }
    let f = frame as usize;
    for (k, mut l) in layers.into_iter().enumerate() {
        pad(&mut l.albedo, f);
        let (x0, y0) = ((k % n as usize) * f, (k / n as usize) * f);
        for row in 0..f {
            let at = (y0 + row) * size as usize + x0;
            albedo.data[at * 4..(at + f) * 4].copy_from_slice(&l.albedo[row * f * 4..(row + 1) * f * 4]);
            normal.data[at * 3..(at + f) * 3].copy_from_slice(&l.normal[row * f * 3..(row + 1) * f * 3]);
        }
    }
    let part = billboards(centre, radius, n, frame, size, image_base);
    Ok(Impostor {
        images: vec![
            ModelImage { name: "impostor_albedo".into(), image: albedo.into(), repeat: false },
            ModelImage { name: "impostor_normal".into(), image: normal.into(), repeat: false },
        ],
        part,
    })
}

/// Fills the colour of uncovered texels of a `f × f` RGBA frame from covered (or already
/// filled) neighbours, [`PADDING`] rounds, so filtering at the silhouette does not
/// bleed black. Alpha is left as it is.
fn pad(rgba: &mut [u8], f: usize) {
    let mut filled: Vec<bool> = rgba.chunks_exact(4).map(|p| p[3] > 0).collect();
    for _ in 0..PADDING {
        let before = filled.clone();
        let src = rgba.to_vec();
        for y in 0..f {
            for x in 0..f {
                let i = y * f + x;
                if before[i] {
                    continue;
                }
                let (mut sum, mut k) = ([0u32; 3], 0u32);
                for (dx, dy) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1), (-1, -1), (1, 1), (-1, 1), (1, -1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < 0 || ny < 0 || nx >= f as i64 || ny >= f as i64 {
                        continue;
                    }
                    let j = ny as usize * f + nx as usize;
                    if before[j] {
                        for c in 0..3 {
                            sum[c] += src[j * 4 + c] as u32;
                        }
                        k += 1;
                    }
                }
                let half = k / 2;
                let mut any = false;
                for c in 0..3 {
                    if let Some(v) = (sum[c] + half).checked_div(k) {
                        rgba[i * 4 + c] = v as u8;
                        any = true;
                    }
                }
                if any {
                    filled[i] = true;
                }
            }
        }
    }
}

/// The billboards: a vertical quad through the centre for each side frame nearest
/// [`BILLBOARD_AZIMUTHS`] (facing that frame's exact direction, so from there it shows
/// that view pixel for pixel), and a horizontal one showing the frame nearest the view
/// from straight above. Quads are `2R` square, double-sided, UVs on their frame.
fn billboards(centre: Vec3, radius: f32, n: u32, frame: u32, size: u32, image_base: u32) -> Part {
    let side_frames: Vec<(u32, u32)> = (0..n * n)
        .map(|k| (k % n, k / n))
        .filter(|&(i, j)| i == 0 || j == 0 || i == n - 1 || j == n - 1)
        .collect();
    let mut chosen: Vec<((u32, u32), Vec3)> = Vec::new();
    for az in BILLBOARD_AZIMUTHS {
        let a = az.to_radians();
        let want = Vec3::new(a.sin(), 0.0, a.cos());
        let Some(&best) = side_frames.iter().max_by(|p, q| {
            let (dp, dq) = (frame_direction(p.0, p.1, n).dot(want), frame_direction(q.0, q.1, n).dot(want));
            dp.total_cmp(&dq).then(q.cmp(p))
        }) else {
            continue;
        };
        let d = frame_direction(best.0, best.1, n);
        if chosen.iter().all(|(_, e)| e.dot(d).abs() < 0.999) {
            chosen.push((best, d));
        }
    }
    let mut mesh = Mesh::new();
    let mut uvs = FaceVarying::default();
    let mut normals = FaceVarying::default();
    let texel = |i: u32, j: u32, sx: f32, sy: f32| {
        let f = frame as f32;
        let s = size as f32;
        Vec2::new((i as f32 * f + (sx + 1.0) * 0.5 * f) / s, 1.0 - (j as f32 * f + (1.0 - sy) * 0.5 * f) / s)
    };
    let mut quad = |(i, j): (u32, u32), right: Vec3, up: Vec3, facing: Vec3| {
        let first = mesh.positions.len() as u32;
        for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            mesh.positions.push(centre + (right * sx + up * sy) * radius);
            uvs.values.push(texel(i, j, sx, sy));
        }
        mesh.push_face(&[first, first + 1, first + 2, first + 3]);
        uvs.indices.extend(first..first + 4);
        normals.indices.extend([normals.values.len() as u32; 4]);
        normals.values.push(facing);
    };
    for &(f, d) in &chosen {
        let (right, up) = view_basis(d);
        quad(f, right, up, d);
    }
    let top = frame_of(Vec3::Y, n);
    let (right, _) = view_basis(frame_direction(top.0, top.1, n));
    quad(top, right, Vec3::Y.cross(right), Vec3::Y);
    mesh.uvs = Some(uvs);
    mesh.normals = Some(normals);
    let material = Material {
        name: "impostor".into(),
        base_color: [1.0, 1.0, 1.0, 1.0],
        metallic: 0.0,
        roughness: 0.9,
        double_sided: true,
        maps: MaterialMaps {
            base_color: Some(image_base),
            normal: Some(image_base + 1),
            ..Default::default()
        },
        alpha_cutoff: Some(0.5),
    };
    Part::new("impostor", mesh, material)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_and_the_edges_are_the_horizon() {
        for n in [2u32, 3, 8, 9, 16] {
            for j in 0..n {
                for i in 0..n {
                    let d = frame_direction(i, j, n);
                    assert!((d.length() - 1.0).abs() < 1e-5 && d.y >= 0.0);
                    assert_eq!(frame_of(d, n), (i, j), "n {n}");
                    if i == 0 || j == 0 || i == n - 1 || j == n - 1 {
                        assert!(d.y.abs() < 1e-6, "edge frame ({i}, {j}) of {n} is on the horizon: {d}");
                    }
                }
            }
            let c = |i, j| frame_direction(i, j, n);
            assert!((c(n - 1, n - 1) - Vec3::X).length() < 1e-6);
            assert!((c(n - 1, 0) - Vec3::Z).length() < 1e-6);
            assert!((c(0, 0) + Vec3::X).length() < 1e-6);
            assert!((c(0, n - 1) + Vec3::Z).length() < 1e-6);
        }
        assert_eq!(frame_direction(4, 4, 9), Vec3::Y);
    }
}
