//! The parallel loop's batches: taken from the calendar, worked out ahead on the workers (see
//! [`ahead`]), and committed in order, the commit of one batch and the workers of the next at once.
//!
//! It owns the order of a batch's events and the use of what the workers found. While batch k is
//! committed, the workers work out batch k + 1 from the [`ahead::Mirror`], the world as the commit
//! of batch k - 1 left it, and the thread that commits takes batch k + 2 from the calendar as
//! soon as it is done; between two commits the mirror takes what the earlier changed, the only
//! step on one thread alone. A result is used when no cell it read changed since its world (in
//! the commit of its own batch or of the one before: [`ahead::Marks`]), so every event is handled
//! as the serial loop handles it. Batch k + 1 may hold events that come before some of batch k's
//! (events batch k - 1's commit predicted): the commit of batch k handles those at their turn,
//! without their results, and batch k + 1's commit starts after them. It never decides what an
//! event does: the serial loop's own code does, or the workers' results of the same arithmetic.

use super::ahead::{self, Pushed, Worked, CELLS_PER_EVENT, MIN_PER_THREAD, PER_THREAD};
use super::calendar::{Entry, Events};
use super::screen;
use super::EventLoop;
use crate::bodies::Bodies;
use crate::event_queue::Event;
use crate::frame::{Contact, Output, Physics, Touched};
use crate::response::rules::Rule;

impl EventLoop {
    /// [`Self::step`] on every worker: batch after batch of the next events before `t1`, each
    /// worked out on the workers while the batch before it is committed (see the module
    /// documentation).
    pub(super) fn step_ahead(&mut self, bodies: &mut Bodies, physics: &Physics, t1: f64, out: &mut Output) {
        let mut mirror = std::mem::take(&mut self.mirror);
        if mirror.stale {
            // Every slot's events copied: a body entered but not listed yet has none.
            self.calendar.grow(bodies.slots());
            mirror.copy_all(bodies, &self.cells, &self.calendar, &self.impacts.rules);
        }
        // The batch committed, the one worked out meanwhile, and the one after, taken once the
        // commit is done.
        let (mut batch, mut ahead, mut later) =
            (std::mem::take(&mut self.batch), std::mem::take(&mut self.ahead), std::mem::take(&mut self.later));
        let (mut worked, mut worked_ahead) = (std::mem::take(&mut self.worked), std::mem::take(&mut self.worked_ahead));
        let mut workers = std::mem::take(&mut self.workers);
        let (bounds, screen) = (self.bounds, screen::screen_trusted(self.scale, self.min_radius));
        // The events of `batch` from `start` on are still to be committed.
        let (mut start, mut interrupted) = (0, false);
        batch.clear();
        ahead.clear();
        loop {
            if start == batch.len() {
                // None worked out ahead: the batch taken ahead, or else the next, is worked out
                // alone. (Stopped, the one taken ahead is committed still: its events left the
                // calendar.)
                std::mem::swap(&mut batch, &mut ahead);
                ahead.clear();
                if batch.is_empty() && !interrupted {
                    self.take_batch(t1, &mut batch);
                }
                start = 0;
                if batch.is_empty() {
                    break;
                }
                mirror.seen(&bounds, physics, screen).work_out_batch(&mut workers, &batch, &mut worked);
                if !interrupted {
                    self.take_batch(t1, &mut ahead);
                }
            }
            self.marks.next_batch(self.cells.len());
            self.owners.clear();
            let seen = mirror.seen(&bounds, physics, screen);
            let (taken, ()) = rayon::join(
                || {
                    let taken =
                        self.commit_batch(bodies, physics, (&batch[start..], &worked[start..]), &ahead, t1, out);
                    // The batch after, from the calendar as the commit left it, while the workers
                    // may still be busy: it is theirs next, from the mirror as the commit left it.
                    later.clear();
                    if !interrupted {
                        self.take_batch(t1, &mut later);
                    }
                    taken
                },
                || seen.work_out_batch(&mut workers, &ahead, &mut worked_ahead),
            );
            for worker in &mut workers {
                out.stats.narrow_tests += std::mem::take(&mut worker.tests);
            }
            let world = (&*bodies, &self.cells, &self.calendar, &self.impacts.rules);
            mirror.copy_changed(world, self.marks.changed(), &self.owners);
            #[cfg(test)]
            mirror.check(world);
            (batch, ahead, later, start) = (ahead, later, batch, taken);
            std::mem::swap(&mut worked, &mut worked_ahead);
            interrupted |= crate::interrupt::raised();
        }
        (self.batch, self.ahead, self.later, self.worked, self.worked_ahead) =
            (batch, ahead, later, worked, worked_ahead);
        (self.workers, self.mirror) = (workers, mirror);
    }

    /// The next events before `t1` taken from the calendar into `batch`, as many as the workers
    /// share.
    #[inline(never)]
    fn take_batch(&mut self, t1: f64, batch: &mut Vec<Entry>) {
        batch.clear();
        // Fewer events a batch in a small world: one handled early in a batch then changes what
        // another read less often.
        let size = (self.cells.len() / CELLS_PER_EVENT).clamp(MIN_PER_THREAD, PER_THREAD) * self.threads;
        while batch.len() < size {
            match self.calendar.peek_entry() {
                Some(entry) if entry.scheduled.time() < t1 => {
                    self.calendar.pop();
                    batch.push(entry);
                }
                _ => break,
            }
        }
    }

    /// The events of `batch` handled in order, each with what the workers found (`worked`), and
    /// before each the events due before it: those predicted since (in the calendar) and those of
    /// the batch taken `ahead` of it. Returns how many of `ahead`'s were handled so. (Kept out of
    /// line: a profile then tells the serial share of a step.)
    #[inline(never)]
    fn commit_batch(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        (batch, worked): (&[Entry], &[Worked]),
        ahead: &[Entry],
        t1: f64,
        out: &mut Output,
    ) -> usize {
        let mut taken = 0;
        for (entry, worked) in batch.iter().zip(worked) {
            self.handle_before(bodies, physics, entry, (ahead, &mut taken), t1, out);
            if self.calendar.is_current_entry(entry) {
                self.owners.push(entry.owner);
                self.commit(bodies, physics, *entry, worked, out);
            }
        }
        taken
    }

    /// The events before `entry` handled in order, without the workers' results: those in the
    /// calendar due before `t1`, and those of `ahead` from `taken` on (all due before `t1`).
    fn handle_before(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        entry: &Entry,
        (ahead, taken): (&[Entry], &mut usize),
        t1: f64,
        out: &mut Output,
    ) {
        loop {
            let first = self.calendar.peek_entry().filter(|first| first.scheduled.time() < t1 && first.precedes(entry));
            let early = ahead.get(*taken).filter(|early| early.precedes(entry));
            let (next, in_calendar) = match (first, early) {
                (None, None) => return,
                (Some(first), Some(early)) if !early.precedes(&first) => (first, true),
                (Some(first), None) => (first, true),
                (_, Some(&early)) => (early, false),
            };
            if in_calendar {
                self.calendar.pop();
            } else {
                *taken += 1;
            }
            if self.calendar.is_current_entry(&next) {
                self.owners.push(next.owner);
                self.dispatch(bodies, physics, next, out);
            }
        }
    }

    /// Handles `entry` with what a worker found for it, when nothing it read has changed since.
    fn commit(&mut self, bodies: &mut Bodies, physics: &Physics, entry: Entry, worked: &Worked, out: &mut Output) {
        let i = entry.owner as usize;
        match worked {
            &Worked::Crossed { next, crossing } if self.untouched_crossing(i) => {
                self.marks.mark(self.cells.cell_of(i));
                let (_, into) = self.cells.step_across(i, self.calendar.events(i).crossing);
                self.marks.mark(into);
                self.calendar.schedule(i as u32, Events { next, crossing });
            }
            &Worked::Voided { next } if self.untouched_around(i) => {
                out.stats.invalidations += 1;
                out.stats.retests += 1;
                let crossing = self.calendar.events(i).crossing;
                self.calendar.schedule(i as u32, Events { next, crossing });
            }
            Worked::Pushed(pushed) if self.untouched_pair(bodies, pushed, entry.scheduled.event) => {
                self.commit_pushed(bodies, physics, pushed, entry.scheduled.event.time, out);
            }
            _ => self.dispatch(bodies, physics, entry, out),
        }
    }

    /// True when the contact `event`, which a worker found `pushed` apart, can be handled as it
    /// found: its bodies have the motions it was predicted from, no cell around either was
    /// marked since the world the workers read, and the contact rules would not jam them.
    fn untouched_pair(&self, bodies: &Bodies, pushed: &Pushed, event: Event) -> bool {
        let [a, b] = pushed.pair;
        event.is_current(bodies)
            && self.untouched_around(a as usize)
            && self.untouched_around(b as usize)
            && !self.impacts.rules.would_jam(a, b, event.time)
    }

    /// The contact of bodies `pushed.pair` at `t`, handled with what a worker found: what
    /// [`crate::pipeline::respond::pair_impact`] and [`Self::pair_contact`] do for two
    /// frictionless spheres pushed apart, from the same arithmetic on the same motions.
    fn commit_pushed(&mut self, bodies: &mut Bodies, physics: &Physics, pushed: &Pushed, t: f64, out: &mut Output) {
        let [a, b] = pushed.pair;
        let (i, j) = (a as usize, b as usize);
        let rule = self.impacts.rules.pair(a, b, t, physics.restitution, physics.contact_duration);
        let Rule::Impulse { restitution, changed } = rule else { unreachable!("checked: the rules do not jam them") };
        debug_assert_eq!(restitution.to_bits(), pushed.restitution.to_bits());
        out.stats.tc_contacts += changed as u64;
        // The worker's motions hold the centres at `t` the store's paths give (the bodies'
        // motions are those it read: `untouched_pair`), so they are set as found.
        let [on_i, on_j] = pushed.motions;
        bodies.set_velocity_on(i, on_i, on_i.velocity);
        bodies.set_velocity_on(j, on_j, on_j.velocity);
        out.stats.pair_virial += pushed.virial;
        for k in 0..2 {
            let i = pushed.pair[k] as usize;
            debug_assert!(
                ahead::same_bits(&bodies.motion(i), &pushed.motions[k]) && bodies.stamp(i) == pushed.stamps[k]
            );
            self.marks.mark(self.cells.cell_of(i));
            self.calendar.schedule(pushed.pair[k], Events { next: pushed.next[k], crossing: pushed.crossings[k] });
        }
        out.stats.retests += 2;
        out.stats.pair_contacts += 1;
        let (body, touched) = (bodies.handle(i), Touched::Body(bodies.handle(j)));
        out.contacts.push(Contact {
            time: t,
            body,
            touched,
            point: pushed.point,
            normal: pushed.normal,
            impulse: pushed.impulse,
        });
    }

    /// True when no cell around body `i`'s was marked since the world the workers read.
    fn untouched_around(&self, i: usize) -> bool {
        match self.cells.rows_around(i) {
            Some(rows) => !self.marks.any_in_rows(&rows),
            None => {
                let mut untouched = true;
                self.cells.for_each_around(i, |n| untouched &= !self.marks.is_marked(n.cell));
                untouched
            }
        }
    }

    /// True when neither body `i`'s cell nor the cells its next crossing brings within reach were
    /// marked since the world the workers read.
    fn untouched_crossing(&self, i: usize) -> bool {
        let crossing = self.calendar.events(i).crossing;
        let mut untouched = !self.marks.is_marked(self.cells.cell_of(i));
        self.cells
            .for_each_new(self.cells.stepped(i, crossing), crossing, |n| untouched &= !self.marks.is_marked(n.cell));
        untouched
    }
}
