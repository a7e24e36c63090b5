//! [`MeshReport`]: what [`check_mesh`](super::check_mesh) found, its verdicts and its
//! `Display` (the first few offending items named).

use std::fmt;

/// What [`check_mesh`](super::check_mesh) found. Counts are complete; the lists hold the first
/// [`CheckOptions::max_listed`](super::CheckOptions::max_listed) items so a report can name them.
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
    /// The search stopped at [`CheckOptions::max_intersections`](super::CheckOptions::max_intersections): the count is a lower bound.
    pub intersections_truncated: bool,
    /// Faces that repeat an earlier face: the same corner positions in the same order
    /// (one primitive drawn twice, a copied triangle). They are reported here and left
    /// out of the self-intersection search (a copy would pair with everything its
    /// original does, and coincident copies make the search quadratic). A back face (the
    /// same corners in reverse order, a leaf card's) is not a duplicate. Looked for only
    /// with the self-intersection search ([`CheckOptions::self_intersections`](super::CheckOptions::self_intersections)) and
    /// reported as a note ([`MeshReport::notes`]), not a problem: coincident copies
    /// (a model that draws one branch twice) do not cross each other.
    pub duplicate_faces: Vec<usize>,
    /// Number of duplicate faces.
    pub duplicate_face_count: usize,
    /// Candidate triangle pairs the self-intersection search looked at (its work).
    pub pairs_searched: u64,
    /// The self-intersection search used up [`CheckOptions::max_pairs`](super::CheckOptions::max_pairs) and stopped
    /// before every triangle was searched: the intersection count is a lower bound and
    /// the mesh is not judged valid.
    pub search_stopped: bool,
    /// The [`CheckOptions::max_pairs`](super::CheckOptions::max_pairs) the search ran with (named in the report).
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
