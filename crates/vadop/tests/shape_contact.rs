//! The shape narrow phase against an independent oracle: parry's own distance query sampled
//! densely in time, on random shapes, sizes, poses, velocities and spins. Every pair of solid
//! kinds, every solid against a static mesh and a half-space, and every solid in the box:
//!
//! (a) nothing missed: outside the reported contacts no sample is within `tol/2`, at a reported
//!     start the distance is at most `tol`, inside a contact at most `2 tol`;
//! (b) no tunnelling: thin plates crossed at 1000 diameters per frame, a fast-spinning long box;
//! (c) canonical: the same time for every window holding it, bit-identical repeats, and scaling a
//!     scene by a power of two scales the times' inputs without changing them;
//! (d) hand-computed cases.
//!
//! The spin used here turns at a constant angular velocity: it stands in for the torque-free
//! rotation, which only needs to bound its angular speed the same way.

use glam::{DQuat, DVec3};
use parry3d_f64::bounding_volume::BoundingVolume;
use parry3d_f64::math::Pose;
use parry3d_f64::shape::Shape as ParryShape;
use parry3d_f64::shape::TriMesh;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::fmt::Debug;
use std::time::Instant;
use vadop::motion::FreeRotation;
use vadop::motion::Motion;
use vadop::motion::{RigidMotion, Spin};
use vadop::narrow_phase::shapes::{
    contact_end_search, contact_end_time, contact_geometry, contact_in_progress_end_time, contact_tolerance,
    shape_contact_after, shape_contact_after_parked, shape_contact_resumed, shape_contact_search, shape_contact_time,
    shape_wall_search, shape_wall_time, wall_contact_geometry,
};
use vadop::narrow_phase::spheres::pair_contact_time;
use vadop::shape::{Shape, ShapeGeometry};
use vadop::{Wall, Window};

/// Constant angular velocity `omega` (world frame) from orientation `start` (test only); with
/// `body`, that angular velocity in the body frame, which the search may read (as it reads the
/// torque-free rotation's steady spins) to tell a spin that leaves a symmetric shape in place.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Steady {
    start: DQuat,
    omega: DVec3,
    body: Option<DVec3>,
}

impl Spin for Steady {
    fn orientation_at(&self, dt: f64) -> DQuat {
        (DQuat::from_scaled_axis(self.omega * dt) * self.start).normalize()
    }
    fn max_angular_speed(&self) -> f64 {
        self.omega.length() * (1.0 + 1e-12)
    }
    fn steady_spin(&self) -> Option<DVec3> {
        self.body
    }
    fn angular_velocity_at(&self, _dt: f64) -> Option<DVec3> {
        Some(self.omega)
    }
    fn max_angular_acceleration(&self) -> f64 {
        0.0
    }
}

/// A body: its shape and motion, turning at a constant angular velocity unless said otherwise.
type Body<S = Steady> = (ShapeGeometry, RigidMotion<S>);

fn body(geometry: ShapeGeometry, position: DVec3, velocity: DVec3, start: DQuat, omega: DVec3) -> Body {
    (
        geometry,
        RigidMotion {
            position,
            since: 0.0,
            velocity,
            acceleration: DVec3::ZERO,
            spin: Steady { start, omega, body: None },
        },
    )
}

/// A body spinning at `rate` about its shape's axis of symmetry (the body frame's image of the
/// shape's y axis), said to be steady; a body of a kind without one does not turn.
fn symmetric_spinner(geometry: ShapeGeometry, position: DVec3, velocity: DVec3, start: DQuat, rate: f64) -> Body {
    let symmetric = matches!(geometry.shape(), Shape::Capsule { .. } | Shape::Cylinder { .. } | Shape::Cone { .. });
    let axis = if symmetric { geometry.body_from_shape().rotation * DVec3::Y * rate } else { DVec3::ZERO };
    steady_spinner(geometry, position, velocity, start, axis)
}

/// A body turning at the constant angular velocity `body` (in its own frame), said to be steady:
/// the search may bound its turning by the shape's reach from that axis.
fn steady_spinner(geometry: ShapeGeometry, position: DVec3, velocity: DVec3, start: DQuat, body: DVec3) -> Body {
    let spin = Steady { start, omega: start * body, body: Some(body) };
    (geometry, RigidMotion { position, since: 0.0, velocity, acceleration: DVec3::ZERO, spin })
}

/// A body tumbling by the exact torque-free rotation of its shape's inertia, from orientation
/// `start` and world angular velocity `omega`.
fn tumbler(
    geometry: ShapeGeometry,
    position: DVec3,
    velocity: DVec3,
    start: DQuat,
    omega: DVec3,
) -> Body<FreeRotation> {
    let spin = FreeRotation::new(geometry.principal_inertia_unit(), start, omega);
    (geometry, RigidMotion { position, since: 0.0, velocity, acceleration: DVec3::ZERO, spin })
}

fn fixed(geometry: ShapeGeometry, position: DVec3, orientation: DQuat) -> Body {
    body(geometry, position, DVec3::ZERO, orientation, DVec3::ZERO)
}

fn pair<S>(b: &Body<S>) -> (&ShapeGeometry, &RigidMotion<S>) {
    (&b.0, &b.1)
}

/// parry's distance of the two shapes at time `t` (0 when they intersect): the oracle.
///
/// A hair from contact, and for flat or thin shapes, a single parry query sometimes calls
/// separated shapes intersecting or returns far-off closest points. The oracle asks four times
/// (distance and contact queries, both orders; GJK starts differently in each) and takes the
/// smallest positive answer, unless at least two say the shapes intersect. No answer counts below
/// the shapes' separation along the contact queries' normals, from parry's support functions: a
/// separation along any axis bounds the distance from below, so an answer under it is a query's
/// error (a cuboid edge a hair from a cylinder's rim once read 3.56e-6 and 0 where a normal
/// separated them by 4.35e-6). parry's distance to a half-space is a closed form and is taken as
/// is (its contact query mistakes the frames when the half-space comes second). A mesh has no
/// support function, so near it the distance is the least of its triangles', each read as above:
/// a cone's tip a hair from a bumpy floor once read 0 in both of the whole mesh's distance
/// queries where both contact queries read 1.70e-6, a nanosecond either side 1.695e-6 and
/// 1.699e-6.
fn distance<S: Spin, T: Spin>(a: &Body<S>, b: &Body<T>, t: f64) -> f64 {
    let (pa, pb) = (
        a.0.pose_of_shape(a.1.position_at(t), a.1.orientation_at(t)),
        b.0.pose_of_shape(b.1.position_at(t), b.1.orientation_at(t)),
    );
    shapes_distance(&pa, a.0.parry_shape().as_ref(), &pb, b.0.parry_shape().as_ref())
}

/// [`distance`] of two parry shapes at their poses.
fn shapes_distance(pa: &Pose, sa: &dyn ParryShape, pb: &Pose, sb: &dyn ParryShape) -> f64 {
    // Beyond this the whole mesh's query is trusted (its failures are a hair from contact).
    const NEAR_MESH: f64 = 1e-3;
    let d = parry3d_f64::query::distance(pa, sa, pb, sb).unwrap().distance;
    if sa.as_halfspace().is_some() || sb.as_halfspace().is_some() {
        return d;
    }
    if d <= NEAR_MESH {
        // The least of the distances of the mesh's triangles within reach of the other's box.
        let least = |mesh: &TriMesh, pose: &Pose, other: &dyn ParryShape, other_pose: &Pose, mesh_first: bool| {
            let reach = other.compute_aabb(other_pose).loosened(NEAR_MESH);
            let near = mesh.triangles().filter(|t| t.compute_aabb(pose).intersects(&reach));
            near.map(|t| match mesh_first {
                true => shapes_distance(pose, &t, other_pose, other),
                false => shapes_distance(other_pose, other, pose, &t),
            })
            .fold(f64::INFINITY, f64::min)
        };
        if let Some(mesh) = sa.as_trimesh() {
            return least(mesh, pa, sb, pb, true);
        }
        if let Some(mesh) = sb.as_trimesh() {
            return least(mesh, pb, sa, pa, false);
        }
    }
    // Within a prediction of 1 (beyond it the distance query alone is trusted).
    let contact =
        |pa, sa, pb, sb| parry3d_f64::query::contact(pa, sa, pb, sb, 1.0).unwrap().map_or(f64::INFINITY, |c| c.dist);
    let readings = [
        d,
        parry3d_f64::query::distance(pb, sb, pa, sa).unwrap().distance,
        contact(pa, sa, pb, sb),
        contact(pb, sb, pa, sa),
    ];
    let separation = |pa: &Pose, sa: &dyn ParryShape, pb: &Pose, sb: &dyn ParryShape| {
        let (Some(ma), Some(mb)) = (sa.as_support_map(), sb.as_support_map()) else { return f64::NEG_INFINITY };
        let Ok(Some(c)) = parry3d_f64::query::contact(pa, sa, pb, sb, 1.0) else { return f64::NEG_INFINITY };
        // Any unit axis bounds the distance: the normal read in the world frame and in a's.
        [c.normal1, pa.rotation * c.normal1]
            .map(|n| n.dot(mb.support_point(pb, -n) - ma.support_point(pa, n)))
            .into_iter()
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let lower = separation(pa, sa, pb, sb).max(separation(pb, sb, pa, sa));
    if readings.iter().filter(|d| **d <= 0.0).count() >= 2 {
        return lower.max(0.0);
    }
    readings.into_iter().filter(|d| *d > 0.0).fold(f64::INFINITY, f64::min).max(lower)
}

fn cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

/// The name of solid kind `kind` (0 to 5), as [`solid`] numbers them.
fn name(kind: usize) -> &'static str {
    ["sphere", "cuboid", "capsule", "cylinder", "cone", "hull"][kind]
}

/// A solid of kind `kind` with sizes from `size` (each in (0, ~1.5]) and, for a hull, `points`.
fn solid(kind: usize, size: [f64; 3], points: &[DVec3]) -> ShapeGeometry {
    let [x, y, z] = size;
    let shape = match kind {
        0 => Shape::Sphere { radius: x },
        1 => Shape::Cuboid { half_extents: DVec3::new(x, y, z) },
        2 => Shape::Capsule { half_height: x, radius: y },
        3 => Shape::Cylinder { half_height: x, radius: y },
        4 => Shape::Cone { half_height: x, radius: y },
        _ => {
            // A small tetrahedron among the points keeps the hull solid whatever they are.
            let core =
                [DVec3::new(0.3, 0.0, 0.0), DVec3::new(0.0, 0.3, 0.0), DVec3::new(0.0, 0.0, 0.3), DVec3::splat(-0.2)];
            Shape::ConvexHull { points: points.iter().chain(&core).map(|p| *p * DVec3::new(x, y, z)).collect() }
        }
    };
    shape.geometry().unwrap()
}

/// Every contact `(start, end)` of the pair in `window`, through the public API: the first start
/// in the window, its end, then the first start after it, and so on.
fn contacts<S: Spin + Debug, T: Spin + Debug>(a: &Body<S>, b: &Body<T>, window: Window) -> Vec<(f64, Option<f64>)> {
    let mut out = Vec::new();
    let mut from = window.start;
    let fail = |e| panic!("{e}: {:?} {:?} vs {:?} {:?}", a.0.shape(), a.1, b.0.shape(), b.1);
    while out.len() < 50 {
        let next = shape_contact_time(pair(a), pair(b), Window::new(from, window.end)).unwrap_or_else(fail);
        let Some(start) = next else { break };
        let end = contact_end_time(pair(a), pair(b), start, window.end).unwrap_or_else(fail);
        out.push((start, end));
        match end {
            Some(_) => from = start.next_up(),
            None => break,
        }
    }
    out
}

/// Checks the contract against `samples` evenly spaced times of `window`; returns the contacts.
fn check_pair<S: Spin + Debug, T: Spin + Debug>(
    a: &Body<S>,
    b: &Body<T>,
    window: Window,
    samples: usize,
    what: &str,
) -> Vec<(f64, Option<f64>)> {
    let tol = contact_tolerance(&a.0, &b.0);
    let found = contacts(a, b, window);
    for &(start, end) in &found {
        assert!(window.contains(start), "{what}: start {start} outside {window:?}");
        let d = distance(a, b, start);
        assert!(d <= tol, "{what}: distance {d:e} > tol {tol:e} at the reported start {start}");
        if let Some(end) = end {
            assert!(end > start, "{what}: end {end} before start {start}");
            let d = distance(a, b, end);
            assert!(d > tol, "{what}: distance {d:e} <= tol {tol:e} at the reported end {end}");
        }
    }
    for i in 0..samples {
        let t = window.start + window.duration() * (i as f64 / samples as f64);
        let inside = found.iter().any(|&(s, e)| s <= t && e.is_none_or(|e| t < e));
        let d = distance(a, b, t);
        if inside {
            assert!(d <= 2.0 * tol, "{what}: distance {d:e} > 2 tol inside a contact at {t} ({found:?})");
        } else {
            assert!(d > 0.5 * tol, "{what}: missed: distance {d:e} <= tol/2 at {t}, contacts {found:?}");
        }
    }
    // Canonical: every window holding a start gives it, to the bit, and repeats are identical.
    let first = shape_contact_time(pair(a), pair(b), window).unwrap();
    assert_eq!(first.map(f64::to_bits), found.first().map(|c| c.0.to_bits()), "{what}: repeated call");
    for (k, &(start, _)) in found.iter().enumerate() {
        // Windows from anywhere after the previous start.
        let earliest = if k == 0 { window.start } else { found[k - 1].0.next_up() };
        for (lo, hi) in [(0.0, 1.0), (0.5, 0.5), (1.0, 0.0), (0.9, 0.1)] {
            let w = Window::new((start - lo * (start - earliest)).max(earliest), start + hi * (window.end - start));
            let w = Window::new(w.start, w.end.max(start.next_up()));
            let again = shape_contact_time(pair(a), pair(b), w).unwrap();
            assert_eq!(
                again.map(f64::to_bits),
                Some(start.to_bits()),
                "{what}: window {w:?} for {start}: {again:?} in {found:?}"
            );
        }
    }
    found
}

/// A random solid's sizes, hull points, orientation and angular velocity (see [`solid_params`]).
type SolidParams = ([f64; 3], Vec<DVec3>, DQuat, DVec3);

/// Every pair of solid kinds (each kind with itself too) on the parameters `pa` and `pb`: its
/// name, the two shapes and the sum of their bounding radii.
fn solid_pairs(pa: &SolidParams, pb: &SolidParams) -> Vec<(String, ShapeGeometry, ShapeGeometry, f64)> {
    let kinds = (0..6).flat_map(|ka| (ka..6).map(move |kb| (ka, kb)));
    kinds
        .map(|(ka, kb)| {
            let (ga, gb) = (solid(ka, pa.0, &pa.1), solid(kb, pb.0, &pb.1));
            let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
            (format!("{} vs {}", name(ka), name(kb)), ga, gb, reach)
        })
        .collect()
}

fn unit(v: [f64; 3]) -> DVec3 {
    DVec3::from(v).try_normalize().unwrap_or(DVec3::X)
}

prop_compose! {
    /// A random solid kind's sizes, hull points, orientation and angular velocity.
    fn solid_params()(
        size in prop::array::uniform3(0.15f64..1.5),
        points in prop::collection::vec(prop::array::uniform3(-1.0f64..1.0), 8),
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..6.3,
        omega in prop::array::uniform3(-3.0f64..3.0),
    ) -> SolidParams {
        (size, points.into_iter().map(DVec3::from).collect(), DQuat::from_axis_angle(unit(axis), angle), DVec3::from(omega))
    }
}

proptest! {
    // PROPTEST_CASES raises the count for a longer soak.
    #![proptest_config(ProptestConfig { cases: cases(10), ..ProptestConfig::default() })]

    /// (a) + (c) for every pair of solid kinds, on one random set of parameters per case; the
    /// same pair said to spin steadily (the search then bounds turning by each shape's reach
    /// from its spin's axis, and only across it); and the same pair only translating: neither turns, or one turns steadily about its shape's
    /// axis of symmetry (a capsule, cylinder or cone about its own axis: the oracle turns it, the
    /// search holds it still). Besides the contract, a translating pair's contact ends take a
    /// handful of probes (regula falsi on the convex distance, not steps at the rate bound), and
    /// no contact follows one that ended.
    #[test]
    fn every_solid_pair_against_dense_sampling(
        pa in solid_params(),
        pb in solid_params(),
        direction in prop::array::uniform3(-1.0f64..1.0),
        gap in 0.3f64..4.0,
        speed in 0.5f64..4.0,
        drift in prop::array::uniform3(-0.6f64..0.6),
        va in prop::array::uniform3(-1.0f64..1.0),
        rates in prop::array::uniform2(-5.0f64..5.0),
    ) {
        let u = unit(direction);
        for (what, ga, gb, reach) in solid_pairs(&pa, &pb) {
            let va = DVec3::from(va);
            let vb = va - u * speed + DVec3::from(drift);
            let (from_a, from_b) = (DVec3::new(0.25, -0.5, 1.0), DVec3::new(0.25, -0.5, 1.0) + u * (reach + gap));
            let a = body(ga.clone(), from_a, va, pa.2, pa.3);
            let b = body(gb.clone(), from_b, vb, pb.2, pb.3);
            check_pair(&a, &b, Window::new(0.0, 5.0), 1000, &what);
            let a = steady_spinner(ga.clone(), from_a, va, pa.2, pa.3);
            let b = steady_spinner(gb.clone(), from_b, vb, pb.2, pb.3);
            check_pair(&a, &b, Window::new(0.0, 5.0), 1000, &format!("{what}, steady"));
            let a = symmetric_spinner(ga, from_a, va, pa.2, rates[0]);
            let b = symmetric_spinner(gb, from_b, vb, pb.2, rates[1]);
            let what = format!("{what}, translating");
            let found = check_pair(&a, &b, Window::new(0.0, 5.0), 1000, &what);
            prop_assert!(found.len() <= 1, "{what}: a contact after an end: {found:?}");
            for &(start, _) in &found {
                let end = contact_end_search(pair(&a), pair(&b), start, 5.0).unwrap();
                prop_assert!(end.iterations <= 40, "{what}: {} probes to the end", end.iterations);
            }
        }
    }

    /// (a) + (c) for every pair of solid kinds tumbling by the exact torque-free rotation, whose
    /// angular velocities move in the bodies (what the searches' chords bound with the angular
    /// acceleration): aimed off the other's centre by up to the sum of the bounding radii, so that
    /// many pass through each other and many graze or miss by a hair; and spinning twelve times
    /// as fast over a shorter window.
    #[test]
    fn every_solid_pair_tumbling_against_dense_sampling(
        pa in solid_params(),
        pb in solid_params(),
        direction in prop::array::uniform3(-1.0f64..1.0),
        aim in prop::array::uniform3(-1.0f64..1.0),
        gap in 0.3f64..3.0,
        speed in 0.5f64..4.0,
        va in prop::array::uniform3(-1.0f64..1.0),
    ) {
        let u = unit(direction);
        for (what, ga, gb, reach) in solid_pairs(&pa, &pb) {
            let off = DVec3::from(aim).reject_from_normalized(u) * reach;
            let va = DVec3::from(va);
            let from_b = u * (reach + gap) + off;
            for (fast, window) in [(1.0, Window::new(0.0, 5.0)), (12.0, Window::new(0.0, 1.5))] {
                let a = tumbler(ga.clone(), DVec3::ZERO, va, pa.2, pa.3 * fast);
                let b = tumbler(gb.clone(), from_b, va - u * speed, pb.2, pb.3 * fast);
                check_pair(&a, &b, window, 1500, &format!("{what}, tumbling at {fast}x"));
            }
        }
    }

    /// (a) + (c) for every solid against a static bumpy mesh and a tilted half-space.
    #[test]
    fn every_solid_against_static_geometry(
        p in solid_params(),
        heights in prop::collection::vec(-0.4f64..0.4, 49),
        normal in prop::array::uniform3(-0.3f64..0.3),
        start in prop::array::uniform3(-2.0f64..2.0),
        velocity in prop::array::uniform3(-2.0f64..2.0),
        fall in 0.5f64..3.0,
    ) {
        let mesh = bumpy_floor(&heights, 6.0);
        let floor = Shape::HalfSpace { normal: DVec3::new(normal[0], 1.0, normal[2]) }.geometry().unwrap();
        for kind in 0..6 {
            let g = solid(kind, p.0, &p.1);
            let r = g.bounding_radius().unwrap();
            let position = DVec3::new(start[0], 1.0 + r + start[1].abs(), start[2]);
            let velocity = DVec3::new(velocity[0], -fall, velocity[2]);
            let a = body(g, position, velocity, p.2, p.3);
            let m = fixed(mesh.clone(), DVec3::new(0.0, 0.2, 0.0), DQuat::from_rotation_y(0.3));
            check_pair(&m, &a, Window::new(0.0, 3.0), 400, &format!("mesh vs {}", name(kind)));
            check_pair(&a, &m, Window::new(0.0, 3.0), 100, &format!("{} vs mesh", name(kind)));
            let h = fixed(floor.clone(), DVec3::new(0.1, -0.3, 0.0), DQuat::IDENTITY);
            check_pair(&a, &h, Window::new(0.0, 3.0), 1000, &format!("{} vs half-space", name(kind)));
            let steady = steady_spinner(a.0.clone(), position, velocity, p.2, p.3);
            check_pair(&steady, &h, Window::new(0.0, 3.0), 1000, &format!("{}, steady, vs half-space", name(kind)));
            check_pair(&h, &a, Window::new(0.0, 3.0), 200, &format!("half-space vs {}", name(kind)));
        }
    }

    /// Walls: a spinning solid in the box (said to spin steadily too, and tumbling), against the
    /// exact support distance sampled densely.
    #[test]
    fn every_solid_against_the_walls(
        p in solid_params(),
        start in prop::array::uniform3(-1.0f64..1.0),
        velocity in prop::array::uniform3(-4.0f64..4.0),
    ) {
        let (min, max) = (DVec3::splat(-4.0), DVec3::splat(4.0));
        for kind in 0..6 {
            let g = solid(kind, p.0, &p.1);
            let a = body(g.clone(), DVec3::from(start), DVec3::from(velocity), p.2, p.3);
            check_walls(&a, min, max, Window::new(0.0, 4.0), 2000, name(kind));
            let a = steady_spinner(g.clone(), DVec3::from(start), DVec3::from(velocity), p.2, p.3);
            check_walls(&a, min, max, Window::new(0.0, 4.0), 2000, &format!("{}, steady", name(kind)));
            // Tumbling by the exact torque-free rotation (the start search's hold follows the
            // extreme point towards each wall to first order), and twelve times as fast.
            for (fast, window) in [(1.0, Window::new(0.0, 4.0)), (12.0, Window::new(0.0, 1.5))] {
                let a = tumbler(g.clone(), DVec3::from(start), DVec3::from(velocity), p.2, p.3 * fast);
                check_walls(&a, min, max, window, 2000, &format!("{}, tumbling at {fast}x", name(kind)));
            }
        }
    }

    /// (c) Scaling a scene by a power of two gives bit-identical contact times.
    #[test]
    fn scaling_by_powers_of_two_is_exact(
        pa in solid_params(),
        pb in solid_params(),
        direction in prop::array::uniform3(-1.0f64..1.0),
        exponent in -60i32..60,
    ) {
        let u = unit(direction);
        let s = 2f64.powi(exponent);
        // Primitives only: a hull's principal axes come out of an eigen-solver.
        for (ka, kb) in [(1, 2), (3, 4), (1, 1), (0, 4)] {
            let scene = |s: f64| {
                let ga = solid(ka, pa.0.map(|x| x * s), &pa.1);
                let gb = solid(kb, pb.0.map(|x| x * s), &pb.1);
                let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
                let a = body(ga, DVec3::ZERO, u * 0.5 * s, pa.2, pa.3);
                let b = body(gb, u * (reach + 1.5 * s), -u * 1.5 * s, pb.2, pb.3);
                shape_contact_time(pair(&a), pair(&b), Window::new(0.0, 10.0)).unwrap()
            };
            let unit_time = scene(1.0);
            prop_assert!(unit_time.is_some());
            prop_assert_eq!(scene(s).map(f64::to_bits), unit_time.map(f64::to_bits), "kinds {} {} scale 2^{}", name(ka), name(kb), exponent);
        }
    }
}

/// `b` under the uniform acceleration `gravity`: its centre's path a parabola.
fn under(mut b: Body, gravity: DVec3) -> Body {
    b.1.acceleration = gravity;
    b
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(6), ..ProptestConfig::default() })]

    /// (a) + (c) under gravity, for every pair of solid kinds: both falling under one gravity
    /// (their relative motion stays straight: the contacts are those of the same pair without
    /// gravity, to the bit), and one falling past the other held still (a relative motion that
    /// bends, as past a body at rest on a pile or a static shape), thrown up or down.
    #[test]
    fn every_solid_pair_under_gravity(
        pa in solid_params(),
        pb in solid_params(),
        direction in prop::array::uniform3(-1.0f64..1.0),
        gap in 0.3f64..3.0,
        speed in 0.0f64..3.0,
        gravity in prop::array::uniform3(-4.0f64..4.0),
        va in prop::array::uniform3(-1.0f64..1.0),
    ) {
        let (u, g) = (unit(direction), DVec3::from(gravity));
        for ka in 0..6 {
            for kb in ka..6 {
                let ga = solid(ka, pa.0, &pa.1);
                let gb = solid(kb, pb.0, &pb.1);
                let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
                let (from_a, from_b) = (DVec3::new(0.25, -0.5, 1.0), DVec3::new(0.25, -0.5, 1.0) + u * (reach + gap));
                let (va, vb) = (DVec3::from(va), DVec3::from(va) - u * speed);
                let a = body(ga.clone(), from_a, va, pa.2, pa.3);
                let b = body(gb.clone(), from_b, vb, pb.2, pb.3);
                let what = format!("{} vs {}", name(ka), name(kb));
                let straight = contacts(&a, &b, Window::new(0.0, 4.0));
                let (fa, fb) = (under(a.clone(), g), under(b.clone(), g));
                let found = check_pair(&fa, &fb, Window::new(0.0, 4.0), 800, &format!("{what}, falling together"));
                prop_assert_eq!(&found, &straight, "{}: falling together", what);
                // One held still, the other falling past it: thrown at it, or dropped on it from
                // rest, neither turning (only the pull brings them together).
                check_pair(&a, &under(b.clone(), g), Window::new(0.0, 4.0), 800, &format!("{what}, one falling"));
                let held = body(ga.clone(), from_a, DVec3::ZERO, pa.2, DVec3::ZERO);
                // Pulled hard enough to cover twice the distance of their centres, reach and gap, in
                // the window (8 a >= 2 (reach + gap)), so the drop always meets the body held.
                let pull = g.length().max(0.5).max((reach + gap) / 4.0);
                let dropped = under(body(gb.clone(), from_b, DVec3::ZERO, pb.2, DVec3::ZERO), -u * pull);
                let found = check_pair(&dropped, &held, Window::new(0.0, 4.0), 800, &format!("{what}, dropped on it"));
                prop_assert!(!found.is_empty(), "{}: dropped on it, never touched", what);
            }
        }
    }

    /// (a) + (c) for every solid falling onto a static bumpy mesh and a tilted half-space, thrown
    /// up, sideways or down.
    #[test]
    fn every_solid_falling_on_static_geometry(
        p in solid_params(),
        heights in prop::collection::vec(-0.4f64..0.4, 49),
        normal in prop::array::uniform3(-0.3f64..0.3),
        start in prop::array::uniform3(-2.0f64..2.0),
        velocity in prop::array::uniform3(-2.0f64..2.0),
        pull in 0.5f64..6.0,
        tilt in prop::array::uniform2(-0.3f64..0.3),
    ) {
        let mesh = bumpy_floor(&heights, 6.0);
        let floor = Shape::HalfSpace { normal: DVec3::new(normal[0], 1.0, normal[2]) }.geometry().unwrap();
        let g = DVec3::new(tilt[0], -1.0, tilt[1]) * pull;
        for kind in 0..6 {
            let geometry = solid(kind, p.0, &p.1);
            let r = geometry.bounding_radius().unwrap();
            let position = DVec3::new(start[0], 1.0 + r + start[1].abs(), start[2]);
            let a = under(body(geometry, position, DVec3::from(velocity), p.2, p.3), g);
            let m = fixed(mesh.clone(), DVec3::new(0.0, 0.2, 0.0), DQuat::from_rotation_y(0.3));
            check_pair(&m, &a, Window::new(0.0, 3.0), 600, &format!("mesh vs falling {}", name(kind)));
            let h = fixed(floor.clone(), DVec3::new(0.1, -0.3, 0.0), DQuat::IDENTITY);
            check_pair(&a, &h, Window::new(0.0, 3.0), 1000, &format!("falling {} vs half-space", name(kind)));
            let cube = fixed(solid(1, [1.5, 0.4, 1.2], &[]), DVec3::new(0.5, -0.6, 0.0), DQuat::from_rotation_z(0.2));
            check_pair(&cube, &a, Window::new(0.0, 3.0), 1000, &format!("static cuboid vs falling {}", name(kind)));
        }
    }

    /// Walls: a spinning solid thrown in the box under gravity of any direction, against the
    /// exact support distance sampled densely.
    #[test]
    fn every_solid_against_the_walls_under_gravity(
        p in solid_params(),
        start in prop::array::uniform3(-1.0f64..1.0),
        velocity in prop::array::uniform3(-4.0f64..4.0),
        gravity in prop::array::uniform3(-8.0f64..8.0),
    ) {
        let (min, max) = (DVec3::splat(-4.0), DVec3::splat(4.0));
        for kind in 0..6 {
            let g = solid(kind, p.0, &p.1);
            let a = under(body(g.clone(), DVec3::from(start), DVec3::from(velocity), p.2, p.3), DVec3::from(gravity));
            check_walls(&a, min, max, Window::new(0.0, 4.0), 2000, &format!("{}, falling", name(kind)));
        }
    }
}

/// Checks a body against the walls: reported wall contacts touch within `tol` and nothing closer
/// than `tol/2` before the first; returns the first.
fn check_walls<S: Spin>(
    a: &Body<S>,
    min: DVec3,
    max: DVec3,
    window: Window,
    samples: usize,
    what: &str,
) -> Option<(f64, Wall)> {
    let tol = vadop::narrow_phase::shapes::SHAPE_CONTACT_TOLERANCE * a.0.bounding_radius().unwrap();
    let found = shape_wall_time(&a.0, &a.1, min, max, window).unwrap();
    let wall_distance = |t: f64, wall: Wall| {
        let c = wall_contact_geometry(&a.0, &a.1, wall, min, max, t).unwrap();
        // Cross-check the support distance against parry's distance to the wall as a half-space.
        let n = wall.outward_normal();
        let plane = Shape::HalfSpace { normal: -n }.geometry().unwrap();
        let origin = if wall.is_max() { max } else { min };
        let parry = distance(a, &fixed(plane, origin, DQuat::IDENTITY), t);
        assert!((parry - c.distance.max(0.0)).abs() <= 1e-9 + 1e-9 * parry, "{what}: {parry} vs {}", c.distance);
        c.distance
    };
    if let Some((t, wall)) = found {
        let d = wall_distance(t, wall);
        assert!(d <= tol, "{what}: wall {wall} at {t}: distance {d:e} > tol");
        let again = shape_wall_time(&a.0, &a.1, min, max, Window::new(t, t.next_up())).unwrap();
        assert_eq!(again.map(|(t, w)| (t.to_bits(), w)), Some((t.to_bits(), wall)));
    }
    let until = found.map_or(window.end, |(t, _)| t);
    for i in 0..samples {
        let t = window.start + window.duration() * (i as f64 / samples as f64);
        if t >= until {
            break;
        }
        for wall in Wall::ALL {
            let d = wall_distance(t, wall);
            assert!(d > 0.5 * tol, "{what}: missed wall {wall} at {t}: distance {d:e}, reported {found:?}");
        }
    }
    found
}

/// A 7 x 7 grid of heights over `[-half, half]^2` in the x-z plane, as a triangle mesh.
fn bumpy_floor(heights: &[f64], half: f64) -> ShapeGeometry {
    let n = 7;
    let mut vertices = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, z) =
                (-half + 2.0 * half * i as f64 / (n - 1) as f64, -half + 2.0 * half * j as f64 / (n - 1) as f64);
            vertices.push(DVec3::new(x, heights[i * n + j], z));
        }
    }
    let mut triangles = Vec::new();
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            let k = (i * n + j) as u32;
            let n = n as u32;
            triangles.push([k, k + 1, k + n]);
            triangles.push([k + 1, k + n + 1, k + n]);
        }
    }
    Shape::TriMesh { vertices, triangles }.geometry().unwrap()
}

fn every_solid(size: f64) -> Vec<(usize, ShapeGeometry)> {
    let points = [
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(-0.7, 0.7, 0.1),
        DVec3::new(-0.6, -0.8, 0.0),
        DVec3::new(0.1, 0.2, 1.0),
        DVec3::new(0.0, 0.1, -0.9),
    ];
    (0..6).map(|k| (k, solid(k, [size, 0.6 * size, 0.8 * size], &points))).collect()
}

/// (b) A thin plate (thickness 1e-3 of its size) crossed at 1000 diameters per frame by every
/// solid, and every solid plate-shaped... plates both still and moving.
#[test]
fn thin_plates_are_never_tunnelled() {
    let plate = Shape::Cuboid { half_extents: DVec3::new(1.0, 1.0, 1e-3) }.geometry().unwrap();
    for (kind, g) in every_solid(0.05) {
        let diameter = 2.0 * g.bounding_radius().unwrap();
        let speed = 1000.0 * diameter;
        for (k, axis) in [DVec3::Z, DVec3::new(0.3, -0.2, 1.0).normalize()].into_iter().enumerate() {
            // Start 400 diameters away: the crossing is in the middle of the frame [0, 1).
            let start = -axis * 400.0 * diameter + DVec3::new(0.2, -0.1, 0.0);
            let spin = DVec3::new(50.0, -30.0, 80.0) * k as f64;
            let a = body(g.clone(), start, axis * speed, DQuat::from_rotation_x(0.4), spin);
            let p = fixed(plate.clone(), DVec3::ZERO, DQuat::IDENTITY);
            let what = format!("{} through plate {k}", name(kind));
            let found = contacts(&a, &p, Window::new(0.0, 1.0));
            assert!(!found.is_empty(), "{what}: tunnelled");
            let t = found[0].0;
            let tol = contact_tolerance(&a.0, &p.0);
            assert!(distance(&a, &p, t) <= tol, "{what}");
            // Before the contact it flies towards the plate: the gap closes linearly, so samples
            // near the contact are the telling ones.
            for i in 1..=1000 {
                let s = t * (1.0 - (i as f64 / 1000.0).powi(3));
                assert!(distance(&a, &p, s) > 0.5 * tol, "{what}: missed at {s}");
            }
            // The plate moving instead of the body: the same crossing.
            let q = body(plate.clone(), -start, -axis * speed, DQuat::IDENTITY, DVec3::ZERO);
            let b = fixed(g.clone(), DVec3::ZERO, DQuat::from_rotation_x(0.4));
            let moving = shape_contact_time(pair(&b), pair(&q), Window::new(0.0, 1.0)).unwrap();
            assert!(moving.is_some(), "{what}: moving plate tunnelled");
        }
    }
}

/// A plank spinning at 3e4 rad/s through a cube in detect mode touches it again and again on one
/// motion. Each contact resumed from the one before (`shape_contact_after`, `contact_end_time`
/// from its start) is the contact a fresh search finds from the reference, to the bit, and costs
/// the same number of distance evaluations whichever contact it is: a frame costs what its
/// contacts need, not the square of their number (it did: every search replayed the contacts
/// before it). An end asked from any time inside a contact is that contact's end.
#[test]
fn contacts_of_a_fast_spinner_resume_bit_exactly_at_a_flat_cost() {
    let plank = Shape::Cuboid { half_extents: DVec3::new(0.5, 0.2, 0.1) }.geometry().unwrap();
    let omega = DVec3::new(1.0, 0.3, 0.1).normalize() * 3e4;
    let a = body(plank.clone(), DVec3::ZERO, DVec3::new(6.0, 0.0, 0.0), DQuat::IDENTITY, omega);
    let b = body(plank, DVec3::new(1.3, 0.0, 0.0), DVec3::new(-6.0, 0.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    let until = 1.0 / 30.0;
    let mut start = shape_contact_time(pair(&a), pair(&b), Window::new(0.0, until)).unwrap().expect("they meet");
    let mut costs = Vec::new();
    while costs.len() < 40 {
        let end = contact_end_search(pair(&a), pair(&b), start, until).unwrap();
        let Some(end_time) = end.found else { break };
        for f in [0.1, 0.5, 0.9] {
            let at = start + f * (end_time - start);
            let again = contact_in_progress_end_time(pair(&a), pair(&b), at, until).unwrap();
            assert_eq!(again.map(f64::to_bits), Some(end_time.to_bits()), "end asked at {at}");
        }
        let later = Window::new(start.next_up(), until);
        let Some(next) = shape_contact_after(pair(&a), pair(&b), start, later).unwrap() else { break };
        let fresh = shape_contact_search(pair(&a), pair(&b), later).unwrap();
        assert_eq!(fresh.found.map(f64::to_bits), Some(next.to_bits()), "contact {} after {start}", costs.len());
        let between = Window::new(end_time, until);
        assert_eq!(shape_contact_time(pair(&a), pair(&b), between).unwrap(), Some(next));
        costs.push(end.iterations);
        start = next;
    }
    assert!(costs.len() >= 20, "only {} contacts", costs.len());
    let (first, last) = (&costs[..5], &costs[costs.len() - 5..]);
    let mean = |c: &[u32]| c.iter().sum::<u32>() as f64 / c.len() as f64;
    eprintln!("ends' evaluations: first {first:?}, last {last:?}");
    assert!(mean(last) <= 3.0 * mean(first) + 50.0, "cost grows with the contacts before: {costs:?}");
}

/// (b) A long box spinning at 2000 rad per frame sweeps past a small cube: its end passes in a
/// few millionths of a frame, and the contact is found.
#[test]
fn fast_spinning_long_box_hits_a_cube_it_sweeps_past() {
    let long = Shape::Cuboid { half_extents: DVec3::new(5.0, 0.05, 0.05) }.geometry().unwrap();
    let cube = Shape::Cuboid { half_extents: DVec3::splat(0.1) }.geometry().unwrap();
    let omega = 2000.0;
    let spinner = body(long, DVec3::ZERO, DVec3::ZERO, DQuat::IDENTITY, DVec3::new(0.0, 0.0, omega));
    for (x, y) in [(0.0, 3.0), (-2.0, 4.0), (4.0, -2.5)] {
        let target = fixed(cube.clone(), DVec3::new(x, y, 0.0), DQuat::from_rotation_z(0.3));
        let search = shape_contact_search(pair(&spinner), pair(&target), Window::new(0.0, 1.0)).unwrap();
        let t = search.found.expect("the sweeping box must hit the cube");
        // It hits within the first half turn, and nothing touched before.
        assert!(t < std::f64::consts::PI / omega, "{t}");
        let tol = contact_tolerance(&spinner.0, &target.0);
        assert!(distance(&spinner, &target, t) <= tol);
        for i in 0..20000 {
            let s = t * i as f64 / 20000.0;
            assert!(distance(&spinner, &target, s) > 0.5 * tol, "missed at {s}");
        }
        eprintln!("spinning box hits ({x}, {y}) at {t:.9e} after {} evaluations", search.iterations);
    }
}

/// (d) A cube hitting a half-space and a wall face first at a known time.
#[test]
fn cube_hits_a_wall_face_first() {
    let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
    let tol = vadop::narrow_phase::shapes::SHAPE_CONTACT_TOLERANCE * cube.bounding_radius().unwrap();
    // Centre at x = 1, speed 3 towards the plane x = 10 (normal -x): the face at 1.5 closes 8.5.
    let a = body(cube.clone(), DVec3::new(1.0, 2.0, 3.0), DVec3::new(3.0, 0.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    let wall =
        fixed(Shape::HalfSpace { normal: -DVec3::X }.geometry().unwrap(), DVec3::new(10.0, 0.0, 0.0), DQuat::IDENTITY);
    let t = shape_contact_time(pair(&a), pair(&wall), Window::new(0.0, 10.0)).unwrap().unwrap();
    let exact = 8.5 / 3.0;
    assert!(t <= exact && t >= exact - tol / 3.0, "{t} vs {exact}");
    let c = contact_geometry(pair(&a), pair(&wall), t).unwrap();
    assert!((c.normal - DVec3::X).length() < 1e-12, "{c:?}");
    assert!((c.point.x - 10.0).abs() < 1e-6, "{c:?}");
    // The same against the box's max-x wall at 10.
    let (tw, w) =
        shape_wall_time(&a.0, &a.1, DVec3::splat(-10.0), DVec3::splat(10.0), Window::new(0.0, 10.0)).unwrap().unwrap();
    assert_eq!(w, Wall::MaxX);
    assert!(tw <= exact && tw >= exact - tol / 3.0, "{tw}");
    // Tilted by 45 degrees about z, an edge leads: it reaches the wall 0.5 (sqrt 2 - 1) earlier.
    let tilted =
        body(cube, a.1.position, a.1.velocity, DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4), DVec3::ZERO);
    let t = shape_contact_time(pair(&tilted), pair(&wall), Window::new(0.0, 10.0)).unwrap().unwrap();
    let exact = (9.0 - 0.5 * 2f64.sqrt()) / 3.0;
    assert!((t - exact).abs() <= tol, "{t} vs {exact}");
}

/// (d) Two capsules head on, along their axes and across them.
#[test]
fn capsules_head_on() {
    let capsule = Shape::Capsule { half_height: 1.0, radius: 0.5 }.geometry().unwrap();
    let tol = contact_tolerance(&capsule, &capsule);
    // Along the y axis: tips at +1.5 and 10 - 1.5 close 7 at speed 2.
    let a = body(capsule.clone(), DVec3::ZERO, DVec3::new(0.0, 1.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    let b = body(capsule.clone(), DVec3::new(0.0, 10.0, 0.0), DVec3::new(0.0, -1.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    let t = shape_contact_time(pair(&a), pair(&b), Window::new(0.0, 10.0)).unwrap().unwrap();
    assert!(t <= 3.5 && t >= 3.5 - tol / 2.0, "{t}");
    // Side by side (axes parallel, 3 apart along x): the cylinders' sides close 2 at speed 4.
    let c = body(capsule.clone(), DVec3::new(3.0, 0.0, 0.0), DVec3::new(-4.0, 0.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    let a = body(capsule.clone(), DVec3::ZERO, DVec3::ZERO, DQuat::IDENTITY, DVec3::ZERO);
    let t = shape_contact_time(pair(&a), pair(&c), Window::new(0.0, 10.0)).unwrap().unwrap();
    assert!(t <= 0.5 && t >= 0.5 - tol / 4.0, "{t}");
    let g = contact_geometry(pair(&a), pair(&c), t).unwrap();
    assert!((g.normal - DVec3::X).length() < 1e-6, "{g:?}");
    // Crossed (one along y, one along z), closing along x: they touch when the axes are 1 apart.
    let crossed =
        body(capsule, DVec3::new(5.0, 0.0, 0.0), DVec3::new(-2.0, 0.0, 0.0), DQuat::from_rotation_x(1.0), DVec3::ZERO);
    let t = shape_contact_time(pair(&a), pair(&crossed), Window::new(0.0, 10.0)).unwrap().unwrap();
    assert!(t <= 2.0 && t >= 2.0 - tol / 2.0, "{t}");
}

/// Spheres through conservative advancement agree with the closed form of the narrow phase.
#[test]
fn spheres_agree_with_the_closed_form() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..200 {
        let (ra, rb) = (rng.random_range(0.1..2.0), rng.random_range(0.1..2.0));
        let pa = DVec3::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0), 0.0);
        let pb = pa + DVec3::new(ra + rb + rng.random_range(0.5..5.0), rng.random_range(-1.0..1.0), 0.3);
        let va = DVec3::new(rng.random_range(-1.0..1.0), 0.0, rng.random_range(-0.2..0.2));
        let vb = DVec3::new(-rng.random_range(0.5..4.0), rng.random_range(-0.5..0.5), 0.0);
        let spin = DVec3::new(rng.random_range(-9.0..9.0), 2.0, 0.0);
        let a = body(Shape::Sphere { radius: ra }.geometry().unwrap(), pa, va, DQuat::IDENTITY, spin);
        let b = body(Shape::Sphere { radius: rb }.geometry().unwrap(), pb, vb, DQuat::IDENTITY, -spin);
        let closed = pair_contact_time(
            &Motion { position: pa, since: 0.0, velocity: va },
            &Motion { position: pb, since: 0.0, velocity: vb },
            ra + rb,
            (DVec3::ZERO, DVec3::ZERO),
        )
        .filter(|&t| t < 100.0);
        let search = shape_contact_search(pair(&a), pair(&b), Window::new(0.0, 100.0)).unwrap();
        match (closed, search.found) {
            (Some(exact), Some(t)) => {
                // Touching within tol happens at most tol / (closing speed) before the closed form.
                let tol = contact_tolerance(&a.0, &b.0);
                let grazing = tol / (vb - va).length() * 1e6;
                assert!(t <= exact + 1e-12 && t >= exact - grazing, "{t} vs {exact}");
                // A sphere's spin does not move its surface: no evaluations wasted on it.
                assert!(search.iterations <= 8, "{} evaluations", search.iterations);
            }
            (None, None) => {}
            // A graze within the tolerance band may go either way.
            (Some(exact), None) | (None, Some(exact)) => {
                let d = distance(&a, &b, exact);
                assert!(d <= contact_tolerance(&a.0, &b.0), "disagree at {exact}: {d:e}");
            }
        }
    }
}

/// A spinning pair touching several times on one motion: every contact, its end, and the next.
#[test]
fn spinning_pair_touches_repeatedly() {
    let long = Shape::Cuboid { half_extents: DVec3::new(2.0, 0.2, 0.2) }.geometry().unwrap();
    let post = Shape::Cylinder { half_height: 1.0, radius: 0.3 }.geometry().unwrap();
    // A bar spinning about z next to a post it clips on every half turn, both passing through
    // (detect mode), while slowly drifting away: a handful of contacts, then none.
    let upright = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
    let bar = body(long, DVec3::ZERO, DVec3::new(-0.1, 0.0, 0.0), upright, DVec3::new(0.0, 0.0, 3.0));
    let post = fixed(post, DVec3::new(1.8, 0.0, 0.0), DQuat::IDENTITY);
    let found = check_pair(&bar, &post, Window::new(0.0, 12.0), 20000, "bar vs post");
    assert!(found.len() >= 3, "{found:?}");
    // Each window between two contacts sees exactly the next start.
    for k in 1..found.len() {
        let between = Window::new(found[k - 1].1.unwrap(), 12.0);
        let t = shape_contact_time(pair(&bar), pair(&post), between).unwrap();
        assert_eq!(t, Some(found[k].0));
    }
}

/// At the reference a touching pair is a new contact only when it goes deeper.
#[test]
fn touching_at_the_reference() {
    let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
    let a = fixed(cube.clone(), DVec3::ZERO, DQuat::IDENTITY);
    let w = Window::new(0.0, 10.0);
    for (spin, vx, expect) in [(0.0, -1.0, true), (0.0, 1.0, false), (1.0, 1.0, false), (0.0, 0.0, false)] {
        // Face to face, exactly touching; b's spin tips its corner into a when it turns.
        let b =
            body(cube.clone(), DVec3::new(1.0, 0.0, 0.0), DVec3::new(vx, 0.0, 0.0), DQuat::IDENTITY, DVec3::Z * spin);
        let t = shape_contact_time(pair(&a), pair(&b), w).unwrap();
        assert_eq!(t == Some(0.0), expect, "spin {spin} velocity {vx}: {t:?}");
    }
    // Turning in place while touching: a corner digs in at once: a contact now.
    let b = body(cube.clone(), DVec3::new(1.0, 0.0, 0.0), DVec3::ZERO, DQuat::IDENTITY, DVec3::Z * 2.0);
    assert_eq!(shape_contact_time(pair(&a), pair(&b), w).unwrap(), Some(0.0));
    // Deep overlap at the reference is a contact in progress (detect mode): the next contact
    // starts after it ends, not now.
    let b = body(cube.clone(), DVec3::new(0.5, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    assert_eq!(shape_contact_time(pair(&a), pair(&b), w).unwrap(), None);
    // Against the walls a body already past one and moving on out is turned back now.
    let out = body(cube, DVec3::new(9.7, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    let found = shape_wall_time(&out.0, &out.1, DVec3::splat(-10.0), DVec3::splat(10.0), w).unwrap();
    assert_eq!(found, Some((0.0, Wall::MaxX)));
}

/// A body starting deep in a wall while moving back into the box is not turned back; a body
/// resting on the floor of the box while sliding never touches it again.
#[test]
fn wall_rules() {
    let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
    let (min, max) = (DVec3::splat(-10.0), DVec3::splat(10.0));
    let back = body(cube.clone(), DVec3::new(9.7, 0.0, 0.0), DVec3::new(-1.0, 0.0, 0.0), DQuat::IDENTITY, DVec3::ZERO);
    let found = shape_wall_time(&back.0, &back.1, min, max, Window::new(0.0, 30.0)).unwrap();
    assert_eq!(found.map(|(_, w)| w), Some(Wall::MinX));
    assert!((found.unwrap().0 - 19.2).abs() < 1e-6);
    let sliding = body(cube, DVec3::new(0.0, -9.5, 0.0), DVec3::new(0.5, 0.0, 0.3), DQuat::IDENTITY, DVec3::ZERO);
    let found = shape_wall_time(&sliding.0, &sliding.1, min, max, Window::new(0.0, 30.0)).unwrap();
    assert_eq!(found.map(|(_, w)| w), Some(Wall::MaxX));
    assert!((found.unwrap().0 - 19.0).abs() < 1e-6);
}

/// Typical and worst evaluation counts and the time per query, on random pairs in a frame
/// (printed with `--nocapture`); the counts stay far below the cap.
#[test]
fn iteration_statistics() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut counts = Vec::new();
    let (mut ends, mut end_time) = (Vec::new(), 0.0);
    let mut found = 0;
    let started = Instant::now();
    let points: Vec<DVec3> = (0..10)
        .map(|_| DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)))
        .collect();
    for _ in 0..3000 {
        let ka = rng.random_range(0..6);
        let kb = rng.random_range(0..6);
        let size =
            |rng: &mut ChaCha8Rng| [rng.random_range(0.2..1.0), rng.random_range(0.2..1.0), rng.random_range(0.2..1.0)];
        let ga = solid(ka, size(&mut rng), &points);
        let gb = solid(kb, size(&mut rng), &points);
        let u = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
            .normalize();
        let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
        let spin = |rng: &mut ChaCha8Rng| {
            DVec3::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0))
        };
        let a = body(ga, DVec3::ZERO, DVec3::ZERO, DQuat::IDENTITY, spin(&mut rng));
        let drift = DVec3::new(rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5), rng.random_range(-0.5..0.5));
        let b = body(gb, u * (reach + rng.random_range(0.1..3.0)), -u * 2.0 + drift, DQuat::IDENTITY, spin(&mut rng));
        let s = shape_contact_search(pair(&a), pair(&b), Window::new(0.0, 2.0)).unwrap();
        found += s.found.is_some() as usize;
        counts.push(s.iterations);
        if let (Some(t), true) = (s.found, ends.len() < 300) {
            // Detect mode: where the pass-through ends (timed apart).
            let began = Instant::now();
            ends.push(contact_end_search(pair(&a), pair(&b), t, 10.0).unwrap().iterations);
            end_time += began.elapsed().as_secs_f64();
        }
    }
    let elapsed = started.elapsed().as_secs_f64() - end_time;
    counts.sort();
    let n = counts.len();
    eprintln!(
        "{n} queries, {found} contacts: evaluations median {}, p90 {}, p99 {}, max {}; {:.1} us per query",
        counts[n / 2],
        counts[n * 9 / 10],
        counts[n * 99 / 100],
        counts[n - 1],
        elapsed * 1e6 / n as f64
    );
    ends.sort();
    eprintln!(
        "{} contact ends (replay from the reference included): evaluations median {}, p90 {}, max {}; {:.0} us per query",
        ends.len(),
        ends[ends.len() / 2],
        ends[ends.len() * 9 / 10],
        ends[ends.len() - 1],
        end_time * 1e6 / ends.len() as f64
    );
    assert!(counts[n - 1] < 10_000);
    // Solids falling through a bumpy mesh (detect mode): the contact start, then its end.
    let heights: Vec<f64> = (0..49).map(|_| rng.random_range(-0.4..0.4)).collect();
    let m = fixed(bumpy_floor(&heights, 6.0), DVec3::new(0.0, 0.2, 0.0), DQuat::from_rotation_y(0.3));
    let (mut starts, mut ends) = (Vec::new(), Vec::new());
    let started = Instant::now();
    for _ in 0..60 {
        for kind in 0..6 {
            let g = solid(kind, [0.5, 0.4, 0.3], &points);
            let spin =
                DVec3::new(rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0), rng.random_range(-3.0..3.0));
            let position = DVec3::new(rng.random_range(-2.0..2.0), 2.0, rng.random_range(-2.0..2.0));
            let a = body(g, position, DVec3::new(0.7, -1.5, 0.2), DQuat::from_rotation_x(0.5), spin);
            let s = shape_contact_search(pair(&a), pair(&m), Window::new(0.0, 3.0)).unwrap();
            starts.push(s.iterations);
            if let Some(t) = s.found {
                ends.push(contact_end_search(pair(&a), pair(&m), t, 3.0).unwrap().iterations);
            }
        }
    }
    starts.sort();
    ends.sort();
    eprintln!(
        "mesh: starts median {} max {}, ends (replay included) median {} max {}; {:.0} us per solid (start and end)",
        starts[starts.len() / 2],
        starts[starts.len() - 1],
        ends[ends.len() / 2],
        ends[ends.len() - 1],
        started.elapsed().as_secs_f64() * 1e6 / starts.len() as f64
    );
    let a = body(
        Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap(),
        DVec3::new(0.0, 2.0, 0.0),
        DVec3::new(0.3, -1.0, 0.0),
        DQuat::IDENTITY,
        DVec3::new(1.0, 2.0, 0.5),
    );
    let started = Instant::now();
    let mut counts = Vec::new();
    for _ in 0..200 {
        counts.push(
            shape_wall_search(&a.0, &a.1, DVec3::splat(-3.0), DVec3::splat(3.0), Window::new(0.0, 5.0))
                .unwrap()
                .iterations,
        );
    }
    eprintln!(
        "wall search: {} evaluations, {:.1} us per query",
        counts[0],
        started.elapsed().as_secs_f64() * 1e6 / 200.0
    );
}

/// A solid of kind `kind` one unit long and a fifth across (for a hull, `points` stretched alike):
/// long shapes sweep most of their bounding sphere as they spin.
fn long_solid(kind: usize, rng: &mut ChaCha8Rng, points: &[DVec3]) -> ShapeGeometry {
    let across = |rng: &mut ChaCha8Rng| rng.random_range(0.1..0.3);
    solid(kind, [rng.random_range(0.6..1.2), across(rng), across(rng)], points)
}

/// A random angular velocity of up to `speed` per axis.
fn random_spin(rng: &mut ChaCha8Rng, speed: f64) -> DVec3 {
    DVec3::new(rng.random_range(-speed..speed), rng.random_range(-speed..speed), rng.random_range(-speed..speed))
}

/// (e) The bounding-sphere cut never drops a contact: long spinning solids of every kind pass
/// each other so that their bounding spheres only graze (overlapping by at most a few percent of
/// their radii, or missing by a hair), where the shapes touch, if at all, at the edge of the
/// spheres; sampled densely. Spheres, whose bounding sphere is the shape, pass at a few
/// tolerances either side of touching. A pair whose bounding spheres miss by more than `2 tol`
/// costs no distance evaluation.
#[test]
fn bounding_sphere_cut_never_drops_a_contact() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    let points: Vec<DVec3> = (0..8).map(|_| random_spin(&mut rng, 1.0)).collect();
    let mut touched = 0;
    for case in 0..cases(60) {
        let (ka, kb) = (rng.random_range(0..6), rng.random_range(0..6));
        let (ga, gb) = (long_solid(ka, &mut rng, &points), long_solid(kb, &mut rng, &points));
        let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
        // b passes a along x, its centre's closest approach `miss` times the reach.
        let miss = rng.random_range(0.95..1.002);
        let speed = rng.random_range(1.0..3.0);
        let qa = DQuat::from_scaled_axis(random_spin(&mut rng, 3.0));
        let a = body(ga, DVec3::ZERO, DVec3::ZERO, qa, random_spin(&mut rng, 4.0));
        let start = DVec3::new(-2.0 * reach, miss * reach, 0.0);
        let b = body(gb, start, DVec3::X * speed, DQuat::IDENTITY, random_spin(&mut rng, 4.0));
        let window = Window::new(0.0, 4.0 * reach / speed);
        let what = format!("case {case}: {} grazing {}", name(ka), name(kb));
        touched += !check_pair(&a, &b, window, 2000, &what).is_empty() as usize;
    }
    assert!(touched >= 5, "only {touched} grazing pairs touched: the cut's edge is not exercised");
    // Spheres passing a few tolerances either side of touching.
    let ball = Shape::Sphere { radius: 0.5 }.geometry().unwrap();
    let tol = contact_tolerance(&ball, &ball);
    let reach = 2.0 * ball.bounding_radius().unwrap();
    for gap in [-1.5, -0.5, 0.25, 0.45, 0.55, 0.8, 1.2, 3.0] {
        let a = fixed(ball.clone(), DVec3::ZERO, DQuat::IDENTITY);
        let b = body(ball.clone(), DVec3::new(-3.0, reach + gap * tol, 0.0), DVec3::X, DQuat::IDENTITY, DVec3::Y);
        check_pair(&a, &b, Window::new(0.0, 6.0), 6000, &format!("spheres {gap} tol apart"));
    }
    // Missing by more than 2 tol: no evaluation at all.
    let a = fixed(ball.clone(), DVec3::ZERO, DQuat::IDENTITY);
    let b = body(ball, DVec3::new(-3.0, reach + 2.5 * tol, 0.0), DVec3::X, DQuat::IDENTITY, DVec3::Y);
    let search = shape_contact_search(pair(&a), pair(&b), Window::new(0.0, 6.0)).unwrap();
    assert_eq!((search.found, search.iterations), (None, 0));
}

/// (e) The cut against static geometry: bodies gliding past and over the edge of a mesh's box,
/// where the box's side is the first thing they can touch, sampled densely; a body whose bounding
/// sphere keeps clear of the box, or of a half-space's plane, costs no distance evaluation.
#[test]
fn static_geometry_cut_never_drops_a_contact() {
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let points: Vec<DVec3> = (0..8).map(|_| random_spin(&mut rng, 1.0)).collect();
    let heights: Vec<f64> = (0..49).map(|_| rng.random_range(-0.4..0.4)).collect();
    let mesh = fixed(bumpy_floor(&heights, 6.0), DVec3::new(0.0, 0.2, 0.0), DQuat::IDENTITY);
    for case in 0..cases(24) {
        let kind = rng.random_range(0..6);
        let g = long_solid(kind, &mut rng, &points);
        // From outside the box's -x side, low over the bumps, across its edge or along it.
        let position = DVec3::new(-6.0 - 2.0 * g.bounding_radius().unwrap(), rng.random_range(0.0..1.2), 0.0);
        let position = position + DVec3::Z * rng.random_range(-7.0..7.0);
        let velocity = DVec3::new(rng.random_range(0.5..3.0), rng.random_range(-0.3..0.1), rng.random_range(-1.0..1.0));
        let a = body(g, position, velocity, DQuat::IDENTITY, random_spin(&mut rng, 3.0));
        check_pair(&a, &mesh, Window::new(0.0, 3.0), 600, &format!("case {case}: {} over the mesh's edge", name(kind)));
    }
    let brick = Shape::Cuboid { half_extents: DVec3::new(0.5, 0.2, 0.1) }.geometry().unwrap();
    let clear = 0.2 + 0.4 + brick.bounding_radius().unwrap() + 0.01;
    // Above the highest bump, gliding over the mesh; beside the box, along it.
    for (position, velocity) in
        [(DVec3::new(-9.0, clear, 0.0), DVec3::X), (DVec3::new(-9.0, 0.0, 6.0 + clear), DVec3::X)]
    {
        let a = body(brick.clone(), position, velocity * 3.0, DQuat::IDENTITY, DVec3::new(1.0, 2.0, 3.0));
        let search = shape_contact_search(pair(&a), pair(&mesh), Window::new(0.0, 6.0)).unwrap();
        assert_eq!((search.found, search.iterations), (None, 0), "{position} {velocity}");
    }
    // Above a half-space: rising, or gliding along it clear of it.
    let floor = fixed(Shape::HalfSpace { normal: DVec3::Y }.geometry().unwrap(), DVec3::ZERO, DQuat::IDENTITY);
    for velocity in [DVec3::new(0.3, 1.0, 0.0), DVec3::new(2.0, 0.0, -1.0)] {
        let a = body(brick.clone(), DVec3::Y * clear, velocity, DQuat::IDENTITY, DVec3::new(1.0, 2.0, 3.0));
        let search = shape_contact_search(pair(&a), pair(&floor), Window::new(0.0, 6.0)).unwrap();
        assert_eq!((search.found, search.iterations), (None, 0), "{velocity}");
    }
}

/// A random pair of long spinning solids (their kinds too), `b` closing on `a` at a speed in
/// `closing`: in reach at the reference for even cases (the search starts there), far apart for
/// odd ones.
fn spinning_pair(
    rng: &mut ChaCha8Rng,
    case: u32,
    points: &[DVec3],
    closing: std::ops::Range<f64>,
) -> (usize, usize, Body, Body) {
    let (ka, kb) = (rng.random_range(0..6), rng.random_range(0..6));
    let (ga, gb) = (long_solid(ka, rng, points), long_solid(kb, rng, points));
    let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
    let gap = if case.is_multiple_of(2) { rng.random_range(-0.3..0.0) } else { rng.random_range(0.5..2.0) };
    let u = random_spin(rng, 1.0).normalize();
    let a = body(ga, DVec3::ZERO, DVec3::ZERO, DQuat::IDENTITY, random_spin(rng, 4.0));
    let velocity = -u * rng.random_range(closing) + random_spin(rng, 0.2);
    let b = body(gb, u * (reach + gap), velocity, DQuat::IDENTITY, random_spin(rng, 4.0));
    (ka, kb, a, b)
}

/// (e) Starts are canonical frame by frame: asked one frame at a time, as the pipeline does,
/// every contact of a pair comes out in its own frame and bit for bit as one long window gives it,
/// whether its search starts at the reference or where the bounding spheres first meet; its end
/// is the same on every call.
#[test]
fn starts_are_canonical_frame_by_frame() {
    let mut rng = ChaCha8Rng::seed_from_u64(29);
    let points: Vec<DVec3> = (0..8).map(|_| random_spin(&mut rng, 1.0)).collect();
    let mut total = 0;
    for case in 0..cases(30) {
        let (ka, kb, a, b) = spinning_pair(&mut rng, case, &points, 0.5..2.0);
        let window = Window::new(0.0, 4.0);
        let long: Vec<f64> = contacts(&a, &b, window).into_iter().map(|(start, _)| start).collect();
        let mut framed = Vec::new();
        for frame in 0..40 {
            let frame = Window::new(frame as f64 * 0.1, (frame + 1) as f64 * 0.1);
            let mut from = frame.start;
            while let Some(start) = shape_contact_time(pair(&a), pair(&b), Window::new(from, frame.end)).unwrap() {
                assert!(frame.contains(start), "case {case}: {start} outside {frame:?}");
                framed.push(start);
                from = start.next_up();
            }
        }
        let bits = |times: &[f64]| times.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&framed), bits(&long), "case {case}: {} vs {}", name(ka), name(kb));
        for &start in &long {
            let end = contact_end_time(pair(&a), pair(&b), start, 4.0).unwrap();
            assert_eq!(contact_end_time(pair(&a), pair(&b), start, 4.0).unwrap(), end, "case {case}");
        }
        total += long.len();
    }
    assert!(total >= 10, "only {total} contacts");
}

/// A search parked at a frame's end and taken up in the next finds the same starts as one long
/// search, to the bit, and makes each probe once: the frame-by-frame replays from the reference
/// that it saves cost many times more.
#[test]
fn parked_searches_resume_bit_exactly_frame_by_frame() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let points: Vec<DVec3> = (0..8).map(|_| random_spin(&mut rng, 1.0)).collect();
    let (mut resumed_probes, mut replayed_probes, mut total) = (0u64, 0u64, 0);
    for case in 0..cases(30) {
        let (ka, kb, a, b) = spinning_pair(&mut rng, case, &points, 0.2..1.0);
        let long: Vec<f64> = contacts(&a, &b, Window::new(0.0, 4.0)).into_iter().map(|(start, _)| start).collect();
        let (framed, resumed, replayed) = framed_starts(&a, &b);
        (resumed_probes, replayed_probes) = (resumed_probes + resumed, replayed_probes + replayed);
        let bits = |times: &[f64]| times.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&framed), bits(&long), "case {case}: {} vs {}", name(ka), name(kb));
        total += long.len();
    }
    assert!(total >= 10, "only {total} contacts");
    assert!(resumed_probes * 4 < replayed_probes, "resumed {resumed_probes} probes, replays {replayed_probes}");
}

/// The starts of a pair's contacts over 40 frames of 0.1 as the pipeline asks: the first start of
/// each frame, taken up where the last search parked, then each later start of the frame after
/// the one before it; with the probes that took, and those of replaying each frame's search from
/// the reference (whose answers must be the same).
fn framed_starts(a: &Body, b: &Body) -> (Vec<f64>, u64, u64) {
    let (mut framed, mut parked, mut resumed, mut replayed) = (Vec::new(), None, 0, 0);
    for frame in 0..40 {
        let frame = Window::new(frame as f64 * 0.1, (frame + 1) as f64 * 0.1);
        let replay = shape_contact_search(pair(a), pair(b), frame).unwrap();
        replayed += replay.iterations as u64;
        let (search, mut park) = shape_contact_resumed(pair(a), pair(b), frame, parked.as_ref()).unwrap();
        resumed += search.iterations as u64;
        assert_eq!(search.found, replay.found, "frame {frame:?}");
        let mut next = search.found;
        while let Some(start) = next {
            assert!(frame.contains(start), "{start} outside {frame:?}");
            framed.push(start);
            (next, park) =
                shape_contact_after_parked(pair(a), pair(b), start, Window::new(start.next_up(), frame.end)).unwrap();
        }
        parked = park;
    }
    (framed, resumed, replayed)
}

/// Pairs that only translate (see `every_solid_pair_against_dense_sampling`) searched frame by
/// frame, each search taken up where the last one parked (a contact's end past a frame's end parks
/// the chain outside the contact), find one long search's starts to the bit.
#[test]
fn translating_searches_resume_bit_exactly_frame_by_frame() {
    let mut rng = ChaCha8Rng::seed_from_u64(37);
    let points: Vec<DVec3> = (0..8).map(|_| random_spin(&mut rng, 1.0)).collect();
    let mut total = 0;
    for case in 0..cases(40) {
        let (ka, kb) = (rng.random_range(0..6), rng.random_range(0..6));
        let (ga, gb) = (long_solid(ka, &mut rng, &points), long_solid(kb, &mut rng, &points));
        let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
        let turn = |rng: &mut ChaCha8Rng| DQuat::from_scaled_axis(random_spin(rng, 3.0));
        let a = symmetric_spinner(ga, DVec3::ZERO, DVec3::ZERO, turn(&mut rng), rng.random_range(-5.0..5.0));
        let u = random_spin(&mut rng, 1.0).normalize();
        let aim = random_spin(&mut rng, 0.3 * reach);
        let velocity = -u * rng.random_range(1.0..3.0) * reach;
        let (start, rate) = (turn(&mut rng), rng.random_range(-5.0..5.0));
        let b = symmetric_spinner(gb, u * 1.5 * reach + aim, velocity, start, rate);
        let long: Vec<f64> = contacts(&a, &b, Window::new(0.0, 4.0)).into_iter().map(|(start, _)| start).collect();
        let (framed, _, _) = framed_starts(&a, &b);
        let bits = |times: &[f64]| times.iter().map(|t| t.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&framed), bits(&long), "case {case}: {} vs {}", name(ka), name(kb));
        total += long.len();
    }
    assert!(total >= 10, "only {total} contacts");
}

/// parry's contact of two solids at time `t`: its signed distance (negative when they overlap)
/// and normal; `None` where parry's query fails (a hair from contact, say).
fn parry_contact(a: &Body, b: &Body, t: f64) -> Option<(f64, DVec3)> {
    let pose = |b: &Body| b.0.pose_of_shape(b.1.position_at(t), b.1.orientation_at(t));
    let (sa, sb) = (a.0.parry_shape().as_ref(), b.0.parry_shape().as_ref());
    let c = parry3d_f64::query::contact(&pose(a), sa, &pose(b), sb, 10.0).unwrap()?;
    Some((c.dist, c.normal1))
}

/// (e) Spheres and capsules taken as a point or a segment plus a radius agree with parry's
/// queries on the whole shapes: against every solid kind, at random poses apart, near contact and
/// overlapping, the signed distance [`contact_geometry`] reports is parry's to within an eighth
/// of the tolerance within a few tolerances of contact, with parry's normal (far off, to within
/// 5%, all the search needs there), and when they overlap to within 2% of parry's depth.
#[test]
fn sphere_and_capsule_cores_agree_with_parry() {
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let points: Vec<DVec3> = (0..8).map(|_| random_spin(&mut rng, 1.0)).collect();
    for ka in [0, 2] {
        for kb in 0..6 {
            for _ in 0..40 {
                let size = |rng: &mut ChaCha8Rng| [0.0; 3].map(|_| rng.random_range(0.2..1.0));
                let (ga, gb) = (solid(ka, size(&mut rng), &points), solid(kb, size(&mut rng), &points));
                let tol = contact_tolerance(&ga, &gb);
                let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
                let qa = DQuat::from_scaled_axis(random_spin(&mut rng, 3.0));
                let qb = DQuat::from_scaled_axis(random_spin(&mut rng, 3.0));
                let u = random_spin(&mut rng, 1.0).normalize();
                let a = fixed(ga, DVec3::ZERO, qa);
                // Along u, the offset where parry's distance is `target` (bisection; 0 inside).
                let at = |s: f64| fixed(gb.clone(), u * s, qb);
                // Far, then within the band of a few tolerances where the search needs precision.
                let target = [1.0, 1e-2, 1e-4, 4e-6, 1e-6, 5e-7][rng.random_range(0..6)] * reach;
                let (mut inside, mut outside) = (0.0, 2.0 * reach);
                for _ in 0..80 {
                    let mid = 0.5 * (inside + outside);
                    if distance(&a, &at(mid), 0.0) < target {
                        inside = mid;
                    } else {
                        outside = mid;
                    }
                }
                let overlap = rng.random_range(0.0..0.5 * reach);
                // Apart: the oracle's distance, and parry's normal where its contact query answers.
                let b = at(outside);
                let ours = contact_geometry(pair(&a), pair(&b), 0.0).unwrap();
                let theirs = distance(&a, &b, 0.0);
                let what = format!("{} vs {} at {}: {ours:?} vs {theirs:e}", name(ka), name(kb), b.1.position);
                if theirs < 8.0 * tol {
                    assert!((ours.distance - theirs).abs() <= tol / 8.0, "{what}");
                    if let Some((_, normal)) = parry_contact(&a, &b, 0.0) {
                        assert!((ours.normal - normal).length() <= 1e-3, "{what}: normal {normal}");
                    }
                } else {
                    // Far from contact the bounds need only be tight relative to the distance
                    // (parry's GJK itself stops at a relative precision of about 1.5e-7).
                    assert!((ours.distance - theirs).abs() <= tol / 8.0 + 0.05 * theirs, "{what}");
                }
                // Overlapping: both depths come from EPA (closed forms for two cores), to a
                // relative precision.
                let b = at(outside - overlap - target);
                if let Some((theirs, _)) = parry_contact(&a, &b, 0.0).filter(|(dist, _)| *dist < 0.0) {
                    let ours = contact_geometry(pair(&a), pair(&b), 0.0).unwrap();
                    let what = format!("{} in {}: {ours:?} vs {theirs:e}", name(ka), name(kb));
                    assert!((ours.distance - theirs).abs() <= tol / 8.0 + 0.02 * theirs.abs(), "{what}");
                }
            }
        }
    }
}

/// Regression: a capsule leaving a spinning cone it passed through, where GJK on the capsule's
/// segment alone (its precision relative to the segment's distance, about the capsule's radius)
/// left the bounds too loose to step.
#[test]
fn capsule_leaving_a_cone() {
    let a = body(
        Shape::Capsule { half_height: 1.2336772592669938, radius: 0.8672969900862867 }.geometry().unwrap(),
        DVec3::new(0.25, -0.5, 1.0),
        DVec3::new(-0.5940085947679125, -0.9742081019494209, -0.385482758481817),
        DQuat::from_xyzw(-0.8776400911890241, 0.21500905900518802, -0.4124587603196337, -0.11574431268540215),
        DVec3::new(-0.23115694061719555, 0.6154141791500346, -2.297423917464457),
    );
    let b = body(
        Shape::Cone { half_height: 0.8649473073384151, radius: 1.3536948598296066 }.geometry().unwrap(),
        DVec3::new(-3.6681280409749095, -3.0271771208817015, 3.7070358665842926),
        DVec3::new(0.7224778773230642, -0.7472120174875421, -1.2612798253345507),
        DQuat::from_xyzw(0.023698843783052398, -0.2664633499413703, -0.5894163605573816, 0.7622493042624966),
        DVec3::new(-0.4846658371565571, -1.6064629342221186, -2.3300452048254856),
    );
    assert!(check_pair(&a, &b, Window::new(0.0, 5.0), 4000, "capsule vs cone").len() >= 2);
}

/// Regression: a capsule passing through a spinning cylinder, where parry's GJK on the whole
/// shapes a hair from contact returns closest points thousands of tolerances apart (parry's own
/// distance query agrees with it there) while GJK on the capsule's segment does not.
#[test]
fn capsule_through_a_cylinder_where_gjk_fails() {
    let a = body(
        Shape::Capsule { half_height: 0.6732743885909533, radius: 0.4673471442095855 }.geometry().unwrap(),
        DVec3::new(0.25, -0.5, 1.0),
        DVec3::ZERO,
        DQuat::from_xyzw(-0.86364283982503, 0.11849531548158597, 0.47038123332172366, 0.13719111037749956),
        DVec3::new(2.6727864647873223, -2.104618913968983, 1.7378029678510636),
    );
    let b = body(
        Shape::Cylinder { half_height: 1.4965987989382539, radius: 0.8299030379555883 }.geometry().unwrap(),
        DVec3::new(-2.1962712480028137, 1.877521985320215, 3.4559357670716992),
        DVec3::new(1.8584576227995722, -2.183949514052383, -2.1070119424139166),
        DQuat::from_xyzw(0.28169180272687155, 0.004164265794124586, -0.6863357898774047, -0.6705039676991034),
        DVec3::new(2.3293452233814804, 2.900805932110492, -1.0125379094001992),
    );
    assert!(check_pair(&a, &b, Window::new(0.0, 5.0), 4000, "capsule vs cylinder").len() >= 2);
}

/// Regression: a cylinder leaving a spinning cone, where GJK, a hair from contact, returns closest
/// points hundreds of tolerances apart and the shapes' extreme points lie far off (flat faces
/// nearly parallel): projecting GJK's points back and forth between the shapes finds close ones.
#[test]
fn cylinder_leaving_a_cone_where_gjk_fails() {
    let a = body(
        Shape::Cylinder { half_height: 0.9949133571143649, radius: 0.4959836576802795 }.geometry().unwrap(),
        DVec3::new(0.25, -0.5, 1.0),
        DVec3::new(0.0, 0.9306341675632507, 0.0),
        DQuat::from_xyzw(-0.22190393481404433, -0.16114904805538158, -0.5060231966508482, -0.8177592264695922),
        DVec3::new(-2.9900735965495486, 2.8381225175578733, -2.922482088626912),
    );
    let b = body(
        Shape::Cone { half_height: 1.2446937448858635, radius: 0.6553087706419543 }.geometry().unwrap(),
        DVec3::new(1.6207715326839647, -2.734576962533308, 3.337612356172342),
        DVec3::new(-0.7813763348997127, 2.1128118331127523, -1.666724913866342),
        DQuat::from_xyzw(0.9149309557236104, -0.24090611544485463, 0.31965240122042443, 0.05184527166451982),
        DVec3::new(-0.9306778894067625, 2.4336735107299203, -0.6017994943166973),
    );
    assert!(!check_pair(&a, &b, Window::new(0.0, 5.0), 4000, "cylinder vs cone").is_empty());
    // Where GJK failed: the bounds are as tight as the oracle.
    let t = 2.1072636577201256;
    let c = contact_geometry(pair(&a), pair(&b), t).unwrap();
    let tol = contact_tolerance(&a.0, &b.0);
    assert!((c.distance - distance(&a, &b, t)).abs() <= tol / 8.0, "{c:?} vs {}", distance(&a, &b, t));
}

/// Median, 90th percentile and largest of `counts`.
fn spread(counts: &mut [u32]) -> (u32, u32, u32) {
    counts.sort();
    let n = counts.len();
    (counts[n / 2], counts[n * 9 / 10], counts[n - 1])
}

/// Evaluations and time per query by pair kind (printed with `--nocapture`), on three sets of
/// random spinning pairs: pairs aimed at each other as in [`iteration_statistics`], broad-phase
/// candidates (bodies in a cube whose swept boxes overlap in the frame, most of which never
/// touch), and solids against a tilted half-space.
#[test]
fn statistics_by_pair_kind() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let points: Vec<DVec3> = (0..10)
        .map(|_| DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)))
        .collect();
    let size =
        |rng: &mut ChaCha8Rng| [rng.random_range(0.2..1.0), rng.random_range(0.2..1.0), rng.random_range(0.2..1.0)];
    let vector = |rng: &mut ChaCha8Rng, scale: f64| {
        DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)) * scale
    };
    let report = |what: &str, counts: &mut Vec<u32>, seconds: f64, found: usize| {
        let n = counts.len();
        let (median, p90, max) = spread(counts);
        eprintln!(
            "{what:>22}: {n:5} queries, {found:5} contacts, evaluations median {median:4} p90 {p90:4} max {max:5}; \
             {:7.1} us per query",
            seconds * 1e6 / n as f64
        );
    };
    let timed = |a: &Body, b: &Body, window: Window| {
        let began = Instant::now();
        let s = shape_contact_search(pair(a), pair(b), window).unwrap();
        (s, began.elapsed().as_secs_f64())
    };
    eprintln!("aimed pairs (as in iteration_statistics), window [0, 2):");
    for ka in 0..6 {
        for kb in ka..6 {
            let (mut counts, mut seconds, mut found) = (Vec::new(), 0.0, 0);
            for _ in 0..100 {
                let (ga, gb) = (solid(ka, size(&mut rng), &points), solid(kb, size(&mut rng), &points));
                let u = vector(&mut rng, 1.0).normalize();
                let reach = ga.bounding_radius().unwrap() + gb.bounding_radius().unwrap();
                let a = body(ga, DVec3::ZERO, DVec3::ZERO, DQuat::IDENTITY, vector(&mut rng, 3.0));
                let velocity = -u * 2.0 + vector(&mut rng, 0.5);
                let at = u * (reach + rng.random_range(0.1..3.0));
                let b = body(gb, at, velocity, DQuat::IDENTITY, vector(&mut rng, 3.0));
                let (s, t) = timed(&a, &b, Window::new(0.0, 2.0));
                (seconds, found) = (seconds + t, found + s.found.is_some() as usize);
                counts.push(s.iterations);
            }
            report(&format!("{} vs {}", name(ka), name(kb)), &mut counts, seconds, found);
        }
    }
    // Broad-phase candidates: random bodies in a cube of side 8 moving up to 2 per axis, kept
    // when their bounding boxes swept over the frame [0, 1) overlap and they do not touch at 0.
    let (mut by_kind, mut all) = (vec![(Vec::new(), 0.0, 0); 36], (Vec::new(), 0.0, 0));
    while all.0.len() < 3000 {
        let (ka, kb) = (rng.random_range(0..6), rng.random_range(0..6));
        let (ga, gb) = (solid(ka, size(&mut rng), &points), solid(kb, size(&mut rng), &points));
        let (ra, rb) = (ga.bounding_radius().unwrap(), gb.bounding_radius().unwrap());
        let (pa, pb) = (vector(&mut rng, 4.0), vector(&mut rng, 4.0));
        let (va, vb) = (vector(&mut rng, 2.0), vector(&mut rng, 2.0));
        let swept = |p: DVec3, v: DVec3, r: f64| (p.min(p + v) - r, p.max(p + v) + r);
        let ((la, ha), (lb, hb)) = (swept(pa, va, ra), swept(pb, vb, rb));
        if !(la.cmple(hb).all() && lb.cmple(ha).all()) {
            continue;
        }
        let qa = DQuat::from_scaled_axis(vector(&mut rng, 3.0));
        let a = body(ga, pa, va, qa, vector(&mut rng, 3.0));
        let b = body(gb, pb, vb, DQuat::IDENTITY, vector(&mut rng, 3.0));
        if distance(&a, &b, 0.0) < 0.05 {
            continue;
        }
        let (s, t) = timed(&a, &b, Window::new(0.0, 1.0));
        for set in [&mut by_kind[ka.min(kb) * 6 + ka.max(kb)], &mut all] {
            set.0.push(s.iterations);
            (set.1, set.2) = (set.1 + t, set.2 + s.found.is_some() as usize);
        }
    }
    eprintln!("broad-phase candidates, window [0, 1):");
    for ka in 0..6 {
        for kb in ka..6 {
            let (counts, seconds, found) = &mut by_kind[ka * 6 + kb];
            report(&format!("{} vs {}", name(ka), name(kb)), counts, *seconds, *found);
        }
    }
    report("all candidates", &mut all.0, all.1, all.2);
    // Solids thrown at a tilted half-space from random heights and directions, window [0, 2).
    let floor = Shape::HalfSpace { normal: DVec3::new(0.2, 1.0, -0.1) }.geometry().unwrap();
    let h = fixed(floor, DVec3::ZERO, DQuat::IDENTITY);
    eprintln!("half-space, window [0, 2):");
    for kind in 0..6 {
        let (mut counts, mut seconds, mut found) = (Vec::new(), 0.0, 0);
        for _ in 0..100 {
            let g = solid(kind, size(&mut rng), &points);
            let at = DVec3::new(0.0, g.bounding_radius().unwrap() + rng.random_range(0.1..3.0), 0.0);
            let a = body(g, at, vector(&mut rng, 2.0), DQuat::IDENTITY, vector(&mut rng, 3.0));
            let (s, t) = timed(&a, &h, Window::new(0.0, 2.0));
            (seconds, found) = (seconds + t, found + s.found.is_some() as usize);
            counts.push(s.iterations);
        }
        report(&format!("{} vs half-space", name(kind)), &mut counts, seconds, found);
    }
}

/// Regression: a spinning cylinder crossing a bumpy mesh, where parry's GJK calls a triangle
/// and the cylinder intersecting from both sides a hair before they touch.
#[test]
fn gjk_failing_near_a_mesh_triangle() {
    let heights = [
        -0.27998743236960005,
        -0.31741669512566684,
        -0.14470459474129954,
        0.3506536416338036,
        0.30104244722928375,
        0.2505359491615926,
        0.09283624883142425,
        0.16555003864511533,
        -0.27379638498609693,
        -0.20288964776872984,
        0.2671597770177481,
        -0.27080272896869295,
        0.057253653364925335,
        -0.10868079189489992,
        0.24035859085458441,
        0.3580955819347937,
        0.2070784842003561,
        0.38448976476318664,
        0.14535024254483497,
        0.3946384788696417,
        0.07444173960067307,
        0.3125442847070784,
        -0.019149349974676357,
        -0.3871939719100782,
        -0.39574354475298806,
        -0.1032363617134199,
        0.03189342533685468,
        -0.19518269133498228,
        0.10418161635392377,
        -0.3920837217688817,
        -0.17000139631650388,
        0.22550734719151497,
        -0.131649886588001,
        0.3416160630166529,
        0.09337425680794367,
        -0.2126241740433737,
        0.23706396603521102,
        0.3923859615376652,
        0.18492442743235996,
        0.1642156048800444,
        0.07285672541721756,
        -0.22560729684636657,
        0.38419484749704585,
        0.17414257460253357,
        0.2786186295268434,
        -0.12014309809941892,
        0.04287508891427421,
        0.15898824086322932,
        0.006481695713712566,
    ];
    let turn = DQuat::from_xyzw(0.0, 0.14943813247359922, 0.0, 0.9887710779360422);
    let m = fixed(bumpy_floor(&heights, 6.0), DVec3::new(0.0, 0.2, 0.0), turn);
    let g = Shape::Cylinder { half_height: 0.9196562029574497, radius: 0.9167193105192427 }.geometry().unwrap();
    let a = body(
        g,
        DVec3::new(-0.4596514279054744, 2.5400457919493706, 0.7635567796124711),
        DVec3::new(0.82375483240813, -1.7114946972812886, -0.15020363499012604),
        DQuat::from_xyzw(0.4138813718320829, -0.3984082281819546, 0.812776824139709, -0.09678289057822775),
        DVec3::new(-2.34763059300101, 2.2746900577053686, 0.009144707613501267),
    );
    let found = check_pair(&m, &a, Window::new(0.0, 3.0), 400, "mesh vs cylinder");
    assert!(!found.is_empty());
}
