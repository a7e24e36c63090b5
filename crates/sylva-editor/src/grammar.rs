//! The grammar editor for an L-system recipe: the text of its `.l` file (cpfg syntax,
//! Mech2004, the cpfg manual; MacMurchy2004 §4.3) in a code editor beside the
//! view, regrown [`GRAMMAR_DEBOUNCE`] after the last keystroke; the engine's error shown
//! at its line and column (the line marked in the gutter and the text, a click puts the
//! cursor there) while the last good tree stays; every `#define NAME number` line as a
//! slider that rewrites that number in the text; Save grammar and Revert.
//!
//! The text lives in the [`Document`] ([`crate::document::Grammar`]), which lays it over
//! the recipe's file for the worker. Undo and redo of typing are the text editor's own
//! (Ctrl+Z, Ctrl+Shift+Z, Ctrl+Y while it has the focus; a slider's rewrite is not
//! reliably one of its steps: move the slider back, or Revert); the menu's Undo steps
//! through recipe changes only.
//!
//! [`defines`] and [`set_define`] are plain text functions: they read a `#define` line
//! the way the engine's preprocessor does (`#define NAME body`, a macro with
//! parameters is not a constant) and leave every other byte of the text as it was.

use crate::document::{Document, GRAMMAR_DEBOUNCE};
use std::ops::{Range, RangeInclusive};
use std::path::PathBuf;
use std::time::Instant;

/// A `#define NAME number` line of a grammar.
#[derive(Debug, Clone, PartialEq)]
pub struct Define {
    /// The constant's name.
    pub name: String,
    /// Its value.
    pub value: f64,
    /// Whether the literal is a whole number (no `.` and no exponent).
    pub integer: bool,
    /// Digits after the literal's `.` (0 for an integer).
    pub decimals: usize,
    /// 1-based line of the `#define`.
    pub line: usize,
    /// Byte range of the number in the text.
    pub span: Range<usize>,
}

/// Every `#define NAME number` of `text` outside comments, in order: the body must be
/// one number (an optional sign, digits with an optional `.` and exponent), optionally
/// followed by a comment. Macros with parameters, other bodies and lines continued with
/// `\` are not constants.
pub fn defines(text: &str) -> Vec<Define> {
    let mut out = Vec::new();
    let mut in_comment = false;
    let mut start = 0;
    for (k, line) in text.split('\n').enumerate() {
        let line_start = start;
        start += line.len() + 1;
        let was_in_comment = in_comment;
        in_comment = block_comment_after(line, in_comment);
        if was_in_comment {
            continue;
        }
        if let Some((name, span)) = define_number(line) {
            let literal = &line[span.clone()];
            let Ok(value) = literal.parse::<f64>() else { continue };
            let integer = !literal.contains(['.', 'e', 'E']);
            let decimals = literal
                .split_once('.')
                .map_or(0, |(_, frac)| frac.chars().take_while(|c| c.is_ascii_digit()).count());
            out.push(Define {
                name: name.to_string(),
                value,
                integer,
                decimals,
                line: k + 1,
                span: line_start + span.start..line_start + span.end,
            });
        }
    }
    out
}

/// Whether a `/* … */` comment is open at the end of `line`, given whether one was open
/// at its start (`//` comments end with the line).
fn block_comment_after(line: &str, mut open: bool) -> bool {
    let b = line.as_bytes();
    let mut i = 0;
    while i + 1 < b.len() {
        match (open, b[i], b[i + 1]) {
            (true, b'*', b'/') => {
                open = false;
                i += 2;
            }
            (false, b'/', b'*') => {
                open = true;
                i += 2;
            }
            (false, b'/', b'/') => return false,
            _ => i += 1,
        }
    }
    open
}

/// The name and the number's byte range in `line` when it is `#define NAME number`.
fn define_number(line: &str) -> Option<(&str, Range<usize>)> {
    let rest = line.trim_start();
    let after_hash = rest.strip_prefix('#')?.trim_start();
    let after_define = after_hash.strip_prefix("define")?;
    if !after_define.starts_with([' ', '\t']) {
        return None;
    }
    let name_at = line.len() - after_define.trim_start().len();
    let name_len = line[name_at..]
        .char_indices()
        .find(|&(_, c)| !(c.is_ascii_alphanumeric() || c == '_'))
        .map_or(line.len() - name_at, |(k, _)| k);
    let name = &line[name_at..name_at + name_len];
    if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit()) {
        return None;
    }
    let after_name = &line[name_at + name_len..];
    // A macro with parameters (`#define F(x) …`), or no body at all.
    if !after_name.starts_with([' ', '\t']) {
        return None;
    }
    let at = line.len() - after_name.trim_start().len();
    let len = number_len(&line[at..]);
    if len == 0 {
        return None;
    }
    let tail = line[at + len..].trim();
    let ends = tail.is_empty() || tail.starts_with("/*") || tail.starts_with("//");
    (ends && !tail.ends_with('\\')).then_some((name, at..at + len))
}

/// The length of the number literal `s` starts with (0: none): `[+-]digits[.digits][e[+-]digits]`,
/// with at least one digit in the mantissa.
fn number_len(s: &str) -> usize {
    let b = s.as_bytes();
    let mut i = usize::from(matches!(b.first(), Some(b'+' | b'-')));
    let digits = |i: &mut usize| {
        let from = *i;
        while b.get(*i).is_some_and(u8::is_ascii_digit) {
            *i += 1;
        }
        *i - from
    };
    let mut mantissa = digits(&mut i);
    if b.get(i) == Some(&b'.') {
        i += 1;
        mantissa += digits(&mut i);
    }
    if mantissa == 0 {
        return 0;
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        let mut j = i + 1 + usize::from(matches!(b.get(i + 1), Some(b'+' | b'-')));
        if digits(&mut j) > 0 {
            i = j;
        }
    }
    // `1.5x` is not a number followed by a comment.
    if b.get(i).is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_' || *c == b'.') {
        return 0;
    }
    i
}

/// The decimals a slider of `define` writes: the literal's own, at least 2, more when
/// the slider's span is small, at most 6; 0 for an integer.
pub fn slider_decimals(define: &Define, range: &RangeInclusive<f64>) -> usize {
    if define.integer {
        return 0;
    }
    let span = (range.end() - range.start()).abs().max(1e-12);
    let fine = (2.0 - span.log10()).ceil().max(0.0) as usize;
    define.decimals.max(2).max(fine).min(6)
}

/// The span a slider for a constant whose value was `value` covers: 0 to twice the
/// value (on its side of 0), at least 0 to 10 for a whole number; −1 to 1 for 0.0.
pub fn slider_range(value: f64, integer: bool) -> RangeInclusive<f64> {
    let (lo, hi) = match (value.partial_cmp(&0.0), integer) {
        (Some(std::cmp::Ordering::Greater), true) => (0.0, (2.0 * value).max(10.0)),
        (Some(std::cmp::Ordering::Less), true) => ((2.0 * value).min(-10.0), 0.0),
        (Some(std::cmp::Ordering::Greater), false) => (0.0, 2.0 * value),
        (Some(std::cmp::Ordering::Less), false) => (2.0 * value, 0.0),
        (_, true) => (0.0, 10.0),
        (_, false) => (-1.0, 1.0),
    };
    lo..=hi
}

/// `value` as the literal a slider writes: a whole number for an integer constant, else
/// `decimals` digits after the point (never `-0`).
pub fn format_value(value: f64, integer: bool, decimals: usize) -> String {
    let s = if integer { format!("{}", value.round() as i64) } else { format!("{value:.decimals$}") };
    match s.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_string(),
        _ => s,
    }
}

/// `text` with the number of `define` (read from this same text) replaced by `literal`;
/// every other byte stays.
pub fn set_define(text: &str, define: &Define, literal: &str) -> String {
    let mut out = String::with_capacity(text.len() + literal.len());
    out.push_str(&text[..define.span.start]);
    out.push_str(literal);
    out.push_str(&text[define.span.end..]);
    out
}

/// A place in the grammar: 1-based line and column (in characters).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Location {
    /// 1-based line.
    pub line: usize,
    /// 1-based column, in characters.
    pub column: usize,
}

/// The place an engine message gives in the file named `name`: located errors start
/// `name:line:column: …` (`sylva::diagnostic::LsystemError::located`). `None` when the
/// message names no place, or a place in another file (an `#include`d one). Returns the
/// place and the rest of the message.
pub fn locate<'a>(message: &'a str, name: &str) -> Option<(Location, &'a str)> {
    let prefix = format!("{name}:");
    let at = message.find(&prefix)?;
    let rest = &message[at + prefix.len()..];
    let (line, rest) = rest.split_once(':')?;
    let (column, rest) = rest.split_once(':')?;
    let location = Location { line: line.parse().ok()?, column: column.parse().ok()? };
    Some((location, rest.trim_start()))
}

/// The character index of `at` in `text` (for the text editor's cursor), kept within
/// the line (and the text).
pub fn char_index(text: &str, at: Location) -> usize {
    let mut index = 0;
    for (k, line) in text.split('\n').enumerate() {
        let n = line.chars().count();
        if k + 1 == at.line {
            return index + at.column.saturating_sub(1).min(n);
        }
        index += n + 1;
    }
    text.chars().count()
}

/// The grammar panel's own state (kept in egui's memory, not in the app).
#[derive(Debug, Clone, Default)]
struct PanelState {
    hidden: bool,
    /// The file name Save grammar writes, and the grammar it was set for.
    save: Option<(String, String)>,
}

fn state_id() -> egui::Id {
    egui::Id::unique("sylva-edit grammar panel")
}

/// The id of the grammar's text editor.
pub fn text_id() -> egui::Id {
    egui::Id::unique("sylva-edit grammar text")
}

/// The menu bar's "Grammar" toggle, shown when the document's generator is an L-system.
pub fn menu_toggle(ui: &mut egui::Ui, doc: &Document) {
    if doc.grammar().is_none() && doc.grammar_error().is_none() {
        return;
    }
    let mut s = ui.data_mut(|d| d.get_temp::<PanelState>(state_id())).unwrap_or_default();
    let mut shown = !s.hidden;
    if ui.toggle_value(&mut shown, "Grammar").on_hover_text("the L-system's text beside the view").changed() {
        s.hidden = !shown;
        ui.data_mut(|d| d.insert_temp(state_id(), s));
    }
}

/// The grammar panel (a right-hand side panel) when the document's generator is an
/// L-system and the panel is not hidden: call it before the central panel. `message`
/// is the error the status bar shows (a failed run names its place there). Gives the
/// typing to the document once it pauses; returns a message for the status bar (a
/// save's outcome, a refused slider value).
pub fn show(ui: &mut egui::Ui, doc: &mut Document, message: Option<&str>) -> Option<String> {
    if let Some(wait) = doc.apply_grammar_when_quiet(Instant::now()) {
        ui.ctx().request_repaint_after(wait);
    }
    if doc.grammar().is_none() && doc.grammar_error().is_none() {
        return None;
    }
    let mut s = ui.data_mut(|d| d.get_temp::<PanelState>(state_id())).unwrap_or_default();
    if s.hidden {
        return None;
    }
    let out = egui::Panel::right("grammar")
        .resizable(true)
        .default_size(420.0)
        .show(ui, |ui| panel(ui, doc, message, &mut s))
        .inner;
    ui.data_mut(|d| d.insert_temp(state_id(), s));
    out
}

fn panel(ui: &mut egui::Ui, doc: &mut Document, message: Option<&str>, s: &mut PanelState) -> Option<String> {
    ui.heading("L-system grammar");
    let Some(g) = doc.grammar() else {
        let why = doc.grammar_error().unwrap_or_default();
        ui.label(egui::RichText::new(format!("the grammar cannot be shown: {why}")).color(ERROR));
        return None;
    };
    let name = g.name.clone();
    let mut out = None;
    ui.horizontal(|ui| {
        ui.label(egui::RichText::new(&name).monospace().weak());
        if g.modified() {
            ui.label(egui::RichText::new("modified").italics()).on_hover_text("not saved to the file");
        }
    });
    let default_path = doc.grammar_path().map(|p| p.display().to_string()).unwrap_or_default();
    if s.save.as_ref().is_none_or(|(for_name, _)| *for_name != name) {
        s.save = Some((name.clone(), default_path));
    }
    let save_path = &mut s.save.as_mut().expect("set above").1;
    ui.horizontal(|ui| {
        if ui.button("Save grammar").on_hover_text("write the text to the file named here").clicked() {
            let path = PathBuf::from(save_path.trim());
            out = Some(match doc.save_grammar(&path) {
                Ok(()) => format!("saved the grammar to {}", path.display()),
                Err(e) => e,
            });
        }
        ui.add(egui::TextEdit::singleline(save_path).desired_width(180.0))
            .on_hover_text("the file Save grammar writes")
            .accessible_name("grammar file name");
        let modified = doc.grammar().is_some_and(|g| g.modified());
        if ui
            .add_enabled(modified, egui::Button::new("Revert"))
            .on_hover_text("back to the file's text")
            .clicked()
        {
            let original = doc.grammar().map(|g| g.original.clone()).unwrap_or_default();
            doc.set_grammar_text(original);
        }
    });

    // The error of the last run, at its place in this file.
    let text = doc.grammar().map(|g| g.text.clone()).unwrap_or_default();
    let located = message.and_then(|m| locate(m, &name));
    let mut goto = None;
    if let Some((at, what)) = located {
        let first = what.lines().next().unwrap_or_default();
        let label = format!("line {}, column {}: {first}", at.line, at.column);
        let r = ui
            .add(egui::Button::new(egui::RichText::new(&label).color(ERROR)).frame(false))
            .on_hover_text(format!("{what}\n\nclick: put the cursor there"));
        if r.clicked() {
            goto = Some(at);
        }
    } else if let Some(m) = message.filter(|m| m.contains(name.as_str())) {
        ui.label(egui::RichText::new(m).color(ERROR));
    }

    if let Some(e) = defines_section(ui, doc, &text) {
        out = Some(e);
    }
    ui.separator();
    editor(ui, doc, located.map(|(at, _)| at), goto);
    out
}

const ERROR: egui::Color32 = egui::Color32::from_rgb(200, 40, 40);

/// The sliders of the `#define` constants. A constant the recipe sets
/// (`generator.define.NAME`, which wins over the file's) moves that recipe key instead.
fn defines_section(ui: &mut egui::Ui, doc: &mut Document, text: &str) -> Option<String> {
    let found = defines(text);
    if found.is_empty() {
        return None;
    }
    let original = doc.grammar().map(|g| defines(&g.original)).unwrap_or_default();
    let recipe_defines = match &doc.recipe().generator {
        sylva::recipe::Generator::Lsystem(g) => g.define.clone(),
        _ => Default::default(),
    };
    let mut out = None;
    egui::CollapsingHeader::new(format!("Constants (#define, {})", found.len()))
        .id_salt("grammar defines")
        .default_open(true)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().id_salt("grammar defines scroll").max_height(220.0).show(ui, |ui| {
                egui::Grid::new("grammar defines grid").num_columns(2).striped(true).show(ui, |ui| {
                    for d in &found {
                        let base = original.iter().find(|o| o.name == d.name).map_or(d.value, |o| o.value);
                        let overridden = recipe_defines.get(&d.name);
                        let current = overridden
                            .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
                            .unwrap_or(d.value);
                        let range = slider_range(base, d.integer);
                        let range = range.start().min(current)..=range.end().max(current);
                        let decimals = slider_decimals(d, &range);
                        let mut v = current;
                        ui.label(egui::RichText::new(&d.name).monospace()).on_hover_text(format!(
                            "#define {} on line {}{}",
                            d.name,
                            d.line,
                            if overridden.is_some() {
                                "\nthe recipe's generator.define sets it: the slider moves that key"
                            } else {
                                ""
                            }
                        ));
                        // The number beside the rail moves by one step a pixel (and an
                        // assistive technology's increment by one step).
                        let step = 10f64.powi(-(decimals as i32));
                        let slider = egui::Slider::new(&mut v, range.clone()).drag_value_speed(step);
                        let slider = if d.integer {
                            slider.integer()
                        } else {
                            slider.step_by(step).fixed_decimals(decimals)
                        };
                        let r = ui.add(slider).accessible_name(format!("#define {}", d.name));
                        ui.end_row();
                        let moved = (v - current).abs() > 0.5 * 10f64.powi(-(decimals as i32));
                        if !(r.changed() && moved) {
                            continue;
                        }
                        if overridden.is_some() {
                            let key = format!("generator.define.{}", d.name);
                            let value = if d.integer {
                                toml::Value::Integer(v.round() as i64)
                            } else {
                                toml::Value::Float(format_value(v, false, decimals).parse().unwrap_or(v))
                            };
                            if let Err(e) = doc.set(&key, value, r.dragged()) {
                                out = Some(e);
                            }
                        } else {
                            let literal = format_value(v, d.integer, decimals);
                            doc.set_grammar_text(set_define(text, d, &literal));
                        }
                        // One change a frame: the other spans refer to the old text.
                        break;
                    }
                });
            });
        });
    out
}

/// The text editor with a line-number gutter; the error's line is marked red in both.
/// `goto` puts the cursor at a place (and the focus in the editor).
fn editor(ui: &mut egui::Ui, doc: &mut Document, error: Option<Location>, goto: Option<Location>) {
    let id = text_id();
    if let (Some(at), Some(g)) = (goto, doc.grammar()) {
        let mut state = egui::TextEdit::load_state(ui.ctx(), id).unwrap_or_default();
        let c = egui::text::CCursor::new(char_index(&g.text, at));
        state.cursor.set_char_range(Some(egui::text::CCursorRange::one(c)));
        egui::TextEdit::store_state(ui.ctx(), id, state);
        ui.memory_mut(|m| m.request_focus(id));
    }
    let error_line = error.map(|e| e.line);
    let font = egui::TextStyle::Monospace.resolve(ui.style());
    let color = ui.visuals().text_color();
    let Some(buffer) = doc.grammar_text_mut() else { return };
    let lines = buffer.split('\n').count();
    let mut layouter = |ui: &egui::Ui, text: &dyn egui::TextBuffer, _wrap: f32| {
        let mut job = egui::text::LayoutJob::default();
        for (k, line) in text.as_str().split_inclusive('\n').enumerate() {
            let mut format = egui::text::TextFormat::simple(font.clone(), color);
            if error_line == Some(k + 1) {
                format.background = egui::Color32::from_rgba_unmultiplied(220, 40, 40, 60);
            }
            job.append(line, 0.0, format);
        }
        ui.fonts_mut(|f| f.layout_job(job))
    };
    let mut changed = false;
    let mut focused = false;
    egui::ScrollArea::both().id_salt("grammar text scroll").auto_shrink([false, false]).show(ui, |ui| {
        ui.horizontal_top(|ui| {
            let mut gutter = egui::text::LayoutJob::default();
            for k in 1..=lines {
                let mut format = egui::text::TextFormat::simple(font.clone(), ui.visuals().weak_text_color());
                if error_line == Some(k) {
                    format.color = ERROR;
                    format.background = egui::Color32::from_rgba_unmultiplied(220, 40, 40, 60);
                }
                let end = if k < lines { "\n" } else { "" };
                gutter.append(&format!("{k:>4}{end}"), 0.0, format);
            }
            ui.vertical(|ui| {
                ui.add_space(2.0);
                ui.add(egui::Label::new(gutter).selectable(false));
            });
            let r = ui
                .add(
                    egui::TextEdit::multiline(buffer)
                        .id(id)
                        .code_editor()
                        .margin(egui::Margin::symmetric(4, 2))
                        .desired_width(f32::INFINITY)
                        .desired_rows(30)
                        .layouter(&mut layouter),
                )
                .accessible_name("grammar text");
            changed = r.changed();
            focused = r.has_focus();
        });
    });
    if changed {
        doc.grammar_typed(Instant::now());
        ui.ctx().request_repaint_after(GRAMMAR_DEBOUNCE);
    }
    if focused {
        // The text editor undid or redid these itself: keep them from the recipe's undo.
        ui.input_mut(|i| {
            i.consume_key(egui::Modifiers::COMMAND | egui::Modifiers::SHIFT, egui::Key::Z);
            i.consume_key(egui::Modifiers::COMMAND, egui::Key::Z);
            i.consume_key(egui::Modifiers::COMMAND, egui::Key::Y);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = "/* #define HIDDEN 3\n   still a comment */\n#define N 6\n  #  define LEN 0.25 /* length */\n#define NEG -35\n#define SCI 1.5e-2 // small\n#define F(x) (x*2)\n#define WORD abc\n#define EXPR 1+2\n#define FLAG\n#define CONT 4 \\\n#define ANGLE\t45.0\nLsystem: 1\nAxiom: F(LEN)\nendlsystem\n";

    #[test]
    fn finds_the_numeric_defines_outside_comments() {
        let found = defines(MODEL);
        let names: Vec<&str> = found.iter().map(|d| d.name.as_str()).collect();
        assert_eq!(names, ["N", "LEN", "NEG", "SCI", "ANGLE"]);
        let n = &found[0];
        assert_eq!((n.value, n.integer, n.decimals, n.line), (6.0, true, 0, 3));
        assert_eq!(&MODEL[n.span.clone()], "6");
        let len = &found[1];
        assert_eq!((len.value, len.integer, len.decimals, len.line), (0.25, false, 2, 4));
        assert_eq!(&MODEL[len.span.clone()], "0.25");
        assert_eq!((found[2].value, found[2].integer), (-35.0, true));
        assert_eq!((found[3].value, found[3].integer), (0.015, false));
        assert_eq!(&MODEL[found[4].span.clone()], "45.0");
    }

    #[test]
    fn rewriting_a_define_keeps_every_other_byte() {
        let found = defines(MODEL);
        let len = &found[1];
        let out = set_define(MODEL, len, &format_value(0.5, false, 2));
        assert_eq!(
            out,
            MODEL.replace("  #  define LEN 0.25 /* length */", "  #  define LEN 0.50 /* length */")
        );
        let again = defines(&out);
        assert_eq!(again[1].value, 0.5);
        assert_eq!(again.len(), found.len());
        let n = set_define(&out, &again[0], &format_value(8.4, true, 0));
        assert_eq!(n, out.replace("#define N 6\n", "#define N 8\n"));
        // CRLF text keeps its line ends.
        let crlf = "#define A 1.0\r\nAxiom: F\r\n";
        let d = defines(crlf);
        assert_eq!(d.len(), 1);
        assert_eq!(set_define(crlf, &d[0], "2.00"), "#define A 2.00\r\nAxiom: F\r\n");
    }

    #[test]
    fn slider_ranges_and_literals() {
        assert_eq!(slider_range(6.0, true), 0.0..=12.0);
        assert_eq!(slider_range(3.0, true), 0.0..=10.0);
        assert_eq!(slider_range(-35.0, true), -70.0..=0.0);
        assert_eq!(slider_range(-2.0, true), -10.0..=0.0);
        assert_eq!(slider_range(0.25, false), 0.0..=0.5);
        assert_eq!(slider_range(0.0, false), -1.0..=1.0);
        assert_eq!(slider_range(0.0, true), 0.0..=10.0);
        assert_eq!(format_value(-0.0001, false, 2), "0.00");
        assert_eq!(format_value(1.0, false, 3), "1.000");
        assert_eq!(format_value(-3.6, true, 0), "-4");
        let d = &defines("#define S 0.001\n")[0];
        assert!(slider_decimals(d, &slider_range(d.value, d.integer)) >= 5);
        let d = &defines("#define S 10.5\n")[0];
        assert_eq!(slider_decimals(d, &slider_range(d.value, d.integer)), 2);
    }

    #[test]
    fn locates_the_engines_message_in_this_file_only() {
        let m = "/tmp/x/plant.l:12:7: unknown name `Q`";
        let (at, rest) = locate(m, "/tmp/x/plant.l").unwrap();
        assert_eq!(at, Location { line: 12, column: 7 });
        assert_eq!(rest, "unknown name `Q`");
        assert!(locate(m, "/tmp/x/other.l").is_none());
        assert!(locate("presets/lsystem/honda.l: no place", "presets/lsystem/honda.l").is_none());
        let text = "ab\ncdé\nx";
        assert_eq!(char_index(text, Location { line: 2, column: 3 }), 5);
        assert_eq!(char_index(text, Location { line: 2, column: 99 }), 6, "kept within the line");
        assert_eq!(char_index(text, Location { line: 9, column: 1 }), 8);
    }
}
