//! Sweep and prune over the axis pool: one sorted interval list per pool axis, holding only the
//! bodies that use that axis.
//!
//! It owns the per-axis lists, each body's current axis set, and the candidate rule: a pair is a
//! candidate iff its intervals overlap on every axis the two share. Each pair is examined on one
//! axis only, the lowest-numbered axis the two share, so no pair is reported twice and no pair
//! table is ever stored: memory is O(bodies x axes per body). It never computes contact times or
//! touches velocities.
//!
//! Two things go beyond the paper. First, a single list per axis compares bodies along one
//! direction only, and the axes two bodies share all lie near the direction orthogonal to both
//! velocities, so with many bodies almost every pair whose paths pass within reach would be
//! enumerated. Each list is therefore tiled by the plane orthogonal to its axis: entries are
//! sorted by (tile, start) with each body's tile taken at the midpoint of its path over the frame,
//! tiles are at least twice the largest distance a body's surface can be from that midpoint, and
//! a tile is swept only against itself and its
//! neighbours. Within a tile the sort key is still the projection on a velocity-orthogonal axis,
//! so insertion sort keeps its near-linear cost. Second, entries are never searched for and
//! deleted: each carries its body's velocity stamp; a stale entry is skipped and dropped later.
//! A body that changes velocity mid-frame gets fresh entries in a small per-axis `pending` list.

use super::{BroadPhase, PrepareCounts};
use crate::axis_pool::AxisPool;
use crate::bounding_volume::{interval, select_axes, Interval};
use crate::broad_phase::coherent_sort::coherent_sort;
use crate::broad_phase::proxy::{CompactBox, Proxies, Reported};
use crate::parallel::Workers;
use crate::window::Window;
use glam::DVec3;
use std::sync::Arc;

/// Relative margin on tile reach, far above rounding.
const REACH_MARGIN: f64 = 1e-9;
/// Most tiles along one side of an axis plane, so tile ids fit in 32 bits.
const MAX_TILES_PER_SIDE: f64 = 60_000.0;

/// One body's interval on one axis, valid while the body's stamp equals `stamp`, with the body's
/// axis set (pools of at most 64 axes) and its swept box, so a pair is pruned on the spot.
#[derive(Debug, Clone, Copy)]
struct Entry {
    lo: f64,
    hi: f64,
    body: u32,
    stamp: u32,
    tile: u32,
    mask: u64,
    bbox: CompactBox,
}

impl Entry {
    /// Sort order: by tile, then by interval start.
    #[inline]
    fn precedes(&self, other: &Entry) -> bool {
        (self.tile, self.lo) < (other.tile, other.lo)
    }

    /// The same order as a total order, for the standard sorts.
    fn order(a: &Entry, b: &Entry) -> std::cmp::Ordering {
        a.tile.cmp(&b.tile).then(a.lo.total_cmp(&b.lo))
    }
}

#[derive(Debug)]
struct AxisList {
    /// Sorted by (tile, lo).
    sorted: Vec<Entry>,
    /// Entries added since the last merge, unsorted.
    pending: Vec<Entry>,
    /// Widest interval in `sorted`: bounds how far back a range query must look.
    max_width: f64,
    /// Orthonormal basis of the plane orthogonal to the axis, and the plane's lowest corner.
    across: DVec3,
    up: DVec3,
    origin: [f64; 2],
}

/// The tiling shared by all axis planes.
#[derive(Debug, Clone, Copy)]
struct Tiling {
    size: f64,
    /// Tiles per side of every axis plane.
    side: u32,
}

impl Tiling {
    #[inline]
    fn coordinate(&self, value: f64, origin: f64) -> u32 {
        ((value - origin) / self.size).floor().clamp(0.0, (self.side - 1) as f64) as u32
    }
}

/// The VADOP broad phase.
#[derive(Debug)]
pub struct SweepPrune {
    pool: Arc<AxisPool>,
    sin_phi: f64,
    lists: Vec<AxisList>,
    /// Ascending pool-axis ids per body slot.
    axes_of: Vec<Vec<u32>>,
    /// True when the pool has at most 64 axes: axis sets are bit masks and a pair's lowest shared
    /// axis is one `trailing_zeros` away.
    masked: bool,
    /// The proxy stamp each body's entries were made with (`None`: no entries yet).
    entered: Vec<Option<u32>>,
    /// Scratch: the axes of the body being queried.
    query_axes: Vec<u32>,
    tiling: Tiling,
    /// Side of the box's projection on any axis plane (its diagonal bounds all of them).
    plane_extent: f64,
    /// Largest radius plus distance still to travel in the frame, over all live entries.
    max_reach: f64,
    /// False for the classic, untiled sweep and prune (one run per list), kept as a baseline.
    tiled: bool,
}

#[inline]
fn is_live(entry: &Entry, proxies: Proxies) -> bool {
    proxies.is_current(entry.body as usize, entry.stamp)
}

/// Midpoint of body `b`'s path over its proxy window: the point its tile is taken from.
#[inline]
fn path_midpoint(proxies: Proxies, b: usize) -> DVec3 {
    proxies.origin(b) + proxies.velocity(b) * (0.5 * proxies.window_of(b).duration())
}

/// How far body `b`'s surface can be from its path midpoint over its proxy window: its bounding
/// radius plus half the path. Measuring from the midpoint rather than the start halves the tiles
/// fast bodies need.
#[inline]
fn reach(proxies: Proxies, b: usize) -> f64 {
    proxies.radius(b) + proxies.velocity(b).length() * 0.5 * proxies.window_of(b).duration()
}

/// Body `b`'s interval on `axis` over its proxy window.
#[inline]
fn body_interval(axis: DVec3, proxies: Proxies, b: usize) -> Interval {
    interval(axis, proxies.origin(b), proxies.velocity(b), proxies.radius(b), proxies.window_of(b).duration())
}

impl AxisList {
    fn new(axis: DVec3, min: DVec3, max: DVec3) -> AxisList {
        let across = axis.any_orthonormal_vector();
        let up = axis.cross(across);
        let corners = (0..8).map(|k| {
            DVec3::new(
                if k & 1 == 0 { min.x } else { max.x },
                if k & 2 == 0 { min.y } else { max.y },
                if k & 4 == 0 { min.z } else { max.z },
            )
        });
        let origin = corners.fold([f64::INFINITY; 2], |o, c| [o[0].min(c.dot(across)), o[1].min(c.dot(up))]);
        AxisList { sorted: Vec::new(), pending: Vec::new(), max_width: 0.0, across, up, origin }
    }

    #[inline]
    fn tile_of(&self, tiling: &Tiling, centre: DVec3) -> u32 {
        tiling.coordinate(centre.dot(self.across), self.origin[0]) * tiling.side
            + tiling.coordinate(centre.dot(self.up), self.origin[1])
    }

    /// The run of `sorted` in tile `tile`.
    #[inline]
    fn run(&self, tile: u32) -> &[Entry] {
        let start = self.sorted.partition_point(|e| e.tile < tile);
        let len = self.sorted[start..].partition_point(|e| e.tile == tile);
        &self.sorted[start..start + len]
    }

    /// Drops void entries and merges `pending` into `sorted`. Valid mid-frame: every entry still
    /// bounds its body over the rest of the frame, whenever it was computed.
    fn absorb_pending(&mut self, proxies: Proxies) {
        self.sorted.retain(|e| is_live(e, proxies));
        self.pending.retain(|e| is_live(e, proxies));
        self.merge_pending();
        self.max_width = self.sorted.iter().map(|e| e.hi - e.lo).fold(0.0, f64::max);
    }

    /// Sorts `pending` and merges it into `sorted` in linear time, in place from the back, so
    /// no frame allocates once the lists have grown. Ties keep `sorted` first, as a stable sort
    /// of the two runs would.
    fn merge_pending(&mut self) {
        self.pending.sort_unstable_by(Entry::order);
        let (mut i, mut j) = (self.sorted.len(), self.pending.len());
        self.sorted.extend_from_slice(&self.pending);
        // Invariant: slots [i + j, len) hold the merged tail; [0, i) is still the untouched head.
        while j > 0 {
            let k = i + j - 1;
            if i > 0 && Entry::order(&self.pending[j - 1], &self.sorted[i - 1]).is_lt() {
                self.sorted[k] = self.sorted[i - 1];
                i -= 1;
            } else {
                self.sorted[k] = self.pending[j - 1];
                j -= 1;
            }
        }
        self.pending.clear();
    }
}

impl SweepPrune {
    /// An empty broad phase over `pool` for bodies in the box `[min, max]`, selecting axes within
    /// angle asin(`sin_phi`) of the plane orthogonal to each body's velocity (`sin_phi` = 1: every
    /// axis, a swept k-DOP). `tiled` = false gives the classic sweep and prune of the paper and of
    /// most engines, one sorted run per axis.
    pub fn new(pool: Arc<AxisPool>, sin_phi: f64, min: DVec3, max: DVec3, tiled: bool) -> SweepPrune {
        let lists = pool.axes().iter().map(|&a| AxisList::new(a, min, max)).collect();
        let plane_extent = (max - min).length();
        let masked = pool.len() <= 64;
        SweepPrune {
            pool,
            sin_phi,
            lists,
            axes_of: Vec::new(),
            masked,
            entered: Vec::new(),
            query_axes: Vec::new(),
            tiling: Tiling { size: plane_extent, side: 1 },
            plane_extent,
            max_reach: 0.0,
            tiled,
        }
    }

    /// The axis pool.
    pub fn pool(&self) -> &Arc<AxisPool> {
        &self.pool
    }

    /// Ascending ids of the axes body `body` uses (empty for unknown bodies).
    pub fn axes_of(&self, body: u32) -> &[u32] {
        self.axes_of.get(body as usize).map_or(&[], |a| a.as_slice())
    }

    /// Picks body `b`'s axes for its proxy's velocity and adds fresh entries to the lists' pending
    /// parts (its old entries carry an old stamp and are void). Mid-window (`absorb`), a pending
    /// part that grows beyond small is merged in at once, because queries scan it linearly; at a
    /// window's start the sort merges everything once.
    fn enter_entries(&mut self, b: usize, proxies: Proxies, absorb: bool) {
        if self.axes_of.len() <= b {
            self.axes_of.resize_with(b + 1, Vec::new);
            self.entered.resize(b + 1, None);
        }
        let mut axes = std::mem::take(&mut self.axes_of[b]);
        select_axes(&self.pool, proxies.velocity(b), self.sin_phi, &mut axes);
        let midpoint = path_midpoint(proxies, b);
        self.max_reach = self.max_reach.max(reach(proxies, b));
        let (mask, bbox) = (self.mask_of(&axes), proxies.bbox(b));
        for &a in &axes {
            let iv = body_interval(self.pool.axis(a), proxies, b);
            let list = &mut self.lists[a as usize];
            let tile = list.tile_of(&self.tiling, midpoint);
            list.pending.push(Entry {
                lo: iv.lo,
                hi: iv.hi,
                body: b as u32,
                stamp: proxies.stamp(b),
                tile,
                mask,
                bbox,
            });
            if absorb && list.pending.len() > 64 + list.sorted.len() / 128 {
                list.absorb_pending(proxies);
            }
        }
        self.axes_of[b] = axes;
        self.entered[b] = Some(proxies.stamp(b));
    }

    /// The bit mask of an axis set (0 for pools of more than 64 axes, which use the lists).
    #[inline]
    fn mask_of(&self, axes: &[u32]) -> u64 {
        if self.masked {
            axes.iter().fold(0, |m, &a| m | 1 << a)
        } else {
            0
        }
    }

    /// True when the pair of entries `e` (of body `i`, whose axes are `axes_i`) and `f` is a
    /// candidate through `axis`: their swept boxes overlap, `axis` is the lowest axis the two
    /// bodies share (so the pair is reported once), and their intervals overlap on every other
    /// shared axis.
    #[inline]
    fn is_candidate(&self, e: &Entry, axes_i: &[u32], f: &Entry, axis: u32, proxies: Proxies) -> bool {
        if !e.bbox.overlaps(&f.bbox) {
            return false;
        }
        let (i, j) = (e.body as usize, f.body as usize);
        if !self.masked {
            return self.shared_axes_overlap(i, axes_i, j, axis, proxies);
        }
        let shared = e.mask & f.mask;
        if shared.trailing_zeros() != axis {
            return false;
        }
        let mut rest = shared & (shared - 1);
        while rest != 0 {
            let a = self.pool.axis(rest.trailing_zeros());
            if !body_interval(a, proxies, i).overlaps(body_interval(a, proxies, j)) {
                return false;
            }
            rest &= rest - 1;
        }
        true
    }

    /// [`Self::is_candidate`]'s axis rule for pools of more than 64 axes, on the sorted lists.
    fn shared_axes_overlap(&self, i: usize, axes_i: &[u32], j: usize, axis: u32, proxies: Proxies) -> bool {
        let axes_j = &self.axes_of[j];
        let (mut x, mut y) = (0, 0);
        let mut first = true;
        while x < axes_i.len() && y < axes_j.len() {
            let (ai, aj) = (axes_i[x], axes_j[y]);
            if ai < aj {
                x += 1;
            } else if aj < ai {
                y += 1;
            } else {
                if first {
                    // Only the pair's lowest shared axis reports it: exactly once.
                    if ai != axis {
                        return false;
                    }
                    first = false;
                } else {
                    let a = self.pool.axis(ai);
                    if !body_interval(a, proxies, i).overlaps(body_interval(a, proxies, j)) {
                        return false;
                    }
                }
                x += 1;
                y += 1;
            }
        }
        !first
    }

    /// Calls `report` for every candidate pair reported through axis `axis` (the lowest axis of
    /// the pair's shared ones): sweeps each tile of its list against itself and half of its
    /// neighbours.
    fn list_pairs(&self, axis: u32, proxies: Proxies, mut report: impl FnMut(Reported, Reported, Window)) {
        let side = self.tiling.side;
        let list = &self.lists[axis as usize];
        let mut check = |e: &Entry, f: &Entry| {
            if self.is_candidate(e, &self.axes_of[e.body as usize], f, axis, proxies) {
                let (i, j) = (e.body as usize, f.body as usize);
                report(proxies.reported(i), proxies.reported(j), proxies.window_of(i).intersect(proxies.window_of(j)));
            }
        };
        let mut start = 0;
        while start < list.sorted.len() {
            let tile = list.sorted[start].tile;
            let len = list.sorted[start..].partition_point(|e| e.tile == tile);
            let run = &list.sorted[start..start + len];
            start += len;
            for (k, e) in run.iter().enumerate() {
                for f in run[k + 1..].iter().take_while(|f| f.lo <= e.hi) {
                    check(e, f);
                }
            }
            // Half of the 8 neighbours, so each pair of adjacent tiles is swept once.
            let (row, col) = (tile / side, tile % side);
            let neighbours = [(row, col + 1), (row + 1, col.wrapping_sub(1)), (row + 1, col), (row + 1, col + 1)];
            for (r, c) in neighbours {
                if r >= side || c >= side {
                    continue;
                }
                let other = list.run(r * side + c);
                let mut first = 0;
                for e in run {
                    while first < other.len() && other[first].lo < e.lo - list.max_width {
                        first += 1;
                    }
                    for f in other[first..].iter().take_while(|f| f.lo <= e.hi) {
                        if f.hi >= e.lo {
                            check(e, f);
                        }
                    }
                }
            }
        }
    }

    /// True when bodies `i` and `j` use at least one common axis (the invariant that makes
    /// pruning safe: a pair is only ever pruned on a true separating axis).
    pub fn shares_axis(&self, i: u32, j: u32) -> bool {
        let (axes_i, axes_j) = (self.axes_of(i), self.axes_of(j));
        let (mut x, mut y) = (0, 0);
        while x < axes_i.len() && y < axes_j.len() {
            match axes_i[x].cmp(&axes_j[y]) {
                std::cmp::Ordering::Less => x += 1,
                std::cmp::Ordering::Greater => y += 1,
                std::cmp::Ordering::Equal => return true,
            }
        }
        false
    }
}

impl BroadPhase for SweepPrune {
    /// Drops void entries, sizes the tiles for the window, recomputes every interval and tile
    /// (c_update folded in: the intervals are the lists' own), then sorts every list by (tile,
    /// interval start).
    fn prepare(&mut self, proxies: Proxies, _workers: &Workers) -> PrepareCounts {
        for b in 0..proxies.slots() {
            if proxies.is_live(b) && self.entered.get(b).copied().flatten() != Some(proxies.stamp(b)) {
                self.enter_entries(b, proxies, false);
            }
        }
        let mut max_reach: f64 = 0.0;
        for b in 0..proxies.slots() {
            if proxies.is_live(b) {
                max_reach = max_reach.max(reach(proxies, b));
            }
        }
        // Bodies that touch during the window have path midpoints at most 2 * max_reach apart in
        // any plane, so they lie in the same or adjacent tiles. Resize only when the tiles are
        // too small or far too large, so the sort stays coherent from window to window.
        let needed = 2.0 * max_reach * (1.0 + REACH_MARGIN) + f64::MIN_POSITIVE;
        let size = self.tiling.size;
        if self.tiled && (size < needed || size > 2.0 * needed) {
            let size = (1.1 * needed).max(self.plane_extent / MAX_TILES_PER_SIDE);
            let side = ((self.plane_extent / size).floor() as u32 + 1).max(1);
            self.tiling = Tiling { size, side };
        }
        self.max_reach = max_reach;
        let tiling = self.tiling;
        let mut counts = PrepareCounts::default();
        for (a, list) in self.lists.iter_mut().enumerate() {
            let axis = self.pool.axis(a as u32);
            let (across, up, origin) = (list.across, list.up, list.origin);
            let refresh = |e: &mut Entry| {
                let b = e.body as usize;
                let iv = body_interval(axis, proxies, b);
                e.lo = iv.lo;
                e.hi = iv.hi;
                e.bbox = proxies.bbox(b);
                let midpoint = path_midpoint(proxies, b);
                e.tile = tiling.coordinate(midpoint.dot(across), origin[0]) * tiling.side
                    + tiling.coordinate(midpoint.dot(up), origin[1]);
            };
            list.pending.retain_mut(|e| {
                let live = is_live(e, proxies);
                if live {
                    refresh(e);
                }
                live
            });
            // An entry that changed tile jumps a whole tile row in the (tile, start) order: it
            // joins `pending`, to be merged in, so insertion sort only sees moves within a tile.
            let pending = &mut list.pending;
            list.sorted.retain_mut(|e| {
                if !is_live(e, proxies) {
                    return false;
                }
                let tile = e.tile;
                refresh(e);
                if e.tile != tile {
                    pending.push(*e);
                    return false;
                }
                true
            });
            counts.moves += coherent_sort(&mut list.sorted, Entry::precedes);
            // Entries added or moved to another tile since the last window are sorted apart and
            // merged: appended at the end they would each travel the whole list and spend
            // insertion sort's budget.
            if !list.pending.is_empty() {
                list.merge_pending();
            }
            counts.entries += list.sorted.len() as u64;
            list.max_width = list.sorted.iter().map(|e| e.hi - e.lo).fold(0.0, f64::max);
        }
        counts
    }

    /// The axis lists are independent: workers sweep whole lists.
    fn find_pairs<T: Send>(
        &mut self,
        proxies: Proxies,
        workers: &Workers,
        predict: impl Fn(Reported, Reported, Window, &mut Vec<T>) + Sync + Send,
        out: &mut Vec<T>,
    ) -> u64 {
        let this = &*self;
        let counts = workers.extend_ranges(this.lists.len(), out, |axes, found| {
            let mut candidates = 0u64;
            for a in axes {
                this.list_pairs(a as u32, proxies, |x, y, window| {
                    candidates += 1;
                    predict(x, y, window, found);
                });
            }
            candidates
        });
        counts.iter().sum()
    }

    /// Picks the body's axes for its new velocity, adds fresh entries (its old ones carry an old
    /// stamp and are void) and reports its candidate partners.
    fn query(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, mut report: impl FnMut(Reported, Window)) {
        let b = body as usize;
        let mut axes = std::mem::take(&mut self.query_axes);
        select_axes(&self.pool, proxies.velocity(b), self.sin_phi, &mut axes);
        let midpoint = path_midpoint(proxies, b);
        let body_reach = reach(proxies, b);
        let window = proxies.window_of(b);
        let distance = (body_reach + self.max_reach.max(body_reach)) * (1.0 + REACH_MARGIN)
            + REACH_MARGIN * midpoint.abs().max_element();
        let mask = self.mask_of(&axes);
        for &a in &axes {
            let query = body_interval(self.pool.axis(a), proxies, b);
            let own = Entry {
                lo: query.lo,
                hi: query.hi,
                body,
                stamp: proxies.stamp(b),
                tile: 0,
                mask,
                bbox: proxies.bbox(b),
            };
            let list = &self.lists[a as usize];
            let mut visit = |e: &Entry| {
                if e.body == body || Some(e.body) == skip || e.hi < query.lo || e.lo > query.hi || !is_live(e, proxies)
                {
                    return;
                }
                if self.is_candidate(&own, &axes, e, a, proxies) {
                    report(proxies.reported(e.body as usize), window.intersect(proxies.window_of(e.body as usize)));
                }
            };
            let (x, y) = (midpoint.dot(list.across), midpoint.dot(list.up));
            let tiling = &self.tiling;
            let rows =
                tiling.coordinate(x - distance, list.origin[0])..=tiling.coordinate(x + distance, list.origin[0]);
            for row in rows {
                let cols =
                    tiling.coordinate(y - distance, list.origin[1])..=tiling.coordinate(y + distance, list.origin[1]);
                for col in cols {
                    let run = list.run(row * tiling.side + col);
                    let start = run.partition_point(|e| e.lo < query.lo - list.max_width);
                    run[start..].iter().take_while(|e| e.lo <= query.hi).for_each(&mut visit);
                }
            }
            list.pending.iter().for_each(&mut visit);
        }
        self.query_axes = axes;
    }

    /// Reports the body's candidate partners on its new axes against the lists as they were, then
    /// enters its fresh entries.
    fn update(&mut self, body: u32, proxies: Proxies, skip: Option<u32>, report: impl FnMut(Reported, Window)) {
        self.query(body, proxies, skip, report);
        self.enter_entries(body as usize, proxies, true);
    }

    /// Bytes held by the lists and axis sets (capacity, not just length).
    fn memory_bytes(&self) -> usize {
        let lists: usize = self
            .lists
            .iter()
            .map(|l| (l.sorted.capacity() + l.pending.capacity()) * std::mem::size_of::<Entry>())
            .sum();
        let axes: usize = self.axes_of.iter().map(|a| a.capacity() * 4 + std::mem::size_of::<Vec<u32>>()).sum();
        lists + axes + self.lists.capacity() * std::mem::size_of::<AxisList>()
    }
}
