//! The world: bodies in a box, stepped frame by frame, with every contact of the frame reported
//! in time order.
//!
//! It is the thin front of the library: it owns the bodies and the settings, validates every
//! input before anything changes, and hands each frame to the method's engine — the frame
//! pipeline of a continuous method ([`crate::pipeline`]) over its broad phase, or the
//! pseudo-dynamic stepper. The methods differ only in where candidate pairs come from; the narrow
//! phase, queue and response are shared, so every continuous method and the brute-force oracle
//! produce bit-identical contact sequences. It never decides what touches or how bodies respond.

use crate::axis_pool::AxisPool;
use crate::bodies::{Bodies, Sphere};
use crate::broad_phase::brute_force::BruteForce;
use crate::broad_phase::grid::Grid;
use crate::broad_phase::sweep_prune::SweepPrune;
use crate::collapse::{ContactRules, DEFAULT_CONTACT_DURATION};
use crate::error::{check_length, check_magnitude, check_vector, Result, VadopError};
use crate::handle::BodyHandle;
use crate::narrow_phase::Wall;
use crate::parallel::Workers;
use crate::pipeline::{Output, Physics, Pipeline, WindowRule};
use crate::pseudo_dynamic::PseudoDynamic;
use glam::DVec3;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A body moving more box lengths than this in one frame is rejected: it would bounce off the
/// walls that many times per frame, which is never a meaningful simulation.
pub const MAX_BOX_LENGTHS_PER_FRAME: f64 = 1e4;

/// How candidate pairs are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Method {
    /// Continuous: the fastest broad phase (see [`Method::resolve`]).
    Auto,
    /// Continuous: velocity-aligned volumes, sweep and prune over the axis pool (the paper).
    Vadop,
    /// Continuous: hierarchical uniform grid over pieces of the swept paths.
    Grid,
    /// Continuous: every pair tested (the oracle; O(n^2) per frame).
    Brute,
    /// Pseudo-dynamic: overlap checks at frame instants only (misses what passes in between).
    Discrete,
    /// Continuous baseline: classic sweep and prune over swept axis-aligned boxes (the three
    /// coordinate axes for every body, one sorted list per axis, no tiles), as most engines do.
    SweptAabb,
    /// Continuous baseline: the VADOP sweep and prune with *every* pool axis for every body, a
    /// swept k-DOP; isolates what the velocity alignment buys.
    SweptKdop,
}

impl Method {
    /// Every method, in the order the benchmarks list them.
    pub const ALL: [Method; 7] = [
        Method::Auto,
        Method::Vadop,
        Method::Grid,
        Method::SweptAabb,
        Method::SweptKdop,
        Method::Discrete,
        Method::Brute,
    ];

    /// The method's name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Auto => "auto",
            Method::Vadop => "vadop",
            Method::Grid => "grid",
            Method::Brute => "brute",
            Method::Discrete => "discrete",
            Method::SweptAabb => "swept-aabb",
            Method::SweptKdop => "swept-kdop",
        }
    }

    /// The method called `name` (as [`Method::name`] writes it).
    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }

    /// True for the methods that find every contact inside the frame.
    pub fn is_continuous(self) -> bool {
        self != Method::Discrete
    }

    /// The broad phase a method steps with: [`Method::Auto`] is the grid, the others are
    /// themselves. Measured by `vadop-bench speed` (BENCHMARKS.md, "where each broad phase wins"):
    /// on every scene it runs — the paper's at 0.05 to 5 diameters a frame, an equilibrium gas, a
    /// stream within 1 to 10 degrees of one direction, heavy-tailed speeds — the grid is the
    /// fastest continuous broad phase, the VADOP sweep and prune 1.3 to 6 times slower (closest in
    /// streams, as velocity alignment predicts). No scene statistic picked out a case where it
    /// wins, so Auto does not switch.
    pub fn resolve(self) -> Method {
        match self {
            Method::Auto => Method::Grid,
            other => other,
        }
    }
}

/// Whether bodies collide with each other or only report contacts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Mode {
    /// Full response between bodies and with the walls.
    Simulate,
    /// Bodies pass through each other (contacts are reported, not resolved) and bounce only off
    /// the walls, so every method sees exactly the same paths.
    Detect,
}

/// World settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorldConfig {
    pub method: Method,
    pub mode: Mode,
    /// Number of pool axes (methods Vadop and SweptKdop); `None` uses [`AUTO_POOL_AXES`].
    pub pool_axes: Option<usize>,
    /// Alignment angle phi in radians; `None` uses the pool's covering radius rho, the smallest
    /// angle for which every pair of bodies shares an axis.
    pub phi: Option<f64>,
    /// Coefficient of restitution for body and wall impacts, in [0, 1].
    pub restitution: f64,
    /// Coulomb friction coefficient of every impact (0: frictionless), finite and >= 0. Friction
    /// acts at the contact point, so it spins bodies up (spheres included).
    #[serde(default)]
    pub friction: f64,
    /// Contact duration t_c of the TC model, in seconds: with restitution below 1, a contact of a
    /// body whose previous contact lies less than t_c before is elastic (see [`crate::collapse`]).
    #[serde(default = "default_contact_duration")]
    pub contact_duration: f64,
    /// Threads the frame pipeline shares its bulk work among; `None`: every core. Results are
    /// bit-identical whatever the number; with 1, no thread pool is made. At most as many threads
    /// as the system has cores are used ([`WorldConfig::thread_count`]): more would only wait for
    /// each other (1000 threads on 2 cores made a run 375 times slower).
    #[serde(default)]
    pub threads: Option<usize>,
    /// Detect mode: also report when each contact between bodies ends ([`World::contact_ends`])
    /// and keep the pairs in contact ([`World::touching`]), as started and stopped events.
    /// Off by default: it costs a prediction and a list entry per contact.
    #[serde(default)]
    pub contact_ends: bool,
}

fn default_contact_duration() -> f64 {
    DEFAULT_CONTACT_DURATION
}

impl Default for WorldConfig {
    fn default() -> Self {
        WorldConfig {
            method: Method::Auto,
            mode: Mode::Simulate,
            pool_axes: None,
            phi: None,
            restitution: 1.0,
            friction: 0.0,
            contact_duration: DEFAULT_CONTACT_DURATION,
            threads: None,
            contact_ends: false,
        }
    }
}

impl WorldConfig {
    /// The number of threads a step uses: as configured, but never more than the cores the
    /// system reports (its CPU quota, in a container), and every core when not configured. The
    /// bound is applied here, not refused, so that a world saved on a large machine runs on a
    /// small one.
    ///
    /// ```
    /// use vadop::WorldConfig;
    /// let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    /// let config = WorldConfig { threads: Some(100_000), ..WorldConfig::default() };
    /// assert_eq!(config.thread_count(), cores);
    /// assert_eq!(WorldConfig { threads: Some(1), ..config }.thread_count(), 1);
    /// ```
    pub fn thread_count(&self) -> usize {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        self.threads.map_or(cores, |threads| threads.min(cores))
    }
}

/// The axis-aligned box the bodies live in.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BoxBounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl BoxBounds {
    /// A box, checked to have finite corners and sides of at least [`crate::error::MIN_LENGTH`].
    pub fn new(min: DVec3, max: DVec3) -> Result<BoxBounds> {
        if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
            return Err(VadopError::BadBox { min: min.to_array(), max: max.to_array() });
        }
        check_vector("box corner", min)?;
        check_vector("box corner", max)?;
        check_length("box side", (max - min).min_element())?;
        Ok(BoxBounds { min, max })
    }
    /// The cube `[0, side]^3`.
    pub fn cube(side: f64) -> Result<BoxBounds> {
        BoxBounds::new(DVec3::ZERO, DVec3::splat(side))
    }
    pub(crate) fn contains(&self, position: DVec3, radius: f64) -> bool {
        (position - radius).cmpge(self.min).all() && (position + radius).cmple(self.max).all()
    }
}

/// What a contact's body touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Touched {
    Body(BodyHandle),
    Wall(Wall),
}

/// One contact found in a frame. Bodies are named by the handles they have at the contact, which
/// are their current handles: bodies are only removed between frames.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// Absolute simulation time of first touch.
    pub time: f64,
    /// The body (of a pair, the one with the lower index).
    pub body: BodyHandle,
    /// What it touched.
    pub touched: Touched,
    /// Contact point.
    pub point: DVec3,
    /// Unit normal from `body` towards what it touched.
    pub normal: DVec3,
    /// Magnitude of the impulse applied along the normal (0 when not resolved: detect mode
    /// resolves only contacts with walls and static bodies; 0 for a contact's end).
    pub impulse: f64,
}

/// Counters and timings of one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameStats {
    /// Seconds spent refreshing bounding volumes at window starts (c_update).
    pub update_seconds: f64,
    /// Seconds spent sorting or binning them (c_sort).
    pub sort_seconds: f64,
    /// Seconds spent finding candidates and predicting contacts at window starts (c_test).
    pub test_seconds: f64,
    /// Seconds spent processing contacts: response, volume rebuilds and re-tests (c_response).
    pub response_seconds: f64,
    /// Broad-phase windows started in the frame (a window may span several frames).
    pub windows: u64,
    /// Insertion-sort moves over all lists (sweep and prune) or entries binned (grid).
    pub endpoint_swaps: u64,
    /// Entries held by the broad phase after its last window start.
    pub list_entries: u64,
    /// Candidate pairs reported at window starts.
    pub candidate_pairs: u64,
    /// Narrow-phase pair tests, re-tests included.
    pub narrow_tests: u64,
    /// Bodies re-tested after a velocity change (or entered mid-window).
    pub retests: u64,
    /// Contacts reported.
    pub contacts: u64,
    /// Of which body-body.
    pub pair_contacts: u64,
    /// Predictions voided by a velocity change before their time came.
    pub invalidations: u64,
    /// Bytes held by the engine: broad phase, proxies, event queue.
    pub broad_phase_bytes: u64,
    /// Contacts made elastic by the TC model (restitution below 1; see [`crate::collapse`]).
    pub tc_contacts: u64,
    /// Contacts resolved as resting contact by the jam rule (see [`crate::collapse`]).
    pub jam_contacts: u64,
    /// Contacts between bodies that ended (detect mode, when contact ends are reported).
    #[serde(default)]
    pub contact_ends: u64,
}

impl FrameStats {
    /// c_total = c_update + c_sort + c_test + c_response, in seconds.
    pub fn total_seconds(&self) -> f64 {
        self.update_seconds + self.sort_seconds + self.test_seconds + self.response_seconds
    }
}

/// Pool size used when none is given, whatever the bodies' speeds. Measured by experiment 4 of
/// `vadop-bench experiments` (BENCHMARKS.md): with tiled axis lists the 3-axis pool is the fastest at every
/// speed it tests (0.05, 0.5 and 5 diameters per frame, pools of 3 to 39,000 axes), because each
/// extra axis per body costs more in updates and candidate checks than its thinner volume saves.
/// phi stays rho, the smallest angle that keeps every pair sharing an axis; every axis for every
/// body (the swept k-DOP, table 3) is no faster. The paper's finding that the best pool grows
/// with speed holds for untiled lists, where thinner volumes are the only way to cut overlaps;
/// the tiles do that job here.
pub const AUTO_POOL_AXES: usize = 3;

/// The engine of a method, built at the first step.
// One engine per world: the size of its largest variant does not matter, a box would only add a
// pointer hop.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
enum Engine {
    Unbuilt,
    Grid(Pipeline<Grid>),
    SweepPrune(Pipeline<SweepPrune>),
    Brute(Pipeline<BruteForce>),
    Discrete(PseudoDynamic),
}

/// Runs `$body` with `$p` bound to the engine's pipeline, or `$otherwise` for the others.
macro_rules! with_pipeline {
    ($engine:expr, $p:ident => $body:expr, $otherwise:expr) => {
        match $engine {
            Engine::Grid($p) => $body,
            Engine::SweepPrune($p) => $body,
            Engine::Brute($p) => $body,
            Engine::Discrete(_) | Engine::Unbuilt => $otherwise,
        }
    };
}

// After the macro, which they use too.
mod rigid;
mod snapshot;

pub use rigid::{Body, BodyShape, ShapeId};

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
    engine: Engine,
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
}

/// What a step that may be interrupted must put back: what the engine keeps besides the bodies
/// (which keep their own undo), and the bodies waiting to be entered.
struct BeforeStep {
    waiting: Vec<u32>,
    speed_bound: f64,
    rules: ContactRules,
    touching: Vec<(u32, u32, f64)>,
}

impl World {
    /// An empty world. Fails on a bad box, restitution, contact duration, pool size or phi.
    pub fn new(bounds: BoxBounds, config: WorldConfig) -> Result<World> {
        let bounds = BoxBounds::new(bounds.min, bounds.max)?;
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
        let pool = AxisPool::new(config.pool_axes.unwrap_or(AUTO_POOL_AXES))?;
        check_phi(config.phi.unwrap_or(pool.covering_radius()), &pool)?;
        Ok(World {
            config,
            bounds,
            bodies: Bodies::default(),
            live: 0,
            free_slots: Vec::new(),
            unplaced: Vec::new(),
            engine: Engine::Unbuilt,
            threads: None,
            pool,
            time: 0.0,
            user_shapes: Vec::new(),
            contacts: Vec::new(),
            ends: Vec::new(),
            stats: FrameStats::default(),
            interrupt: None,
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
        if let Some(rules) = self.rules_mut() {
            rules.forget(slot as usize);
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
        self.bodies.remove(i);
        self.live -= 1;
        self.unplaced.retain(|&u| u != slot);
        match &mut self.engine {
            Engine::Discrete(pd) => pd.remove_body(slot),
            engine => with_pipeline!(engine, p => p.remove(slot), ()),
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
        if self.used_slots() + more >= u32::MAX as usize - 1 {
            return Err(VadopError::TooManyBodies(u32::MAX as usize - 1));
        }
        Ok(())
    }

    /// Sets a moving body's velocity (between frames); it goes on spinning as it did.
    pub fn set_velocity(&mut self, handle: BodyHandle, velocity: DVec3) -> Result<()> {
        let i = self.moving_slot(handle)?;
        check_vector("velocity", velocity)?;
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
        match &self.engine {
            Engine::Unbuilt => self.config.method,
            Engine::Grid(_) => Method::Grid,
            Engine::Brute(_) => Method::Brute,
            Engine::Discrete(_) => Method::Discrete,
            Engine::SweepPrune(_) => match self.config.method {
                Method::SweptAabb | Method::SweptKdop => self.config.method,
                _ => Method::Vadop,
            },
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
        let pairs = match &self.engine {
            Engine::Discrete(pd) => pd.overlapping().to_vec(),
            engine => with_pipeline!(engine, p => p.touching.pairs(), Vec::new()),
        };
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
        match &self.engine {
            Engine::SweepPrune(p) => Some(p.broad()),
            _ => None,
        }
    }
    /// Total kinetic energy: of the centres' motion and of the spins.
    pub fn kinetic_energy(&self) -> f64 {
        let b = &self.bodies;
        self.moving_ids().map(|i| 0.5 * b.mass[i] * b.velocity(i).length_squared() + b.spin_energy(i)).sum()
    }
    /// Total linear momentum.
    pub fn momentum(&self) -> DVec3 {
        self.moving_ids().map(|i| self.bodies.mass[i] * self.bodies.velocity(i)).sum()
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
        let before = self.keep_undo(waiting);
        let physics = self.physics();
        let World { engine, bodies, contacts, ends, stats, threads, interrupt, .. } = self;
        let threads = &*threads;
        let mut out = Output { contacts, ends, stats };
        let mut run = || match engine {
            Engine::Grid(p) => p.step(bodies, &physics, t0, t1, &mut out),
            Engine::SweepPrune(p) => p.step(bodies, &physics, t0, t1, &mut out),
            Engine::Brute(p) => p.step(bodies, &physics, t0, t1, &mut out),
            Engine::Discrete(pd) => pd.step(bodies, &physics, t0, t1, &mut out),
            Engine::Unbuilt => unreachable!("built by place_new_bodies"),
        };
        let on_threads = || match threads {
            Some(pool) => pool.install(run),
            None => run(),
        };
        match (&before, interrupt) {
            (Some(_), Some(flag)) => crate::interrupt::watching(flag, threads.as_ref(), on_threads),
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
        if self.interrupt.is_none() || matches!(self.engine, Engine::Discrete(_)) {
            return None;
        }
        let rules = self.rules().cloned().unwrap_or_default();
        let touching = with_pipeline!(&self.engine, p => p.touching.contacts(), Vec::new());
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
        with_pipeline!(&mut self.engine, p => {
            p.rules = rules;
            for (a, b, since) in touching {
                p.touching.insert(a, b, since);
            }
        }, ());
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
        self.engine = Engine::Unbuilt;
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
        match &self.engine {
            Engine::Discrete(pd) => pd.memory_bytes(),
            engine => with_pipeline!(engine, p => p.memory_bytes(), 0),
        }
    }

    /// The engine's contact rules (its per-body contact history), once built.
    fn rules_mut(&mut self) -> Option<&mut ContactRules> {
        match &mut self.engine {
            Engine::Discrete(pd) => Some(&mut pd.rules),
            engine => with_pipeline!(engine, p => Some(&mut p.rules), None),
        }
    }

    fn rules(&self) -> Option<&ContactRules> {
        match &self.engine {
            Engine::Discrete(pd) => Some(&pd.rules),
            engine => with_pipeline!(engine, p => Some(&p.rules), None),
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
        let Some(&generation) = self.bodies.generation.get(i) else {
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
        if !self.bounds.contains(s.position, s.radius) {
            return Err(VadopError::OutsideBox {
                position: s.position.to_array(),
                radius: s.radius,
                min: self.bounds.min.to_array(),
                max: self.bounds.max.to_array(),
            });
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
            if let Some((a, b, depth)) = crate::overlap::first_overlap(&self.bodies, &self.unplaced, self.time) {
                let (a, b) = (self.bodies.handle(a as usize), self.bodies.handle(b as usize));
                return Err(VadopError::Overlap { a, b, depth });
            }
        }
        Ok(())
    }

    /// Builds the engine on the first step and enters bodies added since the last one.
    fn place_new_bodies(&mut self) {
        if matches!(self.engine, Engine::Unbuilt) {
            let threads = self.config.thread_count();
            // A pool only when there is something to share; a failed pool leaves one thread.
            self.threads =
                (threads > 1).then(|| rayon::ThreadPoolBuilder::new().num_threads(threads).build().ok()).flatten();
            self.engine = self.build_engine(self.config.method.resolve());
        }
        let physics = self.physics();
        let (bodies, time, stats) = (&self.bodies, self.time, &mut self.stats);
        // Static bodies have no proxy: the pipeline bounds them when their revision changes.
        for &id in self.unplaced.iter().filter(|&&id| !bodies.is_fixed(id as usize)) {
            match &mut self.engine {
                Engine::Discrete(pd) => {
                    pd.rules.resize(bodies.slots());
                    pd.add_body(id);
                }
                engine => with_pipeline!(engine, p => p.enter(id, bodies, &physics, time, stats), ()),
            }
        }
        // A one-off list as long as the bodies added: its room is given back, not kept.
        self.unplaced = Vec::new();
    }

    fn build_engine(&self, method: Method) -> Engine {
        let (min, max) = (self.bounds.min, self.bounds.max);
        let workers = Workers::new(if self.threads.is_some() { self.config.thread_count() } else { 1 });
        match method {
            Method::Brute => {
                Engine::Brute(Pipeline::new(BruteForce::default(), WindowRule::Frame, &self.bounds, workers))
            }
            Method::Discrete => Engine::Discrete(PseudoDynamic::default()),
            Method::Grid | Method::Auto => {
                Engine::Grid(Pipeline::new(Grid::new(min, max), WindowRule::Adaptive, &self.bounds, workers))
            }
            Method::Vadop => {
                let phi = self.config.phi.unwrap_or(self.pool.covering_radius());
                // A hair wider than phi, so rounding never costs a pair its shared axis.
                let sin_phi = (phi.sin() * (1.0 + 1e-12) + 1e-15).min(1.0);
                let sap = SweepPrune::new(self.pool.clone(), sin_phi, min, max, true);
                Engine::SweepPrune(Pipeline::new(sap, WindowRule::Adaptive, &self.bounds, workers))
            }
            Method::SweptKdop => {
                let sap = SweepPrune::new(self.pool.clone(), 1.0, min, max, true);
                Engine::SweepPrune(Pipeline::new(sap, WindowRule::Adaptive, &self.bounds, workers))
            }
            Method::SweptAabb => {
                let coordinate_axes = AxisPool::new(3).expect("the 3-axis pool always builds");
                let sap = SweepPrune::new(coordinate_axes, 1.0, min, max, false);
                Engine::SweepPrune(Pipeline::new(sap, WindowRule::Adaptive, &self.bounds, workers))
            }
        }
    }
}

fn check_phi(phi: f64, pool: &AxisPool) -> Result<()> {
    let rho = pool.covering_radius();
    if !(phi.is_finite() && phi >= rho && phi <= std::f64::consts::FRAC_PI_2) {
        return Err(VadopError::BadPhi { got: phi, rho });
    }
    Ok(())
}
