//! The rapier / parry side of vadop's peer benchmark (the f64 builds, rapier3d-f64 and the
//! parry3d-f64 it re-exports, so positions keep the precision vadop uses), on either scene:
//!  rapier           discrete: rapier's CollisionPipeline with every body a sensor collider
//!                   (sensors are rapier's overlap-only colliders), overlaps at frame instants;
//!  parry-ccd        continuous: parry's Bvh over each body's swept box, rebuilt every frame in
//!                   its own buffers, its overlapping leaf pairs from the single-tree traversal,
//!                   then parry's cast on each pair for the time of impact: the ball-ball cast for
//!                   the spheres, the nonlinear cast (a constant linear and angular velocity about
//!                   the centre of mass, `NonlinearRigidMotion`) for the spinning shapes;
//!  parry-ccd-refit  the same, but the first frame's tree is kept and refitted to the new boxes
//!                   (cheap while bodies move little; the tree degrades as they travel far).
//! It reads the trajectory files written by `vadop-bench peers` (the sphere scene's format is in
//! ../cpp/trajectory.h, the shapes scene's in crates/vadop-bench/src/peers/shapes.rs; this file
//! mirrors both) and reports exactly as the C++ peers do: contacts as (frame, i, j) u32 triples
//! in a file, and one JSON line with per-frame milliseconds and peak memory.
//! Usage: vadop-peer-rapier PIPELINE TRAJECTORY CONTACTS_OUT.

use rapier3d_f64::parry::bounding_volume::Aabb;
use rapier3d_f64::parry::math::Rotation;
use rapier3d_f64::parry::partitioning::{Bvh, BvhBuildStrategy, BvhWorkspace};
use rapier3d_f64::parry::query::details::cast_shapes_ball_ball;
use rapier3d_f64::parry::query::{cast_shapes_nonlinear, NonlinearRigidMotion, ShapeCastOptions};
use rapier3d_f64::parry::shape::Ball;
use rapier3d_f64::prelude::*;
use std::fs::File;
use std::io::{BufReader, Read, Write};
use std::time::Instant;

/// Little-endian values from a trajectory file.
struct Reader(BufReader<File>);

impl Reader {
    fn open(path: &str) -> Result<(Reader, [u8; 8]), String> {
        let mut file = BufReader::new(File::open(path).map_err(|e| format!("{path}: {e}"))?);
        let mut magic = [0u8; 8];
        file.read_exact(&mut magic).map_err(|e| format!("{path}: {e}"))?;
        Ok((Reader(file), magic))
    }

    fn bytes<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let mut bytes = [0u8; N];
        self.0.read_exact(&mut bytes).map_err(|_| "trajectory file is truncated".to_string())?;
        Ok(bytes)
    }

    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.bytes()?))
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.bytes()?))
    }

    fn f64s(&mut self, out: &mut [f64]) -> Result<(), String> {
        for value in out {
            *value = f64::from_le_bytes(self.bytes()?);
        }
        Ok(())
    }

    fn vector(&mut self) -> Result<Vector, String> {
        let mut v = [0.0; 3];
        self.f64s(&mut v)?;
        Ok(Vector::from_array(v))
    }
}

/// What the pipelines need of a scene's trajectory file, one frame at a time.
trait Scene {
    fn bodies(&self) -> usize;
    fn frames(&self) -> u64;
    /// Loads the next frame.
    fn next_frame(&mut self) -> Result<(), String>;
    /// Body i's shape, its pose at the loaded frame's start and at its end.
    fn shape(&self, i: usize) -> SharedShape;
    fn pose_at_start(&self, i: usize) -> Pose;
    fn pose_at_end(&self, i: usize) -> Pose;
    /// The box around everything body i covers in the loaded frame.
    fn swept_box(&self, i: usize) -> Aabb;
    /// Whether bodies i and j begin touching during the loaded frame, by parry's cast.
    fn new_contact(&mut self, i: usize, j: usize) -> bool;
}

/// The sphere scene: equal spheres whose paths are polylines (straight pieces between wall
/// bounces). Per frame: position and velocity of every body at the frame start, its position at
/// the frame end, and its wall bounces (time since the frame start, position).
struct Spheres {
    file: Reader,
    n: usize,
    frames: u64,
    dt: f64,
    ball: Ball,
    start: Vec<[f64; 6]>,
    end: Vec<[f64; 3]>,
    /// Body i's bounces are `bounces[first_bounce[i]..first_bounce[i + 1]]`.
    bounces: Vec<(f64, [f64; 3])>,
    first_bounce: Vec<usize>,
    /// Scratch space of `new_contact`, reused from pair to pair.
    cuts: Vec<f64>,
}

impl Spheres {
    fn open(mut file: Reader) -> Result<Spheres, String> {
        let (n, frames) = (file.u64()? as usize, file.u64()?);
        // dt, radius and the box (which no pipeline here needs).
        let mut header = [0f64; 8];
        file.f64s(&mut header)?;
        Ok(Spheres {
            file,
            n,
            frames,
            dt: header[0],
            ball: Ball::new(header[1]),
            start: vec![[0.0; 6]; n],
            end: vec![[0.0; 3]; n],
            bounces: Vec::new(),
            first_bounce: vec![0; n + 1],
            cuts: Vec::new(),
        })
    }

    fn bounces(&self, i: usize) -> &[(f64, [f64; 3])] {
        &self.bounces[self.first_bounce[i]..self.first_bounce[i + 1]]
    }

    /// Position of body i at time tau since the frame start: linear between knots.
    fn position(&self, i: usize, tau: f64) -> Vector {
        let (mut t0, mut t1) = (0.0, self.dt);
        let (mut p0, mut p1) = ([self.start[i][0], self.start[i][1], self.start[i][2]], self.end[i]);
        for &(t, p) in self.bounces(i) {
            if t <= tau {
                (t0, p0) = (t, p);
            } else {
                (t1, p1) = (t, p);
                break;
            }
        }
        let f = if t1 > t0 { (tau - t0) / (t1 - t0) } else { 0.0 };
        Vector::from_array(p0) + f * (Vector::from_array(p1) - Vector::from_array(p0))
    }
}

impl Scene for Spheres {
    fn bodies(&self) -> usize {
        self.n
    }

    fn frames(&self) -> u64 {
        self.frames
    }

    fn next_frame(&mut self) -> Result<(), String> {
        for s in &mut self.start {
            self.file.f64s(s)?;
        }
        for e in &mut self.end {
            self.file.f64s(e)?;
        }
        let count = self.file.u64()? as usize;
        self.bounces.clear();
        self.first_bounce.fill(0);
        for _ in 0..count {
            let body = self.file.u64()? as usize;
            let mut knot = [0.0; 4];
            self.file.f64s(&mut knot)?;
            self.bounces.push((knot[0], [knot[1], knot[2], knot[3]]));
            self.first_bounce[body + 1] += 1;
        }
        for i in 0..self.n {
            self.first_bounce[i + 1] += self.first_bounce[i];
        }
        Ok(())
    }

    fn shape(&self, _: usize) -> SharedShape {
        SharedShape::ball(self.ball.radius)
    }

    fn pose_at_start(&self, i: usize) -> Pose {
        Pose::from_translation(self.position(i, 0.0))
    }

    fn pose_at_end(&self, i: usize) -> Pose {
        Pose::from_translation(Vector::from_array(self.end[i]))
    }

    /// The box around body i's path (a polyline lies in the box of its vertices), grown by r.
    fn swept_box(&self, i: usize) -> Aabb {
        let mut lo = self.position(i, 0.0);
        let mut hi = lo;
        for p in std::iter::once(&self.end[i]).chain(self.bounces(i).iter().map(|(_, p)| p)) {
            lo = lo.min(Vector::from_array(*p));
            hi = hi.max(Vector::from_array(*p));
        }
        Aabb::new(lo - Vector::splat(self.ball.radius), hi + Vector::splat(self.ball.radius))
    }

    /// Parry's ball-ball cast over each piece of the frame in which both move in a straight line
    /// (split at either body's wall bounces). A touch at a piece's start means the pair still
    /// overlaps from before, so only a later touch is a new contact (possibly in a later piece:
    /// overlapping pairs can separate and meet again after a bounce).
    fn new_contact(&mut self, i: usize, j: usize) -> bool {
        let mut cuts = std::mem::take(&mut self.cuts);
        cuts.clear();
        cuts.extend([0.0, self.dt]);
        cuts.extend(self.bounces(i).iter().chain(self.bounces(j)).map(|(t, _)| *t));
        cuts.sort_unstable_by(f64::total_cmp);
        let options = ShapeCastOptions { max_time_of_impact: 1.0, stop_at_penetration: true, ..Default::default() };
        let found = cuts.windows(2).filter(|piece| piece[1] > piece[0]).any(|piece| {
            let (ta, tb) = (piece[0], piece[1]);
            let (a0, b0) = (self.position(i, ta), self.position(j, ta));
            let (a1, b1) = (self.position(i, tb), self.position(j, tb));
            // The cast works in i's frame: j's offset and velocity relative to i.
            let hit = cast_shapes_ball_ball(
                &Pose::from_translation(b0 - a0),
                (b1 - b0) - (a1 - a0),
                &self.ball,
                &self.ball,
                options,
            );
            hit.is_some_and(|hit| hit.time_of_impact > 0.0)
        });
        self.cuts = cuts;
        found
    }
}

/// One shape of the shapes scene: parry's, the centre of mass it turns about (in its own frame)
/// and the radius about that centre that holds it.
struct ShapeEntry {
    shape: SharedShape,
    centre: Vector,
    bounding_radius: f64,
}

/// The mixed-shape scene: bodies whose centres of mass move in straight lines while they turn
/// about them at constant angular velocities. Per frame, every body's state at the frame start
/// and at its end (the next frame's start): the shape frame's position and orientation (x, y, z,
/// w), the centre of mass's velocity and the angular velocity.
struct Shapes {
    file: Reader,
    n: usize,
    frames: u64,
    dt: f64,
    shapes: Vec<ShapeEntry>,
    shape_of: Vec<usize>,
    start: Vec<[f64; 13]>,
    end: Vec<[f64; 13]>,
}

impl Shapes {
    fn open(mut file: Reader) -> Result<Shapes, String> {
        let (n, frames) = (file.u64()? as usize, file.u64()?);
        // dt and the box (which no pipeline here needs).
        let mut header = [0f64; 7];
        file.f64s(&mut header)?;
        let count = file.u64()? as usize;
        let mut shapes = Vec::with_capacity(count);
        for _ in 0..count {
            let kind = file.u64()?;
            let size = file.vector()?;
            let centre = file.vector()?;
            let mut bounding_radius = [0.0];
            file.f64s(&mut bounding_radius)?;
            let (vertices, triangles) = (file.u64()? as usize, file.u64()? as usize);
            let points = (0..vertices).map(|_| file.vector()).collect::<Result<Vec<_>, _>>()?;
            let faces = (0..triangles)
                .map(|_| Ok([file.u32()?, file.u32()?, file.u32()?]))
                .collect::<Result<Vec<_>, String>>()?;
            let shape = match kind {
                0 => SharedShape::ball(size.x),
                1 => SharedShape::cuboid(size.x, size.y, size.z),
                2 => SharedShape::capsule_y(size.x, size.y),
                3 => SharedShape::cylinder(size.x, size.y),
                4 => SharedShape::cone(size.x, size.y),
                5 => SharedShape::convex_mesh(points, &faces).ok_or("a convex hull that parry refuses")?,
                other => return Err(format!("unknown shape kind {other}")),
            };
            shapes.push(ShapeEntry { shape, centre, bounding_radius: bounding_radius[0] });
        }
        let shape_of = (0..n).map(|_| Ok(file.u32()? as usize)).collect::<Result<Vec<_>, String>>()?;
        if shape_of.iter().any(|&s| s >= count) {
            return Err("a body's shape is not in the shape table".into());
        }
        let mut scene = Shapes {
            file,
            n,
            frames,
            dt: header[0],
            shapes,
            shape_of,
            start: vec![[0.0; 13]; n],
            end: vec![[0.0; 13]; n],
        };
        scene.read_states()?;
        Ok(scene)
    }

    /// Reads the next states into `end`.
    fn read_states(&mut self) -> Result<(), String> {
        for state in &mut self.end {
            self.file.f64s(state)?;
        }
        Ok(())
    }

    fn entry(&self, i: usize) -> &ShapeEntry {
        &self.shapes[self.shape_of[i]]
    }

    fn centre_of_mass(&self, i: usize, state: &[f64; 13]) -> Vector {
        pose(state) * self.entry(i).centre
    }

    /// Body i's motion over the loaded frame, from its start state.
    fn motion(&self, i: usize) -> NonlinearRigidMotion {
        let state = &self.start[i];
        NonlinearRigidMotion::new(
            pose(state),
            self.entry(i).centre,
            Vector::new(state[7], state[8], state[9]),
            Vector::new(state[10], state[11], state[12]),
        )
    }
}

/// The pose of a state's shape frame.
fn pose(state: &[f64; 13]) -> Pose {
    Pose::from_parts(
        Vector::new(state[0], state[1], state[2]),
        Rotation::from_xyzw(state[3], state[4], state[5], state[6]),
    )
}

impl Scene for Shapes {
    fn bodies(&self) -> usize {
        self.n
    }

    fn frames(&self) -> u64 {
        self.frames
    }

    fn next_frame(&mut self) -> Result<(), String> {
        std::mem::swap(&mut self.start, &mut self.end);
        self.read_states()
    }

    fn shape(&self, i: usize) -> SharedShape {
        self.entry(i).shape.clone()
    }

    fn pose_at_start(&self, i: usize) -> Pose {
        pose(&self.start[i])
    }

    fn pose_at_end(&self, i: usize) -> Pose {
        pose(&self.end[i])
    }

    /// The centre of mass moves in a straight line and the shape stays within its bounding radius
    /// of it however it turns.
    fn swept_box(&self, i: usize) -> Aabb {
        let (a, b) = (self.centre_of_mass(i, &self.start[i]), self.centre_of_mass(i, &self.end[i]));
        let r = Vector::splat(self.entry(i).bounding_radius);
        Aabb::new(a.min(b) - r, a.max(b) + r)
    }

    /// Parry's nonlinear cast over the frame. A touch at the frame's start means the pair still
    /// overlaps from before: only a later touch is a new contact.
    fn new_contact(&mut self, i: usize, j: usize) -> bool {
        let hit = cast_shapes_nonlinear(
            &self.motion(i),
            self.entry(i).shape.as_ref(),
            &self.motion(j),
            self.entry(j).shape.as_ref(),
            0.0,
            self.dt,
            true,
        );
        // Every scene shape is a support map, which the cast supports.
        hit.ok().flatten().is_some_and(|hit| hit.time_of_impact > 0.0)
    }
}

/// Contacts and per-frame times, reported as the C++ peers do.
#[derive(Default)]
struct Report {
    frame_ms: Vec<f64>,
    contacts: Vec<u32>,
}

impl Report {
    fn contact(&mut self, frame: u32, i: usize, j: usize) {
        let (i, j) = if i < j { (i, j) } else { (j, i) };
        self.contacts.extend([frame, i as u32, j as u32]);
    }

    fn finish(&self, path: &str) -> Result<(), String> {
        let bytes: Vec<u8> = self.contacts.iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(path, bytes).map_err(|e| format!("{path}: {e}"))?;
        let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
        let peak: i64 = status
            .lines()
            .find_map(|l| l.strip_prefix("VmHWM:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
            .unwrap_or(-1);
        let times: Vec<String> = self.frame_ms.iter().map(|t| format!("{t:.6}")).collect();
        let mut out = std::io::stdout().lock();
        writeln!(out, "{{\"frame_ms\":[{}],\"peak_kib\":{peak}}}", times.join(",")).map_err(|e| e.to_string())
    }
}

/// Frame-instant overlaps become contacts only when new since the previous frame instant (the
/// rule of vadop's discrete method); the bookkeeping is part of the frame's cost.
fn rapier(scene: &mut impl Scene, report: &mut Report) -> Result<(), String> {
    let mut bodies = RigidBodySet::new();
    let mut colliders = ColliderSet::new();
    let mut handles = Vec::with_capacity(scene.bodies());
    // Colliders start at their first frame's start: all at the origin, every pair would overlap.
    scene.next_frame()?;
    for i in 0..scene.bodies() {
        let collider = ColliderBuilder::new(scene.shape(i))
            .position(scene.pose_at_start(i))
            .sensor(true)
            // Colliders without a body are fixed, and rapier skips fixed-fixed pairs by default.
            .active_collision_types(ActiveCollisionTypes::all())
            .user_data(i as u128)
            .build();
        handles.push(colliders.insert(collider));
    }
    let mut islands = IslandManager::new();
    let mut broad_phase = BroadPhaseBvh::new();
    let mut narrow_phase = NarrowPhase::new();
    let mut pipeline = CollisionPipeline::new();
    let (mut previous, mut current): (Vec<u64>, Vec<u64>) = (Vec::new(), Vec::new());
    for frame in 0..scene.frames() {
        if frame > 0 {
            scene.next_frame()?;
        }
        let started = Instant::now();
        for (i, &handle) in handles.iter().enumerate() {
            colliders[handle].set_position(scene.pose_at_end(i));
        }
        pipeline.step(0.0, &mut islands, &mut broad_phase, &mut narrow_phase, &mut bodies, &mut colliders, &(), &());
        current.clear();
        current.extend(narrow_phase.intersection_pairs().filter(|&(_, _, intersecting)| intersecting).map(
            |(a, b, _)| {
                let (i, j) = (colliders[a].user_data as u64, colliders[b].user_data as u64);
                i.min(j) << 32 | i.max(j)
            },
        ));
        current.sort_unstable();
        for &key in &current {
            if previous.binary_search(&key).is_err() {
                report.contact(frame as u32, (key >> 32) as usize, (key & 0xffff_ffff) as usize);
            }
        }
        std::mem::swap(&mut previous, &mut current);
        report.frame_ms.push(started.elapsed().as_secs_f64() * 1e3);
    }
    Ok(())
}

/// How the continuous pipeline keeps parry's Bvh over the swept boxes from frame to frame.
#[derive(Clone, Copy)]
enum Upkeep {
    /// Rebuild the whole tree (binned SAH) over the new boxes, in the tree's own buffers.
    Rebuild,
    /// Keep the first frame's tree, move its leaves to the new boxes and refit the nodes above.
    Refit,
}

/// Continuous: parry's Bvh over each body's swept box, its overlapping leaf pairs from parry's
/// single-tree traversal (each pair once), then the scene's cast on each pair.
fn parry_ccd(scene: &mut impl Scene, report: &mut Report, upkeep: Upkeep) -> Result<(), String> {
    let n = scene.bodies();
    let mut bvh = Bvh::new();
    let mut workspace = BvhWorkspace::default();
    for frame in 0..scene.frames() {
        scene.next_frame()?;
        let started = Instant::now();
        if frame == 0 {
            bvh = Bvh::from_iter(BvhBuildStrategy::Binned, (0..n).map(|i| (i, scene.swept_box(i))));
        } else {
            // Margin 0: leaves hold the exact boxes, so every reported pair's boxes overlap.
            for i in 0..n {
                bvh.insert_or_update_partially(scene.swept_box(i), i as u32, 0.0);
            }
            match upkeep {
                Upkeep::Rebuild => bvh.rebuild(&mut workspace, BvhBuildStrategy::Binned),
                Upkeep::Refit => bvh.refit(&mut workspace),
            }
        }
        bvh.traverse_bvtt_single_tree::<false>(&mut workspace, &mut |a, b| {
            if scene.new_contact(a as usize, b as usize) {
                report.contact(frame as u32, a as usize, b as usize);
            }
        });
        report.frame_ms.push(started.elapsed().as_secs_f64() * 1e3);
    }
    Ok(())
}

/// Runs `pipeline` on `scene` and reports, its contacts written to `contacts`.
fn run(pipeline: &str, mut scene: impl Scene, contacts: &str) -> Result<(), String> {
    let mut report = Report::default();
    match pipeline {
        "rapier" => rapier(&mut scene, &mut report)?,
        "parry-ccd" => parry_ccd(&mut scene, &mut report, Upkeep::Rebuild)?,
        "parry-ccd-refit" => parry_ccd(&mut scene, &mut report, Upkeep::Refit)?,
        other => return Err(format!("unknown pipeline {other}")),
    }
    report.finish(contacts)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: vadop-peer-rapier PIPELINE TRAJECTORY CONTACTS_OUT");
        std::process::exit(2);
    }
    let outcome = Reader::open(&args[2]).and_then(|(file, magic)| match &magic {
        b"VADOPTR1" => run(&args[1], Spheres::open(file)?, &args[3]),
        b"VADOPSH1" => run(&args[1], Shapes::open(file)?, &args[3]),
        _ => Err(format!("{}: not a vadop trajectory file", args[2])),
    });
    if let Err(message) = outcome {
        eprintln!("error: {message}");
        std::process::exit(1);
    }
}
