//! Helpers shared by the reliability tests: bit-exact fingerprints of contacts and states, random
//! directions, and the frame-end invariants every run must keep.

#![allow(dead_code)] // Each test file uses its own subset.

use glam::DVec3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use vadop::narrow_phase::shapes::{contact_tolerance, SHAPE_CONTACT_TOLERANCE};
use vadop::narrow_phase::spheres::CONTACT_TOLERANCE;
use vadop::shape::Shape;
use vadop::{Body, BodyHandle, BodyShape, Contact, Method, Mode, Sphere, VadopError, World};

/// Every field of every contact as bits: a difference in the last bit, or in the sign of a zero,
/// shows.
pub fn contact_bits(contacts: &[Contact]) -> Vec<String> {
    let bits = |v: DVec3| v.to_array().map(f64::to_bits);
    contacts
        .iter()
        .map(|c| {
            format!(
                "{:x} {} {:?} {:?} {:?} {:x}",
                c.time.to_bits(),
                c.body,
                c.touched,
                bits(c.point),
                bits(c.normal),
                c.impulse.to_bits()
            )
        })
        .collect()
}

/// The time and every live body as bits.
pub fn state_bits(world: &World) -> Vec<String> {
    let bits = |v: DVec3| v.to_array().map(f64::to_bits);
    let mut state = vec![format!("time {:x}", world.time().to_bits())];
    state.extend(world.spheres().map(|(id, s)| {
        format!("{id} {:?} {:?} {:x} {:x}", bits(s.position), bits(s.velocity), s.radius.to_bits(), s.mass.to_bits())
    }));
    state
}

/// A uniformly random unit vector.
pub fn random_direction(rng: &mut ChaCha8Rng) -> DVec3 {
    loop {
        let v = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        if v.length_squared() <= 1.0 {
            if let Some(u) = v.try_normalize() {
                return u;
            }
        }
    }
}

/// What is wrong at a frame end, if anything: a body outside the box, or (simulate mode, when
/// `pairs` is set) two bodies overlapping beyond the contact tolerance, with a little slack for
/// the rounding of positions far from the origin.
pub fn frame_end_violation(world: &World, pairs: bool) -> Option<String> {
    let bounds = world.bounds();
    let scale = bounds.min.abs().max(bounds.max.abs()).max_element();
    let spheres: Vec<(BodyHandle, Sphere)> = world.spheres().collect();
    for (id, s) in &spheres {
        let slack = 1e-9 * s.radius + 4.0 * f64::EPSILON * scale;
        if !((s.position - s.radius).cmpge(bounds.min - slack).all()
            && (s.position + s.radius).cmple(bounds.max + slack).all())
        {
            return Some(format!("body {id} left the box: {s:?}"));
        }
    }
    if !pairs || world.config().mode == Mode::Detect {
        return None;
    }
    for (k, (i, a)) in spheres.iter().enumerate() {
        for (j, b) in &spheres[k + 1..] {
            let reach = a.radius + b.radius;
            let slack = 2.0 * CONTACT_TOLERANCE * reach + 8.0 * f64::EPSILON * a.position.abs().max_element();
            let distance = a.position.distance(b.position);
            if distance < reach - slack {
                return Some(format!("bodies {i} and {j} overlap by {:e}", reach - distance));
            }
        }
    }
    None
}

/// What is wrong at a frame end in a periodic box, if anything: a centre outside the faces of a
/// periodic axis, a body through a wall of a walled one, or (simulate mode) two bodies
/// overlapping through their nearest images beyond the contact tolerance.
pub fn periodic_violation(world: &World) -> Option<String> {
    let bounds = world.bounds();
    let spheres: Vec<_> = world.spheres().collect();
    for (id, s) in &spheres {
        for a in 0..3 {
            let reach = if bounds.periodic[a] { 0.0 } else { s.radius };
            let slack = 1e-9 * s.radius;
            if s.position[a] - reach < bounds.min[a] - slack || s.position[a] + reach > bounds.max[a] + slack {
                return Some(format!("body {id} left the box on axis {a}: {s:?}"));
            }
        }
    }
    if world.config().mode == Mode::Simulate {
        for (k, (i, a)) in spheres.iter().enumerate() {
            for (j, b) in &spheres[k + 1..] {
                let reach = a.radius + b.radius;
                let distance = bounds.nearest_image(b.position - a.position).length();
                if distance < reach * (1.0 - 1e-8) {
                    return Some(format!("bodies {i} and {j} overlap by {:e}", reach - distance));
                }
            }
        }
    }
    None
}

/// Steps `found` and the brute-force `oracle` side by side for `frames` frames of `dt`: each
/// frame's contacts must match the oracle's to the bit, then `check(frame, oracle)` runs; at the
/// end the states must match to the bit. A step both refuse ends the run early and returns the
/// error, which must read the same for both.
pub fn step_beside_oracle(
    found: &mut World,
    oracle: &mut World,
    frames: usize,
    dt: f64,
    mut check: impl FnMut(usize, &World),
) -> Option<VadopError> {
    let method = found.method();
    let mut refused = None;
    for frame in 0..frames {
        match (found.step(dt).map(<[Contact]>::to_vec), oracle.step(dt)) {
            (Ok(contacts), Ok(expected)) => {
                assert_eq!(contact_bits(&contacts), contact_bits(expected), "frame {frame}: {method:?}");
            }
            (Err(e), Err(o)) => {
                assert_eq!(e.to_string(), o.to_string(), "frame {frame}: both refuse the same body");
                refused = Some(e);
                break;
            }
            (found, expected) => panic!("frame {frame}: {method:?} gave {found:?}, the oracle {expected:?}"),
        }
        check(frame, oracle);
    }
    assert_eq!(state_bits(found), state_bits(oracle), "{method:?}: final states differ");
    refused
}

/// [`step_beside_oracle`] for each continuous method (`build` makes the worlds), none refusing
/// a step; returns the oracle of the last, stepped `frames` frames of `dt`.
pub fn every_method_beside_oracle(build: impl Fn(Method) -> World, frames: usize, dt: f64) -> World {
    let mut settled = None;
    for method in [Method::Vadop, Method::Grid, Method::SweptAabb] {
        let (mut found, mut oracle) = (build(method), build(Method::Brute));
        let refused = step_beside_oracle(&mut found, &mut oracle, frames, dt, |_, _| {});
        assert!(refused.is_none(), "{method:?}: {refused:?}");
        settled = Some(oracle);
    }
    settled.expect("three methods ran")
}

/// Saves `world` (under `name` in the temporary directory), loads it back, and steps both for
/// `frames` frames of `dt`: the resumed world's contacts and final state must match to the bit.
pub fn assert_resumes_bit_exactly(world: &mut World, name: &str, frames: usize, dt: f64) {
    let path = std::env::temp_dir().join(format!("vadop-{name}-{}.json", std::process::id()));
    world.save(&path).unwrap();
    let mut resumed = World::load(&path).unwrap();
    std::fs::remove_file(&path).ok();
    for frame in 0..frames {
        let (a, b) = (world.step(dt).unwrap().to_vec(), resumed.step(dt).unwrap().to_vec());
        assert_eq!(contact_bits(&a), contact_bits(&b), "frame {frame}");
    }
    assert_eq!(state_bits(world), state_bits(&resumed));
}

/// The instants (from the drop) at which a ball of `radius` dropped from rest `height` above its
/// floor under gravity `g` lands, each landing at `restitution` times the last's speed, until the
/// rest rule takes the first landing whose bounce would be slower than the rest speed (the last).
pub fn closed_form_landings(height: f64, g: f64, restitution: f64, radius: f64) -> Vec<f64> {
    let v0 = (2.0 * g * height).sqrt();
    let rest_speed = (2.0 * g * vadop::response::rest::REST_HEIGHT * radius).sqrt();
    let mut time = (2.0 * height / g).sqrt();
    let mut landings = vec![time];
    let mut speed = v0;
    while restitution * speed >= rest_speed {
        time += 2.0 * restitution * speed / g;
        speed *= restitution;
        landings.push(time);
    }
    landings
}

/// The deepest overlap at the frame end, if beyond `tolerance` times the sizes (see
/// [`deepest_overlap`]).
pub fn sunk(world: &World, tolerance: f64) -> Option<String> {
    let (depth, what) = deepest_overlap(world, Overlap::OfSize);
    (depth > tolerance).then_some(what)
}

/// What [`deepest_overlap`] measures an overlap against.
#[derive(Clone, Copy, PartialEq)]
pub enum Overlap {
    /// The bodies' sizes: their bounding radii, the smaller of a pair's.
    OfSize,
    /// The contact tolerance of the pair (`contact_tolerance`, from the sum of the bounding
    /// radii) or of the body against a wall: what the narrow phase's contract bounds.
    InTolerances,
}

/// The deepest overlap at the frame end, relative to `unit`, and what overlaps: between two
/// bodies (moving or static; moving ones only in simulate mode, where they turn back) or a
/// moving body and a wall, measured by parry on the bodies' poses, independently of vadop's
/// searches.
pub fn deepest_overlap(world: &World, unit: Overlap) -> (f64, String) {
    let bodies: Vec<(BodyHandle, Body)> = world.bodies().collect();
    let geometry = |b: &Body| match b.shape {
        BodyShape::Sphere { radius } => Shape::Sphere { radius }.geometry().unwrap(),
        BodyShape::Shape(id) => world.shape(id).unwrap().clone(),
    };
    let pose = |b: &Body| parry3d_f64::math::Pose::from_parts(b.position, b.orientation);
    let size = |b: &Body| geometry(b).bounding_radius().unwrap_or(1.0);
    let bounds = world.bounds();
    let mut deepest = (0.0, String::new());
    let mut keep = |depth: f64, what: &dyn Fn() -> String| {
        if depth > deepest.0 {
            deepest = (depth, what());
        }
    };
    for (k, (i, a)) in bodies.iter().enumerate() {
        if a.mass.is_finite() {
            // The shape's farthest points along the axes (its bounding box would be loose for a
            // turned cylinder or cone).
            let g = geometry(a);
            let support = g.parry_shape().as_support_map().expect("moving bodies are convex");
            let pose = pose(a);
            for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
                let [high, low] =
                    [axis, -axis].map(|d| pose * support.local_support_point(pose.rotation.inverse() * d));
                let depth = (bounds.min.dot(axis) - low.dot(axis)).max(high.dot(axis) - bounds.max.dot(axis));
                let scale = match unit {
                    Overlap::OfSize => size(a),
                    Overlap::InTolerances => SHAPE_CONTACT_TOLERANCE * size(a),
                };
                keep(depth / scale, &|| format!("body {i} through a wall: it spans {low}..{high}"));
            }
        }
        for (j, b) in &bodies[k + 1..] {
            // Static geometry turns bodies back in detect mode too; moving bodies pass through.
            let moving = a.mass.is_finite() && b.mass.is_finite();
            if !(a.mass.is_finite() || b.mass.is_finite()) || (moving && world.config().mode == Mode::Detect) {
                continue;
            }
            let (ga, gb) = (geometry(a), geometry(b));
            let (sa, sb) = (ga.parry_shape().as_ref(), gb.parry_shape().as_ref());
            if let Ok(Some(c)) = parry3d_f64::query::contact(&pose(a), sa, &pose(b), sb, 0.0) {
                let scale = match unit {
                    Overlap::OfSize => size(a).min(size(b)),
                    Overlap::InTolerances => contact_tolerance(&ga, &gb),
                };
                keep(-c.dist / scale, &|| format!("bodies {i} and {j} overlap by {:e}", -c.dist));
            }
        }
    }
    deepest
}
