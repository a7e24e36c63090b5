//! The editor's kittest harness, shared by the UI test files: the editor on a preset or
//! file in a headless window drawn by wgpu (lavapipe in `.ci/run`), and waiting for its
//! trees. Each test file uses part of it.
#![allow(dead_code)]

use egui_kittest::Harness;
use std::time::Duration;
use sylva_editor::{Document, EditOptions, EditorApp};

/// Generous: a debug-profile grow on a busy 2-core machine.
pub const WAIT: Duration = Duration::from_secs(240);

/// The editor on `what` in a `size` window at full resolution (snapshots compare
/// exactly); `None`, with a printed reason naming `tests`, where no GPU adapter exists
/// (unless `SYLVA_REQUIRE_GPU=1`).
pub fn harness(what: &str, tests: &str, size: [f32; 2]) -> Option<Harness<'static, EditorApp>> {
    sylva_gpu::Gpu::or_skip(tests)?;
    let doc = Document::open(Some(what)).expect("the preset or model opens");
    let h = Harness::builder().with_size(size).wgpu().build_eframe(move |cc| {
        EditorApp::from_creation_context(cc, doc, EditOptions { full_resolution: true, ..Default::default() })
    });
    Some(h)
}

/// Waits for the newest recipe's tree (or failure), then draws a few frames with it.
pub fn wait(h: &mut Harness<'_, EditorApp>) {
    assert!(h.state_mut().wait_settled(WAIT), "the tree was grown within {WAIT:?}");
    h.run_steps(3);
}

/// [`wait`], and no error is shown.
pub fn settle(h: &mut Harness<'_, EditorApp>) {
    wait(h);
    assert_eq!(h.state().message(), None, "no error is shown");
}

/// The triangles of the tree shown.
pub fn triangles(h: &Harness<'_, EditorApp>) -> usize {
    h.state().tree().expect("a tree is shown").report.triangles
}
