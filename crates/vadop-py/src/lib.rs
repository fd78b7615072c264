//! Python bindings of vadop: the `vadop._vadop` extension module.
//!
//! It owns the translation between numpy arrays and the core's types, and nothing else: every
//! physical rule stays in the `vadop` crate. Input is checked here first, row by row, so that a
//! bad argument raises `TypeError` (wrong type or dtype) or `ValueError` (wrong shape or value,
//! an int out of its range) naming the argument, the row and what was expected, before the world
//! is touched; lists and tuples are read with `numpy.asarray` where arrays are taken; whatever
//! the core still rejects (overlaps, absurd speeds, bad settings) becomes a `ValueError` with the
//! core's message. Body handles cross as ints, [`vadop::BodyHandle::to_bits`]. Stepping releases
//! the GIL.

mod contacts;
mod convert;
mod functions;
mod handles;
mod interrupt;
mod shape_ids;
mod shapes;
mod stats;
mod world;

use contacts::{Contacts, WALLS};
use functions::{detect, scene};
use pyo3::prelude::*;
use world::PyWorld;

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
