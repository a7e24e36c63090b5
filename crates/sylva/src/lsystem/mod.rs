//! The L-system language of cpfg (vlab) and The Algorithmic Beauty of Plants.
//!
//! ```text
//!  .l text ─► source (preprocess: comments, #define) ─► parse (compile productions)
//!          ─► derive (parallel rewriting, module budget) ─► ModuleString
//!          ─► turtle (3D, ABOP conventions) ─► Skeleton
//! ```
//!
//! McLoughlin2021 §2 (D0L and parametric L-systems, the Honda tree family) and §4 (turtle
//! conventions). The language reference is `docs/lsystem.md`.

mod comments;
pub mod derive;
pub mod environment;
pub mod expr;
pub mod files;
pub mod parse;
pub mod preprocess;
pub mod source;
pub mod string;
pub mod turtle;

pub use derive::{DeriveOptions, ModuleString, DEFAULT_MODULE_BUDGET};
pub use expr::RandomGenerator;
pub use parse::{LSystem, Symbols};
pub use source::{ErrorKind, LsystemError};
pub use turtle::{interpret, interpret_with, TurtleOptions};
