//! cpfg contours (issue 26): the `.con` contour reader, the view file's `contour:` lines
//! and `@#(n)`, which turns generalized cylinders (`@Gs` … `@Ge`) into swept surfaces
//! with that cross-section. Uses a small model of its own
//! (`tests/data/cpfg/contour`) and the vlab corpus in `shared/corpus/cpfg` (those tests
//! are skipped with a message when the corpus is absent).

use glam::Vec3;
use std::path::{Path, PathBuf};
use sylva::lsystem::files::{self, contour};
use sylva::skeleton::{OrganKind, Skeleton, SweptSurface};

#[path = "common/cpfg_corpus.rs"]
mod cpfg_corpus;
#[path = "common/folders.rs"]
mod folders;
#[path = "common/recipes.rs"]
mod recipes;
use cpfg_corpus::corpus;

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cpfg/contour")
}

fn grow(l: &Path) -> sylva::Result<sylva::pipeline::Grown> {
    recipes::grow(l, &[])
}

/// The error growing `dir/plant.l` gives (it must fail).
fn fails(dir: &Path) -> sylva::Error {
    match grow(&dir.join("plant.l")) {
        Ok(_) => panic!("{} grew", dir.display()),
        Err(e) => e,
    }
}

fn swept(sk: &Skeleton) -> Vec<&SweptSurface> {
    sk.organs
        .iter()
        .filter_map(|o| match &o.kind {
            OrganKind::Swept(s) => Some(s),
            _ => None,
        })
        .collect()
}

/// A fresh folder under the target's temporary directory with the given files.
fn folder(name: &str, files: &[(&str, &str)]) -> PathBuf {
    folders::with_files("cpfg-contours", name, files)
}

const FLAT: &str = "cver 1 3\nname: flat\npoints: 2 6\ntype: or\nsamples: 8\n-1 0 0 3\n1 0 0 3\n";
const VIEW: &str = "line style: cylinder\ncontour sides: 4\ncontour: 1 flat.con\n";

#[test]
fn corpus_contour_files_read_as_documented() {
    let Some(dir) = corpus() else { return };
    let read = |p: &str| {
        let path = dir.join(p);
        contour::parse(&path.display().to_string(), &std::fs::read_to_string(&path).unwrap()).unwrap()
    };
    let lily = read("11-CPFG__03-inverse-modeling__01-herb-lily/leaf.con");
    assert_eq!((lily.distinct, lily.control.len(), lily.closed, lily.end_point), (11, 15, false, false));
    assert_eq!((lily.name.as_deref(), lily.samples, lily.segments()), (Some("leaf.con"), Some(8), 12));
    // The multiplicity-3 end points are interpolated: the sampled curve starts and ends
    // exactly on them.
    let s = lily.sample(16);
    assert_eq!(s.len(), 17);
    assert!((s[0] - glam::DVec2::new(-8.517361, -0.402775)).length() < 1e-9, "{}", s[0]);
    assert!((s[16] - glam::DVec2::new(9.678128, -0.714061)).length() < 1e-9, "{}", s[16]);
    // Equal arc-length steps: no chord is longer than a sixteenth of the length, and
    // chords are that long where the curve is nearly straight.
    let step = lily.length() / 16.0;
    let mut chords: Vec<f64> = s.windows(2).map(|w| w[0].distance(w[1])).collect();
    assert!(chords.iter().all(|d| *d <= step * 1.001), "{chords:?} vs {step}");
    chords.sort_by(f64::total_cmp);
    assert!((chords[8] - step).abs() < 0.01 * step, "{chords:?} vs {step}");

    let stripe = read("10-manuals__11-CPFG__Tropisms/stripe.con");
    assert_eq!((stripe.distinct, stripe.control.len(), stripe.closed), (4, 8, false));
    let brush = read("11-CPFG__03-inverse-modeling__04-paintbrush/leaf.con");
    assert_eq!((brush.distinct, brush.control.len(), brush.closed), (5, 10, false));
}

#[test]
fn the_view_file_loads_its_contours() {
    let folder = files::load_folder(&data().join("plant.l")).unwrap();
    assert_eq!(folder.contours.len(), 1);
    assert_eq!(folder.contours[0].0, 1);
    assert_eq!(folder.contours[0].1.control.len(), 6);
    assert!(!folder.ignored.iter().any(|n| n.contains("contour")), "{:?}", folder.ignored);
}

#[test]
fn the_test_model_grows_one_swept_strap() {
    let g = grow(&data().join("plant.l")).unwrap();
    let sk = &g.skeleton;
    // The generalized cylinder is a surface, not an axis of the skeleton.
    assert_eq!(sk.stats().segments, 0, "{:?}", sk.position);
    let s = swept(sk);
    assert_eq!(s.len(), 1);
    let s = s[0];
    assert!(!s.closed);
    // Five control points: @Gs, three @Gc(2) (two rings each) and @Ge(1).
    assert_eq!(s.rings.len(), 1 + 3 * 2 + 1);
    assert!(s.rings.iter().all(|r| r.len() == 5), "contour sides 4: five points per open ring");
    // Ring centres climb the heading (+Y) in half steps, then one step to the end.
    let ys: Vec<f32> = s.rings.iter().map(|r| r.iter().map(|p| p.y).sum::<f32>() / 5.0).collect();
    for (y, want) in ys.iter().zip([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0]) {
        assert!((y - want).abs() < 1e-5, "{ys:?}");
    }
    // Width 0.2 (radius 0.1) times the contour's x from −1 to 1, along the turtle's up
    // (+X for L-systems); the last ring has width 0.1.
    let span = |r: &[Vec3]| r[0].distance(r[4]);
    for r in &s.rings[..7] {
        assert!((span(r) - 0.2).abs() < 1e-5, "{}", span(r));
        assert!((r[0] - Vec3::new(-0.1, r[0].y, 0.0)).length() < 1e-5, "{:?}", r[0]);
    }
    assert!((span(&s.rings[7]) - 0.1).abs() < 1e-5);
    // The organ mesh: a strip of 7 × 4 quads, two triangles each, with UVs and normals.
    let leaves = g.model.parts.iter().find(|p| p.mesh.face_count() > 0 && p.name.contains("lea"));
    let mesh = &leaves.expect("a leaves part").mesh;
    assert_eq!(mesh.face_count(), 7 * 4 * 2);
    let normals = mesh.normals.as_ref().unwrap();
    assert!(normals.values.iter().all(|n| (n.length() - 1.0).abs() < 1e-4 && n.x.abs() < 1e-4));
    let uvs = mesh.uvs.as_ref().unwrap();
    assert!(uvs.values.iter().all(|uv| (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y)));
    assert!(uvs.values.iter().any(|uv| uv.y == 1.0) && uvs.values.iter().any(|uv| uv.x == 1.0));
}

#[test]
fn the_herb_lily_leaf_is_a_flat_swept_leaf() {
    let Some(dir) = corpus() else { return };
    let g = grow(&dir.join("11-CPFG__03-inverse-modeling__01-herb-lily/plant.l")).unwrap();
    let s = swept(&g.skeleton);
    assert_eq!(s.len(), 1, "one leaf");
    let leaf = s[0];
    assert!(!leaf.closed);
    // `@Gs`, 49 `@Gc(1)` and `@Ge(1)`: one ring per control point; polygonization
    // level 3 is 16 contour sides, so 17 points per ring.
    assert!((45..=55).contains(&leaf.rings.len()), "{}", leaf.rings.len());
    assert!(leaf.rings.iter().all(|r| r.len() == 17));
    // The leaf is one unit long (f(dx) steps from x = 0 to 1).
    let centre = |r: &[Vec3]| r.iter().copied().sum::<Vec3>() / r.len() as f32;
    let length: f32 = leaf.rings.windows(2).map(|w| centre(&w[0]).distance(centre(&w[1]))).sum();
    assert!((length - 1.0).abs() < 0.05, "{length}");
    // Its widest ring is about 0.2 wide (radius 0.05·WIDTH/2 times the contour's 23
    // units), and flat: the contour's depth is a small fraction of its width.
    let widest =
        leaf.rings.iter().max_by(|a, b| a[0].distance(a[16]).total_cmp(&b[0].distance(b[16]))).unwrap();
    let width = widest[0].distance(widest[16]);
    assert!((0.1..0.4).contains(&width), "{width}");
    let chord = (widest[16] - widest[0]).normalize();
    let depth = widest
        .iter()
        .map(|p| {
            let d = *p - widest[0];
            (d - chord * d.dot(chord)).length()
        })
        .fold(0.0f32, f32::max);
    assert!(depth < 0.25 * width, "depth {depth} of width {width}");
    // Narrow at the tip: the last ring is much narrower than the widest.
    let tip = leaf.rings.last().unwrap();
    assert!(tip[0].distance(tip[16]) < 0.3 * width);
}

#[test]
fn the_circle_keeps_tracing_skeleton_tubes() {
    let dir = folder(
        "circle",
        &[
            ("plant.l", "Lsystem: 1\nAxiom: @#(0) !(0.2) @Gs f(1) @Gc(1) f(1) @Ge(1)\nendlsystem\n"),
            ("plant.v", VIEW),
            ("flat.con", FLAT),
        ],
    );
    let g = grow(&dir.join("plant.l")).unwrap();
    assert!(swept(&g.skeleton).is_empty());
    assert_eq!(g.skeleton.stats().segments, 2);
    assert!((g.skeleton.radius[1] - 0.1).abs() < 1e-6, "`@#(0)` does not set the width");
}

#[test]
fn errors_name_the_contour_and_the_file() {
    let err = |dir: &Path| fails(dir).to_string();
    let sweep = "Lsystem: 1\nAxiom: @#(1) @Gs f(1) @Ge(1)\nendlsystem\n";

    // `@#(n)` for a contour the view file does not declare.
    let dir = folder("undeclared", &[("plant.l", sweep), ("plant.v", "contour sides: 4\n")]);
    let e = err(&dir);
    assert!(e.contains("selects contour 1") && e.contains("declared: none"), "{e}");

    // A missing contour file: the folder loads (it is noted), selecting it fails.
    let dir = folder("missing", &[("plant.l", sweep), ("plant.v", VIEW)]);
    let loaded = files::load_folder(&dir.join("plant.l")).unwrap();
    assert_eq!(loaded.contour_errors.len(), 1);
    let e = err(&dir);
    assert!(e.contains("selects contour 1") && e.contains("flat.con") && e.contains("does not exist"), "{e}");
    assert!(e.contains("plant.v"), "{e}");

    // A malformed contour file: its name, line and why.
    let bad = FLAT.replace("\n1 0 0 3", "\n1 zero 0 3");
    let dir = folder("bad", &[("plant.l", sweep), ("plant.v", VIEW), ("flat.con", &bad)]);
    let e = err(&dir);
    assert!(e.contains("flat.con:7:") && e.contains("four finite numbers"), "{e}");

    // An open contour and the (closed) circle in one generalized cylinder.
    let mixed = "Lsystem: 1\nAxiom: @#(1) @Gs f(1) @#(0) @Ge(1)\nendlsystem\n";
    let dir = folder("mixed", &[("plant.l", mixed), ("plant.v", VIEW), ("flat.con", FLAT)]);
    let e = fails(&dir);
    assert!(
        matches!(&e, sylva::Error::Lsystem(l) if l.kind == sylva::lsystem::ErrorKind::Unsupported),
        "{e}"
    );
    assert!(e.to_string().contains("unsupported:") && e.to_string().contains("mixes"), "{e}");

    // Switching a circle generalized cylinder to a contour half way.
    let switch = "Lsystem: 1\nAxiom: @Gs f(1) @#(1) @Gc(1) f(1) @Ge(1)\nendlsystem\n";
    let dir = folder("switch", &[("plant.l", switch), ("plant.v", VIEW), ("flat.con", FLAT)]);
    let e = err(&dir);
    assert!(e.contains("unsupported:") && e.contains("started with the circle"), "{e}");
}

#[test]
fn a_closed_contour_has_outward_normals() {
    let square = "cver 1 2\nname: sq\npoints: 4 4\ntype: cr\n1 0 0 1\n0 1 0 1\n-1 0 0 1\n0 -1 0 1\n";
    // The same square listed clockwise: the normals must still point outward.
    let cw = "cver 1 2\nname: sq\npoints: 4 4\ntype: cr\n1 0 0 1\n0 -1 0 1\n-1 0 0 1\n0 1 0 1\n";
    for (name, con) in [("ccw", square), ("cw", cw)] {
        let dir = folder(
            name,
            &[
                ("plant.l", "Lsystem: 1\nAxiom: @#(1) !(2) @Gs f(1) @Gc(3) f(1) @Ge(1)\nendlsystem\n"),
                ("plant.v", "contour sides: 8\ncontour: 1 sq.con\n"),
                ("sq.con", con),
            ],
        );
        let g = grow(&dir.join("plant.l")).unwrap();
        let s = swept(&g.skeleton);
        assert_eq!(s.len(), 1);
        assert!(s[0].closed && s[0].rings.len() == 5 && s[0].rings[0].len() == 8);
        let mesh = &g.model.parts.iter().find(|p| p.mesh.face_count() == 4 * 8 * 2).expect("the tube").mesh;
        let normals = mesh.normals.as_ref().unwrap();
        let corners = &mesh.face_indices;
        assert_eq!(corners.len(), normals.indices.len());
        for (k, &v) in corners.iter().enumerate() {
            let p = mesh.positions[v as usize];
            let n = normals.values[normals.indices[k] as usize];
            let out = Vec3::new(p.x, 0.0, p.z);
            assert!(n.dot(out) > 0.0, "{name}: normal {n} at {p}");
        }
    }
}

#[test]
fn the_other_corpus_contour_models_grow_swept_organs() {
    let Some(dir) = corpus() else { return };
    // Tropisms: one stripe swept along the whole axis (@Gs … @Gc(10) … @Ge(10)).
    let g = grow(&dir.join("10-manuals__11-CPFG__Tropisms/lsystem.l")).unwrap();
    let s = swept(&g.skeleton);
    assert_eq!(s.len(), 1);
    assert!(s[0].rings.len() > 100 && s[0].rings.iter().all(|r| r.len() == 17), "{}", s[0].rings.len());
    // Paintbrush: every leaf is a swept leaf with the 8 sides of `contour sides: 8`.
    let g = grow(&dir.join("11-CPFG__03-inverse-modeling__04-paintbrush/plant.l")).unwrap();
    let s = swept(&g.skeleton);
    assert!(s.len() > 10, "{}", s.len());
    assert!(s.iter().all(|w| !w.closed && w.rings.iter().all(|r| r.len() == 9)));
}

#[test]
fn swept_organs_round_trip_through_the_json_skeleton() {
    use sylva::export::skeleton::{from_json, to_json};
    let g = grow(&data().join("plant.l")).unwrap();
    let text = to_json(&g.skeleton);
    assert!(text.contains("\"kind\":\"swept\"") && text.contains("\"closed\":false"), "{text}");
    let back = from_json(&text).unwrap();
    assert_eq!(back.organs, g.skeleton.organs);
    // Rings of different lengths, or `rings` on another kind, are errors.
    let uneven = text.replacen("[[-0.1,", "[[-0.1,0.0,0.0],[-0.1,", 1);
    assert_ne!(uneven, text);
    let e = from_json(&uneven).unwrap_err().to_string();
    assert!(e.contains("same number of points"), "{e}");
    let wrong = text.replace("\"kind\":\"swept\"", "\"kind\":\"disc\"");
    let e = from_json(&wrong).unwrap_err().to_string();
    assert!(e.contains("swept organ only"), "{e}");
}
