//! The searcher: conservative advancement over a gauge, from a canonical reference through every
//! contact start and end it finds, with the restart points, the budgets and the termination guard
//! of the module doc. It owns the stepping only; what is measured at a probe is the gauge's.

use super::gauges::{Gauge, Measure, Probe, Then};
use super::reach::Reach;
use super::{ceiling, cleared, ending, guard, MARGIN, MAX_ITERATIONS, RESTING_BUDGET};
use crate::error::{Result, VadopError};
use crate::window::Window;

/// How much deeper than it is, in tolerances, a pair touching at its reference must at least go
/// to count as approaching there: real progress, so that a pair a rule has just left that deep is
/// not found approaching again at once, and small, so that a pair pressed deeper at each new
/// reference sinks an eighth of a tolerance each time, not a whole one.
const PROGRESS: f64 = 0.125;

/// The iteration of one search: the reference, the scaled tolerance, the step count, and the
/// times outside which the pair is more than `2 tol` apart (neither touching nor in contact).
pub(super) struct Searcher<G> {
    pub(super) gauge: G,
    pub(super) reference: f64,
    pub(super) tol: f64,
    pub(super) iterations: u32,
    /// `iterations` when the chain last started afresh: [`MAX_ITERATIONS`] caps each piece.
    pub(super) restarted: u32,
    /// Probes of a resumed chain made before this searcher took it up (counted in `iterations`
    /// for the budget, not made here).
    pub(super) carried: u32,
    pub(super) reach: Option<Reach>,
    /// Where the chain stopped without finding anything, if it stopped at a horizon (the end it
    /// was asked to search to, or the end of all contacts): what [`super::Resume`] carries.
    pub(super) parked: Option<Parked>,
}

/// Where a chain stopped at a horizon: the next probe's time since the reference, and whether
/// it was following a contact to its end. The probe at `tau` has not been made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Parked {
    pub(super) tau: f64,
    pub(super) in_contact: bool,
}

impl Parked {
    /// A chain that finds nothing more, ever.
    pub(super) const DONE: Parked = Parked { tau: f64::INFINITY, in_contact: false };
}

/// The end of a contact: its time since the reference, and whether no contact can follow it
/// (the bounding volumes have parted, or the separation along the ending probe's axis stays above
/// the guard until they do).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct End {
    pub(super) tau: f64,
    pub(super) last: bool,
}

/// What the pair does when it touches at the reference.
pub(super) enum AtReference {
    /// It goes deeper: a new contact at the reference.
    Approaching,
    /// Deeper than the tolerance already: a contact in progress.
    Inside,
    /// Separating: the contact in progress ends at this tau.
    Ended(f64),
    /// Neither deeper nor apart, ever: no new contact.
    Resting,
}

impl<G: Gauge> Searcher<G> {
    pub(super) fn new(gauge: G, reference: f64, tol: f64) -> Self {
        let reach = gauge.reach(2.0 * tol);
        Searcher { gauge, reference, tol, iterations: 0, restarted: 0, carried: 0, reach, parked: None }
    }

    /// Starts the chain afresh at absolute `time`, a contact start or end it found (or a time the
    /// caller knows to be one): a cold probe, a fresh iteration budget, and the time since the
    /// reference derived from the absolute time alone. What follows is then a function of the
    /// motions and `time` only, so a caller that holds a contact's start resumes the chain there
    /// without replaying the contacts before it, to the bit.
    pub(super) fn restart_at(&mut self, time: f64) -> f64 {
        self.gauge.forget();
        self.restarted = self.iterations;
        (time - self.reference).max(0.0)
    }

    /// From this time since the reference on the pair stays more than `2 tol` apart.
    pub(super) fn leave(&self) -> f64 {
        self.reach.map_or(0.0, |r| r.leave)
    }

    pub(super) fn stall(&self, tau: f64, reason: &'static str) -> VadopError {
        VadopError::ContactSearchStalled { time: self.reference + tau, iterations: self.probes(), reason }
    }

    /// Probes made by this searcher.
    pub(super) fn probes(&self) -> u32 {
        self.iterations - self.carried
    }

    pub(super) fn probe(&mut self, tau: f64, measure: Measure) -> Result<Probe> {
        if self.iterations - self.restarted >= MAX_ITERATIONS {
            return Err(self.stall(tau, "the iteration cap was reached (resting or sliding contact while turning?)"));
        }
        if self.iterations.is_multiple_of(crate::interrupt::POLL_INTERVAL) && crate::interrupt::raised() {
            // Void: the world undoes the step.
            return Err(self.stall(tau, "the step was interrupted"));
        }
        self.iterations += 1;
        Ok(self.gauge.probe(tau, measure))
    }

    /// `tau + step`; `None` when that is beyond every horizon.
    pub(super) fn advance(&self, tau: f64, step: f64) -> Result<Option<f64>> {
        let next = tau + step;
        if !next.is_finite() {
            return Ok(None);
        }
        if !(next > tau) {
            return Err(self.stall(tau, "the step fell below the resolution of time"));
        }
        Ok(Some(next))
    }

    /// Nothing more, ever: parks the chain for good.
    fn done<T>(&mut self) -> Option<T> {
        self.parked = Some(Parked::DONE);
        None
    }

    /// At most this, a contact starts (`tol` less the margin).
    pub(super) fn touch(&self) -> f64 {
        self.tol * (1.0 - MARGIN)
    }
    /// The distance is kept above this until a contact starts (`tol/2` plus the margin).
    pub(super) fn guard(&self) -> f64 {
        guard(self.tol)
    }
    /// Above this, a contact has ended (`tol` plus the margin).
    pub(super) fn clear(&self) -> f64 {
        cleared(self.tol)
    }
    /// During a contact the signed distance is kept below this (`2 tol` less the margin).
    pub(super) fn ceiling(&self) -> f64 {
        ceiling(self.tol)
    }

    /// The first contact start from `tau` (where the pair does not touch) before absolute time
    /// `end`.
    pub(super) fn next_start(&mut self, mut tau: f64, end: f64) -> Result<Option<f64>> {
        loop {
            if !(self.reference + tau < end && tau <= self.leave()) {
                self.parked = Some(Parked { tau, in_contact: false });
                return Ok(None);
            }
            let p = self.probe(tau, Measure::Gap)?;
            if p.upper <= self.touch() {
                return Ok(Some(tau));
            }
            let step = match p.approach_step(self.guard()) {
                Some(step) => step.max(p.hold),
                None if p.hold > 0.0 => p.hold,
                None => return Err(self.stall(tau, "the distance bounds were too loose to step")),
            };
            if step == f64::INFINITY {
                // The separation along a fixed axis never shrinks: no contact ever.
                return Ok(self.done());
            }
            match self.advance(tau, step)? {
                Some(next) => tau = next,
                None => return Ok(self.done()),
            }
        }
    }

    /// The end of the contact in progress at `tau`, before absolute time `end`. A search for
    /// what follows the contact ([`Then::NextStart`]) stops, the chain done, at a probe from
    /// which the distance only grows for good: nothing can follow, and where exactly the contact
    /// ends does not matter. The answers are the same: the search for the end would have found
    /// no start after it.
    pub(super) fn contact_end(&mut self, mut tau: f64, end: f64, then: Then) -> Result<Option<End>> {
        if self.gauge.translating() {
            return match self.translating_end(tau)? {
                // Their distance is convex in time: once it has grown past the band, it only grows.
                Some(found) if self.reference + found < end => Ok(Some(End { tau: found, last: true })),
                // The chain goes on from the end as the caller would take it up (restarted
                // there, see `after_contact`), outside the contact: the same iterates follow.
                Some(found) => {
                    let next = self.restart_at(self.reference + found);
                    self.parked = Some(Parked { tau: next, in_contact: false });
                    Ok(None)
                }
                None => Ok(self.done()),
            };
        }
        loop {
            if !(self.reference + tau < end) {
                self.parked = Some(Parked { tau, in_contact: true });
                return Ok(None);
            }
            if tau >= self.leave() {
                // The bounding volumes have parted: more than `2 tol` apart.
                return Ok(Some(End { tau, last: true }));
            }
            let p = self.probe(tau, Measure::Contact(then))?;
            if p.parting {
                return Ok(self.done());
            }
            if p.lower > self.clear() {
                // Leaving along an axis faster than turning can bring the surfaces back along it
                // (a pair passing through another at speed): no start can follow, and the start
                // search from here would spend a probe to find that out.
                let last = p.approach_step(self.guard()).is_some_and(|step| tau + step >= self.leave());
                return Ok(Some(End { tau, last }));
            }
            let room = self.ceiling() - p.upper;
            if !(room > 0.0) {
                return Err(self.stall(tau, "the distance bounds were too loose to step"));
            }
            if !(p.grow > 0.0 || p.bend > 0.0) {
                return Ok(self.done());
            }
            // In contact until the step's end, and apart from `leave` on.
            match self.advance(tau, p.time_to(room, p.grow).max(p.hold))? {
                Some(next) => tau = next.min(self.leave()),
                None => return Ok(self.done()),
            }
        }
    }

    /// The end of the contact in progress at `tau` of a pair that only translates, whatever
    /// window asks (the same iterates for every caller); `None` when it never ends.
    ///
    /// The signed distance `d` is then convex in time: between two times where it is at most
    /// `2 tol` it stays so, and a time where the bounds put it in `(tol, 2 tol)` (less the
    /// margins) ends the contact in progress at `tau`, where it is at most `2 tol`. Such a time is
    /// found by the Illinois variant of regula falsi on the bounds' midpoint against the middle
    /// of that band, bracketed by `tau` and the time the bounding volumes part (where `d`
    /// exceeds `2 tol`), bisecting where the interpolation falls outside the bracket: a handful
    /// of probes where stepping at the rate bound needs one per halving of the depth. Once it
    /// has ended the distance only grows: no contact follows (the next probe of a start search
    /// finds the pair receding along its axis, see [`Self::next_start`]).
    fn translating_end(&mut self, tau: f64) -> Result<Option<f64>> {
        if tau >= self.leave() {
            // The bounding volumes have parted: more than `2 tol` apart.
            return Ok(Some(tau));
        }
        let target = ending(self.tol);
        let first = self.probe(tau, Measure::Depth)?;
        if first.lower > self.clear() {
            return Ok(Some(tau));
        }
        if !(first.upper <= self.ceiling()) {
            return Err(self.stall(tau, "the distance bounds were too loose to step"));
        }
        let leave = self.leave();
        if !leave.is_finite() {
            // No relative motion: the distance never changes.
            return Ok(None);
        }
        let value = |p: &Probe| if p.lower.is_finite() { 0.5 * (p.lower + p.upper) } else { p.upper };
        // Below and above the band's middle, with the distance's excess over it there.
        let (mut low, mut high) = ((tau, (value(&first) - target).min(0.0)), (leave, f64::NAN));
        // Which end the last probe replaced: Illinois halves an end's excess when it is kept twice.
        let mut replaced_low = None;
        loop {
            let next = if high.1.is_nan() {
                // The first probe past the contact: where the bounding volumes part.
                leave
            } else {
                let chord = low.0 + (high.0 - low.0) * (low.1 / (low.1 - high.1));
                if chord > low.0 && chord < high.0 {
                    chord
                } else {
                    low.0 + 0.5 * (high.0 - low.0)
                }
            };
            if !(next > low.0 && (next < high.0 || high.1.is_nan())) {
                return Err(self.stall(low.0, "the step fell below the resolution of time"));
            }
            let p = self.probe(next, Measure::Depth)?;
            if p.lower > self.clear() && p.upper <= self.ceiling() {
                return Ok(Some(next));
            }
            let below = p.upper <= self.ceiling();
            if below {
                low = (next, (value(&p) - target).min(0.0));
                if replaced_low == Some(true) {
                    high.1 *= 0.5;
                }
            } else {
                high = (next, (value(&p) - target).max(f64::MIN_POSITIVE));
                if replaced_low == Some(false) {
                    low.1 *= 0.5;
                }
            }
            replaced_low = Some(below);
        }
    }

    /// Whether a pair touching at the reference (`p0`) is approaching. Decided by the motion
    /// itself, whatever window asks: does it get past the floor (`tol` deep, or [`PROGRESS`]
    /// deeper than it is, whichever is deeper) before it separates beyond `tol`?
    pub(super) fn classify(&mut self, p0: Probe, deep_is_contact: bool) -> Result<AtReference> {
        if deep_is_contact && p0.upper < -self.tol {
            return Ok(AtReference::Inside);
        }
        // The floor is absolute down to `tol` so that new references (each velocity change of
        // either body) cannot each let a pressed pair sink a tolerance deeper than the last; below
        // it a pair must still go deeper than it is, or every reference would be a new contact.
        let floor = (p0.lower - PROGRESS * self.tol).min(-self.tol);
        let (mut tau, mut p) = (0.0, p0);
        let budget = self.iterations + RESTING_BUDGET;
        loop {
            if p.lower <= floor {
                return Ok(AtReference::Approaching);
            }
            if p.lower > self.clear() {
                return Ok(AtReference::Ended(tau));
            }
            let room = self.ceiling() - p.upper;
            if !(room > 0.0) {
                return Err(self.stall(tau, "the distance bounds were too loose to step"));
            }
            let (down, up) = (p.time_to(p.lower - floor, p.shrink), p.time_to(room, p.grow));
            match self.advance(tau, down.min(up))? {
                // Neither deeper nor apart before the bounding volumes part.
                Some(next) if next >= self.leave() => return Ok(AtReference::Ended(self.leave())),
                Some(next) => tau = next,
                None => return Ok(AtReference::Resting),
            }
            if self.iterations >= budget {
                // A pair that turns back stops where it was found touching, not down to the floor
                // where the search gave up: stall after stall, it would sink that far each.
                let at = if deep_is_contact { tau } else { 0.0 };
                return Err(self.stall(at, "resting or sliding in contact: neither deeper nor apart"));
            }
            p = self.probe(tau, Measure::Depth)?;
        }
    }

    /// The first contact start in `window`, as a time since the reference.
    pub(super) fn first_start_in(&mut self, window: Window, deep_is_contact: bool) -> Result<Option<f64>> {
        let Some(reach) = self.reach else { return Ok(None) };
        // Not probed at all: probes at the reference with bounds too loose to say whether it
        // touches there let such a pair, touching, start a contact at the reference, and the jam
        // rule that froze it gave it the same motion again, at the same instant, for ever.
        if self.gauge.moving_as_one() {
            return Ok(self.done());
        }
        if !(self.reference + reach.enter < window.end) {
            return Ok(None);
        }
        // Before `enter` the pair is more than `2 tol` apart: the search starts there, and the
        // rules at the reference apply only when it is in reach at the reference.
        let mut tau = reach.enter;
        let p0 = if tau == 0.0 { Some(self.probe(0.0, Measure::Depth)?) } else { None };
        if let Some(p0) = p0.filter(|p0| p0.upper <= self.touch()) {
            let next = match self.classify(p0, deep_is_contact)? {
                AtReference::Approaching if self.reference >= window.start => return Ok(Some(0.0)),
                AtReference::Approaching | AtReference::Inside => self.after_contact(self.reference, window.end)?,
                AtReference::Ended(end) => Some(self.restart_at(self.reference + end)),
                AtReference::Resting => self.done(),
            };
            match next {
                Some(next) => tau = next,
                None => return Ok(None),
            }
        }
        self.start_from(tau, window)
    }

    /// The first contact start in `window` on the chain parked at `parked` (by a search of the
    /// same motions that ended no later than `window.start`): what [`Self::first_start_in`]
    /// finds, to the bit, without replaying the chain up to there. `spent` is the probes made
    /// since the chain last started afresh.
    pub(super) fn resume(&mut self, parked: Parked, spent: u32, window: Window) -> Result<Option<f64>> {
        (self.iterations, self.restarted, self.carried) = (spent, 0, spent);
        let tau = if parked.in_contact {
            let end = self.contact_end(parked.tau, window.end, Then::NextStart)?;
            match self.past(end) {
                Some(tau) => tau,
                None => return Ok(None),
            }
        } else {
            parked.tau
        };
        self.start_from(tau, window)
    }

    /// The first contact start in `window` from `tau`, where the pair does not touch.
    pub(super) fn start_from(&mut self, mut tau: f64, window: Window) -> Result<Option<f64>> {
        loop {
            let Some(start) = self.next_start(tau, window.end)? else { return Ok(None) };
            if self.reference + start >= window.start {
                return Ok(Some(start));
            }
            match self.after_contact(self.reference + start, window.end)? {
                Some(next) => tau = next,
                None => return Ok(None),
            }
        }
    }

    /// Where the chain goes on after the contact that starts at absolute time `start`: the time
    /// since the reference at which it has ended, restarted there; `None` if not before `until`,
    /// or when no contact can follow (two shapes that only translate: the chain is done).
    pub(super) fn after_contact(&mut self, start: f64, until: f64) -> Result<Option<f64>> {
        if self.gauge.translating() {
            // Their distance is convex in time: below the touch threshold once, never again.
            return Ok(self.done());
        }
        let tau = self.restart_at(start);
        let end = self.contact_end(tau, until, Then::NextStart)?;
        Ok(self.past(end))
    }

    /// Where the chain goes on past a contact's end (restarted there): `None` when the contact
    /// has not ended (parked in it) or nothing can follow (done).
    fn past(&mut self, end: Option<End>) -> Option<f64> {
        match end {
            Some(End { last: true, .. }) => self.done(),
            Some(End { tau, .. }) => Some(self.restart_at(self.reference + tau)),
            None => None,
        }
    }

    /// The first contact start in `window` after the contact that starts at absolute time
    /// `start`, which the caller holds from this chain: no replay of the contacts before it.
    pub(super) fn first_start_after(&mut self, start: f64, window: Window) -> Result<Option<f64>> {
        match self.after_contact(start, window.end)? {
            Some(tau) => self.start_from(tau, window),
            None => Ok(None),
        }
    }

    /// The end of the contact that starts at absolute time `start` (a canonical start the caller
    /// holds), before `until`.
    pub(super) fn end_of(&mut self, start: f64, until: f64) -> Result<Option<f64>> {
        let tau = self.restart_at(start);
        Ok(self.contact_end(tau, until, Then::End)?.map(|end| end.tau))
    }

    /// The end, before `until`, of the contact in progress at absolute time `at`, found by
    /// replaying the chain from the reference: the same for every `at` inside one contact. A pair
    /// the chain does not find in contact at `at` is taken to be in a contact from `at` on.
    pub(super) fn end_of_contact_at(&mut self, at: f64, until: f64, deep_is_contact: bool) -> Result<Option<f64>> {
        let Some(reach) = self.reach else { return self.end_of(at, until) };
        let mut tau = reach.enter;
        let p0 = if tau == 0.0 { Some(self.probe(0.0, Measure::Depth)?) } else { None };
        if let Some(p0) = p0.filter(|p0| p0.upper <= self.touch()) {
            let end = match self.classify(p0, deep_is_contact)? {
                AtReference::Approaching | AtReference::Inside => {
                    let tau = self.restart_at(self.reference);
                    self.contact_end(tau, until, Then::End)?
                }
                AtReference::Ended(end) => Some(End { tau: end, last: false }),
                AtReference::Resting => None,
            };
            match end {
                Some(end) if self.reference + end.tau > at => return Ok(Some(end.tau)),
                Some(End { last: true, .. }) => return self.end_of(at, until),
                Some(end) => tau = self.restart_at(self.reference + end.tau),
                None => return Ok(None),
            }
        }
        let before = at.next_up();
        while let Some(start) = self.next_start(tau, before)? {
            let start = self.restart_at(self.reference + start);
            match self.contact_end(start, until, Then::End)? {
                Some(end) if self.reference + end.tau > at => return Ok(Some(end.tau)),
                Some(End { last: true, .. }) => break,
                Some(end) => tau = self.restart_at(self.reference + end.tau),
                None => return Ok(None),
            }
        }
        self.end_of(at, until)
    }
}
