//! A deterministic test tree shared by the hull tests and the mesher benchmarks
//! (`#[path]`-included): `depth` levels, three children per branch, `segs` internodes
//! per branch, wobbling directions and tapering radii (about 10 k nodes at depth 8).

use glam::Vec3;
use sylva::{Skeleton, NO_PARENT};

/// The tree: branch lengths shrink by 0.75 and radii by 0.65 per level; each node's up
/// vector is orthogonal to its internode; branch order is the level.
pub fn tree(depth: u32, segs: u32) -> Skeleton {
    let mut s = Skeleton::new();
    let root = s.push(Vec3::ZERO, 0.3, NO_PARENT, Vec3::X, 0);
    let mut stack = vec![(root, Vec3::Y, 2.0f32, 0.3f32, 0u32)];
    let mut h = 1u32;
    while let Some((node, dir, len, r, level)) = stack.pop() {
        let mut at = node;
        let mut p = s.position[node as usize];
        let mut d = dir;
        for k in 0..segs {
            h = h.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let wob =
                Vec3::new(((h >> 8) % 100) as f32 / 500.0 - 0.1, 0.0, ((h >> 16) % 100) as f32 / 500.0 - 0.1);
            d = (d + wob).normalize();
            p += d * (len / segs as f32);
            let rr = r * (1.0 - 0.25 * (k + 1) as f32 / segs as f32);
            at = s.push(p, rr, at, d.any_orthonormal_vector(), level as u16);
        }
        if level + 1 < depth {
            let side = d.any_orthonormal_vector();
            let other = d.cross(side);
            for (k, w) in [0.8f32, -0.7, 0.3].iter().enumerate() {
                let nd = (d + side * *w + other * (k as f32 - 1.0) * 0.5).normalize();
                stack.push((at, nd, len * 0.75, r * 0.65, level + 1));
            }
        }
    }
    s
}
