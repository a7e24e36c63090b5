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

/// Squared length at or below which cpfg's rayshade output leaves a cylinder or cone out
/// (`r_end_cylinder`'s "degenerated cone" test in vlab's `cpfg/rayshade.c`): the corpus
/// references' `geometry.segments.csv` were written through it, so internodes shorter
/// than √0.00001 ≈ 0.00316 are missing there although cpfg's turtle draws them (issue 46).
#[allow(dead_code)]
pub const RAYSHADE_MIN_SQUARED_LENGTH: f64 = 0.00001;

/// Whether cpfg's rayshade output writes the segment `a`→`b` (model units).
#[allow(dead_code)]
pub fn rayshade_writes(a: glam::DVec3, b: glam::DVec3) -> bool {
    (b - a).length_squared() > RAYSHADE_MIN_SQUARED_LENGTH
}
