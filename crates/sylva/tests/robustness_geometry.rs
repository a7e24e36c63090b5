//! Issue 39, items 4–6: hostile skeletons and sizes end quickly, with a result or an
//! error that names what to change.
//!
//! - **4** a forest of 10,000 separate roots (`generator.gap = "new-root"`): the flat-base
//!   cut is local to each root (it rebuilt the whole mesh once per root: minutes);
//! - **5** an absurd `generator.width` (1e30 on internodes of about a metre) is rejected
//!   before de-collision, naming the key (its collision search ran for minutes);
//! - **6** degenerate skeletons — every node coincident, zig-zags that turn straight back,
//!   chains of zero-length internodes, many near-coincident nodes — are rejected before
//!   the collision searches when their capsules pile up, and otherwise stop within the
//!   work budgets, which now count the candidate pairs a search examines (their cost
//!   varied by orders of magnitude per unit before).
//!
//! No test reads a clock: each input is big enough that the old code took minutes in
//! this (debug) profile, so a regression shows as a test that does not end.

#[path = "common/hostile_skeletons.rs"]
mod hostile;
use sylva::pipeline::Grown;

/// Grows `text`, written to a file called `name` in a fresh temporary folder, with the
/// recipe keys `sets`.
fn grow_file(name: &str, text: &str, sets: &[&str]) -> sylva::Result<Grown> {
    let dir = std::env::temp_dir().join(format!("sylva-robustness-geometry-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    let sets: Vec<(String, toml::Value)> =
        sets.iter().map(|s| sylva::recipe::parse_set(s).unwrap()).collect();
    let out = sylva::recipe::load(path.to_str().unwrap(), &sets).and_then(|l| sylva::pipeline::grow(&l));
    let _ = std::fs::remove_dir_all(&dir);
    out
}

/// Grows a preset with the recipe keys `sets`.
fn grow_preset(name: &str, sets: &[&str]) -> sylva::Result<Grown> {
    let sets: Vec<(String, toml::Value)> =
        sets.iter().map(|s| sylva::recipe::parse_set(s).unwrap()).collect();
    sylva::pipeline::grow(&sylva::recipe::load(name, &sets)?)
}

/// The bark part of a grown model.
fn bark(g: &Grown) -> &sylva::geometry::Mesh {
    &g.model.parts.iter().find(|p| p.name == "bark").expect("a bark part").mesh
}

/// A run that ends: a model with a valid, non-empty bark, or an error naming one of
/// `keys`.
fn ends_well(what: &str, r: sylva::Result<Grown>, keys: &[&str]) {
    match r {
        Ok(g) => {
            let m = bark(&g);
            m.validate().unwrap_or_else(|e| panic!("{what}: invalid bark: {e}"));
            assert!(m.face_count() > 0, "{what}: empty bark");
        }
        Err(e) => {
            let m = e.to_string();
            assert!(keys.iter().any(|k| m.contains(k)), "{what}: the error names none of {keys:?}: {m}");
        }
    }
}

/// Item 4: 10,000 separate cylinders, one root each, every one standing on a flat base
/// at y = 0 (the cut was roots × faces: 10⁴ × 4·10⁵ face visits, minutes in debug).
#[test]
fn item4_ten_thousand_roots_each_get_a_flat_base() {
    let g = grow_file(
        "forest.lst",
        &hostile::many_roots_lst(10_000),
        &["generator.gap=\"new-root\"", "mesh.method=\"tube\"", "output.textures=\"none\""],
    )
    .expect("the forest grows");
    assert_eq!(g.report.skeleton.roots, 10_000);
    assert!(
        !g.report.warnings.iter().any(|w| w.contains("flat base")),
        "every root is cut: {:?}",
        &g.report.warnings[..g.report.warnings.len().min(3)]
    );
    let m = bark(&g);
    m.validate().unwrap();
    let lo = m.positions.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    assert_eq!(lo, 0.0, "the bases lie on the ground plane");
    // Each base is a fan facing down: at least one downward face per root.
    let down = (0..m.face_count())
        .filter(|&f| {
            let v = m.face(f);
            v.iter().all(|&i| m.positions[i as usize].y == 0.0)
        })
        .count();
    assert!(down >= 10_000, "{down} base faces");
}

/// Item 5: `generator.width = 1e30` on an L-system whose internodes are about a metre
/// long: every capsule holds the whole tree. Rejected before de-collision (whose
/// collision search ran for minutes), naming the key, with every mesher.
#[test]
fn item5_an_absurd_width_is_rejected_naming_the_key() {
    for method in ["sweep", "hull", "quad", "tube"] {
        let e = grow_preset("lsys-abop-a", &["generator.width=1e30", &format!("mesh.method=\"{method}\"")])
            .expect_err("an absurd width");
        let m = e.to_string();
        assert!(m.contains("generator.width") && m.contains("radius"), "{method}: {m}");
    }
    // A skeleton file with such radii: the message names the file's radii.
    let e = grow_file("huge.skel.json", &hostile::radius_tree(4000, 1e30, 4), &["mesh.method=\"sweep\""])
        .expect_err("absurd radii");
    assert!(e.to_string().contains("the file's radii"), "{e}");
}

/// Item 6: 4,023 coincident nodes (a chain and a star), a zig-zag of 4,023 nodes that
/// turns straight back at every node, and 10,000 nodes of zero-length chains are
/// rejected before the collision searches, naming the first offending node and what to
/// change (they ran 40 s to minutes in release).
#[test]
fn item6_piles_of_degenerate_internodes_are_rejected_before_the_searches() {
    let cases = [
        (
            "chain.skel.json",
            hostile::coincident_chain(4023),
            "zero-length internode(s), the first ending at node 1",
        ),
        (
            "star.skel.json",
            hostile::coincident_star(4023),
            "zero-length internode(s), the first ending at node 1",
        ),
        (
            "zigzag.skel.json",
            hostile::zigzag(4023),
            "turning straight back along their parent, the first ending at node 2",
        ),
        ("zero.skel.json", hostile::zero_length_chains(10_000, 9, 1), "zero-length internode(s)"),
    ];
    for (name, text, why) in &cases {
        for method in ["sweep", "hull", "quad"] {
            let e = grow_file(name, text, &[&format!("mesh.method=\"{method}\"")]).expect_err("degenerate");
            let m = e.to_string();
            assert!(m.contains("degenerate geometry") && m.contains(why), "{name} {method}: {m}");
            assert!(m.contains("mesh.method") && m.contains("tube"), "{name} {method}: {m}");
        }
        // The tube mesher has no collision search: it meshes the pile.
        let g = grow_file(name, text, &["mesh.method=\"tube\"", "output.textures=\"none\""]);
        if let Err(e) = g {
            assert!(!e.to_string().contains("degenerate geometry"), "{name} tube: {e}");
        }
    }
}

/// Item 6: degenerate skeletons too small to be rejected up front — 400 coincident
/// nodes, a 400-node zig-zag, a 1,000-node zero-length tail, 400 nodes within 0.1 mm
/// of each other — end within the work budgets with every joint mesher (the old
/// budgets counted nodes, and these ran 20 s to minutes in release).
#[test]
fn item6_small_degenerate_skeletons_end_within_the_budgets() {
    let budgets =
        ["fit.decollide.max_work", "fit.clear.max_work", "mesh.quad.max_repair_work", "degenerate geometry"];
    let cases = [
        ("chain.skel.json", hostile::coincident_chain(400)),
        ("zigzag.skel.json", hostile::zigzag(400)),
        ("tail.skel.json", hostile::zero_length_tail(1000)),
        ("near.skel.json", hostile::near_coincident(400, 1e-4, 2)),
    ];
    for (name, text) in &cases {
        for method in ["sweep", "hull", "quad"] {
            let r =
                grow_file(name, text, &[&format!("mesh.method=\"{method}\""), "output.textures=\"none\""]);
            // "no triangles": a pile of coincident nodes may mesh to nothing.
            let keys = [&budgets[..], &["no triangles"]].concat();
            ends_well(&format!("{name} {method}"), r, &keys);
        }
    }
}

/// Item 6: the sweep mesher alone (no de-collision, no clearing) on 4,000
/// near-coincident nodes: its repair checks stop at their budget, or the skeleton is
/// rejected as degenerate (it passed 90 s in release).
#[test]
fn item6_sweep_on_near_coincident_nodes_ends() {
    let text = hostile::near_coincident(4000, 1e-3, 3);
    let r = grow_file(
        "near.skel.json",
        &text,
        &["mesh.method=\"sweep\"", "mesh.decollide=false", "mesh.clear=false", "output.textures=\"none\""],
    );
    ends_well("sweep, near-coincident", r, &["degenerate geometry", "budget"]);
}

/// The acceptance campaign's slowest runs (stop 39): 528 nodes of radius 1e30 spaced
/// 1.9e27 apart along a line with a few side branches, grown with the sweep mesher and
/// the clearing: every capsule holds 500 internodes, 117,010 overlapping pairs, and the
/// de-collision took 11.7 s resolving them (the crowded floor was 10⁶ pairs). Now the
/// pile is refused before the searches, naming the radii and the way out.
#[test]
fn huge_radii_over_a_long_line_are_refused_as_crowded() {
    let n = 528;
    let nodes: Vec<([f64; 3], f64, Option<usize>)> = (0..n)
        .map(|i| {
            let parent = (i > 0).then(|| if i % 10 == 0 { i / 2 } else { i - 1 });
            ([0.0, i as f64 * 1e30 / n as f64, (i % 10 == 0) as u8 as f64 * 1e27], 1e30, parent)
        })
        .collect();
    let text = hostile::skel_json(&nodes);
    let r = grow_file("huge.skel.json", &text, &["mesh.method=\"sweep\"", "mesh.clear=true"]);
    let e = match r {
        Ok(_) => panic!("a pile of 1e30 capsules grew"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("degenerate geometry") && e.contains("overlap in more than"), "{e}");
    // The tube mesher does not search: the same skeleton meshes.
    ends_well("huge, tube", grow_file("huge.skel.json", &text, &["mesh.method=\"tube\""]), &[]);
}
