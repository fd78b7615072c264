//! Long simulate-mode runs with restitution 1: kinetic energy is conserved to 1e-9 relative over
//! the whole run, momentum in every collision, no body leaves the box, and no pair of bodies ends
//! a frame overlapping beyond the contact tolerance.

use glam::DVec3;
use vadop::narrow_phase::spheres::CONTACT_TOLERANCE;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{BoxBounds, Method, Mode, Sphere, Touched, World, WorldConfig};

fn check_frame_end(world: &World) {
    let bounds = world.bounds();
    let spheres: Vec<_> = world.spheres().map(|(_, s)| s).collect();
    for s in &spheres {
        let slack = 1e-9 * s.radius;
        assert!((s.position - s.radius).cmpge(bounds.min - slack).all(), "escaped below: {s:?}");
        assert!((s.position + s.radius).cmple(bounds.max + slack).all(), "escaped above: {s:?}");
    }
    // A sparse all-pairs check: these runs are small.
    for (i, a) in spheres.iter().enumerate() {
        for b in &spheres[i + 1..] {
            let reach = a.radius + b.radius;
            assert!(a.position.distance(b.position) >= reach * (1.0 - 2.0 * CONTACT_TOLERANCE), "overlap at frame end");
        }
    }
}

#[test]
fn energy_and_momentum_over_a_long_run() {
    let scene =
        PaperScene { bodies: 400, packing_fraction: 0.2, max_speed: 2.0, radius: 0.5, seed: 11 }.build().unwrap();
    let mut world =
        scene.world(WorldConfig { method: Method::Vadop, mode: Mode::Simulate, ..WorldConfig::default() }).unwrap();
    let energy = world.kinetic_energy();
    let mut pair_contacts = 0;
    for _ in 0..300 {
        let before: Vec<_> = world.spheres().map(|(_, s)| s).collect();
        let contacts = world.step(1.0 / FRAMES_PER_SECOND).unwrap().to_vec();
        // Momentum: every pair impulse is equal and opposite, so only wall impulses change the
        // total; check the change equals the sum of wall impulses.
        let after: Vec<_> = world.spheres().map(|(_, s)| s).collect();
        let change: glam::DVec3 = before.iter().zip(&after).map(|(b, a)| a.mass * (a.velocity - b.velocity)).sum();
        let wall: glam::DVec3 =
            contacts.iter().filter(|c| matches!(c.touched, Touched::Wall(_))).map(|c| -c.impulse * c.normal).sum();
        let scale = before.iter().map(|s| s.mass * s.velocity.length()).sum::<f64>();
        assert!((change - wall).length() <= 1e-10 * scale, "momentum not conserved in pair impacts");
        pair_contacts += contacts.iter().filter(|c| matches!(c.touched, Touched::Body(_))).count();
        check_frame_end(&world);
    }
    let drift = (world.kinetic_energy() - energy).abs() / energy;
    assert!(drift <= 1e-9, "relative energy drift {drift:e}");
    assert!(pair_contacts > 10_000, "the run must collide a lot, got {pair_contacts}");
}

#[test]
fn inelastic_runs_lose_energy_but_never_overlap() {
    let scene =
        PaperScene { bodies: 200, packing_fraction: 0.1, max_speed: 1.0, radius: 0.5, seed: 5 }.build().unwrap();
    let config = WorldConfig { restitution: 0.9, ..WorldConfig::default() };
    let mut world = scene.world(config).unwrap();
    let energy = world.kinetic_energy();
    for _ in 0..60 {
        world.step(1.0 / FRAMES_PER_SECOND).unwrap();
        check_frame_end(&world);
    }
    assert!(world.kinetic_energy() < energy);
}

/// Two equal spheres meeting head on at separation 1: the one struck gains the striker's
/// momentum of 30 along the line of centres, so the virial is 1 x 30; the wall bounce after it
/// is not a pair's and adds nothing.
#[test]
fn a_head_on_impact_has_the_virial_of_separation_times_momentum_exchanged() {
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    let ball = |x: f64, vx: f64| Sphere {
        position: DVec3::new(x, 5.0, 5.0),
        velocity: DVec3::new(vx, 0.0, 0.0),
        radius: 0.5,
        mass: 1.0,
    };
    world.add_sphere(ball(2.0, 30.0)).unwrap();
    world.add_sphere(ball(8.0, 0.0)).unwrap();
    let contacts = world.step(0.25).unwrap().to_vec();
    assert_eq!(contacts.len(), 2, "the pair's impact, then the struck ball's bounce: {contacts:?}");
    assert!((world.stats().pair_virial - 30.0).abs() < 1e-12, "virial {}", world.stats().pair_virial);
    let mut detect =
        World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig { mode: Mode::Detect, ..WorldConfig::default() })
            .unwrap();
    detect.add_sphere(ball(2.0, 30.0)).unwrap();
    detect.add_sphere(ball(8.0, 0.0)).unwrap();
    detect.step(0.25).unwrap();
    assert_eq!(detect.stats().pair_virial, 0.0, "bodies passing through each other exchange nothing");
}

/// The virial identity, exact for free flight between impulses: over a run, the change of
/// G = sum r . p equals 2 K T (each body's r . p grows at m v^2 while it flies) plus every
/// impact's r . (momentum gained): the pairs' is the frame's `pair_virial`, the walls' is read
/// from the contacts. An elastic run keeps K, so a wrong or missing virial term breaks it.
#[test]
fn the_pair_virial_closes_the_virial_identity() {
    let scene =
        PaperScene { bodies: 300, packing_fraction: 0.25, max_speed: 2.0, radius: 0.5, seed: 3 }.build().unwrap();
    for method in [Method::Auto, Method::Grid, Method::Discrete] {
        let mut world = scene.world(WorldConfig { method, ..WorldConfig::default() }).unwrap();
        let virial_sum = |world: &World| world.spheres().map(|(_, s)| s.position.dot(s.mass * s.velocity)).sum::<f64>();
        let (start, kinetic) = (virial_sum(&world), world.translational_kinetic_energy());
        let (mut pairs, mut walls, mut flight, mut impacts) = (0.0, 0.0, 0.0, 0);
        let dt = 1.0 / FRAMES_PER_SECOND;
        for _ in 0..90 {
            let contacts = world.step(dt).unwrap().to_vec();
            pairs += world.stats().pair_virial;
            impacts += world.stats().pair_contacts;
            for c in contacts.iter().filter(|c| matches!(c.touched, Touched::Wall(_))) {
                let centre = world.sphere(c.body).map(|s| c.point - s.radius * c.normal).unwrap();
                walls += centre.dot(-c.impulse * c.normal);
            }
            flight += 2.0 * world.translational_kinetic_energy() * dt;
        }
        assert!(impacts > 1000, "{method:?}: the run must collide a lot, got {impacts}");
        assert!(pairs > 0.0, "{method:?}: impacts push apart, so their virial is positive");
        let change = virial_sum(&world) - start;
        let residue = change - (flight + pairs + walls);
        assert!(
            residue.abs() <= 1e-9 * (flight + pairs.abs() + walls.abs()),
            "{method:?}: residue {residue:e} of {change:e}"
        );
        assert!((world.translational_kinetic_energy() - kinetic).abs() <= 1e-9 * kinetic);
    }
}
