//! Scenes: the paper's test scene (spheres in a cube at a given packing fraction, random
//! directions, speeds up to a maximum in diameters per frame, 30 frames per second) and the scene
//! file format.
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
        if self.bodies == 0 {
            return Err(VadopError::Scene("a scene needs at least one sphere".into()));
        }
        if self.bodies > MAX_SCENE_BODIES {
            return Err(VadopError::Scene(format!("a scene holds at most {MAX_SCENE_BODIES} spheres, got {}", self.bodies)));
        }
        if !(self.packing_fraction > 0.0 && self.packing_fraction <= 0.6) {
            return Err(VadopError::Scene(format!("packing fraction must be in (0, 0.6], got {}", self.packing_fraction)));
        }
        if !(self.max_speed.is_finite() && self.max_speed >= 0.0) {
            return Err(VadopError::Scene(format!("max speed must be finite and >= 0, got {}", self.max_speed)));
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
                let velocity = random_direction(&mut rng) * rng.random_range(0.0..=1.0) * self.max_speed * speed_unit;
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
    /// A world holding this scene's spheres (ids 0..n in file order).
    pub fn world(&self, config: WorldConfig) -> Result<World> {
        let mut world = World::new(self.bounds, config)?;
        world.add_spheres(&self.spheres)?;
        Ok(world)
    }

    /// Reads a scene file.
    pub fn load(path: &std::path::Path) -> Result<Scene> {
        let io = |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
        let text = std::fs::read_to_string(path).map_err(|e| io(&e))?;
        let scene: Scene = serde_json::from_str(&text).map_err(|e| io(&e))?;
        BoxBounds::new(scene.bounds.min, scene.bounds.max)?;
        Ok(scene)
    }

    /// Writes a scene file atomically (a temporary file renamed into place).
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        let io = |e: &dyn std::fmt::Display| VadopError::Io { path: path.display().to_string(), message: e.to_string() };
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
