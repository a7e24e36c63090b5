//! Two small hand-built rigs with known shapes: a trunk with side branches and a
//! vertical chain. The wind module's own tests and the GPU wind's comparison with it
//! (`sylva-gpu/tests/wind.rs`) run on these same trees; they also make a quick rig to
//! try wind settings on without growing a tree (Skjermo2008-spec §4).

use super::WindRig;
use crate::model::BranchCurves;
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::Vec3;

/// A trunk of three unit segments (radius 0.2) with a two-segment side branch (radii
/// 0.05 and 0.03, order 1) at each inner node: two levels of branches.
pub fn small_tree() -> WindRig {
    let mut s = Skeleton::new();
    let mut prev = s.push(Vec3::ZERO, 0.2, NO_PARENT, Vec3::X, 0);
    for k in 1..=3 {
        let n = s.push(Vec3::new(0.0, k as f32, 0.0), 0.2, prev, Vec3::X, 0);
        if k < 3 {
            let a = s.push(Vec3::new(0.8, k as f32 + 0.5, 0.0), 0.05, n, Vec3::Y, 1);
            s.push(Vec3::new(1.5, k as f32 + 1.2, 0.3), 0.03, a, Vec3::Y, 1);
        }
        prev = n;
    }
    WindRig::new(&BranchCurves::fit(&s))
}

/// A vertical chain of `k` unit segments (radius 0.1) on one axis.
pub fn chain(k: usize) -> WindRig {
    let mut s = Skeleton::new();
    let mut prev = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
    for i in 1..=k {
        prev = s.push(Vec3::new(0.0, i as f32, 0.0), 0.1, prev, Vec3::X, 0);
    }
    WindRig::new(&BranchCurves::fit(&s))
}
