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
use crate::frame::{FrameStats, Output, Physics};
use crate::parallel::Workers;
use crate::pipeline::pseudo_dynamic::PseudoDynamic;
use crate::pipeline::{Pipeline, WindowRule};
use crate::response::rules::ContactRules;
use crate::walls::BoxBounds;
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
        Method::Grid | Method::Auto => {
            Box::new(Pipeline::new(Grid::new(min, max), WindowRule::Adaptive, bounds, workers))
        }
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
