//! The engine's error type: every failure says what failed, where and why.

use std::path::PathBuf;

/// Any error the engine reports.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum Error {
    /// A file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The output format could not be chosen from the file name.
    #[error("cannot tell the format of {} from its extension: use one of {expected}", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// The extensions that are understood.
        expected: &'static str,
    },
    /// Geometry that would put a NaN, an infinity or a bad index into a file.
    #[error("invalid geometry in {what}: {why}")]
    InvalidGeometry {
        /// Which part or stage.
        what: String,
        /// What is wrong.
        why: String,
    },
    /// A recipe problem (unknown key, bad value, unknown preset). Its display clips every
    /// quoted piece of the message (a `--set` value quoted whole by one of the many
    /// checks) to [`crate::diagnostic::MAX_QUOTED_CHARS`] characters.
    #[error("recipe: {}", crate::diagnostic::clip_quoted_to(.0, crate::diagnostic::MAX_QUOTED_CHARS))]
    #[diagnostic(help("run `sylva presets` for preset names; docs/recipe.md lists every key"))]
    Recipe(String),
    /// An L-system parse or evaluation error, with its source excerpt.
    #[error(transparent)]
    #[diagnostic(transparent)]
    Lsystem(#[from] Box<crate::diagnostic::LsystemError>),
    /// A mesh that cannot be subdivided (a cancelled subdivision converts to
    /// [`Error::Cancelled`] instead).
    #[error(transparent)]
    #[diagnostic(transparent)]
    Refine(crate::refine::RefineError),
    /// An invalid skeleton.
    #[error("invalid skeleton: {0}")]
    Skeleton(#[from] crate::skeleton::SkeletonError),
    /// The computation was cancelled through its [`crate::cancel::Cancel`] token (a
    /// front end dropped a stale regeneration); nothing it made is kept.
    #[error("cancelled")]
    Cancelled,
}

impl From<crate::refine::RefineError> for Error {
    fn from(e: crate::refine::RefineError) -> Error {
        match e {
            crate::refine::RefineError::Cancelled { .. } => Error::Cancelled,
            e => Error::Refine(e),
        }
    }
}

impl From<crate::cancel::Cancelled> for Error {
    fn from(_: crate::cancel::Cancelled) -> Error {
        Error::Cancelled
    }
}

/// The engine's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
