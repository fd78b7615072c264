//! What an impact makes an engine do, the same for the frame pipeline and the event loop: where
//! the bodies touch, the impact (through [`Impacts`]), the jam rule's freeze, the collisional
//! virial, the impulse reported, and which bodies must be tested again.
//!
//! It owns that sequence once, so both engines give the same bits for every contact; each
//! engine says, through [`Responder`], how it finds a cluster's members and what testing a moved
//! body again means to it (new proxies and predictions for the rest of the window, or a body's
//! next event). It never predicts a contact nor schedules an event itself.

use super::Pipeline;
use crate::bodies::{Bodies, Rest};
use crate::broad_phase::BroadPhase;
use crate::frame::{Contact, FrameStats, Output, Physics, Touched};
use crate::narrow_phase::contacts;
use crate::response::impact::{exchange_virial, is_plain_pair, Impacts, Resolution};
use crate::walls::Wall;
use glam::DVec3;

/// An engine, as an impact needs it.
pub(crate) trait Responder {
    /// The engine's impact scratch and contact history.
    fn impacts(&mut self) -> &mut Impacts;
    /// The jam rule on the bodies touching `seeds` at `t`, its members tested again; returns
    /// the cluster's virial.
    fn freeze_cluster(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        seeds: &[u32],
        t: f64,
        stats: &mut FrameStats,
    ) -> f64;
    /// Body `a` (and, given, body `b > a`) changed motion at `t`: test it again (them, the pair
    /// once).
    fn moved(&mut self, bodies: &Bodies, physics: &Physics, a: u32, b: Option<u32>, t: f64, stats: &mut FrameStats);
    /// Body `woken`, which lay still (see [`crate::response::rest`]), moves at `t`: the bodies
    /// it held up fall again.
    fn woke(&mut self, bodies: &mut Bodies, physics: &Physics, woken: usize, t: f64, stats: &mut FrameStats);
    /// Whether the engine's bodies may lie still: an impact then asks whether it woke one. The
    /// event loop runs without gravity, so none of its bodies does, and its impacts read nothing
    /// for it.
    const MAY_LIE_STILL: bool = true;
}

/// The impact of bodies `a < b` touching at `t`: where, the normal from `a` to `b`, how it was
/// resolved and the impulse to report. Pushed bodies are tested again and a jammed cluster frozen;
/// the virial of an impact between moving bodies is added to `stats` (impacts with static
/// bodies are the level's pressure, as the walls' are).
pub(crate) fn pair_impact<E: Responder>(
    engine: &mut E,
    bodies: &mut Bodies,
    physics: &Physics,
    (a, b): (u32, u32),
    t: f64,
    stats: &mut FrameStats,
) -> (DVec3, DVec3, Resolution, f64) {
    let (i, j) = (a as usize, b as usize);
    if is_plain_pair(bodies, physics, i, j) {
        return plain_pair_impact(engine, bodies, physics, (a, b), t, stats);
    }
    let still = lying_still::<E>(bodies, i, j);
    let between_moving = !bodies.is_fixed(i) && !bodies.is_fixed(j);
    let (point, normal) = contacts::pair_geometry(bodies, i, j, t);
    let before_j = bodies.velocity_at(j, t);
    let resolution = engine.impacts().pair(bodies, physics, (a, b), t, (point, normal), stats);
    let pushed = matches!(resolution, Resolution::Pushed(_)) && between_moving;
    let pushed_virial = if pushed { exchange_virial(bodies, (i, j), t, before_j) } else { 0.0 };
    let outcome = Outcome { normal, resolution, pushed_virial, between_moving, still };
    (point, normal, resolution, settle(engine, bodies, physics, (a, b), t, outcome, stats))
}

/// [`pair_impact`] of an [`is_plain_pair`] pair (two moving frictionless spheres without the
/// rest rule: every impact of a gas), which the event loop calls directly: the lean impact
/// reads each path once and finds the push's virial with it, and neither body can be static.
#[inline]
pub(crate) fn plain_pair_impact<E: Responder>(
    engine: &mut E,
    bodies: &mut Bodies,
    physics: &Physics,
    (a, b): (u32, u32),
    t: f64,
    stats: &mut FrameStats,
) -> (DVec3, DVec3, Resolution, f64) {
    let still = lying_still::<E>(bodies, a as usize, b as usize);
    let (touch, resolution, pushed_virial) = engine.impacts().plain_pair(bodies, physics, (a, b), t, stats);
    let outcome = Outcome { normal: touch.normal, resolution, pushed_virial, between_moving: true, still };
    (touch.point, touch.normal, resolution, settle(engine, bodies, physics, (a, b), t, outcome, stats))
}

/// Which of bodies `i` and `j` lie still before their impact (none in an engine whose bodies
/// never do).
#[inline(always)]
fn lying_still<E: Responder>(bodies: &Bodies, i: usize, j: usize) -> [bool; 2] {
    if E::MAY_LIE_STILL {
        [i, j].map(|k| bodies.rest_of(k) == Rest::Still)
    } else {
        [false; 2]
    }
}

/// What an impact resolved, as [`settle`] needs it.
struct Outcome {
    normal: DVec3,
    resolution: Resolution,
    /// The collisional virial of a push between moving bodies.
    pushed_virial: f64,
    between_moving: bool,
    /// Which of the two lay still before it.
    still: [bool; 2],
}

/// An impact's consequences for the engine: the jammed cluster frozen, or the pushed or rested
/// bodies tested again (and what a body lying still held up woken); the virial added. Returns
/// the impulse to report.
#[inline(always)]
fn settle<E: Responder>(
    engine: &mut E,
    bodies: &mut Bodies,
    physics: &Physics,
    (a, b): (u32, u32),
    t: f64,
    outcome: Outcome,
    stats: &mut FrameStats,
) -> f64 {
    let (i, j) = (a as usize, b as usize);
    let Outcome { normal, resolution, pushed_virial, between_moving, still } = outcome;
    match resolution {
        Resolution::Jammed { by_rule } => {
            let before = bodies.velocity_at(i, t);
            let virial = engine.freeze_cluster(bodies, physics, &[a, b], t, stats);
            if between_moving {
                stats.pair_virial += virial;
            }
            if by_rule {
                (bodies.mass(i) * (before - bodies.velocity(i)).dot(normal)).max(0.0)
            } else {
                0.0
            }
        }
        Resolution::Pushed(total) => {
            if between_moving {
                stats.pair_virial += pushed_virial;
            }
            engine.moved(bodies, physics, a, Some(b), t, stats);
            for (k, was_still) in [(i, still[0]), (j, still[1])] {
                if was_still && bodies.rest_of(k) != Rest::Still {
                    engine.woke(bodies, physics, k, t, stats);
                }
            }
            total
        }
        Resolution::Rested(k, total) => {
            engine.moved(bodies, physics, k, None, t, stats);
            total
        }
        Resolution::Parting | Resolution::Passed => 0.0,
    }
}

/// Body `a` touches `wall` at `t`: the impact (a jammed one freezes its cluster), the body
/// tested again, the contact reported.
pub(crate) fn wall_contact(
    engine: &mut impl Responder,
    bodies: &mut Bodies,
    physics: &Physics,
    a: u32,
    wall: Wall,
    t: f64,
    out: &mut Output,
) {
    let i = a as usize;
    let (point, normal) = contacts::wall_geometry(bodies, i, wall, &physics.bounds, t);
    let impulse = match engine.impacts().wall(bodies, physics, (a, wall), t, (point, normal), out.stats) {
        Resolution::Jammed { by_rule: true } => {
            let before = bodies.velocity_at(i, t);
            engine.freeze_cluster(bodies, physics, &[a], t, out.stats);
            bodies.mass(i) * (before - bodies.velocity(i)).length()
        }
        Resolution::Jammed { by_rule: false } => {
            engine.freeze_cluster(bodies, physics, &[a], t, out.stats);
            0.0
        }
        Resolution::Pushed(total) => {
            engine.moved(bodies, physics, a, None, t, out.stats);
            total
        }
        Resolution::Parting | Resolution::Passed | Resolution::Rested(..) => {
            unreachable!("a wall always turns a body back")
        }
    };
    out.contacts.push(Contact {
        time: t,
        body: bodies.handle(i),
        touched: Touched::Wall(wall),
        point,
        normal,
        impulse,
    });
}

impl<B: BroadPhase> Responder for Pipeline<B> {
    fn impacts(&mut self) -> &mut Impacts {
        &mut self.impacts
    }
    fn freeze_cluster(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        seeds: &[u32],
        t: f64,
        stats: &mut FrameStats,
    ) -> f64 {
        Pipeline::freeze_cluster(self, bodies, physics, seeds, t, stats)
    }
    /// The pair is re-tested once, by the second body, when both proxies are fresh (a rounding
    /// residue may still approach).
    fn moved(&mut self, bodies: &Bodies, physics: &Physics, a: u32, b: Option<u32>, t: f64, stats: &mut FrameStats) {
        match b {
            Some(b) => self.retest_pair(a, b, bodies, physics, t, stats),
            None => self.retest(a, None, bodies, physics, t, stats),
        }
    }
    fn woke(&mut self, bodies: &mut Bodies, physics: &Physics, woken: usize, t: f64, stats: &mut FrameStats) {
        self.wake_held(bodies, physics, woken, t, stats);
    }
}
