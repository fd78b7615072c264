//! Python bindings of vadop: the `vadop._vadop` extension module.
//!
//! It owns the translation between numpy arrays and the core's types, and nothing else: every
//! physical rule stays in the `vadop` crate. Input is checked here first, row by row, so that a
//! bad argument raises `TypeError` (wrong type or dtype) or `ValueError` (wrong shape or value,
//! an int out of its range) naming the argument, the row and what was expected, before the world
//! is touched; lists and tuples are read with `numpy.asarray` where arrays are taken; whatever
//! the core still rejects (overlaps, absurd speeds, bad settings) becomes a `ValueError` with the
//! core's message. Body handles cross as ints, [`BodyHandle::to_bits`]. Stepping releases the GIL.

mod shapes;

use glam::{DQuat, DVec3};
use numpy::ndarray::{Array1, Array2};
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyArrayDescr, PyUntypedArray};
use pyo3::exceptions::{PyMemoryError, PyOverflowError, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex, MutexGuard, TryLockError};
use std::time::{Duration, Instant};
use vadop::axis_pool::MAX_AXES;
use vadop::bounding_volume::interval;
use vadop::collapse::DEFAULT_CONTACT_DURATION;
use vadop::memory;
use vadop::scene::{PaperScene, MAX_SCENE_BODIES};
use vadop::shape::ShapeGeometry;
use vadop::{
    Body, BodyHandle, BodyShape, BoxBounds, Contact, Method, Mode, ShapeId, Sphere, Touched, VadopError, World,
    WorldConfig,
};

/// Names of the six walls, indexed by the `wall` column of [`Contacts`].
const WALLS: [&str; 6] = ["min_x", "max_x", "min_y", "max_y", "min_z", "max_z"];

/// How long a call steps without the GIL before it looks at signals (Ctrl-C).
const SIGNAL_CHECK: Duration = Duration::from_millis(50);
/// How long a step's caller waits for it without sleeping.
const BUSY_WAIT: Duration = Duration::from_micros(200);

fn value_error(e: VadopError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// `MemoryError` unless `bytes` fit in the memory left; `what` names the request.
fn check_memory(what: &str, bytes: u64) -> PyResult<()> {
    memory::check(bytes).map_err(|shortfall| PyMemoryError::new_err(format!("{what} {shortfall}")))
}

/// `MemoryError` unless a world of `bodies` bodies fits in the memory left.
fn check_world_memory(bodies: usize) -> PyResult<()> {
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
fn checked_array<'py>(
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
enum IntArg {
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
    fn in_range(&self, name: &str, min: i128, max: i128) -> PyResult<i128> {
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
fn vectors(obj: &Bound<'_, PyAny>, name: &str, rows: Option<usize>) -> PyResult<Vec<DVec3>> {
    Ok(finite_rows::<3>(obj, name, rows)?.into_iter().map(DVec3::from_array).collect())
}

/// Rows of a float64 array of shape (n, 4) as quaternions (x, y, z, w), each checked to be finite
/// (whether one is a rotation, non-zero, is the core's check).
fn quaternions(obj: &Bound<'_, PyAny>, name: &str, rows: Option<usize>) -> PyResult<Vec<DQuat>> {
    Ok(finite_rows::<4>(obj, name, rows)?.into_iter().map(DQuat::from_array).collect())
}

/// A float64 array of shape (N,), checked to be finite.
fn finite_row<const N: usize>(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<[f64; N]> {
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
fn positive_values(obj: &Bound<'_, PyAny>, name: &str, rows: usize) -> PyResult<Vec<f64>> {
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
fn also_accepts(py: Python<'_>, error: PyErr, alternative: &str) -> PyErr {
    let message = error.value(py).to_string().replacen("must be", &format!("must be {alternative} or"), 1);
    if error.is_instance_of::<PyTypeError>(py) {
        PyTypeError::new_err(message)
    } else {
        PyValueError::new_err(message)
    }
}

/// Body ids as given: an int, or an int64 array (or a list or tuple of ints) of shape (k,).
/// [`live_handles`] checks that they name live bodies; an int too large for int64, in a list or
/// not, names no body: `ValueError`.
fn ids_of(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<i128>> {
    let no_body = |text: &str| PyValueError::new_err(format!("{name} must name live bodies, got {text}"));
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        // Python ints one by one, whatever their size; anything else goes to the array check.
        let mut ids = Vec::with_capacity(obj.len()?);
        for item in obj.try_iter()? {
            match item?.extract::<IntArg>()? {
                IntArg::Int(id) => ids.push(id),
                IntArg::Huge(text) => return Err(no_body(&text)),
                IntArg::NotInt(_) => break,
            }
        }
        if ids.len() == obj.len()? {
            return Ok(ids);
        }
    } else if !obj.is_instance_of::<PyUntypedArray>() {
        match obj.extract::<IntArg>()? {
            IntArg::Int(id) => return Ok(vec![id]),
            IntArg::Huge(text) => return Err(no_body(&text)),
            // Not an int: the array check below names what was expected.
            IntArg::NotInt(_) => {}
        }
    }
    let py = obj.py();
    let array =
        checked_array(obj, name, numpy::dtype::<i64>(py), &[None]).map_err(|e| also_accepts(py, e, "an int"))?;
    let array = array.downcast::<PyArray1<i64>>()?.readonly();
    Ok(array.as_array().iter().map(|&id| i128::from(id)).collect())
}

/// The box: a cube side (a number) or a float64 array [[min x, y, z], [max x, y, z]].
fn bounds(obj: &Bound<'_, PyAny>) -> PyResult<BoxBounds> {
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
fn spheres(
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
        if !((p - r).cmpge(bounds.min).all() && (p + r).cmple(bounds.max).all()) {
            return Err(PyValueError::new_err(format!(
                "positions[{i}] = {:?} with radii[{i}] = {r} must lie inside the box {:?}..{:?}",
                p.to_array(),
                bounds.min.to_array(),
                bounds.max.to_array()
            )));
        }
        out.push(Sphere { position: p, velocity: velocities[i], radius: r, mass: masses[i] });
    }
    Ok(out)
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

#[allow(clippy::too_many_arguments)]
fn config(
    method: &str,
    mode: &str,
    pool_axes: Option<IntArg>,
    phi: Option<f64>,
    restitution: f64,
    friction: f64,
    contact_duration: f64,
    threads: Option<IntArg>,
    contact_ends: bool,
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
    })
}

fn vectors_array<'py>(py: Python<'py>, rows: &[DVec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flat_map(|v| v.to_array()).collect();
    Array2::from_shape_vec((rows.len(), 3), flat).expect("3 values per row").into_pyarray(py)
}

/// The contacts of one or more frames, as columns in time order.
///
/// ``time`` (m,) float64 absolute times; ``i`` (m,) int64 the body's id (of a pair, the body of
/// the lower slot: the lower id, unless a slot was reused); ``j`` (m,) int64 the other body's id,
/// or -1 for a wall; ``wall`` (m,) int64 the wall's index in ``vadop.WALLS``, or -1 for a pair;
/// ``point`` and ``normal`` (m, 3) float64, the normal pointing from ``i`` towards what it
/// touched; ``impulse`` (m,) float64, 0 when not resolved.
///
/// >>> import vadop
/// >>> w = vadop.World([[2.0, 5, 5], [8, 5, 5]], [[30.0, 0, 0], [0, 0, 0]], [0.5, 0.5], box=10.0)
/// >>> c = w.step(0.2)
/// >>> len(c), c.point[0].round(6).tolist(), c.normal[0].tolist()
/// (1, [7.5, 5.0, 5.0], [1.0, 0.0, 0.0])
#[pyclass(frozen, get_all, module = "vadop._vadop")]
struct Contacts {
    time: Py<PyArray1<f64>>,
    i: Py<PyArray1<i64>>,
    j: Py<PyArray1<i64>>,
    wall: Py<PyArray1<i64>>,
    point: Py<PyArray2<f64>>,
    normal: Py<PyArray2<f64>>,
    impulse: Py<PyArray1<f64>>,
}

impl Contacts {
    fn new(py: Python<'_>, contacts: &[Contact]) -> Contacts {
        let column = |f: &dyn Fn(&Contact) -> f64| Array1::from_iter(contacts.iter().map(f)).into_pyarray(py).unbind();
        let index = |f: &dyn Fn(&Contact) -> i64| Array1::from_iter(contacts.iter().map(f)).into_pyarray(py).unbind();
        let points: Vec<DVec3> = contacts.iter().map(|c| c.point).collect();
        let normals: Vec<DVec3> = contacts.iter().map(|c| c.normal).collect();
        Contacts {
            time: column(&|c| c.time),
            i: index(&|c| handle_id(c.body)),
            j: index(&|c| match c.touched {
                Touched::Body(j) => handle_id(j),
                Touched::Wall(_) => -1,
            }),
            wall: index(&|c| match c.touched {
                Touched::Body(_) => -1,
                Touched::Wall(w) => w as i64,
            }),
            point: vectors_array(py, &points).unbind(),
            normal: vectors_array(py, &normals).unbind(),
            impulse: column(&|c| c.impulse),
        }
    }
}

#[pymethods]
impl Contacts {
    fn __len__(&self, py: Python<'_>) -> usize {
        self.time.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let walls = self.wall.bind(py).readonly().as_array().iter().filter(|&&w| w >= 0).count();
        let n = self.time.bind(py).len();
        format!("<Contacts: {} body-body, {} wall>", n - walls, walls)
    }
}

/// Bodies in a box, stepped frame by frame; every contact inside a frame is found, in time order.
/// Bodies are spheres (given here or with ``add``) or rigid bodies of any shape (``add_shape``,
/// then ``add_bodies``, or ``add_static`` for fixed level geometry).
///
/// Spheres are given as numpy columns: ``positions`` and ``velocities`` float64 (n, 3), ``radii``
/// and ``masses`` float64 (n,) (``masses`` defaults to 1). ``box`` is a cube side or a float64
/// array ``[[min x, y, z], [max x, y, z]]``. Lists and tuples of numbers (ints too) are taken
/// wherever an array is, read with ``numpy.asarray``; numpy arrays must have the dtype itself.
///
/// Settings: ``method`` ('auto', the fastest broad phase for the scene; 'vadop', the paper's
/// velocity-aligned sweep and prune; 'grid'; 'brute' — every pair, the oracle —; 'discrete' —
/// overlap checks at frame instants only — or the continuous baselines 'swept-aabb' and
/// 'swept-kdop'), ``mode`` ('simulate' or 'detect': bodies pass through each other and bounce
/// only off the walls), ``pool_axes`` (None picks the engine's default, else an int in
/// 3..=100000), ``phi`` in radians (None: the pool's covering radius), ``restitution`` in [0, 1],
/// ``friction`` (the Coulomb coefficient of every impact, >= 0; 0: frictionless) and
/// ``contact_duration`` (seconds; with restitution below 1, a contact within this time of a
/// body's previous one is elastic — the TC model that ends inelastic collapse) and ``threads``
/// (how many threads a step shares its work among, at least 1, and no more than the cores are
/// used; None: every core; results are bit-identical whatever the number) and ``contact_ends`` (detect mode only: also report when
/// each contact between bodies ends, ``contact_ends()``, and keep the pairs in contact,
/// ``touching()`` — started and stopped events).
///
/// Bodies are named by int ids, 0, 1, 2 ... in row order. A removed body's slot is reused by a
/// later body (lowest slot first) under a new id, the slot plus 2**32 per reuse (the core's
/// ``BodyHandle``: ``generation << 32 | slot``), so a removed body's id never names another body:
/// it raises ``ValueError`` wherever ids are taken. Arrays read back (``positions``,
/// ``velocities`` ...) hold every live body, of any shape, static ones too, in ascending slot
/// order (``ids``).
///
/// >>> import numpy as np, vadop
/// >>> w = vadop.World(np.array([[2.0, 5, 5], [8, 5, 5]]), np.array([[30.0, 0, 0], [0, 0, 0]]),
/// ...                 np.array([0.5, 0.5]), box=10.0)
/// >>> c = w.step(0.25)
/// >>> int(c.i[0]), int(c.j[0]), round(float(c.time[0]), 6)
/// (0, 1, 0.166667)
///
/// Lists work as well:
///
/// >>> w = vadop.World([[2, 5, 5], [8, 5, 5]], [[30, 0, 0], [0, 0, 0]], [0.5, 0.5], box=10)
/// >>> len(w.step(0.2))
/// 1
///
/// Threads may share a world: calls on it take turns (``step`` is serialised by a lock inside
/// the world, never ``RuntimeError: Already borrowed``). A thread that calls while another steps
/// waits, without holding the GIL, until that step is done.
#[pyclass(name = "World", module = "vadop._vadop", frozen)]
struct PyWorld {
    state: Mutex<World>,
}

/// Python's shape ids are the core's [`ShapeId`] indices: dense, 0, 1, 2 ... in the order
/// `add_shape` made them.
trait PyShapeIds {
    fn shape_id(&self, number: i128, name: &str) -> PyResult<ShapeId>;
    fn moving_shape_id(&self, number: i128, name: &str) -> PyResult<ShapeId>;
    fn shape_number(&self, body: &Body) -> i64;
    fn geometry(&self, body: &Body) -> Option<&ShapeGeometry>;
    fn radius(&self, body: &Body) -> f64;
    fn centre_of_mass(&self, body: &Body) -> DVec3;
}

impl PyShapeIds for World {
    /// The core's id of the shape Python calls `number`; `name` names the argument in messages.
    fn shape_id(&self, number: i128, name: &str) -> PyResult<ShapeId> {
        let found = usize::try_from(number).ok().and_then(|k| self.shapes().nth(k));
        found.map(|(id, _)| id).ok_or_else(|| {
            let ids = match self.shapes().count() {
                0 => "this world has none yet".to_string(),
                n => format!("0 to {}", n - 1),
            };
            PyValueError::new_err(format!("{name} must be a shape id from add_shape ({ids}), got {number}"))
        })
    }

    /// [`PyShapeIds::shape_id`] of a shape a moving body can take: not level geometry.
    fn moving_shape_id(&self, number: i128, name: &str) -> PyResult<ShapeId> {
        let id = self.shape_id(number, name)?;
        if self.shape(id).map_err(value_error)?.is_static_only() {
            return Err(PyValueError::new_err(format!(
                "{name} = {number} is level geometry (a triangle mesh or a half-space): add it with add_static"
            )));
        }
        Ok(id)
    }

    /// The Python id of `body`'s shape; -1 for a body added as a plain sphere.
    fn shape_number(&self, body: &Body) -> i64 {
        match body.shape {
            BodyShape::Sphere { .. } => -1,
            BodyShape::Shape(id) => i64::from(id.index()),
        }
    }

    /// The geometry of `body`'s shape; `None` for a plain sphere.
    fn geometry(&self, body: &Body) -> Option<&ShapeGeometry> {
        match body.shape {
            BodyShape::Sphere { .. } => None,
            BodyShape::Shape(id) => self.shape(id).ok(),
        }
    }

    /// A sphere's radius; another shape's bounding radius (about its centre of mass); infinite
    /// for level geometry, which no sphere bounds.
    fn radius(&self, body: &Body) -> f64 {
        match (body.shape, self.geometry(body)) {
            (BodyShape::Sphere { radius }, _) => radius,
            (_, geometry) => geometry.and_then(|g| g.bounding_radius()).unwrap_or(f64::INFINITY),
        }
    }

    /// Where `body`'s centre of mass is: its shape's origin moved by the shape's offset from it
    /// (see `vadop::shape`'s frames).
    fn centre_of_mass(&self, body: &Body) -> DVec3 {
        match self.geometry(body) {
            None => body.position,
            Some(g) => {
                let offset = g.body_from_shape();
                let principal = body.orientation * offset.rotation.inverse();
                body.position - principal * offset.translation
            }
        }
    }
}

#[pymethods]
impl PyWorld {
    #[new]
    #[pyo3(signature = (positions = None, velocities = None, radii = None, masses = None, *, r#box, method = "auto", mode = "simulate", pool_axes = None, phi = None, restitution = 1.0, friction = 0.0, contact_duration = 1e-5, threads = None, contact_ends = false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        positions: Option<&Bound<'_, PyAny>>,
        velocities: Option<&Bound<'_, PyAny>>,
        radii: Option<&Bound<'_, PyAny>>,
        masses: Option<&Bound<'_, PyAny>>,
        r#box: &Bound<'_, PyAny>,
        method: &str,
        mode: &str,
        pool_axes: Option<IntArg>,
        phi: Option<f64>,
        restitution: f64,
        friction: f64,
        contact_duration: f64,
        threads: Option<IntArg>,
        contact_ends: bool,
    ) -> PyResult<PyWorld> {
        let bounds = bounds(r#box)?;
        let config =
            config(method, mode, pool_axes, phi, restitution, friction, contact_duration, threads, contact_ends)?;
        let spheres = match (positions, velocities, radii) {
            (Some(p), Some(v), Some(r)) => spheres(p, v, r, masses, &bounds)?,
            (None, None, None) if masses.is_none() => Vec::new(),
            given => {
                let names = ["positions", "velocities", "radii"];
                let present = [given.0.is_some(), given.1.is_some(), given.2.is_some()];
                let missing: Vec<&str> = names.iter().zip(present).filter(|(_, p)| !p).map(|(n, _)| *n).collect();
                let missing = match missing.split_last() {
                    Some((last, [])) => last.to_string(),
                    Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
                    None => unreachable!("all three given is the first arm"),
                };
                return Err(PyTypeError::new_err(format!(
                    "World() missing {missing}: spheres need positions, velocities and radii (give none of them \
                     for a world with no spheres yet)"
                )));
            }
        };
        check_world_memory(spheres.len())?;
        let mut world = World::new(bounds, config).map_err(value_error)?;
        world.add_spheres(&spheres).map_err(value_error)?;
        Ok(PyWorld { state: Mutex::new(world) })
    }

    /// Adds bodies (all or none) and returns their ids as an int64 array; the arguments are
    /// those of ``World`` (arrays, lists or tuples). Slots of removed bodies are taken first, each
    /// under a new id.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[2.0, 2, 2]], [[0.0, 0, 0]], [0.5], box=10.0)
    /// >>> w.add([[5.0, 5, 5], [8, 8, 8]], [[1.0, 0, 0], [0, 1, 0]], [0.5, 0.25]).tolist()
    /// [1, 2]
    #[pyo3(signature = (positions, velocities, radii, masses = None))]
    fn add<'py>(
        &self,
        py: Python<'py>,
        positions: &Bound<'py, PyAny>,
        velocities: &Bound<'py, PyAny>,
        radii: &Bound<'py, PyAny>,
        masses: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let bounds = self.lock(py)?.bounds();
        let spheres = spheres(positions, velocities, radii, masses, &bounds)?;
        check_world_memory(spheres.len())?;
        let added = self.lock(py)?.add_spheres(&spheres).map_err(value_error)?;
        Ok(Array1::from_iter(added.into_iter().map(handle_id)).into_pyarray(py))
    }

    /// Adds a shape that bodies can then take and returns its id (0, 1, 2 ... in the order
    /// shapes are added); ``kind`` and its parameters, all sizes in the shape's own frame:
    ///
    /// - ``"sphere"``: ``radius``;
    /// - ``"cuboid"``: ``half_extents`` (3,);
    /// - ``"capsule"``, ``"cylinder"``, ``"cone"``: ``half_height`` and ``radius``, along the
    ///   shape's y axis (a cone's apex at ``+half_height``);
    /// - ``"convex_hull"``: ``points`` float64 (n, 3), at least 4 not all in one plane;
    /// - ``"trimesh"``: ``vertices`` float64 (n, 3) and ``triangles`` int64 (m, 3) indices into
    ///   them: level geometry (a surface, static bodies only);
    /// - ``"halfspace"``: ``normal`` (3,), pointing out of the solid half-space behind the plane
    ///   through the shape's origin: level geometry.
    ///
    /// An unknown kind raises ``ValueError``; a missing or unexpected parameter, or one of the
    /// wrong type, ``TypeError`` naming it; a bad value (a size <= 0, a flat hull, a triangle
    /// index past the vertices) ``ValueError`` saying what is wrong. Runs without the GIL (a
    /// hull or a large mesh takes a while to build).
    ///
    /// >>> import vadop
    /// >>> w = vadop.World(box=10.0)
    /// >>> w.add_shape("cuboid", half_extents=[1.0, 0.5, 0.25]), w.add_shape("capsule", half_height=1.0, radius=0.2)
    /// (0, 1)
    /// >>> w.add_shape("capsule", half_height=1.0)
    /// Traceback (most recent call last):
    /// ...
    /// TypeError: add_shape('capsule') missing keyword argument 'radius'; a 'capsule' takes half_height, radius
    #[pyo3(signature = (kind, **params))]
    fn add_shape(&self, py: Python<'_>, kind: &str, params: Option<&Bound<'_, PyDict>>) -> PyResult<usize> {
        let shape = shapes::parse(kind, params)?;
        let mut state = self.lock(py)?;
        let world = &mut *state;
        let id = py.allow_threads(|| world.add_shape(shape)).map_err(value_error)?;
        Ok(id.index() as usize)
    }

    /// The shapes added so far, in id order, each as the keyword arguments of ``add_shape`` that
    /// make it: ``kind`` and its parameters (vectors and points as float64 arrays, triangles as
    /// int64), so ``add_shape(**shape)`` makes it again.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World(box=10.0)
    /// >>> _ = w.add_shape("cone", half_height=1.0, radius=0.5)
    /// >>> w.shapes()
    /// [{'kind': 'cone', 'half_height': 1.0, 'radius': 0.5}]
    fn shapes<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let state = self.lock(py)?;
        state.shapes().map(|(_, geometry)| shapes::describe(py, geometry.shape())).collect()
    }

    /// The surface of shape ``shape`` as triangles, for drawing: ``(vertices, triangles)``,
    /// float64 (v, 3) points in the shape's own frame and int64 (t, 3) indices into them,
    /// counter-clockwise seen from outside. Exact for cuboids, convex hulls and meshes; round
    /// surfaces have 24 segments around. A half-space, unbounded, raises ``ValueError``.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World(box=10.0)
    /// >>> vertices, triangles = w.shape_surface(w.add_shape("cuboid", half_extents=[1.0, 2, 3]))
    /// >>> vertices.max(axis=0).tolist(), triangles.shape
    /// ([1.0, 2.0, 3.0], (12, 3))
    #[allow(clippy::type_complexity)]
    fn shape_surface<'py>(
        &self,
        py: Python<'py>,
        shape: IntArg,
    ) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>)> {
        let state = self.lock(py)?;
        let number = shape_number(&shape, "shape")?;
        let geometry = state.shape(state.shape_id(number, "shape")?).map_err(value_error)?;
        let Some((vertices, triangles)) = shapes::surface(geometry) else {
            return Err(PyValueError::new_err(format!(
                "shape {number} is a half-space: it is unbounded and has no surface to draw"
            )));
        };
        Ok((vectors_array(py, &vertices), shapes::triangles_array(py, &triangles)))
    }

    /// Adds moving rigid bodies of the world's shapes (all or none) and returns their ids, int64.
    ///
    /// ``shapes`` is one shape id for every body or an int64 (n,) array of them; ``positions``
    /// float64 (n, 3) place each shape's own origin (for a cone or a hull, not its centre of
    /// mass); ``velocities`` float64 (n, 3) are those of the centres of mass (default 0);
    /// ``orientations`` float64 (n, 4) quaternions (x, y, z, w) rotating the shape's frame to the
    /// world's, any non-zero length (default: the identity); ``angular_velocities`` float64
    /// (n, 3) in world axes, radians per second (default 0); ``masses`` float64 (n,) (default
    /// 1), the inertia following from the shape. Lists and tuples work as elsewhere. Level
    /// geometry (a mesh, a half-space) goes to ``add_static`` instead; the discrete method takes
    /// spheres only. Runs without the GIL.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[2.0, 5, 5]], [[0.0, 0, 0]], [0.5], box=10.0, mode="detect")
    /// >>> brick = w.add_shape("cuboid", half_extents=[0.5, 0.25, 0.25])
    /// >>> w.add_bodies(brick, [[5.0, 5, 5], [8, 5, 5]], velocities=[[-10.0, 0, 0], [0, 0, 0]],
    /// ...              angular_velocities=[[0.0, 0, 3], [0, 0, 0]]).tolist()
    /// [1, 2]
    /// >>> w.shape_ids.tolist(), w.radii.round(3).tolist()   # a plain sphere has shape -1
    /// ([-1, 0, 0], [0.5, 0.612, 0.612])
    /// >>> c = w.step(0.3)                                  # the spinning brick reaches the ball
    /// >>> c.i.tolist(), c.j.tolist()
    /// ([0], [1])
    #[pyo3(signature = (shapes, positions, velocities = None, orientations = None, angular_velocities = None, masses = None))]
    #[allow(clippy::too_many_arguments)]
    fn add_bodies<'py>(
        &self,
        py: Python<'py>,
        shapes: &Bound<'py, PyAny>,
        positions: &Bound<'py, PyAny>,
        velocities: Option<&Bound<'py, PyAny>>,
        orientations: Option<&Bound<'py, PyAny>>,
        angular_velocities: Option<&Bound<'py, PyAny>>,
        masses: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let positions = vectors(positions, "positions", None)?;
        let n = positions.len();
        let shapes = ShapeNumbers::of(shapes, n)?;
        let vectors_or_zero = |obj: Option<&Bound<'py, PyAny>>, name: &str| match obj {
            Some(obj) => vectors(obj, name, Some(n)),
            None => Ok(vec![DVec3::ZERO; n]),
        };
        let velocities = vectors_or_zero(velocities, "velocities")?;
        let angular_velocities = vectors_or_zero(angular_velocities, "angular_velocities")?;
        let orientations = match orientations {
            Some(obj) => quaternions(obj, "orientations", Some(n))?,
            None => vec![DQuat::IDENTITY; n],
        };
        let masses = match masses {
            Some(obj) => positive_values(obj, "masses", n)?,
            None => vec![1.0; n],
        };
        check_world_memory(n)?;
        let mut state = self.lock(py)?;
        let shapes = shapes.ids(&state, n)?;
        let bodies: Vec<Body> = (0..n)
            .map(|k| Body {
                shape: BodyShape::Shape(shapes[k]),
                position: positions[k],
                orientation: orientations[k],
                velocity: velocities[k],
                angular_velocity: angular_velocities[k],
                mass: masses[k],
            })
            .collect();
        let world = &mut *state;
        let added = py.allow_threads(|| world.add_bodies(&bodies)).map_err(value_error)?;
        Ok(Array1::from_iter(added.into_iter().map(handle_id)).into_pyarray(py))
    }

    /// Adds a static body and returns its id: level geometry (a triangle mesh, a half-space) or
    /// any shape fixed in place, at ``position`` (float64 (3,), the shape's origin) turned by
    /// ``orientation`` (float64 (4,), x, y, z, w; default: the identity). It never moves, has
    /// infinite mass and may reach beyond the box; moving bodies bounce off it, in detect mode too.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[5.0, 5, 5]], [[0.0, 0, -4]], [0.5], box=10.0)
    /// >>> floor = w.add_static(w.add_shape("halfspace", normal=[0.0, 0, 1]), [0.0, 0, 2])
    /// >>> c = w.step(1.0)                       # the ball's bottom reaches z = 2 at t = 2.5 / 4
    /// >>> c.j.tolist() == [floor], round(float(c.time[0]), 6), w.velocities.tolist()
    /// (True, 0.625, [[0.0, 0.0, 4.0], [0.0, 0.0, 0.0]])
    /// >>> w.static.tolist(), w.masses.tolist()
    /// ([False, True], [1.0, inf])
    #[pyo3(signature = (shape, position, orientation = None))]
    fn add_static(
        &self,
        py: Python<'_>,
        shape: IntArg,
        position: &Bound<'_, PyAny>,
        orientation: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<i64> {
        let number = shape_number(&shape, "shape")?;
        let position = DVec3::from_array(finite_row(position, "position")?);
        let orientation = match orientation {
            Some(obj) => DQuat::from_array(finite_row(obj, "orientation")?),
            None => DQuat::IDENTITY,
        };
        let mut state = self.lock(py)?;
        let id = state.shape_id(number, "shape")?;
        state.add_static(id, position, orientation).map(handle_id).map_err(value_error)
    }

    /// Removes bodies of any shape by id (an int, or an int64 array, list or tuple of ints), all
    /// or none. Their ids are stale from then on: a body added later may take the slot, under a
    /// new id.
    ///
    /// >>> import vadop
    /// >>> w = vadop.scene(10)
    /// >>> w.remove([0, 3])
    /// >>> w.ids.tolist()
    /// [1, 2, 4, 5, 6, 7, 8, 9]
    /// >>> w.add([[1.0, 1, 1]], [[0.0, 0, 0]], [0.5]).tolist()   # slot 0 again, generation 1
    /// [4294967296]
    /// >>> w.remove(0)
    /// Traceback (most recent call last):
    /// ...
    /// ValueError: ids must name live bodies, got 0: that body was removed; its slot now holds 4294967296
    fn remove(&self, py: Python<'_>, ids: &Bound<'_, PyAny>) -> PyResult<()> {
        let ids = ids_of(ids, "ids")?;
        let mut state = self.lock(py)?;
        for handle in live_handles(&state, &ids, "ids")? {
            state.remove_body(handle).map_err(value_error)?;
        }
        Ok(())
    }

    /// Sets the velocities of moving bodies ``ids`` (an int, or k ids as for ``remove``) to the
    /// rows of ``velocities`` (float64 (k, 3), or lists), all or none; they go on spinning as
    /// they did.
    ///
    /// >>> import vadop
    /// >>> w = vadop.scene(10)
    /// >>> w.set_velocities(4, [[1.0, 2.0, 3.0]])
    /// >>> w.velocities[4].tolist()
    /// [1.0, 2.0, 3.0]
    fn set_velocities(&self, py: Python<'_>, ids: &Bound<'_, PyAny>, velocities: &Bound<'_, PyAny>) -> PyResult<()> {
        let ids = ids_of(ids, "ids")?;
        let velocities = vectors(velocities, "velocities", Some(ids.len()))?;
        let mut state = self.lock(py)?;
        let handles = moving_handles(&state, &ids, "ids")?;
        state.set_velocities(&handles, &velocities).map_err(value_error)
    }

    /// Sets the velocities and angular velocities (world axes, radians per second) of moving
    /// bodies ``ids`` (as for ``set_velocities``) to the rows of ``velocities`` and
    /// ``angular_velocities`` (float64 (k, 3) each), all or none. A sphere spins too: friction
    /// acts on its spin.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[5.0, 5, 5]], [[0.0, 0, 0]], [0.5], box=10.0)
    /// >>> w.set_motions(0, [[1.0, 0, 0]], [[0.0, 0, 2.0]])
    /// >>> w.velocities.tolist(), w.angular_velocities.tolist()
    /// ([[1.0, 0.0, 0.0]], [[0.0, 0.0, 2.0]])
    fn set_motions(
        &self,
        py: Python<'_>,
        ids: &Bound<'_, PyAny>,
        velocities: &Bound<'_, PyAny>,
        angular_velocities: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let ids = ids_of(ids, "ids")?;
        let velocities = vectors(velocities, "velocities", Some(ids.len()))?;
        let angular_velocities = vectors(angular_velocities, "angular_velocities", Some(ids.len()))?;
        let mut state = self.lock(py)?;
        let handles = moving_handles(&state, &ids, "ids")?;
        state.set_motions(&handles, &velocities, &angular_velocities).map_err(value_error)
    }

    /// Advances the world by ``dt`` and returns the frame's contacts in time order. Runs without
    /// the GIL; a Ctrl-C, before it starts or while it runs (within 50 ms, however long the
    /// step), raises ``KeyboardInterrupt`` and leaves the world as it was before the step. Steps
    /// are serialised: another thread's call on this world waits (without the GIL) until the
    /// step is done.
    ///
    /// >>> import vadop
    /// >>> w = vadop.scene(500, 0.1, 2.0)
    /// >>> contacts = w.step(1 / 30)
    /// >>> round(w.time, 6), len(contacts) > 0
    /// (0.033333, True)
    fn step(&self, py: Python<'_>, dt: f64) -> PyResult<Contacts> {
        py.check_signals()?;
        let contacts = py.allow_threads(|| {
            let mut state = self.state.lock().map_err(|_| poisoned())?;
            interruptible(&mut state, |world| world.step(dt).map(|c| c.to_vec()).map_err(value_error))
        })?;
        Ok(Contacts::new(py, &contacts))
    }

    /// The contacts between bodies that ended in the last frame, in time order: when the two part,
    /// where they last touched, impulse 0. Empty unless the world was made with
    /// ``contact_ends=True`` (detect mode).
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[2.0, 5, 5], [8, 5, 5]], [[1.5, 0, 0], [-1.5, 0, 0]], [0.5, 0.5], box=10.0,
    /// ...                 mode="detect", contact_ends=True)
    /// >>> [round(float(t), 6) for t in w.step(2.0).time], w.touching().tolist()
    /// ([1.666667], [[0, 1]])
    /// >>> _ = w.step(1.0)
    /// >>> [round(float(t), 6) for t in w.contact_ends().time], w.touching().tolist()
    /// ([2.333333], [])
    fn contact_ends(&self, py: Python<'_>) -> PyResult<Contacts> {
        let ends = self.lock(py)?.contact_ends().to_vec();
        Ok(Contacts::new(py, &ends))
    }

    /// The pairs of bodies in contact now, an int64 (k, 2) array of ids, ascending: those whose
    /// contact started and has not ended. Empty unless the world was made with
    /// ``contact_ends=True``.
    fn touching<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let pairs = self.lock(py)?.touching();
        let flat: Vec<i64> = pairs.iter().flat_map(|&(a, b)| [handle_id(a), handle_id(b)]).collect();
        Ok(Array2::from_shape_vec((pairs.len(), 2), flat).expect("2 ids per row").into_pyarray(py))
    }

    /// Ids of the live bodies, int64, ascending by slot (the row order of every array read back).
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        Ok(Array1::from_vec(self.per_body(py, |_, handle, _| handle_id(handle))?).into_pyarray(py))
    }

    /// Positions now, float64 (n, 3): a sphere's centre, another shape's own origin (for a cone
    /// or a convex hull, not its centre of mass).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(vectors_array(py, &self.per_body(py, |_, _, body| body.position)?))
    }

    /// Velocities of the centres of mass now, float64 (n, 3).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(vectors_array(py, &self.per_body(py, |_, _, body| body.velocity)?))
    }

    /// Radii, float64 (n,): a sphere's radius (a plain sphere's, or a ``"sphere"`` shape's);
    /// for another shape its bounding radius, that of the smallest sphere about its centre of
    /// mass that holds it (all the broad phase sees of a shape); ``inf`` for level geometry
    /// (meshes, half-spaces), which no sphere bounds.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(Array1::from_vec(self.per_body(py, |state, _, body| state.radius(body))?).into_pyarray(py))
    }

    /// Masses, float64 (n,): ``inf`` for static bodies.
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(Array1::from_vec(self.per_body(py, |_, _, body| body.mass)?).into_pyarray(py))
    }

    /// Orientations now, float64 (n, 4): unit quaternions (x, y, z, w) rotating each shape's own
    /// frame to the world's (a quaternion and its negative are the same rotation).
    #[getter]
    fn orientations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows = self.per_body(py, |_, _, body| body.orientation.to_array())?;
        Ok(Array2::from_shape_vec((rows.len(), 4), rows.concat()).expect("4 values per row").into_pyarray(py))
    }

    /// Angular velocities now, float64 (n, 3), world axes, radians per second (a free body
    /// keeps its angular momentum, so an asymmetric one's angular velocity changes as it tumbles).
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        Ok(vectors_array(py, &self.per_body(py, |_, _, body| body.angular_velocity)?))
    }

    /// Shape ids, int64 (n,): the ``add_shape`` id of each body's shape, -1 for a body added as a
    /// plain sphere (``World(...)``, ``add``).
    #[getter]
    fn shape_ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<i64>>> {
        Ok(Array1::from_vec(self.per_body(py, |state, _, body| state.shape_number(body))?).into_pyarray(py))
    }

    /// Which bodies are static (``add_static``), bool (n,).
    #[getter(r#static)]
    fn is_static<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<bool>>> {
        Ok(Array1::from_vec(self.per_body(py, |_, _, body| !body.mass.is_finite())?).into_pyarray(py))
    }

    /// The box as float64 [[min x, y, z], [max x, y, z]].
    #[getter(r#box)]
    fn get_box<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let b = self.lock(py)?.bounds();
        Ok(vectors_array(py, &[b.min, b.max]))
    }

    /// Simulation time now.
    #[getter]
    fn time(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.time())
    }

    /// The method's name: 'vadop', 'brute', 'discrete', 'swept-aabb', 'swept-kdop' or 'grid'.
    #[getter]
    fn method(&self, py: Python<'_>) -> PyResult<&'static str> {
        Ok(self.lock(py)?.config().method.name())
    }

    /// 'simulate' or 'detect'.
    #[getter]
    fn mode(&self, py: Python<'_>) -> PyResult<&'static str> {
        Ok(mode_name(self.lock(py)?.config().mode))
    }

    /// Number of axes in the pool.
    #[getter]
    fn pool_axes(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.lock(py)?.pool().len())
    }

    /// The alignment angle phi in use, in radians.
    #[getter]
    fn phi(&self, py: Python<'_>) -> PyResult<f64> {
        let world = &*self.lock(py)?;
        Ok(world.config().phi.unwrap_or(world.pool().covering_radius()))
    }

    /// Coefficient of restitution.
    #[getter]
    fn restitution(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.config().restitution)
    }

    /// The pool's axes as unit vectors, float64 (pool_axes, 3).
    #[getter]
    fn axes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let pool = self.lock(py)?.pool().clone();
        Ok(vectors_array(py, pool.axes()))
    }

    /// Statistics of the last frame: seconds per stage (update, sort, test, response, total) and
    /// counters (broad-phase windows, endpoint swaps, list entries, candidate pairs, narrow tests,
    /// re-tests, contacts, pair contacts, invalidations, broad-phase bytes) and the contacts whose
    /// physics a rule changed (``tc_contacts``: made elastic by the TC model; ``jam_contacts``:
    /// resolved by the jam rule).
    ///
    /// >>> import vadop
    /// >>> w = vadop.scene(300, 0.1, 2.0)
    /// >>> _ = w.step(1 / 30)
    /// >>> s = w.stats()
    /// >>> s["contacts"] >= s["pair_contacts"], s["total_seconds"] > 0
    /// (True, True)
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = *self.lock(py)?.stats();
        let d = PyDict::new(py);
        d.set_item("update_seconds", s.update_seconds)?;
        d.set_item("sort_seconds", s.sort_seconds)?;
        d.set_item("test_seconds", s.test_seconds)?;
        d.set_item("response_seconds", s.response_seconds)?;
        d.set_item("total_seconds", s.total_seconds())?;
        d.set_item("windows", s.windows)?;
        d.set_item("endpoint_swaps", s.endpoint_swaps)?;
        d.set_item("list_entries", s.list_entries)?;
        d.set_item("candidate_pairs", s.candidate_pairs)?;
        d.set_item("narrow_tests", s.narrow_tests)?;
        d.set_item("retests", s.retests)?;
        d.set_item("contacts", s.contacts)?;
        d.set_item("pair_contacts", s.pair_contacts)?;
        d.set_item("invalidations", s.invalidations)?;
        d.set_item("broad_phase_bytes", s.broad_phase_bytes)?;
        d.set_item("tc_contacts", s.tc_contacts)?;
        d.set_item("jam_contacts", s.jam_contacts)?;
        Ok(d)
    }

    /// Total kinetic energy of the moving bodies: of their centres' motion and of their spins.
    ///
    /// >>> import vadop
    /// >>> vadop.World([[2.0, 5, 5]], [[3.0, 4, 0]], [0.5], [2.0], box=10.0).kinetic_energy()
    /// 25.0
    fn kinetic_energy(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.kinetic_energy())
    }

    /// Total linear momentum, float64 (3,).
    ///
    /// >>> import vadop
    /// >>> vadop.World([[2.0, 5, 5]], [[3.0, 4, 0]], [0.5], [2.0], box=10.0).momentum().tolist()
    /// [6.0, 8.0, 0.0]
    fn momentum<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let momentum = self.lock(py)?.momentum();
        Ok(Array1::from_vec(momentum.to_array().to_vec()).into_pyarray(py))
    }

    /// Total angular momentum about the origin, float64 (3,): of the centres' motion and of the
    /// spins.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[5.0, 5, 5]], [[1.0, 0, 0]], [0.5], box=10.0)
    /// >>> w.set_motions(0, [[1.0, 0, 0]], [[0.0, 0, 2.0]])
    /// >>> w.angular_momentum().round(12).tolist()   # r x m v + (2/5) m r^2 w
    /// [0.0, 5.0, -4.8]
    fn angular_momentum<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let angular_momentum = self.lock(py)?.angular_momentum();
        Ok(Array1::from_vec(angular_momentum.to_array().to_vec()).into_pyarray(py))
    }

    /// The VADOP volumes the next frame of length ``dt`` will use, one row per (moving body,
    /// axis): ``(body, axis, lo, hi)``: int64 body ids, int64 indices into ``axes``, and the
    /// float64 interval each body's swept bounding sphere (about its centre of mass, of radius
    /// ``radii``) covers on that axis. The broad phase is built by the first step, so this needs
    /// method 'vadop' and at least one step; bodies added since the last step have no rows yet,
    /// nor have static bodies, which the broad phase never holds.
    ///
    /// >>> import vadop
    /// >>> w = vadop.scene(100, 0.1, 1.0, method="vadop")
    /// >>> _ = w.step(1 / 30)
    /// >>> body, axis, lo, hi = w.volumes(1 / 30)
    /// >>> bool((lo < hi).all()), set(body.tolist()) == set(w.ids.tolist())
    /// (True, True)
    #[allow(clippy::type_complexity)]
    fn volumes<'py>(
        &self,
        py: Python<'py>,
        dt: f64,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
    )> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(value_error(VadopError::BadTimeStep(dt)));
        }
        let state = self.lock(py)?;
        let world = &*state;
        let Some(sap) = world.sweep_prune() else {
            return Err(PyValueError::new_err(format!(
                "volumes exist only for method 'vadop' after the first step (method {:?}, time {})",
                world.config().method.name(),
                world.time()
            )));
        };
        let (mut body, mut axis, mut lo, mut hi) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (handle, b) in world.bodies().filter(|(_, b)| b.mass.is_finite()) {
            let (centre, radius) = (state.centre_of_mass(&b), state.radius(&b));
            for &a in sap.axes_of(handle.index()) {
                let iv = interval(sap.pool().axis(a), centre, b.velocity, radius, dt);
                body.push(handle_id(handle));
                axis.push(i64::from(a));
                lo.push(iv.lo);
                hi.push(iv.hi);
            }
        }
        drop(state);
        Ok((
            Array1::from_vec(body).into_pyarray(py),
            Array1::from_vec(axis).into_pyarray(py),
            Array1::from_vec(lo).into_pyarray(py),
            Array1::from_vec(hi).into_pyarray(py),
        ))
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.lock(py)?.len())
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let state = self.lock(py)?;
        let world = &*state;
        let config = world.config();
        Ok(format!(
            "<World: {} bodies, method {}, mode {}, time {}>",
            world.len(),
            config.method.name(),
            mode_name(config.mode),
            world.time()
        ))
    }
}

impl PyWorld {
    /// `value` of every live body, in slot order.
    fn per_body<T>(&self, py: Python<'_>, value: impl Fn(&World, BodyHandle, &Body) -> T) -> PyResult<Vec<T>> {
        let state = self.lock(py)?;
        Ok(state.bodies().map(|(handle, body)| value(&state, handle, &body)).collect())
    }

    /// The world, once no other thread is using it. A step holds it without the GIL, so the wait
    /// happens without the GIL too, or that step could never hand it back.
    fn lock(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, World>> {
        loop {
            match self.state.try_lock() {
                Ok(state) => return Ok(state),
                Err(TryLockError::WouldBlock) => py.allow_threads(|| drop(self.state.lock())),
                Err(TryLockError::Poisoned(_)) => return Err(poisoned()),
            }
        }
    }
}

/// A world whose lock a panic left poisoned may be half-way through a change.
fn poisoned() -> PyErr {
    PyRuntimeError::new_err(
        "this world is unusable: an earlier call on it failed inside the engine (a bug, please report it)",
    )
}

fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Simulate => "simulate",
        Mode::Detect => "detect",
    }
}

/// A body's id in Python: its handle's bits, which fit int64 (generations stay at or below
/// [`BodyHandle::MAX_GENERATION`]), so ids share numpy's default int dtype with `Contacts.j`'s -1.
fn handle_id(handle: BodyHandle) -> i64 {
    handle.to_bits() as i64
}

/// The handles of ids that all name distinct live bodies of `world`, or an error naming the
/// first that does not, and saying so when it names a body since removed.
fn live_handles(world: &World, ids: &[i128], name: &str) -> PyResult<Vec<BodyHandle>> {
    let mut seen = std::collections::HashSet::new();
    ids.iter()
        .map(|&id| {
            let not_live = |why: String| PyValueError::new_err(format!("{name} must name live bodies, got {id}{why}"));
            let handle = u64::try_from(id).map(BodyHandle::from_bits).map_err(|_| not_live(String::new()))?;
            match world.body(handle) {
                Ok(_) if seen.insert(handle) => Ok(handle),
                Ok(_) => Err(PyValueError::new_err(format!("{name} must not repeat an id, got {id} twice"))),
                Err(VadopError::StaleHandle { current, .. }) => Err(not_live(match current {
                    Some(current) => format!(": that body was removed; its slot now holds {}", handle_id(current)),
                    None => ": that body was removed".to_string(),
                })),
                Err(_) => Err(not_live(String::new())),
            }
        })
        .collect()
}

/// [`live_handles`] of bodies that move: a static body's id is an error naming it.
fn moving_handles(world: &World, ids: &[i128], name: &str) -> PyResult<Vec<BodyHandle>> {
    let handles = live_handles(world, ids, name)?;
    for (&id, &handle) in ids.iter().zip(&handles) {
        if world.body(handle).is_ok_and(|body| !body.mass.is_finite()) {
            return Err(PyValueError::new_err(format!("{name} must name moving bodies, got {id}: a static body")));
        }
    }
    Ok(handles)
}

/// A shape id given as an int, before `PyShapeIds::shape_id` checks that it names a shape.
fn shape_number(arg: &IntArg, name: &str) -> PyResult<i128> {
    match arg {
        IntArg::Int(number) => Ok(*number),
        IntArg::Huge(text) => {
            Err(PyValueError::new_err(format!("{name} must be a shape id from add_shape, got {text}")))
        }
        IntArg::NotInt(type_name) => {
            Err(PyTypeError::new_err(format!("{name} must be a shape id (an int) from add_shape, got {type_name}")))
        }
    }
}

/// The shapes of `add_bodies`: one for every body, or one per body.
enum ShapeNumbers {
    OneForAll(i128),
    PerBody(Vec<i128>),
}

impl ShapeNumbers {
    /// `shapes` as given: an int, or an int64 array (or a list or tuple of ints) of shape (n,).
    fn of(shapes: &Bound<'_, PyAny>, n: usize) -> PyResult<ShapeNumbers> {
        let sequence = shapes.is_instance_of::<PyUntypedArray>()
            || shapes.is_instance_of::<PyList>()
            || shapes.is_instance_of::<PyTuple>();
        if !sequence {
            match shapes.extract::<IntArg>()? {
                // Not an int: the array check below names what was expected.
                IntArg::NotInt(_) => {}
                number => return Ok(ShapeNumbers::OneForAll(shape_number(&number, "shapes")?)),
            }
        }
        let py = shapes.py();
        let array = checked_array(shapes, "shapes", numpy::dtype::<i64>(py), &[Some(n)])
            .map_err(|e| also_accepts(py, e, "an int"))?;
        let array = array.downcast::<PyArray1<i64>>()?.readonly();
        Ok(ShapeNumbers::PerBody(array.as_array().iter().map(|&k| i128::from(k)).collect()))
    }

    /// The core's ids of the `n` bodies' shapes, each one a moving body can take.
    fn ids(&self, state: &World, n: usize) -> PyResult<Vec<ShapeId>> {
        match self {
            ShapeNumbers::OneForAll(number) => Ok(vec![state.moving_shape_id(*number, "shapes")?; n]),
            ShapeNumbers::PerBody(numbers) => numbers
                .iter()
                .enumerate()
                .map(|(k, &number)| state.moving_shape_id(number, &format!("shapes[{k}]")))
                .collect(),
        }
    }
}

/// The paper's scene as a world: ``bodies`` spheres of radius ``radius`` at ``packing_fraction``
/// in a cube, random directions, speeds uniform up to ``max_speed`` diameters per frame at 30
/// frames per second (so step with ``dt = 1/30``), generated from ``seed``; the world settings
/// as for ``World``. ``bodies`` is an int in 1..=10^8, ``seed`` an int in 0..2^64; any other int
/// raises ``ValueError`` naming the argument and its range, a float ``TypeError``. Raises
/// ``MemoryError``, before allocating anything, when the world would not fit in the memory left
/// (about 640 bytes a body).
///
/// >>> import vadop
/// >>> w = vadop.scene(1000, 0.05, 0.5)
/// >>> len(w), w.positions.shape
/// (1000, (1000, 3))
#[pyfunction]
// The int defaults are `IntArg`s, which pyo3 cannot print in the signature Python sees.
#[pyo3(
    text_signature = "(bodies=1000, packing_fraction=0.05, max_speed=0.5, *, radius=0.5, seed=1, method='auto', mode='simulate', pool_axes=None, phi=None, restitution=1.0, contact_duration=1e-05, threads=None)"
)]
#[pyo3(signature = (bodies = IntArg::Int(1000), packing_fraction = 0.05, max_speed = 0.5, *, radius = 0.5, seed = IntArg::Int(1), method = "auto", mode = "simulate", pool_axes = None, phi = None, restitution = 1.0, contact_duration = 1e-5, threads = None))]
#[allow(clippy::too_many_arguments)]
fn scene(
    py: Python<'_>,
    bodies: IntArg,
    packing_fraction: f64,
    max_speed: f64,
    radius: f64,
    seed: IntArg,
    method: &str,
    mode: &str,
    pool_axes: Option<IntArg>,
    phi: Option<f64>,
    restitution: f64,
    contact_duration: f64,
    threads: Option<IntArg>,
) -> PyResult<PyWorld> {
    let bodies = bodies.in_range("bodies", 1, MAX_SCENE_BODIES as i128)? as usize;
    let seed = seed.in_range("seed", 0, u64::MAX.into())? as u64;
    let config = config(method, mode, pool_axes, phi, restitution, 0.0, contact_duration, threads, false)?;
    check_world_memory(bodies)?;
    let parameters = PaperScene { bodies, packing_fraction, max_speed, radius, seed };
    let world = py.allow_threads(|| parameters.build().and_then(|s| s.world(config))).map_err(value_error)?;
    Ok(PyWorld { state: Mutex::new(world) })
}

/// Detect mode on given paths: bodies start at ``positions`` with ``velocities`` and move in
/// straight lines, passing through each other and bouncing only off the box walls, for
/// ``frames`` frames of ``dt``; returns every contact of the run in time order. ``method``
/// chooses how they are found ('auto', 'vadop', 'grid', 'brute', 'discrete', 'swept-aabb' or
/// 'swept-kdop'; all but 'discrete' find the same contacts). Steps without the GIL; Ctrl-C raises
/// ``KeyboardInterrupt`` within 50 ms, inside a long frame too. Raises ``MemoryError`` when the contacts found
/// so far outgrow the memory left: run fewer frames at a time, or step a ``World``. ``frames`` is
/// an int >= 0; arrays as for ``World`` (lists and tuples too).
///
/// >>> import numpy as np, vadop
/// >>> c = vadop.detect(np.array([[1.0, 1, 1], [4, 1, 1]]), np.array([[40.0, 0, 0], [0, 0, 0]]),
/// ...                  np.array([0.5, 0.5]), box=10.0, dt=0.1, frames=1)
/// >>> c.j.tolist(), c.time.tolist()   # the gap of 2 closes at 40 units/s
/// ([1], [0.05])
#[pyfunction]
#[pyo3(signature = (positions, velocities, radii, *, r#box, dt, frames, method = "auto", pool_axes = None, phi = None, threads = None))]
#[allow(clippy::too_many_arguments)]
fn detect(
    py: Python<'_>,
    positions: &Bound<'_, PyAny>,
    velocities: &Bound<'_, PyAny>,
    radii: &Bound<'_, PyAny>,
    r#box: &Bound<'_, PyAny>,
    dt: f64,
    frames: IntArg,
    method: &str,
    pool_axes: Option<IntArg>,
    phi: Option<f64>,
    threads: Option<IntArg>,
) -> PyResult<Contacts> {
    let frames = frames.in_range("frames", 0, u64::MAX.into())? as u64;
    let bounds = bounds(r#box)?;
    let config = config(method, "detect", pool_axes, phi, 1.0, 0.0, DEFAULT_CONTACT_DURATION, threads, false)?;
    let spheres = spheres(positions, velocities, radii, None, &bounds)?;
    check_world_memory(spheres.len())?;
    let mut world = World::new(bounds, config).map_err(value_error)?;
    world.add_spheres(&spheres).map_err(value_error)?;
    let all = py.allow_threads(|| {
        interruptible(&mut world, |world| {
            let mut all = Vec::new();
            for _ in 0..frames {
                let contacts = world.step(dt).map_err(value_error)?;
                make_room(&mut all, contacts.len())?;
                all.extend_from_slice(contacts);
            }
            Ok(all)
        })
    })?;
    Ok(Contacts::new(py, &all))
}

/// Runs `work` on `world` in a thread of its own while this one (the GIL released) looks at
/// signals every [`SIGNAL_CHECK`]: a Ctrl-C raises the world's interrupt flag, which stops even
/// one long step within milliseconds and undoes it, and the signal's exception
/// (`KeyboardInterrupt`) is raised instead of what `work` returns.
fn interruptible<T: Send>(world: &mut World, work: impl FnOnce(&mut World) -> PyResult<T> + Send) -> PyResult<T> {
    let stop = Arc::new(AtomicBool::new(false));
    world.set_interrupt(Some(stop.clone()));
    let mut signal = None;
    let (done, finished) = mpsc::channel::<()>();
    let (mut result, stepped) = (None, &mut *world);
    // A thread of rayon's global pool runs the work: waking one costs less than starting one.
    rayon::in_place_scope(|scope| {
        let result = &mut result;
        scope.spawn(move |_| {
            *result = Some(work(stepped));
            drop(done);
        });
        // Most steps are short: waiting for them without sleeping saves waking up again.
        let start = Instant::now();
        while matches!(finished.try_recv(), Err(mpsc::TryRecvError::Empty)) && start.elapsed() < BUSY_WAIT {
            std::thread::yield_now();
        }
        while let Err(mpsc::RecvTimeoutError::Timeout) = finished.recv_timeout(SIGNAL_CHECK) {
            if signal.is_none() {
                if let Err(e) = Python::with_gil(|py| py.check_signals()) {
                    stop.store(true, Ordering::Relaxed);
                    signal = Some(e);
                }
            }
        }
    });
    let result = result.expect("the scope ran the work");
    world.set_interrupt(None);
    match signal {
        Some(e) => Err(e),
        None => result,
    }
}

/// Room for `more` contacts in `all`, or `MemoryError` when the grown list and the arrays made
/// from it at the end (as large again, with temporaries) would not fit in the memory left.
fn make_room(all: &mut Vec<Contact>, more: usize) -> PyResult<()> {
    let wanted = all.len() + more;
    if wanted > all.capacity() {
        let capacity = wanted.max(2 * all.capacity());
        let bytes = 3 * (capacity * std::mem::size_of::<Contact>()) as u64;
        check_memory(&format!("detect: room for {capacity} contacts"), bytes)?;
        all.reserve_exact(capacity - all.len());
    }
    Ok(())
}

#[pymodule]
fn _vadop(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyWorld>()?;
    m.add_class::<Contacts>()?;
    m.add_function(wrap_pyfunction!(scene, m)?)?;
    m.add_function(wrap_pyfunction!(detect, m)?)?;
    m.add("WALLS", WALLS.to_vec())?;
    // The workspace's version, which pyproject.toml's matches (the tests check both).
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
