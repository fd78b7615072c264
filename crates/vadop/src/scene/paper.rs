//! The paper's test scene and its variants: spheres in a cube at a packing fraction, with
//! velocities drawn as the paper does (random directions, speeds up to a maximum) or as an
//! equilibrium gas, a stream or heavy-tailed speeds. It owns those velocity laws; placement is
//! shared with the other generators.

use super::file::Scene;
use super::placement::{ball_volume, check_crowd, check_rate, random_direction, Crowd};
use super::FRAMES_PER_SECOND;
use crate::bodies::Sphere;
use crate::error::{Result, VadopError};
use crate::walls::BoxBounds;
use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

/// The scenes of equal spheres the command-line tools generate, by how their velocities are
/// drawn from one speed (see [`SphereScene::velocities`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SphereScene {
    /// The paper's: speeds uniform up to the speed.
    Paper,
    /// An equilibrium gas of that root-mean-square speed.
    Gas,
    /// A stream at that speed.
    Stream,
    /// Heavy-tailed speeds of that median, tail index [`HEAVY_TAIL_INDEX`].
    HeavyTail,
}

/// The tail index of [`SphereScene::HeavyTail`]: one body in a hundred is 20 times faster than
/// the median.
pub const HEAVY_TAIL_INDEX: f64 = 1.5;

impl SphereScene {
    /// Its velocities at `speed` diameters per frame, a stream's directions within `spread`
    /// degrees of +x, and what the scene is for a summary, its parenthesis left open for the
    /// caller to add to and close.
    ///
    /// ```
    /// use vadop::scene::{SphereScene, Velocities};
    /// let (velocities, what) = SphereScene::Stream.velocities(2.0, 90.0);
    /// assert_eq!(velocities, Velocities::Stream { speed: 2.0, spread: std::f64::consts::FRAC_PI_2 });
    /// assert_eq!(format!("{what})"), "stream (2 diameters/frame within 90 degrees of +x)");
    /// ```
    pub fn velocities(self, speed: f64, spread: f64) -> (Velocities, String) {
        match self {
            SphereScene::Paper => {
                (Velocities::Uniform { max_speed: speed }, format!("paper scene (speeds up to {speed} diameters/frame"))
            }
            SphereScene::Gas => (
                Velocities::Maxwell { rms_speed: speed },
                format!("equilibrium gas (rms speed {speed} diameters/frame"),
            ),
            SphereScene::Stream => (
                Velocities::Stream { speed, spread: spread.to_radians() },
                format!("stream ({speed} diameters/frame within {spread} degrees of +x"),
            ),
            SphereScene::HeavyTail => (
                Velocities::HeavyTail { median_speed: speed, tail_index: HEAVY_TAIL_INDEX },
                format!("heavy-tailed speeds (median {speed} diameters/frame, tail index {HEAVY_TAIL_INDEX}"),
            ),
        }
    }
}

impl Velocities {
    /// Checks the parameters.
    pub(super) fn check(&self) -> Result<()> {
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
    pub(super) fn draw(&self, rng: &mut ChaCha8Rng) -> DVec3 {
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
pub(super) fn up_to(rng: &mut ChaCha8Rng, max: f64) -> DVec3 {
    random_direction(rng) * rng.random_range(0.0..=1.0) * max
}

/// A standard normal number (Box–Muller).
pub(super) fn normal(rng: &mut ChaCha8Rng) -> f64 {
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
    pub(super) fn place(&self, mut velocity: impl FnMut(&mut ChaCha8Rng) -> DVec3) -> Result<Scene> {
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
