//! Continuous uniform grid over swept bounds: a baseline broad phase for the benchmarks.
//!
//! It owns a dense grid of cubic cells over the box, each body's swept axis-aligned box over the
//! rest of the frame, and the cell lists, rebuilt by counting sort (no hashing: a cell's index is
//! its position in the grid). A pair is a candidate iff the two swept boxes overlap; it is
//! reported from exactly one cell, the one holding the low corner of the boxes' intersection, so
//! no pair table is stored. Cells are as large as the largest swept box, so a box covers at most
//! two cells per dimension; this is the usual grid's weakness with mixed speeds, which the
//! benchmark is meant to show. It never computes contact times or touches velocities.

use crate::bodies::Bodies;
use glam::DVec3;

/// Relative padding on box ends, far above the rounding of a position update.
const RELATIVE_PADDING: f64 = 1e-12;

/// Uniform grid over swept boxes.
#[derive(Debug, Default)]
pub struct UniformGrid {
    origin: DVec3,
    cell_size: f64,
    cells_per_side: [usize; 3],
    /// Each body slot's swept box, valid while the body's stamp equals `box_stamp`.
    low: Vec<DVec3>,
    high: Vec<DVec3>,
    box_stamp: Vec<u32>,
    /// The body's stamp when the cell lists were last built: entries of bodies whose stamp has
    /// moved on since are void (their fresh box is in `late`).
    binned_stamp: Vec<u32>,
    /// `cell_bodies[cell_start[c]..cell_start[c + 1]]` are the bodies whose box covers cell c.
    cell_start: Vec<u32>,
    cell_bodies: Vec<u32>,
    /// Bodies whose box changed since the last build, with the stamp of that box.
    late: Vec<(u32, u32)>,
}

/// Swept box of body `b` from its position at `t` until `frame_end`.
#[inline]
fn swept_box(bodies: &Bodies, b: usize, t: f64, frame_end: f64) -> (DVec3, DVec3) {
    let start = bodies.position_at(b, t);
    let end = start + bodies.velocity[b] * (frame_end - t);
    let pad = bodies.radius[b] + RELATIVE_PADDING * (start.abs().max(end.abs()).max_element() + bodies.radius[b]);
    (start.min(end) - DVec3::splat(pad), start.max(end) + DVec3::splat(pad))
}

impl UniformGrid {
    /// Frame start: computes every live body's swept box over `[t0, frame_end]`, sizes the cells
    /// to the largest box (but no more cells than a few per body) and bins all boxes.
    pub fn rebuild(&mut self, bodies: &Bodies, box_min: DVec3, box_max: DVec3, t0: f64, frame_end: f64) {
        let slots = bodies.slots();
        self.low.resize(slots, DVec3::ZERO);
        self.high.resize(slots, DVec3::ZERO);
        self.box_stamp.resize(slots, 0);
        self.binned_stamp.resize(slots, 0);
        let mut largest: f64 = 0.0;
        let mut live = 0usize;
        for b in 0..slots {
            if bodies.alive[b] {
                let (low, high) = swept_box(bodies, b, t0, frame_end);
                (self.low[b], self.high[b], self.box_stamp[b]) = (low, high, bodies.stamp[b]);
                largest = largest.max((high - low).max_element());
                live += 1;
            }
        }
        let extent = box_max - box_min;
        let fewest = (extent.x * extent.y * extent.z / (4 * live.max(1)) as f64).cbrt();
        self.cell_size = largest.max(fewest).max(f64::MIN_POSITIVE);
        self.origin = box_min;
        self.cells_per_side = [0, 1, 2].map(|k| ((extent[k] / self.cell_size).floor() as usize + 1).max(1));
        self.bin(bodies);
    }

    #[inline]
    fn cell_coordinates(&self, point: DVec3) -> [usize; 3] {
        [0, 1, 2].map(|k| {
            let c = ((point[k] - self.origin[k]) / self.cell_size).floor();
            c.clamp(0.0, (self.cells_per_side[k] - 1) as f64) as usize
        })
    }

    #[inline]
    fn cell_index(&self, c: [usize; 3]) -> usize {
        (c[0] * self.cells_per_side[1] + c[1]) * self.cells_per_side[2] + c[2]
    }

    /// Calls `visit(cell)` for every cell the box `[low, high]` covers.
    #[inline]
    fn for_each_cell(&self, low: DVec3, high: DVec3, mut visit: impl FnMut(usize)) {
        let (a, b) = (self.cell_coordinates(low), self.cell_coordinates(high));
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    visit(self.cell_index([x, y, z]));
                }
            }
        }
    }

    /// True when body `b`'s stored box bounds its current path. False between a velocity change
    /// and the body's [`Self::update_and_query`] (the world re-tests both bodies of a collision one
    /// after the other): such a body must not be binned with its old box.
    #[inline]
    fn has_current_box(&self, bodies: &Bodies, b: usize) -> bool {
        bodies.alive[b] && self.box_stamp[b] == bodies.stamp[b]
    }

    /// Bins the current boxes of all live bodies by counting sort and empties `late`.
    fn bin(&mut self, bodies: &Bodies) {
        let cells = self.cells_per_side.iter().product::<usize>();
        let mut start = std::mem::take(&mut self.cell_start);
        start.clear();
        start.resize(cells + 1, 0);
        for b in 0..bodies.slots() {
            if self.has_current_box(bodies, b) {
                self.for_each_cell(self.low[b], self.high[b], |c| start[c + 1] += 1);
            }
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        let mut fill = std::mem::take(&mut self.cell_bodies);
        fill.resize(start[cells] as usize, 0);
        // Writes cell c's bodies from start[c] on, shifting start[c] to the next cell's start...
        for b in 0..bodies.slots() {
            if self.has_current_box(bodies, b) {
                self.for_each_cell(self.low[b], self.high[b], |c| {
                    fill[start[c] as usize] = b as u32;
                    start[c] += 1;
                });
            }
            // Not binned: a stamp it no longer has, so its next fresh box goes to `late`.
            self.binned_stamp[b] = self.box_stamp[b];
        }
        // ...so shifting back by one cell restores the starts.
        start.copy_within(0..cells, 1);
        start[0] = 0;
        self.cell_start = start;
        self.cell_bodies = fill;
        self.late.clear();
    }

    #[inline]
    fn overlap(&self, i: usize, j: usize) -> bool {
        self.low[i].cmple(self.high[j]).all() && self.low[j].cmple(self.high[i]).all()
    }

    /// The cell holding the low corner of the intersection of the boxes of `i` and `j`.
    #[inline]
    fn owner_cell(&self, i: usize, j: usize) -> usize {
        self.cell_index(self.cell_coordinates(self.low[i].max(self.low[j])))
    }

    /// Calls `report(i, j)` (i < j) once for every pair whose swept boxes overlap. Call right
    /// after [`Self::rebuild`], before any body changes velocity.
    pub fn for_each_pair(&self, mut report: impl FnMut(u32, u32)) {
        for c in 0..self.cell_start.len() - 1 {
            let cell = &self.cell_bodies[self.cell_start[c] as usize..self.cell_start[c + 1] as usize];
            for (k, &i) in cell.iter().enumerate() {
                for &j in &cell[k + 1..] {
                    let (i, j) = (i as usize, j as usize);
                    if self.overlap(i, j) && self.owner_cell(i, j) == c {
                        report(i.min(j) as u32, i.max(j) as u32);
                    }
                }
            }
        }
    }

    /// Replaces the box of `body` by its swept box from `t` (after it changed velocity) and calls
    /// `report(other)` once for every body whose box overlaps the new one.
    pub fn update_and_query(&mut self, body: u32, bodies: &Bodies, t: f64, frame_end: f64, mut report: impl FnMut(u32)) {
        let q = body as usize;
        let (low, high) = swept_box(bodies, q, t, frame_end);
        (self.low[q], self.high[q], self.box_stamp[q]) = (low, high, bodies.stamp[q]);
        self.late.push((body, bodies.stamp[q]));
        // The late list is scanned linearly by every query: rebin once it is no longer small.
        if self.late.len() > 64 + bodies.slots() / 128 {
            self.bin(bodies);
        }
        let is_current = |j: usize, stamp: u32| j != q && bodies.alive[j] && bodies.stamp[j] == stamp;
        self.for_each_cell(low, high, |c| {
            for &j in &self.cell_bodies[self.cell_start[c] as usize..self.cell_start[c + 1] as usize] {
                let j = j as usize;
                if is_current(j, self.binned_stamp[j]) && self.overlap(q, j) && self.owner_cell(q, j) == c {
                    report(j as u32);
                }
            }
        });
        for &(j, stamp) in &self.late {
            let j = j as usize;
            // A body binned since its last change is already reported from the cells.
            if is_current(j, stamp) && self.binned_stamp[j] != stamp && self.overlap(q, j) {
                report(j as u32);
            }
        }
    }

    /// Bytes held.
    pub fn memory_bytes(&self) -> usize {
        (self.low.capacity() + self.high.capacity()) * 24
            + (self.box_stamp.capacity() + self.binned_stamp.capacity()) * 4
            + (self.cell_start.capacity() + self.cell_bodies.capacity()) * 4
            + self.late.capacity() * 8
    }
}
