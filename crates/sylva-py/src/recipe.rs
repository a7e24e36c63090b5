//! `sylva.Recipe`: a recipe with the origin its file names resolve in (the engine's
//! [`sylva::recipe::Loaded`]), built from a preset, TOML text, a file or L-system text,
//! changed key by key ([`sylva::Recipe::set`], every value checked) and grown.

use crate::convert;
use crate::errors::{guard, recipe_error, sylva_error};
use crate::tree::Tree;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use sylva::recipe::{Loaded, Origin};

/// A tree recipe: the generator, mesher, refinement, leaves, wind, LOD and output
/// settings of one tree (docs/recipe.md), with where its model files are read from.
/// `Recipe()` is the default preset's recipe.
#[pyclass(module = "sylva", name = "Recipe")]
#[derive(Clone)]
pub struct Recipe {
    /// The recipe and its origin.
    pub loaded: Loaded,
}

thread_local! {
    /// The worker pools of `grow(threads=n)` called from this thread, by size: kept, so
    /// their threads (and their warm allocator arenas) serve the thread's next grows.
    static POOLS: std::cell::RefCell<Vec<(usize, std::sync::Arc<rayon::ThreadPool>)>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// This thread's pool of `n` worker threads, started on first use.
fn pool(n: usize) -> PyResult<std::sync::Arc<rayon::ThreadPool>> {
    POOLS.with(|pools| {
        if let Some((_, p)) = pools.borrow().iter().find(|(k, _)| *k == n) {
            return Ok(p.clone());
        }
        let p = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| sylva_error(format!("cannot start {n} worker thread(s): {e}")))?;
        let p = std::sync::Arc::new(p);
        pools.borrow_mut().push((n, p.clone()));
        Ok(p)
    })
}

/// The model file the recipe's generator reads (`generator.file`), if any.
fn model_file(recipe: &sylva::Recipe) -> Option<String> {
    let table = recipe.to_table().ok()?;
    lookup(&table, "generator.file")?.as_str().map(str::to_string)
}

/// The value at dotted `key` of `table`, if any.
fn lookup<'a>(table: &'a toml::Table, key: &str) -> Option<&'a toml::Value> {
    let mut parts = key.split('.');
    let mut v = table.get(parts.next()?.trim())?;
    for p in parts {
        v = v.as_table()?.get(p.trim())?;
    }
    Some(v)
}

#[pymethods]
impl Recipe {
    /// The default preset's recipe (`sylva grow` without arguments).
    #[new]
    fn new() -> PyResult<Recipe> {
        Ok(Recipe { loaded: guard(|| Loaded::preset(sylva::presets::DEFAULT_PRESET))? })
    }

    /// The recipe of the embedded preset `name` (`sylva.presets()` lists them).
    #[staticmethod]
    fn preset(name: &str) -> PyResult<Recipe> {
        Ok(Recipe { loaded: guard(|| Loaded::preset(name))? })
    }

    /// A recipe from TOML text. `preset = "name"` in it starts from that preset (its
    /// files resolve inside the presets); otherwise file names resolve in `base_dir`
    /// (default: the current directory), and a model file that is not there but is one
    /// of the presets' (what `to_toml` of a preset's recipe names) is read from the
    /// presets. Errors name the key, or the line and column of a syntax error.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir=None))]
    fn from_toml(text: &str, base_dir: Option<PathBuf>) -> PyResult<Recipe> {
        let recipe = guard(|| sylva::Recipe::from_toml(text))?;
        let preset = toml::from_str::<toml::Table>(text)
            .ok()
            .and_then(|t| t.get(sylva::recipe::PRESET_KEY).and_then(|v| v.as_str().map(str::to_string)));
        let dir = base_dir.unwrap_or_default();
        // A preset's recipe written by `to_toml` names the preset's files
        // (`lsystem/honda.l`): where such a file is not on disk, it is read from the
        // presets, so the text grows the same tree.
        let embedded = |file: &str| !dir.join(file).exists() && sylva::presets::file(file).is_some();
        let origin = match (preset, model_file(&recipe)) {
            (Some(name), _) => Origin::Preset(name),
            (None, Some(file)) if embedded(&file) => Origin::Preset(recipe.name.clone()),
            (None, _) => Origin::Folder(dir),
        };
        Ok(Recipe { loaded: guard(|| Loaded::new(recipe, origin))? })
    }

    /// The recipe of a file: a `.toml` recipe, or a model file (`.l`, `.lst`, `.str`,
    /// `.json`) with the default recipe around it, as `sylva grow FILE` reads it.
    #[staticmethod]
    fn from_file(path: PathBuf) -> PyResult<Recipe> {
        Ok(Recipe { loaded: guard(|| sylva::Recipe::from_file(&path))? })
    }

    /// The default recipe around an L-system given as text (cpfg syntax, what a `.l`
    /// file holds); nothing is read from disk. Errors in the text name `model.l`.
    #[staticmethod]
    fn from_lsystem(text: &str) -> PyResult<Recipe> {
        Ok(Recipe { loaded: guard(|| Loaded::from_lsystem_source(text))? })
    }

    /// The recipe schema as data (`sylva.schema()`): one dict per key.
    #[staticmethod]
    fn schema(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
        sylva::recipe::schema().iter().map(|k| convert::schema_key(py, k)).collect()
    }

    /// Sets the dotted `key` (`"mesh.sides"`, `"leaves.mode"`) to `value` (bool, int,
    /// float, str, list or dict), as `sylva grow --set key=value` does. The whole recipe
    /// is checked: an unknown key or a bad value raises `RecipeError` naming it and
    /// leaves the recipe unchanged. Returns the recipe, so calls chain.
    fn set<'py>(
        mut slf: PyRefMut<'py, Self>,
        key: &str,
        value: &Bound<'py, PyAny>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let v = convert::to_toml(key, value)?;
        let mut next = slf.loaded.recipe.clone();
        guard(|| next.set(key, v))?;
        slf.loaded.recipe = next;
        Ok(slf)
    }

    /// The value of the dotted `key`: the recipe's own, else the schema's default.
    /// Raises `RecipeError` for a key the recipe does not have and the schema does not
    /// know.
    fn get<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        let table = guard(|| self.loaded.recipe.to_table())?;
        if let Some(v) = lookup(&table, key) {
            return convert::from_toml(py, v);
        }
        let gen = sylva::recipe::schema::GeneratorKind::from_name(self.loaded.recipe.generator.kind());
        match sylva::recipe::schema::find(key, gen) {
            Some(k) => match k.default_value() {
                Some(v) => convert::from_toml(py, &v),
                None => Ok(py.None().into_bound(py)),
            },
            None => Err(recipe_error(format!("unknown key `{key}` (sylva.schema() lists every key)"))),
        }
    }

    /// The recipe as TOML text; `Recipe.from_toml` reads it back to an equal recipe.
    fn to_toml(&self) -> PyResult<String> {
        guard(|| self.loaded.recipe.to_toml())
    }

    /// The recipe as a dict (the TOML table; keys at their defaults may be left out).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let table = guard(|| self.loaded.recipe.to_table())?;
        convert::from_toml(py, &toml::Value::Table(table))
    }

    /// The recipe's name.
    #[getter]
    fn name(&self) -> String {
        self.loaded.recipe.name.clone()
    }

    /// The seed of every random choice.
    #[getter]
    fn seed(&self) -> u64 {
        self.loaded.recipe.seed
    }

    /// Sets the seed.
    #[setter(seed)]
    fn set_seed(&mut self, seed: u64) {
        self.loaded.recipe.seed = seed;
    }

    /// The generator type (`lsystem`, `import`, `weber-penn`, `space-colonization`,
    /// `least-cost`).
    #[getter]
    fn generator(&self) -> &'static str {
        self.loaded.recipe.generator.kind()
    }

    /// A copy (changing it leaves this recipe alone).
    fn copy(&self) -> Recipe {
        self.clone()
    }

    fn __copy__(&self) -> Recipe {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Recipe {
        self.clone()
    }

    /// Whether `other` is a recipe with the same settings (where the files are read
    /// from aside).
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other.extract::<PyRef<'_, Recipe>>().is_ok_and(|o| o.loaded.recipe == self.loaded.recipe)
    }

    fn __repr__(&self) -> String {
        format!("<sylva.Recipe {:?} ({}, seed {})>", self.loaded.recipe.name, self.generator(), self.seed())
    }

    /// Grows the tree (with `seed` instead of the recipe's, if given). The GIL is
    /// released meanwhile, so Python threads grow trees in parallel. `threads` caps the
    /// engine's own worker threads for this grow (default: the shared pool, one thread
    /// per core); `threads=1` grows on one thread of its own, the right choice when
    /// many Python threads or processes each grow a tree. Raises `SylvaError` (or a
    /// subclass) when the recipe cannot be grown. The tree is the same for any
    /// `threads`. `timeout` (seconds) stops a grow that takes longer, raising
    /// `TimeoutError` (the recipe's work budgets bound the work; this bounds the time).
    #[pyo3(signature = (seed=None, threads=None, timeout=None))]
    fn grow(
        &self,
        py: Python<'_>,
        seed: Option<u64>,
        threads: Option<usize>,
        timeout: Option<f64>,
    ) -> PyResult<Tree> {
        let timeout = crate::limit::seconds(timeout)?;
        let mut loaded = self.loaded.clone();
        if let Some(s) = seed {
            loaded.recipe.seed = s;
        }
        let tree = py.detach(|| {
            crate::limit::run(timeout, |token| {
                let grow = || sylva::cancel::scope(token, || guard(|| sylva::pipeline::grow(&loaded)));
                match threads {
                    None | Some(0) => grow(),
                    Some(n) => pool(n)?.install(grow),
                }
            })
        })?;
        Ok(Tree::grown_from(tree, loaded))
    }
}
