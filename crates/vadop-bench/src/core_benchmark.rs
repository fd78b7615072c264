//! `vadop-bench core`: the core engine over a grid of body counts and speeds in detect mode,
//! where every method follows identical paths: the default method (auto) and the paper's sweep
//! and prune (vadop) against the discrete method and brute force. Times and memory come from
//! children without a reference; the accuracy counts from separate children that step a
//! reference alongside, so references never pollute times or memory. It owns the grid, the
//! markdown section and the CSV (which the Python package's `vadop.plot.benchmark` reads).

use crate::common::{csv_number, window_frames, write_file, Common, Grid};
use crate::markdown::{self, table_cell, Markers, RunInfo};
use crate::progress::Progress;
use crate::runner::{Runner, Simulation};
use crate::summary::Summary;
use crate::CliResult;
use clap::Args;
use std::fmt::Write as _;

const MARKERS: Markers = Markers { name: "core-benchmark" };
/// In table order; auto is the default, the ratios are its.
const METHODS: [&str; 4] = ["auto", "vadop", "discrete", "brute"];

#[derive(Debug, Args)]
#[command(after_help = "Defaults: --bodies 1000,10000,100000,1000000 (with --quick: 1000,10000); --frames: auto and \
vadop enough to cover four broad-phase windows, discrete and brute (which have none) 30 up to 10^4 bodies, 10 up to \
10^5, 3 above (with --quick: 10).")]
pub struct CoreArgs {
    #[command(flatten)]
    grid: Grid,
    /// Largest n for which brute force runs (it tests every pair, O(n^2) per frame)
    /// [default: 10000; with --quick: 1000]
    #[arg(long, value_name = "N")]
    brute_max: Option<usize>,
    #[command(flatten)]
    common: Common,
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
    /// for auto and vadop above brute-max.
    accuracy: Option<Result<Summary, String>>,
}

impl Row {
    fn mean_ms(&self) -> Option<f64> {
        self.timing.as_ref().ok().map(|s| s.c_total_ms.mean)
    }
}

pub fn run(args: &CoreArgs) -> CliResult<()> {
    args.grid.check()?;
    let common = &args.common;
    let runner = Runner::new(common, common.timeout(600.0)?)?;
    let vadop = runner.product()?;
    let (markdown_path, csv_path) = (common.markdown(), common.results()?.join("core-benchmark.csv"));
    markdown::check(&markdown_path, MARKERS)?;
    let quick = common.quick;
    let bodies = args.grid.bodies.clone().unwrap_or(if quick {
        vec![1000, 10_000]
    } else {
        vec![1000, 10_000, 100_000, 1_000_000]
    });
    let brute_max = args.brute_max.unwrap_or(if quick { 1000 } else { 10_000 });
    let frames_for = |n: usize, speed: f64, method: &str| {
        let per_frame = match (quick, n) {
            (true, _) => 10,
            (false, ..=10_000) => 30,
            (false, ..=100_000) => 10,
            (false, _) => 3,
        };
        let windowed = matches!(method, "auto" | "vadop");
        args.grid.frames.unwrap_or(if windowed { per_frame.max(window_frames(speed, quick)) } else { per_frame })
    };
    let methods = |n: usize| METHODS.into_iter().filter(move |&m| m != "brute" || n <= brute_max);
    // The reference of a method's accuracy child, if it has one.
    let reference = |n: usize, method: &str| match (method, n <= brute_max) {
        ("brute", _) | ("auto" | "vadop", false) => None,
        (_, true) => Some("brute"),
        (_, false) => Some("vadop"),
    };
    let total: usize = bodies
        .iter()
        .map(|&n| {
            args.grid.speeds.len() * methods(n).map(|m| 1 + usize::from(reference(n, m).is_some())).sum::<usize>()
        })
        .sum();
    let progress = Progress::new(total);
    let info = RunInfo::start(runner.cpu());
    let mut rows = Vec::new();
    for &n in &bodies {
        for &speed in &args.grid.speeds {
            for method in methods(n) {
                let frames = frames_for(n, speed, method);
                let measure = |reference: &'static str| {
                    let what = format!("n={n} speed={speed} {method} (reference {reference})");
                    progress.start(&what);
                    let run = Simulation { reference, ..Simulation::paper(n, speed, frames, method) };
                    let outcome = runner.simulate(vadop, &run).map(|r| r.summary);
                    progress.done(&match &outcome {
                        Ok(s) => format!("{what}: {:.3} ms/frame (mean c_total)", s.c_total_ms.mean),
                        Err(e) => format!("{what}: {e}"),
                    });
                    outcome
                };
                let timing = measure("none");
                let accuracy = reference(n, method).map(measure);
                rows.push(Row { bodies: n, speed, method, frames, timing, accuracy });
                // Written after every row, so a run stopped early still leaves what it measured.
                write_csv(&csv_path, &rows)?;
                markdown::write_section(&markdown_path, MARKERS, &section(&rows, brute_max, &info))?;
            }
        }
    }
    progress.finish();
    let text = section(&rows, brute_max, &info);
    markdown::write_section(&markdown_path, MARKERS, &text)?;
    crate::common::print(&format!("{text}\nwrote {} and {}\n", markdown_path.display(), csv_path.display()))
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

/// auto's mean ms/frame divided by `other`'s on the same cell.
fn ratio(rows: &[Row], auto: &Row, other: &str) -> Option<f64> {
    if auto.method != "auto" {
        return None;
    }
    let other = rows.iter().find(|r| r.bodies == auto.bodies && r.speed == auto.speed && r.method == other)?;
    Some(auto.mean_ms()? / other.mean_ms()?)
}

fn section(rows: &[Row], brute_max: usize, info: &RunInfo) -> String {
    let mut md = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(md, "## Core benchmark\n\n{}", info.header());
    let _ = writeln!(
        md,
        "Paper scene (packing 0.05, seed 1) in detect mode, so every method follows identical paths. auto is the \
         default method (it picks a broad phase; the method column says which), vadop the paper's velocity-aligned \
         sweep and prune. ms/frame is the mean over frames of c_total = c_update + c_sort + c_test + c_response: the \
         continuous methods rebuild their broad phase once per window of several frames, so single frames are cheap or \
         dear and only a mean over whole windows compares; contacts/s divides all contacts by the wall-clock stepping \
         time; peak MiB is the child process's VmHWM.\n"
    );
    let _ = writeln!(md, "| n | speed (diam./frame) | method | frames | windows | mean ms/frame | contacts/frame | contacts/s | missed pair contacts | peak MiB | auto ÷ discrete | auto ÷ brute |");
    let _ = writeln!(md, "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let fmt_ratio = |r: Option<f64>| r.map_or(String::new(), |r| format!("{r:.3}"));
    for row in rows {
        let (method, windows, mean, per_frame, per_second, peak) = match &row.timing {
            Ok(s) => (
                s.run.method.clone(),
                format!("{:.0}", s.per_frame.windows * s.frames_completed as f64),
                format!("{:.3}", s.c_total_ms.mean),
                format!("{:.1}", s.per_frame.contacts),
                format!("{:.0}", s.contacts.per_wall_second),
                s.peak_memory_mib.map_or("—".to_string(), |m| format!("{m:.1}")),
            ),
            Err(e) => (row.method.to_string(), "—".into(), table_cell(e), "—".into(), "—".into(), "—".into()),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {method} | {} | {windows} | {mean} | {per_frame} | {per_second} | {} | {peak} | {} | {} |",
            row.bodies,
            row.speed,
            row.frames,
            missed_cell(row),
            fmt_ratio(ratio(rows, row, "discrete")),
            fmt_ratio(ratio(rows, row, "brute")),
        );
    }
    let _ = writeln!(md, "\nNotes:\n");
    let _ = writeln!(
        md,
        "- Missed pair contacts: (pair, frame) contacts the reference reported that the method did not report in \
         that frame, counted in a separate child that steps the reference alongside."
    );
    let _ = writeln!(
        md,
        "- Brute force runs only up to n = {brute_max}. Above that, discrete is checked against vadop, and auto and \
         vadop are not re-checked (\"0 (proven)\"): the core test suite proves every continuous method reports exactly \
         brute force's contacts."
    );
    let _ = writeln!(md, "- windows: broad-phase windows started over the run (discrete and brute have none). A ratio below 1 means auto is faster.");
    md
}

fn write_csv(path: &std::path::Path, rows: &[Row]) -> CliResult<()> {
    let mut text = String::from(
        "n,speed,method,frames,status,median_ms,mean_ms,p95_ms,contacts_per_frame,contacts_per_second,peak_mib,\
         reference,missed,extra,reference_pairs,auto_vs_discrete,auto_vs_brute\n",
    );
    for row in rows {
        let timing = row.timing.as_ref().ok();
        let status = match (&row.timing, &row.accuracy) {
            (Err(e), _) | (_, Some(Err(e))) => e.replace(',', ";"),
            _ => "ok".to_string(),
        };
        let accuracy = row.accuracy.as_ref().and_then(|a| a.as_ref().ok()).and_then(|s| s.accuracy.as_ref());
        let _ = writeln!(
            text,
            "{},{},{},{},{status},{},{},{},{},{},{},{},{},{},{},{},{}",
            row.bodies,
            row.speed,
            row.method,
            row.frames,
            csv_number(timing.map(|s| s.c_total_ms.median)),
            csv_number(timing.map(|s| s.c_total_ms.mean)),
            csv_number(timing.map(|s| s.c_total_ms.p95)),
            csv_number(timing.map(|s| s.per_frame.contacts)),
            csv_number(timing.map(|s| s.contacts.per_wall_second)),
            csv_number(timing.and_then(|s| s.peak_memory_mib)),
            accuracy.map_or("", |a| a.reference.as_str()),
            csv_number(accuracy.map(|a| a.missed as f64)),
            csv_number(accuracy.map(|a| a.extra as f64)),
            csv_number(accuracy.map(|a| a.reference_pairs as f64)),
            csv_number(ratio(rows, row, "discrete")),
            csv_number(ratio(rows, row, "brute")),
        );
    }
    write_file(path, &text)
}
