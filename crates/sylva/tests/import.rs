//! Skeleton import and export: the LST format of Pieterse2012 (§4.1.5–4.1.6, Table 4.2;
//! `spec/000-hull-joints-loop.md` §2.1–2.2 and properties 1–3, 22), CPFG `.str` turtle
//! strings (MacMurchy2004 §A.4) and sylva's JSON skeleton (`docs/formats.md`).

use glam::{DVec3, Vec3};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use sylva::export::skeleton::{self, from_json, to_json, to_lst};
use sylva::import::cpfg_str;
use sylva::import::lst::{self, GapPolicy, LstOptions};
use sylva::lsystem::source::Source;
use sylva::lsystem::{interpret, DeriveOptions, ErrorKind, LSystem, TurtleOptions, DEFAULT_MODULE_BUDGET};
use sylva::{Error, Skeleton, NO_PARENT};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn read(name: &str) -> String {
    std::fs::read_to_string(data(name)).unwrap()
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).length() <= tol
}

const HONDA: &str = include_str!("../../../presets/lsystem/honda.l");

/// Derives an L-system file.
fn derive(text: &str, steps: u32) -> (LSystem, sylva::lsystem::ModuleString) {
    let ls = LSystem::parse("t.l", text, &[]).unwrap();
    let s = ls.derive(&DeriveOptions { steps, budget: DEFAULT_MODULE_BUDGET, seed: 7 }).unwrap();
    (ls, s)
}

/// A turtle-grown tree (depth-first, as every sylva generator writes).
fn honda_tree(steps: u32) -> Skeleton {
    let (ls, s) = derive(HONDA, steps);
    interpret(&ls.symbols, &s, &TurtleOptions::default(), &ls.source).unwrap()
}

// ---------------------------------------------------------------------------------
// LST: the seed's sample

/// Pieterse2012-spec property 1: 6 cylinders + 1 bridge, root axis (−sin 0.3, cos 0.3, 0), root
/// end ≈ (−2.9552, 9.5534, 0), first child axis (sin 0.7, cos 0.7, 0).
#[test]
fn sample_lst_property_1() {
    let t = lst::parse_tree("sample.lst", &read("yggdrasil-sample.lst"), &LstOptions::default()).unwrap();
    assert_eq!(t.version, "0.1");
    assert_eq!(t.branches.len(), 7);
    assert_eq!(t.branches.iter().filter(|b| b.bridge).count(), 1);
    assert_eq!(t.branches.iter().filter(|b| !b.bridge).count(), 6);
    let root = &t.branches[0];
    assert!(close(root.frame.y_axis, DVec3::new(-(0.3f64).sin(), (0.3f64).cos(), 0.0), 1e-12));
    let sk = &t.skeleton;
    let end = sk.position[root.end_node as usize].as_dvec3();
    assert!(close(end, DVec3::new(-2.9552, 9.5534, 0.0), 1e-4), "{end}");
    let first_child = &t.branches[1];
    assert_eq!(first_child.start_node, root.end_node);
    assert!(close(first_child.frame.y_axis, DVec3::new((0.7f64).sin(), (0.7f64).cos(), 0.0), 1e-12));
    // The whole tree: two two-segment branches and the bridged top of the trunk.
    assert_eq!(sk.parent, vec![NO_PARENT, 0, 1, 2, 1, 4, 1, 6]);
    assert_eq!(sk.order, vec![0, 0, 1, 1, 1, 1, 0, 0]);
    let bridge = t.branches.iter().position(|b| b.bridge).unwrap();
    assert_eq!(bridge, 5);
    let b = &t.branches[bridge];
    assert_eq!((b.start_node, b.end_node, b.line), (1, 6, 12));
    assert!((b.length - 5.0).abs() < 1e-12 && close(b.frame.y_axis, root.frame.y_axis, 1e-12));
    let top = DVec3::new(-(0.3f64).sin(), (0.3f64).cos(), 0.0) * 15.0
        + DVec3::new(-(0.9f64).sin(), (0.9f64).cos(), 0.0) * 10.0;
    assert!(close(sk.position[7].as_dvec3(), top, 1e-5));
    sk.validate().unwrap();
}

/// Pieterse2012-spec property 3: every non-root branch starts exactly at its parent's end (after
/// the gap policy); property 22: the same file gives the same skeleton, bit for bit.
#[test]
fn sample_lst_branches_connect_and_parse_deterministically() {
    let text = read("yggdrasil-sample.lst");
    let t = lst::parse_tree("sample.lst", &text, &LstOptions::default()).unwrap();
    for b in &t.branches {
        assert_eq!(t.skeleton.parent[b.end_node as usize], b.start_node);
        let start = t.skeleton.position[b.start_node as usize].as_dvec3();
        let axis_end = start + b.frame.y_axis * b.length;
        assert!(close(axis_end, t.skeleton.position[b.end_node as usize].as_dvec3(), 1e-5));
    }
    let again = lst::parse_tree("sample.lst", &text, &LstOptions::default()).unwrap();
    assert_eq!(again, t);
    assert_eq!(to_lst(&again.skeleton), to_lst(&t.skeleton));
}

#[test]
fn sample_lst_gap_is_an_error_when_strict_and_a_root_otherwise() {
    let text = read("yggdrasil-sample.lst");
    let strict = LstOptions { gap: GapPolicy::Strict, ..Default::default() };
    let e = lst::parse("sample.lst", &text, &strict).unwrap_err();
    assert!(e.message.starts_with("sample.lst:12:1: gap: this cylinder starts at"), "{}", e.message);
    assert!(e.message.contains("5 away from the end of the current branch"), "{}", e.message);
    let roots = LstOptions { gap: GapPolicy::NewRoot, ..Default::default() };
    let sk = lst::parse("sample.lst", &text, &roots).unwrap();
    assert_eq!(sk.parent, vec![NO_PARENT, 0, 1, 2, 1, 4, NO_PARENT, 6]);
}

/// The sample exactly as extracted from the seed (`Mo∨Rel3f`, `MovRel3t`): the noise is
/// reported where it is, with a suggestion.
#[test]
fn verbatim_sample_reports_the_extraction_noise() {
    let e = lst::parse("verbatim.lst", &read("yggdrasil-sample-verbatim.lst"), &LstOptions::default())
        .unwrap_err();
    assert!(e.message.starts_with("verbatim.lst:7:1: unknown LST operation `Mo∨Rel3f`"), "{}", e.message);
    assert_eq!(e.help.as_deref(), Some("did you mean `MovRel3f`? (names are case-sensitive)"));
    let fixed = read("yggdrasil-sample-verbatim.lst").replace("Mo∨Rel3f", "MovRel3f");
    let e = lst::parse("verbatim.lst", &fixed, &LstOptions::default()).unwrap_err();
    assert!(e.message.starts_with("verbatim.lst:13:1: unknown LST operation `MovRel3t`"), "{}", e.message);
}

/// Pieterse2012-spec property 2 / assumption A3: rotations compose in the local frame
/// (R ← R·Rot): Rz(90°) then Rx(90°) sends the cylinder axis Y to +Z (pre-multiplying
/// would give −X). Angles are radians, moves are in the rotated frame.
#[test]
fn two_axis_rotation_composes_in_the_local_frame() {
    let q = std::f64::consts::FRAC_PI_2;
    let text = format!(
        "LST 0.1\nRotRel3f({q}, 0, 0, 1) RotRel3f({q}, 2, 0, 0) Cylinder(1, 1, 3) MovRel3f(0, 3, 1)\n"
    );
    let sk = lst::parse("t.lst", &text, &LstOptions::default()).unwrap();
    assert!(close(sk.position[1].as_dvec3(), DVec3::new(0.0, 0.0, 3.0), 1e-12), "{}", sk.position[1]);
    // up = R·X: Rz(90°)·Rx(90°)·X = Y.
    assert!((sk.up[1] - Vec3::Y).length() < 1e-6);
    let text = format!("{text}Cylinder(1, 1, 1)");
    let sk = lst::parse("t.lst", &text, &LstOptions::default()).unwrap();
    // The move (0, 3, 1) in the rotated frame went to (0, 0, 3) + R·(0, 0, 1), with
    // R·Z = Rz(90°)·(−Y) = X: (1, 0, 3), a gap from the last node, bridged.
    assert!(close(sk.position[2].as_dvec3(), DVec3::new(1.0, 0.0, 3.0), 1e-12), "{}", sk.position[2]);
    assert_eq!(sk.parent, vec![NO_PARENT, 0, 1, 2]);
}

// ---------------------------------------------------------------------------------
// LST: malformed files

#[test]
fn malformed_lst_gives_file_line_column() {
    // Each kind of error with its texts and the start of its located message.
    let cases: [(ErrorKind, &[(&str, &str)]); 3] = [
        (
            ErrorKind::Syntax,
            &[
                ("", "t.lst:1:1: missing `LST <version>` header: the file is empty"),
                ("\n\nCylinder(1, 1, 1)\n", "t.lst:3:1: missing `LST <version>` header"),
                ("LST\n", "t.lst:1:1: missing version after `LST`"),
                ("LST x1\n", "t.lst:1:5: LST version `x1` is not a number"),
                ("LST 0.1 SB()\n", "t.lst:1:9: unexpected `SB()` after the LST version"),
                ("LST 0.1\n  Sphere(1)\n", "t.lst:2:3: unknown LST operation `Sphere`"),
                ("LST 0.1\nSB() movrel3f(1, 2, 3)", "t.lst:2:6: unknown LST operation `movrel3f`"),
                ("LST 0.1\nCylinder(1, one, 2)\n", "t.lst:2:13: expected a number, found `one`"),
                ("LST 0.1\nCylinder(1, , 2)\n", "t.lst:2:12: missing number"),
                ("LST 0.1\nCylinder(-1, 1, 2)\n", "t.lst:2:10: negative cylinder start radius -1"),
                ("LST 0.1\nCylinder(1, -0.5, 2)\n", "t.lst:2:13: negative cylinder end radius -0.5"),
                ("LST 0.1\nCylinder(1, 1, -2)\n", "t.lst:2:16: negative cylinder length -2"),
                ("LST 0.1\nRotRel3f(1, 0, 0, 0)\n", "t.lst:2:13: `RotRel3f` has a zero rotation axis"),
                ("LST 0.1\nSB() EB()\nEB()\n", "t.lst:3:1: `EB()` without a matching `SB()`"),
                ("LST 0.1\nSB() SB() EB()\n", "t.lst:2:1: `SB()` is never closed by an `EB()` (1 still open"),
                ("LST 0.1\nSB\n", "t.lst:2:1: expected `(` after `SB`"),
                ("LST 0.1\nMovRel3f(0, 1,\n 0)\n", "t.lst:2:9: unclosed `(` after `MovRel3f`"),
                ("LST 0.1\nMovRel3f(0, (1), 0)\n", "t.lst:2:13: unexpected `(` inside an argument list"),
                ("LST 0.1\n) SB()\n", "t.lst:2:1: unexpected `)`: expected an LST operation"),
            ],
        ),
        (
            ErrorKind::Arity,
            &[
                ("LST 0.1\nMovRel3f(1, 2)\n", "t.lst:2:1: `MovRel3f` takes 3 argument(s), got 2"),
                ("LST 0.1\nSB(1)\n", "t.lst:2:1: `SB` takes 0 argument(s), got 1"),
                ("LST 0.1\nRotRel3f(1, 0, 0, 1, 5, 6)\n", "t.lst:2:1: `RotRel3f` takes 4 argument(s), got 6"),
            ],
        ),
        (
            ErrorKind::NonFinite,
            &[
                ("LST 0.1\nMovRel3f(0, NaN, 0)\n", "t.lst:2:13: `NaN` is not a finite number"),
                ("LST 0.1\nMovRel3f(0, 1e999, 0)\n", "t.lst:2:13: `1e999` is not a finite number"),
            ],
        ),
    ];
    for (kind, texts) in cases {
        for (text, want) in texts {
            let e = lst::parse("t.lst", text, &LstOptions::default()).unwrap_err();
            assert!(e.message.starts_with(want), "{text:?}\n got: {}\nwant: {want}", e.message);
            assert_eq!(e.kind, kind, "{text:?}");
            assert!(e.span.is_some(), "{text:?}");
        }
    }
}

#[test]
fn lst_tolerates_blank_lines_crlf_and_spacing() {
    let text = "\r\n\r\n  LST 0.1 \r\n\r\nCylinder( 1 ,1, 2 )\tMovRel3f (0,2,0)\r\n\r\n  Cylinder(1,1,1)\r\n";
    let sk = lst::parse("t.lst", text, &LstOptions::default()).unwrap();
    assert_eq!(sk.parent, vec![NO_PARENT, 0, 1]);
    assert_eq!(sk.position[2], Vec3::new(0.0, 3.0, 0.0));
    assert!(lst::parse("t.lst", "LST 0.1", &LstOptions::default()).unwrap().is_empty());
}

// ---------------------------------------------------------------------------------
// LST: export and round trip

fn chain() -> Skeleton {
    let mut s = Skeleton::new();
    let mut p = s.push(Vec3::new(1.0, -2.0, 0.5), 0.5, NO_PARENT, Vec3::Z, 0);
    let mut pos = Vec3::new(1.0, -2.0, 0.5);
    for k in 0..40 {
        let a = k as f32 * 0.37;
        pos += Vec3::new(a.sin() * 0.3, 0.5 + 0.01 * k as f32, a.cos() * 0.2);
        p = s.push(pos, 0.5 * 0.97f32.powi(k + 1), p, Vec3::X, 0);
    }
    s
}

fn fork() -> Skeleton {
    let mut s = Skeleton::new();
    let r = s.push(Vec3::ZERO, 0.2, NO_PARENT, Vec3::X, 0);
    let a = s.push(Vec3::new(0.0, 1.0, 0.0), 0.15, r, Vec3::X, 0);
    let b = s.push(Vec3::new(0.6, 1.5, 0.2), 0.08, a, Vec3::Z, 1);
    s.push(Vec3::new(0.9, 1.8, 0.3), 0.05, b, Vec3::Z, 1);
    s.push(Vec3::new(-0.5, 1.4, -0.1), 0.07, a, Vec3::Z, 1);
    s.push(Vec3::new(0.0, 2.0, 0.0), 0.1, a, Vec3::X, 0);
    s
}

/// Positions within 1e-6 relative, radii within 1e-6 relative, identical parents.
fn assert_same_shape(back: &Skeleton, s: &Skeleton) {
    assert_eq!(back.parent, s.parent);
    for i in 0..s.len() {
        let (a, b) = (back.position[i].as_dvec3(), s.position[i].as_dvec3());
        assert!((a - b).length() <= 1e-6 * b.length().max(1.0), "node {i}: {a} vs {b}");
        let (ra, rb) = (f64::from(back.radius[i]), f64::from(s.radius[i]));
        assert!((ra - rb).abs() <= 1e-6 * rb.max(1e-30), "radius {i}: {ra} vs {rb}");
    }
}

#[test]
fn lst_round_trip_of_a_fork_and_a_chain() {
    for s in [fork(), chain()] {
        let text = to_lst(&s);
        let back =
            lst::parse("t.lst", &text, &LstOptions { gap: GapPolicy::Strict, ..Default::default() }).unwrap();
        assert_same_shape(&back, &s);
        assert_eq!(back.order, s.order);
        // Radii are written in their shortest form and read back exactly.
        assert_eq!(back.radius, s.radius);
        // Exporting the import gives the same file (up to the last bits of aim).
        assert_same_shape(&lst::parse("t.lst", &to_lst(&back), &LstOptions::default()).unwrap(), &s);
    }
}

#[test]
fn lst_round_trip_of_a_grown_tree() {
    let s = honda_tree(8);
    assert!(s.len() > 200);
    let text = to_lst(&s);
    let back =
        lst::parse("t.lst", &text, &LstOptions { gap: GapPolicy::Strict, ..Default::default() }).unwrap();
    assert_same_shape(&back, &s);
    assert_eq!(back.order, s.order);
}

#[test]
fn lst_round_trip_of_a_forest_and_a_bushy_root() {
    // Two roots, the first with three children at the root.
    let mut s = Skeleton::new();
    let r = s.push(Vec3::new(-1.0, 0.0, 0.0), 0.1, NO_PARENT, Vec3::X, 0);
    for k in 0..3 {
        let c = s.push(Vec3::new(-1.0 + 0.3 * (k as f32 - 1.0), 1.0, 0.1 * k as f32), 0.05, r, Vec3::X, 0);
        s.push(Vec3::new(-1.0 + 0.5 * (k as f32 - 1.0), 1.8, 0.1 * k as f32), 0.02, c, Vec3::X, 0);
    }
    let r2 = s.push(Vec3::new(2.0, 0.0, 1.0), 0.3, NO_PARENT, Vec3::X, 0);
    s.push(Vec3::new(2.0, 0.0, 1.0), 0.2, r2, Vec3::X, 0); // a zero-length internode
    let text = to_lst(&s);
    let e = lst::parse("t.lst", &text, &LstOptions::default()).unwrap_err();
    assert!(e.message.contains("a second root"), "{}", e.message);
    let back =
        lst::parse("t.lst", &text, &LstOptions { gap: GapPolicy::NewRoot, ..Default::default() }).unwrap();
    assert_same_shape(&back, &s);
}

#[test]
fn lst_renumbers_skeletons_that_are_not_depth_first() {
    // Breadth-first numbering: 0 → 1, 2; 1 → 3; 2 → 4.
    let mut s = Skeleton::new();
    s.push(Vec3::ZERO, 1.0, NO_PARENT, Vec3::X, 0);
    s.push(Vec3::new(-1.0, 1.0, 0.0), 0.9, 0, Vec3::Z, 0);
    s.push(Vec3::new(1.0, 1.0, 0.0), 0.8, 0, Vec3::Z, 0);
    s.push(Vec3::new(-1.0, 2.0, 0.0), 0.7, 1, Vec3::Z, 0);
    s.push(Vec3::new(1.0, 2.0, 0.0), 0.6, 2, Vec3::Z, 0);
    let back = lst::parse("t.lst", &to_lst(&s), &LstOptions::default()).unwrap();
    assert_eq!(back.parent, vec![NO_PARENT, 0, 1, 0, 3]);
    assert_eq!(back.radius, vec![1.0, 0.9, 0.7, 0.8, 0.6]);
}

// ---------------------------------------------------------------------------------
// JSON

#[test]
fn json_round_trip_is_exact() {
    for s in [fork(), chain(), honda_tree(6), Skeleton::new()] {
        let text = to_json(&s);
        assert_eq!(from_json(&text).unwrap(), s);
        assert_eq!(to_json(&from_json(&text).unwrap()), text);
    }
}

/// Issue 26: LST → JSON → read keeps every cylinder's start radius exactly (JSON used to
/// drop them, so the hull and sweep meshers drew other cones from the JSON copy), and a
/// hand-written `start_radius` is read, `null` meaning none.
#[test]
fn lst_to_json_keeps_start_radii() {
    let text = "LST 0.1\nCylinder(0.5, 0.1, 4) MovRel3f(0, 4, 0)\n\
                SB() RotRel3f(0.7, 0, 0, 1) Cylinder(0.02, 0.01, 1) MovRel3f(0, 1, 0) EB()\n\
                Cylinder(0.3, 0.05, 2) MovRel3f(0, 2, 0)\n";
    let sk = lst::parse("t.lst", text, &LstOptions::default()).unwrap();
    assert!(sk.start_radius.iter().flatten().any(|&r| r == 0.3), "{:?}", sk.start_radius);
    let json = to_json(&sk);
    let back = from_json(&json).unwrap();
    assert_eq!(back.start_radius, sk.start_radius, "{json}");
    assert_eq!(back, sk);
    assert_eq!(to_lst(&back), to_lst(&sk));
    let hand = r#"{"format": "sylva-skeleton", "version": 1, "nodes": [
        {"position": [0, 0, 0], "radius": 0.3, "parent": null},
        {"position": [0, 1, 0], "radius": 0.2, "start_radius": 0.25, "parent": 0},
        {"position": [0, 2, 0], "radius": 0.1, "start_radius": null, "parent": 1}]}"#;
    let h = from_json(hand).unwrap();
    assert_eq!(h.start_radius, vec![None, Some(0.25), None]);
    let bad = hand.replace("0.25", "-1");
    assert!(matches!(from_json(&bad), Err(Error::Skeleton(_))), "a negative start radius is refused");
}

#[test]
fn hand_written_json_fills_defaults() {
    let sk = skeleton_from(&data("fork.skel.json"));
    assert_eq!(sk.parent, vec![NO_PARENT, 0, 1, 1]);
    assert_eq!(sk.order, vec![0, 0, 1, 0]);
    assert_eq!(sk.material, vec![0, 0, 2, 0]);
    assert_eq!(sk.up[3], Vec3::Z);
    // A missing `up` is perpendicular to the internode.
    let d = sk.position[2] - sk.position[1];
    assert!(sk.up[2].dot(d).abs() < 1e-6 && (sk.up[2].length() - 1.0).abs() < 1e-6);
}

fn skeleton_from(path: &Path) -> Skeleton {
    sylva::import::load_skeleton(path).unwrap()
}

#[test]
fn malformed_json_is_located() {
    let good = to_json(&fork());
    let cases: Vec<(String, &str)> = vec![
        (good.replacen("\"radius\"", "\"raduis\"", 1), "<json>:3:"),
        (good.replacen("\"parent\":null", "\"parent\":\"x\"", 1), "<json>:3:"),
        (good.replacen("]}", "]", 1), "<json>:"),
        (format!("{good} extra"), "<json>:"),
        (good.replacen("sylva-skeleton", "gltf", 1), "<json>: not a sylva skeleton"),
        (good.replacen("\"version\": 1", "\"version\": 2", 1), "<json>: unsupported skeleton version 2"),
    ];
    for (text, want) in cases {
        let e = from_json(&text).unwrap_err().to_string();
        assert!(e.starts_with(want), "{e}");
    }
    let e = from_json(&good.replacen("\"radius\":0.2", "\"radius\":-0.2", 1));
    assert!(matches!(e, Err(Error::Skeleton(_))), "{e:?}");
    let e = from_json(&good.replacen("\"parent\":0", "\"parent\":4", 1));
    assert!(matches!(e, Err(Error::Skeleton(_))), "{e:?}");
    let text = good.replacen("\"radius\":0.2,", "", 1);
    assert!(from_json(&text).unwrap_err().to_string().contains("nodes[0]: missing field `radius`"));
}

// ---------------------------------------------------------------------------------
// Files

fn temp(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("sylva-import-test-{}-{name}", std::process::id()))
}

#[test]
fn write_and_load_by_extension() {
    let s = honda_tree(5);
    for name in ["tree.skel.json", "tree.LST"] {
        let path = temp(name);
        skeleton::write(&s, &path).unwrap();
        let back = sylva::import::load_skeleton(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        if name.ends_with("json") {
            assert_eq!(back, s);
        } else {
            assert_same_shape(&back, &s);
        }
    }
    let e = skeleton::write(&s, &temp("tree.obj")).unwrap_err();
    assert!(matches!(e, Error::UnknownFormat { .. }), "{e}");
    let e = sylva::import::load_skeleton(Path::new("tree.ply")).unwrap_err();
    assert!(matches!(e, Error::UnknownFormat { .. }), "{e}");
    let e = sylva::import::load_skeleton(&temp("missing.lst")).unwrap_err();
    assert!(matches!(e, Error::Read { .. }), "{e}");
    let mut bad = s.clone();
    bad.radius[3] = -1.0;
    assert!(matches!(skeleton::write(&bad, &temp("bad.lst")), Err(Error::Skeleton(_))));
    assert!(!temp("bad.lst").exists());
    // Errors in a loaded file name it.
    let path = temp("broken.lst");
    std::fs::write(&path, "LST 0.1\nCylinder(1, 1)\n").unwrap();
    let e = sylva::import::load_skeleton(&path).unwrap_err().to_string();
    std::fs::remove_file(&path).unwrap();
    assert!(e.starts_with(&format!("{}:2:1: `Cylinder` takes 3", path.display())), "{e}");
}

#[test]
fn sample_lst_loads_from_disk() {
    let sk = skeleton_from(&data("yggdrasil-sample.lst"));
    assert_eq!(sk.len(), 8);
}

// ---------------------------------------------------------------------------------
// CPFG .str

#[test]
fn str_round_trip_of_a_derived_string_is_exact() {
    let (ls, s) = derive(HONDA, 7);
    let text = cpfg_str::format(&ls.symbols, &s);
    assert!(text.lines().all(|l| l.len() < 120), "cpfg-style lines");
    let mut symbols = ls.symbols.clone();
    let back = cpfg_str::parse_with_symbols("t.str", &text, &mut symbols).unwrap();
    assert_eq!(back, s);
    let bits = |m: &sylva::lsystem::ModuleString| m.params.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&back), bits(&s));
    assert_eq!(symbols.len(), ls.symbols.len());
    // With fresh symbols the names and numbers are the same, and so is the tree.
    let (fresh, back) = cpfg_str::parse("t.str", &text).unwrap();
    let names = |sy: &sylva::lsystem::Symbols, m: &sylva::lsystem::ModuleString| {
        m.syms.iter().map(|&k| sy.name(k).to_string()).collect::<Vec<_>>()
    };
    assert_eq!(names(&fresh, &back), names(&ls.symbols, &s));
    assert_eq!(back.params, s.params);
    let src = Source::new("t.str", "", &[]).unwrap();
    let a = interpret(&ls.symbols, &s, &TurtleOptions::default(), &ls.source).unwrap();
    let b = interpret(&fresh, &back, &TurtleOptions::default(), &src).unwrap();
    assert_eq!(a, b);
}

#[test]
fn str_file_from_disk_draws_a_bifurcating_tree() {
    let (symbols, s) = cpfg_str::parse("bifurcating.str", &read("bifurcating.str")).unwrap();
    let src = Source::new("bifurcating.str", "", &[]).unwrap();
    let sk = interpret(&symbols, &s, &TurtleOptions::default(), &src).unwrap();
    assert_eq!(sk.len(), 6);
    assert_eq!(sk.stats().tips, 3);
    assert!((sk.radius[1] - 0.5).abs() < 1e-6);
}

#[test]
fn malformed_str_is_located() {
    for (text, want) in [
        ("F(1)+(30)\nF(0.5", "t.str:2:2: unclosed `(` after module `F`"),
        ("F(1)\n\n   A(x)", "t.str:3:6: parameter `x` of module `A` is not a number"),
        ("F(inf)", "t.str:1:3: parameter `inf` of module `F` is not a finite number"),
        ("F(1)]\n)", "t.str:2:1: unexpected `)`"),
        ("+(1,2)", "t.str:1:1: turtle module `+` takes at most 1 parameter(s), got 2"),
        ("L-system string: 7 3\n", "t.str:1:1: unsupported: a binary cpfg string dump"),
    ] {
        let e = cpfg_str::parse("t.str", text).unwrap_err();
        assert!(e.message.starts_with(want), "{text:?}: {}", e.message);
    }
}

// ---------------------------------------------------------------------------------
// Property tests

/// A random tree of `n` nodes in depth-first order (children in index order): random
/// parents, renumbered by a depth-first walk.
fn random_tree(
    parents: &[usize],
    pos: &[[f32; 3]],
    radii: &[f32],
    ups: &[[f32; 3]],
    root: [f32; 3],
) -> Skeleton {
    let n = parents.len() + 1;
    let mut kids = vec![Vec::new(); n];
    for (i, &p) in parents.iter().enumerate() {
        kids[p % (i + 1)].push(i + 1);
    }
    let mut order = Vec::with_capacity(n);
    let mut stack = vec![0usize];
    while let Some(v) = stack.pop() {
        order.push(v);
        stack.extend(kids[v].iter().rev());
    }
    let mut new_index = vec![0u32; n];
    for (k, &v) in order.iter().enumerate() {
        new_index[v] = k as u32;
    }
    let mut s = Skeleton::new();
    let mut at = vec![Vec3::ZERO; n];
    for &v in &order {
        let (parent, p) = if v == 0 {
            (NO_PARENT, Vec3::from_array(root))
        } else {
            let old_parent = parents[v - 1] % v;
            (new_index[old_parent], at[old_parent] + Vec3::from_array(pos[v - 1]))
        };
        at[v] = p;
        let up = Vec3::from_array(ups[v % ups.len()]).normalize_or(Vec3::X);
        s.push(p, radii[v % radii.len()], parent, up, 0);
    }
    s
}

fn tree_strategy() -> impl Strategy<Value = Skeleton> {
    (1usize..40).prop_flat_map(|n| {
        (
            prop::collection::vec(0usize..1000, n),
            prop::collection::vec(prop::array::uniform3(-3.0f32..3.0), n),
            prop::collection::vec(0.0f32..2.0, n + 1),
            prop::collection::vec(prop::array::uniform3(-1.0f32..1.0), 1..8),
            prop::array::uniform3(-100.0f32..100.0),
        )
            .prop_map(|(parents, pos, radii, ups, root)| random_tree(&parents, &pos, &radii, &ups, root))
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn prop_json_round_trip_exact(mut s in tree_strategy(), materials in prop::collection::vec(0u32..5, 1..4)) {
        for (i, m) in s.material.iter_mut().enumerate() {
            *m = materials[i % materials.len()];
        }
        prop_assert_eq!(from_json(&to_json(&s)).unwrap(), s);
    }

    #[test]
    fn prop_lst_round_trip(s in tree_strategy()) {
        let text = to_lst(&s);
        let back = lst::parse("p.lst", &text, &LstOptions { gap: GapPolicy::Strict, ..Default::default() }).unwrap();
        prop_assert_eq!(&back.parent, &s.parent);
        prop_assert_eq!(&back.radius, &s.radius);
        for i in 0..s.len() {
            let (a, b) = (back.position[i].as_dvec3(), s.position[i].as_dvec3());
            prop_assert!((a - b).length() <= 1e-6 * b.length().max(1.0), "node {}: {} vs {}", i, a, b);
        }
    }

    #[test]
    fn prop_lst_reader_never_panics(body in "(SB\\(\\)|EB\\(\\)|MovRel3f|RotRel3f|Cylinder|[-+(),. 0-9eE\n\té∨])*") {
        let _ = lst::parse("p.lst", &format!("LST 0.1\n{body}"), &LstOptions::default());
        let _ = lst::parse("p.lst", &body, &LstOptions { gap: GapPolicy::NewRoot, ..Default::default() });
    }

    #[test]
    fn prop_str_reader_never_panics(text in "[-+(),. 0-9eE\n\tFf@?~GsTcA\\[\\]é∨]*") {
        if let Ok((symbols, s)) = cpfg_str::parse("p.str", &text) {
            let again = cpfg_str::format(&symbols, &s);
            let mut symbols2 = symbols.clone();
            prop_assert_eq!(cpfg_str::parse_with_symbols("p.str", &again, &mut symbols2).unwrap(), s);
        }
    }

    #[test]
    fn prop_json_reader_never_panics(cut in 0usize..400, junk in "[-{}\\[\\],:\"0-9a-z. ]{0,8}") {
        let text = to_json(&fork());
        let cut = cut.min(text.len());
        let _ = from_json(&format!("{}{junk}{}", &text[..cut], &text[cut..]));
    }
}
