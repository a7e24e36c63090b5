//! The editor's frame log: how long each UI frame took, when a changed recipe was
//! submitted and when its tree was on screen, so the latency figures of docs/editor.md
//! (launch to first tree, change to visible tree, longest frame during a regeneration)
//! come from the editor itself. Written as JSON lines with `--frame-log FILE`.
//!
//! A tree is logged twice: "shown" when the code of the frame that drew it ends, and
//! "presented" when the next frame begins — after eframe has painted and presented the
//! frame that drew it (the editor asks for that next frame at once), so the second time
//! includes the software renderer's work on the frame and is what the user sees.

use std::path::Path;
use std::time::{Duration, Instant};

/// One entry.
#[derive(Debug, Clone, PartialEq)]
pub enum Entry {
    /// A UI frame and its duration.
    Frame {
        /// Since the editor started.
        at: Duration,
        /// How long the frame's code ran.
        took: Duration,
        /// Since the previous frame began (what the user sees: the frame's whole cost,
        /// painting included, or the idle wait between frames).
        gap: Duration,
        /// Whether a regeneration was running.
        busy: bool,
        /// The CPU time of the frame before this one as eframe measures it: the app's
        /// code, egui's layout and tessellation and the paint's submission (not what the
        /// GPU, or a software renderer's threads, spend after).
        previous_cpu: Option<Duration>,
    },
    /// A recipe was handed to the worker.
    Submitted {
        /// Since the editor started.
        at: Duration,
    },
    /// The frame that drew a tree was painted and presented: the next frame began.
    TreePresented {
        /// Since the editor started.
        at: Duration,
        /// Since the submission the tree answers.
        latency: Duration,
    },
    /// A grown tree reached the view: the code of the frame that drew it ended.
    TreeShown {
        /// Since the editor started.
        at: Duration,
        /// Since the last submission.
        latency: Duration,
        /// The worker's time for the run.
        grow: Duration,
        /// The run's stages and their times (the stages a change skipped are absent).
        stages: Vec<(&'static str, Duration)>,
    },
    /// Something named happened (an edit, a file reload).
    Event {
        /// Since the editor started.
        at: Duration,
        /// What.
        what: String,
        /// Which key or file.
        about: String,
        /// How long handling it took on the UI thread.
        took: Duration,
    },
}

/// The log.
#[derive(Debug, Clone)]
pub struct FrameLog {
    start: Instant,
    submitted: Option<Instant>,
    /// A tree taken from the worker whose frame has not ended yet: its run's time and stages.
    arrived: Option<(Duration, Vec<(&'static str, Duration)>)>,
    /// A tree shown whose frame has not been presented yet: the submission it answers.
    presenting: Option<Instant>,
    last_frame: Option<Instant>,
    entries: Vec<Entry>,
}

/// The most entries kept (older ones are dropped).
pub const MAX_ENTRIES: usize = 100_000;

impl Default for FrameLog {
    fn default() -> Self {
        FrameLog::new()
    }
}

impl FrameLog {
    /// An empty log starting now.
    pub fn new() -> FrameLog {
        FrameLog::starting_at(Instant::now())
    }

    /// An empty log whose times count from `start`.
    pub fn starting_at(start: Instant) -> FrameLog {
        FrameLog {
            start,
            submitted: None,
            arrived: None,
            presenting: None,
            last_frame: None,
            entries: Vec::new(),
        }
    }

    fn push(&mut self, e: Entry) {
        if self.entries.len() >= MAX_ENTRIES {
            self.entries.drain(..MAX_ENTRIES / 2);
        }
        self.entries.push(e);
    }

    /// A frame that began `took` ago ended now (a tree that [`FrameLog::tree_arrived`]
    /// during it counts as shown now).
    pub fn frame(&mut self, took: Duration) {
        self.frame_with_cpu(took, None);
    }

    /// [`FrameLog::frame`] with eframe's CPU time of the previous frame.
    pub fn frame_with_cpu(&mut self, took: Duration, previous_cpu: Option<Duration>) {
        if let Some((grow, stages)) = self.arrived.take() {
            let submitted = self.submitted.take();
            let latency = submitted.map_or(Duration::ZERO, |s| s.elapsed());
            self.presenting = submitted;
            self.push(Entry::TreeShown { at: self.start.elapsed(), latency, grow, stages });
        }
        let busy = self.submitted.is_some();
        let began = Instant::now() - took;
        let gap = self.last_frame.map_or(Duration::ZERO, |t| began.saturating_duration_since(t));
        self.last_frame = Some(began);
        self.push(Entry::Frame { at: self.start.elapsed(), took, gap, busy, previous_cpu });
    }

    /// A frame begins: the previous one has been painted and presented, so a tree it
    /// showed is logged as presented.
    pub fn frame_began(&mut self) {
        if let Some(submitted) = self.presenting.take() {
            self.push(Entry::TreePresented { at: self.start.elapsed(), latency: submitted.elapsed() });
        }
    }

    /// Whether a tree was shown by the last frame and is not yet logged as presented
    /// (the editor asks for the next frame at once then).
    pub fn awaiting_present(&self) -> bool {
        self.presenting.is_some()
    }

    /// A recipe was submitted now.
    pub fn mark_submitted(&mut self) {
        self.submitted = Some(Instant::now());
        self.push(Entry::Submitted { at: self.start.elapsed() });
    }

    /// A tree the worker grew in `grow` (`stages`: its run's stage times) reached the
    /// view during this frame; it is logged as shown when the frame ends.
    pub fn tree_arrived(&mut self, grow: Duration, stages: Vec<(&'static str, Duration)>) {
        self.arrived = Some((grow, stages));
    }

    /// A named event.
    pub fn event(&mut self, what: &str, about: &str, took: Duration) {
        self.push(Entry::Event { at: self.start.elapsed(), what: what.into(), about: about.into(), took });
    }

    /// Every entry, oldest first.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// Writes the log as JSON lines (milliseconds).
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let ms = |d: &Duration| d.as_secs_f64() * 1e3;
        let mut text = String::new();
        for e in &self.entries {
            let line = match e {
                Entry::Frame { at, took, gap, busy, previous_cpu } => format!(
                    r#"{{"frame":{:.3},"took_ms":{:.3},"gap_ms":{:.3},"busy":{busy},"previous_cpu_ms":{}}}"#,
                    ms(at),
                    ms(took),
                    ms(gap),
                    previous_cpu.map_or("null".to_string(), |c| format!("{:.3}", ms(&c)))
                ),
                Entry::Submitted { at } => format!(r#"{{"submitted":{:.3}}}"#, ms(at)),
                Entry::TreePresented { at, latency } => {
                    format!(r#"{{"tree_presented":{:.3},"latency_ms":{:.3}}}"#, ms(at), ms(latency))
                }
                Entry::TreeShown { at, latency, grow, stages } => {
                    let stages: Vec<String> =
                        stages.iter().map(|(n, t)| format!("{n:?}:{:.3}", ms(t))).collect();
                    format!(
                        r#"{{"tree_shown":{:.3},"latency_ms":{:.3},"grow_ms":{:.3},"stages_ms":{{{}}}}}"#,
                        ms(at),
                        ms(latency),
                        ms(grow),
                        stages.join(",")
                    )
                }
                Entry::Event { at, what, about, took } => format!(
                    r#"{{"event":{:?},"about":{:?},"at":{:.3},"took_ms":{:.3}}}"#,
                    what,
                    about,
                    ms(at),
                    ms(took)
                ),
            };
            text.push_str(&line);
            text.push('\n');
        }
        sylva::fsutil::write_atomic(path, |w| w.write_all(text.as_bytes())).map_err(std::io::Error::other)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tree is logged as shown when the frame that took it ends, and as presented when
    /// the next frame begins, both timed from the submission; nothing is presented twice.
    #[test]
    fn a_tree_is_shown_then_presented() {
        let mut log = FrameLog::new();
        log.mark_submitted();
        log.frame_began();
        log.frame(Duration::from_millis(1));
        assert!(!log.awaiting_present(), "no tree yet");
        std::thread::sleep(Duration::from_millis(5));
        log.frame_began();
        log.tree_arrived(Duration::from_millis(4), vec![("dress", Duration::from_millis(2))]);
        log.frame(Duration::from_millis(1));
        assert!(log.awaiting_present(), "shown, not yet presented");
        std::thread::sleep(Duration::from_millis(5));
        log.frame_began();
        assert!(!log.awaiting_present());
        log.frame(Duration::from_millis(1));
        log.frame_began();
        let shown: Vec<Duration> = log
            .entries()
            .iter()
            .filter_map(|e| match e {
                Entry::TreeShown { latency, .. } => Some(*latency),
                _ => None,
            })
            .collect();
        let presented: Vec<Duration> = log
            .entries()
            .iter()
            .filter_map(|e| match e {
                Entry::TreePresented { latency, .. } => Some(*latency),
                _ => None,
            })
            .collect();
        assert_eq!((shown.len(), presented.len()), (1, 1), "{:?}", log.entries());
        assert!(shown[0] >= Duration::from_millis(5), "{shown:?}");
        assert!(presented[0] >= shown[0] + Duration::from_millis(5), "{presented:?} after {shown:?}");
        let dir = std::env::temp_dir().join(format!("sylva-frame-log-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("frames.jsonl");
        log.write(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(text.lines().filter(|l| l.starts_with("{\"tree_presented\":")).count(), 1, "{text}");
    }
}
