//! The rapier / parry side of vadop's peer benchmark (the f64 builds, rapier3d-f64 and the
//! parry3d-f64 it re-exports, so positions keep the precision vadop uses):
//!  rapier           discrete: rapier's CollisionPipeline with every sphere a sensor collider
//!                   (sensors are rapier's overlap-only colliders), overlaps at frame instants;
//!  parry-ccd        continuous: parry's Bvh over each body's swept box, rebuilt every frame in
//!                   its own buffers, its overlapping leaf pairs from the single-tree traversal,
//!                   then parry's ball-ball cast on each pair for the time of impact;
//!  parry-ccd-refit  the same, but the first frame's tree is kept and refitted to the new boxes
//!                   (cheap while bodies move little; the tree degrades as they travel far).
//! It reads the trajectory file written by `vadop-bench peers` (format in ../cpp/trajectory.h, which
//! this file mirrors) and reports exactly as the C++ peers do: contacts as (frame, i, j) u32
//! triples in a file, and one JSON line with per-frame milliseconds and peak memory.
//! Usage: vadop-peer-rapier PIPELINE TRAJECTORY CONTACTS_OUT.

use rapier3d_f64::parry::partitioning::{Bvh, BvhBuildStrategy, BvhWorkspace};
use rapier3d_f64::parry::query::details::cast_shapes_ball_ball;
use rapier3d_f64::parry::query::ShapeCastOptions;
use rapier3d_f64::parry::shape::Ball;
use rapier3d_f64::parry::bounding_volume::Aabb;
use rapier3d_f64::prelude::*;
use std::fs::File;
use std::io::{BufReader, Read, Write};
use std::time::Instant;

/// One frame of the trajectory file.
struct Frame {
    /// Position and velocity of every body at the frame start.
    start: Vec<[f64; 6]>,
    /// Position of every body at the frame end.
    end: Vec<[f64; 3]>,
    /// Wall bounces (time since the frame start, position), by body: body i's are
    /// `bounces[first_bounce[i]..first_bounce[i + 1]]`.
    bounces: Vec<(f64, [f64; 3])>,
    first_bounce: Vec<usize>,
}

struct Trajectory {
    file: BufReader<File>,
    n: usize,
    frames: u64,
    dt: f64,
    radius: f64,
}

impl Trajectory {
    fn open(path: &str) -> Result<Trajectory, String> {
        let mut file = BufReader::new(File::open(path).map_err(|e| format!("{path}: {e}"))?);
        let mut magic = [0u8; 8];
        file.read_exact(&mut magic).map_err(|e| e.to_string())?;
        if &magic != b"VADOPTR1" {
            return Err(format!("{path}: not a vadop trajectory file"));
        }
        let mut header = [0f64; 10];
        let mut t = Trajectory { file, n: 0, frames: 0, dt: 0.0, radius: 0.0 };
        let n = t.u64()?;
        let frames = t.u64()?;
        t.f64s(&mut header[..8])?;
        Ok(Trajectory { n: n as usize, frames, dt: header[0], radius: header[1], ..t })
    }

    fn u64(&mut self) -> Result<u64, String> {
        let mut bytes = [0u8; 8];
        self.file.read_exact(&mut bytes).map_err(|_| "trajectory file is truncated".to_string())?;
        Ok(u64::from_le_bytes(bytes))
    }

    fn f64s(&mut self, out: &mut [f64]) -> Result<(), String> {
        for value in out {
            *value = f64::from_bits(self.u64()?);
        }
        Ok(())
    }

    /// Reads the next frame into `frame`, reusing its buffers.
    fn read_frame(&mut self, frame: &mut Frame) -> Result<(), String> {
        for s in &mut frame.start {
            self.f64s(s)?;
        }
        for e in &mut frame.end {
            self.f64s(e)?;
        }
        let count = self.u64()? as usize;
        frame.bounces.clear();
        frame.first_bounce.fill(0);
        for _ in 0..count {
            let body = self.u64()? as usize;
            let mut knot = [0.0; 4];
            self.f64s(&mut knot)?;
            frame.bounces.push((knot[0], [knot[1], knot[2], knot[3]]));
            frame.first_bounce[body + 1] += 1;
        }
        for i in 0..self.n {
            frame.first_bounce[i + 1] += frame.first_bounce[i];
        }
        Ok(())
    }
}

impl Frame {
    fn new(n: usize) -> Frame {
        Frame { start: vec![[0.0; 6]; n], end: vec![[0.0; 3]; n], bounces: Vec::new(), first_bounce: vec![0; n + 1] }
    }

    fn bounces(&self, i: usize) -> &[(f64, [f64; 3])] {
        &self.bounces[self.first_bounce[i]..self.first_bounce[i + 1]]
    }

    /// Position of body i at time tau since the frame start: linear between knots.
    fn position(&self, i: usize, tau: f64, dt: f64) -> Vector {
        let (mut t0, mut t1) = (0.0, dt);
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
        Vector::new(p0[0] + f * (p1[0] - p0[0]), p0[1] + f * (p1[1] - p0[1]), p0[2] + f * (p1[2] - p0[2]))
    }

    /// The box around body i's path (a polyline lies in the box of its vertices), grown by r.
    fn swept_box(&self, i: usize, radius: f64) -> Aabb {
        let s = self.start[i];
        let mut lo = Vector::new(s[0], s[1], s[2]);
        let mut hi = lo;
        let e = self.end[i];
        for p in std::iter::once(&e).chain(self.bounces(i).iter().map(|(_, p)| p)) {
            let v = Vector::new(p[0], p[1], p[2]);
            lo = lo.min(v);
            hi = hi.max(v);
        }
        Aabb::new(lo - Vector::splat(radius), hi + Vector::splat(radius))
    }

    /// Whether bodies i and j begin touching during the frame: parry's ball-ball cast over each
    /// piece of the frame in which both move in a straight line (split at either body's wall
    /// bounces). A touch at a piece's start means the pair still overlaps from before, so only a
    /// later touch is a new contact (possibly in a later piece: overlapping pairs can separate and
    /// meet again after a bounce). `cuts` is scratch space, reused from pair to pair.
    fn new_contact(&self, i: usize, j: usize, dt: f64, ball: &Ball, cuts: &mut Vec<f64>) -> bool {
        cuts.clear();
        cuts.extend([0.0, dt]);
        cuts.extend(self.bounces(i).iter().chain(self.bounces(j)).map(|(t, _)| *t));
        cuts.sort_unstable_by(f64::total_cmp);
        let options = ShapeCastOptions { max_time_of_impact: 1.0, stop_at_penetration: true, ..Default::default() };
        cuts.windows(2).filter(|piece| piece[1] > piece[0]).any(|piece| {
            let (ta, tb) = (piece[0], piece[1]);
            let (a0, b0) = (self.position(i, ta, dt), self.position(j, ta, dt));
            let (a1, b1) = (self.position(i, tb, dt), self.position(j, tb, dt));
            // The cast works in i's frame: j's offset and velocity relative to i.
            let hit = cast_shapes_ball_ball(&Pose::from_translation(b0 - a0), (b1 - b0) - (a1 - a0), ball, ball, options);
            hit.is_some_and(|hit| hit.time_of_impact > 0.0)
        })
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
fn rapier(trajectory: &mut Trajectory, report: &mut Report) -> Result<(), String> {
    let mut bodies = RigidBodySet::new();
    let mut colliders = ColliderSet::new();
    let mut handles = Vec::with_capacity(trajectory.n);
    // Colliders start at their first frame's start: all at the origin, every pair would overlap.
    let mut data = Frame::new(trajectory.n);
    trajectory.read_frame(&mut data)?;
    for i in 0..trajectory.n {
        let s = data.start[i];
        let collider = ColliderBuilder::ball(trajectory.radius)
            .translation(Vector::new(s[0], s[1], s[2]))
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
    for frame in 0..trajectory.frames {
        if frame > 0 {
            trajectory.read_frame(&mut data)?;
        }
        let started = Instant::now();
        for (&handle, p) in handles.iter().zip(&data.end) {
            colliders[handle].set_translation(Vector::new(p[0], p[1], p[2]));
        }
        pipeline.step(0.0, &mut islands, &mut broad_phase, &mut narrow_phase, &mut bodies, &mut colliders, &(), &());
        current.clear();
        current.extend(narrow_phase.intersection_pairs().filter(|&(_, _, intersecting)| intersecting).map(|(a, b, _)| {
            let (i, j) = (colliders[a].user_data as u64, colliders[b].user_data as u64);
            i.min(j) << 32 | i.max(j)
        }));
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
/// single-tree traversal (each pair once), then the exact ball-ball cast on each pair.
fn parry_ccd(trajectory: &mut Trajectory, report: &mut Report, upkeep: Upkeep) -> Result<(), String> {
    let (n, dt) = (trajectory.n, trajectory.dt);
    let ball = Ball::new(trajectory.radius);
    let mut data = Frame::new(n);
    let mut bvh = Bvh::new();
    let mut workspace = BvhWorkspace::default();
    let mut cuts = Vec::new();
    for frame in 0..trajectory.frames {
        trajectory.read_frame(&mut data)?;
        let started = Instant::now();
        if frame == 0 {
            bvh = Bvh::from_iter(BvhBuildStrategy::Binned, (0..n).map(|i| (i, data.swept_box(i, ball.radius))));
        } else {
            // Margin 0: leaves hold the exact boxes, so every reported pair's boxes overlap.
            for i in 0..n {
                bvh.insert_or_update_partially(data.swept_box(i, ball.radius), i as u32, 0.0);
            }
            match upkeep {
                Upkeep::Rebuild => bvh.rebuild(&mut workspace, BvhBuildStrategy::Binned),
                Upkeep::Refit => bvh.refit(&mut workspace),
            }
        }
        bvh.traverse_bvtt_single_tree::<false>(&mut workspace, &mut |a, b| {
            if data.new_contact(a as usize, b as usize, dt, &ball, &mut cuts) {
                report.contact(frame as u32, a as usize, b as usize);
            }
        });
        report.frame_ms.push(started.elapsed().as_secs_f64() * 1e3);
    }
    Ok(())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 4 {
        eprintln!("usage: vadop-peer-rapier PIPELINE TRAJECTORY CONTACTS_OUT");
        std::process::exit(2);
    }
    let outcome = Trajectory::open(&args[2]).and_then(|mut trajectory| {
        let mut report = Report::default();
        match args[1].as_str() {
            "rapier" => rapier(&mut trajectory, &mut report)?,
            "parry-ccd" => parry_ccd(&mut trajectory, &mut report, Upkeep::Rebuild)?,
            "parry-ccd-refit" => parry_ccd(&mut trajectory, &mut report, Upkeep::Refit)?,
            other => return Err(format!("unknown pipeline {other}")),
        }
        report.finish(&args[3])
    });
    if let Err(message) = outcome {
        eprintln!("error: {message}");
        std::process::exit(1);
    }
}
