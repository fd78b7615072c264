//! The parallel event loop: the world's next events worked out on every worker at once, ahead of
//! their turn, then handled in the calendar's order, each worker's result used only when nothing
//! it read has changed since, so the world steps to the same bits on any number of threads.
//!
//! It owns what a worker finds for an event of a batch, the copy of the world the workers read,
//! and the rule that tells when a result can be used. The next events (as many as [`PER_THREAD`]
//! per thread) are taken from the calendar; the workers find, from the [`Mirror`] and without
//! changing it, what handling each would find: for a contact of two spheres, the impact's new
//! motions and both bodies' next events and cell crossings; for a voided event, its body's next
//! event; for a cell crossing, the contacts with the cells it reaches and its next crossing. One
//! thread handles the events in order, with the serial loop's own code, while the workers work
//! out the next batch (see [`super::in_order`]). A worker's result is used when no cell it read
//! was marked since its world (a body in it moved, changed cells or took part in a contact:
//! [`Marks`]) and, for a contact, when the impact, done again on its turn, gives the very motions
//! the worker assumed; otherwise the event is worked out again on its turn. So every event is
//! handled as the serial loop handles it, in the same order, and what the workers share is the
//! searches, most of an event's cost. This is speculation with in-order commit (as in Khan and
//! Herbordt's parallel event-driven MD) over one calendar: no region of the box is a thread's,
//! so there is no border to agree on. It never schedules or handles an event itself.

use super::calendar::{Calendar, Entry, Events};
use super::cells::{Cells, Crossing, NONE};
use super::search::{Candidates, Eligible, Near, Overlay, Search};
use crate::bodies::{Bodies, BodyState, BodyTag};
use crate::event_queue::{Event, Partner};
use crate::frame::Physics;
use crate::motion::Motion;
use crate::narrow_phase::contacts;
use crate::response::impact::{spheres_pushed, virial};
use crate::response::rules::ContactRules;
use crate::walls::BoxBounds;
use glam::DVec3;
use rayon::prelude::*;

/// Events a batch holds per thread: enough that waking the workers costs little against the
/// batch, few enough that events handled early rarely change what later ones read (an event reads
/// about 50 cells and changes 2 or 3, and a result is checked against the changes of two commits,
/// so with batches of k events over C cells about 150 k / C of them were worked out in vain): at
/// most this many, at least [`MIN_PER_THREAD`], and a batch no larger than one event per
/// [`CELLS_PER_EVENT`] cells.
pub(super) const PER_THREAD: usize = 32;
pub(super) const MIN_PER_THREAD: usize = 8;
pub(super) const CELLS_PER_EVENT: usize = 2048;

/// What a worker found for an event, from the world it read (the [`Mirror`]). Kept unboxed: the
/// workers' vectors are reused from batch to batch, and a box would allocate per event.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
pub(super) enum Worked {
    /// Nothing worked out (a wall contact, a periodic crossing, or a contact the impact would not
    /// simply push apart).
    Nothing,
    /// Bodies `pair` pushed apart (see [`Pushed`]).
    Pushed(Pushed),
    /// A voided event: its body's next event after it.
    Voided { next: Option<Event> },
    /// A body crossing into a cell: its next event with the cells it reaches, its next crossing.
    Crossed { next: Option<Event>, crossing: Crossing },
}

/// A contact of two spheres pushed apart, as a worker found it: what the impact does and what
/// follows it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pushed {
    pub pair: [u32; 2],
    /// Where they touch and the normal from the first to the second.
    pub point: DVec3,
    pub normal: DVec3,
    /// The restitution of the impact (the TC model's), the impulse and the virial it adds.
    pub restitution: f64,
    pub impulse: f64,
    pub virial: f64,
    /// Their motions (from their centres at the contact) and stamps after it.
    pub motions: [Motion; 2],
    pub stamps: [u32; 2],
    /// Their next events and next cell crossings.
    pub next: [Option<Event>; 2],
    pub crossings: [Crossing; 2],
}

/// A worker's scratch, and what it counts.
#[derive(Debug, Default)]
pub(super) struct Worker {
    candidates: Candidates,
    near: Box<Near>,
    /// Exact pair tests made.
    pub tests: u64,
}

/// What the workers read: the world as the batch found it.
pub(super) struct Seen<'a> {
    pub bodies: &'a Bodies,
    pub cells: &'a Cells,
    pub bounds: &'a BoxBounds,
    pub physics: &'a Physics,
    pub rules: &'a ContactRules,
    pub screen: bool,
    /// Each body's next event and next cell crossing, as the calendar booked them.
    pub events: &'a [Events],
}

impl Seen<'_> {
    /// What handling each event of `batch` would find, into `worked` (one result an event),
    /// shared among `workers` in runs of consecutive events.
    pub(super) fn work_out_batch(&self, workers: &mut [Worker], batch: &[Entry], worked: &mut Vec<Worked>) {
        worked.clear();
        worked.resize(batch.len(), Worked::Nothing);
        let share = batch.len().div_ceil(workers.len()).max(1);
        worked.par_chunks_mut(share).zip(workers.par_iter_mut()).enumerate().for_each(|(k, (results, worker))| {
            for (at, result) in (k * share..).zip(results) {
                // The second owner's entry of a contact: handling the first reschedules both
                // bodies, so this one is stale by its turn (if not, it is handled there).
                if !(at > 0 && same_contact(&batch[at - 1], &batch[at])) {
                    *result = self.work_out(&batch[at], worker);
                }
            }
        });
    }

    /// What handling `entry` would find, worked out without changing anything. (Kept out of line:
    /// a profile then tells the workers' share of a step from the rest.)
    #[inline(never)]
    pub(super) fn work_out(&self, entry: &Entry, worker: &mut Worker) -> Worked {
        let (owner, time) = (entry.owner as usize, entry.scheduled.time());
        let mut search = Search {
            bodies: self.bodies,
            cells: self.cells,
            lists: None,
            bounds: self.bounds,
            screen: self.screen,
            candidates: &mut worker.candidates,
            near: &mut worker.near,
            overlay: Overlay::default(),
            tests: 0,
        };
        let worked = if entry.scheduled.cell_crossing() {
            let Events { next: before, crossing } = self.events[owner];
            let into = self.cells.stepped(owner, crossing);
            let next = search.after_crossing(owner, (into, crossing), time, before);
            Worked::Crossed { next, crossing: self.cells.next_crossing_from(&self.bodies.motion(owner), into.0, time) }
        } else {
            let event = entry.scheduled.event;
            match (event.is_current(self.bodies), event.partner) {
                (false, _) => Worked::Voided { next: search.next_event(owner, time, Eligible::After(event)) },
                (true, Partner::Body(b)) => self.pushed(&mut search, event.body, b, time),
                (true, _) => Worked::Nothing,
            }
        };
        worker.tests += search.tests;
        worked
    }

    /// Bodies `a < b` touching at `t`, pushed apart as the impact of two frictionless spheres
    /// pushes them (its restitution under the TC model), and both bodies' next events from their
    /// new motions; nothing when they would part without an impulse.
    fn pushed(&self, search: &mut Search, a: u32, b: u32, t: f64) -> Worked {
        let (i, j) = (a as usize, b as usize);
        let physics = self.physics;
        if physics.friction != 0.0 {
            return Worked::Nothing;
        }
        let restitution = self.rules.pair_restitution(a, b, t, physics.restitution, physics.contact_duration);
        // What the serial loop's impact finds (`Impacts::plain_pair`), from the same functions.
        // The paths moved on to `t` (as `plain_pair` takes them): the new motions keep their
        // centres, the bits `Bodies::set_velocity_at` would work out again.
        let (touch, [on_i, on_j]) = contacts::spheres_touch_on(self.bodies, i, j, t);
        let (point, normal) = (touch.point, touch.normal);
        let before = [on_i.velocity, on_j.velocity];
        let Some((impulse, vi, vj)) = spheres_pushed(self.bodies, (i, j), before, normal, restitution) else {
            return Worked::Nothing;
        };
        let virial = virial(touch.offset, self.bodies.mass(j), (before[1], vj));
        let motions = [Motion { velocity: vi, ..on_i }, Motion { velocity: vj, ..on_j }];
        let stamps = [self.bodies.stamp(i).wrapping_add(1), self.bodies.stamp(j).wrapping_add(1)];
        let state = |k: usize, motion| BodyState { motion, radius: self.bodies.radius(k) };
        search.overlay =
            Overlay::default().with(a, state(i, motions[0]), stamps[0]).with(b, state(j, motions[1]), stamps[1]);
        let next = [search.next_event(i, t, Eligible::From(t)), search.next_event(j, t, Eligible::From(t))];
        let crossings = [(i, motions[0]), (j, motions[1])]
            .map(|(k, motion)| self.cells.next_crossing_from(&motion, self.cells.place(k).0, t));
        Worked::Pushed(Pushed {
            pair: [a, b],
            point,
            normal,
            restitution,
            impulse,
            virial,
            motions,
            stamps,
            next,
            crossings,
        })
    }
}

/// True when `second`, the entry after `first` in the calendar's order, is the same contact held
/// by its other body.
#[inline]
pub(super) fn same_contact(first: &Entry, second: &Entry) -> bool {
    let (a, b) = (&first.scheduled, &second.scheduled);
    !a.cell_crossing() && !b.cell_crossing() && matches!(b.event.partner, Partner::Body(_)) && a.event == b.event
}

/// True when two motions are the same to the bit.
#[inline]
pub(super) fn same_bits(a: &Motion, b: &Motion) -> bool {
    let bits = |m: &Motion| {
        [m.position.x, m.position.y, m.position.z, m.since, m.velocity.x, m.velocity.y, m.velocity.z].map(f64::to_bits)
    };
    bits(a) == bits(b)
}

/// Per cell, whether anything in it changed since the world the workers read: in the commit of
/// this batch or of the one before (the workers of a batch work while the batch before it is
/// committed, from the world as the commit before that left it: see [`Mirror`]). Two bytes per
/// cell, the number of the batch whose commit last changed it, modulo 2^16: a mark from 2^16
/// batches before reads as a change, which only costs working an event out again. And the cells
/// this batch's commit changed, listed, for the mirror.
#[derive(Debug, Default)]
pub(super) struct Marks {
    batch: Vec<u16>,
    current: u16,
    changed: Vec<u32>,
}

impl Marks {
    /// A new batch over `cells` cells: nothing changed in its commit yet.
    pub(super) fn next_batch(&mut self, cells: usize) {
        self.current = self.current.wrapping_add(1);
        if self.batch.len() != cells {
            // Neither this batch's number nor the one before.
            self.batch = vec![self.current.wrapping_sub(2); cells];
        }
        self.changed.clear();
    }

    /// Something in cell `cell` changed.
    #[inline]
    pub(super) fn mark(&mut self, cell: u32) {
        if let Some(b) = self.batch.get_mut(cell as usize) {
            if *b != self.current {
                *b = self.current;
                self.changed.push(cell);
            }
        }
    }

    /// True when `batch` is this batch's number or the one before.
    #[inline(always)]
    fn recent(&self, batch: u16) -> bool {
        self.current.wrapping_sub(batch) <= 1
    }

    /// True when something in cell `cell` may have changed since the world the workers read.
    #[inline]
    pub(super) fn is_marked(&self, cell: u32) -> bool {
        self.batch.get(cell as usize).is_some_and(|&b| self.recent(b))
    }

    /// True when something in a cell of the rows of 3 cells starting at `rows` may have changed
    /// since the world the workers read.
    #[inline]
    pub(super) fn any_in_rows(&self, rows: &[usize; 9]) -> bool {
        rows.iter().fold(false, |any, &first| {
            let row = &self.batch[first..first + 3];
            any | self.recent(row[0]) | self.recent(row[1]) | self.recent(row[2])
        })
    }

    /// The cells this batch's commit changed, each once.
    pub(super) fn changed(&self) -> &[u32] {
        &self.changed
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.batch.capacity() * 2 + self.changed.capacity() * 4
    }
}

/// What the workers read, a copy of the world kept apart from it: the workers of a batch read
/// it while the commit of the batch before changes the world itself, so the two run at once.
/// Between two commits it takes what the earlier one changed (the cells it marked, with their
/// lists and their bodies' records, and the events of the bodies it scheduled): then it is the
/// world as that commit left it, and the next batch's results are checked against the cells
/// marked since (see [`Marks`]). Copied whole when the world changed otherwise (bodies entered
/// or removed, the grid rebuilt, contact histories restored).
#[derive(Debug, Default)]
pub(super) struct Mirror {
    pub bodies: Bodies,
    pub cells: Cells,
    pub events: Vec<Events>,
    pub rules: ContactRules,
    /// Not the world as it stands: to be copied whole before the next batch.
    pub stale: bool,
}

impl Mirror {
    /// What the workers read: the mirror, in the box `bounds`, under `physics`, the search's
    /// screen on when `screen`.
    pub(super) fn seen<'a>(&'a self, bounds: &'a BoxBounds, physics: &'a Physics, screen: bool) -> Seen<'a> {
        Seen {
            bodies: &self.bodies,
            cells: &self.cells,
            bounds,
            physics,
            rules: &self.rules,
            screen,
            events: &self.events,
        }
    }

    /// The world copied whole.
    pub(super) fn copy_all(&mut self, bodies: &Bodies, cells: &Cells, calendar: &Calendar, rules: &ContactRules) {
        self.bodies.clone_from(bodies);
        self.cells.clone_from(cells);
        self.events.clear();
        self.events.extend((0..bodies.slots()).map(|i| *calendar.events(i)));
        self.rules.clone_from(rules);
        self.stale = false;
    }

    /// What a commit changed copied from the world: the cells `changed` with the records of the
    /// bodies listed there (every body whose motion, stamp, place or history a commit changes
    /// is in a cell it marked), and the events of those bodies and of `owners`, the bodies whose
    /// events it handled (the only others it schedules).
    pub(super) fn copy_changed(
        &mut self,
        (bodies, cells, calendar, rules): (&Bodies, &Cells, &Calendar, &ContactRules),
        changed: &[u32],
        owners: &[u32],
    ) {
        for &cell in changed {
            self.cells.copy_cell(cells, cell);
            let mut q = cells.first(cell);
            while q != NONE {
                let i = q as usize;
                (self.bodies.state[i], self.bodies.tags[i]) = (bodies.state[i], bodies.tags[i]);
                self.bodies.alive[i] = bodies.alive[i];
                self.events[i] = *calendar.events(i);
                self.rules.copy_history(rules, i);
                q = cells.after(q);
            }
        }
        for &owner in owners {
            self.events[owner as usize] = *calendar.events(owner as usize);
        }
    }

    /// Tests: the mirror is the world as it stands (what the workers read of it).
    #[cfg(test)]
    pub(super) fn check(&self, (bodies, cells, calendar, rules): (&Bodies, &Cells, &Calendar, &ContactRules)) {
        assert!(self.cells.same_lists(cells), "the mirror's cells differ");
        for i in 0..bodies.slots() {
            assert_eq!(
                (self.bodies.state[i], self.bodies.tags[i], self.bodies.alive[i]),
                (bodies.state[i], bodies.tags[i], bodies.alive[i]),
                "the mirror's body {i} differs"
            );
            assert_eq!(format!("{:?}", self.events[i]), format!("{:?}", calendar.events(i)), "body {i}'s events");
            assert_eq!(self.rules.last_contact(i).to_bits(), rules.last_contact(i).to_bits(), "body {i}'s history");
        }
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        let bodies = &self.bodies;
        bodies.state.capacity() * std::mem::size_of::<BodyState>()
            + bodies.tags.capacity() * std::mem::size_of::<BodyTag>()
            + bodies.alive.capacity()
            + self.cells.memory_bytes()
            + self.events.capacity() * std::mem::size_of::<Events>()
            + self.rules.memory_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The overlap's conflict rule: a result worked out from the world the commit before last
    /// left is used only when no cell it read changed since, in the commit before or in this one;
    /// a change two commits back is in the workers' world already.
    #[test]
    fn a_cell_reads_changed_through_this_commit_and_the_one_before() {
        let mut marks = Marks::default();
        marks.next_batch(64);
        assert!((0..64).all(|c| !marks.is_marked(c)), "a new grid reads unchanged");
        marks.mark(5);
        marks.mark(5);
        marks.mark(9);
        assert_eq!(marks.changed(), &[5, 9], "each changed cell listed once");
        assert!(marks.is_marked(5) && marks.is_marked(9) && !marks.is_marked(6));
        marks.next_batch(64);
        assert!(marks.changed().is_empty());
        assert!(marks.is_marked(5) && marks.is_marked(9), "changed in the commit before");
        marks.mark(9);
        marks.mark(20);
        assert_eq!(marks.changed(), &[9, 20], "a cell changed again is listed for this commit too");
        marks.next_batch(64);
        assert!(!marks.is_marked(5), "changed two commits back: the workers' world has it");
        assert!(marks.is_marked(9) && marks.is_marked(20));
        let unchanged = [0, 30, 33, 36, 40, 44, 48, 52, 56];
        assert!(!marks.any_in_rows(&unchanged));
        assert!(marks.any_in_rows(&[0, 30, 33, 36, 40, 44, 48, 52, 19]), "cell 20 in the last row");
    }
}
