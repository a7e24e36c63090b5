//! Running the repository's external checkers from tests (included with `#[path]` by
//! `gltf_validator.rs` and `rig_tools.rs`): a Node script of a `tools/` folder, skipped
//! loudly where Node or its npm package is missing unless a `SYLVA_REQUIRE_…=1`
//! variable makes that a failure.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::path::PathBuf;
use std::process::Command;

/// Panics with `message` where the environment variable `variable` is `1`, else prints
/// it loudly (a check skipped for a missing tool).
pub fn skip(message: &str, variable: &str) {
    if std::env::var(variable).is_ok_and(|v| v == "1") {
        panic!("{message} ({variable}=1 makes this an error)");
    }
    eprintln!("\n**********\n*** {message}\n**********\n");
}

/// A check that runs a Node script of a `tools/` folder with its npm package.
pub struct NodeCheck {
    /// What the check is, for the message when it is skipped.
    pub what: &'static str,
    /// The folder holding the script and its `node_modules`.
    pub dir: PathBuf,
    /// The script, in `dir`.
    pub script: &'static str,
    /// The npm package the script needs.
    pub package: &'static str,
    /// The environment variable that, set to `1`, makes a missing Node or package a
    /// failure (as `.ci/run` sets them).
    pub require: &'static str,
}

impl NodeCheck {
    /// Runs `node <dir>/<script> args…` and returns whether it succeeded and its output
    /// (stdout, then stderr); `None`, the check skipped with a loud message, when Node,
    /// the package or the script is missing and not required.
    pub fn run<S: AsRef<OsStr>>(&self, args: impl IntoIterator<Item = S>) -> Option<(bool, String)> {
        let script = self.dir.join(self.script);
        let node_ok = Command::new("node").arg("--version").output().is_ok_and(|o| o.status.success());
        let package_ok = self.dir.join("node_modules").join(self.package).is_dir();
        if !(node_ok && package_ok && script.is_file()) {
            let why = if !node_ok { "`node` is not on PATH" } else { "the npm package is not installed" };
            let folder = self.dir.file_name().unwrap_or_default().to_string_lossy();
            let message = format!("SKIPPED {} ({why}): run `npm ci --prefix tools/{folder}`", self.what);
            skip(&message, self.require);
            return None;
        }
        let output = Command::new("node")
            .arg(&script)
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("cannot run node {}: {e}", script.display()));
        let report =
            format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
        Some((output.status.success(), report))
    }
}
