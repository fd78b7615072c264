//! GJK's simplex and its loop for the shapes' distance queries: the origin projected on a
//! simplex of points of the Minkowski difference by signed volumes (Montanari, Petrinic and
//! Barbieri, 2017), the vertices of the smallest face holding the projection kept.
//!
//! Why not parry's: its Voronoi simplex tests every vertex, edge and face region of a tetrahedron
//! before it finds the origin inside or beside a face, and a probe's GJK meets a tetrahedron at
//! nearly every iteration (the support point just added to the last triangle): at 5 diameters per
//! frame those projections took 9 % of the shapes' instructions, 625 a call. Signed volumes decide
//! the inside in five determinants and project only on the faces the origin lies beyond (465 a
//! call); and parry's test for a degenerate segment, an absolute area, refused support points that
//! still carried a distance's last digits on round shapes, leaving GJK a few millionths short. It
//! owns that arithmetic and the loop's stopping rules; it never bounds a distance (the caller's
//! axes and points do that, whatever GJK returns) and never measures a depth (EPA does, from the
//! simplex).

use glam::{DMat3, DVec3};
use parry3d_f64::math::Pose;
use parry3d_f64::query::gjk::{CsoPoint, GJKResult};
use parry3d_f64::shape::SupportMap;

/// The second set's pose in the first's frame, its rotation also as a matrix and its transpose:
/// a support point of the difference turns a direction into the second's frame and the point back,
/// which a quaternion does in about twice the arithmetic of a matrix product, on the dependency
/// chain of every GJK and EPA iteration (parry's `support_point`, 10 % of the shapes' samples at
/// 5 d/f). GJK's and EPA's support points, and the points of a simplex carried between probes, go
/// through the matrices: one rounding for all of them (parry's fallback contact query keeps its
/// quaternion).
#[derive(Debug, Clone, Copy)]
pub(super) struct Relative {
    pub(super) pose: Pose,
    rotation: DMat3,
    inverse: DMat3,
}

impl Relative {
    pub(super) fn new(pose: Pose) -> Self {
        let rotation = DMat3::from_quat(pose.rotation);
        Relative { pose, rotation, inverse: rotation.transpose() }
    }

    /// A point of the second set's frame, in the first's.
    #[inline]
    pub(super) fn apply(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.pose.translation
    }

    /// A point of the first set's frame, in the second's.
    #[inline]
    pub(super) fn unapply(&self, p: DVec3) -> DVec3 {
        self.inverse * (p - self.pose.translation)
    }

    /// The difference's support point along `dir` (in the first's frame), with the two sets'.
    #[inline(always)]
    pub(super) fn support<A: ?Sized + SupportMap, B: ?Sized + SupportMap>(&self, a: &A, b: &B, dir: DVec3) -> CsoPoint {
        let on_b = self.apply(b.local_support_point(self.inverse * -dir));
        CsoPoint::new(a.local_support_point(dir), on_b)
    }
}

/// A point this near a simplex's point or plane (the shapes are scaled to unit size), or whose
/// direction from its first point makes a smaller sine than this with its segment, would make it
/// degenerate, and is not added. Relative for the segment: near convergence on a round surface the
/// support points crowd together, and an absolute area (parry's) refuses points that still carry
/// the distance's last digits, leaving it a few millionths short.
const DEGENERATE: f64 = 1e-12;

/// GJK stops once the separation along its direction is within this share of the distance of
/// the simplex's nearest point (parry's: the square root of ten machine epsilons).
const CONVERGED: f64 = 4.7e-8;

/// A simplex whose nearest point lies this near the origin touches it (parry's: ten machine
/// epsilons).
const TOUCHING: f64 = f64::EPSILON * 10.0;

/// A cap on GJK's iterations, against rounding loops.
const MAX_ITERATIONS: usize = 100;

/// GJK's simplex: up to four points of the Minkowski difference `a - b` (with the points of `a`
/// and `b` they come from) and, after [`Simplex::reduce`], the weights of the origin's projection.
#[derive(Debug, Clone, Copy)]
pub(super) struct Simplex {
    vertices: [CsoPoint; 4],
    weights: [f64; 4],
    count: usize,
}

impl Simplex {
    /// The simplex of the one point `first`.
    pub(super) fn new(first: CsoPoint) -> Simplex {
        Simplex { vertices: [first; 4], weights: [1.0, 0.0, 0.0, 0.0], count: 1 }
    }

    /// Becomes [`Simplex::new`]'s of `first`, in place: a simplex is 328 bytes, and one made
    /// anew and moved into a query's was two memory copies a query.
    pub(super) fn restart(&mut self, first: CsoPoint) {
        (self.vertices, self.weights, self.count) = ([first; 4], [1.0, 0.0, 0.0, 0.0], 1);
    }

    /// How many points it has (1 to 4).
    pub(super) fn len(&self) -> usize {
        self.count
    }

    pub(super) fn vertex(&self, i: usize) -> &CsoPoint {
        &self.vertices[..self.count][i]
    }

    /// Adds `point` unless it would make the simplex degenerate (a repeated point, three on a
    /// line, four in a plane): `false` then.
    pub(super) fn add(&mut self, point: CsoPoint) -> bool {
        let v = |i: usize| self.vertices[i].point;
        let offset = point.point - v(0);
        let degenerate = match self.count {
            1 => offset.length() < DEGENERATE,
            2 => {
                let along = v(1) - v(0);
                along.cross(offset).length() < DEGENERATE * along.length() * offset.length()
            }
            3 => {
                let normal = (v(1) - v(0)).cross(v(2) - v(0)).normalize_or_zero();
                !(normal.dot(offset).abs() >= DEGENERATE)
            }
            _ => true,
        };
        if degenerate {
            return false;
        }
        self.vertices[self.count] = point;
        self.count += 1;
        true
    }

    /// Projects the origin on the simplex, keeps the vertices of the smallest face holding the
    /// projection (all four where the origin lies inside) with its weights, and returns it.
    pub(super) fn reduce(&mut self) -> DVec3 {
        let p = [0, 1, 2, 3].map(|i| self.vertices[i].point);
        let face = match self.count {
            1 => Face { kept: [0; 4], weights: [1.0, 0.0, 0.0, 0.0], count: 1, point: p[0] },
            2 => segment(&p, 0, 1),
            3 => triangle(&p, [0, 1, 2]),
            _ => tetrahedron(&p),
        };
        // The kept indices ascend, so the vertices move down in place.
        for k in 0..face.count {
            self.vertices[k] = self.vertices[face.kept[k]];
        }
        self.weights = face.weights;
        self.count = face.count;
        face.point
    }

    /// The points of `a` and of `b` whose difference is the last projection.
    pub(super) fn points(&self) -> (DVec3, DVec3) {
        (0..self.count).fold((DVec3::ZERO, DVec3::ZERO), |(x, y), k| {
            (x + self.vertices[k].orig1 * self.weights[k], y + self.vertices[k].orig2 * self.weights[k])
        })
    }
}

/// The face of a simplex holding the origin's projection: its vertices' indices (ascending), their
/// weights, how many, and the projection.
#[derive(Clone, Copy)]
struct Face {
    kept: [usize; 4],
    weights: [f64; 4],
    count: usize,
    point: DVec3,
}

impl Face {
    fn vertex(i: usize, p: &[DVec3; 4]) -> Face {
        Face { kept: [i, 0, 0, 0], weights: [1.0, 0.0, 0.0, 0.0], count: 1, point: p[i] }
    }

    /// The nearer of two faces to the origin.
    fn nearer(self, other: Face) -> Face {
        if other.point.length_squared() < self.point.length_squared() {
            other
        } else {
            self
        }
    }
}

/// The origin's projection on the segment `[p[i], p[j]]`, `i < j`.
fn segment(p: &[DVec3; 4], i: usize, j: usize) -> Face {
    let along = p[j] - p[i];
    let s = -p[i].dot(along) / along.length_squared();
    if !(s > 0.0) {
        Face::vertex(i, p)
    } else if !(s < 1.0) {
        Face::vertex(j, p)
    } else {
        Face { kept: [i, j, 0, 0], weights: [1.0 - s, s, 0.0, 0.0], count: 2, point: p[i] + along * s }
    }
}

/// The origin's projection on the triangle `p[i], p[j], p[k]`, `i < j < k`: inside where its
/// areas against the three edges all have the triangle's sign, else the nearest of the
/// projections on the edges it lies beyond.
fn triangle(p: &[DVec3; 4], [i, j, k]: [usize; 3]) -> Face {
    let normal = (p[j] - p[i]).cross(p[k] - p[i]);
    let inverse = 1.0 / normal.length_squared();
    // The origin's areas against each edge, seen along the normal: its barycentric weights.
    let area = |a: DVec3, b: DVec3| normal.dot(a.cross(b)) * inverse;
    let weights = [area(p[j], p[k]), area(p[k], p[i]), area(p[i], p[j])];
    if weights[0] > 0.0 && weights[1] > 0.0 && weights[2] > 0.0 {
        let point = p[i] * weights[0] + p[j] * weights[1] + p[k] * weights[2];
        return Face { kept: [i, j, k, 0], weights: [weights[0], weights[1], weights[2], 0.0], count: 3, point };
    }
    let mut best: Option<Face> = None;
    for (weight, (from, to)) in weights.into_iter().zip([(j, k), (i, k), (i, j)]) {
        if !(weight > 0.0) {
            let edge = segment(p, from, to);
            best = Some(best.map_or(edge, |best| best.nearer(edge)));
        }
    }
    best.unwrap_or_else(|| Face::vertex(i, p))
}

/// The origin's projection on the tetrahedron `p`: the origin itself inside (its volumes against
/// the four faces all of the tetrahedron's sign), else the nearest of the projections on the
/// faces it lies beyond.
fn tetrahedron(p: &[DVec3; 4]) -> Face {
    let volume = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| (b - a).dot((c - a).cross(d - a));
    let inverse = 1.0 / volume(p[0], p[1], p[2], p[3]);
    let o = DVec3::ZERO;
    let weights = [
        volume(o, p[1], p[2], p[3]) * inverse,
        volume(p[0], o, p[2], p[3]) * inverse,
        volume(p[0], p[1], o, p[3]) * inverse,
        volume(p[0], p[1], p[2], o) * inverse,
    ];
    if weights.iter().all(|&w| w > 0.0) {
        return Face { kept: [0, 1, 2, 3], weights, count: 4, point: DVec3::ZERO };
    }
    let mut best: Option<Face> = None;
    for (weight, face) in weights.into_iter().zip([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]) {
        if !(weight > 0.0) {
            let projection = triangle(p, face);
            best = Some(best.map_or(projection, |best| best.nearer(projection)));
        }
    }
    best.unwrap_or_else(|| Face::vertex(0, p))
}

/// GJK from `simplex` on the sets `a` and `b` (b at `relative` in a's frame): their closest points
/// and the unit direction from a to b, or an intersection when the simplex comes to hold the
/// origin (or to lie within rounding of it), or stalls short of a separation.
pub(super) fn closest_points<A: ?Sized + SupportMap, B: ?Sized + SupportMap>(
    relative: &Relative,
    a: &A,
    b: &B,
    simplex: &mut Simplex,
) -> GJKResult {
    // The best separation found along a direction tried, and the largest support point's norm.
    let (mut lower, mut size) = (f64::NEG_INFINITY, 0.0f64);
    let mut last = f64::INFINITY;
    for _ in 0..MAX_ITERATIONS {
        let nearest = simplex.reduce();
        let distance = nearest.length();
        if simplex.len() == 4 || !(distance > TOUCHING) {
            return GJKResult::Intersection;
        }
        let dir = -nearest / distance;
        if !(distance < last) {
            return stalled(simplex, dir, lower, size);
        }
        last = distance;
        let support = relative.support(a, b, dir);
        lower = lower.max(-dir.dot(support.point));
        size = size.max(support.point.length());
        if distance - lower <= CONVERGED * distance {
            return closest(simplex, dir);
        }
        if !simplex.add(support) {
            return stalled(simplex, dir, lower, size);
        }
    }
    GJKResult::NoIntersection(DVec3::X)
}

/// Where GJK can go no nearer: apart, or touching to rounding (the best separation found short of
/// 0 by a rounding of the support points' size), the simplex's points; otherwise an intersection.
fn stalled(simplex: &Simplex, dir: DVec3, lower: f64, size: f64) -> GJKResult {
    if lower > 0.0 || lower >= -CONVERGED * size {
        closest(simplex, dir)
    } else {
        GJKResult::Intersection
    }
}

fn closest(simplex: &Simplex, dir: DVec3) -> GJKResult {
    let (on_a, on_b) = simplex.points();
    GJKResult::ClosestPoints(on_a, on_b, dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_point(rng: &mut ChaCha8Rng) -> DVec3 {
        DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
    }

    /// The nearest point to the origin of the convex hull of `points`, independently of the
    /// simplex's arithmetic: the origin's projection on the affine hull of every subset (normal
    /// equations solved by Cramer's rule), kept where its weights are all non-negative.
    fn nearest_by_subsets(points: &[DVec3]) -> DVec3 {
        let mut best: Option<DVec3> = None;
        for mask in 1..(1usize << points.len()) {
            let subset: Vec<DVec3> = (0..points.len()).filter(|i| mask >> i & 1 == 1).map(|i| points[i]).collect();
            let (base, edges) = (subset[0], subset[1..].iter().map(|&p| p - subset[0]).collect::<Vec<_>>());
            // Weights t of the edges minimising |base + sum t e|: G t = -E^T base.
            let t: Vec<f64> = match edges.len() {
                0 => vec![],
                1 => vec![-base.dot(edges[0]) / edges[0].length_squared()],
                2 => {
                    let (g00, g01, g11) = (edges[0].dot(edges[0]), edges[0].dot(edges[1]), edges[1].dot(edges[1]));
                    let (r0, r1) = (-base.dot(edges[0]), -base.dot(edges[1]));
                    let det = g00 * g11 - g01 * g01;
                    vec![(r0 * g11 - r1 * g01) / det, (g00 * r1 - g01 * r0) / det]
                }
                _ => {
                    let m = glam::DMat3::from_cols(edges[0], edges[1], edges[2]);
                    (m.inverse() * -base).to_array().to_vec()
                }
            };
            if t.iter().all(|&w| w >= -1e-12) && t.iter().sum::<f64>() <= 1.0 + 1e-12 {
                let point = base + edges.iter().zip(&t).map(|(e, w)| *e * *w).sum::<DVec3>();
                if best.is_none_or(|best| point.length() < best.length()) {
                    best = Some(point);
                }
            }
        }
        best.unwrap()
    }

    #[test]
    fn the_projection_is_the_hulls_nearest_point_to_the_origin() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut inside = 0;
        for case in 0..2000 {
            let count = 1 + case % 4;
            let points: Vec<DVec3> = (0..count).map(|_| random_point(&mut rng)).collect();
            let cso = |p: DVec3| CsoPoint::new(p, DVec3::ZERO);
            let mut simplex = Simplex::new(cso(points[0]));
            if !points[1..].iter().all(|&p| simplex.add(cso(p))) {
                continue;
            }
            let projection = simplex.reduce();
            let expected = nearest_by_subsets(&points);
            if simplex.len() == 4 {
                inside += 1;
                assert_eq!(projection.length(), 0.0, "case {case}");
            }
            assert!(projection.distance(expected) < 1e-12, "case {case}: {projection} against {expected}");
            // The kept vertices' weights are positive, sum to 1 and give the projection.
            let sum: f64 = (0..simplex.len()).map(|k| simplex.weights[k]).sum();
            assert!((sum - 1.0).abs() < 1e-12 && (0..simplex.len()).all(|k| simplex.weights[k] > 0.0), "case {case}");
            assert!(simplex.points().0.distance(projection) < 1e-12, "case {case}");
        }
        assert!(inside > 50, "{inside} tetrahedra held the origin");
    }

    #[test]
    fn gjk_finds_parrys_distance_and_intersections() {
        let shapes = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for case in 0..3000 {
            let (ga, gb) = (shapes[case % 6].parry_shape(), shapes[(case / 6) % 6].parry_shape());
            let (a, b) = (ga.as_support_map().unwrap(), gb.as_support_map().unwrap());
            let turn = DQuat::from_scaled_axis(random_point(&mut rng) * 3.0);
            let offset = random_point(&mut rng) * 1.5;
            let pos12 = Pose::from_parts(offset, turn);
            let relative = Relative::new(pos12);
            let mut simplex = Simplex::new(relative.support(a, b, -offset.normalize_or(DVec3::X)));
            let distance =
                parry3d_f64::query::distance(&Pose::IDENTITY, ga.as_ref(), &pos12, gb.as_ref()).unwrap().distance;
            match closest_points(&relative, a, b, &mut simplex) {
                // Both points in a's frame. Their distance bounds the shapes' from above, the
                // separation along `dir` from below, the two within the convergence asked; parry's
                // distance, which stops short on round shapes by a few millionths, near them.
                GJKResult::ClosestPoints(p1, p2, dir) => {
                    let found = p1.distance(p2);
                    let apart = -relative.support(a, b, dir).point.dot(dir);
                    assert!(found - apart <= 1e-6 * found, "case {case}: {apart} to {found}");
                    assert!(
                        (found - distance).abs() <= 1e-5 * (1.0 + distance),
                        "case {case}: {found} against {distance}"
                    );
                    assert!(dir.dot(p2 - p1) > 0.0, "case {case}");
                }
                GJKResult::Intersection => assert!(distance < 1e-9, "case {case}: apart by {distance}"),
                other => panic!("case {case}: {other:?}"),
            }
        }
    }
}
