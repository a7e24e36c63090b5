//! Catmull–Clark subdivision (Skjermo2008 §5: "coarse watertight mesh → Catmull–Clark steps";
//! the junction mesher's all-quad cages are its control meshes).
//!
//! One step turns every n-gon into n quads. Child vertices are numbered vertex points
//! first (`v`), then face points (`V + f`), then edge points (`V + F + e`), so control
//! vertices keep their indices at every level. The child face of parent corner `c` (vertex
//! `v`, outgoing edge `e`, incoming edge `e'`, face `f`) is `c` itself:
//! `[vv(v), ev(e), fv(f), ev(e')]`, counter-clockwise like its parent.
//!
//! Masks (Catmull & Clark 1978; crease rules in [`super::crease`]):
//! - face point: the centroid of the face;
//! - smooth edge point: `(a + b + f₀ + f₁) / 4` with the two adjacent face points;
//!   boundary or sharp edge: `(a + b) / 2`;
//! - smooth vertex point of valence n: `(n − 2)/n · v + 1/n² · Σ eᵢ + 1/n² · Σ fᵢ` (eᵢ the
//!   neighbouring vertices, fᵢ the adjacent face points), OpenSubdiv's form of
//!   `(Q + 2R + (n − 3)S)/n`.

use super::crease::Rules;
use super::topology::{Detail, Topology, NONE};
use super::{assume_init, assume_init_mut, fill, fill_chunks, try_zeroed, Primvar, RefineError};
use std::mem::MaybeUninit;

/// Splits `p` into its Catmull–Clark child topology, building adjacency up to `detail`.
///
/// Errors: [`RefineError::OutOfMemory`] when an array cannot be allocated.
pub(crate) fn split(p: &Topology, detail: Detail, par: bool) -> Result<Topology, RefineError> {
    let nv = p.num_verts;
    let nf = p.num_faces;
    let ne = p.edge_count() as u32;
    let nc = p.corner_count();
    let fv_base = nv;
    let ev_base = nv + nf;
    let mut t = Topology {
        num_verts: nv + nf + ne,
        num_faces: nc as u32,
        face_size: 4,
        face_verts: try_zeroed(4 * nc, "face vertices")?,
        ..Default::default()
    };
    fill_chunks(par, &mut t.face_verts, 4, |c, out| {
        let c = c as u32;
        out[0] = p.face_verts[c as usize];
        out[1] = ev_base + p.face_edges[c as usize];
        out[2] = fv_base + p.face_of(c);
        out[3] = ev_base + p.face_edges[p.prev(c) as usize];
    });
    if detail == Detail::Faces {
        return Ok(t);
    }
    t.face_edges = try_zeroed(4 * nc, "face edges")?;
    fill_chunks(par, &mut t.face_edges, 4, |c, out| {
        let c = c as u32;
        let v = p.face_verts[c as usize];
        let pc = p.prev(c);
        out[0] = p.half_at(p.face_edges[c as usize], v);
        out[1] = 2 * ne + c;
        out[2] = 2 * ne + pc;
        out[3] = p.half_at(p.face_edges[pc as usize], v);
    });
    t.edge_verts = try_zeroed(2 * ne as usize + nc, "edge vertices")?;
    {
        let (halves, interior) = t.edge_verts.split_at_mut(2 * ne as usize);
        fill_chunks(par, halves, 2, |e, out| {
            let [a, b] = p.edge_verts[e];
            out[0] = [a, ev_base + e as u32];
            out[1] = [ev_base + e as u32, b];
        });
        fill(par, interior, |c, out| {
            *out = [ev_base + p.face_edges[c], fv_base + p.face_of(c as u32)];
        });
    }
    if detail == Detail::Edges {
        return Ok(t);
    }
    t.edge_corners = try_zeroed(2 * ne as usize + nc, "edge corners")?;
    {
        let (halves, interior) = t.edge_corners.split_at_mut(2 * ne as usize);
        super::fill_half_edge_corners(p, halves, par, |ck| (4 * ck, 4 * p.next(ck) + 3));
        fill(par, interior, |c, out| {
            let c = c as u32;
            *out = [4 * c + 1, 4 * p.next(c) + 2];
        });
    }
    // Vertex → corners: vertex points, face points, edge points.
    let off = super::child_corner_offsets(p, t.num_verts, true, 2)?;
    let mut vc: Vec<u32> = try_zeroed(*off.last().unwrap_or(&0) as usize, "vertex corners")?;
    {
        let (vvs, rest) = vc.split_at_mut(off[nv as usize] as usize);
        let (fvs, evs) = rest.split_at_mut((off[(nv + nf) as usize] - off[nv as usize]) as usize);
        fill(par, vvs, |i, slot| *slot = 4 * p.vert_corners[i]);
        fill(par, fvs, |c, slot| *slot = 4 * c as u32 + 2);
        super::fill_edge_point_corners(p, evs, par, |ck| [4 * ck + 1, 4 * p.next(ck) + 3]);
    }
    t.vert_corner_offsets = off;
    t.vert_corners = vc;
    Ok(t)
}

/// Interpolates per-vertex values of level `p` into `dst` (the child level's values).
pub(crate) fn interpolate<T: Primvar>(
    p: &Topology,
    rules: &Rules,
    src: &[T],
    dst: &mut [MaybeUninit<T>],
    par: bool,
) {
    let nv = p.num_verts as usize;
    let nf = p.num_faces as usize;
    let (vv, rest) = dst.split_at_mut(nv);
    let (fp, ep) = rest.split_at_mut(nf);
    face_points(p, src, fp, par);
    // SAFETY: every face point was written just above.
    let fp: &[T] = unsafe { assume_init(fp) };
    fill(par, ep, |e, out| {
        let [a, b] = p.edge_verts[e];
        let [c0, c1] = p.edge_corners[e];
        let s = src[a as usize].add(src[b as usize]);
        out.write(if c1 == NONE {
            s.scale(0.5)
        } else {
            s.add(fp[p.face_of(c0) as usize]).add(fp[p.face_of(c1) as usize]).scale(0.25)
        });
    });
    fill(par, vv, |v, out| {
        let cs = p.vertex_corners(v);
        if cs.is_empty() {
            out.write(src[v]);
            return;
        }
        let mut sum = T::zero();
        for &c in cs {
            sum = sum.add(src[p.face_verts[p.next(c) as usize] as usize]).add(fp[p.face_of(c) as usize]);
        }
        let n = cs.len() as f32;
        out.write(src[v].scale((n - 2.0) / n).add(sum.scale(1.0 / (n * n))));
    });
    // SAFETY: every edge and vertex point was written just above.
    let (ep, vv) = unsafe { (assume_init_mut(ep), assume_init_mut(vv)) };
    super::apply_specials(rules, p, src, ep, vv);
}

/// Linear interpolation (every edge and vertex sharp): face centroids, edge midpoints,
/// vertices kept. Used for face-varying data interpolated linearly (Pieterse2012 §2.9).
pub(crate) fn interpolate_linear<T: Primvar>(p: &Topology, src: &[T], dst: &mut [MaybeUninit<T>], par: bool) {
    let nv = p.num_verts as usize;
    let nf = p.num_faces as usize;
    let (vv, rest) = dst.split_at_mut(nv);
    let (fp, ep) = rest.split_at_mut(nf);
    face_points(p, src, fp, par);
    super::interpolate_linear_edges(p, src, vv, ep, par);
}

/// Face points: each face's centroid, written into `fp` (one per face).
fn face_points<T: Primvar>(p: &Topology, src: &[T], fp: &mut [MaybeUninit<T>], par: bool) {
    fill(par, fp, |f, out| {
        let r = p.corners(f);
        let inv = 1.0 / r.len() as f32;
        let mut s = T::zero();
        for c in r {
            s = s.add(src[p.face_verts[c] as usize]);
        }
        out.write(s.scale(inv));
    });
}

/// Number of faces after `levels` steps from a control mesh with `corners` face corners
/// and `faces` faces (saturating).
pub fn face_count(faces: usize, corners: usize, levels: u32) -> u128 {
    if levels == 0 {
        return faces as u128;
    }
    (corners as u128).saturating_mul(4u128.saturating_pow(levels - 1))
}
