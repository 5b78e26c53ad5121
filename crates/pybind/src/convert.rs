//! Structured values across the FFI as Python objects: Python `dict`/`list`/scalars to the
//! `serde_json::Value` tree the Rust crates deserialize their inputs from (so serde names a
//! mistyped field exactly as it does for the data files), and any `Serialize` result back to
//! plain Python `dict`/`list`/`float`/`str`. No text is formatted or parsed on the way.
//!
//! Non-finite floats are refused on the way in (`InvalidInputError` naming the field); on the
//! way out serde writes them as `None`, as it would in a data file.
use crate::errors::{invalid, invalid_type};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use pyo3::IntoPyObjectExt;
use serde::Serialize;
use serde_json::{Map, Number, Value};

/// What a binding returns, bound to the GIL's lifetime (or the Python exception): a numpy
/// vector, a numpy matrix, a `dict`, any object.
pub(crate) type VectorOut<'py> = PyResult<Bound<'py, numpy::PyArray1<f64>>>;
pub(crate) type MatrixOut<'py> = PyResult<Bound<'py, numpy::PyArray2<f64>>>;
pub(crate) type DictOut<'py> = PyResult<Bound<'py, PyDict>>;
pub(crate) type AnyOut<'py> = PyResult<Bound<'py, PyAny>>;

/// One field of every record as a numpy column.
pub(crate) fn column<'py, T, V: numpy::Element>(
    py: Python<'py>,
    records: &[T],
    field: impl Fn(&T) -> V,
) -> Bound<'py, numpy::PyArray1<V>> {
    records
        .iter()
        .map(field)
        .collect::<Vec<_>>()
        .into_pyarray(py)
}

/// How deep a structured input may nest (dicts and lists within each other): a robot
/// description or behaviour nests a handful of levels; the bound keeps the conversion's
/// recursion (and serde's after it) far from the stack's end, whatever the caller passes.
pub(crate) const MAX_NESTING: usize = 64;

/// A Python value as a JSON value; `field` names it in errors (`"terrain.height_m"`).
pub(crate) fn to_value(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Value> {
    to_value_at(obj, field, 0)
}

fn to_value_at(obj: &Bound<'_, PyAny>, field: &str, depth: usize) -> PyResult<Value> {
    if depth > MAX_NESTING {
        return Err(invalid(
            field,
            format!("`{field}`: nested deeper than {MAX_NESTING} levels"),
        ));
    }
    if obj.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if obj.is_instance_of::<PyInt>() {
        if let Ok(i) = obj.extract::<i64>() {
            return Ok(Value::from(i));
        }
        if let Ok(u) = obj.extract::<u64>() {
            return Ok(Value::from(u));
        }
        return Err(invalid(
            field,
            format!("`{field}`: integer {obj} is out of range"),
        ));
    }
    if obj.is_instance_of::<PyFloat>() {
        let v: f64 = obj.extract()?;
        return Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| invalid(field, format!("`{field}`: must be finite, got {v}")));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Value::String(s.to_str()?.to_owned()));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        return Ok(Value::Object(to_map_at(d, field, depth + 1)?));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for (i, item) in obj.try_iter()?.enumerate() {
            out.push(to_value_at(&item?, &format!("{field}[{i}]"), depth + 1)?);
        }
        return Ok(Value::Array(out));
    }
    Err(invalid_type(
        field,
        format!(
            "`{field}`: unsupported value of type {}",
            obj.get_type().name()?
        ),
    ))
}

/// A `dict` with string keys as a JSON object; `field` prefixes the keys in errors.
pub(crate) fn to_map(d: &Bound<'_, PyDict>, field: &str) -> PyResult<Map<String, Value>> {
    to_map_at(d, field, 0)
}

fn to_map_at(d: &Bound<'_, PyDict>, field: &str, depth: usize) -> PyResult<Map<String, Value>> {
    let mut out = Map::new();
    for (k, v) in d.iter() {
        let key: String = k.extract().map_err(|_| {
            invalid_type(field, format!("`{field}`: keys must be strings, got {k}"))
        })?;
        let name = if field.is_empty() {
            key.clone()
        } else {
            format!("{field}.{key}")
        };
        out.insert(key, to_value_at(&v, &name, depth)?);
    }
    Ok(out)
}

/// A JSON value as a plain Python object.
pub(crate) fn from_value<'py>(py: Python<'py>, v: &Value) -> AnyOut<'py> {
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_bound_py_any(py)?,
        Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_bound_py_any(py)?,
            (None, Some(u)) => u.into_bound_py_any(py)?,
            _ => n.as_f64().unwrap_or(f64::NAN).into_bound_py_any(py)?,
        },
        Value::String(s) => s.into_bound_py_any(py)?,
        Value::Array(a) => {
            let items = a
                .iter()
                .map(|x| from_value(py, x))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)?.into_any()
        }
        Value::Object(m) => {
            let d = PyDict::new(py);
            for (k, x) in m {
                d.set_item(k, from_value(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// Any serializable Rust value as a plain Python object.
pub(crate) fn to_py<'py>(py: Python<'py>, v: &impl Serialize) -> AnyOut<'py> {
    let value = serde_json::to_value(v)
        .map_err(|e| crate::errors::engine(format!("could not convert a result: {e}")))?;
    from_value(py, &value)
}

/// Rows of equal length as an `(n, ncols)` array.
pub(crate) fn rows_array(rows: &[Vec<f64>], ncols: usize) -> numpy::ndarray::Array2<f64> {
    numpy::ndarray::Array2::from_shape_fn((rows.len(), ncols), |(k, j)| rows[k][j])
}

/// Per-sample, per-contact optional `(x, z)` pairs as an `(n, nc, 2)` array, NaN where absent.
pub(crate) fn pairs_array(
    rows: &[Vec<Option<[f64; 2]>>],
    nc: usize,
) -> numpy::ndarray::Array3<f64> {
    numpy::ndarray::Array3::from_shape_fn((rows.len(), nc, 2), |(k, c, i)| {
        rows[k][c].map_or(f64::NAN, |v| v[i])
    })
}
