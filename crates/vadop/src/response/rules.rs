//! The rules that keep every frame finite without giving up exact physics where it is finite.
//!
//! Elastic hard spheres collide finitely often in finite time (a mass ratio M/m gives about
//! pi sqrt(M/m) collisions), so with restitution 1 every contact is processed as it comes. Two
//! cases would never end, and only they are changed, each change counted:
//!
//! - **Inelastic collapse** (restitution below 1): a group of bodies can collide infinitely often
//!   in finite time (three spheres in a line between walls, a dense column). The TC model of
//!   Luding and McNamara (1998) ends it: a contact of a body whose previous contact lies less than
//!   the contact duration t_c before is elastic. Dissipation then needs time between contacts, as
//!   real contacts do, and the collision rate stays finite. Counted in
//!   [`crate::FrameStats::tc_contacts`].
//! - **Jams**: bodies wedged with no free space at all between each other and the walls exchange
//!   velocities forever at a single instant, whatever the restitution; and a body trapped between
//!   a wall and one 10^100 times heavier is hit about 10^50 times before it is released. A body
//!   that takes part in more than [`JAM_LIMIT`] contacts at one instant, or more than
//!   [`BURST_LIMIT`] within one step, is jammed. Its cluster — every body that touches it, or
//!   touches one that does, without separating — is frozen: all move on with the cluster's
//!   centre-of-mass velocity, less any component into a wall a member touches. Momentum is kept
//!   but for what the walls take. A frozen cluster has no relative motion left, so the instant
//!   ends; a body reaching the cluster later at the same instant joins it, and the cluster is
//!   frozen again. One freeze costs time linear in the cluster. Counted in
//!   [`crate::FrameStats::jam_contacts`].
//!
//! A Newton's cradle of k touching bodies takes about 2k contacts per body at one instant, so
//! cradles of up to about [`JAM_LIMIT`] / 2 bodies are resolved exactly.
//!
//! This module owns the per-body contact history (one record per body, by body id, no hashing);
//! it decides which rule applies and never changes a body itself.

/// Contacts one body may take part in at a single instant before it counts as jammed.
pub const JAM_LIMIT: u32 = 64;
// The per-instant counts are bytes.
const _: () = assert!(JAM_LIMIT < u8::MAX as u32);

/// Contacts one body may take part in within one step before it counts as jammed: far above what
/// a body meets at the fastest speed a world accepts (about 10^5 at 10^4 box lengths per frame),
/// so only pathological scenes (extreme mass ratios against a wall) ever reach it.
pub const BURST_LIMIT: u32 = 1_000_000;

/// Default contact duration t_c of the TC model, in seconds.
pub const DEFAULT_CONTACT_DURATION: f64 = 1e-5;

/// What a contact does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Rule {
    /// An impulse with this restitution (the world's, or 1 under the TC model).
    Impulse { restitution: f64, changed: bool },
    /// Jammed: freeze the cluster (see the module documentation).
    Jam,
}

/// Contact history.
#[derive(Debug, Default, Clone)]
pub(crate) struct ContactRules {
    /// Per body: its history (see [`History`]).
    history: Vec<History>,
    /// Per body: the instant at which it was last frozen into a jammed cluster (`-inf` if never).
    /// Apart from the history and empty until the first freeze: jams are rare, and every body's
    /// record is 8 bytes smaller without it (at 10^7 bodies, 80 MB of a world's peak).
    frozen: Vec<f64>,
    /// The bodies whose `in_step` is not zero: the next step clears only those, so no body needs
    /// a step number of its own.
    counted: Vec<u32>,
}

/// One body's contact history, its fields side by side: every contact reads and writes them
/// together for bodies scattered in memory (the event loop's contacts come in time order, each
/// far from the last), and each field in an array of its own then cost a cache miss of its own.
#[derive(Debug, Clone, Copy)]
struct History {
    /// Time of the body's last contact (`-inf` before the first).
    last_contact: f64,
    /// Its contacts within the current step.
    in_step: u32,
    /// Its contacts at the instant `last_contact`, saturating: only "more than [`JAM_LIMIT`]"
    /// matters, and a byte holds that.
    at_instant: u8,
}

// Two records to a cache line; the freeze instants live apart (see `ContactRules::frozen`).
const _: () = assert!(std::mem::size_of::<History>() == 16);

impl History {
    const NONE: History = History { last_contact: f64::NEG_INFINITY, in_step: 0, at_instant: 0 };
}

impl ContactRules {
    /// Makes room for `slots` bodies; new bodies have no history.
    pub(crate) fn resize(&mut self, slots: usize) {
        if self.history.len() < slots {
            self.history.resize(slots, History::NONE);
        }
    }

    /// Forgets body `i`'s history (its slot was reused or removed).
    pub(crate) fn forget(&mut self, i: usize) {
        self.resize(i + 1);
        let history = &mut self.history[i];
        (history.last_contact, history.at_instant) = (f64::NEG_INFINITY, 0);
    }

    /// Body `i`'s history copied from `other`'s.
    pub(crate) fn copy_history(&mut self, other: &ContactRules, i: usize) {
        self.history[i] = other.history[i];
        let frozen = other.frozen_at(i);
        if frozen != self.frozen_at(i) {
            self.frozen_mut()[i] = frozen;
        }
    }

    /// The instant at which body `i` was last frozen (`-inf` if never).
    #[inline]
    fn frozen_at(&self, i: usize) -> f64 {
        self.frozen.get(i).copied().unwrap_or(f64::NEG_INFINITY)
    }

    /// Every body's freeze instant, made on the first freeze.
    fn frozen_mut(&mut self) -> &mut [f64] {
        if self.frozen.len() < self.history.len() {
            self.frozen.resize(self.history.len(), f64::NEG_INFINITY);
        }
        &mut self.frozen
    }

    /// The time of body `i`'s last contact (`-inf` before the first, or for a body not held).
    pub(crate) fn last_contact(&self, i: usize) -> f64 {
        self.history.get(i).map_or(f64::NEG_INFINITY, |h| h.last_contact)
    }

    /// Body `i`'s last contact was at `t` (a restored history).
    pub(crate) fn set_last_contact(&mut self, i: usize, t: f64) {
        self.resize(i + 1);
        self.history[i].last_contact = t;
    }

    /// A new step: every body's step count starts again.
    pub(crate) fn next_step(&mut self) {
        for &i in &self.counted {
            self.history[i as usize].in_step = 0;
        }
        self.counted.clear();
    }

    /// Marks body `i` frozen into a jammed cluster at `t`; false when it already was.
    pub(crate) fn freeze(&mut self, i: u32, t: f64) -> bool {
        let frozen = &mut self.frozen_mut()[i as usize];
        let was = *frozen == t;
        *frozen = t;
        !was
    }

    /// Counts a contact of body `i` at `t`; true once it is jammed.
    fn count(&mut self, i: usize, t: f64) -> bool {
        let (at_instant, in_step, jammed) = self.after_count(i, t);
        let history = &mut self.history[i];
        if history.in_step == 0 {
            self.counted.push(i as u32);
        }
        (history.at_instant, history.in_step) = (at_instant, in_step);
        jammed
    }

    /// Body `i`'s counts at the instant and in the step once a contact at `t` is counted, and
    /// whether it is jammed then.
    #[inline]
    fn after_count(&self, i: usize, t: f64) -> (u8, u32, bool) {
        let history = &self.history[i];
        let at_instant = if history.last_contact == t { history.at_instant.saturating_add(1) } else { 1 };
        let in_step = history.in_step + 1;
        (at_instant, in_step, at_instant as u32 > JAM_LIMIT || in_step > BURST_LIMIT || self.frozen_at(i) == t)
    }

    /// True when a contact of bodies `a` and `b` at `t` would jam them, found without counting it.
    pub(crate) fn would_jam(&self, a: u32, b: u32, t: f64) -> bool {
        self.would_jam_alone(a, t) || self.would_jam_alone(b, t)
    }

    /// True when a contact of body `a` with a wall at `t` would jam it, found without counting it.
    #[inline]
    pub(crate) fn would_jam_alone(&self, a: u32, t: f64) -> bool {
        self.after_count(a as usize, t).2
    }

    /// The restitution of a contact at `t` of bodies whose previous contacts were at
    /// `previous` under the TC model with duration `duration`.
    fn restitution(restitution: f64, duration: f64, t: f64, previous: f64) -> Rule {
        let recent = restitution < 1.0 && t - previous < duration;
        Rule::Impulse { restitution: if recent { 1.0 } else { restitution }, changed: recent }
    }

    /// The restitution a contact of bodies `a` and `b` at `t` gets under the TC model, unless it
    /// jams them, without recording it: what [`Self::pair`] would apply.
    pub(crate) fn pair_restitution(&self, a: u32, b: u32, t: f64, restitution: f64, duration: f64) -> f64 {
        let previous = self.history[a as usize].last_contact.max(self.history[b as usize].last_contact);
        match ContactRules::restitution(restitution, duration, t, previous) {
            Rule::Impulse { restitution, .. } => restitution,
            Rule::Jam => unreachable!("the TC model never jams"),
        }
    }

    /// The rule for a contact of bodies `a` and `b` at `t`, recorded in their history.
    pub(crate) fn pair(&mut self, a: u32, b: u32, t: f64, restitution: f64, duration: f64) -> Rule {
        let (a, b) = (a as usize, b as usize);
        let previous = self.history[a].last_contact.max(self.history[b].last_contact);
        let jammed = self.count(a, t) | self.count(b, t);
        self.history[a].last_contact = t;
        self.history[b].last_contact = t;
        if jammed {
            Rule::Jam
        } else {
            ContactRules::restitution(restitution, duration, t, previous)
        }
    }

    /// The rule for a contact of body `a` with a wall at `t`, recorded in its history.
    pub(crate) fn wall(&mut self, a: u32, t: f64, restitution: f64, duration: f64) -> Rule {
        let a = a as usize;
        let previous = self.history[a].last_contact;
        let jammed = self.count(a, t);
        self.history[a].last_contact = t;
        if jammed {
            Rule::Jam
        } else {
            ContactRules::restitution(restitution, duration, t, previous)
        }
    }

    /// Bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.history.capacity() * std::mem::size_of::<History>()
            + self.frozen.capacity() * 8
            + self.counted.capacity() * 4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tc_model_makes_quick_repeats_elastic() {
        let mut rules = ContactRules::default();
        rules.resize(3);
        let plain = Rule::Impulse { restitution: 0.5, changed: false };
        let elastic = Rule::Impulse { restitution: 1.0, changed: true };
        assert_eq!(rules.pair(0, 1, 1.0, 0.5, 1e-3), plain);
        // Body 1 touched at 1.0: a contact 1e-4 later is elastic, one 1e-2 later is not.
        assert_eq!(rules.pair(1, 2, 1.0001, 0.5, 1e-3), elastic);
        assert_eq!(rules.wall(2, 1.0201, 0.5, 1e-3), plain);
        // Elastic worlds are never changed.
        assert_eq!(rules.pair(0, 2, 1.0202, 1.0, 1e-3), Rule::Impulse { restitution: 1.0, changed: false });
    }

    #[test]
    fn jams_are_counted_per_instant_and_frozen_bodies_stay_jammed_at_it() {
        let mut rules = ContactRules::default();
        rules.resize(4);
        for _ in 0..JAM_LIMIT / 2 {
            assert!(matches!(rules.pair(0, 1, 2.0, 1.0, 0.0), Rule::Impulse { .. }));
            assert!(matches!(rules.wall(0, 2.0, 1.0, 0.0), Rule::Impulse { .. }));
        }
        assert_eq!(rules.pair(0, 1, 2.0, 1.0, 0.0), Rule::Jam);
        assert!(rules.freeze(1, 2.0));
        assert!(!rules.freeze(1, 2.0));
        // Anyone touching a frozen body at the same instant is jammed too.
        assert_eq!(rules.pair(1, 3, 2.0, 1.0, 0.0), Rule::Jam);
        // The next instant starts afresh.
        assert!(matches!(rules.pair(0, 1, 2.5, 1.0, 0.0), Rule::Impulse { .. }));
    }
}
