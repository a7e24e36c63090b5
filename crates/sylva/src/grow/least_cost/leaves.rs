//! Leaves of least-cost-path trees (Xu2015 §4.5; Xu2015-spec §2.8): organs placed at the
//! tips of the finished skeleton, after the path union is built and thickened.
//!
//! - `leaf`: "randomly rotated polygons of varied size centred at endpoints" — each leaf
//!   blade ([`OrganKind::Leaf`], length `size`, width `size / 2`) is centred on its tip:
//!   its base lies `size / 2` behind the tip along a uniformly random heading, its blade
//!   normal is a uniformly random direction perpendicular to the heading.
//! - `needles`: "a few short lines per endpoint at random angles from the up vector" —
//!   each needle is a thin quad ([`OrganKind::Polygon`], width `size / 16`) from the tip
//!   along a direction at most `spread` degrees from +Y, at a uniformly random azimuth.
//!
//! Sizes vary uniformly in `size · (1 ± size_variation)`. Every random choice is a hash
//! of (seed, tip node, organ), so leaves never depend on visiting order or threads, and
//! `kind = "none"` (the default) leaves the skeleton untouched.

use super::{bad, hash01, in_range};
use crate::error::Result;
use crate::skeleton::{Organ, OrganKind, Skeleton};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Most leaf organs one tree may carry (all tips together).
pub const MAX_LEAVES: usize = 2_000_000;

/// `generator.leaves.kind` (serde: `none`, `leaf`, `needles`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LeafKind {
    /// No leaves.
    #[default]
    None,
    /// A leaf organ per tip.
    Leaf,
    /// Needles (quads) per tip.
    Needles,
}

impl std::fmt::Display for LeafKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LeafKind::None => "none",
            LeafKind::Leaf => "leaf",
            LeafKind::Needles => "needles",
        })
    }
}

/// `[generator.leaves]` of a least-cost recipe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LeafParams {
    /// `none` (default), `leaf` or `needles`.
    pub kind: LeafKind,
    /// Organs per tip, 1..=64 (default 1).
    pub count: u32,
    /// Leaf length / needle length in metres (default 0.15).
    pub size: f64,
    /// Relative size variation in [0, 1) (default 0.3): sizes are uniform in
    /// `size · (1 ± size_variation)`.
    pub size_variation: f64,
    /// Needles: largest angle from the up vector (+Y) in degrees, 0..=180 (default 60).
    pub spread: f64,
}

impl Default for LeafParams {
    fn default() -> Self {
        LeafParams { kind: LeafKind::None, count: 1, size: 0.15, size_variation: 0.3, spread: 60.0 }
    }
}

impl LeafParams {
    /// Checks the keys; errors name them (`generator.leaves.size`).
    pub fn validate(&self) -> Result<()> {
        if !(1..=64).contains(&self.count) {
            return bad("leaves.count", format!("must be in 1..=64, got {}", self.count));
        }
        in_range("leaves.size", self.size, 1e-6, 1e3)?;
        in_range("leaves.size_variation", self.size_variation, 0.0, 0.99)?;
        in_range("leaves.spread", self.spread, 0.0, 180.0)
    }
}

/// A uniformly random unit vector from two numbers in `[0, 1)`.
fn sphere(a: f64, b: f64) -> DVec3 {
    let z = 2.0 * a - 1.0;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * b;
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// Adds the leaves `p` asks for at every tip (node without children) of `sk`; returns
/// how many organs were placed. Errors when the count would exceed [`MAX_LEAVES`].
pub fn place(p: &LeafParams, sk: &mut Skeleton, seed: u64) -> Result<usize> {
    if p.kind == LeafKind::None {
        return Ok(0);
    }
    let n = sk.len();
    let mut has_child = vec![false; n];
    for &q in &sk.parent {
        if (q as usize) < n {
            has_child[q as usize] = true;
        }
    }
    let tips: Vec<usize> = (0..n).filter(|&i| !has_child[i] && sk.parent[i] != crate::NO_PARENT).collect();
    let total = tips.len() * p.count as usize;
    if total > MAX_LEAVES {
        return bad(
            "leaves.count",
            format!(
                "would place {total} organs, over the budget of {MAX_LEAVES}; lower generator.leaves.count"
            ),
        );
    }
    sk.organs.reserve(total);
    let needles = p.kind == LeafKind::Needles;
    let cos_max = p.spread.to_radians().cos();
    for &t in &tips {
        let tip = sk.position[t].as_dvec3();
        for k in 0..p.count as u64 {
            let r = |j: u64| hash01(seed, t as u64, k * 8 + j);
            let size = p.size * (1.0 + p.size_variation * (2.0 * r(0) - 1.0));
            let organ = if needles {
                // A direction in the cap of half-angle `spread` about +Y, uniform in area.
                let y = 1.0 - r(1) * (1.0 - cos_max);
                let s = (1.0 - y * y).max(0.0).sqrt();
                let phi = TAU * r(2);
                let d = DVec3::new(s * phi.cos(), y, s * phi.sin());
                let side = d.any_orthonormal_vector() * (size / 32.0);
                let end = tip + d * size;
                let quad = [tip - side, tip + side, end + side, end - side];
                Organ {
                    kind: OrganKind::Polygon(quad.iter().map(|v| v.as_vec3()).collect()),
                    node: t as u32,
                    position: tip.as_vec3(),
                    heading: d.as_vec3(),
                    up: d.cross(side).normalize_or_zero().as_vec3(),
                    size: size as f32,
                    material: 0,
                }
            } else {
                let h = sphere(r(1), r(2));
                let a = h.any_orthonormal_vector();
                let b = h.cross(a);
                let phi = TAU * r(3);
                let up = a * phi.cos() + b * phi.sin();
                Organ {
                    kind: OrganKind::Leaf,
                    node: t as u32,
                    position: (tip - h * (size / 2.0)).as_vec3(),
                    heading: h.as_vec3(),
                    up: up.as_vec3(),
                    size: size as f32,
                    material: 0,
                }
            };
            sk.organs.push(organ);
        }
    }
    Ok(total)
}
