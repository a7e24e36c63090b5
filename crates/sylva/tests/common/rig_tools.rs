//! Test helpers for rigged, animated files (issue 24): three.js plays the wind clip
//! (`tools/threejs/wind.mjs`) and Blender imports the rig (`tools/blender/wind_check.py`).
//!
//! Each returns `None`, after a loud message, when its tool is missing, unless
//! `SYLVA_REQUIRE_THREEJS=1` / `SYLVA_REQUIRE_BLENDER=1` is set (as `.ci/run` does),
//! which makes a missing tool a failure. Other crates' tests can include this file with
//! `#[path = "../../sylva/tests/common/rig_tools.rs"] mod rig_tools;`.
#![allow(dead_code)]

// Self-contained for other crates' #[path] includes; a test that loads both helpers
// loads this file twice, harmlessly.
#[allow(clippy::duplicate_mod)]
#[path = "node_check.rs"]
mod node_check;

use node_check::{skip, NodeCheck};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's `tools` folder.
fn tools_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools")
}

/// What three.js measured playing a file's wind clip (`tools/threejs/wind.mjs`).
#[derive(Debug, Clone, PartialEq)]
pub struct ThreeWind {
    /// Bones of the first skinned mesh's skeleton.
    pub joints: usize,
    /// The clips' names.
    pub clips: Vec<String>,
    /// The first clip's duration in seconds.
    pub duration: f64,
    /// Skinned meshes in the scene (one per primitive).
    pub meshes: usize,
    /// How far the bind pose's highest vertex moved between t = 0 and T/4.
    pub tip_move: f64,
    /// How far the bind pose's lowest vertex moved between t = 0 and T/4.
    pub base_move: f64,
    /// The height given, or the bind pose's highest minus lowest y.
    pub height: f64,
    /// The whole report.
    pub json: serde_json::Value,
}

/// Loads `path` (a `.glb`) with three.js's `GLTFLoader`, plays its first clip with an
/// `AnimationMixer` and measures the skinned tip and base at t = 0 and T/4
/// (`tools/threejs/wind.mjs`); `height` (else the bind pose's) goes into
/// [`ThreeWind::height`]. Panics if the script fails; `None` when Node or three.js is
/// missing (unless `SYLVA_REQUIRE_THREEJS=1`).
pub fn threejs_wind(path: &Path, height: Option<f64>) -> Option<ThreeWind> {
    let check = NodeCheck {
        what: "three.js wind check",
        dir: tools_dir().join("threejs"),
        script: "wind.mjs",
        package: "three",
        require: "SYLVA_REQUIRE_THREEJS",
    };
    let height = height.map(|h| std::ffi::OsString::from(h.to_string()));
    let (ok, report) = check.run(std::iter::once(path.as_os_str().to_owned()).chain(height))?;
    assert!(ok, "three.js could not play {}:\n{report}", path.display());
    let line = report.lines().find(|l| l.starts_with('{')).unwrap_or_else(|| panic!("no report:\n{report}"));
    let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
    let num = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("no number `{k}` in {line}"));
    Some(ThreeWind {
        joints: num("joints") as usize,
        clips: v["clips"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|c| c.as_str().map(String::from))
            .collect(),
        duration: num("duration"),
        meshes: num("meshes") as usize,
        tip_move: num("tip_move"),
        base_move: num("base_move"),
        height: num("height"),
        json: v.clone(),
    })
}

/// What Blender's glTF importer made of a rigged file (`tools/blender/wind_check.py`).
#[derive(Debug, Clone, PartialEq)]
pub struct BlenderRig {
    /// Bones over every armature.
    pub bones: usize,
    /// Armature objects.
    pub armatures: usize,
    /// Actions with keyframes.
    pub actions: usize,
    /// The earliest keyframe of any action, in seconds.
    pub start: Option<f64>,
    /// The latest keyframe of any action, in seconds.
    pub end: Option<f64>,
    /// The scene's frame rate the keyframes were converted with.
    pub fps: f64,
    /// The whole report.
    pub json: serde_json::Value,
}

/// Imports each `.glb` of `paths` into Blender headless (`blender -b --factory-startup`)
/// and reports its armatures' bones and its actions' keyframe range
/// (`tools/blender/wind_check.py`), one report per file. Panics if an import fails;
/// `None` when `blender` is not on PATH (unless `SYLVA_REQUIRE_BLENDER=1`).
pub fn blender_rig<P: AsRef<Path>>(paths: &[P]) -> Option<Vec<BlenderRig>> {
    let has = Command::new("blender").arg("--version").output().is_ok_and(|o| o.status.success());
    if !has {
        skip(
            "SKIPPED Blender rig check: `blender` is not on PATH (apt install blender python3-numpy)",
            "SYLVA_REQUIRE_BLENDER",
        );
        return None;
    }
    let output = Command::new("blender")
        .args(["-b", "--factory-startup", "--python"])
        .arg(tools_dir().join("blender/wind_check.py"))
        .arg("--")
        .args(paths.iter().map(AsRef::as_ref))
        .output()
        .unwrap_or_else(|e| panic!("cannot run blender: {e}"));
    let text = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "blender failed:\n{text}\n{}", String::from_utf8_lossy(&output.stderr));
    let reports: Vec<BlenderRig> = text
        .lines()
        .filter_map(|l| l.strip_prefix("SYLVA "))
        .map(|line| {
            let v: serde_json::Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
            BlenderRig {
                bones: v["bones"].as_u64().unwrap_or_else(|| panic!("no bones: {line}")) as usize,
                armatures: v["armatures"].as_array().map_or(0, Vec::len),
                actions: v["actions"].as_array().map_or(0, Vec::len),
                start: v["start"].as_f64(),
                end: v["end"].as_f64(),
                fps: v["fps"].as_f64().unwrap_or(0.0),
                json: v,
            }
        })
        .collect();
    assert_eq!(reports.len(), paths.len(), "one report per file:\n{text}");
    Some(reports)
}
