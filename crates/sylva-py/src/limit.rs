//! `timeout=` of the calls that grow: a timer thread sets the engine's cancellation token
//! ([`sylva::cancel`]) once the seconds have passed; the run stops at its next
//! checkpoint and the call raises Python's `TimeoutError`. The recipe's work budgets bound
//! the work itself; this bounds the wall-clock time, as the CLI's `--time-limit` does.

use pyo3::exceptions::{PyRuntimeError, PyTimeoutError, PyValueError};
use pyo3::prelude::*;
use std::time::Duration;
use sylva::cancel::{Cancel, Timer};

/// `timeout` checked: `None`, or seconds in 0.001..=1,000,000 (`ValueError` otherwise).
pub fn seconds(timeout: Option<f64>) -> PyResult<Option<f64>> {
    match timeout {
        None => Ok(None),
        Some(t) if (0.001..=1e6).contains(&t) => Ok(Some(t)),
        Some(t) => {
            Err(PyValueError::new_err(format!("timeout={t}: use seconds in 0.001..=1000000, or None")))
        }
    }
}

/// Runs `f` with a token the timer sets after `timeout` seconds (`None`: never); `f`
/// installs it where the work runs ([`sylva::cancel::scope`]). A failure once the timer
/// fired is a `TimeoutError`; a result that was complete stays.
pub fn run<T>(timeout: Option<f64>, f: impl FnOnce(&Cancel) -> PyResult<T>) -> PyResult<T> {
    let token = Cancel::new();
    let Some(limit) = timeout else { return f(&token) };
    let timer = Timer::start(&token, Duration::from_secs_f64(limit)).map_err(|e| {
        PyRuntimeError::new_err(format!("timeout={limit}: cannot start its timer thread: {e}"))
    })?;
    let result = f(&token);
    let fired = timer.stop();
    match result {
        Err(_) if fired => {
            Err(PyTimeoutError::new_err(format!("growing passed timeout={limit} s and was stopped")))
        }
        r => r,
    }
}
