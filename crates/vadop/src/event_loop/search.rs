//! A body's next event in the event loop: its earliest contact with a body of its neighbourhood
//! (the 27 cells around it, or its neighbour list: [`super::lists`]), with a wall, or its crossing
//! of a periodic face.
//!
//! It owns two things. Which events a body may still be given ([`Eligible`]): every one from
//! now on when its motion is new, or those after the one just handled when it is unchanged (a
//! contact that pushed nothing), which is how the event queue of the frame pipeline drops a
//! contact it has handled. And the partners it gathers, each screened ([`super::screen`]) before
//! the exact test, which is the frame pipeline's own: [`contacts::pair_start`] on the lower id's
//! motion and the higher id's, shifted by whole sides across periodic faces, so every time is
//! canonical and the same bits as every method's. It never schedules, handles an event or
//! changes a body.

use super::cells::{Cells, Crossing, Lookup, Neighbour, NONE};
use super::lists::{self, Lists};
use super::screen::{lanes, screen, screen_fours, Own, Partners, ROUNDINGS};
use crate::bodies::{Bodies, BodyState};
use crate::event_queue::{Event, Partner};
use crate::memory::prefetch_item;
use crate::narrow_phase::contacts;
use crate::pipeline::predict::{crossing_event, sphere_wall_event};
use crate::walls::BoxBounds;
use crate::window::Window;
use glam::DVec3;
use std::cell::Cell;
use std::mem::MaybeUninit;

/// Which of a body's events may be scheduled.
#[derive(Debug, Clone, Copy)]
pub(super) enum Eligible {
    /// Every event from this instant on: the body's motion is new (or the calendar is rebuilt
    /// at a step's start, before any event of the step was handled).
    From(f64),
    /// The events after this one, in the event queue's order: the body's motion is unchanged,
    /// and every event of it up to this one was handled.
    After(Event),
}

impl Eligible {
    #[inline]
    fn start(&self) -> f64 {
        match self {
            Eligible::From(t) => *t,
            Eligible::After(event) => event.time,
        }
    }

    #[inline]
    fn admits(&self, event: &Event) -> bool {
        match self {
            Eligible::From(t) => event.time >= *t,
            // The queue's `Ord` puts earlier events last.
            Eligible::After(handled) => event < handled,
        }
    }
}

/// True when `a` comes before `b` in the event queue's order.
#[inline]
pub(super) fn earlier(a: &Event, b: &Event) -> bool {
    a > b
}

/// What a search reads: the bodies, the cells, whether the screen is trusted; its scratch; and
/// what it counts.
pub(super) struct Search<'a> {
    pub bodies: &'a Bodies,
    pub cells: &'a Cells,
    /// The neighbour lists, when the loop keeps them: a body's neighbourhood is then its list.
    pub lists: Option<&'a Lists>,
    pub bounds: &'a BoxBounds,
    pub screen: bool,
    /// The partners that passed the screen, waiting for their exact tests, and the cells they
    /// came from.
    pub candidates: &'a mut Candidates,
    pub near: &'a mut Near,
    /// Motions not yet written to the store (see [`Overlay`]).
    pub overlay: Overlay,
    /// Exact pair tests made.
    pub tests: u64,
}

/// The motions and stamps of up to two bodies as an impact not yet applied leaves them: a search
/// made ahead of the impact's turn reads them instead of the store's. Its first `len` entries
/// alone are written: the serial loop's searches, which have none, then start without zeroing
/// and copying two states each (about 50 instructions a search).
/// (The fields written first, apart from the entries: the compiler then has no gap of unwritten
/// bytes to fill with its zeroing of them.)
#[derive(Debug, Clone, Copy)]
#[repr(C)]
pub(super) struct Overlay {
    len: usize,
    /// A body of the overlay a search met among the neighbours, and its cell there.
    met: Option<(u32, u8)>,
    bodies: [MaybeUninit<(u32, u32, BodyState)>; 2],
}

impl Default for Overlay {
    #[inline(always)]
    fn default() -> Overlay {
        Overlay { bodies: [MaybeUninit::uninit(); 2], len: 0, met: None }
    }
}

impl Overlay {
    /// Body `i` with `state` and `stamp`.
    pub(super) fn with(mut self, i: u32, state: BodyState, stamp: u32) -> Overlay {
        self.bodies[self.len] = MaybeUninit::new((i, stamp, state));
        self.len += 1;
        self
    }

    #[inline(always)]
    fn find(&self, i: usize) -> Option<&(u32, u32, BodyState)> {
        // SAFETY: `with` wrote every entry below `len`, and nothing else changes them.
        self.bodies[..self.len]
            .iter()
            .map(|entry| unsafe { entry.assume_init_ref() })
            .find(|(k, _, _)| *k as usize == i)
    }
}

/// A partner from the neighbourhood: once it passed the screen, its exact test waits, ordered by
/// the earliest it could touch (after `now`; minus infinity when not bounded).
#[derive(Debug, Clone, Copy)]
pub(super) struct Candidate {
    earliest: f64,
    q: u32,
    /// Its cell among the neighbourhood's (see [`Near`]), or with lists its image (see
    /// [`Lists::images`]).
    cell: u8,
    /// The screen found its velocity surely apart from the searching body's, beyond the exact
    /// test's noise rule, which its test then skips (see [`super::screen`]).
    moving: bool,
}

/// The partners a search gathered, then those that passed the screen: the first `len` of a buffer
/// that only grows. A body gathered is written into its slot with the count kept in a register
/// along a cell's list, where a `Vec`'s push reads and writes its length through the search at
/// every body (a tenth of a search's own instructions).
#[derive(Debug, Default)]
pub(super) struct Candidates {
    slots: Vec<Candidate>,
    len: usize,
}

impl Candidates {
    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.slots.capacity() * std::mem::size_of::<Candidate>()
    }

    #[inline(always)]
    fn clear(&mut self) {
        self.len = 0;
    }

    /// The candidates.
    #[inline(always)]
    fn as_mut_slice(&mut self) -> &mut [Candidate] {
        &mut self.slots[..self.len]
    }

    /// Writes `candidate` into slot `len`, the buffer grown first when it holds no such slot.
    #[inline(always)]
    fn put(&mut self, len: usize, candidate: Candidate) {
        match self.slots.get_mut(len) {
            Some(slot) => *slot = candidate,
            None => {
                self.grow();
                self.slots[len] = candidate;
            }
        }
    }

    #[inline(always)]
    fn push(&mut self, candidate: Candidate) {
        self.put(self.len, candidate);
        self.len += 1;
    }

    #[cold]
    #[inline(never)]
    fn grow(&mut self) {
        let none = Candidate { earliest: 0.0, q: NONE, cell: 0, moving: false };
        self.slots.resize((2 * self.slots.len()).max(64), none);
    }
}

/// The neighbour cells a search gathered bodies from, each with the whole sides that bring its
/// bodies next to the searching body, and the searching body's centre less those. (After a list
/// is built anew, the origins are indexed by image instead: see [`Search::gather_fresh`].)
#[derive(Debug)]
pub(super) struct Near {
    cells: usize,
    shifts: [DVec3; 32],
    origins: [DVec3; 32],
}

impl Default for Near {
    fn default() -> Near {
        Near { cells: 0, shifts: [DVec3::ZERO; 32], origins: [DVec3::ZERO; 32] }
    }
}

/// The earliest eligible event found so far, and how long after `now` it comes (infinite when
/// none); and how long after `now` the earliest contact of the partners screened so far comes
/// at the latest, which bounds the screen.
struct Best {
    event: Option<Event>,
    horizon: f64,
    bound: f64,
}

impl Best {
    fn new(event: Option<Event>, now: f64) -> Best {
        let horizon = event.map_or(f64::INFINITY, |e| e.time - now);
        Best { event, horizon, bound: horizon }
    }

    /// Keeps `event` when eligible and earlier.
    #[inline]
    fn offer(&mut self, event: Event, eligible: Eligible, now: f64) {
        if eligible.admits(&event) && self.event.is_none_or(|b| earlier(&event, &b)) {
            (self.event, self.horizon) = (Some(event), event.time - now);
            self.bound = self.bound.min(self.horizon);
        }
    }
}

impl<'a> Search<'a> {
    /// Body `p`'s earliest eligible event at `now`: a contact with a body of its neighbourhood,
    /// with a wall, or its crossing of a periodic face.
    #[inline]
    pub(super) fn next_event(&mut self, p: usize, now: f64, eligible: Eligible) -> Option<Event> {
        let mut best = Best::new(None, now);
        if self.cells.at_face(self.cells.place(p).0) {
            self.offer_own(p, now, eligible, &mut best);
        }
        let (own, cells) = (self.own(p, now), self.cells);
        self.candidates.clear();
        self.near.cells = 0;
        if let Some(lists) = self.lists {
            self.screen_members(&own, lists, &mut best);
            self.test_candidates(&own, eligible, &mut best);
            return best.event;
        }
        let lookup = cells.lookup();
        match cells.rows_around(p) {
            Some(rows) => {
                // No cell across a face: one origin for all.
                (self.near.origins[0], self.near.shifts[0], self.near.cells) = (own.position, DVec3::ZERO, 1);
                // The occupied cells as bits, four a row: no array of them to zero.
                let mut bits = 0;
                for (k, &first) in rows.iter().enumerate() {
                    bits |= u64::from(lookup.occupied_in_row(first)) << (4 * k);
                }
                let occupied = std::iter::from_fn(|| {
                    (bits != 0).then(|| {
                        let bit = bits.trailing_zeros();
                        bits &= bits - 1;
                        (rows[bit as usize / 4] as u32 + bit % 4, 0)
                    })
                });
                self.gather_cells(lookup, own.p, occupied);
            }
            None => {
                let mut found = [0; 32];
                cells.for_each_around(p, |n| self.note(lookup, &own, n, &mut found));
                self.gather_noted(lookup, own.p, &found);
            }
        }
        self.screen_all(&own, &mut best);
        self.test_candidates(&own, eligible, &mut best);
        best.event
    }

    /// Body `p`, which steps into the cell `into` by `crossing` at `now`: its earliest
    /// contact with the bodies of the cells it came within reach of, or `best` when none is
    /// earlier. (A contact with them cannot be at `now` itself: touching bodies are always in
    /// neighbouring cells.)
    #[inline]
    pub(super) fn after_crossing(
        &mut self,
        p: usize,
        (into, crossing): (([u16; 3], u32), Crossing),
        now: f64,
        best: Option<Event>,
    ) -> Option<Event> {
        let (own, cells) = (self.own(p, now), self.cells);
        let mut best = Best::new(best, now);
        if cells.entered_face(into.0, crossing) {
            self.offer_own(p, now, Eligible::From(now), &mut best);
        }
        self.candidates.clear();
        self.near.cells = 0;
        let lookup = cells.lookup();
        match cells.cells_ahead(into, crossing) {
            Some(ahead) => {
                // No cell across a face: one origin for all, and an empty cell costs a bit's test.
                (self.near.origins[0], self.near.shifts[0], self.near.cells) = (own.position, DVec3::ZERO, 1);
                let (mut found, mut len) = ([0; 9], 0);
                for cell in ahead {
                    (found[len], len) = (cell, len + lookup.is_occupied(cell) as usize);
                }
                self.gather_cells(lookup, own.p, found[..len].iter().map(|&cell| (cell, 0)));
            }
            None => {
                // Inline: a call per cell (about 35 instructions, the closure left out of line
                // by the nested loops) for a mostly empty cell's bit test.
                let mut found = [0; 32];
                cells.for_each_new(
                    into,
                    crossing,
                    #[inline(always)]
                    |n| self.note(lookup, &own, n, &mut found),
                );
                self.gather_noted(lookup, own.p, &found);
            }
        }
        self.screen_all(&own, &mut best);
        self.test_candidates(&own, Eligible::From(now), &mut best);
        best.event
    }

    /// Body `p`, whose list was just built anew at `now` (its motion unchanged): its earliest
    /// contact with the bodies new to its list, or `best` when none is earlier; its own events
    /// too when its cell came to a face of the box (`entered_face`). (A contact with a new member
    /// cannot be at `now` itself: the two shells were out of reach, see [`super::lists`].)
    #[inline]
    pub(super) fn after_shell_exit(
        &mut self,
        p: usize,
        now: f64,
        best: Option<Event>,
        entered_face: bool,
    ) -> Option<Event> {
        let lists = self.lists.expect("a shell exit comes with the lists");
        let own = self.own(p, now);
        let mut best = Best::new(best, now);
        if entered_face {
            self.offer_own(p, now, Eligible::From(now), &mut best);
        }
        self.candidates.clear();
        self.gather_fresh(&own, lists);
        self.screen_all(&own, &mut best);
        self.test_candidates(&own, Eligible::From(now), &mut best);
        best.event
    }

    /// Body `p`'s own events at `now`, those `eligible`: its wall contact and its crossing of a
    /// periodic face. Asked only of a body in a cell on a face of the box: a centre reaches no face
    /// before it crosses into such a cell, nor a sphere a wall (a cell is wider than a diameter).
    #[inline]
    fn offer_own(&self, p: usize, now: f64, eligible: Eligible, best: &mut Best) {
        let window = Window::new(eligible.start(), f64::INFINITY);
        let (state, stamp, gravity) = (self.state_of(p), self.stamp_of(p), self.bodies.gravity);
        // A box periodic on every axis has no walls to predict against, one with no periodic
        // axis no faces to cross (whose corners the cells keep: see `Cells::faces`). Each event
        // offered as found, the wall's first (no array of the two to walk: a tenth of the call).
        if self.bounds.periodic.contains(&false) {
            if let Some(wall) = sphere_wall_event((p as u32, stamp), state, gravity, self.bounds, window) {
                best.offer(wall, eligible, now);
            }
        }
        if let Some(faces) = self.cells.faces {
            if let Some(face) = crossing_event((p as u32, stamp), &state.motion, gravity, faces, window) {
                best.offer(face, eligible, now);
            }
        }
    }

    /// Body `i`'s motion and radius: the overlay's, or the store's.
    #[inline(always)]
    fn state_of(&self, i: usize) -> &BodyState {
        match self.overlay.len {
            0 => &self.bodies.state[i],
            _ => self.overlay.find(i).map_or(&self.bodies.state[i], |(_, _, state)| state),
        }
    }

    /// Body `i`'s stamp: the overlay's, or the store's.
    #[inline(always)]
    fn stamp_of(&self, i: usize) -> u32 {
        self.overlay.find(i).map_or(self.bodies.stamp(i), |(_, stamp, _)| *stamp)
    }

    #[inline]
    fn own(&self, p: usize, now: f64) -> Own {
        let state = self.state_of(p);
        let rounding = ROUNDINGS * f64::EPSILON * now.abs();
        Own { p, position: state.motion.at(now), velocity: state.motion.velocity, radius: state.radius, now, rounding }
    }

    /// Neighbour cell `n`, when it holds a body: its shift becomes the neighbourhood's next (with
    /// the origin `own`'s centre less it), and the cell is noted in `found` at that shift's
    /// place, its bodies to be gathered ([`Self::gather_noted`]) once every cell is noted.
    /// (Indexed as the origins are, one bounds check serves both, and no count of its own.)
    #[inline(always)]
    fn note(&mut self, lookup: Lookup, own: &Own, n: Neighbour, found: &mut [u32; 32]) {
        if !lookup.is_occupied(n.cell) {
            return;
        }
        let k = self.near.cells;
        self.near.origins[k] = own.position - n.shift;
        self.near.shifts[k] = n.shift;
        found[k] = n.cell;
        self.near.cells += 1;
    }

    /// [`Self::gather_cells`] of the cells [`Self::note`] noted, each at its shift's place.
    #[inline(always)]
    fn gather_noted(&mut self, lookup: Lookup, p: usize, found: &[u32; 32]) {
        let noted = found[..self.near.cells].iter().zip(0..);
        self.gather_cells(lookup, p, noted.map(|(&cell, k)| (cell, k)));
    }

    /// Lists the bodies (but `own`'s) of the cells `occupied`, each holding a body and given with
    /// the place of its shift among the neighbourhood's, in `self.candidates`, to be screened,
    /// asking for their records on the way: a neighbourhood's bodies are scattered in memory,
    /// and the records then arrive together rather than one after the other. A cell that is not
    /// crowded holds its head alone, whose place in the lists is then not read. A body of the
    /// overlay met this way waits aside (see [`Self::screen_all`]). The candidates' place and
    /// count stay in registers from one cell to the next, where a call per cell read and wrote
    /// them through the search (with the grid's arrays: see [`Lookup`]).
    #[inline(always)]
    fn gather_cells(&mut self, cells: Lookup, p: usize, occupied: impl IntoIterator<Item = (u32, u8)>) {
        let (states, overlaid) = (&self.bodies.state[..], self.overlay.len > 0);
        let candidates = &mut *self.candidates;
        let mut len = candidates.len;
        let mut slots = &mut candidates.slots[..];
        for (cell, k) in occupied {
            let (mut q, crowded) = cells.first_of_occupied(cell);
            while q != NONE {
                if q as usize != p {
                    if overlaid && self.overlay.find(q as usize).is_some() {
                        self.overlay.met = Some((q, k));
                    } else {
                        prefetch_item(states, q as usize);
                        let candidate = Candidate { earliest: 0.0, q, cell: k, moving: false };
                        // One comparison a body: the slot's bounds check is the room's.
                        match slots.get_mut(len) {
                            Some(slot) => *slot = candidate,
                            None => {
                                candidates.grow();
                                slots = &mut candidates.slots[..];
                                slots[len] = candidate;
                            }
                        }
                        len += 1;
                    }
                }
                q = if crowded { cells.after(q) } else { NONE };
            }
        }
        candidates.len = len;
    }

    /// Lists the members new to `own`'s list (see [`Lists::fresh`]) in `self.candidates`, to be
    /// screened as the cells' bodies are ([`Self::screen_all`], four at a time in lanes): the
    /// origin of each image they are met through is set in `self.near` on the way (the screen's
    /// offsets are then the same bits as [`Self::screen_members`]'), and their records asked for.
    #[inline(always)]
    fn gather_fresh(&mut self, own: &Own, lists: &Lists) {
        debug_assert_eq!(self.overlay.len, 0, "the parallel loop keeps no lists");
        let (states, origins, candidates) = (&self.bodies.state[..], &mut self.near.origins, &mut *self.candidates);
        for &entry in lists.members(own.p) {
            let (q, image) = lists::split(entry);
            if lists.fresh(q) {
                prefetch_item(states, q);
                origins[image] = own.position - lists.images[image];
                candidates.push(Candidate { earliest: 0.0, q: q as u32, cell: image as u8, moving: false });
            }
        }
    }

    /// Screens the members of `own`'s list as they are read: those that pass wait in
    /// `self.candidates`, each with the earliest it can touch `own` and its image (see
    /// [`Lists::images`]). One pass, nothing gathered first: a list is short and its members
    /// known, so the screen's reject, most members' fate, is all they cost.
    #[inline(always)]
    fn screen_members(&mut self, own: &Own, lists: &Lists, best: &mut Best) {
        debug_assert_eq!(self.overlay.len, 0, "the parallel loop keeps no lists");
        let (states, members) = (&self.bodies.state[..], lists.members(own.p));
        // The members' records, scattered in memory, asked for all at once: they then arrive
        // together rather than one after the other.
        for &entry in members {
            prefetch_item(states, lists::split(entry).0);
        }
        // The screen's switch and the candidates' `Vec` read once, not through the search at
        // every member (as in `gather_cells`).
        let (mut bound, screened, candidates) = (best.bound, self.screen, &mut *self.candidates);
        // Four at a time in lanes, as in `screen_all`.
        let grouped = if screened && lanes() { members.len() & !3 } else { 0 };
        if grouped > 0 {
            // What lets the lanes read the members' records unchecked (see `Listed`).
            assert!(lists.slots() <= states.len(), "the lists outnumber the bodies");
            let partners = |group| Listed { group, images: &lists.images, centre: own.position };
            let groups = members[..grouped].as_chunks().0;
            screen_fours(own, states, groups, partners, &mut bound, |group, lane, (earliest, moving)| {
                let (q, image) = lists::split(group[lane]);
                candidates.push(Candidate { earliest, q: q as u32, cell: image as u8, moving });
            });
        }
        for &entry in &members[grouped..] {
            let (q, image) = lists::split(entry);
            let (earliest, moving) = if screened {
                match screen(own, &states[q], own.position - lists.images[image], &mut bound) {
                    Some(screened) => screened,
                    None => continue,
                }
            } else {
                (f64::NEG_INFINITY, false)
            };
            candidates.push(Candidate { earliest, q: q as u32, cell: image as u8, moving });
        }
        best.bound = bound;
    }

    /// Screens the bodies gathered: those that pass stay in `self.candidates`, each with the
    /// earliest it can touch `own`.
    #[inline(always)]
    fn screen_all(&mut self, own: &Own, best: &mut Best) {
        if !self.screen {
            if let Some((q, cell)) = self.overlay.met.take() {
                self.candidates.push(Candidate { earliest: 0.0, q, cell, moving: false });
            }
            self.candidates.as_mut_slice().iter_mut().for_each(|c| c.earliest = f64::NEG_INFINITY);
            return;
        }
        let (states, origins) = (&self.bodies.state[..], &self.near.origins);
        let mut bound = best.bound;
        let mut kept = 0;
        // Through a slice: its length stays in a register, where the `Vec`'s is read again
        // after every write into it.
        let candidates = self.candidates.as_mut_slice();
        // Four at a time in lanes (see `screen_fours`), the steps that depend on the bound then
        // for the lanes left, in order: every bound and result is the scalar screen's.
        let grouped = if lanes() { candidates.len() & !3 } else { 0 };
        if grouped > 0 {
            // Read and written over through cells: `kept` is at most the place of the entry
            // kept (four a group before its own, plus its lane), so an entry is read before it
            // is written over.
            let slots = Cell::from_mut(&mut *candidates).as_slice_of_cells();
            let (partners, groups) = (|group| Gathered { group, origins }, slots[..grouped].as_chunks().0);
            screen_fours(own, states, groups, partners, &mut bound, |group, lane, (earliest, moving)| {
                slots[kept].set(Candidate { earliest, moving, ..group[lane].get() });
                kept += 1;
            });
        }
        for k in grouped..candidates.len() {
            let c = candidates[k];
            if let Some((earliest, moving)) =
                screen(own, &states[c.q as usize], origins[c.cell as usize & 31], &mut bound)
            {
                candidates[kept] = Candidate { earliest, moving, ..c };
                kept += 1;
            }
        }
        self.candidates.len = kept;
        // The overlay's body met among the neighbours, by its own motion.
        if let Some((q, k)) = self.overlay.met.take() {
            let state = self.state_of(q as usize);
            if let Some((earliest, moving)) = screen(own, state, origins[k as usize & 31], &mut bound) {
                self.candidates.push(Candidate { earliest, q, cell: k, moving });
            }
        }
        best.bound = bound;
    }

    /// The candidates' exact tests, earliest first, until the next cannot come before the best.
    /// Each is the earliest of those left, found by a pass over them and then taken out of the
    /// buffer: a search keeps a few candidates and tests one or two, for which a pass each costs
    /// less than a sort of them all. (Among candidates equally early, which is tested first
    /// changes nothing: each bounds its contact from below, so once one is tested the others
    /// still come no later than the best, and are tested too.)
    #[inline(always)]
    fn test_candidates(&mut self, own: &Own, eligible: Eligible, best: &mut Best) {
        // Most searches of the thin gas keep none (a crossing's new cells are mostly empty): no
        // call then, where the call's entry and exit were about 25 instructions.
        if self.candidates.len > 0 {
            self.test_kept(own, eligible, best);
        }
    }

    /// [`Self::test_candidates`] of a search that kept some.
    #[inline]
    fn test_kept(&mut self, own: &Own, eligible: Eligible, best: &mut Best) {
        let mut left = self.candidates.len;
        while left > 0 {
            let slots = &mut self.candidates.slots[..left];
            let mut first = 0;
            for k in 1..left {
                if slots[k].earliest.total_cmp(&slots[first].earliest).is_lt() {
                    first = k;
                }
            }
            let c = slots[first];
            if c.earliest > best.horizon {
                break;
            }
            left -= 1;
            slots[first] = slots[left];
            let shift = match self.lists {
                Some(lists) => lists.images[c.cell as usize],
                None => self.near.shifts[c.cell as usize],
            };
            self.exact(own, (c.q as usize, c.moving), shift, eligible, best);
        }
        // The buffer holds the candidates left untested, no taken one twice.
        self.candidates.len = left;
    }

    /// The exact test of `own.p` and `q` (through `q`'s image shifted by `shift`), as the frame
    /// pipeline makes it (its noise rule skipped when the screen found them `moving`): their
    /// contact becomes `best` when eligible and earlier.
    #[inline]
    fn exact(&mut self, own: &Own, (q, moving): (usize, bool), shift: DVec3, eligible: Eligible, best: &mut Best) {
        self.tests += 1;
        let p = own.p;
        // The lower id's own motion against the higher id's, shifted next to it.
        let (low, high, image_shift) = if p < q { (p, q, shift) } else { (q, p, DVec3::ZERO - shift) };
        let (low_state, high_state) = (self.state_of(low), self.state_of(high));
        let mut image = *high_state;
        if image_shift != DVec3::ZERO {
            image.motion.position += image_shift;
        }
        let window = Window::new(eligible.start(), f64::INFINITY);
        // Moving spheres without gravity (the loop takes no other world), screened: the lean
        // form of `contacts::pair_start`, the same bits.
        debug_assert!(self.bodies.are_spheres(low, high) && self.bodies.straight_paths());
        let Some((time, _)) = contacts::screened_spheres_start(low_state, &image, window, moving) else {
            return;
        };
        let stamps = (self.stamp_of(low), self.stamp_of(high));
        let event = Event {
            time,
            body: low as u32,
            partner: Partner::Body(high as u32),
            body_stamp: stamps.0,
            partner_stamp: stamps.1,
        };
        best.offer(event, eligible, own.now);
    }
}

/// Four gathered partners (candidates in a row), each with the origin of its cell.
struct Gathered<'a> {
    group: &'a [Cell<Candidate>; 4],
    origins: &'a [DVec3; 32],
}

impl Partners for Gathered<'_> {
    #[inline(always)]
    fn body(&self, lane: usize) -> usize {
        self.group[lane].get().q as usize
    }

    #[inline(always)]
    fn origin(&self, lane: usize) -> DVec3 {
        self.origins[self.group[lane].get().cell as usize & 31]
    }

    #[inline(always)]
    fn shared_origin(&self) -> Option<DVec3> {
        let cell = self.group[0].get().cell;
        self.group[1..].iter().all(|c| c.get().cell == cell).then(|| self.origins[cell as usize & 31])
    }
}

/// Four members of a list in a row (see [`lists::split`]), each with the origin of its image:
/// `centre`, the searching body's, less the image's sides (as the scalar screen takes it).
///
/// Built only of a list of lists no more than the bodies (see [`Lists::slots`]; asserted once a
/// search, in [`Search::screen_members`]; the lanes' test's, of its four bodies), and screened
/// against those bodies' records: its
/// records are read unchecked, four bounds checks a group saved.
struct Listed<'a> {
    group: &'a [u32; 4],
    images: &'a [DVec3; 27],
    centre: DVec3,
}

impl Partners for Listed<'_> {
    #[inline(always)]
    fn body(&self, lane: usize) -> usize {
        lists::split(self.group[lane]).0
    }

    #[inline(always)]
    fn state<'s>(&self, states: &'s [BodyState], lane: usize) -> &'s BodyState {
        let q = self.body(lane);
        debug_assert!(q < states.len(), "a member past the bodies");
        // SAFETY: a list's member is below `Lists::slots`, which is no more than the bodies
        // `states` holds (see `Listed`).
        unsafe { states.get_unchecked(q) }
    }

    #[inline(always)]
    fn origin(&self, lane: usize) -> DVec3 {
        self.centre - self.images[lists::split(self.group[lane]).1]
    }

    #[inline(always)]
    fn shared_origin(&self) -> Option<DVec3> {
        // The entries' image bits alike: one image, one origin.
        let [first, second, third, fourth] = *self.group;
        let differ = (first ^ second) | (first ^ third) | (first ^ fourth);
        (differ >> lists::IMAGE_BITS == 0).then(|| self.origin(0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::event_loop::screen::screen_four;
    use crate::motion::Motion;
    use rand::{Rng, SeedableRng};

    /// A random float of every kind the screen may meet: ordinary, tiny, huge, zero of either
    /// sign, or (rarely) not finite.
    fn float(rng: &mut impl Rng, scale: f64) -> f64 {
        match rng.random_range(0..40) {
            0 => 0.0,
            1 => -0.0,
            2 => f64::NAN,
            3 => f64::INFINITY,
            4 => scale * 1e-300,
            _ => scale * rng.random_range(-1.0..1.0),
        }
    }

    /// The lanes' answers (for gathered partners and for a list's members), taken in order with
    /// the bound as the scalar screen leaves it, are the scalar screen's to the bit: every answer and every bound, for random partners near and
    /// far, approaching and parting, touching, grazing (their paths' closest approach within a
    /// hair of the reach), and with NaN, infinities, zeros of either sign and tiny numbers.
    #[test]
    fn the_screen_in_lanes_answers_as_the_scalar_screen() {
        if !lanes() {
            return;
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27);
        // How often the scalar screen rejected, had no bound, bounded, and lowered the bound.
        let mut met = [0; 4];
        for round in 0..100_000 {
            let now = rng.random_range(0.0..10.0);
            let own = {
                let (position, velocity) = (
                    DVec3::from_array([(); 3].map(|_| float(&mut rng, 3.0))),
                    DVec3::from_array([(); 3].map(|_| float(&mut rng, 1.0))),
                );
                Own { p: 0, position, velocity, radius: 0.5, now, rounding: ROUNDINGS * f64::EPSILON * now }
            };
            let partner = |rng: &mut rand_chacha::ChaCha8Rng| {
                let since = now - rng.random_range(0.0..1.0);
                let velocity = DVec3::from_array([(); 3].map(|_| float(rng, 1.0)));
                let position = match rng.random_range(0..4) {
                    // Grazing: its closest approach to `own` a hair from the reach.
                    0 => {
                        let relative = velocity - own.velocity;
                        let side = relative.any_orthonormal_vector() * (1.0 + rng.random_range(-1e-9..1e-9));
                        own.position + side - relative * rng.random_range(0.0..2.0) - velocity * (now - since)
                    }
                    _ => own.position + DVec3::from_array([(); 3].map(|_| float(rng, 3.0))) - velocity * (now - since),
                };
                BodyState { motion: Motion { position, since, velocity }, radius: 0.5 }
            };
            let states: [BodyState; 4] = std::array::from_fn(|_| partner(&mut rng));
            // Each lane through an image of its own (as a list's members are met), its origin
            // `own`'s centre less that image's sides (as both searches take it).
            let images: [DVec3; 27] = std::array::from_fn(|_| DVec3::X * rng.random_range(-1..=1) as f64);
            // Every third round the four through one image (one cell), as most groups are.
            let shared = round % 3 == 0;
            let image_of: [u32; 4] = match shared {
                true => [rng.random_range(0..27); 4],
                false => std::array::from_fn(|_| rng.random_range(0..27)),
            };
            let mut origins = [DVec3::ZERO; 32];
            for (origin, &image) in origins.iter_mut().zip(&image_of) {
                *origin = own.position - images[image as usize];
            }
            let group: [Candidate; 4] = std::array::from_fn(|k| Candidate {
                earliest: 0.0,
                q: k as u32,
                cell: if shared { 0 } else { k as u8 },
                moving: false,
            });
            let members: [u32; 4] = std::array::from_fn(|k| k as u32 | image_of[k] << lists::IMAGE_BITS);
            let start = match round % 4 {
                0 => f64::INFINITY,
                _ => rng.random_range(0.0..3.0),
            };
            let mut scalar_bound = start;
            let fours = [
                screen_four(&own, &states, &Gathered { group: &group.map(Cell::new), origins: &origins }, start),
                screen_four(&own, &states, &Listed { group: &members, images: &images, centre: own.position }, start),
            ];
            let mut lanes_bounds = [start; 2];
            for lane in 0..4 {
                let before = scalar_bound;
                let scalar = screen(&own, &states[lane], origins[lane], &mut scalar_bound);
                met[match scalar {
                    None => 0,
                    Some((f64::NEG_INFINITY, _)) => 1,
                    Some(_) if scalar_bound == before => 2,
                    Some(_) => 3,
                }] += 1;
                for (four, lanes_bound) in fours.iter().zip(&mut lanes_bounds) {
                    let in_lanes = if four.left & (1 << lane) != 0 { four.lane(lane, &own, lanes_bound) } else { None };
                    assert_eq!(
                        (scalar.map(|(t, moving)| (t.to_bits(), moving)), scalar_bound.to_bits()),
                        (in_lanes.map(|(t, moving)| (t.to_bits(), moving)), lanes_bound.to_bits()),
                        "round {round}, lane {lane}"
                    );
                }
            }
        }
        assert!(met.iter().all(|&n| n > 100), "every outcome met: {met:?}");
    }
}
