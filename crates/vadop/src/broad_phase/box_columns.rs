//! Compact boxes stored column by column: every low x, then every low y, and so on.
//!
//! It owns a broad phase's binned boxes and the inner loop of its pair sweep: one box tested
//! against a run of stored boxes, on x86_64 eight at a time with AVX where the processor has it
//! and four at a time with SSE2 (part of that target's baseline) where not, one at a time
//! elsewhere. All report exactly the boxes [`CompactBox::overlaps`] accepts, in ascending order,
//! so which path runs never changes a result. It knows nothing of bodies, cells or windows.

use crate::broad_phase::proxy::CompactBox;
use std::ops::Range;

/// Boxes by coordinate, all six columns of one length: the boxes' count and `PADDING` more,
/// so the vector scan reads whole groups past the last box and masks off what is not
/// asked for, with no scalar tail (whose branch on each box's overlap mispredicts as often as
/// not).
#[derive(Debug, Default, Clone)]
pub struct BoxColumns {
    low: [Vec<f32>; 3],
    high: [Vec<f32>; 3],
}

/// Slots past the last box in every column (empty while no box is stored): the widest scan reads
/// eight at a time.
const PADDING: usize = 7;

/// Disjoint mutable windows onto the columns, one per worker, all six of one length.
pub struct BoxColumnsMut<'a> {
    low: [&'a mut [f32]; 3],
    high: [&'a mut [f32]; 3],
}

impl BoxColumnsMut<'_> {
    /// Stores `bbox` at `k`, counted from the start of this part. One bounds check for the six
    /// columns rather than one each: the binning stores every box of a window's start this way.
    #[inline]
    pub fn set(&mut self, k: usize, bbox: CompactBox) {
        assert!(k < self.low[0].len(), "box {k} beyond a part of {}", self.low[0].len());
        for axis in 0..3 {
            // SAFETY: the six windows have one length (`BoxColumns::parts_mut`), above `k`.
            unsafe {
                *self.low[axis].get_unchecked_mut(k) = bbox.low[axis];
                *self.high[axis].get_unchecked_mut(k) = bbox.high[axis];
            }
        }
    }
}

impl BoxColumns {
    /// Number of boxes.
    #[inline]
    pub fn len(&self) -> usize {
        self.low[0].len().saturating_sub(PADDING)
    }

    /// True when no box is stored.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sets the number of boxes; new ones are empty boxes at the origin.
    pub fn resize(&mut self, len: usize) {
        for column in self.low.iter_mut().chain(&mut self.high) {
            column.resize(len + PADDING, 0.0);
        }
    }

    /// Box `i`. Always inline: the sweep compiled for AVX left it a call, once per piece. One
    /// bounds check for the six columns rather than one each.
    #[inline(always)]
    pub fn get(&self, i: usize) -> CompactBox {
        assert!(i < self.low[0].len(), "box {i} beyond {}", self.low[0].len());
        // SAFETY: the six columns have one length (`resize`), above `i`.
        unsafe {
            CompactBox {
                low: [0, 1, 2].map(|axis| *self.low[axis].get_unchecked(i)),
                high: [0, 1, 2].map(|axis| *self.high[axis].get_unchecked(i)),
            }
        }
    }

    /// Stores `bbox` as box `i`.
    #[inline]
    pub fn set(&mut self, i: usize, bbox: CompactBox) {
        for axis in 0..3 {
            self.low[axis][i] = bbox.low[axis];
            self.high[axis][i] = bbox.high[axis];
        }
    }

    /// The columns cut at ascending `points` into disjoint parts, for workers writing ranges.
    pub fn parts_mut(&mut self, points: &[usize]) -> Vec<BoxColumnsMut<'_>> {
        use crate::parallel::split_at_points;
        let [lx, ly, lz] = &mut self.low;
        let [hx, hy, hz] = &mut self.high;
        let split = |column| split_at_points(column, points).into_iter();
        split(lx)
            .zip(split(ly))
            .zip(split(lz))
            .zip(split(hx))
            .zip(split(hy))
            .zip(split(hz))
            .map(|(((((lx, ly), lz), hx), hy), hz)| {
                // The columns are of one length and cut at the same points: so are their parts.
                debug_assert!([ly.len(), lz.len(), hx.len(), hy.len(), hz.len()].iter().all(|&len| len == lx.len()));
                BoxColumnsMut { low: [lx, ly, lz], high: [hx, hy, hz] }
            })
            .collect()
    }

    /// Bytes held (capacity).
    pub fn memory_bytes(&self) -> usize {
        self.low.iter().chain(&self.high).map(|c| c.capacity() * 4).sum()
    }

    /// Calls `hit(j)` for every box `j` in `range` that overlaps `query`, in ascending order.
    ///
    /// ```
    /// use vadop::broad_phase::box_columns::BoxColumns;
    /// use vadop::broad_phase::proxy::CompactBox;
    /// let unit = |x: f32| CompactBox { low: [x, 0.0, 0.0], high: [x + 1.0, 1.0, 1.0] };
    /// let mut boxes = BoxColumns::default();
    /// boxes.resize(6);
    /// for i in 0..6 {
    ///     boxes.set(i, unit(i as f32 * 2.0));
    /// }
    /// let mut hits = Vec::new();
    /// // From x = 2.5 to 4.5: it meets the boxes at 2..3 and 4..5.
    /// let query = CompactBox { low: [2.5, 0.5, 0.5], high: [4.5, 0.6, 0.6] };
    /// boxes.for_each_overlap(&query, 0..6, |j| hits.push(j));
    /// assert_eq!(hits, [1, 2]);
    /// ```
    #[inline]
    pub fn for_each_overlap(&self, query: &CompactBox, range: Range<usize>, hit: impl FnMut(usize)) {
        assert!(range.end <= self.len(), "range {range:?} beyond {} boxes", self.len());
        #[cfg(target_arch = "x86_64")]
        {
            let avx = std::arch::is_x86_feature_detected!("avx");
            // SAFETY: the range lies within the boxes, and AVX is asked for only where it is.
            let bits = |first, last| unsafe {
                if avx {
                    self.overlaps_avx(query, first, last)
                } else {
                    self.overlaps_sse2(query, first, last)
                }
            };
            // SAFETY: as above.
            unsafe { self.scan(range, bits, hit) };
        }
        #[cfg(not(target_arch = "x86_64"))]
        let mut hit = hit;
        #[cfg(not(target_arch = "x86_64"))]
        for j in range {
            let overlaps =
                (0..3).all(|axis| (query.low[axis] <= self.high[axis][j]) & (self.low[axis][j] <= query.high[axis]));
            if overlaps {
                hit(j);
            }
        }
    }

    /// [`Self::for_each_overlap`] of a query made by [`Query::new`] with the same `AVX`, for a
    /// caller that has asked for AVX once (`AVX`: the processor has it) rather than at every
    /// scan: called from a function compiled for AVX, the vector scan inlines there, and the
    /// query's lanes are set up once for all the runs it scans.
    ///
    /// # Safety
    /// `AVX` only where the processor has AVX.
    #[inline(always)]
    pub unsafe fn for_each_overlap_of<const AVX: bool>(
        &self,
        query: &Query,
        range: Range<usize>,
        hit: impl FnMut(usize),
    ) {
        #[cfg(target_arch = "x86_64")]
        if AVX {
            assert!(range.end <= self.len(), "range {range:?} beyond {} boxes", self.len());
            // SAFETY: the range lies within the boxes, and the processor has AVX (the caller's),
            // so the query's lanes were set (`Query::new`).
            return unsafe { self.scan(range, |first, last| self.overlaps_lanes(&query.lanes, first, last), hit) };
        }
        self.for_each_overlap(&query.bbox, range, hit)
    }

    /// [`Self::for_each_overlap`] by vector code, `bits(first, last)` the overlaps of boxes
    /// `first..last` (eight at a time with AVX, four otherwise): up to 64 boxes' overlaps
    /// gathered as bits by a loop with no call inside, then reported. `hit` is a call, which
    /// clobbers every vector register: were it made inside the scan, the query and the columns
    /// would be saved and reloaded around it.
    ///
    /// # Safety
    /// `range.end <= self.len()`, and `bits` safe for every `last <= range.end`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn scan(&self, range: Range<usize>, bits: impl Fn(usize, usize) -> u64, mut hit: impl FnMut(usize)) {
        let (mut first, end) = (range.start, range.end);
        while first < end {
            let last = end.min(first + 64);
            let mut found = bits(first, last);
            while found != 0 {
                hit(first + found.trailing_zeros() as usize);
                found &= found - 1;
            }
            first = last;
        }
    }

    /// The overlaps with `query` of boxes `first..last` (at most 64), as bits from bit 0, four
    /// boxes at a time.
    ///
    /// # Safety
    /// `last <= self.len()`.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn overlaps_sse2(&self, query: &CompactBox, first: usize, last: usize) -> u64 {
        use std::arch::x86_64::*;
        let q_low = query.low.map(|v| _mm_set1_ps(v));
        let q_high = query.high.map(|v| _mm_set1_ps(v));
        let (low, high) = (self.low.each_ref().map(|c| c.as_ptr()), self.high.each_ref().map(|c| c.as_ptr()));
        // SAFETY: every load reads four floats at j..j + 4 <= last + PADDING <= len + PADDING,
        // the length of a column.
        let group = |j: usize| unsafe {
            let mut all = _mm_castsi128_ps(_mm_set1_epi32(-1));
            for axis in 0..3 {
                let box_low = _mm_loadu_ps(low[axis].add(j));
                let box_high = _mm_loadu_ps(high[axis].add(j));
                // Ordered comparisons: a NaN fails them, as it fails `<=`.
                let overlap = _mm_and_ps(_mm_cmple_ps(q_low[axis], box_high), _mm_cmple_ps(box_low, q_high[axis]));
                all = _mm_and_ps(all, overlap);
            }
            _mm_movemask_ps(all) as u64
        };
        chunk_bits::<4>(first, last, group)
    }

    /// [`Self::overlaps_sse2`] eight boxes at a time: the scan's instructions halve on the
    /// longer runs of neighbour cells.
    ///
    /// # Safety
    /// The processor has AVX, and `last <= self.len()`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn overlaps_avx(&self, query: &CompactBox, first: usize, last: usize) -> u64 {
        // SAFETY: the caller's.
        unsafe { self.overlaps_lanes(&lanes_of(query), first, last) }
    }

    /// [`Self::overlaps_avx`] of a query already in lanes ([`lanes_of`]).
    ///
    /// # Safety
    /// The processor has AVX, and `last <= self.len()`.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn overlaps_lanes(&self, query: &[std::arch::x86_64::__m256; 6], first: usize, last: usize) -> u64 {
        use std::arch::x86_64::*;
        let (q_low, q_high) = ([query[0], query[1], query[2]], [query[3], query[4], query[5]]);
        let (low, high) = (self.low.each_ref().map(|c| c.as_ptr()), self.high.each_ref().map(|c| c.as_ptr()));
        // SAFETY: every load reads eight floats at j..j + 8 <= last + PADDING <= len + PADDING,
        // the length of a column.
        let group = |j: usize| unsafe {
            let mut all = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
            for axis in 0..3 {
                let box_low = _mm256_loadu_ps(low[axis].add(j));
                let box_high = _mm256_loadu_ps(high[axis].add(j));
                // Ordered, non-signalling comparisons: a NaN fails them, as it fails `<=`. The
                // stored box second in both (`q_high >= box_low` is `box_low <= q_high`), so each
                // load is the comparison's memory operand rather than an instruction of its own.
                let overlap = _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LE_OQ>(q_low[axis], box_high),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(q_high[axis], box_low),
                );
                all = _mm256_and_ps(all, overlap);
            }
            _mm256_movemask_ps(all) as u64
        };
        chunk_bits::<8>(first, last, group)
    }
}

/// A query box made ready for the scans of many runs ([`BoxColumns::for_each_overlap_of`]): on
/// x86_64 with AVX, its bounds broadcast into lanes once rather than at every run.
#[derive(Clone, Copy)]
pub struct Query {
    bbox: CompactBox,
    #[cfg(target_arch = "x86_64")]
    lanes: [std::arch::x86_64::__m256; 6],
}

impl Query {
    /// `bbox` ready for scans with AVX when `AVX`.
    ///
    /// # Safety
    /// `AVX` only where the processor has AVX.
    #[inline(always)]
    pub unsafe fn new<const AVX: bool>(bbox: CompactBox) -> Query {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: the processor has AVX when `AVX` (the caller's); zeros are lanes too, and
            // never read without AVX.
            let lanes = unsafe {
                if AVX {
                    lanes_of(&bbox)
                } else {
                    std::mem::zeroed()
                }
            };
            Query { bbox, lanes }
        }
        #[cfg(not(target_arch = "x86_64"))]
        Query { bbox }
    }
}

/// `query`'s low then high bounds, each broadcast into the eight lanes of a register.
///
/// # Safety
/// The processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn lanes_of(query: &CompactBox) -> [std::arch::x86_64::__m256; 6] {
    use std::arch::x86_64::_mm256_set1_ps;
    let ([lx, ly, lz], [hx, hy, hz]) = (query.low, query.high);
    [lx, ly, lz, hx, hy, hz].map(|v| _mm256_set1_ps(v))
}

/// The bits of boxes `first..last` (at most 64), `group(j)` giving those of boxes
/// `j..j + LANES`; the boxes past `last` (the padding, or boxes not asked for) masked off.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn chunk_bits<const LANES: usize>(first: usize, last: usize, group: impl Fn(usize) -> u64) -> u64 {
    // Each group's bits enter at the top and the earlier ones move down a group: two shifts by
    // constants, where shifting each group up to its place took a variable count (moved to `cl`
    // and masked).
    let (mut found, mut k, count) = (0u64, 0, last - first);
    while k < count {
        found = (found >> LANES) | (group(first + k) << (64 - LANES));
        k += LANES;
    }
    // The boxes past `last` (the last group's top bits) shifted out, then the first to bit 0.
    (found << (k - count)) >> (64 - count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn the_vector_scan_reports_what_the_scalar_test_accepts() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let random_box = |rng: &mut rand_chacha::ChaCha8Rng| {
            let low: [f32; 3] = std::array::from_fn(|_| rng.random_range(0.0..10.0));
            let high: [f32; 3] = std::array::from_fn(|k| low[k] + rng.random_range(0.0..3.0));
            CompactBox { low, high }
        };
        let stored: Vec<CompactBox> = (0..203).map(|_| random_box(&mut rng)).collect();
        let mut boxes = BoxColumns::default();
        boxes.resize(stored.len());
        for (i, b) in stored.iter().enumerate() {
            boxes.set(i, *b);
        }
        for _ in 0..200 {
            let query = random_box(&mut rng);
            let from = rng.random_range(0..stored.len());
            let to = rng.random_range(from..=stored.len());
            let mut found = Vec::new();
            boxes.for_each_overlap(&query, from..to, |j| found.push(j));
            let expected: Vec<usize> = (from..to).filter(|&j| query.overlaps(&stored[j])).collect();
            assert_eq!(found, expected);
            // The four-wide scan too, which the dispatch skips on a processor with AVX.
            #[cfg(target_arch = "x86_64")]
            {
                found.clear();
                // SAFETY: `to` is at most the boxes' count; no AVX asked for.
                unsafe { boxes.scan(from..to, |f, l| boxes.overlaps_sse2(&query, f, l), |j| found.push(j)) };
                assert_eq!(found, expected);
            }
        }
        // Touching faces overlap; a NaN never does.
        let unit = CompactBox { low: [0.0; 3], high: [1.0; 3] };
        let touching = CompactBox { low: [1.0, 0.0, 0.0], high: [2.0, 1.0, 1.0] };
        let nan = CompactBox { low: [f32::NAN, 0.0, 0.0], high: [1.0; 3] };
        let mut boxes = BoxColumns::default();
        boxes.resize(5);
        for (i, b) in [touching, nan, touching, nan, touching].into_iter().enumerate() {
            boxes.set(i, b);
        }
        let mut found = Vec::new();
        boxes.for_each_overlap(&unit, 0..5, |j| found.push(j));
        assert_eq!(found, [0, 2, 4]);
    }

    #[test]
    fn parts_write_disjoint_ranges() {
        let mut boxes = BoxColumns::default();
        boxes.resize(10);
        let b = |x: f32| CompactBox { low: [x; 3], high: [x + 1.0; 3] };
        for (p, mut part) in boxes.parts_mut(&[3, 7]).into_iter().enumerate() {
            part.set(0, b(p as f32));
        }
        assert_eq!([boxes.get(0), boxes.get(3), boxes.get(7)], [b(0.0), b(1.0), b(2.0)]);
    }
}
