//! When two bodies can be near at all: the times since a search's reference outside which their
//! bounding volumes (spheres about the centres of mass, or a body's sphere and a plane or a box)
//! keep them farther apart than a distance, in closed form on straight and bent paths. A search
//! probes only inside them. It owns those intervals only: it never measures a shape.

use super::SLACK;
use crate::narrow_phase::falling::bent_reach;
use crate::narrow_phase::spheres::{sphere_separation_time, sphere_sphere_time};
use glam::DVec3;

/// The times since the reference `[enter, leave]` outside which a pair is certainly farther apart
/// than some distance: bounding volumes moving in straight lines meet in one interval at most.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Reach {
    pub(super) enter: f64,
    /// Infinite when they never part again.
    pub(super) leave: f64,
}

impl Reach {
    /// The times `tau >= 0` with `height + rate * tau <= limit`.
    pub(super) fn below(height: f64, rate: f64, limit: f64) -> Option<Reach> {
        if height <= limit {
            let leave = if rate > 0.0 { (limit - height) / rate } else { f64::INFINITY };
            Some(Reach { enter: 0.0, leave })
        } else if rate < 0.0 {
            Some(Reach { enter: (height - limit) / -rate, leave: f64::INFINITY })
        } else {
            None
        }
    }

    /// The times `tau >= 0` with `height + rate tau + accel tau^2 / 2 <= limit`: a height over
    /// a plane on a parabola. Where those times are two intervals (a height that dips below the
    /// limit, rises above it and comes back) the one interval holds both.
    pub(super) fn below_bent(height: f64, rate: f64, accel: f64, limit: f64) -> Option<Reach> {
        if accel == 0.0 {
            return Reach::below(height, rate, limit);
        }
        // The roots of accel tau^2 / 2 + rate tau + gap, free of cancellation.
        let gap = height - limit;
        let discriminant = rate * rate - 2.0 * accel * gap;
        if !(discriminant >= 0.0) {
            // Never at the limit: always below it (bending down) or above it.
            return (accel < 0.0).then_some(Reach { enter: 0.0, leave: f64::INFINITY });
        }
        let q = -0.5 * (rate + discriminant.sqrt().copysign(rate));
        let roots = if q == 0.0 { (0.0, 0.0) } else { (2.0 * q / accel, gap / q) };
        let (first, last) = (roots.0.min(roots.1), roots.0.max(roots.1));
        if accel > 0.0 {
            // Below the limit between the roots.
            return (last >= 0.0).then_some(Reach { enter: first.max(0.0), leave: last });
        }
        // Below it outside them.
        let enter = if first < 0.0 && last > 0.0 { last } else { 0.0 };
        Some(Reach { enter, leave: f64::INFINITY })
    }

    /// The times `tau >= 0` with `|offset + velocity * tau| <= limit`: the closed forms of two
    /// spheres of radii summing to `limit`.
    pub(super) fn sphere(offset: DVec3, velocity: DVec3, limit: f64) -> Option<Reach> {
        // Without relative motion the spheres part never.
        let leave = sphere_separation_time(offset, velocity, limit).unwrap_or(f64::INFINITY);
        if offset.length() <= limit {
            return Some(Reach { enter: 0.0, leave });
        }
        // None when receding or missing, with a margin far below the `limit` this is called with.
        let enter = sphere_sphere_time(offset, velocity, limit)?;
        Some(Reach { enter, leave: leave.max(enter) })
    }

    /// The times `tau >= 0` with `|offset + velocity tau + acceleration tau^2 / 2| <= limit`:
    /// two spheres on a bent relative path, from the first time they come within `limit` to
    /// the last (see [`bent_reach`]).
    pub(super) fn bent_sphere(offset: DVec3, velocity: DVec3, acceleration: DVec3, limit: f64) -> Option<Reach> {
        if acceleration == DVec3::ZERO {
            return Reach::sphere(offset, velocity, limit);
        }
        let (enter, leave) = bent_reach(offset, velocity, acceleration, limit)?;
        Some(Reach { enter, leave })
    }

    /// The times in both.
    pub(super) fn meet(self, other: Reach) -> Option<Reach> {
        let met = Reach { enter: self.enter.max(other.enter), leave: self.leave.min(other.leave) };
        (met.enter <= met.leave).then_some(met)
    }
}

/// The times two solids whose centres of mass are `offset` apart, with the relative `velocity`
/// and `acceleration`, may come within `within` of each other: they lie in their bounding spheres
/// of radii summing to `size`. It needs no pose, so a pair's search asks it before building its
/// bodies (see `super::convex_pair_in_reach`).
pub(super) fn spheres_reach(
    (offset, velocity, acceleration): (DVec3, DVec3, DVec3),
    size: f64,
    within: f64,
) -> Option<Reach> {
    let limit = size + within + SLACK * (offset.length() + size);
    Reach::bent_sphere(offset, velocity, acceleration, limit)
}
