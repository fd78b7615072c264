//! Shape ids between Python and the core: a Python shape id is a [`ShapeId`]'s index, given as
//! an int or an array of them and checked against a world's shapes, and what the getters read of
//! a body's shape (its id, its bounding radius, its centre of mass). It only looks the core's
//! shapes up; it never makes, changes or checks the validity of a shape.

use crate::convert::{also_accepts, checked_array, value_error, IntArg};
use glam::DVec3;
use numpy::prelude::*;
use numpy::{PyArray1, PyUntypedArray};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};
use vadop::shape::ShapeGeometry;
use vadop::{Body, BodyShape, ShapeId, World};

/// Python's shape ids are the core's [`ShapeId`] indices: dense, 0, 1, 2 ... in the order
/// `add_shape` made them.
pub(crate) trait PyShapeIds {
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

/// A shape id given as an int, before `PyShapeIds::shape_id` checks that it names a shape.
pub(crate) fn shape_number(arg: &IntArg, name: &str) -> PyResult<i128> {
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
pub(crate) enum ShapeNumbers {
    OneForAll(i128),
    PerBody(Vec<i128>),
}

impl ShapeNumbers {
    /// `shapes` as given: an int, or an int64 array (or a list or tuple of ints) of shape (n,).
    pub(crate) fn of(shapes: &Bound<'_, PyAny>, n: usize) -> PyResult<ShapeNumbers> {
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
    pub(crate) fn ids(&self, state: &World, n: usize) -> PyResult<Vec<ShapeId>> {
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
