//! The recipe's own tests: `--set`, unknown keys. The keys, defaults and ranges against
//! `docs/recipe.md` and the schema are in `tests/recipe_schema.rs`.

use super::*;

fn sets(kv: &[&str]) -> Vec<(String, toml::Value)> {
    kv.iter().map(|s| parse_set(s).unwrap()).collect()
}

#[test]
fn every_preset_loads() {
    for p in crate::presets::all().into_iter().filter(|p| !p.is_curves()) {
        let l = load(p.name, &[]).unwrap_or_else(|e| panic!("{}: {e}", p.name));
        assert_eq!(l.recipe.name, p.name, "recipe name matches the file name");
    }
}

#[test]
fn set_overrides_and_types() {
    let l = load("lsys-honda-a", &sets(&["generator.angle=22.5", "mesh.sides=6", "seed=7"])).unwrap();
    let Generator::Lsystem(g) = &l.recipe.generator else { panic!("an L-system recipe") };
    assert_eq!(g.angle, 22.5);
    assert_eq!(l.recipe.mesh.sides, 6);
    assert_eq!(l.recipe.seed, 7);
    let l = load("lsys-honda-a", &sets(&["generator.define.R1=0.5"])).unwrap();
    let Generator::Lsystem(g) = &l.recipe.generator else { panic!("an L-system recipe") };
    assert_eq!(g.define.get("R1"), Some(&toml::Value::Float(0.5)));
}

#[test]
fn decollide_defaults_to_the_joint_meshers() {
    assert!(!load("lsys-honda-a", &[]).unwrap().recipe.mesh.decollides(), "tube: off");
    for m in ["hull", "sweep", "quad"] {
        let l = load("lsys-honda-a", &sets(&[&format!("mesh.method=\"{m}\"")])).unwrap();
        assert!(l.recipe.mesh.decollides(), "{m}: on");
    }
    let l = load("lsys-honda-a", &sets(&["mesh.method=\"hull\"", "mesh.decollide=false"])).unwrap();
    assert!(!l.recipe.mesh.decollides());
    let l = load("lsys-honda-a", &sets(&["mesh.decollide=true"])).unwrap();
    assert!(l.recipe.mesh.decollides());
    assert!(l.recipe.mesh.decollides_nodes(10 * DECOLLIDE_AUTO_NODES), "explicit: any size");
    // Unset: the joint meshers skip very large skeletons.
    let l = load("lsys-honda-a", &sets(&["mesh.method=\"hull\""])).unwrap();
    assert!(l.recipe.mesh.decollides_nodes(DECOLLIDE_AUTO_NODES));
    assert!(!l.recipe.mesh.decollides_nodes(DECOLLIDE_AUTO_NODES + 1));
    // Mesh clearing follows de-collision unless set, and never runs for tubes.
    assert!(l.recipe.mesh.clears_nodes(100) && !l.recipe.mesh.clears_nodes(DECOLLIDE_AUTO_NODES + 1));
    let l = load("lsys-honda-a", &sets(&["mesh.method=\"hull\"", "mesh.clear=false"])).unwrap();
    assert!(l.recipe.mesh.decollides_nodes(100) && !l.recipe.mesh.clears_nodes(100));
    let l = load("lsys-honda-a", &sets(&["mesh.method=\"quad\"", "mesh.decollide=false", "mesh.clear=true"]))
        .unwrap();
    assert!(l.recipe.mesh.clears_nodes(10 * DECOLLIDE_AUTO_NODES), "explicit: any size");
    assert!(!load("lsys-honda-a", &sets(&["mesh.clear=true"])).unwrap().recipe.mesh.clears_nodes(100));
}

#[test]
fn unknown_keys_are_named() {
    let e = load("lsys-honda-a", &sets(&["generator.angel=3"])).unwrap_err();
    assert!(e.to_string().contains("unknown key `generator.angel`"), "{e}");
    let e = load("lsys-honda-a", &sets(&["colour=3"])).unwrap_err();
    assert!(e.to_string().contains("unknown key `colour`"), "{e}");
    // Keys at the defaults the written recipe leaves out are still known.
    for (k, v) in [
        ("output.compress", "\"none\""),
        ("output.instancing_fallback", "\"none\""),
        ("output.lod_layout", "\"msft\""),
        ("output.wind_colors", "false"),
        ("wind.preset", "\"none\""),
        ("lod.impostor", "false"),
    ] {
        let set = parse_set(&format!("{k}={v}")).unwrap();
        load("lsys-honda-a", &[set]).unwrap_or_else(|e| panic!("{k} = {v}: {e}"));
    }
    let e = load("lsys-honda-a", &sets(&["wind.gusts=1"])).unwrap_err();
    assert!(e.to_string().contains("gusts"), "{e}");
    let e = load("lsys-honda-a", &sets(&["mesh.sides=2"])).unwrap_err();
    assert!(e.to_string().contains("mesh.sides"), "{e}");
    let e = load("lsys-honda-a", &sets(&["mesh.sides=many"])).unwrap_err();
    assert!(e.to_string().contains("sides") || e.to_string().contains("integer"), "{e}");
    assert!(parse_set("novalue").is_err());
    let e = load("lsys-honda-a", &sets(&["mesh.decollide=3"])).unwrap_err();
    assert!(e.to_string().contains("decollide") || e.to_string().contains("bool"), "{e}");
    assert!(load("no-such-preset", &[]).unwrap_err().to_string().contains("unknown preset"));
    assert!(load("missing.l", &[]).unwrap_err().to_string().contains("missing.l"));
}

#[test]
fn an_overlay_replaces_the_file_and_keeps_the_origin() {
    let loaded = load("lsys-honda-a", &[]).unwrap();
    let Generator::Lsystem(g) = &loaded.recipe.generator else { panic!("an L-system recipe") };
    let file = g.file.clone();
    let (name, original) = loaded.read(&file).unwrap();
    let edited = original.replace("#define N 10", "#define N 3");
    assert_ne!(edited, original, "the preset's grammar has the line");
    let over = loaded.clone().with_overlay(&file, &edited);
    assert_eq!(over.origin, loaded.origin, "the origin stays, so #includes still resolve there");
    assert_eq!(over.read(&file).unwrap(), (name, edited), "the same name in messages, the edited text");
    // Other files still come from the origin; a name the origin lacks is still an error.
    assert!(over.read("lsystem/binary-tree.l").unwrap().1.contains("b --> bb"));
    assert!(over.read("lsystem/no-such.l").is_err());
    assert_ne!(over, loaded);
}
