//! BCM — the construction method (Xu2015 §3.3.1, Figs. 3.3–3.10; Xu2015-spec §2.4), the
//! least-cost-path system the thesis starts from, kept as a recipe method for comparison
//! with MIG and MGV (`method = "bcm"`).
//!
//! 1. **Graph.** A lattice (4-connected in 2D, 6-connected in 3D) filling the volume,
//!    spacing `generator.spacing` or, when 0, the spacing that puts about
//!    `generator.nodes` sites in the volume; `bcm.jitter` moves each site by up to that
//!    fraction of the spacing (0 = the seed's regular lattice, whose paths show the
//!    staircase artefact of Fig. 3.3).
//! 2. **Weights.** `bcm.weights = "random"`: `W = 1 + v^β` per edge with `v` uniform in
//!    `[low, low + range)` (Fig. 3.8; β = 0 gives W ≡ 2); or a spatial variation (Fig.
//!    3.7): `left`, `right`, `axis`, `height` (the edge midpoint's distance to that side,
//!    axis or the bottom, so paths bend toward it).
//! 3. **Round 1.** Dijkstra from the root; `endpoints` endpoints drawn (seeded, without
//!    replacement) from the reached sites in the shell `−d_e ≤ sdf ≤ 0` under the volume
//!    surface (`shell`, 0 = 3·spacing), as MIG's level 1; the union of their paths is
//!    the first tree.
//! 4. **Later rounds** (`bcm.rounds` in all). The weights of edges between two tree
//!    sites are multiplied by `bcm.cheapen` (the seed leaves the factor open; Xu2015-spec
//!    §2.4 asks for it to be exposed; an edge is cheapened again in every later round,
//!    so older paths become cheaper still), `bcm.later_endpoints` new endpoints are drawn
//!    from the sites not on the tree within `bcm.near` lattice steps of it and farther
//!    than `bcm.min_root_distance` from the root (the elm of Fig. 3.10), and Dijkstra
//!    from the root runs again. Each new path is added from its endpoint back to the
//!    first site already on the tree, so the union stays a tree.
//!
//! Deterministic in the seed (lattice jitter, weights and endpoint draws have their own
//! streams).

use super::graph::{lattice, Graph, NONE};
use super::paths::{bcm_random_weights, bcm_spatial_weights, dijkstra, Spatial, Stored};
use super::{bad, in_range, LeastCostParams, LeastCostReport, PathTree};
use crate::error::Result;
use glam::DVec3;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::time::Instant;

crate::named::mode! {
    /// `generator.bcm.weights`: the edge weights of the basic cost model.
    Weights, key "generator.bcm.weights", default Random {
        /// `W = 1 + v^β`, `v` uniform in [`low`, `low + range`].
        Random = "random",
        /// The edge midpoint's distance to the left side (paths bend toward it).
        Left = "left",
        /// The distance to the right side.
        Right = "right",
        /// The distance to the vertical axis through the root.
        Axis = "axis",
        /// The height above the bottom.
        Height = "height",
    }
}

/// The `[generator.bcm]` keys of a `method = "bcm"` recipe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BcmParams {
    /// `random`, or a spatial variation: `left`, `right`, `axis`, `height`.
    pub weights: Weights,
    /// β of `W = 1 + v^β`.
    pub beta: f64,
    /// Lower end of `v`'s range.
    pub low: f64,
    /// Width `R` of `v`'s range (the seed's R = 100).
    pub range: f64,
    /// Lattice jitter as a fraction of the spacing, in [0, 0.45].
    pub jitter: f64,
    /// Rounds in all (1 = only the first).
    pub rounds: u32,
    /// Factor on the weights of edges along the tree before a later round, in (0, 1].
    pub cheapen: f64,
    /// Later endpoints lie within this many lattice steps of the tree.
    pub near: u32,
    /// Endpoints per later round (0 = twice `endpoints`).
    pub later_endpoints: usize,
    /// Later endpoints lie farther than this from the root (metres).
    pub min_root_distance: f64,
}

impl Default for BcmParams {
    fn default() -> Self {
        BcmParams {
            weights: Weights::Random,
            beta: 1.0,
            low: 0.0,
            range: 100.0,
            jitter: 0.0,
            rounds: 2,
            cheapen: 0.3,
            near: 3,
            later_endpoints: 0,
            min_root_distance: 0.0,
        }
    }
}

/// Checks the BCM keys; errors name the key.
pub fn validate(p: &LeastCostParams) -> Result<()> {
    let b = &p.bcm;
    in_range("bcm.beta", b.beta, 0.0, 10.0)?;
    in_range("bcm.low", b.low, 0.0, 1e6)?;
    in_range("bcm.range", b.range, 1e-6, 1e6)?;
    in_range("bcm.jitter", b.jitter, 0.0, 0.45)?;
    in_range("bcm.cheapen", b.cheapen, 1e-3, 1.0)?;
    in_range("bcm.min_root_distance", b.min_root_distance, 0.0, 1e6)?;
    in_range("shell", p.shell, 0.0, 1e6)?;
    if b.rounds == 0 || b.rounds > 20 {
        return bad("bcm.rounds", format!("must be in 1..=20, got {}", b.rounds));
    }
    if b.near == 0 || b.near > 1000 {
        return bad("bcm.near", format!("must be in 1..=1000, got {}", b.near));
    }
    if p.endpoints == 0 {
        return bad("endpoints", "must be at least 1");
    }
    Ok(())
}

/// Grows a BCM tree (see the module docs).
pub fn grow(p: &LeastCostParams, seed: u64, report: &mut LeastCostReport) -> Result<PathTree> {
    let b = &p.bcm;
    let t = Instant::now();
    let vol = p.graph_volume();
    let spacing = if p.spacing > 0.0 {
        p.spacing
    } else {
        (vol.measure(p.dims, seed) / p.nodes as f64).powf(1.0 / p.dims as f64)
    };
    let mut g = lattice(&vol, spacing, b.jitter, p.dims, seed ^ 0x6263_6d31)?;
    if let Some(r) = p.root {
        let r = DVec3::from_array(r).as_vec3();
        g.root = (0..g.len() as u32)
            .min_by(|&x, &y| {
                g.position[x as usize]
                    .distance_squared(r)
                    .total_cmp(&g.position[y as usize].distance_squared(r))
            })
            .unwrap_or(0);
    }
    let mut w = match b.weights {
        Weights::Random => bcm_random_weights(&g, b.beta, b.low, b.range, seed ^ 0x6263_6d32),
        Weights::Left => bcm_spatial_weights(&g, Spatial::Left),
        Weights::Right => bcm_spatial_weights(&g, Spatial::Right),
        Weights::Axis => bcm_spatial_weights(&g, Spatial::Axis),
        Weights::Height => bcm_spatial_weights(&g, Spatial::Height),
    };
    report.graph_nodes = g.len();
    report.graph_edges = g.edge_count();
    report.graph_bytes = g.bytes();
    report.graph_time += t.elapsed();

    let t = Instant::now();
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x6263_6d33);
    let mut tree = PathTree::default();
    let mut local = vec![NONE; g.len()];
    local[g.root as usize] = tree.push(g.position[g.root as usize], NONE);
    let de = if p.shell > 0.0 { p.shell } else { 3.0 * spacing };
    for round in 0..b.rounds {
        if round > 0 {
            for u in 0..g.len() as u32 {
                if local[u as usize] == NONE {
                    continue;
                }
                let first = g.offsets[u as usize] as usize;
                for (k, &v) in g.out(u).iter().enumerate() {
                    if local[v as usize] != NONE {
                        w[first + k] *= b.cheapen as f32;
                    }
                }
            }
        }
        let s = dijkstra(&g, &[g.root], None, &mut Stored(&w));
        if round == 0 {
            report.unreachable = (0..g.len() as u32).filter(|&u| !s.reached(u)).count();
        }
        let root = g.position[g.root as usize];
        let mut cand: Vec<u32> = if round == 0 {
            (0..g.len() as u32)
                .filter(|&u| u != g.root && s.reached(u) && vol.sdf(g.position[u as usize].as_dvec3()) >= -de)
                .collect()
        } else {
            let hops = hops_to_tree(&g, &local);
            (0..g.len() as u32)
                .filter(|&u| {
                    let h = hops[u as usize];
                    h > 0
                        && h <= b.near
                        && s.reached(u)
                        && g.position[u as usize].distance(root) as f64 > b.min_root_distance
                })
                .collect()
        };
        let want = if round == 0 {
            p.endpoints
        } else if b.later_endpoints > 0 {
            b.later_endpoints
        } else {
            2 * p.endpoints
        };
        super::shuffle(&mut cand, &mut rng);
        cand.truncate(want);
        for &e in &cand {
            // From the endpoint back to the first site already on the tree.
            let mut path = vec![e];
            let mut u = e;
            while local[u as usize] == NONE {
                u = s.parent[u as usize];
                if u == NONE {
                    break;
                }
                path.push(u);
            }
            if u == NONE {
                continue;
            }
            for k in (0..path.len() - 1).rev() {
                let (v, par) = (path[k], path[k + 1]);
                local[v as usize] = tree.push(g.position[v as usize], local[par as usize]);
            }
            report.endpoints += 1;
        }
    }
    report.path_time += t.elapsed();
    Ok(tree)
}

/// Lattice steps from every site to the nearest tree site (0 on the tree, `u32::MAX`
/// when none is reachable): a multi-source breadth-first search.
fn hops_to_tree(g: &Graph, local: &[u32]) -> Vec<u32> {
    let mut hops = vec![u32::MAX; g.len()];
    let mut queue = VecDeque::new();
    for (u, &l) in local.iter().enumerate() {
        if l != NONE {
            hops[u] = 0;
            queue.push_back(u as u32);
        }
    }
    while let Some(u) = queue.pop_front() {
        let h = hops[u as usize] + 1;
        for &v in g.out(u) {
            if hops[v as usize] == u32::MAX {
                hops[v as usize] = h;
                queue.push_back(v);
            }
        }
    }
    hops
}
