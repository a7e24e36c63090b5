//! A small tmpfs for the full-disk tests of the library and the CLI (included with
//! `#[path]` by both crates' tests): mounted at a fresh folder, unmounted on drop.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::Command;

/// A tmpfs mounted at the folder it holds; unmounted and removed on drop.
pub struct Tmpfs(pub PathBuf);

impl Tmpfs {
    /// Mounts a tmpfs of `bytes` at the empty folder `dir`, or returns `None` with the
    /// reason printed as `SKIPPED name: …` where this test cannot mount one (not root,
    /// no permission); `dir` is removed then.
    pub fn mount(name: &str, dir: PathBuf, bytes: u64) -> Option<Tmpfs> {
        let root = Command::new("id")
            .arg("-u")
            .output()
            .is_ok_and(|uid| String::from_utf8_lossy(&uid.stdout).trim() == "0");
        let ok = root
            && Command::new("mount")
                .args(["-t", "tmpfs", "-o", &format!("size={bytes}"), "tmpfs"])
                .arg(&dir)
                .status()
                .is_ok_and(|s| s.success());
        if !ok {
            let why = if root {
                "`mount -t tmpfs` failed (no CAP_SYS_ADMIN?)"
            } else {
                "mounting a small tmpfs needs root"
            };
            eprintln!("SKIPPED {name}: {why}");
            let _ = std::fs::remove_dir_all(&dir);
            return None;
        }
        Some(Tmpfs(dir))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.0).status();
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
