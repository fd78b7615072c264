//! The event loop of spheres in simulate mode, of the class of dedicated event-driven molecular
//! dynamics (EDMD) codes: one scheduled event per body, cells with crossing events or neighbour
//! lists with shell exits, an O(1) calendar, and no work at a frame's end for the bodies nothing
//! touched.
//!
//! It owns the scheduling of a world whose every body is a moving sphere, in simulate mode and
//! without gravity: each body's earliest event alone (a contact, a wall contact, a crossing of a
//! periodic face, or the crossing of its centre into another cell: [`cells`]) is kept in the
//! calendar ([`calendar`]); a body whose motion changed is tested against the bodies of the 27
//! cells around it ([`search`], each partner screened first: [`screen`]), and a body crossing
//! into a cell against the 9 that came within reach. In a dense world the serial loop keeps neighbour lists instead ([`lists`], see
//! [`Lists::paying`]): a body whose motion changed is tested against its list, and the
//! crossing of its centre out of its shell replaces the cell crossings: its list is built anew,
//! and it is tested against the bodies new to it. A body whose scheduled contact was voided by
//! its partner's velocity change (stamps, as in the event queue) is tested again when that
//! contact surfaces. Each body's event is the
//! earliest of those it may still have, so the calendar's earliest is the next event of the
//! world: the events are handled in the order the frame pipeline's queue handles them, ties
//! included. The contact times, the impacts, the contact rules (the TC model and the jam rule,
//! its cluster found through the cells) and the reports are the pipeline's own functions, so the
//! contacts and states are bit-identical to the brute-force oracle's, for every frame length.
//! The events come in time order, so each reaches bodies far in memory from the last one's: the
//! loop asks for the records and cells of the events a few places ahead while it handles the next.
//!
//! Where it applies: [`crate::world`] steps a world of `Method::Auto` in simulate mode with it
//! while every body is a moving sphere and there is no gravity, and hands the world to the grid's
//! frame pipeline (which predicts from the same canonical times, so nothing changes at the hand-over)
//! as soon as another shape or a static body is added. Detect mode stays with the pipeline:
//! there no contact changes a path, so predicting every pair once per window costs less than
//! testing a body's neighbourhood after each of its contacts. Shapes stay with it because their
//! searches are conservative advancement, parked and resumed across windows, which the
//! pipeline owns; gravity, because a body's path is then a parabola, and its cell crossings and
//! resting contact belong with the pipeline's proxies. It never decides what touches (the narrow
//! phase) nor what an impact does (the response).

mod ahead;
mod calendar;
mod cells;
mod in_order;
mod lists;
mod screen;
mod search;

use crate::bodies::Bodies;
use crate::event_queue::{Event, Partner};
use crate::frame::{Contact, FrameStats, Output, Physics, Touched};
use crate::pipeline::jam::Cluster;
use crate::pipeline::respond::{self, Responder};
use crate::response::impact::{is_plain_pair, Impacts, Resolution};
use crate::response::rules::ContactRules;
use crate::walls::BoxBounds;
use ahead::{Marks, Mirror, Worked, Worker};
use calendar::{Calendar, Entry, Events};
use cells::{Cells, Crossing, NONE};
use lists::Lists;
use search::{Candidates, Eligible, Near, Overlay, Search};
use std::time::Instant;

/// The parallel loop runs from this many threads on. Its thread that handles the events in order
/// commits one batch while the workers work out the next (see [`in_order`]), so on 2 threads both
/// share all of the work but the mirror's upkeep: measured with callgrind on the periodic gas at
/// n = 10^5, per pair collision, at packing 0.05 and 0.2 the commit (with taking the next batch)
/// executes 7.2 k and 3.2 k instructions, the workers 10.6 k and 9.1 k, the mirror's upkeep 1.5 k
/// and 0.5 k, where the serial loop executes 15.3 k and 10.7 k in all: 2 threads are bounded to
/// 1.47x and 1.60x before the batches' hand-offs. Timed (five pairs of runs, one thread pinned
/// against two, BENCHMARKS.md's fifteenth session) 2 threads gave 0.91x at packing 0.05 and 1.18x
/// at 0.2: the hand-offs cost more than the bound leaves in a thin gas, so 2 threads keep the
/// serial loop until they pay at every packing. In a dense world the parallel loop keeps cells
/// where the serial loop keeps neighbour lists ([`Lists::paying`]): at packing 0.4 its workers
/// alone execute 12.3 k instructions per collision against the serial loop's 9.1 k with lists,
/// which bounds 2 threads to 1.15x, 3 threads to 1.68x.
const AHEAD_THREADS: usize = 3;
/// Workers of the parallel loop a thread: a batch's searches are shared in this many runs a
/// thread, so that the thread that commits the batch before takes those left when it is done.
const WORKERS_PER_THREAD: usize = 4;
/// The grid is rebuilt when the bodies have grown past this many times those it was sized for.
const GROWTH: usize = 2;
/// The records of the event this many after the next are asked for while the next is handled
/// (see [`EventLoop::prefetch`]). Measured on the sparse gas at n = 10^5 (packing 0.05), where
/// most events are cell crossings of bodies far apart in memory: 2 and 4 both cut the time per
/// event by about a tenth, 1 by less.
const PREFETCH_AHEAD: usize = 4;
/// How many events pass between looks at the interrupt flag.
const INTERRUPT_EVERY: u32 = 4096;

/// The event loop (see the module documentation).
#[derive(Debug)]
pub(crate) struct EventLoop {
    bounds: BoxBounds,
    cells: Cells,
    /// The calendar, which keeps each body's next events (see [`Events`]).
    calendar: Calendar,
    /// The neighbour lists (see [`lists`]): the serial loop's, built with the grid.
    lists: Option<Lists>,
    pub(crate) impacts: Impacts,
    cluster: Cluster,
    /// Scratch: the members of the cluster last frozen; a search's candidates.
    members: Vec<u32>,
    candidates: Candidates,
    near: Box<Near>,
    /// Per slot: the body was entered and not removed since.
    held: Vec<bool>,
    /// Bodies listed in the cells, and how many the grid was sized for.
    listed: usize,
    sized_for: usize,
    /// The largest coordinate of the box, and the smallest radius entered: whether the search's
    /// screen is trusted (see [`screen::screen_trusted`]).
    scale: f64,
    min_radius: f64,
    /// With more than one thread (`threads`), the parallel loop (see [`in_order`]): its workers
    /// (a few a thread, so that a thread done early takes a share of those left), the batch
    /// committed and what the workers found for it, the batch worked out ahead and its results,
    /// the batch after it, the cells changed since the world the workers read, the bodies whose events a commit
    /// handled, and the world the workers read.
    threads: usize,
    workers: Vec<Worker>,
    batch: Vec<Entry>,
    worked: Vec<Worked>,
    ahead: Vec<Entry>,
    worked_ahead: Vec<Worked>,
    later: Vec<Entry>,
    marks: Marks,
    owners: Vec<u32>,
    mirror: Mirror,
    /// Tests: every step ends checking the search's screen, and the lists when kept.
    #[cfg(test)]
    checking: bool,
    /// Tests: the serial loop keeps lists whatever the packing, with blocks of this many entries
    /// at first.
    #[cfg(test)]
    always_lists: Option<usize>,
    /// The grid and the calendar are rebuilt at the next step (bodies were entered that the grid
    /// does not fit, or none was entered yet).
    stale: bool,
}

impl EventLoop {
    /// An event loop for the box `bounds` on `threads` threads: the parallel loop (see [`ahead`])
    /// from [`AHEAD_THREADS`] threads on, the serial loop below.
    pub(crate) fn new(bounds: &BoxBounds, threads: usize) -> EventLoop {
        Self::with_workers(bounds, if threads >= AHEAD_THREADS { threads } else { 1 })
    }

    /// An event loop for the box `bounds` whose searches are shared among `workers` workers (the
    /// serial loop with one).
    pub(crate) fn with_workers(bounds: &BoxBounds, workers: usize) -> EventLoop {
        EventLoop {
            bounds: *bounds,
            cells: Cells::default(),
            calendar: Calendar::default(),
            lists: None,
            impacts: Impacts::default(),
            cluster: Cluster::default(),
            members: Vec::new(),
            candidates: Candidates::default(),
            near: Box::default(),
            held: Vec::new(),
            listed: 0,
            sized_for: 0,
            scale: bounds.min.abs().max(bounds.max.abs()).max_element() + bounds.side().max_element(),
            min_radius: f64::INFINITY,
            threads: workers,
            workers: if workers > 1 {
                (0..workers * WORKERS_PER_THREAD).map(|_| Worker::default()).collect()
            } else {
                Vec::new()
            },
            batch: Vec::new(),
            worked: Vec::new(),
            ahead: Vec::new(),
            worked_ahead: Vec::new(),
            later: Vec::new(),
            marks: Marks::default(),
            owners: Vec::new(),
            mirror: Mirror { stale: true, ..Mirror::default() },
            #[cfg(test)]
            checking: false,
            #[cfg(test)]
            always_lists: None,
            stale: true,
        }
    }

    /// True when the loop takes body `i`: a moving sphere.
    pub(crate) fn takes(bodies: &Bodies, i: usize) -> bool {
        bodies.is_sphere(i) && !bodies.is_fixed(i)
    }

    /// The bodies entered and not removed, ascending.
    pub(crate) fn bodies(&self) -> impl Iterator<Item = u32> + '_ {
        self.held.iter().enumerate().filter(|(_, &held)| held).map(|(i, _)| i as u32)
    }

    /// Bytes held: cells, calendar (with each body's next events), the rules.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.cells.memory_bytes()
            + self.calendar.memory_bytes()
            + self.impacts.rules.memory_bytes()
            + self.cluster.memory_bytes()
            + self.members.capacity() * 4
            + self.held.capacity()
            + self.marks.memory_bytes()
            + (self.batch.capacity() + self.ahead.capacity() + self.later.capacity()) * std::mem::size_of::<Entry>()
            + (self.worked.capacity() + self.worked_ahead.capacity()) * std::mem::size_of::<Worked>()
            + self.owners.capacity() * 4
            + self.mirror.memory_bytes()
            + self.candidates.memory_bytes()
            + self.lists.as_ref().map_or(0, Lists::memory_bytes)
    }

    /// Body `i` was added, or given a new motion between frames, at `t`.
    pub(crate) fn enter(&mut self, i: u32, bodies: &Bodies, t: f64, stats: &mut FrameStats) {
        let i = i as usize;
        self.impacts.rules.resize(bodies.slots());
        if self.held.len() < bodies.slots() {
            self.held.resize(bodies.slots(), false);
        }
        self.held[i] = true;
        self.mirror.stale = true;
        self.min_radius = self.min_radius.min(bodies.radius(i));
        if self.stale {
            return;
        }
        if self.cells.cell_of(i) == NONE {
            if !self.cells.fits(bodies.radius(i)) || self.listed + 1 > GROWTH * self.sized_for.max(64) {
                self.stale = true;
                return;
            }
            self.grow(bodies.slots());
            self.cells.insert(bodies, i, t);
            self.listed += 1;
            if let Some(lists) = &mut self.lists {
                lists.rebuild(&self.cells, bodies, i, t, false);
            }
        } else if let Some(lists) = &mut self.lists {
            // A new motion, maybe from a new place: a new shell.
            self.cells.relist(bodies, i, t);
            lists.rebuild(&self.cells, bodies, i, t, false);
        }
        self.predict(bodies, i, t, Eligible::From(t), stats);
    }

    /// The contact rules, to be changed from outside the loop (a step taken back restores them):
    /// the workers' copy is then taken whole before the next batch.
    pub(crate) fn rules_mut(&mut self) -> &mut ContactRules {
        self.mirror.stale = true;
        &mut self.impacts.rules
    }

    /// Body `i` was removed: it leaves its cell, and its event is void.
    pub(crate) fn remove(&mut self, i: u32) {
        if let Some(held) = self.held.get_mut(i as usize) {
            *held = false;
        }
        self.mirror.stale = true;
        if self.cells.cell_of(i as usize) != NONE {
            if let Some(lists) = &mut self.lists {
                lists.remove(i as usize);
            }
            self.cells.remove(i as usize);
            self.listed -= 1;
        }
        self.calendar.cancel(i);
        self.impacts.rules.forget(i as usize);
    }

    fn grow(&mut self, slots: usize) {
        self.calendar.grow(slots);
        if let Some(lists) = &mut self.lists {
            lists.grow(slots);
        }
    }

    /// Lists every body afresh in a grid sized for them and schedules each one's earliest
    /// event from `t` on, before any event at `t` was handled.
    fn rebuild(&mut self, bodies: &Bodies, t: f64, stats: &mut FrameStats) {
        let ids: Vec<u32> = self.bodies().collect();
        let max_radius = ids.iter().map(|&i| bodies.radius(i as usize)).fold(0.0, f64::max);
        // The parallel loop keeps cells: its workers' results are checked against the cells
        // marked since their world, and a list built anew changes the lists around it.
        #[cfg(not(test))]
        let always = None;
        #[cfg(test)]
        let always = self.always_lists;
        self.lists = self.workers.is_empty().then(|| Lists::paying(&self.bounds, bodies, &ids, always)).flatten();
        let shell = self.lists.as_ref().map_or(0.0, |lists| lists.shell);
        self.cells = Cells::new(&self.bounds, max_radius, shell, ids.len());
        (self.listed, self.sized_for) = (ids.len(), ids.len());
        self.calendar.clear();
        self.grow(bodies.slots());
        for &i in &ids {
            self.min_radius = self.min_radius.min(bodies.radius(i as usize));
            self.cells.insert(bodies, i as usize, t);
        }
        if let Some(lists) = &mut self.lists {
            lists.build_all(&self.cells, bodies, &ids, t);
        }
        for &i in &ids {
            let mut search = self.search(bodies);
            let next = search.next_event(i as usize, t, Eligible::From(t));
            stats.narrow_tests += search.tests;
            let crossing = self.next_crossing(bodies, i as usize, t);
            self.calendar.book(i, Events { next, crossing });
        }
        stats.retests += ids.len() as u64;
        self.stale = false;
        self.mirror.stale = true;
        self.calendar.retune(t);
    }

    /// When body `i`'s centre next leaves its cell, or with lists its shell, from `now` on.
    #[inline]
    fn next_crossing(&self, bodies: &Bodies, i: usize, now: f64) -> Crossing {
        match &self.lists {
            Some(lists) => Crossing { time: lists.exit(bodies, i, now), ..Crossing::NEVER },
            None => self.cells.next_crossing(bodies, i, now),
        }
    }

    /// A search of the cells, its screen on when trusted for the bodies entered so far.
    fn search<'a>(&'a mut self, bodies: &'a Bodies) -> Search<'a> {
        let screen = screen::screen_trusted(self.scale, self.min_radius);
        let (candidates, near) = (&mut self.candidates, &mut self.near);
        Search {
            bodies,
            cells: &self.cells,
            lists: self.lists.as_ref(),
            bounds: &self.bounds,
            screen,
            candidates,
            near,
            overlay: Overlay::default(),
            tests: 0,
        }
    }

    /// Body `i`'s events at `now` found again, those `eligible`; a body whose motion is new gets
    /// its next cell crossing too.
    #[inline]
    fn predict(&mut self, bodies: &Bodies, i: usize, now: f64, eligible: Eligible, stats: &mut FrameStats) {
        let mut search = self.search(bodies);
        let next = search.next_event(i, now, eligible);
        stats.narrow_tests += search.tests;
        stats.retests += 1;
        let crossing = match eligible {
            Eligible::From(_) => {
                self.mark_cell_of(i);
                self.next_crossing(bodies, i, now)
            }
            Eligible::After(_) => self.calendar.events(i).crossing,
        };
        self.calendar.schedule(i as u32, Events { next, crossing });
    }

    /// Steps from `t0` to `t1`: every contact with a time in `[t0, t1)`, in time order.
    pub(crate) fn step(&mut self, bodies: &mut Bodies, physics: &Physics, t0: f64, t1: f64, out: &mut Output) {
        let start = Instant::now();
        self.impacts.rules.resize(bodies.slots());
        self.impacts.rules.next_step();
        if self.stale {
            self.rebuild(bodies, t0, out.stats);
        } else if self.calendar.needs_tuning() {
            self.calendar.retune(t0);
        }
        if self.workers.is_empty() {
            let mut handled = 0u32;
            while let Some(entry) = self.calendar.peek_entry() {
                if !(entry.scheduled.time() < t1) {
                    break;
                }
                handled = handled.wrapping_add(1);
                if handled.is_multiple_of(INTERRUPT_EVERY) && crate::interrupt::raised() {
                    break;
                }
                self.calendar.pop();
                if let Some(following) = self.calendar.following(PREFETCH_AHEAD) {
                    self.prefetch(bodies, following);
                }
                if let Some(following) = self.calendar.following(1) {
                    self.prefetch_cells(following);
                }
                self.dispatch(bodies, physics, entry, out);
            }
        } else {
            self.step_ahead(bodies, physics, t1, out);
        }
        out.stats.response_seconds += start.elapsed().as_secs_f64();
        #[cfg(test)]
        if self.checking {
            self.check_screen(bodies, t1);
            if let Some(lists) = &self.lists {
                lists.check(&self.cells, bodies, &self.bounds, t1);
            }
        }
    }

    /// Asks for the records the event `entry` will read, ahead of its turn: the events come in
    /// time order, so each reaches bodies far in memory from the last one's, and the event handled
    /// meanwhile hides the wait.
    #[inline]
    fn prefetch(&self, bodies: &Bodies, entry: &Entry) {
        self.prefetch_body(bodies, entry.owner as usize);
        if let (false, Partner::Body(partner)) = (entry.scheduled.cell_crossing(), entry.scheduled.event.partner) {
            self.prefetch_body(bodies, partner as usize);
        }
    }

    /// Asks for the heads of the cells the event `entry` will search, ahead of its turn: those a
    /// cell crossing brings within reach. (Its bodies' records were asked for earlier, see
    /// [`PREFETCH_AHEAD`]: they tell which cells.) The cells around a contact's bodies are not
    /// asked for: that measured no faster in the dense gas, where contacts are most events.
    #[inline]
    fn prefetch_cells(&self, entry: &Entry) {
        let owner = entry.owner as usize;
        if self.lists.is_some() || self.cells.cell_of(owner) == NONE {
            return;
        }
        if entry.scheduled.cell_crossing() {
            // The entry may be stale: the body's crossing is the one of the cell it is in.
            let crossing = self.calendar.events(owner).crossing;
            if crossing.time.is_finite() {
                self.cells.prefetch_new(owner, crossing);
            }
        }
    }

    /// [`Self::prefetch`] of body `i`'s records: its motion, tag (stamp), events, place in the cells.
    #[inline]
    fn prefetch_body(&self, bodies: &Bodies, i: usize) {
        bodies.prefetch(i);
        self.cells.prefetch(i);
        self.calendar.prefetch(i);
        if let Some(lists) = &self.lists {
            lists.prefetch(i);
        }
    }

    /// Body `i`'s cell changed (see [`Marks`]): marked for the parallel loop, whose workers' results
    /// are checked against the cells changed since their world. The serial loop keeps no marks,
    /// and reads no cell for them. (Told by `threads`: the parallel loop takes its workers out
    /// of the loop while it steps.)
    #[inline(always)]
    fn mark_cell_of(&mut self, i: usize) {
        if self.threads > 1 {
            self.marks.mark(self.cells.cell_of(i));
        }
    }

    /// The calendar's event `entry`, handled.
    fn dispatch(&mut self, bodies: &mut Bodies, physics: &Physics, entry: Entry, out: &mut Output) {
        let (owner, t) = (entry.owner as usize, entry.scheduled.time());
        if entry.scheduled.cell_crossing() {
            if self.lists.is_some() {
                self.exit_shell(bodies, owner, t, out.stats);
            } else {
                self.cross_cell(bodies, owner, t, out.stats);
            }
        } else {
            self.handle(bodies, physics, owner, entry.scheduled.event, out);
        }
    }

    /// Body `i` crosses into the next cell at `t`: it is listed there, and tested against the
    /// bodies that came within reach.
    fn cross_cell(&mut self, bodies: &Bodies, i: usize, t: f64, stats: &mut FrameStats) {
        let Events { next: before, crossing } = *self.calendar.events(i);
        // Both cells change: the one it leaves, then (once it stepped across) the one it enters.
        self.mark_cell_of(i);
        let into = self.cells.step_across(i, crossing);
        self.mark_cell_of(i);
        let mut search = self.search(bodies);
        let next = search.after_crossing(i, (into, crossing), t, before);
        stats.narrow_tests += search.tests;
        let crossing = self.cells.next_crossing(bodies, i, t);
        self.calendar.schedule(i as u32, Events { next, crossing });
    }

    /// Body `i` leaves its shell at `t`: it is listed by its new shell's centre, and tested
    /// against the bodies new to its list.
    fn exit_shell(&mut self, bodies: &Bodies, i: usize, t: f64, stats: &mut FrameStats) {
        let was_at_face = self.cells.at_face(self.cells.place(i).0);
        self.cells.relist(bodies, i, t);
        let lists = self.lists.as_mut().expect("a shell exit comes with the lists");
        // In place: a wrap across a periodic face builds the list anew at once, so none came
        // since the last.
        lists.rebuild(&self.cells, bodies, i, t, true);
        let crossing = Crossing { time: lists.exit(bodies, i, t), ..Crossing::NEVER };
        let entered_face = !was_at_face && self.cells.at_face(self.cells.place(i).0);
        let before = self.calendar.events(i).next;
        let mut search = self.search(bodies);
        let next = search.after_shell_exit(i, t, before, entered_face);
        stats.narrow_tests += search.tests;
        self.calendar.schedule(i as u32, Events { next, crossing });
    }

    /// The event `event`, scheduled by body `owner`: handled if its bodies' motions are those
    /// it was predicted from; otherwise `owner`'s events after it are found again.
    fn handle(&mut self, bodies: &mut Bodies, physics: &Physics, owner: usize, event: Event, out: &mut Output) {
        let i = event.body as usize;
        if !event.is_current(bodies) {
            out.stats.invalidations += 1;
            self.predict(bodies, owner, event.time, Eligible::After(event), out.stats);
            return;
        }
        let t = event.time;
        match event.partner {
            Partner::Body(j) => self.pair_contact(bodies, physics, event, j, out),
            Partner::Wall(wall) => respond::wall_contact(self, bodies, physics, event.body, wall, t, out),
            Partner::Cross(face) => {
                bodies.wrap(i, face, t);
                self.mark_cell_of(i);
                self.cells.relist(bodies, i, t);
                if let Some(lists) = &mut self.lists {
                    // Its shell's centre moves with it, whole sides away.
                    lists.rebuild(&self.cells, bodies, i, t, false);
                }
                self.predict(bodies, i, t, Eligible::From(t), out.stats);
            }
            Partner::End(_) | Partner::Stalled(_) | Partner::WallStalled | Partner::Renew => {
                unreachable!("the event loop predicts contacts, wall contacts and periodic crossings only")
            }
        }
    }

    /// The contact `event` of bodies `event.body < b`, as the frame pipeline handles two moving
    /// spheres (see [`respond`]); bodies that parted at it go on to their events after it.
    fn pair_contact(&mut self, bodies: &mut Bodies, physics: &Physics, event: Event, b: u32, out: &mut Output) {
        let (a, t) = (event.body, event.time);
        // Their contact histories change, whatever the impact does.
        self.mark_cell_of(a as usize);
        self.mark_cell_of(b as usize);
        let (point, normal, resolution, impulse) = if is_plain_pair(bodies, physics, a as usize, b as usize) {
            respond::plain_pair_impact(self, bodies, physics, (a, b), t, out.stats)
        } else {
            respond::pair_impact(self, bodies, physics, (a, b), t, out.stats)
        };
        if resolution == Resolution::Parting {
            // Nothing changed: each goes on to its events after this one.
            self.predict(bodies, a as usize, t, Eligible::After(event), out.stats);
            self.predict(bodies, b as usize, t, Eligible::After(event), out.stats);
        }
        out.stats.pair_contacts += 1;
        let (body, touched) = (bodies.handle(a as usize), Touched::Body(bodies.handle(b as usize)));
        out.contacts.push(Contact { time: t, body, touched, point, normal, impulse });
    }
}

impl Responder for EventLoop {
    const MAY_LIE_STILL: bool = false;

    fn impacts(&mut self) -> &mut Impacts {
        &mut self.impacts
    }

    /// The event loop runs only without gravity, where no body lies still (see
    /// [`crate::response::rest`]), so no impact wakes one.
    fn woke(&mut self, _: &mut Bodies, _: &Physics, woken: usize, _: f64, _: &mut FrameStats) {
        unreachable!("body {woken} lay still in the event loop, which runs without gravity");
    }

    /// The jam rule on the bodies touching `seeds` at `t`, found through the cells; every member's
    /// events are found again. Returns the cluster's virial.
    fn freeze_cluster(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        seeds: &[u32],
        t: f64,
        stats: &mut FrameStats,
    ) -> f64 {
        let cells = &self.cells;
        let near = |_: &Bodies, m: usize, near: &mut Vec<u32>| {
            cells.for_each_around(m, |n| {
                let mut q = cells.first(n.cell);
                while q != NONE {
                    if q as usize != m {
                        near.push(q);
                    }
                    q = cells.after(q);
                }
            })
        };
        let rules = &mut self.impacts.rules;
        let virial = self.cluster.freeze(bodies, physics, rules, seeds, t, stats, near, |_, _| false);
        let mut members = std::mem::take(&mut self.members);
        members.clear();
        members.extend_from_slice(self.cluster.members());
        for &m in &members {
            self.predict(bodies, m as usize, t, Eligible::From(t), stats);
        }
        self.members = members;
        virial
    }

    fn moved(&mut self, bodies: &Bodies, _: &Physics, a: u32, b: Option<u32>, t: f64, stats: &mut FrameStats) {
        for i in [Some(a), b].into_iter().flatten() {
            self.predict(bodies, i as usize, t, Eligible::From(t), stats);
        }
    }
}

#[cfg(test)]
impl EventLoop {
    /// From now on every step ends checking the search's screen (see [`Self::check_screen`]) and
    /// the lists when kept (see [`Lists::check`]).
    pub(crate) fn check_screen_each_step(&mut self) {
        self.checking = true;
    }

    /// The serial loop keeps lists whatever the packing (from the next rebuild of the grid), with
    /// blocks of `block` entries at first.
    pub(crate) fn keep_lists_always(&mut self, block: usize) {
        self.always_lists = Some(block);
    }

    /// Every listed body's next event found again at `now`, with the screen and without it: the
    /// screen must never change what the exact tests alone find.
    fn check_screen(&mut self, bodies: &Bodies, now: f64) {
        let ids: Vec<u32> = self.bodies().filter(|&i| self.cells.cell_of(i as usize) != NONE).collect();
        assert!(!ids.is_empty());
        for &i in &ids {
            let found = |event_loop: &mut EventLoop, screen: bool| {
                let mut search = event_loop.search(bodies);
                search.screen = screen;
                search.next_event(i as usize, now, Eligible::From(now))
            };
            let (screened, exact) = (found(self, true), found(self, false));
            assert_eq!(format!("{screened:?}"), format!("{exact:?}"), "body {i}: the screen changed its next event");
        }
    }
}
