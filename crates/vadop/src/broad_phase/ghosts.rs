//! Ghosts: the periodic images of proxies, so broad phases find pairs across periodic faces
//! without knowing the box is periodic.
//!
//! In a box with periodic axes a body near a face meets the bodies near the opposite face through
//! its image one side away. A ghost is that image as a proxy of its own, in a slot past every
//! body's (from [`Ghosts::base`]): the body's swept box and motion shifted by whole sides. A proxy
//! whose box reaches across a face gets a ghost for every combination of the faces it crosses
//! (at most one per axis, for no proxy spans a third of a side: at most seven). That is enough:
//! when one body's box overlaps another's image across a face, the first reaches past that face
//! at least as far as the second stays short of the opposite one, so whichever of the two
//! reaches across has its ghost there, and the broad phase reports the pair through it, or
//! through two ghosts across a corner. Ghost slots are handed out in order within a window and
//! never reused in it, and each ghost gets a stamp no slot ever had, so a broad phase's entry for
//! a retired ghost is stale. It owns which proxies get ghosts and the ghosts' owners, shifts,
//! states and stamps; it never decides how a reported pair is tested (the pipeline tests it as
//! the lower id's own motion against the higher id's shifted by the difference of the two
//! shifts, so a pair reported through either ghost gives the same bits).

use crate::bodies::BodyState;
use crate::walls::Periodic;
use glam::DVec3;

/// A proxy never spans more than a third of a periodic side, so it crosses at most one face per
/// axis and meets another body through one image at a time.
const WIDTH_PER_SIDE: f64 = 1.0 / 3.0;

/// Relative room left between a proxy's widest box and a third of a side, for the
/// single-precision rounding of compact boxes.
const ROUNDING_ROOM: f64 = 1e-5;

/// The ghost slots of one window and whose images they are.
#[derive(Debug, Default, Clone)]
pub(crate) struct Ghosts {
    periodic: Periodic,
    /// First ghost slot: the bodies' slots at the window's start (no ghost slot at all in a box
    /// without periodic axes).
    base: usize,
    /// The widest a proxy may be.
    width: f64,
    /// Per ghost slot from `base`: the body it images, the body's stamp it was made with, the
    /// shift (whole sides) and its state (the body's motion shifted).
    owners: Vec<(u32, u32)>,
    shifts: Vec<DVec3>,
    states: Vec<BodyState>,
    /// Per body: its ghosts' slots, `first..first + count`.
    runs: Vec<(u32, u8)>,
    /// The stamp of the next ghost made.
    next_stamp: u32,
}

impl Ghosts {
    /// Ghosts for a box of `periodic` axes (none without any).
    pub(crate) fn new(periodic: Periodic) -> Ghosts {
        let shortest = (0..3).filter(|&a| periodic.axes[a]).map(|a| periodic.side[a]).fold(f64::INFINITY, f64::min);
        Ghosts { periodic, base: usize::MAX, width: WIDTH_PER_SIDE * shortest, ..Ghosts::default() }
    }

    /// True in a box with periodic axes.
    #[inline]
    pub(crate) fn active(&self) -> bool {
        self.periodic.any()
    }

    /// The first ghost slot: every slot below it is a body's.
    #[inline]
    pub(crate) fn base(&self) -> usize {
        self.base
    }

    /// The longest path a proxy may cover in the window: its box, of a body of bounding radius
    /// at most `largest` (widened by gravity's bend), then spans less than a third of a side.
    pub(crate) fn longest_path(&self, largest: f64) -> f64 {
        let room = ROUNDING_ROOM * self.periodic.side.max_element();
        (self.width - 2.0 * largest - room).max(0.0)
    }

    /// Starts a window over `slots` body slots: every ghost of the last one is gone.
    pub(crate) fn clear(&mut self, slots: usize) {
        let shortest =
            (0..3).filter(|&a| self.periodic.axes[a]).map(|a| self.periodic.side[a]).fold(f64::INFINITY, f64::min);
        self.width = WIDTH_PER_SIDE * shortest;
        self.base = if self.active() { slots } else { usize::MAX };
        self.owners.clear();
        self.shifts.clear();
        self.states.clear();
        self.runs.clear();
        self.runs.resize(slots, (0, 0));
    }

    /// Ghost slot `slot`'s state (its body's, shifted).
    #[inline]
    pub(crate) fn state(&self, slot: usize) -> &BodyState {
        &self.states[slot - self.base]
    }

    /// The body ghost slot `slot` images, the body's stamp when it was made, and its shift.
    #[inline]
    pub(crate) fn owner(&self, slot: usize) -> (u32, u32, DVec3) {
        let (body, stamp) = self.owners[slot - self.base];
        (body, stamp, self.shifts[slot - self.base])
    }

    /// Body `body`'s ghost slots.
    #[inline]
    pub(crate) fn of(&self, body: usize) -> std::ops::Range<usize> {
        match self.runs.get(body) {
            Some(&(first, count)) if count > 0 => first as usize..first as usize + count as usize,
            _ => 0..0,
        }
    }

    /// A fresh stamp for a ghost slot: never one a slot had before.
    #[inline]
    pub(crate) fn fresh_stamp(&mut self) -> u32 {
        self.next_stamp = self.next_stamp.wrapping_add(1);
        self.next_stamp
    }

    /// Makes body `body`'s ghosts from its proxy's swept box `[low, high]` (relative to the box's
    /// low corner) and its `state`, made with the body's `stamp`, calling `add(shift, stamp)`
    /// for each new slot in order (the slots follow the last one made): the proxy, shifted.
    pub(crate) fn make(
        &mut self,
        body: usize,
        (low, high): (DVec3, DVec3),
        state: &BodyState,
        stamp: u32,
        mut add: impl FnMut(DVec3, u32),
    ) {
        let first = self.base + self.owners.len();
        let mut count = 0u8;
        // Corners relative to the box's low corner, the faces' own coordinates.
        let min = self.periodic.min;
        for shift in self.periodic.image_shifts(min + low, min + high) {
            let mut image = *state;
            image.motion.position += shift;
            self.owners.push((body as u32, stamp));
            self.shifts.push(shift);
            self.states.push(image);
            add(shift, self.fresh_stamp());
            count += 1;
        }
        if self.runs.len() <= body {
            self.runs.resize(body + 1, (0, 0));
        }
        self.runs[body] = (first as u32, count);
    }

    /// Forgets body `body`'s ghosts (their slots stay retired for the rest of the window).
    pub(crate) fn forget(&mut self, body: usize) {
        if let Some(run) = self.runs.get_mut(body) {
            *run = (0, 0);
        }
    }

    /// Bytes held (capacity).
    pub(crate) fn memory_bytes(&self) -> usize {
        self.owners.capacity() * 8
            + self.states.capacity() * std::mem::size_of::<BodyState>()
            + self.runs.capacity() * 8
    }
}
