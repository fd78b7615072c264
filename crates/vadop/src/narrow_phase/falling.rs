//! Two spheres whose accelerations differ: one falling under gravity, the other at rest on a
//! pile or sliding on the floor (see [`crate::bodies::Rest`]). Their relative path bends,
//! p(tau) = d + w tau + c tau^2 / 2, and the gap |p|^2 - R^2 is a quartic in tau: no closed form
//! as simple as the straight paths' of [`super::spheres`].
//!
//! It owns that quartic's roots and nothing else: the first (the contact), and for bounding
//! volumes on bent paths the first and the last ([`bent_reach`]). The gap's rate is p . p', a cubic; its real
//! roots split `tau >= 0` into pieces on which the gap is monotone, and the first piece that ends
//! at or below zero holds the contact, found by bisection. Every root is bracketed and bisected to
//! adjacent floats (over the floats' bits, so at most 64 steps), so the time is a function of the
//! two motions alone, to the bit (canonical, like the straight paths'), and scaling lengths and
//! times by powers of two first makes a scene scaled by a power of two give times scaled alike.
//! The touching tolerance and the rule at the reference instant are the straight paths' (see
//! [`super::spheres`]), with two additions, or the pull would sink one into the other: a pair
//! touching with no relative velocity but pulled together (a ball let go on a resting one) is
//! approaching, and a pair touching and parting so slowly that the pull turns it back before its
//! gap opens touches again where it turns.

use super::spheres::{APPROACH_TOLERANCE, CONTACT_TOLERANCE};
use crate::motion::Motion;
use crate::numeric::{exponent, power_of_two, scale_by_power_of_two};
use crate::window::Window;
use glam::DVec3;

/// The relative path of two spheres in units where the radius sum and the acceleration are near 1.
#[derive(Debug, Clone, Copy)]
struct Bent {
    offset: DVec3,
    velocity: DVec3,
    acceleration: DVec3,
    radius_sq: f64,
}

impl Bent {
    #[inline]
    fn at(&self, tau: f64) -> DVec3 {
        self.offset + tau * (self.velocity + (0.5 * tau) * self.acceleration)
    }

    /// |p|^2 - R^2: positive while apart.
    #[inline]
    fn gap(&self, tau: f64) -> f64 {
        self.at(tau).length_squared() - self.radius_sq
    }

    /// p . p', half the gap's rate: negative while approaching.
    #[inline]
    fn rate(&self, tau: f64) -> f64 {
        self.at(tau).dot(self.velocity + tau * self.acceleration)
    }

    /// The gap and its rate (for Newton's steps).
    #[inline]
    fn gap_and_slope(&self, tau: f64) -> (f64, f64) {
        let (p, v) = (self.at(tau), self.velocity + tau * self.acceleration);
        (p.length_squared() - self.radius_sq, 2.0 * p.dot(v))
    }

    /// The rate and its own rate, p' . p' + p . p'' (for Newton's steps).
    #[inline]
    fn rate_and_slope(&self, tau: f64) -> (f64, f64) {
        let (p, v) = (self.at(tau), self.velocity + tau * self.acceleration);
        (p.dot(v), v.length_squared() + p.dot(self.acceleration))
    }

    /// The times in `(0, inf)` where the gap's rate changes sign, ascending.
    fn turning_points(&self) -> ([f64; 3], usize) {
        let (d, w, c) = (self.offset, self.velocity, self.acceleration);
        // p . p' = a0 + a1 tau + a2 tau^2 + a3 tau^3.
        let (a0, a1, a2, a3) = (d.dot(w), w.dot(w) + d.dot(c), 1.5 * w.dot(c), 0.5 * c.dot(c));
        // All real roots lie below Cauchy's bound.
        let bound = 1.0 + a0.abs().max(a1.abs()).max(a2.abs()) / a3;
        // The rate is monotone between the roots of its derivative a1 + 2 a2 tau + 3 a3 tau^2.
        let mut ends = [0.0, bound, bound, bound];
        let discriminant = a2 * a2 - 3.0 * a1 * a3;
        if discriminant > 0.0 {
            let q = -(a2 + a2.signum() * discriminant.sqrt());
            let (s, t) = (q / (3.0 * a3), a1 / q);
            let (s, t) = (s.min(t), s.max(t));
            ends[1] = s.clamp(0.0, bound);
            ends[2] = t.clamp(0.0, bound);
        }
        let mut roots = [0.0; 3];
        let mut count = 0;
        for k in 0..3 {
            let (lo, hi) = (ends[k], ends[k + 1]);
            // A bracketed sign change: its root, where the gap turns.
            if let Some(root) = (hi > lo).then(|| first_change(lo, hi, |tau| self.rate_and_slope(tau))).flatten() {
                roots[count] = root;
                count += 1;
            }
        }
        (roots, count)
    }
}

/// Newton's steps towards the root: after these, the search to the float starts where they
/// got (bisections stand in for steps that leave the bracket).
const NEWTON_STEPS: u32 = 6;

/// In `[lo, hi]` (`0 <= lo <= hi`): the first float at which `f` (its value and slope) no longer
/// has the sign it has at `lo` (positive or not), `None` when it still has it at `hi`. A few
/// safeguarded Newton steps find where to look; from there a bracket that doubles its width in
/// floats, then a bisection over the floats' bits (ordered as the values are for floats of one
/// sign), close in on adjacent floats: far fewer evaluations than bisecting `[lo, hi]` (64), and
/// a function of its arguments alone, so every caller gets the same bits.
fn first_change(lo: f64, hi: f64, f: impl Fn(f64) -> (f64, f64)) -> Option<f64> {
    let positive = f(lo).0 > 0.0;
    let holds = |tau: f64| (f(tau).0 > 0.0) == positive;
    if holds(hi) {
        return None;
    }
    let (mut low, mut high, mut x) = (lo, hi, lo + 0.5 * (hi - lo));
    for _ in 0..NEWTON_STEPS {
        let (value, slope) = f(x);
        if (value > 0.0) == positive {
            low = x;
        } else {
            high = x;
        }
        let next = x - value / slope;
        x = if next > low && next < high { next } else { low + 0.5 * (high - low) };
    }
    // A bracket [a, b] of `[lo, hi]` about `x` where it holds at `a` and not at `b`.
    let (floor, ceiling) = (lo.to_bits(), hi.to_bits());
    let start = x.clamp(lo, hi).to_bits();
    let (mut a, mut b, mut width) = (start, start, 1u64);
    if holds(f64::from_bits(start)) {
        loop {
            b = (a + width).min(ceiling);
            if !holds(f64::from_bits(b)) {
                break;
            }
            (a, width) = (b, 2 * width);
        }
    } else {
        loop {
            a = b.saturating_sub(width).max(floor);
            if a == b || holds(f64::from_bits(a)) {
                break;
            }
            (b, width) = (a, 2 * width);
        }
    }
    while b - a > 1 {
        let mid = a + (b - a) / 2;
        if holds(f64::from_bits(mid)) {
            a = mid;
        } else {
            b = mid;
        }
    }
    Some(f64::from_bits(b))
}

/// Scales the relative path so that R and the acceleration are near 1: lengths by `2^-l`, times
/// by `2^-k`; returns it with `k`, the exponent a time found in it is scaled back by.
fn scaled(offset: DVec3, velocity: DVec3, acceleration: DVec3, radius_sum: f64) -> (Bent, i32) {
    let length = exponent(radius_sum);
    let time = (length - exponent(acceleration.abs().max_element())).div_euclid(2);
    let bent = Bent {
        offset: offset * power_of_two(-length),
        velocity: velocity * power_of_two((time - length).clamp(-1022, 1022)),
        acceleration: acceleration * power_of_two((2 * time - length).clamp(-1022, 1022)),
        radius_sq: (radius_sum * power_of_two(-length)).powi(2),
    };
    (bent, time)
}

/// Time `tau >= 0` after the reference instant at which two spheres, `offset` apart (the second's
/// centre minus the first's) with `relative_velocity` and a non-zero `relative_acceleration`
/// there, first touch while approaching, if they ever do: a pair touching at the reference and
/// parting touches again when it comes back, or where the pull turns it back before it parts.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::falling::falling_sphere_time;
/// // A unit ball dropped from rest 3 above a resting one (R = 2) under g = 2: the gap of 1
/// // closes after sqrt(2 * 1 / 2) = 1 (to the float where the rounded gap first reaches zero).
/// let tau = falling_sphere_time(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::new(0.0, 0.0, -2.0), 2.0);
/// assert!((tau.unwrap() - 1.0).abs() <= f64::EPSILON);
/// // Thrown sideways fast enough, it misses.
/// let tau = falling_sphere_time(DVec3::new(0.0, 0.0, 3.0), DVec3::new(9.0, 0.0, 0.0), DVec3::new(0.0, 0.0, -2.0), 2.0);
/// assert_eq!(tau, None);
/// ```
pub fn falling_sphere_time(
    offset: DVec3,
    relative_velocity: DVec3,
    relative_acceleration: DVec3,
    radius_sum: f64,
) -> Option<f64> {
    let (bent, time) = scaled(offset, relative_velocity, relative_acceleration, radius_sum);
    let gap = bent.gap(0.0);
    if !gap.is_finite() {
        return None;
    }
    let mut apart = gap > 0.0;
    if !apart {
        let touching = gap >= -2.0 * CONTACT_TOLERANCE * bent.radius_sq;
        if !touching || approaching_at_reference(&bent) {
            return touching.then_some(0.0);
        }
    }
    // The gap is monotone between turning points: the first piece, once apart, that ends at or
    // below zero holds the contact. Touching and parting, the pair touches again where its gap
    // turns back if it never opened (a bounce too slow for the pull), or where it closes again.
    let (turns, count) = bent.turning_points();
    let mut lo = 0.0;
    for &hi in &turns[..count] {
        let ends_apart = bent.gap(hi) > 0.0;
        if apart && !ends_apart {
            let tau = first_change(lo, hi, |tau| bent.gap_and_slope(tau))?;
            return finite(scale_by_power_of_two(tau, time));
        }
        if !apart && !ends_apart && bent.rate(lo + 0.5 * (hi - lo)) > 0.0 {
            return finite(scale_by_power_of_two(hi, time));
        }
        apart = ends_apart;
        lo = hi;
    }
    // After the last turning point the gap only grows.
    None
}

/// The first and the last time `tau >= 0` at which two spheres, `offset` apart (the second's
/// centre minus the first's) with `relative_velocity` and a non-zero `relative_acceleration`
/// there, are at most `radius_sum` apart, if they ever are (between the two they may part and
/// meet again). Each is the first float past its root at which the rounded gap has changed sign,
/// a function of the arguments alone; the caller's `radius_sum` holds a margin for the rounding.
///
/// ```
/// use glam::DVec3;
/// use vadop::narrow_phase::falling::bent_reach;
/// // Dropped from rest 3 above a ball it falls past (R = 2) under g = 2: within reach from
/// // tau = 1 (fallen 1) to tau = sqrt(5) (fallen 5).
/// let (enter, leave) = bent_reach(DVec3::new(0.0, 0.0, 3.0), DVec3::ZERO, DVec3::new(0.0, 0.0, -2.0), 2.0).unwrap();
/// assert!((enter - 1.0).abs() < 1e-12 && (leave - 5f64.sqrt()).abs() < 1e-12, "{enter} {leave}");
/// ```
pub fn bent_reach(
    offset: DVec3,
    relative_velocity: DVec3,
    relative_acceleration: DVec3,
    radius_sum: f64,
) -> Option<(f64, f64)> {
    let (bent, time) = scaled(offset, relative_velocity, relative_acceleration, radius_sum);
    let within = |tau: f64| !(bent.gap(tau) > 0.0);
    if !bent.gap(0.0).is_finite() {
        return None;
    }
    let gap = |tau: f64| bent.gap_and_slope(tau);
    // The gap is monotone between turning points and grows for good after the last: each piece
    // that starts apart and ends within holds an entry, each that starts within and ends apart
    // an exit.
    let (turns, count) = bent.turning_points();
    let (mut enter, mut leave) = (within(0.0).then_some(0.0), None);
    let mut lo = 0.0;
    for &hi in &turns[..count] {
        match (within(lo), within(hi)) {
            (false, true) => enter = enter.or_else(|| first_change(lo, hi, gap)),
            (true, false) => leave = first_change(lo, hi, gap),
            _ => {}
        }
        lo = hi;
    }
    if within(lo) {
        // The last piece leaves: bracket its exit by doubling.
        let mut hi = 2.0 * lo.max(1.0);
        for _ in 0..64 {
            if !within(hi) {
                break;
            }
            hi *= 2.0;
        }
        leave = if within(hi) { Some(f64::INFINITY) } else { first_change(lo, hi, gap) };
    }
    let back = |tau: f64| scale_by_power_of_two(tau, time);
    Some((back(enter?), leave.map_or(f64::INFINITY, back)))
}

/// Whether two spheres on motions `a` and `b` under the accelerations `ga` and `gb` may touch
/// within `window`: false only when their centres stay farther apart than `radius_sum` all
/// through it, by a margin far above rounding, so that their canonical time
/// ([`falling_sphere_time`]), if any, lies past it. A bound on how far the relative path can go
/// from the window's start: it spares the quartic the many candidate pairs of a falling body
/// among bodies at rest that cannot meet in the window.
pub(crate) fn may_touch_within(a: &Motion, ga: DVec3, b: &Motion, gb: DVec3, radius_sum: f64, window: Window) -> bool {
    let from = window.start.max(a.since).max(b.since);
    let span = window.end - from;
    if !(span >= 0.0) {
        return span.is_nan();
    }
    let offset = b.at_under(from, gb) - a.at_under(from, ga);
    let velocity = b.velocity_under(from, gb) - a.velocity_under(from, ga);
    let reach = span * (velocity.length() + 0.5 * span * (gb - ga).length());
    let distance = offset.length();
    !(distance - reach > radius_sum * (1.0 + 1e-6) + 1e-9 * distance)
}

/// At the reference a touching pair approaches when its gap shrinks, or, with no relative
/// velocity to speak of, when the pull brings it together.
fn approaching_at_reference(bent: &Bent) -> bool {
    let (d, w, c) = (bent.offset, bent.velocity, bent.acceleration);
    let threshold = APPROACH_TOLERANCE * (d.length_squared() * w.length_squared()).sqrt();
    let approach = d.dot(w);
    approach < -threshold || (approach <= threshold && w.length_squared() + d.dot(c) < 0.0)
}

fn finite(tau: f64) -> Option<f64> {
    tau.is_finite().then_some(tau)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first sampled time at which the gap is at most zero while shrinking: an independent
    /// oracle, fine enough for the tests' paths.
    fn sampled(d: DVec3, w: DVec3, c: DVec3, r: f64, until: f64) -> Option<f64> {
        let steps = 2_000_000;
        let gap = |t: f64| (d + t * w + 0.5 * t * t * c).length() - r;
        (0..=steps).map(|k| until * k as f64 / steps as f64).find(|&t| gap(t) <= 0.0)
    }

    #[test]
    fn agrees_with_a_sampled_oracle_on_random_bent_paths() {
        let mut seed = 7u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..300 {
            let d = DVec3::new(next(), next(), next()) * 4.0;
            let w = -0.4 * d + DVec3::new(next(), next(), next()) * 1.5;
            let c = DVec3::new(next() * 0.1, next() * 0.1, -1.0 - next().abs());
            let r = 1.0 + next().abs();
            if d.length() <= r {
                continue;
            }
            let found = falling_sphere_time(d, w, c, r);
            match (found, sampled(d, w, c, r, 20.0)) {
                (Some(t), Some(s)) => {
                    hits += 1;
                    assert!((t - s).abs() <= 2e-5, "{t} vs sampled {s}");
                    let gap = (d + t * w + 0.5 * t * t * c).length() - r;
                    assert!(gap.abs() <= 1e-12, "gap {gap} at the root");
                }
                (None, None) => misses += 1,
                // Found beyond the oracle's horizon.
                (Some(t), None) => assert!(t > 20.0, "{t}"),
                (None, Some(s)) => panic!("missed a contact at {s}: {d} {w} {c} {r}"),
            }
        }
        assert!(hits > 50 && misses > 20, "{hits} hits, {misses} misses");
    }

    #[test]
    fn a_ball_let_go_on_a_resting_one_is_approaching() {
        // Touching from above, no relative velocity, pulled down: a contact now.
        let g = DVec3::new(0.0, 0.0, -9.81);
        let now = falling_sphere_time(DVec3::new(0.0, 0.3, 1.9), DVec3::ZERO, g, (0.09f64 + 3.61).sqrt());
        assert!(now.is_some_and(|t| t < 1e-7), "{now:?}");
        assert_eq!(falling_sphere_time(DVec3::new(0.0, 0.0, 2.0), DVec3::ZERO, g, 2.0), Some(0.0));
        // Beside it, pulled along the surface and away: not.
        assert_eq!(falling_sphere_time(DVec3::new(2.0, 0.0, 0.0), DVec3::ZERO, g, 2.0), None);
        // Below it, pulled away: not.
        assert_eq!(falling_sphere_time(DVec3::new(0.0, 0.0, -2.0), DVec3::ZERO, g, 2.0), None);
    }

    #[test]
    fn a_ball_bouncing_off_a_resting_one_falls_back_onto_it() {
        // Touching, parting upwards at 1 under g = 2: back after 1.
        let g = DVec3::new(0.0, 0.0, -2.0);
        let tau = falling_sphere_time(DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.0, 0.0, 1.0), g, 2.0).unwrap();
        assert!((tau - 1.0).abs() < 1e-15, "{tau}");
        // Deep inside each other: no new contact.
        assert_eq!(falling_sphere_time(DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, 1.0), g, 2.0), None);
    }

    #[test]
    fn a_ball_thrown_up_past_a_resting_one_falls_back_onto_it() {
        // Beside and below, thrown up and over: the gap shrinks, grows, and shrinks again.
        let g = DVec3::new(0.0, 0.0, -1.0);
        let (d, w) = (DVec3::new(2.0, 0.0, -2.0), DVec3::new(-0.5, 0.0, 3.0));
        let t = falling_sphere_time(d, w, g, 1.0).expect("lands");
        let s = sampled(d, w, g, 1.0, 20.0).unwrap();
        assert!((t - s).abs() < 1e-5, "{t} vs {s}");
        let p = d + t * w + 0.5 * t * t * g;
        assert!(p.z > 0.0 && (p.length() - 1.0).abs() < 1e-12, "lands on top: {p}");
    }

    #[test]
    fn scaling_by_powers_of_two_scales_the_time_exactly() {
        let (d, w, c) = (DVec3::new(0.5, 0.25, 3.0), DVec3::new(0.125, 0.0, -0.5), DVec3::new(0.0, 0.0, -2.0));
        let unit = falling_sphere_time(d, w, c, 1.5).unwrap();
        for k in [-40, -8, 8, 40] {
            // Lengths times 4^k, times 2^k: velocities 2^k, accelerations the same.
            let (l, s) = (2f64.powi(2 * k), 2f64.powi(k));
            let t = falling_sphere_time(d * l, w * s, c, 1.5 * l).unwrap();
            assert_eq!(t, unit * s, "2^{k}");
        }
    }
}
