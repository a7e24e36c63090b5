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
//!   large overlaps; parallel over triangles with rayon. For a sequence of meshes that
//!   differ in places (the mesh clearing's rounds) an incremental search tests only the
//!   pairs with a changed triangle, and a memo spares the meshers' per-junction
//!   searches the junctions that did not change (issue 44; `incremental.rs`, `memo.rs`).
//!
//! Plus the components and the Euler characteristic, so a caller can check genus
//! ([`MeshReport::total_genus`] sums the components' genera).

use crate::geometry::Mesh;
use glam::DVec3;
use std::collections::HashMap;

mod bvh;
mod capsules;
mod incremental;
mod intersect;
pub(crate) mod memo;
mod report;

pub(crate) use self::bvh::{build_bvh, query, Aabb, Node};
pub use self::capsules::skeleton_collisions;
pub(crate) use self::capsules::{meeting, meeting_gap, node_depths, segment_closest, Meeting};
pub(crate) use self::incremental::IncrementalSearch;
#[cfg(test)]
pub(crate) use self::intersect::self_intersections;
pub(crate) use self::intersect::{group_crossings, group_crossings_within, self_intersections_within};
pub use self::report::MeshReport;

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

    let faults = search_faults(mesh, &good, r.non_finite_count == 0, opts);
    for (count, list, found) in [
        (&mut r.degenerate_face_count, &mut r.degenerate_faces, &faults.degenerate),
        (&mut r.duplicate_face_count, &mut r.duplicate_faces, &faults.duplicates),
    ] {
        *count = found.len();
        list.extend(found.iter().take(max));
    }
    r.triangles = (0..nf).filter(|&f| good[f]).map(|f| mesh.face(f).len().saturating_sub(2)).sum();
    r.max_pairs = opts.max_pairs;
    if let Some(found) = faults.intersections {
        r.intersections_truncated = found.pairs.len() >= opts.max_intersections;
        r.intersection_count = Some(found.pairs.len());
        r.intersections = found.pairs.into_iter().take(max).collect();
        r.pairs_searched = found.work;
        r.search_stopped = found.stopped;
    }
    r
}

/// What [`check_mesh`] finds without its topology part: the degenerate faces, the
/// duplicate faces and the self-intersection search over the rest.
pub(crate) struct Faults {
    /// Degenerate faces, ascending (all of them).
    pub(crate) degenerate: Vec<usize>,
    /// Duplicate faces, ascending (all of them; looked for only with the search).
    pub(crate) duplicates: Vec<usize>,
    /// The self-intersection search (`None` when not asked for, or with a non-finite
    /// position).
    pub(crate) intersections: Option<intersect::Search>,
}

/// The degenerate faces and self-intersections of `mesh` exactly as [`check_mesh`]
/// reports them (every one, whatever `opts.max_listed`), without the edge, fan and
/// component bookkeeping — for a caller that needs only these (the sweep mesher's repair
/// rounds: issue 44).
pub(crate) fn surface_faults(mesh: &Mesh, opts: &CheckOptions) -> Faults {
    let nv = mesh.vertex_count();
    let good: Vec<bool> = (0..mesh.face_count())
        .map(|f| {
            let face = mesh.face(f);
            face.len() >= 3 && face.iter().all(|&v| (v as usize) < nv)
        })
        .collect();
    let finite = mesh.positions.iter().all(|p| p.is_finite());
    search_faults(mesh, &good, finite, opts)
}

/// The fault search shared by [`check_mesh`] and [`surface_faults`] over the `good`
/// faces (at least 3 corners, references in range); the self-intersection search runs
/// only with `finite` positions.
fn search_faults(mesh: &Mesh, good: &[bool], finite: bool, opts: &CheckOptions) -> Faults {
    let nf = mesh.face_count();
    // Degenerate faces: repeated vertex or tiny area (Newell's normal). They and the
    // duplicates below are reported here and left out of the self-intersection search.
    let mut searched = good.to_vec();
    let mut degenerate = Vec::new();
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
            degenerate.push(f);
        }
    }
    // Duplicates are coincident geometry, like intersections: looked for only with the
    // self-intersection search, which they would otherwise make quadratic.
    let duplicates = if opts.self_intersections { duplicate_faces(mesh, &searched) } else { Vec::new() };
    for &f in &duplicates {
        searched[f] = false;
    }

    // Self-intersections, only on meshes whose positions and references are sound.
    let intersections = (opts.self_intersections && finite).then(|| {
        let tris = fan_triangles(mesh, |f| searched[f]);
        self_intersections_within(&mesh.positions, &tris, opts.max_intersections, opts.max_pairs)
    });
    Faults { degenerate, duplicates, intersections }
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

#[cfg(test)]
mod tests {
    use super::capsules::segment_distance;
    use super::intersect::{group_crossings, self_intersections};
    use super::*;
    use glam::Vec3;

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
