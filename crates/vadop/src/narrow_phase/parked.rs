//! Parked shape searches: for each pair of shapes the broad phase keeps reporting, where its
//! last search stopped, keyed by the two motions it ran on, so that the next window's search
//! takes the chain up there instead of replaying it from the pair's reference (see
//! [`crate::narrow_phase::shapes::Resume`]). Without it a pair that stays within reach costs, in
//! its k-th window, the probes of all k; with it, what its motion needs once.
//!
//! It owns the store and its pruning only: it never searches, never schedules, and reads nothing
//! of a body but its motion epoch. Sphere pairs have closed forms and are never parked here.

use crate::narrow_phase::shapes::Resume;

/// One pair's parked search, kept with the lower body id.
#[derive(Debug, Clone, Copy)]
struct ParkedPair {
    partner: u32,
    /// The two bodies' motion epochs when it parked: either changed, it is void.
    epochs: (u32, u32),
    resume: Resume,
}

/// The parked searches of every shape pair, by the lower body id: one short list per body,
/// found by index and scanned, never hashed.
#[derive(Debug, Default)]
pub(crate) struct ParkedSearches {
    by_body: Vec<Vec<ParkedPair>>,
}

impl ParkedSearches {
    /// Where the search of bodies `a < b`, on the motions of `epochs`, last parked.
    #[inline]
    pub(crate) fn get(&self, a: u32, b: u32, epochs: (u32, u32)) -> Option<&Resume> {
        let list = self.by_body.get(a as usize)?;
        list.iter().find(|p| p.partner == b && p.epochs == epochs).map(|p| &p.resume)
    }

    /// Keeps where the search of bodies `a < b` on the motions of `epochs` parked, over what an
    /// earlier one left (the later of two searched to a later time). Pairs searched only before
    /// `stale` (the current window's start) are dropped: the broad phase no longer reports them,
    /// and a pair that comes back is searched from its reference again, which only costs time.
    pub(crate) fn keep(&mut self, a: u32, b: u32, epochs: (u32, u32), resume: Resume, stale: f64) {
        let i = a as usize;
        if i >= self.by_body.len() {
            self.by_body.resize_with(i + 1, Vec::new);
        }
        let list = &mut self.by_body[i];
        list.retain(|p| p.epochs.0 == epochs.0 && (p.partner == b || p.resume.searched_to() >= stale));
        match list.iter_mut().find(|p| p.partner == b) {
            Some(p) if p.epochs == epochs && p.resume.searched_to() > resume.searched_to() => {}
            Some(p) => *p = ParkedPair { partner: b, epochs, resume },
            None => list.push(ParkedPair { partner: b, epochs, resume }),
        }
    }

    /// Forgets body `i`'s pairs (it was removed); pairs it is the higher id of go void with its
    /// epoch.
    pub(crate) fn remove(&mut self, i: u32) {
        if let Some(list) = self.by_body.get_mut(i as usize) {
            list.clear();
        }
    }

    /// Bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.by_body.capacity() * std::mem::size_of::<Vec<ParkedPair>>()
            + self.by_body.iter().map(|l| l.capacity() * std::mem::size_of::<ParkedPair>()).sum::<usize>()
    }
}
