//! Body ids between Python and the core: an id is a [`BodyHandle`]'s bits, given as an int or an
//! array of them and checked to name live (or moving) bodies of a world. It never guesses: an id
//! that is unknown, repeated or stale (its body removed) is an error naming it, never a
//! reference to whatever body holds that slot now.

use crate::convert::{also_accepts, checked_array, IntArg};
use numpy::prelude::*;
use numpy::{PyArray1, PyUntypedArray};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};
use vadop::{BodyHandle, VadopError, World};

/// A body's id in Python: its handle's bits, which fit int64 (generations stay at or below
/// [`BodyHandle::MAX_GENERATION`]), so ids share numpy's default int dtype with `Contacts.j`'s -1.
pub(crate) fn handle_id(handle: BodyHandle) -> i64 {
    handle.to_bits() as i64
}

/// Body ids as given: an int, or an int64 array (or a list or tuple of ints) of shape (k,).
/// [`live_handles`] checks that they name live bodies; an int too large for int64, in a list or
/// not, names no body: `ValueError`.
pub(crate) fn ids_of(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<i128>> {
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

/// The handles of ids that all name distinct live bodies of `world`, or an error naming the
/// first that does not, and saying so when it names a body since removed.
pub(crate) fn live_handles(world: &World, ids: &[i128], name: &str) -> PyResult<Vec<BodyHandle>> {
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
pub(crate) fn moving_handles(world: &World, ids: &[i128], name: &str) -> PyResult<Vec<BodyHandle>> {
    let handles = live_handles(world, ids, name)?;
    for (&id, &handle) in ids.iter().zip(&handles) {
        if world.body(handle).is_ok_and(|body| !body.mass.is_finite()) {
            return Err(PyValueError::new_err(format!("{name} must name moving bodies, got {id}: a static body")));
        }
    }
    Ok(handles)
}
