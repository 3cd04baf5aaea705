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

/// An integer argument from Python (counts, seeds, sizes, rows, jobs): an
/// int, never a bool — `True` is an int to Python, and `spp=True` was
/// taken as 1 sample — and one that `T` cannot hold (`spp=2**70`,
/// `frames=-1`) a `GloamError` (a `ValueError`) giving the range, where
/// PyO3 raised a bare `OverflowError` ("can't convert negative int to
/// unsigned"). PyO3 notes the argument ("while processing 'spp'"); the
/// library then holds the value to its own limits.
pub struct Count<T>(pub T);

impl<T> Count<T> {
    /// The values of a list argument (`rows=[…]`).
    pub fn all(v: Vec<Count<T>>) -> Vec<T> {
        v.into_iter().map(|c| c.0).collect()
    }
}

/// The range of an integer type, for [`Count`]'s message.
pub trait IntRange {
    const MIN: i128;
    const MAX: i128;
}

macro_rules! int_range {
    ($($t:ty),*) => {$(
        impl IntRange for $t {
            const MIN: i128 = <$t>::MIN as i128;
            const MAX: i128 = <$t>::MAX as i128;
        }
    )*};
}
int_range!(u8, u16, u32, u64, usize, i32, i64);

impl<'a, 'py, T: pyo3::conversion::FromPyObjectOwned<'py> + IntRange> FromPyObject<'a, 'py>
    for Count<T>
{
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
        obj.extract::<T>().map(Count).map_err(|e| {
            let e: PyErr = e.into();
            if !e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) {
                return e;
            }
            // 10**5000 has more digits than Python prints (and than help).
            let v = match obj.str() {
                Ok(s) if s.to_string().len() <= 24 => s.to_string(),
                _ => "an int that large".to_string(),
            };
            crate::errors::GloamError::new_err(format!(
                "{v} is out of range: a whole number from {} to {} here",
                T::MIN,
                T::MAX
            ))
        })
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
