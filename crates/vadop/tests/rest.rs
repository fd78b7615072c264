//! Resting under gravity with restitution below 1 (the rest rule, `vadop::response::rest`): a
//! ball comes to rest on the floor after the bounces the closed form says, a pile settles in
//! bounded time with nothing sinking or floating, every method matches brute force to the bit,
//! and a saved world at rest resumes bit-exactly.

mod common;

use glam::DVec3;
use proptest::prelude::*;
use vadop::response::rest::REST_HEIGHT;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{BoxBounds, Method, Mode, Rest, Sphere, Touched, Wall, World, WorldConfig};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;
const G: f64 = 9.81;

fn config(method: Method, restitution: f64) -> WorldConfig {
    WorldConfig {
        gravity: DVec3::new(0.0, 0.0, -G),
        restitution,
        method,
        mode: Mode::Simulate,
        ..WorldConfig::default()
    }
}

fn ball(position: DVec3, velocity: DVec3) -> Sphere {
    Sphere { position, velocity, radius: 0.5, mass: 1.0 }
}

/// Dropped from 4 above the floor with restitution 1/2, the ball lands at the closed form's
/// instants, each landing at half the speed of the last, until a bounce would rise less than
/// the rest height: then it lies still on the floor, and no contact follows.
#[test]
fn a_dropped_ball_bounces_as_the_closed_form_says_then_lies_still() {
    let e = 0.5;
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto, e)).unwrap();
    let b = world.add_sphere(ball(DVec3::new(5.0, 5.0, 4.5), DVec3::ZERO)).unwrap();
    let (mut contacts, mut rests) = (Vec::new(), 0);
    for _ in 0..120 {
        contacts.extend(world.step(DT).unwrap().iter().copied());
        rests += world.stats().rest_contacts;
    }
    // Landing k comes at speed v0 e^k; the last is the first whose bounce e v0 e^k is below the
    // rest speed.
    let landings = common::closed_form_landings(4.0, G, e, 0.5);
    assert_eq!(contacts.len(), landings.len(), "{contacts:?}");
    for (k, (c, time)) in contacts.iter().zip(landings).enumerate() {
        assert_eq!(c.touched, Touched::Wall(Wall::MinZ));
        assert!((c.time - time).abs() <= 1e-9, "landing {k} at {} not {time}", c.time);
    }
    assert_eq!(world.rest(b).unwrap(), Rest::Still);
    assert_eq!(rests, 1, "only the last landing is the rest rule's");
    let s = world.sphere(b).unwrap();
    assert!((s.position.z - 0.5).abs() <= 1e-12 && s.velocity == DVec3::ZERO, "{s:?}");
    assert_eq!(world.kinetic_energy(), 0.0);
}

/// Thrown along the floor, a ball slides on it: its bounces end, its motion along the floor goes
/// on with no event while it rolls, and a side wall turns it back at half its speed.
#[test]
fn a_ball_thrown_along_the_floor_slides_and_bounces_off_the_side_walls() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto, 0.5)).unwrap();
    let b = world.add_sphere(ball(DVec3::new(5.0, 5.0, 1.5), DVec3::new(3.0, 0.0, 0.0))).unwrap();
    let mut side = Vec::new();
    let mut contacts = 0;
    for _ in 0..300 {
        let step = world.step(DT).unwrap();
        contacts += step.len();
        side.extend(
            step.iter()
                .filter(|c| c.touched == Touched::Wall(Wall::MaxX) || c.touched == Touched::Wall(Wall::MinX))
                .map(|c| c.time),
        );
    }
    assert_eq!(world.rest(b).unwrap(), Rest::Sliding(0b100));
    let s = world.sphere(b).unwrap();
    assert!((s.position.z - 0.5).abs() <= 1e-12 && s.velocity.z == 0.0, "{s:?}");
    // 4.5 to the wall at 3, 9 back at 1.5: at 1.5 and 7.5.
    assert_eq!(side.len(), 2, "{side:?}");
    assert!((side[0] - 1.5).abs() < 1e-9 && (side[1] - 7.5).abs() < 1e-9, "{side:?}");
    assert!((s.velocity.x - 0.75).abs() < 1e-12, "{s:?}");
    assert!(contacts < 20, "{contacts} contacts");
    // Slow along the floor too, it lies still once it lands.
    let slow = world.add_sphere(ball(DVec3::new(5.0, 2.0, 1.5), DVec3::new(0.02, 0.0, 0.0))).unwrap();
    for _ in 0..60 {
        world.step(DT).unwrap();
    }
    assert_eq!(world.rest(slow).unwrap(), Rest::Still);
}

/// A ball let go touching the top of one lying still comes to rest on it; one let go beside it
/// slides off it and falls to the floor.
#[test]
fn a_ball_rests_on_top_of_a_still_one_and_slides_off_its_side() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto, 0.5)).unwrap();
    let below = world.add_sphere(ball(DVec3::new(5.0, 5.0, 0.5), DVec3::ZERO)).unwrap();
    world.step(DT).unwrap();
    assert_eq!(world.rest(below).unwrap(), Rest::Still);
    let on_top = world.add_sphere(ball(DVec3::new(5.0, 5.0, 1.5 + 1e-3), DVec3::ZERO)).unwrap();
    let beside = world.add_sphere(ball(DVec3::new(5.2, 6.0, 0.55), DVec3::ZERO)).unwrap();
    for _ in 0..120 {
        world.step(DT).unwrap();
    }
    for (handle, z) in [(below, 0.5), (on_top, 1.5), (beside, 0.5)] {
        assert_eq!(world.rest(handle).unwrap(), Rest::Still, "{handle}");
        let s = world.sphere(handle).unwrap();
        assert!((s.position.z - z).abs() < 1e-6, "{handle} at {}", s.position);
    }
    let violation = common::frame_end_violation(&world, true);
    assert!(violation.is_none(), "{violation:?}");
}

/// A hard hit moves a ball lying still, and the one lying on it falls again instead of floating.
#[test]
fn a_ball_knocked_away_drops_the_one_lying_on_it() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto, 0.5)).unwrap();
    let below = world.add_sphere(ball(DVec3::new(5.0, 5.0, 0.5), DVec3::ZERO)).unwrap();
    world.step(DT).unwrap();
    let on_top = world.add_sphere(ball(DVec3::new(5.0, 5.0, 1.5 + 1e-4), DVec3::ZERO)).unwrap();
    for _ in 0..30 {
        world.step(DT).unwrap();
    }
    assert_eq!(world.rest(on_top).unwrap(), Rest::Still);
    world.add_sphere(ball(DVec3::new(2.0, 5.0, 0.5), DVec3::new(8.0, 0.0, 0.0))).unwrap();
    for _ in 0..300 {
        world.step(DT).unwrap();
    }
    let (b, t) = (world.sphere(below).unwrap(), world.sphere(on_top).unwrap());
    assert!((t.position.z - 0.5).abs() < 1e-6, "the top ball fell to the floor: {}", t.position);
    assert!(b.position.x > 5.5, "the hit one moved: {}", b.position);
}

/// A pile of balls dropped into a box settles: after a few seconds every body lies still, none
/// overlaps another or leaves the box, and the frames stay cheap. Energy (kinetic plus potential)
/// never grows in a frame by more than the hops the rest rule allows: at most `m v^2 / 2` at half
/// the rest speed per rest contact.
#[test]
fn a_pile_settles_with_nothing_sinking() {
    let scene =
        PaperScene { bodies: 400, packing_fraction: 0.2, max_speed: 1.0, radius: 0.5, seed: 3 }.build().unwrap();
    let mut world = scene.world(config(Method::Auto, 0.5)).unwrap();
    let hop = 0.5 * (2.0 * G * REST_HEIGHT * 0.5).sqrt();
    let mass = scene.spheres[0].mass;
    let mut contacts = 0;
    let mut energy = world.kinetic_energy() + world.potential_energy();
    for frame in 0..300 {
        contacts += world.step(DT).unwrap().len();
        let violation = common::frame_end_violation(&world, true);
        assert!(violation.is_none(), "frame {frame}: {violation:?}");
        let now = world.kinetic_energy() + world.potential_energy();
        let hops = world.stats().rest_contacts as f64 * 0.5 * mass * hop * hop;
        assert!(now <= energy + hops + 1e-12 * energy.abs(), "frame {frame}: energy {energy} to {now}");
        energy = now;
    }
    let moving = world.spheres().filter(|(h, _)| world.rest(*h).unwrap() != Rest::Still).count();
    assert!(moving <= 4, "{moving} bodies still move after 10 s");
    assert!(contacts < 400 * 300, "{contacts} contacts");
    let top = world.spheres().map(|(_, s)| s.position.z).fold(0.0, f64::max);
    assert!(top < 0.6 * scene.bounds.max.z, "settled below {top}");
}

/// A ball lies still on another: when the caller moves the one below, or removes it, the one on
/// top falls at the next step instead of floating, for every method (and after a save and load
/// in between).
#[test]
fn a_ball_lying_on_one_the_caller_moves_or_removes_falls() {
    for method in [Method::Auto, Method::Vadop, Method::Brute] {
        for removed in [false, true] {
            for saved in [false, true] {
                let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(method, 0.5)).unwrap();
                let below = world.add_sphere(ball(DVec3::new(5.0, 5.0, 0.5), DVec3::ZERO)).unwrap();
                world.step(DT).unwrap();
                let on_top = world.add_sphere(ball(DVec3::new(5.0, 5.0, 1.5 + 1e-4), DVec3::ZERO)).unwrap();
                for _ in 0..30 {
                    world.step(DT).unwrap();
                }
                assert_eq!([world.rest(below).unwrap(), world.rest(on_top).unwrap()], [Rest::Still; 2]);
                if removed {
                    world.remove_sphere(below).unwrap();
                } else {
                    world.set_velocity(below, DVec3::new(3.0, 0.0, 0.0)).unwrap();
                }
                if saved {
                    let path = std::env::temp_dir().join(format!("vadop-release-{}.json", std::process::id()));
                    world.save(&path).unwrap();
                    world = World::load(&path).unwrap();
                    std::fs::remove_file(&path).ok();
                }
                world.step(DT).unwrap();
                assert_ne!(world.rest(on_top).unwrap(), Rest::Still, "{method:?}, removed {removed}, saved {saved}");
                for _ in 0..60 {
                    world.step(DT).unwrap();
                }
                let z = world.sphere(on_top).unwrap().position.z;
                assert!(
                    (z - 0.5).abs() < 1e-9,
                    "{method:?}, removed {removed}: the top ball fell to the floor, at {z}"
                );
            }
        }
    }
}

/// The discrete method bounces bodies off walls exactly between frame instants: a dropped ball
/// comes to rest on the floor there too, after as many bounces as the closed form says, rather
/// than bouncing without end.
#[test]
fn the_discrete_method_lets_a_dropped_ball_lie_still_on_the_floor() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Discrete, 0.5)).unwrap();
    let b = world.add_sphere(ball(DVec3::new(5.0, 5.0, 4.5), DVec3::ZERO)).unwrap();
    let mut contacts = 0;
    for _ in 0..120 {
        contacts += world.step(DT).unwrap().len();
    }
    let v0 = (2.0 * G * 4.0f64).sqrt();
    let rest_speed = (2.0 * G * REST_HEIGHT * 0.5).sqrt();
    let landings = (0..).find(|&k| 0.5 * v0 * 0.5f64.powi(k) < rest_speed).unwrap() + 1;
    assert_eq!(contacts, landings as usize);
    assert_eq!(world.rest(b).unwrap(), Rest::Still);
    assert_eq!(world.sphere(b).unwrap().position.z, 0.5);
}

/// Under gravity tilted towards a corner of the floor, a ball lands, slides along the floor into
/// a side wall, along that into the corner, and lies still there.
#[test]
fn under_tilted_gravity_a_ball_slides_into_the_corner_and_lies_still() {
    let gravity = DVec3::new(-1.0, -2.0, -10.0);
    let config = WorldConfig { gravity, ..config(Method::Auto, 0.5) };
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config).unwrap();
    let b = world.add_sphere(ball(DVec3::new(5.0, 5.0, 2.0), DVec3::ZERO)).unwrap();
    let mut seen = Vec::new();
    for _ in 0..600 {
        world.step(DT).unwrap();
        let rest = world.rest(b).unwrap();
        if seen.last() != Some(&rest) {
            seen.push(rest);
        }
    }
    assert_eq!(seen.last(), Some(&Rest::Still), "{seen:?}");
    assert!(seen.contains(&Rest::Sliding(0b100)) || seen.contains(&Rest::Sliding(0b110)), "{seen:?}");
    let s = world.sphere(b).unwrap();
    assert_eq!(s.position, DVec3::splat(0.5), "in the corner");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Every continuous method, on one thread or two, reports the oracle's contacts to the bit
    /// while bodies come to rest, slide and are knocked off again, under gravity tilted up to
    /// about 17 degrees, with or without friction, for equal spheres or mixed sizes, in a box or
    /// a slab periodic in x and y, over frames of 1/240 to 2/15 s; and in the oracle nothing
    /// sinks or leaves the box.
    #[test]
    fn every_method_matches_brute_force_while_bodies_rest(
        bodies in 2usize..150,
        packing_fraction in 0.05f64..0.3,
        max_speed in 0.05f64..2.0,
        restitution in 0.0f64..0.95,
        tilt in (-0.3f64..0.3, -0.3f64..0.3),
        friction in prop_oneof![Just(0.0), 0.0f64..0.5],
        mixed in any::<bool>(),
        periodic in any::<bool>(),
        frames_per_second in prop_oneof![Just(30.0), Just(240.0), Just(7.5)],
        threads in 1usize..3,
        method in prop_oneof![Just(Method::Auto), Just(Method::Vadop), Just(Method::Grid), Just(Method::SweptAabb), Just(Method::SweptKdop)],
        seed in any::<u64>(),
    ) {
        let scene = PaperScene { bodies, packing_fraction, max_speed, radius: 0.5, seed }.build();
        prop_assume!(scene.is_ok());
        let mut scene = scene.unwrap();
        if mixed {
            // Radii from a quarter to a half, masses as the volume: nothing comes to overlap.
            for (k, s) in scene.spheres.iter_mut().enumerate() {
                let f = 0.5 + 0.5 * ((k as u64 ^ seed).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11) as f64 / (1u64 << 53) as f64;
                (s.radius, s.mass) = (s.radius * f, s.mass * f * f * f);
            }
        }
        // A periodic side holds at least 8 diameters.
        let periodic = periodic && scene.bounds.max.x - scene.bounds.min.x >= 8.0;
        scene.bounds = scene.bounds.with_periodic([periodic, periodic, false]);
        let gravity = DVec3::new(tilt.0, tilt.1, -1.0).normalize() * G;
        let config = |method, threads| WorldConfig { restitution, friction, gravity, threads: Some(threads), ..config(method, restitution) };
        let mut found = scene.world(config(method, threads)).unwrap();
        let mut oracle = scene.world(config(Method::Brute, 1)).unwrap();
        // A second and a half.
        let frames = (1.5 * frames_per_second) as usize;
        let refused = common::step_beside_oracle(&mut found, &mut oracle, frames, 1.0 / frames_per_second, |frame, oracle| {
            let violation = common::periodic_violation(oracle);
            assert!(violation.is_none(), "frame {frame}: {violation:?}");
        });
        prop_assert!(refused.is_none(), "{refused:?}");
    }
}

/// A world saved while bodies rest and slide resumes to the same bits as one stepped on.
#[test]
fn a_world_at_rest_resumes_bit_exactly() {
    let scene =
        PaperScene { bodies: 120, packing_fraction: 0.2, max_speed: 1.0, radius: 0.5, seed: 5 }.build().unwrap();
    let mut world = scene.world(config(Method::Auto, 0.4)).unwrap();
    for _ in 0..60 {
        world.step(DT).unwrap();
    }
    assert!(world.spheres().any(|(h, _)| world.rest(h).unwrap() == Rest::Still));
    common::assert_resumes_bit_exactly(&mut world, "rest", 60, DT);
}

/// The quartic's pairs against straight-line brute force: a resting body and a falling one meet
/// where an independent fine sampling of their paths says.
#[test]
fn a_ball_falling_onto_a_still_one_lands_where_the_paths_cross() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Vadop, 0.5)).unwrap();
    let below = world.add_sphere(ball(DVec3::new(5.0, 5.0, 0.5), DVec3::ZERO)).unwrap();
    world.step(DT).unwrap();
    let thrown = DVec3::new(-1.0, 0.3, 2.0);
    let start = DVec3::new(6.0, 4.8, 2.0);
    let t0 = world.time();
    let falling = world.add_sphere(ball(start, thrown)).unwrap();
    let mut first = None;
    for _ in 0..60 {
        for c in world.step(DT).unwrap() {
            if first.is_none() && c.touched == Touched::Body(falling)
                || c.body == falling && c.touched == Touched::Body(below)
            {
                first.get_or_insert(c.time);
            }
        }
    }
    let first = first.expect("lands on it");
    let centre = DVec3::new(5.0, 5.0, 0.5);
    let path = |t: f64| start + (t - t0) * thrown + 0.5 * (t - t0) * (t - t0) * DVec3::new(0.0, 0.0, -G);
    let sampled = (0..2_000_000).map(|k| t0 + 2.0 * k as f64 / 2e6).find(|&t| path(t).distance(centre) <= 1.0).unwrap();
    assert!((first - sampled).abs() < 2e-6, "{first} vs {sampled}");
}
