//! The proxy table: what the broad phase knows of each body, in flat arrays indexed by body id.
//!
//! A proxy bounds one body over the rest of the current broad-phase window: its straight motion
//! from `start` (the window's start, or the instant the body last changed velocity) until `end`,
//! the window's end or, when sooner, the instant the body reaches a wall (where its velocity
//! changes and it gets a fresh proxy) or has travelled its `reach` (then the pipeline renews the
//! proxy at its end), its bounding radius and its swept box. Ending at the wall keeps every path
//! inside the box, and the reach keeps a fast body's proxy local, however fast it is: a body
//! that will soon hit another never pays for the rest of its path. It is the only thing a broad
//! phase reads, so broad phases know nothing of shapes: a body of any shape is bounded by the
//! sphere about its centre that contains it. The table holds no motion of its own: a proxy's
//! motion is the body's (the store's `BodyState`, one cache line), which a broad phase
//! reads through [`Proxies`]; a body's stamp changes whenever its motion does, so an entry made
//! from an older motion is stale and its predictions void. The table never decides what is a
//! candidate and never moves a body; the pipeline refreshes every proxy at a window's start and
//! a body's proxy when it changes velocity.
//!
//! In a box with periodic axes a proxy ends where its body's centre crosses a periodic face (the
//! body then comes back through the opposite face, on a fresh motion), proxies near the faces get
//! ghosts, their images across the faces, in slots past the bodies' (`broad_phase::ghosts`), and
//! no proxy covers more than the ghost width allows: a broad phase reads a ghost as one more proxy.

use crate::bodies::{Bodies, BodyState, FORESEEN_STEP};
use crate::broad_phase::ghosts::Ghosts;
use crate::memory::prefetch;
use crate::motion::Motion;
use crate::narrow_phase::spheres::wall_contact_time;
use crate::parallel::Workers;
use crate::walls::BoxBounds;
use crate::window::Window;
use glam::DVec3;

/// Relative padding of swept boxes, far above the rounding of a position update, so a box always
/// holds its body whichever instant the body's position is computed from.
pub const RELATIVE_PADDING: f64 = 1e-12;

/// A body as a broad phase reports it: its id, the stamp of the proxy the report comes from, and
/// the body's motion and radius as of that proxy. A broad phase may keep its own copy of the
/// state next to its other data, so the narrow phase reads it without a trip to memory.
#[derive(Debug, Clone, Copy)]
pub struct Reported<'a> {
    pub body: u32,
    pub stamp: u32,
    pub state: &'a BodyState,
}

/// A proxy's straight path as a broad phase cuts it into pieces: the centre and velocity at its
/// start, its bounding radius, its window and its swept box.
#[derive(Debug, Clone, Copy)]
pub struct Path {
    pub origin: DVec3,
    pub velocity: DVec3,
    pub radius: f64,
    pub window: Window,
    pub bbox: CompactBox,
}

/// A body's path after its first wall bounce of the window, foreseen at the window's start (see
/// `pipeline::foreseen`): the stamp it will have if it takes that bounce (its stamp then plus
/// `bodies::FORESEEN_STEP`), its motion and radius after it, and the proxy and flags it then gets.
#[derive(Debug, Clone, Copy)]
pub struct Foreseen {
    pub body: u32,
    pub stamp: u32,
    pub state: BodyState,
    pub made: (Span, u8),
}

/// Where and when a proxy bounds its body: over `[start, end)`, inside `bbox`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Span {
    pub start: f64,
    pub end: f64,
    /// Swept box over `[start, end]`, padded, relative to [`ProxyTable::box_min`].
    pub bbox: CompactBox,
}

/// Flat table of proxies, arrays by body id: the spans, the liveness and expiry flags, and the
/// stamps that a broad phase checks for every entry it passes, kept dense so that check stays in
/// cache. The motions are the bodies' own: a broad phase reads the table through [`Proxies`],
/// which pairs it with them.
#[derive(Debug, Default, Clone)]
pub struct ProxyTable {
    /// The broad-phase window every proxy lies in.
    window: Window,
    /// The box the bodies live in.
    bounds: BoxBounds,
    /// Longest path a proxy may cover before it must be renewed, in typical diameters.
    reach: f64,
    /// Median bounding radius of the live bodies at the window's start.
    typical_radius: f64,
    /// Few proxies are expected to change within the window (see [`Self::calm`]).
    calm: bool,
    pub spans: Vec<Span>,
    /// The body's velocity stamp when its proxy was built: broad-phase entries carrying another
    /// stamp are stale.
    stamps: Vec<u32>,
    /// False for removed bodies and bodies not entered yet.
    live: Vec<bool>,
    /// Per proxy, [`EXPIRES`] when it ends before the window because of its reach (it must be
    /// renewed) and [`NO_WALL`] when its body meets no wall before the window's end. Kept out of
    /// the spans, which they would pad by 8 bytes.
    flags: Vec<u8>,
    /// Scratch for the median radius (a sample).
    radii: Vec<f64>,
    /// The bodies' uniform acceleration, and how far a path may bend off its tangent within a
    /// proxy: every proxy is the straight path from its start along its velocity there, its
    /// radius widened by this bend, and lasts no longer than the bend allows. Broad phases thus
    /// see straight paths whatever the gravity (0 and no limit without it).
    gravity: DVec3,
    bend: f64,
    /// The periodic images of the proxies near periodic faces, and the largest bounding radius
    /// of the live bodies at the window's start, which the ghost width is sized for.
    ghosts: Ghosts,
    largest_radius: f64,
}

/// A box in single precision relative to an origin, rounded outwards: it only ever grows, so it
/// stays conservative, and it takes half the room of a double-precision one — a broad phase keeps
/// it next to its entries for a cheap overlap test.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CompactBox {
    pub low: [f32; 3],
    pub high: [f32; 3],
}

impl CompactBox {
    /// The box `[low, high]` relative to `origin`.
    #[inline]
    pub fn new(low: DVec3, high: DVec3, origin: DVec3) -> CompactBox {
        let (low, high) = (low - origin, high - origin);
        CompactBox { low: [down(low.x), down(low.y), down(low.z)], high: [up(high.x), up(high.y), up(high.z)] }
    }

    /// Branch-free overlap test.
    #[inline]
    pub fn overlaps(&self, other: &CompactBox) -> bool {
        (self.low[0] <= other.high[0])
            & (other.low[0] <= self.high[0])
            & (self.low[1] <= other.high[1])
            & (other.low[1] <= self.high[1])
            & (self.low[2] <= other.high[2])
            & (other.low[2] <= self.high[2])
    }

    /// The corners back in double precision, relative to the origin.
    #[inline]
    pub fn corners(&self) -> (DVec3, DVec3) {
        let wide = |c: [f32; 3]| DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        (wide(self.low), wide(self.high))
    }

    /// The largest side.
    #[inline]
    pub fn extent(&self) -> f64 {
        let (low, high) = self.corners();
        (high - low).max_element()
    }
}

/// `x` in single precision, rounded down (up): `x as f32` stepped one ulp down (up) when it
/// rounded the wrong way, the step made on the bits without a branch (it is as likely as not for
/// every coordinate of every box, so a branch would mispredict half the time). The step is the
/// one `f32::next_down` (`next_up`) takes on the values it can meet: a negative value's bits go
/// up, a positive one's (and infinity's) down; zero and NaN never step the other way.
#[inline]
fn down(x: f64) -> f32 {
    let f = x as f32;
    let sign = (f.to_bits() >> 31) as i32;
    let step = i32::from(f as f64 > x) * (2 * sign - 1);
    f32::from_bits(f.to_bits().wrapping_add_signed(step))
}
#[inline]
fn up(x: f64) -> f32 {
    let f = x as f32;
    let sign = (f.to_bits() >> 31) as i32;
    let step = i32::from((f as f64) < x) * (1 - 2 * sign);
    f32::from_bits(f.to_bits().wrapping_add_signed(step))
}

/// Proxy flags: it ends before the window because of its reach; its body meets no wall in the window.
const EXPIRES: u8 = 1;
const NO_WALL: u8 = 2;

/// Most values [`sampled_quantile`] looks at.
const QUANTILE_SAMPLE: usize = 4096;

/// The `q`-quantile (0 the least, 1 the largest) of the values `value(i)` gives for the slots
/// `i < slots` (`None`: no value, e.g. a free slot), from an evenly strided sample of at most a
/// few thousand slots: a typical size needs no scratch as large as the bodies. The same slots are
/// sampled whatever the number of threads. `None` when the sample holds no value.
///
/// ```
/// use vadop::broad_phase::proxy::sampled_quantile;
/// let mut scratch = Vec::new();
/// let value = |i: usize| (i % 2 == 0).then_some(i as f64);
/// assert_eq!(sampled_quantile(10, 0.5, value, &mut scratch), Some(4.0));
/// assert_eq!(sampled_quantile(10, 0.0, value, &mut scratch), Some(0.0));
/// ```
pub fn sampled_quantile(
    slots: usize,
    q: f64,
    value: impl Fn(usize) -> Option<f64>,
    scratch: &mut Vec<f64>,
) -> Option<f64> {
    scratch.clear();
    let stride = slots.div_ceil(QUANTILE_SAMPLE).max(1);
    scratch.extend((0..slots).step_by(stride).filter_map(&value));
    if scratch.is_empty() {
        // A sparse table whose sampled slots hold no value: look at every slot.
        scratch.extend((0..slots).filter_map(&value));
    }
    let k = ((scratch.len() as f64 * q) as usize).min(scratch.len().saturating_sub(1));
    (!scratch.is_empty()).then(|| *scratch.select_nth_unstable_by(k, f64::total_cmp).1)
}

/// Swept box of a sphere of `radius` moving from `a` to `b`, padded for rounding.
#[inline]
pub fn swept_box(a: DVec3, b: DVec3, radius: f64) -> (DVec3, DVec3) {
    let pad = radius + RELATIVE_PADDING * (a.abs().max(b.abs()).max_element() + radius);
    (a.min(b) - pad, a.max(b) + pad)
}

impl ProxyTable {
    /// An empty table for bodies in the box `bounds`.
    pub fn new(bounds: &BoxBounds) -> ProxyTable {
        ProxyTable {
            bounds: *bounds,
            reach: f64::INFINITY,
            ghosts: Ghosts::new(bounds.periodic_part()),
            ..ProxyTable::default()
        }
    }

    /// Sets how far a proxy may reach, in typical diameters (infinity: to the window's end).
    pub fn set_reach_diameters(&mut self, diameters: f64) {
        self.reach = diameters;
    }

    /// Says whether few proxies are expected to change within the window (bodies that rarely
    /// change velocity), as the pipeline measured over the last one.
    pub fn set_calm(&mut self, calm: bool) {
        self.calm = calm;
    }

    /// True when few proxies are expected to change within the window: a broad phase may then
    /// make its window start cheaper at the price of dearer mid-window re-tests.
    #[inline]
    pub fn calm(&self) -> bool {
        self.calm
    }

    /// Median bounding radius of the live bodies at the window's start: the length scale the
    /// broad phases size their cells and pieces by.
    #[inline]
    pub fn typical_radius(&self) -> f64 {
        self.typical_radius
    }

    /// The corner of the box the bodies live in: the origin of compact boxes.
    #[inline]
    pub fn box_min(&self) -> DVec3 {
        self.bounds.min
    }

    /// A swept box of a sphere of `radius` from `a` to `b` as a compact box relative to
    /// [`Self::box_min`].
    #[inline]
    pub fn compact_swept_box(&self, a: DVec3, b: DVec3, radius: f64) -> CompactBox {
        let (low, high) = swept_box(a, b, radius);
        CompactBox::new(low, high, self.bounds.min)
    }

    /// The current window.
    #[inline]
    pub fn window(&self) -> Window {
        self.window
    }

    /// Number of slots (live or not).
    #[inline]
    pub fn slots(&self) -> usize {
        self.spans.len()
    }

    /// True in a box with periodic faces, where proxies may be ghosts (see [`Self::owner`]).
    #[inline]
    pub fn has_ghosts(&self) -> bool {
        self.ghosts.active()
    }

    /// Number of the bodies' slots (live or not), ghosts' left out.
    #[inline]
    pub fn body_slots(&self) -> usize {
        self.spans.len().min(self.ghosts.base())
    }

    /// The window proxy `i` bounds its body over.
    #[inline]
    pub fn window_of(&self, i: usize) -> Window {
        Window::new(self.spans[i].start, self.spans[i].end)
    }

    /// Proxy `i`'s swept box.
    #[inline]
    pub fn bbox(&self, i: usize) -> CompactBox {
        self.spans[i].bbox
    }

    /// The velocity stamp proxy `i` was built with.
    #[inline]
    pub fn stamp(&self, i: usize) -> u32 {
        self.stamps[i]
    }

    /// True when proxy `i` ends before the window because of its reach.
    #[inline]
    pub fn expires(&self, i: usize) -> bool {
        self.flags[i] & EXPIRES != 0
    }

    /// True when proxy `i`'s body, on the motion the proxy was made from, meets no wall before
    /// the window's end: its wall contact, computed once with the proxy, need not be predicted
    /// again (false when unknown, e.g. for a shape, whose proxy does not stop at walls).
    #[inline]
    pub fn meets_no_wall(&self, i: usize) -> bool {
        self.flags[i] & NO_WALL != 0
    }

    /// True when body `i` has a proxy.
    #[inline]
    pub fn is_live(&self, i: usize) -> bool {
        self.live.get(i).copied().unwrap_or(false)
    }

    /// How many of the first `slots` slots (the bodies': the ghosts' follow) are live: one pass
    /// over the flags, which the compiler vectorises (a window's start asks it, on one thread,
    /// where a look per slot cost 4 instructions a body).
    pub fn live_count(&self, slots: usize) -> usize {
        // Summed as bytes, 255 at most at a time so a byte's sum cannot wrap: a loop of vector
        // additions rather than a test and an increment per slot.
        let live = &self.live[..slots.min(self.live.len())];
        live.chunks(255).map(|chunk| chunk.iter().fold(0u8, |sum, &live| sum + u8::from(live)) as usize).sum()
    }

    /// True when a broad-phase entry of body `i` made with `stamp` is current. One load: a
    /// removed body's stamp has moved on (see [`Self::remove`]), so liveness needs no check of
    /// its own, and a query's stale-entry test costs one memory access instead of two. An entry
    /// of a ghost slot the table no longer holds (one of an earlier window) is stale.
    #[inline]
    pub fn is_current(&self, i: usize, stamp: u32) -> bool {
        self.stamps.get(i) == Some(&stamp)
    }

    /// True when a broad-phase entry of body `i` made with `stamp` is of the path it will take
    /// after a foreseen bounce (see [`Foreseen`]) it has not taken yet, nor missed.
    #[inline]
    pub fn is_foreseen(&self, i: usize, stamp: u32) -> bool {
        self.stamps.get(i).is_some_and(|&now| now.wrapping_add(FORESEEN_STEP) == stamp)
    }

    /// Asks for the cache line of body `i`'s stamp ahead of an [`Self::is_current`] check.
    #[inline(always)]
    pub fn prefetch_stamp(&self, i: usize) {
        if let Some(stamp) = self.stamps.get(i) {
            prefetch(stamp);
        }
    }

    /// The table paired with `bodies`, the bodies its proxies bound, for a broad phase to read.
    #[inline]
    pub fn view<'a>(&'a self, bodies: &'a Bodies) -> Proxies<'a> {
        Proxies { table: self, bodies }
    }

    /// Window start: every live body's proxy over `window`, bodies at their positions at its
    /// start; shared among `workers`.
    pub fn refresh_all(&mut self, bodies: &Bodies, window: Window, workers: &Workers) {
        self.window = window;
        // The last window's ghosts are gone: their slots are handed out afresh below.
        self.truncate(bodies.slots());
        self.resize(bodies.slots());
        let live = &self.live;
        if self.ghosts.active() {
            self.largest_radius =
                (0..bodies.slots()).filter(|&i| live[i]).map(|i| bodies.bounding_radius(i)).fold(0.0, f64::max);
        }
        if let Some(median) =
            sampled_quantile(bodies.slots(), 0.5, |i| live[i].then(|| bodies.bounding_radius(i)), &mut self.radii)
        {
            self.typical_radius = median;
        }
        // A quarter of a typical radius: proxies a little wider, and renewed only after the time
        // it takes gravity to bend a path that far (about 0.1 s for unit spheres under 9.81).
        self.gravity = bodies.gravity;
        self.bend = if self.gravity == DVec3::ZERO { 0.0 } else { 0.25 * self.typical_radius };
        if self.ghosts.active() {
            self.ghosts.clear(bodies.slots());
        }
        let rule = self.rule();
        // Without gravity every body moves straight: the proxy's arithmetic is the same with the
        // pull known to be zero, and the compiler then drops its every test of the pull (with the
        // wall test in line below, 29 % of the refresh's instructions at n = 10^5, 5 d/f).
        let straight = bodies.straight_paths();
        workers.zip_chunks(&mut self.spans, &mut self.flags, |offset, spans, flags| {
            if straight {
                // From the rule's own window start, so `span_under`'s `t.max(window.start)` is
                // `x.max(x)`, which the compiler folds to `x` (its bits, NaN included): the same
                // start without the NaN-faithful `max` (8 instructions a body).
                rule.fill(offset, spans, flags, live, |i| {
                    let motion = &bodies.state[i].motion;
                    rule.span_under(i, bodies, motion, rule.window.start, DVec3::ZERO)
                });
            } else {
                rule.fill(offset, spans, flags, live, |i| rule.span(i, bodies, window.start));
            }
        });
        // A removed body's stamp moved on at its removal, so its entries stay stale.
        for (stamp, tag) in self.stamps.iter_mut().zip(&bodies.tags) {
            *stamp = tag.stamp;
        }
        if self.ghosts.active() {
            for i in 0..bodies.slots() {
                if self.live[i] {
                    self.make_ghosts(i, bodies);
                }
            }
        }
    }

    /// Enters body `i` (added, or changed velocity at time `t`) with its motion from `t` on,
    /// with fresh ghosts (see [`Self::slots_of`]).
    pub fn enter(&mut self, i: usize, bodies: &Bodies, t: f64) {
        let made = self.rule().span(i, bodies, t);
        self.enter_made(i, bodies, made);
    }

    /// Counts body `i` among the live ones without a proxy yet: added when no window is under
    /// way, it gets its proxy and ghosts with every other body's at the next window's start (see
    /// [`Self::refresh_all`]). Entered now, a body of a periodic box could fall past the ended
    /// window's ghost slots or be wider than its ghosts were sized for.
    pub fn admit(&mut self, i: usize, bodies: &Bodies) {
        self.resize(bodies.slots());
        self.live[i] = true;
    }

    /// The proxy and flags body `i` would get on entering at `t` with `motion` instead of its
    /// own, to the bit: what [`Self::enter_made`] takes once the body moves so.
    pub fn made_ahead(&self, i: usize, bodies: &Bodies, motion: &Motion, t: f64) -> (Span, u8) {
        self.rule().span_of(i, bodies, motion, t)
    }

    /// [`Self::enter`] with the proxy and flags [`Self::made_ahead`] made for the body's motion.
    /// Always inline: a call costs [`Self::enter`] 60 instructions of passing the proxy.
    #[inline(always)]
    pub fn enter_made(&mut self, i: usize, bodies: &Bodies, (span, flags): (Span, u8)) {
        debug_assert!(self.fits(i, bodies), "a body the window's ghosts are not sized for");
        self.resize(bodies.slots());
        (self.spans[i], self.flags[i]) = (span, flags);
        self.stamps[i] = bodies.stamp(i);
        self.live[i] = true;
        if self.ghosts.active() {
            self.retire_ghosts(i);
            self.make_ghosts(i, bodies);
        }
    }

    /// Drops body `i` (removed): its broad-phase entries become stale, for its stamp moves on.
    pub fn remove(&mut self, i: usize) {
        if let Some(live) = self.live.get_mut(i) {
            *live = false;
            self.stamps[i] = self.stamps[i].wrapping_add(1);
            self.retire_ghosts(i);
        }
    }

    /// True when body `i` may enter the window under way: always, but in a periodic box a body
    /// in a slot past the window's ghost base, or wider than the bodies its ghost width was sized
    /// for, needs a new window.
    pub fn fits(&self, i: usize, bodies: &Bodies) -> bool {
        !self.ghosts.active() || (i < self.ghosts.base() && bodies.bounding_radius(i) <= self.largest_radius)
    }

    /// Body `i`'s proxy slot and its ghosts' (none outside a periodic box): each is entered
    /// into the broad phase and meets its own partners.
    #[inline]
    pub fn slots_of(&self, i: usize) -> impl Iterator<Item = usize> {
        std::iter::once(i).chain(self.ghosts.of(i))
    }

    /// The body a report from slot `slot` is of, the stamp of the motion its state was made
    /// from, and, for a ghost, the whole sides its state is shifted by (never zero; `None` for
    /// the body's own slot, so the common case compares no vector); `None` for a ghost retired
    /// since `stamp` was entered.
    #[inline]
    pub fn owner(&self, slot: u32, stamp: u32) -> Option<(u32, u32, Option<DVec3>)> {
        let k = slot as usize;
        if k < self.ghosts.base() {
            return Some((slot, stamp, None));
        }
        if !self.is_current(k, stamp) {
            return None;
        }
        let (body, stamp, shift) = self.ghosts.owner(k);
        Some((body, stamp, Some(shift)))
    }

    /// Body `i`'s ghosts from its proxy, into fresh slots.
    fn make_ghosts(&mut self, i: usize, bodies: &Bodies) {
        let (spans, stamps, live, flags) = (&mut self.spans, &mut self.stamps, &mut self.live, &mut self.flags);
        let own = spans[i];
        let (low, high) = own.bbox.corners();
        self.ghosts.make(i, (low, high), &bodies.state[i], bodies.stamp(i), |shift, stamp| {
            spans.push(Span { bbox: CompactBox::new(low + shift, high + shift, DVec3::ZERO), ..own });
            stamps.push(stamp);
            live.push(true);
            flags.push(0);
        });
    }

    /// Body `i`'s ghosts leave: their slots' entries become stale.
    fn retire_ghosts(&mut self, i: usize) {
        for slot in self.ghosts.of(i) {
            self.live[slot] = false;
            self.stamps[slot] = self.ghosts.fresh_stamp();
        }
        self.ghosts.forget(i);
    }

    /// What a proxy is made by, copied so workers can share it.
    fn rule(&self) -> ProxyRule {
        let mut reach = 2.0 * self.typical_radius * self.reach;
        if self.ghosts.active() {
            reach = reach.min(self.ghosts.longest_path(self.largest_radius + self.bend));
        }
        ProxyRule {
            window: self.window,
            box_min: self.bounds.min,
            walls: self.bounds.walls(),
            faces: self.bounds.is_periodic().then(|| self.bounds.faces()),
            reach,
            bend: self.bend,
            // Within a proxy the path stays within the bend of its tangent: |g| tau^2 / 2 <= bend.
            longest: if self.bend > 0.0 { (2.0 * self.bend / self.gravity.length()).sqrt() } else { f64::INFINITY },
        }
    }

    /// Drops every slot from `slots` on: the ghosts' of the last window.
    fn truncate(&mut self, slots: usize) {
        self.spans.truncate(slots);
        self.stamps.truncate(slots);
        self.live.truncate(slots);
        self.flags.truncate(slots);
    }

    fn resize(&mut self, slots: usize) {
        if self.spans.len() < slots {
            self.spans.resize(slots, Span::default());
            self.stamps.resize(slots, 0);
            self.live.resize(slots, false);
            self.flags.resize(slots, 0);
        }
    }

    /// Bytes held (capacity).
    pub fn memory_bytes(&self) -> usize {
        self.spans.capacity() * std::mem::size_of::<Span>()
            + self.stamps.capacity() * 4
            + self.live.capacity()
            + self.flags.capacity()
            + self.radii.capacity() * 8
            + self.ghosts.memory_bytes()
    }
}

/// What a broad phase reads: the proxy table together with the bodies' states its proxies bound.
/// A copyable view, built by the pipeline for each call ([`ProxyTable::view`]); the table's own
/// accessors are reached through it.
#[derive(Debug, Clone, Copy)]
pub struct Proxies<'a> {
    table: &'a ProxyTable,
    bodies: &'a Bodies,
}

impl std::ops::Deref for Proxies<'_> {
    type Target = ProxyTable;
    fn deref(&self) -> &ProxyTable {
        self.table
    }
}

impl<'a> Proxies<'a> {
    /// Proxy `i`'s motion and bounding radius: its body's, or a ghost's (shifted by whole sides).
    #[inline]
    pub fn state(&self, i: usize) -> &'a BodyState {
        if i < self.table.ghosts.base() {
            &self.bodies.state[i]
        } else {
            self.table.ghosts.state(i)
        }
    }

    /// Proxy `i` as a broad phase reports it from this table.
    #[inline]
    pub fn reported(&self, i: usize) -> Reported<'a> {
        Reported { body: i as u32, stamp: self.table.stamp(i), state: self.state(i) }
    }

    /// Bounding radius of proxy `i`: the body's, widened by the bend gravity may give its path
    /// within the proxy.
    #[inline]
    pub fn radius(&self, i: usize) -> f64 {
        self.state(i).radius + self.table.bend
    }

    /// Velocity of proxy `i` at its start.
    #[inline]
    pub fn velocity(&self, i: usize) -> DVec3 {
        self.origin_and_velocity(i).1
    }

    /// Centre of proxy `i` at its start.
    #[inline]
    pub fn origin(&self, i: usize) -> DVec3 {
        self.origin_and_velocity(i).0
    }

    /// Centre and velocity of proxy `i` at its start, from one read of its motion: what cutting
    /// a path into pieces needs for every proxy at a window's start.
    #[inline(always)]
    pub fn origin_and_velocity(&self, i: usize) -> (DVec3, DVec3) {
        self.origin_and_velocity_known(i, self.pull_free())
    }

    /// True when the table's bodies move under no pull: every proxy's path is its motion's own.
    #[inline(always)]
    pub fn pull_free(&self) -> bool {
        self.table.gravity == DVec3::ZERO
    }

    /// [`Self::origin_and_velocity`] where `pull_free` is [`Self::pull_free`], asked once by a
    /// pass over every proxy rather than once a proxy (three loads and comparisons each time).
    #[inline(always)]
    fn origin_and_velocity_known(&self, i: usize, pull_free: bool) -> (DVec3, DVec3) {
        let (motion, start) = (&self.state(i).motion, self.table.spans[i].start);
        // Without gravity, the straight path's own arithmetic (`at_under`'s, to the bit), the
        // pull not tested again.
        if pull_free {
            return (motion.at(start), motion.velocity);
        }
        let gravity = self.gravity_on(i);
        (motion.at_under(start, gravity), motion.velocity_under(start, gravity))
    }

    /// Proxy `i`'s path.
    #[inline(always)]
    pub fn path(&self, i: usize) -> Path {
        self.path_known(i, self.pull_free())
    }

    /// [`Self::path`] where `pull_free` is [`Self::pull_free`], asked once by a pass over every
    /// proxy.
    #[inline(always)]
    pub fn path_known(&self, i: usize, pull_free: bool) -> Path {
        let (origin, velocity) = self.origin_and_velocity_known(i, pull_free);
        Path { origin, velocity, radius: self.radius(i), window: self.window_of(i), bbox: self.bbox(i) }
    }

    /// The path of body `i` (a body's own slot) over `span` with the motion and radius `state`
    /// (see [`ProxyTable::made_ahead`]).
    pub fn path_ahead(&self, i: usize, state: &BodyState, span: &Span) -> Path {
        let gravity = self.gravity_on(i);
        let (motion, start) = (&state.motion, span.start);
        Path {
            origin: motion.at_under(start, gravity),
            velocity: motion.velocity_under(start, gravity),
            radius: state.radius + self.table.bend,
            window: Window::new(span.start, span.end),
            bbox: span.bbox,
        }
    }

    /// The acceleration proxy `i`'s body moves under (a ghost's is its owner's). Always inline:
    /// cutting every path at a window's start asks it (a call there costs 20 instructions a body).
    #[inline(always)]
    fn gravity_on(&self, i: usize) -> DVec3 {
        if self.table.gravity == DVec3::ZERO {
            return DVec3::ZERO;
        }
        let body = if i < self.table.ghosts.base() { i } else { self.table.ghosts.owner(i).0 as usize };
        self.bodies.gravity_on(body)
    }
}

/// The settings a proxy is built with.
#[derive(Debug, Clone, Copy)]
struct ProxyRule {
    window: Window,
    box_min: DVec3,
    /// The walls (at infinity on periodic axes) and, in a periodic box, the periodic faces (at
    /// infinity on walled axes).
    walls: (DVec3, DVec3),
    faces: Option<(DVec3, DVec3)>,
    /// Longest path a proxy may cover.
    reach: f64,
    /// How far a path may bend off its tangent within a proxy, and the longest a proxy may last
    /// for that (infinite without gravity).
    bend: f64,
    longest: f64,
}

impl ProxyRule {
    /// Body `i`'s proxy from time `t` on, and its flags: [`EXPIRES`] when it ends because of its
    /// reach, [`NO_WALL`] when the body meets no wall before the window's end.
    #[inline(always)]
    fn span(&self, i: usize, bodies: &Bodies, t: f64) -> (Span, u8) {
        self.span_of(i, bodies, &bodies.motion(i), t)
    }

    /// [`Self::span`] of body `i` on `motion` rather than its own.
    #[inline(always)]
    fn span_of(&self, i: usize, bodies: &Bodies, motion: &Motion, t: f64) -> (Span, u8) {
        self.span_under(i, bodies, motion, t, bodies.gravity_on(i))
    }

    /// The spans and flags of the live ones of the proxies `offset..offset + spans.len()`, each
    /// from `made(i)`.
    #[inline(always)]
    fn fill(
        &self,
        offset: usize,
        spans: &mut [Span],
        flags: &mut [u8],
        live: &[bool],
        made: impl Fn(usize) -> (Span, u8),
    ) {
        let live = &live[offset..offset + spans.len()];
        for (k, ((span, flags), &live)) in spans.iter_mut().zip(flags).zip(live).enumerate() {
            if live {
                (*span, *flags) = made(offset + k);
            }
        }
    }

    /// [`Self::span_of`] under the pull `gravity`, the one body `i` moves under.
    #[inline(always)]
    fn span_under(&self, i: usize, bodies: &Bodies, motion: &Motion, t: f64, gravity: DVec3) -> (Span, u8) {
        let start = t.max(self.window.start);
        let velocity = motion.velocity_under(start, gravity);
        let body_radius = bodies.bounding_radius(i);
        // A body at rest, or sliding under a pull its floor takes whole, moves straight: its
        // proxy needs no bend and lasts as long as a straight one.
        let (bend, longest) = if gravity == DVec3::ZERO { (0.0, f64::INFINITY) } else { (self.bend, self.longest) };
        let radius = body_radius + bend;
        // Up to and including the wall contact: a pair touching at that very instant is still
        // found with the motion before the bounce, whichever of the two events comes first. A
        // body of another shape reaches the walls later than its bounding sphere: its proxy goes
        // on to the window's end, and its own wall contact changes its velocity.
        // Tested in line rather than through `bool::then`'s closure, which stayed a call and kept
        // the zero pull of a straight path from folding into the wall test.
        let sphere = bodies.is_sphere(i);
        let wall =
            if sphere { wall_contact_time(motion, body_radius, self.walls.0, self.walls.1, gravity) } else { None };
        // Up to and including the crossing of a periodic face too, where the body comes back
        // through the opposite face on a fresh motion.
        let crossing = self.faces.and_then(|(low, high)| wall_contact_time(motion, 0.0, low, high, gravity));
        let first = match (wall, crossing) {
            (Some((a, _)), Some((b, _))) => Some(a.min(b)),
            (a, b) => a.or(b).map(|(t, _)| t),
        };
        let mut end = match first {
            Some(time) if time < self.window.end => time.max(start).next_up().min(self.window.end),
            _ => self.window.end,
        };
        let ahead = start + self.reach / velocity.length();
        let longest = (gravity != DVec3::ZERO).then_some(longest);
        let expires = if let Some(reached) = reach_expiry(ahead, start, end, longest) {
            end = reached;
            true
        } else {
            false
        };
        let origin = motion.at_under(start, gravity);
        let (low, high) = swept_box(origin, origin + velocity * (end - start), radius);
        let bbox = CompactBox::new(low, high, self.box_min);
        // The very time the wall prediction would compute (same motion, radius and pull, the
        // body's own), so a wall contact at or past the window's end is known to be none of this
        // window's.
        let no_wall = sphere && wall.is_none_or(|(time, _)| !(time < self.window.end));
        (Span { start, end, bbox }, (u8::from(expires) * EXPIRES) | (u8::from(no_wall) * NO_WALL))
    }
}

/// When a proxy from `start` to `end` expires by its reach, strictly between the two: at the
/// reach's end `ahead`, or under a pull at `start + longest` if that comes first (`longest`
/// `None` without a pull). Without a pull `longest` would be infinite, and `min(start + inf)`
/// would only turn a NaN `ahead` into infinity (or, from a start at -inf, leave it): values the
/// comparisons read alike (never before `end`, never past `start`), so the NaN-faithful `min` is
/// left out there (8 instructions a body).
#[inline(always)]
fn reach_expiry(ahead: f64, start: f64, end: f64, longest: Option<f64>) -> Option<f64> {
    let reached = match longest {
        Some(longest) => ahead.min(start + longest),
        None => ahead,
    };
    (reached < end && reached > start).then_some(reached)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without a pull, `reach_expiry` (`span_under`'s) takes the reach's end as it is where it
    /// would take its `min` with `start + inf`: the same flag and end for every start, reach end and end, NaN and
    /// infinities included (a NaN reach end is 0 / 0: a body at rest with no reach).
    #[test]
    fn an_infinite_longest_changes_no_expiry() {
        let values = [0.0, -0.0, 1.0, -1.0, 0.5, 1e300, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        for (start, ahead, end) in
            values.iter().flat_map(|&s| values.iter().flat_map(move |&a| values.map(|e| (s, a, e))))
        {
            let with_min = reach_expiry(ahead, start, end, Some(f64::INFINITY));
            let without = reach_expiry(ahead, start, end, None);
            let (with_min, without) = (with_min.map(f64::to_bits), without.map(f64::to_bits));
            assert_eq!(with_min, without, "{start} {ahead} {end}");
        }
    }

    /// The branch-free steps give the bits of `next_down` and `next_up` on every kind of value.
    #[test]
    fn rounding_outwards_matches_next_down_and_next_up() {
        let plain_down = |x: f64| if x as f32 as f64 > x { (x as f32).next_down() } else { x as f32 };
        let plain_up = |x: f64| if ((x as f32) as f64) < x { (x as f32).next_up() } else { x as f32 };
        let mut values = vec![0.0, -0.0, 1e-50, -1e-50, 1e300, -1e300, f64::INFINITY, f64::NEG_INFINITY, f64::NAN];
        values.extend([f32::MAX as f64, f32::MIN_POSITIVE as f64, 1.0 + 1e-12, -1.0 - 1e-12, 0.1, -0.1, 3.4e38]);
        let mut state = 0x2545f4914f6cdd1du64;
        for _ in 0..100_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let unit = (state >> 11) as f64 / (1u64 << 53) as f64;
            values.push((unit - 0.5) * 10f64.powi((state % 90) as i32 - 45));
        }
        for x in values {
            assert_eq!(down(x).to_bits(), plain_down(x).to_bits(), "down({x:e})");
            assert_eq!(up(x).to_bits(), plain_up(x).to_bits(), "up({x:e})");
            if x.is_finite() {
                assert!(down(x) as f64 <= x && up(x) as f64 >= x, "{x:e}");
            }
        }
    }
}
