//! Where each broad phase wins: the grid, the paper's sweep and prune (vadop), the swept k-DOP
//! and classic sweep and prune over swept boxes, on scenes of different speed profiles: the
//! paper's at three speeds, a stream, heavy-tailed speeds (detect mode) and an equilibrium gas
//! (simulate mode). A method that times out at one n is not run at a larger one.

use super::{mean_ms, ms_cell, Context, Section, Timed};
use crate::common::{csv_number, window_frames};
use crate::plots;
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::CliResult;
use std::fmt::Write as _;
use std::rc::Rc;

const METHODS: [&str; 4] = ["grid", "vadop", "swept-kdop", "swept-aabb"];

/// A scene of the comparison: its name and its run (any method, any n).
struct Scene {
    name: &'static str,
    kind: &'static str,
    speed: f64,
    spread: Option<f64>,
    packing: f64,
    mode: &'static str,
}

const SCENES: [Scene; 6] = [
    Scene { name: "paper 0.05", kind: "paper", speed: 0.05, spread: None, packing: 0.05, mode: "detect" },
    Scene { name: "paper 0.5", kind: "paper", speed: 0.5, spread: None, packing: 0.05, mode: "detect" },
    Scene { name: "paper 5", kind: "paper", speed: 5.0, spread: None, packing: 0.05, mode: "detect" },
    Scene { name: "stream 5 within 5°", kind: "stream", speed: 5.0, spread: Some(5.0), packing: 0.05, mode: "detect" },
    Scene { name: "heavy tail 0.5", kind: "heavy-tail", speed: 0.5, spread: None, packing: 0.05, mode: "detect" },
    Scene { name: "gas 0.2 (simulate)", kind: "gas", speed: 0.2, spread: None, packing: 0.2, mode: "simulate" },
];

/// One scene at one n: each method's run, `None` when skipped.
struct Row {
    bodies: usize,
    scene: &'static Scene,
    frames: u64,
    runs: Vec<Option<Rc<Timed>>>,
}

pub(super) fn run(context: &Context) -> CliResult<()> {
    let plan = &context.plan;
    let product = context.runner.product()?;
    let progress = Progress::new(plan.methods_bodies.len() * SCENES.len() * METHODS.len());
    let mut rows: Vec<Row> = Vec::new();
    for &n in &plan.methods_bodies {
        for scene in &SCENES {
            let frames = window_frames(scene.speed, plan.quick);
            let runs = METHODS
                .iter()
                .enumerate()
                .map(|(k, &method)| {
                    let timed_out_before = rows.iter().filter(|r| std::ptr::eq(r.scene, scene)).any(|r| {
                        r.runs[k].as_deref().is_some_and(|t| t.as_ref().is_err_and(|e| e.starts_with("timed out")))
                    });
                    if timed_out_before {
                        progress.done(&format!("{} n={n} {method}: skipped, timed out at a smaller n", scene.name));
                        return None;
                    }
                    let run = Simulation {
                        kind: scene.kind,
                        packing: scene.packing,
                        spread: scene.spread,
                        mode: scene.mode,
                        ..Simulation::paper(n, scene.speed, frames, method)
                    };
                    Some(context.time(product, &run, &progress))
                })
                .collect();
            rows.push(Row { bodies: n, scene, frames, runs });
            write(context, &rows)?;
        }
    }
    progress.finish();
    for &n in &plan.methods_bodies {
        let groups: Vec<(String, Vec<Option<f64>>)> = rows
            .iter()
            .filter(|r| r.bodies == n)
            .map(|r| (r.scene.name.to_string(), r.runs.iter().map(|t| t.as_deref().and_then(mean_ms)).collect()))
            .collect();
        let (path, _) = context.plot(&format!("methods-{n}.png"));
        let title = format!("Broad phases by scene, n = {n}: mean ms per frame");
        plots::grouped_bars(&path, &title, "scene", "mean ms per frame (log scale)", &METHODS, &groups)?;
    }
    Ok(())
}

fn write(context: &Context, rows: &[Row]) -> CliResult<()> {
    let mut md = format!(
        "Detect mode (bodies pass through each other) except the gas. paper S: the paper scene, speeds up to S \
         diameters per frame; stream: every body at 5 diameters per frame within 5° of +x; heavy tail: Pareto speeds, \
         median 0.5, tail index 1.5; gas: Maxwell velocities, rms 0.2, packing 0.2, full response. ms/frame: mean \
         wall-clock time of a step over frames covering several broad-phase windows, median of {} runs; a method \
         that timed out at a smaller n is skipped (—).\n\n",
        context.repeats
    );
    let _ = writeln!(md, "| n | scene | frames | {} | fastest |", METHODS.join(" | "));
    let _ = writeln!(md, "|---:|---|---:|{}---|", "---:|".repeat(METHODS.len()));
    let mut csv = format!("n,scene,frames,{},fastest,status\n", METHODS.map(|m| format!("{m}_ms")).join(","));
    for r in rows {
        let times: Vec<Option<f64>> = r.runs.iter().map(|t| t.as_deref().and_then(mean_ms)).collect();
        let fastest = times
            .iter()
            .zip(METHODS)
            .filter_map(|(t, m)| Some((t.as_ref()?, m)))
            .min_by(|a, b| a.0.total_cmp(b.0))
            .map_or("—", |f| f.1);
        let cells: Vec<String> = r.runs.iter().map(|t| t.as_deref().map_or("—".to_string(), ms_cell)).collect();
        let _ = writeln!(md, "| {} | {} | {} | {} | {fastest} |", r.bodies, r.scene.name, r.frames, cells.join(" | "));
        let failures: Vec<String> =
            r.runs.iter().flatten().filter_map(|t| t.as_ref().as_ref().err().map(|e| e.replace(',', ";"))).collect();
        let status = if failures.is_empty() { "ok".to_string() } else { failures.join("; ") };
        let numbers: Vec<String> = times.iter().map(|t| csv_number(*t)).collect();
        let _ = writeln!(csv, "{},{},{},{},{fastest},{status}", r.bodies, r.scene.name, r.frames, numbers.join(","));
    }
    for &n in &context.plan.methods_bodies {
        let (_, link) = context.plot(&format!("methods-{n}.png"));
        let _ = writeln!(md, "\n![broad phases by scene, n = {n}]({link})");
    }
    context.write(Section::Methods.markers(), "Where each broad phase wins", &md, "methods.csv", &csv)
}
