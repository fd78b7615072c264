//! Distance bounds between two placed shapes: closed forms where the shapes allow them, GJK with
//! refinement and projections otherwise, and for meshes the bounds of their triangles' tree.
//! Each query returns a lower and an upper bound on the separation, tight near contact and
//! relative far from it; it owns that arithmetic and never decides a contact time.

use super::epa::penetration;
use super::gjk::{self, Relative};
use super::scaled::{hull_nearest, refine, Core, HullPoint, Kind, Scaled};
use super::MARGIN;
use glam::DVec3;
use parry3d_f64::math::Pose;
use parry3d_f64::partitioning::BvhLeafCost;
use parry3d_f64::query::details::{closest_points_segment_segment_with_locations_nD, contact_support_map_support_map};
use parry3d_f64::query::gjk::{CsoPoint, GJKResult, VoronoiSimplex};
use parry3d_f64::query::point::local_point_projection_on_support_map;
use parry3d_f64::query::{PointProjection, PointQuery};
use parry3d_f64::shape::{Ball, Capsule, Cone, Cuboid, Cylinder, Segment, SupportMap};

/// Within this many tolerances of contact the distance bounds are tightened to a fraction of the
/// tolerance; beyond, they need only be tight relative to the distance, which sets the step.
pub(super) const BAND: f64 = 8.0;

/// Projections, alternating between the shapes, that look for closer points from each shape's
/// extreme point a few tolerances from contact (see `closer_points`).
pub(super) const PROJECTION_ROUNDS: usize = 4;

/// Separation of `a` and `b` along the unit axis `n` from a to b: a lower bound on their signed
/// distance.
pub(super) fn separation(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose, n: DVec3) -> f64 {
    n.dot(b.support_point(pose_b, -n) - a.support_point(pose_a, n))
}

/// Climbs the separation of `a` and `b` over the axes around `best.1` by a pattern search with
/// shrinking steps. For curved surfaces a hair apart the separation falls off with the square of
/// the axis error times the curvature, and GJK's axis can be off by 1e-2 there; where a surface
/// is ruled (a cylinder's side, an edge) the best axes form a ridge orthogonal to the ruling, so
/// the search also moves along each such ridge, which keeps the axis exactly orthogonal to it.
pub(super) fn polish(
    a: &Scaled,
    pose_a: &Pose,
    b: &Scaled,
    pose_b: &Pose,
    mut best: (f64, DVec3),
    enough: f64,
) -> (f64, DVec3) {
    let mut step = 1.0 / 64.0;
    let mut evaluations = 0;
    // Below a step of 1e-6 the separation of curved surfaces changes by 1e-12 of their size.
    while step > 1e-6 && evaluations < 640 && best.0 < enough {
        let n = best.1;
        let (fa, fb) = (a.features(pose_a.rotation, n), b.features(pose_b.rotation, -n));
        let (t1, t2) = n.any_orthonormal_pair();
        let ridges = fa.edges().iter().chain(fb.edges()).filter_map(|e| e.cross(n).try_normalize());
        let mut improved = false;
        for d in [t1, t2].into_iter().chain(ridges) {
            for sign in [1.0, -1.0] {
                let m = (n + d * (sign * step)).normalize();
                let gap = separation(a, pose_a, b, pose_b, m);
                evaluations += 1;
                if gap > best.0 {
                    best = (gap, m);
                    improved = true;
                }
            }
        }
        if !improved {
            step *= 0.25;
        }
    }
    best
}

/// The point of the shape nearest to `point` (both in the frame of `pose`, scaled), and its
/// distance: an upper bound on the distance of the two shapes when `point` belongs to the other
/// one. Any point parry returns lies in the shape (a support-map projection is a convex
/// combination of support points), so the bound is valid whatever the projection's accuracy; a
/// point found inside gives nothing, since that verdict is not certain.
pub(super) fn nearest(shape: &Scaled, pose: &Pose, point: DVec3) -> Option<(f64, DVec3)> {
    let local = pose.inverse_transform_point(point);
    // Everything in scaled lengths, where parry's absolute tolerances mean the same at any scale:
    // closed forms on a scaled copy of a primitive, a hull's faces, GJK on the scaled support map
    // otherwise.
    let (p, s) = (shape.parry, shape.scale);
    let projection = match shape.kind {
        Kind::Ball(ball) => Ball::new(ball.radius * s).project_local_point(local, true),
        Kind::Cuboid(cuboid) => Cuboid::new(cuboid.half_extents * s).project_local_point(local, true),
        Kind::Capsule(c) => {
            Capsule::new(c.segment.a * s, c.segment.b * s, c.radius * s).project_local_point(local, true)
        }
        Kind::Cylinder(c) => Cylinder::new(c.half_height * s, c.radius * s).project_local_point(local, true),
        Kind::Cone(c, _) => Cone::new(c.half_height * s, c.radius * s).project_local_point(local, true),
        Kind::Hull(hull, planes) => match hull_nearest(hull, planes, local * shape.inverse_scale) {
            HullPoint::Outside(on) => PointProjection::new(false, on * s),
            HullPoint::Inside(_) => return None,
        },
        _ if s == 1.0 => p.project_local_point(local, true),
        _ => local_point_projection_on_support_map(shape, &mut VoronoiSimplex::new(), local, true),
    };
    (!projection.is_inside).then(|| ((local - projection.point).length(), pose * projection.point))
}

/// The closer of `known` (a distance and the points at it) and the pairs met projecting each of
/// the known points, and each shape's extreme point along `axis` (from a to b) if given, on the
/// other shape, and back, `rounds` times in all: alternating projections approach closest points,
/// also where GJK's are off or an extreme point is an arbitrary point of a flat face.
pub(super) fn closer_points(
    (a, pose_a): (&Scaled, &Pose),
    (b, pose_b): (&Scaled, &Pose),
    known: (f64, Option<(DVec3, DVec3)>),
    axis: Option<DVec3>,
    rounds: usize,
) -> (f64, Option<(DVec3, DVec3)>) {
    let mut closest = known;
    let known_points = known.1.map(|(x, y)| [(true, y), (false, x)]);
    let extreme = axis.map(|m| [(true, b.support_point(pose_b, -m)), (false, a.support_point(pose_a, m))]);
    // From a point of b, projecting on a, then on b, and so on; from a point of a, the other way.
    for (from_b, mut point) in known_points.into_iter().chain(extreme).flatten() {
        for round in 0..rounds {
            let onto_a = from_b == (round % 2 == 0);
            let Some((d, projected)) = (if onto_a { nearest(a, pose_a, point) } else { nearest(b, pose_b, point) })
            else {
                break;
            };
            if d < closest.0 {
                closest = (d, Some(if onto_a { (projected, point) } else { (point, projected) }));
            }
            point = projected;
        }
    }
    closest
}

/// How tight a depth must be: EPA may stop once its bound is within `share` of the depth plus
/// `tol` of the true one, or within `resolution` of it within [`BAND`] tolerances of contact
/// ([`EXACT_DEPTH`], or a resolution of 0 there: converged, to rounding, by parry).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct DepthNeed {
    pub(super) share: f64,
    pub(super) tol: f64,
    pub(super) resolution: f64,
}

/// The share of a depth a search's probes leave EPA (see [`DepthNeed`]): a step out of a deep
/// contact on a bound this much short goes at most this much less far. EPA run to convergence
/// took 17 support points a call on mixed shapes (the CLI's crowd), about 5 at 1/32; 1/8 saves
/// a further 0.6 to 0.8 % of the instructions at 0.5 and 5 d/f (the steps rarely rest on the
/// depth alone: the chords' holds reach farther), 1/4 nothing more.
pub(super) const PROBE_DEPTH_SHARE: f64 = 1.0 / 8.0;

/// How far apart, in tolerances, a search's probe may leave its bounds on a distance or a shallow
/// depth (within [`BAND`] tolerances of contact): well inside the half margin its bounds must
/// decide within. Converged instead, parry's GJK refines a distance to 1.5e-8 of itself (3 % of
/// the peers' mixed shapes, most of it GJK on rounded shapes), and parry's contact query for a
/// shallow depth runs GJK again, then EPA to rounding (70,000 instructions a call, 6 %).
pub(super) const PROBE_RESOLUTION: f64 = MARGIN / 16.0;

/// The depth share of a measure that must be exact: EPA run to convergence (contact geometry).
pub(super) const EXACT_DEPTH: f64 = 0.0;

/// A gap probe this many tolerances or more from contact needs its distance only to a share
/// ([`GAP_SHARE`]): it steps the search by the distance over a rate, and no bound there decides.
pub(super) const ROUGH_FLOOR: f64 = 64.0;

/// The share of a distance beyond [`ROUGH_FLOOR`] tolerances a gap probe leaves GJK: a step on a
/// lower bound this much short goes at most this much less far. parry's GJK refines every
/// distance to about 5e-8 of itself, some 11 support points a call far from contact on the CLI's
/// crowd of mixed shapes; the searches' probes there are as many at this share, and half as dear.
pub(super) const GAP_SHARE: f64 = 1.0 / 16.0;

/// Points GJK starts from instead of a support point: not themselves support points, so GJK may
/// stop where a new support point falls in their plane, short of converging (its bounds stay
/// bounds, looser, which a chain's probes then tighten where it matters). With `verify`, a result
/// that did not converge is measured again from a support point.
#[derive(Clone, Copy)]
pub(super) struct Seed<'s> {
    simplex: &'s Simplex,
    verify: bool,
}

/// How close to the distance of GJK's closest points the separation along their line must come
/// for a GJK started from carried points to count as converged (see [`converged`]).
const SEEDED_PRECISION: f64 = 1e-6;

/// Whether the points `p1` of `a` and `p2` of `b` (at `relative`) lie within [`SEEDED_PRECISION`]
/// of their distance of the sets' separation along the line through them.
fn converged<A: SupportMap, B: SupportMap>(relative: &Relative, (a, b): (&A, &B), (p1, p2): (DVec3, DVec3)) -> bool {
    let (n, distance) = (p2 - p1).normalize_and_length();
    distance == 0.0 || distance + n.dot(relative.support(a, b, n).point) <= SEEDED_PRECISION * distance
}

/// GJK's iterations before a rough query hands its simplex to the converged GJK
/// ([`gjk::closest_points`]). A rough query seldom needs more than a dozen; handing over after 8
/// cost 3 to 4 % more instructions on the mixed shapes at every speed (measured against 32, when
/// the converged GJK was parry's and started over).
const ROUGH_ITERATIONS: usize = 32;

/// What a distance query must measure, beyond bounds tight enough to decide near contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Need<'s> {
    /// `None`: an intersection need only be recognised; otherwise the share of its depth EPA may
    /// leave (see [`DepthNeed`]).
    pub(super) depth: Option<f64>,
    /// Beyond [`ROUGH_FLOOR`] tolerances from contact, the share of the distance GJK's bounds may
    /// leave between them: 0 to converge.
    pub(super) gap_share: f64,
    /// Nearer, how far apart (in tolerances) the bounds may lie: [`PROBE_RESOLUTION`] for a
    /// search's probe, 0 to converge (a measure that is reported).
    pub(super) resolution: f64,
    /// Where GJK starts: a unit axis from the first shape to the second (world frame), the last
    /// probe's on a chain; `None` to start from the line between the shapes' middles.
    pub(super) start: Option<DVec3>,
    /// Points of the two cores whose differences GJK starts from instead: the last probe's
    /// simplex on a chain, carried along with the bodies. Lent, not copied: it is 200 bytes,
    /// and a need passes through two calls.
    pub(super) simplex: Option<&'s Simplex>,
}

/// Pairs of points, one of each core in that shape's own frame, whose differences are points of
/// the cores' Minkowski difference: the vertices of GJK's last simplex. Fixed in the bodies they
/// stay points of the cores wherever the bodies go, so the next probe's GJK (or EPA, where they
/// still hold the origin) starts from them, near where the last one ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Simplex {
    points: [(DVec3, DVec3); 4],
    count: usize,
}

impl Simplex {
    /// Each pair's points moved by `grow`: points of the two shapes again where the moves keep
    /// them in their shapes (a core's point moved by at most the shape's margin).
    fn mapped(&self, grow_a: impl Fn(DVec3) -> DVec3, grow_b: impl Fn(DVec3) -> DVec3) -> Simplex {
        Simplex { points: self.points.map(|(x, y)| (grow_a(x), grow_b(y))), count: self.count }
    }

    /// GJK's `simplex` of the sets at `relative` (the second's pose in the first's frame).
    fn of(simplex: &gjk::Simplex, relative: &Relative) -> Simplex {
        let pair = |i: usize| {
            let vertex = simplex.vertex(i.min(simplex.len() - 1));
            (vertex.orig1, relative.unapply(vertex.orig2))
        };
        Simplex { points: std::array::from_fn(pair), count: simplex.len() }
    }

    /// The pairs as GJK's simplex of the sets at `relative`, less any that would make it
    /// degenerate, written into `simplex`.
    fn load(&self, relative: &Relative, simplex: &mut gjk::Simplex) {
        let vertex = |(x, y): (DVec3, DVec3)| CsoPoint::new(x, relative.apply(y));
        simplex.restart(vertex(self.points[0]));
        for &pair in &self.points[1..self.count] {
            simplex.add(vertex(pair));
        }
    }
}

impl Need<'_> {
    /// Converged bounds, with the depth to `depth`'s share, GJK started between the middles.
    pub(super) fn converged(depth: Option<f64>) -> Self {
        Need { depth, gap_share: 0.0, resolution: 0.0, start: None, simplex: None }
    }

    /// A search's probe: bounds to [`PROBE_RESOLUTION`], the depth to `depth`'s share, GJK
    /// started between the middles.
    pub(super) fn probe(depth: Option<f64>) -> Self {
        Need { resolution: PROBE_RESOLUTION, ..Need::converged(depth) }
    }
}

/// Bounds on the signed distance of two shapes at one instant (scaled lengths, in the frame of
/// their poses).
#[derive(Debug, Clone, Copy)]
pub(super) struct Bounds {
    /// The separation along `axis`: at most the signed distance.
    pub(super) lower: f64,
    /// At least the signed distance.
    pub(super) upper: f64,
    /// Unit axis from the first shape to the second.
    pub(super) axis: DVec3,
    /// Points of the first and second shape whose distance is `upper` (or EPA's deepest points),
    /// when known.
    pub(super) witness: Option<(DVec3, DVec3)>,
    /// GJK's last simplex on the cores, when it ran.
    pub(super) simplex: Option<Simplex>,
}

/// A first estimate of the distance of two shapes (scaled, in the frame of their poses): closed
/// forms where they exist, GJK (and EPA when the shapes intersect) otherwise.
pub(super) struct Estimate {
    /// At least the signed distance; infinite when unknown.
    pub(super) upper: f64,
    /// Unit axis from the first shape to the second.
    pub(super) axis: DVec3,
    /// Points of the shapes whose distance is `upper`, when known.
    pub(super) witness: Option<(DVec3, DVec3)>,
    /// GJK's own last search direction (unit, world frame).
    pub(super) search: Option<DVec3>,
    /// EPA's depth (negative) and deepest points when the shapes intersect.
    pub(super) penetration: Option<(f64, (DVec3, DVec3))>,
    /// GJK's last simplex.
    pub(super) simplex: Option<Simplex>,
}

/// The estimate from closed forms when both cores are points or segments, or one is a point
/// outside the other shape: the cores' distance less the margins, exact to rounding, with its
/// witness points and axis. `None` otherwise.
pub(super) fn closed_form(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose) -> Option<Estimate> {
    let posed = |segment: &Segment, pose: &Pose| Segment::new(pose * segment.a, pose * segment.b);
    let on = |segment: &Segment, point: DVec3| segment.project_local_point(point, true).point;
    let (x, y) = match (&a.core, &b.core) {
        (Core::Point, Core::Point) => (pose_a.translation, pose_b.translation),
        (Core::Point, Core::Segment(t)) => (pose_a.translation, on(&posed(t, pose_b), pose_a.translation)),
        (Core::Segment(s), Core::Point) => (on(&posed(s, pose_a), pose_b.translation), pose_b.translation),
        (Core::Segment(s), Core::Segment(t)) => {
            let (s, t) = (posed(s, pose_a), posed(t, pose_b));
            let (at_s, at_t) = closest_points_segment_segment_with_locations_nD((&s.a, &s.b), (&t.a, &t.b));
            (s.point_at(&at_s), t.point_at(&at_t))
        }
        (Core::Point, Core::Solid(_)) => (pose_a.translation, nearest(b, pose_b, pose_a.translation)?.1),
        (Core::Solid(_), Core::Point) => (nearest(a, pose_a, pose_b.translation)?.1, pose_b.translation),
        _ => return None,
    };
    let (axis, distance) = (y - x).normalize_and_length();
    // Coincident cores (deep inside each other): any axis bounds the separation.
    let axis = if distance > 0.0 {
        axis
    } else {
        (pose_b.translation - pose_a.translation).try_normalize().unwrap_or(DVec3::X)
    };
    Some(Estimate {
        upper: distance - a.margin - b.margin,
        axis,
        witness: Some((x + axis * a.margin, y - axis * b.margin)),
        search: None,
        penetration: None,
        simplex: None,
    })
}

/// How far a rough GJK may stop short (see [`rough_closest`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Rough {
    share: f64,
    floor: f64,
    /// Nearer than `floor`, how far apart the bounds may lie: 0 to leave them to the converged
    /// GJK.
    resolution: f64,
}

/// GJK's iterations (the sets `a` and `b` at `relative`, grown by `margins`) from `simplex`, until
/// the separation along a direction it tried lies within `rough.share` of the distance of the
/// simplex's nearest points (points of the two sets) where the grown sets lie more than
/// `rough.floor` apart, or within `rough.resolution` of it: those points then; an intersection
/// where the simplex comes to hold the origin inside; `None` if neither comes within
/// [`ROUGH_ITERATIONS`] or the origin lies on the simplex's boundary (the simplex is then left
/// for the converged GJK, [`gjk::closest_points`], to go on from). Kept apart from that loop:
/// folded into it as an early stop, the measures took 1.3 % more instructions at 1e4 x 5 d/f
/// (not traced further).
fn rough_closest<A: SupportMap, B: SupportMap>(
    relative: &Relative,
    (a, b): (&A, &B),
    margins: (f64, f64),
    rough: Rough,
    simplex: &mut gjk::Simplex,
) -> Option<GJKResult> {
    let margin = margins.0 + margins.1;
    let mut lower = f64::NEG_INFINITY;
    for _ in 0..ROUGH_ITERATIONS {
        // The point of the simplex nearest the origin: a - b for a point of each set.
        let nearest = simplex.reduce();
        let upper = nearest.length();
        if simplex.len() == 4 {
            // The origin lies inside the tetrahedron: the sets intersect.
            return Some(GJKResult::Intersection);
        }
        if !(upper > 0.0) || (upper - margin <= rough.floor && rough.resolution == 0.0) {
            return None;
        }
        // The sets lie at least this far apart along `dir`, by the difference's support point.
        let dir = -nearest / upper;
        let support = relative.support(a, b, dir);
        lower = lower.max(-dir.dot(support.point));
        let far = lower - margin > rough.floor && upper - lower <= rough.share * (upper - margin);
        if far || upper - lower <= rough.resolution {
            let (on_a, on_b) = simplex.points();
            return Some(GJKResult::ClosestPoints(on_a, on_b, dir));
        }
        if !simplex.add(support) {
            return None;
        }
    }
    None
}

/// GJK's estimate (EPA's when the sets intersect and `depth` asks for it) from the sets `a` at
/// `pose_a` and `b` at `pose_b`, grown by `margins` into the shapes; `toward` (in a's frame) is
/// where GJK starts from and the axis to fall back on. With `rough`, GJK may stop short far from
/// contact ([`rough_closest`]).
pub(super) fn gjk_estimate<A: SupportMap, B: SupportMap>(
    (a, pose_a): (&A, &Pose),
    (b, pose_b): (&B, &Pose),
    margins: (f64, f64),
    toward: DVec3,
    depth: Option<DepthNeed>,
    rough: Option<Rough>,
    seed: Option<Seed>,
) -> Estimate {
    let relative = Relative::new(pose_a.inv_mul(pose_b));
    let mut estimate =
        Estimate { upper: f64::INFINITY, axis: toward, witness: None, search: None, penetration: None, simplex: None };
    let grown = |(p1, p2): (DVec3, DVec3), n: DVec3| (p1 + n * margins.0, p2 - n * margins.1);
    // GJK from `dir` (or the seed) in `simplex`, which it leaves as it ends.
    let gjk_from = |dir: DVec3, rough: Option<Rough>, seed: Option<Seed>, simplex: &mut gjk::Simplex| {
        let fresh = |simplex: &mut gjk::Simplex| simplex.restart(relative.support(a, b, dir));
        match seed {
            Some(seed) => seed.simplex.load(&relative, simplex),
            None => fresh(simplex),
        }
        if let Some(stopped) = rough.and_then(|rough| rough_closest(&relative, (a, b), margins, rough, simplex)) {
            return stopped;
        }
        match gjk::closest_points(&relative, a, b, simplex) {
            GJKResult::ClosestPoints(p1, p2, _)
                if seed.is_some_and(|seed| seed.verify) && !converged(&relative, (a, b), (p1, p2)) =>
            {
                fresh(simplex);
                gjk::closest_points(&relative, a, b, simplex)
            }
            found => found,
        }
    };
    let mut simplex = gjk::Simplex::new(CsoPoint::ZERO);
    let mut result = gjk_from(-toward, rough, seed, &mut simplex);
    estimate.simplex = Some(Simplex::of(&simplex, &relative));
    // A depth need only be as tight as asked: EPA from GJK's simplex, stopped early, deep inside
    // each other at a share of the depth, within the band at the resolution; a measure that asks
    // for none there takes parry's converged one.
    let deep = |need: DepthNeed, simplex: &gjk::Simplex| {
        let shallow = |depth: f64| depth + margins.0 + margins.1 < BAND * need.tol;
        let allowance = |depth: f64| {
            if shallow(depth) && need.resolution > 0.0 {
                need.resolution
            } else {
                need.share * (depth + margins.0 + margins.1 + need.tol)
            }
        };
        let found = (need.share > 0.0).then(|| penetration(&relative, a, b, simplex, allowance))??;
        (need.resolution > 0.0 || !shallow(found.depth)).then_some(found)
    };
    let early = (result == GJKResult::Intersection).then(|| depth.and_then(|need| deep(need, &simplex))).flatten();
    // GJK's verdict is not reliable a hair from contact: ask again from the other side, unless
    // EPA's polytope, points of the difference about the origin, already proved them inside each
    // other (to rounding: a hair apart after all, an axis separates them and EPA's points bound
    // their distance).
    if early.is_none() && !matches!(result, GJKResult::ClosestPoints(..)) {
        let again = gjk_from(toward, None, None, &mut gjk::Simplex::new(CsoPoint::ZERO));
        if matches!(again, GJKResult::ClosestPoints(..)) {
            result = again;
        }
    }
    match (result, early) {
        (GJKResult::ClosestPoints(p1, p2, dir), _) => {
            let d = p2 - p1;
            estimate.axis = d.try_normalize().unwrap_or(toward);
            estimate.upper = d.length() - margins.0 - margins.1;
            estimate.search = Some(pose_a.rotation * dir);
            estimate.witness = Some(grown((*pose_a * p1, *pose_a * p2), pose_a.rotation * estimate.axis));
        }
        (GJKResult::Intersection, _) if depth.is_none() => {}
        (_, Some(found)) => {
            estimate.axis = found.axis.try_normalize().unwrap_or(toward);
            let normal = pose_a.rotation * found.normal.try_normalize().unwrap_or(toward);
            let points = grown((*pose_a * found.points.0, *pose_a * found.points.1), normal);
            estimate.penetration = Some((-found.depth - margins.0 - margins.1, points));
            // Points of the shapes: where an axis proves them apart after all (a hair from
            // contact), their distance bounds the shapes'.
            (estimate.upper, estimate.witness) = ((points.1 - points.0).length(), Some(points));
        }
        // Intersecting (measure the depth), or GJK did not converge (try again).
        _ => {
            if let Some(contact) = contact_support_map_support_map(&relative.pose, a, b, f64::MAX) {
                estimate.axis = contact.normal1.try_normalize().unwrap_or(toward);
                let points =
                    grown((*pose_a * contact.point1, *pose_b * contact.point2), pose_a.rotation * estimate.axis);
                let dist = contact.dist - margins.0 - margins.1;
                if dist >= 0.0 {
                    estimate.upper = (points.1 - points.0).length();
                    estimate.witness = Some(points);
                } else {
                    estimate.penetration = Some((dist, points));
                }
            }
        }
    }
    estimate.axis = pose_a.rotation * estimate.axis;
    estimate
}

/// Lower and upper bounds on the signed distance of two convex support maps, with the axis (from
/// `a` to `b`) whose separation is the lower bound.
///
/// The upper bound is the distance of two points of the shapes (closest points from closed forms
/// or GJK, and each shape's extreme point along the axis projected on the other), or EPA's depth
/// when they intersect (EPA's polytope lies inside the Minkowski difference, so its depth never
/// exceeds the true one); the lower bound is a separation along an axis, computed from the exact
/// support functions. With `need.depth` `None`, an intersection only needs to be recognised, not
/// measured; otherwise a deep one is measured to within that share of the depth plus `tol`, a
/// shallow one to a small share of `tol`, or with the share 0 to rounding (see [`DepthNeed`]).
/// Far from contact the bounds may lie `need.gap_share` of the distance apart. GJK runs on the
/// cores, and on the shapes too where their distance is a small part of the cores' (its
/// precision is relative to the distance it measures). The bounds are tightened where it
/// matters: within a few `tol` of contact.
pub(super) fn convex_bounds(
    a: &Scaled,
    pose_a: &Pose,
    b: &Scaled,
    pose_b: &Pose,
    need: Need,
    tol: f64,
    slack: f64,
) -> Bounds {
    match measure(a, pose_a, b, pose_b, need, tol, slack) {
        (bounds, true) => bounds,
        // Measured again as a reported contact is, GJK converged from scratch.
        (_, false) => {
            let converged = Need { gap_share: 0.0, resolution: 0.0, start: None, simplex: None, ..need };
            measure(a, pose_a, b, pose_b, converged, tol, slack).0
        }
    }
}

/// [`convex_bounds`], and whether they decide: not where a rough GJK left them a tolerance apart
/// or more within [`BAND`] of contact. It can take shapes a hair apart for intersecting and leave
/// an axis too far off for the polish to climb back (a cone's rim on a cylinder's, 1.3e-6 apart:
/// bounds 9 tolerances wide, which could not say whether the pair touched).
fn measure(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose, need: Need, tol: f64, slack: f64) -> (Bounds, bool) {
    let band = BAND * tol;
    let resolution = need.resolution * tol;
    let depth = need.depth.map(|share| DepthNeed { share, tol, resolution });
    // The last probe's axis, or from the middle of a to the middle of b, in a's frame: where GJK
    // starts, and the axis to fall back on if it fails.
    let toward = match need.start {
        Some(axis) => pose_a.rotation.inverse() * axis,
        None => (pose_a.inv_mul(pose_b) * b.middle() - a.middle()).try_normalize().unwrap_or(DVec3::X),
    };
    let rough = (need.gap_share > 0.0 || resolution > 0.0).then_some(Rough {
        share: need.gap_share,
        floor: ROUGH_FLOOR * tol,
        resolution,
    });
    let (first, second) = match closed_form(a, pose_a, b, pose_b) {
        Some(exact) => (exact, None),
        None => {
            let margins = (a.margin, b.margin);
            let seed = need.simplex.map(|simplex| Seed { simplex, verify: false });
            let cores = (&a.core(), pose_a);
            let cores = gjk_estimate(cores, (&b.core(), pose_b), margins, toward, depth, rough, seed);
            let distance = cores.penetration.map_or(cores.upper, |(dist, _)| dist);
            // GJK's precision is relative to the distance it measures, the cores' with the
            // margins: where the shapes' own is a small part of it, GJK runs on them too, and the
            // tighter estimate counts (either fails at times a hair from contact).
            let near = distance.abs() < (margins.0 + margins.1) / 16.0;
            // It starts from the cores' last simplex grown into the shapes along their axis.
            let grown = |simplex: &Simplex| {
                let (along_a, along_b) =
                    (pose_a.rotation.inverse() * cores.axis, pose_b.rotation.inverse() * cores.axis);
                simplex.mapped(|x| x + along_a * margins.0, |y| y - along_b * margins.1)
            };
            let grown = cores.simplex.as_ref().map(grown);
            // A lone measure (a contact's geometry, reported as measured) must converge as if
            // GJK had started afresh.
            let seed = grown.as_ref().map(|simplex| Seed { simplex, verify: need.simplex.is_none() });
            (cores, near.then(|| gjk_estimate((a, pose_a), (b, pose_b), (0.0, 0.0), toward, depth, rough, seed)))
        }
    };
    let estimates = || std::iter::once(&first).chain(&second);
    // Every estimate bounds the distance: the closest points and the deepest overlap of any.
    let (mut upper, mut witness) =
        estimates().map(|e| (e.upper, e.witness)).fold((f64::INFINITY, None), |x, y| if y.0 < x.0 { y } else { x });
    let penetration = estimates().filter_map(|e| e.penetration).min_by(|x, y| x.0.total_cmp(&y.0));
    // The upper bound the shapes will get: EPA's depth stands unless an axis separates them.
    let effective = |best: (f64, DVec3), upper: f64| match penetration {
        Some((dist, _)) if best.0 <= 0.0 => dist.min(upper),
        _ => upper,
    };
    // Near contact the bounds must decide within the search's margins: a gap of half of one.
    let settled = |best: (f64, DVec3), upper: f64| best.0 >= effective(best, upper) - 2.0 * slack - 0.5 * MARGIN * tol;
    let mut best = (f64::NEG_INFINITY, first.axis);
    for estimate in estimates() {
        // GJK's own last search direction is often better than its closest points'.
        let search = estimate.search.map(|dir| if dir.dot(estimate.axis) < 0.0 { -dir } else { dir });
        for axis in std::iter::once(estimate.axis).chain(search) {
            if settled(best, upper) {
                break;
            }
            let gap = separation(a, pose_a, b, pose_b, axis);
            if gap > best.0 {
                best = (gap, axis);
            }
        }
    }
    // Near contact GJK loses accuracy (its simplices grow ill-conditioned), and a flat feature
    // makes the axis matter to first order: look for a tighter axis and for closer points.
    if !settled(best, upper) && best.0 < band && effective(best, upper) > -band {
        let mut closer = |m: DVec3| {
            (upper, witness) = closer_points((a, pose_a), (b, pose_b), (upper, witness), Some(m), PROJECTION_ROUNDS);
            upper
        };
        best = refine(a, pose_a, b, pose_b, best.1, best);
        let mut bound = closer(best.1);
        if !settled(best, bound) {
            let enough = effective(best, bound) - 2.0 * slack - 0.5 * MARGIN * tol;
            best = polish(a, pose_a, b, pose_b, best, enough);
            bound = closer(best.1);
        }
        upper = bound;
        if effective(best, upper) - best.0 > tol && rough.is_some() {
            let loose = Bounds { lower: best.0 - slack, upper: upper + slack, axis: best.1, witness, simplex: None };
            return (loose, false);
        }
    }
    if let Some((dist, points)) = penetration {
        // EPA's depth, unless a separating axis proves the shapes apart.
        if best.0 <= 0.0 && dist < upper {
            (upper, witness) = (dist, Some(points));
        }
    }
    if upper == f64::INFINITY && best.0 <= 0.0 {
        // Both GJK runs found the shapes intersecting and no depth was measured.
        upper = 0.0;
    }
    (Bounds { lower: best.0 - slack, upper: upper + slack, axis: best.1, witness, simplex: first.simplex }, true)
}

/// One triangle's bounds rank by their lower bound in parry's best-first search of the mesh.
impl BvhLeafCost for Bounds {
    fn cost(&self) -> f64 {
        self.lower
    }
}
