//! `sylva.Session`: the engine's [`sylva::Session`] for fast re-grows — it keeps every
//! stage's result, and `update(recipe)` recomputes from the first stage whose inputs
//! changed (a leaf or wind change never regrows the skeleton).

use crate::errors::{guard, sylva_error};
use crate::recipe::Recipe;
use crate::tree::Tree;
use pyo3::prelude::*;
use std::sync::Mutex;

/// A recipe and the result of every pipeline stage, for re-growing after a change:
/// `session = sylva.Session(recipe); tree = session.run(); recipe.set(...);
/// tree = session.update(recipe)`. The recipe's model files are read from where the
/// first recipe's were. Safe to share between threads (calls take turns).
#[pyclass(module = "sylva", name = "Session", frozen)]
pub struct Session {
    session: Mutex<sylva::Session>,
    base: sylva::recipe::Loaded,
}

impl Session {
    /// Runs `f` on the session with the GIL released and the session locked.
    fn with<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&mut sylva::Session) -> sylva::Result<T> + Send,
    ) -> PyResult<T> {
        py.detach(|| {
            let mut s =
                self.session.lock().map_err(|_| sylva_error("the session was poisoned by a panic"))?;
            guard(|| f(&mut s))
        })
    }
}

#[pymethods]
impl Session {
    /// A session for `recipe`; nothing is computed until `run` or `update`.
    #[new]
    fn new(recipe: PyRef<'_, Recipe>) -> Session {
        Session {
            session: Mutex::new(sylva::Session::new(recipe.loaded.clone())),
            base: recipe.loaded.clone(),
        }
    }

    /// Computes the tree of the current recipe (only the stages not kept) and returns
    /// it. The GIL is released meanwhile. `timeout` (seconds) stops a run that takes
    /// longer, raising `TimeoutError`; the stages it finished are kept.
    #[pyo3(signature = (timeout=None))]
    fn run(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Tree> {
        let timeout = crate::limit::seconds(timeout)?;
        let tree = crate::limit::run(timeout, |token| self.with(py, |s| s.run_with(token).cloned()))?;
        Ok(Tree::grown_from(tree, self.base.clone()))
    }

    /// Makes `recipe` the session's recipe and recomputes from the first stage whose
    /// inputs changed; returns the tree. An invalid recipe raises `RecipeError` and
    /// changes nothing. The GIL is released meanwhile. `timeout` as for `run`.
    #[pyo3(signature = (recipe, timeout=None))]
    fn update(&self, py: Python<'_>, recipe: PyRef<'_, Recipe>, timeout: Option<f64>) -> PyResult<Tree> {
        let timeout = crate::limit::seconds(timeout)?;
        let r = recipe.loaded.recipe.clone();
        let tree =
            crate::limit::run(timeout, |token| self.with(py, move |s| s.update_with(r, token).cloned()))?;
        Ok(Tree::grown_from(tree, self.base.clone()))
    }

    /// The stages the last run or update computed (the others were kept), by name.
    #[getter]
    fn last_run(&self, py: Python<'_>) -> PyResult<Vec<&'static str>> {
        self.with(py, |s| Ok(s.last_run().iter().map(|st| st.name()).collect()))
    }

    /// The session's current recipe.
    #[getter]
    fn recipe(&self, py: Python<'_>) -> PyResult<Recipe> {
        let loaded = self.with(py, |s| Ok(s.loaded().clone()))?;
        Ok(Recipe { loaded })
    }

    /// The tree of the last successful run or update, or None.
    #[getter]
    fn tree(&self, py: Python<'_>) -> PyResult<Option<Tree>> {
        let tree = self.with(py, |s| Ok(s.tree().cloned()))?;
        Ok(tree.map(|t| Tree::grown_from(t, self.base.clone())))
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let name = self.with(py, |s| Ok(s.recipe().name.clone()))?;
        Ok(format!("<sylva.Session {name:?}>"))
    }
}
