//! MGV — modified guiding vectors (Xu2015 Ch. 5; Xu2015-spec §2.6): one Yao graph whose
//! edge weights follow guiding vectors that Dijkstra sets lazily, over several
//! iterations that each grow the tree from the whole current tree.
//!
//! # Guiding vectors (§5.2.1–§5.2.2)
//!
//! The root's guide is `up` (+Y). When Dijkstra settles a node `u` reached from `p`, `u`
//! gets `rotate(p.guide, α(h))` (`h` = edges from the iteration's source, sources have
//! `h = 0`), and `u`'s out-edges then weigh `d_E·(1 − ê_E·v̂_u)`
//! ([`paths::mgv_weight`](super::paths::mgv_weight)). Sources keep their guides.
//!
//! **Rotation axis** (Xu2015-spec §2.6, §7.2): `axis = normalize(up × ê_{p→u})` (the edge
//! form of §5.3.1; `generator.axis = "edge"`, the default) and Rodrigues' formula in
//! `f64`. A positive α tilts a vertical guide towards the edge's horizontal direction and
//! turns a horizontal guide downward (Fig. 5.4). When `|up × ê| < 1e-6` (a vertical
//! edge) the axis falls back to `up × p.guide`, then to `up × horizontal(u − root)`,
//! and else the guide is copied unrotated. `generator.axis = "guide"` uses §5.2.2's
//! `up × p.guide` first (then the edge, then the horizontal offset) — degenerate while
//! the guide is vertical, which is why it is not the default.
//!
//! # Rotation rules (§5.3.1), `rotation.rule`
//!
//! | rule | α (degrees) |
//! |---|---|
//! | `constant` | `alpha` |
//! | `two-phase` | Eq. 5.1: `alpha1` if `h ≤ h0`, else `alpha2` |
//! | `random` | `alpha1 ~ U[alpha1, alpha1_max]` per node (a hash of seed and node), `alpha2` after `h0` |
//! | `eq52` | Eq. 5.2: `θ·√(β/π)`, β the angle between `u − root` and up |
//! | `height` | `alpha1 = 180·(1 − N.y/H)` if `h ≤ h0`, else `alpha2`; N the source node, H the current tree's height above the root (the graph's height while the tree is the root alone) |
//! | `helical`, `rotational`, `spherical` | no rotation: the guide is a field at `u` (Fig. 5.7): circles about the vertical axis through the root (`rotational`), the same tilted up by `pitch` (`helical`, `v = normalize(t + pitch·up)`), or the upward meridian of the sphere about the root (`spherical`); `up` where the field vanishes |
//!
//! A regional rule (Table 6.1 l) is `lower`: that rule applies to nodes whose **source**
//! is below `region_height` (so a branch keeps one rule).
//!
//! # Iterations (§5.2.4) and endpoints (§5.3.2–§5.3.3)
//!
//! Each iteration resets every non-tree node (no guide, parent or distance), runs
//! Dijkstra from all tree nodes at once (cost 0, hop 0) and appends the paths of its
//! endpoints, each path from the endpoint back to the tree node it starts at (its
//! *source*). `endpoints`:
//!
//! - `point`: the reached node nearest `target` (the trunk of iteration 1);
//! - `volume`: `count` random reached nodes inside `crown`, at least `min_distance`
//!   apart (Poisson-disc spaced; 0 = `(0.35·V/count)^{1/3}` from the crown's volume);
//! - `surface` (late endpoints): the reached nodes exactly `hops` edges from the tree
//!   in this iteration's forest, ranked by hops from the root (tree depth of the
//!   source + `hops`; ties by a seeded hash), the outermost `⌈outer_fraction·|S_k|⌉`
//!   kept, then `count` drawn at random;
//! - `none`.
//!
//! `direction = "lower"` / `"higher"` keeps only candidates below / above their source
//! (hanging branches, Fig. 5.12; upward ones, Table 6.1 f). The filter bites where
//! sources differ in height: in iteration 1 the only source is the root at the bottom,
//! so every crown node is already higher than it; from iteration 2 on the sources are
//! tree nodes at every height.
//!
//! An iteration that gets fewer endpoints than it asks for (`point`: 1, `volume` /
//! `surface`: `count`) records why in [`MgvState::shortfall`], and [`grow`] reports it
//! as a warning naming the counts, the cause and the key to change.

use super::graph::{Graph, Primitive, Volume, NONE};
use super::paths::{dijkstra_until, mgv_weight, Costs, Search, Until};
use super::{bad, hash01, in_range, main_graph, shuffle, LeastCostParams, LeastCostReport, PathTree};
use crate::error::Result;
use glam::{DVec3, Vec3};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

crate::named::mode! {
    /// `rule` of an iteration's `rotation` / `lower` table: how the guide turns (see the
    /// module docs).
    RotationRule, key "generator.iterations.rotation.rule", default Constant {
        /// α for every edge.
        Constant = "constant",
        /// Eq. 5.1: α₁ while `h ≤ h0`, then α₂.
        TwoPhase = "two-phase",
        /// Eq. 5.1 with α₁ drawn per node in [α₁, `alpha1_max`].
        Random = "random",
        /// Eq. 5.2 from θ and the angle to the vertical.
        Eq52 = "eq52",
        /// Eq. 5.1 with α₁ = 180°·(1 − N.y/H) from the source's height.
        Height = "height",
        /// Field: circles about the vertical through the root, tilted up by `pitch`.
        Helical = "helical",
        /// Field: circles about the vertical through the root.
        Rotational = "rotational",
        /// Field: the upward meridian of the sphere about the root.
        Spherical = "spherical",
    }
}

crate::named::mode! {
    /// `generator.iterations[].endpoints`: where an iteration's endpoints come from.
    EndpointRule, key "generator.iterations.endpoints", default Surface {
        /// One endpoint, `target`.
        Point = "point",
        /// `count` endpoints drawn inside `crown`.
        Volume = "volume",
        /// `count` endpoints near the tree's outer surface (`hops`, `outer_fraction`).
        Surface = "surface",
        /// No endpoints (the iteration only re-weights).
        None = "none",
    }
}

crate::named::mode! {
    /// `generator.iterations[].direction`: endpoints kept relative to their source.
    Direction, key "generator.iterations.direction", default Any {
        /// Every endpoint.
        Any = "any",
        /// Endpoints lower than their source.
        Lower = "lower",
        /// Endpoints higher than their source.
        Higher = "higher",
    }
}

crate::named::mode! {
    /// `generator.axis`: which axis form of the guide's rotation to try first.
    AxisRule, key "generator.axis", default Edge {
        /// `up × ê` first (Xu2015-spec's recommendation).
        Edge = "edge",
        /// `up × parent guide` first (§5.2.2).
        Guide = "guide",
    }
}

/// A rotation rule (the `rotation` / `lower` tables of an iteration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Rotation {
    /// `constant`, `two-phase`, `random`, `eq52`, `height`, `helical`, `rotational` or
    /// `spherical` (see the module docs).
    pub rule: RotationRule,
    /// α of `constant` (degrees).
    pub alpha: f64,
    /// α₁ of `two-phase`, lower bound of `random` (degrees).
    pub alpha1: f64,
    /// Upper bound of α₁ for `random` (degrees).
    pub alpha1_max: f64,
    /// α₂ (degrees).
    pub alpha2: f64,
    /// h₀: α₁ applies while `h ≤ h0`.
    pub h0: u32,
    /// θ of Eq. 5.2 (degrees).
    pub theta: f64,
    /// Rise per unit of tangent of the `helical` field.
    pub pitch: f64,
}

impl Default for Rotation {
    fn default() -> Self {
        Rotation {
            rule: RotationRule::Constant,
            alpha: 0.0,
            alpha1: 30.0,
            alpha1_max: 120.0,
            alpha2: 0.0,
            h0: 1,
            theta: 25.0,
            pitch: 0.5,
        }
    }
}

impl Rotation {
    /// `constant`: α for every edge (0 = guides stay as they are).
    pub fn constant(alpha: f64) -> Rotation {
        Rotation { rule: RotationRule::Constant, alpha, ..Default::default() }
    }

    /// `two-phase` (Eq. 5.1): α₁ while `h ≤ h0`, then α₂.
    pub fn two_phase(alpha1: f64, alpha2: f64, h0: u32) -> Rotation {
        Rotation { rule: RotationRule::TwoPhase, alpha1, alpha2, h0, ..Default::default() }
    }

    fn validate(&self, key: &str) -> Result<()> {
        for (k, v) in [
            ("alpha", self.alpha),
            ("alpha1", self.alpha1),
            ("alpha1_max", self.alpha1_max),
            ("alpha2", self.alpha2),
            ("theta", self.theta),
        ] {
            in_range(&format!("{key}.{k}"), v, -360.0, 360.0)?;
        }
        in_range(&format!("{key}.pitch"), self.pitch, -100.0, 100.0)?;
        if self.rule == RotationRule::Random && self.alpha1_max < self.alpha1 {
            return bad(
                &format!("{key}.alpha1_max"),
                format!("must be ≥ alpha1 ({}), got {}", self.alpha1, self.alpha1_max),
            );
        }
        Ok(())
    }

    /// Whether the rule sets the guide from a field instead of rotating it.
    fn is_field(&self) -> bool {
        matches!(self.rule, RotationRule::Helical | RotationRule::Rotational | RotationRule::Spherical)
    }
}

/// One MGV iteration (a `[[generator.iterations]]` entry).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MgvIteration {
    /// The rotation rule.
    pub rotation: Rotation,
    /// Rule for nodes whose source is below `region_height` (Table 6.1 l).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lower: Option<Rotation>,
    /// Height splitting `rotation` (above) from `lower` (below).
    pub region_height: f64,
    /// `point`, `volume`, `surface` or `none`.
    pub endpoints: EndpointRule,
    /// Endpoints to draw (`volume`, `surface`).
    pub count: usize,
    /// The `point` endpoint's target.
    pub target: [f64; 3],
    /// The `volume` endpoints' crown (a union of primitives).
    pub crown: Vec<Primitive>,
    /// Smallest distance between `volume` endpoints (0 = from the crown's volume).
    pub min_distance: f64,
    /// k of the `surface` endpoints (edges from the tree).
    pub hops: u32,
    /// t of the `surface` endpoints, in (0, 1].
    pub outer_fraction: f64,
    /// `any`, `lower` or `higher` than the endpoint's source.
    pub direction: Direction,
}

impl Default for MgvIteration {
    fn default() -> Self {
        MgvIteration {
            rotation: Rotation::default(),
            lower: None,
            region_height: 0.0,
            endpoints: EndpointRule::Surface,
            count: 1000,
            target: [0.0, 5.0, 0.0],
            crown: Vec::new(),
            min_distance: 0.0,
            hops: 5,
            outer_fraction: 0.6,
            direction: Direction::Any,
        }
    }
}

/// The default iterations: a straight trunk to `[0, 4, 0]`, crown endpoints with
/// (30°, 0, 1), then two rounds of surface endpoints with (30°, 0, 1).
pub fn default_iterations() -> Vec<MgvIteration> {
    let fork = Rotation::two_phase(30.0, 0.0, 1);
    vec![
        MgvIteration {
            endpoints: EndpointRule::Point,
            target: [0.0, 4.0, 0.0],
            rotation: Rotation::constant(0.0),
            ..Default::default()
        },
        MgvIteration {
            endpoints: EndpointRule::Volume,
            count: 40,
            crown: vec![Primitive::HalfEllipsoid {
                center: [0.0, 4.0, 0.0],
                radii: [4.0, 5.0, 4.0],
                axis: [0.0, 1.0, 0.0],
            }],
            rotation: Rotation::two_phase(10.0, 0.0, 1000),
            ..Default::default()
        },
        MgvIteration {
            endpoints: EndpointRule::Surface,
            count: 300,
            rotation: fork.clone(),
            ..Default::default()
        },
        MgvIteration { endpoints: EndpointRule::Surface, count: 600, rotation: fork, ..Default::default() },
    ]
}

/// Checks the MGV keys.
pub fn validate(p: &LeastCostParams) -> Result<()> {
    in_range("epsilon", p.epsilon, 0.0, 10.0)?;
    if p.iterations.len() > 32 {
        return bad("iterations", format!("has {} entries; at most 32", p.iterations.len()));
    }
    for (i, it) in p.iterations.iter().enumerate() {
        let k = format!("iterations[{i}]");
        it.rotation.validate(&format!("{k}.rotation"))?;
        if let Some(l) = &it.lower {
            l.validate(&format!("{k}.lower"))?;
        }
        in_range(&format!("{k}.region_height"), it.region_height, -1e6, 1e6)?;
        if it.count > p.nodes && matches!(it.endpoints, EndpointRule::Volume | EndpointRule::Surface) {
            return bad(
                &format!("{k}.count"),
                format!("is {}, more than the graph's {} nodes", it.count, p.nodes),
            );
        }
        for v in it.target {
            in_range(&format!("{k}.target"), v, -1e6, 1e6)?;
        }
        if it.endpoints == EndpointRule::Volume && it.crown.is_empty() {
            return bad(&format!("{k}.crown"), "needs at least one primitive for `volume` endpoints");
        }
        for (j, c) in it.crown.iter().enumerate() {
            c.validate(&format!("generator.{k}.crown[{j}]"))?;
        }
        in_range(&format!("{k}.min_distance"), it.min_distance, 0.0, 1e6)?;
        if it.hops == 0 || it.hops > 10_000 {
            return bad(&format!("{k}.hops"), format!("must be in 1..=10000, got {}", it.hops));
        }
        finite(&format!("{k}.outer_fraction"), it.outer_fraction)?;
        if !(it.outer_fraction > 0.0 && it.outer_fraction <= 1.0) {
            return bad(
                &format!("{k}.outer_fraction"),
                format!("must be in (0, 1], got {}", it.outer_fraction),
            );
        }
    }
    Ok(())
}

use super::finite;

/// Rotates `guide` by `alpha` radians about the rule's axis (see the module docs), in
/// `f64`; returns a unit vector (the guide unrotated when every axis is degenerate).
pub fn rotate_guide(
    guide: DVec3,
    edge: DVec3,
    offset: DVec3,
    alpha: f64,
    up: DVec3,
    rule: AxisRule,
) -> DVec3 {
    let g = guide.normalize_or(up);
    if alpha == 0.0 {
        return g;
    }
    let horiz = offset - up * offset.dot(up);
    let cands = match rule {
        AxisRule::Edge => {
            [up.cross(edge.normalize_or_zero()), up.cross(g), up.cross(horiz.normalize_or_zero())]
        }
        AxisRule::Guide => {
            [up.cross(g), up.cross(edge.normalize_or_zero()), up.cross(horiz.normalize_or_zero())]
        }
    };
    let Some(axis) = cands.into_iter().find(|a| a.length() >= 1e-6).map(DVec3::normalize) else {
        return g;
    };
    // Rodrigues: v cosα + (k × v) sinα + k (k·v)(1 − cosα)
    let (s, c) = alpha.sin_cos();
    (g * c + axis.cross(g) * s + axis * axis.dot(g) * (1.0 - c)).normalize_or(g)
}

/// Eq. 5.2: `α = θ·√(β/π)` (radians in, radians out).
pub fn eq52(theta: f64, beta: f64) -> f64 {
    // Xu2015, Eq. 5.2
    theta * (beta.clamp(0.0, std::f64::consts::PI) / std::f64::consts::PI).sqrt()
}

/// Eq. 5.1: `α₁` while `h ≤ h₀`, else `α₂`.
pub fn eq51(alpha1: f64, alpha2: f64, h0: u32, h: u32) -> f64 {
    // Xu2015, Eq. 5.1
    if h <= h0 {
        alpha1
    } else {
        alpha2
    }
}

struct MgvCosts<'a> {
    guide: Vec<Vec3>,
    rule: &'a Rotation,
    lower: Option<&'a Rotation>,
    region_height: f32,
    root: DVec3,
    height: f64,
    seed: u64,
    epsilon: f32,
    axis: AxisRule,
}

impl MgvCosts<'_> {
    fn field(&self, rule: &Rotation, p: DVec3) -> DVec3 {
        let up = DVec3::Y;
        let r = p - self.root;
        let radial = DVec3::new(r.x, 0.0, r.z);
        match rule.rule {
            RotationRule::Spherical => {
                let rn = r.normalize_or_zero();
                (up - rn * up.dot(rn)).normalize_or(up)
            }
            _ => {
                let t = up.cross(radial).normalize_or_zero();
                if t == DVec3::ZERO {
                    return up;
                }
                if rule.rule == RotationRule::Helical {
                    (t + up * rule.pitch).normalize_or(up)
                } else {
                    t
                }
            }
        }
    }
}

impl Costs for MgvCosts<'_> {
    fn settle(&mut self, g: &Graph, u: u32, parent: u32, hops: u32, source: u32) {
        self.settle_at(g, u, g.position[u as usize], parent, hops, source);
    }

    fn settle_at(&mut self, g: &Graph, u: u32, pu: Vec3, parent: u32, hops: u32, source: u32) {
        if parent == NONE {
            if self.guide[u as usize] == Vec3::ZERO {
                self.guide[u as usize] = Vec3::Y;
            }
            return;
        }
        let pu = pu.as_dvec3();
        // The source's position is read only by the rules that need it.
        let src = || g.position[source as usize];
        let rule = match self.lower {
            Some(l) if src().y < self.region_height => l,
            _ => self.rule,
        };
        let new = if rule.is_field() {
            self.field(rule, pu)
        } else {
            let deg = match rule.rule {
                RotationRule::Constant => rule.alpha,
                RotationRule::TwoPhase => eq51(rule.alpha1, rule.alpha2, rule.h0, hops),
                RotationRule::Random => {
                    let a1 = rule.alpha1
                        + (rule.alpha1_max - rule.alpha1) * hash01(self.seed, u as u64, 0x7261_6e64);
                    eq51(a1, rule.alpha2, rule.h0, hops)
                }
                RotationRule::Eq52 => {
                    let beta = (pu - self.root).angle_between(DVec3::Y);
                    let beta = if beta.is_finite() { beta } else { 0.0 };
                    eq52(rule.theta.to_radians(), beta).to_degrees()
                }
                // The field rules do not rotate (`is_field` above).
                RotationRule::Height
                | RotationRule::Helical
                | RotationRule::Rotational
                | RotationRule::Spherical => {
                    // `height`: α₁ = 180°·(1 − N.y/H), N the source node.
                    let ny = (src().as_dvec3() - self.root).y;
                    let a1 = 180.0 * (1.0 - ny / self.height);
                    eq51(a1, rule.alpha2, rule.h0, hops)
                }
            };
            let pp = g.position[parent as usize].as_dvec3();
            rotate_guide(
                self.guide[parent as usize].as_dvec3(),
                pu - pp,
                pu - self.root,
                deg.to_radians(),
                DVec3::Y,
                self.axis,
            )
        };
        self.guide[u as usize] = new.as_vec3();
    }

    fn weight(&self, g: &Graph, u: u32, v: u32, _edge: usize) -> f32 {
        mgv_weight(g.position[v as usize] - g.position[u as usize], self.guide[u as usize], self.epsilon)
    }

    fn prefetch(&self, u: u32, parent: u32) {
        super::graph::prefetch(&self.guide, parent as usize);
        super::graph::prefetch(&self.guide, u as usize);
    }

    #[inline]
    fn weight_at(&self, _g: &Graph, u: u32, pu: Vec3, _v: u32, pv: Vec3, _edge: usize) -> f32 {
        mgv_weight(pv - pu, self.guide[u as usize], self.epsilon)
    }
}

/// The state of an MGV run between iterations (exposed for tests).
#[derive(Debug, Clone)]
pub struct MgvState {
    /// Whether a graph node is in the tree.
    pub in_tree: Vec<bool>,
    /// Tree parent of each tree node (`NONE` for the root and non-tree nodes).
    pub parent: Vec<u32>,
    /// Guides of tree nodes (zero elsewhere).
    pub guide: Vec<Vec3>,
    /// Edges from the root along the tree, for tree nodes.
    pub depth: Vec<u32>,
    /// Tree nodes in insertion order (parents first).
    pub nodes: Vec<u32>,
    /// Endpoints of each iteration.
    pub endpoints: Vec<Vec<u32>>,
    /// The last iteration's search.
    pub last: Option<Search>,
    /// Nodes reachable from the root through out-edges.
    pub reachable: Vec<bool>,
    /// Per iteration: why it got fewer endpoints than it asked for ([`asked`]), with the
    /// key to change; `None` when it got them all.
    pub shortfall: Vec<Option<String>>,
}

impl MgvState {
    /// A tree holding the graph's root with guide `up`.
    pub fn new(g: &Graph) -> MgvState {
        MgvState::with_roots(g, &[g.root])
    }

    /// A tree (a forest) holding the given root nodes, each with guide `up`;
    /// reachability from all of them.
    pub fn with_roots(g: &Graph, roots: &[u32]) -> MgvState {
        let n = g.len();
        let mut s = MgvState {
            in_tree: vec![false; n],
            parent: vec![NONE; n],
            guide: vec![Vec3::ZERO; n],
            depth: vec![0; n],
            nodes: Vec::with_capacity(roots.len()),
            endpoints: Vec::new(),
            last: None,
            reachable: g.reachable(roots),
            shortfall: Vec::new(),
        };
        for &r in roots {
            if !s.in_tree[r as usize] {
                s.in_tree[r as usize] = true;
                s.guide[r as usize] = Vec3::Y;
                s.nodes.push(r);
            }
        }
        s
    }

    /// Runs one iteration (see the module docs).
    pub fn iterate(&mut self, g: &Graph, it: &MgvIteration, p: &LeastCostParams, seed: u64, index: usize) {
        let root = g.position[g.root as usize].as_dvec3();
        let tree_top = self.nodes.iter().map(|&u| g.position[u as usize].y as f64).fold(root.y, f64::max);
        let mut height = tree_top - root.y;
        if height <= 1e-9 {
            height = g.position.iter().map(|q| q.y as f64).fold(root.y, f64::max) - root.y;
        }
        let mut guide = super::graph::huge_capacity(self.guide.len());
        guide.extend_from_slice(&self.guide);
        let mut costs = MgvCosts {
            guide,
            rule: &it.rotation,
            lower: it.lower.as_ref(),
            region_height: it.region_height as f32,
            root,
            height: height.max(1e-9),
            seed: seed ^ index as u64,
            epsilon: p.epsilon as f32,
            axis: p.axis,
        };
        // The search stops as soon as the endpoint candidates are final (see
        // `paths::Until`; the endpoints and their paths are those of a full search). A
        // `point` endpoint is known before the search (the reachable non-tree node
        // nearest the target): stop once it is settled. `volume` candidates are the
        // reachable non-tree nodes in the crown: stop once all are settled. `surface`
        // candidates are the nodes exactly `hops` edges out: stop once every node with
        // at most `hops` edges is settled. `none` stops after the first settle.
        let crown_flags: Vec<bool>;
        // Which nodes the `volume` crown contains (one parallel pass, used for the early
        // stop and again for the candidates).
        let inside: Option<Vec<bool>> = (it.endpoints == EndpointRule::Volume).then(|| {
            let crown = Volume::new(it.crown.clone());
            g.position.par_iter().map(|q| crown.contains(q.as_dvec3())).collect()
        });
        let until = if it.endpoints == EndpointRule::Point && it.direction == Direction::Any {
            let t = DVec3::from_array(it.target).as_vec3();
            let nearest = (0..g.len() as u32)
                .filter(|&v| self.reachable[v as usize] && !self.in_tree[v as usize])
                .min_by(|&a, &b| {
                    g.position[a as usize]
                        .distance_squared(t)
                        .total_cmp(&g.position[b as usize].distance_squared(t))
                        .then(a.cmp(&b))
                })
                .unwrap_or(NONE);
            Until::Node(nearest)
        } else if let Some(inside) = &inside {
            crown_flags = (0..g.len()).map(|v| self.reachable[v] && !self.in_tree[v] && inside[v]).collect();
            Until::Settled(&crown_flags)
        } else if it.endpoints == EndpointRule::Surface {
            Until::Hops(it.hops)
        } else if it.endpoints == EndpointRule::None {
            Until::Settled(&[])
        } else {
            // A `point` with a direction filter.
            Until::Never
        };
        let search = dijkstra_until(g, &self.nodes, None, &mut costs, until);
        let guide = costs.guide;
        let mut rng =
            Pcg64::seed_from_u64(seed ^ 0x656e_6470_6f69_6e74 ^ (index as u64).wrapping_mul(0x9e37_79b9));
        let (ends, why) = self.choose_in(g, it, &search, seed, index, &mut rng, inside.as_deref());
        self.shortfall.push((ends.len() < asked(it)).then_some(why));
        for &e in &ends {
            let path = search.path(e);
            // path: e … source; add from the source side.
            for w in path.windows(2).rev() {
                let (child, par) = (w[0], w[1]);
                if self.in_tree[child as usize] {
                    continue;
                }
                self.in_tree[child as usize] = true;
                self.parent[child as usize] = par;
                self.guide[child as usize] = guide[child as usize];
                self.depth[child as usize] = self.depth[par as usize] + 1;
                self.nodes.push(child);
            }
        }
        self.endpoints.push(ends);
        self.last = Some(search);
    }

    /// Candidates passing the direction filter.
    fn direction_ok(g: &Graph, it: &MgvIteration, s: &Search, v: u32) -> bool {
        let y = g.position[v as usize].y;
        let sy = g.position[s.source[v as usize] as usize].y;
        match it.direction {
            Direction::Lower => y < sy,
            Direction::Higher => y > sy,
            Direction::Any => true,
        }
    }

    /// The endpoints of one iteration (see the module docs).
    pub fn choose(
        &self,
        g: &Graph,
        it: &MgvIteration,
        s: &Search,
        seed: u64,
        index: usize,
        rng: &mut Pcg64,
    ) -> Vec<u32> {
        self.choose_in(g, it, s, seed, index, rng, None).0
    }

    /// [`MgvState::choose`], given which nodes the `volume` crown contains when known
    /// (`inside[v] == crown.contains(position v)`, saving that test per node), with the
    /// reason to report should there be fewer endpoints than [`asked`].
    #[allow(clippy::too_many_arguments)]
    fn choose_in(
        &self,
        g: &Graph,
        it: &MgvIteration,
        s: &Search,
        seed: u64,
        index: usize,
        rng: &mut Pcg64,
        inside: Option<&[bool]>,
    ) -> (Vec<u32>, String) {
        let name = |k: &str| format!("generator.iterations[{index}].{k}");
        let dir = match it.direction {
            Direction::Any => String::new(),
            d => format!(" and {d} than their source"),
        };
        let fresh = |v: u32| s.reached(v) && !self.in_tree[v as usize] && Self::direction_ok(g, it, s, v);
        match it.endpoints {
            EndpointRule::Point => {
                let t = DVec3::from_array(it.target).as_vec3();
                let best = s.order.iter().copied().filter(|&v| fresh(v)).min_by(|&a, &b| {
                    g.position[a as usize]
                        .distance_squared(t)
                        .total_cmp(&g.position[b as usize].distance_squared(t))
                        .then(a.cmp(&b))
                });
                let why = if it.direction == Direction::Any {
                    "no reachable graph node lies outside the tree; raise `generator.nodes`".to_string()
                } else {
                    format!("no reachable graph node outside the tree{dir}; change `{}`", name("direction"))
                };
                (best.into_iter().collect(), why)
            }
            EndpointRule::Volume => {
                let crown = Volume::new(it.crown.clone());
                let contains = |v: u32| match inside {
                    Some(f) => f[v as usize],
                    None => crown.contains(g.position[v as usize].as_dvec3()),
                };
                let mut cand: Vec<u32> = (0..g.len() as u32).filter(|&v| fresh(v) && contains(v)).collect();
                let candidates = cand.len();
                shuffle(&mut cand, rng);
                let dmin = if it.min_distance > 0.0 {
                    it.min_distance
                } else {
                    let m = crown.measure(g.dims, seed);
                    super::graph::auto_spacing(m, it.count.max(1), g.dims)
                } as f32;
                // Accepted endpoints hashed by cell of size dmin: only the 27 cells
                // around a candidate can hold one closer than dmin (lookups only, so
                // the map's order never matters).
                let mut near: HashMap<(i32, i32, i32), Vec<u32>> = HashMap::new();
                let key = |p: Vec3| {
                    let c = (p / dmin.max(1e-9)).floor();
                    (c.x as i32, c.y as i32, c.z as i32)
                };
                let mut out: Vec<u32> = Vec::new();
                for v in cand {
                    if out.len() >= it.count {
                        break;
                    }
                    let pv = g.position[v as usize];
                    let (kx, ky, kz) = key(pv);
                    let mut ok = true;
                    'cells: for dz in -1..=1 {
                        for dy in -1..=1 {
                            for dx in -1..=1 {
                                if let Some(list) = near.get(&(kx + dx, ky + dy, kz + dz)) {
                                    if list.iter().any(|&o| g.position[o as usize].distance(pv) < dmin) {
                                        ok = false;
                                        break 'cells;
                                    }
                                }
                            }
                        }
                    }
                    if ok {
                        near.entry((kx, ky, kz)).or_default().push(v);
                        out.push(v);
                    }
                }
                let why = if candidates < it.count {
                    format!(
                        "only {candidates} reachable graph nodes outside the tree lie in the crown{dir}; \
                         enlarge `{}` or raise `generator.nodes`, or lower `{}`",
                        name("crown"),
                        name("count")
                    )
                } else {
                    let set = if it.min_distance > 0.0 { "" } else { ", from the crown's volume" };
                    format!(
                        "endpoints at least {dmin:.4} apart{set} fit only {} of the {candidates} candidates in \
                         the crown; lower `{}` or `{}`",
                        out.len(),
                        name("min_distance"),
                        name("count")
                    )
                };
                (out, why)
            }
            EndpointRule::Surface => {
                let k = it.hops;
                let mut ring: Vec<(u32, u64, u32)> = (0..g.len() as u32)
                    .filter(|&v| s.reached(v) && !self.in_tree[v as usize] && s.hops[v as usize] == k)
                    .map(|v| {
                        let rank = self.depth[s.source[v as usize] as usize] + k;
                        let tie =
                            (hash01(seed ^ index as u64, v as u64, 0x7469_6573) * (1u64 << 52) as f64) as u64;
                        (rank, tie, v)
                    })
                    .collect();
                // Outermost first.
                ring.sort_unstable_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
                let keep = ((it.outer_fraction * ring.len() as f64).ceil() as usize).min(ring.len());
                let mut cand: Vec<u32> =
                    ring[..keep].iter().map(|r| r.2).filter(|&v| Self::direction_ok(g, it, s, v)).collect();
                let why = if ring.is_empty() {
                    format!(
                        "no reachable graph node lies exactly {k} hops from the tree; lower `{}`",
                        name("hops")
                    )
                } else {
                    let filtered = if it.direction == Direction::Any {
                        String::new()
                    } else {
                        format!(", {} of them {} than their source", cand.len(), it.direction)
                    };
                    format!(
                        "{} graph nodes lie exactly {k} hops from the tree and `outer_fraction` {} keeps the \
                         outermost {keep}{filtered}; raise `{}` (at most 1) or `generator.nodes`, or lower `{}`",
                        ring.len(),
                        it.outer_fraction,
                        name("outer_fraction"),
                        name("count")
                    )
                };
                cand.sort_unstable();
                shuffle(&mut cand, rng);
                cand.truncate(it.count);
                (cand, why)
            }
            EndpointRule::None => (Vec::new(), String::new()),
        }
    }
}

/// Grows an MGV tree as a path union over the graph; with `generator.roots`, a forest:
/// every root starts in the tree, and roots that won no endpoint are dropped
/// ([`super::forest`]).
pub fn grow(
    p: &LeastCostParams,
    seed: u64,
    base: Option<&Path>,
    report: &mut LeastCostReport,
) -> Result<PathTree> {
    let g = main_graph(p, seed, base, report)?;
    if g.shortfall > 0 {
        report.warnings.push(format!(
            "the graph volume holds only {} of the {} nodes at spacing {:.4}",
            g.len(),
            p.nodes,
            g.spacing
        ));
    }
    let t = Instant::now();
    let roots = if p.roots.is_empty() { vec![g.root] } else { super::forest::root_nodes(p, &g)? };
    let defaults;
    let iters = if p.iterations.is_empty() {
        defaults = default_iterations();
        &defaults
    } else {
        &p.iterations
    };
    let mut st = MgvState::with_roots(&g, &roots);
    report.unreachable = st.reachable.iter().filter(|r| !**r).count();
    for (i, it) in iters.iter().enumerate() {
        st.iterate(&g, it, p, seed, i);
        if let Some(why) = &st.shortfall[i] {
            let at = if p.iterations.is_empty() {
                "of the defaults; set `generator.iterations` to change them".to_string()
            } else {
                format!("`generator.iterations[{i}]`")
            };
            report.warnings.push(format!(
                "MGV iteration {} ({at}) asked for {} endpoints and got {}: {why}",
                i + 1,
                asked(it),
                st.endpoints[i].len()
            ));
        }
    }
    report.endpoints = st.endpoints.iter().map(Vec::len).sum();
    report.path_time = t.elapsed();
    let tree = tree_of(&g, &st);
    Ok(if p.roots.is_empty() { tree } else { super::forest::drop_lone_roots(&tree, report) })
}

/// The endpoints an iteration asks for: 1 for `point`, `count` for `volume` and
/// `surface`, 0 for `none`.
pub fn asked(it: &MgvIteration) -> usize {
    match it.endpoints {
        EndpointRule::Point => 1,
        EndpointRule::Volume | EndpointRule::Surface => it.count,
        EndpointRule::None => 0,
    }
}

/// The path union of an MGV state as a [`PathTree`] (graph ids compacted in tree order).
pub fn tree_of(g: &Graph, st: &MgvState) -> PathTree {
    let mut id = vec![NONE; g.len()];
    let mut t = PathTree::default();
    for &u in &st.nodes {
        let par = st.parent[u as usize];
        let pid = if par == NONE { NONE } else { id[par as usize] };
        id[u as usize] = t.push(g.position[u as usize], pid);
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_signs_follow_fig_5_4() {
        let up = DVec3::Y;
        let v = rotate_guide(up, DVec3::X, DVec3::X, 0.3, up, AxisRule::Edge);
        assert!(v.x > 0.0);
        assert!((v.angle_between(up) - 0.3).abs() < 1e-9);
        let h = rotate_guide(DVec3::X, DVec3::X, DVec3::X, 0.3, up, AxisRule::Edge);
        assert!(h.y < 0.0);
        // Vertical edge: falls back to up × guide, then to the horizontal offset.
        let f = rotate_guide(up, DVec3::Y, DVec3::new(0.0, 1.0, 1.0), 0.2, up, AxisRule::Edge);
        assert!((f.angle_between(up) - 0.2).abs() < 1e-9 && f.z > 0.0);
        assert_eq!(rotate_guide(up, DVec3::Y, DVec3::Y, 0.2, up, AxisRule::Edge), up);
    }

    #[test]
    fn crown_flags_choose_the_same_volume_endpoints() {
        let v = Volume::new(vec![Primitive::Box { center: [0.0, 1.0, 0.0], size: [2.0; 3] }]);
        let g = super::super::graph::poisson_yao(&v, 3000, None, None, 8, 3, 7).unwrap();
        let it = MgvIteration {
            endpoints: EndpointRule::Volume,
            count: 50,
            crown: vec![Primitive::Sphere { center: [0.0, 1.2, 0.0], radius: 0.8 }],
            ..Default::default()
        };
        let p = LeastCostParams::default();
        let mut st = MgvState::new(&g);
        st.iterate(&g, &it, &p, 3, 0);
        let s = st.last.clone().unwrap();
        // The same choice by `choose`, which tests the crown itself.
        let mut rng = Pcg64::seed_from_u64(3 ^ 0x656e_6470_6f69_6e74);
        let want = MgvState::new(&g).choose(&g, &it, &s, 3, 0, &mut rng);
        assert!(want.len() > 10, "{}", want.len());
        assert_eq!(st.endpoints[0], want);
    }

    #[test]
    fn eq52_values() {
        let th = 25f64.to_radians();
        let pi = std::f64::consts::PI;
        for (beta, want) in [(0.0, 0.0), (pi / 4.0, 12.5), (pi / 2.0, 17.677_669_5), (pi, 25.0)] {
            assert!((eq52(th, beta).to_degrees() - want).abs() < 1e-6, "{beta}");
        }
        assert_eq!(eq51(6.0, -6.0, 20, 20), 6.0);
        assert_eq!(eq51(6.0, -6.0, 20, 21), -6.0);
    }
}
