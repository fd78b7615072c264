//! Every bad input gets a typed error with a clear message and leaves the world as it was.

use glam::DVec3;
use vadop::{BodyHandle, BoxBounds, Method, Mode, Sphere, Touched, VadopError, World, WorldConfig};

fn sphere(x: f64) -> Sphere {
    Sphere { position: DVec3::new(x, 5.0, 5.0), velocity: DVec3::new(1.0, 0.0, 0.0), radius: 0.5, mass: 1.0 }
}

/// A world of two bodies, stepped once, and their handles.
fn world() -> (World, [BodyHandle; 2]) {
    let mut w = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    let a = w.add_sphere(sphere(2.0)).unwrap();
    let b = w.add_sphere(sphere(5.0)).unwrap();
    w.step(0.01).unwrap();
    (w, [a, b])
}

fn snapshot(w: &World) -> (f64, Vec<(BodyHandle, Sphere)>) {
    (w.time(), w.spheres().collect())
}

#[test]
fn bad_spheres_are_rejected_and_change_nothing() {
    let (mut w, _) = world();
    let before = snapshot(&w);
    let cases: Vec<(Sphere, &str)> = vec![
        (Sphere { position: DVec3::new(f64::NAN, 5.0, 5.0), ..sphere(1.0) }, "position must be finite"),
        (Sphere { velocity: DVec3::new(0.0, f64::INFINITY, 0.0), ..sphere(8.0) }, "velocity must be finite"),
        (Sphere { radius: 0.0, ..sphere(8.0) }, "radius must be"),
        (Sphere { radius: -1.0, ..sphere(8.0) }, "radius must be"),
        (Sphere { radius: f64::NAN, ..sphere(8.0) }, "radius must be"),
        (Sphere { mass: 0.0, ..sphere(8.0) }, "mass must be"),
        (Sphere { mass: -2.0, ..sphere(8.0) }, "mass must be"),
        (Sphere { position: DVec3::new(9.8, 5.0, 5.0), ..sphere(0.0) }, "does not fit inside the box"),
        (Sphere { position: DVec3::new(50.0, 5.0, 5.0), ..sphere(0.0) }, "does not fit inside the box"),
        (Sphere { radius: 20.0, ..sphere(5.0) }, "does not fit inside the box"),
    ];
    for (bad, message) in cases {
        let err = w.add_sphere(bad).unwrap_err();
        assert!(err.to_string().contains(message), "{err} should say {message}");
        assert_eq!(snapshot(&w), before);
    }
    // A batch with one bad sphere adds none.
    let err = w.add_spheres(&[sphere(8.0), Sphere { radius: -1.0, ..sphere(8.0) }]).unwrap_err();
    assert_eq!(err, VadopError::InSphere { index: 1, source: Box::new(VadopError::BadRadius(-1.0)) });
    assert_eq!(err.to_string(), "sphere 1: radius must be a finite number > 0, got -1");
    assert_eq!(snapshot(&w), before);
}

#[test]
fn bad_steps_are_rejected_and_change_nothing() {
    let (mut w, _) = world();
    let before = snapshot(&w);
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(w.step(dt), Err(VadopError::BadTimeStep(_))));
        assert_eq!(snapshot(&w), before);
    }
    // Absurd speed: 1e9 units per second in a box of 10.
    let fast = w.add_sphere(Sphere { velocity: DVec3::new(1e9, 0.0, 0.0), ..sphere(8.0) }).unwrap();
    let err = w.step(0.1).unwrap_err();
    assert!(matches!(err, VadopError::AbsurdSpeed { .. }), "{err}");
    w.remove_sphere(fast).unwrap();
    assert_eq!(snapshot(&w), before);
    // Overlap at the start of a simulate-mode run: rejected, and the world steps on once removed.
    let overlapping = w.add_sphere(sphere(2.3)).unwrap();
    let err = w.step(0.01).unwrap_err();
    assert!(err.to_string().contains("overlap"), "{err}");
    w.remove_sphere(overlapping).unwrap();
    assert_eq!(snapshot(&w), before);
    w.step(0.01).unwrap();
}

#[test]
fn overlaps_are_fine_in_detect_mode_and_touching_is_fine_in_simulate_mode() {
    let bounds = BoxBounds::cube(10.0).unwrap();
    let mut detect = World::new(bounds, WorldConfig { mode: Mode::Detect, ..WorldConfig::default() }).unwrap();
    detect.add_spheres(&[sphere(2.0), sphere(2.3)]).unwrap();
    detect.step(0.01).unwrap();
    let mut simulate = World::new(bounds, WorldConfig::default()).unwrap();
    simulate.add_spheres(&[sphere(2.0), Sphere { velocity: DVec3::ZERO, ..sphere(3.0) }]).unwrap();
    let contacts = simulate.step(0.01).unwrap();
    assert_eq!(contacts.len(), 1, "touching and approaching: a contact at once");
    assert_eq!(contacts[0].time, 0.0);
}

#[test]
fn empty_worlds_bad_ids_and_bad_configs() {
    let bounds = BoxBounds::cube(10.0).unwrap();
    let mut empty = World::new(bounds, WorldConfig::default()).unwrap();
    assert_eq!(empty.step(0.1).unwrap_err(), VadopError::EmptyWorld);
    let (mut w, [a, _]) = world();
    let unknown = BodyHandle::from_bits(7);
    assert_eq!(w.remove_sphere(unknown).unwrap_err(), VadopError::NoSuchBody(unknown));
    assert_eq!(w.set_velocity(unknown, DVec3::X).unwrap_err(), VadopError::NoSuchBody(unknown));
    assert_eq!(w.sphere(unknown).unwrap_err().to_string(), "no body with handle 7 in this world");
    assert!(w.set_velocity(a, DVec3::splat(f64::NAN)).is_err());
    assert!(BoxBounds::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0)).is_err());
    assert!(BoxBounds::new(DVec3::ZERO, DVec3::new(1.0, f64::INFINITY, 1.0)).is_err());
    let bad = |config: WorldConfig| World::new(bounds, config).unwrap_err();
    assert!(matches!(bad(WorldConfig { restitution: 1.5, ..WorldConfig::default() }), VadopError::BadRestitution(_)));
    assert!(matches!(
        bad(WorldConfig { pool_axes: Some(2), ..WorldConfig::default() }),
        VadopError::BadPoolSize { .. }
    ));
    assert!(matches!(
        bad(WorldConfig { pool_axes: Some(1_000_000), ..WorldConfig::default() }),
        VadopError::BadPoolSize { .. }
    ));
    // phi below the covering radius would let two bodies share no axis.
    let err = bad(WorldConfig { pool_axes: Some(13), phi: Some(0.1), ..WorldConfig::default() });
    assert!(matches!(err, VadopError::BadPhi { .. }), "{err}");
    assert!(matches!(bad(WorldConfig { phi: Some(f64::NAN), ..WorldConfig::default() }), VadopError::BadPhi { .. }));
    for method in [Method::Vadop, Method::Brute, Method::Discrete] {
        let mut w = World::new(bounds, WorldConfig { method, ..WorldConfig::default() }).unwrap();
        assert_eq!(w.step(1.0).unwrap_err(), VadopError::EmptyWorld);
    }
}

#[test]
fn removed_bodies_free_their_slots_and_vanish_from_contacts() {
    let (mut w, [a, b]) = world();
    let gone = w.remove_sphere(b).unwrap();
    assert_eq!(gone.radius, 0.5);
    assert_eq!(w.sphere(b), Err(VadopError::StaleHandle { handle: b, current: None }));
    for _ in 0..30 {
        for c in w.step(0.1).unwrap() {
            assert_eq!(c.body, a);
        }
    }
    let again = w.add_sphere(sphere(5.0)).unwrap();
    assert_eq!((again.index(), again.generation()), (b.index(), b.generation() + 1));
}

/// A removed body's handle names nothing, even once its slot holds another body: every method
/// that takes a handle refuses it, with the same error, and changes nothing.
#[test]
fn stale_handles_are_refused_by_every_method() {
    let (mut w, [a, b]) = world();
    w.remove_sphere(b).unwrap();
    let c = w.add_sphere(Sphere { velocity: DVec3::new(-1.0, 0.0, 0.0), ..sphere(8.0) }).unwrap();
    assert_eq!(c.index(), b.index());
    assert_ne!(c, b);
    let stale = VadopError::StaleHandle { handle: b, current: Some(c) };
    assert_eq!(stale.to_string(), "body 1 was removed; its slot now holds body 1v1");
    let before = snapshot(&w);
    assert_eq!(w.sphere(b), Err(stale.clone()));
    assert_eq!(w.remove_sphere(b), Err(stale.clone()));
    assert_eq!(w.set_velocity(b, DVec3::X), Err(stale.clone()));
    // A batch with one stale handle changes none of its bodies.
    assert_eq!(w.set_velocities(&[a, b], &[DVec3::Y, DVec3::X]), Err(stale.clone()));
    assert_eq!(snapshot(&w), before);
    // The live handles work, and the new body is the one named in contacts.
    assert_eq!(w.sphere(c).unwrap().position, DVec3::new(8.0, 5.0, 5.0));
    w.set_velocities(&[a, c], &[DVec3::new(20.0, 0.0, 0.0), DVec3::new(-20.0, 0.0, 0.0)]).unwrap();
    let contacts = w.step(0.2).unwrap();
    assert!(contacts.iter().any(|x| (x.body, x.touched) == (a, Touched::Body(c))), "{contacts:?}");
    // Once the slot is empty again, the stale handles say so.
    w.remove_sphere(c).unwrap();
    for handle in [b, c] {
        assert_eq!(w.sphere(handle), Err(VadopError::StaleHandle { handle, current: None }));
    }
    assert_eq!(VadopError::StaleHandle { handle: c, current: None }.to_string(), "body 1v1 was removed");
    // A generation the slot never had names nothing.
    let future = BodyHandle::from_bits(b.to_bits() + (5 << 32));
    assert_eq!(w.set_velocity(future, DVec3::X), Err(VadopError::NoSuchBody(future)));
}

#[test]
fn huge_and_tiny_values_are_rejected_before_they_overflow() {
    let (mut w, [a, _]) = world();
    let before = snapshot(&w);
    let cases: Vec<(Sphere, &str)> = vec![
        (Sphere { velocity: DVec3::new(1e51, 0.0, 0.0), ..sphere(8.0) }, "velocity 1e51 is out of range"),
        (Sphere { mass: 1e60, ..sphere(8.0) }, "mass 1e60 is out of range"),
        (Sphere { mass: 1e-60, ..sphere(8.0) }, "inverse mass 1e60 is out of range"),
        (Sphere { mass: 5e-324, ..sphere(8.0) }, "inverse mass inf"),
        (Sphere { mass: f64::INFINITY, ..sphere(8.0) }, "mass must be"),
    ];
    for (bad, message) in cases {
        let err = w.add_sphere(bad).unwrap_err();
        assert!(err.to_string().contains(message), "{err} should say {message}");
        assert_eq!(snapshot(&w), before);
    }
    assert!(matches!(w.set_velocity(a, DVec3::new(0.0, -1e300, 0.0)), Err(VadopError::OutOfRange { .. })));
    assert_eq!(snapshot(&w), before);
    // A box far beyond 1e50 would square to infinity.
    let err = BoxBounds::cube(1e200).unwrap_err();
    assert!(matches!(err, VadopError::OutOfRange { what: "box corner", .. }), "{err}");
    // At the limit itself everything still works: a head-on pair 1e49 wide is found.
    let mut big = World::new(BoxBounds::cube(1e50).unwrap(), WorldConfig::default()).unwrap();
    let r = 1e48;
    big.add_sphere(Sphere {
        position: DVec3::new(2.0 * r, 5e49, 5e49),
        velocity: DVec3::new(1e49, 0.0, 0.0),
        radius: r,
        mass: 1e50,
    })
    .unwrap();
    let right = big
        .add_sphere(Sphere {
            position: DVec3::new(9e49, 5e49, 5e49),
            velocity: DVec3::new(-1e49, 0.0, 0.0),
            radius: r,
            mass: 1e-50,
        })
        .unwrap();
    let contacts = big.step(10.0).unwrap();
    assert!(contacts.iter().any(|c| c.touched == Touched::Body(right)), "{contacts:?}");
}

#[test]
fn scenes_too_large_to_generate_are_rejected_at_once() {
    let err = vadop::scene::PaperScene::new(10_000_000_000_000, 0.05, 1.0).build().unwrap_err();
    assert!(err.to_string().contains("at most"), "{err}");
}

/// Regression (found from Python): one out-of-range velocity in a batch used to be rejected only
/// after the rows before it were applied.
#[test]
fn set_velocities_is_all_or_none() {
    let (mut w, [a, b]) = world();
    let before = snapshot(&w);
    let err = w.set_velocities(&[a, b], &[DVec3::new(3.0, 0.0, 0.0), DVec3::new(1e60, 0.0, 0.0)]).unwrap_err();
    assert!(matches!(err, VadopError::OutOfRange { .. }), "{err}");
    let unknown = BodyHandle::from_bits(7);
    assert_eq!(w.set_velocities(&[a, unknown], &[DVec3::X, DVec3::X]).unwrap_err(), VadopError::NoSuchBody(unknown));
    assert!(matches!(w.set_velocities(&[a, b], &[DVec3::X]).unwrap_err(), VadopError::LengthMismatch { .. }));
    assert_eq!(snapshot(&w), before);
    w.set_velocities(&[a, b], &[DVec3::new(3.0, 0.0, 0.0), DVec3::new(-3.0, 0.0, 0.0)]).unwrap();
    assert_eq!(w.sphere(b).unwrap().velocity, DVec3::new(-3.0, 0.0, 0.0));
}

/// Regression: the speed's square underflowed to 0 below 1e-162, so a tiny speed times a huge dt
/// escaped the absurd-speed check and the step never returned.
#[test]
fn tiny_speed_times_huge_step_is_an_absurd_speed() {
    let (mut w, [a, _]) = world();
    w.set_velocity(a, DVec3::new(1e-200, 0.0, 0.0)).unwrap();
    let before = snapshot(&w);
    assert!(matches!(w.step(1e300).unwrap_err(), VadopError::AbsurdSpeed { body, .. } if body == a));
    assert_eq!(snapshot(&w), before);
}

/// Regression: bodies at rest passed every check, and time overflowing to infinity turned every
/// position into NaN without an error.
#[test]
fn time_never_overflows() {
    let (mut w, handles) = world();
    w.set_velocities(&handles, &[DVec3::ZERO, DVec3::ZERO]).unwrap();
    w.step(1e308).unwrap();
    let before = snapshot(&w);
    assert!(matches!(w.step(1e308).unwrap_err(), VadopError::TimeOverflow { .. }));
    assert_eq!(snapshot(&w), before);
    assert!(w.spheres().all(|(_, s)| s.position.is_finite()));
}

/// Regression: an orientation's squared length overflowed above ~1e154 (the cube was stored as
/// [0, 0, 0, 0] and collided as a point, and its saved state was refused) and underflowed below
/// ~1e-154 (refused as zero). Any finite non-zero quaternion is a rotation: a cube given one
/// scaled by a power of two, from 2^1000 to subnormal, collides exactly as with the unit one in a
/// brute-force run, and its world saves and resumes.
#[test]
fn huge_and_tiny_orientations_normalise_exactly() {
    use glam::DQuat;
    use vadop::shape::Shape;
    use vadop::{Body, BodyShape};
    let run = |method: Method, orientation: DQuat| {
        let config = WorldConfig { method, mode: Mode::Detect, contact_ends: true, ..WorldConfig::default() };
        let mut w = World::new(BoxBounds::cube(10.0).unwrap(), config).unwrap();
        let cube = w.add_shape(Shape::Cuboid { half_extents: DVec3::splat(0.5) }).unwrap();
        let body = Body {
            shape: BodyShape::Shape(cube),
            position: DVec3::new(2.0, 5.0, 5.0),
            orientation,
            velocity: DVec3::new(1.0, 0.0, 0.0),
            angular_velocity: DVec3::ZERO,
            mass: 1.0,
        };
        w.add_body(body).unwrap();
        w.add_body(Body { position: DVec3::new(5.0, 5.0, 5.0), velocity: DVec3::ZERO, ..body }).unwrap();
        let first = w.step(1.0).unwrap().to_vec();
        let path = std::env::temp_dir().join(format!("vadop-bad-input-{}-{method:?}.json", std::process::id()));
        w.save(&path).unwrap();
        let mut resumed = World::load(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let second = resumed.step(4.0).unwrap().to_vec();
        let bodies: Vec<_> = resumed.bodies().map(|(_, b)| b).collect();
        (first, second, resumed.contact_ends().to_vec(), bodies)
    };
    // 45 degrees about z: the cubes' edges lead, 0.71 from their centres, not 0.5 (nor 0, points).
    let turned = DQuat::from_xyzw(0.0, 0.0, (0.125 * std::f64::consts::PI).sin(), (0.125 * std::f64::consts::PI).cos());
    let reference = run(Method::Brute, turned);
    assert!(reference.0.is_empty(), "{:?}", reference.0);
    let [touch] = &reference.1[..] else { panic!("one contact expected, got {:?}", reference.1) };
    assert!((touch.time - (3.0 - 2.0f64.sqrt())).abs() < 1e-5, "the cubes touched at {}", touch.time);
    assert!(!reference.2.is_empty());
    // The same quaternion scaled by an exact power of two into ordinary lengths, where squaring
    // it neither overflows nor underflows.
    let ordinary = |mut q: DQuat| {
        let largest = |q: DQuat| q.to_array().into_iter().fold(0.0, |m: f64, c| m.max(c.abs()));
        while largest(q) > 1e100 {
            q *= 2f64.powi(-500);
        }
        while largest(q) < 1e-100 {
            q *= 2f64.powi(500);
        }
        q
    };
    let odd = [
        turned * 2f64.powi(1000),
        turned * 2f64.powi(-1000),
        DQuat::from_xyzw(0.0, 0.0, 0.0, 1e155),
        DQuat::from_xyzw(0.0, 0.0, 0.0, 1e300),
        DQuat::from_xyzw(0.0, 0.0, 0.0, f64::MAX),
        DQuat::from_xyzw(0.0, 0.0, 0.0, 1e-300),
        DQuat::from_xyzw(0.0, 0.0, 0.0, 5e-324),
        DQuat::from_xyzw(0.0, 0.0, 5e-324, 1e-323),
        DQuat::from_xyzw(1e-300, -2e-300, 3e-310, 4e-300),
    ];
    for q in odd {
        let usual = ordinary(q);
        assert_ne!(usual, q);
        assert_eq!(run(Method::Vadop, q), run(Method::Brute, usual), "orientation {q:?}");
    }
    assert_eq!(run(Method::Vadop, turned * 2f64.powi(1000)), reference);
    // Zero, NaN and infinity stay errors.
    let mut w = World::new(BoxBounds::cube(10.0).unwrap(), WorldConfig::default()).unwrap();
    let cube = w.add_shape(Shape::Cuboid { half_extents: DVec3::splat(0.5) }).unwrap();
    for bad in [[0.0; 4], [0.0, 0.0, 0.0, f64::NAN], [0.0, 0.0, 0.0, f64::INFINITY], [0.0, -0.0, 0.0, -0.0]] {
        let body = Body {
            shape: BodyShape::Shape(cube),
            position: DVec3::splat(5.0),
            orientation: DQuat::from_array(bad),
            velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            mass: 1.0,
        };
        assert!(matches!(w.add_body(body), Err(VadopError::BadOrientation(_))), "{bad:?}");
        assert!(matches!(w.add_static(cube, DVec3::splat(5.0), body.orientation), Err(VadopError::BadOrientation(_))));
    }
}
