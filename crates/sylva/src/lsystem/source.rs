//! A preprocessed L-system source and its error reporting with excerpts: the text
//! every later L-system stage reads (`parse`, `expr`, `derive`, `turtle`), with a map
//! from each of its bytes back to the file and byte it came from, so every error points
//! at the line and column the user wrote, in the right file. The preprocessor that
//! builds it is [`super::preprocess`]; MacMurchy2004 §4.3 (cpfg's files), McLoughlin2021 §2.

use std::collections::HashMap;
use std::sync::Arc;

pub use crate::diagnostic::{ErrorKind, LsystemError};

/// A macro definition.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Macro {
    /// Parameter names for function-like macros.
    pub(crate) params: Option<Vec<String>>,
    /// Replacement text.
    pub(crate) body: String,
}

/// A character with its origin: (file index << 32) | byte offset.
pub(crate) type Ch = (char, u64);

pub(crate) fn origin(file: usize, off: usize) -> u64 {
    ((file as u64) << 32) | off as u64
}

/// A preprocessed L-system source: text plus a byte map back to the original files.
#[derive(Debug, Clone)]
pub struct Source {
    /// Name of the main file, used in messages.
    pub name: String,
    /// The main file's original text.
    pub original: Arc<str>,
    /// The preprocessed text (comments blanked, macros expanded, continuations joined).
    pub text: String,
    /// For each byte of `text`, its origin (file index << 32 | byte offset).
    pub(crate) map: Vec<u64>,
    /// Every file read: (display name, text); index 0 is the main file.
    pub(crate) files: Vec<(String, Arc<str>)>,
    /// Object-like macros (name → replacement), for callers that want constants.
    pub defines: HashMap<String, String>,
    pub(crate) macros: HashMap<String, Macro>,
}

impl Source {
    fn locate(&self, at: usize) -> u64 {
        if self.map.is_empty() {
            return 0;
        }
        self.map[at.min(self.map.len() - 1)]
    }

    /// Original byte offset (in its own file) of a preprocessed offset.
    pub fn original_offset(&self, at: usize) -> usize {
        (self.locate(at) & 0xffff_ffff) as usize
    }

    /// 1-based line of a preprocessed offset, in the file it came from.
    pub fn line_of(&self, at: usize) -> usize {
        let o = self.locate(at);
        let (file, off) = ((o >> 32) as usize, (o & 0xffff_ffff) as usize);
        line_col(&self.files[file].1, off).0
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
        let o = self.locate(at);
        let end = if len > 0 { self.locate(at + len - 1) } else { o };
        let len = if end >> 32 == o >> 32 && end >= o { (end - o) as usize + 1 } else { 1 };
        self.error_origin(kind, o, len, what, label)
    }

    pub(crate) fn error_origin(
        &self,
        kind: ErrorKind,
        o: u64,
        len: usize,
        what: &str,
        label: &str,
    ) -> Box<LsystemError> {
        let (file, off) = ((o >> 32) as usize, (o & 0xffff_ffff) as usize);
        let (name, text) = &self.files[file.min(self.files.len() - 1)];
        LsystemError::located(kind, name, text, off, len, what, label)
    }

    /// An error at an ORIGINAL byte offset of the main file.
    pub fn error_at(
        &self,
        kind: ErrorKind,
        orig: usize,
        len: usize,
        what: &str,
        label: &str,
    ) -> Box<LsystemError> {
        self.error_origin(kind, origin(0, orig), len, what, label)
    }

    /// An error with no particular place in the file.
    pub fn error_nowhere(&self, kind: ErrorKind, what: &str) -> Box<LsystemError> {
        LsystemError::nowhere(kind, &self.name, what)
    }
}

use crate::diagnostic::line_col;
