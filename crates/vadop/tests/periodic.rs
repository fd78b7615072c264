//! Periodic boxes: bodies leave through one face and come back through the other, meet across
//! the faces through their nearest images, exactly as the brute-force oracle says, and an elastic
//! gas in a periodic box has the hard-sphere pressure.

mod common;

use glam::DVec3;
use proptest::prelude::*;
use vadop::scene::{GeneratedScene, PaperScene, Scene, Velocities, FRAMES_PER_SECOND};
use vadop::{BoxBounds, Contact, Method, Mode, Sphere, Touched, VadopError, World, WorldConfig};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;

fn config(method: Method, mode: Mode) -> WorldConfig {
    WorldConfig { method, mode, ..WorldConfig::default() }
}

fn ball(position: DVec3, velocity: DVec3) -> Sphere {
    Sphere { position, velocity, radius: 0.5, mass: 1.0 }
}

/// A ball thrown across a periodic face meets a partner on the other side at the instant it meets
/// it in the same scene with the box shifted by half a side, where the meeting is inside the box.
#[test]
fn a_ball_thrown_across_a_face_meets_its_partner_as_in_a_shifted_box() {
    for method in Method::ALL.into_iter().filter(|&m| m != Method::Discrete) {
        for mode in [Mode::Detect, Mode::Simulate] {
            let mut times = Vec::new();
            for shift in [0.0, 5.0] {
                // Periodic in x and y, walls in z; the ball at x = 9 flies towards x = 10 and
                // meets the partner at x = 0.8, one diameter away through the face, after 0.8 / 3.
                let bounds = BoxBounds::new(DVec3::new(shift, 0.0, 0.0), DVec3::new(10.0 + shift, 10.0, 10.0))
                    .unwrap()
                    .with_periodic([true, true, false]);
                let wrap = |x: f64| if x < shift { x + 10.0 } else { x };
                let mut world = World::new(bounds, config(method, mode)).unwrap();
                let thrown =
                    world.add_sphere(ball(DVec3::new(wrap(9.0), 5.0, 5.0), DVec3::new(3.0, 0.0, 0.0))).unwrap();
                let partner = world.add_sphere(ball(DVec3::new(wrap(0.8), 5.0, 5.0), DVec3::ZERO)).unwrap();
                let contacts = world.step(1.0).unwrap().to_vec();
                let pair: Vec<&Contact> = contacts.iter().filter(|c| matches!(c.touched, Touched::Body(_))).collect();
                assert_eq!(pair.len(), 1, "{method:?} {mode:?} shift {shift}: {contacts:?}");
                assert_eq!((pair[0].body, pair[0].touched), (thrown, Touched::Body(partner)));
                assert!((pair[0].normal - DVec3::X).length() < 1e-12, "{:?}", pair[0].normal);
                // The contact point lies by the thrown ball, still short of x = 10, so across the face.
                let point = pair[0].point.x;
                assert!((point - 10.3).abs() < 1e-9, "point {point}");
                times.push(pair[0].time);
                if mode == Mode::Simulate {
                    // Equal masses: the thrown ball stopped, the partner took its velocity.
                    assert!(world.sphere(thrown).unwrap().velocity.length() < 1e-12);
                    assert!((world.sphere(partner).unwrap().velocity.x - 3.0).abs() < 1e-12);
                }
            }
            let expected = 0.8 / 3.0;
            assert!(times.iter().all(|t| (t - expected).abs() < 1e-12), "{method:?} {mode:?}: {times:?}");
        }
    }
}

/// A body crossing faces keeps its path: its position wraps into the box, its crossings count,
/// and its position unwrapped is where a straight path takes it.
#[test]
fn crossings_are_counted_and_unwrap_the_path() {
    let bounds = BoxBounds::cube(10.0).unwrap().with_periodic([true, true, true]);
    let mut world = World::new(bounds, WorldConfig::default()).unwrap();
    let start = DVec3::new(5.0, 5.0, 5.0);
    let velocity = DVec3::new(7.3, -4.1, 2.9);
    let body = world.add_sphere(ball(start, velocity)).unwrap();
    for _ in 0..300 {
        world.step(DT).unwrap();
    }
    let s = world.sphere(body).unwrap();
    assert!(s.position.cmpge(DVec3::ZERO).all() && s.position.cmple(DVec3::splat(10.0)).all(), "{s:?}");
    let crossed = world.crossings(body).unwrap();
    let unwrapped = s.position + DVec3::new(crossed[0] as f64, crossed[1] as f64, crossed[2] as f64) * 10.0;
    let expected = start + velocity * world.time();
    assert!((unwrapped - expected).length() < 1e-9, "unwrapped {unwrapped} vs {expected}");
    assert_eq!(crossed, [7, -4, 3]);
}

/// `scene` in a world of `config` beside the oracle: the contacts and states to the bit, the
/// bodies inside, the energy (kinetic plus potential) kept in simulate mode and under gravity,
/// and the crossings alike.
fn assert_same_as_oracle(scene: &Scene, config: WorldConfig, frames: usize) {
    let mut found = scene.world(config).unwrap();
    let mut oracle = scene.world(WorldConfig { method: Method::Brute, ..config }).unwrap();
    let energy = |w: &World| w.kinetic_energy() + w.potential_energy();
    let start = energy(&oracle);
    let (kept, tolerance) = match config.gravity == DVec3::ZERO {
        true => (config.mode == Mode::Simulate, 1e-12),
        false => (true, 1e-9),
    };
    common::step_beside_oracle(&mut found, &mut oracle, frames, DT, |frame, oracle| {
        if kept {
            assert!((energy(oracle) - start).abs() <= tolerance * start.abs(), "frame {frame}: energy drift");
        }
        assert_eq!(common::periodic_violation(oracle), None, "frame {frame}");
    });
    let crossings = |w: &World| w.spheres().map(|(h, _)| w.crossings(h).unwrap()).collect::<Vec<_>>();
    assert_eq!(crossings(&found), crossings(&oracle), "{:?}: crossings differ", config.method);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Every continuous method reports the oracle's contacts to the bit, in both modes, with any
    /// mix of periodic and walled axes, slow, fast and grazing.
    #[test]
    fn every_method_matches_brute_force_in_a_periodic_box(
        bodies in 2usize..250,
        packing_fraction in 0.01f64..0.35,
        max_speed in prop_oneof![0.01f64..0.1, 0.1f64..2.0, 2.0f64..10.0],
        axes in (any::<bool>(), any::<bool>(), any::<bool>()),
        method in prop_oneof![Just(Method::Auto), Just(Method::Vadop), Just(Method::Grid), Just(Method::SweptAabb), Just(Method::SweptKdop)],
        simulate in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let periodic = [axes.0, axes.1, axes.2];
        prop_assume!(periodic.contains(&true));
        let scene = PaperScene { bodies, packing_fraction, max_speed, radius: 0.5, seed }.build();
        prop_assume!(scene.is_ok());
        let mut scene = scene.unwrap();
        prop_assume!(scene.bounds.side().min_element() >= 8.0);
        scene.bounds = scene.bounds.with_periodic(periodic);
        assert_same_as_oracle(&scene, config(method, if simulate { Mode::Simulate } else { Mode::Detect }), 15);
    }
}

/// A fast crowd in a small periodic box: paths of many box lengths a frame, all through faces.
#[test]
fn a_fast_crowd_crossing_faces_matches_brute_force() {
    let mut scene =
        PaperScene { bodies: 120, packing_fraction: 0.02, max_speed: 40.0, radius: 0.5, seed: 3 }.build().unwrap();
    scene.bounds = scene.bounds.with_periodic([true, true, true]);
    for method in [Method::Auto, Method::Vadop, Method::SweptAabb] {
        for mode in [Mode::Detect, Mode::Simulate] {
            assert_same_as_oracle(&scene, config(method, mode), 20);
        }
    }
}

/// The discrete method finds the overlaps across the faces at frame instants, as it does inside.
#[test]
fn the_discrete_method_sees_overlaps_across_faces() {
    let bounds = BoxBounds::cube(10.0).unwrap().with_periodic([true, false, true]);
    let mut world = World::new(bounds, config(Method::Discrete, Mode::Detect)).unwrap();
    let a = world.add_sphere(ball(DVec3::new(9.6, 5.0, 0.2), DVec3::ZERO)).unwrap();
    let b = world.add_sphere(ball(DVec3::new(0.2, 5.0, 9.7), DVec3::ZERO)).unwrap();
    let contacts = world.step(DT).unwrap();
    assert_eq!(contacts.len(), 1, "{contacts:?}");
    assert_eq!((contacts[0].body, contacts[0].touched), (a, Touched::Body(b)));
    let normal = contacts[0].normal;
    assert!((normal - DVec3::new(0.6, 0.0, -0.5).normalize()).length() < 1e-12, "{normal}");
}

/// A saved periodic world resumes to the bit, crossings included.
#[test]
fn a_periodic_world_resumes_bit_exactly() {
    let mut scene =
        PaperScene { bodies: 200, packing_fraction: 0.1, max_speed: 3.0, radius: 0.5, seed: 11 }.build().unwrap();
    scene.bounds = scene.bounds.with_periodic([true, true, false]);
    let mut first = scene.world(config(Method::Auto, Mode::Simulate)).unwrap();
    for _ in 0..10 {
        first.step(DT).unwrap();
    }
    let path = std::env::temp_dir().join(format!("vadop-periodic-{}.json", std::process::id()));
    first.save(&path).unwrap();
    let mut resumed = World::load(&path).unwrap();
    std::fs::remove_file(&path).ok();
    assert_eq!(resumed.bounds().periodic, [true, true, false]);
    let crossed = |w: &World| w.spheres().map(|(h, _)| w.crossings(h).unwrap()).collect::<Vec<_>>();
    assert_eq!(crossed(&first), crossed(&resumed));
    assert!(crossed(&first).iter().any(|c| *c != [0; 3]), "some body crossed a face");
    for frame in 0..10 {
        let a = first.step(DT).unwrap().to_vec();
        assert_eq!(common::contact_bits(&a), common::contact_bits(resumed.step(DT).unwrap()), "frame {frame}");
    }
    assert_eq!(common::state_bits(&first), common::state_bits(&resumed));
    assert_eq!(crossed(&first), crossed(&resumed));
}

/// What a periodic box does not take is refused with the reason.
#[test]
fn unsupported_periodic_worlds_are_refused_clearly() {
    let bounds = BoxBounds::cube(10.0).unwrap().with_periodic([false, true, false]);
    let mut world = World::new(bounds, WorldConfig::default()).unwrap();
    // Ten diameters of 1.25 fit a side of 10 no more than eight times.
    let big = Sphere { position: DVec3::splat(5.0), velocity: DVec3::ZERO, radius: 0.7, mass: 1.0 };
    let error = world.add_sphere(big).unwrap_err();
    assert!(matches!(error, VadopError::PeriodicSideTooShort { axis: 'y', .. }), "{error}");
    // The centre must lie inside on a periodic axis; the body may reach across the face.
    assert!(world.add_sphere(ball(DVec3::new(5.0, 10.2, 5.0), DVec3::ZERO)).is_err());
    assert!(world.add_sphere(ball(DVec3::new(5.0, 0.1, 5.0), DVec3::ZERO)).is_ok());
    assert!(world.add_sphere(ball(DVec3::new(0.1, 5.0, 5.0), DVec3::ZERO)).is_err(), "x is walled");
    let cube = world.add_shape(vadop::shape::Shape::Cuboid { half_extents: DVec3::splat(0.5) }).unwrap();
    let body = vadop::Body {
        shape: vadop::BodyShape::Shape(cube),
        position: DVec3::splat(5.0),
        orientation: glam::DQuat::IDENTITY,
        velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        mass: 1.0,
    };
    // Shapes move through periodic faces as spheres do, when the side holds 8 of their bounding
    // diameters (the cube's is 1.73); static level geometry is not periodic yet.
    let error = world.add_body(body).unwrap_err();
    assert!(matches!(error, VadopError::PeriodicSideTooShort { axis: 'y', .. }), "{error}");
    let error = world.add_static(cube, DVec3::splat(5.0), glam::DQuat::IDENTITY).unwrap_err();
    assert!(matches!(error, VadopError::PeriodicUnsupported(_)), "{error}");
}

/// Carnahan-Starling's compressibility factor Z = PV/NkT of the hard-sphere fluid at packing eta.
fn carnahan_starling(eta: f64) -> f64 {
    (1.0 + eta + eta * eta - eta * eta * eta) / (1.0 - eta).powi(3)
}

/// An elastic gas of 2000 spheres at packing 0.3 in a periodic box: the pressure from the
/// collisional virial, Z = 1 + W / (3 N kT t), within 1 % of Carnahan-Starling, energy kept.
#[test]
fn a_periodic_gas_has_the_carnahan_starling_pressure() {
    let generated = GeneratedScene {
        bodies: 2000,
        packing_fraction: 0.3,
        velocities: Velocities::Maxwell { rms_speed: 0.2 },
        radius: 0.5,
        seed: 5,
    };
    let mut scene = generated.build().unwrap();
    scene.bounds = scene.bounds.with_periodic([true, true, true]);
    let mut world = scene.world(config(Method::Auto, Mode::Simulate)).unwrap();
    let n = world.len() as f64;
    let energy = world.kinetic_energy();
    let kt = 2.0 * world.translational_kinetic_energy() / (3.0 * n);
    // Enskog's collision rate per sphere, 24 eta g(sigma) sqrt(kT / pi m) with the contact value
    // g(sigma) = (Z - 1) / 4 eta: frames of half a mean free time; about 37 collisions per sphere
    // to forget the lattice, then 75 measured (75,000 pair collisions).
    let rate = 6.0 * (carnahan_starling(0.3) - 1.0) * (kt / std::f64::consts::PI).sqrt();
    let frame = 0.5 / rate;
    let (mut virial, mut time) = (0.0, 0.0);
    let (mut frames, mut measured) = (0, 0);
    while measured < 150 {
        world.step(frame).unwrap();
        frames += 1;
        if frames > 75 {
            virial += world.stats().pair_virial;
            time += frame;
            measured += 1;
        }
    }
    let drift = (world.kinetic_energy() - energy).abs() / energy;
    assert!(drift <= 1e-12, "energy drift {drift:e}");
    assert_eq!(common::periodic_violation(&world), None);
    let z = 1.0 + virial / (3.0 * n * kt * time);
    let expected = carnahan_starling(0.3);
    eprintln!("Z {z} from the virial, Carnahan-Starling {expected}");
    assert!((z / expected - 1.0).abs() < 0.01, "Z {z} vs Carnahan-Starling {expected}");
}

/// An independent oracle for a fully periodic box in detect mode, where every path is straight
/// forever: each pair, through every image `k` its relative path passes near, starts to touch
/// where the closed form of two spheres on lines says. Every method's contacts are those, to
/// 1e-9, fast and grazing pairs included, and none besides.
#[test]
fn every_method_finds_the_closed_form_contacts_through_every_image() {
    use vadop::narrow_phase::spheres::sphere_sphere_time;
    let mut scene =
        PaperScene { bodies: 150, packing_fraction: 0.05, max_speed: 6.0, radius: 0.5, seed: 21 }.build().unwrap();
    scene.bounds = scene.bounds.with_periodic([true, true, true]);
    let side = scene.bounds.side();
    let frames = 20;
    let duration = frames as f64 * DT;
    let mut expected = Vec::new();
    for (i, a) in scene.spheres.iter().enumerate() {
        for (j, b) in scene.spheres.iter().enumerate().skip(i + 1) {
            let (offset, w, reach) = (b.position - a.position, b.velocity - a.velocity, a.radius + b.radius);
            let (low, high) = (offset.min(offset + w * duration) - reach, offset.max(offset + w * duration) + reach);
            let range = |a: usize| (low[a] / side[a]).floor() as i64..=(high[a] / side[a]).ceil() as i64;
            for kx in range(0) {
                for ky in range(1) {
                    for kz in range(2) {
                        let shift = DVec3::new(kx as f64, ky as f64, kz as f64) * side;
                        if let Some(t) = sphere_sphere_time(offset - shift, w, reach) {
                            if t < duration {
                                expected.push((i as u32, j as u32, t));
                            }
                        }
                    }
                }
            }
        }
    }
    expected.sort_by(|x, y| x.2.total_cmp(&y.2));
    assert!(expected.len() > 100, "{} contacts", expected.len());
    for method in Method::ALL.into_iter().filter(|&m| m != Method::Discrete) {
        let mut world = scene.world(config(method, Mode::Detect)).unwrap();
        let mut found = Vec::new();
        for _ in 0..frames {
            for c in world.step(DT).unwrap() {
                if let Touched::Body(other) = c.touched {
                    found.push((c.body.index(), other.index(), c.time));
                }
            }
        }
        assert_eq!(found.len(), expected.len(), "{method:?}");
        for (f, e) in found.iter().zip(&expected) {
            assert!(f.0 == e.0 && f.1 == e.1 && (f.2 - e.2).abs() <= 1e-9, "{method:?}: found {f:?}, expected {e:?}");
        }
    }
}

/// A simulate-mode world refuses bodies that overlap across a periodic face, as it refuses them
/// inside the box; touching across it is allowed.
#[test]
fn bodies_overlapping_across_a_face_are_refused() {
    let bounds = BoxBounds::cube(10.0).unwrap().with_periodic([false, false, true]);
    let mut world = World::new(bounds, WorldConfig::default()).unwrap();
    let a = world.add_sphere(ball(DVec3::new(5.0, 5.0, 0.3), DVec3::ZERO)).unwrap();
    let b = world.add_sphere(ball(DVec3::new(5.2, 5.0, 9.6), DVec3::ZERO)).unwrap();
    let error = world.step(DT).unwrap_err();
    assert!(matches!(error, VadopError::Overlap { a: x, b: y, .. } if (x, y) == (a, b)), "{error}");
    world.remove_sphere(b).unwrap();
    world.add_sphere(ball(DVec3::new(5.0, 5.0, 9.3), DVec3::ZERO)).unwrap();
    assert!(world.step(DT).is_ok(), "touching across the face is no overlap");
}

/// Gravity along a walled axis of a box periodic in the others: every method is the oracle to the
/// bit, and the energy, kinetic plus potential, is kept.
#[test]
fn gravity_in_a_periodic_slab_matches_brute_force() {
    let mut scene =
        PaperScene { bodies: 200, packing_fraction: 0.1, max_speed: 2.0, radius: 0.5, seed: 8 }.build().unwrap();
    scene.bounds = scene.bounds.with_periodic([true, true, false]);
    let gravity = DVec3::new(0.0, 0.0, -20.0);
    for method in [Method::Auto, Method::Vadop, Method::SweptAabb] {
        for mode in [Mode::Detect, Mode::Simulate] {
            assert_same_as_oracle(&scene, WorldConfig { gravity, ..config(method, mode) }, 20);
        }
    }
}

/// A body larger than any before, added between frames, gets a window sized for it: it meets a
/// neighbour across the face as the oracle says.
#[test]
fn a_larger_body_added_mid_run_meets_its_neighbours_across_a_face() {
    for method in [Method::Auto, Method::Vadop, Method::Grid] {
        let mut worlds = [method, Method::Brute].map(|method| {
            let bounds = BoxBounds::cube(20.0).unwrap().with_periodic([true, true, true]);
            let mut world = World::new(bounds, config(method, Mode::Detect)).unwrap();
            world.add_sphere(ball(DVec3::new(18.0, 10.0, 10.0), DVec3::new(-0.5, 0.0, 0.0))).unwrap();
            world.step(DT).unwrap();
            // Ten times as wide, just across the face from the first.
            let big = Sphere {
                position: DVec3::new(2.0, 10.0, 10.0),
                velocity: DVec3::new(-60.0, 0.0, 0.0),
                radius: 1.2,
                mass: 8.0,
            };
            world.add_sphere(big).unwrap();
            world
        });
        let mut all = [Vec::new(), Vec::new()];
        for _ in 0..10 {
            for (world, contacts) in worlds.iter_mut().zip(&mut all) {
                contacts.extend(world.step(DT).unwrap().iter().copied());
            }
        }
        assert!(all[1].iter().any(|c| matches!(c.touched, Touched::Body(_))), "they meet");
        assert_eq!(common::contact_bits(&all[0]), common::contact_bits(&all[1]), "{method:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10, ..ProptestConfig::default() })]

    /// Spinning shapes of every kind through periodic faces: every continuous method reports the
    /// oracle's contacts to the bit, in both modes.
    #[test]
    fn shapes_match_brute_force_in_a_periodic_box(
        bodies in 30usize..80,
        max_speed in prop_oneof![0.05f64..0.5, 0.5f64..3.0],
        axes in (any::<bool>(), any::<bool>(), any::<bool>()),
        method in prop_oneof![Just(Method::Auto), Just(Method::Vadop), Just(Method::SweptAabb)],
        simulate in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let periodic = [axes.0, axes.1, axes.2];
        prop_assume!(periodic.contains(&true));
        let scene = vadop::scene::ShapesScene { bodies, packing_fraction: 0.015, max_speed, max_spin: 0.5, floor: false, seed }.build();
        prop_assume!(scene.is_ok());
        let mut scene = scene.unwrap();
        prop_assume!(scene.bounds.side().min_element() >= 8.0);
        scene.bounds = scene.bounds.with_periodic(periodic);
        let mode = if simulate { Mode::Simulate } else { Mode::Detect };
        let mut found = scene.world(config(method, mode)).unwrap();
        let mut oracle = scene.world(config(Method::Brute, mode)).unwrap();
        for frame in 0..8 {
            let contacts = found.step(DT).unwrap().to_vec();
            let expected = oracle.step(DT).unwrap();
            prop_assert_eq!(common::contact_bits(&contacts), common::contact_bits(expected), "frame {}: {:?}", frame, method);
        }
    }
}

/// A cuboid thrown across a periodic face meets a partner on the other side, its contact point
/// across the face and its normal through it.
#[test]
fn a_shape_meets_its_partner_across_a_face() {
    for method in [Method::Auto, Method::Vadop, Method::Brute] {
        let bounds = BoxBounds::cube(16.0).unwrap().with_periodic([true, false, false]);
        let mut world = World::new(bounds, config(method, Mode::Detect)).unwrap();
        let cube = world.add_shape(vadop::shape::Shape::Cuboid { half_extents: DVec3::splat(0.5) }).unwrap();
        let body = |x: f64, v: f64| vadop::Body {
            shape: vadop::BodyShape::Shape(cube),
            position: DVec3::new(x, 5.0, 5.0),
            orientation: glam::DQuat::IDENTITY,
            velocity: DVec3::new(v, 0.0, 0.0),
            angular_velocity: DVec3::ZERO,
            mass: 1.0,
        };
        let thrown = world.add_body(body(15.0, 3.0)).unwrap();
        let partner = world.add_body(body(0.8, 0.0)).unwrap();
        let contacts = world.step(0.5).unwrap().to_vec();
        let pair: Vec<&Contact> = contacts.iter().filter(|c| matches!(c.touched, Touched::Body(_))).collect();
        assert_eq!(pair.len(), 1, "{method:?}: {contacts:?}");
        assert_eq!((pair[0].body, pair[0].touched), (thrown, Touched::Body(partner)));
        // Faces 0.8 apart through x = 10 close at 3.
        assert!((pair[0].time - 0.8 / 3.0).abs() < 1e-6, "{method:?}: {}", pair[0].time);
        assert!((pair[0].normal - DVec3::X).length() < 1e-6, "{:?}", pair[0].normal);
        assert!((pair[0].point.x - 16.3).abs() < 1e-3, "{:?}", pair[0].point);
    }
}
