//! The grammar editor driven headless through the editor's real UI (egui_kittest on
//! wgpu — lavapipe in `.ci/run`): open an `.l` model, type into its text to break it
//! (the error is shown at its line and column, a click puts the cursor there, the last
//! tree stays), fix it (the tree regrows), move a `#define` slider (the text's number
//! changes and so does the tree), save the grammar. Skips with a printed reason where
//! no GPU adapter exists, unless `SYLVA_REQUIRE_GPU=1`.

use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use std::path::PathBuf;
use std::time::Duration;
use sylva::Stage;
use sylva_editor::grammar::{self, Location};
use sylva_editor::EditorApp;

mod common;
use common::{triangles, wait};

fn harness(what: &str) -> Option<Harness<'static, EditorApp>> {
    common::harness(what, "the grammar editor's UI tests", [1300.0, 800.0])
}

/// A small parametric model: `N` steps of a branching apex.
const MODEL: &str = "/* the grammar editor's test model */
#define N 3
#define ANG 30
#define LEN 1.0

Lsystem: 1
derivation length: N
Axiom: A
A --> F(LEN)[+(ANG)/(90)A][-(ANG)/(90)A]
endlsystem
";

/// Lets the typing pause past the debounce, so the next frame gives it to the worker.
fn pause_typing(h: &mut Harness<'_, EditorApp>) {
    std::thread::sleep(sylva_editor::document::GRAMMAR_DEBOUNCE + Duration::from_millis(50));
    h.run_steps(2);
}

fn text(h: &Harness<'_, EditorApp>) -> String {
    h.state().document().grammar().expect("the grammar is held").text.clone()
}

/// A folder with the test model in it (removed by the caller).
fn model_folder(tag: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("sylva-edit-grammar-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("plant.l");
    std::fs::write(&path, MODEL).unwrap();
    (dir, path)
}

/// The character index of the grammar editor's cursor.
fn cursor(h: &Harness<'_, EditorApp>) -> Option<usize> {
    let state = egui::TextEdit::load_state(&h.ctx, grammar::text_id())?;
    state.cursor.char_range().map(|r| r.primary.index.0)
}

#[test]
fn break_fix_slide_and_save_a_grammar() {
    let (dir, path) = model_folder("edit");
    let Some(mut h) = harness(path.to_str().unwrap()) else { return };
    wait(&mut h);
    assert_eq!(h.state().message(), None);
    assert_eq!(text(&h), MODEL, "the editor shows the file's text");
    let good = triangles(&h);
    assert!(good > 0);
    let name = path.display().to_string();

    // Type at the end of the text (the cursor's place when the editor takes the focus):
    // text after `endlsystem` is a syntax error on line 11.
    h.get_by_label("grammar text").focus();
    h.run_steps(2);
    h.get_by_label("grammar text").type_text("oops");
    h.run_steps(1);
    assert_eq!(text(&h), format!("{MODEL}oops"));
    assert!(h.state().document().grammar().unwrap().pending(), "not regrown while typing");
    pause_typing(&mut h);
    assert!(!h.state().document().grammar().unwrap().pending(), "given to the worker after the pause");
    wait(&mut h);
    let message = h.state().message().expect("the failed run says why").to_string();
    let (at, _) = grammar::locate(&message, &name).unwrap_or_else(|| panic!("located in {name}: {message}"));
    assert_eq!(at, Location { line: 11, column: 1 }, "{message}");
    assert_eq!(triangles(&h), good, "the last good tree stays");
    // `SYLVA_EDITOR_GRAMMAR_SCREENSHOT=file.png` saves the window showing the error.
    if let Ok(shot) = std::env::var("SYLVA_EDITOR_GRAMMAR_SCREENSHOT") {
        let image = h.render().expect("the window renders");
        let (w, ht) = image.dimensions();
        let png = sylva::image::Image::from_rgba(w, ht, image.into_raw()).to_png().unwrap();
        std::fs::write(shot, png).unwrap();
    }
    // The panel shows the place; a click puts the cursor there.
    h.get_by_label_contains("line 11, column 1").click_accesskit();
    h.run_steps(2);
    assert_eq!(cursor(&h), Some(MODEL.chars().count()), "the cursor is at line 11, column 1");

    // Fix it: delete what was typed (from the cursor the click put there).
    for _ in 0..4 {
        h.key_press(egui::Key::Delete);
        h.run_steps(1);
    }
    assert_eq!(text(&h), MODEL);
    pause_typing(&mut h);
    wait(&mut h);
    assert_eq!(h.state().message(), None, "the error is gone");
    assert!(h.state().last_stages().unwrap().contains(&Stage::Generate), "the tree was regrown");
    assert_eq!(triangles(&h), good);

    // A `#define` slider rewrites that number in the text and regrows.
    h.get_by_label("#define N").scroll_to_me();
    h.run_steps(2);
    h.get_by_label("#define N").increment_accesskit();
    h.run_steps(2);
    assert_eq!(text(&h), MODEL.replace("#define N 3\n", "#define N 4\n"), "only the number changed");
    wait(&mut h);
    assert_eq!(h.state().message(), None);
    let more = triangles(&h);
    assert!(more > good, "one more step grows more: {good} → {more}");

    // Save grammar writes the file it came from; Save recipe does not overwrite it.
    h.get_by_label("Save grammar").click_accesskit();
    h.run_steps(2);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), text(&h), "{:?}", h.state().message());
    assert!(!h.state().document().grammar().unwrap().modified());
    h.get_by_label("Save recipe").click_accesskit();
    h.run_steps(2);
    let recipe = path.with_extension("toml");
    assert!(recipe.exists(), "the recipe is saved beside the model: {:?}", h.state().message());
    assert!(std::fs::read_to_string(&path).unwrap().contains("Lsystem: 1"), "the model is still the model");
    let back = sylva::recipe::Loaded::from_file(&recipe).unwrap();
    assert_eq!(back.read("plant.l").unwrap().1, text(&h));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_define_the_recipe_sets_moves_the_recipe_key() {
    let Some(mut h) = harness("lsys-honda-a") else { return };
    wait(&mut h);
    let before = text(&h);
    let good = triangles(&h);
    assert!(before.contains("#define N 10"), "honda's grammar is shown");
    // The preset's `generator.define.N = 10` wins over the file's line: the slider moves
    // the recipe key (an undo step), and the text stays.
    h.get_by_label("#define N").scroll_to_me();
    h.run_steps(2);
    h.get_by_label("#define N").decrement_accesskit();
    h.run_steps(2);
    let n = |h: &Harness<'_, EditorApp>| match &h.state().document().recipe().generator {
        sylva::recipe::Generator::Lsystem(g) => g.define.get("N").cloned(),
        _ => None,
    };
    assert_eq!(n(&h), Some(toml::Value::Integer(9)));
    assert_eq!(text(&h), before);
    wait(&mut h);
    assert!(triangles(&h) < good, "one step fewer");
    // Ctrl+Z in the text editor is the text's own undo, not the recipe's.
    h.get_by_label("grammar text").focus();
    h.run_steps(2);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(n(&h), Some(toml::Value::Integer(9)), "the recipe step is still there");
    h.get_by_label("Undo").click_accesskit();
    h.run_steps(2);
    assert_eq!(n(&h), Some(toml::Value::Integer(10)));
    // The panel's own toggle hides it.
    h.get_by_label("Grammar").click_accesskit();
    h.run_steps(2);
    assert!(h.query_by_label("grammar text").is_none(), "the panel is hidden");
}
