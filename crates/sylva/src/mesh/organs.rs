//! Meshes for the organs placed on a skeleton: polygons traced by the turtle (`{ . }`,
//! ABOP §1.6 leaves), named surfaces (cpfg `~x` with `.s` files), spheres (`@O`),
//! discs (`@o`, `@c`), swept surfaces (cpfg generalized cylinders with a contour,
//! `@#` … `@Gs` … `@Ge`, issue 26) and simple leaf quads. All organs go into one mesh with
//! face-varying UVs and normals; the exporter puts it in the `leaves` part with a
//! double-sided material.
//!
//! Organ frame: heading H (`Organ::heading`), up U (`Organ::up`) and X = H × U. A named
//! surface's local coordinates (x, y, z) map to `position + size·(x·X + y·H + z·U)`.

use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::{Organ, OrganKind, Skeleton};
use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// Builds one mesh for every organ of `skeleton`. `surfaces` maps a surface name (the
/// `x` of `~x`) to its mesh in the organ frame; organs naming a missing surface are
/// returned by name in the second value (the caller reports them) and skipped.
pub fn organ_mesh(skeleton: &Skeleton, surfaces: &HashMap<String, Mesh>) -> (Mesh, Vec<String>) {
    organ_mesh_where(skeleton, surfaces, |_| true)
}

/// [`organ_mesh`] of the organs for which `keep` is true (the others are drawn
/// elsewhere, such as leaf cards).
pub fn organ_mesh_where(
    skeleton: &Skeleton,
    surfaces: &HashMap<String, Mesh>,
    keep: impl Fn(&Organ) -> bool,
) -> (Mesh, Vec<String>) {
    let mut out = Mesh::new();
    out.uvs = Some(FaceVarying::default());
    out.normals = Some(FaceVarying::default());
    let mut missing: Vec<String> = Vec::new();
    for o in skeleton.organs.iter().filter(|o| keep(o)) {
        let h = o.heading.normalize_or_zero();
        let mut u = (o.up - h * o.up.dot(h)).normalize_or_zero();
        if h == Vec3::ZERO {
            continue;
        }
        if u == Vec3::ZERO {
            u = h.any_orthonormal_vector();
        }
        let x = h.cross(u);
        match &o.kind {
            OrganKind::Polygon(v) => polygon(&mut out, v, o.position, h),
            OrganKind::Leaf => {
                let w = o.size * 0.25;
                let p = o.position;
                let quad = [p - x * w, p + x * w, p + x * w + h * o.size, p - x * w + h * o.size];
                let uv = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
                push_face(&mut out, &quad, &uv, &[u; 4]);
            }
            OrganKind::Disc => disc(&mut out, o, h, u),
            OrganKind::Sphere => sphere(&mut out, o.position, o.size),
            OrganKind::Swept(sw) => swept(&mut out, &sw.rings, sw.closed, u),
            OrganKind::Surface(name) => match surfaces.get(name) {
                Some(m) => place(&mut out, m, o, x, h, u),
                None => {
                    if !missing.contains(name) {
                        missing.push(name.clone());
                    }
                }
            },
        }
    }
    (out, missing)
}

/// Appends one face with its own corner UVs and normals.
fn push_face(out: &mut Mesh, pos: &[Vec3], uv: &[Vec2], n: &[Vec3]) {
    let base = out.positions.len() as u32;
    out.positions.extend_from_slice(pos);
    let idx: Vec<u32> = (0..pos.len() as u32).map(|k| base + k).collect();
    out.push_face(&idx);
    if let Some(ch) = out.uvs.as_mut() {
        let b = ch.values.len() as u32;
        ch.values.extend_from_slice(uv);
        ch.indices.extend((0..uv.len() as u32).map(|k| b + k));
    }
    if let Some(ch) = out.normals.as_mut() {
        let b = ch.values.len() as u32;
        ch.values.extend_from_slice(n);
        ch.indices.extend((0..n.len() as u32).map(|k| b + k));
    }
}

/// A planar polygon, welded: its outline's points once, fan-triangulated from the first
/// point (so the unified output has one vertex per outline point). UVs run along the
/// midrib: v from the organ's base (0) to its tip (1) along its heading projected into
/// the blade's plane, u across (0.5 on the midrib), scaled to the outline's bounding
/// box; one normal by Newell's method.
fn polygon(out: &mut Mesh, v: &[Vec3], base: Vec3, heading: Vec3) {
    if v.len() < 3 || v.iter().any(|p| !p.is_finite()) {
        return;
    }
    let mut n = Vec3::ZERO;
    for k in 0..v.len() {
        let (a, b) = (v[k], v[(k + 1) % v.len()]);
        n += Vec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    let n = n.normalize_or_zero();
    if n == Vec3::ZERO {
        return; // degenerate (collinear) outline
    }
    // The midrib: the heading in the blade's plane (else the first edge's direction).
    let along = (heading - n * heading.dot(n))
        .try_normalize()
        .or_else(|| (v[1] - v[0]).try_normalize())
        .unwrap_or_else(|| n.any_orthonormal_vector());
    let across = along.cross(n);
    let flat: Vec<Vec2> =
        v.iter().map(|p| Vec2::new((*p - base).dot(across), (*p - base).dot(along))).collect();
    let lo = flat.iter().fold(Vec2::splat(f32::MAX), |a, b| a.min(*b)).min(Vec2::ZERO);
    let hi = flat.iter().fold(Vec2::splat(f32::MIN), |a, b| a.max(*b)).max(Vec2::ZERO);
    // Symmetric about the midrib across (u = 0.5 there), base to tip along.
    let half = (-lo.x).max(hi.x).max(1e-9);
    let len = (hi.y - lo.y).max(1e-9);
    // Repeated outline points (a fan's closing point) are one vertex; fan triangles that
    // fold onto a repeated point are dropped.
    let first_of: Vec<u32> = (0..v.len())
        .map(|k| if v.len() <= 64 { (0..k).find(|&j| v[j] == v[k]).unwrap_or(k) as u32 } else { k as u32 })
        .collect();
    let p0 = out.positions.len() as u32;
    out.positions.extend_from_slice(v);
    let mut corners: Vec<u32> = Vec::with_capacity(3 * (v.len() - 2));
    for k in 1..v.len() - 1 {
        let t = [first_of[0], first_of[k], first_of[k + 1]];
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            out.push_face(&t.map(|i| p0 + i));
            corners.extend_from_slice(&t);
        }
    }
    if let Some(ch) = out.uvs.as_mut() {
        let b = ch.values.len() as u32;
        ch.values.extend(flat.iter().map(|f| Vec2::new(0.5 + 0.5 * f.x / half, (f.y - lo.y) / len)));
        ch.indices.extend(corners.iter().map(|&k| b + k));
    }
    if let Some(ch) = out.normals.as_mut() {
        let b = ch.values.len() as u32;
        ch.values.push(n);
        ch.indices.extend(corners.iter().map(|_| b));
    }
}

/// A swept surface: a strip of triangles between consecutive rings (two per quad,
/// welded: each ring point is one vertex), with u along the contour (0 at its first
/// point, 1 at its last, or back at the first when closed) and v along the sweep (0 at
/// the first ring, 1 at the last, by the rings' centres' distance). Normals are smooth
/// (contour tangent × sweep direction at each point) and face the same way as the
/// triangles; a closed contour's point outward whichever way the contour winds. Rings
/// of different lengths, non-finite points and zero-area triangles (a ring shrunk to a
/// point) are skipped; `fallback` is the normal where the surface has no direction.
fn swept(out: &mut Mesh, rings: &[Vec<Vec3>], closed: bool, fallback: Vec3) {
    let k = rings.first().map_or(0, Vec::len);
    if rings.len() < 2 || k < 2 || rings.iter().any(|r| r.len() != k || r.iter().any(|p| !p.is_finite())) {
        return;
    }
    let segs = if closed { k } else { k - 1 };
    let centre = |r: &[Vec3]| r.iter().copied().sum::<Vec3>() / k as f32;
    let centres: Vec<Vec3> = rings.iter().map(|r| centre(r)).collect();
    let mut along = vec![0.0f32];
    for w in centres.windows(2) {
        along.push(along.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    let total = along.last().copied().unwrap_or(0.0).max(1e-12);
    // A closed contour winding clockwise about the sweep direction is flipped, so its
    // normals point outward.
    let mut flip = false;
    if closed {
        let dir = centres[centres.len() - 1] - centres[0];
        let r = &rings[0];
        let c = centres[0];
        let area: Vec3 = (0..k).map(|i| (r[i] - c).cross(r[(i + 1) % k] - c)).sum();
        flip = area.dot(dir) < 0.0;
    }
    let sign = if flip { -1.0 } else { 1.0 };
    let at = |j: usize, i: usize| rings[j][i % k];
    let normal = |j: usize, i: usize| {
        let (ia, ib) =
            if closed { ((i + k - 1) % k, (i + 1) % k) } else { (i.saturating_sub(1), (i + 1).min(k - 1)) };
        let (ja, jb) = (j.saturating_sub(1), (j + 1).min(rings.len() - 1));
        let du = at(j, ib) - at(j, ia);
        let dv = at(jb, i) - at(ja, i);
        (du.cross(dv) * sign).try_normalize().unwrap_or(fallback)
    };
    let base = out.positions.len() as u32;
    for r in rings {
        out.positions.extend_from_slice(r);
    }
    let (uv0, n0) = (
        out.uvs.as_ref().map_or(0, |c| c.values.len()) as u32,
        out.normals.as_ref().map_or(0, |c| c.values.len()) as u32,
    );
    if let Some(ch) = out.uvs.as_mut() {
        for v in &along {
            ch.values.extend((0..=segs).map(|i| Vec2::new(i as f32 / segs as f32, v / total)));
        }
    }
    if let Some(ch) = out.normals.as_mut() {
        for j in 0..rings.len() {
            ch.values.extend((0..k).map(|i| normal(j, i)));
        }
    }
    for j in 0..rings.len() - 1 {
        for i in 0..segs {
            // Corners (ring, index along the contour): a, b along the contour, then up the sweep.
            let quad = [(j, i), (j, i + 1), (j + 1, i + 1), (j + 1, i)];
            let tris: [[usize; 3]; 2] = if flip { [[0, 2, 1], [0, 3, 2]] } else { [[0, 1, 2], [0, 2, 3]] };
            for t in tris {
                let c = t.map(|q| quad[q]);
                let p = c.map(|(j, i)| at(j, i));
                if (p[1] - p[0]).cross(p[2] - p[0]).length_squared() <= 1e-30 {
                    continue;
                }
                out.push_face(&c.map(|(j, i)| base + (j * k + i % k) as u32));
                if let Some(ch) = out.uvs.as_mut() {
                    ch.indices.extend(c.map(|(j, i)| uv0 + (j * (segs + 1) + i) as u32));
                }
                if let Some(ch) = out.normals.as_mut() {
                    ch.indices.extend(c.map(|(j, i)| n0 + (j * k + i % k) as u32));
                }
            }
        }
    }
}

/// A disc of radius `size` perpendicular to the heading.
fn disc(out: &mut Mesh, o: &Organ, h: Vec3, u: Vec3) {
    const SEG: usize = 12;
    let x = h.cross(u);
    for k in 0..SEG {
        let a0 = k as f32 / SEG as f32 * std::f32::consts::TAU;
        let a1 = (k + 1) as f32 / SEG as f32 * std::f32::consts::TAU;
        let p = |a: f32| o.position + (x * a.cos() + u * a.sin()) * o.size;
        let t = |a: f32| Vec2::new(0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin());
        push_face(out, &[o.position, p(a0), p(a1)], &[Vec2::splat(0.5), t(a0), t(a1)], &[h; 3]);
    }
}

/// A UV sphere of radius `r`.
fn sphere(out: &mut Mesh, c: Vec3, r: f32) {
    const LON: usize = 12;
    const LAT: usize = 6;
    let point = |i: usize, j: usize| {
        let th = i as f32 / LAT as f32 * std::f32::consts::PI;
        let ph = j as f32 / LON as f32 * std::f32::consts::TAU;
        Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    for i in 0..LAT {
        for j in 0..LON {
            let n = [point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1)];
            let uv = [
                Vec2::new(j as f32 / LON as f32, i as f32 / LAT as f32),
                Vec2::new(j as f32 / LON as f32, (i + 1) as f32 / LAT as f32),
                Vec2::new((j + 1) as f32 / LON as f32, (i + 1) as f32 / LAT as f32),
                Vec2::new((j + 1) as f32 / LON as f32, i as f32 / LAT as f32),
            ];
            // Two triangles; the pole rows have one degenerate edge, dropped here.
            let p = n.map(|d| c + d * r);
            let tris: [[usize; 3]; 2] = [[0, 1, 2], [0, 2, 3]];
            for t in tris {
                if (i == 0 && t == [0, 2, 3]) || (i == LAT - 1 && t == [0, 1, 2]) {
                    continue;
                }
                push_face(
                    out,
                    &[p[t[0]], p[t[1]], p[t[2]]],
                    &[uv[t[0]], uv[t[1]], uv[t[2]]],
                    &[n[t[0]], n[t[1]], n[t[2]]],
                );
            }
        }
    }
}

/// Places a surface mesh in the organ's frame.
fn place(out: &mut Mesh, m: &Mesh, o: &Organ, x: Vec3, h: Vec3, u: Vec3) {
    let map = |p: Vec3| o.position + (x * p.x + h * p.y + u * p.z) * o.size;
    let mut placed = m.clone();
    for p in &mut placed.positions {
        *p = map(*p);
    }
    if let Some(n) = placed.normals.as_mut() {
        for v in &mut n.values {
            *v = (x * v.x + h * v.y + u * v.z).normalize_or_zero();
        }
    }
    if placed.uvs.is_none() {
        placed.uvs =
            Some(FaceVarying { values: vec![Vec2::ZERO], indices: vec![0; placed.face_indices.len()] });
    }
    if placed.normals.is_none() {
        placed.normals = Some(FaceVarying { values: vec![u], indices: vec![0; placed.face_indices.len()] });
    }
    placed.creases.clear();
    out.append(&placed);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn organ(kind: OrganKind, size: f32) -> Organ {
        Organ { kind, node: 0, position: Vec3::ZERO, heading: Vec3::Y, up: Vec3::Z, size, material: 0 }
    }

    #[test]
    fn every_kind_meshes_validly() {
        let mut sk = Skeleton::new();
        let hex = vec![
            Vec3::ZERO,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::new(-1.0, 2.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        sk.organs = vec![
            organ(OrganKind::Polygon(hex), 1.0),
            organ(OrganKind::Leaf, 1.0),
            organ(OrganKind::Disc, 0.5),
            organ(OrganKind::Sphere, 0.5),
            organ(OrganKind::Surface("l".into()), 2.0),
            organ(OrganKind::Surface("missing".into()), 2.0),
        ];
        let mut leaf = Mesh::new();
        leaf.positions = vec![Vec3::ZERO, Vec3::new(0.5, 0.5, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        leaf.push_face(&[0, 1, 2]);
        let surfaces = HashMap::from([("l".to_string(), leaf)]);
        let (m, missing) = organ_mesh(&sk, &surfaces);
        m.validate().unwrap();
        assert_eq!(missing, vec!["missing".to_string()]);
        // 4 polygon triangles + 1 quad + 12 disc + sphere + 1 surface triangle.
        assert!(m.face_count() > 4 + 1 + 12 + 1);
        // The surface is scaled by 2 and its local y runs along the heading (+Y).
        assert!(m.positions.iter().any(|p| p.distance(Vec3::new(0.0, 2.0, 0.0)) < 1e-6));
    }

    #[test]
    fn a_polygon_leaf_is_welded_with_uvs_along_its_midrib() {
        // A Weber–Penn style fan: centre, six outline points, the first repeated.
        let ring: Vec<Vec3> = (0..6)
            .map(|k| {
                let a = k as f32 / 6.0 * std::f32::consts::TAU;
                Vec3::new(0.3 * a.sin(), 0.5 - 0.5 * a.cos(), 0.0)
            })
            .collect();
        let mut fan = vec![Vec3::new(0.0, 0.5, 0.0)];
        fan.extend_from_slice(&ring);
        fan.push(ring[0]);
        let mut sk = Skeleton::new();
        sk.organs = vec![organ(OrganKind::Polygon(fan), 1.0)];
        let (m, _) = organ_mesh(&sk, &HashMap::new());
        m.validate().unwrap();
        // Six triangles around the centre, seven output vertices (the closing point is
        // the first one).
        assert_eq!(m.face_count(), 6);
        let unified = crate::export::unify(&m);
        assert_eq!(unified.vertices.len(), 7);
        // Base (0, 0, 0) → tip (0, 1, 0) runs along +v at u = 0.5.
        let uv = m.uvs.as_ref().unwrap();
        let uv_at = |p: Vec3| {
            let c = m.face_indices.iter().position(|&i| m.positions[i as usize] == p).unwrap();
            uv.values[uv.indices[c] as usize]
        };
        let (b, t) = (uv_at(ring[0]), uv_at(ring[3]));
        assert!((b - Vec2::new(0.5, 0.0)).length() < 1e-6 && (t - Vec2::new(0.5, 1.0)).length() < 1e-6);
    }

    #[test]
    fn degenerate_polygons_are_skipped() {
        let mut sk = Skeleton::new();
        sk.organs = vec![organ(OrganKind::Polygon(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0]), 1.0)];
        let (m, _) = organ_mesh(&sk, &HashMap::new());
        assert_eq!(m.face_count(), 0);
    }
}
