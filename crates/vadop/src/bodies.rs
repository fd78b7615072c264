//! The body store: the state of every sphere in flat arrays, indexed by body id.
//!
//! Inside the engine a body's id is its slot index, reused after a removal; users name bodies by
//! [`BodyHandle`], the slot and its generation. The store owns each body's motion and bounding
//! radius, its mass, the per-body velocity stamp that voids stale predictions and each slot's
//! generation. It never moves bodies on its own or knows about axes or contacts. A position is
//! stored together with the time it refers to (`since`), so a body that changed velocity
//! mid-frame is evaluated exactly as p(t) = p + (t - since) * v by every method alike.
//! The motion and the radius share one cache line per body ([`BodyState`]): it is what the
//! narrow phase reads for a candidate pair, and the proxy table reads it from here rather than
//! keeping a copy.

use crate::handle::BodyHandle;
use crate::narrow_phase::Motion;
use crate::proxy::prefetch;
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

/// What the narrow phase needs of a body, in one cache line: its straight motion since its last
/// velocity change and the radius of the sphere about its centre that holds the whole body.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub struct BodyState {
    pub motion: Motion,
    pub radius: f64,
}

impl Default for BodyState {
    fn default() -> Self {
        BodyState { motion: Motion { position: DVec3::ZERO, since: 0.0, velocity: DVec3::ZERO }, radius: 0.0 }
    }
}

/// Flat store of all bodies; removed slots stay until reused (lowest first, by the world).
#[derive(Debug, Default, Clone)]
pub struct Bodies {
    /// Motion and radius of each body.
    pub state: Vec<BodyState>,
    pub mass: Vec<f64>,
    /// Bumped on every velocity change (and on removal): predictions made earlier are void.
    pub stamp: Vec<u32>,
    pub alive: Vec<bool>,
    /// Of a live slot, its body's generation; of a removed one, the generation its next body
    /// gets (above [`BodyHandle::MAX_GENERATION`]: retired, never reused).
    pub(crate) generation: Vec<u32>,
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
        self.state.len()
    }

    /// Centre of body `i` at absolute time `t`.
    #[inline]
    pub fn position_at(&self, i: usize, t: f64) -> DVec3 {
        self.state[i].motion.at(t)
    }

    /// Body `i`'s straight motion since its last velocity change.
    #[inline]
    pub fn motion(&self, i: usize) -> Motion {
        self.state[i].motion
    }

    /// Velocity of body `i`.
    #[inline]
    pub fn velocity(&self, i: usize) -> DVec3 {
        self.state[i].motion.velocity
    }

    /// Asks for the cache lines of body `i`'s state, stamp and liveness ahead of their use (a
    /// hint: nothing changes).
    #[inline]
    pub fn prefetch(&self, i: usize) {
        if i < self.slots() {
            prefetch(&self.state[i]);
            prefetch(&self.stamp[i]);
            prefetch(&self.alive[i]);
        }
    }

    /// Inverse mass of body `i`, computed rather than stored: 8 bytes per body less, for a
    /// division only where a response needs it.
    #[inline]
    pub fn inverse_mass(&self, i: usize) -> f64 {
        1.0 / self.mass[i]
    }

    /// Radius of sphere `i`.
    #[inline]
    pub fn radius(&self, i: usize) -> f64 {
        self.state[i].radius
    }

    /// Radius of the sphere about body `i`'s centre that holds the whole body: all the broad
    /// phase needs of its shape.
    #[inline]
    pub fn bounding_radius(&self, i: usize) -> f64 {
        self.state[i].radius
    }

    /// Makes room for `additional` more slots, exactly: a world built from a scene of a million
    /// bodies holds a million slots, not the next power of two.
    pub(crate) fn reserve(&mut self, additional: usize) {
        self.state.reserve_exact(additional);
        self.mass.reserve_exact(additional);
        self.stamp.reserve_exact(additional);
        self.alive.reserve_exact(additional);
        self.generation.reserve_exact(additional);
    }

    /// Writes `sphere` into slot `i`, appending when `i` is one past the end; a reused slot keeps
    /// the generation its last removal set.
    pub(crate) fn put(&mut self, i: usize, sphere: Sphere, time: f64) {
        self.speed_bound = self.speed_bound.max(speed(sphere.velocity));
        let state = BodyState {
            motion: Motion { position: sphere.position, since: time, velocity: sphere.velocity },
            radius: sphere.radius,
        };
        if i == self.slots() {
            self.state.push(state);
            self.mass.push(sphere.mass);
            self.stamp.push(0);
            self.alive.push(true);
            self.generation.push(0);
        } else {
            self.state[i] = state;
            self.mass[i] = sphere.mass;
            self.stamp[i] = self.stamp[i].wrapping_add(1);
            self.alive[i] = true;
        }
    }

    /// Empties slot `i`: voids the body's predictions and moves the slot on to its next
    /// generation, so the body's handle names nothing from now on.
    pub(crate) fn remove(&mut self, i: usize) {
        self.alive[i] = false;
        self.stamp[i] = self.stamp[i].wrapping_add(1);
        self.generation[i] += 1;
    }

    /// The handle of the body in live slot `i`.
    #[inline]
    pub fn handle(&self, i: usize) -> BodyHandle {
        BodyHandle::new(i as u32, self.generation[i])
    }

    /// True when removed slot `i` may hold another body: its generation has not run out.
    pub(crate) fn is_reusable(&self, i: usize) -> bool {
        self.generation[i] <= BodyHandle::MAX_GENERATION
    }

    /// Moves body `i` to time `t` and gives it a new velocity, voiding its predictions.
    #[inline]
    pub(crate) fn set_velocity_at(&mut self, i: usize, t: f64, velocity: DVec3) {
        self.state[i].motion = Motion { position: self.position_at(i, t), since: t, velocity };
        self.stamp[i] = self.stamp[i].wrapping_add(1);
        self.speed_bound = self.speed_bound.max(speed(velocity));
    }

    /// Sets the speed bound to the speed of the fastest live body, and returns it.
    pub(crate) fn tighten_speed_bound(&mut self) -> f64 {
        self.speed_bound = self.alive_ids().map(|i| speed(self.velocity(i as usize))).fold(0.0, f64::max);
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
            velocity: self.velocity(i),
            radius: self.radius(i),
            mass: self.mass[i],
        }
    }

    /// Ids of live bodies, ascending.
    pub fn alive_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.alive.iter().enumerate().filter(|(_, &a)| a).map(|(i, _)| i as u32)
    }
}
