//! Random skeletons for the meshers' property tests (issue 5: "random branching angles
//! 5°–170°, 1–8 children, radius ratios 0.1–1.2, lengths from 0.2 to 20 radii").

use glam::Vec3;
use sylva::{Skeleton, NO_PARENT};

/// A random tree: branching angles 5°–170°, 1–8 children, radius ratios 0.1–1.2,
/// internode lengths 0.2–20 radii.
pub fn random_tree(seed: u64, max_nodes: usize) -> Skeleton {
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut rnd = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 33) as f64 / (1u64 << 31) as f64) as f32
    };
    let mut s = Skeleton::new();
    let root = s.push(Vec3::ZERO, 0.2, NO_PARENT, Vec3::X, 0);
    let first = s.push(Vec3::Y * (0.2 * (0.2 + rnd() * 19.8)), 0.2, root, Vec3::X, 0);
    let mut open = vec![first];
    while let Some(node) = open.pop() {
        if s.len() >= max_nodes {
            break;
        }
        let parent = s.parent[node as usize];
        let p = s.position[node as usize];
        let dir = (p - s.position[parent as usize]).try_normalize().unwrap_or(Vec3::Y);
        let r = s.radius[node as usize];
        let n = if rnd() < 0.25 { 0 } else { 1 + (rnd() * 8.0) as usize % 8 };
        let side = dir.any_orthonormal_vector();
        for _ in 0..n {
            let angle = (5.0 + rnd() * 165.0).to_radians();
            let az = rnd() * std::f32::consts::TAU;
            let ortho = glam::Quat::from_axis_angle(dir, az) * side;
            let d = dir * angle.cos() + ortho * angle.sin();
            let rc = (r * (0.1 + rnd() * 1.1)).max(1e-3);
            let len = rc * (0.2 + rnd() * 19.8);
            let up = d.any_orthonormal_vector();
            let c = s.push(p + d * len, rc, node, up, 1);
            if s.len() >= max_nodes {
                break;
            }
            open.push(c);
        }
    }
    s
}
