//! The editor driven headless through its real UI (egui_kittest on wgpu — lavapipe in
//! `.ci/run`): pick a preset, move a leaf slider, undo, change the mesher, set a seed;
//! each step checks what the session grew and that the rendered window changed. Skips
//! with a printed reason where no GPU adapter exists, unless `SYLVA_REQUIRE_GPU=1`.

use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use sylva::recipe::MeshMethod;
use sylva::Stage;
use sylva_editor::EditorApp;

mod common;
use common::{settle, triangles, WAIT};

fn harness(what: &str) -> Option<Harness<'static, EditorApp>> {
    common::harness(what, "the editor's UI tests", [1100.0, 760.0])
}

/// Scrolls the control named `name` into view and draws two frames.
fn reveal(h: &mut Harness<'_, EditorApp>, name: &str) {
    h.get_by_label(name).scroll_to_me();
    h.run_steps(2);
}

/// Closes the drop-down `name` (an accessibility click picks an item but leaves the
/// popup open, where a pointer click would close it): a second click on its button.
fn close_popup(h: &mut Harness<'_, EditorApp>, name: &str) {
    h.get_by_label(name).click_accesskit();
    h.run_steps(2);
}

/// The rendered window (the view and the panel).
fn snapshot(h: &mut Harness<'_, EditorApp>) -> Vec<u8> {
    h.render().expect("the window renders").into_raw()
}

#[test]
fn pick_slider_undo_mesher_seed() {
    let Some(mut h) = harness(sylva::presets::DEFAULT_PRESET) else { return };
    settle(&mut h);

    // Pick a preset from the menu bar.
    h.get_by_label("preset picker").click_accesskit();
    h.run_steps(2);
    reveal(&mut h, "wp-quaking-aspen");
    h.get_by_label("wp-quaking-aspen").click_accesskit();
    close_popup(&mut h, "preset picker");
    h.run_steps(2);
    settle(&mut h);
    assert_eq!(h.state().document().source().to_string(), "wp-quaking-aspen");
    let aspen = triangles(&h);
    assert!(aspen > 1000, "{aspen}");
    let before = snapshot(&mut h);
    // `SYLVA_EDITOR_SCREENSHOT=docs/images/editor.png` saves this view for docs/editor.md.
    if let Ok(path) = std::env::var("SYLVA_EDITOR_SCREENSHOT") {
        let image = h.render().expect("the window renders");
        let (w, ht) = image.dimensions();
        let png = sylva::image::Image::from_rgba(w, ht, image.into_raw()).to_png().unwrap();
        std::fs::write(path, png).unwrap();
    }

    // Move a leaf slider (accessibility increments; a pointer drag did not move it in
    // kittest): only the stages after the skeleton run again.
    let cutoff = h.state().document().recipe().leaves.alpha_cutoff;
    reveal(&mut h, "leaves.alpha_cutoff");
    for _ in 0..5 {
        h.get_by_label("leaves.alpha_cutoff").increment_accesskit();
        h.run_steps(1);
    }
    settle(&mut h);
    let dragged = h.state().document().recipe().leaves.alpha_cutoff;
    assert!(dragged > cutoff, "the slider moved the value up: {cutoff} → {dragged}");
    let stages = h.state().last_stages().expect("a run finished").to_vec();
    assert!(!stages.contains(&Stage::Generate), "a leaf setting does not regrow the skeleton: {stages:?}");

    // Undo from the menu bar: the last slider step goes back, and is grown again.
    h.get_by_label("Undo").click_accesskit();
    h.run_steps(2);
    settle(&mut h);
    let undone = h.state().document().recipe().leaves.alpha_cutoff;
    assert!(cutoff < undone && undone < dragged, "one step undone: {cutoff} < {undone} < {dragged}");
    assert!(h.state().document().can_redo());
    assert_eq!(
        h.state().tree().unwrap().recipe.leaves.alpha_cutoff,
        undone,
        "the tree shown is the undone recipe's"
    );

    // Change the mesher from its drop-down.
    reveal(&mut h, "mesh.method");
    h.get_by_label("mesh.method").click_accesskit();
    h.run_steps(2);
    h.get_by_label("quad").click_accesskit();
    close_popup(&mut h, "mesh.method");
    h.run_steps(2);
    settle(&mut h);
    assert_eq!(h.state().document().recipe().mesh.method, MeshMethod::Quad);
    assert_ne!(triangles(&h), aspen, "the quad mesher makes another mesh");
    let after = snapshot(&mut h);
    assert_ne!(before, after, "the window shows the new tree");

    // Type a seed (the control is the second node named `seed`, after its label).
    h.get_all_by_label("seed").last().unwrap().scroll_to_me();
    h.run_steps(2);
    h.get_all_by_label("seed").last().unwrap().set_value_accesskit(4242.0);
    h.run_steps(2);
    settle(&mut h);
    assert_eq!(h.state().document().recipe().seed, 4242);
}

#[test]
fn a_refused_value_keeps_the_last_tree_and_says_why() {
    let Some(mut h) = harness("lsys-honda-a") else { return };
    settle(&mut h);
    let shown = triangles(&h);
    h.state_mut().apply("mesh.sides", toml::Value::Integer(2), false);
    h.run_steps(2);
    let message = h.state().message().expect("a message is shown").to_string();
    assert!(message.contains("mesh.sides"), "{message}");
    assert_eq!(triangles(&h), shown, "the last good tree stays");
    // A run that fails in the engine (a derivation over its budget) also keeps it.
    h.state_mut().apply("generator.max_modules", toml::Value::Integer(5), false);
    assert!(h.state_mut().wait_settled(WAIT));
    h.run_steps(2);
    assert!(h.state().message().is_some(), "the failed run says why");
    assert_eq!(triangles(&h), shown);
}

#[test]
fn exports_the_tree_and_a_picture_of_the_view() {
    let Some(mut h) = harness("lsys-honda-a") else { return };
    settle(&mut h);
    let dir = std::env::temp_dir().join(format!("sylva-edit-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (glb, png) = (dir.join("tree.glb"), dir.join("view.png"));
    h.state_mut().set_file_name(glb.to_str().unwrap());
    h.state_mut().export();
    assert_eq!(&std::fs::read(&glb).unwrap()[..4], b"glTF", "{:?}", h.state().message());
    h.state_mut().set_file_name(png.to_str().unwrap());
    h.state_mut().export();
    let bytes = std::fs::read(&png).unwrap_or_else(|e| panic!("{e}: {:?}", h.state().message()));
    assert_eq!(&bytes[1..4], b"PNG");
    let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut pixels).unwrap();
    let corner = &pixels[..4];
    let tree = pixels.chunks(4).filter(|p| p != &corner).count();
    assert!(tree > 1000, "the picture shows the tree ({tree} pixels differ from the corner)");
    // An unwritable name is a message, not a crash.
    h.state_mut().set_file_name(dir.join("missing-folder/x.png").to_str().unwrap());
    h.state_mut().export();
    assert!(h.state().message().is_some_and(|m| m.starts_with("cannot save")), "{:?}", h.state().message());

    // Save the recipe with a change, open it again through the menu's Open button.
    h.state_mut().apply("leaves.alpha_cutoff", toml::Value::Float(0.625), false);
    settle(&mut h);
    let recipe = dir.join("saved.toml");
    h.state_mut().set_file_name(recipe.to_str().unwrap());
    h.state_mut().save();
    h.state_mut().open(Some(sylva::presets::DEFAULT_PRESET));
    settle(&mut h);
    assert_ne!(h.state().document().recipe().leaves.alpha_cutoff, 0.625);
    h.state_mut().set_file_name(recipe.to_str().unwrap());
    h.run_steps(1);
    h.get_by_label("Open").click_accesskit();
    h.run_steps(1);
    assert_eq!(h.state().document().source(), &sylva_editor::document::Source::File(recipe.clone()));
    settle(&mut h);
    assert_eq!(h.state().document().recipe().leaves.alpha_cutoff, 0.625, "the saved change is back");
    assert_eq!(h.state().document().recipe().name, "lsys-honda-a");
    // A file that does not exist is a message; the document stays.
    h.state_mut().set_file_name(dir.join("nothing-here.toml").to_str().unwrap());
    h.run_steps(1);
    h.get_by_label("Open").click_accesskit();
    h.run_steps(1);
    assert!(h.state().message().is_some_and(|m| m.starts_with("cannot open")), "{:?}", h.state().message());
    assert_eq!(h.state().document().source(), &sylva_editor::document::Source::File(recipe));
    let _ = std::fs::remove_dir_all(&dir);
}
