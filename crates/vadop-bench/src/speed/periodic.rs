//! The periodic gas's pressure: an elastic equilibrium gas (`--kind gas`) in a box periodic on
//! every axis, at packings 0.1, 0.3 and 0.45, its compressibility factor Z = PV/NkT from the
//! collisional virial against Hansen-Goos's equation of state (J. Chem. Phys. 144, 164506 (2016),
//! within about 0.01 % of simulations over the whole fluid range), with Carnahan-Starling beside
//! it. Each packing is one long run, pinned to one core: the first frames let the lattice start
//! melt, the rest are cut into blocks whose Z's give the mean and its standard error. It also
//! says how fast the gas runs (pair collisions per second), the one figure here that is a time.

use super::{cell, Context, Section};
use crate::common::csv_number;
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::summary::Report;
use crate::CliResult;
use std::fmt::Write as _;

const PACKINGS: [f64; 3] = [0.1, 0.3, 0.45];
/// The gas's rms speed in diameters per frame (the frame 1/30 s).
const RMS_SPEED: f64 = 0.2;
/// Collisions per sphere before the measurement starts: a lattice start has melted by then.
const EQUILIBRATION_PER_SPHERE: f64 = 40.0;
/// Blocks the measured frames are cut into for the standard error: long enough to be nearly
/// independent (each holds thousands of collision times of the whole gas).
const BLOCKS: usize = 20;
/// Z must lie within this of Hansen-Goos (issue 26).
const GOAL: f64 = 5e-4;

/// Hansen-Goos's equation of state: Z = 8 ln(1 - eta) / eta + P(eta) / (1 - eta)^3, P the
/// polynomial of his Table I.
pub(crate) fn hansen_goos(eta: f64) -> f64 {
    // Highest power first.
    const P: [f64; 8] = [-0.096495, 0.248245, 0.041212, -1.265575, -2.635232, 47.0 / 3.0, -19.0, 9.0];
    let polynomial = P.iter().fold(0.0, |sum, c| sum * eta + c);
    8.0 * (1.0 - eta).ln() / eta + polynomial / (1.0 - eta).powi(3)
}

/// Carnahan-Starling's: Z = (1 + eta + eta^2 - eta^3) / (1 - eta)^3.
pub(crate) fn carnahan_starling(eta: f64) -> f64 {
    (1.0 + eta + eta * eta - eta.powi(3)) / (1.0 - eta).powi(3)
}

/// Enskog's collisions per sphere per frame, 24 eta g(sigma) sqrt(kT / pi m), with the contact
/// value g(sigma) = (Z - 1) / 4 eta from Hansen-Goos: what sizes the runs.
pub(super) fn collisions_per_sphere_per_frame(eta: f64) -> f64 {
    let kt = RMS_SPEED * RMS_SPEED / 3.0;
    6.0 * (hansen_goos(eta) - 1.0) * (kt / std::f64::consts::PI).sqrt()
}

/// One packing's run and what it measured.
struct Row {
    packing: f64,
    equilibration_frames: u64,
    outcome: Result<Measured, String>,
}

struct Measured {
    frames: u64,
    collisions: u64,
    z: f64,
    standard_error: f64,
    per_second: f64,
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let product = context.runner.product()?;
    let bodies = context.plan.periodic_bodies;
    let progress = Progress::new(PACKINGS.len());
    let mut rows = Vec::new();
    for packing in PACKINGS {
        let rate = collisions_per_sphere_per_frame(packing);
        let equilibration = (EQUILIBRATION_PER_SPHERE / rate).ceil() as u64;
        // Pair collisions to measure: each adds one virial term to Z's sum.
        let measured = ((2.0 * context.plan.periodic_collisions / bodies as f64) / rate).ceil() as u64;
        let frames = equilibration + measured.max(BLOCKS as u64);
        let run = Simulation {
            kind: "gas",
            packing,
            speed: RMS_SPEED,
            mode: "simulate",
            periodic: Some("xyz"),
            ..Simulation::paper(bodies, RMS_SPEED, frames, "auto")
        };
        progress.start(&format!("periodic gas n={bodies} packing={packing}: {frames} frames"));
        let outcome = context.runner.simulate(product, &run).and_then(|report| measure(&report, equilibration));
        progress.done(&match &outcome {
            Ok(m) => format!("Z {:.5} ± {:.5}, Hansen-Goos {:.5}", m.z, m.standard_error, hansen_goos(packing)),
            Err(e) => e.clone(),
        });
        rows.push(Row { packing, equilibration_frames: equilibration, outcome });
        write(context, bodies, &rows)?;
    }
    progress.finish();
    Ok(())
}

/// Z and its standard error from the frames after `equilibration`: Z = 1 + W / (2 K T) per block,
/// W the block's virial, K the translational kinetic energy (kept to rounding) and T its time.
fn measure(report: &Report, equilibration: u64) -> Result<Measured, String> {
    let summary = &report.summary;
    let kinetic = summary.conservation.as_ref().map(|c| c.translational_end).ok_or("no energy in the report")?;
    let dt = summary.run.dt;
    let measured: Vec<_> = report.frames.iter().skip(equilibration as usize).collect();
    if measured.len() < BLOCKS {
        return Err(format!("only {} frames after the equilibration", measured.len()));
    }
    let per_block = measured.len() / BLOCKS;
    let blocks: Vec<f64> = measured
        .chunks_exact(per_block)
        .take(BLOCKS)
        .map(|block| 1.0 + block.iter().map(|f| f.pair_virial).sum::<f64>() / (2.0 * kinetic * dt * block.len() as f64))
        .collect();
    let mean = blocks.iter().sum::<f64>() / BLOCKS as f64;
    let variance = blocks.iter().map(|z| (z - mean).powi(2)).sum::<f64>() / (BLOCKS - 1) as f64;
    let used = &measured[..per_block * BLOCKS];
    let collisions: u64 = used.iter().map(|f| f.pair_contacts).sum();
    let seconds: f64 = used.iter().map(|f| f.wall_ms).sum::<f64>() / 1e3;
    Ok(Measured {
        frames: used.len() as u64,
        collisions,
        z: mean,
        standard_error: (variance / BLOCKS as f64).sqrt(),
        per_second: collisions as f64 / seconds,
    })
}

fn write(context: &Context, bodies: usize, rows: &[Row]) -> CliResult<()> {
    let mut md = format!(
        "`vadop simulate --kind gas --periodic xyz --bodies {bodies} --max-speed {RMS_SPEED}` (elastic, default method, \
         one pinned core, one run per packing): {EQUILIBRATION_PER_SPHERE} collisions per sphere to melt the lattice \
         start, then the measured frames cut into {BLOCKS} blocks; Z = 1 + W / (2 K T) per block from the collisional \
         virial W, its mean and standard error. Goal: within {:.2} % of Hansen-Goos.\n\n",
        GOAL * 100.0
    );
    let _ = writeln!(
        md,
        "| packing | frames (melt + measured) | pair collisions measured | Z ± standard error | Hansen-Goos | Z ÷ HG − 1 | within {:.2} % | Carnahan-Starling | collisions / s |",
        GOAL * 100.0
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---|---:|---:|");
    let mut csv = String::from("n,packing,equilibration_frames,frames,collisions,z,standard_error,hansen_goos,carnahan_starling,collisions_per_second\n");
    for row in rows {
        let (hg, cs) = (hansen_goos(row.packing), carnahan_starling(row.packing));
        match &row.outcome {
            Ok(m) => {
                let off = m.z / hg - 1.0;
                let verdict = if off.abs() <= GOAL { "yes" } else { "**no**" };
                let _ = writeln!(
                    md,
                    "| {} | {} + {} | {} | {:.5} ± {:.5} | {hg:.5} | {:+.4} % | {verdict} | {cs:.5} | {} |",
                    row.packing,
                    row.equilibration_frames,
                    m.frames,
                    m.collisions,
                    m.z,
                    m.standard_error,
                    off * 100.0,
                    cell(Some(m.per_second), 0)
                );
                let _ = writeln!(
                    csv,
                    "{bodies},{},{},{},{},{},{},{},{},{}",
                    row.packing,
                    row.equilibration_frames,
                    m.frames,
                    m.collisions,
                    csv_number(Some(m.z)),
                    csv_number(Some(m.standard_error)),
                    csv_number(Some(hg)),
                    csv_number(Some(cs)),
                    csv_number(Some(m.per_second))
                );
            }
            Err(e) => {
                let _ = writeln!(
                    md,
                    "| {} | {} | — | {} | {hg:.5} | — | — | {cs:.5} | — |",
                    row.packing,
                    row.equilibration_frames,
                    crate::markdown::table_cell(e)
                );
            }
        }
    }
    context.write(Section::Periodic.markers(), "The periodic gas's pressure", &md, "periodic.csv", &csv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_equations_of_state_agree_where_they_should() {
        // Both tend to the second virial coefficient at low density: Z = 1 + 4 eta + ...
        assert!((hansen_goos(1e-4) - 1.0 - 4e-4).abs() < 1e-6, "{}", hansen_goos(1e-4));
        assert!((carnahan_starling(1e-4) - 1.0 - 4e-4).abs() < 1e-6);
        // Carnahan-Starling is within a fraction of a percent at fluid densities.
        for eta in [0.1, 0.3, 0.45] {
            let off = carnahan_starling(eta) / hansen_goos(eta) - 1.0;
            assert!(off.abs() < 0.01, "eta {eta}: {off}");
        }
    }
}
