//! Collision response: the velocity change of an elastic (or partly inelastic) impact.
//!
//! It owns the impulse arithmetic only: between spheres (along the line of centres) and between
//! rigid bodies of any shape (at the contact point, with their inertia, restitution and Coulomb
//! friction). It never decides *when* bodies touch (narrow phase) nor what a velocity change
//! invalidates (world); both continuous methods and the pseudo-dynamic baseline call the same
//! functions.

use glam::{DMat3, DVec3};

/// Impulse magnitude along `normal` (unit, from body a to body b) that resolves an impact between
/// bodies with inverse masses `inv_mass_a`, `inv_mass_b` and restitution `restitution`.
/// Zero when the bodies are not approaching along the normal.
///
/// Apply it as `va -= j * inv_mass_a * normal`, `vb += j * inv_mass_b * normal`.
///
/// ```
/// use glam::DVec3;
/// use vadop::response::pair_impulse;
/// // Equal masses head-on with restitution 1 exchange velocities.
/// let j = pair_impulse(DVec3::X, DVec3::new(1.0, 0.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), 1.0, 1.0, 1.0);
/// assert_eq!(j, 2.0);
/// ```
#[inline]
pub fn pair_impulse(
    normal: DVec3,
    velocity_a: DVec3,
    velocity_b: DVec3,
    inv_mass_a: f64,
    inv_mass_b: f64,
    restitution: f64,
) -> f64 {
    let closing = (velocity_a - velocity_b).dot(normal);
    if closing <= 0.0 {
        return 0.0;
    }
    (1.0 + restitution) * closing / (inv_mass_a + inv_mass_b)
}

/// Velocity after bouncing off a wall orthogonal to coordinate `axis` (an infinitely heavy body).
#[inline]
pub fn wall_bounce(velocity: DVec3, axis: usize, restitution: f64) -> DVec3 {
    let mut v = velocity;
    v[axis] *= -restitution;
    v
}

/// One side of a contact between rigid bodies, as the impulse sees it at the instant of contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidSide {
    /// Velocity of the centre of mass.
    pub velocity: DVec3,
    /// Angular velocity, world frame.
    pub angular_velocity: DVec3,
    /// 0 for an immovable body (a wall, level geometry).
    pub inverse_mass: f64,
    /// Inverse inertia tensor in world axes at the contact instant; zero for an immovable body.
    pub inverse_inertia: DMat3,
    /// From the centre of mass to the contact point.
    pub arm: DVec3,
}

impl RigidSide {
    /// An immovable body: a wall or static level geometry.
    pub const FIXED: RigidSide = RigidSide {
        velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        inverse_mass: 0.0,
        inverse_inertia: DMat3::ZERO,
        arm: DVec3::ZERO,
    };

    /// Velocity of the body's material point at the contact.
    #[inline]
    pub fn point_velocity(&self) -> DVec3 {
        self.velocity + self.angular_velocity.cross(self.arm)
    }

    /// The side's share of the collision matrix: how the contact point's velocity answers an
    /// impulse, `w I - [r]x I^-1 [r]x`.
    #[inline]
    pub fn response(&self) -> DMat3 {
        let arm = skew(self.arm);
        DMat3::from_diagonal(DVec3::splat(self.inverse_mass)) - arm * self.inverse_inertia * arm
    }

    /// The velocities after an impulse `impulse` applied at the contact point.
    #[inline]
    pub fn after(&self, impulse: DVec3) -> (DVec3, DVec3) {
        (
            self.velocity + self.inverse_mass * impulse,
            self.angular_velocity + self.inverse_inertia * self.arm.cross(impulse),
        )
    }
}

/// The cross-product matrix: `skew(a) * b == a.cross(b)`.
#[inline]
fn skew(a: DVec3) -> DMat3 {
    DMat3::from_cols(DVec3::new(0.0, a.z, -a.y), DVec3::new(-a.z, 0.0, a.x), DVec3::new(a.y, -a.x, 0.0))
}

/// The impulse on body `b` (body `a` takes its opposite) of an impact at a contact with unit
/// `normal` from `a` to `b`, restitution `restitution` and Coulomb friction coefficient
/// `friction`; zero when the contact points are not approaching along the normal.
///
/// The normal part follows Newton's law: the contact points' normal relative velocity leaves at
/// `-restitution` times its arrival. Friction (Coulomb, algebraic form): the impulse that also
/// stops the tangential slip, if it lies in the friction cone; else sliding, along the
/// arrival slip opposed, at `friction` times the normal impulse. Newton's law with sliding
/// friction can, for some geometries, return more energy than it takes: such an impulse is
/// replaced by the frictionless one, so an impact never adds energy. With `restitution` 1 and no
/// friction, kinetic energy (linear and rotational) is conserved; momentum and angular momentum
/// always are.
///
/// ```
/// use glam::{DMat3, DVec3};
/// use vadop::response::{rigid_impulse, RigidSide};
/// // A unit cube (mass 1) moving at 1 onto a wall, hit off centre: it leaves spinning.
/// let inertia = 1.0 / 6.0;
/// let cube = RigidSide {
///     velocity: DVec3::X,
///     angular_velocity: DVec3::ZERO,
///     inverse_mass: 1.0,
///     inverse_inertia: DMat3::from_diagonal(DVec3::splat(1.0 / inertia)),
///     arm: DVec3::new(0.5, 0.5, 0.0),
/// };
/// let impulse = rigid_impulse(&cube, &RigidSide::FIXED, DVec3::X, 1.0, 0.0);
/// let (v, w) = cube.after(-impulse);
/// let energy = |v: DVec3, w: DVec3| 0.5 * v.length_squared() + 0.5 * inertia * w.length_squared();
/// assert!((energy(v, w) - 0.5).abs() < 1e-15);
/// assert!(w.z > 0.0 && v.x < 1.0);
/// ```
pub fn rigid_impulse(a: &RigidSide, b: &RigidSide, normal: DVec3, restitution: f64, friction: f64) -> DVec3 {
    let arrival = b.point_velocity() - a.point_velocity();
    let closing = arrival.dot(normal);
    if !(closing < 0.0) {
        return DVec3::ZERO;
    }
    let matrix = a.response() + b.response();
    let normal_weight = normal.dot(matrix * normal);
    if !(normal_weight > 0.0) {
        return DVec3::ZERO;
    }
    let frictionless = normal * (-(1.0 + restitution) * closing / normal_weight);
    if !(friction > 0.0) {
        return frictionless;
    }
    let slip = arrival - closing * normal;
    // Sticking: the tangential slip stopped and the normal velocity reversed by the restitution.
    let wanted = -(1.0 + restitution) * closing * normal - slip;
    let sticking = matrix.inverse() * wanted;
    let normal_part = sticking.dot(normal);
    let impulse = if (sticking - normal_part * normal).length() <= friction * normal_part {
        sticking
    } else {
        match crate::numeric::direction(slip) {
            Some(along) => {
                let direction = normal - friction * along;
                let weight = normal.dot(matrix * direction);
                if weight > 0.0 {
                    direction * (-(1.0 + restitution) * closing / weight)
                } else {
                    frictionless
                }
            }
            None => frictionless,
        }
    };
    // The kinetic energy an impulse J adds is J . u + J . K J / 2 (u the arrival velocity).
    let gained = impulse.dot(arrival) + 0.5 * impulse.dot(matrix * impulse);
    let frictionless_gained = frictionless.dot(arrival) + 0.5 * frictionless.dot(matrix * frictionless);
    if impulse.is_finite() && gained <= frictionless_gained.max(0.0) {
        impulse
    } else {
        frictionless
    }
}

/// A rigid body's motion as an impact changes it, about its centre of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impacted {
    pub velocity: DVec3,
    pub angular_velocity: DVec3,
    /// 0 for an immovable body.
    pub inverse_mass: f64,
    /// World axes, at the impact; zero for an immovable body.
    pub inverse_inertia: DMat3,
    pub centre: DVec3,
}

impl Impacted {
    /// An immovable body (a wall, level geometry).
    pub const FIXED: Impacted = Impacted {
        velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        inverse_mass: 0.0,
        inverse_inertia: DMat3::ZERO,
        centre: DVec3::ZERO,
    };

    /// The acceleration of the body's material point at `point` as it turns freely (the body
    /// keeps its angular momentum, so its angular velocity changes unless it spins about a
    /// principal axis): `dw/dt x r + w x (w x r)`.
    #[inline]
    pub fn point_acceleration(&self, point: DVec3) -> DVec3 {
        if self.inverse_mass == 0.0 {
            return DVec3::ZERO;
        }
        let (w, arm) = (self.angular_velocity, point - self.centre);
        let momentum = self.inverse_inertia.inverse() * w;
        let turning = self.inverse_inertia * momentum.cross(w);
        turning.cross(arm) + w.cross(w.cross(arm))
    }

    /// The body as one side of a contact at `point`.
    #[inline]
    pub fn side(&self, point: DVec3) -> RigidSide {
        RigidSide {
            velocity: self.velocity,
            angular_velocity: self.angular_velocity,
            inverse_mass: self.inverse_mass,
            inverse_inertia: self.inverse_inertia,
            arm: point - self.centre,
        }
    }
}

/// Sweeps over an impact's points at most this many times before it counts as unsettled.
pub const IMPACT_SWEEPS: usize = 256;

/// Resolves an impact of `a` and `b` touching at several `points` at once (a face or an edge on a
/// face), each with its unit normal from `a` to `b`, and returns the total normal impulse on `b`.
///
/// One point is [`rigid_impulse`]. Several are solved together, as simultaneous contacts:
/// accumulated impulses at each point, never pulling (projected Gauss-Seidel), until every point
/// leaves at least `restitution` times the speed it arrived with (Newton's law at each point) and
/// those that push leave at exactly that speed, with Coulomb friction at each point bounded by
/// `friction` times its normal impulse. A body landing flat stops flat (restitution 0) or leaves
/// as it came (restitution 1, which then keeps the energy exactly: every pushing point's normal
/// velocity is reversed). Should the iteration not settle within [`IMPACT_SWEEPS`] sweeps, or
/// end with more energy than it started with, it falls back to impulses point after point (each
/// one keeps or takes energy); `None` when points still approach after that too: a jammed
/// contact, for the caller's jam rule, with `a` and `b` as far as they got.
///
/// Turning bodies: a point left with no normal speed may still dip into the other body a moment
/// later, because the bodies turn (a box landing on an edge pivots about it). With restitution
/// below 1 such a point leaves with the least speed that keeps the dip within `clearance` (a
/// microcollision: `sqrt(2 a clearance)` for a normal acceleration `a` into the other body), so
/// the contact goes on as a train of small impacts, each taking energy, instead of a body sinking
/// through another. That speed adds at most the mass times `a clearance` of energy, far less than
/// the restitution takes; elastic impacts (restitution 1) never leave a point at rest, and get
/// no such speed.
///
/// ```
/// use glam::{DMat3, DVec3};
/// use vadop::response::{resolve_impact, Impacted};
/// // A unit cube (mass 1) falling flat at 1 onto the floor: its four bottom corners touch.
/// let cube = Impacted {
///     velocity: DVec3::new(0.0, 0.0, -1.0),
///     angular_velocity: DVec3::ZERO,
///     inverse_mass: 1.0,
///     inverse_inertia: DMat3::from_diagonal(DVec3::splat(6.0)),
///     centre: DVec3::new(0.0, 0.0, 0.5),
/// };
/// let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];
/// let points: Vec<(DVec3, DVec3)> = corners.iter().map(|&(x, y)| (DVec3::new(x, y, 0.0), DVec3::Z)).collect();
/// // Perfectly inelastic: it stops flat, without spinning.
/// let (mut floor, mut stopped) = (Impacted::FIXED, cube);
/// let impulse = resolve_impact(&mut floor, &mut stopped, &points, 0.0, 0.0, 1e-6).unwrap();
/// assert!((impulse - 1.0).abs() < 1e-9 && stopped.velocity.length() < 1e-9);
/// assert!(stopped.angular_velocity.length() < 1e-9);
/// // Elastic: it leaves straight up at the speed it came.
/// let (mut floor, mut bounced) = (Impacted::FIXED, cube);
/// resolve_impact(&mut floor, &mut bounced, &points, 1.0, 0.0, 1e-6).unwrap();
/// assert!((bounced.velocity - DVec3::Z).length() < 1e-9 && bounced.angular_velocity.length() < 1e-9);
/// ```
pub fn resolve_impact(
    a: &mut Impacted,
    b: &mut Impacted,
    points: &[(DVec3, DVec3)],
    restitution: f64,
    friction: f64,
    clearance: f64,
) -> Option<f64> {
    let mut total = first_order(a, b, points, restitution, friction)?;
    if restitution < 1.0 && clearance > 0.0 {
        // The least leaving speed of each point that keeps its dip within the clearance.
        let dip_speed = |a: &Impacted, b: &Impacted, point: DVec3, normal: DVec3| {
            let dip = (b.point_acceleration(point) - a.point_acceleration(point)).dot(normal);
            if dip < 0.0 {
                (-2.0 * dip * clearance).sqrt()
            } else {
                0.0
            }
        };
        let leaving = |a: &Impacted, b: &Impacted, point: DVec3, normal: DVec3| {
            (b.side(point).point_velocity() - a.side(point).point_velocity()).dot(normal)
        };
        if points.iter().any(|&(p, n)| leaving(a, b, p, n) < dip_speed(a, b, p, n)) {
            total += simultaneous(a, b, points, |a, b, p, n| dip_speed(a, b, p, n), friction)?;
        }
    }
    Some(total)
}

/// [`resolve_impact`] to first order: Newton's law at every point.
fn first_order(
    a: &mut Impacted,
    b: &mut Impacted,
    points: &[(DVec3, DVec3)],
    restitution: f64,
    friction: f64,
) -> Option<f64> {
    if let [(point, normal)] = *points {
        let (side_a, side_b) = (a.side(point), b.side(point));
        let push = rigid_impulse(&side_a, &side_b, normal, restitution, friction);
        (a.velocity, a.angular_velocity) = side_a.after(-push);
        (b.velocity, b.angular_velocity) = side_b.after(push);
        return Some(push.dot(normal));
    }
    let (start_a, start_b) = (*a, *b);
    let arrival = |a: &Impacted, b: &Impacted, point: DVec3, normal: DVec3| {
        -restitution * (b.side(point).point_velocity() - a.side(point).point_velocity()).dot(normal).min(0.0)
    };
    if let Some(total) = simultaneous(a, b, points, arrival, friction) {
        if energy(a) + energy(b) <= (energy(&start_a) + energy(&start_b)) * (1.0 + 1e-12) {
            return Some(total);
        }
    }
    (*a, *b) = (start_a, start_b);
    one_after_another(a, b, points, restitution, friction)
}

/// Kinetic energy of an impacted body (an immovable one has none that can change).
fn energy(body: &Impacted) -> f64 {
    if body.inverse_mass == 0.0 {
        return 0.0;
    }
    let inertia = body.inverse_inertia.inverse();
    0.5 * body.velocity.length_squared() / body.inverse_mass
        + 0.5 * body.angular_velocity.dot(inertia * body.angular_velocity)
}

/// The impact's points solved together by projected Gauss-Seidel on accumulated impulses: each
/// point leaves with at least the normal speed `target` gives for the velocities at the start
/// (exactly that speed where it pushes); `None` when it does not settle within the sweeps.
fn simultaneous(
    a: &mut Impacted,
    b: &mut Impacted,
    points: &[(DVec3, DVec3)],
    target: impl Fn(&Impacted, &Impacted, DVec3, DVec3) -> f64,
    friction: f64,
) -> Option<f64> {
    // A handful of points: their bookkeeping fits the stack.
    const MOST: usize = 16;
    if points.len() > MOST {
        return None;
    }
    let normal_velocity = |a: &Impacted, b: &Impacted, point: DVec3, normal: DVec3| {
        (b.side(point).point_velocity() - a.side(point).point_velocity()).dot(normal)
    };
    let mut wanted_speed = [0.0; MOST];
    let mut pushed = [0.0; MOST];
    let mut rubbed = [DVec3::ZERO; MOST];
    for (k, &(point, normal)) in points.iter().enumerate() {
        wanted_speed[k] = target(a, b, point, normal);
    }
    let scale = points
        .iter()
        .zip(wanted_speed)
        .map(|(&(p, n), speed)| normal_velocity(a, b, p, n).abs().max(speed))
        .fold(f64::MIN_POSITIVE, f64::max);
    for _ in 0..IMPACT_SWEEPS {
        let mut change: f64 = 0.0;
        for (k, &(point, normal)) in points.iter().enumerate() {
            let (side_a, side_b) = (a.side(point), b.side(point));
            let matrix = side_a.response() + side_b.response();
            let weight = normal.dot(matrix * normal);
            if !(weight > 0.0) {
                continue;
            }
            let wanted = (wanted_speed[k] - normal_velocity(a, b, point, normal)) / weight;
            let now = (pushed[k] + wanted).max(0.0);
            let mut push = (now - pushed[k]) * normal;
            pushed[k] = now;
            if friction > 0.0 {
                let relative = side_b.point_velocity() - side_a.point_velocity() + matrix * push;
                let slip = relative - relative.dot(normal) * normal;
                // The tangential impulse that would stop the slip, within the cone of this point's
                // accumulated normal impulse.
                let stop = -slip
                    / (slip.dot(matrix * slip) / slip.length_squared().max(f64::MIN_POSITIVE)).max(f64::MIN_POSITIVE);
                let mut total = rubbed[k] + if slip.length_squared() > 0.0 { stop } else { DVec3::ZERO };
                let bound = friction * pushed[k];
                if total.length() > bound {
                    total *= bound / total.length();
                }
                push += total - rubbed[k];
                rubbed[k] = total;
            }
            (a.velocity, a.angular_velocity) = side_a.after(-push);
            (b.velocity, b.angular_velocity) = side_b.after(push);
            change = change.max(push.length() * weight);
        }
        if change <= 1e-14 * scale {
            let settled = points.iter().all(|&(p, n)| normal_velocity(a, b, p, n) >= -1e-12 * scale);
            return settled.then(|| pushed[..points.len()].iter().sum());
        }
    }
    None
}

/// Impulses point after point, as [`rigid_impulse`] gives them for the velocities left by the
/// ones before, until no point approaches; `None` when points still approach after the sweeps.
fn one_after_another(
    a: &mut Impacted,
    b: &mut Impacted,
    points: &[(DVec3, DVec3)],
    restitution: f64,
    friction: f64,
) -> Option<f64> {
    let mut total = 0.0;
    for _ in 0..IMPACT_SWEEPS {
        let mut pushed = false;
        for &(point, normal) in points {
            let (side_a, side_b) = (a.side(point), b.side(point));
            let push = rigid_impulse(&side_a, &side_b, normal, restitution, friction);
            if push != DVec3::ZERO {
                (a.velocity, a.angular_velocity) = side_a.after(-push);
                (b.velocity, b.angular_velocity) = side_b.after(push);
                total += push.dot(normal);
                pushed = true;
            }
        }
        if !pushed {
            return Some(total);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn momentum_and_energy_are_conserved() {
        let n = DVec3::new(1.0, 2.0, -0.5).normalize();
        let (va, vb) = (DVec3::new(3.0, 1.0, 0.2), DVec3::new(-1.0, -0.5, 2.0));
        let (ma, mb) = (2.0, 0.7);
        let j = pair_impulse(n, va, vb, 1.0 / ma, 1.0 / mb, 1.0);
        let (va2, vb2) = (va - j / ma * n, vb + j / mb * n);
        let p0 = va * ma + vb * mb;
        let p1 = va2 * ma + vb2 * mb;
        assert!((p0 - p1).length() < 1e-12);
        let e0 = 0.5 * (ma * va.length_squared() + mb * vb.length_squared());
        let e1 = 0.5 * (ma * va2.length_squared() + mb * vb2.length_squared());
        assert!((e0 - e1).abs() < 1e-12 * e0);
        // After the impact they separate along the normal.
        assert!((vb2 - va2).dot(n) > 0.0);
    }

    #[test]
    fn separating_bodies_get_no_impulse() {
        assert_eq!(pair_impulse(DVec3::X, DVec3::new(-1.0, 0.0, 0.0), DVec3::X, 1.0, 1.0, 1.0), 0.0);
    }

    #[test]
    fn inelastic_wall() {
        assert_eq!(wall_bounce(DVec3::new(1.0, 2.0, 3.0), 1, 0.5), DVec3::new(1.0, -1.0, 3.0));
    }

    /// A random rigid side: mass, a rotated diagonal inertia, velocities and an arm.
    fn side(seed: &mut u64) -> RigidSide {
        let mut next = || {
            *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut vector = || DVec3::new(next(), next(), next());
        let (velocity, angular_velocity, arm) = (vector(), vector() * 3.0, vector());
        let axis = vector().normalize();
        let moments = vector().abs() + DVec3::splat(0.1);
        let rotation = DMat3::from_axis_angle(axis, 1.3);
        let inverse_inertia = rotation * DMat3::from_diagonal(moments.recip()) * rotation.transpose();
        RigidSide { velocity, angular_velocity, inverse_mass: 1.0 / (0.5 + moments.x), inverse_inertia, arm }
    }

    /// Linear and angular momentum (about the origin, the contact point at `point`) and energy
    /// of two bodies with these sides, before and after `impulse` on b.
    fn budgets(a: &RigidSide, b: &RigidSide, point: DVec3, impulse: DVec3) -> [(DVec3, DVec3, f64); 2] {
        let totals = |sides: [(RigidSide, DVec3, DVec3); 2]| {
            let (mut p, mut l, mut e) = (DVec3::ZERO, DVec3::ZERO, 0.0);
            for (s, v, w) in sides {
                let (m, inertia) = (1.0 / s.inverse_mass, s.inverse_inertia.inverse());
                let centre = point - s.arm;
                p += m * v;
                l += centre.cross(m * v) + inertia * w;
                e += 0.5 * m * v.length_squared() + 0.5 * w.dot(inertia * w);
            }
            (p, l, e)
        };
        let (va, wa) = a.after(-impulse);
        let (vb, wb) = b.after(impulse);
        [
            totals([(*a, a.velocity, a.angular_velocity), (*b, b.velocity, b.angular_velocity)]),
            totals([(*a, va, wa), (*b, vb, wb)]),
        ]
    }

    #[test]
    fn rigid_impacts_keep_momenta_and_elastic_frictionless_ones_keep_energy() {
        let mut seed = 7;
        let mut impacts = 0;
        for _ in 0..2000 {
            let (a, b) = (side(&mut seed), side(&mut seed));
            let normal = side(&mut seed).velocity.normalize();
            let point = DVec3::new(0.3, -0.2, 0.1);
            for (restitution, friction) in [(1.0, 0.0), (0.5, 0.0), (1.0, 0.4), (0.2, 2.0)] {
                let impulse = rigid_impulse(&a, &b, normal, restitution, friction);
                if impulse == DVec3::ZERO {
                    continue;
                }
                impacts += 1;
                let [(p0, l0, e0), (p1, l1, e1)] = budgets(&a, &b, point, impulse);
                assert!((p1 - p0).length() <= 1e-12 * (1.0 + p0.length()), "momentum");
                assert!((l1 - l0).length() <= 1e-11 * (1.0 + l0.length()), "angular momentum");
                if restitution == 1.0 && friction == 0.0 {
                    assert!((e1 - e0).abs() <= 1e-12 * e0, "energy {e0} -> {e1}");
                } else {
                    assert!(e1 <= e0 * (1.0 + 1e-12), "an impact added energy: {e0} -> {e1}");
                }
                // The contact points no longer approach along the normal.
                let (va, wa) = a.after(-impulse);
                let (vb, wb) = b.after(impulse);
                let leaving = (vb + wb.cross(b.arm) - va - wa.cross(a.arm)).dot(normal);
                assert!(leaving >= -1e-12, "still approaching at {leaving}");
            }
        }
        assert!(impacts > 1000);
    }

    #[test]
    fn friction_stops_a_slip_inside_the_cone_and_bounds_a_sliding_one() {
        // A unit ball dropped at 1 onto the floor while sliding at 0.1 (inside the cone for
        // friction 1) or at 10 (outside): it grips, or slides with tangential impulse mu j.
        let ball = |slide: f64| RigidSide {
            velocity: DVec3::new(slide, -1.0, 0.0),
            angular_velocity: DVec3::ZERO,
            inverse_mass: 1.0,
            inverse_inertia: DMat3::from_diagonal(DVec3::splat(2.5)),
            arm: DVec3::new(0.0, -1.0, 0.0),
        };
        let gripped = ball(0.1);
        let impulse = rigid_impulse(&RigidSide::FIXED, &gripped, DVec3::Y, 0.0, 1.0);
        let (v, w) = gripped.after(impulse);
        assert!((v + w.cross(gripped.arm)).length() < 1e-15, "the contact point stops");
        let sliding = ball(10.0);
        let impulse = rigid_impulse(&RigidSide::FIXED, &sliding, DVec3::Y, 0.0, 1.0);
        assert!((impulse.x + impulse.y).abs() < 1e-12 && impulse.y > 0.0, "tangential = mu x normal: {impulse}");
    }
}
