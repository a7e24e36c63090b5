//! Issue 39, items 1, 8 and 15, through the `sylva` binary: errors on lines of any
//! length print a short, located report and never panic (item 1); thread counts are
//! bounded with a message naming `--threads` (item 8); type and range errors name the
//! key or flag and the limit (item 15).

mod common;

use common::{sylva, sylva_env, tempdir, Run};
use std::path::Path;
use std::process::Command;

/// Line length of the hostile inputs.
const LINE: usize = 200_000;
/// Column of the error in them (about).
const COL: usize = 150_000;
/// The most a report may take on stderr.
const MAX_REPORT: usize = 4096;

/// Checks a failed run: exit 1, no panic, a short report that contains `want`.
fn fails_short(r: &Run, want: &str) {
    let head = &r.stderr[..r.stderr.len().min(1500)];
    assert_eq!(r.code, 1, "exit {}: {head}", r.code);
    assert!(!r.stderr.contains("panicked"), "{head}");
    assert!(r.stderr.len() < MAX_REPORT, "a {}-byte report: {head}", r.stderr.len());
    assert!(r.stderr.contains(want), "no `{want}` in: {head}");
}

/// Runs `sylva grow <file> -o out.glb --no-preview` on `text` written to `dir/name`.
fn grow_file(dir: &Path, name: &str, text: &str) -> Run {
    std::fs::write(dir.join(name), text).unwrap();
    sylva(&["grow", name, "-o", "out.glb", "--no-preview"], dir)
}

#[test]
fn item01_long_lines_give_short_located_reports_on_every_reader() {
    let dir = tempdir("robustness-messages", "long-lines");
    let ops = "MovRel3f(0,0,0) ".repeat(COL / 16);
    let lst = format!("LST 0.1\n{ops}Bogus(1) {}\n", " ".repeat(LINE - ops.len()));
    let r = grow_file(&dir, "long.lst", &lst);
    fails_short(&r, &format!("long.lst:2:{}", ops.len() + 1));

    let mods = "F ".repeat(COL / 2);
    let s = format!("{mods}F(1,x) {}", "F ".repeat((LINE - COL) / 2));
    let r = grow_file(&dir, "long.str", &s);
    fails_short(&r, &format!("long.str:1:{}", mods.len() + 5));

    let pad = "F".repeat(COL - 8);
    let l = format!("Lsystem: 1\nAxiom: {pad}F(1,,2){}\nendlsystem\n", "F".repeat(LINE - COL));
    let r = grow_file(&dir, "long.l", &l);
    fails_short(&r, "long.l:2:1500");

    let json = format!("{{{}\"format\": x{}}}", " ".repeat(COL), " ".repeat(LINE - COL));
    let r = grow_file(&dir, "long.skel.json", &json);
    fails_short(&r, "long.skel.json:1:1500");

    let toml = format!("name = \"t\"\nx = [{}x]\n", "1, ".repeat(COL / 3));
    let r = grow_file(&dir, "long.toml", &toml);
    fails_short(&r, &format!("line 2, column {}", 6 + 3 * (COL / 3)));
    // Nothing was written.
    assert!(!dir.join("out.glb").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn item01_long_set_values_give_short_reports() {
    let dir = tempdir("robustness-messages", "long-set");
    // One argument may hold at most 128 KiB on Linux: 120,000 characters.
    let items = "1, ".repeat(30_000);
    let kv = format!("generator.angle=[{items}x, {}]", "2, ".repeat(9_000));
    let r = sylva(&["grow", "lsys-binary-tree", "--set", &kv, "-o", "out.glb"], &dir);
    fails_short(&r, &format!("column {}", items.len() + 2));
    assert!(r.stderr.contains("generator.angle"), "{}", r.stderr);
    let z = "z".repeat(120_000);
    for kv in [format!("generator.angle={z}"), format!("{z}=1"), z.clone(), format!("generator.{z}=1")] {
        let r = sylva(&["grow", "lsys-binary-tree", "--set", &kv, "-o", "out.glb"], &dir);
        fails_short(&r, "zzzz…");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn item08_thread_counts_are_bounded_and_named() {
    let dir = tempdir("robustness-messages", "threads");
    std::fs::write(dir.join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    for n in ["100000", "0", "1e9", "99999999999999999999999"] {
        let r = sylva(&["subdivide", "t.obj", "-o", "o.obj", "--threads", n], &dir);
        assert_ne!(r.code, 0, "--threads {n}");
        assert!(r.stderr.contains("--threads") && r.stderr.contains("1..=1024"), "{}", r.stderr);
        assert!(!dir.join("o.obj").exists());
    }
    let r = sylva(&["subdivide", "t.obj", "-o", "o.obj", "--threads", "3"], &dir);
    assert_eq!(r.code, 0, "{}", r.stderr);

    // rayon's own setting is bounded the same way (it panicked at the first parallel step).
    let r =
        sylva_env(&["subdivide", "t.obj", "-o", "o2.obj"], &dir, &[("RAYON_NUM_THREADS", Some("100000"))]);
    let err = &r.stderr;
    assert_eq!(r.code, 1, "{err}");
    assert!(err.contains("RAYON_NUM_THREADS=100000") && err.contains("1024"), "{err}");
    assert!(!dir.join("o2.obj").exists());

    // A pool the system refuses (here: 1024 stacks in a 1.5 GB address space) names the
    // threads too, where the shell can set the limit.
    if cfg!(target_os = "linux") {
        let bin = env!("CARGO_BIN_EXE_sylva");
        let out = Command::new("sh")
            .arg("-c")
            .arg(format!("ulimit -v 1500000 && exec '{bin}' subdivide t.obj -o o3.obj --threads 1024"))
            .current_dir(&dir)
            .env("NO_COLOR", "1")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{err}");
        // 1024 stacks of 2 MiB cannot fit 1.5 GB: refused before any thread starts (a
        // pool started regardless aborted when its last threads' signal stacks could
        // not be mapped, on CI).
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains("--threads 1024") && err.contains("ulimit -v"), "{err}");
        assert!(!dir.join("o3.obj").exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn item15_type_and_range_errors_name_the_key_or_flag_and_the_limit() {
    let dir = tempdir("robustness-messages", "messages");
    let grow = |args: &[&str]| {
        let mut a = vec!["grow", "lsys-binary-tree", "-o", "out.glb", "--no-preview"];
        a.extend_from_slice(args);
        sylva(&a, &dir)
    };
    let r = grow(&["--set", "generator.iterations=1e9"]);
    fails_short(&r, "`generator.iterations`");
    assert!(r.stderr.contains("whole number in 0..=4294967295"), "{}", r.stderr);

    let r = grow(&["--lod", "1e12"]);
    fails_short(&r, "--lod 1e12");
    assert!(r.stderr.contains("out of range") && r.stderr.contains("12..=10000000"), "{}", r.stderr);
    assert!(!r.stderr.contains("neither"), "{}", r.stderr);
    let r = grow(&["--lod", "30000,lots"]);
    fails_short(&r, "neither a triangle budget");

    // clap's flags: every bad number names the flag and its range.
    for (args, flag, range) in [
        (&["grow", "lsys-binary-tree", "-n", "1e9"][..], "--iterations", "0..=4294967295"),
        (&["grow", "lsys-binary-tree", "-n", "99999999999"][..], "--iterations", "0..=4294967295"),
        (
            &["grow", "lsys-binary-tree", "--seed", "99999999999999999999"][..],
            "--seed",
            "0..=9223372036854775807",
        ),
        (&["grow", "lsys-binary-tree", "--preview-size", "100000"][..], "--preview-size", "1..=8192"),
        (&["render", "lsys-binary-tree", "--frames", "1e12"][..], "--frames", "1..=1200"),
        (&["render", "lsys-binary-tree", "--forest", "99999999999"][..], "--forest", "1..=10000"),
        (&["render", "lsys-binary-tree", "--fps", "1000"][..], "--fps", "1..=60"),
    ] {
        let r = sylva(args, &dir);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(flag) && r.stderr.contains(range), "{args:?}: {}", r.stderr);
    }
    let r = sylva(&["render", "lsys-binary-tree", "--size", "99999999999x5"], &dir);
    fails_short(&r, "--size 99999999999x5: width and height must each be in 1..=8192");
    assert!(!dir.join("out.glb").exists() && !dir.join("render.png").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
