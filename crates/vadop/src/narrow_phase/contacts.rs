//! Contacts between bodies of the store, as the pipeline asks about them: when two bodies (or a
//! body and a wall) start or stop touching within a window, and where.
//!
//! It owns the choice of narrow phase: two spheres by the closed forms of
//! [`crate::narrow_phase::spheres`], anything else by the conservative advancement of
//! [`crate::narrow_phase::shapes`], from the body store's motions, shapes and spins. A search that cannot
//! decide (see [`crate::narrow_phase::shapes`]'s termination guard) is answered as *stalled* at the time
//! it stopped, before which no contact starts: the pipeline then starts the pair's motions afresh
//! from that instant (or, in simulate mode when they touch there, applies the jam rule), so a
//! contact is never dropped.
//! It never schedules, responds or changes a body.

use crate::bodies::{Bodies, BodyState};
use crate::error::VadopError;
use crate::motion::{Motion, RigidMotion};
use crate::narrow_phase::falling::may_touch_within;
use crate::narrow_phase::parked::ParkedSearches;
use crate::narrow_phase::shapes::{contact_end_time, contact_geometry};
use crate::narrow_phase::shapes::{contact_tolerance, wall_contact_geometry, SHAPE_CONTACT_TOLERANCE};
use crate::narrow_phase::shapes::{
    pair_first_start, shape_contact_after_measured, shape_wall_time, walls_in_reach, Resume,
};
use crate::narrow_phase::spheres::{moving_pair_contact_time, straight_pair_contact_time_past_screen};
use crate::narrow_phase::spheres::{pair_contact_time, pair_separation_time, straight_pair_contact_time};
use crate::narrow_phase::spheres::{wall_contact_time, CONTACT_TOLERANCE};
use crate::numeric::{direction, unit_scale};
use crate::walls::BoxBounds;
use crate::walls::Wall;
use crate::window::Window;
use glam::DVec3;
use parry3d_f64::math::Pose;
use parry3d_f64::query::{
    ContactManifold, ContactManifoldsWorkspace, DefaultQueryDispatcher, PersistentQueryDispatcher,
};
use parry3d_f64::shape::{HalfSpace, Shape as ParryShape};

/// When something happens, and whether the search stalled there instead of deciding.
pub(crate) type Found = Option<(f64, bool)>;

/// A search's answer within `window`, an undecided search answered as stalled where it stopped.
fn settled(found: std::result::Result<Option<f64>, &VadopError>, window: Window) -> Found {
    let found = match found {
        Ok(found) => found.map(|t| (t, false)),
        Err(VadopError::ContactSearchStalled { time, .. }) => Some((*time, true)),
        // The shape narrow phase fails in no other way on validated bodies.
        Err(_) => None,
    };
    found.filter(|&(t, _)| window.contains(t))
}

/// Where a search parked, taken out of its answer, tested first: an empty option taken is still
/// copied whole (a resume is 392 bytes, and it was copied three times a search), and most searches
/// the broad phase asks for never park.
fn take_parked(parked: &mut Option<Resume>) -> Option<Resume> {
    if parked.is_some() {
        parked.take()
    } else {
        None
    }
}

/// A shape pair's search parked: the pair (lower id first), the motion epochs it ran on, and
/// where it stopped.
pub(crate) type Parking = ((u32, u32), (u32, u32), Resume);

/// The canonical time in `window` at which bodies `a` and `b` start to touch, `a` the lower id,
/// from their motions `state_a`, `state_b` (current for the stamps the caller holds).
#[inline(always)]
pub(crate) fn pair_start(
    bodies: &Bodies,
    (a, state_a): (usize, &BodyState),
    (b, state_b): (usize, &BodyState),
    window: Window,
) -> Found {
    if bodies.are_spheres(a, b) {
        let (ma, mb, radius_sum) = (&state_a.motion, &state_b.motion, state_a.radius + state_b.radius);
        // Without gravity (most worlds) every path is straight: no pull to read or compare.
        let time = if bodies.straight_paths() {
            straight_pair_contact_time(ma, mb, radius_sum)?
        } else {
            let (ga, gb) = (bodies.gravity_on(a), bodies.gravity_on(b));
            if ga != gb && !may_touch_within(ma, ga, mb, gb, radius_sum, window) {
                return None;
            }
            pair_contact_time(ma, mb, radius_sum, (ga, gb))?
        };
        return window.contains(time).then_some((time, false));
    }
    shape_pair_start(bodies, a, b, window)
}

/// [`pair_start`] of two spheres on straight paths (a world without gravity) that a screen of
/// the caller's own has passed, the same time to the bit: the clear-miss screen that
/// [`straight_pair_contact_time`] asks first only rejects pairs its exact test rejects too (see
/// [`straight_pair_contact_time_past_screen`]), and most pairs screened already pass it. With
/// `moving`, the caller's screen found the relative velocity beyond its noise rule, which is then
/// not asked (see [`moving_pair_contact_time`]).
#[inline(always)]
pub(crate) fn screened_spheres_start(state_a: &BodyState, state_b: &BodyState, window: Window, moving: bool) -> Found {
    let (a, b, radius_sum) = (&state_a.motion, &state_b.motion, state_a.radius + state_b.radius);
    let time = match moving {
        true => moving_pair_contact_time(a, b, radius_sum)?,
        false => straight_pair_contact_time_past_screen(a, b, radius_sum)?,
    };
    window.contains(time).then_some((time, false))
}

/// [`pair_start`] of a pair that is not two spheres (shapes across periodic faces come through
/// [`pair_start_parked`], with their shift): kept out of line, off the spheres' path.
#[inline(never)]
fn shape_pair_start(bodies: &Bodies, a: usize, b: usize, window: Window) -> Found {
    pair_start_parked(bodies, (a, b, DVec3::ZERO), window, None, |_| {})
}

/// [`pair_start`] for a pair that is not two spheres, taking the search up where `parked` holds
/// it (from an earlier window, on the same motions), with where it parks now handed to `park`
/// (not returned: an empty option of a resume returned through two calls was copied whole).
pub(crate) fn pair_start_parked(
    bodies: &Bodies,
    (a, b, shift): (usize, usize, DVec3),
    window: Window,
    parked: Option<&ParkedSearches>,
    park: impl FnOnce(Parking),
) -> Found {
    let (Some(ga), Some(gb)) = (bodies.geometry(a), bodies.geometry(b)) else { return None };
    let (ma, mb) = (bodies.rigid_motion(a), shifted(bodies.rigid_motion(b), shift));
    // A pair across periodic faces is searched afresh each time: its parked search would be
    // of one image, and it is rare.
    let across = shift != DVec3::ZERO;
    let (key, epochs) = parking_key(bodies, a, b);
    let resume = parked.filter(|_| !across).and_then(|p| p.get(key.0, key.1, epochs));
    let turns_back = bodies.mode.turns_back(bodies.is_fixed(a) || bodies.is_fixed(b));
    let mut search = pair_first_start((ga, &ma), (gb, &mb), window, resume, turns_back);
    let found = settled(search.as_ref().map(|(s, _)| s.found), window);
    if let (false, Ok((_, parked))) = (across, &mut search) {
        if let Some(resume) = take_parked(parked) {
            park((key, epochs, resume));
        }
    }
    found
}

/// A motion shifted by whole sides `shift`: a body's image across periodic faces.
#[inline]
fn shifted<S>(mut motion: RigidMotion<S>, shift: DVec3) -> RigidMotion<S> {
    if shift != DVec3::ZERO {
        motion.position += shift;
    }
    motion
}

/// The pair `a < b` and the motion epochs its parked searches are kept under.
fn parking_key(bodies: &Bodies, a: usize, b: usize) -> ((u32, u32), (u32, u32)) {
    ((a as u32, b as u32), (bodies.motion_epoch(a), bodies.motion_epoch(b)))
}

/// The canonical time in `window` at which bodies `a` and `b` (`a` the lower id), which started
/// to touch at `start`, touch again on the same motions (spinning shapes may; spheres never do),
/// with where the search parks when they do not, and where they touch at `start` and the normal
/// when the search measured them there ([`pair_geometry`]'s, to the bit).
pub(crate) fn pair_start_after(
    bodies: &Bodies,
    a: usize,
    b: usize,
    start: f64,
    window: Window,
) -> (Found, Option<Parking>, Option<(DVec3, DVec3)>) {
    let (Some(ga), Some(gb), false) = (bodies.geometry(a), bodies.geometry(b), bodies.are_spheres(a, b)) else {
        return (None, None, None);
    };
    // Touching at `start`: through their nearest image then.
    let shift = bodies.image_shift(a, b, start);
    let (ma, mb) = (bodies.rigid_motion(a), shifted(bodies.rigid_motion(b), shift));
    let (key, epochs) = parking_key(bodies, a, b);
    let mut search = shape_contact_after_measured((ga, &ma), (gb, &mb), start, window);
    let measured = search.as_ref().ok().and_then(|(_, _, at_start)| at_start.map(|c| (c.point, c.normal)));
    let found = settled(search.as_ref().map(|(found, _, _)| *found), window);
    let parks = match &mut search {
        Ok((_, parked, _)) if shift == DVec3::ZERO => take_parked(parked).map(|r| (key, epochs, r)),
        _ => None,
    };
    (found, parks, measured)
}

/// The canonical time in `window` at which touching bodies `a` and `b` (`a` the lower id), in
/// contact since `since`, part.
pub(crate) fn pair_end(bodies: &Bodies, a: usize, b: usize, since: f64, window: Window) -> Found {
    // Touching from `since` on, so through their nearest image then, which they keep until
    // they part.
    let (ma, mb) = (bodies.motion(a), bodies.motion(b));
    let shift = bodies.image_shift(a, b, since.max(ma.since).max(mb.since));
    if bodies.are_spheres(a, b) {
        let mut mb = mb;
        mb.position += shift;
        let time = pair_separation_time(&ma, &mb, bodies.radius(a) + bodies.radius(b), bodies.gravity)?;
        return window.contains(time).then_some((time, false));
    }
    let (ga, gb) = (bodies.geometry(a)?, bodies.geometry(b)?);
    let (ma, mb) = (bodies.rigid_motion(a), shifted(bodies.rigid_motion(b), shift));
    // Searched from the contact's start, not the window's: the search's steps depend on where it
    // starts, and windows differ between runs (a resumed one starts its first at the saved time).
    settled(contact_end_time((ga, &ma), (gb, &mb), since, window.end).as_ref().copied(), window)
}

/// Body `i`'s first contact with a wall of `bounds` in `window`: the time and the wall, or
/// `Err(time)` where an undecided search stalled.
#[inline]
pub(crate) fn wall_start(
    bodies: &Bodies,
    i: usize,
    bounds: &BoxBounds,
    window: Window,
) -> Option<std::result::Result<(f64, Wall), f64>> {
    let shape = if bodies.is_sphere(i) { None } else { bodies.geometry(i) };
    let walls = bounds.walls();
    let found = match shape {
        None => Ok(wall_contact_time(&bodies.motion(i), bodies.radius(i), walls.0, walls.1, bodies.gravity_on(i))?),
        // Most bodies are far from every wall: told from the centre's path, before the spin.
        Some(g) if !walls_in_reach(g, &bodies.motion(i), bodies.gravity_on(i), walls, window.end) => return None,
        Some(g) => match shape_wall_time(g, &bodies.rigid_motion(i), walls.0, walls.1, window) {
            Ok(found) => Ok(found?),
            Err(VadopError::ContactSearchStalled { time, .. }) => Err(time),
            Err(_) => return None,
        },
    };
    let time = match found {
        Ok((time, _)) | Err(time) => time,
    };
    window.contains(time).then_some(found)
}

/// Where bodies `i` and `j` touch at `t`, and the unit normal from `i` towards `j`.
#[inline]
pub(crate) fn pair_geometry(bodies: &Bodies, i: usize, j: usize, t: f64) -> (DVec3, DVec3) {
    if !bodies.are_spheres(i, j) {
        if let (Some(gi), Some(gj)) = (bodies.geometry(i), bodies.geometry(j)) {
            let (mi, mj) = (bodies.rigid_motion(i), shifted(bodies.rigid_motion(j), bodies.image_shift(i, j, t)));
            if let Some(contact) = contact_geometry((gi, &mi), (gj, &mj), t) {
                return (contact.point, contact.normal);
            }
        }
    }
    sphere_pair_geometry(bodies, (i, &SpherePath::of(bodies, i)), (j, &SpherePath::of(bodies, j)), t)
}

/// A sphere's path as its contact geometry reads it: its straight motion since its last velocity
/// change and the acceleration it moves under. A copy outlives the body's next velocity change,
/// so the geometry of a contact can be worked out after the step has moved on (see
/// [`sphere_pair_geometry`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SpherePath {
    motion: Motion,
    gravity: DVec3,
}

impl SpherePath {
    /// Body `i`'s path now.
    #[inline]
    pub(crate) fn of(bodies: &Bodies, i: usize) -> SpherePath {
        SpherePath { motion: bodies.motion(i), gravity: bodies.gravity_on(i) }
    }
}

/// [`pair_geometry`] of spheres `i` and `j` on the paths given (theirs at `t`, whatever their
/// motions are now): the same bits. Always inline: the passing pairs' pass calls it for each
/// pair, and where the compiler's partition of the crate left it a call (after a change in the
/// grid), that pass cost 8.8 M instructions more over 6 frames at 10^5 x 5 d/f (BENCHMARKS.md).
#[inline(always)]
pub(crate) fn sphere_pair_geometry(
    bodies: &Bodies,
    (i, path_i): (usize, &SpherePath),
    (j, path_j): (usize, &SpherePath),
    t: f64,
) -> (DVec3, DVec3) {
    let touch = sphere_pair_touch(bodies, (i, path_i), (j, path_j), t);
    (touch.point, touch.normal)
}

/// Where two spheres touch, as [`sphere_pair_touch`] finds it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SphereTouch {
    /// The contact point ([`sphere_pair_geometry`]'s).
    pub point: DVec3,
    /// The unit normal from the first sphere towards the second ([`sphere_pair_geometry`]'s).
    pub normal: DVec3,
    /// The second centre minus the first through the nearest image: [`Bodies::offset_at`] at
    /// the contact, to the bit, which the impact's virial needs (see
    /// [`crate::response::impact::virial`]).
    pub offset: DVec3,
}

/// [`sphere_pair_geometry`] with the centres' offset it is worked out from, so that an impact
/// reads the two paths once. Always inlined: a detect-mode step asks `sphere_pair_geometry` of
/// every pair passing through each other, and a call returning the whole record cost it 1 %.
#[inline(always)]
pub(crate) fn sphere_pair_touch(
    bodies: &Bodies,
    (i, path_i): (usize, &SpherePath),
    (j, path_j): (usize, &SpherePath),
    t: f64,
) -> SphereTouch {
    let centres = [path_i.motion.at_under(t, path_i.gravity), path_j.motion.at_under(t, path_j.gravity)];
    sphere_pair_touch_from(bodies, (i, path_i), (j, path_j), t, centres)
}

/// [`sphere_pair_touch`] from the two centres at `t` on the paths given (read by the caller).
#[inline(always)]
fn sphere_pair_touch_from(
    bodies: &Bodies,
    (i, path_i): (usize, &SpherePath),
    (j, path_j): (usize, &SpherePath),
    t: f64,
    [pi, pj]: [DVec3; 2],
) -> SphereTouch {
    let (offset, shift) = bodies.nearest_offset(pi, pj);
    // Coincident centres have no normal; the relative velocity gives one.
    let relative_velocity =
        || path_i.motion.velocity_under(t, path_i.gravity) - path_j.motion.velocity_under(t, path_j.gravity);
    let normal = direction(offset).or_else(|| direction(relative_velocity())).unwrap_or(DVec3::X);
    // Midway between the two surface points (which coincide at a contact, up to rounding), so
    // that in a walled box naming the pair either way round gives the same bits: the sum
    // commutes, and negating the normal is exact. Two processes that hold a pair under different
    // local ids then agree on its contact (vadop-mpi). Across a periodic face the point lies by
    // the lower id's image, as before.
    let point = 0.5 * ((pi + normal * bodies.radius(i)) + ((pj + shift) - normal * bodies.radius(j)));
    SphereTouch { point, normal, offset }
}

/// [`sphere_pair_touch`] of spheres `i` and `j` on their paths now, with the two paths moved on
/// to `t` (centre and velocity there, since `t`: [`Motion::moved_on`]'s bits, the velocities
/// [`Bodies::velocity_at`]'s) from the same read of their paths, which an impact at `t` gives
/// new velocities from.
#[inline]
pub(crate) fn spheres_touch_on(bodies: &Bodies, i: usize, j: usize, t: f64) -> (SphereTouch, [Motion; 2]) {
    let (path_i, path_j) = (SpherePath::of(bodies, i), SpherePath::of(bodies, j));
    let centres = [path_i.motion.at_under(t, path_i.gravity), path_j.motion.at_under(t, path_j.gravity)];
    let touch = sphere_pair_touch_from(bodies, (i, &path_i), (j, &path_j), t, centres);
    // (No array `map` here nor below: the compiler left its closure a call.)
    let velocities = [path_i.motion.velocity_under(t, path_i.gravity), path_j.motion.velocity_under(t, path_j.gravity)];
    let on = |k: usize| Motion { position: centres[k], since: t, velocity: velocities[k] };
    (touch, [on(0), on(1)])
}

/// Where body `i` touches `wall` at `t`, and the wall's outward normal.
#[inline]
pub(crate) fn wall_geometry(bodies: &Bodies, i: usize, wall: Wall, bounds: &BoxBounds, t: f64) -> (DVec3, DVec3) {
    let normal = wall.outward_normal();
    if let Some(g) = bodies.geometry(i).filter(|_| !bodies.is_sphere(i)) {
        let motion = bodies.rigid_motion(i);
        if let Some(contact) = wall_contact_geometry(g, &motion, wall, bounds.min, bounds.max, t) {
            return (contact.point, normal);
        }
    }
    (bodies.position_at(i, t) + normal * bodies.radius(i), normal)
}

/// True when bodies `i` and `j` touch at `t` and are not moving apart at the contact: the jam
/// rule's test for who belongs to a jammed cluster.
pub(crate) fn pressed_together(bodies: &Bodies, i: usize, j: usize, t: f64) -> bool {
    if bodies.are_spheres(i, j) {
        let reach = (bodies.radius(i) + bodies.radius(j)) * (1.0 + 4.0 * CONTACT_TOLERANCE);
        let scale = unit_scale(reach);
        let offset = bodies.offset_at(i, j, t) * scale;
        let separating = (bodies.velocity_at(j, t) - bodies.velocity_at(i, t)).dot(offset) > 0.0;
        return offset.length_squared() <= (reach * scale) * (reach * scale) && !separating;
    }
    let (Some(gi), Some(gj)) = (bodies.geometry(i), bodies.geometry(j)) else { return false };
    let shift = bodies.image_shift(i, j, t);
    let (mi, mj) = (bodies.rigid_motion(i), shifted(bodies.rigid_motion(j), shift));
    let Some(contact) = contact_geometry((gi, &mi), (gj, &mj), t) else { return false };
    // j's point velocity about its own centre, not its image's.
    let (vi, vj) = (bodies.point_velocity(i, t, contact.point), bodies.point_velocity(j, t, contact.point - shift));
    let separating = (vj - vi).dot(contact.normal) > 0.0;
    contact.distance <= 2.0 * contact_tolerance(gi, gj) && !separating
}

/// True when body `i` is within twice the contact tolerance of a wall of `bounds` at `t`: the
/// jam rule's test for a search against the walls that could not decide.
pub(crate) fn touches_a_wall(bodies: &Bodies, i: usize, bounds: &BoxBounds, t: f64) -> bool {
    walls_within(bodies, i, bounds, t, 2.0).iter().flatten().any(|&near| near)
}

/// The walls of `bounds` that body `i` lies within `tolerances` of its own contact tolerances of
/// at `t`, as `[min side, max side]` per axis: a sphere by its centre and radius, a shape by its
/// own extreme point toward the wall, since its bounding sphere may reach a wall the shape is far
/// from (a cube's reaches 0.37 of its side further). The periodic axes have none.
pub(crate) fn walls_within(bodies: &Bodies, i: usize, bounds: &BoxBounds, t: f64, tolerances: f64) -> [[bool; 3]; 2] {
    let (p, r) = (bodies.position_at(i, t), bodies.radius(i));
    let (min, max) = bounds.walls();
    let shape = bodies.geometry(i).filter(|_| !bodies.is_sphere(i));
    let tolerance = if shape.is_some() { SHAPE_CONTACT_TOLERANCE } else { CONTACT_TOLERANCE };
    let slack = tolerances * tolerance * r;
    let mut near = [[false; 3]; 2];
    for axis in 0..3 {
        near[0][axis] = p[axis] - r <= min[axis] + slack;
        near[1][axis] = p[axis] + r >= max[axis] - slack;
    }
    if let Some(g) = shape {
        let (motion, tol) = (bodies.rigid_motion(i), tolerance * g.size());
        for wall in Wall::ALL {
            let side = &mut near[wall.is_max() as usize][wall.axis()];
            if *side {
                let contact = wall_contact_geometry(g, &motion, wall, bounds.min, bounds.max, t);
                *side = contact.is_some_and(|c| c.distance <= tolerances * tol);
            }
        }
    }
    near
}

/// How deep bodies `i` and `j` interpenetrate at `t` beyond the contact tolerance (touching is
/// allowed), for the start-of-run check of simulate mode.
pub(crate) fn penetration(bodies: &Bodies, i: usize, j: usize, t: f64) -> Option<f64> {
    let unbounded = |k: usize| bodies.geometry(k).is_some_and(|g| g.is_static_only());
    if !unbounded(i) && !unbounded(j) {
        // How deep the bounding spheres overlap (for spheres, the bodies themselves).
        let reach = bodies.radius(i) + bodies.radius(j);
        // Scaled so the square neither underflows nor overflows at any scale.
        let scale = unit_scale(reach);
        let distance = (bodies.offset_at(i, j, t) * scale).length() / scale;
        let depth = reach - distance;
        if bodies.are_spheres(i, j) {
            return (depth > CONTACT_TOLERANCE * reach).then_some(depth);
        }
        // Shapes apart within their bounding spheres: most neighbours of a sparse scene, spared
        // the exact query below (converged GJK and EPA, 30,000 instructions a pair).
        if !(depth > 0.0) {
            return None;
        }
    }
    let (a, b) = (i.min(j), i.max(j));
    let (ga, gb) = (bodies.geometry(a)?, bodies.geometry(b)?);
    let (ma, mb) = (bodies.rigid_motion(a), shifted(bodies.rigid_motion(b), bodies.image_shift(a, b, t)));
    let contact = contact_geometry((ga, &ma), (gb, &mb), t)?;
    (-contact.distance > contact_tolerance(ga, gb)).then_some(-contact.distance)
}

/// Scratch of the contact manifolds an impact is resolved over, kept by the pipeline so a contact
/// allocates nothing in steady state. Emptied before every use: what parry keeps between calls
/// would make one contact's points depend on the contacts before it.
#[derive(Default)]
pub(crate) struct ManifoldScratch {
    manifolds: Vec<ContactManifold<(), ()>>,
    workspace: Option<ContactManifoldsWorkspace>,
    /// The contact points found, with their normals.
    pub(crate) points: Vec<(DVec3, DVec3)>,
}

impl std::fmt::Debug for ManifoldScratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ManifoldScratch").field("points", &self.points).finish_non_exhaustive()
    }
}

impl ManifoldScratch {
    /// Fills `points` with where the shapes `first` at `pose_first` and `second` at
    /// `pose_second` touch, within `reach`, each with the unit normal from the first towards the
    /// second; `fallback` when their features give none.
    fn touch(
        &mut self,
        (first, pose_first): (&dyn ParryShape, Pose),
        (second, pose_second): (&dyn ParryShape, Pose),
        reach: f64,
        fallback: (DVec3, DVec3),
    ) {
        self.points.clear();
        self.manifolds.clear();
        self.workspace = None;
        let relative = pose_first.inv_mul(&pose_second);
        let found = DefaultQueryDispatcher.contact_manifolds(
            &relative,
            first,
            second,
            reach,
            &mut self.manifolds,
            &mut self.workspace,
        );
        if found.is_ok() {
            for manifold in &self.manifolds {
                let part = pose_first * manifold.subshape_pos1().copied().unwrap_or(Pose::identity());
                let normal = part.rotation * manifold.local_n1;
                for contact in manifold.points.iter().filter(|c| c.dist <= reach) {
                    let on_first = part * contact.local_p1;
                    // Halfway between the two surfaces.
                    self.points.push((on_first + normal * (0.5 * contact.dist), normal));
                }
            }
        }
        if self.points.is_empty() {
            self.points.push(fallback);
        }
    }
}

/// Every point where bodies `i` and `j` touch at `t` (a face or an edge touches at several),
/// each with the unit normal from `i` towards `j`, into `scratch.points`; two spheres, or shapes
/// whose features give none, touch at `fallback` (the contact's own point and normal).
pub(crate) fn pair_points(
    bodies: &Bodies,
    i: usize,
    j: usize,
    t: f64,
    fallback: (DVec3, DVec3),
    scratch: &mut ManifoldScratch,
) {
    let (Some(gi), Some(gj), false) = (bodies.geometry(i), bodies.geometry(j), bodies.are_spheres(i, j)) else {
        scratch.points.clear();
        scratch.points.push(fallback);
        return;
    };
    // j by its nearest image, where the contact is.
    let pose = |g: &crate::shape::ShapeGeometry, k: usize, shift: DVec3| {
        g.pose_of_shape(bodies.position_at(k, t) + shift, bodies.orientation_at(k, t))
    };
    let (own, image) = (pose(gi, i, DVec3::ZERO), pose(gj, j, bodies.image_shift(i, j, t)));
    let reach = 2.0 * contact_tolerance(gi, gj);
    scratch.touch((gi.parry_shape().as_ref(), own), (gj.parry_shape().as_ref(), image), reach, fallback);
}

/// Every point where body `i` touches `wall` of `bounds` at `t`, each with the unit normal from
/// the wall into the box, into `scratch.points`; `fallback` (the contact's own point, the normal
/// into the box) when the body's features give none.
pub(crate) fn wall_points(
    bodies: &Bodies,
    i: usize,
    wall: Wall,
    bounds: &BoxBounds,
    t: f64,
    fallback: (DVec3, DVec3),
    scratch: &mut ManifoldScratch,
) {
    let Some(g) = bodies.geometry(i).filter(|_| !bodies.is_sphere(i)) else {
        scratch.points.clear();
        scratch.points.push(fallback);
        return;
    };
    // The wall as a half-space whose solid is outside the box: its normal points in.
    let inward = -wall.outward_normal();
    let on_wall = if wall.is_max() { bounds.max } else { bounds.min };
    let plane = HalfSpace::new(inward);
    let pose_plane = Pose::from_translation(on_wall);
    let pose_body = g.pose_of_shape(bodies.position_at(i, t), bodies.orientation_at(i, t));
    let reach = 2.0 * crate::narrow_phase::shapes::SHAPE_CONTACT_TOLERANCE * bodies.radius(i);
    scratch.touch((&plane, pose_plane), (g.parry_shape().as_ref(), pose_body), reach, fallback);
}

/// How far bodies `i` and `j` may dip into each other between two impacts of a contact that goes
/// on: their contact tolerance (a sphere pair's, relative to the sum of the radii).
pub(crate) fn clearance(bodies: &Bodies, i: usize, j: usize) -> f64 {
    match (bodies.geometry(i), bodies.geometry(j)) {
        (Some(gi), Some(gj)) if !bodies.are_spheres(i, j) => contact_tolerance(gi, gj),
        _ => CONTACT_TOLERANCE * (bodies.radius(i) + bodies.radius(j)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bodies::RigidState;
    use crate::shape::Shape;
    use crate::Mode;
    use glam::DQuat;

    /// Whether a cube of side 1 lying flat with its bottom face `height` above the floor of a box
    /// counts as on the floor: the jam rule's wall test (four contact tolerances) and the stall's
    /// (two).
    fn cube_on_the_floor(height: f64) -> (bool, bool) {
        let bounds = BoxBounds::cube(4.0).unwrap();
        let mut bodies = Bodies::new(DVec3::new(0.0, 0.0, -9.81), bounds.periodic_part(), Mode::Simulate);
        let cube = Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap();
        let radius = cube.bounding_radius().unwrap();
        bodies.rigid.shapes.push(cube);
        let body = RigidState {
            shape: 0,
            radius,
            position: DVec3::new(2.0, 2.0, 0.5 + height),
            orientation: DQuat::IDENTITY,
            velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            mass: 1.0,
            fixed: false,
        };
        bodies.put_rigid(0, body, 0.0);
        let [min, max] = walls_within(&bodies, 0, &bounds, 0.0, 4.0);
        assert_eq!((min[0], min[1], max), (false, false, [false; 3]), "only the floor is near");
        (min[2], touches_a_wall(&bodies, 0, &bounds, 0.0))
    }

    /// A shape is near a wall by its own surface, within its own contact tolerance, not by its
    /// bounding sphere: a cube a shape tolerance off the floor is on it (counted off it, it kept
    /// its fall and touched the floor again at one instant for ever), one a tenth of its side off
    /// is not, though its bounding sphere reaches the floor (a cluster frozen there would lie
    /// still in mid-air).
    #[test]
    fn a_shape_is_near_a_wall_by_its_own_surface() {
        let tol =
            SHAPE_CONTACT_TOLERANCE * Shape::Cuboid { half_extents: DVec3::splat(0.5) }.geometry().unwrap().size();
        assert_eq!(cube_on_the_floor(0.0), (true, true));
        assert_eq!(cube_on_the_floor(tol), (true, true));
        assert_eq!(cube_on_the_floor(3.0 * tol), (true, false));
        assert_eq!(cube_on_the_floor(5.0 * tol), (false, false));
        assert_eq!(cube_on_the_floor(0.1), (false, false));
    }
}
