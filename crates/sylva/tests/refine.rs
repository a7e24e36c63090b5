//! Properties of the subdivision engine (`sylva::refine`) from Pieterse2012-spec, MacMurchy2004-spec and Skjermo2008-spec:
//! counts, closedness, convex hull, crease curves, sharpness decay, analytic limit
//! surfaces, face-varying seams and determinism across thread counts.

use glam::{Vec2, Vec3};
use sylva::geometry::{Crease, FaceVarying, Mesh};
use sylva::refine::{
    loop_, subdivide, subdivide_traced, Corner, FvarInterpolation, RefineError, RefineOptions, Refiner,
    Scheme, SubdivideOptions, Topology,
};
#[path = "common/meshes.rs"]
mod meshes;
use meshes::{cube, mesh_from, octahedron, tetrahedron, torus};

// ---------------------------------------------------------------------------------------
// Meshes

/// (nx+1)×(ny+1) vertices, vertex (i, j) at index j·(nx+1) + i, quads counter-clockwise.
fn grid_quads(nx: u32, ny: u32, at: impl Fn(u32, u32) -> Vec3) -> Mesh {
    let w = nx + 1;
    let pos = (0..=ny).flat_map(|j| (0..=nx).map(move |i| (i, j))).map(|(i, j)| at(i, j)).collect();
    let mut faces = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let a = j * w + i;
            faces.push(vec![a, a + 1, a + w + 1, a + w]);
        }
    }
    mesh_from(pos, &faces)
}

/// Triangulated grid with diagonals along (1, 1): the three-direction mesh of Loop's
/// regular case (each quad of [`grid_quads`] fanned from its first corner).
fn grid_tris(nx: u32, ny: u32, at: impl Fn(u32, u32) -> Vec3) -> Mesh {
    triangulate(&grid_quads(nx, ny, at))
}

/// A triangle (0, 2, 1) and a pentagon (0, 1, 3, 4, 5) sharing the edge 0–1, in the
/// plane z = 0 but for vertex `i` lifted by `lift[i]`.
fn triangle_and_pentagon(lift: [f32; 6]) -> Mesh {
    let xy = [(0.0, 0.0), (1.0, 0.0), (0.5, -1.0), (1.5, 1.0), (0.5, 2.0), (-0.5, 1.0)];
    let pos = xy.iter().zip(lift).map(|(&(x, y), z)| Vec3::new(x, y, z)).collect();
    mesh_from(pos, &[vec![0, 2, 1], vec![0, 1, 3, 4, 5]])
}

/// Small deterministic pseudo-random numbers in [-1, 1].
fn noise(k: u32) -> f32 {
    let mut x = k.wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
    x ^= x >> 15;
    x = x.wrapping_mul(0x2C1B_3C6D);
    x ^= x >> 12;
    (x % 20001) as f32 / 10000.0 - 1.0
}

fn opts(scheme: Scheme, levels: u32) -> RefineOptions {
    RefineOptions { scheme, levels, ..Default::default() }
}

fn refine(mesh: &Mesh, scheme: Scheme, levels: u32) -> Mesh {
    let o = SubdivideOptions { refine: opts(scheme, levels), ..Default::default() };
    subdivide(mesh, &[], &o).unwrap()
}

fn edge_count(m: &Mesh) -> usize {
    Topology::from_faces(m.vertex_count(), &m.face_offsets, &m.face_indices).unwrap().edge_count()
}

/// Largest distance from a point of `a` to the nearest point of `b`, both ways (∞ when
/// some point has no neighbour within 0.01).
fn hausdorff(a: &[Vec3], b: &[Vec3]) -> f32 {
    let (a, b): (Vec<[f32; 3]>, Vec<[f32; 3]>) =
        (a.iter().map(|p| p.to_array()).collect(), b.iter().map(|p| p.to_array()).collect());
    max_nearest_both_ways(&a, &b, 0.01).unwrap_or(f32::INFINITY)
}

/// The boundary loop of `m` starting at vertex `start`, following boundary edges
/// counter-clockwise.
fn boundary_loop(m: &Mesh, start: u32) -> Vec<u32> {
    let t = Topology::from_faces(m.vertex_count(), &m.face_offsets, &m.face_indices).unwrap();
    // next boundary vertex: the end of the boundary edge leaving `v` in face order.
    let mut next = std::collections::HashMap::new();
    for f in 0..t.face_count() {
        let face = t.face(f);
        for k in 0..face.len() {
            let (a, b) = (face[k], face[(k + 1) % face.len()]);
            let e = t.find_edge(a, b).unwrap();
            if t.is_boundary_edge(e as usize) {
                next.insert(a, b);
            }
        }
    }
    let mut out = vec![start];
    let mut v = next[&start];
    while v != start {
        out.push(v);
        v = next[&v];
    }
    out
}

/// Cubic B-spline subdivision of a closed polygon; `pinned` points stay (corners).
fn curve_subdivide(p: &[Vec3], pinned: &[bool], levels: u32) -> Vec<Vec3> {
    let (mut p, mut pinned) = (p.to_vec(), pinned.to_vec());
    for _ in 0..levels {
        let n = p.len();
        let mut q = Vec::with_capacity(2 * n);
        let mut qp = Vec::with_capacity(2 * n);
        for i in 0..n {
            let (a, b, c) = (p[(i + n - 1) % n], p[i], p[(i + 1) % n]);
            q.push(if pinned[i] { b } else { (a + 6.0 * b + c) / 8.0 });
            qp.push(pinned[i]);
            q.push((b + c) / 2.0);
            qp.push(false);
        }
        p = q;
        pinned = qp;
    }
    p
}

// ---------------------------------------------------------------------------------------
// Counts, closedness, errors

#[test]
fn loop_beta_erratum() {
    assert_eq!(loop_::beta(3), 3.0 / 16.0);
    assert_eq!(loop_::beta(6), 1.0 / 16.0);
    assert!((loop_::beta(4) - 31.0 / 256.0).abs() < 1e-15);
}

#[test]
fn loop_counts_per_level() {
    let mut m = octahedron();
    for _ in 0..4 {
        let (v, e, f) = (m.vertex_count(), edge_count(&m), m.face_count());
        let c = refine(&m, Scheme::Loop, 1);
        assert_eq!(c.face_count(), 4 * f);
        assert_eq!(c.vertex_count(), v + e);
        assert_eq!(edge_count(&c), 2 * e + 3 * f);
        m = c;
    }
    assert_eq!(refine(&octahedron(), Scheme::Loop, 3).face_count(), 8 * 64);
}

/// Every refined face knows its control face: 4^L children per triangle under Loop; under
/// Catmull–Clark a quad has 4^L and a triangle 3·4^(L−1), numbered in face order.
#[test]
fn refined_faces_trace_back_to_their_control_face() {
    let opts = |scheme, levels| SubdivideOptions {
        refine: RefineOptions { scheme, levels, ..Default::default() },
        ..Default::default()
    };
    let (fine, up) = subdivide_traced(&octahedron(), &[], &opts(Scheme::Loop, 2)).unwrap();
    assert_eq!(up.len(), fine.face_count());
    assert!(up.iter().enumerate().all(|(f, &c)| c as usize == f / 16), "Loop: 16 children per face");
    // A triangle and a quad side by side (triangle first: `f >> 2L` would be wrong).
    let m = mesh_from(
        vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::new(2.0, 0.5, 0.0)],
        &[vec![1, 4, 2], vec![0, 1, 2, 3]],
    );
    let (fine, up) = subdivide_traced(&m, &[], &opts(Scheme::CatmullClark, 2)).unwrap();
    assert_eq!(fine.face_count(), 28);
    let expected: Vec<u32> = std::iter::repeat_n(0, 12).chain(std::iter::repeat_n(1, 16)).collect();
    assert_eq!(up, expected);
}

#[test]
fn catmull_clark_counts_per_level() {
    // A triangle and a pentagon sharing an edge: the first level makes 3 + 5 quads.
    let m = triangle_and_pentagon([0.0; 6]);
    let one = refine(&m, Scheme::CatmullClark, 1);
    assert_eq!(one.face_count(), 8);
    assert!((0..8).all(|f| one.face(f).len() == 4));
    assert_eq!(one.vertex_count(), 6 + 2 + edge_count(&m));
    for l in 2..5 {
        assert_eq!(refine(&m, Scheme::CatmullClark, l).face_count(), 8 * 4usize.pow(l - 1));
    }
    // Skjermo2008 §10.11: V' = V + E + F on a closed quad mesh.
    let c = cube();
    let r = refine(&c, Scheme::CatmullClark, 1);
    assert_eq!(r.vertex_count(), 8 + 12 + 6);
    assert_eq!(r.face_count(), 24);
}

#[test]
fn closed_manifold_stays_closed_and_manifold() {
    for (m, scheme) in [
        (cube(), Scheme::CatmullClark),
        (octahedron(), Scheme::Loop),
        (torus(6, 4, false), Scheme::CatmullClark),
        (torus(6, 4, true), Scheme::Loop),
    ] {
        let chi0 = m.vertex_count() as i64 - edge_count(&m) as i64 + m.face_count() as i64;
        for l in 1..4 {
            let r = refine(&m, scheme, l);
            let t = Topology::from_faces(r.vertex_count(), &r.face_offsets, &r.face_indices).unwrap();
            assert_eq!(t.edge_count() * 2, r.face_indices.len(), "every edge has two faces");
            assert!((0..t.edge_count()).all(|e| !t.is_boundary_edge(e)));
            let chi = t.vertex_count() as i64 - t.edge_count() as i64 + t.face_count() as i64;
            assert_eq!(chi, chi0, "Euler characteristic");
        }
    }
}

#[test]
fn non_manifold_input_names_the_vertices() {
    let m = mesh_from(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Y],
        &[vec![0, 1, 2], vec![1, 0, 3], vec![0, 1, 4]],
    );
    let e = Refiner::new(&m, &[], &opts(Scheme::Loop, 1)).unwrap_err();
    assert!(matches!(&e, RefineError::NonManifoldEdge { a: 0, b: 1, faces } if faces.len() == 3), "{e}");
    assert!(e.to_string().contains("vertices 0 and 1"), "{e}");
    let flipped = mesh_from(vec![Vec3::ZERO, Vec3::X, Vec3::Y, -Vec3::Y], &[vec![0, 1, 2], vec![0, 1, 3]]);
    let e = Refiner::new(&flipped, &[], &opts(Scheme::Loop, 1)).unwrap_err();
    assert!(e.to_string().contains("vertex 0 to vertex 1"), "{e}");
}

#[test]
fn loop_rejects_quads_and_budget_is_enforced() {
    let e = Refiner::new(&cube(), &[], &opts(Scheme::Loop, 1)).unwrap_err();
    assert!(matches!(e, RefineError::NotTriangles { face: 0, corners: 4 }), "{e}");
    let o = RefineOptions { max_faces: 1000, ..opts(Scheme::CatmullClark, 5) };
    let e = Refiner::new(&cube(), &[], &o).unwrap_err();
    assert!(matches!(e, RefineError::Budget { faces: 6144, .. }), "{e}");
    assert!(e.to_string().contains("6144"));
}

#[test]
fn creases_must_be_edges_and_sharpness_valid() {
    let mut m = cube();
    m.creases.push(Crease { a: 0, b: 7, sharpness: 1.0 });
    assert!(matches!(
        Refiner::new(&m, &[], &opts(Scheme::CatmullClark, 1)),
        Err(RefineError::CreaseNotAnEdge { a: 0, b: 7 })
    ));
    m.creases[0] = Crease { a: 0, b: 1, sharpness: f32::NAN };
    assert!(matches!(
        Refiner::new(&m, &[], &opts(Scheme::CatmullClark, 1)),
        Err(RefineError::BadSharpness { .. })
    ));
}

// ---------------------------------------------------------------------------------------
// Geometry

#[test]
fn refined_vertices_stay_in_the_convex_hull() {
    // Tetrahedron: inside all four face planes (MacMurchy2004-spec §7.7: positive weights).
    let t = tetrahedron();
    let planes: Vec<(Vec3, f32)> = (0..4)
        .map(|f| {
            let [a, b, c] = [0, 1, 2].map(|k| t.positions[t.face(f)[k] as usize]);
            let n = (b - a).cross(c - a).normalize();
            (n, n.dot(a))
        })
        .collect();
    for l in 1..6 {
        for p in &refine(&t, Scheme::Loop, l).positions {
            for (n, d) in &planes {
                assert!(n.dot(*p) <= d + 1e-5, "level {l}: {p} outside the hull");
            }
        }
    }
    // Random closed meshes, 5 levels: inside the control bounding box.
    for seed in 0..3 {
        let mut o = octahedron();
        for (i, p) in o.positions.iter_mut().enumerate() {
            *p += Vec3::new(
                noise(seed * 100 + 3 * i as u32),
                noise(seed * 100 + 3 * i as u32 + 1),
                noise(seed * 100 + 3 * i as u32 + 2),
            ) * 0.4;
        }
        let (lo, hi) = o.bounds().unwrap();
        for p in &refine(&o, Scheme::Loop, 5).positions {
            assert!(p.cmpge(lo - 1e-5).all() && p.cmple(hi + 1e-5).all());
        }
    }
    let (lo, hi) = cube().bounds().unwrap();
    for p in &refine(&cube(), Scheme::CatmullClark, 4).positions {
        assert!(p.cmpge(lo - 1e-5).all() && p.cmple(hi + 1e-5).all());
    }
}

#[test]
fn boundary_refines_as_cubic_bspline_curve() {
    for scheme in [Scheme::CatmullClark, Scheme::Loop] {
        let f = |i: u32, j: u32| {
            Vec3::new(
                i as f32 + 0.3 * noise(i * 7 + j),
                j as f32 + 0.3 * noise(i * 13 + j + 5),
                noise(i * 31 + j),
            )
        };
        let m = if scheme == Scheme::Loop { grid_tris(4, 3, f) } else { grid_quads(4, 3, f) };
        let control = boundary_loop(&m, 0);
        // Grid corners have a single face (two for the triangle grid's diagonal corners):
        // with EdgeAndCorner the single-face ones stay put.
        let faces_at = |v: u32| m.face_indices.iter().filter(|&&x| x == v).count();
        let pinned: Vec<bool> = control.iter().map(|&v| faces_at(v) == 1).collect();
        let pts: Vec<Vec3> = control.iter().map(|&v| m.positions[v as usize]).collect();
        for l in 1..4 {
            let r = refine(&m, scheme, l);
            let got: Vec<Vec3> = boundary_loop(&r, 0).iter().map(|&v| r.positions[v as usize]).collect();
            let want = curve_subdivide(&pts, &pinned, l);
            assert_eq!(got.len(), want.len());
            for (g, w) in got.iter().zip(&want) {
                assert!(g.distance(*w) < 1e-5, "{scheme:?} level {l}: {g} vs {w}");
            }
        }
    }
}

/// Pieterse2012-spec property 17: with the `Fixed` rule every level-0 boundary vertex keeps its
/// exact position and every new boundary vertex lies on the control rim (the polyline of
/// the control boundary), at every level and at the limit; the B-spline rule moves them.
#[test]
fn fixed_boundary_keeps_the_control_rim() {
    use sylva::refine::BoundaryInterpolation;
    // An open square tube (s = 4, Pieterse2012's loop) of 3 segments, Loop triangles.
    let (s, rings) = (4u32, 4u32);
    let pos: Vec<Vec3> = (0..rings)
        .flat_map(|j| (0..s).map(move |i| (i, j)))
        .map(|(i, j)| {
            let a = std::f32::consts::TAU * i as f32 / s as f32;
            Vec3::new(a.cos(), j as f32, a.sin())
        })
        .collect();
    let mut faces = Vec::new();
    for j in 0..rings - 1 {
        for i in 0..s {
            let (a, b) = (j * s + i, j * s + (i + 1) % s);
            faces.push(vec![a, b + s, b]);
            faces.push(vec![a, a + s, b + s]);
        }
    }
    let m = mesh_from(pos.clone(), &faces);
    let on_rim = |p: Vec3| {
        // Distance from p to the nearest control boundary edge (base ring or top ring).
        [0, rings - 1]
            .iter()
            .flat_map(|&j| (0..s).map(move |i| (j * s + i, j * s + (i + 1) % s)))
            .map(|(a, b)| {
                let (a, b) = (pos[a as usize], pos[b as usize]);
                let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                p.distance(a + t * (b - a))
            })
            .fold(f32::INFINITY, f32::min)
    };
    let boundary_of = |r: &Mesh| -> Vec<u32> {
        let t = Topology::from_faces(r.vertex_count(), &r.face_offsets, &r.face_indices).unwrap();
        (0..t.edge_count()).filter(|&e| t.is_boundary_edge(e)).flat_map(|e| t.edge(e)).collect()
    };
    for limit in [false, true] {
        for levels in 1..4 {
            let o = |boundary| SubdivideOptions {
                refine: RefineOptions {
                    scheme: Scheme::Loop,
                    levels,
                    boundary,
                    full_last_level: limit,
                    ..Default::default()
                },
                limit,
                ..Default::default()
            };
            let fixed = subdivide(&m, &[], &o(BoundaryInterpolation::Fixed)).unwrap();
            // Level-0 vertices keep their index (even vertices first) and exact position.
            for v in 0..s as usize {
                assert_eq!(fixed.positions[v], pos[v], "base vertex {v} moved (levels {levels})");
                let top = ((rings - 1) * s) as usize + v;
                assert_eq!(fixed.positions[top], pos[top], "tip vertex {top} moved (levels {levels})");
            }
            let rim = boundary_of(&fixed);
            assert_eq!(rim.len() / 2, (2 * s * (1 << levels)) as usize, "rim edge count");
            let worst = rim.iter().map(|&v| on_rim(fixed.positions[v as usize])).fold(0.0, f32::max);
            assert!(worst < 1e-6, "Fixed: a rim vertex is {worst} off the control rim (levels {levels})");
            // The B-spline rim shrinks off the control square.
            let bs = subdivide(&m, &[], &o(BoundaryInterpolation::EdgeAndCorner)).unwrap();
            let off = boundary_of(&bs).iter().map(|&v| on_rim(bs.positions[v as usize])).fold(0.0, f32::max);
            assert!(off > 0.05, "BSpline: the rim should leave the control square, max {off}");
        }
    }
}

/// Marks the ring of torus edges at big-circle index 0 (j = 0..m) as creases.
fn torus_crease_ring(m: &mut Mesh, mm: u32, sharpness: f32) {
    for j in 0..mm {
        m.creases.push(Crease { a: j, b: (j + 1) % mm, sharpness });
    }
}

#[test]
fn sharp_crease_refines_as_cubic_bspline_curve() {
    for (tris, scheme) in [(false, Scheme::CatmullClark), (true, Scheme::Loop)] {
        let mm = 6;
        let mut m = torus(8, mm, tris);
        torus_crease_ring(&mut m, mm, f32::INFINITY);
        let pts: Vec<Vec3> = (0..mm).map(|j| m.positions[j as usize]).collect();
        for l in 1..4 {
            let refiner = Refiner::new(&m, &[], &opts(scheme, l)).unwrap();
            let fine = refiner.interpolate(&m.positions).unwrap();
            let want = curve_subdivide(&pts, &vec![false; mm as usize], l);
            // The refined crease: the sharp edges of the finest level, chained from vertex 0.
            let creases = refiner.finest_creases();
            assert_eq!(creases.len(), want.len());
            let mut chain = vec![0u32];
            while chain.len() < want.len() {
                let v = *chain.last().unwrap();
                let prev = if chain.len() > 1 { chain[chain.len() - 2] } else { u32::MAX };
                let next = creases
                    .iter()
                    .find_map(|c| {
                        if c.a == v && c.b != prev {
                            Some(c.b)
                        } else if c.b == v && c.a != prev {
                            Some(c.a)
                        } else {
                            None
                        }
                    })
                    .unwrap();
                chain.push(next);
            }
            let got: Vec<Vec3> = chain.iter().map(|&v| fine[v as usize]).collect();
            // The chain may run either way round.
            let fwd = got.iter().zip(&want).all(|(g, w)| g.distance(*w) < 1e-5);
            let mut rev = want.clone();
            rev[1..].reverse();
            let bwd = got.iter().zip(&rev).all(|(g, w)| g.distance(*w) < 1e-5);
            assert!(fwd || bwd, "{scheme:?} level {l}");
        }
    }
}

#[test]
fn sharpness_s_uses_sharp_masks_for_s_levels() {
    for (tris, scheme) in [(false, Scheme::CatmullClark), (true, Scheme::Loop)] {
        let mm = 6;
        let base = torus(8, mm, tris);
        let with = |s: f32, levels: u32| {
            let mut m = base.clone();
            torus_crease_ring(&mut m, mm, s);
            refine(&m, scheme, levels)
        };
        // s = 0 is untagged; s ≥ levels is infinitely sharp.
        assert_eq!(with(0.0, 3).positions, refine(&base, scheme, 3).positions);
        assert_eq!(with(3.0, 3).positions, with(f32::INFINITY, 3).positions);
        assert_eq!(with(7.0, 3).positions, with(f32::INFINITY, 3).positions);
        // s = 2: two sharp levels, then smooth ones.
        let mut sharp2 = with(f32::INFINITY, 2);
        sharp2.creases.clear();
        let then_smooth = refine(&sharp2, scheme, 2);
        let direct = with(2.0, 4);
        assert!(hausdorff(&direct.positions, &then_smooth.positions) < 1e-5);
        assert!(hausdorff(&direct.positions, &with(3.0, 4).positions) > 1e-3);
        // Fractional sharpness lies between its neighbours on the crease.
        let p = |s: f32| with(s, 2).positions[0];
        let (a, b, c) = (p(1.0), p(1.5), p(2.0));
        assert!((b - a).length() > 1e-4 && (c - b).length() > 1e-4);
        assert!((b - a).dot(c - b) > 0.0, "s = 1.5 between s = 1 and s = 2");
    }
}

#[test]
fn tip_sharpness_pins_a_vertex_for_t_levels() {
    // MacMurchy2004 §2.10: "a tip with sharpness t stays fixed for t levels".
    let m = octahedron();
    let tip = [Corner { vertex: 4, sharpness: 2.0 }];
    let at = |l: u32| {
        let r = Refiner::new(&m, &tip, &opts(Scheme::Loop, l)).unwrap();
        r.interpolate(&m.positions).unwrap()[4]
    };
    assert_eq!(at(1), Vec3::Z);
    assert_eq!(at(2), Vec3::Z);
    assert!(at(3).distance(Vec3::Z) > 1e-3);
    let inf = [Corner { vertex: 4, sharpness: f32::INFINITY }];
    let r = Refiner::new(&m, &inf, &opts(Scheme::Loop, 4)).unwrap();
    assert_eq!(r.interpolate(&m.positions).unwrap()[4], Vec3::Z);
}

// ---------------------------------------------------------------------------------------
// Limit surface

/// Uniform cubic B-spline basis centred at 0 (support [-2, 2]) and its derivative.
fn bspline(t: f32) -> (f32, f32) {
    let a = t.abs();
    let (v, d) = if a < 1.0 {
        (2.0 / 3.0 - a * a + 0.5 * a * a * a, -2.0 * a + 1.5 * a * a)
    } else if a < 2.0 {
        let u = 2.0 - a;
        (u * u * u / 6.0, -0.5 * u * u)
    } else {
        (0.0, 0.0)
    };
    (v, d * t.signum())
}

#[test]
fn catmull_clark_limit_matches_bicubic_bspline() {
    let n = 10;
    let h = |i: u32, j: u32| 0.5 * noise(i * 101 + j * 7 + 3);
    let m = grid_quads(n, n, |i, j| Vec3::new(i as f32, j as f32, h(i, j)));
    let o = SubdivideOptions { refine: opts(Scheme::CatmullClark, 3), limit: true, ..Default::default() };
    let r = subdivide(&m, &[], &o).unwrap();
    let (lo, hi) = (2.0, (n - 2) as f32);
    let bicubic = |x: f32, y: f32| {
        let (mut z, mut zx, mut zy) = (0.0, 0.0, 0.0);
        for j in 0..=n {
            for i in 0..=n {
                let (bx, dx) = bspline(x - i as f32);
                let (by, dy) = bspline(y - j as f32);
                z += h(i, j) * bx * by;
                zx += h(i, j) * dx * by;
                zy += h(i, j) * bx * dy;
            }
        }
        (z, zx, zy)
    };
    assert!(limit_matches(&r, (lo, hi), bicubic, 1e-4, 1e-5) > 1000);
}

/// Checks every corner of the limit mesh `r` whose position has x and y in `[lo, hi]`
/// against the height field `surface(x, y) = (z, ∂z/∂x, ∂z/∂y)`: height within `dz`,
/// normal's cosine to the field's above `1 − dn`. Returns how many corners it checked.
fn limit_matches(
    r: &Mesh,
    (lo, hi): (f32, f32),
    surface: impl Fn(f32, f32) -> (f32, f32, f32),
    dz: f32,
    dn: f32,
) -> usize {
    let normals = r.normals.as_ref().unwrap();
    let mut checked = 0;
    for (c, &v) in r.face_indices.iter().enumerate() {
        let p = r.positions[v as usize];
        if p.x < lo || p.y < lo || p.x > hi || p.y > hi {
            continue;
        }
        let (z, zx, zy) = surface(p.x, p.y);
        assert!((p.z - z).abs() < dz, "limit height at ({}, {}): {} vs {z}", p.x, p.y, p.z);
        let want = Vec3::new(-zx, -zy, 1.0).normalize();
        let got = normals.values[normals.indices[c] as usize];
        assert!(got.dot(want) > 1.0 - dn, "normal at ({}, {}): {got} vs {want}", p.x, p.y);
        checked += 1;
    }
    checked
}

#[test]
fn loop_limit_matches_quartic_box_spline() {
    // For a cubic polynomial p sampled on the three-direction lattice, the box spline
    // M₂₂₂ gives S = p + ½ Σ ∂ₐ∂ᵦp · Cov with Cov = h²/6 [[2, 1], [1, 2]] (the covariance
    // of Σ ξₖ Uₖ, Uₖ uniform on [0, 1]; odd moments vanish by symmetry).
    let n = 12;
    let h = 0.25f32;
    let a = [0.1f32, 0.3, -0.2, 0.15, -0.1, 0.2, 0.05, -0.04, 0.03, 0.02];
    let p = |x: f32, y: f32| {
        a[0] + a[1] * x
            + a[2] * y
            + a[3] * x * x
            + a[4] * x * y
            + a[5] * y * y
            + a[6] * x * x * x
            + a[7] * x * x * y
            + a[8] * x * y * y
            + a[9] * y * y * y
    };
    // Second derivatives pxx, pxy, pyy and their gradients.
    let pxx = |x: f32, y: f32| 2.0 * a[3] + 6.0 * a[6] * x + 2.0 * a[7] * y;
    let pxy = |x: f32, y: f32| a[4] + 2.0 * a[7] * x + 2.0 * a[8] * y;
    let pyy = |x: f32, y: f32| 2.0 * a[5] + 2.0 * a[8] * x + 6.0 * a[9] * y;
    let cov = [2.0 * h * h / 6.0, h * h / 6.0, 2.0 * h * h / 6.0];
    let s =
        |x: f32, y: f32| p(x, y) + 0.5 * (cov[0] * pxx(x, y) + 2.0 * cov[1] * pxy(x, y) + cov[2] * pyy(x, y));
    let sx = |x: f32, y: f32| {
        a[1] + 2.0 * a[3] * x
            + a[4] * y
            + 3.0 * a[6] * x * x
            + 2.0 * a[7] * x * y
            + a[8] * y * y
            + 0.5 * (cov[0] * 6.0 * a[6] + 2.0 * cov[1] * 2.0 * a[7] + cov[2] * 2.0 * a[8])
    };
    let sy = |x: f32, y: f32| {
        a[2] + a[4] * x
            + 2.0 * a[5] * y
            + a[7] * x * x
            + 2.0 * a[8] * x * y
            + 3.0 * a[9] * y * y
            + 0.5 * (cov[0] * 2.0 * a[7] + 2.0 * cov[1] * 2.0 * a[8] + cov[2] * 6.0 * a[9])
    };
    let m = grid_tris(n, n, |i, j| {
        let (x, y) = (i as f32 * h, j as f32 * h);
        Vec3::new(x, y, p(x, y))
    });
    let o = SubdivideOptions { refine: opts(Scheme::Loop, 3), limit: true, ..Default::default() };
    let r = subdivide(&m, &[], &o).unwrap();
    let (lo, hi) = (2.5 * h, (n as f32 - 2.5) * h);
    assert!(limit_matches(&r, (lo, hi), |x, y| (s(x, y), sx(x, y), sy(x, y)), 2e-5, 1e-6) > 1000);
}

#[test]
fn limit_is_level_independent_and_normals_point_outward() {
    // MacMurchy2004-spec §7.26: a vertex has the same limit position at level n and n + 1.
    for (m, scheme) in
        [(cube(), Scheme::CatmullClark), (octahedron(), Scheme::Loop), (torus(6, 4, true), Scheme::Loop)]
    {
        let lim = |l: u32| {
            let o = SubdivideOptions { refine: opts(scheme, l), limit: true, ..Default::default() };
            subdivide(&m, &[], &o).unwrap()
        };
        let (a, b) = (lim(2), lim(3));
        for v in 0..a.vertex_count() {
            assert!(a.positions[v].distance(b.positions[v]) < 1e-5, "{scheme:?} vertex {v}");
        }
        let n = b.normals.as_ref().unwrap();
        let is_torus = m.face_count() == 48;
        for (c, &v) in b.face_indices.iter().enumerate() {
            let p = b.positions[v as usize];
            // Outward: away from the centre, or from the torus's core circle (radius 2).
            let out = if is_torus { p - 2.0 * Vec3::new(p.x, 0.0, p.z).normalize() } else { p };
            assert!(n.values[n.indices[c] as usize].dot(out) > 0.0, "{scheme:?}: inward normal at {p}");
        }
    }
}

#[test]
fn crease_keeps_two_normals_and_boundary_limit_is_on_the_curve() {
    // A flat open grid folded along x = 2 by an infinitely sharp crease.
    let mut m = grid_quads(4, 4, |i, j| {
        let x = i as f32;
        Vec3::new(x, j as f32, if i > 2 { (x - 2.0) * 0.8 } else { 0.0 })
    });
    for j in 0..4 {
        m.creases.push(Crease { a: j * 5 + 2, b: (j + 1) * 5 + 2, sharpness: f32::INFINITY });
    }
    let o = SubdivideOptions { refine: opts(Scheme::CatmullClark, 2), limit: true, ..Default::default() };
    let r = subdivide(&m, &[], &o).unwrap();
    let n = r.normals.as_ref().unwrap();
    // Vertex 12 = control (2, 2): on the crease, interior. Its corners see two normals.
    let mut seen: Vec<Vec3> = Vec::new();
    for (c, &v) in r.face_indices.iter().enumerate() {
        if v == 12 {
            let nv = n.values[n.indices[c] as usize];
            if !seen.iter().any(|s| s.distance(nv) < 1e-6) {
                seen.push(nv);
            }
        }
    }
    assert_eq!(seen.len(), 2, "{seen:?}");
    let flat = seen.iter().find(|s| s.z > 0.999).expect("the flat side's normal is +Z");
    let tilted = seen.iter().find(|s| s.z < 0.99).unwrap();
    assert!(flat.dot(*tilted) < 0.9);
    assert!((tilted.x + 0.8 * tilted.z).abs() < 1e-3, "{tilted}");
}

// ---------------------------------------------------------------------------------------
// Face-varying UVs

/// A quad strip wrapped into a cylinder (open at both ends), with a UV seam at u = 0 / 1.
fn cylinder_with_seam(around: u32, along: u32) -> Mesh {
    let mut pos = Vec::new();
    for j in 0..=along {
        for i in 0..around {
            let a = i as f32 / around as f32 * std::f32::consts::TAU;
            pos.push(Vec3::new(a.cos(), j as f32 * 0.5, a.sin()));
        }
    }
    let mut uv = Vec::new();
    for j in 0..=along {
        for i in 0..=around {
            uv.push(Vec2::new(i as f32 / around as f32, j as f32 / along as f32));
        }
    }
    let mut m = Mesh::new();
    m.positions = pos;
    let mut idx = Vec::new();
    for j in 0..along {
        for i in 0..around {
            let v = |i: u32, j: u32| j * around + i % around;
            let t = |i: u32, j: u32| j * (around + 1) + i;
            // Counter-clockwise seen from outside (x = cos a, z = sin a; +y up).
            m.push_face(&[v(i, j), v(i, j + 1), v(i + 1, j + 1), v(i + 1, j)]);
            idx.extend_from_slice(&[t(i, j), t(i, j + 1), t(i + 1, j + 1), t(i + 1, j)]);
        }
    }
    m.uvs = Some(FaceVarying { values: uv, indices: idx });
    m
}

#[test]
fn uv_seams_stay_exact_in_every_mode() {
    let m = cylinder_with_seam(6, 3);
    for uv in FvarInterpolation::ALL {
        for scheme in [Scheme::CatmullClark] {
            let o = SubdivideOptions { refine: opts(scheme, 3), uv, ..Default::default() };
            let r = subdivide(&m, &[], &o).unwrap();
            let uvs = r.uvs.as_ref().unwrap();
            // Every vertex on the seam (x > 0, z ≈ 0) has corners with u = 0 and u = 1 and
            // the same v on both sides.
            let mut per_vertex: std::collections::HashMap<u32, Vec<Vec2>> = Default::default();
            for (c, &v) in r.face_indices.iter().enumerate() {
                per_vertex.entry(v).or_default().push(uvs.values[uvs.indices[c] as usize]);
            }
            let mut seam_vertices = 0;
            for (v, list) in &per_vertex {
                let p = r.positions[*v as usize];
                if p.z.abs() > 1e-6 || p.x <= 0.0 {
                    // Off the seam a vertex has a single UV.
                    assert!(list.iter().all(|t| *t == list[0]), "{uv:?}: split UV off the seam at {p}");
                    continue;
                }
                seam_vertices += 1;
                // On the seam: two charts, mirror images of each other (u and 1 − u, the
                // same v). Every mode but `Smooth` pins the chart's corners, so u stays
                // exactly 0 and 1; `Smooth` (OpenSubdiv's NONE) smooths the corners where
                // the seam meets the open ends, and the seam next to them follows.
                let (lo, hi) = list.iter().fold((list[0], list[0]), |(a, b), t| {
                    (if t.x < a.x { *t } else { a }, if t.x > b.x { *t } else { b })
                });
                assert!(list.iter().all(|t| *t == lo || *t == hi), "{uv:?}: more than two UVs at {p}");
                assert!((lo.y - hi.y).abs() < 1e-6, "{uv:?}: v differs across the seam at {p}");
                assert!((lo.x + hi.x - 1.0).abs() < 1e-6, "{uv:?}: seam sides not mirrored at {p}");
                if uv != FvarInterpolation::Smooth {
                    assert!(lo.x == 0.0 && hi.x == 1.0, "{uv:?}: seam moved off u = 0 / 1 at {p}");
                }
            }
            assert_eq!(seam_vertices, 3 * 8 + 1, "{uv:?}");
        }
    }
}

#[test]
fn linear_boundary_uvs_do_not_shrink() {
    // A grid with UV = position / size: the UV chart's border must stay the unit square's
    // border with uniformly spaced values in Linear and Boundaries modes.
    let n = 4;
    let mut m = grid_quads(n, n, |i, j| Vec3::new(i as f32, j as f32, 0.3 * noise(i * 17 + j)));
    m.uvs = Some(FaceVarying {
        values: m.positions.iter().map(|p| Vec2::new(p.x / n as f32, p.y / n as f32)).collect(),
        indices: m.face_indices.clone(),
    });
    for uv in [FvarInterpolation::Linear, FvarInterpolation::Boundaries] {
        let o = SubdivideOptions { refine: opts(Scheme::CatmullClark, 2), uv, ..Default::default() };
        let r = subdivide(&m, &[], &o).unwrap();
        let uvs = r.uvs.as_ref().unwrap();
        let mut bottom: Vec<f32> = uvs.values.iter().filter(|t| t.y == 0.0).map(|t| t.x).collect();
        bottom.sort_by(f32::total_cmp);
        let want: Vec<f32> = (0..=16).map(|k| k as f32 / 16.0).collect();
        assert_eq!(bottom.len(), want.len(), "{uv:?}");
        for (a, b) in bottom.iter().zip(&want) {
            assert!((a - b).abs() < 1e-6, "{uv:?}: {bottom:?}");
        }
        assert!(uvs.values.iter().all(|t| t.x >= 0.0 && t.x <= 1.0 && t.y >= 0.0 && t.y <= 1.0));
    }
}

#[test]
fn smooth_uvs_follow_the_surface_without_seams() {
    // Without seams, CornersPlus UVs use the same masks as the positions, so an affine
    // UV map of a flat grid stays affine in the refined positions.
    let n = 5;
    let mut m = grid_tris(n, n, |i, j| {
        Vec3::new(i as f32 + 0.2 * noise(i * 3 + j), j as f32 + 0.2 * noise(i + 7 * j), 0.0)
    });
    let map = |p: Vec3| Vec2::new(0.1 * p.x + 0.05 * p.y + 0.2, -0.03 * p.x + 0.12 * p.y);
    m.uvs = Some(FaceVarying {
        values: m.positions.iter().map(|&p| map(p)).collect(),
        indices: m.face_indices.clone(),
    });
    let o = SubdivideOptions {
        refine: opts(Scheme::Loop, 3),
        uv: FvarInterpolation::CornersPlus,
        ..Default::default()
    };
    let r = subdivide(&m, &[], &o).unwrap();
    let uvs = r.uvs.as_ref().unwrap();
    for (c, &v) in r.face_indices.iter().enumerate() {
        let want = map(r.positions[v as usize]);
        let got = uvs.values[uvs.indices[c] as usize];
        assert!(got.distance(want) < 1e-5, "{got} vs {want}");
    }
}

// ---------------------------------------------------------------------------------------
// Determinism

#[test]
fn output_is_identical_for_any_thread_count() {
    let n = 48;
    let mut m = grid_quads(n, n, |i, j| Vec3::new(i as f32, j as f32, noise(i * 1000 + j)));
    m.uvs = Some(FaceVarying {
        values: m.positions.iter().map(|p| Vec2::new(p.x, p.y) / n as f32).collect(),
        indices: m.face_indices.clone(),
    });
    m.creases.push(Crease { a: 5, b: 6, sharpness: 1.5 });
    let run = |threads: usize, parallel: bool| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let o = SubdivideOptions {
            refine: RefineOptions { parallel, ..opts(Scheme::CatmullClark, 3) },
            limit: true,
            uv: FvarInterpolation::Boundaries,
        };
        pool.install(|| subdivide(&m, &[], &o).unwrap())
    };
    let one = run(1, false);
    assert!(one.face_count() > 4 * 2048);
    for threads in [1, 2, 3] {
        assert_eq!(run(threads, true), one, "{threads} threads");
    }
}

// ---------------------------------------------------------------------------------------
// Agreement with OpenSubdiv (bench/opensubdiv/osd_refine.cpp, Far API)

/// The reference program: `$SYLVA_OSD_REFINE`, or built here with g++ when OpenSubdiv's
/// headers are installed (`apt-get install libosd-dev`). `None` (the test is skipped)
/// when neither works, unless `SYLVA_REQUIRE_OSD` is set. Built once per test process
/// (tests run in parallel: a second build would overwrite the program while another test
/// runs it), into a per-process file.
fn osd_refine() -> Option<std::path::PathBuf> {
    static BUILT: std::sync::OnceLock<Option<std::path::PathBuf>> = std::sync::OnceLock::new();
    if let Some(p) = BUILT.get_or_init(build_osd_refine) {
        return Some(p.clone());
    }
    assert!(
        std::env::var_os("SYLVA_REQUIRE_OSD").is_none(),
        "SYLVA_REQUIRE_OSD is set but OpenSubdiv is not available"
    );
    eprintln!("skipping the OpenSubdiv agreement test: install libosd-dev and g++, or set SYLVA_OSD_REFINE");
    None
}

fn build_osd_refine() -> Option<std::path::PathBuf> {
    if let Ok(p) = std::env::var("SYLVA_OSD_REFINE") {
        return Some(p.into());
    }
    let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/opensubdiv/osd_refine.cpp");
    let out =
        std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("osd_refine-{}", std::process::id()));
    let built = std::path::Path::new("/usr/include/opensubdiv/far/topologyDescriptor.h").exists()
        && std::process::Command::new("g++")
            .args(["-O2", "-std=c++14"])
            .arg(&src)
            .args(["-losdCPU", "-o"])
            .arg(&out)
            .status()
            .is_ok_and(|s| s.success());
    built.then_some(out)
}

/// Writes `m` as OBJ with OpenSubdiv tags (sharpness ∞ → 10).
fn write_osd_obj(m: &Mesh, corners: &[Corner], chaikin: bool, path: &std::path::Path) {
    use std::fmt::Write as _;
    let mut s = String::new();
    for p in &m.positions {
        writeln!(s, "v {:.9} {:.9} {:.9}", p.x, p.y, p.z).unwrap();
    }
    if let Some(uv) = &m.uvs {
        for t in &uv.values {
            writeln!(s, "vt {:.9} {:.9}", t.x, t.y).unwrap();
        }
    }
    for f in 0..m.face_count() {
        s.push('f');
        for c in m.corners(f) {
            write!(s, " {}", m.face_indices[c] + 1).unwrap();
            if let Some(uv) = &m.uvs {
                write!(s, "/{}", uv.indices[c] + 1).unwrap();
            }
        }
        s.push('\n');
    }
    let sharp = |x: f32| if x.is_finite() { x } else { 10.0 };
    for c in &m.creases {
        writeln!(s, "t crease 2/1 {} {} {}", c.a, c.b, sharp(c.sharpness)).unwrap();
    }
    for c in corners {
        writeln!(s, "t corner 1/1 {} {}", c.vertex, sharp(c.sharpness)).unwrap();
    }
    if chaikin {
        s.push_str("t creasemethod 0/0/1 chaikin\n");
    }
    std::fs::write(path, s).unwrap();
}

/// Largest distance from any point of `a` to its nearest point in `b` (spatial hash with
/// cells of `cell`; `None` if some point has no neighbour within a cell).
fn max_nearest(a: &[[f32; 3]], b: &[[f32; 3]], cell: f32) -> Option<f32> {
    use std::collections::HashMap;
    let key = |p: &[f32; 3]| p.map(|x| (x / cell).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, p) in b.iter().enumerate() {
        grid.entry(key(p)).or_default().push(i);
    }
    let mut worst = 0.0f32;
    for p in a {
        let k = key(p);
        let mut best = f32::MAX;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) {
                        for &i in list {
                            let q = b[i];
                            let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2))
                                .sqrt();
                            best = best.min(d);
                        }
                    }
                }
            }
        }
        if best == f32::MAX {
            return None;
        }
        worst = worst.max(best);
    }
    Some(worst)
}

/// The larger of [`max_nearest`] from `a` to `b` and from `b` to `a` (a Hausdorff
/// distance), `None` if either is.
fn max_nearest_both_ways(a: &[[f32; 3]], b: &[[f32; 3]], cell: f32) -> Option<f32> {
    max_nearest(a, b, cell).zip(max_nearest(b, a, cell)).map(|(x, y)| x.max(y))
}

fn diagonal(p: &[[f32; 3]]) -> f32 {
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for q in p {
        for k in 0..3 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt()
}

/// Refines `m` with both engines at levels 1–3 and compares positions (and linear UVs)
/// as point sets: counts equal, every point within 1e-5 of the bounding-box diagonal.
fn agree(osd: &std::path::Path, name: &str, m: &Mesh, corners: &[Corner], scheme: Scheme, chaikin: bool) {
    agree_uv(osd, name, m, corners, scheme, chaikin, FvarInterpolation::Linear);
}

/// [`agree`] with the UVs interpolated by `uv` in sylva and by the matching
/// `FVarLinearInterpolation` rule in OpenSubdiv.
fn agree_uv(
    osd: &std::path::Path,
    name: &str,
    m: &Mesh,
    corners: &[Corner],
    scheme: Scheme,
    chaikin: bool,
    uv: FvarInterpolation,
) {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
    let obj = dir.join(format!("osd-{name}.obj"));
    write_osd_obj(m, corners, chaikin, &obj);
    let name = &format!("{name} --uv {uv:?}");
    for levels in 1..=3 {
        let out = dir.join(format!("osd-{name}-{levels}.txt").replace([' ', ':'], "_"));
        let scheme_arg = if scheme == Scheme::Loop { "loop" } else { "catmark" };
        let status = std::process::Command::new(osd)
            .arg(&obj)
            .arg(scheme_arg)
            .arg(levels.to_string())
            .arg(&out)
            .args(["--fvar", uv.opensubdiv_name()])
            .status()
            .unwrap();
        assert!(status.success(), "{name}: osd_refine failed");
        let text = std::fs::read_to_string(&out).unwrap();
        let mut lines = text.lines();
        let header: Vec<usize> = lines.next().unwrap().split(' ').map(|x| x.parse().unwrap()).collect();
        let (mut osd_p, mut osd_t) = (Vec::new(), Vec::new());
        for l in lines {
            let nums: Vec<f32> = l.split(' ').skip(1).map(|x| x.parse().unwrap()).collect();
            if l.starts_with("v ") {
                osd_p.push([nums[0], nums[1], nums[2]]);
            } else {
                osd_t.push([nums[0], nums[1], 0.0]);
            }
        }
        let o = SubdivideOptions {
            refine: RefineOptions {
                scheme,
                levels,
                creasing: if chaikin { sylva::refine::CreasingMethod::Chaikin } else { Default::default() },
                ..Default::default()
            },
            uv,
            ..Default::default()
        };
        let r = subdivide(m, corners, &o).unwrap();
        assert_eq!(r.face_count(), header[1], "{name} level {levels}: faces");
        assert_eq!(r.vertex_count(), header[0], "{name} level {levels}: vertices");
        let ours: Vec<[f32; 3]> = r.positions.iter().map(|p| p.to_array()).collect();
        let tol = 1e-5 * diagonal(&osd_p);
        let d = max_nearest_both_ways(&ours, &osd_p, 4.0 * tol);
        assert!(
            d.is_some_and(|d| d <= tol),
            "{name} level {levels}: positions differ from OpenSubdiv by {d:?} (tolerance {tol})"
        );
        if let Some(uv) = &r.uvs {
            assert_eq!(uv.values.len(), header[2], "{name} level {levels}: UV values");
            let ours: Vec<[f32; 3]> = uv.values.iter().map(|t| [t.x, t.y, 0.0]).collect();
            let tol = 1e-5 * diagonal(&osd_t).max(1e-3);
            let d = max_nearest_both_ways(&ours, &osd_t, 4.0 * tol);
            assert!(
                d.is_some_and(|d| d <= tol),
                "{name} level {levels}: UVs differ from OpenSubdiv by {d:?}"
            );
        }
    }
}

/// `m` with each polygon fanned into triangles from its first corner, keeping UVs and
/// creases.
fn triangulate(m: &Mesh) -> Mesh {
    let mut t = Mesh::new();
    t.positions = m.positions.clone();
    t.creases = m.creases.clone();
    let mut uv_indices = Vec::new();
    for f in 0..m.face_count() {
        let face = m.face(f);
        let uv: Vec<u32> = m.uvs.iter().flat_map(|uv| m.corners(f).map(|c| uv.indices[c])).collect();
        for k in 1..face.len() - 1 {
            t.push_face(&[face[0], face[k], face[k + 1]]);
            if !uv.is_empty() {
                uv_indices.extend_from_slice(&[uv[0], uv[k], uv[k + 1]]);
            }
        }
    }
    t.uvs = m.uvs.as_ref().map(|uv| FaceVarying { values: uv.values.clone(), indices: uv_indices });
    t
}

/// Gives `m` UVs with a seam wherever `chart_of` differs across an edge: the corners of a
/// vertex share a value when their faces are in the same chart. Values are an arbitrary
/// per-chart projection, so the charts do not overlap in UV space.
fn with_charts(mut m: Mesh, chart_of: impl Fn(usize) -> u32) -> Mesh {
    let mut key_to_value = std::collections::HashMap::new();
    let (mut values, mut indices) = (Vec::new(), Vec::new());
    for f in 0..m.face_count() {
        let chart = chart_of(f);
        for c in m.corners(f) {
            let v = m.face_indices[c];
            let p = m.positions[v as usize];
            let value = *key_to_value.entry((chart, v)).or_insert_with(|| {
                values.push(Vec2::new(4.0 * chart as f32 + p.x + 0.3 * p.z, p.y - 0.2 * p.z));
                values.len() as u32 - 1
            });
            indices.push(value);
        }
    }
    m.uvs = Some(FaceVarying { values, indices });
    m
}

/// A 6×5 quad grid cut by two UV seams along x = 2: one across the whole grid (two
/// charts), and one along x = 4 from the border to the middle, ending inside the mesh (a
/// "dart": the seam's last vertex has a single value).
fn grid_with_seams() -> Mesh {
    let bumpy =
        |i: u32, j: u32| Vec3::new(i as f32 + 0.2 * noise(i + 11 * j), j as f32, 0.4 * noise(7 * i + j + 1));
    let mut m = grid_quads(6, 5, bumpy);
    let (mut values, mut indices) = (Vec::new(), Vec::new());
    let mut key_to_value = std::collections::HashMap::new();
    for f in 0..m.face_count() {
        let (fi, fj) = (f as u32 % 6, f as u32 / 6);
        for c in m.corners(f) {
            let v = m.face_indices[c];
            let (i, j) = (v % 7, v / 7);
            // Which side of a seam this corner is on (0 where the vertex is not split).
            let side = if i == 2 {
                u32::from(fi >= 2)
            } else if i == 4 && j < 3 {
                u32::from(fi >= 4) + 2
            } else {
                0
            };
            let p = m.positions[v as usize];
            let value = *key_to_value.entry((side, v)).or_insert_with(|| {
                let shift = if side % 2 == 1 { 0.5 } else { 0.0 };
                values.push(Vec2::new(p.x + shift + 0.1 * fj as f32, p.y - 0.1 * p.z));
                values.len() as u32 - 1
            });
            indices.push(value);
        }
    }
    m.uvs = Some(FaceVarying { values, indices });
    m
}

#[test]
fn agrees_with_opensubdiv() {
    let Some(osd) = osd_refine() else { return };
    let bumpy =
        |i: u32, j: u32| Vec3::new(i as f32 + 0.2 * noise(i + 11 * j), j as f32, 0.5 * noise(7 * i + j + 1));
    // 1. cube, 2. tetrahedron, 3. open grid, 4. torus — both schemes.
    agree(&osd, "cube-cc", &cube(), &[], Scheme::CatmullClark, false);
    agree(&osd, "cube-loop", &triangulate(&cube()), &[], Scheme::Loop, false);
    agree(&osd, "tetra-loop", &tetrahedron(), &[], Scheme::Loop, false);
    agree(&osd, "tetra-cc", &tetrahedron(), &[], Scheme::CatmullClark, false);
    agree(&osd, "grid-cc", &grid_quads(5, 4, bumpy), &[], Scheme::CatmullClark, false);
    agree(&osd, "grid-loop", &grid_tris(5, 4, bumpy), &[], Scheme::Loop, false);
    agree(&osd, "torus-cc", &torus(8, 6, false), &[], Scheme::CatmullClark, false);
    agree(&osd, "torus-loop", &torus(8, 6, true), &[], Scheme::Loop, false);
    // 5. semi-sharp creases (uniform and Chaikin decay), infinitely sharp creases.
    let mut creased = cube();
    for (a, b, s) in
        [(0, 1, 0.5), (1, 3, 1.5), (3, 2, 2.3), (4, 5, f32::INFINITY), (5, 7, f32::INFINITY), (0, 4, 1.0)]
    {
        creased.creases.push(Crease { a, b, sharpness: s });
    }
    agree(&osd, "creased-cc", &creased, &[], Scheme::CatmullClark, false);
    agree(&osd, "creased-cc-chaikin", &creased, &[], Scheme::CatmullClark, true);
    agree(&osd, "creased-loop", &triangulate(&creased), &[], Scheme::Loop, false);
    let mut ring = torus(8, 6, false);
    torus_crease_ring(&mut ring, 6, 1.7);
    agree(&osd, "torus-ring-cc", &ring, &[], Scheme::CatmullClark, true);
    // 6. corners (vertex sharpness), on a closed and an open mesh.
    let corners = [Corner { vertex: 0, sharpness: f32::INFINITY }, Corner { vertex: 6, sharpness: 1.5 }];
    agree(&osd, "corners-cc", &cube(), &corners, Scheme::CatmullClark, false);
    agree(&osd, "corners-loop", &octahedron(), &[Corner { vertex: 4, sharpness: 2.5 }], Scheme::Loop, false);
    agree(
        &osd,
        "grid-corner-cc",
        &grid_quads(4, 4, bumpy),
        &[Corner { vertex: 12, sharpness: 0.6 }],
        Scheme::CatmullClark,
        false,
    );
    // 7. mixed polygons.
    let mixed = triangle_and_pentagon([0.0, 0.2, 0.0, 0.0, 0.3, 0.0]);
    agree(&osd, "mixed-cc", &mixed, &[], Scheme::CatmullClark, false);
    // 8. face-varying UV seams (linear UVs).
    agree(&osd, "cylinder-uv-cc", &cylinder_with_seam(6, 3), &[], Scheme::CatmullClark, false);
    agree(&osd, "cylinder-uv-loop", &triangulate(&cylinder_with_seam(6, 3)), &[], Scheme::Loop, false);
    // 9. a tree control mesh from the tube mesher (triangles, bark UVs).
    let mut bark = tree_bark();
    bark.normals = None;
    agree(&osd, "tree-tube-loop", &bark, &[], Scheme::Loop, false);
    agree(&osd, "tree-tube-cc", &bark, &[], Scheme::CatmullClark, false);
    // ... and from every other mesher: hull and sweep (triangles, the sweep's caps
    // creased) with both schemes, quad (an all-quad cage) with Catmull–Clark.
    for method in ["hull", "sweep", "quad"] {
        let mut m = tree_mesh(method);
        m.normals = None;
        if method != "quad" {
            agree(&osd, &format!("tree-{method}-loop"), &m, &[], Scheme::Loop, false);
        }
        agree(&osd, &format!("tree-{method}-cc"), &m, &[], Scheme::CatmullClark, false);
    }
}

/// Every face-varying mode against the OpenSubdiv rule it claims to match
/// ([`FvarInterpolation::opensubdiv_name`]), Loop and Catmull–Clark, levels 1–3, on meshes
/// with UV seams, darts, three-chart junctions, chart corners, borders and a crease
/// crossing a seam.
#[test]
fn uv_modes_agree_with_opensubdiv() {
    let Some(osd) = osd_refine() else { return };
    // Cube: top+front+right in one chart, back+left in another, bottom alone: seams meet
    // in three-chart junctions and two-chart vertices, some chart corners have one face.
    let cube_uv = with_charts(cube(), |f| [0, 1, 0, 1, 1, 2][f]);
    let mut creased_grid = grid_with_seams();
    for i in 0..6 {
        // An infinitely sharp crease along y = 2 crossing both seams.
        creased_grid.creases.push(Crease { a: 2 * 7 + i, b: 2 * 7 + i + 1, sharpness: f32::INFINITY });
    }
    let mut bark = tree_bark();
    bark.normals = None;
    let meshes = [
        ("uv-cylinder", cylinder_with_seam(6, 3)),
        ("uv-cube", cube_uv),
        ("uv-grid-seams", grid_with_seams()),
        ("uv-grid-crease", creased_grid),
        ("uv-tree-tube", bark),
    ];
    for (name, m) in &meshes {
        let tris = triangulate(m);
        for uv in FvarInterpolation::ALL {
            agree_uv(&osd, &format!("{name}-cc"), m, &[], Scheme::CatmullClark, false, uv);
            agree_uv(&osd, &format!("{name}-loop"), &tris, &[], Scheme::Loop, false, uv);
        }
    }
}

/// The bark of the default preset, a few derivation steps deep (the tube mesher's output).
fn tree_bark() -> Mesh {
    tree_mesh("tube")
}

/// The bark of the default preset, a few derivation steps deep, from mesher `method`
/// (`tube`, `hull`, `sweep` or `quad`), with its creases.
fn tree_mesh(method: &str) -> Mesh {
    let sets = [
        ("generator.iterations".to_string(), toml::Value::Integer(3)),
        ("mesh.method".to_string(), toml::Value::String(method.to_string())),
    ];
    let loaded = sylva::recipe::load(sylva::presets::DEFAULT_PRESET, &sets).unwrap();
    let grown = sylva::pipeline::grow(&loaded).unwrap();
    grown.model.parts.into_iter().find(|p| p.name == "bark").unwrap().mesh
}

#[test]
fn tree_meshes_refine_closed_or_open_consistently() {
    let bark = tree_bark();
    for scheme in [Scheme::Loop, Scheme::CatmullClark] {
        let r = refine(&bark, scheme, 2);
        let t = Topology::from_faces(r.vertex_count(), &r.face_offsets, &r.face_indices).unwrap();
        let t0 = Topology::from_faces(bark.vertex_count(), &bark.face_offsets, &bark.face_indices).unwrap();
        let chi = |t: &Topology| t.vertex_count() as i64 - t.edge_count() as i64 + t.face_count() as i64;
        assert_eq!(chi(&t), chi(&t0));
        let open = |t: &Topology| (0..t.edge_count()).filter(|&e| t.is_boundary_edge(e)).count();
        assert_eq!(open(&t), open(&t0) * 4, "boundary edges double per level");
    }
}

/// An empty control mesh refines to an empty mesh with either scheme, at any level and
/// with the limit options: no panic, no error.
#[test]
fn empty_meshes_refine_to_empty_meshes() {
    use sylva::refine::{subdivide, RefineOptions, Refiner, Scheme, SubdivideOptions};
    let empty = sylva::Mesh::new();
    for scheme in [Scheme::Loop, Scheme::CatmullClark] {
        for levels in [0, 1, 3] {
            let refine = RefineOptions { scheme, levels, ..Default::default() };
            let r = Refiner::new(&empty, &[], &refine).unwrap();
            assert_eq!(r.finest().face_count(), 0);
            for limit in [false, true] {
                let out = subdivide(
                    &empty,
                    &[],
                    &SubdivideOptions { refine: refine.clone(), limit, ..Default::default() },
                )
                .unwrap_or_else(|e| panic!("{scheme:?} {levels} {limit}: {e}"));
                assert_eq!((out.face_count(), out.vertex_count()), (0, 0));
            }
        }
    }
}

#[test]
fn a_cancelled_token_stops_refinement_before_the_next_level() {
    let token = sylva::cancel::Cancel::new();
    let cube = cube();
    let o = opts(Scheme::CatmullClark, 2);
    // Not cancelled: the same calls succeed inside the scope.
    let refiner = sylva::cancel::scope(&token, || Refiner::new(&cube, &[], &o)).unwrap();
    token.cancel();
    let r = sylva::cancel::scope(&token, || Refiner::new(&cube, &[], &o));
    assert!(matches!(r, Err(RefineError::Cancelled { level: 1 })), "{r:?}");
    let r = sylva::cancel::scope(&token, || refiner.interpolate(&cube.positions));
    assert!(matches!(r, Err(RefineError::Cancelled { level: 1 })), "{r:?}");
    let r = sylva::cancel::scope(&token, || {
        subdivide(&cube, &[], &SubdivideOptions { refine: o.clone(), ..Default::default() })
    });
    let e: sylva::Error = r.unwrap_err().into();
    assert!(matches!(e, sylva::Error::Cancelled), "{e:?}");
    // Outside the scope the token is not seen.
    assert!(Refiner::new(&cube, &[], &o).is_ok());
}
