//! The mesh checker: is a control cage or a refined surface a valid 2-manifold?
//!
//! Issue 5 ("a mesh checker used by tests and by `sylva check`") for the meshers of
//! Pieterse2012 (hull joints), MacMurchy2004 (sweeps) and Skjermo2008 (quad boxes), and for any OBJ or glTF
//! file. [`check_mesh`] reports, for any polygon mesh:
//!
//! - **references**: face indices out of range, faces with fewer than 3 corners or a
//!   repeated vertex, vertices no face uses (a defect in a control mesh: it breaks
//!   subdivision and OBJ round trips);
//! - **non-finite** positions (NaN, ∞);
//! - **manifoldness**: edges used by more than two faces, and vertices whose faces form
//!   more than one fan (a "bow-tie");
//! - **orientation**: interior edges traversed the same way by both faces;
//! - **boundary loops**: connected chains of boundary edges (an open tube base, a leaf
//!   edge); the caller compares them with the loops its mesher designs;
//! - **degenerate faces**: a repeated vertex, a sliver (area below `sliver` times the
//!   square of the face's longest edge: collinear corners), or a face whose longest edge
//!   is below `tiny_edge` times the bounding-box diagonal (a few `f32` ulps: the face is
//!   rounding noise). Small but well-shaped faces, such as the tip of a tapering twig,
//!   are not degenerate;
//! - **self-intersections** (optional, the expensive part): every face is fanned into
//!   triangles, a bounding-volume hierarchy (median split on the longest axis) is built
//!   over the triangles, and every pair with overlapping boxes that shares no vertex is
//!   tested edge-against-triangle in `f64` (a pair intersects when an edge of one
//!   crosses the other). Pairs that share a vertex are not tested: they are neighbours
//!   on the surface, where a test would only measure rounding. Coplanar overlaps are not
//!   reported. Cost: O(n log n) to build, about O(n log n) to query on a mesh without
//!   large overlaps; parallel over triangles with rayon.
//!
//! Plus the components and the Euler characteristic, so a caller can check genus
//! ([`MeshReport::total_genus`] sums the components' genera).

use crate::geometry::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::fmt;

/// What [`check_mesh`] looks at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckOptions {
    /// Test for self-intersections (the expensive part).
    pub self_intersections: bool,
    /// A face is a degenerate sliver when its area is below this times the square of its
    /// longest edge.
    pub sliver: f64,
    /// A face is degenerate when its longest edge is below this times the diagonal of the
    /// mesh's bounding box.
    pub tiny_edge: f64,
    /// At most this many offending items of each kind are listed in the report (all are
    /// counted).
    pub max_listed: usize,
    /// Stop the self-intersection search after about this many intersecting pairs (a
    /// tree whose branches pass through each other can have millions); the count is then
    /// a lower bound and [`MeshReport::intersections_truncated`] is set.
    pub max_intersections: usize,
    /// The self-intersection search's work budget: it stops after looking at about this
    /// many candidate triangle pairs (pairs whose boxes overlap), so coincident or
    /// overlapping geometry, where nearly every pair is a candidate, cannot make it run
    /// for minutes; [`MeshReport::search_stopped`] is then set and the mesh is not
    /// judged valid. Default [`DEFAULT_MAX_PAIRS`] (`sylva check --max-pairs`).
    pub max_pairs: u64,
}

/// Default [`CheckOptions::max_pairs`]: 5·10⁷ candidate pairs. A grown tree's mesh
/// needs about 45 per triangle (2.6 M for a 58,000-triangle `lsys-ternary-tree`), so
/// this searches meshes of about a million triangles; the worst case, where every pair
/// is a coplanar overlap that goes through the whole triangle test, costs about 7 s of
/// CPU in release on the project's 2-core machine.
pub const DEFAULT_MAX_PAIRS: u64 = 50_000_000;

impl Default for CheckOptions {
    fn default() -> Self {
        Self {
            self_intersections: true,
            sliver: crate::tolerance::SLIVER_RATIO,
            tiny_edge: crate::tolerance::TINY_EDGE_RATIO,
            max_listed: 8,
            max_intersections: 100_000,
            max_pairs: DEFAULT_MAX_PAIRS,
        }
    }
}

/// What [`check_mesh`] found. Counts are complete; the lists hold the first
/// [`CheckOptions::max_listed`] items so a report can name them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshReport {
    /// Vertices in the mesh.
    pub vertices: usize,
    /// Faces in the mesh.
    pub faces: usize,
    /// Distinct undirected edges.
    pub edges: usize,
    /// Triangles after fanning every face (the self-intersection test's unit).
    pub triangles: usize,
    /// Faces referencing a vertex that does not exist, or with fewer than 3 corners.
    pub bad_faces: Vec<usize>,
    /// Number of faces in `bad_faces` (all of them).
    pub bad_face_count: usize,
    /// Vertices with a NaN or infinite coordinate.
    pub non_finite: Vec<usize>,
    /// Number of non-finite vertices.
    pub non_finite_count: usize,
    /// Vertices no face references.
    pub unused_vertices: usize,
    /// Edges (vertex pairs) shared by more than two faces.
    pub non_manifold_edges: Vec<[u32; 2]>,
    /// Number of non-manifold edges.
    pub non_manifold_edge_count: usize,
    /// Vertices whose faces form more than one fan.
    pub non_manifold_vertices: Vec<u32>,
    /// Number of non-manifold vertices.
    pub non_manifold_vertex_count: usize,
    /// Interior edges whose two faces run the same way (inconsistent orientation).
    pub flipped_edges: Vec<[u32; 2]>,
    /// Number of flipped edges.
    pub flipped_edge_count: usize,
    /// Edges with exactly one face.
    pub boundary_edges: usize,
    /// Connected chains of boundary edges.
    pub boundary_loops: usize,
    /// Faces with a repeated vertex or (near) zero area.
    pub degenerate_faces: Vec<usize>,
    /// Number of degenerate faces.
    pub degenerate_face_count: usize,
    /// Edge-connected components of faces.
    pub components: usize,
    /// V − E + F over referenced vertices.
    pub euler: i64,
    /// Intersecting face pairs (face indices), when tested.
    pub intersections: Vec<[usize; 2]>,
    /// Number of intersecting triangle pairs; `None` when not tested.
    pub intersection_count: Option<usize>,
    /// The search stopped at [`CheckOptions::max_intersections`]: the count is a lower bound.
    pub intersections_truncated: bool,
    /// Faces that repeat an earlier face: the same corner positions in the same order
    /// (one primitive drawn twice, a copied triangle). They are reported here and left
    /// out of the self-intersection search (a copy would pair with everything its
    /// original does, and coincident copies make the search quadratic). A back face (the
    /// same corners in reverse order, a leaf card's) is not a duplicate. Looked for only
    /// with the self-intersection search ([`CheckOptions::self_intersections`]) and
    /// reported as a note ([`MeshReport::notes`]), not a problem: coincident copies
    /// (a model that draws one branch twice) do not cross each other.
    pub duplicate_faces: Vec<usize>,
    /// Number of duplicate faces.
    pub duplicate_face_count: usize,
    /// Candidate triangle pairs the self-intersection search looked at (its work).
    pub pairs_searched: u64,
    /// The self-intersection search used up [`CheckOptions::max_pairs`] and stopped
    /// before every triangle was searched: the intersection count is a lower bound and
    /// the mesh is not judged valid.
    pub search_stopped: bool,
    /// The [`CheckOptions::max_pairs`] the search ran with (named in the report).
    pub max_pairs: u64,
}

impl MeshReport {
    /// True when the mesh is a consistently oriented 2-manifold with finite positions,
    /// valid references, no degenerate faces and (if tested) no self-intersections.
    /// Boundaries are allowed: compare [`MeshReport::boundary_loops`] with the design.
    pub fn is_valid(&self) -> bool {
        self.bad_face_count == 0
            && self.non_finite_count == 0
            && self.non_manifold_edge_count == 0
            && self.non_manifold_vertex_count == 0
            && self.flipped_edge_count == 0
            && self.degenerate_face_count == 0
            && self.unused_vertices == 0
            && self.intersection_count.unwrap_or(0) == 0
            && !self.search_stopped
    }

    /// Sum of the genera of the components, `(2C − B − χ) / 2`, meaningful when
    /// [`MeshReport::structural_problems`] is empty (an orientable 2-manifold, possibly
    /// with boundary). Every component satisfies `χᵢ = 2 − 2gᵢ − Bᵢ` with `gᵢ ≥ 0`, so
    /// the sum is 0 exactly when **every** component is a sphere or a sphere with holes
    /// (the per-component genus check the meshers' tests need).
    pub fn total_genus(&self) -> i64 {
        (2 * self.components as i64 - self.boundary_loops as i64 - self.euler) / 2
    }

    /// True when the structure is sound ([`MeshReport::structural_problems`] empty) and
    /// every component has genus 0 ([`MeshReport::total_genus`]).
    pub fn is_genus_zero_manifold(&self) -> bool {
        self.structural_problems().is_empty()
            && 2 * self.components as i64 - self.boundary_loops as i64 == self.euler
    }

    /// True when [`MeshReport::is_valid`] holds and there is no boundary at all.
    pub fn is_closed_manifold(&self) -> bool {
        self.is_valid() && self.boundary_edges == 0
    }

    /// The problems as short lines (empty when valid).
    pub fn problems(&self) -> Vec<String> {
        let mut out = self.structural_problems();
        if let Some(n) = self.intersection_count.filter(|&n| n > 0) {
            out.push(format!(
                "{}{n} self-intersecting triangle pair(s){}",
                if self.search_stopped || self.intersections_truncated { "at least " } else { "" },
                listed(&self.intersections, "faces")
            ));
        }
        if self.search_stopped {
            out.push(self.search_stopped_message());
        }
        out
    }

    /// The line that says the self-intersection search stopped at its work budget.
    pub fn search_stopped_message(&self) -> String {
        format!(
            "self-intersection search stopped after {} candidate triangle pairs, over its budget of {} \
             (`sylva check --max-pairs N` raises it; CheckOptions::max_pairs): not every triangle was \
             searched, so the mesh is not shown to be free of self-intersections",
            self.pairs_searched, self.max_pairs
        )
    }

    /// What the check noticed that does not make the mesh invalid: duplicate faces.
    pub fn notes(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.duplicate_face_count > 0 {
            out.push(format!(
                "{} duplicate face(s) (the same corners in the same order as an earlier face; \
                 coincident copies, left out of the self-intersection search){}",
                self.duplicate_face_count,
                listed(&self.duplicate_faces, "faces")
            ));
        }
        out
    }

    /// [`MeshReport::problems`] without self-intersections: what is wrong with the
    /// mesh's structure (references, finiteness, manifoldness, orientation, degenerate
    /// faces, unused vertices), for callers that judge intersections separately.
    pub fn structural_problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        let mut add = |n: usize, what: &str, list: String| {
            if n > 0 {
                out.push(format!("{n} {what}{list}"));
            }
        };
        add(self.bad_face_count, "face(s) with bad vertex references", listed(&self.bad_faces, "faces"));
        add(self.non_finite_count, "vertex position(s) not finite", listed(&self.non_finite, "vertices"));
        add(
            self.non_manifold_edge_count,
            "edge(s) shared by more than two faces",
            listed(&self.non_manifold_edges, "edges"),
        );
        add(
            self.non_manifold_vertex_count,
            "non-manifold (bow-tie) vertex(es)",
            listed(&self.non_manifold_vertices, "vertices"),
        );
        add(
            self.flipped_edge_count,
            "edge(s) with inconsistent face orientation",
            listed(&self.flipped_edges, "edges"),
        );
        add(self.degenerate_face_count, "degenerate face(s)", listed(&self.degenerate_faces, "faces"));
        add(self.unused_vertices, "vertex(es) used by no face", String::new());
        out
    }
}

fn listed<T: fmt::Debug>(items: &[T], what: &str) -> String {
    if items.is_empty() {
        String::new()
    } else {
        format!(" ({what} {items:?}{})", if items.len() >= 8 { " …" } else { "" })
    }
}

impl fmt::Display for MeshReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} vertices, {} faces, {} edges, {} component(s), Euler characteristic {}",
            self.vertices, self.faces, self.edges, self.components, self.euler
        )?;
        writeln!(f, "{} boundary edge(s) in {} loop(s)", self.boundary_edges, self.boundary_loops)?;
        match self.intersection_count {
            Some(n) => writeln!(
                f,
                "{}{n} self-intersecting triangle pair(s) among {} triangles",
                if self.intersections_truncated || self.search_stopped { "at least " } else { "" },
                self.triangles
            )?,
            None => writeln!(f, "self-intersections not tested")?,
        }
        for n in self.notes() {
            writeln!(f, "note: {n}")?;
        }
        let problems = self.problems();
        if problems.is_empty() {
            write!(
                f,
                "valid: {}",
                if self.boundary_edges == 0 { "closed 2-manifold" } else { "2-manifold with boundary" }
            )
        } else {
            for p in &problems {
                writeln!(f, "problem: {p}")?;
            }
            write!(f, "INVALID")
        }
    }
}

/// Disjoint-set forest with path halving.
struct UnionFind(Vec<u32>);

impl UnionFind {
    fn new(n: usize) -> Self {
        Self((0..n as u32).collect())
    }
    fn find(&mut self, mut a: u32) -> u32 {
        while self.0[a as usize] != a {
            let p = self.0[self.0[a as usize] as usize];
            self.0[a as usize] = p;
            a = p;
        }
        a
    }
    fn union(&mut self, a: u32, b: u32) {
        let (a, b) = (self.find(a), self.find(b));
        if a != b {
            self.0[a.max(b) as usize] = a.min(b);
        }
    }
}

/// Checks `mesh` (see the module documentation for what is checked).
pub fn check_mesh(mesh: &Mesh, opts: &CheckOptions) -> MeshReport {
    let nv = mesh.vertex_count();
    let nf = mesh.face_count();
    let max = opts.max_listed;
    let mut r = MeshReport { vertices: nv, faces: nf, ..Default::default() };

    for (i, p) in mesh.positions.iter().enumerate() {
        if !p.is_finite() {
            r.non_finite_count += 1;
            if r.non_finite.len() < max {
                r.non_finite.push(i);
            }
        }
    }
    // Faces usable for topology: ≥ 3 corners, all references in range.
    let mut good = vec![true; nf];
    for (f, ok) in good.iter_mut().enumerate() {
        let face = mesh.face(f);
        if face.len() < 3 || face.iter().any(|&v| v as usize >= nv) {
            *ok = false;
            r.bad_face_count += 1;
            if r.bad_faces.len() < max {
                r.bad_faces.push(f);
            }
        }
    }

    // Undirected edge → (faces using it, how many run a→b with a < b).
    let mut edges: HashMap<(u32, u32), (u32, u32, u32)> = HashMap::with_capacity(mesh.face_indices.len());
    let mut used = vec![false; nv];
    for f in (0..nf).filter(|&f| good[f]) {
        let face = mesh.face(f);
        for (k, &a) in face.iter().enumerate() {
            used[a as usize] = true;
            let b = face[(k + 1) % face.len()];
            if a == b {
                continue;
            }
            let e = edges.entry((a.min(b), a.max(b))).or_insert((0, 0, f as u32));
            e.0 += 1;
            if a < b {
                e.1 += 1;
            }
        }
    }
    r.unused_vertices = used.iter().filter(|u| !**u).count();
    r.edges = edges.len();
    let mut sorted: Vec<_> = edges.iter().map(|(&k, &v)| (k, v)).collect();
    sorted.sort_unstable_by_key(|e| e.0);
    let mut boundary = UnionFind::new(nv);
    let mut on_boundary = vec![false; nv];
    for &((a, b), (count, forward, _)) in &sorted {
        match count {
            1 => {
                r.boundary_edges += 1;
                boundary.union(a, b);
                on_boundary[a as usize] = true;
                on_boundary[b as usize] = true;
            }
            2 if forward != 1 => {
                r.flipped_edge_count += 1;
                if r.flipped_edges.len() < max {
                    r.flipped_edges.push([a, b]);
                }
            }
            2 => {}
            _ => {
                r.non_manifold_edge_count += 1;
                if r.non_manifold_edges.len() < max {
                    r.non_manifold_edges.push([a, b]);
                }
            }
        }
    }
    r.boundary_loops = (0..nv as u32).filter(|&v| on_boundary[v as usize] && boundary.find(v) == v).count();

    // Fans around each vertex: union the corners of a vertex that share an edge.
    // Corner c of face f at vertex v touches the edges (prev, v) and (v, next).
    let mut vertex_corners: Vec<Vec<(u32, u32, u32)>> = vec![Vec::new(); nv];
    let mut faces_uf = UnionFind::new(nf);
    for f in (0..nf).filter(|&f| good[f]) {
        let face = mesh.face(f);
        let n = face.len();
        for k in 0..n {
            let v = face[k];
            vertex_corners[v as usize].push((f as u32, face[(k + n - 1) % n], face[(k + 1) % n]));
        }
        for k in 0..n {
            let (a, b) = (face[k], face[(k + 1) % n]);
            if let Some(&(_, _, first)) = edges.get(&(a.min(b), a.max(b))) {
                faces_uf.union(f as u32, first);
            }
        }
    }
    for (v, corners) in vertex_corners.iter().enumerate() {
        if corners.len() < 2 {
            continue;
        }
        let mut uf = UnionFind::new(corners.len());
        let mut by_neighbour: HashMap<u32, u32> = HashMap::with_capacity(corners.len() * 2);
        for (i, &(_, p, n)) in corners.iter().enumerate() {
            for w in [p, n] {
                match by_neighbour.get(&w) {
                    Some(&j) => uf.union(i as u32, j),
                    None => {
                        by_neighbour.insert(w, i as u32);
                    }
                }
            }
        }
        let fans = (0..corners.len() as u32).filter(|&i| uf.find(i) == i).count();
        if fans > 1 {
            r.non_manifold_vertex_count += 1;
            if r.non_manifold_vertices.len() < max {
                r.non_manifold_vertices.push(v as u32);
            }
        }
    }
    r.components = (0..nf as u32).filter(|&f| good[f as usize] && faces_uf.find(f) == f).count();
    let used_count = (nv - r.unused_vertices) as i64;
    r.euler = used_count - r.edges as i64 + (nf - r.bad_face_count) as i64;

    // Degenerate faces: repeated vertex or tiny area (Newell's normal). They and the
    // duplicates below are reported here and left out of the self-intersection search.
    let mut searched = good.clone();
    let diag = crate::tolerance::Tolerance::of_points(&mesh.positions).scale;
    for f in (0..nf).filter(|&f| good[f]) {
        let face = mesh.face(f);
        let repeated = (0..face.len()).any(|i| face[i + 1..].contains(&face[i]));
        let area = newell(mesh, face).length() * 0.5;
        let longest = (0..face.len())
            .map(|k| {
                let (a, b) = (face[k] as usize, face[(k + 1) % face.len()] as usize);
                mesh.positions[a].as_dvec3().distance(mesh.positions[b].as_dvec3())
            })
            .fold(0.0, f64::max);
        // NaN areas and lengths count as degenerate too.
        let sliver = crate::tolerance::is_sliver_at(opts.sliver, area, longest * longest);
        let tiny = longest.is_nan() || longest <= opts.tiny_edge * diag;
        if repeated || sliver || tiny {
            searched[f] = false;
            r.degenerate_face_count += 1;
            if r.degenerate_faces.len() < max {
                r.degenerate_faces.push(f);
            }
        }
    }
    // Duplicates are coincident geometry, like intersections: looked for only with the
    // self-intersection search, which they would otherwise make quadratic.
    let duplicates = if opts.self_intersections { duplicate_faces(mesh, &searched) } else { Vec::new() };
    for f in duplicates {
        searched[f] = false;
        r.duplicate_face_count += 1;
        if r.duplicate_faces.len() < max {
            r.duplicate_faces.push(f);
        }
    }

    // Self-intersections, only on meshes whose positions and references are sound.
    r.triangles = (0..nf).filter(|&f| good[f]).map(|f| mesh.face(f).len().saturating_sub(2)).sum();
    r.max_pairs = opts.max_pairs;
    if opts.self_intersections && r.non_finite_count == 0 {
        let tris = fan_triangles(mesh, |f| searched[f]);
        let found = self_intersections_within(&mesh.positions, &tris, opts.max_intersections, opts.max_pairs);
        r.intersections_truncated = found.pairs.len() >= opts.max_intersections;
        r.intersection_count = Some(found.pairs.len());
        r.intersections = found.pairs.into_iter().take(max).collect();
        r.pairs_searched = found.work;
        r.search_stopped = found.stopped;
    }
    r
}

/// The faces among `keep` that repeat an earlier kept face: the same corner positions
/// (bit-identical, −0 = 0) in the same cyclic order, ascending. O(corners) with hashing.
fn duplicate_faces(mesh: &Mesh, keep: &[bool]) -> Vec<usize> {
    // Vertices at one position share an id, so copies with vertices of their own match.
    let mut ids: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
    let weld: Vec<u32> = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let key = p.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() });
            *ids.entry(key).or_insert(i as u32)
        })
        .collect();
    // A face's key: its welded corners rotated to start at the smallest (which keeps the
    // orientation, so a back face is a different key). Faces of up to 4 corners take a
    // fixed-size key; longer ones a vector.
    let mut small: HashMap<[u32; 4], ()> = HashMap::with_capacity(mesh.face_count());
    let mut long: HashMap<Vec<u32>, ()> = HashMap::new();
    let mut out = Vec::new();
    for f in (0..mesh.face_count()).filter(|&f| keep[f]) {
        let face = mesh.face(f);
        let at = (0..face.len()).min_by_key(|&k| weld[face[k] as usize]).unwrap_or(0);
        let rotated = (0..face.len()).map(|k| weld[face[(at + k) % face.len()] as usize]);
        let first_time = if face.len() <= 4 {
            let mut key = [u32::MAX; 4];
            for (slot, v) in key.iter_mut().zip(rotated) {
                *slot = v;
            }
            small.insert(key, ()).is_none()
        } else {
            long.insert(rotated.collect(), ()).is_none()
        };
        if !first_time {
            out.push(f);
        }
    }
    out
}

/// The faces `keep` accepts, split into fans from their first corner: `(corners, face)`
/// per triangle, the input of [`self_intersections`].
pub(crate) fn fan_triangles(mesh: &Mesh, keep: impl Fn(usize) -> bool) -> Vec<([u32; 3], u32)> {
    let mut tris = Vec::with_capacity(mesh.face_indices.len());
    for f in (0..mesh.face_count()).filter(|&f| keep(f)) {
        let face = mesh.face(f);
        for k in 1..face.len().saturating_sub(1) {
            tris.push(([face[0], face[k], face[k + 1]], f as u32));
        }
    }
    tris
}

fn newell(mesh: &Mesh, face: &[u32]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for (k, &a) in face.iter().enumerate() {
        let p = mesh.positions[a as usize].as_dvec3();
        let q = mesh.positions[face[(k + 1) % face.len()] as usize].as_dvec3();
        n += p.cross(q);
    }
    n
}

/// An axis-aligned box (shared with [`crate::fit::decollide`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Aabb {
    pub(crate) lo: DVec3,
    pub(crate) hi: DVec3,
}

impl Aabb {
    /// The empty box: overlaps nothing, grows to whatever it is grown by.
    pub(crate) const EMPTY: Aabb =
        Aabb { lo: DVec3::splat(f64::INFINITY), hi: DVec3::splat(f64::NEG_INFINITY) };
    fn empty() -> Self {
        Self::EMPTY
    }
    pub(crate) fn grow(&mut self, o: &Aabb) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
    }
    pub(crate) fn overlaps(&self, o: &Aabb) -> bool {
        self.lo.cmple(o.hi).all() && o.lo.cmple(self.hi).all()
    }
}

/// A BVH node: a box and either two children or a range of leaf items.
pub(crate) struct Node {
    pub(crate) bounds: Aabb,
    /// Leaves: start into `order`; inner: index of the left child (right = left + 1).
    pub(crate) first: u32,
    /// Leaf item count; 0 for an inner node.
    pub(crate) count: u32,
}

/// Builds the BVH over `boxes` of the items in `order` (median split on the longest
/// axis of the centres, ties by item id); `order` is permuted so each leaf owns a
/// contiguous range.
pub(crate) fn build_bvh(boxes: &[Aabb], order: &mut [u32]) -> Vec<Node> {
    const LEAF: usize = 4;
    let mut nodes = vec![Node { bounds: Aabb::empty(), first: 0, count: order.len() as u32 }];
    let mut stack = vec![(0usize, 0usize, order.len())];
    while let Some((id, start, end)) = stack.pop() {
        let mut b = Aabb::empty();
        let mut centres = Aabb::empty();
        for &t in &order[start..end] {
            b.grow(&boxes[t as usize]);
            let c = (boxes[t as usize].lo + boxes[t as usize].hi) * 0.5;
            centres.grow(&Aabb { lo: c, hi: c });
        }
        nodes[id].bounds = b;
        let extent = centres.hi - centres.lo;
        if end - start <= LEAF || extent.max_element() <= 0.0 {
            nodes[id].first = start as u32;
            nodes[id].count = (end - start) as u32;
            continue;
        }
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = (start + end) / 2;
        let key = |t: &u32| boxes[*t as usize].lo[axis] + boxes[*t as usize].hi[axis];
        order[start..end]
            .select_nth_unstable_by(mid - start, |a, b| key(a).total_cmp(&key(b)).then(a.cmp(b)));
        let left = nodes.len();
        nodes.push(Node { bounds: Aabb::empty(), first: 0, count: 0 });
        nodes.push(Node { bounds: Aabb::empty(), first: 0, count: 0 });
        nodes[id].first = left as u32;
        nodes[id].count = 0;
        stack.push((left, start, mid));
        stack.push((left + 1, mid, end));
    }
    nodes
}

/// Pairs of internodes (each named by its child node, smaller first) of `skeleton`
/// whose capsules overlap where the tree does not join them: branches that pass
/// through each other in the skeleton itself, so no mesher can keep their surfaces
/// apart. A capsule is the segment parent → child swept by the larger of the two radii;
/// overlaps shallower than `tolerance × (r_a + r_b)` are ignored.
///
/// How the tree joins the two decides how they are measured (`Meeting`):
/// - siblings, and branches of one node joined through internodes shorter in all than
///   `r_a + r_b`, always overlap at their joint whatever their angle; they collide only
///   when the far end of one comes within the radii of the other's axis (two twigs
///   leaving a fork a few degrees apart, or a stub shorter than the radii);
/// - one internode hanging below the other through such short internodes collides when
///   the bends between them fold a tube of their radii (a zig-zag of two sharp bends
///   over a stub does; a straight run of short stations does not);
/// - internodes linked through a chain shorter than twice their radii collide only
///   where their axes come closer than half the chain (a gently curved stem of short,
///   thick internodes is not a collision);
/// - chained internodes (one ends where the other starts) never collide: that is a
///   bend.
pub fn skeleton_collisions(skeleton: &crate::Skeleton, tolerance: f64) -> Vec<[usize; 2]> {
    let seg: Vec<usize> = (0..skeleton.len()).filter(|&i| skeleton.parent[i] != crate::NO_PARENT).collect();
    if seg.is_empty() {
        return Vec::new();
    }
    let depth = node_depths(&skeleton.parent);
    let ends = |s: usize| {
        let i = seg[s];
        let p = skeleton.parent[i] as usize;
        let r = skeleton.radius[i].max(skeleton.radius[p]) as f64;
        ([skeleton.position[p].as_dvec3(), skeleton.position[i].as_dvec3()], r, i)
    };
    let boxes: Vec<Aabb> = (0..seg.len())
        .map(|s| {
            let ([a, b], r, _) = ends(s);
            Aabb { lo: a.min(b) - r, hi: a.max(b) + r }
        })
        .collect();
    let mut order: Vec<u32> = (0..seg.len() as u32).collect();
    let nodes = build_bvh(&boxes, &mut order);
    let mut pairs: Vec<[usize; 2]> = (0..seg.len())
        .into_par_iter()
        .flat_map_iter(|s| {
            let mut found = Vec::new();
            let (x, ra, ia) = ends(s);
            for o in query(&nodes, &order, &boxes[s]) {
                let (y, rb, ib) = ends(o);
                if o <= s || !boxes[o].overlaps(&boxes[s]) {
                    continue;
                }
                // Axes this far apart never collide: a joined or linked gap is never
                // smaller than the axis gap, and a folded pair's axes are closer (the
                // stub between them is shorter than the radii).
                let limit = (ra + rb) * (1.0 - tolerance);
                if segment_distance(x[0], x[1], y[0], y[1]) >= limit.max(ra + rb) {
                    continue;
                }
                let m = meeting(skeleton, &depth, ia, ib, ra + rb);
                if meeting_gap(x, y, m, ra + rb).is_some_and(|(d, ..)| d < limit) {
                    found.push([ia.min(ib), ia.max(ib)]);
                }
            }
            found
        })
        .collect();
    pairs.sort_unstable();
    pairs
}

/// How two internodes (named by their child nodes) meet in the tree, for the
/// skeleton-collision rule ([`skeleton_collisions`], and `decollide`, which pulls
/// apart exactly what it counts). `short` below is the sum of the two radii.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Meeting {
    /// One ends where the other starts: a bend, never a collision.
    Chained,
    /// Siblings, or branches of a common node joined through internodes shorter in
    /// all than `short`: their capsules overlap at the joint whatever their angle, so
    /// each is measured from its far end (its child node) to the other's axis.
    Joined,
    /// One hangs below the other through internodes of total length `path` under
    /// `short` (a stub, or a run of short stations): their axes are always that close,
    /// so what matters is whether the bends between them fold a tube of their radii,
    /// i.e. whether `path < short / 2 × bends`, `bends` the sum of `tan(β/2)` over the
    /// bends `β` at the nodes from one to the other (a straight run never folds, a
    /// U-turn always does).
    Folded {
        /// Length of the internodes between the two.
        path: f64,
        /// Sum of `tan(β/2)` over the bends between them (capped).
        bends: f64,
    },
    /// Joined through internodes of total length `P` between `short` and
    /// `short / LINK_FOLD`: their axes may come as close as `P` without anything
    /// folding (a gently curved stem of short, thick internodes), so they collide only
    /// where the axes come closer than `LINK_FOLD × P`.
    Linked(f64),
    /// Measured axis to axis.
    Apart,
}

/// Steps walked up the tree at most when looking for a close joint (a chain of
/// zero-length internodes must not make the walk unbounded).
const MAX_JOINED_HOPS: usize = 64;

/// See [`Meeting::Linked`]: the fraction of the chain between two linked internodes
/// their axes may come to before they count as folded onto each other. It makes the
/// rule continuous in the radii (at `P = short / LINK_FOLD` the linked threshold is the
/// radii), so thinning never turns a chain into a new collision.
const LINK_FOLD: f64 = 0.5;

/// The depth of every node (parents precede their children in a valid skeleton).
pub(crate) fn node_depths(parent: &[u32]) -> Vec<u32> {
    let mut depth = vec![0u32; parent.len()];
    for i in 0..parent.len() {
        let p = parent[i] as usize; // NO_PARENT is never below `i`
        if p < i {
            depth[i] = depth[p] + 1;
        }
    }
    depth
}

/// How internodes `i` and `j` meet (see [`Meeting`]); `short` is the sum of their radii.
pub(crate) fn meeting(s: &crate::Skeleton, depth: &[u32], i: usize, j: usize, short: f64) -> Meeting {
    let (pi, pj) = (s.parent[i] as usize, s.parent[j] as usize);
    if pi == j || pj == i {
        return Meeting::Chained;
    }
    let limit = short / LINK_FOLD;
    // Walk both up to their common ancestor, adding the internodes passed on the way
    // (not `i`'s and `j`'s own).
    let (mut at, mut moved, mut path, mut bends) = ([i, j], [false; 2], 0.0, 0.0);
    let pos = |n: usize| s.position[n].as_dvec3();
    for _ in 0..MAX_JOINED_HOPS {
        if at[0] == at[1] {
            return match (path < short, moved) {
                (true, [false, _] | [_, false]) => Meeting::Folded { path, bends },
                (true, _) => Meeting::Joined,
                (false, _) => Meeting::Linked(path),
            };
        }
        let side = usize::from(depth[at[1]] > depth[at[0]]);
        let n = at[side];
        let p = s.parent[n];
        if p == crate::NO_PARENT {
            return Meeting::Apart;
        }
        if moved[side] {
            path += s.internode_length(n);
            if path >= limit {
                return Meeting::Apart;
            }
        }
        moved[side] = true;
        // The bend at `p`, between its own internode and the one walked up.
        let p = p as usize;
        if let Some(&g) = s.parent.get(p).filter(|&&g| g != crate::NO_PARENT) {
            let (u, v) =
                ((pos(p) - pos(g as usize)).normalize_or_zero(), (pos(n) - pos(p)).normalize_or_zero());
            let half = 0.5 * u.dot(v).clamp(-1.0, 1.0).acos();
            bends += half.tan().min(MAX_BEND_TAN);
        }
        at[side] = p;
    }
    Meeting::Apart
}

/// Cap on one bend's `tan(β/2)` in [`Meeting::Folded`] (a U-turn).
const MAX_BEND_TAN: f64 = 1e6;

/// The gap between two internode axes `x` and `y` (parent end, child end) met as `m`,
/// with the closest points (on `x`, on `y`), to be compared with the radii `short` as
/// for any pair: for [`Meeting::Linked`] the axis gap is scaled up by
/// `short / (LINK_FOLD × P)` when that is over 1; for [`Meeting::Folded`] it is
/// `2 × path / bends` (under `short` exactly when the bends fold the tube). `None` for
/// chained internodes.
pub(crate) fn meeting_gap(
    x: [DVec3; 2],
    y: [DVec3; 2],
    m: Meeting,
    short: f64,
) -> Option<(f64, DVec3, DVec3)> {
    match m {
        Meeting::Chained => None,
        Meeting::Apart => Some(segment_closest(x[0], x[1], y[0], y[1])),
        Meeting::Folded { path, bends } => {
            let (_, p, q) = segment_closest(x[0], x[1], y[0], y[1]);
            Some((if bends > 0.0 { 2.0 * path / bends } else { f64::INFINITY }, p, q))
        }
        Meeting::Linked(path) => {
            let (d, p, q) = segment_closest(x[0], x[1], y[0], y[1]);
            Some((d * (short / (LINK_FOLD * path).max(f64::MIN_POSITIVE)).max(1.0), p, q))
        }
        Meeting::Joined => {
            let (dx, px, qx) = segment_closest(x[1], x[1], y[0], y[1]);
            let (dy, py, qy) = segment_closest(y[1], y[1], x[0], x[1]);
            Some(if dx <= dy { (dx, px, qx) } else { (dy, qy, py) })
        }
    }
}

/// Leaf items of the BVH whose node boxes overlap `b` (candidates; callers re-test).
pub(crate) fn query(nodes: &[Node], order: &[u32], b: &Aabb) -> Vec<usize> {
    let mut out = Vec::new();
    let mut stack = vec![0u32];
    while let Some(n) = stack.pop() {
        let node = &nodes[n as usize];
        if !node.bounds.overlaps(b) {
            continue;
        }
        if node.count == 0 {
            stack.push(node.first);
            stack.push(node.first + 1);
        } else {
            out.extend(
                order[node.first as usize..(node.first + node.count) as usize].iter().map(|&o| o as usize),
            );
        }
    }
    out
}

/// Closest distance between segments p0p1 and q0q1.
fn segment_distance(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> f64 {
    segment_closest(p0, p1, q0, q1).0
}

/// Closest distance between segments p0p1 and q0q1, with the closest points on each.
pub(crate) fn segment_closest(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> (f64, DVec3, DVec3) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let (s, t) = if a <= 1e-30 && e <= 1e-30 {
        (0.0, 0.0)
    } else if a <= 1e-30 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= 1e-30 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-30 { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    let (x, y) = (p0 + d1 * s, q0 + d2 * t);
    (x.distance(y), x, y)
}

/// Pairs of faces whose triangles cross (each pair once, smaller triangle index first),
/// with no work budget (the callers bound the mesh's size).
pub(crate) fn self_intersections(
    positions: &[Vec3],
    tris: &[([u32; 3], u32)],
    limit: usize,
) -> Vec<[usize; 2]> {
    self_intersections_within(positions, tris, limit, u64::MAX).pairs
}

/// What [`self_intersections_within`] found.
pub(crate) struct Search {
    /// Crossing face pairs, ascending, at most the limit.
    pub(crate) pairs: Vec<[usize; 2]>,
    /// Candidate pairs looked at: every triangle its box query returned.
    pub(crate) work: u64,
    /// The search stopped over `max_work` before every triangle was searched.
    pub(crate) stopped: bool,
}

/// Most triangles in one part of the search.
const SEARCH_PART_MAX: usize = 1 << 14;

/// Fewest triangles in one part of the search (and the first part's size): the search
/// stops at most this many triangles' candidates past its budget.
const SEARCH_PART_MIN: usize = 64;

/// About this many candidate pairs per part of the search (parts are sized from the work
/// per triangle so far, so a part costs about the same on any input).
const SEARCH_PART_WORK: u64 = 1 << 21;

/// [`self_intersections`] with a work budget: one unit per candidate pair a triangle's
/// box query returns (where many triangles overlap, as on coincident or tangled
/// geometry, nearly every pair is a candidate and the search is quadratic). The search
/// runs through the triangles in order, in parts sized from the work per triangle so far,
/// each part in parallel, and stops after the part that takes the total over `max_work`
/// — so where it stops, and what it found, depends on the input alone, not on the
/// thread count or the machine.
pub(crate) fn self_intersections_within(
    positions: &[Vec3],
    tris: &[([u32; 3], u32)],
    limit: usize,
    max_work: u64,
) -> Search {
    if tris.is_empty() {
        return Search { pairs: Vec::new(), work: 0, stopped: false };
    }
    let corners = |t: usize| tris[t].0.map(|v| positions[v as usize].as_dvec3());
    let boxes: Vec<Aabb> = (0..tris.len())
        .map(|t| {
            let [a, b, c] = corners(t);
            // Pad by a relative epsilon so touching boxes are still visited.
            let pad = (a.abs().max(b.abs()).max(c.abs())).max_element() * 1e-9;
            Aabb { lo: a.min(b).min(c) - pad, hi: a.max(b).max(c) + pad }
        })
        .collect();
    let mut order: Vec<u32> = (0..tris.len() as u32).collect();
    let nodes = build_bvh(&boxes, &mut order);
    // Triangles are searched in order, in parts, each part in parallel; the search
    // stops after the part that reaches the limit or uses up the work budget. Which
    // triangles were searched is then the same on every run and for any number of
    // threads (a flag checked inside the workers made a truncated result depend on
    // thread timing). Parts end between faces, and every pair found in a later part has
    // a larger first face, so stopping at the limit after any part keeps the same
    // (sorted, truncated) pairs as searching on would.
    let n = tris.len();
    let mut pairs: Vec<[usize; 2]> = Vec::new();
    let (mut work, mut stopped) = (0u64, false);
    // The first part is small: on coincident geometry one triangle's query returns
    // nearly all of them.
    let (mut start, mut part) = (0usize, SEARCH_PART_MIN);
    while start < n {
        let mut end = (start + part).min(n);
        while end < n && tris[end].1 == tris[end - 1].1 {
            end += 1;
        }
        let found: Vec<(u64, Vec<[usize; 2]>)> = (start..end)
            .into_par_iter()
            .map(|t| {
                let mut found = Vec::new();
                let (tv, tb, tp) = (tris[t].0, boxes[t], corners(t));
                let candidates = query(&nodes, &order, &tb);
                for &o in &candidates {
                    if o <= t || !boxes[o].overlaps(&tb) || tris[o].0.iter().any(|v| tv.contains(v)) {
                        continue;
                    }
                    if triangles_cross(&tp, &corners(o)) {
                        found.push([tris[t].1 as usize, tris[o].1 as usize]);
                    }
                }
                (candidates.len() as u64, found)
            })
            .collect();
        let part_work: u64 = found.iter().map(|f| f.0).sum();
        work = work.saturating_add(part_work);
        pairs.extend(found.into_iter().flat_map(|f| f.1));
        let searched = end - start;
        start = end;
        if pairs.len() >= limit {
            break;
        }
        if work > max_work && start < n {
            stopped = true;
            break;
        }
        let per_triangle = (part_work / searched as u64).max(1);
        part = usize::try_from(SEARCH_PART_WORK / per_triangle)
            .unwrap_or(usize::MAX)
            .clamp(SEARCH_PART_MIN, SEARCH_PART_MAX);
    }
    pairs.sort_unstable();
    // A truncated count is a lower bound; below the limit the result is exact.
    pairs.truncate(limit);
    Search { pairs, work, stopped }
}

/// Crossing triangle pairs *within* groups, for the meshers' repair loops: `tris` holds
/// `(group, corners, face)`; each group's triangles are searched among themselves by
/// sweep and prune along the group's longest extent (a junction has a few hundred to a
/// few thousand refined triangles; this measured 5× faster than a BVH per group and far
/// cheaper than one over the whole mesh), triangles sharing a vertex are skipped as in
/// [`check_mesh`]. Returns `(group, face, face)` with at most `per_group` pairs per
/// group, groups ascending; parallel over groups.
pub(crate) fn group_crossings(
    positions: &[Vec3],
    tris: Vec<(u32, [u32; 3], u32)>,
    per_group: usize,
) -> Vec<(u32, u32, u32)> {
    group_crossings_within(positions, tris, per_group, u64::MAX).map(|(found, _)| found).unwrap_or_default()
}

/// A crossing pair of [`group_crossings`]: `(group, face, face)`.
pub(crate) type GroupPair = (u32, u32, u32);

/// Work units of [`group_crossings_within`] spent between two looks at the shared count.
const GROUP_WORK_CHUNK: u64 = 1 << 16;

/// [`group_crossings`] with a work budget (issue 27): one unit per triangle of a group
/// and per candidate pair the sweep looks at (the sweep is quadratic where many of a
/// group's triangles overlap along its axis). Returns the pairs and the work spent, or
/// `None` when the search needs more than `max_work` units (it stops soon after, so a
/// pathological group cannot run for minutes). Which it is does not depend on the
/// thread count: every group's work is fixed, and the search stops only once the sum
/// is over the budget.
pub(crate) fn group_crossings_within(
    positions: &[Vec3],
    mut tris: Vec<(u32, [u32; 3], u32)>,
    per_group: usize,
    max_work: u64,
) -> Option<(Vec<GroupPair>, u64)> {
    use std::sync::atomic::{AtomicU64, Ordering};
    let spent = AtomicU64::new(0);
    // Adds `n` units; false once the total is over the budget.
    let charge = |n: u64| spent.fetch_add(n, Ordering::Relaxed).saturating_add(n) <= max_work;
    tris.sort_unstable_by_key(|t| (t.0, t.2));
    let groups: Vec<&[(u32, [u32; 3], u32)]> = tris.chunk_by(|a, b| a.0 == b.0).collect();
    let mut out: Vec<(u32, u32, u32)> = groups
        .into_par_iter()
        .flat_map_iter(|g| {
            let mut found = Vec::new();
            if !charge(g.len() as u64) {
                return found;
            }
            let tri: Vec<[DVec3; 3]> =
                g.iter().map(|t| t.1.map(|v| positions[v as usize].as_dvec3())).collect();
            let bx: Vec<Aabb> =
                tri.iter().map(|[a, b, c]| Aabb { lo: a.min(*b).min(*c), hi: a.max(*b).max(*c) }).collect();
            // Sweep and prune along the group's longest extent.
            let mut all = Aabb::EMPTY;
            bx.iter().for_each(|b| all.grow(b));
            let ax = (all.hi - all.lo).max_position();
            let mut order: Vec<usize> = (0..g.len()).collect();
            order.sort_by(|&a, &b| bx[a].lo[ax].total_cmp(&bx[b].lo[ax]));
            let mut local = 0u64;
            'all: for (i, &a) in order.iter().enumerate() {
                for &b in &order[i + 1..] {
                    if bx[b].lo[ax] > bx[a].hi[ax] {
                        break;
                    }
                    local += 1;
                    if local == GROUP_WORK_CHUNK {
                        local = 0;
                        if !charge(GROUP_WORK_CHUNK) {
                            break 'all;
                        }
                    }
                    if bx[a].overlaps(&bx[b])
                        && !g[a].1.iter().any(|v| g[b].1.contains(v))
                        && triangles_cross(&tri[a], &tri[b])
                    {
                        found.push((g[0].0, g[a].2.min(g[b].2), g[a].2.max(g[b].2)));
                        if found.len() >= per_group {
                            break 'all;
                        }
                    }
                }
            }
            charge(local);
            found
        })
        .collect();
    let spent = spent.into_inner();
    if spent > max_work {
        return None;
    }
    out.sort_unstable();
    Some((out, spent))
}

/// True when an edge of either triangle passes through the other's interior (the
/// checker's intersection test; triangles sharing a vertex should be skipped by the
/// caller).
pub(crate) fn triangles_cross(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    // Early out: one triangle strictly on one side of the other's plane cannot touch it.
    if off_plane(a, b) || off_plane(b, a) {
        return false;
    }
    (0..3).any(|i| segment_hits(a[i], a[(i + 1) % 3], b))
        || (0..3).any(|i| segment_hits(b[i], b[(i + 1) % 3], a))
}

/// True when `b` lies strictly on one side of the plane of `a`.
fn off_plane(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    let n = (a[1] - a[0]).cross(a[2] - a[0]);
    let d = b.map(|p| n.dot(p - a[0]));
    (d[0] > 0.0 && d[1] > 0.0 && d[2] > 0.0) || (d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0)
}

/// Segment p→q against triangle t (Möller–Trumbore, both ends inclusive, parallel misses).
fn segment_hits(p: DVec3, q: DVec3, t: &[DVec3; 3]) -> bool {
    let d = q - p;
    let e1 = t[1] - t[0];
    let e2 = t[2] - t[0];
    let h = d.cross(e2);
    let det = e1.dot(h);
    let scale = e1.length() * e2.length() * d.length();
    if det.abs() <= 1e-12 * scale {
        return false;
    }
    let inv = 1.0 / det;
    let s = p - t[0];
    let u = s.dot(h) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let qv = s.cross(e1);
    let v = d.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let s_param = e2.dot(qv) * inv;
    (0.0..=1.0).contains(&s_param)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn group_crossings_only_within_groups() {
        // Two triangles crossing each other, and a third far away.
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.5, 0.5, -1.0),
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(1.5, 0.2, 0.0),
            Vec3::new(9.0, 9.0, 9.0),
            Vec3::new(9.0, 10.0, 9.0),
            Vec3::new(10.0, 9.0, 9.0),
        ];
        let (a, b, far) = ([0, 1, 2], [3, 4, 5], [6, 7, 8]);
        let same = group_crossings(&p, vec![(7, a, 0), (7, b, 1), (7, far, 2)], 8);
        assert_eq!(same, vec![(7, 0, 1)]);
        assert!(group_crossings(&p, vec![(1, a, 0), (2, b, 1)], 8).is_empty());
        // Sharing a vertex: not tested (neighbours on a surface).
        assert!(group_crossings(&p, vec![(1, a, 0), (1, [3, 4, 0], 1)], 8).is_empty());
    }

    fn cube(offset: Vec3) -> Mesh {
        let mut m = Mesh::new();
        for i in 0..8 {
            m.positions
                .push(offset + Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32));
        }
        for f in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
            m.push_face(&f);
        }
        m
    }

    fn merge(a: &Mesh, b: &Mesh) -> Mesh {
        let mut m = a.clone();
        let off = m.positions.len() as u32;
        m.positions.extend_from_slice(&b.positions);
        for f in 0..b.face_count() {
            let face: Vec<u32> = b.face(f).iter().map(|v| v + off).collect();
            m.push_face(&face);
        }
        m
    }

    #[test]
    fn crossing_branches_collide_and_a_fork_does_not() {
        use crate::{Skeleton, NO_PARENT};
        let mut s = Skeleton::new();
        let root = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let top = s.push(Vec3::Y * 2.0, 0.1, root, Vec3::X, 0);
        s.push(Vec3::new(1.0, 3.0, 0.0), 0.05, top, Vec3::X, 1);
        s.push(Vec3::new(-1.0, 3.0, 0.0), 0.05, top, Vec3::X, 1);
        assert!(skeleton_collisions(&s, 0.01).is_empty());
        // A second tree whose trunk passes through the first one's trunk.
        let r2 = s.push(Vec3::new(-1.0, 1.0, 0.05), 0.1, NO_PARENT, Vec3::Y, 0);
        let t2 = s.push(Vec3::new(1.0, 1.0, 0.05), 0.1, r2, Vec3::Y, 0);
        assert_eq!(skeleton_collisions(&s, 0.01), vec![[1, t2 as usize]]);
        assert!(
            (segment_distance(
                Vec3::ZERO.as_dvec3(),
                DVec3::X,
                DVec3::new(0.5, 1.0, -1.0),
                DVec3::new(0.5, 1.0, 1.0)
            ) - 1.0)
                .abs()
                < 1e-12
        );
    }

    /// A skeleton from (position, radius, parent) triples.
    fn skeleton_of(nodes: &[([f32; 3], f32, u32)]) -> crate::Skeleton {
        let mut s = crate::Skeleton::new();
        for &(p, r, parent) in nodes {
            s.push(Vec3::from(p), r, parent, Vec3::X, 0);
        }
        s
    }

    #[test]
    fn siblings_collide_only_when_a_far_end_lies_in_the_other() {
        use crate::NO_PARENT;
        let fork = |deg: f32, len: f32| {
            let (sn, cs) = deg.to_radians().sin_cos();
            skeleton_of(&[
                ([0.0; 3], 0.1, NO_PARENT),
                ([0.0, 1.0, 0.0], 0.1, 0),
                ([0.0, 1.0 + len, 0.0], 0.1, 1),
                ([len * sn, 1.0 + len * cs, 0.0], 0.1, 1),
            ])
        };
        // Two twigs 3° apart overlap along their length; 40° apart they clear.
        assert_eq!(skeleton_collisions(&fork(3.0, 1.0), 0.01), vec![[2, 3]]);
        assert!(skeleton_collisions(&fork(40.0, 1.0), 0.01).is_empty());
        // A stub shorter than the radii ends inside its sibling, at any angle: the joint
        // meshers fold there (clusters of such stubs at `lsys-honda-f`'s tips), so it
        // counts.
        let mut s = fork(40.0, 1.0);
        s.position[2] = Vec3::new(0.0, 1.05, 0.0);
        assert_eq!(skeleton_collisions(&s, 0.01), vec![[2, 3]]);
    }

    #[test]
    fn a_run_of_short_internodes_collides_only_where_it_folds() {
        use crate::NO_PARENT;
        // A straight stem of radius 0.1 written with 0.05-long stations: no collision,
        // although every internode's capsule overlaps the next-but-one's.
        let mut nodes = vec![([0.0f32; 3], 0.1f32, NO_PARENT)];
        for k in 1..=20u32 {
            nodes.push(([0.0, 0.05 * k as f32, 0.0], 0.1, k - 1));
        }
        assert!(skeleton_collisions(&skeleton_of(&nodes), 0.01).is_empty());
        // A gentle curve of the same stations (2° per node): still none.
        let mut p = Vec3::ZERO;
        let mut curved = vec![([0.0f32; 3], 0.1f32, NO_PARENT)];
        for k in 1..=20u32 {
            let a = (2.0 * k as f32).to_radians();
            p += Vec3::new(a.sin(), a.cos(), 0.0) * 0.05;
            curved.push((p.to_array(), 0.1, k - 1));
        }
        assert!(skeleton_collisions(&skeleton_of(&curved), 0.01).is_empty());
        // A U-turn over a 0.05 stub: the stem folds back onto itself.
        let u = skeleton_of(&[
            ([0.0; 3], 0.1, NO_PARENT),
            ([0.0, 1.0, 0.0], 0.1, 0),
            ([0.05, 1.0, 0.0], 0.1, 1),
            ([0.05, 0.0, 0.0], 0.1, 2),
        ]);
        assert_eq!(skeleton_collisions(&u, 0.01), vec![[1, 3]]);
    }

    #[test]
    fn a_cube_is_a_closed_manifold() {
        let r = check_mesh(&cube(Vec3::ZERO), &CheckOptions::default());
        assert!(r.is_closed_manifold(), "{r}");
        assert_eq!((r.vertices, r.edges, r.faces, r.euler, r.components), (8, 12, 6, 2, 1));
        assert_eq!(r.intersection_count, Some(0));
    }

    /// A quad torus of `n × n` vertices (genus 1).
    fn torus(n: u32) -> Mesh {
        use std::f32::consts::TAU;
        let mut m = Mesh::new();
        for i in 0..n {
            for j in 0..n {
                let (a, b) = (TAU * i as f32 / n as f32, TAU * j as f32 / n as f32);
                let r = 2.0 + 0.7 * b.cos();
                m.positions.push(Vec3::new(r * a.cos(), 0.7 * b.sin(), r * a.sin()));
            }
        }
        let id = |i: u32, j: u32| (i % n) * n + (j % n);
        for i in 0..n {
            for j in 0..n {
                m.push_face(&[id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j)]);
            }
        }
        m
    }

    #[test]
    fn genus_is_counted_over_every_component() {
        let r = check_mesh(&cube(Vec3::ZERO), &CheckOptions::default());
        assert_eq!(r.total_genus(), 0);
        assert!(r.is_genus_zero_manifold());
        let t = check_mesh(&torus(6), &CheckOptions::default());
        assert!(t.is_closed_manifold(), "{t}");
        assert_eq!((t.euler, t.total_genus()), (0, 1));
        assert!(!t.is_genus_zero_manifold());
        // A torus next to two cubes: three components, genera 0 + 0 + 1.
        let three =
            merge(&merge(&cube(Vec3::new(9.0, 0.0, 0.0)), &cube(Vec3::new(-9.0, 0.0, 0.0))), &torus(6));
        let r = check_mesh(&three, &CheckOptions::default());
        assert_eq!((r.components, r.euler, r.total_genus()), (3, 4, 1));
        assert!(!r.is_genus_zero_manifold());
    }

    #[test]
    fn an_open_box_has_one_boundary_loop() {
        let mut m = Mesh::new();
        let c = cube(Vec3::ZERO);
        m.positions = c.positions.clone();
        for f in 0..5 {
            m.push_face(c.face(f));
        }
        let r = check_mesh(&m, &CheckOptions::default());
        assert!(r.is_valid() && !r.is_closed_manifold(), "{r}");
        assert_eq!((r.boundary_edges, r.boundary_loops), (4, 1));
    }

    #[test]
    fn a_flipped_face_is_reported() {
        let mut m = cube(Vec3::ZERO);
        let f = m.corners(2);
        m.face_indices[f].reverse();
        let r = check_mesh(&m, &CheckOptions::default());
        assert_eq!(r.flipped_edge_count, 4, "{r}");
        assert!(!r.is_valid());
    }

    #[test]
    fn overlapping_cubes_intersect_and_separate_ones_do_not() {
        let apart = merge(&cube(Vec3::ZERO), &cube(Vec3::new(2.0, 0.0, 0.0)));
        let r = check_mesh(&apart, &CheckOptions::default());
        assert!(r.is_closed_manifold(), "{r}");
        assert_eq!(r.components, 2);
        let overlap = merge(&cube(Vec3::ZERO), &cube(Vec3::new(0.5, 0.3, 0.2)));
        let r = check_mesh(&overlap, &CheckOptions::default());
        assert!(r.intersection_count.unwrap() > 0, "{r}");
        assert!(!r.is_valid());
        assert!(r.problems().iter().any(|p| p.contains("self-intersecting")));
    }

    #[test]
    fn a_third_face_on_an_edge_is_non_manifold() {
        let mut m = cube(Vec3::ZERO);
        m.positions.push(Vec3::new(0.5, -1.0, 0.5));
        m.push_face(&[0, 1, 8]);
        let r = check_mesh(&m, &CheckOptions { self_intersections: false, ..Default::default() });
        assert_eq!(r.non_manifold_edge_count, 1, "{r}");
        assert_eq!(r.intersection_count, None);
    }

    #[test]
    fn bow_ties_nan_bad_indices_and_degenerate_faces_are_reported() {
        let mut m = Mesh::new();
        m.positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
        ];
        m.push_face(&[0, 1, 2]);
        m.push_face(&[0, 3, 4]);
        m.push_face(&[0, 1, 5]); // zero area: collinear
        m.push_face(&[0, 1, 9]); // out of range
        let r = check_mesh(&m, &CheckOptions::default());
        assert_eq!(r.bad_face_count, 1);
        assert_eq!(r.degenerate_face_count, 1);
        assert!(r.non_manifold_vertex_count >= 1, "{r}");
        m.positions[2].x = f32::NAN;
        let r = check_mesh(&m, &CheckOptions::default());
        assert_eq!(r.non_finite_count, 1);
        assert_eq!(r.intersection_count, None);
        assert!(!r.is_valid());
    }

    /// A truncated search finds the same pairs on every run and for any number of
    /// threads (it used to depend on thread timing: sweep on wp-weeping-willow wrote
    /// different files run to run).
    #[test]
    fn truncated_intersection_search_is_deterministic() {
        // 40 000 thin triangles in the z = 0 plane pierced by 40 000 vertical ones.
        let mut p = Vec::new();
        let mut tris = Vec::new();
        for i in 0..200 {
            for j in 0..200 {
                let (x, y) = (i as f32, j as f32);
                let b = p.len() as u32;
                p.extend([Vec3::new(x, y, 0.0), Vec3::new(x + 0.9, y, 0.0), Vec3::new(x, y + 0.9, 0.0)]);
                p.extend([
                    Vec3::new(x + 0.2, y + 0.2, -1.0),
                    Vec3::new(x + 0.2, y + 0.2, 1.0),
                    Vec3::new(x + 0.3, y + 0.25, 0.0),
                ]);
                tris.push(([b, b + 1, b + 2], tris.len() as u32));
                tris.push(([b + 3, b + 4, b + 5], tris.len() as u32));
            }
        }
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| self_intersections(&p, &tris, 20_000))
        };
        let one = run(1);
        assert_eq!(one.len(), 20_000);
        for threads in [2, 7] {
            assert_eq!(run(threads), one, "{threads} threads");
        }
        assert_eq!(self_intersections(&p, &tris, usize::MAX).len(), 40_000);
    }
}
