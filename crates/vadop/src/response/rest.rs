//! The rest rule: how bodies come to rest under gravity in simulate mode with restitution below 1.
//!
//! A ball dropped on a floor with restitution e bounces ever lower, each flight e times the last:
//! infinitely many bounces in the finite time `2 v / (g (1 - e))`. The TC model would end the
//! collapse by making the bounces elastic once they come within the contact duration of each
//! other, but the ball would then hover in bounces that short for ever, a hundred thousand a
//! second. So a body comes to rest ([`crate::bodies::Rest`]) instead of making a bounce that
//! would rise less than [`REST_HEIGHT`] of its radius (slower than its *rest speed*), or instead
//! of repeating its own last contact within the contact duration while pressed onto what holds
//! it (it is wedged, or collapsing onto it). Each such contact is counted in
//! [`crate::FrameStats::rest_contacts`]:
//!
//! - **On a wall** gravity pulls it into: it *slides* on, its velocity into the wall dropped and
//!   the pull into the wall gone (rolling on a floor costs no events; pressed into a side wall
//!   too under tilted gravity, it slides along the corner). Slower than the rest speed with no
//!   pull left, it lies *still*.
//! - **On a body lying still** that its pull (gravity, less what its walls take) presses it
//!   onto, slower than the rest speed (or in such a repeat): it lies still too, and its support
//!   stays as it was, so a pile settles from the floor up. This is where the rule changes the
//!   physics most: a body that slow sticks where it touches, even on a steep side, as static
//!   friction would hold it; it loses at most `m v^2 / 2` at the rest speed.
//! - **On static geometry** (a half-space, a mesh, any static body), which holds still as a body
//!   lying still does and is never woken: the same, but a body rests there when its bounce would
//!   be slower than the rest speed, as on a wall, so a ball lands there as often as on the floor.
//!   It cannot slide along a surface that need not be a wall's plane: moving on faster, it hops
//!   along it as below.
//! - **Sliding and slow**: after any impact, a sliding body slower than the rest speed with no
//!   pull left lies still.
//! - **A shape other than a ball** cannot slide or roll on (it would turn into what holds it):
//!   where a ball would rest it lies still, where it touches, its spin stopped, and its speed
//!   counts its spin too (the speed its farthest points get from it), so a body only lies still
//!   once every point of it is slower than the rest speed. It never bounces off a body lying
//!   still by its centre's velocity alone (a turning shape's point could still approach): it
//!   takes the ordinary impact, which moves the body lying still, or not if it is static.
//!
//! A body lying still is held up by what it lies on, so it does not move when a body lands on
//! top of it (the normal from it to the other within 60 degrees of the other's pull, [`ON_TOP`]:
//! its supports carry the blow down to the floor, as in a settled pile), nor when a body touches
//! it too softly to move it (the bounce, restitution times the approach, below the rest speed):
//! the other body bounces off it as off a wall. A harder impact from the side or below moves it
//! as any body, and it falls again; the bodies lying still on it are woken too, or they would
//! float (the engine does that, as it knows which bodies are near; between frames the world does
//! it for the bodies the caller moves or removes). A jammed cluster (the jam rule) that is held
//! up by a wall gravity pulls into or by a body lying still lies still as a whole.
//!
//! Gravity pulls a body that falls into one that does not (lies still or slides on a floor)
//! even with no velocity between them, sliding down its side or riding on it: no impulse would
//! push them apart, and the falling one would sink in. So such a pair parts at least at half the
//! rest speed, its momentum kept: the falling body hops along the other in bounces a quarter of
//! [`REST_HEIGHT`] high, as the TC model makes quick repeats elastic. This adds at most
//! `m v^2 / 2` at half the rest speed per contact, far below what a frame can show, and each hop
//! takes a flight of its own; when the pressed body repeats its last contact within the contact
//! duration it is jammed instead (or rests, on a body lying still), so a body wedged between what
//! holds it cannot hop without end.
//!
//! This module decides and changes the bodies of one contact; which bodies are near (the
//! bodies to wake, the cluster to freeze) is the engine's knowledge.

use crate::bodies::{Bodies, Rest};
use crate::frame::{Mode, Physics};
use crate::motion::hold::without_axes;
use crate::walls::Wall;
use glam::DVec3;

/// A bounce rising less than this fraction of the body's radius comes to rest instead.
pub const REST_HEIGHT: f64 = 1e-4;

/// A body lying still holds against an impact of a body on top of it: the normal from its centre
/// to the other's makes at least this cosine with the other's pull reversed (within 60 degrees).
pub const ON_TOP: f64 = 0.5;

/// The least speed, as a fraction of the rest speed, at which a body pressed onto another by
/// gravity alone parts from it: below the rest speed, so that it lands slow enough to rest.
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

/// Whether body `i` holds still as a support: it lies still, or it is static (level geometry is
/// a body lying still that nothing wakes).
#[inline]
fn is_still(bodies: &Bodies, i: usize) -> bool {
    bodies.is_fixed(i) || bodies.rest_of(i) == Rest::Still
}

/// `speed`, body `i`'s centre's at `t`, and for a shape other than a sphere the speed its spin
/// gives its farthest points too: such a shape lies still with its spin stopped, so the rest
/// speed bounds the spin's share as well (a sphere's spin moves no point off its surface).
fn with_spin(bodies: &Bodies, i: usize, t: f64, speed: f64) -> f64 {
    match bodies.is_sphere(i) {
        true => speed,
        false => speed + bodies.angular_velocity_at(i, t).length() * bodies.radius(i),
    }
}

/// How a body held on the walls across `axes` with `velocity` (none into them) rests: still
/// when slower than `limit` with no pull left along the walls, sliding otherwise.
fn held(gravity: DVec3, velocity: DVec3, axes: u8, limit: f64) -> Rest {
    if velocity.length() < limit && without_axes(gravity, axes) == DVec3::ZERO {
        Rest::Still
    } else {
        Rest::Sliding(axes)
    }
}

/// Body `i` touches `wall` at `t` and would bounce with `restitution`, `quick` when it is a
/// repeat within the contact duration: whether it comes to rest on the wall instead (true), its
/// new rest set.
pub(crate) fn on_wall(
    bodies: &mut Bodies,
    physics: &Physics,
    i: usize,
    wall: Wall,
    t: f64,
    restitution: f64,
    quick: bool,
) -> bool {
    let axis = wall.axis();
    if !(bodies.gravity.dot(wall.outward_normal()) > 0.0) {
        return false;
    }
    let (velocity, limit) = (bodies.velocity_at(i, t), rest_speed(bodies, i));
    if !bodies.is_sphere(i) {
        // Any other shape would turn into the wall as it slid: it lies still where it touches.
        if !(quick || restitution * with_spin(bodies, i, t, velocity.length()) < limit) {
            return false;
        }
        bodies.lie_still(i, t);
        return true;
    }
    if !(quick || restitution * velocity[axis].abs() < limit) {
        return false;
    }
    let axes = bodies.rest_of(i).sliding_axes() | (1 << axis);
    let rest = held(bodies.gravity, without_axes(velocity, axes), axes, limit);
    bodies.come_to_rest(i, t, rest, axes, physics.bounds.walls());
    true
}

/// After an impact gave body `i` a new motion at `t` (which falls), when it slid on walls before
/// (`before`): it slides on along those its velocity does not leave, or lies still when slow.
pub(crate) fn keep_held(bodies: &mut Bodies, physics: &Physics, i: usize, t: f64, before: Rest) {
    let velocity = bodies.velocity_at(i, t);
    let axes = (0..3).filter(|&axis| velocity[axis] == 0.0).fold(0, |axes, axis| axes | (1 << axis));
    let axes = before.sliding_axes() & axes;
    if axes != 0 && bodies.rest_of(i) == Rest::Falling {
        let rest = held(bodies.gravity, velocity, axes, rest_speed(bodies, i));
        bodies.come_to_rest(i, t, rest, axes, physics.bounds.walls());
    }
}

/// Bodies `i` and `j` touch at `t` along `normal` (from `i` to `j`), exactly one of them lying
/// still, with the contact's `restitution`, `quick[0]` (`quick[1]`) when `i`'s (`j`'s) previous
/// contact lies within the contact duration:
/// the body that is not still rests on it or bounces off it, which holds (see the module
/// documentation). Returns that body and the impulse it took; `None` when the impact moves the
/// body lying still (an ordinary impact).
pub(crate) fn against_still(
    bodies: &mut Bodies,
    (i, j): (usize, usize),
    t: f64,
    normal: DVec3,
    (restitution, quick): (f64, [bool; 2]),
) -> Option<(usize, f64)> {
    let (k, out, quick, support) = match (is_still(bodies, i), is_still(bodies, j)) {
        (true, false) => (j, normal, quick[1], i),
        (false, true) => (i, -normal, quick[0], j),
        _ => return None,
    };
    let (velocity, limit, pull) = (bodies.velocity_at(k, t), rest_speed(bodies, k), bodies.gravity_on(k));
    // `out` runs from the body lying still to `k`: its pull (gravity, less what its walls take)
    // presses `k` onto it, or more.
    let pressed = out.dot(pull) < 0.0;
    let on_top = pressed && -out.dot(pull) >= ON_TOP * pull.length();
    let normal_speed = velocity.dot(out);
    // Static geometry is a floor as the walls are: `k` rests on it when its bounce would be
    // slower than the rest speed, so a ball lands there as often as on a wall.
    let speed = match bodies.is_fixed(support) {
        true => (velocity - (1.0 + restitution) * normal_speed * out).length(),
        false => velocity.length(),
    };
    let speed = with_spin(bodies, k, t, speed);
    if pressed && (quick || speed < limit) {
        bodies.lie_still(k, t);
        return Some((k, bodies.mass(k) * velocity.length()));
    }
    // Bouncing off by its centre's velocity suits a ball only: a turning shape's point may still
    // approach, so any other shape takes the ordinary impact (a static support holds it anyway).
    if !(on_top || -restitution * normal_speed < limit) || !bodies.is_sphere(k) {
        return None;
    }
    // It holds: `k` bounces off it, and parts at least at half the rest speed when pressed.
    let mut leaving = (-restitution * normal_speed).max(normal_speed);
    if pressed {
        leaving = leaving.max(HOP * limit);
    }
    let bounced = velocity + (leaving - normal_speed) * out;
    bodies.set_velocity_at(k, t, bounced);
    Some((k, bodies.mass(k) * (leaving - normal_speed)))
}

/// Of bodies `i` and `j`, touching along `normal` (from `i` to `j`) with their accelerations as
/// they are held now: the one gravity presses onto the other (the one that falls, on one that
/// does not), if any: 0 for `i`, 1 for `j`.
#[inline]
pub(crate) fn pressed_onto(bodies: &Bodies, (i, j): (usize, usize), normal: DVec3) -> Option<usize> {
    let (ai, aj) = (bodies.gravity_on(i), bodies.gravity_on(j));
    if !((aj - ai).dot(normal) < 0.0) {
        return None;
    }
    Some(if aj.dot(normal) < 0.0 { 1 } else { 0 })
}

/// Bodies `i` and `j`, pressed together by gravity before their impact at `t` along `normal`
/// (from `i` to `j`), which left them parting slower than half the rest speed: they part at that
/// speed, momentum kept; the impulse that took (see the module documentation).
pub(crate) fn part(bodies: &mut Bodies, (i, j): (usize, usize), t: f64, normal: DVec3) -> f64 {
    let (vi, vj) = (bodies.velocity_at(i, t), bodies.velocity_at(j, t));
    let (wi, wj) = (bodies.inverse_mass(i), bodies.inverse_mass(j));
    let parting = (vj - vi).dot(normal);
    let least = HOP * rest_speed(bodies, i).min(rest_speed(bodies, j));
    if !(parting < least) {
        return 0.0;
    }
    let impulse = (least - parting) / (wi + wj);
    // A static body keeps its motion and its stamp: its predictions stand, as it is never
    // tested again.
    for (k, velocity) in [(i, vi - impulse * wi * normal), (j, vj + impulse * wj * normal)] {
        if !bodies.is_fixed(k) {
            bodies.set_velocity_at(k, t, velocity);
        }
    }
    impulse
}
