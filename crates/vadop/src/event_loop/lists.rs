//! The neighbour lists of the serial event loop (as in the "Single" variant of Smallenburg's
//! EDMD): each body keeps the short list of the bodies around its shell, so a body whose motion
//! changed is tested against its list instead of the 27 cells around it.
//!
//! It owns when lists pay (in a dense world: [`FROM_PACKING`]) and how wide a shell is, and, per
//! body, its shell (a ball of radius [`Lists::shell`] around the centre the body had when its list
//! was built), the time its centre leaves the shell, and its list: every body whose shell comes
//! within reach of its own, that is whose shell centre is within the sum of the two
//! radii plus two shells (with a slack far above rounding), each with the whole sides that bring
//! it next to the body across periodic faces. The lists are symmetric: a body is in the list of
//! every body in its own, so a body that builds its list anew takes itself off the lists of its
//! old members and onto those of its new ones (at a shell exit, the lists of the members it
//! keeps stay as they are). **Why a list never misses a partner:** while two
//! bodies are inside their shells, their centres are within a shell of their shells' centres, so
//! when they touch (centres a sum of radii apart) their shells' centres are at most two shells
//! further apart, within the lists' reach: each is in the other's list. A body builds its list anew
//! when its centre leaves its shell (its "shell exit", which the loop schedules as it schedules
//! a cell crossing without lists), when it wraps across a periodic face, and when it is entered,
//! so two bodies are always inside their shells up to the first of their shell exits, and a pair
//! that touches is listed from before the instant it touches until after. The lists are found
//! through the cells, whose bodies the loop then lists by their shells' centres (which move only
//! when a list is built), so a shell exit replaces every cell crossing. The lists live in one flat
//! array of fixed-size blocks (the count first, then the entries), grown (and every list built
//! again from the shells' centres, which gives the same lists) on the rare list that outgrows its
//! block, so nothing is allocated per event. It never computes a contact time nor changes a body.

use super::cells::{Cells, NONE};
use crate::bodies::Bodies;
use crate::memory::prefetch;
use crate::walls::BoxBounds;
use glam::{DVec3, DVec4};

/// The lists' reach is the sum of the radii plus two shells, times this plus this many roundings
/// of the box's largest coordinate: above the rounding of a shell's centre and of a shell exit's
/// time, and below the cells' own slack (see [`super::cells`]), so a body within the reach is
/// always in a neighbour cell.
const REACH_SLACK: f64 = 1e-7;
const ROUNDINGS: f64 = 16.0;
/// A list entry holds the body in its low bits and its image (see [`Lists::images`]) above them.
pub(super) const IMAGE_BITS: u32 = 27;
const BODY_MASK: u32 = (1 << IMAGE_BITS) - 1;
/// Entries per block a first sizing gives (the count takes one more, so a block is two cache
/// lines): no list outgrew it in the gas at n = 2e4 and packing 0.4 or 0.45 (see [`SHELL`]);
/// a denser world widens the blocks once.
const FIRST_BLOCK: usize = 31;

/// Marks, in [`Lists::seen`], a body of the old list that the list built anew holds again (the
/// lists' numbers count below it).
const FOUND_AGAIN: u32 = 1 << 31;

/// The most bodies (slots) the lists can number.
const MAX_BODIES: usize = BODY_MASK as usize;

/// The serial loop keeps neighbour lists in a world of at least this packing fraction, cells below
/// it. Measured with callgrind on the periodic gas at n = 2e4 (instructions per pair collision,
/// cells then lists): 13.5 k then 19.2 k at packing 0.2, 13.8 k then 14.6 k at 0.3, 13.9 k then
/// 13.4 k at 0.35, 14.9 k then 12.4 k at 0.4, 15.6 k then 11.5 k at 0.45: even at about 0.33.
/// Again once the lists were screened as read and built from the cells within reach alone (12
/// frames): 14.4 k then 14.7 k at 0.3, 14.0 k then 12.6 k at 0.35, still even between; and once
/// the slabs of a list built anew were found without `array::from_fn` and the calendar's
/// buckets held 6 events (the event loop's instructions alone, 15, 12 and 12 frames): 11.9 k
/// then 13.6 k at 0.25, 12.4 k then 12.0 k at 0.3, 12.4 k then 10.7 k at 0.35: even at about
/// 0.29. A list pays where the mean free path is short against a shell: a collision's two
/// searches then read fewer bodies than the 27 cells hold, and a body seldom leaves its shell. In
/// a thinner gas a body leaves its shell several times between collisions, and each list built
/// anew (a look at the cells, wider by two shells, of the 27 around it that its shell can reach)
/// costs more than the cell crossings it replaces and the shorter searches save.
const FROM_PACKING: f64 = 0.29;
/// The serial loop's shells, in largest diameters (a body's list holds the bodies whose shells'
/// centres are within a diameter and two shells). Measured as above at packing 0.4: 12.6 k
/// instructions per collision at 0.2, 12.5 k at 0.25 and 0.3, 13.4 k at 0.4, 18.9 k at 0.6
/// (0.25 is the shell of Smallenburg's EDMD). At n = 10^5, where the loop waits on memory, 0.3
/// also misses a 2 MiB cache 4 % less often per collision than 0.25 (cachegrind, BENCHMARKS.md,
/// issue 27's twelfth session): a list is built anew less often, and each such build, which walks
/// about fifty bodies scattered in memory, costs more misses than its longer searches add. At
/// most 0.8: a periodic side holds 8 diameters (see [`crate::walls::MIN_PERIODIC_DIAMETERS`]), so
/// cells a diameter and two shells wide still number 3 to a periodic side, as the cells need.
const SHELL: f64 = 0.3;

/// The neighbour lists (see the module documentation).
#[derive(Debug)]
pub(super) struct Lists {
    /// How far a body's centre may go from its shell's centre.
    pub shell: f64,
    /// The absolute part of the reach's slack.
    slack: f64,
    /// Per image: the whole sides (-1, 0 or 1 of each) that bring a body next to another, as
    /// `(x + 1) + 3 (y + 1) + 9 (z + 1)`.
    pub images: [DVec3; 27],
    /// Per body: its shell's centre, and its radius (read together when lists are built).
    shells: Vec<Shell>,
    /// The radii the shells were placed with (see [`Radii`]).
    radii: Radii,
    /// Per body, `stride` entries: the count, then the list.
    blocks: Vec<u32>,
    stride: usize,
    /// Per body: the number of the last list built while it was in that body's list before
    /// (see [`Lists::fresh`]), with [`FOUND_AGAIN`] when that list holds it again.
    seen: Vec<u32>,
    built: u32,
    /// Scratch: the old list of the body whose list is built anew in place (see
    /// [`Lists::rebuild`] with `in_place`).
    old: Vec<u32>,
}

/// The radii the shells were placed with: none yet, all the one (bit for bit), or several. While
/// all are one, every pair a list built anew meets has the same reach, one float worked out once
/// a list (see [`Lists::pair_around`]), where the walk of the cells around worked it out again for
/// each of the fifty-odd bodies it meets, from the two radii: the same float either way.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Radii {
    None,
    All(f64),
    Several,
}

/// A body's shell: its centre, and its radius as `w`. Aligned to its size, so that one is never
/// split across two cache lines: a list built anew reads those of about fifty bodies scattered in
/// memory, and an unaligned array (as the allocator places a large one) splits every other one.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
struct Shell(DVec4);

impl Lists {
    /// Lists for the bodies `ids` in the box `bounds` when they pay, in a world packed at least
    /// [`FROM_PACKING`] (or `always`, with blocks of that many entries at first), and when the
    /// bodies are few enough to number in an entry; shells of [`SHELL`] largest diameters.
    pub(super) fn paying(bounds: &BoxBounds, bodies: &Bodies, ids: &[u32], always: Option<usize>) -> Option<Lists> {
        let side = bounds.side();
        let volume: f64 =
            ids.iter().map(|&i| 4.0 / 3.0 * std::f64::consts::PI * bodies.radius(i as usize).powi(3)).sum();
        let packed = volume >= FROM_PACKING * side.x * side.y * side.z || always.is_some();
        let max_radius = ids.iter().map(|&i| bodies.radius(i as usize)).fold(0.0, f64::max);
        let shell = 2.0 * SHELL * max_radius;
        (packed && bodies.slots() <= MAX_BODIES).then(|| Lists::new(bounds, shell, always.unwrap_or(FIRST_BLOCK)))
    }

    /// Lists in the box `bounds` with shells of `shell`, blocks of `block` entries at first.
    fn new(bounds: &BoxBounds, shell: f64, block: usize) -> Lists {
        let side = bounds.side();
        let scale = bounds.min.abs().max(bounds.max.abs()).max_element() + side.max_element();
        let images = std::array::from_fn(|k| {
            let step = |a: usize| (k / [1, 3, 9][a] % 3) as f64 - 1.0;
            DVec3::new(step(0) * side.x, step(1) * side.y, step(2) * side.z)
        });
        Lists {
            shell,
            slack: ROUNDINGS * f64::EPSILON * scale,
            images,
            shells: Vec::new(),
            radii: Radii::None,
            blocks: Vec::new(),
            stride: block + 1,
            seen: Vec::new(),
            built: 0,
            old: Vec::new(),
        }
    }

    /// Room for `slots` bodies.
    pub(super) fn grow(&mut self, slots: usize) {
        if self.shells.len() < slots {
            self.shells.resize(slots, Shell(DVec4::ZERO));
            self.seen.resize(slots, 0);
            self.blocks.resize(slots * self.stride, 0);
        }
    }

    /// Bytes held.
    pub(super) fn memory_bytes(&self) -> usize {
        self.shells.capacity() * std::mem::size_of::<Shell>()
            + (self.blocks.capacity() + self.seen.capacity() + self.old.capacity()) * 4
    }

    /// The bodies the lists have room for: every entry's body is below it (an entry is pushed
    /// only once its body's shell is read, and the shells are never fewer).
    #[inline(always)]
    pub(super) fn slots(&self) -> usize {
        self.shells.len()
    }

    /// Body `i`'s list: each entry the body in its low bits, its image above (see [`split`]).
    #[inline(always)]
    pub(super) fn members(&self, i: usize) -> &[u32] {
        let block = &self.blocks[i * self.stride..(i + 1) * self.stride];
        &block[1..1 + block[0] as usize]
    }

    /// Asks for body `i`'s shell and list ahead of their use.
    #[inline]
    pub(super) fn prefetch(&self, i: usize) {
        if let (Some(shell), Some(count)) = (self.shells.get(i), self.blocks.get(i * self.stride)) {
            prefetch(shell);
            prefetch(count);
        }
    }

    /// True when body `q` was not in the list of the body whose list was built last, before it
    /// was built: the pair was not tested before.
    #[inline(always)]
    pub(super) fn fresh(&self, q: usize) -> bool {
        self.seen[q] & !FOUND_AGAIN != self.built
    }

    /// When body `i`'s centre next leaves its shell on its current motion, from `now` on (`now`
    /// when rounding put it a hair outside already).
    #[inline]
    pub(super) fn exit(&self, bodies: &Bodies, i: usize, now: f64) -> f64 {
        let motion = bodies.motion(i);
        let (offset, velocity) = (motion.position - self.shells[i].0.truncate(), motion.velocity);
        let speed2 = velocity.length_squared();
        if speed2 == 0.0 {
            return f64::INFINITY;
        }
        // The later root of |offset + velocity s| = shell, in the form that cancels nothing.
        let (b, c) = (offset.dot(velocity), offset.length_squared() - self.shell * self.shell);
        let root = (b * b - speed2 * c).max(0.0).sqrt();
        let s = if b > 0.0 { -c / (b + root) } else { (root - b) / speed2 };
        let time = motion.since + s;
        if time >= now {
            time
        } else {
            now
        }
    }

    /// The shell `own` as its partners across `shift` are measured from: its centre less the
    /// shift, and its radius plus two shells.
    #[inline(always)]
    fn origin(&self, own: DVec4, shift: DVec3) -> DVec4 {
        (own.truncate() - shift).extend(own.w + 2.0 * self.shell)
    }

    /// The lists' reach, squared, of a shell whose [`Self::origin`]'s radius is `w` and a shell of
    /// radius `other`.
    #[inline(always)]
    fn reach2(slack: f64, w: f64, other: f64) -> f64 {
        let reach = (w + other) * (1.0 + REACH_SLACK) + slack;
        reach * reach
    }

    /// True when body `q` (of `shells`) is within the lists' reach of the shell whose
    /// [`Self::origin`] (for `q`'s image) is `origin`, `reach2` its reach squared from `q`'s radius
    /// (see [`Self::reach2`]).
    #[inline(always)]
    fn within(shells: &[Shell], origin: DVec4, q: usize, reach2: impl Fn(f64) -> f64) -> bool {
        let other = shells[q].0;
        let (x, y, z) = (other.x - origin.x, other.y - origin.y, other.z - origin.z);
        x * x + y * y + z * z < reach2(other.w)
    }

    /// Body `i`'s shell: its centre at `t`, and its radius.
    fn place(&mut self, bodies: &Bodies, i: usize, t: f64) {
        let radius = bodies.radius(i);
        self.shells[i] = Shell(bodies.position_at(i, t).extend(radius));
        self.radii = match self.radii {
            Radii::None => Radii::All(radius),
            Radii::All(all) if all.to_bits() == radius.to_bits() => Radii::All(all),
            _ => Radii::Several,
        };
    }

    /// Lists the pairs of body `i` and the bodies of the cell whose first body is `first`, seen
    /// through `image` (see [`Self::images`]), that are within reach: those of higher id only
    /// when `higher`. With `in_place`, a body of `i`'s old list keeps its entry for `i` (see
    /// [`Self::rebuild`]). `reach2` is the reach squared from a body's radius (see
    /// [`Self::within`]). False when a block overflowed.
    #[inline(always)]
    fn pair_with_cell(
        &mut self,
        cells: &Cells,
        i: usize,
        (first, image): (u32, u32),
        (higher, in_place): (bool, bool),
        reach2: impl Fn(f64) -> f64,
    ) -> bool {
        if first == NONE {
            return true;
        }
        let origin = self.origin(self.shells[i].0, self.images[image as usize]);
        // The arrays as slices, borrowed apart: their places and lengths then stay in registers
        // along the walk, where read through `self` they were read again after every write.
        let (shells, blocks, seen, stride, built) =
            (&self.shells[..], &mut self.blocks[..], &mut self.seen[..], self.stride, self.built);
        let lookup = cells.lookup();
        let mut fits = true;
        let mut q = first;
        while q != NONE {
            let k = q as usize;
            if (if higher { k > i } else { k != i }) && Self::within(shells, origin, k, &reach2) {
                fits &= push(blocks, stride, i, q | (image << IMAGE_BITS));
                if in_place && seen[k] == built {
                    seen[k] |= FOUND_AGAIN;
                } else {
                    fits &= push(blocks, stride, k, i as u32 | ((26 - image) << IMAGE_BITS));
                }
            }
            q = lookup.after(q);
        }
        fits
    }

    /// Lists the pairs of body `i` and the bodies around it within reach (of higher id only when
    /// `higher`); false when a block overflowed. The cells of its neighbourhood that lie out of
    /// reach of its shell, whatever the radii (most of the corners and some edges: a quarter of
    /// the 27 cells' bodies), are not read. While every shell has one radius (see [`Radii`]),
    /// the reach is worked out once, not for each body met.
    #[inline(always)]
    fn pair_around(&mut self, cells: &Cells, i: usize, higher: bool, in_place: bool) -> bool {
        let (w, slack) = (self.shells[i].0.w + 2.0 * self.shell, self.slack);
        match self.radii {
            Radii::All(radius) => {
                let reach2 = Self::reach2(slack, w, radius);
                self.pair_cells(cells, i, (higher, in_place), move |_| reach2)
            }
            Radii::None | Radii::Several => {
                self.pair_cells(cells, i, (higher, in_place), move |other| Self::reach2(slack, w, other))
            }
        }
    }

    /// [`Self::pair_around`] with the reach squared from a body's radius `reach2`.
    #[inline(always)]
    fn pair_cells(&mut self, cells: &Cells, i: usize, ways: (bool, bool), reach2: impl Fn(f64) -> f64) -> bool {
        let own = self.shells[i].0;
        let reach = (own.w + 2.0 * self.shell + cells.max_radius()) * (1.0 + REACH_SLACK) + self.slack;
        // Twice the rounding [`Self::within`] allows for: the gaps' own, and the cells'.
        let [xs, ys, zs] = cells.slabs_around(i, own.truncate(), 2.0 * self.slack);
        let out_of_reach = reach * reach;
        let mut fits = true;
        for z in &zs.0[..zs.1] {
            for y in &ys.0[..ys.1] {
                let gap2 = z.gap2 + y.gap2;
                if gap2 >= out_of_reach {
                    continue;
                }
                for x in &xs.0[..xs.1] {
                    if gap2 + x.gap2 < out_of_reach {
                        let cell = (cells.first(x.part + y.part + z.part), x.sign + 3 * y.sign + 9 * z.sign);
                        fits &= self.pair_with_cell(cells, i, cell, ways, &reach2);
                    }
                }
            }
        }
        fits
    }

    /// Takes body `i` off body `q`'s list.
    #[inline(always)]
    fn take_off(&mut self, q: usize, i: usize) {
        let at = q * self.stride;
        let count = self.blocks[at] as usize;
        let list = &mut self.blocks[at + 1..at + 1 + count];
        if let Some(k) = list.iter().position(|&e| (e & BODY_MASK) as usize == i) {
            list[k] = list[count - 1];
            self.blocks[at] -= 1;
        }
    }

    /// Body `i` leaves every list, its own emptied.
    pub(super) fn remove(&mut self, i: usize) {
        let at = i * self.stride;
        for k in 0..self.blocks[at] as usize {
            self.take_off((self.blocks[at + 1 + k] & BODY_MASK) as usize, i);
        }
        self.blocks[at] = 0;
    }

    /// Body `i`'s list built anew around its centre at `t`, which `cells` list it by: it leaves
    /// its old members' lists (remembered, see [`Self::fresh`]) and joins its new ones'.
    /// `in_place` when it crossed no periodic face since its list was built (at its shell exit):
    /// a body of its old list that its new list holds again then keeps its entry for `i` as it is
    /// (the pair's image is still the one that brings them within reach), so only the lists of
    /// the bodies it leaves or joins change, and those of most of its neighbours, scattered in
    /// memory, are not read at all.
    pub(super) fn rebuild(&mut self, cells: &Cells, bodies: &Bodies, i: usize, t: f64, in_place: bool) {
        self.built += 1;
        if self.built == FOUND_AGAIN {
            // Once in 2^31 lists: no body may look seen by a list of long ago.
            self.seen.fill(0);
            self.built = 1;
        }
        let mut old = std::mem::take(&mut self.old);
        old.clear();
        old.extend_from_slice(self.members(i));
        self.blocks[i * self.stride] = 0;
        for &entry in &old {
            let q = (entry & BODY_MASK) as usize;
            self.seen[q] = self.built;
            if !in_place {
                self.take_off(q, i);
            }
        }
        self.place(bodies, i, t);
        let fits = self.pair_around(cells, i, false, in_place);
        if in_place {
            for &entry in &old {
                let q = (entry & BODY_MASK) as usize;
                if self.seen[q] & FOUND_AGAIN == 0 {
                    self.take_off(q, i);
                }
            }
        }
        self.old = old;
        if !fits {
            self.widen(cells);
        }
    }

    /// Every list built from the shells' centres, the bodies of `ids` with their centres at `t`
    /// (listed by `cells` there).
    pub(super) fn build_all(&mut self, cells: &Cells, bodies: &Bodies, ids: &[u32], t: f64) {
        for &i in ids {
            self.place(bodies, i as usize, t);
        }
        self.relist_all(cells);
    }

    /// Every list built again from the shells' centres.
    fn relist_all(&mut self, cells: &Cells) {
        let mut fits = true;
        for i in 0..self.shells.len() {
            self.blocks[i * self.stride] = 0;
        }
        for i in 0..self.shells.len() {
            // Each pair once, from its lower id: both lists get it.
            if cells.cell_of(i) != NONE {
                fits &= self.pair_around(cells, i, true, false);
            }
        }
        if !fits {
            self.widen(cells);
        }
    }

    /// Blocks twice as long, and every list built again (the same lists: they depend on the
    /// shells' centres alone).
    #[cold]
    fn widen(&mut self, cells: &Cells) {
        self.stride = 2 * self.stride - 1;
        self.blocks = vec![0; self.shells.len() * self.stride];
        self.relist_all(cells);
    }
}

/// Appends `entry` to body `i`'s list, of `blocks` of `stride` entries; false when its block is
/// full.
#[inline(always)]
fn push(blocks: &mut [u32], stride: usize, i: usize, entry: u32) -> bool {
    let at = i * stride;
    let count = blocks[at] as usize;
    if count + 1 == stride {
        return false;
    }
    blocks[at + 1 + count] = entry;
    blocks[at] += 1;
    true
}

/// A list entry's body and image.
#[inline(always)]
pub(super) fn split(entry: u32) -> (usize, usize) {
    ((entry & BODY_MASK) as usize, (entry >> IMAGE_BITS) as usize)
}

#[cfg(test)]
impl Lists {
    /// Checks at `now` that every body listed in `cells` is inside its shell, and that its list
    /// holds exactly the bodies (and images across the periodic faces of `bounds`) within reach.
    pub(super) fn check(&self, cells: &Cells, bodies: &Bodies, bounds: &BoxBounds, now: f64) {
        let listed: Vec<usize> = (0..self.shells.len()).filter(|&i| cells.cell_of(i) != NONE).collect();
        let real = |image: usize| (0..3).all(|a| bounds.periodic[a] || image / [1, 3, 9][a] % 3 == 1);
        for &i in &listed {
            let away = (bodies.position_at(i, now) - self.shells[i].0.truncate()).length();
            assert!(away <= self.shell * (1.0 + 1e-9), "body {i} is {away} from its shell's centre");
            let mut expected: Vec<u32> = Vec::new();
            for &q in listed.iter().filter(|&&q| q != i) {
                for image in (0..27).filter(|&image| real(image)) {
                    let origin = self.origin(self.shells[i].0, self.images[image]);
                    if Self::within(&self.shells, origin, q, |other| Self::reach2(self.slack, origin.w, other)) {
                        expected.push(q as u32 | ((image as u32) << IMAGE_BITS));
                    }
                }
            }
            let mut found = self.members(i).to_vec();
            found.sort_unstable();
            expected.sort_unstable();
            assert_eq!(found, expected, "body {i}'s list at {now}");
        }
    }
}
