//! Mesh adjacency for refinement: faces, edges, vertex–corner incidence and ordered
//! vertex rings, built once from an indexed [`Mesh`](crate::Mesh) and then split level
//! by level without any hashing or sorting.
//!
//! Pieterse2012 §3 asks for a "fully cross-linked graph" rebuilt after each step; this is its
//! compact, OpenSubdiv-style form (Vtr levels). Everything is indexed by **corners**: corner
//! `c` is the `c`-th entry of the face-vertex list, and its *outgoing* edge runs from its
//! vertex to the next corner's vertex. An edge stores the (at most two) corners whose
//! outgoing edge it is, so a manifold, consistently oriented mesh has every interior edge
//! traversed once in each direction. Vertex rings are walked counter-clockwise (seen from
//! the front): the face after corner `c` is the one across `c`'s *incoming* edge.
//!
//! [`Topology::from_faces`] validates the control mesh and reports, naming the vertices,
//! every way the refiner could go wrong: an edge shared by more than two faces, two faces
//! that traverse an edge in the same direction (inconsistent orientation), a "bow-tie"
//! vertex whose faces form more than one fan, and faces that repeat a vertex.

use super::RefineError;

/// "No element": the missing second face of a boundary edge.
pub use crate::geometry::NONE;

/// How much adjacency a refined level needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Detail {
    /// Face vertices only (the last level, nothing is computed from it).
    Faces,
    /// Faces, face edges and edge vertices: enough for linear (bilinear-like) rules.
    Edges,
    /// Everything: edge corners and vertex corners, for the smooth rules and limits.
    Full,
}

/// Adjacency of one refinement level.
///
/// Faces are either all of one size (`face_size > 0`, offsets implicit, the case of every
/// refined level) or of mixed sizes (`face_size == 0`, offsets explicit, only possible for
/// a Catmull–Clark control mesh).
#[derive(Debug, Clone, Default)]
pub struct Topology {
    pub(crate) num_verts: u32,
    pub(crate) num_faces: u32,
    /// Corners per face when all faces have the same size, else 0.
    pub(crate) face_size: u32,
    /// `num_faces + 1` offsets when `face_size == 0`, else empty.
    pub(crate) face_offsets: Vec<u32>,
    /// The face of each corner when `face_size == 0` (and detail ≥ Edges), else empty.
    pub(crate) corner_face: Vec<u32>,
    pub(crate) face_verts: Vec<u32>,
    /// Outgoing edge of each corner (empty at detail `Faces`).
    pub(crate) face_edges: Vec<u32>,
    pub(crate) edge_verts: Vec<[u32; 2]>,
    /// The corners whose outgoing edge this is; `[c, NONE]` on the boundary (detail `Full`).
    pub(crate) edge_corners: Vec<[u32; 2]>,
    /// Vertex → incident corners, CSR (detail `Full`).
    pub(crate) vert_corner_offsets: Vec<u32>,
    pub(crate) vert_corners: Vec<u32>,
}

impl Topology {
    /// Builds and validates the adjacency of a polygon list: `offsets` has one entry per
    /// face plus a trailing end (the first is 0), `indices` the vertex of each corner.
    ///
    /// Errors name the offending vertices: [`RefineError::DegenerateFace`] (a face with
    /// fewer than three corners or a repeated vertex), [`RefineError::VertexOutOfRange`],
    /// [`RefineError::NonManifoldEdge`] (more than two faces on an edge),
    /// [`RefineError::InconsistentOrientation`] and [`RefineError::NonManifoldVertex`].
    /// Cost: O(corners · valence).
    pub fn from_faces(num_verts: usize, offsets: &[u32], indices: &[u32]) -> Result<Topology, RefineError> {
        let num_faces = offsets.len().saturating_sub(1);
        if num_verts >= NONE as usize || indices.len() >= NONE as usize {
            return Err(RefineError::TooLarge { what: "control mesh", count: indices.len() });
        }
        if offsets.first().copied().unwrap_or(0) != 0
            || offsets.windows(2).any(|w| w[1] < w[0])
            || *offsets.last().unwrap_or(&0) as usize != indices.len()
        {
            return Err(RefineError::InvalidMesh(
                "face offsets are not increasing from 0 to the index count".into(),
            ));
        }
        let mut sizes = offsets.windows(2).map(|w| w[1] - w[0]);
        let first = sizes.next().unwrap_or(0);
        let uniform = sizes.all(|s| s == first);
        let mut t = Topology {
            num_verts: num_verts as u32,
            num_faces: num_faces as u32,
            face_size: if uniform { first } else { 0 },
            face_offsets: if uniform { Vec::new() } else { offsets.to_vec() },
            face_verts: indices.to_vec(),
            ..Default::default()
        };
        if !uniform {
            t.corner_face = vec![0; indices.len()];
            for f in 0..num_faces {
                for c in offsets[f]..offsets[f + 1] {
                    t.corner_face[c as usize] = f as u32;
                }
            }
        }
        for f in 0..num_faces {
            let face = &indices[offsets[f] as usize..offsets[f + 1] as usize];
            if face.len() < 3 {
                return Err(RefineError::DegenerateFace { face: f, vertices: face.to_vec() });
            }
            if let Some(&v) = face.iter().find(|&&v| v as usize >= num_verts) {
                return Err(RefineError::VertexOutOfRange { face: f, vertex: v, count: num_verts });
            }
            for (i, v) in face.iter().enumerate() {
                if face[i + 1..].contains(v) {
                    return Err(RefineError::DegenerateFace { face: f, vertices: face.to_vec() });
                }
            }
        }
        t.build_vertex_corners();
        t.build_edges()?;
        t.check_vertex_fans()?;
        Ok(t)
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.num_verts as usize
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.num_faces as usize
    }

    /// Number of edges (0 when the level was built without edges).
    pub fn edge_count(&self) -> usize {
        self.edge_verts.len()
    }

    /// Number of face corners.
    pub fn corner_count(&self) -> usize {
        self.face_verts.len()
    }

    /// The corner range of face `f`.
    #[inline]
    pub fn corners(&self, f: usize) -> std::ops::Range<usize> {
        if self.face_size > 0 {
            let n = self.face_size as usize;
            f * n..f * n + n
        } else {
            self.face_offsets[f] as usize..self.face_offsets[f + 1] as usize
        }
    }

    /// The vertices of face `f`, counter-clockwise.
    #[inline]
    pub fn face(&self, f: usize) -> &[u32] {
        &self.face_verts[self.corners(f)]
    }

    /// The face that corner `c` belongs to.
    #[inline]
    pub fn face_of(&self, c: u32) -> u32 {
        // Constant divisors for the sizes of every refined level (no hardware division).
        match self.face_size {
            4 => c >> 2,
            3 => c / 3,
            0 => self.corner_face[c as usize],
            n => c / n,
        }
    }

    /// The next corner of the same face (counter-clockwise).
    #[inline]
    pub fn next(&self, c: u32) -> u32 {
        match self.face_size {
            4 => (c & !3) | ((c + 1) & 3),
            3 => {
                if c % 3 == 2 {
                    c - 2
                } else {
                    c + 1
                }
            }
            0 => {
                let f = self.corner_face[c as usize] as usize;
                if c + 1 == self.face_offsets[f + 1] {
                    self.face_offsets[f]
                } else {
                    c + 1
                }
            }
            n => {
                if (c + 1).is_multiple_of(n) {
                    c + 1 - n
                } else {
                    c + 1
                }
            }
        }
    }

    /// The previous corner of the same face.
    #[inline]
    pub fn prev(&self, c: u32) -> u32 {
        match self.face_size {
            4 => (c & !3) | (c.wrapping_sub(1) & 3),
            3 => {
                if c.is_multiple_of(3) {
                    c + 2
                } else {
                    c - 1
                }
            }
            0 => {
                let f = self.corner_face[c as usize] as usize;
                if c == self.face_offsets[f] {
                    self.face_offsets[f + 1] - 1
                } else {
                    c - 1
                }
            }
            n => {
                if c.is_multiple_of(n) {
                    c + n - 1
                } else {
                    c - 1
                }
            }
        }
    }

    /// The corners at vertex `v` (in no particular order; see [`Topology::ring`]).
    #[inline]
    pub fn vertex_corners(&self, v: usize) -> &[u32] {
        &self.vert_corners[self.vert_corner_offsets[v] as usize..self.vert_corner_offsets[v + 1] as usize]
    }

    /// The two vertices of edge `e`.
    #[inline]
    pub fn edge(&self, e: usize) -> [u32; 2] {
        self.edge_verts[e]
    }

    /// Whether edge `e` has a single face.
    #[inline]
    pub fn is_boundary_edge(&self, e: usize) -> bool {
        self.edge_corners[e][1] == NONE
    }

    /// The faces incident to edge `e` (one or two).
    pub fn edge_faces(&self, e: usize) -> impl Iterator<Item = u32> + '_ {
        self.edge_corners[e].into_iter().filter(|&c| c != NONE).map(|c| self.face_of(c))
    }

    /// The vertex of edge `e` that is not `v`.
    #[inline]
    pub fn other_vertex(&self, e: u32, v: u32) -> u32 {
        let [a, b] = self.edge_verts[e as usize];
        if a == v {
            b
        } else {
            a
        }
    }

    /// The ordered ring of vertex `v`: its corners counter-clockwise (seen from the
    /// front) and whether `v` is on the boundary. For a boundary vertex the walk starts at
    /// the face whose outgoing edge is on the boundary. The ring's edges are the outgoing
    /// edge of each corner, plus, on the boundary, the incoming edge of the last corner.
    pub fn ring(&self, v: usize) -> Ring {
        let cs = self.vertex_corners(v);
        let mut corners = Vec::with_capacity(cs.len());
        if cs.is_empty() {
            return Ring { corners, boundary: false };
        }
        let start = cs.iter().copied().find(|&c| self.is_boundary_edge(self.face_edges[c as usize] as usize));
        let boundary = start.is_some();
        let start = start.unwrap_or(cs[0]);
        let mut c = start;
        loop {
            corners.push(c);
            match self.across_incoming(c) {
                Some(n) if n != start && corners.len() < cs.len() => c = n,
                _ => break,
            }
        }
        Ring { corners, boundary }
    }

    /// Edges of an ordered ring: outgoing edge of each corner, then on the boundary the
    /// incoming edge of the last corner.
    pub fn ring_edges(&self, ring: &Ring) -> Vec<u32> {
        let mut edges: Vec<u32> = ring.corners.iter().map(|&c| self.face_edges[c as usize]).collect();
        if ring.boundary {
            if let Some(&last) = ring.corners.last() {
                edges.push(self.face_edges[self.prev(last) as usize]);
            }
        }
        edges
    }

    /// The corner at the same vertex in the face across `c`'s incoming edge (the next
    /// face counter-clockwise), or `None` on the boundary.
    #[inline]
    pub(crate) fn across_incoming(&self, c: u32) -> Option<u32> {
        let p = self.prev(c);
        let e = self.face_edges[p as usize] as usize;
        let [c0, c1] = self.edge_corners[e];
        let other = if c0 == p { c1 } else { c0 };
        (other != NONE).then_some(other)
    }

    /// Vertex → corner CSR by counting sort; corners of a vertex in increasing order.
    pub(crate) fn build_vertex_corners(&mut self) {
        let nv = self.num_verts as usize;
        let mut offsets = vec![0u32; nv + 1];
        for &v in &self.face_verts {
            offsets[v as usize + 1] += 1;
        }
        for i in 0..nv {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut corners = vec![0u32; self.face_verts.len()];
        for (c, &v) in self.face_verts.iter().enumerate() {
            let slot = &mut fill[v as usize];
            corners[*slot as usize] = c as u32;
            *slot += 1;
        }
        self.vert_corner_offsets = offsets;
        self.vert_corners = corners;
    }

    /// Numbers the edges in order of first use and links each to its one or two corners,
    /// rejecting non-manifold edges and inconsistent orientation.
    fn build_edges(&mut self) -> Result<(), RefineError> {
        let nc = self.face_verts.len();
        let mut face_edges = vec![NONE; nc];
        let mut edge_verts = Vec::with_capacity(nc / 2 + 8);
        let mut edge_corners = Vec::with_capacity(nc / 2 + 8);
        let mut forward = Vec::new();
        let mut backward = Vec::new();
        for c in 0..nc as u32 {
            if face_edges[c as usize] != NONE {
                continue;
            }
            let a = self.face_verts[c as usize];
            let b = self.face_verts[self.next(c) as usize];
            forward.clear();
            backward.clear();
            for &x in self.vertex_corners(a as usize) {
                if self.face_verts[self.next(x) as usize] == b {
                    forward.push(x);
                }
            }
            for &x in self.vertex_corners(b as usize) {
                if self.face_verts[self.next(x) as usize] == a {
                    backward.push(x);
                }
            }
            let faces = forward.len() + backward.len();
            if faces > 2 {
                let mut fs: Vec<u32> = forward.iter().chain(&backward).map(|&x| self.face_of(x)).collect();
                fs.sort_unstable();
                return Err(RefineError::NonManifoldEdge { a, b, faces: fs });
            }
            if forward.len() == 2 {
                let fs = [self.face_of(forward[0]), self.face_of(forward[1])];
                return Err(RefineError::InconsistentOrientation { a, b, faces: fs });
            }
            let e = edge_verts.len() as u32;
            edge_verts.push([a, b]);
            let twin = backward.first().copied().unwrap_or(NONE);
            edge_corners.push([c, twin]);
            face_edges[c as usize] = e;
            if twin != NONE {
                face_edges[twin as usize] = e;
            }
        }
        self.face_edges = face_edges;
        self.edge_verts = edge_verts;
        self.edge_corners = edge_corners;
        Ok(())
    }

    /// Every vertex's faces must form one fan (a disc or a half-disc).
    fn check_vertex_fans(&self) -> Result<(), RefineError> {
        for v in 0..self.num_verts as usize {
            let cs = self.vertex_corners(v);
            if cs.is_empty() {
                continue;
            }
            let open =
                cs.iter().filter(|&&c| self.is_boundary_edge(self.face_edges[c as usize] as usize)).count();
            let ring = self.ring(v);
            if open > 1 || ring.corners.len() != cs.len() {
                let fans = open.max(2);
                return Err(RefineError::NonManifoldVertex { vertex: v as u32, fans });
            }
        }
        Ok(())
    }

    /// Edge `e`'s child edge at its end `v` after splitting (both schemes number the two
    /// halves of parent edge `e` as `2e` (at `edge_verts[e][0]`) and `2e + 1`).
    #[inline]
    pub(crate) fn half_at(&self, e: u32, v: u32) -> u32 {
        if self.edge_verts[e as usize][0] == v {
            2 * e
        } else {
            2 * e + 1
        }
    }

    /// Boundary edges, in increasing order.
    pub(crate) fn boundary_edges(&self) -> Vec<u32> {
        (0..self.edge_corners.len() as u32).filter(|&e| self.is_boundary_edge(e as usize)).collect()
    }

    /// The edge between `a` and `b`, if any (detail `Full`).
    pub fn find_edge(&self, a: u32, b: u32) -> Option<u32> {
        if a as usize >= self.vertex_count() {
            return None;
        }
        for &c in self.vertex_corners(a as usize) {
            let out = self.face_edges[c as usize];
            if self.other_vertex(out, a) == b {
                return Some(out);
            }
            let inc = self.face_edges[self.prev(c) as usize];
            if self.other_vertex(inc, a) == b {
                return Some(inc);
            }
        }
        None
    }
}

/// A vertex's faces in counter-clockwise order, as corners.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ring {
    /// The vertex's corners, counter-clockwise.
    pub corners: Vec<u32>,
    /// Whether the vertex is on the boundary (the ring is a half-disc).
    pub boundary: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn topo(nv: usize, faces: &[&[u32]]) -> Result<Topology, RefineError> {
        let mut off = vec![0u32];
        let mut idx = Vec::new();
        for f in faces {
            idx.extend_from_slice(f);
            off.push(idx.len() as u32);
        }
        Topology::from_faces(nv, &off, &idx)
    }

    #[test]
    fn cube_is_closed() {
        let t = topo(
            8,
            &[&[0, 3, 2, 1], &[4, 5, 6, 7], &[0, 1, 5, 4], &[1, 2, 6, 5], &[2, 3, 7, 6], &[3, 0, 4, 7]],
        )
        .unwrap();
        assert_eq!(t.edge_count(), 12);
        assert!(t.boundary_edges().is_empty());
        for v in 0..8 {
            let r = t.ring(v);
            assert!(!r.boundary);
            assert_eq!(r.corners.len(), 3);
            assert_eq!(t.ring_edges(&r).len(), 3);
        }
        assert_eq!(t.find_edge(0, 1).map(|e| t.edge(e as usize)), Some([1, 0]).or(Some([0, 1])));
    }

    #[test]
    fn open_quad_grid_ring_order() {
        // 2x1 quads: 0 1 2 / 3 4 5
        let t = topo(6, &[&[0, 1, 4, 3], &[1, 2, 5, 4]]).unwrap();
        let r = t.ring(1);
        assert!(r.boundary);
        // counter-clockwise from the boundary edge 1→2: face 1 then face 0.
        let faces: Vec<u32> = r.corners.iter().map(|&c| t.face_of(c)).collect();
        assert_eq!(faces, vec![1, 0]);
        let edges = t.ring_edges(&r);
        let others: Vec<u32> = edges.iter().map(|&e| t.other_vertex(e, 1)).collect();
        assert_eq!(others, vec![2, 4, 0]);
    }

    #[test]
    fn three_faces_on_an_edge_name_the_vertices() {
        let e = topo(5, &[&[0, 1, 2], &[1, 0, 3], &[0, 1, 4]]).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("0") && msg.contains("1") && msg.contains("3 faces"), "{msg}");
    }

    #[test]
    fn flipped_face_is_reported() {
        let e = topo(4, &[&[0, 1, 2], &[0, 1, 3]]).unwrap_err();
        assert!(matches!(e, RefineError::InconsistentOrientation { a: 0, b: 1, .. }), "{e}");
    }

    #[test]
    fn bow_tie_vertex_is_reported() {
        let e = topo(5, &[&[0, 1, 2], &[0, 3, 4]]).unwrap_err();
        assert!(matches!(e, RefineError::NonManifoldVertex { vertex: 0, .. }), "{e}");
    }

    #[test]
    fn repeated_vertex_is_degenerate() {
        let e = topo(3, &[&[0, 1, 1]]).unwrap_err();
        assert!(matches!(e, RefineError::DegenerateFace { face: 0, .. }));
    }
}
