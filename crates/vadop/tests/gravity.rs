//! Gravity: parabolic paths, exact against the brute-force oracle and against the closed form of
//! a ball bouncing on the floor, with kinetic plus potential energy kept in elastic runs.

mod common;

use glam::DVec3;
use proptest::prelude::*;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{BoxBounds, Contact, Method, Mode, Sphere, Touched, VadopError, Wall, World, WorldConfig};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;

fn world(gravity: DVec3, method: Method, mode: Mode) -> World {
    World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig { gravity, method, mode, ..WorldConfig::default() }).unwrap()
}

/// A ball dropped from rest 4 above the floor bounces back to the same height, 1000 times: each
/// bounce lands at the closed form's instant, the apex's height and the energy stay to 1e-12.
#[test]
fn a_dropped_ball_returns_to_its_height_for_a_thousand_bounces() {
    let g = 9.81;
    let mut world = world(DVec3::new(0.0, 0.0, -g), Method::Auto, Mode::Simulate);
    let ball = world
        .add_sphere(Sphere { position: DVec3::new(5.0, 5.0, 4.5), velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 })
        .unwrap();
    let energy = world.kinetic_energy() + world.potential_energy();
    // Falls 4 in sqrt(2 * 4 / g), rises and falls again in twice that.
    let fall = (8.0 / g).sqrt();
    let mut bounces: Vec<Contact> = Vec::new();
    while bounces.len() < 1000 {
        bounces.extend(world.step(0.1).unwrap().iter().copied());
        let drift = (world.kinetic_energy() + world.potential_energy() - energy).abs() / energy;
        assert!(drift <= 1e-12, "energy drift {drift:e} after {} bounces", bounces.len());
    }
    for (k, c) in bounces.iter().enumerate() {
        assert_eq!((c.body, c.touched), (ball, Touched::Wall(Wall::MinZ)), "bounce {k}");
        let expected = fall * (1 + 2 * k) as f64;
        assert!((c.time - expected).abs() <= 1e-12 * expected, "bounce {k} at {} not {expected}", c.time);
        assert!((c.impulse - 2.0 * (2.0 * g * 4.0f64).sqrt()).abs() < 1e-9, "bounce {k}: impulse {}", c.impulse);
    }
    // Step to the apex after the last bounce: the ball is back at 4.5, at rest.
    let apex = fall * (2 * bounces.len()) as f64 - world.time();
    world.step(apex).unwrap();
    let s = world.sphere(ball).unwrap();
    assert!((s.position.z - 4.5).abs() <= 1e-12 * 4.5, "apex at {}", s.position.z);
    assert!(s.velocity.z.abs() <= 1e-9, "apex speed {}", s.velocity.z);
}

/// Two balls thrown at each other on arcs meet when their linear relative motion says, and
/// every method agrees with the oracle.
#[test]
fn balls_falling_together_meet_as_without_gravity() {
    for method in Method::ALL.into_iter().filter(|&m| m != Method::Discrete) {
        let mut world = world(DVec3::new(0.0, 0.0, -9.81), method, Mode::Detect);
        world
            .add_sphere(Sphere {
                position: DVec3::new(2.0, 5.0, 9.0),
                velocity: DVec3::new(3.0, 0.0, 0.0),
                radius: 0.5,
                mass: 1.0,
            })
            .unwrap();
        world
            .add_sphere(Sphere {
                position: DVec3::new(8.0, 5.0, 9.0),
                velocity: DVec3::new(-3.0, 0.0, 0.0),
                radius: 0.5,
                mass: 1.0,
            })
            .unwrap();
        let contacts = world.step(1.0).unwrap().to_vec();
        let pair = contacts.iter().find(|c| matches!(c.touched, Touched::Body(_))).expect("they meet");
        // The gap of 5 closes at 6 per second, whatever the fall (they fall 0.69 by then, far above the floor).
        assert!((pair.time - 5.0 / 6.0).abs() < 1e-12, "{method:?}: {}", pair.time);
    }
}

fn assert_same_as_oracle(scene: &vadop::scene::Scene, gravity: DVec3, method: Method, mode: Mode, frames: usize) {
    let config = |method| WorldConfig { gravity, method, mode, ..WorldConfig::default() };
    let mut found = scene.world(config(method)).unwrap();
    let mut oracle = scene.world(config(Method::Brute)).unwrap();
    let energy = |w: &World| w.kinetic_energy() + w.potential_energy();
    let start = energy(&oracle);
    let refused = common::step_beside_oracle(&mut found, &mut oracle, frames, DT, |frame, oracle| {
        if mode == Mode::Simulate {
            let scale = start.abs() + oracle.kinetic_energy();
            assert!((energy(oracle) - start).abs() <= 1e-9 * scale, "frame {frame}: energy drift");
            let violation = common::frame_end_violation(oracle, true);
            assert!(violation.is_none(), "frame {frame}: {violation:?}");
        }
    });
    // A body that came to rest on a floor is refused (no resting state yet), by both alike.
    assert!(refused.as_ref().is_none_or(|e| matches!(e, VadopError::RestingUnderGravity { .. })), "{refused:?}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// Every continuous method reports the oracle's contacts to the bit, in both modes, under a
    /// gravity of any direction, from barely felt to ten box lengths per second squared.
    #[test]
    fn every_method_matches_brute_force_under_gravity(
        bodies in 2usize..200,
        packing_fraction in 0.01f64..0.3,
        max_speed in prop_oneof![0.01f64..0.1, 0.1f64..2.0, 2.0f64..10.0],
        strength in prop_oneof![0.01f64..1.0, 1.0f64..100.0],
        direction in (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0),
        method in prop_oneof![Just(Method::Auto), Just(Method::Vadop), Just(Method::Grid), Just(Method::SweptAabb), Just(Method::SweptKdop)],
        simulate in any::<bool>(),
        seed in any::<u64>(),
    ) {
        let direction = DVec3::new(direction.0, direction.1, direction.2);
        prop_assume!(direction.length() > 0.1);
        let scene = PaperScene { bodies, packing_fraction, max_speed, radius: 0.5, seed }.build();
        prop_assume!(scene.is_ok());
        let scene = scene.unwrap();
        let gravity = direction.normalize() * strength * scene.bounds.max.max_element();
        assert_same_as_oracle(&scene, gravity, method, if simulate { Mode::Simulate } else { Mode::Detect }, 12);
    }
}

#[test]
fn a_dense_pack_settles_the_same_way_for_every_method() {
    let scene =
        PaperScene { bodies: 300, packing_fraction: 0.3, max_speed: 2.0, radius: 0.5, seed: 9 }.build().unwrap();
    for method in [Method::Vadop, Method::Grid, Method::SweptAabb] {
        assert_same_as_oracle(&scene, DVec3::new(0.0, 0.0, -20.0), method, Mode::Simulate, 60);
    }
}

/// A unit-mass body of `shape` at rest at (2, 2, 2), upright.
fn at_rest(shape: vadop::ShapeId) -> vadop::Body {
    vadop::Body {
        shape: vadop::BodyShape::Shape(shape),
        position: DVec3::splat(2.0),
        orientation: glam::DQuat::IDENTITY,
        velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        mass: 1.0,
    }
}

#[test]
fn unsupported_gravity_is_refused_clearly() {
    let config = |gravity, restitution| WorldConfig { gravity, restitution, ..WorldConfig::default() };
    let bad = World::new(BoxBounds::cube(1.0).unwrap(), config(DVec3::new(0.0, f64::NAN, 0.0), 1.0));
    assert!(matches!(bad, Err(VadopError::BadGravity(_))));
    // With restitution below 1 bodies come to rest (tests/rest.rs): accepted.
    assert!(World::new(BoxBounds::cube(1.0).unwrap(), config(DVec3::NEG_Z, 0.5)).is_ok());
    let mut world = World::new(BoxBounds::cube(4.0).unwrap(), config(DVec3::NEG_Z, 1.0)).unwrap();
    let cube = world.add_shape(vadop::shape::Shape::Cuboid { half_extents: DVec3::splat(0.5) }).unwrap();
    let body = at_rest(cube);
    // A shape falls in an elastic world, in detect mode, and comes to rest with restitution below
    // 1 (tests/rest_shapes.rs). Static geometry is taken in both modes.
    let cube_body = world.add_body(body).unwrap();
    world.remove_body(cube_body).unwrap();
    let mut resting = World::new(BoxBounds::cube(4.0).unwrap(), config(DVec3::NEG_Z, 0.5)).unwrap();
    let cube = resting.add_shape(vadop::shape::Shape::Cuboid { half_extents: DVec3::splat(0.5) }).unwrap();
    assert!(resting.add_body(vadop::Body { shape: vadop::BodyShape::Shape(cube), ..body }).is_ok());
    let mut detect =
        World::new(BoxBounds::cube(4.0).unwrap(), WorldConfig { mode: Mode::Detect, ..config(DVec3::NEG_Z, 1.0) })
            .unwrap();
    let floor = detect.add_shape(vadop::shape::Shape::HalfSpace { normal: DVec3::Z }).unwrap();
    assert!(
        detect.add_static(floor, DVec3::splat(1.0), glam::DQuat::IDENTITY).is_ok(),
        "static geometry in detect mode"
    );
    // An elastic ball at rest on the floor would bounce ever faster (only a world with
    // restitution below 1 lets bodies rest): refused, the world left as it was.
    let ball = |z: f64| Sphere { position: DVec3::new(2.0, 2.0, z), velocity: DVec3::ZERO, radius: 0.5, mass: 1.0 };
    let resting = world.add_sphere(ball(0.5)).unwrap();
    let error = world.step(0.1).unwrap_err();
    assert!(matches!(error, VadopError::RestingUnderGravity { body, .. } if body == resting), "{error}");
    assert_eq!(world.time(), 0.0);
    world.remove_sphere(resting).unwrap();
    world.add_sphere(ball(1.5)).unwrap();
    assert!(world.step(0.1).is_ok(), "a ball a radius above the floor falls");
}

/// An upright capsule dropped on the floor of an elastic world bounces at the closed-form
/// instants of its lowest point's parabola (to the shape contact tolerance), straight up and
/// down, and keeps its energy, potential included.
#[test]
fn a_dropped_capsule_bounces_at_the_closed_form_instants() {
    let g = 9.81;
    let config = WorldConfig { gravity: DVec3::new(0.0, 0.0, -g), ..WorldConfig::default() };
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config).unwrap();
    let capsule = world.add_shape(vadop::shape::Shape::Capsule { half_height: 0.4, radius: 0.2 }).unwrap();
    let body = vadop::Body {
        shape: vadop::BodyShape::Shape(capsule),
        position: DVec3::new(5.0, 5.0, 3.0),
        // Its axis (the shape's y) upright: the lowest point right under the centre.
        orientation: glam::DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2),
        velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        mass: 1.0,
    };
    let handle = world.add_body(body).unwrap();
    let energy = |w: &World| w.kinetic_energy() + w.potential_energy();
    let start = energy(&world);
    // The lowest point falls 2.4 to the floor, then bounces back up as high: contacts at the
    // odd multiples of the fall's duration.
    let fall = (2.0 * 2.4 / g).sqrt();
    let mut times = Vec::new();
    for _ in 0..120 {
        for contact in world.step(1.0 / 30.0).unwrap() {
            assert_eq!(contact.touched, Touched::Wall(Wall::MinZ), "{contact:?}");
            assert!((contact.normal - DVec3::NEG_Z).length() < 1e-9, "{contact:?}");
            times.push(contact.time);
        }
        assert!((energy(&world) - start).abs() <= 1e-12 * start, "energy {} vs {start}", energy(&world));
    }
    assert_eq!(times.len(), 3, "{times:?}");
    for (k, time) in times.iter().enumerate() {
        let expected = (2 * k + 1) as f64 * fall;
        assert!((time - expected).abs() < 1e-6, "bounce {k} at {time}, expected {expected}");
    }
    let now = world.body(handle).unwrap();
    assert!(now.position.truncate().distance(glam::DVec2::new(5.0, 5.0)) < 1e-9, "it stays upright over its spot");
}

/// A saved world is checked as a built one: a file edited to make the box periodic around a
/// static body (level geometry is not periodic) is refused on loading, naming the slot, not
/// stepped.
#[test]
fn a_save_file_edited_past_the_refusals_is_refused() {
    let mut world = World::new(BoxBounds::cube(4.0).unwrap(), WorldConfig::default()).unwrap();
    let cube = world.add_shape(vadop::shape::Shape::Cuboid { half_extents: DVec3::splat(0.5) }).unwrap();
    world.add_static(cube, DVec3::splat(2.0), glam::DQuat::IDENTITY).unwrap();
    let path = std::env::temp_dir().join(format!("vadop-refusal-edit-{}.json", std::process::id()));
    world.save(&path).unwrap();
    assert!(World::load(&path).is_ok(), "saved with walls: loads");
    let mut saved: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    saved["bounds"]["periodic"] = serde_json::json!([true, false, false]);
    std::fs::write(&path, saved.to_string()).unwrap();
    let refused = World::load(&path).unwrap_err().to_string();
    std::fs::remove_file(&path).unwrap();
    assert!(refused.contains("slot 0") && refused.contains("no static bodies"), "{refused}");
}
