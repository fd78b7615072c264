//! Start-of-run overlap check: finds a pair of bodies that interpenetrate, in O(n log n).
//!
//! It owns one job, validating a simulate-mode scene before its first frame: collisions can only
//! be resolved between separate bodies. It bins the moving bodies into a grid of cells one
//! largest bounding diameter wide, sorts them by cell index (an index, not a hash) and compares
//! each new body only with the bodies in its 27 neighbouring cells, and every new body with every
//! static one (level geometry is few bodies); the narrow phase decides. On a periodic axis the
//! cells tile the box and wrap around, so bodies touching across a face are compared too. It
//! never changes the bodies.

use crate::bodies::Bodies;
use crate::narrow_phase::contacts::penetration;
use glam::DVec3;

const CELL_BITS: u32 = 21;

/// First pair `(a, b, depth)` in which a body of `new_bodies` overlaps any live body by more than
/// the contact tolerance; touching is allowed.
pub fn first_overlap(bodies: &Bodies, new_bodies: &[u32], time: f64) -> Option<(u32, u32, f64)> {
    let (statics, live): (Vec<u32>, Vec<u32>) = bodies.alive_ids().partition(|&i| bodies.is_fixed(i as usize));
    let mut found: Option<(u32, u32, f64)> = None;
    // Report the lowest pair, independent of the order of checks.
    let mut note = |a: u32, b: u32, depth: f64| {
        let pair = (a.min(b), a.max(b), depth);
        if found.is_none_or(|f| (pair.0, pair.1) < (f.0, f.1)) {
            found = Some(pair);
        }
    };
    for &a in new_bodies.iter().filter(|&&a| !bodies.is_fixed(a as usize)) {
        for &s in &statics {
            if let Some(depth) = penetration(bodies, a as usize, s as usize, time) {
                note(a, s, depth);
            }
        }
    }
    for &s in new_bodies.iter().filter(|&&s| bodies.is_fixed(s as usize)) {
        for &a in &live {
            if let Some(depth) = penetration(bodies, a as usize, s as usize, time) {
                note(a, s, depth);
            }
        }
    }
    let cells = Cells::new(bodies, &live, time, live.iter().map(|&i| bodies.radius(i as usize)).fold(0.0, f64::max));
    for &a in new_bodies.iter().filter(|&&a| !bodies.is_fixed(a as usize)) {
        cells.for_each_near(bodies.position_at(a as usize, time), |b| {
            if b != a {
                if let Some(depth) = penetration(bodies, a as usize, b as usize, time) {
                    note(a, b, depth);
                }
            }
        });
    }
    found
}

/// A grid of cells, each at least one largest diameter wide, over some bodies at an instant:
/// their ids sorted by cell index (an index, not a hash). On a periodic axis the cells tile the
/// box and wrap around, so bodies touching across a face are neighbours too.
pub(crate) struct Cells {
    /// Per axis: the first cell's low end, the cells' width, their count, and whether they wrap.
    axes: [(f64, f64, u64, bool); 3],
    by_cell: Vec<(u64, u32)>,
}

impl Cells {
    /// The cells of the bodies `ids` at `time`, for bodies of radius at most `largest`.
    pub(crate) fn new(bodies: &Bodies, ids: &[u32], time: f64, largest: f64) -> Cells {
        let position = |i: u32| bodies.position_at(i as usize, time);
        let (lo, hi) = ids.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
            let p = position(i);
            (lo.min(p), hi.max(p))
        });
        // Cells at least one diameter wide, and few enough per axis to fit the key. On a periodic
        // axis they tile the box's side, and the neighbours of the last cell are the first ones.
        let limit = (1u64 << CELL_BITS) as f64 - 2.0;
        let cell = (2.0 * largest).max((hi - lo).max_element() / limit).max(f64::MIN_POSITIVE);
        let periodic = bodies.periodic;
        let axes = std::array::from_fn(|a| match periodic.axes[a] {
            true => {
                let count = ((periodic.side[a] / cell).floor() as u64).clamp(1, limit as u64);
                (periodic.min[a], periodic.side[a] / count as f64, count, true)
            }
            false => (lo[a], cell, u64::MAX, false),
        });
        let mut cells = Cells { axes, by_cell: Vec::with_capacity(ids.len()) };
        let by_cell: Vec<(u64, u32)> = ids.iter().map(|&i| (cells.key(cells.coords(position(i))), i)).collect();
        cells.by_cell = by_cell;
        cells.by_cell.sort_unstable();
        cells
    }

    fn coords(&self, p: DVec3) -> [u64; 3] {
        std::array::from_fn(|a| {
            let (origin, width, count, _) = self.axes[a];
            (((p[a] - origin) / width).floor().max(0.0) as u64).min(count - 1)
        })
    }

    fn key(&self, c: [u64; 3]) -> u64 {
        c[0] | (c[1] << CELL_BITS) | (c[2] << (2 * CELL_BITS))
    }

    /// The cells next to coordinate `c` on axis `a` (itself included), each once.
    fn near(&self, a: usize, c: u64) -> ([u64; 3], usize) {
        let (_, _, count, wraps) = self.axes[a];
        let mut cells = [0u64; 3];
        let mut n = 0;
        for step in 0..3u64 {
            let next = match wraps {
                true => (c + count - 1 + step) % count,
                false if c + step == 0 => continue,
                false => c + step - 1,
            };
            if !cells[..n].contains(&next) {
                cells[n] = next;
                n += 1;
            }
        }
        (cells, n)
    }

    /// Calls `f` with every body in the cells next to `position`'s: every body within one cell
    /// width of it, and some farther.
    pub(crate) fn for_each_near(&self, position: DVec3, mut f: impl FnMut(u32)) {
        let c = self.coords(position);
        let ((zs, nz), (ys, ny), (xs, nx)) = (self.near(2, c[2]), self.near(1, c[1]), self.near(0, c[0]));
        for &z in &zs[..nz] {
            for &y in &ys[..ny] {
                for &x in &xs[..nx] {
                    let k = self.key([x, y, z]);
                    let start = self.by_cell.partition_point(|&(ck, _)| ck < k);
                    for &(_, b) in self.by_cell[start..].iter().take_while(|&&(ck, _)| ck == k) {
                        f(b);
                    }
                }
            }
        }
    }
}
