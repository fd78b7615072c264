//! Detect mode's first wall bounces, foreseen at a window's start. There only walls turn spheres,
//! so a body's first wall bounce in a window is known at the window's start, and so is its
//! motion after it (a function of the body alone). Its path after the bounce is binned then,
//! beside every proxy, as a further proxy of the body carrying the stamp the body will have after
//! that bounce: the window start's pair sweep, on every worker, predicts its pairs with the other
//! bodies' paths, before and after their own bounces, and a re-test mid-window meets it too while
//! the bounce is still to come. The bounce's wall contact (where, the normal, the impulse) is a
//! function of the body's motion at the window's start too, and is worked out then as well. At
//! the bounce the event loop, on one thread, then only checks that it is the one foreseen, counts
//! it, moves the body on to its foreseen motion and stamp, enters its proxy made ahead, queues
//! its own events (its next wall contact was found at the window's start too, from the motion
//! after the bounce) and reports the contact worked out: no query, no pair test, no geometry.
//!
//! The window's start asks each body's wall contact once ([`Pipeline::predict_walls`]): the
//! foresight and the window's own events both read it.
//!
//! It owns that foresight and the rule that keeps it exact. A foreseen path's stamp is the
//! body's stamp at the window's start plus [`FORESEEN_STEP`]; only the foreseen bounce gives the
//! body that stamp (it moves one step, as every change does, and [`Bodies::take_foreseen`] the
//! rest), and only when the body reaches it unchanged since the window's start, at the contact
//! foreseen, and is not jammed there: its motion after the bounce and its contact are then the
//! foreseen ones to the bit, the same functions of the same motion, whichever thread worked them
//! out. A jam is handled as any contact. Any other change moves the stamp one step, which never
//! meets a foreseen one within a window: the foreseen path's predictions stay void, and the body
//! is re-tested as before. A prediction of a foreseen path can pop at the very instant of the
//! body's bounce, before the bounce (the queue orders a pair before a wall at one instant): it is
//! held, and queued again once the bounce is taken. Second and later bounces in a window are
//! re-tested as any change is. It handles no event but the foreseen bounce itself.

use super::predict::{predict_wall, wall_event};
use super::Pipeline;
use crate::bodies::{Bodies, BodyState, FORESEEN_STEP};
use crate::broad_phase::proxy::{Foreseen, ProxyTable, Span};
use crate::broad_phase::BroadPhase;
use crate::event_queue::{Event, Partner};
use crate::frame::{Contact, Mode, Output, Physics, Touched};
use crate::motion::Motion;
use crate::narrow_phase::contacts::wall_geometry;
use crate::narrow_phase::spheres::wall_contact_time;
use crate::parallel::{split_at_points, Workers};
use crate::response::impact::motion_off_wall;
use crate::response::rules::Rule;
use crate::walls::Wall;
use glam::DVec3;

/// The window's wall contacts, its foreseen bounces, and the predictions of their paths held
/// until they happen.
#[derive(Debug, Default)]
pub(super) struct ForeseenBounces {
    /// Every live body's wall contact in the window, as its start predicted it, by body.
    walls: Vec<Event>,
    /// Each body's first wall bounce of the window, by body: its contact...
    bounces: Vec<Bounce>,
    /// ... and its path after it, in the same order.
    paths: Vec<Foreseen>,
    /// Where the bounces of bodies `b << shift` on start: a look-up reads about one bounce, where
    /// a binary search of them all cost the event loop 120 instructions a bounce. About one
    /// entry a bounce (an index by body would take 4 bytes a body).
    starts: Vec<u32>,
    shift: u32,
    /// Predictions of foreseen paths that popped at their body's bounce, before it.
    held: Vec<Event>,
}

/// A foreseen bounce's wall contact, worked out at the window's start: what the event loop
/// would compute at the bounce from the body's motion then, to the bit.
#[derive(Debug, Clone, Copy)]
struct Bounce {
    body: u32,
    wall: Wall,
    time: f64,
    point: DVec3,
    normal: DVec3,
    impulse: f64,
    /// The body's next wall contact on its foreseen path, found as the event loop's would be
    /// (whether it lies in the window is told at the bounce: the window may end early).
    next_wall: Option<(f64, Wall)>,
}

impl ForeseenBounces {
    /// The foreseen paths of the window under way (none outside detect mode's plain spheres).
    pub(super) fn paths(&self) -> &[Foreseen] {
        &self.paths
    }

    /// Every live body's wall contact in the window under way, as its start predicted it, by body.
    pub(super) fn walls(&self) -> &[Event] {
        &self.walls
    }

    /// Where body `body`'s bounce lies in [`Self::bounces`] and [`Self::paths`], if it has one.
    #[inline]
    fn find(&self, body: u32) -> Option<usize> {
        let bucket = (body >> self.shift) as usize;
        let (&from, &to) = (self.starts.get(bucket)?, self.starts.get(bucket + 1)?);
        let (from, to) = (from as usize, to as usize);
        self.bounces[from..to].binary_search_by_key(&body, |b| b.body).ok().map(|k| from + k)
    }

    pub(super) fn memory_bytes(&self) -> usize {
        self.starts.capacity() * std::mem::size_of::<u32>()
            + (self.walls.capacity() + self.held.capacity()) * std::mem::size_of::<Event>()
            + self.bounces.capacity() * std::mem::size_of::<Bounce>()
            + self.paths.capacity() * std::mem::size_of::<Foreseen>()
    }
}

/// The wall of wall contact `event`, predicted at the window's start, when it is foreseen as its
/// body's bounce: a wall's (not a stalled search's), of a body whose proxy does not end at its
/// reach first (it is renewed before then).
#[inline]
fn bounce_wall(table: &ProxyTable, event: &Event) -> Option<Wall> {
    let Partner::Wall(wall) = event.partner else { return None };
    (!table.expires(event.body as usize)).then_some(wall)
}

/// Each foreseen bounce's contact and the path after it, from the window's wall contacts, on
/// every worker: each of `chunks` (the wall contacts' pass's, in order: how many contacts it
/// found and how many of them are bounces) writes its bounces in their places. Chunks of their
/// own, appended, were grown and moved again: 28-37 % more instructions on two threads than on
/// one. Out of line: a profile then tells its share apart.
#[inline(never)]
fn foresee_bounces(
    foreseen: &mut ForeseenBounces,
    chunks: &[(usize, usize)],
    bodies: &Bodies,
    table: &ProxyTable,
    physics: &Physics,
    workers: &Workers,
) {
    let total = chunks.iter().map(|&(_, bounces)| bounces).sum();
    // Every place is written below (only the places past the last window's filled first).
    let unset = Bounce {
        body: 0,
        wall: Wall::MinX,
        time: 0.0,
        point: DVec3::ZERO,
        normal: DVec3::ZERO,
        impulse: 0.0,
        next_wall: None,
    };
    foreseen.bounces.resize(total, unset);
    let unset = Foreseen { body: 0, stamp: 0, state: BodyState::default(), made: (Span::default(), 0) };
    foreseen.paths.resize(total, unset);
    let (mut points, mut sum) = (Vec::with_capacity(chunks.len()), 0);
    for &(_, bounces) in &chunks[..chunks.len() - 1] {
        sum += bounces;
        points.push(sum);
    }
    let (mut first, walls) = (0, &foreseen.walls);
    let parts: Vec<_> = split_at_points(&mut foreseen.bounces, &points)
        .into_iter()
        .zip(split_at_points(&mut foreseen.paths, &points))
        .zip(chunks)
        .map(|(places, &(found, _))| {
            first += found;
            (&walls[first - found..first], places)
        })
        .collect();
    let (bounds, restitution) = (&physics.bounds, physics.restitution);
    let (min, max) = bounds.walls();
    workers.for_each_part(parts, |_, (walls, (bounces, paths))| {
        let found = walls.iter().filter_map(|event| Some((event, bounce_wall(table, event)?)));
        for ((bounce, path), (event, wall)) in bounces.iter_mut().zip(paths).zip(found) {
            let (body, i, time) = (event.body, event.body as usize, event.time);
            let (point, normal) = wall_geometry(bodies, i, wall, bounds, time);
            let (motion, impulse) = motion_off_wall(bodies, i, wall, time, restitution);
            let radius = bodies.state[i].radius;
            // As `contacts::wall_start` finds a sphere's, from the motion the bounce gives it.
            let next_wall = wall_contact_time(&motion, radius, min, max, bodies.gravity_on(i));
            *bounce = Bounce { body, wall, time, point, normal, impulse, next_wall };
            let state = BodyState { motion, radius };
            let stamp = bodies.stamp(i).wrapping_add(FORESEEN_STEP);
            *path = Foreseen { body, stamp, state, made: table.made_ahead(i, bodies, &motion, time) };
        }
    });
    // Runs of 2^shift bodies, about as many as bounces (a power of two, so a body's is a shift).
    let shift = bodies.slots().div_ceil(total.max(1)).next_power_of_two().trailing_zeros();
    foreseen.shift = shift;
    foreseen.starts.resize((bodies.slots() >> shift) + 2, 0);
    let bounces = &foreseen.bounces;
    let run = |k: usize| bounces.get(k).map_or(usize::MAX, |b| (b.body >> shift) as usize);
    workers.chunks_mut(&mut foreseen.starts, |offset, starts| {
        let mut k = bounces.partition_point(|b| ((b.body >> shift) as usize) < offset);
        for (bucket, start) in (offset..).zip(starts) {
            while run(k) < bucket {
                k += 1;
            }
            *start = k as u32;
        }
    });
}

/// A motion's bits, to tell the foreseen one apart from any other.
fn bits(m: &Motion) -> [u64; 7] {
    let (p, v) = (m.position.to_array(), m.velocity.to_array());
    [p[0], p[1], p[2], m.since, v[0], v[1], v[2]].map(f64::to_bits)
}

impl<B: BroadPhase> Pipeline<B> {
    /// Window start, after the proxies' refresh and before the broad phase's preparation: every
    /// live body's wall contact in the window, once (the window's own events take them from
    /// [`ForeseenBounces::walls`]), then each body's first wall bounce, its contact and its path
    /// after it, on every worker. Only where a bounce is all a wall contact does to a sphere and
    /// nothing else turns one: detect mode, plain spheres on straight paths without friction, in
    /// a box without periodic faces, with a broad phase that bins such paths. A body whose proxy
    /// ends at its reach first is renewed before it bounces: it has none.
    pub(super) fn predict_walls(&mut self, bodies: &Bodies, physics: &Physics) {
        let applies = physics.mode == Mode::Detect
            && !bodies.has_rigid()
            && bodies.straight_paths()
            && physics.friction == 0.0
            && !self.proxies.has_ghosts()
            && self.broad.bins_foreseen();
        let foreseen = &mut self.foreseen;
        foreseen.walls.clear();
        foreseen.held.clear();
        let (table, window, bounds) = (&self.proxies, self.window, &physics.bounds);
        // A proxy just made that meets no wall in the window: its body has no wall contact in it.
        // Each chunk counts its bounces too, so that the bounces' pass writes them in place.
        let chunks = self.workers.extend_ranges(bodies.slots(), &mut foreseen.walls, |range, found| {
            let (before, mut bounces) = (found.len(), 0);
            for i in range.filter(|&i| table.is_live(i) && !table.meets_no_wall(i)) {
                if let Some(event) = predict_wall(bodies, table, bounds, i as u32, window) {
                    bounces += usize::from(applies && bounce_wall(table, &event).is_some());
                    found.push(event);
                }
            }
            (found.len() - before, bounces)
        });
        if applies {
            foresee_bounces(foreseen, &chunks, bodies, table, physics, &self.workers);
        } else {
            foreseen.bounces.clear();
            foreseen.paths.clear();
            foreseen.starts.clear();
        }
    }

    /// `event`, body `event.body` touching `wall`, popped current: when it is the bounce foreseen
    /// at the window's start (the body unchanged since, the same contact) and does not jam the
    /// body, the bounce as the event loop makes it, from what was worked out then: the contact
    /// counted, the body on its foreseen motion and stamp, its proxy made ahead entered, its held
    /// predictions queued again, its own events predicted, the contact reported; and true.
    /// Otherwise false, nothing done: the contact is handled as any.
    pub(super) fn take_foreseen(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        event: &Event,
        out: &mut Output,
    ) -> bool {
        let (body, t, i) = (event.body, event.time, event.body as usize);
        let Some(k) = self.foreseen.find(body) else { return false };
        let (bounce, path) = (self.foreseen.bounces[k], &self.foreseen.paths[k]);
        if bodies.stamp(i).wrapping_add(FORESEEN_STEP) != path.stamp
            || bounce.time != t
            || event.partner != Partner::Wall(bounce.wall)
            || self.impacts.rules.would_jam_alone(body, t)
        {
            return false;
        }
        // Detect mode (see `predict_walls`): no TC model (its contact duration is 0 there) and
        // no resting, so the rule is the world's restitution, the one the foresight took.
        let rule = self.impacts.rules.wall(body, t, physics.restitution, 0.0);
        debug_assert_eq!(rule, Rule::Impulse { restitution: physics.restitution, changed: false });
        bodies.set_velocity_at(i, t, path.state.motion.velocity);
        debug_assert_eq!(bits(&bodies.motion(i)), bits(&path.state.motion), "not as foreseen");
        bodies.take_foreseen(i);
        self.proxies.enter_made(i, bodies, path.made);
        // This body's held predictions only: another's wait for its own bounce. Mostly none
        // are held, and a look costs less than `retain`'s set-up (16 instructions a bounce).
        if !self.foreseen.held.is_empty() {
            let queue = &mut self.queue;
            self.foreseen.held.retain(|event| {
                let of_body = event.body == body || event.partner == Partner::Body(body);
                if of_body {
                    queue.push(*event);
                }
                !of_body
            });
        }
        self.updates += 1;
        out.stats.retests += 1;
        // Its own events, its next wall contact worked out at the window's start.
        let window = self.window.from(t);
        let found = || bounce.next_wall.filter(|&(time, _)| window.contains(time)).map(Ok);
        let wall = wall_event(&self.proxies, (body, bodies.stamp(i)), window, found);
        debug_assert_eq!(wall, predict_wall(bodies, &self.proxies, &physics.bounds, body, window));
        self.push_own_events(body, wall, bodies, physics, window);
        out.contacts.push(Contact {
            time: t,
            body: bodies.handle(i),
            touched: Touched::Wall(bounce.wall),
            point: bounce.point,
            normal: bounce.normal,
            impulse: bounce.impulse,
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
