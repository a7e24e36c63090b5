//! MIG refinement volumes (Xu2015 §4.4.1, Figs. 4.8–4.9; Xu2015-spec §2.5
//! "Refinement"): the level-1 graph of a MIG tree fills spheres and cones instead of
//! the coarse user volume, so the crown breaks up into distinct clusters.
//!
//! 1. `count` sphere centres are thrown as Poisson darts with a large spacing
//!    (`spacing`; 0 = `(0.35·V/count)^{1/3}` of the coarse volume) in the coarse volume
//!    `generator.volume` **without** its trunk primitive.
//! 2. Each centre `C` gets a sphere of `radius` (0 = 0.6 × the centre spacing) and a
//!    cone from `C` (base radius `cone × radius`) to its attach point `A`: on the trunk
//!    primitive's axis (`trunk`, the index of a cylinder or cone in `generator.volume`)
//!    the point nearest `C` (`attach = "nearest"`) or the trunk's top (`"top"`); the
//!    root without a trunk.
//! 3. The union of the trunk, the spheres and the cones is filled with `nodes` Poisson
//!    nodes (one spacing for all). Each node gets one label: [`SHARED`] in the trunk
//!    (and the root), else the sphere + cone subvolume it lies deepest in (smallest
//!    signed distance; ties to the lower index).
//! 4. Edges (the seed's "no edges link nodes within different subvolumes"): the trunk
//!    is a **shared subvolume linkable to every sphere + cone** (the spec's proposal;
//!    the seed leaves the trunk open). The trunk's own Yao graph gives trunk–trunk
//!    edges; for each subvolume `i` the Yao graph of trunk ∪ `i` gives the edges with an
//!    end in `i`. So no edge joins two different subvolumes, and a path from one
//!    sphere to another can only pass through the trunk. Without a trunk the shared
//!    part is the root alone. Out-degree: at most `k` per subvolume a node is linked to.
//! 5. Dijkstra (edge length) runs from the root; each subvolume gets exactly `quota`
//!    endpoints (0 = ⌈`endpoints` / spheres⌉), drawn at random from its reached nodes
//!    in the shell `−d_e ≤ sdf ≤ 0` under its **sphere's** surface (`d_e` =
//!    `generator.shell`, 0 = 3·d). A subvolume with fewer candidates gives all it has,
//!    and the missing count is reported (`report.quota_shortfall`, a warning).
//!
//! Later MIG levels are unchanged (subgraphs at every endpoint, `v_g` away from the root).

use super::graph::{auto_spacing, poisson, spatial_sort, yao, Graph, Primitive, Volume, NONE};
use super::paths::{dijkstra, Length, Search};
use super::{bad, in_range, shuffle, End, LeastCostParams, LeastCostReport, PathTree};
use crate::error::{Error, Result};
use glam::DVec3;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
use std::time::{Duration, Instant};

/// Label of the shared subvolume (the trunk and the root) in [`Refined::label`].
pub const SHARED: u32 = u32::MAX;

/// Most sphere + cone subvolumes.
pub const MAX_SPHERES: usize = 64;

crate::named::mode! {
    /// `generator.refine.attach`: where the cones meet the trunk's axis.
    Attach, key "generator.refine.attach", default Nearest {
        /// The point of the axis nearest the sphere centre.
        Nearest = "nearest",
        /// The top of the trunk.
        Top = "top",
    }
}

/// The `[generator.refine]` keys (see the module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RefineParams {
    /// Sphere centres to throw (the seed: 4–10), 1–64.
    pub count: usize,
    /// Poisson spacing of the centres; 0 = `(0.35·V/count)^{1/3}` of the coarse volume.
    pub spacing: f64,
    /// Sphere radius; 0 = 0.6 × the centre spacing.
    pub radius: f64,
    /// Endpoints per subvolume; 0 = ⌈`generator.endpoints` / spheres⌉.
    pub quota: usize,
    /// Cone radius at the sphere centre as a fraction of the sphere radius, in (0, 1].
    pub cone: f64,
    /// Index in `generator.volume` of the trunk primitive (a cylinder or a cone), the
    /// shared subvolume; none = the cones join the root.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trunk: Option<usize>,
    /// Where the cones meet the trunk's axis: `nearest` (the point nearest the sphere
    /// centre) or `top`.
    pub attach: Attach,
}

impl Default for RefineParams {
    fn default() -> Self {
        RefineParams {
            count: 6,
            spacing: 0.0,
            radius: 0.0,
            quota: 0,
            cone: 0.5,
            trunk: None,
            attach: Attach::Nearest,
        }
    }
}

impl RefineParams {
    /// Checks the keys; errors name them (`generator.refine.count`).
    pub fn validate(&self, p: &LeastCostParams) -> Result<()> {
        if p.method != super::Method::Mig {
            return bad("refine", format!("needs method = \"mig\", not `{}`", p.method));
        }
        if !p.graph_cache.is_empty() {
            return bad(
                "graph_cache",
                "is not supported with `generator.refine` (the refined graph is rebuilt)",
            );
        }
        if self.count == 0 || self.count > MAX_SPHERES {
            return bad("refine.count", format!("must be in 1..={MAX_SPHERES}, got {}", self.count));
        }
        in_range("refine.spacing", self.spacing, 0.0, 1e6)?;
        in_range("refine.radius", self.radius, 0.0, 1e6)?;
        if self.quota > p.nodes {
            return bad(
                "refine.quota",
                format!("must be at most `generator.nodes` = {}, got {}", p.nodes, self.quota),
            );
        }
        in_range("refine.cone", self.cone, 0.01, 1.0)?;
        if let Some(t) = self.trunk {
            match p.volume.get(t) {
                None => {
                    return bad(
                        "refine.trunk",
                        format!(
                            "is {t}, but `generator.volume` has {} primitives (indices from 0)",
                            p.volume.len()
                        ),
                    )
                }
                Some(Primitive::Cylinder { .. } | Primitive::Cone { .. }) => {}
                Some(_) => {
                    return bad(
                        "refine.trunk",
                        format!("must name a cylinder or a cone, volume[{t}] is neither"),
                    )
                }
            }
            if p.volume.len() < 2 {
                return bad(
                    "refine.trunk",
                    "leaves no coarse volume: `generator.volume` needs a crown primitive too",
                );
            }
        }
        Ok(())
    }

    /// The endpoint quota per subvolume with `spheres` subvolumes.
    pub fn quota_for(&self, endpoints: usize, spheres: usize) -> usize {
        if self.quota > 0 {
            self.quota
        } else {
            endpoints.div_ceil(spheres.max(1))
        }
    }
}

/// The refined level-1 graph and its endpoints (exposed for tests).
#[derive(Debug, Clone)]
pub struct Refined {
    /// The graph over the union of the trunk, spheres and cones (root = the tree root).
    pub graph: Graph,
    /// Subvolume of each node: `0..spheres.len()`, or [`SHARED`].
    pub label: Vec<u32>,
    /// The spheres (centre, radius), one per subvolume.
    pub spheres: Vec<(DVec3, f64)>,
    /// Each sphere's cone (`None` when its centre is the attach point).
    pub cones: Vec<Option<Primitive>>,
    /// Dijkstra from the root (edge length).
    pub search: Search,
    /// The endpoints drawn in each subvolume (graph ids).
    pub endpoints: Vec<Vec<u32>>,
    /// The quota per subvolume.
    pub quota: usize,
    /// Endpoints missing from the quotas over all subvolumes.
    pub shortfall: usize,
    /// Warnings (fewer spheres or nodes than asked, quota shortfalls).
    pub warnings: Vec<String>,
    /// Time to place the spheres and build the graph (the rest of [`build`] is paths).
    pub graph_time: Duration,
}

/// The trunk's axis segment (base, top).
fn trunk_axis(t: &Primitive) -> (DVec3, DVec3) {
    let seg = |base: [f64; 3], height: f64, axis: [f64; 3]| {
        let b = DVec3::from_array(base);
        (b, b + DVec3::from_array(axis).normalize_or(DVec3::Y) * height)
    };
    match t {
        Primitive::Cylinder { base, height, axis, .. } | Primitive::Cone { base, height, axis, .. } => {
            seg(*base, *height, *axis)
        }
        _ => {
            let (lo, hi) = t.bounds();
            let c = (lo + hi) / 2.0;
            (DVec3::new(c.x, lo.y, c.z), DVec3::new(c.x, hi.y, c.z))
        }
    }
}

/// Builds the refined level-1 graph, runs Dijkstra and draws the endpoints (module docs).
pub fn build(p: &LeastCostParams, r: &RefineParams, seed: u64) -> Result<Refined> {
    r.validate(p)?;
    let start = Instant::now();
    let mut warnings = Vec::new();
    let trunk = r.trunk.map(|i| p.volume[i].clone());
    let coarse: Vec<Primitive> =
        p.volume.iter().enumerate().filter(|&(i, _)| Some(i) != r.trunk).map(|(_, q)| q.clone()).collect();
    let coarse = Volume::new(coarse);
    let root = p.root.map(DVec3::from_array).unwrap_or_else(|| p.graph_volume().bottom_center(3));

    // 1. Sphere centres: Poisson darts with a large spacing in the coarse volume.
    let m = coarse.measure(3, seed);
    if m.is_nan() || m <= 0.0 {
        return Err(Error::Recipe(
            "`generator.volume` (without the trunk) is empty: no room for refinement spheres".into(),
        ));
    }
    let cs = if r.spacing > 0.0 { r.spacing } else { auto_spacing(m, r.count, 3) };
    let mut rng = Pcg64::seed_from_u64(seed ^ 0x7265_6669_6e65_2031);
    let centres = poisson(&coarse, r.count, cs, None, 3, &mut rng)?;
    if centres.points.is_empty() {
        return bad("refine.spacing", "leaves no room for a single sphere centre in the coarse volume");
    }
    if centres.points.len() < r.count {
        warnings.push(format!(
            "refinement: only {} of the {} sphere centres fit at spacing {cs:.3} (lower `generator.refine.spacing`)",
            centres.points.len(),
            r.count
        ));
    }
    let radius = if r.radius > 0.0 { r.radius } else { 0.6 * cs };

    // 2. Spheres and cones to the trunk (or the root).
    let mut spheres = Vec::new();
    let mut cones = Vec::new();
    for &c in &centres.points {
        let a = match &trunk {
            Some(t) => {
                let (b, top) = trunk_axis(t);
                if r.attach == Attach::Top {
                    top
                } else {
                    let ax = top - b;
                    let s = ((c - b).dot(ax) / ax.length_squared().max(1e-300)).clamp(0.0, 1.0);
                    b + ax * s
                }
            }
            None => root,
        };
        let h = a.distance(c);
        spheres.push((c, radius));
        cones.push((h > 1e-6).then(|| Primitive::Cone {
            base: c.to_array(),
            height: h,
            radius: r.cone * radius,
            axis: ((a - c) / h).to_array(),
        }));
    }
    let subvolumes: Vec<Volume> = spheres
        .iter()
        .zip(&cones)
        .map(|(&(c, rad), cone)| {
            let mut parts = vec![Primitive::Sphere { center: c.to_array(), radius: rad }];
            parts.extend(cone.clone());
            Volume::new(parts)
        })
        .collect();

    // 3. Nodes in the union, one label each.
    let mut all_parts: Vec<Primitive> = trunk.iter().cloned().collect();
    for v in &subvolumes {
        all_parts.extend_from_slice(v.parts());
    }
    let union = Volume::new(all_parts);
    let d = if p.spacing > 0.0 { p.spacing } else { auto_spacing(union.measure(3, seed), p.nodes, 3) };
    let mut rng = Pcg64::seed_from_u64(seed ^ super::GRAPH_STREAM);
    let s = poisson(&union, p.nodes, d, Some(root), 3, &mut rng)?;
    if s.shortfall > 0 {
        warnings.push(format!(
            "the refined level-1 volume holds only {} of the {} nodes",
            s.points.len(),
            p.nodes
        ));
    }
    let (pos, root_id) = spatial_sort(&s.points, d, 0);
    let trunk_vol = trunk.map(|t| Volume::new(vec![t]));
    let label: Vec<u32> = pos
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let q = q.as_dvec3();
            if i as u32 == root_id || trunk_vol.as_ref().is_some_and(|t| t.contains(q)) {
                return SHARED;
            }
            let mut best = (f64::INFINITY, 0u32);
            for (j, v) in subvolumes.iter().enumerate() {
                let sd = v.sdf(q);
                if sd < best.0 {
                    best = (sd, j as u32);
                }
            }
            best.1
        })
        .collect();

    // 4. Edges: the shared part's own Yao graph, then trunk ∪ subvolume i for each i.
    let n = pos.len();
    let mut out: Vec<Vec<u32>> = vec![Vec::new(); n];
    let shared: Vec<u32> = (0..n as u32).filter(|&u| label[u as usize] == SHARED).collect();
    let mut add_group = |members: &[u32], keep_all: bool| {
        let local: Vec<glam::Vec3> = members.iter().map(|&u| pos[u as usize]).collect();
        let g = yao(local, p.sectors, 3, d as f32, 0);
        for (lu, &u) in members.iter().enumerate() {
            for &lv in g.out(lu as u32) {
                let v = members[lv as usize];
                if keep_all || label[u as usize] != SHARED || label[v as usize] != SHARED {
                    out[u as usize].push(v);
                }
            }
        }
    };
    add_group(&shared, true);
    for i in 0..spheres.len() as u32 {
        let members: Vec<u32> =
            (0..n as u32).filter(|&u| label[u as usize] == SHARED || label[u as usize] == i).collect();
        add_group(&members, false);
    }
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0u32);
    let mut targets = Vec::new();
    for mut o in out {
        o.sort_unstable();
        o.dedup();
        targets.extend_from_slice(&o);
        offsets.push(targets.len() as u32);
    }
    let graph = Graph {
        dims: 3,
        position: pos,
        offsets,
        targets,
        root: root_id,
        spacing: d as f32,
        shortfall: s.shortfall,
    };

    let graph_time = start.elapsed();

    // 5. Dijkstra and the quotas.
    let search = dijkstra(&graph, &[graph.root], None, &mut Length);
    let quota = r.quota_for(p.endpoints, spheres.len());
    let de = if p.shell > 0.0 { p.shell } else { 3.0 * d };
    let mut shortfall = 0;
    let mut endpoints = Vec::new();
    for (i, &(c, rad)) in spheres.iter().enumerate() {
        let mut cand: Vec<u32> = (0..n as u32)
            .filter(|&u| {
                let sd = graph.position[u as usize].as_dvec3().distance(c) - rad;
                label[u as usize] == i as u32 && search.reached(u) && sd <= 0.0 && sd >= -de
            })
            .collect();
        let mut rng =
            Pcg64::seed_from_u64(seed ^ 0x0071_756f_7461 ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        shuffle(&mut cand, &mut rng);
        if cand.len() < quota {
            shortfall += quota - cand.len();
            warnings.push(format!(
                "refinement sphere {i} has only {} endpoint candidates for its quota of {quota} (raise `generator.nodes` or `generator.shell`)",
                cand.len()
            ));
        }
        cand.truncate(quota);
        endpoints.push(cand);
    }
    Ok(Refined { graph, label, spheres, cones, search, endpoints, quota, shortfall, warnings, graph_time })
}

/// MIG level 1 in the refined volume: the path union of every subvolume's endpoints and
/// the endpoints for level 2 (see [`super::mig`]).
pub(crate) fn level1(
    p: &LeastCostParams,
    r: &RefineParams,
    seed: u64,
    report: &mut LeastCostReport,
) -> Result<(PathTree, Vec<End>)> {
    let t = Instant::now();
    let rf = build(p, r, seed)?;
    let g = &rf.graph;
    report.graph_time += rf.graph_time;
    report.path_time += t.elapsed().saturating_sub(rf.graph_time);
    report.graph_nodes = g.len();
    report.graph_edges = g.edge_count();
    report.graph_bytes = g.bytes();
    report.shortfall = g.shortfall;
    report.unreachable = (0..g.len() as u32).filter(|&u| !rf.search.reached(u)).count();
    report.subvolumes = rf.spheres.len();
    report.quota_shortfall = rf.shortfall;
    report.warnings.extend(rf.warnings.iter().cloned());
    let mut tree = PathTree::default();
    let mut map = vec![NONE; g.len()];
    map[g.root as usize] = tree.push(g.position[g.root as usize], NONE);
    let root = g.position[g.root as usize].as_dvec3();
    let mut ends = Vec::new();
    for &e in rf.endpoints.iter().flatten() {
        let node = super::forest::add_path(&mut tree, &mut map, g, &rf.search.parent, e);
        ends.push(End { node, pos: g.position[e as usize].as_dvec3(), root });
    }
    report.trees = 1;
    Ok((tree, ends))
}
