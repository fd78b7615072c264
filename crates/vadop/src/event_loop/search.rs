//! A body's next event in the event loop: its earliest contact with a body of its neighbourhood,
//! with a wall, or its crossing of a periodic face.
//!
//! It owns two things. Which events a body may still be given ([`Eligible`]): every one from
//! now on when its motion is new, or those after the one just handled when it is unchanged (a
//! contact that pushed nothing), which is how the event queue of the frame pipeline drops a
//! contact it has handled. And a cheap screen before the exact test: from the two centres at
//! the current instant, a pair moving apart, missing each other or unable to touch before the
//! best event found so far is skipped, with margins far wider than the rounding of the screen
//! (and the screen off in a world whose coordinates are too large for its smallest bodies to
//! trust them), so the screen never skips a pair the exact test would schedule. The exact test
//! is the frame pipeline's own: [`contacts::pair_start`] on the lower id's motion and the higher
//! id's, shifted by whole sides across periodic faces, so every time is canonical and the same
//! bits as every method's. It never schedules, handles an event or changes a body.

use super::cells::{Cells, Crossing, Neighbour, NONE};
use crate::bodies::{Bodies, BodyState};
use crate::event_queue::{Event, Partner};
use crate::memory::prefetch;
use crate::narrow_phase::contacts;
use crate::pipeline::predict::{predict_crossing, predict_wall};
use crate::walls::BoxBounds;
use crate::window::Window;
use glam::DVec3;

/// A pair whose approach rate is below this fraction of |offset| |relative velocity| counts as
/// moving apart (the exact test's own threshold is 1e-12, on the negative side).
const RECEDING: f64 = 1e-6;
/// The screen's slack on a gap (relative to the radius sum squared, and to the offset squared)
/// and on a time bound (relative): all far above its rounding (see [`screen_trusted`]).
const GAP_SLACK: f64 = 1e-6;
const OFFSET_SLACK: f64 = 1e-12;
const TIME_SLACK: f64 = 1e-4;
/// A pair whose relative speed squared is below this fraction of the sum of the two speeds
/// squared may be rounding noise to the exact test (its own rule is 10^-12 of the sum of the
/// speeds): it never bounds the screen.
const NOISE: f64 = 1e-16;
/// The screen is trusted when this many roundings of the largest coordinate are within
/// `1e-11` of the smallest radius.
const ROUNDINGS: f64 = 16.0;
const TRUSTED: f64 = 1e-11;

/// True when centres computed at the current instant are accurate enough, in a box whose
/// coordinates reach `scale`, for the screen's margins to hold for radii of at least `radius`:
/// their rounding is then below 10^-11 of the smallest radius, the margins at least 10^-6 of it.
pub(super) fn screen_trusted(scale: f64, radius: f64) -> bool {
    ROUNDINGS * f64::EPSILON * scale <= TRUSTED * radius
}

/// Which of a body's events may be scheduled.
#[derive(Debug, Clone, Copy)]
pub(super) enum Eligible {
    /// Every event from this instant on: the body's motion is new (or the calendar is rebuilt
    /// at a step's start, before any event of the step was handled).
    From(f64),
    /// The events after this one, in the event queue's order: the body's motion is unchanged,
    /// and every event of it up to this one was handled.
    After(Event),
}

impl Eligible {
    #[inline]
    fn start(&self) -> f64 {
        match self {
            Eligible::From(t) => *t,
            Eligible::After(event) => event.time,
        }
    }

    #[inline]
    fn admits(&self, event: &Event) -> bool {
        match self {
            Eligible::From(t) => event.time >= *t,
            // The queue's `Ord` puts earlier events last.
            Eligible::After(handled) => event < handled,
        }
    }
}

/// True when `a` comes before `b` in the event queue's order.
#[inline]
pub(super) fn earlier(a: &Event, b: &Event) -> bool {
    a > b
}

/// What a search reads: the bodies, the cells, whether the screen is trusted; its scratch; and
/// what it counts.
pub(super) struct Search<'a> {
    pub bodies: &'a Bodies,
    pub cells: &'a Cells,
    pub bounds: &'a BoxBounds,
    pub screen: bool,
    /// The partners that passed the screen, waiting for their exact tests.
    pub candidates: &'a mut Vec<Candidate>,
    /// Exact pair tests made.
    pub tests: u64,
}

/// A partner from the neighbourhood: once it passed the screen, its exact test waits, ordered by
/// the earliest it could touch (after `now`; minus infinity when not bounded).
#[derive(Debug, Clone, Copy)]
pub(super) struct Candidate {
    earliest: f64,
    q: u32,
    /// Its cell among the neighbourhood's (see [`Near`]).
    cell: u8,
}

/// The neighbour cells a search gathered bodies from, each with the whole sides that bring its
/// bodies next to the searching body, and the searching body's centre less those.
struct Near {
    cells: usize,
    shifts: [DVec3; 27],
    origins: [DVec3; 27],
}

impl Default for Near {
    fn default() -> Near {
        Near { cells: 0, shifts: [DVec3::ZERO; 27], origins: [DVec3::ZERO; 27] }
    }
}

/// Body `p` as its partners are screened against it, at `now`.
#[derive(Clone, Copy)]
struct Own {
    p: usize,
    position: DVec3,
    velocity: DVec3,
    radius: f64,
    now: f64,
    /// Rounding of a time near `now`, relative to it: times compared as offsets from `now`
    /// allow for it.
    rounding: f64,
}

/// The earliest eligible event found so far, and how long after `now` it comes (infinite when
/// none); and how long after `now` the earliest contact of the partners screened so far comes
/// at the latest, which bounds the screen.
struct Best {
    event: Option<Event>,
    horizon: f64,
    bound: f64,
}

impl Best {
    fn new(event: Option<Event>, now: f64) -> Best {
        let horizon = event.map_or(f64::INFINITY, |e| e.time - now);
        Best { event, horizon, bound: horizon }
    }

    /// Keeps `event` when eligible and earlier.
    #[inline]
    fn offer(&mut self, event: Event, eligible: Eligible, now: f64) {
        if eligible.admits(&event) && self.event.is_none_or(|b| earlier(&event, &b)) {
            (self.event, self.horizon) = (Some(event), event.time - now);
            self.bound = self.bound.min(self.horizon);
        }
    }
}

impl<'a> Search<'a> {
    /// Body `p`'s earliest eligible event at `now`: a contact with a body of its neighbourhood,
    /// with a wall, or its crossing of a periodic face.
    #[inline]
    pub(super) fn next_event(&mut self, p: usize, now: f64, eligible: Eligible) -> Option<Event> {
        let window = Window::new(eligible.start(), f64::INFINITY);
        let mut best = Best::new(None, now);
        // A box periodic on every axis has no walls to predict against.
        let walled = self.bounds.periodic.contains(&false);
        let (wall, face) = (
            walled.then(|| predict_wall(self.bodies, self.bounds, p as u32, window)).flatten(),
            predict_crossing(self.bodies, self.bounds, p as u32, window),
        );
        for event in [wall, face].into_iter().flatten() {
            best.offer(event, eligible, now);
        }
        let (own, cells) = (self.own(p, now), self.cells);
        let mut near = Near::default();
        self.candidates.clear();
        match cells.inner_around(p) {
            Some(around) => {
                around.for_each(|cell| self.gather(&own, Neighbour { cell, shift: DVec3::ZERO }, &mut near))
            }
            None => cells.for_each_around(p, |n| self.gather(&own, n, &mut near)),
        }
        self.screen_all(&own, &near, &mut best);
        self.test_candidates(&own, &near, eligible, &mut best);
        best.event
    }

    /// Body `p`, which has just stepped into a new cell by `crossing` at `now`: its earliest
    /// contact with the bodies of the cells it came within reach of, or `best` when none is
    /// earlier. (A contact with them cannot be at `now` itself: touching bodies are always in
    /// neighbouring cells.)
    #[inline]
    pub(super) fn after_crossing(
        &mut self,
        p: usize,
        crossing: Crossing,
        now: f64,
        best: Option<Event>,
    ) -> Option<Event> {
        let (own, cells) = (self.own(p, now), self.cells);
        let mut best = Best::new(best, now);
        let mut near = Near::default();
        self.candidates.clear();
        cells.for_each_new(p, crossing, |n| self.gather(&own, n, &mut near));
        self.screen_all(&own, &near, &mut best);
        self.test_candidates(&own, &near, Eligible::From(now), &mut best);
        best.event
    }

    #[inline]
    fn own(&self, p: usize, now: f64) -> Own {
        let state = &self.bodies.state[p];
        let rounding = ROUNDINGS * f64::EPSILON * now.abs();
        Own { p, position: state.motion.at(now), velocity: state.motion.velocity, radius: state.radius, now, rounding }
    }

    /// Lists the bodies of neighbour cell `n` (but `own`'s) in `self.candidates`, to be screened,
    /// asking for their records on the way: a neighbourhood's bodies are scattered in memory,
    /// and the records then arrive together rather than one after the other.
    #[inline(always)]
    fn gather(&mut self, own: &Own, n: Neighbour, near: &mut Near) {
        let (cells, states) = (self.cells, &self.bodies.state[..]);
        let mut q = cells.first(n.cell);
        if q == NONE {
            return;
        }
        let k = near.cells;
        near.origins[k] = own.position - n.shift;
        near.shifts[k] = n.shift;
        near.cells += 1;
        while q != NONE {
            if q as usize != own.p {
                prefetch(&states[q as usize]);
                self.candidates.push(Candidate { earliest: 0.0, q, cell: k as u8 });
            }
            q = cells.after(q);
        }
    }

    /// Screens the bodies gathered: those that pass stay in `self.candidates`, each with the
    /// earliest it can touch `own`.
    #[inline(always)]
    fn screen_all(&mut self, own: &Own, near: &Near, best: &mut Best) {
        let states = &self.bodies.state[..];
        if !self.screen {
            self.candidates.iter_mut().for_each(|c| c.earliest = f64::NEG_INFINITY);
            return;
        }
        let mut bound = best.bound;
        self.candidates.retain_mut(|c| {
            match screen(own, &states[c.q as usize], near.origins[c.cell as usize], &mut bound) {
                Some(earliest) => {
                    c.earliest = earliest;
                    true
                }
                None => false,
            }
        });
        best.bound = bound;
    }

    /// The candidates' exact tests, earliest first, until the next cannot come before the best.
    #[inline]
    fn test_candidates(&mut self, own: &Own, near: &Near, eligible: Eligible, best: &mut Best) {
        let mut candidates = std::mem::take(self.candidates);
        if candidates.len() > 1 {
            candidates.sort_unstable_by(|a, b| a.earliest.total_cmp(&b.earliest));
        }
        for c in &candidates {
            if c.earliest > best.horizon {
                break;
            }
            self.exact(own, c.q as usize, near.shifts[c.cell as usize], eligible, best);
        }
        *self.candidates = candidates;
    }

    /// The exact test of `own.p` and `q` (through `q`'s image shifted by `shift`), as the frame
    /// pipeline makes it: their contact becomes `best` when eligible and earlier.
    #[inline]
    fn exact(&mut self, own: &Own, q: usize, shift: DVec3, eligible: Eligible, best: &mut Best) {
        self.tests += 1;
        let p = own.p;
        // The lower id's own motion against the higher id's, shifted next to it.
        let (low, high, image_shift) = if p < q { (p, q, shift) } else { (q, p, DVec3::ZERO - shift) };
        let mut image = self.bodies.state[high];
        if image_shift != DVec3::ZERO {
            image.motion.position += image_shift;
        }
        let window = Window::new(eligible.start(), f64::INFINITY);
        let Some((time, _)) = contacts::pair_start(self.bodies, (low, &self.bodies.state[low]), (high, &image), window)
        else {
            return;
        };
        let stamps = (self.bodies.stamp[low], self.bodies.stamp[high]);
        let event = Event {
            time,
            body: low as u32,
            partner: Partner::Body(high as u32),
            body_stamp: stamps.0,
            partner_stamp: stamps.1,
        };
        best.offer(event, eligible, own.now);
    }
}

/// The screen of the body of `state` as `own`'s partner, its centre less `origin` (`own`'s,
/// shifted to its image) as its offset: `None` when it can be skipped (moving apart from `own`,
/// passing wide of it, or unable to touch it within `bound` of `own.now`), else a lower bound on
/// when it can touch, after `own.now` (minus infinity when there is none to trust, as for a pair
/// touching now). A pair sure to touch lowers `bound` to an upper bound on when it does. Every
/// bound allows for the rounding of the offsets (see [`screen_trusted`]): |offset|^2 falls no
/// faster than 2 |approach| per unit time at first, and the paths' closest approach is where the
/// discriminant says, to its slack.
#[inline(always)]
fn screen(own: &Own, state: &BodyState, origin: DVec3, bound: &mut f64) -> Option<f64> {
    let motion = &state.motion;
    let offset = motion.position + (own.now - motion.since) * motion.velocity - origin;
    let velocity = motion.velocity - own.velocity;
    let approach = offset.dot(velocity);
    let (d2, v2) = (offset.length_squared(), velocity.length_squared());
    // |approach| clear of 10^-6 |offset| |velocity|: its sign is sure.
    let clear = approach * approach > RECEDING * RECEDING * d2 * v2;
    if approach > 0.0 {
        return if clear { None } else { Some(f64::NEG_INFINITY) };
    }
    let reach = own.radius + state.radius;
    let gap = d2 - reach * reach;
    let slack = GAP_SLACK * reach * reach + OFFSET_SLACK * d2;
    if !(clear && gap > slack) {
        return Some(f64::NEG_INFINITY);
    }
    let closing = -approach;
    if gap - slack > 2.0 * closing * (*bound + own.rounding) * (1.0 + TIME_SLACK) {
        return None;
    }
    let discriminant = approach * approach - v2 * gap;
    let spread = slack * v2;
    if discriminant < -spread {
        return None;
    }
    let earliest = (gap - slack) / (closing * (1.0 + TIME_SLACK) + (discriminant + spread).sqrt()) * (1.0 - TIME_SLACK)
        - own.rounding;
    if earliest > *bound {
        return None;
    }
    // Sure to touch (the exact test's noise rule aside: far faster than rounding noise), and
    // after now: the contact comes by this at the latest.
    if discriminant > spread
        && earliest > 0.0
        && v2 > NOISE * (own.velocity.length_squared() + motion.velocity.length_squared())
    {
        let latest = (gap + slack) / (closing * (1.0 - TIME_SLACK) + (discriminant - spread).sqrt())
            * (1.0 + TIME_SLACK)
            + own.rounding;
        *bound = bound.min(latest);
    }
    Some(earliest)
}
