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

use std::path::{Path, PathBuf};
use std::process::Command;

/// The folder holding `validate.mjs` and `package.json`.
pub fn validator_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/gltf-validator")
}

/// Whether a missing validator must fail the test (`SYLVA_REQUIRE_GLTF_VALIDATOR=1`).
fn required() -> bool {
    std::env::var("SYLVA_REQUIRE_GLTF_VALIDATOR").is_ok_and(|v| v == "1")
}

/// Validates every glTF / GLB file in `paths` with the Khronos validator and panics,
/// printing the report, if any has an error or a warning (infos and hints pass).
pub fn assert_valid_gltf(paths: &[&Path]) {
    validate(paths, false);
}

/// [`assert_valid_gltf`], and an info fails too (an unused attribute or object, an
/// unsupported extension): what every preset's default file must meet (issue 23).
pub fn assert_valid_gltf_without_infos(paths: &[&Path]) {
    validate(paths, true);
}

fn validate(paths: &[&Path], no_infos: bool) {
    let dir = validator_dir();
    let script = dir.join("validate.mjs");
    let node_ok = Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success());
    let package_ok = dir.join("node_modules/gltf-validator").is_dir();
    if !(node_ok && package_ok && script.is_file()) {
        let what = if !node_ok { "`node` is not on PATH" } else { "the npm package is not installed" };
        let message = format!("SKIPPED glTF validation ({what}): run `npm ci --prefix tools/gltf-validator`");
        if required() {
            panic!("{message} (SYLVA_REQUIRE_GLTF_VALIDATOR=1 makes this an error)");
        }
        eprintln!("\n**********\n*** {message}\n**********\n");
        return;
    }
    let output = Command::new("node")
        .arg(&script)
        .args(no_infos.then_some("--no-infos"))
        .args(paths)
        .output()
        .unwrap_or_else(|e| panic!("cannot run node {}: {e}", script.display()));
    let report =
        format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "glTF validation failed:\n{report}");
    println!("{report}");
}

/// Loads every `.glb` in `paths` with three.js's `GLTFLoader` in Node
/// (`tools/threejs/load.mjs`) and panics unless each loads, its `bark` material has a
/// colour map and a normal map, and its `leaf_card` material (where there is one) is
/// alpha-tested with a colour map. Skipped loudly when Node or the npm package is
/// missing, unless `SYLVA_REQUIRE_THREEJS=1` (set by `.ci/run`).
pub fn assert_threejs_loads(paths: &[&Path]) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/threejs");
    let node_ok = Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success());
    if !(node_ok && dir.join("node_modules/three").is_dir()) {
        let message = "SKIPPED three.js GLTFLoader check: run `npm ci --prefix tools/threejs`";
        if std::env::var("SYLVA_REQUIRE_THREEJS").is_ok_and(|v| v == "1") {
            panic!("{message} (SYLVA_REQUIRE_THREEJS=1 makes this an error)");
        }
        eprintln!("\n**********\n*** {message}\n**********\n");
        return;
    }
    let output = Command::new("node")
        .arg(dir.join("load.mjs"))
        .args(paths)
        .output()
        .unwrap_or_else(|e| panic!("cannot run node load.mjs: {e}"));
    let report =
        format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "three.js could not load a file:\n{report}");
    let lines: Vec<&str> = report.lines().filter(|l| l.starts_with('{')).collect();
    assert_eq!(lines.len(), paths.len(), "one report per file:\n{report}");
    for line in lines {
        let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
        let mats = &v["materials"];
        let bark = &mats["bark"];
        assert!(bark["map"] == true && bark["normalMap"] == true, "bark maps missing: {line}");
        if let Some(card) = mats.get("leaf_card") {
            assert!(card["map"] == true && card["alphaTest"].as_f64() > Some(0.0), "leaf cards: {line}");
        }
        assert_eq!(v["extras"], "recipe", "the recipe rides in the scene's extras: {line}");
    }
}
