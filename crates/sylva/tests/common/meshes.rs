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

/// Torus of n×m quads (or 2nm triangles, each quad split along its (i, j)–(i+1, j+1)
/// diagonal), radii 2 and 0.7; vertex (i, j) at index i·m + j, ring `i` around the big
/// circle.
pub fn torus(n: u32, m: u32, tris: bool) -> Mesh {
    let mut pos = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b) =
                (i as f32 / n as f32 * std::f32::consts::TAU, j as f32 / m as f32 * std::f32::consts::TAU);
            let r = 2.0 + 0.7 * b.cos();
            pos.push(Vec3::new(r * a.cos(), 0.7 * b.sin(), r * a.sin()));
        }
    }
    let id = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut faces = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            if tris {
                faces.push(vec![a, b, c]);
                faces.push(vec![a, c, d]);
            } else {
                faces.push(vec![a, b, c, d]);
            }
        }
    }
    mesh_from(pos, &faces)
}
