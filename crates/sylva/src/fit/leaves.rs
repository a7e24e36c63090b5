//! Leaves by level: leaf organs placed on a finished skeleton by branch level (McLoughlin2021
//! §4.2, issue 3 "Leaves", as McLoughlin2021-spec §5 distils it; property 18), for generators whose
//! grammar draws no leaves of its own (the Honda trees a–i).
//!
//! Two placements:
//!
//! - [`Placement::Level`] (the seed's proposal): every internode whose level (its branch
//!   order; for the Honda trees the apex's depth) is at least `start_level` gets
//!   `per_node` leaves, their bases on the internode's cylinder surface at evenly spaced
//!   heights and golden-angle (137.5°) azimuths, each pointing away from the axis and
//!   half-way up (45° from the axis towards +Y, never into the branch) with its blade
//!   facing upward ("rotated to face upward without clipping the branch"). A lower start
//!   level gives a denser crown.
//! - [`Placement::Terminal`] (Bloomenthal 1985, "leaf configurations"): only terminal
//!   apices (nodes without children) get leaves, a configuration of `per_node` leaves
//!   fanned around the branch's heading at its tip, each scaled by a factor in
//!   [0.8, 1.2] drawn from a PRNG seeded with (seed, node), so the result is
//!   deterministic.
//!
//! Leaf length: `size`, or (0) 0.8 × the mean length of the internodes that get leaves.
//! Each leaf hangs on its internode's node (so wind and LOD pruning carry it). The
//! placement adds organs only; the skeleton's nodes are unchanged.

use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::Vec3;
use rand::{RngExt, SeedableRng};

/// Where leaves go (`leaves.place`: `level` or `terminal`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Placement {
    /// On every internode of level ≥ `start_level`.
    Level,
    /// On terminal apices only (Bloomenthal's configurations).
    Terminal,
}

/// Options of [`place_leaves`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeafPlacement {
    /// Which internodes get leaves.
    pub placement: Placement,
    /// Lowest level (branch order) that gets leaves with [`Placement::Level`]; `None`:
    /// the two highest levels of the skeleton.
    pub start_level: Option<u16>,
    /// Leaves per internode (Level) or per configuration (Terminal), 1..=64.
    pub per_node: u32,
    /// Leaf length in metres; 0: 0.8 × the mean length of the internodes with leaves.
    pub size: f32,
    /// Seed of the configurations' scale jitter.
    pub seed: u64,
}

/// Golden angle in radians (phyllotaxis of the leaves along an internode).
const GOLDEN: f32 = 2.399_963;

/// A unit vector perpendicular to `d`.
fn perpendicular(d: Vec3, hint: Vec3) -> Vec3 {
    let p = hint - d * hint.dot(d);
    if p.length_squared() > 1e-8 {
        p.normalize()
    } else {
        d.any_orthonormal_vector()
    }
}

/// Adds leaf organs to `sk` as `opts` says and returns how many were added.
pub fn place_leaves(sk: &mut Skeleton, opts: &LeafPlacement) -> usize {
    let n = sk.len();
    let mut has_child = vec![false; n];
    for i in 0..n {
        let p = sk.parent[i];
        if p != NO_PARENT && (p as usize) < n {
            has_child[p as usize] = true;
        }
    }
    let max_order = (0..n).filter(|&i| sk.parent[i] != NO_PARENT).map(|i| sk.order[i]).max().unwrap_or(0);
    let start = opts.start_level.unwrap_or(max_order.saturating_sub(1));
    let leafy: Vec<usize> = (0..n)
        .filter(|&i| sk.parent[i] != NO_PARENT && sk.internode_length(i) > 0.0)
        .filter(|&i| match opts.placement {
            Placement::Level => sk.order[i] >= start,
            Placement::Terminal => !has_child[i],
        })
        .collect();
    if leafy.is_empty() {
        return 0;
    }
    let size = if opts.size > 0.0 {
        opts.size
    } else {
        let mean = leafy.iter().map(|&i| sk.internode_length(i)).sum::<f64>() / leafy.len() as f64;
        (0.8 * mean) as f32
    };
    let per = opts.per_node.clamp(1, 64);
    let before = sk.organs.len();
    for &i in &leafy {
        let p = sk.parent[i] as usize;
        let (a, b) = (sk.position[p], sk.position[i]);
        let axis = (b - a).normalize_or_zero();
        if axis == Vec3::ZERO {
            continue;
        }
        let u0 = perpendicular(axis, sk.up[i]);
        let w0 = axis.cross(u0);
        let leaf = |position: Vec3, heading: Vec3, size: f32| {
            let heading = heading.normalize_or(axis);
            // The blade faces upward: its normal is +Y made perpendicular to the heading.
            let up = perpendicular(heading, Vec3::Y);
            Organ {
                kind: OrganKind::Leaf,
                node: i as u32,
                position,
                heading,
                up,
                size,
                material: sk.material[i],
            }
        };
        match opts.placement {
            Placement::Level => {
                for k in 0..per {
                    let t = (k as f32 + 0.5) / per as f32;
                    let phi = GOLDEN * (i as f32 * per as f32 + k as f32);
                    let radial = u0 * phi.cos() + w0 * phi.sin();
                    let r = sk.radius[p] + (sk.radius[i] - sk.radius[p]) * t;
                    let base = a + (b - a) * t + radial * r;
                    // 45° from the axis, away from it, lifted toward +Y.
                    let heading = (radial + axis).normalize_or(axis) + Vec3::Y * 0.5;
                    sk.organs.push(leaf(base, heading, size));
                }
            }
            Placement::Terminal => {
                let mut rng = rand_pcg::Pcg64::seed_from_u64(
                    opts.seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
                );
                for k in 0..per {
                    let phi = std::f32::consts::TAU * k as f32 / per as f32;
                    let radial = u0 * phi.cos() + w0 * phi.sin();
                    // A fan around the tip's heading, 40° out from it.
                    let heading = axis * 40f32.to_radians().cos() + radial * 40f32.to_radians().sin();
                    let scale = rng.random_range(0.8..=1.2f32);
                    sk.organs.push(leaf(b + radial * sk.radius[i], heading, size * scale));
                }
            }
        }
    }
    sk.organs.len() - before
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A binary tree of `depth` levels (order = depth), unit internodes.
    fn binary(depth: u16) -> Skeleton {
        let mut s = Skeleton::new();
        let root = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let top = s.push(Vec3::Y, 0.1, root, Vec3::X, 0);
        let mut tips = vec![(top, Vec3::Y)];
        for level in 1..=depth {
            let mut next = Vec::new();
            for (node, dir) in tips {
                for side in [-1.0f32, 1.0] {
                    let d = (dir + Vec3::X * side * 0.7).normalize();
                    let at = s.position[node as usize] + d;
                    next.push((s.push(at, 0.1 / (level + 1) as f32, node, Vec3::Z, level), d));
                }
            }
            tips = next;
        }
        s
    }

    #[test]
    fn leaves_only_from_the_start_level() {
        let mut s = binary(4);
        let opts = LeafPlacement {
            placement: Placement::Level,
            start_level: Some(3),
            per_node: 2,
            size: 0.0,
            seed: 1,
        };
        let added = place_leaves(&mut s, &opts);
        // Levels 3 and 4: 8 + 16 internodes, 2 leaves each.
        assert_eq!(added, 48);
        for o in &s.organs {
            assert!(s.order[o.node as usize] >= 3, "a leaf on level {}", s.order[o.node as usize]);
            assert!(o.heading.is_finite() && o.up.is_finite() && o.size > 0.0);
            assert!(o.up.y > 0.0, "blades face upward");
            // The base sits on the cylinder's surface, not inside the branch.
            let p = s.parent[o.node as usize] as usize;
            let (a, b) = (s.position[p], s.position[o.node as usize]);
            let t = ((o.position - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
            let d = o.position.distance(a + (b - a) * t);
            assert!(d > 0.5 * s.radius[o.node as usize], "base {d} from the axis");
        }
    }

    #[test]
    fn bloomenthal_mode_puts_configurations_on_terminal_apices_only() {
        let mut s = binary(3);
        let opts = LeafPlacement {
            placement: Placement::Terminal,
            start_level: None,
            per_node: 3,
            size: 0.2,
            seed: 7,
        };
        assert_eq!(place_leaves(&mut s, &opts), 8 * 3);
        let parents: std::collections::HashSet<u32> = s.parent.iter().copied().collect();
        for o in &s.organs {
            assert!(!parents.contains(&o.node), "node {} has children", o.node);
            assert!((0.16..=0.24).contains(&o.size));
        }
        // Deterministic.
        let mut again = binary(3);
        place_leaves(&mut again, &opts);
        assert_eq!(again.organs, s.organs);
    }
}
