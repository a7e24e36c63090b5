//! `sylva`: the command-line front end of the sylva engine.
//!
//! A thin client of the library: each subcommand turns its flags into a
//! [`sylva::recipe::Recipe`] (shared flags in [`args::Common`], value parsers in
//! [`args`]), runs a [`sylva::Session`] and writes what the [`sylva::Tree`] holds; errors
//! are printed with `miette` ([`report`]).

#![warn(missing_docs)]

mod args;
mod check_cmd;
mod curves_cmd;
mod edit_cmd;
mod grow_cmd;
mod lsys_cmd;
mod progress;
mod render_cmd;
mod report;
mod subdivide;

use clap::{Parser, Subcommand};
use std::error::Error as _;
use std::process::ExitCode;

/// What `sylva --help` says sylva is.
const ABOUT: &str = "sylva grows trees and plants and writes them as 3D models";

/// The longer account `sylva --help` gives.
const LONG_ABOUT: &str = "\
sylva grows trees and plants and writes them as 3D models.

A tree comes from an L-system (cpfg syntax), Weber & Penn's parametric model, space
colonization, least-cost paths, or an imported skeleton; sylva meshes its branches
(tubes, convex-hull joints, sweeps or quad junctions, optionally subdivided), dresses it
with leaf cards and drawn bark and leaf textures, and can add levels of detail and a wind
rig with a looping clip. It writes glTF/GLB, OBJ, PLY or a POV-Ray scene (or the
skeleton), with a preview picture, and can draw the tree on the GPU.

Start with `sylva presets` and `sylva grow PRESET -o tree.glb`; a recipe (.toml) sets
everything (docs/recipe.md), and `--set key=value` any single key.";

/// Procedural trees and plants: L-systems → skeletons → meshes → glTF / OBJ / PLY.
#[derive(Parser, Debug)]
#[command(name = "sylva", version, about = ABOUT, long_about = LONG_ABOUT)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Grow a tree from a preset, a recipe (.toml) or a model file (.l) and write it.
    Grow(grow_cmd::GrowArgs),
    /// Grow a tree and draw it on the GPU (wgpu): one picture, a wind animation, a forest,
    /// or (`--window`) a window to orbit it in.
    Render(render_cmd::RenderArgs),
    /// List every embedded preset with a one-line description.
    Presets,
    /// Open the live editor: settings on the left, the tree regrown as you change them,
    /// wind playing; save the recipe, export the tree.
    Edit(edit_cmd::EditArgs),
    /// Render a magnetic-curves composition (Xu2015 ch. 7) to SVG or PNG.
    Curves(curves_cmd::CurvesArgs),
    /// Subdivide a control mesh (OBJ) with Loop or Catmull–Clark.
    Subdivide(subdivide::SubdivideArgs),
    /// Check a mesh file (OBJ, glTF, GLB): manifold, oriented, boundaries, self-intersections.
    Check(check_cmd::CheckArgs),
    /// L-system tools.
    Lsys {
        #[command(subcommand)]
        command: lsys_cmd::LsysCommand,
    },
}

/// The command line, or the exit of a bad one: a value refused by one of sylva's own
/// parsers ([`args::FlagError`]) is reported as sylva's errors are (exit 1), the rest
/// by clap (usage, exit 2; `--help` and `--version`, exit 0).
fn parse() -> Result<Cli, ExitCode> {
    Cli::try_parse().map_err(|e| match e.source().and_then(|s| s.downcast_ref::<args::FlagError>()) {
        Some(f) => {
            report::report(&miette::miette!("{f}"));
            ExitCode::FAILURE
        }
        None => e.exit(),
    })
}

fn main() -> ExitCode {
    // SIGINT / SIGTERM / SIGHUP remove the temporaries of the outputs being written.
    sylva::fsutil::install_signal_cleanup();
    report::install();
    let cli = match parse() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    if let Err(e) = report::start_threads() {
        report::report(&e);
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Grow(args) => grow_cmd::run(args),
        Command::Render(args) => render_cmd::run(args),
        Command::Subdivide(args) => subdivide::run(args),
        Command::Check(args) => check_cmd::run(args),
        Command::Curves(args) => curves_cmd::run(args),
        Command::Edit(args) => edit_cmd::run(args),
        Command::Presets => {
            for p in sylva::presets::all() {
                println!("{:<24} {}", p.name, p.description());
            }
            Ok(())
        }
        Command::Lsys { command } => lsys_cmd::run(command),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            report::report(&e);
            ExitCode::FAILURE
        }
    }
}
