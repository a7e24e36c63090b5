//! Adaptive Loop refinement (`sylva::refine::adaptive`, MacMurchy2004 §A.3, MacMurchy2004-spec §2.11 and
//! test 27) and fractal noise between levels (`sylva::refine::noise`, MacMurchy2004 §6.5, MacMurchy2004-spec
//! §2.13 and test 25): conforming output (no cracks, no T-junctions), flat regions
//! stay coarse, Loop positions where refined, fewer triangles than uniform refinement at
//! the same maximum error on a tree mesh; noise determinism and amplitude per level.

use glam::{Vec2, Vec3};
use std::collections::HashSet;
use std::time::Instant;
use sylva::geometry::{FaceVarying, Mesh};
use sylva::refine::adaptive::{adaptive_loop, adaptive_loop_levels, AdaptiveOptions};
use sylva::refine::noise::{bias, displace, subdivide_with_noise, FeatureSize, NoiseOptions};
use sylva::refine::{subdivide, Corner, RefineOptions, Scheme, SubdivideOptions, Topology};
#[path = "common/meshes.rs"]
mod meshes;
use meshes::mesh_from;

// ---------------------------------------------------------------------------------------
// Meshes and checks

/// An octahedron stretched along x (a closed mesh with sharp and flat-ish parts).
fn stretched_octahedron() -> Mesh {
    let mut m = meshes::octahedron();
    for p in &mut m.positions {
        p.x *= 3.0;
    }
    m
}

/// A triangulated n×n grid on [0, 1]² with a bump of height `h` around (0.8, 0.8).
fn bumpy_grid(n: u32, h: f32) -> Mesh {
    let w = n + 1;
    let mut pos = Vec::new();
    let mut uv = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            let r2 = (x - 0.8).powi(2) + (y - 0.8).powi(2);
            pos.push(Vec3::new(x, y, h * (-r2 / 0.01).exp()));
            uv.push(Vec2::new(x, y));
        }
    }
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * w + i;
            faces.push([a, a + 1, a + w + 1]);
            faces.push([a, a + w + 1, a + w]);
        }
    }
    let mut m = mesh_from(pos, &faces);
    m.uvs = Some(FaceVarying { values: uv, indices: m.face_indices.clone() });
    m
}

/// The bark of `lsys-honda-a` (the tube mesher's triangles) with `n` branching orders
/// (the preset's 10 gives 40,944 triangles).
fn honda_bark(n: i64) -> Mesh {
    let sets = [("generator.define.N".to_string(), toml::Value::Integer(n))];
    let loaded = sylva::recipe::load("lsys-honda-a", &sets).unwrap();
    let grown = sylva::pipeline::grow(&loaded).unwrap();
    let mut m = grown.model.parts[0].mesh.clone();
    m.normals = None;
    m
}

fn topology(m: &Mesh) -> Topology {
    Topology::from_faces(m.vertex_count(), &m.face_offsets, &m.face_indices)
        .expect("manifold, oriented output")
}

fn boundary_edges(t: &Topology) -> usize {
    (0..t.edge_count()).filter(|&e| t.is_boundary_edge(e)).count()
}

/// Boundary loops: connected components of the boundary edges.
fn boundary_loops(t: &Topology) -> usize {
    let mut parent: Vec<u32> = (0..t.vertex_count() as u32).collect();
    fn root(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    let mut on = HashSet::new();
    for e in (0..t.edge_count()).filter(|&e| t.is_boundary_edge(e)) {
        let [a, b] = t.edge(e);
        on.insert(a);
        on.insert(b);
        let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
        parent[ra as usize] = rb;
    }
    on.iter().map(|&v| root(&mut parent, v)).collect::<HashSet<_>>().len()
}

fn euler(t: &Topology) -> i64 {
    t.vertex_count() as i64 - t.edge_count() as i64 + t.face_count() as i64
}

/// Why `out` is not a crack-free refinement of `input` (empty when it is): it must be
/// manifold and consistently oriented, with the same Euler characteristic and the same
/// number of boundary loops as the input (a T-junction or crack opens an extra hole), and
/// closed when the input is closed (every edge has the same two vertices on both sides).
fn conforming_problems(input: &Mesh, out: &Mesh) -> Vec<String> {
    let t0 = topology(input);
    let t = match Topology::from_faces(out.vertex_count(), &out.face_offsets, &out.face_indices) {
        Ok(t) => t,
        Err(e) => return vec![format!("not manifold and oriented: {e}")],
    };
    let mut problems = Vec::new();
    if euler(&t) != euler(&t0) {
        problems.push(format!("Euler characteristic {} ≠ {}", euler(&t), euler(&t0)));
    }
    if boundary_loops(&t) != boundary_loops(&t0) {
        problems.push(format!(
            "{} boundary loops ≠ {} (a crack adds one)",
            boundary_loops(&t),
            boundary_loops(&t0)
        ));
    }
    if boundary_edges(&t0) == 0 && boundary_edges(&t) != 0 {
        problems.push(format!("closed input, but {} edges have one face", boundary_edges(&t)));
    }
    // No vertex is unused (every vertex belongs to a face).
    let used: HashSet<u32> = out.face_indices.iter().copied().collect();
    if used.len() != out.vertex_count() {
        problems.push(format!(
            "{} of {} vertices unused",
            out.vertex_count() - used.len(),
            out.vertex_count()
        ));
    }
    problems
}

fn assert_conforming(input: &Mesh, out: &Mesh) {
    let problems = conforming_problems(input, out);
    assert!(problems.is_empty(), "not crack-free: {problems:?}");
}

fn loop_uniform(m: &Mesh, levels: u32, limit: bool) -> Mesh {
    let opts = SubdivideOptions {
        refine: RefineOptions { scheme: Scheme::Loop, levels, ..Default::default() },
        limit,
        ..Default::default()
    };
    subdivide(m, &[], &opts).unwrap()
}

// ---------------------------------------------------------------------------------------
// Point-to-surface distance (one-sided Hausdorff) with a uniform grid

fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    // Ericson, Real-Time Collision Detection §5.1.5.
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Max over `points` of the distance to the triangles of `m` (a hashed uniform grid with
/// cells about twice the mean edge length; rings are searched until the nearest triangle
/// found is provably the nearest).
fn max_distance(points: &[Vec3], m: &Mesh) -> f32 {
    use glam::IVec3;
    use std::collections::HashMap;
    let tri = |f: usize| {
        let v = m.face(f);
        [m.positions[v[0] as usize], m.positions[v[1] as usize], m.positions[v[2] as usize]]
    };
    let mean_edge = (0..m.face_count()).map(|f| (tri(f)[1] - tri(f)[0]).length()).sum::<f32>()
        / m.face_count().max(1) as f32;
    let cell = (2.0 * mean_edge).max(1e-6);
    let cell_of = |p: Vec3| (p / cell).floor().as_ivec3();
    let mut bins: HashMap<IVec3, Vec<u32>> = HashMap::new();
    for f in 0..m.face_count() {
        let [a, b, c] = tri(f);
        let (c0, c1) = (cell_of(a.min(b).min(c)), cell_of(a.max(b).max(c)));
        for z in c0.z..=c1.z {
            for y in c0.y..=c1.y {
                for x in c0.x..=c1.x {
                    bins.entry(IVec3::new(x, y, z)).or_default().push(f as u32);
                }
            }
        }
    }
    let (lo, hi) = m.bounds().unwrap();
    let max_ring = ((hi - lo).max_element() / cell).ceil() as i32 + 2;
    let mut worst = 0.0f32;
    for &p in points {
        let c = cell_of(p);
        let mut best = f32::INFINITY;
        for r in 0..=max_ring {
            for z in c.z - r..=c.z + r {
                for y in c.y - r..=c.y + r {
                    for x in c.x - r..=c.x + r {
                        let shell = (x - c.x).abs().max((y - c.y).abs()).max((z - c.z).abs());
                        if shell != r {
                            continue;
                        }
                        if let Some(fs) = bins.get(&IVec3::new(x, y, z)) {
                            for &f in fs {
                                let [a, b, c] = tri(f as usize);
                                best = best.min((closest_on_triangle(p, a, b, c) - p).length());
                            }
                        }
                    }
                }
            }
            // Every triangle within r·cell of p has been seen.
            if best <= r as f32 * cell {
                break;
            }
        }
        worst = worst.max(best);
    }
    worst
}

// ---------------------------------------------------------------------------------------
// Adaptive refinement

#[test]
fn closed_mesh_stays_closed_without_t_junctions() {
    let m = stretched_octahedron();
    for (flatness, min_area) in [(0.2, 0.0), (0.6, 0.01), (1.2, 0.05), (0.3, 0.2)] {
        let opts = AdaptiveOptions { max_levels: 4, flatness, min_area, ..Default::default() };
        let (out, levels) = adaptive_loop_levels(&m, &[], &opts).unwrap();
        assert_conforming(&m, &out);
        assert_eq!(levels.len(), out.face_count());
        let (lo, hi) = (levels.iter().min().unwrap(), levels.iter().max().unwrap());
        assert!(out.positions.iter().all(|p| p.is_finite()));
        if (flatness, min_area) == (0.6, 0.01) {
            assert!(lo < hi, "a stretched octahedron refines unevenly: levels {lo}..{hi}");
        }
    }
}

/// The crack check used by every adaptive test catches a T-junction: a square of two
/// triangles where one triangle is split at the midpoint of the shared diagonal and the
/// other is not (so the diagonal has a vertex on one side only), on a closed mesh too.
#[test]
fn crack_check_detects_a_t_junction() {
    let square =
        mesh_from(vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y], &[[0, 1, 2], [0, 2, 3]]);
    let mut cracked = square.clone();
    cracked.positions.push(Vec3::new(0.5, 0.5, 0.0));
    cracked.face_offsets.clear();
    cracked.face_indices.clear();
    for f in [[0, 1, 2], [0, 4, 3], [4, 2, 3]] {
        cracked.push_face(&f);
    }
    assert!(conforming_problems(&square, &square).is_empty());
    // The hole along the diagonal leaves vertex 0 with two separate fans of faces.
    assert!(!conforming_problems(&square, &cracked).is_empty());
    // On a closed mesh: the octahedron with one face split green on one side only.
    let o = stretched_octahedron();
    let mut t = o.clone();
    let [a, b, c] = [o.face(0)[0], o.face(0)[1], o.face(0)[2]];
    let m = t.positions.len() as u32;
    t.positions.push((o.positions[a as usize] + o.positions[b as usize]) * 0.5);
    t.face_offsets.clear();
    t.face_indices.clear();
    t.push_face(&[a, m, c]);
    t.push_face(&[m, b, c]);
    for f in 1..o.face_count() {
        t.push_face(o.face(f));
    }
    let problems = conforming_problems(&o, &t);
    assert!(problems.iter().any(|p| p.contains("edges have one face")), "{problems:?}");
}

#[test]
fn infinite_flatness_or_huge_size_means_no_refinement() {
    // MacMurchy2004-spec test 27.
    let m = stretched_octahedron();
    for opts in [
        AdaptiveOptions { flatness: f32::INFINITY, min_area: 0.0, ..Default::default() },
        AdaptiveOptions { flatness: 0.0, min_area: 1e9, ..Default::default() },
    ] {
        let out = adaptive_loop(&m, &[], &opts).unwrap();
        assert_eq!(out.face_count(), m.face_count());
        assert_eq!(out.positions, m.positions);
    }
}

#[test]
fn zero_tolerances_equal_uniform_loop() {
    // Everything refined to the deepest level: exactly Loop's uniform result.
    let m = stretched_octahedron();
    let opts = AdaptiveOptions { max_levels: 3, flatness: 0.0, min_area: 0.0, ..Default::default() };
    let out = adaptive_loop(&m, &[], &opts).unwrap();
    let uni = loop_uniform(&m, 3, false);
    assert_eq!(out.face_count(), uni.face_count());
    assert_eq!(out.vertex_count(), uni.vertex_count());
    let key = |p: &Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let a: HashSet<_> = out.positions.iter().map(key).collect();
    let b: HashSet<_> = uni.positions.iter().map(key).collect();
    assert_eq!(a, b, "same positions, bit for bit");
}

#[test]
fn flat_regions_stay_coarse_and_the_bump_is_refined() {
    let m = bumpy_grid(8, 0.3);
    let opts = AdaptiveOptions { max_levels: 3, flatness: 0.1, min_area: 1e-5, ..Default::default() };
    // The square's corners are tagged corners: the boundary may turn there.
    let corners: Vec<Corner> =
        [0, 8, 72, 80].map(|vertex| Corner { vertex, sharpness: f32::INFINITY }).to_vec();
    let (out, levels) = adaptive_loop_levels(&m, &corners, &opts).unwrap();
    assert_conforming(&m, &out);
    let t = topology(&out);
    // Faces near (0.2, 0.2), far from the bump, stay at level 0; the bump reaches level 3.
    let mut far_levels = HashSet::new();
    let mut bump_max = 0;
    for (f, &l) in levels.iter().enumerate() {
        let c = out.face(f).iter().map(|&v| out.positions[v as usize]).sum::<Vec3>() / 3.0;
        if c.x < 0.4 && c.y < 0.4 {
            far_levels.insert(l);
        }
        if (c.x - 0.8).abs() < 0.1 && (c.y - 0.8).abs() < 0.1 {
            bump_max = bump_max.max(l);
        }
    }
    assert_eq!(far_levels, HashSet::from([0]), "flat corner stays coarse");
    assert_eq!(bump_max, 3, "bump refined to the deepest level");
    assert!(out.face_count() < m.face_count() * 64 / 4);
    // Flat faces keep their plane; boundary stays on the square.
    for p in &out.positions {
        if p.x < 0.4 && p.y < 0.4 {
            assert!(p.z.abs() < 1e-3, "{p}");
        }
    }
    assert!(boundary_edges(&t) > 0);
    // UVs are carried linearly: on the flat part u = x, v = y (the boundary is pinned).
    let uv = out.uvs.as_ref().unwrap();
    for (c, &v) in out.face_indices.iter().enumerate() {
        let p = out.positions[v as usize];
        let q = uv.values[uv.indices[c] as usize];
        if p.x < 0.3 && p.y < 0.3 {
            assert!((q - Vec2::new(p.x, p.y)).length() < 0.05, "{p} {q}");
        }
    }
}

#[test]
fn seams_and_creases_survive() {
    // A sharp crease across the octahedron's equator: conforming, and positions finite.
    let mut m = stretched_octahedron();
    m.creases = vec![
        sylva::geometry::Crease { a: 0, b: 2, sharpness: f32::INFINITY },
        sylva::geometry::Crease { a: 2, b: 1, sharpness: 2.0 },
    ];
    let opts = AdaptiveOptions { max_levels: 3, flatness: 0.3, min_area: 0.0, ..Default::default() };
    let out = adaptive_loop(&m, &[], &opts).unwrap();
    assert_conforming(&m, &out);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let m = stretched_octahedron();
    assert!(adaptive_loop(&m, &[], &AdaptiveOptions { flatness: f32::NAN, ..Default::default() }).is_err());
    assert!(adaptive_loop(&m, &[], &AdaptiveOptions { min_area: -1.0, ..Default::default() }).is_err());
    assert!(adaptive_loop(&m, &[], &AdaptiveOptions { max_levels: 40, ..Default::default() }).is_err());
    let mut quad = Mesh::new();
    quad.positions = vec![Vec3::ZERO, Vec3::X, Vec3::ONE, Vec3::Y];
    quad.push_face(&[0, 1, 2, 3]);
    assert!(adaptive_loop(&quad, &[], &AdaptiveOptions::default()).is_err());
    let mut bad = stretched_octahedron();
    bad.face_indices[0] = 99;
    assert!(adaptive_loop(&bad, &[], &AdaptiveOptions::default()).is_err());
    assert_eq!(adaptive_loop(&Mesh::new(), &[], &AdaptiveOptions::default()).unwrap().face_count(), 0);
}

/// MacMurchy2004 / issue 4: fewer triangles than uniform refinement at the same maximum error
/// on a tree mesh. Error: the largest distance from the limit surface (sampled at the
/// limit positions of uniform level N + 1) to the approximating triangles.
#[test]
fn fewer_triangles_than_uniform_at_the_same_error_on_a_tree() {
    let bark = honda_bark(6);
    let n = 2;
    let reference = loop_uniform(&bark, n + 1, true).positions;
    let uniform = loop_uniform(&bark, n, false);
    let e_uniform = max_distance(&reference, &uniform);
    let opts = AdaptiveOptions { max_levels: n, flatness: 0.25, min_area: 3e-4, ..Default::default() };
    let adaptive = adaptive_loop(&bark, &[], &opts).unwrap();
    assert_conforming(&bark, &adaptive);
    let e_adaptive = max_distance(&reference, &adaptive);
    println!(
        "tree bark {} tris: uniform L{n} {} tris, error {e_uniform:.3e}; adaptive {} tris, error {e_adaptive:.3e}",
        bark.face_count(),
        uniform.face_count(),
        adaptive.face_count()
    );
    assert!(e_adaptive <= e_uniform * 1.0001, "adaptive error {e_adaptive} > uniform {e_uniform}");
    assert!(
        adaptive.face_count() < uniform.face_count(),
        "{} ≥ {}",
        adaptive.face_count(),
        uniform.face_count()
    );
}

/// Timing and counts for the report (`cargo test --release --test refine_adaptive -- --ignored --nocapture`).
#[test]
#[ignore]
fn bench_adaptive_vs_uniform() {
    let order: i64 = std::env::var("HONDA_N").ok().and_then(|v| v.parse().ok()).unwrap_or(10);
    let levels: Vec<u32> = std::env::var("LEVELS")
        .ok()
        .map_or(vec![2], |v| v.split(',').filter_map(|x| x.parse().ok()).collect());
    let areas: Vec<f32> = std::env::var("AREAS")
        .ok()
        .map_or(vec![2e-5], |v| v.split(',').filter_map(|x| x.parse().ok()).collect());
    let bark = honda_bark(order);
    println!("| mesh | levels | min_area | uniform tris | uniform ms | adaptive tris | adaptive ms | uniform error | adaptive error |");
    for &n in &levels {
        let reference = loop_uniform(&bark, n + 1, true).positions;
        let t = Instant::now();
        let uniform = loop_uniform(&bark, n, false);
        let tu = t.elapsed().as_secs_f64() * 1e3;
        let eu = max_distance(&reference, &uniform);
        for &min_area in &areas {
            let opts = AdaptiveOptions { max_levels: n, flatness: 0.25, min_area, ..Default::default() };
            let t = Instant::now();
            let adaptive = adaptive_loop(&bark, &[], &opts).unwrap();
            let ta = t.elapsed().as_secs_f64() * 1e3;
            let ea = max_distance(&reference, &adaptive);
            println!(
                "| honda-a N={order} bark ({} tris) | {n} | {min_area:e} | {} | {tu:.1} | {} | {ta:.1} | {eu:.3e} | {ea:.3e} |",
                bark.face_count(),
                uniform.face_count(),
                adaptive.face_count()
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Fractal noise

#[test]
fn bias_function_properties() {
    // MacMurchy2004-spec test 25.
    for b in [0.05, 0.25, 0.5, 0.75, 0.95] {
        assert_eq!(bias(b, 0.0), 0.0);
        assert_eq!(bias(b, 1.0), 1.0);
    }
    for t in [0.1f32, 0.3, 0.5, 0.9] {
        assert!((bias(0.5, t) - t).abs() < 1e-6);
        assert!(bias(0.25, t) < t && bias(0.75, t) > t);
    }
    assert_eq!(bias(f32::NAN, 0.5), 0.0);
}

fn sphere() -> Mesh {
    // Octahedron projected to the unit sphere and refined once: a round closed mesh.
    let m = loop_uniform(&stretched_octahedron(), 1, false);
    let mut m = m;
    m.positions.iter_mut().for_each(|p| *p = p.normalize());
    m
}

#[test]
fn noise_is_deterministic_and_zero_scale_is_no_noise() {
    let m = sphere();
    let opts = NoiseOptions { k: 0.05, ..Default::default() };
    let (mut a, mut b, mut c) = (m.clone(), m.clone(), m.clone());
    displace(&mut a, 1, &opts, 42).unwrap();
    displace(&mut b, 1, &opts, 42).unwrap();
    displace(&mut c, 1, &opts, 43).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, c);
    assert_ne!(a, m);
    let mut z = m.clone();
    displace(&mut z, 1, &NoiseOptions { k: 0.0, ..Default::default() }, 42).unwrap();
    assert_eq!(z, m);
    let mut l0 = m.clone();
    displace(&mut l0, 0, &opts, 42).unwrap();
    assert_eq!(l0, m, "level 0 (the coarse mesh) is never perturbed");
    // Whole pipeline: deterministic, and k = 0 equals plain subdivision bit for bit.
    let so = SubdivideOptions {
        refine: RefineOptions { scheme: Scheme::Loop, levels: 3, ..Default::default() },
        ..Default::default()
    };
    let x = subdivide_with_noise(&stretched_octahedron(), &[], &so, &opts, 7).unwrap();
    let y = subdivide_with_noise(&stretched_octahedron(), &[], &so, &opts, 7).unwrap();
    assert_eq!(x, y);
    let plain = subdivide(&stretched_octahedron(), &[], &so).unwrap();
    let zero =
        subdivide_with_noise(&stretched_octahedron(), &[], &so, &NoiseOptions { k: 0.0, ..opts.clone() }, 7)
            .unwrap();
    assert_eq!(zero, plain);
    assert_ne!(x, plain);
    assert_eq!(x.face_count(), plain.face_count());
}

#[test]
fn amplitude_follows_k_l_pow_minus_ih() {
    // The displacement's standard deviation at level i is k·L^(−iH) (× Bias = 1 at t = 1).
    let m = loop_uniform(&sphere(), 2, false); // ~ 500 vertices
    let opts = NoiseOptions { k: 0.01, lacunarity: 2.0, h: 0.8, bias: 0.5, feature: FeatureSize::Uniform };
    let mut prev = f32::INFINITY;
    for i in 1..=4u32 {
        let mut sum2 = 0.0f64;
        let mut count = 0usize;
        for seed in 0..8 {
            let mut d = m.clone();
            displace(&mut d, i, &opts, seed).unwrap();
            for (a, b) in d.positions.iter().zip(&m.positions) {
                let along = (*a - *b).dot(b.normalize()); // normals of the sphere ≈ radial
                sum2 += (along as f64).powi(2);
                count += 1;
            }
        }
        let sd = (sum2 / count as f64).sqrt() as f32;
        let expected = 0.01 * 2f32.powf(-(i as f32) * 0.8);
        assert!((sd / expected - 1.0).abs() < 0.08, "level {i}: sd {sd} vs S {expected}");
        assert!(opts.sigma(i) < prev, "S strictly decreases for L > 1, H > 0");
        assert!((opts.sigma(i) - expected).abs() < 1e-9);
        prev = opts.sigma(i);
    }
}

#[test]
fn bias_scales_noise_per_vertex() {
    let m = sphere();
    let n = m.vertex_count();
    // t = 0 on the lower half (no noise), 1 on the upper half (full noise).
    let t: Vec<f32> = m.positions.iter().map(|p| if p.y > 0.0 { 1.0 } else { 0.0 }).collect();
    let opts = NoiseOptions { k: 0.05, feature: FeatureSize::PerVertex(t), ..Default::default() };
    let mut d = m.clone();
    displace(&mut d, 1, &opts, 1).unwrap();
    for i in 0..n {
        let moved = (d.positions[i] - m.positions[i]).length() > 0.0;
        assert_eq!(moved, m.positions[i].y > 0.0, "vertex {i}");
    }
    // Height fall-off with top = 0: the highest vertex does not move.
    let opts = NoiseOptions { k: 0.05, feature: FeatureSize::Height { top: 0.0 }, ..Default::default() };
    let mut d = m.clone();
    displace(&mut d, 1, &opts, 1).unwrap();
    let top = (0..n).max_by(|&a, &b| m.positions[a].y.total_cmp(&m.positions[b].y)).unwrap();
    assert_eq!(d.positions[top], m.positions[top]);
    // Bad values are errors.
    for bad in [
        NoiseOptions { k: f32::NAN, ..Default::default() },
        NoiseOptions { h: 1.5, ..Default::default() },
        NoiseOptions { bias: -0.1, ..Default::default() },
        NoiseOptions { lacunarity: 0.0, ..Default::default() },
        NoiseOptions { feature: FeatureSize::PerVertex(vec![0.5; 3]), ..Default::default() },
    ] {
        assert!(displace(&mut m.clone(), 1, &bad, 0).is_err(), "{bad:?}");
    }
}

/// The deepest level is evaluated sparsely (only where red-refined faces have children),
/// with the uniform kernel's arithmetic: every output vertex is, bit for bit, a vertex of
/// uniform Loop refinement at some level, also with semi-sharp (fractional) creases under
/// both decay rules, a tagged corner and an open boundary, and the deepest level is used.
#[test]
fn sparse_deepest_level_matches_uniform_with_creases_corners_and_boundary() {
    use sylva::refine::{BoundaryInterpolation, CreasingMethod};
    let mut oct = stretched_octahedron();
    oct.creases = vec![
        sylva::geometry::Crease { a: 0, b: 2, sharpness: f32::INFINITY },
        sylva::geometry::Crease { a: 2, b: 1, sharpness: 1.5 },
        sylva::geometry::Crease { a: 1, b: 3, sharpness: 0.4 },
    ];
    let mut grid = bumpy_grid(4, 0.3);
    grid.creases = vec![sylva::geometry::Crease { a: 6, b: 12, sharpness: 2.3 }];
    let corners = [Corner { vertex: 4, sharpness: 1.7 }];
    let key = |p: &Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    for m in [&oct, &grid] {
        for creasing in [CreasingMethod::Uniform, CreasingMethod::Chaikin] {
            for boundary in [BoundaryInterpolation::EdgeOnly, BoundaryInterpolation::EdgeAndCorner] {
                for levels in 1..=3 {
                    let opts = AdaptiveOptions {
                        max_levels: levels,
                        flatness: 0.05,
                        min_area: 0.0,
                        boundary,
                        creasing,
                        ..Default::default()
                    };
                    let (out, face_levels) = adaptive_loop_levels(m, &corners, &opts).unwrap();
                    assert_conforming(m, &out);
                    assert_eq!(face_levels.iter().max(), Some(&(levels as u8)));
                    let mut uniform: HashSet<[u32; 3]> = m.positions.iter().map(key).collect();
                    for l in 1..=levels {
                        let so = SubdivideOptions {
                            refine: RefineOptions {
                                scheme: Scheme::Loop,
                                levels: l,
                                boundary,
                                creasing,
                                ..Default::default()
                            },
                            ..Default::default()
                        };
                        uniform.extend(subdivide(m, &corners, &so).unwrap().positions.iter().map(key));
                    }
                    for p in &out.positions {
                        assert!(uniform.contains(&key(p)), "{p} ({creasing:?} {boundary:?} level {levels})");
                    }
                }
            }
        }
    }
}
