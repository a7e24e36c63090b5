//! PN triangles and PN quads: point-normal cubic Bézier patches tessellated on the CPU
//! (Skjermo2008 §3.3.1 "PN-Triangle and PN-Quad tessellation", Th Eqs. 3.1–3.2, Figs 3.8–3.18;
//! Skjermo2008-spec §5; issue 4 item 7).
//!
//! Every face becomes a cubic Bézier patch built from its corners and their normals only
//! (the method is local):
//!
//! - **Edge control points** (Th Eq. 3.1, Vlachos et al. 2001): the point ⅓ along the edge
//!   projected onto the tangent plane of the nearer corner,
//!   `(2Pᵢ + Pⱼ − ((Pⱼ − Pᵢ)·Nᵢ)Nᵢ)/3`; or the "rounder" rule (Th Eq. 3.2) projecting the
//!   edge midpoint, `(Pᵢ + Pⱼ − ((Pⱼ − Pᵢ)·Nᵢ)Nᵢ)/2` ([`EdgeRule`]).
//! - **PN triangles**: the centre is `V + 1.5 (E − V)`, V the mean of the corners and E the
//!   mean of the six edge points.
//! - **PN quads** (Theyer 2003; Th Fig. 3.9 naming `Pᵢⱼ`): the four inner points either
//!   assume **zero twist**, `P₁₁ = P₀₁ + P₁₀ − P₀₀` (the seed's variant, poor), or follow
//!   **Theyer**: Eq. 3.1 along the diagonals, `P₁₁ = (2P₀₀ + P₃₃ − ((P₃₃ − P₀₀)·N₀₀)N₀₀)/3`
//!   (default). Whether the ½ rule applies to diagonals is unstated (Skjermo2008-spec §5): it is
//!   its own option, [`PnOptions::diagonal_rule`].
//! - **Normals** are interpolated separately, linearly or quadratically (Vlachos: the
//!   mid-edge normal is the average of the end normals reflected across the plane
//!   perpendicular to the edge, `N̂ᵢ + N̂ⱼ − vᵢⱼ(Pⱼ − Pᵢ)`, `vᵢⱼ = 2 (Pⱼ − Pᵢ)·(Nᵢ + Nⱼ)/|Pⱼ − Pᵢ|²`).
//!
//! Each patch is sampled on a uniform grid with `level` segments per edge (Tatarinov's
//! instanced tessellation, done on the CPU): a triangle becomes `level²` triangles, a quad
//! `level²` quads; faces with more corners are fanned into PN triangles. A point on an
//! edge depends only on that edge's two corners and their normals and is computed once,
//! in a fixed direction, so neighbouring patches share identical vertices (no cracks)
//! wherever they share the corner normals. With the mesh's own face-varying normals, a
//! hard edge (different normals on each side) opens, as PN surfaces do.

use super::RefineError;
use crate::geometry::{FaceVarying, Mesh};
use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// Where the edge control points sit before projection (Th Eqs. 3.1 and 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EdgeRule {
    /// ⅓ along the edge: standard PN (Vlachos), Eq. 3.1.
    #[default]
    Standard,
    /// ½ along the edge: the "rounder" variant, Eq. 3.2 (½ radius for a square section,
    /// against the circle's 0.55228).
    Rounder,
}

/// How the four inner control points of a PN quad are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum QuadInterior {
    /// Zero twist at the corners: `P₁₁ = P₀₁ + P₁₀ − P₀₀`.
    ZeroTwist,
    /// Theyer's rule: the edge rule applied along the diagonals.
    #[default]
    Theyer,
}

/// How normals are interpolated across a patch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NormalInterpolation {
    /// Linear (barycentric / bilinear) blend of the corner normals, normalised.
    Linear,
    /// Vlachos' quadratic normals (mid-edge normals reflected across the edge's bisecting
    /// plane), which follow inflections that linear blending misses.
    #[default]
    Quadratic,
}

/// Which corner normals the patches are built from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NormalSource {
    /// The mesh's face-varying normals when it has them, else [`NormalSource::Smooth`].
    #[default]
    Mesh,
    /// Area-weighted smooth vertex normals computed from the positions (one per vertex, so
    /// every shared edge is crack-free).
    Smooth,
}

/// Options of [`pn_tessellate`].
#[derive(Debug, Clone, PartialEq)]
pub struct PnOptions {
    /// Segments per patch edge (≥ 1; 1 returns the flat input faces).
    pub level: u32,
    /// Edge control point rule.
    pub edge_rule: EdgeRule,
    /// Rule for the diagonal points of Theyer's quad interior.
    pub diagonal_rule: EdgeRule,
    /// Inner points of PN quads.
    pub interior: QuadInterior,
    /// Normal interpolation.
    pub normals: NormalInterpolation,
    /// Where corner normals come from.
    pub source: NormalSource,
    /// Refuse to produce more faces than this.
    pub max_faces: usize,
}

impl Default for PnOptions {
    /// Level 4, standard ⅓ rule, Theyer interiors, quadratic normals.
    fn default() -> Self {
        PnOptions {
            level: 4,
            edge_rule: EdgeRule::Standard,
            diagonal_rule: EdgeRule::Standard,
            interior: QuadInterior::Theyer,
            normals: NormalInterpolation::Quadratic,
            source: NormalSource::Mesh,
            max_faces: super::DEFAULT_MAX_FACES,
        }
    }
}

/// An edge or diagonal control point: the ⅓ (or ½) point of `pᵢ → pⱼ` projected onto the
/// tangent plane of `pᵢ` (normal `nᵢ`, unit or zero).
pub fn control_point(pi: Vec3, ni: Vec3, pj: Vec3, rule: EdgeRule) -> Vec3 {
    let w = (pj - pi).dot(ni);
    match rule {
        EdgeRule::Standard => (2.0 * pi + pj - w * ni) / 3.0,
        EdgeRule::Rounder => (pi + pj - w * ni) * 0.5,
    }
}

/// Vlachos' mid-edge normal of the edge `pᵢ → pⱼ` (symmetric in its ends).
pub fn mid_edge_normal(pi: Vec3, ni: Vec3, pj: Vec3, nj: Vec3) -> Vec3 {
    let d = pj - pi;
    let dd = d.length_squared();
    let h = if dd > 0.0 { ni + nj - (2.0 * d.dot(ni + nj) / dd) * d } else { ni + nj };
    h.normalize_or_zero()
}

/// The cubic Bernstein weights at `t`.
fn bernstein3(t: f32) -> [f32; 4] {
    let s = 1.0 - t;
    [s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t]
}

/// A corner's identity for welding: (vertex index, normal index).
type CornerKey = (u32, u32);

/// One corner of a patch: position, unit normal and the key that identifies it for
/// welding (vertex index, normal index).
#[derive(Clone, Copy)]
struct PnCorner {
    p: Vec3,
    n: Vec3,
    key: (u32, u32),
    uv: Vec2,
}

/// Point and normal at `t` along the edge curve `a → b` (its cubic Bézier boundary).
fn edge_sample(a: &PnCorner, b: &PnCorner, t: f32, opts: &PnOptions) -> (Vec3, Vec3) {
    let c1 = control_point(a.p, a.n, b.p, opts.edge_rule);
    let c2 = control_point(b.p, b.n, a.p, opts.edge_rule);
    let w = bernstein3(t);
    let p = a.p * w[0] + c1 * w[1] + c2 * w[2] + b.p * w[3];
    let s = 1.0 - t;
    let n = match opts.normals {
        NormalInterpolation::Linear => a.n * s + b.n * t,
        NormalInterpolation::Quadratic => {
            a.n * (s * s) + mid_edge_normal(a.p, a.n, b.p, b.n) * (s * t) + b.n * (t * t)
        }
    };
    (p, n.normalize_or_zero())
}

/// A PN triangle's control net: `b300, b030, b003, b210, b120, b021, b012, b102, b201, b111`.
struct TriPatch {
    b: [Vec3; 10],
    n: [Vec3; 6],
}

impl TriPatch {
    fn new(c: &[PnCorner; 3], opts: &PnOptions) -> Self {
        let (p1, p2, p3) = (c[0].p, c[1].p, c[2].p);
        let (n1, n2, n3) = (c[0].n, c[1].n, c[2].n);
        let r = opts.edge_rule;
        let b210 = control_point(p1, n1, p2, r);
        let b120 = control_point(p2, n2, p1, r);
        let b021 = control_point(p2, n2, p3, r);
        let b012 = control_point(p3, n3, p2, r);
        let b102 = control_point(p3, n3, p1, r);
        let b201 = control_point(p1, n1, p3, r);
        let e = (b210 + b120 + b021 + b012 + b102 + b201) / 6.0;
        let v = (p1 + p2 + p3) / 3.0;
        let b111 = e + (e - v) * 0.5;
        TriPatch {
            b: [p1, p2, p3, b210, b120, b021, b012, b102, b201, b111],
            n: [
                n1,
                n2,
                n3,
                mid_edge_normal(p1, n1, p2, n2),
                mid_edge_normal(p2, n2, p3, n3),
                mid_edge_normal(p3, n3, p1, n1),
            ],
        }
    }

    /// Position and normal at barycentric (w, u, v) for corners (1, 2, 3).
    fn eval(&self, w: f32, u: f32, v: f32, normals: NormalInterpolation) -> (Vec3, Vec3) {
        let b = &self.b;
        let p = b[0] * (w * w * w)
            + b[1] * (u * u * u)
            + b[2] * (v * v * v)
            + b[3] * (3.0 * w * w * u)
            + b[4] * (3.0 * w * u * u)
            + b[5] * (3.0 * u * u * v)
            + b[6] * (3.0 * u * v * v)
            + b[7] * (3.0 * w * v * v)
            + b[8] * (3.0 * w * w * v)
            + b[9] * (6.0 * w * u * v);
        let n = &self.n;
        let nn = match normals {
            NormalInterpolation::Linear => n[0] * w + n[1] * u + n[2] * v,
            NormalInterpolation::Quadratic => {
                n[0] * (w * w)
                    + n[1] * (u * u)
                    + n[2] * (v * v)
                    + n[3] * (w * u)
                    + n[4] * (u * v)
                    + n[5] * (v * w)
            }
        };
        (p, nn.normalize_or_zero())
    }
}

/// A PN quad's bicubic control net `P[i][j]` (i along corner 0 → 1, j along 0 → 3) and
/// its biquadratic normal net.
struct QuadPatch {
    p: [[Vec3; 4]; 4],
    n: [[Vec3; 3]; 3],
}

impl QuadPatch {
    fn new(c: &[PnCorner; 4], opts: &PnOptions) -> Self {
        let r = opts.edge_rule;
        let (c0, c1, c2, c3) = (&c[0], &c[1], &c[2], &c[3]);
        let e = |a: &PnCorner, b: &PnCorner| control_point(a.p, a.n, b.p, r);
        let mut p = [[Vec3::ZERO; 4]; 4];
        p[0][0] = c0.p;
        p[3][0] = c1.p;
        p[3][3] = c2.p;
        p[0][3] = c3.p;
        p[1][0] = e(c0, c1);
        p[2][0] = e(c1, c0);
        p[3][1] = e(c1, c2);
        p[3][2] = e(c2, c1);
        p[2][3] = e(c2, c3);
        p[1][3] = e(c3, c2);
        p[0][2] = e(c3, c0);
        p[0][1] = e(c0, c3);
        match opts.interior {
            QuadInterior::ZeroTwist => {
                p[1][1] = p[1][0] + p[0][1] - p[0][0];
                p[2][1] = p[2][0] + p[3][1] - p[3][0];
                p[2][2] = p[3][2] + p[2][3] - p[3][3];
                p[1][2] = p[0][2] + p[1][3] - p[0][3];
            }
            QuadInterior::Theyer => {
                let d = |a: &PnCorner, b: &PnCorner| control_point(a.p, a.n, b.p, opts.diagonal_rule);
                p[1][1] = d(c0, c2);
                p[2][2] = d(c2, c0);
                p[2][1] = d(c1, c3);
                p[1][2] = d(c3, c1);
            }
        }
        let m = |a: &PnCorner, b: &PnCorner| mid_edge_normal(a.p, a.n, b.p, b.n);
        let (m01, m12, m23, m30) = (m(c0, c1), m(c1, c2), m(c2, c3), m(c3, c0));
        let centre = (m01 + m12 + m23 + m30).normalize_or_zero();
        let n = [[c0.n, m30, c3.n], [m01, centre, m23], [c1.n, m12, c2.n]];
        QuadPatch { p, n }
    }

    /// Position and normal at (u, v) ∈ [0, 1]².
    fn eval(&self, u: f32, v: f32, corners: &[PnCorner; 4], normals: NormalInterpolation) -> (Vec3, Vec3) {
        let (bu, bv) = (bernstein3(u), bernstein3(v));
        let mut p = Vec3::ZERO;
        for (i, row) in self.p.iter().enumerate() {
            let mut s = Vec3::ZERO;
            for (j, q) in row.iter().enumerate() {
                s += *q * bv[j];
            }
            p += s * bu[i];
        }
        let n = match normals {
            NormalInterpolation::Linear => {
                let c = corners;
                (c[0].n * (1.0 - u) + c[1].n * u) * (1.0 - v) + (c[3].n * (1.0 - u) + c[2].n * u) * v
            }
            NormalInterpolation::Quadratic => {
                // Vlachos' basis (1 − t)², t(1 − t), t², as for the triangles, so that a
                // quad's edge normals equal a neighbouring triangle's.
                let q = |t: f32| [(1.0 - t) * (1.0 - t), t * (1.0 - t), t * t];
                let (qu, qv) = (q(u), q(v));
                let mut n = Vec3::ZERO;
                for (row, wu) in self.n.iter().zip(qu) {
                    for (nij, wv) in row.iter().zip(qv) {
                        n += *nij * (wu * wv);
                    }
                }
                n
            }
        };
        (p, n.normalize_or_zero())
    }
}

/// Area-weighted smooth vertex normals (Newell normals of the faces summed per vertex).
pub fn smooth_vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; mesh.positions.len()];
    for f in 0..mesh.face_count() {
        let face = mesh.face(f);
        let fnorm = polygon_normal(mesh, face);
        for &v in face {
            if let Some(x) = n.get_mut(v as usize) {
                *x += fnorm;
            }
        }
    }
    n.iter().map(|v| v.normalize_or_zero()).collect()
}

/// Newell's (area-weighted) normal of a polygon.
fn polygon_normal(mesh: &Mesh, face: &[u32]) -> Vec3 {
    let mut n = Vec3::ZERO;
    for (i, &a) in face.iter().enumerate() {
        let b = face[(i + 1) % face.len()];
        let (pa, pb) = (mesh.positions[a as usize], mesh.positions[b as usize]);
        n += pa.cross(pb);
    }
    n // twice the vector area
}

/// Welded output vertices: corners and edge samples are shared between patches.
struct Builder<'a> {
    opts: &'a PnOptions,
    out: Mesh,
    normals: Vec<Vec3>,
    uv_values: Vec<Vec2>,
    uv_indices: Vec<u32>,
    corner_verts: HashMap<CornerKey, u32>,
    edge_verts: HashMap<(CornerKey, CornerKey), Vec<u32>>,
}

impl Builder<'_> {
    fn push(&mut self, p: Vec3, n: Vec3) -> u32 {
        self.out.positions.push(p);
        self.normals.push(n);
        self.out.positions.len() as u32 - 1
    }

    fn corner(&mut self, c: &PnCorner) -> u32 {
        if let Some(&v) = self.corner_verts.get(&c.key) {
            return v;
        }
        let v = self.push(c.p, c.n);
        self.corner_verts.insert(c.key, v);
        v
    }

    /// The `level − 1` inner samples of edge `a → b`, in that direction.
    fn edge(&mut self, a: &PnCorner, b: &PnCorner) -> Vec<u32> {
        let s = self.opts.level;
        // Evaluate in an order fixed by the data alone (position, then normal, then key), so
        // the samples depend only on the edge's ends, whatever the vertex numbering.
        let order = |c: &PnCorner| {
            let b = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            (b(c.p), b(c.n), c.key)
        };
        let flip = order(a) > order(b);
        let (x, y) = if flip { (b, a) } else { (a, b) };
        let key = (x.key, y.key); // welding: the same corners (vertex, normal index)
        let mut vs = match self.edge_verts.get(&key) {
            Some(vs) => vs.clone(),
            None => {
                let mut vs = Vec::with_capacity(s as usize - 1);
                for t in 1..s {
                    let (p, n) = edge_sample(x, y, t as f32 / s as f32, self.opts);
                    vs.push(self.push(p, n));
                }
                self.edge_verts.insert(key, vs.clone());
                vs
            }
        };
        if flip {
            vs.reverse();
        }
        vs
    }

    fn face(&mut self, vs: &[u32], uvs: Option<&[Vec2]>) {
        self.out.push_face(vs);
        if let Some(uvs) = uvs {
            for uv in uvs {
                self.uv_indices.push(self.uv_values.len() as u32);
                self.uv_values.push(*uv);
            }
        }
    }

    fn triangle(&mut self, c: [PnCorner; 3], has_uv: bool) {
        let s = self.opts.level as usize;
        let patch = TriPatch::new(&c, self.opts);
        // Grid point (i, j): weight i/s on corner 1, j/s on corner 2, the rest on corner 0.
        let idx = |i: usize, j: usize| (i * (2 * s + 3 - i)) / 2 + j;
        let mut grid = vec![0u32; (s + 1) * (s + 2) / 2];
        let e01 = self.edge(&c[0], &c[1]);
        let e12 = self.edge(&c[1], &c[2]);
        let e20 = self.edge(&c[2], &c[0]);
        grid[idx(0, 0)] = self.corner(&c[0]);
        grid[idx(s, 0)] = self.corner(&c[1]);
        grid[idx(0, s)] = self.corner(&c[2]);
        for t in 1..s {
            grid[idx(t, 0)] = e01[t - 1];
            grid[idx(s - t, t)] = e12[t - 1];
            grid[idx(0, s - t)] = e20[t - 1];
        }
        for i in 1..s {
            for j in 1..s - i {
                let (u, v) = (i as f32 / s as f32, j as f32 / s as f32);
                let (p, n) = patch.eval(1.0 - u - v, u, v, self.opts.normals);
                grid[idx(i, j)] = self.push(p, n);
            }
        }
        let uv = |i: usize, j: usize| {
            let (u, v) = (i as f32 / s as f32, j as f32 / s as f32);
            c[0].uv * (1.0 - u - v) + c[1].uv * u + c[2].uv * v
        };
        for i in 0..s {
            for j in 0..s - i {
                let t = [(i, j), (i + 1, j), (i, j + 1)];
                let uvs = t.map(|(a, b)| uv(a, b));
                self.face(&t.map(|(a, b)| grid[idx(a, b)]), has_uv.then_some(&uvs[..]));
                if i + j + 1 < s {
                    let t = [(i + 1, j), (i + 1, j + 1), (i, j + 1)];
                    let uvs = t.map(|(a, b)| uv(a, b));
                    self.face(&t.map(|(a, b)| grid[idx(a, b)]), has_uv.then_some(&uvs[..]));
                }
            }
        }
    }

    fn quad(&mut self, c: [PnCorner; 4], has_uv: bool) {
        let s = self.opts.level as usize;
        let patch = QuadPatch::new(&c, self.opts);
        let w = s + 1;
        let mut grid = vec![0u32; w * w];
        let idx = |i: usize, j: usize| j * w + i;
        let e01 = self.edge(&c[0], &c[1]);
        let e12 = self.edge(&c[1], &c[2]);
        let e23 = self.edge(&c[2], &c[3]);
        let e30 = self.edge(&c[3], &c[0]);
        grid[idx(0, 0)] = self.corner(&c[0]);
        grid[idx(s, 0)] = self.corner(&c[1]);
        grid[idx(s, s)] = self.corner(&c[2]);
        grid[idx(0, s)] = self.corner(&c[3]);
        for t in 1..s {
            grid[idx(t, 0)] = e01[t - 1];
            grid[idx(s, t)] = e12[t - 1];
            grid[idx(s - t, s)] = e23[t - 1];
            grid[idx(0, s - t)] = e30[t - 1];
        }
        for j in 1..s {
            for i in 1..s {
                let (p, n) = patch.eval(i as f32 / s as f32, j as f32 / s as f32, &c, self.opts.normals);
                grid[idx(i, j)] = self.push(p, n);
            }
        }
        let uv = |i: usize, j: usize| {
            let (u, v) = (i as f32 / s as f32, j as f32 / s as f32);
            (c[0].uv * (1.0 - u) + c[1].uv * u) * (1.0 - v) + (c[3].uv * (1.0 - u) + c[2].uv * u) * v
        };
        for j in 0..s {
            for i in 0..s {
                let q = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                let uvs = q.map(|(a, b)| uv(a, b));
                self.face(&q.map(|(a, b)| grid[idx(a, b)]), has_uv.then_some(&uvs[..]));
            }
        }
    }
}

/// Tessellates every face of `mesh` as a PN triangle (3 corners), PN quad (4) or fan of
/// PN triangles (more), `options.level` segments per edge; see the [module docs](self).
/// The result has per-vertex normals from the chosen normal interpolation (stored as a
/// face-varying channel indexed like the faces) and bilinearly / barycentrically
/// interpolated UVs when `mesh` has UVs. Creases are not carried.
///
/// ```
/// use sylva::refine::pn::{pn_tessellate, PnOptions};
/// # use sylva::Mesh; use glam::Vec3;
/// let mut quad = Mesh::new();
/// quad.positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
/// quad.push_face(&[0, 1, 2, 3]);
/// let fine = pn_tessellate(&quad, &PnOptions { level: 3, ..Default::default() }).unwrap();
/// assert_eq!(fine.face_count(), 9);
/// assert!(fine.positions.iter().all(|p| p.z.abs() < 1e-6)); // flat stays flat
/// ```
pub fn pn_tessellate(mesh: &Mesh, options: &PnOptions) -> Result<Mesh, RefineError> {
    mesh.validate().map_err(RefineError::InvalidMesh)?;
    if options.level == 0 {
        return Err(RefineError::InvalidOption("PN tessellation level must be at least 1".into()));
    }
    let s = options.level as u128;
    let out_faces: u128 = (0..mesh.face_count())
        .map(|f| match mesh.face(f).len() {
            4 => s * s,
            n => (n as u128 - 2) * s * s,
        })
        .sum();
    if out_faces > options.max_faces as u128 {
        return Err(RefineError::InvalidOption(format!(
            "PN tessellation at level {} would make {out_faces} faces, more than the limit of {}",
            options.level, options.max_faces
        )));
    }
    let corners = mesh.face_indices.len() as u128;
    if corners.saturating_mul((s + 1) * (s + 1)) >= u32::MAX as u128 {
        return Err(RefineError::TooLarge { what: "PN tessellation", count: out_faces as usize });
    }
    let use_mesh_normals = options.source == NormalSource::Mesh && mesh.normals.is_some();
    let smooth = if use_mesh_normals { Vec::new() } else { smooth_vertex_normals(mesh) };
    let corner = |c: usize| -> PnCorner {
        let v = mesh.face_indices[c];
        let (n, key) = match (&mesh.normals, use_mesh_normals) {
            (Some(ch), true) => {
                let i = ch.indices[c];
                (ch.values[i as usize].normalize_or_zero(), (v, i))
            }
            _ => (smooth[v as usize], (v, v)),
        };
        let uv = mesh.uvs.as_ref().map_or(Vec2::ZERO, |ch| ch.values[ch.indices[c] as usize]);
        PnCorner { p: mesh.positions[v as usize], n, key, uv }
    };
    let mut b = Builder {
        opts: options,
        out: Mesh::new(),
        normals: Vec::new(),
        uv_values: Vec::new(),
        uv_indices: Vec::new(),
        corner_verts: HashMap::new(),
        edge_verts: HashMap::new(),
    };
    let has_uv = mesh.uvs.is_some();
    for f in 0..mesh.face_count() {
        let r = mesh.corners(f);
        match r.len() {
            4 => b.quad(
                [corner(r.start), corner(r.start + 1), corner(r.start + 2), corner(r.start + 3)],
                has_uv,
            ),
            _ => {
                for k in 1..r.len() - 1 {
                    b.triangle([corner(r.start), corner(r.start + k), corner(r.start + k + 1)], has_uv);
                }
            }
        }
    }
    let mut out = b.out;
    out.normals = Some(FaceVarying { values: b.normals, indices: out.face_indices.clone() });
    if has_uv {
        out.uvs = Some(FaceVarying { values: b.uv_values, indices: b.uv_indices });
    }
    Ok(out)
}
