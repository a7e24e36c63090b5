//! Sharp and semi-sharp creases and corners: sharpness decay, vertex rules and the
//! fractional blending of masks (DeRose–Kass–Truong 1998 as OpenSubdiv's `Sdc::Crease`
//! implements it).
//!
//! MacMurchy2004 §2.10: "an integer sharpness s means sharp masks for s iterations, then smooth
//! ones"; vertex rules follow Hoppe et al. 1994 by the number of sharp incident edges
//! (0–1 smooth or dart, 2 crease, ≥ 3 corner) and "a sharp tip is a corner while its
//! sharpness is > 0". Fractional sharpness blends the sharp and smooth masks by the
//! fractional part in the last sharp level. Boundaries follow the crease rule (Pieterse2012
//! §2.8 `BSpline`, MacMurchy2004 "boundary and crease masks"): boundary edges are infinitely
//! sharp, and with [`BoundaryInterpolation::EdgeAndCorner`] a boundary vertex with a
//! single face is an infinitely sharp corner; with [`BoundaryInterpolation::Fixed`] (Pieterse2012
//! §2.8 `Fixed`) every boundary vertex is one.
//!
//! Sharpness is an `f32`; values ≥ [`INFINITE`] (10, OpenSubdiv's convention) never decay.
//! The features of a level (`Features`: sharp edges, sharp vertices, boundary edges) are
//! kept as sparse sorted lists, so a smooth closed mesh costs nothing here.

use super::topology::Topology;
use super::{BoundaryInterpolation, CreasingMethod};

/// Sharpness at or above which a crease or corner is infinitely sharp (OpenSubdiv's
/// `Crease::SHARPNESS_INFINITE`).
pub const INFINITE: f32 = 10.0;

/// An infinitely sharp or semi-sharp vertex ("corner" tag; MacMurchy2004's tip sharpness).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corner {
    /// The vertex.
    pub vertex: u32,
    /// Its sharpness: a vertex with sharpness `s` stays pinned (corner rule) for `s` levels;
    /// values ≥ [`INFINITE`] pin it for ever.
    pub sharpness: f32,
}

/// The subdivision rule of a vertex, by the sharp features around it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rule {
    /// No sharp edge: the scheme's smooth mask.
    Smooth,
    /// One sharp edge: still the smooth mask.
    Dart,
    /// Two sharp edges: cubic B-spline curve mask along them (1/8, 3/4, 1/8).
    Crease,
    /// Three or more sharp edges, or a sharp vertex: the vertex stays where it is.
    Corner,
}

/// OpenSubdiv's `Crease::decrementSharpness`: one level of uniform decay.
#[inline]
pub fn decrement(s: f32) -> f32 {
    if s >= INFINITE {
        INFINITE
    } else if s > 1.0 {
        s - 1.0
    } else {
        0.0
    }
}

/// The rule of a vertex with sharpness `vertex_sharpness` and `sharp_edges` incident
/// edges of sharpness > 0.
pub fn vertex_rule(vertex_sharpness: f32, sharp_edges: usize) -> Rule {
    if vertex_sharpness > 0.0 {
        return Rule::Corner;
    }
    match sharp_edges {
        0 => Rule::Smooth,
        1 => Rule::Dart,
        2 => Rule::Crease,
        _ => Rule::Corner,
    }
}

/// Child sharpness of each incident edge at one vertex (DeRose et al.'s Chaikin rule
/// `s' = ¾ s + ¼ mean(others) − 1` over the semi-sharp edges, or uniform decay).
pub fn subdivide_edge_sharpness(method: CreasingMethod, parent: &[f32], child: &mut [f32]) {
    let semi = |s: f32| s > 0.0 && s < INFINITE;
    let (count, sum) =
        parent.iter().filter(|&&s| semi(s)).fold((0usize, 0.0f32), |(n, t), &s| (n + 1, t + s));
    for (c, &p) in child.iter_mut().zip(parent) {
        *c = if method == CreasingMethod::Uniform || parent.len() < 2 || count < 2 || !semi(p) {
            decrement(p)
        } else {
            let others = (sum - p) / (count - 1) as f32;
            let s = 0.75 * p + 0.25 * others - 1.0;
            if s > 0.0 {
                s
            } else {
                0.0
            }
        };
    }
}

/// OpenSubdiv's `ComputeFractionalWeightAtVertex`: the weight of the parent (sharper)
/// mask when a vertex changes rule, the mean sharpness of the features that become smooth,
/// clamped to 1.
pub fn fractional_weight(parent_vertex: f32, child_vertex: f32, parent: &[f32], child: &[f32]) -> f32 {
    let mut count = 0usize;
    let mut sum = 0.0f32;
    if parent_vertex > 0.0 && child_vertex <= 0.0 {
        count += 1;
        sum += parent_vertex;
    }
    for (&p, &c) in parent.iter().zip(child) {
        if p > 0.0 && c <= 0.0 {
            count += 1;
            sum += p;
        }
    }
    if count == 0 {
        0.0
    } else {
        (sum / count as f32).min(1.0)
    }
}

/// The sharp features of one level, as sparse lists sorted by index.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Features {
    /// Interior edges with sharpness > 0.
    pub creases: Vec<(u32, f32)>,
    /// Vertices with sharpness > 0.
    pub corners: Vec<(u32, f32)>,
    /// Boundary edges (infinitely sharp).
    pub boundary: Vec<u32>,
}

impl Features {
    /// Sharpness of edge `e` (∞ on the boundary).
    pub fn edge_sharpness(&self, e: u32) -> f32 {
        if self.boundary.binary_search(&e).is_ok() {
            return INFINITE;
        }
        match self.creases.binary_search_by_key(&e, |x| x.0) {
            Ok(i) => self.creases[i].1,
            Err(_) => 0.0,
        }
    }
}

/// A vertex whose child is not given by the smooth mask alone:
/// `child = w_vertex · v + w_pair · (a + b) + smooth · smooth_mask(v)`. Every rule and
/// every blend of two rules fits: a crease adds its two neighbours as the pair, and a
/// blend combines at most one crease with a corner or the smooth mask.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct VertexSpecial {
    pub vertex: u32,
    pub w_vertex: f32,
    pub pair: [u32; 2],
    pub w_pair: f32,
    pub smooth: f32,
}

/// How one level's features change the smooth rules, and the child level's features.
#[derive(Debug, Clone, Default)]
pub(crate) struct Rules {
    /// Interior creased edges and the weight of the midpoint (crease) mask; the smooth
    /// mask gets `1 − w`. Boundary edges always take the midpoint and are not listed.
    pub edge_specials: Vec<(u32, f32)>,
    /// Vertices with a crease or corner rule (or a blend), sorted by vertex.
    pub vertex_specials: Vec<VertexSpecial>,
}

/// One sharp feature incident to a vertex.
#[derive(Clone, Copy)]
struct Incidence {
    vertex: u32,
    edge: u32,
    sharpness: f32,
}

/// The sharp features around one vertex (vertices without any are smooth).
pub(crate) struct VertexFeatures {
    pub vertex: u32,
    pub vertex_sharpness: f32,
    /// Incident sharp edges and their sharpness.
    pub edges: Vec<(u32, f32)>,
}

/// Groups a level's features by vertex (boundary vertices with one face become
/// infinitely sharp under [`BoundaryInterpolation::EdgeAndCorner`], every boundary vertex
/// under [`BoundaryInterpolation::Fixed`]).
pub(crate) fn group_by_vertex(
    topo: &Topology,
    features: &Features,
    boundary: BoundaryInterpolation,
) -> Vec<VertexFeatures> {
    let mut inc: Vec<Incidence> = Vec::with_capacity(2 * (features.creases.len() + features.boundary.len()));
    let edges = features.creases.iter().copied().chain(features.boundary.iter().map(|&e| (e, INFINITE)));
    for (edge, sharpness) in edges {
        for vertex in topo.edge_verts[edge as usize] {
            inc.push(Incidence { vertex, edge, sharpness });
        }
    }
    inc.sort_unstable_by_key(|i| (i.vertex, i.edge));
    let mut out: Vec<VertexFeatures> = Vec::new();
    let mut corners = features.corners.iter().peekable();
    let mut i = 0;
    loop {
        let next_inc = inc.get(i).map(|x| x.vertex);
        let next_corner = corners.peek().map(|x| x.0);
        let v = match (next_inc, next_corner) {
            (None, None) => break,
            (Some(a), None) => a,
            (None, Some(b)) => b,
            (Some(a), Some(b)) => a.min(b),
        };
        let mut vs = 0.0;
        if next_corner == Some(v) {
            vs = corners.next().map_or(0.0, |c| c.1);
        }
        let mut edges = Vec::new();
        while i < inc.len() && inc[i].vertex == v {
            edges.push((inc[i].edge, inc[i].sharpness));
            i += 1;
        }
        let on_boundary = || edges.iter().any(|&(e, _)| topo.is_boundary_edge(e as usize));
        match boundary {
            BoundaryInterpolation::EdgeAndCorner
                if topo.vertex_corners(v as usize).len() == 1 && on_boundary() =>
            {
                vs = INFINITE
            }
            BoundaryInterpolation::Fixed if on_boundary() => vs = INFINITE,
            _ => {}
        }
        out.push(VertexFeatures { vertex: v, vertex_sharpness: vs, edges });
    }
    out
}

/// Computes the masks of one refinement step and the child level's features.
///
/// `vv(v)` (the child of parent vertex `v`) is `v`, and the child of parent edge `e` at its
/// end `v` is [`Topology::half_at`]; both schemes number their children this way.
pub(crate) fn refine_features(
    topo: &Topology,
    features: &Features,
    method: CreasingMethod,
    boundary: BoundaryInterpolation,
) -> (Rules, Features) {
    let groups = group_by_vertex(topo, features, boundary);
    let mut rules = Rules::default();
    let mut child = Features {
        boundary: features.boundary.iter().flat_map(|&e| [2 * e, 2 * e + 1]).collect(),
        ..Default::default()
    };
    // Child sharpness of each crease at each end, to decide the edge-vertex rule.
    let mut crease_child: Vec<[f32; 2]> = vec![[0.0; 2]; features.creases.len()];
    let mut parent_s = Vec::new();
    let mut child_s = Vec::new();
    for g in &groups {
        parent_s.clear();
        parent_s.extend(g.edges.iter().map(|x| x.1));
        child_s.clear();
        child_s.resize(parent_s.len(), 0.0);
        subdivide_edge_sharpness(method, &parent_s, &mut child_s);
        let child_vs = decrement(g.vertex_sharpness);
        if child_vs > 0.0 {
            child.corners.push((g.vertex, child_vs));
        }
        for (k, &(e, _)) in g.edges.iter().enumerate() {
            if topo.is_boundary_edge(e as usize) {
                continue;
            }
            if let Ok(ci) = features.creases.binary_search_by_key(&e, |x| x.0) {
                let end = (topo.edge_verts[e as usize][1] == g.vertex) as usize;
                crease_child[ci][end] = child_s[k];
            }
            if child_s[k] > 0.0 {
                child.creases.push((topo.half_at(e, g.vertex), child_s[k]));
            }
        }
        let p_sharp = parent_s.iter().filter(|&&s| s > 0.0).count();
        let c_sharp = child_s.iter().filter(|&&s| s > 0.0).count();
        let p_rule = vertex_rule(g.vertex_sharpness, p_sharp);
        if matches!(p_rule, Rule::Smooth | Rule::Dart) {
            continue;
        }
        let c_rule = vertex_rule(child_vs, c_sharp);
        let ends = |s: &[f32]| -> [u32; 2] {
            let mut it = g
                .edges
                .iter()
                .zip(s)
                .filter(|(_, &s)| s > 0.0)
                .map(|(e, _)| topo.other_vertex(e.0, g.vertex));
            [it.next().unwrap_or(g.vertex), it.next().unwrap_or(g.vertex)]
        };
        let mut special =
            VertexSpecial { vertex: g.vertex, w_vertex: 0.0, pair: [g.vertex; 2], w_pair: 0.0, smooth: 0.0 };
        // MacMurchy2004 §2.10: crease mask 1/8, 3/4, 1/8; corner keeps the vertex. Parent and
        // child crease never both apply with different ends (child sharp edges are a
        // subset of the parent's, and two crease rules are the same rule).
        let apply = |rule: Rule, ends: [u32; 2], weight: f32, sp: &mut VertexSpecial| match rule {
            Rule::Smooth | Rule::Dart => sp.smooth += weight,
            Rule::Crease => {
                sp.w_vertex += 0.75 * weight;
                sp.pair = ends;
                sp.w_pair += 0.125 * weight;
            }
            Rule::Corner => sp.w_vertex += weight,
        };
        if c_rule == p_rule {
            apply(p_rule, ends(&parent_s), 1.0, &mut special);
        } else {
            let pw = fractional_weight(g.vertex_sharpness, child_vs, &parent_s, &child_s);
            apply(p_rule, ends(&parent_s), pw, &mut special);
            apply(c_rule, ends(&child_s), 1.0 - pw, &mut special);
        }
        rules.vertex_specials.push(special);
    }
    for (ci, &(e, s)) in features.creases.iter().enumerate() {
        let [c0, c1] = crease_child[ci];
        // OpenSubdiv `ComputeEdgeVertexMask`: the edge point keeps the crease mask while
        // its child vertex is a crease (both halves still sharp), else it blends the crease
        // and smooth masks by the parent sharpness s. With uniform decay the halves are
        // sharp exactly when s > 1 (and s = 1 blends with weight 1). With Chaikin a half
        // can vanish while s > 1; OpenSubdiv 3.x then uses s unclamped (a slight
        // extrapolation), and so do we, to produce the same surface.
        let child_crease = match method {
            CreasingMethod::Uniform => s > 1.0,
            CreasingMethod::Chaikin => c0 > 0.0 && c1 > 0.0,
        };
        let w = if child_crease { 1.0 } else { s };
        rules.edge_specials.push((e, w));
    }
    child.creases.sort_unstable_by_key(|x| x.0);
    child.corners.sort_unstable_by_key(|x| x.0);
    (rules, child)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decay_is_one_per_level() {
        assert_eq!(decrement(2.5), 1.5);
        assert_eq!(decrement(0.5), 0.0);
        assert_eq!(decrement(INFINITE), INFINITE);
        assert_eq!(decrement(0.0), 0.0);
    }

    #[test]
    fn rules_by_sharp_edge_count() {
        assert_eq!(vertex_rule(0.0, 0), Rule::Smooth);
        assert_eq!(vertex_rule(0.0, 1), Rule::Dart);
        assert_eq!(vertex_rule(0.0, 2), Rule::Crease);
        assert_eq!(vertex_rule(0.0, 3), Rule::Corner);
        assert_eq!(vertex_rule(0.5, 0), Rule::Corner);
    }

    #[test]
    fn chaikin_averages_neighbouring_sharpness() {
        let mut c = [0.0; 3];
        subdivide_edge_sharpness(CreasingMethod::Chaikin, &[2.0, 4.0, 0.0], &mut c);
        assert_eq!(c, [0.75 * 2.0 + 0.25 * 4.0 - 1.0, 0.75 * 4.0 + 0.25 * 2.0 - 1.0, 0.0]);
        subdivide_edge_sharpness(CreasingMethod::Uniform, &[2.0, 4.0, 0.0], &mut c);
        assert_eq!(c, [1.0, 3.0, 0.0]);
    }

    #[test]
    fn fractional_weight_is_mean_of_vanishing_features() {
        assert_eq!(fractional_weight(0.0, 0.0, &[0.5, 0.25], &[0.0, 0.0]), 0.375);
        assert_eq!(fractional_weight(0.0, 0.0, &[2.5, 1.0], &[1.5, 0.0]), 1.0);
        assert_eq!(fractional_weight(0.3, 0.0, &[], &[]), 0.3);
    }
}
