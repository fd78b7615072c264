//! What a velocity change re-tests: the body's fresh proxy enters the broad phase, and its
//! contacts with its candidate partners, the walls, the static geometry and (with ends
//! reported) the end of each contact it is in are predicted for the rest of the window. A wall
//! bounce foreseen at the window's start (see [`super::foreseen`]) is not re-tested: its pairs
//! and its next wall contact were predicted then, and only its own events are queued here.
//!
//! It owns that re-test only. A shape's searches against its partners are independent of one
//! another, so in a world of shapes with more than one worker they run on every worker, and
//! their events and parked searches are kept in the partners' order, as one worker would: the
//! queue and the store come out the same for every thread count. It never handles an event.

use super::{for_each_static_event, predict_crossing, predict_end, predict_into, predict_pair, predict_wall, renewal};
use super::{sort_predictions, Pipeline, Prediction};
use crate::bodies::Bodies;
use crate::broad_phase::proxy::Reported;
use crate::broad_phase::BroadPhase;
use crate::event_queue::Event;
use crate::frame::{FrameStats, Physics};
use crate::window::Window;

/// Below this many candidate partners a re-test is not worth sharing out.
const SHARED_PARTNERS: usize = 4;

impl<B: BroadPhase> Pipeline<B> {
    /// After `body` changed velocity at `t`: a fresh proxy, and its contacts with the walls and
    /// its candidate partners (except `skip`, tested by the partner) for the rest of the window.
    pub(super) fn retest(
        &mut self,
        body: u32,
        skip: Option<u32>,
        bodies: &Bodies,
        physics: &Physics,
        t: f64,
        stats: &mut FrameStats,
    ) {
        self.updates += 1;
        stats.retests += 1;
        let window = self.window.from(t);
        self.proxies.enter(body as usize, bodies, t);
        // The body's own proxy, then (in a periodic box) its ghosts: each meets the bodies near
        // it. `skip` names a body, which a ghost's partners are told apart by.
        for slot in self.proxies.slots_of(body as usize) {
            let slot = slot as u32;
            let (skip_slot, skip_body) = if slot == body { (skip, None) } else { (None, skip) };
            self.retest_slot(slot, (skip_slot, skip_body), bodies, window, stats);
        }
        self.predict_own_events(body, bodies, physics, window);
    }

    /// Body `body`'s contacts with the walls and the static geometry, its crossing of a periodic
    /// face, its proxy's renewal and (with ends reported) the end of each contact it is in, in
    /// `window`, from its proxy just entered.
    pub(super) fn predict_own_events(&mut self, body: u32, bodies: &Bodies, physics: &Physics, window: Window) {
        let wall = predict_wall(bodies, &self.proxies, &physics.bounds, body, window);
        self.push_own_events(body, wall, bodies, physics, window);
    }

    /// [`Self::predict_own_events`] with the wall contact, `wall`, predicted already.
    pub(super) fn push_own_events(
        &mut self,
        body: u32,
        wall: Option<Event>,
        bodies: &Bodies,
        physics: &Physics,
        window: Window,
    ) {
        let (queue, proxies) = (&mut self.queue, self.proxies.view(bodies));
        if let Some(event) = wall {
            queue.push(event);
        }
        if let Some(event) = predict_crossing(bodies, &physics.bounds, body, window) {
            queue.push(event);
        }
        for_each_static_event(bodies, proxies, &self.statics, body as usize, window, |event| queue.push(event));
        if self.proxies.expires(body as usize) {
            queue.push(renewal(bodies, &self.proxies, body));
        }
        if physics.report_ends {
            for (other, since) in self.touching.contacts_of(body) {
                if let Some(event) = predict_end(bodies, body, other, since, window) {
                    queue.push(event);
                }
            }
        }
    }

    /// Enters proxy `slot` (a body's, or one of its ghosts) into the broad phase, predicting its
    /// contacts with its candidate partners in `window`, but for the proxy `skip.0` and the
    /// proxies of body `skip.1`.
    fn retest_slot(
        &mut self,
        slot: u32,
        (skip_slot, skip_body): (Option<u32>, Option<u32>),
        bodies: &Bodies,
        window: Window,
        stats: &mut FrameStats,
    ) {
        let (proxies, table) = (self.proxies.view(bodies), &self.proxies);
        let skipped =
            |other: &Reported| skip_body.is_some_and(|b| table.owner(other.body, other.stamp).map(|o| o.0) == Some(b));
        // The slot as the broad phase reports it, its state borrowed from the store alone.
        let own = proxies.reported(slot as usize);
        if !bodies.has_rigid() {
            let (queue, mut tests) = (&mut self.queue, 0u64);
            self.broad.update(slot, proxies, skip_slot, |other, bounds| {
                if skipped(&other) {
                    return;
                }
                tests += 1;
                if let Some(event) = predict_pair(bodies, table, own, other, bounds.intersect(window)) {
                    queue.push(event);
                }
            });
            stats.narrow_tests += tests;
        } else {
            let mut partners = std::mem::take(&mut self.partners);
            partners.clear();
            self.broad.update(slot, proxies, skip_slot, |other, bounds| {
                if !skipped(&other) {
                    partners.push((other.body, other.stamp, bounds.intersect(window)));
                }
            });
            stats.narrow_tests += partners.len() as u64;
            let reported = |(other, stamp, _): (u32, u32, Window)| Reported {
                body: other,
                stamp,
                state: proxies.state(other as usize),
            };
            let (mut found, parked) = (std::mem::take(&mut self.predictions), &self.parked);
            found.clear();
            let predict = |range: std::ops::Range<usize>, out: &mut Vec<Prediction>| {
                for &partner in &partners[range] {
                    predict_into(bodies, table, (own, reported(partner), partner.2), parked, out);
                }
            };
            if self.workers.threads() > 1 && partners.len() >= SHARED_PARTNERS {
                self.workers.extend_ranges(partners.len(), &mut found, predict);
            } else {
                predict(0..partners.len(), &mut found);
            }
            let queue = &mut self.queue;
            sort_predictions(&mut found, &mut self.parked, self.window.start, |event| queue.push(event));
            self.predictions = found;
            self.partners = partners;
        }
    }
}
