//! Shapes of every kind coming to rest under gravity in simulate mode with restitution below 1
//! (the rest rule, `vadop::response::rest`): on the floor, on each other and on a bumpy static
//! mesh, every body lying still within a few seconds with nothing sunk into anything; every
//! method matches brute force to the bit; a settled world resumes bit-exactly.

mod common;

use glam::{DQuat, DVec3};
use vadop::narrow_phase::shapes::SHAPE_CONTACT_TOLERANCE;
use vadop::scene::{ShapesScene, FRAMES_PER_SECOND};
use vadop::shape::Shape;
use vadop::{Body, BodyShape, BoxBounds, Method, Mode, Rest, World, WorldConfig};

const DT: f64 = 1.0 / FRAMES_PER_SECOND;

fn config(method: Method, gravity: DVec3) -> WorldConfig {
    WorldConfig { gravity, restitution: 0.5, friction: 0.3, method, mode: Mode::Simulate, ..WorldConfig::default() }
}

fn crowd(bodies: usize, seed: u64) -> vadop::scene::Scene {
    ShapesScene { bodies, packing_fraction: 0.05, max_speed: 0.3, max_spin: 0.3, floor: true, seed }.build().unwrap()
}

fn resting(world: &World) -> usize {
    world.bodies().filter(|(h, b)| b.mass.is_finite() && world.rest(*h).unwrap() == Rest::Still).count()
}

/// Cuboids, capsules, cylinders, cones, rocks and balls, thrown spinning, settle on the box
/// floor and on each other (gravity down z), and on the scene's bumpy mesh floor (gravity down
/// y): within five seconds every body rests (balls may roll on), and at every frame end no body overlaps
/// another, the mesh or a wall by more than the contact tolerance (parry's own contact query; the
/// pair's tolerance, 1e-6 of the sum of the bounding radii, as the narrow phase states it: a check
/// against the smaller radius alone is about twice as strict, and other seeds of this scene failed
/// it within the pair's tolerance).
///
/// This failed three ways before the rule took shapes: a shape whose bounce off a body lying
/// still was judged by its centre's velocity kept turning into it (zero impulses, over and
/// over); a static body's predictions were voided by a parting that rewrote its velocity, so a
/// shape passed into the mesh (3e-3 deep); and bodies that a stalled search left touching were
/// taken, once moved, for a contact in progress and passed into each other (8e-3), or sank a
/// tolerance deeper at each stall (up to 1e-4 of their size).
#[test]
fn a_crowd_of_every_shape_settles_with_nothing_sinking() {
    for (seed, gravity) in [(3, DVec3::new(0.0, 0.0, -9.81)), (1, DVec3::new(0.0, -9.81, 0.0))] {
        let (world, _) = settle_checking_overlaps(seed, gravity);
        // Balls may still roll on the floor; every other shape lies still.
        for (handle, body) in world.bodies().filter(|(_, b)| b.mass.is_finite()) {
            match body.shape {
                BodyShape::Sphere { .. } => {
                    assert_ne!(world.rest(handle).unwrap(), Rest::Falling, "seed {seed}: {handle}")
                }
                BodyShape::Shape(_) => {
                    assert_eq!(world.rest(handle).unwrap(), Rest::Still, "seed {seed}: {handle}");
                    assert!(body.velocity == DVec3::ZERO && body.angular_velocity == DVec3::ZERO, "{handle}: {body:?}");
                }
            }
        }
    }
}

/// The crowd of `seed` under `gravity` stepped 150 frames, asserting at every frame end that
/// nothing overlaps anything by more than its contact tolerance: the world, and the deepest
/// overlap met (in contact tolerances).
fn settle_checking_overlaps(seed: u64, gravity: DVec3) -> (World, f64) {
    let mut world = crowd(120, seed).world(config(Method::Auto, gravity)).unwrap();
    let mut deepest = 0.0f64;
    for frame in 0..150 {
        world.step(DT).unwrap();
        let (depth, what) = common::deepest_overlap(&world, common::Overlap::InTolerances);
        assert!(depth <= 1.0, "seed {seed}, frame {frame}: {what} ({depth} contact tolerances)");
        deepest = deepest.max(depth);
    }
    (world, deepest)
}

/// The overlap check of the test above over seeds 1 to 20 under both gravities, each run's
/// deepest overlap printed: the sweep that found a pressed pair sinking a tolerance per new
/// reference (1.72 tolerances, seed 20 under gravity down y) and a shape jammed against the floor
/// at one instant for ever (seed 18 under gravity down z, with 32 rough GJK iterations). About
/// four minutes: `cargo test --release -p vadop --test rest_shapes -- --ignored --nocapture`.
#[test]
#[ignore]
fn twenty_crowds_never_sink_past_the_contact_tolerance() {
    for gravity in [DVec3::new(0.0, 0.0, -9.81), DVec3::new(0.0, -9.81, 0.0)] {
        for seed in 1..=20 {
            let (_, deepest) = settle_checking_overlaps(seed, gravity);
            eprintln!("gravity {gravity}, seed {seed}: deepest overlap {deepest:.3} contact tolerances");
        }
    }
}

/// A cuboid dropped flat onto the floor bounces ever lower and comes to lie still on its face,
/// at its half height above the floor to within the contact tolerance.
#[test]
fn a_dropped_box_lies_still_on_its_face() {
    let mut world =
        World::new(BoxBounds::cube(4.0).unwrap(), config(Method::Auto, DVec3::new(0.0, 0.0, -9.81))).unwrap();
    let slab = world.add_shape(Shape::Cuboid { half_extents: DVec3::new(0.4, 0.3, 0.2) }).unwrap();
    let body = Body {
        shape: BodyShape::Shape(slab),
        position: DVec3::new(2.0, 2.0, 1.5),
        orientation: DQuat::IDENTITY,
        velocity: DVec3::ZERO,
        angular_velocity: DVec3::ZERO,
        mass: 1.0,
    };
    let handle = world.add_body(body).unwrap();
    let mut landings = 0;
    for _ in 0..90 {
        landings += world.step(DT).unwrap().len();
    }
    assert_eq!(world.rest(handle).unwrap(), Rest::Still);
    let lying = world.body(handle).unwrap();
    assert!(landings >= 4, "it bounces before it rests: {landings} landings");
    assert!((lying.position.z - 0.2).abs() <= SHAPE_CONTACT_TOLERANCE, "{lying:?}");
    assert!(lying.velocity == DVec3::ZERO && lying.angular_velocity == DVec3::ZERO, "{lying:?}");
}

/// Every continuous method finds the settling crowd's contacts bit-identical to brute force,
/// and the settled world, saved and loaded, steps on bit-exactly.
#[test]
fn every_method_settles_shapes_as_brute_force_does() {
    let scene = crowd(40, 5);
    let build = |method| scene.world(config(method, DVec3::new(0.0, -9.81, 0.0))).unwrap();
    let mut oracle = common::every_method_beside_oracle(build, 90, DT);
    assert!(resting(&oracle) > 20, "most shapes rest: {}", resting(&oracle));
    common::assert_resumes_bit_exactly(&mut oracle, "rest-shapes", 30, DT);
}
