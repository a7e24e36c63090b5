//! `--watch`: the editor reloads a recipe file rewritten on disk and shows the new tree
//! within a second of the write (after the worker's grow: the test's own timing line is
//! from the write to the reloaded recipe, and to the tree). Also: a file that vanishes
//! or stops parsing keeps the last good tree and says why. Skips without a GPU adapter
//! unless `SYLVA_REQUIRE_GPU=1` (the view needs one; the watch itself does not).

use egui_kittest::Harness;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use sylva_editor::{Document, EditOptions, EditorApp};

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sylva-edit-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Steps frames until `done` holds or `limit` passes; the time it took.
fn until(
    h: &mut Harness<'_, EditorApp>,
    limit: Duration,
    done: impl Fn(&EditorApp) -> bool,
) -> Option<Duration> {
    let start = Instant::now();
    while start.elapsed() < limit {
        h.step();
        if done(h.state()) {
            return Some(start.elapsed());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    None
}

#[test]
fn a_rewritten_recipe_is_reloaded_and_grown() {
    if sylva_gpu::Gpu::or_skip("the editor's --watch test").is_none() {
        return;
    }
    let dir = folder("watch");
    let path = dir.join("tree.toml");
    std::fs::write(&path, "preset = \"lsys-binary-tree\"\n[mesh]\nsides = 6\n").unwrap();
    let doc = Document::open(Some(path.to_str().unwrap())).unwrap();
    let opts = EditOptions { watch: true, full_resolution: true, ..Default::default() };
    let mut h = Harness::builder()
        .with_size([900.0, 600.0])
        .wgpu()
        .build_eframe(move |cc| EditorApp::from_creation_context(cc, doc, opts));
    assert!(h.state_mut().wait_settled(Duration::from_secs(120)));
    h.run_steps(2);
    let before = h.state().tree().unwrap().report.triangles;

    // Rewrite the file: the editor reloads it and grows the new recipe.
    std::fs::write(&path, "preset = \"lsys-binary-tree\"\n[mesh]\nsides = 12\n").unwrap();
    let reloaded = until(&mut h, Duration::from_secs(5), |a| a.document().recipe().mesh.sides == 12);
    let reloaded = reloaded.expect("the rewritten recipe was reloaded");
    assert!(reloaded < Duration::from_secs(1), "reloaded {reloaded:?} after the write");
    let shown = until(&mut h, Duration::from_secs(60), |a| {
        a.settled() && a.tree().is_some_and(|t| t.recipe.mesh.sides == 12)
    })
    .expect("the new tree is shown");
    eprintln!("--watch: recipe reloaded {reloaded:?} and its tree shown {shown:?} after the reload");
    assert_ne!(h.state().tree().unwrap().report.triangles, before, "12 sides make another mesh");

    // A broken file keeps the last good tree and says why.
    std::fs::write(&path, "preset = \"lsys-binary-tree\"\n[mesh]\nsides = 2\n").unwrap();
    until(&mut h, Duration::from_secs(5), |a| a.message().is_some_and(|m| m.contains("mesh.sides")))
        .expect("the refused value is reported");
    assert_eq!(h.state().document().recipe().mesh.sides, 12);
    // A vanished file too.
    std::fs::remove_file(&path).unwrap();
    until(&mut h, Duration::from_secs(5), |a| a.message().is_some_and(|m| m.contains("not reloaded")))
        .expect("the vanished file is reported");
    assert!(h.state().tree().is_some(), "the last good tree stays");
    let _ = std::fs::remove_dir_all(&dir);
}
