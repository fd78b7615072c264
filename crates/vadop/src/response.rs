//! Collision response: the velocity change of an elastic (or partly inelastic) impact.
//!
//! It owns the impulse arithmetic only. It never decides *when* bodies touch (narrow phase) nor
//! what a velocity change invalidates (world); both continuous methods and the pseudo-dynamic
//! baseline call the same functions.

use glam::DVec3;

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
}
