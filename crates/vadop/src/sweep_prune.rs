//! Sweep and prune over the axis pool: one sorted interval list per pool axis, holding only the
//! bodies that use that axis.
//!
//! It owns the per-axis lists, each body's current axis set, and the candidate rule: a pair is a
//! candidate iff its intervals overlap on every axis the two share. Each pair is examined on one
//! axis only, the lowest-numbered axis the two share, so no pair is reported twice and no pair
//! table is ever stored: memory is O(bodies x axes per body). Lists are re-sorted every frame by
//! insertion sort, which costs little because velocity-aligned projections barely move.
//!
//! Entries are never searched for and deleted: each carries its body's velocity stamp, and an
//! entry whose stamp is old (the body changed velocity or was removed) is simply skipped, then
//! dropped at the next frame start. A body that changes velocity mid-frame gets fresh entries in a
//! small per-axis `pending` list. This module never computes contact times or touches velocities.

use crate::axis_pool::AxisPool;
use crate::bodies::Bodies;
use crate::bounding_volume::{interval, select_axes, Interval};
use std::sync::Arc;

/// One body's interval on one axis, valid while the body's stamp equals `stamp`.
#[derive(Debug, Clone, Copy)]
struct Entry {
    lo: f64,
    hi: f64,
    body: u32,
    stamp: u32,
}

#[derive(Debug, Default)]
struct AxisList {
    /// Sorted by `lo` at frame start.
    sorted: Vec<Entry>,
    /// Entries added since the frame started, unsorted.
    pending: Vec<Entry>,
    /// Widest interval in `sorted`: bounds how far back a range query must look.
    max_width: f64,
}

impl AxisList {
    /// Drops void entries and merges `pending` into `sorted`. Valid mid-frame: every entry still
    /// bounds its body over the rest of the frame, whenever it was computed.
    fn absorb_pending(&mut self, bodies: &Bodies) {
        self.sorted.retain(|e| is_live(e, bodies));
        self.sorted.extend(self.pending.drain(..).filter(|e| is_live(e, bodies)));
        // A long sorted run plus a short tail: the stable sort detects the run and merges.
        self.sorted.sort_by(|a, b| a.lo.total_cmp(&b.lo));
        self.max_width = self.sorted.iter().map(|e| e.hi - e.lo).fold(0.0, f64::max);
    }
}

/// Counters of the last frame's sort.
#[derive(Debug, Default, Clone, Copy)]
pub struct SortCounts {
    /// Entry moves made by insertion sort.
    pub swaps: u64,
    /// Entries across all lists.
    pub entries: u64,
}

/// The VADOP broad phase.
#[derive(Debug)]
pub struct SweepPrune {
    pool: Arc<AxisPool>,
    sin_phi: f64,
    lists: Vec<AxisList>,
    /// Ascending pool-axis ids per body slot.
    axes_of: Vec<Vec<u32>>,
}

#[inline]
fn is_live(entry: &Entry, bodies: &Bodies) -> bool {
    let b = entry.body as usize;
    bodies.alive[b] && bodies.stamp[b] == entry.stamp
}

#[inline]
fn ordered(a: u32, b: u32) -> (u32, u32) {
    if a < b { (a, b) } else { (b, a) }
}

/// Appends the entries beyond `sorted_prefix` into place; insertion sort when they are few
/// (coherence keeps each move short), a full merge-sort otherwise (first frame, mass insertions).
fn sort_by_lo(entries: &mut [Entry], sorted_prefix: usize) -> u64 {
    let appended = entries.len() - sorted_prefix;
    if appended > 64 && appended * 8 > entries.len() {
        entries.sort_by(|a, b| a.lo.total_cmp(&b.lo));
        return 0;
    }
    let mut swaps = 0u64;
    for i in 1..entries.len() {
        let entry = entries[i];
        let mut j = i;
        while j > 0 && entries[j - 1].lo > entry.lo {
            entries[j] = entries[j - 1];
            j -= 1;
        }
        swaps += (i - j) as u64;
        entries[j] = entry;
    }
    swaps
}

impl SweepPrune {
    /// An empty broad phase over `pool`, selecting axes within angle asin(`sin_phi`) of the plane
    /// orthogonal to each body's velocity.
    pub fn new(pool: Arc<AxisPool>, sin_phi: f64) -> SweepPrune {
        let lists = (0..pool.len()).map(|_| AxisList::default()).collect();
        SweepPrune { pool, sin_phi, lists, axes_of: Vec::new() }
    }

    /// The axis pool.
    pub fn pool(&self) -> &Arc<AxisPool> {
        &self.pool
    }

    /// Ascending ids of the axes body `body` uses (empty for unknown bodies).
    pub fn axes_of(&self, body: u32) -> &[u32] {
        self.axes_of.get(body as usize).map_or(&[], |a| a.as_slice())
    }

    /// (Re)builds the volume of `body` from its state at time `now` until `frame_end`: picks its
    /// axes and adds fresh entries. Call after the body was added or changed velocity (its stamp
    /// already bumped, which voids its old entries).
    pub fn set_body(&mut self, body: u32, bodies: &Bodies, now: f64, frame_end: f64) {
        let b = body as usize;
        if self.axes_of.len() <= b {
            self.axes_of.resize_with(b + 1, Vec::new);
        }
        let mut axes = std::mem::take(&mut self.axes_of[b]);
        select_axes(&self.pool, bodies.velocity[b], self.sin_phi, &mut axes);
        let position = bodies.position_at(b, now);
        for &a in &axes {
            let iv = interval(self.pool.axis(a), position, bodies.velocity[b], bodies.radius[b], frame_end - now);
            let list = &mut self.lists[a as usize];
            list.pending.push(Entry { lo: iv.lo, hi: iv.hi, body, stamp: bodies.stamp[b] });
            // Queries scan `pending` linearly: once it is no longer small, merge it into `sorted`.
            if list.pending.len() > 32 + list.sorted.len() / 16 {
                list.absorb_pending(bodies);
            }
        }
        self.axes_of[b] = axes;
    }

    /// Forgets a removed body (its entries are already void: it is no longer alive).
    pub fn remove_body(&mut self, body: u32) {
        if let Some(axes) = self.axes_of.get_mut(body as usize) {
            axes.clear();
        }
    }

    /// Frame start, first half (c_update): drops void entries, takes in pending ones, and
    /// recomputes every interval for the frame `[t0, t0 + dt]` (all bodies are at time t0).
    /// Returns the length of each list's already-sorted prefix for [`Self::sort`].
    pub fn update_intervals(&mut self, bodies: &Bodies, dt: f64, sorted_prefix: &mut Vec<usize>) {
        sorted_prefix.clear();
        for (a, list) in self.lists.iter_mut().enumerate() {
            list.sorted.retain(|e| is_live(e, bodies));
            sorted_prefix.push(list.sorted.len());
            list.sorted.extend(list.pending.drain(..).filter(|e| is_live(e, bodies)));
            let axis = self.pool.axis(a as u32);
            for e in &mut list.sorted {
                let b = e.body as usize;
                let iv = interval(axis, bodies.position[b], bodies.velocity[b], bodies.radius[b], dt);
                e.lo = iv.lo;
                e.hi = iv.hi;
            }
        }
    }

    /// Frame start, second half (c_sort): sorts every list by interval start.
    pub fn sort(&mut self, sorted_prefix: &[usize]) -> SortCounts {
        let mut counts = SortCounts::default();
        for (list, &prefix) in self.lists.iter_mut().zip(sorted_prefix) {
            counts.swaps += sort_by_lo(&mut list.sorted, prefix);
            counts.entries += list.sorted.len() as u64;
            list.max_width = list.sorted.iter().map(|e| e.hi - e.lo).fold(0.0, f64::max);
        }
        counts
    }

    /// True when bodies `i < j` overlap on every axis they share and `axis` is the first of those.
    /// Intervals are taken over `[t, frame_end]` from the bodies' positions at `t`.
    #[inline]
    fn is_candidate(&self, i: u32, j: u32, axis: u32, bodies: &Bodies, t: f64, frame_end: f64) -> bool {
        let (axes_i, axes_j) = (&self.axes_of[i as usize], &self.axes_of[j as usize]);
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
                } else if !self.overlap_on(ai, i, j, bodies, t, frame_end) {
                    return false;
                }
                x += 1;
                y += 1;
            }
        }
        !first
    }

    #[inline]
    fn body_interval(&self, axis: u32, body: u32, bodies: &Bodies, t: f64, frame_end: f64) -> Interval {
        let b = body as usize;
        interval(self.pool.axis(axis), bodies.position_at(b, t), bodies.velocity[b], bodies.radius[b], frame_end - t)
    }

    #[inline]
    fn overlap_on(&self, axis: u32, i: u32, j: u32, bodies: &Bodies, t: f64, frame_end: f64) -> bool {
        self.body_interval(axis, i, bodies, t, frame_end)
            .overlaps(self.body_interval(axis, j, bodies, t, frame_end))
    }

    /// Calls `report(i, j)` (i < j) once for every candidate pair of the frame `[t0, frame_end]`.
    /// Call right after [`Self::sort`], before any body changes velocity.
    pub fn for_each_pair(&self, bodies: &Bodies, t0: f64, frame_end: f64, mut report: impl FnMut(u32, u32)) {
        for (a, list) in self.lists.iter().enumerate() {
            let entries = &list.sorted;
            for (k, e) in entries.iter().enumerate() {
                for f in &entries[k + 1..] {
                    if f.lo > e.hi {
                        break;
                    }
                    let (i, j) = ordered(e.body, f.body);
                    if self.is_candidate(i, j, a as u32, bodies, t0, frame_end) {
                        report(i, j);
                    }
                }
            }
        }
    }

    /// Calls `report(other)` once for every body that is a candidate partner of `body` over
    /// `[t, frame_end]` (typically right after `body` changed velocity at time t).
    pub fn for_each_partner(&self, body: u32, bodies: &Bodies, t: f64, frame_end: f64, mut report: impl FnMut(u32)) {
        for &a in &self.axes_of[body as usize] {
            let query = self.body_interval(a, body, bodies, t, frame_end);
            let list = &self.lists[a as usize];
            let start = list.sorted.partition_point(|e| e.lo < query.lo - list.max_width);
            let near = list.sorted[start..].iter().take_while(|e| e.lo <= query.hi);
            for e in near.chain(list.pending.iter()) {
                if e.body == body || e.hi < query.lo || e.lo > query.hi || !is_live(e, bodies) {
                    continue;
                }
                let (i, j) = ordered(body, e.body);
                if self.is_candidate(i, j, a, bodies, t, frame_end) {
                    report(e.body);
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

    /// Bytes held by the lists and axis sets (capacity, not just length).
    pub fn memory_bytes(&self) -> usize {
        let lists: usize = self
            .lists
            .iter()
            .map(|l| (l.sorted.capacity() + l.pending.capacity()) * std::mem::size_of::<Entry>())
            .sum();
        let axes: usize = self.axes_of.iter().map(|a| a.capacity() * 4 + std::mem::size_of::<Vec<u32>>()).sum();
        lists + axes + self.lists.capacity() * std::mem::size_of::<AxisList>()
    }
}
