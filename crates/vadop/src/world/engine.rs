//! The engine wiring: which engine steps a world for each [`Method`], and the one interface the
//! world drives every engine through. A new broad phase is its own file under `broad_phase/`,
//! one [`Method`] variant and one arm of [`build`]; nothing else in the world changes. It owns
//! that choice and the interface only; the engines own their stepping, the world its bodies.

use super::config::{Method, WorldConfig};
use crate::axis_pool::AxisPool;
use crate::bodies::Bodies;
use crate::broad_phase::brute_force::BruteForce;
use crate::broad_phase::grid::Grid;
use crate::broad_phase::sweep_prune::SweepPrune;
use crate::broad_phase::BroadPhase;
use crate::event_loop::EventLoop;
use crate::frame::{FrameStats, Mode, Output, Physics};
use crate::parallel::Workers;
use crate::pipeline::pseudo_dynamic::PseudoDynamic;
use crate::pipeline::{Pipeline, WindowRule};
use crate::response::rules::ContactRules;
use crate::walls::BoxBounds;
use glam::DVec3;
use std::any::Any;
use std::sync::Arc;

/// What the world asks of the engine that steps it: one frame pipeline over a broad phase, or
/// the pseudo-dynamic stepper. Called once per step or per body entered, never per contact, so
/// the dynamic call costs nothing measurable while each pipeline stays monomorphic inside.
pub(crate) trait Engine: Send + std::fmt::Debug {
    /// Steps the bodies from `t0` to `t1`.
    fn step(&mut self, bodies: &mut Bodies, physics: &Physics, t0: f64, t1: f64, out: &mut Output);
    /// Enters body `i`, added since the last step, at `t`.
    fn enter(&mut self, i: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats);
    /// Body `i`, entered before, was given a new motion between frames at `t`.
    fn reenter(&mut self, i: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats);
    /// Forgets body `i` (removed between frames).
    fn remove(&mut self, i: u32);
    /// The per-body contact history of the contact rules.
    fn rules(&self) -> &ContactRules;
    fn rules_mut(&mut self) -> &mut ContactRules;
    /// The pairs in contact now (the pseudo-dynamic stepper: overlapping at the last instant).
    fn touching_pairs(&self) -> Vec<(u32, u32)>;
    /// The pairs in contact now with the time each contact started, as a saved world keeps them.
    fn touching_since(&self) -> (Vec<(u32, u32)>, Vec<f64>);
    /// Puts back the pairs in contact (`since` empty when the engine keeps no start times).
    fn restore_touching(&mut self, pairs: Vec<(u32, u32)>, since: Vec<f64>);
    /// Whether an interrupted step can be taken back (the pseudo-dynamic stepper is only stopped
    /// before a step starts).
    fn can_undo(&self) -> bool;
    /// Bytes held: broad phase, proxies, queue and rules.
    fn memory_bytes(&self) -> usize;
    /// The broad phase, for callers that inspect it (the sweep and prune's lists).
    fn broad_phase(&self) -> Option<&dyn Any>;
    /// True while simulate mode's event loop of spheres steps the world.
    fn on_event_loop(&self) -> bool {
        false
    }
}

impl<B: BroadPhase + Send + std::fmt::Debug + 'static> Engine for Pipeline<B> {
    fn step(&mut self, bodies: &mut Bodies, physics: &Physics, t0: f64, t1: f64, out: &mut Output) {
        Pipeline::step(self, bodies, physics, t0, t1, out)
    }
    fn enter(&mut self, i: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats) {
        Pipeline::enter(self, i, bodies, physics, t, stats)
    }
    fn reenter(&mut self, i: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats) {
        Pipeline::enter(self, i, bodies, physics, t, stats)
    }
    fn remove(&mut self, i: u32) {
        Pipeline::remove(self, i)
    }
    fn rules(&self) -> &ContactRules {
        &self.impacts.rules
    }
    fn rules_mut(&mut self) -> &mut ContactRules {
        &mut self.impacts.rules
    }
    fn touching_pairs(&self) -> Vec<(u32, u32)> {
        self.touching.pairs()
    }
    fn touching_since(&self) -> (Vec<(u32, u32)>, Vec<f64>) {
        self.touching.contacts().into_iter().map(|(a, b, since)| ((a, b), since)).unzip()
    }
    fn restore_touching(&mut self, pairs: Vec<(u32, u32)>, since: Vec<f64>) {
        for ((a, b), since) in pairs.into_iter().zip(since) {
            self.touching.insert(a, b, since);
        }
    }
    fn can_undo(&self) -> bool {
        true
    }
    fn memory_bytes(&self) -> usize {
        Pipeline::memory_bytes(self)
    }
    fn broad_phase(&self) -> Option<&dyn Any> {
        Some(self.broad())
    }
}

impl Engine for PseudoDynamic {
    fn step(&mut self, bodies: &mut Bodies, physics: &Physics, t0: f64, t1: f64, out: &mut Output) {
        PseudoDynamic::step(self, bodies, physics, t0, t1, out)
    }
    fn enter(&mut self, i: u32, bodies: &Bodies, _: &Physics, _: f64, _: &mut FrameStats) {
        self.rules.resize(bodies.slots());
        self.add_body(i);
    }
    /// Nothing to do: the sweep list is re-sorted from the motions at every frame's end.
    fn reenter(&mut self, _: u32, _: &Bodies, _: &Physics, _: f64, _: &mut FrameStats) {}
    fn remove(&mut self, i: u32) {
        self.remove_body(i)
    }
    fn rules(&self) -> &ContactRules {
        &self.rules
    }
    fn rules_mut(&mut self) -> &mut ContactRules {
        &mut self.rules
    }
    fn touching_pairs(&self) -> Vec<(u32, u32)> {
        self.overlapping().to_vec()
    }
    fn touching_since(&self) -> (Vec<(u32, u32)>, Vec<f64>) {
        (self.overlapping().to_vec(), Vec::new())
    }
    fn restore_touching(&mut self, pairs: Vec<(u32, u32)>, _: Vec<f64>) {
        self.set_overlapping(pairs)
    }
    fn can_undo(&self) -> bool {
        false
    }
    fn memory_bytes(&self) -> usize {
        PseudoDynamic::memory_bytes(self)
    }
    fn broad_phase(&self) -> Option<&dyn Any> {
        None
    }
}

/// The engine of `method` (resolved: not [`Method::Auto`]) for a world in `bounds` with `config`
/// and the axis `pool`, sharing its bulk work among `workers`.
pub(crate) fn build(
    method: Method,
    config: &WorldConfig,
    pool: &Arc<AxisPool>,
    bounds: &BoxBounds,
    workers: Workers,
) -> Box<dyn Engine> {
    let (min, max) = (bounds.min, bounds.max);
    match method {
        // The oracle: one window per frame, nothing adaptive between it and the truth.
        Method::Brute => Box::new(Pipeline::new(BruteForce::default(), WindowRule::Frame, bounds, workers)),
        Method::Discrete => Box::new(PseudoDynamic::default()),
        // The default in simulate mode without gravity: the event loop of spheres while every
        // body is one (see `crate::event_loop`), the grid's pipeline from the first that is not.
        Method::Grid | Method::Auto if starts_on_event_loop(config) => {
            let spheres = EventLoop::new(bounds, workers.threads());
            Box::new(SpheresFirst { spheres: Some(spheres), general: None, bounds: *bounds, workers })
        }
        Method::Grid | Method::Auto => Box::new(grid_pipeline(bounds, workers)),
        Method::Vadop => {
            let phi = config.phi.unwrap_or(pool.covering_radius());
            // A hair wider than phi, so rounding never costs a pair its shared axis.
            let sin_phi = (phi.sin() * (1.0 + 1e-12) + 1e-15).min(1.0);
            let sap = SweepPrune::new(pool.clone(), sin_phi, min, max, true);
            Box::new(Pipeline::new(sap, WindowRule::Adaptive, bounds, workers))
        }
        Method::SweptKdop => {
            let sap = SweepPrune::new(pool.clone(), 1.0, min, max, true);
            Box::new(Pipeline::new(sap, WindowRule::Adaptive, bounds, workers))
        }
        Method::SweptAabb => {
            let coordinate_axes = AxisPool::new(3).expect("the 3-axis pool always builds");
            let sap = SweepPrune::new(coordinate_axes, 1.0, min, max, false);
            Box::new(Pipeline::new(sap, WindowRule::Adaptive, bounds, workers))
        }
    }
}

/// True when a world of `config` starts on the event loop of spheres: [`Method::Auto`] in simulate
/// mode without gravity (it keeps to it while every body is a moving sphere).
pub(super) fn starts_on_event_loop(config: &WorldConfig) -> bool {
    config.method == Method::Auto && config.mode == Mode::Simulate && config.gravity == DVec3::ZERO
}

/// The grid's frame pipeline: the default method's broad phase.
fn grid_pipeline(bounds: &BoxBounds, workers: Workers) -> Pipeline<Grid> {
    Pipeline::new(Grid::new(bounds.min, bounds.max), WindowRule::Adaptive, bounds, workers)
}

/// [`Method::Auto`] in simulate mode without gravity: the event loop of spheres while every body
/// is a moving sphere, then, from the first shape or static body added, the grid's frame
/// pipeline, which takes the bodies and their contact history over at the instant of the hand-over
/// (both predict from the same canonical times, so nothing changes there).
#[derive(Debug)]
struct SpheresFirst {
    spheres: Option<EventLoop>,
    general: Option<Pipeline<Grid>>,
    bounds: BoxBounds,
    workers: Workers,
}

impl SpheresFirst {
    /// The pipeline, taking the event loop's bodies over at `t` if it has not yet.
    fn general(&mut self, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats) -> &mut Pipeline<Grid> {
        if let Some(mut spheres) = self.spheres.take() {
            let mut pipeline = grid_pipeline(&self.bounds, self.workers);
            pipeline.impacts.rules = std::mem::take(&mut spheres.impacts.rules);
            for i in spheres.bodies() {
                pipeline.enter(i, bodies, physics, t, stats);
            }
            self.general = Some(pipeline);
        }
        self.general.as_mut().expect("the pipeline takes over from the event loop")
    }

    fn engine(&self) -> &dyn Engine {
        match (&self.spheres, &self.general) {
            (Some(spheres), _) => spheres,
            (None, general) => general.as_ref().expect("one of the two steps the world"),
        }
    }
}

impl Engine for SpheresFirst {
    fn step(&mut self, bodies: &mut Bodies, physics: &Physics, t0: f64, t1: f64, out: &mut Output) {
        // A static body added since: the level is the pipeline's.
        if bodies.rigid.statics_revision != 0 {
            self.general(bodies, physics, t0, out.stats);
        }
        match (&mut self.spheres, &mut self.general) {
            (Some(spheres), _) => spheres.step(bodies, physics, t0, t1, out),
            (None, Some(general)) => general.step(bodies, physics, t0, t1, out),
            (None, None) => unreachable!("one of the two steps the world"),
        }
    }
    fn enter(&mut self, i: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats) {
        match &mut self.spheres {
            Some(spheres) if EventLoop::takes(bodies, i as usize) => spheres.enter(i, bodies, t, stats),
            _ => self.general(bodies, physics, t, stats).enter(i, bodies, physics, t, stats),
        }
    }
    fn reenter(&mut self, i: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats) {
        self.enter(i, bodies, physics, t, stats)
    }
    fn remove(&mut self, i: u32) {
        match (&mut self.spheres, &mut self.general) {
            (Some(spheres), _) => spheres.remove(i),
            (None, Some(general)) => general.remove(i),
            (None, None) => {}
        }
    }
    fn rules(&self) -> &ContactRules {
        self.engine().rules()
    }
    fn rules_mut(&mut self) -> &mut ContactRules {
        match (&mut self.spheres, &mut self.general) {
            (Some(spheres), _) => &mut spheres.impacts.rules,
            (None, general) => &mut general.as_mut().expect("one of the two steps the world").impacts.rules,
        }
    }
    fn touching_pairs(&self) -> Vec<(u32, u32)> {
        self.engine().touching_pairs()
    }
    fn touching_since(&self) -> (Vec<(u32, u32)>, Vec<f64>) {
        self.engine().touching_since()
    }
    fn restore_touching(&mut self, pairs: Vec<(u32, u32)>, since: Vec<f64>) {
        // Simulate mode keeps no pairs in contact; the pipeline's, after a hand-over, would.
        if let Some(general) = &mut self.general {
            general.restore_touching(pairs, since);
        }
    }
    fn can_undo(&self) -> bool {
        true
    }
    fn memory_bytes(&self) -> usize {
        self.engine().memory_bytes()
    }
    fn broad_phase(&self) -> Option<&dyn Any> {
        self.engine().broad_phase()
    }
    fn on_event_loop(&self) -> bool {
        self.spheres.is_some()
    }
}

/// The event loop as an engine: simulate mode keeps no pairs in contact.
impl Engine for EventLoop {
    fn step(&mut self, bodies: &mut Bodies, physics: &Physics, t0: f64, t1: f64, out: &mut Output) {
        EventLoop::step(self, bodies, physics, t0, t1, out)
    }
    fn enter(&mut self, i: u32, bodies: &Bodies, _: &Physics, t: f64, stats: &mut FrameStats) {
        EventLoop::enter(self, i, bodies, t, stats)
    }
    fn reenter(&mut self, i: u32, bodies: &Bodies, _: &Physics, t: f64, stats: &mut FrameStats) {
        EventLoop::enter(self, i, bodies, t, stats)
    }
    fn remove(&mut self, i: u32) {
        EventLoop::remove(self, i)
    }
    fn rules(&self) -> &ContactRules {
        &self.impacts.rules
    }
    fn rules_mut(&mut self) -> &mut ContactRules {
        EventLoop::rules_mut(self)
    }
    fn touching_pairs(&self) -> Vec<(u32, u32)> {
        Vec::new()
    }
    fn touching_since(&self) -> (Vec<(u32, u32)>, Vec<f64>) {
        (Vec::new(), Vec::new())
    }
    fn restore_touching(&mut self, _: Vec<(u32, u32)>, _: Vec<f64>) {}
    fn can_undo(&self) -> bool {
        true
    }
    fn memory_bytes(&self) -> usize {
        EventLoop::memory_bytes(self)
    }
    fn broad_phase(&self) -> Option<&dyn Any> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{GeneratedScene, Scene, Velocities, FRAMES_PER_SECOND};
    use crate::World;

    /// A gas of `bodies` spheres at `packing` (thinned when too dense to place), periodic on
    /// `periodic`.
    fn gas(bodies: usize, packing: f64, periodic: [bool; 3], seed: u64) -> Scene {
        let velocities = Velocities::Maxwell { rms_speed: 0.5 };
        let mut fraction = packing;
        let mut scene = loop {
            match (GeneratedScene { bodies, packing_fraction: fraction, velocities, radius: 0.5, seed }).build() {
                Ok(scene) => break scene,
                Err(_) => fraction *= 0.9,
            }
        };
        scene.bounds = scene.bounds.with_periodic(periodic);
        scene
    }

    /// The world of `scene`, with its engine the event loop on `workers` workers (the parallel
    /// loop from 2 on, as it runs from [`crate::event_loop`]'s threshold of threads).
    fn on_workers(scene: &Scene, config: WorldConfig, workers: usize) -> World {
        let mut world = scene.world(config).unwrap();
        let spheres = EventLoop::with_workers(&world.bounds, workers);
        let threads = Workers::new(config.thread_count());
        world.engine = Some(Box::new(SpheresFirst {
            spheres: Some(spheres),
            general: None,
            bounds: world.bounds,
            workers: threads,
        }));
        world.threads = crate::interrupt::pool(2, &world.watched);
        world
    }

    /// `world` stepped by the event loop `spheres`, on one thread.
    fn serially_on(world: &mut World, spheres: EventLoop) {
        let (bounds, workers) = (world.bounds, Workers::serial());
        world.engine = Some(Box::new(SpheresFirst { spheres: Some(spheres), general: None, bounds, workers }));
    }

    /// Steps `found` and `expected` by `frames` frames of changing lengths, checking that they give
    /// the same contacts and virial each frame and the same states at the end (case `k`); returns
    /// how many contacts there were.
    fn same_bits(found: &mut World, expected: &mut World, frames: usize, k: usize) -> usize {
        let mut total = 0;
        for frame in 0..frames {
            let dt = [0.2, 1.0, 3.0][frame % 3] / FRAMES_PER_SECOND;
            let contacts = expected.step(dt).unwrap().to_vec();
            assert_eq!(found.step(dt).unwrap(), contacts, "case {k}, frame {frame}");
            assert_eq!(found.stats().pair_virial.to_bits(), expected.stats().pair_virial.to_bits());
            total += contacts.len();
        }
        let state = |w: &World| w.spheres().map(|(_, s)| format!("{s:?}")).collect::<Vec<_>>();
        assert_eq!(state(found), state(expected), "case {k}: final states differ");
        total
    }

    /// The parallel event loop gives the serial loop's bits, contacts and states, frame after frame,
    /// on 2 and 3 workers, in walled and periodic boxes, elastic and not, with frames of changing
    /// lengths; and after every batch the copy of the world its workers read is the world (see
    /// `ahead::Mirror::check`).
    #[test]
    fn the_parallel_event_loop_gives_the_serial_loop_s_bits() {
        let cases =
            [(0.05, [true; 3], 1.0), (0.3, [true; 3], 1.0), (0.4, [false; 3], 1.0), (0.2, [true, false, true], 0.6)];
        for (k, (packing, periodic, restitution)) in cases.into_iter().enumerate() {
            let scene = gas(1500, packing, periodic, k as u64);
            let config = WorldConfig { restitution, threads: Some(2), ..WorldConfig::default() };
            for workers in [2, 3] {
                let (mut serial, mut parallel) = (on_workers(&scene, config, 1), on_workers(&scene, config, workers));
                let total = same_bits(&mut parallel, &mut serial, 12, k);
                assert!(total > 2000, "case {k}, {workers} workers: {total} contacts");
            }
        }
    }

    /// The serial loop with neighbour lists, kept whatever the packing, gives brute force's bits
    /// (contacts, virial and states, frame after frame) and its lists stay complete: sparse and
    /// dense gases in periodic, walled and mixed boxes, elastic and not, frames of changing
    /// lengths, a few bodies thirty times faster than the rest, which leave their shells and cross
    /// periodic faces many times a frame, bodies of one radius and of two, and lists outgrowing
    /// their blocks.
    #[test]
    fn neighbour_lists_give_brute_force_s_bits() {
        let cases =
            [(0.05, [true; 3], 1.0), (0.2, [false; 3], 1.0), (0.45, [true; 3], 1.0), (0.35, [true, false, true], 0.6)];
        for (k, (packing, periodic, restitution)) in cases.into_iter().enumerate() {
            let mut scene = gas(600, packing, periodic, 20 + k as u64);
            for sphere in scene.spheres.iter_mut().step_by(37) {
                sphere.velocity *= 30.0;
            }
            // Two radii in every other case: the lists' reach then comes from each pair's radii
            // (`lists::Radii`), in the others from the one radius of them all.
            for sphere in scene.spheres.iter_mut().step_by(5).filter(|_| k % 2 == 1) {
                sphere.radius *= 0.8;
            }
            let config = WorldConfig { restitution, threads: Some(1), ..WorldConfig::default() };
            let mut listed = scene.world(config).unwrap();
            let mut spheres = EventLoop::with_workers(&listed.bounds, 1);
            // Blocks of 3 entries in every other case: lists outgrow them, and are widened.
            spheres.keep_lists_always(if k % 2 == 1 { 3 } else { 31 });
            spheres.check_screen_each_step();
            serially_on(&mut listed, spheres);
            let mut oracle = scene.world(WorldConfig { method: Method::Brute, ..config }).unwrap();
            let total = same_bits(&mut listed, &mut oracle, 10, k);
            assert!(total > 300, "case {k}: {total} contacts");
        }
    }

    /// The search's screen never changes a body's next event: with it and without it, every body
    /// of dense and sparse gases finds the same one, after every frame of collisions.
    #[test]
    fn the_screen_never_changes_a_next_event() {
        for (k, (packing, periodic)) in
            [(0.05, [true; 3]), (0.45, [true; 3]), (0.3, [false, true, false])].into_iter().enumerate()
        {
            let scene = gas(2000, packing, periodic, 10 + k as u64);
            let mut world = on_workers(&scene, WorldConfig { threads: Some(1), ..WorldConfig::default() }, 1);
            let mut spheres = EventLoop::with_workers(&world.bounds, 1);
            spheres.check_screen_each_step();
            serially_on(&mut world, spheres);
            for _ in 0..6 {
                assert!(!world.step(1.0 / FRAMES_PER_SECOND).unwrap().is_empty());
            }
        }
    }
}
