//! PN triangles and PN quads (`sylva::refine::pn`, Skjermo2008 §3.3.1, Skjermo2008-spec §5 and test
//! 25): patches interpolate their corners and corner normals, Eq. 3.1/3.2 control points lie
//! in the corner's tangent plane, a flat patch with matching normals stays flat, and
//! neighbouring patches share identical edge vertices (no cracks).

use glam::{Vec2, Vec3};
use std::collections::HashSet;
use sylva::geometry::{FaceVarying, Mesh};
use sylva::refine::pn::{
    control_point, pn_tessellate, smooth_vertex_normals, EdgeRule, NormalSource, PnOptions,
};
use sylva::refine::Topology;
#[path = "common/meshes.rs"]
mod meshes;
use meshes::{cube, mesh_from, octahedron};
#[path = "common/pn_options.rs"]
mod pn_options;
use pn_options::all_options;

/// A cube whose top face is split into two triangles: quads and triangles side by side.
fn mixed() -> Mesh {
    let mut m = cube();
    let top = m.face(3).to_vec(); // [2, 6, 7, 3]
    let mut out = Mesh::new();
    out.positions = m.positions.clone();
    for f in 0..m.face_count() {
        if f == 3 {
            out.push_face(&[top[0], top[1], top[2]]);
            out.push_face(&[top[0], top[2], top[3]]);
        } else {
            out.push_face(m.face(f));
        }
    }
    m = out;
    m
}

fn topology(m: &Mesh) -> Topology {
    Topology::from_faces(m.vertex_count(), &m.face_offsets, &m.face_indices).expect("manifold, oriented")
}

#[test]
fn control_points_lie_in_the_tangent_plane() {
    // Skjermo2008-spec test 25: (C − Pᵢ)·Nᵢ = 0 for Eq. 3.1 and Eq. 3.2.
    let (pi, pj) = (Vec3::new(0.3, -1.0, 2.0), Vec3::new(1.7, 0.4, 1.1));
    let ni = Vec3::new(0.2, 0.9, -0.3).normalize();
    for rule in [EdgeRule::Standard, EdgeRule::Rounder] {
        let c = control_point(pi, ni, pj, rule);
        assert!((c - pi).dot(ni).abs() < 1e-6, "{rule:?}");
    }
    // With the normal perpendicular to the edge, the points are at ⅓ and ½.
    let n = Vec3::Z;
    assert!((control_point(Vec3::ZERO, n, Vec3::X * 3.0, EdgeRule::Standard) - Vec3::X).length() < 1e-6);
    assert!((control_point(Vec3::ZERO, n, Vec3::X * 3.0, EdgeRule::Rounder) - Vec3::X * 1.5).length() < 1e-6);
}

#[test]
fn patches_interpolate_corners_and_corner_normals() {
    for m in [cube(), octahedron(), mixed()] {
        let normals = smooth_vertex_normals(&m);
        for opts in all_options(5) {
            let out = pn_tessellate(&m, &opts).unwrap();
            let key = |p: &Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            let have: HashSet<_> = out.positions.iter().map(key).collect();
            for p in &m.positions {
                assert!(have.contains(&key(p)), "corner {p} missing ({opts:?})");
            }
            let on = out.normals.as_ref().unwrap();
            for (c, &v) in out.face_indices.iter().enumerate() {
                let p = out.positions[v as usize];
                if let Some(i) = m.positions.iter().position(|q| *q == p) {
                    let n = on.values[on.indices[c] as usize];
                    assert!((n - normals[i]).length() < 1e-5, "corner normal {n} vs {}", normals[i]);
                }
            }
        }
    }
}

#[test]
fn counts_per_level() {
    let m = mixed(); // 5 quads, 2 triangles
    for level in 1..=6u32 {
        let out = pn_tessellate(&m, &PnOptions { level, ..Default::default() }).unwrap();
        assert_eq!(out.face_count() as u32, 7 * level * level);
        let quads = (0..out.face_count()).filter(|&f| out.face(f).len() == 4).count() as u32;
        assert_eq!(quads, 5 * level * level);
    }
}

#[test]
fn flat_patches_with_matching_normals_stay_flat() {
    // A plane z = 0.5 with quads and triangles, UVs, and normals +z.
    let mut m = mesh_from(
        vec![
            Vec3::new(0.0, 0.0, 0.5),
            Vec3::new(1.0, 0.0, 0.5),
            Vec3::new(2.0, 0.2, 0.5),
            Vec3::new(0.0, 1.0, 0.5),
            Vec3::new(1.1, 1.0, 0.5),
            Vec3::new(2.0, 1.3, 0.5),
        ],
        &[vec![0, 1, 4, 3], vec![1, 2, 5], vec![1, 5, 4]],
    );
    m.uvs = Some(FaceVarying {
        values: m.positions.iter().map(|p| Vec2::new(p.x, p.y)).collect(),
        indices: m.face_indices.clone(),
    });
    for source in [NormalSource::Smooth, NormalSource::Mesh] {
        let mut m = m.clone();
        if source == NormalSource::Mesh {
            m.normals = Some(FaceVarying { values: vec![Vec3::Z], indices: vec![0; m.face_indices.len()] });
        }
        for mut opts in all_options(7) {
            opts.source = source;
            let out = pn_tessellate(&m, &opts).unwrap();
            for p in &out.positions {
                assert!((p.z - 0.5).abs() < 1e-6, "{p} ({opts:?})");
            }
            let n = out.normals.as_ref().unwrap();
            assert!(n.values.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
            // UVs interpolate linearly, so on a plane they equal (x, y) wherever the patch
            // is an affine map: the ⅓ rule, Theyer interior (the bilinear quad is not
            // affine, but its corners are).
            let uv = out.uvs.as_ref().unwrap();
            assert_eq!(uv.indices.len(), out.face_indices.len());
            assert!(uv.values.iter().all(|v| v.is_finite()));
            assert_conforming(&m, &out);
        }
    }
}

/// Same Euler characteristic and boundary-loop count, manifold and oriented.
fn assert_conforming(input: &Mesh, out: &Mesh) {
    let (t0, t) = (topology(input), topology(out));
    let chi = |t: &Topology| t.vertex_count() as i64 - t.edge_count() as i64 + t.face_count() as i64;
    assert_eq!(chi(&t), chi(&t0));
    let open = |t: &Topology| (0..t.edge_count()).filter(|&e| t.is_boundary_edge(e)).count();
    if open(&t0) == 0 {
        assert_eq!(open(&t), 0, "closed stays closed");
    } else {
        assert_eq!(open(&t), open(&t0) * out_level(input, out), "boundary edges split `level` times");
    }
}

fn out_level(input: &Mesh, out: &Mesh) -> usize {
    let per_face = out.face_count() as f64 / input.faces_as_triangles_or_quads() as f64;
    per_face.sqrt().round() as usize
}

trait Patches {
    fn faces_as_triangles_or_quads(&self) -> usize;
}

impl Patches for Mesh {
    fn faces_as_triangles_or_quads(&self) -> usize {
        (0..self.face_count()).map(|f| if self.face(f).len() == 4 { 1 } else { self.face(f).len() - 2 }).sum()
    }
}

#[test]
fn no_cracks_between_patches() {
    for m in [cube(), octahedron(), mixed()] {
        for opts in all_options(6) {
            let out = pn_tessellate(&m, &opts).unwrap();
            assert_conforming(&m, &out);
        }
    }
}

#[test]
fn edge_points_depend_only_on_the_edge() {
    // Tessellate a triangle and a quad that share the edge 0–1 *separately*: the samples
    // along that edge coincide bit for bit (so welded meshes cannot crack).
    let p = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.1, 0.2),
        Vec3::new(0.4, 1.0, 0.5),
        Vec3::new(0.6, -1.0, 0.3),
    ];
    let n = [Vec3::new(0.1, 0.2, 1.0).normalize(), Vec3::new(-0.3, 0.1, 1.0).normalize()];
    let tri = {
        let mut m = mesh_from(vec![p[0], p[1], p[2]], &[vec![0, 1, 2]]);
        m.normals = Some(FaceVarying { values: vec![n[0], n[1], Vec3::Z], indices: vec![0, 1, 2] });
        m
    };
    let quad = {
        let mut m = mesh_from(vec![p[1], p[0], p[3], p[3] + Vec3::X], &[vec![0, 1, 2, 3]]);
        m.normals =
            Some(FaceVarying { values: vec![n[1], n[0], Vec3::Y, Vec3::Z], indices: vec![0, 1, 2, 3] });
        m
    };
    // Interior samples of two different patches never coincide, so the shared points
    // are exactly the edge's.
    let all = |m: &Mesh| -> HashSet<[u32; 3]> {
        m.positions.iter().map(|q| [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()]).collect()
    };
    for opts in all_options(8) {
        let (t, q) = (pn_tessellate(&tri, &opts).unwrap(), pn_tessellate(&quad, &opts).unwrap());
        let (et, eq) = (all(&t), all(&q));
        let shared = et.intersection(&eq).count();
        assert_eq!(shared, 9, "all 9 samples of the shared edge coincide ({opts:?})");
    }
}

#[test]
fn pn_rounds_an_octahedron_towards_its_sphere() {
    // Radial normals: PN moves the faces out towards the unit sphere; the rounder rule
    // bulges further than the standard one.
    let m = octahedron();
    let mean_r = |o: &Mesh| o.positions.iter().map(|p| p.length()).sum::<f32>() / o.positions.len() as f32;
    let std = pn_tessellate(&m, &PnOptions { level: 8, edge_rule: EdgeRule::Standard, ..Default::default() })
        .unwrap();
    let round =
        pn_tessellate(&m, &PnOptions { level: 8, edge_rule: EdgeRule::Rounder, ..Default::default() })
            .unwrap();
    // The flat octahedron's face centres are at 1/√3 ≈ 0.577.
    assert!(mean_r(&std) > 0.8, "{}", mean_r(&std));
    assert!(mean_r(&round) > mean_r(&std));
    assert!(std.positions.iter().all(|p| p.length() < 1.2));
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let m = cube();
    assert!(pn_tessellate(&m, &PnOptions { level: 0, ..Default::default() }).is_err());
    assert!(pn_tessellate(&m, &PnOptions { level: 100_000, ..Default::default() }).is_err());
    let mut bad = cube();
    bad.face_indices[0] = 77;
    assert!(pn_tessellate(&bad, &PnOptions::default()).is_err());
    assert_eq!(pn_tessellate(&Mesh::new(), &PnOptions::default()).unwrap().face_count(), 0);
    // Degenerate geometry (coincident points, zero normals) gives finite output.
    let deg = mesh_from(vec![Vec3::ZERO; 4], &[vec![0, 1, 2, 3]]);
    let out = pn_tessellate(&deg, &PnOptions::default()).unwrap();
    assert!(out.positions.iter().all(|p| p.is_finite()));
    assert!(out.normals.unwrap().values.iter().all(|n| n.is_finite()));
    // Pentagons are fanned into PN triangles.
    let pent = mesh_from(
        (0..5).map(|i| Vec3::new((i as f32).cos(), (i as f32).sin(), 0.0)).collect(),
        &[vec![0, 1, 2, 3, 4]],
    );
    assert_eq!(pn_tessellate(&pent, &PnOptions { level: 2, ..Default::default() }).unwrap().face_count(), 12);
}
