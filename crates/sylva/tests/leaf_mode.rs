//! MacMurchy2004's leaf mode (`/L`, `mesh.method = "leaf"`, issue 26): the leaf mesher of
//! `crates/sylva/src/mesh/leaf.rs` checked against MacMurchy2004-spec §7 properties 1–5, 21, 22
//! and 24, with compound leaves (junctions of 2 and 3 children), Loop refinement of the
//! midrib and tip creases, and a `.str` leaf grown end to end to an OBJ file.

use glam::Vec3;
use std::collections::{HashMap, HashSet};
use sylva::import::cpfg_str;
use sylva::lsystem::source::Source;
use sylva::lsystem::turtle::CPFG_LEFT;
use sylva::lsystem::{interpret, TurtleOptions};
use sylva::mesh::leaf::{leaf_mesh, LeafMapping, LeafMesh, LeafOptions};
use sylva::refine::{subdivide, RefineOptions, Scheme, SubdivideOptions};
use sylva::{Mesh, Skeleton};

/// A cpfg `.str` string interpreted in cpfg's frame (H = +Y, L = −X, U = +Z).
fn str_skeleton(text: &str) -> Skeleton {
    let (symbols, string) = cpfg_str::parse("t.str", text).unwrap();
    let opts = TurtleOptions { left: CPFG_LEFT, ..Default::default() };
    interpret(&symbols, &string, &opts, &Source::new("t.str", "", &[]).unwrap()).unwrap()
}

fn leaf(text: &str, opts: &LeafOptions) -> LeafMesh {
    leaf_mesh(&str_skeleton(text), opts).unwrap()
}

/// Undirected edges with their face counts; panics on a directed edge used twice
/// (inconsistent orientation or a non-manifold edge).
fn edges(m: &Mesh) -> HashMap<(u32, u32), usize> {
    let mut directed = HashSet::new();
    let mut e = HashMap::new();
    for f in 0..m.face_count() {
        let v = m.face(f);
        assert_eq!(v.len(), 3, "property 1: face {f} is not a triangle");
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            assert_ne!(a, b, "degenerate face {f}");
            assert!(directed.insert((a, b)), "property 4: directed edge {a}->{b} used twice");
            *e.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    for (k, n) in &e {
        assert!(*n <= 2, "property 4: edge {k:?} has {n} faces");
    }
    e
}

/// Number of boundary loops (boundary edges chained by their shared vertices).
fn boundary_loops(m: &Mesh) -> usize {
    let e = edges(m);
    let mut adj: HashMap<u32, Vec<u32>> = HashMap::new();
    for (&(a, b), &n) in &e {
        if n == 1 {
            adj.entry(a).or_default().push(b);
            adj.entry(b).or_default().push(a);
        }
    }
    for (v, n) in &adj {
        assert_eq!(n.len(), 2, "boundary vertex {v} has {} boundary edges (pinched)", n.len());
    }
    let mut seen = HashSet::new();
    let mut loops = 0;
    for &start in adj.keys() {
        if seen.contains(&start) {
            continue;
        }
        loops += 1;
        let mut stack = vec![start];
        while let Some(v) = stack.pop() {
            if seen.insert(v) {
                stack.extend(adj[&v].iter().copied());
            }
        }
    }
    loops
}

fn euler(m: &Mesh) -> i64 {
    m.vertex_count() as i64 - edges(m).len() as i64 + m.face_count() as i64
}

fn loop_refine(m: &Mesh, levels: u32) -> Mesh {
    let opts = SubdivideOptions {
        refine: RefineOptions { scheme: Scheme::Loop, levels, ..Default::default() },
        ..Default::default()
    };
    subdivide(m, &[], &opts).unwrap()
}

const TRIFURCATE: &str = "!(0.4)F(1)[+(45)F(1)][-(45)F(1)]F(1)";
const LATERAL: &str = "!(0.4)F(1)[+(45)F(1)]F(1)";
const BIFURCATE: &str = "!(0.4)F(1)[+(35)F(1)][-(35)F(1)]";

/// Property 21: a tip adds exactly 2 triangles and 1 vertex, its apex at Tip Size ×
/// width along (last − second-last section).
#[test]
fn a_tip_adds_two_triangles_one_vertex_at_tip_size_times_width() {
    for tip_size in [0.5, 1.0, 2.5] {
        let opts = LeafOptions { tip_size, ..Default::default() };
        for k in 1..4 {
            let text = format!("!(0.4){}", "F(1)+(20)&(10)".repeat(k));
            let l = leaf(&text, &opts);
            // k strips of 4 triangles on k + 1 sections of 3 vertices, plus the tip.
            assert_eq!(l.mesh.face_count(), 4 * k + 2, "{text}");
            assert_eq!(l.mesh.vertex_count(), 3 * (k + 1) + 1, "{text}");
            assert_eq!(l.tips.len(), 1);
            let t = l.tips[0];
            assert_eq!(t.apex as usize, l.mesh.vertex_count() - 1, "the apex is the tip's one vertex");
            for f in t.faces {
                assert!(l.mesh.face(f).contains(&t.apex));
            }
            let faces_with_apex =
                (0..l.mesh.face_count()).filter(|&f| l.mesh.face(f).contains(&t.apex)).count();
            assert_eq!(faces_with_apex, 2);
            // The apex from the skeleton: last and second-last section centres are the
            // tip node and its parent (chain nodes).
            let sk = str_skeleton(&text);
            let n = sk.len() - 1;
            let (last, prev) = (sk.position[n].as_dvec3(), sk.position[n - 1].as_dvec3());
            let width = 2.0 * sk.radius[n] as f64;
            let want = last + tip_size * width * (last - prev).normalize();
            let got = l.mesh.positions[t.apex as usize].as_dvec3();
            assert!((got - want).length() < 1e-5, "apex {got} != {want} ({text}, tip {tip_size})");
            // The section centre really is the margins' midpoint.
            let [r, _, lm] = t.section;
            let mid = (l.mesh.positions[r as usize] + l.mesh.positions[lm as usize]).as_dvec3() * 0.5;
            assert!((mid - last).length() < 1e-5);
        }
    }
}

/// Property 22: no two coarse leaf vertices closer than ε; the midrib crease edges form
/// one chain per axis.
#[test]
fn coarse_vertices_are_apart_and_midribs_chain_per_axis() {
    let e = LeafOptions { tip_sharpness: 3.0, ..Default::default() };
    for (text, axes) in [(TRIFURCATE, 3), (LATERAL, 2), (BIFURCATE, 3), ("!(0.4)F(1)F(1)F(1)", 1)] {
        let l = leaf(text, &e);
        let p = &l.mesh.positions;
        let size = l.mesh.bounds().map(|(a, b)| (b - a).length()).unwrap();
        let eps = 1e-3 * size;
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                assert!(
                    p[i].distance(p[j]) > eps,
                    "{text}: vertices {i} and {j} are {} apart",
                    p[i].distance(p[j])
                );
            }
        }
        assert_eq!(l.midribs.len(), axes, "{text}: one chain per axis");
        let creases: HashSet<(u32, u32)> =
            l.mesh.creases.iter().map(|c| (c.a.min(c.b), c.a.max(c.b))).collect();
        assert_eq!(creases.len(), l.mesh.creases.len(), "no crease twice");
        let mut covered = HashSet::new();
        for chain in &l.midribs {
            let distinct: HashSet<u32> = chain.iter().copied().collect();
            assert_eq!(distinct.len(), chain.len(), "{text}: chain {chain:?} is not a simple path");
            for w in chain.windows(2) {
                let k = (w[0].min(w[1]), w[0].max(w[1]));
                assert!(creases.contains(&k), "{text}: chain edge {k:?} is not a crease");
                assert!(covered.insert(k), "{text}: edge {k:?} in two chains");
            }
        }
        assert_eq!(covered, creases, "{text}: every crease lies on one axis' chain");
        // Each chain ends at a tip apex.
        let apexes: HashSet<u32> = l.tips.iter().map(|t| t.apex).collect();
        assert_eq!(l.midribs.iter().filter(|c| apexes.contains(c.last().unwrap())).count(), l.tips.len());
    }
}

/// Properties 1, 3, 4, 5 for leaves: triangles, V − E + F = 1 and one boundary loop per
/// connected leaf, edge-manifold and consistently oriented (facing the turtle's +U).
#[test]
fn every_leaf_is_one_open_disc_with_one_boundary_loop() {
    let two_leaves = "!(0.3)F(1)F(1)f(3)F(1)[+(30)F(1)][-(30)F(1)]";
    for (text, pieces) in [
        (TRIFURCATE, 1),
        (LATERAL, 1),
        (BIFURCATE, 1),
        (two_leaves, 2),
        ("[+(40)F(1)][-(40)F(1)]", 1),
        ("!(0.4)F(1)[+(30)F(1)[-(30)F(1)][+(30)F(1)]][-(60)F(1)]&(20)/(30)F(1)[+(90)F(0.5)]F(1)", 1),
    ] {
        let l = leaf(text, &LeafOptions::default());
        assert_eq!(l.pieces, pieces, "{text}");
        assert_eq!(euler(&l.mesh), pieces as i64, "{text}: V − E + F");
        assert_eq!(boundary_loops(&l.mesh), pieces, "{text}: boundary loops");
        // Front faces face +Z for a leaf drawn in the cpfg plane with only turns.
        if !text.contains('&') {
            for f in 0..l.mesh.face_count() {
                let v = l.mesh.face(f);
                let [a, b, c] = [0, 1, 2].map(|k| l.proxy.positions[v[k] as usize]);
                assert!((b - a).cross(c - a).z > 0.0, "{text}: face {f} is not counter-clockwise from +U");
            }
        }
        // Property 3: invariant under subdivision.
        let r = loop_refine(&l.mesh, 2);
        assert_eq!(euler(&r), pieces as i64, "{text}: refined V − E + F");
        assert_eq!(boundary_loops(&r), pieces);
    }
}

/// Junctions of 2 and of 3+ children: the coincident base vertices of neighbouring
/// children are merged (n − 1 per junction), the fan has 2n + 4 triangles, and with the
/// Eq 5.1 offsets the two margins met before merging (the merged vertex lies on both
/// children's margin lines: a single centre vertex fanned to the whole polygon).
#[test]
fn junctions_of_two_and_three_children_merge_their_base_vertices() {
    for (text, n) in [
        (LATERAL, 2),
        (TRIFURCATE, 3),
        (BIFURCATE, 2),
        ("!(0.4)F(1)[+(60)F(1)][+(20)F(1)][-(20)F(1)][-(60)F(1)]", 4),
    ] {
        let l = leaf(text, &LeafOptions { midrib_depth: 0.0, ..Default::default() });
        assert_eq!(l.junctions.len(), 1, "{text}");
        assert_eq!(l.merged, n - 1, "{text}");
        let j = l.junctions[0];
        // The fan and the trunk's 4 strip faces belong to node j.
        let fan = l.face_node.iter().filter(|&&node| node == j).count();
        assert_eq!(fan, 2 * n + 4 + 4, "{text}");
        // Vertex count: trunk base + trunk end + X + n child sections − (n − 1) merged
        // + n end sections + n tips (+ the continuation counts as a child).
        let internodes = 1 + n;
        assert_eq!(l.mesh.vertex_count(), 3 + 3 + 1 + 3 * n - (n - 1) + 3 * n + n, "{text}");
        assert_eq!(l.mesh.face_count(), 4 * internodes + (2 * n + 4) + 2 * n, "{text}");
        // Every merged vertex is on the boundary of both neighbours' margins: it has
        // exactly 2 boundary edges and a bounded distance to the node.
        let node = str_skeleton(text).position[j as usize];
        let e = edges(&l.mesh);
        let xs: Vec<u32> = (0..l.mesh.vertex_count() as u32)
            .filter(|&v| l.mesh.positions[v as usize].distance(node) < 1e-6)
            .collect();
        assert_eq!(xs.len(), 1, "{text}: one centre vertex at the node");
        let x = xs[0];
        let degree = e.keys().filter(|k| k.0 == x || k.1 == x).count();
        assert_eq!(degree, 2 * n + 4, "{text}: centre fanned to the whole polygon");
    }
}

/// Property 24: the proxy lies in z = 0 with the final mesh's faces; UVs are in
/// [0, 1]²; a leaf with only turns is its own proxy; pitches and rolls do not change it.
#[test]
fn the_cutout_proxy_is_planar_with_the_same_topology() {
    let bent = "!(0.3)F(1)[+(50)F(0.7)&(30)F(0.5)][-(50)F(0.7)/(40)F(0.5)]&(15)F(1)[+(40)F(0.6)]/(10)F(0.8)";
    let flat = "!(0.3)F(1)[+(50)F(0.7)F(0.5)][-(50)F(0.7)F(0.5)]F(1)[+(40)F(0.6)]F(0.8)";
    let a = leaf(bent, &LeafOptions::default());
    assert!(a.mesh.positions.iter().any(|p| p.z.abs() > 0.1), "the bent leaf leaves the plane");
    assert!(a.proxy.positions.iter().all(|p| p.z == 0.0), "proxy z = 0");
    assert_eq!(a.proxy.face_indices, a.mesh.face_indices);
    assert_eq!(a.proxy.face_offsets, a.mesh.face_offsets);
    assert_eq!(a.proxy.vertex_count(), a.mesh.vertex_count());
    let uv = a.mesh.uvs.as_ref().unwrap();
    assert!(uv.values.iter().all(|t| t.is_finite() && t.x >= 0.0 && t.x <= 1.0 && t.y >= 0.0 && t.y <= 1.0));
    // The bounding-box fit: the longer side spans exactly [0, 1].
    let spans = |f: fn(&glam::Vec2) -> f32| {
        uv.values.iter().any(|t| f(t) == 0.0) && uv.values.iter().any(|t| f(t) == 1.0)
    };
    assert!(spans(|t| t.x) || spans(|t| t.y), "the fit fills [0, 1] along the longer side");
    // The unbent string's flat mesh (no midrib depth) is the bent one's proxy.
    let flat_opts = LeafOptions { midrib_depth: 0.0, ..Default::default() };
    let b = leaf(flat, &flat_opts);
    assert_eq!(b.mesh.face_indices, a.proxy.face_indices);
    for (p, q) in b.mesh.positions.iter().zip(&a.proxy.positions) {
        assert!(p.distance(*q) < 1e-4, "proxy vertex {q} != unbent leaf's {p}");
    }
    // UV = the proxy's (x, y) under one affine fit.
    let (lo, hi) = a.proxy.bounds().unwrap();
    let s = (hi - lo).x.max((hi - lo).y);
    for (v, p) in a.proxy.positions.iter().enumerate() {
        let t = uv.values[v];
        let back = Vec3::new(t.x * s, t.y * s, 0.0);
        let d = (back - (*p - lo)) - Vec3::new((s - (hi - lo).x) / 2.0, (s - (hi - lo).y) / 2.0, 0.0);
        assert!(d.length() < 1e-4 * s, "uv of vertex {v}");
    }
    // Tiled mapping: u across the width, v in [0, 1] over every internode.
    let t = leaf(bent, &LeafOptions { mapping: LeafMapping::Tiled, ..Default::default() });
    let uv = t.mesh.uvs.as_ref().unwrap();
    assert_eq!(uv.indices.len(), t.mesh.face_indices.len());
    assert!(uv.values.iter().all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y)));
    for tip in &t.tips {
        for f in tip.faces {
            let c = t.mesh.corners(f);
            let apex_corner = c.clone().find(|&k| t.mesh.face_indices[k] == tip.apex).unwrap();
            assert_eq!(uv.values[uv.indices[apex_corner] as usize].y, 1.0, "v = 1 at a tip");
        }
    }
}

/// The refined leaf has no NaN and keeps the midrib crease sharp for `/E` levels; a tip
/// with `/T` sharpness stays put.
#[test]
fn refinement_keeps_the_midrib_sharp_for_e_levels() {
    let text = "!(0.4)F(1)F(1)F(1)F(1)";
    let depth = 0.2;
    let z = (depth * 0.4) as f32; // midrib offset: depth × width along U = +Z
    let on_midrib = |m: &Mesh| m.positions.iter().filter(|p| (p.z - z).abs() < 1e-6).count();
    let mesh = |e: f64, t: f64| {
        leaf(
            text,
            &LeafOptions { midrib_depth: depth, midrib_sharpness: e, tip_sharpness: t, ..Default::default() },
        )
    };
    let sharp = loop_refine(&mesh(255.0, 0.0).mesh, 3);
    let smooth = loop_refine(&mesh(0.0, 0.0).mesh, 3);
    assert!(sharp.positions.iter().chain(&smooth.positions).all(|p| p.is_finite()));
    // 4 coarse midrib edges → 32 refined edges on the crease line (the last one's end
    // is a dart and leaves it).
    assert!(on_midrib(&sharp) >= 25, "sharp midrib: {} vertices on it", on_midrib(&sharp));
    assert!(on_midrib(&smooth) <= 1, "smooth: only the base corner stays, {}", on_midrib(&smooth));
    // Semi-sharp: /E2 is the sharp crease for 2 levels and smooth after.
    for levels in 1..=2 {
        assert_eq!(
            loop_refine(&mesh(2.0, 0.0).mesh, levels).positions,
            loop_refine(&mesh(255.0, 0.0).mesh, levels).positions
        );
    }
    assert_ne!(
        loop_refine(&mesh(2.0, 0.0).mesh, 3).positions,
        loop_refine(&mesh(255.0, 0.0).mesh, 3).positions
    );
    // Tip sharpness: the apex is a corner while its sharpness lasts.
    for (t, fixed) in [(255.0, true), (0.0, false)] {
        let l = mesh(255.0, t);
        let apex = l.mesh.positions[l.tips[0].apex as usize];
        let r = loop_refine(&l.mesh, 3);
        let kept = r.positions.iter().any(|p| p.distance(apex) < 1e-6);
        assert_eq!(kept, fixed, "tip sharpness {t}");
        assert!(r.positions.iter().all(|p| p.is_finite()));
    }
}

/// Bad options and skeletons without internodes are errors that say what and why.
#[test]
fn bad_input_is_a_clear_error() {
    let sk = str_skeleton(LATERAL);
    for (opts, key) in [
        (LeafOptions { tip_size: 0.0, ..Default::default() }, "tip_size"),
        (LeafOptions { midrib_depth: f64::NAN, ..Default::default() }, "midrib_depth"),
        (LeafOptions { midrib_sharpness: 256.0, ..Default::default() }, "midrib_sharpness"),
        (LeafOptions { tip_sharpness: -1.0, ..Default::default() }, "tip_sharpness"),
    ] {
        let e = leaf_mesh(&sk, &opts).unwrap_err().to_string();
        assert!(e.contains(key) && e.contains("leaf mesher"), "{e}");
    }
    let mut lone = Skeleton::new();
    lone.push(Vec3::ZERO, 0.1, sylva::skeleton::NO_PARENT, Vec3::Z, 0);
    let e = leaf_mesh(&lone, &LeafOptions::default()).unwrap_err().to_string();
    assert!(e.contains("no internode"), "{e}");
    let mut huge = str_skeleton("F(1)F(1)");
    huge.position[2] = Vec3::new(0.0, 3e38, 0.0);
    huge.radius[2] = 3e38;
    match leaf_mesh(&huge, &LeafOptions::default()) {
        Ok(l) => assert!(l.mesh.positions.iter().all(|p| p.is_finite())),
        Err(e) => assert!(e.to_string().contains("leaf mesher") || e.to_string().contains("node"), "{e}"),
    }
    let r =
        sylva::recipe::load("lsys-binary-tree", &[("mesh.leaf.tip_size".into(), toml::Value::Float(-2.0))]);
    let e = r.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains("mesh.leaf.tip_size"), "recipe error names the key: {e}");
}

/// A leaf model grown end to end: the `.str` compound leaf of `tests/data` through the
/// pipeline with `--set mesh.method=leaf`, refined twice, written as OBJ.
#[test]
fn a_str_leaf_grows_end_to_end_to_obj() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/compound-leaf.str");
    let sets = vec![
        ("mesh.method".to_string(), toml::Value::String("leaf".into())),
        ("mesh.leaf.tip_sharpness".to_string(), toml::Value::Integer(2)),
        ("refine.levels".to_string(), toml::Value::Integer(2)),
        ("refine.scheme".to_string(), toml::Value::String("loop".into())),
    ];
    let loaded = sylva::recipe::load(file, &sets).unwrap();
    let grown = sylva::pipeline::grow(&loaded).unwrap();
    let coarse = leaf_mesh(&grown.skeleton, &loaded.recipe.mesh.leaf).unwrap();
    let part = grown.model.parts.iter().find(|p| p.name == "leaf").expect("a leaf part");
    assert_eq!(part.mesh.face_count(), 16 * coarse.mesh.face_count(), "two Loop levels");
    assert!(part.mesh.positions.iter().all(|p| p.is_finite()));
    assert_eq!(euler(&part.mesh), 1);
    assert_eq!(boundary_loops(&part.mesh), 1);
    assert_eq!(coarse.junctions.len(), 3);
    assert_eq!(coarse.merged, 2 + 1 + 2);
    let dir = std::env::temp_dir().join(format!("sylva-leaf-mode-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("leaf.obj");
    sylva::export::write(&grown.model, &out).unwrap();
    let text = std::fs::read_to_string(&out).unwrap();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(faces, part.mesh.face_count());
    assert!(text.lines().any(|l| l.starts_with("vt ")), "cut-out UVs are written");
    // No bark part, so no bark maps (no bark PNGs beside the file).
    assert!(!grown.model.parts.iter().any(|p| p.name == "bark"));
    assert!(grown.model.images.iter().all(|i| !i.name.starts_with("bark")), "bark maps without bark");
    let _ = std::fs::remove_dir_all(&dir);
}
