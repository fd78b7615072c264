//! Child processes: every measurement runs in its own process, pinned to one core with
//! `taskset -c <cpu>` (so runs do not migrate or share a core with each other) unless it is a
//! run on several threads, which gets the whole machine; stopped after a timeout, and reporting
//! its own peak memory. A child is either the product binary's
//! `vadop simulate ... --json` (or an older engine's, for the speed suite's baseline) or this
//! binary's hidden `--child` job. Output goes through files, never pipes, so a talkative child
//! cannot block; a child that fails or times out is an `Err` carrying its last message, which the
//! suites turn into a row that says so.

use crate::common::{create_dir, io_error, Common};
use crate::summary::Report;
use crate::CliResult;
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How often a running child is checked for exit or timeout.
const POLL: Duration = Duration::from_millis(20);

pub struct Runner {
    /// The product binary, or why it cannot be used.
    product: Result<PathBuf, String>,
    this: PathBuf,
    /// `None` when taskset is missing: runs are then not pinned, and the tables say so.
    cpu: Option<usize>,
    pub timeout: Duration,
    scratch: PathBuf,
    runs: Cell<u64>,
}

impl Runner {
    pub fn new(common: &Common, timeout: Duration) -> CliResult<Runner> {
        let this = std::env::current_exe().map_err(|e| format!("cannot find this program's own path: {e}"))?;
        let product = match &common.vadop {
            Some(path) if path.is_file() => Ok(path.clone()),
            Some(path) => Err(format!("--vadop {}: no such file", path.display())),
            None => {
                let beside = this.with_file_name("vadop");
                let rebuild = "build it with `cargo build --release -p vadop-cli` or pass --vadop FILE";
                match newer_source(&beside) {
                    _ if !beside.is_file() => Err(format!("{} not found: {rebuild}", beside.display())),
                    Some(source) => Err(format!("{} is older than {}: {rebuild}", beside.display(), source.display())),
                    None => Ok(beside),
                }
            }
        };
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let cpu = common.cpu.unwrap_or(cores - 1);
        if cpu >= cores {
            return Err(format!("--cpu {cpu}: this machine has cores 0 to {}", cores - 1));
        }
        let pinned = Command::new("taskset").arg("--version").stdout(Stdio::null()).status().is_ok();
        if !pinned {
            eprintln!("taskset not found: runs are not pinned to a core");
        }
        let scratch = std::env::temp_dir().join(format!("vadop-bench-{}", std::process::id()));
        create_dir(&scratch)?;
        Ok(Runner { product, this, cpu: pinned.then_some(cpu), timeout, scratch, runs: Cell::new(0) })
    }

    /// The product binary; an error when it was not found.
    pub fn product(&self) -> CliResult<&Path> {
        self.product.as_deref().map_err(Clone::clone)
    }

    /// The core runs are pinned to, if they are.
    pub fn cpu(&self) -> Option<usize> {
        self.cpu
    }

    /// A file name for this run's scratch output, never used twice.
    pub fn scratch_file(&self, name: &str) -> PathBuf {
        self.runs.set(self.runs.get() + 1);
        self.scratch.join(format!("{}-{name}", self.runs.get()))
    }

    /// `program`'s `simulate` (the product binary's or an older engine's) of `run`, and its JSON
    /// report.
    pub fn simulate(&self, program: &Path, run: &Simulation) -> Result<Report, String> {
        let json = self.scratch_file("run.json");
        let mut full =
            vec!["simulate".to_string(), "--quiet".to_string(), "--json".to_string(), json.display().to_string()];
        full.extend(run.args());
        let outcome = self.run_on(program, &full, self.timeout, run.pinned()).and_then(|_| {
            let text = std::fs::read_to_string(&json).map_err(|e| io_error(&json, e))?;
            serde_json::from_str::<Report>(&text).map_err(|e| io_error(&json, e))
        });
        let _ = std::fs::remove_file(&json);
        let report = outcome?;
        match &report.summary.error {
            Some(e) => Err(format!("stopped: {e}")),
            None => Ok(report),
        }
    }

    /// This binary's hidden `--child` job with `args`; returns what it printed.
    pub fn child(&self, args: &[String], timeout: Duration) -> Result<String, String> {
        let mut full = vec!["--child".to_string()];
        full.extend_from_slice(args);
        self.run(&self.this, &full, timeout)
    }

    /// Runs `program` pinned to the core, to completion or `timeout`; returns its stdout.
    pub fn run(&self, program: &Path, args: &[String], timeout: Duration) -> Result<String, String> {
        self.run_on(program, args, timeout, true)
    }

    /// Runs `program` free on every core (a launcher that places its own processes), to
    /// completion or `timeout`; returns its stdout.
    pub fn run_free(&self, program: &Path, args: &[String], timeout: Duration) -> Result<String, String> {
        self.run_on(program, args, timeout, false)
    }

    /// [`Runner::run`], pinned to the core or free on every core.
    fn run_on(&self, program: &Path, args: &[String], timeout: Duration, pinned: bool) -> Result<String, String> {
        let (stdout_path, stderr_path) = (self.scratch_file("stdout"), self.scratch_file("stderr"));
        let create = |path: &Path| std::fs::File::create(path).map_err(|e| io_error(path, e));
        let (stdout, stderr) = (create(&stdout_path)?, create(&stderr_path)?);
        let mut command = match self.cpu.filter(|_| pinned) {
            Some(cpu) => {
                let mut c = Command::new("taskset");
                c.arg("-c").arg(cpu.to_string()).arg(program);
                c
            }
            None => Command::new(program),
        };
        let spawned = command.args(args).stdin(Stdio::null()).stdout(stdout).stderr(stderr).spawn();
        let waited = match spawned {
            Ok(child) => wait(child, timeout),
            Err(e) => Err(format!("could not start {}: {e}", program.display())),
        };
        let output = std::fs::read_to_string(&stdout_path).unwrap_or_default();
        let messages = std::fs::read_to_string(&stderr_path).unwrap_or_default();
        let _ = std::fs::remove_file(&stdout_path);
        let _ = std::fs::remove_file(&stderr_path);
        match waited? {
            status if status.success() => Ok(output),
            status => {
                let last = messages.lines().rev().find(|line| !line.trim().is_empty()).unwrap_or("no message");
                Err(format!("failed ({status}): {}", last.trim_start_matches("error: ")))
            }
        }
    }
}

/// A `vadop simulate` run of a generated scene (seed 1).
#[derive(Debug, Clone)]
pub struct Simulation {
    /// paper, gas, stream or heavy-tail (`--kind`).
    pub kind: &'static str,
    pub bodies: usize,
    pub packing: f64,
    /// `--max-speed`: the paper's maximum, the gas's rms, the stream's or the heavy tail's median speed.
    pub speed: f64,
    /// A stream's half-angle in degrees.
    pub spread: Option<f64>,
    pub frames: u64,
    /// detect or simulate.
    pub mode: &'static str,
    pub method: &'static str,
    /// brute, vadop or none.
    pub reference: &'static str,
    /// Frame length in seconds [default: 1/30].
    pub dt: Option<f64>,
    /// Pool axes [default: automatic].
    pub pool: Option<usize>,
    /// `--threads`: one for a run pinned to one core, more for a run on the whole machine;
    /// `None` leaves the flag out (an older binary without it is single-threaded).
    pub threads: Option<usize>,
    /// `--gravity` as x,y,z; `None` leaves the flag out.
    pub gravity: Option<[f64; 3]>,
    /// `--periodic` axes (e.g. xyz); `None` leaves the flag out.
    pub periodic: Option<&'static str>,
}

impl Simulation {
    /// The paper's scene (packing 0.05) in detect mode, no reference.
    pub fn paper(bodies: usize, speed: f64, frames: u64, method: &'static str) -> Simulation {
        Simulation {
            kind: "paper",
            bodies,
            packing: 0.05,
            speed,
            spread: None,
            frames,
            mode: "detect",
            method,
            reference: "none",
            dt: None,
            pool: None,
            threads: Some(1),
            gravity: None,
            periodic: None,
        }
    }

    /// Whether the run is pinned to one core: unless it asks for several threads.
    fn pinned(&self) -> bool {
        self.threads.is_none_or(|threads| threads == 1)
    }

    /// The command-line arguments. Options left at their default are left out, so that an older
    /// binary without them runs the paper scene too.
    fn args(&self) -> Vec<String> {
        let mut flags = vec![
            ("--bodies", self.bodies.to_string()),
            ("--packing", self.packing.to_string()),
            ("--max-speed", self.speed.to_string()),
            ("--frames", self.frames.to_string()),
            ("--mode", self.mode.to_string()),
            ("--method", self.method.to_string()),
            ("--reference", self.reference.to_string()),
        ];
        if self.kind != "paper" {
            flags.push(("--kind", self.kind.to_string()));
        }
        flags.extend(self.spread.map(|s| ("--spread", s.to_string())));
        flags.extend(self.dt.map(|dt| ("--dt", dt.to_string())));
        flags.extend(self.pool.map(|m| ("--pool", m.to_string())));
        flags.extend(self.threads.map(|t| ("--threads", t.to_string())));
        flags.extend(self.gravity.map(|[x, y, z]| ("--gravity", format!("{x},{y},{z}"))));
        flags.extend(self.periodic.map(|axes| ("--periodic", axes.to_string())));
        flags.into_iter().flat_map(|(flag, value)| [flag.to_string(), value]).collect()
    }
}

/// A source file of the product binary newer than `binary`, when `binary` sits in the target
/// folder of a vadop checkout: measuring a stale build would publish another engine's figures.
fn newer_source(binary: &Path) -> Option<PathBuf> {
    let built = std::fs::metadata(binary).and_then(|m| m.modified()).ok()?;
    let root = binary.parent()?.parent()?.parent()?;
    let mut pending: Vec<PathBuf> = ["crates/vadop", "crates/vadop-cli"]
        .iter()
        .map(|c| root.join(c))
        .filter(|c| c.join("Cargo.toml").is_file())
        .collect();
    while let Some(path) = pending.pop() {
        if path.is_dir() {
            // A crate's own target or test folders do not go into the binary.
            if path.file_name().is_some_and(|name| name == "target" || name == "tests") {
                continue;
            }
            pending.extend(std::fs::read_dir(&path).ok()?.filter_map(|entry| Some(entry.ok()?.path())));
        } else if std::fs::metadata(&path).and_then(|m| m.modified()).is_ok_and(|modified| modified > built) {
            return Some(path);
        }
    }
    None
}

impl Drop for Runner {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.scratch);
    }
}

/// Waits for `child` until it exits or `timeout` passes, then kills it.
fn wait(mut child: std::process::Child, timeout: Duration) -> Result<std::process::ExitStatus, String> {
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return Ok(status),
            Ok(None) if start.elapsed() > timeout => {
                // Failing to kill means it has just exited; either way it is waited for.
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("timed out after {} s", timeout.as_secs_f64()));
            }
            Ok(None) => std::thread::sleep(POLL),
            Err(e) => return Err(format!("could not wait for the child: {e}")),
        }
    }
}
