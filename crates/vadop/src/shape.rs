//! Shapes: what a body looks like, as users describe it, and the geometry every later stage
//! derives from that description once.
//!
//! It owns the user-facing [`Shape`] (sizes in the shape's own frame), its validation, and the
//! [`ShapeGeometry`] built from it: the parry shape that all distance and contact queries run on,
//! the mass properties for unit density, the frame the body moves in, and the bounding radius
//! about the centre of mass — the one number the broad phase ever sees of a shape. It never moves
//! bodies, schedules anything or decides contacts: [`crate::narrow_phase::shapes`] does the contact
//! arithmetic, the world does the rest.
//!
//! # Frames
//!
//! A shape is described in its own *shape frame* (parry's convention: a capsule, cylinder or cone
//! lies along local y, a cone's apex at `+half_height`). A body carrying it moves in its *body
//! frame*: origin at the centre of mass, axes along the principal axes of inertia. A body's
//! `position` is its centre of mass and its `orientation` rotates body-frame vectors to world
//! vectors, so a point `x` of the body frame is at `position + orientation * x` in the world.
//! [`ShapeGeometry::body_from_shape`] maps shape-frame points into the body frame; the parry pose
//! of the shape is `Pose(position, orientation) * body_from_shape`
//! ([`ShapeGeometry::pose_of_shape`]). For a sphere, cuboid, capsule or cylinder the two frames
//! coincide; a cone's centre of mass lies a quarter of its height above its base, and a convex
//! hull's centre of mass and principal axes are wherever its points put them.
//!
//! Static-only shapes ([`Shape::TriMesh`], [`Shape::HalfSpace`]) are level geometry: they have no
//! mass (it is infinite), their body frame is their shape frame, and they have no bounding radius
//! (a mesh is bounded by its own hierarchy; its box is [`ShapeGeometry::local_aabb`]).
//!
//! ```
//! use glam::{DQuat, DVec3};
//! use vadop::shape::Shape;
//! let cone = Shape::Cone { half_height: 1.0, radius: 0.5 }.geometry().unwrap();
//! // The body frame sits at the centre of mass, a quarter of the height above the base.
//! assert!((cone.body_from_shape().translation - DVec3::new(0.0, 0.5, 0.0)).length() < 1e-12);
//! // A body at the origin: its apex is 1.5 above the centre of mass.
//! let pose = cone.pose_of_shape(DVec3::ZERO, DQuat::IDENTITY);
//! assert!((pose * DVec3::new(0.0, 1.0, 0.0) - DVec3::new(0.0, 1.5, 0.0)).length() < 1e-12);
//! // Its bounding sphere about the centre of mass reaches the apex.
//! assert!((cone.bounding_radius().unwrap() - 1.5).abs() < 1e-9);
//! ```

use crate::error::{check_length, check_vector, Result, VadopError};
use crate::numeric::{direction, unit_scale};
use glam::{DQuat, DVec3};
use parry3d_f64::math::Pose;
use parry3d_f64::shape::{ConvexPolyhedron, SharedShape, TriMesh};

/// A body's shape as users describe it; all sizes in the shape's own frame (see the
/// [module documentation](self) for the frames).
///
/// ```
/// use glam::DVec3;
/// use vadop::shape::Shape;
/// let brick = Shape::Cuboid { half_extents: DVec3::new(2.0, 1.0, 0.5) };
/// let geometry = brick.geometry().unwrap();
/// assert_eq!(geometry.volume(), 8.0);
/// // The smallest sphere about the centre of mass holding the brick reaches its corners.
/// assert!((geometry.bounding_radius().unwrap() / DVec3::new(2.0, 1.0, 0.5).length() - 1.0).abs() < 1e-9);
/// // Zero sizes are refused with a message, never a panic.
/// assert!(Shape::Cuboid { half_extents: DVec3::new(1.0, 0.0, 1.0) }.geometry().is_err());
/// ```
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Shape {
    /// A ball about the shape origin.
    #[serde(rename = "sphere", alias = "Sphere")]
    Sphere { radius: f64 },
    /// A box about the shape origin, `half_extents` along the shape's axes.
    #[serde(rename = "cuboid", alias = "Cuboid")]
    Cuboid { half_extents: DVec3 },
    /// The points within `radius` of the segment from `-half_height` to `+half_height` on the
    /// shape's y axis.
    #[serde(rename = "capsule", alias = "Capsule")]
    Capsule { half_height: f64, radius: f64 },
    /// A solid cylinder along the shape's y axis, from `-half_height` to `+half_height`.
    #[serde(rename = "cylinder", alias = "Cylinder")]
    Cylinder { half_height: f64, radius: f64 },
    /// A solid cone along the shape's y axis: base disc of `radius` at `-half_height`, apex at
    /// `+half_height`.
    #[serde(rename = "cone", alias = "Cone")]
    Cone { half_height: f64, radius: f64 },
    /// The convex hull of `points` (at least four, not all in one plane). Give the points about
    /// the shape's own centre: coordinates far from it cost precision.
    #[serde(rename = "convex_hull", alias = "ConvexHull")]
    ConvexHull { points: Vec<DVec3> },
    /// Static-only level geometry: the triangles (a surface, not a solid; each triangle indexes
    /// three distinct `vertices`). A body inside a closed mesh touches nothing until it reaches a
    /// triangle.
    #[serde(rename = "trimesh", alias = "TriMesh")]
    TriMesh { vertices: Vec<DVec3>, triangles: Vec<[u32; 3]> },
    /// Static-only level geometry: the solid half-space behind the plane through the shape origin
    /// orthogonal to `normal`, which points out of the solid (any non-zero length).
    #[serde(rename = "halfspace", alias = "HalfSpace")]
    HalfSpace { normal: DVec3 },
}

/// Declares [`ShapeKind`] from one table: each kind of [`Shape`], the one name it goes by
/// everywhere (scene files, Python, the CLI's summaries, the viewer), its parameters in the order
/// messages list them, and the words a readable summary uses. A new shape is one variant of
/// [`Shape`] and one row here.
macro_rules! shape_kinds {
    ($($variant:ident => $name:literal, [$($parameter:literal),*], $singular:literal, $plural:literal;)*) => {
        /// The kind of a [`Shape`], without its sizes.
        ///
        /// ```
        /// use vadop::shape::{Shape, ShapeKind};
        /// let kind = Shape::ConvexHull { points: Vec::new() }.kind();
        /// assert_eq!((kind.name(), kind.parameters()), ("convex_hull", &["points"][..]));
        /// assert_eq!(ShapeKind::from_name("convex_hull"), Some(kind));
        /// ```
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum ShapeKind {
            $($variant,)*
        }

        impl ShapeKind {
            /// Every kind, in the order summaries list them.
            pub const ALL: [ShapeKind; [$($name),*].len()] = [$(ShapeKind::$variant),*];

            /// The kind's name, as scene files, Python and the viewer spell it.
            pub fn name(self) -> &'static str {
                match self {
                    $(ShapeKind::$variant => $name,)*
                }
            }

            /// The kind called `name`.
            pub fn from_name(name: &str) -> Option<ShapeKind> {
                ShapeKind::ALL.into_iter().find(|kind| kind.name() == name)
            }

            /// The shape's parameters (the fields of its [`Shape`] variant), in order.
            pub fn parameters(self) -> &'static [&'static str] {
                match self {
                    $(ShapeKind::$variant => &[$($parameter),*],)*
                }
            }

            /// How a readable summary names one body of the kind, and several.
            pub fn words(self) -> (&'static str, &'static str) {
                match self {
                    $(ShapeKind::$variant => ($singular, $plural),)*
                }
            }
        }

        impl Shape {
            /// The shape's kind.
            pub fn kind(&self) -> ShapeKind {
                match self {
                    $(Shape::$variant { .. } => ShapeKind::$variant,)*
                }
            }
        }
    };
}

shape_kinds! {
    Sphere => "sphere", ["radius"], "sphere", "spheres";
    Cuboid => "cuboid", ["half_extents"], "cuboid", "cuboids";
    Capsule => "capsule", ["half_height", "radius"], "capsule", "capsules";
    Cylinder => "cylinder", ["half_height", "radius"], "cylinder", "cylinders";
    Cone => "cone", ["half_height", "radius"], "cone", "cones";
    ConvexHull => "convex_hull", ["points"], "convex hull", "convex hulls";
    TriMesh => "trimesh", ["vertices", "triangles"], "triangle mesh", "triangle meshes";
    HalfSpace => "halfspace", ["normal"], "half-space", "half-spaces";
}

/// Everything derived once from a [`Shape`]: built by [`Shape::geometry`], which validates.
#[derive(Debug, Clone)]
pub struct ShapeGeometry {
    shape: Shape,
    parry: SharedShape,
    volume: f64,
    principal_inertia: DVec3,
    body_from_shape: Pose,
    bounding_radius: Option<f64>,
    rotation_radius: f64,
    /// [`ShapeGeometry::rotation_radius_about`] each principal axis, computed once.
    principal_reach: [f64; 3],
    /// A convex hull's face planes (outward unit normal, offset from the shape frame's origin),
    /// empty for other kinds: how deep a point lies is the least of the offsets less its
    /// projections on the normals, read in one pass over contiguous planes.
    face_planes: Vec<(DVec3, f64)>,
}

/// Relative margin added to computed bounding radii so that rounding never leaves a point of the
/// shape outside its bounding sphere.
const RADIUS_MARGIN: f64 = 1e-12;

/// A hull whose points span less than this fraction of their size in the third dimension (or a
/// triangle whose sides make an angle with sine below it) is flat.
const FLATNESS: f64 = 1e-12;

/// A size: finite, > 0, and within the library's range.
fn check_size(what: &'static str, value: f64) -> Result<()> {
    if !(value.is_finite() && value > 0.0) {
        return Err(VadopError::BadSize { what, value });
    }
    check_length(what, value)
}

/// `v`'s error wrapped with its place in the list.
fn at<T>(what: &'static str, index: usize, result: Result<T>) -> Result<T> {
    result.map_err(|source| VadopError::InShape { what, index, source: Box::new(source) })
}

impl Shape {
    /// True for shapes that can only be static level geometry: a triangle mesh or a half-space.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::shape::Shape;
    /// assert!(Shape::HalfSpace { normal: DVec3::Y }.is_static_only());
    /// assert!(!Shape::Sphere { radius: 1.0 }.is_static_only());
    /// ```
    pub fn is_static_only(&self) -> bool {
        matches!(self, Shape::TriMesh { .. } | Shape::HalfSpace { .. })
    }

    /// Validates the shape and derives its geometry. Sizes must be finite, > 0 and within
    /// `[1e-50, 1e50]`; coordinates finite and at most `1e50` in magnitude; a convex hull needs
    /// at least four points not all in one plane; a mesh at least one triangle, every index below
    /// the vertex count and no triangle of zero area; a half-space a non-zero normal. Anything
    /// else is an [`Err`] whose message says what was wrong.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::shape::Shape;
    /// let flat = Shape::ConvexHull { points: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::X + DVec3::Y] };
    /// let message = flat.geometry().unwrap_err().to_string();
    /// assert!(message.contains("one plane"), "{message}");
    /// let tetrahedron = Shape::ConvexHull { points: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z] };
    /// assert!((tetrahedron.geometry().unwrap().volume() - 1.0 / 6.0).abs() < 1e-15);
    /// ```
    pub fn geometry(&self) -> Result<ShapeGeometry> {
        match self {
            Shape::Sphere { radius } => {
                check_size("sphere radius", *radius)?;
                // A ball is the same set however it turns: rotation never moves its surface.
                Ok(self.solid(SharedShape::ball(*radius), *radius, 0.0))
            }
            Shape::Cuboid { half_extents: h } => {
                check_vector("cuboid half extents", *h)?;
                for (axis, what) in
                    ["cuboid half extent x", "cuboid half extent y", "cuboid half extent z"].iter().enumerate()
                {
                    check_size(what, h[axis])?;
                }
                let radius = h.length();
                Ok(self.solid(SharedShape::cuboid(h.x, h.y, h.z), radius, radius))
            }
            Shape::Capsule { half_height, radius } => {
                check_size("capsule half height", *half_height)?;
                check_size("capsule radius", *radius)?;
                // The points within `radius` of its segment: turning moves them as it moves the
                // segment's ends.
                let bound = half_height + radius;
                Ok(self.solid(SharedShape::capsule_y(*half_height, *radius), bound, *half_height))
            }
            Shape::Cylinder { half_height, radius } => {
                check_size("cylinder half height", *half_height)?;
                check_size("cylinder radius", *radius)?;
                let bound = DVec3::new(*half_height, *radius, 0.0).length();
                Ok(self.solid(SharedShape::cylinder(*half_height, *radius), bound, bound))
            }
            Shape::Cone { half_height, radius } => {
                check_size("cone half height", *half_height)?;
                check_size("cone radius", *radius)?;
                // The centre of mass is at -half_height / 2: the apex lies 1.5 half heights from
                // it, the base rim at hypot(half_height / 2, radius).
                let apex = 1.5 * half_height;
                let rim = DVec3::new(0.5 * half_height, *radius, 0.0).length();
                let bound = apex.max(rim);
                Ok(self.solid(SharedShape::cone(*half_height, *radius), bound, bound))
            }
            Shape::ConvexHull { points } => self.hull(points),
            Shape::TriMesh { vertices, triangles } => self.mesh(vertices, triangles),
            Shape::HalfSpace { normal } => {
                check_vector("half-space normal", *normal)?;
                let n = direction(*normal).ok_or(VadopError::ZeroNormal(normal.to_array()))?;
                Ok(self.fixed(SharedShape::halfspace(n)))
            }
        }
    }

    /// The geometry of a solid shape whose parry form is `parry`, given a bound on its distance
    /// from the centre of mass (`bound`) and on that of its core (`rotation_radius`, see
    /// [`ShapeGeometry::rotation_radius`]).
    fn solid(&self, parry: SharedShape, bound: f64, rotation_radius: f64) -> ShapeGeometry {
        let props = parry.mass_properties(1.0);
        let body_from_shape = Pose::from_parts(props.local_com, props.principal_inertia_local_frame).inverse();
        let rotation_radius = rotation_radius * (1.0 + RADIUS_MARGIN);
        let principal_reach =
            DVec3::AXES.map(|axis| self.reach_about(&parry, body_from_shape, axis).min(rotation_radius));
        let face_planes = parry.as_convex_polyhedron().map_or_else(Vec::new, |hull| {
            let (points, corners) = (hull.points(), hull.vertices_adj_to_face());
            let plane = |normal: DVec3, corner: u32| (normal, normal.dot(points[corners[corner as usize] as usize]));
            hull.faces().iter().map(|face| plane(face.normal, face.first_vertex_or_edge)).collect()
        });
        ShapeGeometry {
            shape: self.clone(),
            volume: props.mass(),
            principal_inertia: props.principal_inertia(),
            body_from_shape,
            bounding_radius: Some(bound * (1.0 + RADIUS_MARGIN)),
            rotation_radius,
            principal_reach,
            face_planes,
            parry,
        }
    }

    /// How far the core of this shape (as `parry`, placed in the body frame by `body`) reaches
    /// from the line through the centre of mass along the unit `axis`: from a cuboid's corners, a
    /// capsule's segment ends and a hull's points; infinite for the round kinds (the rotation
    /// radius bounds them).
    fn reach_about(&self, parry: &SharedShape, body: Pose, axis: DVec3) -> f64 {
        let off_axis = |points: &mut dyn Iterator<Item = DVec3>| {
            points.map(|p| (body * p).reject_from_normalized(axis).length()).fold(0.0, f64::max) * (1.0 + RADIUS_MARGIN)
        };
        match self {
            Shape::Cuboid { half_extents: h } => off_axis(&mut (0..8).map(|k| *h * corner(k))),
            Shape::Capsule { half_height, .. } => {
                off_axis(&mut [DVec3::Y, -DVec3::Y].map(|y| y * *half_height).into_iter())
            }
            Shape::ConvexHull { .. } => match parry.as_convex_polyhedron() {
                Some(hull) => off_axis(&mut hull.points().iter().copied()),
                None => f64::INFINITY,
            },
            _ => f64::INFINITY,
        }
    }

    /// The geometry of a static-only shape.
    fn fixed(&self, parry: SharedShape) -> ShapeGeometry {
        ShapeGeometry {
            shape: self.clone(),
            parry,
            volume: 0.0,
            principal_inertia: DVec3::ZERO,
            body_from_shape: Pose::IDENTITY,
            bounding_radius: None,
            rotation_radius: 0.0,
            principal_reach: [0.0; 3],
            face_planes: Vec::new(),
        }
    }

    fn hull(&self, points: &[DVec3]) -> Result<ShapeGeometry> {
        for (i, p) in points.iter().enumerate() {
            at("convex hull point", i, check_vector("convex hull point", *p))?;
        }
        if points.len() < 4 {
            return Err(VadopError::HullTooFewPoints(points.len()));
        }
        let thickness = relative_thickness(points);
        if !(thickness > FLATNESS) {
            return Err(VadopError::FlatHull { thickness });
        }
        let failed = VadopError::HullFailed { points: points.len() };
        // parry's hull is robust on valid input; a panic inside it must still not escape.
        let polyhedron = std::panic::catch_unwind(|| ConvexPolyhedron::from_convex_hull(points))
            .map_err(|_| failed.clone())?
            .ok_or(failed.clone())?;
        let parry = SharedShape::new(polyhedron);
        let props = parry.mass_properties(1.0);
        if !(props.mass() > 0.0 && props.mass().is_finite()) {
            return Err(failed);
        }
        let com = props.local_com;
        let hull_points = parry.as_convex_polyhedron().map(|c| c.points()).unwrap_or(points);
        let radius = hull_points.iter().map(|p| (*p - com).length()).fold(0.0, f64::max);
        check_length("convex hull size", radius)?;
        Ok(self.solid(parry, radius, radius))
    }

    fn mesh(&self, vertices: &[DVec3], triangles: &[[u32; 3]]) -> Result<ShapeGeometry> {
        if vertices.is_empty() || triangles.is_empty() {
            return Err(VadopError::EmptyMesh { vertices: vertices.len(), triangles: triangles.len() });
        }
        for (i, v) in vertices.iter().enumerate() {
            at("mesh vertex", i, check_vector("mesh vertex", *v))?;
        }
        for (i, t) in triangles.iter().enumerate() {
            if t.iter().any(|&k| k as usize >= vertices.len()) {
                return Err(VadopError::BadTriangleIndex { triangle: i, indices: *t, vertices: vertices.len() });
            }
            let [a, b, c] = t.map(|k| vertices[k as usize]);
            let (e1, e2) = (b - a, c - a);
            let scale = unit_scale(e1.abs().max_element().max(e2.abs().max_element()));
            let (e1, e2) = (e1 * scale, e2 * scale);
            let area = e1.cross(e2).length();
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || !(area > FLATNESS * e1.length() * e2.length()) {
                return Err(VadopError::DegenerateTriangle { triangle: i, indices: *t });
            }
        }
        let mesh = TriMesh::new(vertices.to_vec(), triangles.to_vec())
            .map_err(|_| VadopError::EmptyMesh { vertices: vertices.len(), triangles: triangles.len() })?;
        Ok(self.fixed(SharedShape::new(mesh)))
    }
}

/// Corner `k` (0 to 7) of the box with half extents 1: the signs of bits 0, 1 and 2 of `k`.
fn corner(k: usize) -> DVec3 {
    let sign = |bit: usize| if k >> bit & 1 == 0 { 1.0 } else { -1.0 };
    DVec3::new(sign(0), sign(1), sign(2))
}

/// How far `points` extend out of their best plane, relative to their extent: the volume of the
/// largest tetrahedron found greedily, over the cube of the largest distance from the first point.
/// Zero for coplanar or collinear points.
fn relative_thickness(points: &[DVec3]) -> f64 {
    let origin = points[0];
    let offsets: Vec<DVec3> = points.iter().map(|p| *p - origin).collect();
    let size = offsets.iter().map(|d| d.abs().max_element()).fold(0.0, f64::max);
    if !(size > 0.0) {
        return 0.0;
    }
    // Exact power-of-two scaling: no cube under- or overflows whatever the hull's size.
    let scale = unit_scale(size);
    let offsets: Vec<DVec3> = offsets.iter().map(|d| *d * scale).collect();
    let argmax = |f: &dyn Fn(DVec3) -> f64| {
        offsets.iter().copied().max_by(|x, y| f(*x).total_cmp(&f(*y))).unwrap_or(DVec3::ZERO)
    };
    let first = argmax(&|d| d.length_squared());
    let second = argmax(&|d| d.cross(first).length_squared());
    let normal = first.cross(second);
    let third = argmax(&|d| d.dot(normal).abs());
    let extent = first.length();
    normal.dot(third).abs() / (extent * extent * extent)
}

impl ShapeGeometry {
    /// The shape this geometry was built from.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// The parry shape, in the shape frame, that all queries run on.
    pub fn parry_shape(&self) -> &SharedShape {
        &self.parry
    }

    /// A convex hull's face planes in the shape frame (outward unit normal, offset), in parry's
    /// order of its faces; empty for other kinds.
    pub(crate) fn face_planes(&self) -> &[(DVec3, f64)] {
        &self.face_planes
    }

    /// True for static-only shapes (a mesh or a half-space).
    pub fn is_static_only(&self) -> bool {
        self.shape.is_static_only()
    }

    /// Volume, which is also the mass at unit density (0 for static-only shapes).
    pub fn volume(&self) -> f64 {
        self.volume
    }

    /// Principal moments of inertia at unit density, about the body frame's axes (zero for
    /// static-only shapes).
    pub fn principal_inertia_unit(&self) -> DVec3 {
        self.principal_inertia
    }

    /// Mass and principal moments of inertia (about the body frame's axes) at `density` (a
    /// finite number > 0, which the caller validates). Static-only shapes are immovable: both are
    /// infinite.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::shape::Shape;
    /// let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
    /// let (mass, inertia) = cube.mass_properties(2.0);
    /// assert_eq!(mass, 2.0);
    /// // m (a^2 + b^2) / 12 for a unit cube.
    /// assert!((inertia - DVec3::splat(2.0 / 6.0)).abs().max_element() < 1e-12);
    /// let floor = Shape::HalfSpace { normal: DVec3::Y }.geometry().unwrap();
    /// assert_eq!(floor.mass_properties(2.0).0, f64::INFINITY);
    /// ```
    pub fn mass_properties(&self, density: f64) -> (f64, DVec3) {
        if self.is_static_only() {
            (f64::INFINITY, DVec3::INFINITY)
        } else {
            (self.volume * density, self.principal_inertia * density)
        }
    }

    /// Maps shape-frame points into the body frame (origin at the centre of mass, axes along the
    /// principal axes). The identity for static-only shapes.
    pub fn body_from_shape(&self) -> Pose {
        self.body_from_shape
    }

    /// The parry pose of the shape for a body whose centre of mass is at `position` and whose
    /// `orientation` rotates body-frame vectors to world vectors.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::shape::Shape;
    /// let rod = Shape::Capsule { half_height: 2.0, radius: 0.5 }.geometry().unwrap();
    /// let pose = rod.pose_of_shape(DVec3::new(1.0, 0.0, 0.0), DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2));
    /// // The rod's local +y end now points along -x.
    /// assert!((pose * DVec3::new(0.0, 2.0, 0.0) - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-12);
    /// ```
    pub fn pose_of_shape(&self, position: DVec3, orientation: DQuat) -> Pose {
        Pose::from_parts(position, orientation) * self.body_from_shape
    }

    /// Radius of the smallest sphere about the centre of mass that holds the whole shape (a hair
    /// larger, so rounding never leaves a point outside): all the broad phase ever sees of a
    /// shape. `None` for static-only shapes, which are unbounded or bounded by their own
    /// hierarchy.
    pub fn bounding_radius(&self) -> Option<f64> {
        self.bounding_radius
    }

    /// The bounding radius, 0 for static-only shapes: what the contact tolerance of a pair is
    /// proportional to.
    pub(crate) fn size(&self) -> f64 {
        self.bounding_radius.unwrap_or(0.0)
    }

    /// Bound on the distance from the centre of mass of the shape's core, the set the shape holds
    /// every point within a fixed radius of (a ball's centre, a capsule's segment, the whole shape
    /// otherwise): a turn at angular speed w moves the shape's support in any fixed direction at
    /// most w times this. Zero for a ball, whose surface does not move when it turns, and for
    /// static-only shapes.
    pub(crate) fn rotation_radius(&self) -> f64 {
        self.rotation_radius
    }

    /// The axis, in the body's principal frame, about which the shape is symmetric under every
    /// turn (a capsule's, cylinder's or cone's own y axis): a spin about it leaves the shape where
    /// it is. `None` for shapes without one; a ball is symmetric about every axis.
    pub(crate) fn symmetry_axis(&self) -> Option<DVec3> {
        match self.shape {
            Shape::Capsule { .. } | Shape::Cylinder { .. } | Shape::Cone { .. } => {
                Some(self.body_from_shape.rotation * DVec3::Y)
            }
            _ => None,
        }
    }

    /// Bound on the distance of the shape's core (see [`Self::rotation_radius`]) from the line
    /// through the centre of mass along `axis` (a unit vector in the body's principal frame): a
    /// steady spin about that axis at angular speed w moves the shape's support in any fixed
    /// direction n at most w |n x axis| times this. About a principal axis (where steady spins
    /// of bodies with distinct moments are) it is exact, up to the radii's margin, for a
    /// cuboid's corners, a capsule's segment and a hull's points, and the rotation radius for
    /// the round kinds; about any other axis, the rotation radius.
    pub(crate) fn rotation_radius_about(&self, axis: DVec3) -> f64 {
        match DVec3::AXES.iter().position(|&e| axis.abs() == e) {
            Some(k) => self.principal_reach[k],
            None => self.rotation_radius,
        }
    }

    /// The axis-aligned box `(min, max)` of a triangle mesh in its own frame; `None` for other
    /// shapes (a half-space is unbounded, a solid has its bounding radius).
    pub fn local_aabb(&self) -> Option<(DVec3, DVec3)> {
        let aabb = self.parry.as_trimesh()?.local_aabb();
        Some((aabb.mins, aabb.maxs))
    }
}

/// One solid of each moving kind, about one unit across, for the narrow phase's unit tests.
#[cfg(test)]
pub(crate) fn one_solid_of_each_kind() -> [Shape; 6] {
    let hull = [[0.5, 0.0, 0.0], [-0.3, 0.4, 0.1], [-0.2, -0.4, 0.2], [0.0, 0.1, -0.5], [0.1, 0.0, 0.45]];
    [
        Shape::Sphere { radius: 0.4 },
        Shape::Capsule { half_height: 0.3, radius: 0.2 },
        Shape::Cuboid { half_extents: DVec3::new(0.35, 0.25, 0.2) },
        Shape::Cone { half_height: 0.4, radius: 0.3 },
        Shape::Cylinder { half_height: 0.4, radius: 0.3 },
        Shape::ConvexHull { points: hull.map(DVec3::from_array).to_vec() },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all_solids() -> Vec<Shape> {
        vec![
            Shape::Sphere { radius: 0.7 },
            Shape::Cuboid { half_extents: DVec3::new(1.0, 0.5, 0.25) },
            Shape::Capsule { half_height: 1.0, radius: 0.3 },
            Shape::Cylinder { half_height: 0.8, radius: 0.4 },
            Shape::Cone { half_height: 0.6, radius: 0.5 },
            Shape::ConvexHull {
                points: vec![
                    DVec3::new(0.3, 0.1, 0.0),
                    DVec3::new(2.0, 0.0, 0.1),
                    DVec3::new(0.0, 1.5, 0.2),
                    DVec3::new(0.1, 0.2, 1.0),
                    DVec3::new(1.0, 1.0, 1.0),
                ],
            },
        ]
    }

    /// Points sampled on the shape's surface through its support map, in the shape frame.
    fn support_samples(geometry: &ShapeGeometry) -> Vec<DVec3> {
        let support = geometry.parry_shape().as_support_map().unwrap();
        let mut out = Vec::new();
        for i in 0..400 {
            // A spiral of directions over the sphere.
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 400.0;
            let phi = i as f64 * 2.399963229728653;
            let r = (1.0 - z * z).sqrt();
            out.push(support.local_support_point(DVec3::new(r * phi.cos(), r * phi.sin(), z)));
        }
        out
    }

    #[test]
    fn scene_files_spell_every_kind_by_its_one_name_and_read_the_old_names_too() {
        let shapes = [
            Shape::Sphere { radius: 1.0 },
            Shape::Cuboid { half_extents: DVec3::ONE },
            Shape::Capsule { half_height: 1.0, radius: 1.0 },
            Shape::Cylinder { half_height: 1.0, radius: 1.0 },
            Shape::Cone { half_height: 1.0, radius: 1.0 },
            Shape::ConvexHull { points: vec![DVec3::ZERO] },
            Shape::TriMesh { vertices: vec![DVec3::ZERO], triangles: vec![[0, 0, 0]] },
            Shape::HalfSpace { normal: DVec3::Y },
        ];
        let kinds: Vec<ShapeKind> = shapes.iter().map(Shape::kind).collect();
        assert_eq!(kinds, ShapeKind::ALL);
        for shape in shapes {
            let json = serde_json::to_value(&shape).unwrap();
            let tag = json.as_object().unwrap().keys().next().unwrap().clone();
            assert_eq!(tag, shape.kind().name());
            let old = format!("{:?}", shape.kind());
            let renamed = serde_json::json!({ old: json[&tag].clone() });
            assert_eq!(serde_json::from_value::<Shape>(renamed).unwrap(), shape);
        }
    }

    #[test]
    fn bounding_radius_holds_the_shape_and_is_tight() {
        for shape in all_solids() {
            let g = shape.geometry().unwrap();
            let r = g.bounding_radius().unwrap();
            let body = g.body_from_shape();
            let farthest = support_samples(&g).iter().map(|p| (body * *p).length()).fold(0.0, f64::max);
            assert!(farthest <= r, "{shape:?}: {farthest} > {r}");
            assert!(farthest >= 0.98 * r, "{shape:?}: radius {r} not tight ({farthest})");
        }
    }

    #[test]
    fn body_frame_is_at_the_centre_of_mass_on_principal_axes() {
        for shape in all_solids() {
            let g = shape.geometry().unwrap();
            // In the body frame the centre of mass is the origin and the inertia is diagonal.
            let props = g.parry_shape().mass_properties(1.0).transform_by(&g.body_from_shape());
            assert!(props.local_com.length() < 1e-12, "{shape:?}: {:?}", props.local_com);
            let inertia = props.reconstruct_inertia_matrix();
            let off = inertia.x_axis.y.abs() + inertia.x_axis.z.abs() + inertia.y_axis.z.abs();
            assert!(off < 1e-9 * inertia.x_axis.x.abs(), "{shape:?}: {inertia:?}");
            let diagonal = DVec3::new(inertia.x_axis.x, inertia.y_axis.y, inertia.z_axis.z);
            assert!((diagonal - g.principal_inertia_unit()).abs().max_element() < 1e-9, "{shape:?}");
            assert!(g.volume() > 0.0);
        }
    }

    #[test]
    fn cone_frame_and_sphere_rotation_radius() {
        let g = Shape::Cone { half_height: 2.0, radius: 1.0 }.geometry().unwrap();
        assert_eq!(g.body_from_shape().translation, DVec3::new(0.0, 1.0, 0.0));
        assert!((g.bounding_radius().unwrap() - 3.0).abs() < 1e-9);
        let ball = Shape::Sphere { radius: 2.0 }.geometry().unwrap();
        assert_eq!(ball.rotation_radius(), 0.0);
        assert!(ball.bounding_radius().unwrap() >= 2.0);
    }

    #[test]
    fn static_only_shapes() {
        let floor = Shape::HalfSpace { normal: DVec3::new(0.0, 3.0, 0.0) }.geometry().unwrap();
        assert!(floor.is_static_only() && floor.bounding_radius().is_none());
        let hs = floor.parry_shape().as_halfspace().unwrap();
        assert_eq!(hs.normal, DVec3::Y);
        let mesh = Shape::TriMesh { vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Z], triangles: vec![[0, 1, 2]] };
        let mesh = mesh.geometry().unwrap();
        assert_eq!(mesh.local_aabb(), Some((DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0))));
        assert_eq!(mesh.mass_properties(1.0).0, f64::INFINITY);
    }

    #[test]
    fn invalid_shapes_are_errors_with_messages() {
        let bad = [
            (Shape::Sphere { radius: f64::NAN }, "sphere radius"),
            (Shape::Sphere { radius: -1.0 }, "sphere radius"),
            (Shape::Sphere { radius: 1e-60 }, "out of range"),
            (Shape::Cuboid { half_extents: DVec3::new(1.0, f64::INFINITY, 1.0) }, "finite"),
            (Shape::Capsule { half_height: 0.0, radius: 1.0 }, "capsule half height"),
            (Shape::Cylinder { half_height: 1.0, radius: 1e60 }, "out of range"),
            (Shape::Cone { half_height: 1.0, radius: 0.0 }, "cone radius"),
            (Shape::ConvexHull { points: vec![DVec3::ZERO, DVec3::X, DVec3::Y] }, "at least 4"),
            (Shape::ConvexHull { points: vec![DVec3::ZERO; 6] }, "one plane"),
            (Shape::ConvexHull { points: vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0, DVec3::X * 3.0] }, "one line"),
            (
                Shape::ConvexHull { points: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(0.0, 0.0, f64::NAN)] },
                "convex hull point 3",
            ),
            (Shape::TriMesh { vertices: vec![DVec3::ZERO], triangles: vec![] }, "at least one triangle"),
            (Shape::TriMesh { vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y], triangles: vec![[0, 1, 3]] }, "below"),
            (
                Shape::TriMesh { vertices: vec![DVec3::ZERO, DVec3::X, DVec3::Y], triangles: vec![[0, 1, 1]] },
                "zero area",
            ),
            (
                Shape::TriMesh { vertices: vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0], triangles: vec![[0, 1, 2]] },
                "zero area",
            ),
            (Shape::HalfSpace { normal: DVec3::ZERO }, "non-zero"),
        ];
        for (shape, expected) in bad {
            let message = shape.geometry().unwrap_err().to_string();
            assert!(message.contains(expected), "{shape:?}: {message}");
        }
    }

    #[test]
    fn tiny_and_huge_shapes_scale_exactly_enough() {
        let unit = Shape::Cone { half_height: 1.0, radius: 0.5 }.geometry().unwrap();
        for e in [-160, 160] {
            let s = 2f64.powi(e);
            let g = Shape::Cone { half_height: s, radius: 0.5 * s }.geometry().unwrap();
            assert!((g.bounding_radius().unwrap() / s - unit.bounding_radius().unwrap()).abs() < 1e-15);
            assert!((g.volume() / (s * s * s) - unit.volume()).abs() < 1e-15);
            let hull = Shape::ConvexHull { points: vec![DVec3::ZERO, DVec3::X * s, DVec3::Y * s, DVec3::Z * s] };
            assert!((hull.geometry().unwrap().volume() / (s * s * s) - 1.0 / 6.0).abs() < 1e-12);
        }
    }

    #[test]
    fn serde_round_trip() {
        for shape in all_solids() {
            let text = serde_json::to_string(&shape).unwrap();
            assert_eq!(serde_json::from_str::<Shape>(&text).unwrap(), shape);
        }
    }
}
