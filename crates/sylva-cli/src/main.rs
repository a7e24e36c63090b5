//! `sylva`: the command-line front end of the sylva engine.
//!
//! A thin layer over `sylva::recipe` and `sylva::pipeline`: it parses flags into recipe
//! keys, runs the pipeline, writes the outputs and reports errors with `miette`.

#![warn(missing_docs)]

mod check_cmd;
mod curves_cmd;
mod subdivide;

use clap::{Parser, Subcommand};
use miette::{IntoDiagnostic, Result};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use sylva::recipe::{self, Generator};

/// Procedural trees and plants: L-systems → skeletons → meshes → glTF / OBJ / PLY.
#[derive(Parser, Debug)]
#[command(name = "sylva", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Grow a tree from a preset, a recipe (.toml) or a model file (.l) and write it.
    Grow(GrowArgs),
    /// List every embedded preset with a one-line description.
    Presets,
    /// Render a magnetic-curves composition (seed 004 ch. 7) to SVG or PNG.
    Curves(curves_cmd::CurvesArgs),
    /// Subdivide a control mesh (OBJ) with Loop or Catmull–Clark.
    Subdivide(subdivide::SubdivideArgs),
    /// Check a mesh file (OBJ, glTF, GLB): manifold, oriented, boundaries, self-intersections.
    Check(check_cmd::CheckArgs),
    /// L-system tools.
    Lsys {
        #[command(subcommand)]
        command: LsysCommand,
    },
}

#[derive(clap::Args, Debug)]
struct GrowArgs {
    /// Preset name, recipe file (.toml), L-system file (.l), or a skeleton file (.lst,
    /// CPFG string .str, sylva .skel.json). Default: the default preset.
    what: Option<String>,
    /// Output file; the extension picks the format (.glb, .gltf, .obj, .ply; .lst or
    /// .skel.json for the skeleton). Recipe key `output.file`.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Write a preview PNG here. Default: next to the output, with a .png extension.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Do not write a preview.
    #[arg(long, conflicts_with = "preview")]
    no_preview: bool,
    /// Preview width and height in pixels (recipe key `output.preview_size`).
    #[arg(long, value_name = "PIXELS")]
    preview_size: Option<u32>,
    /// Derivation steps (recipe key `generator.iterations`).
    #[arg(short = 'n', long)]
    iterations: Option<u32>,
    /// Random seed (recipe key `seed`).
    #[arg(long)]
    seed: Option<u64>,
    /// Set any recipe key: `--set generator.angle=22.5 --set mesh.sides=6`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Wind preset (`none`, `calm`, `breeze`, `storm`): a skinned rig, a looping clip and
    /// wind shader channels in the output (recipe key `wind.preset`; docs/wind.md).
    #[arg(long, value_name = "PRESET")]
    wind: Option<String>,
    /// Levels of detail as triangle budgets, LOD0 first, optionally ending in
    /// `impostor`: `--lod 30000,8000,2000,impostor` (recipe table `[lod]`; docs/lod.md).
    #[arg(long, value_name = "BUDGETS")]
    lod: Option<String>,
    /// Render one loop of the wind clip with the CPU preview to an animated GIF (`.gif`)
    /// or PNG (`.png`); turns on `--wind breeze` unless a wind preset is set.
    #[arg(long, value_name = "FILE")]
    preview_wind: Option<PathBuf>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// `--lod 30000,8000,2000,impostor` as recipe overrides (`lod.levels`, `lod.impostor`).
fn lod_overrides(spec: &str) -> Result<Vec<(String, toml::Value)>> {
    let mut levels = Vec::new();
    let mut impostor = false;
    for (i, item) in spec.split(',').map(str::trim).enumerate() {
        if item.eq_ignore_ascii_case("impostor") {
            impostor = true;
        } else if impostor {
            return Err(miette::miette!("--lod {spec}: `impostor` must come last (item {})", i + 1));
        } else {
            let n: u32 = item.replace('_', "").parse().map_err(|_| {
                miette::miette!(
                    "--lod {spec}: item {} (`{item}`) is neither a triangle budget nor `impostor`",
                    i + 1
                )
            })?;
            levels.push(toml::Value::Integer(n.into()));
        }
    }
    Ok(vec![
        ("lod.levels".into(), toml::Value::Array(levels)),
        ("lod.impostor".into(), toml::Value::Boolean(impostor)),
    ])
}

#[derive(Subcommand, Debug)]
enum LsysCommand {
    /// Print the derived module string of an L-system.
    Derive {
        /// L-system file (.l), recipe (.toml) or preset name.
        what: String,
        /// Derivation steps (default: the file's derivation length).
        #[arg(short = 'n', long)]
        iterations: Option<u32>,
        /// Random seed.
        #[arg(long)]
        seed: Option<u64>,
        /// Set any recipe key.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
}

fn main() -> ExitCode {
    // Long messages stay on one line so they can be searched and copied whole.
    let _ =
        miette::set_hook(Box::new(|_| Box::new(miette::MietteHandlerOpts::new().wrap_lines(false).build())));
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Grow(args) => grow(args),
        Command::Subdivide(args) => subdivide::run(args),
        Command::Check(args) => check_cmd::run(args),
        Command::Curves(args) => curves_cmd::run(args),
        Command::Presets => {
            for p in sylva::presets::all() {
                println!("{:<24} {}", p.name, p.description());
            }
            Ok(())
        }
        Command::Lsys { command: LsysCommand::Derive { what, iterations, seed, sets } } => {
            derive(&what, iterations, seed, &sets)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e:?}");
            ExitCode::FAILURE
        }
    }
}

/// Collects flags and `--set` pairs into recipe overrides, flags last so they win.
fn overrides(
    sets: &[String],
    iterations: Option<u32>,
    seed: Option<u64>,
    output: Option<&Path>,
) -> Result<Vec<(String, toml::Value)>> {
    let mut v = Vec::new();
    for s in sets {
        v.push(recipe::parse_set(s)?);
    }
    if let Some(n) = iterations {
        v.push(("generator.iterations".into(), toml::Value::Integer(n.into())));
    }
    if let Some(s) = seed {
        let s =
            i64::try_from(s).map_err(|_| miette::miette!("--seed {s} is too large (max {})", i64::MAX))?;
        v.push(("seed".into(), toml::Value::Integer(s)));
    }
    if let Some(o) = output {
        v.push(("output.file".into(), toml::Value::String(o.display().to_string())));
    }
    Ok(v)
}

fn grow(args: GrowArgs) -> Result<()> {
    let what = args.what.clone().unwrap_or_else(|| sylva::presets::DEFAULT_PRESET.to_string());
    let mut sets = overrides(&args.sets, args.iterations, args.seed, args.output.as_deref())?;
    if let Some(px) = args.preview_size {
        sets.push(("output.preview_size".into(), toml::Value::Integer(px.into())));
    }
    if let Some(w) = &args.wind {
        sets.push(("wind.preset".into(), toml::Value::String(w.clone())));
    }
    if let Some(l) = &args.lod {
        sets.extend(lod_overrides(l)?);
    }
    if let Some(p) = &args.preview_wind {
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if !["gif", "png", "apng"].contains(&ext.as_str()) {
            return Err(miette::miette!(
                "--preview-wind {}: `.{ext}` is not an animation format; use .gif or .png (APNG)",
                p.display()
            ));
        }
    }
    let mut loaded = recipe::load(&what, &sets)?;
    if args.preview_wind.is_some() && !loaded.recipe.wind.enabled() {
        sets.push(("wind.preset".into(), toml::Value::String("breeze".into())));
        loaded = recipe::load(&what, &sets)?;
    }
    let out = PathBuf::from(&loaded.recipe.output.file);
    // `.lst` and `.json` outputs are skeletons; anything else must be a mesh format.
    let ext = out.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let skeleton_out = ext == "lst" || ext == "json";
    if !skeleton_out {
        // Fail on a bad extension before doing any work.
        sylva::export::Format::from_path(&out)?;
    }
    let preview = if args.no_preview {
        None
    } else if let Some(p) = args.preview {
        Some(p)
    } else if let Some(p) = &loaded.recipe.output.preview {
        Some(PathBuf::from(p))
    } else {
        Some(out.with_extension("png"))
    };
    let grown = sylva::pipeline::grow(&loaded)?;
    for w in &grown.report.warnings {
        eprintln!("warning: {w}");
    }
    if !grown.report.missing_surfaces.is_empty() {
        eprintln!("warning: no surface file for {}", grown.report.missing_surfaces.join(", "));
    }
    if skeleton_out {
        sylva::export::skeleton::write(&grown.skeleton, &out)?;
    } else {
        let opts = loaded.recipe.output.export_options(&out)?;
        sylva::export::write_with_options(&grown.model, &out, &opts)?;
    }
    if let Some(p) = &preview {
        let size = loaded.recipe.output.preview_size;
        let opts = sylva::preview::PreviewOptions { width: size, height: size, ..Default::default() };
        let img = sylva::preview::render(&grown.model, &opts)?;
        sylva::preview::write_png(&img, p)?;
    }
    if let Some(p) = &args.preview_wind {
        let size = loaded.recipe.output.preview_size.min(512);
        let opts = sylva::preview::PreviewOptions { width: size, height: size, ..Default::default() };
        let fps = 15;
        let frames = sylva::animation::wind_frames(&grown.model, &opts, fps)?;
        sylva::animation::write_animation(&frames, fps, p)?;
    }
    if !args.quiet {
        let r = &grown.report;
        let s = &r.skeleton;
        println!("{}: {}", loaded.recipe.name, loaded.recipe.description);
        if r.summary.is_empty() {
            println!(
                "  derived {} steps, {} modules in {:.1} ms; turtle {:.1} ms; mesh {:.1} ms",
                r.steps,
                r.modules,
                r.derive_time.as_secs_f64() * 1e3,
                r.interpret_time.as_secs_f64() * 1e3,
                r.mesh_time.as_secs_f64() * 1e3
            );
        } else {
            println!("  {}; mesh {:.1} ms", r.summary, r.mesh_time.as_secs_f64() * 1e3);
        }
        println!(
            "  skeleton: {} nodes, {} segments, {} tips, depth {}, max order {}, total length {:.3} m, height {:.3} m",
            s.nodes,
            s.segments,
            s.tips,
            s.depth,
            s.max_order,
            s.total_length,
            s.bounds.1.y - s.bounds.0.y
        );
        if let Some(d) = &r.decollide {
            println!(
                "  decollide: {} skeleton collision(s), {} resolved, {} left ({} nodes thinned, {} branches moved, {} tips pulled back, {} stubs moved or bent, {} traded, {} rounds, {:.1} ms)",
                d.before,
                d.resolved(),
                d.after,
                d.thinned,
                d.rotations,
                d.retracted,
                d.extended,
                d.traded,
                d.rounds,
                d.elapsed.as_secs_f64() * 1e3
            );
        }
        if let Some(c) = &r.clear {
            match (c.before, c.after) {
                (Some(before), Some(after)) => println!(
                    "  clear: {before} crossing face pair(s) in the refined mesh, {}{after} left ({} nodes thinned, {} rounds, {:.1} ms)",
                    if c.truncated { "at least " } else { "" },
                    c.thinned,
                    c.rounds,
                    c.elapsed.as_secs_f64() * 1e3
                ),
                _ => println!("  clear: not searched (the refined mesh is too large; see the warning)"),
            }
        }
        println!("  mesh: {} axes, {} triangles, {} vertices", r.axes, r.triangles, r.vertices);
        if r.joints > 0 {
            let clip = grown.model.clip.as_ref().map_or(0.0, |c| c.duration());
            println!(
                "  wind: {} joints, {:.1} s clip, {:.1} ms",
                r.joints,
                clip,
                r.wind_time.as_secs_f64() * 1e3
            );
        }
        for (k, lod) in grown.model.lods.iter().enumerate() {
            let tris: usize = lod.parts.iter().map(|p| p.mesh.triangle_count()).sum();
            println!(
                "  LOD{}: {} triangles, from {:.0} % of the view",
                k + 1,
                tris,
                lod.screen_coverage * 100.0
            );
        }
        println!("  wrote {}", out.display());
        if let Some(p) = &preview {
            println!("  wrote {}", p.display());
        }
        if let Some(p) = &args.preview_wind {
            println!("  wrote {}", p.display());
        }
    }
    Ok(())
}

fn derive(what: &str, iterations: Option<u32>, seed: Option<u64>, sets: &[String]) -> Result<()> {
    let sets = overrides(sets, iterations, seed, None)?;
    let loaded = recipe::load(what, &sets)?;
    let Generator::Lsystem(g) = &loaded.recipe.generator else {
        return Err(miette::miette!(
            "`{what}` is not an L-system: `lsys derive` needs a .l file or an L-system recipe"
        ));
    };
    let d = sylva::pipeline::derive_lsystem(&loaded, g)?;
    let text = d.lsystem.format(&d.string);
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{text}").into_diagnostic()?;
    Ok(())
}
