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
        // total, so no two events are equal unless they are the same prediction: unstable is fine.
        workers.sort_unstable(&mut self.bulk);
    }
    /// The earliest event (valid or not), from whichever part holds it.
    #[inline]
    fn peek(&self) -> Option<&Event> {
        match (self.heap.peek(), self.bulk.last()) {
            (Some(h), Some(b)) => Some(if h > b { h } else { b }),
            (h, b) => h.or(b),
        }
    }
    /// The event `ahead` places after the earliest in the bulk part: most events come from there,
    /// in this order, so the caller may fetch the bodies it will need a few events early.
    #[inline]
    pub fn upcoming(&self, ahead: usize) -> Option<&Event> {
        self.bulk.len().checked_sub(ahead + 1).map(|k| &self.bulk[k])
    }
    /// Puts back an event popped but not handled: it pops again in its order.
    pub fn put_back(&mut self, event: Event) {
        self.heap.push(event);
        // It is not a repeat of itself.
        self.last = None;
    }
    /// Time of the earliest event (valid or not) but repeats of the event popped last, which it
    /// drops: what [`Self::pop`] returns next is this one.
    #[inline]
    pub fn peek_time(&mut self) -> Option<f64> {
        while let Some(&event) = self.peek() {
            if !self.is_repeat(&event) {
                return Some(event.time);
            }
            self.take();
        }
        None
    }
    /// True when `event` repeats the event popped last. Times almost never tie: the rest of the
    /// order is only looked at when they do.
    #[inline(always)]
    fn is_repeat(&self, event: &Event) -> bool {
        self.last.as_ref().is_some_and(|last| last.time.to_bits() == event.time.to_bits() && last == event)
    }
    /// Removes and returns the earliest event (valid or not: the caller checks stamps), dropping
    /// repeats of the event popped before it.
    #[inline]
    pub fn pop(&mut self) -> Option<Event> {
        loop {
            let event = self.take()?;
            if !self.is_repeat(&event) {
                self.last = Some(event);
                return Some(event);
            }
        }
    }
    /// Removes the earliest event, from whichever part holds it.
    #[inline]
    fn take(&mut self) -> Option<Event> {
        let from_heap = match (self.heap.peek(), self.bulk.last()) {
            (Some(h), Some(b)) => h > b,
            (h, _) => h.is_some(),
        };
        if from_heap {
            self.heap.pop()
        } else {
            self.bulk.pop()
        }
    }
    /// Drops every event, keeping the allocation.
    pub fn clear(&mut self) {
        self.heap.clear();
        self.bulk.clear();
        self.last = None;
    }
    /// Bytes held (capacity).
    pub fn memory_bytes(&self) -> usize {
        (self.heap.capacity() + self.bulk.capacity()) * std::mem::size_of::<Event>()
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
        assert_eq!(queue.pop().map(|e| e.body), Some(1));
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
        let order: Vec<(f64, u32, Partner)> =
            std::iter::from_fn(|| q.pop()).map(|e| (e.time, e.body, e.partner)).collect();
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

    #[test]
    fn a_prediction_made_twice_pops_once() {
        let mut q = EventQueue::default();
        q.push(event(1.0, 2, Partner::Body(5)));
        q.push(event(1.0, 2, Partner::Body(5)));
        q.push(Event { body_stamp: 1, ..event(1.0, 2, Partner::Body(5)) });
        assert_eq!(std::iter::from_fn(|| q.pop()).count(), 2);
    }
}
