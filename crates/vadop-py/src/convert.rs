//! Arguments from Python into the core's types, and the core's results and errors back: numpy
//! arrays (lists and tuples too, read with `numpy.asarray`) into vectors, quaternions, spheres
//! and a box, ints into their ranges, names into settings, vectors back into arrays. Every
//! message that names an argument, its row and what was expected is written here. It checks
//! form only (dtype, shape, finiteness, range) and never decides a physical rule: what the core
//! still rejects comes back as a `ValueError` with the core's own message.

use glam::{DQuat, DVec3};
use numpy::ndarray::Array2;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyArrayDescr, PyUntypedArray};
use pyo3::exceptions::{PyMemoryError, PyOverflowError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};
use vadop::axis_pool::MAX_AXES;
use vadop::memory;
use vadop::{BoxBounds, Method, Mode, Sphere, VadopError, WorldConfig};

pub(crate) fn value_error(e: VadopError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `MemoryError` unless `bytes` fit in the memory left; `what` names the request.
pub(crate) fn check_memory(what: &str, bytes: u64) -> PyResult<()> {
    memory::check(bytes).map_err(|shortfall| PyMemoryError::new_err(format!("{what} {shortfall}")))
}

/// `MemoryError` unless a world of `bodies` bodies fits in the memory left.
pub(crate) fn check_world_memory(bodies: usize) -> PyResult<()> {
    check_memory(&format!("a world of {bodies} bodies"), memory::world_bytes(bodies))
}

/// A numpy shape written the way Python prints it: `(4,)`, `(4, 3)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!("({})", shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")),
    }
}

/// What an argument must be, for messages: "a float64 array of shape (n, 3)".
fn expected(dtype: &str, shape: &[Option<usize>]) -> String {
    let dims: Vec<String> = shape.iter().map(|d| d.map_or("n".to_string(), |d| d.to_string())).collect();
    let shape = if dims.len() == 1 { format!("({},)", dims[0]) } else { format!("({})", dims.join(", ")) };
    let article = if dtype.starts_with("int") { "an" } else { "a" };
    format!("{article} {dtype} array of shape {shape}")
}

/// Checks that `obj` is a numpy array of `dtype` whose shape matches `shape` (`None` = any
/// length) and returns it; a list or tuple is read with `numpy.asarray` first (see
/// [`sequence_array`]). Type and dtype problems are `TypeError`, shape problems `ValueError`.
pub(crate) fn checked_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    dtype: Bound<'py, PyArrayDescr>,
    shape: &[Option<usize>],
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let want = expected(&dtype.to_string(), shape);
    let (array, what) = if let Ok(array) = obj.downcast::<PyUntypedArray>() {
        if !array.dtype().is_equiv_to(&dtype) {
            let got = format!("{} of shape {}", array.dtype(), shape_text(array.shape()));
            return Err(PyTypeError::new_err(format!("{name} must be {want}, got {got}")));
        }
        (array.clone(), array.dtype().to_string())
    } else if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        (sequence_array(obj, name, &want, &dtype)?, format!("a {}", obj.get_type().name()?))
    } else {
        let type_name = obj.get_type().name()?;
        return Err(PyTypeError::new_err(format!(
            "{name} must be {want}, got {type_name} (convert with numpy.asarray({name}, dtype={dtype}))"
        )));
    };
    let fits = array.ndim() == shape.len() && array.shape().iter().zip(shape).all(|(&d, &s)| s.is_none_or(|s| s == d));
    if !fits {
        return Err(PyValueError::new_err(format!(
            "{name} must be {want}, got {what} of shape {}",
            shape_text(array.shape())
        )));
    }
    Ok(array)
}

/// A list or tuple argument as an array of `dtype`, the way `numpy.asarray` reads it: Python and
/// numpy numbers of any int or float type are taken (ints only, for an int `dtype`), anything
/// else (str, bool, None, nested lists of different lengths) is an error naming the argument.
fn sequence_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    want: &str,
    dtype: &Bound<'py, PyArrayDescr>,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let py = obj.py();
    let type_name = obj.get_type().name()?;
    let numpy = py.import("numpy")?;
    let array = numpy.call_method1("asarray", (obj,)).map_err(|e| {
        PyValueError::new_err(format!(
            "{name} must be {want}, got a {type_name} that is not a rectangular array of numbers ({})",
            e.value(py)
        ))
    })?;
    let array = array.downcast_into::<PyUntypedArray>()?;
    let kind = array.dtype().kind();
    let accepted: &[u8] = if dtype.kind() == b'f' { b"iuf" } else { b"iu" };
    // `numpy.asarray([])` is float64: an empty list is fine whatever the dtype.
    let empty = array.shape().contains(&0);
    if !(accepted.contains(&kind) || empty) {
        let values = match kind {
            b'b' => "bools".to_string(),
            b'U' | b'S' => "strings".to_string(),
            b'O' => "values that are not all numbers (or ints beyond 64 bits)".to_string(),
            _ => format!("{} values", array.dtype()),
        };
        return Err(PyTypeError::new_err(format!("{name} must be {want}, got a {type_name} of {values}")));
    }
    Ok(array.call_method1("astype", (dtype,))?.downcast_into::<PyUntypedArray>()?)
}

/// An int argument as given, before its range is known: [`IntArg::in_range`] checks it. Taking
/// every object (instead of a Rust int type) keeps a negative or huge int from ever becoming
/// `OverflowError`, and lets the message name the argument and its range.
pub(crate) enum IntArg {
    /// Fits i128 (Python and numpy ints, bools).
    Int(i128),
    /// An int beyond i128, as Python prints it.
    Huge(String),
    /// Not an int (floats too, even 5.0): the type's name.
    NotInt(String),
}

impl<'py> FromPyObject<'py> for IntArg {
    fn extract_bound(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        Ok(match obj.extract::<i128>() {
            Ok(value) => IntArg::Int(value),
            Err(e) if e.is_instance_of::<PyOverflowError>(obj.py()) => IntArg::Huge(obj.str()?.to_string()),
            Err(_) => IntArg::NotInt(obj.get_type().name()?.to_string()),
        })
    }
}

impl IntArg {
    /// The value if it lies in `min..=max`; else `ValueError` (`TypeError` if not an int) naming
    /// `name` and the range.
    pub(crate) fn in_range(&self, name: &str, min: i128, max: i128) -> PyResult<i128> {
        let range = format!("{name} must be an int between {min} and {max}");
        match self {
            IntArg::Int(value) if (min..=max).contains(value) => Ok(*value),
            IntArg::Int(value) => Err(PyValueError::new_err(format!("{range}, got {value}"))),
            IntArg::Huge(text) => Err(PyValueError::new_err(format!("{range}, got {text}"))),
            IntArg::NotInt(type_name) => Err(PyTypeError::new_err(format!("{range}, got {type_name}"))),
        }
    }
}

/// Rows of a float64 array of shape (n, N), each checked to be finite.
fn finite_rows<const N: usize>(obj: &Bound<'_, PyAny>, name: &str, rows: Option<usize>) -> PyResult<Vec<[f64; N]>> {
    let py = obj.py();
    let array = checked_array(obj, name, numpy::dtype::<f64>(py), &[rows, Some(N)])?;
    let array = array.downcast::<PyArray2<f64>>()?.readonly();
    let view = array.as_array();
    let mut out = Vec::with_capacity(view.nrows());
    for (i, row) in view.rows().into_iter().enumerate() {
        let values: [f64; N] = std::array::from_fn(|k| row[k]);
        if !values.iter().all(|v| v.is_finite()) {
            return Err(PyValueError::new_err(format!("{name}[{i}] must be finite, got {values:?}")));
        }
        out.push(values);
    }
    Ok(out)
}

/// Rows of a float64 array of shape (n, 3) as vectors, each checked to be finite.
pub(crate) fn vectors(obj: &Bound<'_, PyAny>, name: &str, rows: Option<usize>) -> PyResult<Vec<DVec3>> {
    Ok(finite_rows::<3>(obj, name, rows)?.into_iter().map(DVec3::from_array).collect())
}

/// Rows of a float64 array of shape (n, 4) as quaternions (x, y, z, w), each checked to be finite
/// (whether one is a rotation, non-zero, is the core's check).
pub(crate) fn quaternions(obj: &Bound<'_, PyAny>, name: &str, rows: Option<usize>) -> PyResult<Vec<DQuat>> {
    Ok(finite_rows::<4>(obj, name, rows)?.into_iter().map(DQuat::from_array).collect())
}

/// A float64 array of shape (N,), checked to be finite.
pub(crate) fn finite_row<const N: usize>(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<[f64; N]> {
    let py = obj.py();
    let array = checked_array(obj, name, numpy::dtype::<f64>(py), &[Some(N)])?;
    let array = array.downcast::<PyArray1<f64>>()?.readonly();
    let view = array.as_array();
    let values: [f64; N] = std::array::from_fn(|k| view[k]);
    if !values.iter().all(|v| v.is_finite()) {
        return Err(PyValueError::new_err(format!("{name} must be finite, got {values:?}")));
    }
    Ok(values)
}

/// A float64 array of shape (n,), each value checked to be finite and > 0.
pub(crate) fn positive_values(obj: &Bound<'_, PyAny>, name: &str, rows: usize) -> PyResult<Vec<f64>> {
    let py = obj.py();
    let array = checked_array(obj, name, numpy::dtype::<f64>(py), &[Some(rows)])?;
    let array = array.downcast::<PyArray1<f64>>()?.readonly();
    let values: Vec<f64> = array.as_array().iter().copied().collect();
    if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v > 0.0)) {
        return Err(PyValueError::new_err(format!("{name}[{i}] must be a finite number > 0, got {v}")));
    }
    Ok(values)
}

/// An array error for an argument that also accepts `alternative`: the message says so, the
/// exception type (TypeError or ValueError) stays.
pub(crate) fn also_accepts(py: Python<'_>, error: PyErr, alternative: &str) -> PyErr {
    let message = error.value(py).to_string().replacen("must be", &format!("must be {alternative} or"), 1);
    if error.is_instance_of::<PyTypeError>(py) {
        PyTypeError::new_err(message)
    } else {
        PyValueError::new_err(message)
    }
}

/// The box: a cube side (a number) or a float64 array [[min x, y, z], [max x, y, z]].
pub(crate) fn bounds(obj: &Bound<'_, PyAny>) -> PyResult<BoxBounds> {
    if !obj.is_instance_of::<PyUntypedArray>() {
        if let Ok(side) = obj.extract::<f64>() {
            return BoxBounds::cube(side).map_err(|_| {
                PyValueError::new_err(format!(
                    "box as a number is the side of the cube [0, side]^3 and must be finite and > 0, got {side}"
                ))
            });
        }
    }
    let py = obj.py();
    let array = checked_array(obj, "box", numpy::dtype::<f64>(py), &[Some(2), Some(3)])
        .map_err(|e| also_accepts(py, e, "a number (cube side)"))?;
    let array = array.downcast::<PyArray2<f64>>()?.readonly();
    let v = array.as_array();
    BoxBounds::new(DVec3::new(v[[0, 0]], v[[0, 1]], v[[0, 2]]), DVec3::new(v[[1, 0]], v[[1, 1]], v[[1, 2]]))
        .map_err(value_error)
}

/// Spheres from the column arrays, each checked (and checked to fit in `bounds`) before any is used.
pub(crate) fn spheres(
    positions: &Bound<'_, PyAny>,
    velocities: &Bound<'_, PyAny>,
    radii: &Bound<'_, PyAny>,
    masses: Option<&Bound<'_, PyAny>>,
    bounds: &BoxBounds,
) -> PyResult<Vec<Sphere>> {
    let positions = vectors(positions, "positions", None)?;
    let n = positions.len();
    let velocities = vectors(velocities, "velocities", Some(n))?;
    let radii = positive_values(radii, "radii", n)?;
    let masses = match masses {
        Some(m) => positive_values(m, "masses", n)?,
        None => vec![1.0; n],
    };
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (p, r) = (positions[i], radii[i]);
        if !bounds.contains(p, r) {
            return Err(PyValueError::new_err(format!(
                "positions[{i}] = {:?} with radii[{i}] = {r} must lie inside the box {:?}..{:?} (on a periodic axis its centre must)",
                p.to_array(),
                bounds.min.to_array(),
                bounds.max.to_array()
            )));
        }
        out.push(Sphere { position: p, velocity: velocities[i], radius: r, mass: masses[i] });
    }
    Ok(out)
}

/// The periodic axes named by `axes`, letters among x, y and z (`"xyz"`, `"xy"`; `None` or `""`:
/// none).
pub(crate) fn periodic_axes(axes: Option<&str>) -> PyResult<[bool; 3]> {
    let mut periodic = [false; 3];
    for letter in axes.unwrap_or("").chars() {
        let Some(axis) = "xyz".find(letter) else {
            return Err(PyValueError::new_err(format!(
                "periodic must name axes among 'x', 'y' and 'z' (e.g. 'xyz'), got {:?}",
                axes.unwrap_or("")
            )));
        };
        if std::mem::replace(&mut periodic[axis], true) {
            return Err(PyValueError::new_err(format!("periodic names axis {letter:?} twice")));
        }
    }
    Ok(periodic)
}

fn parse_method(method: &str) -> PyResult<Method> {
    Method::ALL.into_iter().find(|m| m.name() == method).ok_or_else(|| {
        let names: Vec<String> = Method::ALL.iter().map(|m| format!("'{}'", m.name())).collect();
        PyValueError::new_err(format!("method must be one of {}, got {method:?}", names.join(", ")))
    })
}

fn parse_mode(mode: &str) -> PyResult<Mode> {
    match mode {
        "simulate" => Ok(Mode::Simulate),
        "detect" => Ok(Mode::Detect),
        _ => Err(PyValueError::new_err(format!("mode must be 'simulate' or 'detect', got {mode:?}"))),
    }
}

pub(crate) fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Simulate => "simulate",
        Mode::Detect => "detect",
    }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn config(
    method: &str,
    mode: &str,
    pool_axes: Option<IntArg>,
    phi: Option<f64>,
    restitution: f64,
    friction: f64,
    contact_duration: f64,
    threads: Option<IntArg>,
    contact_ends: bool,
    gravity: DVec3,
) -> PyResult<WorldConfig> {
    let pool_axes = pool_axes.map(|m| m.in_range("pool_axes", 3, MAX_AXES as i128).map(|m| m as usize)).transpose()?;
    // Any count that fits: the core uses no more threads than there are cores.
    let threads = threads.map(|n| n.in_range("threads", 1, usize::MAX as i128).map(|n| n as usize)).transpose()?;
    Ok(WorldConfig {
        method: parse_method(method)?,
        mode: parse_mode(mode)?,
        pool_axes,
        phi,
        restitution,
        friction,
        contact_duration,
        threads,
        contact_ends,
        gravity,
    })
}

pub(crate) fn vectors_array<'py>(py: Python<'py>, rows: &[DVec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flat_map(|v| v.to_array()).collect();
    Array2::from_shape_vec((rows.len(), 3), flat).expect("3 values per row").into_pyarray(py)
}
