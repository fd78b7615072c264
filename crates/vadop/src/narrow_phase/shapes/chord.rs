//! Chord certificates: how long two turning shapes certainly stay within a distance of each
//! other, from a point fixed in one body followed through the other's signed distance function,
//! its path predicted to first order from the bodies' actual velocities and angular velocities.
//!
//! For any point p, `sd(A, B) <= σ_A(p) + σ_B(p)`, σ being a shape's signed distance from a
//! point (a ball about p as deep as it lies in one shape, or the nearest point of each, shows
//! it). Fix p in B: `σ_B(p)` stays what it is, and in A's frame p follows a smooth path `P(s)`,
//! within `s²/2 sup|P''|` of the line `P0 + s P1` that the velocities at the probe give, the rest
//! bounded from the spins' bounds on angular speed and acceleration. `σ_A` is 1-Lipschitz, and
//! convex, so along the line below its chord: over `[0, S]` it stays at most the chord plus the
//! remainder `M t² / 2`, a convex function of t, at most the larger of `σ_A(P0)` and
//! `σ_A(P0 + S P1) + M S² / 2`. Where the rate bound moves every point at its worst and the steps
//! shrink with the room left (a contact's end approached like Zeno's arrow), the chord follows the
//! actual rate at which p leaves A, and sliding along a flat or round surface costs nothing to
//! first order.
//!
//! It owns that certificate only; it never measures the shapes' distance or chooses a probe time.

use super::scaled::{Scaled, Turning};
use super::SLACK;
use glam::DVec3;
use parry3d_f64::math::Pose;
use parry3d_f64::shape::SupportMap;

/// A body at a probe time as the certificate reads it, in the probe's frame (world axes, scaled
/// lengths): its shape and the shape's pose, its centre of mass, how far the shape reaches from
/// it, its velocity and its turning.
pub(super) struct Moving<'s, 'a> {
    pub(super) shape: &'s Scaled<'a>,
    pub(super) pose: &'s Pose,
    pub(super) centre: DVec3,
    pub(super) radius: f64,
    pub(super) velocity: DVec3,
    pub(super) turning: Turning,
}

/// Relative allowance for the rounding of an evaluated angular velocity.
const OMEGA_ROUNDING: f64 = 1e-12;

/// What a hold over `[0, s]` allows for rounding: the probe's `slack`, [`SLACK`] of the way its
/// first-order part moves at `rate`, and [`OMEGA_ROUNDING`] of the way its points move at `turned`
/// (each evaluated angular speed times the lever it turns).
#[inline]
fn rounding(slack: f64, rate: f64, turned: f64, s: f64) -> f64 {
    slack + SLACK * s * rate + OMEGA_ROUNDING * turned * s
}

/// Far ends of the chord tried per certificate.
const TRIALS: usize = 4;

/// The longest time found (in a few trials of the chord's far end) over which the signed
/// distance of the two shapes certainly stays at most `level`, from the point `p` fixed in
/// `own` followed through `other`'s signed distance; 0 when the chord does not even hold now.
/// `slack` covers the rounding of the probe's frame and coordinates. `signed`: p's signed
/// distances from `own`'s shape and from `other`'s when the caller has them (a point inside both
/// whose depths it measured, to the bit what [`Scaled::signed_distance_above`] gives there).
pub(super) fn chord_hold(
    p: DVec3,
    signed: Option<(f64, f64)>,
    own: &Moving,
    other: &Moving,
    level: f64,
    slack: f64,
) -> f64 {
    let lever = p - own.centre;
    let reach = p - other.centre;
    let relative = own.velocity - other.velocity;
    // p's velocity relative to `other`'s centre, then in `other`'s turning frame.
    let moving = relative + own.turning.omega.cross(lever);
    let start = other.pose.inverse_transform_point(p);
    let heading = other.pose.rotation.inverse() * (moving - other.turning.omega.cross(reach));
    let (own_depth, near) = signed.unwrap_or_else(|| {
        (own.shape.signed_distance_above(own.pose.inverse_transform_point(p)), other.shape.signed_distance_above(start))
    });
    let (w_own, w_other) = (own.turning.speed, other.turning.speed);
    // |d/ds (p - other's centre)| at every time, and |P''| over [0, s]: p's own turning, the
    // frame's turning of p's offset, and twice the frame's turning of p's velocity (Coriolis).
    let drift = relative.length() + w_own * lever.length();
    let curvature = |s: f64| {
        (own.turning.acceleration + w_own * w_own) * lever.length()
            + (other.turning.acceleration + w_other * w_other) * (reach.length() + s * drift)
            + 2.0 * w_other * drift
    };
    let turned = w_own * lever.length() + w_other * reach.length();
    // Along [0, s] the path is within `curvature(s) t² / 2` of the line at time t, and σ on the
    // line below its chord: their sum is convex in t, at most its larger end.
    let bound = |s: f64, far: f64| {
        near.max(far + 0.5 * curvature(s) * s * s) + own_depth + rounding(slack, heading.length(), turned, s)
    };
    let room = level - bound(0.0, near);
    if !(room > 0.0) {
        return 0.0;
    }
    longest(room, heading.length(), curvature, |s| {
        let far = other.shape.signed_distance_above(start + heading * s);
        (bound(s, far) - level, far - near)
    })
}

/// [`chord_hold`] for a point `p` inside both shapes that slides through `own` along the straight
/// line `drift` (a velocity in `own`'s frame, in world axes at the probe) instead of staying fixed
/// in it: where two edges or faces cross at speed, the region inside both slides along each, and a
/// point sliding with it stays inside both for as long as the features cross, where a point fixed
/// in either leaves the other at once. In `own`'s frame the path is a line, along which its signed
/// distance is convex; in `other`'s it bends by both turnings at most (`|P''| <= (alpha_o + w_o²)
/// |q| + 2 w_o |q'| + |p''|`, `q` its offset from `other`'s centre, and `|p''| <= (alpha + w²) |r|
/// + 2 w |drift|` from `own`'s turning of the sliding point at `r` from its centre). The sum of
/// the two signed distances with that rest is convex over `[0, S]`: at most the larger of its ends.
pub(super) fn sliding_hold(
    (p, signed): (DVec3, Option<(f64, f64)>),
    drift: DVec3,
    own: &Moving,
    other: &Moving,
    level: f64,
    slack: f64,
) -> f64 {
    let lever = p - own.centre;
    let reach = p - other.centre;
    let (w_own, w_other) = (own.turning.speed, other.turning.speed);
    // p's world velocity, then relative to `other`'s centre in `other`'s turning frame.
    let moving = own.velocity + own.turning.omega.cross(lever) + drift;
    let start_own = own.pose.inverse_transform_point(p);
    let heading_own = own.pose.rotation.inverse() * drift;
    let start = other.pose.inverse_transform_point(p);
    let relative = moving - other.velocity;
    let heading = other.pose.rotation.inverse() * (relative - other.turning.omega.cross(reach));
    let depth = |s: f64| {
        own.shape.signed_distance_above(start_own + heading_own * s)
            + other.shape.signed_distance_above(start + heading * s)
    };
    let near = signed.map_or_else(|| depth(0.0), |(own, other)| own + other);
    let slide = drift.length();
    let curvature = |s: f64| {
        let own_bend = (own.turning.acceleration + w_own * w_own) * (lever.length() + s * slide) + 2.0 * w_own * slide;
        let speed = relative.length() + s * own_bend;
        own_bend
            + (other.turning.acceleration + w_other * w_other) * (reach.length() + s * speed)
            + 2.0 * w_other * speed
    };
    let speed = heading_own.length() + heading.length();
    let turned = w_own * lever.length() + w_other * reach.length();
    let bound = |s: f64, far: f64| near.max(far + 0.5 * curvature(s) * s * s) + rounding(slack, speed, turned, s);
    let room = level - bound(0.0, near);
    if !(room > 0.0) {
        return 0.0;
    }
    longest(room, speed, curvature, |s| {
        let far = depth(s);
        (bound(s, far) - level, far - near)
    })
}

/// The longest time found over which the distance along the unit axis `m`, fixed in `with`
/// and pointing towards `other`, between the planes touching the two shapes (their separation
/// along it, a lower bound on their distance) certainly stays above `level`; 0 when not even now.
///
/// With the axis turning with its body, that body's support along it stays what it is; the
/// offset of the centres along the axis and the other's support along it follow the velocities
/// at the probe to first order. The first is linear and the support function convex along the
/// line of directions, so their difference is concave, above its chord, and so is that less
/// the second-order rest `M t² / 2`: over `[0, S]` it stays above the smaller of its ends.
pub(super) fn axis_hold(m: DVec3, with: &Moving, other: &Moving, level: f64, slack: f64) -> f64 {
    let own = support(with.shape, with.pose, with.centre, m);
    let frame = Frame { centre: with.centre, velocity: with.velocity, turning: with.turning };
    turned_axis_hold(m, own, &frame, other, level, slack)
}

/// [`axis_hold`] for a wall of the box, which neither moves nor turns: how long `body` certainly
/// stays farther than `level` from the plane through `on_wall` with the outward unit normal `n`.
pub(super) fn wall_hold(n: DVec3, on_wall: DVec3, body: &Moving, level: f64, slack: f64) -> f64 {
    let still = Turning { omega: DVec3::ZERO, speed: 0.0, acceleration: 0.0 };
    // The wall's support along the axis into the box, from a point on it, is 0.
    turned_axis_hold(-n, 0.0, &Frame { centre: on_wall, velocity: DVec3::ZERO, turning: still }, body, level, slack)
}

/// The body an axis turns with, in the probe's frame, without its shape: its support along the
/// axis is measured once.
struct Frame {
    centre: DVec3,
    velocity: DVec3,
    turning: Turning,
}

/// How far `shape` at `pose` reaches along the unit `direction` from `centre`.
fn support(shape: &Scaled, pose: &Pose, centre: DVec3, direction: DVec3) -> f64 {
    direction.dot(shape.support_point(pose, direction) - centre)
}

/// [`axis_hold`] with the support `own` along `m` of the body turning with `m` given.
fn turned_axis_hold(m: DVec3, own: f64, with: &Frame, other: &Moving, level: f64, slack: f64) -> f64 {
    let offset = other.centre - with.centre;
    let relative = other.velocity - with.velocity;
    let (w_with, w_other) = (with.turning.speed, other.turning.speed);
    let turn = (other.turning.omega - with.turning.omega).cross(m);
    let (along, along_rate) = (m.dot(offset), m.dot(relative) + with.turning.omega.cross(m).dot(offset));
    // The gap without its own support: the offset along the axis less the other's support
    // along the reversed axis turned to first order (`-m + s turn` in the probe's frame).
    let gap = |s: f64| along + along_rate * s - support(other.shape, other.pose, other.centre, turn * s - m);
    let near = gap(0.0);
    // |d²/ds²| of the offset along the turning axis, and the other's radius times the second
    // derivative of the axis seen from the other body.
    let radius = other.radius;
    let curvature = |s: f64| {
        (with.turning.acceleration + w_with * w_with) * (offset.length() + s * relative.length())
            + 2.0 * w_with * relative.length()
            + radius * (with.turning.acceleration + other.turning.acceleration + (w_with + w_other).powi(2))
    };
    let rate = along_rate.abs() + turn.length() * radius;
    let turned = w_with * offset.length() + (w_with + w_other) * radius;
    // Concave in t over [0, s] (the gap on the line above its chord, less the rest): at least
    // its smaller end.
    let bound = |s: f64, far: f64| near.min(far - 0.5 * curvature(s) * s * s) - own - rounding(slack, rate, turned, s);
    let room = bound(0.0, near) - level;
    if !(room > 0.0) {
        return 0.0;
    }
    longest(room, rate, curvature, |s| {
        let far = gap(s);
        (level - bound(s, far), near - far)
    })
}

/// The longest time s found in [`TRIALS`] trials at which `excess(s)` (how far a bound over
/// `[0, s]` is beyond its level, with how far the first-order part moved towards it) is at most
/// 0, `room` being how far it is within at 0, `speed` a bound on how fast the first-order part
/// moves and `curvature(s)` its second-order coefficient over `[0, s]`: a first trial on the
/// speed, then trials on the slope the first-order part actually took, and once one fails, the
/// chord of the excess between the longest that held and the shortest that failed (the excess
/// is convex in s, so that holds too unless rounding says otherwise). Every trial is checked;
/// the longest that held is kept.
fn longest(room: f64, speed: f64, curvature: impl Fn(f64) -> f64, excess: impl Fn(f64) -> (f64, f64)) -> f64 {
    let mut held = (0.0, -room);
    let mut failed: Option<(f64, f64)> = None;
    let (mut slope, mut bend) = (speed, curvature(0.0));
    for _ in 0..TRIALS {
        let s = match failed {
            Some((high, over)) => held.0 + (high - held.0) * (-held.1 / (over - held.1)),
            None => step_within(room, slope, bend),
        };
        if !(s > held.0 && s.is_finite()) {
            break;
        }
        let (over, moved) = excess(s);
        if over <= 0.0 {
            (slope, bend) = ((moved / s).max(0.0), curvature(2.0 * s));
            held = (s, over);
        } else {
            failed = Some((s, over));
        }
    }
    held.0
}

/// The time s at which `slope s + m s² / 2` reaches `room` (infinite when neither term grows).
fn step_within(room: f64, slope: f64, m: f64) -> f64 {
    let root = (slope * slope + 2.0 * m * room).sqrt();
    2.0 * room / (slope + root)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::{FreeRotation, RigidMotion};
    use crate::narrow_phase::shapes::scaled::Body;
    use crate::shape::ShapeGeometry;
    use glam::DQuat;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Two tumbling solids of every kind pair near each other, at a random time of their motions.
    struct Case {
        geometry: [ShapeGeometry; 2],
        motion: [RigidMotion<FreeRotation>; 2],
        tau: f64,
    }

    fn random_vector(rng: &mut ChaCha8Rng, size: f64) -> DVec3 {
        DVec3::new(rng.random_range(-size..size), rng.random_range(-size..size), rng.random_range(-size..size))
    }

    fn random_case(rng: &mut ChaCha8Rng, k: usize) -> Case {
        let shapes = crate::shape::one_solid_of_each_kind();
        let geometry = [shapes[k % 6].geometry().unwrap(), shapes[(k / 6) % 6].geometry().unwrap()];
        let reach = geometry[0].size() + geometry[1].size();
        let offset = random_vector(rng, 1.0).normalize_or(DVec3::X) * reach * rng.random_range(0.2..1.0);
        let tau = rng.random_range(0.0..2.0);
        let motion = [DVec3::ZERO, offset].map(|at| {
            let turn = DQuat::from_scaled_axis(random_vector(rng, 3.0));
            let velocity = random_vector(rng, 3.0);
            // Fast tumbles about every axis, the world's exact torque-free rotation.
            let spin = FreeRotation::new(DVec3::ONE, turn, random_vector(rng, 12.0));
            RigidMotion { position: at - velocity * tau, since: 0.0, velocity, acceleration: DVec3::ZERO, spin }
        });
        let motion = [0, 1].map(|i| RigidMotion {
            spin: FreeRotation::new(
                geometry[i].principal_inertia_unit(),
                motion[i].spin.orientation_at(0.0),
                motion[i].spin.angular_velocity_at(0.0),
            ),
            ..motion[i]
        });
        Case { geometry, motion, tau }
    }

    /// The bodies of a case and their shapes' poses at `tau + s` (unscaled).
    fn posed(case: &Case, s: f64) -> [(Body<'_>, Pose, DVec3); 2] {
        [0, 1].map(|i| {
            let body = Body::new(&case.geometry[i], &case.motion[i], 0.0);
            let t = case.tau + s;
            let centre = body.position + body.velocity * t;
            let pose = body.pose(body.orientation(t), centre, 1.0);
            (body, pose, centre)
        })
    }

    /// Runs `check` on the two bodies of `case` at its time as the certificates read them, a's
    /// first for even `k`, b's for odd, with the index of the first.
    fn in_either_order(case: &Case, k: usize, check: impl FnOnce(&Moving, &Moving, usize)) {
        let [(body_a, pose_a, centre_a), (body_b, pose_b, centre_b)] = posed(case, 0.0);
        let shapes = [0, 1].map(|i| Scaled::new(&case.geometry[i], 1.0));
        let moving_a = moving(&body_a, &shapes[0], &pose_a, centre_a, case.tau);
        let moving_b = moving(&body_b, &shapes[1], &pose_b, centre_b, case.tau);
        if k.is_multiple_of(2) {
            check(&moving_a, &moving_b, 0)
        } else {
            check(&moving_b, &moving_a, 1)
        }
    }

    fn moving<'s, 'a>(
        body: &Body<'a>,
        shape: &'s Scaled<'a>,
        pose: &'s Pose,
        centre: DVec3,
        tau: f64,
    ) -> Moving<'s, 'a> {
        let turning = body.turning(tau).unwrap();
        Moving { shape, pose, centre, radius: body.geometry.size(), velocity: body.velocity, turning }
    }

    /// Over the time `chord_hold` gives, the point fixed in one tumbling body stays, in the
    /// other's signed distance plus its own depth, at most the level asked: sampled along the
    /// bodies' exact motions, for every kind pair, points inside both shapes, on either
    /// surface and off both, and rooms from a millionth to a tenth of the pair's size. And the
    /// chord goes farther than stepping at the worst-case rate would in most cases.
    #[test]
    fn the_chord_bounds_the_signed_distance_along_the_exact_motion() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let (mut checked, mut farther) = (0, 0);
        for k in 0..1500 {
            let case = random_case(&mut rng, k);
            in_either_order(&case, k, |own, other, own_index| {
                // A point of the own shape's surface, or a random point near both.
                let p = if k % 3 == 0 {
                    own.shape.support_point(own.pose, random_vector(&mut rng, 1.0))
                } else {
                    (own.centre + other.centre) * 0.5 + random_vector(&mut rng, 0.3)
                };
                let depth = own.shape.signed_distance_above(own.pose.inverse_transform_point(p));
                let start = other.shape.signed_distance_above(other.pose.inverse_transform_point(p));
                let size = case.geometry[0].size() + case.geometry[1].size();
                let level = start + depth + size * 10f64.powf(rng.random_range(-6.0..-1.0));
                let held = chord_hold(p, None, own, other, level, 1e-15);
                if held == 0.0 {
                    return;
                }
                checked += 1;
                let worst = (level - start - depth)
                    / ((own.velocity - other.velocity).length()
                        + own.turning.speed * own.radius.max((p - own.centre).length())
                        + other.turning.speed * (p - other.centre).length());
                farther += (held > worst) as usize;
                // p fixed in its body, followed along the exact motions.
                let in_own = own.pose.inverse_transform_point(p);
                for i in 1..=64 {
                    let s = held * i as f64 / 64.0;
                    let poses = posed(&case, s);
                    let p_then = poses[own_index].1 * in_own;
                    let other_pose = poses[1 - own_index].1;
                    let reached = other.shape.signed_distance_above(other_pose.inverse_transform_point(p_then)) + depth;
                    assert!(reached <= level + 1e-12, "case {k} at {s} of {held}: {reached} above {level}");
                }
            });
        }
        assert!(checked > 1000, "only {checked} cases held");
        assert!(farther * 2 > checked, "the chord went farther than the worst-case rate in {farther} of {checked}");
    }

    /// Over the time `sliding_hold` gives, a point sliding along a straight line through one
    /// tumbling body keeps the sum of its signed distances from both shapes at most the level
    /// asked: sampled along the bodies' exact motions, for every kind pair, points near both and
    /// slides from none to the pair's speed.
    #[test]
    fn the_sliding_point_bounds_the_signed_distance_along_the_exact_motion() {
        let mut checked = 0;
        each_case(23, |rng, case, k, own, other, own_index| {
            let p = (own.centre + other.centre) * 0.5 + random_vector(rng, 0.3);
            let drift = random_vector(rng, 1.0) * (own.velocity - other.velocity).length();
            let sum = |in_own: DVec3, world: DVec3, other_pose: &Pose| {
                own.shape.signed_distance_above(in_own)
                    + other.shape.signed_distance_above(other_pose.inverse_transform_point(world))
            };
            let start = sum(own.pose.inverse_transform_point(p), p, other.pose);
            let size = case.geometry[0].size() + case.geometry[1].size();
            let level = start + size * 10f64.powf(rng.random_range(-6.0..-1.0));
            let held = sliding_hold((p, None), drift, own, other, level, 1e-15);
            if held == 0.0 {
                return;
            }
            checked += 1;
            // The point on its line through its own body, followed along the exact motions.
            let (in_own, along) = (own.pose.inverse_transform_point(p), own.pose.rotation.inverse() * drift);
            for i in 1..=64 {
                let s = held * i as f64 / 64.0;
                let poses = posed(case, s);
                let local = in_own + along * s;
                let reached = sum(local, poses[own_index].1 * local, &poses[1 - own_index].1);
                assert!(reached <= level + 1e-12, "case {k} at {s} of {held}: {reached} above {level}");
            }
        });
        assert!(checked > 1000, "only {checked} cases held");
    }

    /// Runs `check` on 1500 random cases drawn from `seed`, each in one order (see
    /// [`in_either_order`]), with the generator, the case and its index.
    fn each_case(seed: u64, mut check: impl FnMut(&mut ChaCha8Rng, &Case, usize, &Moving, &Moving, usize)) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for k in 0..1500 {
            let case = random_case(&mut rng, k);
            in_either_order(&case, k, |own, other, own_index| check(&mut rng, &case, k, own, other, own_index));
        }
    }

    /// Over the time `axis_hold` gives, the separation of two tumbling solids along an axis
    /// turning with one of them (their supports' planes, sampled along the exact motions) stays
    /// at least the level asked, for every kind pair, random axes and rooms.
    #[test]
    fn the_turning_axis_bounds_the_separation_along_the_exact_motion() {
        let mut rng = ChaCha8Rng::seed_from_u64(19);
        let mut checked = 0;
        for k in 0..1500 {
            let case = random_case(&mut rng, k);
            in_either_order(&case, k, |with, other, with_index| {
                let m = ((other.centre - with.centre).normalize() + random_vector(&mut rng, 0.3)).normalize();
                let separation = |poses: &[(Body, Pose, DVec3); 2], m: DVec3| {
                    let (w, o) = (&poses[with_index], &poses[1 - with_index]);
                    let support = |shape: &Scaled, pose: &Pose, u: DVec3| u.dot(shape.support_point(pose, u));
                    m.dot(o.2 - w.2) - support(with.shape, &w.1, m) + m.dot(w.2)
                        - support(other.shape, &o.1, -m)
                        - m.dot(o.2)
                };
                let now = posed(&case, 0.0);
                let size = case.geometry[0].size() + case.geometry[1].size();
                let level = separation(&now, m) - size * 10f64.powf(rng.random_range(-6.0..-1.0));
                let held = axis_hold(m, with, other, level, 1e-15);
                if held == 0.0 {
                    return;
                }
                checked += 1;
                let in_with = now[with_index].1.rotation.inverse() * m;
                for i in 1..=64 {
                    let s = held * i as f64 / 64.0;
                    let poses = posed(&case, s);
                    let gap = separation(&poses, poses[with_index].1.rotation * in_with);
                    assert!(gap >= level - 1e-12, "case {k} at {s} of {held}: {gap} below {level}");
                }
            });
        }
        assert!(checked > 1000, "only {checked} cases held");
    }

    /// Over the time `wall_hold` gives, a tumbling solid's distance from a wall (the plane less
    /// the solid's support towards it, sampled along the exact motion) stays at least the level
    /// asked, for every kind, random walls and rooms from a millionth of its size to its size.
    #[test]
    fn the_wall_hold_bounds_the_distance_along_the_exact_motion() {
        let mut rng = ChaCha8Rng::seed_from_u64(23);
        let mut checked = 0;
        for k in 0..1500 {
            let case = random_case(&mut rng, k);
            in_either_order(&case, k, |body, _, index| {
                let n = random_vector(&mut rng, 1.0).normalize_or(DVec3::X);
                let reach = |pose: &Pose, centre: DVec3| n.dot(body.shape.support_point(pose, n) - centre);
                let room = case.geometry[index].size() * 10f64.powf(rng.random_range(-6.0..0.0));
                let on_wall = body.centre + n * (reach(body.pose, body.centre) + room);
                let distance = |s: f64| {
                    let (_, pose, centre) = &posed(&case, s)[index];
                    n.dot(on_wall - *centre) - reach(pose, *centre)
                };
                let level = distance(0.0) - room * rng.random_range(0.0..1.0);
                let held = wall_hold(n, on_wall, body, level, 1e-15);
                if held == 0.0 {
                    return;
                }
                checked += 1;
                for i in 1..=64 {
                    let s = held * i as f64 / 64.0;
                    let d = distance(s);
                    assert!(d >= level - 1e-12, "case {k} at {s} of {held}: {d} below {level}");
                }
            });
        }
        assert!(checked > 1000, "only {checked} cases held");
    }
}
