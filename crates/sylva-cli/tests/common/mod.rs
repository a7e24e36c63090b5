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
    sylva_env(args, cwd, &[])
}

/// Runs `sylva args…` in `cwd` without colours, with each `(name, value)` of `env` set
/// in its environment (`None`: removed).
pub fn sylva_env(args: &[&str], cwd: &Path, env: &[(&str, Option<&str>)]) -> Run {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sylva"));
    cmd.args(args).current_dir(cwd).env("NO_COLOR", "1");
    for (name, value) in env {
        match value {
            Some(v) => cmd.env(name, v),
            None => cmd.env_remove(name),
        };
    }
    let out = cmd.output().expect("the sylva binary runs");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// `args` followed by `--set key=value` for each `key=value` of `sets`.
#[allow(dead_code)]
pub fn with_sets<'a>(args: &[&'a str], sets: &[&'a str]) -> Vec<&'a str> {
    let mut all = args.to_vec();
    for kv in sets {
        all.extend(["--set", kv]);
    }
    all
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
