//! The environmental programs of issue 26 (`clover`, `ecosystem`, `chiba`, `obcheck`,
//! and `honda81` configured from its spec file), each on a small cpfg model folder of
//! `tests/data/cpfg/<program>/` (an `.l`, `specifications` naming `-e plant.e`, the
//! `.e`, its spec file and data files), loaded as a user would: `sylva::recipe::load`
//! and `sylva::pipeline::grow`. docs/environments.md defines the programs.

#[path = "common/folders.rs"]
mod folders;
#[path = "common/recipes.rs"]
mod recipes;

use recipes::{derive, grow};
use std::path::{Path, PathBuf};
use sylva::lsystem::ErrorKind;

fn data(program: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/cpfg").join(program)
}

/// A copy of the model folder `program` in a fresh temp folder, to break.
fn copy(program: &str, tag: &str) -> PathBuf {
    let dir = folders::tempdir("env", tag);
    for e in std::fs::read_dir(data(program)).unwrap() {
        let p = e.unwrap().path();
        std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
    }
    dir
}

/// The top-level branches `[…]` of a derived string.
fn branches(text: &str) -> Vec<String> {
    let (mut out, mut depth, mut cur) = (Vec::new(), 0, String::new());
    for c in text.chars() {
        match c {
            '[' => {
                depth += 1;
                if depth == 1 {
                    cur.clear();
                    continue;
                }
            }
            ']' => {
                depth -= 1;
                if depth == 0 {
                    out.push(cur.clone());
                    continue;
                }
            }
            _ => {}
        }
        if depth >= 1 {
            cur.push(c);
        }
    }
    out
}

/// The parameter lists of every `name(…)` in `text`.
fn params(text: &str, name: &str) -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find(&format!("{name}(")) {
        let after = &rest[at + name.len() + 1..];
        let end = after.find(')').unwrap();
        out.push(after[..end].split(',').map(|v| v.trim().parse::<f64>().unwrap()).collect());
        rest = &after[end..];
    }
    out
}

fn text(d: &sylva::pipeline::Derived) -> String {
    d.lsystem.format(&d.string)
}

/// The top-level branches of the L-system `file` with `kv`, derived.
fn derived_branches(file: &Path, kv: &[&str]) -> Vec<String> {
    branches(&text(&derive(file, kv).unwrap()))
}

#[test]
fn clover_grows_by_the_light_of_its_image_and_leaves() {
    let file = data("clover").join("plant.l");
    let b = derived_branches(&file, &[]);
    assert_eq!(b.len(), 3);
    assert!(!b[2].contains("?E"), "the leaf's ?E(1,la) is gone after step 1: {b:?}");
    let length = |s: &str| params(s, "F").iter().map(|p| p[0]).sum::<f64>();
    let (dark, bright) = (length(&b[0]), length(&b[1]));
    // The dark half (0.2) grows 0.2 a step; the bright half 1 a step until its apex
    // reaches the registered leaf (radius 2.2 around y = 6.5), then 0.1 (transmittance).
    assert!((dark - 2.0).abs() < 1e-4, "dark stolon {dark}");
    assert!((bright - 4.6).abs() < 1e-4, "bright stolon {bright}");
    let g = grow(&file, &[]).unwrap();
    assert!(g.report.skeleton.segments > 0);
    // The same model under a PNG of the opposite light: the left stolon is now the long one.
    let b = derived_branches(&file, &["generator.environment.image=\"light.png\""]);
    assert!((length(&b[0]) - 10.0).abs() < 1e-4 && (length(&b[1]) - 2.0).abs() < 1e-4, "{b:?}");
    // Without the image: uniform full light, and a warning saying so.
    let d = derive(&file, &["generator.environment.image=\"nowhere.rgb\""]).unwrap();
    assert!(
        d.warnings.iter().any(|w| w.contains("nowhere.rgb") && w.contains("uniform")),
        "{:?}",
        d.warnings
    );
    let b = branches(&text(&d));
    assert!((length(&b[0]) - 10.0).abs() < 1e-4, "{b:?}");
    // An opaque leaf stops the bright stolon under it.
    let b = derived_branches(&file, &["generator.environment.transmittance=0"]);
    assert!((length(&b[1]) - 4.0).abs() < 1e-4, "{b:?}");
}

#[test]
fn ecosystem_kills_the_smaller_of_overlapping_plants() {
    let file = data("ecosystem").join("plant.l");
    let d = derive(&file, &[]).unwrap();
    let t = text(&d);
    let b = branches(&t);
    // The plant at x = 3 met the one at x = 0 in step 2 (radii 2 and 1.5, 3 apart) and died.
    assert_eq!(b.len(), 3);
    assert!(b[1].starts_with("@M(3") && !b[1].contains("P("), "the dominated plant is removed: {b:?}");
    assert_eq!(params(&b[0], "P"), vec![vec![3.0]]);
    assert_eq!(params(&b[2], "P"), vec![vec![2.5]]);
    let g = grow(&file, &[]).unwrap();
    assert_eq!(g.report.skeleton.roots, 2, "two plants are drawn");

    // Self-thinning on a random field: survivors never overlap, and every dominated
    // plant overlaps a larger one (larger radius, or equal and earlier).
    // The field was laid out with sylva's generator (a `.l` file now gets cpfg's by
    // default, issue 46 item 9, which lays out another field).
    let d = derive(data("ecosystem").join("field.l"), &["generator.random=\"sylva\""]).unwrap();
    let plants: Vec<(f64, f64, f64, f64)> = branches(&text(&d))
        .iter()
        .filter_map(|b| {
            let m = params(b, "@M").into_iter().next()?;
            let e = params(b, "?E").into_iter().next()?;
            Some((m[0], m[2], e[0], e[1]))
        })
        .collect();
    // The printed string rounds the numbers: compare with a small tolerance.
    let dist = |a: &(f64, f64, f64, f64), b: &(f64, f64, f64, f64)| {
        ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
    };
    let overlap = |a: &(f64, f64, f64, f64), b: &(f64, f64, f64, f64)| dist(a, b) < a.2 + b.2 - 1e-4;
    let alive: Vec<_> = plants.iter().filter(|p| p.3 == 1.0).collect();
    let dead = plants.len() - alive.len();
    assert!(alive.len() > 5 && dead > 0, "{} alive, {dead} dying", alive.len());
    for (i, a) in alive.iter().enumerate() {
        for b in &alive[i + 1..] {
            assert!(!overlap(a, b), "survivors overlap: {a:?} {b:?}");
        }
    }
    for (i, p) in plants.iter().enumerate().filter(|(_, p)| p.3 == 0.0) {
        assert!(
            plants
                .iter()
                .enumerate()
                .any(|(j, q)| j != i && q.2 > p.2 - 1e-4 && dist(p, q) < p.2 + q.2 + 1e-4),
            "{p:?} died without a larger neighbour"
        );
    }
    // Fewer plants remain than were sown.
    assert!(d.lsystem.format(&d.string).matches("P(").count() < 60);
}

#[test]
fn chiba_shaded_leaves_get_less_light_and_grow_less() {
    let file = data("chiba").join("plant.l");
    let b = derived_branches(&file, &[]);
    assert_eq!(b.len(), 3);
    let light = |s: &str| params(s, "?E")[0][0];
    let height = |s: &str| params(s, "F").iter().map(|p| p[0]).sum::<f64>();
    let (open, shaded, canopy) = (light(&b[0]), light(&b[1]), light(&b[2]));
    assert!(open > 0.95, "almost nothing above the open shoot: {open}");
    assert!(canopy > 0.95, "almost nothing above the canopy leaf: {canopy}");
    assert!(shaded < 0.8, "the shoot under the canopy: {shaded}");
    assert!(height(&b[0]) > 7.5, "{}", height(&b[0]));
    assert!(height(&b[1]) < 5.0, "the shaded shoot grows less: {}", height(&b[1]));
    // The skeleton shows it too: one shoot (the open one) is much taller than the other.
    let g = grow(&file, &[]).unwrap();
    let xs = g.skeleton.position.iter().map(|p| p.x);
    let (lo, hi) = xs.fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let mid = 0.5 * (lo + hi);
    let (y0, ya, yb) = g.skeleton.position.iter().fold((f32::MAX, f32::MIN, f32::MIN), |(m, a, b), p| {
        if p.x < mid {
            (m.min(p.y), a.max(p.y), b)
        } else {
            (m.min(p.y), a, b.max(p.y))
        }
    });
    let (tall, short) = ((ya - y0).max(yb - y0), (ya - y0).min(yb - y0));
    assert!(tall > 1.5 * short && short > 0.0, "shoot heights {tall} and {short}");
    // A translucent canopy lets more light through.
    assert!(light(&derived_branches(&file, &["generator.environment.transmittance=0.8"])[1]) > shaded);
}

#[test]
fn obcheck_keeps_the_stem_out_of_the_obstacle() {
    let file = data("obcheck").join("plant.l");
    let with = grow(&file, &[]).unwrap();
    let without = grow(&file, &["generator.environment.obstacles=\"empty.txt\""]).unwrap();
    let top = |g: &sylva::pipeline::Grown| g.skeleton.position.iter().map(|p| p.y).fold(f32::MIN, f32::max);
    // Without obstacles the stem grows all 12 steps, 12 units; with them it stops at 5.
    let unit = top(&without) / 12.0;
    assert!(unit > 0.0);
    assert!(top(&without) > 7.0 * unit, "the free stem grows through where the slab is");
    for p in &with.skeleton.position {
        let (x, y, z) = (p.x / unit, p.y / unit, p.z / unit);
        let inside = (-1.0..=1.0).contains(&x) && (5.5..=7.0).contains(&y) && (-1.0..=1.0).contains(&z);
        assert!(!inside, "a node inside the slab: {p:?}");
    }
    assert!((top(&with) / unit - 5.0).abs() < 1e-3, "stops below the slab: {}", top(&with) / unit);
    // The answer's second parameter is the distance to the nearest obstacle surface.
    let d = derive(&file, &[]).unwrap();
    let e = params(&text(&d), "?E");
    assert_eq!(e.len(), 1);
    assert_eq!(e[0][0], 0.0, "the probe one step ahead is inside");
    assert!((e[0][1] + 0.5).abs() < 1e-9, "0.5 deep: {:?}", e[0]);
}

#[test]
fn honda81_takes_its_radius_from_the_spec_file() {
    let dir = copy("obcheck", "honda");
    std::fs::write(
        dir.join("plant.l"),
        "Lsystem: 1\nderivation length: 1\nAxiom: [?E(1)][f(0.3)?E(2)]\nendlsystem\n",
    )
    .unwrap();
    std::fs::write(dir.join("plant.e"), "executable: honda81 density.spec\n").unwrap();
    let answers = |radius: &str| {
        std::fs::write(dir.join("density.spec"), format!("verbose: off\nradius: {radius}\n3d case: on\n"))
            .unwrap();
        let d = derive(dir.join("plant.l"), &[]).unwrap();
        params(&text(&d), "?E").into_iter().map(|p| p[0]).collect::<Vec<_>>()
    };
    assert_eq!(answers("0.01"), vec![1.0, 1.0], "0.3 apart: no collision at 0.01");
    assert_eq!(answers("1.0"), vec![0.0, 1.0], "collision at 1: the stronger wins");
    let e = derive(dir.join("plant.l"), &["generator.environment.radius=0.01"]).unwrap();
    assert_eq!(params(&text(&e), "?E")[0][0], 1.0, "the recipe overrides the spec file");
}

#[test]
fn environment_errors_name_the_file_and_why() {
    // A missing spec file.
    let dir = copy("obcheck", "nospec");
    std::fs::remove_file(dir.join("obstacles.spec")).unwrap();
    let e = derive(dir.join("plant.l"), &[]).err().expect("no spec file").to_string();
    assert!(e.contains("obstacles.spec") && e.contains("cannot read"), "{e}");
    // A missing obstacle file.
    let dir = copy("obcheck", "noobst");
    std::fs::remove_file(dir.join("obstacles.txt")).unwrap();
    let e = derive(dir.join("plant.l"), &[]).err().expect("no obstacle file").to_string();
    assert!(e.contains("obstacles.txt") && e.contains("obcheck"), "{e}");
    // A broken obstacle line.
    std::fs::write(dir.join("obstacles.txt"), "# x\nsphere 1 2\n").unwrap();
    let e = derive(dir.join("plant.l"), &[]).err().expect("bad obstacle").to_string();
    assert!(e.contains("obstacles.txt:2:") && e.contains("4 numbers"), "{e}");
    // A bad spec value names file:line and why; an unknown key is a warning.
    let dir = copy("clover", "badvalue");
    let spec = std::fs::read_to_string(dir.join("enviro.spec")).unwrap();
    std::fs::write(dir.join("enviro.spec"), spec.replace("transmittance: 0.1", "transmittance: lots"))
        .unwrap();
    let e = derive(dir.join("plant.l"), &[]).err().expect("bad transmittance").to_string();
    assert!(e.contains("enviro.spec:5:") && e.contains("transmittance") && e.contains("not a number"), "{e}");
    std::fs::write(dir.join("enviro.spec"), format!("{spec}colour: green\n")).unwrap();
    let d = derive(dir.join("plant.l"), &[]).unwrap();
    assert!(
        d.warnings.iter().any(|w| w.contains("enviro.spec:7:") && w.contains("colour")),
        "{:?}",
        d.warnings
    );
    let f = d.folder.as_ref().unwrap();
    assert!(f.ignored.iter().any(|w| w.contains("colour")), "{:?}", f.ignored);
    // A corrupt image is an error naming it.
    std::fs::write(dir.join("light.rgb"), b"\x01\xdanot really").unwrap();
    let e = derive(dir.join("plant.l"), &[]).err().expect("corrupt image").to_string();
    assert!(e.contains("light.rgb"), "{e}");
    // An unknown program is unsupported, listing the five sylva has.
    std::fs::write(dir.join("plant.e"), "executable: lightning enviro.spec\n").unwrap();
    let e = derive(dir.join("plant.l"), &[]).err().expect("unknown program");
    let msg = e.to_string();
    assert!(matches!(&e, sylva::Error::Lsystem(l) if l.kind == ErrorKind::Unsupported), "{msg}");
    for p in ["`lightning`", "honda81", "clover", "ecosystem", "chiba", "obcheck"] {
        assert!(msg.contains(p), "{msg}");
    }
    // A recipe key the environment does not have is an unknown key.
    let e = derive(data("chiba").join("plant.l"), &["generator.environment.colour=1"]).err().unwrap();
    assert!(e.to_string().contains("colour"), "{e}");
}

#[test]
fn the_corpus_clover_grows_and_its_leaves_shade() {
    let dir =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/corpus/cpfg/11-CPFG__07-Open__13-clover");
    if !dir.is_dir() {
        eprintln!("SKIPPED: the cpfg corpus is not at ../shared/corpus/cpfg");
        return;
    }
    let file = dir.join("plant.l");
    // The model's own derivation length is one step; run it for 25 (a season).
    let d = derive(&file, &["generator.iterations=25"]).unwrap();
    let t = text(&d);
    assert!(d.warnings.iter().any(|w| w.contains("light.rgb") && w.contains("uniform")), "{:?}", d.warnings);
    assert!(d.warnings.iter().any(|w| w.contains("view.pnl")), "{:?}", d.warnings);
    let internodes = t.matches("F(").count() + t.matches("f(").count();
    let leaves = t.matches("L(").count();
    assert!(internodes > 20 && leaves > 0, "{internodes} internodes, {leaves} leaves");
    // Leaves that let all light through change nothing for the apices; opaque ones do.
    let clear = derive(&file, &["generator.iterations=25", "generator.environment.transmittance=1"]).unwrap();
    assert_ne!(text(&clear), t, "the registered leaves shade the apices");
    let g = grow(&file, &["generator.iterations=25"]).unwrap();
    assert!(g.report.skeleton.segments > 0);
}

/// Environment settings with no program to use them (no `program` key and no `.e` file)
/// are not silently dropped: the run warns that they are unused.
#[test]
fn environment_settings_without_a_program_warn() {
    let plain = "Lsystem: 1\nderivation length: 2\nAxiom: F(1)A\nA --> F(1)A\nendlsystem\n";
    let dir = folders::with_files("env", "noprogram", &[("plain.l", plain)]);
    let file = dir.join("plain.l");
    let d = derive(&file, &["generator.environment.transmittance=0.5"]).unwrap();
    assert!(
        d.warnings.iter().any(|w| w.contains("[generator.environment]") && w.contains("not used")),
        "{:?}",
        d.warnings
    );
    let quiet = derive(&file, &[]).unwrap();
    assert!(!quiet.warnings.iter().any(|w| w.contains("generator.environment")), "{:?}", quiet.warnings);
    let _ = std::fs::remove_dir_all(&dir);
}
