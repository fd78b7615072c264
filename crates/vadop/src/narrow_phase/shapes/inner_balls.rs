//! Inner balls: how long a contact in progress certainly lasts, from two balls fixed in the two
//! bodies. A ball that a solid holds stays inside it however the body moves, so while two such
//! balls (one in each shape) overlap, or lie less than a distance apart, so do the shapes. Their
//! centres move with the bodies: the relative velocity of the centres of mass carries the pair's
//! direction (a contact deepening or shallowing along it, not at the worst-case rate), and
//! turning moves a centre at most its angular speed times its distance from the centre of mass.
//! It owns that certificate only; it never measures distances or chooses a probe time.

use glam::DVec3;

/// A ball a shape holds, in the shape's own frame (scaled): its centre and radius.
pub(super) type ShapeBall = (DVec3, f64);

/// A ball fixed in a body, at a probe time: its centre in the probe's frame, its radius (0 for a
/// point), and a bound on how fast turning moves its centre.
#[derive(Debug, Clone, Copy)]
pub(super) struct InnerBall {
    pub(super) centre: DVec3,
    pub(super) radius: f64,
    pub(super) drift: f64,
}

/// The longest time `s >= 0` over which the ball `b` (in the second body) stays within `limit`
/// of the ball `a` (in the first) while the second body's centre of mass moves at `velocity`
/// relative to the first's, up to `slack` of rounding: over it the shapes' signed distance stays
/// at most `limit`. 0 when the balls are farther apart than that already.
///
/// The centres are at most `|d + velocity s| + (drift_a + drift_b) s` apart at time `s` (`d` the
/// centres' offset now), a convex function of `s`, so the longest time is the root of one
/// quadratic, and the check at its end holds for every time before it.
pub(super) fn held(a: InnerBall, b: InnerBall, velocity: DVec3, limit: f64, slack: f64) -> f64 {
    let d = b.centre - a.centre;
    let drift = a.drift + b.drift;
    let reach = limit + a.radius + b.radius - slack;
    let apart = |s: f64| (d + velocity * s).length() + drift * s;
    if !(apart(0.0) <= reach) {
        return 0.0;
    }
    // |d + v s|² = (reach - drift s)²: q s² + 2 h s + c = 0 with c <= 0, its root s >= 0.
    let q = velocity.length_squared() - drift * drift;
    let h = d.dot(velocity) + reach * drift;
    let c = d.length_squared() - reach * reach;
    let below = h + (h * h - q * c).max(0.0).sqrt();
    if !(below > 0.0) {
        // Neither the offset nor the turning ever grows.
        return if velocity == DVec3::ZERO && drift == 0.0 { f64::INFINITY } else { 0.0 };
    }
    // Rounding of the root and of `apart`: back off until the end is certainly inside.
    let mut s = -c / below * (1.0 - 1e-9);
    for _ in 0..4 {
        let rounding = 8.0 * f64::EPSILON * (d.length() + (velocity.length() + drift) * s + reach);
        if apart(s) + rounding <= reach {
            return s;
        }
        s *= 0.5;
    }
    0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Over the time `held` gives, the balls' centres, moved by the velocity and turned about
    /// their centres of mass as fast as the drift allows, stay within the limit plus the radii;
    /// and the time is not much shorter than the longest such time.
    #[test]
    fn held_balls_stay_within_the_limit_and_the_time_is_nearly_the_longest() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut unit =
            move || DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let mut found = 0;
        for _ in 0..20000 {
            let a = InnerBall { centre: unit(), radius: unit().x.abs(), drift: unit().x.abs() * 0.3 };
            let b = InnerBall { centre: unit(), radius: unit().x.abs(), drift: unit().x.abs() * 0.3 };
            let (velocity, limit) = (unit() * 2.0, 1e-3);
            let s = held(a, b, velocity, limit, 0.0);
            let reach = limit + a.radius + b.radius;
            let worst = |t: f64| (b.centre - a.centre + velocity * t).length() + (a.drift + b.drift) * t;
            if s == 0.0 {
                assert!(worst(0.0) > reach * (1.0 - 1e-12));
                continue;
            }
            found += 1;
            for k in 0..=64 {
                let t = s * k as f64 / 64.0;
                assert!(worst(t) <= reach, "{t} of {s}: {} > {reach}", worst(t));
            }
            assert!(worst(s * 1.001) > reach, "{s} is far from the longest");
        }
        assert!(found > 5000, "only {found} pairs within reach");
    }
}
