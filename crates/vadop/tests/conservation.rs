//! Long simulate-mode runs with restitution 1: kinetic energy is conserved to 1e-9 relative over
//! the whole run, momentum in every collision, no body leaves the box, and no pair of bodies ends
//! a frame overlapping beyond the contact tolerance.

use vadop::narrow_phase::spheres::CONTACT_TOLERANCE;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{Method, Mode, Touched, World, WorldConfig};

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
