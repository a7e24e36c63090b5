//! Thinning: radius caps that make near-joint and grazing pairs clear, carried down to
//! every descendant and relaxed up the axis as a smooth taper, and the joint meshers'
//! radius floor.

use super::detect::{capsule, gap, near_joint, Topology};
use super::DecollideOptions;
use crate::skeleton::{Skeleton, NO_PARENT};

/// Caps radii so the near-joint (and grazing) pairs clear; returns whether any radius
/// changed.
pub(super) fn thin(s: &mut Skeleton, topo: &Topology, pairs: &[[usize; 2]], o: &DecollideOptions) -> bool {
    let n = s.len();
    let mut cap = vec![f64::INFINITY; n];
    let mut any = false;
    for &[a, b] in pairs {
        let (ca, cb) = (capsule(s, a), capsule(s, b));
        let Some((d, ..)) = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY) else { continue };
        let sum = (ca.r + cb.r) * (1.0 + o.clearance);
        if sum <= 0.0 {
            continue;
        }
        let f = d / sum;
        let near = near_joint(s, topo, a, b, o);
        if f >= 1.0 || f < if near { o.min_thinning } else { o.far_thinning } {
            continue;
        }
        // Slightly under the exact factor, so f32 rounding cannot leave a graze.
        let f = f * 0.999;
        for (x, r) in [(a, ca.r), (b, cb.r)] {
            for node in [x, s.parent[x] as usize] {
                cap[node] = cap[node].min(f * r);
            }
        }
        any = true;
    }
    any && apply_caps(s, cap, o.taper, floor_of(s, o.min_radius))
}

/// Lowers every radius to its cap in `cap` (one per node, `INFINITY` for none) after
/// relaxing each cap up its axis by at most `taper` metres of radius per metre of length
/// and carrying it down to every descendant (radii stay non-increasing towards the tips
/// and the thinning is a smooth taper, not a notch). Returns whether any radius changed.
///
/// Explicit start radii ([`Skeleton::start_radius()`]) are thinned with the node they
/// start at: the start radius of the internode ending at node `i` lies at its parent
/// `p`, so it is scaled by the factor `p`'s radius was lowered by (a cone keeps its
/// proportions to the axis it leaves, and a start radius no larger than `p`'s radius,
/// the capsule's, stays so), never below the floor unless it already was.
pub(crate) fn apply_caps(s: &mut Skeleton, mut cap: Vec<f64>, taper: f64, floor: f32) -> bool {
    let n = s.len();
    let before = if s.start_radius.is_empty() { Vec::new() } else { s.radius.clone() };
    // Relax up each axis (a child continuing its parent's order), children first.
    for i in (0..n).rev() {
        let p = s.parent[i];
        if p == NO_PARENT || !cap[i].is_finite() || s.order[i] != s.order[p as usize] {
            continue;
        }
        let up = cap[i] + taper * s.internode_length(i);
        cap[p as usize] = cap[p as usize].min(up);
    }
    // Carry every cap down to the descendants (radii non-increasing towards the tips).
    for i in 0..n {
        let p = s.parent[i];
        if p != NO_PARENT {
            cap[i] = cap[i].min(cap[p as usize]);
        }
    }
    let mut changed = false;
    for (r, &c) in s.radius.iter_mut().zip(&cap) {
        let c = (c as f32).max(floor).max(0.0);
        if c < *r {
            *r = c;
            changed = true;
        }
    }
    if changed && !before.is_empty() {
        scale_start_radii(s, &before, floor);
    }
    changed
}

/// Scales each explicit start radius by the factor its internode's parent node's radius
/// changed by from `before` (only where that radius was lowered), never below `floor`
/// unless it already was (see [`apply_caps`]).
fn scale_start_radii(s: &mut Skeleton, before: &[f32], floor: f32) {
    let n = s.len().min(s.start_radius.len()).min(before.len());
    for i in 0..n {
        let p = s.parent[i];
        let Some(r0) = s.start_radius[i] else { continue };
        if p == NO_PARENT || p as usize >= n {
            continue;
        }
        let (old, new) = (before[p as usize], s.radius[p as usize]);
        if new < old && old > 0.0 {
            let scaled = (f64::from(r0) * f64::from(new) / f64::from(old)) as f32;
            s.start_radius[i] = Some(scaled.max(floor.min(r0)));
        }
    }
}

/// The radius floor: `fraction` of the skeleton's largest radius.
pub(crate) fn floor_of(s: &Skeleton, fraction: f64) -> f32 {
    let rmax = s.radius.iter().fold(0.0f32, |m, &r| m.max(r));
    (fraction * rmax as f64) as f32
}

/// Raises every radius under the floor (`fraction` of the largest radius) to it;
/// returns how many were raised. Explicit start radii under the floor are raised to it
/// too (the meshers draw them that thick), but not counted.
pub(crate) fn raise_to_floor(s: &mut Skeleton, fraction: f64) -> usize {
    let floor = floor_of(s, fraction);
    let mut raised = 0;
    for r in s.radius.iter_mut().filter(|r| **r < floor) {
        *r = floor;
        raised += 1;
    }
    for r0 in s.start_radius.iter_mut().flatten().filter(|r| **r < floor) {
        *r0 = floor;
    }
    raised
}
