//! `vadop-bench mpi`: weak scaling of vadop-mpi — the paper scene (detect mode) with a fixed
//! number of bodies per rank on 1, 2, 4, ... ranks, each run beside the one-process `vadop
//! simulate` of the same scene on one pinned core — and, from those counts, a model of a
//! billion bodies on a hundred nodes, written as a model. The same command measures a cluster
//! when given its launcher (`--launcher 'srun -n {ranks}'`; scripts/mpi-cluster.sh).
//!
//! It owns the runs, the table, the CSV and the model; vadop-mpi's JSON report carries the
//! figures (per-rank ms, bytes sent, ghost bodies, the ghost layer's width).

use crate::common::{csv_number, write_file, Common};
use crate::markdown::{self, Markers, RunInfo};
use crate::progress::Progress;
use crate::runner::{Runner, Simulation};
use crate::CliResult;
use clap::Args;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::PathBuf;

const MARKERS: Markers = Markers { name: "mpi-weak-scaling" };

#[derive(Debug, Args)]
#[command(after_help = "Each run is `LAUNCHER vadop-mpi simulate --bodies (ranks x per rank) ...`, unpinned (the \
launcher places the ranks), beside `vadop simulate` of the same scene on one pinned core. On this 2-core machine \
runs of more than 2 ranks share cores: the table marks them. --timeout defaults to 1800 s per run.")]
pub struct MpiArgs {
    /// Rank counts, comma-separated
    #[arg(long, value_delimiter = ',', default_value = "1,2,4")]
    ranks: Vec<usize>,
    /// Bodies per rank [default: 100000; with --quick: 10000]
    #[arg(long, value_name = "N")]
    bodies_per_rank: Option<usize>,
    /// Largest speed, in diameters per frame
    #[arg(long, value_name = "S", default_value_t = 0.5)]
    speed: f64,
    /// Frames per run [default: 60, several broad-phase windows; with --quick: 20]
    #[arg(long, value_name = "F")]
    frames: Option<u64>,
    /// How K ranks are started, `{ranks}` standing for K [default: mpirun -np {ranks}
    /// --oversubscribe, with --allow-run-as-root when run as root]
    #[arg(long, value_name = "COMMAND")]
    launcher: Option<String>,
    /// Leave out the one-process runs of the same scenes (on a cluster, too large for one node)
    #[arg(long)]
    without_one_process: bool,
    /// The vadop-mpi binary [default: beside this program]
    #[arg(long, value_name = "FILE")]
    vadop_mpi: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
}

/// What vadop-mpi's `--json` report holds that this suite reads.
#[derive(Debug, Deserialize)]
struct MpiReport {
    bodies: usize,
    #[serde(rename = "box")]
    side: [f64; 3],
    ghost_width: f64,
    summary: MpiSummary,
}

#[derive(Debug, Deserialize)]
struct MpiSummary {
    frames: u64,
    step_ms_max: f64,
    step_ms_mean: f64,
    exchange_ms_max: f64,
    bytes_mean: f64,
    ghosts_mean: f64,
    owned_min: u64,
    owned_max: u64,
}

impl MpiSummary {
    fn per_frame(&self, total: f64) -> f64 {
        total / self.frames.max(1) as f64
    }
}

struct Row {
    ranks: usize,
    bodies: usize,
    split: Result<MpiReport, String>,
    /// One process, same scene: mean wall-clock ms per frame.
    one: Result<f64, String>,
}

fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status").is_ok_and(|status| {
        status.lines().any(|line| line.starts_with("Uid:") && line.split_whitespace().nth(1) == Some("0"))
    })
}

pub fn run(args: &MpiArgs) -> CliResult<()> {
    let common = &args.common;
    let runner = Runner::new(common, common.timeout(1800.0)?)?;
    let product = runner.product()?.to_path_buf();
    let vadop_mpi = args.vadop_mpi.clone().unwrap_or_else(|| product.with_file_name("vadop-mpi"));
    if !vadop_mpi.is_file() {
        return Err(format!(
            "{} not found: build it with `cargo build --release -p vadop-mpi` (MPI installed by scripts/setup.sh --mpi) or pass --vadop-mpi",
            vadop_mpi.display()
        ));
    }
    if args.ranks.is_empty() || args.ranks.contains(&0) {
        return Err("--ranks: give one or more rank counts of at least 1".to_string());
    }
    let launcher = args.launcher.clone().unwrap_or_else(|| {
        let root = if is_root() { " --allow-run-as-root" } else { "" };
        format!("mpirun -np {{ranks}} --oversubscribe{root}")
    });
    if !launcher.contains("{ranks}") {
        return Err(format!("--launcher {launcher:?} must say where the rank count goes, as {{ranks}}"));
    }
    let per_rank = args.bodies_per_rank.unwrap_or(if common.quick { 10_000 } else { 100_000 });
    let frames = args.frames.unwrap_or(if common.quick { 20 } else { 60 });
    let (markdown_path, results) = (common.markdown(), common.results()?);
    markdown::check(&markdown_path, MARKERS)?;
    let info = RunInfo::start(runner.cpu());
    let progress = Progress::new(if args.without_one_process { 1 } else { 2 } * args.ranks.len());
    let mut rows = Vec::new();
    for &ranks in &args.ranks {
        let bodies = ranks * per_rank;
        let json = runner.scratch_file("mpi.json");
        let mut words: Vec<String> =
            launcher.replace("{ranks}", &ranks.to_string()).split_whitespace().map(str::to_string).collect();
        let program = PathBuf::from(words.remove(0));
        words.push(vadop_mpi.display().to_string());
        for (flag, value) in [
            ("simulate", None),
            ("--quiet", None),
            ("--bodies", Some(bodies.to_string())),
            ("--max-speed", Some(args.speed.to_string())),
            ("--frames", Some(frames.to_string())),
            ("--json", Some(json.display().to_string())),
        ] {
            words.push(flag.to_string());
            words.extend(value);
        }
        progress.start(&format!("{ranks} ranks, {bodies} bodies"));
        let split = runner.run_free(&program, &words, runner.timeout).and_then(|_| {
            let text = std::fs::read_to_string(&json).map_err(|e| format!("{}: {e}", json.display()))?;
            serde_json::from_str::<MpiReport>(&text).map_err(|e| format!("{}: {e}", json.display()))
        });
        let _ = std::fs::remove_file(&json);
        progress.done(&format!("{ranks} ranks, {bodies} bodies: {}", if split.is_ok() { "done" } else { "failed" }));
        let one = match args.without_one_process {
            true => Err("not run".to_string()),
            false => {
                progress.start(&format!("one process, {bodies} bodies"));
                let run = Simulation::paper(bodies, args.speed, frames, "auto");
                let one = runner.simulate(&product, &run).map(|r| r.summary.wall_ms.mean);
                progress
                    .done(&format!("one process, {bodies} bodies: {}", if one.is_ok() { "done" } else { "failed" }));
                one
            }
        };
        rows.push(Row { ranks, bodies, split, one });
        write(&rows, (per_rank, args.speed, frames), &launcher, &info, (&markdown_path, &results))?;
    }
    progress.finish();
    Ok(())
}

/// The model's machine: a hundred nodes of 64 cores, one rank a core, an InfiniBand-class
/// network. Assumptions, not measurements.
const NODES: f64 = 100.0;
const CORES_PER_NODE: f64 = 64.0;
const MODEL_BODIES: f64 = 1e9;
/// One message's latency, seconds, and the bandwidth a rank gets, bytes per second.
const LATENCY: f64 = 2e-6;
const BANDWIDTH: f64 = 10e9;
/// A brick in a 3D cut has 26 neighbours (faces, edges and corners).
const NEIGHBOURS: f64 = 26.0;

fn write(
    rows: &[Row],
    (per_rank, speed, frames): (usize, f64, u64),
    launcher: &str,
    info: &RunInfo,
    (markdown_path, results): (&std::path::Path, &std::path::Path),
) -> CliResult<()> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut md = format!(
        "### Beyond one machine: vadop-mpi's weak scaling (issue 29)\n\n{}\nThe paper scene (packing 0.05, speeds up \
         to {speed} diameters per frame, detect mode, default method, seed 1) with {per_rank} bodies per rank, {frames} \
         frames, run as `{launcher} vadop-mpi simulate ...` (one thread per rank, not pinned: the launcher places the \
         ranks); beside it `vadop simulate` of the same \
         scene on one pinned core. Per frame, means over the frames: the step of the slowest rank and of the mean rank, \
         the exchanges of the slowest rank (handing bodies on, copying them into neighbours' ghost layers, the frame's \
         reductions; it includes waiting for the slowest rank), the ghost bodies a rank holds and the bytes it sends. \
         Efficiency: one rank's step + exchanges over this row's. Rows marked * have more ranks than the machine's {cores} \
         cores: their ranks share cores, so their times are not scaling figures (their counts are).\n\n",
        info.header()
    );
    let _ = writeln!(
        md,
        "| ranks | bodies | owned per rank | step ms, slowest | step ms, mean | exchanges ms | efficiency | ghosts per rank | ghosts ÷ owned | bytes sent per rank | one process ms (same n) |"
    );
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut csv = String::from(
        "ranks,bodies,step_ms_max,step_ms_mean,exchange_ms_max,efficiency,ghosts_per_rank,ghosts_per_owned,bytes_per_rank,one_process_ms\n",
    );
    let frame_ms = |r: &MpiReport| r.summary.per_frame(r.summary.step_ms_max + r.summary.exchange_ms_max);
    let base = rows.iter().find(|r| r.ranks == 1).and_then(|r| r.split.as_ref().ok()).map(frame_ms);
    for row in rows {
        let star = if row.ranks > cores { "*" } else { "" };
        let one = row.one.as_ref().ok().copied();
        match &row.split {
            Ok(r) => {
                let s = &r.summary;
                let owned = r.bodies as f64 / row.ranks as f64;
                let efficiency = base.map(|b| b / frame_ms(r));
                let ghosts = s.per_frame(s.ghosts_mean);
                let _ = writeln!(
                    md,
                    "| {}{star} | {} | {}–{} | {:.3} | {:.3} | {:.3} | {} | {ghosts:.0} | {:.3} | {:.0} | {} |",
                    row.ranks,
                    row.bodies,
                    s.owned_min,
                    s.owned_max,
                    s.per_frame(s.step_ms_max),
                    s.per_frame(s.step_ms_mean),
                    s.per_frame(s.exchange_ms_max),
                    efficiency.map_or("—".to_string(), |e| format!("{e:.2}")),
                    ghosts / owned,
                    s.per_frame(s.bytes_mean),
                    one.map_or("—".to_string(), |ms| format!("{ms:.3}")),
                );
                let _ = writeln!(
                    csv,
                    "{},{},{},{},{},{},{},{},{},{}",
                    row.ranks,
                    row.bodies,
                    s.per_frame(s.step_ms_max),
                    s.per_frame(s.step_ms_mean),
                    s.per_frame(s.exchange_ms_max),
                    csv_number(efficiency),
                    ghosts,
                    ghosts / owned,
                    s.per_frame(s.bytes_mean),
                    csv_number(one)
                );
            }
            Err(e) => {
                let _ = writeln!(
                    md,
                    "| {}{star} | {} | {} | | | | | | | | |",
                    row.ranks,
                    row.bodies,
                    markdown::table_cell(e)
                );
            }
        }
    }
    if let Some(model) = model(rows) {
        md.push_str(&model);
    }
    write_file(&results.join("mpi").join("weak-scaling.csv"), &csv)?;
    markdown::write_section(markdown_path, MARKERS, &md)
}

/// The model of [`MODEL_BODIES`] on [`NODES`] nodes, from the one-rank run (the step's cost per
/// body) and the two-rank run (ghosts and bytes per area of a cut), or `None` before both ran.
fn model(rows: &[Row]) -> Option<String> {
    let one = rows.iter().find(|r| r.ranks == 1)?.split.as_ref().ok()?;
    let two = rows.iter().find(|r| r.ranks == 2)?.split.as_ref().ok()?;
    let step_per_body = one.summary.per_frame(one.summary.step_ms_mean) / one.bodies as f64;
    // Two ranks share one cut across the box's longest side: ghosts and bytes per area of a cut.
    let [x, y, z] = two.side;
    let cut = (x * y * z) / x.max(y).max(z);
    let ghosts_per_area = two.summary.per_frame(two.summary.ghosts_mean) / cut;
    let bytes_per_area = two.summary.per_frame(two.summary.bytes_mean) / cut;
    let density = two.bodies as f64 / (x * y * z);
    let width = two.ghost_width;
    let ranks = NODES * CORES_PER_NODE;
    let per_rank = MODEL_BODIES / ranks;
    // A cubic brick: six faces of its side squared (edges and corners add little at this size).
    let side = (per_rank / density).cbrt();
    let area = 6.0 * side * side;
    let ghosts = ghosts_per_area * area;
    let bytes = bytes_per_area * area;
    let step = step_per_body * (per_rank + ghosts);
    let messages = NEIGHBOURS * LATENCY + bytes / BANDWIDTH;
    let reductions = 3.0 * ranks.log2().ceil() * LATENCY;
    let exchange = 1e3 * (messages + reductions);
    let mut md = String::new();
    let _ = write!(
        md,
        "\n**A model, not a measurement: {MODEL_BODIES:e} bodies on {NODES} nodes of {CORES_PER_NODE} cores** ({ranks} ranks, one a \
         core, {per_rank:.0} bodies each, the paper scene's density at this speed, a ghost layer {width:.2} wide as \
         here). From this run: the step costs \
         {:.3} µs per body held per frame (1 rank); a cut carries {ghosts_per_area:.3} ghost bodies and {bytes_per_area:.1} bytes \
         per frame per unit of its area (2 ranks). A cubic brick of side {side:.1} then holds {ghosts:.0} ghosts \
         ({:.1} % of its bodies) and sends {bytes:.0} bytes a frame. Assumed network: {} µs a message, {} GB/s a rank, \
         26 neighbours, 3 reductions of log2(ranks) steps a frame. Predicted: step {step:.2} ms + exchanges {exchange:.3} ms \
         = **{:.2} ms per frame** (contacts counted, not gathered: writing every contact to one file is rank 0's load alone \
         and does not scale; at this size each rank would write its own). Not modelled: load imbalance as bodies drift \
         (the bricks are cut once), and the network's contention.\n",
        step_per_body * 1e3,
        100.0 * ghosts / per_rank,
        LATENCY * 1e6,
        BANDWIDTH / 1e9,
        step + exchange
    );
    Some(md)
}
