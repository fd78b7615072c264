//! Shapes as the search sees them: scaled by an exact power of two to unit size, split into a
//! core and a radius where the shape has one (a sphere's centre, a capsule's segment), with the
//! support maps and features the distance bounds read, and a body's shape placed at a probe time.
//! It owns that scaled view only; it never bounds distances or steps a search.

use super::distance::separation;
use super::inner_balls::ShapeBall;
use crate::motion::{RigidMotion, Spin};
use crate::shape::ShapeGeometry;
use glam::{DQuat, DVec3};
use parry3d_f64::math::Pose;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::{
    Ball, Capsule, Cone, ConvexPolyhedron, Cuboid, Cylinder, Segment, Shape, SupportMap, Triangle,
};
use std::cell::Cell;

/// A shape's support map with lengths multiplied by an exact power of two, and the shape itself
/// for its flat features.
pub(super) struct Scaled<'a> {
    /// The shape is the set of points within `margin` of its core.
    pub(super) core: Core<'a>,
    pub(super) margin: f64,
    pub(super) parry: &'a dyn Shape,
    /// Which primitive `parry` is, asked once.
    pub(super) kind: Kind<'a>,
    pub(super) scale: f64,
    /// `1 / scale`, exact (a power of two): a point is brought back to the shape's own lengths
    /// by a product, which gives the quotient's bits, not by a division, whose latency was a
    /// tenth of the depth evaluations' time at 5 d/f.
    pub(super) inverse_scale: f64,
}

/// The primitive a parry shape is, for the closed forms that depend on it: asked of the shape once
/// per search's view of it, not at every depth or projection.
#[derive(Clone, Copy)]
pub(super) enum Kind<'a> {
    Ball(&'a Ball),
    Capsule(&'a Capsule),
    Cuboid(&'a Cuboid),
    Cylinder(&'a Cylinder),
    /// With its slant height, `sqrt(4 h² + r²)` for half height `h` and radius `r`.
    Cone(&'a Cone, f64),
    /// A hull with its face planes (see [`ShapeGeometry::face_planes`]).
    Hull(&'a ConvexPolyhedron, &'a [(DVec3, f64)]),
    /// Any other shape (a triangle of a mesh): no closed form.
    Other,
}

impl<'a> Kind<'a> {
    fn of(shape: &'a dyn Shape, planes: &'a [(DVec3, f64)]) -> Kind<'a> {
        if let Some(ball) = shape.as_ball() {
            Kind::Ball(ball)
        } else if let Some(capsule) = shape.as_capsule() {
            Kind::Capsule(capsule)
        } else if let Some(cuboid) = shape.as_cuboid() {
            Kind::Cuboid(cuboid)
        } else if let Some(cylinder) = shape.as_cylinder() {
            Kind::Cylinder(cylinder)
        } else if let Some(cone) = shape.as_cone() {
            let (h, r) = (cone.half_height, cone.radius);
            Kind::Cone(cone, (4.0 * h * h + r * r).sqrt())
        } else if let Some(hull) = shape.as_convex_polyhedron() {
            debug_assert_eq!(planes.len(), hull.faces().len(), "a hull's planes come with it");
            Kind::Hull(hull, planes)
        } else {
            Kind::Other
        }
    }
}

/// The convex set a shape is the neighbourhood of, in the shape frame and scaled: a ball's
/// centre, a capsule's segment, or the shape itself. Distances between points and segments have
/// closed forms, where GJK would converge slowly on the round surfaces around them.
#[derive(Clone, Copy)]
pub(super) enum Core<'a> {
    Point,
    Segment(Segment),
    Solid(&'a dyn SupportMap),
}

impl<'a> Scaled<'a> {
    /// A body's shape, scaled by `scale`.
    pub(super) fn new(geometry: &'a ShapeGeometry, scale: f64) -> Self {
        Self::build(geometry.parry_shape().as_ref(), geometry.face_planes(), scale)
    }

    /// A triangle of a mesh, unscaled.
    pub(super) fn triangle(triangle: &'a Triangle) -> Self {
        Self::build(triangle, &[], 1.0)
    }

    fn build(parry: &'a dyn Shape, planes: &'a [(DVec3, f64)], scale: f64) -> Self {
        let kind = Kind::of(parry, planes);
        let (core, margin) = match kind {
            Kind::Ball(ball) => (Core::Point, ball.radius),
            Kind::Capsule(capsule) => {
                let segment = Segment::new(capsule.segment.a * scale, capsule.segment.b * scale);
                (Core::Segment(segment), capsule.radius)
            }
            _ => (Core::Solid(parry.as_support_map().expect("solid shapes have support maps")), 0.0),
        };
        let inverse_scale = 1.0 / scale;
        debug_assert!(scale.is_normal() && scale.to_bits() & ((1 << 52) - 1) == 0, "the scale is a power of two");
        Scaled { core, margin: margin * scale, parry, kind, scale, inverse_scale }
    }

    /// How deep the point `p` (in the shape's frame, scaled) lies inside the shape: the radius of
    /// a ball about it that the shape holds, exact to rounding, at most 0 outside; with the
    /// direction (in the shape's frame) in which that depth grows fastest, away from the nearest
    /// face. A kind without a closed form counts every point 0 deep.
    pub(super) fn depth_at(&self, p: DVec3) -> (f64, DVec3) {
        self.depth_with::<true>(p)
    }

    /// [`Self::depth_at`]'s depth alone, to the bit: without the direction's divisions, which
    /// sat on the chain of every depth a distance bound asked for.
    pub(super) fn depth_only(&self, p: DVec3) -> f64 {
        self.depth_with::<false>(p).0
    }

    /// The depth, and with `INWARD` its direction (zero without).
    #[inline(always)]
    fn depth_with<const INWARD: bool>(&self, p: DVec3) -> (f64, DVec3) {
        let unit = |v: DVec3| if INWARD { v.normalize_or_zero() } else { DVec3::ZERO };
        match &self.core {
            Core::Point => (self.margin - p.length(), -unit(p)),
            Core::Segment(segment) => {
                let on = segment.project_local_point(p, true).point;
                (self.margin - on.distance(p), unit(on - p))
            }
            Core::Solid(_) => {
                let (depth, inward) = solid_depth::<INWARD>(self.kind, p * self.inverse_scale);
                (depth * self.scale, inward)
            }
        }
    }

    /// At least the signed distance of the point `p` (in the shape's frame, scaled) from the
    /// shape, negative inside, to rounding: the closed-form depth inside (and on either side for
    /// a ball or a capsule), outside the distance to the nearest point of the shape (parry's
    /// closed forms for the primitives, [`hull_nearest`] for a hull).
    pub(super) fn signed_distance_above(&self, p: DVec3) -> f64 {
        let local = p * self.inverse_scale;
        if let Kind::Hull(hull, planes) = self.kind {
            // One pass over the faces tells inside from outside and finds the nearest point.
            return match hull_nearest(hull, planes, local) {
                HullPoint::Outside(on) => on.distance(local) * self.scale,
                HullPoint::Inside(depth) => -depth * self.scale,
            };
        }
        let depth = self.depth_only(p);
        if depth > 0.0 || !matches!(self.core, Core::Solid(_)) {
            return -depth;
        }
        let projection = self.parry.project_local_point(local, true);
        if projection.is_inside {
            0.0
        } else {
            projection.point.distance(local) * self.scale
        }
    }

    /// The shape's core, as a support map.
    pub(super) fn core(&self) -> CoreOf<'_, 'a> {
        CoreOf(self)
    }
}

/// How deep `p` lies inside a solid without a core, in the shape's own lengths, and the
/// direction away from the nearest face: the nearest of the planes of its faces, and for round
/// sides the exact distance to them; 0 for a kind without a closed form.
#[inline(always)]
fn solid_depth<const INWARD: bool>(kind: Kind, p: DVec3) -> (f64, DVec3) {
    fn nearest(faces: impl IntoIterator<Item = (f64, DVec3)>) -> (f64, DVec3) {
        faces.into_iter().fold((f64::INFINITY, DVec3::ZERO), |x, y| if y.0 < x.0 { y } else { x })
    }
    if let Kind::Cuboid(cuboid) = kind {
        let inward = |axis: usize| -DVec3::AXES[axis] * p[axis].signum();
        return nearest((0..3).map(|k| (cuboid.half_extents[k] - p[k].abs(), inward(k))));
    }
    let across = DVec3::new(p.x, 0.0, p.z);
    let radius = across.length();
    let outward = if INWARD { across.normalize_or_zero() } else { DVec3::ZERO };
    if let Kind::Cylinder(cylinder) = kind {
        return nearest([
            (cylinder.radius - radius, -outward),
            (cylinder.half_height - p.y.abs(), -DVec3::Y * p.y.signum()),
        ]);
    }
    if let Kind::Cone(cone, slant) = kind {
        // Apex at +h, base of radius r at -h: a point inside is nearest the base or the side's
        // generator through it, whose line it meets at right angles (the half angle is acute).
        let (h, r) = (cone.half_height, cone.radius);
        let side = (r * (h - p.y) / (2.0 * h) - radius) * (2.0 * h) / slant;
        let side_inward = if INWARD { -(outward * (2.0 * h) + DVec3::Y * r) / slant } else { DVec3::ZERO };
        return nearest([(side, side_inward), (p.y + h, DVec3::Y)]);
    }
    if let Kind::Hull(_, planes) = kind {
        // The nearest plane by its index: its normal is read once, not carried through the scan.
        let (mut depth, mut face) = (f64::INFINITY, 0);
        for (k, &(normal, offset)) in planes.iter().enumerate() {
            let below = offset - normal.dot(p);
            if below < depth {
                (depth, face) = (below, k);
            }
        }
        return (depth, -planes[face].0);
    }
    (0.0, DVec3::ZERO)
}

/// Where a point lies against a hull: outside, with the hull's point nearest to it, or inside,
/// as deep as its nearest face's plane is from it (at least 0).
pub(super) enum HullPoint {
    Outside(DVec3),
    Inside(f64),
}

/// Where `p` (in the hull's frame) lies against `hull` (with its face `planes`). Outside, the
/// nearest point is on a face `p` lies above (the direction to `p` is in the normal cone there, so
/// some face through the nearest point has `p` above its plane): at its foot on the plane of the
/// face `p` lies farthest above, where the foot falls in that face (the plane bounds the hull:
/// nothing is nearer), else on an edge of a face `p` lies above. Only that farthest face can hold
/// the foot: a foot inside a face is the nearest point, at least as far as every plane. So one
/// pass over the planes, one face's ring, and the edges only where needed; not parry's projections
/// on each face's fan of triangles (two fifths of this function's instructions, itself 6 % of the
/// peers' shapes' at 5 d/f), nor a ring test on every face above (a third of what was left). Any
/// point found lies on the hull, so its distance bounds the hull's from above whatever the
/// rounding; inside, the depth is [`Scaled::depth_at`]'s, to the bit.
pub(super) fn hull_nearest(hull: &ConvexPolyhedron, planes: &[(DVec3, f64)], p: DVec3) -> HullPoint {
    let (points, corners) = (hull.points(), hull.vertices_adj_to_face());
    let mut depth = f64::INFINITY;
    let mut farthest = 0;
    for (k, &(normal, offset)) in planes.iter().enumerate() {
        let below = offset - normal.dot(p);
        if below < depth {
            (depth, farthest) = (below, k);
        }
    }
    if !(depth < 0.0) {
        return HullPoint::Inside(depth.max(0.0));
    }
    // A face's edges as its ring of corners turns, each from a corner to the next (the last back
    // to the first, by a comparison: an index modulo the ring's length was an integer division).
    let edges = |k: usize| {
        let face = &hull.faces()[k];
        let first = face.first_vertex_or_edge as usize;
        let ring = &corners[first..first + face.num_vertices_or_edges as usize];
        let corner = move |i: usize| points[ring[if i == ring.len() { 0 } else { i }] as usize];
        (0..ring.len()).map(move |i| (corner(i), corner(i + 1)))
    };
    let (normal, _) = planes[farthest];
    let foot = p + normal * depth;
    // On the same side of every edge, as the ring turns: inside the face.
    let turn = |(a, b): (DVec3, DVec3)| normal.dot((b - a).cross(foot - a));
    if edges(farthest).all(|edge| turn(edge) > 0.0) || edges(farthest).all(|edge| turn(edge) < 0.0) {
        return HullPoint::Outside(foot);
    }
    let mut best: Option<(f64, DVec3)> = None;
    for (k, &(normal, offset)) in planes.iter().enumerate() {
        if !(offset - normal.dot(p) < 0.0) {
            continue;
        }
        for (a, b) in edges(k) {
            let along = b - a;
            let t = ((p - a).dot(along) / along.length_squared()).clamp(0.0, 1.0);
            let on = a + along * t;
            let distance = on.distance_squared(p);
            if t.is_finite() && best.is_none_or(|(d, _)| distance < d) {
                best = Some((distance, on));
            }
        }
    }
    // A hull's edges have length: a corner (on the hull) only if rounding made them all none.
    let corner = || edges(farthest).next().map_or(foot, |(a, _)| a);
    HullPoint::Outside(best.map_or_else(corner, |(_, on)| on))
}

/// The support map of a shape's core.
pub(super) struct CoreOf<'s, 'a>(&'s Scaled<'a>);

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
pub(super) struct Features {
    pub(super) normals: [DVec3; 3],
    pub(super) normal_count: usize,
    pub(super) edges: [DVec3; 4],
    pub(super) edge_count: usize,
}

impl Features {
    pub(super) fn normal(&mut self, n: DVec3) {
        if self.normal_count < self.normals.len() {
            self.normals[self.normal_count] = n;
            self.normal_count += 1;
        }
    }
    pub(super) fn edge(&mut self, e: DVec3) {
        if self.edge_count < self.edges.len() {
            self.edges[self.edge_count] = e;
            self.edge_count += 1;
        }
    }
    pub(super) fn normals(&self) -> &[DVec3] {
        &self.normals[..self.normal_count]
    }
    pub(super) fn edges(&self) -> &[DVec3] {
        &self.edges[..self.edge_count]
    }
}

impl Scaled<'_> {
    /// The flat features of the shape (posed by `rotation`) that may face along `dir`: the
    /// directions a separating axis must be exactly orthogonal to, or equal to, for the
    /// separation along it to be tight when the shapes nearly touch.
    pub(super) fn features(&self, rotation: DQuat, dir: DVec3) -> Features {
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
pub(super) fn refine(
    a: &Scaled,
    pose_a: &Pose,
    b: &Scaled,
    pose_b: &Pose,
    axis: DVec3,
    mut best: (f64, DVec3),
) -> (f64, DVec3) {
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
    pub(super) fn middle(&self) -> DVec3 {
        self.parry.compute_local_aabb().center() * self.scale
    }

    /// The ball about [`Self::middle`] that the shape holds, its centre and radius: `None` when
    /// the middle lies outside (a box's centre need not lie in a convex shape) or the kind has
    /// no closed-form depth.
    pub(super) fn middle_ball(&self) -> Option<ShapeBall> {
        let middle = self.middle();
        let depth = self.depth_only(middle);
        (depth > 0.0).then_some((middle, depth))
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

/// A body's turning at a probe time: its world angular velocity, and bounds on the angular
/// speed and on the angular acceleration over all time.
#[derive(Debug, Clone, Copy)]
pub(super) struct Turning {
    pub(super) omega: DVec3,
    pub(super) speed: f64,
    pub(super) acceleration: f64,
}

/// A body as the gauges see it, relative to the reference instant.
pub(super) struct Body<'a> {
    pub(super) geometry: &'a ShapeGeometry,
    pub(super) spin: &'a dyn Spin,
    pub(super) lag: f64,
    /// The centre of mass and its velocity at the reference, on the body's path.
    pub(super) position: DVec3,
    pub(super) velocity: DVec3,
    /// The centre's uniform acceleration (gravity; none on a straight path).
    pub(super) acceleration: DVec3,
    /// The orientation of a body whose turning leaves its shape where it is: a ball, a body that
    /// does not turn, or a steady spin about the shape's axis of symmetry (see [`still`]). Its
    /// shape is then the same set at every time, taken at this orientation; `None` for a body
    /// whose turning moves its shape.
    pub(super) still: Option<DQuat>,
    /// The world axis (a unit vector) of a steady spin that moves the shape, and how far the
    /// shape's core reaches from the line along it through the centre of mass: a point of the
    /// core moves at most `max_angular_speed` times its distance from that line, and only across
    /// the axis. Without a steady axis, the rotation radius.
    pub(super) axis: Option<DVec3>,
    pub(super) reach: f64,
    /// The angular velocity at the last time its orientation was asked for, found with it: a
    /// probe asks for both at one time, and for a tumbling body they share an elliptic integral.
    turned: Cell<(f64, Option<DVec3>)>,
}

/// Where a point at `position` moving at `velocity` under the uniform `acceleration` is `tau`
/// later: a parabola, and the straight path's bits without acceleration.
#[inline]
pub(super) fn along(position: DVec3, velocity: DVec3, acceleration: DVec3, tau: f64) -> DVec3 {
    let straight = position + velocity * tau;
    if acceleration == DVec3::ZERO {
        straight
    } else {
        straight + acceleration * (0.5 * tau * tau)
    }
}

/// The velocity `tau` later of a point moving at `velocity` under the uniform `acceleration`.
#[inline]
pub(super) fn speeding(velocity: DVec3, acceleration: DVec3, tau: f64) -> DVec3 {
    if acceleration == DVec3::ZERO {
        velocity
    } else {
        velocity + acceleration * tau
    }
}

/// The orientation at which a body of `geometry` turning by `spin` always shows the same shape,
/// if it does: its orientation at its motion's start when it is a ball (or a static-only shape),
/// when it does not turn, or when it turns steadily about the axis the shape is symmetric about
/// (a capsule, cylinder or cone about its own y axis; exactly: the spin's body-frame components
/// off that axis are zero after [`crate::motion::FreeRotation`]'s rounding snap).
pub(super) fn still(geometry: &ShapeGeometry, spin: &dyn Spin) -> Option<DQuat> {
    let unmoved = geometry.rotation_radius() == 0.0
        || spin.steady_spin().is_some_and(|w| {
            w == DVec3::ZERO || geometry.symmetry_axis().is_some_and(|axis| w.cross(axis) == DVec3::ZERO)
        });
    unmoved.then(|| spin.orientation_at(0.0))
}

impl<'a> Body<'a> {
    pub(super) fn new<S: Spin>(geometry: &'a ShapeGeometry, motion: &'a RigidMotion<S>, reference: f64) -> Self {
        let lag = reference - motion.since;
        let still = still(geometry, &motion.spin);
        let steady = motion.spin.steady_spin().filter(|_| still.is_none()).and_then(|w| w.try_normalize());
        let (axis, reach) = match steady {
            Some(w) => (Some(motion.spin.orientation_at(0.0) * w), geometry.rotation_radius_about(w)),
            None => (None, geometry.rotation_radius()),
        };
        Body {
            geometry,
            spin: &motion.spin,
            lag,
            position: motion.position_at(reference),
            velocity: motion.velocity_at(reference),
            acceleration: motion.acceleration,
            still,
            axis,
            reach,
            turned: Cell::new((f64::NAN, None)),
        }
    }

    /// The centre of mass `tau` after the reference (unscaled).
    pub(super) fn centre(&self, tau: f64) -> DVec3 {
        along(self.position, self.velocity, self.acceleration, tau)
    }

    pub(super) fn orientation(&self, tau: f64) -> DQuat {
        match self.still {
            Some(q) => q,
            None => {
                let (orientation, omega) = self.spin.orientation_and_angular_velocity_at(self.lag + tau);
                self.turned.set((tau, omega));
                orientation
            }
        }
    }

    /// The body's turning at `tau` as [`super::chord`] reads it: none for a body held still,
    /// `None` when its spin gives no angular velocity.
    pub(super) fn turning(&self, tau: f64) -> Option<Turning> {
        if self.still.is_some() {
            return Some(Turning { omega: DVec3::ZERO, speed: 0.0, acceleration: 0.0 });
        }
        let omega = match self.turned.get() {
            (at, omega) if at == tau => omega,
            _ => self.spin.angular_velocity_at(self.lag + tau),
        }?;
        Some(Turning {
            omega,
            speed: self.spin.max_angular_speed(),
            acceleration: self.spin.max_angular_acceleration(),
        })
    }

    /// A bound on how fast the body's shape turns: 0 when turning leaves it where it is.
    pub(super) fn turning_speed(&self) -> f64 {
        if self.still.is_some() {
            0.0
        } else {
            self.spin.max_angular_speed()
        }
    }

    /// How fast turning can move the surface, in unscaled lengths per time.
    pub(super) fn spin_rate(&self) -> f64 {
        self.turning_speed() * self.reach
    }

    /// How fast turning can move the shape's support along the fixed unit direction `n`, in
    /// unscaled lengths per time: a steady spin moves points only across its axis.
    pub(super) fn spin_rate_along(&self, n: DVec3) -> f64 {
        match self.axis {
            Some(axis) => self.spin_rate() * (n.cross(axis).length() * (1.0 + 1e-12)).min(1.0),
            None => self.spin_rate(),
        }
    }

    /// How fast turning can move the point `p` fixed in the body (in any frame with the body's
    /// centre of mass at `centre`, world axes): its distance from the spin's axis (or from the
    /// centre of mass, without a steady one) times the angular speed bound.
    pub(super) fn drift_of(&self, p: DVec3, centre: DVec3) -> f64 {
        let offset = p - centre;
        let lever = match self.axis {
            Some(axis) => offset.reject_from_normalized(axis).length() * (1.0 + 1e-12),
            None => offset.length(),
        };
        self.turning_speed() * lever
    }

    pub(super) fn support(&self, scale: f64) -> Scaled<'a> {
        Scaled::new(self.geometry, scale)
    }

    /// The scaled parry pose of the shape for centre of mass `centre` and orientation `q`.
    pub(super) fn pose(&self, q: DQuat, centre: DVec3, scale: f64) -> Pose {
        let body = self.geometry.body_from_shape();
        Pose::from_parts(centre + q * (body.translation * scale), q * body.rotation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Shape;
    use rand::{Rng, SeedableRng};

    /// The nearest point of a hull's faces is parry's projection (GJK on the support map), to
    /// 1e-9, for points near and far around two irregular hulls, and a point inside is as deep
    /// as `depth_at` says, to the bit.
    #[test]
    fn hull_nearest_is_the_projection() {
        let eight = [[0.42, 0.0, 0.0], [-0.3, 0.3, 0.1], [-0.2, -0.3, 0.2], [0.0, 0.1, -0.38], [0.1, 0.0, 0.38]];
        let more = [[0.2, 0.25, -0.2], [-0.25, -0.1, -0.25], [0.15, -0.3, -0.1]];
        let hulls = [eight.to_vec(), [eight.as_slice(), more.as_slice()].concat()]
            .map(|points| Shape::ConvexHull { points: points.into_iter().map(DVec3::from_array).collect() });
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (mut outside, mut inside) = (0, 0);
        for shape in &hulls {
            let geometry = shape.geometry().unwrap();
            let hull = geometry.parry_shape().as_convex_polyhedron().unwrap();
            for k in 0..20_000 {
                let reach = [0.05, 0.5, 3.0][k % 3];
                let p =
                    DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
                        * reach;
                let parry = hull.project_local_point(p, true);
                match hull_nearest(hull, geometry.face_planes(), p) {
                    HullPoint::Outside(on) => {
                        outside += 1;
                        assert!(!parry.is_inside, "{p} found outside, parry says inside");
                        let (mine, theirs) = (on.distance(p), parry.point.distance(p));
                        assert!((mine - theirs).abs() <= 1e-9, "{p}: {mine} against parry's {theirs}");
                    }
                    HullPoint::Inside(depth) => {
                        inside += 1;
                        assert!(parry.is_inside || parry.point.distance(p) < 1e-12, "{p} found inside");
                        let scaled = Scaled::new(&geometry, 1.0);
                        assert_eq!(depth.to_bits(), scaled.depth_at(p).0.max(0.0).to_bits(), "{p}");
                    }
                }
            }
        }
        assert!(outside > 10_000 && inside > 1_000, "{outside} outside, {inside} inside");
    }

    /// No point of a solid's core (its support points in every direction) lies farther from a
    /// line through the centre of mass than `rotation_radius_about` that line's axis says, and
    /// about a principal axis, for a cuboid, a capsule and a hull, some point lies nearly that
    /// far: the bound a steady spin about the axis moves the shape by.
    #[test]
    fn the_core_lies_within_its_reach_from_every_axis() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut unit = move || {
            DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
                .normalize_or(DVec3::X)
        };
        for shape in crate::shape::one_solid_of_each_kind() {
            let geometry = shape.geometry().unwrap();
            let scaled = Scaled::new(&geometry, 1.0);
            let exact = matches!(shape, Shape::Cuboid { .. } | Shape::Capsule { .. } | Shape::ConvexHull { .. });
            for case in 0..200 {
                // The principal axes, where the bound is exact, then any.
                let axis = if case < 6 { DVec3::AXES[case % 3] * if case < 3 { 1.0 } else { -1.0 } } else { unit() };
                let bound = geometry.rotation_radius_about(axis);
                assert!(bound <= geometry.rotation_radius(), "{shape:?}: {bound} above the rotation radius");
                let mut farthest: f64 = 0.0;
                for _ in 0..400 {
                    let point = geometry.body_from_shape() * scaled.core().local_support_point(unit());
                    let off = point.reject_from_normalized(axis).length();
                    assert!(off <= bound * (1.0 + 1e-9), "{shape:?} about {axis}: {off} beyond {bound}");
                    farthest = farthest.max(off);
                }
                if exact && case < 6 {
                    assert!(farthest >= 0.9 * bound, "{shape:?} about {axis}: {farthest} of {bound}");
                }
            }
        }
    }

    /// The depth of a point inside each solid is its distance to the boundary (parry's
    /// projection), to rounding; outside it is at most 0; and the inward direction deepens it.
    #[test]
    fn depth_inside_every_solid_is_the_distance_to_its_boundary() {
        let shapes = crate::shape::one_solid_of_each_kind();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut random = move || rng.random_range(-0.5..0.5);
        for shape in &shapes {
            let geometry = shape.geometry().unwrap();
            // Scaled by 4: depths scale with it.
            let scaled = Scaled::new(&geometry, 4.0);
            let mut inside = 0;
            for _ in 0..5000 {
                let p = DVec3::new(random(), random(), random()) * 1.2;
                let projection = geometry.parry_shape().project_local_point(p, false);
                let (depth, inward) = scaled.depth_at(p * 4.0);
                if projection.is_inside {
                    inside += 1;
                    let exact = projection.point.distance(p) * 4.0;
                    assert!((depth - exact).abs() < 1e-12, "{shape:?} at {p}: {depth} against {exact}");
                    let deeper = scaled.depth_at(p * 4.0 + inward * (1e-3 * depth)).0;
                    assert!(deeper >= depth - 1e-12, "{shape:?} at {p}: {inward} does not deepen");
                } else {
                    assert!(depth <= 1e-12, "{shape:?} at {p}: outside, yet {depth} deep");
                }
            }
            assert!(inside > 100, "{shape:?}: only {inside} points inside");
        }
    }
}
