//! Step 4 of the tube mesher: the exact counting pass that reserves every buffer, and the
//! emitter that writes rings, bands between them, and flat or round caps.

use super::axes::{has_faces, Station};
use super::frames::Frame;
use super::{BaseStyle, TipStyle, TubeOptions};
use crate::geometry::{FaceVarying, Mesh};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, TAU};

/// Buffer sizes (u64 so overflow is detected, not wrapped).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct Counts {
    pub(super) vertices: u64,
    pub(super) uvs: u64,
    pub(super) normals: u64,
    pub(super) triangles: u64,
    pub(super) rings: u64,
}

impl Counts {
    pub(super) fn add(&mut self, o: &Counts) {
        self.vertices += o.vertices;
        self.uvs += o.uvs;
        self.normals += o.normals;
        self.triangles += o.triangles;
        self.rings += o.rings;
    }
}

/// Exact buffer sizes [`Emitter::axis`] will write for one axis.
pub(super) fn count_axis(st: &[Station], sides: u32, opts: &TubeOptions, round_rings: u32) -> Counts {
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
pub(super) struct Emitter {
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
    pub(super) fn with_capacity(c: &Counts, sides: u32) -> Self {
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

    /// The mesh written so far: triangles with face-varying UVs and normals.
    pub(super) fn finish(self) -> Mesh {
        Mesh {
            positions: self.positions,
            face_offsets: self.face_offsets,
            face_indices: self.face_indices,
            uvs: Some(FaceVarying { values: self.uv_values, indices: self.uv_indices }),
            normals: Some(FaceVarying { values: self.normal_values, indices: self.normal_indices }),
            creases: Vec::new(),
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
    pub(super) fn axis(
        &mut self,
        st: &[Station],
        frames: &[Frame],
        texel: f32,
        opts: &TubeOptions,
        rings: u32,
    ) {
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
