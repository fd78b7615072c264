//! What gravity costs: the paper scene (packing 0.05, speeds up to 0.5 diameters per frame) with
//! and without a gravity of 9.81 diameters per second squared along -z, in detect and in simulate
//! mode (elastic), each pair of runs in this command on one pinned core. Under gravity every
//! proxy is the tangent of its parabola widened by the bend and renewed before the bend exceeds a
//! quarter radius, and walls see a quadratic: the ratio says what that costs.

use super::{cell, first, mean_ms, ms_cell, ratio, Context, Section, Timed};
use crate::common::csv_number;
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::CliResult;
use std::fmt::Write as _;
use std::rc::Rc;

const SPEED: f64 = 0.5;
/// Diameters per second squared, along -z: unit spheres of one metre under the Earth's pull.
const GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];
const FRAMES: u64 = 90;
const MODES: [&str; 2] = ["detect", "simulate"];

struct Row {
    bodies: usize,
    mode: &'static str,
    free: Rc<Timed>,
    falling: Rc<Timed>,
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let product = context.runner.product()?;
    let progress = Progress::new(context.plan.gravity_bodies.len() * MODES.len() * 2);
    let mut rows = Vec::new();
    for &bodies in &context.plan.gravity_bodies {
        for mode in MODES {
            let free = Simulation { mode, ..Simulation::paper(bodies, SPEED, FRAMES, "auto") };
            let falling = Simulation { gravity: Some(GRAVITY), ..free.clone() };
            let (free, falling) = (context.time(product, &free, &progress), context.time(product, &falling, &progress));
            rows.push(Row { bodies, mode, free, falling });
            write(context, &rows)?;
        }
    }
    progress.finish();
    Ok(())
}

fn contacts(timed: &Timed) -> Option<f64> {
    first(timed).map(|r| r.summary.contacts.pairs as f64)
}

fn write(context: &Context, rows: &[Row]) -> CliResult<()> {
    let mut md = format!(
        "Paper scene (packing 0.05, seed 1), speeds up to {SPEED} diameters per frame, default method, {FRAMES} \
         frames, without and with `--gravity 0,0,-9.81` (diameters per second squared), one pinned core; mean \
         wall-clock ms per frame, median of {} runs.\n\n",
        context.repeats
    );
    let _ = writeln!(
        md,
        "| n | mode | no gravity ms/frame | gravity ms/frame | gravity ÷ none | pair contacts none / gravity | per pair contact, gravity ÷ none |"
    );
    let _ = writeln!(md, "|---:|---|---:|---:|---:|---:|---:|");
    let mut csv = String::from(
        "n,mode,frames,free_ms,gravity_ms,ratio,free_pair_contacts,gravity_pair_contacts,per_contact_ratio\n",
    );
    for row in rows {
        let (free, falling) = (mean_ms(&row.free), mean_ms(&row.falling));
        let (c_free, c_falling) = (contacts(&row.free), contacts(&row.falling));
        // Bodies falling to the floor crowd there and touch more often: the cost per contact
        // tells the price of the parabolas apart from that of the denser scene.
        let per_contact = ratio(ratio(falling, c_falling), ratio(free, c_free));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} / {} | {} |",
            row.bodies,
            row.mode,
            ms_cell(&row.free),
            ms_cell(&row.falling),
            cell(ratio(falling, free), 2),
            cell(c_free, 0),
            cell(c_falling, 0),
            cell(per_contact, 2)
        );
        let _ = writeln!(
            csv,
            "{},{},{FRAMES},{},{},{},{},{},{}",
            row.bodies,
            row.mode,
            csv_number(free),
            csv_number(falling),
            csv_number(ratio(falling, free)),
            csv_number(c_free),
            csv_number(c_falling),
            csv_number(per_contact)
        );
    }
    context.write(Section::Gravity.markers(), "What gravity costs", &md, "gravity.csv", &csv)
}
