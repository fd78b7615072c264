//! Reporting: the per-frame rows, the run summary (built once from the rows, printed as text,
//! written as JSON and read back by the benchmark from its child runs), the CSV and JSON files,
//! and the small measurement helpers they need (order statistics, peak memory, progress bars,
//! writing to stdout). It owns every number format the user sees. It never steps a world or
//! decides what to run, and it never produces NaN in a summary, because JSON has no NaN and the
//! benchmark must be able to read every summary back.

use crate::CliResult;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::Path;
use vadop::scene::Scene;
use vadop::FrameStats;

/// One frame as written to the per-frame CSV and JSON: its counters, the cost split of
/// c_total in milliseconds and the wall-clock time of the whole step.
#[derive(Debug, Clone, Serialize)]
pub struct FrameRow {
    pub frame: u64,
    pub time: f64,
    pub contacts: u64,
    pub pair_contacts: u64,
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
}

impl FrameRow {
    const CSV_HEADER: &'static str = "frame,time,contacts,pair_contacts,ms,update_ms,sort_ms,test_ms,response_ms,\
        endpoint_swaps,list_entries,candidate_pairs,narrow_tests,invalidations,wall_ms,broad_phase_bytes";

    pub fn new(frame: u64, time: f64, stats: &FrameStats, wall_seconds: f64) -> FrameRow {
        FrameRow {
            frame,
            time,
            contacts: stats.contacts,
            pair_contacts: stats.pair_contacts,
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
        }
    }

    /// The row in the order of `CSV_HEADER`.
    fn csv_line(&self) -> String {
        format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
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
            self.broad_phase_bytes
        )
    }
}

/// What was simulated, described from the scene itself so that paper scenes and files read alike.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SceneInfo {
    /// Where the scene came from ("paper scene ..." or "scene file ...").
    pub source: String,
    pub bodies: usize,
    /// Side lengths of the box.
    pub extent: [f64; 3],
    /// Fraction of the box volume the spheres fill.
    pub packing: f64,
    /// Speed of the fastest body in its own diameters per frame.
    pub max_speed: f64,
}

impl SceneInfo {
    pub fn of(scene: &Scene, source: String, dt: f64) -> SceneInfo {
        let extent = scene.bounds.max - scene.bounds.min;
        let volume: f64 = scene.spheres.iter().map(|s| 4.0 / 3.0 * std::f64::consts::PI * s.radius.powi(3)).sum();
        let max_speed = scene.spheres.iter().map(|s| s.velocity.length() * dt / (2.0 * s.radius)).fold(0.0, f64::max);
        SceneInfo {
            source,
            bodies: scene.spheres.len(),
            extent: extent.to_array(),
            packing: volume / extent.element_product(),
            max_speed,
        }
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
    pub frames_requested: u64,
}

/// The axis pool of a VADOP run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PoolInfo {
    pub axes: usize,
    pub covering_radius_deg: f64,
    pub phi_deg: f64,
    /// Mean over frames of list entries / bodies: how many axes each body is bounded on.
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

/// Kinetic energy and momentum at the start and end of a run.
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
}

/// Median, mean and 95th percentile.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Spread {
    pub median: f64,
    pub mean: f64,
    pub p95: f64,
}

impl Spread {
    /// All zero for no values, so a summary never holds NaN.
    fn of(values: impl Iterator<Item = f64>) -> Spread {
        let mut values: Vec<f64> = values.collect();
        if values.is_empty() {
            return Spread::default();
        }
        values.sort_unstable_by(f64::total_cmp);
        let n = values.len();
        let median = if n % 2 == 1 { values[n / 2] } else { 0.5 * (values[n / 2 - 1] + values[n / 2]) };
        // Nearest rank: the smallest value with at least 95% of the values at or below it.
        let rank = ((0.95 * n as f64).ceil() as usize).clamp(1, n);
        Spread { median, mean: values.iter().sum::<f64>() / n as f64, p95: values[rank - 1] }
    }
}

/// Contact counts over the run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ContactTotals {
    pub total: u64,
    pub pairs: u64,
    pub walls: u64,
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
        rows: &[FrameRow],
        pool: Option<PoolInfo>,
        accuracy: Option<Accuracy>,
        conservation: Option<Conservation>,
        error: Option<String>,
    ) -> Summary {
        let frames = rows.len() as u64;
        let mean = |value: fn(&FrameRow) -> f64| if rows.is_empty() { 0.0 } else { rows.iter().map(value).sum::<f64>() / rows.len() as f64 };
        let total: u64 = rows.iter().map(|r| r.contacts).sum();
        let pairs: u64 = rows.iter().map(|r| r.pair_contacts).sum();
        let wall_seconds: f64 = rows.iter().map(|r| r.wall_ms).sum::<f64>() / 1e3;
        Summary {
            frames_completed: frames,
            simulated_seconds: frames as f64 * run.dt,
            pool,
            contacts: ContactTotals {
                total,
                pairs,
                walls: total - pairs,
                per_wall_second: if wall_seconds > 0.0 { total as f64 / wall_seconds } else { 0.0 },
            },
            accuracy,
            c_total_ms: Spread::of(rows.iter().map(|r| r.ms)),
            wall_ms: Spread::of(rows.iter().map(|r| r.wall_ms)),
            cost_split: CostSplit {
                update_ms: mean(|r| r.update_ms),
                sort_ms: mean(|r| r.sort_ms),
                test_ms: mean(|r| r.test_ms),
                response_ms: mean(|r| r.response_ms),
            },
            per_frame: PerFrame {
                contacts: mean(|r| r.contacts as f64),
                endpoint_swaps: mean(|r| r.endpoint_swaps as f64),
                candidate_pairs: mean(|r| r.candidate_pairs as f64),
                narrow_tests: mean(|r| r.narrow_tests as f64),
                invalidations: mean(|r| r.invalidations as f64),
            },
            broad_phase_bytes: rows.iter().map(|r| r.broad_phase_bytes).max().unwrap_or(0),
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
        let shape = if x == y && y == z { format!("cube of side {x:.4}") } else { format!("box {x:.4} x {y:.4} x {z:.4}") };
        writeln!(f, "scene       {}", scene.source)?;
        writeln!(
            f,
            "            {} bodies, {shape}, packing {:.4}, max speed {:.4} diameters/frame (fastest body)",
            scene.bodies, scene.packing, scene.max_speed
        )?;
        writeln!(f, "method      {}, {} mode, dt {} s, restitution {}", run.method, run.mode, run.dt, run.restitution)?;
        match &self.pool {
            Some(p) => writeln!(
                f,
                "pool        m = {} axes, rho = {:.4} deg, phi = {:.4} deg, {:.2} axes per body",
                p.axes, p.covering_radius_deg, p.phi_deg, p.axes_per_body
            )?,
            None => writeln!(f, "pool        none (the {} method does not use axes)", run.method)?,
        }
        writeln!(
            f,
            "frames      {} of {} ({:.4} s simulated)",
            self.frames_completed, run.frames_requested, self.simulated_seconds
        )?;
        let c = &self.contacts;
        writeln!(
            f,
            "contacts    {} ({} body pairs, {} walls), {:.1} per frame, {:.0} per wall-clock second",
            c.total, c.pairs, c.walls, self.per_frame.contacts, c.per_wall_second
        )?;
        match &self.accuracy {
            Some(a) => {
                let label = if a.identical_paths {
                    "detect mode: identical paths, so these are exact misses".to_string()
                } else {
                    match a.first_difference_frame {
                        Some(frame) => format!("simulate mode: paths diverge from frame {frame} on, so later differences are not misses"),
                        None => "simulate mode: paths never diverged".to_string(),
                    }
                };
                writeln!(
                    f,
                    "accuracy    vs {}: {} missed, {} extra of {} reference pair contacts ({label})",
                    a.reference, a.missed, a.extra, a.reference_pairs
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
            "per frame   {:.1} endpoint swaps, {:.1} candidate pairs, {:.1} narrow tests, {:.1} invalidations",
            p.endpoint_swaps, p.candidate_pairs, p.narrow_tests, p.invalidations
        )?;
        let peak = match self.peak_memory_mib {
            Some(mib) if self.accuracy.is_some() => format!("{mib:.1} MiB (whole process, reference world included)"),
            Some(mib) => format!("{mib:.1} MiB (whole process)"),
            None => "unknown (no /proc/self/status)".to_string(),
        };
        writeln!(f, "memory      broad phase {}, peak {peak}", format_bytes(self.broad_phase_bytes))?;
        if let Some(c) = &self.conservation {
            let drift = match c.kinetic_relative_drift {
                Some(drift) => format!("{drift:+.3e}"),
                None => "n/a (nothing moves)".to_string(),
            };
            writeln!(
                f,
                "energy      kinetic-energy relative drift {drift}; momentum change {:.3e} (walls exchange momentum with the bodies)",
                c.momentum_change
            )?;
        }
        if let Some(error) = &self.error {
            writeln!(f, "stopped     {error}")?;
        }
        Ok(())
    }
}

/// Bytes in the largest binary unit that keeps the number at or above 1.
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["B", "KiB", "MiB", "GiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{bytes} B")
    } else {
        format!("{value:.1} {}", UNITS[unit])
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

/// Writes the per-frame CSV: a header and one line per frame.
pub fn write_frames_csv(file: File, path: &Path, rows: &[FrameRow]) -> CliResult<()> {
    let mut out = BufWriter::new(file);
    writeln!(out, "{}", FrameRow::CSV_HEADER).map_err(|e| io_error(path, e))?;
    for row in rows {
        writeln!(out, "{}", row.csv_line()).map_err(|e| io_error(path, e))?;
    }
    out.flush().map_err(|e| io_error(path, e))
}

/// Writes `{"summary": ..., "frames": [...]}`.
pub fn write_json(file: File, path: &Path, summary: &Summary, rows: &[FrameRow]) -> CliResult<()> {
    #[derive(Serialize)]
    struct Report<'a> {
        summary: &'a Summary,
        frames: &'a [FrameRow],
    }
    let mut out = BufWriter::new(file);
    serde_json::to_writer_pretty(&mut out, &Report { summary, frames: rows }).map_err(|e| io_error(path, e))?;
    out.flush().map_err(|e| io_error(path, e))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_uses_nearest_rank_and_never_nan() {
        let s = Spread::of((1..=20).map(f64::from));
        assert_eq!((s.median, s.mean, s.p95), (10.5, 10.5, 19.0));
        let empty = Spread::of(std::iter::empty());
        assert_eq!((empty.median, empty.mean, empty.p95), (0.0, 0.0, 0.0));
    }

    #[test]
    fn bytes_read_well() {
        assert_eq!(format_bytes(512), "512 B");
        assert_eq!(format_bytes(1536), "1.5 KiB");
        assert_eq!(format_bytes(3 << 20), "3.0 MiB");
    }
}
