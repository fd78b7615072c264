//! The expanding polytope algorithm (EPA, Van den Bergen's), stopped as soon as its depth bound is
//! as tight as the caller asks: a search stepping out of a deep contact needs the depth to a few
//! per cent, a shallow one to a small share of the contact tolerance, not to rounding (parry's
//! converged EPA, which the caller keeps for contact geometry, spends some 17 support points a
//! call on mixed shapes). It owns the polytope's arithmetic and never decides a contact.
//!
//! The polytope is a closed triangle mesh over support points of the Minkowski difference
//! `a - b`, started from GJK's simplex about the origin. Each step takes the face whose plane lies
//! nearest the origin, adds the difference's support point along that face's normal, drops every
//! face the new point lies in front of, and closes the hole with a fan of triangles from the new
//! point to the hole's rim (the edges of dropped faces whose reverse edge belongs to a kept face).
//!
//! Why the bound may be returned after any step: every vertex is a point of `a - b`, so the convex
//! polytope lies inside that convex set, and it holds the origin. The origin's distance to the
//! polytope's boundary is then at most its distance to the set's boundary, the penetration depth;
//! for a convex polytope about the origin that distance is the least distance of a face's plane,
//! the face expanded next. Conversely each support value along a face's normal is the distance of a
//! plane that bounds `a - b`, so the least of them bounds the depth from above: the gap between the
//! two says how tight the bound is, and the loop stops once the caller's allowance covers it.
//!
//! The same mesh, grown from a small tetrahedron about the origin toward the axes of a cone instead
//! of the nearest face, proves lower bounds on the difference's support values over that cone (see
//! [`closing_supports_exceed`]): what the parting certificate needs of a shallow grazing pass.

use super::gjk::{Relative, Simplex};
use glam::DVec3;
use parry3d_f64::query::gjk::CsoPoint;
use parry3d_f64::shape::SupportMap;
use std::cell::RefCell;

/// Gaps and distances below this many units of the polytope's size (at least 1) are rounding.
const ROUNDING: f64 = f64::EPSILON * 100.0;

/// A cap on the expansions (the polytope then has about 200 faces), against rounding loops.
const MAX_EXPANSIONS: usize = 100;

/// Directions tried for a second vertex when GJK stopped on a single point.
const AXES: [DVec3; 6] = [DVec3::X, DVec3::Y, DVec3::Z, DVec3::NEG_X, DVec3::NEG_Y, DVec3::NEG_Z];

/// How deep two intersecting shapes lie in each other, in a's frame.
#[derive(Debug, Clone, Copy)]
pub(super) struct Penetration {
    /// At most the penetration depth (at least 0).
    pub(super) depth: f64,
    /// Points of a and of b (a convex combination of each shape's support points) whose
    /// difference is the origin's projection on the face giving `depth`.
    pub(super) points: (DVec3, DVec3),
    /// That face's outward unit normal (from a towards b).
    pub(super) normal: DVec3,
    /// The unit normal of the nearest plane bounding `a - b` that the expansion met: the shapes
    /// are separated along it by at least minus `depth` less the allowance. `normal` may give
    /// less: on two flat faces pressed together, its tilt times the faces' size.
    pub(super) axis: DVec3,
}

/// The depth of the intersecting sets `g1` and `g2` (`relative`: g2's pose in g1's frame) from
/// GJK's `simplex` enclosing the origin, once within `allowance(depth)` of the least support value
/// along the normals tried (an upper bound on the depth); `None` where the polytope degenerates.
pub(super) fn penetration<G1, G2>(
    relative: &Relative,
    g1: &G1,
    g2: &G2,
    simplex: &Simplex,
    allowance: impl Fn(f64) -> f64,
) -> Option<Penetration>
where
    G1: ?Sized + SupportMap,
    G2: ?Sized + SupportMap,
{
    let support = |dir: DVec3| relative.support(g1, g2, dir);
    // One polytope per thread, its buffers kept between calls: no allocation in steady state.
    POLYTOPE.with_borrow_mut(|polytope| {
        polytope.seed(simplex, support)?;
        polytope.expand(support, allowance)
    })
}

/// Whether the support value of the difference `g1 - g2` (`relative`: g2's pose in g1's frame)
/// exceeds `level` along every unit axis `n` of g1's frame with `n . heading <= cap`, where the
/// difference holds the ball of radius `inner` about the origin; the difference's support point
/// along `first` is taken first. `false` where an axis of that set has its support value at most
/// `level`, or where [`PROOF_SUPPORTS`] more points do not settle it.
///
/// A convex polytope of the difference's points has support values at most the difference's. Its
/// values exceed `level` along every axis of the set unless the polar set `{n : n . v <= level}`
/// (v over its vertices) holds a point of the set's cone at least 1 from the origin; the polar set
/// is the convex hull of the faces' poles, `level m / o` (a face's outward unit normal `m`, its
/// distance `o`), its edges joining the poles of adjacent faces, so the farthest point of it on
/// the cone's side of the plane `n . heading = cap` is a pole or an edge's crossing of the plane.
/// Each round takes the farthest one past 1: along its direction the polytope's support value is
/// at most `level`, and the difference's support point there either proves the axis fails or lies
/// outside the polytope, which grows by it.
pub(super) fn closing_supports_exceed<G1, G2>(
    relative: &Relative,
    (g1, g2): (&G1, &G2),
    inner: f64,
    (heading, cap): (DVec3, f64),
    level: f64,
    first: DVec3,
) -> bool
where
    G1: ?Sized + SupportMap,
    G2: ?Sized + SupportMap,
{
    let support = |dir: DVec3| relative.support(g1, g2, dir);
    POLYTOPE.with_borrow_mut(|polytope| {
        if polytope.seed_ball(inner).is_none() || polytope.grow(support(first)).is_none() {
            return false;
        }
        for _ in 0..PROOF_SUPPORTS {
            let Some(dir) = polytope.farthest_pole(heading, cap, level) else { return true };
            let apex = support(dir);
            if apex.point.dot(dir) <= level || polytope.grow(apex).is_none() {
                return false;
            }
        }
        false
    })
}

/// How many support points past the first [`closing_supports_exceed`] may add (12 took as many
/// instructions on mixed shapes at 5 diameters per frame).
const PROOF_SUPPORTS: usize = 8;

/// A pole this near 1 counts as reaching the unit sphere: rounding of the polar arithmetic.
const POLE_REACH: f64 = 1.0 - 1e-9;

thread_local! {
    static POLYTOPE: RefCell<Polytope> = RefCell::new(Polytope::default());
}

/// A triangle of the polytope: three vertex indices, counter-clockwise seen from outside, and its
/// plane `normal . x = offset` (outward unit normal; the offset is the origin's distance to it).
#[derive(Clone, Copy)]
struct Triangle {
    corners: [usize; 3],
    normal: DVec3,
    offset: f64,
}

/// A closed, convex triangle mesh about the origin. The triangles form a flat list: the nearest
/// is found by a scan (a polytope keeps some 20 to 60 of them) and an expansion's hole by the
/// edges its dropped triangles do not share, so no triangle tracks its neighbours.
#[derive(Default)]
struct Polytope {
    vertices: Vec<CsoPoint>,
    triangles: Vec<Triangle>,
    /// The directed edges around the hole an expansion opens, as the dropped triangles ran them.
    rim: Vec<[usize; 2]>,
    /// Lengths below this are rounding: `ROUNDING` times the largest vertex norm (at least 1).
    eps: f64,
    /// Which triangle runs each directed edge, by its two vertices (see `farthest_pole`).
    owners: Vec<u32>,
}

impl Polytope {
    fn add_vertex(&mut self, vertex: CsoPoint) -> usize {
        self.eps = self.eps.max(ROUNDING * vertex.point.length());
        self.vertices.push(vertex);
        self.vertices.len() - 1
    }

    fn point(&self, vertex: usize) -> DVec3 {
        self.vertices[vertex].point
    }

    /// The triangle over `corners`, or `None` where they are collinear to rounding.
    fn triangle(&self, corners: [usize; 3]) -> Option<Triangle> {
        let [a, b, c] = corners.map(|i| self.point(i));
        let cross = (b - a).cross(c - a);
        let twice_area = cross.length();
        // Relative to the squared size: rounding leaves a cross product this far from its value.
        if twice_area <= self.eps * self.eps / ROUNDING {
            return None;
        }
        let normal = cross / twice_area;
        Some(Triangle { corners, normal, offset: normal.dot(a) })
    }

    /// A tetrahedron holding the origin, from GJK's simplex (`None` where it is degenerate or the
    /// origin lies outside it). A simplex short of four points gets support points off its affine
    /// hull: a point on the boundary (barely touching shapes), the first of the six axis
    /// directions giving another; a segment, the first of four directions perpendicular to it
    /// giving a point off its line; a triangle, its normal or the opposite one giving a point off
    /// its plane. The origin may then lie on the tetrahedron's boundary, at depth 0, and the
    /// first expansions push those faces out.
    fn seed(&mut self, simplex: &Simplex, support: impl Fn(DVec3) -> CsoPoint) -> Option<()> {
        self.vertices.clear();
        self.triangles.clear();
        self.eps = ROUNDING;
        for i in 0..simplex.len() {
            self.add_vertex(*simplex.vertex(i));
        }
        if self.vertices.len() == 1 {
            let first = self.point(0);
            let second = AXES.iter().map(|&dir| support(dir)).find(|v| v.point.distance(first) > self.eps)?;
            self.add_vertex(second);
        }
        if self.vertices.len() == 2 {
            let base = self.point(0);
            let along = (self.point(1) - base).try_normalize()?;
            let across = along.any_orthonormal_vector();
            let third = [across, -across, along.cross(across), -along.cross(across)]
                .into_iter()
                .map(&support)
                .find(|v| (v.point - base).cross(along).length() > self.eps)?;
            self.add_vertex(third);
        }
        if self.vertices.len() == 3 {
            let base = self.point(0);
            let normal = (self.point(1) - base).cross(self.point(2) - base).try_normalize()?;
            let fourth =
                [normal, -normal].into_iter().map(&support).find(|v| (v.point - base).dot(normal).abs() > self.eps)?;
            self.add_vertex(fourth);
        }
        self.close_tetrahedron()
    }

    /// The four triangles over the first four vertices, wound so that their normals face out:
    /// `None` where the tetrahedron is flat to rounding or does not hold the origin.
    fn close_tetrahedron(&mut self) -> Option<()> {
        let [a, b, c, d] = [0, 1, 2, 3].map(|i| self.point(i));
        let six_volumes = (b - a).cross(c - a).dot(d - a);
        if six_volumes.abs() <= self.eps * self.eps * self.eps / (ROUNDING * ROUNDING) {
            return None;
        }
        if six_volumes > 0.0 {
            // Vertex 3 lies in front of triangle 0 1 2: reverse the winding so normals face out.
            self.vertices.swap(1, 2);
        }
        for corners in [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]] {
            let triangle = self.triangle(corners)?;
            // A face with the origin beyond it: GJK's simplex did not hold the origin.
            if triangle.offset < -self.eps {
                return None;
            }
            self.triangles.push(triangle);
        }
        Some(())
    }

    /// The regular tetrahedron inscribed in the ball of `radius` (a hair less) about the origin.
    fn seed_ball(&mut self, radius: f64) -> Option<()> {
        if !(radius > 0.0) {
            return None;
        }
        self.vertices.clear();
        self.triangles.clear();
        self.eps = ROUNDING;
        let corner = radius * (1.0 - 1e-6) / 3f64.sqrt();
        for signs in [[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]] {
            self.add_vertex(CsoPoint::new(DVec3::from_array(signs) * corner, DVec3::ZERO));
        }
        self.close_tetrahedron()
    }

    /// Takes `apex` into the polytope (nothing where it lies inside): `None` where a new triangle
    /// degenerates or comes nearer the origin than the nearest did (rounding).
    fn grow(&mut self, apex: CsoPoint) -> Option<()> {
        let floor = self.nearest()?.offset;
        let index = self.add_vertex(apex);
        self.open_hole(apex.point);
        if self.rim.is_empty() {
            self.vertices.pop();
            return Some(());
        }
        self.close_hole(index, floor)?.then_some(())
    }

    /// The direction of the polar set's farthest point past [`POLE_REACH`] on the side
    /// `n . heading <= cap` (see [`closing_supports_exceed`]), `None` when there is none.
    fn farthest_pole(&mut self, heading: DVec3, cap: f64, level: f64) -> Option<DVec3> {
        // At most 0 where a face's pole lies on the cone's side of the plane.
        let side = |t: &Triangle| level * t.normal.dot(heading) - cap * t.offset;
        let mut farthest = (POLE_REACH, None);
        for t in &self.triangles {
            if !(t.offset > 0.0) {
                // The origin on a face (a ball of rounding size): the polar set is unbounded, and
                // no proof stands until that face is pushed out.
                return Some(t.normal);
            }
            if side(t) <= 0.0 && level >= farthest.0 * t.offset {
                farthest = (level / t.offset, Some(t.normal));
            }
        }
        // Each directed edge's triangle, to find the one across it (the reverse edge).
        let count = self.vertices.len();
        self.owners.clear();
        self.owners.resize(count * count, u32::MAX);
        for (index, t) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                self.owners[t.corners[k] * count + t.corners[(k + 1) % 3]] = index as u32;
            }
        }
        for (index, t) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let across = self.owners[t.corners[(k + 1) % 3] * count + t.corners[k]] as usize;
                let Some(u) = self.triangles.get(across).filter(|_| across > index) else { continue };
                let (f1, f2) = (side(t), side(u));
                if (f1 > 0.0) == (f2 > 0.0) {
                    continue;
                }
                // The crossing `level (f1 m2 - f2 m1) / (f1 o2 - f2 o1)`.
                let (toward, over) = (u.normal * f1 - t.normal * f2, f1 * u.offset - f2 * t.offset);
                let reach = level * toward.length();
                if reach >= farthest.0 * over.abs() {
                    farthest = (reach / over.abs(), Some(toward.normalize() * over.signum()));
                }
            }
        }
        farthest.1
    }

    /// Expands the polytope until the nearest face's distance is within the allowance (or
    /// rounding) of the least support value found.
    fn expand(&mut self, support: impl Fn(DVec3) -> CsoPoint, allowance: impl Fn(f64) -> f64) -> Option<Penetration> {
        let (mut least_support, mut least_normal) = (f64::INFINITY, DVec3::ZERO);
        let mut nearest = self.nearest()?;
        for _ in 0..MAX_EXPANSIONS {
            let apex = support(nearest.normal);
            let value = apex.point.dot(nearest.normal);
            if value < least_support {
                (least_support, least_normal) = (value, nearest.normal);
            }
            // The gap exceeds eps past here, so the nearest face is among those the apex sees.
            if least_support - nearest.offset <= allowance(nearest.offset).max(self.eps) {
                break;
            }
            let apex = self.add_vertex(apex);
            self.open_hole(self.point(apex));
            if !self.close_hole(apex, nearest.offset)? {
                break;
            }
            nearest = self.nearest()?;
        }
        Some(self.bound(&nearest, least_normal))
    }

    fn nearest(&self) -> Option<Triangle> {
        self.triangles.iter().min_by(|x, y| x.offset.total_cmp(&y.offset)).copied()
    }

    /// Drops the triangles `apex` lies in front of and leaves the hole's rim in `rim`.
    fn open_hole(&mut self, apex: DVec3) {
        let (eps, rim) = (self.eps, &mut self.rim);
        rim.clear();
        self.triangles.retain(|triangle| {
            let seen = triangle.normal.dot(apex) - triangle.offset > eps;
            if seen {
                for k in 0..3 {
                    let (from, to) = (triangle.corners[k], triangle.corners[(k + 1) % 3]);
                    // Two dropped triangles run their shared edge both ways: it is inside the hole.
                    match rim.iter().position(|&edge| edge == [to, from]) {
                        Some(inner) => _ = rim.swap_remove(inner),
                        None => rim.push([from, to]),
                    }
                }
            }
            !seen
        });
    }

    /// Fills the hole with a triangle from each rim edge to `apex`: `None` where one degenerates,
    /// `Some(false)` where one lies nearer the origin than `floor` (the nearest face's distance
    /// before the expansion), which only rounding can do to a growing convex polytope.
    fn close_hole(&mut self, apex: usize, floor: f64) -> Option<bool> {
        if self.rim.len() < 3 {
            return None;
        }
        for i in 0..self.rim.len() {
            let [from, to] = self.rim[i];
            let triangle = self.triangle([from, to, apex])?;
            if triangle.offset < floor - self.eps {
                return Some(false);
            }
            self.triangles.push(triangle);
        }
        Some(true)
    }

    /// The bound a face gives: its distance, and the shapes' points whose difference is the
    /// origin's projection on it (weighed by the areas the projection cuts the face into), with
    /// `axis` the normal of the least support value met.
    fn bound(&self, face: &Triangle, axis: DVec3) -> Penetration {
        let corners = face.corners.map(|i| &self.vertices[i]);
        let [a, b, c] = corners.map(|v| v.point);
        let projection = face.normal * face.offset;
        let area = |p: DVec3, q: DVec3| (p - projection).cross(q - projection).dot(face.normal);
        let whole = area(a, b) + area(b, c) + area(c, a);
        let weights = [area(b, c) / whole, area(c, a) / whole, area(a, b) / whole];
        let mix = |of: fn(&CsoPoint) -> DVec3| (0..3).map(|k| of(corners[k]) * weights[k]).sum::<DVec3>();
        let points = (mix(|v| v.orig1), mix(|v| v.orig2));
        Penetration { depth: face.offset.max(0.0), points, normal: face.normal, axis }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::narrow_phase::shapes::gjk;
    use glam::DQuat;
    use parry3d_f64::math::Pose;
    use parry3d_f64::query::gjk::GJKResult;
    use rand::{Rng, SeedableRng};

    /// The early depth's allowance in these tests: 1/32 of the depth, plus a tolerance.
    fn allowance(depth: f64) -> f64 {
        (depth + 1e-3) / 32.0
    }

    /// Runs `check(case, early, exact)` on random intersecting pairs of every two solid kinds,
    /// turned and offset at random: `early` from [`penetration`] on GJK's simplex, `exact` the
    /// depth of parry's contact query; `check` may ask the difference's support value along a
    /// unit vector (the shapes' separation along it is minus that).
    fn on_random_intersections(mut check: impl FnMut(usize, Option<Penetration>, f64, &dyn Fn(DVec3) -> f64)) {
        let shapes = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut random = move || rng.random_range(-0.5..0.5);
        for case in 0..3000 {
            let (ga, gb) = (shapes[case % 6].parry_shape(), shapes[(case / 6) % 6].parry_shape());
            let (a, b) = (ga.as_support_map().unwrap(), gb.as_support_map().unwrap());
            let turn = DQuat::from_xyzw(random(), random(), random(), random()).normalize();
            let offset = DVec3::new(random(), random(), random()) * 0.8;
            let pos12 = Pose::from_parts(offset, turn);
            let relative = Relative::new(pos12);
            let mut simplex = Simplex::new(relative.support(a, b, -offset.normalize_or(DVec3::X)));
            if gjk::closest_points(&relative, a, b, &mut simplex) != GJKResult::Intersection {
                continue;
            }
            let Ok(Some(contact)) = parry3d_f64::query::contact(&Pose::IDENTITY, ga.as_ref(), &pos12, gb.as_ref(), 0.0)
            else {
                continue;
            };
            let support_value = |n: DVec3| relative.support(a, b, n).point.dot(n);
            check(case, penetration(&relative, a, b, &simplex, allowance), -contact.dist, &support_value);
        }
    }

    /// Stopped early, the depth is never more than the true one (parry's contact query), and
    /// nearly always short of it by at most the allowance (where the polytope degenerates it
    /// gives `None`, and the caller falls back to parry's depth).
    #[test]
    fn an_early_depth_is_a_lower_bound_within_its_allowance() {
        let (mut measured, mut tight) = (0, 0);
        on_random_intersections(|case, early, exact, _| {
            let Some(early) = early else { return };
            assert!(early.depth <= exact + 1e-9, "case {case}: {} deeper than parry's {exact}", early.depth);
            measured += 1;
            tight += (early.depth >= exact - allowance(exact) - 1e-9) as usize;
        });
        assert!(measured > 500, "only {measured} intersecting cases");
        assert!(tight * 100 >= measured * 95, "only {tight} of {measured} depths within their allowance");
    }

    /// The witness points lie `depth` apart along the normal (a unit vector): a's point minus b's
    /// is the origin's projection on the face that gave the depth.
    #[test]
    fn the_witness_points_differ_by_the_depth_along_the_normal() {
        let mut measured = 0;
        on_random_intersections(|case, early, _, _| {
            let Some(early) = early else { return };
            let (on_a, on_b) = early.points;
            let miss = (on_a - on_b - early.normal * early.depth).length();
            assert!((early.normal.length() - 1.0).abs() < 1e-12, "case {case}: normal {}", early.normal);
            assert!(miss < 1e-9, "case {case}: witnesses {} off depth * normal", miss);
            measured += 1;
        });
        assert!(measured > 500, "only {measured} intersecting cases");
    }

    /// The axis bounds the depth from above (its support value is never below the true depth), and
    /// nearly always within the allowance of the early depth: the shapes' separation along it is
    /// then a lower bound on their signed distance as tight as the depth.
    #[test]
    fn the_axis_separates_the_shapes_within_the_allowance() {
        let (mut measured, mut tight) = (0, 0);
        on_random_intersections(|case, early, exact, support_value| {
            let Some(early) = early else { return };
            let value = support_value(early.axis);
            assert!((early.axis.length() - 1.0).abs() < 1e-12, "case {case}: axis {}", early.axis);
            assert!(value >= exact - 1e-9, "case {case}: support value {value} below parry's depth {exact}");
            measured += 1;
            tight += (value <= early.depth + allowance(early.depth) + 1e-12) as usize;
        });
        assert!(measured > 500, "only {measured} intersecting cases");
        assert!(tight * 100 >= measured * 95, "only {tight} of {measured} axes within the allowance");
    }

    /// Where the polytope proves the support values of the difference above a level over the
    /// closing axes, none of thousands of closing axes sampled has one at or below it; and it
    /// proves it on most pairs whose sampled closing axes all lie well above the level.
    #[test]
    fn closing_supports_exceed_the_level_only_where_every_closing_axis_does() {
        use parry3d_f64::query::PointQuery;
        let shapes = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let unit = |rng: &mut rand_chacha::ChaCha8Rng| loop {
            let v = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        };
        let (mut proved, mut clear, mut clear_proved) = (0, 0, 0);
        for case in 0..1500 {
            let (ga, gb) = (shapes[case % 6].parry_shape(), shapes[(case / 6) % 6].parry_shape());
            let (a, b) = (ga.as_support_map().unwrap(), gb.as_support_map().unwrap());
            let turn = DQuat::from_scaled_axis(unit(&mut rng) * rng.random_range(0.0..3.0));
            let offset = unit(&mut rng) * rng.random_range(0.0..0.8);
            let pos12 = Pose::from_parts(offset, turn);
            let relative = Relative::new(pos12);
            // A ball about the origin inside the difference: as deep as the centres' midpoint
            // lies in each shape.
            let middle = offset * 0.5;
            let depth = |shape: &dyn PointQuery, p: DVec3| {
                let projection = shape.project_local_point(p, false);
                projection.is_inside.then(|| projection.point.distance(p))
            };
            let (Some(in_a), Some(in_b)) =
                (depth(ga.as_ref(), middle), depth(gb.as_ref(), pos12.inverse_transform_point(middle)))
            else {
                continue;
            };
            let (heading, cap, level) = (unit(&mut rng), rng.random_range(0.0..0.3), rng.random_range(0.01..0.6));
            let support_value = |n: DVec3| relative.support(a, b, n).point.dot(n);
            let first = unit(&mut rng);
            let found = closing_supports_exceed(&relative, (a, b), in_a + in_b, (heading, cap), level, first);
            let lowest = (0..4000)
                .map(|_| unit(&mut rng))
                .filter(|n| n.dot(heading) <= cap)
                .map(support_value)
                .fold(f64::INFINITY, f64::min);
            if found {
                proved += 1;
                assert!(lowest > level - 1e-12, "case {case}: a closing axis's support value {lowest} <= {level}");
            }
            if lowest > 1.05 * level {
                clear += 1;
                clear_proved += found as usize;
            }
        }
        assert!(proved > 400 && clear_proved * 10 >= clear * 9, "proved {proved}; {clear_proved} of {clear} clear");
    }

    /// A simplex short of a tetrahedron is filled out: two balls about one centre (their difference
    /// a ball of radius 0.8 about the origin) from a diameter and from a triangle about the centre
    /// give the depth within its allowance; touching balls, from the single touching point, a
    /// depth of 0. The allowance is a quarter of the depth here: a ball is EPA's slowest case
    /// (every support point is a new vertex, so the gap shrinks only with the faces' size).
    #[test]
    fn a_point_a_segment_or_a_triangle_grows_into_a_tetrahedron() {
        use parry3d_f64::shape::Ball;
        let (a, b) = (Ball::new(0.5), Ball::new(0.3));
        let allowance = |depth: f64| depth / 4.0;
        let simplex_along = |relative: &Relative, dirs: &[DVec3]| {
            let mut simplex = Simplex::new(relative.support(&a, &b, dirs[0]));
            for &dir in &dirs[1..] {
                assert!(simplex.add(relative.support(&a, &b, dir)));
            }
            simplex
        };
        let centred = Relative::new(Pose::IDENTITY);
        let in_tilted_plane = |turn: f64| DVec3::new(turn.cos(), turn.sin(), 0.3 * turn.cos()).normalize();
        let turns = [0.0, 2.1, 4.2].map(in_tilted_plane);
        for dirs in [&[DVec3::new(0.2, 0.5, -0.3), DVec3::new(-0.2, -0.5, 0.3)][..], &turns[..]] {
            let found = penetration(&centred, &a, &b, &simplex_along(&centred, dirs), allowance).unwrap();
            assert!(
                found.depth <= 0.8 + 1e-12 && found.depth >= 0.8 - allowance(0.8),
                "{} simplex: {found:?}",
                dirs.len()
            );
        }
        let touching = Relative::new(Pose::from_parts(DVec3::new(0.8, 0.0, 0.0), glam::DQuat::IDENTITY));
        let found = penetration(&touching, &a, &b, &simplex_along(&touching, &[DVec3::X]), allowance).unwrap();
        assert!(found.depth <= 1e-12, "touching: {found:?}");
    }
}
