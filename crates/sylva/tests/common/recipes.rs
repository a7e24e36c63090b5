//! Loading, deriving and growing recipes in tests (included with `#[path]`): a preset
//! name or a model file, with `--set`-style `key=value` strings.
#![allow(dead_code)]

use std::path::Path;
use sylva::recipe::{self, Generator, Loaded};

/// `key=value` strings parsed as `--set` parses them.
pub fn sets(kv: &[&str]) -> Vec<(String, toml::Value)> {
    kv.iter().map(|s| recipe::parse_set(s).unwrap()).collect()
}

/// The preset or model file `what` loaded with the settings `kv`.
pub fn load(what: impl AsRef<Path>, kv: &[&str]) -> sylva::Result<Loaded> {
    recipe::load(what.as_ref().to_str().unwrap(), &sets(kv))
}

/// `what` with `kv`, grown.
pub fn grow(what: impl AsRef<Path>, kv: &[&str]) -> sylva::Result<sylva::pipeline::Grown> {
    sylva::pipeline::grow(&load(what, kv)?)
}

/// `what` with `kv` (an L-system), derived.
pub fn derive(what: impl AsRef<Path>, kv: &[&str]) -> sylva::Result<sylva::pipeline::Derived> {
    let l = load(what, kv)?;
    let Generator::Lsystem(g) = &l.recipe.generator else { panic!("an L-system recipe") };
    sylva::pipeline::derive_lsystem(&l, g)
}
