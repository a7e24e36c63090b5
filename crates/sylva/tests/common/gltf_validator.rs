//! Test helper: runs the Khronos glTF-Validator (`tools/gltf-validator/validate.mjs`,
//! npm package `gltf-validator`) on files and fails the test on any error or warning.
//!
//! Other crates' tests can include it directly:
//! `#[path = "../../sylva/tests/common/gltf_validator.rs"] mod gltf_validator;`
//!
//! When `node` or the npm package is missing, the check is skipped with a loud message,
//! unless `SYLVA_REQUIRE_GLTF_VALIDATOR=1` is set (as CI does), which makes it a failure.
//! [`assert_threejs_loads`] is the same for three.js's `GLTFLoader` (`tools/threejs`).
#![allow(dead_code)]

// Self-contained for other crates' #[path] includes; a test that loads both helpers
// loads this file twice, harmlessly.
#[allow(clippy::duplicate_mod)]
#[path = "node_check.rs"]
mod node_check;

use node_check::NodeCheck;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// The folder holding `validate.mjs` and `package.json`.
pub fn validator_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/gltf-validator")
}

/// Validates every glTF / GLB file in `paths` with the Khronos validator and panics,
/// printing the report, if any has an error or a warning (infos and hints pass).
pub fn assert_valid_gltf<P: AsRef<Path>>(paths: &[P]) {
    validate(paths, false);
}

/// [`assert_valid_gltf`], and an info fails too (an unused attribute or object, an
/// unsupported extension): what every preset's default file must meet (issue 23).
pub fn assert_valid_gltf_without_infos<P: AsRef<Path>>(paths: &[P]) {
    validate(paths, true);
}

fn validate<P: AsRef<Path>>(paths: &[P], no_infos: bool) {
    let flag = no_infos.then_some(OsStr::new("--no-infos"));
    let check = NodeCheck {
        what: "glTF validation",
        dir: validator_dir(),
        script: "validate.mjs",
        package: "gltf-validator",
        require: "SYLVA_REQUIRE_GLTF_VALIDATOR",
    };
    let args = flag.into_iter().chain(paths.iter().map(|p| p.as_ref().as_os_str()));
    let Some((ok, report)) = check.run(args) else { return };
    assert!(ok, "glTF validation failed:\n{report}");
    println!("{report}");
}

/// Loads every `.glb` in `paths` with three.js's `GLTFLoader` in Node
/// (`tools/threejs/load.mjs`) and panics unless each loads, its `bark` material has a
/// colour map and a normal map, and its `leaf_card` material (where there is one) is
/// alpha-tested with a colour map. Returns the script's JSON report of each file (its
/// materials, bounds, instances). Skipped loudly (`None`) when Node or the npm package
/// is missing, unless `SYLVA_REQUIRE_THREEJS=1` (set by `.ci/run`).
pub fn assert_threejs_loads<P: AsRef<Path>>(paths: &[P]) -> Option<Vec<serde_json::Value>> {
    let check = NodeCheck {
        what: "three.js GLTFLoader check",
        dir: Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/threejs"),
        script: "load.mjs",
        package: "three",
        require: "SYLVA_REQUIRE_THREEJS",
    };
    let (ok, report) = check.run(paths.iter().map(AsRef::as_ref))?;
    assert!(ok, "three.js could not load a file:\n{report}");
    let lines: Vec<&str> = report.lines().filter(|l| l.starts_with('{')).collect();
    assert_eq!(lines.len(), paths.len(), "one report per file:\n{report}");
    let reports = lines.iter().map(|line| {
        let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
        let mats = &v["materials"];
        let bark = &mats["bark"];
        assert!(bark["map"] == true && bark["normalMap"] == true, "bark maps missing: {line}");
        if let Some(card) = mats.get("leaf_card") {
            assert!(card["map"] == true && card["alphaTest"].as_f64() > Some(0.0), "leaf cards: {line}");
        }
        assert_eq!(v["extras"], "recipe", "the recipe rides in the scene's extras: {line}");
        v
    });
    Some(reports.collect())
}
