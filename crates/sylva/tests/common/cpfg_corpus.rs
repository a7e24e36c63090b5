//! Where the cpfg corpus is (`../shared/corpus/cpfg`, beside the repository), for the
//! tests that read its models.

use std::path::{Path, PathBuf};

/// The corpus folder, or `None` (after printing that the test is skipped) when it is not
/// there.
pub fn corpus() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/corpus/cpfg");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipped: the cpfg corpus is not at {}", dir.display());
        None
    }
}
