//! The least-cost generator's own modes (issue 40: no mode of a recipe is a `String`):
//! `axis`, `thickness`, `bcm.weights`, the MGV iterations' `rotation.rule`, `lower.rule`,
//! `endpoints` and `direction`, the MIG levels' `shape` and `direction` and
//! `refine.attach` are enums written as the names the presets hold; a bad name through
//! `--set` is an error naming the key and listing the names.

use sylva::grow::least_cost::{self as lc, bcm, mgv, mig, refine};
use sylva::recipe::{self, Recipe};

/// A bad value of each key, the key the error names and the names it lists.
const BAD: &[(&str, &str, &str)] = &[
    ("generator.axis=\"sideways\"", "`generator.axis` is `sideways`", "use edge or guide"),
    ("generator.thickness=\"thick\"", "`generator.thickness` is `thick`", "use power or pipe"),
    (
        "generator.bcm.weights=\"sideways\"",
        "`generator.bcm.weights` is `sideways`",
        "use random, left, right, axis or height",
    ),
    (
        "generator.iterations=[{rotation={rule=\"spiral\"}}]",
        "`generator.iterations[0].rotation.rule` is `spiral`",
        "use constant, two-phase, random, eq52, height, helical, rotational or spherical",
    ),
    (
        "generator.iterations=[{}, {lower={rule=\"spiral\"}}]",
        "`generator.iterations[1].lower.rule` is `spiral`",
        "use constant, two-phase, random, eq52, height, helical, rotational or spherical",
    ),
    (
        "generator.iterations=[{endpoints=\"crown\"}]",
        "`generator.iterations[0].endpoints` is `crown`",
        "use point, volume, surface or none",
    ),
    (
        "generator.iterations=[{direction=\"up\"}]",
        "`generator.iterations[0].direction` is `up`",
        "use any, lower or higher",
    ),
    ("generator.levels=[{shape=\"ball\"}]", "`generator.levels[0].shape` is `ball`", "use sector or cone"),
    (
        "generator.levels=[{}, {direction=\"in\"}]",
        "`generator.levels[1].direction` is `in`",
        "use outward, down or up",
    ),
    ("generator.refine={attach=\"side\"}", "`generator.refine.attach` is `side`", "use nearest or top"),
];

#[test]
fn a_bad_least_cost_mode_names_the_key_and_the_names() {
    for (set, key, names) in BAD {
        let sets = vec![recipe::parse_set(set).unwrap_or_else(|e| panic!("{set}: {e}"))];
        let e = recipe::load("mig-a", &sets).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains(key), "{set}: {e}");
        assert!(e.contains(names), "{set}: {e}");
    }
}

#[test]
fn every_least_cost_mode_reads_and_writes_its_names() {
    let mut recipe = Recipe::preset("mig-a").unwrap();
    for (set, value) in [
        ("generator.axis=\"guide\"", "axis = \"guide\""),
        ("generator.thickness=\"pipe\"", "thickness = \"pipe\""),
        ("generator.bcm.weights=\"height\"", "weights = \"height\""),
        ("generator.levels=[{shape=\"cone\", direction=\"down\"}]", "shape = \"cone\""),
    ] {
        let sets = vec![recipe::parse_set(set).unwrap()];
        recipe = recipe::load("mig-a", &sets).unwrap_or_else(|e| panic!("{set}: {e}")).recipe;
        let text = toml::to_string(&recipe).unwrap();
        assert!(text.contains(value), "{set}: `{value}` in\n{text}");
        assert_eq!(Recipe::from_toml(&text).unwrap(), recipe, "{set}");
    }
    let recipe::Generator::LeastCost(p) = &recipe.generator else { panic!("mig-a is least-cost") };
    assert_eq!(p.levels[0].shape, mig::SubShape::Cone);
    assert_eq!(p.levels[0].direction, mig::GuideDirection::Down);

    // Every name of every mode round-trips through its text and serde form.
    fn round<T>(all: &[T], names: &[&str])
    where
        T: Copy + PartialEq + std::fmt::Debug + std::fmt::Display + std::str::FromStr,
        T: serde::Serialize + serde::de::DeserializeOwned,
    {
        assert_eq!(all.len(), names.len());
        for (v, n) in all.iter().zip(names) {
            assert_eq!(v.to_string(), *n);
            assert!(n.parse::<T>().ok() == Some(*v), "{n}");
            let t: toml::Value = toml::Value::try_from(v).unwrap();
            assert_eq!(t.as_str(), Some(*n));
            assert_eq!(t.try_into::<T>().unwrap(), *v);
        }
    }
    round(mgv::AxisRule::ALL, mgv::AxisRule::NAMES);
    round(lc::Thickness::ALL, lc::Thickness::NAMES);
    round(bcm::Weights::ALL, bcm::Weights::NAMES);
    round(mgv::RotationRule::ALL, mgv::RotationRule::NAMES);
    round(mgv::EndpointRule::ALL, mgv::EndpointRule::NAMES);
    round(mgv::Direction::ALL, mgv::Direction::NAMES);
    round(mig::SubShape::ALL, mig::SubShape::NAMES);
    round(mig::GuideDirection::ALL, mig::GuideDirection::NAMES);
    round(refine::Attach::ALL, refine::Attach::NAMES);
}

/// `FromStr` of each mode says the key and the names too (what a front end's field says).
#[test]
fn parsing_a_mode_name_names_the_key() {
    let e = "spiral".parse::<mgv::RotationRule>().unwrap_err().to_string();
    assert!(e.contains("`generator.iterations.rotation.rule` is `spiral`; use constant,"), "{e}");
    let e = "ball".parse::<mig::SubShape>().unwrap_err().to_string();
    assert!(e.contains("`generator.levels.shape` is `ball`; use sector or cone"), "{e}");
    let e = "side".parse::<refine::Attach>().unwrap_err().to_string();
    assert!(e.contains("`generator.refine.attach` is `side`; use nearest or top"), "{e}");
}

/// The string values under `v` whose key is one of `keys`, with their paths.
fn modes_in(v: &toml::Value, path: &str, keys: &[&str], out: &mut Vec<(String, String)>) {
    match v {
        toml::Value::Table(t) => {
            for (k, v) in t {
                let p = format!("{path}.{k}");
                match v.as_str() {
                    Some(s) if keys.contains(&k.as_str()) => out.push((p, s.to_string())),
                    _ => modes_in(v, &p, keys, out),
                }
            }
        }
        toml::Value::Array(a) => {
            for (i, v) in a.iter().enumerate() {
                modes_in(v, &format!("{path}[{i}]"), keys, out);
            }
        }
        _ => {}
    }
}

/// Every least-cost preset's recipe, written back as TOML (a file's metadata), gives each
/// of these modes the name the preset file gives it, at the same place.
#[test]
fn least_cost_presets_write_the_same_mode_names() {
    const KEYS: &[&str] =
        &["axis", "thickness", "weights", "rule", "endpoints", "direction", "shape", "attach"];
    let mut checked = 0;
    for p in sylva::presets::all().into_iter().filter(|p| !p.is_curves()) {
        let file: toml::Table = toml::from_str(p.recipe).unwrap();
        if file.get("generator").and_then(|g| g.get("type")).and_then(|t| t.as_str()) != Some("least-cost") {
            continue;
        }
        let recipe = Recipe::preset(p.name).unwrap_or_else(|e| panic!("{}: {e}", p.name));
        let written = toml::Value::try_from(&recipe).unwrap();
        let (mut want, mut got) = (Vec::new(), Vec::new());
        modes_in(&file["generator"], "generator", KEYS, &mut want);
        modes_in(&written["generator"], "generator", KEYS, &mut got);
        for w in &want {
            assert!(got.contains(w), "{}: {} = {} written as {got:?}", p.name, w.0, w.1);
            checked += 1;
        }
    }
    assert!(checked >= 10, "the least-cost presets set modes ({checked})");
}
