//! Detect mode's first wall bounces, foreseen at a window's start. There only walls turn spheres,
//! so a body's first wall bounce in a window is known at the window's start, and so is its
//! motion after it (a function of the body alone). Its path after the bounce is binned then,
//! beside every proxy, as a further proxy of the body carrying the stamp the body will have after
//! that bounce: the window start's pair sweep, on every worker, predicts its pairs with the other
//! bodies' paths, before and after their own bounces, and a re-test mid-window meets it too while
//! the bounce is still to come. At the bounce the event loop, on one thread, then only moves the
//! body's stamp on and enters its proxy made ahead: no query, no pair test.
//!
//! It owns that foresight and the rule that keeps it exact. A foreseen path's stamp is the
//! body's stamp at the window's start plus [`FORESEEN_STEP`]; only the foreseen bounce gives the
//! body that stamp (it moves one step, as every change does, and [`Bodies::take_foreseen`] the
//! rest), and only when the body reaches it unchanged since the window's start and leaves it on
//! the foreseen motion, to the bit. Any other change moves the stamp one step, which never meets
//! a foreseen one within a window: the foreseen path's predictions stay void, and the body is
//! re-tested as before. A prediction of a foreseen path can pop at the very instant of the body's
//! bounce, before the bounce (the queue orders a pair before a wall at one instant): it is held,
//! and queued again once the bounce is taken. Second and later bounces in a window are re-tested
//! as any change is. It never handles an event.

use super::predict::predict_wall;
use super::Pipeline;
use crate::bodies::{Bodies, BodyState, FORESEEN_STEP};
use crate::broad_phase::proxy::Foreseen;
use crate::broad_phase::BroadPhase;
use crate::event_queue::{Event, Partner};
use crate::frame::{Mode, Physics};
use crate::motion::Motion;
use crate::response::impact::motion_off_wall;

/// The window's foreseen bounces, and the predictions of their paths held until they happen.
#[derive(Debug, Default)]
pub(super) struct ForeseenBounces {
    /// Each body's first wall bounce of the window and its path after it, by body.
    paths: Vec<Foreseen>,
    /// Predictions of foreseen paths that popped at their body's bounce, before it.
    held: Vec<Event>,
}

impl ForeseenBounces {
    /// The foreseen paths of the window under way (none outside detect mode's plain spheres).
    pub(super) fn paths(&self) -> &[Foreseen] {
        &self.paths
    }

    pub(super) fn memory_bytes(&self) -> usize {
        self.paths.capacity() * std::mem::size_of::<Foreseen>() + self.held.capacity() * std::mem::size_of::<Event>()
    }
}

/// A motion's bits, to tell the foreseen one apart from any other.
fn bits(m: &Motion) -> [u64; 7] {
    let (p, v) = (m.position.to_array(), m.velocity.to_array());
    [p[0], p[1], p[2], m.since, v[0], v[1], v[2]].map(f64::to_bits)
}

impl<B: BroadPhase> Pipeline<B> {
    /// Window start, after the proxies' refresh and before the broad phase's preparation: each
    /// body's first wall bounce of the window, from its fresh proxy, and its path after it, on
    /// every worker. Only where a bounce is all a wall contact does to a sphere and nothing else
    /// turns one: detect mode, plain spheres on straight paths without friction, in a box
    /// without periodic faces, with a broad phase that bins such paths. A body whose proxy ends
    /// at its reach first is renewed before it bounces: it has none.
    pub(super) fn foresee_bounces(&mut self, bodies: &Bodies, physics: &Physics) {
        let foreseen = &mut self.foreseen;
        foreseen.paths.clear();
        foreseen.held.clear();
        let applies = physics.mode == Mode::Detect
            && !bodies.has_rigid()
            && bodies.straight_paths()
            && physics.friction == 0.0
            && !self.proxies.has_ghosts()
            && self.broad.bins_foreseen();
        if !applies {
            return;
        }
        let (table, window) = (&self.proxies, self.window);
        self.workers.extend_ranges(bodies.slots(), &mut foreseen.paths, |range, found| {
            for i in range.filter(|&i| table.is_live(i) && !table.meets_no_wall(i) && !table.expires(i)) {
                let Some(Event { time, partner: Partner::Wall(wall), body_stamp, .. }) =
                    predict_wall(bodies, table, &physics.bounds, i as u32, window)
                else {
                    continue;
                };
                let motion = motion_off_wall(bodies, i, wall, time, physics.restitution);
                let state = BodyState { motion, radius: bodies.state[i].radius };
                let (body, stamp) = (i as u32, body_stamp.wrapping_add(FORESEEN_STEP));
                found.push(Foreseen { body, stamp, state, made: table.made_ahead(i, bodies, &motion, time) });
            }
        });
    }

    /// Body `body` just bounced off a wall: when the bounce is the one foreseen (its stamp moved
    /// once since the window's start, its motion the foreseen one to the bit), its stamp moves on
    /// to the foreseen path's, its proxy made ahead enters the table, its held predictions are
    /// queued again, and true; otherwise false, nothing done.
    pub(super) fn take_foreseen(&mut self, body: u32, bodies: &mut Bodies) -> bool {
        let paths = &self.foreseen.paths;
        let Ok(k) = paths.binary_search_by_key(&body, |f| f.body) else { return false };
        let (i, foreseen) = (body as usize, &paths[k]);
        if bodies.stamp(i).wrapping_add(FORESEEN_STEP - 1) != foreseen.stamp
            || bits(&foreseen.state.motion) != bits(&bodies.motion(i))
        {
            return false;
        }
        bodies.take_foreseen(i);
        self.proxies.enter_made(i, bodies, foreseen.made);
        // This body's held predictions only: another's wait for its own bounce.
        let queue = &mut self.queue;
        self.foreseen.held.retain(|event| {
            let of_body = event.body == body || event.partner == Partner::Body(body);
            if of_body {
                queue.push(*event);
            }
            !of_body
        });
        true
    }

    /// `event` popped void: true, and held, when it is a prediction of a foreseen path whose
    /// bounce is still to come (it popped at that very instant, see the module's doc).
    pub(super) fn hold_foreseen(&mut self, event: &Event, bodies: &Bodies) -> bool {
        let to_come = |i: u32, stamp: u32| bodies.stamp(i as usize).wrapping_add(FORESEEN_STEP) == stamp;
        let held = to_come(event.body, event.body_stamp)
            || matches!(event.partner, Partner::Body(j) if to_come(j, event.partner_stamp));
        if held {
            self.foreseen.held.push(*event);
        }
        held
    }
}
