//! Skeleton and module-string import: LST skeletons and CPFG turtle strings; glTF meshes
//! read back for checking ([`gltf_read`]).
//!
//! ```text
//!  .lst text ──► lst::parse ──────────────► Skeleton          (Pieterse2012 §4.1.5–4.1.6)
//!  .skel.json ─► skel_json::from_json ─────► Skeleton          (sylva's own format)
//!  .str text ──► cpfg_str::parse ─► (Symbols, ModuleString) ─► lsystem::interpret ─► Skeleton
//!                                                              (MacMurchy2004 §4.3, §A.4)
//! ```
//!
//! - [`lst`]: the LST skeleton format of Pieterse2012 (Table 4.2: `SB`, `EB`, `MovRel3f`,
//!   `RotRel3f`, `Cylinder`), with every convention the seed leaves open stated in the
//!   module docs and in `docs/formats.md`;
//! - [`skel_json`]: sylva's JSON skeleton, the exact round trip of every field;
//! - [`cpfg_str`]: cpfg's text string files (`.str`), a derived module string written
//!   out as text, read with the module-name rules of the L-system parser;
//! - [`load_skeleton`]: reads a skeleton file, choosing the format from its extension.
//!
//! Parse errors are [`LsystemError`]s: `file:line:column: what`, with a caret excerpt.
//! Nothing here panics or allocates more than a constant factor of its input.

pub mod cpfg_str;
pub mod gltf_read;
pub mod lst;
pub mod obj;
pub mod skel_json;

use crate::error::{Error, Result};
use crate::lsystem::source::{ErrorKind, LsystemError};
use crate::skeleton::Skeleton;
use std::path::Path;

/// The skeleton file extensions [`load_skeleton`] understands, for error messages.
pub const SKELETON_EXTENSIONS: &str = ".lst, .skel.json (any .json)";

/// Reads a skeleton file, choosing the format from the extension (case-insensitive):
/// `.lst` is an LST file read with the default [`lst::LstOptions`] (lenient gap policy),
/// `.json` (conventionally `.skel.json`) is sylva's JSON skeleton
/// ([`skel_json::from_json`]). Anything else is [`Error::UnknownFormat`].
///
/// Errors name the file: LST and JSON syntax errors carry `file:line:column` and an
/// excerpt; a skeleton that breaks an invariant is [`Error::Skeleton`].
pub fn load_skeleton(path: &Path) -> Result<Skeleton> {
    load_skeleton_with(path, &lst::LstOptions::default())
}

/// Like [`load_skeleton`], with explicit options for `.lst` files (their node budget,
/// [`lst::LstOptions::max_nodes`], bounds JSON skeletons too).
pub fn load_skeleton_with(path: &Path, opts: &lst::LstOptions) -> Result<Skeleton> {
    load_skeleton_limited(path, opts, crate::input::DEFAULT_MAX_BYTES)
}

/// Like [`load_skeleton_with`], reading at most `max_bytes` (the recipe's
/// `input.max_bytes`) from a regular file ([`crate::input::read_input`]).
pub fn load_skeleton_limited(path: &Path, opts: &lst::LstOptions, max_bytes: u64) -> Result<Skeleton> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if !matches!(ext.as_str(), "lst" | "json") {
        return Err(Error::UnknownFormat { path: path.to_path_buf(), expected: SKELETON_EXTENSIONS });
    }
    let text = crate::input::read_input_to_string(path, max_bytes)?;
    parse_skeleton(&path.display().to_string(), &text, opts)
}

/// A skeleton from the text of a file called `name` (`.lst` or sylva `.json`, by the
/// extension of `name`), as [`load_skeleton_with`] reads it from disk; for files held in
/// memory.
pub fn parse_skeleton(name: &str, text: &str, opts: &lst::LstOptions) -> Result<Skeleton> {
    let ext = Path::new(name).extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    match ext.as_str() {
        "lst" => Ok(lst::parse(name, text, opts)?),
        "json" => skel_json::from_json_budget(name, text, opts.max_nodes),
        _ => Err(Error::UnknownFormat { path: name.into(), expected: SKELETON_EXTENSIONS }),
    }
}

/// A located error in `text` (the original file) at byte offset `at`, `len` bytes long:
/// `name:line:column: what` with a caret excerpt, exactly as the L-system parser's
/// errors ([`Source::error_at`](crate::lsystem::source::Source::error_at)).
///
/// The error is built directly rather than through a `Source`, which would run the
/// cpfg preprocessor over the text (LST and `.str` files are not C: a `.str` line may
/// start with the module `#`). It is built only on the error path and keeps only a
/// clipped window of the text ([`LsystemError::located`]).
pub(crate) fn located(
    name: &str,
    text: &str,
    kind: ErrorKind,
    at: usize,
    len: usize,
    what: &str,
    label: &str,
) -> Box<LsystemError> {
    LsystemError::located(kind, name, text, at, len.max(1), what, label)
}

/// An error with no place in the file: `name: what`.
pub(crate) fn nowhere(name: &str, _text: &str, kind: ErrorKind, what: &str) -> Box<LsystemError> {
    LsystemError::nowhere(kind, name, what)
}

/// Why a token is not a usable number.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum NumberError {
    /// Not a decimal number at all.
    Syntax,
    /// `nan`, `inf`, or a literal too large for `f64`.
    NonFinite,
}

impl NumberError {
    /// The error kind and the label under the token: `not finite` or `not a number`.
    pub(crate) fn kind_label(&self) -> (ErrorKind, &'static str) {
        match self {
            NumberError::NonFinite => (ErrorKind::NonFinite, "not finite"),
            NumberError::Syntax => (ErrorKind::Syntax, "not a number"),
        }
    }
}

/// Parses a decimal literal: `[+-]` digits with an optional fraction and exponent
/// (`1`, `-0.5`, `.5`, `5.`, `1e+06`, `2.5E-3`). `nan`/`inf` and overflowing literals
/// are [`NumberError::NonFinite`]; anything else that is not such a literal is
/// [`NumberError::Syntax`].
pub(crate) fn parse_number(tok: &str) -> std::result::Result<f64, NumberError> {
    let b = tok.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let unsigned = &tok[i..];
    if ["nan", "inf", "infinity"].iter().any(|w| unsigned.eq_ignore_ascii_case(w)) {
        return Err(NumberError::NonFinite);
    }
    let int_start = i;
    while i < b.len() && b[i].is_ascii_digit() {
        i += 1;
    }
    let mut digits = i - int_start;
    if i < b.len() && b[i] == b'.' {
        i += 1;
        let frac_start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        digits += i - frac_start;
    }
    if digits == 0 {
        return Err(NumberError::Syntax);
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        i += 1;
        if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
            i += 1;
        }
        let exp_start = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i == exp_start {
            return Err(NumberError::Syntax);
        }
    }
    if i != b.len() {
        return Err(NumberError::Syntax);
    }
    match tok.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(NumberError::NonFinite),
        Err(_) => Err(NumberError::Syntax),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers() {
        for (t, v) in [("1", 1.0), ("-0.5", -0.5), (".5", 0.5), ("5.", 5.0), ("1e+06", 1e6), ("+2E-3", 2e-3)]
        {
            assert_eq!(parse_number(t), Ok(v), "{t}");
        }
        for t in ["", "-", ".", "e5", "1e", "1x", "0x10", "1,2", "--1", "1e+"] {
            assert_eq!(parse_number(t), Err(NumberError::Syntax), "{t}");
        }
        for t in ["nan", "NaN", "-inf", "Infinity", "1e999", "-1e400"] {
            assert_eq!(parse_number(t), Err(NumberError::NonFinite), "{t}");
        }
    }

    #[test]
    fn located_errors_point_at_line_and_column() {
        let text = "LST 0.1\n  Foo()\n";
        let e = located("t.lst", text, ErrorKind::Syntax, 10, 3, "bad", "here");
        assert!(e.message.starts_with("t.lst:2:3: bad"), "{}", e.message);
        // Offsets inside a multi-byte character or past the end do not panic.
        let e = located("t.lst", "é", ErrorKind::Syntax, 1, 1, "x", "y");
        assert!(e.message.starts_with("t.lst:1:1"), "{}", e.message);
        let e = located("t.lst", "ab", ErrorKind::Syntax, 99, 1, "x", "y");
        assert!(e.message.starts_with("t.lst:1:3"), "{}", e.message);
    }
}
