//! The granular pile (issue 26): `vadop simulate --kind pile`, spheres placed as the paper scene
//! at packing 0.2 falling under gravity (9.81 diameters per second squared along -z) with
//! restitution 0.5 onto the floor, where they come to rest on it and on each other (the rest
//! rule), each run on one pinned core. It reports the mean ms per frame while the pile forms and
//! settles, and whether a frame's time is linear in its contacts: a least-squares line of the
//! frames' wall-clock ms on their contacts (its slope the cost of a contact, its intercept the
//! cost of a frame without any, and R^2), and the cost per contact in bands of frames from the
//! quietest to the busiest, which a linear cost keeps level.

use super::{cell, first, mean_ms, ms_cell, Context, Section, Timed};
use crate::common::csv_number;
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::summary::Frame;
use crate::CliResult;
use std::fmt::Write as _;
use std::rc::Rc;

/// The start: the paper scene's placement at this packing, a few diameters of fall per layer.
const PACKING: f64 = 0.2;
const SPEED: f64 = 0.5;
/// Bands the frames with contacts are cut into, by their contacts, for the cost per contact.
const BANDS: usize = 5;

struct Row {
    bodies: usize,
    frames: u64,
    timed: Rc<Timed>,
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let product = context.runner.product()?;
    let (bodies, frames) = (&context.plan.pile_bodies, context.plan.pile_frames);
    let progress = Progress::new(bodies.len());
    let mut rows = Vec::new();
    for &n in bodies {
        let run = Simulation {
            kind: "pile",
            packing: PACKING,
            mode: "simulate",
            ..Simulation::paper(n, SPEED, frames, "auto")
        };
        rows.push(Row { bodies: n, frames, timed: context.time(product, &run, &progress) });
        write(context, &rows)?;
    }
    progress.finish();
    Ok(())
}

/// The least-squares line `ms = intercept + slope * contacts` over `frames`, and its R^2.
fn fit(frames: &[Frame]) -> Option<(f64, f64, f64)> {
    let n = frames.len() as f64;
    if n < 3.0 {
        return None;
    }
    let (mx, my) =
        (frames.iter().map(|f| f.contacts as f64).sum::<f64>() / n, frames.iter().map(|f| f.wall_ms).sum::<f64>() / n);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for f in frames {
        let (dx, dy) = (f.contacts as f64 - mx, f.wall_ms - my);
        (sxx, sxy, syy) = (sxx + dx * dx, sxy + dx * dy, syy + dy * dy);
    }
    if !(sxx > 0.0 && syy > 0.0) {
        return None;
    }
    let slope = sxy / sxx;
    Some((my - slope * mx, slope, sxy * sxy / (sxx * syy)))
}

/// The frames with contacts cut into [`BANDS`] bands of equal count by their contacts, each band's
/// (fewest contacts, most contacts, ms per thousand contacts).
fn bands(frames: &[Frame]) -> Vec<(u64, u64, f64)> {
    let mut busy: Vec<&Frame> = frames.iter().filter(|f| f.contacts > 0).collect();
    busy.sort_by_key(|f| f.contacts);
    let per_band = busy.len() / BANDS;
    if per_band == 0 {
        return Vec::new();
    }
    busy.chunks(per_band)
        .take(BANDS)
        .map(|band| {
            let contacts: u64 = band.iter().map(|f| f.contacts).sum();
            let ms: f64 = band.iter().map(|f| f.wall_ms).sum();
            (band[0].contacts, band[band.len() - 1].contacts, 1e3 * ms / contacts as f64)
        })
        .collect()
}

fn write(context: &Context, rows: &[Row]) -> CliResult<()> {
    let mut md = format!(
        "`vadop simulate --kind pile --packing {PACKING} --max-speed {SPEED} --reference none --threads 1`: spheres \
         placed as the paper scene's falling under gravity 9.81 diameters/s² along -z with restitution 0.5 onto the \
         floor, where they come to rest (the rest rule), one pinned core, default method; mean wall-clock ms per frame \
         (median of {} runs) while the pile forms and settles. Time linear in contacts: the least-squares line of a \
         frame's ms on its contacts (slope per thousand contacts, intercept, R²) over the first run's frames, and ms \
         per thousand contacts in {BANDS} bands of the frames with contacts, from the quietest to the busiest.\n\n",
        context.repeats
    );
    let _ = writeln!(
        md,
        "| n | frames | ms/frame | p95 ms | contacts/frame | rest-rule contacts/frame | at rest at the end | ms per 1000 contacts (fit) | ms/frame without contacts (fit) | R² | ms per 1000 contacts, quietest to busiest band |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---|");
    let mut csv = String::from(
        "n,frames,ms_per_frame,p95_ms,contacts_per_frame,rest_contacts_per_frame,still,sliding,ms_per_1000_contacts,ms_without_contacts,r_squared\n",
    );
    for row in rows {
        let report = first(&row.timed);
        let summary = report.map(|r| &r.summary);
        let fitted = report.and_then(|r| fit(&r.frames));
        let per_frame = |count: Option<u64>| Some(count? as f64 / summary?.frames_completed.max(1) as f64);
        let contacts = per_frame(summary.map(|s| s.contacts.total));
        let rest = per_frame(summary.map(|s| s.rules.rest_contacts));
        let resting = summary.and_then(|s| s.resting.as_ref());
        let at_rest =
            resting.map_or("—".to_string(), |r| format!("{} of {} still, {} sliding", r.still, r.bodies, r.sliding));
        let banded = report.map(|r| bands(&r.frames)).unwrap_or_default();
        let banded = match banded.is_empty() {
            true => "—".to_string(),
            false => banded.iter().map(|(_, _, ms)| format!("{ms:.3}")).collect::<Vec<_>>().join(", "),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {at_rest} | {} | {} | {} | {banded} |",
            row.bodies,
            row.frames,
            ms_cell(&row.timed),
            cell(summary.map(|s| s.wall_ms.p95), 3),
            cell(contacts, 0),
            cell(rest, 0),
            cell(fitted.map(|f| 1e3 * f.1), 3),
            cell(fitted.map(|f| f.0), 3),
            cell(fitted.map(|f| f.2), 3)
        );
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{}",
            row.bodies,
            row.frames,
            csv_number(mean_ms(&row.timed)),
            csv_number(summary.map(|s| s.wall_ms.p95)),
            csv_number(contacts),
            csv_number(rest),
            csv_number(resting.map(|r| r.still as f64)),
            csv_number(resting.map(|r| r.sliding as f64)),
            csv_number(fitted.map(|f| 1e3 * f.1)),
            csv_number(fitted.map(|f| f.0)),
            csv_number(fitted.map(|f| f.2))
        );
    }
    context.write(Section::Pile.markers(), "The granular pile", &md, "pile.csv", &csv)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(contacts: u64, wall_ms: f64) -> Frame {
        Frame { pair_contacts: contacts, contacts, pair_virial: 0.0, wall_ms }
    }

    #[test]
    fn a_cost_linear_in_contacts_fits_exactly_and_keeps_its_bands_level() {
        let frames: Vec<Frame> = (0..50).map(|k| frame(100 * k, 0.5 + 0.002 * (100 * k) as f64)).collect();
        let (intercept, slope, r2) = fit(&frames).unwrap();
        assert!((intercept - 0.5).abs() < 1e-9 && (slope - 0.002).abs() < 1e-12 && (r2 - 1.0).abs() < 1e-12);
        // Per contact the fixed cost fades as frames get busier: the bands fall towards the slope.
        let banded = bands(&frames);
        assert_eq!(banded.len(), BANDS);
        assert!(banded.windows(2).all(|w| w[0].2 >= w[1].2) && banded[BANDS - 1].2 > 2.0);
        // Too few frames, or no spread: no line.
        assert!(fit(&frames[..2]).is_none());
        assert!(fit(&[frame(5, 1.0), frame(5, 2.0), frame(5, 3.0)]).is_none());
    }
}
