//! Adaptive Loop refinement with crack-free (red–green) transitions between levels
//! (MacMurchy2004 §A.3 and §8.2, MacMurchy2004-spec §2.11; issue 4 item 6).
//!
//! MacMurchy2004's Salad refines a triangle only where the surface bends — the **flatness
//! tolerance**, the dihedral angle (radians) between two adjacent triangles, or on creases
//! and boundaries the turn between two consecutive sharp edges — and only while the
//! triangle is larger than the **size tolerance** (world-space area). The seed leaves
//! crack handling open; the output here is always conforming:
//!
//! 1. The control mesh is refined uniformly to `max_levels − 1` by the [`Refiner`], so
//!    every level's positions are exactly Loop's (creases, corners, boundaries, semi-sharp
//!    decay included). The deepest level `max_levels` — four times the faces of the one
//!    above, and where almost all of uniform refinement's time goes — is never built:
//!    only the children of red-refined faces of level `max_levels − 1` exist there, and
//!    their vertices are evaluated one by one with the uniform kernel's masks and
//!    arithmetic (bit for bit the uniform positions). The refinement hierarchy is a forest
//!    of 4-ary face trees: face `f` of level `l` has the children `4f … 4f + 3` at level
//!    `l + 1`.
//! 2. A face of the hierarchy is **red-refined** when it is a leaf so far, wants
//!    refinement (bends more than the flatness tolerance across one of its edges, and is
//!    larger than the size tolerance) and is above `max_levels`.
//! 3. **Balance**: a refined face's edge neighbours must exist at its level (so two
//!    faces sharing an edge differ by at most one level, and an edge carries at most one
//!    hanging vertex).
//! 4. **Closure**: a leaf with two or three hanging edge midpoints is red-refined too;
//!    a leaf with one is split **green** into two triangles through the midpoint.
//!
//! Steps 2–4 repeat until nothing changes. Every edge of the output then has the same
//! vertices on both sides (no T-junctions): a closed manifold input gives a closed
//! manifold output. Each output vertex takes its Loop position at the finest level that
//! uses it, so refined regions sit on the refined surface. Output vertices keep the
//! hierarchy's order: the control vertices first (same indices when all are used). UVs
//! are carried linearly (barycentric in the control triangle, dyadic weights, so seams
//! stay exact).

use super::crease::Rules;
use super::loop_::beta;
use super::topology::{Topology, NONE};
use super::{BoundaryInterpolation, Corner, CreasingMethod, RefineError, RefineOptions, Refiner, Scheme};
use crate::geometry::{FaceVarying, Mesh};
use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// Tolerances and rules of [`adaptive_loop`].
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptiveOptions {
    /// The deepest level any triangle may reach.
    pub max_levels: u32,
    /// Flatness tolerance in **radians** (MacMurchy2004: "the dihedral angle between adjacent
    /// triangles"): a triangle is split when the angle between its normal and a
    /// neighbour's exceeds it, or, across a crease or boundary edge, when the turn between
    /// that edge and the next sharp edge does. `f32::INFINITY` never refines.
    pub flatness: f32,
    /// Size tolerance: triangles of this world-space area or less are never split.
    pub min_area: f32,
    /// Boundary vertex rule (as in [`RefineOptions::boundary`]).
    pub boundary: BoundaryInterpolation,
    /// Semi-sharp crease decay (as in [`RefineOptions::creasing`]).
    pub creasing: CreasingMethod,
    /// Refuse inputs whose uniform refinement to `max_levels` would exceed this many faces.
    pub max_faces: usize,
    /// Refuse inputs whose uniform refinement to `max_levels` would need more memory
    /// than this at its peak (bytes; as in [`RefineOptions::max_memory`]).
    pub max_memory: u64,
}

impl Default for AdaptiveOptions {
    /// MacMurchy2004's Fig A.5 values (flatness 0.25 rad, size 0.0001) and 4 levels at most.
    fn default() -> Self {
        AdaptiveOptions {
            max_levels: 4,
            flatness: 0.25,
            min_area: 1e-4,
            boundary: BoundaryInterpolation::EdgeAndCorner,
            creasing: CreasingMethod::Uniform,
            max_faces: super::DEFAULT_MAX_FACES,
            max_memory: super::DEFAULT_MAX_MEMORY,
        }
    }
}

/// Refines the triangle mesh `mesh` (with its creases and the vertex sharpness in
/// `corners`) adaptively with Loop's rules; see the [module docs](self). The result is
/// conforming, carries linearly interpolated UVs when `mesh` has UVs, and has no normals
/// (the exporters compute smooth ones).
///
/// ```
/// use sylva::refine::adaptive::{adaptive_loop, AdaptiveOptions};
/// # use sylva::Mesh; use glam::Vec3;
/// let mut tet = Mesh::new();
/// tet.positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
/// for f in [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]] { tet.push_face(&f); }
/// let opts = AdaptiveOptions { max_levels: 3, flatness: 0.3, min_area: 0.01, ..Default::default() };
/// let fine = adaptive_loop(&tet, &[], &opts).unwrap();
/// assert!(fine.face_count() > 4 && fine.face_count() < 4 * 64);
/// ```
pub fn adaptive_loop(
    mesh: &Mesh,
    corners: &[Corner],
    options: &AdaptiveOptions,
) -> Result<Mesh, RefineError> {
    adaptive_loop_levels(mesh, corners, options).map(|(m, _)| m)
}

/// [`adaptive_loop`], also returning the hierarchy level of every output face (green
/// halves report the level of the triangle they split).
pub fn adaptive_loop_levels(
    mesh: &Mesh,
    corners: &[Corner],
    options: &AdaptiveOptions,
) -> Result<(Mesh, Vec<u8>), RefineError> {
    mesh.validate().map_err(RefineError::InvalidMesh)?;
    if mesh.face_count() == 0 {
        let mut out = mesh.clone();
        out.normals = None;
        return Ok((out, Vec::new()));
    }
    if options.flatness.is_nan() || options.flatness < 0.0 {
        return Err(RefineError::InvalidOption(format!(
            "adaptive flatness tolerance must be an angle ≥ 0 (radians), got {}",
            options.flatness
        )));
    }
    if options.min_area.is_nan() || options.min_area < 0.0 {
        return Err(RefineError::InvalidOption(format!(
            "adaptive size tolerance must be an area ≥ 0, got {}",
            options.min_area
        )));
    }
    if options.max_levels > 15 {
        return Err(RefineError::Budget {
            levels: options.max_levels,
            faces: super::output_face_count(Scheme::Loop, mesh.face_count(), 0, options.max_levels),
            limit: options.max_faces,
        });
    }
    // The face budget of the deepest level, checked as the uniform refiner would.
    let n = options.max_levels as usize;
    let out_faces = super::output_face_count(Scheme::Loop, mesh.face_count(), 0, options.max_levels);
    if out_faces > options.max_faces as u128 {
        return Err(RefineError::Budget {
            levels: options.max_levels,
            faces: out_faces,
            limit: options.max_faces,
        });
    }
    if out_faces.saturating_mul(2) + mesh.positions.len() as u128 >= NONE as u128 {
        return Err(RefineError::TooLarge { what: "refined mesh", count: out_faces as usize });
    }
    // Levels 0 … n − 1 are refined uniformly with full adjacency; the deepest level n is
    // only ever needed for the children of red-refined faces of level n − 1, so its
    // topology is never built and its positions are evaluated on demand (`Hierarchy::finest_position`).
    let ro = RefineOptions {
        scheme: Scheme::Loop,
        levels: n.saturating_sub(1) as u32,
        boundary: options.boundary,
        creasing: options.creasing,
        full_last_level: true,
        parallel: true,
        max_faces: options.max_faces,
        max_memory: options.max_memory,
    };
    let refiner = Refiner::new(mesh, corners, &ro)?;
    let mut pos: Vec<Vec<Vec3>> = Vec::with_capacity(n);
    pos.push(mesh.positions.clone());
    for l in 0..n.saturating_sub(1) {
        let mut next = vec![Vec3::ZERO; refiner.level(l + 1).vertex_count()];
        refiner.interpolate_level(l, &pos[l], &mut next);
        pos.push(next);
    }
    let finest_rules = (n > 0).then(|| {
        let last = &refiner.levels[n - 1];
        super::crease::refine_features(&last.topo, &last.features, options.creasing, options.boundary).0
    });
    // Per level below the finest: face normals (area-weighted) and which edges are sharp,
    // computed once instead of on every query.
    let normals: Vec<Vec<Vec3>> = (0..n)
        .map(|l| {
            let t = &refiner.levels[l].topo;
            let p = &pos[l];
            t.face_verts
                .chunks_exact(3)
                .map(|v| {
                    let (a, b, c) = (p[v[0] as usize], p[v[1] as usize], p[v[2] as usize]);
                    (b - a).cross(c - a)
                })
                .collect()
        })
        .collect();
    let sharp: Vec<Vec<bool>> = (0..n)
        .map(|l| {
            let feat = &refiner.levels[l].features;
            let mut s = vec![false; refiner.levels[l].topo.edge_count()];
            for &e in &feat.boundary {
                s[e as usize] = true;
            }
            for &(e, x) in &feat.creases {
                s[e as usize] |= x > 0.0;
            }
            s
        })
        .collect();
    // angle(a, b) > flatness  ⇔  a·b < cos(flatness)·|a||b| for flatness in [0, π).
    let cos_flatness = if options.flatness < std::f32::consts::PI { options.flatness.cos() } else { -2.0 };
    let h = Hierarchy {
        refiner: &refiner,
        levels: n,
        pos: &pos,
        finest_rules,
        options,
        normals,
        sharp,
        cos_flatness,
    };
    let refined = h.select();
    Ok(h.emit(mesh, &refined))
}

/// The uniform hierarchy and the tolerances.
struct Hierarchy<'a> {
    /// The uniform refinement of levels 0 … `levels − 1` (full adjacency on all of them).
    refiner: &'a Refiner,
    /// The deepest level (`max_levels`); its topology and positions are never built.
    levels: usize,
    /// Positions of levels 0 … `levels − 1`.
    pos: &'a [Vec<Vec3>],
    /// Crease and corner masks from level `levels − 1` to `levels` (none when `levels` = 0).
    finest_rules: Option<Rules>,
    options: &'a AdaptiveOptions,
    /// Unnormalized face normals of each level below the finest.
    normals: Vec<Vec<Vec3>>,
    /// Whether each edge of each level below the finest is sharp (crease or boundary).
    sharp: Vec<Vec<bool>>,
    /// cos of the flatness tolerance (−2 when no angle exceeds it).
    cos_flatness: f32,
}

/// 0 unknown, 1 no, 2 yes.
type Want = Vec<u8>;

/// An output triangle: global vertices, barycentric corner weights in its control face,
/// the control face, and its level.
type Leaf = ([u32; 3], [[f32; 3]; 3], u32, u8);

impl Hierarchy<'_> {
    fn topo(&self, l: usize) -> &Topology {
        &self.refiner.levels[l].topo
    }

    /// The face across edge `j` of face `f` at level `l` (< max level), if any.
    fn neighbour(&self, l: usize, f: usize, j: usize) -> Option<usize> {
        let t = self.topo(l);
        let c = (3 * f + j) as u32;
        let [c0, c1] = t.edge_corners[t.face_edges[c as usize] as usize];
        let other = if c0 == c { c1 } else { c0 };
        (other != NONE).then_some(other as usize / 3)
    }

    /// The turn (radians) at `v` between sharp edge `e` and the one other sharp edge at
    /// `v`; 0 when `v` has no single continuation (an end, a dart or a corner).
    fn sharp_turn(&self, l: usize, e: u32, v: u32) -> f32 {
        let t = self.topo(l);
        let feat = &self.refiner.levels[l].features;
        // A corner (tagged, or a single-face boundary vertex with the EdgeAndCorner rule)
        // is expected to be pointed.
        let single_face = t.vertex_corners(v as usize).len() == 1;
        let boundary_corner = match self.options.boundary {
            BoundaryInterpolation::EdgeAndCorner => single_face,
            // Every boundary vertex is a corner.
            BoundaryInterpolation::Fixed => t.vertex_corners(v as usize).iter().any(|&c| {
                t.is_boundary_edge(t.face_edges[c as usize] as usize)
                    || t.is_boundary_edge(t.face_edges[t.prev(c) as usize] as usize)
            }),
            BoundaryInterpolation::EdgeOnly => false,
        };
        if feat.corners.binary_search_by_key(&v, |x| x.0).is_ok() || boundary_corner {
            return 0.0;
        }
        let mut other = None;
        for &c in t.vertex_corners(v as usize) {
            for x in [t.face_edges[c as usize], t.face_edges[t.prev(c) as usize]] {
                if x != e && self.sharp[l][x as usize] && other != Some(x) {
                    if other.is_some() {
                        return 0.0; // three or more sharp edges: a corner
                    }
                    other = Some(x);
                }
            }
        }
        let Some(x) = other else { return 0.0 };
        let p = &self.pos[l];
        let u = t.other_vertex(e, v);
        let w = t.other_vertex(x, v);
        let d1 = p[v as usize] - p[u as usize];
        let d2 = p[w as usize] - p[v as usize];
        angle(d1, d2)
    }

    /// Whether face `f` of level `l` bends more than the flatness tolerance and is larger
    /// than the size tolerance.
    fn wants(&self, l: usize, f: usize) -> bool {
        if self.options.flatness == f32::INFINITY {
            return false;
        }
        let nf = self.normals[l][f];
        let len_f = nf.length();
        if 0.5 * len_f <= self.options.min_area {
            return false;
        }
        let t = self.topo(l);
        for j in 0..3 {
            let e = t.face_edges[3 * f + j];
            let bends = if self.sharp[l][e as usize] {
                let [a, b] = t.edge_verts[e as usize];
                self.sharp_turn(l, e, a).max(self.sharp_turn(l, e, b)) > self.options.flatness
            } else {
                match self.neighbour(l, f, j) {
                    Some(g) => {
                        // The angle between the normals exceeds the tolerance (degenerate
                        // normals never bend).
                        let ng = self.normals[l][g];
                        let d = len_f * ng.length();
                        d > 0.0 && d.is_finite() && nf.dot(ng) < self.cos_flatness * d
                    }
                    None => false,
                }
            };
            if bends {
                return true;
            }
        }
        false
    }

    /// Which faces of each level (below the finest) are red-refined.
    fn select(&self) -> Vec<Vec<bool>> {
        let n = self.levels;
        let mut refine: Vec<Vec<bool>> = (0..n).map(|l| vec![false; self.topo(l).face_count()]).collect();
        let mut want: Vec<Want> = (0..n).map(|l| vec![0u8; self.topo(l).face_count()]).collect();
        loop {
            let mut changed = false;
            // Wishes of every existing leaf, coarse to fine.
            for l in 0..n {
                let nf = self.topo(l).face_count();
                for f in 0..nf {
                    if refine[l][f] || (l > 0 && !refine[l - 1][f / 4]) {
                        continue;
                    }
                    if want[l][f] == 0 {
                        want[l][f] = if self.wants(l, f) { 2 } else { 1 };
                    }
                    if want[l][f] == 2 {
                        refine[l][f] = true;
                        changed = true;
                    }
                }
            }
            // Balance, fine to coarse: a refined face's parent and its edge neighbours'
            // parents are refined.
            for l in (1..n).rev() {
                let (coarse, fine) = refine.split_at_mut(l);
                let (parent, this) = (&mut coarse[l - 1], &fine[0]);
                for f in 0..this.len() {
                    if !this[f] {
                        continue;
                    }
                    if !parent[f / 4] {
                        parent[f / 4] = true;
                        changed = true;
                    }
                    for j in 0..3 {
                        if let Some(g) = self.neighbour(l, f, j) {
                            if !parent[g / 4] {
                                parent[g / 4] = true;
                                changed = true;
                            }
                        }
                    }
                }
            }
            // Red closure: a leaf with two or more hanging edges is refined.
            for l in 0..n {
                for f in 0..refine[l].len() {
                    if refine[l][f] || (l > 0 && !refine[l - 1][f / 4]) {
                        continue;
                    }
                    let hanging =
                        (0..3).filter(|&j| self.neighbour(l, f, j).is_some_and(|g| refine[l][g])).count();
                    if hanging >= 2 {
                        refine[l][f] = true;
                        changed = true;
                    }
                }
            }
            if !changed {
                return refine;
            }
        }
    }

    /// The Loop position of vertex `v` of the deepest level (`levels` > 0): the vertex
    /// point of vertex `v` or the edge point of edge `v − V` of level `levels − 1`. The
    /// same arithmetic, in the same order, as the uniform kernel (`loop_::interpolate`),
    /// so the result is bit for bit the uniform one.
    fn finest_position(&self, v: u32) -> Vec3 {
        let l = self.levels - 1;
        let p = self.topo(l);
        let src = &self.pos[l];
        let rules = self.finest_rules.as_ref().expect("a finest level below level 0");
        let nv = p.num_verts;
        if v >= nv {
            let e = v - nv;
            let [a, b] = p.edge_verts[e as usize];
            let [c0, c1] = p.edge_corners[e as usize];
            let s = src[a as usize] + src[b as usize];
            let smooth = if c1 == NONE {
                s * 0.5
            } else {
                let opp = src[p.face_verts[p.prev(c0) as usize] as usize]
                    + src[p.face_verts[p.prev(c1) as usize] as usize];
                s * 0.375 + opp * 0.125
            };
            return match rules.edge_specials.binary_search_by_key(&e, |x| x.0) {
                Ok(i) => {
                    let w = rules.edge_specials[i].1;
                    let mid = (src[a as usize] + src[b as usize]) * 0.5;
                    mid * w + smooth * (1.0 - w)
                }
                Err(_) => smooth,
            };
        }
        let cs = p.vertex_corners(v as usize);
        let n = cs.len();
        let smooth = if n == 0 {
            src[v as usize]
        } else {
            let mut sum = Vec3::ZERO;
            for &c in cs {
                sum += src[p.face_verts[p.next(c) as usize] as usize];
            }
            let b = beta(n) as f32;
            src[v as usize] * (1.0 - n as f32 * b) + sum * b
        };
        match rules.vertex_specials.binary_search_by_key(&v, |x| x.vertex) {
            Ok(i) => {
                let s = &rules.vertex_specials[i];
                let mut out = src[v as usize] * s.w_vertex;
                if s.w_pair != 0.0 {
                    out += (src[s.pair[0] as usize] + src[s.pair[1] as usize]) * s.w_pair;
                }
                if s.smooth != 0.0 {
                    out += smooth * s.smooth;
                }
                out
            }
            Err(_) => smooth,
        }
    }

    /// Writes the leaves (and green halves) as a mesh.
    fn emit(&self, mesh: &Mesh, refine: &[Vec<bool>]) -> (Mesh, Vec<u8>) {
        let n = self.levels;
        // Vertices of the deepest level: V + E of level n − 1 (Loop's numbering).
        let finest_verts = if n == 0 {
            self.topo(0).vertex_count()
        } else {
            let t = self.topo(n - 1);
            t.vertex_count() + t.edge_count()
        };
        // (global vertex, barycentric corner weights in the control face), per leaf corner.
        let mut tris: Vec<Leaf> = Vec::new();
        let mut level_of = vec![u8::MAX; finest_verts];
        let mut use_vertex = |v: u32, l: usize| {
            let s = &mut level_of[v as usize];
            if *s == u8::MAX || (*s as usize) < l {
                *s = l as u8;
            }
        };
        for l in 0..n {
            let t = self.topo(l);
            for f in 0..t.face_count() {
                let exists = l == 0 || refine[l - 1][f / 4];
                if !exists || refine[l][f] {
                    continue;
                }
                let v: [u32; 3] = [t.face_verts[3 * f], t.face_verts[3 * f + 1], t.face_verts[3 * f + 2]];
                let (root, w) = barycentric(f, l);
                let hanging = (0..3).find(|&j| self.neighbour(l, f, j).is_some_and(|g| refine[l][g]));
                for &x in &v {
                    use_vertex(x, l);
                }
                match hanging {
                    None => tris.push((v, w, root, l as u8)),
                    Some(j) => {
                        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
                        let m = t.num_verts + t.face_edges[3 * f + j];
                        use_vertex(m, l + 1);
                        let wm = mid(w[j], w[j1]);
                        tris.push(([v[j], m, v[j2]], [w[j], wm, w[j2]], root, l as u8));
                        tris.push(([m, v[j1], v[j2]], [wm, w[j1], w[j2]], root, l as u8));
                    }
                }
            }
        }
        if n == 0 {
            for f in 0..self.topo(0).face_count() {
                let t = self.topo(0);
                let v: [u32; 3] = [t.face_verts[3 * f], t.face_verts[3 * f + 1], t.face_verts[3 * f + 2]];
                for &x in &v {
                    use_vertex(x, 0);
                }
                tris.push((v, barycentric(f, 0).1, f as u32, 0));
            }
        } else {
            // The deepest level: only the children of red-refined faces of level n − 1 exist
            // (all leaves), with Loop's child layout (see `barycentric`).
            let p = self.topo(n - 1);
            for (pf, _) in refine[n - 1].iter().enumerate().filter(|x| *x.1) {
                let pv = &p.face_verts[3 * pf..3 * pf + 3];
                let pe = &p.face_edges[3 * pf..3 * pf + 3];
                let (m0, m1, m2) = (p.num_verts + pe[0], p.num_verts + pe[1], p.num_verts + pe[2]);
                let children = [[pv[0], m0, m2], [m0, pv[1], m1], [m2, m1, pv[2]], [m0, m1, m2]];
                for (k, v) in children.into_iter().enumerate() {
                    for &x in &v {
                        use_vertex(x, n);
                    }
                    let (root, w) = barycentric(4 * pf + k, n);
                    tris.push((v, w, root, n as u8));
                }
            }
        }
        // Compact the vertices in hierarchy order: control vertices keep their order
        // (and their indices when all are used), then each level's new edge points.
        let mut index = vec![u32::MAX; finest_verts];
        let mut out = Mesh::new();
        for (v, &l) in level_of.iter().enumerate() {
            if l != u8::MAX {
                index[v] = out.positions.len() as u32;
                let l = l as usize;
                out.positions.push(if l < n || n == 0 {
                    self.pos[l][v]
                } else {
                    self.finest_position(v as u32)
                });
            }
        }
        out.face_indices.reserve(3 * tris.len());
        out.face_offsets.reserve(tris.len());
        for (vs, ..) in &tris {
            out.push_face(&[index[vs[0] as usize], index[vs[1] as usize], index[vs[2] as usize]]);
        }
        if let Some(uv) = &mesh.uvs {
            let mut values: Vec<Vec2> = Vec::new();
            let mut indices = Vec::with_capacity(3 * tris.len());
            // A vertex has one UV value except on seams: remember the first value of each
            // output vertex and hash only the others.
            let mut first = vec![u32::MAX; out.positions.len()];
            let mut others: HashMap<(u32, [u32; 2]), u32> = HashMap::new();
            for (vs, ws, root, _) in &tris {
                let r = 3 * *root as usize;
                let c = [
                    uv.values[uv.indices[r] as usize],
                    uv.values[uv.indices[r + 1] as usize],
                    uv.values[uv.indices[r + 2] as usize],
                ];
                for k in 0..3 {
                    let w = ws[k];
                    let value = c[0] * w[0] + c[1] * w[1] + c[2] * w[2];
                    let vi = index[vs[k] as usize];
                    let bits = [value.x.to_bits(), value.y.to_bits()];
                    let f = first[vi as usize];
                    let i = if f == u32::MAX {
                        values.push(value);
                        first[vi as usize] = values.len() as u32 - 1;
                        values.len() as u32 - 1
                    } else if [values[f as usize].x.to_bits(), values[f as usize].y.to_bits()] == bits {
                        f
                    } else {
                        *others.entry((vi, bits)).or_insert_with(|| {
                            values.push(value);
                            values.len() as u32 - 1
                        })
                    };
                    indices.push(i);
                }
            }
            out.uvs = Some(FaceVarying { values, indices });
        }
        let levels = tris.iter().map(|t| t.3).collect();
        (out, levels)
    }
}

/// The angle between two vectors (0 when either is degenerate).
fn angle(a: Vec3, b: Vec3) -> f32 {
    let d = (a.length_squared() * b.length_squared()).sqrt();
    if d.is_nan() || d <= 0.0 || d.is_infinite() {
        return 0.0;
    }
    (a.dot(b) / d).clamp(-1.0, 1.0).acos()
}

fn mid(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5, (a[2] + b[2]) * 0.5]
}

/// The control face of face `f` at level `l` and the barycentric weights of its three
/// corners in it (Loop's child layout: `4f (v₀ m₀ m₂)`, `4f+1 (m₀ v₁ m₁)`,
/// `4f+2 (m₂ m₁ v₂)`, `4f+3 (m₀ m₁ m₂)`). The weights are dyadic, hence exact.
fn barycentric(f: usize, l: usize) -> (u32, [[f32; 3]; 3]) {
    let mut w = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for i in (0..l).rev() {
        let k = (f >> (2 * i)) & 3;
        let [a, b, c] = w;
        let (m0, m1, m2) = (mid(a, b), mid(b, c), mid(c, a));
        w = match k {
            0 => [a, m0, m2],
            1 => [m0, b, m1],
            2 => [m2, m1, c],
            _ => [m0, m1, m2],
        };
    }
    ((f >> (2 * l)) as u32, w)
}
