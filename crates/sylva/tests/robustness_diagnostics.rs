//! Issue 39, items 1 and 15: located errors on lines of any length render without a
//! panic and without copying the line (item 1), and recipe type errors name the full key
//! and the expected type (item 15).
//!
//! miette's graphical handler panicked ("Formatting argument out of range") on an error
//! past column 65,535, and printed the whole line before; every reader now clips the
//! excerpt to a window around the error (`sylva::diagnostic`). Each test here puts the
//! error at column ~150,000 of a 200,000-character line, renders the report as the CLI
//! does, and checks it is short and names the true `line:column`.

use miette::{Diagnostic, GraphicalReportHandler, GraphicalTheme};
use sylva::diagnostic::{Excerpt, LsystemError};
use sylva::import::{cpfg_str, lst, skel_json};
use sylva::lsystem::{ErrorKind, LSystem};
use sylva::recipe;

/// Line length of the hostile inputs.
const LINE: usize = 200_000;
/// Column of the error in them (about).
const COL: usize = 150_000;
/// The most a rendered report may take.
const MAX_REPORT: usize = 4096;

/// The report as the CLI prints it (graphical, unwrapped), without colours.
fn render(e: &dyn Diagnostic) -> String {
    let mut out = String::new();
    GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor())
        .with_wrap_lines(false)
        .render_report(&mut out, e)
        .expect("the report renders");
    out
}

/// Renders `e` (which must not panic), checks the report is short, and returns it.
fn short_report(e: &dyn Diagnostic) -> String {
    let r = render(e);
    assert!(r.len() < MAX_REPORT, "a {}-byte report:\n{}", r.len(), &r[..r.len().min(2000)]);
    r
}

#[test]
fn item01_excerpt_keeps_a_window_with_true_line_and_column() {
    // Three lines: a short one, a long one with the error, a long one after.
    let long = "a".repeat(LINE);
    let text = format!("short\n{}X{}\n{long}\nend", &long[..COL - 1], &long[COL..]);
    let at = text.find('X').unwrap();
    let e = LsystemError::located(ErrorKind::Syntax, "t.txt", &text, at, 1, "bad `X`", "here");
    assert!(e.message.starts_with(&format!("t.txt:2:{COL}: ")), "{}", e.message);
    let window = e.source_code.text();
    assert!(window.len() < 2000, "the window is {} bytes", window.len());
    let span = e.span.unwrap();
    assert_eq!(&window[span.offset()..span.offset() + span.len()], "X");
    let r = short_report(e.as_ref());
    // miette's header and gutter name the file's line and column, not the window's.
    assert!(r.contains(&format!("[t.txt:2:{COL}]")), "{r}");
    assert!(r.contains("2 │"), "{r}");
    assert!(r.contains("here"), "{r}");
    // Short files keep their whole text, as before.
    let (x, span) = Excerpt::new("s", "ab\ncd\nef\n", 4, 1);
    assert_eq!(x.text(), "ab\ncd\nef\n");
    assert_eq!((span.offset(), span.len()), (4, 1));
}

#[test]
fn item01_excerpt_handles_edges_without_panicking() {
    let long = "é".repeat(LINE);
    for text in ["", "x", "\n", "\r\n\r", long.as_str(), &format!("{long}\n{long}\n")] {
        for at in [0, 1, 2, text.len() / 2, text.len().saturating_sub(1), text.len(), text.len() + 5] {
            for len in [0, 1, 3, text.len(), usize::MAX / 2] {
                let e = LsystemError::located(ErrorKind::Syntax, "e", text, at, len, "w", "l");
                let span = e.span.unwrap();
                assert!(span.offset() + span.len() <= e.source_code.text().len());
                short_report(e.as_ref());
            }
        }
    }
    // A span over many long lines is cut after a few of them.
    let many = format!("{long}\n").repeat(20);
    let e = LsystemError::located(ErrorKind::Syntax, "m", &many, 5, many.len(), "w", "l");
    assert!(e.source_code.text().len() < 8000);
    let r = render(e.as_ref());
    assert!(r.len() < 16_000, "{} bytes", r.len());
}

#[test]
fn item01_lsystem_error_on_a_long_line() {
    let pad = "F".repeat(COL - 8);
    let text = format!("Lsystem: 1\nAxiom: {pad}F(1,,2){}\nendlsystem\n", "F".repeat(LINE - COL));
    let e = LSystem::parse("long.l", &text, &[]).expect_err("`,,` is a syntax error");
    let r = short_report(&*e);
    assert!(e.message.starts_with("long.l:2:"), "{}", e.message);
    let col: usize = e.message.split(':').nth(2).unwrap().parse().unwrap();
    assert!((COL - 10..COL + 10).contains(&col), "{}", e.message);
    assert!(r.contains(&format!("[long.l:2:{col}]")), "{r}");
}

#[test]
fn item01_lsystem_messages_quote_long_tokens_clipped() {
    let long = "x".repeat(LINE);
    let mut errors = 0;
    for text in [
        format!("Lsystem: 1\nAxiom: A({long})\nA(x) --> A({long})\nendlsystem\n"),
        format!("Lsystem: 1\n{long}: 5\nAxiom: A\nendlsystem\n"),
        format!("Lsystem: 1\nAxiom: A(1,,{long})\nendlsystem\n"),
        format!("#define {long} (\nLsystem: 1\nAxiom: A\nendlsystem\n"),
    ] {
        let Err(e) = LSystem::parse("q.l", &text, &[]) else { continue };
        errors += 1;
        // `undefined name `xxx…``: the constructor's safety net clips the quoted name.
        assert!(e.message.len() < 1000, "{} bytes: {}", e.message.len(), &e.message[..300]);
        short_report(&*e);
    }
    assert!(errors >= 3, "{errors} of the inputs failed");
}

#[test]
fn item01_lst_error_on_a_long_line() {
    let ops = "MovRel3f(0,0,0) ".repeat(COL / 16);
    let before = ops.len();
    let text = format!("LST 0.1\n{ops}Bogus(1) {}\n", " ".repeat(LINE - before));
    let e = lst::parse("long.lst", &text, &lst::LstOptions::default()).expect_err("unknown operation");
    let r = short_report(&*e);
    let want = format!("long.lst:2:{}", before + 1);
    assert!(e.message.starts_with(&want), "{}", e.message);
    assert!(r.contains(&format!("[{want}]")), "{r}");
    // An unknown operation name of 200,000 characters is quoted clipped.
    let text = format!("LST 0.1\n{}()\n", "Q".repeat(LINE));
    let e = lst::parse("name.lst", &text, &lst::LstOptions::default()).expect_err("unknown operation");
    assert!(e.message.len() < 400, "{}", e.message);
    short_report(&*e);
}

#[test]
fn item01_str_error_on_a_long_line() {
    let mods = "F ".repeat(COL / 2);
    let text = format!("{mods}F(1,x) {}", "F ".repeat((LINE - COL) / 2));
    let e = cpfg_str::parse("long.str", &text).expect_err("`x` is not a number");
    let r = short_report(&*e);
    let want = format!("long.str:1:{}", mods.len() + 5);
    assert!(e.message.starts_with(&want), "{}", e.message);
    assert!(r.contains(&format!("[{want}]")), "{r}");
    // A parameter token of 200,000 characters is quoted clipped.
    let text = format!("F({})", "9".repeat(LINE) + "x");
    let e = cpfg_str::parse("tok.str", &text).expect_err("not a number");
    assert!(e.message.len() < 400, "{}", e.message);
    // So is a module name.
    let text = format!("{}({})", "A".repeat(LINE), "1,,");
    let e = cpfg_str::parse("name.str", &text).expect_err("not a number");
    assert!(e.message.len() < 400, "{}", e.message);
    short_report(&*e);
}

#[test]
fn item01_json_error_on_a_long_line() {
    let text = format!("{{{}\"format\": x{}}}", " ".repeat(COL), " ".repeat(LINE - COL));
    let e = skel_json::from_json_named("long.skel.json", &text).expect_err("`x` is not JSON");
    let r = short_report(&e);
    let msg = e.to_string();
    assert!(msg.starts_with("long.skel.json:1:"), "{msg}");
    let col: usize = msg.split(':').nth(2).unwrap().parse().unwrap();
    assert!((COL..COL + 20).contains(&col), "{msg}");
    assert!(r.contains(&format!("[long.skel.json:1:{col}]")), "{r}");
    // A string value of 200,000 characters where a number goes is quoted clipped.
    let text = format!(
        "{{\"format\": \"sylva-skeleton\", \"version\": 1, \"nodes\": [{{\"position\": [\"{}\", 0, 0]}}]}}",
        "z".repeat(LINE)
    );
    let e = skel_json::from_json_named("val.skel.json", &text).expect_err("a string is not a number");
    assert!(e.to_string().len() < 400, "{e}");
    short_report(&e);
    // So is a `format` of that length.
    let text = format!("{{\"format\": \"{}\", \"version\": 1, \"nodes\": []}}", "z".repeat(LINE));
    let e = skel_json::from_json_named("fmt.skel.json", &text).expect_err("not a sylva skeleton");
    assert!(e.to_string().len() < 400, "{e}");
}

#[test]
fn item01_set_value_with_an_error_on_a_long_line() {
    // A TOML array with a syntax error at column ~150,000 of the value.
    let items = "1, ".repeat(COL / 3);
    let kv = format!("generator.angle=[{items}x, {}]", "2, ".repeat((LINE - COL) / 3));
    let e = recipe::parse_set(&kv).expect_err("`x` is not a TOML value");
    let r = short_report(&e);
    let msg = e.to_string();
    assert!(msg.len() < 1000, "{} bytes: {}", msg.len(), &msg[..msg.len().min(500)]);
    assert!(msg.contains("generator.angle"), "{msg}");
    assert!(msg.contains(&format!("column {}", items.len() + 2)), "{msg}");
    assert!(r.contains("generator.angle"), "{r}");
    // A value of 200,000 characters of the wrong type is quoted clipped.
    let kv = format!("generator.angle={}", "z".repeat(LINE));
    let set = recipe::parse_set(&kv).unwrap();
    let e = recipe::load("lsys-binary-tree", &[set]).expect_err("a string is not an angle");
    assert!(e.to_string().len() < 400, "{e}");
    assert!(e.to_string().contains("generator.angle"), "{e}");
    // So is a key of that length, and a `--set` with no `=`.
    let kv = format!("{}=1", "k".repeat(LINE));
    let set = recipe::parse_set(&kv).unwrap();
    let e = recipe::load("lsys-binary-tree", &[set]).expect_err("unknown key");
    assert!(e.to_string().len() < 400, "{e}");
    let e = recipe::parse_set(&"k".repeat(LINE)).expect_err("no `=`");
    assert!(e.to_string().len() < 400, "{e}");
}

#[test]
fn item01_recipe_file_error_on_a_long_line() {
    let dir = std::env::temp_dir().join(format!("sylva-robustness-diag-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("long.toml");
    let text = format!("name = \"t\"\nx = [{}x]\n", "1, ".repeat(COL / 3));
    std::fs::write(&path, &text).unwrap();
    let e = recipe::load(path.to_str().unwrap(), &[]).expect_err("a TOML syntax error");
    let msg = e.to_string();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(msg.len() < 2000, "{} bytes: {}", msg.len(), &msg[..msg.len().min(500)]);
    assert!(msg.contains(&format!("line 2, column {}", 6 + 3 * (COL / 3))), "{msg}");
    short_report(&e);
}

#[test]
fn item15_float_iterations_names_the_key_and_the_type() {
    let set = recipe::parse_set("generator.iterations=1e9").unwrap();
    let e = recipe::load("lsys-binary-tree", &[set]).expect_err("iterations are a whole number");
    let msg = e.to_string();
    assert!(msg.contains("`generator.iterations`"), "{msg}");
    assert!(msg.contains("whole number") || msg.contains("u32"), "{msg}");
    // Other keys of the generator's table too, for every generator type.
    let set = recipe::parse_set("generator.max_modules=-1").unwrap();
    let e = recipe::load("lsys-binary-tree", &[set]).expect_err("no negative budget");
    assert!(e.to_string().contains("`generator.max_modules`"), "{e}");
    let set = recipe::parse_set("generator.angle=\"x\"").unwrap();
    let e = recipe::load("lsys-binary-tree", &[set]).expect_err("an angle is a number");
    assert!(e.to_string().contains("`generator.angle`"), "{e}");
}

/// Item 1 on the OBJ reader (found by the campaign's long-line class): a 200,000-character
/// bad `f` line made a message as long as the line; it is clipped now.
#[test]
fn item01_obj_error_on_a_long_line_is_clipped() {
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 ");
    text.push_str(&"q".repeat(200_000));
    text.push('\n');
    let e = sylva::mesh::obj_read::parse_obj(&text).expect_err("a bad index is an error");
    if let sylva::mesh::obj_read::ObjError::Parse { message, .. } = &e {
        assert!(message.len() > 100_000, "the input quoted in the message is what gets clipped");
    }
    let shown = e.to_string();
    assert!(shown.starts_with("line 4:"), "{}", &shown[..shown.len().min(200)]);
    assert!(shown.len() < 4096, "a message of {} bytes", shown.len());
}
