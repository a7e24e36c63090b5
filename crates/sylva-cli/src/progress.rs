//! Progress on the terminal: a bar over the session's stages ([`sylva::Session::on_progress`])
//! and the CLI's own steps (preview, writing), naming the step. It appears once the work
//! has taken a second, only when stderr is a terminal and `-q` is not given, and is
//! cleared when done, so the summary and pipes see no trace of it.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::Duration;
use sylva::{Session, Stage};

/// How long the work runs before the bar appears.
const DELAY: Duration = Duration::from_secs(1);

/// A progress bar over the pipeline's stages and `extra` later steps; a no-op when off.
pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar over the stages and `extra` steps of the CLI's own, or none when `quiet` or
    /// stderr is not a terminal.
    pub fn new(quiet: bool, extra: u64) -> Progress {
        if quiet || !std::io::stderr().is_terminal() {
            return Progress { bar: None };
        }
        let style = ProgressStyle::with_template("{spinner} {prefix} [{bar:24}] {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
        let bar = ProgressBar::with_draw_target(
            Some(Stage::ALL.len() as u64 + extra),
            ProgressDrawTarget::hidden(),
        )
        .with_style(style)
        .with_prefix("sylva");
        bar.enable_steady_tick(Duration::from_millis(120));
        let shown = bar.clone();
        std::thread::spawn(move || {
            std::thread::sleep(DELAY);
            if !shown.is_finished() {
                shown.set_draw_target(ProgressDrawTarget::stderr());
            }
        });
        Progress { bar: Some(bar) }
    }

    /// Drives the bar from `session`'s stages (`generate`, `fit`, `bark`, …).
    pub fn follow(&self, session: &mut Session) {
        if let Some(bar) = self.bar.clone() {
            session.on_progress(move |stage, fraction| {
                let at = Stage::ALL.iter().position(|&s| s == stage).unwrap_or(0) as u64;
                bar.set_position(at + u64::from(fraction >= 1.0));
                bar.set_message(stage.name());
            });
        }
    }

    /// Starts one of the CLI's own steps (`preview`, `write`), after the stages.
    pub fn step(&self, name: &'static str) {
        if let Some(bar) = &self.bar {
            bar.set_message(name);
        }
    }

    /// Ends a step started with [`Progress::step`].
    pub fn done_step(&self) {
        if let Some(bar) = &self.bar {
            bar.inc(1);
        }
    }

    /// Prints `line` on stderr (a warning), above the bar when it shows.
    pub fn println(&self, line: &str) {
        match &self.bar {
            Some(bar) => bar.suspend(|| eprintln!("{line}")),
            None => eprintln!("{line}"),
        }
    }

    /// Removes the bar (before the summary is printed).
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Progress {
    /// Clears the bar, also when an error ends the work early (before it is printed).
    fn drop(&mut self) {
        self.finish();
    }
}
