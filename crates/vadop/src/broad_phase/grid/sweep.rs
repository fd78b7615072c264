//! The grid's pair sweep at a window's start: each cell of a level against itself and 13 of its
//! neighbours, each piece against the coarser levels' cells that can hold an overlapping box,
//! the boxes scanned by [`BoxColumns`](crate::broad_phase::box_columns::BoxColumns) and each
//! candidate handed to a [`Candidates`]. It reads the binned pieces alone and writes nothing of
//! the grid, so workers sweep slabs of cells side by side.

use super::Grid;
use crate::broad_phase::box_columns::Query;
use crate::broad_phase::candidates::{Candidates, Reporting};
use crate::broad_phase::proxy::Reported;
use crate::parallel::Workers;
use crate::window::Window;

impl Grid {
    /// [`crate::broad_phase::BroadPhase::find_pairs`] with each worker's candidates given to `candidates(reporting)`.
    pub(super) fn sweep<'a, T: Send, C: Candidates>(
        &'a self,
        workers: &Workers,
        predict: impl Fn(Reported, Reported, Window, C::Kept, &mut Vec<T>) + Sync + Send,
        out: &mut Vec<T>,
        candidates: impl Fn(Reporting<'a>) -> C + Sync,
    ) -> u64 {
        let mut count = 0;
        #[cfg(target_arch = "x86_64")]
        let avx = std::arch::is_x86_feature_detected!("avx");
        for k in 0..self.levels.len() {
            let reporting = Reporting { owners: &self.owners, motions: &self.motions };
            let counts = workers.extend_ranges(self.levels[k].dims[0], out, |slabs, found| {
                let (mut reported, mut candidates) = (0u64, candidates(reporting));
                let mut report = |x: Reported, y: Reported, window, kept| {
                    reported += 1;
                    predict(x, y, window, kept, found);
                };
                #[cfg(target_arch = "x86_64")]
                if avx {
                    // SAFETY: the processor has AVX.
                    unsafe { self.slab_pairs_avx(k, slabs, &mut candidates, &mut report) };
                    candidates.finish(&mut report);
                    return reported + candidates.cleared();
                }
                // SAFETY: no AVX asked for.
                unsafe { self.slab_pairs::<false, C>(k, slabs, &mut candidates, &mut report) };
                candidates.finish(&mut report);
                reported + candidates.cleared()
            });
            count += counts.iter().sum::<u64>();
        }
        count
    }

    /// [`Self::slab_pairs`] compiled for AVX, so the box scans' vector code inlines into the
    /// sweep: each scan's query is set up once rather than at every call of an out-of-line
    /// scan, which the short runs of neighbour cells paid for once per few boxes.
    ///
    /// # Safety
    /// The processor has AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn slab_pairs_avx<C: Candidates>(
        &self,
        k: usize,
        slabs: std::ops::Range<usize>,
        candidates: &mut C,
        report: &mut impl FnMut(Reported, Reported, Window, C::Kept),
    ) {
        // SAFETY: the caller's.
        unsafe { self.slab_pairs::<true, C>(k, slabs, candidates, report) }
    }

    /// Hands `candidates` every candidate pair found from the cells of level `k` with x in
    /// `slabs` (each cell against itself and 13 of its neighbours, each piece against the
    /// coarser levels), with `report` for the pairs it passes on; the boxes scanned with AVX
    /// when `AVX`.
    ///
    /// # Safety
    /// `AVX` only where the processor has AVX.
    #[inline(always)]
    unsafe fn slab_pairs<const AVX: bool, C: Candidates>(
        &self,
        k: usize,
        slabs: std::ops::Range<usize>,
        candidates: &mut C,
        report: &mut impl FnMut(Reported, Reported, Window, C::Kept),
    ) {
        // Half of the 26 neighbours, so each pair of adjacent cells is swept once. Cells along z
        // are adjacent in memory, so the 13 cells are 5 contiguous runs: the next cell of this
        // column, then z - 1 ..= z + 1 of the columns (x, y + 1) and (x + 1, y - 1 ..= y + 1);
        // column offsets are stored +1 in y so that -1 needs no signed arithmetic.
        const COLUMNS: [[usize; 2]; 4] = [[0, 2], [1, 0], [1, 1], [1, 2]];
        let boxes = &self.boxes;
        let level = &self.levels[k];
        let [nx, ny, nz] = level.dims;
        let starts = &level.cell_start[..];
        for x in slabs {
            for y in 0..ny {
                for z in 0..nz {
                    let c = (x * ny + y) * nz + z;
                    let (from, to) = (level.first + starts[c] as usize, level.first + starts[c + 1] as usize);
                    if from == to {
                        continue;
                    }
                    // The neighbours' runs of binned slots: the columns, each with the axes a
                    // box must reach across into it (as bits: x 1, y 2) and where the run ends
                    // when the box does not reach across z. The next cell along z follows this
                    // one's slots, so it extends this cell's own run.
                    let mut runs = [(0, 0, 0, 0); 4];
                    let mut count = 0;
                    let next_z_end = if z + 1 < nz { level.first + starts[c + 2] as usize } else { to };
                    for [dx, dy] in COLUMNS {
                        let (x2, y2) = (x + dx, (y + dy).wrapping_sub(1));
                        if x2 >= nx || y2 >= ny {
                            continue;
                        }
                        let column = (x2 * ny + y2) * nz;
                        let (z_from, z_to) = (z.saturating_sub(1), (z + 1).min(nz - 1));
                        let from = level.first + starts[column + z_from] as usize;
                        let within = level.first + starts[column + z + 1] as usize;
                        let across = level.first + starts[column + z_to + 1] as usize;
                        runs[count] = (from, within, across, dx | usize::from(dy == 2) << 1);
                        count += 1;
                    }
                    for a in from..to {
                        let bbox = boxes.get(a);
                        // SAFETY (here and below): `AVX` only with AVX, the caller's.
                        let query = unsafe { Query::new::<AVX>(bbox) };
                        // A box in a neighbour lies past this cell's upper face on each axis that
                        // leads there (its low corner does, and cells are never smaller than a
                        // box): only a box reaching across those faces can overlap it, and the
                        // next cell along z of a column only one reaching across z. The
                        // coordinate is the binning's own, monotonic in the value, so no overlap
                        // is skipped. Boxes of this level reach across in a fraction of cases
                        // near their extent over the cell's, which this saves sweeping the rest.
                        let reach = level.coordinates(bbox.corners().1);
                        let beyond = usize::from(reach[0] > x) | usize::from(reach[1] > y) << 1;
                        let across_z = reach[2] > z;
                        unsafe {
                            boxes.for_each_overlap_of::<AVX>(
                                &query,
                                a + 1..if across_z { next_z_end } else { to },
                                |b| candidates.overlap(a, b, report),
                            )
                        };
                        for &(other_from, within, across, faces) in &runs[..count] {
                            if beyond & faces == faces {
                                let other_to = if across_z { across } else { within };
                                unsafe {
                                    boxes.for_each_overlap_of::<AVX>(&query, other_from..other_to, |b| {
                                        candidates.overlap(a, b, report)
                                    })
                                };
                            }
                        }
                        // Coarser levels: the cells that can hold an overlapping box there.
                        let (low, high) = bbox.corners();
                        for coarser in &self.levels[k + 1..] {
                            for c2 in coarser.cells_near(low, high) {
                                unsafe {
                                    boxes.for_each_overlap_of::<AVX>(&query, coarser.run(c2), |b| {
                                        candidates.overlap(a, b, report)
                                    })
                                };
                            }
                        }
                    }
                }
            }
        }
    }
}
