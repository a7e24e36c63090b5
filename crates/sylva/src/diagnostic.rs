//! Located errors: what went wrong, where (file:line:column with an excerpt of the
//! text) and how to fix it. Plain data below every stage: the L-system language
//! (MacMurchy2004 §4.3, McLoughlin2021 §2), the LST and `.str` readers (Pieterse2012 §4.1.5) and the
//! crate's [`crate::Error`] all carry these, so none of them depends on another for it.
//!
//! Every located error is built by [`LsystemError::located`] (or
//! [`LsystemError::nowhere`] when there is no place), which never copies more than a
//! small window of the text: the [`Excerpt`] it carries holds the error's line clipped
//! to [`EXCERPT_SIDE`] characters either side of the error, and at most
//! [`EXCERPT_CONTEXT`] clipped neighbouring lines each side, with the span re-based into
//! that window. The excerpt reports the file's true line and column to the renderer, so
//! miette's header and gutter name the place in the file, and a line of any length
//! renders (miette's graphical handler panics on a column past 65,535, issue 39, and
//! would print the whole line). Messages quote pieces of the input through [`quote`],
//! which clips them to [`QUOTE_CHARS`] characters; as a safety net the constructors
//! clip every piece a message quotes (between backticks or double quotes) to
//! [`MAX_QUOTED_CHARS`] ([`clip_quoted_to`]; generous, for paths), and the whole message
//! to [`MAX_MESSAGE_CHARS`].

use miette::{MietteError, MietteSpanContents, SourceCode, SourceSpan, SpanContents};
use std::borrow::Cow;
use std::sync::Arc;

/// The most characters of the error's line an excerpt keeps on each side of the error
/// (the span itself keeps at most as many again).
pub const EXCERPT_SIDE: usize = 120;

/// The most neighbouring lines an excerpt keeps before and after the error's lines
/// (each clipped like the error's line).
pub const EXCERPT_CONTEXT: usize = 2;

/// The most lines of a span that reaches over several lines an excerpt keeps; the span
/// is cut at the end of the last one.
pub const EXCERPT_SPAN_LINES: usize = 4;

/// The most characters of a piece of input (a token, a value) a message quotes.
pub const QUOTE_CHARS: usize = 80;

/// The most characters of any piece a located error's message quotes (between backticks
/// or double quotes): a safety net behind [`quote`], long enough for file paths.
pub const MAX_QUOTED_CHARS: usize = 4 * QUOTE_CHARS;

/// The most characters of a located error's message and label; longer ones are clipped
/// with an ellipsis.
pub const MAX_MESSAGE_CHARS: usize = 2000;

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
    /// An array index or a loop count outside its bounds.
    OutOfRange,
}

/// An L-system error: what, where (file:line:column with an excerpt) and why.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error("{message}")]
pub struct LsystemError {
    /// The kind of error.
    pub kind: ErrorKind,
    /// The full message, starting with `file:line:column:` when a place is known.
    pub message: String,
    /// A clipped window of the file the error is in, for the excerpt.
    #[source_code]
    pub source_code: Excerpt,
    /// The offending span, as an offset into [`Excerpt::text`] (not into the file).
    #[label("{label}")]
    pub span: Option<SourceSpan>,
    /// Short label under the caret.
    pub label: String,
    /// How to fix it, when known.
    #[help]
    pub help: Option<String>,
}

impl LsystemError {
    /// A located error in `text` (a file named `name`, as written, before any
    /// preprocessing) at byte offset `at`, `len` bytes long: the message is
    /// `name:line:column: what`, the excerpt a clipped window around the place (see the
    /// module docs), so neither its building nor its rendering depends on the length of
    /// the text's lines. Offsets past the end or inside a character are moved back to
    /// the nearest character; `len` is kept within the text and is at least 1 unless the
    /// place is the end of the text.
    pub fn located(
        kind: ErrorKind,
        name: &str,
        text: &str,
        at: usize,
        len: usize,
        what: &str,
        label: &str,
    ) -> Box<Self> {
        let at = floor_char_boundary(text, at);
        let len = len.min(text.len() - at).max(usize::from(at < text.len()));
        let (line, col) = line_col(text, at);
        let (source_code, span) = Excerpt::new(name, text, at, len);
        Box::new(LsystemError {
            kind,
            message: format!("{name}:{line}:{col}: {}", clip_quoted_to(what, MAX_QUOTED_CHARS)),
            source_code,
            span: Some(span),
            label: clip(label, MAX_MESSAGE_CHARS).into_owned(),
            help: None,
        })
    }

    /// An error with no place in the file `name`: `name: what`, without an excerpt.
    pub fn nowhere(kind: ErrorKind, name: &str, what: &str) -> Box<Self> {
        Box::new(LsystemError {
            kind,
            message: format!("{name}: {}", clip_quoted_to(what, MAX_QUOTED_CHARS)),
            source_code: Excerpt::empty(name),
            span: None,
            label: String::new(),
            help: None,
        })
    }

    /// Attaches a help text.
    pub fn with_help(mut self: Box<Self>, help: impl Into<String>) -> Box<Self> {
        self.help = Some(help.into());
        self
    }
}

/// `s` clipped to at most `max` characters, with `…` in place of the rest.
pub fn clip(s: &str, max: usize) -> Cow<'_, str> {
    match s.char_indices().nth(max) {
        Some((k, _)) => Cow::Owned(format!("{}…", &s[..k])),
        None => Cow::Borrowed(s),
    }
}

/// A piece of the input for a message: `s` clipped to [`QUOTE_CHARS`] characters.
pub fn quote(s: &str) -> Cow<'_, str> {
    clip(s, QUOTE_CHARS)
}

/// The largest character boundary of `text` at or before `at` (and at most its length).
fn floor_char_boundary(text: &str, at: usize) -> usize {
    let mut at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    at
}

/// 1-based line and column (in characters) of byte offset `off` in `text`; an offset
/// inside a character or past the end counts as the character boundary before it.
pub fn line_col(text: &str, off: usize) -> (usize, usize) {
    let before = &text[..floor_char_boundary(text, off)];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

/// One line of an [`Excerpt`]'s window.
#[derive(Debug, Clone, PartialEq, Eq)]
struct WindowLine {
    /// Byte offset in the window where the line starts (at its `…`, if clipped).
    start: usize,
    /// Byte offset in the window of the first character kept from the file's line.
    body: usize,
    /// 0-based column (in characters) in the file's line of that character.
    col: usize,
}

/// A clipped window of a text around an error, for miette: it holds a few hundred
/// characters at most (see the [module docs](self)) whatever the length of the text and
/// its lines, and reports the file's true line and column numbers to the renderer.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Excerpt {
    /// The file's name, as in messages.
    name: String,
    /// The window: the kept lines, each clipped, a clipped side marked `…`.
    text: Arc<str>,
    /// 0-based line in the file of the window's first line.
    first_line: usize,
    /// The window's lines, in order.
    lines: Vec<WindowLine>,
}

impl Excerpt {
    /// An excerpt with no text (for errors with no place).
    pub fn empty(name: &str) -> Self {
        Excerpt { name: name.to_string(), text: Arc::from(""), first_line: 0, lines: Vec::new() }
    }

    /// The window of `text` (named `name`) around the `len` bytes at byte offset `at`,
    /// and that span re-based into the window. `at` must be a character boundary within
    /// the text and `at + len` at most its length.
    pub fn new(name: &str, text: &str, at: usize, len: usize) -> (Self, SourceSpan) {
        let at = floor_char_boundary(text, at);
        let end = floor_char_boundary(text, at.saturating_add(len)).max(at);
        let line_start = |i: usize| text[..i].rfind('\n').map_or(0, |k| k + 1);
        // The first kept line: up to EXCERPT_CONTEXT lines before the error's.
        let err_line_start = line_start(at);
        let mut first = err_line_start;
        let mut before = 0;
        while before < EXCERPT_CONTEXT && first > 0 {
            first = line_start(first - 1);
            before += 1;
        }
        let first_line = text[..first].bytes().filter(|&b| b == b'\n').count();
        // The error's start column (characters) is the focus of every kept line; the
        // span's last line focuses on the span's end.
        let focus = text[err_line_start..at].chars().count();
        let mut window = String::new();
        let mut lines = Vec::new();
        let (mut span_start, mut span_end) = (None, None);
        let mut pos = first;
        let mut span_lines = 0;
        // Once the span's lines are kept: how many lines after them are.
        let mut after: Option<usize> = None;
        loop {
            let stop = text[pos..].find('\n').map_or(text.len(), |k| pos + k);
            let line = &text[pos..stop];
            let is_start = pos == err_line_start;
            let in_span = is_start || (pos > err_line_start && pos < end && after.is_none());
            let is_end = in_span && end <= stop;
            // Columns (characters) this line keeps: 2·SIDE around its focus, plus the
            // span's own characters (at most SIDE) on the error's line.
            let (f, extra) = if is_start {
                (focus, text[at..end.min(stop)].chars().take(EXCERPT_SIDE).count())
            } else if is_end {
                (text[pos..end].chars().count(), 0)
            } else {
                (focus, 0)
            };
            let n = line.chars().count();
            let a = f.saturating_sub(EXCERPT_SIDE).min(n.saturating_sub(2 * EXCERPT_SIDE + extra));
            let b = n.min(a + 2 * EXCERPT_SIDE + extra);
            let byte = |c: usize| line.char_indices().nth(c).map_or(line.len(), |(k, _)| k);
            let (ba, bb) = (byte(a), byte(b));
            let start = window.len();
            if a > 0 {
                window.push('…');
            }
            let body = window.len();
            // A lone `\r` would be a line break to miette: keep the offsets, drop the break.
            window.extend(line[ba..bb].chars().map(|c| if c == '\r' { ' ' } else { c }));
            let rebase = |o: usize| body + o.clamp(pos + ba, pos + bb) - (pos + ba);
            if is_start {
                span_start = Some(rebase(at));
            }
            if in_span {
                // A span that goes on past the kept part ends at its end.
                span_end = Some(rebase(end));
                span_lines += 1;
            }
            if bb < line.len() {
                window.push('…');
            }
            lines.push(WindowLine { start, body, col: a });
            if in_span && (is_end || span_lines >= EXCERPT_SPAN_LINES) {
                after = Some(0);
            } else if let (false, Some(k)) = (in_span, after.as_mut()) {
                *k += 1;
            }
            if stop >= text.len() || after.is_some_and(|k| k >= EXCERPT_CONTEXT) {
                break;
            }
            window.push('\n');
            pos = stop + 1;
        }
        let s = span_start.unwrap_or(window.len());
        let e = span_end.unwrap_or(s).max(s);
        let excerpt = Excerpt { name: name.to_string(), text: Arc::from(window), first_line, lines };
        (excerpt, SourceSpan::new(s.into(), e - s))
    }

    /// The window's text.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// 0-based column in the file of byte `off` of the window.
    fn column(&self, off: usize) -> usize {
        let Some(l) = self.lines.iter().rev().find(|l| l.start <= off) else { return 0 };
        if off == l.start {
            return 0;
        }
        let body = self.text.get(l.body..off.max(l.body)).map_or(0, |s| s.chars().count());
        l.col + body
    }
}

impl SourceCode for Excerpt {
    fn read_span<'a>(
        &'a self,
        span: &SourceSpan,
        context_lines_before: usize,
        context_lines_after: usize,
    ) -> Result<Box<dyn SpanContents<'a> + 'a>, MietteError> {
        let inner = self.text.read_span(span, context_lines_before, context_lines_after)?;
        let column = if inner.column() == 0 { 0 } else { self.column(inner.span().offset()) };
        Ok(Box::new(MietteSpanContents::new_named(
            self.name.clone(),
            inner.data(),
            *inner.span(),
            inner.line() + self.first_line,
            column,
            inner.line_count() + self.first_line,
        )))
    }
}

/// A message from another library (serde, serde_json, toml) with every piece it
/// quotes — between `"` or `` ` `` — clipped to [`QUOTE_CHARS`] characters, and the
/// whole to [`MAX_MESSAGE_CHARS`]: those messages quote the offending value whole.
pub fn clip_quoted(msg: &str) -> Cow<'_, str> {
    clip_quoted_to(msg, QUOTE_CHARS)
}

/// [`clip_quoted`] with pieces clipped to `max` characters.
pub fn clip_quoted_to(msg: &str, max: usize) -> Cow<'_, str> {
    let mut out = String::with_capacity(msg.len().min(MAX_MESSAGE_CHARS));
    let mut chars = msg.chars();
    let mut changed = false;
    while let Some(c) = chars.next() {
        out.push(c);
        if !matches!(c, '"' | '`') {
            continue;
        }
        // Inside a quoted piece: keep `max` characters of it, then skip to its end.
        let mut kept = 0;
        let mut escaped = false;
        for d in chars.by_ref() {
            let end = d == c && !escaped;
            escaped = !escaped && c == '"' && d == '\\';
            if end {
                out.push(d);
                break;
            }
            kept += 1;
            if kept <= max {
                out.push(d);
            } else if kept == max + 1 {
                out.push('…');
                changed = true;
            }
        }
    }
    if !changed {
        return clip(msg, MAX_MESSAGE_CHARS);
    }
    Cow::Owned(clip(&out, MAX_MESSAGE_CHARS).into_owned())
}

/// A plain-text excerpt for messages that carry no [`Excerpt`] (TOML recipes, `--set`
/// values): the line of byte offset `at` in `text`, clipped to [`EXCERPT_SIDE`]
/// characters either side of it, under a gutter with the line's number, and a caret
/// under the place. Returns the 1-based line and column (in characters) too.
pub fn caret_excerpt(text: &str, at: usize) -> (usize, usize, String) {
    let at = floor_char_boundary(text, at);
    let (line, col) = line_col(text, at);
    let start = text[..at].rfind('\n').map_or(0, |k| k + 1);
    let stop = text[at..].find('\n').map_or(text.len(), |k| at + k);
    let l = &text[start..stop];
    let n = l.chars().count();
    let a = (col - 1).saturating_sub(EXCERPT_SIDE).min(n.saturating_sub(2 * EXCERPT_SIDE + 1));
    let b = n.min(a + 2 * EXCERPT_SIDE + 1);
    let mut shown = String::new();
    if a > 0 {
        shown.push('…');
    }
    shown.extend(l.chars().skip(a).take(b - a).map(|c| if c.is_control() { ' ' } else { c }));
    if b < n {
        shown.push('…');
    }
    let caret = " ".repeat(usize::from(a > 0) + col - 1 - a);
    let num = line.to_string();
    let pad = " ".repeat(num.len());
    (line, col, format!("{pad} |\n{num} | {shown}\n{pad} | {caret}^"))
}
