//! The crowd of mixed shapes: spheres, cuboids, capsules, cylinders, cones and a convex rock,
//! spinning, over an optional floor mesh. It owns the crowd's shapes and spins; placement is
//! shared with the other generators.

use super::file::{NamedShape, Scene, SceneBody, StaticBody};
use super::paper::up_to;
use super::placement::{ball_volume, check_crowd, check_rate, random_rotation, Crowd};
use super::FRAMES_PER_SECOND;
use crate::bodies::Sphere;
use crate::error::Result;
use crate::shape::Shape;
use crate::walls::BoxBounds;
use glam::{DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Largest spin of a [`ShapesScene`] made by [`ShapesScene::new`], in radians per frame: a body
/// one diameter across then moves its surface by up to a quarter of a diameter per frame.
pub const DEFAULT_MAX_SPIN: f64 = 0.5;

/// Radius of the ball every body of a [`ShapesScene`] lies within, about its shape's origin: half
/// the diameter that is the length unit of speeds.
pub(super) const CROWD_RADIUS: f64 = 0.5;

/// How far below the crowd a [`ShapesScene`]'s box reaches when it has a floor, in diameters: the
/// floor's bumps lie between a half and a quarter diameter below the crowd.
pub(super) const FLOOR_DEPTH: f64 = 1.0;

/// The points of a [`ShapesScene`]'s rock: an irregular convex hull within 0.45 of its origin.
pub(super) const ROCK: [[f64; 3]; 7] = [
    [0.45, 0.0, 0.0],
    [-0.3, 0.3, 0.1],
    [-0.2, -0.35, 0.15],
    [0.05, 0.1, -0.42],
    [0.1, -0.05, 0.4],
    [0.2, 0.3, 0.2],
    [-0.25, 0.0, -0.3],
];

/// A crowd of mixed shapes: spheres, cuboids, capsules, cylinders, cones and rocks (convex
/// hulls), each kind equally likely, each within half a diameter of its position (the diameter
/// is the length unit of speeds), at random orientations, placed as the paper's spheres are, with
/// speeds uniform in `[0, max_speed]` diameters per frame and spins uniform in `[0, max_spin]`
/// radians per frame (at [`FRAMES_PER_SECOND`]), in random directions; masses are volumes (unit
/// density). With `floor`, the box reaches one diameter lower and a static bumpy triangle mesh
/// lies under the crowd, a quarter to a half diameter below it.
///
/// The spheres are the scene's `spheres`; the other shapes are its `bodies`, named `cuboid`,
/// `capsule`, `cylinder`, `cone` and `rock` in its `shapes` (and the floor `floor`).
///
/// ```
/// use vadop::scene::ShapesScene;
/// use vadop::WorldConfig;
/// let scene = ShapesScene { floor: true, ..ShapesScene::new(200, 0.05, 1.0) }.build()?;
/// assert_eq!(scene.spheres.len() + scene.bodies.len(), 200);
/// assert_eq!(scene.static_bodies[0].shape, "floor");
/// // In simulate mode, the default, the world refuses overlapping bodies at the first step.
/// let mut world = scene.world(WorldConfig::default())?;
/// world.step(1.0 / 30.0)?;
/// # Ok::<(), vadop::VadopError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShapesScene {
    /// Number of moving bodies.
    pub bodies: usize,
    /// Fraction of the crowd's cube the bodies fill (their own volume), in (0, 0.6]. Their
    /// bounding balls take nearly three times more room, so beyond about 0.2 they do not fit
    /// apart.
    pub packing_fraction: f64,
    /// Speeds are uniform in [0, this] diameters per frame, each body's own diameter (its
    /// bounding sphere's), so that no body covers more of its own size per frame than this.
    pub max_speed: f64,
    /// Spins are uniform in [0, this] radians per frame.
    pub max_spin: f64,
    /// A static triangle-mesh floor under the crowd.
    pub floor: bool,
    /// Seed of the generator.
    pub seed: u64,
}

impl ShapesScene {
    /// Spins up to [`DEFAULT_MAX_SPIN`], no floor, seed 1.
    pub fn new(bodies: usize, packing_fraction: f64, max_speed: f64) -> ShapesScene {
        ShapesScene { bodies, packing_fraction, max_speed, max_spin: DEFAULT_MAX_SPIN, floor: false, seed: 1 }
    }

    /// Generates the scene.
    pub fn build(&self) -> Result<Scene> {
        check_crowd(self.bodies, self.packing_fraction, ["body", "bodies"])?;
        check_rate("max speed", self.max_speed)?;
        check_rate("max spin", self.max_spin)?;
        let mut shapes: Vec<NamedShape> =
            crowd_shapes().into_iter().map(|(name, shape)| NamedShape::new(name, shape)).collect();
        // Kind 0 is the sphere, kind k > 0 the shape shapes[k - 1]: its volume and its diameter,
        // its bounding sphere's, the unit of its speed (the summary's and the docs' too).
        let (volumes, diameters): (Vec<f64>, Vec<f64>) =
            std::iter::once(Ok((ball_volume(CROWD_RADIUS), 2.0 * CROWD_RADIUS)))
                .chain(shapes.iter().map(|s| {
                    let geometry = s.shape.geometry()?;
                    Ok((geometry.volume(), 2.0 * geometry.bounding_radius().unwrap_or(CROWD_RADIUS)))
                }))
                .collect::<Result<Vec<_>>>()?
                .into_iter()
                .unzip();
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let kinds: Vec<usize> = (0..self.bodies).map(|_| rng.random_range(0..volumes.len())).collect();
        let volume: f64 = kinds.iter().map(|&kind| volumes[kind]).sum();
        let side = (volume / self.packing_fraction).cbrt();
        let crowd = Crowd { count: self.bodies, packing_fraction: self.packing_fraction, side, radius: CROWD_RADIUS };
        // A sphere's orientation and spin are drawn too, and left unused: every body draws the same
        // numbers, so a body's motion does not depend on the kinds drawn before it.
        let placed = crowd.place(&mut rng, "bodies", |rng, k, position| {
            let orientation = random_rotation(rng);
            let velocity = up_to(rng, self.max_speed) * diameters[kinds[k]] * FRAMES_PER_SECOND;
            let angular_velocity = up_to(rng, self.max_spin) * FRAMES_PER_SECOND;
            (kinds[k], position, orientation, velocity, angular_velocity)
        })?;
        let mut scene = Scene::new(BoxBounds::cube(side)?, Vec::new());
        for (kind, position, orientation, velocity, angular_velocity) in placed {
            let mass = volumes[kind];
            match kind {
                0 => scene.spheres.push(Sphere { position, velocity, radius: CROWD_RADIUS, mass }),
                _ => scene.bodies.push(SceneBody {
                    shape: shapes[kind - 1].name.clone(),
                    position,
                    orientation,
                    velocity,
                    angular_velocity,
                    mass,
                }),
            }
        }
        if self.floor {
            scene.bounds = BoxBounds::new(DVec3::new(0.0, -FLOOR_DEPTH, 0.0), DVec3::splat(side))?;
            shapes.push(NamedShape::new("floor", floor_mesh(side, &mut rng)));
            scene.static_bodies.push(StaticBody {
                shape: "floor".to_string(),
                position: DVec3::new(0.0, -0.5 * FLOOR_DEPTH, 0.0),
                orientation: DQuat::IDENTITY,
            });
        }
        scene.shapes = shapes;
        Ok(scene)
    }
}

/// The moving shapes of a [`ShapesScene`] besides its spheres, by name, each within
/// [`CROWD_RADIUS`] of its origin.
pub(super) fn crowd_shapes() -> [(&'static str, Shape); 5] {
    [
        ("cuboid", Shape::Cuboid { half_extents: DVec3::new(0.35, 0.25, 0.2) }),
        ("capsule", Shape::Capsule { half_height: 0.25, radius: 0.2 }),
        ("cylinder", Shape::Cylinder { half_height: 0.3, radius: 0.3 }),
        ("cone", Shape::Cone { half_height: 0.3, radius: 0.35 }),
        ("rock", Shape::ConvexHull { points: ROCK.map(DVec3::from_array).to_vec() }),
    ]
}

/// A bumpy square of triangles over `[0, side]` in x and z, up to a quarter diameter high: about
/// one cell per diameter, at most 64 per side.
pub(super) fn floor_mesh(side: f64, rng: &mut ChaCha8Rng) -> Shape {
    let cells = (side.ceil() as u32).clamp(1, 64);
    let row = cells + 1;
    let vertices = (0..row * row)
        .map(|v| {
            let (i, k) = (v / row, v % row);
            let bump = 0.25 * FLOOR_DEPTH * rng.random_range(0.0..1.0);
            DVec3::new(side * i as f64 / cells as f64, bump, side * k as f64 / cells as f64)
        })
        .collect();
    let triangles = (0..cells * cells)
        .flat_map(|c| {
            let v = (c / cells) * row + c % cells;
            [[v, v + 1, v + row], [v + 1, v + row + 1, v + row]]
        })
        .collect();
    Shape::TriMesh { vertices, triangles }
}
