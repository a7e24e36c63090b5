//! Cancellation: a shared flag a front end sets to drop a stale computation, and the
//! checkpoints the long stages call between units of work.
//!
//! A [`Cancel`] token is cheap to clone and to check. The session installs its token on
//! the thread that runs the pipeline ([`scope`]); deep loops (derivation steps, meshing
//! axes, texture rows, refinement levels, LOD levels) call [`cancelled`] or [`check`]
//! without a token in their signature, and parallel loops capture [`current`] before
//! they fork. A stage that stops early returns a partial result the session never
//! keeps: it checks the token after every stage and returns
//! [`crate::Error::Cancelled`] (what [`Cancelled`] converts to). A [`Timer`] cancels a
//! token once a time limit has passed (the CLI's `--time-limit`, Python's `timeout=`).

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A cancellation flag shared between a front end and a running computation.
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A token not cancelled.
    pub fn new() -> Cancel {
        Cancel::default()
    }

    /// Asks the computation to stop at its next checkpoint. Safe from any thread.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Clears the request (the session does this when an update starts).
    pub fn reset(&self) {
        self.0.store(false, Ordering::Relaxed);
    }

    /// Whether [`Cancel::cancel`] was called since the last [`Cancel::reset`].
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once cancelled.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

/// A checkpoint found its token cancelled. It converts to [`crate::Error::Cancelled`],
/// so `cancel::check()?` works in any function returning the engine's result; this module
/// depends on nothing else, so every stage may call it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cancelled")]
pub struct Cancelled;

thread_local! {
    static CURRENT: RefCell<Option<Cancel>> = const { RefCell::new(None) };
}

/// Runs `f` with `token` installed as this thread's token (the previous one is restored
/// afterwards, also when `f` unwinds).
pub fn scope<R>(token: &Cancel, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Cancel>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let previous = self.0.take();
            CURRENT.with(|c| *c.borrow_mut() = previous);
        }
    }
    let _restore = Restore(CURRENT.with(|c| c.borrow_mut().replace(token.clone())));
    f()
}

/// [`scope`] with `token` when there is one, else `f` as it is (for work handed to
/// another thread with the token [`current`] gave).
pub fn scope_opt<R>(token: Option<&Cancel>, f: impl FnOnce() -> R) -> R {
    match token {
        Some(t) => scope(t, f),
        None => f(),
    }
}

/// This thread's token, for a parallel loop to capture before it forks.
pub fn current() -> Option<Cancel> {
    CURRENT.with(|c| c.borrow().clone())
}

/// Whether this thread's token (if any) is cancelled.
pub fn cancelled() -> bool {
    CURRENT.with(|c| c.borrow().as_ref().is_some_and(Cancel::is_cancelled))
}

/// `Err(Cancelled)` when this thread's token is cancelled.
pub fn check() -> Result<(), Cancelled> {
    if cancelled() {
        Err(Cancelled)
    } else {
        Ok(())
    }
}

/// A thread that cancels a token once a time limit has passed, unless stopped first.
/// [`Timer::stop`] (or dropping it) ends the thread at once.
///
/// ```
/// use sylva::cancel::{Cancel, Timer};
/// let token = Cancel::new();
/// let timer = Timer::start(&token, std::time::Duration::from_millis(10))?;
/// std::thread::sleep(std::time::Duration::from_millis(50));
/// assert!(token.is_cancelled() && timer.stop());
/// # Ok::<(), std::io::Error>(())
/// ```
#[derive(Debug)]
pub struct Timer {
    done: Option<std::sync::mpsc::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
    fired: Arc<AtomicBool>,
}

impl Timer {
    /// Starts the timer of `token`. Errors: the system cannot start a thread.
    pub fn start(token: &Cancel, limit: std::time::Duration) -> std::io::Result<Timer> {
        let (done, wait) = std::sync::mpsc::channel::<()>();
        let fired = Arc::new(AtomicBool::new(false));
        let thread = {
            let (token, fired) = (token.clone(), fired.clone());
            std::thread::Builder::new().name("sylva-time-limit".into()).spawn(move || {
                // Only the timeout fires it: `stop` closes the channel, which ends the wait.
                if let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = wait.recv_timeout(limit) {
                    fired.store(true, Ordering::SeqCst);
                    token.cancel();
                }
            })?
        };
        Ok(Timer { done: Some(done), thread: Some(thread), fired })
    }

    /// Stops the timer; whether it had fired (cancelled its token) before.
    pub fn stop(mut self) -> bool {
        self.end();
        self.fired.load(Ordering::SeqCst)
    }

    fn end(&mut self) {
        self.done.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Timer {
    fn drop(&mut self) {
        self.end();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_timer_stopped_in_time_never_fires() {
        let token = Cancel::new();
        let timer = Timer::start(&token, std::time::Duration::from_secs(60)).unwrap();
        let started = std::time::Instant::now();
        assert!(!timer.stop(), "stopped before its limit");
        assert!(!token.is_cancelled());
        assert!(started.elapsed() < std::time::Duration::from_secs(30), "stop waits for nothing");
    }

    #[test]
    fn the_scope_installs_and_restores_the_token() {
        let outer = Cancel::new();
        let inner = Cancel::new();
        inner.cancel();
        assert!(!cancelled());
        scope(&outer, || {
            assert!(!cancelled());
            scope(&inner, || assert_eq!(check(), Err(Cancelled)));
            assert!(check().is_ok());
            outer.cancel();
            assert!(cancelled() && current().is_some_and(|c| c.is_cancelled()));
        });
        assert!(current().is_none() && !cancelled());
        outer.reset();
        assert!(outer.check().is_ok());
    }
}
