//! The frame pipeline of the continuous methods: proxies → candidate pairs → predicted contacts →
//! the event loop, window after window.
//!
//! It owns the scheduling: the broad-phase window, the proxy table, the event queue, what a
//! velocity change re-tests, the jam rule's clusters, and the loop that ties the stages together;
//! how an impact changes the bodies is the response's ([`crate::response`]). A *window* is the stretch of time one broad-phase pass
//! covers; it is chosen from the bodies' speeds, not from the caller's frames, so a window may
//! span many short frames or a long frame many windows, and the cost of a frame does not depend
//! on its length beyond the contacts in it. At a window's start every proxy is refreshed, the
//! broad phase reports its candidate pairs and every pair contact (and, with contact ends on, the
//! end of every pair in contact), every contact with static level geometry and every wall
//! contact inside the window is predicted into the queue. The loop then pops events in time
//! order up to the frame's end: a contact is reported and resolved (in simulate mode; against
//! walls and static bodies in detect mode too), and every body whose velocity changed gets a
//! fresh proxy and is re-tested against its candidate partners for the rest of the window. Events
//! left in the queue at a frame's end stay valid for the next frame.
//!
//! Exactness: contact times are canonical (see [`crate::narrow_phase::spheres`]) and each prediction is
//! kept only inside the window its bounds hold for, so every contact is predicted, and reported
//! once, in the frame whose `[start, end)` holds its time, whichever window, frame length or
//! method finds it. It never validates input (the world does), never reads a broad phase's
//! internals and never computes an impulse.

mod foreseen;
pub(crate) mod jam;
mod pass_through;
mod passed;
pub(crate) mod predict;
pub(crate) mod pseudo_dynamic;
pub(crate) mod respond;
mod retest;
pub(crate) mod touching;
mod wake;

use crate::bodies::Bodies;
use crate::broad_phase::proxy::{sampled_quantile, Proxies, ProxyTable, Reported};
use crate::broad_phase::BroadPhase;
use crate::event_queue::{Event, EventQueue, Partner};
use crate::frame::{Contact, FrameStats, Mode, Touched};
use crate::frame::{Output, Physics};
use crate::narrow_phase::contacts::{self, Parking};
use crate::narrow_phase::parked::ParkedSearches;
use crate::narrow_phase::static_geometry::StaticGeometry;
use crate::parallel::Workers;
use crate::pipeline::touching::Touching;
use crate::response::impact::{passes_through, Impacts, Resolution};
use crate::walls::BoxBounds;
use crate::window::Window;
use foreseen::ForeseenBounces;
use glam::DVec3;
use pass_through::Searched;
use passed::{Ahead, PassedContacts};
use predict::{
    for_each_static_event, pair_event, predict_crossing, predict_end, predict_into, predict_own_pair,
    straight_sphere_event_at, StraightSpheres,
};
use predict::{predict_pair, push_found};
use predict::{predict_wall, renewal, sort_predictions, Prediction};
use std::collections::VecDeque;
use std::time::Instant;

/// A window ends early once this many proxies per live body were refreshed within it: the broad
/// phase's mid-window entries then cost more than starting afresh.
const UPDATES_PER_BODY: usize = 2;
/// Windows last as long as the fastest tenth of the bodies takes to travel this many of their
/// own diameters (then halved while windows keep ending early): long enough to amortise a window's
/// start over many events, short enough that paths stay a piece or two. A calm window (few
/// re-tests expected) is longer: its start is what costs, not re-testing what it holds. 4.5
/// rather than 3 once the grid's pair sweep skipped the neighbour cells a box cannot reach: about
/// 6 % fewer instructions at 5 diameters/frame (BENCHMARKS.md, eleventh session).
const WINDOW_DIAMETERS: f64 = 2.0;
const CALM_WINDOW_DIAMETERS: f64 = 4.5;
/// A calm window of a world with shapes stays at 3: their pair predictions, not the window's start,
/// are what costs, and a longer window predicts more (the peers' shapes at 5 d/f: 8.6 % more
/// instructions at 4.5; BENCHMARKS.md, eleventh session).
const SHAPE_CALM_WINDOW_DIAMETERS: f64 = 3.0;
/// A window is calm when the last one refreshed fewer proxies mid-window than this, per live
/// body and per diameter the fastest tenth travels. Measured: the paper scene in detect mode
/// (only wall bounces) refreshes about 0.02, the equilibrium gas at packing 0.05 about 0.3 and
/// at 0.3 about 4. The calm settings make the first 1.2-1.4x faster and would make the gas about
/// 1.3x slower (`vadop simulate`, n = 10^4 and 10^5, one pinned core; BENCHMARKS.md, Speed).
const CALM_UPDATES: f64 = 0.1;
/// A proxy reaches this many typical diameters along its path at most; then it is renewed, so a
/// fast body's retest covers only where it can go before its next contact is likely.
const REACH_DIAMETERS: f64 = 8.0;
/// A window that would end within this share of a frame before the frame's end runs to it: a
/// window start (every proxy refreshed and binned, every pair predicted) costs about what the
/// window's events do at 5 diameters a frame, where windows last about one frame and the last
/// sliver of a frame would otherwise start a window of its own.
const SLIVER: f64 = 0.1;
/// The quantile of travel times that sets the window.
const WINDOW_QUANTILE: f64 = 0.1;
/// The event loop fetches the bodies of the event this many places ahead.
const EVENTS_AHEAD: usize = 8;
/// Windows are kept within this factor of the caller's frame either way.
const FRAME_RATIO: f64 = 64.0;
/// A window holding shapes lasts at most this many of the caller's frames. A shape pair's search
/// costs per unit of time searched, whatever the window (a parked search takes up where it
/// stopped), so a longer window saves only window starts, while it puts the searches of frames
/// not yet asked for on the frame that starts it, and a run that stops throws them away. Measured
/// on mixed shapes at 0.05 diameters per frame (windows of 64 frames before): 10 frames of
/// n = 10^5 take a tenth of the time, 30 of n = 10^4 three quarters (windows of 2 frames take
/// 1.2x that at 10^4, of 8 frames 1.4x at 10^5); at 0.5 diameters per frame, where windows are
/// about 7 frames, no change.
const SHAPE_WINDOW_FRAMES: f64 = 4.0;

/// How a pipeline picks its windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum WindowRule {
    /// One window per frame (the oracle: nothing adaptive between it and the truth).
    Frame,
    /// From the bodies' speeds (see [`WINDOW_DIAMETERS`]).
    Adaptive,
}

/// A continuous method: one broad phase in the frame pipeline.
#[derive(Debug)]
pub(crate) struct Pipeline<B: BroadPhase> {
    broad: B,
    rule: WindowRule,
    proxies: ProxyTable,
    queue: EventQueue,
    pub(crate) impacts: Impacts,
    /// The pairs in contact now, when contact ends are reported.
    pub(crate) touching: Touching,
    /// The static bodies, bounded once.
    statics: StaticGeometry,
    /// Where each shape pair's last search stopped, to take it up in the next window.
    parked: ParkedSearches,
    /// Scratch of a window start in a world of shapes: its predictions and parked searches.
    predictions: Vec<Prediction>,
    /// Pass-through contacts searched ahead, earliest first (see [`pass_through`]), and the
    /// scratch of those searches.
    ahead: VecDeque<Searched>,
    batch: Vec<Event>,
    searched: Vec<Searched>,
    /// Scratch of a re-test in a world of shapes: the candidate partners, with their stamps and
    /// the windows their bounds hold for.
    partners: Vec<(u32, u32, Window)>,
    /// The current window (empty before the first).
    window: Window,
    /// Proxies refreshed since the window started.
    updates: usize,
    /// Halved each time a window ends early, doubled back when windows pass calmly.
    shrink: f64,
    /// The threads bulk work is shared among.
    workers: Workers,
    /// Scratch: a sample of travel times for the window rule.
    travel: Vec<f64>,
    /// Scratch of the jam rule, and the members of the cluster last frozen, to re-test (also
    /// the stack of the walk that wakes what lay on a body).
    cluster: jam::Cluster,
    cluster_members: Vec<u32>,
    /// Scratch: a body's neighbours, for the wake walk.
    near: Vec<u32>,
    /// The step's contacts of spheres passing through each other, their geometry still to work
    /// out.
    passed: PassedContacts,
    /// The window's first wall bounces, foreseen (see [`foreseen`]).
    foreseen: ForeseenBounces,
}

impl<B: BroadPhase> Pipeline<B> {
    pub(crate) fn new(broad: B, rule: WindowRule, bounds: &BoxBounds, workers: Workers) -> Pipeline<B> {
        let mut proxies = ProxyTable::new(bounds);
        if rule == WindowRule::Adaptive {
            proxies.set_reach_diameters(REACH_DIAMETERS);
        }
        Pipeline {
            broad,
            rule,
            proxies,
            queue: EventQueue::default(),
            impacts: Impacts::default(),
            touching: Touching::default(),
            statics: StaticGeometry::default(),
            parked: ParkedSearches::default(),
            predictions: Vec::new(),
            ahead: VecDeque::new(),
            batch: Vec::new(),
            searched: Vec::new(),
            partners: Vec::new(),
            window: Window::default(),
            updates: 0,
            shrink: 1.0,
            workers,
            travel: Vec::new(),
            cluster: jam::Cluster::default(),
            cluster_members: Vec::new(),
            near: Vec::new(),
            passed: PassedContacts::default(),
            foreseen: ForeseenBounces::default(),
        }
    }

    /// The broad phase (for inspection and tests).
    pub(crate) fn broad(&self) -> &B {
        &self.broad
    }

    /// Bytes held by the broad phase, the proxies, the queue and the rules.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.broad.memory_bytes()
            + self.proxies.memory_bytes()
            + self.queue.memory_bytes()
            + self.impacts.rules.memory_bytes()
            + self.touching.memory_bytes()
            + self.parked.memory_bytes()
            + self.predictions.capacity() * std::mem::size_of::<Prediction>()
            + (self.ahead.capacity() + self.searched.capacity()) * std::mem::size_of::<Searched>()
            + self.batch.capacity() * std::mem::size_of::<Event>()
            + self.partners.capacity() * std::mem::size_of::<(u32, u32, Window)>()
            + self.travel.capacity() * 8
            + self.cluster.memory_bytes()
            + (self.cluster_members.capacity() + self.near.capacity()) * 4
            + self.passed.memory_bytes()
            + self.foreseen.memory_bytes()
    }

    /// Body `i` was added or changed velocity between frames at time `t`: it enters the window
    /// under way (if any) with its candidates predicted; otherwise the next window takes it.
    pub(crate) fn enter(&mut self, i: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats) {
        self.impacts.rules.resize(bodies.slots());
        if self.window.end > t && !self.proxies.fits(i as usize, bodies) {
            // Past the slots or the widths the window's ghosts were made for: a new window now.
            self.window.end = t;
        }
        if self.window.end > t {
            self.retest(i, None, bodies, physics, t, stats);
        } else {
            // The next step starts a window, which makes every live body's proxy and ghosts.
            self.proxies.admit(i as usize, bodies);
        }
    }

    /// Body `i` was removed: its predictions and broad-phase entries are void.
    pub(crate) fn remove(&mut self, i: u32) {
        self.proxies.remove(i as usize);
        self.impacts.rules.forget(i as usize);
        self.parked.remove(i);
        // Its contacts end with it, unreported: it is gone, not apart.
        self.touching.remove_body(i);
    }

    /// Steps from `t0` to `t1`: every contact with a time in `[t0, t1)`, in time order.
    pub(crate) fn step(&mut self, bodies: &mut Bodies, physics: &Physics, t0: f64, t1: f64, out: &mut Output) {
        self.impacts.rules.resize(bodies.slots());
        self.impacts.rules.next_step();
        // A static body added or removed since: every body's contacts with the level change, so
        // a new window starts now.
        if self.statics.is_stale(bodies) {
            self.window.end = self.window.end.min(t0);
        }
        let mut now = t0;
        loop {
            if !(self.window.end > now) {
                self.start_window(bodies, physics, now, Window::new(t0, t1), out.stats);
            }
            let until = t1.min(self.window.end);
            let start = Instant::now();
            self.passed.work_out_ahead(bodies, physics, self.queue.bulk_before(until), &self.workers);
            self.process_events(bodies, physics, until, out);
            out.stats.response_seconds += start.elapsed().as_secs_f64();
            // An interrupted step is undone by the world: the rest of it need not run.
            if t1 <= self.window.end || crate::interrupt::raised() {
                break;
            }
            now = self.window.end;
        }
        self.passed.resolve(bodies, out.contacts, &self.workers);
    }

    /// The length of the window starting at `now`, for frames of length `frame`; tells the proxy
    /// table whether the window is calm.
    fn window_length(&mut self, bodies: &Bodies, mode: Mode, frame: f64) -> f64 {
        if self.rule == WindowRule::Frame {
            return frame;
        }
        let proxies = &self.proxies;
        let live = proxies.live_count(bodies.slots());
        let travel = |i: usize| {
            let speed = bodies.velocity(i).length();
            (proxies.is_live(i) && speed > 0.0).then(|| 2.0 * bodies.bounding_radius(i) / speed)
        };
        let Some(quick) = sampled_quantile(bodies.slots(), WINDOW_QUANTILE, travel, &mut self.travel) else {
            return frame;
        };
        // The last window's refreshes per live body and per diameter travelled (by the fastest
        // tenth). Before the first, the mode tells: in detect mode only walls and the caller
        // change velocities, in simulate mode every contact does.
        let last = self.window.duration();
        let calm = if last > 0.0 {
            (self.updates as f64) * quick < CALM_UPDATES * live as f64 * last
        } else {
            mode == Mode::Detect
        };
        self.proxies.set_calm(calm);
        let (calm_diameters, longest) = if bodies.has_rigid() {
            (SHAPE_CALM_WINDOW_DIAMETERS, frame * SHAPE_WINDOW_FRAMES)
        } else {
            (CALM_WINDOW_DIAMETERS, frame * FRAME_RATIO)
        };
        let diameters = if calm { calm_diameters } else { WINDOW_DIAMETERS };
        (quick * diameters * self.shrink).clamp(frame / FRAME_RATIO, longest)
    }

    /// Starts a window at `now`, inside the caller's `frame`: refreshes every proxy (c_update),
    /// prepares the broad phase (c_sort) and predicts every pair and wall contact inside the
    /// window (c_test).
    fn start_window(&mut self, bodies: &Bodies, physics: &Physics, now: f64, frame: Window, stats: &mut FrameStats) {
        let length = self.window_length(bodies, physics.mode, frame.duration());
        let mut end = now + length;
        if end < frame.end && end >= frame.end - SLIVER * frame.duration() {
            // Otherwise the frame's last sliver takes a window start of its own.
            end = frame.end;
        }
        if !(end > now) {
            // A window too short to move the clock on (a time far beyond the frame length).
            end = now + frame.duration();
        }
        if !(end > now) {
            end = now.next_up();
        }
        self.window = Window::new(now, end);
        self.updates = 0;
        // Searched ahead within the window that ends: their next contacts stop at its end.
        self.ahead.clear();
        stats.windows += 1;

        let start = Instant::now();
        self.proxies.refresh_all(bodies, self.window, &self.workers);
        stats.update_seconds += start.elapsed().as_secs_f64();

        let start = Instant::now();
        self.predict_walls(bodies, physics);
        let (view, foreseen) = (self.proxies.view(bodies), self.foreseen.paths());
        let counts = if foreseen.is_empty() {
            self.broad.prepare(view, &self.workers)
        } else {
            self.broad.prepare_foreseen(view, foreseen, &self.workers)
        };
        stats.endpoint_swaps += counts.moves;
        stats.list_entries = counts.entries;
        stats.sort_seconds += start.elapsed().as_secs_f64();

        let start = Instant::now();
        self.statics.update(bodies);
        let mut predicted = self.queue.take_bulk();
        let candidates = if bodies.has_rigid() {
            // Shape searches park where they stop; the store is read by every worker and
            // written once they are done, in an order that does not depend on their number.
            let (mut found, parked) = (std::mem::take(&mut self.predictions), &self.parked);
            let table = &self.proxies;
            let candidates = self.broad.find_pairs(
                self.proxies.view(bodies),
                &self.workers,
                |a, b, window, out| predict_into(bodies, table, (a, b, window), parked, out),
                &mut found,
            );
            sort_predictions(&mut found, &mut self.parked, self.window.start, |event| predicted.push(event));
            self.predictions = found;
            candidates
        } else {
            let (table, view, workers) = (&self.proxies, self.proxies.view(bodies), &self.workers);
            let (broad, found) = (&mut self.broad, &mut predicted);
            if table.has_ghosts() {
                find_pair_events(broad, view, workers, found, |a, b, w| predict_pair(bodies, table, a, b, w))
            } else if bodies.straight_paths() {
                // Every proxy is its body's own (no owners to look up for each candidate), and
                // every body a sphere on a straight path: the exact test's screen first, by the
                // broad phase, then the rest of the test for the pairs it keeps.
                broad.find_pairs_screened(
                    view,
                    workers,
                    &StraightSpheres,
                    |a, b, time, out| out.push(straight_sphere_event_at(a, b, time)),
                    found,
                )
            } else {
                find_pair_events(broad, view, workers, found, |a, b, w| predict_own_pair(bodies, a, b, w))
            }
        };
        let (proxies, statics, window) = (self.proxies.view(bodies), &self.statics, self.window);
        // Asked once per window rather than of every body: most boxes have no periodic face and
        // most worlds no static body.
        let (periodic, level) = (physics.bounds.is_periodic(), !statics.is_empty());
        let walls = self.foreseen.walls();
        // Each body's own events (walls, crossings, the level, renewals) follow the pairs'; the
        // walls' were predicted with the foresight, in the bodies' order.
        self.workers.extend_ranges(bodies.slots(), &mut predicted, |range, found| {
            let first = walls.partition_point(|wall| (wall.body as usize) < range.start);
            let mut walls = walls[first..].iter().peekable();
            for i in range.filter(|&i| proxies.is_live(i)) {
                found.extend(walls.next_if(|wall| wall.body as usize == i));
                if periodic {
                    push_found(found, predict_crossing(bodies, &physics.bounds, i as u32, window));
                }
                if level {
                    for_each_static_event(bodies, proxies, statics, i, window, |event| found.push(event));
                }
                if proxies.expires(i) {
                    found.push(renewal(bodies, &proxies, i as u32));
                }
            }
        });
        if physics.report_ends {
            for (a, b, since) in self.touching.contacts() {
                predicted.extend(predict_end(bodies, a, b, since, window));
            }
        }
        self.queue.set_bulk(predicted, &self.workers);
        stats.candidate_pairs += candidates;
        stats.narrow_tests += candidates;
        stats.test_seconds += start.elapsed().as_secs_f64();
    }

    /// Pops and handles contacts with a time before `until`; may end the window early.
    fn process_events(&mut self, bodies: &mut Bodies, physics: &Physics, until: f64, out: &mut Output) {
        let interrupt = crate::interrupt::Watch::current();
        // No body is added within the loop: its refresh limit is known now.
        let most_updates = UPDATES_PER_BODY * self.proxies.body_slots().max(64);
        // Runs of pass-throughs worked out ahead (see below): only where the step's start worked
        // some out, and not with contact ends reported (each pass-through then pushes its end
        // into the queue).
        let runs = !physics.report_ends && self.passed.worked_ahead().holds_any();
        while !interrupt.raised() {
            // Most events of a step in detect mode: spheres passing through each other, their
            // record made ahead, in runs between the heap's events. A run is reported as the loop
            // below would report each, without its look at the heap, its prefetch and its check of
            // the window's refreshes (a pass-through refreshes nothing); not once the window is to
            // end early at the next event (the loop below ends it).
            if runs && self.updates <= most_updates {
                let (worked, stats, contacts) = (self.passed.worked_ahead(), &mut *out.stats, &mut *out.contacts);
                self.queue.pop_bulk_run(until, |place, event| {
                    !interrupt.raised()
                        && match worked.ahead_of(bodies, place, event) {
                            Ahead::Current(contact, _) => {
                                stats.pair_contacts += 1;
                                contacts.push(contact);
                                true
                            }
                            Ahead::Void => {
                                stats.invalidations += 1;
                                true
                            }
                            Ahead::Unknown => false,
                        }
                });
            }
            let Some((event, bulk_place)) = self.queue.pop_before(until) else { break };
            // The bodies of an event a few ahead, unless it was worked out ahead: their records
            // are random memory accesses, and asking early lets them arrive while this one is
            // handled.
            if let Some((place, next)) = self.queue.upcoming(EVENTS_AHEAD) {
                if !self.passed.worked_ahead().is_worked_out(place) {
                    bodies.prefetch(next.body as usize);
                    if let Partner::Body(j) | Partner::End(j) | Partner::Stalled(j) = next.partner {
                        bodies.prefetch(j as usize);
                    }
                }
            }
            // Most events of a step in detect mode: spheres passing through each other, their
            // record made ahead.
            match bulk_place.map_or(Ahead::Unknown, |place| self.passed.worked_ahead().ahead_of(bodies, place, &event))
            {
                Ahead::Current(contact, j) => {
                    self.report_pair_contact(bodies, physics, (event.body, j), contact, Resolution::Passed, out);
                }
                Ahead::Void => {
                    out.stats.invalidations += 1;
                    continue;
                }
                Ahead::Unknown => {
                    if !event.is_current(bodies) {
                        if !self.hold_foreseen(&event, bodies) {
                            out.stats.invalidations += 1;
                        }
                        continue;
                    }
                    self.handle(bodies, physics, &event, until, out);
                }
            }
            // Too many fresh proxies: start afresh at the next event's time, strictly after this
            // one, so nothing already handled is predicted again.
            if self.updates > most_updates {
                if let Some(next) = self.queue.peek_time() {
                    if next > event.time && next < self.window.end {
                        self.window.end = next;
                        self.shrink *= 0.5;
                        return;
                    }
                }
            }
        }
        if self.updates * 4 < most_updates {
            self.shrink = (self.shrink * 2.0).min(1.0);
        }
    }

    /// Handles `event`, popped current, that was not worked out ahead.
    fn handle(&mut self, bodies: &mut Bodies, physics: &Physics, event: &Event, until: f64, out: &mut Output) {
        let i = event.body as usize;
        match event.partner {
            Partner::Body(j) => match self.searched_ahead(bodies, physics, event, until) {
                Some(searched) => self.pass_through(bodies, physics, event, searched, out),
                None => self.pair_contact(bodies, physics, (event.body, j), event.time, out),
            },
            Partner::End(j) => self.contact_end(bodies, event.body, j, event.time, out),
            Partner::Stalled(j) => self.stalled(bodies, physics, &[event.body, j], event.time, out),
            Partner::Wall(wall) => {
                if !self.take_foreseen(bodies, physics, event, out) {
                    respond::wall_contact(self, bodies, physics, event.body, wall, event.time, out);
                }
            }
            Partner::WallStalled => self.stalled(bodies, physics, &[event.body], event.time, out),
            Partner::Cross(face) => {
                bodies.wrap(i, face, event.time);
                self.retest(event.body, None, bodies, physics, event.time, out.stats);
            }
            Partner::Renew => {
                bodies.renew(i);
                self.retest(event.body, None, bodies, physics, event.time, out.stats);
            }
        }
    }

    /// The contact of bodies `a < b` at `t`, popped valid and not worked out ahead.
    fn pair_contact(&mut self, bodies: &mut Bodies, physics: &Physics, (a, b): (u32, u32), t: f64, out: &mut Output) {
        let (i, j) = (a as usize, b as usize);
        if bodies.are_spheres(i, j) && passes_through(bodies, physics, i, j) {
            // Nothing changes, and it was predicted mid-step (those of the window's start were
            // worked out ahead): where they touch is worked out at the step's end, on every
            // worker.
            self.passed.defer(bodies, (a, b), out.contacts.len());
            let contact = pair_record(bodies, (a, b), t, (DVec3::ZERO, DVec3::ZERO, 0.0));
            self.report_pair_contact(bodies, physics, (a, b), contact, Resolution::Passed, out);
            return;
        }
        let stamps = (bodies.stamp(i), bodies.stamp(j));
        let (point, normal, resolution, impulse) = respond::pair_impact(self, bodies, physics, (a, b), t, out.stats);
        // Spinning shapes may touch again on the same motions (spheres never do): with nothing
        // changed, the pair's next contact is predicted now, as a later window would find it.
        if impulse == 0.0 && !bodies.are_spheres(i, j) && bodies.stamp(i) == stamps.0 && bodies.stamp(j) == stamps.1 {
            let later = self.window.from(t.next_up());
            let (found, parks, _) = contacts::pair_start_after(bodies, i, j, t, later);
            self.follow_pair((a, stamps.0), (b, stamps.1), found, parks);
        }
        let contact = pair_record(bodies, (a, b), t, (point, normal, impulse));
        self.report_pair_contact(bodies, physics, (a, b), contact, resolution, out);
    }

    /// What the search after a contact of bodies `a < b` (each with its stamp) found: their next
    /// contact goes into the queue, or where the search parked into the store.
    fn follow_pair(&mut self, a: (u32, u32), b: (u32, u32), next: contacts::Found, parks: Option<Parking>) {
        if let Some(found) = next {
            self.queue.push(pair_event(a, b, found));
        }
        if let Some(((a, b), epochs, resume)) = parks {
            self.parked.keep(a, b, epochs, resume, self.window.start);
        }
    }

    /// Shapes passing through each other in detect mode at `event`, searched ahead: as
    /// [`Self::pair_contact`] handles them (no impulse, the next contact predicted now).
    fn pass_through(
        &mut self,
        bodies: &Bodies,
        physics: &Physics,
        event: &Event,
        searched: Searched,
        out: &mut Output,
    ) {
        let Partner::Body(b) = event.partner else { unreachable!("a pass-through is a pair contact") };
        self.follow_pair((event.body, event.body_stamp), (b, event.partner_stamp), searched.next, searched.parks);
        let (point, normal) = searched.point_normal;
        let contact = pair_record(bodies, (event.body, b), event.time, (point, normal, 0.0));
        self.report_pair_contact(bodies, physics, (event.body, b), contact, Resolution::Passed, out);
    }

    /// Reports `contact`, of bodies `a < b` (see [`pair_record`]), and starts following it to its
    /// end when it was passed through with ends reported. Inlined: the event loop reports most of
    /// its events here, and a call passed the 96-byte record through the stack.
    #[inline(always)]
    fn report_pair_contact(
        &mut self,
        bodies: &Bodies,
        physics: &Physics,
        (a, b): (u32, u32),
        contact: Contact,
        resolution: Resolution,
        out: &mut Output,
    ) {
        out.stats.pair_contacts += 1;
        if physics.report_ends && resolution == Resolution::Passed {
            let t = contact.time;
            self.touching.insert(a, b, t);
            if let Some(event) = predict_end(bodies, a, b, t, self.window.from(t)) {
                self.queue.push(event);
            }
        }
        out.contacts.push(contact);
    }

    /// A search that could not decide stopped at `t` with `stuck` (one body and a wall, or two
    /// bodies): a long skim a hair apart, a fast spinner's long approach, or resting or sliding
    /// in contact while turning. Unless they are touching, or the search stalled at the instant
    /// their motions began (nothing gained by going on), their motions start afresh from `t`
    /// (the same paths, a new reference instant and a fresh search budget), so the next search
    /// begins there; bodies apart are never jammed. In simulate mode the jam rule freezes the
    /// others (no spin, the cluster's velocity), and in detect mode too when one side is a wall or
    /// static geometry, which turns bodies back there as well (started afresh, a body collapsing
    /// onto the floor would sink through it while each new search stalled again); two moving
    /// bodies in detect mode, which keep their paths, start afresh all the same. Every method
    /// stalls at the same instant: canonical.
    fn stalled(&mut self, bodies: &mut Bodies, physics: &Physics, stuck: &[u32], t: f64, out: &mut Output) {
        if physics.turns_back(stuck.len() == 1 || stuck.iter().any(|&k| bodies.is_fixed(k as usize))) {
            let progressed =
                stuck.iter().all(|&k| bodies.is_fixed(k as usize) || t > bodies.state[k as usize].motion.since);
            let touching = match *stuck {
                [a, b] => contacts::pressed_together(bodies, a as usize, b as usize, t),
                _ => contacts::touches_a_wall(bodies, stuck[0] as usize, &physics.bounds, t),
            };
            if touching || !progressed {
                self.freeze_cluster(bodies, physics, stuck, t, out.stats);
                return;
            }
        }
        for &k in stuck {
            let i = k as usize;
            if !bodies.is_fixed(i) {
                bodies.restart_at(i, t);
            }
        }
        match *stuck {
            [a, b] => self.retest_pair(a, b, bodies, physics, t, out.stats),
            _ => self.retest(stuck[0], None, bodies, physics, t, out.stats),
        }
    }

    /// Re-tests the bodies of pair `a`, `b` that moved, the pair itself once (by the second, when
    /// both proxies are fresh); a static body never moves and is never re-tested.
    fn retest_pair(&mut self, a: u32, b: u32, bodies: &Bodies, physics: &Physics, t: f64, stats: &mut FrameStats) {
        match (bodies.is_fixed(a as usize), bodies.is_fixed(b as usize)) {
            (false, false) => {
                self.retest(a, Some(b), bodies, physics, t, stats);
                self.retest(b, None, bodies, physics, t, stats);
            }
            (false, true) => self.retest(a, None, bodies, physics, t, stats),
            (true, false) => self.retest(b, None, bodies, physics, t, stats),
            (true, true) => {}
        }
    }

    /// The contact of `a` and `b` ends at `t`: they part (detect mode, ends reported).
    fn contact_end(&mut self, bodies: &Bodies, a: u32, b: u32, t: f64, out: &mut Output) {
        if !self.touching.remove(a, b) {
            return;
        }
        let (i, j) = (a as usize, b as usize);
        let (point, normal) = contacts::pair_geometry(bodies, i, j, t);
        out.stats.contact_ends += 1;
        let (body, touched) = (bodies.handle(i), Touched::Body(bodies.handle(j)));
        out.ends.push(Contact { time: t, body, touched, point, normal, impulse: 0.0 });
    }

    /// The jam rule (see [`jam::Cluster::freeze`]) on the bodies touching `seeds` at `t`, found
    /// through the broad phase (a body's own proxy and, across periodic faces, its ghosts) and
    /// the static geometry; its members are re-tested. Returns the cluster's virial.
    fn freeze_cluster(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        seeds: &[u32],
        t: f64,
        stats: &mut FrameStats,
    ) -> f64 {
        let (broad, table, statics) = (&mut self.broad, &self.proxies, &self.statics);
        let near = |bodies: &Bodies, m: usize, near: &mut Vec<u32>| wake::neighbours(broad, table, bodies, m, near);
        let pinned = |bodies: &Bodies, m: usize| {
            let (pm, rm, mut pinned) = (bodies.position_at(m, t), bodies.radius(m), false);
            statics.for_each_near(pm - rm, pm + rm, |s| pinned |= contacts::pressed_together(bodies, m, s as usize, t));
            pinned
        };
        let rules = &mut self.impacts.rules;
        let virial = self.cluster.freeze(bodies, physics, rules, seeds, t, stats, near, pinned);
        let mut members = std::mem::take(&mut self.cluster_members);
        members.clear();
        members.extend_from_slice(self.cluster.members());
        for &m in &members {
            self.retest(m, None, bodies, physics, t, stats);
        }
        self.cluster_members = members;
        virial
    }
}

/// The record of the contact of bodies `a < b` at `t`: where, its normal and the impulse applied.
#[inline]
pub(super) fn pair_record(bodies: &Bodies, (a, b): (u32, u32), t: f64, geometry: (DVec3, DVec3, f64)) -> Contact {
    let (point, normal, impulse) = geometry;
    let (body, touched) = (bodies.handle(a as usize), Touched::Body(bodies.handle(b as usize)));
    Contact { time: t, body, touched, point, normal, impulse }
}

/// [`BroadPhase::find_pairs`] in a world of spheres, each candidate pair's event (if any) by
/// `predict`, pushed into `found`; returns the candidates' count.
fn find_pair_events<B: BroadPhase>(
    broad: &mut B,
    view: Proxies,
    workers: &Workers,
    found: &mut Vec<Event>,
    predict: impl Fn(Reported, Reported, Window) -> Option<Event> + Sync + Send,
) -> u64 {
    broad.find_pairs(view, workers, |a, b, w, out| push_found(out, predict(a, b, w)), found)
}
