//! The part of `vadop simulate --json` the suites read: the per-frame rows they need and the
//! summary. Fields that older binaries do not write (the baseline engine of `speed`) default to
//! zero, so one reader serves both.

use serde::Deserialize;

#[derive(Debug, Clone, Deserialize)]
pub struct Report {
    #[serde(default)]
    pub frames: Vec<Frame>,
    pub summary: Summary,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Frame {
    pub pair_contacts: u64,
    /// Every contact of the frame: between bodies, with static bodies and with walls.
    #[serde(default)]
    pub contacts: u64,
    /// The collisional virial of the frame's impacts between moving bodies.
    #[serde(default)]
    pub pair_virial: f64,
    /// Wall-clock milliseconds of the step.
    pub wall_ms: f64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Summary {
    pub run: Run,
    pub frames_completed: u64,
    pub pool: Option<Pool>,
    pub contacts: Contacts,
    pub accuracy: Option<Accuracy>,
    /// c_total = c_update + c_sort + c_test + c_response per frame.
    pub c_total_ms: Spread,
    /// Wall-clock time of the step per frame.
    pub wall_ms: Spread,
    pub cost_split: CostSplit,
    pub per_frame: PerFrame,
    pub peak_memory_mib: Option<f64>,
    /// Simulate mode: energy and momentum kept.
    #[serde(default)]
    pub conservation: Option<Conservation>,
    /// Contacts whose physics a rule changed.
    #[serde(default)]
    pub rules: Rules,
    /// Under gravity with restitution below 1: the bodies at rest at the end.
    #[serde(default)]
    pub resting: Option<Resting>,
    pub error: Option<String>,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Conservation {
    /// Kinetic energy of the centres' motion at the end: the temperature of a gas.
    #[serde(default)]
    pub translational_end: f64,
    /// The kinetic (plus potential) energy's relative change over the run.
    #[serde(default)]
    pub kinetic_relative_drift: Option<f64>,
}

impl Summary {
    /// Pair contacts per frame.
    pub fn pairs_per_frame(&self) -> f64 {
        self.contacts.pairs as f64 / self.frames_completed.max(1) as f64
    }
}

#[derive(Debug, Clone, Deserialize)]
pub struct Run {
    /// The method as run, `auto (grid)` for the automatic choice.
    pub method: String,
    /// Frame length in seconds.
    #[serde(default)]
    pub dt: f64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Pool {
    pub axes: usize,
}

#[derive(Debug, Clone, Default, Deserialize)]
pub struct Rules {
    /// Contacts the rest rule changed.
    #[serde(default)]
    pub rest_contacts: u64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Resting {
    pub still: u64,
    pub sliding: u64,
    pub bodies: u64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Contacts {
    /// Every contact.
    #[serde(default)]
    pub total: u64,
    pub pairs: u64,
    pub per_wall_second: f64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Accuracy {
    pub reference: String,
    pub reference_pairs: u64,
    pub missed: u64,
    pub extra: u64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct Spread {
    pub median: f64,
    pub mean: f64,
    pub p95: f64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct CostSplit {
    pub update_ms: f64,
    pub sort_ms: f64,
    pub test_ms: f64,
    pub response_ms: f64,
}

#[derive(Debug, Clone, Deserialize)]
pub struct PerFrame {
    pub contacts: f64,
    pub endpoint_swaps: f64,
    pub candidate_pairs: f64,
    pub narrow_tests: f64,
    #[serde(default)]
    pub windows: f64,
}
