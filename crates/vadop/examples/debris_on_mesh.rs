//! Debris of mixed shapes thrown down onto a static triangle-mesh terrain under gravity, in
//! simulate mode with restitution and friction: the bounces off the terrain, the impacts between
//! pieces, the energy (kinetic, of translation and spin, plus potential) that every impact takes
//! a share of, and the pieces coming to rest on the hills and on each other. Nothing passes
//! through the terrain, however fast it falls.
//!
//! ```sh
//! cargo run --release --example debris_on_mesh
//! ```

use glam::{DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vadop::shape::Shape;
use vadop::{Body, BodyShape, BoxBounds, Mode, Rest, Touched, VadopError, World, WorldConfig};

const FRAMES: usize = 240;
const DT: f64 = 1.0 / 30.0;
/// Terrain cells per side: the mesh spans the box's floor, a little beyond.
const CELLS: u32 = 16;
const SIDE: f64 = 24.0;
const HEIGHT: f64 = 16.0;
const PIECES: usize = 30;

/// Height of the terrain's rolling hills at (x, z).
fn ground(x: f64, z: f64) -> f64 {
    2.0 + 1.2 * (x / 3.0).sin() * (z / 4.0).cos()
}

fn main() -> Result<(), VadopError> {
    // Gravity down the terrain's height axis, y.
    let gravity = DVec3::new(0.0, -9.81, 0.0);
    let config =
        WorldConfig { mode: Mode::Simulate, restitution: 0.6, friction: 0.4, gravity, ..WorldConfig::default() };
    let mut world = World::new(BoxBounds::new(DVec3::ZERO, DVec3::new(SIDE, HEIGHT, SIDE))?, config)?;

    // The terrain: a triangulated height field over the box's floor, fixed in place.
    let step = (SIDE + 2.0) / CELLS as f64;
    let at = |i: u32| -1.0 + step * i as f64;
    let vertices = (0..=CELLS).flat_map(|i| (0..=CELLS).map(move |k| DVec3::new(at(i), ground(at(i), at(k)), at(k))));
    let row = CELLS + 1;
    let triangles = (0..CELLS * CELLS).flat_map(|c| {
        let v = (c / CELLS) * row + c % CELLS;
        [[v, v + 1, v + row], [v + 1, v + row + 1, v + row]]
    });
    let terrain = Shape::TriMesh { vertices: vertices.collect(), triangles: triangles.collect() };
    let terrain = world.add_shape(terrain)?;
    let terrain = world.add_static(terrain, DVec3::ZERO, DQuat::IDENTITY)?;

    // The debris: six kinds of piece, each under a unit across.
    let kinds = [
        Shape::Sphere { radius: 0.4 },
        Shape::Cuboid { half_extents: DVec3::new(0.5, 0.25, 0.2) },
        Shape::Capsule { half_height: 0.35, radius: 0.2 },
        Shape::Cylinder { half_height: 0.25, radius: 0.35 },
        Shape::Cone { half_height: 0.35, radius: 0.3 },
        Shape::ConvexHull {
            points: vec![
                DVec3::new(0.45, 0.0, 0.0),
                DVec3::new(-0.3, 0.3, 0.1),
                DVec3::new(-0.2, -0.35, 0.15),
                DVec3::new(0.05, 0.1, -0.4),
                DVec3::new(0.1, -0.05, 0.4),
            ],
        },
    ];
    let kinds = kinds.into_iter().map(|shape| world.add_shape(shape)).collect::<Result<Vec<_>, _>>()?;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for k in 0..PIECES {
        let position =
            DVec3::new(3.0 + 3.0 * (k % 6) as f64, 7.0 + 2.0 * (k / 18) as f64, 3.0 + 3.5 * (k / 6 % 3) as f64);
        let random = |rng: &mut ChaCha8Rng, scale: f64| {
            DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)) * scale
        };
        world.add_body(Body {
            shape: BodyShape::Shape(kinds[k % kinds.len()]),
            position,
            orientation: DQuat::from_scaled_axis(random(&mut rng, 3.0)),
            // Thrown down at about half a unit per frame, gravity adding as much each second.
            velocity: DVec3::new(0.0, -15.0, 0.0) + random(&mut rng, 4.0),
            angular_velocity: random(&mut rng, 6.0),
            mass: world.shape(kinds[k % kinds.len()])?.volume(),
        })?;
    }

    let energy_now = |world: &World| world.kinetic_energy() + world.potential_energy();
    let start = energy_now(&world);
    println!("{PIECES} pieces thrown onto a terrain of {} triangles; energy {start:.2}\n", 2 * CELLS * CELLS);
    println!("frames    terrain bounces  impacts  wall hits  energy (kinetic and potential)  lying still");
    let (mut bounces, mut impacts, mut walls) = (0, 0, 0);
    let mut energy = start;
    for frame in 1..=FRAMES {
        for c in world.step(DT)? {
            match c.touched {
                Touched::Body(other) if c.body == terrain || other == terrain => bounces += 1,
                Touched::Body(_) => impacts += 1,
                Touched::Wall(_) => walls += 1,
            }
        }
        // Every impact keeps or loses energy (restitution below 1, friction); only the rest
        // rule's hops may add a trace, far below what a frame can show.
        let now = energy_now(&world);
        assert!(now <= energy + 1e-6 * start.abs(), "frame {frame}: {energy} -> {now}");
        energy = now;
        // Nothing gets through the terrain: every centre stays above it.
        for (handle, body) in world.bodies().filter(|(handle, _)| *handle != terrain) {
            let p = body.position;
            assert!(p.y > ground(p.x, p.z) - 0.3, "frame {frame}: body {handle} at {p} is under the terrain");
        }
        if frame % 10 == 0 {
            let still =
                world.bodies().filter(|(handle, _)| *handle != terrain && world.rest(*handle) == Ok(Rest::Still));
            println!(
                "{:>3}..{frame:<3}   {bounces:>15}  {impacts:>7}  {walls:>9}  {energy:>30.2}  {:>11}",
                frame - 9,
                still.count()
            );
            (bounces, impacts, walls) = (0, 0, 0);
        }
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
