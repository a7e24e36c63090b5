//! The cpfg preprocessor: builds a [`Source`] from L-system text.
//!
//! cpfg runs its L-system files through the C preprocessor. This module implements the
//! part of it that L-system files rely on: `/* */` and `//` comments, `\` line
//! continuation, `#define NAME value` and `#define NAME(a, b) body` with
//! identifier-token substitution (C semantics: `AB` is one identifier, a macro is not
//! expanded inside its own expansion), `#undef`, `#if` / `#ifdef` / `#ifndef` /
//! `#elif` / `#else` / `#endif` (with `defined`), and `#include "file"` of sibling
//! files through a caller-supplied resolver. The preprocessed text keeps a map from
//! each of its bytes back to the file and byte it came from, so every error points at
//! the line and column the user wrote, in the right file.

use super::comments::{blank_comments, CommentStyle};
use super::expr;
use super::source::{origin, Ch, ErrorKind, LsystemError, Macro, Source};
use std::collections::HashMap;
use std::sync::Arc;

/// Finds a file named by `#include`: given the name as written, returns the display
/// name and the text, or why it cannot be included (no such file; refused: outside
/// the model folder, not a regular file, over the input limit), which the error at the
/// `#include` line quotes.
pub type IncludeResolver<'a> = &'a dyn Fn(&str) -> Result<(String, String), String>;

/// Most characters one logical line may expand to (issue 27: `#define A B B`,
/// `#define B C C`, … doubles at every level; C preprocessors have no such limit, an
/// L-system file has no use for a longer line).
pub const MAX_EXPANDED_LINE: usize = 1 << 20;

/// Most characters the whole preprocessed text may have.
pub const MAX_PREPROCESSED: usize = 1 << 26;

/// What the walk over the model's files carries from file to file: the `#define`
/// overrides, the `#include` resolver, the open `#if` blocks and the include depth.
struct Walk<'a> {
    overrides: HashMap<String, String>,
    resolve: IncludeResolver<'a>,
    conds: Vec<Cond>,
    depth: usize,
}

struct Cond {
    active: bool,
    taken: bool,
    parent_active: bool,
}

impl Source {
    /// Preprocesses `original`. `overrides` replace (or add) `#define` values, as the
    /// recipe's `generator.define` table does. `#include` is an error here; use
    /// [`Source::with_includes`] to allow it.
    pub fn new(
        name: &str,
        original: &str,
        overrides: &[(String, String)],
    ) -> Result<Source, Box<LsystemError>> {
        Self::with_includes(name, original, overrides, &|_| Err("no such file next to the model".into()))
    }

    /// Like [`Source::new`], resolving `#include "file"` through `resolve`.
    pub fn with_includes(
        name: &str,
        original: &str,
        overrides: &[(String, String)],
        resolve: IncludeResolver,
    ) -> Result<Source, Box<LsystemError>> {
        Self::with_predefined(name, original, overrides, &[], resolve)
    }

    /// Like [`Source::with_includes`], with `predefined` macros defined before the file
    /// as a command line's `-DNAME=value` does: the file's own `#define` of a name
    /// replaces it (cpfg passes a function set's names this way, issue 46).
    pub fn with_predefined(
        name: &str,
        original: &str,
        overrides: &[(String, String)],
        predefined: &[(String, String)],
        resolve: IncludeResolver,
    ) -> Result<Source, Box<LsystemError>> {
        let original: Arc<str> = Arc::from(original);
        let mut src = Source {
            name: name.to_string(),
            original: original.clone(),
            text: String::with_capacity(original.len()),
            map: Vec::with_capacity(original.len()),
            files: vec![(name.to_string(), original.clone())],
            defines: HashMap::new(),
            macros: HashMap::new(),
        };
        for (k, v) in predefined {
            src.defines.insert(k.clone(), v.clone());
            src.macros.insert(k.clone(), Macro { params: None, body: v.clone() });
        }
        let mut walk =
            Walk { overrides: overrides.iter().cloned().collect(), resolve, conds: Vec::new(), depth: 0 };
        src.process_file(0, &mut walk)?;
        if let Some(_c) = walk.conds.last() {
            return Err(src.error_nowhere(ErrorKind::Syntax, "`#if` without a matching `#endif`"));
        }
        Ok(src)
    }

    fn process_file(&mut self, file: usize, walk: &mut Walk) -> Result<(), Box<LsystemError>> {
        let text = self.files[file].1.clone();
        let stripped = blank_comments(&text, CommentStyle::Lsystem);
        let lines = logical_lines(&stripped, file);
        for line in &lines {
            let s: String = line.iter().map(|&(c, _)| c).collect();
            let trimmed = s.trim_start();
            let active = walk.conds.last().map(|c| c.active).unwrap_or(true);
            // A directive is `#`, optional blanks, then a name (or nothing: the null
            // directive). `#(0.06) F(5)` — cpfg's width module opening a successor's
            // continuation line — is L-system text, not a directive (issue 26: it was
            // taken for a null directive and silently dropped).
            let directive = trimmed
                .strip_prefix('#')
                .filter(|rest| rest.trim_start().chars().next().is_none_or(|c| c.is_ascii_alphabetic()));
            if let Some(rest) = directive {
                let lead = s.chars().count() - trimmed.chars().count();
                let at = line.get(lead).map(|&(_, o)| o).unwrap_or(origin(file, 0));
                self.directive(rest.trim_end(), at, active, walk)?;
            } else if active {
                let expanded = self.expand(line, 0)?;
                if self.text.len() + expanded.len() > MAX_PREPROCESSED {
                    let o = line.first().map_or(0, |c| c.1);
                    return Err(self.error_origin(
                        ErrorKind::Budget,
                        o,
                        1,
                        &format!("the preprocessed L-system is longer than {MAX_PREPROCESSED} characters (macros expand too much)"),
                        "here",
                    ));
                }
                for (c, o) in expanded {
                    self.push_char(c, o);
                }
                continue;
            }
            // A directive or a line an `#if` leaves out keeps only its newline.
            if let Some(&(_, o)) = line.last() {
                self.push_char('\n', o);
            }
        }
        Ok(())
    }

    fn push_char(&mut self, c: char, orig: u64) {
        self.text.push(c);
        for _ in 0..c.len_utf8() {
            self.map.push(orig);
        }
    }

    fn directive(
        &mut self,
        rest: &str,
        at: u64,
        active: bool,
        walk: &mut Walk,
    ) -> Result<(), Box<LsystemError>> {
        let conds = &mut walk.conds;
        let rest = rest.trim_start();
        let word: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric()).collect();
        let arg = rest[word.len()..].trim();
        let err =
            |s: &Self, kind, what: &str, label: &str| s.error_origin(kind, at, 1 + word.len(), what, label);
        match word.as_str() {
            "ifdef" | "ifndef" => {
                let name = leading_ident(arg);
                let defined = self.macros.contains_key(&name);
                let cond = if word == "ifdef" { defined } else { !defined };
                conds.push(Cond { active: active && cond, taken: cond, parent_active: active });
                Ok(())
            }
            "if" => {
                let v = if active { self.eval_condition(arg, at)? } else { false };
                conds.push(Cond { active: active && v, taken: v, parent_active: active });
                Ok(())
            }
            "elif" => {
                let Some(top) = conds.last() else {
                    return Err(err(self, ErrorKind::Syntax, "`#elif` without `#if`", "here"));
                };
                let (taken, parent) = (top.taken, top.parent_active);
                let v = if parent && !taken { self.eval_condition(arg, at)? } else { false };
                let top = conds.last_mut().expect("checked above");
                top.active = parent && !taken && v;
                top.taken = taken || v;
                Ok(())
            }
            "else" => {
                let Some(top) = conds.last_mut() else {
                    return Err(err(self, ErrorKind::Syntax, "`#else` without `#if`", "here"));
                };
                top.active = top.parent_active && !top.taken;
                top.taken = true;
                Ok(())
            }
            "endif" => {
                if conds.pop().is_none() {
                    return Err(err(self, ErrorKind::Syntax, "`#endif` without `#if`", "here"));
                }
                Ok(())
            }
            _ if !active => Ok(()),
            "define" => {
                let name = leading_ident(arg);
                if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit()) {
                    return Err(err(self, ErrorKind::Syntax, "`#define` needs a name", "here"));
                }
                let after = &arg[name.len()..];
                let (params, body) = if let Some(p) = after.strip_prefix('(') {
                    let Some(close) = p.find(')') else {
                        return Err(err(
                            self,
                            ErrorKind::Syntax,
                            &format!("unclosed `(` in `#define {name}(`"),
                            "here",
                        ));
                    };
                    let params: Vec<String> = p[..close]
                        .split(',')
                        .map(|s| s.trim().to_string())
                        .filter(|s| !s.is_empty())
                        .collect();
                    (Some(params), p[close + 1..].trim().to_string())
                } else {
                    (None, after.trim().to_string())
                };
                let body = match (&params, walk.overrides.get(&name)) {
                    (None, Some(v)) => v.clone(),
                    _ => body,
                };
                if params.is_none() {
                    self.defines.insert(name.clone(), body.clone());
                }
                self.macros.insert(name, Macro { params, body });
                Ok(())
            }
            "undef" => {
                let name = leading_ident(arg);
                self.macros.remove(&name);
                self.defines.remove(&name);
                Ok(())
            }
            "include" => {
                let file = arg.trim_matches(|c| c == '"' || c == '<' || c == '>').trim();
                if file.starts_with("lpfg") {
                    return Err(err(
                        self,
                        ErrorKind::Unsupported,
                        &format!(
                            "unsupported: `#include <{file}>` makes this an lpfg model (L-systems in \
                             C++); sylva reads cpfg L-systems only"
                        ),
                        "lpfg header",
                    ));
                }
                if walk.depth >= 16 {
                    return Err(err(self, ErrorKind::Syntax, "`#include` nested more than 16 deep", "here"));
                }
                let (name, text) = match (walk.resolve)(file) {
                    Ok(found) => found,
                    Err(why) => {
                        return Err(err(
                            self,
                            ErrorKind::Syntax,
                            &format!("cannot include `{}`: {why}", crate::input::excerpt(file)),
                            "included here",
                        ))
                    }
                };
                self.files.push((name, Arc::from(text.as_str())));
                let idx = self.files.len() - 1;
                walk.depth += 1;
                let done = self.process_file(idx, walk);
                walk.depth -= 1;
                done
            }
            "" | "pragma" | "line" => Ok(()),
            other => Err(err(
                self,
                ErrorKind::Unsupported,
                &format!("unsupported: preprocessor directive `#{other}`"),
                "not supported",
            )),
        }
    }

    /// Evaluates a `#if` condition: `defined(X)` / `defined X`, macros, then an
    /// expression; unknown identifiers are 0 as in C.
    fn eval_condition(&self, arg: &str, at: u64) -> Result<bool, Box<LsystemError>> {
        let s = map_identifiers(arg, |ident, rest| {
            if ident != "defined" {
                return (ident.to_string(), 0);
            }
            // `defined(X)` or `defined X`.
            let mut j = 0;
            while j < rest.len() && (rest[j] == ' ' || rest[j] == '(') {
                j += 1;
            }
            let ns = j;
            j = ident_end(rest, j);
            let name: String = rest[ns..j].iter().collect();
            while j < rest.len() && (rest[j] == ' ' || rest[j] == ')') {
                j += 1;
            }
            ((if self.macros.contains_key(&name) { " 1 " } else { " 0 " }).to_string(), j)
        });
        let line: Vec<Ch> = s.chars().map(|c| (c, at)).collect();
        let expanded: String = self.expand(&line, 0)?.into_iter().map(|(c, _)| c).collect();
        // Remaining identifiers are 0 (C rule); function names stay.
        let t = map_identifiers(&expanded, |ident, rest| {
            let call = rest.iter().find(|c| !c.is_whitespace()) == Some(&'(');
            ((if call { ident } else { "0" }).to_string(), 0)
        });
        let tmp = Source::new("#if", &t, &[])?;
        let e = expr::compile(&tmp, 0, tmp.text.len(), &expr::Scope::default()).map_err(|_| {
            self.error_origin(ErrorKind::Syntax, at, 3, &format!("bad `#if` condition `{arg}`"), "here")
        })?;
        let v = expr::Evaluator::new(0).eval(&e, &[]).map_err(|_| {
            self.error_origin(ErrorKind::Syntax, at, 3, &format!("bad `#if` condition `{arg}`"), "here")
        })?;
        Ok(v != 0.0)
    }

    /// Expands macros in one logical line. `depth` guards recursion.
    fn expand(&self, line: &[Ch], depth: usize) -> Result<Vec<Ch>, Box<LsystemError>> {
        self.expand_except(line, depth, &[])
    }

    fn expand_except(
        &self,
        line: &[Ch],
        depth: usize,
        disabled: &[String],
    ) -> Result<Vec<Ch>, Box<LsystemError>> {
        let mut out = Vec::with_capacity(line.len());
        let mut k = 0;
        while k < line.len() {
            let (c, o) = line[k];
            if c.is_ascii_alphabetic() || c == '_' {
                let start = k;
                while k < line.len() && is_ident(line[k].0) {
                    k += 1;
                }
                let ident: String = line[start..k].iter().map(|&(c, _)| c).collect();
                let Some(mac) = self.macros.get(&ident).filter(|_| !disabled.contains(&ident)) else {
                    out.extend_from_slice(&line[start..k]);
                    continue;
                };
                // The expansion of this use makes the line longer than the limit.
                let too_long = || {
                    self.error_origin(
                        ErrorKind::Budget,
                        o,
                        ident.len(),
                        &format!(
                            "macro `{ident}` expands this line to more than {MAX_EXPANDED_LINE} characters"
                        ),
                        "macro use",
                    )
                };
                if depth > 64 {
                    return Err(self.error_origin(
                        ErrorKind::Syntax,
                        o,
                        ident.len(),
                        &format!("macro `{ident}` expands recursively more than 64 levels"),
                        "here",
                    ));
                }
                let body: Vec<Ch> = match &mac.params {
                    None => mac.body.chars().map(|c| (c, o)).collect(),
                    Some(params) => {
                        // A function-like macro needs `(`; otherwise it is an ordinary name.
                        let mut j = k;
                        while j < line.len() && line[j].0.is_whitespace() {
                            j += 1;
                        }
                        if j >= line.len() || line[j].0 != '(' {
                            out.extend_from_slice(&line[start..k]);
                            continue;
                        }
                        let (args, end) = split_macro_args(line, j).ok_or_else(|| {
                            self.error_origin(
                                ErrorKind::Syntax,
                                o,
                                ident.len(),
                                &format!("unclosed `(` in the use of macro `{ident}`"),
                                "macro use",
                            )
                        })?;
                        let args = if params.is_empty()
                            && args.len() == 1
                            && args[0].iter().all(|c| c.0.is_whitespace())
                        {
                            Vec::new()
                        } else {
                            args
                        };
                        if args.len() != params.len() {
                            return Err(self.error_origin(
                                ErrorKind::Arity,
                                o,
                                ident.len(),
                                &format!(
                                    "macro `{ident}` takes {} argument(s), got {}",
                                    params.len(),
                                    args.len()
                                ),
                                "macro use",
                            ));
                        }
                        k = end + 1;
                        // Arguments are fully expanded before substitution (C rule).
                        let mut expanded_args = Vec::with_capacity(args.len());
                        for a in &args {
                            expanded_args.push(self.expand_except(a, depth + 1, disabled)?);
                        }
                        let body = substitute(&mac.body, params, &expanded_args, o);
                        if body.len() > MAX_EXPANDED_LINE {
                            return Err(too_long());
                        }
                        body
                    }
                };
                let mut dis = disabled.to_vec();
                dis.push(ident.clone());
                let rescanned = self.expand_except(&body, depth + 1, &dis)?;
                out.extend(rescanned);
                if out.len() > MAX_EXPANDED_LINE {
                    return Err(too_long());
                }
            } else if c.is_ascii_digit() || c == '.' {
                // Numbers such as 1e5 must not have their exponent taken as an identifier.
                while k < line.len()
                    && (line[k].0.is_ascii_alphanumeric() || line[k].0 == '.' || line[k].0 == '_')
                {
                    let exp = line[k].0 == 'e' || line[k].0 == 'E';
                    out.push(line[k]);
                    k += 1;
                    if exp && k < line.len() && (line[k].0 == '+' || line[k].0 == '-') {
                        out.push(line[k]);
                        k += 1;
                    }
                }
            } else if c == '"' {
                // String literals (printf formats) pass through unexpanded.
                out.push(line[k]);
                k += 1;
                while k < line.len() && line[k].0 != '"' {
                    out.push(line[k]);
                    k += 1;
                }
                if k < line.len() {
                    out.push(line[k]);
                    k += 1;
                }
            } else {
                out.push((c, o));
                k += 1;
            }
        }
        Ok(out)
    }
}

/// Whether `c` may continue an identifier (C rules, ASCII).
fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The end of the identifier characters of `b` from `i` on.
fn ident_end(b: &[char], mut i: usize) -> usize {
    while i < b.len() && is_ident(b[i]) {
        i += 1;
    }
    i
}

/// The identifier at the start of `s` (empty when there is none).
fn leading_ident(s: &str) -> String {
    s.chars().take_while(|&c| is_ident(c)).collect()
}

/// A piece of text as [`scan_identifiers`] walks it.
enum Piece<'a> {
    /// An identifier and the text after it.
    Ident(&'a str, &'a [char]),
    /// A character outside identifiers.
    Other(char),
}

/// Walks `text`, handing `f` each identifier (with the rest of the text) and each other
/// character; `f` returns how many characters after the piece it consumed, or `None`
/// to stop.
fn scan_identifiers(text: &str, mut f: impl FnMut(Piece<'_>) -> Option<usize>) {
    let b: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < b.len() {
        let used = if b[i].is_ascii_alphabetic() || b[i] == '_' {
            let st = i;
            i = ident_end(&b, i);
            let ident: String = b[st..i].iter().collect();
            f(Piece::Ident(&ident, &b[i..]))
        } else {
            i += 1;
            f(Piece::Other(b[i - 1]))
        };
        match used {
            Some(n) => i += n,
            None => return,
        }
    }
}

/// Rewrites every identifier of `text` through `f(identifier, rest of the text)`, which
/// returns the replacement and how many characters of the rest it consumed.
fn map_identifiers(text: &str, mut f: impl FnMut(&str, &[char]) -> (String, usize)) -> String {
    let mut out = String::with_capacity(text.len());
    scan_identifiers(text, |piece| match piece {
        Piece::Ident(ident, rest) => {
            let (rep, used) = f(ident, rest);
            out.push_str(&rep);
            Some(used)
        }
        Piece::Other(c) => {
            out.push(c);
            Some(0)
        }
    });
    out
}

/// Splits comment-free text into logical lines (joining `\` continuations), each char
/// tagged with its origin; every line keeps its trailing newline.
fn logical_lines(stripped: &str, file: usize) -> Vec<Vec<Ch>> {
    let mut lines: Vec<Vec<Ch>> = vec![Vec::new()];
    let chars: Vec<(usize, char)> = stripped.char_indices().collect();
    let mut k = 0;
    while k < chars.len() {
        let (off, c) = chars[k];
        if c == '\\' {
            let mut j = k + 1;
            while j < chars.len() && matches!(chars[j].1, ' ' | '\t' | '\r') {
                j += 1;
            }
            if j < chars.len() && chars[j].1 == '\n' {
                k = j + 1;
                continue;
            }
        }
        lines.last_mut().expect("never empty").push((c, origin(file, off)));
        if c == '\n' {
            lines.push(Vec::new());
        }
        k += 1;
    }
    lines
}

/// Splits the arguments of a macro call whose `(` is at `open`; returns them and the
/// index of the closing `)`.
fn split_macro_args(line: &[Ch], open: usize) -> Option<(Vec<Vec<Ch>>, usize)> {
    let mut depth = 0;
    let mut args = vec![Vec::new()];
    for (k, &(c, o)) in line.iter().enumerate().skip(open) {
        match c {
            '(' => {
                depth += 1;
                if depth == 1 {
                    continue;
                }
            }
            ')' => {
                depth -= 1;
                if depth == 0 {
                    return Some((args, k));
                }
            }
            ',' if depth == 1 => {
                args.push(Vec::new());
                continue;
            }
            _ => {}
        }
        args.last_mut().expect("never empty").push((c, o));
    }
    None
}

/// Replaces parameter identifiers in `body` by the argument texts.
fn substitute(body: &str, params: &[String], args: &[Vec<Ch>], o: u64) -> Vec<Ch> {
    let mut out = Vec::new();
    scan_identifiers(body, |piece| {
        match piece {
            Piece::Ident(ident, _) => {
                match params.iter().position(|p| *p == ident) {
                    Some(k) => out.extend_from_slice(&args[k]),
                    None => out.extend(ident.chars().map(|c| (c, o))),
                }
                if out.len() > MAX_EXPANDED_LINE {
                    // The caller's rescan reports the line as too long.
                    out.truncate(MAX_EXPANDED_LINE + 1);
                    return None;
                }
            }
            Piece::Other(c) => out.push((c, o)),
        }
        Some(0)
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pp(text: &str) -> String {
        Source::new("t.l", text, &[])
            .unwrap()
            .text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("|")
    }

    #[test]
    fn defines_expand_by_identifier() {
        assert_eq!(pp("#define D 3\n#define AB 7\nA(D) AB ABC D2 1e5\n"), "A(3) 7 ABC D2 1e5");
    }

    #[test]
    fn overrides_replace_defines() {
        let s = Source::new("t.l", "#define D 3\nx D\n", &[("D".into(), "9".into())]).unwrap();
        assert_eq!(s.text.trim(), "x 9");
    }

    #[test]
    fn comments_and_continuations() {
        assert_eq!(pp("a /* b\n c */ d // e\nf\\\ng\n"), "a|d|fg");
    }

    #[test]
    fn function_like_macros() {
        assert_eq!(pp("#define frac(x) ((x)-floor(x))\nA(frac(t*2))\n"), "A(((t*2)-floor(t*2)))");
        assert_eq!(
            pp("#define MAX(a,b) (((a)>(b))?(a):(b))\nMAX(1, f(2,3))\n"),
            "(((1)>( f(2,3)))?(1):( f(2,3)))"
        );
        assert_eq!(pp("#define f(x) x\nf + f(1)\n"), "f + 1");
        assert_eq!(pp("#define A B\n#define B A\nA\n"), "A");
    }

    #[test]
    fn conditionals() {
        let t = "#define L 1\n#if L==1\nyes\n#else\nno\n#endif\n#ifdef Q\nq\n#elif defined(L) && L > 0\nel\n#endif\n#ifndef Q\nnq\n#endif\n";
        assert_eq!(pp(t), "yes|el|nq");
        assert!(Source::new("t.l", "#if 1\nx\n", &[]).is_err());
        assert!(Source::new("t.l", "#endif\n", &[]).is_err());
    }

    #[test]
    fn includes_map_errors_to_their_file() {
        let resolve = |name: &str| {
            (name == "leaf.l")
                .then(|| ("leaf.l".to_string(), "#define W 2\nbad here\n".to_string()))
                .ok_or_else(|| "no such file next to the model".to_string())
        };
        let s = Source::with_includes("t.l", "#include \"leaf.l\"\nx W\n", &[], &resolve).unwrap();
        assert!(s.text.contains("x 2"));
        let at = s.text.find("bad").unwrap();
        let e = s.error(ErrorKind::Syntax, at, 3, "oops", "x");
        assert!(e.message.starts_with("leaf.l:2:1: oops"), "{}", e.message);
        let e = Source::with_includes("t.l", "#include \"none.l\"\n", &[], &resolve).unwrap_err();
        assert!(e.message.contains("cannot include `none.l`"));
    }

    #[test]
    fn error_positions_map_to_original() {
        let s = Source::new("t.l", "#define X 1\n\n  foo X bar\n", &[]).unwrap();
        let at = s.text.find("bar").unwrap();
        let e = s.error(ErrorKind::Syntax, at, 3, "bad", "x");
        assert!(e.message.starts_with("t.l:3:9: bad"), "{}", e.message);
    }

    #[test]
    fn unsupported_directive() {
        let e = Source::new("t.l", "#warning x\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Unsupported);
        assert!(e.message.contains("t.l:1:1"));
    }
}
