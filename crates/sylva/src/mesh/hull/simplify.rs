//! Steps 1–3 of the hull mesher: the branch graph, trimming by the pairwise offsets of
//! two solid cylinders, and graph simplification (Pieterse2012 §4.1.3–§4.1.4;
//! Pieterse2012-spec §2.3–§2.4).

use super::{HullOptions, NONE};
use crate::error::Result;
use crate::mesh::check::segment_closest;
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::DVec3;

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
pub(super) struct Work {
    pub(super) n: usize,
    /// Node `i` ends a live branch.
    pub(super) branch: Vec<bool>,
    pub(super) start_joint: Vec<u32>,
    pub(super) start: Vec<DVec3>,
    pub(super) end: Vec<DVec3>,
    pub(super) r0: Vec<f64>,
    pub(super) r1: Vec<f64>,
    /// Branches starting at joint node `j`.
    pub(super) out: Vec<Vec<u32>>,
    pub(super) soff: Vec<f64>,
    pub(super) eoff: Vec<f64>,
    pub(super) aligned: Vec<bool>,
    pub(super) margin: f64,
    pub(super) eps: f64,
    pub(super) zero: f64,
    pub(super) collapsed: Vec<u32>,
    pub(super) clamped: Vec<u32>,
    pub(super) dropped: Vec<u32>,
}

impl Work {
    pub(super) fn new(sk: &Skeleton, opts: &HullOptions) -> Work {
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

    pub(super) fn len(&self, b: usize) -> f64 {
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
