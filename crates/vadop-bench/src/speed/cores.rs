//! All cores against one: the default method on one thread pinned to one core, and on every
//! core of the machine (unpinned, `--threads` = the core count), one right after the other, so
//! the machine's drift within a command does not enter the speed-up (the one-thread runs are
//! measured again, not read from the detect section). Detect mode on the paper scene for every n
//! and speed of the detect section, with the goals of 33 ms per frame at 0.05 and 66 ms at 0.5 diameters
//! per frame for n = 10^6; the equilibrium gas of the throughput section in simulate mode, up to
//! n = 10^6 (aim: 1.5 M pair collisions/s on every core); the mixed shapes of `--kind shapes`
//! (walls bouncing them) in detect mode at n = 10^4 and 10^5; and one run at n = 10^7 on every
//! core, with its peak memory per body.

use super::throughput::{collision_rates, gas, RMS_SPEED};
use super::{cell, mean_ms, ms_cell, ratio, Context, Section, Timed};
use crate::common::{csv_number, window_frames};
use crate::plots::{self, Series};
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::CliResult;
use std::fmt::Write as _;
use std::rc::Rc;

/// Goals at n = 10^6 on every core: (speed, ms per frame).
const GOALS: [(f64, f64); 2] = [(0.05, 33.0), (0.5, 66.0)];
/// Goal of the all-cores speed-up at n >= 10^5.
const SPEEDUP_GOAL: f64 = 1.8;
/// Packing of the gas rows.
const GAS_PACKING: f64 = 0.05;
/// Aim for the gas at n = 10^6 on every core, in pair collisions per second.
const GAS_AIM: f64 = 1.5e6;
/// Speed of the shapes rows, in diameters per frame (a shape's diameter is its bounding sphere's).
const SHAPES_SPEED: f64 = 0.5;

/// What a row runs.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// The paper scene in detect mode: ms/frame.
    Detect,
    /// The gas in simulate mode, measured after `warm_up` frames: pair collisions per second.
    Gas { warm_up: u64 },
    /// Mixed shapes in detect mode: ms/frame, no goal of its own.
    Shapes,
}

/// One scene on one thread and on every core.
struct Row {
    scene: String,
    kind: Kind,
    bodies: usize,
    one: Rc<Timed>,
    all: Rc<Timed>,
}

impl Row {
    /// ms/frame (detect, shapes) or pair collisions per second (gas), on one thread and on all.
    fn values(&self) -> (Option<f64>, Option<f64>) {
        match self.kind {
            Kind::Detect | Kind::Shapes => (mean_ms(&self.one), mean_ms(&self.all)),
            Kind::Gas { warm_up } => {
                let rate = |t: &Timed| collision_rates(t, warm_up).map(|r| r.1);
                (rate(&self.one), rate(&self.all))
            }
        }
    }

    /// How many times faster every core is than one.
    fn speedup(&self) -> Option<f64> {
        let (one, all) = self.values();
        match self.kind {
            Kind::Detect | Kind::Shapes => ratio(one, all),
            Kind::Gas { .. } => ratio(all, one),
        }
    }
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let plan = &context.plan;
    let product = context.runner.product()?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let detect_rows = plan.detect_bodies.len() * plan.speeds.len();
    let progress = Progress::new(
        2 * (detect_rows + plan.cores_gas_bodies.len() + plan.cores_shapes_bodies.len()) + plan.huge_bodies.len(),
    );
    let mut rows = Vec::new();
    for &bodies in &plan.detect_bodies {
        for &speed in &plan.speeds {
            let one = Simulation::paper(bodies, speed, window_frames(speed, plan.quick), "auto");
            let all = Simulation { threads: Some(cores), ..one.clone() };
            rows.push(Row {
                scene: format!("detect, speed {speed}"),
                kind: Kind::Detect,
                bodies,
                one: context.measure(product, &one, &progress),
                all: context.measure(product, &all, &progress),
            });
            write(context, cores, &rows, &[])?;
        }
    }
    for &bodies in &plan.cores_gas_bodies {
        let (one, warm_up, _) = gas(plan, bodies, GAS_PACKING, RMS_SPEED, 1);
        let (all, _, _) = gas(plan, bodies, GAS_PACKING, RMS_SPEED, cores);
        rows.push(Row {
            scene: format!("gas, packing {GAS_PACKING} (pair collisions/s)"),
            kind: Kind::Gas { warm_up },
            bodies,
            one: context.measure(product, &one, &progress),
            all: context.measure(product, &all, &progress),
        });
        write(context, cores, &rows, &[])?;
    }
    for &bodies in &plan.cores_shapes_bodies {
        let frames = window_frames(SHAPES_SPEED, plan.quick);
        let one = Simulation { kind: "shapes", ..Simulation::paper(bodies, SHAPES_SPEED, frames, "auto") };
        let all = Simulation { threads: Some(cores), ..one.clone() };
        rows.push(Row {
            scene: format!("shapes, detect, speed {SHAPES_SPEED}"),
            kind: Kind::Shapes,
            bodies,
            one: context.measure(product, &one, &progress),
            all: context.measure(product, &all, &progress),
        });
        write(context, cores, &rows, &[])?;
    }
    let mut huge = Vec::new();
    for &bodies in &plan.huge_bodies {
        let speed = plan.speeds[0];
        let run = Simulation {
            threads: Some(cores),
            ..Simulation::paper(bodies, speed, window_frames(speed, plan.quick), "auto")
        };
        huge.push((bodies, speed, context.time(product, &run, &progress)));
        write(context, cores, &rows, &huge)?;
    }
    progress.finish();
    let (path, _) = context.plot("cores.png");
    let series = plan
        .speeds
        .iter()
        .map(|&speed| {
            let scene = format!("detect, speed {speed}");
            let points = rows
                .iter()
                .filter(|r| r.scene == scene)
                .filter_map(|r| Some((r.bodies as f64, r.speedup()?)))
                .collect();
            Series::new(&format!("detect mode, speed {speed}"), points)
        })
        .chain([Kind::Gas { warm_up: 0 }, Kind::Shapes].map(|kind| {
            let name = if kind == Kind::Shapes { "detect mode, mixed shapes" } else { "simulate mode, gas" };
            let same = |r: &&Row| std::mem::discriminant(&r.kind) == std::mem::discriminant(&kind);
            Series::markers(
                name,
                rows.iter().filter(same).filter_map(|r| Some((r.bodies as f64, r.speedup()?))).collect(),
            )
        }))
        .collect();
    plots::line_chart(
        &path,
        &format!("Default method: speed-up of {cores} threads over one"),
        "bodies n",
        "one thread's time / all threads' time",
        series,
    )
}

fn write(context: &Context, cores: usize, rows: &[Row], huge: &[(usize, f64, Rc<Timed>)]) -> CliResult<()> {
    let mut md = format!(
        "The default method on one thread (pinned to one core, as in the other sections) and on all {cores} cores \
         of the machine (`--threads {cores}`, not pinned), each right after the other in this command (the \
         one-thread runs are measured again, not read from the detect section, so the machine's drift between \
         sections stays out of the speed-up). Detect rows: the paper scene, mean \
         wall-clock ms/frame over frames covering several broad-phase windows; gas rows: the equilibrium gas of the \
         throughput section (rms speed {RMS_SPEED} diameters per frame), pair collisions per second of the measured \
         frames; shapes rows: `vadop simulate --kind shapes` (spheres, boxes, capsules, cylinders, cones and hulls, \
         spinning, bouncing off the walls) in detect mode at {SHAPES_SPEED} diameters per frame, mean wall-clock \
         ms/frame. Median of {} runs. Goals: a speed-up of at least {SPEEDUP_GOAL} at n >= 10^5; at n = 10^6 on every \
         core, at most {} ms/frame at speed {} and {} ms/frame at speed {}; for the gas at n = 10^6 on every \
         core, an aim of {} M pair collisions/s.\n\n",
        context.repeats,
        GOALS[0].1,
        GOALS[0].0,
        GOALS[1].1,
        GOALS[1].0,
        GAS_AIM / 1e6,
    );
    let _ = writeln!(md, "| scene | n | one thread | {cores} threads | speed-up | goal |");
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---|");
    let mut csv = String::from("scene,n,threads,value,unit,speedup,status\n");
    for r in rows {
        let (one, all) = r.values();
        let decimals = if matches!(r.kind, Kind::Gas { .. }) { 0 } else { 3 };
        let shown = |timed: &Timed, value: Option<f64>| match timed {
            Ok(_) => cell(value, decimals),
            Err(e) => crate::markdown::table_cell(e),
        };
        let goal = goal(r, all);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {goal} |",
            r.scene,
            r.bodies,
            shown(&r.one, one),
            shown(&r.all, all),
            cell(r.speedup(), 2)
        );
        let unit = if matches!(r.kind, Kind::Gas { .. }) { "pair_collisions_per_s" } else { "ms_per_frame" };
        for (threads, timed, value) in [(1, &r.one, one), (cores, &r.all, all)] {
            let status = timed.as_ref().as_ref().err().map_or("ok".to_string(), |e| e.replace(',', ";"));
            let _ = writeln!(
                csv,
                "{},{},{threads},{},{unit},{},{status}",
                r.scene.replace(',', ";"),
                r.bodies,
                csv_number(value),
                csv_number(r.speedup())
            );
        }
    }
    if !huge.is_empty() {
        let _ = writeln!(md, "\nThe largest scenes, on all {cores} cores (detect mode, paper scene):\n");
        let _ = writeln!(md, "| n | speed | ms/frame | peak MiB | bytes per body | goal |");
        let _ = writeln!(md, "|---:|---:|---:|---:|---:|---|");
        for (bodies, speed, timed) in huge {
            let peak = timed.as_ref().as_ref().ok().and_then(|reports| reports.first()?.summary.peak_memory_mib);
            let per_body = peak.map(|mib| mib * 1024.0 * 1024.0 / *bodies as f64);
            let met = per_body.map_or("—", |b| if b <= 300.0 { "met (≤ 300 B/body)" } else { "missed (> 300 B/body)" });
            let _ = writeln!(
                md,
                "| {bodies} | {speed} | {} | {} | {} | {met} |",
                ms_cell(timed),
                cell(peak, 0),
                cell(per_body, 0)
            );
            let status = timed.as_ref().as_ref().err().map_or("ok".to_string(), |e| e.replace(',', ";"));
            let _ = writeln!(
                csv,
                "detect; speed {speed},{bodies},{cores},{},ms_per_frame,,{status}",
                csv_number(mean_ms(timed))
            );
        }
    }
    let (_, link) = context.plot("cores.png");
    let _ = writeln!(md, "\n![speed-up of all cores against n]({link})\n");
    context.write(Section::Cores.markers(), "All cores against one", &md, "cores.csv", &csv)
}

/// Whether the row meets its goal: the n = 10^6 ms/frame goals, else the speed-up goal from
/// n = 10^5 on (and for the gas at n = 10^6 the aim of 1.5 M collisions/s); empty where there is
/// none (the shapes rows).
fn goal(row: &Row, all: Option<f64>) -> String {
    if row.kind == Kind::Shapes {
        return String::new();
    }
    let speed_goal =
        GOALS.iter().find(|(speed, _)| row.kind == Kind::Detect && row.scene == format!("detect, speed {speed}"));
    if let (1_000_000, Some(&(_, ms))) = (row.bodies, speed_goal) {
        return match all {
            Some(v) if v <= ms => format!("met (≤ {ms} ms)"),
            Some(_) => format!("missed (> {ms} ms)"),
            None => "—".into(),
        };
    }
    let speedup = match row.speedup() {
        Some(s) if row.bodies >= 100_000 && s >= SPEEDUP_GOAL => format!("met (≥ {SPEEDUP_GOAL}x)"),
        Some(_) if row.bodies >= 100_000 => format!("missed (< {SPEEDUP_GOAL}x)"),
        _ => String::new(),
    };
    let aim = GAS_AIM / 1e6;
    match (row.kind, row.bodies, all) {
        (Kind::Gas { .. }, 1_000_000, Some(rate)) if rate >= GAS_AIM => format!("{speedup}; {aim} M/s met"),
        (Kind::Gas { .. }, 1_000_000, Some(_)) => format!("{speedup}; {aim} M/s missed"),
        _ => speedup,
    }
}
