//! The `World` class: a core world behind a lock, its methods and the arrays read back from it.
//! Each method checks its arguments first (see `convert`), then takes the lock without holding
//! the GIL and calls the core; it never implements a physical rule nor keeps any state beside
//! the core's world, so that Python sees exactly what the core does.

use crate::contacts::Contacts;
use crate::convert::{
    bounds, check_world_memory, config, finite_row, mode_name, periodic_axes, positive_values, quaternions, spheres,
    value_error, vectors, vectors_array, IntArg,
};
use crate::handles::{handle_id, ids_of, live_handles, moving_handles};
use crate::interrupt::interruptible;
use crate::shape_ids::{shape_number, PyShapeIds, ShapeNumbers};
use crate::shapes;
use crate::stats::frame_stats;
use glam::{DQuat, DVec3};
use numpy::ndarray::{Array1, Array2};
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Mutex, MutexGuard, TryLockError};
use vadop::bounding_volume::interval;
use vadop::{Body, BodyHandle, BodyShape, Rest, VadopError, World};

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
/// ``touching()`` — started and stopped events) and ``gravity`` (x, y, z: the uniform
/// acceleration of every moving body; None: none; bodies of any shape; with restitution below
/// 1 in simulate mode bodies of every shape come to rest, ``rest``, on static geometry too) and ``periodic`` (the box's periodic axes as letters, e.g. ``'xyz'`` or
/// ``'xy'``; the others keep their walls: a body leaving through one face comes back through the
/// opposite one, bodies meet across the faces, and ``crossings`` counts each body's passages;
/// bodies of any shape, no static bodies yet, and each periodic side at least 8 largest bounding
/// diameters).
///
/// >>> import vadop
/// >>> w = vadop.World([[9.0, 5, 5], [0.8, 5, 5]], [[3.0, 0, 0], [0, 0, 0]], [0.5, 0.5], box=10.0,
/// ...                 periodic='x')
/// >>> c = w.step(0.5)  # they meet through the face at x = 10
/// >>> round(float(c.time[0]), 9)
/// 0.266666667
/// >>> c = w.step(4.0)  # the partner went round and hit it back through the face
/// >>> round(float(c.time[0]), 9), w.crossings.tolist()
/// (2.933333333, [[1, 0, 0], [0, 0, 0]])
///
/// >>> import vadop
/// >>> w = vadop.World([[5.0, 5, 4.5]], [[0.0, 0, 0]], [0.5], box=10.0, gravity=(0, 0, -2.0))
/// >>> [round(float(t), 9) for t in w.step(2.5).time]  # lands after sqrt(2 * 4 / 2) = 2
/// [2.0]
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
pub(crate) struct PyWorld {
    pub(crate) state: Mutex<World>,
}

#[pymethods]
impl PyWorld {
    #[new]
    #[pyo3(signature = (positions = None, velocities = None, radii = None, masses = None, *, r#box, method = "auto", mode = "simulate", pool_axes = None, phi = None, restitution = 1.0, friction = 0.0, contact_duration = 1e-5, threads = None, contact_ends = false, gravity = None, periodic = None))]
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
        gravity: Option<[f64; 3]>,
        periodic: Option<&str>,
    ) -> PyResult<PyWorld> {
        let bounds = bounds(r#box)?.with_periodic(periodic_axes(periodic)?);
        let config = config(
            method,
            mode,
            pool_axes,
            phi,
            restitution,
            friction,
            contact_duration,
            threads,
            contact_ends,
            gravity.map_or(DVec3::ZERO, DVec3::from_array),
        )?;
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

    /// The box's periodic axes as letters, e.g. ``'xyz'`` (``''``: every axis walled).
    ///
    /// >>> import vadop
    /// >>> vadop.World(box=10.0, periodic="zx").periodic
    /// 'xz'
    #[getter]
    fn periodic(&self, py: Python<'_>) -> PyResult<String> {
        let periodic = self.lock(py)?.bounds().periodic;
        Ok("xyz".chars().zip(periodic).filter(|(_, p)| *p).map(|(a, _)| a).collect())
    }

    /// Each body's crossings of the periodic faces, int64 (n, 3): per axis x, y, z, +1 for each
    /// passage out through the face at the box's maximum, -1 through the minimum (zeros on
    /// walled axes). ``positions + crossings * side`` is the path unwrapped.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[5.0, 5, 5]], [[4.0, 0, -3.0]], [0.5], box=10.0, periodic="xz")
    /// >>> _ = w.step(2.0)
    /// >>> w.crossings.tolist(), w.positions.round(9).tolist()
    /// ([[1, 0, -1]], [[3.0, 5.0, 9.0]])
    #[getter]
    fn crossings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let rows = self.per_body(py, |world, handle, _| world.crossings(handle).unwrap_or_default())?;
        let flat: Vec<i64> = rows.into_iter().flatten().collect();
        Ok(Array2::from_shape_vec((flat.len() / 3, 3), flat).expect("3 values per row").into_pyarray(py))
    }

    /// How each body is held up under gravity (see the Rust ``vadop::Rest``): ``'falling'``,
    /// ``'sliding'`` (a ball along walls gravity presses it into: the floor, or a corner under
    /// tilted gravity) or ``'still'`` (on walls, on bodies lying still or on static geometry; a
    /// shape other than a ball lies still rather than slides). Bodies come to rest only in
    /// simulate mode with restitution below 1; static bodies are ``'still'``.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[5.0, 5, 2]], [[0.0, 0, 0]], [0.5], box=10.0, gravity=(0, 0, -9.81), restitution=0.5)
    /// >>> w.rest
    /// ['falling']
    /// >>> _ = w.step(3.0)
    /// >>> w.rest, round(float(w.positions[0, 2]), 12), w.stats()["rest_contacts"]
    /// (['still'], 0.5, 1)
    #[getter]
    fn rest(&self, py: Python<'_>) -> PyResult<Vec<&'static str>> {
        self.per_body(py, |world, handle, body| match world.rest(handle) {
            _ if !body.mass.is_finite() => "still",
            Ok(Rest::Sliding(_)) => "sliding",
            Ok(Rest::Still) => "still",
            _ => "falling",
        })
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
    /// resolved by the jam rule; ``rest_contacts``: under gravity with restitution below 1, a
    /// body brought to rest, or parted from or bounced off one that does not fall), and
    /// ``pair_virial``: the collisional virial of the frame's
    /// impacts between moving bodies (separation of the centres dotted with the momentum
    /// exchanged; simulate mode). Over a run of duration T at translational kinetic energy K,
    /// Z = PV/NkT = 1 + sum(pair_virial) / (2 K T).
    ///
    /// >>> import vadop
    /// >>> w = vadop.scene(300, 0.1, 2.0)
    /// >>> _ = w.step(1 / 30)
    /// >>> s = w.stats()
    /// >>> s["contacts"] >= s["pair_contacts"], s["total_seconds"] > 0
    /// (True, True)
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let stats = *self.lock(py)?.stats();
        frame_stats(py, &stats)
    }

    /// Total kinetic energy of the moving bodies: of their centres' motion and of their spins.
    ///
    /// >>> import vadop
    /// >>> vadop.World([[2.0, 5, 5]], [[3.0, 4, 0]], [0.5], [2.0], box=10.0).kinetic_energy()
    /// 25.0
    fn kinetic_energy(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.kinetic_energy())
    }

    /// Kinetic energy of the centres' motion only (3/2 NkT for a gas; spins left out).
    ///
    /// >>> import vadop
    /// >>> vadop.World([[2.0, 5, 5]], [[3.0, 4, 0]], [0.5], [2.0], box=10.0).translational_kinetic_energy()
    /// 25.0
    fn translational_kinetic_energy(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.translational_kinetic_energy())
    }

    /// Potential energy of the moving bodies in the world's gravity, ``-sum m g . p`` (0 without
    /// gravity): kinetic plus potential is what an elastic run keeps.
    ///
    /// >>> import vadop
    /// >>> w = vadop.World([[5.0, 5, 5]], [[0.0, 0, 0]], [0.5], [3.0], box=10.0, gravity=(0, 0, -2.0))
    /// >>> w.potential_energy()
    /// 30.0
    fn potential_energy(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.potential_energy())
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
