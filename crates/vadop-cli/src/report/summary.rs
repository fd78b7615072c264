//! What a run reports, as data: the scene described from the world itself, the run's settings,
//! the axis pool, the accuracy against a reference method, the conservation of energy and
//! momentum, and the totals accumulated frame by frame from which the summary is built once, at
//! the end. The summary is written as JSON and read back by the benchmark from its child runs, so
//! it must never hold NaN (JSON has none). It keeps nothing per frame, and never formats text for
//! the user: that is `text`.

use super::quantiles::{Quantiles, Spread};
use super::writers::FrameRow;
use crate::CliResult;
use glam::DVec3;
use serde::{Deserialize, Serialize};
use vadop::shape::ShapeKind;
use vadop::{BodyShape, World};

/// What was simulated, described from the world itself so that generated scenes, scene files and
/// saved worlds read alike.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneInfo {
    /// Where the scene came from ("paper scene ...", "scene file ...", "saved world ...").
    pub source: String,
    /// Moving bodies.
    pub bodies: usize,
    /// The moving bodies by kind of shape, in the order of `ShapeKind::ALL` (kinds with none left out), each named by its summary word.
    #[serde(default)]
    pub kinds: Vec<KindCount>,
    /// The static bodies by kind of shape.
    #[serde(default)]
    pub static_bodies: Vec<KindCount>,
    /// Side lengths of the box.
    pub extent: [f64; 3],
    /// The box's periodic axes (x, y, z).
    #[serde(default)]
    pub periodic: [bool; 3],
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

/// Kinds of shape a summary counts: the core's, in its order.
const KINDS: usize = ShapeKind::ALL.len();

impl SceneInfo {
    pub fn of(world: &World, source: String, dt: f64) -> CliResult<SceneInfo> {
        let extent = world.bounds().max - world.bounds().min;
        let (mut moving, mut fixed) = ([0usize; KINDS], [0usize; KINDS]);
        let (mut volume, mut max_speed, mut max_spin) = (0.0, 0.0f64, 0.0f64);
        for (_, body) in world.bodies() {
            let (kind, body_volume, radius) = match body.shape {
                BodyShape::Sphere { radius } => {
                    (ShapeKind::Sphere as usize, 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3), radius)
                }
                BodyShape::Shape(id) => {
                    let geometry = world.shape(id).map_err(|e| e.to_string())?;
                    (geometry.shape().kind() as usize, geometry.volume(), geometry.bounding_radius().unwrap_or(0.0))
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
        let by_kind = |counts: [usize; KINDS]| {
            ShapeKind::ALL
                .iter()
                .zip(counts)
                .filter(|(_, count)| *count > 0)
                .map(|(kind, count)| KindCount { kind: kind.words().0.to_string(), count })
                .collect::<Vec<_>>()
        };
        Ok(SceneInfo {
            source,
            bodies: moving.iter().sum(),
            kinds: by_kind(moving),
            static_bodies: by_kind(fixed),
            extent: extent.to_array(),
            periodic: world.bounds().periodic,
            packing: volume / extent.element_product(),
            max_speed,
            max_spin,
        })
    }

    /// True when bodies spin or may be set spinning by an impact: bodies other than spheres,
    /// static bodies, spins.
    pub fn may_spin(&self) -> bool {
        self.kinds.iter().any(|k| k.kind != ShapeKind::Sphere.words().0)
            || !self.static_bodies.is_empty()
            || self.max_spin > 0.0
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
    /// Uniform acceleration of every moving body (zero: none).
    #[serde(default)]
    pub gravity: [f64; 3],
    pub frames_requested: u64,
}

impl RunInfo {
    /// True when bodies moved under gravity: the energy kept then includes the potential.
    pub fn has_gravity(&self) -> bool {
        self.gravity != [0.0; 3]
    }
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
    /// Of the centres' motion only: the gas's temperature.
    translational: f64,
    /// In the world's gravity (0 without).
    potential: f64,
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
            translational: world.translational_kinetic_energy(),
            potential: world.potential_energy(),
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
    /// (end - start) / start of the kinetic plus the potential energy (0 without gravity), the
    /// start taken as kinetic plus |potential|; absent when nothing moves.
    pub kinetic_relative_drift: Option<f64>,
    /// Potential energy in the world's gravity at the start and the end (0 without gravity).
    #[serde(default)]
    pub potential_start: f64,
    #[serde(default)]
    pub potential_end: f64,
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
    /// Kinetic energy of the centres' motion at the start and the end: the temperature of a gas.
    #[serde(default)]
    pub translational_start: f64,
    #[serde(default)]
    pub translational_end: f64,
}

/// The pressure of an elastic, frictionless run from the collisional virial of its impacts
/// between moving bodies (the per-frame `pair_virial`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Pressure {
    /// The virial W summed over the frames: each impact's separation of centres dotted with the
    /// momentum exchanged.
    pub virial: f64,
    /// The compressibility factor PV/NkT = 1 + W / (2 K T), K the translational kinetic energy
    /// (the mean of the start's and the end's, equal up to rounding in such a run) and T the
    /// simulated time; N counts the moving bodies.
    pub z: f64,
    /// Impacts between moving bodies that made it.
    pub impacts: u64,
}

impl Pressure {
    /// The pressure of a run of `seconds` with `impacts` between moving bodies whose virial
    /// summed to `virial`; `None` where it means nothing (no time simulated, nothing moving).
    pub fn new(virial: f64, conservation: &Conservation, seconds: f64, impacts: u64) -> Option<Pressure> {
        let kinetic = 0.5 * (conservation.translational_start + conservation.translational_end);
        let scale = 2.0 * kinetic * seconds;
        (scale > 0.0 && scale.is_finite()).then(|| Pressure { virial, z: 1.0 + virial / scale, impacts })
    }
}

impl Conservation {
    /// From `start` to `end`, with angular momentum when `spins`.
    pub fn new(start: &Motion, end: &Motion, spins: bool) -> Conservation {
        let angular = |value: DVec3| spins.then_some(value.to_array());
        // Without gravity the potential is 0 and this is the kinetic energy's drift, to the bit.
        let scale = start.kinetic + start.potential.abs();
        Conservation {
            kinetic_start: start.kinetic,
            kinetic_end: end.kinetic,
            kinetic_relative_drift: (scale > 0.0)
                .then(|| (end.kinetic + end.potential - start.kinetic - start.potential) / scale),
            potential_start: start.potential,
            potential_end: end.potential,
            momentum_start: start.momentum.to_array(),
            momentum_end: end.momentum.to_array(),
            momentum_change: (end.momentum - start.momentum).length(),
            momentum_sum: start.momentum_sum,
            angular_momentum_start: angular(start.angular_momentum),
            angular_momentum_end: angular(end.angular_momentum),
            angular_momentum_change: spins.then(|| (end.angular_momentum - start.angular_momentum).length()),
            translational_start: start.translational,
            translational_end: end.translational,
        }
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
    rest_contacts: u64,
    contact_ends: u64,
    pair_virial: f64,
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
        self.rest_contacts += row.rest_contacts;
        self.contact_ends += row.contact_ends;
        self.pair_virial += row.pair_virial;
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
    /// Under gravity with restitution below 1: contacts at which the rest rule brought a body to
    /// rest, or parted or bounced it off one that does not fall.
    #[serde(default)]
    pub rest_contacts: u64,
}

/// Under gravity with restitution below 1: how many bodies are at rest at the end.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Resting {
    /// Lying still on walls or on bodies lying still.
    pub still: u64,
    /// Sliding along walls gravity presses them into.
    pub sliding: u64,
    /// Moving bodies in all.
    pub bodies: u64,
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
    /// Elastic, frictionless simulate runs without gravity: the pressure from the collisional virial.
    #[serde(default)]
    pub pressure: Option<Pressure>,
    /// Under gravity with restitution below 1 (simulate mode): the bodies at rest at the end.
    #[serde(default)]
    pub resting: Option<Resting>,
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
        let simulated_seconds = frames.frames as f64 * run.dt;
        // Only an elastic, frictionless gas keeps the temperature that Z is measured against.
        let pressure = conservation
            .as_ref()
            .filter(|_| run.restitution == 1.0 && run.friction == 0.0 && !run.has_gravity())
            .and_then(|c| Pressure::new(frames.pair_virial, c, simulated_seconds, pairs));
        Summary {
            pressure,
            frames_completed: frames.frames,
            simulated_seconds,
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
            rules: RuleCounts {
                tc_contacts: frames.tc_contacts,
                jam_contacts: frames.jam_contacts,
                rest_contacts: frames.rest_contacts,
            },
            resting: None,
            broad_phase_bytes: frames.broad_phase_bytes,
            peak_memory_mib: peak_memory_mib(),
            conservation,
            error,
            run,
        }
    }
}

/// Peak resident memory of this process in MiB (VmHWM), or `None` off Linux.
fn peak_memory_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|line| line.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}
