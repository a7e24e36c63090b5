//! `sylva lsys`: L-system tools; `lsys derive` prints the derived module string.

use crate::args::Common;
use miette::{IntoDiagnostic, Result};
use sylva::recipe::Generator;

/// The subcommands of `sylva lsys`.
#[derive(clap::Subcommand, Debug)]
pub enum LsysCommand {
    /// Print the derived module string of an L-system.
    Derive {
        /// What to derive, `-n`, `--seed`, `--set`.
        #[command(flatten)]
        common: Common,
    },
}

/// Runs `sylva lsys …`.
pub fn run(command: LsysCommand) -> Result<()> {
    match command {
        LsysCommand::Derive { common } => derive(&common),
    }
}

/// `sylva lsys derive`: the string is streamed, so a string of millions of modules is
/// never held whole as text.
fn derive(common: &Common) -> Result<()> {
    let loaded = common.load(&[])?;
    let Generator::Lsystem(g) = &loaded.recipe.generator else {
        return Err(miette::miette!(
            "`{}` is not an L-system: `lsys derive` needs a .l file or an L-system recipe",
            common.what()
        ));
    };
    let d = common.timed(|_| sylva::pipeline::derive_lsystem(&loaded, g))?;
    use std::io::Write;
    let mut stdout = std::io::BufWriter::new(std::io::stdout().lock());
    d.lsystem.write_to(&d.string, &mut stdout).into_diagnostic()?;
    writeln!(stdout).into_diagnostic()?;
    stdout.flush().into_diagnostic()?;
    Ok(())
}
