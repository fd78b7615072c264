//! Fuzzing with a time budget: the narrow phase against exact rational arithmetic, and the World
//! API against random sequences of add, remove, set velocity, step and save/resume with
//! arbitrary values. No panic, no hang, no contact missed.
//!
//! Each target runs a fixed seed for `VADOP_FUZZ_SECONDS` seconds (default 4) or
//! `VADOP_FUZZ_CASES` cases, whichever ends first. A longer run with a fresh seed:
//!
//!     VADOP_FUZZ_SECONDS=600 VADOP_FUZZ_SEED=$RANDOM cargo test --release -p vadop --test fuzz -- --nocapture
//!
//! A failure prints the seed and the case number; rerun with that seed to reproduce it.

mod common;

use common::{contact_bits, frame_end_violation, random_direction, state_bits};
use glam::DVec3;
use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::Signed;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::{Duration, Instant};
use vadop::narrow_phase::spheres::{sphere_sphere_time, CONTACT_TOLERANCE};
use vadop::{BodyHandle, BoxBounds, Method, Mode, Sphere, VadopError, World, WorldConfig};

/// The budget: (seed, deadline, most cases).
fn budget(default_cases: u64) -> (u64, Instant, u64) {
    let var = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok());
    let seconds = var("VADOP_FUZZ_SECONDS").unwrap_or(4);
    let cases =
        var("VADOP_FUZZ_CASES").unwrap_or(if var("VADOP_FUZZ_SECONDS").is_some() { u64::MAX } else { default_cases });
    (var("VADOP_FUZZ_SEED").unwrap_or(7), Instant::now() + Duration::from_secs(seconds), cases)
}

fn power(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    10f64.powf(rng.random_range(lo..hi))
}

// ---------------------------------------------------------------------------------------------
// Narrow phase against exact arithmetic.

fn q(x: f64) -> BigRational {
    BigRational::from_float(x).expect("finite")
}

/// The exact squared centre distance d^2(t) = c + 2 b t + a t^2 of one input.
struct Exact {
    a: BigRational,
    b: BigRational,
    c: BigRational,
    radius_sq: BigRational,
}

impl Exact {
    fn new(offset: DVec3, velocity: DVec3, radius_sum: f64) -> Exact {
        let o = offset.to_array().map(q);
        let v = velocity.to_array().map(q);
        let dot = |x: &[BigRational; 3], y: &[BigRational; 3]| &x[0] * &y[0] + &x[1] * &y[1] + &x[2] * &y[2];
        let r = q(radius_sum);
        Exact { a: dot(&v, &v), b: dot(&o, &v), c: dot(&o, &o), radius_sq: &r * &r }
    }

    fn distance_sq(&self, t: &BigRational) -> BigRational {
        &self.c + BigRational::from_integer(BigInt::from(2)) * &self.b * t + &self.a * t * t
    }

    /// True when d^2 drops below `level` at some time in [0, before).
    fn reaches_below(&self, level: &BigRational, before: &BigRational) -> bool {
        let c = &self.c - level;
        if c.is_negative() {
            return before.is_positive();
        }
        if !self.b.is_negative() {
            return false;
        }
        let discriminant = &self.b * &self.b - &self.a * &c;
        if !discriminant.is_positive() {
            return false;
        }
        // First root (-b - sqrt(D)) / a < before  <=>  -b - a before < sqrt(D).
        let lhs = -&self.b - &self.a * before;
        lhs.is_negative() || &lhs * &lhs < discriminant
    }
}

/// One narrow-phase input, drawn from a mix of generic, aimed, grazing, touching, far-from-origin,
/// nearly parallel and very fast cases.
fn narrow_case(rng: &mut ChaCha8Rng) -> (DVec3, DVec3, f64, f64) {
    let radius = power(rng, -4.0, 4.0);
    let window = power(rng, -3.0, 1.0);
    let speed = radius / window * power(rng, -2.0, 3.0);
    match rng.random_range(0..6) {
        0 => (random_direction(rng) * radius * power(rng, -0.5, 3.0), random_direction(rng) * speed, radius, window),
        1 | 2 => {
            // Aimed: closest approach at distance `miss` at time `when`; grazing when miss ~ R.
            let u = random_direction(rng);
            let across = u.any_orthonormal_vector();
            let across = across * rng.random_range(-1.0f64..1.0).signum();
            let miss = match rng.random_range(0..4) {
                0 => radius * rng.random_range(0.0..1.2),
                1 => radius,
                2 => radius * (1.0 + power(rng, -16.0, -3.0)),
                _ => radius * (1.0 - power(rng, -16.0, -3.0)),
            };
            let when = window * rng.random_range(-0.5..1.5);
            (across * miss - u * speed * when, u * speed, radius, window)
        }
        3 => {
            // Touching (or a rounding away from it) at the start, approaching or not.
            let n = random_direction(rng);
            let gap = [0.0, 1e-16, -1e-16, 1e-10, -1e-10, -3e-9][rng.random_range(0..6)];
            (n * radius * (1.0 + gap), random_direction(rng) * speed, radius, window)
        }
        4 => {
            // Far from the origin: the offset is the rounded difference of two large positions.
            let base = random_direction(rng) * power(rng, 5.0, 7.0);
            let a = base + random_direction(rng) * radius * power(rng, 0.0, 2.0);
            let b = base + random_direction(rng) * radius * power(rng, 0.0, 2.0);
            (b - a, random_direction(rng) * speed, radius, window)
        }
        _ => {
            // Nearly parallel (tiny relative speed) or very fast (many diameters per window).
            let scale = if rng.random_bool(0.5) { power(rng, -14.0, -6.0) } else { power(rng, 3.0, 6.0) };
            (
                random_direction(rng) * radius * power(rng, 0.0, 3.0),
                random_direction(rng) * radius / window * scale,
                radius,
                window,
            )
        }
    }
}

/// Checks one result against exact arithmetic; returns why it is wrong.
fn check_narrow(
    offset: DVec3,
    velocity: DVec3,
    radius_sum: f64,
    window: f64,
    found: Option<f64>,
) -> Result<(), String> {
    let exact = Exact::new(offset, velocity, radius_sum);
    let eps = f64::EPSILON;
    let r2 = radius_sum * radius_sum;
    match found {
        Some(tau) => {
            if !(tau >= 0.0 && tau < window) {
                return Err(format!("time {tau} outside [0, {window})"));
            }
            // Touching at tau to the tolerance plus the rounding of the inputs' magnitudes ...
            let slack = 4.0 * CONTACT_TOLERANCE * r2
                + 16.0 * eps * (offset.length_squared() + (tau * velocity.length()).powi(2));
            let at = exact.distance_sq(&q(tau));
            let (low, high) = (&exact.radius_sq - q(slack), &exact.radius_sq + q(slack));
            if at < low || at > high {
                return Err(format!("not touching at {tau}"));
            }
            // ... and never deeper than that before it: no earlier contact was skipped.
            if exact.reaches_below(&low, &q(tau)) {
                return Err(format!("overlapped before the reported time {tau}"));
            }
        }
        None => {
            let slack = 8.0 * CONTACT_TOLERANCE * r2 + 32.0 * eps * offset.length_squared();
            let approaching = exact.b.is_negative() && &exact.b * &exact.b > q(1e-20) * &exact.c * &exact.a;
            let apart_at_start = exact.c >= q(r2) * q(1.0 - CONTACT_TOLERANCE);
            let touching_at_start = exact.c <= exact.radius_sq;
            let deep_later = exact.reaches_below(&(&exact.radius_sq - q(slack)), &q(window * (1.0 - 1e-9)));
            if approaching && apart_at_start && (touching_at_start || deep_later) {
                return Err("missed a contact".to_string());
            }
        }
    }
    Ok(())
}

#[test]
fn narrow_phase_matches_exact_arithmetic() {
    let (seed, deadline, cases) = budget(200_000);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut found = 0u64;
    let mut case = 0u64;
    while case < cases && Instant::now() < deadline {
        let (offset, velocity, radius_sum, window) = narrow_case(&mut rng);
        let result = sphere_sphere_time(offset, velocity, radius_sum).filter(|&tau| tau < window);
        found += result.is_some() as u64;
        if let Err(why) = check_narrow(offset, velocity, radius_sum, window, result) {
            panic!("seed {seed} case {case}: {why}: sphere_sphere_time({offset:?}, {velocity:?}, {radius_sum:e}, {window:e}) = {result:?}");
        }
        case += 1;
    }
    println!("narrow phase: {case} cases, {found} contacts, seed {seed}");
    assert!(case >= 100 && found >= case / 20, "too few cases ({case}) or contacts ({found})");
}

#[test]
fn narrow_phase_survives_arbitrary_values() {
    let (seed, deadline, cases) = budget(200_000);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 1);
    const SPECIAL: [f64; 12] = [
        0.0,
        -0.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        f64::MIN,
        1e-310,
        -1e-310,
        1e200,
        -1e200,
        1.0,
    ];
    let pick = |rng: &mut ChaCha8Rng| {
        if rng.random_bool(0.5) {
            SPECIAL[rng.random_range(0..SPECIAL.len())]
        } else {
            rng.random_range(-10.0..10.0)
        }
    };
    let mut case = 0u64;
    while case < cases && Instant::now() < deadline {
        let offset = DVec3::new(pick(&mut rng), pick(&mut rng), pick(&mut rng));
        let velocity = DVec3::new(pick(&mut rng), pick(&mut rng), pick(&mut rng));
        let radius_sum = pick(&mut rng);
        if let Some(tau) = sphere_sphere_time(offset, velocity, radius_sum) {
            assert!(
                tau >= 0.0 && tau.is_finite(),
                "seed {seed} case {case}: {tau} for {offset:?} {velocity:?} {radius_sum}"
            );
        }
        case += 1;
    }
}

// ---------------------------------------------------------------------------------------------
// The World API.

/// A value that is usually sensible for the world and sometimes anything at all.
fn maybe_bad(rng: &mut ChaCha8Rng, good: f64) -> f64 {
    const BAD: [f64; 11] =
        [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0, -1.0, 1e308, -1e308, 1e-310, 1e60, 1e-60];
    if rng.random_bool(0.03) {
        BAD[rng.random_range(0..BAD.len())]
    } else {
        good
    }
}

fn random_bounds(rng: &mut ChaCha8Rng) -> BoxBounds {
    let side = power(rng, -3.0, 4.0);
    let min = match rng.random_range(0..3) {
        0 => DVec3::ZERO,
        1 => DVec3::splat(1e6),
        _ => random_direction(rng) * power(rng, -3.0, 7.0),
    };
    BoxBounds::new(min, min + DVec3::new(side, side * rng.random_range(0.2..2.0), side * rng.random_range(0.2..2.0)))
        .unwrap()
}

/// A handle to try: often one the world gave out (live, or stale after a removal), else any
/// slot up to two past the last live one with a small generation (mostly ones never given out).
fn random_handle(rng: &mut ChaCha8Rng, world: &World, issued: &[BodyHandle]) -> BodyHandle {
    if !issued.is_empty() && rng.random_bool(0.6) {
        return issued[rng.random_range(0..issued.len())];
    }
    let slots = world.spheres().map(|(handle, _)| handle.index() as u64 + 1).max().unwrap_or(0) + 2;
    BodyHandle::from_bits(rng.random_range(0..slots) | rng.random_range(0..3u64) << 32)
}

#[test]
fn world_api_survives_random_operation_sequences() {
    let (seed, deadline, cases) = budget(400);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 2);
    let scratch = std::env::temp_dir().join(format!("vadop-fuzz-{}.json", std::process::id()));
    let mut case = 0u64;
    let mut contacts = 0usize;
    while case < cases && Instant::now() < deadline {
        let bounds = random_bounds(&mut rng);
        let side = (bounds.max - bounds.min).min_element();
        let config = WorldConfig {
            method: [Method::Auto, Method::Grid, Method::Vadop][rng.random_range(0..3)],
            mode: if rng.random_bool(0.5) { Mode::Simulate } else { Mode::Detect },
            pool_axes: [None, Some(3), Some(7), Some(13)][rng.random_range(0..4)],
            phi: None,
            restitution: [1.0, 1.0, 0.5, 0.0, rng.random_range(0.0..1.0)][rng.random_range(0..5)],
            ..WorldConfig::default()
        };
        let mut vadop = World::new(bounds, config).unwrap();
        let mut oracle = World::new(bounds, WorldConfig { method: Method::Brute, ..config }).unwrap();
        let fail = |what: String| -> ! { panic!("seed {seed} case {case}: {what} ({config:?}, {bounds:?})") };
        // Every handle either world gave out, so removed bodies' handles are tried again.
        let mut issued = Vec::new();
        for op in 0..60 {
            match rng.random_range(0..20) {
                0..=7 => {
                    let radius = side * power(&mut rng, -4.0, -1.3);
                    let radius = maybe_bad(&mut rng, radius);
                    let position =
                        bounds.min + (bounds.max - bounds.min) * DVec3::new(rng.random(), rng.random(), rng.random());
                    let position = DVec3::new(maybe_bad(&mut rng, position.x), position.y, position.z);
                    let velocity = random_direction(&mut rng) * side * power(&mut rng, -3.0, 2.5);
                    let velocity = DVec3::new(velocity.x, maybe_bad(&mut rng, velocity.y), velocity.z);
                    let mass = power(&mut rng, -3.0, 3.0);
                    let mass = maybe_bad(&mut rng, mass);
                    let sphere = Sphere { position, velocity, radius, mass };
                    let (a, b) = (vadop.add_sphere(sphere), oracle.add_sphere(sphere));
                    if format!("{a:?}") != format!("{b:?}") {
                        fail(format!("op {op}: add_sphere differs: {a:?} vs {b:?}"));
                    }
                    issued.extend(a.ok());
                }
                8..=9 => {
                    let handle = random_handle(&mut rng, &vadop, &issued);
                    let (a, b) = (vadop.sphere(handle), oracle.sphere(handle));
                    if format!("{a:?}") != format!("{b:?}") {
                        fail(format!("op {op}: sphere differs: {a:?} vs {b:?}"));
                    }
                    let (a, b) = (vadop.remove_sphere(handle), oracle.remove_sphere(handle));
                    if format!("{a:?}") != format!("{b:?}") {
                        fail(format!("op {op}: remove_sphere differs: {a:?} vs {b:?}"));
                    }
                }
                10..=12 => {
                    let handle = random_handle(&mut rng, &vadop, &issued);
                    let velocity = random_direction(&mut rng) * side * power(&mut rng, -3.0, 2.5);
                    let velocity = DVec3::new(maybe_bad(&mut rng, velocity.x), velocity.y, velocity.z);
                    let (a, b) = (vadop.set_velocity(handle, velocity), oracle.set_velocity(handle, velocity));
                    if format!("{a:?}") != format!("{b:?}") {
                        fail(format!("op {op}: set_velocity differs: {a:?} vs {b:?}"));
                    }
                }
                13 => {
                    vadop.save(&scratch).unwrap_or_else(|e| fail(format!("save: {e}")));
                    vadop = World::load(&scratch).unwrap_or_else(|e| fail(format!("load: {e}")));
                }
                _ => {
                    let dt = power(&mut rng, -4.0, -1.0);
                    let dt = maybe_bad(&mut rng, dt);
                    let before = vadop.kinetic_energy();
                    let started = Instant::now();
                    let a = vadop.step(dt).map(contact_bits);
                    if started.elapsed() > Duration::from_secs(5) {
                        fail(format!("op {op}: a step of {dt} took {:?}", started.elapsed()));
                    }
                    let b = oracle.step(dt).map(contact_bits);
                    if format!("{a:?}") != format!("{b:?}") {
                        fail(format!("op {op}: step({dt}) differs: {a:?} vs {b:?}"));
                    }
                    match a {
                        Ok(found) => {
                            contacts += found.len();
                            if let Some(e) = frame_end_violation(&vadop, false) {
                                fail(format!("op {op}: {e}"));
                            }
                            let after = vadop.kinetic_energy();
                            if config.mode == Mode::Simulate && after > before * (1.0 + 1e-9) {
                                fail(format!("op {op}: energy grew from {before} to {after}"));
                            }
                        }
                        // Unstick the world the way a user would: drop the offending body.
                        Err(VadopError::Overlap { b: body, .. }) | Err(VadopError::AbsurdSpeed { body, .. }) => {
                            vadop.remove_sphere(body).unwrap();
                            oracle.remove_sphere(body).unwrap();
                        }
                        Err(_) => {}
                    }
                }
            }
            if state_bits(&vadop) != state_bits(&oracle) {
                fail(format!("op {op}: states differ"));
            }
        }
        case += 1;
    }
    let _ = std::fs::remove_file(&scratch);
    println!("world API: {case} sequences, {contacts} contacts, seed {seed}");
    assert!(case >= 1 && contacts > 0, "no sequence ({case}) or no contact ({contacts}) in the budget");
}
