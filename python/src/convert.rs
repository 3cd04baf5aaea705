//! Values between Rust and Python: serde values as Python dicts and lists
//! (through `json`, so a dict is exactly what the CLI's JSON file holds),
//! and `settings={…}` as the CLI's `KEY=VALUE` pairs.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};
use serde::Serialize;

use crate::errors::OrPy;

/// A serde value as Python objects: its JSON read with every object a
/// `gloam.Result` (a dict with attribute access, `gloam/_results.py`), the
/// top-level object (or each of a top-level list's) the named result
/// class (`""`: `Result`).
pub fn to_py_as<'py>(
    py: Python<'py>,
    v: &impl Serialize,
    class: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).or_py()?;
    py.import("gloam._results")?
        .call_method1("load", (text, class))
}

/// `result[key]` on the classes that hold arrays (`RenderResult`,
/// `Capture`): the entry `key` of their `to_dict()`, a KeyError when there
/// is none — so dict-style code keeps working.
pub fn dict_item<'py>(d: Bound<'py, PyDict>, key: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?
        .ok_or_else(|| pyo3::exceptions::PyKeyError::new_err(key.to_string()))
}

/// A Python object (dicts, lists, numbers, strings) as a serde value.
pub fn from_py<T: serde::de::DeserializeOwned>(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<T> {
    // `allow_nan=False`: JSON has no NaN, and `json.dumps` wrote the token
    // anyway, which serde then called "expected value at line 1 column 33".
    let kwargs = pyo3::types::PyDict::new(obj.py());
    kwargs.set_item("allow_nan", false)?;
    let text: String = obj
        .py()
        .import("json")?
        .call_method("dumps", (obj,), Some(&kwargs))
        .map_err(
            |e| match e.is_instance_of::<pyo3::exceptions::PyValueError>(obj.py()) {
                true => crate::errors::GloamError::new_err(format!(
                    "{what}: {e} (NaN and infinities are not values here)"
                )),
                false => e,
            },
        )?
        .extract()?;
    serde_json::from_str(&text)
        .map_err(|e| crate::errors::GloamError::new_err(format!("{what}: {e}")))
}

/// A count or seed from Python (`spp`, `samples`, `threads`, `seed`): an
/// int, never a bool — `True` is an int to Python, and `spp=True` was
/// taken as 1 sample.
pub struct Count<T>(pub T);

impl<'a, 'py, T: pyo3::conversion::FromPyObjectOwned<'py>> FromPyObject<'a, 'py> for Count<T> {
    type Error = PyErr;
    fn extract(obj: pyo3::Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        if obj.is_instance_of::<PyBool>() {
            let v = if obj.extract::<bool>()? {
                "True"
            } else {
                "False"
            };
            return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                "{v} is a bool, not a count"
            )));
        }
        obj.extract::<T>().map(Count).map_err(Into::into)
    }
}

/// `{"recursion": 2, "indirect": "off"}` → `["recursion=2", "indirect=off"]`.
pub fn setting_pairs(settings: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let mut out = Vec::new();
    if let Some(d) = settings {
        for (k, v) in d.iter() {
            let k: String = k.str()?.extract()?;
            let v: String = if v.is_instance_of::<PyBool>() {
                if v.extract::<bool>()? {
                    "true"
                } else {
                    "false"
                }
                .to_string()
            } else {
                v.str()?.extract()?
            };
            out.push(format!("{k}={v}"));
        }
    }
    Ok(out)
}
