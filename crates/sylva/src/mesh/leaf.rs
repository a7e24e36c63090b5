//! The leaf mesher ("Turtle Leaf", Salad's `/L`): a turtle skeleton becomes one open
//! triangle surface per leaf, ready for Loop subdivision with a creased midrib, after
//! MacMurchy2004 §5.4 (Figs 5.5, 5.6), §6.4.1–§6.4.2 (Figs 6.2, 6.3) and §A.3, as distilled
//! by MacMurchy2004-spec §2.8, §2.9 and §2.12 (properties 1–5, 21, 22 and 24).
//!
//! # Construction
//!
//! 1. **Graph.** Internodes shorter than float noise are collapsed into their parent
//!    (listed in [`LeafMesh::collapsed`]). A node with two or more children (or a root
//!    with several) is a *junction*, one child a *chain node*, none a *tip*.
//! 2. **Frames.** Every internode has the turtle frame it was drawn with: heading `H`
//!    (its direction), up `U` (the skeleton's per-node `up`, made perpendicular to
//!    `H`) and left `L = U × H` (`H × L = U`, MacMurchy2004-spec §2.1).
//! 3. **Section** (§5.4, spec §2.9): open, 3 vertices across `L` — right margin
//!    `c − r L`, midrib `c + midrib_depth · w · U`, left margin `c + r L` — with `r` the
//!    skeleton radius and `w = 2r` the turtle width (the blade is as wide as the line
//!    width, as a stem is as thick). A chain node's section is shared by its two
//!    internodes (bisector heading, mean up). Each internode is a strip of **4
//!    triangles** with the diagonals mirrored about the midrib (both from the start
//!    margins to the end midrib vertex), so the strip is symmetric.
//! 4. **Junctions** (§5.4, Figs 5.5a, 5.6): the trunk section is moved back and each
//!    child's section forward by the Eq 5.1/5.2 offsets (maximum over the partners,
//!    guarded as the sweep mesher's [`guarded_offsets`], each at most 45 % of its
//!    internode). With these offsets the facing margins of two neighbouring children
//!    coincide; the pair is **merged** into one vertex (at the midpoint when another
//!    partner pushed a child further out). Children are ordered by their signed angle
//!    about the leaf normal, right to left, and a centre vertex `X` at the node (offset by
//!    the midrib depth) is fanned to the polygon trunk-right → every child's right,
//!    midrib, left (= next child's right) → trunk-left → trunk-midrib: `2n + 4`
//!    triangles for `n` children, any planar degree. A root with several children is the
//!    same fan without a trunk (open between the outer children). The result is one
//!    open surface per leaf: `V − E + F = 1`, one boundary loop.
//! 5. **Midrib** (§5.4): every edge between consecutive midrib vertices, and `X` to the
//!    trunk's and every child's midrib vertex, is a crease of sharpness
//!    [`LeafOptions::midrib_sharpness`] (`/E`, 0–255; 255 is infinitely sharp, `k` keeps
//!    crease masks for `k` levels). The creases of each axis form one chain
//!    ([`LeafMesh::midribs`]): the continuation child (the one with its parent's branch
//!    order) carries the trunk's chain on through `X`; every lateral chain starts at `X`.
//! 6. **Tips** (§5.4, Fig 5.5c, spec §2.8): each tip gets a pair of triangles
//!    (right margin, apex, midrib) and (midrib, apex, left margin) and one vertex, the
//!    apex, at `tip_size × w` (`/A`, `w` the tip's width) beyond the last section's
//!    centre along the vector from the second-last section's centre to the last's. The
//!    apex–midrib edge is a crease of sharpness [`LeafOptions::tip_sharpness`] (`/T`):
//!    with its two boundary edges the apex then has three sharp edges, so Loop keeps it
//!    fixed (corner rule) for that many levels — tip sharpness travels in the mesh's
//!    creases alone; [`LeafMesh::corners`] lists the same tags for callers that pass
//!    vertex sharpness to [`crate::refine::subdivide`].
//! 7. **Cut-out mapping proxy** (§6.4.1, Fig 6.2; spec §2.12; property 24). The proxy is
//!    the same string "interpreted honouring only rotations about U". We derive it from
//!    the skeleton instead of interpreting the string a second time, so every skeleton
//!    (`.str`, L-system, LST) has one: the rotation between an internode's frame and its
//!    parent's is split into turn (about U), pitch (about the new L) and roll (about the
//!    new H), and only the turn `α = atan2(H·L_p, H·H_p)` is kept; the proxy turtle
//!    starts at `H = +Y, L = −X, U = +Z` and walks each internode's true length. This
//!    equals the second interpretation whenever the rotations between two `F`s come as
//!    turn, then pitch, then roll (any of them absent) — the way leaf strings bend and
//!    twist a flat blade. The proxy is meshed by the same construction (the child order
//!    of every junction is taken from the proxy and shared), so it has the final mesh's
//!    faces exactly and `z = 0` everywhere ([`LeafMesh::proxy`]). Its `(x, y)`, fitted
//!    to `[0, 1]²` by its bounding box (one scale for both axes, so the texture keeps
//!    its aspect; centred along the shorter side), is the final mesh's `(u, v)`.
//! 8. **Tiled mapping** (§6.4.2, Fig 6.3; [`LeafMapping::Tiled`]): `u` runs across the
//!    width (right margin 1, midrib ½, left margin 0) and `v` from 0 to 1 over every
//!    internode together with the junction it starts from (a tip's internode includes
//!    its tip triangles), face-varying.
//!
//! Output: triangles only, counter-clockwise seen from the turtle's `+U` side.
//! Deterministic; bad options or a bad skeleton give an error, never a panic or NaN.

use crate::error::{Error, Result};
use crate::geometry::NONE;
use crate::geometry::{Crease, FaceVarying, Mesh};
use crate::mesh::sweep::{collapse_short, guarded_offsets, perpendicular, unit_or, Collapsed};
use crate::refine::Corner;
use crate::skeleton::Skeleton;
use glam::{DVec3, Vec2, Vec3};

/// How the leaf mesher maps texture coordinates (MacMurchy2004-spec §2.12, Leaf tab "Use Cutout
/// Texture Mapping").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LeafMapping {
    /// The whole leaf cut out of one image: the planar proxy's `(x, y)`, fitted to
    /// `[0, 1]²`, becomes `(u, v)` (§6.4.1, Fig 6.2).
    #[default]
    Cutout,
    /// `u` across the width, `v` over each internode (§6.4.2, Fig 6.3).
    Tiled,
}

/// Options of [`leaf_mesh`] (MacMurchy2004-spec §3 Leaf and SubD tabs, switches `/A /E /T`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LeafOptions {
    /// Offset of the midrib vertex along the turtle's up vector, as a fraction of the
    /// section's width ("Midrib Depth"; default 0.1; in -1..=1, negative for a groove on
    /// the upper side).
    pub midrib_depth: f64,
    /// Tip height divided by the tip's width ("Tip Size", `/A`; default 1; in (0, 100]).
    pub tip_size: f64,
    /// Sharpness of the midrib creases (`/E`, 0–255; default 255: infinitely sharp; `k`
    /// uses crease masks for `k` levels; 0: no creases).
    pub midrib_sharpness: f64,
    /// Sharpness of the tip vertices (`/T`, 0–255; default 0: the tip rounds; 255 keeps
    /// it pointed at every level).
    pub tip_sharpness: f64,
    /// Texture mapping (default cut-out).
    pub mapping: LeafMapping,
    /// Smallest half-width as a fraction of the skeleton's largest radius (default 0.01,
    /// range 1e-6–1): narrower sections (a leaf string starting at width 0) are widened
    /// to it, so no two vertices coincide.
    pub min_width: f64,
}

impl Default for LeafOptions {
    fn default() -> Self {
        LeafOptions {
            midrib_depth: 0.1,
            tip_size: 1.0,
            midrib_sharpness: 255.0,
            tip_sharpness: 0.0,
            mapping: LeafMapping::Cutout,
            min_width: 0.01,
        }
    }
}

impl LeafOptions {
    /// Checks every option's range; the message starts with the option's name.
    pub fn check(&self) -> Result<()> {
        let bad = |why: String| Err(Error::InvalidGeometry { what: "leaf mesher".into(), why });
        if !(self.midrib_depth.is_finite() && (-1.0..=1.0).contains(&self.midrib_depth)) {
            return bad(format!("midrib_depth = {}; it must be in -1..=1", self.midrib_depth));
        }
        if !(self.tip_size.is_finite() && self.tip_size > 0.0 && self.tip_size <= 100.0) {
            return bad(format!("tip_size = {}; it must be in (0, 100]", self.tip_size));
        }
        for (name, s) in [("midrib_sharpness", self.midrib_sharpness), ("tip_sharpness", self.tip_sharpness)]
        {
            if !(s.is_finite() && (0.0..=255.0).contains(&s)) {
                return bad(format!("{name} = {s}; it must be in 0..=255"));
            }
        }
        if !(self.min_width.is_finite() && (1e-6..=1.0).contains(&self.min_width)) {
            return bad(format!("min_width = {}; it must be in 1e-6..=1", self.min_width));
        }
        Ok(())
    }
}

/// One leaf tip (property 21).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeafTip {
    /// The skeleton node it ends.
    pub node: u32,
    /// The apex vertex.
    pub apex: u32,
    /// The last section's (right margin, midrib, left margin) vertices.
    pub section: [u32; 3],
    /// Centres of the second-last and the last section.
    pub centres: [DVec3; 2],
    /// The tip's width (twice the tip node's radius, after `min_width`).
    pub width: f64,
    /// Its two triangles (face indices).
    pub faces: [usize; 2],
}

/// What [`leaf_mesh`] made.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LeafMesh {
    /// The triangle control mesh with UVs and midrib (and tip) creases.
    pub mesh: Mesh,
    /// The planar proxy (§6.4.1): the same faces, `z = 0`; its `(x, y)` gives the
    /// cut-out UVs.
    pub proxy: Mesh,
    /// The tip vertices tagged with the tip sharpness (empty at 0); the same sharpness
    /// is already in the apex–midrib creases of `mesh`.
    pub corners: Vec<Corner>,
    /// Every tip.
    pub tips: Vec<LeafTip>,
    /// The midrib vertex chain of each axis (trunk first), apex included.
    pub midribs: Vec<Vec<u32>>,
    /// Junction nodes.
    pub junctions: Vec<u32>,
    /// Number of merged vertex pairs (one per pair of neighbouring children).
    pub merged: usize,
    /// Collapsed zero-length internodes (their end nodes).
    pub collapsed: Vec<u32>,
    /// Connected leaf pieces (roots with at least one internode).
    pub pieces: usize,
    /// The skeleton node each face was made for.
    pub face_node: Vec<u32>,
}

/// Per-node geometry of one interpretation (the 3D skeleton or its planar proxy).
struct Geometry {
    pos: Vec<DVec3>,
    /// Heading of the internode into each node (zero for roots).
    dir: Vec<DVec3>,
    /// Up of the internode into each node (a root: its own up).
    up: Vec<DVec3>,
}

/// The skeleton's graph after collapsing zero-length internodes.
struct Graph {
    live: Vec<bool>,
    par: Vec<u32>,
    kids: Vec<Vec<u32>>,
    rad: Vec<f64>,
    len: Vec<f64>,
    order: Vec<u16>,
    collapsed: Vec<u32>,
}

fn graph(s: &Skeleton, opts: &LeafOptions) -> Graph {
    let n = s.len();
    let pos: Vec<DVec3> = s.position.iter().map(|p| p.as_dvec3()).collect();
    let rmax = s.radius.iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
    let scale = pos.iter().fold(0.0f64, |a, p| a.max(p.abs().max_element()));
    let rmin = if rmax > 0.0 { opts.min_width * rmax } else { opts.min_width * scale.max(1e-3) };
    let rad: Vec<f64> = s.radius.iter().map(|&r| (r as f64).max(rmin)).collect();
    let Collapsed { live, parent: par, collapsed } = collapse_short(&s.parent, &pos, &rad);
    let mut kids = vec![Vec::new(); n];
    let mut len = vec![0.0; n];
    for i in 0..n {
        if par[i] != NONE {
            kids[par[i] as usize].push(i as u32);
            len[i] = (pos[i] - pos[par[i] as usize]).length();
        }
    }
    Graph { live, par, kids, rad, len, order: s.order.clone(), collapsed }
}

/// The 3D geometry: turtle frames from the skeleton.
fn frames(s: &Skeleton, g: &Graph) -> Geometry {
    let n = s.len();
    let pos: Vec<DVec3> = s.position.iter().map(|p| p.as_dvec3()).collect();
    let mut dir = vec![DVec3::ZERO; n];
    let mut up = vec![DVec3::Z; n];
    for i in 0..n {
        if !g.live[i] {
            continue;
        }
        let raw = s.up[i].as_dvec3();
        if g.par[i] == NONE {
            // A root: its up made perpendicular to its first child's heading.
            let h =
                g.kids[i].first().map(|&k| unit_or(pos[k as usize] - pos[i], DVec3::Y)).unwrap_or(DVec3::Y);
            up[i] = perpendicular(unit_or(raw, DVec3::Z), h);
        } else {
            let p = g.par[i] as usize;
            dir[i] = unit_or(pos[i] - pos[p], DVec3::Y);
            up[i] = perpendicular(unit_or(raw, up[p]), dir[i]);
        }
    }
    Geometry { pos, dir, up }
}

/// The planar proxy (module docs, step 7): only the turn about each parent frame's up
/// is kept; the proxy turtle starts at `H = +Y, L = −X, U = +Z`.
fn proxy_geometry(s: &Skeleton, g: &Graph, real: &Geometry) -> Geometry {
    let n = s.len();
    let mut pos = vec![DVec3::ZERO; n];
    let mut dir = vec![DVec3::ZERO; n];
    let up = vec![DVec3::Z; n];
    let mut phi = vec![0.0f64; n];
    for i in 0..n {
        if !g.live[i] {
            continue;
        }
        if g.par[i] == NONE {
            let p = real.pos[i];
            pos[i] = DVec3::new(p.x, p.y, 0.0);
            continue;
        }
        let p = g.par[i] as usize;
        // The parent frame: the parent internode's, or a root's (its up, heading +Y).
        let (hp, up_p) = if g.par[p] == NONE {
            let u0 = real.up[p];
            (perpendicular(DVec3::Y, u0), u0)
        } else {
            (real.dir[p], real.up[p])
        };
        let lp = up_p.cross(hp);
        let h = real.dir[i];
        let (a, b) = (h.dot(hp), h.dot(lp));
        let alpha = if a.abs() + b.abs() > 1e-12 { b.atan2(a) } else { 0.0 };
        phi[i] = phi[p] + alpha;
        dir[i] = DVec3::new(-phi[i].sin(), phi[i].cos(), 0.0);
        pos[i] = pos[p] + g.len[i] * dir[i];
    }
    Geometry { pos, dir, up }
}

/// Children of every junction ordered right to left by their signed angle about the
/// proxy's normal (+Z) from the trunk heading (a root: the children's mean heading).
fn order_children(g: &Graph, proxy: &Geometry) -> Vec<Vec<u32>> {
    let n = g.live.len();
    let mut sorted = vec![Vec::new(); n];
    for (j, slot) in sorted.iter_mut().enumerate() {
        if !g.live[j] || g.kids[j].len() < 2 {
            continue;
        }
        let href = if g.par[j] != NONE {
            proxy.dir[j]
        } else {
            let m: DVec3 = g.kids[j].iter().map(|&k| proxy.dir[k as usize]).sum();
            unit_or(m, DVec3::Y)
        };
        let mut ks: Vec<(f64, u32)> = g.kids[j]
            .iter()
            .map(|&k| {
                let d = proxy.dir[k as usize];
                (href.cross(d).z.atan2(href.dot(d)), k)
            })
            .collect();
        ks.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        *slot = ks.into_iter().map(|(_, k)| k).collect();
    }
    sorted
}

/// One open section.
#[derive(Debug, Clone, Copy)]
struct Section {
    /// Right margin, midrib, left margin.
    v: [u32; 3],
    c: DVec3,
    /// Tiled `v` of this section on its internode.
    t: f32,
}

struct Build<'a> {
    opts: &'a LeafOptions,
    mesh: Mesh,
    /// Tiled UVs per corner.
    uv: Vec<Vec2>,
    creases: Vec<Crease>,
    face_node: Vec<u32>,
}

fn sharpness(s: f64) -> f32 {
    if s >= 255.0 {
        f32::INFINITY
    } else {
        s as f32
    }
}

impl Build<'_> {
    fn vertex(&mut self, p: DVec3) -> u32 {
        self.mesh.positions.push(p.as_vec3());
        (self.mesh.positions.len() - 1) as u32
    }

    fn section(&mut self, c: DVec3, h: DVec3, u: DVec3, r: f64, t: f32, right: Option<u32>) -> Section {
        let l = u.cross(h);
        let rv = match right {
            Some(v) => {
                // Merged with the neighbour's left margin: the midpoint of both.
                let mine = c - r * l;
                let other = self.mesh.positions[v as usize].as_dvec3();
                self.mesh.positions[v as usize] = (0.5 * (mine + other)).as_vec3();
                v
            }
            None => self.vertex(c - r * l),
        };
        let m = self.vertex(c + self.opts.midrib_depth * 2.0 * r * u);
        let lv = self.vertex(c + r * l);
        Section { v: [rv, m, lv], c, t }
    }

    fn tri(&mut self, v: [u32; 3], uv: [Vec2; 3], node: u32) {
        self.mesh.push_face(&v);
        self.uv.extend_from_slice(&uv);
        self.face_node.push(node);
    }

    fn crease(&mut self, a: u32, b: u32, s: f64) {
        if s > 0.0 {
            self.creases.push(Crease { a, b, sharpness: sharpness(s) });
        }
    }

    /// The 4-triangle strip from section `a` to section `b`.
    fn strip(&mut self, a: &Section, b: &Section, node: u32) {
        let uv = |s: &Section, k: usize| Vec2::new([1.0, 0.5, 0.0][k], s.t);
        let (ar, am, al) = (a.v[0], a.v[1], a.v[2]);
        let (br, bm, bl) = (b.v[0], b.v[1], b.v[2]);
        self.tri([ar, br, bm], [uv(a, 0), uv(b, 0), uv(b, 1)], node);
        self.tri([ar, bm, am], [uv(a, 0), uv(b, 1), uv(a, 1)], node);
        self.tri([am, bm, al], [uv(a, 1), uv(b, 1), uv(a, 2)], node);
        self.tri([bm, bl, al], [uv(b, 1), uv(b, 2), uv(a, 2)], node);
        self.crease(am, bm, self.opts.midrib_sharpness);
    }
}

/// What one construction made (for the 3D geometry or the proxy).
struct Built {
    mesh: Mesh,
    uv: Vec<Vec2>,
    face_node: Vec<u32>,
    tips: Vec<LeafTip>,
    midribs: Vec<Vec<u32>>,
    junctions: Vec<u32>,
    merged: usize,
    pieces: usize,
}

/// Tip height of node `i` (0 unless it is a tip).
fn tip_height(g: &Graph, opts: &LeafOptions, i: usize) -> f64 {
    if g.kids[i].is_empty() {
        opts.tip_size * 2.0 * g.rad[i]
    } else {
        0.0
    }
}

/// Tiled `v` at `s` metres into internode `i` (a tip's internode includes its tip).
fn tile_v(g: &Graph, opts: &LeafOptions, i: usize, s: f64) -> f32 {
    (s / (g.len[i] + tip_height(g, opts, i)).max(1e-300)) as f32
}

/// Builds the mesh of one geometry; the topology depends only on `g` and `sorted`.
fn build(g: &Graph, geo: &Geometry, sorted: &[Vec<u32>], opts: &LeafOptions) -> Built {
    let n = g.live.len();
    let mut b = Build { opts, mesh: Mesh::new(), uv: Vec::new(), creases: Vec::new(), face_node: Vec::new() };
    let mut start: Vec<Option<Section>> = vec![None; n];
    let mut end: Vec<Option<Section>> = vec![None; n];
    let mut xv = vec![NONE; n];
    let mut junctions = Vec::new();
    let mut merged = 0;
    let mut pieces = 0;
    let depth = opts.midrib_depth;
    for j in 0..n {
        if !g.live[j] {
            continue;
        }
        let kids = &g.kids[j];
        let root = g.par[j] == NONE;
        if root && !kids.is_empty() {
            pieces += 1;
        }
        match (root, kids.len()) {
            (_, 0) if root => {}
            (true, 1) => {
                let k = kids[0] as usize;
                start[k] = Some(b.section(geo.pos[j], geo.dir[k], geo.up[k], g.rad[j], 0.0, None));
            }
            (false, 0) => {
                let t = tile_v(g, opts, j, g.len[j]);
                end[j] = Some(b.section(geo.pos[j], geo.dir[j], geo.up[j], g.rad[j], t, None));
            }
            (false, 1) => {
                let k = kids[0] as usize;
                let h = unit_or(geo.dir[j] + geo.dir[k], geo.dir[k]);
                let u = perpendicular(unit_or(geo.up[j] + geo.up[k], geo.up[k]), h);
                let s = b.section(geo.pos[j], h, u, g.rad[j], 1.0, None);
                end[j] = Some(Section { t: tile_v(g, opts, j, g.len[j]), ..s });
                start[k] = Some(Section { t: 0.0, ..s });
            }
            _ => {
                junctions.push(j as u32);
                // Eq 5.1 offsets over every pair of branches (the trunk's axis is −H).
                let mut axes: Vec<(usize, DVec3, f64, f64)> = Vec::new();
                if !root {
                    axes.push((j, -geo.dir[j], g.rad[j], g.len[j]));
                }
                for &k in &sorted[j] {
                    let k = k as usize;
                    axes.push((k, geo.dir[k], g.rad[k], g.len[k]));
                }
                let mut off: Vec<f64> = axes.iter().map(|a| (0.25 * a.2).min(0.45 * a.3)).collect();
                for a in 0..axes.len() {
                    for c in a + 1..axes.len() {
                        let theta = axes[a].1.dot(axes[c].1).clamp(-1.0, 1.0).acos();
                        let (r1, r2) = (axes[a].2, axes[c].2);
                        if let Some((d1, d2, _)) =
                            guarded_offsets(r1, r2, theta, 0.45 * axes[a].3, 0.45 * axes[c].3)
                        {
                            off[a] = off[a].max(d1);
                            off[c] = off[c].max(d2);
                        }
                    }
                }
                let first_kid = usize::from(!root);
                let normal = if root {
                    let m: DVec3 = sorted[j].iter().map(|&k| geo.up[k as usize]).sum();
                    unit_or(m, DVec3::Z)
                } else {
                    geo.up[j]
                };
                let x = b.vertex(geo.pos[j] + depth * 2.0 * g.rad[j] * normal);
                xv[j] = x;
                let trunk = (!root).then(|| {
                    let c = geo.pos[j] - off[0] * geo.dir[j];
                    let t = tile_v(g, opts, j, g.len[j] - off[0]);
                    b.section(c, geo.dir[j], geo.up[j], g.rad[j], t, None)
                });
                // Polygon around X with each corner's tiled UV.
                let mut poly: Vec<(u32, Vec2)> = Vec::new();
                if let Some(t) = &trunk {
                    poly.push((t.v[0], Vec2::new(1.0, 0.0)));
                }
                let mut prev_left: Option<u32> = None;
                for (q, &k) in sorted[j].iter().enumerate() {
                    let k = k as usize;
                    let d = off[first_kid + q];
                    let t = tile_v(g, opts, k, d);
                    let s =
                        b.section(geo.pos[j] + d * geo.dir[k], geo.dir[k], geo.up[k], g.rad[k], t, prev_left);
                    if prev_left.is_some() {
                        merged += 1;
                    } else {
                        poly.push((s.v[0], Vec2::new(1.0, t)));
                    }
                    poly.push((s.v[1], Vec2::new(0.5, t)));
                    poly.push((s.v[2], Vec2::new(0.0, t)));
                    prev_left = Some(s.v[2]);
                    b.crease(x, s.v[1], opts.midrib_sharpness);
                    start[k] = Some(s);
                }
                if let Some(t) = trunk {
                    poly.push((t.v[2], Vec2::new(0.0, 0.0)));
                    poly.push((t.v[1], Vec2::new(0.5, 0.0)));
                    poly.push(poly[0]);
                    b.crease(x, t.v[1], opts.midrib_sharpness);
                    end[j] = Some(t);
                }
                let xuv = Vec2::new(0.5, 0.0);
                for w in poly.windows(2) {
                    b.tri([x, w[0].0, w[1].0], [xuv, w[0].1, w[1].1], j as u32);
                }
            }
        }
    }
    // Strips.
    for i in 0..n {
        if let (Some(a), Some(e)) = (start[i], end[i]) {
            b.strip(&a, &e, i as u32);
        }
    }
    // Tips (property 21): two triangles and one vertex each.
    let mut tips = Vec::new();
    let mut apex_of = vec![NONE; n];
    for i in 0..n {
        if !(g.live[i] && g.par[i] != NONE && g.kids[i].is_empty()) {
            continue;
        }
        let (Some(a), Some(e)) = (start[i], end[i]) else { continue };
        let w = 2.0 * g.rad[i];
        let dir = unit_or(e.c - a.c, geo.dir[i]);
        let apex = b.vertex(e.c + opts.tip_size * w * dir);
        let f0 = b.mesh.face_count();
        let uv = |k: usize| Vec2::new([1.0, 0.5, 0.0][k], e.t);
        let top = Vec2::new(0.5, 1.0);
        b.tri([e.v[0], apex, e.v[1]], [uv(0), top, uv(1)], i as u32);
        b.tri([e.v[1], apex, e.v[2]], [uv(1), top, uv(2)], i as u32);
        b.crease(e.v[1], apex, opts.tip_sharpness);
        apex_of[i] = apex;
        tips.push(LeafTip {
            node: i as u32,
            apex,
            section: e.v,
            centres: [a.c, e.c],
            width: w,
            faces: [f0, f0 + 1],
        });
    }
    // Midrib chains, one per axis: the continuation child has its parent's order.
    let continuation = |j: usize| -> Option<usize> {
        let ks = &g.kids[j];
        if ks.len() == 1 && g.par[j] != NONE {
            return Some(ks[0] as usize);
        }
        if g.par[j] == NONE {
            return None;
        }
        let same: Vec<usize> = ks.iter().map(|&k| k as usize).filter(|&k| g.order[k] == g.order[j]).collect();
        // Several with the parent's order: the straightest continues.
        same.into_iter().max_by(|&a, &c| geo.dir[j].dot(geo.dir[a]).total_cmp(&geo.dir[j].dot(geo.dir[c])))
    };
    let mut continues = vec![false; n];
    for j in 0..n {
        if g.live[j] {
            if let Some(k) = continuation(j) {
                continues[k] = true;
            }
        }
    }
    let mut midribs = Vec::new();
    for k0 in 0..n {
        if !g.live[k0] || g.par[k0] == NONE || continues[k0] || start[k0].is_none() {
            continue;
        }
        let mut chain = Vec::new();
        let p = g.par[k0] as usize;
        if xv[p] != NONE {
            chain.push(xv[p]);
        }
        let mut k = k0;
        loop {
            for v in [start[k].map(|s| s.v[1]), end[k].map(|s| s.v[1])].into_iter().flatten() {
                if chain.last() != Some(&v) {
                    chain.push(v);
                }
            }
            if apex_of[k] != NONE {
                chain.push(apex_of[k]);
            }
            if xv[k] != NONE {
                chain.push(xv[k]);
            }
            match continuation(k) {
                Some(c) => k = c,
                None => break,
            }
        }
        midribs.push(chain);
    }
    let Build { mut mesh, uv, creases, face_node, .. } = b;
    mesh.creases = creases;
    Built { mesh, uv, face_node, tips, midribs, junctions, merged, pieces }
}

/// Meshes `skeleton` as leaves (module docs): one open, creased control surface per
/// leaf, its planar cut-out proxy and the tips. Errors: bad options, an invalid skeleton,
/// one without internodes, or coordinates so large the mesh is not finite.
pub fn leaf_mesh(skeleton: &Skeleton, opts: &LeafOptions) -> Result<LeafMesh> {
    opts.check()?;
    skeleton.validate()?;
    let bad = |why: String| Error::InvalidGeometry { what: "leaf mesher".into(), why };
    let g = graph(skeleton, opts);
    if (0..g.live.len()).all(|i| g.par[i] == NONE) {
        return Err(bad(format!(
            "the skeleton ({} nodes) has no internode to make a leaf of (draw at least one `F`)",
            skeleton.len()
        )));
    }
    let real = frames(skeleton, &g);
    let flat = proxy_geometry(skeleton, &g, &real);
    let sorted = order_children(&g, &flat);
    let built = build(&g, &real, &sorted, opts);
    let proxy_opts = LeafOptions { midrib_depth: 0.0, ..opts.clone() };
    let mut proxy = build(&g, &flat, &sorted, &proxy_opts).mesh;
    for p in &mut proxy.positions {
        p.z = 0.0;
    }
    proxy.creases.clear();
    let mut mesh = built.mesh;
    if let Some(v) = mesh.positions.iter().chain(&proxy.positions).position(|p| !p.is_finite()) {
        return Err(bad(format!(
            "vertex {v} is not finite (skeleton coordinates or radii too large for single precision)"
        )));
    }
    if proxy.face_indices != mesh.face_indices {
        return Err(bad("the proxy's faces differ from the leaf's (internal error)".into()));
    }
    mesh.uvs = Some(match opts.mapping {
        LeafMapping::Cutout => cutout_uvs(&proxy),
        LeafMapping::Tiled => {
            FaceVarying { values: built.uv, indices: (0..mesh.face_indices.len() as u32).collect() }
        }
    });
    let corners = if opts.tip_sharpness > 0.0 {
        built
            .tips
            .iter()
            .map(|t| Corner { vertex: t.apex, sharpness: sharpness(opts.tip_sharpness) })
            .collect()
    } else {
        Vec::new()
    };
    Ok(LeafMesh {
        mesh,
        proxy,
        corners,
        tips: built.tips,
        midribs: built.midribs,
        junctions: built.junctions,
        merged: built.merged,
        collapsed: g.collapsed,
        pieces: built.pieces,
        face_node: built.face_node,
    })
}

/// The cut-out UVs: the proxy's `(x, y)` fitted to `[0, 1]²` by its bounding box, one
/// scale for both axes, centred along the shorter side; one value per vertex.
pub fn cutout_uvs(proxy: &Mesh) -> FaceVarying<Vec2> {
    let (lo, hi) = proxy.bounds().unwrap_or((Vec3::ZERO, Vec3::ONE));
    let ext = hi - lo;
    let s = ext.x.max(ext.y).max(1e-30);
    let pad = Vec2::new(s - ext.x, s - ext.y) * 0.5;
    let values = proxy
        .positions
        .iter()
        .map(|p| ((Vec2::new(p.x - lo.x, p.y - lo.y) + pad) / s).clamp(Vec2::ZERO, Vec2::ONE))
        .collect();
    FaceVarying { values, indices: proxy.face_indices.clone() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::NO_PARENT;
    use glam::Vec3;

    /// A chain of internodes from the origin through `pts`, radius `r`, up `up`.
    fn chain(pts: &[Vec3], r: f32, up: Vec3) -> Skeleton {
        let mut s = Skeleton::new();
        let mut p = s.push(Vec3::ZERO, r, NO_PARENT, up, 0);
        for &q in pts {
            p = s.push(q, r, p, up, 0);
        }
        s
    }

    #[test]
    fn options_are_checked_by_name() {
        assert!(LeafOptions::default().check().is_ok());
        for (o, key) in [
            (LeafOptions { midrib_depth: 1.5, ..Default::default() }, "midrib_depth"),
            (LeafOptions { tip_size: f64::INFINITY, ..Default::default() }, "tip_size"),
            (LeafOptions { tip_sharpness: f64::NAN, ..Default::default() }, "tip_sharpness"),
            (LeafOptions { min_width: 0.0, ..Default::default() }, "min_width"),
        ] {
            let e = o.check().unwrap_err().to_string();
            assert!(e.contains(key), "{e}");
        }
    }

    #[test]
    fn sharpness_255_is_infinite_and_k_is_k_levels() {
        assert_eq!(sharpness(255.0), f32::INFINITY);
        assert_eq!(sharpness(3.0), 3.0);
        let s = chain(&[Vec3::Y, Vec3::Y * 2.0], 0.1, Vec3::Z);
        let l =
            leaf_mesh(&s, &LeafOptions { midrib_sharpness: 0.0, tip_sharpness: 0.0, ..Default::default() })
                .unwrap();
        assert!(l.mesh.creases.is_empty() && l.corners.is_empty());
        let l =
            leaf_mesh(&s, &LeafOptions { midrib_sharpness: 4.0, tip_sharpness: 7.0, ..Default::default() })
                .unwrap();
        assert_eq!(l.mesh.creases.len(), 3, "2 midrib edges and the tip edge");
        assert!(l.mesh.creases[..2].iter().all(|c| c.sharpness == 4.0));
        assert_eq!(l.mesh.creases[2].sharpness, 7.0);
        assert_eq!(l.corners, vec![Corner { vertex: l.tips[0].apex, sharpness: 7.0 }]);
    }

    /// The section: margins at ± r along L = U × H, the midrib offset along U by
    /// midrib depth × width; a strip is 4 triangles facing +U.
    #[test]
    fn the_section_is_open_with_a_v_shaped_midrib() {
        let s = chain(&[Vec3::new(0.0, 1.0, 0.0)], 0.2, Vec3::Z);
        let l = leaf_mesh(&s, &LeafOptions { midrib_depth: 0.25, ..Default::default() }).unwrap();
        let p = &l.mesh.positions;
        // Base section: right (+X, since L = Z × Y = −X), midrib, left.
        assert!((p[0] - Vec3::new(0.2, 0.0, 0.0)).length() < 1e-6);
        assert!((p[1] - Vec3::new(0.0, 0.0, 0.1)).length() < 1e-6);
        assert!((p[2] - Vec3::new(-0.2, 0.0, 0.0)).length() < 1e-6);
        assert_eq!(l.mesh.face_count(), 4 + 2);
        for f in 0..4 {
            let v = l.mesh.face(f);
            let n = (l.proxy.positions[v[1] as usize] - l.proxy.positions[v[0] as usize])
                .cross(l.proxy.positions[v[2] as usize] - l.proxy.positions[v[0] as usize]);
            assert!(n.z > 0.0, "face {f} faces +U");
        }
    }

    /// The proxy keeps exactly the turn of a turn-pitch-roll rotation between two
    /// internodes.
    #[test]
    fn the_proxy_keeps_only_the_turn() {
        // Parent frame: H = +Y, U = +Z, L = −X. Child: turn 30°, pitch 40°, roll 50°.
        let (h, l, u) = (DVec3::Y, DVec3::NEG_X, DVec3::Z);
        let turn = glam::DQuat::from_axis_angle(u, 30f64.to_radians());
        let (h1, l1, u1) = (turn * h, turn * l, u);
        let pitch = glam::DQuat::from_axis_angle(l1, 40f64.to_radians());
        let (h2, u2) = (pitch * h1, pitch * u1);
        let roll = glam::DQuat::from_axis_angle(h2, 50f64.to_radians());
        let u3 = roll * u2;
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::Z, 0);
        let a = s.push(Vec3::Y, 0.1, r, Vec3::Z, 0);
        s.push((DVec3::Y + 2.0 * h2).as_vec3(), 0.1, a, u3.as_vec3(), 0);
        let opts = LeafOptions::default();
        let g = graph(&s, &opts);
        let real = frames(&s, &g);
        let flat = proxy_geometry(&s, &g, &real);
        let want = DVec3::new(-30f64.to_radians().sin(), 30f64.to_radians().cos(), 0.0);
        assert!((flat.dir[2] - want).length() < 1e-6, "{} != {want}", flat.dir[2]);
        assert!((flat.pos[2] - (DVec3::Y + 2.0 * want)).length() < 1e-5);
    }

    #[test]
    fn tiled_uvs_run_across_the_width_and_along_each_internode() {
        let s = chain(&[Vec3::Y, Vec3::Y * 2.0], 0.1, Vec3::Z);
        let l = leaf_mesh(&s, &LeafOptions { mapping: LeafMapping::Tiled, ..Default::default() }).unwrap();
        let uv = l.mesh.uvs.as_ref().unwrap();
        // The first strip's first triangle: (start right, end right, end midrib).
        let c: Vec<Vec2> = (0..3).map(|k| uv.values[uv.indices[k] as usize]).collect();
        assert_eq!(c, vec![Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.5, 1.0)]);
        assert!(uv.values.iter().all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y)));
    }
}
