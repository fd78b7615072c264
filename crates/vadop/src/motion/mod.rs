//! Motion between velocity changes: a body's straight or parabolic path ([`Motion`]), how its orientation
//! evolves ([`Spin`]: fixed, or the exact torque-free rotation of [`free_rotation`]), and the two
//! together ([`RigidMotion`]). Every stage evaluates a body's place and orientation through these
//! types, so all of them see the same bits; they never change a body nor know about contacts.

pub mod free_rotation;
pub mod hold;

pub use free_rotation::FreeRotation;

use glam::{DQuat, DVec3};

/// A body's straight motion: at `since` its centre is at `position`, then it moves with `velocity`.
/// In declaration order: a pair screen loads the position and `since` as one row of four.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct Motion {
    pub position: DVec3,
    pub since: f64,
    pub velocity: DVec3,
}

impl Motion {
    /// Centre at time `t`.
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.position + (t - self.since) * self.velocity
    }

    /// The motion on from time `t` with `velocity`, from where this one's centre is then under
    /// `gravity`.
    #[inline]
    pub fn moved_on(&self, t: f64, velocity: DVec3, gravity: DVec3) -> Motion {
        Motion { position: self.at_under(t, gravity), since: t, velocity }
    }

    /// Centre at time `t` under the uniform acceleration `gravity`: a parabola from `position`
    /// with `velocity` at `since` (the straight path, to the bit, without gravity).
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::motion::Motion;
    /// let thrown = Motion { position: DVec3::ZERO, since: 1.0, velocity: DVec3::new(1.0, 0.0, 4.0) };
    /// let g = DVec3::new(0.0, 0.0, -2.0);
    /// assert_eq!(thrown.at_under(3.0, g), DVec3::new(2.0, 0.0, 4.0));
    /// assert_eq!(thrown.velocity_under(3.0, g), DVec3::new(1.0, 0.0, 0.0));
    /// ```
    #[inline]
    pub fn at_under(&self, t: f64, gravity: DVec3) -> DVec3 {
        if gravity == DVec3::ZERO {
            return self.at(t);
        }
        let tau = t - self.since;
        self.position + tau * self.velocity + (0.5 * tau * tau) * gravity
    }

    /// Velocity at time `t` under the uniform acceleration `gravity`.
    #[inline]
    pub fn velocity_under(&self, t: f64, gravity: DVec3) -> DVec3 {
        if gravity == DVec3::ZERO {
            return self.velocity;
        }
        self.velocity + (t - self.since) * gravity
    }
}

/// How a body's orientation evolves since its last velocity change: the exact torque-free
/// rotation for a free body, [`Fixed`] for one that never turns.
pub trait Spin {
    /// The orientation (rotating body-frame vectors to world vectors) `dt` after the body's last
    /// velocity change.
    fn orientation_at(&self, dt: f64) -> DQuat;
    /// Upper bound on the body's angular speed |w| over all time.
    fn max_angular_speed(&self) -> f64;
    /// The constant angular velocity in the body's own frame when the rotation is steady (zero
    /// for a body that does not turn), `None` when it may change: what tells a spin that leaves
    /// a symmetric shape where it is.
    fn steady_spin(&self) -> Option<DVec3> {
        None
    }
    /// The world angular velocity `dt` after the body's last velocity change (the derivative of
    /// [`Self::orientation_at`]), `None` when unknown. With [`Self::max_angular_acceleration`] it
    /// predicts turning to first order and bounds the rest, where the speed bound alone would
    /// take every point to move at its worst.
    fn angular_velocity_at(&self, _dt: f64) -> Option<DVec3> {
        None
    }
    /// Upper bound on |dω/dt| over all time (world frame): infinite when unknown.
    fn max_angular_acceleration(&self) -> f64 {
        f64::INFINITY
    }
    /// [`Self::orientation_at`] and [`Self::angular_velocity_at`] together, the same values:
    /// for spins that find both from one costly step.
    fn orientation_and_angular_velocity_at(&self, dt: f64) -> (DQuat, Option<DVec3>) {
        (self.orientation_at(dt), self.angular_velocity_at(dt))
    }
}

impl<S: Spin + ?Sized> Spin for &S {
    fn orientation_at(&self, dt: f64) -> DQuat {
        (**self).orientation_at(dt)
    }
    fn max_angular_speed(&self) -> f64 {
        (**self).max_angular_speed()
    }
    fn steady_spin(&self) -> Option<DVec3> {
        (**self).steady_spin()
    }
    fn angular_velocity_at(&self, dt: f64) -> Option<DVec3> {
        (**self).angular_velocity_at(dt)
    }
    fn max_angular_acceleration(&self) -> f64 {
        (**self).max_angular_acceleration()
    }
    fn orientation_and_angular_velocity_at(&self, dt: f64) -> (DQuat, Option<DVec3>) {
        (**self).orientation_and_angular_velocity_at(dt)
    }
}

/// A spin that never turns: a constant orientation, angular speed bound 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fixed(pub DQuat);

impl Spin for Fixed {
    fn orientation_at(&self, _dt: f64) -> DQuat {
        self.0
    }
    fn max_angular_speed(&self) -> f64 {
        0.0
    }
    fn steady_spin(&self) -> Option<DVec3> {
        Some(DVec3::ZERO)
    }
    fn angular_velocity_at(&self, _dt: f64) -> Option<DVec3> {
        Some(DVec3::ZERO)
    }
    fn max_angular_acceleration(&self) -> f64 {
        0.0
    }
}

/// A body's motion since its last velocity change: centre of mass `position` at time `since`,
/// moving with `velocity` then under the uniform `acceleration` (gravity; zero for a straight
/// path), spinning per `spin`. A uniform acceleration exerts no torque: the spin is that of a
/// free body whatever the acceleration.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::motion::{Fixed, RigidMotion};
/// let m = RigidMotion { position: DVec3::ZERO, since: 1.0, velocity: DVec3::X, acceleration: DVec3::ZERO, spin: Fixed(DQuat::IDENTITY) };
/// assert_eq!(m.position_at(3.0), DVec3::new(2.0, 0.0, 0.0));
/// // Thrown up under gravity: back at its height after 2 v / g, falling as fast as it rose.
/// let thrown = RigidMotion { velocity: DVec3::new(0.0, 0.0, 4.0), acceleration: DVec3::new(0.0, 0.0, -2.0), ..m };
/// assert_eq!(thrown.position_at(5.0), DVec3::ZERO);
/// assert_eq!(thrown.velocity_at(5.0), DVec3::new(0.0, 0.0, -4.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion<S> {
    /// Centre of mass at `since`.
    pub position: DVec3,
    /// The time of the last velocity change.
    pub since: f64,
    /// Velocity of the centre of mass at `since`.
    pub velocity: DVec3,
    /// The centre's uniform acceleration: its path is a parabola (straight when zero).
    pub acceleration: DVec3,
    /// Orientation as a function of the time since `since`.
    pub spin: S,
}

impl<S: Spin> RigidMotion<S> {
    /// The path of the centre of mass, without the spin.
    #[inline]
    pub fn path(&self) -> Motion {
        Motion { position: self.position, since: self.since, velocity: self.velocity }
    }
    /// Centre of mass at absolute time `t`: the bits of [`Motion::at_under`].
    #[inline]
    pub fn position_at(&self, t: f64) -> DVec3 {
        self.path().at_under(t, self.acceleration)
    }
    /// Velocity of the centre of mass at absolute time `t`.
    #[inline]
    pub fn velocity_at(&self, t: f64) -> DVec3 {
        self.path().velocity_under(t, self.acceleration)
    }
    /// Orientation at absolute time `t`.
    pub fn orientation_at(&self, t: f64) -> DQuat {
        self.spin.orientation_at(t - self.since)
    }
}

impl RigidMotion<Fixed> {
    /// A body that never moves: at `position` with `orientation` from time `since` on.
    pub fn fixed(position: DVec3, orientation: DQuat, since: f64) -> Self {
        RigidMotion { position, since, velocity: DVec3::ZERO, acceleration: DVec3::ZERO, spin: Fixed(orientation) }
    }
}
