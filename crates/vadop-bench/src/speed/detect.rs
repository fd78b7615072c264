//! Detect mode on the paper scene, n x speed: mean ms/frame of the default method (auto), the
//! grid and the paper's sweep and prune (vadop), of the old engine's grid (commit d35de4a, built
//! by scripts/build-baseline.sh: its paper-scene generator is bit-identical, so it steps the same
//! scene), and of the fastest exact and fastest discrete peer of `vadop-bench peers` where its
//! CSV has the cell.

use super::{cell, first, mean_ms, ms_cell, ratio, Context, Section, Timed};
use crate::common::{csv_number, window_frames};
use crate::peers::{self, Row};
use crate::plots::{self, Panel, Series, Stroke};
use crate::progress::Progress;
use crate::runner::Simulation;
use crate::CliResult;
use std::fmt::Write as _;
use std::path::Path;
use std::rc::Rc;

/// The product's methods in this table, the default first.
const METHODS: [&str; 3] = ["auto", "grid", "vadop"];

/// One (n, speed) cell.
struct Cell {
    bodies: usize,
    speed: f64,
    frames: u64,
    /// auto, grid, vadop.
    runs: Vec<Rc<Timed>>,
    /// `None` when the old engine is not built.
    old_grid: Option<Rc<Timed>>,
    /// Name and ms/frame of the fastest exact and the fastest discrete peer.
    exact_peer: Option<(&'static str, f64)>,
    discrete_peer: Option<(&'static str, f64)>,
}

impl Cell {
    fn auto_ms(&self) -> Option<f64> {
        mean_ms(&self.runs[0])
    }
    fn old_ms(&self) -> Option<f64> {
        self.old_grid.as_deref().and_then(mean_ms)
    }
}

pub fn run(context: &Context, baseline: &Path, peers_csv: &Path) -> CliResult<()> {
    let plan = &context.plan;
    let product = context.runner.product()?;
    let old = baseline.is_file().then_some(baseline);
    if old.is_none() {
        eprintln!(
            "{} not found: the old engine's column stays empty (build it with scripts/build-baseline.sh)",
            baseline.display()
        );
    }
    // The peers' columns are a comparison, not the measurement: without a readable CSV they stay empty.
    let peer_rows = peers::read_csv(peers_csv).unwrap_or_else(|e| {
        eprintln!("{e}: the peers' columns stay empty");
        Vec::new()
    });
    let cells_count = plan.detect_bodies.len() * plan.speeds.len();
    let progress = Progress::new(cells_count * (METHODS.len() + usize::from(old.is_some())));
    let mut cells = Vec::new();
    for &bodies in &plan.detect_bodies {
        for &speed in &plan.speeds {
            let frames = window_frames(speed, plan.quick);
            let scene = |method| Simulation::paper(bodies, speed, frames, method);
            let runs = METHODS.iter().map(|m| context.time(product, &scene(m), &progress)).collect();
            // The old engine has no --threads: it is single-threaded.
            let old_grid = old.map(|old| context.time(old, &Simulation { threads: None, ..scene("grid") }, &progress));
            let fastest = |exact: bool| {
                peer_rows
                    .iter()
                    .filter(|r| r.bodies == bodies && r.speed == speed && !r.pipeline.starts_with("vadop"))
                    .filter(|r| if exact { r.exact() } else { !r.continuous })
                    .filter_map(|r: &Row| Some((r.pipeline, r.outcome.as_ref().ok()?.mean_ms)))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
            };
            cells.push(Cell {
                bodies,
                speed,
                frames,
                runs,
                old_grid,
                exact_peer: fastest(true),
                discrete_peer: fastest(false),
            });
            write(context, &cells, old.is_some(), peers_csv, !peer_rows.is_empty())?;
        }
    }
    progress.finish();
    draw(context, &cells)
}

fn write(context: &Context, cells: &[Cell], old_built: bool, peers_csv: &Path, peers_read: bool) -> CliResult<()> {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "Paper scene (packing 0.05, seed 1) in detect mode. ms/frame: the mean over the run's frames of the \
         wall-clock time of a step, median of {} runs; frames cover several broad-phase windows (the windows \
         column counts auto's). auto is the default method ({}), vadop the paper's sweep and prune, old grid \
         today's Method::Grid before the frame pipeline (commit d35de4a, {}). Peers: the fastest exact (continuous, \
         nothing missed or false) and fastest discrete pipeline of `{}` on the same cell, {} (another command, \
         other frames: its times are per-frame too, but measured at another time).\n",
        context.repeats,
        cells
            .first()
            .and_then(|c| first(&c.runs[0]))
            .map(|r| r.summary.run.method.clone())
            .unwrap_or_else(|| "auto".into()),
        if old_built { "scripts/build-baseline.sh" } else { "not built here: run scripts/build-baseline.sh" },
        peers_csv.display(),
        if peers_read { "read from it" } else { "not found, so these columns are empty" },
    );
    let _ = writeln!(md, "| n | speed | frames | windows | auto ms | grid ms | vadop ms | old grid ms | fastest exact peer ms | fastest discrete peer ms | auto ÷ exact peer | auto ÷ discrete peer | old grid ÷ auto |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut csv = String::from("n,speed,frames,windows,auto_ms,grid_ms,vadop_ms,old_grid_ms,exact_peer,exact_peer_ms,discrete_peer,discrete_peer_ms,auto_vs_exact_peer,auto_vs_discrete_peer,old_grid_vs_auto,status\n");
    for c in cells {
        let windows = first(&c.runs[0]).map(|r| r.summary.per_frame.windows * r.summary.frames_completed as f64);
        let peer = |p: Option<(&str, f64)>| p.map_or("—".to_string(), |(name, ms)| format!("{ms:.3} ({name})"));
        let (vs_exact, vs_discrete, old_vs_auto) = (
            ratio(c.auto_ms(), c.exact_peer.map(|p| p.1)),
            ratio(c.auto_ms(), c.discrete_peer.map(|p| p.1)),
            ratio(c.old_ms(), c.auto_ms()),
        );
        let old = c.old_grid.as_deref().map_or("not built".to_string(), ms_cell);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {old} | {} | {} | {} | {} | {} |",
            c.bodies,
            c.speed,
            c.frames,
            cell(windows, 0),
            ms_cell(&c.runs[0]),
            ms_cell(&c.runs[1]),
            ms_cell(&c.runs[2]),
            peer(c.exact_peer),
            peer(c.discrete_peer),
            cell(vs_exact, 2),
            cell(vs_discrete, 2),
            cell(old_vs_auto, 2),
        );
        let failures: Vec<String> = c
            .runs
            .iter()
            .chain(&c.old_grid)
            .filter_map(|t| t.as_ref().as_ref().err().map(|e| e.replace(',', ";")))
            .collect();
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            c.bodies,
            c.speed,
            c.frames,
            csv_number(windows),
            csv_number(c.auto_ms()),
            csv_number(mean_ms(&c.runs[1])),
            csv_number(mean_ms(&c.runs[2])),
            csv_number(c.old_ms()),
            c.exact_peer.map_or("", |p| p.0),
            csv_number(c.exact_peer.map(|p| p.1)),
            c.discrete_peer.map_or("", |p| p.0),
            csv_number(c.discrete_peer.map(|p| p.1)),
            csv_number(vs_exact),
            csv_number(vs_discrete),
            csv_number(old_vs_auto),
            if failures.is_empty() { "ok".to_string() } else { failures.join("; ") },
        );
    }
    // The old engine must step the same scene: the same contacts say it did.
    for c in cells {
        let pairs = |t: &Timed| first(t).map(|r| r.summary.contacts.pairs);
        if let (Some(new), Some(old)) = (pairs(&c.runs[0]), c.old_grid.as_deref().and_then(pairs)) {
            if new != old {
                let _ = writeln!(md, "\n**The old engine found {old} pair contacts, auto {new}, at n = {}, speed {}: not the same scene.**", c.bodies, c.speed);
            }
        }
    }
    let (_, link) = context.plot("detect.png");
    let _ = writeln!(md, "\nRatios below 1 mean auto is faster; old grid ÷ auto above 1 means the new engine is faster.\n\n![detect-mode ms per frame against n]({link})\n");
    context.write(
        Section::Detect.markers(),
        "Detect mode: ms per frame against the old engine and the peers",
        &md,
        "detect.csv",
        &csv,
    )
}

/// ms/frame against n, one panel per speed.
fn draw(context: &Context, cells: &[Cell]) -> CliResult<()> {
    let mut speeds: Vec<f64> = cells.iter().map(|c| c.speed).collect();
    speeds.sort_by(f64::total_cmp);
    speeds.dedup();
    let panels = speeds
        .iter()
        .map(|&speed| {
            let at: Vec<&Cell> = cells.iter().filter(|c| c.speed == speed).collect();
            let line = |label: &str, value: &dyn Fn(&Cell) -> Option<f64>| {
                Series::new(label, at.iter().filter_map(|c| Some((c.bodies as f64, value(c)?))).collect())
            };
            let mut series: Vec<Series> =
                METHODS.iter().enumerate().map(|(k, m)| line(m, &|c| mean_ms(&c.runs[k]))).collect();
            series.push(line("old grid (d35de4a)", &|c| c.old_ms()));
            series.push(line("fastest exact peer", &|c| c.exact_peer.map(|p| p.1)).styled("#404040", Stroke::Solid));
            series.push(
                line("fastest discrete peer", &|c| c.discrete_peer.map(|p| p.1)).styled("#a0a0a0", Stroke::Dashed),
            );
            Panel {
                title: format!("max speed {speed} diameters/frame"),
                x_label: "bodies n".into(),
                y_label: "mean ms per frame".into(),
                series,
            }
        })
        .collect::<Vec<_>>();
    let (path, _) = context.plot("detect.png");
    plots::line_panels(&path, Some("Detect mode, paper scene: mean ms per frame"), &panels)
}
