//! `--watch`: the recipe file and the files it names in its folder (an `.l` model and
//! its `.v`, `.s` and `.func` files) are watched with `notify`; a change, once the file
//! has been quiet for a moment, reloads the document. A file that vanishes or does not
//! parse keeps the last good tree and says why.

use notify::{RecursiveMode, Watcher};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

/// How long a file must be quiet before it is read again (editors write in steps).
pub const QUIET: Duration = Duration::from_millis(120);

/// A watch on a recipe's folder.
pub struct Watch {
    _watcher: notify::RecommendedWatcher,
    events: Receiver<notify::Result<notify::Event>>,
    pending: Option<Instant>,
    file: PathBuf,
}

impl Watch {
    /// Watches `file` and the folder it resolves names in (`folder`, else the file's).
    pub fn new(file: &Path, folder: Option<&Path>) -> Result<Watch, String> {
        let (send, events) = channel();
        let mut watcher = notify::recommended_watcher(move |e| {
            let _ = send.send(e);
        })
        .map_err(|e| format!("cannot watch {}: {e}", file.display()))?;
        let dir = folder
            .map(Path::to_path_buf)
            .or_else(|| file.parent().map(Path::to_path_buf))
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or_else(|| PathBuf::from("."));
        watcher
            .watch(&dir, RecursiveMode::NonRecursive)
            .map_err(|e| format!("cannot watch {}: {e}", dir.display()))?;
        Ok(Watch { _watcher: watcher, events, pending: None, file: file.to_path_buf() })
    }

    /// Whether the watched files changed and have been quiet for [`QUIET`] since.
    pub fn changed(&mut self) -> bool {
        while let Ok(e) = self.events.try_recv() {
            let Ok(e) = e else { continue };
            if matches!(e.kind, notify::EventKind::Access(_)) {
                continue;
            }
            self.pending = Some(Instant::now());
        }
        if self.pending.is_some_and(|t| t.elapsed() >= QUIET) {
            self.pending = None;
            return true;
        }
        false
    }

    /// The watched recipe file.
    pub fn file(&self) -> &Path {
        &self.file
    }
}
