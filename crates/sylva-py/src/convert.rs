//! Values between Python and the engine: TOML values (a recipe key's value, both ways),
//! schema keys as dicts, and flat `Vec`s as numpy arrays.

use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{Element, IntoPyArray};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::ops::Bound as B;
use sylva::recipe::schema::{DefaultValue, Key, Kind, When};

/// A Python value as a TOML value: bool, int, float, str, a list or tuple of them, a
/// dict with string keys. Anything else is a `RecipeError` naming `key` and the type.
pub fn to_toml(key: &str, v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        let i: i64 = v.extract().map_err(|_| {
            crate::errors::recipe_error(format!("`{key}`: {v} does not fit in a 64-bit integer"))
        })?;
        return Ok(toml::Value::Integer(i));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: PyResult<Vec<toml::Value>> = v.try_iter()?.map(|x| to_toml(key, &x?)).collect();
        return Ok(toml::Value::Array(items?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, x) in d.iter() {
            let k: String = k.extract().map_err(|_| {
                crate::errors::recipe_error(format!("`{key}`: a table's keys must be text, got {k}"))
            })?;
            let sub = format!("{key}.{k}");
            t.insert(k, to_toml(&sub, &x)?);
        }
        return Ok(toml::Value::Table(t));
    }
    // numpy scalars and other numbers: through float() / int().
    if let Ok(i) = v.extract::<i64>() {
        return Ok(toml::Value::Integer(i));
    }
    if let Ok(f) = v.extract::<f64>() {
        return Ok(toml::Value::Float(f));
    }
    let ty = v.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into());
    Err(crate::errors::recipe_error(format!(
        "`{key}`: a {ty} is not a recipe value (give a bool, int, float, str, list or dict)"
    )))
}

/// A TOML value as a Python value (dates as their TOML text).
pub fn from_toml<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(a) => {
            let items: PyResult<Vec<Bound<'py, PyAny>>> = a.iter().map(|x| from_toml(py, x)).collect();
            PyList::new(py, items?)?.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, from_toml(py, x)?)?;
            }
            d.into_any()
        }
    })
}

fn bound(py: Python<'_>, b: &B<f64>) -> PyResult<Option<(f64, bool)>> {
    let _ = py;
    Ok(match b {
        B::Included(x) => Some((*x, true)),
        B::Excluded(x) => Some((*x, false)),
        B::Unbounded => None,
    })
}

/// A schema [`Kind`] as a dict: `type` (`bool`, `integer`, `float`, `mode`, `string`,
/// `path`, `list`, `table`) and its limits (`min`/`max`, `min_inclusive`…, `values`,
/// `item`, `min_len`/`max_len`).
fn kind<'py>(py: Python<'py>, k: &Kind) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match k {
        Kind::Bool => d.set_item("type", "bool")?,
        Kind::Integer { min, max } => {
            d.set_item("type", "integer")?;
            d.set_item("min", min)?;
            d.set_item("max", max)?;
        }
        Kind::Float { min, max } => {
            d.set_item("type", "float")?;
            let (lo, hi) = (bound(py, min)?, bound(py, max)?);
            d.set_item("min", lo.map(|b| b.0))?;
            d.set_item("min_inclusive", lo.map(|b| b.1))?;
            d.set_item("max", hi.map(|b| b.0))?;
            d.set_item("max_inclusive", hi.map(|b| b.1))?;
        }
        Kind::Mode(names) => {
            d.set_item("type", "mode")?;
            d.set_item("values", names.to_vec())?;
        }
        Kind::String => d.set_item("type", "string")?,
        Kind::Path => d.set_item("type", "path")?,
        Kind::List { item, min_len, max_len } => {
            d.set_item("type", "list")?;
            d.set_item("item", kind(py, item)?)?;
            d.set_item("min_len", min_len)?;
            d.set_item("max_len", (*max_len < usize::MAX).then_some(*max_len))?;
        }
        Kind::Table => d.set_item("type", "table")?,
    }
    Ok(d)
}

/// One schema key as a dict: `key`, `section` (its table, `""` for top-level keys),
/// `generator` (the generator type a `generator.*` key belongs to, else None), `kind`
/// (a dict, see [`kind`]), `values` (the values in words), `default` (a Python value;
/// None when unset), `required`, `unit` (a symbol or None), `doc`, `when` (a list of
/// conditions) and `limits` (text or None).
pub fn schema_key<'py>(py: Python<'py>, k: &Key) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("key", k.key)?;
    d.set_item("section", k.section.table())?;
    d.set_item("generator", k.section.generator().map(|g| g.name()))?;
    d.set_item("kind", kind(py, &k.kind)?)?;
    d.set_item("values", k.kind.to_string())?;
    let default = match k.default_value() {
        Some(v) => Some(from_toml(py, &v)?),
        None => None,
    };
    d.set_item("default", default)?;
    d.set_item("required", k.default == DefaultValue::Required)?;
    d.set_item("unit", k.unit.map(|u| u.symbol()))?;
    d.set_item("doc", k.doc)?;
    let when = PyList::empty(py);
    for w in k.when {
        let c = PyDict::new(py);
        match w {
            When::Is { key, names } => {
                c.set_item("key", *key)?;
                c.set_item("is", names.to_vec())?;
            }
            When::Table(t) => c.set_item("table", *t)?,
        }
        when.append(c)?;
    }
    d.set_item("when", when)?;
    d.set_item("limits", k.limits)?;
    Ok(d)
}

/// `flat` (`rows × cols` values, row-major) as an `(rows, cols)` numpy array.
pub fn array2<'py, T: Element>(py: Python<'py>, flat: Vec<T>, cols: usize) -> PyResult<Bound<'py, PyAny>> {
    let rows = flat.len().checked_div(cols).unwrap_or(0);
    let a = Array2::from_shape_vec((rows, cols), flat)
        .map_err(|e| crate::errors::sylva_error(format!("array shape: {e}")))?;
    Ok(a.into_pyarray(py).into_any())
}

/// `v` as a 1-D numpy array.
pub fn array1<'py, T: Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyAny> {
    Array1::from_vec(v).into_pyarray(py).into_any()
}

/// An image as an `(height, width, channels)` `uint8` array.
pub fn image<'py>(py: Python<'py>, img: &sylva::image::Image) -> PyResult<Bound<'py, PyAny>> {
    let shape = (img.height as usize, img.width as usize, img.channels as usize);
    let a = Array3::from_shape_vec(shape, img.data.clone())
        .map_err(|e| crate::errors::sylva_error(format!("image shape: {e}")))?;
    Ok(a.into_pyarray(py).into_any())
}
