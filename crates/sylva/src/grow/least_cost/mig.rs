//! MIG — multiple independent graphs (Xu2015 Ch. 4, `maketree` of Fig. 4.2; Xu2015-spec
//! §2.5).
//!
//! 1. **Level 1.** A Yao graph of `nodes` nodes fills the user volume (steps 1A–1H,
//!    edge weight = length). Dijkstra runs from the root; `endpoints` (b) endpoints are
//!    drawn without replacement from the reached nodes in the shell `−d_e ≤ sdf ≤ 0`
//!    under the volume's surface (§4.2; `shell`, 0 = 3·d). Their paths form the trunk
//!    and primary branches.
//! 2. **Levels 2, 3, …** (`levels`, each repeated `repeat` times). Every endpoint `e` of
//!    the previous level (of **all** previous levels when `all_previous`, the
//!    spine-and-twig final level of trees e and n) gets its own subgraph: `sub_nodes`
//!    (k) Poisson nodes with `e` as the first node, in the sector `{p : |p − e| ≤ r ∧
//!    ∠(p − e, v_g) ≤ α}` (`shape = "sector"`) or the solid cone of height `r` and
//!    half-angle α (`shape = "cone"`), where `v_g = (e − R)/|e − R|` points away from
//!    the root `R` of `e`'s own graph (step 4B; Xu2015-spec §7.1). `direction = "down"` /
//!    `"up"` fixes `v_g` vertical (tree g); `rotate` turns `v_g` downward by that many
//!    degrees about `up × v_g` (negative = upward; the willow of Fig. 4.13). The radius
//!    is `r_l = sub_radius·shrink^(l−2)`; subgraph spacing comes from the region's
//!    volume and k. Dijkstra runs from `e`, and `b` endpoints are drawn from the reached
//!    nodes farther than `(1 − sub_shell)·r_l` from `e` (inference: endpoints anywhere
//!    would give stubs).
//! 3. Subgraphs are separate graphs, so no edge joins two of them (§4.4.2); their paths
//!    join the tree at `e`. They are built in parallel, each with its own generator
//!    seeded from (seed, level, index), and merged in index order: deterministic.
//!
//! Level-1 endpoints that Dijkstra does not reach are never chosen; when fewer
//! candidates than `b` exist, all are taken. With `[generator.refine]` level 1 is the
//! refined graph of [`refine`](super::refine) (Figs. 4.8–4.9), with `roots` the forest
//! of [`forest`](super::forest); later levels are the same.

use super::graph::{auto_spacing, poisson_yao, Graph, Primitive, Volume, NONE};
use super::paths::{dijkstra, Length};
use super::{bad, in_range, level1_search, shuffle, End, LeastCostParams, LeastCostReport, PathTree};
use crate::error::{Error, Result};
use glam::{DQuat, DVec3, Vec3};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

crate::named::mode! {
    /// `generator.levels[].shape`: the subgraph region of a MIG level.
    SubShape, key "generator.levels.shape", default Sector {
        /// A portion of a sphere about the endpoint.
        Sector = "sector",
        /// A cone from the endpoint.
        Cone = "cone",
    }
}

crate::named::mode! {
    /// `generator.levels[].direction`: the guiding direction `v_g` of a MIG level.
    GuideDirection, key "generator.levels.direction", default Outward {
        /// `v_g = e − R`, away from the root.
        Outward = "outward",
        /// Straight down.
        Down = "down",
        /// Straight up.
        Up = "up",
    }
}

/// One `maketree` level after the first (a `[[generator.levels]]` entry).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MigLevel {
    /// Endpoints per subgraph (b).
    pub endpoints: usize,
    /// Subgraph half-angle α (degrees, in (0, 180]).
    pub half_angle: f64,
    /// `sector` (portion of sphere) or `cone`.
    pub shape: SubShape,
    /// `outward` (`v_g = e − R`), `down` or `up`.
    pub direction: GuideDirection,
    /// Downward rotation of `v_g` about `up × v_g` (degrees; negative = upward).
    pub rotate: f64,
    /// Build subgraphs around the endpoints of all previous levels.
    pub all_previous: bool,
    /// How many consecutive levels use these settings.
    pub repeat: u32,
}

impl Default for MigLevel {
    fn default() -> Self {
        MigLevel {
            endpoints: 6,
            half_angle: 54.0,
            shape: SubShape::Sector,
            direction: GuideDirection::Outward,
            rotate: 0.0,
            all_previous: false,
            repeat: 1,
        }
    }
}

/// Checks the MIG keys.
pub fn validate(p: &LeastCostParams) -> Result<()> {
    if p.dims != 3 {
        return bad("dims", "must be 3 with method = \"mig\" (flat trees need method = \"mgv\")");
    }
    if p.endpoints == 0 || p.endpoints > p.nodes {
        return bad(
            "endpoints",
            format!("must be in 1..={} (the level-1 nodes), got {}", p.nodes, p.endpoints),
        );
    }
    in_range("shell", p.shell, 0.0, 1e6)?;
    if !(2..=1_000_000).contains(&p.sub_nodes) {
        return bad("sub_nodes", format!("must be in 2..=1000000, got {}", p.sub_nodes));
    }
    in_range("sub_radius", p.sub_radius, 1e-6, 1e6)?;
    in_range("shrink", p.shrink, 0.01, 1.0)?;
    in_range("sub_shell", p.sub_shell, 0.01, 1.0)?;
    let levels: u32 = p.levels.iter().map(|l| l.repeat).sum();
    if levels > 16 {
        return bad("levels", format!("add up to {levels} levels (with repeat); at most 16"));
    }
    for (i, l) in p.levels.iter().enumerate() {
        let k = format!("levels[{i}]");
        if l.endpoints == 0 || l.endpoints > p.sub_nodes {
            return bad(
                &format!("{k}.endpoints"),
                format!("must be in 1..={} (sub_nodes), got {}", p.sub_nodes, l.endpoints),
            );
        }
        in_range(&format!("{k}.half_angle"), l.half_angle, 1e-3, 180.0)?;
        if l.shape == SubShape::Cone && l.half_angle >= 89.0 {
            return bad(&format!("{k}.half_angle"), "must be below 89 for a cone");
        }
        in_range(&format!("{k}.rotate"), l.rotate, -180.0, 180.0)?;
        if l.repeat == 0 {
            return bad(&format!("{k}.repeat"), "must be at least 1");
        }
    }
    Ok(())
}

/// The guiding direction `v_g` of a subgraph at `e` (step 4B, with the level's options).
pub fn guide_direction(e: DVec3, root: DVec3, level: &MigLevel) -> DVec3 {
    let up = DVec3::Y;
    let mut v = match level.direction {
        GuideDirection::Down => -up,
        GuideDirection::Up => up,
        GuideDirection::Outward => (e - root).normalize_or(up),
    };
    if level.rotate != 0.0 {
        let axis = up.cross(v);
        if axis.length() > 1e-9 {
            v = (DQuat::from_axis_angle(axis.normalize(), level.rotate.to_radians()) * v).normalize_or(v);
        }
    }
    v
}

/// The subgraph region of a level at `e` with direction `v` and radius `r`.
pub fn sub_region(e: DVec3, v: DVec3, r: f64, level: &MigLevel) -> Primitive {
    if level.shape == SubShape::Cone {
        let a = level.half_angle.to_radians();
        Primitive::Cone {
            base: (e + v * r).to_array(),
            height: r,
            radius: r * a.tan(),
            axis: (-v).to_array(),
        }
    } else {
        Primitive::Sector {
            center: e.to_array(),
            radius: r,
            half_angle: level.half_angle,
            axis: v.to_array(),
        }
    }
}

/// What one subgraph produced: path nodes (graph positions) and their parents (local
/// ids into the same list, `NONE` = attach to the subgraph root `e`), and endpoints.
struct SubResult {
    pos: Vec<Vec3>,
    parent: Vec<u32>,
    ends: Vec<u32>,
    graph_nodes: usize,
    graph_edges: usize,
}

/// Draws `b` endpoints among `cand` (without replacement) and returns the union of their
/// paths in `search` as local lists (see [`SubResult`]).
fn union_paths(g: &Graph, parent: &[u32], cand: &mut Vec<u32>, b: usize, rng: &mut Pcg64) -> SubResult {
    cand.sort_unstable();
    shuffle(cand, rng);
    cand.truncate(b);
    let mut local = vec![NONE; g.len()];
    let mut res = SubResult {
        pos: Vec::new(),
        parent: Vec::new(),
        ends: Vec::new(),
        graph_nodes: g.len(),
        graph_edges: g.edge_count(),
    };
    for &e in cand.iter() {
        let mut path = vec![e];
        let mut u = e;
        while parent[u as usize] != NONE && parent[u as usize] != g.root && local[u as usize] == NONE {
            u = parent[u as usize];
            path.push(u);
        }
        // Add from the root side: `path` ends at a node whose parent is the root or
        // an already added node (or that is already added itself).
        for &v in path.iter().rev() {
            if local[v as usize] != NONE {
                continue;
            }
            let pv = parent[v as usize];
            let pl = if pv == NONE || pv == g.root { NONE } else { local[pv as usize] };
            local[v as usize] = res.pos.len() as u32;
            res.pos.push(g.position[v as usize]);
            res.parent.push(pl);
        }
        res.ends.push(local[e as usize]);
    }
    res
}

fn subgraph(p: &LeastCostParams, level: &MigLevel, end: End, r: f64, seed: u64) -> Result<SubResult> {
    let v = guide_direction(end.pos, end.root, level);
    let region = sub_region(end.pos, v, r, level);
    let spacing = auto_spacing(region.analytic_volume(), p.sub_nodes, 3);
    let vol = Volume::new(vec![region]);
    let g = poisson_yao(&vol, p.sub_nodes, Some(spacing), Some(end.pos), p.sectors, 3, seed)?;
    let s = dijkstra(&g, &[g.root], None, &mut Length);
    let inner = (1.0 - p.sub_shell) * r;
    let e = end.pos.as_vec3();
    let mut cand: Vec<u32> = (0..g.len() as u32)
        .filter(|&u| u != g.root && s.reached(u) && g.position[u as usize].distance(e) as f64 >= inner)
        .collect();
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x656e_6473);
    Ok(union_paths(&g, &s.parent, &mut cand, level.endpoints, &mut rng))
}

/// Grows a MIG tree as a path union: level 1 (the plain volume, the refinement volumes
/// of [`refine`](super::refine) or several competing roots of
/// [`forest`](super::forest)), then levels 2, 3, ….
pub fn grow(
    p: &LeastCostParams,
    seed: u64,
    base: Option<&Path>,
    report: &mut LeastCostReport,
) -> Result<PathTree> {
    let (mut tree, first) = if let Some(r) = &p.refine {
        super::refine::level1(p, r, seed, report)?
    } else if !p.roots.is_empty() {
        super::forest::mig_level1(p, seed, base, report)?
    } else {
        level1(p, seed, base, report)?
    };
    grow_levels(p, seed, &mut tree, first, report)?;
    Ok(tree)
}

/// Level 1 of `maketree` in the user volume from one root.
fn level1(
    p: &LeastCostParams,
    seed: u64,
    base: Option<&Path>,
    report: &mut LeastCostReport,
) -> Result<(PathTree, Vec<End>)> {
    let (g, _, s, mut cand, mut rng, t) = level1_search(p, seed, base, report, |g| Ok(vec![g.root]))?;
    let sub = union_paths(&g, &s.parent, &mut cand, p.endpoints, &mut rng);
    let mut tree = PathTree::default();
    let root_pos = g.position[g.root as usize];
    let root = tree.push(root_pos, NONE);
    let first = merge(&mut tree, &sub, root, root_pos.as_dvec3());
    report.path_time += t.elapsed();
    Ok((tree, first))
}

/// Levels 2, 3, … of `maketree`: a subgraph at every endpoint of the previous level
/// (of all previous levels with `all_previous`), starting from the level-1 endpoints
/// `first`.
pub(crate) fn grow_levels(
    p: &LeastCostParams,
    seed: u64,
    tree: &mut PathTree,
    first: Vec<End>,
    report: &mut LeastCostReport,
) -> Result<()> {
    let mut all: Vec<End> = first.clone();
    let mut last = first;
    let mut level_no = 1u32;
    for level in &p.levels {
        for _ in 0..level.repeat {
            level_no += 1;
            let parents: Vec<End> = if level.all_previous { all.clone() } else { last.clone() };
            let total = report.graph_nodes + parents.len() * p.sub_nodes;
            if total > p.max_nodes {
                return Err(Error::Recipe(format!(
                    "MIG level {level_no} would bring the graphs to {total} nodes, over `generator.max_nodes` = {} (raise it, at most {}, or lower `sub_nodes` / the endpoint counts)",
                    p.max_nodes,
                    super::MAX_NODES_LIMIT
                )));
            }
            let r = p.sub_radius * p.shrink.powi(level_no as i32 - 2);
            let t = Instant::now();
            let results: Vec<Result<SubResult>> = parents
                .par_iter()
                .enumerate()
                .map(|(i, e)| {
                    let s = seed ^ (level_no as u64) << 40 ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                    subgraph(p, level, *e, r, s)
                })
                .collect();
            report.graph_time += t.elapsed();
            let mut next = Vec::new();
            for (e, res) in parents.iter().zip(results) {
                let res = res?;
                report.graph_nodes += res.graph_nodes;
                report.graph_edges += res.graph_edges;
                report.subgraphs += 1;
                next.extend(merge(tree, &res, e.node, e.pos));
            }
            all.extend_from_slice(&next);
            last = next;
        }
    }
    report.endpoints = all.len();
    Ok(())
}

/// Appends a subgraph's paths to the tree, attached at `at` (the subgraph root's tree
/// node); returns the new endpoints.
fn merge(tree: &mut PathTree, sub: &SubResult, at: u32, root: DVec3) -> Vec<End> {
    let first = tree.position.len() as u32;
    for (i, &pos) in sub.pos.iter().enumerate() {
        let par = sub.parent[i];
        tree.push(pos, if par == NONE { at } else { first + par });
    }
    sub.ends.iter().map(|&l| End { node: first + l, pos: sub.pos[l as usize].as_dvec3(), root }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guide_direction_rotates_down_and_up() {
        let l = MigLevel { rotate: 30.0, ..Default::default() };
        let v = guide_direction(DVec3::new(1.0, 0.0, 0.0), DVec3::ZERO, &l);
        assert!(v.y < 0.0 && (v.angle_between(DVec3::X) - 30f64.to_radians()).abs() < 1e-9);
        let l = MigLevel { direction: GuideDirection::Down, ..Default::default() };
        assert_eq!(guide_direction(DVec3::X, DVec3::ZERO, &l), -DVec3::Y);
    }
}
