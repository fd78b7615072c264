//! What the pipeline predicts into its queue: a pair's contact (or its end) from the proxies a
//! broad phase reported, a body's contact with the walls and the static geometry, its crossing of
//! a periodic face and its proxy's renewal, each as an event stamped with the motions it was
//! predicted from.
//!
//! It owns how a reported pair is tested: as the lower id's motion against the higher id's, the
//! latter shifted by whole sides when the pair meets across periodic faces, so the same contact
//! reported twice (through either body's ghost) is the same event, which the queue pops once. It
//! never schedules or handles an event.

use crate::bodies::{Bodies, BodyState};
use crate::broad_phase::proxy::{Proxies, ProxyTable, Reported};
use crate::broad_phase::PairScreen;
use crate::event_queue::{Event, Partner};
use crate::motion::Motion;
use crate::narrow_phase::contacts::{self, Parking};
use crate::narrow_phase::parked::ParkedSearches;
use crate::narrow_phase::spheres::{
    straight_pair_contact_time_past_screen, straight_pair_contact_times_four, straight_paths_clearly_miss,
    straight_paths_clearly_miss_four, wall_contact_time,
};
use crate::narrow_phase::static_geometry::StaticGeometry;
use crate::walls::{BoxBounds, Wall};
use crate::window::Window;
use glam::DVec3;

/// The end of the contact of bodies `a` and `b`, touching since `since`, if its canonical time
/// lies in `window`, stamped with their current stamps: a velocity change of either voids it.
#[inline]
pub(super) fn predict_end(bodies: &Bodies, a: u32, b: u32, since: f64, window: Window) -> Option<Event> {
    let (a, b) = (a.min(b), a.max(b));
    let (i, j) = (a as usize, b as usize);
    let (time, stalled) = contacts::pair_end(bodies, i, j, since, window)?;
    Some(Event {
        time,
        body: a,
        partner: if stalled { Partner::Stalled(b) } else { Partner::End(b) },
        body_stamp: bodies.stamp(i),
        partner_stamp: bodies.stamp(j),
    })
}

/// The contact of two reported proxies if its canonical time lies in `window`, from the motions
/// the broad phase reported (the bodies' own), stamped with the stamps of the motions they came
/// from: a prediction made from a proxy not yet refreshed after a velocity change is void when
/// it pops. Across a periodic face (a ghost reported) it is the lower id's own motion against the
/// higher id's shifted by the difference of the two shifts: the same arithmetic through whichever
/// ghost the pair was reported (see [`crate::broad_phase::ghosts`]). Always inlined into the pair
/// sweeps and re-tests that call it for every candidate pair.
#[inline(always)]
pub(super) fn predict_pair(
    bodies: &Bodies,
    proxies: &ProxyTable,
    x: Reported,
    y: Reported,
    window: Window,
) -> Option<Event> {
    let ((a, shift_a), (b, shift_b)) = resolved(proxies, x, y)?;
    sphere_event(bodies, (a, shift_a), (b, shift_b), window)
}

/// [`predict_pair`] of two proxies that are their bodies' own (a box without periodic faces has
/// no ghosts): the same arithmetic, without looking up owners.
#[inline(always)]
pub(super) fn predict_own_pair(bodies: &Bodies, x: Reported, y: Reported, window: Window) -> Option<Event> {
    // Always the lower id first, as `resolved` orders them.
    let (a, b) = if x.body < y.body { (x, y) } else { (y, x) };
    if a.body == b.body {
        return None;
    }
    sphere_event(bodies, (a, None), (b, None), window)
}

/// The exact test's first screen for spheres on straight paths ([`straight_paths_clearly_miss`]),
/// for a broad phase's sweep to ask of its candidates, four at a time where it can.
pub(super) struct StraightSpheres;

impl PairScreen for StraightSpheres {
    /// The pair's contact time ([`straight_pair_contact_time_past_screen`]), whichever body
    /// comes first (the offset and relative velocity of `b, a` are those of `a, b` negated,
    /// exactly, which no square, product of two or comparison with zero sees).
    type Kept = f64;

    #[inline(always)]
    fn clears(&self, a: &BodyState, b: &BodyState) -> bool {
        straight_paths_clearly_miss(&a.motion, &b.motion, a.radius + b.radius)
    }

    #[inline(always)]
    fn kept(&self, a: &BodyState, b: &BodyState, window: Window) -> Option<f64> {
        straight_pair_contact_time_past_screen(&a.motion, &b.motion, a.radius + b.radius)
            .filter(|&time| window.contains(time))
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn clears_four_avx(&self, a: [&BodyState; 4], b: [&BodyState; 4]) -> u32 {
        // SAFETY: the caller's.
        unsafe { straight_paths_clearly_miss_four(a, b) }
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn kept_four_avx(
        &self,
        a: [&BodyState; 4],
        b: [&BodyState; 4],
        windows: [std::arch::x86_64::__m256d; 2],
    ) -> (u32, [f64; 4]) {
        // SAFETY: the caller's.
        unsafe { straight_pair_contact_times_four(a, b, windows) }
    }
}

/// The event of two spheres on straight paths whose contact time is `time`, in their window
/// (what [`StraightSpheres`] keeps of them, which asked the window already): the lower id first,
/// the stamps.
#[inline(always)]
pub(super) fn straight_sphere_event_at(x: Reported, y: Reported, time: f64) -> Event {
    let (a, b) = if x.body < y.body { (x, y) } else { (y, x) };
    debug_assert!(a.body != b.body, "a body reported against itself");
    pair_event((a.body, a.stamp), (b.body, b.stamp), (time, false))
}

/// Pushes `event`, if any: not `out.extend(event)`, which reserves room for it even when there is
/// none, as for most candidate pairs and most bodies' wall contacts, at a dozen instructions each.
#[inline(always)]
pub(super) fn push_found(out: &mut Vec<Event>, event: Option<Event>) {
    if let Some(event) = event {
        out.push(event);
    }
}

/// A report as the body it is of, with the stamp its motion was made with and, for a ghost, the
/// whole sides its state is shifted by.
type Resolved<'a> = (Reported<'a>, Option<DVec3>);

/// Two reports as the bodies they are of ([`Resolved`]), the lower id first; `None` for a ghost
/// retired since it was entered, or a body against its own image.
#[inline(always)]
fn resolved<'a>(proxies: &ProxyTable, x: Reported<'a>, y: Reported<'a>) -> Option<(Resolved<'a>, Resolved<'a>)> {
    let own = |r: Reported<'a>| {
        let (body, stamp, shift) = proxies.owner(r.body, r.stamp)?;
        Some((Reported { body, stamp, state: r.state }, shift))
    };
    let (x, y) = (own(x)?, own(y)?);
    // Always the lower id first, so every method does bit-identical arithmetic for a pair.
    let (a, b) = if x.0.body < y.0.body { (x, y) } else { (y, x) };
    (a.0.body != b.0.body).then_some((a, b))
}

/// [`predict_pair`] of two resolved spheres (or any two bodies, by their shapes' search, but
/// without parking it).
#[inline(always)]
fn sphere_event(bodies: &Bodies, (a, shift_a): Resolved, (b, shift_b): Resolved, window: Window) -> Option<Event> {
    let (i, j) = (a.body as usize, b.body as usize);
    let found = if shift_a.is_none() && shift_b.is_none() {
        contacts::pair_start(bodies, (i, a.state), (j, b.state), window)?
    } else {
        // Two ghosts of one shift are the bodies themselves.
        let shift = relative_shift(shift_a, shift_b);
        let mut image = bodies.state[j];
        if shift != DVec3::ZERO {
            image.motion.position += shift;
        }
        contacts::pair_start(bodies, (i, &bodies.state[i]), (j, &image), window)?
    };
    Some(pair_event((a.body, a.stamp), (b.body, b.stamp), found))
}

/// The whole sides the second of two reports is shifted by relative to the first: zero for two
/// ghosts of one shift (the bodies themselves), each own slot counting as unshifted.
#[inline]
fn relative_shift(shift_a: Option<DVec3>, shift_b: Option<DVec3>) -> DVec3 {
    if shift_a == shift_b {
        return DVec3::ZERO;
    }
    shift_b.unwrap_or(DVec3::ZERO) - shift_a.unwrap_or(DVec3::ZERO)
}

/// What predicting a pair in a world of shapes gives: an event for the queue, or where a shape
/// search parked, for [`ParkedSearches`]. Kept unboxed: the predictions' vector is reused from
/// frame to frame, and a box would allocate per parked search.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub(super) enum Prediction {
    Event(Event),
    Parked(Parking),
}

/// [`predict_pair`] in a world of shapes: a shape pair's search taken up where `parked` holds it,
/// with where it parks now handed to `park`.
#[inline]
pub(super) fn predict_pair_parked(
    bodies: &Bodies,
    proxies: &ProxyTable,
    (x, y, window): (Reported, Reported, Window),
    parked: &ParkedSearches,
    park: impl FnOnce(Parking),
) -> Option<Event> {
    let ((a, shift_a), (b, shift_b)) = resolved(proxies, x, y)?;
    let (i, j) = (a.body as usize, b.body as usize);
    if bodies.are_spheres(i, j) {
        return sphere_event(bodies, (a, shift_a), (b, shift_b), window);
    }
    let shift = relative_shift(shift_a, shift_b);
    let found = contacts::pair_start_parked(bodies, (i, j, shift), window, Some(parked), park);
    found.map(|found| pair_event((a.body, a.stamp), (b.body, b.stamp), found))
}

/// [`predict_pair_parked`] for `(x, y, window)` into `out`, for [`sort_predictions`].
#[inline]
pub(super) fn predict_into(
    bodies: &Bodies,
    proxies: &ProxyTable,
    (x, y, window): (Reported, Reported, Window),
    parked: &ParkedSearches,
    out: &mut Vec<Prediction>,
) {
    // A pair's parked search goes in before its event: the two go to different stores.
    let event =
        predict_pair_parked(bodies, proxies, (x, y, window), parked, |parks| out.push(Prediction::Parked(parks)));
    out.extend(event.map(Prediction::Event));
}

/// Empties `found` in its order: each event to `event`, each parked search into `parked` (pairs
/// not searched since `window_start` are dropped from the store).
pub(super) fn sort_predictions(
    found: &mut Vec<Prediction>,
    parked: &mut ParkedSearches,
    window_start: f64,
    mut event: impl FnMut(Event),
) {
    for prediction in found.drain(..) {
        match prediction {
            Prediction::Event(e) => event(e),
            Prediction::Parked(((a, b), epochs, resume)) => parked.keep(a, b, epochs, resume, window_start),
        }
    }
}

/// The event of bodies `a < b` (each with its stamp) starting to touch, or of their search
/// stalling, at the time found.
#[inline]
pub(super) fn pair_event((a, stamp_a): (u32, u32), (b, stamp_b): (u32, u32), (time, stalled): (f64, bool)) -> Event {
    let partner = if stalled { Partner::Stalled(b) } else { Partner::Body(b) };
    Event { time, body: a, partner, body_stamp: stamp_a, partner_stamp: stamp_b }
}

/// Calls `found` with body `i`'s contact with every static body its proxy's box meets, inside
/// the proxy's window and `window`. Static bodies have no proxy; their stamps never change.
#[inline]
pub(super) fn for_each_static_event(
    bodies: &Bodies,
    proxies: Proxies,
    statics: &StaticGeometry,
    i: usize,
    window: Window,
    mut found: impl FnMut(Event),
) {
    if statics.is_empty() {
        return;
    }
    let (low, high) = proxies.bbox(i).corners();
    let window = proxies.window_of(i).intersect(window);
    let own = proxies.reported(i);
    statics.for_each_near(proxies.box_min() + low, proxies.box_min() + high, |s| {
        let fixed = Reported { body: s, stamp: bodies.stamp(s as usize), state: &bodies.state[s as usize] };
        if let Some(event) = predict_pair(bodies, &proxies, own, fixed, window) {
            found(event);
        }
    });
}

/// The renewal of body `body`'s proxy at its end.
#[inline]
pub(super) fn renewal(bodies: &Bodies, proxies: &ProxyTable, body: u32) -> Event {
    let i = body as usize;
    Event {
        time: proxies.window_of(i).end,
        body,
        partner: Partner::Renew,
        body_stamp: bodies.stamp(i),
        partner_stamp: 0,
    }
}

/// Body `body`'s wall contact if its canonical time lies in `window` (or where an undecided
/// search stalled); `proxies` holds the body's proxy, made from its current motion.
#[inline]
pub(super) fn predict_wall(
    bodies: &Bodies,
    proxies: &ProxyTable,
    bounds: &BoxBounds,
    body: u32,
    window: Window,
) -> Option<Event> {
    let i = body as usize;
    wall_event(proxies, (body, bodies.stamp(i)), window, || contacts::wall_start(bodies, i, bounds, window))
}

/// [`predict_wall`] of body `body` (stamped as given) whose first wall contact in `window`, as
/// [`contacts::wall_start`] finds it, is `start`'s: asked only when the proxy does not tell.
#[inline]
pub(super) fn wall_event(
    proxies: &ProxyTable,
    (body, stamp): (u32, u32),
    window: Window,
    start: impl FnOnce() -> Option<Result<(f64, Wall), f64>>,
) -> Option<Event> {
    // Its proxy, just made from this motion, found the wall contact past the window's end.
    if proxies.meets_no_wall(body as usize) && !(window.end > proxies.window().end) {
        return None;
    }
    let (time, partner) = match start()? {
        Ok((time, wall)) => (time, Partner::Wall(wall)),
        Err(time) => (time, Partner::WallStalled),
    };
    Some(Event { time, body, partner, body_stamp: stamp, partner_stamp: 0 })
}

/// Body `body`'s crossing of a periodic face of `bounds` if its canonical time lies in `window`:
/// when its centre reaches the face (the body then comes back through the opposite one).
#[inline]
pub(crate) fn predict_crossing(bodies: &Bodies, bounds: &BoxBounds, body: u32, window: Window) -> Option<Event> {
    // Asked of every body at every window start: a walled box answers before reading the body.
    if !bounds.is_periodic() {
        return None;
    }
    let i = body as usize;
    crossing_event((body, bodies.stamp(i)), &bodies.motion(i), bodies.gravity_on(i), bounds.faces(), window)
}

/// [`predict_crossing`] of body `body` (stamped as given) on `motion` under `gravity`, in a box
/// whose periodic faces are `(low, high)` ([`BoxBounds::faces`] of a periodic box, read once by
/// the caller): a motion the store may not hold yet.
#[inline]
pub(crate) fn crossing_event(
    (body, stamp): (u32, u32),
    motion: &Motion,
    gravity: DVec3,
    (low, high): (DVec3, DVec3),
    window: Window,
) -> Option<Event> {
    let (time, face) = wall_contact_time(motion, 0.0, low, high, gravity)?;
    let event = Event { time, body, partner: Partner::Cross(face), body_stamp: stamp, partner_stamp: 0 };
    window.contains(time).then_some(event)
}

/// [`predict_wall`] of a sphere `body` (stamped as given) of `state` under `gravity`: a motion the
/// store may not hold yet.
#[inline]
pub(crate) fn sphere_wall_event(
    (body, stamp): (u32, u32),
    state: &BodyState,
    gravity: DVec3,
    bounds: &BoxBounds,
    window: Window,
) -> Option<Event> {
    let walls = bounds.walls();
    let (time, wall) = wall_contact_time(&state.motion, state.radius, walls.0, walls.1, gravity)?;
    let event = Event { time, body, partner: Partner::Wall(wall), body_stamp: stamp, partner_stamp: 0 };
    window.contains(time).then_some(event)
}
