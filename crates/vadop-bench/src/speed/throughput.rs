//! Simulate-mode throughput: pair collisions per second of stepping an equilibrium gas (Maxwell
//! velocities, rms speed 0.2 diameters per frame) with the default method, after warm-up frames
//! that let the lattice the gas starts on melt. Then the same gas stepped with frames of 0.05 to
//! 5 rms diameters of travel (the speed unchanged, dt scaled): the pipeline works in windows
//! chosen from speeds, not frames, so the rate should not depend on the frame length.

use super::{cell, Context, Plan, Section, Timed};
use crate::common::{csv_number, median};
use crate::plots::{self, Panel, Series};
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::summary::Report;
use crate::CliResult;
use std::fmt::Write as _;
use std::rc::Rc;
use vadop::scene::FRAMES_PER_SECOND;

/// The gas's rms speed in diameters per frame at 30 frames per second.
pub(super) const RMS_SPEED: f64 = 0.2;
/// Packing fraction of the frame-length sweep.
const SWEEP_PACKING: f64 = 0.2;

/// One run: its scene and frames, and its outcome.
struct Row {
    bodies: usize,
    packing: f64,
    /// rms diameters of travel per frame.
    travel: f64,
    warm_up: u64,
    measured: u64,
    timed: Rc<Timed>,
}

impl Row {
    fn rates(&self) -> Option<(f64, f64)> {
        collision_rates(&self.timed, self.warm_up)
    }
}

/// Median over repeats of (pair collisions per frame, per second of stepping), over the frames
/// after the first `warm_up`.
pub(super) fn collision_rates(timed: &Timed, warm_up: u64) -> Option<(f64, f64)> {
    let reports = timed.as_ref().ok()?;
    let rate = |r: &Report| {
        let measured = r.frames.get(warm_up as usize..)?;
        let pairs: u64 = measured.iter().map(|f| f.pair_contacts).sum();
        let seconds: f64 = measured.iter().map(|f| f.wall_ms).sum::<f64>() / 1e3;
        (seconds > 0.0).then(|| (pairs as f64 / measured.len() as f64, pairs as f64 / seconds))
    };
    let rates: Vec<(f64, f64)> = reports.iter().filter_map(rate).collect();
    Some((
        median(&rates.iter().map(|r| r.0).collect::<Vec<_>>())?,
        median(&rates.iter().map(|r| r.1).collect::<Vec<_>>())?,
    ))
}

/// The gas of `bodies` at `packing` with frames of `travel` rms diameters, stepped on `threads`
/// threads: the run, and its warm-up and measured frames (whole frames covering the plan's
/// travels).
pub(super) fn gas(plan: &Plan, bodies: usize, packing: f64, travel: f64, threads: usize) -> (Simulation, u64, u64) {
    let frames = |distance: f64| (distance / travel).ceil() as u64;
    let (warm_up, measured) = (frames(plan.warm_up_travel), frames(plan.measured_travel));
    let run = Simulation {
        kind: "gas",
        bodies,
        packing,
        speed: RMS_SPEED,
        frames: warm_up + measured,
        mode: "simulate",
        dt: Some(travel / (RMS_SPEED * FRAMES_PER_SECOND)),
        threads: Some(threads),
        ..Simulation::paper(bodies, RMS_SPEED, 1, "auto")
    };
    (run, warm_up, measured)
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let plan = &context.plan;
    let product = context.runner.product()?;
    let progress = Progress::new(plan.throughput_bodies.len() * plan.packings.len() + plan.travels.len());
    let gas = |bodies: usize, packing: f64, travel: f64| {
        let (run, warm_up, measured) = gas(plan, bodies, packing, travel, 1);
        Row { bodies, packing, travel, warm_up, measured, timed: context.time(product, &run, &progress) }
    };
    let mut packings = Vec::new();
    for &n in &plan.throughput_bodies {
        for &packing in &plan.packings {
            packings.push(gas(n, packing, RMS_SPEED));
            write(context, &packings, &[])?;
        }
    }
    let sweep_bodies = plan.throughput_bodies[0];
    let mut sweep = Vec::new();
    for &travel in &plan.travels {
        sweep.push(gas(sweep_bodies, SWEEP_PACKING, travel));
        write(context, &packings, &sweep)?;
    }
    progress.finish();
    let (path, _) = context.plot("throughput.png");
    let rate = |r: &Row, x: f64| Some((x, r.rates()?.1));
    let by_packing = plan
        .throughput_bodies
        .iter()
        .map(|&n| {
            Series::new(
                &format!("n = {n}"),
                packings.iter().filter(|r| r.bodies == n).filter_map(|r| rate(r, r.packing)).collect(),
            )
        })
        .collect();
    let by_frame = vec![Series::new(
        &format!("n = {sweep_bodies}, packing {SWEEP_PACKING}"),
        sweep.iter().filter_map(|r| rate(r, r.travel)).collect(),
    )];
    let y_label = "pair collisions per second of stepping".to_string();
    let panels = [
        Panel {
            title: format!("frames of {RMS_SPEED} rms diameters"),
            x_label: "packing fraction".into(),
            y_label: y_label.clone(),
            series: by_packing,
        },
        Panel {
            title: "frame length sweep".into(),
            x_label: "frame length (rms diameters of travel)".into(),
            y_label,
            series: by_frame,
        },
    ];
    plots::line_panels(&path, Some("Equilibrium gas, default method: pair collisions per second"), &panels)
}

fn write(context: &Context, packings: &[Row], sweep: &[Row]) -> CliResult<()> {
    let plan = &context.plan;
    let mut md = format!(
        "Equilibrium gas (`vadop simulate --kind gas`: Maxwell velocities of rms speed {RMS_SPEED} diameters per frame \
         at 30 frames per second, seed 1), simulate mode, default method. Each run steps {} rms diameters of travel \
         to warm up (the gas starts on a lattice), then {} measured: collisions per second = pair collisions over \
         the wall-clock time of the measured steps; median of {} runs.\n\n",
        plan.warm_up_travel, plan.measured_travel, context.repeats
    );
    let _ = writeln!(md, "| n | packing | frame (rms diameters) | dt (s) | frames (warm-up + measured) | pair collisions/frame | pair collisions/s |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|");
    let mut csv = String::from(
        "table,n,packing,travel_per_frame,dt,warm_up_frames,measured_frames,pairs_per_frame,pairs_per_second,status\n",
    );
    let mut table = |rows: &[Row], name: &str, md: &mut String| {
        for r in rows {
            let rates = r.rates();
            let dt = r.travel / (RMS_SPEED * FRAMES_PER_SECOND);
            let status = r.timed.as_ref().as_ref().err().map_or("ok".to_string(), |e| e.replace(',', ";"));
            let rate = match r.timed.as_ref() {
                Ok(_) => cell(rates.map(|x| x.1), 0),
                Err(e) => crate::markdown::table_cell(e),
            };
            let _ = writeln!(
                md,
                "| {} | {} | {} | {dt:.5} | {} + {} | {} | {rate} |",
                r.bodies,
                r.packing,
                r.travel,
                r.warm_up,
                r.measured,
                cell(rates.map(|x| x.0), 1)
            );
            let _ = writeln!(
                csv,
                "{name},{},{},{},{dt},{},{},{},{},{status}",
                r.bodies,
                r.packing,
                r.travel,
                r.warm_up,
                r.measured,
                csv_number(rates.map(|x| x.0)),
                csv_number(rates.map(|x| x.1))
            );
        }
    };
    table(packings, "packing", &mut md);
    let _ = writeln!(md, "\nFrame-length sweep: the same gas at packing {SWEEP_PACKING}, frames of different length; the rate should not depend on it.\n");
    let _ = writeln!(md, "| n | packing | frame (rms diameters) | dt (s) | frames (warm-up + measured) | pair collisions/frame | pair collisions/s |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|");
    table(sweep, "frame-length", &mut md);
    let (_, link) = context.plot("throughput.png");
    let _ = writeln!(md, "\n![pair collisions per second against packing]({link})\n");
    context.write(
        Section::Throughput.markers(),
        "Simulate-mode throughput: an equilibrium gas",
        &md,
        "throughput.csv",
        &csv,
    )
}
