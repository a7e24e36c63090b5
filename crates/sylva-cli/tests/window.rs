//! `sylva render --window` end to end (issue 25 item 4, the windowed target): the window
//! opens on the display, shows a few frames (`--frames N` closes it) of a tree, a swaying
//! tree and an instanced forest, and the binary exits 0 having presented them.
//!
//! Needs the cargo feature `window` and a display: where neither `DISPLAY` nor
//! `WAYLAND_DISPLAY` is set the test is skipped with a printed reason, unless
//! `SYLVA_REQUIRE_WINDOW=1` makes that a failure. On a machine without one, run it under
//! a virtual X server: `xvfb-run -a cargo test -p sylva-cli --features window --test window`
//! (Debian package `xvfb`; Mesa's lavapipe presents to it). A display without a GPU
//! adapter skips likewise, unless `SYLVA_REQUIRE_GPU=1`. Without the feature, `--window`
//! is refused with the way to build it.

use std::path::PathBuf;

mod common;
use common::sylva;

fn tempdir(name: &str) -> PathBuf {
    common::tempdir("window", name)
}

#[cfg(not(feature = "window"))]
#[test]
fn without_the_feature_window_names_it() {
    let dir = tempdir("nofeature");
    let r = sylva(&["render", "lsys-honda-a", "--window", "--frames", "1"], &dir);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("cargo feature `window`"), "{}", r.stderr);
    assert!(std::fs::read_dir(&dir).unwrap().next().is_none(), "nothing is written");
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(feature = "window")]
mod window {
    use super::*;
    use common::{sylva_env, Run};

    fn flag(name: &str) -> bool {
        std::env::var(name).is_ok_and(|v| !v.is_empty() && v != "0")
    }

    /// Prints why `what` is skipped, past the test harness's output capture.
    fn skip(what: &str, why: &str, env: &str) {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "skipping {what}: {why} (set {env}=1 to make this a failure)");
    }

    /// The display the window opens on, or `None` after printing why the test is skipped.
    fn display_or_skip(what: &str) -> Option<String> {
        let display = ["WAYLAND_DISPLAY", "DISPLAY"]
            .into_iter()
            .find_map(|v| std::env::var(v).ok().filter(|x| !x.is_empty()).map(|x| format!("{v}={x}")));
        if display.is_none() {
            let why = "no display (neither DISPLAY nor WAYLAND_DISPLAY is set; run under `xvfb-run -a`)";
            if flag("SYLVA_REQUIRE_WINDOW") {
                panic!("{what}: {why} (SYLVA_REQUIRE_WINDOW is set)");
            }
            skip(what, why, "SYLVA_REQUIRE_WINDOW");
        }
        display
    }

    /// Runs `sylva render … --window`; `None` where the binary finds no GPU adapter (and the
    /// test is skipped, unless `SYLVA_REQUIRE_GPU=1`).
    fn window_or_skip(what: &str, args: &[&str]) -> Option<Run> {
        let display = display_or_skip(what)?;
        let dir = tempdir(what);
        let r = sylva(args, &dir);
        if r.code != 0 && r.stderr.contains("no GPU adapter") {
            if flag("SYLVA_REQUIRE_GPU") {
                panic!("{what}: {} (SYLVA_REQUIRE_GPU is set)", r.stderr.trim());
            }
            skip(what, r.stderr.trim(), "SYLVA_REQUIRE_GPU");
            return None;
        }
        assert_eq!(r.code, 0, "{what} on {display}: {}\n{}", r.stderr, r.stdout);
        let written: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(written.is_empty(), "{what}: a window writes no file");
        let _ = std::fs::remove_dir_all(&dir);
        Some(r)
    }

    #[test]
    fn a_window_shows_a_tree_for_the_frames_asked_and_closes() {
        let args = ["render", "lsys-honda-a", "--window", "--frames", "3", "--size", "320x240"];
        let Some(r) = window_or_skip("window-tree", &args) else { return };
        assert!(r.stdout.contains("showed 3 frame(s) of 320x240"), "{}", r.stdout);
        assert!(
            r.stdout.contains("4 sample(s) per pixel") || r.stdout.contains("1 sample(s)"),
            "{}",
            r.stdout
        );
        assert!(r.stdout.contains("1 tree(s)"), "{}", r.stdout);
    }

    #[test]
    fn a_window_plays_the_wind_over_a_forest_without_msaa() {
        let args = [
            "render",
            "lsys-honda-a",
            "--window",
            "--wind",
            "breeze",
            "--forest",
            "4",
            "--frames",
            "2",
            "--size",
            "256x256",
            "--no-msaa",
            "--camera",
            "orbit:40,20",
        ];
        let Some(r) = window_or_skip("window-forest", &args) else { return };
        assert!(r.stdout.contains("showed 2 frame(s) of 256x256"), "{}", r.stdout);
        assert!(r.stdout.contains("1 sample(s) per pixel"), "{}", r.stdout);
        assert!(r.stdout.contains("4 tree(s)"), "{}", r.stdout);
    }

    #[test]
    fn window_flags_are_checked_before_any_work() {
        let dir = tempdir("flags");
        // `-o` means a file, `--window` a window: not both.
        let r = sylva(&["render", "lsys-honda-a", "--window", "-o", "x.png"], &dir);
        assert_ne!(r.code, 0);
        assert!(r.stderr.contains("--window") || r.stderr.contains("cannot be used"), "{}", r.stderr);
        // No display: refused with the reason, before growing anything.
        let no_display = [("DISPLAY", None), ("WAYLAND_DISPLAY", None)];
        let r = sylva_env(&["render", "lsys-honda-a", "--window", "--frames", "1"], &dir, &no_display);
        let stderr = &r.stderr;
        assert_eq!(r.code, 1, "{stderr}");
        assert!(stderr.contains("no display") && stderr.contains("xvfb-run"), "{stderr}");
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none(), "nothing is written");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
