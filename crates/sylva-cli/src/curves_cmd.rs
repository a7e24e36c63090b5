//! `sylva curves`: draw a magnetic-curves composition (Xu2015 ch. 7, issue 8; the
//! engine is `sylva::curves`) to SVG or PNG, or export its 3D curves as a tube mesh.
//!
//! ```text
//! sylva curves curves-klimt-tree -o klimt.svg
//! sylva curves curves-hair -o hair.png --size 800 --seed 3
//! sylva curves my-composition.toml -o out.png --set curves.style.width=5
//! sylva curves curves-3d-tree -o tree.glb
//! ```

use miette::Result;
use std::path::PathBuf;
use std::time::Instant;
use sylva::curves::{self, Output};

/// Arguments of `sylva curves`.
#[derive(clap::Args, Debug)]
pub struct CurvesArgs {
    /// A curves preset (`sylva presets` lists the `curves-…` ones) or a composition file
    /// (.toml with `kind = "curves"`).
    pub preset_or_file: String,
    /// Output file: .svg (vector paths) or .png (anti-aliased); .glb, .gltf, .obj or .ply
    /// mesh the 3D curves of `space` and `sphere` layers.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output width in pixels; the height follows the canvas (key `curves.size`).
    #[arg(long, value_name = "PIXELS")]
    pub size: Option<u32>,
    /// Random seed (key `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Set any composition key: `--set curves.style.width=5 --set curves.max_steps=100000000`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs `sylva curves`.
pub fn run(args: CurvesArgs) -> Result<()> {
    // Fail on a bad extension before doing any work.
    let output = Output::from_path(&args.output)?;
    let mut sets = Vec::new();
    for s in &args.sets {
        sets.push(sylva::recipe::parse_set(s)?);
    }
    if let Some(s) = args.seed {
        let s =
            i64::try_from(s).map_err(|_| miette::miette!("--seed {s} is too large (max {})", i64::MAX))?;
        sets.push(("seed".into(), toml::Value::Integer(s)));
    }
    if let Some(px) = args.size {
        sets.push(("curves.size".into(), toml::Value::Integer(px.into())));
    }
    let comp = curves::load_preset(&args.preset_or_file, &sets)?;
    let start = Instant::now();
    let generated = comp.generate()?;
    let gen_time = start.elapsed();
    let start = Instant::now();
    curves::write(&generated, &args.output, comp.spec.size)?;
    let write_time = start.elapsed();
    if !args.quiet {
        let s = &generated.stats;
        println!("{}: {}", comp.name, comp.description);
        println!(
            "  {} curves, {} integration steps, {} space-filling attempts ({} positions abandoned) in {:.1} ms",
            s.curves,
            s.steps,
            s.attempts,
            s.abandoned,
            gen_time.as_secs_f64() * 1e3
        );
        let what = match output {
            Output::Svg => "SVG",
            Output::Png => "PNG",
            Output::Mesh(_) => "mesh",
        };
        println!("  wrote {} ({what}, {:.1} ms)", args.output.display(), write_time.as_secs_f64() * 1e3);
    }
    Ok(())
}
