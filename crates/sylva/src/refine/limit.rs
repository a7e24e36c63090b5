//! Limit positions and exact limit normals ("move to limit surface", MacMurchy2004 §A.3 /
//! MacMurchy2004-spec §2.11).
//!
//! Limit position masks (Hoppe et al. 1994; Halstead, Kass & DeRose 1993):
//! - Loop, smooth vertex of valence n: `(1 − nχ) v + χ Σ qᵢ`, `χ = 1/(n + 3/(8β(n)))`,
//!   i.e. MacMurchy2004-spec's `(ω v + Σ qⱼ)/(ω + n)` with `ω = 3/(8β)` (½ and 1/12 at n = 6);
//! - Catmull–Clark, smooth vertex of valence n in a quad mesh:
//!   `(n² v + 4 Σ eᵢ + Σ dᵢ) / (n(n + 5))` with eᵢ the edge neighbours and dᵢ the
//!   diagonal vertices (4/9, 1/9, 1/36 at n = 4 — the bicubic B-spline at a knot);
//! - crease and boundary vertices: `(a + 4v + b)/6` (the cubic B-spline curve's limit);
//! - corners: `v`.
//!
//! Limit tangents use the standard eigen-analysis masks (Loop: `Σ cos(2πi/n) qᵢ`,
//! `Σ sin(2πi/n) qᵢ`; Catmull–Clark: Halstead et al.'s edge weights `4 cos(2πi/n)` and
//! face weights `(cos(2πi/n) + cos(2π(i+1)/n))/(4λ − 1)`; on crease and boundary sectors
//! the cross-tangent masks of Biermann, Levin & Zorin 2000 as OpenSubdiv applies them).
//! Normals are `t₁ × t₂` for counter-clockwise rings, so they point to the front (outward
//! on a closed, consistently oriented mesh; MacMurchy2004 notes Salad's point inward).
//! Normals are face-varying: one value per smooth vertex and one per *sector* (the faces
//! between two consecutive sharp edges) on creases, corners and boundaries, so a sharp
//! crease keeps a distinct normal on each side.

use super::crease::{group_by_vertex, vertex_rule, Features, Rule};
use super::loop_::beta;
use super::topology::Topology;
use super::{fill, BoundaryInterpolation, Primvar, RefineError, Scheme};
use crate::geometry::FaceVarying;
use glam::Vec3;
use std::f64::consts::PI;

/// What both limit evaluations need: the last level's full adjacency, one value per
/// vertex (`what` names them), and quads for Catmull–Clark.
fn check_input(scheme: Scheme, topo: &Topology, len: usize, what: &'static str) -> Result<(), RefineError> {
    if topo.vert_corner_offsets.len() != topo.vertex_count() + 1
        || topo.edge_corners.len() != topo.edge_count()
    {
        return Err(RefineError::InvalidMesh(
            "limit positions and normals need the full adjacency of the last level \
             (set RefineOptions::full_last_level)"
                .into(),
        ));
    }
    if len != topo.vertex_count() {
        return Err(RefineError::WrongLength { what, expected: topo.vertex_count(), got: len });
    }
    if scheme == Scheme::CatmullClark && topo.face_count() > 0 && topo.face_size != 4 {
        return Err(RefineError::LimitNeedsQuads);
    }
    Ok(())
}

/// The rule and the two crease neighbours (for [`Rule::Crease`]) of every vertex with a
/// sharp feature, sorted by vertex.
fn special_rules(
    topo: &Topology,
    features: &Features,
    boundary: BoundaryInterpolation,
) -> Vec<(u32, Rule, [u32; 2])> {
    group_by_vertex(topo, features, boundary)
        .into_iter()
        .map(|g| {
            let sharp: Vec<u32> =
                g.edges.iter().filter(|x| x.1 > 0.0).map(|x| topo.other_vertex(x.0, g.vertex)).collect();
            let rule = vertex_rule(g.vertex_sharpness, sharp.len());
            let ends =
                [sharp.first().copied().unwrap_or(g.vertex), sharp.get(1).copied().unwrap_or(g.vertex)];
            (g.vertex, rule, ends)
        })
        .collect()
}

/// Pushes the finest-level values `src` to their limit positions.
pub(crate) fn limit_positions<T: Primvar>(
    scheme: Scheme,
    boundary: BoundaryInterpolation,
    topo: &Topology,
    features: &Features,
    src: &[T],
    par: bool,
) -> Result<Vec<T>, RefineError> {
    check_input(scheme, topo, src.len(), "finest-level values")?;
    let mut out = vec![T::zero(); src.len()];
    fill(par, &mut out, |v, o| {
        let cs = topo.vertex_corners(v);
        let n = cs.len();
        *o = match scheme {
            _ if n == 0 => src[v],
            Scheme::CatmullClark if n == 2 => src[v],
            Scheme::CatmullClark => {
                let mut e = T::zero();
                let mut d = T::zero();
                for &c in cs {
                    let c1 = topo.next(c);
                    e = e.add(src[topo.face_verts[c1 as usize] as usize]);
                    d = d.add(src[topo.face_verts[topo.next(c1) as usize] as usize]);
                }
                let nf = n as f32;
                let fw = 1.0 / (nf * (nf + 5.0));
                src[v].scale(1.0 - nf * 5.0 * fw).add(e.scale(4.0 * fw)).add(d.scale(fw))
            }
            Scheme::Loop => {
                let mut q = T::zero();
                for &c in cs {
                    q = q.add(src[topo.face_verts[topo.next(c) as usize] as usize]);
                }
                let chi = (1.0 / (n as f64 + 3.0 / (8.0 * beta(n)))) as f32;
                src[v].scale(1.0 - n as f32 * chi).add(q.scale(chi))
            }
        };
    });
    for (v, rule, [a, b]) in special_rules(topo, features, boundary) {
        let v = v as usize;
        match rule {
            Rule::Smooth | Rule::Dart => {}
            Rule::Crease => {
                out[v] = src[v].scale(2.0 / 3.0).add(src[a as usize].add(src[b as usize]).scale(1.0 / 6.0));
            }
            Rule::Corner => out[v] = src[v],
        }
    }
    Ok(out)
}

/// Exact limit normals of the finest level from its limit `positions`, one per smooth
/// vertex and one per sector elsewhere, indexed per corner.
pub(crate) fn limit_normals(
    scheme: Scheme,
    boundary: BoundaryInterpolation,
    topo: &Topology,
    features: &Features,
    pos: &[Vec3],
) -> Result<FaceVarying<Vec3>, RefineError> {
    check_input(scheme, topo, pos.len(), "finest-level positions")?;
    let groups = group_by_vertex(topo, features, boundary);
    let mut gi = 0;
    let mut values = Vec::with_capacity(topo.vertex_count());
    let mut indices = vec![0u32; topo.corner_count()];
    for v in 0..topo.vertex_count() {
        let group = if gi < groups.len() && groups[gi].vertex as usize == v {
            gi += 1;
            Some(&groups[gi - 1])
        } else {
            None
        };
        let ring = topo.ring(v);
        if ring.corners.is_empty() {
            continue;
        }
        let edges = topo.ring_edges(&ring);
        let k = ring.corners.len();
        let p = pos[v];
        let e: Vec<Vec3> = edges.iter().map(|&x| pos[topo.other_vertex(x, v as u32) as usize]).collect();
        let d: Vec<Vec3> = ring
            .corners
            .iter()
            .map(|&c| match scheme {
                Scheme::CatmullClark => pos[topo.face_verts[topo.next(topo.next(c)) as usize] as usize],
                Scheme::Loop => p,
            })
            .collect();
        let sharp: Vec<usize> = match group {
            Some(g) => {
                (0..edges.len()).filter(|&i| g.edges.iter().any(|x| x.0 == edges[i] && x.1 > 0.0)).collect()
            }
            None => Vec::new(),
        };
        let vs = group.map_or(0.0, |g| g.vertex_sharpness);
        let rule = vertex_rule(vs, sharp.len());
        let fan = |start: usize, m: usize| -> Vec3 {
            let mut n = Vec3::ZERO;
            for i in start..start + m {
                n += (e[i % e.len()] - p).cross(e[(i + 1) % e.len()] - p);
            }
            n
        };
        let base = values.len() as u32;
        if matches!(rule, Rule::Smooth | Rule::Dart) && !ring.boundary {
            let n = smooth_normal(scheme, p, &e, &d);
            values.push(finish(n, || fan(0, k)));
            for &c in &ring.corners {
                indices[c as usize] = base;
            }
            continue;
        }
        // Sectors: (first edge, face count).
        let mut sectors = Vec::new();
        if ring.boundary {
            for w in sharp.windows(2) {
                sectors.push((w[0], w[1] - w[0]));
            }
        } else if sharp.len() <= 1 {
            sectors.push((sharp.first().copied().unwrap_or(0), k));
        } else {
            for j in 0..sharp.len() {
                let (s, t) = (sharp[j], sharp[(j + 1) % sharp.len()]);
                sectors.push((s, (t + k - s) % k));
            }
        }
        for (start, m) in sectors {
            let n = if rule == Rule::Crease {
                let se: Vec<Vec3> = (0..=m).map(|i| e[(start + i) % e.len()]).collect();
                let sd: Vec<Vec3> = (0..m).map(|i| d[(start + i) % k]).collect();
                crease_normal(scheme, p, &se, &sd)
            } else {
                fan(start, m)
            };
            let id = values.len() as u32;
            values.push(finish(n, || fan(start, m)));
            for i in 0..m {
                indices[ring.corners[(start + i) % k] as usize] = id;
            }
        }
    }
    Ok(FaceVarying { values, indices })
}

/// Unit normal, falling back to the polygon fan's normal (then +Y) when degenerate.
fn finish(n: Vec3, fallback: impl Fn() -> Vec3) -> Vec3 {
    let u = n.normalize_or_zero();
    if u != Vec3::ZERO {
        return u;
    }
    let f = fallback().normalize_or_zero();
    if f != Vec3::ZERO {
        f
    } else {
        Vec3::Y
    }
}

/// `t₁ × t₂` of a smooth interior vertex: ring edge neighbours `e` counter-clockwise and,
/// for Catmull–Clark, the diagonal vertex `d[i]` of the quad between `e[i]` and `e[i+1]`.
fn smooth_normal(scheme: Scheme, p: Vec3, e: &[Vec3], d: &[Vec3]) -> Vec3 {
    let n = e.len();
    let theta = 2.0 * PI / n as f64;
    match scheme {
        Scheme::Loop => {
            let (mut t1, mut t2) = (Vec3::ZERO, Vec3::ZERO);
            for (i, &q) in e.iter().enumerate() {
                let a = theta * i as f64;
                t1 += q * a.cos() as f32;
                t2 += q * a.sin() as f32;
            }
            t1.cross(t2)
        }
        Scheme::CatmullClark if n == 2 => (e[0] - p).cross(e[1] - p),
        Scheme::CatmullClark => {
            let lambda =
                5.0 / 16.0 + (theta.cos() + (theta * 0.5).cos() * (2.0 * (9.0 + theta.cos())).sqrt()) / 16.0;
            let face_scale = 1.0 / (4.0 * lambda - 1.0);
            let ew: Vec<f32> = (0..n).map(|i| (4.0 * (theta * i as f64).cos()) as f32).collect();
            let fw: Vec<f32> = (0..n)
                .map(|i| (face_scale * ((theta * i as f64).cos() + (theta * (i + 1) as f64).cos())) as f32)
                .collect();
            let (mut t1, mut t2) = (Vec3::ZERO, Vec3::ZERO);
            for i in 0..n {
                let j = (i + n - 1) % n; // t₂ is t₁ rotated by one step
                t1 += e[i] * ew[i] + d[i] * fw[i];
                t2 += e[i] * ew[j] + d[i] * fw[j];
            }
            t1.cross(t2)
        }
    }
}

/// `t₁ × t₂` on one side of a crease or boundary: `e[0]` is the leading crease edge,
/// `e[m]` the trailing one, `e[1..m]` the interior edges of the sector's `m` faces, `d` the
/// Catmull–Clark diagonals.
fn crease_normal(scheme: Scheme, p: Vec3, e: &[Vec3], d: &[Vec3]) -> Vec3 {
    let m = e.len() - 1;
    let t1 = e[0] - e[m];
    let t2 = match (scheme, m) {
        (_, 1) => (e[0] + e[1]) * 3.0 - p * 6.0,
        (Scheme::Loop, 2) => (e[1] - p) * 3.0,
        (Scheme::Loop, 3) => {
            let r3 = 3f32.sqrt();
            (e[1] + e[2]) * r3 - (e[0] + e[3]) * (0.5 * r3) - p * r3
        }
        (Scheme::Loop, _) => {
            let th = PI / m as f64;
            let mut t = (e[0] + e[m]) * (-3.0 * th.sin()) as f32;
            let coeff = -3.0 * (2.0 * th.cos() - 2.0);
            for (i, &q) in e.iter().enumerate().take(m).skip(1) {
                t += q * (coeff * (th * i as f64).sin()) as f32;
            }
            t
        }
        (Scheme::CatmullClark, 2) => (e[1] * 4.0 - e[0] - e[2] - p * 4.0 + d[0] + d[1]) * (1.0 / 6.0),
        (Scheme::CatmullClark, _) => {
            let k = m as f64;
            let th = PI / k;
            let (c, s) = (th.cos(), th.sin());
            let den = 1.0 / (k * (3.0 + c));
            let r = (c + 1.0) / s;
            let mut t =
                p * (4.0 * r * (c - 1.0) * den) as f32 + (e[0] + e[m]) * (-r * (1.0 + 2.0 * c) * den) as f32;
            t += d[0] * (s * den) as f32;
            for i in 1..m {
                let si = (th * i as f64).sin();
                let si1 = (th * (i + 1) as f64).sin();
                t += e[i] * (4.0 * si * den) as f32 + d[i] * ((si + si1) * den) as f32;
            }
            t
        }
    };
    t1.cross(t2)
}
