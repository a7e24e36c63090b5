//! Incremental self-intersection search over a sequence of meshes (issue 44, local and
//! incremental fitting), for the mesh clearing's rounds ([`crate::fit::clear`]): each
//! round remeshes the whole tree after thinning a few internodes, but most of the
//! surface comes back bit for bit the same.
//!
//! The first mesh is searched in full ([`self_intersections`](super::self_intersections_within)'s
//! BVH search). For each later one, every triangle is matched to the previous mesh's by
//! its corner positions (bit for bit, through a sorted hash list); a triangle counts as
//! *unchanged* when it has exactly one match, neither copy repeats another triangle, and
//! none of its corners shares its position with another vertex (then two unchanged
//! triangles share a vertex in one mesh exactly when they do in the other). A pair of
//! unchanged triangles crosses exactly when it crossed before, so only pairs with a
//! changed triangle are tested: a small BVH over the changed triangles is queried with
//! every triangle's box. The pairs are those the full search finds — the same test on
//! the same candidates (padded boxes that overlap, no shared vertex), ordered and cut at
//! the limit the same way; where the count reaches the limit the mesh is searched in full.

use super::bvh::{build_bvh, query_each, Aabb};
use super::intersect::triangles_cross;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A triangle of the search: corners and the face it was fanned from.
type Tri = ([u32; 3], u32);

/// What the last search of an [`IncrementalSearch`] looked at.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct SearchStats {
    /// Triangles of the mesh.
    pub(crate) triangles: usize,
    /// Triangles searched against the others (all of them in a full search; the changed
    /// ones in an incremental search).
    pub(crate) searched: usize,
    /// Crossing pairs carried over from the previous mesh without a test.
    pub(crate) carried: usize,
    /// Whether the search was a full one.
    pub(crate) full: bool,
}

/// The state the next search compares with.
struct Previous {
    /// Per triangle its corner positions' bits.
    keys: Vec<[u32; 9]>,
    /// `(hash of key, triangle)`, sorted.
    sorted: Vec<(u64, u32)>,
    /// Per triangle: may it be matched (unique key, corners at unique positions).
    matchable: Vec<bool>,
    /// Every crossing triangle pair, `[smaller, larger]`.
    pairs: Vec<[u32; 2]>,
}

/// Searches a sequence of meshes for crossing face pairs, each after the first only
/// where it changed (see the module docs).
#[derive(Default)]
pub(crate) struct IncrementalSearch {
    previous: Option<Previous>,
    /// What the last search looked at.
    pub(crate) stats: SearchStats,
}

fn key_of(positions: &[Vec3], t: &Tri) -> [u32; 9] {
    let mut k = [0u32; 9];
    for (c, &v) in t.0.iter().enumerate() {
        let p = positions[v as usize];
        k[3 * c..3 * c + 3].copy_from_slice(&[p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]);
    }
    k
}

fn hash_words(words: &[u32]) -> u64 {
    let mut h = 0u64;
    for &w in words {
        h = (h.rotate_left(5) ^ u64::from(w)).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    h ^ (h >> 29)
}

/// The padded box of a triangle (as the full search pads it).
fn padded_box(c: &[DVec3; 3]) -> Aabb {
    let [a, b, c] = *c;
    let pad = (a.abs().max(b.abs()).max(c.abs())).max_element() * 1e-9;
    Aabb { lo: a.min(b).min(c) - pad, hi: a.max(b).max(c) + pad }
}

impl IncrementalSearch {
    /// Crossing face pairs of the triangles `tris` (fanned faces) at `positions`: what
    /// [`self_intersections_within`](super::self_intersections_within)`(positions, tris, limit,
    /// u64::MAX)` returns.
    pub(crate) fn crossings(&mut self, positions: &[Vec3], tris: &[Tri], limit: usize) -> Vec<[usize; 2]> {
        let keys: Vec<[u32; 9]> = tris.par_iter().map(|t| key_of(positions, t)).collect();
        let mut sorted: Vec<(u64, u32)> =
            keys.par_iter().enumerate().map(|(i, k)| (hash_words(k), i as u32)).collect();
        sorted.par_sort_unstable();
        let matchable = matchable(positions, tris, &keys, &sorted);
        let corners = |t: usize| tris[t].0.map(|v| positions[v as usize].as_dvec3());
        let mut result = None;
        if let Some(prev) = &self.previous {
            // New triangle → old triangle, where unchanged.
            let mut old_of = vec![u32::MAX; tris.len()];
            let (mut i, mut j) = (0, 0);
            while i < sorted.len() && j < prev.sorted.len() {
                let (a, b) = (sorted[i], prev.sorted[j]);
                if a.0 != b.0 {
                    if a.0 < b.0 {
                        i += 1;
                    } else {
                        j += 1;
                    }
                    continue;
                }
                // One hash on both sides: every new triangle with it against every old one.
                let ie = i + sorted[i..].iter().take_while(|x| x.0 == a.0).count();
                let je = j + prev.sorted[j..].iter().take_while(|x| x.0 == a.0).count();
                for &(_, t) in &sorted[i..ie] {
                    if !matchable[t as usize] {
                        continue;
                    }
                    for &(_, o) in &prev.sorted[j..je] {
                        if prev.matchable[o as usize] && prev.keys[o as usize] == keys[t as usize] {
                            old_of[t as usize] = o;
                        }
                    }
                }
                (i, j) = (ie, je);
            }
            let mut new_of = vec![u32::MAX; prev.keys.len()];
            for (t, &o) in old_of.iter().enumerate() {
                if o != u32::MAX {
                    new_of[o as usize] = t as u32;
                }
            }
            let carried: Vec<[u32; 2]> = prev
                .pairs
                .iter()
                .filter_map(|&[a, b]| {
                    let (x, y) = (new_of[a as usize], new_of[b as usize]);
                    (x != u32::MAX && y != u32::MAX).then(|| [x.min(y), x.max(y)])
                })
                .collect();
            let changed: Vec<u32> =
                (0..tris.len() as u32).filter(|&t| old_of[t as usize] == u32::MAX).collect();
            let fresh = changed_pairs(tris, &corners, &changed);
            self.stats = SearchStats {
                triangles: tris.len(),
                searched: changed.len(),
                carried: carried.len(),
                full: false,
            };
            let mut pairs = carried;
            pairs.extend(fresh);
            // At the limit the full search keeps only a prefix: search in full then.
            if pairs.len() < limit {
                pairs.sort_unstable();
                result = Some(pairs);
            }
        }
        let pairs = match result {
            Some(p) => p,
            None => {
                let (pairs, complete) = full_pairs(tris, &corners, limit);
                self.stats =
                    SearchStats { triangles: tris.len(), searched: tris.len(), carried: 0, full: true };
                if !complete {
                    // Only a prefix is known: the next mesh is searched in full too.
                    self.previous = None;
                    return face_pairs(tris, &pairs, limit);
                }
                pairs
            }
        };
        let out = face_pairs(tris, &pairs, limit);
        self.previous = Some(Previous { keys, sorted, matchable, pairs });
        out
    }
}

/// Which triangles may be matched: a key no other triangle has, and corners at positions
/// no other vertex has.
fn matchable(positions: &[Vec3], tris: &[Tri], keys: &[[u32; 9]], sorted: &[(u64, u32)]) -> Vec<bool> {
    let mut ok = vec![true; tris.len()];
    // Repeated keys.
    for run in sorted.chunk_by(|a, b| a.0 == b.0).filter(|r| r.len() > 1) {
        for (x, &(_, a)) in run.iter().enumerate() {
            if run[x + 1..].iter().any(|&(_, b)| keys[a as usize] == keys[b as usize]) {
                ok[a as usize] = false;
                run[x + 1..].iter().filter(|&&(_, b)| keys[a as usize] == keys[b as usize]).for_each(
                    |&(_, b)| {
                        ok[b as usize] = false;
                    },
                );
            }
        }
    }
    // Vertices sharing a position.
    let mut by_position: Vec<(u64, u32)> = positions
        .par_iter()
        .enumerate()
        .map(|(v, p)| (hash_words(&[p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]), v as u32))
        .collect();
    by_position.par_sort_unstable();
    let mut shared = vec![false; positions.len()];
    let bits = |v: u32| positions[v as usize].to_array().map(f32::to_bits);
    for run in by_position.chunk_by(|a, b| a.0 == b.0).filter(|r| r.len() > 1) {
        for (x, &(_, a)) in run.iter().enumerate() {
            for &(_, b) in &run[x + 1..] {
                if bits(a) == bits(b) {
                    shared[a as usize] = true;
                    shared[b as usize] = true;
                }
            }
        }
    }
    for (t, tri) in tris.iter().enumerate() {
        if tri.0.iter().any(|&v| shared[v as usize]) {
            ok[t] = false;
        }
    }
    ok
}

/// The crossing pair test of the full search for triangles `a < b`.
fn crossing(
    tris: &[Tri],
    corners: &impl Fn(usize) -> [DVec3; 3],
    boxes: (&Aabb, &Aabb),
    a: usize,
    b: usize,
) -> bool {
    boxes.0.overlaps(boxes.1)
        && !tris[b].0.iter().any(|v| tris[a].0.contains(v))
        && triangles_cross(&corners(a), &corners(b))
}

/// Every crossing pair with a triangle of `changed` (ascending), `[smaller, larger]`,
/// unsorted: a BVH over the changed triangles, queried with every triangle's box.
fn changed_pairs(
    tris: &[Tri],
    corners: &(impl Fn(usize) -> [DVec3; 3] + Sync),
    changed: &[u32],
) -> Vec<[u32; 2]> {
    if changed.is_empty() {
        return Vec::new();
    }
    let mut boxes = vec![Aabb::EMPTY; tris.len()];
    for &c in changed {
        boxes[c as usize] = padded_box(&corners(c as usize));
    }
    let mut order = changed.to_vec();
    let nodes = build_bvh(&boxes, &mut order);
    let is_changed = {
        let mut v = vec![false; tris.len()];
        changed.iter().for_each(|&c| v[c as usize] = true);
        v
    };
    (0..tris.len())
        .into_par_iter()
        .with_min_len(4096)
        .map_init(Vec::new, |stack, t| {
            let mut found = Vec::new();
            let tb = if is_changed[t] { boxes[t] } else { padded_box(&corners(t)) };
            if !nodes[0].bounds.overlaps(&tb) {
                return found;
            }
            query_each(&nodes, &order, &tb, stack, |o| {
                let o = o as usize;
                // A changed–changed pair is tested from its smaller triangle.
                if o == t || (is_changed[t] && o < t) {
                    return;
                }
                let (a, b) = (t.min(o), t.max(o));
                let (ba, bb) = if a == t { (&tb, &boxes[o]) } else { (&boxes[o], &tb) };
                if crossing(tris, corners, (ba, bb), a, b) {
                    found.push([a as u32, b as u32]);
                }
            });
            found
        })
        .flatten_iter()
        .collect()
}

/// The full search (as [`self_intersections`](super::self_intersections_within) runs it): every
/// crossing pair, `[smaller, larger]`, sorted, and whether it is complete (`false`: it
/// stopped at `limit` pairs after a prefix of the faces).
fn full_pairs(
    tris: &[Tri],
    corners: &(impl Fn(usize) -> [DVec3; 3] + Sync),
    limit: usize,
) -> (Vec<[u32; 2]>, bool) {
    let boxes: Vec<Aabb> = (0..tris.len()).into_par_iter().map(|t| padded_box(&corners(t))).collect();
    let mut order: Vec<u32> = (0..tris.len() as u32).collect();
    let nodes = build_bvh(&boxes, &mut order);
    let n = tris.len();
    let mut pairs = Vec::new();
    let mut start = 0;
    while start < n {
        // Parts end between faces, so a stop keeps every pair of the faces searched.
        let mut end = (start + (1 << 14)).min(n);
        while end < n && tris[end].1 == tris[end - 1].1 {
            end += 1;
        }
        let part: Vec<[u32; 2]> = (start..end)
            .into_par_iter()
            .map_init(Vec::new, |stack, t| {
                let mut found = Vec::new();
                query_each(&nodes, &order, &boxes[t], stack, |o| {
                    let o = o as usize;
                    if o > t && crossing(tris, corners, (&boxes[t], &boxes[o]), t, o) {
                        found.push([t as u32, o as u32]);
                    }
                });
                found
            })
            .flatten_iter()
            .collect();
        pairs.extend(part);
        start = end;
        if pairs.len() >= limit && start < n {
            pairs.sort_unstable();
            return (pairs, false);
        }
    }
    pairs.sort_unstable();
    (pairs, true)
}

/// Triangle pairs as face pairs, sorted and cut at `limit` (as the full search returns
/// them).
fn face_pairs(tris: &[Tri], pairs: &[[u32; 2]], limit: usize) -> Vec<[usize; 2]> {
    let mut out: Vec<[usize; 2]> =
        pairs.iter().map(|&[a, b]| [tris[a as usize].1 as usize, tris[b as usize].1 as usize]).collect();
    out.sort_unstable();
    out.truncate(limit);
    out
}

#[cfg(test)]
mod tests {
    use super::super::intersect::self_intersections;
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A soup of `n` small triangles in a unit box, some sharing vertices.
    fn soup(rng: &mut rand_pcg::Pcg64, n: usize) -> (Vec<Vec3>, Vec<Tri>) {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for f in 0..n as u32 {
            let c = Vec3::new(rng.random(), rng.random(), rng.random());
            let base = p.len() as u32;
            for _ in 0..3 {
                p.push(c + Vec3::new(rng.random(), rng.random(), rng.random()) * 0.15);
            }
            // Every fifth triangle reuses a corner of the one before (a shared vertex).
            let first = if f % 5 == 4 { base - 1 } else { base };
            t.push(([first, base + 1, base + 2], f / 2));
        }
        (p, t)
    }

    #[test]
    fn every_round_equals_the_full_search_and_searches_only_what_changed() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(44);
        for case in 0..12 {
            let (mut p, t) = soup(&mut rng, 400);
            let mut search = IncrementalSearch::default();
            for round in 0..5 {
                let limit = if case % 4 == 3 { 40 } else { usize::MAX };
                let got = search.crossings(&p, &t, limit);
                assert_eq!(got, self_intersections(&p, &t, limit), "case {case} round {round}");
                assert_eq!(search.stats.triangles, t.len());
                if round == 0 {
                    assert!(search.stats.full);
                }
                // Move a few vertices (and, in some cases, make two vertices coincide).
                let moved: Vec<usize> = (0..6).map(|_| rng.random_range(0..p.len())).collect();
                for &v in &moved {
                    p[v] += Vec3::new(rng.random(), rng.random(), rng.random()) * 0.05;
                }
                if case % 3 == 1 {
                    p[moved[1]] = p[moved[0]];
                }
                let touched = t.iter().filter(|x| x.0.iter().any(|v| moved.contains(&(*v as usize)))).count();
                let got = search.crossings(&p, &t, limit);
                assert_eq!(got, self_intersections(&p, &t, limit), "case {case} round {round}, moved");
                if !search.stats.full {
                    // The triangles searched: those moved, plus any at coincident corners.
                    assert!(
                        search.stats.searched >= touched
                            && search.stats.searched <= touched + 8 * (round + 1),
                        "{:?}",
                        search.stats
                    );
                }
            }
        }
    }

    #[test]
    fn an_unchanged_mesh_is_not_searched_again_and_a_renumbered_one_matches() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let (p, t) = soup(&mut rng, 2000);
        let mut search = IncrementalSearch::default();
        let first = search.crossings(&p, &t, usize::MAX);
        assert!(!first.is_empty(), "the soup should cross");
        assert_eq!(search.crossings(&p, &t, usize::MAX), first);
        assert_eq!((search.stats.searched, search.stats.full), (0, false));
        assert_eq!(search.stats.carried, first.len());
        // The same triangles in another order, with vertices renumbered: all carried.
        let mut t2: Vec<Tri> =
            t.iter().rev().map(|&(c, f)| (c.map(|v| p.len() as u32 - 1 - v), 3000 - f)).collect();
        t2.sort_by_key(|x| x.1);
        let p2: Vec<Vec3> = p.iter().rev().copied().collect();
        assert_eq!(search.crossings(&p2, &t2, usize::MAX), self_intersections(&p2, &t2, usize::MAX));
        assert_eq!(search.stats.searched, 0);
    }
}
