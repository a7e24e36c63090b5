//! The view's "View" row driven headless through the real UI (egui_kittest on wgpu —
//! lavapipe in `.ci/run`; issue 41 item 2): turning the ground, the wireframe, the
//! skeleton, the cage and a fixed level of detail on or off each changes the rendered
//! window, and the cage (the mesher's control mesh) has fewer triangles than the refined
//! bark. The UI tests skip with a printed reason where no GPU adapter exists, unless
//! `SYLVA_REQUIRE_GPU=1`; the cage's own test needs no adapter.

use egui_kittest::kittest::{NodeT, Queryable};
use egui_kittest::Harness;
use std::time::{Duration, Instant};
use sylva::Mesh;
use sylva_editor::worker::cage_mesh;
use sylva_editor::{Document, EditorApp};

mod common;
use common::{settle, WAIT};

fn harness(what: &str) -> Option<Harness<'static, EditorApp>> {
    common::harness(what, "the editor's view tests", [1100.0, 760.0])
}

/// The 3D view's pixels in the rendered window ("tree view"): what changes when only
/// the view changes, not a check box's tick.
fn view_part(h: &mut Harness<'_, EditorApp>) -> Vec<u8> {
    let rect = h.get_by_label("tree view").rect();
    let image = h.render().expect("the window renders");
    let scale = image.width() as f32 / h.ctx.content_rect().width();
    let px = |v: f32| (v * scale).round() as u32;
    let (x0, x1) = (px(rect.min.x), px(rect.max.x).min(image.width()));
    let (y0, y1) = (px(rect.min.y), px(rect.max.y).min(image.height()));
    assert!(x1 > x0 + 100 && y1 > y0 + 100, "the view is shown: {rect:?}");
    (y0..y1).flat_map(|y| (x0..x1).map(move |x| (x, y))).flat_map(|(x, y)| image.get_pixel(x, y).0).collect()
}

/// Clicks the control named `name` and draws two frames; returns the view before and
/// after.
fn click(h: &mut Harness<'_, EditorApp>, name: &str) -> (Vec<u8>, Vec<u8>) {
    let before = view_part(h);
    h.get_by_label(name).click_accesskit();
    h.run_steps(2);
    (before, view_part(h))
}

/// Triangles of a mesh's faces, fan-triangulated.
fn triangles(m: &Mesh) -> usize {
    (0..m.face_count()).map(|f| m.face(f).len().saturating_sub(2)).sum()
}

/// The Honda tree meshed by the quad mesher with one level of Catmull–Clark refinement.
fn quad_honda() -> Document {
    let mut doc = Document::open(Some("lsys-honda-a")).expect("the preset opens");
    doc.set("mesh.method", toml::Value::String("quad".into()), false).unwrap();
    doc.set("refine.levels", toml::Value::Integer(1), false).unwrap();
    doc
}

#[test]
fn the_cage_is_the_unrefined_control_mesh() {
    let doc = quad_honda();
    let mut session = sylva::Session::new(doc.loaded().clone());
    let tree = session.run().expect("the tree grows").clone();
    let bark = &tree.model.parts[0];
    assert_eq!(bark.name, "bark");
    let cage = cage_mesh(&tree.recipe, &tree.skeleton).expect("the cage meshes");
    let (n_cage, n_bark) = (triangles(&cage), triangles(&bark.mesh));
    assert!(n_cage > 100, "{n_cage}");
    // One Catmull–Clark level makes four quads of each cage quad.
    assert!(n_cage * 3 < n_bark, "the cage has {n_cage} triangles, the refined bark {n_bark}");
    // The cage of the same tree is the same mesh (it is a function of the skeleton and
    // the recipe).
    assert_eq!(cage_mesh(&tree.recipe, &tree.skeleton).unwrap(), cage);
}

#[test]
fn view_toggles_change_the_picture() {
    let Some(mut h) = harness("lsys-honda-a") else { return };
    settle(&mut h);
    for name in ["Ground", "Wireframe", "Skeleton"] {
        let (before, after) = click(&mut h, name);
        assert_ne!(before, after, "turning `{name}` over changes the view");
        let (_, back) = click(&mut h, name);
        assert_eq!(back, before, "turning `{name}` back restores the picture");
    }

    // A fixed level of detail: give the tree a LOD chain, then pick its coarsest level.
    if let Ok(dir) = std::env::var("SYLVA_VIEW_DUMP") {
        h.get_by_label("Wireframe").click_accesskit();
        h.get_by_label("Skeleton").click_accesskit();
        h.run_steps(2);
        h.render().unwrap().save(format!("{dir}/view-window.png")).unwrap();
        h.get_by_label("Wireframe").click_accesskit();
        h.get_by_label("Skeleton").click_accesskit();
        h.run_steps(2);
    }
    let budgets = toml::Value::Array(vec![toml::Value::Integer(50_000), toml::Value::Integer(300)]);
    h.state_mut().apply("lod.levels", budgets, false);
    settle(&mut h);
    let auto = view_part(&mut h);
    h.get_by_label("Level of detail").click_accesskit();
    h.run_steps(2);
    h.get_by_label("LOD 1").click_accesskit();
    h.get_by_label("Level of detail").click_accesskit();
    h.run_steps(3);
    assert_ne!(view_part(&mut h), auto, "the coarse level is another picture");
}

/// The text of the View row's cage label (`cage: …`), if it is shown.
fn cage_row(h: &Harness<'_, EditorApp>) -> Option<String> {
    let node = h.query_all_by(|n| n.value().is_some_and(|v| v.starts_with("cage: "))).next()?;
    node.accesskit_node().value()
}

#[test]
fn the_cage_is_drawn_once_meshed_off_the_ui_thread() {
    let Some(mut h) = harness("lsys-honda-a") else { return };
    settle(&mut h);
    h.state_mut().apply("mesh.method", toml::Value::String("quad".into()), false);
    h.state_mut().apply("refine.levels", toml::Value::Integer(1), false);
    settle(&mut h);
    let before = view_part(&mut h);
    h.get_by_label("Cage").click_accesskit();
    // The frames go on while the cage thread meshes; its count shows when it is done.
    let started = Instant::now();
    let label = loop {
        h.run_steps(1);
        let row = cage_row(&h);
        if let Some(text) = row.as_ref().filter(|t| t.ends_with(" triangles")) {
            break text.clone();
        }
        assert!(started.elapsed() < WAIT, "the cage was meshed within {WAIT:?}; the row says {row:?}");
        std::thread::sleep(Duration::from_millis(20));
    };
    h.run_steps(2);
    let cage: usize = label
        .trim_start_matches("cage: ")
        .trim_end_matches(" triangles")
        .parse()
        .unwrap_or_else(|e| panic!("`{label}`: {e}"));
    let bark = triangles(&h.state().tree().expect("a tree is shown").model.parts[0].mesh);
    assert!(cage > 0 && cage * 3 < bark, "the cage has {cage} triangles, the refined bark {bark}");
    assert_ne!(view_part(&mut h), before, "the cage's edges are drawn");
}
