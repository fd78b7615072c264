//! Free rotation: the exact torque-free motion of a rigid body between collisions, as a helper
//! of the body store.
//!
//! It owns the closed-form solution of Euler's torque-free equations and the special functions
//! behind it (Jacobi's sn, cn, dn by the descending Landen transformation, Carlson's R_F and R_J).
//! It never integrates numerically, never allocates, keeps nothing but what
//! [`FreeRotation::new`] precomputes, and knows nothing of shapes, contacts or the store itself:
//! every query is a pure function of the constructor's inputs and the elapsed time, so the same
//! inputs give the same bits on every call and thread (and on every machine with the same libm).
//!
//! # Method
//! The world angular momentum L and the kinetic energy E are constant. The principal axes are
//! relabelled into a *working frame* (x, y, z) in which the body-frame angular momentum
//! circulates about z (the axis of the largest moment if |L|² > 2 E I_mid, else of the smallest)
//! with L_z > 0: L_W(u) = (a1 cn u, a2 sn u, a3 dn u), u = u0 + ω_p t (van Zon & Schofield,
//! J. Comput. Phys. 225, 2007). The orientation is R(t) = A · Rz(ψ(t)) · P(t) · S, where S takes
//! body to working coordinates, P(t) is the smallest rotation taking L̂_W(t) to z (never singular:
//! L_z > 0), A is fixed by the reference orientation, and
//! dψ/dt = |L|/I_z + (2E - |L|²/I_z) / (|L| + L_z(t)).
//! The last term is integrated as its mean over a period times t (so the error grows with the
//! number of periods no faster than that of the time itself) plus a bounded periodic part in
//! closed form: an elliptic integral of the third kind with negative characteristic, written
//! with only positive terms as atan2(λ sn, cn dn)/λ + μ sn³/3 · R_J (Carlson's p ↔ q
//! transformation), so it stays exact to rounding however close two moments are. The mean
//! comes from the trapezoidal rule (spectrally accurate for this smooth periodic integrand) for
//! m ≤ 0.99, where the complete closed form would lose digits to cancellation when L is near a
//! principal axis, and from the complete closed form above.
//! Isotropic bodies, symmetric tops about their equator and spins exactly about a principal axis
//! are steady rotations; a symmetric top is the elliptic case with m = 0, so nearly symmetric
//! bodies join it continuously.
//!
//! # Thresholds
//! - Body-frame angular velocity components below 2^-47 (about 32 ulps) of the largest are zeroed:
//!   they are the rounding of the frame change, and this is what lets a spin about the unstable
//!   intermediate axis stay one (the exact solution of the rounded input would leave it after
//!   some 40 e-foldings). Zeroing a component that small turns ω by at most 7e-15 rad and
//!   changes the energy and |L| only at second order, so the long-time phase is unaffected.
//! - A state whose separatrix measure d23 L3² - d12 L1² is within 2^-47 of its terms is put on the
//!   separatrix (m = 1, hyperbolic functions, infinite period): its distance from it is rounding.
//!   Just outside, the elliptic parameter m' = 1 - m is computed from that difference directly (no
//!   1 - m cancellation), so the period grows continuously (logarithmically) toward the
//!   separatrix, and both sides agree up to the time the slower one turns back.
//! - Landen's descent stops at modulus k ≤ 2^-28, where sn, cn differ from sin, cos by under
//!   k²/4 ≈ 1e-17; at most 14 levels, enough for m' down to the smallest normal numbers.
//! - The mean precession rate takes 8 trapezoidal nodes over [0, K] (half a period of dn) for m ≤ 1/2 and 16 up to
//!   m = 0.99: the error is of order q^(2 nodes) for the nome q (≤ 0.043 and ≤ 0.27), below
//!   1e-19. Above 0.99 the complete integral's few ulps are less than the motion's own
//!   sensitivity to its inputs, which grows like 1/(1 - m).
//! - Carlson's duplication stops at its own error bound (relative 2^-53) or after 64 rounds.
//!
//! Inertia must be finite and positive, with ratios of moments whose reciprocals stay finite:
//! checking that is the caller's job. Other inputs give meaningless numbers (possibly NaN) but
//! [`FreeRotation::new`] never panics or loops forever: every loop here is bounded.

use crate::numeric::unit_scale;
use glam::{DMat3, DQuat, DVec3};
use std::f64::consts::{FRAC_PI_2, PI};

/// Body-frame angular velocity components at most this fraction of the largest are zeroed
/// (about 32 ulps: the rounding of rotating a vector into the body frame).
const AXIS_SNAP: f64 = 1.0 / (1u64 << 47) as f64;

/// A state whose separatrix measure is within this fraction of its terms is on the separatrix.
const SEPARATRIX_SNAP: f64 = 1.0 / (1u64 << 47) as f64;

/// Relative slack on [`FreeRotation::max_angular_speed`] so that rounding in the evaluated
/// angular velocity can never exceed it.
const SPEED_BOUND_SLACK: f64 = 1.0 / (1u64 << 40) as f64;

/// Enough Landen levels for a complementary parameter down to the smallest normal numbers.
const MAX_LANDEN_LEVELS: usize = 14;

/// Landen's descent stops at a modulus this small: sn, cn are then sin, cos to 1e-17.
const LANDEN_BOTTOM: f64 = 1.0 / (1u64 << 28) as f64;

/// Carlson's duplication converges four-fold per round; this bound is only reached by
/// arguments spread over hundreds of orders of magnitude or by non-finite input.
const MAX_DUPLICATIONS: usize = 64;

/// Up to this parameter m the mean precession rate comes from the trapezoidal rule; above it
/// from the complete elliptic integral, whose cancellation there (a few ulps) is below the
/// sensitivity of the motion itself to rounding of its inputs, which grows like 1/(1 - m).
const TRAPEZOID_MAX_PARAMETER: f64 = 0.99;

/// Trapezoidal nodes over [0, K] (half a period of dn) for the mean precession rate: the error is of order
/// q^(2 nodes), q being the nome (q ≤ e^-π ≈ 0.043 for m ≤ 1/2, q ≤ 0.27 for m ≤ 0.99), far
/// below rounding either way.
fn trapezoid_nodes(m: f64) -> usize {
    if m <= 0.5 {
        8
    } else {
        16
    }
}

/// Exact free rotation of a rigid body from a reference instant.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::motion::free_rotation::FreeRotation;
/// // A tumbling brick: the angular momentum and the energy stay put while it wobbles.
/// let inertia = DVec3::new(1.0, 2.0, 3.0);
/// let rotation = FreeRotation::new(inertia, DQuat::IDENTITY, DVec3::new(0.3, 1.0, 0.2));
/// let later = rotation.orientation_at(10.0);
/// let omega = rotation.angular_velocity_at(10.0);
/// let momentum = later * (inertia * (later.inverse() * omega));
/// assert!((momentum - rotation.angular_momentum()).length() < 1e-13);
/// assert!(omega.length() <= rotation.max_angular_speed());
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FreeRotation {
    motion: Motion,
    angular_momentum: DVec3,
    kinetic_energy: f64,
    max_angular_speed: f64,
}

// A plain value kept per body: boxing the large variant would allocate.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    /// The angular velocity is parallel to L, so it is constant.
    Steady {
        orientation: DQuat,
        angular_velocity: DVec3,
        /// The angular velocity in the principal frame, its rounding zeroed (see [`AXIS_SNAP`]).
        body_angular_velocity: DVec3,
    },
    Tumbling(Tumbling),
}

/// A body whose angular velocity moves in the body: R(t) = A · Rz(ψ) · P(t) · S. Lengths are in
/// the scaled units of [`FreeRotation::new`], rates in real units.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Tumbling {
    /// A: the L-aligned frame to world, L̂ being its z axis.
    aligned_to_world: DQuat,
    /// S: principal (body) coordinates to working coordinates.
    body_to_working: DQuat,
    /// (a1, a2, a3) of L_W(u) = (a1 cn u, a2 sn u, a3 dn u); a2 carries the sense of circulation.
    amplitude: DVec3,
    /// |L|.
    momentum: f64,
    /// 1/I in working coordinates.
    inverse_inertia: DVec3,
    /// Converts scaled angular velocity to real units (an exact power of two).
    velocity_unscale: f64,
    /// du/dt.
    polhode_rate: f64,
    /// u at the reference instant.
    phase: f64,
    /// Mean dψ/dt.
    precession_rate: f64,
    orbit: Orbit,
}

#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
enum Orbit {
    /// 0 ≤ m < 1: periodic in u with period 2K (half the period of sn and cn, whose sign flips).
    Periodic { landen: Landen, half_period: f64, wobble: Option<Wobble> },
    /// m = 1: sn = tanh, cn = dn = sech; the motion approaches the intermediate axis forever.
    Separatrix { scale: f64, slope: f64, offset: f64 },
}

/// The periodic part of ψ: scale · (|L| Π(u) - a3 ρ Θ(u)) - slope · u, minus its value at u0.
/// Absent for m = 0, where the integrand is constant.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Wobble {
    scale: f64,
    slope: f64,
    /// Π's characteristic is -r; λ = sqrt((1 + r)(1 + μ)), μ = m / r, ρ = 1/sqrt(1 + r).
    lambda: f64,
    mu: f64,
    rho: f64,
    offset: f64,
}

impl FreeRotation {
    /// Precomputes the motion of a body with principal moments `principal_inertia` (finite and
    /// positive) about its principal axes, whose principal frame is taken to the world by the
    /// unit quaternion `orientation` at the reference instant, spinning with world angular
    /// velocity `angular_velocity` then.
    ///
    /// Inputs are scaled by exact powers of two before any square is taken, so tiny and huge
    /// magnitudes behave like ordinary ones.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// // A sphere spins steadily: after a quarter turn about z, x has gone to y.
    /// let sphere = FreeRotation::new(DVec3::ONE, DQuat::IDENTITY, DVec3::new(0.0, 0.0, 2.0));
    /// let turned = sphere.orientation_at(std::f64::consts::PI / 4.0) * DVec3::X;
    /// assert!((turned - DVec3::Y).length() < 1e-15);
    /// ```
    pub fn new(principal_inertia: DVec3, orientation: DQuat, angular_velocity: DVec3) -> FreeRotation {
        let inertia_scale = unit_scale(principal_inertia.max_element());
        let velocity_scale = unit_scale(angular_velocity.abs().max_element());
        let inertia = principal_inertia * inertia_scale;
        let velocity = orientation.inverse() * (angular_velocity * velocity_scale);
        let snap = DVec3::splat(AXIS_SNAP * velocity.abs().max_element());
        let velocity = DVec3::select(velocity.abs().cmple(snap), DVec3::ZERO, velocity);
        let momentum = inertia * velocity;
        // 1 / scale is exact: the scales are powers of two in the normal range.
        let (inertia_unscale, velocity_unscale) = (1.0 / inertia_scale, 1.0 / velocity_scale);
        let angular_momentum = orientation * momentum * inertia_unscale * velocity_unscale;
        let kinetic_energy = 0.5 * velocity.dot(momentum) * inertia_unscale * velocity_unscale * velocity_unscale;
        let steady = |velocity: DVec3| FreeRotation {
            motion: Motion::Steady {
                orientation,
                angular_velocity: orientation * velocity * velocity_unscale,
                body_angular_velocity: velocity * velocity_unscale,
            },
            angular_momentum,
            kinetic_energy,
            max_angular_speed: velocity.length() * velocity_unscale * (1.0 + SPEED_BOUND_SLACK),
        };

        let mut order = [0, 1, 2];
        order.sort_by(|&i, &j| inertia[i].total_cmp(&inertia[j]));
        let [small, middle, large] = order;
        let (i1, i2, i3) = (inertia[small], inertia[middle], inertia[large]);
        // Differences of reciprocal moments from differences of moments: exact when close.
        let d12 = (i2 - i1) / (i1 * i2);
        let d23 = (i3 - i2) / (i2 * i3);
        let d13 = (i3 - i1) / (i1 * i3);
        let top = d23 * momentum[large] * momentum[large];
        let bottom = d12 * momentum[small] * momentum[small];
        let nonzero = momentum.cmpne(DVec3::ZERO).bitmask().count_ones();
        // ω ∥ L exactly when L is along a principal axis, or every non-zero component of L
        // shares its moment with the middle one.
        if nonzero <= 1 || (top == 0.0 && bottom == 0.0) || !(top + bottom).is_finite() {
            return steady(velocity);
        }
        let separatrix = (top - bottom).abs() <= SEPARATRIX_SNAP * (top + bottom);
        let about_largest = separatrix || top > bottom;
        let (x, y, z) = if about_largest { (small, middle, large) } else { (large, middle, small) };
        let (d_xy, d_yz) = if about_largest { (d12, d23) } else { (d23, d12) };
        let separation = if separatrix { 0.0 } else { (top - bottom).abs() };
        // Working axes: z along the circulation with L_z > 0, x with L_x >= 0 at the reference.
        let z_axis = DVec3::AXES[z] * momentum[z].signum();
        let x_axis = if momentum[x] < 0.0 { -DVec3::AXES[x] } else { DVec3::AXES[x] };
        let y_axis = z_axis.cross(x_axis);
        let body_to_working = DQuat::from_mat3(&DMat3::from_cols(x_axis, y_axis, z_axis)).inverse();
        let l = DVec3::new(x_axis.dot(momentum), y_axis.dot(momentum), z_axis.dot(momentum));
        let inverse_inertia = DVec3::new(1.0 / inertia[x], 1.0 / inertia[y], 1.0 / inertia[z]);
        let orbit = BodyOrbit { l, d_xy, d_yz, d13, separation, sense: if about_largest { 1.0 } else { -1.0 } };
        let tumbling = orbit.tumbling(inverse_inertia, velocity_unscale);
        let Some((mut tumbling, l0)) = tumbling else { return steady(velocity) };
        tumbling.body_to_working = body_to_working;
        // A = R0 S⁻¹ P0⁻¹, P0 being what later calls compute at dt = 0 (to the bit).
        let tilt = tumbling.tilt(l0);
        tumbling.aligned_to_world = orientation * body_to_working.inverse() * tilt.inverse();
        let amplitude = tumbling.amplitude;
        let e = inverse_inertia;
        // |ω|² over the orbit is linear in sn², so its maximum is at sn² = 0 or 1.
        let low = (e.x * amplitude.x).powi(2) + (e.z * amplitude.z).powi(2);
        let high = (e.y * amplitude.y).powi(2) + (e.z * amplitude.z).powi(2) * orbit.complementary_parameter();
        let max_angular_speed = low.max(high).sqrt() * velocity_unscale * (1.0 + SPEED_BOUND_SLACK);
        FreeRotation { motion: Motion::Tumbling(tumbling), angular_momentum, kinetic_energy, max_angular_speed }
    }

    /// Rotation taking principal-frame vectors to world vectors `dt` after the reference instant
    /// (any finite `dt`, negative included).
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// let start = DQuat::from_rotation_x(0.4);
    /// let rotation = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), start, DVec3::new(1.0, 0.5, -2.0));
    /// let moved = |q: DQuat| (q * DVec3::new(1.0, 2.0, 3.0) - start * DVec3::new(1.0, 2.0, 3.0)).length();
    /// assert!(moved(rotation.orientation_at(0.0)) < 1e-14);
    /// // Forward, then back again from there.
    /// let (later, spin) = (rotation.orientation_at(5.0), rotation.angular_velocity_at(5.0));
    /// let there = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), later, spin);
    /// assert!(moved(there.orientation_at(-5.0)) < 1e-12);
    /// ```
    pub fn orientation_at(&self, dt: f64) -> DQuat {
        match &self.motion {
            Motion::Steady { orientation, angular_velocity, .. } => {
                DQuat::from_scaled_axis(*angular_velocity * dt) * *orientation
            }
            Motion::Tumbling(tumbling) => tumbling.working_to_world(dt).0 * tumbling.body_to_working,
        }
    }

    /// World angular velocity `dt` after the reference instant.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// let omega = DVec3::new(0.1, 2.0, 0.3);
    /// let rotation = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), DQuat::IDENTITY, omega);
    /// assert!((rotation.angular_velocity_at(0.0) - omega).length() < 1e-15);
    /// // Energy is conserved: ½ ω·L.
    /// let energy = 0.5 * rotation.angular_velocity_at(7.0).dot(rotation.angular_momentum());
    /// assert!((energy - rotation.kinetic_energy()).abs() < 1e-14);
    /// ```
    pub fn angular_velocity_at(&self, dt: f64) -> DVec3 {
        match &self.motion {
            Motion::Steady { angular_velocity, .. } => *angular_velocity,
            Motion::Tumbling(tumbling) => tumbling.angular_velocity(tumbling.working_to_world(dt)),
        }
    }

    /// [`Self::orientation_at`] and [`Self::angular_velocity_at`] together, the same bits, for
    /// the cost of one: a tumbling body's frame at `dt` (an elliptic integral) is found once.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// let rotation = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), DQuat::IDENTITY, DVec3::new(1.0, 0.5, -2.0));
    /// let both = rotation.orientation_and_angular_velocity_at(3.0);
    /// assert_eq!(both, (rotation.orientation_at(3.0), rotation.angular_velocity_at(3.0)));
    /// ```
    pub fn orientation_and_angular_velocity_at(&self, dt: f64) -> (DQuat, DVec3) {
        match &self.motion {
            Motion::Steady { .. } => (self.orientation_at(dt), self.angular_velocity_at(dt)),
            Motion::Tumbling(tumbling) => {
                let working = tumbling.working_to_world(dt);
                (working.0 * tumbling.body_to_working, tumbling.angular_velocity(working))
            }
        }
    }

    /// World angular momentum, constant.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// let rotation = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), DQuat::IDENTITY, DVec3::new(1.0, 1.0, 1.0));
    /// assert_eq!(rotation.angular_momentum(), DVec3::new(1.0, 2.0, 3.0));
    /// ```
    pub fn angular_momentum(&self) -> DVec3 {
        self.angular_momentum
    }

    /// Rotational kinetic energy, constant.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// let rotation = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), DQuat::IDENTITY, DVec3::new(1.0, 1.0, 1.0));
    /// assert_eq!(rotation.kinetic_energy(), 3.0);
    /// ```
    pub fn kinetic_energy(&self) -> f64 {
        self.kinetic_energy
    }

    /// An upper bound on |angular velocity| over all time: its exact maximum over the orbit of
    /// the body-frame angular momentum, plus a relative 2^-40 for rounding. It is at most
    /// |L| / I_min and usually much less.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// let rotation = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), DQuat::IDENTITY, DVec3::new(0.1, 1.0, 0.1));
    /// let bound = rotation.max_angular_speed();
    /// assert!((0..1000).all(|i| rotation.angular_velocity_at(0.01 * i as f64).length() <= bound));
    /// let smallest_moment = 1.0;
    /// assert!(bound < rotation.angular_momentum().length() / smallest_moment);
    /// ```
    pub fn max_angular_speed(&self) -> f64 {
        self.max_angular_speed
    }

    /// An upper bound on |dω/dt| over all time: 0 for a steady rotation; for a tumbling one
    /// (I_max - I_min) / (2 I_min) times the square of [`Self::max_angular_speed`], from Euler's
    /// equations I dω/dt = (I ω) × ω = ((I - c) ω) × ω with c halfway between the extreme
    /// moments (the world and body frames see the same derivative of ω), plus a relative 2^-40
    /// for rounding.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// let rotation = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), DQuat::IDENTITY, DVec3::new(0.3, 1.0, 0.2));
    /// let bound = rotation.max_angular_acceleration();
    /// let h = 1e-4;
    /// for i in 0..1000 {
    ///     let t = 0.01 * i as f64;
    ///     let rate = (rotation.angular_velocity_at(t + h) - rotation.angular_velocity_at(t - h)) / (2.0 * h);
    ///     assert!(rate.length() <= bound * (1.0 + 1e-6));
    /// }
    /// ```
    pub fn max_angular_acceleration(&self) -> f64 {
        match &self.motion {
            Motion::Steady { .. } => 0.0,
            Motion::Tumbling(tumbling) => {
                let e = tumbling.inverse_inertia;
                let spread = 0.5 * (e.max_element() / e.min_element() - 1.0);
                spread * self.max_angular_speed * self.max_angular_speed * (1.0 + SPEED_BOUND_SLACK)
            }
        }
    }

    /// The constant angular velocity in the body's principal frame of a steady rotation (one
    /// whose angular velocity stays parallel to the angular momentum), with the components that
    /// are rounding of the frame change zeroed; `None` for a tumbling body. A spin about a body
    /// axis along which a shape is symmetric leaves the shape where it is.
    ///
    /// ```
    /// use glam::{DQuat, DVec3};
    /// use vadop::motion::free_rotation::FreeRotation;
    /// // About the middle principal axis, given in world axes after a quarter turn: steady.
    /// let turned = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
    /// let top = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), turned, turned * DVec3::new(0.0, 3.0, 0.0));
    /// assert_eq!(top.steady_spin(), Some(DVec3::new(0.0, 3.0, 0.0)));
    /// let tumbling = FreeRotation::new(DVec3::new(1.0, 2.0, 3.0), DQuat::IDENTITY, DVec3::new(0.1, 3.0, 0.2));
    /// assert_eq!(tumbling.steady_spin(), None);
    /// ```
    pub fn steady_spin(&self) -> Option<DVec3> {
        match &self.motion {
            Motion::Steady { body_angular_velocity, .. } => Some(*body_angular_velocity),
            Motion::Tumbling(_) => None,
        }
    }
}

/// The body-frame angular momentum in working coordinates and what classifies its orbit.
struct BodyOrbit {
    l: DVec3,
    d_xy: f64,
    d_yz: f64,
    d13: f64,
    /// d_yz L_z² - d_xy L_x² > 0, or 0 on the separatrix.
    separation: f64,
    /// +1 when L circulates about the largest moment (dψ/dt above |L|/I_z), else -1.
    sense: f64,
}

impl BodyOrbit {
    fn polhode_rate_squared(&self) -> f64 {
        (self.d_xy * self.l.y * self.l.y + self.d13 * self.l.z * self.l.z) * self.d_yz
    }

    /// m' = 1 - m, computed from the separation so it stays accurate near the separatrix.
    fn complementary_parameter(&self) -> f64 {
        self.d13 * self.separation / self.polhode_rate_squared()
    }

    /// The precomputed motion (all but its frames) and L_W at the reference instant; `None` if
    /// the inputs are degenerate after all (e.g. non-finite).
    fn tumbling(&self, inverse_inertia: DVec3, velocity_unscale: f64) -> Option<(Tumbling, DVec3)> {
        let BodyOrbit { l, d_xy, d_yz, d13, sense, .. } = *self;
        let rate_squared = self.polhode_rate_squared();
        let polhode_rate = rate_squared.sqrt();
        let ratio = d_yz / d13;
        let a1 = (l.x * l.x + l.y * l.y * ratio).sqrt();
        let a2 = sense * (l.y * l.y + l.x * l.x / ratio).sqrt();
        let a3 = (l.z * l.z + l.y * l.y * d_xy / d13).sqrt();
        let momentum = l.length();
        let rho = ratio.sqrt();
        let mc = self.complementary_parameter();
        let m = a2 * a2 * d_xy * d_yz / rate_squared;
        if !(polhode_rate > 0.0 && momentum > 0.0 && mc >= 0.0 && m >= 0.0 && a1 > 0.0) {
            return None;
        }
        // κ = 2E - |L|²/I_z: the numerator of the varying part of dψ/dt.
        let kappa = sense * a1 * a1 * d13;
        let base_rate = momentum * inverse_inertia.z;
        let mut tumbling = Tumbling {
            aligned_to_world: DQuat::IDENTITY,
            body_to_working: DQuat::IDENTITY,
            amplitude: DVec3::new(a1, a2, a3),
            momentum,
            inverse_inertia,
            velocity_unscale,
            polhode_rate: polhode_rate * velocity_unscale,
            phase: 0.0,
            precession_rate: 0.0,
            orbit: Orbit::Separatrix { scale: 0.0, slope: 0.0, offset: 0.0 },
        };
        if mc == 0.0 {
            // sn = tanh, cn = dn = sech: tan(amplitude) = sinh u.
            let phase = (a1 / a2 * l.y / l.x).asinh();
            let slope = a1 / (momentum + a3);
            let scale = 2.0 * a1 * a3 * d13 / (momentum * polhode_rate);
            tumbling.phase = phase;
            tumbling.precession_rate = (base_rate + kappa / momentum) * velocity_unscale;
            tumbling.orbit = Orbit::Separatrix { scale, slope, offset: (slope * (0.5 * phase).tanh()).atan() };
            let sech = 1.0 / phase.cosh();
            return Some((tumbling, DVec3::new(a1 * sech, a2 * phase.tanh(), a3 * sech)));
        }
        let landen = Landen::new(m, mc);
        let half_period = PI / landen.argument_scale;
        let quarter_period = 0.5 * half_period;
        // The amplitude φ0 of u0: tan φ0 = sn/cn = (L_y/a2)/(L_x/a1), in [-π/2, π/2] as L_x >= 0.
        let (sn0, cn0) = {
            let (s, c) = (a1 / a2 * l.y, l.x);
            let h = s.hypot(c);
            (s / h, c / h)
        };
        let phase = sn0 * carlson_rf(cn0 * cn0, cn0 * cn0 + mc * sn0 * sn0, 1.0);
        let g = |dn: f64| 1.0 / (momentum + a3 * dn);
        let r = d_xy / d_yz;
        let mu = a2 * a2 * d_yz * d_yz / rate_squared;
        let lambda = ((1.0 + r) * (1.0 + mu)).sqrt();
        let wobble = Wobble { scale: sense * d13 / polhode_rate, slope: 0.0, lambda, mu, rho, offset: 0.0 };
        let mean = if m == 0.0 {
            g(1.0)
        } else if m <= TRAPEZOID_MAX_PARAMETER {
            // g is even and 2K-periodic: the trapezoidal rule over [0, K] with halved ends.
            // dn(K - u) = k'/dn(u) pairs the nodes, and dn(K/2) = sqrt(k').
            let nodes = trapezoid_nodes(m);
            let step = quarter_period / nodes as f64;
            let modulus = mc.sqrt();
            let pairs: f64 = (1..nodes / 2)
                .map(|i| {
                    let dn = landen.sn_cn_dn(step * i as f64).2;
                    g(dn) + g(modulus / dn)
                })
                .sum();
            (pairs + g(modulus.sqrt()) + 0.5 * (g(1.0) + g(modulus))) / nodes as f64
        } else {
            // H(K) = (|L| Π(n|m) - a3 ρ π/2) / a1², and the mean is H(K)/K.
            let complete = wobble.third_kind(1.0, 0.0, mc.sqrt());
            (momentum * complete - a3 * rho * FRAC_PI_2) / (a1 * a1 * quarter_period)
        };
        let wobble = Wobble { slope: kappa * mean / polhode_rate, ..wobble };
        let (s, c, d) = landen.sn_cn_dn(phase);
        let wobble = (m > 0.0).then(|| Wobble { offset: wobble.at(phase, s, c, d, momentum, a3), ..wobble });
        tumbling.phase = phase;
        tumbling.precession_rate = (base_rate + kappa * mean) * velocity_unscale;
        tumbling.orbit = Orbit::Periodic { landen, half_period, wobble };
        Some((tumbling, DVec3::new(a1 * c, a2 * s, a3 * d)))
    }
}

impl Tumbling {
    /// ψ(t) - ψ(0) and L_W(t).
    #[inline]
    fn aligned_angle_and_momentum(&self, dt: f64) -> (f64, DVec3) {
        let u = self.phase + self.polhode_rate * dt;
        let DVec3 { x: a1, y: a2, z: a3 } = self.amplitude;
        match &self.orbit {
            Orbit::Periodic { landen, half_period, wobble } => {
                let turns = (u / half_period).round();
                let reduced = u - turns * half_period;
                let (s, c, d) = landen.sn_cn_dn(reduced);
                // sn and cn change sign every half period; dn does not.
                let sign = if turns.rem_euclid(2.0) == 1.0 { -1.0 } else { 1.0 };
                let wobble = wobble.map_or(0.0, |w| w.at(reduced, s, c, d, self.momentum, a3) - w.offset);
                (self.precession_rate * dt + wobble, DVec3::new(a1 * c * sign, a2 * s * sign, a3 * d))
            }
            Orbit::Separatrix { scale, slope, offset } => {
                let sech = 1.0 / u.cosh();
                let wobble = scale * ((slope * (0.5 * u).tanh()).atan() - offset);
                (self.precession_rate * dt - wobble, DVec3::new(a1 * sech, a2 * u.tanh(), a3 * sech))
            }
        }
    }

    /// P: the smallest rotation taking L_W to +z (L_z > 0, so it is never a half turn).
    #[inline]
    fn tilt(&self, l: DVec3) -> DQuat {
        DQuat::from_xyzw(l.y, -l.x, 0.0, self.momentum + l.z).normalize()
    }

    /// The rotation from working to world coordinates and L_W, `dt` after the reference.
    #[inline]
    fn working_to_world(&self, dt: f64) -> (DQuat, DVec3) {
        let (angle, l) = self.aligned_angle_and_momentum(dt);
        (self.aligned_to_world * DQuat::from_rotation_z(angle) * self.tilt(l), l)
    }

    /// The world angular velocity from [`Self::working_to_world`]'s rotation and L_W.
    #[inline]
    fn angular_velocity(&self, (frame, l): (DQuat, DVec3)) -> DVec3 {
        frame * (self.inverse_inertia * l) * self.velocity_unscale
    }
}

impl Wobble {
    /// Π(n; φ|m) = ∫_0^φ dθ / ((1 - n sin²θ) sqrt(1 - m sin²θ)) for n = -r < 0, given
    /// sin φ, cos φ >= 0 and Δ = sqrt(1 - m sin²φ). Written with positive terms only
    /// (Carlson's p ↔ q transformation of R_J about the argument 1), it has no cancellation
    /// however large r is.
    #[inline]
    fn third_kind(&self, s: f64, c: f64, delta: f64) -> f64 {
        let circular = (self.lambda * s).atan2(c * delta) / self.lambda;
        if self.mu == 0.0 {
            return circular;
        }
        let s2 = s * s;
        circular + self.mu * s * s2 / 3.0 * carlson_rj(c * c, delta * delta, 1.0, 1.0 + self.mu * s2)
    }

    /// The periodic part of ψ at reduced phase u (|u| <= K) with sn, cn, dn of u.
    #[inline]
    fn at(&self, u: f64, s: f64, c: f64, d: f64, momentum: f64, a3: f64) -> f64 {
        let circular = self.rho * s.atan2(self.rho * c);
        self.scale * (momentum * self.third_kind(s, c, d) - a3 * circular) - self.slope * u
    }
}

/// The descending Landen transformation of one parameter m, precomputed: sn, cn, dn of u follow
/// from sin and cos of u / ∏(1 + k_j) by a few rational steps with only positive terms, so sn
/// stays within about an ulp and cn, dn within a few ulps of their size (absolutely), up to m'
/// as small as the smallest normal number.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Landen {
    /// The moduli k_j of the descent.
    modulus: [f64; MAX_LANDEN_LEVELS],
    /// 1 - k_j, relatively accurate even as k_j → 1.
    complement: [f64; MAX_LANDEN_LEVELS],
    levels: usize,
    /// π / (2K): the argument at the bottom is u times this.
    argument_scale: f64,
    /// k² of the last modulus, for dn ≈ 1 - k² sin² / 2 at the bottom.
    bottom_parameter: f64,
    /// m' = 1 - m of the top modulus.
    complementary_parameter: f64,
}

impl Landen {
    /// For parameter m = k² and complementary parameter mc = 1 - m, each computed accurately.
    fn new(m: f64, mc: f64) -> Landen {
        let (mut k, mut kc) = (m.sqrt(), mc.sqrt());
        let mut landen = Landen {
            modulus: [0.0; MAX_LANDEN_LEVELS],
            complement: [0.0; MAX_LANDEN_LEVELS],
            levels: 0,
            argument_scale: 1.0,
            bottom_parameter: 0.0,
            complementary_parameter: mc,
        };
        while k > LANDEN_BOTTOM && landen.levels < MAX_LANDEN_LEVELS {
            // k1 = (1 - k')/(1 + k') = k²/(1 + k')², 1 - k1 = 2k'/(1 + k'), k1' = 2 sqrt(k')/(1 + k').
            let next = (k / (1.0 + kc)).powi(2);
            landen.modulus[landen.levels] = next;
            landen.complement[landen.levels] = 2.0 * kc / (1.0 + kc);
            landen.levels += 1;
            landen.argument_scale /= 1.0 + next;
            kc = 2.0 * kc.sqrt() / (1.0 + kc);
            k = next;
        }
        landen.bottom_parameter = k * k;
        landen
    }

    /// (sn u, cn u, dn u) for |u| <= K, where cn >= 0.
    #[inline]
    fn sn_cn_dn(&self, u: f64) -> (f64, f64, f64) {
        let (mut s, mut c) = (u * self.argument_scale).sin_cos();
        let mut d = 1.0 - 0.5 * self.bottom_parameter * s * s;
        for level in (0..self.levels).rev() {
            let (k, complement) = (self.modulus[level], self.complement[level]);
            let s2 = s * s;
            let denominator = 1.0 / (1.0 + k * s2);
            // 1 - k s² = c² + (1 - k) s²: no cancellation as k → 1.
            let next_d = (c * c + complement * s2) * denominator;
            c *= d * denominator;
            s *= (1.0 + k) * denominator;
            d = next_d;
        }
        // sn keeps about an ulp through the levels while the rounding of cn doubles per level
        // near m = 1. Where sn² <= 1/2, sqrt(1 - sn²) is the accurate cn; nearer its zero the
        // recursion keeps cn's absolute error at a few ulps. dn from sqrt(cn² + m' sn²)
        // (positive terms only) then inherits cn's accuracy.
        if s * s <= 0.5 {
            c = ((1.0 - s) * (1.0 + s)).sqrt();
        }
        (s, c, (c * c + self.complementary_parameter * s * s).sqrt())
    }
}

/// Carlson's R_F(x, y, z) = ½ ∫_0^∞ dt / sqrt((t+x)(t+y)(t+z)) for x, y, z >= 0, at most one
/// zero (Carlson 1995, duplication with a fifth-order series).
fn carlson_rf(x: f64, y: f64, z: f64) -> f64 {
    let mean0 = (x + y + z) / 3.0;
    // (3r)^(-1/6) for r = 2^-53.
    let bound = 385.0 * (mean0 - x).abs().max((mean0 - y).abs()).max((mean0 - z).abs());
    let (mut xm, mut ym, mut zm, mut mean, mut power) = (x, y, z, mean0, 1.0);
    for _ in 0..MAX_DUPLICATIONS {
        if bound * power < mean.abs() {
            break;
        }
        let (sx, sy, sz) = (xm.sqrt(), ym.sqrt(), zm.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        (xm, ym, zm, mean) = (0.25 * (xm + lambda), 0.25 * (ym + lambda), 0.25 * (zm + lambda), 0.25 * (mean + lambda));
        power *= 0.25;
    }
    let dx = (mean0 - x) * power / mean;
    let dy = (mean0 - y) * power / mean;
    let dz = -(dx + dy);
    let e2 = dx * dy - dz * dz;
    let e3 = dx * dy * dz;
    (1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0) / mean.sqrt()
}

/// Carlson's R_J(x, y, z, p) = 3/2 ∫_0^∞ dt / ((t+p) sqrt((t+x)(t+y)(t+z))) for x, y, z >= 0
/// (at most one zero) and p >= max(x, y, z), which is all this module needs: then every R_C
/// of the duplication is a circular one (Carlson 1995).
fn carlson_rj(x: f64, y: f64, z: f64, p: f64) -> f64 {
    let mean0 = (x + y + z + 2.0 * p) / 5.0;
    let delta = (p - x) * (p - y) * (p - z);
    // (r/4)^(-1/6) for r = 2^-53.
    let bound = 584.0 * (mean0 - x).abs().max((mean0 - y).abs()).max((mean0 - z).abs()).max((mean0 - p).abs());
    let (mut xm, mut ym, mut zm, mut pm, mut mean, mut power) = (x, y, z, p, mean0, 1.0);
    let mut sum = 0.0;
    for _ in 0..MAX_DUPLICATIONS {
        if bound * power < mean.abs() {
            break;
        }
        let (sx, sy, sz, sp) = (xm.sqrt(), ym.sqrt(), zm.sqrt(), pm.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        let d = (sp + sx) * (sp + sy) * (sp + sz);
        let e = power * power * power * delta / (d * d);
        sum += power * circular_rc(e) / d;
        (xm, ym, zm, pm, mean) = (
            0.25 * (xm + lambda),
            0.25 * (ym + lambda),
            0.25 * (zm + lambda),
            0.25 * (pm + lambda),
            0.25 * (mean + lambda),
        );
        power *= 0.25;
    }
    let dx = (mean0 - x) * power / mean;
    let dy = (mean0 - y) * power / mean;
    let dz = (mean0 - z) * power / mean;
    let dp = -0.5 * (dx + dy + dz);
    let e2 = dx * dy + dx * dz + dy * dz - 3.0 * dp * dp;
    let xyz = dx * dy * dz;
    let e3 = xyz + 2.0 * e2 * dp + 4.0 * dp * dp * dp;
    let e4 = (2.0 * xyz + e2 * dp + 3.0 * dp * dp * dp) * dp;
    let e5 = xyz * dp * dp;
    let series = 1.0 - 3.0 * e2 / 14.0 + e3 / 6.0 + 9.0 * e2 * e2 / 88.0 - 3.0 * e4 / 22.0 - 9.0 * e2 * e3 / 52.0
        + 3.0 * e5 / 26.0;
    power * series / (mean * mean.sqrt()) + 6.0 * sum
}

/// R_C(1, 1 + e) = atan(sqrt e) / sqrt e for e >= 0.
#[inline]
fn circular_rc(e: f64) -> f64 {
    // Below 2^-12 five terms of the series are exact to rounding.
    if e < 1.0 / 4096.0 {
        1.0 - e * (1.0 / 3.0 - e * (1.0 / 5.0 - e * (1.0 / 7.0 - e * (1.0 / 9.0))))
    } else {
        let root = e.sqrt();
        root.atan() / root
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫_a^b f by 5-point Gauss–Legendre on `panels` equal panels: an independent reference.
    fn quadrature(f: impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
        const NODES: [(f64, f64); 5] = [
            (0.0, 0.568_888_888_888_888_9),
            (-0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
            (0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
            (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
            (0.906_179_845_938_664, 0.236_926_885_056_189_1),
        ];
        let width = (b - a) / panels as f64;
        // Neumaier's compensated sum, so the reference is not limited by adding up the panels.
        let (mut sum, mut carry) = (0.0f64, 0.0);
        for i in 0..panels {
            let centre = a + (i as f64 + 0.5) * width;
            let term = NODES.iter().map(|&(x, w)| w * f(centre + 0.5 * width * x)).sum::<f64>() * 0.5 * width;
            let next = sum + term;
            carry += if sum.abs() >= term.abs() { (sum - next) + term } else { (term - next) + sum };
            sum = next;
        }
        sum + carry
    }

    fn close(a: f64, b: f64, tolerance: f64) -> bool {
        (a - b).abs() <= tolerance * b.abs().max(1.0)
    }

    #[test]
    fn carlson_matches_published_values() {
        // Carlson (1995), table of test values.
        assert!(close(carlson_rf(1.0, 2.0, 0.0), 1.311_028_777_146_1, 1e-13));
        assert!(close(carlson_rf(2.0, 3.0, 4.0), 0.584_082_841_677_15, 1e-13));
        assert!(close(carlson_rj(0.0, 1.0, 2.0, 3.0), 0.776_886_237_785_82, 1e-13));
        assert!(close(carlson_rj(2.0, 3.0, 4.0, 5.0), 0.142_975_796_671_57, 1e-13));
        // K(1/2) = R_F(0, 1/2, 1), and R_F(x, x, x) = x^-1/2, R_J(x, x, x, x) = x^-3/2 exactly.
        assert!(close(carlson_rf(0.0, 0.5, 1.0), 1.854_074_677_301_371_9, 2e-16));
        assert!(close(carlson_rf(4.0, 4.0, 4.0), 0.5, 1e-16));
        assert!(close(carlson_rj(4.0, 4.0, 4.0, 4.0), 0.125, 1e-16));
        // Homogeneity, and far-spread arguments still converge within the bound.
        assert!(close(carlson_rj(0.0, 1e-200, 1.0, 1e10), carlson_rj(0.0, 1e-196, 1e4, 1e14) * 1e6, 1e-14));
        assert!(carlson_rf(0.0, 1e-300, 1.0).is_finite());
    }

    #[test]
    fn jacobi_functions_satisfy_identities_and_derivatives() {
        for &m in &[0.0, 1e-12, 0.1, 0.5, 0.9, 0.999_999, 1.0 - 1e-12] {
            let mc = 1.0 - m;
            let landen = Landen::new(m, mc);
            let quarter = FRAC_PI_2 / landen.argument_scale;
            // K(m) = R_F(0, 1 - m, 1), an independent route.
            assert!(close(quarter, carlson_rf(0.0, mc, 1.0), 4e-15), "K({m})");
            let (s, c, d) = landen.sn_cn_dn(quarter);
            assert!(close(s, 1.0, 1e-15) && c.abs() < 1e-15 * quarter && close(d, mc.sqrt(), 1e-14), "at K, m = {m}");
            let (s, _, d) = landen.sn_cn_dn(0.5 * quarter);
            assert!(close(s, 1.0 / (1.0 + mc.sqrt()).sqrt(), 1e-14) && close(d, mc.sqrt().sqrt(), 1e-14));
            for i in -20..=20 {
                let u = quarter * i as f64 / 20.0;
                let (s, c, d) = landen.sn_cn_dn(u);
                // cn gathers a few ulps per Landen level (up to 8 levels here).
                let tolerance = 5e-16 * (1 + landen.levels) as f64;
                assert!((s * s + c * c - 1.0).abs() < tolerance, "sn²+cn² at m = {m}, u = {u}");
                assert!((d * d + m * s * s - 1.0).abs() < tolerance, "dn²+m sn² at m = {m}, u = {u}");
                // Fourth-order central differences: d sn = cn dn, d cn = -sn dn, d dn = -m sn cn.
                let h = 1e-3;
                let diff = |f: &dyn Fn(f64) -> f64| {
                    (8.0 * (f(u + h) - f(u - h)) - (f(u + 2.0 * h) - f(u - 2.0 * h))) / (12.0 * h)
                };
                assert!((diff(&|v| landen.sn_cn_dn(v).0) - c * d).abs() < 1e-9);
                assert!((diff(&|v| landen.sn_cn_dn(v).1) + s * d).abs() < 1e-9);
                assert!((diff(&|v| landen.sn_cn_dn(v).2) + m * s * c).abs() < 1e-9);
            }
        }
        // m = 0 is sin and cos; near m = 1, tanh and sech.
        let (s, c, d) = Landen::new(0.0, 1.0).sn_cn_dn(0.7);
        assert!(close(s, 0.7f64.sin(), 2e-16) && close(c, 0.7f64.cos(), 2e-16) && close(d, 1.0, 2e-16));
        let (s, c, d) = Landen::new(1.0 - 1e-30, 1e-30).sn_cn_dn(1.3);
        assert!(close(s, 1.3f64.tanh(), 1e-15) && close(c, 1.0 / 1.3f64.cosh(), 1e-14) && close(d, c, 1e-14));
    }

    #[test]
    fn third_kind_matches_its_integral() {
        for &(r, m) in &[(1e-12f64, 0.3f64), (0.5, 0.0), (0.5, 0.4), (3.0, 0.9), (1e3, 0.2), (1e8, 0.7), (2.0, 0.9)] {
            let mu = m / r;
            let wobble =
                Wobble { scale: 0.0, slope: 0.0, lambda: ((1.0 + r) * (1.0 + mu)).sqrt(), mu, rho: 0.0, offset: 0.0 };
            for i in 0..=8 {
                let phi = FRAC_PI_2 * i as f64 / 8.0;
                let (s, c) = phi.sin_cos();
                let delta = (c * c + (1.0 - m) * s * s).sqrt();
                // The integrand peaks over a width 1/sqrt(r) at 0: panels that double in width.
                let integrand = |t: f64| 1.0 / ((1.0 + r * t.sin().powi(2)) * (1.0 - m * t.sin().powi(2)).sqrt());
                let mut exact = 0.0;
                let mut start = 0.0;
                let mut width = 0.01 / (1.0 + r).sqrt();
                while start < phi {
                    let end = (start + width).min(phi);
                    exact += quadrature(integrand, start, end, 16);
                    (start, width) = (end, 2.0 * width);
                }
                let closed = wobble.third_kind(s, c.max(0.0), delta);
                assert!(
                    (closed - exact).abs() <= 2e-15 * exact.abs().max(1e-300) + 1e-16,
                    "r {r} m {m} φ {phi}: {closed} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn third_kind_matches_high_precision_values() {
        // Π(n; φ|m) from mpmath's ellippi at 30 digits.
        let cases = [
            (-2.0f64, FRAC_PI_2, 0.99f64, 1.679_409_341_379_721_2),
            (-1e8, PI / 16.0, 0.7, 1.570_300_498_411_03e-4),
            (-1e-12, 1.0, 1.0 - 1e-14, 1.226_191_170_883_128_2),
        ];
        for (n, phi, m, exact) in cases {
            let (r, mu) = (-n, -m / n);
            let wobble =
                Wobble { scale: 0.0, slope: 0.0, lambda: ((1.0 + r) * (1.0 + mu)).sqrt(), mu, rho: 0.0, offset: 0.0 };
            let (s, c) = phi.sin_cos();
            let closed = wobble.third_kind(s, c.max(0.0), (c * c + (1.0 - m) * s * s).sqrt());
            assert!(close(closed, exact, 3e-15), "Π({n}; {phi}|{m}) = {closed}, not {exact}");
        }
    }

    #[test]
    fn mean_rate_matches_quadrature_on_both_routes() {
        // I = (1, 2, 3), L = (l1, 0, 1) in working coordinates: m = d12 l1² / d23. Both sides of
        // m = 1/2 (8 nodes below, 16 above) and of the switch at m = 0.99 (trapezoid below,
        // complete integral above) against a brute mean.
        let (d12, d23, d13) = (0.5f64, 1.0 / 6.0, 2.0 / 3.0);
        for m in [1e-9, 0.3, 0.5 - 1e-12, 0.5 + 1e-12, 0.7, 0.99 - 1e-12, 0.99 + 1e-12, 0.999] {
            let l1 = (m * d23 / d12).sqrt();
            let orbit = BodyOrbit {
                l: DVec3::new(l1, 0.0, 1.0),
                d_xy: d12,
                d_yz: d23,
                d13,
                separation: d23 - d12 * l1 * l1,
                sense: 1.0,
            };
            let rate = orbit.tumbling(DVec3::new(1.0, 0.5, 1.0 / 3.0), 1.0).unwrap().0.precession_rate;
            let momentum = (1.0 + l1 * l1).sqrt();
            let landen = Landen::new(m, 1.0 - m);
            let quarter = FRAC_PI_2 / landen.argument_scale;
            // a1 = l1 and a3 = 1 as L_y = 0; dψ/dt = |L|/I_z + κ / (|L| + a3 dn), κ = a1² d13.
            let mean = quadrature(|u| 1.0 / (momentum + landen.sn_cn_dn(u).2), 0.0, quarter, 100) / quarter;
            let brute = momentum / 3.0 + l1 * l1 * d13 * mean;
            // The complete-integral route (m > 0.99) is good to a few ulps.
            let tolerance = if m <= TRAPEZOID_MAX_PARAMETER { 4e-16 } else { 3e-15 };
            assert!(close(rate, brute, tolerance), "m {m}: {rate} vs {brute}");
        }
    }

    #[test]
    fn each_kind_of_motion_takes_its_branch() {
        let kind =
            |inertia: DVec3, q: DQuat, body_omega: DVec3| match FreeRotation::new(inertia, q, q * body_omega).motion {
                Motion::Steady { .. } => "steady",
                Motion::Tumbling(Tumbling { orbit: Orbit::Separatrix { .. }, .. }) => "separatrix",
                Motion::Tumbling(Tumbling { orbit: Orbit::Periodic { wobble: None, .. }, .. }) => "symmetric",
                Motion::Tumbling(_) => "asymmetric",
            };
        let (brick, turned) = (DVec3::new(1.0, 2.0, 3.0), DQuat::from_euler(glam::EulerRot::XYZ, 0.9, -0.2, 2.4));
        assert_eq!(kind(brick, turned, DVec3::new(0.3, 1.0, 0.2)), "asymmetric");
        // About the intermediate axis, through a frame change that rounds.
        assert_eq!(kind(brick, turned, DVec3::new(0.0, 2.0, 0.0)), "steady");
        // d23 L3² = d12 L1² to rounding: on the separatrix.
        assert_eq!(kind(brick, turned, DVec3::new(1.0, 0.05, 3f64.sqrt() / 3.0)), "separatrix");
        assert_eq!(kind(DVec3::new(1.0, 1.0, 2.0), turned, DVec3::new(0.3, 1.0, 0.2)), "symmetric");
        assert_eq!(kind(DVec3::new(1.0, 1.0, 2.0), turned, DVec3::new(0.3, 1.0, 0.0)), "steady");
        assert_eq!(kind(DVec3::ONE, turned, DVec3::new(0.3, 1.0, 0.2)), "steady");
        assert_eq!(kind(brick, turned, DVec3::ZERO), "steady");
    }

    #[test]
    fn landen_descends_to_the_bottom_for_every_normal_parameter() {
        for mc in [1.0, 0.5, 1e-16, 1e-100, f64::MIN_POSITIVE] {
            let landen = Landen::new(1.0 - mc, mc);
            assert!(landen.bottom_parameter <= LANDEN_BOTTOM * LANDEN_BOTTOM, "m' = {mc:e}: {} levels", landen.levels);
            assert!(landen.levels <= MAX_LANDEN_LEVELS);
        }
    }
}
