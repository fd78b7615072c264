//! The event calendar: one scheduled event per body, the earliest first, at O(1) cost per event.
//!
//! It owns Paul's scheme (J. Comput. Phys. 1975; the calendar of most event-driven MD codes):
//! time is cut into buckets of a fixed width; the bucket being worked through is a small binary
//! list, sorted; the buckets after it, a ring of them, are unsorted lists, each poured into the
//! sorted list (and sorted) when its turn comes; events past the ring wait in an overflow list, sorted into the ring
//! each time it turns. A body's event is replaced by scheduling it anew: the old entry stays where
//! it is and is dropped when it surfaces (each body carries a version, bumped at every
//! scheduling). The order is total and the one the frame pipeline's event queue keeps: earlier
//! first, then (for contacts, walls and periodic crossings) the queue's own rule, so ties between
//! simultaneous events fall as they fall there; a body's crossing into another cell, which
//! changes nothing but the cell lists, comes before any contact at the same instant. It also
//! keeps each body's next events, the two the loop predicts (its earliest contact, wall contact or
//! periodic crossing, and its next cell crossing), of which the earlier is the one scheduled, in
//! one cache line with the body's version: the loop reads and writes them through it. It never
//! predicts or handles an event.

use super::cells::Crossing;
use crate::event_queue::{Event, Partner};
use std::cmp::Ordering;

/// Events a bucket holds on average when the width is tuned: the sorted list stays short, and the
/// pouring costs little per event. Measured with callgrind on the periodic gas at n = 2e4
/// (instructions of the event loop per pair collision at packings 0.05, 0.2 and 0.4): 18.5 k,
/// 11.8 k and 10.1 k with 24; 17.5 k, 11.4 k and 9.9 k with 6; 17.4 k, 11.3 k and 9.8 k with 3,
/// 17.8 k, 11.4 k and 9.8 k with 1.5 (and 10.0 k at 0.4 with 12, 10.2 k with 48): the sort of a
/// bucket poured, about 270 instructions an event with 24, shrinks faster than the pours and the
/// overflow's turns grow. 6 rather than 3: the last step gained about 1 %, for twice the pours.
const EVENTS_PER_BUCKET: f64 = 6.0;
/// Buckets in the ring per body (rounded up to a power of two): with 6 events a bucket the ring
/// spans about as many events as there are bodies, and later ones wait in the overflow list. (A
/// ring four times as long measured 0.4 % to 0.8 % more instructions, as above.)
const BUCKETS_PER_BODY: f64 = 0.125;

/// A body's scheduled event: a predicted contact, wall contact or periodic crossing (`event`),
/// or the crossing of its centre into another cell at `event.time`, told by its partner,
/// [`Partner::Renew`], which the loop never predicts: no flag of its own, so a calendar entry
/// takes 40 bytes, not 48, in the sorted list a bucket's sort and insertions move.
#[derive(Debug, Clone, Copy)]
pub(super) struct Scheduled {
    pub event: Event,
}

impl Scheduled {
    /// The instant it happens.
    #[inline]
    pub(super) fn time(&self) -> f64 {
        self.event.time
    }

    /// True when it is the body's cell crossing, not a predicted event.
    #[inline]
    pub(super) fn cell_crossing(&self) -> bool {
        self.event.partner == Partner::Renew
    }
}

/// An entry of the sorted list: the event, whose body scheduled it, and that body's version then.
#[derive(Debug, Clone, Copy)]
pub(super) struct Entry {
    pub scheduled: Scheduled,
    pub owner: u32,
    pub version: u32,
}

impl Entry {
    /// True when `self` comes before `other` in the calendar's order.
    #[inline]
    pub(super) fn precedes(&self, other: &Entry) -> bool {
        self.order(other) == Ordering::Less
    }

    /// `Less` when `self` comes first.
    #[inline(always)]
    fn order(&self, other: &Entry) -> Ordering {
        // Two plain comparisons settle times that differ, most pairs a bucket's sort compares,
        // inline in the sort's loop; `total_cmp` (its order, which they agree with) decides the
        // rest out of line: equal times, signed zeros and NaN.
        let (s, t) = (self.scheduled.event.time, other.scheduled.event.time);
        if s < t {
            return Ordering::Less;
        }
        if s > t {
            return Ordering::Greater;
        }
        self.order_at_tie(other)
    }

    /// [`Self::order`] of two entries whose times compare neither less nor greater.
    #[inline(never)]
    fn order_at_tie(&self, other: &Entry) -> Ordering {
        let (a, b) = (&self.scheduled, &other.scheduled);
        let (s, t) = (a.event.time, b.event.time);
        s.total_cmp(&t).then_with(|| {
            // Cell crossings first, then the event queue's order (its `Ord` puts the earlier
            // event last), then the owner: two owners may hold one contact.
            let crossings = (a.cell_crossing(), b.cell_crossing());
            crossings
                .1
                .cmp(&crossings.0)
                .then_with(|| if crossings.0 { Ordering::Equal } else { b.event.cmp(&a.event) })
                .then_with(|| self.owner.cmp(&other.owner))
        })
    }
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.order(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    // Reversed: a list sorted ascending ends with the earliest.
    fn cmp(&self, other: &Self) -> Ordering {
        other.order(self)
    }
}

/// A body's next events: the earlier is its scheduled event (see [`Events::scheduled`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Events {
    /// Its earliest eligible contact, wall contact or periodic crossing.
    pub next: Option<Event>,
    /// When its centre next leaves its cell, or with lists its shell (the time alone).
    pub crossing: Crossing,
}

impl Events {
    pub(super) const NONE: Events = Events { next: None, crossing: Crossing::NEVER };

    /// Body `owner`'s scheduled event: its earliest contact (or wall contact, or periodic
    /// crossing) or its next cell crossing, whichever comes first (the crossing at a tie).
    #[inline]
    fn scheduled(&self, owner: u32) -> Scheduled {
        match self.next {
            Some(event) if event.time < self.crossing.time => {
                debug_assert!(event.partner != Partner::Renew, "the loop predicts no renewal");
                Scheduled { event }
            }
            _ => {
                let event = Event {
                    time: self.crossing.time,
                    body: owner,
                    partner: Partner::Renew,
                    body_stamp: 0,
                    partner_stamp: 0,
                };
                Scheduled { event }
            }
        }
    }
}

/// Events a bucket of the ring holds in place; more go to its spill list. Buckets hold 6 on
/// average ([`EVENTS_PER_BUCKET`]), so a spill is rare.
const SLOTS_PER_BUCKET: usize = 16;

/// A bucket's entry: only what finds the body's event again. No time: a bucket poured reads its
/// bodies' events (their times among them) for the version check anyway, so 8 bytes an entry,
/// and the ring takes half the memory it took with the time (2 MiB at n = 1e5, not 4).
#[derive(Debug, Clone, Copy)]
struct Slot {
    owner: u32,
    version: u32,
}

/// An event past the ring: its time too, to find its bucket when the ring turns.
#[derive(Debug, Clone, Copy)]
struct Later {
    time: f64,
    slot: Slot,
}

/// A bucket's entries in place, aligned to a cache line: the first 8 (a bucket holds 6 on
/// average) lie in one line, where a large `Vec` of entries starts 16 bytes past a line.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Bucket {
    slots: [Slot; SLOTS_PER_BUCKET],
}

/// A body's next events and the version they were scheduled under, in one cache line: a bucket
/// poured reads the version and the event of each of its bodies, scattered in memory, and the
/// event handled then reads its body's events again (and schedules them anew), so the line it
/// missed on once serves all three.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
struct Booked {
    events: Events,
    version: u32,
}

impl Booked {
    const NONE: Booked = Booked { events: Events::NONE, version: 0 };
}

/// The ring's buckets, flat: bucket `b` holds its first [`SLOTS_PER_BUCKET`] events in
/// `buckets[b]` and the rest in `spill[b]`. A push then reads only the
/// bucket's count (4 bytes a bucket) before its write, where a list per bucket read its 24-byte
/// header (393 kB at n = 1e5, beside the rest of the loop's records in the caches).
#[derive(Debug, Default)]
struct Ring {
    buckets: Vec<Bucket>,
    /// Per bucket: the events it holds, in place and spilled.
    filled: Vec<u32>,
    spill: Vec<Vec<Slot>>,
}

impl Ring {
    /// Empties it, with `buckets` buckets.
    fn reset(&mut self, buckets: usize) {
        self.buckets.resize(buckets, Bucket { slots: [Slot { owner: 0, version: 0 }; SLOTS_PER_BUCKET] });
        self.filled.clear();
        self.filled.resize(buckets, 0);
        self.spill.resize_with(buckets, Vec::new);
        self.spill.iter_mut().for_each(Vec::clear);
    }

    fn len(&self) -> usize {
        self.filled.len()
    }

    /// The ring's bucket that holds the calendar's bucket `k`: `k` modulo the ring's length, a
    /// power of two, by a mask (the same for a negative `k`, as `rem_euclid`), not a division.
    #[inline]
    fn of(&self, k: i64) -> usize {
        debug_assert!(self.len().is_power_of_two());
        (k & (self.len() as i64 - 1)) as usize
    }

    #[inline]
    fn push(&mut self, bucket: usize, slot: Slot) {
        let filled = self.filled[bucket] as usize;
        if filled < SLOTS_PER_BUCKET {
            self.buckets[bucket].slots[filled] = slot;
        } else {
            self.spill[bucket].push(slot);
        }
        self.filled[bucket] += 1;
    }

    /// Bucket `bucket`'s events, in place and spilled.
    fn bucket(&self, bucket: usize) -> (&[Slot], &[Slot]) {
        let filled = (self.filled[bucket] as usize).min(SLOTS_PER_BUCKET);
        let spilled = if filled == SLOTS_PER_BUCKET { &self.spill[bucket][..] } else { &[] };
        (&self.buckets[bucket].slots[..filled], spilled)
    }

    /// Empties bucket `bucket`; returns how many events it held.
    fn clear(&mut self, bucket: usize) -> usize {
        let filled = std::mem::take(&mut self.filled[bucket]) as usize;
        if filled > SLOTS_PER_BUCKET {
            self.spill[bucket].clear();
        }
        filled
    }

    /// Bytes held.
    fn memory_bytes(&self) -> usize {
        self.buckets.capacity() * std::mem::size_of::<Bucket>()
            + self.spill.iter().map(Vec::capacity).sum::<usize>() * std::mem::size_of::<Slot>()
            + self.filled.capacity() * 4
            + self.spill.capacity() * std::mem::size_of::<Vec<Slot>>()
    }
}

/// One scheduled event per body, earliest first.
#[derive(Debug, Default)]
pub(super) struct Calendar {
    /// Per body: its next events and the version they were scheduled under.
    booked: Vec<Booked>,
    /// The instant bucket 0 starts at, and the buckets' width (as its inverse).
    origin: f64,
    inverse_width: f64,
    /// The bucket whose events are in `near`, sorted latest first (popped from the end): most
    /// come in all at once when the bucket's turn comes, and one sort then costs less than as
    /// many heap pushes and pops; an event due in this bucket already is inserted in its place.
    current: i64,
    near: Vec<Entry>,
    /// Bucket `k` (for `current < k < current + ring.len()`) at `ring[k % ring.len()]`.
    ring: Ring,
    in_ring: usize,
    overflow: Vec<Later>,
    /// Since the last tuning: events popped, buckets poured.
    popped: u64,
    poured: u64,
}

impl Calendar {
    /// Empties the calendar for `bodies` slots from `now` on, with buckets tuned to events `gap`
    /// apart on average in the whole calendar.
    pub(super) fn reset(&mut self, bodies: usize, now: f64, gap: f64) {
        let buckets = ((bodies as f64 * BUCKETS_PER_BODY) as usize).next_power_of_two().max(64);
        self.ring.reset(buckets);
        self.in_ring = 0;
        self.overflow.clear();
        self.near.clear();
        let width = (gap * EVENTS_PER_BUCKET).max(f64::MIN_POSITIVE);
        self.inverse_width = 1.0 / width;
        if !self.inverse_width.is_finite() {
            self.inverse_width = f64::MAX;
        }
        self.origin = now;
        self.current = 0;
        self.booked.iter_mut().for_each(|b| b.version = b.version.wrapping_add(1));
        (self.popped, self.poured) = (0, 0);
    }

    /// True when the buckets hold far more or far fewer events than they were tuned for: the
    /// event rate changed, and the calendar should be reset with a new width.
    pub(super) fn needs_tuning(&self) -> bool {
        self.poured >= 1024 && {
            let per_bucket = self.popped as f64 / self.poured as f64;
            !(EVENTS_PER_BUCKET / 8.0..=EVENTS_PER_BUCKET * 8.0).contains(&per_bucket)
        }
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.booked.capacity() * std::mem::size_of::<Booked>()
            + self.near.capacity() * std::mem::size_of::<Entry>()
            + self.overflow.capacity() * std::mem::size_of::<Later>()
            + self.ring.memory_bytes()
    }

    #[inline]
    fn bucket(&self, time: f64) -> i64 {
        // Monotone in time (a subtraction and a product by a positive number, each rounded
        // correctly), so every event of a bucket comes before every event of a later one.
        // Rounded down by hand: `floor` is a library call where the target lacks SSE4.1.
        let x = (time - self.origin) * self.inverse_width;
        let k = x as i64;
        k - ((k as f64) > x) as i64
    }

    /// Room for the events of `slots` bodies (those not booked yet have none).
    pub(super) fn grow(&mut self, slots: usize) {
        if self.booked.len() < slots {
            self.booked.resize(slots, Booked::NONE);
        }
    }

    /// Body `owner`'s next events, as last booked.
    #[inline]
    pub(super) fn events(&self, owner: usize) -> &Events {
        &self.booked[owner].events
    }

    /// Every body's next events dropped: none is scheduled until booked again.
    pub(super) fn clear(&mut self) {
        for booked in &mut self.booked {
            *booked = Booked { events: Events::NONE, version: booked.version.wrapping_add(1) };
        }
    }

    /// Books `events` as body `owner`'s without scheduling them: every body's events booked so
    /// are scheduled by the next [`Self::retune`] (a grid built anew books them all, then retunes).
    pub(super) fn book(&mut self, owner: u32, events: Events) {
        let booked = &mut self.booked[owner as usize];
        *booked = Booked { events, version: booked.version.wrapping_add(1) };
    }

    /// Resets the calendar with buckets sized for the events now booked, and schedules them,
    /// from `now` on.
    pub(super) fn retune(&mut self, now: f64) {
        let (mut sum, mut count) = (0.0, 0usize);
        for (i, booked) in self.booked.iter().enumerate() {
            let time = booked.events.scheduled(i as u32).time();
            if time.is_finite() {
                (sum, count) = (sum + (time - now).max(0.0), count + 1);
            }
        }
        // A body's events come about `sum / count` apart: the world's, that over `count`.
        let gap = if count > 0 { sum / (count * count) as f64 } else { 1.0 };
        self.reset(self.booked.len(), now, if gap > 0.0 { gap } else { 1.0 });
        for i in 0..self.booked.len() {
            self.schedule(i as u32, self.booked[i].events);
        }
    }

    /// Schedules `events` as body `owner`'s next events, replacing those it had: the earlier of
    /// them is its scheduled event.
    #[inline]
    pub(super) fn schedule(&mut self, owner: u32, events: Events) {
        let i = owner as usize;
        let version = self.booked[i].version.wrapping_add(1);
        self.booked[i] = Booked { events, version };
        let scheduled = events.scheduled(owner);
        let time = scheduled.time();
        if !time.is_finite() {
            return;
        }
        let slot = Slot { owner, version };
        let k = self.bucket(time);
        if k <= self.current {
            self.insert_near(Entry { scheduled, owner, version });
        } else if k < self.current + self.ring.len() as i64 {
            self.ring.push(self.ring.of(k), slot);
            self.in_ring += 1;
        } else {
            self.overflow.push(Later { time, slot });
        }
    }

    /// Body `owner` has no event any more (it was removed).
    pub(super) fn cancel(&mut self, owner: u32) {
        if let Some(booked) = self.booked.get_mut(owner as usize) {
            *booked = Booked { events: Events::NONE, version: booked.version.wrapping_add(1) };
        }
    }

    /// True when `entry` is still its body's scheduled event.
    #[inline]
    pub(super) fn is_current_entry(&self, entry: &Entry) -> bool {
        self.is_current(entry.owner, entry.version)
    }

    #[inline]
    fn is_current(&self, owner: u32, version: u32) -> bool {
        self.booked[owner as usize].version == version
    }

    /// The earliest scheduled event as an entry, dropping entries replaced since.
    #[inline]
    pub(super) fn peek_entry(&mut self) -> Option<Entry> {
        self.peek()?;
        self.near.last().copied()
    }

    /// The earliest scheduled event and its body, dropping entries replaced since.
    #[inline]
    pub(super) fn peek(&mut self) -> Option<(u32, Scheduled)> {
        loop {
            match self.near.last() {
                Some(top) if self.is_current(top.owner, top.version) => return Some((top.owner, top.scheduled)),
                Some(_) => {
                    self.near.pop();
                }
                None => {
                    if !self.pour_next() {
                        return None;
                    }
                }
            }
        }
    }

    /// The entry `ahead` places after the earliest in the sorted list, if any: likely the event
    /// `ahead` after the next (it may have been replaced since), whose records can be asked for
    /// ahead of its turn.
    #[inline]
    pub(super) fn following(&self, ahead: usize) -> Option<&Entry> {
        self.near.len().checked_sub(1 + ahead).map(|k| &self.near[k])
    }

    /// Asks for body `owner`'s events ahead of their use (see [`crate::memory::prefetch`]).
    #[inline]
    pub(super) fn prefetch(&self, owner: usize) {
        if let Some(booked) = self.booked.get(owner) {
            crate::memory::prefetch(booked);
        }
    }

    /// Removes the event [`Self::peek`] returned.
    #[inline]
    pub(super) fn pop(&mut self) {
        self.near.pop();
        self.popped += 1;
    }

    /// Moves on to the next bucket holding anything and pours it into the sorted list; false when
    /// nothing is scheduled.
    fn pour_next(&mut self) -> bool {
        let ring = self.ring.len() as i64;
        loop {
            if self.in_ring == 0 {
                // Nothing in the ring: skip to the ring's turn that reaches the earliest of
                // the overflow (never backwards).
                let Some(first) = self
                    .overflow
                    .iter()
                    .filter(|later| self.is_current(later.slot.owner, later.slot.version))
                    .map(|later| later.time)
                    .reduce(f64::min)
                else {
                    self.overflow.clear();
                    return false;
                };
                let turn = self.bucket(first).div_euclid(ring) * ring - 1;
                let next_turn = (self.current.div_euclid(ring) + 1) * ring - 1;
                self.current = if turn > self.current { turn } else { next_turn };
            }
            self.current += 1;
            let bucket = self.ring.of(self.current);
            if bucket == 0 {
                self.sort_overflow();
            }
            let (in_place, spilled) = self.ring.bucket(bucket);
            for slot in in_place.iter().chain(spilled) {
                if self.is_current(slot.owner, slot.version) {
                    let scheduled = self.booked[slot.owner as usize].events.scheduled(slot.owner);
                    self.near.push(Entry { scheduled, owner: slot.owner, version: slot.version });
                }
            }
            self.in_ring -= self.ring.clear(bucket);
            self.poured += 1;
            // Ascending in `Ord`, which puts earlier events after later ones.
            self.near.sort_unstable();
            if !self.near.is_empty() {
                return true;
            }
        }
    }

    /// The ring turned: the overflow's events within its reach go into their buckets.
    fn sort_overflow(&mut self) {
        let ring = self.ring.len() as i64;
        let mut overflow = std::mem::take(&mut self.overflow);
        let mut kept = 0;
        for k in 0..overflow.len() {
            let Later { time, slot } = overflow[k];
            if !self.is_current(slot.owner, slot.version) {
                continue;
            }
            let bucket = self.bucket(time);
            if bucket <= self.current {
                let scheduled = self.booked[slot.owner as usize].events.scheduled(slot.owner);
                self.insert_near(Entry { scheduled, owner: slot.owner, version: slot.version });
            } else if bucket < self.current + ring {
                self.ring.push(self.ring.of(bucket), slot);
                self.in_ring += 1;
            } else {
                overflow[kept] = overflow[k];
                kept += 1;
            }
        }
        overflow.truncate(kept);
        self.overflow = overflow;
    }

    /// Puts `entry`, due in the current bucket, in its place among the others.
    #[inline]
    fn insert_near(&mut self, entry: Entry) {
        let at = self.near.partition_point(|e| e < &entry);
        self.near.insert(at, entry);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::walls::Wall;
    use rand::{Rng, SeedableRng};

    /// A wall contact of `body` at `time` (a renewal would be a cell crossing).
    fn at(time: f64, body: u32) -> Events {
        let event = Event { time, body, partner: Partner::Wall(Wall::MinX), body_stamp: 0, partner_stamp: 0 };
        Events { next: Some(event), crossing: Crossing::NEVER }
    }

    /// Against a sorted list: random schedules and reschedules pop in order, each body's last
    /// event once, whatever the bucket width.
    #[test]
    fn pops_every_body_s_last_event_in_time_order() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for gap in [1e-4, 0.01, 1.0, 100.0] {
            let mut calendar = Calendar::default();
            calendar.grow(500);
            calendar.reset(500, 0.0, gap);
            let mut last = vec![f64::INFINITY; 500];
            let mut now = 0.0;
            let mut popped = Vec::new();
            for round in 0..20_000 {
                let owner = rng.random_range(0..500u32);
                let time = now + rng.random_range(0.0..10.0f64).powi(3);
                calendar.schedule(owner, at(time, owner));
                last[owner as usize] = time;
                if round % 3 == 0 {
                    if let Some((owner, s)) = calendar.peek() {
                        assert_eq!(s.time(), last[owner as usize]);
                        assert!(s.time() >= now);
                        now = s.time();
                        calendar.pop();
                        last[owner as usize] = f64::INFINITY;
                        popped.push(now);
                    }
                }
            }
            while let Some((owner, s)) = calendar.peek() {
                assert_eq!(s.time(), last[owner as usize]);
                assert!(s.time() >= now);
                now = s.time();
                calendar.pop();
                last[owner as usize] = f64::INFINITY;
            }
            assert!(last.iter().all(|t| t.is_infinite()), "gap {gap}: an event was lost");
            assert!(popped.len() > 1000);
        }
    }

    #[test]
    fn simultaneous_events_pop_in_the_event_queue_s_order_cell_crossings_first() {
        let mut calendar = Calendar::default();
        calendar.grow(8);
        calendar.reset(8, 0.0, 1.0);
        calendar.schedule(5, at(2.0, 5));
        calendar.schedule(2, at(2.0, 2));
        calendar.schedule(7, Events { next: None, crossing: Crossing { time: 2.0, ..Crossing::NEVER } });
        calendar.schedule(1, at(3.0, 1));
        let mut order = Vec::new();
        while let Some((owner, _)) = calendar.peek() {
            calendar.pop();
            order.push(owner);
        }
        assert_eq!(order, [7, 2, 5, 1]);
    }
}
