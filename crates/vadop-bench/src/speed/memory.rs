//! Memory per body: the peak resident memory (VmHWM) of a detect-mode run of the default method
//! at speed 0.5, less that of the same binary stepping a single body (the empty process: code,
//! allocator and buffers), divided by the body count. The goal is at most 300 bytes per body at
//! n = 10^6.

use super::{cell, median_of, Context, Section, Timed};
use crate::common::csv_number;
use crate::plots::{self, Series};
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::CliResult;
use std::fmt::Write as _;
use std::rc::Rc;

const SPEED: f64 = 0.5;
/// Enough to pass a window start and the frames after it; the peak comes at the first.
const FRAMES: u64 = 5;
const GOAL_BYTES: f64 = 300.0;

/// Median over repeats of a run's peak MiB.
fn peak_mib(timed: &Timed) -> Option<f64> {
    let reports = timed.as_ref().ok()?;
    reports
        .iter()
        .all(|r| r.summary.peak_memory_mib.is_some())
        .then(|| median_of(reports, |r| r.summary.peak_memory_mib.unwrap_or(0.0)))
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let plan = &context.plan;
    let product = context.runner.product()?;
    let progress = Progress::new(plan.memory_bodies.len() + 1);
    let empty = context.time(product, &Simulation::paper(1, SPEED, FRAMES, "auto"), &progress);
    let mut rows: Vec<(usize, Rc<Timed>)> = Vec::new();
    for &n in &plan.memory_bodies {
        rows.push((n, context.time(product, &Simulation::paper(n, SPEED, FRAMES, "auto"), &progress)));
        write(context, &empty, &rows)?;
    }
    progress.finish();
    let (path, _) = context.plot("memory.png");
    let per_body: Vec<(f64, f64)> =
        rows.iter().filter_map(|(n, t)| Some((*n as f64, bytes_per_body(*n, t, &empty)?))).collect();
    let goal = per_body.iter().map(|p| (p.0, GOAL_BYTES)).collect();
    let series = vec![Series::new("default method, detect mode, speed 0.5", per_body), Series::new("goal", goal)];
    plots::line_chart(&path, "Peak memory above an empty process, per body", "bodies n", "bytes per body", series)
}

fn bytes_per_body(n: usize, timed: &Timed, empty: &Timed) -> Option<f64> {
    Some((peak_mib(timed)? - peak_mib(empty)?) * 1024.0 * 1024.0 / n as f64)
}

fn write(context: &Context, empty: &Timed, rows: &[(usize, Rc<Timed>)]) -> CliResult<()> {
    let empty_mib = peak_mib(empty);
    let mut md = format!(
        "Paper scene (packing 0.05, seed 1), detect mode, speed {SPEED}, default method, {FRAMES} frames. Peak: the \
         child's VmHWM (median of {} runs); the empty process is the same binary stepping one body ({} MiB). \
         Goal: at most {GOAL_BYTES} bytes per body at n = 10^6.\n\n",
        context.repeats,
        match empty {
            Ok(_) => cell(empty_mib, 1),
            Err(e) => format!("failed: {e}"),
        }
    );
    let _ = writeln!(md, "| n | peak MiB | bytes per body above the empty process |");
    let _ = writeln!(md, "|---:|---:|---:|");
    let mut csv = String::from("n,frames,peak_mib,empty_peak_mib,bytes_per_body,status\n");
    for (n, timed) in rows {
        let (peak, per_body) = (peak_mib(timed), bytes_per_body(*n, timed, empty));
        let peak_cell = match timed.as_ref() {
            Ok(_) => cell(peak, 1),
            Err(e) => crate::markdown::table_cell(e),
        };
        let _ = writeln!(md, "| {n} | {peak_cell} | {} |", cell(per_body, 0));
        let status = timed.as_ref().as_ref().err().map_or("ok".to_string(), |e| e.replace(',', ";"));
        let _ = writeln!(
            csv,
            "{n},{FRAMES},{},{},{},{status}",
            csv_number(peak),
            csv_number(empty_mib),
            csv_number(per_body)
        );
    }
    let (_, link) = context.plot("memory.png");
    let _ = writeln!(md, "\n![bytes per body against n]({link})\n");
    context.write(Section::Memory.markers(), "Memory per body", &md, "memory.csv", &csv)
}
