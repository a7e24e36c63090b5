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
    /// Grow a tree and draw it on the GPU (wgpu): one picture, a wind animation, a forest,
    /// or (`--window`) a window to orbit it in.
    Render(RenderArgs),
    /// List every embedded preset with a one-line description.
    Presets,
    /// Render a magnetic-curves composition (Xu2015 ch. 7) to SVG or PNG.
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
    /// Preview width and height in pixels, 1..=8192 (recipe key `output.preview_size`).
    #[arg(long, value_name = "PIXELS", value_parser = whole_in::<u32>(1, sylva::preview::MAX_SIZE as u64))]
    preview_size: Option<u32>,
    /// Derivation steps (recipe key `generator.iterations`).
    #[arg(short = 'n', long, value_parser = whole_in::<u32>(0, u32::MAX as u64))]
    iterations: Option<u32>,
    /// Random seed (recipe key `seed`).
    #[arg(long, value_parser = whole_in::<u64>(0, i64::MAX as u64))]
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

/// Why a flag's value is not a whole number in its range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BadNumber {
    /// Not a number at all.
    NotANumber,
    /// A number outside the range (however many digits it has).
    OutOfRange,
    /// A fraction inside the range.
    NotWhole,
    /// A whole number inside the range written as a float (`1e3`): the recipe refuses
    /// floats for whole-number keys, so the flags do too.
    Float,
}

impl BadNumber {
    /// The message, naming the range.
    fn say(self, lo: u64, hi: u64) -> String {
        let why = match self {
            BadNumber::NotANumber => "not a number",
            BadNumber::OutOfRange => "out of range",
            BadNumber::NotWhole => "not a whole number",
            BadNumber::Float => "written as a float (write it in digits)",
        };
        format!("{why}: use a whole number in {lo}..={hi}")
    }
}

/// `s` as a whole number in `lo..=hi`: digits, `_` allowed between them.
fn whole_number(s: &str, lo: u64, hi: u64) -> std::result::Result<u64, BadNumber> {
    let t = s.trim().replace('_', "");
    match t.parse::<u64>() {
        Ok(n) if (lo..=hi).contains(&n) => Ok(n),
        Ok(_) => Err(BadNumber::OutOfRange),
        Err(_) if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) => Err(BadNumber::OutOfRange),
        Err(_) => match t.parse::<f64>() {
            Ok(x) if x.is_finite() && (x < lo as f64 || x > hi as f64) => Err(BadNumber::OutOfRange),
            Ok(x) if x.is_finite() && x.fract() != 0.0 => Err(BadNumber::NotWhole),
            Ok(x) if x.is_finite() => Err(BadNumber::Float),
            _ => Err(BadNumber::NotANumber),
        },
    }
}

/// A clap value parser for a whole number in `lo..=hi` whose every message names the
/// range (clap names the flag): a number out of the range, however long, is "out of
/// range", not "invalid digit" or "too large to fit".
fn whole_in<T>(
    lo: u64,
    hi: u64,
) -> impl Fn(&str) -> std::result::Result<T, String> + Clone + Send + Sync + 'static
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
{
    move |s: &str| {
        let n = whole_number(s, lo, hi).map_err(|e| e.say(lo, hi))?;
        T::try_from(n).map_err(|_| BadNumber::OutOfRange.say(lo, hi))
    }
}

/// `--lod 30000,8000,2000,impostor` as recipe overrides (`lod.levels`, `lod.impostor`).
/// An item that is not a number, one out of [`recipe::LOD_BUDGETS`] and one that is not
/// whole get their own messages, each naming `--lod` and the range.
fn lod_overrides(spec: &str) -> Result<Vec<(String, toml::Value)>> {
    use sylva::diagnostic::quote;
    let mut levels = Vec::new();
    let mut impostor = false;
    let (lo, hi) = (u64::from(*recipe::LOD_BUDGETS.start()), u64::from(*recipe::LOD_BUDGETS.end()));
    for (i, item) in spec.split(',').map(str::trim).enumerate() {
        let (shown, k) = (quote(spec), i + 1);
        if item.eq_ignore_ascii_case("impostor") {
            impostor = true;
        } else if impostor {
            return Err(miette::miette!("--lod {shown}: `impostor` must come last (item {k})"));
        } else {
            let n = whole_number(item, lo, hi).map_err(|e| match e {
                BadNumber::NotANumber => miette::miette!(
                    "--lod {shown}: item {k} (`{}`) is neither a triangle budget (a whole number in {lo}..={hi}) nor `impostor`",
                    quote(item)
                ),
                e => miette::miette!(
                    "--lod {shown}: item {k} (`{}`) is not a triangle budget: {}",
                    quote(item),
                    e.say(lo, hi)
                ),
            })?;
            levels.push(toml::Value::Integer(n as i64));
        }
    }
    Ok(vec![
        ("lod.levels".into(), toml::Value::Array(levels)),
        ("lod.impostor".into(), toml::Value::Boolean(impostor)),
    ])
}

#[derive(clap::Args, Debug)]
struct RenderArgs {
    /// Preset name, recipe file (.toml), L-system file (.l) or skeleton file, as for
    /// `grow`. Default: the default preset.
    what: Option<String>,
    /// Output: `.png` (one frame; an animated PNG for several), `.gif`, or a pattern with
    /// `%d` / `%03d` for a numbered PNG sequence.
    #[arg(short, long, default_value = "render.png", conflicts_with = "window")]
    output: PathBuf,
    /// Show the tree in a window instead of writing a file: drag with the left mouse
    /// button to orbit, scroll to zoom, Esc or closing the window quits; the wind plays
    /// in real time. `--frames N` closes it after N frames. Needs a display and a sylva
    /// built with the cargo feature `window`.
    #[arg(long)]
    window: bool,
    /// Image size in pixels, `WIDTHxHEIGHT` (each 1..=8192); with `--window`, the
    /// window's initial size.
    #[arg(long, default_value = "1024x1024", value_name = "WxH")]
    size: String,
    /// View: `orbit:AZ,EL` in degrees (azimuth about +Y from +Z, elevation -89..=89).
    /// Default: the CPU preview's choice for the model's shape.
    #[arg(long, value_name = "orbit:AZ,EL")]
    camera: Option<String>,
    /// Wind preset (`calm`, `breeze`, `storm`): the tree sways, skinned on the GPU.
    #[arg(long, value_name = "PRESET")]
    wind: Option<String>,
    /// Frames to render (1..=1200) at `--fps`; default 60 with `--wind`, else 1. With
    /// `--window`: close the window after N frames (default: stay open).
    #[arg(long, value_parser = whole_in::<u32>(1, sylva::animation::MAX_FRAMES as u64))]
    frames: Option<u32>,
    /// Frames per second of an animation (1..=60).
    #[arg(long, default_value_t = 30, value_parser = whole_in::<u32>(1, 60))]
    fps: u32,
    /// Draw N copies of the tree on a grid (seeded yaw, scale and position jitter),
    /// instanced, each at the level of detail its projected size asks for.
    #[arg(long, value_name = "N", value_parser = whole_in::<u32>(1, MAX_FOREST as u64))]
    forest: Option<u32>,
    /// Levels of detail as for `grow --lod` (`30000,8000,impostor`); far trees of a
    /// forest use the coarser ones.
    #[arg(long, value_name = "BUDGETS")]
    lod: Option<String>,
    /// Turn off 4× multisampling.
    #[arg(long)]
    no_msaa: bool,
    /// Derivation steps (recipe key `generator.iterations`).
    #[arg(short = 'n', long, value_parser = whole_in::<u32>(0, u32::MAX as u64))]
    iterations: Option<u32>,
    /// Random seed (recipe key `seed`; also seeds the forest's jitter).
    #[arg(long, value_parser = whole_in::<u64>(0, i64::MAX as u64))]
    seed: Option<u64>,
    /// Set any recipe key, as for `grow`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Print nothing but errors.
    #[arg(short, long)]
    quiet: bool,
}

/// Most trees `sylva render --forest` draws.
const MAX_FOREST: u32 = 10_000;

/// Where `sylva render` writes its frames.
#[derive(Debug, Clone, PartialEq)]
enum RenderOutput {
    /// One PNG (one frame) or an animated PNG.
    Png(PathBuf),
    /// An animated GIF.
    Gif(PathBuf),
    /// Numbered PNGs: the path's text before and after the `%d` / `%0Nd`, and N.
    Sequence(String, String, usize),
}

impl RenderOutput {
    fn parse(p: &Path) -> Result<RenderOutput> {
        let text = p.to_string_lossy().into_owned();
        if let Some(at) = text.find('%') {
            let rest = &text[at + 1..];
            let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
            let after = &rest[digits.len()..];
            let bad = || {
                miette::miette!(
                    "-o {text}: a sequence pattern needs exactly one `%d` or `%0Nd` (e.g. `frame_%03d.png`)"
                )
            };
            let Some(tail) = after.strip_prefix('d') else { return Err(bad()) };
            if tail.contains('%') || (!digits.is_empty() && !digits.starts_with('0')) {
                return Err(bad());
            }
            let width: usize = if digits.is_empty() { 0 } else { digits.parse().map_err(|_| bad())? };
            if width > 9 {
                return Err(bad());
            }
            if !tail.to_ascii_lowercase().ends_with(".png") {
                return Err(miette::miette!(
                    "-o {text}: a frame sequence is written as PNG; end the pattern in `.png`"
                ));
            }
            return Ok(RenderOutput::Sequence(text[..at].to_string(), tail.to_string(), width));
        }
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "png" | "apng" => Ok(RenderOutput::Png(p.to_path_buf())),
            "gif" => Ok(RenderOutput::Gif(p.to_path_buf())),
            _ => Err(miette::miette!(
                "-o {text}: `.{ext}` is not an image format; use .png (APNG for several frames), .gif, or a `%03d.png` pattern"
            )),
        }
    }

    /// The file of frame `k` of a sequence.
    fn frame_path(before: &str, after: &str, width: usize, k: usize) -> PathBuf {
        PathBuf::from(format!("{before}{k:0width$}{after}"))
    }
}

/// `WxH` as (width, height), each in 1..=8192.
fn parse_size(s: &str) -> Result<(u32, u32)> {
    let shown = sylva::diagnostic::quote(s);
    let max = sylva::preview::MAX_SIZE;
    let bad = || miette::miette!("--size {shown}: expected WIDTHxHEIGHT in pixels, e.g. 1920x1080");
    let range = || miette::miette!("--size {shown}: width and height must each be in 1..={max}");
    let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    // A side that is all digits is a number, however long: too large, not malformed.
    let side = |t: &str| -> Result<u32> {
        let t = t.trim();
        match t.parse::<u32>() {
            Ok(n) if (1..=max).contains(&n) => Ok(n),
            Ok(_) => Err(range()),
            Err(_) if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) => Err(range()),
            Err(_) => Err(bad()),
        }
    };
    Ok((side(w)?, side(h)?))
}

fn render(args: RenderArgs) -> Result<()> {
    // Every argument is checked before any work, so bad input writes nothing.
    let (width, height) = parse_size(&args.size)?;
    let output = if args.window { None } else { Some(RenderOutput::parse(&args.output)?) };
    if let Some(o) = &output {
        let first = match o {
            RenderOutput::Png(p) | RenderOutput::Gif(p) => p.clone(),
            RenderOutput::Sequence(before, after, w) => RenderOutput::frame_path(before, after, *w, 0),
        };
        check_outputs(&[("-o", &first)])?;
    }
    let frames = args.frames.unwrap_or(if args.wind.is_some() { 60 } else { 1 });
    let max_frames = sylva::animation::MAX_FRAMES as u32;
    if !(1..=max_frames).contains(&frames) {
        return Err(miette::miette!("--frames {frames}: render 1..={max_frames} frames"));
    }
    if !(1..=60).contains(&args.fps) {
        return Err(miette::miette!("--fps {}: use 1..=60 frames per second", args.fps));
    }
    if output.is_some() {
        // Frames are streamed to the file one at a time, so memory holds one frame; but
        // 1200 frames of 8192x8192 are still 322 GB of pictures to draw and encode.
        sylva::animation::animation_bytes(frames as u64, (width, height)).map_err(|why| {
            miette::miette!(
                "--frames {frames} --size {}: {why}; render fewer --frames or a smaller --size",
                args.size.trim()
            )
        })?;
    }
    if let Some(n) = args.forest {
        if !(1..=MAX_FOREST).contains(&n) {
            return Err(miette::miette!("--forest {n}: draw 1..={MAX_FOREST} trees"));
        }
    }
    if let Some(RenderOutput::Gif(p)) = &output {
        if width > u16::MAX as u32 || height > u16::MAX as u32 {
            return Err(miette::miette!("-o {}: too large for GIF", p.display()));
        }
    }
    if let Some(w) = &args.wind {
        if sylva::wind::WindOptions::preset(w).is_none() && w != "none" {
            return Err(miette::miette!("--wind {w}: not a wind preset; use calm, breeze or storm"));
        }
    }
    check_camera(args.camera.as_deref())?;
    if args.window {
        check_window()?;
    }
    let mut sets = overrides(&args.sets, args.iterations, args.seed, None)?;
    if let Some(w) = &args.wind {
        sets.push(("wind.preset".into(), toml::Value::String(w.clone())));
    }
    if let Some(l) = &args.lod {
        sets.extend(lod_overrides(l)?);
    }
    let what = args.what.clone().unwrap_or_else(|| sylva::presets::DEFAULT_PRESET.to_string());
    let loaded = recipe::load(&what, &sets)?;
    match &output {
        Some(output) => render_gpu(&args, &loaded, (width, height), frames, output),
        None => render_window(&args, &loaded, (width, height)),
    }
}

/// Checks that `--window` can open one before any work: the feature is built in and a
/// display is named.
#[cfg(feature = "window")]
fn check_window() -> Result<()> {
    if sylva_gpu::render::window::display().is_none() {
        return Err(miette::miette!(
            "--window: no display to open a window on (neither DISPLAY nor WAYLAND_DISPLAY is set); run it in a desktop session or under `xvfb-run`, or drop --window to write a picture"
        ));
    }
    Ok(())
}

/// Without the windowed target `--window` is refused.
#[cfg(not(feature = "window"))]
fn check_window() -> Result<()> {
    Err(miette::miette!(
        "--window: this sylva was built without the windowed target (cargo feature `window`: `cargo build -p sylva-cli --features window`); drop --window to write a picture"
    ))
}

#[cfg(not(feature = "window"))]
fn render_window(_args: &RenderArgs, _loaded: &recipe::Loaded, _size: (u32, u32)) -> Result<()> {
    check_window()
}

/// The renderer's per-frame counts, as `sylva render` and the window print them.
#[cfg(feature = "gpu")]
fn print_draw_stats(trees: usize, s: &sylva_gpu::render::Stats) {
    let levels: Vec<String> = s.instances_per_level.iter().map(u32::to_string).collect();
    println!(
        "  {trees} tree(s), {} draw call(s) per frame, trees per level of detail [{}], {} triangles per frame",
        s.draw_calls,
        levels.join(", "),
        s.triangles
    );
}

/// `sylva render --window`: grows the tree and shows it until the window is closed (or
/// `--frames` frames are shown).
#[cfg(feature = "window")]
fn render_window(args: &RenderArgs, loaded: &recipe::Loaded, (width, height): (u32, u32)) -> Result<()> {
    use sylva_gpu::render::{forest, window, Orbit, RenderOptions};
    let orbit = args.camera.as_deref().map(Orbit::parse).transpose().map_err(|e| miette::miette!("--{e}"))?;
    let grown = sylva::pipeline::grow(loaded)?;
    for w in &grown.report.warnings {
        eprintln!("warning: {w}");
    }
    let bounds = grown.model.flattened().bounds().unwrap_or((glam::Vec3::ZERO, glam::Vec3::ZERO));
    let instances = match args.forest {
        Some(n) => forest::grid(n as usize, loaded.recipe.seed, bounds),
        None => vec![glam::Mat4::IDENTITY],
    };
    let mut render = RenderOptions { width, height, orbit, msaa: !args.no_msaa, ..Default::default() };
    let animated = grown.model.rig.is_some() && grown.model.clip.is_some();
    if animated && args.forest.is_none() {
        // As `render_gpu` frames a wind animation: room for the swaying crown.
        let pad = glam::Vec3::splat((bounds.1 - bounds.0).max_element() / 6.0);
        render.frame = Some((bounds.0 - pad, bounds.1 + pad));
    }
    let opts = window::WindowOptions {
        title: format!("sylva — {}", loaded.recipe.name),
        render,
        close_after: args.frames,
    };
    let report = window::run(&grown.model, &instances, &opts).map_err(|e| gpu_error(args, e))?;
    if !args.quiet {
        let s = &report.stats;
        println!("{}: {}", loaded.recipe.name, loaded.recipe.description);
        println!("  on {}", report.adapter);
        println!(
            "  showed {} frame(s) of {}x{} ({:?}, {} sample(s) per pixel) in {:.1} s",
            report.frames, report.size.0, report.size.1, report.format, s.samples, report.seconds
        );
        print_draw_stats(instances.len(), s);
    }
    Ok(())
}

/// A GPU error as `sylva render` reports it: a missing adapter names the CPU preview.
#[cfg(feature = "gpu")]
fn gpu_error(args: &RenderArgs, e: sylva_gpu::GpuError) -> miette::Report {
    match e {
        sylva_gpu::GpuError::NoAdapter(why) => miette::miette!(
            "no GPU adapter was found ({why}), so `sylva render` cannot draw; install a Vulkan driver (on Debian `apt-get install mesa-vulkan-drivers` gives lavapipe, a software one), or use `sylva grow {} --preview out.png`, which draws the tree with the CPU preview",
            args.what.as_deref().unwrap_or(sylva::presets::DEFAULT_PRESET)
        ),
        e => miette::miette!("{e}"),
    }
}

/// Checks `--camera` (`orbit:AZ,EL`) before any work.
#[cfg(feature = "gpu")]
fn check_camera(camera: Option<&str>) -> Result<()> {
    camera.map(sylva_gpu::render::Orbit::parse).transpose().map_err(|e| miette::miette!("--{e}"))?;
    Ok(())
}

/// Without the GPU renderer the camera is not looked at.
#[cfg(not(feature = "gpu"))]
fn check_camera(_camera: Option<&str>) -> Result<()> {
    Ok(())
}

#[cfg(not(feature = "gpu"))]
fn render_gpu(
    _args: &RenderArgs,
    _loaded: &recipe::Loaded,
    _size: (u32, u32),
    _frames: u32,
    _output: &RenderOutput,
) -> Result<()> {
    Err(miette::miette!(
        "this sylva was built without GPU support (cargo feature `gpu`), so `sylva render` cannot draw; `sylva grow --preview out.png` draws the tree with the CPU preview instead"
    ))
}

#[cfg(feature = "gpu")]
fn render_gpu(
    args: &RenderArgs,
    loaded: &recipe::Loaded,
    (width, height): (u32, u32),
    frames: u32,
    output: &RenderOutput,
) -> Result<()> {
    use sylva_gpu::render::{forest, Orbit, RenderOptions, Renderer};
    let orbit = args.camera.as_deref().map(Orbit::parse).transpose().map_err(|e| miette::miette!("--{e}"))?;
    let gpu = sylva_gpu::Gpu::new().map_err(|e| gpu_error(args, e))?;
    let start = std::time::Instant::now();
    let grown = sylva::pipeline::grow(loaded)?;
    for w in &grown.report.warnings {
        eprintln!("warning: {w}");
    }
    let grow_time = start.elapsed();
    let renderer = Renderer::new(&gpu, &grown.model).map_err(|e| miette::miette!("{e}"))?;
    let bounds = renderer.bounds().unwrap_or((glam::Vec3::ZERO, glam::Vec3::ZERO));
    let instances = match args.forest {
        Some(n) => forest::grid(n as usize, loaded.recipe.seed, bounds),
        None => vec![glam::Mat4::IDENTITY],
    };
    let animated = frames > 1 && renderer.animated();
    let mut opts = RenderOptions { width, height, orbit, msaa: !args.no_msaa, ..Default::default() };
    if animated && args.forest.is_none() {
        // The CPU wind preview's framing: the rest pose grown by a sixth of its largest
        // extent on every side, so the swaying crown stays in the picture.
        let pad = glam::Vec3::splat((bounds.1 - bounds.0).max_element() / 6.0);
        opts.frame = Some((bounds.0 - pad, bounds.1 + pad));
    }
    let draw_start = std::time::Instant::now();
    // Frames are drawn as the encoder asks for them and dropped once written (memory
    // holds one frame, whatever the frame count); every file is staged and the set is
    // committed only when all frames are drawn, so a failure leaves nothing.
    let mut stats = None;
    let mut draw = |k: usize| -> Result<sylva::preview::Image> {
        let t = k as f32 / args.fps as f32;
        let r = renderer.render(&opts, &instances, t).map_err(|e| miette::miette!("{e}"))?;
        stats.get_or_insert(r.stats);
        Ok(r.image)
    };
    let (set, written) = match output {
        RenderOutput::Png(p) if frames == 1 => {
            let mut set = sylva::fsutil::OutputSet::new(p);
            sylva::preview::stage_png(&draw(0)?, p, &mut set)?;
            (set, vec![p.clone()])
        }
        RenderOutput::Png(p) | RenderOutput::Gif(p) => {
            let mut set = sylva::fsutil::OutputSet::new(p);
            let size = (width, height);
            sylva::animation::stage_animation_with(size, frames as usize, args.fps, p, &mut set, &mut draw)?;
            (set, vec![p.clone()])
        }
        RenderOutput::Sequence(before, after, w) => {
            // The frames are one result: all of them replace an earlier sequence, or none.
            let mut set = sylva::fsutil::OutputSet::new(RenderOutput::frame_path(before, after, *w, 0));
            let mut out = Vec::with_capacity(frames as usize);
            for k in 0..frames as usize {
                let p = RenderOutput::frame_path(before, after, *w, k);
                sylva::preview::stage_png(&draw(k)?, &p, &mut set)?;
                out.push(p);
            }
            (set, out)
        }
    };
    set.commit()?;
    let draw_time = draw_start.elapsed();
    if !args.quiet {
        let s = stats.unwrap_or_default();
        println!("{}: {}", loaded.recipe.name, loaded.recipe.description);
        println!("  on {}", gpu.describe());
        println!(
            "  grew {} triangles in {:.1} ms; {} frame(s) of {width}x{height}, {} sample(s) per pixel, in {:.1} ms ({:.1} ms per frame)",
            grown.model.triangle_count(),
            grow_time.as_secs_f64() * 1e3,
            frames,
            s.samples,
            draw_time.as_secs_f64() * 1e3,
            draw_time.as_secs_f64() * 1e3 / frames as f64
        );
        print_draw_stats(instances.len(), &s);
        if frames > 1 && !renderer.animated() {
            println!("  note: the model has no wind clip, so every frame is the same (add --wind breeze)");
        }
        match written.as_slice() {
            [one] => println!("  wrote {}", one.display()),
            [first, .., last] => println!("  wrote {} … {}", first.display(), last.display()),
            [] => {}
        }
    }
    Ok(())
}

#[derive(Subcommand, Debug)]
enum LsysCommand {
    /// Print the derived module string of an L-system.
    Derive {
        /// L-system file (.l), recipe (.toml) or preset name.
        what: String,
        /// Derivation steps (default: the file's derivation length).
        #[arg(short = 'n', long, value_parser = whole_in::<u32>(0, u32::MAX as u64))]
        iterations: Option<u32>,
        /// Random seed.
        #[arg(long, value_parser = whole_in::<u64>(0, i64::MAX as u64))]
        seed: Option<u64>,
        /// Set any recipe key.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
}

fn main() -> ExitCode {
    // SIGINT / SIGTERM / SIGHUP remove the temporaries of the outputs being written.
    sylva::fsutil::install_signal_cleanup();
    // Long messages stay on one line so they can be searched and copied whole.
    let _ =
        miette::set_hook(Box::new(|_| Box::new(miette::MietteHandlerOpts::new().wrap_lines(false).build())));
    let cli = Cli::parse();
    if let Err(e) = start_threads() {
        report(&e);
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Grow(args) => grow(args),
        Command::Render(args) => render(args),
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
            report(&e);
            ExitCode::FAILURE
        }
    }
}

/// Prints an error with miette's handler. The report is rendered into a string first;
/// should the renderer panic on some input (miette's graphical handler did on columns
/// past 65,535, issue 39; located errors now carry clipped excerpts), the panic is
/// caught, silently, and the plain message, its causes and its help are printed
/// instead: printing an error never panics.
fn report(e: &miette::Report) {
    eprintln!("{}", render_report(e));
}

/// The text [`report`] prints: miette's rendering, or the plain fallback.
fn render_report(e: &miette::Report) -> String {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let rendered = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| format!("{e:?}")));
    std::panic::set_hook(hook);
    rendered.unwrap_or_else(|_| {
        let mut text = format!("Error: {e}");
        for cause in e.chain().skip(1) {
            text.push_str(&format!("\n  caused by: {cause}"));
        }
        if let Some(help) = e.help() {
            text.push_str(&format!("\n  help: {help}"));
        }
        text
    })
}

/// Starts the engine's worker threads before any work, so a `RAYON_NUM_THREADS` above
/// [`sylva::refine::MAX_THREADS`], or one the system cannot start, is an error naming
/// it rather than a panic at the first parallel step.
fn start_threads() -> Result<()> {
    sylva::refine::start_global_threads().map_err(|e| match std::env::var("RAYON_NUM_THREADS") {
        Ok(v) => miette::miette!("RAYON_NUM_THREADS={}: {e}", sylva::diagnostic::quote(&v)),
        Err(_) => miette::miette!("{e}"),
    })
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
    let (preview, preview_flag) = if args.no_preview {
        (None, "")
    } else if let Some(p) = args.preview {
        (Some(p), "--preview")
    } else if let Some(p) = &loaded.recipe.output.preview {
        (Some(PathBuf::from(p)), "output.preview")
    } else {
        (Some(out.with_extension("png")), "the preview (next to the output)")
    };
    // Every output path is checked before any work, so a bad one writes nothing.
    let out_flag = if args.output.is_some() { "-o" } else { "output.file" };
    let mut outputs = vec![(out_flag, out.as_path())];
    if let Some(p) = &preview {
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if ext != "png" {
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
    let grown = sylva::pipeline::grow(&loaded)?;
    for w in &grown.report.warnings {
        eprintln!("warning: {w}");
    }
    if !grown.report.missing_surfaces.is_empty() {
        eprintln!("warning: no surface file for {}", grown.report.missing_surfaces.join(", "));
    }
    // The model, its side files and the previews are one result: each is staged to a
    // temporary, and they replace the files of an earlier run together when all of them
    // were written (the model last), or not at all.
    let mut set = sylva::fsutil::OutputSet::new(&out);
    grown.stage(&out, &mut set)?;
    if let Some(p) = &preview {
        let size = loaded.recipe.output.preview_size;
        let opts = sylva::preview::PreviewOptions { width: size, height: size, ..Default::default() };
        let img = sylva::preview::render(&grown.model, &opts)?;
        sylva::preview::stage_png(&img, p, &mut set)?;
    }
    if let Some(p) = &args.preview_wind {
        let size = loaded.recipe.output.preview_size.min(512);
        let opts = sylva::preview::PreviewOptions { width: size, height: size, ..Default::default() };
        let fps = 15;
        let frames = sylva::animation::wind_frames(&grown.model, &opts, fps)?;
        sylva::animation::stage_animation(&frames, fps, p, &mut set)?;
    }
    set.commit()?;
    if !args.quiet {
        print!("{grown}");
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

/// Checks the output paths of a run before any work: each can be written
/// ([`sylva::fsutil::check_output`]: its folder exists and is writable, it is not a
/// folder) and no two name the same file. Each pair is the flag or key that named the
/// path, for the message, and the path.
fn check_outputs(outputs: &[(&str, &Path)]) -> Result<()> {
    let key = |p: &Path| {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::canonicalize(dir).ok().map(|d| d.join(p.file_name().unwrap_or_default()))
    };
    for (i, (flag, p)) in outputs.iter().enumerate() {
        sylva::fsutil::check_output(p).map_err(|e| miette::miette!("{flag}: {e}"))?;
        if let Some((other, _)) = outputs[..i].iter().find(|(_, q)| key(q).is_some() && key(q) == key(p)) {
            return Err(miette::miette!(
                "{flag} {}: the same file as {other}; every output needs a name of its own",
                p.display()
            ));
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
    // Streamed: a string of millions of modules is never held whole as text.
    use std::io::Write;
    let mut stdout = std::io::BufWriter::new(std::io::stdout().lock());
    d.lsystem.write_to(&d.string, &mut stdout).into_diagnostic()?;
    writeln!(stdout).into_diagnostic()?;
    stdout.flush().into_diagnostic()?;
    Ok(())
}

#[cfg(test)]
mod report_tests {
    use super::render_report;
    use miette::{Diagnostic, MietteError, SourceCode, SourceSpan, SpanContents};

    /// Source code whose every read panics, as miette's renderer did on long lines.
    #[derive(Debug)]
    struct Exploding;

    impl SourceCode for Exploding {
        fn read_span<'a>(
            &'a self,
            _: &SourceSpan,
            _: usize,
            _: usize,
        ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
            panic!("Formatting argument out of range")
        }
    }

    #[derive(Debug, Diagnostic)]
    #[diagnostic(help("fix it"))]
    struct Bad {
        #[source_code]
        src: Exploding,
        #[label("here")]
        span: SourceSpan,
    }

    impl std::fmt::Display for Bad {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("t.l:1:70000: bad")
        }
    }

    impl std::error::Error for Bad {}

    #[test]
    fn a_renderer_panic_falls_back_to_the_plain_message() {
        let e = miette::Report::new(Bad { src: Exploding, span: SourceSpan::new(0.into(), 1) });
        let text = render_report(&e);
        assert!(text.starts_with("Error: t.l:1:70000: bad"), "{text}");
        assert!(text.contains("help: fix it"), "{text}");
    }
}
