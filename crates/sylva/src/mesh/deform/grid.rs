//! The (v, θ) grids of several LODs sharing one vertex list (Skjermo2008 D §2.3) and the
//! CPU mesher that deforms one grid per record into a [`Mesh`](crate::Mesh).

use super::bend::Deformer;
use super::record::BranchRecord;
use super::{DeformError, DEFAULT_LODS};
use crate::geometry::{FaceVarying, Mesh};
use glam::Vec2;
use std::fmt::Debug;

// ---------------------------------------------------------------------------------------
// Grids (D §2.3) and the CPU mesher.

/// One vertex of an input grid (16 bytes, `#[repr(C)]`; WGSL `struct { v: f32, theta:
/// f32, uv: vec2<f32> }`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridVertex {
    /// Position along the branch, 0 at P₀, 1 at P₃.
    pub v: f32,
    /// Angle around the branch in [0, 2π); the seam column repeats θ = 0.
    pub theta: f32,
    /// Texture coordinates: (θ/2π, v), u = 1 on the seam column.
    pub uv: Vec2,
}

/// Where one LOD grid lies in [`Grids`]' shared vertex and index lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GridLod {
    /// Rings of vertices along v (v = i / (rings − 1)).
    pub rings: u32,
    /// Quads around the branch (θ = 2π j / sides); each ring has `sides + 1` vertices.
    pub sides: u32,
    /// First vertex in [`Grids::vertices`].
    pub first_vertex: u32,
    /// `rings × (sides + 1)`.
    pub vertex_count: u32,
    /// First index in [`Grids::indices`].
    pub first_index: u32,
    /// `6 (rings − 1) sides`.
    pub index_count: u32,
}

/// Several (v, θ) grids sharing one vertex list and one index list (D §2.3: one VBO, one
/// index range per LOD): a triangle list, counter-clockwise seen from outside, indices
/// absolute into [`Grids::vertices`] (draw with base vertex 0). Within a level vertices
/// run ring by ring from v = 0, each ring from θ = 0 to the seam column (θ stored as 0
/// again so the seam's positions coincide bit for bit with the first column's, texture u
/// = 1). Quad (i, j) is the triangles (i,j) (i,j+1) (i+1,j+1) and (i,j) (i+1,j+1) (i+1,j).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Grids {
    /// Every level's vertices.
    pub vertices: Vec<GridVertex>,
    /// Every level's triangles.
    pub indices: Vec<u32>,
    /// The levels, in the order asked for.
    pub lods: Vec<GridLod>,
}

impl Grids {
    /// The grids of `levels`, each `(rings, sides)` with rings ≥ 2 and sides ≥ 3. Keep
    /// the bulge count below half the finest level's rings − 1 and the lobe count below
    /// half its sides (D §3.2.3).
    pub fn new(levels: &[(u32, u32)]) -> Result<Grids, DeformError> {
        let mut g = Grids::default();
        for &(rings, sides) in levels {
            if rings < 2 || sides < 3 {
                return Err(DeformError::Grid { rings, sides });
            }
            let first_vertex = g.vertices.len() as u32;
            let first_index = g.indices.len() as u32;
            let cols = sides + 1;
            for i in 0..rings {
                let v = i as f32 / (rings - 1) as f32;
                for j in 0..cols {
                    let along = j as f32 / sides as f32;
                    let theta = if j == sides { 0.0 } else { along * std::f32::consts::TAU };
                    g.vertices.push(GridVertex { v, theta, uv: Vec2::new(along, v) });
                }
            }
            for i in 0..rings - 1 {
                for j in 0..sides {
                    let at = |i: u32, j: u32| first_vertex + i * cols + j;
                    let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
                    g.indices.extend_from_slice(&[a, b, c, a, c, d]);
                }
            }
            g.lods.push(GridLod {
                rings,
                sides,
                first_vertex,
                vertex_count: rings * cols,
                first_index,
                index_count: 6 * (rings - 1) * sides,
            });
        }
        Ok(g)
    }

    /// The [`DEFAULT_LODS`] grids.
    pub fn standard() -> Grids {
        Grids::new(&DEFAULT_LODS).expect("the default levels are valid")
    }

    /// The vertices of level `lod`.
    pub fn lod_vertices(&self, lod: usize) -> &[GridVertex] {
        let l = &self.lods[lod];
        &self.vertices[l.first_vertex as usize..(l.first_vertex + l.vertex_count) as usize]
    }

    /// The indices of level `lod` (absolute into [`Grids::vertices`]).
    pub fn lod_indices(&self, lod: usize) -> &[u32] {
        let l = &self.lods[lod];
        &self.indices[l.first_index as usize..(l.first_index + l.index_count) as usize]
    }
}

/// A single grid of `rings` rings and `sides` sides (see [`Grids::new`]).
pub fn grid(rings: u32, sides: u32) -> Result<Grids, DeformError> {
    Grids::new(&[(rings, sides)])
}

/// Every record deformed over level `lod` of `grids` (the coarsest level where `lod` is
/// past the last; an empty mesh when there are no levels), as the GPU's instanced draw
/// will show them: per record the level's vertices in order (seam column included, so the
/// mesh is open along the seam), its triangles, per-vertex UVs and normals as
/// face-varying channels indexed like the faces.
pub fn branch_mesh(records: &[BranchRecord], grids: &Grids, lod: usize) -> Mesh {
    let mut mesh = Mesh::new();
    if grids.lods.is_empty() {
        return mesh;
    }
    let lod = lod.min(grids.lods.len() - 1);
    let level = grids.lods[lod];
    let (verts, idx) = (grids.lod_vertices(lod), grids.lod_indices(lod));
    let n = records.len() * verts.len();
    mesh.positions.reserve(n);
    let (mut normals, mut uvs) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for rec in records {
        let d = Deformer::new(rec);
        let base = mesh.positions.len() as u32;
        for gv in verts {
            let s = d.evaluate(gv.v, gv.theta);
            mesh.positions.push(s.position);
            normals.push(s.normal);
            uvs.push(gv.uv);
        }
        for tri in idx.chunks_exact(3) {
            mesh.push_face(&[tri[0], tri[1], tri[2]].map(|i| i - level.first_vertex + base));
        }
    }
    mesh.uvs = Some(FaceVarying { values: uvs, indices: mesh.face_indices.clone() });
    mesh.normals = Some(FaceVarying { values: normals, indices: mesh.face_indices.clone() });
    mesh
}
