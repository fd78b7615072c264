//! Placement shared by the generators: bodies spread over a jittered face-centred cubic grid so
//! that none overlaps at any packing fraction the generators accept, random directions and
//! rotations from the scene's seed, and the checks of a generator's counts and rates. It never
//! chooses velocities or shapes.

use super::MAX_SCENE_BODIES;
use crate::error::{Result, VadopError};
use glam::{DQuat, DVec3};
use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Volume of a ball, which is also its mass at unit density.
pub(super) fn ball_volume(radius: f64) -> f64 {
    4.0 / 3.0 * std::f64::consts::PI * radius.powi(3)
}

/// Checks a generated scene's body count and packing fraction; `[one, many]` names its bodies.
pub(super) fn check_crowd(bodies: usize, packing_fraction: f64, [one, many]: [&str; 2]) -> Result<()> {
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
pub(super) fn check_rate(what: &str, value: f64) -> Result<()> {
    if !(value.is_finite() && value >= 0.0) {
        return Err(VadopError::Scene(format!("{what} must be finite and >= 0, got {value}")));
    }
    Ok(())
}

/// `count` balls of `radius` to place apart in the cube `[0, side]^3`, filled to
/// `packing_fraction` (which only the error message needs).
pub(super) struct Crowd {
    pub(super) count: usize,
    pub(super) packing_fraction: f64,
    pub(super) side: f64,
    pub(super) radius: f64,
}

impl Crowd {
    /// Places the balls on a face-centred cubic grid, the smallest with room for every ball,
    /// stretched over the whole box, at sites drawn at random and each jittered by up to half the
    /// free gap between neighbours, so no two overlap. `make` turns each centre into a body, in
    /// site order, with its index among them, drawing what else it needs from `rng` after the
    /// centre's jitter. `many` names the bodies in the error for a packing too dense.
    pub(super) fn place<T>(
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

pub(super) fn random_direction(rng: &mut ChaCha8Rng) -> DVec3 {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * angle.cos(), r * angle.sin(), z)
}

/// A rotation uniform over all rotations (Shoemake's method).
pub(super) fn random_rotation(rng: &mut ChaCha8Rng) -> DQuat {
    let u: f64 = rng.random_range(0.0..=1.0);
    let (a, b): (f64, f64) =
        (rng.random_range(0.0..std::f64::consts::TAU), rng.random_range(0.0..std::f64::consts::TAU));
    let (r, s) = ((1.0 - u).sqrt(), u.sqrt());
    DQuat::from_xyzw(r * a.sin(), r * a.cos(), s * b.sin(), s * b.cos())
}
