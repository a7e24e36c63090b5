//! Located errors: what went wrong, where (file:line:column with an excerpt of the
//! text) and how to fix it. Plain data below every stage: the L-system language
//! (seed 001 §4.3, seed 002 §2), the LST and `.str` readers (seed 000 §4.1.5) and the
//! crate's [`crate::Error`] all carry these, so none of them depends on another for it.

use miette::{NamedSource, SourceSpan};
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
    /// The source of the file the error is in, for the excerpt.
    #[source_code]
    pub source_code: NamedSource<Arc<str>>,
    /// The offending span in that file.
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
