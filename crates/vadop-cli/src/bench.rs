//! `vadop bench`: the benchmark of the core engine over a grid of body counts and speeds in
//! detect mode, where every method follows identical paths. Every measurement is a child process
//! of this same binary running `simulate --json`, so each method's peak memory is its own; the
//! accuracy counts come from separate children that step a reference alongside, so references
//! never pollute times or memory. It owns the grid, the child processes (with a timeout), and the
//! markdown section and CSV it writes. It never touches the markdown file outside its markers, and
//! a child that fails or times out becomes a row saying so, never a crash of the benchmark.

use crate::experiments;
use crate::report::{self, Summary};
use crate::CliResult;
use clap::Args;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

const BEGIN: &str = "<!-- core-benchmark:begin -->";
const END: &str = "<!-- core-benchmark:end -->";
/// The paper's packing fraction; the benchmark varies only n and the speed.
const PACKING: &str = "0.05";
/// How often a running child is checked for exit or timeout.
const POLL: Duration = Duration::from_millis(20);

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Core suite: body counts n, comma-separated [default: 1000,10000,100000,1000000; with --quick: 1000,10000]
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    bodies: Option<Vec<usize>>,
    /// Core suite: maximum speeds in sphere diameters per frame, comma-separated
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_values_t = [0.05, 0.5, 5.0])]
    speeds: Vec<f64>,
    /// Core suite: frames per run [default: 30 up to 10^4 bodies, 10 up to 10^5, 3 above; with --quick: 10]
    #[arg(long, value_name = "F", value_parser = clap::value_parser!(u64).range(1..))]
    frames: Option<u64>,
    /// Core suite: largest n for which brute force runs (it tests every pair, O(n^2) per frame)
    /// [default: 10000; with --quick: 1000]
    #[arg(long, value_name = "N")]
    brute_max: Option<usize>,
    /// Seconds after which a child run is stopped and recorded as timed out
    #[arg(long, value_name = "SECONDS", default_value_t = 600.0)]
    timeout: f64,
    /// Small sizes that finish in about a minute: core grid at n = 1000 and 10000 with 10 frames
    /// (brute force only at 1000), experiments at n = 1000 with 5 frames and pools up to 32 axes
    #[arg(long)]
    quick: bool,
    /// Markdown file whose sections (between their markers) are replaced or added
    #[arg(long, value_name = "FILE", default_value = "BENCHMARKS.md")]
    output: PathBuf,
    /// Core suite: CSV file of all rows (its directory is created if missing)
    #[arg(long, value_name = "FILE", default_value = "results/core-benchmark.csv")]
    csv: PathBuf,
    /// Which benchmark to run: core (the n x speed grid of vadop, discrete and brute force), experiments
    /// (the paper's experiments with every method, CSV and plots) or all
    #[arg(long, value_enum, default_value_t = Suite::All)]
    suite: Suite,
    /// Folder for the experiments' CSV and PNG plots
    #[arg(long, value_name = "DIR", default_value = "results/experiments")]
    plots: PathBuf,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Suite {
    Core,
    Experiments,
    All,
}

/// The part of a child's `--json` file the benchmark reads.
#[derive(Deserialize)]
struct ChildReport {
    summary: Summary,
}

/// One method on one (n, speed) cell.
struct Row {
    bodies: usize,
    speed: f64,
    method: &'static str,
    frames: u64,
    /// Time and memory, from a child without a reference.
    timing: Result<Summary, String>,
    /// Missed contacts, from a child with a reference; `None` for brute (it is the reference) and
    /// for vadop above brute-max.
    accuracy: Option<Result<Summary, String>>,
}

impl Row {
    fn median_ms(&self) -> Option<f64> {
        self.timing.as_ref().ok().map(|s| s.c_total_ms.median)
    }
}

pub fn run(args: &BenchArgs) -> CliResult<()> {
    let timeout = Duration::try_from_secs_f64(args.timeout).map_err(|e| format!("--timeout {}: {e}", args.timeout))?;
    if args.suite != Suite::Experiments {
        run_core(args, timeout)?;
    }
    if args.suite != Suite::Core {
        experiments::run(&experiments::Plan::new(args.quick, timeout), &args.output, &args.plots)?;
    }
    Ok(())
}

/// The core grid: n x speed, vadop against the discrete method and brute force.
fn run_core(args: &BenchArgs, timeout: Duration) -> CliResult<()> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find this program's own path: {e}"))?;
    let default_bodies: &[usize] = if args.quick { &[1000, 10_000] } else { &[1000, 10_000, 100_000, 1_000_000] };
    let bodies = args.bodies.clone().unwrap_or_else(|| default_bodies.to_vec());
    let frames_for = |n: usize| {
        args.frames.unwrap_or(match (args.quick, n) {
            (true, _) => 10,
            (false, ..=10_000) => 30,
            (false, ..=100_000) => 10,
            (false, _) => 3,
        })
    };
    // Check that both outputs can be written before spending minutes measuring.
    let existing = read_markdown(&args.output)?;
    if let Some(dir) = args.csv.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| report::io_error(dir, e))?;
    }
    let csv_file = report::create_file(&args.csv)?;

    // Brute force at 10^4 bodies takes about a second per frame, too slow for a quick grid.
    let brute_max = args.brute_max.unwrap_or(if args.quick { 1000 } else { 10_000 });
    let brute_feasible = |n: usize| n <= brute_max;
    let methods = |n: usize| -> Vec<&'static str> {
        if brute_feasible(n) {
            vec!["vadop", "discrete", "brute"]
        } else {
            vec!["vadop", "discrete"]
        }
    };
    let child_runs: usize = bodies
        .iter()
        .map(|&n| {
            let accuracy_runs = if brute_feasible(n) { 2 } else { 1 };
            args.speeds.len() * (methods(n).len() + accuracy_runs)
        })
        .sum();
    let bar = report::progress_bar(child_runs as u64, "runs");
    report::reveal(&bar);
    let scratch = std::env::temp_dir().join(format!("vadop-bench-{}", std::process::id()));
    let mut rows = Vec::new();
    for &n in &bodies {
        for &speed in &args.speeds {
            let frames = frames_for(n);
            for method in methods(n) {
                let measure = |reference: &str| {
                    bar.set_message(format!("n={n} speed={speed} {method} (reference {reference})"));
                    let outcome = run_child(&exe, &child_args(n, speed, frames, method, "detect", reference, &scratch), &scratch, timeout);
                    bar.inc(1);
                    outcome
                };
                let timing = measure("none");
                let accuracy = match (method, brute_feasible(n)) {
                    ("brute", _) | ("vadop", false) => None,
                    (_, true) => Some(measure("brute")),
                    (_, false) => Some(measure("vadop")),
                };
                rows.push(Row { bodies: n, speed, method, frames, timing, accuracy });
            }
        }
    }
    bar.finish_and_clear();

    write_csv(csv_file, &args.csv, &rows)?;
    let section = markdown_section(&rows, brute_max);
    let merged = merge_section(existing.as_deref(), &section, &args.output)?;
    std::fs::write(&args.output, merged).map_err(|e| report::io_error(&args.output, e))?;
    report::print(&format!("{section}\nwrote {} and {}\n", args.output.display(), args.csv.display()))
}

/// The flags of a paper-scene run; the child writes its summary to `scratch`.json.
pub(crate) fn child_args(bodies: usize, speed: f64, frames: u64, method: &str, mode: &str, reference: &str, scratch: &Path) -> Vec<String> {
    let flags = [
        ("--bodies", bodies.to_string()),
        ("--packing", PACKING.to_string()),
        ("--max-speed", speed.to_string()),
        ("--seed", "1".to_string()),
        ("--frames", frames.to_string()),
        ("--mode", mode.to_string()),
        ("--method", method.to_string()),
        ("--reference", reference.to_string()),
        ("--json", scratch.with_extension("json").display().to_string()),
    ];
    let mut args = vec!["simulate".to_string(), "--quiet".to_string()];
    for (flag, value) in flags {
        args.push(flag.to_string());
        args.push(value);
    }
    args
}

/// Runs one child to completion or timeout and reads its summary.
pub(crate) fn run_child(exe: &Path, args: &[String], scratch: &Path, timeout: Duration) -> Result<Summary, String> {
    let (json, stderr_path) = (scratch.with_extension("json"), scratch.with_extension("stderr"));
    // A file, not a pipe: a child writing more than a pipe holds would block until the timeout.
    let stderr = report::create_file(&stderr_path)?;
    let child = Command::new(exe)
        .args(args)
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .map_err(|e| format!("could not start {}: {e}", exe.display()))?;
    if let Err(e) = finish_child(child, timeout, &stderr_path) {
        let _ = std::fs::remove_file(&json);
        return Err(e);
    }
    let text = std::fs::read_to_string(&json).map_err(|e| report::io_error(&json, e))?;
    let _ = std::fs::remove_file(&json);
    let report: ChildReport = serde_json::from_str(&text).map_err(|e| report::io_error(&json, e))?;
    Ok(report.summary)
}

/// Waits for `child` until it exits or `timeout` passes (then kills it). A failed exit becomes
/// an error carrying the last line the child wrote to `stderr_path`, which is removed either way.
pub(crate) fn finish_child(mut child: Child, timeout: Duration, stderr_path: &Path) -> Result<(), String> {
    let start = Instant::now();
    let waited = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Ok(status),
            Ok(None) if start.elapsed() > timeout => {
                // Failing to kill means it has just exited; either way it is waited for.
                let _ = child.kill();
                let _ = child.wait();
                break Err(format!("timed out after {} s", timeout.as_secs_f64()));
            }
            Ok(None) => std::thread::sleep(POLL),
            Err(e) => break Err(format!("could not wait for the child: {e}")),
        }
    };
    let messages = std::fs::read_to_string(stderr_path).unwrap_or_default();
    let _ = std::fs::remove_file(stderr_path);
    let status = waited?;
    if !status.success() {
        let last = messages.lines().rev().find(|line| !line.trim().is_empty()).unwrap_or("no message");
        return Err(format!("failed ({status}): {}", last.trim_start_matches("error: ")));
    }
    Ok(())
}

/// Reads the markdown file, or `None` when it does not exist yet.
pub(crate) fn read_markdown(path: &Path) -> CliResult<Option<String>> {
    match std::fs::read_to_string(path) {
        Ok(text) => Ok(Some(text)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(report::io_error(path, e)),
    }
}

/// `existing` with its section between the core-benchmark markers replaced by `section`.
fn merge_section(existing: Option<&str>, section: &str, path: &Path) -> CliResult<String> {
    merge_marked_section(existing, section, path, BEGIN, END)
}

/// `existing` with its section between the markers `begin` and `end` replaced by `section`, or
/// `section` appended when there are no markers. Unbalanced markers are an error: guessing could
/// delete user text.
pub(crate) fn merge_marked_section(existing: Option<&str>, section: &str, path: &Path, begin_marker: &str, end_marker: &str) -> CliResult<String> {
    let Some(text) = existing else {
        return Ok(format!("# Benchmarks\n\n{section}\n"));
    };
    match (text.find(begin_marker), text.find(end_marker)) {
        (Some(begin), Some(end)) if begin < end => Ok(format!("{}{section}{}", &text[..begin], &text[end + end_marker.len()..])),
        (None, None) => {
            let separator = if text.is_empty() || text.ends_with("\n\n") {
                ""
            } else if text.ends_with('\n') {
                "\n"
            } else {
                "\n\n"
            };
            Ok(format!("{text}{separator}{section}\n"))
        }
        _ => Err(format!("{}: the markers {begin_marker} and {end_marker} are unbalanced or out of order; fix them by hand", path.display())),
    }
}

/// Missed contacts of an accuracy run, as a table cell.
fn missed_cell(row: &Row) -> String {
    match &row.accuracy {
        None if row.method == "brute" => "reference".to_string(),
        None => "0 (proven)".to_string(),
        Some(Err(e)) => table_cell(e),
        Some(Ok(summary)) => match &summary.accuracy {
            Some(a) => format!("{} of {} (vs {})", a.missed, a.reference_pairs, a.reference),
            None => "n/a".to_string(),
        },
    }
}

/// A child's message made safe inside a markdown table row.
pub(crate) fn table_cell(message: &str) -> String {
    message.replace('|', "\\|").replace('\n', " ")
}

/// vadop's median ms/frame divided by `other`'s on the same cell.
fn ratio(rows: &[Row], vadop: &Row, other: &str) -> Option<f64> {
    let other = rows.iter().find(|r| r.bodies == vadop.bodies && r.speed == vadop.speed && r.method == other)?;
    Some(vadop.median_ms()? / other.median_ms()?)
}

fn markdown_section(rows: &[Row], brute_max: usize) -> String {
    let mut md = String::new();
    let command: Vec<String> = std::env::args().skip(1).map(|a| if a.contains(' ') { format!("'{a}'") } else { a }).collect();
    // Writing to a String cannot fail.
    let _ = writeln!(md, "{BEGIN}");
    let _ = writeln!(md, "## Core benchmark\n");
    let _ = writeln!(md, "Produced by `vadop {}` on {}.  ", command.join(" "), utc_now());
    let _ = writeln!(md, "Machine: {}.\n", machine());
    let _ = writeln!(
        md,
        "Paper scene (packing {PACKING}, seed 1) in detect mode, so every method follows identical paths. \
         ms/frame is the median of c_total = c_update + c_sort + c_test + c_response; contacts/s divides all \
         contacts by the wall-clock stepping time; peak MiB is the child process's VmHWM.\n"
    );
    let _ = writeln!(md, "| n | speed (diam./frame) | method | frames | median ms/frame | contacts/frame | contacts/s | missed pair contacts | peak MiB | vadop ÷ discrete | vadop ÷ brute |");
    let _ = writeln!(md, "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let fmt_ratio = |r: Option<f64>| r.map_or("—".to_string(), |r| format!("{r:.3}"));
    for row in rows {
        let (median, per_frame, per_second, peak) = match &row.timing {
            Ok(s) => (
                format!("{:.3}", s.c_total_ms.median),
                format!("{:.1}", s.per_frame.contacts),
                format!("{:.0}", s.contacts.per_wall_second),
                s.peak_memory_mib.map_or("—".to_string(), |m| format!("{m:.1}")),
            ),
            Err(e) => (table_cell(e), "—".into(), "—".into(), "—".into()),
        };
        let (vs_discrete, vs_brute) = if row.method == "vadop" {
            (fmt_ratio(ratio(rows, row, "discrete")), fmt_ratio(ratio(rows, row, "brute")))
        } else {
            (String::new(), String::new())
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {median} | {per_frame} | {per_second} | {} | {peak} | {vs_discrete} | {vs_brute} |",
            row.bodies,
            row.speed,
            row.method,
            row.frames,
            missed_cell(row)
        );
    }
    let _ = writeln!(md, "\nNotes:\n");
    let _ = writeln!(
        md,
        "- Missed pair contacts: (pair, frame) contacts the reference reported that the method did not report in \
         that frame, counted in a separate child that steps the reference alongside; times and memory come from \
         children without a reference."
    );
    let _ = writeln!(
        md,
        "- Brute force runs only up to n = {brute_max}. Above that, discrete is checked against vadop, and vadop is \
         not re-checked (\"0 (proven)\"): the core test suite proves it reports exactly brute force's contacts."
    );
    let _ = writeln!(md, "- A ratio below 1 means vadop is faster than that method on the same scene.");
    let _ = write!(md, "{END}");
    md
}

fn write_csv(file: std::fs::File, path: &Path, rows: &[Row]) -> CliResult<()> {
    let mut text = String::from(
        "n,speed,method,frames,status,median_ms,mean_ms,p95_ms,contacts_per_frame,contacts_per_second,peak_mib,\
         reference,missed,extra,reference_pairs,vadop_vs_discrete,vadop_vs_brute\n",
    );
    let number = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
    for row in rows {
        let timing = row.timing.as_ref().ok();
        let status = match (&row.timing, &row.accuracy) {
            (Err(e), _) | (_, Some(Err(e))) => e.replace(',', ";"),
            _ => "ok".to_string(),
        };
        let accuracy = row.accuracy.as_ref().and_then(|a| a.as_ref().ok()).and_then(|s| s.accuracy.as_ref());
        let vadop_ratio = |other| if row.method == "vadop" { ratio(rows, row, other) } else { None };
        let _ = writeln!(
            text,
            "{},{},{},{},{status},{},{},{},{},{},{},{},{},{},{},{},{}",
            row.bodies,
            row.speed,
            row.method,
            row.frames,
            number(timing.map(|s| s.c_total_ms.median)),
            number(timing.map(|s| s.c_total_ms.mean)),
            number(timing.map(|s| s.c_total_ms.p95)),
            number(timing.map(|s| s.per_frame.contacts)),
            number(timing.map(|s| s.contacts.per_wall_second)),
            number(timing.and_then(|s| s.peak_memory_mib)),
            accuracy.map_or("", |a| a.reference.as_str()),
            number(accuracy.map(|a| a.missed as f64)),
            number(accuracy.map(|a| a.extra as f64)),
            number(accuracy.map(|a| a.reference_pairs as f64)),
            number(vadop_ratio("discrete")),
            number(vadop_ratio("brute")),
        );
    }
    use std::io::Write as _;
    let mut file = file;
    file.write_all(text.as_bytes()).map_err(|e| report::io_error(path, e))
}

/// CPU model, core count and total memory, from /proc where available.
pub(crate) fn machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let cpu = cpuinfo
        .lines()
        .find(|line| line.starts_with("model name"))
        .and_then(|line| line.split(':').nth(1))
        .map_or("unknown CPU".to_string(), |model| model.trim().to_string());
    let cores = std::thread::available_parallelism().map_or("unknown".to_string(), |n| n.to_string());
    let meminfo = std::fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let memory = meminfo
        .lines()
        .find(|line| line.starts_with("MemTotal:"))
        .and_then(|line| line.split_whitespace().nth(1))
        .and_then(|kib| kib.parse::<f64>().ok())
        .map_or("unknown".to_string(), |kib| format!("{:.1} GiB", kib / (1024.0 * 1024.0)));
    format!("{cpu}, {cores} cores available, {memory} memory")
}

/// The current UTC date and time, without a date crate.
pub(crate) fn utc_now() -> String {
    let seconds = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    // Howard Hinnant's days-from-civil inverse, for the proleptic Gregorian calendar.
    let z = (seconds / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let day_of_era = z.rem_euclid(146_097);
    let year_of_era = (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let shifted_month = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * shifted_month + 2) / 5 + 1;
    let month = if shifted_month < 10 { shifted_month + 3 } else { shifted_month - 9 };
    let year = year_of_era + era * 400 + i64::from(month <= 2);
    let minutes = seconds % 86_400 / 60;
    format!("{year:04}-{month:02}-{day:02} {:02}:{:02} UTC", minutes / 60, minutes % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_replace_only_between_markers() {
        let path = Path::new("B.md");
        let section = format!("{BEGIN}\nnew\n{END}");
        let text = format!("# Top\n\n{BEGIN}\nold\n{END}\n\nTail\n");
        assert_eq!(merge_section(Some(&text), &section, path).unwrap(), format!("# Top\n\n{section}\n\nTail\n"));
        assert_eq!(merge_section(Some("# Top\n"), &section, path).unwrap(), format!("# Top\n\n{section}\n"));
        assert!(merge_section(None, &section, path).unwrap().contains(&section));
        assert!(merge_section(Some(&format!("{END}{BEGIN}")), &section, path).is_err());
    }
}
