//! `sylva render`: grow a tree and draw it on the GPU (`sylva_gpu`): one picture, a wind
//! animation, a forest, or a window to orbit it in. Every argument is checked before any
//! work, so bad input writes nothing.

use crate::args::{self, check_outputs, Common, Lod, Size};
use miette::Result;
use std::path::{Path, PathBuf};
use sylva::recipe::{self, WindPreset};

/// Arguments of `sylva render`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// What to grow, `-n`, `--seed`, `--set`, `-q`.
    #[command(flatten)]
    pub common: Common,
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
    #[arg(long, default_value = "1024x1024", value_name = "WxH", value_parser = args::size)]
    size: Size,
    /// View: `orbit:AZ,EL` in degrees (azimuth about +Y from +Z, elevation -89..=89).
    /// Default: the CPU preview's choice for the model's shape.
    #[arg(long, value_name = "orbit:AZ,EL")]
    camera: Option<String>,
    /// Wind preset (`calm`, `breeze`, `storm`; `none`): the tree sways, skinned on the GPU.
    #[arg(long, value_name = "PRESET", value_parser = args::wind)]
    wind: Option<WindPreset>,
    /// Frames to render (1..=1200) at `--fps`; default 60 with `--wind`, else 1. With
    /// `--window`: close the window after N frames (default: stay open).
    #[arg(long, value_parser = args::whole_in::<u32>(1, sylva::animation::MAX_FRAMES as u64))]
    frames: Option<u32>,
    /// Frames per second of an animation (1..=60).
    #[arg(long, default_value_t = 30, value_parser = args::whole_in::<u32>(1, 60))]
    fps: u32,
    /// Draw N copies of the tree on a grid (seeded yaw, scale and position jitter),
    /// instanced, each at the level of detail its projected size asks for.
    #[arg(long, value_name = "N", value_parser = args::whole_in::<u32>(1, MAX_FOREST as u64))]
    forest: Option<u32>,
    /// Levels of detail as for `grow --lod` (`30000,8000,impostor`); far trees of a
    /// forest use the coarser ones.
    #[arg(long, value_name = "BUDGETS", value_parser = args::lod)]
    lod: Option<Lod>,
    /// Turn off 4× multisampling.
    #[arg(long)]
    no_msaa: bool,
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

/// Runs `sylva render`.
pub fn run(args: RenderArgs) -> Result<()> {
    let Size { width, height } = args.size;
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
                args.size
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
    check_camera(args.camera.as_deref())?;
    if args.window {
        check_window()?;
    }
    let mut sets = Vec::new();
    if let Some(w) = args.wind {
        sets.push(("wind.preset".into(), toml::Value::String(w.name().into())));
    }
    if let Some(l) = &args.lod {
        sets.extend(l.overrides());
    }
    let loaded = args.common.load(&sets)?;
    match &output {
        Some(output) => render_gpu(&args, &loaded, (width, height), frames, output),
        None => render_window(&args, &loaded, (width, height)),
    }
}

/// Checks that `--window` can open one before any work: the feature is built in and a
/// display is named.
#[cfg(feature = "window")]
pub fn check_window() -> Result<()> {
    if sylva_gpu::render::window::display().is_none() {
        return Err(miette::miette!(
            "--window: no display to open a window on (neither DISPLAY nor WAYLAND_DISPLAY is set); run it in a desktop session or under `xvfb-run`, or drop --window to write a picture"
        ));
    }
    Ok(())
}

/// Without the windowed target `--window` is refused.
#[cfg(not(feature = "window"))]
pub fn check_window() -> Result<()> {
    Err(miette::miette!(
        "--window: this sylva was built without the windowed target (cargo feature `window`: `cargo build -p sylva-cli --features window`); drop --window to write a picture"
    ))
}

#[cfg(not(feature = "window"))]
fn render_window(_args: &RenderArgs, _loaded: &recipe::Loaded, _size: (u32, u32)) -> Result<()> {
    check_window()
}

/// Grows the tree of `loaded` through a session, with a progress bar on a terminal, and
/// prints its warnings.
#[cfg(feature = "gpu")]
fn grow(args: &RenderArgs, loaded: &recipe::Loaded) -> Result<sylva::Tree> {
    let progress = crate::progress::Progress::new(args.common.quiet, 0);
    let mut session = sylva::Session::new(loaded.clone()).keep_stages(false);
    progress.follow(&mut session);
    args.common.timed(|cancel| session.run_with(cancel).map(|_| ()))?;
    progress.finish();
    let tree = session.into_tree().expect("a successful run leaves a tree");
    for w in &tree.report.warnings {
        eprintln!("warning: {w}");
    }
    Ok(tree)
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
    let grown = grow(args, loaded)?;
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
    if !args.common.quiet {
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
            args.common.what()
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
    let grown = grow(args, loaded)?;
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
    if !args.common.quiet {
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
