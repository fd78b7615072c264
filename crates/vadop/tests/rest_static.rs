//! Resting on static geometry (the rest rule, `vadop::response::rest`): balls rest on static
//! half-spaces, spheres and cuboids under gravity in simulate mode with restitution below 1, as
//! on the walls, and a body resting on static geometry in an elastic world or in detect mode lies
//! still instead of bouncing without end, as a shape collapsing onto the floor in detect mode
//! does. Nothing sinks into a wall or a static body; every
//! method matches brute force to the bit; a saved world at rest resumes bit-exactly.

mod common;

use glam::{DQuat, DVec3};
use vadop::scene::{PaperScene, ShapesScene, FRAMES_PER_SECOND};
use vadop::shape::Shape;
use vadop::{BoxBounds, Method, Mode, Rest, Sphere, Touched, World, WorldConfig};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;
const G: f64 = 9.81;

fn config(method: Method, mode: Mode, restitution: f64, friction: f64) -> WorldConfig {
    WorldConfig { gravity: DVec3::new(0.0, 0.0, -G), restitution, friction, method, mode, ..WorldConfig::default() }
}

fn ball(position: DVec3, velocity: DVec3) -> Sphere {
    Sphere { position, velocity, radius: 0.5, mass: 1.0 }
}

fn resting(world: &World) -> usize {
    world.bodies().filter(|(h, b)| b.mass.is_finite() && world.rest(*h).unwrap() != Rest::Falling).count()
}

/// A ball dropped on a static half-space lands at the closed form's instants, as on a wall, and
/// lies still on it; on a tilted one, a static ball, a static cuboid and a mesh floor (the shapes
/// scene's), balls settle too, nothing sunk.
#[test]
fn balls_rest_on_static_geometry() {
    let e = 0.5;
    let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto, Mode::Simulate, e, 0.0)).unwrap();
    let floor = world.add_shape(Shape::HalfSpace { normal: DVec3::Z }).unwrap();
    world.add_static(floor, DVec3::new(5.0, 5.0, 2.0), DQuat::IDENTITY).unwrap();
    let b = world.add_sphere(ball(DVec3::new(5.0, 5.0, 6.5), DVec3::ZERO)).unwrap();
    let mut contacts = Vec::new();
    for _ in 0..150 {
        contacts.extend(world.step(DT).unwrap().iter().copied());
    }
    let landings = common::closed_form_landings(4.0, G, e, 0.5);
    assert_eq!(contacts.len(), landings.len(), "{contacts:?}");
    for (k, (c, time)) in contacts.iter().zip(landings).enumerate() {
        assert!(matches!(c.touched, Touched::Body(_)));
        assert!((c.time - time).abs() <= 1e-6, "landing {k} at {} not {time}", c.time);
    }
    assert_eq!(world.rest(b).unwrap(), Rest::Still);
    let s = world.sphere(b).unwrap();
    assert!((s.position.z - 2.5).abs() <= 1e-6 && s.velocity == DVec3::ZERO, "{s:?}");

    let mut world = World::new(BoxBounds::cube(14.0).unwrap(), config(Method::Auto, Mode::Simulate, e, 0.0)).unwrap();
    let knob = world.add_shape(Shape::Sphere { radius: 1.0 }).unwrap();
    world.add_static(knob, DVec3::new(3.0, 5.0, 3.5), DQuat::IDENTITY).unwrap();
    let slab = world.add_shape(Shape::Cuboid { half_extents: DVec3::new(1.5, 1.5, 0.3) }).unwrap();
    world.add_static(slab, DVec3::new(7.5, 7.0, 4.0), DQuat::IDENTITY).unwrap();
    world.add_static(slab, DVec3::new(10.5, 3.0, 5.0), DQuat::from_rotation_x(0.3)).unwrap();
    for k in 0..4 {
        let (dx, z) = (0.13 * k as f64, 7.0 + 1.1 * k as f64);
        world.add_sphere(ball(DVec3::new(3.0 + dx, 5.0, z), DVec3::ZERO)).unwrap();
        world.add_sphere(ball(DVec3::new(7.2 + dx, 7.0, z), DVec3::new(0.3, 0.0, 0.0))).unwrap();
        world.add_sphere(ball(DVec3::new(10.5 + dx, 3.0, z), DVec3::ZERO)).unwrap();
    }
    for frame in 0..300 {
        world.step(DT).unwrap();
        let violation = common::sunk(&world, 1e-5);
        assert!(violation.is_none(), "frame {frame}: {violation:?}");
    }
    let moving: Vec<_> = world.spheres().filter(|(h, _)| world.rest(*h).unwrap() == Rest::Falling).collect();
    assert!(moving.is_empty(), "every ball rests on the static bodies or the floor: {moving:?}");
}

/// In detect mode under gravity, a spinning cylinder of the shapes scene collapsing onto the box
/// floor (restitution 1/2, bounces ever closer together) stays out of it: the search against the
/// floor stalls in the collapse, and the jam rule stops the body there instead of starting it
/// afresh (it sank 1.4e-3 deep in 0.3 s that way, each new search stalling again).
#[test]
fn a_spinning_shape_chattering_on_the_floor_stays_out_of_it() {
    let scene = ShapesScene { bodies: 60, packing_fraction: 0.05, max_speed: 0.3, max_spin: 0.3, floor: true, seed: 2 }
        .build()
        .unwrap();
    let mut world = scene.world(config(Method::Auto, Mode::Detect, 0.5, 0.3)).unwrap();
    for frame in 0..45 {
        world.step(DT).unwrap();
        let violation = common::sunk(&world, 1e-5);
        assert!(violation.is_none(), "frame {frame}: {violation:?}");
    }
}

/// A body resting on static geometry where nothing comes to rest (an elastic world, detect mode)
/// would bounce ever more often: the jam rule stops it and it lies still, its energy kept; a ball
/// dropped there keeps bouncing elastically.
#[test]
fn resting_on_static_geometry_without_the_rest_rule_lies_still() {
    for mode in [Mode::Detect, Mode::Simulate] {
        let mut world = World::new(BoxBounds::cube(10.0).unwrap(), config(Method::Auto, mode, 1.0, 0.0)).unwrap();
        let floor = world.add_shape(Shape::HalfSpace { normal: DVec3::Z }).unwrap();
        world.add_static(floor, DVec3::new(5.0, 5.0, 2.0), DQuat::IDENTITY).unwrap();
        let on_it = world.add_sphere(ball(DVec3::new(3.0, 5.0, 2.5), DVec3::ZERO)).unwrap();
        let dropped = world.add_sphere(ball(DVec3::new(7.0, 5.0, 4.5), DVec3::ZERO)).unwrap();
        let energy = |w: &World| w.kinetic_energy() + w.potential_energy();
        let start = energy(&world);
        let mut bounces = 0;
        for _ in 0..90 {
            bounces += world
                .step(DT)
                .unwrap()
                .iter()
                .filter(|c| c.body == dropped || c.touched == Touched::Body(dropped))
                .count();
        }
        assert_eq!(world.rest(on_it).unwrap(), Rest::Still, "{mode:?}");
        assert_eq!(world.rest(dropped).unwrap(), Rest::Falling, "{mode:?}");
        assert_eq!(bounces, 2, "{mode:?}: the dropped ball bounces back to its height");
        assert!((energy(&world) - start).abs() <= 1e-12 * start.abs(), "{mode:?}: {} to {}", start, energy(&world));
    }
}

/// Every continuous method settles balls on static geometry (a slab, a knob, a tilted half-space)
/// to the oracle's bits, and a world saved while they rest resumes to the same bits.
#[test]
fn balls_settling_on_static_geometry_match_brute_force_and_resume_bit_exactly() {
    let mut scene =
        PaperScene { bodies: 150, packing_fraction: 0.1, max_speed: 1.0, radius: 0.5, seed: 11 }.build().unwrap();
    let side = scene.bounds.max.x;
    let centre = DVec3::splat(0.5 * side);
    // A slab in the middle, a knob in a bottom corner, a tilted floor; the balls start clear of
    // them (the world refuses overlapping bodies at the first step).
    let statics = [
        (Shape::Cuboid { half_extents: DVec3::new(0.25 * side, 0.25 * side, 0.2) }, centre, DQuat::IDENTITY),
        (Shape::Sphere { radius: 1.0 }, DVec3::new(0.2 * side, 0.2 * side, 0.0), DQuat::IDENTITY),
        (Shape::HalfSpace { normal: DVec3::Z }, DVec3::new(0.0, 0.0, -1.0), DQuat::from_rotation_x(0.2)),
    ];
    scene.spheres.retain(|s| {
        let clear = |p: DVec3| (s.position - p).length() > s.radius + 0.3 * side;
        clear(centre) && clear(statics[1].1) && s.position.z - s.radius > 0.2 * side
    });
    let build = |method| {
        let mut world = scene.world(config(method, Mode::Simulate, 0.4, 0.3)).unwrap();
        for (shape, position, orientation) in &statics {
            let id = world.add_shape(shape.clone()).unwrap();
            world.add_static(id, *position, *orientation).unwrap();
        }
        world
    };
    let mut oracle = common::every_method_beside_oracle(build, 150, DT);
    assert!(resting(&oracle) > 0, "some balls rest");
    common::assert_resumes_bit_exactly(&mut oracle, "rest-static", 60, DT);
}
