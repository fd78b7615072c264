//! Detect mode's wall bounces, their re-tests run ahead on every worker. There only walls turn
//! spheres, so a body's first wall bounce in a window is known at the window's start, and so is
//! its motion after it (a function of the body alone). What costs in its re-test is the query of
//! the window start's binned pieces and the pair tests of what it finds (about three quarters of
//! a re-test's instructions), which the event loop would run on one thread as the bounce pops.
//!
//! It owns that speculation only: the window's start lists each body's first wall contact, and
//! before each step's events every worker takes a range of the bounces the step reaches (of
//! bodies that have not moved since the window's start), makes the proxy each body would get
//! from its bounce, queries the binned pieces with it (the broad phase keeps them as they are
//! for the window, [`BroadPhase::fix_binned`]) and predicts each pair on the bounced motion.
//! When a body is re-tested without a partner to skip, the loop
//! takes these when the body's stamp and motion are, to the bit, the ones speculated (then its
//! proxy is the one queried): it keeps the predictions whose binned partners are still current,
//! and queries the pieces entered since the window's start itself. The queue gets the events the
//! full re-test would push, and the stats count the same tests, for every thread count; other
//! re-tests run as before. It never handles an event, and never changes a body.

use super::predict::{predict_pair, predict_straight_sphere_pair};
use super::Pipeline;
use crate::bodies::{Bodies, BodyState};
use crate::broad_phase::proxy::{Reported, Span};
use crate::broad_phase::BroadPhase;
use crate::event_queue::{Event, Partner};
use crate::frame::{FrameStats, Mode, Physics};
use crate::motion::Motion;
use crate::response::impact::motion_off_wall;
use crate::window::Window;

/// What a window's start found for bodies' first wall bounces: each bounce, followed by its
/// binned candidate partners.
#[derive(Debug, Clone, Copy)]
enum Ahead {
    /// Body `body` bounces on to `motion`, under `stamp`, and the proxy and flags it then gets.
    Bounce { body: u32, stamp: u32, motion: Motion, made: (Span, u8) },
    /// A binned candidate partner of the bounce before it, as the broad phase reported it (its
    /// body and stamp), and the pair's contact in the rest of the window on the bounced motion.
    Partner { body: u32, stamp: u32, event: Option<Event> },
}

/// The window's first wall bounces, re-tested ahead against the binned pieces.
#[derive(Debug, Default)]
pub(super) struct BouncesAhead {
    /// Each body's first wall contact of the window as predicted at its start, by body.
    pending: Vec<Event>,
    /// The bounces before this time have been run ahead.
    run_until: f64,
    /// The bounces run ahead last, each followed by its partners.
    found: Vec<Ahead>,
    /// Each bouncing body and the place of its bounce in `found`, by body.
    bounces: Vec<(u32, u32)>,
}

impl BouncesAhead {
    /// The proxy made ahead for body `body`'s motion now and the places in `found` of the
    /// partners run ahead for it, if its stamp and motion are the ones speculated.
    fn partners_of(&self, body: u32, bodies: &Bodies) -> Option<((Span, u8), std::ops::Range<usize>)> {
        let k = self.bounces.binary_search_by_key(&body, |&(b, _)| b).ok()?;
        let first = self.bounces[k].1 as usize;
        let Ahead::Bounce { stamp, motion, made, .. } = self.found[first] else { unreachable!("a bounce's place") };
        let now = bodies.motion(body as usize);
        let bits = |m: &Motion| {
            let (p, v) = (m.position.to_array(), m.velocity.to_array());
            [p[0], p[1], p[2], m.since, v[0], v[1], v[2]].map(f64::to_bits)
        };
        if stamp != bodies.stamp(body as usize) || bits(&motion) != bits(&now) {
            return None;
        }
        let end = self.bounces.get(k + 1).map_or(self.found.len(), |&(_, next)| next as usize);
        Some((made, first + 1..end))
    }

    pub(super) fn memory_bytes(&self) -> usize {
        self.pending.capacity() * std::mem::size_of::<Event>()
            + self.found.capacity() * std::mem::size_of::<Ahead>()
            + self.bounces.capacity() * 8
    }
}

impl<B: BroadPhase> Pipeline<B> {
    /// Window start, after the broad phase's preparation: every body's first wall contact of the
    /// window, from the window start's `predicted` wall contacts (and the rest of its bodies'
    /// own events), to run its bounce's re-test ahead once a step reaches it. Only where a bounce
    /// is all a wall contact does to a sphere and nothing else turns one: detect mode, plain
    /// spheres on straight paths without friction, in a box without periodic faces.
    pub(super) fn plan_bounces_ahead(&mut self, bodies: &Bodies, physics: &Physics, predicted: &[Event]) {
        let ahead = &mut self.bounces_ahead;
        ahead.pending.clear();
        ahead.run_until = self.window.start;
        let applies = physics.mode == Mode::Detect
            && !bodies.has_rigid()
            && bodies.straight_paths()
            && physics.friction == 0.0
            && !self.proxies.has_ghosts();
        if applies && self.broad.fix_binned() {
            ahead.pending.extend(predicted.iter().filter(|event| matches!(event.partner, Partner::Wall(_))));
        }
    }

    /// Before the events up to `until` are handled: the re-tests of the window's first wall
    /// bounces before then (those of bodies that have not moved since the window's start) run
    /// ahead against the binned pieces, on every worker; those of earlier steps are dropped, as
    /// they have popped. Run step by step rather than at the window's start, so a run that stops
    /// mid-window (or a window cut short) does not pay for bounces it never reaches. Out of line:
    /// a profile then tells its share apart.
    #[inline(never)]
    pub(super) fn retest_bounces_ahead(&mut self, bodies: &Bodies, physics: &Physics, until: f64) {
        let ahead = &mut self.bounces_ahead;
        let from = ahead.run_until;
        if ahead.pending.is_empty() || !(until > from) {
            return;
        }
        ahead.run_until = until;
        ahead.found.clear();
        ahead.bounces.clear();
        let (broad, table, proxies, window) = (&self.broad, &self.proxies, self.proxies.view(bodies), self.window);
        let pending = &ahead.pending;
        self.workers.extend_ranges(pending.len(), &mut ahead.found, |range, found| {
            for &Event { time, body, partner, body_stamp, .. } in &pending[range] {
                let (i, Partner::Wall(wall)) = (body as usize, partner) else { unreachable!("wall contacts") };
                if !(from <= time && time < until) || bodies.stamp(i) != body_stamp {
                    continue;
                }
                let motion = motion_off_wall(bodies, i, wall, time, physics.restitution);
                let state = BodyState { motion, radius: bodies.state[i].radius };
                let stamp = body_stamp.wrapping_add(1);
                let made = table.made_ahead(i, bodies, &motion, time);
                found.push(Ahead::Bounce { body, stamp, motion, made });
                let (own, rest) = (Reported { body, stamp, state: &state }, window.from(time));
                broad.query_binned(body, &proxies.path_ahead(i, &state, &made.0), proxies, |other, bounds| {
                    // Bounces run ahead only in a world of spheres on straight paths (see
                    // `plan_bounces_ahead`), and the binned pieces are of the window start's bodies.
                    let event = predict_straight_sphere_pair(bodies, own, other, bounds.intersect(rest));
                    found.push(Ahead::Partner { body: other.body, stamp: other.stamp, event });
                });
            }
        });
        let bounces = ahead.found.iter().enumerate().filter_map(|(k, record)| match *record {
            Ahead::Bounce { body, .. } => Some((body, k as u32)),
            Ahead::Partner { .. } => None,
        });
        ahead.bounces.extend(bounces);
    }

    /// Body `body` entered with the proxy made ahead and re-tested with its binned partners run
    /// ahead when they are its motion's (true), its later partners queried now; false, doing
    /// nothing, when none were run ahead for this motion.
    pub(super) fn retest_from_ahead(
        &mut self,
        body: u32,
        bodies: &Bodies,
        window: Window,
        stats: &mut FrameStats,
    ) -> bool {
        let Some((made, partners)) = self.bounces_ahead.partners_of(body, bodies) else { return false };
        self.proxies.enter_made(body as usize, bodies, made);
        let (queue, table, proxies, mut tests) = (&mut self.queue, &self.proxies, self.proxies.view(bodies), 0u64);
        let own = proxies.reported(body as usize);
        self.broad.update_late(body, proxies, None, |other, bounds| {
            tests += 1;
            if let Some(event) = predict_pair(bodies, table, own, other, bounds.intersect(window)) {
                queue.push(event);
            }
        });
        for record in &self.bounces_ahead.found[partners] {
            if let Ahead::Partner { body, stamp, event } = *record {
                if table.is_current(body as usize, stamp) {
                    tests += 1;
                    if let Some(event) = event {
                        queue.push(event);
                    }
                }
            }
        }
        stats.narrow_tests += tests;
        true
    }
}
