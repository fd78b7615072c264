//! The options every suite shares, and where a run writes: the published BENCHMARKS.md and
//! results/ for a full run, a scratch copy under target/bench-quick/ for a quick one (a smoke
//! check must never overwrite published figures), unless `--publish` says otherwise.

use crate::CliResult;
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The n x speed grid of the core and peers suites; their help gives the defaults.
#[derive(Debug, Args)]
pub struct Grid {
    /// Body counts n, comma-separated
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pub bodies: Option<Vec<usize>>,
    /// Maximum speeds in sphere diameters per frame, comma-separated
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_values_t = [0.05, 0.5, 5.0])]
    pub speeds: Vec<f64>,
    /// Frames per run
    #[arg(long, value_name = "F", value_parser = clap::value_parser!(u64).range(1..))]
    pub frames: Option<u64>,
}

impl Grid {
    /// Refuses what no run could measure, before any runs.
    pub fn check(&self) -> CliResult<()> {
        if self.bodies.as_ref().is_some_and(|b| b.contains(&0)) {
            return Err("--bodies: every body count must be at least 1".to_string());
        }
        match self.speeds.iter().find(|s| !(s.is_finite() && **s >= 0.0)) {
            Some(speed) => Err(format!("--speeds: every speed must be finite and at least 0, got {speed}")),
            None => Ok(()),
        }
    }
}

/// Where quick runs write unless `--publish` is given.
const QUICK_DIR: &str = "target/bench-quick";

#[derive(Debug, Args)]
pub struct Common {
    /// Small sizes for a smoke check of a few minutes; written under target/bench-quick/ unless
    /// --publish is given
    #[arg(long)]
    pub quick: bool,
    /// With --quick: write the published BENCHMARKS.md sections and results/ all the same
    #[arg(long, requires = "quick")]
    publish: bool,
    /// Markdown file whose sections (between their markers) are replaced or added
    /// [default: BENCHMARKS.md; with --quick: target/bench-quick/BENCHMARKS.md]
    #[arg(long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Folder of the CSVs and plots [default: results; with --quick: target/bench-quick/results]
    #[arg(long, value_name = "DIR")]
    results: Option<PathBuf>,
    /// Seconds after which a child run is stopped and recorded as timed out [default: per suite]
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    timeout: Option<f64>,
    /// The core every child run is pinned to with taskset [default: the last one]
    #[arg(long, value_name = "CPU")]
    pub cpu: Option<usize>,
    /// The product binary whose `simulate` the suites run [default: `vadop` beside this program]
    #[arg(long, value_name = "FILE")]
    pub vadop: Option<PathBuf>,
}

impl Common {
    fn scratch(&self) -> bool {
        self.quick && !self.publish
    }

    /// The markdown file the suite's sections go into.
    pub fn markdown(&self) -> PathBuf {
        self.output.clone().unwrap_or_else(|| {
            if self.scratch() {
                Path::new(QUICK_DIR).join("BENCHMARKS.md")
            } else {
                PathBuf::from("BENCHMARKS.md")
            }
        })
    }

    /// The folder of CSVs and plots, created if missing.
    pub fn results(&self) -> CliResult<PathBuf> {
        let dir = self.results.clone().unwrap_or_else(|| {
            if self.scratch() {
                Path::new(QUICK_DIR).join("results")
            } else {
                PathBuf::from("results")
            }
        });
        create_dir(&dir)?;
        Ok(dir)
    }

    /// `--timeout`, or the suite's default.
    pub fn timeout(&self, default_seconds: f64) -> CliResult<Duration> {
        let seconds = self.timeout.unwrap_or(default_seconds);
        Duration::try_from_secs_f64(seconds).map_err(|e| format!("--timeout {seconds}: {e}"))
    }
}

/// The message for an I/O failure on `path`.
pub fn io_error(path: &Path, error: impl std::fmt::Display) -> String {
    format!("{}: {error}", path.display())
}

/// Creates `dir` and its parents.
pub fn create_dir(dir: &Path) -> CliResult<()> {
    std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))
}

/// Writes `text` to `path`, creating its folder.
pub fn write_file(path: &Path, text: &str) -> CliResult<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        create_dir(dir)?;
    }
    std::fs::write(path, text).map_err(|e| io_error(path, e))
}

/// Writes to stdout, turning a closed pipe into an error message instead of a panic.
pub fn print(text: &str) -> CliResult<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes()).and_then(|()| out.flush()).map_err(|e| format!("stdout: {e}"))
}

/// A number for a CSV cell: empty when unknown.
pub fn csv_number(value: Option<f64>) -> String {
    value.map_or(String::new(), |v| v.to_string())
}

/// The median of `values` (`None` when empty).
pub fn median(values: &[f64]) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let len = sorted.len();
    match len {
        0 => None,
        _ if len % 2 == 1 => Some(sorted[len / 2]),
        _ => Some(0.5 * (sorted[len / 2 - 1] + sorted[len / 2])),
    }
}

/// The value of nearest rank `q` in `values` (`None` when empty).
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len().max(1));
    sorted.get(rank - 1).copied()
}

/// Frames a run of speed `speed` (diameters per frame) needs so that its mean time per frame
/// covers several broad-phase windows: a window lasts about as long as the fastest tenth of the
/// bodies take to travel two diameters (the core's window rule), so a frame's cost is bimodal and
/// only a mean over whole windows means anything. Four windows, three with `quick`.
pub fn window_frames(speed: f64, quick: bool) -> u64 {
    let (windows, least) = if quick { (3.0, 5) } else { (4.0, 15) };
    ((windows * 2.0 / (0.9 * speed.max(1e-3))).ceil() as u64).clamp(least, 400)
}
