//! Adversarial scenes: grazing contacts, bodies touching at the start, bodies in line at the same
//! speed, head-on at 1000 diameters per frame, radii from 1e-3 to 1e3, coordinates 1e6 from the
//! origin, a dense pack at packing fraction 0.6, bodies at rest, one body crossing the whole box
//! in one frame, and inelastic collapse. In every one the VADOP world must report the same
//! contacts as the brute-force oracle, no body may leave the box, no pair may end a frame
//! overlapping beyond the contact tolerance (simulate mode), and elastic runs conserve energy.

use glam::DVec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::{Duration, Instant};
use vadop::scene::{PaperScene, Scene};
use vadop::{BoxBounds, Contact, Method, Mode, Sphere, Touched, World, WorldConfig};

mod common;

use common::{frame_end_violation, random_direction};

fn check_frame_end(world: &World, frame: usize) {
    if let Some(what) = frame_end_violation(world, true) {
        panic!("frame {frame}: {what}");
    }
}

/// Steps the VADOP world and the oracle side by side: identical contacts every frame, frame-end
/// invariants, and (restitution 1, simulate mode) energy conserved. Returns the contact count.
fn run_against_oracle(scene: &Scene, config: WorldConfig, dt: f64, frames: usize) -> usize {
    let mut vadop = scene.world(WorldConfig { method: Method::Vadop, ..config }).unwrap();
    let mut oracle = scene.world(WorldConfig { method: Method::Brute, ..config }).unwrap();
    let energy = vadop.kinetic_energy();
    let (mut total, mut plastic) = (0, 0);
    for frame in 0..frames {
        let found = vadop.step(dt).unwrap().to_vec();
        let expected = oracle.step(dt).unwrap();
        assert_same(&found, expected, frame);
        total += found.len();
        plastic += vadop.stats().jam_contacts + vadop.stats().tc_contacts;
        check_frame_end(&vadop, frame);
    }
    // The collapse rule loses energy by design; only scenes that never needed it must keep it all.
    if config.mode == Mode::Simulate && config.restitution == 1.0 && energy > 0.0 && plastic == 0 {
        let drift = (vadop.kinetic_energy() - energy).abs() / energy;
        assert!(drift <= 1e-9, "relative energy drift {drift:e}");
    }
    total
}

/// Fails at the first contact where the two sequences part, showing a few around it.
fn assert_same(found: &[Contact], expected: &[Contact], frame: usize) {
    if let Some(k) = (0..found.len().max(expected.len())).find(|&k| found.get(k) != expected.get(k)) {
        let around = |c: &[Contact]| c[k.saturating_sub(2)..(k + 2).min(c.len())].to_vec();
        panic!(
            "frame {frame}: contact {k} of {} (vadop) / {} (oracle) differs\nvadop:  {:?}\noracle: {:?}",
            found.len(),
            expected.len(),
            around(found),
            around(expected)
        );
    }
}

fn sphere(position: DVec3, velocity: DVec3, radius: f64) -> Sphere {
    Sphere { position, velocity, radius, mass: radius.powi(3) }
}

fn both_modes() -> [WorldConfig; 2] {
    [Mode::Detect, Mode::Simulate].map(|mode| WorldConfig { mode, pool_axes: Some(7), ..WorldConfig::default() })
}

#[test]
fn many_bodies_touching_at_the_start() {
    // A simple cubic lattice of unit spheres exactly touching their neighbours, random velocities.
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut spheres = Vec::new();
    for k in 0..343 {
        let cell = DVec3::new((k % 7) as f64, ((k / 7) % 7) as f64, (k / 49) as f64);
        spheres.push(sphere(DVec3::splat(1.0) + 2.0 * cell, random_direction(&mut rng) * 3.0, 1.0));
    }
    let scene = Scene::new(BoxBounds::cube(14.5).unwrap(), spheres);
    for config in both_modes() {
        let contacts = run_against_oracle(&scene, config, 0.05, 10);
        assert!(contacts > 500, "{config:?}: {contacts}");
    }
}

/// Elastic spheres jammed between each other and the walls with no free space at all: without
/// the collapse rule they would exchange velocities forever at one instant.
#[test]
fn elastic_bodies_jammed_against_the_walls_end_every_frame() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let spheres: Vec<Sphere> = (0..27)
        .map(|k| {
            let cell = DVec3::new((k % 3) as f64, ((k / 3) % 3) as f64, (k / 9) as f64);
            sphere(DVec3::splat(1.0) + 2.0 * cell, random_direction(&mut rng), 1.0)
        })
        .collect();
    let scene = Scene::new(BoxBounds::cube(6.0).unwrap(), spheres);
    let started = Instant::now();
    let config = WorldConfig { pool_axes: Some(7), ..WorldConfig::default() };
    let mut vadop = scene.world(config).unwrap();
    let mut oracle = scene.world(WorldConfig { method: Method::Brute, ..config }).unwrap();
    let momentum = vadop.momentum();
    let mut plastic = 0;
    for frame in 0..5 {
        let found = vadop.step(0.05).unwrap().to_vec();
        assert_same(&found, oracle.step(0.05).unwrap(), frame);
        plastic += vadop.stats().jam_contacts + vadop.stats().tc_contacts;
        check_frame_end(&vadop, frame);
    }
    assert!(plastic > 0, "the collapse rule must have been used");
    assert!(vadop.momentum().length() <= momentum.length() + 1e-9, "walls only ever absorb momentum here");
    assert!(started.elapsed() < Duration::from_secs(10), "took {:?}", started.elapsed());
}

#[test]
fn bodies_in_line_at_the_same_speed() {
    // Rows of spheres along x, spaced and all moving at the same velocity: no contact until the
    // first one bounces off the wall, then a cascade back along each row.
    let mut spheres = Vec::new();
    for row in 0..10 {
        for k in 0..20 {
            let position = DVec3::new(1.0 + 3.0 * k as f64, 2.0 + 4.0 * row as f64, 5.0 + 0.5 * row as f64);
            spheres.push(sphere(position, DVec3::new(40.0, 0.0, 0.0), 1.0));
        }
    }
    let scene = Scene::new(BoxBounds::new(DVec3::ZERO, DVec3::new(80.0, 44.0, 20.0)).unwrap(), spheres);
    for config in both_modes() {
        let contacts = run_against_oracle(&scene, config, 1.0 / 30.0, 60);
        assert!(contacts > 200, "{config:?}: {contacts}");
    }
}

#[test]
fn head_on_at_a_thousand_diameters_per_frame() {
    let dt = 1.0 / 30.0;
    let speed = 1000.0 * 2.0 / dt;
    let mut spheres = Vec::new();
    for k in 0..30 {
        let y = 2.0 + 5.0 * k as f64;
        let lateral = [0.0, 1.0, 1.999_999_999, 0.5][k % 4];
        spheres.push(sphere(DVec3::new(10.0, y, 10.0), DVec3::new(speed, 0.0, 0.0), 1.0));
        spheres.push(sphere(DVec3::new(1990.0, y + lateral, 10.0), DVec3::new(-speed, 0.0, 0.0), 1.0));
    }
    let scene = Scene::new(BoxBounds::new(DVec3::ZERO, DVec3::new(2000.0, 155.0, 20.0)).unwrap(), spheres);
    for config in both_modes() {
        let contacts = run_against_oracle(&scene, config, dt, 4);
        let pairs = |c: &usize| *c;
        assert!(pairs(&contacts) >= 30, "{config:?}: {contacts}");
    }
}

#[test]
fn radii_from_a_thousandth_to_a_thousand() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let side = 6000.0;
    let mut spheres = vec![
        sphere(DVec3::new(1500.0, 3000.0, 3000.0), DVec3::new(2000.0, 0.0, 0.0), 1000.0),
        sphere(DVec3::new(4500.0, 3000.0, 3000.0), DVec3::new(-500.0, 300.0, 0.0), 1000.0),
    ];
    // Radii spread log-uniformly over 1e-3..1e1, fast, placed where they do not overlap.
    while spheres.len() < 300 {
        let radius = 10f64.powf(rng.random_range(-3.0..1.0));
        let position = DVec3::new(
            rng.random_range(20.0..side - 20.0),
            rng.random_range(20.0..side - 20.0),
            rng.random_range(20.0..side - 20.0),
        );
        if spheres.iter().all(|s| s.position.distance(position) > s.radius + radius) {
            spheres.push(sphere(position, random_direction(&mut rng) * rng.random_range(0.0..30_000.0), radius));
        }
    }
    let scene = Scene::new(BoxBounds::cube(side).unwrap(), spheres);
    for config in both_modes() {
        let contacts = run_against_oracle(&scene, config, 1.0 / 30.0, 30);
        assert!(contacts > 100, "{config:?}: {contacts}");
    }
}

#[test]
fn a_million_units_from_the_origin_with_grazing_passes() {
    let offset = DVec3::splat(1.0e6);
    let base =
        PaperScene { bodies: 300, packing_fraction: 0.05, max_speed: 3.0, radius: 0.5, seed: 4 }.build().unwrap();
    let mut spheres: Vec<Sphere> =
        base.spheres.iter().map(|s| Sphere { position: s.position + offset, ..*s }).collect();
    let bounds = BoxBounds::new(base.bounds.min + offset, base.bounds.max + offset).unwrap();
    // Grazing pairs beside the pack: paths exactly R apart, and a hair inside and outside.
    let side = base.bounds.max.x;
    let mut grazing = Vec::new();
    for (k, miss) in [0.0, 1e-9, -1e-9, 1e-12].into_iter().enumerate() {
        let y = 1.0 + 2.5 * k as f64;
        grazing.push(sphere(DVec3::new(1.0, y, side - 0.6), DVec3::new(30.0, 0.0, 0.0), 0.5));
        grazing.push(sphere(DVec3::new(4.0, y + 1.0 + miss, side - 0.6), DVec3::ZERO, 0.5));
    }
    // Keep only grazing bodies that do not overlap the pack.
    for g in grazing {
        let g = Sphere { position: g.position + offset, ..g };
        if spheres.iter().all(|s| s.position.distance(g.position) > s.radius + g.radius + 1e-6) {
            spheres.push(g);
        }
    }
    let scene = Scene::new(bounds, spheres);
    for config in both_modes() {
        let contacts = run_against_oracle(&scene, config, 1.0 / 30.0, 30);
        assert!(contacts > 100, "{config:?}: {contacts}");
    }
}

#[test]
fn dense_pack_at_packing_fraction_0_6() {
    let scene =
        PaperScene { bodies: 500, packing_fraction: 0.6, max_speed: 1.0, radius: 0.5, seed: 9 }.build().unwrap();
    for config in both_modes() {
        let contacts = run_against_oracle(&scene, config, 1.0 / 30.0, 10);
        assert!(contacts > 1000, "{config:?}: {contacts}");
    }
}

#[test]
fn all_bodies_at_rest() {
    let base = PaperScene::new(200, 0.3, 0.0).build().unwrap();
    let scene =
        Scene { spheres: base.spheres.iter().map(|s| Sphere { velocity: DVec3::ZERO, ..*s }).collect(), ..base };
    for config in both_modes() {
        let mut world = scene.world(config).unwrap();
        for _ in 0..5 {
            assert!(world.step(1.0 / 30.0).unwrap().is_empty());
        }
        let now: Vec<Sphere> = world.spheres().map(|(_, s)| s).collect();
        assert_eq!(now, scene.spheres, "bodies at rest must not move by a single bit");
    }
}

#[test]
fn one_body_crosses_the_whole_box_in_one_frame() {
    let base = PaperScene { bodies: 300, packing_fraction: 0.3, max_speed: 0.2, radius: 0.5, seed: 6 }.build().unwrap();
    let side = base.bounds.max.x;
    let mut spheres = base.spheres.clone();
    // 1.5 box diagonals per frame, through the middle of the pack.
    spheres[150].velocity = DVec3::new(1.0, 0.7, 0.3).normalize() * 1.5 * side * 3f64.sqrt() * 30.0;
    let scene = Scene { spheres, ..base };
    for config in both_modes() {
        let contacts = run_against_oracle(&scene, config, 1.0 / 30.0, 10);
        assert!(contacts > 10, "{config:?}: {contacts}");
    }
}

/// Three spheres in a line between two walls, touching, with restitution 0.5: without a rule the
/// number of contacts in finite time is unbounded.
#[test]
fn inelastic_collapse_between_walls_ends_every_frame() {
    let bounds = BoxBounds::new(DVec3::ZERO, DVec3::new(6.0, 4.0, 4.0)).unwrap();
    let spheres = vec![
        sphere(DVec3::new(1.0, 2.0, 2.0), DVec3::new(5.0, 0.0, 0.0), 1.0),
        sphere(DVec3::new(3.0, 2.0, 2.0), DVec3::ZERO, 1.0),
        sphere(DVec3::new(5.0, 2.0, 2.0), DVec3::new(-5.0, 0.0, 0.0), 1.0),
    ];
    let scene = Scene::new(bounds, spheres);
    let config = WorldConfig { restitution: 0.5, ..WorldConfig::default() };
    let started = Instant::now();
    let mut vadop = scene.world(config).unwrap();
    let mut oracle = scene.world(WorldConfig { method: Method::Brute, ..config }).unwrap();
    let mut plastic = 0;
    for frame in 0..100 {
        let found = vadop.step(1.0 / 30.0).unwrap().to_vec();
        assert_same(&found, oracle.step(1.0 / 30.0).unwrap(), frame);
        plastic += vadop.stats().jam_contacts + vadop.stats().tc_contacts;
        check_frame_end(&vadop, frame);
    }
    assert!(plastic > 0, "the collapse rule must have been used");
    assert!(started.elapsed() < Duration::from_secs(10), "took {:?}", started.elapsed());
}

/// A column of touching spheres closing in on itself with restitution 0.5, far from any wall:
/// the rule ends every frame and every impulse conserves momentum.
#[test]
fn inelastic_collapse_of_a_free_column_conserves_momentum() {
    let bounds = BoxBounds::cube(200.0).unwrap();
    let spheres: Vec<Sphere> = (0..20)
        .map(|k| {
            let x = 80.0 + 2.0 * k as f64;
            // Converging on the middle, with a little lateral noise so the column stays a column.
            let velocity = DVec3::new(if k < 10 { 3.0 } else { -3.0 }, 1e-3 * (k % 3) as f64, 0.0);
            Sphere { position: DVec3::new(x, 100.0, 100.0), velocity, radius: 1.0, mass: 1.0 + (k % 4) as f64 }
        })
        .collect();
    let scene = Scene::new(bounds, spheres);
    let mut world = scene.world(WorldConfig { restitution: 0.5, ..WorldConfig::default() }).unwrap();
    let momentum = world.momentum();
    let energy = world.kinetic_energy();
    let started = Instant::now();
    let mut contacts = 0;
    for frame in 0..30 {
        contacts += world.step(1.0 / 30.0).unwrap().iter().filter(|c| matches!(c.touched, Touched::Body(_))).count();
        check_frame_end(&world, frame);
        assert!((world.momentum() - momentum).length() <= 1e-12 * 60.0, "momentum drifted to {:?}", world.momentum());
    }
    assert!(contacts > 100, "{contacts}");
    assert!(world.kinetic_energy() < energy);
    assert!(started.elapsed() < Duration::from_secs(10), "took {:?}", started.elapsed());
}

/// Two boxes, one spinning at up to 1e7 rad/s (over 50 000 turns a frame), flying at each other
/// in free space, elastic and frictionless. The spinner's approach took more distance evaluations
/// than a search may spend, and a search that could not decide jammed the pair: all energy and
/// spin gone, no contact reported. Bodies apart are never jammed: a search out of budget starts
/// afresh where it stopped. Every method finds the same impact, at the time detect mode finds it,
/// and the impacts keep the energy.
#[test]
fn a_fast_spin_never_jams_bodies_in_free_space() {
    use glam::DQuat;
    use vadop::shape::Shape;
    use vadop::{Body, BodyShape};
    for spin in [3e6, 1e7] {
        let run = |method, mode| {
            let config = WorldConfig { method, mode, threads: Some(1), ..WorldConfig::default() };
            let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config).unwrap();
            let plank = world.add_shape(Shape::Cuboid { half_extents: DVec3::new(0.5, 0.2, 0.1) }).unwrap();
            let omega = DVec3::new(1e7, 3e6, 1e6).normalize() * spin;
            for (x, v, w) in [(2.0, 6.0, omega), (3.3, -6.0, DVec3::ZERO)] {
                let body = Body {
                    shape: BodyShape::Shape(plank),
                    position: DVec3::new(x, 5.0, 5.0),
                    orientation: DQuat::IDENTITY,
                    velocity: DVec3::new(v, 0.0, 0.0),
                    angular_velocity: w,
                    mass: 1.0,
                };
                world.add_body(body).unwrap();
            }
            let energy = world.kinetic_energy();
            let contacts = world.step(1.0 / 30.0).unwrap().to_vec();
            (contacts, energy, world.kinetic_energy(), *world.stats())
        };
        let (contacts, before, after, stats) = run(Method::Auto, Mode::Simulate);
        assert_eq!(stats.jam_contacts, 0, "spin {spin:e}: jammed in free space");
        let first = contacts.iter().find(|c| matches!(c.touched, Touched::Body(_))).expect("the boxes meet");
        assert!(first.impulse > 0.0, "spin {spin:e}: {first:?}");
        assert!((after - before).abs() <= 1e-6 * before, "spin {spin:e}: energy {before:e} -> {after:e}");
        let (detected, ..) = run(Method::Auto, Mode::Detect);
        assert_eq!(detected.first().map(|c| c.time), Some(first.time), "spin {spin:e}: detect mode");
        let (oracle, ..) = run(Method::Brute, Mode::Simulate);
        assert_eq!(oracle, contacts, "spin {spin:e}: brute force");
    }
}
