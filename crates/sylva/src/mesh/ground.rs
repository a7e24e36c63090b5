//! Flat trunk bases (issue 23, "clean files"): a tree that stands on flat terrain.
//!
//! Every mesher ends the trunk its own way — the hull mesher in a rounded base below the
//! root node, quad + Catmull–Clark in a cap that subdivision shrinks above it, tube and
//! sweep in a flat fan. To give every mesher the same base, the pipeline
//!
//! 1. **sinks** each upright root standing on the ground ([`sink_roots`]): the root node moves down by
//!    [`SINK_RADII`] × its radius, so whatever the mesher and refinement do to the end,
//!    the trunk's wall reaches below the root's original height (the ground plane);
//! 2. **cuts** the refined bark at that plane ([`cut_base`]): faces near the root are
//!    clipped to the half-space above it (Sutherland–Hodgman per face, intersection
//!    points shared by the two faces of an edge, UVs and normals interpolated), and each
//!    closed cut loop is filled with a fan around its centroid facing −y. The result is
//!    a watertight base lying exactly on the plane.
//!
//! A root with a stem that does not rise (roots, creepers) is left as it is, and a cut
//! whose loops do not close is abandoned with a warning (the mesh is unchanged).
//! `mesh.base = "round"` keeps each mesher's own end.

use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{Vec2, Vec3};
use std::collections::{HashMap, HashSet};

/// How far a root is sunk below its plane, in root radii.
pub const SINK_RADII: f32 = 1.5;

/// Faces with a vertex within this many root radii (horizontally) of a sunk root are
/// cut at its plane; faces farther out are kept whole.
pub const CUT_REACH_RADII: f32 = 6.0;

/// A root moved down by [`sink_roots`]: where its base plane lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunkRoot {
    /// The root node.
    pub node: u32,
    /// The root node's original position (the plane is y = `at.y`).
    pub at: Vec3,
    /// The root's radius.
    pub radius: f32,
}

/// How far above the lowest upright root another upright root may stand and still be on
/// the ground, in radii of the thickest upright root.
pub const GROUND_BAND_RADII: f32 = 2.0;

/// Moves every upright root of `skeleton` that stands on the ground down by
/// [`SINK_RADII`] × its radius and returns where each was. A root is upright when every
/// child rises at least half its internode length (a trunk); roots with a level or
/// descending stem, a zero radius or no children are left alone. It stands on the ground
/// when it is at most [`GROUND_BAND_RADII`] radii of the thickest upright root above the
/// lowest upright root: a forest on flat ground sinks every trunk, while the separate
/// pieces a model draws in the air (a cpfg leaf's outline drawn with `F`, a floating
/// cylinder of an LST file) keep their ends and get no flat base.
pub fn sink_roots(skeleton: &mut Skeleton) -> Vec<SunkRoot> {
    let mut root_children: HashMap<u32, Vec<u32>> = HashMap::new();
    for (i, &p) in skeleton.parent.iter().enumerate() {
        if p != NO_PARENT && skeleton.parent.get(p as usize) == Some(&NO_PARENT) {
            root_children.entry(p).or_default().push(i as u32);
        }
    }
    let mut sunk = Vec::new();
    for (i, &p) in skeleton.parent.iter().enumerate() {
        if p != NO_PARENT {
            continue;
        }
        let (at, radius) = (skeleton.position[i], skeleton.radius[i]);
        let Some(children) = root_children.get(&(i as u32)) else { continue };
        let upright = children.iter().all(|&c| {
            let d = skeleton.position[c as usize] - at;
            d.y > 0.5 * d.length() && d.y > 0.0
        });
        if !(upright && radius.is_finite() && radius > 0.0 && at.is_finite()) {
            continue;
        }
        sunk.push(SunkRoot { node: i as u32, at, radius });
    }
    let ground = sunk.iter().map(|s| s.at.y).fold(f32::INFINITY, f32::min);
    let thickest = sunk.iter().map(|s| s.radius).fold(0.0, f32::max);
    sunk.retain(|s| s.at.y - ground <= GROUND_BAND_RADII * thickest);
    for s in &sunk {
        skeleton.position[s.node as usize].y -= SINK_RADII * s.radius;
    }
    sunk
}

/// Puts the roots [`sink_roots`] moved back where they were.
pub fn restore_roots(skeleton: &mut Skeleton, sunk: &[SunkRoot]) {
    for s in sunk {
        if let Some(p) = skeleton.position.get_mut(s.node as usize) {
            *p = s.at;
        }
    }
}

/// What [`cut_base`] did at one root.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CutOutcome {
    /// The base was cut and filled with this many loops.
    Flat(usize),
    /// Nothing near the root reaches below its plane (the mesh is unchanged).
    NothingBelow,
    /// The cut loops did not close (the mesh is unchanged).
    Open,
}

/// Cuts `mesh` at the plane of each of `roots` and fills the cut (see the module docs).
/// Returns one outcome per root.
///
/// The roots are cut one after another, each on the mesh the ones before it left, but
/// the work of each is local to it (issue 39: a forest of 10,000 separate roots used to
/// rebuild the whole mesh once per root): the faces are indexed once by a grid over
/// (x, z), a root looks only at the faces in the cells its reach covers, the faces it
/// cuts are replaced in place and its fans appended, and the unused positions are
/// dropped once at the end. The result is the one cutting and compacting the whole mesh
/// root by root would give, byte for byte.
pub fn cut_base(mesh: &mut Mesh, roots: &[SunkRoot]) -> Vec<CutOutcome> {
    if roots.is_empty() {
        return Vec::new();
    }
    let mut work = Cutter::new(mesh, roots);
    let outcomes: Vec<CutOutcome> =
        roots.iter().enumerate().map(|(k, r)| work.cut(k as u32 + 1, r)).collect();
    if outcomes.iter().any(|o| matches!(o, CutOutcome::Flat(_))) {
        *mesh = work.finish(mesh);
    }
    outcomes
}

/// An intersection point's key: the two ends of the edge it lies on, ordered.
fn edge_key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

// No face (as a [`Face`]'s parent).
use crate::geometry::NONE;

/// One face of [`Cutter`]'s arena: an original face, a piece a cut left of one, or a fan
/// triangle of a filled cut.
#[derive(Clone, Copy)]
struct Face {
    /// Its corners: `start..start + len` of the corner columns.
    start: u32,
    len: u32,
    /// The face it is a piece of (`NONE` for an original face or a fan), and its rank
    /// there (among the pieces, or among the top-level faces).
    up: u32,
    rank: u32,
    /// The pieces replacing it once a cut crossed it: `first..first + count` of the arena.
    replaced: Option<(u32, u32)>,
}

/// The mesh being cut, as an arena of faces (see [`cut_base`]).
struct Cutter {
    positions: Vec<Vec3>,
    uv_values: Option<Vec<Vec2>>,
    normal_values: Option<Vec<Vec3>>,
    faces: Vec<Face>,
    corner_pos: Vec<u32>,
    corner_uv: Vec<u32>,
    corner_nr: Vec<u32>,
    /// Top-level faces in mesh order: the original faces, then each filled cut's fans.
    top: Vec<u32>,
    /// Live faces that are not triangles (a triangle mesh stays one).
    polygons: usize,
    /// Face ids by the (x, z) grid cells of their corners.
    grid: HashMap<(i64, i64), Vec<u32>>,
    cell: f32,
    /// The root that last found each face (so a face in several cells counts once).
    stamp: Vec<u32>,
}

/// A corner of a cut face's kept polygon: position, uv and normal index, on the plane.
type Corner = (u32, u32, u32, bool);

impl Cutter {
    fn new(mesh: &Mesh, roots: &[SunkRoot]) -> Cutter {
        // Cells about as wide as a typical root's reach (the median), so a root looks at
        // a few cells; a root far wider than that walks the occupied cells instead.
        let mut reach: Vec<f32> = roots.iter().map(|r| CUT_REACH_RADII * r.radius).collect();
        reach.sort_unstable_by(f32::total_cmp);
        let cell = reach[reach.len() / 2];
        let cell = if cell.is_finite() && cell > 0.0 { cell } else { 1.0 };
        let faces = mesh.face_count();
        let mut c = Cutter {
            positions: mesh.positions.clone(),
            uv_values: mesh.uvs.as_ref().map(|u| u.values.clone()),
            normal_values: mesh.normals.as_ref().map(|n| n.values.clone()),
            faces: Vec::with_capacity(faces),
            corner_pos: mesh.face_indices.clone(),
            corner_uv: mesh.uvs.as_ref().map(|u| u.indices.clone()).unwrap_or_default(),
            corner_nr: mesh.normals.as_ref().map(|n| n.indices.clone()).unwrap_or_default(),
            top: (0..faces as u32).collect(),
            polygons: 0,
            grid: HashMap::new(),
            cell,
            stamp: Vec::new(),
        };
        for f in 0..faces {
            let r = mesh.corners(f);
            c.faces.push(Face {
                start: r.start as u32,
                len: r.len() as u32,
                up: NONE,
                rank: f as u32,
                replaced: None,
            });
            c.polygons += usize::from(r.len() != 3);
            c.index(f as u32);
        }
        c
    }

    /// The grid cell of `p`.
    fn cell_of(&self, p: Vec3) -> (i64, i64) {
        ((p.x / self.cell).floor() as i64, (p.z / self.cell).floor() as i64)
    }

    /// Adds face `f` to the cells of its corners.
    fn index(&mut self, f: u32) {
        let face = self.faces[f as usize];
        let mut cells: Vec<(i64, i64)> = self.corner_pos
            [face.start as usize..(face.start + face.len) as usize]
            .iter()
            .map(|&i| self.cell_of(self.positions[i as usize]))
            .collect();
        cells.sort_unstable();
        cells.dedup();
        for k in cells {
            self.grid.entry(k).or_default().push(f);
        }
    }

    fn pos(&self, f: u32) -> &[u32] {
        let face = &self.faces[f as usize];
        &self.corner_pos[face.start as usize..(face.start + face.len) as usize]
    }

    /// The live faces near `root` (a corner within its reach horizontally) with a corner
    /// below its plane, in mesh order.
    fn candidates(&mut self, stamp: u32, root: &SunkRoot) -> Vec<u32> {
        let plane = root.at.y;
        let reach = CUT_REACH_RADII * root.radius;
        let near = |p: Vec3| Vec2::new(p.x - root.at.x, p.z - root.at.z).length() <= reach;
        // One cell more each way: a corner the rounding of `at ± reach` puts just
        // outside is still found.
        let (lo, hi) =
            (self.cell_of(root.at - Vec3::splat(reach)), self.cell_of(root.at + Vec3::splat(reach)));
        let (lo, hi) = (
            (lo.0.saturating_sub(1), lo.1.saturating_sub(1)),
            (hi.0.saturating_add(1), hi.1.saturating_add(1)),
        );
        let span = (hi.0 as i128 - lo.0 as i128 + 1) * (hi.1 as i128 - lo.1 as i128 + 1);
        let lists: Vec<&Vec<u32>> = if span > self.grid.len() as i128 || !(reach.is_finite()) {
            self.grid.values().collect()
        } else {
            let mut v = Vec::new();
            for x in lo.0..=hi.0 {
                for z in lo.1..=hi.1 {
                    if let Some(l) = self.grid.get(&(x, z)) {
                        v.push(l);
                    }
                }
            }
            v
        };
        self.stamp.resize(self.faces.len(), 0);
        let mut found = Vec::new();
        for list in lists {
            for &f in list {
                if self.stamp[f as usize] == stamp || self.faces[f as usize].replaced.is_some() {
                    continue;
                }
                self.stamp[f as usize] = stamp;
                let face = self.pos(f);
                if face.iter().any(|&i| self.positions[i as usize].y < plane)
                    && face.iter().any(|&i| near(self.positions[i as usize]))
                {
                    found.push(f);
                }
            }
        }
        // Mesh order: the path of ranks from the top-level face down.
        let mut keyed: Vec<(Vec<u32>, u32)> = found
            .into_iter()
            .map(|f| {
                let mut path = Vec::new();
                let mut g = f;
                loop {
                    let face = &self.faces[g as usize];
                    path.push(face.rank);
                    if face.up == NONE {
                        break;
                    }
                    g = face.up;
                }
                path.reverse();
                (path, f)
            })
            .collect();
        keyed.sort_unstable();
        keyed.into_iter().map(|(_, f)| f).collect()
    }

    /// Cuts at one root (`stamp`: its number, from 1): the faces it crosses are replaced
    /// by their pieces above its plane and each closed cut loop is filled; a cut whose
    /// loops do not close leaves everything as it was.
    fn cut(&mut self, stamp: u32, root: &SunkRoot) -> CutOutcome {
        let plane = root.at.y;
        let cut = self.candidates(stamp, root);
        if cut.is_empty() {
            return CutOutcome::NothingBelow;
        }
        let (has_uv, has_nr) = (self.uv_values.is_some(), self.normal_values.is_some());
        let marks = (
            self.positions.len(),
            self.uv_values.as_ref().map_or(0, Vec::len),
            self.normal_values.as_ref().map_or(0, Vec::len),
        );
        let mut clip = Clip::new(plane, self.polygons == 0);
        // The pieces of each cut face.
        let mut pieces: Vec<(u32, Vec<Piece>)> = Vec::with_capacity(cut.len());
        for &f in &cut {
            let face = self.faces[f as usize];
            let corners = face.start as usize..(face.start + face.len) as usize;
            let uv: Option<&[u32]> = has_uv.then(|| &self.corner_uv[corners.clone()]);
            let nr: Option<&[u32]> = has_nr.then(|| &self.corner_nr[corners.clone()]);
            let mut values = Values {
                positions: &mut self.positions,
                uvs: self.uv_values.as_mut(),
                normals: self.normal_values.as_mut(),
            };
            pieces.push((f, clip.face(&mut values, &self.corner_pos[corners], uv, nr)));
        }
        let open = |c: &mut Cutter| {
            c.positions.truncate(marks.0);
            if let Some(v) = c.uv_values.as_mut() {
                v.truncate(marks.1);
            }
            if let Some(v) = c.normal_values.as_mut() {
                v.truncate(marks.2);
            }
            CutOutcome::Open
        };
        let Some(loops) = chain_loops(&clip.plane_edges) else { return open(self) };
        // Commit: the pieces replace their faces.
        for (f, own) in pieces {
            let first = self.faces.len() as u32;
            for (rank, (p, u, n)) in own.into_iter().enumerate() {
                self.push(&p, &u, &n, f, rank as u32);
            }
            let len = self.faces[f as usize].len;
            self.polygons -= usize::from(len != 3);
            self.faces[f as usize].replaced = Some((first, self.faces.len() as u32 - first));
        }
        // Fill each loop; its fan's triangles are top-level faces.
        for ring in &loops {
            let mut values = Values {
                positions: &mut self.positions,
                uvs: self.uv_values.as_mut(),
                normals: self.normal_values.as_mut(),
            };
            for (p, u, n) in fill_loop(&mut values, ring, plane, root.radius) {
                let rank = self.top.len() as u32;
                let id = self.push(&p, &u, &n, NONE, rank);
                self.top.push(id);
            }
        }
        CutOutcome::Flat(loops.len())
    }

    /// Appends a face (a piece of `up` of rank `rank`, or a top-level face) and indexes it.
    fn push(&mut self, p: &[u32], u: &[u32], n: &[u32], up: u32, rank: u32) -> u32 {
        let start = self.corner_pos.len() as u32;
        self.corner_pos.extend_from_slice(p);
        if self.uv_values.is_some() {
            self.corner_uv.extend_from_slice(u);
        }
        if self.normal_values.is_some() {
            self.corner_nr.extend_from_slice(n);
        }
        let id = self.faces.len() as u32;
        self.faces.push(Face { start, len: p.len() as u32, up, rank, replaced: None });
        self.polygons += usize::from(p.len() != 3);
        self.index(id);
        id
    }

    /// The cut mesh: live faces in mesh order, unused positions dropped.
    fn finish(self, mesh: &Mesh) -> Mesh {
        let mut out = Mesh::new();
        out.positions = self.positions;
        out.creases = mesh.creases.clone();
        let mut uvs = self.uv_values.map(|values| FaceVarying { values, indices: Vec::new() });
        let mut normals = self.normal_values.map(|values| FaceVarying { values, indices: Vec::new() });
        let mut stack: Vec<u32> = Vec::new();
        for &t in self.top.iter().rev() {
            stack.push(t);
        }
        while let Some(f) = stack.pop() {
            let face = &self.faces[f as usize];
            if let Some((first, count)) = face.replaced {
                stack.extend((first..first + count).rev());
                continue;
            }
            let r = face.start as usize..(face.start + face.len) as usize;
            out.push_face(&self.corner_pos[r.clone()]);
            if let Some(c) = uvs.as_mut() {
                c.indices.extend_from_slice(&self.corner_uv[r.clone()]);
            }
            if let Some(c) = normals.as_mut() {
                c.indices.extend_from_slice(&self.corner_nr[r]);
            }
        }
        out.uvs = uvs;
        out.normals = normals;
        compact(&mut out);
        out
    }
}

/// A piece of a clipped face, or a fan triangle: its position, UV and normal corners (the
/// last two ignored where the mesh has no UVs or normals).
type Piece = (Vec<u32>, Vec<u32>, Vec<u32>);

/// The value columns a cut appends to: positions, and UV and normal values where the
/// mesh has them.
struct Values<'a> {
    positions: &'a mut Vec<Vec3>,
    uvs: Option<&'a mut Vec<Vec2>>,
    normals: Option<&'a mut Vec<Vec3>>,
}

/// One root's cut in progress, face by face (Sutherland–Hodgman against y ≥ `plane`):
/// the intersection points, UVs and normals made so far, shared by the two faces of an
/// edge, and the directed edges on the plane in the kept polygons' winding (the loops'
/// successor map).
struct Clip {
    plane: f32,
    /// The mesh is all triangles: a clipped triangle's quad is fanned so it stays so.
    triangles: bool,
    new_point: HashMap<(u32, u32), u32>,
    new_uv: HashMap<(u32, u32, u32, u32), u32>,
    new_normal: HashMap<(u32, u32, u32, u32), u32>,
    plane_edges: Vec<(u32, u32)>,
}

impl Clip {
    fn new(plane: f32, triangles: bool) -> Clip {
        Clip {
            plane,
            triangles,
            new_point: HashMap::new(),
            new_uv: HashMap::new(),
            new_normal: HashMap::new(),
            plane_edges: Vec::new(),
        }
    }

    /// The pieces above the plane of the face with corners `pos` (`uv`, `nr`: its UV and
    /// normal corners where the mesh has them); none when less than a polygon is left.
    fn face(
        &mut self,
        values: &mut Values,
        pos: &[u32],
        uv: Option<&[u32]>,
        nr: Option<&[u32]>,
    ) -> Vec<Piece> {
        let plane = self.plane;
        // Each output corner (position, uv, normal) and whether it lies on the plane.
        let k = pos.len();
        let ds: Vec<f32> = pos.iter().map(|&i| values.positions[i as usize].y - plane).collect();
        let d = |i: usize| ds[i];
        let mut kept: Vec<Corner> = Vec::with_capacity(k + 2);
        let corner = |i: usize| (pos[i], uv.map_or(0, |u| u[i]), nr.map_or(0, |n| n[i]), d(i) == 0.0);
        for i in 0..k {
            let j = (i + 1) % k;
            let (di, dj) = (d(i), d(j));
            if di >= 0.0 {
                kept.push(corner(i));
            }
            if (di < 0.0 && dj > 0.0) || (di > 0.0 && dj < 0.0) {
                let t = di / (di - dj);
                let (a, b) = (pos[i], pos[j]);
                let key = edge_key(a, b);
                let positions = &mut *values.positions;
                let p = *self.new_point.entry(key).or_insert_with(|| {
                    let (pa, pb) = (positions[a as usize], positions[b as usize]);
                    let mut q = pa + (pb - pa) * t;
                    q.y = plane;
                    positions.push(q);
                    (positions.len() - 1) as u32
                });
                // t measured from the key's first end, so both faces agree.
                let t_key = if a == key.0 { t } else { 1.0 - t };
                let ui = values.uvs.as_deref_mut().zip(uv).map_or(0, |(c, u)| {
                    let (u0, u1) = if a == key.0 { (u[i], u[j]) } else { (u[j], u[i]) };
                    *self.new_uv.entry((key.0, key.1, u0, u1)).or_insert_with(|| {
                        let v = c[u0 as usize].lerp(c[u1 as usize], t_key);
                        c.push(v);
                        (c.len() - 1) as u32
                    })
                });
                let un = values.normals.as_deref_mut().zip(nr).map_or(0, |(c, n)| {
                    let (n0, n1) = if a == key.0 { (n[i], n[j]) } else { (n[j], n[i]) };
                    *self.new_normal.entry((key.0, key.1, n0, n1)).or_insert_with(|| {
                        let v = c[n0 as usize].lerp(c[n1 as usize], t_key).normalize_or_zero();
                        c.push(v);
                        (c.len() - 1) as u32
                    })
                });
                kept.push((p, ui, un, true));
            }
        }
        // The edges that run from a point on the plane to the next through the
        // removed part: where the original polygon went below between them.
        let n = kept.len();
        for a in 0..n {
            let b = (a + 1) % n;
            if n >= 2 && kept[a].3 && kept[b].3 && kept[a].0 != kept[b].0 {
                // On the plane at both ends: a boundary edge unless it is an edge of
                // the original polygon (both original corners, consecutive).
                let original =
                    pos.iter().enumerate().any(|(i, &p)| p == kept[a].0 && pos[(i + 1) % k] == kept[b].0);
                if !original {
                    self.plane_edges.push((kept[a].0, kept[b].0));
                }
            }
        }
        let distinct = {
            let mut v: Vec<u32> = kept.iter().map(|c| c.0).collect();
            v.sort_unstable();
            v.dedup();
            v.len()
        };
        let mut own = Vec::new();
        if distinct >= 3 {
            let p: Vec<u32> = kept.iter().map(|c| c.0).collect();
            let u: Vec<u32> = kept.iter().map(|c| c.1).collect();
            let nn: Vec<u32> = kept.iter().map(|c| c.2).collect();
            if self.triangles && p.len() > 3 {
                // A clipped triangle is a quad: fanned, so a triangle mesh stays one
                // (Loop subdivision needs triangles). Clipped polygons are convex.
                for t in 1..p.len() - 1 {
                    let pick = |v: &[u32]| vec![v[0], v[t], v[t + 1]];
                    own.push((pick(&p), pick(&u), pick(&nn)));
                }
            } else {
                own.push((p, u, nn));
            }
        }
        own
    }
}

/// Fills one closed cut loop with a fan around its centroid, facing −y, with planar UVs
/// at the bark's texel scale (one unit of u around the root's circumference of `radius`):
/// appends the centre and the fan's values, returns its triangles.
fn fill_loop(values: &mut Values, ring: &[u32], plane: f32, radius: f32) -> Vec<Piece> {
    let per_metre = 1.0 / (std::f32::consts::TAU * radius.max(1e-6));
    let c = ring.iter().map(|&i| values.positions[i as usize]).sum::<Vec3>() / ring.len() as f32;
    let centre = values.positions.len() as u32;
    values.positions.push(Vec3::new(c.x, plane, c.z));
    let uv_of = |p: Vec3| Vec2::new(0.5 + (p.x - c.x) * per_metre, 0.5 + (p.z - c.z) * per_metre);
    let positions = &*values.positions;
    let uv0 = values.uvs.as_deref_mut().map(|ch| {
        let first = ch.len() as u32;
        ch.push(Vec2::splat(0.5));
        ch.extend(ring.iter().map(|&i| uv_of(positions[i as usize])));
        first
    });
    let n0 = values.normals.as_deref_mut().map(|ch| {
        ch.push(-Vec3::Y);
        (ch.len() - 1) as u32
    });
    (0..ring.len())
        .map(|k| {
            let kb = (k + 1) % ring.len();
            let u = uv0.map_or(Vec::new(), |u0| vec![u0, u0 + 1 + k as u32, u0 + 1 + kb as u32]);
            let n = n0.map_or(Vec::new(), |n0| vec![n0; 3]);
            (vec![centre, ring[k], ring[kb]], u, n)
        })
        .collect()
}

/// Chains the reversed plane edges into closed loops (each start the smallest vertex not
/// yet on a loop); `None` when they do not close.
fn chain_loops(plane_edges: &[(u32, u32)]) -> Option<Vec<Vec<u32>>> {
    let mut next: HashMap<u32, u32> = HashMap::with_capacity(plane_edges.len());
    for &(a, b) in plane_edges {
        if next.insert(b, a).is_some() {
            return None;
        }
    }
    let mut loops: Vec<Vec<u32>> = Vec::new();
    let mut seen: HashSet<u32> = HashSet::new();
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable();
    for s in starts {
        if seen.contains(&s) {
            continue;
        }
        let mut ring = vec![s];
        seen.insert(s);
        let mut v = s;
        loop {
            let &w = next.get(&v)?;
            if w == s {
                break;
            }
            if !seen.insert(w) || ring.len() > plane_edges.len() {
                return None;
            }
            ring.push(w);
            v = w;
        }
        if ring.len() < 3 {
            return None;
        }
        loops.push(ring);
    }
    (!loops.is_empty()).then_some(loops)
}

/// Drops positions no face uses (renumbering faces and creases).
fn compact(mesh: &mut Mesh) {
    let mut map = vec![u32::MAX; mesh.positions.len()];
    let mut kept = Vec::with_capacity(mesh.positions.len());
    for &i in &mesh.face_indices {
        if map[i as usize] == u32::MAX {
            map[i as usize] = kept.len() as u32;
            kept.push(i);
        }
    }
    // Keep the original order (stable output) rather than first use.
    kept.sort_unstable();
    for (new, &old) in kept.iter().enumerate() {
        map[old as usize] = new as u32;
    }
    mesh.positions = kept.iter().map(|&i| mesh.positions[i as usize]).collect();
    for i in &mut mesh.face_indices {
        *i = map[*i as usize];
    }
    mesh.creases.retain(|c| map[c.a as usize] != u32::MAX && map[c.b as usize] != u32::MAX);
    for c in &mut mesh.creases {
        c.a = map[c.a as usize];
        c.b = map[c.b as usize];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An open-topped square tube from y = −1 to y = 1 around the y axis, ending below
    /// in a pyramid point at y = −2 (a "rounded" base), outward-facing quads.
    fn tube() -> Mesh {
        let mut m = Mesh::new();
        let ring =
            |y: f32| [(1.0, 1.0), (1.0, -1.0), (-1.0, -1.0), (-1.0, 1.0)].map(|(x, z)| Vec3::new(x, y, z));
        m.positions.extend(ring(1.0));
        m.positions.extend(ring(-1.0));
        m.positions.push(Vec3::new(0.0, -2.0, 0.0));
        for k in 0..4u32 {
            let j = (k + 1) % 4;
            m.push_face(&[4 + k, 4 + j, j, k]);
            m.push_face(&[8, 4 + j, 4 + k]);
        }
        m.uvs = Some(FaceVarying {
            values: m.positions.iter().map(|p| Vec2::new(p.x, p.y)).collect(),
            indices: m.face_indices.clone(),
        });
        m
    }

    #[test]
    fn a_cut_base_lies_flat_on_the_plane_and_closes_the_tube() {
        let mut m = tube();
        // Orientation check: the sides face outwards.
        let f = m.face(0);
        let [a, b, c] = [f[0], f[1], f[2]].map(|i| m.positions[i as usize]);
        let outward = (b - a).cross(c - a).dot((a + c) * 0.5 - Vec3::new(0.0, (a.y + c.y) * 0.5, 0.0));
        assert!(outward > 0.0);
        let r = SunkRoot { node: 0, at: Vec3::ZERO, radius: 1.0 };
        assert_eq!(cut_base(&mut m, &[r]), vec![CutOutcome::Flat(1)]);
        m.validate().unwrap();
        let lo = m.positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
        assert_eq!(lo, 0.0);
        // Every edge is shared by exactly two faces except the open top ring (4 edges).
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for f in 0..m.face_count() {
            let face = m.face(f);
            for k in 0..face.len() {
                let (a, b) = (face[k], face[(k + 1) % face.len()]);
                *edges.entry(edge_key(a, b)).or_default() += if a < b { 1 } else { -1 };
            }
        }
        let open: Vec<_> = edges.iter().filter(|(_, &s)| s != 0).collect();
        assert_eq!(open.len(), 4, "only the top ring is open: {open:?}");
        // The cap faces down.
        let cap = m.face(m.face_count() - 1);
        let [a, b, c] = [cap[0], cap[1], cap[2]].map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).y < 0.0);
        // UVs of the cut points are interpolated: the side corners at y = 0 have v = 0.
        let uv = m.uvs.as_ref().unwrap();
        assert_eq!(uv.indices.len(), m.face_indices.len());
    }

    #[test]
    fn nothing_below_leaves_the_mesh_as_it_is() {
        let mut m = tube();
        let before = m.clone();
        let r = SunkRoot { node: 0, at: Vec3::new(0.0, -5.0, 0.0), radius: 1.0 };
        assert_eq!(cut_base(&mut m, &[r]), vec![CutOutcome::NothingBelow]);
        assert_eq!(m, before);
    }

    /// The cut as it was before issue 39 (the whole mesh rebuilt and compacted once per
    /// root), kept to check that the local cut gives the same bytes: the same clipping of
    /// each face ([`Clip`]), loops and fans, over every face in mesh order.
    fn reference_cut_base(mesh: &mut Mesh, roots: &[SunkRoot]) -> Vec<CutOutcome> {
        roots.iter().map(|r| reference_cut_one(mesh, r)).collect()
    }

    fn reference_cut_one(mesh: &mut Mesh, root: &SunkRoot) -> CutOutcome {
        let plane = root.at.y;
        let reach = CUT_REACH_RADII * root.radius;
        let near = |p: Vec3| Vec2::new(p.x - root.at.x, p.z - root.at.z).length() <= reach;
        let faces = mesh.face_count();
        // Faces that take part: near the root with a corner below the plane.
        let cut: Vec<bool> = (0..faces)
            .map(|f| {
                let face = mesh.face(f);
                face.iter().any(|&i| mesh.positions[i as usize].y < plane)
                    && face.iter().any(|&i| near(mesh.positions[i as usize]))
            })
            .collect();
        if !cut.iter().any(|&c| c) {
            return CutOutcome::NothingBelow;
        }
        // A triangle mesh (hull, sweep, tube) stays one; a quad mesh (quad + Catmull–Clark)
        // gets n-gons where the cut crosses its faces.
        let triangles = mesh.face_offsets.windows(2).all(|w| w[1] - w[0] == 3);
        let mut out = Mesh::new();
        out.positions = mesh.positions.clone();
        out.creases = mesh.creases.clone();
        let mut uvs =
            mesh.uvs.as_ref().map(|c| FaceVarying { values: c.values.clone(), indices: Vec::new() });
        let mut normals =
            mesh.normals.as_ref().map(|c| FaceVarying { values: c.values.clone(), indices: Vec::new() });
        let push = |out: &mut Mesh,
                    uvs: &mut Option<FaceVarying<Vec2>>,
                    normals: &mut Option<FaceVarying<Vec3>>,
                    p: &[u32],
                    u: &[u32],
                    n: &[u32]| {
            out.push_face(p);
            if let Some(c) = uvs.as_mut() {
                c.indices.extend_from_slice(u);
            }
            if let Some(c) = normals.as_mut() {
                c.indices.extend_from_slice(n);
            }
        };
        let mut clip = Clip::new(plane, triangles);
        for (f, &cut_face) in cut.iter().enumerate() {
            let corners = mesh.corners(f);
            let pos: &[u32] = &mesh.face_indices[corners.clone()];
            let uv: Option<&[u32]> = mesh.uvs.as_ref().map(|c| &c.indices[corners.clone()]);
            let nr: Option<&[u32]> = mesh.normals.as_ref().map(|c| &c.indices[corners.clone()]);
            if !cut_face {
                push(&mut out, &mut uvs, &mut normals, pos, uv.unwrap_or(&[]), nr.unwrap_or(&[]));
                continue;
            }
            let mut values = Values {
                positions: &mut out.positions,
                uvs: uvs.as_mut().map(|c| &mut c.values),
                normals: normals.as_mut().map(|c| &mut c.values),
            };
            for (p, u, n) in clip.face(&mut values, pos, uv, nr) {
                push(&mut out, &mut uvs, &mut normals, &p, &u, &n);
            }
        }
        let Some(loops) = chain_loops(&clip.plane_edges) else { return CutOutcome::Open };
        for ring in &loops {
            let mut values = Values {
                positions: &mut out.positions,
                uvs: uvs.as_mut().map(|c| &mut c.values),
                normals: normals.as_mut().map(|c| &mut c.values),
            };
            for (p, u, n) in fill_loop(&mut values, ring, plane, root.radius) {
                push(&mut out, &mut uvs, &mut normals, &p, &u, &n);
            }
        }
        out.uvs = uvs;
        out.normals = normals;
        compact(&mut out);
        *mesh = out;
        CutOutcome::Flat(loops.len())
    }

    /// Tubes (a [`tube`] each, scaled and moved) of a forest: some far apart, some
    /// overlapping so that one root's cut crosses another's faces and fans, some at other
    /// heights, one root far wider than the rest, one with nothing below it; triangle and
    /// quad meshes, with and without UVs, and an unused position.
    #[test]
    fn the_local_cut_is_the_whole_mesh_cut_byte_for_byte() {
        let place = |m: &Mesh, at: Vec3, s: f32| {
            let mut out = m.clone();
            out.positions.iter_mut().for_each(|p| *p = *p * s + at);
            out
        };
        let forest = |triangles: bool, uvs: bool| {
            let mut m = Mesh::new();
            let mut roots = Vec::new();
            let spots = [
                (Vec3::new(0.0, 0.0, 0.0), 1.0),
                (Vec3::new(10.0, 0.0, 0.0), 1.0),
                (Vec3::new(1.5, 0.3, 0.5), 0.8),
                (Vec3::new(-20.0, 5.0, 3.0), 2.0),
                (Vec3::new(0.7, -0.2, -0.4), 0.5),
                (Vec3::new(40.0, 0.0, 40.0), 9.0),
                (Vec3::new(10.0, 0.0, 0.0), 1.0),
            ];
            m.positions.push(Vec3::splat(99.0)); // unused
            for (k, &(at, s)) in spots.iter().enumerate() {
                let t = place(&tube(), at, s);
                let base = m.positions.len() as u32;
                m.positions.extend(&t.positions);
                for f in 0..t.face_count() {
                    let face: Vec<u32> = t.face(f).iter().map(|&i| i + base).collect();
                    if triangles && face.len() == 4 {
                        m.push_face(&[face[0], face[1], face[2]]);
                        m.push_face(&[face[0], face[2], face[3]]);
                    } else {
                        m.push_face(&face);
                    }
                }
                roots.push(SunkRoot { node: k as u32, at, radius: s });
            }
            roots.push(SunkRoot { node: 99, at: Vec3::new(500.0, 0.0, 0.0), radius: 1.0 });
            if uvs {
                m.uvs = Some(FaceVarying {
                    values: m.positions.iter().map(|p| Vec2::new(p.x, p.y)).collect(),
                    indices: m.face_indices.clone(),
                });
                m.normals = Some(FaceVarying {
                    values: m.positions.iter().map(|p| p.normalize_or_zero()).collect(),
                    indices: m.face_indices.clone(),
                });
            }
            (m, roots)
        };
        for triangles in [false, true] {
            for uvs in [false, true] {
                let (m, roots) = forest(triangles, uvs);
                for n in 1..=roots.len() {
                    let (mut a, mut b) = (m.clone(), m.clone());
                    let oa = cut_base(&mut a, &roots[..n]);
                    let ob = reference_cut_base(&mut b, &roots[..n]);
                    assert_eq!(oa, ob, "outcomes, {n} roots (triangles {triangles}, uvs {uvs})");
                    assert_eq!(a, b, "mesh, {n} roots (triangles {triangles}, uvs {uvs})");
                    if n == roots.len() {
                        let flat = oa.iter().filter(|o| matches!(o, CutOutcome::Flat(_))).count();
                        assert!(flat >= 3 && oa.contains(&CutOutcome::NothingBelow), "{oa:?}");
                    }
                }
                // Reversed order too: cuts interact.
                let rev: Vec<SunkRoot> = roots.iter().rev().copied().collect();
                let (mut a, mut b) = (m.clone(), m.clone());
                assert_eq!(cut_base(&mut a, &rev), reference_cut_base(&mut b, &rev));
                assert_eq!(a, b);
            }
        }
    }

    #[test]
    fn only_upright_roots_sink() {
        let mut sk = Skeleton::new();
        let r0 = sk.push(Vec3::ZERO, 0.2, NO_PARENT, Vec3::X, 0);
        sk.push(Vec3::new(0.0, 1.0, 0.0), 0.1, r0, Vec3::X, 0);
        let r1 = sk.push(Vec3::new(5.0, 0.0, 0.0), 0.2, NO_PARENT, Vec3::X, 0);
        sk.push(Vec3::new(5.0, -1.0, 0.0), 0.1, r1, Vec3::X, 0);
        let sunk = sink_roots(&mut sk);
        assert_eq!(sunk, vec![SunkRoot { node: 0, at: Vec3::ZERO, radius: 0.2 }]);
        assert!((sk.position[0].y + SINK_RADII * 0.2).abs() < 1e-6);
        assert_eq!(sk.position[2], Vec3::new(5.0, 0.0, 0.0));
    }

    #[test]
    fn only_roots_on_the_ground_sink() {
        let mut sk = Skeleton::new();
        // A trunk at y = 0, a second one slightly higher (within two trunk radii), and an
        // upright piece floating in the crown (a leaf outline drawn with `F`).
        let trunk = sk.push(Vec3::ZERO, 0.5, NO_PARENT, Vec3::X, 0);
        sk.push(Vec3::new(0.0, 3.0, 0.0), 0.3, trunk, Vec3::X, 0);
        let near = sk.push(Vec3::new(4.0, 0.6, 0.0), 0.2, NO_PARENT, Vec3::X, 0);
        sk.push(Vec3::new(4.0, 2.0, 0.0), 0.1, near, Vec3::X, 0);
        let high = sk.push(Vec3::new(0.5, 2.5, 0.0), 0.05, NO_PARENT, Vec3::X, 0);
        sk.push(Vec3::new(0.5, 2.7, 0.0), 0.05, high, Vec3::X, 0);
        let sunk = sink_roots(&mut sk);
        let nodes: Vec<u32> = sunk.iter().map(|s| s.node).collect();
        assert_eq!(nodes, vec![trunk, near]);
        assert_eq!(sk.position[high as usize], Vec3::new(0.5, 2.5, 0.0), "the floating piece stays");
    }
}
