//! Shape narrow phase: the first contact of two shapes under rigid motion, or of a shape and a
//! wall of the box, by conservative advancement over parry's distance queries.
//!
//! It owns the motion interface ([`Spin`], [`RigidMotion`]), the contact-time arithmetic for
//! non-spherical shapes and its tolerance, and nothing else: like [`crate::narrow_phase::spheres`] it
//! never sees the world, the broad phase or the queue, and it never moves a body. Sphere pairs
//! keep their closed form in [`crate::narrow_phase::spheres`]; this module serves every pair with a
//! non-spherical or static-only shape (a sphere pair works here too, only slower).
//!
//! # Motion
//!
//! Between velocity changes a body's centre of mass moves in a straight line,
//! `p(t) = position + (t - since) * velocity`, and its orientation (which rotates body-frame
//! vectors to world vectors, see [`crate::shape`]) is `spin.orientation_at(t - since)`; the spin
//! also bounds the angular speed for all time. A static body is a [`RigidMotion`] with zero
//! velocity and the [`Fixed`](crate::motion::Fixed) spin; static-only shapes must not turn.
//!
//! # Bounding volumes first
//!
//! Each solid lies in a sphere of its bounding radius about its centre of mass, and the centres
//! move in straight lines: the closed forms of [`crate::narrow_phase::spheres`] give the one interval of
//! time in which the two spheres, grown by `2 tol` (see below), overlap. Outside it the shapes are
//! more than `2 tol` apart: neither touching nor in contact. Against a half-space the sphere's
//! height above the plane, and against a mesh the sphere against the mesh's box, give the
//! interval alike. A pair whose interval misses the window costs no distance evaluation; any
//! other is searched from the interval's start (the reference when it lies inside) and known
//! apart, for good, from its end. Most candidate pairs of the broad phase never come that close.
//!
//! # Conservative advancement
//!
//! At a time t, let d be a lower bound on the distance of the shapes obtained as their
//! separation along a fixed unit axis n from a to b (`min over b of n.y - max over a of n.x`).
//! That separation cannot shrink faster than
//! `mu = (v_a - v_b) . n + w_a r_a + w_b r_b`,
//! w being a body's angular speed bound and r how far its core (below) reaches from the centre of
//! mass: its bounding radius, a capsule's half height, 0 for a sphere, whose surface does not move
//! when it turns. So the distance stays above `tol/2` until `t + (d - tol/2) / mu`, and the
//! search steps there, less the margins below: on bounds tightened to decide, the steps are at
//! least `(tol/4) / mu` long (`(5/24) tol / mu` on a warm start's). Where `mu <= 0` (two solids
//! leaving each other along n faster than turning can close it) no contact ever follows: this
//! also ends the search at the probe that ends a contact of two solids passing through each other
//! at speed. Against a triangle mesh, whose nearest triangle may change, `mu` uses `|v_a - v_b|`
//! instead of the projection; against a half-space or a wall, n is the fixed plane normal, the
//! separation along it is the exact signed distance, and `mu` takes the projection's positive
//! part only.
//!
//! A spinning solid never leaves its bounding sphere, so far from contact a fast spinner is also
//! stepped on its sphere's separation from the other shape (or from the other's sphere, a plane
//! or a wall), which its spin cannot shrink: the longer of the two steps is taken, and the
//! approach costs what the straight motion needs, whatever the spin.
//!
//! Where spins dominate `mu` the steps are short and the bodies turn little between two probes:
//! each probe of two solids (or of a solid and each mesh triangle the last probe measured) first
//! tries the last one's axis, turned with either shape (a face normal turns with its face), and
//! its witness points, carried along with the shapes. Any axis still gives a lower bound and any
//! two points of the shapes an upper bound; when they lie within half the room above `tol/2` of
//! each other, the step on them goes at least two thirds as far as on exact bounds, and GJK is not
//! needed.
//!
//! A probe against a mesh measures only the triangles that may be the nearest: one whose lower
//! bound at an earlier probe, less how far the body's points can have moved since (at `|v_a -
//! v_b|` plus the spin's), or whose plane's separation from the body, is above the smallest upper
//! bound met so far can neither hold the smallest lower bound nor lower the upper one.
//!
//! Inside a contact, while the search looks for its end, only an upper bound on the signed
//! distance steps it (the distance must stay below `2 tol` until the end), and far from the end
//! the last full measure's witness points, carried along, give one with no search: their
//! distance, or, where a point lies inside both shapes, minus how deep it lies in each (a ball
//! that deep about it lies in each shape, and two shapes holding such balls about one point must
//! move the sum of their radii apart to part). Shapes passing through each other in detect mode
//! are then followed with closed-form depths of the points in each solid, and GJK and EPA run
//! only a hair from the contact's start and end. Each such probe also says how long the contact
//! certainly lasts from balls fixed in the two bodies (`inner_balls`): the balls about that
//! point, about each shape's middle, and wider ones deeper in each shape, whose centres move
//! with the bodies along the pair's actual direction (a worst-case rate only for turning, times
//! a centre's distance from its centre of mass); the step is the longer of that and the one on
//! the rate bound.
//!
//! Steps on a rate bound shrink with the room left: a contact's end (or start) approached so
//! takes a probe or two per halving of the depth, however fast the pair actually parts, some
//! fifty for a tumbling pair. Where the spins give their angular velocities and a bound on the
//! angular acceleration (the exact torque-free rotation does), each probe also predicts the
//! motion to first order and bounds the rest (`chord`): within a contact a point fixed in either
//! body, followed through the other's signed distance, which is convex, so that along the
//! predicted line it stays below the larger of its ends (the chord); before one, the separation
//! along the probe's axis turned with either body, the other's support along it convex in the
//! turned direction. Each step goes as far as its certificate keeps the distance on its side of
//! the band the search is crossing, aiming at the band's middle, so that the probe it lands on
//! mostly decides: a few probes per contact start and end, by the pair's actual rate of
//! separation, sliding along flat or round surfaces included.
//!
//! The bounds never rest on GJK's own accuracy. The lower bound is a separation along an axis,
//! computed from the shapes' exact support functions: any axis gives a valid bound, and GJK (and,
//! a hair from contact, where GJK's simplices grow ill-conditioned and its directions drift, the
//! shapes' face normals, edge cross products and a local climb of the separation) only choose a
//! tight one. The upper bound is the distance between two points of the shapes (closest points
//! from closed forms or GJK, or each shape's extreme point projected on the other, and back and
//! forth), or EPA's depth when they intersect (EPA's polytope lies inside the Minkowski
//! difference). Near contact the bounds are tightened until their gap is half the search's
//! margin (below), enough to decide. Everything runs in lengths scaled by an exact power of two
//! near the pair's size, so parry's absolute tolerances act alike at every scale, and a scene
//! scaled by a power of two gives bit-identical times.
//!
//! A ball is the set of points within its radius of its centre, a capsule within its radius of
//! its segment: their *cores*; any other solid is its own core. Two shapes are as far apart as
//! their cores less the radii, and between points and segments, or a point and a solid (parry's
//! projections), that distance has closed forms, exact to rounding where GJK would converge
//! slowly on the round surfaces. GJK and EPA, where still needed, run on the cores, and on the
//! shapes themselves too where the shapes' distance is a small part of the cores' (their
//! precision is relative to the distance they measure); either can fail a hair from contact, and
//! the tighter bounds count.
//!
//! # Tolerance: the contract
//!
//! Two shapes *touch* when their distance is at most
//! `tol = SHAPE_CONTACT_TOLERANCE * (r_a + r_b)` ([`contact_tolerance`]; r the bounding radii, a
//! static-only shape counting 0; against the walls `SHAPE_CONTACT_TOLERANCE * r`). The relative
//! tolerance is 1e-6, not the spheres' 1e-9: see [`SHAPE_CONTACT_TOLERANCE`].
//!
//! * A reported contact start has distance at most `tol`, and from the reference on (outside the
//!   earlier contacts of the same motions) the distance stays above `tol/2` at every time before
//!   it: no contact is missed, whatever the speeds, sizes or spins.
//! * A contact lasts while the signed distance (negative when penetrating) stays at most
//!   `2 tol`, and *ends* at a time where it is above `tol`. A pair may touch several times on one
//!   motion (spinning shapes, detect mode): the k-th contact start is searched from the end of
//!   the (k-1)-th, and a window gets the first contact *start* it contains.
//! * At the reference instant itself, a touching pair is a new contact only if it is
//!   approaching: if, before it separates beyond `tol`, it goes on to penetrate past `tol`, or
//!   `tol/8` deeper than it is where it is deeper than `7/8 tol` already. (A pair just resolved in
//!   simulate mode separates: its next contact is a new one.) So a pair pressed together (each
//!   velocity change of either body a new reference) cannot sink past `tol` without a contact
//!   that turns it back, nor further than `tol/8` per reference once a rule has left it there. A
//!   pair already deeper than `tol` is a contact in progress where bodies pass through each
//!   other (detect mode), as for spheres; where contacts turn them back (simulate mode, static
//!   geometry, the walls) depth does not matter: a rule that stops bodies touching may leave
//!   them that deep, and they must not then pass into each other. Such a pair that the search
//!   cannot decide (it neither goes deeper nor parts) stalls at the reference, where it was
//!   found touching, so that the jam rule stops it there and not deeper, stall after stall.
//!
//! The search works a little inside the band: it stops at `(1 - 1/8) tol` and keeps the
//! distance above `(1 + 1/8) tol/2`, so that an independent oracle (parry's own distance query)
//! agrees with the contract.
//!
//! # Canonical times
//!
//! Every search starts from the reference instant `max(a.since, b.since)` (the wall search from
//! `since`), or from where the bounding volumes first come within reach, and every iterate is a
//! function of the two motions and of the time since the reference only (each probe starts from
//! what the one before found), never of the window asked about: every caller, window or method
//! gets the same time to the bit. A search stops once past the window's end and *parks* there
//! ([`Resume`]: the next probe's time, the warm start, the budget spent): a later window of the
//! same motions takes the chain up where it parked ([`shape_contact_resumed`]) and makes the very
//! iterates a search from the reference would, without replaying them, so a pair that stays in
//! reach for many windows costs what its motion needs once. The chain starts afresh at every contact start and end it finds
//! (a cold probe, a fresh budget, the time since the reference derived from the absolute time),
//! so what follows a contact start depends on that start alone: a caller holding it resumes the
//! chain there ([`shape_contact_after`], [`contact_end_time`]) without replaying the contacts
//! before it, and a spinner that touches a body thousands of times on one motion costs what its
//! contacts need, not the square of their number. The pair is
//! ordered: the world passes it in a fixed order (lower body id first), as (a, b) and (b, a) may
//! differ in the last bits.
//!
//! # Termination guard
//!
//! A search that has not decided after [`MAX_ITERATIONS`] distance evaluations since the chain
//! last started afresh (a pair resting or sliding in contact while turning, skimming along a hair
//! apart for a long time, or a fast spinner's long approach), whose step falls below the
//! resolution of time, or whose distance bounds are too loose to step, returns
//! [`VadopError::ContactSearchStalled`] with the time up to which no contact starts: it never
//! silently drops a contact. The world then starts the bodies' motions afresh from that time and
//! searches on, unless they touch there (simulate mode then applies the jam rule).

mod chord;
mod distance;
mod epa;
mod fixed_gauges;
mod gauges;
mod gjk;
mod inner_balls;
mod parting;
mod reach;
mod scaled;
mod searcher;
mod walls;

use crate::error::{Result, VadopError};
use crate::motion::{RigidMotion, Spin};
use crate::numeric::unit_scale;
use crate::shape::ShapeGeometry;
use crate::window::Window;
use distance::{Bounds, Need, EXACT_DEPTH};
use fixed_gauges::{MeshPair, PlanePair};
use gauges::{ConvexPair, Gauge, PairGauge, Warm};
use glam::{DQuat, DVec3};
use parry3d_f64::shape::SupportMap;
use reach::spheres_reach;
use scaled::Body;
use searcher::{Parked, Searcher};
use std::cell::{Cell, RefCell};
pub(crate) use walls::walls_in_reach;
pub use walls::{shape_wall_search, shape_wall_time, wall_contact_geometry};

/// Where and how two shapes (or a shape and a wall) touch at a contact time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactPoint {
    /// World point halfway between the two closest (or deepest) points.
    pub point: DVec3,
    /// Unit normal from the first body to the second (for a wall: out of the box).
    pub normal: DVec3,
    /// Signed distance, negative when penetrating.
    pub distance: f64,
}

/// A contact search's answer together with the number of distance evaluations it took (what
/// [`MAX_ITERATIONS`] caps between two restarts of its chain).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Search<T> {
    /// What the search found, if anything.
    pub found: Option<T>,
    /// Distance evaluations (probes) it took.
    pub iterations: u32,
}

/// A search's chain parked where it stopped without finding a contact start, so that a later
/// search of the same two motions takes it up there instead of replaying it
/// from the reference: the same iterates follow, so the same times, to the bit (see *Canonical
/// times* in the [module documentation](self)). Valid for a window that starts at or after
/// [`Resume::searched_to`]; the caller keeps it with the motions it was made on, and drops it
/// when either changes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resume {
    /// The chain's reference instant: a resume of other motions is ignored.
    reference: f64,
    searched_to: f64,
    parked: Parked,
    /// Probes since the chain last started afresh (its budget so far).
    spent: u32,
    warm: Option<Warm>,
}

impl Resume {
    /// No contact starts on the chain before this time (the end of the window searched).
    pub fn searched_to(&self) -> f64 {
        self.searched_to
    }

    /// A chain parked for good, searched to `searched_to`: a value for the store's tests.
    #[cfg(test)]
    pub(crate) fn done_at(searched_to: f64) -> Resume {
        Resume { reference: 0.0, searched_to, parked: Parked::DONE, spent: 0, warm: None }
    }

    /// Where `searcher` parked after finding nothing before `searched_to`; `None` when it did
    /// not park (it never probed, or found something) or its gauge's warm start cannot be kept.
    fn of<G: Gauge>(searcher: &Searcher<G>, searched_to: f64) -> Option<Resume> {
        let parked = searcher.parked?;
        let warm = searcher.gauge.warm_start()?;
        let spent = searcher.iterations - searcher.restarted;
        Some(Resume { reference: searcher.reference, searched_to, parked, spent, warm })
    }

    /// The first contact start in `window` on `searcher`'s chain, taken up from `resume` when it
    /// was parked on the same chain before `window` starts, searched from the reference
    /// otherwise; with where the chain parks when it finds none.
    fn first_start<G: Gauge>(
        searcher: &mut Searcher<G>,
        resume: Option<&Resume>,
        window: Window,
        deep_is_contact: bool,
    ) -> Result<(Option<f64>, Option<Resume>)> {
        let found = match resume.filter(|r| r.reference == searcher.reference && r.searched_to <= window.start) {
            Some(r) => {
                searcher.gauge.set_warm_start(r.warm);
                searcher.resume(r.parked, r.spent, window)?
            }
            None => searcher.first_start_in(window, deep_is_contact)?,
        };
        let parked = if found.is_none() { Resume::of(searcher, window.end) } else { None };
        Ok((found.map(|tau| searcher.reference + tau), parked))
    }
}

/// Cap on the distance evaluations of one search between two restarts of its chain (the
/// reference, a contact start or end); see the module doc. Low enough that a resting contact that
/// stalls costs little before the jam rule takes it; a search out of budget in free space loses
/// nothing, the world goes on from where it stopped.
pub const MAX_ITERATIONS: u32 = 10_000;

/// Cap on the distance evaluations that decide whether a pair touching at the reference goes
/// deeper or parts: one that does neither for this long rests or slides in contact, which the
/// world hands to the jam rule (a pair that merely grazes decides in a few dozen).
pub const RESTING_BUDGET: u32 = 500;

/// Relative tolerance on the distance within which two shapes count as touching, times the sum
/// of their bounding radii.
///
/// It is larger than the spheres' [`crate::narrow_phase::spheres::CONTACT_TOLERANCE`] (1e-9), which lies
/// below what parry's GJK and EPA resolve: measured on every pair of solid kinds placed at known
/// distances, a hair from contact parry's closest points are off by up to several times the
/// distance at 1e-9 of the pair's size (and GJK calls some such pairs intersecting), by up to 20%
/// at 1e-8, and agree with the exact distance to within 1% from 1e-7 on, with the bounds of this
/// module. The band `(tol/2, tol]` starts ten times above that.
pub const SHAPE_CONTACT_TOLERANCE: f64 = 1e-6;

/// Relative margin inside the tolerance band: the search stops at `(1 - MARGIN) tol` and keeps
/// the distance above `(1 + MARGIN) tol/2` (a contact ends above `(1 + MARGIN) tol` and stays
/// below `(1 - MARGIN) 2 tol`), so that an independent distance oracle (parry's own query, with
/// its own convergence threshold) agrees with the contract.
const MARGIN: f64 = 0.125;

/// Relative rounding allowance on support points and closest points, times the size of the
/// coordinates involved.
const SLACK: f64 = 64.0 * f64::EPSILON;

/// The distance a search keeps above until a contact starts: `tol/2` plus the margin.
fn guard(tol: f64) -> f64 {
    0.5 * tol * (1.0 + MARGIN)
}

/// Above this a contact has ended: `tol` plus the margin.
fn cleared(tol: f64) -> f64 {
    tol * (1.0 + MARGIN)
}

/// The signed distance a contact is kept below until it ends: `2 tol` less the margin.
fn ceiling(tol: f64) -> f64 {
    2.0 * tol * (1.0 - MARGIN)
}

/// The middle of the band in which a contact starts: between `tol/2` plus the margin (the
/// distance is kept above it) and `tol` less the margin (at most it, a contact starts).
fn starting(tol: f64) -> f64 {
    0.5 * (guard(tol) + tol * (1.0 - MARGIN))
}

/// The middle of the band in which a contact ends: between `tol` plus the margin (above it the
/// contact has ended) and `2 tol` less the margin (below it the contact lasts).
fn ending(tol: f64) -> f64 {
    0.5 * (cleared(tol) + ceiling(tol))
}

/// The distance within which two shapes count as touching: [`SHAPE_CONTACT_TOLERANCE`] times the
/// sum of their bounding radii (a static-only shape counts 0).
///
/// ```
/// use glam::DVec3;
/// use vadop::shape::Shape;
/// use vadop::narrow_phase::shapes::contact_tolerance;
/// let ball = Shape::Sphere { radius: 2.0 }.geometry().unwrap();
/// let floor = Shape::HalfSpace { normal: DVec3::Y }.geometry().unwrap();
/// assert!((contact_tolerance(&ball, &floor) - 2e-6).abs() < 1e-15);
/// ```
pub fn contact_tolerance(a: &ShapeGeometry, b: &ShapeGeometry) -> f64 {
    SHAPE_CONTACT_TOLERANCE * (a.size() + b.size())
}

/// The searcher of a pair, or `None` for two static-only shapes (which never meet).
fn pair_searcher<'a, S: Spin, T: Spin>(
    a: (&'a ShapeGeometry, &'a RigidMotion<S>),
    b: (&'a ShapeGeometry, &'a RigidMotion<T>),
) -> Result<Option<Searcher<PairGauge<'a>>>> {
    let reference = a.1.since.max(b.1.since);
    let motions = (a.1, b.1);
    let (a, b) = (Body::new(a.0, a.1, reference), Body::new(b.0, b.1, reference));
    let size = a.geometry.size() + b.geometry.size();
    let stall = |reason| VadopError::ContactSearchStalled { time: reference, iterations: 0, reason };
    if !(size > 0.0) {
        return Ok(None);
    }
    for body in [&a, &b] {
        if body.geometry.is_static_only() && body.spin.max_angular_speed() != 0.0 {
            return Err(stall("a static-only shape (mesh or half-space) must not turn: give it a spin bounded by 0"));
        }
    }
    let scale = unit_scale(size);
    let tol = SHAPE_CONTACT_TOLERANCE * size * scale;
    let spin = (a.spin_rate() + b.spin_rate()) * scale;
    if !spin.is_finite() {
        return Err(stall("the angular speed bound is not finite"));
    }
    let gauge = match (a.geometry.is_static_only(), b.geometry.is_static_only()) {
        (false, false) => {
            let shapes = (a.support(scale), b.support(scale));
            let (offset, velocity, acceleration) = relative_motion(motions, reference, scale);
            PairGauge::Convex(ConvexPair {
                middles: (shapes.0.middle_ball(), shapes.1.middle_ball()),
                shapes,
                offset,
                velocity,
                acceleration,
                a,
                b,
                scale,
                spin,
                size: size * scale,
                tol,
                warm: RefCell::new(None),
                measured: Cell::new(None),
            })
        }
        (first_static, _) => {
            let (body, fixed) = if first_static { (b, a) } else { (a, b) };
            let offset = (body.position - fixed.position) * scale;
            let velocity = (body.velocity - fixed.velocity) * scale;
            let acceleration = (body.acceleration - fixed.acceleration) * scale;
            let parry = fixed.geometry.parry_shape();
            if let Some(half_space) = parry.as_halfspace() {
                let normal = half_space.normal;
                let size = size * scale;
                let pair = PlanePair { body, plane: fixed, normal, scale, offset, velocity, acceleration, size };
                PairGauge::Plane(pair, first_static)
            } else {
                let trimesh = parry.as_trimesh().expect("static-only shapes are half-spaces or meshes");
                let pair = MeshPair {
                    body,
                    mesh: fixed,
                    trimesh,
                    scale,
                    offset,
                    velocity,
                    acceleration,
                    spin,
                    size: size * scale,
                    tol,
                    measures: RefCell::default(),
                };
                PairGauge::Mesh(pair, first_static)
            }
        }
    };
    Ok(Some(Searcher::new(gauge, reference, tol)))
}

/// The first time in `window` (half-open `[start, end)`) at which two shapes begin to touch,
/// canonical (see the [module documentation](self) for the tolerance and the rules), with the
/// number of distance evaluations it took.
pub fn shape_contact_search<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    window: Window,
) -> Result<Search<f64>> {
    Ok(shape_contact_resumed(a, b, window, None)?.0)
}

/// [`shape_contact_search`] taking up the chain where `resume` parked it (by an earlier search
/// of the same motions), with where the chain parks when no contact starts in `window`: what a
/// caller keeps to search a later window of the same motions without replaying this one. The
/// answer is the same, to the bit, with or without `resume`.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::narrow_phase::shapes::{shape_contact_resumed, shape_contact_time};
/// use vadop::motion::RigidMotion;
/// use vadop::Window;
/// let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
/// let a = RigidMotion::fixed(DVec3::ZERO, DQuat::IDENTITY, 0.0);
/// let b = RigidMotion { velocity: DVec3::new(-0.25, 0.0, 0.0), ..RigidMotion::fixed(DVec3::new(3.0, 0.0, 0.0), DQuat::IDENTITY, 0.0) };
/// // Window after window, each search taking up where the last one parked.
/// let (mut resume, mut found) = (None, None);
/// for k in 0..10 {
///     let window = Window::new(k as f64, k as f64 + 1.0);
///     let (search, parked) = shape_contact_resumed((&cube, &a), (&cube, &b), window, resume.as_ref()).unwrap();
///     assert_eq!(search.found, shape_contact_time((&cube, &a), (&cube, &b), window).unwrap());
///     found = found.or(search.found);
///     resume = parked;
/// }
/// assert!((found.unwrap() - 8.0).abs() < 1e-5);
/// ```
pub fn shape_contact_resumed<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    window: Window,
    resume: Option<&Resume>,
) -> Result<(Search<f64>, Option<Resume>)> {
    pair_first_start(a, b, window, resume, false)
}

/// b's centre of mass relative to a's at `reference`, as `Body::new` takes them: offset, velocity
/// and acceleration, scaled; what a convex pair's search and its reach test start from.
fn relative_motion<S: Spin, T: Spin>(
    (ma, mb): (&RigidMotion<S>, &RigidMotion<T>),
    reference: f64,
    scale: f64,
) -> (DVec3, DVec3, DVec3) {
    (
        (mb.position_at(reference) - ma.position_at(reference)) * scale,
        (mb.velocity_at(reference) - ma.velocity_at(reference)) * scale,
        (mb.acceleration - ma.acceleration) * scale,
    )
}

/// False when two solids (neither static-only) cannot start touching before the absolute time
/// `until`, from their centre paths and bounding spheres alone: the first test of the search
/// [`pair_searcher`] would build (`Searcher::first_start_in`), on the same numbers, asked before
/// the bodies' poses are; most candidate pairs of a window start end there. True whenever the
/// search could end otherwise: a static-only shape, or spins too fast to bound (which stall).
fn convex_pair_in_reach<S: Spin, T: Spin>(
    (ga, ma): (&ShapeGeometry, &RigidMotion<S>),
    (gb, mb): (&ShapeGeometry, &RigidMotion<T>),
    until: f64,
) -> bool {
    let size = ga.size() + gb.size();
    if ga.is_static_only() || gb.is_static_only() || !(size > 0.0) {
        return true;
    }
    let scale = unit_scale(size);
    let spins = ma.spin.max_angular_speed() * ga.rotation_radius() + mb.spin.max_angular_speed() * gb.rotation_radius();
    if !(spins * scale).is_finite() {
        return true;
    }
    let reference = ma.since.max(mb.since);
    let relative = relative_motion((ma, mb), reference, scale);
    let tol = SHAPE_CONTACT_TOLERANCE * size * scale;
    spheres_reach(relative, size * scale, 2.0 * tol).is_some_and(|reach| reference + reach.enter < until)
}

/// [`shape_contact_resumed`], for a pair whose contacts turn it back when `turns_back` (see
/// [`crate::Mode::turns_back`]): then a pair deeper than the tolerance at the reference is not a
/// contact in progress but one more to turn back if it goes deeper, as against a wall (a rule
/// that stops bodies touching, the jam rule or a stalled search, may leave them that deep).
pub(crate) fn pair_first_start<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    window: Window,
    resume: Option<&Resume>,
    turns_back: bool,
) -> Result<(Search<f64>, Option<Resume>)> {
    let nothing = Ok((Search { found: None, iterations: 0 }, None));
    let reference = a.1.since.max(b.1.since);
    let resumed = resume.is_some_and(|r| r.reference == reference && r.searched_to <= window.start);
    if !resumed && !convex_pair_in_reach(a, b, window.end) {
        return nothing;
    }
    let Some(mut searcher) = pair_searcher(a, b)? else { return nothing };
    let (found, parked) = Resume::first_start(&mut searcher, resume, window, !turns_back)?;
    Ok((Search { found, iterations: searcher.probes() }, parked))
}

/// The first time in `window` (half-open `[start, end)`) at which two shapes begin to touch: the
/// canonical contact start by conservative advancement from `max(a.since, b.since)`. The distance
/// there is at most [`contact_tolerance`], and above half of it at every earlier time from the
/// reference on (outside earlier contacts). `None` when no contact starts in the window (two
/// static-only shapes never touch). [`VadopError::ContactSearchStalled`] if the search could not
/// decide (see the module documentation).
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::narrow_phase::shapes::shape_contact_time;
/// use vadop::motion::RigidMotion;
/// use vadop::Window;
/// let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
/// let wall = Shape::HalfSpace { normal: -DVec3::X }.geometry().unwrap();
/// // A unit cube, face first, 4 from a wall at x = 4.5, closing at 2: touches at 2.
/// let cube_motion = RigidMotion::fixed(DVec3::ZERO, DQuat::IDENTITY, 0.0);
/// let cube_motion = RigidMotion { velocity: DVec3::new(2.0, 0.0, 0.0), ..cube_motion };
/// let wall_motion = RigidMotion::fixed(DVec3::new(4.5, 0.0, 0.0), DQuat::IDENTITY, 0.0);
/// let t = shape_contact_time((&cube, &cube_motion), (&wall, &wall_motion), Window::new(0.0, 10.0)).unwrap();
/// assert!((t.unwrap() - 2.0).abs() < 1e-5);
/// // Another window holding it gives the same time to the bit.
/// let again = shape_contact_time((&cube, &cube_motion), (&wall, &wall_motion), Window::new(1.5, 2.5)).unwrap();
/// assert_eq!(again, t);
/// ```
pub fn shape_contact_time<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    window: Window,
) -> Result<Option<f64>> {
    Ok(shape_contact_search(a, b, window)?.found)
}

/// The time, before `until`, at which the contact that started at `start` ends (the signed
/// distance is above the tolerance again), for detect mode where bodies pass through each other.
/// `start` is a canonical contact start (from [`shape_contact_time`] on the same motions): the
/// chain restarts at every contact start and end it finds, so the end follows from `start` alone,
/// the same for every caller, without replaying earlier contacts. `None` when it has not ended
/// before `until`. Any other `start` is taken as the start of a contact in progress; for a time
/// inside a contact whose start the caller does not hold, see [`contact_in_progress_end_time`].
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::narrow_phase::shapes::{contact_end_time, shape_contact_time};
/// use vadop::motion::RigidMotion;
/// use vadop::Window;
/// let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
/// let a = RigidMotion::fixed(DVec3::ZERO, DQuat::IDENTITY, 0.0);
/// let b = RigidMotion { velocity: DVec3::new(-1.0, 0.0, 0.0), ..RigidMotion::fixed(DVec3::new(3.0, 0.0, 0.0), DQuat::IDENTITY, 0.0) };
/// // b passes through a: it touches at 2 and leaves at 4.
/// let start = shape_contact_time((&cube, &a), (&cube, &b), Window::new(0.0, 10.0)).unwrap().unwrap();
/// let end = contact_end_time((&cube, &a), (&cube, &b), start, 10.0).unwrap().unwrap();
/// assert!((start - 2.0).abs() < 1e-5 && (end - 4.0).abs() < 1e-5, "{start} {end}");
/// ```
pub fn contact_end_time<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    start: f64,
    until: f64,
) -> Result<Option<f64>> {
    Ok(contact_end_search(a, b, start, until)?.found)
}

/// [`contact_end_time`] with the number of distance evaluations it took.
pub fn contact_end_search<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    start: f64,
    until: f64,
) -> Result<Search<f64>> {
    let Some(mut searcher) = pair_searcher(a, b)? else { return Ok(Search { found: None, iterations: 0 }) };
    let found = searcher.end_of(start, until)?.map(|tau| searcher.reference + tau);
    Ok(Search { found, iterations: searcher.probes() })
}

/// The end, before `until`, of the contact two shapes are in at time `at`, whose start the
/// caller does not hold: the contacts are replayed from the reference to the one in progress at
/// `at`, so every `at` inside one contact gives the end of [`contact_end_time`] from its start,
/// to the bit. A pair that is not in contact at `at` on its motions is taken to be in one from
/// `at` on.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::narrow_phase::shapes::{contact_end_time, contact_in_progress_end_time, shape_contact_time};
/// use vadop::motion::RigidMotion;
/// use vadop::Window;
/// let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
/// let a = RigidMotion::fixed(DVec3::ZERO, DQuat::IDENTITY, 0.0);
/// let b = RigidMotion { velocity: DVec3::new(-1.0, 0.0, 0.0), ..RigidMotion::fixed(DVec3::new(3.0, 0.0, 0.0), DQuat::IDENTITY, 0.0) };
/// let start = shape_contact_time((&cube, &a), (&cube, &b), Window::new(0.0, 10.0)).unwrap().unwrap();
/// let end = contact_end_time((&cube, &a), (&cube, &b), start, 10.0).unwrap();
/// for at in [2.5, 3.0, 3.9] {
///     assert_eq!(contact_in_progress_end_time((&cube, &a), (&cube, &b), at, 10.0).unwrap(), end);
/// }
/// ```
pub fn contact_in_progress_end_time<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    at: f64,
    until: f64,
) -> Result<Option<f64>> {
    let Some(mut searcher) = pair_searcher(a, b)? else { return Ok(None) };
    Ok(searcher.end_of_contact_at(at, until, true)?.map(|tau| searcher.reference + tau))
}

/// The first time in `window` at which two shapes begin to touch again after the contact that
/// started at `start` (a canonical start the caller holds, from [`shape_contact_time`] on the same
/// motions): what [`shape_contact_time`] finds in a window after `start`, to the bit, without
/// replaying the contacts before `start`. Spinning shapes may touch many times on one motion.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::motion::free_rotation::FreeRotation;
/// use vadop::narrow_phase::shapes::{shape_contact_after, shape_contact_time};
/// use vadop::motion::RigidMotion;
/// use vadop::Window;
/// let plank = Shape::Cuboid { half_extents: DVec3::new(1.0, 0.1, 0.1) }.geometry().unwrap();
/// let ball = Shape::Sphere { radius: 0.2 }.geometry().unwrap();
/// // A plank spinning about z beside a ball: its end sweeps past the ball twice a turn.
/// let spin = FreeRotation::new(plank.principal_inertia_unit(), DQuat::IDENTITY, DVec3::new(0.0, 0.0, 6.0));
/// let spinning = RigidMotion { position: DVec3::ZERO, since: 0.0, velocity: DVec3::ZERO, acceleration: DVec3::ZERO, spin };
/// let ball_motion = RigidMotion::fixed(DVec3::new(0.0, 1.1, 0.0), DQuat::IDENTITY, 0.0);
/// let window = Window::new(0.0, 5.0);
/// let first = shape_contact_time((&plank, &spinning), (&ball, &ball_motion), window).unwrap().unwrap();
/// let later = Window::new(first.next_up(), 5.0);
/// let second = shape_contact_after((&plank, &spinning), (&ball, &ball_motion), first, later).unwrap();
/// assert_eq!(second, shape_contact_time((&plank, &spinning), (&ball, &ball_motion), later).unwrap());
/// assert!(second.unwrap() > first);
/// ```
pub fn shape_contact_after<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    start: f64,
    window: Window,
) -> Result<Option<f64>> {
    Ok(shape_contact_after_parked(a, b, start, window)?.0)
}

/// [`shape_contact_after`] with where the chain parks when no contact starts in `window` (see
/// [`shape_contact_resumed`]).
pub fn shape_contact_after_parked<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    start: f64,
    window: Window,
) -> Result<(Option<f64>, Option<Resume>)> {
    shape_contact_after_measured(a, b, start, window).map(|(found, parked, _)| (found, parked))
}

/// [`shape_contact_after_parked`] with where the shapes touch at `start`, as
/// [`contact_geometry`] gives it to the bit, when the search measured it there (the first probe
/// of the contact's end search): a caller that reports the contact need not measure it again.
pub(crate) fn shape_contact_after_measured<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    start: f64,
    window: Window,
) -> Result<(Option<f64>, Option<Resume>, Option<ContactPoint>)> {
    let Some(mut searcher) = pair_searcher(a, b)? else { return Ok((None, None, None)) };
    let found = searcher.first_start_after(start, window)?;
    let parked = if found.is_none() { Resume::of(&searcher, window.end) } else { None };
    let measured = match &searcher.gauge {
        PairGauge::Convex(pair) => pair.measured.get().filter(|&(tau, _)| tau == start - searcher.reference),
        PairGauge::Plane(..) | PairGauge::Mesh(..) => None,
    };
    Ok((found.map(|tau| searcher.reference + tau), parked, measured.map(|(_, point)| point)))
}

/// Where two shapes touch at `time` (normally a contact time), in world coordinates: the normal
/// (from a to b) is the axis of the tightest separation found (at a touch, the contact normal),
/// the point lies halfway between the closest points (parry's GJK, or a shape's extreme point
/// and its projection on the other, whichever are closer; EPA's deepest points when they
/// penetrate), and the distance is their signed distance. `None` for two static-only shapes.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::narrow_phase::shapes::contact_geometry;
/// use vadop::motion::RigidMotion;
/// let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
/// let a = RigidMotion::fixed(DVec3::ZERO, DQuat::IDENTITY, 0.0);
/// let b = RigidMotion::fixed(DVec3::new(1.0, 0.25, 0.0), DQuat::IDENTITY, 0.0);
/// // Face to face along x: the normal is +x, the point on the shared face.
/// let c = contact_geometry((&cube, &a), (&cube, &b), 0.0).unwrap();
/// assert!((c.normal - DVec3::X).length() < 1e-9 && c.distance.abs() < 1e-9);
/// assert!((c.point.x - 0.5).abs() < 1e-9);
/// ```
pub fn contact_geometry<S: Spin, T: Spin>(
    a: (&ShapeGeometry, &RigidMotion<S>),
    b: (&ShapeGeometry, &RigidMotion<T>),
    time: f64,
) -> Option<ContactPoint> {
    let searcher = pair_searcher(a, b).ok()??;
    let tau = time - searcher.reference;
    match &searcher.gauge {
        PairGauge::Convex(pair) => {
            let poses = pair.poses(tau);
            Some(pair.contact_point(tau, (&poses.0, &poses.1), pair.exact_bounds((&poses.0, &poses.1))))
        }
        PairGauge::Plane(pair, flipped) => {
            let (n, pose, distance, _) = pair.state(tau);
            let deepest = pair.body.support(pair.scale).support_point(&pose, -n);
            let origin = pair.plane.centre(tau);
            let point = origin + (deepest - n * (0.5 * distance)) / pair.scale;
            let normal = if *flipped { n } else { -n };
            Some(ContactPoint { point, normal, distance: distance / pair.scale })
        }
        PairGauge::Mesh(pair, flipped) => {
            let bounds = pair.closest(tau, Need::converged(Some(EXACT_DEPTH)))?;
            let (_, pose) = pair.state(tau);
            let witness = bounds.witness.unwrap_or_else(|| {
                // The body's extreme point towards the mesh, on both sides.
                let point = pair.body.support(pair.scale).support_point(&pose, -bounds.axis);
                (point, point)
            });
            let origin = pair.body.centre(tau);
            let c = contact_point(origin, witness, bounds, pair.mesh.orientation(tau), pair.scale);
            Some(if *flipped { c } else { ContactPoint { normal: -c.normal, ..c } })
        }
    }
}

/// The world contact point and normal from bounds in a frame rotated by `rotation` from the world
/// axes, scaled by `scale`, whose origin is at `origin`.
fn contact_point(origin: DVec3, witness: (DVec3, DVec3), bounds: Bounds, rotation: DQuat, scale: f64) -> ContactPoint {
    let midpoint = rotation * ((witness.0 + witness.1) * 0.5) / scale;
    let distance = if bounds.upper.is_finite() { bounds.upper } else { bounds.lower };
    ContactPoint { point: origin + midpoint, normal: (rotation * bounds.axis).normalize(), distance: distance / scale }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Fixed;
    use crate::shape::Shape;

    fn still(position: DVec3) -> RigidMotion<Fixed> {
        RigidMotion::fixed(position, DQuat::IDENTITY, 0.0)
    }

    #[test]
    fn head_on_cubes_and_their_end() {
        let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
        let a = still(DVec3::ZERO);
        let b = RigidMotion { velocity: DVec3::new(-2.0, 0.0, 0.0), ..still(DVec3::new(5.0, 0.0, 0.0)) };
        let w = Window::new(0.0, 100.0);
        let start = shape_contact_time((&cube, &a), (&cube, &b), w).unwrap().unwrap();
        assert!((start - 2.0).abs() < 1e-5, "{start}");
        let end = contact_end_time((&cube, &a), (&cube, &b), start, 100.0).unwrap().unwrap();
        assert!((end - 3.0).abs() < 1e-5, "{end}");
        // After the pass-through, no second contact.
        assert_eq!(shape_contact_time((&cube, &a), (&cube, &b), Window::new(start.next_up(), 100.0)).unwrap(), None);
        let c = contact_geometry((&cube, &a), (&cube, &b), start).unwrap();
        assert!((c.normal - DVec3::X).length() < 1e-9, "{c:?}");
        assert!((c.point.x - 0.5).abs() < 1e-5, "{c:?}");
    }

    #[test]
    fn separating_pair_touching_at_the_reference_is_not_a_contact() {
        let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
        let a = still(DVec3::ZERO);
        let away = RigidMotion { velocity: DVec3::new(1.0, 0.0, 0.0), ..still(DVec3::new(1.0, 0.0, 0.0)) };
        assert_eq!(shape_contact_time((&cube, &a), (&cube, &away), Window::new(0.0, 10.0)).unwrap(), None);
        let into = RigidMotion { velocity: DVec3::new(-1.0, 0.0, 0.0), ..away };
        assert_eq!(shape_contact_time((&cube, &a), (&cube, &into), Window::new(0.0, 10.0)).unwrap(), Some(0.0));
        // Sliding along each other, not turning: resting, no contact ever.
        let slide = RigidMotion { velocity: DVec3::new(0.0, 1.0, 0.0), ..away };
        let floor = Shape::HalfSpace { normal: DVec3::X }.geometry().unwrap();
        let floor_motion = still(DVec3::new(0.5, 0.0, 0.0));
        let on_floor = RigidMotion { position: DVec3::new(1.0, 0.0, 0.0), ..slide };
        assert_eq!(
            shape_contact_time((&floor, &floor_motion), (&cube, &on_floor), Window::new(0.0, 10.0)).unwrap(),
            None
        );
    }

    /// A pair touching at the reference that dips past the tolerance and turns back (two cubes,
    /// the second pushed into the first and pulled away) is a new contact at the reference,
    /// however deep within the tolerance it starts (a whole tolerance deeper than it is was
    /// needed before, so a pair pressed together could sink that much per new reference); one
    /// already past the tolerance is a contact once it goes an eighth of one deeper.
    #[test]
    fn a_pair_touching_at_the_reference_that_dips_past_its_floor_is_a_contact() {
        let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
        let tol = contact_tolerance(&cube, &cube);
        let a = still(DVec3::ZERO);
        for (start, dip) in [(0.0, 1.3), (0.3, 1.3), (0.72, 1.3), (0.9, 1.2), (1.5, 1.75)] {
            let speed = 1e-3;
            let pull = speed * speed / (2.0 * (dip - start) * tol);
            let b = RigidMotion {
                velocity: DVec3::new(-speed, 0.0, 0.0),
                acceleration: DVec3::new(pull, 0.0, 0.0),
                ..still(DVec3::new(1.0 - start * tol, 0.0, 0.0))
            };
            // Where contacts turn bodies back (simulate mode): a deep pair is no contact in progress.
            let (search, _) = pair_first_start((&cube, &a), (&cube, &b), Window::new(0.0, 10.0), None, true).unwrap();
            assert_eq!(search.found, Some(0.0), "touching {start} tolerances deep, dipping to {dip}");
        }
    }

    /// Two shapes frozen into one motion by the jam rule (one velocity, one gravity, no spin)
    /// never start a contact, touching or not, and their search spends no probe: probes at the
    /// reference too loose to say whether such a pair touched once let it start a contact at the
    /// reference, which froze it into the same motion at the same instant, for ever.
    #[test]
    fn shapes_moving_as_one_never_start_a_contact() {
        let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
        let tol = contact_tolerance(&cube, &cube);
        let together = |x: f64| RigidMotion {
            velocity: DVec3::new(0.3, -0.5, 0.2),
            acceleration: DVec3::new(0.0, -9.81, 0.0),
            ..still(DVec3::new(x, 0.0, 0.0))
        };
        for gap in [-0.5, 0.0, 0.5, 3.0] {
            let (a, b) = (together(0.0), together(1.0 + gap * tol));
            let mut searcher = pair_searcher((&cube, &a), (&cube, &b)).unwrap().unwrap();
            assert_eq!(searcher.first_start_in(Window::new(0.0, 10.0), true).unwrap(), None, "{gap} tolerances apart");
            assert_eq!(searcher.probes(), 0, "{gap} tolerances apart");
        }
    }

    /// Two shapes that only translate (here cubes not turning, and a ball spinning) touch once
    /// as they pass through each other: after the contact's start the search knows no other
    /// follows without looking for the contact's end (their distance is convex in time).
    #[test]
    fn translating_shapes_touch_once_and_their_search_stops_there() {
        fn passes_once<S: Spin>(first: (&ShapeGeometry, &RigidMotion<S>)) {
            let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
            let b = RigidMotion { velocity: DVec3::new(-2.0, 0.3, 0.0), ..still(DVec3::new(5.0, 0.0, 0.0)) };
            let window = Window::new(0.0, 100.0);
            let mut searcher = pair_searcher(first, (&cube, &b)).unwrap().unwrap();
            let start = searcher.reference + searcher.first_start_in(window, false).unwrap().unwrap();
            let probes = searcher.probes();
            assert_eq!(searcher.first_start_after(start, window).unwrap(), None);
            assert_eq!(searcher.probes(), probes, "no probe after the start");
            // The search from the reference agrees, past the contact's start.
            let later = Window::new(start.next_up(), 100.0);
            assert_eq!(shape_contact_time(first, (&cube, &b), later).unwrap(), None);
        }
        let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
        passes_once((&cube, &still(DVec3::ZERO)));
        let ball = Shape::Sphere { radius: 0.5 }.geometry().unwrap();
        let turn = crate::motion::FreeRotation::new(
            ball.principal_inertia_unit(),
            DQuat::IDENTITY,
            DVec3::new(3.0, -2.0, 1.0),
        );
        passes_once((
            &ball,
            &RigidMotion {
                position: DVec3::ZERO,
                since: 0.0,
                velocity: DVec3::ZERO,
                acceleration: DVec3::ZERO,
                spin: turn,
            },
        ));
    }

    /// A spinning pair that leaves along the ending probe's axis faster than turning can close
    /// it touches no more: the search after its contact stops at the end's probe at the latest
    /// (earlier where a probe shows the pair parting for good, see [`parting`]), with no probe of
    /// a start search after it.
    #[test]
    fn a_fast_pass_through_of_spinning_shapes_ends_the_search_at_its_end() {
        use crate::motion::FreeRotation;
        let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
        let spin = FreeRotation::new(cube.principal_inertia_unit(), DQuat::IDENTITY, DVec3::new(1.0, -2.0, 3.0));
        let spinning = RigidMotion {
            position: DVec3::new(6.0, 0.2, 0.0),
            since: 0.0,
            velocity: DVec3::new(-20.0, 0.5, 0.3),
            acceleration: DVec3::ZERO,
            spin,
        };
        let (a, b) = ((&cube, &still(DVec3::ZERO)), (&cube, &spinning));
        let window = Window::new(0.0, 10.0);
        let start = shape_contact_time(a, b, window).unwrap().unwrap();
        let mut after = pair_searcher(a, b).unwrap().unwrap();
        assert_eq!(after.first_start_after(start, window).unwrap(), None);
        let mut end = pair_searcher(a, b).unwrap().unwrap();
        assert!(end.end_of(start, window.end).unwrap().is_some());
        assert!(after.probes() <= end.probes(), "the end's probes and no more");
        assert_eq!(after.parked, Some(Parked::DONE));
        // The search from the reference agrees, past the contact's start.
        assert_eq!(shape_contact_time(a, b, Window::new(start.next_up(), 10.0)).unwrap(), None);
    }

    /// A pair search skipped because the bounding spheres stay out of reach
    /// (`convex_pair_in_reach`) would have found nothing: the full search agrees on spinning
    /// solids near and far, straight and falling, and most pairs far apart are skipped.
    #[test]
    fn pairs_out_of_reach_have_no_contact() {
        use crate::motion::FreeRotation;
        use rand::{Rng, SeedableRng};
        let solids = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let (mut skipped, mut found) = (0, 0);
        for case in 0..600 {
            let mut random = |low: f64, high: f64| rng.random_range(low..high);
            let mut body = |kind: usize, falling: bool| {
                let position = DVec3::new(random(-1.5, 1.5), random(-1.5, 1.5), random(-1.5, 1.5));
                let velocity = DVec3::new(random(-8.0, 8.0), random(-8.0, 8.0), random(-8.0, 8.0));
                let start =
                    DQuat::from_scaled_axis(DVec3::new(random(-3.0, 3.0), random(-3.0, 3.0), random(-3.0, 3.0)));
                let omega = DVec3::new(random(-20.0, 20.0), random(-20.0, 20.0), random(-20.0, 20.0));
                let spin = FreeRotation::new(solids[kind].principal_inertia_unit(), start, omega);
                let acceleration = if falling { DVec3::new(0.0, -9.81, 0.0) } else { DVec3::ZERO };
                RigidMotion { position, since: random(0.0, 0.2), velocity, acceleration, spin }
            };
            let (a, mut b) = (body(case % 6, case % 3 == 0), body((case / 6) % 6, case % 5 == 0));
            if case % 2 == 0 {
                // Aimed at each other: many of these touch.
                b.velocity = (a.position - b.position) * rng.random_range(1.0..6.0);
            }
            let from = a.since.max(b.since) + rng.random_range(-0.1..0.3);
            let window = Window::new(from, from + rng.random_range(0.01..0.5));
            let (ga, gb) = (&solids[case % 6], &solids[(case / 6) % 6]);
            let full = pair_first_start((ga, &a), (gb, &b), window, None, false).map(|(search, _)| search.found);
            found += usize::from(matches!(full, Ok(Some(_))));
            if !convex_pair_in_reach((ga, &a), (gb, &b), window.end) {
                skipped += 1;
                let searcher = pair_searcher((ga, &a), (gb, &b)).unwrap().unwrap();
                let mut searcher = searcher;
                assert_eq!(searcher.first_start_in(window, true).unwrap(), None, "case {case}: skipped, but found");
                assert_eq!(searcher.probes(), 0, "case {case}: skipped, but the search probed");
            }
        }
        assert!(skipped > 200 && found > 20, "{skipped} skipped, {found} contacts found");
    }

    /// The search after a contact measures where the shapes touch at its start with its first
    /// probe: the same bits as [`contact_geometry`], on every kind of solid, spinning or not.
    #[test]
    fn the_search_after_a_contact_measures_its_geometry_to_the_bit() {
        use crate::motion::FreeRotation;
        use rand::{Rng, SeedableRng};
        let solids = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(29);
        let mut measured = 0;
        for case in 0..144 {
            let mut random = |low: f64, high: f64| rng.random_range(low..high);
            let mut body = |kind: usize, spinning: bool| {
                let position = DVec3::new(random(-3.0, 3.0), random(-3.0, 3.0), random(-3.0, 3.0));
                let start =
                    DQuat::from_scaled_axis(DVec3::new(random(-3.0, 3.0), random(-3.0, 3.0), random(-3.0, 3.0)));
                let omega = if spinning {
                    DVec3::new(random(-9.0, 9.0), random(-9.0, 9.0), random(-9.0, 9.0))
                } else {
                    DVec3::ZERO
                };
                let spin = FreeRotation::new(solids[kind].principal_inertia_unit(), start, omega);
                RigidMotion { position, since: 0.0, velocity: DVec3::ZERO, acceleration: DVec3::ZERO, spin }
            };
            let (kinds, spinning) = ((case % 6, (case / 6) % 6), case % 4 != 0);
            let (a, mut b) = (body(kinds.0, spinning), body(kinds.1, spinning || case % 8 == 0));
            // Aimed through each other, fast or slow.
            b.velocity = (a.position - b.position) * rng.random_range(0.5..12.0);
            let (a, b) = ((&solids[kinds.0], &a), (&solids[kinds.1], &b));
            let window = Window::new(0.0, 2.0);
            let Some(start) = shape_contact_time(a, b, window).unwrap() else { continue };
            let after = Window::new(start.next_up(), window.end);
            let (found, _, at_start) = shape_contact_after_measured(a, b, start, after).unwrap();
            // The chain with its exact first probe is the chain replayed from the reference.
            assert_eq!(found, shape_contact_time(a, b, after).unwrap(), "case {case}");
            if let Some(point) = at_start {
                assert_eq!(Some(point), contact_geometry(a, b, start), "case {case}");
                measured += 1;
            }
        }
        assert!(measured > 60, "{measured} contacts measured by their searches");
    }

    #[test]
    fn two_static_shapes_never_meet() {
        let floor = Shape::HalfSpace { normal: DVec3::Y }.geometry().unwrap();
        let m = still(DVec3::ZERO);
        assert_eq!(shape_contact_time((&floor, &m), (&floor, &m), Window::new(0.0, 1.0)).unwrap(), None);
        assert!(contact_geometry((&floor, &m), (&floor, &m), 0.0).is_none());
    }
}
