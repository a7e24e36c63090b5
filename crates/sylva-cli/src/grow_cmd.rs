//! `sylva grow`: flags to a recipe, a [`sylva::Session`] run, and the model, its preview
//! and its wind animation written together; the summary is the [`sylva::Tree`]'s own.

use crate::args::{self, check_outputs, Common, Lod};
use crate::progress::Progress;
use miette::Result;
use std::path::PathBuf;
use sylva::recipe::WindPreset;

/// Arguments of `sylva grow`.
#[derive(clap::Args, Debug)]
pub struct GrowArgs {
    /// What to grow, `-n`, `--seed`, `--set`, `-q`.
    #[command(flatten)]
    pub common: Common,
    /// Output file; the extension picks the format (.glb, .gltf, .obj, .ply; .lst or
    /// .skel.json for the skeleton). Recipe key `output.file`.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write a preview PNG here. Default: next to the output, with a .png extension (a
    /// skeleton output, .lst or .json, gets none unless named: it is written without
    /// meshing).
    #[arg(long)]
    pub preview: Option<PathBuf>,
    /// Do not write a preview.
    #[arg(long, conflicts_with = "preview")]
    pub no_preview: bool,
    /// Preview width and height in pixels, 1..=8192 (recipe key `output.preview_size`).
    #[arg(long, value_name = "PIXELS", value_parser = args::whole_in::<u32>(1, sylva::preview::MAX_SIZE as u64))]
    pub preview_size: Option<u32>,
    /// Wind preset (`none`, `calm`, `breeze`, `storm`): a skinned rig, a looping clip and
    /// wind shader channels in the output (recipe key `wind.preset`; docs/wind.md).
    #[arg(long, value_name = "PRESET", value_parser = args::wind)]
    pub wind: Option<WindPreset>,
    /// Levels of detail as triangle budgets, LOD0 first, optionally ending in
    /// `impostor`: `--lod 30000,8000,2000,impostor` (recipe table `[lod]`; docs/lod.md).
    #[arg(long, value_name = "BUDGETS", value_parser = args::lod)]
    pub lod: Option<Lod>,
    /// Render one loop of the wind clip with the CPU preview to an animated GIF (`.gif`)
    /// or PNG (`.png`); turns on `--wind breeze` unless a wind preset is set.
    #[arg(long, value_name = "FILE")]
    pub preview_wind: Option<PathBuf>,
}

/// The lower-cased extension of `p`.
fn ext(p: &std::path::Path) -> String {
    p.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase()
}

/// Runs `sylva grow`.
pub fn run(args: GrowArgs) -> Result<()> {
    let mut sets = Vec::new();
    if let Some(o) = &args.output {
        sets.push(("output.file".into(), toml::Value::String(o.display().to_string())));
    }
    if let Some(px) = args.preview_size {
        sets.push(("output.preview_size".into(), toml::Value::Integer(px.into())));
    }
    if let Some(w) = args.wind {
        sets.push(("wind.preset".into(), toml::Value::String(w.name().into())));
    }
    if let Some(l) = &args.lod {
        sets.extend(l.overrides());
    }
    if let Some(p) = &args.preview_wind {
        if !["gif", "png", "apng"].contains(&ext(p).as_str()) {
            return Err(miette::miette!(
                "--preview-wind {}: `.{}` is not an animation format; use .gif or .png (APNG)",
                p.display(),
                ext(p)
            ));
        }
    }
    let mut loaded = args.common.load(&sets)?;
    if args.preview_wind.is_some() && !loaded.recipe.wind.enabled() {
        sets.push(("wind.preset".into(), toml::Value::String(WindPreset::Breeze.name().into())));
        loaded = args.common.load(&sets)?;
    }
    let out = PathBuf::from(&loaded.recipe.output.file);
    // `.lst` and `.json` outputs are skeletons; anything else must be a mesh format.
    let skeleton_only = ["lst", "json"].contains(&ext(&out).as_str());
    if !skeleton_only {
        // Fail on a bad extension before doing any work.
        sylva::export::Format::from_path(&out)?;
    }
    let (preview, preview_flag) = if args.no_preview {
        (None, "")
    } else if let Some(p) = args.preview {
        (Some(p), "--preview")
    } else if let Some(p) = &loaded.recipe.output.preview {
        (Some(PathBuf::from(p)), "output.preview")
    } else if skeleton_only {
        // A skeleton has no mesh to picture: nothing is meshed unless a preview or a
        // wind preview is asked for by name.
        (None, "")
    } else {
        (Some(out.with_extension("png")), "the preview (next to the output)")
    };
    let skeleton_only = skeleton_only && preview.is_none() && args.preview_wind.is_none();
    // Every output path is checked before any work, so a bad one writes nothing.
    let out_flag = if args.output.is_some() { "-o" } else { "output.file" };
    let mut outputs = vec![(out_flag, out.as_path())];
    if let Some(p) = &preview {
        if ext(p) != "png" {
            return Err(miette::miette!(
                "{preview_flag} {}: the preview is written as PNG; end its name in .png",
                p.display()
            ));
        }
        outputs.push((preview_flag, p.as_path()));
    }
    if let Some(p) = &args.preview_wind {
        outputs.push(("--preview-wind", p.as_path()));
    }
    check_outputs(&outputs)?;
    let progress = Progress::new(args.common.quiet, 3);
    let mut session = sylva::Session::new(loaded).keep_stages(false);
    progress.follow(&mut session);
    if skeleton_only {
        return write_skeleton(&args.common, session, &out, &progress);
    }
    // Growing and staging the files run under `--time-limit` (the temporaries' writers
    // stop at its token too); the commit that renames them into place does not.
    let (tree, set) = args.common.timed(|cancel| {
        session.run_with(cancel)?;
        let recipe = session.recipe().clone();
        let tree = session.into_tree().expect("a successful run leaves a tree");
        for w in &tree.report.warnings {
            progress.println(&format!("warning: {w}"));
        }
        if !tree.report.missing_surfaces.is_empty() {
            progress.println(&format!(
                "warning: no surface file for {}",
                tree.report.missing_surfaces.join(", ")
            ));
        }
        // The model, its side files and the previews are one result: each is staged to
        // a temporary, and they replace the files of an earlier run together when all of
        // them were written (the model last), or not at all.
        let mut set = sylva::fsutil::OutputSet::new(&out);
        progress.step("write");
        tree.stage(&out, &mut set)?;
        progress.done_step();
        if let Some(p) = &preview {
            progress.step("preview");
            let size = recipe.output.preview_size;
            let opts = sylva::preview::PreviewOptions { width: size, height: size, ..Default::default() };
            let img = sylva::preview::render(&tree.model, &opts)?;
            sylva::preview::stage_png(&img, p, &mut set)?;
        }
        progress.done_step();
        if let Some(p) = &args.preview_wind {
            progress.step("wind preview");
            let size = recipe.output.preview_size.min(512);
            let opts = sylva::preview::PreviewOptions { width: size, height: size, ..Default::default() };
            let fps = 15;
            let frames = sylva::animation::wind_frames(&tree.model, &opts, fps)?;
            sylva::animation::stage_animation(&frames, fps, p, &mut set)?;
        }
        Ok((tree, set))
    })?;
    set.commit()?;
    progress.finish();
    if !args.common.quiet {
        print!("{tree}");
        for p in std::iter::once(&out).chain(&preview).chain(&args.preview_wind) {
            println!("  wrote {}", p.display());
        }
    }
    Ok(())
}

/// A skeleton output with no preview: the generator and the skeleton passes only, then
/// the skeleton staged and committed (under `--time-limit` as a whole grow is).
fn write_skeleton(
    common: &Common,
    mut session: sylva::Session,
    out: &std::path::Path,
    progress: &Progress,
) -> Result<()> {
    let (skeleton, report, set) = common.timed(|cancel| {
        let (skeleton, report) = session.skeleton_with(cancel)?;
        for w in &report.warnings {
            progress.println(&format!("warning: {w}"));
        }
        let mut set = sylva::fsutil::OutputSet::new(out);
        progress.step("write");
        sylva::export::skeleton::stage(&skeleton, out, &mut set)?;
        progress.done_step();
        Ok((skeleton, report, set))
    })?;
    set.commit()?;
    progress.finish();
    if !common.quiet {
        let recipe = session.recipe();
        println!("{}: {}", recipe.name, recipe.description);
        print!("{report}");
        println!("  skeleton: {} nodes, nothing meshed", skeleton.len());
        println!("  wrote {}", out.display());
    }
    Ok(())
}
