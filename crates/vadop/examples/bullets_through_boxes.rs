//! Fast small bullets shot through a spinning crowd of boxes, in detect mode with contact ends on:
//! every time a bullet enters a box and every time it leaves it, with the exact instants, however
//! thin the box and however fast the bullet (a hundred of its diameters per frame).
//!
//! ```sh
//! cargo run --release --example bullets_through_boxes
//! ```

use glam::{DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeSet;
use vadop::shape::Shape;
use vadop::{Body, BodyHandle, BodyShape, BoxBounds, Contact, Mode, Sphere, Touched, VadopError, World, WorldConfig};

const FRAMES: usize = 5;
const DT: f64 = 1.0 / 30.0;
/// Boxes per side of the crowd's cubic grid, and their spacing.
const CROWD: usize = 5;
const SPACING: f64 = 2.0;
const BULLETS: usize = 8;
/// Bullets are spheres of radius 0.05 flying at 300 units per second: 100 diameters per frame.
const BULLET_RADIUS: f64 = 0.05;
const BULLET_SPEED: f64 = 300.0;

fn main() -> Result<(), VadopError> {
    // Detect mode: bodies pass through each other and report it; contact ends say when they part.
    let config = WorldConfig { mode: Mode::Detect, contact_ends: true, ..WorldConfig::default() };
    let mut world = World::new(BoxBounds::new(DVec3::ZERO, DVec3::new(40.0, 20.0, 20.0))?, config)?;
    let mut rng = ChaCha8Rng::seed_from_u64(7);

    // A crowd of thin boxes around (20, 10, 10), each turned at random and spinning.
    let plank = world.add_shape(Shape::Cuboid { half_extents: DVec3::new(0.15, 0.6, 0.45) })?;
    let corner = DVec3::new(20.0, 10.0, 10.0) - SPACING * (CROWD - 1) as f64 / 2.0;
    let mut boxes = BTreeSet::new();
    for k in 0..CROWD.pow(3) {
        let cell = DVec3::new((k % CROWD) as f64, (k / CROWD % CROWD) as f64, (k / CROWD / CROWD) as f64);
        let spin_axis = DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 1.0).normalize();
        boxes.insert(world.add_body(Body {
            shape: BodyShape::Shape(plank),
            position: corner + SPACING * cell,
            orientation: DQuat::from_rotation_y(rng.random_range(-0.5..0.5)),
            velocity: DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), 0.0),
            angular_velocity: spin_axis * rng.random_range(2.0..8.0),
            mass: 1.0,
        })?);
    }

    // Bullets from x = 8 along +x, each aimed at a row of the crowd (they bounce off the far wall
    // and come back through it).
    let mut bullets = BTreeSet::new();
    for _ in 0..BULLETS {
        let mut aim = || SPACING * rng.random_range(0..CROWD) as f64 + rng.random_range(-0.3..0.3);
        let (y, z) = (corner.y + aim(), corner.z + aim());
        bullets.insert(world.add_sphere(Sphere {
            position: DVec3::new(8.0, y, z),
            velocity: DVec3::new(BULLET_SPEED, 0.0, 0.0),
            radius: BULLET_RADIUS,
            mass: 0.01,
        })?);
    }
    let diameters_per_frame = BULLET_SPEED * DT / (2.0 * BULLET_RADIUS);
    println!(
        "{} spinning boxes, {} bullets at {diameters_per_frame} diameters per frame\n",
        boxes.len(),
        bullets.len()
    );

    let mut inside: BTreeSet<(BodyHandle, BodyHandle)> = BTreeSet::new();
    for frame in 1..=FRAMES {
        let starts = world.step(DT)?.to_vec();
        let ends = world.contact_ends().to_vec();
        // A contact names its lower handle first: the box (the boxes were added first), touching
        // the bullet.
        let bullet_of = |c: &Contact| match c.touched {
            Touched::Body(other) if bullets.contains(&other) && boxes.contains(&c.body) => Some((other, c.body)),
            _ => None,
        };
        let mut events: Vec<(f64, &str, BodyHandle, BodyHandle, DVec3)> = Vec::new();
        for (contacts, what) in [(&starts, "enters"), (&ends, "leaves")] {
            for c in contacts.iter() {
                if let Some((bullet, plank)) = bullet_of(c) {
                    events.push((c.time, what, bullet, plank, c.point));
                }
            }
        }
        events.sort_by(|a, b| a.0.total_cmp(&b.0));
        println!("frame {frame}:");
        for &(time, what, bullet, plank, point) in &events {
            println!(
                "  {time:.6} s  bullet {bullet} {what} box {plank} at ({:.3}, {:.3}, {:.3})",
                point.x, point.y, point.z
            );
            // Every exit follows its entry: a bullet is inside a box from one to the other.
            let pair = (bullet, plank);
            assert!(if what == "enters" { inside.insert(pair) } else { inside.remove(&pair) }, "{pair:?}");
        }
        let crowd =
            starts.iter().filter(|c| matches!(c.touched, Touched::Body(other) if boxes.contains(&other))).count();
        let walls = starts.iter().filter(|c| matches!(c.touched, Touched::Wall(_))).count();
        println!(
            "  {} entries, {} exits; {crowd} contacts between boxes, {walls} with the walls; {} bullets inside a box now\n",
            events.iter().filter(|e| e.1 == "enters").count(),
            events.iter().filter(|e| e.1 == "leaves").count(),
            inside.len()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn runs() {
        super::main().unwrap();
    }
}
