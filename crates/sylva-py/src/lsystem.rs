//! `sylva.lsystem`: the cpfg-syntax L-system language (McLoughlin2021 §2, ABOP; the
//! reference is docs/lsystem.md) from Python — derive a module string, and interpret a
//! module string with the 3D turtle into a skeleton.
//!
//! Both go through the engine's pipeline ([`sylva::pipeline::derive_lsystem`],
//! [`sylva::pipeline::skeleton`]) on the default recipe around the text
//! ([`sylva::recipe::Loaded::from_lsystem_source`]), so they read the text exactly as
//! `sylva grow model.l` and `sylva lsys derive` do. Errors are `sylva.LsystemError` with
//! `file` (`model.l`), `line` and `column`.

use crate::convert;
use crate::errors::{guard, recipe_error};
use crate::tree::Skeleton;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;
use sylva::recipe::{Generator, Loaded};

/// The default recipe around L-system `text`, with `steps` derivation steps, `seed` and
/// the recipe `settings` (full dotted keys) applied.
fn loaded(
    text: &str,
    steps: Option<u32>,
    seed: Option<u64>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<Loaded> {
    let mut loaded = guard(|| Loaded::from_lsystem_source(text))?;
    if let Some(d) = settings {
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| recipe_error(format!("settings: keys are dotted recipe keys, got {k}")))?;
            let value = convert::to_toml(&key, &v)?;
            guard(|| loaded.recipe.set(&key, value))?;
        }
    }
    if let Some(n) = steps {
        let r = loaded.recipe.clone();
        loaded.recipe = guard(|| r.with_iterations(n))?;
    }
    if let Some(s) = seed {
        loaded.recipe.seed = s;
    }
    Ok(loaded)
}

/// Derives the L-system `text` (cpfg syntax, what a `.l` file holds) for `steps` steps
/// (default: its `derivation length`) and returns the module string, modules separated
/// as `sylva lsys derive` prints them. `seed` drives stochastic productions; `settings`
/// are recipe keys (`{"generator.define": {"R": 2}}`). The GIL is released meanwhile.
#[pyfunction]
#[pyo3(signature = (text, steps=None, seed=None, settings=None))]
fn derive(
    py: Python<'_>,
    text: &str,
    steps: Option<u32>,
    seed: Option<u64>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<String> {
    let loaded = loaded(text, steps, seed, settings)?;
    py.detach(|| {
        guard(|| {
            let Generator::Lsystem(g) = &loaded.recipe.generator else {
                return Err(sylva::Error::Recipe(
                    "the settings changed the generator away from `lsystem`".into(),
                ));
            };
            let d = sylva::pipeline::derive_lsystem(&loaded, g)?;
            Ok(d.lsystem.format(&d.string))
        })
    })
}

/// The turtle's skeleton of the L-system `text` after `steps` steps (default: its
/// `derivation length`): derivation, homomorphism and the 3D turtle, as `sylva grow`
/// runs them before meshing. `settings` are recipe keys (`{"generator.angle": 30}`).
#[pyfunction]
#[pyo3(signature = (text, steps=None, seed=None, settings=None))]
fn skeleton(
    py: Python<'_>,
    text: &str,
    steps: Option<u32>,
    seed: Option<u64>,
    settings: Option<&Bound<'_, PyDict>>,
) -> PyResult<Skeleton> {
    let loaded = loaded(text, steps, seed, settings)?;
    let sk = py.detach(|| {
        guard(|| {
            let mut report = sylva::Report::default();
            Ok(sylva::pipeline::skeleton(&loaded, &mut report)?.skeleton)
        })
    })?;
    Ok(Skeleton { skeleton: Arc::new(sk) })
}

/// The turtle's skeleton of a module string (`"F(1)[+F(0.5)]F"`, what `derive` returns),
/// interpreted as it stands (the string is the axiom of an L-system with no productions
/// and no steps). `settings` are recipe keys for the turtle (`{"generator.angle": 30}`).
/// An error's `line` and `column` are those of the module string itself.
#[pyfunction]
#[pyo3(signature = (modules, settings=None))]
fn interpret(py: Python<'_>, modules: &str, settings: Option<&Bound<'_, PyDict>>) -> PyResult<Skeleton> {
    if modules.contains('\n') {
        return Err(recipe_error("interpret: give the module string on one line"));
    }
    const HEAD: &str = "Lsystem: 1\nderivation length: 0\nAxiom: ";
    let text = format!("{HEAD}{modules}\nendlsystem\n");
    skeleton(py, &text, Some(0), None, settings).inspect_err(|e| {
        // The module string is line 3 of the wrapper, after `Axiom: `: say where in it.
        let v = e.value(py);
        if let (Ok(Some(line)), Ok(Some(col))) = (
            v.getattr("line").and_then(|l| l.extract::<Option<u32>>()),
            v.getattr("column").and_then(|c| c.extract::<Option<u32>>()),
        ) {
            if line == 3 {
                let _ = v.setattr("line", 1);
                let _ = v.setattr("column", col.saturating_sub(7).max(1));
            }
        }
    })
}

/// Adds the module's functions to `m` (`sylva.lsystem`).
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add(
        "__doc__",
        "The cpfg-syntax L-system language: derive module strings, interpret them with the turtle.",
    )?;
    m.add_function(wrap_pyfunction!(derive, m)?)?;
    m.add_function(wrap_pyfunction!(skeleton, m)?)?;
    m.add_function(wrap_pyfunction!(interpret, m)?)?;
    Ok(())
}
