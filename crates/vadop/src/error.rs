//! Typed errors for every public entry point.
//!
//! Every fallible call validates its input *before* it touches any state, so an `Err` always
//! leaves the world exactly as it was. Messages name the offending value and what was expected.

use crate::handle::BodyHandle;
use thiserror::Error;

/// Everything that can go wrong when building or stepping a world.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum VadopError {
    /// A position, velocity or other vector had a NaN or infinite component.
    #[error("{what} must be finite, got {value}")]
    NotFinite { what: &'static str, value: String },
    /// A radius was zero, negative or not finite.
    #[error("radius must be a finite number > 0, got {0}")]
    BadRadius(f64),
    /// A sphere of a batch (`add_spheres`, a scene file) was rejected; `index` is its place in
    /// the batch, so a user can find it among thousands.
    #[error("sphere {index}: {source}")]
    InSphere { index: usize, source: Box<VadopError> },
    /// A body of a batch (`add_bodies`, a scene file) was rejected; `index` is its place in the
    /// batch.
    #[error("body {index}: {source}")]
    InBody { index: usize, source: Box<VadopError> },
    /// A static body of a scene was rejected; `index` is its place among the scene's static
    /// bodies.
    #[error("static body {index}: {source}")]
    InStaticBody { index: usize, source: Box<VadopError> },
    /// A shape of a scene's table was rejected; `index` is its place in the table.
    #[error("shape {index} ({name:?}): {source}")]
    InSceneShape { index: usize, name: String, source: Box<VadopError> },
    /// A scene's body named a shape that its table does not hold.
    #[error("no shape named {0:?} in the scene's shapes (names are case-sensitive)")]
    UnknownShapeName(String),
    /// A scene's table gave a name to two shapes; `first` is the first one's place.
    #[error("the name is taken by shape {first}: give every shape a name of its own")]
    DuplicateShapeName { first: usize },
    /// A scene's moving body took level geometry.
    #[error("shape {0:?} is level geometry (a triangle mesh or a half-space): only a static body can take it")]
    MovingLevelGeometry(String),
    /// [`VadopError::Overlap`] in a world built from a scene, with the bodies named as the scene's
    /// entries (see [`crate::scene::SceneLayout::name_entries`]).
    #[error("{a} and {b} overlap by {depth:.3e} at the start of a simulate-mode run; collisions can only be resolved between separate bodies")]
    SceneOverlap { a: SceneEntry, b: SceneEntry, depth: f64 },
    /// A mass was zero, negative or not finite.
    #[error("mass must be a finite number > 0, got {0}")]
    BadMass(f64),
    /// The restitution coefficient was outside [0, 1].
    #[error("restitution must lie in [0, 1], got {0}")]
    BadRestitution(f64),
    /// A finite value too large (or a mass too small) for the arithmetic to stay finite.
    #[error("{what} {value:e} is out of range: coordinates, velocities, radii and masses must have magnitude at most 1e50, and masses at least 1e-50, so that squared distances, speeds and inverse masses stay finite")]
    OutOfRange { what: &'static str, value: f64 },
    /// The box had a non-finite corner or a side of length <= 0.
    #[error("box must have finite corners with min < max on every axis, got min {min:?} max {max:?}")]
    BadBox { min: [f64; 3], max: [f64; 3] },
    /// A sphere did not fit entirely inside the box.
    #[error("sphere at {position:?} with radius {radius} does not fit inside the box {min:?}..{max:?}")]
    OutsideBox { position: [f64; 3], radius: f64, min: [f64; 3], max: [f64; 3] },
    /// A body's shape reaches out of the box.
    #[error("the body at {position:?} reaches out of the box: its shape spans {low:?}..{high:?}")]
    ShapeOutsideBox { position: [f64; 3], low: [f64; 3], high: [f64; 3] },
    /// A shape id the world never gave out.
    #[error("no shape {0}: give a ShapeId from World::add_shape")]
    NoSuchShape(u32),
    /// A triangle mesh or half-space given to a moving body.
    #[error("shape {0} is level geometry (a triangle mesh or a half-space): it can only be a static body (World::add_static)")]
    StaticOnlyShape(u32),
    /// An orientation that is not a rotation.
    #[error("orientation must be a finite, non-zero quaternion, got {0:?}")]
    BadOrientation([f64; 4]),
    /// A sphere's call on a body of another shape.
    #[error("body {0} is not a sphere: use World::body, World::remove_body")]
    NotASphere(BodyHandle),
    /// A velocity given to a static body.
    #[error("body {0} is static: it never moves")]
    StaticBody(BodyHandle),
    /// The discrete (frame-instant) method was given a body other than a moving sphere.
    #[error(
        "the discrete method checks overlaps of spheres only: give shapes and static bodies to a continuous method"
    )]
    DiscreteSpheresOnly,
    /// The friction coefficient was negative or not finite.
    #[error("friction must be a finite number >= 0, got {0}")]
    BadFriction(f64),
    /// The contact duration of the TC model was negative or not finite.
    #[error("contact duration must be a finite number >= 0 seconds, got {0}")]
    BadContactDuration(f64),
    /// A thread count of zero.
    #[error("threads must be at least 1 (or left unset for every core)")]
    BadThreads,
    /// Contact ends were asked for in simulate mode, where contacts are impacts that end at once.
    #[error(
        "contact ends are reported in detect mode only: in simulate mode a contact is an impact, over as it starts"
    )]
    ContactEndsNeedDetectMode,
    /// Gravity that is not a finite vector.
    #[error("gravity must be a finite vector, got {0:?}")]
    BadGravity([f64; 3]),
    /// A body that (nearly) rests on a wall under gravity: it would bounce without end.
    #[error("body {body} rests on a wall under gravity: its bounces rise {height:e}, so it would bounce more than {limit:e} times in this step; bodies come to rest only in simulate mode with restitution below 1, so such a body is refused rather than left to sink or to bounce without end")]
    RestingUnderGravity { body: BodyHandle, height: f64, limit: f64 },
    /// A periodic box with what it does not support yet.
    #[error(
        "periodic boxes take moving bodies of any shape but no static bodies yet (level geometry is not periodic): {0}"
    )]
    PeriodicUnsupported(&'static str),
    /// A body too large for a periodic side: it would meet a neighbour through two images.
    #[error("the box's periodic side along {axis} is {side}, less than {minimum} times the diameter {diameter} of a body: a periodic side must hold that many of the largest diameter, so two bodies meet through one image at a time")]
    PeriodicSideTooShort { axis: char, side: f64, diameter: f64, minimum: f64 },
    /// A length (radius, box side) below the supported range.
    #[error(
        "{what} {value:e} is out of range: radii, box sides and shape sizes must be at least 1e-50 (and at most 1e50)"
    )]
    TooSmall { what: &'static str, value: f64 },
    /// The time step was zero, negative or not finite.
    #[error("time step must be a finite number > 0, got {0}")]
    BadTimeStep(f64),
    /// The world's time plus the time step is no longer a finite number.
    #[error("the world's time {time:e} plus the time step {dt:e} is not finite; positions at that time would be NaN")]
    TimeOverflow { time: f64, dt: f64 },
    /// [`crate::World::start_at`] with a time that is not finite or is negative.
    #[error("a world's start time must be finite and >= 0, got {0}")]
    BadStartTime(f64),
    /// [`crate::World::start_at`] on a world that holds bodies or has stepped: its clock is theirs.
    #[error("only an empty world that has never stepped can start at another time")]
    AlreadyStarted,
    /// A body's record ([`crate::SphereRecord`]) holds a time after the world's.
    #[error("a record's {what} must be finite and at most the world's time {time}, got {value}")]
    BadRecordTime { what: &'static str, value: f64, time: f64 },
    /// A body's record rests in a way its world or its velocity does not allow.
    /// The rest is named as printed (`Rest`'s debug form), so the error module needs no body type.
    #[error("a record's rest {0} needs gravity, and no velocity along the walls it slides on (axes as bits 1 to 7) or none at all lying still")]
    BadRecordRest(String),
    /// A body's record counts crossings of periodic faces, but the box has walls on every axis.
    #[error("a record counts crossings of periodic faces, but this world's box has none")]
    CrossingsInWalledBox,
    /// The step's interrupt flag ([`crate::World::set_interrupt`]) was raised: the world is as it
    /// was before the step.
    #[error("the step was interrupted; the world is as it was before it")]
    Interrupted,
    /// The time step is below the resolution of the world's time: the clock would not move.
    #[error(
        "the time step {dt:e} is too small to advance the world's time {time:e} (below its floating-point resolution)"
    )]
    TimeStepTooSmall { time: f64, dt: f64 },
    /// `step` was called on a world with no bodies.
    #[error("the world is empty: add at least one sphere before stepping")]
    EmptyWorld,
    /// A batch call was given lists of different lengths.
    #[error("{handles} handles but {velocities} velocities: give one velocity per handle")]
    LengthMismatch { handles: usize, velocities: usize },
    /// A handle this world never gave out.
    #[error("no body with handle {0} in this world")]
    NoSuchBody(BodyHandle),
    /// The handle of a body since removed; `current` is the body its slot holds now, if any.
    #[error("body {handle} was removed{}", now_in_slot(.current))]
    StaleHandle { handle: BodyHandle, current: Option<BodyHandle> },
    /// Two spheres overlap at the start of a run that resolves collisions.
    #[error("spheres {a} and {b} overlap by {depth:.3e} at the start of a simulate-mode run; collisions can only be resolved between separate bodies")]
    Overlap { a: BodyHandle, b: BodyHandle, depth: f64 },
    /// A body would cross the box so many times in one frame that stepping it is meaningless.
    #[error("body {body} moves {lengths:.3e} box lengths in one frame (limit {limit:.0e}); reduce the speed or the time step")]
    AbsurdSpeed { body: BodyHandle, lengths: f64, limit: f64 },
    /// The axis pool size was out of the supported range.
    #[error("axis pool size must be between {min} and {max}, got {got}")]
    BadPoolSize { got: usize, min: usize, max: usize },
    /// The alignment angle phi was out of range.
    #[error("phi must be a finite angle in [rho, pi/2] radians (rho = {rho:.6}) so that every pair of bodies shares an axis, got {got}")]
    BadPhi { got: f64, rho: f64 },
    /// Too many bodies: a world holds fewer than 2^31 slots (the event loop flags a cell in a body
    /// index's top bit).
    #[error("a world holds at most {0} bodies")]
    TooManyBodies(usize),
    /// A scene file or scene parameters could not be used.
    #[error("scene: {0}")]
    Scene(String),
    /// A size of a shape (half extent, radius, half height) was zero, negative or not finite.
    #[error("{what} must be a finite number > 0, got {value}")]
    BadSize { what: &'static str, value: f64 },
    /// One point, vertex or triangle of a shape was rejected; `index` is its place in its list.
    #[error("{what} {index}: {source}")]
    InShape { what: &'static str, index: usize, source: Box<VadopError> },
    /// A convex hull was given fewer than four points.
    #[error("a convex hull needs at least 4 points that are not all in one plane, got {0} points")]
    HullTooFewPoints(usize),
    /// The points of a convex hull all lie in one plane (or on one line): the hull has no volume.
    #[error("the convex hull's points all lie in one plane or on one line (thickness {thickness:.1e} of its size); give at least 4 points that span a volume")]
    FlatHull { thickness: f64 },
    /// The convex hull of valid points could not be built.
    #[error("the convex hull of the {points} points could not be computed; check for near-duplicate or near-coplanar points")]
    HullFailed { points: usize },
    /// A triangle mesh without triangles or without vertices.
    #[error("a triangle mesh needs at least one triangle, got {vertices} vertices and {triangles} triangles")]
    EmptyMesh { vertices: usize, triangles: usize },
    /// A mesh triangle referred to a vertex that does not exist.
    #[error("mesh triangle {triangle} has vertex indices {indices:?}, but the mesh has {vertices} vertices: indices must be below that")]
    BadTriangleIndex { triangle: usize, indices: [u32; 3], vertices: usize },
    /// A mesh triangle had (nearly) zero area.
    #[error("mesh triangle {triangle} with vertex indices {indices:?} has zero area (a repeated vertex or three vertices on one line); remove it")]
    DegenerateTriangle { triangle: usize, indices: [u32; 3] },
    /// A half-space was given a zero normal.
    #[error("a half-space needs a non-zero outward normal, got {0:?}")]
    ZeroNormal([f64; 3]),
    /// A contact search between shapes could not finish: it never silently drops a contact, so
    /// it reports this instead. No contact starts before `time`.
    #[error("the contact search of two shapes stopped at time {time:e} after {iterations} steps: {reason}")]
    ContactSearchStalled { time: f64, iterations: u32, reason: &'static str },
    /// An I/O failure while reading or writing a file.
    #[error("{path}: {message}")]
    Io { path: String, message: String },
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, VadopError>;

/// The end of a [`VadopError::StaleHandle`] message: who holds the slot now, if anyone.
fn now_in_slot(current: &Option<BodyHandle>) -> String {
    match current {
        Some(current) => format!("; its slot now holds body {current}"),
        None => String::new(),
    }
}

/// Largest magnitude of a coordinate, velocity component, radius or mass (and inverse of the
/// smallest mass): products of four such values stay far from overflow, so no contact is lost
/// to an infinite square.
pub const MAX_MAGNITUDE: f64 = 1e50;

/// Smallest radius or box side: with lengths in [1e-50, 1e50], and the narrow phase scaling
/// lengths and speeds by exact powers of two, no square under- or overflows.
pub const MIN_LENGTH: f64 = 1e-50;

/// Checks that a positive length lies in [[`MIN_LENGTH`], [`MAX_MAGNITUDE`]].
pub(crate) fn check_length(what: &'static str, value: f64) -> Result<()> {
    if value < MIN_LENGTH {
        return Err(VadopError::TooSmall { what, value });
    }
    check_magnitude(what, value)
}

/// Checks that every component of `v` is finite and at most [`MAX_MAGNITUDE`] in magnitude.
pub(crate) fn check_vector(what: &'static str, v: glam::DVec3) -> Result<()> {
    if !v.is_finite() {
        return Err(VadopError::NotFinite { what, value: format!("{v:?}") });
    }
    check_magnitude(what, v.abs().max_element())
}

/// Checks that a finite value is at most [`MAX_MAGNITUDE`] in magnitude.
pub(crate) fn check_magnitude(what: &'static str, value: f64) -> Result<()> {
    if value.abs() > MAX_MAGNITUDE {
        return Err(VadopError::OutOfRange { what, value });
    }
    Ok(())
}

/// An entry of a scene's body lists: its list and its index there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SceneEntry {
    Sphere(usize),
    Body(usize),
    StaticBody(usize),
}

impl std::fmt::Display for SceneEntry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneEntry::Sphere(i) => write!(f, "sphere {i}"),
            SceneEntry::Body(i) => write!(f, "body {i}"),
            SceneEntry::StaticBody(i) => write!(f, "static body {i}"),
        }
    }
}
