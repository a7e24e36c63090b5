//! Least-cost-path trees (Xu2015, Chs. 3–6; Xu2015-spec §2.1–§2.8): a tree is the union
//! of least-cost paths from a root to chosen endpoints in a graph filling a volume.
//!
//! ```text
//!  volume ─► Poisson nodes ─► Yao-k graph ─► weights ─► Dijkstra ─► endpoints ─► path union
//!          (graph/sample.rs)  (graph/yao.rs)  (paths.rs)  (paths.rs)  (mig.rs / mgv.rs)
//!  path union ─► thickness w = c·s^ζ or pipe model ─► smoothing ─► Skeleton (parent-first)
//! ```
//!
//! - [`mig`]: *multiple independent graphs* (Ch. 4): a level-1 graph in a user volume,
//!   then a conical subgraph at every endpoint, level by level (`maketree`, Fig. 4.2).
//! - [`mgv`]: *modified guiding vectors* (Ch. 5): one graph whose edge weights follow
//!   guiding vectors set lazily during Dijkstra, over 4–5 iterations.
//! - [`refine`]: MIG refinement volumes (Figs. 4.8–4.9): a level-1 graph over spheres
//!   and cones to the trunk, no edges between them, an endpoint quota each.
//! - [`forest`]: several competing roots on one graph (multi-source Dijkstra).
//! - [`bcm`]: the construction method (§3.3.1) the thesis starts from: a lattice with
//!   random or spatial weights, rounds that cheapen the tree's edges.
//! - [`graph`]: volumes, Poisson-disc nodes, Yao-k and lattice graphs, graph files.
//! - [`paths`]: multi-source Dijkstra, BCM / MIG / MGV weights.
//! - [`leaves`]: leaves or needles at the tips (§4.5).
//!
//! # Thickness (§4.3, Fig. 6.2; Xu2015-spec §2.7)
//!
//! Every leaf of the final path union is a tip. `power` (the seed's rule): `s(n)` is
//! the summed segment length from `n` out to its **farthest** descendant tip (the
//! seed leaves the aggregation at shared nodes open; the maximum is monotone, so `w`
//! never decreases towards the root), and `w = max(min_radius, radius_scale·s^ζ)`.
//! `pipe`: tips get `min_radius` and `r_p^e = Σ r_c^e` (exponent `pipe_exponent`, 2 =
//! da Vinci), which gives a visibly thicker trunk (Fig. 6.2, right).
//!
//! # Skeleton
//!
//! The union is written parent-first by a depth-first walk from the root that visits
//! the child with the largest `s` first (so the tube mesher continues the main axis
//! there); branch order rises by one at every other child. Paths that follow graph
//! edges look crooked (§6.2.1): `smooth` (0–1) moves every node with exactly one child
//! towards the midpoint of its neighbours `smooth_iterations` times, with junctions,
//! tips and the root pinned (inference; 0 = off, the seed's look).

pub mod bcm;
pub mod forest;
pub mod graph;
pub mod leaves;
pub mod mgv;
pub mod mig;
pub mod paths;
pub mod refine;

use crate::error::{Error, Result};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{DVec3, Vec3};
use graph::{Graph, Primitive, Volume, NONE};
use paths::{dijkstra, Length, Search};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::{Duration, Instant};

/// Default node budget (graph nodes in total, all MIG subgraphs included).
pub const MAX_NODES: usize = 5_000_000;
/// The largest budget `generator.max_nodes` may set.
pub const MAX_NODES_LIMIT: usize = 50_000_000;

/// `generator.method` of a least-cost recipe (serde: `mig`, `mgv`, `bcm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Multiple Interacting Graphs (Xu2015 Ch. 4).
    Mig,
    /// Multiple Guiding Vectors (Xu2015 Ch. 5).
    #[default]
    Mgv,
    /// The basic cost model (Xu2015 §3.3.1), for comparison.
    Bcm,
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Method::Mig => "mig",
            Method::Mgv => "mgv",
            Method::Bcm => "bcm",
        })
    }
}

crate::named::mode! {
    /// `generator.thickness`: the thickness rule.
    Thickness, key "generator.thickness", default Power {
        /// `w = c·s^ζ` from the path length `s` below a node.
        Power = "power",
        /// The pipe model: `r^e` summed over the children (`pipe_exponent`).
        Pipe = "pipe",
    }
}

/// Parameters of the least-cost-path generator: the `[generator]` keys of a recipe with
/// `type = "least-cost"` (`docs/least-cost.md`). Lengths in metres, angles in degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LeastCostParams {
    /// `mig` (Ch. 4), `mgv` (Ch. 5, the default) or `bcm` (§3.3.1, for comparison).
    pub method: Method,
    /// 3 (trees) or 2 (flat trees in the z = 0 plane).
    pub dims: u8,
    /// Graph nodes `K` (MGV: the graph; MIG: the level-1 graph).
    pub nodes: usize,
    /// Poisson spacing `d`; 0 = chosen from the volume and `nodes`.
    pub spacing: f64,
    /// Yao sectors `k` (8 = octants in 3D; see [`graph`]).
    pub sectors: u32,
    /// The graph volume (MGV) or the level-1 volume (MIG): a union of primitives.
    pub volume: Vec<Primitive>,
    /// The root; default: the bottom centre of the volume's bounding box.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub root: Option<[f64; 3]>,
    /// Several competing roots on one graph (MGV, MIG): a forest whose trees share the
    /// graph; every endpoint joins the root that reaches it cheapest ([`forest`]).
    /// Empty = one tree from `root`.
    pub roots: Vec<[f64; 3]>,
    /// A graph file to reuse (MGV graph / MIG level-1 graph): read when it exists and
    /// was built from the same graph parameters, else built and written there.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub graph_cache: String,
    /// Node budget over all graphs (at most [`MAX_NODES_LIMIT`]).
    pub max_nodes: usize,
    /// MIG: the level-1 endpoint count `b`.
    pub endpoints: usize,
    /// MIG: level-1 endpoint shell thickness `d_e` under the volume's surface; 0 = 3·d.
    pub shell: f64,
    /// MIG: nodes `k` in each subgraph.
    pub sub_nodes: usize,
    /// MIG: subgraph radius `r` at level 2.
    pub sub_radius: f64,
    /// MIG: shrink ratio `a` of the subgraph radius per level (≤ 1).
    pub shrink: f64,
    /// MIG: subgraph endpoints are drawn from the nodes farther than
    /// `(1 − sub_shell)·r` from the subgraph root (inference), in (0, 1].
    pub sub_shell: f64,
    /// MIG: levels 2, 3, … of `maketree`.
    pub levels: Vec<mig::MigLevel>,
    /// MIG: refinement volumes of the level-1 graph (Figs. 4.8–4.9;
    /// `[generator.refine]`, [`refine`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refine: Option<refine::RefineParams>,
    /// MGV: the iterations (§5.2.4).
    pub iterations: Vec<mgv::MgvIteration>,
    /// MGV: rotation axis: `edge` (Xu2015-spec's recommendation, §5.3.1) or `guide`
    /// (§5.2.2's `up × parent guide`).
    pub axis: mgv::AxisRule,
    /// MGV: weight floor `ε·d_E` (0 = the seed's weights).
    pub epsilon: f64,
    /// Thickness rule: `power` (`w = c·s^ζ`) or `pipe`.
    pub thickness: Thickness,
    /// ζ of `w = c·s^ζ`.
    pub zeta: f64,
    /// c of `w = c·s^ζ`.
    pub radius_scale: f64,
    /// Smallest radius (tips).
    pub min_radius: f64,
    /// Pipe-model exponent (`thickness = "pipe"`), in [1, 4].
    pub pipe_exponent: f64,
    /// Smoothing strength in [0, 1] (0 = off).
    pub smooth: f64,
    /// Smoothing passes (at most 100).
    pub smooth_iterations: u32,
    /// BCM: `[generator.bcm]` (lattice, weights, rounds).
    pub bcm: bcm::BcmParams,
    /// Leaves or needles at the tips (`[generator.leaves]`, §4.5; default none).
    pub leaves: leaves::LeafParams,
}

impl Default for LeastCostParams {
    fn default() -> Self {
        LeastCostParams {
            method: Method::Mgv,
            dims: 3,
            nodes: 30_000,
            spacing: 0.0,
            sectors: 8,
            volume: vec![Primitive::Box { center: [0.0, 5.0, 0.0], size: [10.0, 10.0, 10.0] }],
            root: None,
            roots: Vec::new(),
            graph_cache: String::new(),
            max_nodes: MAX_NODES,
            endpoints: 12,
            shell: 0.0,
            sub_nodes: 200,
            sub_radius: 2.0,
            shrink: 0.7,
            sub_shell: 0.5,
            levels: Vec::new(),
            refine: None,
            iterations: Vec::new(),
            axis: mgv::AxisRule::Edge,
            epsilon: 0.0,
            thickness: Thickness::Power,
            zeta: 0.3,
            radius_scale: 0.05,
            min_radius: 0.01,
            pipe_exponent: 2.0,
            smooth: 0.0,
            smooth_iterations: 3,
            bcm: bcm::BcmParams::default(),
            leaves: leaves::LeafParams::default(),
        }
    }
}

pub(crate) fn bad<T>(key: &str, why: impl std::fmt::Display) -> Result<T> {
    Err(Error::Recipe(format!("`generator.{key}` {why}")))
}

pub(crate) fn finite(key: &str, v: f64) -> Result<()> {
    if !v.is_finite() || v.abs() > 1e6 {
        return bad(key, format!("must be a finite number of magnitude ≤ 1e6, got {v}"));
    }
    Ok(())
}

pub(crate) fn in_range(key: &str, v: f64, lo: f64, hi: f64) -> Result<()> {
    finite(key, v)?;
    if v < lo || v > hi {
        return bad(key, format!("must be in [{lo}, {hi}], got {v}"));
    }
    Ok(())
}

impl LeastCostParams {
    /// Checks every parameter; errors name the key (`generator.zeta`).
    pub fn validate(&self) -> Result<()> {
        if self.dims != 2 && self.dims != 3 {
            return bad("dims", format!("must be 2 or 3, got {}", self.dims));
        }
        if self.max_nodes == 0 || self.max_nodes > MAX_NODES_LIMIT {
            return bad("max_nodes", format!("must be in 1..={MAX_NODES_LIMIT}, got {}", self.max_nodes));
        }
        if self.nodes < 2 {
            return bad("nodes", format!("must be at least 2, got {}", self.nodes));
        }
        if self.nodes > self.max_nodes {
            return bad(
                "nodes",
                format!(
                    "is {}, over the node budget of {} (raise `generator.max_nodes`, at most {MAX_NODES_LIMIT}; a graph takes about 100 bytes per node)",
                    self.nodes, self.max_nodes
                ),
            );
        }
        in_range("spacing", self.spacing, 0.0, 1e6)?;
        graph::check_sectors(self.sectors, self.dims)?;
        if self.volume.is_empty() {
            return bad("volume", "needs at least one primitive");
        }
        for (i, p) in self.volume.iter().enumerate() {
            p.validate(&format!("generator.volume[{i}]"))?;
        }
        if let Some(r) = self.root {
            for v in r {
                finite("root", v)?;
            }
        }
        forest::validate(self)?;
        if let Some(r) = &self.refine {
            r.validate(self)?;
        }
        if self.graph_cache.contains('\0') {
            return bad("graph_cache", "is not a valid file name");
        }
        in_range("zeta", self.zeta, 0.0, 4.0)?;
        in_range("radius_scale", self.radius_scale, 0.0, 1e3)?;
        in_range("min_radius", self.min_radius, 1e-6, 1e3)?;
        in_range("pipe_exponent", self.pipe_exponent, 1.0, 4.0)?;
        in_range("smooth", self.smooth, 0.0, 1.0)?;
        self.leaves.validate()?;
        if self.smooth_iterations > 100 {
            return bad("smooth_iterations", format!("must be at most 100, got {}", self.smooth_iterations));
        }
        match self.method {
            Method::Mig => mig::validate(self),
            Method::Bcm => bcm::validate(self),
            Method::Mgv => mgv::validate(self),
        }
    }

    /// The level-1 / MGV graph volume.
    pub fn graph_volume(&self) -> Volume {
        Volume::new(self.volume.clone())
    }

    /// Hash of everything the graph depends on (the graph file's key).
    pub fn graph_key(&self, seed: u64) -> u64 {
        let mut text = serde_json::to_string(&(
            &self.volume,
            self.nodes,
            self.spacing,
            self.sectors,
            self.dims,
            self.root,
            seed,
        ))
        .unwrap_or_default();
        if !self.roots.is_empty() {
            // Only forests add their roots, so single-tree keys stay as they were.
            text += &serde_json::to_string(&self.roots).unwrap_or_default();
        }
        // FNV-1a, 64 bit.
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in text.bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        h
    }
}

/// What [`grow`] built.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LeastCostReport {
    /// Nodes in all graphs built (MGV: the graph; MIG: level 1 plus subgraphs).
    pub graph_nodes: usize,
    /// Edges in all graphs.
    pub graph_edges: usize,
    /// Bytes of the largest graph.
    pub graph_bytes: usize,
    /// Requested nodes that Poisson sampling could not place (level-1 / MGV graph).
    pub shortfall: usize,
    /// Graph nodes not reachable from the root through out-edges (level-1 / MGV graph).
    pub unreachable: usize,
    /// Subgraphs built (MIG).
    pub subgraphs: usize,
    /// MIG refinement: sphere + cone subvolumes of the level-1 graph (0 without
    /// `[generator.refine]`).
    pub subvolumes: usize,
    /// MIG refinement: endpoints missing from the subvolumes' quotas (too few candidates).
    pub quota_shortfall: usize,
    /// Trees in the forest (1 for a single root; roots that won no endpoint are dropped).
    pub trees: usize,
    /// Endpoints whose paths were added.
    pub endpoints: usize,
    /// Skeleton nodes.
    pub nodes: usize,
    /// Tips.
    pub tips: usize,
    /// Leaf or needle organs placed at the tips (`[generator.leaves]`).
    pub leaves: usize,
    /// `built`, `loaded` or `saved` (the graph file), empty without one.
    pub cache: String,
    /// Time to build (or load) graphs.
    pub graph_time: Duration,
    /// Time in Dijkstra and endpoint selection.
    pub path_time: Duration,
    /// Time for thickness, smoothing and the skeleton.
    pub skeleton_time: Duration,
    /// Whole run.
    pub elapsed: Duration,
    /// Problems that did not stop the run.
    pub warnings: Vec<String>,
}

/// The result of [`grow`].
#[derive(Debug, Clone, PartialEq)]
pub struct LeastCostTree {
    /// The skeleton: parent-first, +Y up, metres.
    pub skeleton: Skeleton,
    /// What was built.
    pub report: LeastCostReport,
}

/// A union of paths: a forest over its own node list (parents need not come first).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PathTree {
    /// Node positions.
    pub position: Vec<Vec3>,
    /// Parent of each node (`NONE` for roots).
    pub parent: Vec<u32>,
}

impl PathTree {
    /// Adds a node and returns its id.
    pub fn push(&mut self, p: Vec3, parent: u32) -> u32 {
        self.position.push(p);
        self.parent.push(parent);
        (self.position.len() - 1) as u32
    }

    /// Nodes in an order where every parent comes before its children (breadth-first
    /// from the roots, children in id order). Nodes on a cycle (never produced by the
    /// generators) are left out.
    pub fn top_down(&self) -> Vec<u32> {
        let (start, kids) = self.children();
        let mut order: Vec<u32> =
            (0..self.parent.len() as u32).filter(|&i| self.parent[i as usize] == NONE).collect();
        let mut head = 0;
        while head < order.len() {
            let u = order[head] as usize;
            head += 1;
            order.extend_from_slice(&kids[start[u] as usize..start[u + 1] as usize]);
        }
        order
    }

    /// Children in CSR form: `(start, kids)`, kids of each node in id order.
    pub fn children(&self) -> (Vec<u32>, Vec<u32>) {
        crate::skeleton::children_csr(self.parent.len(), &self.parent)
    }

    /// `s(n)`: summed segment length from each node out to its farthest descendant tip
    /// (0 at tips; see the module docs).
    pub fn reach(&self) -> Vec<f64> {
        let order = self.top_down();
        let mut s = vec![0.0f64; self.parent.len()];
        for &u in order.iter().rev() {
            let p = self.parent[u as usize];
            if p != NONE {
                let len = self.position[u as usize].distance(self.position[p as usize]) as f64;
                let v = s[u as usize] + len;
                if v > s[p as usize] {
                    s[p as usize] = v;
                }
            }
        }
        s
    }

    /// Radii by the rule of the module docs.
    pub fn radii(&self, p: &LeastCostParams, reach: &[f64]) -> Vec<f64> {
        if p.thickness == Thickness::Pipe {
            let order = self.top_down();
            let e = p.pipe_exponent;
            let mut acc = vec![0.0f64; self.parent.len()];
            let mut r = vec![p.min_radius; self.parent.len()];
            for &u in order.iter().rev() {
                let u = u as usize;
                if acc[u] > 0.0 {
                    r[u] = acc[u].powf(1.0 / e).max(p.min_radius);
                }
                let q = self.parent[u];
                if q != NONE {
                    acc[q as usize] += r[u].powf(e);
                }
            }
            r
        } else {
            // Xu2015, §4.3: w = s^ζ (scaled by c, floored at w_min)
            reach.iter().map(|&s| (p.radius_scale * s.powf(p.zeta)).max(p.min_radius)).collect()
        }
    }

    /// Laplacian smoothing of chain nodes (see the module docs).
    pub fn smooth(&mut self, strength: f64, passes: u32) {
        if strength <= 0.0 || passes == 0 {
            return;
        }
        let (start, kids) = self.children();
        let chain: Vec<(u32, u32, u32)> = (0..self.parent.len())
            .filter(|&u| self.parent[u] != NONE && start[u + 1] - start[u] == 1)
            .map(|u| (u as u32, self.parent[u], kids[start[u] as usize]))
            .collect();
        let t = strength as f32;
        for _ in 0..passes {
            let old = self.position.clone();
            for &(u, a, b) in &chain {
                let mid = (old[a as usize] + old[b as usize]) / 2.0;
                let p = &mut self.position[u as usize];
                *p += t * (mid - *p);
            }
        }
    }

    /// Number of tips (nodes with a parent and no child).
    pub fn tips(&self) -> usize {
        let (start, _) = self.children();
        (0..self.parent.len()).filter(|&u| self.parent[u] != NONE && start[u + 1] == start[u]).count()
    }

    /// The parent-first skeleton (see the module docs).
    pub fn to_skeleton(&self, radius: &[f64], reach: &[f64]) -> Result<Skeleton> {
        let (start, kids) = self.children();
        let n = self.parent.len();
        let mut sk = Skeleton::new();
        let mut new_id = vec![NO_PARENT; n];
        let mut stack: Vec<(u32, u16)> = Vec::new();
        let roots: Vec<u32> = (0..n as u32).filter(|&i| self.parent[i as usize] == NONE).collect();
        for &r in roots.iter().rev() {
            stack.push((r, 0));
        }
        let mut sorted: Vec<u32> = Vec::new();
        while let Some((u, order)) = stack.pop() {
            let ui = u as usize;
            let p = self.parent[ui];
            let pos = self.position[ui];
            let (parent, up) = if p == NONE {
                (NO_PARENT, Vec3::Z)
            } else {
                let pi = new_id[p as usize];
                let dir = (pos - sk.position[pi as usize]).normalize_or_zero();
                let prev = sk.up[pi as usize];
                let mut up = (prev - dir * prev.dot(dir)).normalize_or_zero();
                if up == Vec3::ZERO {
                    up = dir.any_orthonormal_vector();
                }
                (pi, up)
            };
            if !pos.is_finite() || !radius[ui].is_finite() {
                return Err(Error::InvalidGeometry {
                    what: "least-cost tree".into(),
                    why: format!("node {u} has a non-finite position or radius"),
                });
            }
            new_id[ui] = sk.push(pos, radius[ui] as f32, parent, up, order);
            sorted.clear();
            sorted.extend_from_slice(&kids[start[ui] as usize..start[ui + 1] as usize]);
            // Heaviest child first (continues the axis); ties by id.
            sorted.sort_by(|&a, &b| reach[b as usize].total_cmp(&reach[a as usize]).then(a.cmp(&b)));
            for (i, &c) in sorted.iter().enumerate().rev() {
                stack.push((c, if i == 0 { order } else { order.saturating_add(1) }));
            }
        }
        sk.validate()?;
        Ok(sk)
    }
}

/// Builds (or loads from `graph_cache`) the MGV / level-1 graph and records its time,
/// size and shortfall in `report`.
pub(crate) fn main_graph(
    p: &LeastCostParams,
    seed: u64,
    base: Option<&Path>,
    report: &mut LeastCostReport,
) -> Result<Graph> {
    let t = Instant::now();
    let g = build_or_load_graph(p, seed, base, report)?;
    report.graph_time += t.elapsed();
    report.graph_nodes = g.len();
    report.graph_edges = g.edge_count();
    report.graph_bytes = g.bytes();
    report.shortfall = g.shortfall;
    Ok(g)
}

fn build_or_load_graph(
    p: &LeastCostParams,
    seed: u64,
    base: Option<&Path>,
    report: &mut LeastCostReport,
) -> Result<Graph> {
    let key = p.graph_key(seed);
    let file = (!p.graph_cache.is_empty()).then(|| match base {
        Some(b) => b.join(&p.graph_cache),
        None => Path::new(&p.graph_cache).to_path_buf(),
    });
    if let Some(f) = &file {
        if f.exists() {
            let (g, k) = Graph::read(f)?;
            if k == key {
                report.cache = "loaded".into();
                return Ok(g);
            }
            report.warnings.push(format!(
                "graph file {} was built from other graph parameters; rebuilt and overwritten",
                f.display()
            ));
        }
    }
    let root = p.root.map(DVec3::from_array);
    let spacing = (p.spacing > 0.0).then_some(p.spacing);
    if !p.roots.is_empty() {
        let g = forest::poisson_yao_roots(p, spacing, seed ^ GRAPH_STREAM)?;
        if let Some(f) = &file {
            g.write(f, key)?;
            report.cache = "saved".into();
        }
        return Ok(g);
    }
    let g = graph::poisson_yao(
        &p.graph_volume(),
        p.nodes,
        spacing,
        root,
        p.sectors,
        p.dims,
        seed ^ GRAPH_STREAM,
    )?;
    if let Some(f) = &file {
        g.write(f, key)?;
        report.cache = "saved".into();
    }
    Ok(g)
}

const GRAPH_STREAM: u64 = 0x9e37_79b9_7f4a_7c15;

/// Grows a least-cost-path tree (see the module docs). `base` is the folder a relative
/// `graph_cache` resolves in (the recipe's folder; the working directory when `None`).
/// Deterministic in `seed`. Errors: [`Error::Recipe`] naming the key for bad
/// parameters or an exceeded node budget.
pub fn grow(p: &LeastCostParams, seed: u64, base: Option<&Path>) -> Result<LeastCostTree> {
    let start = Instant::now();
    p.validate()?;
    let mut report = LeastCostReport::default();
    let mut tree = match p.method {
        Method::Mig => mig::grow(p, seed, base, &mut report)?,
        Method::Bcm => bcm::grow(p, seed, &mut report)?,
        Method::Mgv => mgv::grow(p, seed, base, &mut report)?,
    };
    let t = Instant::now();
    if tree.parent.iter().all(|&q| q == NONE) {
        return Err(Error::Recipe(
            "the least-cost generator found no endpoint to grow to: enlarge the volume, raise `generator.nodes` or check the endpoint settings".into(),
        ));
    }
    tree.smooth(p.smooth, p.smooth_iterations);
    let reach = tree.reach();
    let radius = tree.radii(p, &reach);
    let mut skeleton = tree.to_skeleton(&radius, &reach)?;
    report.leaves = leaves::place(&p.leaves, &mut skeleton, seed)?;
    report.skeleton_time = t.elapsed();
    report.nodes = skeleton.len();
    report.tips = tree.tips();
    report.trees = skeleton.stats().roots;
    report.elapsed = start.elapsed();
    Ok(LeastCostTree { skeleton, report })
}

/// A deterministic hash of `(seed, a, b)` to `[0, 1)` (per-node random choices that must
/// not depend on visiting order).
pub(crate) fn hash01(seed: u64, a: u64, b: u64) -> f64 {
    let mut x = seed ^ a.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ b.wrapping_mul(0xc2b2_ae3d_27d4_eb4f);
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^= x >> 33;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

// ---------------------------------------------------------------------------------
// Shared by the MIG, forest, refined-MIG and MGV growers.

/// An endpoint of the growing tree.
#[derive(Debug, Clone, Copy)]
pub(crate) struct End {
    /// Node id in the path tree.
    pub(crate) node: u32,
    /// Its position.
    pub(crate) pos: DVec3,
    /// The root of the graph (the tree's own root in a forest) it was chosen in.
    pub(crate) root: DVec3,
}

/// The generator stream of the level-1 endpoints.
pub(crate) const LEVEL1_STREAM: u64 = 0x6c65_7665_6c31;

/// What [`level1_search`] finds: the level-1 graph, its roots, the length-weighted
/// search from them, the shell candidates for endpoints, the endpoint stream, and when
/// the search started (for `report.path_time`).
pub(crate) type Level1 = (Graph, Vec<u32>, Search, Vec<u32>, Pcg64, Instant);

/// The level-1 graph (a warning when its volume holds fewer than `nodes` nodes), a
/// Dijkstra with length weights from `roots(&graph)`, its unreachable nodes counted in
/// `report`, and the shell candidates for the endpoints.
pub(crate) fn level1_search(
    p: &LeastCostParams,
    seed: u64,
    base: Option<&Path>,
    report: &mut LeastCostReport,
    roots: impl FnOnce(&Graph) -> Result<Vec<u32>>,
) -> Result<Level1> {
    let g = main_graph(p, seed, base, report)?;
    if g.shortfall > 0 {
        report.warnings.push(format!("the level-1 volume holds only {} of the {} nodes", g.len(), p.nodes));
    }
    let t = Instant::now();
    let roots = roots(&g)?;
    let s = dijkstra(&g, &roots, None, &mut Length);
    report.unreachable = (0..g.len() as u32).filter(|&u| !s.reached(u)).count();
    let cand = shell_candidates(p, &g, &s);
    let rng = Pcg64::seed_from_u64(seed ^ LEVEL1_STREAM);
    Ok((g, roots, s, cand, rng, t))
}

/// Level-1 endpoint candidates: reached nodes (not sources) in the shell
/// `−d_e ≤ sdf ≤ 0` under the volume's surface, in id order.
pub(crate) fn shell_candidates(p: &LeastCostParams, g: &Graph, s: &Search) -> Vec<u32> {
    let vol = p.graph_volume();
    let de = if p.shell > 0.0 { p.shell } else { 3.0 * g.spacing as f64 };
    (0..g.len() as u32)
        .filter(|&u| {
            s.reached(u) && s.parent[u as usize] != NONE && vol.sdf(g.position[u as usize].as_dvec3()) >= -de
        })
        .collect()
}

/// Fisher–Yates shuffle with the given generator.
pub(crate) fn shuffle(v: &mut [u32], rng: &mut Pcg64) {
    use rand::RngExt;
    for i in (1..v.len()).rev() {
        let j = rng.random_range(0..=i);
        v.swap(i, j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain() -> PathTree {
        // 0 ─ 1 ─ 2 ─ 3 (tip), 1 ─ 4 (tip)
        let mut t = PathTree::default();
        t.push(Vec3::ZERO, NONE);
        t.push(Vec3::Y, 0);
        t.push(Vec3::Y * 2.0, 1);
        t.push(Vec3::Y * 3.0, 2);
        t.push(Vec3::new(1.0, 1.0, 0.0), 1);
        t
    }

    #[test]
    fn reach_is_the_farthest_tip() {
        let t = chain();
        assert_eq!(t.reach(), vec![3.0, 2.0, 1.0, 0.0, 0.0]);
        assert_eq!(t.tips(), 2);
    }

    #[test]
    fn pipe_radii_add_areas() {
        let t = chain();
        let p = LeastCostParams { thickness: Thickness::Pipe, min_radius: 0.1, ..Default::default() };
        let r = t.radii(&p, &t.reach());
        assert!((r[1] * r[1] - (r[2] * r[2] + r[4] * r[4])).abs() < 1e-12);
        assert_eq!(r[3], 0.1);
    }

    #[test]
    fn skeleton_is_parent_first_heaviest_child_first() {
        let t = chain();
        let reach = t.reach();
        let sk = t.to_skeleton(&[0.1; 5], &reach).unwrap();
        assert_eq!(sk.len(), 5);
        assert_eq!(sk.position[2], Vec3::Y * 2.0, "the main axis continues first");
        assert_eq!(sk.order[4], 1);
    }
}
