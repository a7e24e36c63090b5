//! Skeleton collisions: internode capsules that overlap where the tree does not join
//! them, the rule for when two internodes meet (siblings, short links, folds), and the
//! closest points of two segments.

use super::bvh::{build_bvh, query, Aabb};
use glam::DVec3;
use rayon::prelude::*;

/// Pairs of internodes (each named by its child node, smaller first) of `skeleton`
/// whose capsules overlap where the tree does not join them: branches that pass
/// through each other in the skeleton itself, so no mesher can keep their surfaces
/// apart. A capsule is the segment parent → child swept by the larger of the two radii;
/// overlaps shallower than `tolerance × (r_a + r_b)` are ignored.
///
/// How the tree joins the two decides how they are measured (`Meeting`):
/// - siblings, and branches of one node joined through internodes shorter in all than
///   `r_a + r_b`, always overlap at their joint whatever their angle; they collide only
///   when the far end of one comes within the radii of the other's axis (two twigs
///   leaving a fork a few degrees apart, or a stub shorter than the radii);
/// - one internode hanging below the other through such short internodes collides when
///   the bends between them fold a tube of their radii (a zig-zag of two sharp bends
///   over a stub does; a straight run of short stations does not);
/// - internodes linked through a chain shorter than twice their radii collide only
///   where their axes come closer than half the chain (a gently curved stem of short,
///   thick internodes is not a collision);
/// - chained internodes (one ends where the other starts) never collide: that is a
///   bend.
pub fn skeleton_collisions(skeleton: &crate::Skeleton, tolerance: f64) -> Vec<[usize; 2]> {
    let seg: Vec<usize> = (0..skeleton.len()).filter(|&i| skeleton.parent[i] != crate::NO_PARENT).collect();
    if seg.is_empty() {
        return Vec::new();
    }
    let depth = node_depths(&skeleton.parent);
    let ends = |s: usize| {
        let i = seg[s];
        let p = skeleton.parent[i] as usize;
        let r = skeleton.radius[i].max(skeleton.radius[p]) as f64;
        ([skeleton.position[p].as_dvec3(), skeleton.position[i].as_dvec3()], r, i)
    };
    let boxes: Vec<Aabb> = (0..seg.len())
        .map(|s| {
            let ([a, b], r, _) = ends(s);
            Aabb { lo: a.min(b) - r, hi: a.max(b) + r }
        })
        .collect();
    let mut order: Vec<u32> = (0..seg.len() as u32).collect();
    let nodes = build_bvh(&boxes, &mut order);
    let mut pairs: Vec<[usize; 2]> = (0..seg.len())
        .into_par_iter()
        .flat_map_iter(|s| {
            let mut found = Vec::new();
            let (x, ra, ia) = ends(s);
            for o in query(&nodes, &order, &boxes[s]) {
                let (y, rb, ib) = ends(o);
                if o <= s || !boxes[o].overlaps(&boxes[s]) {
                    continue;
                }
                // Axes this far apart never collide: a joined or linked gap is never
                // smaller than the axis gap, and a folded pair's axes are closer (the
                // stub between them is shorter than the radii).
                let limit = (ra + rb) * (1.0 - tolerance);
                if segment_distance(x[0], x[1], y[0], y[1]) >= limit.max(ra + rb) {
                    continue;
                }
                let m = meeting(skeleton, &depth, ia, ib, ra + rb);
                if meeting_gap(x, y, m, ra + rb).is_some_and(|(d, ..)| d < limit) {
                    found.push([ia.min(ib), ia.max(ib)]);
                }
            }
            found
        })
        .collect();
    pairs.sort_unstable();
    pairs
}

/// How two internodes (named by their child nodes) meet in the tree, for the
/// skeleton-collision rule ([`skeleton_collisions`], and `decollide`, which pulls
/// apart exactly what it counts). `short` below is the sum of the two radii.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Meeting {
    /// One ends where the other starts: a bend, never a collision.
    Chained,
    /// Siblings, or branches of a common node joined through internodes shorter in
    /// all than `short`: their capsules overlap at the joint whatever their angle, so
    /// each is measured from its far end (its child node) to the other's axis.
    Joined,
    /// One hangs below the other through internodes of total length `path` under
    /// `short` (a stub, or a run of short stations): their axes are always that close,
    /// so what matters is whether the bends between them fold a tube of their radii,
    /// i.e. whether `path < short / 2 × bends`, `bends` the sum of `tan(β/2)` over the
    /// bends `β` at the nodes from one to the other (a straight run never folds, a
    /// U-turn always does).
    Folded {
        /// Length of the internodes between the two.
        path: f64,
        /// Sum of `tan(β/2)` over the bends between them (capped).
        bends: f64,
    },
    /// Joined through internodes of total length `P` between `short` and
    /// `short / LINK_FOLD`: their axes may come as close as `P` without anything
    /// folding (a gently curved stem of short, thick internodes), so they collide only
    /// where the axes come closer than `LINK_FOLD × P`.
    Linked(f64),
    /// Measured axis to axis.
    Apart,
}

/// Steps walked up the tree at most when looking for a close joint (a chain of
/// zero-length internodes must not make the walk unbounded).
const MAX_JOINED_HOPS: usize = 64;

/// See [`Meeting::Linked`]: the fraction of the chain between two linked internodes
/// their axes may come to before they count as folded onto each other. It makes the
/// rule continuous in the radii (at `P = short / LINK_FOLD` the linked threshold is the
/// radii), so thinning never turns a chain into a new collision.
const LINK_FOLD: f64 = 0.5;

/// The depth of every node (parents precede their children in a valid skeleton).
pub(crate) fn node_depths(parent: &[u32]) -> Vec<u32> {
    let mut depth = vec![0u32; parent.len()];
    for i in 0..parent.len() {
        let p = parent[i] as usize; // NO_PARENT is never below `i`
        if p < i {
            depth[i] = depth[p] + 1;
        }
    }
    depth
}

/// How internodes `i` and `j` meet (see [`Meeting`]); `short` is the sum of their radii.
pub(crate) fn meeting(s: &crate::Skeleton, depth: &[u32], i: usize, j: usize, short: f64) -> Meeting {
    let (pi, pj) = (s.parent[i] as usize, s.parent[j] as usize);
    if pi == j || pj == i {
        return Meeting::Chained;
    }
    let limit = short / LINK_FOLD;
    // Walk both up to their common ancestor, adding the internodes passed on the way
    // (not `i`'s and `j`'s own).
    // The bends are summed only for a folded meeting, afterwards along the one side
    // that moved (the same terms in the same order): a pair of huge capsules walks up
    // to `MAX_JOINED_HOPS` nodes, and an `acos` per hop was most of a collision search.
    let (mut at, mut moved, mut path) = ([i, j], [false; 2], 0.0);
    for _ in 0..MAX_JOINED_HOPS {
        if at[0] == at[1] {
            return match (path < short, moved) {
                (true, [false, _]) => Meeting::Folded { path, bends: bends_up(s, j, at[0]) },
                (true, [_, false]) => Meeting::Folded { path, bends: bends_up(s, i, at[0]) },
                (true, _) => Meeting::Joined,
                (false, _) => Meeting::Linked(path),
            };
        }
        let side = usize::from(depth[at[1]] > depth[at[0]]);
        let n = at[side];
        let p = s.parent[n];
        if p == crate::NO_PARENT {
            return Meeting::Apart;
        }
        if moved[side] {
            path += s.internode_length(n);
            if path >= limit {
                return Meeting::Apart;
            }
        }
        moved[side] = true;
        at[side] = p as usize;
    }
    Meeting::Apart
}

/// The sum of `tan(β/2)` over the bends met walking up from node `from` to its ancestor
/// `to`: at each parent `p` passed, the bend between `p`'s own internode and the one
/// walked up (none where `p` is a root).
fn bends_up(s: &crate::Skeleton, from: usize, to: usize) -> f64 {
    let pos = |n: usize| s.position[n].as_dvec3();
    let (mut n, mut bends) = (from, 0.0);
    while n != to {
        let p = s.parent[n] as usize;
        if let Some(&g) = s.parent.get(p).filter(|&&g| g != crate::NO_PARENT) {
            let (u, v) =
                ((pos(p) - pos(g as usize)).normalize_or_zero(), (pos(n) - pos(p)).normalize_or_zero());
            let half = 0.5 * u.dot(v).clamp(-1.0, 1.0).acos();
            bends += half.tan().min(MAX_BEND_TAN);
        }
        n = p;
    }
    bends
}

/// Cap on one bend's `tan(β/2)` in [`Meeting::Folded`] (a U-turn).
const MAX_BEND_TAN: f64 = 1e6;

/// The gap between two internode axes `x` and `y` (parent end, child end) met as `m`,
/// with the closest points (on `x`, on `y`), to be compared with the radii `short` as
/// for any pair: for [`Meeting::Linked`] the axis gap is scaled up by
/// `short / (LINK_FOLD × P)` when that is over 1; for [`Meeting::Folded`] it is
/// `2 × path / bends` (under `short` exactly when the bends fold the tube). `None` for
/// chained internodes.
pub(crate) fn meeting_gap(
    x: [DVec3; 2],
    y: [DVec3; 2],
    m: Meeting,
    short: f64,
) -> Option<(f64, DVec3, DVec3)> {
    match m {
        Meeting::Chained => None,
        Meeting::Apart => Some(segment_closest(x[0], x[1], y[0], y[1])),
        Meeting::Folded { path, bends } => {
            let (_, p, q) = segment_closest(x[0], x[1], y[0], y[1]);
            Some((if bends > 0.0 { 2.0 * path / bends } else { f64::INFINITY }, p, q))
        }
        Meeting::Linked(path) => {
            let (d, p, q) = segment_closest(x[0], x[1], y[0], y[1]);
            Some((d * (short / (LINK_FOLD * path).max(f64::MIN_POSITIVE)).max(1.0), p, q))
        }
        Meeting::Joined => {
            let (dx, px, qx) = segment_closest(x[1], x[1], y[0], y[1]);
            let (dy, py, qy) = segment_closest(y[1], y[1], x[0], x[1]);
            Some(if dx <= dy { (dx, px, qx) } else { (dy, qy, py) })
        }
    }
}

/// Closest distance between segments p0p1 and q0q1.
pub(super) fn segment_distance(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> f64 {
    segment_closest(p0, p1, q0, q1).0
}

/// Closest distance between segments p0p1 and q0q1, with the closest points on each.
pub(crate) fn segment_closest(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> (f64, DVec3, DVec3) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t) = if a <= 1e-30 && e <= 1e-30 {
        (0.0, 0.0)
    } else if a <= 1e-30 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= 1e-30 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-30 { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    let (x, y) = (p0 + d1 * s, q0 + d2 * t);
    (x.distance(y), x, y)
}
