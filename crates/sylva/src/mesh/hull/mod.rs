//! The hull mesher: one watertight triangle control mesh for a whole [`Skeleton`](crate::Skeleton), with
//! convex-hull joints at every branching node, ready for Loop subdivision.
//!
//! Pieterse2012 ("Yggdrasil") §4.1.3–§4.1.4 (trimming and simplification, `simplify.rs`),
//! §4.2.2 (branch segments, Algorithm 1, `build.rs`), §4.2.3 (convex-hull joints,
//! Algorithms 3–4, `joint.rs`) and §4.3.2–§4.3.3 (UVs, `uv.rs`), as pinned down by
//! Pieterse2012-spec §2.3–§2.7; `docs/meshers.md` ("hull", "Construction") has the seven
//! steps in full. The Loop step (§4.4) is [`crate::refine::subdivide`], run by the caller.
//! Output: counter-clockwise triangles with face-varying UVs and smooth normals; every
//! input gives a mesh or an [`Error::InvalidGeometry`], never a panic.

pub mod convex;

use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::mesh::tube::{MAX_SIDES, MIN_SIDES};
use glam::{DVec3, Vec2, Vec3};
use std::f64::consts::TAU;
use std::ops::Range;

mod build;
mod joint;
mod simplify;
mod uv;

pub use self::build::hull_mesh;
pub(crate) use self::joint::{cap_hull, CapLoop};
pub use self::simplify::{pair_offsets, simplify, BranchGraph, GraphBranch};

use crate::geometry::NONE;

/// Options of [`hull_mesh`] (Pieterse2012-spec §4 "User parameters").
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HullOptions {
    /// Vertices per loop, in `3..=1024` (default 4, the seed's choice).
    #[serde(skip)]
    pub sides: u32,
    /// Close the root base and every tip with a flat fan (default false: the seed leaves
    /// them open). With caps the mesh is closed (Euler characteristic 2 per piece).
    #[serde(skip)]
    pub caps: bool,
    /// Trim margin `m`: offsets are multiplied by `1 + m` so rims do not touch
    /// (default 0.05).
    pub margin: f64,
    /// Two outward axes with `cos α > 1 − ε` are *aligned* (seed case 3): the joint
    /// fails and falls back (default 1e-6).
    pub aligned_epsilon: f64,
    /// Segment length as a multiple of half the mean circumference `π·r̄` (default 1).
    pub segment_factor: f64,
    /// Most segments per branch (default 32): a budget guard for long, hair-thin
    /// branches, where `L / (π·r̄)` grows without bound.
    pub max_segments: u32,
    /// Largest straightening a collapse may cause, in radii of the collapsed node
    /// (default 1; `f64::INFINITY` is the seed's rule). Collapsing a branch re-attaches
    /// its children to its start, so each child's tube runs straight past the collapsed
    /// node; where that node lies further than this from a child's new axis and the
    /// straightened tube would pass through another (live) branch of the graph, the
    /// branch is not collapsed and its trims are clamped instead (reported in
    /// [`HullMesh::clamped`]). Beyond the seed: on `mig-a`, a collapse moved a tube 5
    /// radii off the skeleton, through a neighbouring branch.
    pub max_straightening: f64,
}

impl Default for HullOptions {
    fn default() -> Self {
        HullOptions {
            sides: 4,
            caps: false,
            margin: 0.05,
            aligned_epsilon: 1e-6,
            segment_factor: 1.0,
            max_segments: 32,
            max_straightening: 1.0,
        }
    }
}

impl HullOptions {
    /// Checks every option's range; the message starts with the option's name.
    pub fn check(&self) -> Result<()> {
        let bad = |why: String| Err(Error::InvalidGeometry { what: "hull mesher".into(), why });
        if !(MIN_SIDES..=MAX_SIDES).contains(&self.sides) {
            return bad(format!("sides = {}; it must be in {MIN_SIDES}..={MAX_SIDES}", self.sides));
        }
        if !(self.margin.is_finite() && (0.0..=10.0).contains(&self.margin)) {
            return bad(format!("margin = {}; it must be in 0..=10", self.margin));
        }
        if !(self.aligned_epsilon.is_finite() && (0.0..1.0).contains(&self.aligned_epsilon)) {
            return bad(format!("aligned_epsilon = {}; it must be in [0, 1)", self.aligned_epsilon));
        }
        if !(self.segment_factor.is_finite() && self.segment_factor > 0.0) {
            return bad(format!("segment_factor = {}; it must be positive", self.segment_factor));
        }
        if self.max_straightening.is_nan() || self.max_straightening < 0.0 {
            return bad(format!("max_straightening = {}; it must be non-negative", self.max_straightening));
        }
        if !(1..=65536).contains(&self.max_segments) {
            return bad(format!("max_segments = {}; it must be in 1..=65536", self.max_segments));
        }
        Ok(())
    }
}

/// How a joint was meshed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Two branches (a bend): a band of `2s` triangles.
    Band,
    /// Three or more branches (or two stems from a root): the convex-hull joint.
    Hull,
    /// The joint could not be meshed: its branches run to the node untrimmed and each of
    /// their loops there is closed by a fan (see [`HullMesh::fallbacks`]).
    Fallback,
}

/// One joint of the output mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSpan {
    /// Skeleton node at the joint.
    pub node: u32,
    /// How it was meshed.
    pub kind: JointKind,
    /// Number of loops that meet there (`k`: the parent's end loop and each child's
    /// start loop).
    pub loops: u32,
    /// Its faces in [`HullMesh::mesh`] (for a fallback: its cap fans).
    pub faces: Range<u32>,
    /// Branches (their end nodes) detached from this joint because they were aligned
    /// with another (Pieterse2012 §4.1.3 case 3): each runs untrimmed to the node and is
    /// closed there by a fan. The joint is then listed in [`HullMesh::fallbacks`].
    pub detached: Vec<u32>,
}

/// One meshed branch (a trimmed internode after simplification).
#[derive(Debug, Clone, PartialEq)]
pub struct BranchSpan {
    /// Skeleton node at the branch's end (its tip end point, never moved).
    pub node: u32,
    /// Skeleton node at its start (its parent's end, or a root); differs from the
    /// node's skeleton parent when simplification collapsed branches in between.
    pub start_node: u32,
    /// First vertex: the branch owns vertices `first_vertex .. first_vertex + (N+1)·s`,
    /// loop `i` vertex `j` at `first_vertex + i·s + j`.
    pub first_vertex: u32,
    /// Number of segments `N` (`N + 1` loops).
    pub segments: u32,
    /// Its faces (`2·N·s`) in [`HullMesh::mesh`].
    pub faces: Range<u32>,
    /// Distance from the start point to the first loop.
    pub start_offset: f64,
    /// Distance from the last loop to the end point.
    pub end_offset: f64,
    /// Untrimmed length (start point to end point).
    pub length: f64,
    /// Texture `v` of loop 0 (loop `i` has `v₀ + i/2`).
    pub v0: f64,
}

/// The result of [`hull_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct HullMesh {
    /// Triangles with face-varying UVs and normals.
    pub mesh: Mesh,
    /// Joint nodes that fell back, wholly ([`JointKind::Fallback`]) or by detaching
    /// aligned branches ([`JointSpan::detached`]), in node order.
    pub fallbacks: Vec<u32>,
    /// Every joint (nodes where 2 or more branches meet), in node order.
    pub joints: Vec<JointSpan>,
    /// Every meshed branch, in node order.
    pub branches: Vec<BranchSpan>,
    /// Nodes whose internode simplification collapsed (Pieterse2012 §4.1.4).
    pub collapsed: Vec<u32>,
    /// Nodes whose branch (a root stem or a tip) was too short for its trims and could
    /// not collapse without moving an end point: its offsets were scaled down.
    pub clamped: Vec<u32>,
    /// Tip nodes dropped because their internode has zero length.
    pub dropped: Vec<u32>,
    /// Loops left open (the base and the tips when not capped).
    pub open_loops: usize,
}

/// A loop at a joint: branch slot and which end.
#[derive(Debug, Clone, Copy)]
struct LoopRef {
    slot: u32,
    at_end: bool,
}

/// What a joint becomes.
#[derive(Debug, Clone)]
enum Plan {
    Band,
    /// Faces as (loop index within the joint, vertex index within the loop).
    Hull(Vec<[(u32, u32); 3]>),
    Fallback,
}

/// Per-branch geometry for meshing.
#[derive(Debug, Clone, Copy, Default)]
struct Geo {
    node: u32,
    start: DVec3,
    d: DVec3,
    len: f64,
    r0: f64,
    r1: f64,
    u: DVec3,
    w: DVec3,
    off_s: f64,
    off_e: f64,
    segments: u32,
    first_vertex: u32,
    first_uv: u32,
    v0: f64,
    /// A root's virtual base loop (see [`root_base`]): one ring at the root node, no
    /// segments, closed by a fan; not a branch.
    base: bool,
}

impl Geo {
    fn radius_at(&self, t: f64) -> f64 {
        if self.len > 0.0 {
            self.r0 + (self.r1 - self.r0) * (t / self.len).clamp(0.0, 1.0)
        } else {
            self.r0
        }
    }

    /// Centre and radius of the loop at the start (`at_end = false`) or the end.
    fn end_loop(&self, at_end: bool) -> (DVec3, f64) {
        let t = if at_end { self.len - self.off_e } else { self.off_s };
        (self.start + self.d * t, self.radius_at(t))
    }

    fn loop_vertex(&self, at_end: bool, j: u32, s: u32) -> u32 {
        self.first_vertex + if at_end { self.segments * s } else { 0 } + j
    }

    fn loop_uv(&self, at_end: bool, j: u32, s: u32) -> u32 {
        self.first_uv + if at_end { self.segments * (s + 1) } else { 0 } + j
    }
}

/// Output buffers.
#[derive(Default)]
struct Emit {
    positions: Vec<Vec3>,
    face_offsets: Vec<u32>,
    indices: Vec<u32>,
    uvs: Vec<Vec2>,
    uv_indices: Vec<u32>,
}

impl Emit {
    fn face_count(&self) -> u32 {
        (self.face_offsets.len() - 1) as u32
    }

    fn tri(&mut self, v: [u32; 3], uv: [u32; 3]) {
        self.indices.extend_from_slice(&v);
        self.uv_indices.extend_from_slice(&uv);
        self.face_offsets.push(self.indices.len() as u32);
    }

    /// A flat fan closing the start (`at_end = false`) or end loop of branch `g`, facing
    /// away from the branch; UVs on a disc.
    fn cap(&mut self, g: &Geo, at_end: bool, s: u32) {
        let (c, _) = g.end_loop(at_end);
        let centre = self.positions.len() as u32;
        self.positions.push(c.as_vec3());
        let uc = self.uvs.len() as u32;
        self.uvs.push(Vec2::splat(0.5));
        let sign = if at_end { 1.0 } else { -1.0 };
        for j in 0..s {
            let ph = TAU * j as f64 / s as f64;
            self.uvs.push(Vec2::new((0.5 + 0.5 * ph.cos()) as f32, (0.5 + 0.5 * sign * ph.sin()) as f32));
        }
        for j in 0..s {
            let jn = (j + 1) % s;
            let (vj, vn) = (g.loop_vertex(at_end, j, s), g.loop_vertex(at_end, jn, s));
            let (uj, un) = (uc + 1 + j, uc + 1 + jn);
            if at_end {
                self.tri([vj, vn, centre], [uj, un, uc]);
            } else {
                self.tri([vn, vj, centre], [un, uj, uc]);
            }
        }
    }

    /// Smooth per-vertex normals: area-weighted face normals.
    fn normals(&self) -> Vec<Vec3> {
        let mut acc = vec![DVec3::ZERO; self.positions.len()];
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|v| self.positions[v as usize].as_dvec3());
            let nrm = (b - a).cross(c - a);
            for &v in t {
                acc[v as usize] += nrm;
            }
        }
        acc.into_iter()
            .map(|n| {
                let n = n.normalize_or_zero().as_vec3();
                if n.is_finite() && n != Vec3::ZERO {
                    n
                } else {
                    Vec3::Y
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::joint::{flip_slivers, is_sliver, tri_shape};
    use super::uv::unfold;
    use super::*;

    #[test]
    fn pair_offsets_match_the_printed_special_cases() {
        let (a, b) = (DVec3::X, DVec3::Y);
        let (oa, ob) = pair_offsets(a, 0.3, b, 0.7, 1e-6).unwrap();
        assert!((oa - 0.7).abs() < 1e-12 && (ob - 0.3).abs() < 1e-12);
        assert_eq!(pair_offsets(a, 1.0, -a, 1.0, 1e-6), Some((0.0, 0.0)));
        assert_eq!(pair_offsets(a, 1.0, a, 1.0, 1e-6), None);
        // Equal radii: symmetric.
        let c = DVec3::new(1.0, 1.0, 0.0).normalize();
        let (oa, ob) = pair_offsets(a, 0.5, c, 0.5, 1e-6).unwrap();
        assert!((oa - ob).abs() < 1e-12);
        let c = DVec3::new(-1.0, 1.0, 0.0).normalize();
        let (oa, ob) = pair_offsets(a, 0.5, c, 0.5, 1e-6).unwrap();
        assert!((oa - ob).abs() < 1e-12);
    }

    #[test]
    fn slivers_are_flipped_away_and_the_surface_kept() {
        // a, b, d a proper triangle (normal +z) and c on ab: the sliver (b, a, c) and
        // (a, b, d) share ab; a third face (c, a, e) below keeps c's other side.
        let pos = [
            Vec3::new(0.0, 0.0, 0.0),  // a
            Vec3::new(2.0, 0.0, 0.0),  // b
            Vec3::new(1.0, 0.0, 0.0),  // c
            Vec3::new(1.0, 1.0, 0.0),  // d
            Vec3::new(0.5, -1.0, 0.0), // e
        ];
        let mut faces = vec![[1, 0, 2], [0, 1, 3], [2, 0, 4]];
        assert!(is_sliver(faces[0], &pos));
        let area = |fs: &[[u32; 3]]| fs.iter().map(|&f| tri_shape(f, &pos).0).sum::<f64>();
        let before = area(&faces);
        flip_slivers(&mut faces, &pos);
        assert!(faces.iter().all(|&f| !is_sliver(f, &pos)), "{faces:?}");
        assert!((area(&faces) - before).abs() < 1e-9);
        let has = |x: u32, y: u32| faces.iter().any(|f| (0..3).any(|e| f[e] == x && f[(e + 1) % 3] == y));
        assert!(!has(0, 1) && !has(1, 0), "ab is gone: {faces:?}");
        assert!(has(0, 2) && has(2, 1), "c splits the old ab in the same direction");
        // Collinear everything: nothing proper to flip to, left alone, no loop.
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0];
        let mut flat = vec![[0, 1, 2], [1, 0, 3]];
        flip_slivers(&mut flat, &line);
        assert_eq!(flat, vec![[0, 1, 2], [1, 0, 3]]);
    }

    #[test]
    fn unfold_is_counter_clockwise_and_isometric() {
        let uv = unfold(DVec3::ZERO, DVec3::X, DVec3::new(0.5, 0.0, 2.0), Vec2::ZERO, Vec2::X);
        assert!((uv - Vec2::new(0.5, 2.0)).length() < 1e-6);
        // Degenerate edge: no NaN.
        let uv = unfold(DVec3::ONE, DVec3::ONE, DVec3::ZERO, Vec2::ONE, Vec2::ONE);
        assert_eq!(uv, Vec2::ONE);
    }
}
