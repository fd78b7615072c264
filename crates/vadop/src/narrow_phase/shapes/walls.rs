//! A shape against the six walls of the box: the first time it starts touching one (a searcher
//! per wall, over the wall gauge of [`super::fixed_gauges`]) and where. It owns the cheap test
//! that tells, from the centre's path alone, that a body cannot reach a wall before a time, so
//! the window start, which asks every body, builds a searcher only for the few near a wall. It
//! never sees another body.

use super::fixed_gauges::{wall_reach, wall_reach_limit, WallGauge};
use super::scaled::Body;
use super::searcher::Searcher;
use super::{ContactPoint, Search, SHAPE_CONTACT_TOLERANCE};
use crate::error::Result;
use crate::motion::{Motion, RigidMotion, Spin};
use crate::numeric::unit_scale;
use crate::shape::ShapeGeometry;
use crate::walls::Wall;
use crate::window::Window;
use glam::DVec3;

/// True when `wall` of the box `(min, max)` exists: a periodic axis has no walls, its corners
/// are at infinity.
fn walled(wall: Wall, (min, max): (DVec3, DVec3)) -> bool {
    if wall.is_max() {
        max[wall.axis()].is_finite()
    } else {
        min[wall.axis()].is_finite()
    }
}

/// A body's centre of mass against one wall, at its `since`, scaled as its wall search scales
/// them: the gap to the wall plane, the speed and pull towards it, the bounding radius, the
/// tolerance and the scale. It needs no pose, so it is cheap.
struct WallApproach {
    gap: f64,
    speed: f64,
    pull: f64,
    size: f64,
    tol: f64,
    scale: f64,
}

impl WallApproach {
    /// Of a body of bounding radius `size` whose centre is at `position` with `velocity` under
    /// `acceleration` at its `since`, as `Body::new` takes them.
    fn new(
        size: f64,
        (position, velocity, acceleration): (DVec3, DVec3, DVec3),
        wall: Wall,
        (min, max): (DVec3, DVec3),
    ) -> WallApproach {
        let scale = unit_scale(size);
        let axis = wall.axis();
        let gap = if wall.is_max() { max[axis] - position[axis] } else { position[axis] - min[axis] };
        let speed = if wall.is_max() { velocity[axis] } else { -velocity[axis] };
        let pull = if wall.is_max() { acceleration[axis] } else { -acceleration[axis] };
        let tol = SHAPE_CONTACT_TOLERANCE * size * scale;
        WallApproach { gap: gap * scale, speed: speed * scale, pull: pull * scale, size: size * scale, tol, scale }
    }

    /// False when the bounding sphere stays out of the wall search's reach before the absolute
    /// time `until`: the search's own first test (`Searcher::first_start_in`), on the same numbers,
    /// so a search skipped on it would have found nothing.
    fn in_reach_before(&self, since: f64, until: f64) -> bool {
        wall_reach(self.gap, self.speed, self.pull, self.size, 2.0 * self.tol)
            .is_some_and(|reach| since + reach.enter < until)
    }
}

/// The centre's position, velocity and acceleration on `path` under `acceleration` at its
/// `since`: the bits of [`RigidMotion::position_at`] and [`RigidMotion::velocity_at`] there.
fn centre_at_since(path: &Motion, acceleration: DVec3) -> (DVec3, DVec3, DVec3) {
    (path.at_under(path.since, acceleration), path.velocity_under(path.since, acceleration), acceleration)
}

/// False when a body of `geometry` on the centre path `path` under `acceleration` can start
/// touching no wall of the box `[min, max]` before the absolute time `until`: told from the path
/// alone, before its spin is read (a window start asks this of every body).
pub(crate) fn walls_in_reach(
    geometry: &ShapeGeometry,
    path: &Motion,
    acceleration: DVec3,
    bounds: (DVec3, DVec3),
    until: f64,
) -> bool {
    let Some(size) = geometry.bounding_radius() else { return false };
    let centre = centre_at_since(path, acceleration);
    !far_from_walls(size, centre, bounds, until - path.since)
        && any_wall_in_reach(size, centre, bounds, path.since, until)
}

/// The six walls' own test of [`walls_in_reach`]: each wall's search's first test.
fn any_wall_in_reach(size: f64, centre: (DVec3, DVec3, DVec3), bounds: (DVec3, DVec3), since: f64, until: f64) -> bool {
    Wall::ALL
        .into_iter()
        .filter(|&wall| walled(wall, bounds))
        .any(|wall| WallApproach::new(size, centre, wall, bounds).in_reach_before(since, until))
}

/// Whether a body of bounding radius `size`, its centre at `position` with `velocity` under
/// `acceleration`, stays for twice `span` farther from every wall than twice the reach a wall's
/// search starts at: then no wall is in its reach within `span`, as every wall's own test would
/// say (margins of twice the time and twice the distance dwarf that test's rounding). Most
/// bodies lie far from every wall, and this screen spares them the six walls' tests.
fn far_from_walls(
    size: f64,
    (position, velocity, acceleration): (DVec3, DVec3, DVec3),
    (min, max): (DVec3, DVec3),
    span: f64,
) -> bool {
    let span = 2.0 * span;
    let travel = velocity.abs() * span + acceleration.abs() * (0.5 * span * span);
    // A wall search looks `2 tol` beyond the bounding sphere (see `WallApproach::in_reach_before`).
    let within = 2.0 * SHAPE_CONTACT_TOLERANCE * size;
    // An open side (an infinite wall) is far; NaN is not.
    let far = |gap: f64, travel: f64| gap == f64::INFINITY || gap - travel > 2.0 * wall_reach_limit(gap, size, within);
    let (below, above) = ((position - min).to_array(), (max - position).to_array());
    let travel = travel.to_array();
    (0..3).all(|k| far(below[k], travel[k]) && far(above[k], travel[k]))
}

/// The searcher of a body against one wall of the box `[min, max]`; `None` for a static-only
/// shape, and, given an absolute time `until`, for a body out of the search's reach before it
/// (see [`WallApproach::in_reach_before`]), before its pose machinery is built.
fn wall_searcher<'a, S: Spin>(
    geometry: &'a ShapeGeometry,
    motion: &'a RigidMotion<S>,
    wall: Wall,
    bounds: (DVec3, DVec3),
    until: Option<f64>,
) -> Option<Searcher<WallGauge<'a>>> {
    let size = geometry.bounding_radius()?;
    let approach = WallApproach::new(size, centre_at_since(&motion.path(), motion.acceleration), wall, bounds);
    if until.is_some_and(|until| !approach.in_reach_before(motion.since, until)) {
        return None;
    }
    let WallApproach { gap, speed, pull, size, tol, scale } = approach;
    let body = Body::new(geometry, motion, motion.since);
    let gauge = WallGauge { normal: wall.outward_normal(), gap, speed, pull, size, scale, body, tol };
    Some(Searcher::new(gauge, motion.since, tol))
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
/// use vadop::narrow_phase::shapes::shape_wall_time;
/// use vadop::motion::RigidMotion;
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
    for wall in Wall::ALL.into_iter().filter(|&wall| walled(wall, (min, max))) {
        // A later wall only matters before the best time so far.
        let window = Window::new(window.start, best.map_or(window.end, |(t, _)| t.next_up().min(window.end)));
        let Some(mut searcher) = wall_searcher(geometry, motion, wall, (min, max), Some(window.end)) else { continue };
        let found = searcher.first_start_in(window, false);
        iterations += searcher.probes();
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
    let searcher = wall_searcher(geometry, motion, wall, (min, max), None)?;
    let g = &searcher.gauge;
    let tau = time - searcher.reference;
    let (distance, extreme, _) = g.distance(tau);
    let centre = g.body.centre(tau);
    let point = centre + (extreme + g.normal * (0.5 * distance)) / g.scale;
    Some(ContactPoint { point, normal: g.normal, distance: distance / g.scale })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    /// A wall search skipped because no wall is in reach (`walls_in_reach`, asked of every body
    /// at every window start) would have found nothing: the full search agrees on spinning
    /// solids near and far from the walls, straight and falling, the window starting before or
    /// after their `since`; and most bodies in mid-box are skipped.
    #[test]
    fn bodies_out_of_the_walls_reach_have_no_wall_contact() {
        use crate::motion::FreeRotation;
        use rand::{Rng, SeedableRng};
        let solids = crate::shape::one_solid_of_each_kind().map(|s| s.geometry().unwrap());
        let (min, max) = (DVec3::ZERO, DVec3::splat(20.0));
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (mut skipped, mut found) = (0, 0);
        for case in 0..600 {
            let solid = &solids[case % 6];
            let mut random = |low: f64, high: f64| rng.random_range(low..high);
            let position = DVec3::new(random(0.5, 19.5), random(0.5, 19.5), random(0.5, 19.5));
            let velocity = DVec3::new(random(-6.0, 6.0), random(-6.0, 6.0), random(-6.0, 6.0));
            let acceleration = if case % 3 == 0 { DVec3::new(0.0, -9.81, 0.0) } else { DVec3::ZERO };
            let start = DQuat::from_scaled_axis(DVec3::new(random(-3.0, 3.0), random(-3.0, 3.0), random(-3.0, 3.0)));
            let omega = DVec3::new(random(-20.0, 20.0), random(-20.0, 20.0), random(-20.0, 20.0));
            let spin = FreeRotation::new(solid.principal_inertia_unit(), start, omega);
            let since = random(0.0, 0.2);
            let motion = RigidMotion { position, since, velocity, acceleration, spin };
            let from = since + random(-0.1, 0.3);
            let window = Window::new(from, from + random(0.01, 0.5));
            let full = shape_wall_time(solid, &motion, min, max, window).unwrap();
            found += usize::from(full.is_some());
            if !walls_in_reach(solid, &motion.path(), acceleration, (min, max), window.end) {
                skipped += 1;
                assert_eq!(full, None, "case {case}: skipped, but the search finds a wall contact");
            }
        }
        assert!(skipped > 200 && found > 20, "{skipped} skipped, {found} wall contacts found");
    }

    /// The screen before the six walls' tests never says far where one of them says in reach:
    /// bodies near and far, inside and outside the box, straight and falling, at times from 0 to
    /// 1e6 and spans from a window down to a few ulps of the time; and it screens most of those
    /// in mid-box.
    #[test]
    fn the_screen_never_skips_a_wall_in_reach() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        let (mut screened, mut mid_box) = (0, 0);
        for case in 0..200_000 {
            let mut random = |low: f64, high: f64| rng.random_range(low..high);
            let side = 10f64.powf(random(-3.0, 3.0));
            let (min, max) = (DVec3::splat(-side), DVec3::splat(side));
            let size = side * 10f64.powf(random(-4.0, -0.5));
            let position = DVec3::new(random(-1.1, 1.1), random(-1.1, 1.1), random(-1.1, 1.1)) * side;
            let speed = side * 10f64.powf(random(-3.0, 2.0));
            let velocity = DVec3::new(random(-1.0, 1.0), random(-1.0, 1.0), random(-1.0, 1.0)) * speed;
            let acceleration =
                if case % 3 == 0 { DVec3::new(0.0, random(-50.0, 0.0), 0.0) * side } else { DVec3::ZERO };
            let since = if case % 2 == 0 { 0.0 } else { 10f64.powf(random(-3.0, 6.0)) };
            let span = if case % 5 == 0 { since.max(1.0) * f64::EPSILON * random(1.0, 8.0) } else { random(1e-4, 0.1) };
            let until = since + span;
            let centre = (position, velocity, acceleration);
            mid_box += usize::from(position.abs().max_element() < 0.5 * side);
            if far_from_walls(size, centre, (min, max), until - since) {
                screened += 1;
                assert!(
                    !any_wall_in_reach(size, centre, (min, max), since, until),
                    "case {case}: screened, but in reach"
                );
            }
        }
        assert!(screened > mid_box / 2, "{screened} screened, {mid_box} in mid-box");
    }
}
