//! Scenes: the paper's test scene (spheres in a cube at a given packing fraction, random
//! directions, speeds up to a maximum in diameters per frame, 30 frames per second), the same
//! placement with other velocities (an equilibrium gas, a stream, heavy-tailed speeds), a crowd of
//! mixed shapes ([`ShapesScene`]), and the scene file format.
//!
//! It owns scene generation, which is seeded and deterministic, and reading, writing and
//! resolving scene files: a scene names its shapes, and [`Scene::world`] turns the names into the
//! world's shapes. It never steps anything. Generated bodies never overlap: each lies within a
//! ball one diameter across about a site of a jittered face-centred cubic grid spread over the
//! whole box, so the same scene serves simulate mode.
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
//! An unknown key, anywhere (a misspelt `static_body` at the top, a `radus` in a sphere entry, a
//! third corner in `bounds`), is refused with its name, line and column rather than ignored.
//! [`Scene::world`] validates everything else and names the offending entry: `shape 2
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

/// Most bodies a generated scene holds: more would not fit in memory, and generating them would
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
            Velocities::Uniform { max_speed } => up_to(rng, max_speed),
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

/// A vector in a random direction, its length uniform in `[0, max]`.
fn up_to(rng: &mut ChaCha8Rng, max: f64) -> DVec3 {
    random_direction(rng) * rng.random_range(0.0..=1.0) * max
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
        check_rate("max speed", self.max_speed)?;
        let velocities = Velocities::Uniform { max_speed: self.max_speed };
        self.place(|rng| velocities.draw(rng))
    }

    /// The placement of this scene's spheres, with velocities in diameters per frame from
    /// `velocity`.
    fn place(&self, mut velocity: impl FnMut(&mut ChaCha8Rng) -> DVec3) -> Result<Scene> {
        check_crowd(self.bodies, self.packing_fraction, ["sphere", "spheres"])?;
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(VadopError::BadRadius(self.radius));
        }
        let side = self.box_side();
        let speed_unit = 2.0 * self.radius * FRAMES_PER_SECOND;
        let mass = ball_volume(self.radius);
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let crowd = Crowd { count: self.bodies, packing_fraction: self.packing_fraction, side, radius: self.radius };
        let spheres = crowd.place(&mut rng, "spheres", |rng, _, position| {
            let velocity = velocity(rng) * speed_unit;
            Sphere { position, velocity, radius: self.radius, mass }
        })?;
        Ok(Scene::new(BoxBounds::cube(side)?, spheres))
    }
}

/// Volume of a ball, which is also its mass at unit density.
fn ball_volume(radius: f64) -> f64 {
    4.0 / 3.0 * std::f64::consts::PI * radius.powi(3)
}

/// Checks a generated scene's body count and packing fraction; `[one, many]` names its bodies.
fn check_crowd(bodies: usize, packing_fraction: f64, [one, many]: [&str; 2]) -> Result<()> {
    if bodies == 0 {
        return Err(VadopError::Scene(format!("a scene needs at least one {one}")));
    }
    if bodies > MAX_SCENE_BODIES {
        return Err(VadopError::Scene(format!("a scene holds at most {MAX_SCENE_BODIES} {many}, got {bodies}")));
    }
    if !(packing_fraction > 0.0 && packing_fraction <= 0.6) {
        return Err(VadopError::Scene(format!("packing fraction must be in (0, 0.6], got {packing_fraction}")));
    }
    Ok(())
}

/// Checks a generated scene's largest speed or spin.
fn check_rate(what: &str, value: f64) -> Result<()> {
    if !(value.is_finite() && value >= 0.0) {
        return Err(VadopError::Scene(format!("{what} must be finite and >= 0, got {value}")));
    }
    Ok(())
}

/// `count` balls of `radius` to place apart in the cube `[0, side]^3`, filled to
/// `packing_fraction` (which only the error message needs).
struct Crowd {
    count: usize,
    packing_fraction: f64,
    side: f64,
    radius: f64,
}

impl Crowd {
    /// Places the balls on a face-centred cubic grid, the smallest with room for every ball,
    /// stretched over the whole box, at sites drawn at random and each jittered by up to half the
    /// free gap between neighbours, so no two overlap. `make` turns each centre into a body, in
    /// site order, with its index among them, drawing what else it needs from `rng` after the
    /// centre's jitter. `many` names the bodies in the error for a packing too dense.
    fn place<T>(
        &self,
        rng: &mut ChaCha8Rng,
        many: &str,
        mut make: impl FnMut(&mut ChaCha8Rng, usize, DVec3) -> T,
    ) -> Result<Vec<T>> {
        let diameter = 2.0 * self.radius;
        let usable = self.side - diameter;
        // Face-centred cubic grid: integer triples with an even sum, spacing h, neighbours h*sqrt(2)
        // apart.
        let mut per_axis = 2usize;
        while per_axis.pow(3).div_ceil(2) < self.count {
            per_axis += 1;
        }
        let spacing = usable / (per_axis - 1) as f64;
        let neighbour_distance = spacing * std::f64::consts::SQRT_2;
        if neighbour_distance < diameter {
            return Err(VadopError::Scene(format!(
                "packing fraction {} is too dense to place {} separate {many}",
                self.packing_fraction, self.count
            )));
        }
        let mut sites: Vec<[usize; 3]> = (0..per_axis.pow(3))
            .map(|k| [k % per_axis, (k / per_axis) % per_axis, k / (per_axis * per_axis)])
            .filter(|c| (c[0] + c[1] + c[2]) % 2 == 0)
            .collect();
        sites.shuffle(rng);
        sites.truncate(self.count);
        sites.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
        // Each centre may move up to half the free gap between neighbours: they never overlap.
        let jitter = 0.5 * (neighbour_distance - diameter) * (1.0 - 1e-9) / 3f64.sqrt();
        let (low, high) = (self.radius, self.side - self.radius);
        let bodies = sites
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let lattice = DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64) * spacing + low;
                let offset = DVec3::new(
                    rng.random_range(-1.0..=1.0),
                    rng.random_range(-1.0..=1.0),
                    rng.random_range(-1.0..=1.0),
                ) * jitter;
                let position = (lattice + offset).clamp(DVec3::splat(low), DVec3::splat(high));
                make(rng, k, position)
            })
            .collect();
        Ok(bodies)
    }
}

fn random_direction(rng: &mut ChaCha8Rng) -> DVec3 {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * angle.cos(), r * angle.sin(), z)
}

/// A rotation uniform over all rotations (Shoemake's method).
fn random_rotation(rng: &mut ChaCha8Rng) -> DQuat {
    let u: f64 = rng.random_range(0.0..=1.0);
    let (a, b): (f64, f64) =
        (rng.random_range(0.0..std::f64::consts::TAU), rng.random_range(0.0..std::f64::consts::TAU));
    let (r, s) = ((1.0 - u).sqrt(), u.sqrt());
    DQuat::from_xyzw(r * a.sin(), r * a.cos(), s * b.sin(), s * b.cos())
}

/// Largest spin of a [`ShapesScene`] made by [`ShapesScene::new`], in radians per frame: a body
/// one diameter across then moves its surface by up to a quarter of a diameter per frame.
pub const DEFAULT_MAX_SPIN: f64 = 0.5;

/// Radius of the ball every body of a [`ShapesScene`] lies within, about its shape's origin: half
/// the diameter that is the length unit of speeds.
const CROWD_RADIUS: f64 = 0.5;

/// How far below the crowd a [`ShapesScene`]'s box reaches when it has a floor, in diameters: the
/// floor's bumps lie between a half and a quarter diameter below the crowd.
const FLOOR_DEPTH: f64 = 1.0;

/// The points of a [`ShapesScene`]'s rock: an irregular convex hull within 0.45 of its origin.
const ROCK: [[f64; 3]; 7] = [
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
fn crowd_shapes() -> [(&'static str, Shape); 5] {
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
fn floor_mesh(side: f64, rng: &mut ChaCha8Rng) -> Shape {
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
struct StrictBounds {
    min: DVec3,
    max: DVec3,
}

/// A scene file's sphere entry, read as [`Sphere`] is but refusing unknown keys.
#[derive(serde::Deserialize)]
#[serde(remote = "Sphere", deny_unknown_fields)]
struct StrictSphere {
    position: DVec3,
    velocity: DVec3,
    radius: f64,
    mass: f64,
}

fn strict_spheres<'de, D: serde::Deserializer<'de>>(entries: D) -> std::result::Result<Vec<Sphere>, D::Error> {
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
    use std::collections::BTreeSet;

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
    fn crowd_shapes_lie_within_half_a_diameter_of_their_origin() {
        for (name, shape) in crowd_shapes() {
            let geometry = shape.geometry().unwrap();
            let support = geometry.parry_shape().as_support_map().unwrap();
            // A spiral of directions over the sphere; the farthest support point is the reach.
            let reach = (0..2000)
                .map(|i| {
                    let z = 1.0 - 2.0 * (i as f64 + 0.5) / 2000.0;
                    let (r, phi) = ((1.0 - z * z).sqrt(), i as f64 * 2.399963229728653);
                    support.local_support_point(DVec3::new(r * phi.cos(), r * phi.sin(), z)).length()
                })
                .fold(0.0, f64::max);
            assert!(reach <= CROWD_RADIUS, "{name} reaches {reach}");
        }
    }

    #[test]
    fn shapes_scenes_place_every_kind_apart_within_their_limits() {
        for (bodies, packing_fraction, floor) in [(5, 0.02, false), (600, 0.05, true), (300, 0.15, false)] {
            let parameters = ShapesScene { bodies, packing_fraction, max_speed: 2.0, max_spin: 1.5, floor, seed: 4 };
            let scene = parameters.build().unwrap();
            assert_eq!(scene.spheres.len() + scene.bodies.len(), bodies);
            assert_eq!(scene.static_bodies.len(), usize::from(floor));
            if bodies > 100 {
                let kinds: BTreeSet<&str> = scene.bodies.iter().map(|b| b.shape.as_str()).collect();
                assert_eq!(kinds.len(), crowd_shapes().len());
                assert!(!scene.spheres.is_empty());
            }
            // The crowd fills its cube (the box above the floor) to the packing fraction.
            let side = scene.bounds.max.x;
            let volume: f64 =
                scene.spheres.iter().map(|s| s.mass).sum::<f64>() + scene.bodies.iter().map(|b| b.mass).sum::<f64>();
            assert!((volume / side.powi(3) - packing_fraction).abs() < 1e-12);
            let speeds = scene.spheres.iter().map(|s| s.velocity).chain(scene.bodies.iter().map(|b| b.velocity));
            assert!(speeds.map(|v| v.length()).all(|v| v <= 2.0 * FRAMES_PER_SECOND * (1.0 + 1e-12)));
            assert!(scene
                .bodies
                .iter()
                .all(|b| b.angular_velocity.length() <= 1.5 * FRAMES_PER_SECOND * (1.0 + 1e-12)));
            // Simulate mode refuses overlapping bodies at the first step, and every body is in the box.
            let mut world = scene.world(WorldConfig::default()).unwrap();
            world.step(1.0 / FRAMES_PER_SECOND).unwrap();
            assert_eq!(scene, parameters.build().unwrap(), "the same seed, the same scene");
            assert_ne!(scene, ShapesScene { seed: 5, ..parameters }.build().unwrap());
        }
    }

    #[test]
    fn bad_shapes_scene_parameters_are_errors() {
        let good = ShapesScene::new(100, 0.05, 1.0);
        for (bad, expected) in [
            (ShapesScene { bodies: 0, ..good }, "at least one body"),
            (ShapesScene { packing_fraction: 0.7, ..good }, "packing fraction"),
            (ShapesScene { packing_fraction: 0.5, ..good }, "too dense to place 100 separate bodies"),
            (ShapesScene { max_speed: -1.0, ..good }, "max speed"),
            (ShapesScene { max_spin: f64::INFINITY, ..good }, "max spin"),
        ] {
            let message = bad.build().unwrap_err().to_string();
            assert!(message.contains(expected), "{bad:?}: {message}");
        }
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
