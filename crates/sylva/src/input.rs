//! Reading input files (issue 39, items 9 and 14): every file sylva reads goes through
//! [`read_input`] (or [`read_input_to_string`]), which
//!
//! - opens the file without blocking (a FIFO with no writer would otherwise block the
//!   `open` itself) and checks the *opened* handle's type, so a name swapped between a
//!   check and the open cannot slip a device through: anything but a regular file (a
//!   character device such as `/dev/zero` or `/dev/urandom`, a FIFO, a socket, a
//!   directory) is refused with "not a regular file";
//! - refuses a file larger than the input limit before reading a byte, and reads at most
//!   one byte more than the limit, so a file that grows underneath cannot exceed it
//!   either. The limit is the recipe key `input.max_bytes` ([`MAX_BYTES_KEY`], default
//!   [`DEFAULT_MAX_BYTES`] = 1 GiB: the largest real inputs are LST and glTF exports of
//!   scanned trees, a few hundred MB; the models of the cpfg corpus are a few KB).
//!
//! sylva has no standard-input mode: a run's input kind comes from the file's extension
//! and a cpfg model's side files from its folder, neither of which `-` has, so `-` is
//! read as a file name like any other.
//!
//! [`SideFiles`] confines what a cpfg model folder can make sylva read: the files its
//! `specifications`, view, environment and L-system files name must resolve inside the
//! model folder (symbolic links included) or inside a folder the recipe's
//! `generator.allow_paths` ([`ALLOW_PATHS_KEY`]) lists. [`excerpt`] clips what messages
//! quote of such files.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// The default input limit: 1 GiB per file.
pub const DEFAULT_MAX_BYTES: u64 = 1 << 30;

/// The recipe key of the input limit.
pub const MAX_BYTES_KEY: &str = "input.max_bytes";

/// The recipe key that lets a model folder's files name files in other folders.
pub const ALLOW_PATHS_KEY: &str = "generator.allow_paths";

/// The most characters a message quotes of a file the user did not name.
pub const MAX_EXCERPT: usize = 60;

/// Why sylva refused to read a file (the inner error of an [`Error::Read`]): not a
/// regular file, over the input limit, or outside the model folder. [`is_refusal`]
/// tells it apart from an ordinary I/O error.
#[derive(Debug)]
pub struct Refused(pub String);

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Refused {}

fn refused(path: &Path, kind: std::io::ErrorKind, why: String) -> Error {
    Error::Read { path: path.to_path_buf(), source: std::io::Error::new(kind, Refused(why)) }
}

/// `true` when `e` is a file sylva refused to read ([`Refused`]) rather than one that
/// could not be read: such errors stop a run even where a missing optional file
/// would only be a warning.
pub fn is_refusal(e: &Error) -> bool {
    match e {
        Error::Read { source, .. } => source.get_ref().is_some_and(|inner| inner.is::<Refused>()),
        _ => false,
    }
}

/// What kind of file `ft` is, in words.
fn kind_of(ft: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_char_device() {
            return "a character device";
        }
        if ft.is_block_device() {
            return "a block device";
        }
        if ft.is_fifo() {
            return "a FIFO";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    if ft.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

/// Opens `path` for reading without blocking on a FIFO.
fn open(path: &Path) -> std::io::Result<std::fs::File> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK);
    }
    o.open(path)
}

/// The message of a file over the limit.
fn too_large(path: &Path, what: &str, limit: u64) -> Error {
    refused(
        path,
        std::io::ErrorKind::InvalidData,
        format!(
            "{what}, more than the input limit of {limit} bytes (`{MAX_BYTES_KEY}`; raise it with \
             --set {MAX_BYTES_KEY}=N)"
        ),
    )
}

/// Reads the whole regular file at `path`, at most `limit` bytes.
///
/// Errors ([`Error::Read`], naming the file): it cannot be opened or read; it is not a
/// regular file (a device, FIFO, socket or directory; symbolic links are followed to
/// what they name); it holds more than `limit` bytes (the message names the size, the
/// limit and [`MAX_BYTES_KEY`]), checked before reading and again while reading.
pub fn read_input(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let io = |source| Error::Read { path: path.to_path_buf(), source };
    let file = open(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    let ft = meta.file_type();
    if !ft.is_file() {
        return Err(refused(
            path,
            std::io::ErrorKind::InvalidInput,
            format!("not a regular file ({}); sylva reads inputs only from regular files", kind_of(&ft)),
        ));
    }
    let len = meta.len();
    if len > limit {
        return Err(too_large(path, &format!("the file holds {len} bytes"), limit));
    }
    let mut bytes = Vec::new();
    bytes.try_reserve_exact(len as usize).map_err(|_| {
        refused(path, std::io::ErrorKind::OutOfMemory, format!("cannot allocate {len} bytes to read it"))
    })?;
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(path, "the file grew while it was read", limit));
    }
    Ok(bytes)
}

/// [`read_input`] for a text file: invalid UTF-8 is an error naming the file, as
/// [`std::fs::read_to_string`] makes it.
pub fn read_input_to_string(path: &Path, limit: u64) -> Result<String> {
    let bytes = read_input(path, limit)?;
    String::from_utf8(bytes).map_err(|_| Error::Read {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, "stream did not contain valid UTF-8"),
    })
}

/// [`read_input`] for a text file whose invalid UTF-8 (Latin-1 comments in old model
/// files) is replaced rather than an error.
pub fn read_input_lossy(path: &Path, limit: u64) -> Result<String> {
    let bytes = read_input(path, limit)?;
    Ok(match String::from_utf8(bytes) {
        Ok(s) => s,
        Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
    })
}

/// At most [`MAX_EXCERPT`] characters of `s` for a message: control characters
/// (newlines, escapes) become `?`, and a longer text ends in `…`.
pub fn excerpt(s: &str) -> String {
    let mut out: String = s.chars().take(MAX_EXCERPT).map(|c| if c.is_control() { '?' } else { c }).collect();
    if s.chars().nth(MAX_EXCERPT).is_some() {
        out.push('…');
    }
    out
}

/// `path` made absolute (against the current folder) with `.` and `..` removed
/// lexically.
fn lexical(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// Where `path` really is: its deepest existing ancestor resolved by the system
/// (symbolic links and `..` as the system follows them), then the rest, which does not
/// exist, lexically.
fn physical(path: &Path) -> PathBuf {
    let mut rest: Vec<std::ffi::OsString> = Vec::new();
    let mut at = path.to_path_buf();
    loop {
        if let Ok(c) = std::fs::canonicalize(&at) {
            let mut p = c;
            for r in rest.iter().rev() {
                p.push(r);
            }
            return lexical(&p);
        }
        match (at.file_name().map(|n| n.to_os_string()), at.parent()) {
            (Some(name), Some(parent)) => {
                rest.push(name);
                at = if parent.as_os_str().is_empty() { PathBuf::from(".") } else { parent.to_path_buf() };
            }
            // `..` or a root that does not resolve: judge the path lexically.
            _ => return lexical(path),
        }
    }
}

/// The files a cpfg model folder may make sylva read: those inside the folder, or
/// inside one of the folders the recipe allows ([`ALLOW_PATHS_KEY`]); each at most
/// `max_bytes` long. Paths resolve as the system resolves them, symbolic links
/// included, so a link inside the folder that points outside it is outside.
#[derive(Debug, Clone)]
pub struct SideFiles {
    dir: PathBuf,
    /// The folder and the allowed ones, as written (made absolute) and resolved.
    roots: Vec<PathBuf>,
    allowed: Vec<PathBuf>,
    max_bytes: u64,
}

impl SideFiles {
    /// Side files of the model folder `dir`, with the extra folders `allow` (absolute,
    /// or relative to the current folder) and the input limit `max_bytes`.
    /// An empty `dir` is the current folder (names then join as written).
    pub fn new(dir: &Path, allow: &[PathBuf], max_bytes: u64) -> SideFiles {
        let here = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
        let mut roots = vec![physical(here)];
        roots.extend(allow.iter().map(|a| physical(a)));
        SideFiles { dir: dir.to_path_buf(), roots, allowed: allow.to_vec(), max_bytes }
    }

    /// The model folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The input limit.
    pub fn max_bytes(&self) -> u64 {
        self.max_bytes
    }

    /// The path of `entry` (a file name as a model file writes it: relative to the
    /// folder, or absolute), after checking that it is inside the model folder or an
    /// allowed one. `what` says where the entry was written (`plant.v:3: \`function:\``)
    /// for the refusal, which names it, the resolved path and [`ALLOW_PATHS_KEY`]. The
    /// file need not exist (callers report missing optional files themselves).
    pub fn resolve(&self, entry: &str, what: &str) -> Result<PathBuf> {
        let path = self.dir.join(entry);
        let real = physical(&path);
        if self.roots.iter().any(|r| real.starts_with(r)) {
            return Ok(path);
        }
        let suggest = real.parent().map(|p| p.display().to_string()).unwrap_or_else(|| "/".into());
        let allowed = if self.allowed.is_empty() {
            String::new()
        } else {
            format!(
                " or the allowed {}",
                self.allowed.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
            )
        };
        Err(refused(
            &real,
            std::io::ErrorKind::PermissionDenied,
            format!(
                "{what} names `{}`, which resolves to {}, outside the model folder {}{allowed}: a model \
                 folder's files may name only files inside it (allow another folder with --set \
                 {ALLOW_PATHS_KEY}='[\"{}\"]', or in the recipe)",
                excerpt(entry),
                real.display(),
                self.roots[0].display(),
                suggest.replace('\\', "\\\\").replace('"', "\\\"")
            ),
        ))
    }

    /// Reads the file at `path` (a path [`SideFiles::resolve`] returned, or a file of
    /// the folder's own listing, which is checked here) within the input limit.
    pub fn read(&self, path: &Path, what: &str) -> Result<Vec<u8>> {
        let rel = path.strip_prefix(&self.dir).unwrap_or(path);
        let checked = self.resolve(&rel.to_string_lossy(), what)?;
        read_input(&checked, self.max_bytes)
    }

    /// [`SideFiles::read`] as text, invalid UTF-8 replaced.
    pub fn read_text(&self, path: &Path, what: &str) -> Result<String> {
        let bytes = self.read(path, what)?;
        Ok(match String::from_utf8(bytes) {
            Ok(s) => s,
            Err(e) => String::from_utf8_lossy(e.as_bytes()).into_owned(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("sylva-input-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn regular_files_within_the_limit_only() {
        let d = temp("limit");
        let f = d.join("a.txt");
        std::fs::write(&f, "hello").unwrap();
        assert_eq!(read_input(&f, 5).unwrap(), b"hello");
        let e = read_input(&f, 4).unwrap_err();
        assert!(is_refusal(&e));
        let m = e.to_string();
        assert!(m.contains("a.txt") && m.contains("5 bytes") && m.contains(MAX_BYTES_KEY), "{m}");
        let e = read_input(&d, 100).unwrap_err().to_string();
        assert!(e.contains("not a regular file (a directory)"), "{e}");
        #[cfg(unix)]
        {
            let e = read_input(Path::new("/dev/zero"), 100).unwrap_err();
            assert!(is_refusal(&e) && e.to_string().contains("character device"), "{e}");
        }
        let e = read_input(&d.join("none"), 100).unwrap_err();
        assert!(!is_refusal(&e));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn excerpts_are_short_and_plain() {
        assert_eq!(excerpt("ab\ncd"), "ab?cd");
        let long = "x".repeat(500);
        assert_eq!(excerpt(&long).chars().count(), MAX_EXCERPT + 1);
    }

    #[test]
    fn side_files_stay_in_their_folder() {
        let d = temp("side");
        let m = d.join("model");
        std::fs::create_dir_all(m.join("sub")).unwrap();
        std::fs::write(d.join("secret"), "s").unwrap();
        std::fs::write(m.join("a.v"), "v").unwrap();
        let s = SideFiles::new(&m, &[], 100);
        assert!(s.resolve("a.v", "x").is_ok());
        assert!(s.resolve("sub/../a.v", "x").is_ok());
        assert!(s.resolve("missing.v", "x").is_ok());
        for bad in ["../secret", "sub/../../secret", d.join("secret").to_str().unwrap(), "/etc/passwd"] {
            let e = s.resolve(bad, "p.v:3: `function:`").unwrap_err();
            assert!(is_refusal(&e), "{bad}");
            assert!(e.to_string().contains(ALLOW_PATHS_KEY) && e.to_string().contains("p.v:3"), "{e}");
        }
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("secret"), m.join("link.v")).unwrap();
            std::os::unix::fs::symlink(&d, m.join("up")).unwrap();
            assert!(s.resolve("link.v", "x").is_err());
            assert!(s.resolve("up/secret", "x").is_err());
            assert!(s.resolve("up/missing", "x").is_err(), "a link out, even to nothing");
            assert!(s.read(&m.join("link.v"), "x").is_err());
        }
        let open = SideFiles::new(&m, std::slice::from_ref(&d), 100);
        assert!(open.resolve("../secret", "x").is_ok());
        assert_eq!(open.read(&m.join("../secret"), "x").unwrap(), b"s");
        std::fs::remove_dir_all(&d).unwrap();
    }
}
