//! The body store: structure-of-arrays state of every sphere, indexed by body id.
//!
//! It owns positions, velocities, radii, masses and the per-body velocity stamp that voids stale
//! predictions. It never moves bodies on its own or knows about axes or contacts. A position is
//! stored together with the time it refers to (`since`), so a body that changed velocity mid-frame
//! is evaluated exactly as p(t) = p + (t - since) * v by every method alike.

use crate::narrow_phase::Motion;
use glam::DVec3;

/// One sphere as users see it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sphere {
    /// Centre position.
    pub position: DVec3,
    /// Linear velocity (units per second).
    pub velocity: DVec3,
    /// Radius, > 0.
    pub radius: f64,
    /// Mass, > 0.
    pub mass: f64,
}

/// Structure-of-arrays store of all bodies; removed slots stay until reused.
#[derive(Debug, Default, Clone)]
pub struct Bodies {
    /// Centre at time `since`.
    pub position: Vec<DVec3>,
    pub velocity: Vec<DVec3>,
    /// Time at which `position` holds.
    pub since: Vec<f64>,
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
    pub inv_mass: Vec<f64>,
    /// Bumped on every velocity change (and on removal): predictions made earlier are void.
    pub stamp: Vec<u32>,
    pub alive: Vec<bool>,
    /// No live body is faster than this: raised by every velocity written and lowered only by
    /// `Bodies::tighten_speed_bound`, so a step need not read every body to rule out an absurd
    /// speed.
    pub speed_bound: f64,
}

/// The length of `velocity`, robust to squares that underflow: below about 1e-162 the largest
/// component stands in for it.
#[inline]
pub fn speed(velocity: DVec3) -> f64 {
    let length = velocity.length();
    if length > 0.0 {
        length
    } else {
        velocity.abs().max_element()
    }
}

impl Bodies {
    /// Number of slots, removed ones included.
    pub fn slots(&self) -> usize {
        self.position.len()
    }

    /// Centre of body `i` at absolute time `t`.
    #[inline]
    pub fn position_at(&self, i: usize, t: f64) -> DVec3 {
        self.position[i] + (t - self.since[i]) * self.velocity[i]
    }

    /// Body `i`'s straight motion since its last velocity change.
    #[inline]
    pub fn motion(&self, i: usize) -> Motion {
        Motion { position: self.position[i], since: self.since[i], velocity: self.velocity[i] }
    }

    /// Radius of the sphere about body `i`'s centre that holds the whole body: all the broad
    /// phase needs of its shape.
    #[inline]
    pub fn bounding_radius(&self, i: usize) -> f64 {
        self.radius[i]
    }

    /// Writes `sphere` into slot `i`, appending when `i` is one past the end.
    pub(crate) fn put(&mut self, i: usize, sphere: Sphere, time: f64) {
        self.speed_bound = self.speed_bound.max(speed(sphere.velocity));
        if i == self.slots() {
            self.position.push(sphere.position);
            self.velocity.push(sphere.velocity);
            self.since.push(time);
            self.radius.push(sphere.radius);
            self.mass.push(sphere.mass);
            self.inv_mass.push(1.0 / sphere.mass);
            self.stamp.push(0);
            self.alive.push(true);
        } else {
            self.position[i] = sphere.position;
            self.velocity[i] = sphere.velocity;
            self.since[i] = time;
            self.radius[i] = sphere.radius;
            self.mass[i] = sphere.mass;
            self.inv_mass[i] = 1.0 / sphere.mass;
            self.stamp[i] = self.stamp[i].wrapping_add(1);
            self.alive[i] = true;
        }
    }

    /// Moves body `i` to time `t` and gives it a new velocity, voiding its predictions.
    #[inline]
    pub(crate) fn set_velocity_at(&mut self, i: usize, t: f64, velocity: DVec3) {
        self.position[i] = self.position_at(i, t);
        self.since[i] = t;
        self.velocity[i] = velocity;
        self.stamp[i] = self.stamp[i].wrapping_add(1);
        self.speed_bound = self.speed_bound.max(speed(velocity));
    }

    /// Sets the speed bound to the speed of the fastest live body, and returns it.
    pub(crate) fn tighten_speed_bound(&mut self) -> f64 {
        self.speed_bound = self.alive_ids().map(|i| speed(self.velocity[i as usize])).fold(0.0, f64::max);
        self.speed_bound
    }

    /// Voids body `i`'s predictions without changing its motion (its proxy is being renewed).
    #[inline]
    pub(crate) fn renew(&mut self, i: usize) {
        self.stamp[i] = self.stamp[i].wrapping_add(1);
    }

    /// The sphere in slot `i` as of time `t`.
    pub fn sphere_at(&self, i: usize, t: f64) -> Sphere {
        Sphere {
            position: self.position_at(i, t),
            velocity: self.velocity[i],
            radius: self.radius[i],
            mass: self.mass[i],
        }
    }

    /// Ids of live bodies, ascending.
    pub fn alive_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.alive.iter().enumerate().filter(|(_, &a)| a).map(|(i, _)| i as u32)
    }
}
