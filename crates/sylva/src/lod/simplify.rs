//! Simplification of one part to a triangle budget with meshoptimizer (the `meshopt`
//! crate): `simplifyWithAttributes` (normals and UVs weighted, borders locked), then
//! `simplifySloppy` when topology stops it short of the target; then the vertex cache
//! and vertex fetch orders. Face-varying UVs and normals come through unchanged (every
//! output corner keeps an input corner's values), so seams stay exact.

use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use meshopt::SimplifyOptions;

/// How a part reached its triangle count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Already within its target: triangulated and reordered only.
    Kept,
    /// `meshopt::simplify_with_attributes_and_locks` (locked borders).
    Simplified,
    /// `meshopt::simplify_sloppy` (the topology-preserving pass stopped short).
    Sloppy,
}

/// Triangles, vertex-cache-ordered, as corners into a unified vertex list, with each
/// vertex's position, UV and normal index.
struct Triangles {
    /// Three vertices per triangle.
    indices: Vec<u32>,
    /// Per vertex: (position, uv, normal) indices of the mesh (`u32::MAX`: none).
    keys: Vec<[u32; 3]>,
}

/// The mesh's faces fanned into triangles over its distinct (position, UV, normal)
/// corner tuples.
fn triangles(mesh: &Mesh) -> Triangles {
    let u = crate::export::unify(mesh);
    let keys = u.vertices.iter().map(|k| [k.position, k.uv, k.normal]).collect();
    let mut indices = Vec::with_capacity(mesh.triangle_count() * 3);
    for cs in mesh.fan_corners() {
        indices.extend(cs.map(|c| u.corner_vertex[c]));
    }
    Triangles { indices, keys }
}

/// Simplifies `mesh` to about `target` triangles (nothing is removed when it has no
/// more), as a triangle mesh in vertex-cache order with its positions, UVs and normals
/// in first-use (vertex-fetch) order. Errors: a mesh that fails [`Mesh::validate`].
pub fn simplify(mesh: &Mesh, target: usize, what: &str) -> Result<(Mesh, Method)> {
    mesh.validate().map_err(|why| Error::InvalidGeometry { what: what.to_owned(), why })?;
    let t = triangles(mesh);
    let count = t.indices.len() / 3;
    let positions: Vec<[f32; 3]> = t.keys.iter().map(|k| mesh.positions[k[0] as usize].to_array()).collect();
    let (mut indices, method) = if count <= target {
        (t.indices, Method::Kept)
    } else {
        // Attributes: the normal (weight 0.5) and the UV (0.05: bark UVs run to many
        // units along a branch, and a seam is kept anyway).
        let mut attrs = Vec::with_capacity(t.keys.len() * 5);
        for k in &t.keys {
            let n =
                mesh.normals.as_ref().and_then(|c| c.values.get(k[2] as usize)).copied().unwrap_or_default();
            let uv = mesh.uvs.as_ref().and_then(|c| c.values.get(k[1] as usize)).copied().unwrap_or_default();
            attrs.extend([n.x, n.y, n.z, uv.x, uv.y]);
        }
        let weights = [0.5, 0.5, 0.5, 0.05, 0.05];
        let locks = vec![false; t.keys.len()];
        let goal = target * 3;
        let fine = meshopt::simplify_with_attributes_and_locks_decoder(
            &t.indices,
            &positions,
            &attrs,
            &weights,
            5 * std::mem::size_of::<f32>(),
            &locks,
            goal,
            1e3,
            SimplifyOptions::LockBorder,
            None,
        );
        if fine.len() as f64 <= goal as f64 * 1.05 {
            (fine, Method::Simplified)
        } else {
            let sloppy = meshopt::simplify_sloppy_decoder(&t.indices, &positions, goal, 1e3, None);
            // Sloppy stops at or under the target; keep whichever is nearer to it.
            if (sloppy.len() as f64 - goal as f64).abs() < (fine.len() as f64 - goal as f64).abs() {
                (sloppy, Method::Sloppy)
            } else {
                (fine, Method::Simplified)
            }
        }
    };
    meshopt::optimize_vertex_cache_in_place(&mut indices, t.keys.len());
    Ok((rebuild(mesh, &t.keys, &indices), method))
}

/// The triangle mesh of `indices` over vertices `keys` of `mesh`, with positions, UVs
/// and normals numbered in order of first use (meshoptimizer's vertex-fetch order).
fn rebuild(mesh: &Mesh, keys: &[[u32; 3]], indices: &[u32]) -> Mesh {
    use crate::geometry::NONE;
    let mut out = Mesh::new();
    let mut map = [vec![NONE; mesh.positions.len()], Vec::new(), Vec::new()];
    let mut uvs = mesh.uvs.as_ref().map(|c| {
        map[1] = vec![NONE; c.values.len()];
        FaceVarying { values: Vec::new(), indices: Vec::with_capacity(indices.len()) }
    });
    let mut normals = mesh.normals.as_ref().map(|c| {
        map[2] = vec![NONE; c.values.len()];
        FaceVarying { values: Vec::new(), indices: Vec::with_capacity(indices.len()) }
    });
    out.face_indices.reserve(indices.len());
    for tri in indices.chunks_exact(3) {
        for &v in tri {
            let k = keys[v as usize];
            let p = &mut map[0][k[0] as usize];
            if *p == NONE {
                *p = out.positions.len() as u32;
                out.positions.push(mesh.positions[k[0] as usize]);
            }
            out.face_indices.push(*p);
            if let (Some(fv), Some(src)) = (uvs.as_mut(), mesh.uvs.as_ref()) {
                let m = &mut map[1][k[1] as usize];
                if *m == NONE {
                    *m = fv.values.len() as u32;
                    fv.values.push(src.values[k[1] as usize]);
                }
                fv.indices.push(*m);
            }
            if let (Some(fv), Some(src)) = (normals.as_mut(), mesh.normals.as_ref()) {
                let m = &mut map[2][k[2] as usize];
                if *m == NONE {
                    *m = fv.values.len() as u32;
                    fv.values.push(src.values[k[2] as usize]);
                }
                fv.indices.push(*m);
            }
        }
        out.face_offsets.push(out.face_indices.len() as u32);
    }
    out.uvs = uvs;
    out.normals = normals;
    out
}

/// Simplifies `mesh` as far as meshoptimizer can while no vertex moves more than
/// `error` (metres, absolute), borders locked; the result in vertex-cache order. For the
/// impostor's views, where what is smaller than a pixel cannot be seen.
pub fn simplify_within(mesh: &Mesh, error: f32, what: &str) -> Result<Mesh> {
    mesh.validate().map_err(|why| Error::InvalidGeometry { what: what.to_owned(), why })?;
    let t = triangles(mesh);
    let positions: Vec<[f32; 3]> = t.keys.iter().map(|k| mesh.positions[k[0] as usize].to_array()).collect();
    let mut indices = meshopt::simplify_decoder(
        &t.indices,
        &positions,
        0,
        error.max(0.0),
        SimplifyOptions::LockBorder | SimplifyOptions::ErrorAbsolute,
        None,
    );
    meshopt::optimize_vertex_cache_in_place(&mut indices, t.keys.len());
    Ok(rebuild(mesh, &t.keys, &indices))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tube::{tube_mesh, TubeOptions};
    use crate::skeleton::{Skeleton, NO_PARENT};
    use glam::Vec3;

    fn branch() -> Mesh {
        let mut s = Skeleton::new();
        let mut p = s.push(Vec3::ZERO, 0.2, NO_PARENT, Vec3::X, 0);
        for k in 1..40 {
            let t = k as f32 / 40.0;
            p = s.push(Vec3::new((t * 6.0).sin() * 0.5, t * 4.0, 0.0), 0.2 * (1.0 - t) + 0.02, p, Vec3::X, 0);
        }
        tube_mesh(&s, &TubeOptions { sides: 12, ..Default::default() }).unwrap().mesh
    }

    #[test]
    fn a_tube_reaches_its_target_and_keeps_valid_channels() {
        let m = branch();
        let before = m.triangle_count();
        let (out, method) = simplify(&m, before / 5, "test").unwrap();
        out.validate().unwrap();
        let after = out.triangle_count();
        assert!(
            (after as f64 - (before / 5) as f64).abs() <= 0.1 * (before / 5) as f64,
            "{before} → {after}"
        );
        assert_ne!(method, Method::Kept);
        assert_eq!(out.uvs.is_some(), m.uvs.is_some());
        assert_eq!(out.normals.is_some(), m.normals.is_some());
        if let Some(n) = &out.normals {
            assert!(n.values.iter().all(|v| (v.length() - 1.0).abs() < 1e-3));
        }
        // Every position is used, in first-use order.
        assert_eq!(out.face_indices.iter().max().map(|&i| i as usize + 1), Some(out.positions.len()));
        let (same, kept) = simplify(&m, before, "test").unwrap();
        assert_eq!((same.triangle_count(), kept), (before, Method::Kept));
        let (again, _) = simplify(&m, before / 5, "test").unwrap();
        assert_eq!(again, out, "deterministic");
    }
}
