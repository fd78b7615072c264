//! The paper's experiments, reproduced and extended (`vadop bench --suite experiments`): contacts
//! found and missed against speed, time against n, speed and pool size per method, the cost split,
//! endpoint swaps and peak memory. Every run is a detect-mode child of this binary (identical
//! paths for every method, each child's peak memory its own), all launched by one command so the
//! ratios compare runs on the same machine at the same time. It owns the experiment plans, the
//! CSV per experiment, the plots and the markdown section; it never touches the markdown file
//! outside its markers, and a failed or timed-out child becomes a row saying so.

use crate::bench::{child_args, machine, merge_marked_section, read_markdown, run_child, table_cell, utc_now};
use crate::plots::{self, Series};
use crate::report::{self, Summary};
use crate::CliResult;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const BEGIN: &str = "<!-- experiments:begin -->";
const END: &str = "<!-- experiments:end -->";

/// Methods compared in the time experiments, in legend order.
const METHODS: [&str; 6] = ["vadop", "swept-aabb", "swept-kdop", "grid", "discrete", "brute"];

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
    fn median_ms(&self) -> Option<f64> {
        self.summary().map(|s| s.c_total_ms.median)
    }
    fn label(&self) -> String {
        match (self.method, self.pool) {
            ("vadop", None) => "vadop (auto)".to_string(),
            (method, Some(m)) => format!("{method} m={m}"),
            (method, None) => method.to_string(),
        }
    }
}

/// One run to make: experiment, n, speed, method, pool (`None`: automatic), reference.
type PlannedRun = (Experiment, usize, f64, &'static str, Option<usize>, &'static str);

/// The sizes of the experiments.
pub struct Plan {
    bodies: usize,
    frames: u64,
    accuracy_speeds: Vec<f64>,
    speeds: Vec<f64>,
    body_counts: Vec<usize>,
    pool_speeds: Vec<f64>,
    pools: Vec<usize>,
    simulate_speeds: Vec<f64>,
    /// Largest n brute force runs at in the time experiments.
    brute_max: usize,
    timeout: Duration,
}

impl Plan {
    /// The full plan, or the quick one that finishes in about a minute.
    pub fn new(quick: bool, timeout: Duration) -> Plan {
        if quick {
            Plan {
                bodies: 1000,
                frames: 5,
                accuracy_speeds: vec![0.05, 0.5, 5.0],
                speeds: vec![0.05, 0.5, 5.0],
                body_counts: vec![250, 500, 1000, 2000],
                pool_speeds: vec![0.05, 0.5, 5.0],
                pools: vec![3, 7, 13, 32],
                simulate_speeds: vec![0.5],
                brute_max: 2000,
                timeout,
            }
        } else {
            Plan {
                bodies: 10_000,
                frames: 10,
                accuracy_speeds: vec![0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0],
                speeds: vec![0.05, 0.2, 0.5, 2.0, 5.0],
                body_counts: vec![1000, 3000, 10_000, 30_000, 100_000],
                pool_speeds: vec![0.05, 0.5, 5.0],
                pools: vec![3, 7, 13, 32, 65, 200, 1000, 39_000],
                simulate_speeds: vec![0.5, 5.0],
                brute_max: 10_000,
                timeout,
            }
        }
    }

    /// Every run of every experiment.
    fn runs(&self) -> Vec<PlannedRun> {
        let mut runs = Vec::new();
        for &speed in &self.accuracy_speeds {
            for method in ["vadop", "discrete"] {
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

/// Runs the experiments, writes `out_dir`/*.csv and *.png and the markdown section.
pub fn run(plan: &Plan, markdown: &Path, out_dir: &Path) -> CliResult<()> {
    let exe = std::env::current_exe().map_err(|e| format!("cannot find this program's own path: {e}"))?;
    let existing = read_markdown(markdown)?;
    std::fs::create_dir_all(out_dir).map_err(|e| report::io_error(out_dir, e))?;
    let planned = plan.runs();
    let bar = report::progress_bar(planned.len() as u64, "runs");
    report::reveal(&bar);
    let scratch = std::env::temp_dir().join(format!("vadop-experiments-{}", std::process::id()));
    let started = Instant::now();
    let mut runs = Vec::new();
    for (experiment, bodies, speed, method, pool, reference) in planned {
        let label = pool.map_or(String::new(), |m| format!(" m={m}"));
        bar.set_message(format!("{}: n={bodies} speed={speed} {method}{label}", experiment.name()));
        let mut args = child_args(bodies, speed, plan.frames, method, experiment.mode(), reference, &scratch);
        if let Some(m) = pool {
            args.extend(["--pool".to_string(), m.to_string()]);
        }
        let outcome = run_child(&exe, &args, &scratch, plan.timeout);
        bar.inc(1);
        runs.push(Run { experiment, bodies, speed, method, pool, reference, outcome });
    }
    bar.finish_and_clear();
    let elapsed = started.elapsed();

    write_csv(&runs, &out_dir.join("experiments.csv"))?;
    let figures = draw_figures(&runs, plan, out_dir)?;
    let section = markdown_section(&runs, plan, out_dir, markdown, &figures, elapsed);
    let merged = merge_marked_section(existing.as_deref(), &section, markdown, BEGIN, END)?;
    std::fs::write(markdown, merged).map_err(|e| report::io_error(markdown, e))?;
    report::print(&format!("{section}\nwrote {}, {} and its plots\n", markdown.display(), out_dir.display()))
}

fn of(runs: &[Run], experiment: Experiment) -> impl Iterator<Item = &Run> {
    runs.iter().filter(move |r| r.experiment == experiment)
}

/// Least-squares slope of log(y) against log(x): the exponent of y ~ x^slope.
fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points.iter().filter(|p| p.0 > 0.0 && p.1 > 0.0).map(|p| (p.0.ln(), p.1.ln())).collect();
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
fn points(runs: &[Run], experiment: Experiment, method: &str, x: fn(&Run) -> f64, y: fn(&Summary) -> f64) -> Vec<(f64, f64)> {
    of(runs, experiment)
        .filter(|r| r.method == method)
        .filter_map(|r| r.summary().map(|s| (x(r), y(s))))
        .collect()
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
    let series = vec![
        Series::new("contacts (brute force)", accuracy("vadop", |s| s.accuracy.as_ref().map_or(0.0, |a| a.reference_pairs as f64) / s.frames_completed.max(1) as f64)),
        Series::new("found by vadop", accuracy("vadop", |s| s.contacts.pairs as f64 / s.frames_completed.max(1) as f64)),
        Series::new("found by discrete", accuracy("discrete", |s| s.contacts.pairs as f64 / s.frames_completed.max(1) as f64)),
        Series::new("missed by discrete", accuracy("discrete", |s| s.accuracy.as_ref().map_or(0.0, |a| a.missed as f64) / s.frames_completed.max(1) as f64)),
        Series::new("missed by vadop", accuracy("vadop", |s| s.accuracy.as_ref().map_or(0.0, |a| a.missed as f64) / s.frames_completed.max(1) as f64)),
    ];
    let title = format!("Pair contacts per frame vs speed (n = {}, detect mode)", plan.bodies);
    plots::line_chart(&figure("1-contacts-vs-speed.png", title.clone()), &title, "max speed (diameters/frame)", "pair contacts per frame", &series)?;

    // 2. Time against n.
    let series: Vec<Series> = METHODS
        .iter()
        .map(|&m| {
            let p = points(runs, Experiment::Bodies, m, n_of, |s| s.c_total_ms.median);
            let slope = log_log_slope(&p).map_or(String::new(), |k| format!(" (slope {k:.2})"));
            Series::new(&format!("{m}{slope}"), p)
        })
        .collect();
    let title = "Median ms per frame vs n (speed 0.5 diameters/frame)".to_string();
    plots::line_chart(&figure("2-time-vs-n.png", title.clone()), &title, "bodies n", "ms per frame (median c_total)", &series)?;

    // 3. Time against speed.
    let series: Vec<Series> = METHODS.iter().map(|&m| Series::new(m, points(runs, Experiment::Speed, m, speed_of, |s| s.c_total_ms.median))).collect();
    let title = format!("Median ms per frame vs speed (n = {})", plan.bodies);
    plots::line_chart(&figure("3-time-vs-speed.png", title.clone()), &title, "max speed (diameters/frame)", "ms per frame (median c_total)", &series)?;

    // 4. Time against pool size, one line per speed, the automatic choice as its own series.
    let mut series = Vec::new();
    let mut auto_points = Vec::new();
    for &speed in &plan.pool_speeds {
        let at: Vec<&Run> = of(runs, Experiment::Pool).filter(|r| r.speed == speed).collect();
        series.push(Series::new(
            &format!("speed {speed}"),
            at.iter().filter_map(|r| Some((r.pool? as f64, r.median_ms()?))).collect(),
        ));
        auto_points.extend(at.iter().filter(|r| r.pool.is_none()).filter_map(|r| Some((r.summary()?.pool.as_ref()?.axes as f64, r.median_ms()?))));
    }
    series.push(Series::markers("automatic choice", auto_points));
    let title = format!("vadop: median ms per frame vs pool size (n = {})", plan.bodies);
    plots::line_chart(&figure("4-time-vs-pool.png", title.clone()), &title, "pool axes m", "ms per frame (median c_total)", &series)?;

    // 5. Cost split per method at speed 0.5; brute force would dwarf every other bar.
    let split: Vec<(String, [f64; 4])> = of(runs, Experiment::Speed)
        .filter(|r| r.speed == 0.5 && r.method != "brute")
        .filter_map(|r| {
            let c = &r.summary()?.cost_split;
            Some((r.label(), [c.update_ms, c.sort_ms, c.test_ms, c.response_ms]))
        })
        .collect();
    let title = format!("Cost split per frame, brute force left out (n = {}, speed 0.5)", plan.bodies);
    plots::stacked_bars(&figure("5-cost-split.png", title.clone()), &title, "ms per frame (mean)", &["c_update", "c_sort", "c_test", "c_response"], &split)?;

    // 6. Endpoint swaps against speed, for the methods that keep sorted lists.
    let series: Vec<Series> = ["vadop", "swept-aabb", "swept-kdop", "discrete"]
        .iter()
        .map(|&m| Series::new(m, points(runs, Experiment::Speed, m, speed_of, |s| s.per_frame.endpoint_swaps.max(0.5))))
        .collect();
    let title = format!("Insertion-sort moves per frame vs speed (n = {})", plan.bodies);
    plots::line_chart(&figure("6-swaps-vs-speed.png", title.clone()), &title, "max speed (diameters/frame)", "endpoint moves per frame", &series)?;

    // 7. Peak memory against n.
    let series: Vec<Series> = METHODS
        .iter()
        .map(|&m| Series::new(m, points(runs, Experiment::Bodies, m, n_of, |s| s.peak_memory_mib.unwrap_or(0.0))))
        .collect();
    let title = "Peak memory vs n (whole process, speed 0.5)".to_string();
    plots::line_chart(&figure("7-memory-vs-n.png", title.clone()), &title, "bodies n", "peak resident memory (MiB)", &series)?;
    Ok(figures)
}

fn write_csv(runs: &[Run], path: &Path) -> CliResult<()> {
    let mut text = String::from(
        "experiment,n,speed,method,pool,chosen_pool,reference,status,median_ms,update_ms,sort_ms,test_ms,response_ms,\
         endpoint_swaps,candidate_pairs,pair_contacts_per_frame,reference_pairs,missed,extra,peak_mib\n",
    );
    let number = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
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
            number(s.and_then(|s| s.pool.as_ref()).map(|p| p.axes as f64)),
            r.reference,
            number(r.median_ms()),
            number(s.map(|s| s.cost_split.update_ms)),
            number(s.map(|s| s.cost_split.sort_ms)),
            number(s.map(|s| s.cost_split.test_ms)),
            number(s.map(|s| s.cost_split.response_ms)),
            number(s.map(|s| s.per_frame.endpoint_swaps)),
            number(s.map(|s| s.per_frame.candidate_pairs)),
            number(s.map(|s| s.contacts.pairs as f64 / s.frames_completed.max(1) as f64)),
            number(a.map(|a| a.reference_pairs as f64)),
            number(a.map(|a| a.missed as f64)),
            number(a.map(|a| a.extra as f64)),
            number(s.and_then(|s| s.peak_memory_mib)),
        );
    }
    std::fs::write(path, text).map_err(|e| report::io_error(path, e))
}

fn cell(r: Option<&Run>) -> String {
    match r.map(|r| &r.outcome) {
        None => "—".to_string(),
        Some(Ok(s)) => format!("{:.2}", s.c_total_ms.median),
        Some(Err(e)) => table_cell(e),
    }
}

fn markdown_section(runs: &[Run], plan: &Plan, out_dir: &Path, markdown: &Path, figures: &[(String, String)], elapsed: Duration) -> String {
    let mut md = String::new();
    let command: Vec<String> = std::env::args().skip(1).collect();
    // Figures are linked relative to the markdown file.
    let base = markdown.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let link = |file: &str| {
        let full = out_dir.join(file);
        full.strip_prefix(base).unwrap_or(&full).display().to_string()
    };
    let _ = writeln!(md, "{BEGIN}");
    let _ = writeln!(md, "## The paper's experiments\n");
    let _ = writeln!(md, "Produced by `vadop {}` on {} in {:.1} minutes.  ", command.join(" "), utc_now(), elapsed.as_secs_f64() / 60.0);
    let _ = writeln!(md, "Machine: {}.  ", machine());
    let _ = writeln!(
        md,
        "Paper scene (packing 0.05, seed 1) in detect mode, {} frames per run; times are medians over frames of \
         c_total = c_update + c_sort + c_test + c_response. CSV: `{}`.\n",
        plan.frames,
        link("experiments.csv")
    );

    let _ = writeln!(md, "### 1. Contacts found and missed vs speed (n = {})\n", plan.bodies);
    let _ = writeln!(md, "| speed | brute-force pair contacts | vadop found | vadop missed | discrete found | discrete missed | discrete missed % |");
    let _ = writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|");
    for &speed in &plan.accuracy_speeds {
        let find = |m: &str| of(runs, Experiment::Accuracy).find(|r| r.speed == speed && r.method == m).and_then(|r| r.summary());
        let (v, d) = (find("vadop"), find("discrete"));
        let reference = v.or(d).and_then(|s| s.accuracy.as_ref()).map(|a| a.reference_pairs);
        let missed = |s: Option<&Summary>| s.and_then(|s| s.accuracy.as_ref()).map_or("—".to_string(), |a| a.missed.to_string());
        let found = |s: Option<&Summary>| s.map_or("—".to_string(), |s| s.contacts.pairs.to_string());
        let percent = d
            .and_then(|s| s.accuracy.as_ref())
            .filter(|a| a.reference_pairs > 0)
            .map_or("—".to_string(), |a| format!("{:.1}", 100.0 * a.missed as f64 / a.reference_pairs as f64));
        let _ = writeln!(
            md,
            "| {speed} | {} | {} | {} | {} | {} | {percent} |",
            reference.map_or("—".to_string(), |r| r.to_string()),
            found(v),
            missed(v),
            found(d),
            missed(d)
        );
    }

    let _ = writeln!(md, "\n### 2. Median ms per frame vs n (speed 0.5) and fitted log-log slope\n");
    let _ = write!(md, "| method |");
    for n in &plan.body_counts {
        let _ = write!(md, " n = {n} |");
    }
    let _ = writeln!(md, " slope | peak MiB at largest n |");
    let _ = writeln!(md, "|---|{}---:|---:|", "---:|".repeat(plan.body_counts.len()));
    for method in METHODS {
        let _ = write!(md, "| {method} |");
        for &n in &plan.body_counts {
            let _ = write!(md, " {} |", cell(of(runs, Experiment::Bodies).find(|r| r.bodies == n && r.method == method)));
        }
        let p = points(runs, Experiment::Bodies, method, |r| r.bodies as f64, |s| s.c_total_ms.median);
        let peak = of(runs, Experiment::Bodies).filter(|r| r.method == method).filter_map(|r| r.summary()?.peak_memory_mib).last();
        let _ = writeln!(
            md,
            " {} | {} |",
            log_log_slope(&p).map_or("—".to_string(), |k| format!("{k:.2}")),
            peak.map_or("—".to_string(), |m| format!("{m:.0}"))
        );
    }

    let _ = writeln!(md, "\n### 3. Median ms per frame vs speed (n = {}), and vadop's ratio to each\n", plan.bodies);
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
            let ratio = match (find("vadop").and_then(Run::median_ms), find(method).and_then(Run::median_ms)) {
                (Some(v), Some(o)) if method != "vadop" => format!(" (vadop ÷ = {:.2})", v / o),
                _ => String::new(),
            };
            let _ = write!(md, " {}{ratio} |", cell(find(method)));
        }
        let _ = writeln!(md);
    }

    let _ = writeln!(md, "\n### 4. vadop: median ms per frame vs pool size m (n = {})\n", plan.bodies);
    let _ = write!(md, "| speed |");
    for m in &plan.pools {
        let _ = write!(md, " m = {m} |");
    }
    let _ = writeln!(md, " auto (chosen m) | best fixed m | auto ÷ best |");
    let _ = writeln!(md, "|---:|{}---:|---:|---:|", "---:|".repeat(plan.pools.len()));
    for &speed in &plan.pool_speeds {
        let at: Vec<&Run> = of(runs, Experiment::Pool).filter(|r| r.speed == speed).collect();
        let _ = write!(md, "| {speed} |");
        for &m in &plan.pools {
            let _ = write!(md, " {} |", cell(at.iter().copied().find(|r| r.pool == Some(m))));
        }
        let auto = at.iter().copied().find(|r| r.pool.is_none());
        let chosen = auto.and_then(|r| r.summary()?.pool.as_ref()).map_or("?".to_string(), |p| p.axes.to_string());
        let best = at.iter().filter(|r| r.pool.is_some()).filter_map(|r| Some((r.pool?, r.median_ms()?))).min_by(|a, b| a.1.total_cmp(&b.1));
        let (best_cell, ratio) = match (best, auto.and_then(Run::median_ms)) {
            (Some((m, t)), Some(a)) => (format!("{m} ({t:.2})"), format!("{:.2}", a / t)),
            (Some((m, t)), None) => (format!("{m} ({t:.2})"), "—".to_string()),
            _ => ("—".to_string(), "—".to_string()),
        };
        let _ = writeln!(md, " {} ({chosen}) | {best_cell} | {ratio} |", cell(auto));
    }

    let _ = writeln!(md, "\n### 5–6. Cost split (ms per frame, mean) and sort work at speed 0.5 (n = {})\n", plan.bodies);
    let _ = writeln!(md, "| method | c_update | c_sort | c_test | c_response | endpoint moves/frame | candidate pairs/frame |");
    let _ = writeln!(md, "|---|---:|---:|---:|---:|---:|---:|");
    for r in of(runs, Experiment::Speed).filter(|r| r.speed == 0.5) {
        if let Some(s) = r.summary() {
            let c = &s.cost_split;
            let _ = writeln!(
                md,
                "| {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} | {:.0} |",
                r.method, c.update_ms, c.sort_ms, c.test_ms, c.response_ms, s.per_frame.endpoint_swaps, s.per_frame.candidate_pairs
            );
        }
    }
    let _ = writeln!(md, "\n### 7. Simulate mode (full response; paths differ between methods, so no miss counts): median ms per frame (n = {})\n", plan.bodies);
    let _ = writeln!(md, "| method | {} |", plan.simulate_speeds.iter().map(|s| format!("speed {s} | pair contacts/frame")).collect::<Vec<_>>().join(" | "));
    let _ = writeln!(md, "|---|{}", "---:|---:|".repeat(plan.simulate_speeds.len()));
    for method in METHODS {
        let _ = write!(md, "| {method} |");
        for &speed in &plan.simulate_speeds {
            let run = of(runs, Experiment::Simulate).find(|r| r.speed == speed && r.method == method);
            let pairs = run.and_then(Run::summary).map_or("—".to_string(), |s| format!("{:.0}", s.contacts.pairs as f64 / s.frames_completed.max(1) as f64));
            let _ = write!(md, " {} | {pairs} |", cell(run));
        }
        let _ = writeln!(md);
    }
    let _ = writeln!(md, "\n### Plots\n");
    for (file, title) in figures {
        let _ = writeln!(md, "![{title}]({})\n", link(file));
    }
    let _ = write!(md, "{END}");
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
