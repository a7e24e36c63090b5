//! The mesh stage's peak memory, estimated before it is reached (issue 39: a skeleton of
//! half a million internodes made a 5 GB bark mesh and aborted in the flat-base cut).
//!
//! The stages after meshing (the flat-base cut of [`super::ground`], which rebuilds the
//! mesh; the exporters' smooth normals, vertex splitting and buffers; the GLB's bytes;
//! the preview) hold at most [`DOWNSTREAM_FACTOR`] times the bark mesh's own arrays at
//! once, besides the textures (at most [`TEXEL_BYTES`] a texel of the bark maps and the
//! leaf atlas, whatever the tree). The pipeline checks that product against `mesh.max_memory` twice: before
//! meshing, from a lower bound on the mesh the skeleton makes ([`lower_bound_bytes`]),
//! so a skeleton far too large never reaches the mesher, and after meshing (and
//! refinement), from the mesh's true size ([`mesh_bytes`]), before the cut. The
//! subdivision has its own, finer budget ([`crate::refine::peak_memory`]).

use crate::geometry::Mesh;

/// Default `mesh.max_memory`: 4 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 4 << 30;

/// Peak bytes of the stages after meshing, as a multiple of [`mesh_bytes`] of the bark.
/// Measured with a counting allocator (`tests/robustness_memory.rs`): growing and
/// exporting the Honda tree `lsys-honda-a` peaks at 5.2 times its bark's bytes at 12 and
/// 14 derivation steps (the textures a small part); 6 leaves room for leaves and organs.
pub const DOWNSTREAM_FACTOR: u128 = 6;

/// Bytes per texel of the bark maps and the leaf atlas at the pipeline's peak: a tree
/// with a small bark (`lsys-binary-tree`, 0.7 MB) peaks at 23 MB with the default
/// 1024² maps, 5.5 bytes per texel.
pub const TEXEL_BYTES: u128 = 8;

/// Bytes held by `mesh`'s arrays (their lengths, not their capacities).
pub fn mesh_bytes(mesh: &Mesh) -> u128 {
    let len = |n: usize, size: usize| n as u128 * size as u128;
    let mut bytes = len(mesh.positions.len(), 12)
        + len(mesh.face_offsets.len(), 4)
        + len(mesh.face_indices.len(), 4)
        + len(mesh.creases.len(), std::mem::size_of::<crate::geometry::Crease>());
    if let Some(uv) = &mesh.uvs {
        bytes += len(uv.values.len(), 8) + len(uv.indices.len(), 4);
    }
    if let Some(n) = &mesh.normals {
        bytes += len(n.values.len(), 12) + len(n.indices.len(), 4);
    }
    bytes
}

/// A lower bound on [`mesh_bytes`] of the bark a skeleton of `internodes` internodes
/// makes with rings of `sides` vertices: every internode adds at least one ring of
/// `sides` vertices and `sides` quads between it and the ring before, with a UV per
/// vertex (12 + 8 bytes a vertex; 4 + 4 × 4 + 4 × 4 bytes a quad). Every mesher makes
/// at least that much (the tube mesher about 2.5 times as much).
pub fn lower_bound_bytes(internodes: usize, sides: u32) -> u128 {
    internodes as u128 * sides.max(3) as u128 * (12 + 8 + 4 + 16 + 16)
}

/// The estimated peak bytes after meshing a bark mesh of `bytes` bytes with the textures
/// `textures` asks for (three bark maps and the leaf atlas; see the module docs).
pub fn downstream_peak(bytes: u128, textures: &crate::texture::TextureOptions) -> u128 {
    let square = |edge: u32| edge as u128 * edge as u128;
    let texels = 3 * square(textures.bark_size) + square(textures.atlas_size);
    bytes.saturating_mul(DOWNSTREAM_FACTOR).saturating_add(texels * TEXEL_BYTES)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quad_with_uvs_is_counted_array_by_array() {
        let mut m = Mesh::new();
        m.positions = vec![glam::Vec3::ZERO; 4];
        m.face_indices = vec![0, 1, 2, 3];
        m.face_offsets = vec![0, 4];
        m.uvs = Some(crate::geometry::FaceVarying {
            values: vec![glam::Vec2::ZERO; 4],
            indices: vec![0, 1, 2, 3],
        });
        assert_eq!(mesh_bytes(&m), 4 * 12 + 2 * 4 + 4 * 4 + 4 * 8 + 4 * 4);
        let t = crate::texture::TextureOptions { bark_size: 16, atlas_size: 32, ..Default::default() };
        assert_eq!(downstream_peak(mesh_bytes(&m), &t), 6 * mesh_bytes(&m) + (3 * 256 + 1024) * 8);
        assert_eq!(lower_bound_bytes(0, 8), 0);
        assert_eq!(lower_bound_bytes(2, 8), 2 * lower_bound_bytes(1, 8));
    }
}
