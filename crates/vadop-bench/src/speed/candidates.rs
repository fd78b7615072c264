//! The yardstick of the candidates section, computed independently of vadop's broad phases: the
//! number of body pairs whose swept boxes over a frame overlap. A body's box covers its whole
//! path in the frame, a polyline through its start, its wall bounces and its end, grown by its
//! radius; the pairs come from a plain sort and sweep on x. This is what a swept-box broad phase
//! would hand its narrow phase, so a broad phase testing at most about twice as many pairs is
//! doing its job. Runs as a `--child` job (in detect mode every method follows the same paths, so
//! the default method steps them).

use super::{cell, first, Context, Section};
use crate::common::{csv_number, window_frames};
use crate::plots::{self, Series};
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::CliResult;
use glam::DVec3;
use std::fmt::Write as _;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{Method, Mode, Touched, WorldConfig};

/// Body counts of this section: those of the detect section up to 10^5.
const MAX_BODIES: usize = 100_000;

/// One (n, speed) cell: the swept-box overlaps and the methods' narrow tests, per frame.
struct Cell {
    bodies: usize,
    speed: f64,
    frames: u64,
    overlaps: Result<f64, String>,
    /// auto and vadop.
    tests: [Option<f64>; 2],
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let plan = &context.plan;
    let product = context.runner.product()?;
    let bodies: Vec<usize> = plan.detect_bodies.iter().copied().filter(|&n| n <= MAX_BODIES).collect();
    let progress = Progress::new(bodies.len() * plan.speeds.len() * 3);
    let mut cells = Vec::new();
    for &n in &bodies {
        for &speed in &plan.speeds {
            let frames = window_frames(speed, plan.quick);
            // The runs of the detect section, made once; narrow tests do not vary between repeats.
            let tests = ["auto", "vadop"].map(|method| {
                first(&context.time(product, &Simulation::paper(n, speed, frames, method), &progress))
                    .map(|r| r.summary.per_frame.narrow_tests)
            });
            let args = [("--bodies", n.to_string()), ("--speed", speed.to_string()), ("--frames", frames.to_string())];
            let overlaps = context.child("candidates", &args, 1, &progress).and_then(|values| {
                values
                    .first()
                    .and_then(|v| v["pairs_per_frame"].as_f64())
                    .ok_or_else(|| "no pairs_per_frame".to_string())
            });
            cells.push(Cell { bodies: n, speed, frames, overlaps, tests });
            write(context, &cells)?;
        }
    }
    progress.finish();
    let (path, _) = context.plot("candidates.png");
    let series: Vec<Series> = ["auto", "vadop"]
        .iter()
        .enumerate()
        .flat_map(|(k, method)| {
            let cells = &cells;
            bodies.iter().map(move |&n| {
                let points = cells
                    .iter()
                    .filter(|c| c.bodies == n)
                    .filter_map(|c| Some((c.speed, c.tests[k]? / *c.overlaps.as_ref().ok()?)))
                    .collect();
                Series::new(&format!("{method}, n = {n}"), points)
            })
        })
        .collect();
    plots::line_chart(
        &path,
        "Narrow tests per swept-box overlap (goal: at most 2)",
        "max speed (diameters/frame)",
        "narrow tests ÷ overlapping swept boxes",
        series,
    )
}

fn write(context: &Context, cells: &[Cell]) -> CliResult<()> {
    let mut md = String::from(
        "Paper scene (packing 0.05, seed 1) in detect mode, the runs of the detect section. Overlaps: body pairs \
         whose swept boxes over the frame overlap (each box around the body's whole path in the frame, wall \
         bounces included, grown by its radius), counted by a child with a plain sort and sweep, independent of \
         vadop's broad phases. Narrow tests: the method's pair tests per frame, re-tests after wall bounces \
         included. The goal is a ratio of at most 2.\n\n",
    );
    let _ = writeln!(md, "| n | speed | frames | overlapping swept boxes/frame | auto narrow tests/frame | auto ÷ overlaps | vadop narrow tests/frame | vadop ÷ overlaps |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut csv = String::from(
        "n,speed,frames,overlaps_per_frame,auto_tests_per_frame,auto_ratio,vadop_tests_per_frame,vadop_ratio,status\n",
    );
    for c in cells {
        let overlaps = c.overlaps.as_ref().ok().copied();
        let ratios = c.tests.map(|t| Some(t? / overlaps?));
        let overlaps_cell = match &c.overlaps {
            Ok(v) => format!("{v:.0}"),
            Err(e) => crate::markdown::table_cell(e),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {overlaps_cell} | {} | {} | {} | {} |",
            c.bodies,
            c.speed,
            c.frames,
            cell(c.tests[0], 0),
            cell(ratios[0], 2),
            cell(c.tests[1], 0),
            cell(ratios[1], 2)
        );
        let status = c.overlaps.as_ref().err().map_or("ok".to_string(), |e| e.replace(',', ";"));
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{status}",
            c.bodies,
            c.speed,
            c.frames,
            csv_number(overlaps),
            csv_number(c.tests[0]),
            csv_number(ratios[0]),
            csv_number(c.tests[1]),
            csv_number(ratios[1])
        );
    }
    let (_, link) = context.plot("candidates.png");
    let _ = writeln!(md, "\n![narrow tests per overlapping swept-box pair]({link})\n");
    context.write(
        Section::Candidates.markers(),
        "Candidates: narrow tests against overlapping swept boxes",
        &md,
        "candidates.csv",
        &csv,
    )
}

/// An axis-aligned box: lower and upper corner.
type Aabb = (DVec3, DVec3);

/// Steps the paper scene for `frames` frames and prints the mean number of overlapping swept
/// boxes per frame as `{"pairs_per_frame": x}`.
pub fn count(bodies: usize, speed: f64, frames: u64) -> CliResult<()> {
    let scene = PaperScene::new(bodies, 0.05, speed).build().map_err(|e| e.to_string())?;
    let mut world = scene
        .world(WorldConfig { method: Method::Auto, mode: Mode::Detect, ..WorldConfig::default() })
        .map_err(|e| e.to_string())?;
    let radii: Vec<f64> = scene.spheres.iter().map(|s| s.radius).collect();
    let grow = |aabb: &mut Aabb, centre: DVec3, radius: f64| {
        aabb.0 = aabb.0.min(centre - radius);
        aabb.1 = aabb.1.max(centre + radius);
    };
    let mut total = 0;
    for _ in 0..frames {
        // No body is ever removed: a body's slot index is its place in the scene.
        let mut boxes: Vec<Aabb> =
            world.spheres().map(|(_, s)| (s.position - s.radius, s.position + s.radius)).collect();
        for c in world.step(1.0 / FRAMES_PER_SECOND).map_err(|e| e.to_string())? {
            if let Touched::Wall(_) = c.touched {
                let i = c.body.index() as usize;
                let radius = radii[i];
                // The contact point sits one radius out along the normal from the centre.
                grow(&mut boxes[i], c.point - c.normal * radius, radius);
            }
        }
        for (handle, s) in world.spheres() {
            grow(&mut boxes[handle.index() as usize], s.position, s.radius);
        }
        total += overlapping_pairs(&mut boxes);
    }
    crate::common::print(&format!("{{\"pairs_per_frame\":{}}}\n", total as f64 / frames.max(1) as f64))
}

/// Pairs of overlapping (or touching) boxes, by sort and sweep on x; reorders `boxes`.
fn overlapping_pairs(boxes: &mut [Aabb]) -> u64 {
    boxes.sort_unstable_by(|a, b| a.0.x.total_cmp(&b.0.x));
    let mut pairs = 0;
    for (i, &(low, high)) in boxes.iter().enumerate() {
        for other in boxes[i + 1..].iter().take_while(|other| other.0.x <= high.x) {
            if other.0.y <= high.y && low.y <= other.1.y && other.0.z <= high.z && low.z <= other.1.z {
                pairs += 1;
            }
        }
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn sweep_counts_what_every_pair_test_counts() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut boxes: Vec<Aabb> = (0..400)
            .map(|_| {
                let low =
                    DVec3::new(rng.random_range(0.0..20.0), rng.random_range(0.0..20.0), rng.random_range(0.0..20.0));
                (
                    low,
                    low + DVec3::new(
                        rng.random_range(0.0..3.0),
                        rng.random_range(0.0..3.0),
                        rng.random_range(0.0..3.0),
                    ),
                )
            })
            .collect();
        let overlap = |a: &Aabb, b: &Aabb| a.0.cmple(b.1).all() && b.0.cmple(a.1).all();
        let every_pair = (0..boxes.len())
            .flat_map(|i| (i + 1..boxes.len()).map(move |j| (i, j)))
            .filter(|&(i, j)| overlap(&boxes[i], &boxes[j]))
            .count();
        assert!(every_pair > 0);
        assert_eq!(overlapping_pairs(&mut boxes), every_pair as u64);
    }
}
