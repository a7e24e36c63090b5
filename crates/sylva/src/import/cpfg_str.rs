//! CPFG turtle string files (`.str`): a derived module string written out as text
//! (MacMurchy2004 §4.3 "turtle string", §A.4 "Salad takes as input string (".str") files,
//! which are text files containing turtle commands"; MacMurchy2004-spec §1, §2.1).
//!
//! cpfg writes these with *Save string*: modules back to back, parameters in
//! parentheses printed with `%g` and separated by commas (`F(1)+(30)[-(30)F(0.5)]A(1,2)`),
//! a line break after about 70 characters (always between modules), and a final
//! newline. There is no header (the binary dump `.strb` starts with `L-system string:`
//! and is not read here).
//!
//! **Reading** follows cpfg's reader and sylva's L-system parser:
//!
//! - whitespace (spaces, tabs, line breaks) is allowed between modules, between a name
//!   and its `(`, and around parameters; it is not allowed inside a module name;
//! - module names follow the L-system parser (`docs/lsystem.md`): a single character,
//!   `@` plus a letter or a cpfg two-letter name (`@Ts`, `@Gs`, …), `?X` query modules
//!   and `~x` surface names;
//! - parameters are decimal numbers, possibly negative and in exponent form (`-1.5`,
//!   `1e+06`, `.5`); expressions are not evaluated here. NaN, infinities, empty
//!   parameters (`F()`, `F(1,)`), unclosed `(`, a stray `)` and more parameters than a
//!   turtle module takes (`F(1,2)`) are errors with `file:line:column` and an excerpt.
//!
//! [`format()`] writes a [`ModuleString`] back in cpfg's layout, with each parameter as
//! the shorter of Rust's `{}` and `{:e}` forms (both round-trip exactly), so
//! `parse(format(s)) == s` for every finite string whose names the L-system parser can
//! produce. The turtle ([`crate::lsystem::interpret`]) draws the result.

use super::{located, parse_number, NumberError};
use crate::diagnostic::quote;
use crate::lsystem::source::{ErrorKind, LsystemError};
use crate::lsystem::{ModuleString, Symbols};

type SResult<T> = Result<T, Box<LsystemError>>;

/// The header of cpfg's binary string dumps, which are not text strings.
const BINARY_HEADER: &str = "L-system string:";

/// Lines are broken before a module once they reach this many bytes (cpfg uses 70).
const LINE_WIDTH: usize = 70;

/// Two-letter `@` modules of cpfg; other `@X` are one letter. Must match the L-system
/// parser (`lsystem/parse.rs`), which a test checks.
const AT_TWO_LETTER: &[&str] = &[
    "Ts", "Tf", "Ti", "Td", "Tx", "Gs", "Gc", "Ge", "Gr", "Gt", "Di", "Dd", "Ds", "Dt", "Pa", "Pc", "Pd",
    "Pt", "Pm", "Ms", "Mb",
];

/// Turtle modules with a fixed maximum number of parameters (as in the L-system parser).
fn turtle_max_arity(name: &str) -> Option<usize> {
    Some(match name {
        "F" | "f" | "G" | "g" | "+" | "-" | "&" | "^" | "\\" | "/" | "!" | "#" | ";" | "," => 1,
        "[" | "]" | "|" | "$" | "%" => 0,
        _ => return None,
    })
}

/// Byte offset just after the module name starting at byte `i` of `text` (which must be
/// a character boundary before the end): the L-system parser's rules.
fn name_end(text: &str, i: usize) -> usize {
    let s = text.as_bytes();
    let Some(c) = text[i..].chars().next() else {
        return i;
    };
    let mut j = i + c.len_utf8();
    match c {
        '@' if j < s.len() && s[j].is_ascii_alphabetic() => {
            j += 1;
            if j < s.len() && s[j].is_ascii() && AT_TWO_LETTER.contains(&&text[j - 1..j + 1]) {
                j += 1;
            }
        }
        '?' if j < s.len() && s[j].is_ascii_uppercase() => j += 1,
        '~' if j < s.len() && s[j].is_ascii_alphanumeric() => j += 1,
        _ => {}
    }
    j
}

/// Reads a `.str` file into fresh symbols and a module string. `name` is used in error
/// messages. Symbol ids are given in order of first appearance; to get the ids of an
/// existing L-system (and so an identical [`ModuleString`]), use [`parse_with_symbols`].
pub fn parse(name: &str, text: &str) -> SResult<(Symbols, ModuleString)> {
    let mut symbols = Symbols::default();
    let string = parse_with_symbols(name, text, &mut symbols)?;
    Ok((symbols, string))
}

/// Reads a `.str` file, interning its module names into `symbols` (names already there
/// keep their ids). On error `symbols` may have gained names.
pub fn parse_with_symbols(name: &str, text: &str, symbols: &mut Symbols) -> SResult<ModuleString> {
    let err = |kind, at, len, what: &str, label: &str| located(name, text, kind, at, len, what, label);
    let b = text.as_bytes();
    let mut i = if text.starts_with('\u{feff}') { 3 } else { 0 };
    let skip_ws = |mut i: usize| {
        while let Some(c) = text[i..].chars().next() {
            if !c.is_whitespace() {
                break;
            }
            i += c.len_utf8();
        }
        i
    };
    if text[skip_ws(i)..].starts_with(BINARY_HEADER) {
        let at = skip_ws(i);
        return Err(err(
            ErrorKind::Unsupported,
            at,
            BINARY_HEADER.len(),
            "unsupported: a binary cpfg string dump (.strb)",
            "binary header",
        )
        .with_help("save the string from cpfg as text (.str)"));
    }
    let mut out = ModuleString::with_capacity(text.len() / 4, 0);
    let mut params: Vec<f64> = Vec::new();
    loop {
        i = skip_ws(i);
        if i >= text.len() {
            break;
        }
        let at = i;
        if b[i] == b'(' || b[i] == b')' {
            let c = b[i] as char;
            return Err(err(
                ErrorKind::Syntax,
                i,
                1,
                &format!("unexpected `{c}`: parameters must follow a module name"),
                "unexpected",
            ));
        }
        let end = name_end(text, i);
        let module = &text[at..end];
        // Messages quote at most a clipped piece of the input.
        let shown = quote(module);
        let Some(sym) = symbols.intern(module) else {
            return Err(err(
                ErrorKind::Syntax,
                at,
                end - at,
                "more than 65,535 distinct module names",
                "here",
            ));
        };
        i = end;
        params.clear();
        let k = skip_ws(i);
        if k < b.len() && b[k] == b'(' {
            let open = k;
            i = open + 1;
            let unclosed = || {
                err(
                    ErrorKind::Syntax,
                    open,
                    1,
                    &format!("unclosed `(` after module `{shown}`"),
                    "opened here",
                )
            };
            // The character at `i` where `expected` should be.
            let unexpected = |i: usize, expected: &str| {
                let c = text[i..].chars().next().unwrap_or(' ');
                let what = format!("expected {expected} in the parameters of `{shown}`, found `{c}`");
                err(ErrorKind::Syntax, i, c.len_utf8(), &what, &format!("expected {expected}"))
            };
            loop {
                i = skip_ws(i);
                let t_end = text[i..]
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '+' || c == '-'))
                    .map_or(text.len(), |n| i + n);
                if t_end == i {
                    return Err(if i >= text.len() { unclosed() } else { unexpected(i, "a number") });
                }
                let tok = &text[i..t_end];
                let shown_tok = quote(tok);
                match parse_number(tok) {
                    Ok(v) => params.push(v),
                    Err(e) => {
                        let why = match e {
                            NumberError::NonFinite => "is not a finite number",
                            NumberError::Syntax => {
                                "is not a number (string files hold numbers, not expressions)"
                            }
                        };
                        let (kind, label) = e.kind_label();
                        let what = format!("parameter `{shown_tok}` of module `{shown}` {why}");
                        return Err(err(kind, i, tok.len(), &what, label));
                    }
                }
                i = skip_ws(t_end);
                match b.get(i) {
                    Some(b',') => i += 1,
                    Some(b')') => {
                        i += 1;
                        break;
                    }
                    None => return Err(unclosed()),
                    Some(_) => return Err(unexpected(i, "`,` or `)`")),
                }
            }
        }
        if let Some(max) = turtle_max_arity(module) {
            if params.len() > max {
                return Err(err(
                    ErrorKind::Arity,
                    at,
                    i - at,
                    &format!(
                        "turtle module `{shown}` takes at most {max} parameter(s), got {}",
                        params.len()
                    ),
                    "too many parameters",
                ));
            }
        }
        if out.params.len() + params.len() > u32::MAX as usize {
            return Err(err(ErrorKind::Budget, at, i - at, "more than 4,294,967,295 parameters", "here"));
        }
        out.push(sym, &params);
    }
    Ok(out)
}

/// Writes `string` as `.str` text in cpfg's layout: modules back to back, parameters
/// comma-separated, a line break before a module once a line reaches 70 bytes, and a
/// final newline. A space separates two modules only where the reader would otherwise
/// join their names (a bare `@` before `F` is written `@ F`).
///
/// Exact round trip: [`parse_with_symbols`] on the result with (a clone of) `symbols`
/// gives `string` back bit for bit, provided every parameter is finite and every name is
/// one the L-system parser produces. Modules whose symbol id is not in `symbols` are
/// written as `\u{FFFD}`.
pub fn format(symbols: &Symbols, string: &ModuleString) -> String {
    use std::fmt::Write;
    let mut out = String::with_capacity(string.len() * 2 + string.params.len() * 4 + 1);
    let mut line_start = 0;
    let mut prev_bare: Option<&str> = None;
    let (mut plain, mut exp) = (String::new(), String::new());
    for (i, &sym) in string.syms.iter().enumerate() {
        let name = if (sym as usize) < symbols.len() { symbols.name(sym) } else { "\u{FFFD}" };
        let params = match (string.pofs.get(i), string.pofs.get(i + 1)) {
            (Some(&a), Some(&b)) => string.params.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        };
        if out.len() - line_start >= LINE_WIDTH {
            out.push('\n');
            line_start = out.len();
        } else if let Some(prev) = prev_bare {
            if joins(prev, name) {
                out.push(' ');
            }
        }
        out.push_str(name);
        if params.is_empty() {
            prev_bare = Some(name);
            continue;
        }
        prev_bare = None;
        out.push('(');
        for (k, v) in params.iter().enumerate() {
            if k > 0 {
                out.push(',');
            }
            plain.clear();
            exp.clear();
            let _ = write!(plain, "{v}");
            let _ = write!(exp, "{v:e}");
            out.push_str(if exp.len() < plain.len() { &exp } else { &plain });
        }
        out.push(')');
    }
    out.push('\n');
    out
}

/// Whether the reader would read `prev` written right before `next` as a different name.
fn joins(prev: &str, next: &str) -> bool {
    if next.is_empty() || !matches!(prev.as_bytes().first(), Some(b'@' | b'?' | b'~')) {
        return false;
    }
    let both = format!("{prev}{next}");
    name_end(&both, 0) != prev.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lsystem::LSystem;

    fn names(symbols: &Symbols, s: &ModuleString) -> Vec<String> {
        s.syms.iter().map(|&k| symbols.name(k).to_string()).collect()
    }

    #[test]
    fn reads_cpfg_output() {
        let text = "F(1)+(30)[-(30)F(0.5)]A(1,2e-07)\n@Gs @GcF ?P(1, -2.5) ~l(3)\n%f(1e+06)\n";
        let (sy, s) = parse("t.str", text).unwrap();
        assert_eq!(
            names(&sy, &s),
            ["F", "+", "[", "-", "F", "]", "A", "@Gs", "@Gc", "F", "?P", "~l", "%", "f"]
        );
        assert_eq!(s.module(6).1, &[1.0, 2e-7]);
        assert_eq!(s.module(10).1, &[1.0, -2.5]);
        assert_eq!(s.module(13).1, &[1e6]);
    }

    #[test]
    fn module_names_match_the_lsystem_parser() {
        let axiom = "F(1)@Gs@Gc@Ts@X@xA~l~1@@(1)B#!$%|&^\\/;,{.}";
        let ls = LSystem::parse("t.l", &format!("Lsystem: 1\nAxiom: {axiom}\nendlsystem\n"), &[]).unwrap();
        let from_l: Vec<&str> = ls.axiom.iter().map(|m| ls.symbols.name(m.sym)).collect();
        let (sy, s) = parse("t.str", axiom).unwrap();
        assert_eq!(names(&sy, &s), from_l);
    }

    #[test]
    fn format_separates_names_only_where_needed() {
        let mut sy = Symbols::default();
        let ids: Vec<u16> = ["@", "F", "@G", "s", "?", "X", "~", "a", "A", "B"]
            .iter()
            .map(|n| sy.intern(n).unwrap())
            .collect();
        let mut s = ModuleString::new();
        for &id in &ids {
            s.push(id, &[]);
        }
        let text = format(&sy, &s);
        assert_eq!(text, "@ F@G s? X~ aAB\n");
        let mut sy2 = sy.clone();
        assert_eq!(parse_with_symbols("t.str", &text, &mut sy2).unwrap(), s);
    }

    #[test]
    fn format_wraps_lines_and_numbers_round_trip() {
        let mut sy = Symbols::default();
        let f = sy.intern("F").unwrap();
        let a = sy.intern("A").unwrap();
        let mut s = ModuleString::new();
        let vals = [0.1, -0.0, 1e300, 5e-324, -123456.789, 1.0 / 3.0, f64::MAX, 2.5e-8];
        for (k, v) in vals.iter().enumerate() {
            s.push(f, &[*v]);
            s.push(a, &[*v, k as f64, -v]);
        }
        let text = format(&sy, &s);
        assert!(text.contains("1e300") && !text.contains("00000000000000000000"), "{text}");
        assert!(text.lines().count() > 1);
        let mut sy2 = sy.clone();
        let back = parse_with_symbols("t.str", &text, &mut sy2).unwrap();
        let bits = |m: &ModuleString| m.params.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(back, s);
        assert_eq!(bits(&back), bits(&s));
        assert_eq!(format(&Symbols::default(), &ModuleString::new()), "\n");
    }

    #[test]
    fn errors_are_located() {
        for (text, at, kind) in [
            ("F(1", "t.str:1:2: unclosed `(`", ErrorKind::Syntax),
            ("F(1)\nA(1x)", "t.str:2:3: parameter `1x` of module `A` is not a number", ErrorKind::Syntax),
            ("F(a)", "t.str:1:3: parameter `a`", ErrorKind::Syntax),
            (
                "F(nan)",
                "t.str:1:3: parameter `nan` of module `F` is not a finite number",
                ErrorKind::NonFinite,
            ),
            ("F(1e999)", "t.str:1:3: parameter `1e999`", ErrorKind::NonFinite),
            ("F()", "t.str:1:3: expected a number in the parameters of `F`, found `)`", ErrorKind::Syntax),
            ("A(1,)", "t.str:1:5: expected a number", ErrorKind::Syntax),
            ("A(1 2)", "t.str:1:5: expected `,` or `)`", ErrorKind::Syntax),
            ("A(2*3)", "t.str:1:4: expected `,` or `)`", ErrorKind::Syntax),
            ("F(1)\n  )", "t.str:2:3: unexpected `)`", ErrorKind::Syntax),
            ("(1)", "t.str:1:1: unexpected `(`", ErrorKind::Syntax),
            ("F(1,2)", "t.str:1:1: turtle module `F` takes at most 1 parameter(s), got 2", ErrorKind::Arity),
            ("[(1)", "t.str:1:1: turtle module `[`", ErrorKind::Arity),
            ("\nL-system string: 12 3\n", "t.str:2:1: unsupported", ErrorKind::Unsupported),
        ] {
            let e = parse("t.str", text).unwrap_err();
            assert!(e.message.starts_with(at), "{text:?}: {}", e.message);
            assert_eq!(e.kind, kind, "{text:?}");
        }
    }

    #[test]
    fn whitespace_and_odd_input() {
        let (sy, s) = parse("t.str", " F (1)\t+( 30 )\r\n").unwrap();
        assert_eq!(names(&sy, &s), ["F", "+"]);
        assert_eq!(s.module(1).1, &[30.0]);
        let (_, s) = parse("t.str", "").unwrap();
        assert!(s.is_empty());
        // Non-ASCII names and a multi-byte character after `@` do not panic.
        let (sy, s) = parse("t.str", "é@é@Aé").unwrap();
        assert_eq!(names(&sy, &s), ["é", "@", "é", "@A", "é"]);
    }
}
