//! The readers of a cpfg model folder's sibling files (issue 3): view files,
//! functions, surfaces, colour maps and materials, on synthetic input and on the vlab
//! corpus in `shared/corpus/cpfg` (skipped with a message when that folder is absent).

use std::path::{Path, PathBuf};
use sylva::lsystem::files::{self, colormap, func, surface, view};

#[path = "common/cpfg_corpus.rs"]
mod cpfg_corpus;
use cpfg_corpus::corpus;

/// Every file of the corpus with extension `ext`, sorted.
fn corpus_files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for model in std::fs::read_dir(dir).unwrap().flatten() {
        if let Ok(rd) = std::fs::read_dir(model.path()) {
            for f in rd.flatten() {
                let p = f.path();
                if p.extension().map(|e| e == ext).unwrap_or(false) {
                    out.push(p);
                }
            }
        }
    }
    out.sort();
    out
}

/// [`corpus_files`] with extension `ext`, which must be `n` files.
fn corpus_files_n(dir: &Path, ext: &str, n: usize) -> Vec<PathBuf> {
    let files = corpus_files(dir, ext);
    assert_eq!(files.len(), n, "corpus files `.{ext}`");
    files
}

fn text(p: &Path) -> String {
    String::from_utf8_lossy(&std::fs::read(p).unwrap()).into_owned()
}

fn name(p: &Path) -> String {
    p.display().to_string()
}

#[test]
fn view_file_keys_tropisms_and_surfaces() {
    let v = view::parse(
        "plant.v",
        "angle factor: 12\ninitial color: 1\ncolor increment: 2\ninitial line width: 0.5 /* units */\n\
         line width increment: 0.1\nline style: cylinder\ncontour sides: 12\ntwist of cylinders: on\n\
         tropism: T: 0,1,0 E: 0.2\ntorque: T: 0.0 0.0 1.0\nsurface: l leaf.s 1 8 4\n\
         function: internode.func 100\nviewpoint: 0,0,1\nrender mode: shaded\n",
    )
    .unwrap();
    assert!((v.angle_increment - 30.0).abs() < 1e-12);
    assert_eq!((v.initial_color, v.color_increment), (1, 2));
    assert_eq!((v.initial_line_width, v.width_increment), (0.5, 0.1));
    assert_eq!(v.line_style, view::LineStyle::Cylinder);
    assert_eq!(v.contour_sides, 12);
    assert!(v.twist_of_cylinders);
    assert_eq!(v.tropisms.len(), 2);
    assert_eq!(v.tropisms[0].elasticity, 0.2);
    assert_eq!(v.tropisms[1].kind, view::MovementKind::Torque);
    assert_eq!(v.surfaces[0].file, "leaf.s");
    assert_eq!(v.functions[0].file, "internode.func");
    assert_eq!(v.ignored.len(), 2);
    let e = view::parse("bad.v", "contour sides: 8\ninitial elasticity: lots\n").unwrap_err();
    assert!(e.message.starts_with("bad.v:2:21:"), "{}", e.message);
}

#[test]
fn linear_function_and_end_points() {
    let f = func::parse(
        "lin.func",
        "fver 1 1\nname: lin\nsamples: 10\nflip: off\npoints: 4\n0 0.5 1\n0.3333333333333333 1.0 1\n0.6666666666666666 1.5 1\n1 2 1\n",
    )
    .unwrap();
    // cpfg's values: its bisection stops within 0.001 of x (so within 1.5e-3 here, the
    // slope being 1.5), the table interpolates those; the exact curve is exact up to
    // the f32 coordinates.
    for i in 0..=50 {
        let x = i as f64 / 50.0;
        assert!((f.eval(x) - (0.5 + 1.5 * x)).abs() <= 1.5e-3 + 1e-7, "f({x}) = {}", f.eval(x));
        assert!((f.eval_bisected(x) - (0.5 + 1.5 * x)).abs() <= 1.5e-3 + 1e-7);
        assert!((f.eval_exact(x) - (0.5 + 1.5 * x)).abs() < 1e-6);
    }
    assert_eq!(f.eval(-1.0), f.eval(0.0));
    assert!((f.eval(-1.0) - 0.5).abs() <= 1.5e-3);
    assert_eq!(f.eval(2.0), f.eval(1.0));
    assert!((f.eval(2.0) - 2.0).abs() <= 1.5e-3);
}

#[test]
fn flat_patch_is_flat_and_interpolates_its_corners() {
    let mut s = String::from(
        "0 2 0 2 0 0\nCONTACT POINT X: 1 Y: 0 Z: 0\nEND POINT X: 1 Y: 2 Z: 0\nHEADING X: 0 Y: 1 Z: 0\n\
         UP X: 0 Y: 0 Z: 1\nSIZE: 2\np\nTOP COLOR: 0 DIFFUSE: 0 BOTTOM COLOR: 0 DIFFUSE: 0\n\
         AL: ~ A: ~ AR: ~\nL: ~ R: ~\nBL: ~ B: ~ BR: ~\n",
    );
    for i in 0..4 {
        for j in 0..4 {
            // A curved parametrization of a flat square: only the corners are on the grid.
            let x = j as f64 * 2.0 / 3.0 + if (1..3).contains(&j) && i == 1 { 0.2 } else { 0.0 };
            s += &format!("{x} {} 0 ", i as f64 * 2.0 / 3.0);
        }
    }
    let surf = surface::parse("sq.s", &s).unwrap();
    let m = surf.tessellate(6);
    m.validate().unwrap();
    assert_eq!(m.face_count(), 2 * 36);
    assert!(m.positions.iter().all(|p| p.z.abs() < 1e-6));
    // Contact (1, 0, 0) is the origin; SIZE 2 becomes 1; x maps to H × U = +X.
    for c in [[-0.5, 0.0], [0.5, 0.0], [-0.5, 1.0], [0.5, 1.0]] {
        assert!(m.positions.iter().any(|p| (p.x - c[0]).abs() < 1e-6 && (p.y - c[1]).abs() < 1e-6), "{c:?}");
    }
    let uvs = m.uvs.as_ref().unwrap();
    assert!(uvs.values.iter().all(|uv| (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y)));
}

#[test]
fn colour_map_and_materials() {
    let mut map = vec![0u8; 768];
    map[765..].copy_from_slice(&[255, 128, 0]);
    let m = colormap::parse(&map).unwrap();
    assert_eq!(m.colors.len(), 256);
    assert_eq!(m.color(255), Some([1.0, 128.0 / 255.0, 0.0]));
    let mat = colormap::parse_materials(&[7, 0, 0, 0, 0, 255, 255, 255, 0, 0, 0, 0, 0, 0, 0]).unwrap();
    assert_eq!(mat.color(7), Some([1.0, 1.0, 1.0]));
}

#[test]
fn corpus_view_files() {
    let Some(dir) = corpus() else { return };
    let mut ok = 0;
    let mut failed = Vec::new();
    for p in corpus_files(&dir, "v") {
        match view::parse(&name(&p), &text(&p)) {
            Ok(_) => ok += 1,
            Err(e) => failed.push(e.message),
        }
    }
    // The only failure is the exercise whose blanks are still `?`.
    assert_eq!(failed.len(), 1, "{failed:?}");
    assert!(failed[0].contains("snowflake-exercise/fractal.v:1:18:"), "{}", failed[0]);
    assert_eq!(ok, 53);

    let tropisms = dir.join("10-manuals__11-CPFG__Tropisms/view.v");
    let v = view::parse(&name(&tropisms), &text(&tropisms)).unwrap();
    assert_eq!(v.tropisms.len(), 3);
    assert_eq!(v.tropisms[1].angle, 90.0);
    assert_eq!(v.tropisms[2].kind, view::MovementKind::Torque);
    assert_eq!(v.contours[0].file, "stripe.con");
    assert!(v.twist_of_cylinders);

    let birch = dir.join("10-manuals__11-CPFG__WeepingBirch/fractal.v");
    let v = view::parse(&name(&birch), &text(&birch)).unwrap();
    let old = v.old_tropism.unwrap();
    assert_eq!((old.elasticity, old.elasticity_increment), (0.4, -0.06));
    assert!((v.angle_increment - 30.0).abs() < 1e-12);
}

#[test]
fn corpus_functions() {
    let Some(dir) = corpus() else { return };
    let mut count = 0;
    let mut check = |f: &func::Function| {
        let first = f.points[0];
        let last = f.points[f.points.len() - 1];
        // Near the end points: cpfg's bisection stops within 0.001 of x.
        let scale = f.points.iter().map(|p| p[1].abs()).fold(1.0, f64::max);
        assert!((f.eval(0.0) - first[1]).abs() < 0.01 * scale, "{} vs {}", f.eval(0.0), first[1]);
        assert!((f.eval(1.0) - last[1]).abs() < 0.01 * scale, "{} vs {}", f.eval(1.0), last[1]);
        assert!((f.eval_exact(0.0) - first[1]).abs() < 1e-9);
        assert!((f.eval_exact(1.0) - last[1]).abs() < 1e-9);
        for i in 0..=100 {
            assert!(f.eval(i as f64 / 100.0).is_finite());
        }
        count += 1;
    };
    for p in corpus_files(&dir, "func") {
        check(&func::parse(&name(&p), &text(&p)).unwrap());
    }
    for p in corpus_files(&dir, "fset") {
        let set = func::parse_set(&name(&p), &text(&p)).unwrap();
        assert_eq!(set.functions.len(), 5);
        set.functions.iter().for_each(|(_, f)| check(f));
    }
    assert_eq!(count, 40 + 5);
}

#[test]
fn corpus_surfaces() {
    let Some(dir) = corpus() else { return };
    for p in corpus_files_n(&dir, "s", 11) {
        let s = surface::parse(&name(&p), &text(&p)).unwrap();
        assert!(s.neighbour_problems().is_empty(), "{}: {:?}", p.display(), s.neighbour_problems());
        for n in [1, 3, 8] {
            let m = s.tessellate(n);
            m.validate().unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert_eq!(m.face_count(), 2 * (n * n) as usize * s.patches.len());
            let normals = m.normals.as_ref().unwrap();
            assert!(normals.values.iter().all(|v| (v.length() - 1.0).abs() < 1e-4));
        }
        // The corner control points are on the surface.
        let m = s.tessellate(4);
        for k in 0..s.patches.len() {
            let c = s.local_control(k).unwrap();
            for corner in [c[0][0], c[0][3], c[3][0], c[3][3]] {
                let hit = m.positions.iter().any(|p| {
                    (p.x as f64 - corner[0]).abs() < 1e-5
                        && (p.y as f64 - corner[1]).abs() < 1e-5
                        && (p.z as f64 - corner[2]).abs() < 1e-5
                });
                assert!(hit, "{}: corner {corner:?} of patch {k}", p.display());
            }
        }
    }
}

#[test]
fn corpus_colour_maps_and_materials() {
    let Some(dir) = corpus() else { return };
    for p in corpus_files_n(&dir, "map", 33) {
        let m = colormap::parse(&std::fs::read(&p).unwrap()).unwrap();
        assert_eq!(m.colors.len(), 256, "{}", p.display());
    }
    for p in corpus_files_n(&dir, "mat", 17) {
        let m = colormap::parse_materials(&std::fs::read(&p).unwrap()).unwrap();
        assert!(m.materials.as_ref().unwrap().iter().any(|m| m.defined), "{}", p.display());
    }
    // Lilac's material 1 is the lilac flower colour.
    let lilac = colormap::parse_materials(
        &std::fs::read(dir.join("10-manuals__11-CPFG__Lilac/materials.mat")).unwrap(),
    )
    .unwrap();
    assert_eq!(lilac.color(1), Some([228.0 / 255.0, 197.0 / 255.0, 1.0]));
}

#[test]
fn corpus_model_folders() {
    let Some(dir) = corpus() else { return };
    let mut loaded = 0;
    for model in std::fs::read_dir(&dir).unwrap().flatten() {
        let spec = model.path().join("specifications");
        let Ok(spec) = std::fs::read_to_string(spec) else { continue };
        // Every L-system that a `cpfg` command line of the folder names.
        let mut lsystems: Vec<String> = spec
            .lines()
            .filter(|l| l.split_whitespace().any(|w| w == "cpfg"))
            .filter_map(|l| l.split_whitespace().find(|w| w.ends_with(".l")).map(str::to_string))
            .collect();
        lsystems.dedup();
        for l in lsystems {
            let path = model.path().join(&l);
            match files::load_folder(&path) {
                Ok(folder) => {
                    assert!(folder.view.is_some(), "{}", path.display());
                    loaded += 1;
                }
                Err(e) => {
                    assert!(
                        path.display().to_string().contains("snowflake-exercise"),
                        "{}: {e}",
                        path.display()
                    )
                }
            }
        }
    }
    assert_eq!(loaded, 52);

    let lilac = files::load_folder(&dir.join("10-manuals__11-CPFG__Lilac/plant.l")).unwrap();
    let names: Vec<&str> = lilac.functions.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["br_ang", "elas"]);
    let ids: Vec<&str> = lilac.surfaces.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(ids, ["p", "c"]);
    assert!(lilac.colormap.as_ref().unwrap().materials.is_some());
    assert!(lilac.ignored.iter().any(|n| n.contains("plant.a")));

    let sedge = files::load_folder(&dir.join("10-manuals__11-CPFG__Sedge/female.l")).unwrap();
    let ids: Vec<&str> = sedge.surfaces.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(ids, ["f", "n", "c", "L"]);
    assert!(sedge.ignored.iter().any(|n| n.contains("bract.s")), "{:?}", sedge.ignored);
    assert!(sedge.ignored.iter().any(|n| n.contains("sedge.map2")), "{:?}", sedge.ignored);

    let lily = files::load_folder(&dir.join("11-CPFG__03-inverse-modeling__01-herb-lily/plant.l")).unwrap();
    let names: Vec<&str> = lily.functions.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["WIDTH", "TURN", "BEND", "TWIST", "ROTATE"]);

    let ridley = files::load_folder(&dir.join("10-manuals__11-CPFG__Ridley/spiral.l")).unwrap();
    assert_eq!(ridley.functions.len(), 1);
    assert!(ridley.colormap.is_some());
}

#[test]
fn truncated_and_garbled_corpus_files_do_not_panic() {
    let Some(dir) = corpus() else { return };
    let mut texts = Vec::new();
    for ext in ["v", "func", "fset", "s"] {
        for p in corpus_files(&dir, ext) {
            texts.push(text(&p));
        }
    }
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for t in &texts {
        let mut variants: Vec<String> = (0..8)
            .map(|k| {
                let mut cut = t.len() * k / 8;
                while !t.is_char_boundary(cut) {
                    cut -= 1;
                }
                t[..cut].to_string()
            })
            .collect();
        // Replace a few characters by digits, colons, minus signs and letters.
        let mut bytes = t.clone().into_bytes();
        for _ in 0..6 {
            if bytes.is_empty() {
                break;
            }
            let i = (next() as usize) % bytes.len();
            if bytes[i].is_ascii() {
                bytes[i] = b"9:-x ~\n0e"[(next() % 9) as usize];
            }
        }
        variants.push(String::from_utf8_lossy(&bytes).into_owned());
        for v in &variants {
            let _ = view::parse("x.v", v);
            let _ = func::parse("x.func", v);
            let _ = func::parse_set("x.fset", v);
            if let Ok(s) = surface::parse("x.s", v) {
                s.tessellate(2).validate().unwrap();
            }
            let _ = colormap::parse(v.as_bytes());
            let _ = colormap::parse_materials(v.as_bytes());
        }
    }
}
