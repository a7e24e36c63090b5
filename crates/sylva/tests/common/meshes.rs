//! Mesh fixtures shared by the integration tests (included with `#[path]`, so each test
//! file compiles only this module).
#![allow(dead_code)]

use glam::Vec3;
use sylva::Mesh;

/// A mesh with `positions` and one face per index list.
pub fn mesh_from<F: AsRef<[u32]>>(positions: Vec<Vec3>, faces: &[F]) -> Mesh {
    let mut m = Mesh::new();
    m.positions = positions;
    for f in faces {
        m.push_face(f.as_ref());
    }
    m
}

/// The cube [−1, 1]³ of six quads, counter-clockwise from outside; vertex `i` sits at
/// `(i & 1, i >> 1 & 1, i >> 2 & 1) · 2 − 1`.
pub fn cube() -> Mesh {
    let p =
        (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) * 2.0 - 1.0);
    mesh_from(
        p.collect(),
        &[[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]],
    )
}

/// The regular tetrahedron on alternate corners of [−1, 1]³, outward.
pub fn tetrahedron() -> Mesh {
    mesh_from(
        vec![
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(-1.0, -1.0, 1.0),
        ],
        &[[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]],
    )
}

/// The octahedron with vertices ±X, ±Y, ±Z (in that order), outward.
pub fn octahedron() -> Mesh {
    let p = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let f = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    mesh_from(p, &f)
}
