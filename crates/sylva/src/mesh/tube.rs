//! The tube mesher: generalized cylinders around the axes of a [`Skeleton`].
//!
//! This is the baseline "cylinder model" that MacMurchy2004 and McLoughlin2021 compare against, with
//! the tube features McLoughlin2021 §4.2 plans but never builds: per-node widths (tapered
//! tubes), a user-set side count, and texture coordinates with vertical segmentation so
//! square bark texels do not stretch.
//!
//! # Algorithm
//!
//! 1. **Axes.** The skeleton is split into axes (chains of nodes). At every node the
//!    axis continues into one child: among the children with the node's own branch
//!    `order` (or all children when none has it) the one with the largest radius, ties
//!    broken by the direction most aligned with the incoming internode, then by the
//!    lower index (a root has no incoming internode, so there the index decides).
//!    Every other child starts a *lateral* axis whose first ring sits at the branching
//!    node's centre with the internode's explicit start radius
//!    ([`Skeleton::start_radius()`], e.g. an LST cylinder's r0), else radius
//!    `min(parent node radius, child node radius)`, so the child tube starts inside its
//!    parent and no crack can show. (Rings along an axis are shared by consecutive
//!    internodes and have their node's radius, so a continuing internode's explicit
//!    start radius is not used; a root's axis starts with the root node's radius.) It is not pulled back
//!    along the child direction: at wide branching angles that would push the base out
//!    through the far side of the parent. Nodes that coincide with the previous ring of
//!    their axis (zero-length internodes) are merged into it (the earlier ring is kept).
//! 2. **Frames.** Rotation-minimizing frames by the double-reflection method (Wang,
//!    Jüttler, Zheng & Liu 2008, "Computation of rotation minimizing frames"), started
//!    from the `up` reference of the axis's second ring projected perpendicular to the
//!    first tangent. The ring tangent at an interior node is the normalized sum of the
//!    incoming and outgoing unit directions (the incoming one when they cancel).
//! 3. **Rings.** One continuous tube per axis: `sides` vertices per ring, rings shared
//!    by consecutive internodes. At a bend the ring is stretched along the bend
//!    direction by `1 / cos(θ/2)` (a mitre, clamped at θ = 120°) so elbows keep the
//!    tube's thickness. A ring of radius 0 collapses to a single vertex (a cone point).
//! 4. **Caps.** A flat fan closes each axis base; tips get a hemispherical cap, a flat
//!    fan or nothing ([`TipStyle`]). With closed bases and tips every axis is a closed,
//!    consistently oriented 2-manifold.
//!
//! Output: triangles, counter-clockwise seen from outside, with face-varying UVs
//! (`u` around, 0 → 1 with a duplicated seam column; `v` = arc length / the
//! circumference `2πr` at the axis base) and face-varying smooth normals (radial,
//! tilted for taper; flat caps get their own split normal).
//!
//! Cost: O(nodes × sides), one counting pass to reserve every buffer exactly, no
//! allocation per ring.

use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::{Children, Skeleton, NO_PARENT};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, TAU};

/// Fewest sides a tube may have.
pub const MIN_SIDES: u32 = 3;
/// Most sides a tube may have.
pub const MAX_SIDES: u32 = 1024;

/// How the free end (tip) of every axis is closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TipStyle {
    /// A hemisphere of the tip radius: `clamp(sides / 4, 1, 8)` extra rings converging
    /// to one apex vertex. It extends the axis by its tip radius.
    #[default]
    Round,
    /// A flat fan to a centre vertex.
    Flat,
    /// No cap: the tube is open at its tip.
    Open,
}

/// How the start (base) of every axis is closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BaseStyle {
    /// A flat fan to a centre vertex, with its own (split) normal.
    #[default]
    Flat,
    /// No cap: the tube is open at its base.
    Open,
}

/// Options of [`tube_mesh`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TubeOptions {
    /// Vertices per ring, in `3..=1024` (default 8).
    #[serde(skip)]
    pub sides: u32,
    /// How axis tips are closed (default [`TipStyle::Round`]).
    #[serde(skip)]
    pub tips: TipStyle,
    /// How axis bases are closed (default [`BaseStyle::Flat`]).
    pub bases: BaseStyle,
}

impl Default for TubeOptions {
    fn default() -> Self {
        TubeOptions { sides: 8, tips: TipStyle::Round, bases: BaseStyle::Flat }
    }
}

/// The result of [`tube_mesh`]: the mesh and what went into it.
#[derive(Debug, Clone, PartialEq)]
pub struct TubeMesh {
    /// Triangles with face-varying UVs and normals.
    pub mesh: Mesh,
    /// Number of axes that produced geometry.
    pub axes: usize,
    /// Number of side rings (one per kept axis node, including radius-0 points; cap
    /// rings not counted).
    pub rings: usize,
    /// Number of triangles in `mesh`.
    pub triangles: usize,
}

/// Meshes every axis of `skeleton` as one generalized cylinder (see the module docs).
///
/// Errors: [`Error::InvalidGeometry`] when `opts.sides` is outside `3..=1024` or the
/// mesh would need more than `u32` indices; [`Error::Skeleton`] when the skeleton
/// fails [`Skeleton::validate`]. Deterministic; O(nodes × sides).
pub fn tube_mesh(skeleton: &Skeleton, opts: &TubeOptions) -> Result<TubeMesh> {
    if !(MIN_SIDES..=MAX_SIDES).contains(&opts.sides) {
        return Err(Error::InvalidGeometry {
            what: "tube mesher".into(),
            why: format!("sides = {}; it must be in {MIN_SIDES}..={MAX_SIDES}", opts.sides),
        });
    }
    skeleton.validate()?;
    let axes = build_axes(skeleton);
    let sides = opts.sides;
    let round_rings = round_cap_rings(sides);

    // Counting pass: exact sizes of every buffer.
    let mut total = Counts::default();
    for a in 0..axes.count() {
        total.add(&count_axis(axes.axis(a), sides, opts, round_rings));
    }
    let limit = u32::MAX as u64;
    if total.vertices >= limit
        || total.uvs >= limit
        || total.normals >= limit
        || total.triangles.saturating_mul(3) >= limit
    {
        return Err(Error::InvalidGeometry {
            what: "tube mesher".into(),
            why: format!(
                "the tube mesh would have {} vertices and {} triangles, more than u32 \
                 indices allow; use fewer sides or a smaller skeleton",
                total.vertices, total.triangles
            ),
        });
    }

    let mut e = Emitter::with_capacity(&total, sides);
    let mut frames = Vec::new();
    let mut axis_count = 0;
    for a in 0..axes.count() {
        let st = axes.axis(a);
        if !has_faces(st) {
            continue;
        }
        let texel = axis_frames(st, skeleton, &mut frames);
        e.axis(st, &frames, texel, opts, round_rings);
        axis_count += 1;
    }
    debug_assert_eq!(e.positions.len() as u64, total.vertices);
    debug_assert_eq!(e.face_offsets.len() as u64, total.triangles + 1);
    let triangles = e.face_offsets.len() - 1;
    let rings = total.rings as usize;
    let mesh = Mesh {
        positions: e.positions,
        face_offsets: e.face_offsets,
        face_indices: e.face_indices,
        uvs: Some(FaceVarying { values: e.uv_values, indices: e.uv_indices }),
        normals: Some(FaceVarying { values: e.normal_values, indices: e.normal_indices }),
        creases: Vec::new(),
    };
    Ok(TubeMesh { mesh, axes: axis_count, rings, triangles })
}

/// Extra rings of a round tip cap (the apex not counted).
fn round_cap_rings(sides: u32) -> u32 {
    (sides / 4).clamp(1, 8)
}

/// One ring centre along an axis.
#[derive(Debug, Clone, Copy)]
struct Station {
    pos: Vec3,
    radius: f32,
    /// Skeleton node whose `up` this station carries (for a lateral base: the child).
    node: u32,
}

impl Station {
    /// A radius-0 station is a single vertex, not a ring. So is a radius too small for
    /// `f32` to place distinct ring vertices around this position (a twig tapering to
    /// ~1e-6 m at 4 m from the origin): its ring would be a fan of zero-area faces.
    fn is_point(&self) -> bool {
        self.radius <= self.pos.abs().max_element() * (16.0 * f32::EPSILON)
    }
}

/// All axes as stations in compressed rows.
struct Axes {
    stations: Vec<Station>,
    offsets: Vec<u32>,
}

impl Axes {
    fn count(&self) -> usize {
        self.offsets.len() - 1
    }

    fn axis(&self, a: usize) -> &[Station] {
        &self.stations[self.offsets[a] as usize..self.offsets[a + 1] as usize]
    }
}

/// True when `b` is at `a` up to float noise (a zero-length internode).
fn coincident(a: Vec3, b: Vec3) -> bool {
    let d = (a - b).abs().max_element();
    let scale = a.abs().max_element().max(b.abs().max_element());
    d <= 4.0 * f32::EPSILON * scale || d < 1e-30
}

/// The child that continues node `i`'s axis, or [`NO_PARENT`] when `i` has none.
fn continuation(s: &Skeleton, children: &Children, i: usize) -> u32 {
    let kids = children.of(i);
    let order = s.order[i];
    let same_order = kids.iter().any(|&c| s.order[c as usize] == order);
    let incoming = match s.parent[i] {
        NO_PARENT => Vec3::ZERO,
        p => (s.position[i] - s.position[p as usize]).normalize_or_zero(),
    };
    let mut best = NO_PARENT;
    let (mut best_r, mut best_align) = (0.0f32, 0.0f32);
    for &c in kids {
        let cu = c as usize;
        if same_order && s.order[cu] != order {
            continue;
        }
        let r = s.radius[cu];
        let align = incoming.dot((s.position[cu] - s.position[i]).normalize_or_zero());
        if best == NO_PARENT || r > best_r || (r == best_r && align > best_align) {
            best = c;
            best_r = r;
            best_align = align;
        }
    }
    best
}

/// Splits the skeleton into axes of stations (step 1 of the module docs). Axes with
/// fewer than two stations are dropped.
fn build_axes(s: &Skeleton) -> Axes {
    let n = s.len();
    let children = s.children();
    let next: Vec<u32> = (0..n).map(|i| continuation(s, &children, i)).collect();
    let mut stations = Vec::with_capacity(n + n / 2);
    let mut offsets = vec![0u32];
    for i in 0..n {
        let p = s.parent[i];
        if p != NO_PARENT && next[p as usize] == i as u32 {
            continue; // i continues its parent's axis
        }
        let begin = stations.len();
        if p != NO_PARENT {
            // Lateral axis: its first ring is at the branching node, with the internode's
            // explicit start radius, else the smaller of the two radii so the base stays
            // inside the parent tube.
            let pu = p as usize;
            stations.push(Station {
                pos: s.position[pu],
                radius: s.start_radius(i).unwrap_or(s.radius[pu].min(s.radius[i])),
                node: i as u32,
            });
        }
        let mut k = i as u32;
        while k != NO_PARENT {
            let ku = k as usize;
            let pos = s.position[ku];
            let merged = stations.len() > begin
                && stations.last().is_some_and(|last: &Station| coincident(last.pos, pos));
            if !merged {
                stations.push(Station { pos, radius: s.radius[ku], node: k });
            }
            k = next[ku]; // always > k, so this ends
        }
        // A run of point stations at either end would leave all but one of its vertices
        // unused (a cone needs one apex): keep only the point next to the last ring.
        while stations.len() - begin >= 2
            && stations[stations.len() - 1].is_point()
            && stations[stations.len() - 2].is_point()
        {
            stations.pop();
        }
        while stations.len() - begin >= 2 && stations[begin].is_point() && stations[begin + 1].is_point() {
            stations.remove(begin);
        }
        if stations.len() - begin >= 2 {
            offsets.push(stations.len() as u32);
        } else {
            stations.truncate(begin);
        }
    }
    Axes { stations, offsets }
}

/// An axis makes faces unless every ring is a point.
fn has_faces(st: &[Station]) -> bool {
    st.windows(2).any(|w| !w[0].is_point() || !w[1].is_point())
}

/// Buffer sizes (u64 so overflow is detected, not wrapped).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Counts {
    vertices: u64,
    uvs: u64,
    normals: u64,
    triangles: u64,
    rings: u64,
}

impl Counts {
    fn add(&mut self, o: &Counts) {
        self.vertices += o.vertices;
        self.uvs += o.uvs;
        self.normals += o.normals;
        self.triangles += o.triangles;
        self.rings += o.rings;
    }
}

/// Exact buffer sizes [`Emitter::axis`] will write for one axis.
fn count_axis(st: &[Station], sides: u32, opts: &TubeOptions, round_rings: u32) -> Counts {
    let mut c = Counts::default();
    if !has_faces(st) {
        return c;
    }
    let n = sides as u64;
    for s in st {
        if s.is_point() {
            c.vertices += 1;
            c.uvs += n;
            c.normals += 2;
        } else {
            c.vertices += n;
            c.uvs += n + 1;
            c.normals += n;
        }
        c.rings += 1;
    }
    for w in st.windows(2) {
        c.triangles += match (w[0].is_point(), w[1].is_point()) {
            (false, false) => 2 * n,
            (true, true) => 0,
            _ => n,
        };
    }
    let flat_cap = Counts { vertices: 1, uvs: n + 1, normals: 1, triangles: n, rings: 0 };
    if opts.bases == BaseStyle::Flat && !st[0].is_point() {
        c.add(&flat_cap);
    }
    if !st[st.len() - 1].is_point() {
        match opts.tips {
            TipStyle::Flat => c.add(&flat_cap),
            TipStyle::Round => {
                let r = round_rings as u64;
                c.add(&Counts {
                    vertices: r * n + 1,
                    uvs: r * (n + 1) + n,
                    normals: r * n + 1,
                    triangles: 2 * n * r + n,
                    rings: 0,
                });
            }
            TipStyle::Open => {}
        }
    }
    c
}

/// Per-station frame and ring data of one axis.
#[derive(Debug, Clone, Copy, Default)]
struct Frame {
    /// Direction of the segment to the next station (the last repeats the one before).
    dir: Vec3,
    /// Ring tangent.
    t: Vec3,
    /// Rotation-minimizing normal: the u = 0 direction.
    n: Vec3,
    /// `t × n`, the u = 1/4 direction.
    b: Vec3,
    /// Ring offset multiplied by cos(angle): `radius · n`, stretched by the mitre.
    p: Vec3,
    /// Ring offset multiplied by sin(angle): `radius · b`, stretched by the mitre.
    q: Vec3,
    /// Texture v (arc length / base circumference).
    v: f32,
    /// dr/ds, for tilting the side normals.
    dr: f32,
}

/// Fills `out` with one [`Frame`] per station (steps 2 and 3 of the module docs) and
/// returns the texture scale: metres per unit of u or v (the base circumference).
fn axis_frames(st: &[Station], skel: &Skeleton, out: &mut Vec<Frame>) -> f32 {
    out.clear();
    let s = st.len();
    // Pass 1: segment directions and arc lengths.
    let mut arc = 0.0f32;
    let mut prev_dir = Vec3::Y;
    for k in 0..s {
        let mut dir = prev_dir;
        if k + 1 < s {
            let d = (st[k + 1].pos - st[k].pos).normalize_or_zero();
            if d != Vec3::ZERO {
                dir = d;
            }
        }
        out.push(Frame { dir, v: arc, ..Frame::default() });
        if k + 1 < s {
            let len = st[k + 1].pos.distance(st[k].pos);
            if len.is_finite() {
                arc += len;
            }
        }
        prev_dir = dir;
    }
    let base_r = st[0].radius;
    let ref_r = if base_r > 0.0 { base_r } else { st.iter().fold(0.0f32, |m, x| m.max(x.radius)) };
    let texel = if ref_r > 0.0 && (TAU * ref_r).is_normal() { TAU * ref_r } else { 1.0 };

    // Pass 2: tangents, rotation-minimizing frames, ring offsets, taper.
    let (mut t_prev, mut n_prev) = (Vec3::ZERO, Vec3::ZERO);
    for k in 0..s {
        let d_out = out[k].dir;
        let d_in = if k > 0 { out[k - 1].dir } else { d_out };
        let interior = k > 0 && k + 1 < s;
        let t = if interior {
            let sum = d_in + d_out;
            if sum.length_squared() > 1e-8 {
                sum.normalize()
            } else {
                d_in // a U-turn: the directions cancel
            }
        } else if k == 0 {
            d_out
        } else {
            d_in
        };
        let n = if k == 0 {
            let up = skel.up[st[1.min(s - 1)].node as usize];
            let n0 = (up - t * t.dot(up)).normalize_or_zero();
            if n0 == Vec3::ZERO {
                t.any_orthonormal_vector()
            } else {
                n0
            }
        } else {
            // Double reflection (Wang, Jüttler, Zheng & Liu 2008, Eq. 4 and Table 1),
            // with the unit segment direction so tiny segments cannot overflow.
            let v1 = d_in;
            let r_l = n_prev - 2.0 * v1.dot(n_prev) * v1;
            let t_l = t_prev - 2.0 * v1.dot(t_prev) * v1;
            let v2 = t - t_l;
            let c2 = v2.length_squared();
            let r = if c2 > 1e-12 { r_l - (2.0 / c2) * v2.dot(r_l) * v2 } else { r_l };
            // Re-orthonormalize against float drift.
            let r = (r - t * t.dot(r)).normalize_or_zero();
            if r == Vec3::ZERO {
                t.any_orthonormal_vector()
            } else {
                r
            }
        };
        let b = t.cross(n);
        let radius = st[k].radius;
        let (mut p, mut q) = (n * radius, b * radius);
        if interior {
            // Mitre: stretch the ring along the bend by 1 / cos(θ/2) (clamped at
            // θ = 120°) so the elbow keeps the tube's thickness.
            let c = t.dot(d_in);
            if c < 0.99999 {
                let kv = d_out - d_in;
                let kv = (kv - t * t.dot(kv)).normalize_or_zero();
                let f = 1.0 / c.max(0.5) - 1.0;
                p += kv * (f * kv.dot(p));
                q += kv * (f * kv.dot(q));
            }
        }
        let (a, c) = (k.saturating_sub(1), (k + 1).min(s - 1));
        let ds = out[c].v - out[a].v;
        let dr = if ds > 0.0 { (st[c].radius - st[a].radius) / ds } else { 0.0 };
        let f = &mut out[k];
        f.t = t;
        f.n = n;
        f.b = b;
        f.p = p;
        f.q = q;
        f.dr = if dr.is_finite() { dr.clamp(-100.0, 100.0) } else { 0.0 };
        t_prev = t;
        n_prev = n;
    }
    for f in out.iter_mut() {
        f.v /= texel;
    }
    texel
}

/// Where a ring's data starts in the output buffers.
#[derive(Debug, Clone, Copy)]
struct RingRef {
    /// First vertex (the only one for a point).
    v: u32,
    /// First UV value.
    uv: u32,
    /// First normal value; for a point, its normal facing forward (+t).
    n: u32,
    /// For a point, its normal facing backward (−t); else equal to `n`.
    n_back: u32,
    /// A single vertex instead of a ring.
    point: bool,
}

/// Output buffers plus the per-side tables computed once.
struct Emitter {
    sides: u32,
    /// (cos, sin) of each side angle, `sides` entries.
    cs: Vec<Vec2>,
    /// u of each seam-duplicated column, `sides + 1` entries (exactly 0 and 1 at the ends).
    u: Vec<f32>,
    /// u half-way between columns, for point and apex corners.
    u_mid: Vec<f32>,
    positions: Vec<Vec3>,
    face_offsets: Vec<u32>,
    face_indices: Vec<u32>,
    uv_values: Vec<Vec2>,
    uv_indices: Vec<u32>,
    normal_values: Vec<Vec3>,
    normal_indices: Vec<u32>,
}

impl Emitter {
    fn with_capacity(c: &Counts, sides: u32) -> Self {
        let n = sides as usize;
        let corners = c.triangles as usize * 3;
        let mut face_offsets = Vec::with_capacity(c.triangles as usize + 1);
        face_offsets.push(0);
        Emitter {
            sides,
            cs: (0..n)
                .map(|j| {
                    let (s, c) = (TAU * j as f32 / n as f32).sin_cos();
                    Vec2::new(c, s)
                })
                .collect(),
            u: (0..=n).map(|j| j as f32 / n as f32).collect(),
            u_mid: (0..n).map(|j| (j as f32 + 0.5) / n as f32).collect(),
            positions: Vec::with_capacity(c.vertices as usize),
            face_offsets,
            face_indices: Vec::with_capacity(corners),
            uv_values: Vec::with_capacity(c.uvs as usize),
            uv_indices: Vec::with_capacity(corners),
            normal_values: Vec::with_capacity(c.normals as usize),
            normal_indices: Vec::with_capacity(corners),
        }
    }

    #[inline]
    fn tri(&mut self, v: [u32; 3], uv: [u32; 3], n: [u32; 3]) {
        self.face_indices.extend_from_slice(&v);
        self.uv_indices.extend_from_slice(&uv);
        self.normal_indices.extend_from_slice(&n);
        self.face_offsets.push(self.face_indices.len() as u32);
    }

    fn mark(&self, point: bool) -> RingRef {
        let n = self.normal_values.len() as u32;
        RingRef { v: self.positions.len() as u32, uv: self.uv_values.len() as u32, n, n_back: n, point }
    }

    /// A ring of `sides` vertices `centre + cos·p + sin·q` with normals
    /// `cos·nn + sin·nb + nt` and UVs `(j / sides, v)` over `sides + 1` columns.
    #[allow(clippy::too_many_arguments)]
    fn ring(&mut self, centre: Vec3, p: Vec3, q: Vec3, nn: Vec3, nb: Vec3, nt: Vec3, v: f32) -> RingRef {
        let r = self.mark(false);
        for cs in &self.cs {
            self.positions.push(centre + p * cs.x + q * cs.y);
            self.normal_values.push(nn * cs.x + nb * cs.y + nt);
        }
        self.uv_values.extend(self.u.iter().map(|&u| Vec2::new(u, v)));
        r
    }

    /// A radius-0 station: one vertex, UVs per column, normals −t and +t.
    fn point(&mut self, centre: Vec3, t: Vec3, v: f32) -> RingRef {
        let mut r = self.mark(true);
        self.positions.push(centre);
        self.uv_values.extend(self.u_mid.iter().map(|&u| Vec2::new(u, v)));
        self.normal_values.push(-t);
        self.normal_values.push(t);
        r.n += 1;
        r
    }

    /// Triangles between two consecutive rings (either may be a point).
    fn band(&mut self, a: RingRef, b: RingRef) {
        let n = self.sides;
        match (a.point, b.point) {
            (false, false) => {
                for j in 0..n {
                    let jn = if j + 1 == n { 0 } else { j + 1 };
                    let (a0, a1, b0, b1) = (a.v + j, a.v + jn, b.v + j, b.v + jn);
                    let (ua0, ua1, ub0, ub1) = (a.uv + j, a.uv + j + 1, b.uv + j, b.uv + j + 1);
                    let (na0, na1, nb0, nb1) = (a.n + j, a.n + jn, b.n + j, b.n + jn);
                    self.tri([a0, a1, b1], [ua0, ua1, ub1], [na0, na1, nb1]);
                    self.tri([a0, b1, b0], [ua0, ub1, ub0], [na0, nb1, nb0]);
                }
            }
            (false, true) => {
                for j in 0..n {
                    let jn = if j + 1 == n { 0 } else { j + 1 };
                    self.tri(
                        [a.v + j, a.v + jn, b.v],
                        [a.uv + j, a.uv + j + 1, b.uv + j],
                        [a.n + j, a.n + jn, b.n],
                    );
                }
            }
            (true, false) => {
                for j in 0..n {
                    let jn = if j + 1 == n { 0 } else { j + 1 };
                    self.tri(
                        [a.v, b.v + jn, b.v + j],
                        [a.uv + j, b.uv + j + 1, b.uv + j],
                        [a.n_back, b.n + jn, b.n + j],
                    );
                }
            }
            (true, true) => {}
        }
    }

    /// A flat fan over ring `r` to a new centre vertex; `tip` faces +t, else −t.
    /// UVs: the disk mapped at the side's texel scale around (0.5, v).
    fn flat_cap(&mut self, r: RingRef, centre: Vec3, f: &Frame, radius: f32, texel: f32, tip: bool) {
        let c = self.positions.len() as u32;
        self.positions.push(centre);
        let ni = self.normal_values.len() as u32;
        self.normal_values.push(if tip { f.t } else { -f.t });
        let uv0 = self.uv_values.len() as u32;
        self.uv_values.push(Vec2::new(0.5, f.v));
        let s = radius / texel;
        for k in 0..self.cs.len() {
            let cs = self.cs[k];
            self.uv_values.push(Vec2::new(0.5 + cs.x * s, f.v + cs.y * s));
        }
        let n = self.sides;
        for j in 0..n {
            let jn = if j + 1 == n { 0 } else { j + 1 };
            if tip {
                self.tri([c, r.v + j, r.v + jn], [uv0, uv0 + 1 + j, uv0 + 1 + jn], [ni; 3]);
            } else {
                self.tri([c, r.v + jn, r.v + j], [uv0, uv0 + 1 + jn, uv0 + 1 + j], [ni; 3]);
            }
        }
    }

    /// A hemisphere of the tip radius over the last ring `r`, ending in an apex.
    fn round_cap(&mut self, r: RingRef, centre: Vec3, f: &Frame, radius: f32, texel: f32, rings: u32) {
        let mut prev = r;
        for m in 1..=rings {
            let phi = FRAC_PI_2 * m as f32 / (rings + 1) as f32;
            let (s, c) = phi.sin_cos();
            let rc = radius * c;
            let ring = self.ring(
                centre + f.t * (radius * s),
                f.n * rc,
                f.b * rc,
                f.n * c,
                f.b * c,
                f.t * s,
                f.v + radius * phi / texel,
            );
            self.band(prev, ring);
            prev = ring;
        }
        let apex = self.mark(true);
        self.positions.push(centre + f.t * radius);
        self.normal_values.push(f.t);
        let v = f.v + radius * FRAC_PI_2 / texel;
        self.uv_values.extend(self.u_mid.iter().map(|&u| Vec2::new(u, v)));
        self.band(prev, apex);
    }

    /// Everything of one axis: rings, bands and caps.
    fn axis(&mut self, st: &[Station], frames: &[Frame], texel: f32, opts: &TubeOptions, rings: u32) {
        let mut prev: Option<RingRef> = None;
        for (k, (s, f)) in st.iter().zip(frames).enumerate() {
            let r = if s.is_point() {
                self.point(s.pos, f.t, f.v)
            } else {
                // Side normal ∝ radial − (dr/ds)·t: tilted towards the tip on a taper.
                let inv = 1.0 / (1.0 + f.dr * f.dr).sqrt();
                self.ring(s.pos, f.p, f.q, f.n * inv, f.b * inv, f.t * (-f.dr * inv), f.v)
            };
            if k == 0 && !s.is_point() && opts.bases == BaseStyle::Flat {
                self.flat_cap(r, s.pos, f, s.radius, texel, false);
            }
            if let Some(p) = prev {
                self.band(p, r);
            }
            prev = Some(r);
        }
        let (Some(r), Some(s), Some(f)) = (prev, st.last(), frames.last()) else {
            return;
        };
        if s.is_point() {
            return;
        }
        match opts.tips {
            TipStyle::Flat => self.flat_cap(r, s.pos, f, s.radius, texel, true),
            TipStyle::Round => self.round_cap(r, s.pos, f, s.radius, texel, rings),
            TipStyle::Open => {}
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::collections::HashMap;

    /// A chain of nodes with the given positions and radii, `up` per node.
    fn chain(points: &[Vec3], radii: &[f32], up: &[Vec3]) -> Skeleton {
        let mut s = Skeleton::new();
        let mut parent = NO_PARENT;
        for (i, &p) in points.iter().enumerate() {
            parent = s.push(p, radii[i.min(radii.len() - 1)], parent, up[i.min(up.len() - 1)], 0);
        }
        s
    }

    fn straight() -> Skeleton {
        chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0)], &[0.2, 0.15, 0.1], &[Vec3::X])
    }

    fn y_fork() -> Skeleton {
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let a = s.push(Vec3::Y, 0.1, r, Vec3::X, 0);
        s.push(Vec3::new(0.0, 2.0, 0.0), 0.05, a, Vec3::X, 0);
        s.push(Vec3::new(1.0, 2.0, 0.0), 0.05, a, Vec3::Z, 1);
        s
    }

    /// Every directed edge appears exactly once and its reverse exactly once: a closed,
    /// consistently oriented 2-manifold (per connected piece).
    fn assert_closed(m: &Mesh) {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for f in 0..m.face_count() {
            let face = m.face(f);
            for k in 0..face.len() {
                *edges.entry((face[k], face[(k + 1) % face.len()])).or_default() += 1;
            }
        }
        for (&(a, b), &count) in &edges {
            assert_eq!(count, 1, "directed edge {a}->{b} used {count} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
        }
    }

    fn assert_sane(m: &Mesh) {
        m.validate().unwrap();
        for f in 0..m.face_count() {
            assert_eq!(m.face(f).len(), 3);
        }
    }

    /// Signed volume by the divergence theorem (positive when faces point outward).
    fn volume(m: &Mesh) -> f32 {
        (0..m.face_count())
            .map(|f| {
                let v = m.face(f);
                let [a, b, c] = [0, 1, 2].map(|k| m.positions[v[k] as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    fn face_normal(m: &Mesh, f: usize) -> Vec3 {
        let v = m.face(f);
        let [a, b, c] = [0, 1, 2].map(|k| m.positions[v[k] as usize]);
        (b - a).cross(c - a)
    }

    /// Every corner normal is unit and on the outer side of its (non-degenerate) face.
    fn assert_normals_outward(m: &Mesh) {
        let n = m.normals.as_ref().unwrap();
        for f in 0..m.face_count() {
            let fnrm = face_normal(m, f);
            if fnrm.length() < 1e-9 {
                continue;
            }
            for c in m.corners(f) {
                let cn = n.values[n.indices[c] as usize];
                assert!((cn.length() - 1.0).abs() < 1e-4, "normal {cn} not unit");
                assert!(cn.dot(fnrm.normalize()) > 0.0, "face {f} corner normal {cn} vs {fnrm}");
            }
        }
    }

    fn mesh(s: &Skeleton, opts: &TubeOptions) -> TubeMesh {
        let t = tube_mesh(s, opts).unwrap();
        assert_sane(&t.mesh);
        assert_eq!(t.triangles, t.mesh.triangle_count());
        // The counting pass predicted every buffer exactly.
        let axes = build_axes(s);
        let mut c = Counts::default();
        for a in 0..axes.count() {
            c.add(&count_axis(axes.axis(a), opts.sides, opts, round_cap_rings(opts.sides)));
        }
        assert_eq!(c.vertices as usize, t.mesh.positions.len());
        assert_eq!(c.triangles as usize, t.triangles);
        assert_eq!(c.uvs as usize, t.mesh.uvs.as_ref().unwrap().values.len());
        assert_eq!(c.normals as usize, t.mesh.normals.as_ref().unwrap().values.len());
        t
    }

    #[test]
    fn straight_chain_is_one_closed_axis() {
        for tips in [TipStyle::Round, TipStyle::Flat] {
            let opts = TubeOptions { tips, ..Default::default() };
            let t = mesh(&straight(), &opts);
            assert_eq!(t.axes, 1);
            assert_eq!(t.rings, 3);
            assert_closed(&t.mesh);
            assert_normals_outward(&t.mesh);
            let vol = volume(&t.mesh);
            // Octagonal frustums are a bit smaller than the round ones.
            assert!(vol > 0.08 && vol < 0.16, "volume {vol}");
        }
        let t = mesh(&straight(), &TubeOptions { tips: TipStyle::Flat, ..Default::default() });
        // 3 rings × 8 + 2 cap centres; 2 bands × 16 + 2 fans × 8.
        assert_eq!(t.mesh.positions.len(), 26);
        assert_eq!(t.triangles, 48);
    }

    #[test]
    fn side_normals_point_away_from_the_axis() {
        let t = mesh(&straight(), &TubeOptions::default());
        let m = &t.mesh;
        let n = m.normals.as_ref().unwrap();
        for f in 0..m.face_count() {
            if face_normal(m, f).normalize().y.abs() > 0.999 {
                continue; // a flat base cap: its normal is the axis
            }
            for c in m.corners(f) {
                let p = m.positions[m.face_indices[c] as usize];
                let radial = Vec3::new(p.x, 0.0, p.z);
                if radial.length() > 1e-3 {
                    assert!(n.values[n.indices[c] as usize].dot(radial) > 0.0);
                }
            }
        }
    }

    #[test]
    fn uv_v_follows_arc_length_and_the_seam_is_exact() {
        let opts = TubeOptions { tips: TipStyle::Flat, ..Default::default() };
        let t = mesh(&straight(), &opts);
        let m = &t.mesh;
        let uv = m.uvs.as_ref().unwrap();
        let circumference = TAU * 0.2;
        let mut seen_seam = false;
        let mut at_zero = std::collections::HashSet::new();
        let mut at_one = Vec::new();
        for f in 0..m.face_count() {
            if face_normal(m, f).normalize().y.abs() > 0.5 {
                continue; // a flat cap
            }
            let us: Vec<f32> = m.corners(f).map(|c| uv.values[uv.indices[c] as usize].x).collect();
            let spread =
                us.iter().cloned().fold(f32::MIN, f32::max) - us.iter().cloned().fold(f32::MAX, f32::min);
            assert!(spread <= 1.0 / 8.0 + 1e-6, "face {f} wraps around the seam: {us:?}");
            for c in m.corners(f) {
                let p = m.positions[m.face_indices[c] as usize];
                let q = uv.values[uv.indices[c] as usize];
                assert!((q.y - p.y / circumference).abs() < 1e-5, "v {} at y {}", q.y, p.y);
                if q.x == 1.0 {
                    seen_seam = true;
                    at_one.push(m.face_indices[c]);
                }
                if q.x == 0.0 {
                    at_zero.insert(m.face_indices[c]);
                }
            }
        }
        assert!(seen_seam);
        // u = 1 corners sit on the very vertices of the u = 0 column: a UV seam only.
        assert!(at_one.iter().all(|v| at_zero.contains(v)));
    }

    #[test]
    fn y_fork_gives_two_closed_axes() {
        let s = y_fork();
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!(t.axes, 2);
        assert_closed(&t.mesh);
        assert_normals_outward(&t.mesh);
        assert!(volume(&t.mesh) > 0.0);
        // The lateral axis starts at the branching node, inside the trunk.
        let axes = build_axes(&s);
        assert_eq!(axes.count(), 2);
        assert_eq!(axes.axis(0).len(), 3);
        assert_eq!(axes.axis(1)[0].pos, Vec3::Y);
        assert_eq!(axes.axis(1)[0].radius, 0.05);
        // An explicit start radius (issue 26, an LST cylinder's r0) starts the lateral.
        let mut s = s;
        s.set_start_radius(3, Some(0.08));
        assert_eq!(build_axes(&s).axis(1)[0].radius, 0.08);
        assert_closed(&mesh(&s, &TubeOptions::default()).mesh);
    }

    #[test]
    fn axis_prefers_same_order_then_radius_then_alignment() {
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let a = s.push(Vec3::Y, 0.1, r, Vec3::X, 0);
        let thick_lateral = s.push(Vec3::new(1.0, 1.0, 0.0), 0.09, a, Vec3::X, 1);
        let bent = s.push(Vec3::new(0.5, 2.0, 0.0), 0.05, a, Vec3::X, 0);
        let straight_on = s.push(Vec3::new(0.0, 2.0, 0.0), 0.05, a, Vec3::X, 0);
        let c = s.children();
        assert_eq!(continuation(&s, &c, a as usize), straight_on);
        s.radius[bent as usize] = 0.06;
        assert_eq!(continuation(&s, &c, a as usize), bent);
        s.order[bent as usize] = 1;
        s.order[straight_on as usize] = 1;
        // None has order 0 now: the thickest child wins.
        assert_eq!(continuation(&s, &c, a as usize), thick_lateral);
    }

    #[test]
    fn bends_and_u_turns_stay_finite() {
        let bend = chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)], &[0.1], &[Vec3::Z]);
        let uturn =
            chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0), Vec3::Y, Vec3::ZERO], &[0.1], &[Vec3::X]);
        let hairpin = chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.3, 0.0, 0.0)], &[0.1], &[Vec3::Z]);
        for s in [bend, uturn, hairpin] {
            for tips in [TipStyle::Round, TipStyle::Flat, TipStyle::Open] {
                let t = mesh(&s, &TubeOptions { tips, ..Default::default() });
                assert!(t.mesh.positions.iter().all(|p| p.is_finite()));
                if tips != TipStyle::Open {
                    assert_closed(&t.mesh);
                }
            }
        }
        // The mitred elbow keeps the tube's thickness: the inner and outer ring points
        // of the 90° bend lie on the bisector plane at r / cos 45°.
        let s = chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)], &[0.1], &[Vec3::Z]);
        let t = mesh(&s, &TubeOptions { tips: TipStyle::Open, bases: BaseStyle::Open, sides: 4 });
        let far = t.mesh.positions[4..8].iter().map(|p| p.distance(Vec3::Y)).fold(0.0, f32::max);
        assert!((far - 0.1 * 2f32.sqrt()).abs() < 1e-5, "elbow radius {far}");
    }

    /// Direction of vertex 0 of ring `k` from its centre, for open tubes (rings are
    /// consecutive blocks of `sides` vertices).
    fn first_vertex_dir(m: &Mesh, sides: usize, k: usize, centre: Vec3) -> Vec3 {
        (m.positions[k * sides] - centre).normalize()
    }

    #[test]
    fn frames_do_not_twist() {
        let open = TubeOptions { sides: 6, tips: TipStyle::Open, bases: BaseStyle::Open };
        // A straight line with a different `up` at every node: RMF ignores all but the
        // first, so the seam stays put.
        let pts: Vec<Vec3> = (0..6).map(|i| Vec3::new(0.0, i as f32, 0.0)).collect();
        let ups = [Vec3::X, Vec3::X, Vec3::Z, -Vec3::X, Vec3::new(1.0, 0.0, 1.0), -Vec3::Z];
        let s = chain(&pts, &[0.1], &ups);
        let t = mesh(&s, &open);
        let d0 = first_vertex_dir(&t.mesh, 6, 0, pts[0]);
        assert!((d0 - Vec3::X).length() < 1e-5);
        for (k, &p) in pts.iter().enumerate() {
            assert!(first_vertex_dir(&t.mesh, 6, k, p).dot(d0) > 0.9999);
        }
        // A planar arc with `up` normal to its plane: the RMF normal stays that normal.
        let pts: Vec<Vec3> = (0..24)
            .map(|i| {
                let a = i as f32 * 0.25;
                Vec3::new(a.cos(), a.sin(), 0.0) * 2.0
            })
            .collect();
        let s = chain(&pts, &[0.1], &[Vec3::Z]);
        let t = mesh(&s, &open);
        for (k, &p) in pts.iter().enumerate() {
            let d = first_vertex_dir(&t.mesh, 6, k, p);
            assert!(d.dot(Vec3::Z) > 0.9999, "ring {k} twisted: {d}");
        }
        // A helix: successive first-vertex directions rotate only by the curve's turn.
        let pts: Vec<Vec3> = (0..40)
            .map(|i| {
                let a = i as f32 * 0.2;
                Vec3::new(a.cos(), i as f32 * 0.05, a.sin())
            })
            .collect();
        let s = chain(&pts, &[0.05], &[Vec3::Y]);
        let t = mesh(&s, &open);
        for k in 1..pts.len() {
            let a = first_vertex_dir(&t.mesh, 6, k - 1, pts[k - 1]);
            let b = first_vertex_dir(&t.mesh, 6, k, pts[k]);
            assert!(a.dot(b) > 0.97, "ring {k} turned by {}", a.dot(b).acos());
        }
    }

    #[test]
    fn side_counts_3_and_64_work() {
        for sides in [3, 64] {
            let opts = TubeOptions { sides, ..Default::default() };
            let t = mesh(&y_fork(), &opts);
            assert_closed(&t.mesh);
            assert_normals_outward(&t.mesh);
            assert!(volume(&t.mesh) > 0.0);
        }
    }

    #[test]
    fn zero_length_internodes_are_merged() {
        let s = chain(
            &[Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 2.0, 0.0)],
            &[0.1],
            &[Vec3::X],
        );
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!(t.rings, 3);
        assert_closed(&t.mesh);
        // A skeleton that is all one point makes nothing, without NaN.
        let s = chain(&[Vec3::ONE, Vec3::ONE, Vec3::ONE], &[0.1], &[Vec3::X]);
        let t = tube_mesh(&s, &TubeOptions::default()).unwrap();
        assert_eq!(t.axes, 0);
        assert_eq!(t.triangles, 0);
        t.mesh.validate().unwrap();
    }

    #[test]
    fn zero_radius_ends_collapse_to_points() {
        let s = chain(
            &[Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 3.0, 0.0)],
            &[0.0, 0.1, 0.0, 0.1],
            &[Vec3::X],
        );
        for sides in [3, 8] {
            let t = mesh(&s, &TubeOptions { sides, ..Default::default() });
            assert_closed(&t.mesh);
            assert_normals_outward(&t.mesh);
            assert!(volume(&t.mesh) > 0.0);
        }
        // All radii zero: nothing to draw.
        let s = chain(&[Vec3::ZERO, Vec3::Y], &[0.0], &[Vec3::X]);
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!((t.axes, t.triangles), (0, 0));
    }

    #[test]
    fn runs_of_point_stations_leave_no_unused_vertex() {
        // Radii taper below f32 resolution over the last two nodes (and start at 0).
        let s = chain(
            &[
                Vec3::ZERO,
                Vec3::Y,
                Vec3::new(0.0, 2.0, 0.0),
                Vec3::new(0.0, 3.0, 0.0),
                Vec3::new(0.0, 4.0, 0.0),
            ],
            &[0.0, 0.1, 1e-9, 0.0],
            &[Vec3::X],
        );
        let t = mesh(&s, &TubeOptions::default());
        let r = crate::mesh::check::check_mesh(&t.mesh, &Default::default());
        assert!(r.is_closed_manifold(), "{r}");
    }

    #[test]
    fn degenerate_up_falls_back() {
        // `up` along the internode and zero `up`.
        for up in [Vec3::Y, Vec3::ZERO] {
            let s = chain(&[Vec3::ZERO, Vec3::Y], &[0.1], &[up]);
            let t = mesh(&s, &TubeOptions::default());
            assert_closed(&t.mesh);
        }
    }

    #[test]
    fn bad_input_is_rejected() {
        for sides in [0, 2, 1025] {
            let e = tube_mesh(&straight(), &TubeOptions { sides, ..Default::default() });
            assert!(matches!(e, Err(Error::InvalidGeometry { .. })), "sides {sides}");
        }
        let mut s = straight();
        s.radius[1] = f32::NAN;
        assert!(matches!(tube_mesh(&s, &TubeOptions::default()), Err(Error::Skeleton(_))));
        let mut s = straight();
        s.order.pop();
        assert!(matches!(tube_mesh(&s, &TubeOptions::default()), Err(Error::Skeleton(_))));
    }

    #[test]
    fn empty_skeleton_gives_an_empty_mesh() {
        let t = mesh(&Skeleton::new(), &TubeOptions::default());
        assert_eq!((t.axes, t.rings, t.triangles), (0, 0, 0));
    }

    #[test]
    fn output_is_deterministic() {
        let a = tube_mesh(&y_fork(), &TubeOptions::default()).unwrap();
        let b = tube_mesh(&y_fork(), &TubeOptions::default()).unwrap();
        assert_eq!(a, b);
    }

    /// A binary tree of `depth` levels with `segs` internodes per branch.
    pub(crate) fn binary_tree(depth: u32, segs: u32) -> Skeleton {
        let mut s = Skeleton::new();
        let root = s.push(Vec3::ZERO, 0.3, NO_PARENT, Vec3::X, 0);
        let mut stack = vec![(root, Vec3::Y, 1.0f32, 0.3f32, 0u16, 0u32)];
        while let Some((node, dir, len, r, order, level)) = stack.pop() {
            let mut at = node;
            let mut p = s.position[node as usize];
            for k in 0..segs {
                p += dir * (len / segs as f32);
                let rr = r * (1.0 - 0.3 * (k + 1) as f32 / segs as f32);
                at = s.push(p, rr, at, dir.any_orthonormal_vector(), order);
            }
            if level + 1 < depth {
                let side = dir.any_orthonormal_vector();
                let a = (dir + side * 0.6).normalize();
                let b = (dir - side * 0.5 + dir.cross(side) * 0.4).normalize();
                stack.push((at, a, len * 0.8, r * 0.7, order, level + 1));
                stack.push((at, b, len * 0.7, r * 0.6, order + 1, level + 1));
            }
        }
        s
    }

    #[test]
    fn binary_tree_is_closed() {
        let s = binary_tree(6, 3);
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!(t.axes, 32);
        assert_closed(&t.mesh);
        assert_normals_outward(&t.mesh);
    }

    /// Throughput check: `cargo test --release -p sylva tube::tests::throughput -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn throughput() {
        let s = binary_tree(14, 4);
        let opts = TubeOptions::default();
        let _ = tube_mesh(&s, &opts).unwrap();
        let t0 = std::time::Instant::now();
        let runs = 5;
        let mut tris = 0;
        for _ in 0..runs {
            tris = tube_mesh(&s, &opts).unwrap().triangles;
        }
        let dt = t0.elapsed().as_secs_f64() / runs as f64;
        println!(
            "{} nodes, {tris} triangles, {:.1} ms, {:.1} M tri/s",
            s.len(),
            dt * 1e3,
            tris as f64 / dt / 1e6
        );
    }
}
