//! Scenes: the paper's test scene (spheres in a cube at a given packing fraction, random
//! directions, speeds up to a maximum in diameters per frame, 30 frames per second), the same
//! placement with other velocities (an equilibrium gas, a stream, heavy-tailed speeds), and the
//! scene file format.
//!
//! It owns scene generation, which is seeded and deterministic, and reading, writing and
//! resolving scene files: a scene names its shapes, and [`Scene::world`] turns the names into the
//! world's shapes. It never steps anything. Generated spheres never overlap: centres sit on a
//! jittered face-centred cubic grid spread over the whole box, so the same scene serves simulate
//! mode.
//!
//! # File format
//!
//! JSON; units are free (the generated scenes use diameters and seconds). A sphere-only file, the
//! original format, holds a box and spheres:
//!
//! ```json
//! {"bounds": {"min": [0, 0, 0], "max": [10, 10, 10]},
//!  "spheres": [{"position": [2, 5, 5], "velocity": [1, 0, 0], "radius": 0.5, "mass": 1}]}
//! ```
//!
//! Bodies of other shapes take three more lists, each optional (`spheres` too):
//!
//! - `shapes`, the table of named shapes: `{"name": "brick", "shape": {"Cuboid": {"half_extents":
//!   [0.5, 0.25, 0.25]}}}`. A shape is written as [`Shape`] serialises: `{"Sphere": {"radius":
//!   r}}`, `{"Cuboid": {"half_extents": [x, y, z]}}`, `{"Capsule": {"half_height": h, "radius":
//!   r}}`, `Cylinder` and `Cone` alike, `{"ConvexHull": {"points": [[x, y, z], ...]}}`,
//!   `{"TriMesh": {"vertices": [[x, y, z], ...], "triangles": [[i, j, k], ...]}}` and
//!   `{"HalfSpace": {"normal": [x, y, z]}}`, sizes in the shape's own frame (see
//!   [`crate::shape`]). Names are unique and case-sensitive.
//! - `bodies`, the moving bodies: `{"shape": "brick", "position": [x, y, z], "orientation": [x, y,
//!   z, w], "velocity": [x, y, z], "angular_velocity": [x, y, z], "mass": m}`. `position` places
//!   the shape's origin; `orientation` is a quaternion in the order **[x, y, z, w]**, the vector
//!   part first and the scalar last (`[0, 0, 0, 1]` is no rotation; any non-zero length, it is
//!   normalised); `angular_velocity` is in world axes, radians per unit of time. `orientation`
//!   and `angular_velocity` may be left out: no rotation, no spin. A triangle mesh or a half-space
//!   cannot move.
//! - `static_bodies`, level geometry or any shape fixed in place: `{"shape": "floor", "position":
//!   [x, y, z], "orientation": [x, y, z, w]}` (`orientation` optional). A static body never moves,
//!   has infinite mass and may reach beyond the box.
//!
//! A misspelt field of a shape, body or static body entry is refused rather than left at its
//! default. [`Scene::world`] validates everything else and names the offending entry: `shape 2
//! ("floor")`, `sphere 7`, `body 3`, `static body 0`. A world built from a scene holds its spheres,
//! then its bodies, then its static bodies, in file order, in slots 0, 1, 2, ...: [`SceneLayout`]
//! names the entry behind a handle, so that the overlap a simulate-mode world finds at its first
//! step is reported as between entries too.

use crate::bodies::Sphere;
use crate::error::{Result, VadopError};
use crate::handle::BodyHandle;
use crate::shape::Shape;
use crate::world::{Body, BodyShape, BoxBounds, ShapeId, World, WorldConfig};
use glam::{DQuat, DVec3};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use std::fmt;

/// Most spheres a generated scene holds: more would not fit in memory, and generating them would
/// run for hours before failing.
pub const MAX_SCENE_BODIES: usize = 100_000_000;

/// Frame rate of the paper's scene.
pub const FRAMES_PER_SECOND: f64 = 30.0;

/// How a generated scene's velocities are drawn. Speeds are in diameters per frame at
/// [`FRAMES_PER_SECOND`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Velocities {
    /// The paper's: random directions, speeds uniform in `[0, max_speed]`.
    Uniform { max_speed: f64 },
    /// An equilibrium gas: Maxwell–Boltzmann velocities (each component normal) with this
    /// root-mean-square speed, total momentum zero.
    Maxwell { rms_speed: f64 },
    /// A stream, as bullets, rain or a particle beam: every body at `speed`, its direction within
    /// `spread` radians of +x.
    Stream { speed: f64, spread: f64 },
    /// Heavy-tailed: random directions, Pareto speeds with this median and tail index (smaller
    /// is heavier: at 1.5 one body in a hundred is 20 times faster than the median).
    HeavyTail { median_speed: f64, tail_index: f64 },
}

impl Velocities {
    /// Checks the parameters.
    fn check(&self) -> Result<()> {
        let bad =
            |what: &str, value: f64| Err(VadopError::Scene(format!("{what} must be finite and >= 0, got {value}")));
        match *self {
            Velocities::Uniform { max_speed } if !(max_speed.is_finite() && max_speed >= 0.0) => bad("max speed", max_speed),
            Velocities::Maxwell { rms_speed } if !(rms_speed.is_finite() && rms_speed >= 0.0) => bad("rms speed", rms_speed),
            Velocities::Stream { speed, spread } if !(speed.is_finite() && speed >= 0.0 && (0.0..=std::f64::consts::PI).contains(&spread)) => {
                Err(VadopError::Scene(format!("a stream needs a finite speed >= 0 and a spread in [0, pi], got {speed} and {spread}")))
            }
            Velocities::HeavyTail { median_speed, tail_index }
                if !(median_speed.is_finite() && median_speed >= 0.0 && tail_index.is_finite() && tail_index >= 1.0) =>
            {
                Err(VadopError::Scene(format!("heavy-tailed speeds need a finite median >= 0 and a tail index >= 1, got {median_speed} and {tail_index}")))
            }
            _ => Ok(()),
        }
    }

    /// One velocity, in diameters per frame.
    fn draw(&self, rng: &mut ChaCha8Rng) -> DVec3 {
        match *self {
            Velocities::Uniform { max_speed } => random_direction(rng) * rng.random_range(0.0..=1.0) * max_speed,
            Velocities::Maxwell { rms_speed } => {
                let sigma = rms_speed / 3f64.sqrt();
                DVec3::new(normal(rng), normal(rng), normal(rng)) * sigma
            }
            Velocities::Stream { speed, spread } => {
                // Uniform over the cap of half-angle `spread` around +x.
                let cos = 1.0 - rng.random_range(0.0..=1.0) * (1.0 - spread.cos());
                let sin = (1.0 - cos * cos).max(0.0).sqrt();
                let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                DVec3::new(cos, sin * angle.cos(), sin * angle.sin()) * speed
            }
            Velocities::HeavyTail { median_speed, tail_index } => {
                // Pareto with P(s > x) = (m / x)^a for x >= m, m set so the median is `median_speed`.
                let scale = median_speed / 2f64.powf(1.0 / tail_index);
                let u: f64 = rng.random_range(f64::EPSILON..=1.0);
                random_direction(rng) * scale / u.powf(1.0 / tail_index)
            }
        }
    }
}

/// A standard normal number (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..=1.0);
    let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    (-2.0 * u.ln()).sqrt() * angle.cos()
}

/// The paper's placement with any velocities: `bodies` spheres of `radius` at `packing_fraction`
/// in a cube, velocities drawn from `velocities`, generated from `seed`.
///
/// ```
/// use vadop::scene::{GeneratedScene, Velocities};
/// // An equilibrium gas: rms travel of 0.2 diameters a frame, no net momentum.
/// let gas = GeneratedScene { bodies: 1000, packing_fraction: 0.3, velocities: Velocities::Maxwell { rms_speed: 0.2 }, radius: 0.5, seed: 1 };
/// let scene = gas.build().unwrap();
/// let momentum: glam::DVec3 = scene.spheres.iter().map(|s| s.velocity * s.mass).sum();
/// assert!(momentum.length() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GeneratedScene {
    pub bodies: usize,
    pub packing_fraction: f64,
    pub velocities: Velocities,
    pub radius: f64,
    pub seed: u64,
}

impl GeneratedScene {
    /// Generates the scene.
    pub fn build(&self) -> Result<Scene> {
        self.velocities.check()?;
        let paper = PaperScene {
            bodies: self.bodies,
            packing_fraction: self.packing_fraction,
            max_speed: 0.0,
            radius: self.radius,
            seed: self.seed,
        };
        let mut scene = paper.place(|rng| self.velocities.draw(rng))?;
        if let Velocities::Maxwell { .. } = self.velocities {
            // An equilibrium gas at rest as a whole.
            let mass: f64 = scene.spheres.iter().map(|s| s.mass).sum();
            let drift = scene.spheres.iter().map(|s| s.mass * s.velocity).sum::<DVec3>() / mass;
            for s in &mut scene.spheres {
                s.velocity -= drift;
            }
        }
        Ok(scene)
    }
}

/// Parameters of the paper's scene.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PaperScene {
    /// Number of spheres.
    pub bodies: usize,
    /// Fraction of the box volume the spheres fill, in (0, 0.6].
    pub packing_fraction: f64,
    /// Speeds are uniform in [0, this] diameters per frame.
    pub max_speed: f64,
    /// Sphere radius (all equal; the diameter is the length unit of speeds).
    pub radius: f64,
    /// Seed of the generator.
    pub seed: u64,
}

impl PaperScene {
    /// The paper's defaults: radius 0.5 (diameter 1), seed 1.
    pub fn new(bodies: usize, packing_fraction: f64, max_speed: f64) -> PaperScene {
        PaperScene { bodies, packing_fraction, max_speed, radius: 0.5, seed: 1 }
    }

    /// Side of the cube that holds the spheres at the packing fraction.
    pub fn box_side(&self) -> f64 {
        let volume = self.bodies as f64 * 4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3);
        (volume / self.packing_fraction).cbrt()
    }

    /// Generates the scene.
    ///
    /// ```
    /// use vadop::scene::PaperScene;
    /// let scene = PaperScene::new(1000, 0.05, 0.5).build().unwrap();
    /// assert_eq!(scene.spheres.len(), 1000);
    /// // Speeds are in diameters per frame at 30 frames per second.
    /// let fastest = scene.spheres.iter().map(|s| s.velocity.length()).fold(0.0, f64::max);
    /// assert!(fastest <= 0.5 * 1.0 * 30.0);
    /// ```
    pub fn build(&self) -> Result<Scene> {
        if !(self.max_speed.is_finite() && self.max_speed >= 0.0) {
            return Err(VadopError::Scene(format!("max speed must be finite and >= 0, got {}", self.max_speed)));
        }
        let velocities = Velocities::Uniform { max_speed: self.max_speed };
        self.place(|rng| velocities.draw(rng))
    }

    /// The placement of this scene's spheres, with velocities in diameters per frame from
    /// `velocity`.
    fn place(&self, mut velocity: impl FnMut(&mut ChaCha8Rng) -> DVec3) -> Result<Scene> {
        if self.bodies == 0 {
            return Err(VadopError::Scene("a scene needs at least one sphere".into()));
        }
        if self.bodies > MAX_SCENE_BODIES {
            return Err(VadopError::Scene(format!(
                "a scene holds at most {MAX_SCENE_BODIES} spheres, got {}",
                self.bodies
            )));
        }
        if !(self.packing_fraction > 0.0 && self.packing_fraction <= 0.6) {
            return Err(VadopError::Scene(format!(
                "packing fraction must be in (0, 0.6], got {}",
                self.packing_fraction
            )));
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(VadopError::BadRadius(self.radius));
        }
        let diameter = 2.0 * self.radius;
        let side = self.box_side();
        let usable = side - diameter;
        // Face-centred cubic grid: integer triples with an even sum, spacing h, neighbours h*sqrt(2)
        // apart. The smallest grid with room for every sphere, stretched over the whole box.
        let mut per_axis = 2usize;
        while per_axis.pow(3).div_ceil(2) < self.bodies {
            per_axis += 1;
        }
        let spacing = usable / (per_axis - 1) as f64;
        let neighbour_distance = spacing * std::f64::consts::SQRT_2;
        if neighbour_distance < diameter {
            return Err(VadopError::Scene(format!(
                "packing fraction {} is too dense to place {} separate spheres",
                self.packing_fraction, self.bodies
            )));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut sites: Vec<[usize; 3]> = (0..per_axis.pow(3))
            .map(|k| [k % per_axis, (k / per_axis) % per_axis, k / (per_axis * per_axis)])
            .filter(|c| (c[0] + c[1] + c[2]) % 2 == 0)
            .collect();
        sites.shuffle(&mut rng);
        sites.truncate(self.bodies);
        sites.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
        // Each centre may move up to half the free gap between neighbours: they never overlap.
        let jitter = 0.5 * (neighbour_distance - diameter) * (1.0 - 1e-9) / 3f64.sqrt();
        let (low, high) = (self.radius, side - self.radius);
        let speed_unit = diameter * FRAMES_PER_SECOND;
        let mass = 4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3);
        let spheres = sites
            .iter()
            .map(|c| {
                let lattice = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * spacing + low;
                let offset = DVec3::new(
                    rng.random_range(-1.0..=1.0),
                    rng.random_range(-1.0..=1.0),
                    rng.random_range(-1.0..=1.0),
                ) * jitter;
                let position = (lattice + offset).clamp(DVec3::splat(low), DVec3::splat(high));
                let velocity = velocity(&mut rng) * speed_unit;
                Sphere { position, velocity, radius: self.radius, mass }
            })
            .collect();
        Ok(Scene::new(BoxBounds::cube(side)?, spheres))
    }
}

fn random_direction(rng: &mut ChaCha8Rng) -> DVec3 {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * angle.cos(), r * angle.sin(), z)
}

/// A box and the bodies in it: spheres, and bodies of the shapes it names (see the
/// [module documentation](self) for the file format).
///
/// ```
/// use vadop::scene::{Scene, SceneEntry};
/// use vadop::{Touched, WorldConfig};
/// let text = r#"{
///   "bounds": {"min": [0, 0, 0], "max": [10, 10, 10]},
///   "spheres": [{"position": [2, 5, 5], "velocity": [3, 0, 0], "radius": 0.5, "mass": 1}],
///   "shapes": [
///     {"name": "brick", "shape": {"Cuboid": {"half_extents": [0.5, 0.25, 0.25]}}},
///     {"name": "ground", "shape": {"HalfSpace": {"normal": [0, 1, 0]}}}
///   ],
///   "bodies": [{"shape": "brick", "position": [8, 5, 5], "orientation": [0, 0, 0.6, 0.8],
///               "velocity": [-3, 0, 0], "angular_velocity": [0, 0, 2], "mass": 2}],
///   "static_bodies": [{"shape": "ground", "position": [0, 1, 0]}]
/// }"#;
/// let scene: Scene = serde_json::from_str(text)?;
/// let mut world = scene.world(WorldConfig::default())?;
/// // The sphere and the brick meet within the second.
/// let contacts = world.step(1.0)?.to_vec();
/// let (sphere, brick) = (contacts[0].body, contacts[0].touched);
/// let layout = scene.layout();
/// assert_eq!(layout.entry(sphere), Some(SceneEntry::Sphere(0)));
/// assert!(matches!(brick, Touched::Body(b) if layout.entry(b) == Some(SceneEntry::Body(0))));
/// // A scene of the world as it is now, and back: files round-trip.
/// let now = Scene::from_world(&world);
/// assert_eq!(serde_json::from_str::<Scene>(&serde_json::to_string(&now)?)?, now);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scene {
    pub bounds: BoxBounds,
    /// Moving spheres.
    #[serde(default)]
    pub spheres: Vec<Sphere>,
    /// The shapes that bodies and static bodies take, by name. Written only when not empty, so a
    /// sphere-only scene is written as it always was.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub shapes: Vec<NamedShape>,
    /// Moving bodies of the named shapes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bodies: Vec<SceneBody>,
    /// Static bodies of the named shapes.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub static_bodies: Vec<StaticBody>,
}

/// A shape of a scene's table, with the name bodies give it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NamedShape {
    pub name: String,
    pub shape: Shape,
}

impl NamedShape {
    /// The shape `shape` named `name`.
    pub fn new(name: impl Into<String>, shape: Shape) -> NamedShape {
        NamedShape { name: name.into(), shape }
    }
}

/// A moving body of a scene: a [`Body`] whose shape is named.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneBody {
    /// The name of its shape in the scene's table.
    pub shape: String,
    /// Where the shape's origin is.
    pub position: DVec3,
    /// Rotates the shape's frame to the world's; `[x, y, z, w]` in a file, no rotation when left
    /// out.
    #[serde(default)]
    pub orientation: DQuat,
    /// Velocity of the centre of mass.
    pub velocity: DVec3,
    /// Angular velocity in world axes, radians per unit of time; none when left out.
    #[serde(default)]
    pub angular_velocity: DVec3,
    /// Mass, > 0.
    pub mass: f64,
}

/// A static body of a scene: level geometry, or any shape fixed in place.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticBody {
    /// The name of its shape in the scene's table.
    pub shape: String,
    /// Where the shape's origin is.
    pub position: DVec3,
    /// Rotates the shape's frame to the world's; `[x, y, z, w]` in a file, no rotation when left
    /// out.
    #[serde(default)]
    pub orientation: DQuat,
}

/// An entry of a scene's body lists: its list and its index there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SceneEntry {
    Sphere(usize),
    Body(usize),
    StaticBody(usize),
}

impl fmt::Display for SceneEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneEntry::Sphere(i) => write!(f, "sphere {i}"),
            SceneEntry::Body(i) => write!(f, "body {i}"),
            SceneEntry::StaticBody(i) => write!(f, "static body {i}"),
        }
    }
}

/// The lengths of a scene's body lists: all it takes to name the entry behind a handle of the
/// scene's world, long after the scene itself is gone. [`Scene::world`] puts the spheres, then
/// the bodies, then the static bodies into slots 0, 1, 2, ...
///
/// ```
/// use glam::DVec3;
/// use vadop::scene::{Scene, SceneEntry};
/// use vadop::{BoxBounds, Sphere, VadopError, WorldConfig};
/// let ball = |x: f64| Sphere { position: DVec3::new(x, 5.0, 5.0), velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 };
/// let scene = Scene::new(BoxBounds::cube(10.0)?, vec![ball(2.0), ball(5.0), ball(5.5)]);
/// let layout = scene.layout();
/// // Simulate mode: the world refuses the overlapping spheres at its first step...
/// let error = scene.world(WorldConfig::default())?.step(0.1).unwrap_err();
/// assert!(matches!(error, VadopError::Overlap { .. }));
/// // ...and the layout names them as the scene does.
/// let named = layout.name_entries(error);
/// assert!(matches!(named, VadopError::SceneOverlap { a: SceneEntry::Sphere(1), b: SceneEntry::Sphere(2), .. }));
/// assert!(named.to_string().starts_with("sphere 1 and sphere 2 overlap"), "{named}");
/// # Ok::<(), VadopError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SceneLayout {
    pub spheres: usize,
    pub bodies: usize,
    pub static_bodies: usize,
}

impl SceneLayout {
    /// Every body of the scene, static ones included.
    pub fn count(&self) -> usize {
        self.spheres + self.bodies + self.static_bodies
    }

    /// The entry behind `handle` in a world the scene built, before any body was removed; `None`
    /// for a handle no entry has.
    pub fn entry(&self, handle: BodyHandle) -> Option<SceneEntry> {
        let slot = handle.index() as usize;
        if handle.generation() != 0 {
            return None;
        }
        let bodies_start = self.spheres;
        let statics_start = bodies_start + self.bodies;
        if slot < bodies_start {
            Some(SceneEntry::Sphere(slot))
        } else if slot < statics_start {
            Some(SceneEntry::Body(slot - bodies_start))
        } else if slot < statics_start + self.static_bodies {
            Some(SceneEntry::StaticBody(slot - statics_start))
        } else {
            None
        }
    }

    /// `error` with the bodies it names by handle named as the scene's entries: an
    /// [`VadopError::Overlap`] of two entries becomes a [`VadopError::SceneOverlap`]; any other
    /// error is returned as it is.
    pub fn name_entries(&self, error: VadopError) -> VadopError {
        match error {
            VadopError::Overlap { a, b, depth } => match (self.entry(a), self.entry(b)) {
                (Some(a), Some(b)) => VadopError::SceneOverlap { a, b, depth },
                _ => error,
            },
            other => other,
        }
    }
}

impl Scene {
    /// A scene of spheres alone.
    pub fn new(bounds: BoxBounds, spheres: Vec<Sphere>) -> Scene {
        Scene { bounds, spheres, shapes: Vec::new(), bodies: Vec::new(), static_bodies: Vec::new() }
    }

    /// The lengths of the body lists, which name the entry behind each handle of the scene's world.
    pub fn layout(&self) -> SceneLayout {
        SceneLayout { spheres: self.spheres.len(), bodies: self.bodies.len(), static_bodies: self.static_bodies.len() }
    }

    /// A world holding this scene's bodies, their handles in file order: the spheres, then the
    /// bodies, then the static bodies, in slots 0, 1, 2, ... (generation 0; see
    /// [`Scene::layout`]).
    ///
    /// Fails, naming the entry, on what the world refuses (a bad value, a body reaching out of the
    /// box, a shape that cannot be built) and on what only a scene can get wrong: two shapes of
    /// one name, a body naming no shape of the table, a moving body of level geometry. Overlapping
    /// bodies are refused by the world's first step in simulate mode, as [`VadopError::Overlap`]:
    /// [`SceneLayout::name_entries`] names them.
    pub fn world(&self, config: WorldConfig) -> Result<World> {
        let mut world = World::new(self.bounds, config)?;
        let shapes = self.add_shapes(&mut world)?;
        world.add_spheres(&self.spheres)?;
        let bodies = self
            .bodies
            .iter()
            .enumerate()
            .map(|(index, body)| {
                let in_body = |source| VadopError::InBody { index, source: Box::new(source) };
                let TableEntry { id, static_only, .. } = shapes.find(&body.shape).map_err(in_body)?;
                if static_only {
                    return Err(in_body(VadopError::MovingLevelGeometry(body.shape.clone())));
                }
                Ok(Body {
                    shape: BodyShape::Shape(id),
                    position: body.position,
                    orientation: body.orientation,
                    velocity: body.velocity,
                    angular_velocity: body.angular_velocity,
                    mass: body.mass,
                })
            })
            .collect::<Result<Vec<Body>>>()?;
        world.add_bodies(&bodies)?;
        for (index, body) in self.static_bodies.iter().enumerate() {
            shapes
                .find(&body.shape)
                .and_then(|entry| world.add_static(entry.id, body.position, body.orientation))
                .map_err(|source| VadopError::InStaticBody { index, source: Box::new(source) })?;
        }
        Ok(world)
    }

    /// Adds the table's shapes to `world`, refusing a name taken twice.
    fn add_shapes(&self, world: &mut World) -> Result<ShapeTable<'_>> {
        let mut table = ShapeTable::default();
        for (index, named) in self.shapes.iter().enumerate() {
            let in_shape =
                |source| VadopError::InSceneShape { index, name: named.name.clone(), source: Box::new(source) };
            if let Some(first) = table.by_name.get(named.name.as_str()) {
                return Err(in_shape(VadopError::DuplicateShapeName { first: first.index }));
            }
            let id = world.add_shape(named.shape.clone()).map_err(in_shape)?;
            table.by_name.insert(&named.name, TableEntry { index, id, static_only: named.shape.is_static_only() });
        }
        Ok(table)
    }

    /// The scene of `world` as it is now: its moving spheres, its other bodies, its static bodies,
    /// each list in the order of the handles, and the shapes they take, named `shape k` after
    /// their [`ShapeId`]. A sphere that spins (friction spins spheres) becomes a body of a sphere
    /// shape named `ball of radius r`, since a scene's spheres do not spin. Handles are not kept:
    /// a world built from the scene numbers its bodies by the scene's lists. [`World::save`] keeps
    /// the world exactly.
    pub fn from_world(world: &World) -> Scene {
        let mut scene = Scene::new(world.bounds(), Vec::new());
        // The shapes in the order of their ids, then the balls by radius (positive floats sort
        // as their bits do).
        let mut shapes = BTreeMap::new();
        for (_, body) in world.bodies() {
            let (key, name) = match body.shape {
                BodyShape::Sphere { radius } if body.angular_velocity == DVec3::ZERO => {
                    let Body { position, velocity, mass, .. } = body;
                    scene.spheres.push(Sphere { position, velocity, radius, mass });
                    continue;
                }
                BodyShape::Sphere { radius } => ((1, radius.to_bits()), format!("ball of radius {radius}")),
                BodyShape::Shape(id) => ((0, u64::from(id.index())), format!("shape {}", id.index())),
            };
            shapes.entry(key).or_insert_with(|| {
                let shape = match body.shape {
                    BodyShape::Sphere { radius } => Shape::Sphere { radius },
                    BodyShape::Shape(id) => world.shape(id).expect("a body's shape is its world's").shape().clone(),
                };
                NamedShape::new(name.clone(), shape)
            });
            let Body { position, orientation, velocity, angular_velocity, mass, .. } = body;
            if mass.is_finite() {
                scene.bodies.push(SceneBody { shape: name, position, orientation, velocity, angular_velocity, mass });
            } else {
                scene.static_bodies.push(StaticBody { shape: name, position, orientation });
            }
        }
        scene.shapes = shapes.into_values().collect();
        scene
    }

    /// Reads a scene file. Only its syntax and its box are checked here; [`Scene::world`]
    /// validates the rest.
    pub fn load(path: &std::path::Path) -> Result<Scene> {
        let io =
            |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
        let text = std::fs::read_to_string(path).map_err(|e| io(&e))?;
        let scene: Scene = serde_json::from_str(&text).map_err(|e| io(&e))?;
        BoxBounds::new(scene.bounds.min, scene.bounds.max)?;
        Ok(scene)
    }

    /// Writes a scene file atomically (a temporary file renamed into place). Numbers are written
    /// in the shortest form that reads back to the same bits, so [`Scene::load`] gives this scene
    /// back exactly.
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        let io =
            |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
        let text = serde_json::to_string(self).map_err(|e| io(&e))?;
        let temporary = path.with_extension("json.partial");
        std::fs::write(&temporary, text).map_err(|e| io(&e))?;
        std::fs::rename(&temporary, path).map_err(|e| io(&e))
    }
}

/// A scene's shapes in its world, by name.
#[derive(Default)]
struct ShapeTable<'a> {
    by_name: BTreeMap<&'a str, TableEntry>,
}

/// A shape of a scene's table in its world.
#[derive(Clone, Copy)]
struct TableEntry {
    /// Its place in the table.
    index: usize,
    id: ShapeId,
    /// Level geometry, which only static bodies take.
    static_only: bool,
}

impl ShapeTable<'_> {
    fn find(&self, name: &str) -> Result<TableEntry> {
        self.by_name.get(name).copied().ok_or_else(|| VadopError::UnknownShapeName(name.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_scenes_do_not_overlap_and_fit_the_box() {
        for (n, fraction) in [(1usize, 0.05), (7, 0.1), (1001, 0.4), (500, 0.6)] {
            let scene = PaperScene { bodies: n, packing_fraction: fraction, max_speed: 1.0, radius: 0.5, seed: 3 }
                .build()
                .unwrap();
            assert_eq!(scene.spheres.len(), n);
            let world = scene.world(WorldConfig::default()).unwrap();
            assert_eq!(world.len(), n);
            for (i, a) in scene.spheres.iter().enumerate() {
                for b in &scene.spheres[i + 1..] {
                    assert!(a.position.distance(b.position) >= 1.0 - 1e-9);
                }
            }
        }
    }

    #[test]
    fn same_seed_same_scene() {
        let a = PaperScene::new(200, 0.1, 2.0).build().unwrap();
        let b = PaperScene::new(200, 0.1, 2.0).build().unwrap();
        assert_eq!(a, b);
        let c = PaperScene { seed: 2, ..PaperScene::new(200, 0.1, 2.0) }.build().unwrap();
        assert_ne!(a, c);
    }

    #[test]
    fn bad_parameters_are_errors() {
        assert!(PaperScene::new(0, 0.1, 1.0).build().is_err());
        assert!(PaperScene::new(10, 0.0, 1.0).build().is_err());
        assert!(PaperScene::new(10, 0.7, 1.0).build().is_err());
        assert!(PaperScene::new(10, 0.1, f64::NAN).build().is_err());
    }

    #[test]
    fn files_round_trip() {
        let scene = PaperScene::new(20, 0.1, 1.0).build().unwrap();
        let path = std::env::temp_dir().join(format!("vadop-scene-{}.json", std::process::id()));
        scene.save(&path).unwrap();
        assert_eq!(Scene::load(&path).unwrap(), scene);
        std::fs::remove_file(&path).unwrap();
        assert!(matches!(Scene::load(&path), Err(VadopError::Io { .. })));
    }
}
