//! The module's functions `scene` and `detect`: the paper's scene built as a `World`, and detect
//! mode run over given paths into one `Contacts`. Like `World`'s methods they check their
//! arguments (see `convert`) before calling the core, and add no rule of their own.

use crate::contacts::Contacts;
use crate::convert::{bounds, check_memory, check_world_memory, config, spheres, value_error, IntArg};
use crate::interrupt::interruptible;
use crate::world::PyWorld;
use glam::DVec3;
use pyo3::prelude::*;
use std::sync::Mutex;
use vadop::response::rules::DEFAULT_CONTACT_DURATION;
use vadop::scene::{PaperScene, MAX_SCENE_BODIES};
use vadop::{Contact, World};

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
pub(crate) fn scene(
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
    let config = config(method, mode, pool_axes, phi, restitution, 0.0, contact_duration, threads, false, DVec3::ZERO)?;
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
pub(crate) fn detect(
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
    let config =
        config(method, "detect", pool_axes, phi, 1.0, 0.0, DEFAULT_CONTACT_DURATION, threads, false, DVec3::ZERO)?;
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
