//! The cells of the event loop: the box cut into a grid of cells at least as wide as the largest
//! pair of bodies can reach, each body listed in the cell its centre is in, and the time its
//! centre next crosses into another.
//!
//! It owns the grid's sizing, the lists (one intrusive doubly linked list per cell through the
//! bodies, so moving a body costs O(1) and nothing is allocated while stepping; with neighbour
//! lists, see [`super::lists`], a body is listed by its shell's centre instead, in cells wider
//! by two shells, and has no crossings) with a bit per cell that tells an empty cell without
//! reading its list's head, and a bit in the head that tells a cell of one body without reading
//! past it), a body's neighbourhood (the 27 cells around its own, or the 9 it has just come
//! within reach of) with the whole sides that bring each neighbour cell's bodies to their nearest
//! image across periodic faces, and the crossing times (and the box's periodic faces, which a
//! search from a cell on a face reads for its body's crossing of them). Two bodies that touch
//! are always in neighbouring cells, so a body need only be tested against its neighbourhood,
//! and again against the 9 new cells each time it crosses into a new one. It never computes a
//! contact time nor changes a body.

use crate::bodies::Bodies;
use crate::memory::prefetch;
use crate::motion::Motion;
use crate::walls::BoxBounds;
use glam::DVec3;

/// No body, or no cell.
pub(super) const NONE: u32 = u32::MAX;

/// The bit of a cell's head that says the cell holds more than one body (see [`Cells::head`]);
/// the bits below it are the head's id.
const CROWDED: u32 = 1 << 31;

/// A cell is at least this much wider than the largest sum of two radii (relative), plus this many
/// roundings of the box's largest coordinate, so rounding in a crossing time or a position never
/// lets two touching bodies sit two cells apart.
const WIDTH_SLACK: f64 = 1e-6;
const ROUNDINGS: f64 = 64.0;
/// Bodies per cell the grid aims at: enough that a crossing rarely finds the new cells empty,
/// few enough that a neighbourhood stays short. Measured on the equilibrium gas at n = 10^5:
/// see BENCHMARKS.md, "The event loop".
const BODIES_PER_CELL: f64 = 0.15;
/// The grid never has more cells than this many per body (a few bodies in a huge box).
const MAX_CELLS_PER_BODY: f64 = 8.0;

/// When a body's centre next leaves its cell: the time, the axis, and whether upwards.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Crossing {
    pub time: f64,
    pub axis: u8,
    pub up: bool,
}

impl Crossing {
    /// No crossing (a body at rest, or in a cell it cannot leave).
    pub(super) const NEVER: Crossing = Crossing { time: f64::INFINITY, axis: 0, up: false };
}

/// A cell of the neighbourhood: its index, and the whole sides that bring its bodies to their
/// images near the body whose neighbourhood it is.
#[derive(Debug, Clone, Copy)]
pub(super) struct Neighbour {
    pub cell: u32,
    pub shift: DVec3,
}

/// A slab of cells next to a body's along one axis (its own among them): its part of a cell
/// index, the sign of the whole side that brings its bodies next to the body across a periodic
/// face (0, 1 or 2 for -, none or +), and the least distance from a point in the body's cell to
/// the slab, squared.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Slab {
    pub part: u32,
    pub sign: u32,
    pub gap2: f64,
}

/// The most cells along one axis (coordinates are kept as 16 bits).
const MAX_PER_AXIS: f64 = 65_535.0;

/// The grid and its lists.
#[derive(Debug, Default, Clone)]
pub(super) struct Cells {
    min: DVec3,
    side: DVec3,
    width: DVec3,
    inverse_width: DVec3,
    counts: [i64; 3],
    /// Cell index = `x + y * strides[1] + z * strides[2]`.
    strides: [i64; 3],
    /// The index offsets of the 9 rows of cells (their middle cells) around a cell away from
    /// every face.
    rows: [i64; 9],
    periodic: [bool; 3],
    /// The box's periodic faces ([`BoxBounds::faces`]), none in a box without any: read by every
    /// search from a cell on a face of the box for its body's crossing, where working them out
    /// from the box's corners cost about a tenth of that prediction.
    pub faces: Option<(DVec3, DVec3)>,
    /// The widest pair of bodies the grid was sized for (the sum of two radii).
    reach: f64,
    /// Per cell: its first body, or [`NONE`]; with [`CROWDED`] set when the cell holds more than
    /// one. A search that finds it clear takes the head for the cell's only body and does not
    /// read that body's place in the lists for a next one: in a thin gas most occupied cells hold
    /// one body, and each such read is a miss. (The flag rides in the head, which the search
    /// reads anyway, rather than in a bit array of its own: one read a cell, not two.)
    head: Vec<u32>,
    /// Per cell, one bit: it holds a body (its head is not [`NONE`]). A search reads this before
    /// a cell's head: in a thin gas most cells are empty, and the heads (4 bytes a cell) outgrow
    /// the caches where the bits (one a cell) do not, so an empty cell costs no cache miss.
    occupied: Vec<u64>,
    /// Per body: its place in the lists (see [`Listing`]).
    listing: Vec<Listing>,
}

/// A body's place in the lists: the next and previous bodies of its cell, its cell ([`NONE`]
/// when not listed) and the cell's coordinates. Kept together, not as one array each: the events
/// come in time order, so each reaches a body far from the last one's, and every field read
/// then costs a cache miss of its own when the fields lie in separate arrays.
#[derive(Debug, Clone, Copy)]
struct Listing {
    next: u32,
    prev: u32,
    cell: u32,
    at: [u16; 3],
}

impl Listing {
    const UNLISTED: Listing = Listing { next: NONE, prev: NONE, cell: NONE, at: [0; 3] };
}

/// The lists' arrays as slices, taken once a search: their places and lengths then stay in
/// registers, where read through the grid they are read again after every candidate the search
/// writes (the compiler cannot tell the writes from the grid), three loads a cell's bit test.
#[derive(Clone, Copy)]
pub(super) struct Lookup<'a> {
    head: &'a [u32],
    occupied: &'a [u64],
    listing: &'a [Listing],
}

impl Lookup<'_> {
    /// The first body of cell `cell`, which holds one, and whether it holds more (see
    /// [`Cells::head`]).
    #[inline(always)]
    pub(super) fn first_of_occupied(&self, cell: u32) -> (u32, bool) {
        let head = self.head[cell as usize];
        debug_assert_ne!(head, NONE, "cell {cell} is empty");
        (head & !CROWDED, head & CROWDED != 0)
    }

    /// True when cell `cell` holds a body (see [`Cells::occupied`]).
    #[inline(always)]
    pub(super) fn is_occupied(&self, cell: u32) -> bool {
        self.occupied[cell as usize / 64] & (1 << (cell % 64)) != 0
    }

    /// The cells `first`, `first + 1` and `first + 2` (a row along x) that hold a body, as the
    /// bits 0, 1 and 2.
    #[inline(always)]
    pub(super) fn occupied_in_row(&self, first: usize) -> u32 {
        let (word, bit) = (first / 64, first % 64);
        let mut bits = self.occupied[word] >> bit;
        if bit > 61 {
            // The row runs into the next word (which exists: `first + 2` is a cell).
            bits |= self.occupied[word + 1] << (64 - bit);
        }
        (bits & 7) as u32
    }

    /// The body after `i` in its cell, or [`NONE`].
    #[inline(always)]
    pub(super) fn after(&self, i: u32) -> u32 {
        self.listing[i as usize].next
    }
}

/// A body's neighbours along one axis: up to three (index part, shift) steps.
type AxisSteps = ([(u32, f64); 3], usize);

impl Cells {
    /// An empty grid over `bounds` for bodies of at most `max_radius` and about `bodies` of them,
    /// listed by their centres (`shell` 0), or by their shells' centres, each body's own centre
    /// within `shell` of it (see [`super::lists`]): then the cells are as narrow as they may be,
    /// since they serve only to build lists, and the fewer bodies around a body the fewer to look at.
    pub(super) fn new(bounds: &BoxBounds, max_radius: f64, shell: f64, bodies: usize) -> Cells {
        let side = bounds.side();
        let reach = 2.0 * max_radius;
        let scale = bounds.min.abs().max(bounds.max.abs()).max_element() + side.max_element();
        let narrowest = (reach + 2.0 * shell) * (1.0 + WIDTH_SLACK) + ROUNDINGS * f64::EPSILON * scale;
        // Cells of about BODIES_PER_CELL bodies each, never narrower than the reach.
        let volume = side.x * side.y * side.z;
        let spacing = if shell > 0.0 { 0.0 } else { (volume * BODIES_PER_CELL / bodies.max(1) as f64).cbrt() };
        let mut width = spacing.max(narrowest);
        let cells_for = |width: f64| side.to_array().map(|s| ((s / width).floor().clamp(1.0, MAX_PER_AXIS)) as i64);
        // A few bodies in a huge box: wider cells than the spacing says, to bound the memory.
        let limit = (MAX_CELLS_PER_BODY * bodies.max(64) as f64).max(27.0);
        while cells_for(width).iter().map(|&c| c as f64).product::<f64>() > limit {
            width *= 1.25;
        }
        let mut counts = cells_for(width);
        for (axis, count) in counts.iter_mut().enumerate() {
            // Periodic axes keep at least 3 cells (a side holds 8 diameters), so the 27 cells of
            // a neighbourhood are distinct and each meets one image of the others.
            if bounds.periodic[axis] {
                *count = (*count).max(3);
            }
        }
        let width = DVec3::from_array(std::array::from_fn(|a| side[a] / counts[a] as f64));
        let total = counts.iter().product::<i64>() as usize;
        let strides = [1, counts[0], counts[0] * counts[1]];
        let rows = std::array::from_fn(|k| (k as i64 % 3 - 1) * strides[1] + (k as i64 / 3 - 1) * strides[2]);
        Cells {
            min: bounds.min,
            side,
            width,
            inverse_width: width.recip(),
            counts,
            strides,
            rows,
            periodic: bounds.periodic,
            faces: bounds.is_periodic().then(|| bounds.faces()),
            reach,
            head: vec![NONE; total],
            occupied: vec![0; total.div_ceil(64)],
            listing: Vec::new(),
        }
    }

    /// True when bodies of `radius` fit the grid: two of them never reach past a neighbour cell.
    pub(super) fn fits(&self, radius: f64) -> bool {
        2.0 * radius <= self.reach
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.head.capacity() * 4
            + self.occupied.capacity() * 8
            + self.listing.capacity() * std::mem::size_of::<Listing>()
    }

    /// The cell body `i` is listed in, or [`NONE`].
    #[inline]
    pub(super) fn cell_of(&self, i: usize) -> u32 {
        self.listing.get(i).map_or(NONE, |l| l.cell)
    }

    /// Asks for body `i`'s place in the lists ahead of its use (see [`crate::memory::prefetch`]).
    #[inline]
    pub(super) fn prefetch(&self, i: usize) {
        if let Some(listing) = self.listing.get(i) {
            prefetch(listing);
        }
    }

    /// Asks for the heads of the cells body `i`, listed, comes within reach of by `crossing` (a
    /// crossing out of its cell), ahead of the search that follows it.
    #[inline]
    pub(super) fn prefetch_new(&self, i: usize, crossing: Crossing) {
        self.for_each_new(self.stepped(i, crossing), crossing, |n| {
            if self.is_occupied(n.cell) {
                prefetch(&self.head[n.cell as usize]);
            }
        });
    }

    /// The coordinates of the cell holding the centre `position`.
    fn cell_at(&self, position: DVec3) -> [i64; 3] {
        std::array::from_fn(|a| {
            let k = ((position[a] - self.min[a]) * self.inverse_width[a]).floor();
            // NaN-free: positions are checked; clamped for centres on (or a rounding past) a face.
            (k.max(0.0) as i64).min(self.counts[a] - 1)
        })
    }

    /// Lists body `i` in the cell of its centre at `t`.
    pub(super) fn insert(&mut self, bodies: &Bodies, i: usize, t: f64) {
        if self.listing.len() < bodies.slots() {
            // Ids below the head's flag, and a crowded head never [`NONE`]: the world holds
            // fewer than 2^31 - 1 slots.
            debug_assert!(bodies.slots() < CROWDED as usize - 1, "too many bodies for the cells");
            self.listing.resize(bodies.slots(), Listing::UNLISTED);
        }
        debug_assert_eq!(self.listing[i].cell, NONE, "body {i} listed twice");
        let at = self.cell_at(bodies.position_at(i, t));
        self.link(i, at);
    }

    /// Takes body `i` off its cell's list (if listed).
    pub(super) fn remove(&mut self, i: usize) {
        if self.cell_of(i) != NONE {
            self.unlink(i);
        }
    }

    /// Lists body `i` in the cell its centre is in at `t` (after a wrap across a periodic face).
    pub(super) fn relist(&mut self, bodies: &Bodies, i: usize, t: f64) {
        self.unlink(i);
        let at = self.cell_at(bodies.position_at(i, t));
        self.link(i, at);
    }

    /// Moves body `i` one cell along `crossing`'s axis; returns its new cell's coordinates and
    /// index. (The index as [`Self::stepped`] finds it, a stride from the old one, not worked out
    /// from the coordinates again, and the unlinking and linking inline, not calls: about 50
    /// instructions fewer a crossing in the thin gas, of some 130.)
    #[inline]
    pub(super) fn step_across(&mut self, i: usize, crossing: Crossing) -> ([u16; 3], u32) {
        let (at, cell) = self.stepped(i, crossing);
        self.unlink_inline(i);
        self.link_into(i, at, cell);
        (at, cell)
    }

    /// The coordinates and index of the cell body `i` steps into by `crossing`.
    #[inline]
    pub(super) fn stepped(&self, i: usize, crossing: Crossing) -> ([u16; 3], u32) {
        let (mut at, axis) = (self.listing[i].at, crossing.axis as usize);
        let stride = self.strides[axis] as u32;
        let cell = if crossing.up {
            at[axis] += 1;
            self.listing[i].cell + stride
        } else {
            at[axis] -= 1;
            self.listing[i].cell - stride
        };
        (at, cell)
    }

    /// True when the cell at `at` lies on a face of the box (a wall, or a periodic face).
    #[inline]
    pub(super) fn at_face(&self, at: [u16; 3]) -> bool {
        (0..3).any(|a| at[a] == 0 || at[a] as i64 == self.counts[a] - 1)
    }

    /// True when a step across `crossing` into the cell at `into` brought a body to a face of the
    /// box on the crossing's axis.
    #[inline]
    pub(super) fn entered_face(&self, into: [u16; 3], crossing: Crossing) -> bool {
        let a = crossing.axis as usize;
        into[a] == 0 || into[a] as i64 == self.counts[a] - 1
    }

    /// Body `i`'s cell: its coordinates and index.
    #[inline]
    pub(super) fn place(&self, i: usize) -> ([u16; 3], u32) {
        (self.listing[i].at, self.listing[i].cell)
    }

    fn link(&mut self, i: usize, at: [i64; 3]) {
        let cell = (at[0] + at[1] * self.strides[1] + at[2] * self.strides[2]) as u32;
        self.link_into(i, at.map(|c| c as u16), cell);
    }

    /// Lists body `i` first in cell `cell`, at `at`.
    #[inline(always)]
    fn link_into(&mut self, i: usize, at: [u16; 3], cell: u32) {
        let first = self.first(cell);
        self.listing[i] = Listing { next: first, prev: NONE, cell, at };
        self.head[cell as usize] = if first != NONE {
            self.listing[first as usize].prev = i as u32;
            i as u32 | CROWDED
        } else {
            self.occupied[cell as usize / 64] |= 1 << (cell % 64);
            i as u32
        };
    }

    /// Takes body `i`, listed, off its cell's list (out of line but in a crossing's move).
    fn unlink(&mut self, i: usize) {
        self.unlink_inline(i);
    }

    /// [`Self::unlink`], inline in a crossing's move.
    #[inline(always)]
    fn unlink_inline(&mut self, i: usize) {
        let Listing { next, prev, cell, .. } = self.listing[i];
        // One body left: `i` was the head and its next is the last, or `i` was the last and its
        // previous the head (lines the unlinking writes anyway).
        let one_left = if prev == NONE {
            next != NONE && self.listing[next as usize].next == NONE
        } else {
            next == NONE && self.listing[prev as usize].prev == NONE
        };
        if prev == NONE {
            // `next` becomes the head, and the cell stays crowded unless it is the last.
            self.head[cell as usize] = if next == NONE || one_left { next } else { next | CROWDED };
            if next == NONE {
                self.occupied[cell as usize / 64] &= !(1 << (cell % 64));
            }
        } else {
            if one_left {
                self.head[cell as usize] &= !CROWDED;
            }
            self.listing[prev as usize].next = next;
        }
        if next != NONE {
            self.listing[next as usize].prev = prev;
        }
        self.listing[i].cell = NONE;
    }

    /// The first body of cell `cell`, or [`NONE`].
    #[inline]
    pub(super) fn first(&self, cell: u32) -> u32 {
        match self.head[cell as usize] {
            NONE => NONE,
            head => head & !CROWDED,
        }
    }

    /// True when cell `cell` holds a body (see [`Self::occupied`]).
    #[inline(always)]
    pub(super) fn is_occupied(&self, cell: u32) -> bool {
        self.lookup().is_occupied(cell)
    }

    /// The lists' arrays, for a search's many reads (see [`Lookup`]).
    #[inline(always)]
    pub(super) fn lookup(&self) -> Lookup<'_> {
        Lookup { head: &self.head, occupied: &self.occupied, listing: &self.listing }
    }

    /// Cell `cell` of `other`, a grid of the same cells, copied: its head, and the places of the
    /// bodies listed there (a body that left it is listed in another cell, copied too).
    pub(super) fn copy_cell(&mut self, other: &Cells, cell: u32) {
        let (c, word, bit) = (cell as usize, cell as usize / 64, 1u64 << (cell % 64));
        self.head[c] = other.head[c];
        self.occupied[word] = (self.occupied[word] & !bit) | (other.occupied[word] & bit);
        let mut q = other.first(cell);
        while q != NONE {
            self.listing[q as usize] = other.listing[q as usize];
            q = other.listing[q as usize].next;
        }
    }

    /// Tests: the same cells hold the same bodies, in the same order, as in `other`.
    #[cfg(test)]
    pub(super) fn same_lists(&self, other: &Cells) -> bool {
        let place = |l: &Listing| (l.next, l.prev, l.cell, l.at);
        self.head == other.head
            && self.occupied == other.occupied
            && self.listing.iter().map(place).eq(other.listing.iter().map(place))
    }

    /// The body after `i` in its cell, or [`NONE`].
    #[inline]
    pub(super) fn after(&self, i: u32) -> u32 {
        self.lookup().after(i)
    }

    /// The cell `d` steps from coordinate `c` along axis `a`, as its part of a cell index, with
    /// the whole side that brings its bodies next to `c` across a periodic face; none past a wall.
    #[inline(always)]
    fn step(&self, a: usize, c: i64, d: i64) -> Option<(u32, f64)> {
        let (k, n) = (c + d, self.counts[a]);
        let (k, shift) = if k < 0 {
            (k + n, -self.side[a])
        } else if k >= n {
            (k - n, self.side[a])
        } else {
            return Some(((k * self.strides[a]) as u32, 0.0));
        };
        self.periodic[a].then_some(((k * self.strides[a]) as u32, shift))
    }

    /// The cells next to coordinate `c` along axis `a`, itself included.
    #[inline(always)]
    fn around(&self, a: usize, c: i64) -> AxisSteps {
        let mut steps = ([(0, 0.0); 3], 0);
        let reach = if self.counts[a] == 1 { 0..=0 } else { -1..=1 };
        for d in reach {
            if let Some(step) = self.step(a, c, d) {
                steps.0[steps.1] = step;
                steps.1 += 1;
            }
        }
        steps
    }

    /// Calls `visit` with every cell of the block `xs` x `ys` x `zs`.
    #[inline(always)]
    fn for_each_in(xs: AxisSteps, ys: AxisSteps, zs: AxisSteps, mut visit: impl FnMut(Neighbour)) {
        for &(z, sz) in &zs.0[..zs.1] {
            for &(y, sy) in &ys.0[..ys.1] {
                for &(x, sx) in &xs.0[..xs.1] {
                    visit(Neighbour { cell: x + y + z, shift: DVec3::new(sx, sy, sz) });
                }
            }
        }
    }

    /// Number of cells.
    pub(super) fn len(&self) -> usize {
        self.head.len()
    }

    /// The first cells of the 9 rows of 3 cells along x around body `i`'s, when none of them lies
    /// across a face of the box (most bodies' case).
    #[inline]
    pub(super) fn rows_around(&self, i: usize) -> Option<[usize; 9]> {
        let at = self.listing[i].at;
        let inside = (0..3).all(|a| at[a] >= 1 && (at[a] as i64) + 2 <= self.counts[a]);
        let centre = self.listing[i].cell as i64;
        inside.then(|| self.rows.map(|d| (centre + d - 1) as usize))
    }

    /// The widest radius a body of the grid may have (see [`Self::fits`]).
    pub(super) fn max_radius(&self) -> f64 {
        self.reach / 2.0
    }

    /// The slabs of cells along each axis whose cells make body `i`'s neighbourhood (see
    /// [`Slab`]), each with how near `position`, a point of body `i`'s cell, comes to it, less
    /// `margin`: a cell whose three slabs' gaps add up to more than a distance squared holds no
    /// centre within that distance of `position` (but by `margin`).
    #[inline(always)]
    pub(super) fn slabs_around(&self, i: usize, position: DVec3, margin: f64) -> [([Slab; 3], usize); 3] {
        let at = self.listing[i].at;
        let mut slabs = [([Slab::default(); 3], 0); 3];
        for (a, (slabs, len)) in slabs.iter_mut().enumerate() {
            let (c, n, stride) = (at[a] as i64, self.counts[a], self.strides[a]);
            let into = position[a] - (self.min[a] + c as f64 * self.width[a]);
            let mut push = |k: i64, sign: u32, gap: f64| {
                let gap = gap.max(0.0);
                slabs[*len] = Slab { part: (k * stride) as u32, sign, gap2: gap * gap };
                *len += 1;
            };
            // Below, its own, above: across a periodic face the slab wraps to the far side
            // (a periodic axis has 3 cells at least, so the three are distinct); past a wall,
            // none.
            if c > 0 {
                push(c - 1, 1, into - margin);
            } else if self.periodic[a] {
                push(n - 1, 0, into - margin);
            }
            push(c, 1, 0.0);
            if c + 1 < n {
                push(c + 1, 1, self.width[a] - into - margin);
            } else if self.periodic[a] {
                push(0, 2, self.width[a] - into - margin);
            }
        }
        slabs
    }

    /// Calls `visit` with every cell of body `i`'s neighbourhood: the 27 cells around its own
    /// (fewer against walls).
    #[inline(always)]
    pub(super) fn for_each_around(&self, i: usize, visit: impl FnMut(Neighbour)) {
        let at = self.listing[i].at.map(i64::from);
        Self::for_each_in(self.around(0, at[0]), self.around(1, at[1]), self.around(2, at[2]), visit);
    }

    /// The cells a body came within reach of by a step across `crossing` into the cell
    /// `(at, cell)`, when none of them lies across a face of the box (most crossings' case): the
    /// 9 of the plane beyond it in the direction it moved, in [`Self::for_each_new`]'s order.
    #[inline(always)]
    pub(super) fn cells_ahead(&self, (at, cell): ([u16; 3], u32), crossing: Crossing) -> Option<[u32; 9]> {
        let inside = (0..3).all(|a| at[a] >= 1 && (at[a] as i64) + 2 <= self.counts[a]);
        inside.then(|| {
            let axis = crossing.axis as usize;
            let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
            let ahead = cell as i64 + if crossing.up { self.strides[axis] } else { -self.strides[axis] };
            let (su, sw) = (self.strides[u], self.strides[w]);
            let (a, b, c) = (ahead - su - sw, ahead - su, ahead - su + sw);
            [a, a + su, a + 2 * su, b, b + su, b + 2 * su, c, c + su, c + 2 * su].map(|cell| cell as u32)
        })
    }

    /// Calls `visit` with the cells a body came within reach of by a step across `crossing` into
    /// the cell `(at, cell)`: the 9 beyond it in the direction it moved.
    #[inline(always)]
    pub(super) fn for_each_new(
        &self,
        (at, cell): ([u16; 3], u32),
        crossing: Crossing,
        mut visit: impl FnMut(Neighbour),
    ) {
        if let Some(ahead) = self.cells_ahead((at, cell), crossing) {
            for cell in ahead {
                visit(Neighbour { cell, shift: DVec3::ZERO });
            }
            return;
        }
        let at = at.map(i64::from);
        let axis = crossing.axis as usize;
        let mut steps: [AxisSteps; 3] = std::array::from_fn(|a| self.around(a, at[a]));
        let ahead = self.step(axis, at[axis], if crossing.up { 1 } else { -1 });
        steps[axis] = ([ahead.unwrap_or((0, 0.0)); 3], ahead.is_some() as usize);
        let [xs, ys, zs] = steps;
        Self::for_each_in(xs, ys, zs, visit);
    }

    /// When body `i`, listed in its cell, next crosses a face of it on its current motion (no
    /// gravity: the event loop takes none), from `now` on. The outer faces of the outermost
    /// cells are never crossed: walls turn the body back first, and a periodic face is the
    /// body's wrap, an event of its own.
    #[inline(always)]
    pub(super) fn next_crossing(&self, bodies: &Bodies, i: usize, now: f64) -> Crossing {
        self.next_crossing_from(&bodies.motion(i), self.listing[i].at, now)
    }

    /// [`Self::next_crossing`] of a body on `motion` in the cell at `at`.
    #[inline(always)]
    pub(super) fn next_crossing_from(&self, motion: &Motion, at: [u16; 3], now: f64) -> Crossing {
        // Axis by axis, written out: each axis's components then read as fields, with no loop
        // left rolled (a loop over the axes stayed rolled once inlined, which cost more).
        let mut best = Crossing::NEVER;
        self.offer_crossing(motion, at, now, 0, &mut best);
        self.offer_crossing(motion, at, now, 1, &mut best);
        self.offer_crossing(motion, at, now, 2, &mut best);
        best
    }

    /// The crossing of a face on axis `a` of the cell at `at` by a body on `motion`, kept in
    /// `best` when earlier (from `now` on).
    #[inline(always)]
    fn offer_crossing(&self, motion: &Motion, at: [u16; 3], now: f64, a: usize, best: &mut Crossing) {
        let (v, c) = (motion.velocity[a], at[a] as i64);
        let (face, up) = if v > 0.0 && c + 1 < self.counts[a] {
            (self.min[a] + (c + 1) as f64 * self.width[a], true)
        } else if v < 0.0 && c > 0 {
            (self.min[a] + c as f64 * self.width[a], false)
        } else {
            return;
        };
        let time = motion.since + (face - motion.position[a]) / v;
        if time < best.time {
            // `time.max(now)`, in one comparison: `time` is never NaN here (a NaN fails the
            // comparison above), so the NaN's fix-up of `max` is left out.
            *best = Crossing { time: if now > time { now } else { time }, axis: a as u8, up };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The next crossing as it was first written (a loop over the axes, the time clamped by
    /// `f64::max`): the reference of [`Cells::next_crossing_from`].
    fn crossing_by_max(cells: &Cells, motion: &Motion, at: [u16; 3], now: f64) -> Crossing {
        let faces = (0..3).filter_map(|a| {
            let (v, c) = (motion.velocity[a], at[a] as i64);
            let crosses = (v > 0.0 && c + 1 < cells.counts[a]) || (v < 0.0 && c > 0);
            let k = if v > 0.0 { c + 1 } else { c };
            let face = cells.min[a] + k as f64 * cells.width[a];
            crosses.then(|| (motion.since + (face - motion.position[a]) / v, a as u8, v > 0.0))
        });
        faces.fold(Crossing::NEVER, |best, (time, axis, up)| match time < best.time {
            true => Crossing { time: time.max(now), axis, up },
            false => best,
        })
    }

    /// The next crossing is the reference's to the bit (time, axis and direction) for bodies in
    /// every cell of a small grid, at rest or moving along some axes only, and with crossings
    /// already past (clamped to now), ties between axes, zeros of either sign and huge speeds.
    #[test]
    fn the_next_crossing_is_the_clamped_earliest_face() {
        let bounds = BoxBounds::cube(10.0).unwrap().with_periodic([true, false, true]);
        let cells = Cells::new(&bounds, 0.5, 0.0, 8);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(27);
        let mut clamped = 0;
        for round in 0..100_000 {
            let at: [u16; 3] = std::array::from_fn(|a| rng.random_range(0..cells.counts[a]) as u16);
            let speed = |rng: &mut rand_chacha::ChaCha8Rng| match rng.random_range(0..8) {
                0 => 0.0,
                1 => -0.0,
                2 => rng.random_range(-1e300..1e300),
                _ => rng.random_range(-2.0..2.0),
            };
            let mut velocity = DVec3::from_array(std::array::from_fn(|_| speed(&mut rng)));
            if round % 7 == 0 {
                // Two axes alike: their crossings may tie.
                velocity.y = velocity.x;
            }
            let corner = cells.min + cells.width * DVec3::new(at[0] as f64, at[1] as f64, at[2] as f64);
            let inside = DVec3::from_array(std::array::from_fn(|_| rng.random_range(-0.1..1.1)));
            let since = rng.random_range(0.0..2.0);
            let motion = Motion { position: corner + cells.width * inside, since, velocity };
            let now = since + rng.random_range(0.0..0.5);
            let (found, reference) =
                (cells.next_crossing_from(&motion, at, now), crossing_by_max(&cells, &motion, at, now));
            assert_eq!(
                (found.time.to_bits(), found.axis, found.up),
                (reference.time.to_bits(), reference.axis, reference.up),
                "round {round}"
            );
            clamped += (found.time == now) as u32;
        }
        assert!(clamped > 100, "crossings already past met: {clamped}");
    }
}
