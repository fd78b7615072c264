//! `vadop-bench speed`: where the time goes at scale, in sections, each a table between its
//! own markers in the markdown file with its CSV and plot in results/speed/:
//! detect-mode ms/frame of the default method against grid, vadop, the old engine's grid and the
//! peers ([`detect`]); narrow tests against the pairs whose swept boxes overlap ([`candidates`]);
//! the cost of a velocity change ([`retest`]); simulate-mode collisions per second and their
//! independence of the frame length ([`throughput`]); memory per body ([`memory`]); where
//! each broad phase wins ([`methods`]); all cores against one ([`cores`]); what gravity
//! costs ([`gravity`]); the periodic gas's pressure against its equation of state
//! ([`periodic`]); a granular pile settling under gravity ([`pile`]); and simulate mode's event
//! loop on the periodic gas: one core at every size and packing, frames of every length, every core,
//! the energy over 10^7 collisions ([`event_loop`]).
//!
//! Every run is a child pinned to one core, but the all-cores runs; timed runs are repeated and the tables show the
//! median of the repeats; ratios compare runs of this same command. Times are means over frames
//! of enough frames to cover several broad-phase windows, since a frame that starts a window pays
//! for the whole window. This module owns the plan, the shared measurement cache (a run that two
//! sections need is made once) and the writing of sections; each section module owns its runs,
//! table, CSV and plot.

pub mod candidates;
mod cores;
mod detect;
mod event_loop;
mod gravity;
mod memory;
mod methods;
mod periodic;
mod pile;
pub mod retest;
mod throughput;

use crate::common::{median, write_file, Common};
use crate::markdown::{self, Markers, RunInfo};
use crate::progress::Progress;
use crate::runner::{Runner, Simulation};
use crate::summary::Report;
use crate::CliResult;
use clap::{Args, ValueEnum};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

#[derive(Debug, Args)]
#[command(after_help = "Sizes: detect at n = 10^4, 10^5 and 10^6 x max speeds 0.05, 0.5 and 5 diameters per frame \
(candidates up to 10^5), retest at n = 10^5 with 10,000 calls, throughput at n = 10^4 and 10^5, memory at n = 10^4 to \
10^6, methods at n = 10^4 and 10^5, cores at the detect and throughput sizes on one thread and on every core \
and at n = 10^7 on every core, gravity at n = 10^4 and 10^5, the periodic gas at n = 10^5 (3 x 10^7 collisions measured at each of \
three packings), the granular pile at n = 10^4 over 300 frames, the event loop on the periodic gas at n = 10^4 to 10^6 (3 x 10^6 collisions a run, 10^7 for the energy); with --quick every section at n = 10^4 only (the pile at 2,000), with fewer frames and calls and one \
run each (a minute or two). Frames cover several broad-phase windows. --timeout defaults to 900 s per child run. The \
full suite takes hours: run it on a quiet machine.")]
pub struct SpeedArgs {
    /// Sections to run, comma-separated [default: all, in this order]
    #[arg(long, value_enum, value_delimiter = ',')]
    sections: Option<Vec<Section>>,
    /// Runs of each timed measurement; tables show their median [default: 3; with --quick: 1]
    #[arg(long, value_name = "R", value_parser = clap::value_parser!(u64).range(1..))]
    repeats: Option<u64>,
    /// The old engine's `vadop` (commit d35de4a), as scripts/build-baseline.sh builds it
    #[arg(long, value_name = "FILE", default_value = "target/baseline/vadop-d35de4a")]
    baseline: PathBuf,
    /// The peers' CSV from which the fastest exact and discrete peer of each cell are read
    #[arg(long, value_name = "FILE", default_value = "results/peers/peers.csv")]
    peers_csv: PathBuf,
    #[command(flatten)]
    common: Common,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Section {
    Detect,
    Candidates,
    Retest,
    Throughput,
    Memory,
    Methods,
    Cores,
    Gravity,
    Periodic,
    EventLoop,
    Pile,
}

/// The sizes of every section.
struct Plan {
    quick: bool,
    /// Body counts of the detect section; candidates uses those up to 10^5.
    detect_bodies: Vec<usize>,
    /// Maximum speeds of the paper scene, in diameters per frame.
    speeds: Vec<f64>,
    retest_bodies: usize,
    retest_calls: usize,
    throughput_bodies: Vec<usize>,
    /// Body counts of the gas rows of the cores section.
    cores_gas_bodies: Vec<usize>,
    /// Body counts of the shapes rows of the cores section.
    cores_shapes_bodies: Vec<usize>,
    packings: Vec<f64>,
    /// Travel per frame in rms diameters, for the frame-length sweep.
    travels: Vec<f64>,
    /// Simulated time of a throughput run, in rms diameters of travel: warm-up, then measured.
    warm_up_travel: f64,
    measured_travel: f64,
    memory_bodies: Vec<usize>,
    methods_bodies: Vec<usize>,
    /// Body counts run only on every core, at the lowest speed.
    huge_bodies: Vec<usize>,
    /// Body counts of the gravity section.
    gravity_bodies: Vec<usize>,
    /// The periodic gas's bodies, and the pair collisions measured at each packing.
    periodic_bodies: usize,
    periodic_collisions: f64,
    /// The event-loop section: body counts of its one-core table, of its frame-length sweep and
    /// energy run, of its all-cores table; pair collisions measured per run and in the energy run.
    loop_bodies: Vec<usize>,
    loop_sweep_bodies: usize,
    loop_threads_bodies: Vec<usize>,
    loop_pairs: f64,
    drift_pairs: f64,
    /// Body counts of the granular pile, and the frames each runs (it forms and settles).
    pile_bodies: Vec<usize>,
    pile_frames: u64,
}

impl Plan {
    fn new(quick: bool) -> Plan {
        if quick {
            Plan {
                quick,
                detect_bodies: vec![10_000],
                speeds: vec![0.05, 0.5, 5.0],
                retest_bodies: 10_000,
                retest_calls: 2000,
                throughput_bodies: vec![10_000],
                cores_gas_bodies: vec![10_000],
                cores_shapes_bodies: vec![1_000],
                packings: vec![0.05, 0.2, 0.4],
                travels: vec![0.05, 0.2, 1.0, 5.0],
                warm_up_travel: 1.0,
                measured_travel: 3.0,
                memory_bodies: vec![10_000],
                methods_bodies: vec![10_000],
                huge_bodies: vec![],
                gravity_bodies: vec![10_000],
                periodic_bodies: 10_000,
                periodic_collisions: 1e6,
                loop_bodies: vec![10_000],
                loop_sweep_bodies: 10_000,
                loop_threads_bodies: vec![10_000],
                loop_pairs: 2e5,
                drift_pairs: 1e6,
                pile_bodies: vec![2_000],
                pile_frames: 150,
            }
        } else {
            Plan {
                quick,
                detect_bodies: vec![10_000, 100_000, 1_000_000],
                speeds: vec![0.05, 0.5, 5.0],
                retest_bodies: 100_000,
                retest_calls: 10_000,
                throughput_bodies: vec![10_000, 100_000],
                cores_gas_bodies: vec![10_000, 100_000, 1_000_000],
                cores_shapes_bodies: vec![10_000, 100_000],
                packings: vec![0.05, 0.2, 0.4],
                travels: vec![0.05, 0.2, 1.0, 5.0],
                warm_up_travel: 5.0,
                measured_travel: 20.0,
                memory_bodies: vec![10_000, 100_000, 1_000_000],
                methods_bodies: vec![10_000, 100_000],
                huge_bodies: vec![10_000_000],
                gravity_bodies: vec![10_000, 100_000],
                periodic_bodies: 100_000,
                periodic_collisions: 3e7,
                loop_bodies: vec![10_000, 100_000, 1_000_000],
                loop_sweep_bodies: 100_000,
                loop_threads_bodies: vec![100_000, 1_000_000],
                loop_pairs: 3e6,
                drift_pairs: 1e7,
                pile_bodies: vec![10_000],
                pile_frames: 300,
            }
        }
    }
}

/// What every section works with.
struct Context {
    runner: Runner,
    plan: Plan,
    repeats: u64,
    info: RunInfo,
    markdown: PathBuf,
    results: PathBuf,
    /// Runs made so far, by program and arguments: each is made (and repeated) once.
    made: RefCell<HashMap<String, Rc<Timed>>>,
}

/// The memo key of `program` running `run`, and how the progress line names it.
fn describe(program: &Path, run: &Simulation) -> (String, String) {
    let binary = program.file_name().map_or(String::new(), |name| name.to_string_lossy().into_owned());
    let threads = run.threads.filter(|&t| t > 1).map_or(String::new(), |t| format!(" on {t} threads"));
    let what =
        format!("{binary}: {} n={} speed={} {} {}{threads}", run.kind, run.bodies, run.speed, run.method, run.mode);
    (format!("{} {run:?}", program.display()), what)
}

/// The repeats of one timed run, or why it failed.
type Timed = Result<Vec<Report>, String>;

impl Context {
    /// `program`'s `simulate` of `run`, repeated; made once per command.
    fn time(&self, program: &Path, run: &Simulation, progress: &Progress) -> Rc<Timed> {
        let (key, what) = describe(program, run);
        if let Some(made) = self.made.borrow().get(&key) {
            progress.done(&format!("{what}: measured above"));
            return made.clone();
        }
        self.measure(program, run, progress)
    }

    /// Like [`Self::time`], but always measured now, never read from an earlier section: for a
    /// run compared with the one made right before it, since this machine drifts by 10-30%
    /// within one command (the cores section's speed-ups).
    fn measure(&self, program: &Path, run: &Simulation, progress: &Progress) -> Rc<Timed> {
        let (key, what) = describe(program, run);
        progress.start(&what);
        let mut reports = Vec::new();
        let outcome = loop {
            if reports.len() as u64 == self.repeats {
                break Ok(reports);
            }
            match self.runner.simulate(program, run) {
                Ok(report) => reports.push(report),
                Err(e) => break Err(e),
            }
        };
        progress.done(&match &outcome {
            Ok(reports) => format!("{what}: {:.3} ms/frame", median_of(reports, |r| r.summary.wall_ms.mean)),
            Err(e) => format!("{what}: {e}"),
        });
        let made = Rc::new(outcome);
        self.made.borrow_mut().insert(key, made.clone());
        made
    }

    /// This binary's `--child` job `job` with `args`, run `repeats` times; each run's JSON line.
    fn child(
        &self,
        job: &str,
        args: &[(&str, String)],
        repeats: u64,
        progress: &Progress,
    ) -> Result<Vec<serde_json::Value>, String> {
        let what = format!(
            "{job} {}",
            args.iter().map(|(f, v)| format!("{}={v}", f.trim_start_matches("--"))).collect::<Vec<_>>().join(" ")
        );
        progress.start(&what);
        let mut full = vec!["--job".to_string(), job.to_string()];
        full.extend(args.iter().flat_map(|(flag, value)| [flag.to_string(), value.clone()]));
        let outcome = (0..repeats)
            .map(|_| {
                let stdout = self.runner.child(&full, self.runner.timeout)?;
                let line = stdout.lines().rev().find(|l| l.starts_with('{')).ok_or("printed no result")?;
                serde_json::from_str(line).map_err(|e| format!("bad result: {e}"))
            })
            .collect::<Result<Vec<serde_json::Value>, String>>();
        progress.done(&match &outcome {
            Ok(values) => format!("{what}: {}", values.last().map_or(String::new(), |v| v.to_string())),
            Err(e) => format!("{what}: {e}"),
        });
        outcome
    }

    /// Writes a section (`title`, then the run's header, then `body`) and its CSV.
    fn write(&self, markers: Markers, title: &str, body: &str, csv: &str, csv_text: &str) -> CliResult<()> {
        write_file(&self.results.join(csv), csv_text)?;
        markdown::write_section(&self.markdown, markers, &format!("### {title}\n\n{}\n{body}", self.info.header()))
    }

    /// Where a plot goes, and its link from the markdown file.
    fn plot(&self, file: &str) -> (PathBuf, String) {
        let path = self.results.join(file);
        let link = markdown::link(&self.markdown, &path);
        (path, link)
    }
}

/// The median over repeats of `value`.
fn median_of(reports: &[Report], value: impl Fn(&Report) -> f64) -> f64 {
    median(&reports.iter().map(value).collect::<Vec<_>>()).unwrap_or(f64::NAN)
}

/// A timed run's median over repeats of its mean wall-clock ms per frame.
fn mean_ms(timed: &Timed) -> Option<f64> {
    timed.as_ref().ok().map(|reports| median_of(reports, |r| r.summary.wall_ms.mean))
}

/// A number for a table cell, `—` when unknown.
fn cell(value: Option<f64>, decimals: usize) -> String {
    value.filter(|v| v.is_finite()).map_or("—".to_string(), |v| format!("{v:.decimals$}"))
}

/// A timed run's first repeat, for what does not vary between repeats (counts, methods).
fn first(timed: &Timed) -> Option<&Report> {
    timed.as_ref().ok()?.first()
}

/// A timed run's mean ms/frame as a table cell, or its failure.
fn ms_cell(timed: &Timed) -> String {
    match timed {
        Ok(_) => cell(mean_ms(timed), 3),
        Err(e) => markdown::table_cell(e),
    }
}

/// `a / b` when both are known.
fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    Some(a? / b?)
}

pub fn run(args: &SpeedArgs) -> CliResult<()> {
    let common = &args.common;
    let runner = Runner::new(common, common.timeout(900.0)?)?;
    runner.product()?;
    let results = common.results()?.join("speed");
    crate::common::create_dir(&results)?;
    let sections = args.sections.clone().unwrap_or_else(|| Section::value_variants().to_vec());
    let markdown_path = common.markdown();
    for section in &sections {
        markdown::check(&markdown_path, section.markers())?;
    }
    let info = RunInfo::start(runner.cpu());
    let context = Context {
        plan: Plan::new(common.quick),
        repeats: args.repeats.unwrap_or(if common.quick { 1 } else { 3 }),
        runner,
        info,
        markdown: markdown_path,
        results,
        made: RefCell::new(HashMap::new()),
    };
    for section in sections {
        match section {
            Section::Detect => detect::run(&context, &args.baseline, &args.peers_csv)?,
            Section::Candidates => candidates::run(&context)?,
            Section::Retest => retest::run(&context)?,
            Section::Throughput => throughput::run(&context)?,
            Section::Memory => memory::run(&context)?,
            Section::Methods => methods::run(&context)?,
            Section::Cores => cores::run(&context)?,
            Section::Gravity => gravity::run(&context)?,
            Section::Periodic => periodic::run(&context)?,
            Section::EventLoop => event_loop::run(&context)?,
            Section::Pile => pile::run(&context)?,
        }
    }
    crate::common::print(&format!("wrote {} and {}\n", context.markdown.display(), context.results.display()))
}

impl Section {
    fn markers(self) -> Markers {
        Markers {
            name: match self {
                Section::Detect => "speed-detect",
                Section::Candidates => "speed-candidates",
                Section::Retest => "speed-retest",
                Section::Throughput => "speed-throughput",
                Section::Memory => "speed-memory",
                Section::Methods => "speed-methods",
                Section::Cores => "speed-cores",
                Section::Gravity => "speed-gravity",
                Section::Periodic => "speed-periodic",
                Section::EventLoop => "speed-event-loop",
                Section::Pile => "speed-pile",
            },
        }
    }
}
