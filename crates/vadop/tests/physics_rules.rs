//! The physics is exact where it is finite and changed only where it would never end, each change
//! counted: elastic runs keep their energy however many contacts they take (extreme mass ratios,
//! absurd speeds), inelastic piles end every frame through the TC model and the jam rule, the
//! results do not depend on how a run is cut into frames, and a scene scaled by a power of two
//! gives the same contacts to the bit, at both ends of the supported range.

mod common;

use common::contact_bits;
use glam::DVec3;
use std::time::{Duration, Instant};
use vadop::scene::{PaperScene, Scene};
use vadop::{BoxBounds, Contact, Method, Mode, Sphere, Touched, VadopError, WorldConfig};

fn lattice(k: usize, box_side: f64, velocity: DVec3) -> Scene {
    let spheres = (0..k * k * k)
        .map(|n| {
            let cell = DVec3::new((n % k) as f64, ((n / k) % k) as f64, (n / (k * k)) as f64);
            Sphere { position: DVec3::ONE + 2.0 * cell, velocity, radius: 1.0, mass: 1.0 }
        })
        .collect();
    Scene::new(BoxBounds::cube(box_side).unwrap(), spheres)
}

/// A body of mass 1e6 pushes one of mass 1 against a wall: pi * sqrt(1e6) = 3141 contacts, about
/// half of them between the two bodies, turn the heavy one back; nothing is lost.
#[test]
fn an_elastic_mass_ratio_of_a_million_keeps_its_energy() {
    let spheres = vec![
        Sphere { position: DVec3::new(3.0, 5.0, 5.0), velocity: DVec3::new(-1.0, 0.0, 0.0), radius: 1.0, mass: 1e6 },
        Sphere { position: DVec3::new(1.5, 5.0, 5.0), velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 },
    ];
    let scene = Scene::new(BoxBounds::cube(10.0).unwrap(), spheres);
    for method in [Method::Auto, Method::Vadop, Method::Brute] {
        let mut world = scene.world(WorldConfig { method, ..WorldConfig::default() }).unwrap();
        let heavy = world.spheres().next().unwrap().0;
        let energy = world.kinetic_energy();
        let (mut pairs, mut changed) = (0, 0);
        for _ in 0..300 {
            pairs += world.step(1.0 / 30.0).unwrap().iter().filter(|c| matches!(c.touched, Touched::Body(_))).count();
            changed += world.stats().jam_contacts + world.stats().tc_contacts;
            if pairs == 1570 {
                // Turned back at last: the heavy body now moves away from the wall.
                assert!(world.sphere(heavy).unwrap().velocity.x > 0.0);
            }
        }
        let drift = (world.kinetic_energy() - energy).abs() / energy;
        assert!(drift < 1e-9, "{method:?}: energy drifted by {drift:e}");
        assert_eq!(changed, 0, "{method:?}: no rule may change an elastic run like this");
        // About 1571 to turn it back, and as many again when it returns from the far wall.
        assert!(pairs >= 1570, "{method:?}: only {pairs} contacts");
    }
}

/// 100 bodies at up to 10^4 diameters per frame bounce about 10^5 times per frame: every contact
/// is processed and the energy stays.
#[test]
fn an_elastic_gas_at_absurd_speed_keeps_its_energy() {
    let scene = PaperScene::new(100, 0.05, 1e4).build().unwrap();
    let mut world = scene.world(WorldConfig::default()).unwrap();
    let energy = world.kinetic_energy();
    let contacts = world.step(1.0 / 30.0).unwrap().len();
    assert!(contacts > 100_000, "{contacts}");
    assert_eq!(world.stats().jam_contacts, 0);
    let drift = (world.kinetic_energy() - energy).abs() / energy;
    assert!(drift < 1e-9, "energy drifted by {drift:e}");
}

/// A lattice of touching unit spheres driven into a corner with restitution 0: jammed against the
/// walls when it fills the box, free to spread back when it does not. Every frame ends quickly,
/// energy never grows, and the jam rule is used and counted where the pile is wedged.
#[test]
fn inelastic_piles_driven_into_a_corner_end_every_frame() {
    for (k, side, wedged) in [(10, 20.0, true), (10, 40.0, false), (22, 44.0, true), (22, 88.0, false)] {
        let scene = lattice(k, side, DVec3::splat(-1.0));
        for method in [Method::Auto, Method::Vadop] {
            let config = WorldConfig { method, restitution: 0.0, ..WorldConfig::default() };
            let mut world = scene.world(config).unwrap();
            let mut energy = world.kinetic_energy();
            let mut jams = 0;
            let started = Instant::now();
            for _ in 0..10 {
                world.step(1.0 / 30.0).unwrap();
                jams += world.stats().jam_contacts;
                assert!(world.kinetic_energy() <= energy * (1.0 + 1e-12), "{method:?} {k}^3 in {side}: energy grew");
                energy = world.kinetic_energy();
            }
            // A hang guard, not a benchmark: these take milliseconds.
            assert!(started.elapsed() < Duration::from_secs(60), "{method:?} {k}^3 in {side}: {:?}", started.elapsed());
            if wedged {
                assert!(jams > 0, "{method:?} {k}^3 in {side}: a wedged pile must jam");
                assert!(energy < 1e-9, "{method:?} {k}^3 in {side}: a wedged pile with restitution 0 comes to rest");
            }
        }
    }
}

/// Mixed shapes driven into a corner with restitution 0 and friction 0.3, kicked towards it every
/// frame: a pile of bodies resting and sliding on each other while they turn. Such contacts
/// could not decide for 200 000 evaluations each before the jam rule took them, and frames took
/// a minute (64 bodies) or never ended (216). Every frame now ends promptly (a hang guard, not a
/// benchmark: about a second a frame), energy never grows past the kicks, and jams are counted.
#[test]
fn inelastic_piles_of_shapes_driven_into_a_corner_end_every_frame() {
    let scene = vadop::scene::ShapesScene::new(64, 0.1, 0.5).build().unwrap();
    let config = WorldConfig { restitution: 0.0, friction: 0.3, threads: Some(1), ..WorldConfig::default() };
    let mut world = scene.world(config).unwrap();
    let corner = scene.bounds.min;
    let (mut jams, mut contacts) = (0, 0);
    for frame in 0..24 {
        let (handles, bodies): (Vec<_>, Vec<_>) = world.bodies().unzip();
        let kicked: Vec<DVec3> =
            bodies.iter().map(|b| b.velocity + (corner - b.position).normalize_or_zero() * 0.5).collect();
        let spins: Vec<DVec3> = bodies.iter().map(|b| b.angular_velocity).collect();
        world.set_motions(&handles, &kicked, &spins).unwrap();
        let energy = world.kinetic_energy();
        let started = Instant::now();
        contacts += world.step(1.0 / 30.0).unwrap().len();
        let took = started.elapsed();
        assert!(took < Duration::from_secs(30), "frame {frame} took {took:?}");
        assert!(world.kinetic_energy() <= energy * (1.0 + 1e-9), "frame {frame}: energy grew");
        jams += world.stats().jam_contacts;
    }
    assert!(contacts > 1000 && jams > 0, "{contacts} contacts, {jams} jams: the pile must form");
}

/// The TC model: an inelastic column closing on itself away from any wall collides ever faster;
/// contacts within the contact duration of a body's previous one are elastic, so the column
/// spreads again instead of collapsing, and the frames end.
#[test]
fn the_tc_model_ends_inelastic_collapse_and_is_counted() {
    let spheres: Vec<Sphere> = (0..20)
        .map(|k| {
            let velocity = DVec3::new(if k < 10 { 3.0 } else { -3.0 }, 0.0, 0.0);
            Sphere {
                position: DVec3::new(80.0 + 2.0 * k as f64 + 0.01 * k as f64, 100.0, 100.0),
                velocity,
                radius: 1.0,
                mass: 1.0,
            }
        })
        .collect();
    let scene = Scene::new(BoxBounds::cube(200.0).unwrap(), spheres);
    let config = WorldConfig { restitution: 0.2, contact_duration: 1e-3, ..WorldConfig::default() };
    let mut world = scene.world(config).unwrap();
    let momentum = world.momentum();
    let mut tc = 0;
    for _ in 0..30 {
        world.step(1.0 / 30.0).unwrap();
        tc += world.stats().tc_contacts;
    }
    assert!(tc > 0, "the TC model must have been used");
    assert!((world.momentum() - momentum).length() < 1e-9);
    // Without it (t_c = 0) the same column is plain inelastic and never uses the model.
    let mut plain = scene.world(WorldConfig { contact_duration: 0.0, ..config }).unwrap();
    for _ in 0..30 {
        plain.step(1.0 / 30.0).unwrap();
        assert_eq!(plain.stats().tc_contacts, 0);
    }
}

/// Contacts do not depend on how a run is cut into frames: 30 frames of 1/30 s and 90 of 1/90 s
/// give the same contacts in the same order, to the bit, for every method and mode.
#[test]
fn frames_of_any_length_give_the_same_contacts() {
    let scene =
        PaperScene { bodies: 200, packing_fraction: 0.2, max_speed: 2.0, radius: 0.5, seed: 3 }.build().unwrap();
    for method in [Method::Auto, Method::Vadop, Method::Brute] {
        for (mode, restitution) in [(Mode::Detect, 1.0), (Mode::Simulate, 1.0), (Mode::Simulate, 0.4)] {
            let config = WorldConfig { method, mode, restitution, ..WorldConfig::default() };
            let run = |frames: usize, dt: f64| {
                let mut world = scene.world(config).unwrap();
                let mut all: Vec<Contact> = Vec::new();
                for _ in 0..frames {
                    all.extend(world.step(dt).unwrap());
                }
                // Only what the shorter run reaches: the runs end at rounding-different times.
                all.retain(|c| c.time < 0.99);
                contact_bits(&all)
            };
            let long = run(30, 1.0 / 30.0);
            assert!(long.len() > 100, "{method:?} {mode:?}: {}", long.len());
            assert_eq!(long, run(90, 1.0 / 90.0), "{method:?} {mode:?} e = {restitution}");
        }
    }
}

/// The supported range: lengths from 1e-50 to 1e50. A scene scaled by 2^-160 (radii of 3e-49)
/// or 2^155 (velocities near 1e49), velocities with it, gives the same contact times to the bit
/// and points scaled exactly; beyond the range a clear error.
#[test]
fn scenes_scaled_to_both_ends_of_the_range_give_the_same_contacts() {
    let unit = PaperScene { bodies: 150, packing_fraction: 0.3, max_speed: 3.0, radius: 0.5, seed: 8 }.build().unwrap();
    let scaled = |s: f64| {
        Scene::new(
            BoxBounds::new(unit.bounds.min * s, unit.bounds.max * s).unwrap(),
            unit.spheres
                .iter()
                .map(|b| Sphere {
                    position: b.position * s,
                    velocity: b.velocity * s,
                    radius: b.radius * s,
                    mass: b.mass,
                })
                .collect(),
        )
    };
    for method in [Method::Auto, Method::Vadop, Method::Brute] {
        for mode in [Mode::Detect, Mode::Simulate] {
            let config = WorldConfig { method, mode, ..WorldConfig::default() };
            let contacts = |scene: &Scene| {
                let mut world = scene.world(config).unwrap();
                (0..10).flat_map(|_| world.step(1.0 / 30.0).unwrap().to_vec()).collect::<Vec<_>>()
            };
            let reference = contacts(&unit);
            assert!(reference.len() > 100);
            for exponent in [-160, 155] {
                let s = 2f64.powi(exponent);
                let found = contacts(&scaled(s));
                assert_eq!(found.len(), reference.len(), "{method:?} {mode:?} 2^{exponent}");
                for (a, b) in found.iter().zip(&reference) {
                    assert_eq!(
                        (a.time, a.body, a.touched),
                        (b.time, b.body, b.touched),
                        "{method:?} {mode:?} 2^{exponent}"
                    );
                    assert_eq!(a.point, b.point * s);
                    assert_eq!(a.normal, b.normal);
                }
            }
        }
    }
    let tiny = Sphere { position: DVec3::splat(1e-49), velocity: DVec3::ZERO, radius: 1e-51, mass: 1.0 };
    let mut world = vadop::World::new(BoxBounds::cube(1e-48).unwrap(), WorldConfig::default()).unwrap();
    assert!(matches!(world.add_sphere(tiny), Err(VadopError::TooSmall { what: "radius", .. })));
    assert!(matches!(BoxBounds::cube(1e-51), Err(VadopError::TooSmall { what: "box side", .. })));
    assert!(matches!(BoxBounds::cube(1e51), Err(VadopError::OutOfRange { .. })));
}
