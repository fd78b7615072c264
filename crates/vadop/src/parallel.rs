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

    /// `f` on contiguous chunks of `0..len`, in parallel with more than one thread; the results in
    /// chunk order.
    ///
    /// ```
    /// use vadop::parallel::Workers;
    /// let sums = Workers::new(3).map_ranges(10, |r| r.sum::<usize>());
    /// assert_eq!(sums.iter().sum::<usize>(), 45);
    /// ```
    pub fn map_ranges<T: Send>(&self, len: usize, f: impl Fn(Range<usize>) -> T + Sync + Send) -> Vec<T> {
        if self.threads == 1 {
            return vec![f(0..len)];
        }
        self.ranges(len).map(f).collect()
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

    /// Sorts `v` (unstable: equal elements must be indistinguishable).
    pub fn sort_unstable<T: Ord + Send>(&self, v: &mut [T]) {
        if self.threads == 1 {
            v.sort_unstable();
        } else {
            v.par_sort_unstable();
        }
    }
}
