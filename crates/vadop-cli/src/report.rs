//! Reporting: the per-frame rows, the run summary (built once from totals accumulated frame by
//! frame, printed as text, written as JSON and read back by the benchmark from its child runs),
//! the CSV and JSON files, streamed as the frames come, and the small measurement helpers they
//! need (order statistics, peak memory, progress bars, writing to stdout). It owns every number
//! format the user sees. Nothing here grows with the number of frames, so a run of any length
//! takes the same memory. It never steps a world or decides what to run, and it never produces
//! NaN in a summary, because JSON has no NaN and the benchmark must be able to read every summary
//! back.

use crate::CliResult;
use glam::DVec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use vadop::memory::format_bytes;
use vadop::shape::Shape;
use vadop::{BodyShape, FrameStats, World};

/// One frame as written to the per-frame CSV and JSON: its counters, the cost split of
/// c_total in milliseconds and the wall-clock time of the whole step.
#[derive(Debug, Clone, Serialize)]
pub struct FrameRow {
    pub frame: u64,
    pub time: f64,
    pub contacts: u64,
    /// Contacts between two moving bodies.
    pub pair_contacts: u64,
    /// Contacts of a moving body with a static body (contacts with walls are the rest).
    #[serde(default)]
    pub static_contacts: u64,
    /// c_total in milliseconds.
    pub ms: f64,
    pub update_ms: f64,
    pub sort_ms: f64,
    pub test_ms: f64,
    pub response_ms: f64,
    pub endpoint_swaps: u64,
    pub list_entries: u64,
    pub candidate_pairs: u64,
    pub narrow_tests: u64,
    pub invalidations: u64,
    /// Wall-clock milliseconds of the step call, which also covers work outside the four stages.
    pub wall_ms: f64,
    pub broad_phase_bytes: u64,
    pub windows: u64,
    pub retests: u64,
    /// Contacts whose physics a rule changed: made elastic by the TC model, resolved by the jam rule.
    pub tc_contacts: u64,
    pub jam_contacts: u64,
    /// Contacts between bodies that ended (with --contact-ends).
    #[serde(default)]
    pub contact_ends: u64,
}

impl FrameRow {
    const CSV_HEADER: &'static str = "frame,time,contacts,pair_contacts,ms,update_ms,sort_ms,test_ms,response_ms,\
        endpoint_swaps,list_entries,candidate_pairs,narrow_tests,invalidations,wall_ms,broad_phase_bytes,\
        windows,retests,tc_contacts,jam_contacts,contact_ends,static_contacts";

    /// A frame's row; `static_contacts` of its body contacts were with static bodies.
    pub fn new(frame: u64, time: f64, stats: &FrameStats, static_contacts: u64, wall_seconds: f64) -> FrameRow {
        FrameRow {
            frame,
            time,
            contacts: stats.contacts,
            // The core counts every contact between two bodies, static ones included.
            pair_contacts: stats.pair_contacts.saturating_sub(static_contacts),
            static_contacts,
            ms: stats.total_seconds() * 1e3,
            update_ms: stats.update_seconds * 1e3,
            sort_ms: stats.sort_seconds * 1e3,
            test_ms: stats.test_seconds * 1e3,
            response_ms: stats.response_seconds * 1e3,
            endpoint_swaps: stats.endpoint_swaps,
            list_entries: stats.list_entries,
            candidate_pairs: stats.candidate_pairs,
            narrow_tests: stats.narrow_tests,
            invalidations: stats.invalidations,
            wall_ms: wall_seconds * 1e3,
            broad_phase_bytes: stats.broad_phase_bytes,
            windows: stats.windows,
            retests: stats.retests,
            tc_contacts: stats.tc_contacts,
            jam_contacts: stats.jam_contacts,
            contact_ends: stats.contact_ends,
        }
    }

    /// The row in the order of `CSV_HEADER`.
    fn csv_line(&self) -> String {
        format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            self.frame,
            self.time,
            self.contacts,
            self.pair_contacts,
            self.ms,
            self.update_ms,
            self.sort_ms,
            self.test_ms,
            self.response_ms,
            self.endpoint_swaps,
            self.list_entries,
            self.candidate_pairs,
            self.narrow_tests,
            self.invalidations,
            self.wall_ms,
            self.broad_phase_bytes,
            self.windows,
            self.retests,
            self.tc_contacts,
            self.jam_contacts,
            self.contact_ends,
            self.static_contacts
        )
    }
}

/// What was simulated, described from the world itself so that generated scenes, scene files and
/// saved worlds read alike.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneInfo {
    /// Where the scene came from ("paper scene ...", "scene file ...", "saved world ...").
    pub source: String,
    /// Moving bodies.
    pub bodies: usize,
    /// The moving bodies by kind of shape, in the order of [`KINDS`] (kinds with none left out).
    #[serde(default)]
    pub kinds: Vec<KindCount>,
    /// The static bodies by kind of shape.
    #[serde(default)]
    pub static_bodies: Vec<KindCount>,
    /// Side lengths of the box.
    pub extent: [f64; 3],
    /// Fraction of the box volume the moving bodies fill.
    pub packing: f64,
    /// Speed of the fastest body in its own diameters per frame (a shape's diameter is its
    /// bounding sphere's).
    pub max_speed: f64,
    /// Fastest spin in radians per frame.
    #[serde(default)]
    pub max_spin: f64,
}

/// How many bodies of one kind of shape.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct KindCount {
    pub kind: String,
    pub count: usize,
}

/// The kinds of shape, singular and plural, in the order of the core's `Shape`.
const KINDS: [(&str, &str); 8] = [
    ("sphere", "spheres"),
    ("cuboid", "cuboids"),
    ("capsule", "capsules"),
    ("cylinder", "cylinders"),
    ("cone", "cones"),
    ("convex hull", "convex hulls"),
    ("triangle mesh", "triangle meshes"),
    ("half-space", "half-spaces"),
];

/// The place of `shape`'s kind in [`KINDS`].
fn kind_of(shape: &Shape) -> usize {
    match shape {
        Shape::Sphere { .. } => 0,
        Shape::Cuboid { .. } => 1,
        Shape::Capsule { .. } => 2,
        Shape::Cylinder { .. } => 3,
        Shape::Cone { .. } => 4,
        Shape::ConvexHull { .. } => 5,
        Shape::TriMesh { .. } => 6,
        Shape::HalfSpace { .. } => 7,
    }
}

/// `count` bodies of `kind`, as a reader says it: "1 cone", "3 convex hulls".
fn counted(count: usize, kind: &str) -> String {
    let plural = KINDS.iter().find(|(one, _)| *one == kind).map_or(kind, |(_, many)| many);
    number(count as u64, kind, plural)
}

/// `count` things, singular or plural: "1 contact", "0 contacts".
pub fn number(count: u64, one: &str, many: &str) -> String {
    format!("{count} {}", if count == 1 { one } else { many })
}

impl SceneInfo {
    pub fn of(world: &World, source: String, dt: f64) -> CliResult<SceneInfo> {
        let extent = world.bounds().max - world.bounds().min;
        let (mut moving, mut fixed) = ([0usize; KINDS.len()], [0usize; KINDS.len()]);
        let (mut volume, mut max_speed, mut max_spin) = (0.0, 0.0f64, 0.0f64);
        for (_, body) in world.bodies() {
            let (kind, body_volume, radius) = match body.shape {
                BodyShape::Sphere { radius } => (0, 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3), radius),
                BodyShape::Shape(id) => {
                    let geometry = world.shape(id).map_err(|e| e.to_string())?;
                    (kind_of(geometry.shape()), geometry.volume(), geometry.bounding_radius().unwrap_or(0.0))
                }
            };
            if !body.mass.is_finite() {
                fixed[kind] += 1;
                continue;
            }
            moving[kind] += 1;
            volume += body_volume;
            max_speed = max_speed.max(body.velocity.length() * dt / (2.0 * radius));
            max_spin = max_spin.max(body.angular_velocity.length() * dt);
        }
        let by_kind = |counts: [usize; KINDS.len()]| {
            KINDS
                .iter()
                .zip(counts)
                .filter(|(_, count)| *count > 0)
                .map(|((kind, _), count)| KindCount { kind: kind.to_string(), count })
                .collect::<Vec<_>>()
        };
        Ok(SceneInfo {
            source,
            bodies: moving.iter().sum(),
            kinds: by_kind(moving),
            static_bodies: by_kind(fixed),
            extent: extent.to_array(),
            packing: volume / extent.element_product(),
            max_speed,
            max_spin,
        })
    }

    /// True when bodies spin or may be set spinning by an impact: bodies other than spheres,
    /// static bodies, spins.
    pub fn may_spin(&self) -> bool {
        self.kinds.iter().any(|k| k.kind != KINDS[0].0) || !self.static_bodies.is_empty() || self.max_spin > 0.0
    }
}

/// What does not come from the frames: the run's settings.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunInfo {
    pub scene: SceneInfo,
    pub method: String,
    pub mode: String,
    pub dt: f64,
    pub restitution: f64,
    /// Coulomb friction coefficient of every impact.
    #[serde(default)]
    pub friction: f64,
    pub frames_requested: u64,
}

/// The axis pool of a VADOP run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PoolInfo {
    pub axes: usize,
    pub covering_radius_deg: f64,
    pub phi_deg: f64,
    /// Mean of list entries / bodies over the frames that start a window (the lists are built
    /// there): how many axes each body is bounded on.
    pub axes_per_body: f64,
}

/// Pair contacts compared with a reference method stepped alongside.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Accuracy {
    pub reference: String,
    /// True in detect mode: every method follows the same paths, so the counts are exact misses.
    pub identical_paths: bool,
    /// Pair contacts the reference reported, over all frames.
    pub reference_pairs: u64,
    /// (pair, frame) contacts of the reference that the run did not report in that frame.
    pub missed: u64,
    /// (pair, frame) contacts of the run that the reference did not report in that frame.
    pub extra: u64,
    /// First frame whose pair contacts differ.
    pub first_difference_frame: Option<u64>,
}

/// What a run keeps, or exchanges only with the walls and static bodies, at one instant: the
/// world's totals over its moving bodies, spins included.
pub struct Motion {
    kinetic: f64,
    momentum: DVec3,
    /// Sum of |m v| over the moving bodies: the scale of a change of momentum.
    momentum_sum: f64,
    angular_momentum: DVec3,
}

impl Motion {
    pub fn of(world: &World) -> Motion {
        let momentum_sum =
            world.bodies().filter(|(_, b)| b.mass.is_finite()).map(|(_, b)| b.mass * b.velocity.length()).sum();
        Motion {
            kinetic: world.kinetic_energy(),
            momentum: world.momentum(),
            momentum_sum,
            angular_momentum: world.angular_momentum(),
        }
    }
}

/// Kinetic energy (of translation and of spin), momentum and, when bodies spin, angular momentum
/// at the start and end of a run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Conservation {
    pub kinetic_start: f64,
    pub kinetic_end: f64,
    /// (end - start) / start; absent when nothing moves.
    pub kinetic_relative_drift: Option<f64>,
    pub momentum_start: [f64; 3],
    pub momentum_end: [f64; 3],
    /// |end - start|.
    pub momentum_change: f64,
    /// Sum of |m v| over the moving bodies at the start, the scale of `momentum_change`: the
    /// walls and static bodies exchange momentum with the bodies, up to twice this per crossing.
    #[serde(default)]
    pub momentum_sum: f64,
    /// Angular momentum about the origin, of the centres' motion and of the spins: reported when
    /// bodies spin or may be set spinning (shapes, static bodies, friction), absent otherwise.
    #[serde(default)]
    pub angular_momentum_start: Option<[f64; 3]>,
    #[serde(default)]
    pub angular_momentum_end: Option<[f64; 3]>,
    /// |end - start|.
    #[serde(default)]
    pub angular_momentum_change: Option<f64>,
}

impl Conservation {
    /// From `start` to `end`, with angular momentum when `spins`.
    pub fn new(start: &Motion, end: &Motion, spins: bool) -> Conservation {
        let angular = |value: DVec3| spins.then_some(value.to_array());
        Conservation {
            kinetic_start: start.kinetic,
            kinetic_end: end.kinetic,
            kinetic_relative_drift: (start.kinetic > 0.0).then(|| (end.kinetic - start.kinetic) / start.kinetic),
            momentum_start: start.momentum.to_array(),
            momentum_end: end.momentum.to_array(),
            momentum_change: (end.momentum - start.momentum).length(),
            momentum_sum: start.momentum_sum,
            angular_momentum_start: angular(start.angular_momentum),
            angular_momentum_end: angular(end.angular_momentum),
            angular_momentum_change: spins.then(|| (end.angular_momentum - start.angular_momentum).length()),
        }
    }
}

/// Median, mean and 95th percentile.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Spread {
    pub median: f64,
    pub mean: f64,
    pub p95: f64,
}

/// Order statistics of a stream of non-negative values (milliseconds) in bounded memory: exact
/// for the first `EXACT_VALUES` values, so short runs and the benchmark's runs are exact; beyond,
/// every value goes into a histogram of logarithmic bins `BIN_RATIO` wide, and a median or p95 is
/// the geometric middle of its bin, within 0.5% of a value of that rank (for values between
/// `LOWEST_MS` and `HIGHEST_MS`; beyond, the extremes seen stand in). The mean is always exact.
#[derive(Debug, Clone, Default)]
pub struct Quantiles {
    values: Vec<f64>,
    bins: Vec<u64>,
    count: u64,
    sum: f64,
    min: f64,
    max: f64,
}

impl Quantiles {
    /// 512 KiB of values.
    const EXACT_VALUES: usize = 1 << 16;
    const BIN_RATIO: f64 = 1.01;
    /// A nanosecond to eleven days: 3472 bins, 27 KiB.
    const LOWEST_MS: f64 = 1e-6;
    const HIGHEST_MS: f64 = 1e9;

    pub fn add(&mut self, value: f64) {
        (self.min, self.max) =
            if self.count == 0 { (value, value) } else { (self.min.min(value), self.max.max(value)) };
        self.count += 1;
        self.sum += value;
        if self.bins.is_empty() {
            self.values.push(value);
            if self.values.len() == Self::EXACT_VALUES {
                self.bins = vec![0; Self::bin_count()];
                for value in std::mem::take(&mut self.values) {
                    self.bins[Self::bin(value)] += 1;
                }
            }
        } else {
            self.bins[Self::bin(value)] += 1;
        }
    }

    fn bin(value: f64) -> usize {
        let bin = ((value / Self::LOWEST_MS).ln() / Self::BIN_RATIO.ln()).floor();
        // NaN and values below the lowest (0 too) go to the first bin.
        if bin > 0.0 {
            (bin as usize).min(Self::bin_count() - 1)
        } else {
            0
        }
    }

    fn bin_count() -> usize {
        ((Self::HIGHEST_MS / Self::LOWEST_MS).ln() / Self::BIN_RATIO.ln()).floor() as usize + 1
    }

    /// The value of nearest rank `rank` (1-based): the smallest with at least `rank` values at
    /// or below it.
    fn ranked(&self, sorted: &[f64], rank: u64) -> f64 {
        if self.bins.is_empty() {
            return sorted[rank as usize - 1];
        }
        let mut seen = 0;
        for (bin, &count) in self.bins.iter().enumerate() {
            seen += count;
            if seen >= rank {
                // The end bins also hold what lies beyond the range: the extremes seen stand in.
                return match bin {
                    0 => self.min,
                    _ if bin == self.bins.len() - 1 => self.max,
                    _ => (Self::LOWEST_MS * Self::BIN_RATIO.powf(bin as f64 + 0.5)).clamp(self.min, self.max),
                };
            }
        }
        self.max
    }

    /// All zero for no values, so a summary never holds NaN.
    pub fn spread(&self) -> Spread {
        let n = self.count;
        if n == 0 {
            return Spread::default();
        }
        let mut sorted = self.values.clone();
        sorted.sort_unstable_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            self.ranked(&sorted, n / 2 + 1)
        } else {
            0.5 * (self.ranked(&sorted, n / 2) + self.ranked(&sorted, n / 2 + 1))
        };
        // Nearest rank: the smallest value with at least 95% of the values at or below it.
        let rank = ((0.95 * n as f64).ceil() as u64).clamp(1, n);
        Spread { median, mean: self.sum / n as f64, p95: self.ranked(&sorted, rank) }
    }
}

/// What the summary needs from the frames, accumulated one row at a time.
#[derive(Debug, Clone, Default)]
pub struct FrameTotals {
    pub frames: u64,
    pub contacts: u64,
    pub pair_contacts: u64,
    static_contacts: u64,
    /// Frames that started a broad-phase window, and their list entries: the lists are built
    /// there, and other frames report none.
    window_frames: u64,
    window_list_entries: u64,
    endpoint_swaps: u64,
    candidate_pairs: u64,
    narrow_tests: u64,
    invalidations: u64,
    windows: u64,
    retests: u64,
    tc_contacts: u64,
    jam_contacts: u64,
    contact_ends: u64,
    update_ms: f64,
    sort_ms: f64,
    test_ms: f64,
    response_ms: f64,
    broad_phase_bytes: u64,
    c_total_ms: Quantiles,
    wall_ms: Quantiles,
}

impl FrameTotals {
    pub fn add(&mut self, row: &FrameRow) {
        self.frames += 1;
        self.contacts += row.contacts;
        self.pair_contacts += row.pair_contacts;
        self.static_contacts += row.static_contacts;
        if row.windows > 0 {
            self.window_frames += 1;
            self.window_list_entries += row.list_entries;
        }
        self.endpoint_swaps += row.endpoint_swaps;
        self.candidate_pairs += row.candidate_pairs;
        self.narrow_tests += row.narrow_tests;
        self.invalidations += row.invalidations;
        self.windows += row.windows;
        self.retests += row.retests;
        self.tc_contacts += row.tc_contacts;
        self.jam_contacts += row.jam_contacts;
        self.contact_ends += row.contact_ends;
        self.update_ms += row.update_ms;
        self.sort_ms += row.sort_ms;
        self.test_ms += row.test_ms;
        self.response_ms += row.response_ms;
        self.broad_phase_bytes = self.broad_phase_bytes.max(row.broad_phase_bytes);
        self.c_total_ms.add(row.ms);
        self.wall_ms.add(row.wall_ms);
    }

    /// Axes each of `bodies` is bounded on: list entries per body, over the frames that start a
    /// window; 0 for none.
    pub fn axes_per_body(&self, bodies: usize) -> f64 {
        let body_frames = self.window_frames as f64 * bodies as f64;
        if body_frames > 0.0 {
            self.window_list_entries as f64 / body_frames
        } else {
            0.0
        }
    }

    /// The per-frame mean of a total, 0 for no frames.
    fn mean(&self, total: f64) -> f64 {
        if self.frames == 0 {
            0.0
        } else {
            total / self.frames as f64
        }
    }
}

/// Contact counts over the run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ContactTotals {
    pub total: u64,
    /// Between two moving bodies.
    pub pairs: u64,
    /// Of a moving body with a static body.
    #[serde(default)]
    pub statics: u64,
    pub walls: u64,
    /// Contacts between bodies that ended (with --contact-ends).
    #[serde(default)]
    pub ends: u64,
    /// Contacts per second of wall-clock stepping time.
    pub per_wall_second: f64,
}

/// Means per frame of the cost split, in milliseconds.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CostSplit {
    pub update_ms: f64,
    pub sort_ms: f64,
    pub test_ms: f64,
    pub response_ms: f64,
}

/// Means per frame of the broad- and narrow-phase counters.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PerFrame {
    pub contacts: f64,
    pub endpoint_swaps: f64,
    pub candidate_pairs: f64,
    pub narrow_tests: f64,
    pub invalidations: f64,
    pub windows: f64,
    pub retests: f64,
}

/// Every contact whose physics a rule changed (see the core's `collapse` module).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RuleCounts {
    /// Made elastic by the TC model (restitution below 1).
    pub tc_contacts: u64,
    /// Resolved by the jam rule (a jammed cluster frozen).
    pub jam_contacts: u64,
}

/// Everything a run reports, built once and then printed, written as JSON or read back.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Summary {
    pub run: RunInfo,
    pub frames_completed: u64,
    pub simulated_seconds: f64,
    pub pool: Option<PoolInfo>,
    pub contacts: ContactTotals,
    pub accuracy: Option<Accuracy>,
    pub c_total_ms: Spread,
    pub wall_ms: Spread,
    pub cost_split: CostSplit,
    pub per_frame: PerFrame,
    pub rules: RuleCounts,
    /// Largest broad-phase footprint over the frames.
    pub broad_phase_bytes: u64,
    /// Peak resident memory of the whole process (VmHWM), where the system reports it.
    pub peak_memory_mib: Option<f64>,
    /// Simulate mode only: energy and momentum are meaningless when bodies pass through each other.
    pub conservation: Option<Conservation>,
    /// The error that stopped the run early.
    pub error: Option<String>,
}

impl Summary {
    pub fn new(
        run: RunInfo,
        frames: &FrameTotals,
        pool: Option<PoolInfo>,
        accuracy: Option<Accuracy>,
        conservation: Option<Conservation>,
        error: Option<String>,
    ) -> Summary {
        let (total, pairs, statics) = (frames.contacts, frames.pair_contacts, frames.static_contacts);
        let wall_seconds = frames.wall_ms.sum / 1e3;
        Summary {
            frames_completed: frames.frames,
            simulated_seconds: frames.frames as f64 * run.dt,
            pool,
            contacts: ContactTotals {
                total,
                pairs,
                statics,
                walls: total - pairs - statics,
                ends: frames.contact_ends,
                per_wall_second: if wall_seconds > 0.0 { total as f64 / wall_seconds } else { 0.0 },
            },
            accuracy,
            c_total_ms: frames.c_total_ms.spread(),
            wall_ms: frames.wall_ms.spread(),
            cost_split: CostSplit {
                update_ms: frames.mean(frames.update_ms),
                sort_ms: frames.mean(frames.sort_ms),
                test_ms: frames.mean(frames.test_ms),
                response_ms: frames.mean(frames.response_ms),
            },
            per_frame: PerFrame {
                contacts: frames.mean(total as f64),
                endpoint_swaps: frames.mean(frames.endpoint_swaps as f64),
                candidate_pairs: frames.mean(frames.candidate_pairs as f64),
                narrow_tests: frames.mean(frames.narrow_tests as f64),
                invalidations: frames.mean(frames.invalidations as f64),
                windows: frames.mean(frames.windows as f64),
                retests: frames.mean(frames.retests as f64),
            },
            rules: RuleCounts { tc_contacts: frames.tc_contacts, jam_contacts: frames.jam_contacts },
            broad_phase_bytes: frames.broad_phase_bytes,
            peak_memory_mib: peak_memory_mib(),
            conservation,
            error,
            run,
        }
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let run = &self.run;
        let scene = &run.scene;
        let [x, y, z] = scene.extent;
        let shape =
            if x == y && y == z { format!("cube of side {x:.4}") } else { format!("box {x:.4} x {y:.4} x {z:.4}") };
        writeln!(f, "scene       {}", scene.source)?;
        let bodies = format!("{} {}", scene.bodies, if scene.bodies == 1 { "body" } else { "bodies" });
        if scene.may_spin() {
            let listed =
                |kinds: &[KindCount]| kinds.iter().map(|k| counted(k.count, &k.kind)).collect::<Vec<_>>().join(", ");
            let fixed: usize = scene.static_bodies.iter().map(|k| k.count).sum();
            let fixed = match fixed {
                0 => String::new(),
                n => format!(
                    " and {} ({})",
                    number(n as u64, "static body", "static bodies"),
                    listed(&scene.static_bodies)
                ),
            };
            writeln!(f, "            {bodies} ({}){fixed}", listed(&scene.kinds))?;
            writeln!(
                f,
                "            {shape}, packing {:.4}, max speed {:.4} diameters/frame (fastest body; a shape's diameter is its bounding sphere's), max spin {:.4} rad/frame",
                scene.packing, scene.max_speed, scene.max_spin
            )?;
        } else {
            writeln!(
                f,
                "            {bodies}, {shape}, packing {:.4}, max speed {:.4} diameters/frame (fastest body)",
                scene.packing, scene.max_speed
            )?;
        }
        let friction = if run.friction > 0.0 { format!(", friction {}", run.friction) } else { String::new() };
        writeln!(
            f,
            "method      {}, {} mode, dt {}, restitution {}{friction}",
            run.method,
            run.mode,
            seconds(run.dt),
            run.restitution
        )?;
        // The default is the fastest method, not the paper's: say how to run that one.
        if run.method.starts_with("auto") {
            writeln!(f, "            the default, the fastest method here; --method vadop runs the paper's VADOP sweep and prune")?;
        }
        match &self.pool {
            Some(p) => writeln!(
                f,
                "pool        m = {} axes, rho = {:.4} deg, phi = {:.4} deg, {:.2} axes per body (mean over the frames that start a window)",
                p.axes, p.covering_radius_deg, p.phi_deg, p.axes_per_body
            )?,
            None => writeln!(f, "pool        none ({} uses no axis pool)", run.method)?,
        }
        writeln!(
            f,
            "frames      {} of {} ({:.4} s simulated)",
            self.frames_completed, run.frames_requested, self.simulated_seconds
        )?;
        let c = &self.contacts;
        let statics = if c.statics > 0 || !scene.static_bodies.is_empty() {
            format!(", {} with static bodies", c.statics)
        } else {
            String::new()
        };
        writeln!(
            f,
            "contacts    {} ({}{statics}, {} with walls), {:.1} per frame, {:.0} per wall-clock second{}",
            c.total,
            number(c.pairs, "body pair", "body pairs"),
            c.walls,
            self.per_frame.contacts,
            c.per_wall_second,
            if c.ends > 0 {
                format!("; {} between bodies ended", number(c.ends, "contact", "contacts"))
            } else {
                String::new()
            }
        )?;
        match &self.accuracy {
            Some(a) => {
                let label = if a.identical_paths {
                    "detect mode: identical paths, so these are exact misses".to_string()
                } else {
                    match a.first_difference_frame {
                        Some(frame) => format!(
                            "simulate mode: paths diverge from frame {frame} on, so later differences are not misses"
                        ),
                        None => "simulate mode: paths never diverged".to_string(),
                    }
                };
                writeln!(
                    f,
                    "accuracy    vs {}: {} missed, {} extra of {} ({label})",
                    a.reference,
                    a.missed,
                    a.extra,
                    number(a.reference_pairs, "reference pair contact", "reference pair contacts")
                )?
            }
            None => writeln!(f, "accuracy    not checked (no reference method)")?,
        }
        let (t, w) = (&self.c_total_ms, &self.wall_ms);
        writeln!(f, "ms/frame    c_total    median {:.3}, mean {:.3}, p95 {:.3}", t.median, t.mean, t.p95)?;
        writeln!(f, "            wall-clock median {:.3}, mean {:.3}, p95 {:.3}", w.median, w.mean, w.p95)?;
        let s = &self.cost_split;
        let sum = s.update_ms + s.sort_ms + s.test_ms + s.response_ms;
        let share = |ms: f64| if sum > 0.0 { 100.0 * ms / sum } else { 0.0 };
        writeln!(
            f,
            "cost split  update {:.3} ms ({:.1}%), sort {:.3} ms ({:.1}%), test {:.3} ms ({:.1}%), response {:.3} ms ({:.1}%)",
            s.update_ms,
            share(s.update_ms),
            s.sort_ms,
            share(s.sort_ms),
            s.test_ms,
            share(s.test_ms),
            s.response_ms,
            share(s.response_ms)
        )?;
        let p = &self.per_frame;
        writeln!(
            f,
            "per frame   {:.2} broad-phase windows, {:.1} endpoint swaps, {:.1} candidate pairs, {:.1} narrow tests, {:.1} re-tests, {:.1} invalidations",
            p.windows, p.endpoint_swaps, p.candidate_pairs, p.narrow_tests, p.retests, p.invalidations
        )?;
        let r = &self.rules;
        writeln!(
            f,
            "rules       {} made elastic by the TC model, {} resolved by the jam rule{}",
            number(r.tc_contacts, "contact", "contacts"),
            r.jam_contacts,
            if r.tc_contacts + r.jam_contacts == 0 { " (the physics was never changed)" } else { "" }
        )?;
        let peak = match self.peak_memory_mib {
            Some(mib) if self.accuracy.is_some() => format!("{mib:.1} MiB (whole process, reference world included)"),
            Some(mib) => format!("{mib:.1} MiB (whole process)"),
            None => "unknown (no /proc/self/status)".to_string(),
        };
        writeln!(f, "memory      broad phase {}, peak {peak}", format_bytes(self.broad_phase_bytes))?;
        if let Some(c) = &self.conservation {
            // Spins are in the totals whenever bodies spin; say so when they do.
            let (spin, angular, exchanged) = match c.angular_momentum_change {
                Some(change) => (
                    " (translation and spin)",
                    format!("; angular momentum change {change:.3e} (about the origin, orbits and spins)"),
                    " and angular momentum",
                ),
                None => ("", String::new(), ""),
            };
            // Only an elastic, frictionless run should keep its energy: elsewhere the change is
            // the loss the run was asked for.
            let mut losses = Vec::new();
            if run.restitution < 1.0 {
                losses.push(format!("restitution {}", run.restitution));
            }
            if run.friction > 0.0 {
                losses.push(format!("friction {}", run.friction));
            }
            let energy = match c.kinetic_relative_drift {
                None => "kinetic energy n/a (nothing moves)".to_string(),
                Some(drift) if losses.is_empty() => {
                    format!(
                        "kinetic energy{spin} relative drift {drift:+.3e} (elastic and frictionless: 0 up to rounding)"
                    )
                }
                Some(change) => {
                    format!(
                        "kinetic energy{spin} relative change {change:+.3e} (a loss by design: {})",
                        losses.join(", ")
                    )
                }
            };
            let scale = if c.momentum_sum > 0.0 {
                format!(" ({:.3e} of the bodies' sum of |m v| at the start)", c.momentum_change / c.momentum_sum)
            } else {
                String::new()
            };
            let statics = if scene.static_bodies.is_empty() { "" } else { " and static bodies" };
            writeln!(
                f,
                "energy      {energy}; momentum change {:.3e}{scale}{angular} (walls{statics} exchange momentum{exchanged} with the bodies)",
                c.momentum_change
            )?;
        }
        if let Some(error) = &self.error {
            writeln!(f, "stopped     {error}")?;
        }
        Ok(())
    }
}

/// Peak resident memory of this process in MiB (VmHWM), or `None` off Linux.
pub fn peak_memory_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|line| line.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// The message for an I/O failure on `path`.
pub fn io_error(path: &Path, error: impl fmt::Display) -> String {
    format!("{}: {error}", path.display())
}

/// Creates (truncates) an output file; called before a run so a bad path fails before the work.
pub fn create_file(path: &Path) -> CliResult<File> {
    File::create(path).map_err(|e| io_error(path, e))
}

/// An output file written as the run goes, through a buffer.
pub struct OutputFile {
    out: BufWriter<File>,
    path: PathBuf,
}

impl OutputFile {
    /// Creates (truncates) the file; called before a run so a bad path fails before the work.
    pub fn create(path: &Path) -> CliResult<OutputFile> {
        create_file(path).map(|file| OutputFile::new(file, path))
    }

    /// Writes to `file`, already open, which `path` names in messages.
    pub fn new(file: File, path: &Path) -> OutputFile {
        OutputFile { out: BufWriter::new(file), path: path.to_path_buf() }
    }

    pub fn line(&mut self, line: fmt::Arguments<'_>) -> CliResult<()> {
        writeln!(self.out, "{line}").map_err(|e| io_error(&self.path, e))
    }

    fn json(&mut self, value: &impl Serialize, pretty: bool) -> CliResult<()> {
        let written = if pretty {
            serde_json::to_writer_pretty(&mut self.out, value)
        } else {
            serde_json::to_writer(&mut self.out, value)
        };
        written.map_err(|e| io_error(&self.path, e))
    }

    /// Hands what is buffered to the system.
    pub fn flush(&mut self) -> CliResult<()> {
        self.out.flush().map_err(|e| io_error(&self.path, e))
    }

    /// Flushes, then waits until the data is on the disk.
    pub fn sync(&mut self) -> CliResult<()> {
        self.flush()?;
        self.out.get_ref().sync_data().map_err(|e| io_error(&self.path, e))
    }
}

/// The per-frame CSV: a header, then one line per frame as it completes.
pub struct FramesCsv(OutputFile);

impl FramesCsv {
    pub fn create(path: &Path) -> CliResult<FramesCsv> {
        let mut file = OutputFile::create(path)?;
        file.line(format_args!("{}", FrameRow::CSV_HEADER))?;
        Ok(FramesCsv(file))
    }

    pub fn row(&mut self, row: &FrameRow) -> CliResult<()> {
        self.0.line(format_args!("{}", row.csv_line()))
    }

    pub fn finish(mut self) -> CliResult<()> {
        self.0.flush()
    }
}

/// The JSON report, `{"frames": [...], "summary": {...}}`: the frames as they complete, the
/// summary last, once it is known.
pub struct JsonReport {
    file: OutputFile,
    rows: u64,
}

impl JsonReport {
    pub fn create(path: &Path) -> CliResult<JsonReport> {
        let mut file = OutputFile::create(path)?;
        file.line(format_args!("{{\"frames\": ["))?;
        Ok(JsonReport { file, rows: 0 })
    }

    pub fn row(&mut self, row: &FrameRow) -> CliResult<()> {
        if self.rows > 0 {
            self.file.line(format_args!(","))?;
        }
        self.rows += 1;
        self.file.json(row, false)
    }

    pub fn finish(mut self, summary: &Summary) -> CliResult<()> {
        self.file.line(format_args!("\n],\n\"summary\":"))?;
        self.file.json(summary, true)?;
        self.file.line(format_args!("\n}}"))?;
        self.file.flush()
    }
}

/// Writes to stdout, turning a closed pipe into an error message instead of a panic.
pub fn print(text: &str) -> CliResult<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes()).and_then(|()| out.flush()).map_err(|e| format!("stdout: {e}"))
}

/// A progress bar on stderr that stays invisible until `reveal` is called.
pub fn progress_bar(total: u64, unit: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
    let template = format!("{{bar:40}} {{pos}}/{{len}} {unit} [{{elapsed_precise}} < {{eta_precise}}] {{msg}}");
    // The template is fixed, so this never fails; keeping the default style would be fine anyway.
    if let Ok(style) = ProgressStyle::with_template(&template) {
        bar.set_style(style);
    }
    bar
}

/// Starts drawing `bar`, unless stderr is not a terminal (a pipe or a file would fill with
/// control sequences).
pub fn reveal(bar: &ProgressBar) {
    if std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::stderr());
    }
}

/// A time step as a reader wants it: `1/30 s` for a whole fraction of a second (the frame rates
/// people choose), otherwise six significant digits.
fn seconds(dt: f64) -> String {
    let rate = 1.0 / dt;
    if (2.0..1e9).contains(&rate) && (rate - rate.round()).abs() <= 1e-9 * rate {
        format!("1/{} s", rate.round())
    } else {
        let rounded: f64 = format!("{dt:.5e}").parse().unwrap_or(dt);
        if (1e-4..1e6).contains(&rounded) {
            format!("{rounded} s")
        } else {
            format!("{rounded:e} s")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spread_of(values: impl Iterator<Item = f64>) -> Spread {
        let mut quantiles = Quantiles::default();
        values.for_each(|v| quantiles.add(v));
        quantiles.spread()
    }

    #[test]
    fn spread_uses_nearest_rank_and_never_nan() {
        let s = spread_of((1..=20).map(f64::from));
        assert_eq!((s.median, s.mean, s.p95), (10.5, 10.5, 19.0));
        let empty = spread_of(std::iter::empty());
        assert_eq!((empty.median, empty.mean, empty.p95), (0.0, 0.0, 0.0));
    }

    #[test]
    fn long_streams_keep_bounded_memory_and_half_a_percent() {
        // Ten times more values than are kept exactly, spread over six decades, shuffled.
        let n = 10 * Quantiles::EXACT_VALUES as u64;
        let value = |i: u64| 1e-3 * 10f64.powf(6.0 * ((i * 7919) % n) as f64 / n as f64);
        let mut quantiles = Quantiles::default();
        (0..n).for_each(|i| quantiles.add(value(i)));
        assert!(quantiles.values.capacity() == 0 && quantiles.bins.len() == Quantiles::bin_count());
        let mut sorted: Vec<f64> = (0..n).map(value).collect();
        sorted.sort_unstable_by(f64::total_cmp);
        let s = quantiles.spread();
        let exact_mean = sorted.iter().sum::<f64>() / n as f64;
        assert!((s.mean - exact_mean).abs() <= 1e-9 * exact_mean);
        for (estimate, rank) in [(s.median, n / 2), (s.p95, (0.95 * n as f64).ceil() as u64)] {
            let exact = sorted[rank as usize - 1];
            assert!((estimate / exact - 1.0).abs() <= 0.005, "{estimate} vs {exact}");
        }
        // Values beyond the bins' range (zero too) come back as the extremes seen.
        let mut edges = Quantiles::default();
        for i in 0..Quantiles::EXACT_VALUES as u64 + 11 {
            edges.add(if i % 2 == 0 { 0.0 } else { 1e12 });
        }
        let s = edges.spread();
        assert_eq!((s.median, s.p95), (0.0, 1e12));
    }

    #[test]
    fn time_steps_read_as_people_write_them() {
        assert_eq!(seconds(1.0 / 30.0), "1/30 s");
        assert_eq!(seconds(0.16666666666666666), "1/6 s");
        assert_eq!(seconds(0.25), "1/4 s");
        assert_eq!(seconds(0.123456789), "0.123457 s");
        assert_eq!(seconds(3.0), "3 s");
        assert_eq!(seconds(1e-300), "1e-300 s");
        assert_eq!(seconds(2.5e7), "2.5e7 s");
    }
}
