//! The VADOP bounding volume: which pool axes a body uses, and its interval on each.
//!
//! It owns the axis-selection rule (a body moving with velocity v uses the pool axes a with
//! |a.v|/|v| <= sin(phi), so its projections barely move while it flies) and the interval that
//! bounds a sphere over the rest of the frame on one axis, p(t) = p0 + t (v.a), padded just enough
//! to absorb rounding so a pruned pair is always truly separated. It never stores anything:
//! the sweep and prune keeps the intervals, the world keeps the bodies.
//!
//! Why phi = rho (the pool's covering radius) suffices for every pair to share an axis: the
//! direction d orthogonal to both velocities lies within rho of some axis a; then a is within rho
//! of the plane orthogonal to each velocity, i.e. |a.v|/|v| <= sin(rho) for both bodies. A body at
//! rest has no direction; it takes the band around +z, which meets every other band the same way.

use crate::axis_pool::AxisPool;
use glam::DVec3;

/// Relative padding on interval ends, far above the rounding of a few dot products.
const RELATIVE_PADDING: f64 = 1e-12;

/// Direction whose orthogonal band a body with `velocity` uses.
#[inline]
pub fn alignment_direction(velocity: DVec3) -> DVec3 {
    velocity.try_normalize().unwrap_or(DVec3::Z)
}

/// Ids (ascending) of the pool axes a body moving with `velocity` uses, written into `out`.
///
/// ```
/// use glam::DVec3;
/// use vadop::{axis_pool::AxisPool, bounding_volume::select_axes};
/// let pool = AxisPool::new(3).unwrap();
/// let mut axes = Vec::new();
/// // Along x, the coordinate pool keeps y and z: the x projection moves, the others do not.
/// select_axes(&pool, DVec3::new(5.0, 0.0, 0.0), pool.covering_radius().sin(), &mut axes);
/// assert_eq!(axes.len(), 2);
/// ```
pub fn select_axes(pool: &AxisPool, velocity: DVec3, sin_phi: f64, out: &mut Vec<u32>) {
    pool.band(alignment_direction(velocity), sin_phi, out);
}

/// Closed interval `[lo, hi]` of a projection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    /// True when the two closed intervals share a point.
    #[inline]
    pub fn overlaps(self, other: Interval) -> bool {
        self.lo <= other.hi && other.lo <= self.hi
    }
}

/// Interval on `axis` that bounds a sphere at `position` moving with `velocity` for `duration`.
///
/// ```
/// use glam::DVec3;
/// use vadop::bounding_volume::interval;
/// let i = interval(DVec3::X, DVec3::new(1.0, 0.0, 0.0), DVec3::new(2.0, 9.0, 0.0), 0.5, 1.0);
/// assert!(i.lo <= 0.5 && i.lo > 0.49 && i.hi >= 3.5 && i.hi < 3.51);
/// ```
#[inline]
pub fn interval(axis: DVec3, position: DVec3, velocity: DVec3, radius: f64, duration: f64) -> Interval {
    let start = position.dot(axis);
    let end = start + duration * velocity.dot(axis);
    let padding = RELATIVE_PADDING * (start.abs() + end.abs() + radius);
    Interval { lo: start.min(end) - radius - padding, hi: start.max(end) + radius + padding }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interval_contains_the_swept_sphere() {
        let axis = DVec3::new(1.0, 1.0, 0.0).normalize();
        let p = DVec3::new(1e6, -3.0, 2.0);
        let v = DVec3::new(-40.0, 7.0, 1.0);
        let r = 0.25;
        let i = interval(axis, p, v, r, 0.1);
        for k in 0..=100 {
            let c = (p + v * (0.1 * k as f64 / 100.0)).dot(axis);
            assert!(i.lo <= c - r && c + r <= i.hi);
        }
    }

    #[test]
    fn resting_bodies_use_the_band_around_z() {
        assert_eq!(alignment_direction(DVec3::ZERO), DVec3::Z);
        assert_eq!(alignment_direction(DVec3::new(0.0, -2.0, 0.0)), -DVec3::Y);
    }
}
