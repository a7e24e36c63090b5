//! Self-intersections: pairs of faces (or face groups) whose triangles cross, searched
//! in parallel under a work budget, and the triangle–triangle test.

use super::bvh::{build_bvh, query_each, Aabb};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Pairs of faces whose triangles cross (each pair once, smaller triangle index first),
/// with no work budget (the tests' reference; the mesh clearing runs the same search
/// through [`super::IncrementalSearch`]).
#[cfg(test)]
pub(crate) fn self_intersections(
    positions: &[Vec3],
    tris: &[([u32; 3], u32)],
    limit: usize,
) -> Vec<[usize; 2]> {
    self_intersections_within(positions, tris, limit, u64::MAX).pairs
}

/// What [`self_intersections_within`] found.
pub(crate) struct Search {
    /// Crossing face pairs, ascending, at most the limit.
    pub(crate) pairs: Vec<[usize; 2]>,
    /// Candidate pairs looked at: every triangle its box query returned.
    pub(crate) work: u64,
    /// The search stopped over `max_work` before every triangle was searched.
    pub(crate) stopped: bool,
}

/// Most triangles in one part of the search.
const SEARCH_PART_MAX: usize = 1 << 14;

/// Fewest triangles in one part of the search (and the first part's size): the search
/// stops at most this many triangles' candidates past its budget.
const SEARCH_PART_MIN: usize = 64;

/// About this many candidate pairs per part of the search (parts are sized from the work
/// per triangle so far, so a part costs about the same on any input).
const SEARCH_PART_WORK: u64 = 1 << 21;

/// [`self_intersections`] with a work budget: one unit per candidate pair a triangle's
/// box query returns (where many triangles overlap, as on coincident or tangled
/// geometry, nearly every pair is a candidate and the search is quadratic). The search
/// runs through the triangles in order, in parts sized from the work per triangle so far,
/// each part in parallel, and stops after the part that takes the total over `max_work`
/// — so where it stops, and what it found, depends on the input alone, not on the
/// thread count or the machine.
pub(crate) fn self_intersections_within(
    positions: &[Vec3],
    tris: &[([u32; 3], u32)],
    limit: usize,
    max_work: u64,
) -> Search {
    if tris.is_empty() {
        return Search { pairs: Vec::new(), work: 0, stopped: false };
    }
    // Corners and padded boxes, once per triangle, in triangle order (the candidate loop
    // reads them for every pair; f32 corners keep the memory down, widened exactly).
    let corners: Vec<[Vec3; 3]> = tris.par_iter().map(|t| t.0.map(|v| positions[v as usize])).collect();
    let wide = |t: usize| corners[t].map(|p| p.as_dvec3());
    let boxes: Vec<Aabb> = (0..tris.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = wide(t);
            // Pad by a relative epsilon so touching boxes are still visited.
            let pad = (a.abs().max(b.abs()).max(c.abs())).max_element() * 1e-9;
            Aabb { lo: a.min(b).min(c) - pad, hi: a.max(b).max(c) + pad }
        })
        .collect();
    let mut order: Vec<u32> = (0..tris.len() as u32).collect();
    let nodes = build_bvh(&boxes, &mut order);
    // Triangles are searched in order, in parts, each part in parallel; the search
    // stops after the part that reaches the limit or uses up the work budget. Which
    // triangles were searched is then the same on every run and for any number of
    // threads (a flag checked inside the workers made a truncated result depend on
    // thread timing). Parts end between faces, and every pair found in a later part has
    // a larger first face, so stopping at the limit after any part keeps the same
    // (sorted, truncated) pairs as searching on would.
    let n = tris.len();
    let mut pairs: Vec<[usize; 2]> = Vec::new();
    let (mut work, mut stopped) = (0u64, false);
    // The first part is small: on coincident geometry one triangle's query returns
    // nearly all of them.
    let (mut start, mut part) = (0usize, SEARCH_PART_MIN);
    while start < n {
        let mut end = (start + part).min(n);
        while end < n && tris[end].1 == tris[end - 1].1 {
            end += 1;
        }
        let found: Vec<(u64, Vec<[usize; 2]>)> = (start..end)
            .into_par_iter()
            .map_init(Vec::new, |stack, t| {
                let mut found = Vec::new();
                let (tv, tb, tp) = (tris[t].0, boxes[t], wide(t));
                let candidates = query_each(&nodes, &order, &tb, stack, |o| {
                    let o = o as usize;
                    if o <= t || !boxes[o].overlaps(&tb) || tris[o].0.iter().any(|v| tv.contains(v)) {
                        return;
                    }
                    if triangles_cross(&tp, &wide(o)) {
                        found.push([tris[t].1 as usize, tris[o].1 as usize]);
                    }
                });
                (candidates as u64, found)
            })
            .collect();
        let part_work: u64 = found.iter().map(|f| f.0).sum();
        work = work.saturating_add(part_work);
        pairs.extend(found.into_iter().flat_map(|f| f.1));
        let searched = end - start;
        start = end;
        if pairs.len() >= limit {
            break;
        }
        if work > max_work && start < n {
            stopped = true;
            break;
        }
        let per_triangle = (part_work / searched as u64).max(1);
        part = usize::try_from(SEARCH_PART_WORK / per_triangle)
            .unwrap_or(usize::MAX)
            .clamp(SEARCH_PART_MIN, SEARCH_PART_MAX);
    }
    pairs.sort_unstable();
    // A truncated count is a lower bound; below the limit the result is exact.
    pairs.truncate(limit);
    Search { pairs, work, stopped }
}

/// Crossing triangle pairs *within* groups, for the meshers' repair loops: `tris` holds
/// `(group, corners, face)`; each group's triangles are searched among themselves by
/// sweep and prune along the group's longest extent (a junction has a few hundred to a
/// few thousand refined triangles; this measured 5× faster than a BVH per group and far
/// cheaper than one over the whole mesh), triangles sharing a vertex are skipped as in
/// [`check_mesh`]. Returns `(group, face, face)` with at most `per_group` pairs per
/// group, groups ascending; parallel over groups.
pub(crate) fn group_crossings(
    positions: &[Vec3],
    tris: Vec<(u32, [u32; 3], u32)>,
    per_group: usize,
) -> Vec<(u32, u32, u32)> {
    group_crossings_within(positions, tris, per_group, u64::MAX).map(|(found, _)| found).unwrap_or_default()
}

/// A crossing pair of [`group_crossings`]: `(group, face, face)`.
pub(crate) type GroupPair = (u32, u32, u32);

/// Work units of [`group_crossings_within`] spent between two looks at the shared count.
const GROUP_WORK_CHUNK: u64 = 1 << 16;

/// [`group_crossings`] with a work budget (issue 27): one unit per triangle of a group
/// and per candidate pair the sweep looks at (the sweep is quadratic where many of a
/// group's triangles overlap along its axis). Returns the pairs and the work spent, or
/// `None` when the search needs more than `max_work` units (it stops soon after, so a
/// pathological group cannot run for minutes). Which it is does not depend on the
/// thread count: every group's work is fixed, and the search stops only once the sum
/// is over the budget.
///
/// While a [`memo::scope`](super::memo::scope) is open, a group whose key (its
/// triangles' corners, shared vertices and `per_group`) was searched before in the
/// scope takes the remembered pairs and work instead (issue 44: the mesh clearing's
/// rounds remesh the whole tree but change only a few junctions).
pub(crate) fn group_crossings_within(
    positions: &[Vec3],
    mut tris: Vec<(u32, [u32; 3], u32)>,
    per_group: usize,
    max_work: u64,
) -> Option<(Vec<GroupPair>, u64)> {
    use super::memo::{self, Entry};
    use std::collections::HashMap;
    use std::sync::atomic::{AtomicU64, Ordering};
    let spent = AtomicU64::new(0);
    // Adds `n` units; false once the total is over the budget.
    let charge = |n: u64| spent.fetch_add(n, Ordering::Relaxed).saturating_add(n) <= max_work;
    tris.sort_unstable_by_key(|t| (t.0, t.2));
    let groups: Vec<&[(u32, [u32; 3], u32)]> = tris.chunk_by(|a, b| a.0 == b.0).collect();
    let memo = memo::take();
    // Per group: its pairs, and (when searched in full under a memo) the entry to keep.
    type Found = (Vec<GroupPair>, Option<(u128, Entry)>);
    let found: Vec<Found> = groups
        .into_par_iter()
        .map_init(HashMap::new, |ids, g| {
            let faces = |pairs: &[(u32, u32)]| -> Vec<GroupPair> {
                pairs
                    .iter()
                    .map(|&(a, b)| {
                        let (fa, fb) = (g[a as usize].2, g[b as usize].2);
                        (g[0].0, fa.min(fb), fa.max(fb))
                    })
                    .collect()
            };
            let key = memo.as_ref().map(|_| group_key(positions, g, per_group, ids));
            if let (Some(m), Some(k)) = (&memo, key) {
                if let Some(e) = m.groups.get(&k) {
                    charge(e.work);
                    return (faces(&e.pairs), None);
                }
            }
            let (pairs, work) = search_group(positions, g, per_group, &charge);
            let found = faces(&pairs);
            (found, key.zip(work).map(|(k, work)| (k, Entry { pairs, work })))
        })
        .collect();
    if let Some(mut m) = memo {
        let searched = found.iter().filter(|f| f.1.is_some()).count() as u64;
        m.misses += searched;
        m.hits += (found.len() as u64).saturating_sub(searched);
        m.groups.extend(found.iter().filter_map(|f| f.1.clone()));
        memo::restore(m);
    }
    let spent = spent.into_inner();
    if spent > max_work {
        return None;
    }
    let mut out: Vec<GroupPair> = found.into_iter().flat_map(|f| f.0).collect();
    out.sort_unstable();
    Some((out, spent))
}

/// The memo key of group `g` (see [`super::memo`]): `per_group`, the triangle count,
/// and per triangle its corners' positions (bits) and vertices numbered by first use in
/// the group (`ids` is scratch).
fn group_key(
    positions: &[Vec3],
    g: &[(u32, [u32; 3], u32)],
    per_group: usize,
    ids: &mut std::collections::HashMap<u32, u32>,
) -> u128 {
    let mut k = super::memo::Key::new();
    k.write(per_group as u64);
    k.write(g.len() as u64);
    ids.clear();
    for t in g {
        for v in t.1 {
            let next = ids.len() as u32;
            let id = *ids.entry(v).or_insert(next);
            let p = positions[v as usize];
            k.write(u64::from(p.x.to_bits()) | (u64::from(p.y.to_bits()) << 32));
            k.write(u64::from(p.z.to_bits()) | (u64::from(id) << 32));
        }
    }
    k.finish()
}

/// Searches one group of [`group_crossings_within`] by sweep and prune along its longest
/// extent (a stable sort: ties keep the group's order), charging its work through
/// `charge` (the group's triangles first, then the candidate pairs in chunks). Returns
/// the pairs as positions in `g` (in the order found, at most `per_group`) and the work
/// spent, `None` for the work when `charge` refused (over the budget: the result is then
/// discarded).
fn search_group(
    positions: &[Vec3],
    g: &[(u32, [u32; 3], u32)],
    per_group: usize,
    charge: &(impl Fn(u64) -> bool + Sync),
) -> (Vec<(u32, u32)>, Option<u64>) {
    if !charge(g.len() as u64) {
        return (Vec::new(), None);
    }
    let tri: Vec<[DVec3; 3]> = g.iter().map(|t| t.1.map(|v| positions[v as usize].as_dvec3())).collect();
    let bx: Vec<Aabb> =
        tri.iter().map(|[a, b, c]| Aabb { lo: a.min(*b).min(*c), hi: a.max(*b).max(*c) }).collect();
    let mut all = Aabb::EMPTY;
    bx.iter().for_each(|b| all.grow(b));
    let ax = (all.hi - all.lo).max_position();
    let mut order: Vec<usize> = (0..g.len()).collect();
    order.sort_by(|&a, &b| bx[a].lo[ax].total_cmp(&bx[b].lo[ax]));
    sweep_group(g, &tri, &bx, ax, &order, per_group, charge)
}

/// The sweep of [`search_group`] over the triangles in `order` (boxes `bx`, axis `ax`),
/// on the boxes laid out in sweep order.
fn sweep_group(
    g: &[(u32, [u32; 3], u32)],
    tri: &[[DVec3; 3]],
    bx: &[Aabb],
    ax: usize,
    order: &[usize],
    per_group: usize,
    charge: &(impl Fn(u64) -> bool + Sync),
) -> (Vec<(u32, u32)>, Option<u64>) {
    let sorted: Vec<Aabb> = order.iter().map(|&a| bx[a]).collect();
    let lo: Vec<f64> = sorted.iter().map(|b| b.lo[ax]).collect();
    let mut found = Vec::new();
    let (mut local, mut total) = (0u64, g.len() as u64);
    'all: for (i, &a) in order.iter().enumerate() {
        let (ha, ba) = (sorted[i].hi[ax], &sorted[i]);
        for (k, &b) in order.iter().enumerate().skip(i + 1) {
            if lo[k] > ha {
                break;
            }
            local += 1;
            if local == GROUP_WORK_CHUNK {
                total += local;
                local = 0;
                if !charge(GROUP_WORK_CHUNK) {
                    return (found, None);
                }
            }
            if ba.overlaps(&sorted[k])
                && !g[a].1.iter().any(|v| g[b].1.contains(v))
                && triangles_cross(&tri[a], &tri[b])
            {
                found.push((a as u32, b as u32));
                if found.len() >= per_group {
                    break 'all;
                }
            }
        }
    }
    total += local;
    let ok = charge(local);
    (found, ok.then_some(total))
}

/// True when an edge of either triangle passes through the other's interior (the
/// checker's intersection test; triangles sharing a vertex should be skipped by the
/// caller).
pub(crate) fn triangles_cross(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    // Early out: one triangle strictly on one side of the other's plane cannot touch it.
    if off_plane(a, b) || off_plane(b, a) {
        return false;
    }
    (0..3).any(|i| segment_hits(a[i], a[(i + 1) % 3], b))
        || (0..3).any(|i| segment_hits(b[i], b[(i + 1) % 3], a))
}

/// True when `b` lies strictly on one side of the plane of `a`.
fn off_plane(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let n = (a[1] - a[0]).cross(a[2] - a[0]);
    let d = b.map(|p| n.dot(p - a[0]));
    (d[0] > 0.0 && d[1] > 0.0 && d[2] > 0.0) || (d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0)
}

/// Segment p→q against triangle t (Möller–Trumbore, both ends inclusive, parallel misses).
fn segment_hits(p: DVec3, q: DVec3, t: &[DVec3; 3]) -> bool {
    let d = q - p;
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let h = d.cross(e2);
    let det = e1.dot(h);
    let scale = e1.length() * e2.length() * d.length();
    if det.abs() <= 1e-12 * scale {
        return false;
    }
    let inv = 1.0 / det;
    let s = p - t[0];
    let u = s.dot(h) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let qv = s.cross(e1);
    let v = d.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let s_param = e2.dot(qv) * inv;
    (0.0..=1.0).contains(&s_param)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn the_group_search_finds_every_crossing_pair_and_stops_at_the_limit() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let mut crossed = 0;
        for case in 0..30 {
            let n = rng.random_range(2..300usize);
            let mut p = Vec::new();
            for _ in 0..n {
                let c = Vec3::new(rng.random::<f32>() * 4.0, rng.random(), rng.random());
                p.push(c);
                p.push(c + Vec3::new(rng.random(), rng.random(), rng.random()) * 0.3);
                p.push(c + Vec3::new(rng.random(), rng.random(), rng.random()) * 0.3);
            }
            // Every fourth triangle shares a vertex with the one before.
            let g: Vec<(u32, [u32; 3], u32)> = (0..n as u32)
                .map(|t| (9, [if t % 4 == 3 { 3 * t - 1 } else { 3 * t }, 3 * t + 1, 3 * t + 2], t))
                .collect();
            let corners = |t: usize| g[t].1.map(|v| p[v as usize].as_dvec3());
            let mut want = Vec::new();
            for a in 0..n {
                for b in a + 1..n {
                    let share = g[a].1.iter().any(|v| g[b].1.contains(v));
                    if !share && triangles_cross(&corners(a), &corners(b)) {
                        want.push((9, a as u32, b as u32));
                    }
                }
            }
            let free = |_: u64| true;
            let mut all = search_group(&p, &g, usize::MAX, &free).0;
            all.iter_mut().for_each(|x| *x = (x.0.min(x.1), x.0.max(x.1)));
            all.sort_unstable();
            let all: Vec<_> = all.into_iter().map(|(a, b)| (9, a, b)).collect();
            assert_eq!(all, want, "case {case}");
            let limited = group_crossings(&p, g.clone(), 2);
            assert_eq!(limited.len(), want.len().min(2), "case {case}");
            assert!(limited.iter().all(|x| want.contains(x)), "case {case}");
            crossed += usize::from(want.len() > 2);
        }
        assert!(crossed > 5, "the triangles should cross often: {crossed}");
    }
}
