//! The cost of a velocity change: `World::set_velocity` re-tests the body (a broad-phase query and
//! predictions for the rest of the window), which is what a game or a controller pays whenever it
//! steers a body between frames. A `--child` job steps a paper-scene world a few frames, then
//! times single calls on random bodies with random velocities of the scene's speed scale,
//! spread over several frames so the world stays mid-run; the section tabulates the median and
//! p95 microseconds per call for each speed and method.

use super::{cell, Context, Section};
use crate::common::{csv_number, median, quantile};
use crate::plots::{self, Series};
use crate::progress::Progress;
use crate::CliResult;
use glam::DVec3;
use rand::{Rng, SeedableRng};
use std::fmt::Write as _;
use std::time::Instant;
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{Method, Mode, WorldConfig};

/// The calls are spread over this many frames.
const ROUNDS: usize = 10;
const METHODS: [&str; 2] = ["auto", "vadop"];

/// Steps the paper scene `frames` frames in detect mode with `method`, then times `calls` calls
/// of `set_velocity`, a tenth of them before each of the next frames; prints
/// `{"median_us": m, "p95_us": p}`.
pub fn measure(bodies: usize, speed: f64, frames: u64, method: Method, calls: usize) -> CliResult<()> {
    let scene = PaperScene::new(bodies, 0.05, speed).build().map_err(|e| e.to_string())?;
    let mut world =
        scene.world(WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() }).map_err(|e| e.to_string())?;
    let dt = 1.0 / FRAMES_PER_SECOND;
    for _ in 0..frames {
        world.step(dt).map_err(|e| e.to_string())?;
    }
    let handles: Vec<_> = world.spheres().map(|(handle, _)| handle).collect();
    // The scene's speeds: uniform up to `speed` diameters per frame, random directions.
    let scale = speed * 2.0 * scene.spheres[0].radius * FRAMES_PER_SECOND;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut micros = Vec::with_capacity(calls);
    for round in 0..ROUNDS {
        for _ in round * calls / ROUNDS..(round + 1) * calls / ROUNDS {
            let handle = handles[rng.random_range(0..handles.len())];
            let direction = loop {
                let v =
                    DVec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
                if (1e-6..=1.0).contains(&v.length_squared()) {
                    break v.normalize();
                }
            };
            let velocity = direction * rng.random_range(0.0..=scale);
            let started = Instant::now();
            world.set_velocity(handle, velocity).map_err(|e| e.to_string())?;
            micros.push(started.elapsed().as_secs_f64() * 1e6);
        }
        world.step(dt).map_err(|e| e.to_string())?;
    }
    let (median_us, p95_us) = (median(&micros).unwrap_or(0.0), quantile(&micros, 0.95).unwrap_or(0.0));
    crate::common::print(&format!("{{\"median_us\":{median_us},\"p95_us\":{p95_us}}}\n"))
}

/// One speed and method: median over repeats of the median and p95 microseconds.
struct Row {
    speed: f64,
    method: &'static str,
    outcome: Result<(f64, f64), String>,
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let plan = &context.plan;
    let n = plan.retest_bodies;
    // Mid-run: past the first window start, so the calls meet a window under way.
    let warm_up = 5;
    let progress = Progress::new(plan.speeds.len() * METHODS.len());
    let mut rows = Vec::new();
    for &speed in &plan.speeds {
        for method in METHODS {
            let args = [
                ("--bodies", n.to_string()),
                ("--speed", speed.to_string()),
                ("--frames", warm_up.to_string()),
                ("--method", method.to_string()),
                ("--calls", plan.retest_calls.to_string()),
            ];
            let outcome = context.child("retest", &args, context.repeats, &progress).and_then(|values| {
                let of = |key: &str| {
                    median(&values.iter().filter_map(|v| v[key].as_f64()).collect::<Vec<_>>())
                        .ok_or(format!("no {key}"))
                };
                Ok((of("median_us")?, of("p95_us")?))
            });
            rows.push(Row { speed, method, outcome });
            write(context, &rows, warm_up)?;
        }
    }
    progress.finish();
    let (path, _) = context.plot("retest.png");
    let series = METHODS
        .iter()
        .flat_map(|&method| {
            let rows = &rows;
            [("median", 0), ("p95", 1)].map(move |(statistic, k)| {
                let points = rows
                    .iter()
                    .filter(|r| r.method == method)
                    .filter_map(|r| Some((r.speed, [r.outcome.as_ref().ok()?.0, r.outcome.as_ref().ok()?.1][k])))
                    .collect();
                Series::new(&format!("{method} {statistic}"), points)
            })
        })
        .collect();
    plots::line_chart(
        &path,
        &format!("World::set_velocity: microseconds per call (n = {n})"),
        "max speed (diameters/frame)",
        "microseconds per call",
        series,
    )
}

fn write(context: &Context, rows: &[Row], warm_up: u64) -> CliResult<()> {
    let plan = &context.plan;
    let mut md = format!(
        "Paper scene of {} bodies (packing 0.05, seed 1) in detect mode, stepped {warm_up} frames; then {} calls of \
         `World::set_velocity(handle, v)` on random bodies with random velocities of the scene's speed scale (uniform \
         up to the maximum speed, random directions), {} calls before each of the next {ROUNDS} frames, each call \
         timed alone. A call re-tests the body: a broad-phase query and its predictions for the rest of the window. \
         Median of {} runs.\n\n",
        plan.retest_bodies,
        plan.retest_calls,
        plan.retest_calls / ROUNDS,
        context.repeats
    );
    let _ = writeln!(md, "| speed | method | median µs | p95 µs |");
    let _ = writeln!(md, "|---:|---|---:|---:|");
    let mut csv = String::from("n,speed,method,calls,median_us,p95_us,status\n");
    for r in rows {
        let values = r.outcome.as_ref().ok();
        let (median_us, p95_us) = (values.map(|v| v.0), values.map(|v| v.1));
        let status = r.outcome.as_ref().err().map_or("ok".to_string(), |e| e.replace(',', ";"));
        match &r.outcome {
            Ok(_) => writeln!(md, "| {} | {} | {} | {} |", r.speed, r.method, cell(median_us, 1), cell(p95_us, 1)),
            Err(e) => writeln!(md, "| {} | {} | {} | — |", r.speed, r.method, crate::markdown::table_cell(e)),
        }
        .unwrap_or(());
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{status}",
            plan.retest_bodies,
            r.speed,
            r.method,
            plan.retest_calls,
            csv_number(median_us),
            csv_number(p95_us)
        );
    }
    let (_, link) = context.plot("retest.png");
    let _ = writeln!(md, "\n![microseconds per set_velocity call]({link})\n");
    context.write(Section::Retest.markers(), "Re-test cost: a velocity change between frames", &md, "retest.csv", &csv)
}
