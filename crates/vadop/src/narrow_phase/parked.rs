//! Parked shape searches: for each pair of shapes the broad phase keeps reporting, where its
//! last search stopped, keyed by the two motions it ran on, so that the next window's search
//! takes the chain up there instead of replaying it from the pair's reference (see
//! [`crate::narrow_phase::shapes::Resume`]). Without it a pair that stays within reach costs, in
//! its k-th window, the probes of all k; with it, what its motion needs once.
//!
//! It owns the store and its pruning only: it never searches, never schedules, and reads nothing
//! of a body but its motion epoch. Sphere pairs have closed forms and are never parked here.

use crate::narrow_phase::shapes::Resume;
use crate::slab::Slab;

/// One pair's parked search as its body's list holds it: the key a lookup compares, and where
/// its [`Resume`] lies in the store's slab. Kept apart from the resume (about 400 bytes, the warm
/// start with GJK's simplex) so that scanning a body's list for a partner reads a few cache
/// lines, not one per entry: that scan over whole entries took 44 % of `pair_start_parked`'s
/// samples at 5 d/f.
#[derive(Debug, Clone, Copy)]
struct ParkedKey {
    partner: u32,
    /// The two bodies' motion epochs when it parked: either changed, it is void.
    epochs: (u32, u32),
    slot: u32,
    /// The resume's [`Resume::searched_to`], read when pruning without touching the resume.
    searched_to: f64,
}

/// The parked searches of every shape pair, by the lower body id: one short list of keys per
/// body, found by index and scanned, never hashed; the resumes in a [`Slab`], so that pruning a
/// list never moves them.
#[derive(Debug, Default)]
pub(crate) struct ParkedSearches {
    by_body: Vec<Vec<ParkedKey>>,
    resumes: Slab<Resume>,
}

impl ParkedSearches {
    /// Where the search of bodies `a < b`, on the motions of `epochs`, last parked.
    #[inline]
    pub(crate) fn get(&self, a: u32, b: u32, epochs: (u32, u32)) -> Option<&Resume> {
        let list = self.by_body.get(a as usize)?;
        let key = list.iter().find(|k| k.partner == b && k.epochs == epochs)?;
        Some(&self.resumes[key.slot])
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
        let (list, resumes) = (&mut self.by_body[i], &mut self.resumes);
        list.retain(|k| {
            let kept = k.epochs.0 == epochs.0 && (k.partner == b || k.searched_to >= stale);
            if !kept {
                resumes.free(k.slot);
            }
            kept
        });
        let searched_to = resume.searched_to();
        match list.iter_mut().find(|k| k.partner == b) {
            Some(k) if k.epochs == epochs && k.searched_to > searched_to => {}
            Some(k) => {
                (k.epochs, k.searched_to) = (epochs, searched_to);
                resumes[k.slot] = resume;
            }
            None => list.push(ParkedKey { partner: b, epochs, slot: resumes.insert(resume), searched_to }),
        }
    }

    /// Forgets body `i`'s pairs (it was removed); pairs it is the higher id of go void with its
    /// epoch.
    pub(crate) fn remove(&mut self, i: u32) {
        if let Some(list) = self.by_body.get_mut(i as usize) {
            for key in list.drain(..) {
                self.resumes.free(key.slot);
            }
        }
    }

    /// Bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.by_body.capacity() * std::mem::size_of::<Vec<ParkedKey>>()
            + self.by_body.iter().map(|l| l.capacity() * std::mem::size_of::<ParkedKey>()).sum::<usize>()
            + self.resumes.memory_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn searched_to(store: &ParkedSearches, a: u32, b: u32, epochs: (u32, u32)) -> Option<f64> {
        store.get(a, b, epochs).map(Resume::searched_to)
    }

    /// A lookup finds the latest search of a pair on its motions only; pruning and removal free
    /// their slots, and a store that keeps a few pairs at a time over many windows keeps as few
    /// resumes, however many it has held in all.
    #[test]
    fn the_store_keeps_the_latest_search_and_reuses_freed_slots() {
        let mut store = ParkedSearches::default();
        store.keep(0, 1, (0, 0), Resume::done_at(1.0), 0.0);
        store.keep(0, 1, (0, 0), Resume::done_at(0.5), 0.0);
        assert_eq!(searched_to(&store, 0, 1, (0, 0)), Some(1.0), "an earlier search does not replace a later one");
        store.keep(0, 1, (0, 1), Resume::done_at(0.5), 0.0);
        assert_eq!(searched_to(&store, 0, 1, (0, 1)), Some(0.5), "new motions replace the old search");
        assert_eq!(searched_to(&store, 0, 1, (0, 0)), None);
        assert_eq!(searched_to(&store, 1, 0, (0, 1)), None, "kept under the lower id only");
        // Three partners at a time over a thousand windows: each window's searches prune the
        // pairs not searched since the window before.
        for window in 1..1000 {
            let t = window as f64;
            for partner in 0..3 {
                store.keep(0, 2 + (window + partner) % 7, (0, 1), Resume::done_at(t), t - 1.0);
            }
        }
        assert!(store.resumes.slots() <= 8, "{} slots taken for at most 7 pairs", store.resumes.slots());
        assert_eq!(searched_to(&store, 0, 2 + 999 % 7, (0, 1)), Some(999.0));
        // A new motion of the lower body voids all its pairs; removal frees what is left.
        store.keep(0, 50, (1, 0), Resume::done_at(1000.0), 1000.0);
        assert_eq!(store.by_body[0].len(), 1);
        store.remove(0);
        assert_eq!(searched_to(&store, 0, 50, (1, 0)), None);
        let held = store.resumes.slots();
        for partner in 1..=held as u32 {
            store.keep(3, 3 + partner, (0, 0), Resume::done_at(0.0), 0.0);
        }
        assert_eq!(store.resumes.slots(), held, "freed slots are reused before the slab grows");
    }
}
