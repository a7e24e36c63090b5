//! Space colonization (Runions, Lane & Prusinkiewicz 2007; issue 6 item 2): the
//! acceptance properties at termination, the envelopes, the `colonize-*` presets and the
//! parameter checks.
//!
//! Tolerances follow from the `f32` storage of the skeleton: positions are computed in
//! `f64` and rounded to `f32` (relative error ≤ 2⁻²⁴ ≈ 6e-8 per coordinate), so for a
//! tree ~10 m tall a distance is off by at most ~1e-6 m; radii are `f32` roundings of
//! exact `f64` pipe-model values, so `r^n` is off by at most `n·2⁻²⁴` relative and the
//! fork identity `r^n = Σ r_i^n` holds to `2n·2⁻²⁴ ≤ 4.8e-7 < 1e-6` for `n ≤ 4`.

#![allow(clippy::needless_range_loop)] // node loops index several columns

use glam::{DVec3, Vec3};
use std::path::{Path, PathBuf};
use sylva::grow::colonize::{
    attraction_points, grow, ColonizeLeaves, ColonizeParams, ColonizeTree, Envelope, DUPLICATE_ANGLE_DEG,
    MAX_POINTS,
};
use sylva::mesh::tube::{tube_mesh, TubeOptions};
use sylva::skeleton::{OrganKind, Skeleton, NO_PARENT};

/// Small, fast parameters (a ~5 m tree).
fn small() -> ColonizeParams {
    ColonizeParams {
        envelope: Envelope::Ellipsoid { center_height: 3.5, radii: [2.0, 1.6, 2.0] },
        points: 1500,
        influence_radius: 0.8,
        kill_distance: 0.2,
        segment_length: 0.1,
        trunk_height: 1.5,
        ..Default::default()
    }
}

fn presets_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../presets")
}

/// The `colonize-*.toml` presets: (file stem, whole table, generator parameters).
fn presets() -> Vec<(String, toml::Table, ColonizeParams)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(presets_dir())
        .expect("presets/ exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            name.starts_with("colonize-") && name.ends_with(".toml")
        })
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|path| {
            let text = std::fs::read_to_string(&path).expect("readable preset");
            let table: toml::Table =
                toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let mut g = table.get("generator").cloned().expect("a [generator] table");
            let gt = g.as_table_mut().expect("[generator] is a table");
            assert_eq!(
                gt.remove("type").and_then(|v| v.as_str().map(str::to_string)).as_deref(),
                Some("space-colonization"),
                "{}: generator.type",
                path.display()
            );
            let params: ColonizeParams = g.try_into().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("").to_string();
            (stem, table, params)
        })
        .collect()
}

/// The recipe's generator enum as the lead wires it (`recipe.rs`):
/// `#[serde(tag = "type", rename_all = "kebab-case")]` with a newtype variant.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
enum Generator {
    SpaceColonization(ColonizeParams),
}

fn d(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

fn children(sk: &Skeleton) -> Vec<Vec<usize>> {
    let mut c = vec![Vec::new(); sk.len()];
    for (i, &p) in sk.parent.iter().enumerate() {
        if p != NO_PARENT {
            c[p as usize].push(i);
        }
    }
    c
}

/// Brute force: no node within the kill distance of a surviving point.
fn assert_no_node_near_survivors(name: &str, p: &ColonizeParams, tree: &ColonizeTree) {
    assert_eq!(tree.remaining.len(), tree.report.points_left, "{name}");
    let tol = 1e-5; // f32 node positions (module docs)
    for s in &tree.remaining {
        for (i, q) in tree.skeleton.position.iter().enumerate() {
            let dist = s.distance(d(*q));
            assert!(
                dist > p.kill_distance - tol,
                "{name}: node {i} is {dist} m from a surviving point (kill distance {})",
                p.kill_distance
            );
        }
    }
}

#[test]
fn no_node_within_kill_distance_of_a_surviving_point() {
    // Consumed, stalled and cut-off (max_iterations) terminations.
    let cases = [
        ("default-small", small()),
        ("cut-off", ColonizeParams { max_iterations: 6, ..small() }),
        ("sparse", ColonizeParams { points: 300, influence_radius: 0.5, ..small() }),
        ("tropism", ColonizeParams { tropism: [0.0, -1.0, 0.0], tropism_weight: 0.4, ..small() }),
    ];
    for (name, p) in cases {
        let tree = grow(&p, 3).unwrap();
        assert!(tree.report.nodes > 10, "{name}: {:?}", tree.report);
        assert_no_node_near_survivors(name, &p, &tree);
    }
    let cut = grow(&ColonizeParams { max_iterations: 6, ..small() }, 3).unwrap();
    assert_eq!(cut.report.iterations, 6);
    assert!(!cut.report.stalled && cut.report.points_left > 0, "{:?}", cut.report);
}

#[test]
fn every_segment_has_the_configured_length() {
    for (p, seed) in [
        (small(), 1),
        (ColonizeParams { perturbation: 0.5, segment_length: 0.13, kill_distance: 0.2, ..small() }, 2),
        (ColonizeParams { tropism: [1.0, 0.0, 0.0], tropism_weight: 0.3, ..small() }, 3),
    ] {
        let tree = grow(&p, seed).unwrap();
        let sk = &tree.skeleton;
        let mut segments = 0;
        for i in 0..sk.len() {
            if sk.parent[i] == NO_PARENT {
                continue;
            }
            segments += 1;
            let len = sk.internode_length(i);
            let rel = (len - p.segment_length).abs() / p.segment_length;
            assert!(rel < 1e-4, "segment {i}: length {len}, configured {}", p.segment_length);
        }
        assert_eq!(segments, sk.len() - 1, "a single root");
    }
}

#[test]
fn pipe_model_holds_at_every_fork() {
    for n in [2.0, 2.5, 3.0] {
        let p = ColonizeParams { pipe_exponent: n, tip_radius: 0.006, ..small() };
        let tree = grow(&p, 5).unwrap();
        let sk = &tree.skeleton;
        let kids = children(sk);
        let mut forks = 0;
        for (i, c) in kids.iter().enumerate() {
            let r = sk.radius[i] as f64;
            if c.is_empty() {
                assert!(((r - p.tip_radius) / p.tip_radius).abs() < 1e-7, "tip {i} radius {r}");
                continue;
            }
            forks += usize::from(c.len() > 1);
            let sum: f64 = c.iter().map(|&k| (sk.radius[k] as f64).powf(n)).sum();
            let rel = (r.powf(n) - sum).abs() / sum;
            assert!(
                rel < 1e-6,
                "n = {n}, node {i} with {} children: r^n {} vs Σ {sum} ({rel})",
                c.len(),
                r.powf(n)
            );
        }
        assert!(forks > 20, "n = {n}: only {forks} forks");
    }
}

#[test]
fn deterministic_in_the_seed() {
    let p = small();
    let a = grow(&p, 42).unwrap();
    let b = grow(&p, 42).unwrap();
    assert_eq!(a.skeleton, b.skeleton);
    assert_eq!(a.remaining, b.remaining);
    assert_eq!(
        (a.report.nodes, a.report.iterations, a.report.leaves),
        (b.report.nodes, b.report.iterations, b.report.leaves)
    );
    let c = grow(&p, 43).unwrap();
    assert_ne!(a.skeleton.position, c.skeleton.position, "another seed grows another tree");
    assert_ne!(attraction_points(&p, 42).unwrap(), attraction_points(&p, 43).unwrap());
}

#[test]
fn envelopes_keep_their_points_inside() {
    type Inside = Box<dyn Fn(DVec3) -> bool>;
    let shapes: Vec<(Envelope, Inside)> = vec![
        (
            Envelope::Sphere { center_height: 2.0, radius: 1.5 },
            Box::new(|p: DVec3| (p - DVec3::new(0.0, 2.0, 0.0)).length() <= 1.5 + 1e-12),
        ),
        (
            Envelope::Ellipsoid { center_height: 5.0, radii: [3.0, 1.0, 2.0] },
            Box::new(|p: DVec3| {
                let q = p - DVec3::new(0.0, 5.0, 0.0);
                (q.x / 3.0).powi(2) + (q.y / 1.0).powi(2) + (q.z / 2.0).powi(2) <= 1.0 + 1e-12
            }),
        ),
        (
            Envelope::Cone { base_height: 1.0, height: 8.0, radius: 2.5 },
            Box::new(|p: DVec3| {
                let t = (p.y - 1.0) / 8.0;
                (0.0..=1.0).contains(&t) && p.x.hypot(p.z) <= 2.5 * (1.0 - t) + 1e-12
            }),
        ),
        (
            Envelope::Cylinder { base_height: 0.5, height: 3.0, radius: 1.0 },
            Box::new(|p: DVec3| p.y >= 0.5 && p.y <= 3.5 && p.x.hypot(p.z) <= 1.0 + 1e-12),
        ),
    ];
    for (env, inside) in shapes {
        let p = ColonizeParams { envelope: env.clone(), points: 5000, ..Default::default() };
        let pts = attraction_points(&p, 9).unwrap();
        assert_eq!(pts.len(), 5000);
        for q in &pts {
            assert!(inside(*q), "{env:?}: point {q} outside");
        }
        // Uniform fill: the points' mean height is near the shape's centroid height.
        let mean = pts.iter().map(|q| q.y).sum::<f64>() / pts.len() as f64;
        let centroid = match env {
            Envelope::Sphere { center_height, .. } | Envelope::Ellipsoid { center_height, .. } => {
                center_height
            }
            Envelope::Cone { base_height, height, .. } => base_height + height / 4.0,
            Envelope::Cylinder { base_height, height, .. } => base_height + height / 2.0,
            Envelope::Mesh { .. } => unreachable!(),
        };
        assert!((mean - centroid).abs() < 0.05, "{env:?}: mean height {mean}, centroid {centroid}");
    }
}

#[test]
fn mesh_envelope_keeps_points_inside_and_grows() {
    // An octahedron |x| + |y − 4| + |z| ≤ 2 (8 triangles) as an OBJ file.
    let dir = std::env::temp_dir().join(format!("sylva-colonize-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("octa.obj");
    std::fs::write(
        &obj,
        "v 2 4 0\nv -2 4 0\nv 0 6 0\nv 0 2 0\nv 0 4 2\nv 0 4 -2\n\
         f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n",
    )
    .unwrap();
    let p = ColonizeParams {
        envelope: Envelope::Mesh { file: obj.display().to_string() },
        points: 3000,
        trunk_height: 1.0,
        influence_radius: 0.8,
        kill_distance: 0.2,
        segment_length: 0.1,
        ..Default::default()
    };
    let pts = attraction_points(&p, 1).unwrap();
    assert_eq!(pts.len(), 3000);
    for q in &pts {
        assert!(q.x.abs() + (q.y - 4.0).abs() + q.z.abs() <= 2.0 + 1e-9, "point {q} outside the octahedron");
    }
    let tree = grow(&p, 1).unwrap();
    tree.skeleton.validate().unwrap();
    assert!(tree.report.nodes > 100, "{:?}", tree.report);
    assert_no_node_near_survivors("octahedron", &p, &tree);

    // A missing file, and an open (flat) mesh, are errors naming the key.
    let missing = ColonizeParams {
        envelope: Envelope::Mesh { file: dir.join("none.obj").display().to_string() },
        ..p.clone()
    };
    assert!(grow(&missing, 1).unwrap_err().to_string().contains("none.obj"));
    std::fs::write(
        dir.join("flat.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 2 4\nf 2 3 4\n",
    )
    .unwrap();
    let flat =
        ColonizeParams { envelope: Envelope::Mesh { file: dir.join("flat.obj").display().to_string() }, ..p };
    let e = grow(&flat, 1).unwrap_err().to_string();
    assert!(e.contains("generator.envelope.file"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn presets_grow_valid_skeletons_that_mesh() {
    let presets = presets();
    let names: Vec<&str> = presets.iter().map(|(n, _, _)| n.as_str()).collect();
    for want in ["colonize-broadleaf", "colonize-conifer", "colonize-shrub"] {
        assert!(names.contains(&want), "missing preset {want} (have {names:?})");
    }
    for (name, table, p) in &presets {
        assert_eq!(table.get("name").and_then(|v| v.as_str()), Some(name.as_str()), "{name}: name key");
        assert!(table.get("description").and_then(|v| v.as_str()).is_some_and(|s| !s.is_empty()));
        let mesh = table.get("mesh").and_then(|m| m.as_table()).expect("a [mesh] table");
        assert_eq!(mesh.get("method").and_then(|v| v.as_str()), Some("tube"), "{name}");
        let sides = mesh.get("sides").and_then(|v| v.as_integer()).unwrap_or(8) as u32;
        let seed = table.get("seed").and_then(|v| v.as_integer()).unwrap_or(1) as u64;
        p.validate().unwrap_or_else(|e| panic!("{name}: {e}"));

        // Every key of the preset's [generator] survives a serialize round trip (the
        // recipe loader's unknown-key check).
        let back = toml::Value::try_from(p).unwrap();
        let gen = table["generator"].as_table().unwrap();
        for (k, v) in gen {
            if k == "type" {
                continue;
            }
            assert!(back.get(k).is_some(), "{name}: generator.{k} does not round-trip");
            if let Some(sub) = v.as_table() {
                for kk in sub.keys() {
                    assert!(
                        back[k.as_str()].get(kk).is_some(),
                        "{name}: generator.{k}.{kk} does not round-trip"
                    );
                }
            }
        }

        // Through the recipe's internally tagged generator enum, both ways.
        let Generator::SpaceColonization(tagged) =
            table["generator"].clone().try_into::<Generator>().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&tagged, p, "{name}");
        let round = toml::Value::try_from(Generator::SpaceColonization(p.clone())).unwrap();
        assert_eq!(round.get("type").and_then(|v| v.as_str()), Some("space-colonization"));
        assert_eq!(
            round.try_into::<Generator>().map(|Generator::SpaceColonization(q)| q).ok().as_ref(),
            Some(p)
        );

        let tree = grow(p, seed).unwrap_or_else(|e| panic!("{name}: {e}"));
        let sk = &tree.skeleton;
        sk.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        let st = sk.stats();
        assert_eq!(st.roots, 1, "{name}");
        assert!(
            tree.report.points_left * 50 < tree.report.points,
            "{name}: {} of {} points left",
            tree.report.points_left,
            tree.report.points
        );
        assert!(tree.report.leaves > 500, "{name}: {:?}", tree.report);
        let tube = tube_mesh(sk, &TubeOptions { sides, ..Default::default() }).unwrap();
        tube.mesh.validate().unwrap();
        let (leaves, missing) = sylva::mesh::organs::organ_mesh(sk, &Default::default());
        assert!(missing.is_empty());
        leaves.validate().unwrap();
        let triangles = tube.triangles + leaves.triangle_count();
        assert!((50_000..=600_000).contains(&triangles), "{name}: {triangles} triangles");
        let height = st.bounds.1.y - st.bounds.0.y;
        let want = match name.as_str() {
            "colonize-broadleaf" => 8.0..=12.0,
            "colonize-conifer" => 8.0..=14.0,
            "colonize-shrub" => 1.0..=3.0,
            _ => 0.5..=40.0,
        };
        assert!(want.contains(&height), "{name}: {height} m tall");
        assert!(st.bounds.0.y >= -1e-6, "{name}: grows below the ground ({})", st.bounds.0.y);
    }
}

#[test]
fn bad_parameters_name_the_key() {
    let cases: Vec<(ColonizeParams, &str)> = vec![
        (ColonizeParams { points: MAX_POINTS + 1, ..small() }, "generator.points"),
        (ColonizeParams { kill_distance: f64::NAN, ..small() }, "generator.kill_distance"),
        (ColonizeParams { kill_distance: 0.9, ..small() }, "generator.kill_distance"),
        (ColonizeParams { kill_distance: 0.04, ..small() }, "generator.kill_distance"),
        (ColonizeParams { influence_radius: -1.0, ..small() }, "generator.influence_radius"),
        (ColonizeParams { segment_length: 0.0, ..small() }, "generator.segment_length"),
        (ColonizeParams { segment_length: f64::INFINITY, ..small() }, "generator.segment_length"),
        (ColonizeParams { tropism: [0.0, f64::NAN, 0.0], ..small() }, "generator.tropism"),
        (ColonizeParams { tropism_weight: -0.1, ..small() }, "generator.tropism_weight"),
        (ColonizeParams { perturbation: f64::NEG_INFINITY, ..small() }, "generator.perturbation"),
        (ColonizeParams { trunk_height: -2.0, ..small() }, "generator.trunk_height"),
        (ColonizeParams { segment_length: 1e6, ..small() }, "generator.segment_length"),
        (
            ColonizeParams {
                envelope: Envelope::Ellipsoid { center_height: 1.0, radii: [1e300, 1.0, 1.0] },
                ..small()
            },
            "generator.envelope.radii",
        ),
        (ColonizeParams { trunk_height: 50.0, max_nodes: 100, ..small() }, "generator.trunk_height"),
        (ColonizeParams { max_iterations: 0, ..small() }, "generator.max_iterations"),
        (ColonizeParams { max_nodes: 0, ..small() }, "generator.max_nodes"),
        (ColonizeParams { max_nodes: 40, ..small() }, "generator.max_nodes"),
        (ColonizeParams { pipe_exponent: 0.5, ..small() }, "generator.pipe_exponent"),
        (ColonizeParams { tip_radius: 0.0, ..small() }, "generator.tip_radius"),
        (
            ColonizeParams { leaves: ColonizeLeaves { count: 1000, ..Default::default() }, ..small() },
            "generator.leaves.count",
        ),
        (
            ColonizeParams { leaves: ColonizeLeaves { size: -1.0, ..Default::default() }, ..small() },
            "generator.leaves.size",
        ),
        (
            ColonizeParams { leaves: ColonizeLeaves { angle: 270.0, ..Default::default() }, ..small() },
            "generator.leaves.angle",
        ),
        (
            ColonizeParams {
                leaves: ColonizeLeaves { size_variation: 1.0, ..Default::default() },
                ..small()
            },
            "generator.leaves.size_variation",
        ),
        (
            ColonizeParams { envelope: Envelope::Sphere { center_height: 1.0, radius: 0.0 }, ..small() },
            "generator.envelope.radius",
        ),
        (
            ColonizeParams {
                envelope: Envelope::Ellipsoid { center_height: 1.0, radii: [1.0, -1.0, 1.0] },
                ..small()
            },
            "generator.envelope.radii",
        ),
        (
            ColonizeParams {
                envelope: Envelope::Cone { base_height: f64::NAN, height: 1.0, radius: 1.0 },
                ..small()
            },
            "generator.envelope.base_height",
        ),
        (
            ColonizeParams {
                envelope: Envelope::Cylinder { base_height: 1.0, height: 0.0, radius: 1.0 },
                ..small()
            },
            "generator.envelope.height",
        ),
        (
            ColonizeParams { envelope: Envelope::Mesh { file: " ".into() }, ..small() },
            "generator.envelope.file",
        ),
    ];
    for (p, key) in cases {
        let e = grow(&p, 1).unwrap_err().to_string();
        assert!(e.contains(&format!("`{key}`")), "expected an error naming `{key}`, got: {e}");
    }
    let e = grow(&ColonizeParams { points: 6_000_000, ..small() }, 1).unwrap_err().to_string();
    assert!(e.contains("budget"), "{e}");
}

#[test]
fn unknown_keys_and_shapes_are_rejected_by_serde() {
    let bad_shape: Result<ColonizeParams, _> = toml::from_str("[envelope]\nshape = \"torus\"\n");
    assert!(bad_shape.unwrap_err().to_string().contains("torus"));
    let p: ColonizeParams =
        toml::from_str("points = 10\n[envelope]\nshape = \"cone\"\nheight = 4\n").unwrap();
    assert_eq!(p.points, 10);
    assert!(matches!(p.envelope, Envelope::Cone { height, .. } if height == 4.0));
    // Every field serializes (no skip), so the recipe's round-trip check sees every key.
    let back = toml::Value::try_from(ColonizeParams::default()).unwrap();
    for k in [
        "envelope",
        "points",
        "influence_radius",
        "kill_distance",
        "segment_length",
        "tropism",
        "tropism_weight",
        "perturbation",
        "trunk_height",
        "max_iterations",
        "max_nodes",
        "pipe_exponent",
        "tip_radius",
        "leaves",
    ] {
        assert!(back.get(k).is_some(), "{k} does not serialize");
    }
    let again: ColonizeParams = back.try_into().unwrap();
    assert_eq!(again, ColonizeParams::default());
}

#[test]
fn frames_orders_and_children() {
    let p = ColonizeParams { perturbation: 0.0, ..small() };
    let tree = grow(&p, 11).unwrap();
    let sk = &tree.skeleton;
    let kids = children(sk);
    let dup_cos = DUPLICATE_ANGLE_DEG.to_radians().cos();
    let mut reached_tip_on_order_0 = false;
    for i in 0..sk.len() {
        // up: unit, perpendicular to the incoming internode.
        let u = d(sk.up[i]);
        assert!((u.length() - 1.0).abs() < 1e-5, "node {i}: |up| = {}", u.length());
        if sk.parent[i] != NO_PARENT {
            let t = (d(sk.position[i]) - d(sk.position[sk.parent[i] as usize])).normalize();
            assert!(u.dot(t).abs() < 1e-4, "node {i}: up not perpendicular ({})", u.dot(t));
            // Parallel transport: along a straight internode pair, up does not turn.
            let par = sk.parent[i] as usize;
            if sk.parent[par] != NO_PARENT {
                let tp = (d(sk.position[par]) - d(sk.position[sk.parent[par] as usize])).normalize();
                if tp.dot(t) > 1.0 - 1e-12 {
                    assert!(d(sk.up[par]).dot(u) > 1.0 - 1e-5, "node {i}: up twisted on a straight segment");
                }
            }
        }
        // Orders: exactly one child keeps the order, the others are laterals.
        let c = &kids[i];
        if !c.is_empty() {
            let same = c.iter().filter(|&&k| sk.order[k] == sk.order[i]).count();
            assert_eq!(same, 1, "node {i}: {same} children keep order {}", sk.order[i]);
            assert!(c.iter().all(|&k| sk.order[k] == sk.order[i] || sk.order[k] == sk.order[i] + 1));
        } else if sk.order[i] == 0 {
            reached_tip_on_order_0 = true;
        }
        // No two children in (nearly) the same direction.
        for a in 0..c.len() {
            for b in a + 1..c.len() {
                let da = (d(sk.position[c[a]]) - d(sk.position[i])).normalize();
                let db = (d(sk.position[c[b]]) - d(sk.position[i])).normalize();
                assert!(da.dot(db) < dup_cos + 1e-6, "node {i}: children {} and {} coincide", c[a], c[b]);
            }
        }
    }
    assert!(reached_tip_on_order_0, "the order-0 axis runs from the root to a tip");
    assert!(sk.stats().max_order >= 2);
}

#[test]
fn leaves_hang_on_the_tips() {
    let leaves = ColonizeLeaves { count: 5, nodes: 2, size: 0.1, size_variation: 0.3, angle: 40.0 };
    let p = ColonizeParams { leaves: leaves.clone(), ..small() };
    let tree = grow(&p, 2).unwrap();
    let sk = &tree.skeleton;
    let kids = children(sk);
    assert_eq!(tree.report.leaves, sk.organs.len());
    assert!(sk.organs.len() >= 5 * tree.report.tips, "{} leaves, {} tips", sk.organs.len(), tree.report.tips);
    assert_eq!(sk.organs.len() % 5, 0);
    for o in &sk.organs {
        assert_eq!(o.kind, OrganKind::Leaf);
        let n = o.node as usize;
        assert!(sk.parent[n] != NO_PARENT);
        // The node is a tip or the unbranched node right before one.
        let near_tip = kids[n].is_empty() || (kids[n].len() == 1 && kids[kids[n][0]].is_empty());
        assert!(near_tip, "leaf on node {n}");
        let t = (d(sk.position[n]) - d(sk.position[sk.parent[n] as usize])).normalize();
        let h = d(o.heading);
        assert!((h.length() - 1.0).abs() < 1e-5);
        assert!((h.dot(t) - 40f64.to_radians().cos()).abs() < 1e-4, "leaf angle");
        assert!(d(o.up).dot(h).abs() < 1e-5 && d(o.up).y >= 0.0, "leaf normal ⟂ midrib, facing up");
        assert!(o.size >= 0.07 - 1e-6 && o.size <= 0.13 + 1e-6, "size {}", o.size);
        // On the incoming internode.
        let base = d(sk.position[sk.parent[n] as usize]);
        let along = (d(o.position) - base).dot(t);
        assert!(along > -1e-5 && along <= p.segment_length + 1e-5);
    }
    let bare = grow(&ColonizeParams { leaves: ColonizeLeaves { count: 0, ..leaves }, ..small() }, 2).unwrap();
    assert!(bare.skeleton.organs.is_empty());
    assert_eq!(bare.skeleton.position, tree.skeleton.position, "leaves do not change the branches");
}

#[test]
fn trunk_and_leader_reach_a_high_crown() {
    // No point near the root: the leader grows straight up until the crown attracts it.
    let p = ColonizeParams {
        envelope: Envelope::Sphere { center_height: 8.0, radius: 1.5 },
        points: 800,
        trunk_height: 2.0,
        influence_radius: 0.8,
        kill_distance: 0.2,
        segment_length: 0.1,
        ..Default::default()
    };
    let tree = grow(&p, 4).unwrap();
    let sk = &tree.skeleton;
    let kids = children(sk);
    // Below the reach of every point (crown bottom 6.5 m minus the influence radius)
    // the tree is one straight, unbranched leader on the +Y axis, extended past the
    // 2 m trunk until the crown attracts it.
    let reach = 8.0 - 1.5 - 0.8;
    let mut top = 0.0f32;
    for i in 0..sk.len() {
        if (sk.position[i].y as f64) < reach - 1e-4 {
            assert!(
                sk.position[i].x.abs() < 1e-6 && sk.position[i].z.abs() < 1e-6,
                "leader node {i} is off the axis"
            );
            assert!(kids[i].len() == 1, "leader node {i} has {} children", kids[i].len());
            assert!(i == 0 || sk.parent[i] == i as u32 - 1);
            top = top.max(sk.position[i].y);
        }
    }
    assert!(top as f64 > reach - 0.1 - 1e-4, "the leader stops at {top} m");
    assert!(tree.report.points_left < 40, "{:?}", tree.report);

    // No points at all: only the trunk; a crown out of reach below the root: stalled.
    let bare = grow(&ColonizeParams { points: 0, ..p.clone() }, 4).unwrap();
    assert_eq!(bare.report.nodes, 21);
    assert_eq!(bare.report.iterations, 0);
    assert!(!bare.report.stalled);
    let below = ColonizeParams {
        envelope: Envelope::Sphere { center_height: -5.0, radius: 1.0 },
        trunk_height: 0.5,
        ..p
    };
    let t = grow(&below, 4).unwrap();
    assert!(t.report.stalled && t.report.points_left == 800, "{:?}", t.report);
}

#[test]
fn larger_trees_fill_the_crown() {
    // A denser cloud consumes its points and grows more nodes (a smoke test of scale;
    // the 100 k-point timing is `cargo bench -p sylva --bench colonize`).
    let a = grow(&ColonizeParams { points: 1000, ..small() }, 1).unwrap();
    let b = grow(&ColonizeParams { points: 20_000, ..small() }, 1).unwrap();
    assert!(b.report.nodes > a.report.nodes);
    assert!(b.report.points_left * 100 < b.report.points, "{:?}", b.report);
    assert!(b.report.elapsed.as_secs_f64() < 30.0);
}
