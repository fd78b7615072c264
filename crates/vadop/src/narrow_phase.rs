//! Narrow phase: the exact time of first contact of two moving spheres, or of a sphere and a wall
//! of the box, within the rest of a frame.
//!
//! It owns the contact arithmetic and its tolerance, and nothing else: it never sees the world,
//! the broad phase or the queue, so the VADOP world and the brute-force oracle call the very same
//! functions and get bit-identical times. Motion is linear within a frame: p(t) = p + t * v.
//!
//! Tolerance: two spheres whose centre distance d satisfies d^2 >= R^2 (1 - 2 * `CONTACT_TOLERANCE`)
//! count as touching, R being the sum of the radii (a *relative* tolerance, so it means the same at
//! any scale and any distance from the origin). Spheres already overlapping deeper than that are
//! not a new contact: they are passing through each other (detect mode) or were resolved earlier.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x < y)` deliberately also rejects NaN.

use glam::DVec3;

/// Relative tolerance on the centre distance within which two spheres count as touching.
pub const CONTACT_TOLERANCE: f64 = 1e-9;

/// Smallest approach rate, relative to |offset| |relative velocity|, that counts as approaching.
/// Below it the motion is tangential to rounding accuracy: such a touch carries no impulse, and
/// treating it as a contact could re-detect a just-resolved pair forever.
pub const APPROACH_TOLERANCE: f64 = 1e-12;

/// Time `tau` in `[0, window)` at which two spheres first touch while approaching, if any.
///
/// `offset` is the centre of the second sphere minus the centre of the first, `relative_velocity`
/// the second's velocity minus the first's, both at the current time; `radius_sum` is R.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::sphere_sphere_time;
/// // Two unit spheres 10 apart closing at speed 4 touch after (10 - 2) / 4 = 2.
/// let tau = sphere_sphere_time(DVec3::new(10.0, 0.0, 0.0), DVec3::new(-4.0, 0.0, 0.0), 2.0, 5.0);
/// assert_eq!(tau, Some(2.0));
/// // They do not touch within a window of 1.
/// assert_eq!(sphere_sphere_time(DVec3::new(10.0, 0.0, 0.0), DVec3::new(-4.0, 0.0, 0.0), 2.0, 1.0), None);
/// ```
#[inline]
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x < y)` deliberately rejects NaN too.
pub fn sphere_sphere_time(
    offset: DVec3,
    relative_velocity: DVec3,
    radius_sum: f64,
    window: f64,
) -> Option<f64> {
    let approach = offset.dot(relative_velocity);
    let speed_sq = relative_velocity.length_squared();
    // Only approaching pairs can start a contact; `!(x < y)` also rejects NaN.
    let threshold = -APPROACH_TOLERANCE * (offset.length_squared() * speed_sq).sqrt();
    if !(approach < threshold) {
        return None;
    }
    let radius_sq = radius_sum * radius_sum;
    let gap = offset.length_squared() - radius_sq;
    if gap <= 0.0 {
        let touching = gap >= -2.0 * CONTACT_TOLERANCE * radius_sq;
        // An empty window holds no contact, not even one at its start.
        return (touching && 0.0 < window).then_some(0.0);
    }
    // b^2 - a c written as a R^2 - |offset x v|^2: no cancellation between two large squares,
    // which keeps grazing and nearly parallel motion accurate.
    let discriminant = speed_sq * radius_sq - offset.cross(relative_velocity).length_squared();
    if discriminant < 0.0 {
        return None;
    }
    // The smaller root (-b - sqrt(disc)) / a in the form that never divides by a tiny a.
    let tau = gap / (-approach + discriminant.sqrt());
    (tau < window).then_some(tau)
}

/// A side of the axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
pub enum Wall {
    MinX,
    MaxX,
    MinY,
    MaxY,
    MinZ,
    MaxZ,
}

impl Wall {
    /// The coordinate axis (0, 1, 2) this wall is orthogonal to.
    pub fn axis(self) -> usize {
        self as usize / 2
    }
    /// True for the wall at the box's maximum on its axis.
    pub fn is_max(self) -> bool {
        self as usize % 2 == 1
    }
    /// The wall on `axis` at the maximum side when `is_max`.
    pub fn new(axis: usize, is_max: bool) -> Wall {
        const WALLS: [Wall; 6] = [Wall::MinX, Wall::MaxX, Wall::MinY, Wall::MaxY, Wall::MinZ, Wall::MaxZ];
        WALLS[axis * 2 + is_max as usize]
    }
    /// Unit normal pointing out of the box.
    pub fn outward_normal(self) -> DVec3 {
        let mut n = DVec3::ZERO;
        n[self.axis()] = if self.is_max() { 1.0 } else { -1.0 };
        n
    }
}

/// Earliest time in `[0, window)` at which a sphere moving inside the box `[min, max]` touches a
/// wall while moving towards it, with the wall it touches. Ties go to the lowest axis.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::{sphere_wall_time, Wall};
/// let hit = sphere_wall_time(DVec3::new(5.0, 5.0, 5.0), DVec3::new(2.0, 0.0, 0.0), 1.0,
///                            DVec3::ZERO, DVec3::splat(10.0), 10.0);
/// assert_eq!(hit, Some((2.0, Wall::MaxX)));
/// ```
#[inline]
pub fn sphere_wall_time(
    position: DVec3,
    velocity: DVec3,
    radius: f64,
    min: DVec3,
    max: DVec3,
    window: f64,
) -> Option<(f64, Wall)> {
    let mut best: Option<(f64, Wall)> = None;
    for axis in 0..3 {
        let speed = velocity[axis];
        let (distance, is_max) = if speed > 0.0 {
            (max[axis] - radius - position[axis], true)
        } else if speed < 0.0 {
            (position[axis] - (min[axis] + radius), false)
        } else {
            continue;
        };
        // A body already at (or a rounding error past) the wall and moving out touches it now.
        let tau = distance.max(0.0) / speed.abs();
        if tau < window && best.is_none_or(|(t, _)| tau < t) {
            best = Some((tau, Wall::new(axis, is_max)));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_on_and_miss() {
        let t = sphere_sphere_time(DVec3::new(3.0, 0.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), 1.0, 10.0);
        assert_eq!(t, Some(2.0));
        let miss = sphere_sphere_time(DVec3::new(3.0, 1.5, 0.0), DVec3::new(-1.0, 0.0, 0.0), 1.0, 10.0);
        assert_eq!(miss, None);
        let receding = sphere_sphere_time(DVec3::new(3.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), 1.0, 10.0);
        assert_eq!(receding, None);
    }

    #[test]
    fn touching_at_start_counts_only_when_approaching() {
        let touching = DVec3::new(2.0, 0.0, 0.0);
        assert_eq!(sphere_sphere_time(touching, DVec3::new(-1.0, 0.0, 0.0), 2.0, 1.0), Some(0.0));
        assert_eq!(sphere_sphere_time(touching, DVec3::new(1.0, 0.0, 0.0), 2.0, 1.0), None);
        // Deep overlap is not a new contact (bodies passing through in detect mode).
        let deep = DVec3::new(1.0, 0.0, 0.0);
        assert_eq!(sphere_sphere_time(deep, DVec3::new(-1.0, 0.0, 0.0), 2.0, 1.0), None);
        // Found by fuzzing: touching pairs reported a contact at 0 in an empty window.
        assert_eq!(sphere_sphere_time(touching, DVec3::new(-1.0, 0.0, 0.0), 2.0, 0.0), None);
        assert_eq!(sphere_sphere_time(touching, DVec3::new(-1.0, 0.0, 0.0), 2.0, -1.0), None);
    }

    #[test]
    fn grazing_contact_is_found_at_the_closest_approach() {
        // Passes at distance exactly R: touches once, at the closest approach t = 5.
        let t = sphere_sphere_time(DVec3::new(5.0, 2.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), 2.0, 10.0);
        assert_eq!(t, Some(5.0));
        let just_misses =
            sphere_sphere_time(DVec3::new(5.0, 2.0 + 1e-9, 0.0), DVec3::new(-1.0, 0.0, 0.0), 2.0, 10.0);
        assert_eq!(just_misses, None);
    }

    #[test]
    fn far_from_origin_and_very_fast() {
        // 500 diameters per frame, a million units from the origin.
        let base = DVec3::splat(1.0e6);
        let a = base;
        let b = base + DVec3::new(400.0, 0.3, 0.0);
        let t = sphere_sphere_time(b - a, DVec3::new(-500.0, 0.0, 0.0), 1.0, 1.0).expect("contact");
        let expected = (400.0 - (1.0f64 - 0.09).sqrt()) / 500.0;
        assert!((t - expected).abs() <= 1e-12, "{t} vs {expected}");
    }

    #[test]
    fn nearly_parallel_motion_is_stable() {
        // Relative speed 1e-12: the contact lies far outside any frame, and nothing divides by ~0.
        let t = sphere_sphere_time(DVec3::new(3.0, 0.0, 0.0), DVec3::new(-1e-12, 0.0, 0.0), 2.0, 1.0);
        assert_eq!(t, None);
        let t = sphere_sphere_time(DVec3::new(2.0 + 1e-13, 0.0, 0.0), DVec3::new(-1e-12, 0.0, 0.0), 2.0, 1.0);
        let t = t.expect("contact within the frame");
        assert!((t - 0.1).abs() < 1e-3, "{t}");
    }

    #[test]
    fn walls() {
        let min = DVec3::ZERO;
        let max = DVec3::splat(10.0);
        let r = sphere_wall_time(DVec3::new(1.0, 5.0, 5.0), DVec3::new(-1.0, 0.0, 0.0), 1.0, min, max, 1.0);
        assert_eq!(r, Some((0.0, Wall::MinX)));
        let r = sphere_wall_time(DVec3::new(5.0, 5.0, 8.0), DVec3::new(0.0, 0.0, 2.0), 1.0, min, max, 1.0);
        assert_eq!(r, Some((0.5, Wall::MaxZ)));
        let none = sphere_wall_time(DVec3::new(5.0, 5.0, 5.0), DVec3::new(1.0, 1.0, 1.0), 1.0, min, max, 1.0);
        assert_eq!(none, None);
        assert_eq!(Wall::MaxY.outward_normal(), DVec3::Y);
        assert_eq!(Wall::new(2, false), Wall::MinZ);
    }
}
