//! The generate stage: runs the recipe's generator (an L-system derived and
//! interpreted by the turtle, with its cpfg model folder; Weber–Penn; space
//! colonization; least-cost paths; an imported skeleton) and returns the skeleton, the
//! organs' surfaces and the generator's own branch curves.

use super::*;

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
    // cpfg defines a function set's names for `func(NAME, x)` (issue 46), so the folder
    // is read before the L-system is parsed.
    let predefined = folder.as_ref().map(ModelFolder::gallery_names).unwrap_or_default();
    let mut ls = LSystem::parse_predefined(&name, &text, &defines, &predefined, &resolve)?;
    // cpfg's generator for L-system files, sylva's for presets (issue 46 item 9).
    ls.random = g.random.generator(matches!(loaded.origin, Origin::Preset(_)), loaded.recipe.seed);
    let functions: Vec<lsystem::expr::Function> = folder
        .iter()
        .flat_map(|f| f.functions.iter())
        .map(|(_, f)| {
            let f = f.clone();
            std::sync::Arc::new(move |x: f64| f.eval(x)) as lsystem::expr::Function
        })
        .collect();
    let steps = g.iterations.unwrap_or(ls.derivation_length);
    // With sylva's generator the file's `seed:` and the recipe's seed both matter; cpfg's is
    // seeded as `ls.random` says (docs/recipe.md).
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
    warnings.extend(ls.random_notes());
    if ls.writes_files {
        warnings.push(
            "the model writes files (fopen/fprintf): sylva discards file output, as it discards printf"
                .into(),
        );
    }
    let data = data_files(loaded, &ls, include_files.as_ref(), &dir, &mut warnings)?;
    let (string, evaluator) = ls.derive_full(
        &DeriveOptions { steps, budget: g.max_modules, seed },
        lsystem::expr::ModelFunctions { functions, curves, data },
        Some(&turtle_options(g, folder.as_ref())),
        env.as_ref(),
    )?;
    let steps = evaluator.steps_done;
    Ok(Derived { lsystem: ls, string, steps, seed, evaluator, folder, warnings })
}

/// The files the model's statements read (`fopen("name", "r")`, issue 46 item 10),
/// read before the derivation: from inside the model folder (or an allowed folder)
/// only, within `input.max_bytes`; a name outside is an error naming the statement and
/// `generator.allow_paths`. A file the folder does not hold is left out (its `fopen`
/// gives −1, as in cpfg) with a warning.
fn data_files(
    loaded: &Loaded,
    ls: &LSystem,
    side: Option<&SideFiles>,
    dir: &std::path::Path,
    warnings: &mut Vec<String>,
) -> Result<lsystem::expr::files::DataFiles> {
    let mut data = lsystem::expr::files::DataFiles::new();
    for u in ls.file_uses.iter().filter(|u| u.reads()) {
        if data.contains_key(&u.name) {
            continue;
        }
        let what = format!(
            "{}:{}: `fopen(\"{}\", \"{}\")`",
            ls.source.name,
            ls.source.line_of(u.at),
            crate::input::excerpt(&u.name),
            crate::input::excerpt(&u.mode)
        );
        let bytes = match side {
            Some(side) => {
                let path = side.resolve(&u.name, &what)?;
                if path.is_file() {
                    Some(side.read(&path, &what)?)
                } else {
                    None
                }
            }
            None => loaded.read(&dir.join(&u.name).to_string_lossy()).ok().map(|(_, t)| t.into_bytes()),
        };
        match bytes {
            Some(b) => {
                data.insert(u.name.clone(), b.into());
            }
            None => warnings.push(format!(
                "{what}: the model folder holds no such file, so fopen gives -1 as in cpfg (an fscanf of it \
                 is an error)"
            )),
        }
    }
    for at in lsystem::expr::files::float_stores(&ls.source.text) {
        warnings.push(format!(
            "{}:{}: fscanf's `%f` stores a 4-byte float into an 8-byte variable, as cpfg does (the value is \
             meaningless); `%lf` reads the number",
            ls.source.name,
            ls.source.line_of(at)
        ));
    }
    Ok(data)
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
    // The view file's tropisms bend as cpfg bends (issue 46), in sylva's frame:
    // (x, y, z) = cpfg's (z, y, −x).
    let frame = |d: [f64; 3]| [d[2], d[1], -d[0]];
    if !view.tropisms.is_empty() || view.old_tropism.is_some() {
        use lsystem::turtle::movements::{CpfgTropisms, Movement, OldTropism};
        let movements = view
            .tropisms
            .iter()
            .take(lsystem::turtle::MAX_TROPISMS)
            .map(|t| Movement {
                torque: t.kind == MovementKind::Torque,
                direction: frame(t.direction.map(|c| c * t.intensity.clamp(-1.0, 1.0))),
                angle: t.angle,
                elasticity: t.elasticity,
            })
            .collect();
        let old = view.old_tropism.as_ref().map(|o| OldTropism {
            direction: frame(o.direction),
            elasticity: o.elasticity,
            increment: o.elasticity_increment,
        });
        opts.cpfg_tropisms = Some(CpfgTropisms { movements, old });
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
