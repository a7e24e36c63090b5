//! The embedded presets' skeletons, for the mesher tests that run every preset (included
//! with `#[path]`).
#![allow(dead_code)]

use sylva::presets::Preset;
use sylva::Skeleton;

/// Skeletons over this many nodes (the largest Weber–Penn trees) are kept out of CI for
/// time; the ignored throughput tests mesh them.
pub const MAX_NODES: usize = 30_000;

/// Calls `f` with the name and skeleton of every embedded preset that `keep` accepts and
/// that loads and grows, in preset order. A skeleton over [`MAX_NODES`] is skipped with
/// the table row `| name | nodes | skipped (large) |` on stdout.
pub fn each_preset_skeleton(keep: impl Fn(&Preset) -> bool, mut f: impl FnMut(&'static str, &Skeleton)) {
    for p in sylva::presets::all().into_iter().filter(|p| keep(p)) {
        let Ok(loaded) = sylva::recipe::load(p.name, &[]) else { continue };
        let mut report = sylva::pipeline::Report::default();
        let Ok(g) = sylva::pipeline::skeleton(&loaded, &mut report) else { continue };
        if g.skeleton.len() > MAX_NODES {
            println!("| {} | {} | skipped (large) |", p.name, g.skeleton.len());
            continue;
        }
        f(p.name, &g.skeleton);
    }
}

/// What `f` makes of the name and skeleton of every preset that [`each_preset_skeleton`]
/// gives for `keep`, run on the rayon pool (CI has two cores), in preset order.
pub fn par_map_presets<R: Send>(
    keep: impl Fn(&Preset) -> bool,
    f: impl Fn(&'static str, &Skeleton) -> R + Sync,
) -> Vec<R> {
    use rayon::prelude::*;
    let mut skeletons = Vec::new();
    each_preset_skeleton(keep, |name, sk| skeletons.push((name, sk.clone())));
    skeletons.par_iter().map(|(name, sk)| f(name, sk)).collect()
}

/// The name and skeleton of the preset that environment variable `var` names (`default`
/// when it is unset), for the ignored diagnostic tests.
pub fn named_preset_skeleton(var: &str, default: &str) -> (String, Skeleton) {
    let name = std::env::var(var).unwrap_or_else(|_| default.into());
    let loaded = sylva::recipe::load(&name, &[]).unwrap_or_else(|e| panic!("{name}: {e}"));
    let g = sylva::pipeline::skeleton(&loaded, &mut sylva::pipeline::Report::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    (name, g.skeleton)
}
