//! The parting certificate: from a probe of two shapes in contact, whether their signed distance
//! grows from then on for good, so that no contact can follow the one in progress and a search
//! for the next contact start can stop there without finding where this one ends (the end search
//! was over half the shapes' narrow phase at 5 diameters per frame; a pass-through mostly needs
//! no end).
//!
//! The signed distance of two convex shapes is their largest separation over all axes, and
//! along a fixed axis n the separation changes at `n.v` give or take `spin` (v: b's velocity less
//! a's, on a straight relative path; `spin` bounds how fast turning moves either surface). Where
//! the probe's lower bound is the separation along an axis receding at `n.v > 3 spin`, that
//! separation gains at least `2 spin` per unit of time, and an axis receding slower than `spin`
//! (a *closing* one) gains at most that. So a closing axis whose separation is below the bound's
//! now stays below it for good, the largest separation is always taken on an axis receding faster
//! than turning can close it, and the distance strictly grows.
//!
//! Along any axis n the separation is at most `n.(y - x) - r_a - r_b` for balls of radii r about
//! x in a and y in b, whose largest over the closing axes has a closed form: the balls about the
//! shapes' middles, and balls about the witness points moved into their shapes along the relative
//! motion (a's behind, b's ahead), where a pair passing through still overlaps along it, or along
//! the bound's axis, where a grazing pass leaves a shape at a corner along the motion. Where the
//! balls cannot tell (a shallow grazing pass: a closing axis a little off the bound's, and the
//! balls deep inside), the separation along n is minus the support value of the shapes'
//! difference `a - b` along n, bounded below by a polytope of the difference's points grown
//! toward the closing axes that fail (see [`closing_supports_exceed`]).
//!
//! It owns that certificate only: it never chooses a probe time and never measures a distance.

use super::distance::Bounds;
use super::epa::closing_supports_exceed;
use super::gauges::{deepest_point, ConvexPair};
use super::gjk::Relative;
use glam::DVec3;
use parry3d_f64::math::Pose;

/// How far the witness points are moved into their shapes, in units of the probe's depth (or of
/// the tolerance, if more): the first is enough where the two still overlap along the motion
/// near the witnesses, the second where their nearest faces meet at a sharper angle.
const WITNESS_REACHES: [f64; 2] = [8.0, 32.0];

/// Whether the signed distance of `pair` at the poses of a probe with `bounds` grows from there
/// on for good (see the [module documentation](self)); `slack` covers the rounding of the
/// probe's frame.
pub(super) fn parts_for_good(pair: &ConvexPair, (pose_a, pose_b): (&Pose, &Pose), bounds: &Bounds, slack: f64) -> bool {
    let speed = pair.velocity.length();
    if pair.acceleration != DVec3::ZERO || !(bounds.axis.dot(pair.velocity) > 3.0 * pair.spin) {
        return false;
    }
    // Closing axes: `n.heading <= cap`, a third at most (`n.v > 3 spin` on the bound's axis).
    let (heading, cap) = (pair.velocity / speed, pair.spin / speed);
    let widest = |offset: DVec3| {
        let along = offset.dot(heading);
        if along <= cap * offset.length() {
            offset.length()
        } else {
            cap * along + (1.0 - cap * cap).sqrt() * (offset - heading * along).length()
        }
    };
    let below = |closing: f64| closing + 3.0 * slack < bounds.lower;
    if let (Some((middle_a, radius_a)), Some((middle_b, radius_b))) = pair.middles {
        if below(widest(*pose_b * middle_b - *pose_a * middle_a) - radius_a - radius_b) {
            return true;
        }
    }
    let Some((x, y)) = bounds.witness else { return false };
    let (ga, gb) = &pair.shapes;
    let balls = [heading, bounds.axis].into_iter().any(|inward| {
        WITNESS_REACHES.iter().any(|reach| {
            let reach = reach * bounds.lower.abs().max(pair.tol);
            let (x, y) = (x - inward * reach, y + inward * reach);
            let (depth_a, depth_b) =
                (ga.depth_only(pose_a.inverse_transform_point(x)), gb.depth_only(pose_b.inverse_transform_point(y)));
            depth_a > 0.0 && depth_b > 0.0 && below(widest(y - x) - depth_a - depth_b)
        })
    });
    if balls {
        return true;
    }
    // The shapes' support functions over the closing axes, from a ball about the origin inside
    // their difference: about a point inside both, the witnesses' midpoint or, where that lies
    // outside one, a point moved from it into both.
    let middle = 0.5 * (x + y);
    let (depth_a, depth_b) =
        (ga.depth_only(pose_a.inverse_transform_point(middle)), gb.depth_only(pose_b.inverse_transform_point(middle)));
    let inner = if depth_a >= 0.0 && depth_b >= 0.0 {
        Some(depth_a + depth_b)
    } else {
        deepest_point(&[middle], (ga, pose_a), (gb, pose_b)).map(|(depth, _)| depth)
    };
    let level = 3.0 * slack - bounds.lower;
    let Some(inner) = inner.filter(|_| level > 0.0) else { return false };
    // First the closing axis nearest the bound's, where the separation comes nearest it.
    let across = (bounds.axis - heading * bounds.axis.dot(heading))
        .try_normalize()
        .unwrap_or_else(|| heading.any_orthonormal_vector());
    let nearest = heading * cap + across * (1.0 - cap * cap).sqrt();
    let (relative, local) = (Relative::new(pose_a.inv_mul(pose_b)), pose_a.rotation.inverse());
    closing_supports_exceed(&relative, (ga, gb), inner, (local * heading, cap), level, local * nearest)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::{FreeRotation, RigidMotion};
    use crate::narrow_phase::shapes::gauges::PairGauge;
    use crate::narrow_phase::shapes::pair_searcher;
    use glam::DQuat;
    use rand::{Rng, SeedableRng};

    /// Wherever the certificate holds, the signed distance (converged bounds) never shrinks
    /// after it, on every pair of solid kinds passing through each other while tumbling, and it
    /// holds on a good share of them.
    #[test]
    fn the_distance_never_shrinks_after_a_parting_probe() {
        use crate::shape::Shape;
        // Every kind, and two rods, whose spin sweeps them back into the other.
        let rods = [
            Shape::Cuboid { half_extents: DVec3::new(0.9, 0.08, 0.08) },
            Shape::Capsule { half_height: 0.8, radius: 0.1 },
        ];
        let solids: Vec<_> =
            crate::shape::one_solid_of_each_kind().into_iter().chain(rods).map(|s| s.geometry().unwrap()).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
        let (mut certified, mut probed) = (0, 0);
        for case in 0..640 {
            let kinds = (case % 8, (case / 8) % 8);
            let mut random = |low: f64, high: f64| rng.random_range(low..high);
            let aim = DVec3::new(random(-0.5, 0.5), random(-0.5, 0.5), random(-0.5, 0.5));
            let speed = random(2.0, 60.0);
            let mut body = |kind: usize, position: DVec3| {
                let start =
                    DQuat::from_scaled_axis(DVec3::new(random(-3.0, 3.0), random(-3.0, 3.0), random(-3.0, 3.0)));
                let omega = DVec3::new(random(-30.0, 30.0), random(-30.0, 30.0), random(-30.0, 30.0));
                let spin = FreeRotation::new(solids[kind].principal_inertia_unit(), start, omega);
                RigidMotion { position, since: 0.0, velocity: DVec3::ZERO, acceleration: DVec3::ZERO, spin }
            };
            let a = body(kinds.0, DVec3::ZERO);
            // Through a from 3 units away, off its centre by up to half a unit: head on to grazing.
            let mut b = body(kinds.1, DVec3::new(3.0, 0.0, 0.0) + aim);
            b.velocity = DVec3::new(-speed, 0.0, 0.0);
            let searcher = pair_searcher((&solids[kinds.0], &a), (&solids[kinds.1], &b)).unwrap().unwrap();
            let PairGauge::Convex(pair) = &searcher.gauge else { unreachable!("two solids") };
            let Some(reach) = searcher.reach else { continue };
            let exact = |tau: f64| {
                let (pose_a, pose_b) = pair.poses(tau);
                let bounds = pair.exact_bounds((&pose_a, &pose_b));
                (bounds, pose_a, pose_b)
            };
            let steps = 64;
            let span = reach.leave - reach.enter;
            for k in 0..steps {
                let tau = reach.enter + span * (k as f64 + rng.random_range(0.0..1.0)) / steps as f64;
                let (bounds, pose_a, pose_b) = exact(tau);
                let slack = crate::narrow_phase::shapes::SLACK * (pose_b.translation.length() + pair.size);
                if bounds.lower > pair.tol {
                    continue;
                }
                probed += 1;
                if !parts_for_good(pair, (&pose_a, &pose_b), &bounds, slack) {
                    continue;
                }
                certified += 1;
                // From here to well past the bounding spheres' parting, finely sampled.
                let mut last = bounds.lower;
                for j in 1..=48 {
                    let later = tau + (reach.leave - tau) * 1.5 * j as f64 / 48.0;
                    let (next, _, _) = exact(later);
                    assert!(
                        next.upper >= last - 1e-9 * pair.size,
                        "case {case}: the distance shrank from {last} to {} after a parting probe at {tau}",
                        next.upper
                    );
                    last = last.max(next.lower);
                }
            }
        }
        assert!(certified > 300, "the certificate held at {certified} of {probed} probes in contact");
    }
}
