//! The world: bodies in a box, stepped frame by frame, with every contact of the frame reported
//! in time order.
//!
//! It is the thin front of the library: it owns the bodies and the settings, validates every
//! input before anything changes, and hands each frame to the method's engine — the frame
//! pipeline of a continuous method (`pipeline`) over its broad phase, or the
//! pseudo-dynamic stepper. The methods differ only in where candidate pairs come from; the narrow
//! phase, queue and response are shared, so every continuous method and the brute-force oracle
//! produce bit-identical contact sequences. It never decides what touches or how bodies respond.

use crate::axis_pool::AxisPool;
use crate::bodies::{Bodies, BodyTag, Rest, Sphere};
use crate::broad_phase::sweep_prune::SweepPrune;
use crate::error::{check_length, check_magnitude, check_vector, Result, VadopError};
use crate::frame::{Contact, FrameStats, Mode, Touched};
use crate::frame::{Output, Physics};
use crate::handle::BodyHandle;
use crate::parallel::Workers;
use crate::response::rules::ContactRules;
use crate::walls::{BoxBounds, MIN_PERIODIC_DIAMETERS};
use glam::DVec3;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

mod config;
mod engine;

use engine::Engine;
pub(crate) mod overlap;
mod rigid;
mod snapshot;
mod transfer;
mod wake;

pub use config::{Method, WorldConfig, AUTO_POOL_AXES, MAX_BOX_LENGTHS_PER_FRAME};
pub use rigid::{Body, BodyShape, ShapeId};
pub use transfer::SphereRecord;

/// Most body slots a world holds: below 2^31, so the event loop's cells can keep a flag in the
/// top bit of a body's index (2^31 bodies would take hundreds of GiB anyway).
const MAX_SLOTS: usize = (1 << 31) - 2;
/// Bounces a body may make on one wall in one step under gravity where bodies may not come to
/// rest (elastic or detect mode: see [`crate::response::rest`]): a body resting on a floor
/// would make infinitely many. One that nearly rests makes
/// thousands, which an elastic pile under strong gravity leaves in its floor layer, at a cost of
/// well under a microsecond each; a million in a step is a body at rest.
pub const MAX_BOUNCES_PER_STEP: f64 = 1e6;

/// A world of bodies in a box: spheres, rigid bodies of any shape and static level geometry.
///
/// ```
/// use glam::DVec3;
/// use vadop::{BoxBounds, Sphere, Touched, World, WorldConfig};
/// let mut world = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
/// let a = world.add_sphere(Sphere { position: DVec3::new(2.0, 5.0, 5.0), velocity: DVec3::new(30.0, 0.0, 0.0), radius: 0.5, mass: 1.0 }).unwrap();
/// let b = world.add_sphere(Sphere { position: DVec3::new(8.0, 5.0, 5.0), velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 }).unwrap();
/// // At 30 units/s the gap of 5 closes in 1/6 s, inside a frame of 1/4 s: a discrete check at
/// // the frame end would find them apart again; the continuous step finds the contact.
/// let contacts = world.step(0.25).unwrap();
/// assert_eq!((contacts[0].body, contacts[0].touched), (a, Touched::Body(b)));
/// assert!((contacts[0].time - 5.0 / 30.0).abs() < 1e-12);
/// // Equal masses: the velocities were exchanged.
/// assert!(world.sphere(a).unwrap().velocity.x.abs() < 1e-12);
/// ```
#[derive(Debug)]
pub struct World {
    config: WorldConfig,
    bounds: BoxBounds,
    bodies: Bodies,
    live: usize,
    /// Removed slots that may be reused, highest first (the lowest is popped).
    free_slots: Vec<u32>,
    /// Added since the last step: validated and entered into the engine at the next step.
    unplaced: Vec<u32>,
    /// Built at the first step (see [`engine::build`]).
    engine: Option<Box<dyn Engine>>,
    /// Bodies that lay still, moved or removed by the caller since the last step: where they
    /// were and their radii (see `wake`).
    released: Vec<(DVec3, f64)>,
    /// The threads of the frame pipeline (none with one thread).
    threads: Option<rayon::ThreadPool>,
    pool: Arc<AxisPool>,
    time: f64,
    /// The shapes users added (ascending ids among the store's shapes, which also hold one per
    /// plain sphere radius once the world has rigid bodies).
    user_shapes: Vec<u32>,
    contacts: Vec<Contact>,
    /// The contacts that ended in the last frame (when [`WorldConfig::contact_ends`] is on).
    ends: Vec<Contact>,
    stats: FrameStats,
    /// Raised by the caller to stop the step in progress (see [`World::set_interrupt`]).
    interrupt: Option<Arc<AtomicBool>>,
    /// Where the threads working on a step find `interrupt` while the step may be interrupted.
    watched: Arc<crate::interrupt::Slot>,
    /// Last contacts of bodies added with their history before the engine (which keeps the
    /// history) was built: given to it when it is.
    history: Vec<(u32, f64)>,
}

/// What a step that may be interrupted must put back: what the engine keeps besides the bodies
/// (which keep their own undo), and the bodies waiting to be entered.
struct BeforeStep {
    waiting: Vec<u32>,
    speed_bound: f64,
    rules: ContactRules,
    /// The pairs in contact, with their starts.
    touching: (Vec<(u32, u32)>, Vec<f64>),
}

impl World {
    /// An empty world. Fails on a bad box, restitution, contact duration, pool size or phi.
    pub fn new(bounds: BoxBounds, config: WorldConfig) -> Result<World> {
        let bounds = BoxBounds::new(bounds.min, bounds.max)?.with_periodic(bounds.periodic);
        if !(0.0..=1.0).contains(&config.restitution) {
            return Err(VadopError::BadRestitution(config.restitution));
        }
        if !(config.friction.is_finite() && config.friction >= 0.0) {
            return Err(VadopError::BadFriction(config.friction));
        }
        if !(config.contact_duration.is_finite() && config.contact_duration >= 0.0) {
            return Err(VadopError::BadContactDuration(config.contact_duration));
        }
        if config.threads == Some(0) {
            return Err(VadopError::BadThreads);
        }
        if config.contact_ends && config.mode != Mode::Detect {
            return Err(VadopError::ContactEndsNeedDetectMode);
        }
        if !config.gravity.is_finite() {
            return Err(VadopError::BadGravity(config.gravity.to_array()));
        }
        let pool = AxisPool::new(config.pool_axes.unwrap_or(AUTO_POOL_AXES))?;
        check_phi(config.phi.unwrap_or(pool.covering_radius()), &pool)?;
        Ok(World {
            config,
            bounds,
            bodies: Bodies::new(config.gravity, bounds.periodic_part(), config.mode),
            live: 0,
            free_slots: Vec::new(),
            unplaced: Vec::new(),
            engine: None,
            released: Vec::new(),
            threads: None,
            pool,
            time: 0.0,
            user_shapes: Vec::new(),
            contacts: Vec::new(),
            ends: Vec::new(),
            stats: FrameStats::default(),
            interrupt: None,
            watched: Arc::default(),
            history: Vec::new(),
        })
    }

    /// Adds a sphere; returns its handle. The slots of removed bodies are reused, lowest first,
    /// each under a new generation, so the handles of removed bodies stay stale.
    pub fn add_sphere(&mut self, sphere: Sphere) -> Result<BodyHandle> {
        self.check_sphere(&sphere)?;
        self.place_with(|bodies, slot, time| bodies.put(slot, sphere, time))
    }

    /// Takes the lowest free slot for a validated body that `write` puts there at the world's
    /// time; the engine enters it at the next step.
    fn place_with(&mut self, write: impl FnOnce(&mut Bodies, usize, f64)) -> Result<BodyHandle> {
        self.check_room(1)?;
        let slot = self.free_slots.pop().unwrap_or(self.bodies.slots() as u32);
        write(&mut self.bodies, slot as usize, self.time);
        match self.rules_mut() {
            Some(rules) => rules.forget(slot as usize),
            None => self.history.retain(|&(kept, _)| kept != slot),
        }
        self.live += 1;
        self.unplaced.push(slot);
        Ok(self.bodies.handle(slot as usize))
    }

    /// Adds many spheres at once, all or none. An error names the first bad sphere by its index
    /// in `spheres` ([`VadopError::InSphere`]).
    pub fn add_spheres(&mut self, spheres: &[Sphere]) -> Result<Vec<BodyHandle>> {
        for (index, s) in spheres.iter().enumerate() {
            self.check_sphere(s).map_err(|e| VadopError::InSphere { index, source: Box::new(e) })?;
        }
        self.check_room(spheres.len())?;
        self.bodies.reserve(spheres.len().saturating_sub(self.free_slots.len()));
        self.unplaced.reserve_exact(spheres.len());
        let mut handles = Vec::with_capacity(spheres.len());
        for s in spheres {
            handles.push(self.add_sphere(*s)?);
        }
        Ok(handles)
    }

    /// Removes a body and returns it as it was now. Its handle is stale from now on.
    pub fn remove_sphere(&mut self, handle: BodyHandle) -> Result<Sphere> {
        let sphere = self.sphere(handle)?;
        self.remove_slot(handle)?;
        Ok(sphere)
    }

    /// Empties the slot of the live body `handle`.
    fn remove_slot(&mut self, handle: BodyHandle) -> Result<()> {
        let i = self.live_slot(handle)?;
        let slot = i as u32;
        self.release(i);
        self.bodies.remove(i);
        self.live -= 1;
        self.unplaced.retain(|&u| u != slot);
        if let Some(engine) = &mut self.engine {
            engine.remove(slot);
        }
        if self.bodies.is_reusable(i) {
            self.free_slots.push(slot);
            // Pop the lowest slot first.
            self.free_slots.sort_unstable_by(|a, b| b.cmp(a));
        }
        Ok(())
    }

    /// Fails when `more` bodies would not fit the slots.
    fn check_room(&self, more: usize) -> Result<()> {
        if self.used_slots() + more > MAX_SLOTS {
            return Err(VadopError::TooManyBodies(MAX_SLOTS));
        }
        Ok(())
    }

    /// Sets a moving body's velocity (between frames); it goes on spinning as it did.
    pub fn set_velocity(&mut self, handle: BodyHandle, velocity: DVec3) -> Result<()> {
        let i = self.moving_slot(handle)?;
        check_vector("velocity", velocity)?;
        self.release(i);
        self.bodies.set_velocity_at(i, self.time, velocity);
        self.reenter(i);
        Ok(())
    }

    /// Sets the velocities of the bodies `handles` (between frames), all or none.
    pub fn set_velocities(&mut self, handles: &[BodyHandle], velocities: &[DVec3]) -> Result<()> {
        if handles.len() != velocities.len() {
            return Err(VadopError::LengthMismatch { handles: handles.len(), velocities: velocities.len() });
        }
        for (&handle, &velocity) in handles.iter().zip(velocities) {
            self.moving_slot(handle)?;
            check_vector("velocity", velocity)?;
        }
        for (&handle, &velocity) in handles.iter().zip(velocities) {
            self.set_velocity(handle, velocity)?;
        }
        Ok(())
    }

    /// The sphere `handle` now; [`VadopError::NotASphere`] for a body of another shape (see
    /// [`World::body`]).
    pub fn sphere(&self, handle: BodyHandle) -> Result<Sphere> {
        let i = self.live_slot(handle)?;
        if !self.bodies.is_sphere(i) || self.bodies.is_fixed(i) {
            return Err(VadopError::NotASphere(handle));
        }
        Ok(self.bodies.sphere_at(i, self.time))
    }

    /// How many times body `handle`'s centre crossed the faces of each periodic axis (x, y, z):
    /// +1 for each crossing out through the face at the box's maximum, -1 through the minimum
    /// (zero on walled axes). Positions stay inside the box; the body's path unwrapped is its
    /// position plus these times the box's sides.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::{BoxBounds, Sphere, World, WorldConfig};
    /// let periodic = BoxBounds::cube(10.0)?.with_periodic([true, false, false]);
    /// let mut world = World::new(periodic, WorldConfig::default())?;
    /// let ball = world.add_sphere(Sphere { position: DVec3::splat(5.0), velocity: DVec3::new(4.0, 0.0, 0.0), radius: 0.5, mass: 1.0 })?;
    /// world.step(2.0)?;
    /// // It left through x = 10 after 1.25 and came back in at x = 0: now at x = 3.
    /// assert!((world.sphere(ball)?.position.x - 3.0).abs() < 1e-12);
    /// assert_eq!(world.crossings(ball)?, [1, 0, 0]);
    /// # Ok::<(), vadop::VadopError>(())
    /// ```
    pub fn crossings(&self, handle: BodyHandle) -> Result<[i64; 3]> {
        Ok(self.bodies.crossings_of(self.live_slot(handle)?))
    }

    /// How a body is held up under gravity (see [`Rest`]): falling, sliding on a wall or lying
    /// still. Bodies come to rest only in simulate mode with restitution below 1.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::{BoxBounds, Rest, Sphere, World, WorldConfig};
    /// let config = WorldConfig { gravity: DVec3::new(0.0, 0.0, -9.81), restitution: 0.5, ..WorldConfig::default() };
    /// let mut world = World::new(BoxBounds::cube(10.0)?, config)?;
    /// let ball = world.add_sphere(Sphere { position: DVec3::new(5.0, 5.0, 2.0), velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 })?;
    /// assert_eq!(world.rest(ball)?, Rest::Falling);
    /// world.step(3.0)?;
    /// assert_eq!(world.rest(ball)?, Rest::Still);
    /// assert!((world.sphere(ball)?.position.z - 0.5).abs() < 1e-9);
    /// # Ok::<(), vadop::VadopError>(())
    /// ```
    pub fn rest(&self, handle: BodyHandle) -> Result<Rest> {
        Ok(self.bodies.rest_of(self.live_slot(handle)?))
    }

    /// The live bodies that are moving spheres, with their handles, in ascending order of handle
    /// (and slot): every body of a world of spheres. [`World::bodies`] lists every shape.
    pub fn spheres(&self) -> impl Iterator<Item = (BodyHandle, Sphere)> + '_ {
        self.moving_ids()
            .filter(|&i| self.bodies.is_sphere(i))
            .map(|i| (self.bodies.handle(i), self.bodies.sphere_at(i, self.time)))
    }

    /// Number of live bodies.
    pub fn len(&self) -> usize {
        self.live
    }
    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.live == 0
    }
    /// Current simulation time.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// The box.
    pub fn bounds(&self) -> BoxBounds {
        self.bounds
    }
    /// The settings.
    pub fn config(&self) -> WorldConfig {
        self.config
    }
    /// The method actually stepping: [`Method::Auto`] resolved at the first step.
    pub fn method(&self) -> Method {
        match self.engine {
            None => self.config.method,
            Some(_) => self.config.method.resolve(),
        }
    }
    /// True while simulate mode's event loop of spheres steps this world (or will, at its next
    /// step): the default method in simulate mode without gravity, while every body is a moving
    /// sphere. It gives the same contacts, to the bit, as the grid's frame pipeline, which takes
    /// over from the first shape or static body.
    ///
    /// ```
    /// use vadop::{BoxBounds, Mode, World, WorldConfig};
    /// let world = World::new(BoxBounds::cube(10.0)?, WorldConfig::default())?;
    /// assert!(world.on_event_loop());
    /// let detect = World::new(BoxBounds::cube(10.0)?, WorldConfig { mode: Mode::Detect, ..WorldConfig::default() })?;
    /// assert!(!detect.on_event_loop());
    /// # Ok::<(), vadop::VadopError>(())
    /// ```
    pub fn on_event_loop(&self) -> bool {
        match &self.engine {
            Some(engine) => engine.on_event_loop(),
            None => {
                engine::starts_on_event_loop(&self.config)
                    && self.bodies.alive_ids().all(|i| crate::event_loop::EventLoop::takes(&self.bodies, i as usize))
            }
        }
    }
    /// The axis pool (used by the VADOP method).
    pub fn pool(&self) -> &Arc<AxisPool> {
        &self.pool
    }
    /// Statistics of the last frame.
    pub fn stats(&self) -> &FrameStats {
        &self.stats
    }
    /// The contacts of the last frame, in time order: what [`World::step`] returned.
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }
    /// The contacts between bodies that ended in the last frame, in time order: the instants the
    /// two part, with the point and normal where they last touch (and no impulse). Empty unless
    /// [`WorldConfig::contact_ends`] is on.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::{BoxBounds, Mode, Sphere, Touched, World, WorldConfig};
    /// let config = WorldConfig { mode: Mode::Detect, contact_ends: true, ..WorldConfig::default() };
    /// let mut world = World::new(BoxBounds::cube(10.0)?, config)?;
    /// let ball = |x: f64, vx: f64| Sphere { position: DVec3::new(x, 5.0, 5.0), velocity: DVec3::new(vx, 0.0, 0.0), radius: 0.5, mass: 1.0 };
    /// let (a, b) = (world.add_sphere(ball(2.0, 1.5))?, world.add_sphere(ball(8.0, -1.5))?);
    /// // They touch at 5/3 s (centres 1 apart), pass through each other and part at 7/3 s.
    /// assert_eq!(world.step(2.0)?[0].time, 5.0 / 3.0);
    /// assert_eq!(world.touching(), [(a, b)]);
    /// assert!(world.contact_ends().is_empty());
    /// world.step(1.0)?;
    /// assert_eq!((world.contact_ends()[0].time, world.contact_ends()[0].touched), (7.0 / 3.0, Touched::Body(b)));
    /// assert!(world.touching().is_empty());
    /// // The pairs in contact at any instant of the last frame: touching now, or parted during it.
    /// assert_eq!(world.touching_in_frame(), [(a, b)]);
    /// # Ok::<(), vadop::VadopError>(())
    /// ```
    pub fn contact_ends(&self) -> &[Contact] {
        &self.ends
    }
    /// The pairs of bodies in contact now (lower index first, ascending): those whose contact
    /// started and has not ended. Bodies added overlapping are not in contact until they first
    /// touch. Empty unless [`WorldConfig::contact_ends`] is on, except with [`Method::Discrete`],
    /// whose frame-instant check always knows the pairs overlapping at the frame's end.
    pub fn touching(&self) -> Vec<(BodyHandle, BodyHandle)> {
        let pairs = self.engine.as_ref().map_or_else(Vec::new, |engine| engine.touching_pairs());
        let handle = |i: u32| self.bodies.handle(i as usize);
        pairs.into_iter().map(|(a, b)| (handle(a), handle(b))).collect()
    }
    /// The pairs in contact at any instant of the last frame: those touching now and those whose
    /// contact ended during it, ascending. Empty unless [`WorldConfig::contact_ends`] is on
    /// (with [`Method::Discrete`], as [`World::touching`]).
    pub fn touching_in_frame(&self) -> Vec<(BodyHandle, BodyHandle)> {
        let mut pairs = self.touching();
        pairs.extend(self.ends.iter().filter_map(|c| match c.touched {
            Touched::Body(other) => Some((c.body, other)),
            Touched::Wall(_) => None,
        }));
        pairs.sort_unstable();
        pairs.dedup();
        pairs
    }
    /// The sweep-and-prune broad phase (methods Vadop, SweptAabb, SweptKdop), once built (for
    /// inspection and tests).
    pub fn sweep_prune(&self) -> Option<&SweepPrune> {
        self.engine.as_ref()?.broad_phase()?.downcast_ref()
    }
    /// Total kinetic energy: of the centres' motion and of the spins.
    pub fn kinetic_energy(&self) -> f64 {
        self.translational_kinetic_energy() + self.moving_ids().map(|i| self.bodies.spin_energy(i)).sum::<f64>()
    }
    /// Kinetic energy of the centres' motion only: the temperature of a gas (3/2 NkT) and the
    /// scale of its collisional virial.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::{BoxBounds, Sphere, World, WorldConfig};
    /// let mut world = World::new(BoxBounds::cube(10.0)?, WorldConfig::default())?;
    /// world.add_sphere(Sphere { position: DVec3::splat(5.0), velocity: DVec3::new(3.0, 0.0, 4.0), radius: 0.5, mass: 2.0 })?;
    /// assert_eq!(world.translational_kinetic_energy(), 25.0);
    /// # Ok::<(), vadop::VadopError>(())
    /// ```
    pub fn translational_kinetic_energy(&self) -> f64 {
        let b = &self.bodies;
        self.moving_ids().map(|i| 0.5 * b.mass(i) * b.velocity_at(i, self.time).length_squared()).sum()
    }
    /// Potential energy of the moving bodies in the world's gravity, `-sum m g . p`, zero at the
    /// origin (0 without gravity): kinetic plus potential is what an elastic run keeps.
    ///
    /// ```
    /// use glam::DVec3;
    /// use vadop::{BoxBounds, Sphere, World, WorldConfig};
    /// let config = WorldConfig { gravity: DVec3::new(0.0, 0.0, -2.0), ..WorldConfig::default() };
    /// let mut world = World::new(BoxBounds::cube(10.0)?, config)?;
    /// world.add_sphere(Sphere { position: DVec3::splat(5.0), velocity: DVec3::ZERO, radius: 0.5, mass: 3.0 })?;
    /// assert_eq!(world.potential_energy(), 30.0);
    /// world.step(0.5)?;
    /// // It fell 1/4 and turned 1.5 of potential energy into kinetic.
    /// assert!((world.potential_energy() - 28.5).abs() < 1e-12 && (world.kinetic_energy() - 1.5).abs() < 1e-12);
    /// # Ok::<(), vadop::VadopError>(())
    /// ```
    pub fn potential_energy(&self) -> f64 {
        let (b, g) = (&self.bodies, self.config.gravity);
        // Along a periodic axis a body falls on through the faces: its height unwrapped.
        self.moving_ids().map(|i| -b.mass(i) * g.dot(b.unwrapped_at(i, self.time))).sum()
    }
    /// Total linear momentum.
    pub fn momentum(&self) -> DVec3 {
        self.moving_ids().map(|i| self.bodies.mass(i) * self.bodies.velocity_at(i, self.time)).sum()
    }

    /// Advances the world by `dt` and returns the frame's contacts in time order: every contact
    /// whose time lies in `[time, time + dt)`.
    ///
    /// Fails, changing nothing, on a bad `dt`, an empty world, an absurd speed, or (simulate mode)
    /// bodies added since the last step that overlap another body.
    pub fn step(&mut self, dt: f64) -> Result<&[Contact]> {
        self.check_step(dt)?;
        if self.interrupt.as_ref().is_some_and(|flag| flag.load(Ordering::Relaxed)) {
            return Err(VadopError::Interrupted);
        }
        let (t0, t1) = (self.time, self.time + dt);
        self.contacts.clear();
        self.ends.clear();
        self.stats = FrameStats::default();
        let waiting = self.unplaced.clone();
        self.place_new_bodies();
        self.wake_released();
        let before = self.keep_undo(waiting);
        let physics = self.physics();
        let World { engine, bodies, contacts, ends, stats, threads, interrupt, watched, .. } = self;
        let threads = &*threads;
        let mut out = Output { contacts, ends, stats };
        let engine = engine.as_mut().expect("built by place_new_bodies");
        let mut run = || engine.step(bodies, &physics, t0, t1, &mut out);
        let on_threads = || match threads {
            Some(pool) => pool.install(run),
            None => run(),
        };
        match (&before, interrupt) {
            (Some(_), Some(flag)) => crate::interrupt::watching(watched, flag, on_threads),
            _ => on_threads(),
        }
        if let Some(before) = before {
            if self.interrupt.as_ref().is_some_and(|flag| flag.load(Ordering::Relaxed)) {
                self.undo_step(before);
                return Err(VadopError::Interrupted);
            }
            self.bodies.drop_undo();
        }
        self.time = t1;
        self.stats.contacts = self.contacts.len() as u64;
        self.stats.broad_phase_bytes = self.engine_bytes() as u64;
        Ok(&self.contacts)
    }

    /// Gives the world a flag that stops a step in progress when raised from another thread
    /// (`None` takes it away). The step then returns [`VadopError::Interrupted`] within a few
    /// milliseconds, and the world is exactly as it was before the step: stepping on once the
    /// flag is lowered gives the bits an uninterrupted run gives. While raised, every step is
    /// refused at once. A world with a flag copies its contact history each step (about 21 bytes
    /// a body in simulate mode) and keeps the motions the step overwrites; the discrete method
    /// is stopped only before a step starts.
    ///
    /// ```
    /// use std::sync::atomic::{AtomicBool, Ordering};
    /// use std::sync::Arc;
    /// use vadop::scene::PaperScene;
    /// use vadop::{VadopError, WorldConfig};
    /// let scene = PaperScene { bodies: 500, packing_fraction: 0.1, max_speed: 2.0, radius: 0.5, seed: 1 }.build()?;
    /// let mut world = scene.world(WorldConfig::default())?;
    /// let stop = Arc::new(AtomicBool::new(false));
    /// world.set_interrupt(Some(stop.clone()));
    /// world.step(1.0 / 30.0)?;
    /// stop.store(true, Ordering::Relaxed); // as a Ctrl-C handler would, from another thread
    /// assert_eq!(world.step(1.0 / 30.0).unwrap_err(), VadopError::Interrupted);
    /// assert_eq!(world.time(), 1.0 / 30.0);
    /// stop.store(false, Ordering::Relaxed);
    /// world.step(1.0 / 30.0)?;
    /// # Ok::<(), VadopError>(())
    /// ```
    pub fn set_interrupt(&mut self, flag: Option<Arc<AtomicBool>>) {
        self.interrupt = flag;
    }

    /// With an interrupt flag and an event pipeline: what an interrupted step must put back
    /// (`waiting`, the bodies not yet entered when it started), the bodies keeping their undo.
    fn keep_undo(&mut self, waiting: Vec<u32>) -> Option<BeforeStep> {
        let engine = self.engine.as_ref().filter(|engine| engine.can_undo() && self.interrupt.is_some())?;
        let rules = engine.rules().clone();
        let touching = engine.touching_since();
        self.bodies.keep_undo();
        Some(BeforeStep { waiting, speed_bound: self.bodies.speed_bound, rules, touching })
    }

    /// Takes an interrupted step back: the bodies' motions, and a fresh engine holding what the
    /// old one held before the step (as loading a saved world builds one).
    fn undo_step(&mut self, before: BeforeStep) {
        self.bodies.undo(before.speed_bound);
        self.contacts.clear();
        self.ends.clear();
        self.stats = FrameStats::default();
        self.enter_stepped(before.waiting);
        let BeforeStep { rules, touching, .. } = before;
        if let Some(engine) = &mut self.engine {
            *engine.rules_mut() = rules;
            engine.restore_touching(touching.0, touching.1);
        }
    }

    /// The live bodies but `waiting` (ascending), which earlier steps entered into the engine.
    fn stepped(&self, waiting: &[u32]) -> Vec<u32> {
        self.bodies.alive_ids().filter(|id| waiting.binary_search(id).is_err()).collect()
    }

    /// A fresh engine holding the live bodies earlier steps entered, the bodies of `waiting` left
    /// to the next step (to be checked and entered as bodies just added).
    fn enter_stepped(&mut self, waiting: Vec<u32>) {
        let mut sorted = waiting.clone();
        sorted.sort_unstable();
        self.engine = None;
        self.unplaced = self.stepped(&sorted);
        self.place_new_bodies();
        self.unplaced = waiting;
    }

    fn physics(&self) -> Physics {
        Physics {
            bounds: self.bounds,
            mode: self.config.mode,
            restitution: self.config.restitution,
            friction: self.config.friction,
            contact_duration: self.config.contact_duration,
            report_ends: self.config.contact_ends,
        }
    }

    fn engine_bytes(&self) -> usize {
        self.engine.as_ref().map_or(0, |engine| engine.memory_bytes())
    }

    /// The engine's contact rules (its per-body contact history), once built.
    fn rules_mut(&mut self) -> Option<&mut ContactRules> {
        self.engine.as_mut().map(|engine| engine.rules_mut())
    }

    fn rules(&self) -> Option<&ContactRules> {
        self.engine.as_ref().map(|engine| engine.rules())
    }

    /// The time of body `i`'s last contact, if it had one.
    pub(super) fn last_contact(&self, i: usize) -> Option<f64> {
        let kept = match self.rules() {
            Some(rules) => Some(rules.last_contact(i)),
            None => self.history.iter().rev().find(|&&(slot, _)| slot as usize == i).map(|&(_, t)| t),
        };
        kept.filter(|t| t.is_finite())
    }

    /// Body `i`'s last contact was at `t`; kept until the engine exists when it does not yet.
    fn set_last_contact(&mut self, i: usize, t: f64) {
        match self.rules_mut() {
            Some(rules) => rules.set_last_contact(i, t),
            None => self.history.push((i as u32, t)),
        }
    }

    /// Slots no new body can take: the live bodies' and the retired ones (see
    /// [`BodyHandle::MAX_GENERATION`]). Slot indices must fit a handle's 32 bits.
    fn used_slots(&self) -> usize {
        self.bodies.slots() - self.free_slots.len()
    }

    /// The slot of the live body `handle`, or why there is none.
    fn live_slot(&self, handle: BodyHandle) -> Result<usize> {
        let i = handle.index() as usize;
        let Some(&BodyTag { generation, .. }) = self.bodies.tags.get(i) else {
            return Err(VadopError::NoSuchBody(handle));
        };
        let alive = self.bodies.alive[i];
        if alive && handle.generation() == generation {
            Ok(i)
        } else if handle.generation() < generation {
            // An earlier generation of the slot: a body that was removed.
            Err(VadopError::StaleHandle { handle, current: alive.then(|| self.bodies.handle(i)) })
        } else {
            Err(VadopError::NoSuchBody(handle))
        }
    }

    fn check_sphere(&self, s: &Sphere) -> Result<()> {
        check_vector("position", s.position)?;
        check_vector("velocity", s.velocity)?;
        if !(s.radius.is_finite() && s.radius > 0.0) {
            return Err(VadopError::BadRadius(s.radius));
        }
        if !(s.mass.is_finite() && s.mass > 0.0) {
            return Err(VadopError::BadMass(s.mass));
        }
        check_length("radius", s.radius)?;
        check_magnitude("mass", s.mass)?;
        check_magnitude("inverse mass", 1.0 / s.mass)?;
        self.check_in_box(s.position, s.radius)
    }

    /// Fails when a sphere of `radius` at `position` is not inside the box (see
    /// [`BoxBounds::contains`]) or too large for a periodic side of it.
    pub(crate) fn check_in_box(&self, position: DVec3, radius: f64) -> Result<()> {
        if !self.bounds.contains(position, radius) {
            return Err(VadopError::OutsideBox {
                position: position.to_array(),
                radius,
                min: self.bounds.min.to_array(),
                max: self.bounds.max.to_array(),
            });
        }
        self.check_periodic_sides(radius)
    }

    /// Fails when a body of bounding `radius` is too large for a periodic side.
    pub(crate) fn check_periodic_sides(&self, radius: f64) -> Result<()> {
        for axis in (0..3).filter(|&a| self.bounds.periodic[a]) {
            let (side, diameter) = (self.bounds.side()[axis], 2.0 * radius);
            if !(diameter * MIN_PERIODIC_DIAMETERS <= side) {
                let (axis, minimum) = (['x', 'y', 'z'][axis], MIN_PERIODIC_DIAMETERS);
                return Err(VadopError::PeriodicSideTooShort { axis, side, diameter, minimum });
            }
        }
        Ok(())
    }

    /// Under gravity where bodies may not come to rest (an elastic world, detect mode), no body
    /// may rest on a wall it is pulled towards: it would bounce without end. The height h a body's bounce reaches above touching is its
    /// distance plus v^2 / 2g along each pulled axis, a bounce lasts 2 sqrt(2 h / g), and a body
    /// that would bounce more than [`MAX_BOUNCES_PER_STEP`] times in the step is refused. A body
    /// the jam rule stopped there lies still, and bounces no more.
    fn check_not_resting(&self, dt: f64) -> Result<()> {
        let g = self.config.gravity;
        if g == DVec3::ZERO || (self.config.mode == Mode::Simulate && self.config.restitution < 1.0) {
            return Ok(());
        }
        for i in self.moving_ids().filter(|&i| self.bodies.rest_of(i) != Rest::Still) {
            let (p, v, r) =
                (self.bodies.position_at(i, self.time), self.bodies.velocity_at(i, self.time), self.bodies.radius(i));
            // A periodic axis has no floor to rest on.
            for axis in (0..3).filter(|&axis| g[axis] != 0.0 && !self.bounds.periodic[axis]) {
                let distance = if g[axis] < 0.0 {
                    p[axis] - (self.bounds.min[axis] + r)
                } else {
                    self.bounds.max[axis] - r - p[axis]
                };
                let height = distance.max(0.0) + v[axis] * v[axis] / (2.0 * g[axis].abs());
                let bounce = 2.0 * (2.0 * height / g[axis].abs()).sqrt();
                if !(bounce * MAX_BOUNCES_PER_STEP > dt) {
                    let (body, limit) = (self.bodies.handle(i), MAX_BOUNCES_PER_STEP);
                    return Err(VadopError::RestingUnderGravity { body, height, limit });
                }
            }
        }
        Ok(())
    }

    fn check_step(&mut self, dt: f64) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(VadopError::BadTimeStep(dt));
        }
        if self.live == 0 {
            return Err(VadopError::EmptyWorld);
        }
        self.check_not_resting(dt)?;
        if !(self.time + dt).is_finite() {
            return Err(VadopError::TimeOverflow { time: self.time, dt });
        }
        if !(self.time + dt > self.time) {
            return Err(VadopError::TimeStepTooSmall { time: self.time, dt });
        }
        // The bound settles it in one comparison; only when it is too high (it may be a speed
        // since replaced) are the bodies read, to name the offender or lower the bound.
        let side = (self.bounds.max - self.bounds.min).min_element();
        let within = |speed: f64| speed * dt / side <= MAX_BOX_LENGTHS_PER_FRAME;
        if !within(self.bodies.speed_bound) {
            for i in self.bodies.alive_ids() {
                let speed = crate::bodies::speed(self.bodies.velocity(i as usize));
                if !within(speed) {
                    let (body, lengths) = (self.bodies.handle(i as usize), speed * dt / side);
                    return Err(VadopError::AbsurdSpeed { body, lengths, limit: MAX_BOX_LENGTHS_PER_FRAME });
                }
            }
            self.bodies.tighten_speed_bound();
        }
        if self.config.mode == Mode::Simulate && !self.unplaced.is_empty() {
            if let Some((a, b, depth)) = crate::world::overlap::first_overlap(&self.bodies, &self.unplaced, self.time) {
                let (a, b) = (self.bodies.handle(a as usize), self.bodies.handle(b as usize));
                return Err(VadopError::Overlap { a, b, depth });
            }
        }
        Ok(())
    }

    /// Builds the engine on the first step and enters bodies added since the last one.
    fn place_new_bodies(&mut self) {
        if self.engine.is_none() {
            let threads = self.config.thread_count();
            // A pool only when there is something to share; a failed pool leaves one thread.
            self.threads = (threads > 1).then(|| crate::interrupt::pool(threads, &self.watched)).flatten();
            let workers = Workers::new(if self.threads.is_some() { self.config.thread_count() } else { 1 });
            self.engine =
                Some(engine::build(self.config.method.resolve(), &self.config, &self.pool, &self.bounds, workers));
        }
        for (i, t) in std::mem::take(&mut self.history) {
            self.set_last_contact(i as usize, t);
        }
        let physics = self.physics();
        let (bodies, time, stats) = (&self.bodies, self.time, &mut self.stats);
        let engine = self.engine.as_mut().expect("built above");
        // Static bodies have no proxy: the pipeline bounds them when their revision changes.
        for &id in self.unplaced.iter().filter(|&&id| !bodies.is_fixed(id as usize)) {
            engine.enter(id, bodies, &physics, time, stats);
        }
        // A one-off list as long as the bodies added: its room is given back, not kept.
        self.unplaced = Vec::new();
    }
}

fn check_phi(phi: f64, pool: &AxisPool) -> Result<()> {
    let rho = pool.covering_radius();
    if !(phi.is_finite() && phi >= rho && phi <= std::f64::consts::FRAC_PI_2) {
        return Err(VadopError::BadPhi { got: phi, rho });
    }
    Ok(())
}
