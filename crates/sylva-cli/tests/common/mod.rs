//! The harness the `sylva` binary's integration tests share: run the binary in a folder
//! and capture its exit code and output, and make a fresh temporary folder per test.

use std::path::Path;
use std::process::Command;

/// One run of the binary.
pub struct Run {
    /// Exit code (-1 when killed by a signal).
    pub code: i32,
    /// Standard output.
    #[allow(dead_code)]
    pub stdout: String,
    /// Standard error.
    pub stderr: String,
}

/// Runs `sylva args…` in `cwd` without colours.
pub fn sylva(args: &[&str], cwd: &Path) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_sylva"))
        .args(args)
        .current_dir(cwd)
        .env("NO_COLOR", "1")
        .output()
        .expect("the sylva binary runs");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

#[path = "../../../sylva/tests/common/folders.rs"]
pub mod folders;
#[allow(unused_imports)]
pub use folders::tempdir;

/// Fails unless `text` contains each of `wants`; the message starts with `context` (what
/// was run) and quotes `text`.
#[allow(dead_code)]
pub fn assert_says(context: &str, text: &str, wants: &[&str]) {
    for want in wants {
        assert!(text.contains(want), "{context}: no `{want}` in: {text}");
    }
}
