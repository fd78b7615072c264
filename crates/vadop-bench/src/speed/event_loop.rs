//! Simulate mode's event loop (issue 27): the elastic equilibrium gas (`--kind gas`) in a box
//! periodic on every axis, which the default method steps with its event loop of spheres. Four
//! tables, each from runs of this command: pair collisions per second on one pinned core at
//! every size and packing; the same gas with frames of 0.05 to 5 rms diameters of travel, which
//! should not change the rate; every core against one; and the kinetic energy's drift over 10^7
//! pair collisions. Runs are sized in collisions (from Enskog's rate with Hansen-Goos's contact
//! value), not frames, so dense and sparse gases are measured alike.

use super::periodic::collisions_per_sphere_per_frame;
use super::throughput::collision_rates;
use super::{cell, first, ratio, Context, Section, Timed};
use crate::common::csv_number;
use crate::plots::{self, Panel, Series};
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::CliResult;
use std::fmt::Write as _;
use std::rc::Rc;
use vadop::scene::FRAMES_PER_SECOND;

/// The gas's rms speed in diameters per frame of 1/30 s.
const RMS_SPEED: f64 = 0.2;
/// Packing of the frame-length sweep and of the energy run's neighbour rows.
const SWEEP_PACKING: f64 = 0.2;
/// Collisions per sphere before a run is measured: the lattice start has melted by then.
const WARM_UP_PER_SPHERE: f64 = 5.0;
/// Frames measured at least.
const MIN_FRAMES: u64 = 4;
/// Goals of issue 27: pair collisions per second on one core at n = 10^5, the spread of the
/// frame-length sweep, the speed-up of two cores at n >= 10^5, the energy drift.
const RATE_GOAL: f64 = 1e6;
const SWEEP_GOAL: f64 = 0.2;
const SPEEDUP_GOAL: f64 = 1.7;
const DRIFT_GOAL: f64 = 1e-12;
/// Packing of the energy run: the densest, the most collisions per frame.
const DRIFT_PACKING: f64 = 0.4;

/// A gas run: its frames of `travel` rms diameters, warm-up then measured, for about `pairs`
/// pair collisions measured.
struct Sized {
    run: Simulation,
    warm_up: u64,
    measured: u64,
}

fn sized(bodies: usize, packing: f64, travel: f64, pairs: f64, threads: usize) -> Sized {
    // Collisions per sphere per frame of `travel` rms diameters.
    let rate = collisions_per_sphere_per_frame(packing) * travel / RMS_SPEED;
    let warm_up = (WARM_UP_PER_SPHERE / rate).ceil() as u64;
    let measured = ((2.0 * pairs / bodies as f64) / rate).ceil().max(MIN_FRAMES as f64) as u64;
    let run = Simulation {
        kind: "gas",
        packing,
        mode: "simulate",
        dt: Some(travel / (RMS_SPEED * FRAMES_PER_SECOND)),
        threads: Some(threads),
        periodic: Some("xyz"),
        ..Simulation::paper(bodies, RMS_SPEED, warm_up + measured, "auto")
    };
    Sized { run, warm_up, measured }
}

/// One measured gas: its size, and the runs on one thread (and on every core).
struct Row {
    bodies: usize,
    packing: f64,
    travel: f64,
    warm_up: u64,
    measured: u64,
    one: Rc<Timed>,
    all: Option<Rc<Timed>>,
}

impl Row {
    /// Median pair collisions per second of the measured frames on one thread, on every core.
    fn rates(&self) -> (Option<f64>, Option<f64>) {
        let rate = |t: &Timed| collision_rates(t, self.warm_up).map(|r| r.1);
        (rate(&self.one), self.all.as_deref().and_then(rate))
    }

    /// Pair collisions of the measured frames (the first repeat's).
    fn pairs(&self) -> Option<u64> {
        let report = first(&self.one)?;
        Some(report.frames.iter().skip(self.warm_up as usize).map(|f| f.pair_contacts).sum())
    }
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let plan = &context.plan;
    let product = context.runner.product()?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let progress = Progress::new(
        plan.loop_bodies.len() * plan.packings.len()
            + plan.travels.len()
            + 2 * plan.loop_threads_bodies.len() * plan.packings.len()
            + 1,
    );
    let measure = |bodies: usize, packing: f64, travel: f64, pairs: f64, all: bool| {
        let one = sized(bodies, packing, travel, pairs, 1);
        let timed_one = context.measure(product, &one.run, &progress);
        let all = all.then(|| context.measure(product, &sized(bodies, packing, travel, pairs, cores).run, &progress));
        Row { bodies, packing, travel, warm_up: one.warm_up, measured: one.measured, one: timed_one, all }
    };
    let mut tables = Tables::default();
    for &bodies in &plan.loop_bodies {
        for &packing in &plan.packings {
            tables.rates.push(measure(bodies, packing, RMS_SPEED, plan.loop_pairs, false));
            write(context, &tables, cores)?;
        }
    }
    for &travel in &plan.travels {
        tables.sweep.push(measure(plan.loop_sweep_bodies, SWEEP_PACKING, travel, plan.loop_pairs, false));
        write(context, &tables, cores)?;
    }
    for &bodies in &plan.loop_threads_bodies {
        for &packing in &plan.packings {
            tables.cores.push(measure(bodies, packing, RMS_SPEED, plan.loop_pairs, true));
            write(context, &tables, cores)?;
        }
    }
    tables.drift.push(measure(plan.loop_sweep_bodies, DRIFT_PACKING, RMS_SPEED, plan.drift_pairs, false));
    write(context, &tables, cores)?;
    progress.finish();
    plot(context, &tables)
}

/// The four tables' rows so far.
#[derive(Default)]
struct Tables {
    rates: Vec<Row>,
    sweep: Vec<Row>,
    cores: Vec<Row>,
    drift: Vec<Row>,
}

/// A row's frames as `warm-up + measured`.
fn frames(row: &Row) -> String {
    format!("{} + {}", row.warm_up, row.measured)
}

/// A rate cell, or the run's failure.
fn rate_cell(timed: &Timed, rate: Option<f64>) -> String {
    match timed {
        Ok(_) => cell(rate, 0),
        Err(e) => crate::markdown::table_cell(e),
    }
}

fn write(context: &Context, tables: &Tables, cores: usize) -> CliResult<()> {
    let (plan, repeats) = (&context.plan, context.repeats);
    let mut md = format!(
        "`vadop simulate --kind gas --periodic xyz --max-speed {RMS_SPEED}` (elastic, default method: simulate mode's \
         event loop of spheres), each run warmed up by {WARM_UP_PER_SPHERE} collisions per sphere (the gas starts on a \
         lattice), then about {:.0e} pair collisions measured ({:.0e} for the energy); pair collisions per second of \
         the measured frames' wall-clock time, median of {repeats} runs; one thread is a child pinned to one core, \
         every core ({cores}) is `--threads {cores}`, unpinned.\n\n",
        plan.loop_pairs, plan.drift_pairs
    );
    let _ = writeln!(
        md,
        "One core. Goal: at least {:.0e} pair collisions per second at n = 10^5 in every packing.\n",
        RATE_GOAL
    );
    let _ = writeln!(
        md,
        "| n | packing | frames (warm-up + measured) | pair collisions measured | pair collisions/s | goal |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---|");
    let mut csv = String::from("table,n,packing,travel,warm_up_frames,measured_frames,pairs,one_thread_per_second,all_cores_per_second,energy_drift\n");
    for row in &tables.rates {
        let rate = row.rates().0;
        let goal = match (row.bodies, rate) {
            (100_000, Some(r)) if r >= RATE_GOAL => "met",
            (100_000, Some(_)) => "missed",
            _ => "",
        };
        let pairs = row.pairs().map_or("—".into(), |p| p.to_string());
        let _ = writeln!(
            md,
            "| {} | {} | {} | {pairs} | {} | {goal} |",
            row.bodies,
            row.packing,
            frames(row),
            rate_cell(&row.one, rate)
        );
        csv_row(&mut csv, "one-core", row, None);
    }
    let _ = writeln!(md, "\nFrames of different length (n = {}, packing {SWEEP_PACKING}): the rate should not depend on them. Goal: every rate within {:.0} % of the others.\n", plan.loop_sweep_bodies, SWEEP_GOAL * 100.0);
    let _ = writeln!(
        md,
        "| frame (rms diameters) | dt (s) | frames (warm-up + measured) | pair collisions/s | ÷ fastest |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|");
    let rates: Vec<f64> = tables.sweep.iter().filter_map(|r| r.rates().0).collect();
    let fastest = rates.iter().copied().fold(f64::NAN, f64::max);
    for row in &tables.sweep {
        let rate = row.rates().0;
        let dt = row.travel / (RMS_SPEED * FRAMES_PER_SECOND);
        let _ = writeln!(
            md,
            "| {} | {dt:.5} | {} | {} | {} |",
            row.travel,
            frames(row),
            rate_cell(&row.one, rate),
            cell(ratio(rate, Some(fastest)), 3)
        );
        csv_row(&mut csv, "frame-length", row, None);
    }
    if rates.len() == tables.sweep.len() && !rates.is_empty() {
        let slowest = rates.iter().copied().fold(f64::NAN, f64::min);
        let spread = 1.0 - slowest / fastest;
        let verdict = if spread <= SWEEP_GOAL { "met" } else { "missed" };
        let _ = writeln!(md, "\nSlowest {:.1} % below the fastest: goal {verdict}.", spread * 100.0);
    }
    let _ = writeln!(
        md,
        "\nEvery core against one, right after each other. Goal: at least {SPEEDUP_GOAL}x at n >= 10^5.\n"
    );
    let _ = writeln!(md, "| n | packing | one thread (pair collisions/s) | {cores} threads | speed-up | goal |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---|");
    for row in &tables.cores {
        let (one, all) = row.rates();
        let speedup = ratio(all, one);
        let goal = match speedup {
            Some(s) if row.bodies >= 100_000 && s >= SPEEDUP_GOAL => "met",
            Some(_) if row.bodies >= 100_000 => "missed",
            _ => "",
        };
        let all_cell = row.all.as_deref().map_or("—".into(), |t| rate_cell(t, all));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {all_cell} | {} | {goal} |",
            row.bodies,
            row.packing,
            rate_cell(&row.one, one),
            cell(speedup, 2)
        );
        csv_row(&mut csv, "cores", row, None);
    }
    let _ = writeln!(md, "\nEnergy: the kinetic energy's relative drift over the whole run (warm-up included). Goal: at most {DRIFT_GOAL:.0e} over 10^7 pair collisions.\n");
    let _ = writeln!(md, "| n | packing | frames | pair collisions | pair collisions/s | relative drift | goal |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---|");
    for row in &tables.drift {
        let drift = first(&row.one).and_then(|r| r.summary.conservation.as_ref()?.kinetic_relative_drift);
        let total: Option<u64> = first(&row.one).map(|r| r.frames.iter().map(|f| f.pair_contacts).sum());
        let goal = match (drift, total) {
            (Some(d), Some(p)) if d.abs() <= DRIFT_GOAL && p as f64 >= 1e7 => "met",
            (Some(d), _) if d.abs() > DRIFT_GOAL => "missed",
            _ => "",
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {goal} |",
            row.bodies,
            row.packing,
            row.warm_up + row.measured,
            total.map_or("—".into(), |p| p.to_string()),
            rate_cell(&row.one, row.rates().0),
            drift.map_or("—".into(), |d| format!("{d:+.3e}"))
        );
        csv_row(&mut csv, "energy", row, drift);
    }
    let (_, link) = context.plot("event_loop.png");
    let _ = writeln!(md, "\n![pair collisions per second against packing]({link})\n");
    context.write(
        Section::EventLoop.markers(),
        "Simulate mode's event loop: the periodic gas",
        &md,
        "event_loop.csv",
        &csv,
    )
}

fn csv_row(csv: &mut String, table: &str, row: &Row, drift: Option<f64>) {
    let (one, all) = row.rates();
    let _ = writeln!(
        csv,
        "{table},{},{},{},{},{},{},{},{},{}",
        row.bodies,
        row.packing,
        row.travel,
        row.warm_up,
        row.measured,
        row.pairs().map_or(String::new(), |p| p.to_string()),
        csv_number(one),
        csv_number(all),
        csv_number(drift)
    );
}

fn plot(context: &Context, tables: &Tables) -> CliResult<()> {
    let (path, _) = context.plot("event_loop.png");
    let series = context
        .plan
        .loop_bodies
        .iter()
        .map(|&n| {
            let points = tables.rates.iter().filter(|r| r.bodies == n).filter_map(|r| Some((r.packing, r.rates().0?)));
            Series::new(&format!("n = {n}"), points.collect())
        })
        .collect();
    let panels = [Panel {
        title: format!("periodic gas, frames of {RMS_SPEED} rms diameters, one core"),
        x_label: "packing fraction".into(),
        y_label: "pair collisions per second".into(),
        series,
    }];
    plots::line_panels(&path, Some("Simulate mode's event loop: pair collisions per second"), &panels)
}
