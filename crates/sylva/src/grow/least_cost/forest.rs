//! Multi-root forests on one graph (issue 7; Xu2015 §3.1's multi-source Dijkstra,
//! Xu2015-spec §2.4): `generator.roots = [[x, y, z], …]` grows several trees in one graph
//! whose least-cost paths compete.
//!
//! - **Graph.** The Poisson nodes are thrown with the first root as a node (as for a
//!   single `root`); every other root then replaces the nodes closer to it than the
//!   spacing `d`, so all nodes stay at least `d` apart and each root is a graph node
//!   (roots closer than `d` to each other are an error). The Yao graph is built over
//!   the result as usual ([`poisson_yao_roots`]).
//! - **MGV** ([`super::mgv::grow`], [`super::mgv::MgvState::with_roots`]): every root starts in the tree with the guide `up`, so each
//!   iteration's Dijkstra runs from all current trees at once and every endpoint's path
//!   starts at the tree node — hence the tree — that reaches it cheapest. Rules that
//!   refer to "the root" (`eq52`, `height`, the direct fields) use the first root.
//! - **MIG level 1** (`mig_level1`): Dijkstra runs from all roots with length weights,
//!   so every level-1 endpoint joins the nearest root by path length; `v_g` of its
//!   level-2 subgraph points away from that root. Later levels are unchanged.
//!
//! The result is one [`PathTree`] with one root node per tree; roots that won no
//! endpoint are dropped with a warning ([`drop_lone_roots`]), so the skeleton has
//! exactly one root per grown tree (`report.trees`).

use super::graph::{poisson, resolve_spacing, spatial_sort, yao, Graph, NONE};
use super::{bad, finite, level1_search, shuffle, End, LeastCostParams, LeastCostReport, PathTree};
use crate::error::Result;
use glam::DVec3;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use std::path::Path;

/// Most roots in one forest.
pub const MAX_ROOTS: usize = 256;

/// Checks `generator.roots` (also when empty: nothing to check).
pub fn validate(p: &LeastCostParams) -> Result<()> {
    if p.roots.is_empty() {
        return Ok(());
    }
    if p.roots.len() > MAX_ROOTS {
        return bad("roots", format!("has {} roots; at most {MAX_ROOTS}", p.roots.len()));
    }
    if p.method == super::Method::Bcm {
        return bad("roots", "needs method = \"mgv\" or \"mig\" (BCM grows one tree)");
    }
    if p.root.is_some() {
        return bad("roots", "and `generator.root` exclude each other: list every root in `roots`");
    }
    if p.refine.is_some() {
        return bad("roots", "cannot be combined with `generator.refine` (refinement cones join one root)");
    }
    for (i, r) in p.roots.iter().enumerate() {
        for &v in r {
            finite(&format!("roots[{i}]"), v)?;
        }
        if p.dims == 2 && r[2] != 0.0 {
            return bad(
                &format!("roots[{i}]"),
                format!("must lie in the z = 0 plane with dims = 2, got z = {}", r[2]),
            );
        }
    }
    Ok(())
}

/// The roots as points.
fn root_points(p: &LeastCostParams) -> Vec<DVec3> {
    p.roots.iter().map(|&r| DVec3::from_array(r)).collect()
}

/// The Poisson–Yao graph of `p.volume` with every root of `p.roots` as a node (see the
/// module docs); the graph's `root` is the first root. `spacing = None` picks it from
/// the volume as for one root.
pub fn poisson_yao_roots(p: &LeastCostParams, spacing: Option<f64>, seed: u64) -> Result<Graph> {
    let roots = root_points(p);
    let volume = p.graph_volume();
    let dims = p.dims;
    super::graph::check_sectors(p.sectors, dims)?;
    let d = resolve_spacing(&volume, p.nodes, spacing, dims, seed)?;
    for i in 0..roots.len() {
        for j in i + 1..roots.len() {
            let dist = roots[i].distance(roots[j]);
            if dist < d {
                return bad(
                    "roots",
                    format!(
                        "roots[{i}] and roots[{j}] are {dist:.4} apart, closer than the graph spacing {d:.4}"
                    ),
                );
            }
        }
    }
    let mut rng = Pcg64::seed_from_u64(seed);
    let s = poisson(&volume, p.nodes, d, Some(roots[0]), dims, &mut rng)?;
    let others = &roots[1..];
    let mut points: Vec<DVec3> = s
        .points
        .iter()
        .enumerate()
        .filter(|&(i, q)| i == 0 || others.iter().all(|r| r.distance(*q) >= d))
        .map(|(_, q)| *q)
        .collect();
    points.extend_from_slice(others);
    let (pos, r) = spatial_sort(&points, d, 0);
    let mut g = yao(pos, p.sectors, dims, d as f32, r);
    g.shortfall = s.shortfall;
    Ok(g)
}

/// The graph node of each root of `p.roots` (the node at its position).
pub fn root_nodes(p: &LeastCostParams, g: &Graph) -> Result<Vec<u32>> {
    root_points(p)
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let r = r.as_vec3();
            let best = (0..g.len() as u32)
                .min_by(|&a, &b| {
                    g.position[a as usize]
                        .distance_squared(r)
                        .total_cmp(&g.position[b as usize].distance_squared(r))
                })
                .unwrap_or(NONE);
            if best == NONE || g.position[best as usize].distance(r) > 1e-4 * (1.0 + r.length()) {
                return bad(&format!("roots[{i}]"), "is not a node of the graph (a stale graph file?)");
            }
            Ok(best)
        })
        .collect()
}

/// Adds the path of graph node `e` (following `parent` back to a node already in the
/// tree) to `tree`; `map` holds the tree id of each graph node (`NONE` = not yet added)
/// and must hold every search source. Returns `e`'s tree id.
pub(crate) fn add_path(tree: &mut PathTree, map: &mut [u32], g: &Graph, parent: &[u32], e: u32) -> u32 {
    let mut path = Vec::new();
    let mut u = e;
    while map[u as usize] == NONE {
        path.push(u);
        u = parent[u as usize];
        if u == NONE {
            break;
        }
    }
    for &v in path.iter().rev() {
        let pv = parent[v as usize];
        let pt = if pv == NONE { NONE } else { map[pv as usize] };
        map[v as usize] = tree.push(g.position[v as usize], pt);
    }
    map[e as usize]
}

/// MIG level 1 from several roots (see the module docs): the forest of the level-1
/// endpoints' least-cost paths, each from the root nearest it by path length, and the
/// endpoints with their own roots.
pub(crate) fn mig_level1(
    p: &LeastCostParams,
    seed: u64,
    base: Option<&Path>,
    report: &mut LeastCostReport,
) -> Result<(PathTree, Vec<End>)> {
    let (g, roots, s, mut cand, mut rng, t) = level1_search(p, seed, base, report, |g| root_nodes(p, g))?;
    shuffle(&mut cand, &mut rng);
    cand.truncate(p.endpoints);
    let mut tree = PathTree::default();
    let mut map = vec![NONE; g.len()];
    for &r in &roots {
        map[r as usize] = tree.push(g.position[r as usize], NONE);
    }
    let mut ends: Vec<End> = cand
        .iter()
        .map(|&e| {
            let node = add_path(&mut tree, &mut map, &g, &s.parent, e);
            let root = g.position[s.source[e as usize] as usize].as_dvec3();
            End { node, pos: g.position[e as usize].as_dvec3(), root }
        })
        .collect();
    let (pruned, new_id) = prune(&tree, report);
    for e in &mut ends {
        e.node = new_id[e.node as usize];
    }
    report.path_time += t.elapsed();
    Ok((pruned, ends))
}

/// `tree` without its roots that have no child (a root that won no endpoint), with a
/// warning per dropped root; `report.trees` is set to the roots kept.
pub fn drop_lone_roots(tree: &PathTree, report: &mut LeastCostReport) -> PathTree {
    prune(tree, report).0
}

fn prune(tree: &PathTree, report: &mut LeastCostReport) -> (PathTree, Vec<u32>) {
    let n = tree.parent.len();
    let mut has_child = vec![false; n];
    for &q in &tree.parent {
        if q != NONE {
            has_child[q as usize] = true;
        }
    }
    let mut new_id = vec![NONE; n];
    let mut out = PathTree::default();
    let mut root_no = 0usize;
    for u in 0..n {
        let q = tree.parent[u];
        if q == NONE {
            root_no += 1;
            if !has_child[u] {
                let at = tree.position[u];
                report.warnings.push(format!(
                    "root {} at ({:.2}, {:.2}, {:.2}) won no endpoint and grows no tree",
                    root_no - 1,
                    at.x,
                    at.y,
                    at.z
                ));
                continue;
            }
        }
        new_id[u] = u as u32;
    }
    // Compact: keep the order, renumber.
    let mut next = 0u32;
    for id in new_id.iter_mut() {
        if *id != NONE {
            *id = next;
            next += 1;
        }
    }
    for u in 0..n {
        if new_id[u] != NONE {
            let q = tree.parent[u];
            out.push(tree.position[u], if q == NONE { NONE } else { new_id[q as usize] });
        }
    }
    report.trees = out.parent.iter().filter(|&&q| q == NONE).count();
    (out, new_id)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn lone_roots_are_dropped_and_ids_remapped() {
        let mut t = PathTree::default();
        t.push(Vec3::ZERO, NONE); // 0: root with a child
        t.push(Vec3::X * 5.0, NONE); // 1: lone root
        t.push(Vec3::Y, 0); // 2
        let mut rep = LeastCostReport::default();
        let (out, id) = prune(&t, &mut rep);
        assert_eq!(out.parent, vec![NONE, 0]);
        assert_eq!(id, vec![0, NONE, 1]);
        assert_eq!(rep.trees, 1);
        assert_eq!(rep.warnings.len(), 1);
    }
}
