//! Every crash, hang and runaway allocation the fuzzers found (issue 27,
//! `docs/robustness.md`), each as a named test with its minimized input inline: the
//! reader must return the crate's error (what, where, why, and for a budget the limit
//! and the recipe key that raises it), quickly and without a panic.

use std::time::{Duration, Instant};
use sylva::lsystem::environment::{Environment, Sensor};
use sylva::lsystem::{DeriveOptions, ErrorKind, LSystem};

/// Parses and derives `text` with a module budget, returning the error.
fn derive_err(text: &str, steps: u32, budget: usize) -> Box<sylva::lsystem::LsystemError> {
    let t = Instant::now();
    let e = LSystem::parse("t.l", text, &[])
        .and_then(|ls| ls.derive(&DeriveOptions { steps, budget, seed: 1 }).map(|_| ()))
        .expect_err("an error");
    // The campaign's 20 s is for release builds on their own; here test threads share
    // the machine (alone, the slowest of these takes about 5 s in the test profile).
    assert!(t.elapsed() < Duration::from_secs(60), "took {:?}", t.elapsed());
    e
}

/// [`derive_err`], checked: the error is of `kind` and its message says each of `says`.
fn derive_fails(
    text: &str,
    steps: u32,
    budget: usize,
    kind: ErrorKind,
    says: &[&str],
) -> Box<sylva::lsystem::LsystemError> {
    let e = derive_err(text, steps, budget);
    assert_eq!(e.kind, kind, "{}", e.message);
    for words in says {
        assert!(e.message.contains(words), "not saying {words:?}: {}", e.message);
    }
    e
}

// ---------------------------------------------------------------------------------------
// L-system files

/// Found on the cpfg corpus' `Ridley/spiral.l` with a mutated number: `curveY(-1e308, t)`
/// computed `(id as i64) - 1`, which overflows (a panic in debug builds).
#[test]
fn curve_and_function_ids_far_out_of_range_are_errors() {
    for call in ["curveY(-1e308, 0.5)", "func(-1e308, 0.5)", "curveGAL(-9.3e18)", "func(1e308, 1)"] {
        let text = format!("Lsystem: 1\nStart: {{ y = {call}; }}\nAxiom: F\nendlsystem\n");
        let e = derive_err(&text, 1, 1000);
        assert_eq!(e.kind, ErrorKind::UndefinedName, "{call}: {}", e.message);
        assert!(e.message.starts_with("t.l:2:"), "{}", e.message);
    }
}

/// Macros that double at every level ("billion laughs"): the preprocessed text would
/// be 2³⁰ times the file.
#[test]
fn macro_expansion_bomb_is_a_budget_error() {
    let mut text = String::new();
    let names: Vec<String> = (0..32).map(|i| format!("M{i}")).collect();
    for i in 0..31 {
        text.push_str(&format!("#define {} {} {}\n", names[i], names[i + 1], names[i + 1]));
    }
    text.push_str("#define M31 F\nLsystem: 1\nAxiom: M0\nendlsystem\n");
    derive_fails(&text, 0, 1000, ErrorKind::Budget, &["more than 1048576 characters"]);
}

/// A recursive decomposition (`A(n) --> A(n-1)A(n-1)` from `A(40)`) doubled inside one
/// module without ever returning to the step's budget check.
#[test]
fn recursive_decomposition_stops_at_the_module_budget() {
    let text = "Lsystem: 1\nAxiom: A(40)\ndecomposition\nmaximum depth: 100\n\
                A(n) : n > 0 --> A(n-1)A(n-1)\nendlsystem\n";
    // One step: decomposition follows each step (cpfg does not decompose the axiom).
    let e = derive_fails(text, 1, 100_000, ErrorKind::Budget, &["more than 100000 modules"]);
    assert!(format!("{e:?}").contains("generator.max_modules"), "{e:?}");
}

/// `maximum depth: 10000` with `A --> AA`: the recursion went 10,000 calls deep and
/// overflowed the stack of a test thread (2 MiB); expansion now keeps its own stack.
#[test]
fn deep_decomposition_does_not_overflow_the_stack() {
    let text = "Lsystem: 1\nAxiom: A\ndecomposition\nmaximum depth: 10000\nA --> AA\nendlsystem\n";
    // One step: decomposition follows each step (cpfg does not decompose the axiom).
    derive_fails(text, 1, 100_000, ErrorKind::OutOfRange, &["maximum depth 10000"]);
    // Without `maximum depth` the rule applies once per step: no error.
    let ls = LSystem::parse(
        "t.l",
        "Lsystem: 1\nAxiom: B\ndecomposition\nmaximum depth: 10000\nB --> C\nC --> D\nendlsystem\n",
        &[],
    )
    .unwrap();
    let m = ls.derive(&DeriveOptions { steps: 1, budget: 100, seed: 1 }).unwrap();
    assert_eq!(ls.format(&m), "D");
}

/// The same in a homomorphism, which only the interpretation applies.
#[test]
fn recursive_homomorphism_stops_at_the_module_budget() {
    let text = "Lsystem: 1\nAxiom: A(40)\nhomomorphism\nmaximum depth: 100\nA(n) : n > 0 --> A(n-1)A(n-1)\nendlsystem\n";
    let ls = LSystem::parse("t.l", text, &[]).unwrap();
    let m = ls.derive(&DeriveOptions { steps: 0, budget: 1000, seed: 1 }).unwrap();
    let mut ev = ls.evaluator(1, Default::default()).unwrap();
    let e = ls.interpretation(&m, &mut ev, 1000).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Budget, "{}", e.message);
    assert!(e.message.contains("more than 1000 modules"), "{}", e.message);
    let text = "Lsystem: 1\nAxiom: A\nhomomorphism\nmaximum depth: 10000\nA --> AA\nendlsystem\n";
    let ls = LSystem::parse("t.l", text, &[]).unwrap();
    let m = ls.derive(&DeriveOptions { steps: 0, budget: 1000, seed: 1 }).unwrap();
    // Depth first, the rule reaches the maximum depth (or, with a smaller budget, the
    // modules waiting to be expanded reach the budget) without a deep recursion.
    let e = ls.interpretation(&m, &mut ev, 100_000).unwrap_err();
    assert_eq!(e.kind, ErrorKind::OutOfRange, "{}", e.message);
    let e = ls.interpretation(&m, &mut ev, 1000).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Budget, "{}", e.message);
}

/// A statement loop in a production's condition, run for every module of every step:
/// each block stays under the per-block loop limit, the derivation does not.
#[test]
fn endless_work_in_productions_stops_at_the_work_budget() {
    let text = "Lsystem: 1\nderivation length: 1000\nAxiom: A(0)\n\
                A(x) : { i = 0; while (i < 1000) { i = i + 1; } } x >= 0 --> A(x + 1)\nendlsystem\n";
    let units = format!("{} units of work", sylva::lsystem::derive::work_budget(10_000));
    let says = ["work budget", units.as_str(), "generator.max_modules = 10000"];
    derive_fails(text, 1_000_000, 10_000, ErrorKind::Budget, &says);
}

/// A string that stops growing, derived for two billion steps.
#[test]
fn billions_of_steps_stop_at_the_work_budget() {
    let text = "Lsystem: 1\nAxiom: A\nA --> A\nendlsystem\n";
    derive_fails(text, 2_000_000_000, 10_000, ErrorKind::Budget, &["work budget"]);
}

/// `biran(n, p)` draws n times: charged to the work budget.
#[test]
fn binomial_draws_are_charged() {
    let text = "Lsystem: 1\nAxiom: A(0)\nA(x) --> A(biran(1000000, 0.5))\nendlsystem\n";
    let e = derive_err(text, 1000, 10_000);
    assert!(e.message.contains("work budget"), "{}", e.message);
}

/// Many parameters per module: the parameter array (with `u32` offsets) has a budget
/// of its own, four per module of the module budget.
#[test]
fn parameter_explosion_is_a_budget_error() {
    let params = vec!["1"; 60].join(",");
    let text = format!("Lsystem: 1\nAxiom: A\nA --> A B({params}) A\nendlsystem\n");
    derive_fails(&text, 30, 1_000_000, ErrorKind::Budget, &["parameters"]);
}

/// Several arrays of the largest allowed size would add up to gigabytes.
#[test]
fn arrays_have_a_total_budget() {
    let text = "Lsystem: 1\ndefine: { array a[4096][4096]; array b[4096][4096]; array c[4096][4096]; }\n\
                Axiom: F\nendlsystem\n";
    let t = Instant::now();
    let e = LSystem::parse("t.l", text, &[]).expect_err("an error");
    assert!(t.elapsed() < Duration::from_secs(10));
    assert!(e.message.contains("33554432"), "{}", e.message);
}

/// An interpreted string with more internodes than the node budget is refused before
/// the skeleton is allocated.
#[test]
fn the_turtle_checks_its_node_budget_first() {
    let ls = LSystem::parse("t.l", "Lsystem: 1\nAxiom: FFFFFFFFFFFF\nendlsystem\n", &[]).unwrap();
    let m = ls.derive(&DeriveOptions { steps: 0, budget: 100, seed: 1 }).unwrap();
    let opts = sylva::lsystem::TurtleOptions { max_nodes: 10, ..Default::default() };
    let e = sylva::lsystem::interpret(&ls.symbols, &m, &opts, &ls.source).unwrap_err();
    assert_eq!(e.kind, ErrorKind::Budget);
    assert!(e.message.contains("12 internodes") && e.message.contains("10 nodes"), "{}", e.message);
    assert!(format!("{e:?}").contains("generator.max_nodes"), "{e:?}");
}

// ---------------------------------------------------------------------------------------
// Environmental programs

/// Sensors at ±1e300 with a tiny radius: their cell indices overflowed when the
/// neighbour cells were visited (a panic in debug builds).
#[test]
fn far_sensors_do_not_overflow_the_grid() {
    let env = Environment::by_name("honda81", Some(1e-300)).unwrap();
    let mut s: Vec<Sensor> = [1e300, -1e300, f64::MAX]
        .iter()
        .map(|&x| Sensor { position: glam::DVec3::splat(x), values: vec![1.0] })
        .collect();
    env.respond(&mut s);
    assert_eq!(s[0].values[0], 1.0);
}

/// Sensors piled up in one place make the neighbour search quadratic: bounded by work.
#[test]
fn piled_up_sensors_stop_at_the_work_budget() {
    let env = Environment::by_name("honda81", Some(1.0)).unwrap();
    let mut s: Vec<Sensor> =
        (0..20_000).map(|i| Sensor { position: glam::DVec3::ZERO, values: vec![i as f64] }).collect();
    let t = Instant::now();
    assert!(env.respond_within(&mut s, 1_000_000).is_err());
    assert!(t.elapsed() < Duration::from_secs(5));
}

// ---------------------------------------------------------------------------------------
// Skeleton files

/// The LST reader refuses more nodes than its budget while it reads.
#[test]
fn lst_node_budget() {
    let text = format!("LST 0.1\n{}", "Cylinder(1, 1, 1) MovRel3f(0, 1, 0)\n".repeat(20));
    let opts = sylva::import::lst::LstOptions { max_nodes: 10, ..Default::default() };
    let e = sylva::import::lst::parse("t.lst", &text, &opts).unwrap_err();
    assert!(e.message.starts_with("t.lst:11:1:") && e.message.contains("node budget"), "{}", e.message);
}

/// A polygon vertex that overflows `f32` and an organ too far away to mesh make
/// invalid skeletons.
#[test]
fn json_organs_are_validated() {
    let doc = |organ: &str| {
        format!(
            "{{\"format\":\"sylva-skeleton\",\"version\":1,\"nodes\":[{{\"position\":[0,0,0],\"radius\":1,\"parent\":null}},\
             {{\"position\":[0,1,0],\"radius\":1,\"parent\":0}}],\"organs\":[{organ}]}}"
        )
    };
    let e = sylva::import::skel_json::from_json(&doc(
        "{\"kind\":\"polygon\",\"vertices\":[[0,0,0],[1e39,0,0],[0,1,0]],\"node\":1,\"position\":[0,0,0],\"heading\":[0,1,0],\"up\":[1,0,0],\"size\":1}",
    ))
    .unwrap_err();
    assert!(e.to_string().contains("organ"), "{e}");
    let e = sylva::import::skel_json::from_json(&doc(
        "{\"kind\":\"leaf\",\"node\":1,\"position\":[3e38,0,0],\"heading\":[0,1,0],\"up\":[1,0,0],\"size\":1}",
    ))
    .unwrap_err();
    assert!(e.to_string().contains("beyond the largest"), "{e}");
}

/// Coordinates that are finite in `f32` but whose differences are not (a skeleton from
/// -3e38 to 3e38) are refused by `Skeleton::validate`.
#[test]
fn huge_finite_coordinates_are_invalid() {
    let doc = "{\"format\":\"sylva-skeleton\",\"version\":1,\"nodes\":[{\"position\":[-3e38,0,0],\"radius\":1,\"parent\":null},\
               {\"position\":[3e38,0,0],\"radius\":1,\"parent\":0}]}";
    let e = sylva::import::skel_json::from_json(doc).unwrap_err();
    assert!(matches!(e, sylva::Error::Skeleton(_)), "{e:?}");
}

// ---------------------------------------------------------------------------------------
// Meshes for `check` and `subdivide`

fn write_temp(name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("sylva-fuzz-regressions-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// A glTF document around one triangle, with `edit` applied to its JSON text.
fn gltf(edit: impl Fn(String) -> String) -> Vec<u8> {
    // Three VEC3 floats and three u16 indices, base64.
    let mut bin = Vec::new();
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let b64 = {
        const T: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in bin.chunks(3) {
            let n = (u32::from(c[0]) << 16)
                | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
                | u32::from(*c.get(2).unwrap_or(&0));
            for k in 0..=c.len() {
                s.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            }
        }
        s
    };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":44,"uri":"data:application/octet-stream;base64,{b64}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}]}}"#
    );
    edit(json).into_bytes()
}

#[test]
fn gltf_baseline_reads() {
    let p = write_temp("ok.gltf", &gltf(|j| j));
    let m = sylva::import::gltf_read::read_gltf(&p).unwrap();
    assert_eq!(m[0].mesh.face_count(), 1);
}

/// An accessor count near 2⁶⁴ wrapped the bounds check around and asked for exabytes
/// (an allocation abort); now every offset is checked without wrapping.
#[test]
fn gltf_accessor_count_near_2_64_is_an_error() {
    for count in ["18446744073709551615", "6148914691236517206", "4611686018427387905"] {
        let bytes = gltf(|j| {
            j.replacen("\"count\":3,\"type\":\"VEC3\"", &format!("\"count\":{count},\"type\":\"VEC3\""), 1)
        });
        let p = write_temp("count.gltf", &bytes);
        let e = sylva::import::gltf_read::read_gltf(&p).unwrap_err();
        assert!(e.to_string().contains("run past its buffer view"), "{e}");
    }
    let bytes = gltf(|j| j.replacen("\"byteOffset\":36", "\"byteOffset\":18446744073709551610", 1));
    let e = sylva::import::gltf_read::read_gltf(&write_temp("offset.gltf", &bytes)).unwrap_err();
    assert!(e.to_string().contains("run past"), "{e}");
}

/// An index past the last vertex reached the mesh checker, which indexes positions.
#[test]
fn gltf_index_out_of_range_is_an_error() {
    let mut bytes = gltf(|j| j);
    // The third index (u16 at byte 40 of the buffer) is in the base64; rewrite the JSON
    // to read the indices as u8 instead, which gives indices 0, 0, 1 → fine, so use a
    // POSITION count of 1 so that index 1 and 2 are out of range.
    bytes = String::from_utf8(bytes)
        .unwrap()
        .replacen("\"count\":3,\"type\":\"VEC3\"", "\"count\":1,\"type\":\"VEC3\"", 1)
        .into_bytes();
    let e = sylva::import::gltf_read::read_gltf(&write_temp("index.gltf", &bytes)).unwrap_err();
    assert!(e.to_string().contains("out of range"), "{e}");
}

/// A buffer uri naming a device (or any file that is not a regular one) would be read
/// forever.
#[test]
fn gltf_buffer_uri_must_be_a_relative_regular_file() {
    for uri in ["/dev/zero", "file:///dev/zero", "."] {
        let bytes = gltf(|j| {
            let start = j.find("\"uri\":\"").unwrap() + 7;
            let end = start + j[start..].find('"').unwrap();
            format!("{}{}{}", &j[..start], uri, &j[end..])
        });
        let e = sylva::import::gltf_read::read_gltf(&write_temp("uri.gltf", &bytes)).unwrap_err();
        let m = e.to_string();
        assert!(m.contains("not a relative file name") || m.contains("not a regular file"), "{uri}: {m}");
    }
}

/// OBJ tag counts near 2⁶⁴ overflowed their sum (a panic in debug builds).
#[test]
fn obj_tag_counts_that_overflow_are_errors() {
    let e = sylva::mesh::obj_read::parse_obj("v 0 0 0\nv 1 0 0\nt crease 18446744073709551615/1 0 1 1\n")
        .unwrap_err();
    assert!(e.to_string().contains("line 3") && e.to_string().contains("announces"), "{e}");
}

// ---------------------------------------------------------------------------------------
// Budgets of the pipeline's stages (recipe keys)

/// Loads preset `name` with `--set` lines `sets` and grows it.
fn grow_with(name: &str, sets: &[&str]) -> sylva::Result<sylva::pipeline::Grown> {
    let sets: Vec<(String, toml::Value)> =
        sets.iter().map(|s| sylva::recipe::parse_set(s).unwrap()).collect();
    sylva::pipeline::grow(&sylva::recipe::load(name, &sets)?)
}

/// `generator.max_nodes` bounds the turtle's skeleton (the error names the key and the
/// limit); raising it lets the same tree grow.
#[test]
fn generator_max_nodes_is_a_recipe_key() {
    let e = grow_with("lsys-honda-a", &["generator.max_nodes=100"]).expect_err("over the node budget");
    let m = e.to_string();
    assert!(m.contains("generator.max_nodes") && m.contains("100 nodes"), "{m}");
    let g = grow_with("lsys-honda-a", &["generator.max_nodes=2000000"]).unwrap();
    assert!(g.skeleton.len() > 100);
    // Imported skeletons: the JSON and LST readers take the same key.
    let d = std::env::temp_dir().join(format!("sylva-max-nodes-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let json = d.join("t.skel.json");
    std::fs::write(&json, sylva::export::skeleton::to_json(&g.skeleton)).unwrap();
    let lst = d.join("t.lst");
    std::fs::write(&lst, format!("LST 0.1\n{}", "Cylinder(1, 1, 1) MovRel3f(0, 1, 0)\n".repeat(20))).unwrap();
    for file in [&json, &lst] {
        let set = vec![sylva::recipe::parse_set("generator.max_nodes=10").unwrap()];
        let loaded = sylva::recipe::load(file.to_str().unwrap(), &set).unwrap();
        let e = sylva::pipeline::grow(&loaded).expect_err("over the node budget");
        assert!(e.to_string().contains("generator.max_nodes"), "{}: {e}", file.display());
        let loaded = sylva::recipe::load(file.to_str().unwrap(), &[]).unwrap();
        sylva::pipeline::grow(&loaded).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    }
    std::fs::remove_dir_all(&d).ok();
}

/// The new budget keys are left out of a file's metadata at their defaults (so the
/// golden files keep their form) and written when set.
#[test]
fn budget_keys_are_written_only_when_set() {
    let g = grow_with("lsys-honda-a", &[]).unwrap();
    let text = &g.model.provenance.as_ref().unwrap().recipe;
    let table: toml::Table = toml::from_str(text).unwrap();
    for key in [
        "generator.max_nodes",
        "refine.max_faces",
        "fit.clear.max_work",
        "fit.decollide.max_work",
        "mesh.quad.max_repair_work",
    ] {
        let mut v = Some(&table);
        let parts: Vec<&str> = key.split('.').collect();
        for p in &parts[..parts.len() - 1] {
            v = v.and_then(|t| t.get(*p)).and_then(|t| t.as_table());
        }
        let present = v.is_some_and(|t| t.contains_key(parts[parts.len() - 1]));
        assert!(!present, "{key} in the default metadata:\n{text}");
    }
    let g = grow_with("lsys-honda-a", &["generator.max_nodes=5000", "refine.max_faces=1000000"]).unwrap();
    let text = &g.model.provenance.as_ref().unwrap().recipe;
    assert!(text.contains("max_nodes = 5000") && text.contains("max_faces = 1000000"), "{text}");
}

/// `[refine]` checks its face budget, `refine.max_faces`, before it refines.
#[test]
fn refine_max_faces_is_a_recipe_key() {
    let e = grow_with("lsys-honda-a", &["refine.levels=3", "refine.max_faces=10000"]).expect_err("over");
    let m = e.to_string();
    assert!(m.contains("refine.max_faces") && m.contains("10000"), "{m}");
    grow_with("lsys-honda-a", &["refine.levels=1", "refine.max_faces=10000000"]).unwrap();
}

/// Campaign run: `sylva grow mig-a --set mesh.method=quad` ran 132 s, 117 s of it in
/// `fit::clear`, whose every round meshes again with the quad mesher's level-2 repair.
/// The repair and the pass now count their work: with a budget small enough for a
/// debug build the run stops at once with an error naming the key (release, default
/// budgets: see docs/robustness.md).
#[test]
fn quad_clearing_of_mig_a_stops_at_its_work_budgets() {
    let t = Instant::now();
    // De-collision off (clearing on), to keep the test short: the repair runs in the
    // clearing's first meshing all the same.
    let quad = ["mesh.method=\"quad\"", "mesh.decollide=false", "mesh.clear=true"];
    let e = grow_with("mig-a", &[&quad[..], &["mesh.quad.max_repair_work=2000000"]].concat())
        .expect_err("over the repair budget");
    let m = e.to_string();
    assert!(m.contains("mesh.quad.max_repair_work") && m.contains("2000000"), "{m}");
    let e = grow_with(
        "mig-a",
        &[&quad[..], &["mesh.quad.repair_rounds=0", "fit.clear.max_work=100000"]].concat(),
    )
    .expect_err("over the clearing budget");
    let m = e.to_string();
    assert!(m.contains("fit.clear.max_work") && m.contains("100000"), "{m}");
    assert!(t.elapsed() < Duration::from_secs(120), "took {:?}", t.elapsed());
}

/// The clearing's budget on a small tree: a budget below one round's search is an
/// error naming the key; the default lets it run.
#[test]
fn clearing_work_budget_on_a_small_tree() {
    let e = grow_with("lsys-honda-a", &["mesh.method=\"sweep\"", "fit.clear.max_work=1000"])
        .expect_err("over the clearing budget");
    assert!(e.to_string().contains("fit.clear.max_work"), "{e}");
    let g = grow_with("lsys-honda-a", &["mesh.method=\"sweep\""]).unwrap();
    let c = g.report.clear.expect("the clearing ran");
    assert!(c.work > 1000 && c.work <= sylva::fit::clear::DEFAULT_CLEAR_WORK, "{c:?}");
}

/// De-collision counts its work over the whole pass: a budget below what
/// `lsys-honda-a`'s 2,363 collisions need is an error naming the key; the default lets
/// it clear them.
#[test]
fn decollide_work_budget() {
    let e = grow_with("lsys-honda-a", &["mesh.method=\"hull\"", "fit.decollide.max_work=1500"])
        .expect_err("over the de-collision budget");
    let m = e.to_string();
    assert!(m.contains("fit.decollide.max_work") && m.contains("1500"), "{m}");
    let g = grow_with("lsys-honda-a", &["mesh.method=\"hull\"", "mesh.clear=false"]).unwrap();
    let d = g.report.decollide.expect("the de-collision ran");
    assert!(d.before > 0 && d.after < d.before, "{d:?}");
}

/// Campaign run: `mgv-e` with its graph box 100,000 m tall (10 m wide) took 40 s to
/// build a 30,000-node Yao graph: for nodes whose nearest neighbour in some octant lies
/// far up the column, every search ring walked all the rows between its two y faces.
/// Rings now visit only the rows that hold their cells.
#[test]
fn tall_thin_graph_volume_builds_quickly() {
    let t = Instant::now();
    let r = grow_with(
        "mgv-e",
        &["generator.volume=[{shape=\"box\",center=[0.0,5.0,0.0],size=[10.0,100000.0,10.0]}]"],
    );
    if let Err(e) = &r {
        panic!("{e}");
    }
    assert!(t.elapsed() < Duration::from_secs(60), "took {:?}", t.elapsed());
}

/// The two campaign runs that took over 20 s, with their exact inputs and the default
/// budgets: each must end, with a result or an error, well within 20 s on an idle
/// machine (the wall time printed; the bound asserted leaves room for a loaded one).
/// Ignored (a release measurement): `cargo test --release -p sylva --test
/// fuzz_regressions -- --ignored --nocapture slow_campaign_inputs`.
#[test]
#[ignore]
fn slow_campaign_inputs_end_within_20_s() {
    let mut took = Vec::new();
    for (name, sets) in [
        ("mig-a", vec!["mesh.method=\"quad\""]),
        ("mgv-e", vec!["generator.volume=[{shape=\"box\",center=[0.0,5.0,0.0],size=[10.0,100000.0,10.0]}]"]),
    ] {
        let t = Instant::now();
        let r = grow_with(name, &sets);
        let dt = t.elapsed();
        match &r {
            Ok(g) => println!("{name} {sets:?}: ok in {dt:.2?} ({} skeleton nodes)", g.skeleton.len()),
            Err(e) => println!("{name} {sets:?}: error in {dt:.2?}: {e}"),
        }
        took.push((name, dt));
    }
    for (name, dt) in took {
        assert!(dt < Duration::from_secs(60), "{name}: {dt:?}");
    }
}

/// Measures one quad meshing of `mig-a` (its repair work and time) and a second run
/// that stops at the default budgets. Ignored (a release measurement).
#[test]
#[ignore]
fn quad_repair_work_of_mig_a() {
    let t = Instant::now();
    let g = grow_with(
        "mig-a",
        &["mesh.method=\"quad\"", "fit.clear.max_rounds=0", "mesh.quad.max_repair_work=100000000000"],
    )
    .unwrap();
    println!(
        "mig-a quad, one meshing: repair work {}, clear work {:?}, mesh {:.2?}, total {:.2?}",
        g.report.repair_work,
        g.report.clear.as_ref().map(|c| c.work),
        g.report.mesh_time,
        t.elapsed()
    );
}
