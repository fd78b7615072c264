//! How the frame pipeline's bulk work is shared between threads.
//!
//! It owns one rule: work is cut into contiguous chunks of an index range, the chunks run on
//! rayon's current pool when there is more than one thread (and plainly one after the other
//! otherwise, without touching any pool), and their results are put back together in chunk
//! order. Chunks are contiguous and joined in order, so the result is the same whatever the
//! number of threads: the pipeline's output never depends on it. It never decides what is
//! computed, only where.

use rayon::prelude::*;
use std::ops::Range;

/// How many chunks each thread gets: enough to even out chunks of unequal cost.
const CHUNKS_PER_THREAD: usize = 4;

/// Below this many items in all, the chunks' buffers are appended by the calling thread: waking
/// the workers would cost more than the copy.
const MOVED_TOGETHER: usize = 4096;

/// The threads the pipeline may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Workers {
    threads: usize,
}

impl Workers {
    /// `threads` workers (at least one). With one, nothing ever runs on a pool.
    pub fn new(threads: usize) -> Workers {
        Workers { threads: threads.max(1) }
    }

    /// One worker: everything runs on the calling thread.
    pub fn serial() -> Workers {
        Workers { threads: 1 }
    }

    /// Number of threads.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// The contiguous chunks `0..len` is cut into.
    fn ranges(&self, len: usize) -> impl IndexedParallelIterator<Item = Range<usize>> {
        let chunks = (self.threads * CHUNKS_PER_THREAD).min(len).max(1);
        (0..chunks).into_par_iter().map(move |k| k * len / chunks..(k + 1) * len / chunks)
    }

    /// `f(range, buffer)` on contiguous chunks of `0..len`, each chunk writing into a buffer of
    /// its own; the buffers are appended to `out` in chunk order, so `out` is the same whatever the
    /// number of threads. On one thread `f` writes straight into `out`, with no second buffer the
    /// size of the output. Returns `f`'s results in chunk order.
    pub fn extend_ranges<T: Send, R: Send>(
        &self,
        len: usize,
        out: &mut Vec<T>,
        f: impl Fn(Range<usize>, &mut Vec<T>) -> R + Sync + Send,
    ) -> Vec<R> {
        if self.threads == 1 {
            return vec![f(0..len, out)];
        }
        let mut parts: Vec<(Vec<T>, R)> = self
            .ranges(len)
            .map(|range| {
                let mut found = Vec::new();
                let result = f(range, &mut found);
                (found, result)
            })
            .collect();
        let total: usize = parts.iter().map(|(found, _)| found.len()).sum();
        if total < MOVED_TOGETHER {
            for (found, _) in &mut parts {
                out.append(found);
            }
        } else {
            // Each buffer moved into its own stretch of `out` by a worker: one thread moving them
            // all (some megabytes a frame at 10^5 bodies) was a serial part of every frame.
            out.reserve(total);
            let filled = out.len();
            let mut stretches = Vec::with_capacity(parts.len());
            let mut spare = &mut out.spare_capacity_mut()[..total];
            for (found, _) in &mut parts {
                let (stretch, rest) = std::mem::take(&mut spare).split_at_mut(found.len());
                stretches.push((stretch, found));
                spare = rest;
            }
            stretches.into_par_iter().for_each(|(stretch, found)| {
                for (slot, item) in stretch.iter_mut().zip(found.drain(..)) {
                    slot.write(item);
                }
            });
            // SAFETY: the stretches cover `filled..filled + total` and every slot of them was
            // written above, each item moved out of its buffer once.
            unsafe { out.set_len(filled + total) };
        }
        parts.into_iter().map(|(_, result)| result).collect()
    }

    /// `f(offset, chunk)` on contiguous chunks of `v`; the results in chunk order.
    pub fn chunks_mut<A: Send, T: Send>(&self, v: &mut [A], f: impl Fn(usize, &mut [A]) -> T + Sync + Send) -> Vec<T> {
        if self.threads == 1 {
            return vec![f(0, v)];
        }
        let size = v.len().div_ceil(self.threads * CHUNKS_PER_THREAD).max(1);
        v.par_chunks_mut(size).enumerate().map(|(k, chunk)| f(k * size, chunk)).collect()
    }

    /// `f(offset, a_chunk, b_chunk)` on matching contiguous chunks of two slices of one length.
    pub fn zip_chunks<A: Send, B: Send>(
        &self,
        a: &mut [A],
        b: &mut [B],
        f: impl Fn(usize, &mut [A], &mut [B]) + Sync + Send,
    ) {
        assert_eq!(a.len(), b.len());
        if self.threads == 1 {
            return f(0, a, b);
        }
        let size = a.len().div_ceil(self.threads * CHUNKS_PER_THREAD).max(1);
        a.par_chunks_mut(size).zip(b.par_chunks_mut(size)).enumerate().for_each(|(k, (x, y))| f(k * size, x, y));
    }

    /// `f(offset, share, own)` on each thread's contiguous share of `v` (`v.len() / threads`
    /// rounded up), each with its own stretch `own` of `scratch` (`scratch.len() / threads`
    /// items, at least one): for work each thread does into state of its own, which the caller
    /// keeps from call to call, so no part list is allocated for it.
    pub fn shares_mut<A: Send, B: Send>(
        &self,
        v: &mut [A],
        scratch: &mut [B],
        f: impl Fn(usize, &mut [A], &mut [B]) + Sync + Send,
    ) {
        if self.threads == 1 {
            return f(0, v, scratch);
        }
        let (size, own) = (v.len().div_ceil(self.threads).max(1), (scratch.len() / self.threads).max(1));
        v.par_chunks_mut(size)
            .zip(scratch.par_chunks_mut(own))
            .enumerate()
            .for_each(|(k, (share, own))| f(k * size, share, own));
    }

    /// `f(k, part)` for every part, in parallel with more than one thread: for work already cut
    /// into disjoint pieces (see [`split_at_points`]).
    pub fn for_each_part<S: Send>(&self, parts: Vec<S>, f: impl Fn(usize, S) + Sync + Send) {
        if self.threads == 1 {
            parts.into_iter().enumerate().for_each(|(k, part)| f(k, part));
        } else {
            parts.into_par_iter().enumerate().for_each(|(k, part)| f(k, part));
        }
    }

    /// `len` split into one range per thread, each with about the same share of `weight`: the
    /// boundaries `b` where the running total `weight(b)` (ascending, from 0 at 0) crosses each
    /// thread's share.
    pub fn balanced_points(&self, len: usize, total: usize, weight: impl Fn(usize) -> usize) -> Vec<usize> {
        (1..self.threads)
            .map(|k| {
                let share = k * total / self.threads;
                // The first index whose running total reaches the share.
                let (mut low, mut high) = (0, len);
                while low < high {
                    let middle = (low + high) / 2;
                    if weight(middle) < share {
                        low = middle + 1;
                    } else {
                        high = middle;
                    }
                }
                low
            })
            .collect()
    }

    /// `a()` and `b()`, on two threads when there is more than one (one stage start), else one
    /// after the other.
    pub fn join<RA: Send, RB: Send>(&self, a: impl FnOnce() -> RA + Send, b: impl FnOnce() -> RB + Send) -> (RA, RB) {
        if self.threads == 1 {
            (a(), b())
        } else {
            rayon::join(a, b)
        }
    }

    /// Sorts `v` (unstable: equal elements must be indistinguishable).
    pub fn sort_unstable<T: Ord + Send>(&self, v: &mut [T]) {
        if self.threads == 1 {
            v.sort_unstable();
        } else {
            v.par_sort_unstable();
        }
    }
}

/// `slice` cut at the ascending `points` into `points.len() + 1` disjoint parts.
pub fn split_at_points<'a, T>(mut slice: &'a mut [T], points: &[usize]) -> Vec<&'a mut [T]> {
    let mut parts = Vec::with_capacity(points.len() + 1);
    let mut cut = 0;
    for &point in points {
        let (head, tail) = slice.split_at_mut(point - cut);
        parts.push(head);
        (slice, cut) = (tail, point);
    }
    parts.push(slice);
    parts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extend_ranges_example() {
        let mut evens = Vec::new();
        let counts = Workers::new(3).extend_ranges(10, &mut evens, |r, out| {
            let before = out.len();
            out.extend(r.filter(|i| i % 2 == 0));
            out.len() - before
        });
        assert_eq!(evens, [0, 2, 4, 6, 8]);
        assert_eq!(counts.iter().sum::<usize>(), 5);
    }

    /// Enough items that the workers move the buffers into place: owned items (each moved once,
    /// none dropped twice), after what `out` held, in the order one thread gives.
    #[test]
    fn extend_ranges_moves_large_outputs_in_order() {
        let len = 3 * MOVED_TOGETHER;
        let fill = |r: Range<usize>, out: &mut Vec<String>| out.extend(r.filter(|i| i % 3 != 1).map(|i| i.to_string()));
        let (mut serial, mut shared) = (vec!["first".to_string()], vec!["first".to_string()]);
        Workers::serial().extend_ranges(len, &mut serial, fill);
        Workers::new(3).extend_ranges(len, &mut shared, fill);
        assert!(shared.len() > MOVED_TOGETHER);
        assert_eq!(shared, serial);
    }

    #[test]
    fn shares_mut_example() {
        let (mut v, mut sums) = ([1, 2, 3, 4, 5], [0; 4]);
        Workers::new(2).shares_mut(&mut v, &mut sums, |offset, share, own| {
            own[0] = offset;
            own[1] = share.iter().sum();
        });
        // Shares of 3 and 2, each with two items of its own.
        assert_eq!(sums, [0, 6, 3, 9]);
        let mut all = [0; 2];
        Workers::serial().shares_mut(&mut v, &mut all, |offset, share, own| own[0] = offset + share.len());
        assert_eq!(all, [5, 0]);
    }

    #[test]
    fn for_each_part_example() {
        let mut v = [1, 2, 3, 4, 5];
        Workers::new(2).for_each_part(split_at_points(&mut v, &[2]), |k, part| part.iter_mut().for_each(|x| *x += k));
        assert_eq!(v, [1, 2, 4, 5, 6]);
    }

    #[test]
    fn balanced_points_example() {
        // Running totals 0, 1, 2, 10, 11: the item at 2 weighs 8 of the 11.
        let running = [0, 1, 2, 10, 11];
        assert_eq!(Workers::new(2).balanced_points(5, 11, |b| running[b]), vec![3]);
        assert_eq!(Workers::new(1).balanced_points(5, 11, |b| running[b]), Vec::<usize>::new());
    }
}
