//! cpfg language details that models in the wild use (issue 26, "cpfg language"): a
//! successor continued on a line that begins with `#(`, blanks between a module and its
//! parameters, `\` continuations inside `#define`, and lpfg models, which get an
//! `unsupported:` error naming lpfg.

use sylva::lsystem::{DeriveOptions, ErrorKind, LSystem, DEFAULT_MODULE_BUDGET};

/// Parses `text` and derives `steps` steps; the derived string as text.
fn derive(text: &str, steps: u32) -> String {
    let l = LSystem::parse("t.l", text, &[]).unwrap_or_else(|e| panic!("{}", e.message));
    let s = l.derive(&DeriveOptions { steps, budget: DEFAULT_MODULE_BUDGET, seed: 1 }).unwrap();
    l.format(&s)
}

/// `A --> F(1)` followed by a line `\t#(0.06) F(5)`: the second line continues the
/// successor (cpfg's `#` is the width module). It was taken for a preprocessor null
/// directive and dropped, so `A` derived `F(1)`.
#[test]
fn a_successor_continues_on_a_line_that_begins_with_a_width_module() {
    let text = "Lsystem: 1\nderivation length: 1\nAxiom: A\nA --> F(1)\n\t#(0.06) F(5)\nendlsystem\n";
    assert_eq!(derive(text, 1), "F(1)#(0.06)F(5)");
    // A real directive after a production is still a directive.
    let text = "Lsystem: 1\nAxiom: A\nA --> F(1)\n#define W 2\nB --> F(W)\nendlsystem\n";
    assert_eq!(derive(&text.replace("Axiom: A", "Axiom: A B"), 1), "F(1)F(2)");
    // `#` alone is C's null directive and vanishes.
    assert_eq!(derive("#\nLsystem: 1\nAxiom: F(1)\nendlsystem\n", 0), "F(1)");
}

/// cpfg accepts blanks between a module name and `(`: `F (1)`, `\ (90)`, and on the left
/// side `A (x)`.
#[test]
fn blanks_may_separate_a_module_from_its_parameters() {
    let text = "Lsystem: 1\nAxiom: A (2)\nA (x) --> F (x) \\ (90) + (x*10) F(1)\nendlsystem\n";
    assert_eq!(derive(text, 1), "F(2)\\(90)+(20)F(1)");
    // Modules without parameters still stand alone.
    assert_eq!(derive("Lsystem: 1\nAxiom: F F (3) F\nendlsystem\n", 0), "FF(3)F");
}

/// A `#define` continued with `\` on the next line.
#[test]
fn defines_continue_over_backslashed_lines() {
    let text = "#define X 1 + \\\n  2\nLsystem: 1\nAxiom: A\nA --> F(X)\nendlsystem\n";
    assert_eq!(derive(text, 1), "F(3)");
}

/// lpfg models (`#include <lpfgall.h>`, L-systems in C++) are refused with an
/// `unsupported:` error that names lpfg, not "no such file".
#[test]
fn lpfg_models_are_unsupported_and_say_so() {
    for include in ["#include <lpfgall.h>", "#include \"lpfgall.h\""] {
        let text = format!("{include}\nderivation length: 1;\nAxiom: A;\n");
        let e = LSystem::parse("plant.l", &text, &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Unsupported, "{}", e.message);
        assert!(e.message.contains("unsupported") && e.message.contains("lpfg"), "{}", e.message);
        assert!(e.message.starts_with("plant.l:1:"), "{}", e.message);
    }
}

/// MacMurchy2004 property 10: a `.str` string starts in cpfg's frame, H = +Y, L = −X,
/// U = +Z, so `F(1)+(90)F(1)` ends at (−1, 1, 0) (L-systems keep McLoughlin2021's frame,
/// L = +Z, where it ends at (0, 1, 1)).
#[test]
fn str_strings_start_in_cpfgs_frame() {
    let d = std::env::temp_dir().join(format!("sylva-str-frame-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let file = d.join("turn.str");
    std::fs::write(&file, "F(1)+(90)F(1)\n").unwrap();
    let loaded = sylva::recipe::load(file.to_str().unwrap(), &[]).unwrap();
    let sk = sylva::pipeline::grow(&loaded).unwrap().skeleton;
    let end = *sk.position.last().unwrap();
    assert!((end - glam::Vec3::new(-1.0, 1.0, 0.0)).length() < 1e-6, "ends at {end}");
    let l = LSystem::parse("t.l", "Lsystem: 1\nAxiom: F(1)+(90)F(1)\nendlsystem\n", &[]).unwrap();
    let s = l.derive(&DeriveOptions { steps: 0, budget: DEFAULT_MODULE_BUDGET, seed: 1 }).unwrap();
    let sk = sylva::lsystem::interpret(&l.symbols, &s, &Default::default(), &l.source).unwrap();
    let end = *sk.position.last().unwrap();
    assert!((end - glam::Vec3::new(0.0, 1.0, 1.0)).length() < 1e-6, "L-system ends at {end}");
    let _ = std::fs::remove_dir_all(&d);
}
