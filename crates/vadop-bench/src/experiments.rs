//! The paper's experiments, reproduced and extended (`vadop-bench experiments`): contacts found
//! and missed against speed, time against n, speed and pool size per method, the cost split,
//! endpoint swaps and peak memory. Every run is a detect-mode child of the product binary
//! (identical paths for every method, each child's peak memory its own), all launched by one
//! command so the ratios compare runs on the same machine at the same time. It owns the
//! experiment plans, the CSV, the plots and the markdown section; a failed or timed-out child
//! becomes a row saying so.

use crate::common::{csv_number, window_frames, write_file, Common};
use crate::markdown::{self, table_cell, Markers, RunInfo};
use crate::plots::{self, Series};
use crate::progress::Progress;
use crate::runner::{Runner, Simulation};
use crate::summary::Summary;
use crate::CliResult;
use clap::Args;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const MARKERS: Markers = Markers { name: "experiments" };

/// Methods compared in the time experiments, in legend order: the default first, then the
/// paper's sweep and prune, the other broad phases and the two baselines.
const METHODS: [&str; 7] = ["auto", "vadop", "grid", "swept-aabb", "swept-kdop", "discrete", "brute"];

#[derive(Debug, Args)]
pub struct ExperimentsArgs {
    #[command(flatten)]
    common: Common,
}

/// What one experiment varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Experiment {
    /// Contacts found and missed against speed, vadop and discrete against brute force.
    Accuracy,
    /// ms/frame and peak memory against n, per method.
    Bodies,
    /// ms/frame, cost split and swaps against speed, per method.
    Speed,
    /// vadop's ms/frame against pool size at several speeds.
    Pool,
    /// ms/frame per method with full response (paths differ between methods).
    Simulate,
}

impl Experiment {
    fn name(self) -> &'static str {
        match self {
            Experiment::Accuracy => "accuracy",
            Experiment::Bodies => "bodies",
            Experiment::Speed => "speed",
            Experiment::Pool => "pool",
            Experiment::Simulate => "simulate",
        }
    }

    /// Detect mode (identical paths) everywhere but in the simulate experiment.
    fn mode(self) -> &'static str {
        if self == Experiment::Simulate {
            "simulate"
        } else {
            "detect"
        }
    }
}

/// One child run.
struct Run {
    experiment: Experiment,
    bodies: usize,
    speed: f64,
    method: &'static str,
    /// `None` for the automatic choice.
    pool: Option<usize>,
    reference: &'static str,
    outcome: Result<Summary, String>,
}

impl Run {
    fn summary(&self) -> Option<&Summary> {
        self.outcome.as_ref().ok()
    }
    fn mean_ms(&self) -> Option<f64> {
        self.summary().map(|s| s.c_total_ms.mean)
    }
}

/// One run to make: experiment, n, speed, method, pool (`None`: automatic), reference.
type PlannedRun = (Experiment, usize, f64, &'static str, Option<usize>, &'static str);

/// The sizes of the experiments.
struct Plan {
    bodies: usize,
    /// Frames of the methods without broad-phase windows (discrete and brute); the others run
    /// enough frames to cover several windows.
    frames: u64,
    quick: bool,
    accuracy_speeds: Vec<f64>,
    speeds: Vec<f64>,
    body_counts: Vec<usize>,
    pool_speeds: Vec<f64>,
    pools: Vec<usize>,
    simulate_speeds: Vec<f64>,
    /// Largest n brute force runs at in the time experiments.
    brute_max: usize,
}

impl Plan {
    /// The full plan, or the quick one that finishes in a few minutes.
    fn new(quick: bool) -> Plan {
        if quick {
            Plan {
                bodies: 1000,
                frames: 5,
                quick,
                accuracy_speeds: vec![0.05, 0.5, 5.0],
                speeds: vec![0.05, 0.5, 5.0],
                body_counts: vec![250, 500, 1000, 2000],
                pool_speeds: vec![0.05, 0.5, 5.0],
                pools: vec![3, 7, 13, 32],
                simulate_speeds: vec![0.5],
                brute_max: 2000,
            }
        } else {
            Plan {
                bodies: 10_000,
                frames: 10,
                quick,
                accuracy_speeds: vec![0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0],
                speeds: vec![0.05, 0.2, 0.5, 2.0, 5.0],
                body_counts: vec![1000, 3000, 10_000, 30_000, 100_000],
                pool_speeds: vec![0.05, 0.5, 5.0],
                pools: vec![3, 7, 13, 32, 65, 200, 1000, 39_000],
                simulate_speeds: vec![0.5, 5.0],
                brute_max: 10_000,
            }
        }
    }

    /// Frames of a run: methods with broad-phase windows (every continuous one but brute force,
    /// which re-tests every pair every frame) run enough to cover several windows.
    fn frames(&self, method: &str, speed: f64) -> u64 {
        match method {
            "discrete" | "brute" => self.frames,
            _ => self.frames.max(window_frames(speed, self.quick)),
        }
    }

    /// Every run of every experiment.
    fn runs(&self) -> Vec<PlannedRun> {
        let mut runs = Vec::new();
        for &speed in &self.accuracy_speeds {
            for method in ["auto", "vadop", "discrete"] {
                runs.push((Experiment::Accuracy, self.bodies, speed, method, None, "brute"));
            }
        }
        let methods_at = |n: usize| METHODS.into_iter().filter(move |&m| m != "brute" || n <= self.brute_max);
        for &n in &self.body_counts {
            for method in methods_at(n) {
                runs.push((Experiment::Bodies, n, 0.5, method, None, "none"));
            }
        }
        for &speed in &self.speeds {
            for method in methods_at(self.bodies) {
                runs.push((Experiment::Speed, self.bodies, speed, method, None, "none"));
            }
        }
        for &speed in &self.pool_speeds {
            runs.push((Experiment::Pool, self.bodies, speed, "vadop", None, "none"));
            for &m in &self.pools {
                runs.push((Experiment::Pool, self.bodies, speed, "vadop", Some(m), "none"));
            }
        }
        for &speed in &self.simulate_speeds {
            for method in methods_at(self.bodies) {
                runs.push((Experiment::Simulate, self.bodies, speed, method, None, "none"));
            }
        }
        runs
    }
}

/// Runs the experiments, writes the CSV, the plots and the markdown section.
pub fn run(args: &ExperimentsArgs) -> CliResult<()> {
    let common = &args.common;
    let runner = Runner::new(common, common.timeout(600.0)?)?;
    let vadop = runner.product()?;
    let markdown_path = common.markdown();
    let out_dir = common.results()?.join("experiments");
    markdown::check(&markdown_path, MARKERS)?;
    let plan = Plan::new(common.quick);
    let planned = plan.runs();
    let progress = Progress::new(planned.len());
    let info = RunInfo::start(runner.cpu());
    let mut runs = Vec::new();
    for (experiment, bodies, speed, method, pool, reference) in planned {
        let label = pool.map_or(String::new(), |m| format!(" m={m}"));
        let what = format!("{}: n={bodies} speed={speed} {method}{label}", experiment.name());
        progress.start(&what);
        let run = Simulation {
            mode: experiment.mode(),
            reference,
            pool,
            ..Simulation::paper(bodies, speed, plan.frames(method, speed), method)
        };
        let outcome = runner.simulate(vadop, &run).map(|r| r.summary);
        progress.done(&match &outcome {
            Ok(s) => format!("{what}: {:.3} ms/frame (mean c_total)", s.c_total_ms.mean),
            Err(e) => format!("{what}: {e}"),
        });
        runs.push(Run { experiment, bodies, speed, method, pool, reference, outcome });
    }
    progress.finish();

    write_csv(&runs, &out_dir.join("experiments.csv"))?;
    let figures = draw_figures(&runs, &plan, &out_dir)?;
    let section = markdown_section(&runs, &plan, &out_dir, &markdown_path, &figures, &info);
    markdown::write_section(&markdown_path, MARKERS, &section)?;
    crate::common::print(&format!(
        "{section}\nwrote {}, {} and its plots\n",
        markdown_path.display(),
        out_dir.display()
    ))
}

fn of(runs: &[Run], experiment: Experiment) -> impl Iterator<Item = &Run> {
    runs.iter().filter(move |r| r.experiment == experiment)
}

/// Least-squares slope of log(y) against log(x): the exponent of y ~ x^slope.
fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> =
        points.iter().filter(|p| p.0 > 0.0 && p.1 > 0.0).map(|p| (p.0.ln(), p.1.ln())).collect();
    if logs.len() < 2 {
        return None;
    }
    let n = logs.len() as f64;
    let (mx, my) = (logs.iter().map(|p| p.0).sum::<f64>() / n, logs.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Points (x, y) of one method's successful runs in an experiment.
fn points(
    runs: &[Run],
    experiment: Experiment,
    method: &str,
    x: fn(&Run) -> f64,
    y: fn(&Summary) -> f64,
) -> Vec<(f64, f64)> {
    of(runs, experiment).filter(|r| r.method == method).filter_map(|r| r.summary().map(|s| (x(r), y(s)))).collect()
}

/// The plots, as (file name, title) pairs for the markdown.
fn draw_figures(runs: &[Run], plan: &Plan, out_dir: &Path) -> CliResult<Vec<(String, String)>> {
    let mut figures = Vec::new();
    let mut figure = |file: &str, title: String| -> PathBuf {
        figures.push((file.to_string(), title));
        out_dir.join(file)
    };
    let speed_of = |r: &Run| r.speed;
    let n_of = |r: &Run| r.bodies as f64;

    // 1. Contacts found and missed against speed.
    let accuracy = |method: &str, y: fn(&Summary) -> f64| points(runs, Experiment::Accuracy, method, speed_of, y);
    let mut series = vec![Series::new(
        "contacts (brute force)",
        accuracy("auto", |s| {
            s.accuracy.as_ref().map_or(0.0, |a| a.reference_pairs as f64) / s.frames_completed.max(1) as f64
        }),
    )];
    for method in ["auto", "vadop", "discrete"] {
        series.push(Series::new(&format!("found by {method}"), accuracy(method, |s| s.pairs_per_frame())));
    }
    for method in ["discrete", "auto", "vadop"] {
        let missed = accuracy(method, |s| {
            s.accuracy.as_ref().map_or(0.0, |a| a.missed as f64) / s.frames_completed.max(1) as f64
        });
        series.push(Series::new(&format!("missed by {method}"), missed));
    }
    let title = format!("Pair contacts per frame vs speed (n = {}, detect mode)", plan.bodies);
    plots::line_chart(
        &figure("1-contacts-vs-speed.png", title.clone()),
        &title,
        "max speed (diameters/frame)",
        "pair contacts per frame",
        series,
    )?;

    // 2. Time against n.
    let series: Vec<Series> = METHODS
        .iter()
        .map(|&m| {
            let p = points(runs, Experiment::Bodies, m, n_of, |s| s.c_total_ms.mean);
            let slope = log_log_slope(&p).map_or(String::new(), |k| format!(" (slope {k:.2})"));
            Series::new(&format!("{m}{slope}"), p)
        })
        .collect();
    let title = "Mean ms per frame vs n (speed 0.5 diameters/frame)".to_string();
    plots::line_chart(
        &figure("2-time-vs-n.png", title.clone()),
        &title,
        "bodies n",
        "ms per frame (mean c_total)",
        series,
    )?;

    // 3. Time against speed.
    let series: Vec<Series> = METHODS
        .iter()
        .map(|&m| Series::new(m, points(runs, Experiment::Speed, m, speed_of, |s| s.c_total_ms.mean)))
        .collect();
    let title = format!("Mean ms per frame vs speed (n = {})", plan.bodies);
    plots::line_chart(
        &figure("3-time-vs-speed.png", title.clone()),
        &title,
        "max speed (diameters/frame)",
        "ms per frame (mean c_total)",
        series,
    )?;

    // 4. Time against pool size, one line per speed, the automatic choice as its own series.
    let mut series = Vec::new();
    let mut auto_points = Vec::new();
    for &speed in &plan.pool_speeds {
        let at: Vec<&Run> = of(runs, Experiment::Pool).filter(|r| r.speed == speed).collect();
        series.push(Series::new(
            &format!("speed {speed}"),
            at.iter().filter_map(|r| Some((r.pool? as f64, r.mean_ms()?))).collect(),
        ));
        auto_points.extend(
            at.iter()
                .filter(|r| r.pool.is_none())
                .filter_map(|r| Some((r.summary()?.pool.as_ref()?.axes as f64, r.mean_ms()?))),
        );
    }
    series.push(Series::markers("automatic choice", auto_points));
    let title = format!("vadop: mean ms per frame vs pool size (n = {})", plan.bodies);
    plots::line_chart(
        &figure("4-time-vs-pool.png", title.clone()),
        &title,
        "pool axes m",
        "ms per frame (mean c_total)",
        series,
    )?;

    // 5. Cost split per method at speed 0.5; brute force would dwarf every other bar.
    let split: Vec<(String, Vec<f64>)> = of(runs, Experiment::Speed)
        .filter(|r| r.speed == 0.5 && r.method != "brute")
        .filter_map(|r| {
            let s = r.summary()?;
            let c = &s.cost_split;
            Some((s.run.method.clone(), vec![c.update_ms, c.sort_ms, c.test_ms, c.response_ms]))
        })
        .collect();
    let title = format!("Cost split per frame, brute force left out (n = {}, speed 0.5)", plan.bodies);
    plots::stacked_bars(
        &figure("5-cost-split.png", title.clone()),
        &title,
        "ms per frame (mean)",
        &["c_update", "c_sort", "c_test", "c_response"],
        &split,
    )?;

    // 6. Endpoint swaps against speed, for the methods that keep sorted lists.
    let series: Vec<Series> = ["vadop", "swept-aabb", "swept-kdop", "discrete"]
        .iter()
        .map(|&m| Series::new(m, points(runs, Experiment::Speed, m, speed_of, |s| s.per_frame.endpoint_swaps.max(0.5))))
        .collect();
    let title = format!("Insertion-sort moves per frame vs speed (n = {})", plan.bodies);
    plots::line_chart(
        &figure("6-swaps-vs-speed.png", title.clone()),
        &title,
        "max speed (diameters/frame)",
        "endpoint moves per frame",
        series,
    )?;

    // 7. Peak memory against n.
    let series: Vec<Series> = METHODS
        .iter()
        .map(|&m| Series::new(m, points(runs, Experiment::Bodies, m, n_of, |s| s.peak_memory_mib.unwrap_or(0.0))))
        .collect();
    let title = "Peak memory vs n (whole process, speed 0.5)".to_string();
    plots::line_chart(
        &figure("7-memory-vs-n.png", title.clone()),
        &title,
        "bodies n",
        "peak resident memory (MiB)",
        series,
    )?;
    Ok(figures)
}

fn write_csv(runs: &[Run], path: &Path) -> CliResult<()> {
    let mut text = String::from(
        "experiment,n,speed,method,pool,chosen_pool,reference,status,mean_ms,update_ms,sort_ms,test_ms,response_ms,\
         endpoint_swaps,candidate_pairs,pair_contacts_per_frame,reference_pairs,missed,extra,peak_mib\n",
    );
    for r in runs {
        let s = r.summary();
        let a = s.and_then(|s| s.accuracy.as_ref());
        let status = match &r.outcome {
            Ok(_) => "ok".to_string(),
            Err(e) => e.replace(',', ";"),
        };
        let _ = writeln!(
            text,
            "{},{},{},{},{},{},{},{status},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.experiment.name(),
            r.bodies,
            r.speed,
            r.method,
            r.pool.map_or("auto".to_string(), |m| m.to_string()),
            csv_number(s.and_then(|s| s.pool.as_ref()).map(|p| p.axes as f64)),
            r.reference,
            csv_number(r.mean_ms()),
            csv_number(s.map(|s| s.cost_split.update_ms)),
            csv_number(s.map(|s| s.cost_split.sort_ms)),
            csv_number(s.map(|s| s.cost_split.test_ms)),
            csv_number(s.map(|s| s.cost_split.response_ms)),
            csv_number(s.map(|s| s.per_frame.endpoint_swaps)),
            csv_number(s.map(|s| s.per_frame.candidate_pairs)),
            csv_number(s.map(|s| s.contacts.pairs as f64 / s.frames_completed.max(1) as f64)),
            csv_number(a.map(|a| a.reference_pairs as f64)),
            csv_number(a.map(|a| a.missed as f64)),
            csv_number(a.map(|a| a.extra as f64)),
            csv_number(s.and_then(|s| s.peak_memory_mib)),
        );
    }
    write_file(path, &text)
}

fn cell(r: Option<&Run>) -> String {
    match r.map(|r| &r.outcome) {
        None => "—".to_string(),
        Some(Ok(s)) => format!("{:.2}", s.c_total_ms.mean),
        Some(Err(e)) => table_cell(e),
    }
}

fn markdown_section(
    runs: &[Run],
    plan: &Plan,
    out_dir: &Path,
    markdown: &Path,
    figures: &[(String, String)],
    info: &RunInfo,
) -> String {
    let mut md = String::new();
    // Figures are linked relative to the markdown file.
    let link = |file: &str| markdown::link(markdown, &out_dir.join(file));
    let _ = writeln!(md, "## The paper's experiments\n\n{}", info.header());
    let _ = writeln!(
        md,
        "Paper scene (packing 0.05, seed 1) in detect mode. auto is the default method (it picks a broad phase), \
         vadop the paper's velocity-aligned sweep and prune, grid the hierarchical grid over pieces of swept paths. \
         Times are means over frames of c_total = c_update + c_sort + c_test + c_response: the continuous methods \
         rebuild their broad phase once per window of several frames, so they run enough frames to cover four \
         windows (at least {} frames); discrete and brute force run {} frames. CSV: `{}`.\n",
        plan.frames,
        plan.frames,
        link("experiments.csv")
    );

    let _ = writeln!(md, "### 1. Contacts found and missed vs speed (n = {})\n", plan.bodies);
    let _ = writeln!(md, "| speed | brute-force pair contacts | auto found | auto missed | vadop found | vadop missed | discrete found | discrete missed | discrete missed % |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for &speed in &plan.accuracy_speeds {
        let find = |m: &str| {
            of(runs, Experiment::Accuracy).find(|r| r.speed == speed && r.method == m).and_then(|r| r.summary())
        };
        let (a, v, d) = (find("auto"), find("vadop"), find("discrete"));
        let reference = a.or(v).or(d).and_then(|s| s.accuracy.as_ref()).map(|a| a.reference_pairs);
        let missed = |s: Option<&Summary>| {
            s.and_then(|s| s.accuracy.as_ref()).map_or("—".to_string(), |a| a.missed.to_string())
        };
        let found = |s: Option<&Summary>| s.map_or("—".to_string(), |s| s.contacts.pairs.to_string());
        let percent = d
            .and_then(|s| s.accuracy.as_ref())
            .filter(|a| a.reference_pairs > 0)
            .map_or("—".to_string(), |a| format!("{:.1}", 100.0 * a.missed as f64 / a.reference_pairs as f64));
        let _ = writeln!(
            md,
            "| {speed} | {} | {} | {} | {} | {} | {} | {} | {percent} |",
            reference.map_or("—".to_string(), |r| r.to_string()),
            found(a),
            missed(a),
            found(v),
            missed(v),
            found(d),
            missed(d)
        );
    }

    let _ = writeln!(md, "\n### 2. Mean ms per frame vs n (speed 0.5) and fitted log-log slope\n");
    let _ = write!(md, "| method |");
    for n in &plan.body_counts {
        let _ = write!(md, " n = {n} |");
    }
    let _ = writeln!(md, " slope | peak MiB at largest n |");
    let _ = writeln!(md, "|---|{}---:|---:|", "---:|".repeat(plan.body_counts.len()));
    for method in METHODS {
        let _ = write!(md, "| {method} |");
        for &n in &plan.body_counts {
            let _ =
                write!(md, " {} |", cell(of(runs, Experiment::Bodies).find(|r| r.bodies == n && r.method == method)));
        }
        let p = points(runs, Experiment::Bodies, method, |r| r.bodies as f64, |s| s.c_total_ms.mean);
        let peak = of(runs, Experiment::Bodies)
            .filter(|r| r.method == method)
            .filter_map(|r| r.summary()?.peak_memory_mib)
            .last();
        let _ = writeln!(
            md,
            " {} | {} |",
            log_log_slope(&p).map_or("—".to_string(), |k| format!("{k:.2}")),
            peak.map_or("—".to_string(), |m| format!("{m:.0}"))
        );
    }

    let _ = writeln!(md, "\n### 3. Mean ms per frame vs speed (n = {}), and auto's ratio to each\n", plan.bodies);
    let _ = write!(md, "| method |");
    for s in &plan.speeds {
        let _ = write!(md, " speed {s} |");
    }
    let _ = writeln!(md);
    let _ = writeln!(md, "|---|{}", "---:|".repeat(plan.speeds.len()));
    for method in METHODS {
        let _ = write!(md, "| {method} |");
        for &speed in &plan.speeds {
            let find = |m: &str| of(runs, Experiment::Speed).find(|r| r.speed == speed && r.method == m);
            let ratio = match (find("auto").and_then(Run::mean_ms), find(method).and_then(Run::mean_ms)) {
                (Some(a), Some(o)) if method != "auto" => format!(" (auto ÷ = {:.2})", a / o),
                _ => String::new(),
            };
            let _ = write!(md, " {}{ratio} |", cell(find(method)));
        }
        let _ = writeln!(md);
    }

    let _ = writeln!(md, "\n### 4. vadop: mean ms per frame vs pool size m (n = {})\n", plan.bodies);
    let _ = write!(md, "| speed |");
    for m in &plan.pools {
        let _ = write!(md, " m = {m} |");
    }
    let _ = writeln!(md, " automatic pool (chosen m) | best fixed m | automatic ÷ best |");
    let _ = writeln!(md, "|---:|{}---:|---:|---:|", "---:|".repeat(plan.pools.len()));
    for &speed in &plan.pool_speeds {
        let at: Vec<&Run> = of(runs, Experiment::Pool).filter(|r| r.speed == speed).collect();
        let _ = write!(md, "| {speed} |");
        for &m in &plan.pools {
            let _ = write!(md, " {} |", cell(at.iter().copied().find(|r| r.pool == Some(m))));
        }
        let auto = at.iter().copied().find(|r| r.pool.is_none());
        let chosen = auto.and_then(|r| r.summary()?.pool.as_ref()).map_or("?".to_string(), |p| p.axes.to_string());
        let best = at
            .iter()
            .filter(|r| r.pool.is_some())
            .filter_map(|r| Some((r.pool?, r.mean_ms()?)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        let (best_cell, ratio) = match (best, auto.and_then(Run::mean_ms)) {
            (Some((m, t)), Some(a)) => (format!("{m} ({t:.2})"), format!("{:.2}", a / t)),
            (Some((m, t)), None) => (format!("{m} ({t:.2})"), "—".to_string()),
            _ => ("—".to_string(), "—".to_string()),
        };
        let _ = writeln!(md, " {} ({chosen}) | {best_cell} | {ratio} |", cell(auto));
    }

    let _ =
        writeln!(md, "\n### 5–6. Cost split (ms per frame, mean) and sort work at speed 0.5 (n = {})\n", plan.bodies);
    let _ = writeln!(
        md,
        "| method | c_update | c_sort | c_test | c_response | endpoint moves/frame | candidate pairs/frame |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|");
    for r in of(runs, Experiment::Speed).filter(|r| r.speed == 0.5) {
        if let Some(s) = r.summary() {
            let c = &s.cost_split;
            let _ = writeln!(
                md,
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} | {:.0} |",
                s.run.method,
                c.update_ms,
                c.sort_ms,
                c.test_ms,
                c.response_ms,
                s.per_frame.endpoint_swaps,
                s.per_frame.candidate_pairs
            );
        }
    }
    let _ = writeln!(md, "\n### 7. Simulate mode (full response; paths differ between methods, so no miss counts): mean ms per frame (n = {})\n", plan.bodies);
    let _ = writeln!(
        md,
        "| method | {} |",
        plan.simulate_speeds.iter().map(|s| format!("speed {s} | pair contacts/frame")).collect::<Vec<_>>().join(" | ")
    );
    let _ = writeln!(md, "|---|{}", "---:|---:|".repeat(plan.simulate_speeds.len()));
    for method in METHODS {
        let _ = write!(md, "| {method} |");
        for &speed in &plan.simulate_speeds {
            let run = of(runs, Experiment::Simulate).find(|r| r.speed == speed && r.method == method);
            let pairs = run.and_then(Run::summary).map_or("—".to_string(), |s| format!("{:.0}", s.pairs_per_frame()));
            let _ = write!(md, " {} | {pairs} |", cell(run));
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(md, "\n### Plots\n");
    for (file, title) in figures {
        let _ = writeln!(md, "![{title}]({})\n", link(file));
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law() {
        let points: Vec<(f64, f64)> = [1.0, 10.0, 100.0].iter().map(|&x| (x, 3.0 * x * x)).collect();
        assert!((log_log_slope(&points).unwrap() - 2.0).abs() < 1e-12);
        assert_eq!(log_log_slope(&[(1.0, 1.0)]), None);
    }
}
