//! The `Contacts` class: a frame's contacts as numpy columns, and `WALLS`, the names its `wall`
//! column indexes. It only copies the core's contacts into arrays, in the core's order; it never
//! finds, filters or reorders contacts.

use crate::convert::vectors_array;
use crate::handles::handle_id;
use glam::DVec3;
use numpy::ndarray::Array1;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use vadop::{Contact, Touched};

/// Names of the six walls, indexed by the `wall` column of [`Contacts`].
pub(crate) const WALLS: [&str; 6] = ["min_x", "max_x", "min_y", "max_y", "min_z", "max_z"];

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
pub(crate) struct Contacts {
    time: Py<PyArray1<f64>>,
    i: Py<PyArray1<i64>>,
    j: Py<PyArray1<i64>>,
    wall: Py<PyArray1<i64>>,
    point: Py<PyArray2<f64>>,
    normal: Py<PyArray2<f64>>,
    impulse: Py<PyArray1<f64>>,
}

impl Contacts {
    pub(crate) fn new(py: Python<'_>, contacts: &[Contact]) -> Contacts {
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
