//! Scratch folders and what is left in them, shared by the library's and the CLI's tests
//! (included with `#[path]` by both crates' tests).
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// An empty folder `sylva-<suite>-<name>-<pid>` in the system's temporary folder.
pub fn tempdir(suite: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sylva-{suite}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Every file in `dir` with its bytes (folders as empty).
pub fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap_or_default())
        })
        .collect()
}

/// The names of the entries of `dir`, sorted.
pub fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// The names in `dir` that are temporaries or locks of an output set, sorted (names
/// only: cheap enough to poll).
pub fn leftovers(dir: &Path) -> Vec<String> {
    names(dir).into_iter().filter(|n| n.contains(".tmp-") || n.ends_with(".lock")).collect()
}

/// [`tempdir`] holding `files` (name, text).
pub fn with_files(suite: &str, name: &str, files: &[(&str, &str)]) -> PathBuf {
    let d = tempdir(suite, name);
    for (file, text) in files {
        std::fs::write(d.join(file), text).unwrap();
    }
    d
}
