//! Every mesher on every preset (issue 5 acceptance): the control mesh is a consistently
//! oriented 2-manifold with exactly the designed boundary loops and no degenerate faces,
//! checked by `sylva::mesh::check`; the table printed here (preset × mesher → vertices,
//! faces, boundary loops, intersections) is the one in `docs/meshers.md`.
//!
//! Self-intersections: most trees' skeletons already pass branches through each other
//! (the "skeleton collisions" column: non-adjacent internode capsules that overlap), and
//! no mesher can keep such surfaces apart. The joint meshers must add none of their own:
//! a preset whose skeleton has no collisions must mesh without self-intersections, also
//! after Loop level 2. The tube mesher starts each child tube inside its parent by
//! design, so its intersections are only reported.
//!
//! `cargo test -p sylva --test meshers -- --nocapture` prints the table.
//!
//! After `sylva::fit::decollide` (the pipeline's default for the joint meshers) most
//! skeletons are collision-free, and `sylva::fit::clear` then thins them where the
//! level-2 mesh still crosses itself: `decollided_presets_mesh_without_self_intersections`
//! asserts no self-intersection, also at level 2, for the small presets where that is
//! achieved; `decollide_table_of_every_preset` (ignored: run it in release) prints the
//! before/after table for every preset.

#[path = "common/checks.rs"]
mod checks;
mod common;
#[path = "common/preset_skeletons.rs"]
mod preset_skeletons;
#[path = "common/random_tree.rs"]
mod random_tree;

use preset_skeletons::each_preset_skeleton;
use sylva::fit::clear::{clear_crossings, ClearOptions};
use sylva::fit::decollide::{decollide, DecollideOptions};
use sylva::mesh::check::{check_mesh, skeleton_collisions, CheckOptions, MeshReport};
use sylva::mesh::hull::{hull_mesh, HullOptions};
use sylva::mesh::quad::{quad_mesh, QuadOptions};
use sylva::mesh::sweep::{sweep_mesh, SweepOptions};
use sylva::mesh::tube::{tube_mesh, TubeOptions};
use sylva::refine::{subdivide, RefineOptions, Scheme, SubdivideOptions};
use sylva::{Mesh, Skeleton};

/// Control meshes larger than this are checked without the self-intersection search,
/// and meshes refined to level 2 only below a quarter of it (CI time).
const INTERSECT_FACES: usize = 250_000;

struct Row {
    vertices: usize,
    faces: usize,
    boundary_loops: usize,
    intersections: Option<usize>,
    refined_intersections: Option<usize>,
    fallbacks: usize,
    degenerate: usize,
}

fn refine2(m: &Mesh, scheme: Scheme) -> Mesh {
    let opts = SubdivideOptions {
        refine: RefineOptions { scheme, levels: 2, ..Default::default() },
        ..Default::default()
    };
    subdivide(m, &[], &opts).expect("refining a valid control mesh")
}

fn report(m: &Mesh) -> MeshReport {
    check_mesh(
        m,
        &CheckOptions { self_intersections: m.face_count() <= INTERSECT_FACES, ..Default::default() },
    )
}

/// Meshes `sk` with `mesher` and asserts everything that must hold for any skeleton.
fn mesh_and_check(preset: &str, mesher: &str, sk: &Skeleton, collisions: usize) -> Row {
    let (mesh, designed_loops, fallbacks, scheme) = match mesher {
        "tube" => {
            let t = tube_mesh(sk, &TubeOptions::default()).unwrap_or_else(|e| panic!("{preset} tube: {e}"));
            (t.mesh, 0, 0, Scheme::CatmullClark)
        }
        "hull" => {
            // Large trees mesh with at most two segments per branch: the joints, which
            // are what can go wrong, are the same.
            let max_segments = if sk.len() > 5_000 { 2 } else { HullOptions::default().max_segments };
            let h = hull_mesh(sk, &HullOptions { caps: true, max_segments, ..Default::default() })
                .unwrap_or_else(|e| panic!("{preset} hull: {e}"));
            (h.mesh, 0, h.fallbacks.len(), Scheme::Loop)
        }
        "quad" => {
            // Large raw (colliding) skeletons mesh without the level-2 repair, which
            // would spend most of the debug test's time separating branches the
            // skeleton passes through each other; the cage's structure is the same.
            let repair_rounds = if sk.len() > 5_000 { 0 } else { QuadOptions::default().repair_rounds };
            let q = quad_mesh(sk, &QuadOptions { repair_rounds, ..Default::default() })
                .unwrap_or_else(|e| panic!("{preset} quad: {e}"));
            (q.mesh, 0, q.fallbacks.len(), Scheme::CatmullClark)
        }
        "sweep" => {
            let w = sweep_mesh(sk, &SweepOptions { caps: true, ..Default::default() })
                .unwrap_or_else(|e| panic!("{preset} sweep: {e}"));
            (w.mesh, 0, w.fallbacks.len(), Scheme::Loop)
        }
        _ => unreachable!(),
    };
    let r = report(&mesh);
    let structural = r.structural_problems();
    assert!(structural.is_empty(), "{preset} {mesher}: {structural:?}\n{r}");
    assert_eq!(r.boundary_loops, designed_loops, "{preset} {mesher}: boundary loops\n{r}");
    let refined_intersections =
        (mesh.face_count() * 4 <= INTERSECT_FACES / 4 && mesh.face_count() > 0).then(|| {
            let fine = refine2(&mesh, scheme);
            let rr = report(&fine);
            let structural = rr.structural_problems();
            assert!(structural.is_empty(), "{preset} {mesher} level 2: {structural:?}");
            rr.intersection_count.unwrap_or(0)
        });
    if mesher != "tube" && collisions == 0 {
        // The quad cage is a control polygon: the acceptance is on its Catmull–Clark
        // level 2 (thick forks of short internodes cross in the cage and not after
        // refinement, e.g. raw `colonize-broadleaf`: 20 cage pairs, 0 at level 2).
        if mesher != "quad" {
            assert_eq!(
                r.intersection_count.unwrap_or(0),
                0,
                "{preset} {mesher}: intersections without collisions"
            );
        }
        assert_eq!(refined_intersections.unwrap_or(0), 0, "{preset} {mesher}: level-2 intersections");
    }
    Row {
        vertices: r.vertices,
        faces: r.faces,
        boundary_loops: r.boundary_loops,
        intersections: r.intersection_count,
        refined_intersections,
        fallbacks,
        degenerate: r.degenerate_face_count,
    }
}

fn show(n: Option<usize>) -> String {
    n.map_or("–".into(), |n| n.to_string())
}

#[test]
fn every_preset_with_every_mesher() {
    println!("| preset | nodes | skeleton collisions | mesher | vertices | faces | boundary loops | degenerate | intersections | level-2 intersections | fallbacks |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut skeletons = Vec::new();
    each_preset_skeleton(
        |_| true,
        |name, sk| skeletons.push((name, sk.clone(), skeleton_collisions(sk, 0.01).len())),
    );
    // Every (preset, mesher) pair on the pool (CI has two cores), the rows printed in order.
    let jobs: Vec<(usize, &str)> =
        (0..skeletons.len()).flat_map(|i| ["tube", "hull", "sweep", "quad"].map(|m| (i, m))).collect();
    let rows: Vec<Row> = {
        use rayon::prelude::*;
        jobs.par_iter()
            .map(|&(i, mesher)| {
                let (name, sk, collisions) = &skeletons[i];
                mesh_and_check(name, mesher, sk, *collisions)
            })
            .collect()
    };
    for (&(i, mesher), row) in jobs.iter().zip(&rows) {
        let (name, sk, collisions) = &skeletons[i];
        println!(
            "| {} | {} | {} | {mesher} | {} | {} | {} | {} | {} | {} | {} |",
            name,
            sk.len(),
            collisions,
            row.vertices,
            row.faces,
            row.boundary_loops,
            row.degenerate,
            show(row.intersections),
            show(row.refined_intersections),
            row.fallbacks
        );
    }
    let meshed = rows.len();
    assert!(meshed >= 40, "only {meshed} preset × mesher pairs meshed");
}

/// A preset known to be collision-free must stay so (guards the assertion above from
/// silently applying to nothing).
#[test]
fn the_binary_tree_has_no_skeleton_collisions() {
    let loaded = sylva::recipe::load("lsys-binary-tree", &[]).unwrap();
    let g = sylva::pipeline::skeleton(&loaded, &mut Default::default()).unwrap();
    assert!(skeleton_collisions(&g.skeleton, 0.01).is_empty());
}

/// Every joint mesher through the whole pipeline (refined as its seed says, leaves
/// included) to GLB, checked by the Khronos glTF validator, on one preset of each
/// generator kind (issue 6: "meshes with every mesher … and the glTF validator").
#[test]
fn every_mesher_exports_valid_gltf() {
    let dir = std::env::temp_dir().join(format!("sylva-meshers-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut files = Vec::new();
    for preset in ["lsys-binary-tree", "lsys-honda-b", "wp-palm", "colonize-shrub"] {
        for (mesher, scheme) in
            [("tube", "none"), ("hull", "loop"), ("sweep", "loop"), ("quad", "catmull-clark")]
        {
            let sets = [
                ("mesh.method".to_string(), toml::Value::String(mesher.into())),
                ("refine.scheme".to_string(), toml::Value::String(scheme.into())),
                ("refine.levels".to_string(), toml::Value::Integer(1)),
            ];
            let loaded = sylva::recipe::load(preset, &sets).unwrap();
            let grown = sylva::pipeline::grow(&loaded).unwrap_or_else(|e| panic!("{preset} {mesher}: {e}"));
            let bark = &grown.model.parts[0].mesh;
            let r = check_mesh(
                bark,
                &CheckOptions { self_intersections: mesher != "tube", ..Default::default() },
            );
            assert!(r.structural_problems().is_empty(), "{preset} {mesher} refined: {r}");
            if mesher != "tube" {
                // The pipeline's mesh clearing searched exactly this refined bark.
                let c = grown.report.clear.as_ref().expect("mesh clearing runs for the joint meshers");
                assert_eq!(c.after, r.intersection_count, "{preset} {mesher}: {c:?}");
            }
            let path = dir.join(format!("{preset}-{mesher}.glb"));
            sylva::export::write(&grown.model, &path).unwrap();
            files.push(path);
        }
    }
    common::gltf_validator::assert_valid_gltf(&files);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The joint meshers' control mesh of `sk` and the scheme it is refined with.
fn joint_mesh(preset: &str, mesher: &str, sk: &Skeleton) -> (Mesh, Scheme) {
    match mesher {
        "hull" => {
            let max_segments = if sk.len() > 5_000 { 2 } else { HullOptions::default().max_segments };
            let h = hull_mesh(sk, &HullOptions { caps: true, max_segments, ..Default::default() })
                .unwrap_or_else(|e| panic!("{preset} hull: {e}"));
            (h.mesh, Scheme::Loop)
        }
        "sweep" => {
            let w = sweep_mesh(sk, &SweepOptions { caps: true, ..Default::default() })
                .unwrap_or_else(|e| panic!("{preset} sweep: {e}"));
            (w.mesh, Scheme::Loop)
        }
        "quad" => {
            let q = quad_mesh(sk, &QuadOptions::default()).unwrap_or_else(|e| panic!("{preset} quad: {e}"));
            (q.mesh, Scheme::CatmullClark)
        }
        _ => unreachable!(),
    }
}

/// One preset after `decollide` and, per joint mesher, the mesh clearing
/// (`sylva::fit::clear`, as the pipeline runs them): skeleton collisions before and
/// after, and per joint mesher of `meshers` the self-intersections of the control mesh
/// and of its level-2 refinement before and after clearing (`None`: level 2 over
/// `level2_faces` faces, not searched).
struct Decollided {
    before: usize,
    after: usize,
    millis: f64,
    control: Vec<usize>,
    level2_raw: Vec<Option<usize>>,
    level2: Vec<Option<usize>>,
    clear_millis: Vec<f64>,
}

fn decollided(preset: &str, meshers: &[&str], level2_faces: usize) -> Option<Decollided> {
    let loaded = sylva::recipe::load(preset, &[]).ok()?;
    let mut sk = sylva::pipeline::skeleton(&loaded, &mut Default::default()).ok()?.skeleton;
    let r = decollide(&mut sk, &DecollideOptions::default()).unwrap_or_else(|e| panic!("{preset}: {e}"));
    assert_eq!(r.after, skeleton_collisions(&sk, 0.01).len(), "{preset}: report vs checker");
    let mut d = Decollided {
        before: r.before,
        after: r.after,
        millis: r.elapsed.as_secs_f64() * 1e3,
        control: Vec::new(),
        level2_raw: Vec::new(),
        level2: Vec::new(),
        clear_millis: Vec::new(),
    };
    for &mesher in meshers {
        let mut cleared = sk.clone();
        let opts = ClearOptions { max_faces: level2_faces, ..Default::default() };
        let (mesh, c) = clear_crossings(&mut cleared, &opts, |s| Ok(joint_mesh(preset, mesher, s)))
            .unwrap_or_else(|e| panic!("{preset} {mesher}: {e}"));
        let r = check_mesh(&mesh, &CheckOptions::default());
        let structural = r.structural_problems();
        assert!(structural.is_empty(), "{preset} {mesher} after decollide: {structural:?}\n{r}");
        d.control.push(r.intersection_count.unwrap_or(0));
        if c.after.is_some() {
            // The clearing searched level 2 for crossings; the rest is checked here.
            let scheme = if mesher == "quad" { Scheme::CatmullClark } else { Scheme::Loop };
            let fine = refine2(&mesh, scheme);
            let rr = check_mesh(&fine, &CheckOptions { self_intersections: false, ..Default::default() });
            assert!(rr.structural_problems().is_empty(), "{preset} {mesher} level 2 after decollide");
        }
        d.level2_raw.push(c.before);
        d.level2.push(c.after);
        d.clear_millis.push(c.elapsed.as_secs_f64() * 1e3);
    }
    Some(d)
}

/// Presets (and joint meshers) that `decollide` makes collision-free and whose meshes,
/// after the mesh clearing (`sylva::fit::clear`, as the pipeline runs it), have no
/// self-intersection at Loop / Catmull–Clark level 2 (issue 5's acceptance; the hull and
/// sweep control meshes too), small enough for CI. `decollide_table_of_every_preset` (ignored, run in
/// release) covers every preset and prints the table in `docs/meshers.md`.
const DECOLLIDED_CLEAN_CI: &[(&str, &[&str])] = &[
    ("lsys-binary-tree", &["hull", "sweep", "quad"]),
    ("lsys-honda-a", &["hull", "sweep", "quad"]),
    ("lsys-honda-c", &["hull", "sweep", "quad"]),
    ("lsys-honda-g", &["hull", "sweep", "quad"]),
    ("lsys-honda-h", &["hull", "sweep", "quad"]),
    ("lsys-ternary-tree", &["sweep", "quad"]),
    ("lsys-abop-stochastic", &["hull", "quad"]),
    ("bcm-elm", &["hull", "sweep", "quad"]),
    ("colonize-shrub", &["hull", "quad"]),
    ("mgv-c", &["hull", "sweep", "quad"]),
    ("mig-i", &["hull", "sweep", "quad"]),
    ("mig-roots", &["hull", "sweep", "quad"]),
    // The closed Koch curve, opened by pulling its tip back.
    ("lsys-snowflake", &["hull", "sweep", "quad"]),
    // Weber–Penn children snapped to nodes (no stubs).
    ("wp-palm", &["hull", "sweep", "quad"]),
    // Clean only after the mesh clearing (hull: 21 695 level-2 pairs before it, the
    // seed's collapse) and the quad support rings (72 pairs before them).
    ("lsys-abop-a", &["hull", "sweep", "quad"]),
    ("lsys-abop-bush", &["sweep", "quad"]),
    // Hull clean since session 9's root base loop (76 level-2 pairs before it); mig-m
    // quad since every side child's elbow ring (110 before; its hull is clean at level 2
    // but its control mesh keeps one crossing pair); mig-m sweep since session 10's bend
    // rings (243 level-2 pairs before them, 102 after clearing).
    ("mig-k", &["hull"]),
    ("mig-k-literal", &["hull", "sweep", "quad"]),
    ("mig-m", &["sweep", "quad"]),
];

#[test]
fn decollided_presets_mesh_without_self_intersections() {
    for &(preset, meshers) in DECOLLIDED_CLEAN_CI {
        let d = decollided(preset, meshers, 2_000_000).unwrap_or_else(|| panic!("{preset} does not grow"));
        assert!(d.before > 0 || preset == "lsys-binary-tree", "{preset}: nothing to decollide");
        assert_eq!(d.after, 0, "{preset}: skeleton collisions left");
        for (k, m) in meshers.iter().enumerate() {
            // The quad cage is Catmull–Clark's control polygon, not a surface (its
            // corners lie outside the limit surface, and crotch cages may cross where
            // the limit surface does not): only its refinement must be clean.
            if *m != "quad" {
                assert_eq!(d.control[k], 0, "{preset} {m}: control-mesh intersections");
            }
            assert_eq!(d.level2[k], Some(0), "{preset} {m}: level-2 intersections");
        }
    }
}

/// Every preset after `decollide`, with the self-intersection search at level 2 for all
/// but the largest meshes: `cargo test --release -p sylva --test meshers -- --ignored
/// --nocapture decollide_table` prints the table in `docs/meshers.md`
/// (`SYLVA_PRESETS=a,b` limits it to some presets, `SYLVA_MESHERS=quad` to some meshers;
/// `SYLVA_LEVEL2_FACES=n` searches level 2 only up to `n` faces, default 4 M).
#[test]
#[ignore = "minutes in release: every preset meshed three times and refined to level 2"]
fn decollide_table_of_every_preset() {
    let only: Vec<String> = std::env::var("SYLVA_PRESETS")
        .map(|s| s.split(',').map(str::to_string).collect())
        .unwrap_or_default();
    let level2_faces =
        std::env::var("SYLVA_LEVEL2_FACES").ok().and_then(|s| s.parse().ok()).unwrap_or(4_000_000);
    println!("| preset | collisions before | after | decollide ms | hull | sweep | quad | hull L2 | sweep L2 | quad L2 | clear s (h/s/q) |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let meshers: Vec<&str> = ["hull", "sweep", "quad"]
        .into_iter()
        .filter(|m| std::env::var("SYLVA_MESHERS").map_or(true, |v| v.split(',').any(|x| x == *m)))
        .collect();
    // Level 2 after clearing, with the count before it in brackets when it differs ("·":
    // mesher not run).
    let at = |m: &str| meshers.iter().position(|x| *x == m);
    let l2 = |d: &Decollided, m: &str| match at(m).map(|k| (d.level2_raw[k], d.level2[k])) {
        None => "·".to_string(),
        Some((Some(b), Some(a))) if a != b => format!("{a} ({b})"),
        Some((_, a)) => show(a),
    };
    let control = |d: &Decollided, m: &str| at(m).map_or("·".to_string(), |k| d.control[k].to_string());
    let secs = |d: &Decollided, m: &str| {
        at(m).map_or("·".to_string(), |k| format!("{:.1}", d.clear_millis[k] / 1e3))
    };
    for p in sylva::presets::all() {
        if !only.is_empty() && !only.iter().any(|o| o == p.name) {
            continue;
        }
        let Some(d) = decollided(p.name, &meshers, level2_faces) else { continue };
        println!(
            "| {} | {} | {} | {:.0} | {} | {} | {} | {} | {} | {} | {}/{}/{} |",
            p.name,
            d.before,
            d.after,
            d.millis,
            control(&d, "hull"),
            control(&d, "sweep"),
            control(&d, "quad"),
            l2(&d, "hull"),
            l2(&d, "sweep"),
            l2(&d, "quad"),
            secs(&d, "hull"),
            secs(&d, "sweep"),
            secs(&d, "quad")
        );
    }
}

/// Random skeletons through the one mesher interface (issue 22): for every joint mesher,
/// any valid random skeleton (`common/random_tree.rs`: branching angles 5°–170°, 1–8
/// children, radius ratios 0.1–1.2, lengths 0.2–20 radii) gives a closed, consistently
/// oriented manifold cage of positive volume with the mesher's scheme; any failure names
/// the mesher and the seed. Cages that cross themselves where the skeleton does not
/// collide and no fallback was reported are counted and bounded per mesher (the rate
/// measured over 1,000 seeds is in docs/meshers.md). `SYLVA_PROPTEST_CASES` raises the
/// 48 cases per mesher run in CI.
#[test]
fn every_joint_mesher_gives_a_closed_oriented_cage_or_reports_a_fallback() {
    use proptest::prelude::*;
    use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};
    use sylva::mesh::Mesher;
    let cases: u32 = std::env::var("SYLVA_PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(48);
    // (mesher, the largest share of unexplained crossings allowed)
    let meshers = [
        (Mesher::Hull(HullOptions { caps: true, ..Default::default() }), 0.05),
        (Mesher::Sweep(SweepOptions { caps: true, ..Default::default() }), 0.05),
        (Mesher::Quad(QuadOptions::default()), 0.05),
    ];
    for (mesher, allowed) in meshers {
        let config = ProptestConfig { cases, failure_persistence: None, ..Default::default() };
        let mut runner = TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
        let unexplained = std::cell::Cell::new(0u32);
        let result = runner.run(&any::<u64>(), |seed| {
            let sk = random_tree::random_tree(seed, 60);
            sk.validate().map_err(|e| TestCaseError::reject(e.to_string()))?;
            let cage = mesher.cage(&sk).map_err(|e| TestCaseError::fail(format!("error: {e}")))?;
            let report = checks::closed_oriented_manifold(&cage.mesh, true).map_err(TestCaseError::fail)?;
            prop_assert_eq!(cage.scheme, mesher.scheme());
            let crossed = report.intersection_count.unwrap_or(0) > 0;
            if crossed && skeleton_collisions(&sk, 0.01).is_empty() && cage.fallbacks.is_empty() {
                unexplained.set(unexplained.get() + 1);
            }
            Ok(())
        });
        if let Err(e) = result {
            panic!("mesh.method = {}: {e}", mesher.name());
        }
        let n = unexplained.get();
        println!("{}: {n} of {cases} cages cross themselves unexplained", mesher.name());
        assert!(
            n as f64 <= allowed * cases as f64,
            "{}: {n} of {cases} unexplained crossings",
            mesher.name()
        );
    }
}
