//! The hull mesher: one watertight triangle control mesh for a whole [`Skeleton`], with
//! convex-hull joints at every branching node, ready for Loop subdivision.
//!
//! This implements Pieterse2012 ("Yggdrasil") §4.1.3–§4.1.4 (branch trimming and graph
//! simplification), §4.2.2 (branch segments, Algorithm 1), §4.2.3 with its convex-hull
//! subsection printed as "4.3.3.2" (joints, Algorithms 3–4) and §4.3.2–§4.3.3 (UVs), as
//! pinned down by Pieterse2012-spec §2.3–§2.7. The Loop step (§4.4) is
//! [`crate::refine::subdivide`], run by the caller.
//!
//! # Pipeline
//!
//! 1. **Branch graph.** Every internode (a node with a parent) is a *branch*: a straight
//!    truncated cone from its parent node to its node, radius `r_node` at the end and at
//!    the start the internode's explicit start radius ([`Skeleton::start_radius()`]: an
//!    LST `Cylinder(r0, r1, len)` keeps r0 there, Pieterse2012-spec §2.1), or where it has none
//!    `min(r_parent, r_node)` (the tube mesher's convention for laterals). The loops of
//!    §4.2.2 interpolate the radius linearly between the two (Pieterse2012-spec §2.5).
//!    Every node where two or more branches meet is a *joint*. Zero-length internodes
//!    are collapsed first (zero-length tips are dropped and reported).
//! 2. **Trimming** (Pieterse2012 §4.1.3; Pieterse2012-spec §2.3). At a joint O every branch has an
//!    outward unit axis (the parent's is negated) and its radius at O. For each pair the
//!    offsets come from the actual geometry — the furthest point of the intersection of
//!    two solid half-infinite cylinders ([`pair_offsets`]): acute
//!    `offA = rA·cot α + rB·csc α`, obtuse `offA = min(rB·sin α, rA·tan(π − α))`,
//!    `α = π` → 0, `cos α > 1 − ε` → *aligned* (no solution; the joint fails). A branch's
//!    offset is the maximum over its partners, times `1 + margin`.
//! 3. **Simplification** (Pieterse2012 §4.1.4; Pieterse2012-spec §2.4). In parent-first (depth-first)
//!    order, a branch whose two offsets cross (`start + end ≥ length`) is collapsed: its
//!    children re-attach to its parent and start at the parent's end. End points never
//!    move. The merged joint and the moved children are re-trimmed at once; passes repeat
//!    until one makes no collapse. A root stem or a tip cannot collapse without moving
//!    an end point: their offsets are scaled down to half the length and the node is
//!    reported in [`HullMesh::clamped`]. *Beyond the seed*: neither is a branch whose
//!    collapse would move a child's axis more than [`HullOptions::max_straightening`]
//!    of its radius away from the collapsed node and run that child's tube, straight
//!    across the bend, through another live branch.
//! 4. **Branch segments** (Pieterse2012 §4.2.2, Algorithm 1). `N = round(L / (f·π·r̄))`,
//!    clamped to `1..=max_segments`, with `L` the trimmed length and `r̄` the mean of
//!    the trimmed end radii; `N + 1` loops of `sides` vertices at angles `2πj/s` in a
//!    rotation-minimizing frame (the root's from the skeleton's `up`, each child's the
//!    minimal rotation of its parent's); faces `(A, B, C)`, `(B, D, C)`.
//! 5. **Joints** (Pieterse2012 §4.2.3; Pieterse2012-spec §2.6). Two branches (a bend): a band of `2s`
//!    triangles pairing loop vertex `j` with `j`. Three or more (or two stems from a
//!    root): every loop vertex is centrally projected from O onto the unit sphere, each
//!    loop a small circle about its axis, shrunk if needed so no two circles' caps
//!    overlap; the exact-predicate hull of [`convex`] is built, the faces whose three
//!    vertices lie in one loop (the caps, `s − 2` each) are removed and the rest is
//!    mapped back to the loop vertices: no new vertices, `k(s + 2) − 4` faces.
//!    Every joint is checked (all points on the hull, clean caps, each loop edge once in
//!    the orientation of its tube). Aligned branches (seed case 3) are *detached*: the
//!    thinner of each aligned pair runs to O untrimmed and is closed there by a fan,
//!    the rest still get their joint. A joint whose hull fails (or that keeps fewer
//!    than two loops) falls back whole: its branches run to O untrimmed and each loop
//!    there is closed by a fan (separate closed tubes meeting at O). Both are reported
//!    in [`HullMesh::fallbacks`]. *Beyond the seed*: a root whose stems all leave
//!    within 60° of their mean direction `m` gets a virtual **base loop** ([`root_base`]):
//!    a ring of the root's radius at the root node, normal to `m`, that takes part in
//!    the hull and is closed by a flat fan facing `−m` (the joint is a dome on a flat
//!    base at the node; without it the hull of loops in one narrow cone is a thin lens
//!    whose two sides cross once the loops are moved back from the sphere).
//! 6. **UVs** (Pieterse2012 §4.3.2–4.3.3). Branches: `u = j/s` (the wrap column `u = 1`),
//!    `v = v₀ + i/2`. A branch that continues its parent through a band starts at the
//!    parent's last `v` plus the band's length in the same unit, so chains of internodes
//!    are one seamless chart; other branches start at `v₀ = 0`. Hull joints: each face
//!    without UVs copies the two shared corners from its neighbour across its longest
//!    edge that has UVs and unfolds the third corner (same edge parameter and height,
//!    counter-clockwise), until all have UVs. No wrapping: values outside `[0, 1]`
//!    rely on texture repeat, and shifting a face by whole tiles would add seams.
//! 7. **Caps** (optional): flat fans close the base and the tips, making the mesh a
//!    closed genus-0 surface.
//!
//! Output: triangles, counter-clockwise seen from outside, face-varying UVs and smooth
//! per-vertex normals (as a face-varying channel). Open only at the root base and the
//! tips (unless capped). Deterministic; every input gives a mesh or an
//! [`Error::InvalidGeometry`] for bad options, never a panic.

pub mod convex;

use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use crate::mesh::check::segment_closest;
use crate::mesh::tube::{MAX_SIDES, MIN_SIDES};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{DQuat, DVec2, DVec3, Vec2, Vec3};
use std::collections::HashMap;
use std::f64::consts::{PI, TAU};
use std::ops::Range;

const NONE: u32 = u32::MAX;

/// Options of [`hull_mesh`] (Pieterse2012-spec §4 "User parameters").
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HullOptions {
    /// Vertices per loop, in `3..=1024` (default 4, the seed's choice).
    #[serde(skip)]
    pub sides: u32,
    /// Close the root base and every tip with a flat fan (default false: the seed leaves
    /// them open). With caps the mesh is closed (Euler characteristic 2 per piece).
    #[serde(skip)]
    pub caps: bool,
    /// Trim margin `m`: offsets are multiplied by `1 + m` so rims do not touch
    /// (default 0.05).
    pub margin: f64,
    /// Two outward axes with `cos α > 1 − ε` are *aligned* (seed case 3): the joint
    /// fails and falls back (default 1e-6).
    pub aligned_epsilon: f64,
    /// Segment length as a multiple of half the mean circumference `π·r̄` (default 1).
    pub segment_factor: f64,
    /// Most segments per branch (default 32): a budget guard for long, hair-thin
    /// branches, where `L / (π·r̄)` grows without bound.
    pub max_segments: u32,
    /// Largest straightening a collapse may cause, in radii of the collapsed node
    /// (default 1; `f64::INFINITY` is the seed's rule). Collapsing a branch re-attaches
    /// its children to its start, so each child's tube runs straight past the collapsed
    /// node; where that node lies further than this from a child's new axis and the
    /// straightened tube would pass through another (live) branch of the graph, the
    /// branch is not collapsed and its trims are clamped instead (reported in
    /// [`HullMesh::clamped`]). Beyond the seed: on `mig-a`, a collapse moved a tube 5
    /// radii off the skeleton, through a neighbouring branch.
    pub max_straightening: f64,
}

impl Default for HullOptions {
    fn default() -> Self {
        HullOptions {
            sides: 4,
            caps: false,
            margin: 0.05,
            aligned_epsilon: 1e-6,
            segment_factor: 1.0,
            max_segments: 32,
            max_straightening: 1.0,
        }
    }
}

impl HullOptions {
    /// Checks every option's range; the message starts with the option's name.
    pub fn check(&self) -> Result<()> {
        let bad = |why: String| Err(Error::InvalidGeometry { what: "hull mesher".into(), why });
        if !(MIN_SIDES..=MAX_SIDES).contains(&self.sides) {
            return bad(format!("sides = {}; it must be in {MIN_SIDES}..={MAX_SIDES}", self.sides));
        }
        if !(self.margin.is_finite() && (0.0..=10.0).contains(&self.margin)) {
            return bad(format!("margin = {}; it must be in 0..=10", self.margin));
        }
        if !(self.aligned_epsilon.is_finite() && (0.0..1.0).contains(&self.aligned_epsilon)) {
            return bad(format!("aligned_epsilon = {}; it must be in [0, 1)", self.aligned_epsilon));
        }
        if !(self.segment_factor.is_finite() && self.segment_factor > 0.0) {
            return bad(format!("segment_factor = {}; it must be positive", self.segment_factor));
        }
        if self.max_straightening.is_nan() || self.max_straightening < 0.0 {
            return bad(format!("max_straightening = {}; it must be non-negative", self.max_straightening));
        }
        if !(1..=65536).contains(&self.max_segments) {
            return bad(format!("max_segments = {}; it must be in 1..=65536", self.max_segments));
        }
        Ok(())
    }
}

/// How a joint was meshed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Two branches (a bend): a band of `2s` triangles.
    Band,
    /// Three or more branches (or two stems from a root): the convex-hull joint.
    Hull,
    /// The joint could not be meshed: its branches run to the node untrimmed and each of
    /// their loops there is closed by a fan (see [`HullMesh::fallbacks`]).
    Fallback,
}

/// One joint of the output mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSpan {
    /// Skeleton node at the joint.
    pub node: u32,
    /// How it was meshed.
    pub kind: JointKind,
    /// Number of loops that meet there (`k`: the parent's end loop and each child's
    /// start loop).
    pub loops: u32,
    /// Its faces in [`HullMesh::mesh`] (for a fallback: its cap fans).
    pub faces: Range<u32>,
    /// Branches (their end nodes) detached from this joint because they were aligned
    /// with another (Pieterse2012 §4.1.3 case 3): each runs untrimmed to the node and is
    /// closed there by a fan. The joint is then listed in [`HullMesh::fallbacks`].
    pub detached: Vec<u32>,
}

/// One meshed branch (a trimmed internode after simplification).
#[derive(Debug, Clone, PartialEq)]
pub struct BranchSpan {
    /// Skeleton node at the branch's end (its tip end point, never moved).
    pub node: u32,
    /// Skeleton node at its start (its parent's end, or a root); differs from the
    /// node's skeleton parent when simplification collapsed branches in between.
    pub start_node: u32,
    /// First vertex: the branch owns vertices `first_vertex .. first_vertex + (N+1)·s`,
    /// loop `i` vertex `j` at `first_vertex + i·s + j`.
    pub first_vertex: u32,
    /// Number of segments `N` (`N + 1` loops).
    pub segments: u32,
    /// Its faces (`2·N·s`) in [`HullMesh::mesh`].
    pub faces: Range<u32>,
    /// Distance from the start point to the first loop.
    pub start_offset: f64,
    /// Distance from the last loop to the end point.
    pub end_offset: f64,
    /// Untrimmed length (start point to end point).
    pub length: f64,
    /// Texture `v` of loop 0 (loop `i` has `v₀ + i/2`).
    pub v0: f64,
}

/// The result of [`hull_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct HullMesh {
    /// Triangles with face-varying UVs and normals.
    pub mesh: Mesh,
    /// Joint nodes that fell back, wholly ([`JointKind::Fallback`]) or by detaching
    /// aligned branches ([`JointSpan::detached`]), in node order.
    pub fallbacks: Vec<u32>,
    /// Every joint (nodes where 2 or more branches meet), in node order.
    pub joints: Vec<JointSpan>,
    /// Every meshed branch, in node order.
    pub branches: Vec<BranchSpan>,
    /// Nodes whose internode simplification collapsed (Pieterse2012 §4.1.4).
    pub collapsed: Vec<u32>,
    /// Nodes whose branch (a root stem or a tip) was too short for its trims and could
    /// not collapse without moving an end point: its offsets were scaled down.
    pub clamped: Vec<u32>,
    /// Tip nodes dropped because their internode has zero length.
    pub dropped: Vec<u32>,
    /// Loops left open (the base and the tips when not capped).
    pub open_loops: usize,
}

/// Pairwise trimming offsets of two branches meeting at a joint O (Pieterse2012 §4.1.3,
/// derived as Pieterse2012-spec §2.3 suggests): `a`, `b` are the outward unit axes, `ra`, `rb`
/// the radii at O. Returns `(offA, offB)`: beyond `offA` along `a`, A's solid cylinder
/// no longer meets B's; `None` when the axes are aligned (`a·b > 1 − eps`, seed case 3:
/// no solution).
///
/// Acute (`0 < α ≤ π/2`): `offA = rA·cot α + rB·csc α`; obtuse (`π/2 ≤ α < π`):
/// `offA = min(rB·sin α, rA·tan(π − α))`; `α = π`: 0. Continuous across `π/2` (`rB`).
pub fn pair_offsets(a: DVec3, ra: f64, b: DVec3, rb: f64, eps: f64) -> Option<(f64, f64)> {
    let c = a.dot(b).clamp(-1.0, 1.0);
    if c > 1.0 - eps {
        return None;
    }
    let s = (1.0 - c * c).max(0.0).sqrt();
    if s <= 1e-15 {
        return Some((0.0, 0.0)); // straight continuation
    }
    if c > 0.0 {
        // Pieterse2012 §4.1.3 case 4 (acute)
        Some(((ra * c + rb) / s, (rb * c + ra) / s))
    } else {
        // obtuse: the start of the other branch bounds the intersection
        let t = s / -c; // tan(π − α); +∞ at α = π/2
        let off_a = if c < 0.0 { (rb * s).min(ra * t) } else { rb * s };
        let off_b = if c < 0.0 { (ra * s).min(rb * t) } else { ra * s };
        Some((off_a, off_b))
    }
}

/// One branch of the simplified graph (see [`simplify`]).
#[derive(Debug, Clone, PartialEq)]
pub struct GraphBranch {
    /// Skeleton node at the end.
    pub node: u32,
    /// Skeleton node at the start.
    pub start_node: u32,
    /// The parent branch (its end node), or [`NO_PARENT`] for a root stem.
    pub parent: u32,
    /// Start point (the start node's position).
    pub start: DVec3,
    /// End point (the end node's position, bitwise).
    pub end: DVec3,
    /// Radius at the start.
    pub start_radius: f64,
    /// Radius at the end.
    pub end_radius: f64,
    /// Trim offset at the start (with margin; scaled down if clamped).
    pub start_offset: f64,
    /// Trim offset at the end.
    pub end_offset: f64,
}

/// The trimmed and simplified branch graph of a skeleton (stages 1–3 of the module
/// docs).
#[derive(Debug, Clone, PartialEq)]
pub struct BranchGraph {
    /// Surviving branches in node order.
    pub branches: Vec<GraphBranch>,
    /// Nodes whose internode was collapsed.
    pub collapsed: Vec<u32>,
    /// Nodes whose offsets were clamped (root stems and tips that could not collapse).
    pub clamped: Vec<u32>,
    /// Zero-length tips that were dropped.
    pub dropped: Vec<u32>,
    /// Joints with an aligned pair of branches (seed case 3).
    pub aligned: Vec<u32>,
}

/// Trims and simplifies `skeleton` (Pieterse2012 §4.1.3–4.1.4): the branch graph the mesher
/// builds its loops on. Errors only for invalid options or skeletons.
pub fn simplify(skeleton: &Skeleton, opts: &HullOptions) -> Result<BranchGraph> {
    opts.check()?;
    skeleton.validate()?;
    let w = Work::new(skeleton, opts);
    let branches = (0..w.n)
        .filter(|&b| w.branch[b])
        .map(|b| {
            let j = w.start_joint[b];
            GraphBranch {
                node: b as u32,
                start_node: j,
                parent: if w.branch[j as usize] { j } else { NO_PARENT },
                start: w.start[b],
                end: w.end[b],
                start_radius: w.r0[b],
                end_radius: w.r1[b],
                start_offset: w.soff[b],
                end_offset: w.eoff[b],
            }
        })
        .collect();
    let aligned = (0..w.n).filter(|&j| w.aligned[j]).map(|j| j as u32).collect();
    Ok(BranchGraph { branches, collapsed: w.collapsed, clamped: w.clamped, dropped: w.dropped, aligned })
}

/// The branch graph while it is trimmed and simplified, indexed by skeleton node.
struct Work {
    n: usize,
    /// Node `i` ends a live branch.
    branch: Vec<bool>,
    start_joint: Vec<u32>,
    start: Vec<DVec3>,
    end: Vec<DVec3>,
    r0: Vec<f64>,
    r1: Vec<f64>,
    /// Branches starting at joint node `j`.
    out: Vec<Vec<u32>>,
    soff: Vec<f64>,
    eoff: Vec<f64>,
    aligned: Vec<bool>,
    margin: f64,
    eps: f64,
    zero: f64,
    collapsed: Vec<u32>,
    clamped: Vec<u32>,
    dropped: Vec<u32>,
}

impl Work {
    fn new(sk: &Skeleton, opts: &HullOptions) -> Work {
        let n = sk.len();
        let rmax =
            sk.radius.iter().chain(sk.start_radius.iter().flatten()).fold(0.0f64, |m, &r| m.max(r as f64));
        let extent = sk.position.iter().fold(0.0f64, |m, p| m.max(p.abs().max_element() as f64));
        let scale = (extent + rmax).max(1e-30);
        // Radius floor: thin-to-zero tips keep a tiny loop instead of a point.
        let rfloor = if rmax > 0.0 { rmax * 1e-3 } else { scale * 1e-4 };
        let mut w = Work {
            n,
            branch: vec![false; n],
            start_joint: vec![NONE; n],
            start: vec![DVec3::ZERO; n],
            end: vec![DVec3::ZERO; n],
            r0: vec![0.0; n],
            r1: vec![0.0; n],
            out: vec![Vec::new(); n],
            soff: vec![0.0; n],
            eoff: vec![0.0; n],
            aligned: vec![false; n],
            margin: opts.margin,
            eps: opts.aligned_epsilon,
            zero: crate::tolerance::Tolerance::new(scale).zero_length(),
            collapsed: Vec::new(),
            clamped: Vec::new(),
            dropped: Vec::new(),
        };
        for i in 0..n {
            let p = sk.parent[i];
            if p == NO_PARENT {
                continue;
            }
            let pu = p as usize;
            w.branch[i] = true;
            w.start_joint[i] = p;
            w.start[i] = sk.position[pu].as_dvec3();
            w.end[i] = sk.position[i].as_dvec3();
            let r0 = sk.start_radius(i).unwrap_or(sk.radius[pu].min(sk.radius[i]));
            w.r0[i] = (r0 as f64).max(rfloor);
            w.r1[i] = (sk.radius[i] as f64).max(rfloor);
            w.out[pu].push(i as u32);
        }
        // Zero-length internodes: collapse (nothing moves) or drop the tip.
        for b in 0..n {
            if w.branch[b] && w.len(b) <= w.zero {
                if w.out[b].is_empty() {
                    w.drop_tip(b);
                } else {
                    w.collapse_raw(b);
                }
            }
        }
        // Collapse crossing branches, parent-first, until stable (Pieterse2012 §4.1.4).
        loop {
            let mut any = false;
            for b in 0..n {
                if !w.branch[b] || w.out[b].is_empty() || !w.branch[w.start_joint[b] as usize] {
                    continue; // a tip or a root stem: cannot collapse
                }
                let sj = w.start_joint[b] as usize;
                if w.offset_of(sj, b, false) + w.offset_of(b, b, true) >= w.len(b) - w.zero
                    && (w.straightening(b) <= opts.max_straightening * w.r1[b] || !w.straightened_hits(b))
                {
                    w.collapse(b);
                    any = true;
                }
            }
            if !any {
                break;
            }
        }
        for j in 0..n {
            if w.branch[j] || !w.out[j].is_empty() {
                w.retrim(j);
            }
        }
        // Tips and root stems whose trims still cross: clamp and report.
        for b in 0..n {
            if !w.branch[b] {
                continue;
            }
            let (len, sum) = (w.len(b), w.soff[b] + w.eoff[b]);
            if sum >= len - w.zero && sum > 0.0 {
                let f = 0.5 * len / sum;
                w.soff[b] *= f;
                w.eoff[b] *= f;
                w.clamped.push(b as u32);
            }
        }
        w.collapsed.sort_unstable();
        w.dropped.sort_unstable();
        w
    }

    fn len(&self, b: usize) -> f64 {
        self.start[b].distance(self.end[b])
    }

    /// Whether collapsing `b` would run one of its children's tubes (from `b`'s start
    /// to the child's end, of the child's radius) through another live branch that does
    /// not meet it there (not `b`, its parent or a sibling, the child or the child's
    /// children). Only live branches count, so simplifying the simplified graph again
    /// changes nothing.
    fn straightened_hits(&self, b: usize) -> bool {
        let sj = self.start_joint[b] as usize;
        let a = self.start[b];
        self.out[b].iter().any(|&c| {
            let c = c as usize;
            let q = self.end[c];
            let rc = self.r0[c].max(self.r1[c]);
            let reach = a.distance(q);
            (0..self.n).any(|x| {
                if !self.branch[x] {
                    return false;
                }
                let p = self.start_joint[x] as usize;
                let near = [sj, b, c];
                if near.contains(&x) || near.contains(&p) {
                    return false;
                }
                let r = self.r0[x].max(self.r1[x]);
                let (px, pp) = (self.end[x], self.start[x]);
                if px.distance(a).min(pp.distance(a)) > reach + px.distance(pp) + rc + r {
                    return false;
                }
                segment_closest(a, q, pp, px).0 < rc + r
            })
        })
    }

    /// How far collapsing `b` would move its children's tubes: the largest distance
    /// from `b`'s end point to a child's new axis (from `b`'s start to the child's end).
    fn straightening(&self, b: usize) -> f64 {
        let (a, e) = (self.start[b], self.end[b]);
        self.out[b].iter().map(|&c| segment_closest(a, self.end[c as usize], e, e).0).fold(0.0, f64::max)
    }

    fn drop_tip(&mut self, b: usize) {
        let j = self.start_joint[b] as usize;
        self.out[j].retain(|&c| c as usize != b);
        self.branch[b] = false;
        self.dropped.push(b as u32);
    }

    /// Deletes branch `b` and re-attaches its children to its start joint.
    fn collapse_raw(&mut self, b: usize) -> Vec<u32> {
        let j = self.start_joint[b] as usize;
        let moved = std::mem::take(&mut self.out[b]);
        for &c in &moved {
            self.start_joint[c as usize] = j as u32;
            self.start[c as usize] = self.start[b];
        }
        if let Some(k) = self.out[j].iter().position(|&c| c as usize == b) {
            self.out[j].splice(k..k + 1, moved.iter().copied());
        }
        self.branch[b] = false;
        self.collapsed.push(b as u32);
        moved
    }

    /// Collapses `b` and handles children that became zero-length (collapsed in turn,
    /// or dropped when they are tips). Offsets are computed on demand by
    /// [`Work::offset_of`], so the merged joint is re-trimmed at once without an
    /// O(k²) pass per collapse.
    fn collapse(&mut self, b: usize) {
        let mut stack = vec![b];
        while let Some(x) = stack.pop() {
            for c in self.collapse_raw(x) {
                let cu = c as usize;
                if self.len(cu) <= self.zero {
                    if self.out[cu].is_empty() {
                        self.drop_tip(cu);
                    } else {
                        stack.push(cu);
                    }
                }
            }
        }
    }

    /// Outward axis and radius of branch `x` at joint `j` (`is_in`: `x` ends at `j`);
    /// `None` for a zero-length branch.
    fn incident(&self, x: usize, is_in: bool) -> Option<(DVec3, f64)> {
        let l = self.len(x);
        if l.is_nan() || l <= self.zero {
            return None;
        }
        Some(if is_in {
            ((self.start[x] - self.end[x]) / l, self.r1[x])
        } else {
            ((self.end[x] - self.start[x]) / l, self.r0[x])
        })
    }

    /// The current trim offset of branch `x` at joint `j` (with margin), in O(k).
    fn offset_of(&self, j: usize, x: usize, is_in: bool) -> f64 {
        let Some((a, ra)) = self.incident(x, is_in) else { return 0.0 };
        let mut off = 0.0f64;
        let mut partner = |y: usize, y_in: bool| {
            if y == x && y_in == is_in {
                return;
            }
            if let Some((b, rb)) = self.incident(y, y_in) {
                if let Some((o, _)) = pair_offsets(a, ra, b, rb, self.eps) {
                    off = off.max(o);
                }
            }
        };
        if self.branch[j] {
            partner(j, true);
        }
        for &c in &self.out[j] {
            partner(c as usize, false);
        }
        let o = off * (1.0 + self.margin);
        if o.is_finite() {
            o
        } else {
            0.0
        }
    }

    /// Recomputes the offsets of every branch at joint `j` (Pieterse2012 §4.1.3).
    fn retrim(&mut self, j: usize) {
        let mut inc: Vec<(usize, bool, DVec3, f64)> = Vec::with_capacity(self.out[j].len() + 1);
        if self.branch[j] {
            let l = self.len(j);
            if l > self.zero {
                inc.push((j, true, (self.start[j] - self.end[j]) / l, self.r1[j]));
            } else {
                self.eoff[j] = 0.0;
            }
        }
        for &c in &self.out[j] {
            let cu = c as usize;
            let l = self.len(cu);
            if l > self.zero {
                inc.push((cu, false, (self.end[cu] - self.start[cu]) / l, self.r0[cu]));
            } else {
                self.soff[cu] = 0.0;
            }
        }
        let mut offs = vec![0.0f64; inc.len()];
        let mut aligned = false;
        for x in 0..inc.len() {
            for y in x + 1..inc.len() {
                match pair_offsets(inc[x].2, inc[x].3, inc[y].2, inc[y].3, self.eps) {
                    Some((ox, oy)) => {
                        offs[x] = offs[x].max(ox);
                        offs[y] = offs[y].max(oy);
                    }
                    None => aligned = true,
                }
            }
        }
        self.aligned[j] = aligned;
        for (k, &(b, is_in, _, _)) in inc.iter().enumerate() {
            let o = offs[k] * (1.0 + self.margin);
            let o = if o.is_finite() { o } else { 0.0 };
            if is_in {
                self.eoff[b] = o;
            } else {
                self.soff[b] = o;
            }
        }
    }
}

/// A loop at a joint: branch slot and which end.
#[derive(Debug, Clone, Copy)]
struct LoopRef {
    slot: u32,
    at_end: bool,
}

/// What a joint becomes.
#[derive(Debug, Clone)]
enum Plan {
    Band,
    /// Faces as (loop index within the joint, vertex index within the loop).
    Hull(Vec<[(u32, u32); 3]>),
    Fallback,
}

/// Per-branch geometry for meshing.
#[derive(Debug, Clone, Copy, Default)]
struct Geo {
    node: u32,
    start: DVec3,
    d: DVec3,
    len: f64,
    r0: f64,
    r1: f64,
    u: DVec3,
    w: DVec3,
    off_s: f64,
    off_e: f64,
    segments: u32,
    first_vertex: u32,
    first_uv: u32,
    v0: f64,
    /// A root's virtual base loop (see [`root_base`]): one ring at the root node, no
    /// segments, closed by a fan; not a branch.
    base: bool,
}

impl Geo {
    fn radius_at(&self, t: f64) -> f64 {
        if self.len > 0.0 {
            self.r0 + (self.r1 - self.r0) * (t / self.len).clamp(0.0, 1.0)
        } else {
            self.r0
        }
    }

    /// Centre and radius of the loop at the start (`at_end = false`) or the end.
    fn end_loop(&self, at_end: bool) -> (DVec3, f64) {
        let t = if at_end { self.len - self.off_e } else { self.off_s };
        (self.start + self.d * t, self.radius_at(t))
    }

    fn loop_vertex(&self, at_end: bool, j: u32, s: u32) -> u32 {
        self.first_vertex + if at_end { self.segments * s } else { 0 } + j
    }

    fn loop_uv(&self, at_end: bool, j: u32, s: u32) -> u32 {
        self.first_uv + if at_end { self.segments * (s + 1) } else { 0 } + j
    }
}

/// Meshes `skeleton` with convex-hull joints (see the module docs).
///
/// Errors: [`Error::InvalidGeometry`] for options out of range or a mesh beyond `u32`
/// indices; [`Error::Skeleton`] when the skeleton fails [`Skeleton::validate`].
/// Joints that cannot be meshed fall back locally and are reported, never an error.
pub fn hull_mesh(skeleton: &Skeleton, opts: &HullOptions) -> Result<HullMesh> {
    opts.check()?;
    skeleton.validate()?;
    let work = Work::new(skeleton, opts);
    let n = work.n;
    let s = opts.sides;
    let su = s as usize;

    // Live branches, their slots and frames (parent-first, so parents come first).
    let mut slot = vec![NONE; n];
    let mut geo: Vec<Geo> = Vec::new();
    for b in 0..n {
        if !work.branch[b] {
            continue;
        }
        slot[b] = geo.len() as u32;
        let len = work.len(b);
        let d = (work.end[b] - work.start[b]) / len;
        let pj = work.start_joint[b] as usize;
        let seed = if work.branch[pj] {
            let pg = &geo[slot[pj] as usize];
            DQuat::from_rotation_arc(pg.d, d) * pg.u
        } else {
            skeleton.up[b].as_dvec3()
        };
        let mut u = seed - d * seed.dot(d);
        u = if u.length_squared() > 1e-12 { u.normalize() } else { d.any_orthonormal_vector() };
        let wv = d.cross(u);
        geo.push(Geo {
            node: b as u32,
            start: work.start[b],
            d,
            len,
            r0: work.r0[b],
            r1: work.r1[b],
            u,
            w: wv,
            off_s: work.soff[b],
            off_e: work.eoff[b],
            ..Geo::default()
        });
    }

    // Meshing offsets: a floor at joints so bands and hulls never join coincident
    // loops, within 80% of the length; never less than 5% of the length left.
    for g in geo.iter_mut() {
        let b = g.node as usize;
        let sj = work.start_joint[b] as usize;
        let start_is_joint = work.branch[sj] || work.out[sj].len() >= 2;
        let end_is_joint = !work.out[b].is_empty();
        let floor = |r: f64| (0.25 * PI * r).min(0.25 * g.len);
        let fs = if start_is_joint { floor(g.r0) } else { 0.0 };
        let fe = if end_is_joint { floor(g.r1) } else { 0.0 };
        let (xs, xe) = ((fs - g.off_s).max(0.0), (fe - g.off_e).max(0.0));
        let room = (0.8 * g.len - g.off_s - g.off_e).max(0.0);
        let k = if xs + xe > room && xs + xe > 0.0 { room / (xs + xe) } else { 1.0 };
        g.off_s += xs * k;
        g.off_e += xe * k;
        let sum = g.off_s + g.off_e;
        if sum > 0.95 * g.len {
            let f = 0.95 * g.len / sum;
            g.off_s *= f;
            g.off_e *= f;
        }
    }

    // Joints and their plans.
    let mut joint_nodes = Vec::new();
    let mut plans = Vec::new();
    let mut joint_loops: Vec<Vec<LoopRef>> = Vec::new();
    let mut joint_detached: Vec<Vec<LoopRef>> = Vec::new();
    for j in 0..n {
        let k = work.out[j].len() + work.branch[j] as usize;
        if k < 2 {
            continue;
        }
        let mut loops: Vec<LoopRef> = Vec::with_capacity(k);
        if work.branch[j] {
            loops.push(LoopRef { slot: slot[j], at_end: true });
        }
        for &c in &work.out[j] {
            loops.push(LoopRef { slot: slot[c as usize], at_end: false });
        }
        // Aligned branches (Pieterse2012 §4.1.3 case 3) cannot share a joint: the thinner of
        // each aligned pair is detached (a child folding back into its parent always is)
        // and closed by a fan; the others still get their joint.
        let mut detached: Vec<LoopRef> = Vec::new();
        if work.aligned[j] {
            let eps = opts.aligned_epsilon;
            let axis = |l: &LoopRef| {
                let g = &geo[l.slot as usize];
                if l.at_end {
                    -g.d
                } else {
                    g.d
                }
            };
            let radius = |l: &LoopRef| geo[l.slot as usize].end_loop(l.at_end).1;
            let mut kept: Vec<LoopRef> = Vec::with_capacity(loops.len());
            for l in loops.drain(..) {
                let a = axis(&l);
                match kept.iter().position(|m| axis(m).dot(a) > 1.0 - eps) {
                    None => kept.push(l),
                    Some(p) => {
                        let m = kept[p];
                        if !m.at_end && radius(&l) > radius(&m) {
                            kept[p] = l;
                            detached.push(m);
                        } else {
                            detached.push(l);
                        }
                    }
                }
            }
            loops = kept;
        }
        let has_in = loops.first().is_some_and(|l| l.at_end);
        // A root whose stems all leave within a cone gets a virtual base loop (see
        // `root_base`); without it the hull of their loops is a thin lens.
        let based = if !work.branch[j] && detached.is_empty() {
            root_base(skeleton, j, &geo, &loops).and_then(|b| {
                geo.push(b);
                let mut with = vec![LoopRef { slot: (geo.len() - 1) as u32, at_end: false }];
                with.extend(loops.iter().copied());
                match hull_joint(&geo, &with, s, opts.aligned_epsilon) {
                    Some(t) => Some((t, with)),
                    None => {
                        geo.pop();
                        None
                    }
                }
            })
        } else {
            None
        };
        let plan = if let Some((t, with)) = based {
            loops = with;
            Plan::Hull(t)
        } else if loops.len() < 2 {
            Plan::Fallback
        } else if loops.len() == 2 && has_in {
            let (a, b) = (&geo[loops[0].slot as usize], &geo[loops[1].slot as usize]);
            if (-a.d).dot(b.d) > 1.0 - opts.aligned_epsilon {
                Plan::Fallback
            } else {
                Plan::Band
            }
        } else {
            match hull_joint(&geo, &loops, s, opts.aligned_epsilon) {
                Some(t) => Plan::Hull(t),
                None => Plan::Fallback,
            }
        };
        if matches!(plan, Plan::Fallback) {
            loops.append(&mut detached);
            loops.sort_by_key(|l| (!l.at_end, geo[l.slot as usize].node));
        }
        let zeroed = if matches!(plan, Plan::Fallback) { &loops } else { &detached };
        for l in zeroed.clone() {
            let g = &mut geo[l.slot as usize];
            if l.at_end {
                g.off_e = 0.0;
            } else {
                g.off_s = 0.0;
            }
        }
        joint_nodes.push(j as u32);
        plans.push(plan);
        joint_loops.push(loops);
        joint_detached.push(detached);
    }
    let mut plan_of = vec![NONE; n];
    for (k, &j) in joint_nodes.iter().enumerate() {
        plan_of[j as usize] = k as u32;
    }

    // Segments, vertex and UV bases, v₀ (chains through bands are one chart).
    let mut counts = (0u64, 0u64, 0u64); // vertices, uvs, triangles
    for gi in 0..geo.len() {
        let g = geo[gi];
        if g.base {
            let g = &mut geo[gi];
            g.first_vertex = counts.0.min(u32::MAX as u64) as u32;
            g.first_uv = counts.1.min(u32::MAX as u64) as u32;
            counts.0 += su as u64;
            counts.1 += su as u64 + 1;
            continue;
        }
        let l = (g.len - g.off_s - g.off_e).max(0.0);
        let (_, rs) = g.end_loop(false);
        let (_, re) = g.end_loop(true);
        let seg = l / (opts.segment_factor * PI * 0.5 * (rs + re));
        let segments =
            if seg.is_finite() { seg.round().clamp(1.0, opts.max_segments as f64) as u32 } else { 1 };
        let sj = work.start_joint[g.node as usize] as usize;
        let mut v0 = 0.0;
        let band_child = work.branch[sj]
            && plan_of[sj] != NONE
            && matches!(plans[plan_of[sj] as usize], Plan::Band)
            && joint_loops[plan_of[sj] as usize][1].slot == gi as u32;
        if band_child {
            let p = &geo[slot[sj] as usize];
            let (pc, pr) = p.end_loop(true);
            let (cc, cr) = g.end_loop(false);
            let delta = pc.distance(cc) / (PI * (pr + cr));
            v0 = p.v0 + p.segments as f64 * 0.5 + if delta.is_finite() { delta } else { 0.0 };
        }
        let g = &mut geo[gi];
        g.segments = segments;
        g.v0 = v0;
        g.first_vertex = counts.0.min(u32::MAX as u64) as u32;
        g.first_uv = counts.1.min(u32::MAX as u64) as u32;
        counts.0 += (segments as u64 + 1) * su as u64;
        counts.1 += (segments as u64 + 1) * (su as u64 + 1);
        counts.2 += 2 * segments as u64 * su as u64;
    }
    let cap_count = |caps: bool| -> u64 {
        let mut c = 0u64;
        for j in 0..n {
            let k = work.out[j].len() + work.branch[j] as usize;
            if k == 1 && caps {
                c += 1;
            }
        }
        c
    };
    let extra_caps = cap_count(opts.caps)
        + plans
            .iter()
            .zip(&joint_loops)
            .filter(|(p, _)| matches!(p, Plan::Fallback))
            .map(|(_, l)| l.len() as u64)
            .sum::<u64>()
        + joint_detached.iter().map(|d| d.len() as u64).sum::<u64>()
        + geo.iter().filter(|g| g.base).count() as u64;
    let joint_tris: u64 = joint_loops.iter().map(|l| (l.len() as u64) * (su as u64 + 2)).sum();
    let limit = u32::MAX as u64 / 4;
    if counts.0 + extra_caps >= limit
        || (counts.2 + joint_tris + extra_caps * su as u64) * 3 >= limit
        || counts.1 + extra_caps * (su as u64 + 1) + joint_tris * 3 >= limit
    {
        return Err(Error::InvalidGeometry {
            what: "hull mesher".into(),
            why: format!(
                "the hull mesh would have {} vertices and {} triangles, more than u32 indices \
                 allow; use fewer sides, a larger segment_factor or a smaller skeleton",
                counts.0, counts.2
            ),
        });
    }

    // Emit branches.
    let mut e = Emit::default();
    e.face_offsets.push(0);
    let mut branches = Vec::with_capacity(geo.len());
    for g in &geo {
        let first_face = e.face_count();
        let (c0, r0) = g.end_loop(false);
        let (c1, r1) = g.end_loop(true);
        let nseg = g.segments;
        for i in 0..=nseg {
            let t = if nseg == 0 { 0.0 } else { i as f64 / nseg as f64 };
            let c = c0.lerp(c1, t);
            let r = r0 + (r1 - r0) * t;
            for j in 0..s {
                let ph = TAU * j as f64 / s as f64;
                e.positions.push((c + (g.u * ph.cos() + g.w * ph.sin()) * r).as_vec3());
            }
            let v = g.v0 + i as f64 * 0.5;
            for j in 0..=s {
                e.uvs.push(Vec2::new(j as f32 / s as f32, v as f32));
            }
        }
        for i in 0..nseg {
            for j in 0..s {
                let jn = (j + 1) % s;
                let a = g.first_vertex + i * s + j;
                let b = g.first_vertex + i * s + jn;
                let c = g.first_vertex + (i + 1) * s + j;
                let d = g.first_vertex + (i + 1) * s + jn;
                let ua = g.first_uv + i * (s + 1) + j;
                let uc = g.first_uv + (i + 1) * (s + 1) + j;
                e.tri([a, b, c], [ua, ua + 1, uc]);
                e.tri([b, d, c], [ua + 1, uc + 1, uc]);
            }
        }
        if g.base {
            continue;
        }
        let sj = work.start_joint[g.node as usize];
        branches.push(BranchSpan {
            node: g.node,
            start_node: sj,
            first_vertex: g.first_vertex,
            segments: nseg,
            faces: first_face..e.face_count(),
            start_offset: g.off_s,
            end_offset: g.off_e,
            length: g.len,
            v0: g.v0,
        });
    }

    // Emit joints.
    let mut joints = Vec::with_capacity(joint_nodes.len());
    let mut fallbacks = Vec::new();
    for (k, &jn) in joint_nodes.iter().enumerate() {
        let loops = &joint_loops[k];
        let first_face = e.face_count();
        let kind = match &plans[k] {
            Plan::Band => {
                let (p, c) = (&geo[loops[0].slot as usize], &geo[loops[1].slot as usize]);
                for j in 0..s {
                    let jn1 = (j + 1) % s;
                    let (a, b) = (p.loop_vertex(true, j, s), p.loop_vertex(true, jn1, s));
                    let (cc, d) = (c.loop_vertex(false, j, s), c.loop_vertex(false, jn1, s));
                    let (ua, ub) = (p.loop_uv(true, j, s), p.loop_uv(true, j + 1, s));
                    let (uc, ud) = (c.loop_uv(false, j, s), c.loop_uv(false, j + 1, s));
                    e.tri([a, b, cc], [ua, ub, uc]);
                    e.tri([b, d, cc], [ub, ud, uc]);
                }
                JointKind::Band
            }
            Plan::Hull(tris) => {
                let vid = |(l, j): (u32, u32)| {
                    let lr = loops[l as usize];
                    geo[lr.slot as usize].loop_vertex(lr.at_end, j, s)
                };
                let mut faces: Vec<[u32; 3]> = tris.iter().map(|t| t.map(vid)).collect();
                flip_slivers(&mut faces, &e.positions);
                let uvs = joint_uvs(&mut e, &geo, loops, &faces, s);
                for (f, uv) in faces.iter().zip(uvs) {
                    e.tri(*f, uv);
                }
                for l in loops.iter().filter(|l| geo[l.slot as usize].base) {
                    e.cap(&geo[l.slot as usize], true, s);
                }
                JointKind::Hull
            }
            Plan::Fallback => {
                for l in loops {
                    e.cap(&geo[l.slot as usize], l.at_end, s);
                }
                fallbacks.push(jn);
                JointKind::Fallback
            }
        };
        let faces = first_face..e.face_count();
        let detached = &joint_detached[k];
        for l in detached {
            e.cap(&geo[l.slot as usize], l.at_end, s);
        }
        if !detached.is_empty() && kind != JointKind::Fallback {
            fallbacks.push(jn);
        }
        let detached = detached.iter().map(|l| geo[l.slot as usize].node).collect();
        joints.push(JointSpan { node: jn, kind, loops: loops.len() as u32, faces, detached });
    }

    // Base and tip loops.
    let mut open_loops = 0;
    for j in 0..n {
        let k = work.out[j].len() + work.branch[j] as usize;
        if k != 1 {
            continue;
        }
        let (g, at_end) = if work.branch[j] {
            (&geo[slot[j] as usize], true)
        } else {
            (&geo[slot[work.out[j][0] as usize] as usize], false)
        };
        if opts.caps {
            e.cap(g, at_end, s);
        } else {
            open_loops += 1;
        }
    }

    let normals = e.normals();
    let face_indices = e.indices;
    let mesh = Mesh {
        positions: e.positions,
        face_offsets: e.face_offsets,
        uvs: Some(FaceVarying { values: e.uvs, indices: e.uv_indices }),
        normals: Some(FaceVarying { values: normals, indices: face_indices.clone() }),
        face_indices,
        creases: Vec::new(),
    };
    Ok(HullMesh {
        mesh,
        fallbacks,
        joints,
        branches,
        collapsed: work.collapsed,
        clamped: work.clamped,
        dropped: work.dropped,
        open_loops,
    })
}

/// A virtual base loop for root node `j` whose stems (`loops`, all starting there) leave
/// within 60° of their mean direction `m`: a ring of the root's radius at the node in
/// the plane normal to `m`, facing away from the stems (a zero-length tube pointing
/// down `−m`, closed at once by a fan facing `−m`). Beyond the seed: the hull of stem
/// loops that all lie in one narrow cone is a thin lens whose two faces cross after
/// the loops are moved back from the sphere (`mig-k`'s four stems 3°–8° apart); with
/// the base the joint is a dome over a flat base at the node, and the root stays
/// closed as before. `None` when the stems are not in such a cone, or when a stem's
/// loop dips below the base plane.
fn root_base(sk: &Skeleton, j: usize, geo: &[Geo], loops: &[LoopRef]) -> Option<Geo> {
    if loops.len() < 2 || loops.iter().any(|l| l.at_end) {
        return None;
    }
    let m = loops.iter().map(|l| geo[l.slot as usize].d).sum::<DVec3>().normalize_or_zero();
    if m == DVec3::ZERO {
        return None;
    }
    let mut r = sk.radius[j] as f64;
    for l in loops {
        let g = &geo[l.slot as usize];
        let (c, rl) = g.end_loop(false);
        let cos = g.d.dot(m);
        // The loop's lowest point above the base plane, with a margin of its radius.
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        if cos < 0.5 || (c - g.start).dot(m) - rl * sin < 0.25 * rl {
            return None;
        }
        r = r.max(g.r0);
    }
    if !(r.is_finite() && r > 0.0) {
        return None;
    }
    let d = -m;
    let up = sk.up[j].as_dvec3();
    let u = up - d * up.dot(d);
    let u = if u.length_squared() > 1e-12 { u.normalize() } else { d.any_orthonormal_vector() };
    Some(Geo {
        node: j as u32,
        start: sk.position[j].as_dvec3(),
        d,
        r0: r,
        r1: r,
        u,
        w: d.cross(u),
        base: true,
        ..Geo::default()
    })
}

/// Builds a hull joint (Pieterse2012 §4.2.3; Pieterse2012-spec §2.6): loops centrally projected onto
/// the unit sphere about the joint node, hull, caps removed, checked. `None` when the
/// joint cannot be meshed this way.
fn hull_joint(geo: &[Geo], loops: &[LoopRef], s: u32, eps: f64) -> Option<Vec<[(u32, u32); 3]>> {
    let mut caps = Vec::with_capacity(loops.len());
    for l in loops {
        let g = &geo[l.slot as usize];
        let (a, off) = if l.at_end { (-g.d, g.off_e) } else { (g.d, g.off_s) };
        let (_, r) = g.end_loop(l.at_end);
        caps.push(CapLoop { axis: a, radius: r, offset: off, u: g.u, w: g.w, at_end: l.at_end });
    }
    cap_hull(&caps, s, eps)
}

/// One loop of `s` vertices taking part in a [`cap_hull`] joint about a node `O`: its
/// vertex `j` lies at `O + offset·axis' + radius·(cos φⱼ u + sin φⱼ w)` with
/// `φⱼ = 2πj/s`, where `axis'` is `axis` for a loop that starts a tube and `−axis` is
/// its direction of travel for one that ends a tube (`at_end`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CapLoop {
    /// Unit axis pointing away from the node.
    pub axis: DVec3,
    /// Loop radius.
    pub radius: f64,
    /// Distance of the loop's centre from the node along `axis` (0 allowed).
    pub offset: f64,
    /// First in-plane unit vector (vertex 0).
    pub u: DVec3,
    /// Second in-plane unit vector (vertex at a quarter turn).
    pub w: DVec3,
    /// The loop ends its tube (its tube uses the loop's edges `j+1 → j`, the joint
    /// `j → j+1`); otherwise it starts one (the joint uses `j+1 → j`).
    pub at_end: bool,
}

/// The convex-hull joint of Pieterse2012 §4.2.3 for any loops about one node, shared by the
/// hull and the sweep meshers: every loop vertex is centrally projected onto the unit
/// sphere (each loop a small circle about its axis, shrunk so that no two circles come
/// closer than 20 % of their axes' angle), the exact hull of [`convex`] is built, the
/// caps (faces with all three corners on one loop, `s − 2` each) are removed and the
/// rest is checked: every point on the hull, `k(s + 2) − 4` faces, each directed edge
/// once and every loop edge in the orientation its tube needs. Faces are
/// `(loop index, vertex index)` triples, counter-clockwise seen from outside. `None`
/// when two axes are within `eps` (`1 − cos`) of each other or a check fails.
pub(crate) fn cap_hull(loops: &[CapLoop], s: u32, eps: f64) -> Option<Vec<[(u32, u32); 3]>> {
    let k = loops.len();
    let su = s as usize;
    if k < 2 || s < 3 {
        return None;
    }
    // Outward axis and angular radius of the loop seen from O (central projection).
    let mut ax = Vec::with_capacity(k);
    let mut th = Vec::with_capacity(k);
    for l in loops {
        let t = l.radius.atan2(l.offset).min(1.3);
        if t.is_nan() || t <= 1e-9 || !l.axis.is_finite() {
            return None;
        }
        ax.push(l.axis);
        th.push(t);
    }
    for x in 0..k {
        for y in x + 1..k {
            if ax[x].dot(ax[y]) > 1.0 - eps {
                return None; // aligned (Pieterse2012 §4.1.3 case 3)
            }
        }
    }
    // Shrink circles so every loop is a clean cap: θi + θj ≤ 0.8·∠(ai, aj).
    let mut theta = th.clone();
    for x in 0..k {
        for y in 0..k {
            if x == y {
                continue;
            }
            let gamma = ax[x].dot(ax[y]).clamp(-1.0, 1.0).acos();
            let sum = th[x] + th[y];
            if sum > 0.8 * gamma {
                theta[x] = theta[x].min(th[x] * 0.8 * gamma / sum);
            }
        }
    }
    let mut pts = Vec::with_capacity(k * su);
    for (x, l) in loops.iter().enumerate() {
        let (st, ct) = theta[x].sin_cos();
        for j in 0..s {
            let ph = TAU * j as f64 / s as f64;
            pts.push(ax[x] * ct + (l.u * ph.cos() + l.w * ph.sin()) * st);
        }
    }
    let tris = convex::convex_hull(&pts).ok()?;
    // Every point on the hull (Pieterse2012-spec §2.6 step 4, property 13).
    let mut used = vec![false; pts.len()];
    for t in &tris {
        for &v in t {
            used[v as usize] = true;
        }
    }
    if used.iter().any(|u| !u) {
        return None;
    }
    // Remove the loop caps (step 5): s − 2 faces per loop.
    let mut caps = vec![0usize; k];
    let mut out = Vec::with_capacity(tris.len());
    for t in &tris {
        let l = t.map(|v| v / s);
        if l[0] == l[1] && l[1] == l[2] {
            caps[l[0] as usize] += 1;
        } else {
            out.push(t.map(|v| (v / s, v % s)));
        }
    }
    if caps.iter().any(|&c| c != su - 2) || out.len() != k * (su + 2) - 4 {
        return None;
    }
    // Each loop edge once, in the orientation that matches its tube.
    let mut directed = HashMap::with_capacity(out.len() * 3);
    for t in &out {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            if directed.insert((a.0 * s + a.1, b.0 * s + b.1), ()).is_some() {
                return None;
            }
        }
    }
    for (x, l) in loops.iter().enumerate() {
        let x = x as u32;
        for j in 0..s {
            let (p, q) = (x * s + j, x * s + (j + 1) % s);
            let want = if l.at_end { (p, q) } else { (q, p) };
            if !directed.contains_key(&want) {
                return None;
            }
        }
    }
    Some(out)
}

/// Twice the area and the longest edge's squared length of triangle `f`.
fn tri_shape(f: [u32; 3], pos: &[Vec3]) -> (f64, f64) {
    let [a, b, c] = f.map(|v| pos[v as usize].as_dvec3());
    let area2 = (b - a).cross(c - a).length();
    let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
    (area2, longest)
}

/// True for a sliver by the mesh checker's rule ([`crate::tolerance::is_sliver`]).
fn is_sliver(f: [u32; 3], pos: &[Vec3]) -> bool {
    let (area2, longest) = tri_shape(f, pos);
    crate::tolerance::is_sliver(0.5 * area2, longest)
}

/// Removes slivers from a joint's triangles by edge flips. A hull face on the sphere
/// can become a sliver when its vertices move back to their loops: on a planar tree
/// every loop has a vertex in the same plane, and the vertices of loops along one
/// straight axis end up collinear. For a sliver (a, b, c) with longest edge ab and c on
/// it, the joint face across ab, (b, a, d), is replaced together with it by (b, c, d) and
/// (c, a, d): the same surface, the orientation kept, ab gone. A flip is made only when
/// both new faces are proper (not slivers, facing like the old neighbour) and cd is not
/// already an edge; loop edges (one joint face) are never flipped. At most 4 flips per
/// face, so it always ends.
fn flip_slivers(faces: &mut [[u32; 3]], pos: &[Vec3]) {
    let mut budget = 4 * faces.len();
    'outer: while budget > 0 {
        let mut edge: HashMap<(u32, u32), usize> = HashMap::with_capacity(faces.len() * 3);
        for (i, f) in faces.iter().enumerate() {
            for e in 0..3 {
                edge.insert((f[e], f[(e + 1) % 3]), i);
            }
        }
        for i in 0..faces.len() {
            if !is_sliver(faces[i], pos) {
                continue;
            }
            let f = faces[i];
            // Rotate so (a, b) is the longest edge.
            let len = |x: u32, y: u32| pos[x as usize].distance_squared(pos[y as usize]);
            let r = (0..3).max_by(|&x, &y| len(f[x], f[(x + 1) % 3]).total_cmp(&len(f[y], f[(y + 1) % 3])));
            let r = r.unwrap_or(0);
            let (a, b, c) = (f[r], f[(r + 1) % 3], f[(r + 2) % 3]);
            let Some(&g) = edge.get(&(b, a)) else { continue };
            let Some(d) = faces[g].into_iter().find(|&v| v != a && v != b) else { continue };
            if d == c || edge.contains_key(&(c, d)) || edge.contains_key(&(d, c)) {
                continue;
            }
            let (t1, t2) = ([b, c, d], [c, a, d]);
            let normal = |t: [u32; 3]| {
                let [p, q, s] = t.map(|v| pos[v as usize].as_dvec3());
                (q - p).cross(s - p)
            };
            let old = normal(faces[g]);
            if is_sliver(t1, pos)
                || is_sliver(t2, pos)
                || normal(t1).dot(old) <= 0.0
                || normal(t2).dot(old) <= 0.0
            {
                continue;
            }
            faces[i] = t1;
            faces[g] = t2;
            budget -= 1;
            continue 'outer;
        }
        break;
    }
}

/// UV corners for a hull joint's faces by propagation (Pieterse2012 §4.3.3): each face takes
/// its neighbour across its longest edge that has UVs (branch faces always do), copies
/// the two shared corners and unfolds the third. New UV values are appended to `e`.
fn joint_uvs(e: &mut Emit, geo: &[Geo], loops: &[LoopRef], faces: &[[u32; 3]], s: u32) -> Vec<[u32; 3]> {
    // Directed edges as the branch faces use them → their UV indices.
    let mut branch_edge: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for l in loops {
        let g = &geo[l.slot as usize];
        for j in 0..s {
            let (vj, vn) = (g.loop_vertex(l.at_end, j, s), g.loop_vertex(l.at_end, (j + 1) % s, s));
            let (uj, un) = (g.loop_uv(l.at_end, j, s), g.loop_uv(l.at_end, j + 1, s));
            if l.at_end {
                branch_edge.insert((vn, vj), (un, uj));
            } else {
                branch_edge.insert((vj, vn), (uj, un));
            }
        }
    }
    let mut joint_edge: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
    for (f, t) in faces.iter().enumerate() {
        for k in 0..3 {
            joint_edge.insert((t[k], t[(k + 1) % 3]), (f, k));
        }
    }
    let pos = |v: u32| e.positions[v as usize].as_dvec3();
    let mut done: Vec<Option<[u32; 3]>> = vec![None; faces.len()];
    loop {
        let mut progress = false;
        for f in 0..faces.len() {
            if done[f].is_some() {
                continue;
            }
            let t = faces[f];
            let mut order = [0usize, 1, 2];
            let len = |k: usize| pos(t[k]).distance_squared(pos(t[(k + 1) % 3]));
            order.sort_by(|&x, &y| len(y).total_cmp(&len(x)).then(x.cmp(&y)));
            for k in order {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let shared = if let Some(&(ub, ua)) = branch_edge.get(&(b, a)) {
                    Some((ua, ub))
                } else if let Some(&(g, gk)) = joint_edge.get(&(b, a)) {
                    // Face g has edge b→a at corner gk: b at gk, a at gk + 1.
                    done[g].map(|uv| (uv[(gk + 1) % 3], uv[gk]))
                } else {
                    None
                };
                let Some((ua, ub)) = shared else { continue };
                let c = t[(k + 2) % 3];
                let uc = unfold(pos(a), pos(b), pos(c), e.uvs[ua as usize], e.uvs[ub as usize]);
                let ic = e.uvs.len() as u32;
                e.uvs.push(uc);
                let mut uv = [0u32; 3];
                uv[k] = ua;
                uv[(k + 1) % 3] = ub;
                uv[(k + 2) % 3] = ic;
                done[f] = Some(uv);
                progress = true;
                break;
            }
        }
        if !progress {
            break;
        }
    }
    // Unreachable faces (none for a connected joint): a degenerate UV triangle.
    done.into_iter()
        .map(|d| {
            d.unwrap_or_else(|| {
                let i = e.uvs.len() as u32;
                e.uvs.push(Vec2::ZERO);
                [i, i, i]
            })
        })
        .collect()
}

/// The UV of `c` when triangle `(a, b, c)` is unfolded onto the edge `ua → ub`:
/// the same edge parameter and relative height, counter-clockwise in UV.
fn unfold(a: DVec3, b: DVec3, c: DVec3, ua: Vec2, ub: Vec2) -> Vec2 {
    let e = b - a;
    let l2 = e.length_squared();
    if l2.is_nan() || l2 <= 1e-300 {
        return ua;
    }
    let t = (c - a).dot(e) / l2;
    let h = ((c - a) - e * t).length() / l2.sqrt();
    let (ua, ub) = (ua.as_dvec2(), ub.as_dvec2());
    let ed = ub - ua;
    let perp = DVec2::new(-ed.y, ed.x);
    let r = ua + ed * t + perp * h;
    if r.is_finite() {
        r.as_vec2()
    } else {
        ua.as_vec2()
    }
}

/// Output buffers.
#[derive(Default)]
struct Emit {
    positions: Vec<Vec3>,
    face_offsets: Vec<u32>,
    indices: Vec<u32>,
    uvs: Vec<Vec2>,
    uv_indices: Vec<u32>,
}

impl Emit {
    fn face_count(&self) -> u32 {
        (self.face_offsets.len() - 1) as u32
    }

    fn tri(&mut self, v: [u32; 3], uv: [u32; 3]) {
        self.indices.extend_from_slice(&v);
        self.uv_indices.extend_from_slice(&uv);
        self.face_offsets.push(self.indices.len() as u32);
    }

    /// A flat fan closing the start (`at_end = false`) or end loop of branch `g`, facing
    /// away from the branch; UVs on a disc.
    fn cap(&mut self, g: &Geo, at_end: bool, s: u32) {
        let (c, _) = g.end_loop(at_end);
        let centre = self.positions.len() as u32;
        self.positions.push(c.as_vec3());
        let uc = self.uvs.len() as u32;
        self.uvs.push(Vec2::splat(0.5));
        let sign = if at_end { 1.0 } else { -1.0 };
        for j in 0..s {
            let ph = TAU * j as f64 / s as f64;
            self.uvs.push(Vec2::new((0.5 + 0.5 * ph.cos()) as f32, (0.5 + 0.5 * sign * ph.sin()) as f32));
        }
        for j in 0..s {
            let jn = (j + 1) % s;
            let (vj, vn) = (g.loop_vertex(at_end, j, s), g.loop_vertex(at_end, jn, s));
            let (uj, un) = (uc + 1 + j, uc + 1 + jn);
            if at_end {
                self.tri([vj, vn, centre], [uj, un, uc]);
            } else {
                self.tri([vn, vj, centre], [un, uj, uc]);
            }
        }
    }

    /// Smooth per-vertex normals: area-weighted face normals.
    fn normals(&self) -> Vec<Vec3> {
        let mut acc = vec![DVec3::ZERO; self.positions.len()];
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|v| self.positions[v as usize].as_dvec3());
            let nrm = (b - a).cross(c - a);
            for &v in t {
                acc[v as usize] += nrm;
            }
        }
        acc.into_iter()
            .map(|n| {
                let n = n.normalize_or_zero().as_vec3();
                if n.is_finite() && n != Vec3::ZERO {
                    n
                } else {
                    Vec3::Y
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_offsets_match_the_printed_special_cases() {
        let (a, b) = (DVec3::X, DVec3::Y);
        let (oa, ob) = pair_offsets(a, 0.3, b, 0.7, 1e-6).unwrap();
        assert!((oa - 0.7).abs() < 1e-12 && (ob - 0.3).abs() < 1e-12);
        assert_eq!(pair_offsets(a, 1.0, -a, 1.0, 1e-6), Some((0.0, 0.0)));
        assert_eq!(pair_offsets(a, 1.0, a, 1.0, 1e-6), None);
        // Equal radii: symmetric.
        let c = DVec3::new(1.0, 1.0, 0.0).normalize();
        let (oa, ob) = pair_offsets(a, 0.5, c, 0.5, 1e-6).unwrap();
        assert!((oa - ob).abs() < 1e-12);
        let c = DVec3::new(-1.0, 1.0, 0.0).normalize();
        let (oa, ob) = pair_offsets(a, 0.5, c, 0.5, 1e-6).unwrap();
        assert!((oa - ob).abs() < 1e-12);
    }

    #[test]
    fn slivers_are_flipped_away_and_the_surface_kept() {
        // a, b, d a proper triangle (normal +z) and c on ab: the sliver (b, a, c) and
        // (a, b, d) share ab; a third face (c, a, e) below keeps c's other side.
        let pos = [
            Vec3::new(0.0, 0.0, 0.0),  // a
            Vec3::new(2.0, 0.0, 0.0),  // b
            Vec3::new(1.0, 0.0, 0.0),  // c
            Vec3::new(1.0, 1.0, 0.0),  // d
            Vec3::new(0.5, -1.0, 0.0), // e
        ];
        let mut faces = vec![[1, 0, 2], [0, 1, 3], [2, 0, 4]];
        assert!(is_sliver(faces[0], &pos));
        let area = |fs: &[[u32; 3]]| fs.iter().map(|&f| tri_shape(f, &pos).0).sum::<f64>();
        let before = area(&faces);
        flip_slivers(&mut faces, &pos);
        assert!(faces.iter().all(|&f| !is_sliver(f, &pos)), "{faces:?}");
        assert!((area(&faces) - before).abs() < 1e-9);
        let has = |x: u32, y: u32| faces.iter().any(|f| (0..3).any(|e| f[e] == x && f[(e + 1) % 3] == y));
        assert!(!has(0, 1) && !has(1, 0), "ab is gone: {faces:?}");
        assert!(has(0, 2) && has(2, 1), "c splits the old ab in the same direction");
        // Collinear everything: nothing proper to flip to, left alone, no loop.
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0];
        let mut flat = vec![[0, 1, 2], [1, 0, 3]];
        flip_slivers(&mut flat, &line);
        assert_eq!(flat, vec![[0, 1, 2], [1, 0, 3]]);
    }

    #[test]
    fn unfold_is_counter_clockwise_and_isometric() {
        let uv = unfold(DVec3::ZERO, DVec3::X, DVec3::new(0.5, 0.0, 2.0), Vec2::ZERO, Vec2::X);
        assert!((uv - Vec2::new(0.5, 2.0)).length() < 1e-6);
        // Degenerate edge: no NaN.
        let uv = unfold(DVec3::ONE, DVec3::ONE, DVec3::ZERO, Vec2::ONE, Vec2::ONE);
        assert_eq!(uv, Vec2::ONE);
    }
}
