//! Source text, the cpfg preprocessor subset, and error reporting with excerpts.
//!
//! cpfg runs its L-system files through the C preprocessor. This module implements the
//! part of it that L-system files rely on most: `/* */` and `//` comments, `\` line
//! continuation and object-like `#define NAME value` with identifier-token
//! substitution (C semantics: `AB` is one identifier, so `#define A` does not touch it).
//! The preprocessed text keeps a map from each of its bytes back to the original
//! file, so every error points at the line and column the user wrote.

use miette::{NamedSource, SourceSpan};
use std::collections::HashMap;
use std::sync::Arc;

/// What went wrong, for tests and callers that branch on the kind of error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// The text does not follow the grammar.
    Syntax,
    /// A function or turtle module got the wrong number of arguments.
    Arity,
    /// An identifier in an expression is not a parameter, constant or function.
    UndefinedName,
    /// Division (or `%`) by zero during evaluation.
    DivisionByZero,
    /// An expression produced NaN or an infinity.
    NonFinite,
    /// The module string would exceed the module budget.
    Budget,
    /// A feature of cpfg that sylva does not implement (yet).
    Unsupported,
}

/// An L-system error: what, where (file:line:column with an excerpt) and why.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error("{message}")]
pub struct LsystemError {
    /// The kind of error.
    pub kind: ErrorKind,
    /// The full message, starting with `file:line:column:` when a place is known.
    pub message: String,
    /// The original source, for the excerpt.
    #[source_code]
    pub source_code: NamedSource<Arc<str>>,
    /// The offending span in the original source.
    #[label("{label}")]
    pub span: Option<SourceSpan>,
    /// Short label under the caret.
    pub label: String,
    /// How to fix it, when known.
    #[help]
    pub help: Option<String>,
}

impl LsystemError {
    /// Attaches a help text.
    pub fn with_help(mut self: Box<Self>, help: impl Into<String>) -> Box<Self> {
        self.help = Some(help.into());
        self
    }
}

/// A preprocessed L-system source: text plus a byte map back to the original.
#[derive(Debug, Clone)]
pub struct Source {
    /// File name used in messages.
    pub name: String,
    /// The original text.
    pub original: Arc<str>,
    /// The preprocessed text (comments blanked, macros expanded, continuations joined).
    pub text: String,
    /// For each byte of `text`, the byte offset in `original` it came from.
    map: Vec<u32>,
    /// The object-like macros, in definition order of last definition.
    pub defines: HashMap<String, String>,
}

impl Source {
    /// Preprocesses `original`. `overrides` replace (or add) `#define` values, as the
    /// recipe's `generator.define` table does.
    pub fn new(
        name: &str,
        original: &str,
        overrides: &[(String, String)],
    ) -> Result<Source, Box<LsystemError>> {
        let original: Arc<str> = Arc::from(original);
        let mut src = Source {
            name: name.to_string(),
            original: original.clone(),
            text: String::with_capacity(original.len()),
            map: Vec::with_capacity(original.len()),
            defines: HashMap::new(),
        };
        let stripped = strip_comments(&original);
        // Logical lines: join `\` continuations, keeping each byte's original offset.
        let mut lines: Vec<Vec<(char, u32)>> = vec![Vec::new()];
        let chars: Vec<(usize, char)> = stripped.char_indices().collect();
        let mut k = 0;
        while k < chars.len() {
            let (off, c) = chars[k];
            if c == '\\' {
                // `\` followed by optional spaces and a newline continues the line.
                let mut j = k + 1;
                while j < chars.len() && (chars[j].1 == ' ' || chars[j].1 == '\t' || chars[j].1 == '\r') {
                    j += 1;
                }
                if j < chars.len() && chars[j].1 == '\n' {
                    k = j + 1;
                    continue;
                }
            }
            if c == '\n' {
                lines.last_mut().expect("lines is never empty").push((c, off as u32));
                lines.push(Vec::new());
            } else {
                lines.last_mut().expect("lines is never empty").push((c, off as u32));
            }
            k += 1;
        }
        let overrides: HashMap<&str, &str> =
            overrides.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
        for line in &lines {
            let text: String = line.iter().map(|&(c, _)| c).collect();
            let trimmed = text.trim_start();
            if let Some(rest) = trimmed.strip_prefix('#') {
                let lead = text.len() - trimmed.len();
                let directive_at = line.get(lead).map(|&(_, o)| o).unwrap_or(0);
                src.directive(rest, directive_at, &overrides)?;
                // Keep the line structure.
                if let Some(&(_, o)) = line.last() {
                    src.push_char('\n', o);
                }
                continue;
            }
            src.expand_line(line, 0)?;
        }
        Ok(src)
    }

    fn push_char(&mut self, c: char, orig: u32) {
        self.text.push(c);
        for _ in 0..c.len_utf8() {
            self.map.push(orig);
        }
    }

    fn directive(
        &mut self,
        rest: &str,
        at: u32,
        overrides: &HashMap<&str, &str>,
    ) -> Result<(), Box<LsystemError>> {
        let rest = rest.trim_start();
        let word: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric()).collect();
        match word.as_str() {
            "define" => {
                let body = rest["define".len()..].trim_start();
                let name: String =
                    body.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                if name.is_empty() || name.starts_with(|c: char| c.is_ascii_digit()) {
                    return Err(self.error_at(
                        ErrorKind::Syntax,
                        at as usize,
                        1,
                        "`#define` needs a name",
                        "here",
                    ));
                }
                let after = &body[name.len()..];
                if after.starts_with('(') {
                    return Err(self.error_at(
                        ErrorKind::Unsupported,
                        at as usize,
                        1,
                        &format!("unsupported: `#define {name}(...)` macros with arguments"),
                        "function-like macro",
                    ));
                }
                let value = overrides
                    .get(name.as_str())
                    .map(|v| v.to_string())
                    .unwrap_or_else(|| after.trim().to_string());
                self.defines.insert(name, value);
                Ok(())
            }
            "" => Ok(()), // a lone `#` is a null directive in C
            other => Err(self.error_at(
                ErrorKind::Unsupported,
                at as usize,
                1 + other.len(),
                &format!("unsupported: preprocessor directive `#{other}`"),
                "only #define is supported",
            )),
        }
    }

    /// Appends one logical line with macro expansion. `depth` guards recursion.
    fn expand_line(&mut self, line: &[(char, u32)], depth: usize) -> Result<(), Box<LsystemError>> {
        let mut k = 0;
        while k < line.len() {
            let (c, o) = line[k];
            if c.is_ascii_alphabetic() || c == '_' {
                let start = k;
                while k < line.len() && (line[k].0.is_ascii_alphanumeric() || line[k].0 == '_') {
                    k += 1;
                }
                let ident: String = line[start..k].iter().map(|&(c, _)| c).collect();
                if let Some(value) = self.defines.get(&ident).cloned() {
                    if depth > 32 {
                        return Err(self.error_at(
                            ErrorKind::Syntax,
                            o as usize,
                            ident.len(),
                            &format!("macro `{ident}` expands recursively more than 32 levels"),
                            "here",
                        ));
                    }
                    // The expansion maps to the macro use's position.
                    let sub: Vec<(char, u32)> = value.chars().map(|c| (c, o)).collect();
                    self.expand_line_no_newline(&sub, depth + 1, &ident)?;
                } else {
                    for &(c, o) in &line[start..k] {
                        self.push_char(c, o);
                    }
                }
            } else if c.is_ascii_digit() || c == '.' {
                // Numbers such as 1e5 must not have their exponent taken as an identifier.
                while k < line.len()
                    && (line[k].0.is_ascii_alphanumeric() || line[k].0 == '.' || line[k].0 == '_')
                {
                    let (c, o) = line[k];
                    self.push_char(c, o);
                    let exp = c == 'e' || c == 'E';
                    k += 1;
                    if exp && k < line.len() && (line[k].0 == '+' || line[k].0 == '-') {
                        self.push_char(line[k].0, line[k].1);
                        k += 1;
                    }
                }
            } else {
                self.push_char(c, o);
                k += 1;
            }
        }
        Ok(())
    }

    fn expand_line_no_newline(
        &mut self,
        sub: &[(char, u32)],
        depth: usize,
        ident: &str,
    ) -> Result<(), Box<LsystemError>> {
        // A macro is not expanded inside its own expansion (C rule).
        let saved = self.defines.remove(ident);
        let r = self.expand_line(sub, depth);
        if let Some(v) = saved {
            self.defines.insert(ident.to_string(), v);
        }
        r
    }

    /// Original byte offset of a preprocessed offset.
    pub fn original_offset(&self, at: usize) -> usize {
        if self.map.is_empty() {
            return 0;
        }
        self.map[at.min(self.map.len() - 1)] as usize
    }

    /// 1-based line and column of an original byte offset.
    pub fn line_col(&self, orig: usize) -> (usize, usize) {
        let before = &self.original[..orig.min(self.original.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
        (line, col)
    }

    /// An error at a preprocessed offset `at` spanning `len` bytes.
    pub fn error(
        &self,
        kind: ErrorKind,
        at: usize,
        len: usize,
        what: &str,
        label: &str,
    ) -> Box<LsystemError> {
        let orig = self.original_offset(at);
        let orig_end = if at + len > 0 { self.original_offset(at + len.max(1) - 1) + 1 } else { orig };
        let len = orig_end.saturating_sub(orig).max(1);
        self.error_at(kind, orig, len, what, label)
    }

    /// An error at an ORIGINAL byte offset.
    pub fn error_at(
        &self,
        kind: ErrorKind,
        orig: usize,
        len: usize,
        what: &str,
        label: &str,
    ) -> Box<LsystemError> {
        let (line, col) = self.line_col(orig);
        let len =
            len.min(self.original.len().saturating_sub(orig)).max(usize::from(orig < self.original.len()));
        Box::new(LsystemError {
            kind,
            message: format!("{}:{line}:{col}: {what}", self.name),
            source_code: NamedSource::new(self.name.clone(), self.original.clone()),
            span: Some(SourceSpan::new(orig.into(), len)),
            label: label.to_string(),
            help: None,
        })
    }

    /// An error with no particular place in the file.
    pub fn error_nowhere(&self, kind: ErrorKind, what: &str) -> Box<LsystemError> {
        Box::new(LsystemError {
            kind,
            message: format!("{}: {what}", self.name),
            source_code: NamedSource::new(self.name.clone(), self.original.clone()),
            span: None,
            label: String::new(),
            help: None,
        })
    }
}

/// Replaces comments by spaces (newlines kept), so offsets stay the same.
fn strip_comments(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && i + 1 < b.len() && b[i + 1] == b'*' {
            out.extend_from_slice(b"  ");
            i += 2;
            while i < b.len() && !(b[i] == b'*' && i + 1 < b.len() && b[i + 1] == b'/') {
                out.push(if b[i] == b'\n' {
                    b'\n'
                } else if b[i] < 0x80 {
                    b' '
                } else {
                    b[i]
                });
                i += 1;
            }
            if i < b.len() {
                out.extend_from_slice(b"  ");
                i += 2;
            }
        } else if b[i] == b'/' && i + 1 < b.len() && b[i + 1] == b'/' {
            while i < b.len() && b[i] != b'\n' {
                out.push(if b[i] < 0x80 { b' ' } else { b[i] });
                i += 1;
            }
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    // Non-ASCII bytes were copied unchanged, so the result is valid UTF-8.
    String::from_utf8(out).unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defines_expand_by_identifier() {
        let s = Source::new("t.l", "#define D 3\n#define AB 7\nA(D) AB ABC D2 1e5\n", &[]).unwrap();
        assert_eq!(s.text.trim(), "A(3) 7 ABC D2 1e5");
    }

    #[test]
    fn overrides_replace_defines() {
        let s = Source::new("t.l", "#define D 3\nx D\n", &[("D".into(), "9".into())]).unwrap();
        assert_eq!(s.text.trim(), "x 9");
    }

    #[test]
    fn comments_and_continuations() {
        let s = Source::new("t.l", "a /* b\n c */ d // e\nf\\\ng\n", &[]).unwrap();
        let t: Vec<&str> = s.text.lines().map(str::trim).collect();
        assert_eq!(t, vec!["a", "d", "fg"]);
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
        let e = Source::new("t.l", "#include \"x.h\"\n", &[]).unwrap_err();
        assert_eq!(e.kind, ErrorKind::Unsupported);
        assert!(e.message.contains("t.l:1:1"));
    }
}
