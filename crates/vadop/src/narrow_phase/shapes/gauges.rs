//! Gauges: what one search measures at a probe time, for each kind of pair (two convex shapes,
//! a shape and a plane, a shape and a mesh, a shape and a wall), with the spin-free far bound
//! and the warm start kept between probes. A gauge turns distance bounds into a safe step; it
//! never chooses the probe times (the searcher does).

use super::chord::{axis_hold, chord_hold, sliding_hold, Moving};
use super::distance::{
    closer_points, convex_bounds, separation, Bounds, Need, Simplex, EXACT_DEPTH, GAP_SHARE, PROBE_DEPTH_SHARE,
    PROBE_RESOLUTION,
};
use super::fixed_gauges::{MeshPair, PlanePair};
use super::inner_balls::{held, InnerBall, ShapeBall};
use super::parting::parts_for_good;
use super::reach::{spheres_reach, Reach};
use super::scaled::{along, speeding, Body, Scaled};
use super::{ceiling, cleared, contact_point, ending, guard, starting, ContactPoint, SLACK};
use crate::numeric::direction;
use glam::{DQuat, DVec3};
use parry3d_f64::math::Pose;
use parry3d_f64::shape::SupportMap;
use std::cell::{Cell, RefCell};

/// Bounds on the signed distance at one instant, and on how fast they can move (scaled units).
#[derive(Debug, Clone, Copy)]
pub(super) struct Probe {
    /// `lower <= signed distance <= upper`.
    pub(super) lower: f64,
    pub(super) upper: f64,
    /// The lower bound (a separation along a fixed axis) shrinks at most this fast (a rate below
    /// 0 is one at which it certainly grows, at first: see [`Self::bend`]).
    pub(super) shrink: f64,
    /// The signed distance grows at most this fast.
    pub(super) grow: f64,
    /// A looser lower bound that turning cannot shrink, from the bounding sphere of a spinning
    /// body, and how fast it shrinks: `(-inf, 0)` when there is none. Far from contact it steps a
    /// fast spinner by its straight motion, where `lower` would step it by its spin.
    pub(super) far: (f64, f64),
    /// How long the signed distance certainly stays on this side of the band the search is
    /// crossing: within a contact below the search's ceiling (see [`super::inner_balls`] and
    /// [`super::chord`]), before one above its guard (see [`super::chord::axis_hold`]); 0 when
    /// nothing says so.
    pub(super) hold: f64,
    /// Every rate above (`shrink`, `grow`, `far`'s) grows at most this fast: a bound on the
    /// relative acceleration along the axes they are taken on (0 on a straight relative motion,
    /// as between two bodies falling under one gravity).
    pub(super) bend: f64,
    /// The signed distance only grows from this probe on, for good (see
    /// [`super::parting`]): no contact can follow the one in progress.
    pub(super) parting: bool,
}

/// No spin-free bound.
pub(super) const NO_FAR: (f64, f64) = (f64::NEG_INFINITY, 0.0);

/// What a probe must measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Measure {
    /// How far apart the shapes are: an intersection need only be recognised.
    Gap,
    /// The signed distance both ways, its depth too when the shapes intersect.
    Depth,
    /// Within a contact, looking for its end (or for what follows it): while the shapes lie deep
    /// inside each other only an upper bound on the signed distance steps the search, and a
    /// cheap one will do. The first, cold at the contact's start, is exact: the contact's
    /// reported geometry.
    Contact(Then),
}

/// What a search through a contact is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Then {
    /// The contact's end.
    End,
    /// The next contact start after it: a probe that shows the pair parting for good (see
    /// [`super::parting`]) ends the search, and needs no step out of it.
    NextStart,
}

/// A contact probe takes the carried upper bound on the signed distance (see
/// [`Warm::contact_upper`]) when it is at most this many tolerances, so that the contact is far
/// from its end (above `tol`) and a step on it goes at least six sevenths as far as the widest
/// room a shallow contact leaves, and when it leaves at least [`STALE_ROOM`] of the room below
/// `2 tol` that the deepest bound since the last full measure did: a carried bound gone stale
/// (the shapes turned and slid since, or a pair passing through, deep a probe ago, nears its way
/// out) never holds the search to much shorter steps than a fresh one would take.
const CARRIED_UPPER: f64 = 0.25;

/// The share of the deepest bound's room (see [`CARRIED_UPPER`]) a carried bound must leave. A
/// tenth, not a quarter: the steps also rest on the inner balls, and EPA on each quarter of a
/// contact's exit cost more than the shorter steps between (8% on mixed shapes at 0.05 d/f,
/// measured).
const STALE_ROOM: f64 = 0.1;

/// A start search's probe looks for a hold away from contact (see [`super::chord::axis_hold`])
/// only where turning can move the surfaces along the probe's axis faster than this share of the
/// speed at which the axis closes: below it the step on the lower bound is nearly as long, and
/// the certificate costs about a quarter of a probe. (Instructions on 1e4 mixed shapes against
/// looking always, shares 0.05 / 0.1 / 0.2 / 0.4 / 0.8: at 5 d/f -2.4 / -3.0 / -3.1 / -2.8 /
/// -2.6 %, at 0.5 d/f -0.9 / -1.0 / -1.4 / -1.2 / +0.9 %; never looking, -2.3 % and +14.8 %.)
const APART_TURN: f64 = 0.2;

/// How many times [`Warm::contact_upper`] moves its point deeper into both shapes (one move less
/// took 1.5% more instructions on the CLI's crowd of mixed shapes, one more 0.2% more).
const DEEP_POINT_MOVES: usize = 2;

impl Probe {
    /// The longest step that keeps the distance above `guard` on either lower bound (infinite
    /// when one never shrinks), or `None` when neither bound is above `guard`.
    pub(super) fn approach_step(&self, guard: f64) -> Option<f64> {
        let step = |(lower, shrink): (f64, f64)| {
            let room = lower - guard;
            (room > 0.0).then(|| self.time_to(room, shrink))
        };
        match (step((self.lower, self.shrink)), step(self.far)) {
            (Some(near), Some(far)) => Some(near.max(far)),
            (near, far) => near.or(far),
        }
    }

    /// How long a quantity `room` short of a bound stays short of it, moving towards it at
    /// `rate` now (away from it when negative), a rate that grows at most by [`Self::bend`] per
    /// unit of time: the root of `rate s + bend s^2 / 2 = room` (`room / rate` on a straight
    /// motion), infinite when it never gets there.
    pub(super) fn time_to(&self, room: f64, rate: f64) -> f64 {
        if self.bend == 0.0 {
            return if rate > 0.0 { room / rate } else { f64::INFINITY };
        }
        let root = (rate * rate + 2.0 * self.bend * room).sqrt();
        // Each form where it adds terms of one sign: no cancellation.
        if rate < 0.0 {
            (root - rate) / self.bend
        } else {
            2.0 * room / (rate + root)
        }
    }
}

/// The signed distance of one pair (or of a body and a wall) as a function of the time since the
/// reference, in scaled lengths.
pub(super) trait Gauge {
    fn probe(&self, tau: f64, measure: Measure) -> Probe;
    /// The times within which the distance may be at most `within`, from the bodies' bounding
    /// volumes alone: `None` when it never is.
    fn reach(&self, within: f64) -> Option<Reach>;
    /// Drops what the last probes found (their warm start): the chain starts afresh.
    fn forget(&self) {}
    /// What the last probe left for the next one, to carry a chain into a later search:
    /// `None` when this gauge's warm start cannot be carried (a mesh's, one per triangle).
    fn warm_start(&self) -> Option<Option<Warm>> {
        Some(None)
    }
    /// Takes up a warm start that [`Self::warm_start`] gave.
    fn set_warm_start(&self, _warm: Option<Warm>) {}
    /// Whether the two shapes only translate: neither turns, or turning leaves each where it is
    /// (see [`super::scaled::still`]). Their signed distance is then a convex function of time
    /// (that of a point moving in a straight line to a fixed convex set, their Minkowski
    /// difference).
    fn translating(&self) -> bool {
        false
    }
    /// Whether the two shapes keep one placement relative to each other for ever: they only
    /// translate, at one velocity (a cluster the jam rule froze into one motion). Their distance
    /// never changes, so no contact starts or ends.
    fn moving_as_one(&self) -> bool {
        false
    }
}

/// Two solid shapes. The frame has world axes and its origin at a's centre of mass.
pub(super) struct ConvexPair<'a> {
    pub(super) a: Body<'a>,
    pub(super) b: Body<'a>,
    /// Their shapes as the distance bounds read them, at `scale`.
    pub(super) shapes: (Scaled<'a>, Scaled<'a>),
    pub(super) scale: f64,
    /// b's centre minus a's at the reference, scaled.
    pub(super) offset: DVec3,
    /// b's velocity minus a's, scaled.
    pub(super) velocity: DVec3,
    /// b's acceleration minus a's, scaled: zero for two bodies falling under one gravity, whose
    /// relative motion stays straight.
    pub(super) acceleration: DVec3,
    /// Scaled bound on how fast turning moves the two surfaces.
    pub(super) spin: f64,
    /// Scaled sum of the bounding radii.
    pub(super) size: f64,
    /// Scaled contact tolerance.
    pub(super) tol: f64,
    /// What the last probe found, to start the next one from. Read and renewed in place: it is
    /// 352 bytes, and copies of it (and of the simplex in it) were a fifth of the probes' memory
    /// copies.
    pub(super) warm: RefCell<Option<Warm>>,
    /// The balls about the shapes' middles ([`Scaled::middle_ball`], in the shapes' frames).
    pub(super) middles: (Option<ShapeBall>, Option<ShapeBall>),
    /// Where the shapes touch at the first contact probe made cold (the first of a contact's end
    /// search, at its start), from the exact measure that probe made, with its time: the
    /// contact's geometry, which the caller then need not measure again.
    pub(super) measured: Cell<Option<(f64, ContactPoint)>>,
}

/// A probe's axis and witness points, fixed in the bodies (in frames that move with them): after
/// a step the points still bound the distance, and so does the axis turned with the body whose
/// face (or curved surface) it is the normal of, nearly as tightly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Warm {
    pub(super) axis: (DVec3, DVec3),
    pub(super) witness: (DVec3, DVec3),
    /// The upper bound that probe found.
    pub(super) upper: f64,
    /// GJK's simplex from the last probe that ran it, its points fixed in the bodies.
    pub(super) simplex: Option<Simplex>,
    /// The last probe's time and a point inside both shapes then, fixed in the first (its
    /// deepest point, or the midpoint of the witnesses of an intersection): how the region inside
    /// both slides from one probe to the next (see [`super::chord::sliding_hold`]).
    pub(super) inside: Option<(f64, DVec3)>,
}

impl Warm {
    /// What a probe's `bounds` leave for the next one; `carry` maps each shape's moving frame to
    /// the probe's.
    pub(super) fn new(bounds: &Bounds, carry: (&Pose, &Pose)) -> Option<Warm> {
        let mut slot = None;
        Warm::renew(&mut slot, bounds, carry);
        slot
    }

    /// [`Warm::new`] written into `slot`, the simplex copied once.
    pub(super) fn renew(slot: &mut Option<Warm>, bounds: &Bounds, carry: (&Pose, &Pose)) {
        let Some((x, y)) = bounds.witness else {
            *slot = None;
            return;
        };
        let warm = slot.insert(Warm {
            axis: (carry.0.rotation.inverse() * bounds.axis, carry.1.rotation.inverse() * bounds.axis),
            witness: (carry.0.inverse_transform_point(x), carry.1.inverse_transform_point(y)),
            upper: bounds.upper,
            simplex: None,
            inside: None,
        });
        warm.simplex = bounds.simplex;
    }

    /// How the point inside both shapes at `tau`, `point` (in the probe's frame, the first
    /// shape's pose `pose_a`), slid through the first shape since the last probe's, as a velocity
    /// in world axes; `None` without both.
    pub(super) fn slide(&self, tau: f64, point: Option<DVec3>, pose_a: &Pose) -> Option<DVec3> {
        let (before, from) = self.inside?;
        let to = pose_a.inverse_transform_point(point?);
        (tau > before).then(|| pose_a.rotation * ((to - from) / (tau - before)))
    }

    /// The warm start holds `point`, inside both shapes at `tau` (or none), fixed in the first.
    fn hold_inside(&mut self, tau: f64, point: Option<DVec3>, pose_a: &Pose) {
        self.inside = point.map(|p| (tau, pose_a.inverse_transform_point(p)));
    }

    /// An upper bound on the signed distance from what the last full measure found, with no
    /// distance search: less than 0 by how deep a point lies in both shapes ([`deepest_point`],
    /// from the midpoint of the witness points carried along with the shapes and from each
    /// shape's corner pushed into the other; the witnesses themselves as seeds, and more than
    /// two moves, cost more in depth evaluations than their tighter bounds saved in probes on
    /// mixed shapes), or the witnesses' distance where no point is found inside both.
    pub(super) fn contact_upper(
        &self,
        (a, pose_a): (&Scaled, &Pose),
        (b, pose_b): (&Scaled, &Pose),
        slack: f64,
    ) -> (f64, Deepest) {
        let (x, y) = (*pose_a * self.witness.0, *pose_b * self.witness.1);
        // Each shape's extreme point into the other along the axis turned with the other (a
        // face normal turns with its face): the deepest point of a corner pushed into a face.
        let (n_a, n_b) = (pose_a.rotation * self.axis.0, pose_b.rotation * self.axis.1);
        let corners = [b.support_point(pose_b, -n_a), a.support_point(pose_a, n_b)];
        match deepest_point(&[(x + y) * 0.5, corners[0], corners[1]], (a, pose_a), (b, pose_b)) {
            Some((depth, deepest)) => (slack - depth, deepest),
            None => ((y - x).length() + slack, Deepest::Witnesses(x, y)),
        }
    }

    /// Bounds from the axis, turned with either shape, and the witness points, carried along with
    /// them (or, if those drifted apart, their projections on the other shape), when they lie
    /// within half the room above `guard(tol)` of each other: the step on them then goes at least
    /// two thirds as far as on exact bounds. `None` otherwise (GJK then).
    pub(super) fn bounds(
        &self,
        (a, pose_a): (&Scaled, &Pose),
        (b, pose_b): (&Scaled, &Pose),
        carry: (&Pose, &Pose),
        tol: f64,
        slack: f64,
    ) -> Option<Bounds> {
        let witness = (*carry.0 * self.witness.0, *carry.1 * self.witness.1);
        let (lower, axis) = [carry.0.rotation * self.axis.0, carry.1.rotation * self.axis.1]
            .map(|n| (separation(a, pose_a, b, pose_b, n), n))
            .into_iter()
            .fold((f64::NEG_INFINITY, DVec3::X), |best, c| if c.0 > best.0 { c } else { best });
        let tight = |upper: f64| upper - lower <= 0.5 * (lower - guard(tol));
        let carried = ((witness.1 - witness.0).length(), Some(witness));
        let (upper, witness) =
            if tight(carried.0) { carried } else { closer_points((a, pose_a), (b, pose_b), carried, None, 1) };
        let simplex = self.simplex;
        tight(upper).then_some(Bounds { lower: lower - slack, upper: upper + slack, axis, witness, simplex })
    }
}

/// A point inside both shapes from bounds that say they intersect: the midpoint of the witness
/// points (each shape's deepest point in the other, so both lie in each shape).
fn inside_point(bounds: &Bounds) -> Option<DVec3> {
    let (x, y) = bounds.witness?;
    (bounds.upper < 0.0).then(|| 0.5 * (x + y))
}

/// A point inside both shapes and how deep it lies in them together, `None` when none is found:
/// from whichever of `seeds` lies deepest in the shape it lies shallower in, moved a few times
/// away from the nearer face of that shape by half the difference of the depths. A ball about
/// the point as deep as it lies in a shape lies in that shape, and two shapes holding balls of
/// radii `r_a` and `r_b` about one point must move `r_a + r_b` apart to part: the bound holds at
/// every point, the moves only tighten it.
pub(super) fn deepest_point(
    seeds: &[DVec3],
    (a, pose_a): (&Scaled, &Pose),
    (b, pose_b): (&Scaled, &Pose),
) -> Option<(f64, Deepest)> {
    let depths =
        |p: DVec3| (a.depth_at(pose_a.inverse_transform_point(p)), b.depth_at(pose_b.inverse_transform_point(p)));
    let shallower = |((in_a, _), (in_b, _)): &((f64, DVec3), (f64, DVec3))| in_a.min(*in_b);
    let (mut point, mut measured) = seeds.iter().map(|&p| (p, depths(p))).reduce(|best, seed| {
        if shallower(&seed.1) > shallower(&best.1) {
            seed
        } else {
            best
        }
    })?;
    let mut found = None;
    for moves in 0..=DEEP_POINT_MOVES {
        if moves > 0 {
            measured = depths(point);
        }
        let ((in_a, inward_a), (in_b, inward_b)) = measured;
        if in_a > 0.0 && in_b > 0.0 && found.is_none_or(|(depth, _)| in_a + in_b > depth) {
            let inward = (pose_a.rotation * inward_a, pose_b.rotation * inward_b);
            found = Some((in_a + in_b, Deepest::Inside { point, depths: (in_a, in_b), inward }));
        }
        point += if in_a < in_b {
            pose_a.rotation * inward_a * (0.5 * (in_b - in_a))
        } else {
            pose_b.rotation * inward_b * (0.5 * (in_a - in_b))
        };
    }
    found
}

/// Where [`Warm::contact_upper`] found its bound: a point inside both shapes, as deep as given
/// in each and with the directions in which it deepens in each; or the carried witness points.
#[derive(Debug, Clone, Copy)]
pub(super) enum Deepest {
    Inside { point: DVec3, depths: (f64, f64), inward: (DVec3, DVec3) },
    Witnesses(DVec3, DVec3),
}

impl ConvexPair<'_> {
    /// How long the contact in progress at `tau` certainly lasts, from balls in both shapes: the
    /// balls about `deepest` (or the witness points), the balls about each shape's middle, balls
    /// deeper in each shape than `deepest`, and each near ball with the other shape's deeper one;
    /// from the chords of those points; and from a point inside both sliding through a along
    /// `slide` (the way the region inside both slid since the last probe, when known).
    fn hold(
        &self,
        tau: f64,
        (a, pose_a): (&Scaled, &Pose),
        (b, pose_b): (&Scaled, &Pose),
        deepest: Deepest,
        slide: Option<DVec3>,
        slack: f64,
    ) -> f64 {
        // The balls' certificate is for a straight relative motion (a pair passing through each
        // other in detect mode falls under one gravity).
        if self.acceleration != DVec3::ZERO {
            return 0.0;
        }
        let (mass_a, mass_b) = (DVec3::ZERO, self.offset + self.velocity * tau);
        let ball_a = |(centre, radius)| InnerBall { centre, radius, drift: self.a.drift_of(centre, mass_a) };
        let ball_b = |(centre, radius)| InnerBall { centre, radius, drift: self.b.drift_of(centre, mass_b) };
        let (middle_a, middle_b) = self.middles;
        let middle_a = middle_a.map(|(centre, radius)| ball_a((*pose_a * centre, radius)));
        let middle_b = middle_b.map(|(centre, radius)| ball_b((*pose_b * centre, radius)));
        // Balls deeper in each shape, as wide as the middle ones: while the shapes pass through
        // or leave each other, their centres part at the rate along the contact's normal, not
        // at the pair's whole speed. A centre outside its shape holds no ball.
        let inside = |shape: &Scaled, pose: &Pose, centre: DVec3| {
            let depth = shape.depth_only(pose.inverse_transform_point(centre));
            (depth > 0.0).then_some((centre, depth))
        };
        let (near, inward) = match deepest {
            Deepest::Inside { point, depths, inward } => (((point, depths.0), (point, depths.1)), inward),
            Deepest::Witnesses(x, y) => {
                let inward_of = |shape: &Scaled, pose: &Pose, p: DVec3| {
                    pose.rotation * shape.depth_at(pose.inverse_transform_point(p)).1
                };
                (((x, 0.0), (y, 0.0)), (inward_of(a, pose_a, x), inward_of(b, pose_b, y)))
            }
        };
        let width = |middle: Option<InnerBall>| middle.map_or(0.0, |m| m.radius);
        let deep_a = inside(a, pose_a, near.0 .0 + inward.0 * width(middle_a)).map(ball_a);
        let deep_b = inside(b, pose_b, near.1 .0 + inward.1 * width(middle_b)).map(ball_b);
        let (near_a, near_b) = (Some(ball_a(near.0)), Some(ball_b(near.1)));
        let limit = ceiling(self.tol);
        let balls = [(near_a, near_b), (middle_a, middle_b), (deep_a, deep_b), (near_a, deep_b), (deep_a, near_b)]
            .into_iter()
            .filter_map(|(x, y)| Some(held(x?, y?, self.velocity, limit, slack)))
            .fold(0.0, f64::max);
        // The chords (see [`super::chord`]) below the middle of the band in which a contact ends:
        // of the deepest point (or a's witness) fixed in a, of it (or b's) fixed in b, and of a
        // point inside both sliding through a; none when a spin does not give its angular
        // velocity.
        let Some((moving_a, moving_b)) = self.moving(tau, (a, pose_a), (b, pose_b)) else { return balls };
        // The deepest point's signed distances from a and from b are minus its depths there, to
        // the bit: the chords need not measure them again (two of a chord's five or so).
        let (points, inside, signed) = match deepest {
            Deepest::Inside { point, depths, .. } => ((point, point), point, Some((-depths.0, -depths.1))),
            Deepest::Witnesses(x, y) => ((x, y), 0.5 * (x + y), None),
        };
        let swapped = signed.map(|(in_a, in_b)| (in_b, in_a));
        let level = ending(self.tol);
        let fixed = chord_hold(points.0, signed, &moving_a, &moving_b, level, slack)
            .max(chord_hold(points.1, swapped, &moving_b, &moving_a, level, slack));
        let sliding =
            slide.map_or(0.0, |drift| sliding_hold((inside, signed), drift, &moving_a, &moving_b, level, slack));
        balls.max(fixed).max(sliding)
    }

    /// How long the shapes certainly stay farther apart than the middle of the band in which a
    /// contact starts, by their separation along `axis` (from a to b) turned with either (see
    /// [`super::chord::axis_hold`]): 0 when a spin does not give its angular velocity.
    fn apart(
        &self,
        tau: f64,
        (a, pose_a): (&Scaled, &Pose),
        (b, pose_b): (&Scaled, &Pose),
        axis: DVec3,
        slack: f64,
    ) -> f64 {
        let Some((moving_a, moving_b)) = self.moving(tau, (a, pose_a), (b, pose_b)) else { return 0.0 };
        let level = starting(self.tol);
        axis_hold(axis, &moving_a, &moving_b, level, slack).max(axis_hold(-axis, &moving_b, &moving_a, level, slack))
    }

    /// The two bodies at `tau` as the chord certificates read them; `None` when a spin does not
    /// give its angular velocity, or when the relative motion is not straight (a body falling
    /// past static geometry: the certificates are for a straight relative motion).
    fn moving<'s, 'b>(
        &self,
        tau: f64,
        (a, pose_a): (&'s Scaled<'b>, &'s Pose),
        (b, pose_b): (&'s Scaled<'b>, &'s Pose),
    ) -> Option<(Moving<'s, 'b>, Moving<'s, 'b>)> {
        if self.acceleration != DVec3::ZERO {
            return None;
        }
        let (turning_a, turning_b) = (self.a.turning(tau)?, self.b.turning(tau)?);
        let (radius_a, radius_b) = (self.a.geometry.size() * self.scale, self.b.geometry.size() * self.scale);
        let moving_a = Moving {
            shape: a,
            pose: pose_a,
            centre: DVec3::ZERO,
            radius: radius_a,
            velocity: DVec3::ZERO,
            turning: turning_a,
        };
        let centre = self.offset + self.velocity * tau;
        let moving_b =
            Moving { shape: b, pose: pose_b, centre, radius: radius_b, velocity: self.velocity, turning: turning_b };
        Some((moving_a, moving_b))
    }

    /// The best spin-free bound along the line of centres: a spinning body stays in its bounding
    /// sphere, so its sphere against the other shape (or both spheres) is a lower bound that only
    /// the straight motion and the other's spin shrink.
    pub(super) fn far(
        &self,
        tau: f64,
        (a, pose_a): (&Scaled, &Pose),
        (b, pose_b): (&Scaled, &Pose),
        slack: f64,
    ) -> (f64, f64) {
        // The centres of mass: a's at the origin of the frame.
        let centre = self.centre(tau);
        let Some(n) = direction(centre).filter(|_| self.spin > 0.0) else { return NO_FAR };
        let (radius_a, radius_b) = (self.a.geometry.size() * self.scale, self.b.geometry.size() * self.scale);
        let (spin_a, spin_b) = (self.a.spin_rate_along(n) * self.scale, self.b.spin_rate_along(n) * self.scale);
        let closing = (-self.velocity_at(tau).dot(n)).max(0.0);
        let centres = n.dot(centre);
        let near_b = n.dot(b.support_point(pose_b, -n));
        let near_a = n.dot(a.support_point(pose_a, n));
        let guard = guard(self.tol);
        [
            (centres - radius_a - radius_b, closing),
            (near_b - radius_a, closing + spin_b),
            (centres - radius_b - near_a, closing + spin_a),
        ]
        .map(|(lower, shrink)| (lower - slack, shrink))
        .into_iter()
        .filter(|&(lower, _)| lower > guard)
        .max_by(|x, y| {
            let step = |(lower, shrink): (f64, f64)| (lower - guard) / shrink;
            step(*x).total_cmp(&step(*y))
        })
        .unwrap_or(NO_FAR)
    }

    /// How fast turning can shrink the separation along the fixed unit axis `n` (scaled).
    fn spin_along(&self, n: DVec3) -> f64 {
        (self.a.spin_rate_along(n) + self.b.spin_rate_along(n)) * self.scale
    }

    /// b's centre of mass in the frame (a's at its origin) `tau` after the reference.
    pub(super) fn centre(&self, tau: f64) -> DVec3 {
        along(self.offset, self.velocity, self.acceleration, tau)
    }

    /// b's velocity relative to a's `tau` after the reference.
    fn velocity_at(&self, tau: f64) -> DVec3 {
        speeding(self.velocity, self.acceleration, tau)
    }

    /// The shapes' bounds at their poses, converged, the depth to rounding: what a contact's
    /// reported geometry is measured from.
    pub(super) fn exact_bounds(&self, (pose_a, pose_b): (&Pose, &Pose)) -> Bounds {
        let (ga, gb) = &self.shapes;
        convex_bounds(ga, pose_a, gb, pose_b, Need::converged(Some(EXACT_DEPTH)), self.tol, 0.0)
    }

    /// Where the shapes touch `tau` after the reference, in world coordinates, from their exact
    /// bounds there (see [`super::contact_geometry`]).
    pub(super) fn contact_point(&self, tau: f64, (pose_a, pose_b): (&Pose, &Pose), exact: Bounds) -> ContactPoint {
        let (ga, gb) = &self.shapes;
        let witness = exact
            .witness
            .unwrap_or_else(|| (ga.support_point(pose_a, exact.axis), gb.support_point(pose_b, -exact.axis)));
        contact_point(self.a.centre(tau), witness, exact, DQuat::IDENTITY, self.scale)
    }

    pub(super) fn poses(&self, tau: f64) -> (Pose, Pose) {
        let centre = self.centre(tau);
        (
            self.a.pose(self.a.orientation(tau), DVec3::ZERO, self.scale),
            self.b.pose(self.b.orientation(tau), centre, self.scale),
        )
    }
}

impl Gauge for ConvexPair<'_> {
    fn probe(&self, tau: f64, measure: Measure) -> Probe {
        let (pose_a, pose_b) = self.poses(tau);
        let slack = SLACK * (pose_b.translation.length() + self.size);
        let (ga, gb) = (&self.shapes.0, &self.shapes.1);
        let velocity = self.velocity_at(tau);
        let grow = velocity.length() + self.spin;
        let bend = self.acceleration.length();
        if matches!(measure, Measure::Contact(_)) {
            if let Some(warm) = self.warm.borrow_mut().as_mut() {
                let (upper, deepest) = warm.contact_upper((ga, &pose_a), (gb, &pose_b), slack);
                let room = |upper: f64| 2.0 * self.tol - upper;
                if upper <= CARRIED_UPPER * self.tol && room(upper) >= STALE_ROOM * room(warm.upper) {
                    // Far from the contact's end: nothing else is needed, and the warm start stays,
                    // holding the deepest bound yet (the room a later carried bound is held to) and
                    // the deepest point, fixed in a.
                    let point = match deepest {
                        Deepest::Inside { point, .. } => Some(point),
                        Deepest::Witnesses(..) => None,
                    };
                    let slide = warm.slide(tau, point, &pose_a);
                    warm.upper = upper.min(warm.upper);
                    warm.hold_inside(tau, point, &pose_a);
                    let hold = self.hold(tau, (ga, &pose_a), (gb, &pose_b), deepest, slide, slack);
                    let lower = f64::NEG_INFINITY;
                    return Probe { lower, upper, shrink: grow, grow, far: NO_FAR, hold, bend, parting: false };
                }
            }
        }
        // Each shape's frame moves with its body.
        let carry = (&pose_a, &pose_b);
        let mut slot = self.warm.borrow_mut();
        let warm = slot.as_ref();
        // GJK starts from the last probe's axis turned with a; a gap far from contact needs its
        // distance only to a share (it steps the search and decides nothing).
        let gap = measure == Measure::Gap;
        let need = Need {
            depth: (!gap).then_some(PROBE_DEPTH_SHARE),
            gap_share: if gap { GAP_SHARE } else { 0.0 },
            resolution: PROBE_RESOLUTION,
            start: warm.map(|warm| pose_a.rotation * warm.axis.0),
            simplex: warm.and_then(|warm| warm.simplex.as_ref()),
        };
        let bounds = match warm {
            // A contact's end search starts cold at the contact's start, where the caller reports
            // where the shapes touch: one exact measure serves both (the slack then added, as a
            // probe's bounds must hold it).
            None if matches!(measure, Measure::Contact(_)) => {
                let exact = self.exact_bounds((&pose_a, &pose_b));
                if self.measured.get().is_none() {
                    self.measured.set(Some((tau, self.contact_point(tau, (&pose_a, &pose_b), exact))));
                }
                Bounds { lower: exact.lower - slack, upper: exact.upper + slack, ..exact }
            }
            _ => warm
                .and_then(|warm| warm.bounds((ga, &pose_a), (gb, &pose_b), carry, self.tol, slack))
                .unwrap_or_else(|| convex_bounds(ga, &pose_a, gb, &pose_b, need, self.tol, slack)),
        };
        let inside = inside_point(&bounds);
        let slide = warm.and_then(|warm| warm.slide(tau, inside, &pose_a));
        Warm::renew(&mut slot, &bounds, carry);
        if let Some(next) = slot.as_mut() {
            next.hold_inside(tau, inside, &pose_a);
        }
        drop(slot);
        // Negative where the pair leaves along the axis faster than turning can close it.
        let (turn, closing) = (self.spin_along(bounds.axis), -velocity.dot(bounds.axis));
        let shrink = turn + closing;
        // Apart and never closer along the axis: the start search's step on it is infinite, so
        // neither the certificate nor the spin-free bound could step it farther; most pairs a
        // broad phase reports that never touch end on such a probe, often their first.
        let receding = gap && bend == 0.0 && shrink <= 0.0 && bounds.lower > guard(self.tol);
        let in_contact = matches!(measure, Measure::Contact(_)) && !(bounds.lower > cleared(self.tol));
        let parting = in_contact
            && measure == Measure::Contact(Then::NextStart)
            && parts_for_good(self, (&pose_a, &pose_b), &bounds, slack);
        let hold = match (measure, bounds.witness) {
            // A contact whose end this probe finds needs no step out of it, nor one that parts
            // for good from here when only what follows it is asked.
            (_, Some((x, y))) if in_contact && !parting => {
                self.hold(tau, (ga, &pose_a), (gb, &pose_b), Deepest::Witnesses(x, y), slide, slack)
            }
            (Measure::Gap, _) if bounds.lower > guard(self.tol) && !receding && turn > APART_TURN * closing => {
                self.apart(tau, (ga, &pose_a), (gb, &pose_b), bounds.axis, slack)
            }
            _ => 0.0,
        };
        Probe {
            lower: bounds.lower,
            upper: bounds.upper,
            shrink,
            grow,
            // Only a start search steps on it (see [`Probe::approach_step`]).
            far: if gap && !receding { self.far(tau, (ga, &pose_a), (gb, &pose_b), slack) } else { NO_FAR },
            hold,
            bend,
            parting,
        }
    }

    fn reach(&self, within: f64) -> Option<Reach> {
        spheres_reach((self.offset, self.velocity, self.acceleration), self.size, within)
    }

    fn forget(&self) {
        *self.warm.borrow_mut() = None;
    }
    fn warm_start(&self) -> Option<Option<Warm>> {
        Some(*self.warm.borrow())
    }
    fn set_warm_start(&self, warm: Option<Warm>) {
        *self.warm.borrow_mut() = warm;
    }
    fn translating(&self) -> bool {
        // On a bent relative path the distance need not be convex in time.
        self.a.still.is_some() && self.b.still.is_some() && self.acceleration == DVec3::ZERO
    }
    fn moving_as_one(&self) -> bool {
        self.translating() && self.velocity == DVec3::ZERO
    }
}

/// The pair-specific gauge of two shapes. Kept unboxed: one per search, on the stack, and a box
/// would allocate per search.
#[allow(clippy::large_enum_variant)]
pub(super) enum PairGauge<'a> {
    Convex(ConvexPair<'a>),
    /// `flipped`: the plane is the pair's first body.
    Plane(PlanePair<'a>, bool),
    Mesh(MeshPair<'a>, bool),
}

impl Gauge for PairGauge<'_> {
    fn probe(&self, tau: f64, measure: Measure) -> Probe {
        match self {
            PairGauge::Convex(g) => g.probe(tau, measure),
            PairGauge::Plane(g, _) => g.probe(tau, measure),
            PairGauge::Mesh(g, _) => g.probe(tau, measure),
        }
    }
    fn reach(&self, within: f64) -> Option<Reach> {
        match self {
            PairGauge::Convex(g) => g.reach(within),
            PairGauge::Plane(g, _) => g.reach(within),
            PairGauge::Mesh(g, _) => g.reach(within),
        }
    }
    fn forget(&self) {
        match self {
            PairGauge::Convex(g) => g.forget(),
            PairGauge::Plane(g, _) => g.forget(),
            PairGauge::Mesh(g, _) => g.forget(),
        }
    }
    fn warm_start(&self) -> Option<Option<Warm>> {
        match self {
            PairGauge::Convex(g) => g.warm_start(),
            PairGauge::Plane(g, _) => g.warm_start(),
            PairGauge::Mesh(g, _) => g.warm_start(),
        }
    }
    fn set_warm_start(&self, warm: Option<Warm>) {
        match self {
            PairGauge::Convex(g) => g.set_warm_start(warm),
            PairGauge::Plane(g, _) => g.set_warm_start(warm),
            PairGauge::Mesh(g, _) => g.set_warm_start(warm),
        }
    }
    fn translating(&self) -> bool {
        match self {
            PairGauge::Convex(g) => g.translating(),
            PairGauge::Plane(..) | PairGauge::Mesh(..) => false,
        }
    }
    fn moving_as_one(&self) -> bool {
        match self {
            PairGauge::Convex(g) => g.moving_as_one(),
            PairGauge::Plane(..) | PairGauge::Mesh(..) => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::narrow_phase::shapes::distance::{Need, EXACT_DEPTH};
    use glam::DQuat;
    use rand::{Rng, SeedableRng};

    /// The carried upper bound of a contact probe is never below the signed distance (parry's
    /// contact query), however far the shapes moved and turned since the measure it carries, and
    /// it is tight (within a few tenths of the depth) where it was measured.
    /// A probe decides whether a pair touches even where a rough GJK takes the shapes for
    /// intersecting: a cone's rim 1.3e-6 from a cylinder's (a pose met in the rest scene, seed 12
    /// under gravity down y) gave bounds from -8 to +1.08 tolerances, so the search could not say
    /// whether the pair touched at its reference, and took it for a contact there over and over.
    #[test]
    fn a_probe_a_hair_from_contact_decides_the_touch() {
        use crate::shape::Shape;
        let cone = Shape::Cone { half_height: 0.3, radius: 0.35 }.geometry().unwrap();
        let cylinder = Shape::Cylinder { half_height: 0.3, radius: 0.3 }.geometry().unwrap();
        let (a, b) = (Scaled::new(&cone, 2.0), Scaled::new(&cylinder, 2.0));
        let pose_a = Pose::from_parts(
            DVec3::new(-0.0756406398250358, 0.1098075833417988, -0.26873925698988455),
            DQuat::from_xyzw(0.4582929894338157, -0.6443682401464725, 0.32703959535929095, -0.5174960965973425),
        );
        let pose_b = Pose::from_parts(
            DVec3::new(0.22494252126929126, -0.5522414356015496, -1.1301568575575178),
            DQuat::from_xyzw(0.12712706146338829, 0.9879166020415311, 0.0713567158459498, 0.05260909387246088),
        );
        let (tol, slack) = (1.7485281374256056e-6, 4.3006995429890864e-14);
        let exact = convex_bounds(&a, &pose_a, &b, &pose_b, Need::converged(Some(EXACT_DEPTH)), tol, slack);
        assert!(exact.lower > 0.7 * tol && exact.upper < 0.8 * tol, "{exact:?}");
        let probe = convex_bounds(&a, &pose_a, &b, &pose_b, Need::probe(Some(PROBE_DEPTH_SHARE)), tol, slack);
        assert!(probe.upper - probe.lower <= tol, "bounds {} tolerances apart", (probe.upper - probe.lower) / tol);
        // Touching: at most `tol` less the margin apart, as the search asks at its reference.
        let touch = tol * (1.0 - crate::narrow_phase::shapes::MARGIN);
        assert!(probe.upper <= touch && probe.lower <= exact.upper, "{probe:?}");
    }

    #[test]
    fn the_carried_contact_bound_is_an_upper_bound() {
        let shapes = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut random = move || rng.random_range(-0.5..0.5);
        let (mut measured, mut ratio) = (0, 0.0);
        for case in 0..3000 {
            let (ga, gb) = (&shapes[case % 6], &shapes[(case / 6) % 6]);
            let (a, b) = (Scaled::new(ga, 1.0), Scaled::new(gb, 1.0));
            let mut turn = || DQuat::from_xyzw(random(), random(), random(), random()).normalize();
            let (qa, qb) = (turn(), turn());
            let offset =
                DVec3::new(random(), random(), random()).normalize_or(DVec3::X) * (0.1 + 0.6 * (random() + 0.5));
            let (pose_a, pose_b) = (Pose::from_parts(DVec3::ZERO, qa), Pose::from_parts(offset, qb));
            let bounds = convex_bounds(&a, &pose_a, &b, &pose_b, Need::converged(Some(EXACT_DEPTH)), 1e-6, 1e-14);
            let Some(warm) = Warm::new(&bounds, (&pose_a, &pose_b)) else { continue };
            let (here, _) = warm.contact_upper((&a, &pose_a), (&b, &pose_b), 1e-14);
            if bounds.upper < -1e-3 {
                measured += 1;
                ratio += here / bounds.upper;
            }
            // Moved on: both shapes shifted and turned a little.
            let nudge = DVec3::new(random(), random(), random()) * 0.1;
            let spin = DQuat::from_scaled_axis(DVec3::new(random(), random(), random()) * 0.3);
            let (later_a, later_b) = (Pose::from_parts(nudge, spin * qa), Pose::from_parts(offset - nudge, qb));
            let (upper, _) = warm.contact_upper((&a, &later_a), (&b, &later_b), 1e-14);
            let relative = later_a.inv_mul(&later_b);
            let parry = parry3d_f64::query::contact(
                &Pose::IDENTITY,
                ga.parry_shape().as_ref(),
                &relative,
                gb.parry_shape().as_ref(),
                1.0,
            );
            if let Ok(Some(contact)) = parry {
                assert!(upper >= contact.dist - 1e-9, "case {case}: {upper} below parry's {}", contact.dist);
            }
        }
        assert!(measured > 500, "only {measured} intersecting cases");
        let mean = ratio / measured as f64;
        assert!(mean > 0.5, "the carried bound is loose where it was measured: {mean} of the depth on average");
    }
}
