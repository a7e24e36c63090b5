//! The model's parts as GPU vertex and index streams (issue 25 item 4; Skjermo2008 §4):
//! each part's faces fan-triangulated from their first corner (as the CPU preview does),
//! corners with the same (position, normal, UV) shared, triangles grouped by material,
//! with the skin's joints and weights per vertex for GPU skinning.

use bytemuck::{Pod, Zeroable};
use std::collections::HashMap;
use sylva::model::{Material, Part};

/// One vertex as the mesh pipeline reads it (56 bytes; locations 0–4 of `mesh.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    /// Position, model space (metres).
    pub position: [f32; 3],
    /// Unit normal (the face's normal where the mesh has none).
    pub normal: [f32; 3],
    /// Texture coordinate, mesh convention (origin bottom left, v up).
    pub uv: [f32; 2],
    /// Joint indices (`JOINTS_0`), into the rig's joints.
    pub joints: [u16; 4],
    /// Joint weights (`WEIGHTS_0`); all zero for a vertex that does not move.
    pub weights: [f32; 4],
}

/// Triangles of one material: `count` indices from `first` in the part's index stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Group {
    /// Index of the material among the part's (0: [`Part::material`], `k`:
    /// `extra_materials[k − 1]`).
    pub material: usize,
    /// First index.
    pub first: u32,
    /// Number of indices (3 per triangle).
    pub count: u32,
}

/// A part's GPU streams, built on the CPU.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshData {
    /// Shared vertices.
    pub vertices: Vec<Vertex>,
    /// Triangle indices, grouped by material.
    pub indices: Vec<u32>,
    /// The material groups, in material order.
    pub groups: Vec<Group>,
}

/// The material of a face index among the part's materials (0 unless
/// [`Part::face_materials`] says otherwise; out-of-range indices fall back to 0).
fn face_material(part: &Part, f: usize) -> usize {
    let k = part.face_materials.get(f).copied().unwrap_or(0) as usize;
    if k <= part.extra_materials.len() {
        k
    } else {
        0
    }
}

/// The part's materials in order: [`Part::material`] then its extras.
pub fn part_materials(part: &Part) -> Vec<&Material> {
    std::iter::once(&part.material).chain(&part.extra_materials).collect()
}

/// Builds `part`'s streams. Faces with fewer than three corners are skipped; the caller
/// validates the mesh first ([`sylva::Mesh::validate`]).
pub fn mesh_data(part: &Part) -> MeshData {
    let m = &part.mesh;
    let normals = m.normals.as_ref().filter(|n| n.indices.len() == m.face_indices.len());
    let uvs = m.uvs.as_ref().filter(|u| u.indices.len() == m.face_indices.len());
    let skin = part.skin.as_ref();
    let mut out = MeshData::default();
    let mut shared: HashMap<(u32, u32, u32), u32> = HashMap::new();
    let nmat = part.extra_materials.len() + 1;
    let mut per_material: Vec<Vec<u32>> = vec![Vec::new(); nmat];
    for f in 0..m.face_count() {
        let corners = m.corners(f);
        if corners.len() < 3 {
            continue;
        }
        let c0 = corners.start;
        // Flat shading where the mesh has no normals: the face's first triangle's normal.
        let flat = if normals.is_none() {
            let p = |c: usize| m.positions[m.face_indices[c] as usize];
            (p(c0 + 1) - p(c0)).cross(p(c0 + 2) - p(c0)).normalize_or_zero()
        } else {
            glam::Vec3::ZERO
        };
        let mut vertex = |c: usize| -> u32 {
            let v = m.face_indices[c];
            let n = normals.map_or(u32::MAX - f as u32, |n| n.indices[c]);
            let t = uvs.map_or(u32::MAX, |u| u.indices[c]);
            *shared.entry((v, n, t)).or_insert_with(|| {
                let vi = v as usize;
                let normal = normals.map_or(flat, |nv| nv.values.get(n as usize).copied().unwrap_or(flat));
                let uv = uvs.and_then(|u| u.values.get(t as usize).copied()).unwrap_or_default();
                let (joints, weights) = skin
                    .and_then(|s| Some((*s.joints.get(vi)?, *s.weights.get(vi)?)))
                    .unwrap_or(([0; 4], [0.0; 4]));
                out.vertices.push(Vertex {
                    position: m.positions[vi].to_array(),
                    normal: normal.to_array(),
                    uv: uv.to_array(),
                    joints,
                    weights,
                });
                (out.vertices.len() - 1) as u32
            })
        };
        let mat = face_material(part, f);
        for c1 in c0 + 1..corners.end - 1 {
            let tri = [vertex(c0), vertex(c1), vertex(c1 + 1)];
            per_material[mat].extend(tri);
        }
    }
    for (material, idx) in per_material.into_iter().enumerate() {
        if idx.is_empty() {
            continue;
        }
        let first = out.indices.len() as u32;
        out.groups.push(Group { material, first, count: idx.len() as u32 });
        out.indices.extend(idx);
    }
    out
}

/// The unique edges of `data`'s triangles as a line-list index stream (two indices per
/// edge), for drawing a wireframe without `POLYGON_MODE_LINE` (which software and some
/// mobile adapters lack). Vertices at the same position (split by normal or UV seams)
/// count as one, so an edge shared by two faces is drawn once; each edge indexes the
/// first vertex at each of its ends.
/// `positions` are the vertices' (as [`Vertex::position`]), `indices` the triangles';
/// an index past the vertices is skipped.
pub fn edge_indices(positions: &[[f32; 3]], indices: &[u32]) -> Vec<u32> {
    let mut first_at: HashMap<[u32; 3], u32> = HashMap::new();
    let canonical: Vec<u32> = positions
        .iter()
        .enumerate()
        .map(|(i, p)| *first_at.entry(p.map(f32::to_bits)).or_insert(i as u32))
        .collect();
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    for tri in indices.chunks_exact(3) {
        for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
            let (Some(&a), Some(&b)) = (canonical.get(a as usize), canonical.get(b as usize)) else {
                continue;
            };
            if a != b && seen.insert((a.min(b), a.max(b))) {
                out.extend([a, b]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};
    use sylva::geometry::{FaceVarying, Mesh};
    use sylva::model::SkinWeights;

    #[test]
    fn quads_fan_into_triangles_sharing_corners_and_grouped_by_material() {
        let mut m = Mesh::new();
        m.positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::new(2.0, 0.0, 0.0)];
        m.face_indices = vec![0, 1, 2, 3, 1, 4, 2];
        m.face_offsets = vec![0, 4, 7];
        m.uvs = Some(FaceVarying { values: vec![Vec2::ZERO, Vec2::ONE], indices: vec![0, 0, 1, 1, 0, 0, 1] });
        let mut part = Part::new("p", m, Material::bark());
        part.face_materials = vec![1, 0];
        part.extra_materials = vec![Material::leaf()];
        part.skin =
            Some(SkinWeights { joints: vec![[1, 0, 0, 0]; 5], weights: vec![[1.0, 0.0, 0.0, 0.0]; 5] });
        let d = mesh_data(&part);
        assert_eq!(d.indices.len(), 9, "a quad and a triangle: three triangles");
        assert_eq!(
            d.groups,
            vec![Group { material: 0, first: 0, count: 3 }, Group { material: 1, first: 3, count: 6 }]
        );
        // Flat normals differ per face, so the shared edge's corners are not shared.
        assert_eq!(d.vertices.len(), 7);
        assert!(d.vertices.iter().all(|v| v.normal == [0.0, 0.0, 1.0] && v.joints[0] == 1));
        assert_eq!(std::mem::size_of::<Vertex>(), 56);
    }

    #[test]
    fn edges_are_unique_across_seams() {
        // A unit cube of six flat-shaded quads: 12 triangles whose corners are split by
        // normal (24 vertices), 12 cube edges plus one diagonal per face.
        let mut m = Mesh::new();
        m.positions =
            (0..8).map(|k| Vec3::new((k & 1) as f32, ((k >> 1) & 1) as f32, (k >> 2) as f32)).collect();
        let faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        for f in faces {
            m.face_indices.extend(f);
            m.face_offsets.push(m.face_indices.len() as u32);
        }
        let d = mesh_data(&Part::new("cube", m, Material::bark()));
        assert_eq!(d.vertices.len(), 24);
        let positions: Vec<[f32; 3]> = d.vertices.iter().map(|v| v.position).collect();
        let e = edge_indices(&positions, &d.indices);
        assert_eq!(e.len(), 2 * 18);
        let mut pairs: Vec<(u32, u32)> = e.chunks(2).map(|p| (p[0].min(p[1]), p[0].max(p[1]))).collect();
        pairs.sort_unstable();
        pairs.dedup();
        assert_eq!(pairs.len(), 18, "no edge twice");
    }
}
