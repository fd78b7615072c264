//! Scenes: the paper's test scene (spheres in a cube at a given packing fraction, random
//! directions, speeds up to a maximum in diameters per frame, 30 frames per second), the same
//! placement with other velocities (an equilibrium gas, a stream, heavy-tailed speeds), and the
//! scene file format.
//!
//! It owns scene generation, which is seeded and deterministic, and reading and writing scene
//! files. It never steps anything. Generated spheres never overlap: centres sit on a jittered
//! face-centred cubic grid spread over the whole box, so the same scene serves simulate mode.
//!
//! File format (JSON): `{"bounds": {"min": [x, y, z], "max": [x, y, z]}, "spheres": [{"position":
//! [x, y, z], "velocity": [x, y, z], "radius": r, "mass": m}, ...]}`. Units are free (the paper's
//! scene uses diameters and seconds).

use crate::bodies::Sphere;
use crate::error::{Result, VadopError};
use crate::world::{BoxBounds, World, WorldConfig};
use glam::DVec3;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Most spheres a generated scene holds: more would not fit in memory, and generating them would
/// run for hours before failing.
pub const MAX_SCENE_BODIES: usize = 100_000_000;

/// Frame rate of the paper's scene.
pub const FRAMES_PER_SECOND: f64 = 30.0;

/// A box and the spheres in it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scene {
    pub bounds: BoxBounds,
    pub spheres: Vec<Sphere>,
}

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
        Ok(Scene { bounds: BoxBounds::cube(side)?, spheres })
    }
}

fn random_direction(rng: &mut ChaCha8Rng) -> DVec3 {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * angle.cos(), r * angle.sin(), z)
}

impl Scene {
    /// A world holding this scene's spheres, their handles in file order (slots 0..n, generation 0).
    pub fn world(&self, config: WorldConfig) -> Result<World> {
        let mut world = World::new(self.bounds, config)?;
        world.add_spheres(&self.spheres)?;
        Ok(world)
    }

    /// Reads a scene file.
    pub fn load(path: &std::path::Path) -> Result<Scene> {
        let io =
            |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
        let text = std::fs::read_to_string(path).map_err(|e| io(&e))?;
        let scene: Scene = serde_json::from_str(&text).map_err(|e| io(&e))?;
        BoxBounds::new(scene.bounds.min, scene.bounds.max)?;
        Ok(scene)
    }

    /// Writes a scene file atomically (a temporary file renamed into place).
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        let io =
            |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
        let text = serde_json::to_string(self).map_err(|e| io(&e))?;
        let temporary = path.with_extension("json.partial");
        std::fs::write(&temporary, text).map_err(|e| io(&e))?;
        std::fs::rename(&temporary, path).map_err(|e| io(&e))
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
