//! Typed settings (issue 40): every mode of a recipe is an enum written as the same name
//! the preset files hold, a bad name is an error naming the key and the names allowed,
//! the typed constructors check what they build, and an L-system can come from memory.

use sylva::export::TextureMode;
use sylva::recipe::{self, LeafMode, Loaded, MeshMethod, Recipe, RefineScheme, WindPreset};

/// Every key whose value is a mode name (the least-cost generator's own modes too).
const MODE_KEYS: &[&str] = &[
    "mesh.method",
    "mesh.tips",
    "mesh.base",
    "refine.scheme",
    "refine.boundary",
    "output.textures",
    "output.instancing_fallback",
    "output.compress",
    "output.lod_layout",
    "leaves.mode",
    "leaves.shape",
    "leaves.normals",
    "leaves.place",
    "wind.preset",
    "textures.bark",
    "generator.gap",
    "generator.view",
    "generator.method",
    "generator.leaves.kind",
];

/// The value at a dotted `key` of `table`.
fn at<'a>(table: &'a toml::Table, key: &str) -> Option<&'a toml::Value> {
    let mut parts = key.split('.');
    let mut v = table.get(parts.next()?)?;
    for p in parts {
        v = v.as_table()?.get(p)?;
    }
    Some(v)
}

fn sets(kv: &[&str]) -> Vec<(String, toml::Value)> {
    kv.iter().map(|s| recipe::parse_set(s).unwrap()).collect()
}

/// Each preset's recipe, written back as TOML (what a file's metadata holds), gives every
/// mode the preset file sets the same name, and every mode it writes is a string.
#[test]
fn every_preset_writes_the_same_mode_names() {
    let mut checked = 0;
    for p in sylva::presets::all().into_iter().filter(|p| !p.is_curves()) {
        let recipe = Recipe::preset(p.name).unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let file: toml::Table = toml::from_str(p.recipe).unwrap();
        let text = toml::to_string(&recipe).unwrap();
        let written: toml::Table = toml::from_str(&text).unwrap();
        for key in MODE_KEYS {
            if let Some(v) = at(&file, key) {
                assert_eq!(at(&written, key), Some(v), "{}: {key}", p.name);
                let line = format!("{} = {v}", key.rsplit('.').next().unwrap());
                assert!(text.contains(&line), "{}: `{line}` in\n{text}", p.name);
                checked += 1;
            }
            if let Some(v) = at(&written, key) {
                assert!(v.is_str(), "{}: {key} = {v} is a name", p.name);
            }
        }
        // The text reads back to the same recipe (the L-system's list of keys the recipe
        // gave explicitly is not part of the text).
        let mut back = Recipe::from_toml(&text).unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let mut want = recipe.clone();
        for r in [&mut back, &mut want] {
            if let recipe::Generator::Lsystem(g) = &mut r.generator {
                g.explicit.clear();
            }
        }
        assert_eq!(back, want, "{}", p.name);
    }
    assert!(checked > 20, "the presets set modes ({checked})");
}

/// A bad mode name through `--set`, [`Recipe::set`] or a TOML file names the key and
/// lists the names allowed.
#[test]
fn bad_mode_values_name_the_key_and_the_values() {
    let cases = [
        ("leaves.mode=sprites", "`leaves.mode` is `sprites`; use cards, instanced or geometry"),
        ("mesh.method=quads", "`mesh.method` is `quads`; use tube, hull, sweep, quad or leaf"),
        ("mesh.tips=pointy", "`mesh.tips` is `pointy`; use round, flat or open"),
        ("mesh.base=sunk", "`mesh.base` is `sunk`; use flat or round"),
        ("refine.scheme=butterfly", "`refine.scheme` is `butterfly`; use auto, none, loop or catmull-clark"),
        ("refine.boundary=free", "`refine.boundary` is `free`; use auto, fixed, bspline or edge-only"),
        ("output.textures=inline", "`output.textures` is `inline`; use embed, files or none"),
        ("output.compress=zip", "`output.compress` is `zip`; use none, quantize or meshopt"),
        ("output.instancing_fallback=copies", "`output.instancing_fallback` is `copies`; use none or merged"),
        ("output.lod_layout=nested", "`output.lod_layout` is `nested`; use msft or scene"),
        (
            "leaves.shape=round",
            "`leaves.shape` is `round`; use auto, ovate, lanceolate, lobed, compound, needles or cluster",
        ),
        ("leaves.normals=up", "`leaves.normals` is `up`; use flat or crown"),
        ("leaves.place=all", "`leaves.place` is `all`; use none, level or terminal"),
        ("wind.preset=gale", "`wind.preset` is `gale`; use none, calm, breeze or storm"),
        ("textures.bark=mossy", "`textures.bark` is `mossy`; use auto, smooth, furrowed, plated or birch"),
        ("generator.view=some", "`generator.view` is `some`; use auto or none"),
    ];
    for (kv, want) in cases {
        let e = recipe::load("lsys-honda-a", &sets(&[kv])).unwrap_err().to_string();
        assert!(e.contains(want), "--set {kv}: {e}");
        let mut r = Recipe::preset("lsys-honda-a").unwrap();
        let before = r.clone();
        let e = r.set_text(kv).unwrap_err().to_string();
        assert!(e.contains(want), "set {kv}: {e}");
        assert_eq!(r, before, "a failed set leaves the recipe as it was");
    }
    // The generators' own modes.
    for (preset, kv, want) in [
        ("mgv-a", "generator.method=lattice", "`generator.method` is `lattice`; use mig, mgv or bcm"),
        (
            "mgv-a",
            "generator.leaves.kind=fronds",
            "`generator.leaves.kind` is `fronds`; use none, leaf or needles",
        ),
        ("lsys-honda-a", "generator.type=fractal", "`generator.type` is `fractal`; use lsystem, import"),
    ] {
        let e = recipe::load(preset, &sets(&[kv])).unwrap_err().to_string();
        assert!(e.contains(want), "{preset} --set {kv}: {e}");
    }
    // From a TOML text: the import generator's `gap`.
    let toml = "[generator]\ntype = \"import\"\nfile = \"tree.lst\"\ngap = \"sideways\"\n";
    let e = Recipe::from_toml(toml).unwrap_err().to_string();
    assert!(e.contains("`generator.gap` is `sideways`; use bridge, strict or new-root"), "{e}");
    let toml = "[generator]\ntype = \"lsystem\"\nfile = \"a.l\"\n[leaves]\nmode = \"sprites\"\n";
    let e = Recipe::from_toml(toml).unwrap_err().to_string();
    assert!(e.contains("`leaves.mode` is `sprites`; use cards, instanced or geometry"), "{e}");
    // A value of the wrong type names the key too.
    let e = recipe::load("lsys-honda-a", &sets(&["leaves.mode=3"])).unwrap_err().to_string();
    assert!(e.contains("leaves.mode"), "{e}");
    // A huge bad value is clipped in the message.
    let long = format!("mesh.method={}", "q".repeat(100_000));
    let e = recipe::load("lsys-honda-a", &sets(&[&long])).unwrap_err().to_string();
    assert!(e.contains("`mesh.method` is `qqq") && e.len() < 2_000, "{} chars", e.len());
}

/// The typed constructors and builders check what they build.
#[test]
fn constructors_check_their_values() {
    // The default is the default preset, valid.
    let d = Recipe::default();
    assert_eq!(d.name, sylva::presets::DEFAULT_PRESET);
    d.check().unwrap();
    assert!(Recipe::preset("no-such-preset").unwrap_err().to_string().contains("unknown preset"));
    assert!(Recipe::from_toml("seed = ").is_err());
    let e = Recipe::from_toml("[generator]\ntype = \"lsystem\"\nfile = \"a.l\"\n[mesh]\nsides = 2\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("mesh.sides"), "{e}");

    let r = Recipe::preset("lsys-honda-a").unwrap();
    assert!(r.clone().with_refine_levels(7).unwrap_err().to_string().contains("refine.levels"));
    assert!(r.clone().with_sides(2).unwrap_err().to_string().contains("mesh.sides"));
    let built = r
        .clone()
        .with_mesher(MeshMethod::Quad)
        .with_seed(7)
        .with_refine_scheme(RefineScheme::CatmullClark)
        .with_textures(TextureMode::None)
        .with_leaf_mode(LeafMode::Geometry)
        .with_wind(WindPreset::Breeze)
        .with_refine_levels(1)
        .unwrap()
        .with_iterations(3)
        .unwrap();
    // The same through `set`, the path of `--set`.
    let mut set = r.clone();
    for kv in [
        "mesh.method=quad",
        "seed=7",
        "refine.scheme=catmull-clark",
        "output.textures=none",
        "leaves.mode=geometry",
        "wind.preset=breeze",
        "refine.levels=1",
        "generator.iterations=3",
    ] {
        set.set_text(kv).unwrap();
    }
    assert_eq!(built, set);
    let recipe::Generator::Lsystem(g) = &set.generator else { panic!("an L-system") };
    assert_eq!(g.iterations, Some(3));
    assert!(g.explicit.iter().any(|k| k == "iterations"), "{:?}", g.explicit);
    assert!(
        !g.explicit.iter().any(|k| k == "width_factor"),
        "a round trip marks no key given: {:?}",
        g.explicit
    );

    // `set` rejects unknown keys and bad values and leaves the recipe unchanged.
    let mut s = r.clone();
    assert!(s.set("mesh.sides", 2).unwrap_err().to_string().contains("mesh.sides"));
    assert!(s.set("mesh.colour", "red").unwrap_err().to_string().contains("unknown key `mesh.colour`"));
    assert_eq!(s, r);
    s.set("mesh.sides", 6).unwrap();
    assert_eq!(s.mesh.sides, 6);

    // Iterations belong to L-systems: another generator says so.
    let wp = Recipe::preset("wp-quaking-aspen").unwrap();
    let e = wp.with_iterations(5).unwrap_err().to_string();
    assert!(e.contains("`weber-penn` generator has no iterations"), "{e}");

    // A hand-built invalid recipe cannot become a `Loaded` through the constructors.
    let mut bad = r.clone();
    bad.mesh.sides = 2;
    let e = Loaded::new(bad.clone(), recipe::Origin::Preset("lsys-honda-a".into())).unwrap_err();
    assert!(e.to_string().contains("mesh.sides"), "{e}");
    assert!(Loaded::with_files(bad, []).is_err());
    assert!(Recipe::from_file("tree.png").unwrap_err().to_string().contains("cannot tell"));
}

const BUSH: &str = "Lsystem: 1\nderivation length: 3\nAxiom: F\nF --> F[+F]F[-F]F\nendlsystem\n";

/// An L-system given as text grows as the same file on disk does.
#[test]
fn lsystem_source_from_memory_grows() {
    let loaded = Loaded::from_lsystem_source(BUSH).unwrap();
    assert!(matches!(loaded.origin, recipe::Origin::Memory(_)));
    let tree = sylva::pipeline::grow(&loaded).unwrap();
    assert!(tree.model.triangle_count() > 0);

    let dir = std::env::temp_dir().join(format!("sylva-typed-recipe-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bush.l");
    std::fs::write(&path, BUSH).unwrap();
    let disk = sylva::pipeline::grow(&Recipe::from_file(&path).unwrap()).unwrap();
    assert_eq!(disk.skeleton.position, tree.skeleton.position, "memory and disk grow the same skeleton");
    assert_eq!(disk.model.triangle_count(), tree.model.triangle_count());
    let _ = std::fs::remove_dir_all(&dir);

    // A recipe naming its own file, given in memory with an `#include`d one.
    let recipe = Recipe::from_toml("[generator]\ntype = \"lsystem\"\nfile = \"tree.l\"\n").unwrap();
    let main = "Lsystem: 1\nderivation length: 2\nAxiom: F\n#include \"rules.h\"\nendlsystem\n";
    let files =
        [("tree.l".to_string(), main.to_string()), ("rules.h".to_string(), "F --> F[+F]F\n".to_string())];
    let loaded = Loaded::with_files(recipe.clone(), files).unwrap();
    let tree = sylva::pipeline::grow(&loaded).unwrap();
    assert!(tree.model.triangle_count() > 0);
    // A file the recipe names but memory lacks is an error naming it.
    let e = sylva::pipeline::grow(&Loaded::with_files(recipe, []).unwrap()).unwrap_err().to_string();
    assert!(e.contains("tree.l"), "{e}");
}
