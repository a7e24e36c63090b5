//! A recipe file that starts from a preset (`preset = "name"`, `recipe::over_preset`):
//! the editor saves a preset's recipe as the keys that differ from it.

use std::fs;
use sylva::recipe::{Loaded, Origin, Recipe};

#[test]
fn a_file_over_a_preset_grows_the_preset_with_its_keys() {
    let dir = std::env::temp_dir().join(format!("sylva-recipe-preset-{}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    let path = dir.join("mine.toml");
    fs::write(&path, "preset = \"lsys-honda-a\"\nseed = 7\n[mesh]\nsides = 5\n").unwrap();
    let loaded = Loaded::from_file(&path).unwrap();
    let preset = Recipe::preset("lsys-honda-a").unwrap();
    assert_eq!(loaded.origin, Origin::Preset("lsys-honda-a".into()), "files resolve in the preset");
    assert_eq!((loaded.recipe.seed, loaded.recipe.mesh.sides), (7, 5));
    assert_eq!(loaded.recipe.mesh.method, preset.mesh.method, "the rest is the preset's");
    assert_eq!(loaded.recipe.generator, preset.generator);
    // It grows: the L-system file named by the preset is found among the presets.
    let tree = sylva::pipeline::grow(&loaded).unwrap();
    assert!(tree.model.triangle_count() > 0);
    fs::remove_dir_all(&dir).unwrap();
    // The same from text.
    let r = Recipe::from_toml("preset = \"lsys-honda-a\"\n[mesh]\nsides = 5\n").unwrap();
    assert_eq!(r.mesh.sides, 5);
}

#[test]
fn a_bad_preset_key_is_named() {
    for (text, want) in [
        ("preset = 3\n", "`preset` must be a preset's name"),
        ("preset = \"no-such\"\n", "no tree preset is called `no-such`"),
        ("preset = \"curves-fire\"\n", "no tree preset is called `curves-fire`"),
        ("preset = \"lsys-honda-a\"\n[mesh]\nsides = 2\n", "mesh.sides"),
    ] {
        let e = Recipe::from_toml(text).unwrap_err().to_string();
        assert!(e.contains(want), "{text:?}: {e}");
    }
}

#[test]
fn another_generator_type_replaces_the_presets_generator() {
    let text = "preset = \"lsys-honda-a\"\n[generator]\ntype = \"weber-penn\"\n";
    let r = Recipe::from_toml(text).unwrap();
    assert_eq!(r.generator.generator_kind(), sylva::recipe::schema::GeneratorKind::WeberPenn);
}
