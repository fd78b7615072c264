//! The mixed-shape scene of `vadop-bench peers --scene shapes` and its trajectory file.
//!
//! n rigid bodies of six shapes (spheres, cuboids, capsules, cylinders, cones and a convex hull,
//! each at most one unit across, so speeds are in diameters per frame as in the sphere scene) in
//! detect mode: random orientations, velocities uniform in direction and in speed up to S
//! diameters per frame, and spins of up to [`MAX_SPIN`] radians per frame about one of the body's
//! principal axes. The peers' continuous queries assume a constant angular velocity over a
//! frame; vadop's bodies rotate torque-free, which is a constant angular velocity exactly when
//! the spin is about a principal axis, so both models describe the same motion. A wall bounce
//! would change the spin, so the bodies fill a cube at the packing fraction in the middle of a
//! box whose walls lie farther than any body travels in the run: the paths are straight lines
//! and steady spins, and the export checks that no body reached a wall.
//!
//! The file (little-endian; the readers are `bench/peers/cpp/shapes.h` and
//! `bench/peers/rapier/src/main.rs`, keep them in step): "VADOPSH1", n u64, frames u64, dt f64,
//! box min 3 f64, box max 3 f64; the shape count u64 and per shape its kind u64 ([`Kind`]), three
//! sizes f64 (sphere: radius; cuboid: half extents; capsule, cylinder, cone: half height and
//! radius, along the shape's y axis, a cone's apex at +y), its centre of mass in its own frame 3
//! f64, its bounding radius about that centre f64, and for a convex hull its vertex and triangle
//! counts u64 and that many vertices (3 f64) and triangles (3 u32); then each body's shape index
//! u32; then frames + 1 states, each n x (the shape frame's position 3 f64 and orientation
//! quaternion x, y, z, w 4 f64, the centre of mass's velocity 3 f64, the angular velocity in world
//! axes 3 f64), per unit of time. State k is frame k's start and state k + 1 its end: within the
//! frame the centre of mass moves in a straight line and the body turns about it at the constant
//! angular velocity.

use super::trajectory::{pair_contacts, ExportFiles, PACKING};
use crate::CliResult;
use glam::{DQuat, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use vadop::scene::FRAMES_PER_SECOND;
use vadop::shape::{Shape, ShapeGeometry};
use vadop::{Body, BodyShape, BoxBounds, Method, Mode, Touched, World, WorldConfig};

const MAGIC: &[u8; 8] = b"VADOPSH1";

/// Spins are uniform in [-this, this] radians per frame. Bullet and FCL derive a frame's angular
/// velocity from its start and end orientations, which name the rotation only below 2 pi / 3
/// (Bullet's quaternion from a matrix may take the long way round above it; FCL's angle-axis
/// holds to pi).
pub const MAX_SPIN: f64 = 1.0;

/// How the scene's shapes are written in the trajectory file.
#[derive(Debug, Clone, Copy)]
enum Kind {
    Sphere = 0,
    Cuboid = 1,
    Capsule = 2,
    Cylinder = 3,
    Cone = 4,
    ConvexHull = 5,
}

/// The scene's shapes, each with a bounding radius of at most 0.5 about its centre of mass.
fn shapes() -> [Shape; 6] {
    [
        Shape::Sphere { radius: 0.5 },
        Shape::Cuboid { half_extents: DVec3::new(0.35, 0.25, 0.2) },
        Shape::Capsule { half_height: 0.25, radius: 0.2 },
        Shape::Cylinder { half_height: 0.25, radius: 0.35 },
        Shape::Cone { half_height: 0.3, radius: 0.35 },
        // An irregular hull, its points about its middle (its centre of mass is off the origin).
        Shape::ConvexHull {
            points: [
                [0.42, 0.0, 0.0],
                [-0.3, 0.3, 0.1],
                [-0.2, -0.3, 0.2],
                [0.0, 0.1, -0.38],
                [0.1, 0.0, 0.38],
                [0.2, 0.25, -0.2],
                [-0.25, -0.1, -0.25],
                [0.15, -0.3, -0.1],
            ]
            .map(DVec3::from_array)
            .to_vec(),
        },
    ]
}

/// The shapes' geometries: the same validation and derivation the world does.
fn geometries() -> CliResult<Vec<ShapeGeometry>> {
    shapes().iter().map(|s| s.geometry().map_err(|e| e.to_string())).collect()
}

/// The scene of `n` bodies at speeds of up to `speed` diameters per frame, its box large enough
/// that none reaches a wall in `frames` frames, in detect mode with `method`; and each body's
/// index into [`shapes`] (body k is the world's slot k).
pub fn world(n: usize, speed: f64, frames: u64, method: Method) -> CliResult<(World, Vec<u32>)> {
    let geometries = geometries()?;
    let mean_volume = geometries.iter().map(ShapeGeometry::volume).sum::<f64>() / geometries.len() as f64;
    // The bodies fill a cube at the packing fraction on a jittered lattice of one body per cell.
    let populated = (n as f64 * mean_volume / PACKING).cbrt();
    let per_axis = (n as f64).cbrt().ceil() as usize;
    let spacing = populated / per_axis as f64;
    let diameter = 1.0;
    if spacing < diameter {
        return Err(format!("packing fraction {PACKING} is too dense to place {n} separate bodies"));
    }
    // Each centre of mass moves at most half the free gap between neighbours: none overlap.
    let jitter = 0.5 * (spacing - diameter) * (1.0 - 1e-9) / 3f64.sqrt();
    // The walls lie farther than the fastest body travels in the run, plus its size.
    let margin = speed * frames as f64 + diameter;
    let bounds = BoxBounds::cube(populated + 2.0 * margin).map_err(|e| e.to_string())?;
    let config = WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() };
    let mut world = World::new(bounds, config).map_err(|e| e.to_string())?;
    let mut body_shapes = Vec::with_capacity(geometries.len());
    for shape in shapes() {
        body_shapes.push(match shape {
            // A ball is a sphere body: vadop's closed-form spheres are what its users would take.
            Shape::Sphere { radius } => BodyShape::Sphere { radius },
            other => BodyShape::Shape(world.add_shape(other).map_err(|e| e.to_string())?),
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut kinds = Vec::with_capacity(n);
    let bodies: Vec<Body> = (0..n)
        .map(|k| {
            let cell = DVec3::new(
                (k % per_axis) as f64,
                ((k / per_axis) % per_axis) as f64,
                (k / (per_axis * per_axis)) as f64,
            );
            let jittered =
                DVec3::new(rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0), rng.random_range(-1.0..=1.0));
            let centre = DVec3::splat(margin) + (cell + 0.5) * spacing + jittered * jitter;
            let kind = rng.random_range(0..geometries.len());
            kinds.push(kind as u32);
            let geometry = &geometries[kind];
            let orientation = random_orientation(&mut rng);
            // The principal axes in world axes: the shape frame's orientation less the turn from
            // the shape frame to the body frame.
            let principal = orientation * geometry.body_from_shape().rotation.inverse();
            let axis = [DVec3::X, DVec3::Y, DVec3::Z][rng.random_range(0..3)];
            let spin = rng.random_range(-MAX_SPIN..=MAX_SPIN) * FRAMES_PER_SECOND;
            let velocity = random_direction(&mut rng) * rng.random_range(0.0..=speed) * diameter * FRAMES_PER_SECOND;
            let centre_of_mass = geometry.body_from_shape().inverse().translation;
            Body {
                shape: body_shapes[kind],
                position: centre - orientation * centre_of_mass,
                orientation,
                velocity,
                angular_velocity: principal * axis * spin,
                mass: geometry.volume(),
            }
        })
        .collect();
    world.add_bodies(&bodies).map_err(|e| e.to_string())?;
    Ok((world, kinds))
}

/// Uniform over rotations (Shoemake's subgroup algorithm).
fn random_orientation(rng: &mut ChaCha8Rng) -> DQuat {
    let (u, a, b): (f64, f64, f64) = (
        rng.random_range(0.0..=1.0),
        rng.random_range(0.0..std::f64::consts::TAU),
        rng.random_range(0.0..std::f64::consts::TAU),
    );
    let (s, t) = ((1.0 - u).sqrt(), u.sqrt());
    DQuat::from_xyzw(s * a.sin(), s * a.cos(), t * b.sin(), t * b.cos()).normalize()
}

fn random_direction(rng: &mut ChaCha8Rng) -> DVec3 {
    let z: f64 = rng.random_range(-1.0..=1.0);
    let angle: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * angle.cos(), r * angle.sin(), z)
}

/// The export child job of the shapes scene: steps it in detect mode and writes
/// `dir`/trajectory.bin and `dir`/reference.bin, the pair contacts found by brute force (`brute`)
/// or by the default method. Fails if a body reached a wall: the scene is built so none does.
pub fn export(n: usize, speed: f64, frames: u64, brute: bool, dir: &Path) -> CliResult<()> {
    let (mut world, kinds) = world(n, speed, frames, if brute { Method::Brute } else { Method::Auto })?;
    let dt = 1.0 / FRAMES_PER_SECOND;
    let mut files = ExportFiles::create(dir)?;
    let mut bytes: Vec<u8> = MAGIC.to_vec();
    let bounds = world.bounds();
    put_u64s(&mut bytes, &[n as u64, frames]);
    put_f64s(&mut bytes, &[dt]);
    put_f64s(&mut bytes, &[bounds.min.to_array(), bounds.max.to_array()].concat());
    let geometries = geometries()?;
    put_u64s(&mut bytes, &[geometries.len() as u64]);
    for geometry in &geometries {
        write_shape(&mut bytes, geometry)?;
    }
    bytes.extend(kinds.iter().flat_map(|k| k.to_le_bytes()));
    files.write(&bytes)?;
    let mut contacts = Vec::new();
    for frame in 0..=frames {
        let mut bytes = Vec::with_capacity(n * 13 * 8);
        for (_, body) in world.bodies() {
            let q = body.orientation;
            put_f64s(&mut bytes, &body.position.to_array());
            put_f64s(&mut bytes, &[q.x, q.y, q.z, q.w]);
            put_f64s(&mut bytes, &body.velocity.to_array());
            put_f64s(&mut bytes, &body.angular_velocity.to_array());
        }
        files.write(&bytes)?;
        if frame == frames {
            break;
        }
        let step = world.step(dt).map_err(|e| e.to_string())?;
        if let Some(c) = step.iter().find(|c| matches!(c.touched, Touched::Wall(_))) {
            return Err(format!("body {} reached a wall in frame {frame}: the box is too small", c.body.index()));
        }
        contacts.extend(pair_contacts(frame, step));
    }
    files.finish(contacts)
}

/// One entry of the file's shape table.
fn write_shape(bytes: &mut Vec<u8>, geometry: &ShapeGeometry) -> CliResult<()> {
    let (kind, sizes) = match *geometry.shape() {
        Shape::Sphere { radius } => (Kind::Sphere, [radius, 0.0, 0.0]),
        Shape::Cuboid { half_extents } => (Kind::Cuboid, half_extents.to_array()),
        Shape::Capsule { half_height, radius } => (Kind::Capsule, [half_height, radius, 0.0]),
        Shape::Cylinder { half_height, radius } => (Kind::Cylinder, [half_height, radius, 0.0]),
        Shape::Cone { half_height, radius } => (Kind::Cone, [half_height, radius, 0.0]),
        Shape::ConvexHull { .. } => (Kind::ConvexHull, [0.0; 3]),
        ref other => return Err(format!("the shapes scene has no {other:?}")),
    };
    put_u64s(bytes, &[kind as u64]);
    put_f64s(bytes, &sizes);
    put_f64s(bytes, &geometry.body_from_shape().inverse().translation.to_array());
    put_f64s(bytes, &[geometry.bounding_radius().unwrap_or(0.0)]);
    // The hull's own vertices and faces, as vadop built it: every peer gets the same solid.
    let (vertices, triangles) = match geometry.parry_shape().as_convex_polyhedron() {
        Some(hull) => hull.to_trimesh(),
        None => (Vec::new(), Vec::new()),
    };
    put_u64s(bytes, &[vertices.len() as u64, triangles.len() as u64]);
    for v in &vertices {
        put_f64s(bytes, &v.to_array());
    }
    bytes.extend(triangles.iter().flatten().flat_map(|k| k.to_le_bytes()));
    Ok(())
}

fn put_u64s(bytes: &mut Vec<u8>, values: &[u64]) {
    bytes.extend(values.iter().flat_map(|v| v.to_le_bytes()));
}

fn put_f64s(bytes: &mut Vec<u8>, values: &[f64]) {
    bytes.extend(values.iter().flat_map(|v| v.to_le_bytes()));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::peers::trajectory::exported;

    /// Reads the file the way the peers do and checks that every frame is the motion the peers
    /// assume: the centre of mass moves in a straight line at its velocity and the body turns about
    /// it at its constant angular velocity, from each state to the next; and no body leaves the box.
    #[test]
    fn trajectory_file_holds_straight_paths_and_steady_spins() {
        let (bytes, contacts) = exported("vadop-peers-shapes", |dir| export(60, 5.0, 4, true, dir));
        let at = std::cell::Cell::new(8);
        let take = |count: usize| {
            at.set(at.get() + count);
            &bytes[at.get() - count..at.get()]
        };
        let word = || u64::from_le_bytes(take(8).try_into().unwrap());
        let float = || f64::from_le_bytes(take(8).try_into().unwrap());
        let vector = || DVec3::new(float(), float(), float());
        assert_eq!(&bytes[..8], MAGIC);
        let (n, frames, dt) = (word() as usize, word(), float());
        let (low, high) = (vector(), vector());
        assert_eq!((n, frames, dt), (60, 4, 1.0 / FRAMES_PER_SECOND));
        let table: Vec<(DVec3, f64)> = (0..word())
            .map(|_| {
                let (kind, _sizes, centre, radius) = (word(), vector(), vector(), float());
                let (vertices, triangles) = (word() as usize, word() as usize);
                assert_eq!(kind == Kind::ConvexHull as u64, vertices >= 4 && triangles >= 4);
                take(24 * vertices + 12 * triangles);
                (centre, radius)
            })
            .collect();
        assert_eq!(table.len(), shapes().len());
        let shape_of: Vec<usize> = (0..n).map(|_| u32::from_le_bytes(take(4).try_into().unwrap()) as usize).collect();
        let states: Vec<Vec<[f64; 13]>> =
            (0..=frames).map(|_| (0..n).map(|_| std::array::from_fn(|_| float())).collect()).collect();
        assert_eq!(at.get(), bytes.len());
        let orientation = |s: &[f64; 13]| DQuat::from_xyzw(s[3], s[4], s[5], s[6]);
        let centre_of_mass =
            |s: &[f64; 13], i: usize| DVec3::new(s[0], s[1], s[2]) + orientation(s) * table[shape_of[i]].0;
        for pair in states.windows(2) {
            for i in 0..n {
                let (now, next) = (&pair[0][i], &pair[1][i]);
                let (velocity, spin) = (DVec3::new(now[7], now[8], now[9]), DVec3::new(now[10], now[11], now[12]));
                let moved = centre_of_mass(now, i) + velocity * dt;
                assert!((centre_of_mass(next, i) - moved).length() < 1e-9, "body {i} leaves its line");
                let turned = DQuat::from_scaled_axis(spin * dt) * orientation(now);
                assert!(turned.dot(orientation(next)).abs() > 1.0 - 1e-12, "body {i} does not spin steadily");
                assert!((DVec3::new(next[10], next[11], next[12]) - spin).length() < 1e-9 * (1.0 + spin.length()));
                assert!(spin.length() * dt <= MAX_SPIN * (1.0 + 1e-12));
                let r = table[shape_of[i]].1;
                let c = centre_of_mass(next, i);
                assert!((c - r).cmpgt(low).all() && (c + r).cmplt(high).all(), "body {i} reaches a wall");
            }
        }
        assert!(!contacts.is_empty());
        assert!(contacts.iter().all(|c| (c[0] as u64) < frames && c[1] < c[2] && (c[2] as usize) < n));
    }
}
