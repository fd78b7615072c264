//! Hierarchical uniform grid over swept boxes, with long paths cut into pieces.
//!
//! It owns the grid levels, the binned pieces of the window and the pieces entered since. A
//! body's path over the window is cut into pieces, each a short stretch of the path in time with
//! the box that holds the body over it, so a fast or diagonal path is bounded by a chain of small
//! boxes instead of one huge one, and its cost grows with its length in cells. A piece goes to the
//! level whose cells are at least as large as its box (levels double in size from a base cell
//! sized to the typical body), into the cell holding its low corner, found by index: no hashing.
//! Two overlapping boxes of one level then lie in the same or adjacent cells, so the window's
//! pairs come from each cell against itself and 13 of its neighbours, and from each piece against
//! the few cells of coarser levels that can hold an overlapping box. Boxes are kept in single
//! precision relative to the box's low corner (the grid's origin), rounded outwards, so they stay conservative while a
//! cell's pieces fit a few cache lines, and each piece's motion is copied beside it in cell order:
//! a candidate pair reaches the narrow phase without a trip to memory. A body that changes velocity mid-window gets fresh pieces
//! on per-cell linked lists, and its query visits only the cells its new path can reach. A window's
//! start may bin bodies' foreseen paths (after their first wall bounce) beside the proxies, each a
//! proxy of its own with its stamp and motion ([`BroadPhase::prepare_foreseen`]). It never reads
//! shapes or computes contact times.

mod plan;
mod sweep;

use super::box_columns::BoxColumns;
use super::candidates::Owner;
#[cfg(target_arch = "x86_64")]
use super::candidates::Screened;
use super::{screened_one_by_one, BroadPhase, PairScreen, PrepareCounts};
use crate::bodies::BodyState;
use crate::broad_phase::proxy::{sampled_quantile, CompactBox, Foreseen, Path, Proxies, Reported};
use crate::memory::prefetch;
use crate::parallel::{split_at_points, Workers};
use crate::window::Window;
use glam::DVec3;
use plan::{add_pieces, BinnedPaths, CountPieces, PieceRule, PieceSink, PlanPass, StorePieces};

/// Base cells are this many times the median swept-box extent of the window's proxies (and at
/// least two typical diameters): small enough that a query in a dense gas meets few bodies, large
/// enough that a typical path stays one piece. In a calm window (few re-tests expected) larger
/// cells pay: fewer pieces to bin and fewer cells to sweep, and the dearer queries are rare.
/// Measured together with the pipeline's calm windows (see `pipeline::CALM_UPDATES`).
const BASE_CELL_EXTENTS: f64 = 1.5;
const CALM_BASE_CELL_EXTENTS: f64 = 2.0;
/// A level holds at most this many cells per piece (and at least [`MIN_CELLS`]), so memory stays
/// linear in the bodies however sparse the scene.
const CELLS_PER_PIECE: f64 = 2.0;
const MIN_CELLS: f64 = 64.0;
/// Most cells along one axis of a level.
const MAX_CELLS_PER_AXIS: f64 = (1u32 << 20) as f64;
/// On more than one worker the binning's count is shared out by paths, each worker counting its
/// share's pieces in a count of every cell of its own (4 bytes a cell), while the workers have
/// at most one cell for this many paths between them: a byte a path at most. Past that (many
/// cells beside the pieces) each worker counts the cells it owns, going through every path.
const SHARED_COUNTS_PER_PATH: usize = 4;
/// End of a late list.
const NONE: u32 = u32::MAX;

/// A stretch of one body's path: the body is inside the box over its window.
#[derive(Debug, Clone, Copy, Default)]
struct Entry {
    bbox: CompactBox,
    body: u32,
    stamp: u32,
}

impl Entry {
    #[inline]
    fn overlaps(&self, other: &Entry) -> bool {
        self.bbox.overlaps(&other.bbox)
    }
}

/// One level of the hierarchy: cubic cells of one size.
#[derive(Debug, Default)]
struct Level {
    /// log2 of the nominal cell size in base cells.
    exponent: i32,
    cell: f64,
    inverse: f64,
    dims: [usize; 3],
    /// The last cell coordinate along each axis (`dims - 1`), as a float.
    last: [f64; 3],
    /// Binned pieces of cell c: slots `first + cell_start[c]..first + cell_start[c + 1]`.
    first: usize,
    /// Cells of the levels before this one: its cell c is cell `cells_before + c` of the grid.
    cells_before: usize,
    cell_start: Vec<u32>,
    /// Head of each cell's list of late pieces in `Grid::late`.
    late_head: Vec<u32>,
    /// Pieces binned into this level at the window's start.
    count: usize,
}

impl Level {
    /// Sizes the level for `pieces` pieces in a box of `extent`, reusing its storage.
    fn reset(&mut self, exponent: i32, base_cell: f64, pieces: usize, extent: DVec3) {
        let nominal = base_cell * 2f64.powi(exponent);
        let most_cells = (CELLS_PER_PIECE * pieces as f64).max(MIN_CELLS);
        let cell = nominal
            .max((extent.x * extent.y * extent.z / most_cells).cbrt())
            .max(extent.max_element() / MAX_CELLS_PER_AXIS);
        self.exponent = exponent;
        self.cell = cell;
        self.inverse = 1.0 / cell;
        self.dims = [0, 1, 2].map(|k| ((extent[k] / cell).floor() as usize + 1).max(1));
        self.last = self.dims.map(|d| (d - 1) as f64);
        let cells = self.dims.iter().product::<usize>();
        self.cell_start.clear();
        self.cell_start.resize(cells + 1, 0);
        self.late_head.clear();
        self.late_head.resize(cells, NONE);
        self.count = 0;
    }

    #[inline]
    fn coordinate(&self, value: f64, axis: usize) -> usize {
        // Clamped first (`max` takes NaN to 0), so the truncation, the floor of a non-negative
        // value, needs none of the checks a saturating `as` makes: binning and every query pay
        // for this conversion, three times per box.
        let clamped = (value * self.inverse).max(0.0).min(self.last[axis]);
        // SAFETY: `clamped` is finite and within [0, 2^20], so it fits an i32: a signed
        // conversion, one instruction where an unsigned one takes six for two lanes.
        unsafe { clamped.to_int_unchecked::<i32>() as usize }
    }

    /// Cell coordinates of a point given relative to the grid origin.
    #[inline]
    fn coordinates(&self, p: DVec3) -> [usize; 3] {
        [self.coordinate(p.x, 0), self.coordinate(p.y, 1), self.coordinate(p.z, 2)]
    }

    #[inline]
    fn index(&self, c: [usize; 3]) -> usize {
        (c[0] * self.dims[1] + c[1]) * self.dims[2] + c[2]
    }

    /// The cells that can hold the low corner of a box of this level overlapping `[low, high]`
    /// (given relative to the grid origin): its low corner lies within one cell below `low`.
    #[inline]
    fn cells_near(&self, low: DVec3, high: DVec3) -> impl Iterator<Item = usize> + use<> {
        self.columns_near(low, high).flat_map(|(first, last)| first..=last)
    }

    /// The columns of cells that can hold the low corner of a box of this level overlapping
    /// `[low, high]` (as [`Self::cells_near`]), each as its first and last cell: cells along z
    /// are adjacent, so a column's binned pieces are one run of slots.
    #[inline]
    fn columns_near(&self, low: DVec3, high: DVec3) -> impl Iterator<Item = (usize, usize)> + use<> {
        let a = self.coordinates(low - self.cell);
        let b = self.coordinates(high);
        let [_, ny, nz] = self.dims;
        (a[0]..=b[0]).flat_map(move |x| {
            (a[1]..=b[1]).map(move |y| {
                let column = (x * ny + y) * nz;
                (column + a[2], column + b[2])
            })
        })
    }

    /// The binned pieces of cell `c`, as a range of slots.
    #[inline]
    fn run(&self, c: usize) -> std::ops::Range<usize> {
        self.first + self.cell_start[c] as usize..self.first + self.cell_start[c + 1] as usize
    }
}

/// The grid broad phase.
#[derive(Debug)]
pub struct Grid {
    /// Size of the box the bodies live in; boxes are relative to its low corner.
    extent: DVec3,
    base_cell: f64,
    /// Levels in use, ascending by exponent; `spare` keeps the storage of unused ones.
    levels: Vec<Level>,
    spare: Vec<Level>,
    /// This window's pieces, by level then cell: the box (by coordinate, for the vector sweep),
    /// owner and window, and motion of each.
    boxes: BoxColumns,
    owners: Vec<Owner>,
    motions: Vec<BodyState>,
    /// Pieces entered mid-window, chained per cell: the piece, its window, the next in the chain.
    late: Vec<(Entry, Window, u32)>,
    late_motions: Vec<BodyState>,
    /// Scratch: each body's piece count and level, or for a single piece its cell (numbered
    /// across levels); pieces per level exponent; one body's pieces.
    plan: Vec<(u32, u32)>,
    per_exponent: Vec<(i32, usize)>,
    level_of: Vec<u32>,
    /// Scratch of the binning on one worker: the paths cut into more than one piece.
    cut: Vec<u32>,
    extents: Vec<f64>,
    pieces: Vec<(CompactBox, Window)>,
    /// Scratch of a query: the runs of binned slots it reaches, then the slots whose boxes
    /// overlap (see [`Grid::for_each_overlapping`]).
    runs: Vec<(u32, u32)>,
    hits: Vec<u32>,
    /// Scratch of the binning: each cell's piece count, then the slot of its next piece.
    next_slot: Vec<u32>,
    /// Scratch of the binning on more than one worker: each cell's piece count among the paths
    /// of each worker, while they are few.
    counts: Vec<u32>,
    /// The binned pieces include foreseen paths (see [`BroadPhase::prepare_foreseen`]), and stay
    /// as the window's start left them.
    foreseen: bool,
}

impl Grid {
    /// An empty grid over the box `[min, max]` the bodies live in.
    pub fn new(min: DVec3, max: DVec3) -> Grid {
        Grid {
            extent: (max - min).max(DVec3::splat(f64::MIN_POSITIVE)),
            base_cell: 1.0,
            levels: Vec::new(),
            spare: Vec::new(),
            boxes: BoxColumns::default(),
            owners: Vec::new(),
            motions: Vec::new(),
            late: Vec::new(),
            late_motions: Vec::new(),
            plan: Vec::new(),
            per_exponent: Vec::new(),
            level_of: Vec::new(),
            cut: Vec::new(),
            extents: Vec::new(),
            pieces: Vec::new(),
            runs: Vec::new(),
            hits: Vec::new(),
            next_slot: Vec::new(),
            counts: Vec::new(),
            foreseen: false,
        }
    }

    /// What cutting paths into pieces reads of the grid.
    #[inline]
    fn piece_rule(&self) -> PieceRule {
        PieceRule { base_cell: self.base_cell, largest_side: self.extent.max_element() }
    }

    /// Calls `f` with the box and window of every piece of `path`, cut into `count` pieces.
    #[inline]
    fn for_each_piece(proxies: Proxies, path: &Path, count: u32, mut f: impl FnMut(CompactBox, Window)) {
        let Path { origin, velocity, radius, window, bbox } = *path;
        if count == 1 {
            f(bbox, window);
            return;
        }
        let step = window.duration() / count as f64;
        let (mut from, mut start) = (origin, window.start);
        for k in 1..=count {
            let end = if k == count { window.end } else { window.start + step * k as f64 };
            let to = origin + velocity * (end - window.start);
            f(proxies.compact_swept_box(from, to, radius), Window::new(start, end));
            (from, start) = (to, end);
        }
    }

    /// Hands `sink` the path, cell, box and window of every piece, in path order, whose cell
    /// (numbered across levels) is in `owned`, per the paths' `plan`: the proxies' first, then
    /// the foreseen paths', each in a loop of its own that knows which it reads.
    #[inline(always)]
    fn for_each_owned_piece(
        levels: &[Level],
        plan: &[(u32, u32)],
        paths: BinnedPaths,
        owned: std::ops::Range<usize>,
        sink: &mut impl PieceSink,
    ) {
        let slots = paths.proxies.slots();
        Grid::for_each_owned_piece_of::<false>(levels, &plan[..slots], 0, paths, owned.clone(), sink);
        Grid::for_each_owned_piece_of::<true>(levels, &plan[slots..], slots, paths, owned, sink);
    }

    /// [`Self::for_each_owned_piece`] of the paths from `first` on, the `plan` of each, all
    /// foreseen ones when `AHEAD` and all proxies when not. A constant of the type rather than an
    /// argument: the compiler made one loop of the two calls, the flag read back for each piece.
    #[inline(always)]
    fn for_each_owned_piece_of<const AHEAD: bool>(
        levels: &[Level],
        plan: &[(u32, u32)],
        first: usize,
        paths: BinnedPaths,
        owned: std::ops::Range<usize>,
        sink: &mut impl PieceSink,
    ) {
        for (k, &(count, level_or_cell)) in plan.iter().enumerate() {
            let i = first + k;
            if count == 0 {
                continue;
            }
            if count == 1 {
                let cell = level_or_cell as usize;
                if owned.contains(&cell) {
                    sink.whole(i, cell, AHEAD);
                }
                continue;
            }
            Grid::for_each_owned_piece_cut::<AHEAD>(&levels[level_or_cell as usize], i, count, paths, &owned, sink);
        }
    }

    /// Hands `sink` the pieces, in order, whose cell is in `owned` of path `i` (a foreseen one
    /// when `AHEAD`), cut into `count` pieces of `level`.
    #[inline(always)]
    fn for_each_owned_piece_cut<const AHEAD: bool>(
        level: &Level,
        i: usize,
        count: u32,
        paths: BinnedPaths,
        owned: &std::ops::Range<usize>,
        sink: &mut impl PieceSink,
    ) {
        // The pieces' low corners lie in the path's box, so their cells lie between the cells of
        // its corners: cells are numbered in x, then y, then z order.
        let (low, high) = paths.bbox(i, AHEAD).corners();
        let (first, last) = (level.index(level.coordinates(low)), level.index(level.coordinates(high)));
        if level.cells_before + last < owned.start || level.cells_before + first >= owned.end {
            return;
        }
        Grid::for_each_piece(paths.proxies, &paths.path(i, AHEAD), count, |bbox, window| {
            let cell = level.cells_before + level.index(level.coordinates(bbox.corners().0));
            if owned.contains(&cell) {
                sink.piece(i, cell, bbox, window, AHEAD);
            }
        });
    }

    /// [`Self::for_each_owned_piece_cut`] of path `i`, cut into `count` pieces of `level`,
    /// asking whether it is a foreseen one: for loops over cut paths of both kinds, where the
    /// answer is no constant.
    #[inline(always)]
    fn for_each_cut_piece(
        (level, i, count): (&Level, usize, u32),
        paths: BinnedPaths,
        owned: &std::ops::Range<usize>,
        sink: &mut impl PieceSink,
    ) {
        if paths.is_ahead(i) {
            Grid::for_each_owned_piece_cut::<true>(level, i, count, paths, owned, sink);
        } else {
            Grid::for_each_owned_piece_cut::<false>(level, i, count, paths, owned, sink);
        }
    }

    /// Names in each path's `plan` (paths `offset..`) its level, by `level_of` its exponent less
    /// `lowest`, or for a single piece its cell (numbered across levels), then calls
    /// `placed(path, plan)` for each path with pieces.
    #[inline(always)]
    fn place_paths(
        (levels, level_of, lowest): (&[Level], &[u32], i32),
        paths: BinnedPaths,
        offset: usize,
        plan: &mut [(u32, u32)],
        mut placed: impl FnMut(usize, (u32, u32)),
    ) {
        for (k, entry) in plan.iter_mut().enumerate() {
            if entry.0 == 0 {
                continue;
            }
            // Every counted path's exponent is in the list, so it is its own level's.
            entry.1 = level_of[(entry.1 as i32 - lowest) as usize];
            let i = offset + k;
            if entry.0 == 1 {
                let level = &levels[entry.1 as usize];
                let cell = level.index(level.coordinates(paths.bbox(i, paths.is_ahead(i)).corners().0));
                entry.1 = (level.cells_before + cell) as u32;
            }
            placed(i, *entry);
        }
    }

    /// The level for pieces of `exponent`: the one of that exponent or the next coarser (cells
    /// are never smaller than nominal), created when the pieces are larger than all.
    fn level_for(&mut self, exponent: i32) -> usize {
        if let Some(k) = self.levels.iter().position(|l| l.exponent >= exponent) {
            return k;
        }
        let mut level = self.spare.pop().unwrap_or_default();
        level.reset(exponent, self.base_cell, 1, self.extent);
        level.first = self.owners.len();
        self.levels.push(level);
        self.levels.len() - 1
    }

    /// [`BroadPhase::query`] (reporting the pieces of foreseen paths still to come too when
    /// `foreseen`), leaving the body's new pieces in `self.pieces`; returns the exponent of the
    /// level they fit, so an entry need not plan them again.
    fn query_pieces(
        &mut self,
        body: u32,
        proxies: Proxies,
        (skip, foreseen): (Option<u32>, bool),
        mut report: impl FnMut(Reported, Window),
    ) -> i32 {
        let mut pieces = std::mem::take(&mut self.pieces);
        pieces.clear();
        let path = proxies.path(body as usize);
        let (count, exponent) = self.piece_rule().plan(&path);
        Grid::for_each_piece(proxies, &path, count, |bbox, window| pieces.push((bbox, window)));
        for &(bbox, window) in &pieces {
            let piece = Entry { bbox, body, stamp: 0 };
            for k in 0..self.levels.len() {
                self.for_each_overlapping(k, &piece, proxies, foreseen, |other, other_window, motion| {
                    if other.body != body && Some(other.body) != skip {
                        let common = window.intersect(other_window);
                        if !common.is_empty() {
                            report(Reported { body: other.body, stamp: other.stamp, state: motion }, common);
                        }
                    }
                });
            }
        }
        self.pieces = pieces;
        exponent
    }

    /// Calls `visit(entry, window, motion)` for every current piece, binned or late, of level
    /// `k` whose box overlaps `query` (and every binned piece of a foreseen path still to come
    /// when `foreseen`), unlinking the stale late pieces it passes, so a busy cell's list stays
    /// short.
    #[inline]
    fn for_each_overlapping(
        &mut self,
        k: usize,
        query: &Entry,
        proxies: Proxies,
        foreseen: bool,
        mut visit: impl FnMut(&Entry, Window, &BodyState),
    ) {
        let Grid { levels, late, late_motions, boxes, owners, motions, runs, hits, .. } = self;
        let level = &mut levels[k];
        let (low, high) = query.bbox.corners();
        // In phases, each a loop of independent loads, rather than column by column: a query
        // meets a few memory misses per column (its cell bounds, its boxes, their owners and
        // stamps), and a phase lets the processor wait for all of a kind at once instead of for
        // each in turn. That cut a re-test's cost by about an eighth at n = 10^5 (BENCHMARKS.md).
        runs.clear();
        for (first, last) in level.columns_near(low, high) {
            // The binned pieces of cells z = a..=b of a column are one run.
            runs.push((level.cell_start[first], level.cell_start[last + 1]));
            for &head in &level.late_head[first..=last] {
                if let Some(first) = late.get(head as usize) {
                    prefetch(first);
                }
            }
        }
        hits.clear();
        for &(start, end) in runs.iter() {
            let run = level.first + start as usize..level.first + end as usize;
            boxes.for_each_overlap(&query.bbox, run, |e| hits.push(e as u32));
        }
        for &e in hits.iter() {
            prefetch(&owners[e as usize]);
            prefetch(&motions[e as usize]);
        }
        for &e in hits.iter() {
            proxies.prefetch_stamp(owners[e as usize].body as usize);
        }
        for &e in hits.iter() {
            let e = e as usize;
            let Owner { body, stamp, window } = owners[e];
            if proxies.is_current(body as usize, stamp) || (foreseen && proxies.is_foreseen(body as usize, stamp)) {
                visit(&Entry { bbox: boxes.get(e), body, stamp }, window, &motions[e]);
            }
        }
        for (first, last) in level.columns_near(low, high) {
            for c in first..=last {
                let (mut previous, mut current) = (NONE, level.late_head[c]);
                while current != NONE {
                    let (entry, window, next) = late[current as usize];
                    if proxies.is_current(entry.body as usize, entry.stamp) {
                        if query.overlaps(&entry) {
                            visit(&entry, window, &late_motions[current as usize]);
                        }
                        previous = current;
                    } else if previous == NONE {
                        level.late_head[c] = next;
                    } else {
                        late[previous as usize].2 = next;
                    }
                    current = next;
                }
            }
        }
    }

    /// Enters body `body`'s pieces, just built by [`Self::query_pieces`] into the level of
    /// `exponent`.
    fn enter_pieces(&mut self, body: u32, proxies: Proxies, exponent: i32) {
        let i = body as usize;
        let k = self.level_for(exponent);
        let (boxes, owners, motions) = (&mut self.boxes, &mut self.owners, &mut self.motions);
        let level = &mut self.levels[k];
        for n in 0..self.pieces.len() {
            let (bbox, window) = self.pieces[n];
            let cell = level.index(level.coordinates(bbox.corners().0));
            let entry = Entry { bbox, body, stamp: proxies.stamp(i) };
            // One piece in a cell that holds a binned piece of the body (of a path it left: its
            // stamp has moved on): replace that one where it lies, rather than keep a body's
            // slot by id (4 bytes a body) to find it. A cell holds a handful of pieces. Not among
            // foreseen paths: the piece found could be the body's foreseen one.
            if self.pieces.len() == 1 && !self.foreseen {
                if let Some(old) = level.run(cell).find(|&e| owners[e].body == body) {
                    owners[old] = Owner { body, stamp: entry.stamp, window };
                    boxes.set(old, bbox);
                    motions[old] = *proxies.state(i);
                    continue;
                }
            }
            self.late.push((entry, window, level.late_head[cell]));
            self.late_motions.push(*proxies.state(i));
            level.late_head[cell] = (self.late.len() - 1) as u32;
        }
    }
}

impl Grid {
    /// [`BroadPhase::prepare`] of `paths`: the proxies, then any foreseen paths.
    fn bin(&mut self, paths: BinnedPaths, workers: &Workers) -> PrepareCounts {
        let proxies = paths.proxies;
        // Base cell from the median extent of the swept boxes: robust to a few giant, tiny or
        // fast bodies.
        let sampled = sampled_quantile(
            proxies.slots(),
            0.5,
            |i| proxies.is_live(i).then(|| proxies.bbox(i).extent()),
            &mut self.extents,
        );
        if let Some(median) = sampled {
            let extents = if proxies.calm() { CALM_BASE_CELL_EXTENTS } else { BASE_CELL_EXTENTS };
            self.base_cell = (extents * median).max(4.0 * proxies.typical_radius());
        }
        // Pass 1: each path's piece count and level exponent, and the pieces per exponent.
        let mut plan = std::mem::take(&mut self.plan);
        plan.clear();
        plan.resize(paths.len(), (0, 0));
        let rule = self.piece_rule();
        // Whether the paths bend, asked once a pass rather than once a path. The loop is written
        // once for each answer, a constant within it: one loop over `pull_free` itself read 1.8 %
        // more instructions a detect frame (BENCHMARKS.md, twenty-first session's review). Each
        // answer a constant of the loop's type, as is whether it goes through proxies or foreseen
        // paths: two calls of one closure, each with a constant, were compiled as one loop that
        // read the flag back for every path (BENCHMARKS.md, twenty-second session).
        let pull_free = proxies.pull_free();
        let counted = workers.chunks_mut(&mut plan, |offset, chunk| {
            let mut pass = PlanPass::new(rule, paths);
            // The chunk's proxies, then its foreseen paths.
            let (own, ahead) = chunk.split_at_mut(paths.proxies.slots().saturating_sub(offset).min(chunk.len()));
            if pull_free {
                pass.plan::<true, false>(offset, own);
                pass.plan::<true, true>(offset + own.len(), ahead);
            } else {
                pass.plan::<false, false>(offset, own);
                pass.plan::<false, true>(offset + own.len(), ahead);
            }
            pass.per_exponent()
        });
        let mut per_exponent = std::mem::take(&mut self.per_exponent);
        per_exponent.clear();
        for pieces in counted.into_iter().flatten() {
            add_pieces(&mut per_exponent, pieces);
        }
        per_exponent.sort_unstable();
        // Each exponent's level (its index in the sorted list), by exponent from the lowest: a
        // look-up for each path below rather than a search of the list.
        let mut level_of = std::mem::take(&mut self.level_of);
        level_of.clear();
        let lowest = per_exponent.first().map_or(0, |&(e, _)| e);
        if let Some(&(highest, _)) = per_exponent.last() {
            level_of.resize((highest - lowest) as usize + 1, 0);
            for (k, &(exponent, _)) in per_exponent.iter().enumerate() {
                level_of[(exponent - lowest) as usize] = k as u32;
            }
        }
        // Levels sized to their pieces, storage reused; each path's plan now names its level.
        self.spare.append(&mut self.levels);
        let (mut first, mut cells_before) = (0, 0);
        for &(exponent, count) in &per_exponent {
            let mut level = self.spare.pop().unwrap_or_default();
            level.reset(exponent, self.base_cell, count, self.extent);
            level.first = first;
            level.cells_before = cells_before;
            first += count;
            cells_before += level.late_head.len();
            self.levels.push(level);
        }
        // Each path's level, or a single piece's cell, found in parallel; then pass 2: count
        // the pieces of each cell, and pass 3: scatter them (a counting sort, no hashing). In
        // pass 3 each worker owns a range of cells (cells are numbered level by level, so their
        // slots are a range too) and goes through all bodies in order, taking the pieces that
        // fall in its cells: a cell holds its pieces in body order whatever the number of
        // workers, and no two workers write near each other. Pass 2 counts, which no order
        // changes: by shares of the paths where the cells are few, by cells as pass 3 where
        // not. Longer paths are cut again.
        let cells = self.levels.last().map_or(0, |l| l.cells_before + l.late_head.len());
        let mut next_slot = std::mem::take(&mut self.next_slot);
        let mut counts = std::mem::take(&mut self.counts);
        next_slot.clear();
        next_slot.resize(cells, 0);
        let levels = &self.levels;
        let by_exponent = (&self.levels[..], &level_of[..], lowest);
        if workers.threads() == 1 {
            // One worker owns every cell: a single piece is counted where its cell is found, and
            // pass 2 goes through the cut paths alone, listed here, rather than through every
            // path again (about 20 instructions a single piece).
            let mut cut = std::mem::take(&mut self.cut);
            cut.clear();
            Grid::place_paths(by_exponent, paths, 0, &mut plan, |i, (count, cell)| {
                if count == 1 {
                    next_slot[cell as usize] += 1;
                } else {
                    cut.push(i as u32);
                }
            });
            let owned = 0..cells;
            let sink = &mut CountPieces { counts: &mut next_slot, lowest: 0 };
            for &i in &cut {
                let (i, (count, level)) = (i as usize, plan[i as usize]);
                Grid::for_each_cut_piece((&levels[level as usize], i, count), paths, &owned, sink);
            }
            self.cut = cut;
        } else if cells > 0 && workers.threads() * cells <= plan.len() / SHARED_COUNTS_PER_PATH {
            // Few cells beside the paths: each worker counts the pieces of its own share of the
            // paths in a count of every cell of its own (as one worker does), and the counts are
            // summed, rather than every worker going through every path to take its cells'. The
            // counts are the grid's, so no part list is allocated each window.
            counts.clear();
            counts.resize(workers.threads() * cells, 0);
            workers.shares_mut(&mut plan, &mut counts, |offset, share, counts| {
                let owned = 0..cells;
                Grid::place_paths(by_exponent, paths, offset, share, |i, (count, place)| {
                    if count == 1 {
                        // Straight into the slice, as one worker counts: through the sink it
                        // read the slice back from the sink for each piece.
                        counts[place as usize] += 1;
                    } else {
                        let sink = &mut CountPieces { counts: &mut *counts, lowest: 0 };
                        Grid::for_each_cut_piece((&levels[place as usize], i, count), paths, &owned, sink);
                    }
                });
            });
            let counts = &counts;
            workers.chunks_mut(&mut next_slot, |offset, sums| {
                for theirs in counts.chunks(cells) {
                    for (sum, &count) in sums.iter_mut().zip(&theirs[offset..]) {
                        *sum += count;
                    }
                }
            });
        } else {
            workers
                .chunks_mut(&mut plan, |offset, chunk| Grid::place_paths(by_exponent, paths, offset, chunk, |_, _| {}));
            let equal_cells: Vec<usize> = (1..workers.threads()).map(|k| k * cells / workers.threads()).collect();
            let parts: Vec<_> = split_at_points(&mut next_slot, &equal_cells)
                .into_iter()
                .zip(std::iter::once(0).chain(equal_cells.iter().copied()))
                .collect();
            let plan = &plan;
            workers.for_each_part(parts, |_, (counts, lowest)| {
                let owned = lowest..lowest + counts.len();
                Grid::for_each_owned_piece(levels, plan, paths, owned, &mut CountPieces { counts, lowest });
            });
        }
        // Counts become starts: of each cell in its level, and of the next piece it takes.
        for level in &mut self.levels {
            let mut filled = 0u32;
            for c in 0..level.late_head.len() {
                level.cell_start[c] = filled;
                let next = &mut next_slot[level.cells_before + c];
                (*next, filled) = (filled + level.first as u32, filled + *next);
            }
            let end = level.late_head.len();
            level.cell_start[end] = filled;
            level.count = filled as usize;
        }
        // Every slot is written below: no need to clear what a longer window left.
        self.owners.resize(first, Owner::default());
        self.owners.truncate(first);
        self.boxes.resize(first);
        self.motions.resize(first, BodyState::default());
        self.motions.truncate(first);
        let levels = &self.levels;
        // Cells cut so each worker gets about as many pieces; its slots follow from its cells.
        let slot_of_cell = |g: usize| {
            if levels.is_empty() {
                return 0;
            }
            let level =
                &levels[levels.partition_point(|l| l.cells_before + l.late_head.len() <= g).min(levels.len() - 1)];
            level.first + level.cell_start[g - level.cells_before] as usize
        };
        let cell_points = workers.balanced_points(cells, first, slot_of_cell);
        let slot_points: Vec<usize> = cell_points.iter().map(|&g| slot_of_cell(g)).collect();
        let parts: Vec<_> = split_at_points(&mut next_slot, &cell_points)
            .into_iter()
            .zip(split_at_points(&mut self.owners, &slot_points).into_iter().zip(self.boxes.parts_mut(&slot_points)))
            .zip(split_at_points(&mut self.motions, &slot_points))
            .zip(std::iter::once(0).chain(cell_points.iter().copied()))
            .zip(std::iter::once(0).chain(slot_points.iter().copied()))
            .collect();
        workers.for_each_part(parts, |_, ((((next_slot, (owners, boxes)), motions), lowest), first_slot)| {
            let owned = lowest..lowest + next_slot.len();
            let mut store = StorePieces { paths, next_slot, lowest, first_slot, owners, boxes, motions };
            Grid::for_each_owned_piece(levels, &plan, paths, owned, &mut store);
        });
        self.next_slot = next_slot;
        self.counts = counts;
        self.foreseen = !paths.foreseen.is_empty();
        self.late.clear();
        self.late_motions.clear();
        self.plan = plan;
        self.per_exponent = per_exponent;
        self.level_of = level_of;
        PrepareCounts { moves: first as u64, entries: first as u64 }
    }
}

impl BroadPhase for Grid {
    fn prepare(&mut self, proxies: Proxies, workers: &Workers) -> PrepareCounts {
        self.bin(BinnedPaths { proxies, foreseen: &[] }, workers)
    }

    fn bins_foreseen(&self) -> bool {
        true
    }

    fn prepare_foreseen(&mut self, proxies: Proxies, foreseen: &[Foreseen], workers: &Workers) -> PrepareCounts {
        self.bin(BinnedPaths { proxies, foreseen }, workers)
    }

    /// Workers sweep slabs of cells along x; a slab reads the next one, never writes.
    fn find_pairs<T: Send>(
        &mut self,
        _proxies: Proxies,
        workers: &Workers,
        predict: impl Fn(Reported, Reported, Window, &mut Vec<T>) + Sync + Send,
        out: &mut Vec<T>,
    ) -> u64 {
        self.sweep(workers, |x, y, window, (), found| predict(x, y, window, found), out, |reporting| reporting)
    }

    /// Where the processor has AVX (asked once per sweep), each piece's candidates are screened
    /// four at a time (`Screened`, in `candidates`); elsewhere one by one, as any broad phase does.
    fn find_pairs_screened<T: Send, S: PairScreen>(
        &mut self,
        proxies: Proxies,
        workers: &Workers,
        screen: &S,
        predict: impl Fn(Reported, Reported, S::Kept, &mut Vec<T>) + Sync + Send,
        out: &mut Vec<T>,
    ) -> u64 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the processor has AVX, and the sweep hands on only its own pieces.
            return self.sweep(
                workers,
                |x, y, _, kept, found| predict(x, y, kept, found),
                out,
                |reporting| unsafe { Screened::new(reporting, screen) },
            );
        }
        self.find_pairs(proxies, workers, screened_one_by_one(screen, predict), out)
    }

    fn query(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, report: impl FnMut(Reported, Window)) {
        self.query_pieces(body, proxies, (skip, false), report);
    }

    fn update(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, report: impl FnMut(Reported, Window)) {
        let exponent = self.query_pieces(body, proxies, (skip, self.foreseen), report);
        self.enter_pieces(body, proxies, exponent);
    }

    fn memory_bytes(&self) -> usize {
        let levels: usize =
            self.levels.iter().chain(&self.spare).map(|l| (l.cell_start.capacity() + l.late_head.capacity()) * 4).sum();
        self.boxes.memory_bytes()
            + self.owners.capacity() * std::mem::size_of::<Owner>()
            + self.motions.capacity() * std::mem::size_of::<BodyState>()
            + self.late.capacity() * std::mem::size_of::<(Entry, Window, u32)>()
            + self.late_motions.capacity() * std::mem::size_of::<BodyState>()
            + self.plan.capacity() * 8
            + self.extents.capacity() * 8
            + self.level_of.capacity() * 4
            + self.cut.capacity() * 4
            + (self.next_slot.capacity() + self.counts.capacity()) * 4
            + self.pieces.capacity() * std::mem::size_of::<(CompactBox, Window)>()
            + levels
    }
}
