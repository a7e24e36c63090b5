//! The engine's errors as Python exceptions, and the boundary every engine call crosses.
//!
//! `SylvaError` is the base; `RecipeError` (an unknown key, a bad value, an unknown
//! preset, a TOML syntax error) and `LsystemError` (a parse or evaluation error in an
//! L-system) derive from it. Every raised instance carries `file`, `line` and `column`
//! (1-based; `None` where the error has no place): an L-system error's message starts
//! with `file:line:column:`, a TOML syntax error says `at line L, column C`.
//!
//! [`guard`] runs an engine call with panics caught, so a bug in the engine is a
//! `SylvaError` naming the panic rather than PyO3's `PanicException`.

use pyo3::exceptions::PyException;
use pyo3::prelude::*;

pyo3::create_exception!(
    sylva,
    SylvaError,
    PyException,
    "Any error sylva reports; `file`, `line` and `column` say where, when known (else None)."
);
pyo3::create_exception!(
    sylva,
    RecipeError,
    SylvaError,
    "A recipe problem: an unknown key or preset, a bad value, a TOML syntax error."
);
pyo3::create_exception!(
    sylva,
    LsystemError,
    SylvaError,
    "An L-system parse or evaluation error; `file`, `line` and `column` locate it."
);

/// Where an error is: file, 1-based line and column, each when known.
#[derive(Debug, Default, PartialEq)]
pub struct Place {
    /// The file name as the message gives it.
    pub file: Option<String>,
    /// The 1-based line.
    pub line: Option<u32>,
    /// The 1-based column.
    pub column: Option<u32>,
}

/// The place at the start of an L-system message, `file:line:column: what` (the file
/// name may itself hold colons: the last `:N:N:` before the first `: ` wins).
pub fn lsystem_place(message: &str) -> Place {
    let head = message.split(": ").next().unwrap_or("");
    let mut parts = head.rsplitn(3, ':');
    let (Some(col), Some(line), Some(file)) = (parts.next(), parts.next(), parts.next()) else {
        return Place::default();
    };
    match (line.trim().parse(), col.trim().parse()) {
        (Ok(line), Ok(column)) => {
            Place { file: Some(file.to_string()), line: Some(line), column: Some(column) }
        }
        _ => Place::default(),
    }
}

/// The place of a TOML syntax error (`… at line L, column C`), with `file` when the
/// message starts with a `.toml` file's name.
pub fn toml_place(message: &str) -> Place {
    let Some(at) = message.find("line ") else { return Place::default() };
    let rest = &message[at + 5..];
    let line: String = rest.chars().take_while(char::is_ascii_digit).collect();
    let Some(c) = rest.find("column ") else { return Place::default() };
    let column: String = rest[c + 7..].chars().take_while(char::is_ascii_digit).collect();
    let file = message
        .strip_prefix("recipe: ")
        .unwrap_or(message)
        .split(": ")
        .next()
        .filter(|f| f.ends_with(".toml") && f.len() < message.len())
        .map(str::to_string);
    match (line.parse(), column.parse()) {
        (Ok(line), Ok(column)) => Place { file, line: Some(line), column: Some(column) },
        _ => Place::default(),
    }
}

/// `err` with the place attributes set (every `SylvaError` has them, `None` if unknown).
fn with_place(py: Python<'_>, err: PyErr, place: Place) -> PyErr {
    let value = err.value(py);
    // Setting an attribute on a fresh exception instance does not fail.
    let _ = value.setattr("file", place.file);
    let _ = value.setattr("line", place.line);
    let _ = value.setattr("column", place.column);
    err
}

/// The Python exception of an engine error.
pub fn to_py(e: sylva::Error) -> PyErr {
    Python::attach(|py| match e {
        sylva::Error::Lsystem(l) => {
            let place = lsystem_place(&l.message);
            with_place(py, LsystemError::new_err(l.message.clone()), place)
        }
        sylva::Error::Recipe(_) => {
            let msg = e.to_string();
            let place = toml_place(&msg);
            with_place(py, RecipeError::new_err(msg), place)
        }
        e => with_place(py, SylvaError::new_err(e.to_string()), Place::default()),
    })
}

/// A `SylvaError` with `message` and no place.
pub fn sylva_error(message: impl Into<String>) -> PyErr {
    Python::attach(|py| with_place(py, SylvaError::new_err(message.into()), Place::default()))
}

/// A `RecipeError` with `message` and no place.
pub fn recipe_error(message: impl Into<String>) -> PyErr {
    Python::attach(|py| with_place(py, RecipeError::new_err(message.into()), Place::default()))
}

/// Runs the engine call `f` with panics caught: its error becomes the matching Python
/// exception, a panic a `SylvaError` that says it is a bug. Safe to call with the GIL
/// released (the exception is built after re-attaching).
pub fn guard<T>(f: impl FnOnce() -> sylva::Result<T>) -> PyResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(to_py(e)),
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic without a message".into());
            Err(sylva_error(format!(
                "internal error (a bug in sylva, please report it with the recipe): {what}"
            )))
        }
    }
}
