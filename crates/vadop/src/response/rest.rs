//! The rest rule: how bodies come to rest under gravity in simulate mode with restitution below 1.
//!
//! A ball dropped on a floor with restitution e bounces ever lower, each flight e times the last:
//! infinitely many bounces in the finite time `2 v / (g (1 - e))`. The TC model would end the
//! collapse by making the bounces elastic once they come within the contact duration of each
//! other, but the ball would then hover in bounces that short for ever, a hundred thousand a
//! second. So a body whose bounce would rise less than [`REST_HEIGHT`] of its radius comes to
//! rest instead ([`crate::bodies::Rest`]), each such contact counted in
//! [`crate::FrameStats::rest_contacts`]:
//!
//! - **On a wall** gravity pulls it into: it *slides* on, its velocity into the wall dropped and
//!   the pull into the wall gone (rolling on a floor costs no events), or, slower than such a
//!   bounce in every direction, it lies *still*.
//! - **On a body lying still**, from above (the normal from the support to it points against
//!   gravity) and slower than such a bounce in every direction: it lies still too, and its
//!   support stays as it was, so a pile settles from the floor up.
//!
//! A body lying still holds when a body touches it too softly to move it (the bounce, restitution
//! times the approach, below the rest speed): the other bounces off it, or rests on it when
//! slow enough. A harder impact moves it off as any body, and it falls again; the bodies lying
//! still on it are woken too, or they would float (the engine does that, as it knows which
//! bodies are near). A sliding body is an ordinary body with no pull into its wall.
//!
//! Gravity pulls a falling body into a resting one it touches even with no velocity into it
//! (sliding down its side, or over its top too fast to rest): no impulse would push them apart,
//! and the falling one would sink in. So such a pair parts at least at the rest speed (the
//! falling body hops along the other in bounces [`REST_HEIGHT`] high), as the TC model makes
//! quick repeats elastic: a change of the physics far below what a frame can show, counted with
//! the rest contacts.
//!
//! This module decides; it never changes a body itself.

use crate::bodies::{Bodies, Rest};
use crate::frame::{Mode, Physics};
use crate::walls::Wall;
use glam::DVec3;

/// A bounce rising less than this fraction of the body's radius comes to rest instead.
pub const REST_HEIGHT: f64 = 1e-4;

/// The least speed, as a fraction of the rest speed, at which a body pressed onto a resting one
/// by gravity alone hops off it: below the rest speed, so that it lands slow enough to rest.
const HOP: f64 = 0.5;

/// Whether the rest rule is on: simulate mode under gravity with restitution below 1 (an elastic
/// world keeps every bounce; its bodies may not rest on a floor at all).
#[inline]
pub(crate) fn applies(bodies: &Bodies, physics: &Physics) -> bool {
    physics.mode == Mode::Simulate && physics.restitution < 1.0 && bodies.gravity != DVec3::ZERO
}

/// The speed of a bounce of body `i` that rises [`REST_HEIGHT`] of its radius.
#[inline]
fn rest_speed(bodies: &Bodies, i: usize) -> f64 {
    (2.0 * bodies.gravity.length() * REST_HEIGHT * bodies.radius(i)).sqrt()
}

/// How body `i`, touching `wall` at `t`, comes to rest on it instead of bouncing off it with
/// `restitution`; `None` when it bounces.
pub(crate) fn on_wall(bodies: &Bodies, i: usize, wall: Wall, t: f64, restitution: f64) -> Option<Rest> {
    let axis = wall.axis();
    if !(bodies.gravity.dot(wall.outward_normal()) > 0.0) {
        return None;
    }
    let velocity = bodies.velocity_at(i, t);
    let limit = rest_speed(bodies, i);
    if !(restitution * velocity[axis].abs() < limit) {
        return None;
    }
    Some(resting_on(velocity, axis as u8, limit))
}

/// Body `i`, which slid on a wall across `axis` before it bounced off another wall at `t`: it
/// slides on (or lies still when slow), unless the bounce gave it velocity off its wall.
pub(crate) fn after_bounce(bodies: &Bodies, i: usize, t: f64, before: Rest) -> Option<Rest> {
    let Rest::Sliding(axis) = before else { return None };
    let velocity = bodies.velocity_at(i, t);
    (velocity[axis as usize] == 0.0).then(|| resting_on(velocity, axis, rest_speed(bodies, i)))
}

/// Sliding on the wall across `axis`, or still when slower than `limit` along it too.
fn resting_on(velocity: DVec3, axis: u8, limit: f64) -> Rest {
    let mut along = velocity;
    along[axis as usize] = 0.0;
    if along.length() < limit {
        Rest::Still
    } else {
        Rest::Sliding(axis)
    }
}

/// Of bodies `i` and `j` touching at `t` with `normal` from `i` to `j`: the one that comes to rest
/// on the other, which lies still (or is static) and holds it up.
pub(crate) fn on_body(bodies: &Bodies, (i, j): (usize, usize), t: f64, normal: DVec3) -> Option<usize> {
    [(j, i, normal), (i, j, -normal)].into_iter().find_map(|(body, support, up)| {
        let holds = bodies.is_fixed(support) || bodies.rest_of(support) == Rest::Still;
        let free = !bodies.is_fixed(body) && bodies.rest_of(body) != Rest::Still;
        let slow = bodies.velocity_at(body, t).length() < rest_speed(bodies, body);
        (holds && free && up.dot(bodies.gravity) < 0.0 && slow).then_some(body)
    })
}

/// Of bodies `i` and `j` touching at `t` with `normal` from `i` to `j`, approaching at normal
/// speed `approach`: the one that bounces off the other, which lies still (or is static) and
/// holds, because the bounce is too soft to move it (`restitution` times `approach` below the
/// rest speed), with the normal from the holding body to it.
pub(crate) fn soft_on_still(
    bodies: &Bodies,
    (i, j): (usize, usize),
    normal: DVec3,
    approach: f64,
    restitution: f64,
) -> Option<(usize, DVec3)> {
    [(j, i, normal), (i, j, -normal)].into_iter().find_map(|(body, support, out)| {
        let holds = bodies.is_fixed(support) || bodies.rest_of(support) == Rest::Still;
        let free = !bodies.is_fixed(body) && bodies.rest_of(body) != Rest::Still;
        (holds && free && restitution * approach < rest_speed(bodies, body)).then_some((body, out))
    })
}

/// The velocity of body `k` bouncing at `t` off a body that holds, along `out` (from the holding
/// body to `k`): its approach turned back with `restitution`, and, where gravity presses it onto
/// the other, at least at half the rest speed, so it hops on instead of sinking in.
pub(crate) fn hop(bodies: &Bodies, k: usize, t: f64, out: DVec3, restitution: f64) -> DVec3 {
    let velocity = bodies.velocity_at(k, t);
    let normal = velocity.dot(out);
    let mut leaving = (-restitution * normal).max(normal);
    if out.dot(bodies.gravity) < 0.0 {
        leaving = leaving.max(HOP * rest_speed(bodies, k));
    }
    velocity + (leaving - normal) * out
}

/// Bodies `i` and `j`, which fell differently (one of them rested) before their impact at `t`
/// along `normal` (from `i` to `j`): gravity pulls them together while no velocity may push them
/// apart, so they part at least at half the rest speed, momentum kept; the impulse that took.
pub(crate) fn part(bodies: &mut Bodies, (i, j): (usize, usize), t: f64, normal: DVec3) -> f64 {
    let (vi, vj) = (bodies.velocity_at(i, t), bodies.velocity_at(j, t));
    let (wi, wj) = (bodies.inverse_mass(i), bodies.inverse_mass(j));
    let parting = (vj - vi).dot(normal);
    let least = HOP * rest_speed(bodies, i).min(rest_speed(bodies, j));
    if !(parting < least) || wi + wj == 0.0 {
        return 0.0;
    }
    let impulse = (least - parting) / (wi + wj);
    bodies.set_velocity_at(i, t, vi - impulse * wi * normal);
    bodies.set_velocity_at(j, t, vj + impulse * wj * normal);
    impulse
}

/// Whether bodies `i` and `j` fall differently: one of them rests, so gravity pulls them
/// together while no velocity need do (see the module documentation).
#[inline]
pub(crate) fn fall_differently(bodies: &Bodies, i: usize, j: usize) -> bool {
    bodies.gravity_on(i) != bodies.gravity_on(j)
}
