//! Issue 39, items 10–13: the outputs of `sylva grow` are one transaction. A killed run
//! leaves no temporary (SIGTERM) or has its temporaries removed by the next run into the
//! same name (SIGKILL); a failing run leaves the files of an earlier run as they were;
//! a bad output path fails before any work; two runs into one name leave the files of
//! one of them.

mod common;

#[path = "../../sylva/tests/common/tmpfs.rs"]
mod tmpfs;

use common::folders::{leftovers, snapshot};
use common::{sylva, tempdir};
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;
use tmpfs::Tmpfs;

/// A small tree: the runs below grow it many times.
const SMALL: &str = "lsys-honda-a";

/// Starts `sylva args…` in `cwd`.
fn spawn(args: &[&str], cwd: &Path) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_sylva"))
        .args(args)
        .current_dir(cwd)
        .env("NO_COLOR", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the sylva binary starts")
}

/// Waits until a temporary appears in `dir` while `child` runs; false when the child
/// ended first.
fn wait_for_temporary(child: &mut std::process::Child, dir: &Path) -> bool {
    loop {
        if !leftovers(dir).iter().all(|n| n.ends_with(".lock")) {
            return true;
        }
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// A grow whose model stays staged for a while: the model is staged first, then the
/// (large) preview is rendered while its temporary waits.
fn slow_grow(preview_size: &str) -> [&str; 7] {
    ["grow", "lsys-honda-d", "-o", "t.glb", "--preview-size", preview_size, "--quiet"]
}

/// Starts a [`slow_grow`] with a 2048-pixel preview in `dir` and returns once its model's
/// temporary is there.
fn staged_grow(dir: &Path) -> std::process::Child {
    let mut child = spawn(&slow_grow("2048"), dir);
    assert!(wait_for_temporary(&mut child, dir), "the run ended before a temporary was seen");
    child
}

#[test]
fn item10_sigterm_during_a_write_leaves_no_temporary() {
    let d = tempdir("robust-out", "sigterm");
    let mut child = staged_grow(&d);
    let kill = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let status = child.wait().unwrap();
    // 15: SIGTERM; the run ends of the signal, as it would without a handler.
    assert_eq!(status.signal(), Some(15), "{status:?}");
    assert_eq!(leftovers(&d), Vec::<String>::new(), "temporaries left by a run stopped with SIGTERM");
    // Killed before its outputs were committed, so none of them is there either.
    assert!(!d.join("t.glb").exists() && !d.join("t.png").exists(), "{:?}", snapshot(&d).keys());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn item10_sigkill_temporaries_are_removed_by_the_next_run_into_the_name() {
    let d = tempdir("robust-out", "sigkill");
    let mut child = staged_grow(&d);
    child.kill().unwrap(); // SIGKILL: no cleanup possible
    child.wait().unwrap(); // reaped, so its PID is gone
    let stale = leftovers(&d);
    assert!(
        stale.iter().any(|n| n.starts_with(".t.glb.tmp-")),
        "a killed run leaves its temporary: {stale:?}"
    );
    let r = sylva(&slow_grow("64"), &d);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(leftovers(&d), Vec::<String>::new(), "the next run into t.glb removes the stale temporaries");
    let mut names: Vec<String> = snapshot(&d).into_keys().collect();
    names.sort();
    assert_eq!(names, ["t.glb", "t.png"]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn item11_a_failed_obj_export_leaves_the_earlier_files_as_they_were() {
    // An earlier good export: the OBJ, its .mtl, its texture PNGs and the preview.
    let d = tempdir("robust-out", "obj");
    let r = sylva(&["grow", SMALL, "-o", "t.obj", "--quiet"], &d);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let mut textures: Vec<String> =
        snapshot(&d).into_keys().filter(|n| n.starts_with("t_") && n.ends_with(".png")).collect();
    textures.sort();
    assert!(textures.len() >= 2, "the tree has texture files: {:?}", snapshot(&d).keys());
    // The next export cannot write its last texture (a folder is in the way), after the
    // others were written.
    let blocked = textures.last().unwrap();
    std::fs::remove_file(d.join(blocked)).unwrap();
    std::fs::create_dir(d.join(blocked)).unwrap();
    let before = snapshot(&d);
    let r = sylva(&["grow", SMALL, "-o", "t.obj", "--seed", "7", "--quiet"], &d);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains(blocked.as_str()), "the error names the file: {}", r.stderr);
    assert_eq!(snapshot(&d), before, "the earlier .obj, .mtl, textures and preview are untouched");
    assert_eq!(leftovers(&d), Vec::<String>::new());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn item12_a_bad_preview_path_fails_before_growing_and_writes_nothing() {
    let d = tempdir("robust-out", "preview");
    std::fs::create_dir(d.join("folder.png")).unwrap();
    let cases = [
        (vec!["--preview", "missing/p.png"], "does not exist"),
        (vec!["--preview", "folder.png"], "folder"),
        (vec!["--preview", "p.jpg"], ".png"),
        (vec!["--preview", "t.png", "--preview-wind", "t.png"], "same file"),
        (vec!["--no-preview", "--preview-wind", "missing/w.gif"], "--preview-wind"),
    ];
    for (extra, want) in cases {
        let mut args = vec!["grow", "lsys-honda-d", "-o", "t.glb"];
        args.extend(&extra);
        let r = sylva(&args, &d);
        assert_eq!(r.code, 1, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(want), "{args:?}: {}", r.stderr);
        assert!(!r.stdout.contains("derived"), "{args:?} fails before growing: {}", r.stdout);
        let names: Vec<String> = snapshot(&d).into_keys().collect();
        assert_eq!(names, ["folder.png"], "{args:?} writes nothing");
    }
    // The same for a bad model path: nothing is grown, nothing written.
    let r = sylva(&["grow", SMALL, "-o", "missing/t.glb"], &d);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("-o") && r.stderr.contains("does not exist"), "{}", r.stderr);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn item12_a_full_disk_after_the_model_leaves_nothing() {
    // How large the model and the preview are.
    let probe = tempdir("robust-out", "full-probe");
    let args = ["grow", SMALL, "-o", "t.glb", "--preview-size", "1024", "--quiet"];
    let r = sylva(&args, &probe);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let model = std::fs::metadata(probe.join("t.glb")).unwrap().len();
    let preview = std::fs::metadata(probe.join("t.png")).unwrap().len();
    let _ = std::fs::remove_dir_all(&probe);
    let page = 4096;
    let size = model.div_ceil(page) * page + 2 * page;
    assert!(preview > 3 * page, "the preview ({preview} bytes) must not fit in the room left");
    let Some(fs) = Tmpfs::mount("full-disk", tempdir("robust-out", "full-disk"), size) else { return };
    let r = sylva(&args, &fs.0);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("t.png") && r.stderr.contains("No space left"), "{}", r.stderr);
    assert_eq!(
        snapshot(&fs.0).into_keys().collect::<Vec<_>>(),
        Vec::<String>::new(),
        "neither the model nor a temporary is left when the preview does not fit"
    );
}

#[test]
fn item13_two_runs_into_one_name_leave_the_files_of_one_run() {
    // What each seed gives alone.
    let mut alone = Vec::new();
    for seed in ["1", "2"] {
        let d = tempdir("robust-out", &format!("alone{seed}"));
        let r = sylva(&["grow", "lsys-honda-d", "-o", "t.glb", "--seed", seed, "--quiet"], &d);
        assert_eq!(r.code, 0, "{}", r.stderr);
        alone.push((std::fs::read(d.join("t.glb")).unwrap(), std::fs::read(d.join("t.png")).unwrap()));
        let _ = std::fs::remove_dir_all(&d);
    }
    assert_ne!(alone[0], alone[1], "the seeds give different trees");
    let d = tempdir("robust-out", "together");
    for round in 0..3 {
        let mut children: Vec<_> = ["1", "2"]
            .map(|seed| spawn(&["grow", "lsys-honda-d", "-o", "t.glb", "--seed", seed, "--quiet"], &d))
            .into();
        for c in &mut children {
            assert!(c.wait().unwrap().success());
        }
        let got = (std::fs::read(d.join("t.glb")).unwrap(), std::fs::read(d.join("t.png")).unwrap());
        assert!(
            got == alone[0] || got == alone[1],
            "round {round}: the .glb and the .png come from different runs ({})",
            if got.0 == alone[0].0 { "glb of seed 1" } else { "glb of seed 2" }
        );
        assert_eq!(leftovers(&d), Vec::<String>::new());
    }
    let _ = std::fs::remove_dir_all(&d);
}
