//! Time-ordered queue of predicted contacts, with lazy invalidation.
//!
//! It owns the min-heap and the rule that makes its order total and deterministic: earlier time
//! first, then the lower body id, then the partner (contacts with bodies, then ends of contacts,
//! then stalled searches, then walls and stalled wall searches, then crossings of periodic faces, then renewals, lower ids first;
//! see `Partner::key`). Events
//! carry the velocity stamps their bodies had when they were predicted; an event whose stamps no
//! longer match is void and is dropped when it reaches the top, so invalidating a body's contacts
//! costs O(1). A prediction made twice (a pair found through two pieces of a path, or re-tested
//! by both bodies of a collision) yields two identical events, which pop one after the other:
//! the repeat is dropped, so no contact is ever reported twice. It never computes contacts or
//! changes bodies.

use crate::bodies::Bodies;
use crate::parallel::Workers;
use crate::walls::Wall;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// What a body meets in a predicted event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Partner {
    /// Another body, by id (always greater than the event's first body).
    Body(u32),
    /// The end of the body's contact with another body (detect mode, when contact ends are
    /// reported): the two part.
    End(u32),
    /// The search for a contact with another body (or its end) could not decide before this
    /// time: the two are resting or sliding a hair apart while turning.
    Stalled(u32),
    /// A wall of the box.
    Wall(Wall),
    /// The search for the body's wall contact could not decide before this time.
    WallStalled,
    /// No contact: the body's centre reaches this periodic face of the box, and the body comes
    /// back through the opposite face.
    Cross(Wall),
    /// No contact: the body's proxy ends here and must be renewed (see [`crate::broad_phase::proxy`]).
    Renew,
}

impl Partner {
    /// Sort key: bodies, then contact ends, then stalled searches, then walls (and a stalled wall
    /// search), then crossings of periodic faces, lower ids first, renewals last (every
    /// contact at the same instant is handled with the proxy it was predicted from, and a contact
    /// that ends as the body bounces ends before the bounce).
    fn key(self) -> u64 {
        match self {
            Partner::Body(id) => id as u64,
            Partner::End(id) => (1u64 << 32) + id as u64,
            Partner::Stalled(id) => (2u64 << 32) + id as u64,
            Partner::Wall(wall) => (3u64 << 32) + wall as u64,
            Partner::WallStalled => 4u64 << 32,
            Partner::Cross(face) => (5u64 << 32) + face as u64,
            Partner::Renew => u64::MAX,
        }
    }
}

/// A predicted contact.
#[derive(Debug, Clone, Copy)]
pub struct Event {
    /// Absolute simulation time of the contact.
    pub time: f64,
    /// First body (the lower id of a pair).
    pub body: u32,
    /// What it touches.
    pub partner: Partner,
    /// Velocity stamp of `body` when predicted.
    pub body_stamp: u32,
    /// Velocity stamp of the partner body when predicted (0 for walls).
    pub partner_stamp: u32,
}

impl Event {
    /// True when the bodies of this event still have the motions it was predicted from.
    #[inline]
    pub fn is_current(&self, bodies: &Bodies) -> bool {
        bodies.has_stamp(self.body as usize, self.body_stamp)
            && match self.partner {
                Partner::Body(j) | Partner::End(j) | Partner::Stalled(j) => {
                    bodies.has_stamp(j as usize, self.partner_stamp)
                }
                Partner::Wall(_) | Partner::WallStalled | Partner::Cross(_) | Partner::Renew => true,
            }
    }

    #[inline]
    fn order(&self, other: &Self) -> Ordering {
        // Lazily: times almost never tie, and the rest is only worked out when they do.
        self.time.total_cmp(&other.time).then_with(|| {
            self.body
                .cmp(&other.body)
                .then_with(|| self.partner.key().cmp(&other.partner.key()))
                // Stamps last: the order is total, so repeats of one prediction are adjacent.
                .then_with(|| (self.body_stamp, self.partner_stamp).cmp(&(other.body_stamp, other.partner_stamp)))
        })
    }
}

/// Equal events predict the same contact of the same motions.
impl PartialEq for Event {
    #[inline]
    fn eq(&self, other: &Self) -> bool {
        self.order(other) == Ordering::Equal
    }
}

impl Eq for Event {}
impl PartialOrd for Event {
    #[inline]
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Event {
    // Reversed so that std's max-heap pops the earliest event. Inlined into the sorts and the
    // heap, which compare events more than anything else does.
    #[inline]
    fn cmp(&self, other: &Self) -> Ordering {
        other.order(self)
    }
}

/// Min-heap of events by time, with deterministic ties.
#[derive(Debug, Default)]
pub struct EventQueue {
    /// Events pushed one at a time.
    heap: BinaryHeap<Event>,
    /// Events predicted all at once (a window's start), sorted latest first and popped from the
    /// end: one sort is cheaper than as many heap pushes, and most never move again.
    bulk: Vec<Event>,
    /// The last event popped, to drop repeats of it.
    last: Option<Event>,
    /// Buffers of the bulk part's radix sort, reused window after window.
    radix: RadixBuffers,
}

/// Fewest events the bulk part's radix sort takes (in each half, on more than one worker); why,
/// with the other bounds of the choice, at the one place it is made: [`EventQueue::set_bulk`].
const RADIX_MIN: usize = 1024;
/// Most events more than one worker radix sorts in halves (32 MiB of them): see
/// [`EventQueue::set_bulk`].
const HALVES_MAX: usize = 1 << 20;
/// Bits of the time key sorted per radix pass: 2^11 bins fit the first-level cache.
const DIGIT_BITS: u32 = 11;
/// Bins of a radix pass.
const BINS: usize = 1 << DIGIT_BITS;

/// An event's time as an unsigned key that ascends as the bulk part does, latest first: the
/// bits `f64::total_cmp` orders by, made unsigned and reversed. The map is its own inverse (a
/// key's top bit is its time's sign), so the sort keeps each event's key in place of its time
/// while it runs, and maps it back at the end.
#[inline]
fn latest_first_key(bits: u64) -> u64 {
    bits ^ (!(((bits as i64) >> 63) as u64) >> 1)
}

/// The time whose key is `key` (the key map is its own inverse): what the sort puts back in an
/// event that held its key in place of its time.
#[inline]
fn time_of_key(key: u64) -> f64 {
    f64::from_bits(latest_first_key(key))
}

/// An event's bin in the radix pass that sorts the bits from `shift` of the key it holds.
#[inline]
fn digit(event: &Event, shift: u32) -> usize {
    ((event.time.to_bits() >> shift) as usize) & (BINS - 1)
}

/// The radix sort's reused storage: the events' second buffer (each pass moves the events
/// themselves from one buffer to the other, so a window's events are held twice during the
/// sort, as the keys and places they used to be sorted by were; on more than one worker, up to
/// `HALVES_MAX` of them only).
#[derive(Debug, Default)]
struct RadixBuffers {
    spare: Vec<Event>,
}

impl RadixBuffers {
    /// Sorts `events` ascending in `Ord` (latest first), to the same order `sort_unstable` gives
    /// (the order is total, so there is one, and every way of sorting gives it): one radix sort
    /// (see [`radix_sort`]).
    fn sort_whole(&mut self, events: &mut Vec<Event>) {
        if !self.fit_spare(events) {
            return;
        }
        if radix_sort::<true>(events, &mut self.spare) {
            std::mem::swap(events, &mut self.spare);
        }
    }

    /// [`Self::sort_whole`]'s order, on more than one worker in two stage starts, as few as
    /// sharing it can cost (each wakes a worker, and a dozen of them, one for each pass's count
    /// and move, were slower by the clock than rayon's sort, which wakes one): each half of the
    /// events radix sorted on a worker of its own, in its own half of the spare, then the sorted
    /// halves merged into the other buffer, each worker writing one half of the output from the
    /// stretches of the two halves that land there.
    fn sort_halves(&mut self, events: &mut Vec<Event>, workers: &Workers) {
        if !self.fit_spare(events) {
            return;
        }
        let half = events.len() / 2;
        let (events_a, events_b) = events.split_at_mut(half);
        let (spare_a, spare_b) = self.spare.split_at_mut(half);
        let (moved_a, moved_b) =
            workers.join(|| radix_sort::<false>(events_a, spare_a), || radix_sort::<false>(events_b, spare_b));
        // Both halves in one buffer: they end in different ones only where their times vary in
        // different numbers of digits (rare: a window's halves share their times' leading bits).
        if moved_a != moved_b {
            if moved_a {
                spare_b.copy_from_slice(events_b);
            } else {
                events_b.copy_from_slice(spare_b);
            }
        }
        let (from, to) = if moved_a { (&self.spare[..], &mut events[..]) } else { (&events[..], &mut self.spare[..]) };
        let (a, b) = from.split_at(half);
        let taken = merge_split(a, b, half);
        let (to_a, to_b) = to.split_at_mut(half);
        workers.join(|| merge(&a[..taken], &b[..half - taken], to_a), || merge(&a[taken..], &b[half - taken..], to_b));
        if !moved_a {
            std::mem::swap(events, &mut self.spare);
        }
    }

    /// Sizes the spare to `events`, exactly: it is as large as the window's events, and is kept.
    /// False when there is nothing to sort.
    fn fit_spare(&mut self, events: &[Event]) -> bool {
        let Some(&first) = events.first() else {
            return false;
        };
        self.spare.reserve_exact(events.len().saturating_sub(self.spare.len()));
        self.spare.resize(events.len(), first);
        true
    }

    fn memory_bytes(&self) -> usize {
        self.spare.capacity() * std::mem::size_of::<Event>()
    }
}

/// Sorts `events` ascending in `Ord` (latest first), the sorted events left in `events` or, when
/// it returns true, in `spare` (as long as `events`), with their times, or with their keys in
/// place of their times unless `TIMES_BACK` (for [`merge`]): a least-significant-digit radix
/// sort of the times, skipping the digits they all share (a window's times share their leading
/// bits), then each run of equal times by comparisons. A window start sorts thousands of events, and a pass
/// over them costs less than the dozen comparisons each takes otherwise. Moving the events
/// themselves, rather than (key, place) pairs followed by the permutation's cycles, spares a
/// pass over the events in an order that misses the cache.
fn radix_sort<const TIMES_BACK: bool>(events: &mut [Event], spare: &mut [Event]) -> bool {
    let n = events.len();
    assert!(spare.len() == n && u32::try_from(n).is_ok(), "a spare as long as the events, counted in u32");
    let Some(first) = events.first().map(|event| latest_first_key(event.time.to_bits())) else {
        return false;
    };
    // Each event's key in place of its time; the bits that vary, and the counts of the lowest
    // digit, which nearly always does (the bins a fixed array indexed by a masked digit: no
    // bounds checks).
    let mut bins = [0u32; BINS];
    let mut varying = 0;
    for event in events.iter_mut() {
        let key = latest_first_key(event.time.to_bits());
        event.time = f64::from_bits(key);
        varying |= key ^ first;
        bins[key as usize & (BINS - 1)] += 1;
    }
    let mut moved = false;
    for shift in (0..64).step_by(DIGIT_BITS as usize) {
        if (varying >> shift) & (BINS as u64 - 1) == 0 {
            continue;
        }
        let (from, to) = if moved { (&spare[..], &mut events[..]) } else { (&events[..], &mut spare[..]) };
        // The lowest digit's counts were taken with the keys, from the events this pass moves
        // (it is the first pass when it is made).
        if shift != 0 {
            bins.fill(0);
            for event in from {
                bins[digit(event, shift)] += 1;
            }
        }
        let mut start = 0;
        for bin in bins.iter_mut() {
            (*bin, start) = (start, start + *bin);
        }
        for event in from {
            let place = &mut bins[digit(event, shift)];
            debug_assert!((*place as usize) < to.len());
            // SAFETY: `bins[d]` starts at the number of events of `from` with a digit below `d`
            // and is raised once for each of the `count(d)` events with digit `d`, all counted
            // above from these same events (`n` of them, fitting u32 as asserted): every place
            // is below `count(0) + ... + count(d) <= n = to.len()`.
            unsafe { *to.get_unchecked_mut(*place as usize) = *event };
            *place += 1;
        }
        moved = !moved;
    }
    let sorted = if moved { spare } else { events };
    // The times back, and equal times (equal keys: the key is one-to-one) in the order of the
    // rest of the key, which is the comparisons' whether a run holds its times or its key (they
    // tie either way); equal times are rare but for repeats of one prediction.
    let mut run = 0;
    let mut run_key = sorted[0].time.to_bits();
    for k in 0..n {
        let key = sorted[k].time.to_bits();
        if TIMES_BACK {
            sorted[k].time = time_of_key(key);
        }
        if key != run_key {
            if k - run > 1 {
                sorted[run..k].sort_unstable();
            }
            (run, run_key) = (k, key);
        }
    }
    if n - run > 1 {
        sorted[run..].sort_unstable();
    }
    moved
}

/// The order of two events that hold their keys in place of their times: `Ord`'s (an event's
/// key ascends as the bulk part does, and events of one key tie on their times).
#[inline]
fn key_order(x: &Event, y: &Event) -> Ordering {
    x.time.to_bits().cmp(&y.time.to_bits()).then_with(|| x.cmp(y))
}

/// How many of the merge of the sorted `a` and `b` (keys in place of times, ascending in
/// [`key_order`], `a`'s first on a tie) first `out` events come from `a` (the rest from `b`):
/// the merge path's crossing of that diagonal, by a binary search, so each half of the output is
/// merged on its own.
fn merge_split(a: &[Event], b: &[Event], out: usize) -> usize {
    // `a[i]` is among the first `out` when it precedes or ties `b[out - 1 - i]`: true up to the
    // split and false after it, as `a` ascends and `b[out - 1 - i]` descends.
    let (mut low, mut high) = (out.saturating_sub(b.len()), out.min(a.len()));
    while low < high {
        let middle = (low + high) / 2;
        if key_order(&a[middle], &b[out - 1 - middle]).is_le() {
            low = middle + 1;
        } else {
            high = middle;
        }
    }
    low
}

/// Merges the sorted `a` and `b` (keys in place of times, ascending in [`key_order`]) into
/// `out`, as long as both, with their times back: the earlier of the two fronts taken each time,
/// `a`'s on a tie (equal events are the same prediction, so which is taken does not show). The
/// keys compare as integers, cheaper than the times' `total_cmp`, and each event's time is put
/// back as it is written, not in a walk of its own.
fn merge(a: &[Event], b: &[Event], out: &mut [Event]) {
    let with_time = |event: &Event| Event { time: time_of_key(event.time.to_bits()), ..*event };
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let (x, y) = (&a[i], &b[j]);
        let take_b = key_order(y, x).is_lt();
        out[i + j] = with_time(if take_b { y } else { x });
        i += usize::from(!take_b);
        j += usize::from(take_b);
    }
    for (slot, event) in out[i + j..].iter_mut().zip(a[i..].iter().chain(&b[j..])) {
        *slot = with_time(event);
    }
}

impl EventQueue {
    /// Adds a predicted contact.
    #[inline]
    pub fn push(&mut self, event: Event) {
        self.heap.push(event);
    }
    /// Empties the queue and hands over the bulk part's storage, to be filled with the next
    /// window's predictions and given back by [`Self::set_bulk`]: one buffer serves both, so a
    /// window's predictions are held once.
    pub fn take_bulk(&mut self) -> Vec<Event> {
        self.clear();
        std::mem::take(&mut self.bulk)
    }
    /// Replaces the bulk part by `events`, to be popped in order with everything pushed.
    pub fn set_bulk(&mut self, events: Vec<Event>, workers: &Workers) {
        self.bulk = events;
        // Ascending in `Ord`, which is reversed: the earliest event ends up last. The order is
        // total, so no two events are equal unless they are the same prediction: unstable is
        // fine, and every way of sorting gives the same order. Which sort, decided here alone
        // (BENCHMARKS.md, twenty-fifth and twenty-sixth sessions, at n = 10^5, 5 d/f):
        // - on one worker, from `RADIX_MIN` events, one radix sort: 8.1 M instructions a frame;
        // - on more, from `RADIX_MIN` events a half up to `HALVES_MAX`, two halves radix sorted
        //   side by side and merged: 9.7 M on two, shared (rayon's sort read 27.3 M, 15.3 M of
        //   them on the pipeline's thread), in two stage starts where sharing each radix pass
        //   took a dozen and was slower by the clock;
        // - below `RADIX_MIN` (a half's), comparisons: a radix pass costs its bins whatever the
        //   number of events;
        // - on more than one worker above `HALVES_MAX`, rayon's comparison sort, in place, and no
        //   spare kept: issue 28 holds 10^7 bodies to 300 bytes a body on two threads, and their
        //   windows' spare (0.27 events a body at 0.05 d/f, 8.6 bytes a body) would pass it; on
        //   one worker the spare is the radix sort's, as it always was.
        let (n, one_worker) = (self.bulk.len(), workers.threads() == 1);
        if one_worker && n >= RADIX_MIN {
            self.radix.sort_whole(&mut self.bulk);
        } else if !one_worker && (2 * RADIX_MIN..=HALVES_MAX).contains(&n) {
            self.radix.sort_halves(&mut self.bulk, workers);
        } else {
            if n > HALVES_MAX {
                self.radix.spare = Vec::new();
            }
            workers.sort_unstable(&mut self.bulk);
        }
    }
    /// The earliest event (valid or not), and whether the heap holds it (else the bulk part).
    #[inline]
    fn earliest(&self) -> Option<(Event, bool)> {
        match (self.heap.peek(), self.bulk.last()) {
            // Times told apart by one float comparison each way (where they differ as numbers,
            // `total_cmp` agrees); the whole order only when they do not.
            (Some(h), Some(b)) if h.time < b.time => Some((*h, true)),
            (Some(h), Some(b)) if b.time < h.time => Some((*b, false)),
            (Some(h), Some(b)) => Some(if h > b { (*h, true) } else { (*b, false) }),
            (Some(h), None) => Some((*h, true)),
            (None, b) => b.map(|b| (*b, false)),
        }
    }
    /// Drops the earliest event, from the part [`Self::earliest`] said holds it.
    #[inline]
    fn remove_earliest(&mut self, from_heap: bool) {
        if from_heap {
            self.heap.pop();
        } else {
            self.bulk.pop();
        }
    }
    /// The event `ahead` places after the earliest in the bulk part, with its place: most events
    /// come from there, in this order, so the caller may fetch the bodies it will need a few
    /// events early.
    #[inline]
    pub fn upcoming(&self, ahead: usize) -> Option<(usize, &Event)> {
        self.bulk.len().checked_sub(ahead + 1).map(|k| (k, &self.bulk[k]))
    }
    /// Puts back an event popped but not handled: it pops again in its order.
    pub fn put_back(&mut self, event: Event) {
        self.push(event);
        // It is not a repeat of itself.
        self.last = None;
    }
    /// Time of the earliest event (valid or not) but repeats of the event popped last, which it
    /// drops: what [`Self::pop_before`] returns next is this one.
    #[inline]
    pub fn peek_time(&mut self) -> Option<f64> {
        while let Some((event, from_heap)) = self.earliest() {
            if !self.is_repeat(&event) {
                return Some(event.time);
            }
            self.remove_earliest(from_heap);
        }
        None
    }
    /// Removes and returns the earliest event (valid or not: the caller checks stamps) when its
    /// time is before `until`, dropping repeats of the event popped before it; leaves it queued
    /// otherwise. One look at which part holds the earliest event where a peek and then a pop
    /// took two: the event loop asks this once per event. With the event, the place it held in
    /// the bulk part (see [`Self::bulk_before`]), or `None` when it was pushed one at a time.
    #[inline]
    pub fn pop_before(&mut self, until: f64) -> Option<(Event, Option<usize>)> {
        // Most events are the bulk part's, popped in order between the heap's few: one strictly
        // before the heap's earliest time is the earliest, told by two float comparisons (a NaN
        // on either side fails them, and the general way below decides).
        if let Some(&event) = self.bulk.last() {
            let heap_earliest = self.heap.peek().map_or(f64::INFINITY, |first| first.time);
            if event.time < heap_earliest && event.time < until && !self.is_repeat(&event) {
                let place = self.bulk.len() - 1;
                self.bulk.truncate(place);
                self.last = Some(event);
                return Some((event, Some(place)));
            }
        }
        self.pop_earliest_before(until)
    }
    /// Pops the bulk part's events in order, each with its place, while `take` takes them: as
    /// [`Self::pop_before`] would pop them one by one, as long as each is strictly before the
    /// heap's earliest time and `until` and repeats no event before it (the first one the run
    /// meets that is not so, or that `take` declines, stays queued). The heap is looked at once:
    /// `take` pushes nothing. Most of a detect-mode step's events are such a run between two
    /// events of the heap, and one look at the heap and one record of the last event popped
    /// for the whole run spare the event loop a pop's bookkeeping for each.
    #[inline]
    pub fn pop_bulk_run(&mut self, until: f64, mut take: impl FnMut(usize, &Event) -> bool) {
        let heap_earliest = self.heap.peek().map_or(f64::INFINITY, |first| first.time);
        let start = self.bulk.len();
        if self.bulk.last().is_some_and(|first| self.is_repeat(first)) {
            // `pop_before` drops it.
            return;
        }
        let mut place = start;
        while place > 0 {
            let event = &self.bulk[place - 1];
            // A repeat of the event taken before it, which lies next to it (see `is_repeat`).
            let repeat = place < start && {
                let before = &self.bulk[place];
                before.time.to_bits() == event.time.to_bits() && before == event
            };
            if !(event.time < heap_earliest && event.time < until) || repeat || !take(place - 1, event) {
                break;
            }
            place -= 1;
        }
        if place < start {
            self.last = Some(self.bulk[place]);
            self.bulk.truncate(place);
        }
    }
    /// [`Self::pop_before`] in general: from either part, repeats dropped, ties broken by the
    /// whole order.
    fn pop_earliest_before(&mut self, until: f64) -> Option<(Event, Option<usize>)> {
        loop {
            let (event, from_heap) = self.earliest()?;
            let repeat = self.is_repeat(&event);
            if !repeat && !(event.time < until) {
                return None;
            }
            self.remove_earliest(from_heap);
            if !repeat {
                self.last = Some(event);
                return Some((event, (!from_heap).then_some(self.bulk.len())));
            }
        }
    }
    /// The bulk part's events with a time before `until`, the next to pop last, and the place of
    /// the first of them: the bulk part only shrinks from its end until the next window's
    /// [`Self::take_bulk`], so each keeps its place until it pops, and work done ahead for an
    /// event can be found by the place [`Self::pop_before`] gives.
    pub fn bulk_before(&self, until: f64) -> (usize, &[Event]) {
        let first = self.bulk.partition_point(|event| !(event.time < until));
        (first, &self.bulk[first..])
    }
    /// True when `event` repeats the event popped last. Times almost never tie: the rest of the
    /// order is only looked at when they do.
    #[inline(always)]
    fn is_repeat(&self, event: &Event) -> bool {
        self.last.as_ref().is_some_and(|last| last.time.to_bits() == event.time.to_bits() && last == event)
    }
    /// Drops every event, keeping the allocation.
    pub fn clear(&mut self) {
        self.heap.clear();
        self.bulk.clear();
        self.last = None;
    }
    /// Bytes held (capacity).
    pub fn memory_bytes(&self) -> usize {
        (self.heap.capacity() + self.bulk.capacity()) * std::mem::size_of::<Event>() + self.radix.memory_bytes()
    }
    /// Number of queued events, void ones included.
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.heap.len() + self.bulk.len()
    }
    /// True when no event is queued.
    #[cfg(test)]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn event_queue_example() {
        let mut queue = EventQueue::default();
        queue.push(Event { time: 0.5, body: 3, partner: Partner::Body(7), body_stamp: 0, partner_stamp: 0 });
        queue.push(Event { time: 0.2, body: 1, partner: Partner::Body(2), body_stamp: 0, partner_stamp: 0 });
        assert_eq!(queue.pop_before(f64::INFINITY).map(|(e, _)| e.body), Some(1));
    }

    fn event(time: f64, body: u32, partner: Partner) -> Event {
        Event { time, body, partner, body_stamp: 0, partner_stamp: 0 }
    }

    #[test]
    fn pops_in_time_order_with_deterministic_ties() {
        let mut q = EventQueue::default();
        q.push(event(1.0, 4, Partner::Wall(Wall::MinX)));
        q.push(event(1.0, 4, Partner::Body(9)));
        q.push(event(1.0, 2, Partner::Body(5)));
        q.push(event(0.5, 8, Partner::Body(9)));
        let order: Vec<(f64, u32, Partner)> = std::iter::from_fn(|| q.pop_before(f64::INFINITY).map(|(e, _)| e))
            .map(|e| (e.time, e.body, e.partner))
            .collect();
        assert_eq!(
            order,
            vec![
                (0.5, 8, Partner::Body(9)),
                (1.0, 2, Partner::Body(5)),
                (1.0, 4, Partner::Body(9)),
                (1.0, 4, Partner::Wall(Wall::MinX)),
            ]
        );
        assert!(q.is_empty());
    }

    /// The radix sort of the bulk part gives `sort_unstable`'s order, bit for bit, on one worker
    /// and in two halves merged on two and three: on times of every sign and scale, many ties
    /// among them (resolved by the rest of the key), repeats and NaN, over a window's times,
    /// which share their leading bits, and on tiny sizes (a half of none or one event). One
    /// `RadixBuffers` for all, so the spare shrinks, grows and is swapped.
    #[test]
    fn radix_sort_orders_as_the_comparisons_do() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut radix = RadixBuffers::default();
        for case in 0..80 {
            let n = if case < 16 { case / 2 } else { rng.random_range(0..3000) };
            let events: Vec<Event> = (0..n)
                .map(|_| {
                    let time = match case % 4 {
                        0 => rng.random_range(-1e3..1e3),
                        1 => 12.5 + rng.random_range(0.0..0.03),
                        2 => [0.0, -0.0, 1.0, f64::NAN, -2.5, 1e-300, f64::INFINITY][rng.random_range(0..7)],
                        _ => rng.random_range(0..20) as f64 * 0.25,
                    };
                    let partner = match rng.random_range(0..3) {
                        0 => Partner::Body(rng.random_range(0..50)),
                        1 => Partner::Wall(Wall::ALL[rng.random_range(0..6)]),
                        _ => Partner::Renew,
                    };
                    Event {
                        time,
                        body: rng.random_range(0..50),
                        partner,
                        body_stamp: rng.random_range(0..3),
                        partner_stamp: 0,
                    }
                })
                .collect();
            let mut expected = events.clone();
            expected.sort_unstable();
            let bits = |v: &[Event]| -> Vec<(u64, u32, u64, u32)> {
                v.iter().map(|e| (e.time.to_bits(), e.body, e.partner.key(), e.body_stamp)).collect()
            };
            for threads in [1, 2, 3] {
                let mut sorted = events.clone();
                match threads {
                    1 => radix.sort_whole(&mut sorted),
                    _ => radix.sort_halves(&mut sorted, &Workers::new(threads)),
                }
                assert_eq!(bits(&sorted), bits(&expected), "case {case}, {n} events, {threads} workers");
            }
        }
    }

    /// Two sorted halves whose leading parts hold every event of the other's up to the end:
    /// each half of the output is merged from its own stretches, whatever the split.
    #[test]
    fn merged_halves_are_the_whole_order() {
        let times = |ts: &[f64]| -> Vec<Event> { ts.iter().map(|&t| event(t, 1, Partner::Renew)).collect() };
        let keyed = |v: &[Event]| -> Vec<Event> {
            v.iter().map(|e| Event { time: f64::from_bits(latest_first_key(e.time.to_bits())), ..*e }).collect()
        };
        for (a, b) in [
            (times(&[4.0, 3.0]), times(&[2.0, 1.0, 0.5])),
            (times(&[2.0, 1.0]), times(&[4.0, 3.0, 0.5])),
            (times(&[3.0, 3.0]), times(&[3.0, 3.0, 3.0])),
            (times(&[3.0, 1.0]), times(&[4.0, 2.0, 0.0])),
        ] {
            let mut expected = [a.clone(), b.clone()].concat();
            expected.sort_unstable();
            let (a, b) = (keyed(&a), keyed(&b));
            let taken = merge_split(&a, &b, a.len());
            // Filled with a time no half holds, so a place the merges leave unwritten shows.
            let mut out = times(&vec![-1.0; expected.len()]);
            let (to_a, to_b) = out.split_at_mut(a.len());
            merge(&a[..taken], &b[..a.len() - taken], to_a);
            merge(&a[taken..], &b[a.len() - taken..], to_b);
            let time = |v: &[Event]| v.iter().map(|e| e.time).collect::<Vec<_>>();
            assert_eq!(time(&out), time(&expected));
        }
    }

    /// An event popped from the bulk part comes with the place it held there, as
    /// `bulk_before` numbered it; one pushed on its own comes with none.
    #[test]
    fn a_bulk_event_pops_with_its_place() {
        let mut q = EventQueue::default();
        let bulk =
            vec![event(3.0, 1, Partner::Body(2)), event(1.0, 2, Partner::Body(3)), event(2.0, 4, Partner::Body(5))];
        q.set_bulk(bulk, &Workers::new(1));
        q.push(event(1.5, 6, Partner::Body(7)));
        let (first, before) = q.bulk_before(2.5);
        let times: Vec<f64> = before.iter().map(|e| e.time).collect();
        assert_eq!((first, times), (1, vec![2.0, 1.0]));
        let mut popped = std::iter::from_fn(|| q.pop_before(2.5)).map(|(e, place)| (e.time, place));
        assert_eq!(popped.next(), Some((1.0, Some(2))));
        assert_eq!(popped.next(), Some((1.5, None)));
        assert_eq!(popped.next(), Some((2.0, Some(1))));
        assert_eq!(popped.next(), None);
        assert_eq!(q.len(), 1);
    }

    /// A run pops what `pop_before` would, in its order and with its places, up to the heap's
    /// earliest time, a repeat (dropped by the next `pop_before`) or the event declined, which
    /// stay queued; the event popped last is the run's, so a repeat of it is dropped after.
    #[test]
    fn a_bulk_run_pops_as_pop_before_does() {
        let bulk = vec![
            event(6.0, 1, Partner::Body(2)),
            event(5.0, 1, Partner::Body(2)),
            event(4.0, 3, Partner::Body(4)),
            event(3.0, 2, Partner::Body(5)),
            event(2.0, 1, Partner::Body(3)),
            event(2.0, 1, Partner::Body(3)),
            event(1.0, 1, Partner::Body(2)),
        ];
        let mut q = EventQueue::default();
        q.set_bulk(bulk, &Workers::new(1));
        q.push(event(3.0, 1, Partner::Body(9)));
        let mut taken = Vec::new();
        q.pop_bulk_run(10.0, |place, e| {
            taken.push((place, e.time));
            true
        });
        assert_eq!(taken, [(6, 1.0), (5, 2.0)], "the repeat at 2.0 stays for pop_before to drop");
        assert_eq!(q.pop_before(10.0).map(|(e, place)| (e.time, e.body, place)), Some((3.0, 1, None)));
        taken.clear();
        q.pop_bulk_run(10.0, |place, e| {
            taken.push((place, e.time));
            e.body != 3
        });
        assert_eq!(taken, [(3, 3.0), (2, 4.0)], "the event declined stays queued");
        assert_eq!(q.pop_before(10.0).map(|(e, place)| (e.time, place)), Some((4.0, Some(2))));
        taken.clear();
        q.pop_bulk_run(5.5, |place, e| {
            taken.push((place, e.time));
            true
        });
        assert_eq!(taken, [(1, 5.0)], "nothing at or after the step's end");
        assert_eq!(q.len(), 1);
    }

    /// Events pushed between the bulk part's pops come out in their place: before a bulk event
    /// they precede, by the rest of the order on a tie, and after the heap's earliest is popped
    /// the bulk part's next is taken from the heap's next earliest again.
    #[test]
    fn pushes_between_bulk_pops_keep_the_order() {
        let mut q = EventQueue::default();
        let bulk =
            vec![event(3.0, 5, Partner::Body(6)), event(2.0, 5, Partner::Body(6)), event(1.0, 5, Partner::Body(6))];
        q.set_bulk(bulk, &Workers::new(1));
        let mut order = vec![q.pop_before(10.0).map(|(e, _)| (e.time, e.body))];
        q.push(event(1.5, 7, Partner::Body(8)));
        q.push(event(2.0, 1, Partner::Body(8)));
        q.push(event(2.5, 9, Partner::Body(10)));
        order.extend(std::iter::from_fn(|| q.pop_before(2.75)).map(|(e, _)| Some((e.time, e.body))));
        let expected = [(1.0, 5), (1.5, 7), (2.0, 1), (2.0, 5), (2.5, 9)].map(Some);
        assert_eq!(order, expected);
        q.push(event(f64::NAN, 2, Partner::Body(3)));
        assert_eq!(q.pop_before(10.0).map(|(e, _)| e.time), Some(3.0));
        assert!(q.pop_before(10.0).is_none(), "a NaN time is never before the step's end");
    }

    #[test]
    fn a_prediction_made_twice_pops_once() {
        let mut q = EventQueue::default();
        q.push(event(1.0, 2, Partner::Body(5)));
        q.push(event(1.0, 2, Partner::Body(5)));
        q.push(Event { body_stamp: 1, ..event(1.0, 2, Partner::Body(5)) });
        assert_eq!(std::iter::from_fn(|| q.pop_before(f64::INFINITY).map(|(e, _)| e)).count(), 2);
    }
}
