//! Degenerate skeleton geometry (issue 39): zero-length and reversing internodes, radii
//! absurd against the skeleton's size, and a bounded count of overlapping internode
//! capsules, found before the collision searches of [`super::decollide`],
//! [`super::clear`] and the junction meshers (Pieterse2012 §2.1 and Skjermo2008 §2.1 assume a
//! collision-free skeleton) so a pile of coincident nodes fails with a message instead
//! of running for minutes. Lives here, not in `skeleton`, because it uses the mesh
//! checker's BVH.

use crate::mesh::check::{build_bvh, query, Aabb};
use crate::skeleton::{Degeneracy, Skeleton, NO_PARENT};

/// Finds the skeleton's degenerate geometry ([`Degeneracy`]): one linear pass, plus,
/// when `pair_limit` > 0, a count of the internode pairs whose capsule boxes (padded
/// by the larger end radius) overlap, which stops once it is over `pair_limit` (so
/// its cost is bounded by the limit and the node count, not by the pairs).
pub fn degeneracy(skel: &Skeleton, pair_limit: u64) -> Degeneracy {
    let n = skel.len();
    let mut d = Degeneracy::default();
    if n == 0 {
        return d;
    }
    let (mut lo, mut hi) = (skel.position[0], skel.position[0]);
    for i in 0..n {
        lo = lo.min(skel.position[i]);
        hi = hi.max(skel.position[i]);
        if d.max_radius.is_none_or(|(_, r)| skel.radius[i] > r) {
            d.max_radius = Some((i as u32, skel.radius[i]));
        }
        let p = skel.parent[i];
        if p == NO_PARENT {
            continue;
        }
        d.internodes += 1;
        let (a, b) = (skel.position[p as usize].as_dvec3(), skel.position[i].as_dvec3());
        let v = b - a;
        let tiny = 1e-6 * a.abs().max_element().max(b.abs().max_element()) + 1e-12;
        if v.length() <= tiny {
            d.zero_length += 1;
            d.first_zero_length.get_or_insert(i as u32);
            continue;
        }
        let g = skel.parent[p as usize];
        if g != NO_PARENT {
            let u = a - skel.position[g as usize].as_dvec3();
            let (lu, lv) = (u.length(), v.length());
            if lu > tiny && u.dot(v) < -0.999 * lu * lv {
                d.reversing += 1;
                d.first_reversing.get_or_insert(i as u32);
            }
        }
    }
    d.size = hi.as_dvec3().distance(lo.as_dvec3());
    if pair_limit == 0 || d.internodes < 2 {
        return d;
    }
    let seg: Vec<usize> = (0..n).filter(|&i| skel.parent[i] != NO_PARENT).collect();
    let boxes: Vec<Aabb> = seg
        .iter()
        .map(|&i| {
            let p = skel.parent[i] as usize;
            let r = skel.radius[i].max(skel.radius[p]) as f64;
            let (a, b) = (skel.position[p].as_dvec3(), skel.position[i].as_dvec3());
            Aabb { lo: a.min(b) - r, hi: a.max(b) + r }
        })
        .collect();
    let mut order: Vec<u32> = (0..seg.len() as u32).collect();
    let nodes = build_bvh(&boxes, &mut order);
    for (k, b) in boxes.iter().enumerate() {
        let mine =
            query(&nodes, &order, b).into_iter().filter(|&o| o > k && boxes[o].overlaps(b)).count() as u64;
        d.pairs += mine;
        if d.busiest.is_none_or(|(_, m)| mine > m) {
            d.busiest = Some((seg[k] as u32, mine));
        }
        if d.pairs > pair_limit {
            break;
        }
    }
    d
}
