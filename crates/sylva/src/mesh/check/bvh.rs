//! The bounding-volume hierarchy of axis-aligned boxes shared by the mesh checks and
//! [`crate::fit::decollide`]: building and querying it.

use glam::DVec3;

/// An axis-aligned box (shared with [`crate::fit::decollide`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Aabb {
    pub(crate) lo: DVec3,
    pub(crate) hi: DVec3,
}

impl Aabb {
    /// The empty box: overlaps nothing, grows to whatever it is grown by.
    pub(crate) const EMPTY: Aabb =
        Aabb { lo: DVec3::splat(f64::INFINITY), hi: DVec3::splat(f64::NEG_INFINITY) };
    fn empty() -> Self {
        Self::EMPTY
    }
    pub(crate) fn grow(&mut self, o: &Aabb) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
    }
    pub(crate) fn overlaps(&self, o: &Aabb) -> bool {
        self.lo.cmple(o.hi).all() && o.lo.cmple(self.hi).all()
    }
}

/// A BVH node: a box and either two children or a range of leaf items.
pub(crate) struct Node {
    pub(crate) bounds: Aabb,
    /// Leaves: start into `order`; inner: index of the left child (right = left + 1).
    pub(crate) first: u32,
    /// Leaf item count; 0 for an inner node.
    pub(crate) count: u32,
}

/// Builds the BVH over `boxes` of the items in `order` (median split on the longest
/// axis of the centres, ties by item id); `order` is permuted so each leaf owns a
/// contiguous range.
pub(crate) fn build_bvh(boxes: &[Aabb], order: &mut [u32]) -> Vec<Node> {
    const LEAF: usize = 4;
    let mut nodes = vec![Node { bounds: Aabb::empty(), first: 0, count: order.len() as u32 }];
    let mut stack = vec![(0usize, 0usize, order.len())];
    while let Some((id, start, end)) = stack.pop() {
        let mut b = Aabb::empty();
        let mut centres = Aabb::empty();
        for &t in &order[start..end] {
            b.grow(&boxes[t as usize]);
            let c = (boxes[t as usize].lo + boxes[t as usize].hi) * 0.5;
            centres.grow(&Aabb { lo: c, hi: c });
        }
        nodes[id].bounds = b;
        let extent = centres.hi - centres.lo;
        if end - start <= LEAF || extent.max_element() <= 0.0 {
            nodes[id].first = start as u32;
            nodes[id].count = (end - start) as u32;
            continue;
        }
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = (start + end) / 2;
        let key = |t: &u32| boxes[*t as usize].lo[axis] + boxes[*t as usize].hi[axis];
        order[start..end]
            .select_nth_unstable_by(mid - start, |a, b| key(a).total_cmp(&key(b)).then(a.cmp(b)));
        let left = nodes.len();
        nodes.push(Node { bounds: Aabb::empty(), first: 0, count: 0 });
        nodes.push(Node { bounds: Aabb::empty(), first: 0, count: 0 });
        nodes[id].first = left as u32;
        nodes[id].count = 0;
        stack.push((left, start, mid));
        stack.push((left + 1, mid, end));
    }
    nodes
}

/// Leaf items of the BVH whose node boxes overlap `b` (candidates; callers re-test).
pub(crate) fn query(nodes: &[Node], order: &[u32], b: &Aabb) -> Vec<usize> {
    let mut out = Vec::new();
    query_each(nodes, order, b, &mut Vec::new(), |o| out.push(o as usize));
    out
}

/// [`query`] without allocating: calls `f` with each candidate, in the order [`query`]
/// returns them, using `stack` as scratch (cleared first). Returns how many there were.
pub(crate) fn query_each(
    nodes: &[Node],
    order: &[u32],
    b: &Aabb,
    stack: &mut Vec<u32>,
    mut f: impl FnMut(u32),
) -> usize {
    let mut count = 0;
    stack.clear();
    if nodes.is_empty() {
        return 0;
    }
    stack.push(0);
    while let Some(n) = stack.pop() {
        let node = &nodes[n as usize];
        if !node.bounds.overlaps(b) {
            continue;
        }
        if node.count == 0 {
            stack.push(node.first);
            stack.push(node.first + 1);
        } else {
            let items = &order[node.first as usize..(node.first + node.count) as usize];
            count += items.len();
            items.iter().for_each(|&o| f(o));
        }
    }
    count
}
