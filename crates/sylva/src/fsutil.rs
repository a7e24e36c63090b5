//! File output that never leaves a half-written file, a lost file or a stray temporary.
//!
//! - [`write_atomic`] writes one file: the bytes go to a temporary beside the target
//!   (`.NAME.tmp-PID-SEQ`), are flushed to the disk, and the temporary is renamed over
//!   the target only when everything succeeded.
//! - [`OutputSet`] does the same for every output of a run at once (a model, its `.mtl`,
//!   its texture PNGs or POV-Ray includes, a preview, a wind preview): each file is
//!   staged to its temporary first, and only when all of them are staged are they
//!   renamed into place, under a lock, so that the set changes as one or not at all
//!   (see [`OutputSet::commit`] for the order and the rollback).
//! - [`check_output`] checks a target before any work: its folder exists and can be
//!   written, and the target is not a folder or a special file.
//!
//! Temporaries are never left behind:
//!
//! - every live temporary is kept in a process-wide registry, and
//!   [`install_signal_cleanup`] (the `sylva` binary calls it first thing) makes SIGINT,
//!   SIGTERM and SIGHUP unlink them before the process dies of the signal; a signal that
//!   arrives while an output set is being renamed into place waits until the set is whole
//!   (or rolled back);
//! - a process killed outright (SIGKILL, a power cut) cannot clean up, so the next write
//!   to the same name does: a temporary `.NAME.tmp-PID…` whose process no longer exists
//!   (`kill(PID, 0)` fails with `ESRCH`) is removed when `NAME` is staged again. (Across
//!   PID namespaces, e.g. two containers writing one shared folder, a live writer of
//!   another namespace looks dead; its rename then fails with a clear error.)

use crate::error::{Error, Result};
use std::ffi::{CString, OsStr};
use std::io::Write;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicI32, AtomicIsize, AtomicPtr, AtomicU64, Ordering::SeqCst};

/// Writes the file at `path` through `fill`, atomically: the bytes go to a temporary
/// file in the same folder, which is renamed over `path` only when `fill` succeeded and
/// the data reached the disk. On any error the temporary file is removed; so is it when
/// the process is stopped by SIGINT, SIGTERM or SIGHUP once [`install_signal_cleanup`]
/// ran. Temporaries of `path` left by dead processes are removed first.
///
/// The target is checked with [`check_output`] first. For several files that belong
/// together use an [`OutputSet`].
pub fn write_atomic(path: &Path, fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<()> {
    check_output(path)?;
    let werr = |source| Error::Write { path: path.to_path_buf(), source };
    let temp = Temp::create(path, fill).map_err(werr)?;
    std::fs::rename(&temp.path, path).map_err(werr)?;
    temp.persisted();
    Ok(())
}

/// Checks, before any work, that `path` can be written as an output: it names a file
/// (not `dir/` or `..`), its folder exists, is a folder and is writable, and `path`
/// itself is not a folder or a special file (a device, a FIFO, a socket). The error is
/// [`Error::Write`] naming `path` and saying which of these failed. Whether the extension
/// is one the writer understands is the writer's check (e.g.
/// [`crate::export::Format::from_path`]).
pub fn check_output(path: &Path) -> Result<()> {
    let bad = |why: String| Error::Write { path: path.to_path_buf(), source: std::io::Error::other(why) };
    let name_ok = path.file_name().is_some() && !path.as_os_str().as_bytes().ends_with(b"/");
    if !name_ok {
        return Err(bad("the path names a folder, not a file".into()));
    }
    let dir = parent_or_dot(path);
    match std::fs::metadata(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(bad(format!("the folder {} does not exist", dir.display())))
        }
        Err(e) => return Err(bad(format!("the folder {} cannot be used: {e}", dir.display()))),
        Ok(m) if !m.is_dir() => return Err(bad(format!("{} is not a folder", dir.display()))),
        Ok(_) => {}
    }
    let cdir = CString::new(dir.as_os_str().as_bytes())
        .map_err(|_| bad("the path has a NUL byte in it".to_string()))?;
    // SAFETY: `cdir` is a valid NUL-terminated string.
    if unsafe { libc::access(cdir.as_ptr(), libc::W_OK | libc::X_OK) } != 0 {
        let e = std::io::Error::last_os_error();
        return Err(bad(format!("the folder {} is not writable: {e}", dir.display())));
    }
    if let Ok(m) = std::fs::metadata(path) {
        if m.is_dir() {
            return Err(bad("a folder of that name is in the way".into()));
        }
        if !m.is_file() {
            return Err(bad("it is a special file (a device, FIFO or socket), not a regular file".into()));
        }
    }
    Ok(())
}

/// Several output files written as one result.
///
/// Each file is [staged](OutputSet::stage) to a fsynced temporary beside its target
/// (`.NAME.tmp-PID-SEQ`, removed again on any failure, on drop, and on SIGINT / SIGTERM /
/// SIGHUP with [`install_signal_cleanup`]); [`commit`](OutputSet::commit) renames them all
/// into place, or — on failure — none of them, restoring what was there before. Dropping
/// a set without committing it removes its temporaries and leaves the targets as they
/// were.
///
/// ```no_run
/// use std::io::Write;
/// let mut set = sylva::fsutil::OutputSet::new("tree.obj");
/// set.stage("tree.mtl".as_ref(), |w| w.write_all(b"newmtl bark\n"))?;
/// set.stage("tree.obj".as_ref(), |w| w.write_all(b"mtllib tree.mtl\n"))?;
/// set.commit()?; // both files or neither
/// # Ok::<(), sylva::Error>(())
/// ```
#[derive(Debug)]
pub struct OutputSet {
    /// The main output: renamed last, and the name the lock is taken on.
    primary: PathBuf,
    /// Staged files, in staging order.
    staged: Vec<Staged>,
}

/// One staged file of an [`OutputSet`].
#[derive(Debug)]
struct Staged {
    /// Where it goes.
    target: PathBuf,
    /// The target with its folder made canonical, to find a file staged twice.
    key: PathBuf,
    /// Its temporary.
    temp: Temp,
}

impl OutputSet {
    /// An empty set whose main output is `primary`: the file that refers to the others
    /// (the model) or, for a set of equals, any one of them. Its name picks the lock
    /// ([`commit`](OutputSet::commit)); it need not be staged.
    pub fn new(primary: impl Into<PathBuf>) -> Self {
        OutputSet { primary: primary.into(), staged: Vec::new() }
    }

    /// The main output.
    pub fn primary(&self) -> &Path {
        &self.primary
    }

    /// The targets staged so far, in staging order.
    pub fn targets(&self) -> impl Iterator<Item = &Path> {
        self.staged.iter().map(|s| s.target.as_path())
    }

    /// Writes the future contents of `target` through `fill` to a temporary beside it and
    /// flushes it to the disk. The target is checked with [`check_output`] first; a target
    /// already staged in this set is an error (two outputs of one run would overwrite each
    /// other). On error nothing of this file is left, and the files staged before stay
    /// staged (drop the set to discard them).
    pub fn stage(
        &mut self,
        target: &Path,
        fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<()> {
        check_output(target)?;
        let werr = |source| Error::Write { path: target.to_path_buf(), source };
        let key = canonical_key(target).map_err(werr)?;
        if let Some(other) = self.staged.iter().find(|s| s.key == key) {
            return Err(werr(std::io::Error::other(format!(
                "this run writes it twice (also as {})",
                other.target.display()
            ))));
        }
        let temp = Temp::create(target, fill).map_err(werr)?;
        self.staged.push(Staged { target: target.to_path_buf(), key, temp });
        Ok(())
    }

    /// Renames every staged file over its target, as one result.
    ///
    /// 1. An exclusive lock is taken on `.NAME.lock` beside the primary output (`flock`;
    ///    removed again afterwards), so two runs writing the same name commit one after
    ///    the other and the files left are all of one run.
    /// 2. The files are renamed in staging order, **the primary output last**: the model
    ///    refers to its `.mtl`, textures and includes, never the other way round, so its
    ///    rename is the commit point. A process killed outright in the middle leaves the
    ///    old model (still complete, its side files replaced by same-named new ones)
    ///    rather than a new model pointing at files that are not there yet.
    /// 3. Before a target is replaced, the file there is kept as a backup (a hard link,
    ///    so the target never disappears; a move where links are not supported). If a
    ///    rename fails, the files already renamed are put back from their backups (or
    ///    removed, where there was none), so the previous set is left as it was, and the
    ///    error names the file that failed. On success the backups are removed and the
    ///    folders are synced.
    ///
    /// SIGINT / SIGTERM / SIGHUP arriving during these steps (waiting for the lock
    /// included) are held until they are done (with [`install_signal_cleanup`]), then end
    /// the process. Every temporary is gone when this returns.
    pub fn commit(mut self) -> Result<()> {
        if self.staged.is_empty() {
            return Ok(());
        }
        // Signals wait from before the lock file is made until it is removed again, so
        // that a signal never leaves the lock file or half a set behind.
        commit_begin();
        let result = Lock::acquire(&self.primary).and_then(|lock| {
            let renamed = self.rename_all();
            drop(lock);
            renamed
        });
        commit_end();
        result
    }

    /// Steps 2–3 of [`commit`](OutputSet::commit), under the lock.
    fn rename_all(&mut self) -> Result<()> {
        let primary = canonical_key(&self.primary).ok();
        let mut staged = std::mem::take(&mut self.staged);
        // The primary last; the others keep their staging order.
        staged.sort_by_key(|s| Some(&s.key) == primary.as_ref());
        let mut done: Vec<(PathBuf, Option<Backup>)> = Vec::with_capacity(staged.len());
        let mut failure = None;
        for s in staged {
            match replace(&s.target, &s.temp.path) {
                Ok(backup) => {
                    s.temp.persisted();
                    done.push((s.target, backup));
                }
                Err(e) => {
                    failure = Some(Error::Write { path: s.target.clone(), source: e });
                    break; // `s.temp` and the rest are dropped: their temporaries go.
                }
            }
        }
        if let Some(e) = failure {
            for (target, backup) in done.into_iter().rev() {
                match backup {
                    Some(b) => b.restore(&target),
                    None => {
                        let _ = std::fs::remove_file(&target);
                    }
                }
            }
            return Err(e);
        }
        let mut dirs: Vec<&Path> = done.iter().map(|(t, _)| parent_or_dot(t)).collect();
        dirs.sort();
        dirs.dedup();
        for d in dirs {
            if let Ok(f) = std::fs::File::open(d) {
                let _ = f.sync_all();
            }
        }
        for (_, backup) in done {
            if let Some(b) = backup {
                b.discard();
            }
        }
        Ok(())
    }
}

/// The previous file at a target, kept while an [`OutputSet`] commits.
struct Backup {
    /// Its temporary name.
    path: PathBuf,
    /// Its slot in the signal registry.
    slot: Option<Slot>,
    /// Whether the target was moved (not linked) to the backup.
    moved: bool,
}

impl Backup {
    /// Puts the previous file back at `target`.
    fn restore(self, target: &Path) {
        if std::fs::rename(&self.path, target).is_err() {
            let _ = std::fs::remove_file(&self.path);
        }
        unregister(self.slot);
    }

    /// Removes the backup: the new file is in place.
    fn discard(self) {
        let _ = std::fs::remove_file(&self.path);
        unregister(self.slot);
    }
}

/// Renames `temp` over `target`, keeping the file that was there as a [`Backup`].
fn replace(target: &Path, temp: &Path) -> std::io::Result<Option<Backup>> {
    let backup = match std::fs::symlink_metadata(target) {
        Ok(m) if m.is_dir() => {
            return Err(std::io::Error::other("a folder of that name is in the way"));
        }
        Ok(_) => {
            let path = temp_name(target, ".old");
            let slot = register(&path);
            let moved = match std::fs::hard_link(target, &path) {
                Ok(()) => false,
                Err(_) => match std::fs::rename(target, &path) {
                    Ok(()) => true,
                    Err(e) => {
                        unregister(slot);
                        return Err(e);
                    }
                },
            };
            Some(Backup { path, slot, moved })
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(e),
    };
    match std::fs::rename(temp, target) {
        Ok(()) => Ok(backup),
        Err(e) => {
            if let Some(b) = backup {
                if b.moved {
                    b.restore(target);
                } else {
                    b.discard();
                }
            }
            Err(e)
        }
    }
}

/// The exclusive lock of an output set: `flock` on `.NAME.lock` beside the primary.
struct Lock {
    /// The lock file.
    path: PathBuf,
    /// Holds the lock while open; closing it (after the name is removed) unlocks.
    _file: std::fs::File,
}

impl Lock {
    /// Waits for and takes the lock of `primary`.
    fn acquire(primary: &Path) -> Result<Lock> {
        use std::os::unix::fs::MetadataExt;
        use std::os::unix::io::AsRawFd;
        let mut name = std::ffi::OsString::from(".");
        name.push(short_name(primary));
        name.push(".lock");
        let path = primary.with_file_name(name);
        let werr = |source| Error::Write { path: path.clone(), source };
        loop {
            let file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(werr)?;
            loop {
                // SAFETY: a valid open descriptor.
                if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX) } == 0 {
                    break;
                }
                let e = std::io::Error::last_os_error();
                if e.kind() != std::io::ErrorKind::Interrupted {
                    return Err(werr(e));
                }
            }
            // The holder before us removes the file when it is done: a lock on a file
            // that is no longer at `path` locks nothing, so open it again.
            let held = file.metadata().map_err(werr)?;
            match std::fs::metadata(&path) {
                Ok(m) if m.dev() == held.dev() && m.ino() == held.ino() => {
                    return Ok(Lock { path, _file: file })
                }
                _ => continue,
            }
        }
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Remove the name while still holding the lock; waiters then see that their
        // file is gone and open a new one.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// A temporary file beside its target, registered for removal on a signal; removed on
/// drop unless [`persisted`](Temp::persisted).
#[derive(Debug)]
struct Temp {
    path: PathBuf,
    slot: Option<Slot>,
}

/// A file whose writes fail once this thread's cancellation token ([`crate::cancel`])
/// is set: a run stopped while it writes a large model (a time limit) stops within a
/// buffer's worth of bytes, and its temporary is removed.
struct Stoppable(std::fs::File);

impl Write for Stoppable {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if crate::cancel::cancelled() {
            return Err(std::io::Error::other("cancelled"));
        }
        self.0.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

impl Temp {
    /// Removes stale temporaries of `target`, then writes a new one through `fill` and
    /// flushes it to the disk.
    fn create(
        target: &Path,
        fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> std::io::Result<Temp> {
        clean_stale(target);
        let path = temp_name(target, "");
        let slot = register(&path);
        let temp = Temp { path, slot };
        let file = std::fs::OpenOptions::new().write(true).create_new(true).open(&temp.path)?;
        if STATE.load(SeqCst) < 0 {
            // The process is dying of a signal, which may have swept the registry before
            // this file existed.
            drop(temp);
            park_forever();
        }
        let mut w = std::io::BufWriter::with_capacity(1 << 20, Stoppable(file));
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?.0;
        file.sync_all()?;
        Ok(temp)
    }

    /// The temporary was renamed into place: forget it without removing anything.
    fn persisted(mut self) {
        unregister(self.slot.take());
        self.path = PathBuf::new();
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        if !self.path.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.path);
        }
        unregister(self.slot.take());
    }
}

/// The folder of `path` (`.` for a bare file name).
fn parent_or_dot(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// `path` with its folder made canonical, so two spellings of one file compare equal.
fn canonical_key(path: &Path) -> std::io::Result<PathBuf> {
    let dir = std::fs::canonicalize(parent_or_dot(path))?;
    Ok(dir.join(path.file_name().unwrap_or_default()))
}

/// The file name of `path`, cut to 200 bytes so that temporary names stay within the
/// 255-byte limit of file names.
fn short_name(path: &Path) -> &OsStr {
    let name = path.file_name().unwrap_or_default().as_bytes();
    OsStr::from_bytes(&name[..name.len().min(200)])
}

/// The prefix of every temporary of `target`: `.NAME.tmp-`.
fn temp_prefix(target: &Path) -> Vec<u8> {
    let mut p = b".".to_vec();
    p.extend_from_slice(short_name(target).as_bytes());
    p.extend_from_slice(b".tmp-");
    p
}

/// A fresh temporary name beside `target`: `.NAME.tmp-PID-SEQ<suffix>`.
fn temp_name(target: &Path, suffix: &str) -> PathBuf {
    static SEQ: AtomicU64 = AtomicU64::new(0);
    let mut name = temp_prefix(target);
    name.extend_from_slice(format!("{}-{}{suffix}", std::process::id(), SEQ.fetch_add(1, SeqCst)).as_bytes());
    target.with_file_name(OsStr::from_bytes(&name))
}

/// Removes the temporaries of `target` whose process is gone; a backup (`….old`) whose
/// target is missing (a commit killed between moving the old file aside and renaming
/// the new one in) is put back instead.
fn clean_stale(target: &Path) {
    let prefix = temp_prefix(target);
    let truncated = short_name(target).len() < target.file_name().map_or(0, |n| n.len());
    let Ok(entries) = std::fs::read_dir(parent_or_dot(target)) else { return };
    let own = std::process::id();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.as_bytes().strip_prefix(prefix.as_slice()) else { continue };
        let digits = rest.iter().take_while(|b| b.is_ascii_digit()).count();
        let Some(pid) = std::str::from_utf8(&rest[..digits]).ok().and_then(|d| d.parse::<u32>().ok()) else {
            continue;
        };
        if pid == own || pid == 0 || pid > i32::MAX as u32 || process_alive(pid) {
            continue;
        }
        let path = entry.path();
        if !std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file()) {
            continue;
        }
        let missing =
            matches!(std::fs::symlink_metadata(target), Err(e) if e.kind() == std::io::ErrorKind::NotFound);
        if rest.ends_with(b".old") && missing && !truncated && std::fs::rename(&path, target).is_ok() {
            continue;
        }
        let _ = std::fs::remove_file(&path);
    }
}

/// Whether a process `pid` exists (`kill(pid, 0)` does not fail with `ESRCH`).
fn process_alive(pid: u32) -> bool {
    // SAFETY: signal 0 only checks that the process exists.
    let r = unsafe { libc::kill(pid as libc::pid_t, 0) };
    r == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
}

// ---------------------------------------------------------------------------------
// Removal on a signal

/// How many temporaries the signal registry holds at once; more are still removed on
/// failure and by the next run, just not on a signal.
const SLOTS: usize = 1024;

/// The live temporaries, as NUL-terminated paths made before the files are created
/// (`CString::into_raw`). Whoever swaps a pointer out owns it: a normal unregistration
/// frees it, the signal handler unlinks it and never frees.
static REGISTRY: [AtomicPtr<libc::c_char>; SLOTS] = [const { AtomicPtr::new(std::ptr::null_mut()) }; SLOTS];

/// Commits in progress (≥ 0), or −1 once a signal is removing the temporaries and ending
/// the process.
static STATE: AtomicIsize = AtomicIsize::new(0);

/// The last cleanup signal received (0: none).
static PENDING: AtomicI32 = AtomicI32::new(0);

/// A registered path: its slot and the pointer put there.
#[derive(Debug)]
struct Slot {
    index: usize,
    ptr: usize,
}

/// Adds `path` to the registry (`None` when it is full or the path has a NUL byte).
fn register(path: &Path) -> Option<Slot> {
    let c = CString::new(path.as_os_str().as_bytes()).ok()?;
    let ptr = c.into_raw();
    for (index, slot) in REGISTRY.iter().enumerate() {
        if slot.compare_exchange(std::ptr::null_mut(), ptr, SeqCst, SeqCst).is_ok() {
            return Some(Slot { index, ptr: ptr as usize });
        }
    }
    // SAFETY: `ptr` came from `into_raw` above and was not published.
    drop(unsafe { CString::from_raw(ptr) });
    None
}

/// Takes `slot` out of the registry and frees its path, unless the signal handler took
/// it first.
fn unregister(slot: Option<Slot>) {
    let Some(Slot { index, ptr }) = slot else { return };
    let ptr = ptr as *mut libc::c_char;
    if REGISTRY[index].compare_exchange(ptr, std::ptr::null_mut(), SeqCst, SeqCst).is_ok() {
        // SAFETY: the pointer came from `CString::into_raw` in `register`, and this
        // thread took it out of the registry, so nobody else uses it.
        drop(unsafe { CString::from_raw(ptr) });
    }
}

/// Makes SIGINT, SIGTERM and SIGHUP remove this process's live temporaries (those of
/// [`write_atomic`] and [`OutputSet`]) before it dies of the signal. Safe to call more
/// than once; a signal whose disposition is "ignore" (e.g. SIGHUP under `nohup`) is left
/// ignored.
///
/// The handler is async-signal-safe: it swaps the pre-made paths out of a fixed table of
/// atomic pointers, `unlink`s them, restores the default action and raises the signal
/// again, so the process ends as the signal says (exit status included). While an
/// [`OutputSet`] is being committed the signal is held until the commit has finished or
/// rolled back. It replaces any handler the program had installed for these signals.
pub fn install_signal_cleanup() {
    for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        // SAFETY: plain sigaction calls with zeroed, then filled, structures.
        unsafe {
            let mut old: libc::sigaction = std::mem::zeroed();
            if libc::sigaction(sig, std::ptr::null(), &mut old) != 0 || old.sa_sigaction == libc::SIG_IGN {
                continue;
            }
            let mut act: libc::sigaction = std::mem::zeroed();
            act.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            libc::sigemptyset(&mut act.sa_mask);
            for other in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
                libc::sigaddset(&mut act.sa_mask, other);
            }
            act.sa_flags = libc::SA_RESTART;
            libc::sigaction(sig, &act, std::ptr::null_mut());
        }
    }
}

/// The signal handler of [`install_signal_cleanup`]: atomics, `unlink`, `signal` and
/// `raise` only.
extern "C" fn on_signal(sig: libc::c_int) {
    PENDING.store(sig, SeqCst);
    loop {
        let s = STATE.load(SeqCst);
        if s != 0 {
            // > 0: a commit is running, and the last one to end acts on PENDING;
            // < 0: another thread is already cleaning up and ending the process.
            return;
        }
        if STATE.compare_exchange(0, -1, SeqCst, SeqCst).is_ok() {
            remove_registered_and_die(sig);
            return;
        }
    }
}

/// Unlinks every registered temporary, restores the default action of `sig` and raises
/// it. Async-signal-safe. Called with `STATE` at −1.
fn remove_registered_and_die(sig: libc::c_int) {
    for slot in &REGISTRY {
        let p = slot.swap(std::ptr::null_mut(), SeqCst);
        if !p.is_null() {
            // SAFETY: a NUL-terminated path from `register`, owned by us after the swap.
            unsafe { libc::unlink(p) };
        }
    }
    // SAFETY: async-signal-safe calls; the process ends when the signal is delivered (at
    // once outside a handler, on return from it inside one).
    unsafe {
        libc::signal(sig, libc::SIG_DFL);
        libc::raise(sig);
    }
}

/// Marks a commit as running, so that a cleanup signal waits for it; waits forever if
/// the process is already dying of one.
fn commit_begin() {
    loop {
        let s = STATE.load(SeqCst);
        if s < 0 {
            park_forever();
        }
        if STATE.compare_exchange(s, s + 1, SeqCst, SeqCst).is_ok() {
            return;
        }
    }
}

/// Ends a commit; the last one to end acts on a signal that arrived meanwhile.
fn commit_end() {
    if STATE.fetch_sub(1, SeqCst) == 1 {
        let sig = PENDING.load(SeqCst);
        if sig != 0 && STATE.compare_exchange(0, -1, SeqCst, SeqCst).is_ok() {
            remove_registered_and_die(sig);
        }
    }
}

/// Blocks this thread for good (the process is about to end of a signal).
fn park_forever() -> ! {
    loop {
        std::thread::park();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tempdir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("sylva-fsutil-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn failed_fill_leaves_nothing() {
        let dir = tempdir("fill");
        let p = dir.join("out.txt");
        let r = write_atomic(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert!(!p.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        write_atomic(&p, |w| w.write_all(b"whole")).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "whole");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unwritable_folder_is_an_error() {
        let p = Path::new("/nonexistent-sylva-dir/x.glb");
        let e = write_atomic(p, |w| w.write_all(b"x")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent-sylva-dir/x.glb") && e.contains("does not exist"), "{e}");
    }

    #[test]
    fn check_output_refuses_folders_and_special_files() {
        let dir = tempdir("check");
        let e = check_output(&dir).unwrap_err().to_string();
        assert!(e.contains("folder of that name"), "{e}");
        let e = check_output(Path::new("/dev/null")).unwrap_err().to_string();
        assert!(e.contains("special file"), "{e}");
        let e = check_output(&dir.join("a.txt/b.png")).unwrap_err().to_string();
        assert!(e.contains("does not exist"), "{e}");
        std::fs::write(dir.join("f"), "x").unwrap();
        let e = check_output(&dir.join("f/b.png")).unwrap_err().to_string();
        assert!(e.contains("is not a folder"), "{e}");
        check_output(&dir.join("ok.png")).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn set_commits_all_and_replaces() {
        let dir = tempdir("set");
        let (a, b) = (dir.join("m.obj"), dir.join("m.mtl"));
        std::fs::write(&a, "old obj").unwrap();
        let mut set = OutputSet::new(&a);
        set.stage(&b, |w| w.write_all(b"new mtl")).unwrap();
        set.stage(&a, |w| w.write_all(b"new obj")).unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old obj");
        set.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new obj");
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "new mtl");
        assert_eq!(names(&dir), ["m.mtl", "m.obj"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn dropped_set_leaves_previous_files() {
        let dir = tempdir("drop");
        let a = dir.join("m.obj");
        std::fs::write(&a, "old").unwrap();
        let mut set = OutputSet::new(&a);
        set.stage(&a, |w| w.write_all(b"new")).unwrap();
        set.stage(&dir.join("m.mtl"), |w| w.write_all(b"new")).unwrap();
        let e = set.stage(&dir.join("x.png"), |_| Err(std::io::Error::other("disk full"))).unwrap_err();
        assert!(e.to_string().contains("disk full"));
        drop(set);
        assert_eq!(names(&dir), ["m.obj"]);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_staged_twice_is_refused() {
        let dir = tempdir("twice");
        let mut set = OutputSet::new(dir.join("a.png"));
        set.stage(&dir.join("a.png"), |w| w.write_all(b"1")).unwrap();
        let e = set.stage(&dir.join(".").join("a.png"), |w| w.write_all(b"2")).unwrap_err().to_string();
        assert!(e.contains("writes it twice"), "{e}");
        drop(set);
        assert!(names(&dir).is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failed_rename_rolls_back_the_files_already_renamed() {
        let dir = tempdir("rollback");
        let (model, side, new_side) = (dir.join("m.obj"), dir.join("m.mtl"), dir.join("m_0.png"));
        std::fs::write(&side, "old mtl").unwrap();
        let mut set = OutputSet::new(&model);
        set.stage(&side, |w| w.write_all(b"new mtl")).unwrap();
        set.stage(&new_side, |w| w.write_all(b"new png")).unwrap();
        set.stage(&model, |w| w.write_all(b"new obj")).unwrap();
        // The model's rename, last, fails: a folder appeared in its place.
        std::fs::create_dir(&model).unwrap();
        let e = set.commit().unwrap_err().to_string();
        assert!(e.contains("m.obj") && e.contains("folder"), "{e}");
        assert_eq!(std::fs::read_to_string(&side).unwrap(), "old mtl");
        assert_eq!(names(&dir), ["m.mtl", "m.obj"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed() {
        let dir = tempdir("stale");
        let p = dir.join("t.glb");
        // PID_MAX_LIMIT is 2^22 on Linux: this process never exists.
        let dead = 4_194_305u32;
        std::fs::write(dir.join(format!(".t.glb.tmp-{dead}")), "stale").unwrap();
        std::fs::write(dir.join(format!(".t.glb.tmp-{dead}-7")), "stale").unwrap();
        let own = format!(".t.glb.tmp-{}-99999", std::process::id());
        std::fs::write(dir.join(&own), "mine").unwrap();
        let live = ".t.glb.tmp-1-1"; // init is alive
        std::fs::write(dir.join(live), "live").unwrap();
        std::fs::write(dir.join(format!(".other.glb.tmp-{dead}")), "not ours").unwrap();
        write_atomic(&p, |w| w.write_all(b"x")).unwrap();
        let mut want = vec![own, live.to_string(), format!(".other.glb.tmp-{dead}"), "t.glb".to_string()];
        want.sort();
        assert_eq!(names(&dir), want);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_stale_backup_of_a_missing_target_is_restored() {
        let dir = tempdir("backup");
        let p = dir.join("t.glb");
        std::fs::write(dir.join(".t.glb.tmp-4194305-3.old"), "previous").unwrap();
        clean_stale(&p);
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "previous");
        assert_eq!(names(&dir), ["t.glb"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
