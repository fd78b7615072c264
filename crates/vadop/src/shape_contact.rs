//! Shape narrow phase: the first contact of two shapes under rigid motion, or of a shape and a
//! wall of the box, by conservative advancement over parry's distance queries.
//!
//! It owns the motion interface ([`Spin`], [`RigidMotion`]), the contact-time arithmetic for
//! non-spherical shapes and its tolerance, and nothing else: like [`crate::narrow_phase`] it
//! never sees the world, the broad phase or the queue, and it never moves a body. Sphere pairs
//! keep their closed form in [`crate::narrow_phase`]; this module serves every pair with a
//! non-spherical or static-only shape (a sphere pair works here too, only slower).
//!
//! # Motion
//!
//! Between velocity changes a body's centre of mass moves in a straight line,
//! `p(t) = position + (t - since) * velocity`, and its orientation (which rotates body-frame
//! vectors to world vectors, see [`crate::shape`]) is `spin.orientation_at(t - since)`; the spin
//! also bounds the angular speed for all time. A static body is a [`RigidMotion`] with zero
//! velocity and the [`Fixed`] spin; static-only shapes must not turn.
//!
//! # Bounding volumes first
//!
//! Each solid lies in a sphere of its bounding radius about its centre of mass, and the centres
//! move in straight lines: the closed forms of [`crate::narrow_phase`] give the one interval of
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
//! `mu = max(0, (v_a - v_b) . n) + w_a r_a + w_b r_b`,
//! w being a body's angular speed bound and r how far its core (below) reaches from the centre of
//! mass: its bounding radius, a capsule's half height, 0 for a sphere, whose surface does not move
//! when it turns. So the distance stays above `tol/2` until `t + (d - tol/2) / mu`, and the
//! search steps there, less the margins below: on bounds tightened to decide, the steps are at
//! least `(tol/4) / mu` long (`(5/24) tol / mu` on a warm start's). Against a triangle mesh, whose nearest triangle may change, `mu` uses
//! `|v_a - v_b|` instead of the projection; against a half-space or a wall, n is the fixed plane
//! normal and the separation along it is the exact signed distance.
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
//!   approaching: if it goes on to penetrate `tol` deeper than it is before it separates beyond
//!   `tol`. (A pair just resolved in simulate mode separates: its next contact is a new one.) A
//!   pair already deeper than `tol` is a contact in progress, as for spheres in detect mode;
//!   against the walls, which always turn a body back, depth does not matter.
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
//! gets the same time to the bit. A search stops once past the window's end; a later window
//! recomputes the same iterates. The chain starts afresh at every contact start and end it finds
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

use crate::error::{Result, VadopError};
use crate::narrow_phase::{direction, sphere_separation_time, sphere_sphere_time, unit_scale, Wall};
use crate::shape::ShapeGeometry;
use crate::window::Window;
use glam::{DQuat, DVec3};
use parry3d_f64::math::Pose;
use parry3d_f64::partitioning::{BvhLeafCost, BvhNode};
use parry3d_f64::query::details::{closest_points_segment_segment_with_locations_nD, contact_support_map_support_map};
use parry3d_f64::query::gjk::{self, CsoPoint, GJKResult, VoronoiSimplex};
use parry3d_f64::query::point::local_point_projection_on_support_map;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::{Ball, Capsule, Cone, Cuboid, Cylinder, Segment, Shape, SupportMap, TriMesh, Triangle};
use std::cell::{Cell, RefCell};

/// How a body's orientation evolves since its last velocity change: the exact torque-free
/// rotation for a free body, [`Fixed`] for one that never turns.
pub trait Spin {
    /// The orientation (rotating body-frame vectors to world vectors) `dt` after the body's last
    /// velocity change.
    fn orientation_at(&self, dt: f64) -> DQuat;
    /// Upper bound on the body's angular speed |w| over all time.
    fn max_angular_speed(&self) -> f64;
}

impl<S: Spin + ?Sized> Spin for &S {
    fn orientation_at(&self, dt: f64) -> DQuat {
        (**self).orientation_at(dt)
    }
    fn max_angular_speed(&self) -> f64 {
        (**self).max_angular_speed()
    }
}

/// A spin that never turns: a constant orientation, angular speed bound 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fixed(pub DQuat);

impl Spin for Fixed {
    fn orientation_at(&self, _dt: f64) -> DQuat {
        self.0
    }
    fn max_angular_speed(&self) -> f64 {
        0.0
    }
}

/// A body's motion since its last velocity change: centre of mass `position` at time `since`,
/// moving with constant `velocity`, spinning per `spin`.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape_contact::{Fixed, RigidMotion};
/// let m = RigidMotion { position: DVec3::ZERO, since: 1.0, velocity: DVec3::X, spin: Fixed(DQuat::IDENTITY) };
/// assert_eq!(m.position_at(3.0), DVec3::new(2.0, 0.0, 0.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidMotion<S> {
    /// Centre of mass at `since`.
    pub position: DVec3,
    /// The time of the last velocity change.
    pub since: f64,
    /// Constant velocity of the centre of mass.
    pub velocity: DVec3,
    /// Orientation as a function of the time since `since`.
    pub spin: S,
}

impl<S: Spin> RigidMotion<S> {
    /// Centre of mass at absolute time `t`.
    pub fn position_at(&self, t: f64) -> DVec3 {
        self.position + (t - self.since) * self.velocity
    }
    /// Orientation at absolute time `t`.
    pub fn orientation_at(&self, t: f64) -> DQuat {
        self.spin.orientation_at(t - self.since)
    }
}

impl RigidMotion<Fixed> {
    /// A body that never moves: at `position` with `orientation` from time `since` on.
    pub fn fixed(position: DVec3, orientation: DQuat, since: f64) -> Self {
        RigidMotion { position, since, velocity: DVec3::ZERO, spin: Fixed(orientation) }
    }
}

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
/// It is larger than the spheres' [`crate::narrow_phase::CONTACT_TOLERANCE`] (1e-9), which lies
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

/// Within this many tolerances of contact the distance bounds are tightened to a fraction of the
/// tolerance; beyond, they need only be tight relative to the distance, which sets the step.
const BAND: f64 = 8.0;

/// The distance a search keeps above until a contact starts: `tol/2` plus the margin.
fn guard(tol: f64) -> f64 {
    0.5 * tol * (1.0 + MARGIN)
}

/// Projections, alternating between the shapes, that look for closer points from each shape's
/// extreme point a few tolerances from contact (see `closer_points`).
const PROJECTION_ROUNDS: usize = 4;

/// Relative rounding allowance on support points and closest points, times the size of the
/// coordinates involved.
const SLACK: f64 = 64.0 * f64::EPSILON;

/// The distance within which two shapes count as touching: [`SHAPE_CONTACT_TOLERANCE`] times the
/// sum of their bounding radii (a static-only shape counts 0).
///
/// ```
/// use glam::DVec3;
/// use vadop::shape::Shape;
/// use vadop::shape_contact::contact_tolerance;
/// let ball = Shape::Sphere { radius: 2.0 }.geometry().unwrap();
/// let floor = Shape::HalfSpace { normal: DVec3::Y }.geometry().unwrap();
/// assert!((contact_tolerance(&ball, &floor) - 2e-6).abs() < 1e-15);
/// ```
pub fn contact_tolerance(a: &ShapeGeometry, b: &ShapeGeometry) -> f64 {
    SHAPE_CONTACT_TOLERANCE * (a.size() + b.size())
}

/// A shape's support map with lengths multiplied by an exact power of two, and the shape itself
/// for its flat features.
struct Scaled<'a> {
    /// The shape is the set of points within `margin` of its core.
    core: Core<'a>,
    margin: f64,
    parry: &'a dyn Shape,
    scale: f64,
}

/// The convex set a shape is the neighbourhood of, in the shape frame and scaled: a ball's
/// centre, a capsule's segment, or the shape itself. Distances between points and segments have
/// closed forms, where GJK would converge slowly on the round surfaces around them.
#[derive(Clone, Copy)]
enum Core<'a> {
    Point,
    Segment(Segment),
    Solid(&'a dyn SupportMap),
}

impl<'a> Scaled<'a> {
    /// The shape `parry`, scaled by `scale`.
    fn new(parry: &'a dyn Shape, scale: f64) -> Self {
        let (core, margin) = if let Some(ball) = parry.as_ball() {
            (Core::Point, ball.radius)
        } else if let Some(capsule) = parry.as_capsule() {
            let segment = Segment::new(capsule.segment.a * scale, capsule.segment.b * scale);
            (Core::Segment(segment), capsule.radius)
        } else {
            (Core::Solid(parry.as_support_map().expect("solid shapes have support maps")), 0.0)
        };
        Scaled { core, margin: margin * scale, parry, scale }
    }

    /// The shape's core, as a support map.
    fn core(&self) -> CoreOf<'_, 'a> {
        CoreOf(self)
    }
}

/// The support map of a shape's core.
struct CoreOf<'s, 'a>(&'s Scaled<'a>);

impl SupportMap for CoreOf<'_, '_> {
    #[inline]
    fn local_support_point(&self, dir: DVec3) -> DVec3 {
        match &self.0.core {
            Core::Point => DVec3::ZERO,
            Core::Segment(segment) => segment.local_support_point(dir),
            Core::Solid(shape) => shape.local_support_point(dir) * self.0.scale,
        }
    }
}

/// Directions of a shape's flat features near a direction: face normals and edge (or ruling)
/// directions, in the frame of the pose they were computed for.
#[derive(Default)]
struct Features {
    normals: [DVec3; 3],
    normal_count: usize,
    edges: [DVec3; 4],
    edge_count: usize,
}

impl Features {
    fn normal(&mut self, n: DVec3) {
        if self.normal_count < self.normals.len() {
            self.normals[self.normal_count] = n;
            self.normal_count += 1;
        }
    }
    fn edge(&mut self, e: DVec3) {
        if self.edge_count < self.edges.len() {
            self.edges[self.edge_count] = e;
            self.edge_count += 1;
        }
    }
    fn normals(&self) -> &[DVec3] {
        &self.normals[..self.normal_count]
    }
    fn edges(&self) -> &[DVec3] {
        &self.edges[..self.edge_count]
    }
}

impl Scaled<'_> {
    /// The flat features of the shape (posed by `rotation`) that may face along `dir`: the
    /// directions a separating axis must be exactly orthogonal to, or equal to, for the
    /// separation along it to be tight when the shapes nearly touch.
    fn features(&self, rotation: DQuat, dir: DVec3) -> Features {
        let local = rotation.inverse() * dir;
        let mut f = Features::default();
        let shape = self.parry;
        if shape.as_cuboid().is_some() {
            for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
                f.normal(axis);
                f.edge(axis);
            }
        } else if let Some(hull) = shape.as_convex_polyhedron() {
            let best = hull.faces().iter().max_by(|x, y| x.normal.dot(local).total_cmp(&y.normal.dot(local)));
            if let Some(face) = best {
                f.normal(face.normal);
                let first = face.first_vertex_or_edge as usize;
                let ids = &hull.vertices_adj_to_face()[first..first + face.num_vertices_or_edges as usize];
                let points = hull.points();
                for (k, &i) in ids.iter().enumerate() {
                    let j = ids[(k + 1) % ids.len()];
                    f.edge(points[j as usize] - points[i as usize]);
                }
            }
        } else if let Some(t) = shape.as_triangle() {
            f.normal((t.b - t.a).cross(t.c - t.a));
            for e in [t.b - t.a, t.c - t.b, t.a - t.c] {
                f.edge(e);
            }
        } else if shape.as_cylinder().is_some() {
            f.normal(DVec3::Y);
            f.edge(DVec3::Y);
            // The rim's tangent where it faces `local`.
            f.edge(DVec3::Y.cross(DVec3::new(local.x, 0.0, local.z)));
        } else if let Some(capsule) = shape.as_capsule() {
            f.edge(capsule.segment.b - capsule.segment.a);
        } else if let Some(cone) = shape.as_cone() {
            f.normal(DVec3::Y);
            // The ruling through the support point (from the apex to the rim towards `local`) and
            // the rim's tangent there.
            if let Some(radial) = DVec3::new(local.x, 0.0, local.z).try_normalize() {
                f.edge(radial * cone.radius - DVec3::Y * (2.0 * cone.half_height));
                f.edge(DVec3::Y.cross(radial));
            }
        }
        for n in &mut f.normals[..f.normal_count] {
            *n = rotation * *n;
        }
        for e in &mut f.edges[..f.edge_count] {
            *e = rotation * *e;
        }
        f
    }
}

/// The best separation of `a` and `b` over `axis` and the axes their flat features suggest
/// around it: face normals, edge cross products, and `axis` made exactly orthogonal to each edge.
/// GJK's axis alone loses the separation times the lever arm of a face when its direction is off
/// by the rounding of closest points a hair apart; these axes are computed from the shapes' exact
/// data instead. Every candidate gives a valid lower bound: the choice only affects tightness.
fn refine(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose, axis: DVec3, mut best: (f64, DVec3)) -> (f64, DVec3) {
    let fa = a.features(pose_a.rotation, axis);
    let fb = b.features(pose_b.rotation, -axis);
    // Both senses: `axis` itself may point the wrong way when GJK failed.
    let mut try_axis = |m: DVec3| {
        if let Some(m) = m.try_normalize() {
            for m in [m, -m] {
                let gap = separation(a, pose_a, b, pose_b, m);
                if gap > best.0 {
                    best = (gap, m);
                }
            }
        }
    };
    for &n in fa.normals().iter().chain(fb.normals()) {
        try_axis(n);
    }
    for &ea in fa.edges() {
        for &eb in fb.edges() {
            try_axis(ea.cross(eb));
        }
    }
    for &e in fa.edges().iter().chain(fb.edges()) {
        try_axis(e.cross(axis.cross(e)));
    }
    best
}

impl Scaled<'_> {
    /// The centre of the shape's local box, scaled.
    fn middle(&self) -> DVec3 {
        self.parry.compute_local_aabb().center() * self.scale
    }
}

impl SupportMap for Scaled<'_> {
    #[inline]
    fn local_support_point(&self, dir: DVec3) -> DVec3 {
        let core = self.core().local_support_point(dir);
        match self.core {
            Core::Solid(_) => core,
            _ => core + dir.normalize_or_zero() * self.margin,
        }
    }
}

/// A body as the gauges see it, relative to the reference instant.
struct Body<'a> {
    geometry: &'a ShapeGeometry,
    spin: &'a dyn Spin,
    /// Reference minus `since`: the spin is read at `lag + tau`.
    lag: f64,
    /// Centre of mass at the reference.
    position: DVec3,
    velocity: DVec3,
}

impl<'a> Body<'a> {
    fn new<S: Spin>(geometry: &'a ShapeGeometry, motion: &'a RigidMotion<S>, reference: f64) -> Self {
        let lag = reference - motion.since;
        Body {
            geometry,
            spin: &motion.spin,
            lag,
            position: motion.position + lag * motion.velocity,
            velocity: motion.velocity,
        }
    }

    fn orientation(&self, tau: f64) -> DQuat {
        self.spin.orientation_at(self.lag + tau)
    }

    /// How fast turning can move the surface, in unscaled lengths per time.
    fn spin_rate(&self) -> f64 {
        if self.geometry.rotation_radius() == 0.0 {
            0.0
        } else {
            self.spin.max_angular_speed() * self.geometry.rotation_radius()
        }
    }

    fn support(&self, scale: f64) -> Scaled<'a> {
        Scaled::new(self.geometry.parry_shape().as_ref(), scale)
    }

    /// The scaled parry pose of the shape for centre of mass `centre` and orientation `q`.
    fn pose(&self, q: DQuat, centre: DVec3, scale: f64) -> Pose {
        let body = self.geometry.body_from_shape();
        Pose::from_parts(centre + q * (body.translation * scale), q * body.rotation)
    }
}

/// Bounds on the signed distance at one instant, and on how fast they can move (scaled units).
#[derive(Debug, Clone, Copy)]
struct Probe {
    /// `lower <= signed distance <= upper`.
    lower: f64,
    upper: f64,
    /// The lower bound (a separation along a fixed axis) shrinks at most this fast.
    shrink: f64,
    /// The signed distance grows at most this fast.
    grow: f64,
    /// A looser lower bound that turning cannot shrink, from the bounding sphere of a spinning
    /// body, and how fast it shrinks: `(-inf, 0)` when there is none. Far from contact it steps a
    /// fast spinner by its straight motion, where `lower` would step it by its spin.
    far: (f64, f64),
}

/// No spin-free bound.
const NO_FAR: (f64, f64) = (f64::NEG_INFINITY, 0.0);

impl Probe {
    /// The longest step that keeps the distance above `guard` on either lower bound (infinite
    /// when one never shrinks), or `None` when neither bound is above `guard`.
    fn approach_step(&self, guard: f64) -> Option<f64> {
        let step = |(lower, shrink): (f64, f64)| {
            let room = lower - guard;
            (room > 0.0).then(|| if shrink > 0.0 { room / shrink } else { f64::INFINITY })
        };
        match (step((self.lower, self.shrink)), step(self.far)) {
            (Some(near), Some(far)) => Some(near.max(far)),
            (near, far) => near.or(far),
        }
    }
}

/// The signed distance of one pair (or of a body and a wall) as a function of the time since the
/// reference, in scaled lengths.
trait Gauge {
    fn probe(&self, tau: f64, depth: bool) -> Probe;
    /// The times within which the distance may be at most `within`, from the bodies' bounding
    /// volumes alone: `None` when it never is.
    fn reach(&self, within: f64) -> Option<Reach>;
    /// Drops what the last probes found (their warm start): the chain starts afresh.
    fn forget(&self) {}
}

/// The times since the reference `[enter, leave]` outside which a pair is certainly farther apart
/// than some distance: bounding volumes moving in straight lines meet in one interval at most.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reach {
    enter: f64,
    /// Infinite when they never part again.
    leave: f64,
}

impl Reach {
    /// The times `tau >= 0` with `height + rate * tau <= limit`.
    fn below(height: f64, rate: f64, limit: f64) -> Option<Reach> {
        if height <= limit {
            let leave = if rate > 0.0 { (limit - height) / rate } else { f64::INFINITY };
            Some(Reach { enter: 0.0, leave })
        } else if rate < 0.0 {
            Some(Reach { enter: (height - limit) / -rate, leave: f64::INFINITY })
        } else {
            None
        }
    }

    /// The times `tau >= 0` with `|offset + velocity * tau| <= limit`: the closed forms of two
    /// spheres of radii summing to `limit`.
    fn sphere(offset: DVec3, velocity: DVec3, limit: f64) -> Option<Reach> {
        // Without relative motion the spheres part never.
        let leave = sphere_separation_time(offset, velocity, limit).unwrap_or(f64::INFINITY);
        if offset.length() <= limit {
            return Some(Reach { enter: 0.0, leave });
        }
        // None when receding or missing, with a margin far below the `limit` this is called with.
        let enter = sphere_sphere_time(offset, velocity, limit)?;
        Some(Reach { enter, leave: leave.max(enter) })
    }

    /// The times in both.
    fn meet(self, other: Reach) -> Option<Reach> {
        let met = Reach { enter: self.enter.max(other.enter), leave: self.leave.min(other.leave) };
        (met.enter <= met.leave).then_some(met)
    }
}

/// Separation of `a` and `b` along the unit axis `n` from a to b: a lower bound on their signed
/// distance.
fn separation(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose, n: DVec3) -> f64 {
    n.dot(b.support_point(pose_b, -n) - a.support_point(pose_a, n))
}

/// Climbs the separation of `a` and `b` over the axes around `best.1` by a pattern search with
/// shrinking steps. For curved surfaces a hair apart the separation falls off with the square of
/// the axis error times the curvature, and GJK's axis can be off by 1e-2 there; where a surface
/// is ruled (a cylinder's side, an edge) the best axes form a ridge orthogonal to the ruling, so
/// the search also moves along each such ridge, which keeps the axis exactly orthogonal to it.
fn polish(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose, mut best: (f64, DVec3), enough: f64) -> (f64, DVec3) {
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
fn nearest(shape: &Scaled, pose: &Pose, point: DVec3) -> Option<(f64, DVec3)> {
    let local = pose.inverse_transform_point(point);
    // Everything in scaled lengths, where parry's absolute tolerances mean the same at any scale:
    // closed forms on a scaled copy of a primitive, GJK on the scaled support map otherwise.
    let (p, s) = (shape.parry, shape.scale);
    let projection = if let Some(ball) = p.as_ball() {
        Ball::new(ball.radius * s).project_local_point(local, true)
    } else if let Some(cuboid) = p.as_cuboid() {
        Cuboid::new(cuboid.half_extents * s).project_local_point(local, true)
    } else if let Some(c) = p.as_capsule() {
        Capsule::new(c.segment.a * s, c.segment.b * s, c.radius * s).project_local_point(local, true)
    } else if let Some(c) = p.as_cylinder() {
        Cylinder::new(c.half_height * s, c.radius * s).project_local_point(local, true)
    } else if let Some(c) = p.as_cone() {
        Cone::new(c.half_height * s, c.radius * s).project_local_point(local, true)
    } else if s == 1.0 {
        p.project_local_point(local, true)
    } else {
        local_point_projection_on_support_map(shape, &mut VoronoiSimplex::new(), local, true)
    };
    (!projection.is_inside).then(|| ((local - projection.point).length(), pose * projection.point))
}

/// The closer of `known` (a distance and the points at it) and the pairs met projecting each of
/// the known points, and each shape's extreme point along `axis` (from a to b) if given, on the
/// other shape, and back, `rounds` times in all: alternating projections approach closest points,
/// also where GJK's are off or an extreme point is an arbitrary point of a flat face.
fn closer_points(
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

/// Bounds on the signed distance of two shapes at one instant (scaled lengths, in the frame of
/// their poses).
#[derive(Debug, Clone, Copy)]
struct Bounds {
    /// The separation along `axis`: at most the signed distance.
    lower: f64,
    /// At least the signed distance.
    upper: f64,
    /// Unit axis from the first shape to the second.
    axis: DVec3,
    /// Points of the first and second shape whose distance is `upper` (or EPA's deepest points),
    /// when known.
    witness: Option<(DVec3, DVec3)>,
}

/// A first estimate of the distance of two shapes (scaled, in the frame of their poses): closed
/// forms where they exist, GJK (and EPA when the shapes intersect) otherwise.
struct Estimate {
    /// At least the signed distance; infinite when unknown.
    upper: f64,
    /// Unit axis from the first shape to the second.
    axis: DVec3,
    /// Points of the shapes whose distance is `upper`, when known.
    witness: Option<(DVec3, DVec3)>,
    /// GJK's own last search direction (unit, world frame).
    search: Option<DVec3>,
    /// EPA's depth (negative) and deepest points when the shapes intersect.
    penetration: Option<(f64, (DVec3, DVec3))>,
}

/// The estimate from closed forms when both cores are points or segments, or one is a point
/// outside the other shape: the cores' distance less the margins, exact to rounding, with its
/// witness points and axis. `None` otherwise.
fn closed_form(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose) -> Option<Estimate> {
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
    })
}

/// GJK's estimate (EPA's when the sets intersect and `depth` asks for it) from the sets `a` and
/// `b` at `pos12` (b's pose in a's frame), grown by `margins` into the shapes; `toward` (in a's
/// frame) is where GJK starts from and the axis to fall back on.
fn gjk_estimate<A: SupportMap, B: SupportMap>(
    (a, pose_a): (&A, &Pose),
    (b, pose_b): (&B, &Pose),
    margins: (f64, f64),
    toward: DVec3,
    depth: bool,
) -> Estimate {
    let pos12 = pose_a.inv_mul(pose_b);
    let mut estimate = Estimate { upper: f64::INFINITY, axis: toward, witness: None, search: None, penetration: None };
    let grown = |(p1, p2): (DVec3, DVec3), n: DVec3| (p1 + n * margins.0, p2 - n * margins.1);
    let gjk_from = |dir: DVec3| {
        let mut simplex = VoronoiSimplex::new();
        simplex.reset(CsoPoint::from_shapes(&pos12, a, b, dir));
        gjk::closest_points(&pos12, a, b, f64::MAX, true, &mut simplex)
    };
    let mut result = gjk_from(-toward);
    if !matches!(result, GJKResult::ClosestPoints(..)) {
        // GJK's verdict is not reliable a hair from contact: ask again from the other side.
        let again = gjk_from(toward);
        if matches!(again, GJKResult::ClosestPoints(..)) {
            result = again;
        }
    }
    match result {
        GJKResult::ClosestPoints(p1, p2, dir) => {
            let d = p2 - p1;
            estimate.axis = d.try_normalize().unwrap_or(toward);
            estimate.upper = d.length() - margins.0 - margins.1;
            estimate.search = Some(pose_a.rotation * dir);
            estimate.witness = Some(grown((*pose_a * p1, *pose_a * p2), pose_a.rotation * estimate.axis));
        }
        GJKResult::Intersection if !depth => {}
        // Intersecting (measure the depth), or GJK did not converge (try again).
        _ => {
            if let Some(contact) = contact_support_map_support_map(&pos12, a, b, f64::MAX) {
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
/// support functions. With `depth` false, an intersection only needs to be recognised, not
/// measured. GJK runs on the cores, and on the shapes too where their distance is a small part of
/// the cores' (its precision is relative to the distance it measures). The bounds are tightened
/// where it matters: within a few `tol` of contact.
fn convex_bounds(a: &Scaled, pose_a: &Pose, b: &Scaled, pose_b: &Pose, depth: bool, tol: f64, slack: f64) -> Bounds {
    let band = BAND * tol;
    // From the middle of a to the middle of b, in a's frame: where GJK starts, and the axis to
    // fall back on if it fails.
    let toward = (pose_a.inv_mul(pose_b) * b.middle() - a.middle()).try_normalize().unwrap_or(DVec3::X);
    let (first, second) = match closed_form(a, pose_a, b, pose_b) {
        Some(exact) => (exact, None),
        None => {
            let margins = (a.margin, b.margin);
            let cores = gjk_estimate((&a.core(), pose_a), (&b.core(), pose_b), margins, toward, depth);
            let distance = cores.penetration.map_or(cores.upper, |(dist, _)| dist);
            // GJK's precision is relative to the distance it measures, the cores' with the
            // margins: where the shapes' own is a small part of it, GJK runs on them too, and the
            // tighter estimate counts (either fails at times a hair from contact).
            let near = distance.abs() < (margins.0 + margins.1) / 16.0;
            (cores, near.then(|| gjk_estimate((a, pose_a), (b, pose_b), (0.0, 0.0), toward, depth)))
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
    Bounds { lower: best.0 - slack, upper: upper + slack, axis: best.1, witness }
}

/// Two solid shapes. The frame has world axes and its origin at a's centre of mass.
struct ConvexPair<'a> {
    a: Body<'a>,
    b: Body<'a>,
    scale: f64,
    /// b's centre minus a's at the reference, scaled.
    offset: DVec3,
    /// b's velocity minus a's, scaled.
    velocity: DVec3,
    /// Scaled bound on how fast turning moves the two surfaces.
    spin: f64,
    /// Scaled sum of the bounding radii.
    size: f64,
    /// Scaled contact tolerance.
    tol: f64,
    /// What the last probe found, to start the next one from.
    warm: Cell<Option<Warm>>,
}

/// A probe's axis and witness points, fixed in the bodies (in frames that move with them): after
/// a step the points still bound the distance, and so does the axis turned with the body whose
/// face (or curved surface) it is the normal of, nearly as tightly.
#[derive(Debug, Clone, Copy)]
struct Warm {
    axis: (DVec3, DVec3),
    witness: (DVec3, DVec3),
}

impl Warm {
    /// What a probe's `bounds` leave for the next one; `carry` maps each shape's moving frame to
    /// the probe's.
    fn new(bounds: &Bounds, carry: (&Pose, &Pose)) -> Option<Warm> {
        let (x, y) = bounds.witness?;
        Some(Warm {
            axis: (carry.0.rotation.inverse() * bounds.axis, carry.1.rotation.inverse() * bounds.axis),
            witness: (carry.0.inverse_transform_point(x), carry.1.inverse_transform_point(y)),
        })
    }

    /// Bounds from the axis, turned with either shape, and the witness points, carried along with
    /// them (or, if those drifted apart, their projections on the other shape), when they lie
    /// within half the room above `guard(tol)` of each other: the step on them then goes at least
    /// two thirds as far as on exact bounds. `None` otherwise (GJK then).
    fn bounds(
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
        tight(upper).then_some(Bounds { lower: lower - slack, upper: upper + slack, axis, witness })
    }
}

impl ConvexPair<'_> {
    /// The best spin-free bound along the line of centres: a spinning body stays in its bounding
    /// sphere, so its sphere against the other shape (or both spheres) is a lower bound that only
    /// the straight motion and the other's spin shrink.
    fn far(&self, tau: f64, (a, pose_a): (&Scaled, &Pose), (b, pose_b): (&Scaled, &Pose), slack: f64) -> (f64, f64) {
        // The centres of mass: a's at the origin of the frame.
        let centre = self.offset + self.velocity * tau;
        let Some(n) = direction(centre).filter(|_| self.spin > 0.0) else { return NO_FAR };
        let (radius_a, radius_b) = (self.a.geometry.size() * self.scale, self.b.geometry.size() * self.scale);
        let (spin_a, spin_b) = (self.a.spin_rate() * self.scale, self.b.spin_rate() * self.scale);
        let closing = (-self.velocity.dot(n)).max(0.0);
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

    fn poses(&self, tau: f64) -> (Pose, Pose) {
        let centre = self.offset + self.velocity * tau;
        (
            self.a.pose(self.a.orientation(tau), DVec3::ZERO, self.scale),
            self.b.pose(self.b.orientation(tau), centre, self.scale),
        )
    }
}

impl Gauge for ConvexPair<'_> {
    fn probe(&self, tau: f64, depth: bool) -> Probe {
        let (pose_a, pose_b) = self.poses(tau);
        let slack = SLACK * (pose_b.translation.length() + self.size);
        let (ga, gb) = (self.a.support(self.scale), self.b.support(self.scale));
        // Each shape's frame moves with its body.
        let carry = (&pose_a, &pose_b);
        let bounds = (self.warm.get())
            .and_then(|warm| warm.bounds((&ga, &pose_a), (&gb, &pose_b), carry, self.tol, slack))
            .unwrap_or_else(|| convex_bounds(&ga, &pose_a, &gb, &pose_b, depth, self.tol, slack));
        self.warm.set(Warm::new(&bounds, carry));
        Probe {
            lower: bounds.lower,
            upper: bounds.upper,
            shrink: (-self.velocity.dot(bounds.axis)).max(0.0) + self.spin,
            grow: self.velocity.length() + self.spin,
            far: self.far(tau, (&ga, &pose_a), (&gb, &pose_b), slack),
        }
    }

    /// The shapes lie in their bounding spheres about the centres of mass.
    fn reach(&self, within: f64) -> Option<Reach> {
        let limit = self.size + within + SLACK * (self.offset.length() + self.size);
        Reach::sphere(self.offset, self.velocity, limit)
    }

    fn forget(&self) {
        self.warm.set(None);
    }
}

/// A solid and a half-space. The frame has world axes and its origin at the half-space's origin.
struct PlanePair<'a> {
    body: Body<'a>,
    plane: Body<'a>,
    /// The half-space's outward normal in its own frame.
    normal: DVec3,
    scale: f64,
    /// The body's centre minus the plane origin at the reference, scaled.
    offset: DVec3,
    /// The body's velocity minus the plane's, scaled.
    velocity: DVec3,
    spin: f64,
    size: f64,
}

impl PlanePair<'_> {
    /// World outward normal, the body's pose and its signed distance at `tau`.
    fn state(&self, tau: f64) -> (DVec3, Pose, f64, f64) {
        let n = self.plane.orientation(tau) * self.normal;
        let centre = self.offset + self.velocity * tau;
        let pose = self.body.pose(self.body.orientation(tau), centre, self.scale);
        let distance = n.dot(self.body.support(self.scale).support_point(&pose, -n));
        (n, pose, distance, SLACK * (centre.length() + self.size))
    }
}

impl Gauge for PlanePair<'_> {
    fn probe(&self, tau: f64, _depth: bool) -> Probe {
        let (n, _, distance, slack) = self.state(tau);
        let approach = self.velocity.dot(n);
        // The body's bounding sphere above the plane, which does not turn.
        let height = n.dot(self.offset + self.velocity * tau) - self.size;
        Probe {
            lower: distance - slack,
            upper: distance + slack,
            shrink: (-approach).max(0.0) + self.spin,
            grow: approach.max(0.0) + self.spin,
            far: (height - slack, (-approach).max(0.0)),
        }
    }

    /// The body lies in its bounding sphere; the plane does not turn.
    fn reach(&self, within: f64) -> Option<Reach> {
        let n = self.plane.orientation(0.0) * self.normal;
        let limit = self.size + within + SLACK * (self.offset.length() + self.size);
        Reach::below(n.dot(self.offset), n.dot(self.velocity), limit)
    }
}

/// A solid and a triangle mesh. The frame has the mesh's axes and its origin at the body's centre
/// of mass.
struct MeshPair<'a> {
    body: Body<'a>,
    mesh: Body<'a>,
    trimesh: &'a TriMesh,
    scale: f64,
    /// The body's centre minus the mesh origin at the reference, scaled.
    offset: DVec3,
    velocity: DVec3,
    spin: f64,
    size: f64,
    tol: f64,
    /// What the last probe found for each triangle it measured, to start the next one from.
    warm: RefCell<Vec<(u32, Warm)>>,
}

/// One triangle's bounds rank by their lower bound in parry's best-first search of the mesh.
impl BvhLeafCost for Bounds {
    fn cost(&self) -> f64 {
        self.lower
    }
}

impl MeshPair<'_> {
    /// The body's centre in the mesh frame (unscaled) and its scaled pose about that centre.
    fn state(&self, tau: f64) -> (DVec3, Pose) {
        let q_mesh = self.mesh.orientation(tau).inverse();
        let centre = q_mesh * (self.offset + self.velocity * tau) / self.scale;
        let pose = self.body.pose(q_mesh * self.body.orientation(tau), DVec3::ZERO, self.scale);
        (centre, pose)
    }

    /// Triangle `id` in the frame about `centre`, scaled.
    fn triangle(&self, id: u32, centre: DVec3) -> Triangle {
        let t = self.trimesh.triangle(id);
        let s = self.scale;
        Triangle::new((t.a - centre) * s, (t.b - centre) * s, (t.c - centre) * s)
    }

    /// Bounds on the signed distance of the body to the mesh (the smallest of the triangles'):
    /// the smallest lower bound of a triangle (parry's best-first search over the mesh's
    /// hierarchy, which skips boxes farther than the best so far), and the smallest upper bound
    /// met on the way, with its triangle's axis and points.
    fn closest(&self, tau: f64, depth: bool) -> Option<Bounds> {
        let nearest: Cell<Option<Bounds>> = Cell::new(None);
        let (_, lowest) = self.search(tau, depth, &nearest)?;
        let nearest = nearest.get().unwrap_or(lowest);
        Some(Bounds { lower: lowest.lower, ..nearest })
    }

    /// The triangle with the smallest lower bound on its signed distance to the body; `nearest`
    /// keeps the bounds with the smallest upper bound.
    fn search(&self, tau: f64, depth: bool, nearest: &Cell<Option<Bounds>>) -> Option<(u32, Bounds)> {
        let (centre, pose) = self.state(tau);
        let body = self.body.support(self.scale);
        let slack = SLACK * self.size;
        let s = self.scale;
        // The body's box in the frame, from its support points.
        let extent = |d: DVec3| d.dot(body.support_point(&pose, d));
        let high = DVec3::new(extent(DVec3::X), extent(DVec3::Y), extent(DVec3::Z));
        let low = -DVec3::new(extent(-DVec3::X), extent(-DVec3::Y), extent(-DVec3::Z));
        let mut previous = self.warm.borrow_mut();
        let next = RefCell::new(Vec::with_capacity(previous.len()));
        let found = self.trimesh.bvh().find_best(
            f64::MAX,
            |node: &BvhNode, _| {
                // No triangle in the node's box is nearer than that box is to the body's.
                let (mins, maxs) = ((node.mins() - centre) * s, (node.maxs() - centre) * s);
                let outside = (mins - high).max(low - maxs).max(DVec3::ZERO);
                let gap = outside.length() * (1.0 - 1e-12) - slack;
                if gap > 0.0 {
                    gap
                } else {
                    -f64::MAX
                }
            },
            |id, _| {
                let triangle = self.triangle(id, centre);
                let slack = SLACK * (triangle.a.length() + self.size);
                let support = Scaled::new(&triangle, 1.0);
                // The triangle's frame is fixed to it at its first vertex, the body's to the body.
                let carry = (&Pose::from_translation(triangle.a), &pose);
                let warm = previous.iter().find(|(k, _)| *k == id).map(|(_, warm)| warm);
                let bounds = (warm
                    .and_then(|w| w.bounds((&support, &Pose::IDENTITY), (&body, &pose), carry, self.tol, slack)))
                .unwrap_or_else(|| convex_bounds(&support, &Pose::IDENTITY, &body, &pose, depth, self.tol, slack));
                if let Some(warm) = Warm::new(&bounds, carry) {
                    next.borrow_mut().push((id, warm));
                }
                if nearest.get().is_none_or(|b| bounds.upper < b.upper) {
                    nearest.set(Some(bounds));
                }
                Some(bounds)
            },
        );
        *previous = next.into_inner();
        found
    }
}

impl Gauge for MeshPair<'_> {
    fn probe(&self, tau: f64, depth: bool) -> Probe {
        let rate = self.velocity.length() + self.spin;
        let (lower, upper) = match self.closest(tau, depth) {
            Some(b) => (b.lower, b.upper),
            None => (f64::INFINITY, f64::INFINITY),
        };
        Probe { lower, upper, shrink: rate, grow: rate, far: NO_FAR }
    }

    /// The body's bounding sphere against the mesh's box, in the mesh's frame (it does not turn):
    /// the box grown by the sphere's radius (and more at its corners) on each axis.
    fn reach(&self, within: f64) -> Option<Reach> {
        let q_mesh = self.mesh.orientation(0.0).inverse();
        let (centre, velocity) = (q_mesh * self.offset, q_mesh * self.velocity);
        let aabb = self.trimesh.local_aabb();
        let (low, high) = (aabb.mins * self.scale, aabb.maxs * self.scale);
        let extent = low.abs().max(high.abs()).max_element();
        let grown = self.size + within + SLACK * (centre.length() + extent + self.size);
        let mut reach = Reach { enter: 0.0, leave: f64::INFINITY };
        for axis in 0..3 {
            let (c, v) = (centre[axis], velocity[axis]);
            reach = reach.meet(Reach::below(c, v, high[axis] + grown)?)?;
            reach = reach.meet(Reach::below(-c, -v, grown - low[axis])?)?;
        }
        Some(reach)
    }

    fn forget(&self) {
        self.warm.borrow_mut().clear();
    }
}

/// The pair-specific gauge of two shapes.
enum PairGauge<'a> {
    Convex(ConvexPair<'a>),
    /// `flipped`: the plane is the pair's first body.
    Plane(PlanePair<'a>, bool),
    Mesh(MeshPair<'a>, bool),
}

impl Gauge for PairGauge<'_> {
    fn probe(&self, tau: f64, depth: bool) -> Probe {
        match self {
            PairGauge::Convex(g) => g.probe(tau, depth),
            PairGauge::Plane(g, _) => g.probe(tau, depth),
            PairGauge::Mesh(g, _) => g.probe(tau, depth),
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
}

/// The iteration of one search: the reference, the scaled tolerance, the step count, and the
/// times outside which the pair is more than `2 tol` apart (neither touching nor in contact).
struct Searcher<G> {
    gauge: G,
    reference: f64,
    tol: f64,
    iterations: u32,
    /// `iterations` when the chain last started afresh: [`MAX_ITERATIONS`] caps each piece.
    restarted: u32,
    reach: Option<Reach>,
}

/// What the pair does when it touches at the reference.
enum AtReference {
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
    fn new(gauge: G, reference: f64, tol: f64) -> Self {
        let reach = gauge.reach(2.0 * tol);
        Searcher { gauge, reference, tol, iterations: 0, restarted: 0, reach }
    }

    /// Starts the chain afresh at absolute `time`, a contact start or end it found (or a time the
    /// caller knows to be one): a cold probe, a fresh iteration budget, and the time since the
    /// reference derived from the absolute time alone. What follows is then a function of the
    /// motions and `time` only, so a caller that holds a contact's start resumes the chain there
    /// without replaying the contacts before it, to the bit.
    fn restart_at(&mut self, time: f64) -> f64 {
        self.gauge.forget();
        self.restarted = self.iterations;
        (time - self.reference).max(0.0)
    }

    /// From this time since the reference on the pair stays more than `2 tol` apart.
    fn leave(&self) -> f64 {
        self.reach.map_or(0.0, |r| r.leave)
    }

    fn stall(&self, tau: f64, reason: &'static str) -> VadopError {
        VadopError::ContactSearchStalled { time: self.reference + tau, iterations: self.iterations, reason }
    }

    fn probe(&mut self, tau: f64, depth: bool) -> Result<Probe> {
        if self.iterations - self.restarted >= MAX_ITERATIONS {
            return Err(self.stall(tau, "the iteration cap was reached (resting or sliding contact while turning?)"));
        }
        if self.iterations.is_multiple_of(crate::interrupt::POLL_INTERVAL) && crate::interrupt::raised() {
            // Void: the world undoes the step.
            return Err(self.stall(tau, "the step was interrupted"));
        }
        self.iterations += 1;
        Ok(self.gauge.probe(tau, depth))
    }

    /// `tau + step`; `None` when that is beyond every horizon.
    fn advance(&self, tau: f64, step: f64) -> Result<Option<f64>> {
        let next = tau + step;
        if !next.is_finite() {
            return Ok(None);
        }
        if !(next > tau) {
            return Err(self.stall(tau, "the step fell below the resolution of time"));
        }
        Ok(Some(next))
    }

    /// At most this, a contact starts (`tol` less the margin).
    fn touch(&self) -> f64 {
        self.tol * (1.0 - MARGIN)
    }
    /// The distance is kept above this until a contact starts (`tol/2` plus the margin).
    fn guard(&self) -> f64 {
        guard(self.tol)
    }
    /// Above this, a contact has ended (`tol` plus the margin).
    fn clear(&self) -> f64 {
        self.tol * (1.0 + MARGIN)
    }
    /// During a contact the signed distance is kept below this (`2 tol` less the margin).
    fn ceiling(&self) -> f64 {
        2.0 * self.tol * (1.0 - MARGIN)
    }

    /// The first contact start from `tau` (where the pair does not touch) before absolute time
    /// `end`.
    fn next_start(&mut self, mut tau: f64, end: f64) -> Result<Option<f64>> {
        loop {
            if !(self.reference + tau < end && tau <= self.leave()) {
                return Ok(None);
            }
            let p = self.probe(tau, false)?;
            if p.upper <= self.touch() {
                return Ok(Some(tau));
            }
            let Some(step) = p.approach_step(self.guard()) else {
                return Err(self.stall(tau, "the distance bounds were too loose to step"));
            };
            if step == f64::INFINITY {
                // The separation along a fixed axis never shrinks: no contact ever.
                return Ok(None);
            }
            match self.advance(tau, step)? {
                Some(next) => tau = next,
                None => return Ok(None),
            }
        }
    }

    /// The end of the contact in progress at `tau`, before absolute time `end`.
    fn contact_end(&mut self, mut tau: f64, end: f64) -> Result<Option<f64>> {
        loop {
            if !(self.reference + tau < end) {
                return Ok(None);
            }
            if tau >= self.leave() {
                // The bounding volumes have parted: more than `2 tol` apart.
                return Ok(Some(tau));
            }
            let p = self.probe(tau, true)?;
            if p.lower > self.clear() {
                return Ok(Some(tau));
            }
            let room = self.ceiling() - p.upper;
            if !(room > 0.0) {
                return Err(self.stall(tau, "the distance bounds were too loose to step"));
            }
            if !(p.grow > 0.0) {
                return Ok(None);
            }
            // In contact until the step's end, and apart from `leave` on.
            match self.advance(tau, room / p.grow)? {
                Some(next) => tau = next.min(self.leave()),
                None => return Ok(None),
            }
        }
    }

    /// Whether a pair touching at the reference (`p0`) is approaching. Decided by the motion
    /// itself, whatever window asks: does it get `tol` deeper before it separates beyond `tol`?
    fn classify(&mut self, p0: Probe, deep_is_contact: bool) -> Result<AtReference> {
        if deep_is_contact && p0.upper < -self.tol {
            return Ok(AtReference::Inside);
        }
        let floor = p0.upper.min(0.0) - self.tol;
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
            let down = if p.shrink > 0.0 { (p.lower - floor) / p.shrink } else { f64::INFINITY };
            let up = if p.grow > 0.0 { room / p.grow } else { f64::INFINITY };
            match self.advance(tau, down.min(up))? {
                // Neither deeper nor apart before the bounding volumes part.
                Some(next) if next >= self.leave() => return Ok(AtReference::Ended(self.leave())),
                Some(next) => tau = next,
                None => return Ok(AtReference::Resting),
            }
            if self.iterations >= budget {
                return Err(self.stall(tau, "resting or sliding in contact: neither deeper nor apart"));
            }
            p = self.probe(tau, true)?;
        }
    }

    /// The first contact start in `window`, as a time since the reference.
    fn first_start_in(&mut self, window: Window, deep_is_contact: bool) -> Result<Option<f64>> {
        let Some(reach) = self.reach else { return Ok(None) };
        if !(self.reference + reach.enter < window.end) {
            return Ok(None);
        }
        // Before `enter` the pair is more than `2 tol` apart: the search starts there, and the
        // rules at the reference apply only when it is in reach at the reference.
        let mut tau = reach.enter;
        let p0 = if tau == 0.0 { Some(self.probe(0.0, true)?) } else { None };
        if let Some(p0) = p0.filter(|p0| p0.upper <= self.touch()) {
            let next = match self.classify(p0, deep_is_contact)? {
                AtReference::Approaching if self.reference >= window.start => return Ok(Some(0.0)),
                AtReference::Approaching | AtReference::Inside => self.after_contact(self.reference, window.end)?,
                AtReference::Ended(end) => Some(self.restart_at(self.reference + end)),
                AtReference::Resting => None,
            };
            match next {
                Some(next) => tau = next,
                None => return Ok(None),
            }
        }
        self.start_from(tau, window)
    }

    /// The first contact start in `window` from `tau`, where the pair does not touch.
    fn start_from(&mut self, mut tau: f64, window: Window) -> Result<Option<f64>> {
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
    /// since the reference at which it has ended, restarted there; `None` if not before `until`.
    fn after_contact(&mut self, start: f64, until: f64) -> Result<Option<f64>> {
        let tau = self.restart_at(start);
        Ok(match self.contact_end(tau, until)? {
            Some(end) => Some(self.restart_at(self.reference + end)),
            None => None,
        })
    }

    /// The first contact start in `window` after the contact that starts at absolute time
    /// `start`, which the caller holds from this chain: no replay of the contacts before it.
    fn first_start_after(&mut self, start: f64, window: Window) -> Result<Option<f64>> {
        match self.after_contact(start, window.end)? {
            Some(tau) => self.start_from(tau, window),
            None => Ok(None),
        }
    }

    /// The end of the contact that starts at absolute time `start` (a canonical start the caller
    /// holds), before `until`.
    fn end_of(&mut self, start: f64, until: f64) -> Result<Option<f64>> {
        let tau = self.restart_at(start);
        self.contact_end(tau, until)
    }

    /// The end, before `until`, of the contact in progress at absolute time `at`, found by
    /// replaying the chain from the reference: the same for every `at` inside one contact. A pair
    /// the chain does not find in contact at `at` is taken to be in a contact from `at` on.
    fn end_of_contact_at(&mut self, at: f64, until: f64, deep_is_contact: bool) -> Result<Option<f64>> {
        let Some(reach) = self.reach else { return self.end_of(at, until) };
        let mut tau = reach.enter;
        let p0 = if tau == 0.0 { Some(self.probe(0.0, true)?) } else { None };
        if let Some(p0) = p0.filter(|p0| p0.upper <= self.touch()) {
            let end = match self.classify(p0, deep_is_contact)? {
                AtReference::Approaching | AtReference::Inside => {
                    let tau = self.restart_at(self.reference);
                    self.contact_end(tau, until)?
                }
                AtReference::Ended(end) => Some(end),
                AtReference::Resting => None,
            };
            match end {
                Some(end) if self.reference + end > at => return Ok(Some(end)),
                Some(end) => tau = self.restart_at(self.reference + end),
                None => return Ok(None),
            }
        }
        let before = at.next_up();
        while let Some(start) = self.next_start(tau, before)? {
            let start = self.restart_at(self.reference + start);
            match self.contact_end(start, until)? {
                Some(end) if self.reference + end > at => return Ok(Some(end)),
                Some(end) => tau = self.restart_at(self.reference + end),
                None => return Ok(None),
            }
        }
        self.end_of(at, until)
    }
}

/// The searcher of a pair, or `None` for two static-only shapes (which never meet).
fn pair_searcher<'a, S: Spin, T: Spin>(
    a: (&'a ShapeGeometry, &'a RigidMotion<S>),
    b: (&'a ShapeGeometry, &'a RigidMotion<T>),
) -> Result<Option<Searcher<PairGauge<'a>>>> {
    let reference = a.1.since.max(b.1.since);
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
        (false, false) => PairGauge::Convex(ConvexPair {
            offset: (b.position - a.position) * scale,
            velocity: (b.velocity - a.velocity) * scale,
            a,
            b,
            scale,
            spin,
            size: size * scale,
            tol,
            warm: Cell::new(None),
        }),
        (first_static, _) => {
            let (body, fixed) = if first_static { (b, a) } else { (a, b) };
            let offset = (body.position - fixed.position) * scale;
            let velocity = (body.velocity - fixed.velocity) * scale;
            let parry = fixed.geometry.parry_shape();
            if let Some(half_space) = parry.as_halfspace() {
                let normal = half_space.normal;
                let pair = PlanePair { body, plane: fixed, normal, scale, offset, velocity, spin, size: size * scale };
                PairGauge::Plane(pair, first_static)
            } else {
                let trimesh = parry.as_trimesh().expect("static-only shapes are half-spaces or meshes");
                let warm = RefCell::new(Vec::new());
                let pair = MeshPair {
                    body,
                    mesh: fixed,
                    trimesh,
                    scale,
                    offset,
                    velocity,
                    spin,
                    size: size * scale,
                    tol,
                    warm,
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
    let Some(mut searcher) = pair_searcher(a, b)? else { return Ok(Search { found: None, iterations: 0 }) };
    let found = searcher.first_start_in(window, true)?.map(|tau| searcher.reference + tau);
    Ok(Search { found, iterations: searcher.iterations })
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
/// use vadop::shape_contact::{shape_contact_time, RigidMotion};
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
/// use vadop::shape_contact::{contact_end_time, shape_contact_time, RigidMotion};
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
    Ok(Search { found, iterations: searcher.iterations })
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
/// use vadop::shape_contact::{contact_end_time, contact_in_progress_end_time, shape_contact_time, RigidMotion};
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
/// use vadop::free_rotation::FreeRotation;
/// use vadop::shape_contact::{shape_contact_after, shape_contact_time, RigidMotion};
/// use vadop::Window;
/// let plank = Shape::Cuboid { half_extents: DVec3::new(1.0, 0.1, 0.1) }.geometry().unwrap();
/// let ball = Shape::Sphere { radius: 0.2 }.geometry().unwrap();
/// // A plank spinning about z beside a ball: its end sweeps past the ball twice a turn.
/// let spin = FreeRotation::new(plank.principal_inertia_unit(), DQuat::IDENTITY, DVec3::new(0.0, 0.0, 6.0));
/// let spinning = RigidMotion { position: DVec3::ZERO, since: 0.0, velocity: DVec3::ZERO, spin };
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
    let Some(mut searcher) = pair_searcher(a, b)? else { return Ok(None) };
    Ok(searcher.first_start_after(start, window)?.map(|tau| searcher.reference + tau))
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
/// use vadop::shape_contact::{contact_geometry, RigidMotion};
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
            let (pose_a, pose_b) = pair.poses(tau);
            let (ga, gb) = (pair.a.support(pair.scale), pair.b.support(pair.scale));
            let bounds = convex_bounds(&ga, &pose_a, &gb, &pose_b, true, pair.tol, 0.0);
            let origin = pair.a.position + pair.a.velocity * tau;
            let witness = bounds
                .witness
                .unwrap_or_else(|| (ga.support_point(&pose_a, bounds.axis), gb.support_point(&pose_b, -bounds.axis)));
            Some(contact_point(origin, witness, bounds, DQuat::IDENTITY, pair.scale))
        }
        PairGauge::Plane(pair, flipped) => {
            let (n, pose, distance, _) = pair.state(tau);
            let deepest = pair.body.support(pair.scale).support_point(&pose, -n);
            let origin = pair.plane.position + pair.plane.velocity * tau;
            let point = origin + (deepest - n * (0.5 * distance)) / pair.scale;
            let normal = if *flipped { n } else { -n };
            Some(ContactPoint { point, normal, distance: distance / pair.scale })
        }
        PairGauge::Mesh(pair, flipped) => {
            let bounds = pair.closest(tau, true)?;
            let (_, pose) = pair.state(tau);
            let witness = bounds.witness.unwrap_or_else(|| {
                // The body's extreme point towards the mesh, on both sides.
                let point = pair.body.support(pair.scale).support_point(&pose, -bounds.axis);
                (point, point)
            });
            let origin = pair.body.position + pair.body.velocity * tau;
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

/// A solid and one wall of the box. The frame has world axes and its origin at the body's centre
/// of mass.
struct WallGauge<'a> {
    body: Body<'a>,
    /// The wall's outward normal (out of the box).
    normal: DVec3,
    scale: f64,
    /// Distance from the centre of mass to the wall plane at `since`, scaled.
    gap: f64,
    /// Velocity towards the wall, scaled.
    speed: f64,
    spin: f64,
    size: f64,
}

impl WallGauge<'_> {
    fn distance(&self, tau: f64) -> (f64, DVec3, f64) {
        let pose = self.body.pose(self.body.orientation(tau), DVec3::ZERO, self.scale);
        let extreme = self.body.support(self.scale).support_point(&pose, self.normal);
        let centre = self.gap - self.speed * tau;
        (centre - self.normal.dot(extreme), extreme, SLACK * (centre.abs() + self.size))
    }
}

impl Gauge for WallGauge<'_> {
    fn probe(&self, tau: f64, _depth: bool) -> Probe {
        let (distance, _, slack) = self.distance(tau);
        // The body's bounding sphere from the wall.
        let sphere = self.gap - self.speed * tau - self.size;
        Probe {
            lower: distance - slack,
            upper: distance + slack,
            shrink: self.speed.max(0.0) + self.spin,
            grow: (-self.speed).max(0.0) + self.spin,
            far: (sphere - slack, self.speed.max(0.0)),
        }
    }

    /// The body lies in its bounding sphere.
    fn reach(&self, within: f64) -> Option<Reach> {
        Reach::below(self.gap, -self.speed, self.size + within + SLACK * (self.gap.abs() + self.size))
    }
}

/// The searcher of a body against one wall of the box `[min, max]`.
fn wall_searcher<'a, S: Spin>(
    geometry: &'a ShapeGeometry,
    motion: &'a RigidMotion<S>,
    wall: Wall,
    min: DVec3,
    max: DVec3,
) -> Option<Searcher<WallGauge<'a>>> {
    let size = geometry.bounding_radius()?;
    let body = Body::new(geometry, motion, motion.since);
    let scale = unit_scale(size);
    let axis = wall.axis();
    let gap = if wall.is_max() { max[axis] - body.position[axis] } else { body.position[axis] - min[axis] };
    let speed = if wall.is_max() { body.velocity[axis] } else { -body.velocity[axis] };
    let spin = body.spin_rate() * scale;
    let gauge = WallGauge {
        normal: wall.outward_normal(),
        gap: gap * scale,
        speed: speed * scale,
        spin,
        size: size * scale,
        scale,
        body,
    };
    Some(Searcher::new(gauge, motion.since, SHAPE_CONTACT_TOLERANCE * size * scale))
}

/// The first time in `window` at which a (spinning) shape inside the box `[min, max]` begins to
/// touch one of its six walls while moving into it, with the wall; canonical from `since`, with
/// the tolerance `SHAPE_CONTACT_TOLERANCE * r` (r the bounding radius) and the rules of the module
/// documentation. A body touching a wall at `since` touches it then only if it goes on into the
/// wall, however deep it already is. Ties go to the lowest wall ([`Wall::ALL`] order).
/// Static-only shapes have no walls: `None`.
///
/// ```
/// use glam::{DQuat, DVec3};
/// use vadop::shape::Shape;
/// use vadop::shape_contact::{shape_wall_time, RigidMotion};
/// use vadop::{Wall, Window};
/// let cube = Shape::Cuboid { half_extents: DVec3::splat(1.0) }.geometry().unwrap();
/// let motion = RigidMotion { velocity: DVec3::new(0.0, 0.0, -3.0), ..RigidMotion::fixed(DVec3::splat(5.0), DQuat::IDENTITY, 0.0) };
/// let (t, wall) = shape_wall_time(&cube, &motion, DVec3::ZERO, DVec3::splat(10.0), Window::new(0.0, 5.0)).unwrap().unwrap();
/// assert_eq!(wall, Wall::MinZ);
/// assert!((t - 4.0 / 3.0).abs() < 1e-5);
/// ```
pub fn shape_wall_time<S: Spin>(
    geometry: &ShapeGeometry,
    motion: &RigidMotion<S>,
    min: DVec3,
    max: DVec3,
    window: Window,
) -> Result<Option<(f64, Wall)>> {
    Ok(shape_wall_search(geometry, motion, min, max, window)?.found)
}

/// [`shape_wall_time`] with the number of distance evaluations it took (over the six walls).
pub fn shape_wall_search<S: Spin>(
    geometry: &ShapeGeometry,
    motion: &RigidMotion<S>,
    min: DVec3,
    max: DVec3,
    window: Window,
) -> Result<Search<(f64, Wall)>> {
    let mut best: Option<(f64, Wall)> = None;
    let mut iterations = 0;
    for wall in Wall::ALL {
        let Some(mut searcher) = wall_searcher(geometry, motion, wall, min, max) else { break };
        // A later wall only matters before the best time so far.
        let window = Window::new(window.start, best.map_or(window.end, |(t, _)| t.next_up().min(window.end)));
        let found = searcher.first_start_in(window, false);
        iterations += searcher.iterations;
        if let Some(tau) = found? {
            let time = searcher.reference + tau;
            if best.is_none_or(|(t, _)| time < t) {
                best = Some((time, wall));
            }
        }
    }
    Ok(Search { found: best, iterations })
}

/// Where a shape touches `wall` of the box `[min, max]` at `time`: its extreme point towards the
/// wall moved halfway to it, the wall's outward normal, and the signed distance. `None` for
/// static-only shapes.
pub fn wall_contact_geometry<S: Spin>(
    geometry: &ShapeGeometry,
    motion: &RigidMotion<S>,
    wall: Wall,
    min: DVec3,
    max: DVec3,
    time: f64,
) -> Option<ContactPoint> {
    let searcher = wall_searcher(geometry, motion, wall, min, max)?;
    let g = &searcher.gauge;
    let tau = time - searcher.reference;
    let (distance, extreme, _) = g.distance(tau);
    let centre = g.body.position + g.body.velocity * tau;
    let point = centre + (extreme + g.normal * (0.5 * distance)) / g.scale;
    Some(ContactPoint { point, normal: g.normal, distance: distance / g.scale })
}

#[cfg(test)]
mod tests {
    use super::*;
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

    #[test]
    fn two_static_shapes_never_meet() {
        let floor = Shape::HalfSpace { normal: DVec3::Y }.geometry().unwrap();
        let m = still(DVec3::ZERO);
        assert_eq!(shape_contact_time((&floor, &m), (&floor, &m), Window::new(0.0, 1.0)).unwrap(), None);
        assert!(contact_geometry((&floor, &m), (&floor, &m), 0.0).is_none());
    }
}
