//! Finding collisions: the fixed tree structure ([`Topology`]: depth, pre-order,
//! subtrees), the near-joint test, internode capsules and their gaps (the checker's
//! `check::meeting` rule), and the bounding-volume hierarchy the pass queries.

use super::{DecollideOptions, Work};
use crate::mesh::check::{
    build_bvh, meeting, meeting_gap, node_depths, segment_closest, Aabb, Meeting, Node,
};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::DVec3;
use rayon::prelude::*;

/// Tree structure that never changes during the pass.
pub(super) struct Topology {
    pub(super) depth: Vec<u32>,
    /// Pre-order entry time and subtree end (exclusive) of every node.
    pub(super) tin: Vec<u32>,
    pub(super) tout: Vec<u32>,
    /// Nodes in pre-order, so a subtree is `pre[tin[c]..tout[c]]`.
    pub(super) pre: Vec<u32>,
    /// Number of children per node.
    pub(super) child_count: Vec<u32>,
    /// The organs hanging on each node, as a CSR (offsets, organ indices).
    pub(super) organ_offsets: Vec<u32>,
    pub(super) organ_list: Vec<u32>,
    /// The nearest joint at or above each node ([`joints_above`]), `NO_PARENT` for none:
    /// so finding joints costs one step per joint, not a walk down a long unbranched
    /// chain (issue 39: a chain of 1,000 zero-length internodes walked 1,000 nodes per
    /// colliding pair).
    pub(super) joint_up: Vec<u32>,
}

impl Topology {
    pub(super) fn new(s: &Skeleton) -> Self {
        let n = s.len();
        let children = s.children();
        let depth = node_depths(&s.parent);
        let mut child_count = vec![0u32; n];
        for i in 0..n {
            if s.parent[i] != NO_PARENT {
                child_count[s.parent[i] as usize] += 1;
            }
        }
        let (mut tin, mut tout, mut pre) = (vec![0u32; n], vec![0u32; n], Vec::with_capacity(n));
        let mut stack: Vec<(u32, bool)> = Vec::new();
        for r in (0..n).filter(|&i| s.parent[i] == NO_PARENT) {
            stack.push((r as u32, false));
            while let Some((v, done)) = stack.pop() {
                if done {
                    tout[v as usize] = pre.len() as u32;
                    continue;
                }
                tin[v as usize] = pre.len() as u32;
                pre.push(v);
                stack.push((v, true));
                for &c in children.of(v as usize).iter().rev() {
                    stack.push((c, false));
                }
            }
        }
        let mut organ_offsets = vec![0u32; n + 1];
        for o in &s.organs {
            if (o.node as usize) < n {
                organ_offsets[o.node as usize + 1] += 1;
            }
        }
        for i in 0..n {
            organ_offsets[i + 1] += organ_offsets[i];
        }
        let mut fill = organ_offsets.clone();
        let mut organ_list = vec![0u32; organ_offsets[n] as usize];
        for (k, o) in s.organs.iter().enumerate() {
            if (o.node as usize) < n {
                organ_list[fill[o.node as usize] as usize] = k as u32;
                fill[o.node as usize] += 1;
            }
        }
        let mut joint_up = vec![NO_PARENT; n];
        for i in 0..n {
            let p = s.parent[i];
            if p == NO_PARENT {
                continue;
            }
            joint_up[i] = if child_count[p as usize] > 1 || s.order[i] != s.order[p as usize] {
                i as u32
            } else {
                joint_up[p as usize]
            };
        }
        Topology { depth, tin, tout, pre, child_count, organ_offsets, organ_list, joint_up }
    }

    /// True when `x` is in the subtree of `c` (including `c`).
    pub(super) fn contains(&self, c: usize, x: usize) -> bool {
        self.tin[c] <= self.tin[x] && self.tin[x] < self.tout[c]
    }

    pub(super) fn subtree(&self, c: usize) -> &[u32] {
        &self.pre[self.tin[c] as usize..self.tout[c] as usize]
    }

    pub(super) fn size(&self, c: usize) -> usize {
        (self.tout[c] - self.tin[c]) as usize
    }
}

/// Tree distance between two nodes when at most `limit` (walking up from the deeper).
fn hops(s: &Skeleton, t: &Topology, a: usize, b: usize, limit: usize) -> Option<usize> {
    let (mut x, mut y, mut h) = (a, b, 0usize);
    while x != y {
        if h >= limit {
            return None;
        }
        let step = if t.depth[x] >= t.depth[y] { &mut x } else { &mut y };
        let p = s.parent[*step];
        if p == NO_PARENT {
            return None;
        }
        *step = p as usize;
        h += 1;
    }
    Some(h)
}

/// True when internodes `a` and `b` collide "near a joint": at most
/// [`DecollideOptions::near_joint_hops`] apart, or branches of one node joined through
/// internodes shorter than [`DecollideOptions::near_joint_path`] × their radius sum
/// (one internode below the other counts by hops only).
pub(super) fn near_joint(s: &Skeleton, topo: &Topology, a: usize, b: usize, o: &DecollideOptions) -> bool {
    let short = (capsule(s, a).r + capsule(s, b).r) * o.near_joint_path;
    hops(s, topo, a, b, o.near_joint_hops).is_some()
        || matches!(meeting(s, &topo.depth, a, b, short), Meeting::Joined)
}

/// One internode as a capsule: base, tip, radius (the larger end radius).
#[derive(Clone, Copy)]
pub(super) struct Capsule {
    pub(super) a: DVec3,
    pub(super) b: DVec3,
    pub(super) r: f64,
}

pub(super) fn capsule(s: &Skeleton, i: usize) -> Capsule {
    let p = s.parent[i] as usize;
    Capsule {
        a: s.position[p].as_dvec3(),
        b: s.position[i].as_dvec3(),
        r: s.radius[i].max(s.radius[p]) as f64,
    }
}

pub(super) fn capsule_box(c: &Capsule, clearance: f64) -> Aabb {
    let pad = c.r * (1.0 + clearance);
    Aabb { lo: c.a.min(c.b) - pad, hi: c.a.max(c.b) + pad }
}

/// The gap between internodes `i` and `j` (capsules `x` and `y`, which may be moved
/// copies: rigid moves keep every internode length) with the closest points, as the
/// checker measures it ([`meeting`]: siblings and internodes joined by a stub from
/// their far ends, chained ones never). When their axes are at least `within` apart the
/// axis gap is returned without walking the tree: a joined or linked gap is never
/// smaller than the axis gap, and a folded pair's axes are closer than the radii (the
/// stub between them is shorter than that).
pub(super) fn gap(
    s: &Skeleton,
    topo: &Topology,
    (i, x): (usize, &Capsule),
    (j, y): (usize, &Capsule),
    within: f64,
) -> Option<(f64, DVec3, DVec3)> {
    let (x, y, short) = ([x.a, x.b], [y.a, y.b], x.r + y.r);
    let axes = segment_closest(x[0], x[1], y[0], y[1]);
    if axes.0 >= within {
        let chained = s.parent[i] as usize == j || s.parent[j] as usize == i;
        return (!chained).then_some(axes);
    }
    meeting_gap(x, y, meeting(s, &topo.depth, i, j, short), short)
}

/// True when internodes `i` and `j` (capsules `x`, `y`) collide at `clearance`.
pub(super) fn collide(
    s: &Skeleton,
    topo: &Topology,
    x: (usize, &Capsule),
    y: (usize, &Capsule),
    clearance: f64,
) -> bool {
    let limit = (x.1.r + y.1.r) * (1.0 + clearance);
    gap(s, topo, x, y, limit).is_some_and(|(d, ..)| d < limit)
}

/// A BVH over the internodes (items are child node ids) whose bounds grow as
/// internodes move.
pub(super) struct Bvh {
    pub(super) nodes: Vec<Node>,
    pub(super) order: Vec<u32>,
    /// Box per skeleton node (unused for roots).
    pub(super) boxes: Vec<Aabb>,
    /// Parent of every BVH node (`u32::MAX` for the root).
    pub(super) up: Vec<u32>,
    /// The leaf holding each skeleton node's internode.
    pub(super) leaf: Vec<u32>,
}

impl Bvh {
    pub(super) fn build(s: &Skeleton, clearance: f64) -> Bvh {
        let boxes: Vec<Aabb> =
            (0..s.len())
                .map(|i| {
                    if s.parent[i] == NO_PARENT {
                        Aabb::EMPTY
                    } else {
                        capsule_box(&capsule(s, i), clearance)
                    }
                })
                .collect();
        let mut order: Vec<u32> =
            (0..s.len() as u32).filter(|&i| s.parent[i as usize] != NO_PARENT).collect();
        let nodes = build_bvh(&boxes, &mut order);
        let mut up = vec![u32::MAX; nodes.len()];
        let mut leaf = vec![u32::MAX; s.len()];
        for (k, n) in nodes.iter().enumerate() {
            if n.count == 0 {
                up[n.first as usize] = k as u32;
                up[n.first as usize + 1] = k as u32;
            } else {
                for &t in &order[n.first as usize..(n.first + n.count) as usize] {
                    leaf[t as usize] = k as u32;
                }
            }
        }
        Bvh { nodes, order, boxes, up, leaf }
    }

    /// Sets the box of item `i` and grows the bounds above it to contain it (the old box
    /// stays inside them: the tree stays correct, only looser, for the rest of a round).
    pub(super) fn update(&mut self, i: usize, b: Aabb) {
        self.boxes[i] = b;
        let mut k = self.leaf[i];
        while k != u32::MAX {
            let n = &mut self.nodes[k as usize];
            if n.bounds.lo.cmple(b.lo).all() && b.hi.cmple(n.bounds.hi).all() {
                break;
            }
            n.bounds.grow(&b);
            k = self.up[k as usize];
        }
    }

    /// Calls `f` with every item whose box overlaps `q`; stops when `f` returns false.
    pub(super) fn visit(&self, q: &Aabb, mut f: impl FnMut(usize) -> bool) {
        if self.order.is_empty() {
            return;
        }
        let mut stack = vec![0u32];
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k as usize];
            if !n.bounds.overlaps(q) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
            } else {
                for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    if self.boxes[t as usize].overlaps(q) && !f(t as usize) {
                        return;
                    }
                }
            }
        }
    }
}

/// Pairs examined between two checks of the budget inside one internode's search.
const PAIR_CHECK: u64 = 4096;

/// Colliding internode pairs at `clearance` (axes closer than `(r_a + r_b)(1 + clearance)`),
/// sorted, each `[smaller, larger]` child node. Every candidate pair examined (both
/// orders) is charged to `work`; the search stops part way once `work` is over its
/// budget (the list is then incomplete, and the pass fails).
pub(super) fn collisions(s: &Skeleton, topo: &Topology, clearance: f64, work: &Work) -> Vec<[usize; 2]> {
    let bvh = Bvh::build(s, clearance);
    let mut pairs: Vec<[usize; 2]> = bvh
        .order
        .par_iter()
        .flat_map_iter(|&i| {
            let i = i as usize;
            let ci = capsule(s, i);
            let mut found = Vec::new();
            if work.over() {
                return found;
            }
            let mut examined = 0u64;
            bvh.visit(&bvh.boxes[i], |j| {
                examined += 1;
                if j > i && collide(s, topo, (i, &ci), (j, &capsule(s, j)), clearance) {
                    found.push([i, j]);
                }
                if examined.is_multiple_of(PAIR_CHECK) {
                    work.charge_u64(PAIR_CHECK);
                    return !work.over();
                }
                true
            });
            work.charge_u64(examined % PAIR_CHECK);
            found
        })
        .collect();
    pairs.sort_unstable();
    pairs
}

/// Charges `work` with the candidate pairs a collision search of `s` examines (as
/// [`collisions`] counts them) and its nodes, without testing them; false (and the
/// budget over) when they are more than is left. Guards searches that do not count
/// their own pairs ([`skeleton_collisions`]).
pub(super) fn charge_search(s: &Skeleton, clearance: f64, work: &Work) -> bool {
    let bvh = Bvh::build(s, clearance);
    let left = work.left();
    let mut examined = 0u64;
    for &i in &bvh.order {
        bvh.visit(&bvh.boxes[i as usize], |_| {
            examined += 1;
            examined <= left
        });
        if examined > left {
            work.exhaust();
            return false;
        }
    }
    work.charge_u64(examined);
    work.charge(s.len());
    !work.over()
}
