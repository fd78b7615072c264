//! A granular pile: spheres dropped into a box under gravity, with restitution 0.5, bounce ever
//! lower until they come to rest on the floor and on each other (the rest rule,
//! `vadop::response::rest`), and the frames, busy while the pile forms, fall quiet once it lies
//! still. Every contact is found at its exact instant; nothing sinks into the floor or into
//! another sphere, and the energy (kinetic plus potential) only falls, but for the rule's hops of
//! a quarter of 1e-4 radius.
//!
//! ```sh
//! cargo run --release --example granular_pile
//! ```

use glam::DVec3;
use vadop::response::rest::REST_HEIGHT;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{Rest, VadopError, WorldConfig};

const BODIES: usize = 400;
const FRAMES: usize = 240;

fn main() -> Result<(), VadopError> {
    // One-diameter balls under the Earth's pull (the diameter is the unit of length), placed as
    // the paper's scene at packing 0.2 with speeds up to half a diameter per frame.
    let scene = PaperScene { bodies: BODIES, packing_fraction: 0.2, max_speed: 0.5, radius: 0.5, seed: 4 }.build()?;
    let config = WorldConfig { gravity: DVec3::new(0.0, 0.0, -9.81), restitution: 0.5, ..WorldConfig::default() };
    let mut world = scene.world(config)?;
    let dt = 1.0 / FRAMES_PER_SECOND;
    println!("{BODIES} spheres dropped into a box of side {:.2}\n", scene.bounds.max.x);
    println!("seconds  contacts  rest-rule contacts  lying still  sliding  energy (kinetic + potential)");
    let (mut contacts, mut rests) = (0, 0);
    let mut energy = world.kinetic_energy() + world.potential_energy();
    // A hop parts at half the rest speed, sqrt(2 g REST_HEIGHT r) / 2: at most m v^2 / 2 each.
    let hop = 0.5 * (2.0 * 9.81 * REST_HEIGHT * 0.5f64).sqrt();
    let most_per_hop = 0.5 * scene.spheres[0].mass * hop * hop;
    for frame in 1..=FRAMES {
        contacts += world.step(dt)?.len();
        rests += world.stats().rest_contacts;
        let now = world.kinetic_energy() + world.potential_energy();
        // Restitution below 1 only takes energy away, and a hop adds at most its own.
        let hops = most_per_hop * world.stats().rest_contacts as f64;
        assert!(now <= energy + hops + 1e-12 * energy, "frame {frame}: {energy} -> {now}");
        energy = now;
        let spheres: Vec<_> = world.spheres().collect();
        for (k, (a, sa)) in spheres.iter().enumerate() {
            assert!(sa.position.z >= sa.radius * (1.0 - 1e-9), "frame {frame}: {a} below the floor");
            for (b, sb) in &spheres[k + 1..] {
                let overlap = sa.radius + sb.radius - sa.position.distance(sb.position);
                assert!(overlap < 1e-6, "frame {frame}: {a} and {b} overlap by {overlap:e}");
            }
        }
        if frame % 30 == 0 {
            let count = |rest: fn(Rest) -> bool| spheres.iter().filter(|(h, _)| world.rest(*h).is_ok_and(rest)).count();
            let (still, sliding) = (count(|r| r == Rest::Still), count(|r| matches!(r, Rest::Sliding(_))));
            let seconds = frame as f64 * dt;
            println!("{seconds:>7.0}  {contacts:>8}  {rests:>18}  {still:>11}  {sliding:>7}  {energy:>10.1}");
            (contacts, rests) = (0, 0);
        }
    }
    let moving = world.spheres().filter(|(h, _)| world.rest(*h) != Ok(Rest::Still)).count();
    println!("\n{} of {BODIES} spheres lie still after {} s", BODIES - moving, FRAMES as f64 * dt);
    assert!(moving <= 8, "{moving} spheres still move");
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn runs() {
        super::main().unwrap();
    }
}
