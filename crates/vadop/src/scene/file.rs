//! The scene file: reading it strictly (an unknown key is refused with its line and column),
//! writing it, and resolving its named shapes into a world's (see the format in the module doc
//! of [`crate::scene`]). It owns the file's types and their validation; it never generates
//! bodies.

use super::SceneEntry;
use crate::bodies::Sphere;
use crate::error::{Result, VadopError};
use crate::handle::BodyHandle;
use crate::shape::Shape;
use crate::walls::BoxBounds;
use crate::world::{Body, BodyShape, ShapeId, World, WorldConfig};
use glam::{DQuat, DVec3};
use std::collections::BTreeMap;

/// A box and the bodies in it: spheres, and bodies of the shapes it names (see the
/// [module documentation](crate::scene) for the file format).
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
#[serde(deny_unknown_fields)]
pub struct Scene {
    #[serde(deserialize_with = "StrictBounds::deserialize")]
    pub bounds: BoxBounds,
    /// Moving spheres.
    #[serde(default, deserialize_with = "strict_spheres")]
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

/// A scene file's box, read as [`BoxBounds`] is but refusing unknown keys: a misspelt key would
/// otherwise be ignored without a word.
#[derive(serde::Deserialize)]
#[serde(remote = "BoxBounds", deny_unknown_fields)]
pub(super) struct StrictBounds {
    pub(super) min: DVec3,
    pub(super) max: DVec3,
    #[serde(default)]
    pub(super) periodic: [bool; 3],
}

/// A scene file's sphere entry, read as [`Sphere`] is but refusing unknown keys.
#[derive(serde::Deserialize)]
#[serde(remote = "Sphere", deny_unknown_fields)]
pub(super) struct StrictSphere {
    pub(super) position: DVec3,
    pub(super) velocity: DVec3,
    pub(super) radius: f64,
    pub(super) mass: f64,
}

pub(super) fn strict_spheres<'de, D: serde::Deserializer<'de>>(
    entries: D,
) -> std::result::Result<Vec<Sphere>, D::Error> {
    #[derive(serde::Deserialize)]
    struct Entry(#[serde(with = "StrictSphere")] Sphere);
    let entries: Vec<Entry> = serde::Deserialize::deserialize(entries)?;
    Ok(entries.into_iter().map(|Entry(sphere)| sphere).collect())
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
    pub(super) fn add_shapes(&self, world: &mut World) -> Result<ShapeTable<'_>> {
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
    /// validates the rest. A file too large for the memory left is refused before it is read,
    /// and a stream (a FIFO, a device) once it has delivered too much ([`crate::memory::read_json`]).
    pub fn load(path: &std::path::Path) -> Result<Scene> {
        let scene: Scene = crate::memory::read_json(path)
            .map_err(|message| VadopError::Io { path: path.display().to_string(), message })?;
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
pub(super) struct ShapeTable<'a> {
    pub(super) by_name: BTreeMap<&'a str, TableEntry>,
}

/// A shape of a scene's table in its world.
#[derive(Clone, Copy)]
pub(super) struct TableEntry {
    /// Its place in the table.
    pub(super) index: usize,
    pub(super) id: ShapeId,
    /// Level geometry, which only static bodies take.
    pub(super) static_only: bool,
}

impl ShapeTable<'_> {
    pub(super) fn find(&self, name: &str) -> Result<TableEntry> {
        self.by_name.get(name).copied().ok_or_else(|| VadopError::UnknownShapeName(name.to_string()))
    }
}
