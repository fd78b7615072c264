//! Pair contacts that change nothing: two spheres passing through each other in detect mode.
//!
//! It owns when their geometry (where they touch, the normal) is worked out: not in the event
//! loop, which runs on one thread, but by every worker, before the step's events for the window
//! start's predictions and once they are done for the rest. A window start's prediction that
//! pops valid has its bodies' stamps as they were before the step's events, and every change of
//! a body's motion bumps its stamp, so the paths it happened on are the paths before the step:
//! its geometry and its bodies' handles are worked out then, for every such prediction before
//! the step's end, with the stamps marked ([`Bodies::mark_stamps`]); when it pops, it is still
//! current unless either stamp was bumped since, which one bit a body tells, and the loop
//! reports it without reading either body. Any other such contact (predicted mid-step) is
//! reported in its place at once, with the two paths it happened on kept beside it; a path copied
//! outlives the bodies' later velocity changes (a wall bounce later in the step), and each
//! contact's geometry is a function of its own record alone. Either way the bits are those the
//! event loop would have computed, for every thread count. It never handles an event.

use crate::bodies::Bodies;
use crate::event_queue::{Event, Partner};
use crate::frame::{Contact, Physics, Touched};
use crate::handle::BodyHandle;
use crate::narrow_phase::contacts::{sphere_pair_geometry, SpherePath};
use crate::parallel::Workers;
use crate::response::impact::passes_through;
use glam::DVec3;

/// A reported contact of spheres `i` and `j` whose geometry is still to be worked out.
#[derive(Debug, Clone, Copy)]
struct Pending {
    /// Its place in the step's contacts.
    contact: usize,
    i: u32,
    j: u32,
    /// The two spheres' paths at the contact.
    paths: [SpherePath; 2],
}

/// The step's contacts of spheres passing through each other whose geometry is pending, in the
/// order they were reported.
#[derive(Debug, Default)]
pub(super) struct PassedContacts {
    pending: Vec<Pending>,
    /// The queue's bulk events from place `ahead_first` on, worked out before the step's events
    /// (see [`Self::work_out_ahead`]); only the places of valid pass-throughs of spheres hold
    /// them.
    ahead: Vec<Option<Worked>>,
    ahead_first: usize,
}

/// A pass-through of two spheres worked out ahead: where they touch, the normal, and the two
/// bodies' generations (their handles', which no step changes).
#[derive(Debug, Clone, Copy)]
struct Worked {
    point: DVec3,
    normal: DVec3,
    generations: [u32; 2],
}

/// What [`WorkedAhead::ahead_of`] knows of a bulk event as it pops.
pub(super) enum Ahead {
    /// Nothing: the event loop handles it as any event.
    Unknown,
    /// A pass-through worked out ahead whose bodies changed motion since: void.
    Void,
    /// A pass-through worked out ahead, still current: its record, and the event's partner.
    Current(Contact, u32),
}

/// The bulk events worked out ahead, from place `first` on: a copy the event loop holds in
/// registers through a run of events (see [`crate::event_queue::EventQueue::pop_bulk_run`]),
/// where reading them through [`PassedContacts`] loaded its fields again for each event.
#[derive(Clone, Copy)]
pub(super) struct WorkedAhead<'a> {
    worked: &'a [Option<Worked>],
    first: usize,
}

impl<'a> WorkedAhead<'a> {
    /// Whether the bulk event at `place` was worked out ahead (a valid pass-through of two
    /// spheres when the step started with it before its end): the loop then reads neither body.
    #[inline]
    pub(super) fn is_worked_out(self, place: usize) -> bool {
        self.worked(place).is_some()
    }

    /// Whether any bulk event was worked out ahead: none outside detect mode's spheres.
    pub(super) fn holds_any(self) -> bool {
        !self.worked.is_empty()
    }

    /// What was worked out for the bulk event at `place`, if anything.
    #[inline]
    fn worked(self, place: usize) -> Option<&'a Worked> {
        // A place before the first wraps past the end.
        self.worked.get(place.wrapping_sub(self.first))?.as_ref()
    }

    /// What was worked out ahead of `event`, just popped from the bulk's `place`.
    #[inline]
    pub(super) fn ahead_of(self, bodies: &Bodies, place: usize, event: &Event) -> Ahead {
        let (Some(worked), Partner::Body(j)) = (self.worked(place), event.partner) else {
            return Ahead::Unknown;
        };
        let i = event.body;
        if bodies.bumped_since_mark(i as usize) || bodies.bumped_since_mark(j as usize) {
            return Ahead::Void;
        }
        let [generation_i, generation_j] = worked.generations;
        let contact = Contact {
            time: event.time,
            body: BodyHandle::new(i, generation_i),
            touched: Touched::Body(BodyHandle::new(j, generation_j)),
            point: worked.point,
            normal: worked.normal,
            impulse: 0.0,
        };
        Ahead::Current(contact, j)
    }
}

impl PassedContacts {
    /// The contact of spheres `i` and `j`, reported at place `contact` of the step's contacts,
    /// gets its geometry from their paths now.
    #[inline]
    pub(super) fn defer(&mut self, bodies: &Bodies, (i, j): (u32, u32), contact: usize) {
        let paths = [SpherePath::of(bodies, i as usize), SpherePath::of(bodies, j as usize)];
        self.pending.push(Pending { contact, i, j, paths });
    }

    /// Before the step's events: the geometry and handles of each of `events` (the queue's bulk
    /// events before the step's end, the first at place `first`) that is two spheres passing
    /// through each other on their current paths, on every worker, and the stamps marked. Out of
    /// line: a profile then tells its share apart.
    #[inline(never)]
    pub(super) fn work_out_ahead(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        (first, events): (usize, &[Event]),
        workers: &Workers,
    ) {
        self.ahead_first = first;
        if physics.turns_back(false) || bodies.has_rigid() {
            // Simulate mode: no two bodies pass through each other. A world with shapes: most
            // pairs are not two spheres, and the few that are wait for the step's end.
            self.ahead.clear();
            return;
        }
        // Every place is written in place by its chunk's worker (only the places past the last
        // call's are filled first): chunks of their own, appended, were grown and moved again,
        // 11 % more instructions than one thread's (1.75 M a frame at n = 10^5, 5 d/f).
        self.ahead.resize(events.len(), None);
        let passing = &*bodies;
        workers.chunks_mut(&mut self.ahead, |offset, ahead| {
            for (worked, event) in ahead.iter_mut().zip(&events[offset..]) {
                *worked = passing_geometry(passing, physics, event);
            }
        });
        bodies.mark_stamps();
    }

    /// What was worked out ahead, as the event loop reads it.
    #[inline]
    pub(super) fn worked_ahead(&self) -> WorkedAhead<'_> {
        WorkedAhead { worked: &self.ahead, first: self.ahead_first }
    }

    /// Works out the pending contacts' geometry into `contacts`, on every worker: each chunk of
    /// the contacts fills its own pending ones. Out of line: a profile then tells its share apart.
    #[inline(never)]
    pub(super) fn resolve(&mut self, bodies: &Bodies, contacts: &mut [Contact], workers: &Workers) {
        let Some(first) = self.pending.first().map(|p| p.contact) else { return };
        let pending = &self.pending;
        workers.chunks_mut(&mut contacts[first..], |offset, chunk| {
            let (start, end) = (first + offset, first + offset + chunk.len());
            let from = pending.partition_point(|p| p.contact < start);
            for p in pending[from..].iter().take_while(|p| p.contact < end) {
                let c = &mut chunk[p.contact - start];
                let (i, j) = ((p.i as usize, &p.paths[0]), (p.j as usize, &p.paths[1]));
                (c.point, c.normal) = sphere_pair_geometry(bodies, i, j, c.time);
            }
        });
        self.pending.clear();
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.pending.capacity() * std::mem::size_of::<Pending>()
            + self.ahead.capacity() * std::mem::size_of::<Option<Worked>>()
    }
}

/// Where the spheres of `event` touch on their current paths, the normal and their generations,
/// when it is a valid contact of two spheres passing through each other (an event void now stays
/// void, and whether two bodies pass through does not change within a step).
#[inline]
fn passing_geometry(bodies: &Bodies, physics: &Physics, event: &Event) -> Option<Worked> {
    let Partner::Body(j) = event.partner else { return None };
    let (i, j) = (event.body as usize, j as usize);
    let passing = bodies.are_spheres(i, j) && passes_through(bodies, physics, i, j);
    (passing && event.is_current(bodies)).then(|| {
        let (path_i, path_j) = (SpherePath::of(bodies, i), SpherePath::of(bodies, j));
        let (point, normal) = sphere_pair_geometry(bodies, (i, &path_i), (j, &path_j), event.time);
        Worked { point, normal, generations: [bodies.generation(i), bodies.generation(j)] }
    })
}
