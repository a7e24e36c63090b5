//! The whole pipeline for one recipe: generator → [`Skeleton`] → mesher → [`Model`].
//!
//! Pure data in, data out: reading the recipe's model files goes through
//! [`Loaded::read`]; writing outputs is the caller's (the CLI's) job.

pub mod session;
mod tree;

use crate::error::{Error, Result};
use crate::export::TextureMode;
use crate::geometry::Mesh;
use crate::input::SideFiles;
use crate::lsystem::files::view::{LineStyle, MovementKind};
use crate::lsystem::files::{folder_of, load_folder_in, ModelFolder};
use crate::lsystem::turtle::Tropism;
use crate::lsystem::{self, DeriveOptions, LSystem, TurtleOptions};
use crate::mesh::ground::SunkRoot;
use crate::model::{BranchCurves, Material, Model, Part};
use crate::recipe::{
    Generator, LeafMode, LeafNormals, Loaded, LsystemGenerator, MeshBase, MeshMethod, Origin, Recipe,
};
use crate::skeleton::{Skeleton, SkeletonStats};
use std::collections::HashMap;
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
    /// What the skeleton de-collision did (`mesh.decollide`), when it ran.
    pub decollide: Option<crate::fit::decollide::DecollideReport>,
    /// What the mesh-checked thinning did (`mesh.clear`), when it ran.
    pub clear: Option<crate::fit::clear::ClearReport>,
    /// Surfaces (`~x`) the model places but no `.s` file provides.
    pub missing_surfaces: Vec<String>,
    /// Problems that did not stop the run (printed by the CLI).
    pub warnings: Vec<String>,
    /// One line from generators other than the L-system: what they built.
    pub summary: String,
    /// Joints of the wind rig (0 without `[wind]`).
    pub joints: usize,
    /// Time spent rigging, skinning and baking the wind clip.
    pub wind_time: Duration,
    /// Work the quad mesher's repair spent in this run's meshings, against
    /// `mesh.quad.max_repair_work` (shared by every meshing of the run but the LOD
    /// levels').
    pub repair_work: u64,
    /// Wall time of each stage the last run computed, by stage name
    /// ([`crate::session::Stage::name`]); stages a session kept are not listed.
    pub stage_times: Vec<(&'static str, Duration)>,
}

/// The products of a run: the tree a recipe makes ([`Tree::to_glb`], [`Tree::write`],
/// and a `Display` summary).
#[derive(Debug, Clone)]
pub struct Tree {
    /// The skeleton.
    pub skeleton: Skeleton,
    /// The meshed model.
    pub model: Model,
    /// What was built.
    pub report: Report,
    /// The recipe it was made from.
    pub recipe: Recipe,
}

/// The former name of [`Tree`].
pub type Grown = Tree;

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
    /// The cpfg model folder's files, when they were read.
    pub folder: Option<ModelFolder>,
    /// Problems that did not stop the run.
    pub warnings: Vec<String>,
}

/// Parses and derives the L-system of `g` (part of [`grow`], exposed for `sylva lsys derive`).
/// For a model file on disk with `generator.view = "auto"`, the cpfg model folder's
/// files (view, functions, surfaces) are read too.
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
    // `#include "x"` reads x next to the model (inside presets/ for presets); on disk,
    // only from inside the model folder or a folder of `generator.allow_paths`, within
    // `input.max_bytes` (issue 39, `crate::input`).
    let dir = std::path::Path::new(&g.file).parent().map(|p| p.to_path_buf()).unwrap_or_default();
    let allow: Vec<std::path::PathBuf> = match &loaded.origin {
        Origin::Folder(d) => g.allow_paths.iter().map(|p| d.join(p)).collect(),
        Origin::Preset(_) | Origin::Memory(_) => Vec::new(),
    };
    let max_bytes = loaded.recipe.input.max_bytes;
    let include_files = match &loaded.origin {
        Origin::Folder(d) => Some(SideFiles::new(&d.join(&dir), &allow, max_bytes)),
        Origin::Preset(_) | Origin::Memory(_) => None,
    };
    let resolve = |inc: &str| -> std::result::Result<(String, String), String> {
        let Some(side) = &include_files else {
            let rel = dir.join(inc);
            return loaded.read(&rel.to_string_lossy()).map_err(|_| "no such file next to the model".into());
        };
        let what = format!("`#include \"{}\"`", crate::input::excerpt(inc));
        let path = side.resolve(inc, &what).map_err(|e| e.to_string())?;
        if !path.exists() {
            return Err("no such file next to the model".into());
        }
        let text = side.read_text(&path, &what).map_err(|e| e.to_string())?;
        Ok((path.display().to_string(), text))
    };
    let ls = LSystem::parse_with(&name, &text, &defines, &resolve)?;
    // The model folder's files are optional: a broken one is a warning, not an error;
    // a refused one (outside the folder, not a regular file, too large) is an error.
    let mut warnings = Vec::new();
    let folder = match (&loaded.origin, g.view) {
        (Origin::Folder(d), crate::recipe::ViewFiles::Auto) => match load_folder_in(
            &d.join(&g.file),
            &SideFiles::new(&folder_of(&d.join(&g.file)), &allow, max_bytes),
        ) {
            Ok(f) => Some(f),
            Err(e) if crate::input::is_refusal(&e) => return Err(e),
            Err(e) => {
                warnings.push(format!("the model folder's view/function/surface files were not used: {e}"));
                None
            }
        },
        _ => None,
    };
    let functions: Vec<lsystem::expr::Function> = folder
        .iter()
        .flat_map(|f| f.functions.iter())
        .map(|(_, f)| {
            let f = f.clone();
            std::sync::Arc::new(move |x: f64| f.eval(x)) as lsystem::expr::Function
        })
        .collect();
    let steps = g.iterations.unwrap_or(ls.derivation_length);
    // The file's `seed:` and the recipe's seed both matter (documented in docs/recipe.md).
    let seed = loaded.recipe.seed ^ ls.seed.unwrap_or(0).rotate_left(32);
    let curves =
        folder.iter().flat_map(|f| f.curves.iter()).map(|(_, c)| std::sync::Arc::new(c.clone())).collect();
    // The environment's data files (images, obstacles) are relative to the model's folder.
    let env_dir = match (&folder, &loaded.origin) {
        (Some(f), _) => f.lsystem.parent().map(|p| p.to_path_buf()).unwrap_or_default(),
        (None, Origin::Folder(d)) => d.join(&dir),
        (None, _) => dir.clone(),
    };
    let env_files = SideFiles::new(&env_dir, &allow, max_bytes);
    let env = environment(g, folder.as_ref(), &ls, &env_files, &mut warnings)?;
    if ls.writes_files {
        warnings.push(
            "the model writes files (fopen/fprintf): sylva discards file output, as it discards printf"
                .into(),
        );
    }
    let (string, evaluator) = ls.derive_full(
        &DeriveOptions { steps, budget: g.max_modules, seed },
        lsystem::expr::ModelFunctions { functions, curves },
        Some(&turtle_options(g, folder.as_ref())),
        env.as_ref(),
    )?;
    let steps = evaluator.steps_done;
    Ok(Derived { lsystem: ls, string, steps, seed, evaluator, folder, warnings })
}

/// The environmental program for the model's `?E` modules: the recipe's
/// `[generator.environment]`, else the program the model folder's `.e` file names,
/// configured from the spec file that `.e` file names (when the program is the file's)
/// with the recipe's values overriding it. `None` when neither names a program (the
/// derivation then reports `?E` as unsupported). Notes (a missing light image, unknown
/// spec keys) go to `warnings`.
fn environment(
    g: &LsystemGenerator,
    folder: Option<&ModelFolder>,
    ls: &LSystem,
    dir: &SideFiles,
    warnings: &mut Vec<String>,
) -> Result<Option<lsystem::environment::Environment>> {
    use lsystem::environment::{Environment, Overrides, Spec, PROGRAMS};
    let file_program = folder.and_then(|f| f.environment_program.as_deref());
    let recipe_program = g.environment.as_ref().and_then(|c| c.program.as_deref());
    let program = match (recipe_program, file_program) {
        (Some(p), _) | (None, Some(p)) => p,
        (None, None) => {
            // Name the model's environment file when it is the missing piece.
            let missing = folder.and_then(|f| f.environment_file.as_ref()).filter(|p| !p.is_file());
            return match (ls.environment_at, missing) {
                (Some(at), Some(file)) => {
                    let name = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                    let m = format!(
                        "unsupported: `?E` needs the environmental program of `{name}`, which is not in the model \
                         folder (sylva has: {}; choose one with --set generator.environment.program=…)",
                        PROGRAMS.join(", ")
                    );
                    Err(ls
                        .source
                        .error(lsystem::ErrorKind::Unsupported, at, 2, &m, "communication module")
                        .into())
                }
                _ => {
                    // Settings for a program nobody names are a mistake worth telling.
                    if g.environment.is_some() {
                        warnings.push(format!(
                            "[generator.environment] is set but no program is (neither generator.environment.program                              nor a model .e file names one), so its settings are not used (sylva has: {})",
                            PROGRAMS.join(", ")
                        ));
                    }
                    Ok(None)
                }
            };
        }
    };
    if !PROGRAMS.contains(&program) {
        // An unknown program is an unsupported feature of the model, named at its `?E`.
        let m =
            format!("unsupported: environmental program `{program}` (sylva has: {})", PROGRAMS.join(", "));
        return Err(match ls.environment_at {
            Some(at) => {
                ls.source.error(lsystem::ErrorKind::Unsupported, at, 2, &m, "communication module").into()
            }
            None => Error::Recipe(format!("generator.environment: {m}")),
        });
    }
    let recipe_error = |m: String| Error::Recipe(format!("generator.environment: {m}"));
    // The spec file belongs to the `.e` file's program: it is read only for that one.
    let spec_path =
        folder.and_then(|f| f.environment_spec.as_ref()).filter(|_| file_program == Some(program));
    let spec = match spec_path {
        Some(path) => {
            let e = folder.and_then(|f| f.environment_file.as_ref()).map(|p| p.display().to_string());
            let what = format!("{}: `executable:`", e.as_deref().unwrap_or_default());
            let spec = Spec::read_in(dir, path, &what).map_err(|m| {
                recipe_error(format!("{m} (the spec file of {program}, named by {})", e.unwrap_or_default()))
            })?;
            warnings.extend(spec.unknown(program));
            Some(spec)
        }
        None => None,
    };
    let over = g
        .environment
        .as_ref()
        .map(|c| Overrides {
            radius: c.radius,
            transmittance: c.transmittance,
            image: c.image.clone(),
            directions: c.directions,
            obstacles: c.obstacles.clone(),
        })
        .unwrap_or_default();
    Environment::configure_in(program, spec.as_ref(), &over, dir, warnings).map(Some).map_err(recipe_error)
}

/// Turtle options from the recipe, with the model folder's view file filling in every
/// `generator` key the recipe did not set explicitly.
pub fn turtle_options(g: &LsystemGenerator, folder: Option<&ModelFolder>) -> TurtleOptions {
    let mut opts = TurtleOptions {
        angle: g.angle,
        step: g.step,
        width: g.width,
        width_factor: g.width_factor,
        max_nodes: g.max_nodes,
        ..Default::default()
    };
    let Some(view) = folder.and_then(|f| f.view.as_ref()) else { return opts };
    // Generalized-cylinder contours (`@#`, issue 26), sampled into `contour sides` pieces.
    opts.contour_sides = view.contour_sides as usize;
    opts.twist_of_cylinders = view.twist_of_cylinders;
    for (id, c) in folder.map(|f| f.contours.as_slice()).unwrap_or_default() {
        opts.contours.push(lsystem::turtle::TurtleContour::from_contour(*id, c, opts.contour_sides));
    }
    for (id, why) in folder.map(|f| f.contour_errors.as_slice()).unwrap_or_default() {
        opts.contours.push(lsystem::turtle::TurtleContour::unusable(*id, why));
    }
    let set = |k: &str| g.explicit.iter().any(|e| e == k);
    if !set("angle") {
        opts.angle = view.angle_increment;
    }
    if !set("width") {
        opts.width = view.initial_line_width;
    }
    if !set("width_factor") && view.width_increment != 0.0 {
        opts.width_increment = Some(view.width_increment);
    }
    for t in &view.tropisms {
        if t.kind != MovementKind::Tropism || opts.tropisms.len() >= lsystem::turtle::MAX_TROPISMS {
            continue;
        }
        opts.tropisms.push(Tropism {
            direction: t.direction,
            elasticity: t.elasticity * t.intensity.clamp(-1.0, 1.0),
            angle: (t.angle != 0.0).then_some(t.angle),
        });
    }
    if let Some(old) = &view.old_tropism {
        opts.tropisms.push(Tropism { direction: old.direction, elasticity: old.elasticity, angle: None });
        opts.elasticity_increment = old.elasticity_increment;
    }
    opts
}

/// A generated skeleton and the named surfaces its organs may use.
#[derive(Debug, Clone)]
pub struct Generated {
    /// The skeleton.
    pub skeleton: Skeleton,
    /// Surface meshes by name (`~x` → "x"), in the organ frame.
    pub surfaces: HashMap<String, Mesh>,
    /// The generator's own branch curves (Weber–Penn's stems); `None`: fitted to the
    /// skeleton after the fitting stage ([`BranchCurves::fit`]).
    pub curves: Option<BranchCurves>,
}

/// Runs the recipe's generator and returns its skeleton (with the report's generator
/// fields filled in).
pub fn skeleton(loaded: &Loaded, report: &mut Report) -> Result<Generated> {
    match &loaded.recipe.generator {
        Generator::Lsystem(g) => {
            let t = Instant::now();
            let mut d = derive_lsystem(loaded, g)?;
            report.derive_time = t.elapsed();
            report.steps = d.steps;
            report.modules = d.string.len();
            report.warnings.append(&mut d.warnings);
            let t = Instant::now();
            let shown = d.lsystem.interpretation(&d.string, &mut d.evaluator, g.max_modules)?;
            let opts = turtle_options(g, d.folder.as_ref());
            let mut sk = lsystem::interpret(&d.lsystem.symbols, &shown, &opts, &d.lsystem.source)?;
            let pixel = d
                .folder
                .as_ref()
                .and_then(|f| f.view.as_ref())
                .is_some_and(|v| v.line_style == LineStyle::Pixel);
            if pixel && !g.explicit.iter().any(|k| k == "width") {
                // cpfg's pixel lines: widths are screen pixels; map one pixel to 1/500
                // of the model's size (a 500-pixel window), documented in docs/recipe.md.
                let st = sk.stats();
                let diag = (st.bounds.1 - st.bounds.0).length().max(1e-6);
                for r in &mut sk.radius {
                    *r *= diag / 500.0;
                }
            }
            report.interpret_time = t.elapsed();
            let mut surfaces = HashMap::new();
            if let Some(f) = &d.folder {
                for (name, s) in &f.surfaces {
                    surfaces.insert(name.clone(), s.tessellate(4));
                }
            }
            Ok(Generated { skeleton: sk, surfaces, curves: None })
        }
        Generator::WeberPenn(p) => {
            let tree = crate::grow::weber_penn::grow(p, loaded.recipe.seed)?;
            let r = &tree.report;
            report.interpret_time = r.elapsed;
            report.summary = format!(
                "weber-penn: stems per level {:?} (+ clones {:?}), {} leaves, in {:.1} ms",
                r.stems_per_level,
                r.clones_per_level,
                r.leaves,
                r.elapsed.as_secs_f64() * 1e3
            );
            Ok(Generated {
                curves: Some(crate::grow::weber_penn::branch_curves(&tree)),
                skeleton: tree.skeleton,
                surfaces: HashMap::new(),
            })
        }
        Generator::SpaceColonization(p) => {
            let tree = crate::grow::colonize::grow_with(p, loaded.recipe.seed, &|f: &str| loaded.read(f))?;
            let r = &tree.report;
            report.interpret_time = r.elapsed;
            report.summary = format!(
                "space colonization: {} of {} attraction points consumed in {} iterations{}, {} tips, {} leaves, in {:.1} ms",
                r.points - r.points_left,
                r.points,
                r.iterations,
                if r.stalled { " (stalled)" } else { "" },
                r.tips,
                r.leaves,
                r.elapsed.as_secs_f64() * 1e3
            );
            Ok(Generated { skeleton: tree.skeleton, surfaces: HashMap::new(), curves: None })
        }
        Generator::LeastCost(p) => {
            let base = match &loaded.origin {
                Origin::Folder(d) => Some(d.as_path()),
                Origin::Preset(_) | Origin::Memory(_) => None,
            };
            let mut tree = crate::grow::least_cost::grow(p, loaded.recipe.seed, base)?;
            let r = &tree.report;
            report.interpret_time = r.elapsed;
            report.summary = format!(
                "least-cost ({}): {} graph nodes, {} endpoints, {} tips, {} skeleton nodes{} in {:.1} ms (graph {:.1}, paths {:.1}, skeleton {:.1}){}",
                p.method,
                r.graph_nodes,
                r.endpoints,
                r.tips,
                r.nodes,
                if r.leaves > 0 { format!(", {} {}", r.leaves, p.leaves.kind) } else { String::new() },
                r.elapsed.as_secs_f64() * 1e3,
                r.graph_time.as_secs_f64() * 1e3,
                r.path_time.as_secs_f64() * 1e3,
                r.skeleton_time.as_secs_f64() * 1e3,
                if r.cache.is_empty() { String::new() } else { format!(", graph file {}", r.cache) }
            );
            report.warnings.append(&mut tree.report.warnings);
            Ok(Generated { skeleton: tree.skeleton, surfaces: HashMap::new(), curves: None })
        }
        Generator::Import(g) => {
            let t = Instant::now();
            let path = match &loaded.origin {
                Origin::Folder(d) => d.join(&g.file),
                Origin::Preset(_) | Origin::Memory(_) => std::path::PathBuf::from(&g.file),
            };
            let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
            let sk = if ext == "str" {
                let (name, text) = loaded.read(&g.file)?;
                let (symbols, string) = crate::import::cpfg_str::parse(&name, &text)?;
                report.modules = string.len();
                let opts = TurtleOptions {
                    angle: g.angle,
                    step: g.step,
                    width: g.width,
                    max_nodes: g.max_nodes,
                    // cpfg's frame (MacMurchy2004 property 10): H = +Y, L = −X, U = +Z.
                    left: lsystem::turtle::CPFG_LEFT,
                    ..Default::default()
                };
                let source = lsystem::source::Source::new(&name, "", &[])?;
                lsystem::interpret(&symbols, &string, &opts, &source)?
            } else {
                let opts = crate::import::lst::LstOptions {
                    gap: g.gap,
                    max_nodes: g.max_nodes,
                    ..Default::default()
                };
                if let Origin::Memory(_) = &loaded.origin {
                    let (name, text) = loaded.read(&g.file)?;
                    crate::import::parse_skeleton(&name, &text, &opts)?
                } else {
                    crate::import::load_skeleton_limited(&path, &opts, loaded.recipe.input.max_bytes)?
                }
            };
            report.interpret_time = t.elapsed();
            Ok(Generated { skeleton: sk, surfaces: HashMap::new(), curves: None })
        }
    }
}

/// Meshes a skeleton as the recipe's `[mesh]` section says.
pub fn mesh(
    recipe: &Recipe,
    skeleton: &Skeleton,
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> Result<Model> {
    let mut sunk_skeleton = skeleton.clone();
    let sunk = sink(recipe, &mut sunk_skeleton);
    mesh_sunk(recipe, &sunk_skeleton, &sunk, surfaces, report)
}

/// Sinks the skeleton's upright roots for a flat base (`mesh.base = "flat"`), see
/// [`crate::mesh::ground`].
fn sink(recipe: &Recipe, skeleton: &mut Skeleton) -> Vec<SunkRoot> {
    // A leaf (`mesh.method = "leaf"`) has no trunk to stand on: its base stays open.
    if recipe.mesh.base == MeshBase::Flat && recipe.mesh.method != MeshMethod::Leaf {
        crate::mesh::ground::sink_roots(skeleton)
    } else {
        Vec::new()
    }
}

/// [`mesh`] of a skeleton whose roots [`sink`] has already moved.
fn mesh_sunk(
    recipe: &Recipe,
    skeleton: &Skeleton,
    sunk: &[SunkRoot],
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> Result<Model> {
    let fitted = mesh_fitted(recipe, skeleton, report)?;
    finish(recipe, fitted, skeleton, sunk, surfaces, report)
}

/// Refines the bark's control mesh and adds the leaves: the model.
fn finish(
    recipe: &Recipe,
    fitted: Fitted,
    skeleton: &Skeleton,
    sunk: &[SunkRoot],
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> Result<Model> {
    let bark = bark_stage(recipe, fitted, sunk, report)?;
    let (mut model, card_nodes) = assemble_stage(recipe, bark, skeleton, surfaces, report);
    dress_stage(recipe, &mut model, &card_nodes, &mut crate::texture::TextureCache::default(), report)?;
    Ok(model)
}

/// The bark stage: refines the fitted control mesh as `[refine]` says (unless the
/// fitting already did), checks `mesh.max_memory`, cuts the flat base at the sunk roots
/// and scales the UVs by `textures.scale`.
pub(crate) fn bark_stage(
    recipe: &Recipe,
    fitted: Fitted,
    sunk: &[SunkRoot],
    report: &mut Report,
) -> Result<Mesh> {
    let mut bark = match fitted.refined {
        Some(refined) => refined,
        None => refine_bark(recipe, fitted.control)?,
    };
    check_mesh_memory(recipe, crate::mesh::memory::mesh_bytes(&bark), "")?;
    for (root, outcome) in sunk.iter().zip(crate::mesh::ground::cut_base(&mut bark, sunk)) {
        use crate::mesh::ground::CutOutcome;
        let why = match outcome {
            CutOutcome::Flat(_) => continue,
            CutOutcome::NothingBelow => "nothing near it reaches below its height",
            CutOutcome::Open => "the cut's loops do not close",
        };
        report.warnings.push(format!(
            "flat base: the trunk at root node {} is left as meshed ({why}); mesh.base = \"round\" keeps every mesher's own end",
            root.node
        ));
    }
    if recipe.textures.scale != 1.0 {
        if let Some(uv) = bark.uvs.as_mut() {
            uv.values.iter_mut().for_each(|t| *t *= recipe.textures.scale);
        }
    }
    Ok(bark)
}

/// The assembly stage: the bark (or leaf-mode leaf) part, the organs' meshes and the leaf
/// cards, untextured. Returns the model and the skeleton node of each leaf card.
pub(crate) fn assemble_stage(
    recipe: &Recipe,
    bark: Mesh,
    skeleton: &Skeleton,
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> (Model, Vec<u32>) {
    // The skeleton node of each leaf card, for instancing.
    let mut card_nodes = Vec::new();
    // Leaf mode (`mesh.method = "leaf"`) makes a leaf surface, not bark.
    let (name, material) = if recipe.mesh.method == MeshMethod::Leaf {
        ("leaf", Material::leaf())
    } else {
        ("bark", Material::bark())
    };
    let mut parts = vec![Part { name: name.into(), mesh: bark, material, ..Default::default() }];
    if !skeleton.organs.is_empty() {
        use crate::mesh::cards::{is_card_leaf, leaf_cards};
        let cards = recipe.leaves.mode.cards() && recipe.output.textures != TextureMode::None;
        let keep = |o: &crate::skeleton::Organ| !(cards && is_card_leaf(o));
        let (mut leaves, missing) = crate::mesh::organs::organ_mesh_where(skeleton, surfaces, keep);
        report.missing_surfaces = missing;
        let crown = recipe.leaves.normals == LeafNormals::Crown;
        if crown {
            crate::mesh::cards::bend_toward_crown(&mut leaves);
        }
        if leaves.face_count() > 0 {
            parts.push(Part {
                name: "leaves".into(),
                mesh: leaves,
                material: Material::leaf(),
                ..Default::default()
            });
        }
        if cards {
            // The cell's geometry only: the atlas itself is drawn by the texture stage.
            let atlas = crate::texture::leaf::atlas_layout(recipe.textures.atlas_size);
            let count = skeleton.organs.iter().filter(|o| is_card_leaf(o)).count();
            let (per_card, shape) = recipe.leaves.cards(count);
            let (mut mesh, nodes) = leaf_cards(skeleton, atlas.cell(shape), per_card);
            card_nodes = nodes;
            // One shared instanced shape cannot hold per-card bent normals.
            if crown && recipe.leaves.mode != LeafMode::Instanced {
                crate::mesh::cards::bend_toward_crown(&mut mesh);
            }
            if mesh.face_count() > 0 {
                let material = Material {
                    name: "leaf_card".into(),
                    double_sided: false,
                    alpha_cutoff: Some(recipe.leaves.alpha_cutoff),
                    ..Material::leaf()
                };
                parts.push(Part { name: "leaf_cards".into(), mesh, material, ..Default::default() });
            }
        }
    }
    (Model { parts, ..Default::default() }, card_nodes)
}

/// The dressing stage: textures from `cache` (drawn once per style, size and seed),
/// instancing of the leaf cards, and the report's triangle and vertex counts.
pub(crate) fn dress_stage(
    recipe: &Recipe,
    model: &mut Model,
    card_nodes: &[u32],
    cache: &mut crate::texture::TextureCache,
    report: &mut Report,
) -> Result<()> {
    texture_model(recipe, model, cache);
    if recipe.leaves.mode == LeafMode::Instanced {
        // The textured cards become one card shape and an instance per card, each on the
        // skeleton node of its first leaf.
        model.instance_cards("leaf_cards", card_nodes)?;
    }
    // Counted as drawn: every instance's shape once per instance.
    let drawn = model.flattened();
    report.triangles = drawn.triangle_count();
    report.vertices = drawn.vertex_count();
    Ok(())
}

/// The recipe as TOML for the file's metadata, without where the output goes (the same
/// tree written to two names is the same file).
pub(crate) fn provenance(recipe: &Recipe) -> Option<crate::model::Provenance> {
    let mut value = toml::Value::try_from(recipe).ok()?;
    if let Some(out) = value.get_mut("output").and_then(|o| o.as_table_mut()) {
        out.remove("file");
        out.remove("preview");
    }
    let text = toml::to_string(&value).ok()?;
    Some(crate::model::Provenance { recipe: text, seed: recipe.seed })
}

/// The texture stage (issue 23): draws the bark maps (and the leaf atlas when the model
/// has leaf cards) from the recipe's seed and points the materials at them. Nothing is
/// drawn for `output.textures = "none"`.
fn texture_model(recipe: &Recipe, model: &mut Model, cache: &mut crate::texture::TextureCache) {
    use crate::model::ModelImage;
    use crate::texture::bark;
    if recipe.output.textures == TextureMode::None {
        return;
    }
    let style = recipe.textures.bark.unwrap_or(match recipe.generator {
        crate::recipe::Generator::LeastCost(_) => bark::BarkStyle::Smooth,
        _ => bark::BarkStyle::Furrowed,
    });
    let cards = model.parts.iter().position(|p| p.name == "leaf_cards");
    // A model without bark (a leaf-mode leaf, a cpfg model of organs only) gets no bark
    // maps: nothing would use them.
    let has_bark = model.parts.iter().any(|p| p.name == "bark");
    let colour = {
        let c = crate::model::Material::leaf().base_color;
        [c[0], c[1], c[2]]
    };
    let (maps, atlas) = cache.get(
        has_bark.then_some((style, recipe.textures.bark_size, recipe.seed)),
        cards.map(|_| (recipe.textures.atlas_size, colour, recipe.seed)),
    );
    if let Some(maps) = maps {
        let first = model.images.len() as u32;
        for (name, image) in
            [("bark_albedo", maps.albedo), ("bark_normal", maps.normal), ("bark_orm", maps.orm)]
        {
            model.images.push(ModelImage { name: name.into(), image, repeat: true });
        }
        for part in model.parts.iter_mut().filter(|p| p.name == "bark") {
            part.material.maps = crate::model::MaterialMaps {
                base_color: Some(first),
                normal: Some(first + 1),
                occlusion_roughness_metallic: Some(first + 2),
            };
        }
    }
    if let (Some(i), Some(atlas)) = (cards, atlas) {
        let index = model.images.len() as u32;
        model.images.push(ModelImage { name: "leaf_atlas".into(), image: atlas.image, repeat: false });
        model.parts[i].material.maps.base_color = Some(index);
    }
}

/// The bark's control mesh of `skeleton` by the recipe's mesher (its warnings and axis
/// count go to `report`).
fn control_mesh(recipe: &Recipe, skeleton: &Skeleton, report: &mut Report) -> Result<Mesh> {
    let mut mesher = recipe.mesh.mesher();
    if let crate::mesh::Mesher::Quad(q) = &mut mesher {
        // One repair budget for every meshing of the run (the clearing meshes once a
        // round): what is left of it, at least 1 (the smallest value the mesher takes;
        // its next repair then stops with the budget's error).
        q.max_repair_work = q.max_repair_work.saturating_sub(report.repair_work).max(1);
        // The level-2 repair costs seconds per 10 k nodes: above the de-collision limit
        // (where the skeleton is not de-collided either) the cage is left as built.
        if skeleton.len() > crate::recipe::DECOLLIDE_AUTO_NODES {
            q.repair_rounds = 0;
            report.warnings.push(format!(
                "quad mesher: level-2 repair skipped on {} skeleton nodes (over the automatic limit of {}; the cage may cross itself after subdivision)",
                skeleton.len(),
                crate::recipe::DECOLLIDE_AUTO_NODES
            ));
        }
    }
    let cage = mesher.cage(skeleton)?;
    report.repair_work = report.repair_work.saturating_add(cage.work);
    report.axes = cage.axes;
    report.warnings.extend(cage.warnings);
    Ok(cage.mesh)
}

/// Subdivides the bark control mesh as `[refine]` says (unchanged for `none` or 0 levels).
fn refine_bark(recipe: &Recipe, mesh: Mesh) -> Result<Mesh> {
    use crate::refine::{subdivide, RefineOptions, SubdivideOptions};
    let Some(scheme) = recipe.refine_scheme() else { return Ok(mesh) };
    if recipe.refine.levels == 0 && !recipe.refine.limit {
        return Ok(mesh);
    }
    let opts = SubdivideOptions {
        refine: RefineOptions {
            scheme,
            levels: recipe.refine.levels,
            max_faces: recipe.refine.max_faces,
            max_memory: recipe.refine.max_memory,
            boundary: recipe.refine_boundary(),
            ..Default::default()
        },
        limit: recipe.refine.limit,
        ..Default::default()
    };
    // Without `limit` the result has no normals; the exporters compute smooth ones.
    subdivide(&mesh, &[], &opts).map_err(|e| refine_budget(recipe, e))
}

/// A `[refine]` face- or memory-budget error as a message naming `refine.max_faces` or
/// `refine.max_memory` and `refine.levels`; other refinement errors unchanged.
fn refine_budget(recipe: &Recipe, e: crate::refine::RefineError) -> Error {
    match e {
        crate::refine::RefineError::Budget { levels, faces, limit } => Error::Recipe(format!(
            "`refine.max_faces`: {levels} levels of subdivision would make {faces} faces, more than the face \
             budget of {limit} (use fewer `refine.levels`, or raise the budget with --set refine.max_faces=N; \
             a refined face costs about 200 bytes at the refinement's peak)"
        )),
        crate::refine::RefineError::Memory { levels, faces, bytes, limit } => Error::Recipe(format!(
            "`refine.max_memory`: {levels} levels of subdivision (`refine.levels`) would make {faces} faces and \
             need about {bytes} bytes at the refinement's peak, more than the memory budget of {limit} bytes \
             (use fewer `refine.levels`, or raise the budget with --set refine.max_memory=N if the machine \
             has the memory)"
        )),
        crate::refine::RefineError::OutOfMemory { what, bytes } => Error::Recipe(format!(
            "`refine.max_memory`: the subdivision (`refine.levels` = {}) ran out of memory: its {what} need {bytes} \
             bytes, which the system could not allocate (use fewer `refine.levels`, or lower \
             refine.max_memory to what the machine has so the budget stops it first)",
            recipe.refine.levels
        )),
        e => e.into(),
    }
}

/// Pulls apart the skeleton's crossing branches before meshing (`mesh.decollide`), and
/// warns about the collisions it could not resolve.
pub fn decollide_skeleton(recipe: &Recipe, skeleton: &mut Skeleton, report: &mut Report) -> Result<()> {
    let r = crate::fit::decollide::decollide(skeleton, &recipe.fit.decollide)?;
    if r.after > 0 {
        report.warnings.push(format!(
            "decollide: {} of {} skeleton collision(s) left; the mesh will intersect itself there (first internode pairs, by child node: {:?})",
            r.after,
            r.before,
            &r.unresolved[..r.unresolved.len().min(4)]
        ));
    }
    report.decollide = Some(r);
    Ok(())
}

/// A control mesh the fitting stage already made, with its refinement when that is the
/// one `[refine]` asks for.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The bark's control mesh of the skeleton the fitting left.
    pub control: Mesh,
    /// `control` refined exactly as `[refine]` says (levels ≤ 3, no limit), or `None`.
    pub refined: Option<Mesh>,
}

/// Thins the skeleton where the recipe's mesh, refined as `[refine]` says (the control
/// mesh itself for `refine.scheme = "none"`), still crosses itself (`mesh.clear`, see
/// [`crate::fit::clear`]), and warns about what is left. Returns the control mesh of the
/// skeleton it leaves when that was the last one meshed (its axes, warnings and meshing
/// time then go to `report`) and the refinement it searched when `[refine]` asks for the
/// same one, so the caller need not mesh or refine it again.
pub fn clear_skeleton(
    recipe: &Recipe,
    skeleton: &mut Skeleton,
    report: &mut Report,
) -> Result<Option<Fitted>> {
    use crate::fit::clear::{clear_crossings_refined, ClearOptions};
    use crate::refine::Scheme;
    let (scheme, levels) = match recipe.refine_scheme() {
        Some(scheme) => (scheme, recipe.refine.levels.min(3)),
        None => (Scheme::Loop, 0),
    };
    // The refinement searched stays within `[refine]`'s face budget too.
    let max_faces = recipe.fit.clear.max_faces.min(recipe.refine.max_faces);
    let opts =
        ClearOptions { levels, max_faces, boundary: recipe.refine_boundary(), ..recipe.fit.clear.clone() };
    // The clearing's refinement is the output's when it has the same scheme and levels
    // and no limit step (the same `subdivide` call, so the same bytes).
    let reusable = recipe.refine_scheme().is_some()
        && levels == recipe.refine.levels
        && levels > 0
        && !recipe.refine.limit;
    // The last meshing's report and the radii it was made with.
    let mut last: Option<(Report, Vec<f32>)> = None;
    // The quad repair's budget is shared by every meshing of the pass.
    let mut repair_work = report.repair_work;
    // The repair work of the last meshing: the next one needs about as much.
    let mut last_work = 0u64;
    let cleared = clear_crossings_refined(skeleton, &opts, |s| {
        let left = recipe.mesh.quad.max_repair_work.saturating_sub(repair_work);
        if last_work > left {
            // Stop before a meshing that would run out of budget part way (a 15 k-node
            // quad meshing takes seconds): the same error, one meshing earlier.
            return Err(Error::Recipe(format!(
                "`mesh.quad.max_repair_work`: the mesh clearing's next quad meshing needs about {last_work} units \
                 of repair work (as much as its last), more than the {left} left of the budget of {} (one \
                 budget serves all the meshings of a run); raise it with --set mesh.quad.max_repair_work=N, \
                 lower mesh.quad.repair_rounds or fit.clear.max_rounds, or turn the clearing off with \
                 mesh.clear = false",
                recipe.mesh.quad.max_repair_work
            )));
        }
        let t = Instant::now();
        let mut own = Report { repair_work, ..Report::default() };
        let mesh = control_mesh(recipe, s, &mut own)?;
        last_work = own.repair_work - repair_work;
        repair_work = own.repair_work;
        own.mesh_time = t.elapsed();
        last = Some((own, s.radius.clone()));
        Ok((mesh, scheme))
    })?;
    report.repair_work = repair_work;
    let r = cleared.report;
    match (r.before, r.after) {
        (None, _) => report.warnings.push(format!(
            "mesh clearing skipped: the refined mesh would have over {} faces",
            opts.max_faces
        )),
        (_, Some(left)) if left > 0 => report.warnings.push(format!(
            "mesh clearing: {}{left} crossing face pair(s) left after {} round(s); the surface intersects itself near internodes {:?}",
            if r.truncated { "at least " } else { "" },
            r.rounds,
            r.unresolved
        )),
        _ => {}
    }
    report.clear = Some(r);
    match last {
        Some((own, radius)) if radius == skeleton.radius => {
            report.axes = own.axes;
            report.mesh_time = own.mesh_time;
            report.warnings.extend(own.warnings);
            let refined = cleared.refined.filter(|_| reusable);
            Ok(Some(Fitted { control: cleared.control, refined }))
        }
        _ => Ok(None),
    }
}

/// The wind stage (issue 24): with `wind.preset` other than `none`, a rig of joints
/// chosen from the branch curves, skin weights and wind channels on every part of every
/// level, and a looping clip baked from the wind (see [`crate::wind`]).
pub fn wind_stage(recipe: &Recipe, model: &mut Model, report: &mut Report) {
    if let Some(plan) = rig_stage(recipe, model, report) {
        clip_stage(recipe, &plan, model, report);
    }
}

/// The rig half of [`wind_stage`]: joints from the branch curves within
/// `wind.max_joints`, skin weights and wind channels (`wind.leaf_flutter`) on every
/// part. Reads no other wind setting. `None` without wind.
pub(crate) fn rig_stage(
    recipe: &Recipe,
    model: &mut Model,
    report: &mut Report,
) -> Option<crate::wind::JointPlan> {
    recipe.wind.options()?;
    let t = Instant::now();
    let plan = crate::wind::JointPlan::new(&model.curves, recipe.wind.max_joints as usize);
    crate::wind::rig_model(model, &plan, recipe.wind.leaf_flutter as f32);
    report.joints = plan.rig.joints.len();
    report.wind_time = t.elapsed();
    Some(plan)
}

/// The clip half of [`wind_stage`]: the looping clip baked from the wind's preset,
/// strength, direction, gusts and stiffness over the rig `plan`.
pub(crate) fn clip_stage(
    recipe: &Recipe,
    plan: &crate::wind::JointPlan,
    model: &mut Model,
    report: &mut Report,
) {
    let Some(wind) = recipe.wind.options() else { return };
    let t = Instant::now();
    model.clip = Some(crate::wind::bake_clip(plan, &wind, recipe.wind.clip_seconds, recipe.wind.fps));
    report.wind_time += t.elapsed();
}

/// The optional skeleton passes of McLoughlin2021 §4.2 before fitting: overlap pruning
/// (`mesh.prune_overlaps`, [`crate::fit::overlap`]) and then leaves by level
/// (`[leaves] place`, [`crate::fit::leaves`]), so pruned branches get no leaves.
pub fn shape_stage(recipe: &Recipe, skeleton: &mut Skeleton, report: &mut Report) -> Result<()> {
    if recipe.mesh.prune_overlaps == Some(true) {
        let (pruned, r) = crate::fit::overlap::prune_overlaps(skeleton, 0.0);
        if r.pairs > 0 {
            report.warnings.push(format!(
                "prune_overlaps: {} overlapping internode pair(s); {} subtree(s) with {} node(s) and {} organ(s) pruned",
                r.pairs,
                r.pruned.len(),
                r.removed,
                r.organs_removed
            ));
        }
        *skeleton = pruned;
    }
    if let Some(p) = recipe.leaves.placement(recipe.seed)? {
        crate::fit::leaves::place_leaves(skeleton, &p);
    }
    Ok(())
}

/// Runs the whole pipeline of a loaded recipe: a [`crate::session::Session`] that keeps
/// no stage, run once.
pub fn grow(loaded: &Loaded) -> Result<Tree> {
    let mut session = crate::session::Session::new(loaded.clone()).keep_stages(false);
    session.run()?;
    Ok(session.into_tree().expect("a successful run leaves a tree"))
}

/// The fitting stage on the generated `skeleton`: overlap pruning and leaf placement
/// ([`shape_stage`]), the degeneracy and memory checks, de-collision, the flat base's
/// sinking and the mesh-checked clearing. Returns the sunk roots and the clearing's
/// last meshing, when it is the skeleton's.
pub(crate) fn fit_stage(
    recipe: &Recipe,
    skeleton: &mut Skeleton,
    report: &mut Report,
) -> Result<(Vec<SunkRoot>, Option<Fitted>)> {
    shape_stage(recipe, skeleton, report)?;
    report.skeleton = skeleton.stats();
    check_degenerate(recipe, skeleton)?;
    if recipe.mesh.decollides_nodes(skeleton.len()) {
        decollide_skeleton(recipe, skeleton, report)?;
    } else if recipe.mesh.decollides() {
        report.warnings.push(format!(
            "decollide skipped: {} skeleton nodes is over the automatic limit of {} (the pass would take many seconds); set mesh.decollide = true to run it",
            skeleton.len(),
            crate::recipe::DECOLLIDE_AUTO_NODES
        ));
    }
    if report.skeleton.segments == 0 && skeleton.organs.is_empty() {
        return Err(Error::InvalidGeometry {
            what: format!("recipe `{}`", recipe.name),
            why: "the generator drew nothing (no `F` and no organ in the interpreted string)".into(),
        });
    }
    check_mesh_memory(recipe, mesh_lower_bound(recipe, skeleton)?, "at least")?;
    // The roots sink for a flat base before the fitting stage meshes the skeleton, and
    // come back up once the model is built.
    let sunk = sink(recipe, skeleton);
    let cleared = if recipe.mesh.clears_nodes(skeleton.len()) {
        clear_skeleton(recipe, skeleton, report)?
    } else {
        None
    };
    Ok((sunk, cleared))
}

/// The bark's control mesh of a fitted skeleton (the clearing did not leave one), with
/// its meshing time in `report`.
pub(crate) fn mesh_fitted(recipe: &Recipe, skeleton: &Skeleton, report: &mut Report) -> Result<Fitted> {
    let t = Instant::now();
    let control = control_mesh(recipe, skeleton, report)?;
    report.mesh_time = t.elapsed();
    Ok(Fitted { control, refined: None })
}

/// [`crate::mesh::memory::lower_bound_bytes`] of the bark the recipe's mesher makes of
/// `skeleton` (rings of `mesh.sides` for the tube and hull meshers, of 4 for the others).
fn mesh_lower_bound(recipe: &Recipe, skeleton: &Skeleton) -> Result<u128> {
    use crate::mesh::Mesher;
    let sides = match recipe.mesh.mesher() {
        Mesher::Tube(o) => o.sides,
        Mesher::Hull(o) => o.sides,
        _ => 4,
    };
    let internodes = skeleton.parent.iter().filter(|&&p| p != crate::skeleton::NO_PARENT).count();
    Ok(crate::mesh::memory::lower_bound_bytes(internodes, sides))
}

/// Refuses a bark mesh of `bytes` bytes (`qualifier`: "at least" for the estimate made
/// before meshing) whose estimated downstream peak is over `mesh.max_memory`.
fn check_mesh_memory(recipe: &Recipe, bytes: u128, qualifier: &str) -> Result<()> {
    let peak = crate::mesh::memory::downstream_peak(bytes, &recipe.textures);
    if peak <= recipe.mesh.max_memory as u128 {
        return Ok(());
    }
    let size_key = match &recipe.generator {
        Generator::Lsystem(_) => "fewer derivation steps (`generator.iterations`, `-n`)",
        Generator::Import(_) => "a smaller skeleton",
        _ => "a smaller tree (the generator's level and branch counts)",
    };
    let qualifier = if qualifier.is_empty() { String::new() } else { format!("{qualifier} ") };
    Err(Error::Recipe(format!(
        "`mesh.max_memory`: the bark mesh of recipe `{}` takes {qualifier}{bytes} bytes and the stages after \
         meshing (the flat-base cut, the exporters, the preview) would need about {peak} bytes, more than the \
         memory budget of {} bytes (use {size_key}, fewer `mesh.sides` or `refine.levels`, or raise the \
         budget with --set mesh.max_memory=N if the machine has the memory)",
        recipe.name, recipe.mesh.max_memory
    )))
}

/// Rejects degenerate geometry before the expensive stages (issue 39): a radius over
/// [`crate::skeleton::ABSURD_RADIUS_RATIO`] times the skeleton's size (every capsule would
/// hold the whole tree: `generator.width = 1e30`), and, when a stage that searches for
/// collisions will run (`mesh.decollide`, `mesh.clear`, the `sweep`, `hull` and `quad`
/// meshers' repairs), a skeleton whose internode capsules overlap in more candidate
/// pairs than [`crate::skeleton::Degeneracy::crowded_limit`] (coincident nodes,
/// zero-length or reversing internodes piled up, radii too large for the lengths):
/// those searches are quadratic in such a pile. The message names the first offending
/// node and the key to change. Counting stops at the limit, so the check costs a BVH
/// over the internodes at most.
pub fn check_degenerate(recipe: &Recipe, skeleton: &Skeleton) -> Result<()> {
    use crate::skeleton::Degeneracy;
    let n = skeleton.len();
    let method = recipe.mesh.method;
    let searching = recipe.mesh.decollides_nodes(n) || recipe.mesh.clears_nodes(n) || method.joins();
    let internodes = skeleton.parent.iter().filter(|&&p| p != crate::skeleton::NO_PARENT).count();
    let d = crate::fit::degenerate::degeneracy(
        skeleton,
        if searching { Degeneracy::crowded_limit(internodes) } else { 0 },
    );
    let what = format!("the skeleton of recipe `{}`", recipe.name);
    let radius_key = match &recipe.generator {
        Generator::Lsystem(_) => "`generator.width` (or the model's own width changes)",
        Generator::Import(_) => "the file's radii",
        _ => "the generator's radius settings",
    };
    if let Some((node, r)) = d.absurd_radius() {
        return Err(Error::InvalidGeometry {
            what,
            why: format!(
                "node {node} has radius {r:.3e}, over {} times the size of the whole skeleton ({:.3e}, the \
                 diagonal of its nodes' bounds): every internode would be a ball holding the tree; lower \
                 {radius_key}",
                crate::skeleton::ABSURD_RADIUS_RATIO,
                d.size
            ),
        });
    }
    if searching && d.crowded() {
        let mut causes = Vec::new();
        if let Some(i) = d.first_zero_length {
            causes.push(format!("{} zero-length internode(s), the first ending at node {i}", d.zero_length));
        }
        if let Some(i) = d.first_reversing {
            causes.push(format!(
                "{} internode(s) turning straight back along their parent, the first ending at node {i}",
                d.reversing
            ));
        }
        if causes.is_empty() {
            causes.push("nodes (near-)coincident or radii large for the lengths".into());
        }
        let limit = Degeneracy::crowded_limit(internodes);
        let pile = if d.pairs > limit {
            let busiest = d
                .busiest
                .map(|(i, m)| format!("; the internode ending at node {i} overlaps {m} others"))
                .unwrap_or_default();
            format!(
                "the capsules of its {internodes} internodes overlap in more than {limit} pairs (over {} per \
                 internode{busiest})",
                crate::skeleton::CROWDED_PAIRS_PER_INTERNODE
            )
        } else {
            format!("{} of its {internodes} internodes have zero length", d.zero_length)
        };
        return Err(Error::InvalidGeometry {
            what,
            why: format!(
                "degenerate geometry: {pile}: {}. The collision searches of `mesh.method = \"{method}\"` (and of \
                 mesh.decollide and mesh.clear) are quadratic in such a pile; merge the coincident nodes, lower \
                 {radius_key}, or mesh it with mesh.method = \"tube\", mesh.decollide = false and \
                 mesh.clear = false",
                causes.join(", ")
            ),
        });
    }
    Ok(())
}

/// The LOD stage (issue 24, `[lod]`): builds the chain of [`crate::lod::build_chain`]
/// and puts it into the model (LOD0 replaces the parts, LOD1…n and the impostor go to
/// [`Model::lods`]). Each level re-meshes the pruned skeleton through [`mesh`] with the
/// recipe's `mesh.sides`, `[refine]` and `leaves.per_card` changed as the level asks,
/// and without drawing textures (`output.textures = "none"`): the levels take the full
/// model's materials and maps, so the leaf cards are cut here, from the full atlas's
/// layout, as the finishing step cuts them. Returns what each level is (nothing without
/// `[lod]`); its warnings go to `report`, whose triangle and vertex counts become
/// LOD0's.
pub fn lod_stage(
    loaded: &Loaded,
    skeleton: &Skeleton,
    surfaces: &HashMap<String, Mesh>,
    model: &mut Model,
    report: &mut Report,
) -> Result<Vec<crate::lod::LevelReport>> {
    use crate::mesh::cards::{bend_toward_crown, is_card_leaf, leaf_cards};
    let recipe = &loaded.recipe;
    if !recipe.lod.enabled() {
        return Ok(Vec::new());
    }
    recipe.lod.check()?;
    let cards = recipe.leaves.mode.cards() && recipe.output.textures != TextureMode::None;
    let card_leaves = skeleton.organs.iter().filter(|o| is_card_leaf(o)).count();
    let refine_levels = match recipe.refine_scheme() {
        Some(_) => recipe.refine.levels.min(6),
        None => 0,
    };
    let opts = crate::lod::LodOptions {
        budgets: recipe.lod.levels.clone(),
        impostor: recipe.lod.impostor,
        atlas_frames: recipe.lod.atlas_frames,
        atlas_size: recipe.lod.atlas_size,
        sides: recipe.mesh.sides.max(crate::mesh::tube::MIN_SIDES),
        min_sides: crate::mesh::tube::MIN_SIDES,
        refine_factor: 4u32.pow(refine_levels),
        per_card: if cards && card_leaves > 0 { recipe.leaves.cards(card_leaves).0 as u32 } else { 0 },
    };
    let mut warnings: Vec<String> = Vec::new();
    let mut remesh = |sk: &Skeleton, s: &crate::lod::LevelSettings| -> Result<Model> {
        let mut r = recipe.clone();
        r.mesh.sides = s.sides;
        if !s.refine {
            r.refine.levels = 0;
            r.refine.limit = false;
        }
        r.output.textures = TextureMode::None;
        r.leaves.mode = LeafMode::Cards;
        // The cards are cut below; `mesh` makes the bark and any other organs.
        let mut bare = sk.clone();
        if cards {
            bare.organs.retain(|o| !is_card_leaf(o));
        }
        let mut own = Report::default();
        let mut level = mesh(&r, &bare, surfaces, &mut own)?;
        warnings.append(&mut own.warnings);
        if cards {
            let mut leaves = recipe.leaves.clone();
            leaves.per_card = s.per_card;
            let (per_card, shape) = leaves.cards(card_leaves);
            let atlas = crate::texture::leaf::atlas_layout(recipe.textures.atlas_size);
            let (mut m, _) = leaf_cards(sk, atlas.cell(shape), per_card);
            if recipe.leaves.normals == LeafNormals::Crown {
                bend_toward_crown(&mut m);
            }
            if m.face_count() > 0 {
                level.parts.push(Part::new("leaf_cards", m, Material::leaf()));
            }
        }
        Ok(level)
    };
    let chain = crate::lod::build_chain(model, skeleton, &opts, &mut remesh)?;
    for w in warnings.into_iter().chain(chain.warnings.iter().cloned()) {
        if !report.warnings.contains(&w) {
            report.warnings.push(w);
        }
    }
    let levels = chain.levels.clone();
    chain.apply(model)?;
    // The report counts what the file shows first: LOD0.
    let drawn = model.flattened();
    report.triangles = drawn.triangle_count();
    report.vertices = drawn.vertex_count();
    Ok(levels)
}
