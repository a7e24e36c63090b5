//! `sylva edit`: opens the live editor (crate sylva-editor) on a preset, recipe or model
//! file. Only turns flags into [`sylva_editor::EditOptions`]; built with the cargo
//! feature `edit` (on by default).

use clap::Args;
use std::path::PathBuf;

/// `sylva edit` flags.
#[derive(Args, Debug)]
pub struct EditArgs {
    /// Preset name (`sylva presets`), recipe file (.toml), L-system file (.l) or skeleton
    /// file (.lst, .str, .json). Default: the default preset.
    pub what: Option<String>,
    /// Set any recipe key before the editor opens: `--set mesh.sides=6`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Reload when the recipe file (or the files in its folder) changes on disk.
    #[arg(long)]
    pub watch: bool,
    /// Write the editor's frame log (JSON lines: frame times, change-to-tree latencies)
    /// here when the window closes.
    #[arg(long, value_name = "FILE")]
    pub frame_log: Option<PathBuf>,
    /// Close by itself this many frames after the first tree is shown (tests, demos).
    #[arg(long, value_name = "FRAMES", hide = true)]
    pub close_after_tree: Option<u64>,
    /// Once a tree is shown, set these keys one at a time, each after the previous
    /// one's tree is shown (latency measurements with `--frame-log`).
    #[arg(long = "script-set", value_name = "KEY=VALUE", hide = true)]
    pub script: Vec<String>,
}

/// Runs the editor until its window closes.
#[cfg(feature = "edit")]
pub fn run(args: EditArgs) -> miette::Result<()> {
    let script = args
        .script
        .iter()
        .map(|kv| sylva::recipe::parse_set(kv).map_err(|e| miette::miette!("edit: --script-set: {e}")))
        .collect::<miette::Result<Vec<_>>>()?;
    let opts = sylva_editor::EditOptions {
        what: args.what,
        sets: args.sets,
        watch: args.watch,
        frame_log: args.frame_log,
        close_after_tree: args.close_after_tree,
        script,
        started: None,
        full_resolution: false,
    };
    sylva_editor::run(opts).map_err(|e| miette::miette!("edit: {e}"))
}

/// Without the `edit` feature: says how to get it.
#[cfg(not(feature = "edit"))]
pub fn run(_args: EditArgs) -> miette::Result<()> {
    Err(miette::miette!(
        "edit: this sylva was built without the editor (cargo feature `edit`); build it with `cargo build --release -p sylva-cli` (default features)"
    ))
}
