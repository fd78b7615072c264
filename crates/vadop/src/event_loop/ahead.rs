//! The parallel event loop: the world's next events worked out on every worker at once, ahead of
//! their turn, then handled in the calendar's order, each worker's result used only when nothing
//! it read has changed since, so the world steps to the same bits on any number of threads.
//!
//! It owns the batch and what a worker finds for an event of it. The next events (as many as
//! [`PER_WORKER`] per worker) are taken from the calendar; the workers find, from the world as it
//! stands and without changing it, what handling each would find: for a contact of two spheres,
//! the impact's new motions and both bodies' next events and cell crossings; for a voided event,
//! its body's next event; for a cell crossing, the contacts with the cells it reaches and its
//! next crossing. Then one thread handles the events in order, the batch's and any the calendar
//! now holds before them (events predicted by those just handled), with the serial loop's own
//! code. A worker's result is used when no cell it read was marked since the batch started (a
//! body in it moved, changed cells or took part in a contact) and, for a contact, when the
//! impact, done again on its turn, gives the very motions the worker assumed; otherwise the
//! event is worked out again on its turn. So every event is handled as the serial loop handles
//! it, in the same order, and what the workers share is the searches, most of an event's cost.
//! This is speculation with in-order commit (as in Khan and Herbordt's parallel event-driven MD)
//! over one calendar: no region of the box is a thread's, so there is no border to agree on. It
//! never schedules or handles an event itself.

use super::calendar::{Calendar, Entry, Events};
use super::cells::{Cells, Crossing};
use super::search::{Candidate, Eligible, Near, Overlay, Search};
use crate::bodies::{Bodies, BodyState};
use crate::event_queue::{Event, Partner};
use crate::frame::Physics;
use crate::motion::Motion;
use crate::narrow_phase::contacts;
use crate::response::impact::{spheres_pushed, virial_of};
use crate::response::rules::ContactRules;
use crate::walls::BoxBounds;
use glam::DVec3;

/// Events each worker works out per batch: enough that waking the workers costs little against
/// the batch, few enough that events handled early in it rarely change what later ones read (an
/// event reads about 50 cells and changes 2 or 3, so with a batch of k events over C cells about
/// 75 k / C of them were worked out in vain): at most this many, at least [`MIN_PER_WORKER`],
/// and a batch no larger than one event per [`CELLS_PER_EVENT`] cells.
pub(super) const PER_WORKER: usize = 32;
pub(super) const MIN_PER_WORKER: usize = 8;
pub(super) const CELLS_PER_EVENT: usize = 2048;

/// What a worker found for an event, from the world as the batch found it. Kept unboxed: the
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
    /// Their velocities, motions and stamps after it.
    pub velocities: [DVec3; 2],
    pub motions: [Motion; 2],
    pub stamps: [u32; 2],
    /// Their next events and next cell crossings.
    pub next: [Option<Event>; 2],
    pub crossings: [Crossing; 2],
}

/// A worker's scratch, and what it found for its share of the batch.
#[derive(Debug, Default)]
pub(super) struct Worker {
    candidates: Vec<Candidate>,
    near: Box<Near>,
    pub worked: Vec<Worked>,
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
    /// The calendar, with each body's next event and next cell crossing.
    pub calendar: &'a Calendar,
}

impl Seen<'_> {
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
        let worked = if entry.scheduled.cell_crossing {
            let Events { next: before, crossing } = *self.calendar.events(owner);
            let into = self.cells.stepped(owner, crossing);
            let next = search.after_crossing(owner, (into, crossing), time, before);
            Worked::Crossed { next, crossing: self.cells.next_crossing_from(&self.bodies.motion(owner), into.0, time) }
        } else {
            let event = entry.scheduled.event;
            match (is_current(self.bodies, &event), event.partner) {
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
        let (point, normal) = contacts::pair_geometry(self.bodies, i, j, t);
        let Some((impulse, vi, vj)) = spheres_pushed(self.bodies, (i, j), t, normal, restitution) else {
            return Worked::Nothing;
        };
        let virial = virial_of(self.bodies, (i, j), t, (self.bodies.velocity_at(j, t), vj));
        let moved = |k: usize, velocity| Motion { position: self.bodies.position_at(k, t), since: t, velocity };
        let motions = [moved(i, vi), moved(j, vj)];
        let stamps = [self.bodies.stamp(i).wrapping_add(1), self.bodies.stamp(j).wrapping_add(1)];
        let state = |k: usize, motion| BodyState { motion, radius: self.bodies.radius(k) };
        search.overlay =
            Overlay::default().with(a, state(i, motions[0]), stamps[0]).with(b, state(j, motions[1]), stamps[1]);
        let next = [search.next_event(i, t, Eligible::From(t)), search.next_event(j, t, Eligible::From(t))];
        let crossings = [(i, motions[0]), (j, motions[1])]
            .map(|(k, motion)| self.cells.next_crossing_from(&motion, self.cells.place(k).0, t));
        let velocities = [vi, vj];
        Worked::Pushed(Pushed {
            pair: [a, b],
            point,
            normal,
            restitution,
            impulse,
            virial,
            velocities,
            motions,
            stamps,
            next,
            crossings,
        })
    }
}

/// True when the bodies of `event` still have the motions it was predicted from.
#[inline]
pub(super) fn is_current(bodies: &Bodies, event: &Event) -> bool {
    let current = |k: usize, stamp: u32| bodies.alive[k] && bodies.stamp(k) == stamp;
    let partner_current = match event.partner {
        Partner::Body(j) => current(j as usize, event.partner_stamp),
        _ => true,
    };
    current(event.body as usize, event.body_stamp) && partner_current
}

/// True when `second`, the entry after `first` in the calendar's order, is the same contact held
/// by its other body.
#[inline]
pub(super) fn same_contact(first: &Entry, second: &Entry) -> bool {
    let (a, b) = (&first.scheduled, &second.scheduled);
    !a.cell_crossing && !b.cell_crossing && matches!(b.event.partner, Partner::Body(_)) && a.event == b.event
}

/// True when two motions are the same to the bit.
#[inline]
pub(super) fn same_bits(a: &Motion, b: &Motion) -> bool {
    let bits = |m: &Motion| {
        [m.position.x, m.position.y, m.position.z, m.since, m.velocity.x, m.velocity.y, m.velocity.z].map(f64::to_bits)
    };
    bits(a) == bits(b)
}

/// Per cell, whether anything in it changed since the batch started: a body in it moved, took
/// part in a contact, or came or left. Two bytes per cell, the batch's number modulo 2^16: a mark
/// from 2^16 batches before reads as marked, which only costs working an event out again.
#[derive(Debug, Default)]
pub(super) struct Marks {
    batch: Vec<u16>,
    current: u16,
}

impl Marks {
    /// A new batch over `cells` cells: nothing is marked.
    pub(super) fn next_batch(&mut self, cells: usize) {
        if self.batch.len() != cells {
            self.batch = vec![0; cells];
        }
        self.current = self.current.wrapping_add(1);
    }

    /// Something in cell `cell` changed.
    #[inline]
    pub(super) fn mark(&mut self, cell: u32) {
        if let Some(b) = self.batch.get_mut(cell as usize) {
            *b = self.current;
        }
    }

    /// True when something in cell `cell` may have changed since the batch started.
    #[inline]
    pub(super) fn is_marked(&self, cell: u32) -> bool {
        self.batch.get(cell as usize).is_some_and(|&b| b == self.current)
    }

    /// True when something in a cell of the rows of 3 cells starting at `rows` may have changed
    /// since the batch started.
    #[inline]
    pub(super) fn any_in_rows(&self, rows: &[usize; 9]) -> bool {
        let (marks, current) = (&self.batch[..], self.current);
        rows.iter().fold(false, |any, &first| {
            let row = &marks[first..first + 3];
            any | (row[0] == current) | (row[1] == current) | (row[2] == current)
        })
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.batch.capacity() * 2
    }
}
