//! Least-cost paths: multi-source Dijkstra over out-edges with lazily computed weights,
//! and the edge weights of the three systems (Xu2015 §3.1, §3.3.1, §4.2, §5.2.2;
//! Xu2015-spec §2.3–§2.4).
//!
//! The search keeps `dist`, `parent`, `hops` (edges from the source) and `source` (the
//! source a node's path starts at) per node. A [`Costs`] implementation is told when a
//! node is **settled** (popped with its final distance), before its out-edges are
//! relaxed, and is then asked the weight of each out-edge. That is where MGV sets a
//! node's guiding vector and hence its out-edge weights (§5.2.2): the weights are fixed
//! before they are used, so the search is exact for these self-consistent weights.
//!
//! The priority queue is a radix heap of `u64` keys `distance bits << 32 | node`:
//! non-negative `f32` distances order like their bit patterns, and ties go to the
//! smaller node id, so the settle order — and every output — is deterministic (the same
//! order as a binary heap of `(distance bits, node)` pairs; keys that fall below the
//! last pop, possible when an edge adds less than half an ulp, wait in a 4-ary side
//! heap and come out first).
//!
//! The search is bound by memory latency, so its node state is laid out and fetched
//! for that (none of it changes a value or the settle order): one 32-byte entry per
//! node holds the search values, the node's position and its first out-edge, so a
//! relaxation reads one cache line; a settled node's neighbours' entries are
//! prefetched together before they are relaxed; the radix heap announces the keys
//! it is about to pop (a bucket of ≤ 64 keys spread over lower buckets) so their
//! entries are fetched early; a [`Costs`] is told of the coming settle
//! ([`Costs::prefetch`]) before it is asked to settle; and the state array is
//! advised transparent huge pages (fewer TLB misses).

use super::graph::{prefetch, Graph, NONE};
use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// Edge weights, asked lazily by [`dijkstra`].
pub trait Costs {
    /// Called once when `u` is settled, with its parent (`NONE` for a source), its hop
    /// count and its source, before `u`'s out-edges are relaxed.
    fn settle(&mut self, _g: &Graph, _u: u32, _parent: u32, _hops: u32, _source: u32) {}
    /// Weight of the out-edge `edge` (an index into `g.targets`) from `u` to `v`; must be
    /// finite and ≥ 0.
    fn weight(&self, g: &Graph, u: u32, v: u32, edge: usize) -> f32;
    /// [`Costs::settle`] given `u`'s position `pu` (what [`dijkstra`] calls; the search
    /// keeps positions next to its node state, so an implementation that needs them can
    /// skip a lookup). Must behave exactly like `settle`, which the default calls.
    fn settle_at(&mut self, g: &Graph, u: u32, _pu: Vec3, parent: u32, hops: u32, source: u32) {
        self.settle(g, u, parent, hops, source);
    }
    /// [`Costs::weight`] given the positions `pu`, `pv` of `u` and `v` (what
    /// [`dijkstra`] calls). Must return exactly what `weight` does, which the default
    /// calls.
    fn weight_at(&self, g: &Graph, u: u32, _pu: Vec3, v: u32, _pv: Vec3, edge: usize) -> f32 {
        self.weight(g, u, v, edge)
    }
    /// Told that `u` (with this parent, `NONE` for a source) is about to be settled, so
    /// an implementation can start fetching what its [`Costs::settle_at`] will read; a
    /// hint only (the default does nothing).
    fn prefetch(&self, _u: u32, _parent: u32) {}
}

/// Euclidean edge length (MIG, Fig. 4.2 step 1H).
pub struct Length;

impl Costs for Length {
    fn weight(&self, g: &Graph, u: u32, v: u32, _edge: usize) -> f32 {
        g.position[u as usize].distance(g.position[v as usize])
    }

    fn weight_at(&self, _g: &Graph, _u: u32, pu: Vec3, _v: u32, pv: Vec3, _edge: usize) -> f32 {
        pu.distance(pv)
    }
}

/// Per-edge weights stored in an array (BCM).
pub struct Stored<'a>(pub &'a [f32]);

impl Costs for Stored<'_> {
    fn weight(&self, _g: &Graph, _u: u32, _v: u32, edge: usize) -> f32 {
        self.0[edge]
    }
}

/// The result of [`dijkstra`] (after an early stop of [`dijkstra_until`], the values
/// of nodes not in `order` are tentative).
#[derive(Debug, Clone, Default)]
pub struct Search {
    /// Least cost from the nearest source (`f32::INFINITY` when unreached).
    pub dist: Vec<f32>,
    /// Parent on the least-cost path (`NONE` for sources and unreached nodes).
    pub parent: Vec<u32>,
    /// Edges from the source (`u32::MAX` when unreached).
    pub hops: Vec<u32>,
    /// The source the path starts at (`NONE` when unreached).
    pub source: Vec<u32>,
    /// Nodes in settle order.
    pub order: Vec<u32>,
}

impl Search {
    /// True when `v` was reached.
    pub fn reached(&self, v: u32) -> bool {
        self.source[v as usize] != NONE
    }

    /// The path from `v` back to its source (`v` first).
    pub fn path(&self, v: u32) -> Vec<u32> {
        let mut p = vec![v];
        let mut u = v;
        while self.parent[u as usize] != NONE {
            u = self.parent[u as usize];
            p.push(u);
        }
        p
    }
}

/// Multi-source Dijkstra over out-edges (§3.1, Fig. 3.1): every source starts at cost 0
/// with 0 hops. `allowed`, when given, restricts the search to the flagged nodes.
pub fn dijkstra(g: &Graph, sources: &[u32], allowed: Option<&[bool]>, costs: &mut impl Costs) -> Search {
    dijkstra_until(g, sources, allowed, costs, Until::Never)
}

/// Per-node search state, packed so a relaxation touches one cache line: the search's
/// own values, the node's position (for the edge weight) and its first out-edge (so
/// `u`'s edges are `st[u].first..st[u + 1].first`, one more entry ending the last
/// node's). The top bit of `hops` marks a settled node. 32 bytes, aligned to 32, so
/// a node's state never straddles two cache lines.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct State {
    dist: f32,
    parent: u32,
    hops: u32,
    source: u32,
    pos: Vec3,
    first: u32,
}

/// The "settled" bit of [`State::hops`].
const DONE: u32 = 1 << 31;

/// When [`dijkstra_until`] may stop before the heap is empty. Every node it reports
/// as settled (in [`Search::order`]) has exactly the state — and [`Costs::settle`] was
/// called for it in exactly the order — of a full search, because an early stop only cuts
/// the same deterministic settle sequence short; nodes not settled keep tentative values.
#[derive(Debug, Clone, Copy, Default)]
pub enum Until<'a> {
    /// Run until every reachable node is settled.
    #[default]
    Never,
    /// Stop right after settling this node (`NONE`: never).
    Node(u32),
    /// Stop once every node whose final hop count is ≤ k is settled (and has relaxed its
    /// out-edges). Then a node has hop count exactly k in the result if and only if it
    /// has in a full search: a node left unsettled only ever gets paths through nodes
    /// with more than k hops, so its tentative and final hop counts both exceed k.
    Hops(u32),
    /// Stop once every flagged node is settled (a flagged node that is never reached
    /// means no early stop). With no node flagged it stops right after the first settle.
    Settled(&'a [bool]),
}

/// [`dijkstra`] that may stop early (see [`Until`]).
pub fn dijkstra_until(
    g: &Graph,
    sources: &[u32],
    allowed: Option<&[bool]>,
    costs: &mut impl Costs,
    until: Until,
) -> Search {
    let n = g.len();
    let (stop, max_hops, targets) = match until {
        Until::Never => (NONE, None, None),
        Until::Node(u) => (u, None, None),
        Until::Hops(k) => (NONE, Some(k), None),
        Until::Settled(flags) => (NONE, None, Some(flags)),
    };
    // Targets not yet settled (Until::Settled).
    let mut targets_left = targets.map_or(0, |t| t.iter().take(n).filter(|&&f| f).count());
    // Unsettled nodes whose tentative hop count is ≤ k (Until::Hops).
    let mut pending = 0usize;
    // Hop counts stay below 2³¹ (fewer than 2³¹ nodes), so they never reach DONE.
    let unreached =
        State { dist: f32::INFINITY, parent: NONE, hops: !DONE, source: NONE, pos: Vec3::ZERO, first: 0 };
    let mut st: Vec<State> = super::graph::huge_capacity(n + 1);
    st.extend(g.position.iter().zip(&g.offsets).map(|(&pos, &first)| State { pos, first, ..unreached }));
    st.push(State { first: g.offsets.get(n).copied().unwrap_or(0), ..unreached });
    let mut order = Vec::with_capacity(n);
    let mut heap = RadixHeap::new();
    for &src in sources {
        if (src as usize) < n && st[src as usize].source == NONE {
            let s = &mut st[src as usize];
            (s.dist, s.parent, s.hops, s.source) = (0.0, NONE, 0, src);
            heap.push(src as u64);
            pending += 1;
        }
    }
    let k = max_hops.unwrap_or(u32::MAX);
    // Keys spread out of a bucket are the next to pop: fetch their states meanwhile.
    while let Some(key) = heap.pop_with(|v| prefetch(&st, v as usize)) {
        let (bits, u) = ((key >> 32) as u32, key as u32);
        let ui = u as usize;
        if st[ui].hops & DONE != 0 || bits != st[ui].dist.to_bits() {
            continue;
        }
        st[ui].hops |= DONE;
        order.push(u);
        let su = st[ui];
        let hops = su.hops & !DONE;
        costs.prefetch(u, su.parent);
        // Fetch the targets' states together: their cache misses then overlap (with each
        // other and with what `settle_at` reads) instead of stalling the relaxations below
        // one by one.
        let (first, end) = (su.first as usize, st[ui + 1].first as usize);
        let out = &g.targets[first..end];
        for &v in out {
            prefetch(&st, v as usize);
        }
        costs.settle_at(g, u, su.pos, su.parent, hops, su.source);
        if u == stop {
            break;
        }
        if let Some(t) = targets {
            if t.get(ui).copied().unwrap_or(false) {
                targets_left -= 1;
            }
            if targets_left == 0 {
                break;
            }
        }
        if hops <= k {
            pending -= 1;
        }
        for (i, &v) in out.iter().enumerate() {
            let vi = v as usize;
            if st[vi].hops & DONE != 0 || allowed.is_some_and(|a| !a[vi]) {
                continue;
            }
            let w = costs.weight_at(g, u, su.pos, v, st[vi].pos, first + i).max(0.0);
            let nd = su.dist + w;
            let sv = &mut st[vi];
            if nd < sv.dist || (nd == sv.dist && u < sv.parent) {
                let was = sv.source != NONE && sv.hops <= k;
                (sv.dist, sv.parent, sv.hops, sv.source) = (nd, u, hops + 1, su.source);
                heap.push((nd.to_bits() as u64) << 32 | v as u64);
                pending = pending + usize::from(hops < k) - usize::from(was);
            }
        }
        if max_hops.is_some() && pending == 0 {
            break;
        }
    }
    let hops = |s: &State| if s.source == NONE { u32::MAX } else { s.hops & !DONE };
    st.truncate(n);
    Search {
        dist: st.iter().map(|s| s.dist).collect(),
        parent: st.iter().map(|s| s.parent).collect(),
        hops: st.iter().map(hops).collect(),
        source: st.iter().map(|s| s.source).collect(),
        order,
    }
}

/// A radix heap of `u64` keys (duplicates allowed) that pops exactly the minimum, like
/// [`QuadHeap`], but in amortised O(1) per key for Dijkstra's nearly monotone keys.
///
/// Bucket `b > 0` holds keys whose highest bit differing from `last` (the largest key
/// popped so far) is bit `b − 1`; bucket 0 holds copies of `last`. A pop from an empty
/// bucket 0 takes the lowest non-empty bucket, makes its minimum the new `last` and
/// spreads it over lower buckets. A key below `last` (Dijkstra pushes one when an edge
/// adds less than half an ulp to the distance and the target has a smaller id) is
/// smaller than every bucketed key, so it waits in the side heap `low`, popped first.
struct RadixHeap {
    last: u64,
    buckets: Vec<Vec<u64>>,
    /// Bit `b` set when bucket `b` is non-empty.
    used: u128,
    low: QuadHeap,
}

impl RadixHeap {
    fn new() -> Self {
        RadixHeap { last: 0, buckets: vec![Vec::new(); 65], used: 0, low: QuadHeap::with_capacity(0) }
    }

    #[inline]
    fn bucket(&self, key: u64) -> usize {
        (64 - (key ^ self.last).leading_zeros()) as usize
    }

    #[inline]
    fn push(&mut self, key: u64) {
        if key < self.last {
            self.low.push(key);
            return;
        }
        let b = self.bucket(key);
        self.buckets[b].push(key);
        self.used |= 1 << b;
    }

    #[cfg(test)]
    fn pop(&mut self) -> Option<u64> {
        self.pop_with(|_| {})
    }

    /// Pops the least key. When it spreads a bucket of at most [`HINTED`] keys over
    /// lower buckets (those keys pop next, before any key now in a higher bucket), it
    /// calls `soon` with each one's node (the low 32 bits).
    fn pop_with(&mut self, mut soon: impl FnMut(u32)) -> Option<u64> {
        if let Some(k) = self.low.pop() {
            return Some(k);
        }
        if self.used & 1 == 0 {
            if self.used == 0 {
                return None;
            }
            let b = self.used.trailing_zeros() as usize;
            let items = std::mem::take(&mut self.buckets[b]);
            self.used &= !(1 << b);
            self.last = items.iter().copied().min()?;
            if items.len() <= HINTED {
                items.iter().for_each(|&k| soon(k as u32));
            }
            for &k in &items {
                let t = self.bucket(k);
                self.buckets[t].push(k);
                self.used |= 1 << t;
            }
            // Keep the emptied bucket's allocation for later pushes.
            let mut items = items;
            items.clear();
            if self.buckets[b].is_empty() {
                self.buckets[b] = items;
            }
        }
        let k = self.buckets[0].pop();
        if self.buckets[0].is_empty() {
            self.used &= !1;
        }
        k
    }
}

/// The largest spread bucket whose keys [`RadixHeap::pop_with`] announces.
const HINTED: usize = 64;

/// A 4-ary min-heap of `u64` keys (duplicates allowed).
struct QuadHeap {
    keys: Vec<u64>,
}

impl QuadHeap {
    fn with_capacity(n: usize) -> Self {
        QuadHeap { keys: Vec::with_capacity(n) }
    }

    fn push(&mut self, key: u64) {
        let h = &mut self.keys;
        let mut i = h.len();
        h.push(key);
        while i > 0 {
            let p = (i - 1) / 4;
            if h[p] <= key {
                break;
            }
            h[i] = h[p];
            i = p;
        }
        h[i] = key;
    }

    fn pop(&mut self) -> Option<u64> {
        let h = &mut self.keys;
        let top = *h.first()?;
        let last = h.pop()?;
        let n = h.len();
        if n == 0 {
            return Some(top);
        }
        let mut i = 0;
        loop {
            let c = 4 * i + 1;
            if c >= n {
                break;
            }
            // Smallest of up to four children.
            let mut m = c;
            let end = (c + 4).min(n);
            for j in c + 1..end {
                if h[j] < h[m] {
                    m = j;
                }
            }
            if h[m] >= last {
                break;
            }
            h[i] = h[m];
            i = m;
        }
        h[i] = last;
        Some(top)
    }
}

/// BCM global variation (§3.3.1, Fig. 3.8): `W = 1 + v^β` per edge with `v` uniform in
/// `(lo, range)`; `lo = 0`, `range = 100` by default (Xu2015-spec §7.3).
pub fn bcm_random_weights(g: &Graph, beta: f64, lo: f64, range: f64, seed: u64) -> Vec<f32> {
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x6263_6d5f_7765_6967);
    (0..g.edge_count())
        .map(|_| {
            let v = lo + (range - lo) * rng.random::<f64>();
            (1.0 + v.powf(beta)) as f32
        })
        .collect()
}

/// BCM spatial variation (§3.3.1, Fig. 3.7): where the edge midpoint is cheap.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spatial {
    /// Horizontal distance to the left side (x = min): paths bend left.
    Left,
    /// Horizontal distance to the right side (x = max): paths bend right.
    Right,
    /// Horizontal distance to the vertical axis through the root: paths bend inward.
    Axis,
    /// Height above the bottom: paths bend down.
    Height,
}

/// Spatial-variation weights: the midpoint's distance (see [`Spatial`]) plus a floor of
/// 1 % of the graph spacing, so every weight is positive.
pub fn bcm_spatial_weights(g: &Graph, kind: Spatial) -> Vec<f32> {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in &g.position {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let root = g.position.get(g.root as usize).copied().unwrap_or(Vec3::ZERO);
    let floor = 0.01 * g.spacing.max(1e-6);
    let mut w = Vec::with_capacity(g.edge_count());
    for u in 0..g.len() as u32 {
        for &v in g.out(u) {
            let m = (g.position[u as usize] + g.position[v as usize]) / 2.0;
            let d = match kind {
                Spatial::Left => m.x - lo.x,
                Spatial::Right => hi.x - m.x,
                Spatial::Axis => ((m.x - root.x).powi(2) + (m.z - root.z).powi(2)).sqrt(),
                Spatial::Height => m.y - lo.y,
            };
            w.push(d.max(0.0) + floor);
        }
    }
    w
}

/// MGV weight (§5.2.2): `w = d_E·(1 − ê_E·v̂)` plus an optional floor `ε·d_E`, for the
/// edge vector `e` and the unit guiding vector `guide`. In `[0, 2·d_E]` (+ the floor).
#[inline]
pub fn mgv_weight(e: Vec3, guide: Vec3, epsilon: f32) -> f32 {
    let d = e.length();
    if d <= 0.0 {
        return 0.0;
    }
    // Xu2015, §5.2.2: d_E (1 − e_E · v_E)
    let c = (e.dot(guide) / d).clamp(-1.0, 1.0);
    d * (1.0 - c) + epsilon * d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grow::least_cost::graph::{poisson_yao, Primitive, Volume};

    #[test]
    fn quad_heap_pops_the_minimum() {
        let mut rng = Pcg64::seed_from_u64(5);
        let mut h = QuadHeap::with_capacity(4);
        let mut reference: Vec<u64> = Vec::new();
        for i in 0..3000 {
            let k = rng.random_range(0..500u64);
            h.push(k);
            reference.push(k);
            if i % 3 == 0 {
                let (at, _) = reference.iter().enumerate().min_by_key(|e| *e.1).unwrap();
                assert_eq!(h.pop(), Some(reference.swap_remove(at)));
            }
        }
        reference.sort_unstable();
        for want in reference {
            assert_eq!(h.pop(), Some(want));
        }
        assert_eq!(h.pop(), None);
    }

    #[test]
    fn radix_heap_announces_keys_that_pop_next() {
        let mut rng = Pcg64::seed_from_u64(3);
        let mut h = RadixHeap::new();
        let mut popped = Vec::new();
        let mut hinted = Vec::new();
        for _ in 0..500 {
            h.push(rng.random_range(0..1u64 << 40));
        }
        while let Some(k) = h.pop_with(|v| hinted.push(v)) {
            popped.push(k as u32);
        }
        assert_eq!(popped.len(), 500);
        // Every announced node is popped, at or after the pop that announced it.
        assert!(hinted.len() >= 100, "{}", hinted.len());
        assert!(hinted.iter().all(|v| popped.contains(v)));
    }

    #[test]
    fn radix_heap_pops_the_minimum_even_below_the_last_pop() {
        let mut rng = Pcg64::seed_from_u64(9);
        let mut h = RadixHeap::new();
        let mut q = QuadHeap::with_capacity(4);
        let mut last = 0u64;
        for i in 0..20_000 {
            // Mostly keys at or above the last pop (Dijkstra), sometimes just below it
            // (same distance bits, smaller id), sometimes duplicates.
            let k = match rng.random_range(0..10) {
                0 => last & !0xffff_ffff | rng.random_range(0..=(last & 0xffff_ffff)),
                1 => last,
                _ => {
                    let bits = rng.random_range(0..40);
                    last + rng.random_range(0..1u64 << bits)
                }
            };
            h.push(k);
            q.push(k);
            if i % 3 != 0 {
                let (a, b) = (h.pop(), q.pop());
                assert_eq!(a, b);
                last = last.max(a.unwrap());
            }
        }
        while let Some(b) = q.pop() {
            assert_eq!(h.pop(), Some(b));
        }
        assert_eq!(h.pop(), None);
    }

    /// Length weights through the trait's defaults only (`settle`, `weight`).
    struct PlainLength;

    impl Costs for PlainLength {
        fn weight(&self, g: &Graph, u: u32, v: u32, _edge: usize) -> f32 {
            g.position[u as usize].distance(g.position[v as usize])
        }
    }

    #[test]
    fn positions_kept_in_the_node_state_give_the_same_search() {
        assert_eq!((std::mem::size_of::<State>(), std::mem::align_of::<State>()), (32, 32));
        let v = Volume::new(vec![Primitive::Box { center: [0.0, 0.5, 0.0], size: [1.0; 3] }]);
        let g = poisson_yao(&v, 2000, None, None, 8, 3, 5).unwrap();
        let sources = [g.root, 17, 1500];
        let a = dijkstra(&g, &sources, None, &mut Length);
        let b = dijkstra(&g, &sources, None, &mut PlainLength);
        assert_eq!(a.order.len(), g.len());
        assert_eq!(a.order, b.order);
        assert_eq!(a.parent, b.parent);
        assert_eq!(a.hops, b.hops);
        assert_eq!(a.source, b.source);
        assert!(a.dist.iter().zip(&b.dist).all(|(x, y)| x.to_bits() == y.to_bits()));
        // The last node's out-edges (ended by the extra state entry) are relaxed too.
        let last = g.len() as u32 - 1;
        let c = dijkstra(&g, &[last], None, &mut Length);
        for &t in g.out(last) {
            assert_eq!(c.hops[t as usize], 1, "out-edge {last} → {t}");
        }
    }

    #[test]
    fn mgv_weight_values() {
        let up = Vec3::Y;
        assert_eq!(mgv_weight(Vec3::new(0.0, 2.0, 0.0), up, 0.0), 0.0);
        assert!((mgv_weight(Vec3::new(2.0, 0.0, 0.0), up, 0.0) - 2.0).abs() < 1e-6);
        assert!((mgv_weight(Vec3::new(0.0, -2.0, 0.0), up, 0.0) - 4.0).abs() < 1e-6);
    }

    #[test]
    fn bcm_weights_in_range() {
        let v = Volume::new(vec![Primitive::Box { center: [0.0, 0.5, 0.0], size: [1.0; 3] }]);
        let g = poisson_yao(&v, 200, None, None, 8, 3, 2).unwrap();
        let w = bcm_random_weights(&g, 0.0, 0.0, 100.0, 1);
        assert!(w.iter().all(|&x| x == 2.0));
        let w = bcm_random_weights(&g, 1.5, 0.0, 100.0, 1);
        assert!(w.iter().all(|&x| (1.0..=1.0 + 1000.0 + 1e-3).contains(&x)));
        for k in [Spatial::Left, Spatial::Right, Spatial::Axis, Spatial::Height] {
            assert!(bcm_spatial_weights(&g, k).iter().all(|&x| x > 0.0 && x.is_finite()));
        }
    }
}
