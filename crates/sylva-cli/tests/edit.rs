//! `sylva edit` in a real window: under Xvfb (`xvfb-run`) on Mesa's software Vulkan the
//! editor opens, grows the tree, draws frames and closes by itself
//! (`--close-after-tree`), writing its frame log; the latency figures of BENCHMARKS.md
//! come from that log. Without a display it says so and exits 1. Skips where `xvfb-run`
//! is missing, unless `SYLVA_REQUIRE_XVFB=1` (as `.ci/run` sets it).

use std::process::Command;

fn sylva() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sylva"))
}

fn xvfb() -> bool {
    let found = Command::new("xvfb-run").arg("--help").output().is_ok();
    if !found {
        let required = std::env::var("SYLVA_REQUIRE_XVFB").is_ok_and(|v| !v.is_empty() && v != "0");
        assert!(!required, "SYLVA_REQUIRE_XVFB is set but xvfb-run is missing");
        eprintln!("skipping: xvfb-run is missing (apt install xvfb)");
    }
    found
}

#[test]
fn the_editor_opens_a_window_grows_and_closes() {
    if !xvfb() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("sylva-edit-window-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("frames.jsonl");
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1280x800x24"])
        .arg(env!("CARGO_BIN_EXE_sylva"))
        .args(["edit", "lsys-honda-a", "--close-after-tree", "5", "--frame-log"])
        .arg(&log)
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "sylva edit failed: {stderr}");
    let text = std::fs::read_to_string(&log).expect("the frame log was written");
    assert!(text.lines().any(|l| l.starts_with("{\"tree_shown\"")), "a tree was shown:\n{text}");
    assert!(text.lines().filter(|l| l.starts_with("{\"frame\"")).count() >= 5, "frames were drawn");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn without_a_display_it_says_so() {
    let out = sylva()
        .args(["edit", "lsys-honda-a"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no display"), "{stderr}");
}

#[test]
fn a_bad_input_is_refused_before_any_window() {
    let out = sylva().args(["edit", "no-such-preset"]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no-such-preset"), "{stderr}");
    let out = sylva().args(["edit", "lsys-honda-a", "--set", "mesh.sides=2"]).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("mesh.sides"));
}
