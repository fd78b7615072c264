//! What the grid's pair sweep does with a binned piece's candidates (the binned pieces whose
//! boxes overlap its box), in the order the sweep finds them: each reported as it comes
//! ([`Reporting`]), or held, asked of a [`PairScreen`] four at a time in AVX's lanes, and only
//! the ones it keeps reported, with what the screen works out of them, again four at a time and
//! in their windows ([`Screened`]). Either way the events predicted, their order and the
//! candidates' count are the same. It knows nothing of cells or levels.

use crate::bodies::BodyState;
use crate::broad_phase::proxy::Reported;
#[cfg(target_arch = "x86_64")]
use crate::broad_phase::PairScreen;
use crate::window::Window;

/// Whose a binned piece is (the body and the stamp of the proxy it was cut from) and when it
/// holds: what a box that overlaps is checked for next, in one load.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Owner {
    pub body: u32,
    pub stamp: u32,
    pub window: Window,
}

/// A receiver of the sweep's candidates, with `report(a, b, window)` for the pairs it passes on.
pub(super) trait Candidates {
    /// What is reported of a pair beside its two pieces and their window.
    type Kept;

    /// Binned pieces `a` and `b` have overlapping boxes.
    fn overlap(&mut self, a: usize, b: usize, report: &mut impl FnMut(Reported, Reported, Window, Self::Kept));

    /// Every candidate of the sweep has been given to [`Self::overlap`].
    fn finish(&mut self, report: &mut impl FnMut(Reported, Reported, Window, Self::Kept));

    /// Candidates told without a report (which counts the others).
    fn cleared(&self) -> u64;
}

/// Each candidate reported as it comes when the pieces are of two bodies and their windows meet.
#[derive(Clone, Copy)]
pub(super) struct Reporting<'a> {
    pub owners: &'a [Owner],
    pub motions: &'a [BodyState],
}

impl Reporting<'_> {
    /// The reports of pieces `a` and `b` (of two bodies, as the caller knows) and their windows'
    /// intersection.
    #[inline(always)]
    fn reports(&self, a: usize, b: usize) -> (Reported<'_>, Reported<'_>, Window) {
        let (ea, eb) = (self.owners[a], self.owners[b]);
        let x = Reported { body: ea.body, stamp: ea.stamp, state: &self.motions[a] };
        let y = Reported { body: eb.body, stamp: eb.stamp, state: &self.motions[b] };
        (x, y, ea.window.intersect(eb.window))
    }

    /// [`Self::reports`] without its four bounds checks, for [`Screened`]'s kept pairs, whose
    /// pieces index both by its contract (four compares a pair, 0.7 M instructions a frame at
    /// n = 10^5, 5 d/f).
    ///
    /// # Safety
    /// `a` and `b` index both the owners and the motions.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn reports_unchecked(&self, a: usize, b: usize) -> (Reported<'_>, Reported<'_>, Window) {
        debug_assert!(a.max(b) < self.owners.len().min(self.motions.len()));
        // SAFETY: the caller's.
        let (ea, eb) = unsafe { (*self.owners.get_unchecked(a), *self.owners.get_unchecked(b)) };
        // SAFETY: the caller's.
        let (state_a, state_b) = unsafe { (self.motions.get_unchecked(a), self.motions.get_unchecked(b)) };
        let x = Reported { body: ea.body, stamp: ea.stamp, state: state_a };
        let y = Reported { body: eb.body, stamp: eb.stamp, state: state_b };
        (x, y, ea.window.intersect(eb.window))
    }
}

impl Candidates for Reporting<'_> {
    type Kept = ();

    /// Out of line, as a call from the scans: inlined, it holds registers the scans' loops
    /// would keep (about 6 % more instructions in the shapes scene's sweep at 10^5 bodies).
    #[inline(never)]
    fn overlap(&mut self, a: usize, b: usize, report: &mut impl FnMut(Reported, Reported, Window, ())) {
        let (x, y, window) = self.reports(a, b);
        if x.body != y.body && !window.is_empty() {
            report(x, y, window, ());
        }
    }

    #[inline(always)]
    fn finish(&mut self, _: &mut impl FnMut(Reported, Reported, Window, ())) {}

    fn cleared(&self) -> u64 {
        0
    }
}

/// Most candidates held before they are screened: groups of four full but for the sweep's last,
/// and one call of the screen for many pieces (a piece has about four at 5 diameters/frame).
#[cfg(target_arch = "x86_64")]
const HELD: usize = 64;

/// `screen_held` counts the cleared candidates as four bits a group in one `u64`.
#[cfg(target_arch = "x86_64")]
const _: () = assert!(HELD <= 64);

/// The sweep's candidates held, then asked of `screen` four at a time
/// ([`PairScreen::clears_four_avx`]): the ones it keeps and [`Reporting`] would report (pieces of
/// two bodies whose windows meet) are worked out four at a time in their windows
/// ([`PairScreen::kept_four_avx`]), and those that can have an event there reported in the order
/// found, with what the screen works out of them; the others are only counted, as [`Reporting`]
/// would have counted them. Per candidate the screen's arithmetic is about half its scalar
/// form's, the other pieces' loads included.
#[cfg(target_arch = "x86_64")]
pub(super) struct Screened<'a, S> {
    reporting: Reporting<'a>,
    screen: &'a S,
    /// The candidates held as pairs of pieces, and three slots for the last group's idle lanes.
    held: [(u32, u32); HELD + 3],
    len: usize,
    /// The held candidates to report, in the order found, and three slots as `held`'s.
    kept: [(u32, u32); HELD + 3],
    cleared: u64,
}

#[cfg(target_arch = "x86_64")]
impl<'a, S: PairScreen> Screened<'a, S> {
    /// # Safety
    /// The processor has AVX, and every piece given to [`Candidates::overlap`] is one of
    /// `reporting`'s owners and motions (as every piece the grid sweeps is).
    pub unsafe fn new(reporting: Reporting<'a>, screen: &'a S) -> Self {
        Screened { reporting, screen, held: [(0, 0); HELD + 3], len: 0, kept: [(0, 0); HELD + 3], cleared: 0 }
    }

    /// Screens the candidates held, reports the kept ones and counts the cleared. Out of line,
    /// once per `HELD` candidates: its vector registers are its own.
    ///
    /// # Safety
    /// The processor has AVX, and at least one candidate is held.
    #[target_feature(enable = "avx")]
    unsafe fn screen_held(&mut self, report: &mut impl FnMut(Reported, Reported, Window, S::Kept)) {
        let len = std::mem::take(&mut self.len);
        // The last group's idle lanes hold its last candidate's first piece against itself: a
        // piece's own body, which `reportable_four` never counts, so no mask of lanes is needed.
        let last = self.held[len - 1].0;
        self.held[len..len + 3].fill((last, last));
        let Reporting { owners, motions } = self.reporting;
        let (mut kept, mut cleared_bits) = (0, 0u64);
        for group in (0..len).step_by(4) {
            // Spelt out: nested `map`s here are left as calls (a target-feature function
            // inlines less).
            let held = &self.held[group..group + 4];
            let a = [held[0].0, held[1].0, held[2].0, held[3].0].map(|i| i as usize);
            let b = [held[0].1, held[1].1, held[2].1, held[3].1].map(|i| i as usize);
            // SAFETY: every piece held indexes both (`new`'s contract).
            let (states_a, states_b) =
                unsafe { (a.map(|i| motions.get_unchecked(i)), b.map(|i| motions.get_unchecked(i))) };
            // SAFETY: as above.
            let (owners_a, owners_b) =
                unsafe { (a.map(|i| owners.get_unchecked(i)), b.map(|i| owners.get_unchecked(i))) };
            // SAFETY: AVX, the caller's.
            let cleared = unsafe { self.screen.clears_four_avx(states_a, states_b) };
            // SAFETY: AVX, the caller's.
            let counted = unsafe { reportable_four(owners_a, owners_b) };
            // Four bits a group, at most `HELD / 4` groups: counted once per call (`count_ones`
            // is a dozen instructions without `popcnt`).
            cleared_bits = cleared_bits << 4 | u64::from(cleared & counted);
            let mut reported = !cleared & counted;
            while reported != 0 {
                let k = reported.trailing_zeros() as usize;
                // SAFETY: fewer kept than held, and `HELD + 3` slots; `group + k < len`.
                unsafe { *self.kept.get_unchecked_mut(kept) = *self.held.get_unchecked(group + k) };
                kept += 1;
                reported &= reported - 1;
            }
        }
        self.cleared += u64::from(cleared_bits.count_ones());
        if kept == 0 {
            return;
        }
        // The last group's idle lanes repeat its last pair, and their answers are dropped.
        let last = self.kept[kept - 1];
        self.kept[kept..kept + 3].fill(last);
        let mut reported = 0;
        for group in (0..kept).step_by(4) {
            let pairs = &self.kept[group..group + 4];
            let a = [pairs[0].0, pairs[1].0, pairs[2].0, pairs[3].0].map(|i| i as usize);
            let b = [pairs[0].1, pairs[1].1, pairs[2].1, pairs[3].1].map(|i| i as usize);
            // SAFETY: every piece held indexes both (`new`'s contract).
            let (states_a, states_b) =
                unsafe { (a.map(|i| motions.get_unchecked(i)), b.map(|i| motions.get_unchecked(i))) };
            // SAFETY: as above.
            let (owners_a, owners_b) =
                unsafe { (a.map(|i| owners.get_unchecked(i)), b.map(|i| owners.get_unchecked(i))) };
            // SAFETY: AVX, the caller's.
            let (events, answers) =
                unsafe { self.screen.kept_four_avx(states_a, states_b, windows_four(owners_a, owners_b)) };
            // Only the pairs that can have an event in their window are reported; the others
            // are counted as cleared, below.
            let mut events = events & ((1 << (kept - group).min(4)) - 1);
            while events != 0 {
                let k = events.trailing_zeros() as usize;
                // SAFETY: as above.
                let (x, y, window) = unsafe { self.reporting.reports_unchecked(a[k], b[k]) };
                report(x, y, window, answers[k]);
                reported += 1;
                events &= events - 1;
            }
        }
        self.cleared += (kept - reported) as u64;
    }
}

#[cfg(target_arch = "x86_64")]
impl<S: PairScreen> Candidates for Screened<'_, S> {
    type Kept = S::Kept;

    #[inline(always)]
    fn overlap(&mut self, a: usize, b: usize, report: &mut impl FnMut(Reported, Reported, Window, S::Kept)) {
        let (owners, motions) = (self.reporting.owners.len(), self.reporting.motions.len());
        debug_assert!(a.max(b) < owners.min(motions));
        let len = self.len;
        // SAFETY: `len < HELD`: the candidates are screened, and `len` reset, once `HELD` are
        // held. Unchecked, and `len` kept in a register rather than read back past the store:
        // once per candidate, in the scans' loops.
        unsafe { *self.held.get_unchecked_mut(len) = (a as u32, b as u32) };
        self.len = len + 1;
        if len + 1 == HELD {
            // SAFETY: AVX, by `new`'s contract; a candidate is held.
            unsafe { self.screen_held(report) };
        }
    }

    #[inline(always)]
    fn finish(&mut self, report: &mut impl FnMut(Reported, Reported, Window, S::Kept)) {
        if self.len > 0 {
            // SAFETY: AVX, by `new`'s contract; a candidate is held.
            unsafe { self.screen_held(report) };
        }
    }

    fn cleared(&self) -> u64 {
        self.cleared
    }
}

/// Bit k set when [`Reporting`] would report pieces `a[k]` and `b[k]`: of two bodies, windows
/// that meet ([`windows_four`], each lane's `intersect`'s).
///
/// # Safety
/// The processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn reportable_four(a: [&Owner; 4], b: [&Owner; 4]) -> u32 {
    use std::arch::x86_64::*;
    let bodies =
        |of: [&Owner; 4]| _mm_set_epi32(of[3].body as i32, of[2].body as i32, of[1].body as i32, of[0].body as i32);
    let [start, end] = windows_four(a, b);
    let meet = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(start, end)) as u32;
    let same = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(bodies(a), bodies(b)))) as u32;
    meet & !same
}

/// The windows of pieces `a[k]` and `b[k]` intersected, in lane k: the four starts, then the
/// four ends. `Window::intersect` takes the other's bound where it is the later start (the
/// earlier end), as `vmaxpd` (`vminpd`) takes its first operand where it compares greater
/// (less), so each lane's window is `intersect`'s, NaN and signed zeros included.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn windows_four(a: [&Owner; 4], b: [&Owner; 4]) -> [std::arch::x86_64::__m256d; 2] {
    use std::arch::x86_64::*;
    let () = WINDOW_ROW;
    // Each owner's window read as one row of two floats, the rows of pieces 0 and 2 (1 and 3) in
    // one register, then unpacked into the four starts and the four ends in lane order: six
    // instructions for four owners, where the bounds one by one took ten.
    let columns = |of: [&Owner; 4]| {
        // SAFETY: a window is its start and end side by side (`WINDOW_ROW`).
        let row = |o: &Owner| unsafe { _mm_loadu_pd(std::ptr::from_ref(&o.window).cast::<f64>()) };
        let (even, odd) = (_mm256_set_m128d(row(of[2]), row(of[0])), _mm256_set_m128d(row(of[3]), row(of[1])));
        (_mm256_unpacklo_pd(even, odd), _mm256_unpackhi_pd(even, odd))
    };
    let ((starts_a, ends_a), (starts_b, ends_b)) = (columns(a), columns(b));
    [_mm256_max_pd(starts_b, starts_a), _mm256_min_pd(ends_b, ends_a)]
}

/// What [`windows_four`] reads a window as: its start and end, side by side.
#[cfg(target_arch = "x86_64")]
const WINDOW_ROW: () = {
    use std::mem::{offset_of, size_of};
    assert!(size_of::<Window>() == 16 && offset_of!(Window, start) == 0 && offset_of!(Window, end) == 8);
};
