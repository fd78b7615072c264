//! Shapes passing through each other in detect mode, with their searches shared among the
//! workers. A pair contact there changes no body, and what costs is the search for the pair's
//! next contact (the end of this one, then the next start), which the event loop runs as each
//! contact pops, one at a time. The search's first probe measures the contact's point and normal
//! exactly, so a pass-through is measured once (on one worker too).
//!
//! It owns that speculation only: when a pass-through pops, the searches of the pass-throughs
//! queued right behind it run at once, on every worker, from the bodies as they are. The loop
//! still handles every event in order; a pass-through takes its search from here when both
//! bodies' stamps are still the event's (then their motions are the ones searched), and a search
//! whose event went void is dropped. Contacts, their order and every state are the loop's to
//! the bit, for every thread count. It never handles an event, and never changes a body.

use super::Pipeline;
use crate::bodies::Bodies;
use crate::broad_phase::BroadPhase;
use crate::event_queue::{Event, Partner};
use crate::frame::Physics;
use crate::narrow_phase::contacts::{self, Found, Parking};
use crate::response::impact;
use crate::window::Window;
use glam::DVec3;

/// Pass-throughs searched ahead per worker: enough to share out, few enough that most are still
/// valid when they pop.
const AHEAD_PER_WORKER: usize = 8;

/// What the search after one pass-through contact found.
#[derive(Debug, Clone, Copy)]
pub(super) struct Searched {
    /// The contact it was searched for.
    event: Event,
    /// Where the two touch, and the normal.
    pub(super) point_normal: (DVec3, DVec3),
    /// The pair's next contact start on the same motions, if any in the window.
    pub(super) next: Found,
    /// Where the search parked when it found none.
    pub(super) parks: Option<Parking>,
}

impl Searched {
    /// The search after the pass-through `event` on the bodies as they are, in `window`: the
    /// pair's next contact, where it parks, and where the two touch at `event` (measured by the
    /// search where it can, as for any reported contact otherwise).
    fn of(bodies: &Bodies, window: Window, event: Event) -> Searched {
        let Partner::Body(j) = event.partner else { unreachable!("pass-throughs are pair contacts") };
        let (i, j) = (event.body as usize, j as usize);
        let (next, parks, measured) =
            contacts::pair_start_after(bodies, i, j, event.time, window.from(event.time.next_up()));
        let point_normal = measured.unwrap_or_else(|| contacts::pair_geometry(bodies, i, j, event.time));
        Searched { event, point_normal, next, parks }
    }
}

/// Whether `event` (valid) is two moving bodies, not both spheres, passing through each other
/// (two spheres passing through are [`super::passed`]'s).
fn passes_through(bodies: &Bodies, physics: &Physics, event: &Event) -> bool {
    let Partner::Body(j) = event.partner else { return false };
    let (i, j) = (event.body as usize, j as usize);
    // Spheres first: a world of spheres answers with one load.
    !bodies.are_spheres(i, j) && impact::passes_through(bodies, physics, i, j)
}

impl<B: BroadPhase> Pipeline<B> {
    /// The search after the pass-through `event` (just popped, valid), from those run ahead, or
    /// with those behind it in the queue (before `until`) on every worker (alone on one); `None`
    /// when it is no pass-through (the loop then handles it as any contact).
    pub(super) fn searched_ahead(
        &mut self,
        bodies: &Bodies,
        physics: &Physics,
        event: &Event,
        until: f64,
    ) -> Option<Searched> {
        if !passes_through(bodies, physics, event) {
            return None;
        }
        if self.workers.threads() == 1 {
            return Some(Searched::of(bodies, self.window, *event));
        }
        // Searches for events that popped before this one are stale (their events went void).
        while self.ahead.front().is_some_and(|s| s.event > *event) {
            self.ahead.pop_front();
        }
        if self.ahead.front().is_none_or(|s| s.event != *event) {
            self.search_ahead(bodies, physics, *event, until);
        }
        self.ahead.pop_front().filter(|s| s.event == *event)
    }

    /// Searches `first` and the pass-throughs queued right behind it that are not searched yet,
    /// in parallel, and keeps them with those searched before, earliest first.
    fn search_ahead(&mut self, bodies: &Bodies, physics: &Physics, first: Event, until: f64) {
        let mut events = std::mem::take(&mut self.batch);
        events.clear();
        let limit = AHEAD_PER_WORKER * self.workers.threads();
        // Popping drops repeats of the event popped before (those of `first` too).
        while events.len() < limit {
            let Some((event, _)) = self.queue.pop_before(until) else { break };
            events.push(event);
        }
        events.iter().for_each(|&event| self.queue.put_back(event));
        let ahead = &self.ahead;
        events.retain(|event| {
            event.is_current(bodies)
                && passes_through(bodies, physics, event)
                && !ahead.iter().any(|s| s.event == *event)
        });
        events.insert(0, first);
        let (window, mut searched) = (self.window, std::mem::take(&mut self.searched));
        searched.clear();
        self.workers.extend_ranges(events.len(), &mut searched, |range, found| {
            found.extend(events[range].iter().map(|&event| Searched::of(bodies, window, event)));
        });
        self.ahead.extend(searched.drain(..));
        // Earliest first: the events' order is reversed.
        self.ahead.make_contiguous().sort_unstable_by_key(|s| std::cmp::Reverse(s.event));
        (self.batch, self.searched) = (events, searched);
    }
}
