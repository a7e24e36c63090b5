//! # sylva for Python — the native module `sylva._sylva` (issue 42)
//!
//! ```text
//!  Python                         this crate                     the engine (crate sylva)
//!  sylva.Recipe.preset(name) ──► Recipe (a recipe::Loaded) ──► Recipe::set / to_toml / schema
//!  recipe.grow(seed)         ──► GIL released, panics caught ──► pipeline::grow ──► Tree
//!  sylva.Session(recipe)     ──► Session (a locked Session)  ──► Session::update
//!  tree.skeleton / .parts    ──► numpy arrays (copies)       ◄── Skeleton, Model::parts
//!  tree.to_glb / save / preview                              ──► Tree::to_glb / write, preview
//!  sylva.lsystem.derive      ──► lsystem module               ──► pipeline::derive_lsystem, turtle
//! ```
//!
//! A thin front end over the engine's typed API: every call is one engine call, and every
//! engine error becomes a Python exception ([`errors`]): `sylva.RecipeError`,
//! `sylva.LsystemError` (with `file`, `line` and `column`), both subclasses of
//! `sylva.SylvaError`. The GIL is released while a tree grows, so Python threads grow
//! trees in parallel. A panic inside the engine (a bug) is caught at the boundary and
//! raised as a `SylvaError` rather than PyO3's `PanicException`.
//!
//! The Python package (`python/sylva/__init__.py`) re-exports this module; its typing
//! stubs are `python/sylva/_sylva.pyi`. Built with maturin (`pyproject.toml`), which sets
//! `PYO3_BUILD_EXTENSION_MODULE` so the extension does not link libpython; a plain
//! `cargo build` links it as an ordinary library.

mod convert;
mod errors;
mod limit;
mod lsystem;
mod recipe;
mod session;
mod tree;

use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The names of every embedded tree preset, sorted (the magnetic-curves compositions,
/// which are not trees, are left out).
#[pyfunction]
fn presets() -> Vec<String> {
    sylva::presets::all().into_iter().filter(|p| !p.is_curves()).map(|p| p.name.to_string()).collect()
}

/// A dict from each tree preset's name to its one-line description.
#[pyfunction]
fn preset_descriptions(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for p in sylva::presets::all().into_iter().filter(|p| !p.is_curves()) {
        d.set_item(p.name, p.description())?;
    }
    Ok(d)
}

/// The recipe schema as data: one dict per key, in the order of docs/recipe.md.
#[pyfunction]
fn schema(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    sylva::recipe::schema().iter().map(|k| convert::schema_key(py, k)).collect()
}

/// The module `sylva._sylva`.
#[pymodule]
fn _sylva(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SylvaError", py.get_type::<errors::SylvaError>())?;
    m.add("RecipeError", py.get_type::<errors::RecipeError>())?;
    m.add("LsystemError", py.get_type::<errors::LsystemError>())?;
    m.add_function(wrap_pyfunction!(presets, m)?)?;
    m.add_function(wrap_pyfunction!(preset_descriptions, m)?)?;
    m.add_function(wrap_pyfunction!(schema, m)?)?;
    m.add_class::<recipe::Recipe>()?;
    m.add_class::<tree::Tree>()?;
    m.add_class::<tree::Skeleton>()?;
    m.add_class::<tree::Part>()?;
    m.add_class::<session::Session>()?;
    let ls = PyModule::new(py, "lsystem")?;
    lsystem::register(&ls)?;
    m.add_submodule(&ls)?;
    Ok(())
}
