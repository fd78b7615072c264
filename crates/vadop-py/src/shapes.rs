//! Shapes between Python and the core: `World.add_shape(kind, **params)` read into a
//! [`Shape`], a [`Shape`] written back as the keyword arguments that make it, and the triangles
//! of a shape's surface for drawing.
//!
//! Each kind's name and parameters come from the core's one list ([`ShapeKind`]), which the parser
//! and its messages follow;
//! [`describe`] writes the same names back. Values are only converted here (an array of the right
//! dtype and shape, a finite number); what makes a shape valid (sizes > 0, hulls with volume,
//! meshes with good indices) is the core's to say, in [`Shape::geometry`].

use crate::convert::{checked_array, finite_row, vectors, vectors_array};
use glam::DVec3;
use numpy::ndarray::Array2;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use vadop::shape::{Shape, ShapeGeometry, ShapeKind};

/// Segments around a round surface drawn by [`surface`]: smooth enough for a viewer, a few
/// hundred triangles a shape.
const ROUND_SEGMENTS: u32 = 24;

/// The shape `add_shape(kind, **params)` describes. An unknown kind is a `ValueError`; a missing
/// or unexpected parameter, or one of the wrong type, a `TypeError` naming it.
pub(crate) fn parse(kind: &str, params: Option<&Bound<'_, PyDict>>) -> PyResult<Shape> {
    let Some(shape_kind) = ShapeKind::from_name(kind) else {
        let kinds: Vec<String> = ShapeKind::ALL.iter().map(|k| format!("'{}'", k.name())).collect();
        return Err(PyValueError::new_err(format!("kind must be one of {}, got {kind:?}", kinds.join(", "))));
    };
    let (kind, names) = (shape_kind.name(), shape_kind.parameters());
    let takes = || format!("a '{kind}' takes {}", names.join(", "));
    let mut given: Vec<(String, Bound<'_, PyAny>)> = Vec::new();
    for (name, value) in params.into_iter().flat_map(|p| p.iter()) {
        let name: String = name.extract()?;
        if !names.contains(&name.as_str()) {
            return Err(PyTypeError::new_err(format!(
                "add_shape('{kind}') got an unexpected keyword argument '{name}'; {}",
                takes()
            )));
        }
        given.push((name, value));
    }
    let param = |name: &str| -> PyResult<&Bound<'_, PyAny>> {
        given.iter().find(|(n, _)| n == name).map(|(_, value)| value).ok_or_else(|| {
            PyTypeError::new_err(format!("add_shape('{kind}') missing keyword argument '{name}'; {}", takes()))
        })
    };
    // Every parameter is looked up before any is read, so a missing one is reported first.
    let values = names.iter().map(|name| param(name)).collect::<PyResult<Vec<_>>>()?;
    let number = |k: usize| number(values[k], names[k]);
    Ok(match shape_kind {
        ShapeKind::Sphere => Shape::Sphere { radius: number(0)? },
        ShapeKind::Cuboid => Shape::Cuboid { half_extents: DVec3::from_array(finite_row(values[0], "half_extents")?) },
        ShapeKind::Capsule => Shape::Capsule { half_height: number(0)?, radius: number(1)? },
        ShapeKind::Cylinder => Shape::Cylinder { half_height: number(0)?, radius: number(1)? },
        ShapeKind::Cone => Shape::Cone { half_height: number(0)?, radius: number(1)? },
        ShapeKind::ConvexHull => Shape::ConvexHull { points: vectors(values[0], "points", None)? },
        ShapeKind::TriMesh => {
            Shape::TriMesh { vertices: vectors(values[0], "vertices", None)?, triangles: triangles(values[1])? }
        }
        ShapeKind::HalfSpace => Shape::HalfSpace { normal: DVec3::from_array(finite_row(values[0], "normal")?) },
    })
}

/// A size parameter: any real number (its range is the core's to check).
fn number(value: &Bound<'_, PyAny>, name: &str) -> PyResult<f64> {
    value.extract::<f64>().map_err(|_| {
        let type_name = value.get_type().name().map(|n| n.to_string()).unwrap_or_default();
        PyTypeError::new_err(format!("{name} must be a number, got {type_name}"))
    })
}

/// Triangles as an int64 array (or a list of int lists) of shape (m, 3); each index must fit
/// the core's u32 (whether it names a vertex is the core's check).
fn triangles(value: &Bound<'_, PyAny>) -> PyResult<Vec<[u32; 3]>> {
    let py = value.py();
    let array = checked_array(value, "triangles", numpy::dtype::<i64>(py), &[None, Some(3)])?;
    let array = array.downcast::<PyArray2<i64>>()?.readonly();
    array
        .as_array()
        .rows()
        .into_iter()
        .enumerate()
        .map(|(i, row)| {
            let fit = |k: i64| u32::try_from(k).ok();
            match (fit(row[0]), fit(row[1]), fit(row[2])) {
                (Some(a), Some(b), Some(c)) => Ok([a, b, c]),
                _ => Err(PyValueError::new_err(format!(
                    "triangles[{i}] = {:?} must hold vertex indices from 0 up to the number of vertices",
                    row.to_vec()
                ))),
            }
        })
        .collect()
}

/// The keyword arguments of `add_shape` that make `shape`: `kind` first, then its parameters.
pub(crate) fn describe<'py>(py: Python<'py>, shape: &Shape) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let vector = |v: DVec3| PyArray1::from_slice(py, &v.to_array());
    d.set_item("kind", shape.kind().name())?;
    match shape {
        Shape::Sphere { radius } => d.set_item("radius", radius)?,
        Shape::Cuboid { half_extents } => d.set_item("half_extents", vector(*half_extents))?,
        Shape::Capsule { half_height, radius }
        | Shape::Cylinder { half_height, radius }
        | Shape::Cone { half_height, radius } => {
            d.set_item("half_height", half_height)?;
            d.set_item("radius", radius)?;
        }
        Shape::ConvexHull { points } => d.set_item("points", vectors_array(py, points))?,
        Shape::TriMesh { vertices, triangles } => {
            d.set_item("vertices", vectors_array(py, vertices))?;
            d.set_item("triangles", triangles_array(py, triangles))?;
        }
        Shape::HalfSpace { normal } => d.set_item("normal", vector(*normal))?,
    }
    Ok(d)
}

/// Triangles as an int64 (m, 3) array.
pub(crate) fn triangles_array<'py>(py: Python<'py>, triangles: &[[u32; 3]]) -> Bound<'py, PyArray2<i64>> {
    let flat: Vec<i64> = triangles.iter().flatten().map(|&k| i64::from(k)).collect();
    Array2::from_shape_vec((triangles.len(), 3), flat).expect("3 indices per row").into_pyarray(py)
}

/// The triangles of the surface of `geometry` in its shape's own frame, outward-facing: exact
/// for cuboids, convex hulls and meshes, round surfaces with [`ROUND_SEGMENTS`] segments around.
/// `None` for a half-space, which has no bounded surface.
pub(crate) fn surface(geometry: &ShapeGeometry) -> Option<(Vec<DVec3>, Vec<[u32; 3]>)> {
    let parry = geometry.parry_shape();
    let n = ROUND_SEGMENTS;
    match geometry.shape() {
        Shape::Sphere { .. } => parry.as_ball().map(|s| s.to_trimesh(n, n / 2)),
        Shape::Cuboid { .. } => parry.as_cuboid().map(|s| s.to_trimesh()),
        Shape::Capsule { .. } => parry.as_capsule().map(|s| s.to_trimesh(n, n / 2)),
        Shape::Cylinder { .. } => parry.as_cylinder().map(|s| s.to_trimesh(n)),
        Shape::Cone { .. } => parry.as_cone().map(|s| s.to_trimesh(n)),
        Shape::ConvexHull { .. } => parry.as_convex_polyhedron().map(|s| s.to_trimesh()),
        Shape::TriMesh { .. } => parry.as_trimesh().map(|s| (s.vertices().to_vec(), s.indices().to_vec())),
        Shape::HalfSpace { .. } => None,
    }
}
