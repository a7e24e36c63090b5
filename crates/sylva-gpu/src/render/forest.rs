//! Many trees at once (issue 25 item 4; McLoughlin2021 §4.2, the multi-tree slowdown; Skjermo2008
//! §4): a seeded grid of instance transforms with yaw, scale and position jitter, and the
//! per-frame choice of each instance's level of detail by its projected size, bucketed so
//! the renderer issues one instanced draw per (level, part, material) for all trees.

use super::camera::Camera;
use glam::{Mat4, Quat, Vec3};

/// Most trees a forest may hold.
pub const MAX_TREES: usize = 100_000;

/// SplitMix64: a small, seedable, portable generator (the forest must not change with a
/// dependency's version).
#[derive(Debug, Clone)]
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in \[0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `count` trees of a model with bounds `lo..hi` on a square grid in the ground (x–z)
/// plane: a spacing of 1.1 × the model's larger horizontal extent, each tree turned by a
/// random yaw, scaled by 0.8–1.2 and moved by up to a quarter spacing, from `seed`.
/// The model's horizontal centre sits on its grid point; the grid is centred on the
/// origin. The first tree of a forest of one is the model itself (identity).
pub fn grid(count: usize, seed: u64, (lo, hi): (Vec3, Vec3)) -> Vec<Mat4> {
    if count == 1 {
        return vec![Mat4::IDENTITY];
    }
    let ext = hi - lo;
    let spacing = (ext.x.max(ext.z) * 1.1).max(ext.y * 0.3).max(1e-3);
    let cols = (count as f64).sqrt().ceil() as usize;
    let rows = count.div_ceil(cols.max(1));
    let centre = Vec3::new((lo.x + hi.x) * 0.5, 0.0, (lo.z + hi.z) * 0.5);
    let mut rng = SplitMix(seed ^ 0x5EED_F0E5_7000_0000);
    (0..count)
        .map(|i| {
            let (c, r) = ((i % cols) as f32, (i / cols) as f32);
            let yaw = rng.unit() * std::f32::consts::TAU;
            let scale = 0.8 + 0.4 * rng.unit();
            let jitter = Vec3::new(rng.unit() - 0.5, 0.0, rng.unit() - 0.5) * (0.5 * spacing);
            let at = Vec3::new(
                (c - (cols as f32 - 1.0) * 0.5) * spacing,
                0.0,
                (r - (rows as f32 - 1.0) * 0.5) * spacing,
            ) + jitter;
            Mat4::from_scale_rotation_translation(Vec3::splat(scale), Quat::from_rotation_y(yaw), at)
                * Mat4::from_translation(-centre)
        })
        .collect()
}

/// The box holding the model's box `lo..hi` under every transform of `instances`.
pub fn bounds(instances: &[Mat4], (lo, hi): (Vec3, Vec3)) -> Option<(Vec3, Vec3)> {
    let mut out: Option<(Vec3, Vec3)> = None;
    for m in instances {
        for k in 0..8 {
            let c = m.transform_point3(Vec3::select(
                glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0),
                hi,
                lo,
            ));
            out = Some(out.map_or((c, c), |(a, b)| (a.min(c), b.max(c))));
        }
    }
    out
}

/// The level of detail of each instance: the finest level whose smallest screen coverage
/// (`thresholds`, finest first, fractions of the view's height as glTF's `MSFT_lod`
/// states them) the instance's projected bounding sphere (`centre`, `radius` in model
/// space) reaches; the coarsest level for anything smaller (trees are never culled).
pub fn choose_levels(
    camera: &Camera,
    instances: &[Mat4],
    (centre, radius): (Vec3, f32),
    thresholds: &[f32],
) -> Vec<usize> {
    let last = thresholds.len().saturating_sub(1);
    instances
        .iter()
        .map(|m| {
            let scale = m.x_axis.truncate().length();
            let px = camera.projected_height(m.transform_point3(centre), radius * scale);
            let coverage = px / camera.height as f32;
            thresholds.iter().position(|&t| coverage >= t).unwrap_or(last)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::Orbit;

    #[test]
    fn the_grid_is_seeded_jittered_and_spaced() {
        let b = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 5.0, 1.0));
        let a = grid(20, 7, b);
        assert_eq!(a.len(), 20);
        assert_eq!(a, grid(20, 7, b), "same seed, same forest");
        assert_ne!(a, grid(20, 8, b), "another seed, another forest");
        let pos: Vec<Vec3> = a.iter().map(|m| m.transform_point3(Vec3::ZERO)).collect();
        for (i, p) in pos.iter().enumerate() {
            assert_eq!(p.y, 0.0);
            for q in &pos[i + 1..] {
                assert!(p.distance(*q) > 1.0, "trees keep at least half a spacing apart");
            }
        }
        assert_eq!(grid(1, 7, b), vec![Mat4::IDENTITY]);
    }

    #[test]
    fn far_trees_take_coarser_levels() {
        let b = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 5.0, 1.0));
        let trees = grid(400, 1, b);
        let fb = bounds(&trees, b).unwrap();
        let cam = Camera::new(
            fb,
            Orbit { azimuth_deg: 0.0, elevation_deg: 10.0 },
            30.0,
            (800, 600),
            [fb.0, fb.1],
            fb,
        );
        let levels = choose_levels(&cam, &trees, (Vec3::new(0.0, 2.5, 0.0), 2.7), &[0.2, 0.1, 0.0]);
        let near = trees.iter().zip(&levels).max_by(|a, b| {
            cam.depth(b.0.transform_point3(Vec3::ZERO))
                .total_cmp(&cam.depth(a.0.transform_point3(Vec3::ZERO)))
        });
        let far = trees.iter().zip(&levels).max_by(|a, b| {
            cam.depth(a.0.transform_point3(Vec3::ZERO))
                .total_cmp(&cam.depth(b.0.transform_point3(Vec3::ZERO)))
        });
        assert!(near.unwrap().1 < far.unwrap().1, "{:?} vs {:?}", near.unwrap().1, far.unwrap().1);
        assert!(levels.iter().all(|&l| l <= 2));
    }
}
