//! The world: bodies in a box, stepped frame by frame, with every contact of the frame reported
//! in time order.
//!
//! It owns the frame loop and ties the stages together: validate input, rebuild and sort the
//! volumes, predict contacts for candidate pairs and walls, then pop contacts in time order,
//! respond, void the touched bodies' predictions, rebuild their volumes and re-test them for the
//! rest of the frame. The methods differ only in where candidates come from (VADOP sweep and
//! prune, its swept-AABB, swept-k-DOP and uniform-grid baselines, all pairs, or frame-instant
//! overlap checks); the narrow phase and response are shared, so every continuous method and the
//! brute-force oracle produce bit-identical contact sequences.
//! Every fallible call checks its input before it changes anything.

use crate::axis_pool::AxisPool;
use crate::bodies::{Bodies, Sphere};
use crate::collapse::CollapseGuard;
use crate::error::{check_magnitude, check_vector, Result, VadopError};
use crate::event_queue::{Event, EventQueue, Partner};
use crate::narrow_phase::{sphere_sphere_time, sphere_wall_time, Wall};
use crate::pseudo_dynamic::PseudoDynamic;
use crate::response::{pair_impulse, wall_bounce};
use crate::sweep_prune::SweepPrune;
use crate::uniform_grid::UniformGrid;
use glam::DVec3;
use std::sync::Arc;
use std::time::Instant;

mod snapshot;

/// A body moving more box lengths than this in one frame is rejected: it would bounce off the
/// walls that many times per frame, which is never a meaningful simulation.
pub const MAX_BOX_LENGTHS_PER_FRAME: f64 = 1e4;

/// How candidate pairs are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Method {
    /// Continuous: velocity-aligned volumes, sweep and prune over the axis pool.
    Vadop,
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
    /// Continuous baseline: uniform grid over swept axis-aligned boxes.
    Grid,
}

impl Method {
    /// Every method, in the order the benchmarks list them.
    pub const ALL: [Method; 6] =
        [Method::Vadop, Method::SweptAabb, Method::SweptKdop, Method::Grid, Method::Discrete, Method::Brute];

    /// The method's name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Vadop => "vadop",
            Method::Brute => "brute",
            Method::Discrete => "discrete",
            Method::SweptAabb => "swept-aabb",
            Method::SweptKdop => "swept-kdop",
            Method::Grid => "grid",
        }
    }

    /// True for the methods that find every contact inside the frame.
    pub fn is_continuous(self) -> bool {
        self != Method::Discrete
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
    /// Number of pool axes; `None` uses [`AUTO_POOL_AXES`].
    pub pool_axes: Option<usize>,
    /// Alignment angle phi in radians; `None` uses the pool's covering radius rho, the smallest
    /// angle for which every pair of bodies shares an axis.
    pub phi: Option<f64>,
    /// Coefficient of restitution for body and wall impacts, in [0, 1].
    pub restitution: f64,
}

impl Default for WorldConfig {
    fn default() -> Self {
        WorldConfig { method: Method::Vadop, mode: Mode::Simulate, pool_axes: None, phi: None, restitution: 1.0 }
    }
}

/// The axis-aligned box the bodies live in.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BoxBounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl BoxBounds {
    /// A box, checked to have finite corners and positive sides.
    pub fn new(min: DVec3, max: DVec3) -> Result<BoxBounds> {
        if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
            return Err(VadopError::BadBox { min: min.to_array(), max: max.to_array() });
        }
        check_vector("box corner", min)?;
        check_vector("box corner", max)?;
        Ok(BoxBounds { min, max })
    }
    /// The cube `[0, side]^3`.
    pub fn cube(side: f64) -> Result<BoxBounds> {
        BoxBounds::new(DVec3::ZERO, DVec3::splat(side))
    }
    fn contains(&self, position: DVec3, radius: f64) -> bool {
        (position - radius).cmpge(self.min).all() && (position + radius).cmple(self.max).all()
    }
}

/// What a contact's body touched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Touched {
    Body(u32),
    Wall(Wall),
}

/// One contact found in a frame.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// Absolute simulation time of first touch.
    pub time: f64,
    /// The body (the lower id of a pair).
    pub body: u32,
    /// What it touched.
    pub touched: Touched,
    /// Contact point.
    pub point: DVec3,
    /// Unit normal from `body` towards what it touched.
    pub normal: DVec3,
    /// Magnitude of the impulse applied along the normal (0 when not resolved, as in detect mode).
    pub impulse: f64,
}

/// Counters and timings of one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameStats {
    /// Seconds spent recomputing bounding volumes (c_update).
    pub update_seconds: f64,
    /// Seconds spent sorting (c_sort).
    pub sort_seconds: f64,
    /// Seconds spent finding candidates and predicting contacts at frame start (c_test).
    pub test_seconds: f64,
    /// Seconds spent processing contacts: response, volume rebuilds and re-tests (c_response).
    pub response_seconds: f64,
    /// Insertion-sort moves over all lists.
    pub endpoint_swaps: u64,
    /// Intervals held in all sorted lists.
    pub list_entries: u64,
    /// Candidate pairs at frame start.
    pub candidate_pairs: u64,
    /// Narrow-phase pair tests, re-tests included.
    pub narrow_tests: u64,
    /// Contacts reported.
    pub contacts: u64,
    /// Of which body-body.
    pub pair_contacts: u64,
    /// Predictions voided by a velocity change before their time came.
    pub invalidations: u64,
    /// Bytes held by the broad phase.
    pub broad_phase_bytes: u64,
    /// Contacts made plastic by the collapse rule (see [`crate::collapse`]).
    pub collapse_contacts: u64,
}

impl FrameStats {
    /// c_total = c_update + c_sort + c_test + c_response, in seconds.
    pub fn total_seconds(&self) -> f64 {
        self.update_seconds + self.sort_seconds + self.test_seconds + self.response_seconds
    }
}

/// The candidate source of a method.
#[derive(Debug)]
enum BroadPhase {
    /// Not built yet (the pool is chosen at the first step).
    Unbuilt,
    /// Vadop, SweptAabb and SweptKdop: sweep and prune over pool axes.
    SweepPrune(SweepPrune),
    Brute,
    Discrete(PseudoDynamic),
    Grid(UniformGrid),
}

/// Pool size used when none is given, whatever the bodies' speeds. Measured by experiment 4 of
/// `vadop bench` (BENCHMARKS.md): with tiled axis lists the 3-axis pool is the fastest at every
/// speed it tests (0.05, 0.5 and 5 diameters per frame, pools of 3 to 39,000 axes), because each
/// extra axis per body costs more in updates and candidate checks than its thinner volume saves.
/// phi stays rho, the smallest angle that keeps every pair sharing an axis; every axis for every
/// body (the swept k-DOP, table 3) is no faster. The paper's finding that the best pool grows
/// with speed holds for untiled lists, where thinner volumes are the only way to cut overlaps;
/// the tiles do that job here.
pub const AUTO_POOL_AXES: usize = 3;

/// A world of spheres in a box.
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
/// assert_eq!(contacts[0].touched, Touched::Body(b));
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
    free_slots: Vec<u32>,
    /// Added since the last step: validated and entered into the broad phase at the next step.
    unplaced: Vec<u32>,
    broad: BroadPhase,
    pool: Arc<AxisPool>,
    queue: EventQueue,
    time: f64,
    contacts: Vec<Contact>,
    stats: FrameStats,
    collapse: CollapseGuard,
}

impl World {
    /// An empty world. Fails on a bad box, restitution, pool size or phi.
    pub fn new(bounds: BoxBounds, config: WorldConfig) -> Result<World> {
        let bounds = BoxBounds::new(bounds.min, bounds.max)?;
        if !(0.0..=1.0).contains(&config.restitution) {
            return Err(VadopError::BadRestitution(config.restitution));
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
            broad: BroadPhase::Unbuilt,
            pool,
            queue: EventQueue::default(),
            time: 0.0,
            contacts: Vec::new(),
            stats: FrameStats::default(),
            collapse: CollapseGuard::default(),
        })
    }

    /// Adds a sphere; returns its id. Ids of removed bodies are reused, lowest first.
    pub fn add_sphere(&mut self, sphere: Sphere) -> Result<u32> {
        self.check_sphere(&sphere)?;
        if self.live >= u32::MAX as usize - 1 {
            return Err(VadopError::TooManyBodies(u32::MAX as usize - 1));
        }
        let id = match self.free_slots.pop() {
            Some(id) => id,
            None => self.bodies.slots() as u32,
        };
        self.bodies.put(id as usize, sphere, self.time);
        self.live += 1;
        self.unplaced.push(id);
        Ok(id)
    }

    /// Adds many spheres at once, all or none.
    pub fn add_spheres(&mut self, spheres: &[Sphere]) -> Result<Vec<u32>> {
        for s in spheres {
            self.check_sphere(s)?;
        }
        if self.live + spheres.len() >= u32::MAX as usize - 1 {
            return Err(VadopError::TooManyBodies(u32::MAX as usize - 1));
        }
        spheres.iter().map(|s| self.add_sphere(*s)).collect()
    }

    /// Removes a body and returns it as it was now.
    pub fn remove_sphere(&mut self, id: u32) -> Result<Sphere> {
        let i = self.live_index(id)?;
        let sphere = self.bodies.sphere_at(i, self.time);
        self.bodies.alive[i] = false;
        self.bodies.stamp[i] = self.bodies.stamp[i].wrapping_add(1);
        self.live -= 1;
        self.unplaced.retain(|&u| u != id);
        if let BroadPhase::SweepPrune(sap) = &mut self.broad {
            sap.remove_body(id);
        }
        self.free_slots.push(id);
        // Pop the lowest id first.
        self.free_slots.sort_unstable_by(|a, b| b.cmp(a));
        Ok(sphere)
    }

    /// Sets a body's velocity (between frames).
    pub fn set_velocity(&mut self, id: u32, velocity: DVec3) -> Result<()> {
        let i = self.live_index(id)?;
        check_vector("velocity", velocity)?;
        self.bodies.set_velocity_at(i, self.time, velocity);
        if let BroadPhase::SweepPrune(sap) = &mut self.broad {
            if !self.unplaced.contains(&id) {
                sap.set_body(id, &self.bodies, self.time, self.time);
            }
        }
        Ok(())
    }

    /// Sets the velocities of the bodies `ids` (between frames), all or none.
    pub fn set_velocities(&mut self, ids: &[u32], velocities: &[DVec3]) -> Result<()> {
        if ids.len() != velocities.len() {
            return Err(VadopError::LengthMismatch { ids: ids.len(), velocities: velocities.len() });
        }
        for (&id, &velocity) in ids.iter().zip(velocities) {
            self.live_index(id)?;
            check_vector("velocity", velocity)?;
        }
        for (&id, &velocity) in ids.iter().zip(velocities) {
            self.set_velocity(id, velocity)?;
        }
        Ok(())
    }

    /// The body `id` now, if alive.
    pub fn sphere(&self, id: u32) -> Option<Sphere> {
        let i = id as usize;
        (i < self.bodies.slots() && self.bodies.alive[i]).then(|| self.bodies.sphere_at(i, self.time))
    }

    /// Live bodies with their ids, ascending.
    pub fn spheres(&self) -> impl Iterator<Item = (u32, Sphere)> + '_ {
        self.bodies.alive_ids().map(|id| (id, self.bodies.sphere_at(id as usize, self.time)))
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
    /// The axis pool (used by the VADOP method).
    pub fn pool(&self) -> &Arc<AxisPool> {
        &self.pool
    }
    /// Statistics of the last frame.
    pub fn stats(&self) -> &FrameStats {
        &self.stats
    }
    /// The sweep-and-prune broad phase (methods Vadop, SweptAabb, SweptKdop), once built (for
    /// inspection and tests).
    pub fn sweep_prune(&self) -> Option<&SweepPrune> {
        match &self.broad {
            BroadPhase::SweepPrune(sap) => Some(sap),
            _ => None,
        }
    }
    /// Total kinetic energy.
    pub fn kinetic_energy(&self) -> f64 {
        self.bodies.alive_ids().map(|i| 0.5 * self.bodies.mass[i as usize] * self.bodies.velocity[i as usize].length_squared()).sum()
    }
    /// Total linear momentum.
    pub fn momentum(&self) -> DVec3 {
        self.bodies.alive_ids().map(|i| self.bodies.mass[i as usize] * self.bodies.velocity[i as usize]).sum()
    }

    /// Advances the world by `dt` and returns the frame's contacts in time order.
    ///
    /// Fails, changing nothing, on a bad `dt`, an empty world, an absurd speed, or (simulate mode)
    /// bodies added since the last step that overlap another body.
    pub fn step(&mut self, dt: f64) -> Result<&[Contact]> {
        self.check_step(dt)?;
        self.place_new_bodies();
        let t0 = self.time;
        let t1 = t0 + dt;
        self.contacts.clear();
        self.queue.clear();
        self.collapse.clear();
        self.stats = FrameStats::default();

        self.predict_frame(t0, t1);
        let start = Instant::now();
        self.process_events(t1);
        for i in 0..self.bodies.slots() {
            if self.bodies.alive[i] {
                self.bodies.position[i] = self.bodies.position_at(i, t1);
                self.bodies.since[i] = t1;
            }
        }
        self.time = t1;
        self.stats.response_seconds += start.elapsed().as_secs_f64();
        if self.config.method == Method::Discrete {
            self.resolve_instant_overlaps(t1);
        }
        self.stats.contacts = self.contacts.len() as u64;
        self.stats.broad_phase_bytes = match &self.broad {
            BroadPhase::SweepPrune(sap) => sap.memory_bytes() as u64,
            BroadPhase::Discrete(pd) => pd.memory_bytes() as u64,
            BroadPhase::Grid(grid) => grid.memory_bytes() as u64,
            _ => 0,
        };
        Ok(&self.contacts)
    }

    fn live_index(&self, id: u32) -> Result<usize> {
        let i = id as usize;
        if i < self.bodies.slots() && self.bodies.alive[i] {
            Ok(i)
        } else {
            Err(VadopError::NoSuchBody(id))
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
        check_magnitude("radius", s.radius)?;
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

    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x <= y)` deliberately rejects NaN too.
    fn check_step(&self, dt: f64) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(VadopError::BadTimeStep(dt));
        }
        if self.live == 0 {
            return Err(VadopError::EmptyWorld);
        }
        if !(self.time + dt).is_finite() {
            return Err(VadopError::TimeOverflow { time: self.time, dt });
        }
        let side = (self.bounds.max - self.bounds.min).min_element();
        for i in self.bodies.alive_ids() {
            // The squares of a speed below 1e-162 underflow to 0, which would let a tiny speed
            // times a huge dt through: then the largest component stands in for the speed.
            let v = self.bodies.velocity[i as usize];
            let length = v.length();
            let speed = if length > 0.0 { length } else { v.abs().max_element() };
            let lengths = speed * dt / side;
            if !(lengths <= MAX_BOX_LENGTHS_PER_FRAME) {
                return Err(VadopError::AbsurdSpeed { body: i, lengths, limit: MAX_BOX_LENGTHS_PER_FRAME });
            }
        }
        if self.config.mode == Mode::Simulate && !self.unplaced.is_empty() {
            if let Some((a, b, depth)) = crate::overlap::first_overlap(&self.bodies, &self.unplaced) {
                return Err(VadopError::Overlap { a, b, depth });
            }
        }
        Ok(())
    }

    /// Builds the broad phase on the first step and enters bodies added since the last one.
    fn place_new_bodies(&mut self) {
        if matches!(self.broad, BroadPhase::Unbuilt) {
            self.broad = match self.config.method {
                Method::Brute => BroadPhase::Brute,
                Method::Discrete => BroadPhase::Discrete(PseudoDynamic::default()),
                Method::Grid => BroadPhase::Grid(UniformGrid::default()),
                Method::Vadop => {
                    let phi = self.config.phi.unwrap_or(self.pool.covering_radius());
                    // A hair wider than phi, so rounding never costs a pair its shared axis.
                    let sin_phi = (phi.sin() * (1.0 + 1e-12) + 1e-15).min(1.0);
                    BroadPhase::SweepPrune(SweepPrune::new(self.pool.clone(), sin_phi, self.bounds.min, self.bounds.max, true))
                }
                Method::SweptKdop => {
                    BroadPhase::SweepPrune(SweepPrune::new(self.pool.clone(), 1.0, self.bounds.min, self.bounds.max, true))
                }
                Method::SweptAabb => {
                    let coordinate_axes = AxisPool::new(3).expect("the 3-axis pool always builds");
                    BroadPhase::SweepPrune(SweepPrune::new(coordinate_axes, 1.0, self.bounds.min, self.bounds.max, false))
                }
            };
        }
        for &id in &self.unplaced {
            match &mut self.broad {
                BroadPhase::SweepPrune(sap) => sap.set_body(id, &self.bodies, self.time, self.time),
                BroadPhase::Discrete(pd) => pd.add_body(id),
                BroadPhase::Brute | BroadPhase::Grid(_) | BroadPhase::Unbuilt => {}
            }
        }
        self.unplaced.clear();
    }

    /// Frame start: c_update, c_sort and c_test.
    fn predict_frame(&mut self, t0: f64, t1: f64) {
        let World { bodies, broad, queue, stats, bounds, .. } = self;
        let start = Instant::now();
        match broad {
            BroadPhase::SweepPrune(sap) => {
                sap.update_intervals(bodies, t1 - t0);
                stats.update_seconds = start.elapsed().as_secs_f64();
                let start = Instant::now();
                let counts = sap.sort();
                stats.endpoint_swaps = counts.swaps;
                stats.list_entries = counts.entries;
                stats.sort_seconds = start.elapsed().as_secs_f64();
                let start = Instant::now();
                sap.for_each_pair(bodies, t0, t1, |i, j| {
                    stats.candidate_pairs += 1;
                    predict_pair(bodies, i, j, t0, t1, queue, stats);
                });
                stats.test_seconds = start.elapsed().as_secs_f64();
            }
            BroadPhase::Brute => {
                let start = Instant::now();
                let ids: Vec<u32> = bodies.alive_ids().collect();
                for (k, &i) in ids.iter().enumerate() {
                    for &j in &ids[k + 1..] {
                        stats.candidate_pairs += 1;
                        predict_pair(bodies, i, j, t0, t1, queue, stats);
                    }
                }
                stats.test_seconds = start.elapsed().as_secs_f64();
            }
            BroadPhase::Grid(grid) => {
                grid.rebuild(bodies, bounds.min, bounds.max, t0, t1);
                stats.update_seconds = start.elapsed().as_secs_f64();
                let start = Instant::now();
                grid.for_each_pair(|i, j| {
                    stats.candidate_pairs += 1;
                    predict_pair(bodies, i, j, t0, t1, queue, stats);
                });
                stats.test_seconds = start.elapsed().as_secs_f64();
            }
            BroadPhase::Discrete(_) | BroadPhase::Unbuilt => {}
        }
        let start = Instant::now();
        for i in 0..bodies.slots() as u32 {
            if bodies.alive[i as usize] {
                predict_wall(bodies, bounds, i, t0, t1, queue);
            }
        }
        stats.test_seconds += start.elapsed().as_secs_f64();
    }

    /// Pops contacts in time order until the frame ends (c_response).
    fn process_events(&mut self, t1: f64) {
        let resolve_pairs = self.config.mode == Mode::Simulate;
        while let Some(event) = self.queue.pop() {
            let i = event.body as usize;
            let current = self.bodies.alive[i] && self.bodies.stamp[i] == event.body_stamp;
            let partner_current = match event.partner {
                Partner::Body(j) => self.bodies.alive[j as usize] && self.bodies.stamp[j as usize] == event.partner_stamp,
                Partner::Wall(_) => true,
            };
            if !(current && partner_current) {
                self.stats.invalidations += 1;
                continue;
            }
            let t = event.time;
            let restitution = self.config.restitution;
            match event.partner {
                Partner::Body(j) => {
                    let ju = j as usize;
                    let (pi, pj) = (self.bodies.position_at(i, t), self.bodies.position_at(ju, t));
                    // Coincident centres have no normal; the relative velocity gives one.
                    let normal = (pj - pi)
                        .try_normalize()
                        .or_else(|| (self.bodies.velocity[i] - self.bodies.velocity[ju]).try_normalize())
                        .unwrap_or(DVec3::X);
                    let mut impulse = 0.0;
                    if resolve_pairs && self.collapse.must_merge(event.body, j) {
                        let members = self.collapse.merge(event.body, j).to_vec();
                        let common = self.common_velocity(&members);
                        impulse = (self.bodies.mass[i] * (self.bodies.velocity[i] - common).dot(normal)).max(0.0);
                        self.move_together(&members, common, t, t1);
                    } else if resolve_pairs {
                        let (vi, vj) = (self.bodies.velocity[i], self.bodies.velocity[ju]);
                        let (wi, wj) = (self.bodies.inv_mass[i], self.bodies.inv_mass[ju]);
                        impulse = pair_impulse(normal, vi, vj, wi, wj, restitution);
                        // Zero impulse changes nothing; re-testing would find the same touch again.
                        if impulse > 0.0 {
                            self.bodies.set_velocity_at(i, t, vi - impulse * wi * normal);
                            self.bodies.set_velocity_at(ju, t, vj + impulse * wj * normal);
                            // The pair itself is re-tested last, once both volumes are rebuilt, so
                            // every method tests it (a rounding residue may still approach).
                            self.retest(event.body, Some(j), t, t1);
                            self.retest(j, None, t, t1);
                        }
                    }
                    self.stats.pair_contacts += 1;
                    self.contacts.push(Contact {
                        time: t,
                        body: event.body,
                        touched: Touched::Body(j),
                        point: pi + normal * self.bodies.radius[i],
                        normal,
                        impulse,
                    });
                }
                Partner::Wall(wall) => {
                    let normal = wall.outward_normal();
                    let point = self.bodies.position_at(i, t) + normal * self.bodies.radius[i];
                    let group = self.collapse.group(event.body).filter(|_| resolve_pairs).map(<[u32]>::to_vec);
                    let impulse = match group {
                        // A merged group stops moving into the wall (see `collapse`).
                        Some(members) => {
                            let mut common = self.common_velocity(&members);
                            let into_wall = common.dot(normal).max(0.0);
                            common -= into_wall * normal;
                            let mass: f64 = members.iter().map(|&k| self.bodies.mass[k as usize]).sum();
                            self.move_together(&members, common, t, t1);
                            mass * into_wall
                        }
                        None => {
                            let v = self.bodies.velocity[i];
                            let bounced = wall_bounce(v, wall.axis(), restitution);
                            self.bodies.set_velocity_at(i, t, bounced);
                            self.retest(event.body, None, t, t1);
                            self.bodies.mass[i] * (v - bounced).length()
                        }
                    };
                    self.contacts.push(Contact { time: t, body: event.body, touched: Touched::Wall(wall), point, normal, impulse });
                }
            }
        }
    }

    /// Centre-of-mass velocity of `members` (ascending ids, so the sum is the same every time).
    fn common_velocity(&self, members: &[u32]) -> DVec3 {
        let mass: f64 = members.iter().map(|&k| self.bodies.mass[k as usize]).sum();
        members.iter().map(|&k| self.bodies.mass[k as usize] * self.bodies.velocity[k as usize]).sum::<DVec3>() / mass
    }

    /// The collapse rule (see [`crate::collapse`]): a merged group moves on with one velocity.
    fn move_together(&mut self, members: &[u32], velocity: DVec3, t: f64, t1: f64) {
        self.stats.collapse_contacts += 1;
        for &k in members {
            self.bodies.set_velocity_at(k as usize, t, velocity);
        }
        for &k in members {
            self.retest(k, None, t, t1);
        }
    }

    /// After `body` changed velocity at `t`: rebuild its volume and predict its contacts with the
    /// walls and its candidate partners (except `skip`, already tested) for the rest of the frame.
    fn retest(&mut self, body: u32, skip: Option<u32>, t: f64, t1: f64) {
        let World { bodies, broad, queue, stats, bounds, .. } = self;
        predict_wall(bodies, bounds, body, t, t1, queue);
        match broad {
            BroadPhase::SweepPrune(sap) => {
                sap.set_body(body, bodies, t, t1);
                sap.for_each_partner(body, bodies, t, t1, |other| {
                    if Some(other) != skip {
                        predict_pair(bodies, body, other, t, t1, queue, stats);
                    }
                });
            }
            BroadPhase::Brute => {
                for other in 0..bodies.slots() as u32 {
                    if other != body && Some(other) != skip && bodies.alive[other as usize] {
                        predict_pair(bodies, body, other, t, t1, queue, stats);
                    }
                }
            }
            BroadPhase::Grid(grid) => {
                grid.update_and_query(body, bodies, t, t1, |other| {
                    if Some(other) != skip {
                        predict_pair(bodies, body, other, t, t1, queue, stats);
                    }
                });
            }
            BroadPhase::Discrete(_) | BroadPhase::Unbuilt => {}
        }
    }

    /// Pseudo-dynamic method at the frame instant `t`: report new overlaps (detect) or resolve
    /// approaching ones (simulate).
    fn resolve_instant_overlaps(&mut self, t: f64) {
        let BroadPhase::Discrete(pd) = &mut self.broad else { return };
        let start = Instant::now();
        pd.update(&self.bodies);
        self.stats.update_seconds += start.elapsed().as_secs_f64();
        let start = Instant::now();
        self.stats.endpoint_swaps += pd.sort();
        self.stats.sort_seconds += start.elapsed().as_secs_f64();
        let start = Instant::now();
        self.stats.candidate_pairs += pd.find_overlaps(&self.bodies);
        self.stats.test_seconds += start.elapsed().as_secs_f64();
        let start = Instant::now();
        for &(a, b) in pd.overlapping() {
            let (i, j) = (a as usize, b as usize);
            let normal = (self.bodies.position[j] - self.bodies.position[i]).try_normalize().unwrap_or(DVec3::X);
            let mut impulse = 0.0;
            if self.config.mode == Mode::Simulate {
                let (wi, wj) = (self.bodies.inv_mass[i], self.bodies.inv_mass[j]);
                impulse = pair_impulse(normal, self.bodies.velocity[i], self.bodies.velocity[j], wi, wj, self.config.restitution);
                if impulse == 0.0 {
                    continue;
                }
                self.bodies.set_velocity_at(i, t, self.bodies.velocity[i] - impulse * wi * normal);
                self.bodies.set_velocity_at(j, t, self.bodies.velocity[j] + impulse * wj * normal);
            } else if !pd.is_new((a, b)) {
                continue;
            }
            self.stats.pair_contacts += 1;
            self.contacts.push(Contact {
                time: t,
                body: a,
                touched: Touched::Body(b),
                point: self.bodies.position[i] + normal * self.bodies.radius[i],
                normal,
                impulse,
            });
        }
        self.stats.response_seconds += start.elapsed().as_secs_f64();
    }
}

/// Relative velocities below this fraction of the bodies' speeds are rounding noise.
const NOISE_VELOCITY: f64 = 1e-12;

fn check_phi(phi: f64, pool: &AxisPool) -> Result<()> {
    let rho = pool.covering_radius();
    if !(phi.is_finite() && phi >= rho && phi <= std::f64::consts::FRAC_PI_2) {
        return Err(VadopError::BadPhi { got: phi, rho });
    }
    Ok(())
}

#[inline]
fn predict_pair(bodies: &Bodies, i: u32, j: u32, t: f64, t1: f64, queue: &mut EventQueue, stats: &mut FrameStats) {
    // Always the lower id first, so every method does bit-identical arithmetic for a pair.
    let (a, b) = if i < j { (i as usize, j as usize) } else { (j as usize, i as usize) };
    stats.narrow_tests += 1;
    let offset = bodies.position_at(b, t) - bodies.position_at(a, t);
    let relative_velocity = bodies.velocity[b] - bodies.velocity[a];
    if let Some(tau) = sphere_sphere_time(offset, relative_velocity, bodies.radius[a] + bodies.radius[b], t1 - t) {
        // A relative velocity within rounding of the bodies' own velocities is noise, not an
        // approach: without this, a pair brought to rest against each other would keep
        // "colliding" on rounding residues until they underflow. Checked only for predicted
        // contacts, which are far fewer than candidate pairs.
        if relative_velocity.length() <= NOISE_VELOCITY * (bodies.velocity[a].length() + bodies.velocity[b].length()) {
            return;
        }
        queue.push(Event {
            time: t + tau,
            body: a as u32,
            partner: Partner::Body(b as u32),
            body_stamp: bodies.stamp[a],
            partner_stamp: bodies.stamp[b],
        });
    }
}

#[inline]
fn predict_wall(bodies: &Bodies, bounds: &BoxBounds, body: u32, t: f64, t1: f64, queue: &mut EventQueue) {
    let i = body as usize;
    let position = bodies.position_at(i, t);
    if let Some((tau, wall)) = sphere_wall_time(position, bodies.velocity[i], bodies.radius[i], bounds.min, bounds.max, t1 - t) {
        queue.push(Event { time: t + tau, body, partner: Partner::Wall(wall), body_stamp: bodies.stamp[i], partner_stamp: 0 });
    }
}
