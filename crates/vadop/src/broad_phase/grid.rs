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
//! the few cells of coarser levels that can hold an overlapping box. A body that changes velocity
//! mid-window gets fresh pieces on per-cell linked lists, and its query visits only the cells its
//! new path can reach. It never reads shapes or computes contact times.

use super::{BroadPhase, PrepareCounts};
use crate::proxy::{swept_box, ProxyTable};
use crate::window::Window;
use glam::DVec3;

/// Base cells are this many typical diameters wide: a path moving less than one diameter more
/// stays in one piece.
const BASE_CELL_DIAMETERS: f64 = 2.0;
/// A level holds at most this many cells per piece (and at least [`MIN_CELLS`]), so memory stays
/// linear in the bodies however sparse the scene.
const CELLS_PER_PIECE: f64 = 2.0;
const MIN_CELLS: f64 = 64.0;
/// Most cells along one axis of a level.
const MAX_CELLS_PER_AXIS: f64 = (1u32 << 20) as f64;
/// End of a late list.
const NONE: u32 = u32::MAX;

/// A stretch of one body's path: the body is inside `[low, high]` over `[start, end)`.
#[derive(Debug, Clone, Copy)]
struct Piece {
    low: DVec3,
    high: DVec3,
    start: f64,
    end: f64,
    body: u32,
    stamp: u32,
}

impl Piece {
    #[inline]
    fn overlaps(&self, other: &Piece) -> bool {
        self.low.cmple(other.high).all() && other.low.cmple(self.high).all()
    }
    #[inline]
    fn extent(&self) -> f64 {
        (self.high - self.low).max_element()
    }
    #[inline]
    fn window(&self) -> Window {
        Window::new(self.start, self.end)
    }
}

/// One level of the hierarchy: cubic cells of one size.
#[derive(Debug)]
struct Level {
    /// log2 of the nominal cell size in base cells.
    exponent: i32,
    cell: f64,
    inverse: f64,
    dims: [usize; 3],
    /// Binned pieces of cell c: `binned[first + cell_start[c]..first + cell_start[c + 1]]`.
    first: usize,
    cell_start: Vec<u32>,
    /// Head of each cell's list of late pieces in `Grid::late`.
    late_head: Vec<u32>,
}

impl Level {
    fn new(exponent: i32, base_cell: f64, pieces: usize, extent: DVec3) -> Level {
        let nominal = base_cell * 2f64.powi(exponent);
        let most_cells = (CELLS_PER_PIECE * pieces as f64).max(MIN_CELLS);
        let cell = nominal.max((extent.x * extent.y * extent.z / most_cells).cbrt()).max(extent.max_element() / MAX_CELLS_PER_AXIS);
        let dims = [0, 1, 2].map(|k| ((extent[k] / cell).floor() as usize + 1).max(1));
        let cells = dims.iter().product::<usize>();
        Level { exponent, cell, inverse: 1.0 / cell, dims, first: 0, cell_start: vec![0; cells + 1], late_head: vec![NONE; cells] }
    }

    #[inline]
    fn coordinate(&self, value: f64, axis: usize) -> usize {
        (value * self.inverse).floor().clamp(0.0, (self.dims[axis] - 1) as f64) as usize
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
        let a = self.coordinates(low - self.cell);
        let b = self.coordinates(high);
        let [_, ny, nz] = self.dims;
        (a[0]..=b[0]).flat_map(move |x| (a[1]..=b[1]).flat_map(move |y| ((x * ny + y) * nz + a[2])..=((x * ny + y) * nz + b[2])))
    }
}

/// The grid broad phase.
#[derive(Debug)]
pub struct Grid {
    origin: DVec3,
    extent: DVec3,
    base_cell: f64,
    /// Ascending by exponent.
    levels: Vec<Level>,
    /// This window's pieces, by level then cell.
    binned: Vec<Piece>,
    /// Pieces entered mid-window, chained per cell.
    late: Vec<(Piece, u32)>,
    /// Scratch: pieces with their (level, cell) before binning; one body's pieces.
    unsorted: Vec<(u32, u32, Piece)>,
    pieces: Vec<Piece>,
}

impl Grid {
    /// An empty grid over the box `[min, max]` the bodies live in.
    pub fn new(min: DVec3, max: DVec3) -> Grid {
        Grid {
            origin: min,
            extent: (max - min).max(DVec3::splat(f64::MIN_POSITIVE)),
            base_cell: 1.0,
            levels: Vec::new(),
            binned: Vec::new(),
            late: Vec::new(),
            unsorted: Vec::new(),
            pieces: Vec::new(),
        }
    }

    /// Longest stretch of path one piece of a body of `radius` may cover.
    #[inline]
    fn piece_length(&self, radius: f64) -> f64 {
        // A hair shorter than the room left in a base cell, so the padding of the piece's box
        // never pushes a typical piece up a level.
        (self.base_cell - 2.0 * radius).max(2.0 * radius) * (1.0 - 1e-6)
    }

    /// Calls `f` with every piece of proxy `i`.
    #[inline]
    fn for_each_piece(&self, proxies: &ProxyTable, i: usize, mut f: impl FnMut(Piece)) {
        let window = proxies.window_of(i);
        let (origin, velocity, radius) = (proxies.origin[i], proxies.velocity[i], proxies.radius[i]);
        let length = velocity.length() * window.duration();
        let count = (length / self.piece_length(radius)).ceil().clamp(1.0, u32::MAX as f64) as u32;
        let stamp = proxies.stamp[i];
        if count == 1 {
            let (low, high) = (proxies.low[i], proxies.high[i]);
            f(Piece { low, high, start: window.start, end: window.end, body: i as u32, stamp });
            return;
        }
        let step = window.duration() / count as f64;
        let mut from = origin;
        let mut start = window.start;
        for k in 1..=count {
            let end = if k == count { window.end } else { window.start + step * k as f64 };
            let to = origin + velocity * (end - window.start);
            let (low, high) = swept_box(from, to, radius);
            f(Piece { low, high, start, end, body: i as u32, stamp });
            (from, start) = (to, end);
        }
    }

    /// The exponent of the level whose cells hold a box of `extent`.
    #[inline]
    fn exponent_for(&self, extent: f64) -> i32 {
        let mut exponent = 0;
        let mut cell = self.base_cell;
        while cell < extent {
            cell *= 2.0;
            exponent += 1;
        }
        exponent
    }

    /// The level for a piece: the one of its exponent, or the closest coarser one (coarsened
    /// cells are never smaller than nominal ones), created when the piece is larger than all.
    fn level_for(&mut self, piece: &Piece) -> usize {
        let exponent = self.exponent_for(piece.extent());
        if let Some(k) = self.levels.iter().position(|l| l.exponent >= exponent && l.cell >= piece.extent()) {
            return k;
        }
        let first = self.binned.len();
        let mut level = Level::new(exponent, self.base_cell, 1, self.extent);
        level.first = first;
        self.levels.push(level);
        self.levels.len() - 1
    }

    /// Calls `visit(piece)` for every binned piece in the cells of `level` that can hold the low
    /// corner of a box of that level overlapping `[low, high]`.
    #[inline]
    fn for_each_binned_near(&self, level: &Level, low: DVec3, high: DVec3, mut visit: impl FnMut(&Piece)) {
        for c in level.cells_near(low - self.origin, high - self.origin) {
            let run = level.first + level.cell_start[c] as usize..level.first + level.cell_start[c + 1] as usize;
            self.binned[run].iter().for_each(&mut visit);
        }
    }

    /// Calls `visit(piece)` for every current piece, binned or late, near `[low, high]` in level
    /// `k`, unlinking the stale late pieces it passes, so a busy cell's list stays short.
    #[inline]
    fn for_each_current_near(&mut self, k: usize, low: DVec3, high: DVec3, proxies: &ProxyTable, mut visit: impl FnMut(&Piece)) {
        let Grid { levels, late, binned, origin, .. } = self;
        let level = &mut levels[k];
        for c in level.cells_near(low - *origin, high - *origin) {
            let run = level.first + level.cell_start[c] as usize..level.first + level.cell_start[c + 1] as usize;
            for piece in &binned[run] {
                if proxies.is_current(piece.body as usize, piece.stamp) {
                    visit(piece);
                }
            }
            let (mut previous, mut current) = (NONE, level.late_head[c]);
            while current != NONE {
                let (piece, next) = late[current as usize];
                if proxies.is_current(piece.body as usize, piece.stamp) {
                    visit(&piece);
                    previous = current;
                } else if previous == NONE {
                    level.late_head[c] = next;
                } else {
                    late[previous as usize].1 = next;
                }
                current = next;
            }
        }
    }
}

/// Reports the pair of two overlapping pieces of different bodies, with their common window.
#[inline]
fn report_pair(a: &Piece, b: &Piece, report: &mut impl FnMut(u32, u32, Window)) {
    if a.body != b.body && a.overlaps(b) {
        let window = a.window().intersect(b.window());
        if !window.is_empty() {
            report(a.body.min(b.body), a.body.max(b.body), window);
        }
    }
}

impl BroadPhase for Grid {
    fn prepare(&mut self, proxies: &ProxyTable) -> PrepareCounts {
        // Base cell from the median bounding diameter: robust to a few giant or tiny bodies.
        if proxies.typical_radius() > 0.0 {
            self.base_cell = 2.0 * BASE_CELL_DIAMETERS * proxies.typical_radius();
        }
        // Pieces of every live proxy, with their level exponent.
        let mut unsorted = std::mem::take(&mut self.unsorted);
        unsorted.clear();
        for i in 0..proxies.slots() {
            if proxies.live[i] {
                self.for_each_piece(proxies, i, |piece| unsorted.push((self.exponent_for(piece.extent()) as u32, 0, piece)));
            }
        }
        // Levels, each sized to its pieces; then bin by counting sort on (level, cell).
        unsorted.sort_unstable_by_key(|&(exponent, _, _)| exponent);
        self.levels.clear();
        let mut first = 0;
        while first < unsorted.len() {
            let exponent = unsorted[first].0;
            let count = unsorted[first..].partition_point(|&(e, _, _)| e == exponent);
            let mut level = Level::new(exponent as i32, self.base_cell, count, self.extent);
            level.first = first;
            for entry in &mut unsorted[first..first + count] {
                let cell = level.index(level.coordinates(entry.2.low - self.origin));
                entry.1 = cell as u32;
                level.cell_start[cell + 1] += 1;
            }
            for c in 0..level.cell_start.len() - 1 {
                level.cell_start[c + 1] += level.cell_start[c];
            }
            self.levels.push(level);
            first += count;
        }
        self.binned.clear();
        self.binned.resize(unsorted.len(), Piece { low: DVec3::ZERO, high: DVec3::ZERO, start: 0.0, end: 0.0, body: 0, stamp: 0 });
        for level in &mut self.levels {
            let count = level.cell_start[level.cell_start.len() - 1] as usize;
            // Scatter: cell c's pieces go from cell_start[c] on, shifting it to the next cell's
            // start; shifting back by one cell restores the starts.
            for &(_, cell, piece) in &unsorted[level.first..level.first + count] {
                let slot = &mut level.cell_start[cell as usize];
                self.binned[level.first + *slot as usize] = piece;
                *slot += 1;
            }
            let cells = level.late_head.len();
            level.cell_start.copy_within(0..cells, 1);
            level.cell_start[0] = 0;
        }
        self.late.clear();
        let moves = unsorted.len() as u64;
        self.unsorted = unsorted;
        PrepareCounts { moves, entries: moves }
    }

    fn for_each_pair(&mut self, _proxies: &ProxyTable, mut report: impl FnMut(u32, u32, Window)) {
        // Half of the 26 neighbours, so each pair of adjacent cells is swept once.
        const FORWARD: [[usize; 3]; 13] = [
            [1, 0, 0], [1, 0, 1], [1, 0, 2], [1, 1, 0], [1, 1, 1], [1, 1, 2], [1, 2, 0], [1, 2, 1], [1, 2, 2],
            [0, 2, 0], [0, 2, 1], [0, 2, 2], [0, 1, 2],
        ];
        for (k, level) in self.levels.iter().enumerate() {
            let [nx, ny, nz] = level.dims;
            for x in 0..nx {
                for y in 0..ny {
                    for z in 0..nz {
                        let c = level.index([x, y, z]);
                        let (from, to) = (level.cell_start[c] as usize, level.cell_start[c + 1] as usize);
                        if from == to {
                            continue;
                        }
                        let run = &self.binned[level.first + from..level.first + to];
                        for (m, a) in run.iter().enumerate() {
                            for b in &run[m + 1..] {
                                report_pair(a, b, &mut report);
                            }
                        }
                        // Offsets are stored +1 so that -1 needs no signed arithmetic.
                        for [dx, dy, dz] in FORWARD {
                            let (x2, y2, z2) = (x + dx, (y + dy).wrapping_sub(1), (z + dz).wrapping_sub(1));
                            if x2 >= nx || y2 >= ny || z2 >= nz {
                                continue;
                            }
                            let c2 = level.index([x2, y2, z2]);
                            let other = &self.binned[level.first + level.cell_start[c2] as usize..level.first + level.cell_start[c2 + 1] as usize];
                            for a in run {
                                for b in other {
                                    report_pair(a, b, &mut report);
                                }
                            }
                        }
                        // Coarser levels: each piece against the cells that can hold an
                        // overlapping box there.
                        for coarser in &self.levels[k + 1..] {
                            for a in run {
                                self.for_each_binned_near(coarser, a.low, a.high, |b| report_pair(a, b, &mut report));
                            }
                        }
                    }
                }
            }
        }
    }

    fn query(&mut self, body: u32, proxies: &ProxyTable, skip: Option<u32>, mut report: impl FnMut(u32, Window)) {
        let mut pieces = std::mem::take(&mut self.pieces);
        pieces.clear();
        self.for_each_piece(proxies, body as usize, |piece| pieces.push(piece));
        for piece in &pieces {
            for k in 0..self.levels.len() {
                self.for_each_current_near(k, piece.low, piece.high, proxies, |other| {
                    if other.body != body && Some(other.body) != skip && piece.overlaps(other) {
                        let window = piece.window().intersect(other.window());
                        if !window.is_empty() {
                            report(other.body, window);
                        }
                    }
                });
            }
        }
        self.pieces = pieces;
    }

    fn update(&mut self, body: u32, proxies: &ProxyTable, skip: Option<u32>, report: impl FnMut(u32, Window)) {
        self.query(body, proxies, skip, report);
        // The pieces the query just built.
        for k in 0..self.pieces.len() {
            let piece = self.pieces[k];
            let level = self.level_for(&piece);
            let level = &mut self.levels[level];
            let cell = level.index(level.coordinates(piece.low - self.origin));
            self.late.push((piece, level.late_head[cell]));
            level.late_head[cell] = (self.late.len() - 1) as u32;
        }
    }

    fn memory_bytes(&self) -> usize {
        let piece = std::mem::size_of::<Piece>();
        let levels: usize = self.levels.iter().map(|l| (l.cell_start.capacity() + l.late_head.capacity()) * 4).sum();
        self.binned.capacity() * piece
            + self.late.capacity() * (piece + 4)
            + self.unsorted.capacity() * (piece + 8)
            + self.pieces.capacity() * piece

            + levels
    }
}
