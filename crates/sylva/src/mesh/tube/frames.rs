//! Steps 2 and 3 of the tube mesher: per-station tangents, rotation-minimizing frames by
//! double reflection (Wang2008), mitred ring offsets, taper and texture v.

use super::axes::Station;
use crate::skeleton::Skeleton;
use glam::Vec3;
use std::f32::consts::TAU;

/// Per-station frame and ring data of one axis.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Frame {
    /// Direction of the segment to the next station (the last repeats the one before).
    pub(super) dir: Vec3,
    /// Ring tangent.
    pub(super) t: Vec3,
    /// Rotation-minimizing normal: the u = 0 direction.
    pub(super) n: Vec3,
    /// `t × n`, the u = 1/4 direction.
    pub(super) b: Vec3,
    /// Ring offset multiplied by cos(angle): `radius · n`, stretched by the mitre.
    pub(super) p: Vec3,
    /// Ring offset multiplied by sin(angle): `radius · b`, stretched by the mitre.
    pub(super) q: Vec3,
    /// Texture v (arc length / base circumference).
    pub(super) v: f32,
    /// dr/ds, for tilting the side normals.
    pub(super) dr: f32,
}

/// Fills `out` with one [`Frame`] per station (steps 2 and 3 of the module docs) and
/// returns the texture scale: metres per unit of u or v (the base circumference).
pub(super) fn axis_frames(st: &[Station], skel: &Skeleton, out: &mut Vec<Frame>) -> f32 {
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
