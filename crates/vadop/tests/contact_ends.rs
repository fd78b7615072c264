//! Contact ends (detect mode): every continuous method reports when contacts end exactly as the
//! brute-force oracle does, each end is where the two bodies part, starts and ends alternate per
//! pair, the touching pairs survive a save and resume, and removed bodies leave no end behind.

use glam::DVec3;
use proptest::prelude::*;
use std::collections::BTreeMap;
use vadop::scene::{PaperScene, Scene, FRAMES_PER_SECOND};
use vadop::{BodyHandle, BoxBounds, Contact, Method, Mode, Sphere, Touched, VadopError, World, WorldConfig};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;

fn config(method: Method) -> WorldConfig {
    WorldConfig { method, mode: Mode::Detect, contact_ends: true, ..WorldConfig::default() }
}

fn paper(bodies: usize, max_speed: f64, seed: u64) -> Scene {
    PaperScene { bodies, packing_fraction: 0.1, max_speed, radius: 0.5, seed }.build().unwrap()
}

/// A ball of diameter 1 on the line y = z = 5 at `x`, moving along x at `vx`.
fn ball(x: f64, vx: f64) -> Sphere {
    Sphere { position: DVec3::new(x, 5.0, 5.0), velocity: DVec3::new(vx, 0.0, 0.0), radius: 0.5, mass: 1.0 }
}

fn pair(c: &Contact) -> Option<(BodyHandle, BodyHandle)> {
    match c.touched {
        Touched::Body(other) => Some((c.body, other)),
        Touched::Wall(_) => None,
    }
}

/// Steps `world` for `frames` frames and checks, from the bodies' own states, that every pair's
/// starts and ends alternate, that an end is where the two centres are the sum of the radii apart
/// and moving apart, and that `touching` lists exactly the pairs started and not ended. Returns
/// every frame's (starts, ends).
fn run_checked(world: &mut World, frames: usize) -> Vec<(Vec<Contact>, Vec<Contact>)> {
    let mut open: BTreeMap<(BodyHandle, BodyHandle), f64> = BTreeMap::new();
    let mut out = Vec::new();
    for frame in 0..frames {
        let before: BTreeMap<BodyHandle, Sphere> = world.spheres().collect();
        let t0 = world.time();
        let starts = world.step(DT).unwrap().to_vec();
        let ends = world.contact_ends().to_vec();
        // Merge in time order, starts first at one instant (the engine's order).
        let mut events: Vec<(f64, bool, (BodyHandle, BodyHandle))> = starts
            .iter()
            .filter_map(|c| pair(c).map(|p| (c.time, false, p)))
            .chain(ends.iter().map(|c| (c.time, true, pair(c).expect("ends are between bodies"))))
            .collect();
        events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        for (time, ended, p) in events {
            assert!(t0 <= time && time < world.time(), "frame {frame}: event at {time} outside the frame");
            if ended {
                let started = open.remove(&p);
                assert!(started.is_some_and(|s| s <= time), "frame {frame}: {p:?} ended at {time} without a start");
            } else {
                assert!(open.insert(p, time).is_none(), "frame {frame}: {p:?} started twice without ending");
            }
        }
        for end in &ends {
            let (a, b) = pair(end).unwrap();
            // Judged from the frame's start when neither body bounced in the frame (it ends where
            // its start and velocity take it: a bounce, or two, would have moved it elsewhere), so
            // both moved straight up to the end.
            let (sa, sb) = (before[&a], before[&b]);
            let straight = |h: BodyHandle, s: &Sphere| {
                let now = world.sphere(h).unwrap();
                let moved = s.position + DT * s.velocity;
                now.velocity == s.velocity && (now.position - moved).length() <= 1e-9 * (1.0 + moved.length())
            };
            if straight(a, &sa) && straight(b, &sb) {
                let tau = end.time - t0;
                let offset = (sb.position + tau * sb.velocity) - (sa.position + tau * sa.velocity);
                let reach = sa.radius + sb.radius;
                let slack = 1e-9 * reach + 1e-12 * sa.position.abs().max(sb.position.abs()).max_element();
                assert!(
                    (offset.length() - reach).abs() <= slack,
                    "frame {frame}: {a} and {b} end {} apart, not {reach}",
                    offset.length()
                );
                assert!(offset.dot(sb.velocity - sa.velocity) >= 0.0, "frame {frame}: {a} and {b} end approaching");
            }
        }
        let touching: Vec<_> = open.keys().copied().collect();
        assert_eq!(world.touching(), touching, "frame {frame}: touching pairs");
        out.push((starts, ends));
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Starts and ends of every continuous method are bit-identical to brute force's, and
    /// consistent with the bodies' motion.
    #[test]
    fn every_method_reports_the_oracles_ends(
        bodies in 2usize..300,
        max_speed in prop_oneof![Just(0.05), Just(0.5), Just(3.0), 0.01f64..10.0],
        seed in 0u64..1000,
        method in prop_oneof![Just(Method::Auto), Just(Method::Vadop), Just(Method::Grid), Just(Method::SweptAabb), Just(Method::SweptKdop)],
    ) {
        let scene = paper(bodies, max_speed, seed);
        let mut world = scene.world(config(method)).unwrap();
        let mut oracle = scene.world(config(Method::Brute)).unwrap();
        let found = run_checked(&mut world, 20);
        let expected = run_checked(&mut oracle, 20);
        prop_assert_eq!(found, expected);
    }
}

#[test]
fn a_head_on_pair_starts_and_ends_at_the_exact_times() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto)).unwrap();
    let (a, b) = (world.add_sphere(ball(2.0, 1.5)).unwrap(), world.add_sphere(ball(8.0, -1.5)).unwrap());
    let starts = world.step(2.0).unwrap().to_vec();
    assert_eq!((starts[0].time, starts[0].body, starts[0].touched), (5.0 / 3.0, a, Touched::Body(b)));
    assert_eq!(world.touching(), [(a, b)]);
    world.step(1.0).unwrap();
    let end = world.contact_ends()[0];
    assert_eq!((end.time, end.body, end.touched, end.impulse), (7.0 / 3.0, a, Touched::Body(b), 0.0));
    assert_eq!(end.normal, DVec3::new(-1.0, 0.0, 0.0), "a is now past b: the normal from a to b points back");
    assert_eq!(world.stats().contact_ends, 1);
    assert!(world.touching().is_empty());
    assert_eq!(world.touching_in_frame(), [(a, b)]);
}

#[test]
fn a_touching_body_that_bounces_off_a_wall_ends_its_contact_from_its_new_path() {
    // a runs into b, which rests near the wall; while they overlap, a bounces off the wall and
    // comes back out of b the way it came: the end is re-predicted from a's new path.
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto)).unwrap();
    let (a, b) = (world.add_sphere(ball(6.0, 2.0)).unwrap(), world.add_sphere(ball(9.0, 0.0)).unwrap());
    // a is 1 from b at x = 8 (t = 1), at the wall at x = 9.5 (t = 1.75), and 1 from b again at
    // x = 8 on the way back (t = 2.5). Without the bounce it would have parted at x = 10, t = 2.
    let starts: Vec<_> = world.step(2.0).unwrap().iter().map(|c| (c.time, c.touched)).collect();
    assert_eq!(starts, [(1.0, Touched::Body(b)), (1.75, Touched::Wall(vadop::Wall::MaxX))]);
    assert_eq!(world.touching(), [(a, b)]);
    world.step(1.0).unwrap();
    assert_eq!(world.contact_ends().iter().map(|c| (c.time, pair(c))).collect::<Vec<_>>(), [(2.5, Some((a, b)))]);
}

#[test]
fn touching_pairs_survive_a_save_and_resume_bit_exactly() {
    let scene = paper(400, 1.0, 7);
    let mut straight = scene.world(config(Method::Auto)).unwrap();
    let mut saved = scene.world(config(Method::Auto)).unwrap();
    let path = std::env::temp_dir().join(format!("vadop-contact-ends-{}.json", std::process::id()));
    for _ in 0..10 {
        straight.step(DT).unwrap();
        saved.step(DT).unwrap();
    }
    assert!(!saved.touching().is_empty(), "the test needs pairs in contact at the save");
    saved.save(&path).unwrap();
    let mut resumed = World::load(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(resumed.touching(), straight.touching());
    for frame in 0..10 {
        let expected = straight.step(DT).unwrap().to_vec();
        assert_eq!(resumed.step(DT).unwrap(), expected, "frame {frame}: starts");
        assert_eq!(resumed.contact_ends(), straight.contact_ends(), "frame {frame}: ends");
    }
}

#[test]
fn a_removed_body_leaves_no_end_and_no_touching_pair() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto)).unwrap();
    let (a, b) = (world.add_sphere(ball(2.0, 1.5)).unwrap(), world.add_sphere(ball(8.0, -1.5)).unwrap());
    world.step(2.0).unwrap();
    assert_eq!(world.touching(), [(a, b)]);
    world.remove_sphere(b).unwrap();
    assert!(world.touching().is_empty());
    // A new body in b's slot, far away: nothing of b's contact ends.
    let c = world.add_sphere(ball(8.0, 0.0)).unwrap();
    assert_eq!(c.index(), b.index());
    world.step(0.5).unwrap();
    assert!(world.contact_ends().is_empty());
}

#[test]
fn the_discrete_method_ends_a_contact_when_the_overlap_is_gone() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Discrete)).unwrap();
    let (a, b) = (world.add_sphere(ball(2.0, 1.5)).unwrap(), world.add_sphere(ball(8.0, -1.5)).unwrap());
    // Overlapping at t = 2 (centres 0 apart), apart at t = 3.
    assert_eq!(world.step(2.0).unwrap().iter().filter_map(pair).collect::<Vec<_>>(), [(a, b)]);
    assert_eq!(world.touching(), [(a, b)]);
    world.step(1.0).unwrap();
    assert_eq!(world.contact_ends().iter().map(|c| (c.time, pair(c))).collect::<Vec<_>>(), [(3.0, Some((a, b)))]);
    assert!(world.touching().is_empty());
}

#[test]
fn contact_ends_are_refused_in_simulate_mode() {
    let config = WorldConfig { mode: Mode::Simulate, contact_ends: true, ..WorldConfig::default() };
    assert_eq!(World::new(BoxBounds::cube(1.0).unwrap(), config).err(), Some(VadopError::ContactEndsNeedDetectMode));
}

#[test]
fn without_contact_ends_nothing_is_kept() {
    let scene = paper(300, 2.0, 3);
    let mut world = scene.world(WorldConfig { mode: Mode::Detect, ..WorldConfig::default() }).unwrap();
    let mut with_ends = scene.world(config(Method::Auto)).unwrap();
    for _ in 0..10 {
        // The starts do not depend on whether ends are reported.
        assert_eq!(world.step(DT).unwrap().to_vec(), with_ends.step(DT).unwrap());
        assert!(world.contact_ends().is_empty() && world.touching().is_empty());
    }
}
