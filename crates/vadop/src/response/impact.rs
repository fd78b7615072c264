//! The impact policy: what a contact found by the narrow phase does to the bodies, in one place
//! for both engines. It picks the contact rule (restitution under the TC model, or the jam rule),
//! the arithmetic (the spheres' closed form, or rigid impulses over the contact points against a
//! body, static geometry or a wall) and applies the new motions. It answers with what the engine
//! must still do ([`Resolution`]); it never re-tests, schedules or freezes a cluster itself,
//! because which bodies are near is the engine's knowledge, not the response's.

use super::impulse::{pair_impulse, resolve_impact, wall_bounce, Impacted};
use super::rest;
use super::rules::{ContactRules, Rule};
use crate::bodies::Bodies;
use crate::frame::{FrameStats, Mode, Physics};
use crate::motion::Motion;
use crate::narrow_phase::contacts::{self, ManifoldScratch, SphereTouch};
use crate::narrow_phase::shapes::SHAPE_CONTACT_TOLERANCE;
use crate::walls::Wall;
use glam::{DMat3, DVec3};

/// What the engine must do once an impact is resolved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Resolution {
    /// Detect mode between two moving bodies: they keep their paths, nothing changed.
    Passed,
    /// New motions were set, with this total impulse: re-test the bodies that moved.
    Pushed(f64),
    /// This body came to rest on the other, which is unchanged (the rest rule), taking this
    /// impulse: re-test it alone.
    Rested(u32, f64),
    /// Two plain spheres already parting: a zero impulse, nothing changed.
    Parting,
    /// Freeze the cluster touching them (the jam rule). `by_rule` when the contact rules called
    /// it, so the impulse reported is what the freeze took; otherwise the impulses found nothing
    /// that settles a touch, and it is reported without one.
    Jammed { by_rule: bool },
}

/// The TC model's contact duration for a contact now: the TC model is for collapse between
/// bodies in simulate mode; detect mode only needs the jam rule.
fn tc_duration(physics: &Physics) -> f64 {
    if physics.mode == Mode::Simulate {
        physics.contact_duration
    } else {
        0.0
    }
}

/// Body `i` at time `t` as an impact sees it: immovable when static.
pub(crate) fn impacted(bodies: &Bodies, i: usize, t: f64) -> Impacted {
    if bodies.is_fixed(i) {
        return Impacted::FIXED;
    }
    let rotation = DMat3::from_quat(bodies.orientation_at(i, t));
    let inverse = DMat3::from_diagonal(bodies.principal_inertia(i).recip());
    Impacted {
        velocity: bodies.velocity_at(i, t),
        angular_velocity: bodies.angular_velocity_at(i, t),
        inverse_mass: bodies.inverse_mass(i),
        inverse_inertia: rotation * inverse * rotation.transpose(),
        centre: bodies.position_at(i, t),
    }
}

/// Two moving spheres pushed apart along `normal` (from `i` to `j`) at `t` with `restitution`;
/// the impulse, 0 (and nothing changed) when they already part.
#[inline]
pub(crate) fn push_spheres(
    bodies: &mut Bodies,
    (i, j): (usize, usize),
    t: f64,
    normal: DVec3,
    restitution: f64,
) -> f64 {
    push_spheres_moving(bodies, (i, j), paths_on(bodies, (i, j), t), normal, restitution)
}

/// Bodies `i` and `j`'s paths moved on to `t`: their centres and velocities there, since `t`.
#[inline]
fn paths_on(bodies: &Bodies, (i, j): (usize, usize), t: f64) -> [Motion; 2] {
    [i, j].map(|k| bodies.motion(k).moved_on(t, bodies.velocity_at(k, t), bodies.gravity_on(k)))
}

/// [`push_spheres`] of spheres on `paths`, their paths moved on to the impact's time (read by
/// the caller, see [`paths_on`]): each keeps its centre there with its new velocity.
#[inline(always)]
fn push_spheres_moving(
    bodies: &mut Bodies,
    (i, j): (usize, usize),
    paths: [Motion; 2],
    normal: DVec3,
    restitution: f64,
) -> f64 {
    match spheres_pushed(bodies, (i, j), [paths[0].velocity, paths[1].velocity], normal, restitution) {
        Some((impulse, vi, vj)) => {
            bodies.set_velocity_on(i, paths[0], vi);
            bodies.set_velocity_on(j, paths[1], vj);
            impulse
        }
        None => 0.0,
    }
}

/// What [`push_spheres`] does to spheres `i` and `j` moving at `[vi, vj]` at the impact, without
/// doing it: the impulse and their velocities after it; none when they already part.
#[inline(always)]
pub(crate) fn spheres_pushed(
    bodies: &Bodies,
    (i, j): (usize, usize),
    [vi, vj]: [DVec3; 2],
    normal: DVec3,
    restitution: f64,
) -> Option<(f64, DVec3, DVec3)> {
    let (wi, wj) = (bodies.inverse_mass(i), bodies.inverse_mass(j));
    let impulse = pair_impulse(normal, vi, vj, wi, wj, restitution);
    (impulse > 0.0).then(|| (impulse, vi - impulse * wi * normal, vj + impulse * wj * normal))
}

/// The collisional virial of an impact of bodies `i` and `j` at `t`: the separation of their
/// centres (`j`'s minus `i`'s) dotted with the momentum `j` gained, `before` being `j`'s velocity
/// at `t` before the impact (the impact has just set its motion at `t`). An impact conserves momentum, so taking `i` as the second body gives the same.
pub(crate) fn exchange_virial(bodies: &Bodies, (i, j): (usize, usize), t: f64, before: DVec3) -> f64 {
    virial(bodies.offset_at(i, j, t), bodies.mass(j), (before, bodies.velocity(j)))
}

/// [`exchange_virial`] from the separation of the centres at the impact (`j`'s minus `i`'s,
/// [`Bodies::offset_at`]), `j`'s mass `mass_j` and its velocity `before` and `after` (which
/// the store may not hold yet): for a caller that has the separation at hand.
#[inline]
pub(crate) fn virial(separation: DVec3, mass_j: f64, (before, after): (DVec3, DVec3)) -> f64 {
    separation.dot(mass_j * (after - before))
}

/// A sphere bounced off `wall` at `t` with `restitution`; the impulse.
pub(crate) fn bounce_off_wall(bodies: &mut Bodies, i: usize, wall: Wall, t: f64, restitution: f64) -> f64 {
    let (bounced, impulse) = velocity_off_wall(bodies, i, wall, t, restitution);
    bodies.set_velocity_at(i, t, bounced);
    impulse
}

/// The velocity [`bounce_off_wall`] gives sphere `i`, and the impulse (nothing changed).
#[inline]
fn velocity_off_wall(bodies: &Bodies, i: usize, wall: Wall, t: f64, restitution: f64) -> (DVec3, f64) {
    let v = bodies.velocity_at(i, t);
    let bounced = wall_bounce(v, wall.axis(), restitution);
    (bounced, bodies.mass(i) * (v - bounced).length())
}

/// The motion [`bounce_off_wall`] gives sphere `i` of a world without spins, and the impulse
/// (nothing changed).
#[inline]
pub(crate) fn motion_off_wall(bodies: &Bodies, i: usize, wall: Wall, t: f64, restitution: f64) -> (Motion, f64) {
    let (bounced, impulse) = velocity_off_wall(bodies, i, wall, t, restitution);
    (bodies.motion(i).moved_on(t, bounced, bodies.gravity_on(i)), impulse)
}

/// The scratch an engine keeps for its impacts: the contact rules' history and the contact
/// points a rigid impact is resolved over.
#[derive(Debug, Default)]
pub(crate) struct Impacts {
    pub rules: ContactRules,
    pub manifold: ManifoldScratch,
}

/// Whether bodies `i` and `j` are two moving spheres without friction: their impact is the
/// closed-form impulse along the line of centres ([`push_spheres`]).
#[inline]
fn plain_spheres(bodies: &Bodies, physics: &Physics, i: usize, j: usize) -> bool {
    bodies.are_spheres(i, j) && physics.friction == 0.0 && !bodies.is_fixed(i) && !bodies.is_fixed(j)
}

/// Whether an impact of bodies `i` and `j` is [`Impacts::plain_pair`]'s: two moving spheres
/// without friction in simulate mode, without the rest rule (every impact of a gas).
#[inline]
pub(crate) fn is_plain_pair(bodies: &Bodies, physics: &Physics, i: usize, j: usize) -> bool {
    physics.mode == Mode::Simulate && !rest::applies(bodies, physics) && plain_spheres(bodies, physics, i, j)
}

/// Two moving frictionless spheres, on `paths` (moved on to the impact's time, see
/// [`paths_on`]), pushed apart along `normal` with the contact rules' `restitution` (`changed`
/// when the TC model set it): pushed, or parting with nothing changed.
fn pushed_apart(
    bodies: &mut Bodies,
    (i, j): (usize, usize),
    paths: [Motion; 2],
    normal: DVec3,
    (restitution, changed): (f64, bool),
    stats: &mut FrameStats,
) -> Resolution {
    let impulse = push_spheres_moving(bodies, (i, j), paths, normal, restitution);
    // Zero impulse changes nothing; re-testing would find the same touch again.
    if impulse > 0.0 {
        stats.tc_contacts += changed as u64;
        Resolution::Pushed(impulse)
    } else {
        Resolution::Parting
    }
}

/// Whether bodies `i` and `j` pass through each other at a contact, neither changed: two moving
/// bodies in detect mode (see [`crate::frame::Mode::turns_back`]).
#[inline]
pub(crate) fn passes_through(bodies: &Bodies, physics: &Physics, i: usize, j: usize) -> bool {
    !physics.turns_back(bodies.is_fixed(i) || bodies.is_fixed(j))
}

impl Impacts {
    /// Spheres `a < b`, an [`is_plain_pair`] pair, touch at `t`: where (read once from their
    /// paths), the rule recorded in their history, the push, and the push's virial (0 unless
    /// pushed). The lean case of every impact of a gas, and what [`Self::pair`] with the
    /// geometry of [`contacts::pair_geometry`] and [`exchange_virial`] make of such a pair, to
    /// the bit: for it `pair` records the same rule and pushes through the same
    /// [`pushed_apart`], and the offset of the geometry is the virial's separation (the centres
    /// at `t` do not move when a velocity is set at `t`).
    pub(crate) fn plain_pair(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        (a, b): (u32, u32),
        t: f64,
        stats: &mut FrameStats,
    ) -> (SphereTouch, Resolution, f64) {
        let (i, j) = (a as usize, b as usize);
        let (touch, before) = contacts::spheres_touch_on(bodies, i, j, t);
        let resolution = match self.rules.pair(a, b, t, physics.restitution, tc_duration(physics)) {
            Rule::Jam => return (touch, Resolution::Jammed { by_rule: true }, 0.0),
            Rule::Impulse { restitution, changed } => {
                pushed_apart(bodies, (i, j), before, touch.normal, (restitution, changed), stats)
            }
        };
        let pushed = matches!(resolution, Resolution::Pushed(_));
        let virial =
            if pushed { virial(touch.offset, bodies.mass(j), (before[1].velocity, bodies.velocity(j))) } else { 0.0 };
        (touch, resolution, virial)
    }

    /// Bodies `a` and `b` touch at `t` at `point` with `normal` (from `a` to `b`).
    pub(crate) fn pair(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        (a, b): (u32, u32),
        t: f64,
        (point, normal): (DVec3, DVec3),
        stats: &mut FrameStats,
    ) -> Resolution {
        let (i, j) = (a as usize, b as usize);
        if passes_through(bodies, physics, i, j) {
            return Resolution::Passed;
        }
        let fixed = (bodies.is_fixed(i), bodies.is_fixed(j));
        let duration = tc_duration(physics);
        // Whether each body's own previous contact lies within the contact duration (the TC
        // model asks whether either's does).
        let quick = [a, b].map(|k| t - self.rules.last_contact(k as usize) < duration);
        // Level geometry keeps no contact history, as a wall keeps none: the TC model and the
        // jam count are about the moving body's own contacts.
        let rule = match fixed {
            (true, _) => self.rules.wall(b, t, physics.restitution, duration),
            (_, true) => self.rules.wall(a, t, physics.restitution, duration),
            _ => self.rules.pair(a, b, t, physics.restitution, duration),
        };
        // Two moving spheres without friction: the closed-form impulse along the line of centres.
        let plain = plain_spheres(bodies, physics, i, j);
        let resting = rest::applies(bodies, physics);
        let before = [bodies.rest_of(i), bodies.rest_of(j)];
        // Gravity presses one onto the other whatever their velocities: they must part (see
        // [`rest`]).
        let pressed = if resting { rest::pressed_onto(bodies, (i, j), normal) } else { None };
        if let (true, Rule::Impulse { restitution, .. }) = (resting, rule) {
            if let Some((k, impulse)) = rest::against_still(bodies, (i, j), t, normal, (restitution, quick)) {
                stats.rest_contacts += 1;
                rest::keep_held(bodies, physics, k, t, before[(k == j) as usize]);
                return Resolution::Rested(k as u32, impulse);
            }
            // The pressed body's repeat within the contact duration: it collapses onto the other,
            // which holds it up, or is wedged.
            if pressed.is_some_and(|k| quick[k]) {
                return Resolution::Jammed { by_rule: true };
            }
        }
        let pressed = pressed.is_some();
        let resolution = match rule {
            Rule::Jam => Resolution::Jammed { by_rule: true },
            Rule::Impulse { restitution, changed } if plain => {
                pushed_apart(bodies, (i, j), paths_on(bodies, (i, j), t), normal, (restitution, changed), stats)
            }
            Rule::Impulse { restitution, changed } => {
                contacts::pair_points(bodies, i, j, t, (point, normal), &mut self.manifold);
                let [mut body_i, mut body_j] = [impacted(bodies, i, t), impacted(bodies, j, t)];
                // Across a periodic face the contact lies by j's nearest image.
                body_j.centre += bodies.image_shift(i, j, t);
                let clearance = contacts::clearance(bodies, i, j);
                let points = &self.manifold.points;
                match resolve_impact(&mut body_i, &mut body_j, points, restitution, physics.friction, clearance) {
                    Some(total) if total > 0.0 || pressed => {
                        stats.tc_contacts += changed as u64;
                        for (k, body) in [(i, body_i), (j, body_j)] {
                            if !bodies.is_fixed(k) {
                                bodies.set_motion_at(k, t, body.velocity, body.angular_velocity);
                            }
                        }
                        Resolution::Pushed(total)
                    }
                    // Nothing to push, yet the search found them touching as they turn into
                    // each other (it would find the same touch again while one sinks into the
                    // other), or points still approach however the impulses go: jammed.
                    Some(_) | None => Resolution::Jammed { by_rule: false },
                }
            }
        };
        match resolution {
            Resolution::Pushed(_) | Resolution::Parting if resting => {
                let total = if let Resolution::Pushed(total) = resolution { total } else { 0.0 };
                let parted = if pressed { rest::part(bodies, (i, j), t, normal) } else { 0.0 };
                stats.rest_contacts += (parted > 0.0) as u64;
                if total + parted == 0.0 {
                    return Resolution::Parting;
                }
                for (k, before) in [(i, before[0]), (j, before[1])] {
                    rest::keep_held(bodies, physics, k, t, before);
                }
                Resolution::Pushed(total + parted)
            }
            _ => resolution,
        }
    }

    /// Body `a` touches `wall` at `t` at `point`, `normal` out of the box.
    pub(crate) fn wall(
        &mut self,
        bodies: &mut Bodies,
        physics: &Physics,
        (a, wall): (u32, Wall),
        t: f64,
        (point, normal): (DVec3, DVec3),
        stats: &mut FrameStats,
    ) -> Resolution {
        let i = a as usize;
        let rule = self.rules.wall(a, t, physics.restitution, tc_duration(physics));
        let (resting, before) = (rest::applies(bodies, physics), bodies.rest_of(i));
        if let (true, Rule::Impulse { restitution, changed }) = (resting, rule) {
            let velocity = bodies.velocity_at(i, t);
            if rest::on_wall(bodies, physics, i, wall, t, restitution, changed) {
                stats.rest_contacts += 1;
                return Resolution::Pushed(bodies.mass(i) * (velocity - bodies.velocity(i)).length());
            }
        }
        let resolution = match rule {
            Rule::Jam => Resolution::Jammed { by_rule: true },
            Rule::Impulse { restitution, changed } if bodies.is_sphere(i) && physics.friction == 0.0 => {
                stats.tc_contacts += changed as u64;
                Resolution::Pushed(bounce_off_wall(bodies, i, wall, t, restitution))
            }
            Rule::Impulse { restitution, changed } => {
                // The wall is an immovable body on the far side of the contact.
                contacts::wall_points(bodies, i, wall, &physics.bounds, t, (point, -normal), &mut self.manifold);
                let (mut wall_side, mut body) = (Impacted::FIXED, impacted(bodies, i, t));
                let clearance = SHAPE_CONTACT_TOLERANCE * bodies.radius(i);
                let points = &self.manifold.points;
                match resolve_impact(&mut wall_side, &mut body, points, restitution, physics.friction, clearance) {
                    Some(total) if total > 0.0 => {
                        stats.tc_contacts += changed as u64;
                        bodies.set_motion_at(i, t, body.velocity, body.angular_velocity);
                        Resolution::Pushed(total)
                    }
                    // As between bodies: nothing to push while the search finds it touching, or
                    // no impulse that settles it: jammed against the wall.
                    Some(_) | None => Resolution::Jammed { by_rule: false },
                }
            }
        };
        // A body sliding on the floor that bounced off a side wall slides on.
        if let (true, Resolution::Pushed(_)) = (resting, resolution) {
            rest::keep_held(bodies, physics, i, t, before);
        }
        resolution
    }
}
