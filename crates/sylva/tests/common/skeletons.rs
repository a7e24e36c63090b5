//! Skeleton fixtures shared by the mesher tests (included with `#[path]`).
#![allow(dead_code)]

use glam::Vec3;
use sylva::{Skeleton, NO_PARENT};

/// Appends a node at `p` with radius `r` below `parent` (its up vector any unit vector
/// normal to the segment; +X for a root).
pub fn seg(s: &mut Skeleton, parent: u32, p: Vec3, r: f32) -> u32 {
    let up = if parent == NO_PARENT {
        Vec3::X
    } else {
        let d = p - s.position[parent as usize];
        d.any_orthonormal_vector()
    };
    s.push(p, r, parent, up, 0)
}

/// An unbranched chain through `points`, all of radius `r`.
pub fn chain(points: &[Vec3], r: f32) -> Skeleton {
    let mut s = Skeleton::new();
    let mut at = NO_PARENT;
    for &p in points {
        at = seg(&mut s, at, p, r);
    }
    s
}

/// A trunk of height 3 (radius 0.2) forking into two branches of radii `r_right` (to
/// +x) and `r_left` (to −x, a little out of the plane).
pub fn y_fork(r_right: f32, r_left: f32) -> Skeleton {
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
    let a = seg(&mut s, r, Vec3::Y * 3.0, 0.2);
    seg(&mut s, a, Vec3::new(1.5, 5.0, 0.0), r_right);
    seg(&mut s, a, Vec3::new(-1.2, 5.2, 0.3), r_left);
    s
}

/// Trunk of height 2 (radius 0.2) with `n` children of length 2 fanned around its top at
/// `tilt` from vertical; with `wobble` the children's tilts alternate (a non-planar
/// whorl).
pub fn whorl(n: usize, tilt: f32, r_child: f32, wobble: f32) -> Skeleton {
    let mut s = Skeleton::new();
    let root = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
    let top = seg(&mut s, root, Vec3::Y * 2.0, 0.2);
    for k in 0..n {
        let a = k as f32 * std::f32::consts::TAU / n as f32;
        let t = tilt + if k % 2 == 0 { wobble } else { -wobble };
        let d = Vec3::new(t.sin() * a.cos(), t.cos(), t.sin() * a.sin());
        seg(&mut s, top, Vec3::Y * 2.0 + d * 2.0, r_child);
    }
    s
}
