//! Loop subdivision of triangle meshes (Pieterse2012 §4.4.2 / Pieterse2012-spec §2.8; MacMurchy2004 §3.3 /
//! MacMurchy2004-spec §2.10).
//!
//! One step splits every triangle into three corner triangles and a centre triangle:
//! `F' = 4F`, `V' = V + E`, `E' = 2E + 3F`. Child vertices are the vertex points (`v`,
//! so control vertices keep their indices) followed by the edge points (`V + e`). Parent
//! triangle `f = (v₀, v₁, v₂)` with edge points `m₀ m₁ m₂` (edge `j` runs `vⱼ → vⱼ₊₁`)
//! becomes `4f: (v₀, m₀, m₂)`, `4f+1: (m₀, v₁, m₁)`, `4f+2: (m₂, m₁, v₂)`,
//! `4f+3: (m₀, m₁, m₂)`.
//!
//! Masks (Pieterse2012-spec §2.8, MacMurchy2004-spec §2.10):
//! - odd, interior edge `(a, b)` with opposite vertices `c, d`: `3/8 (a + b) + 1/8 (c + d)`;
//!   boundary or sharp edge: `(a + b)/2`;
//! - even, valence n: `(1 − nβ) v + β Σ qᵢ` with
//!   `β(n) = (1/n)(5/8 − (3/8 + ¼ cos(2π/n))²)` — Pieterse2012 prints `sin`; the erratum in
//!   Pieterse2012-spec §2.8 restores `cos`, giving β(3) = 3/16, β(4) = 31/256, β(6) = 1/16;
//! - crease and boundary vertices: `1/8, 3/4, 1/8` ([`super::crease`]).

use super::crease::Rules;
use super::topology::{Detail, Topology, NONE};
use super::{assume_init_mut, fill, fill_chunks, try_zeroed, Primvar, RefineError};
use std::mem::MaybeUninit;

/// Loop's vertex weight β(n) for valence `n` (Pieterse2012-spec §2.8 with the cos erratum):
/// `β(n) = (1/n)(5/8 − (3/8 + ¼ cos(2π/n))²)`. β(3) = 3/16, β(6) = 1/16.
pub fn beta(n: usize) -> f64 {
    match n {
        0 => 0.0,
        3 => 3.0 / 16.0,
        6 => 1.0 / 16.0,
        _ => {
            let n = n as f64;
            let c = 0.375 + 0.25 * (2.0 * std::f64::consts::PI / n).cos();
            (0.625 - c * c) / n
        }
    }
}

/// β for valences below 64, precomputed as `f32`.
fn beta_table() -> [f32; 64] {
    let mut t = [0.0f32; 64];
    for (n, b) in t.iter_mut().enumerate() {
        *b = beta(n) as f32;
    }
    t
}

/// Splits triangle level `p` into its Loop child topology, building adjacency up to
/// `detail`.
///
/// Errors: [`RefineError::OutOfMemory`] when an array cannot be allocated.
pub(crate) fn split(p: &Topology, detail: Detail, par: bool) -> Result<Topology, RefineError> {
    debug_assert!(p.face_size == 3 || p.num_faces == 0, "Loop needs triangles");
    let nv = p.num_verts;
    let nf = p.num_faces as usize;
    let ne = p.edge_count() as u32;
    let ev_base = nv;
    let mut t = Topology {
        num_verts: nv + ne,
        num_faces: 4 * nf as u32,
        face_size: 3,
        face_verts: try_zeroed(12 * nf, "face vertices")?,
        ..Default::default()
    };
    fill_chunks(par, &mut t.face_verts, 12, |f, out| {
        let v = &p.face_verts[3 * f..3 * f + 3];
        let e = &p.face_edges[3 * f..3 * f + 3];
        let (m0, m1, m2) = (ev_base + e[0], ev_base + e[1], ev_base + e[2]);
        out.copy_from_slice(&[v[0], m0, m2, m0, v[1], m1, m2, m1, v[2], m0, m1, m2]);
    });
    if detail == Detail::Faces {
        return Ok(t);
    }
    t.face_edges = try_zeroed(12 * nf, "face edges")?;
    fill_chunks(par, &mut t.face_edges, 12, |f, out| {
        let v = &p.face_verts[3 * f..3 * f + 3];
        let e = &p.face_edges[3 * f..3 * f + 3];
        let i = 2 * ne + 3 * f as u32;
        let h = |k: usize, at: usize| p.half_at(e[k], v[at]);
        out.copy_from_slice(&[
            h(0, 0),
            i + 2,
            h(2, 0),
            h(0, 1),
            h(1, 1),
            i,
            i + 1,
            h(1, 2),
            h(2, 2),
            i,
            i + 1,
            i + 2,
        ]);
    });
    t.edge_verts = try_zeroed(2 * ne as usize + 3 * nf, "edge vertices")?;
    {
        let (halves, interior) = t.edge_verts.split_at_mut(2 * ne as usize);
        fill_chunks(par, halves, 2, |e, out| {
            let [a, b] = p.edge_verts[e];
            out[0] = [a, ev_base + e as u32];
            out[1] = [ev_base + e as u32, b];
        });
        fill_chunks(par, interior, 3, |f, out| {
            let e = &p.face_edges[3 * f..3 * f + 3];
            let (m0, m1, m2) = (ev_base + e[0], ev_base + e[1], ev_base + e[2]);
            out.copy_from_slice(&[[m0, m1], [m1, m2], [m2, m0]]);
        });
    }
    if detail == Detail::Edges {
        return Ok(t);
    }
    t.edge_corners = try_zeroed(2 * ne as usize + 3 * nf, "edge corners")?;
    {
        let (halves, interior) = t.edge_corners.split_at_mut(2 * ne as usize);
        super::fill_half_edge_corners(p, halves, par, |ck| {
            let (f, j) = (ck / 3, ck % 3);
            (3 * (4 * f + j) + j, 3 * (4 * f + (j + 1) % 3) + j)
        });
        fill_chunks(par, interior, 3, |f, out| {
            let f = f as u32;
            for (k, slot) in out.iter_mut().enumerate() {
                let k = k as u32;
                *slot = [3 * (4 * f + 3) + k, 3 * (4 * f + (k + 1) % 3) + (k + 2) % 3];
            }
        });
    }
    let off = super::child_corner_offsets(p, t.num_verts, false, 3)?;
    let mut vc: Vec<u32> = try_zeroed(*off.last().unwrap_or(&0) as usize, "vertex corners")?;
    {
        let (vvs, evs) = vc.split_at_mut(off[nv as usize] as usize);
        fill(par, vvs, |i, slot| {
            let c = p.vert_corners[i];
            let (f, j) = (c / 3, c % 3);
            *slot = 3 * (4 * f + j) + j;
        });
        // The three child corners of edge point `e` in the children of parent corner `ck`.
        let corners = |ck: u32| {
            let (f, j) = (ck / 3, ck % 3);
            [3 * (4 * f + j) + (j + 1) % 3, 3 * (4 * f + (j + 1) % 3) + j, 3 * (4 * f + 3) + j]
        };
        super::fill_edge_point_corners(p, evs, par, corners);
    }
    t.vert_corner_offsets = off;
    t.vert_corners = vc;
    Ok(t)
}

/// Interpolates per-vertex values of triangle level `p` into `dst` (the child level).
pub(crate) fn interpolate<T: Primvar>(
    p: &Topology,
    rules: &Rules,
    src: &[T],
    dst: &mut [MaybeUninit<T>],
    par: bool,
) {
    let nv = p.num_verts as usize;
    let (vv, ep) = dst.split_at_mut(nv);
    fill(par, ep, |e, out| {
        let [a, b] = p.edge_verts[e];
        let [c0, c1] = p.edge_corners[e];
        let s = src[a as usize].add(src[b as usize]);
        out.write(if c1 == NONE {
            s.scale(0.5)
        } else {
            let opp = src[p.face_verts[p.prev(c0) as usize] as usize]
                .add(src[p.face_verts[p.prev(c1) as usize] as usize]);
            s.scale(0.375).add(opp.scale(0.125))
        });
    });
    let table = beta_table();
    fill(par, vv, |v, out| {
        let cs = p.vertex_corners(v);
        let n = cs.len();
        if n == 0 {
            out.write(src[v]);
            return;
        }
        let mut sum = T::zero();
        for &c in cs {
            sum = sum.add(src[p.face_verts[p.next(c) as usize] as usize]);
        }
        let b = if n < table.len() { table[n] } else { beta(n) as f32 };
        out.write(src[v].scale(1.0 - n as f32 * b).add(sum.scale(b)));
    });
    // SAFETY: every edge and vertex point was written just above.
    let (ep, vv) = unsafe { (assume_init_mut(ep), assume_init_mut(vv)) };
    super::apply_specials(rules, p, src, ep, vv);
}

/// Linear interpolation: edge midpoints, vertices kept (Pieterse2012 §2.9's linear UVs).
pub(crate) fn interpolate_linear<T: Primvar>(p: &Topology, src: &[T], dst: &mut [MaybeUninit<T>], par: bool) {
    let nv = p.num_verts as usize;
    let (vv, ep) = dst.split_at_mut(nv);
    super::interpolate_linear_edges(p, src, vv, ep, par);
}

/// Number of triangles after `levels` steps from `faces` triangles (saturating).
pub fn face_count(faces: usize, levels: u32) -> u128 {
    (faces as u128).saturating_mul(4u128.saturating_pow(levels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beta_erratum_values() {
        assert_eq!(beta(3), 3.0 / 16.0);
        assert_eq!(beta(6), 1.0 / 16.0);
        assert!((beta(4) - 31.0 / 256.0).abs() < 1e-15);
        // The general formula agrees with the special cases (cos, not sin).
        for n in [3usize, 6] {
            let nf = n as f64;
            let c = 0.375 + 0.25 * (2.0 * std::f64::consts::PI / nf).cos();
            assert!(((0.625 - c * c) / nf - beta(n)).abs() < 1e-15);
        }
        for n in 3..40 {
            assert!(1.0 - n as f64 * beta(n) >= 0.0, "negative centre weight at valence {n}");
        }
    }
}
