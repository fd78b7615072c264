//! Gauges of a shape against fixed geometry: a half-space, a triangle mesh (static bodies) and a
//! wall of the box. Each measures the body's distance at a probe time and bounds how fast it can
//! change, with the arc of a falling body; it never chooses probe times (the searcher does) and
//! never sees another moving body (the pair gauges in [`super::gauges`] do).

use super::chord::{wall_hold, Moving};
use super::distance::{convex_bounds, Bounds, Need, PROBE_DEPTH_SHARE};
use super::gauges::{Gauge, Measure, Probe, Warm, NO_FAR};
use super::reach::Reach;
use super::scaled::{along, speeding, Body, Scaled};
use super::{guard, starting, SLACK};
use glam::DVec3;
use parry3d_f64::math::Pose;
use parry3d_f64::partitioning::BvhNode;
use parry3d_f64::shape::{SupportMap, TriMesh, Triangle};
use std::cell::{Cell, RefCell};

/// A solid and a half-space. The frame has world axes and its origin at the half-space's origin.
pub(super) struct PlanePair<'a> {
    pub(super) body: Body<'a>,
    pub(super) plane: Body<'a>,
    /// The half-space's outward normal in its own frame.
    pub(super) normal: DVec3,
    pub(super) scale: f64,
    /// The body's centre minus the plane origin at the reference, scaled.
    pub(super) offset: DVec3,
    /// The body's velocity minus the plane's, scaled.
    pub(super) velocity: DVec3,
    /// The body's acceleration minus the plane's, scaled.
    pub(super) acceleration: DVec3,
    pub(super) size: f64,
}

impl PlanePair<'_> {
    /// World outward normal, the body's pose and its signed distance at `tau`.
    pub(super) fn state(&self, tau: f64) -> (DVec3, Pose, f64, f64) {
        let n = self.plane.orientation(tau) * self.normal;
        let centre = along(self.offset, self.velocity, self.acceleration, tau);
        let pose = self.body.pose(self.body.orientation(tau), centre, self.scale);
        let distance = n.dot(self.body.support(self.scale).support_point(&pose, -n));
        (n, pose, distance, SLACK * (centre.length() + self.size))
    }
}

impl Gauge for PlanePair<'_> {
    fn probe(&self, tau: f64, _measure: Measure) -> Probe {
        let (n, _, distance, slack) = self.state(tau);
        let approach = speeding(self.velocity, self.acceleration, tau).dot(n);
        let spin = self.body.spin_rate_along(n) * self.scale;
        // The body's bounding sphere above the plane, which does not turn.
        let height = n.dot(along(self.offset, self.velocity, self.acceleration, tau)) - self.size;
        Probe {
            lower: distance - slack,
            upper: distance + slack,
            shrink: (-approach).max(0.0) + spin,
            grow: approach.max(0.0) + spin,
            far: (height - slack, (-approach).max(0.0)),
            hold: 0.0,
            bend: self.acceleration.dot(n).abs(),
            parting: false,
        }
    }

    /// The body lies in its bounding sphere; the plane does not turn.
    fn reach(&self, within: f64) -> Option<Reach> {
        let n = self.plane.orientation(0.0) * self.normal;
        let limit = self.size + within + SLACK * (self.offset.length() + self.size);
        Reach::below_bent(n.dot(self.offset), n.dot(self.velocity), n.dot(self.acceleration), limit)
    }
}

/// A solid and a triangle mesh. The frame has the mesh's axes and its origin at the body's centre
/// of mass.
pub(super) struct MeshPair<'a> {
    pub(super) body: Body<'a>,
    pub(super) mesh: Body<'a>,
    pub(super) trimesh: &'a TriMesh,
    pub(super) scale: f64,
    /// The body's centre minus the mesh origin at the reference, scaled.
    pub(super) offset: DVec3,
    pub(super) velocity: DVec3,
    /// The body's acceleration minus the mesh's, scaled.
    pub(super) acceleration: DVec3,
    pub(super) spin: f64,
    pub(super) size: f64,
    pub(super) tol: f64,
    /// What the last probe found of the triangles it met.
    pub(super) measures: RefCell<Measures>,
}

/// What a chain's probes keep of the mesh's triangles between them, in buffers they reuse.
#[derive(Default)]
pub(super) struct Measures {
    /// Each triangle the last probe met (measured, or skipped on an earlier measure).
    last: Vec<Measured>,
    /// The same for the probe under way, swapped with `last` after it.
    next: Vec<Measured>,
}

/// The last measure of one triangle: the next probe starts its distance query from it (`warm`),
/// or skips the triangle when its lower bound then, less how far the body can have moved since,
/// is already above an upper bound found on the mesh's distance (the triangle cannot be the
/// nearest, and a measure would only cost a distance query). A skipped triangle keeps its
/// measure, so its bound goes on loosening from there until it is measured again.
#[derive(Debug, Clone, Copy)]
struct Measured {
    id: u32,
    /// When it was measured, and how fast the body's points could move relative to the mesh then.
    tau: f64,
    rate: f64,
    lower: f64,
    warm: Option<Warm>,
}

impl Measured {
    /// A lower bound on the triangle's signed distance to the body at `tau`: the body's points
    /// moved at most `moved` relative to the mesh since the measure (at a speed that changes at
    /// most at `bend`), and so did the distance; the slack covers the rounding of this bound.
    fn lower_at(&self, tau: f64, bend: f64, size: f64) -> f64 {
        let since = (tau - self.tau).abs();
        let moved = self.rate * since + 0.5 * bend * since * since;
        self.lower - moved - SLACK * (self.lower.abs() + moved + size)
    }
}

impl MeshPair<'_> {
    /// The body's centre in the mesh frame (unscaled) and its scaled pose about that centre.
    pub(super) fn state(&self, tau: f64) -> (DVec3, Pose) {
        let q_mesh = self.mesh.orientation(tau).inverse();
        let centre = q_mesh * along(self.offset, self.velocity, self.acceleration, tau) / self.scale;
        let pose = self.body.pose(q_mesh * self.body.orientation(tau), DVec3::ZERO, self.scale);
        (centre, pose)
    }

    /// Triangle `id` in the frame about `centre`, scaled.
    pub(super) fn triangle(&self, id: u32, centre: DVec3) -> Triangle {
        let t = self.trimesh.triangle(id);
        let s = self.scale;
        Triangle::new((t.a - centre) * s, (t.b - centre) * s, (t.c - centre) * s)
    }

    /// Bounds on the signed distance of the body to the mesh (the smallest of the triangles'):
    /// the smallest lower bound of a triangle measured (parry's best-first search over the mesh's
    /// hierarchy, which skips boxes farther than the best so far, and [`Self::search`]'s skips),
    /// and the smallest upper bound met on the way, with its triangle's axis and points, each
    /// triangle measured to `need`.
    pub(super) fn closest(&self, tau: f64, need: Need) -> Option<Bounds> {
        let nearest: Cell<Option<Bounds>> = Cell::new(None);
        let (_, lowest) = self.search(tau, need, &nearest)?;
        let nearest = nearest.get().unwrap_or(lowest);
        Some(Bounds { lower: lowest.lower, ..nearest })
    }

    /// The triangle with the smallest lower bound on its signed distance to the body; `nearest`
    /// keeps the bounds with the smallest upper bound. A triangle whose distance is certainly
    /// above the smallest upper bound met so far, by its last measure (see [`Measured`]) or, when
    /// the chain never measured it, by its plane's separation from the body, is skipped: it
    /// holds neither the smallest lower bound (that is at most the upper bound) nor would it
    /// lower the upper bound, and every lower bound measured stays below its distance.
    pub(super) fn search(&self, tau: f64, need: Need, nearest: &Cell<Option<Bounds>>) -> Option<(u32, Bounds)> {
        let (centre, pose) = self.state(tau);
        let body = self.body.support(self.scale);
        let slack = SLACK * self.size;
        let s = self.scale;
        // The body's box in the frame, from its support points.
        let extent = |d: DVec3| d.dot(body.support_point(&pose, d));
        let high = DVec3::new(extent(DVec3::X), extent(DVec3::Y), extent(DVec3::Z));
        let low = -DVec3::new(extent(-DVec3::X), extent(-DVec3::Y), extent(-DVec3::Z));
        let mut measures = self.measures.borrow_mut();
        let Measures { last, next } = &mut *measures;
        next.clear();
        let next = RefCell::new(next);
        let (rate, bend) = (self.rate(tau), self.acceleration.length());
        let measure = |id: u32, triangle: Triangle, before: Option<&Measured>| {
            let slack = SLACK * (triangle.a.length() + self.size);
            let support = Scaled::triangle(&triangle);
            // The triangle's frame is fixed to it at its first vertex, the body's to the body.
            let carry = (&Pose::from_translation(triangle.a), &pose);
            let warm = before.and_then(|m| m.warm);
            let bounds = (warm
                .and_then(|w| w.bounds((&support, &Pose::IDENTITY), (&body, &pose), carry, self.tol, slack)))
            .unwrap_or_else(|| convex_bounds(&support, &Pose::IDENTITY, &body, &pose, need, self.tol, slack));
            let warm = Warm::new(&bounds, carry);
            next.borrow_mut().push(Measured { id, tau, rate, lower: bounds.lower, warm });
            if nearest.get().is_none_or(|b| bounds.upper < b.upper) {
                nearest.set(Some(bounds));
            }
            bounds
        };
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
                let before = last.iter().find(|m| m.id == id);
                // Built once, and only when a plane test or a measure needs it.
                let mut triangle = None;
                if let Some(near) = nearest.get() {
                    let floor = match before {
                        Some(m) => m.lower_at(tau, bend, self.size),
                        // One support point, where a measure would cost a distance query.
                        None => self.plane_separation(triangle.insert(self.triangle(id, centre)), &body, &pose),
                    };
                    if floor > near.upper {
                        if let Some(m) = before {
                            next.borrow_mut().push(*m);
                        }
                        return None;
                    }
                }
                Some(measure(id, triangle.unwrap_or_else(|| self.triangle(id, centre)), before))
            },
        );
        std::mem::swap(last, next.into_inner());
        found
    }

    /// The body's separation from `triangle`'s plane on the side of its centre, less the slack of
    /// the triangle's bounds: a lower bound on their signed distance, from one support point.
    fn plane_separation(&self, triangle: &Triangle, body: &Scaled, pose: &Pose) -> f64 {
        let Some(n) = triangle.normal() else { return f64::NEG_INFINITY };
        // The body's centre is the frame's origin.
        let n = if n.dot(triangle.a) > 0.0 { -n } else { n };
        n.dot(body.support_point(pose, -n) - triangle.a) - SLACK * (triangle.a.length() + self.size)
    }

    /// How fast the body's points can move relative to the mesh at `tau` (scaled): its centre's
    /// speed and its spin.
    fn rate(&self, tau: f64) -> f64 {
        speeding(self.velocity, self.acceleration, tau).length() + self.spin
    }
}

impl Gauge for MeshPair<'_> {
    fn probe(&self, tau: f64, measure: Measure) -> Probe {
        let rate = self.rate(tau);
        let (lower, upper) =
            match self.closest(tau, Need::probe((measure != Measure::Gap).then_some(PROBE_DEPTH_SHARE))) {
                Some(b) => (b.lower, b.upper),
                None => (f64::INFINITY, f64::INFINITY),
            };
        let bend = self.acceleration.length();
        Probe { lower, upper, shrink: rate, grow: rate, far: NO_FAR, hold: 0.0, bend, parting: false }
    }

    /// The body's bounding sphere against the mesh's box, in the mesh's frame (it does not turn):
    /// the box grown by the sphere's radius (and more at its corners) on each axis.
    fn reach(&self, within: f64) -> Option<Reach> {
        let q_mesh = self.mesh.orientation(0.0).inverse();
        let (centre, velocity, acceleration) =
            (q_mesh * self.offset, q_mesh * self.velocity, q_mesh * self.acceleration);
        let aabb = self.trimesh.local_aabb();
        let (low, high) = (aabb.mins * self.scale, aabb.maxs * self.scale);
        let extent = low.abs().max(high.abs()).max_element();
        let grown = self.size + within + SLACK * (centre.length() + extent + self.size);
        let mut reach = Reach { enter: 0.0, leave: f64::INFINITY };
        for axis in 0..3 {
            let (c, v, a) = (centre[axis], velocity[axis], acceleration[axis]);
            reach = reach.meet(Reach::below_bent(c, v, a, high[axis] + grown)?)?;
            reach = reach.meet(Reach::below_bent(-c, -v, -a, grown - low[axis])?)?;
        }
        Some(reach)
    }

    fn forget(&self) {
        self.measures.borrow_mut().last.clear();
    }
    fn warm_start(&self) -> Option<Option<Warm>> {
        None
    }
}

/// A solid and one wall of the box. The frame has world axes and its origin at the body's centre
/// of mass.
pub(super) struct WallGauge<'a> {
    pub(super) body: Body<'a>,
    /// The wall's outward normal (out of the box).
    pub(super) normal: DVec3,
    pub(super) scale: f64,
    /// Distance from the centre of mass to the wall plane at `since`, scaled.
    pub(super) gap: f64,
    /// Velocity towards the wall at `since`, scaled.
    pub(super) speed: f64,
    /// Acceleration towards the wall (gravity's pull into it), scaled.
    pub(super) pull: f64,
    pub(super) size: f64,
    pub(super) tol: f64,
}

impl WallGauge<'_> {
    pub(super) fn distance(&self, tau: f64) -> (f64, DVec3, f64) {
        let (distance, extreme, slack, _) = self.measure(tau);
        (distance, extreme, slack)
    }

    /// [`Self::distance`] with the shape's pose.
    fn measure(&self, tau: f64) -> (f64, DVec3, f64, Pose) {
        let pose = self.body.pose(self.body.orientation(tau), DVec3::ZERO, self.scale);
        let extreme = self.body.support(self.scale).support_point(&pose, self.normal);
        let centre = self.centre(tau);
        (centre - self.normal.dot(extreme), extreme, SLACK * (centre.abs() + self.size), pose)
    }

    /// How long the shape certainly stays farther from the wall than the middle of the band in
    /// which a contact starts, its extreme point towards the wall followed as it turns (see
    /// [`super::chord::wall_hold`]): 0 when its spin does not give its angular velocity, or when
    /// gravity pulls it along the wall's normal (the certificate is for a straight motion).
    fn apart(&self, tau: f64, pose: &Pose, slack: f64) -> f64 {
        if self.pull != 0.0 {
            return 0.0;
        }
        let Some(turning) = self.body.turning(tau) else { return 0.0 };
        let shape = self.body.support(self.scale);
        let body = Moving {
            shape: &shape,
            pose,
            centre: DVec3::ZERO,
            radius: self.size,
            velocity: self.normal * self.speed,
            turning,
        };
        let on_wall = self.normal * self.centre(tau);
        wall_hold(self.normal, on_wall, &body, starting(self.tol), slack)
    }

    /// The centre of mass's distance from the wall plane `tau` after `since`.
    fn centre(&self, tau: f64) -> f64 {
        let straight = self.gap - self.speed * tau;
        if self.pull == 0.0 {
            straight
        } else {
            straight - self.pull * (0.5 * tau * tau)
        }
    }

    /// The velocity towards the wall `tau` after `since`.
    fn speed_at(&self, tau: f64) -> f64 {
        if self.pull == 0.0 {
            self.speed
        } else {
            self.speed + self.pull * tau
        }
    }
}

/// The times a body whose centre of mass is `gap` from a wall, closing in at `speed` under `pull`,
/// comes within `within` of it: the body lies in its bounding sphere of radius `size`. It needs no
/// pose, so a wall search asks it before building its body (see `shape_wall_search`).
pub(super) fn wall_reach(gap: f64, speed: f64, pull: f64, size: f64, within: f64) -> Option<Reach> {
    Reach::below_bent(gap, -speed, -pull, wall_reach_limit(gap, size, within))
}

/// The centre's distance from the wall below which [`wall_reach`] counts a body `gap` from it in
/// reach: its bounding radius `size`, `within`, and the rounding slack.
pub(super) fn wall_reach_limit(gap: f64, size: f64, within: f64) -> f64 {
    size + within + SLACK * (gap.abs() + size)
}

impl Gauge for WallGauge<'_> {
    fn probe(&self, tau: f64, measure: Measure) -> Probe {
        let (distance, _, slack, pose) = self.measure(tau);
        // The body's bounding sphere from the wall.
        let sphere = self.centre(tau) - self.size;
        let spin = self.body.spin_rate_along(self.normal) * self.scale;
        let speed = self.speed_at(tau);
        let lower = distance - slack;
        Probe {
            lower,
            upper: distance + slack,
            shrink: speed.max(0.0) + spin,
            grow: (-speed).max(0.0) + spin,
            far: (sphere - slack, speed.max(0.0)),
            // A hold away from the wall steps a start search only, never a contact's end.
            hold: if measure == Measure::Gap && lower > guard(self.tol) { self.apart(tau, &pose, slack) } else { 0.0 },
            bend: self.pull.abs(),
            parting: false,
        }
    }

    fn reach(&self, within: f64) -> Option<Reach> {
        wall_reach(self.gap, self.speed, self.pull, self.size, within)
    }
}

#[cfg(test)]
mod tests {
    use super::super::distance::EXACT_DEPTH;
    use super::super::gauges::PairGauge;
    use super::super::pair_searcher;
    use super::*;
    use crate::motion::{FreeRotation, RigidMotion};
    use crate::scene::ShapesScene;
    use glam::DQuat;
    use rand::{Rng, SeedableRng};

    /// A chain's probes over the scenes' bumpy floor, tumbling and falling across it, skip the
    /// triangles their last measures put out of reach; their bounds still hold the mesh's
    /// distance, that of the nearest triangle measured afresh to convergence: a triangle wrongly
    /// skipped as it became the nearest would leave the lower bound above it.
    #[test]
    fn skipped_triangles_leave_the_bounds_rigorous() {
        let scene = ShapesScene { floor: true, ..ShapesScene::new(300, 0.05, 1.0) }.build().unwrap();
        let floor = scene.shapes.iter().find(|s| s.name == "floor").unwrap().shape.geometry().unwrap();
        let mesh = RigidMotion::fixed(scene.static_bodies[0].position, DQuat::IDENTITY, 0.0);
        let side = scene.bounds.max.x;
        let solids = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (mut skipped, mut probes) = (0, 0);
        for case in 0..36 {
            let solid = &solids[case % 6];
            let mut random = |low: f64, high: f64| rng.random_range(low..high);
            let lift = solid.size() * random(0.3, 1.2);
            let position = DVec3::new(random(2.0, side - 2.0), mesh.position.y + 0.125 + lift, random(2.0, side - 2.0));
            let velocity = DVec3::new(random(-2.0, 2.0), random(-0.5, 0.5), random(-2.0, 2.0));
            let start = DQuat::from_scaled_axis(DVec3::new(random(-3.0, 3.0), random(-3.0, 3.0), random(-3.0, 3.0)));
            let omega = DVec3::new(random(-3.0, 3.0), random(-3.0, 3.0), random(-3.0, 3.0));
            let spin = FreeRotation::new(solid.principal_inertia_unit(), start, omega);
            let acceleration = DVec3::new(0.0, -1.0, 0.0);
            let body = RigidMotion { position, since: 0.0, velocity, acceleration, spin };
            let searcher = pair_searcher((&floor, &mesh), (solid, &body)).unwrap().unwrap();
            let PairGauge::Mesh(pair, _) = &searcher.gauge else { panic!("not a mesh pair") };
            for step in 0..30 {
                let tau = 0.01 * step as f64;
                let depth = (step % 2 == 0).then_some(PROBE_DEPTH_SHARE);
                let Some(bounds) = pair.closest(tau, Need::probe(depth)) else { continue };
                probes += 1;
                skipped += pair.measures.borrow().last.iter().filter(|m| m.tau < tau).count();
                let (centre, pose) = pair.state(tau);
                let shape = pair.body.support(pair.scale);
                let (mut lowest, mut nearest) = (f64::INFINITY, f64::INFINITY);
                for id in 0..pair.trimesh.num_triangles() as u32 {
                    let triangle = pair.triangle(id, centre);
                    let need = Need::converged(Some(EXACT_DEPTH));
                    let exact = convex_bounds(
                        &Scaled::triangle(&triangle),
                        &Pose::IDENTITY,
                        &shape,
                        &pose,
                        need,
                        pair.tol,
                        0.0,
                    );
                    (lowest, nearest) = (lowest.min(exact.lower), nearest.min(exact.upper));
                }
                assert!(
                    bounds.lower <= nearest && bounds.upper >= lowest,
                    "case {case}, tau {tau}: bounds [{}, {}] miss the distance in [{lowest}, {nearest}]",
                    bounds.lower,
                    bounds.upper
                );
            }
        }
        // Most probes skip some triangle.
        assert!(skipped > probes, "{skipped} triangles skipped in {probes} probes");
    }
}
