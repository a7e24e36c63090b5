//! The whole pipeline for one recipe: generator → [`Skeleton`] → mesher → [`Model`].
//!
//! Pure data in, data out: reading the recipe's model files goes through
//! [`Loaded::read`]; writing outputs is the caller's (the CLI's) job.

use crate::error::{Error, Result};
use crate::lsystem::{self, DeriveOptions, LSystem, TurtleOptions};
use crate::mesh::tube::{tube_mesh, TipStyle, TubeOptions};
use crate::mesh::{Material, Model, Part};
use crate::recipe::{Generator, Loaded, LsystemGenerator, Recipe};
use crate::skeleton::{Skeleton, SkeletonStats};
use std::time::{Duration, Instant};

/// What a run built, with timings.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Derivation steps applied.
    pub steps: u32,
    /// Modules in the derived string.
    pub modules: usize,
    /// Skeleton statistics.
    pub skeleton: SkeletonStats,
    /// Axes the mesher built.
    pub axes: usize,
    /// Triangles in the model.
    pub triangles: usize,
    /// Vertices in the model.
    pub vertices: usize,
    /// Time spent deriving.
    pub derive_time: Duration,
    /// Time spent interpreting (homomorphism + turtle).
    pub interpret_time: Duration,
    /// Time spent meshing.
    pub mesh_time: Duration,
    /// Surfaces (`~x`) the model places but no `.s` file provides.
    pub missing_surfaces: Vec<String>,
}

/// The products of a run.
#[derive(Debug, Clone)]
pub struct Grown {
    /// The skeleton.
    pub skeleton: Skeleton,
    /// The meshed model.
    pub model: Model,
    /// What was built.
    pub report: Report,
}

/// The derived string of an L-system recipe, with its parsed L-system.
pub struct Derived {
    /// The parsed L-system.
    pub lsystem: LSystem,
    /// The derived module string.
    pub string: lsystem::ModuleString,
    /// Steps applied.
    pub steps: u32,
    /// The seed used.
    pub seed: u64,
    /// The evaluator after the derivation (globals, generator), for the homomorphism.
    pub evaluator: lsystem::expr::Evaluator,
}

/// Parses and derives the L-system of `g` (part of [`grow`], exposed for `sylva lsys derive`).
pub fn derive_lsystem(loaded: &Loaded, g: &LsystemGenerator) -> Result<Derived> {
    let (name, text) = loaded.read(&g.file)?;
    let defines: Vec<(String, String)> = g
        .define
        .iter()
        .map(|(k, v)| {
            let s = match v {
                toml::Value::String(s) => s.clone(),
                other => other.to_string(),
            };
            (k.clone(), s)
        })
        .collect();
    // `#include "x"` reads x next to the model (inside presets/ for presets).
    let dir = std::path::Path::new(&g.file).parent().map(|p| p.to_path_buf()).unwrap_or_default();
    let resolve = |inc: &str| -> Option<(String, String)> {
        let rel = dir.join(inc);
        loaded.read(&rel.to_string_lossy()).ok()
    };
    let ls = LSystem::parse_with(&name, &text, &defines, &resolve)?;
    let steps = g.iterations.unwrap_or(ls.derivation_length);
    // The file's `seed:` and the recipe's seed both matter (documented in docs/recipe.md).
    let seed = loaded.recipe.seed ^ ls.seed.unwrap_or(0).rotate_left(32);
    let (string, evaluator) =
        ls.derive_full(&DeriveOptions { steps, budget: g.max_modules, seed }, Vec::new())?;
    Ok(Derived { lsystem: ls, string, steps, seed, evaluator })
}

/// Runs the recipe's generator and returns its skeleton (with the report's generator
/// fields filled in).
pub fn skeleton(loaded: &Loaded, report: &mut Report) -> Result<Skeleton> {
    match &loaded.recipe.generator {
        Generator::Lsystem(g) => {
            let t = Instant::now();
            let mut d = derive_lsystem(loaded, g)?;
            report.derive_time = t.elapsed();
            report.steps = d.steps;
            report.modules = d.string.len();
            let t = Instant::now();
            let shown = d.lsystem.interpretation(&d.string, &mut d.evaluator, g.max_modules)?;
            let opts = TurtleOptions {
                angle: g.angle,
                step: g.step,
                width: g.width,
                width_factor: g.width_factor,
                ..Default::default()
            };
            let sk = lsystem::interpret(&d.lsystem.symbols, &shown, &opts, &d.lsystem.source)?;
            report.interpret_time = t.elapsed();
            Ok(sk)
        }
    }
}

/// Meshes a skeleton as the recipe's `[mesh]` section says.
pub fn mesh(recipe: &Recipe, skeleton: &Skeleton, report: &mut Report) -> Result<Model> {
    let t = Instant::now();
    let tips = match recipe.mesh.tips.as_str() {
        "flat" => TipStyle::Flat,
        "open" => TipStyle::Open,
        _ => TipStyle::Round,
    };
    let tube = tube_mesh(skeleton, &TubeOptions { sides: recipe.mesh.sides, tips, ..Default::default() })?;
    report.mesh_time = t.elapsed();
    report.axes = tube.axes;
    let mut parts = vec![Part { name: "bark".into(), mesh: tube.mesh, material: Material::bark() }];
    if !skeleton.organs.is_empty() {
        let (leaves, missing) = crate::mesh::organs::organ_mesh(skeleton, &std::collections::HashMap::new());
        report.missing_surfaces = missing;
        if leaves.face_count() > 0 {
            parts.push(Part { name: "leaves".into(), mesh: leaves, material: Material::leaf() });
        }
    }
    let model = Model { parts };
    report.triangles = model.triangle_count();
    report.vertices = model.vertex_count();
    Ok(model)
}

/// Runs the whole pipeline of a loaded recipe.
pub fn grow(loaded: &Loaded) -> Result<Grown> {
    let mut report = Report::default();
    let skeleton = skeleton(loaded, &mut report)?;
    report.skeleton = skeleton.stats();
    if report.skeleton.segments == 0 {
        return Err(Error::InvalidGeometry {
            what: format!("recipe `{}`", loaded.recipe.name),
            why: "the generator drew nothing (no `F` in the interpreted string)".into(),
        });
    }
    let model = mesh(&loaded.recipe, &skeleton, &mut report)?;
    Ok(Grown { skeleton, model, report })
}
