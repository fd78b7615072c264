//! `vadop peers`: vadop side by side with Bullet, FCL and rapier/parry on identical paths.
//!
//! The paper scene runs in detect mode (bodies pass through each other and bounce only off the
//! walls), so the paths do not depend on who detects the contacts. A child of this binary steps
//! the scene once and exports the paths to a trajectory file: per frame, every body's start
//! position and velocity, its end position and its wall bounces (time and position), so a path
//! is a polyline. The same child records the reference contact set: the (frame, i, j) pairs that
//! begin touching during the frame, found by vadop's brute-force method up to `--brute-max`
//! bodies and above that by vadop (which the core test suite proves bit-identical to brute
//! force). Every pipeline, vadop's own included, then runs in its own child pinned to one core
//! with a timeout, and its contact set is compared with the reference: found, missed, false.
//!
//! It owns the build of the peer programs (`bench/peers/cpp`, `bench/peers/rapier`; it only
//! checks that Debian's libbullet-dev and libfcl-dev are present, scripts/install-peers.sh
//! installs them), the trajectory format's writer (the reader is `bench/peers/cpp/trajectory.h`;
//! keep them in step), the runs, and the table, CSV and plot it writes. It never touches
//! BENCHMARKS.md outside its markers, and a failed or timed-out run becomes a row saying so.

use crate::bench::{finish_child, machine, merge_marked_section};
use crate::report;
use crate::CliResult;
use clap::{Args, ValueEnum};
use std::fmt::Write as _;
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use vadop::scene::{PaperScene, FRAMES_PER_SECOND};
use vadop::{Method, Mode, Touched, WorldConfig};

const BEGIN: &str = "<!-- peers:begin -->";
const END: &str = "<!-- peers:end -->";
const PACKING: f64 = 0.05;
const MAGIC: &[u8; 8] = b"VADOPTR1";

#[derive(Debug, Args)]
pub struct PeersArgs {
    /// Body counts n, comma-separated [default: 1000,2000,10000,100000,1000000; with --quick: 1000,2000]
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    bodies: Option<Vec<usize>>,
    /// Maximum speeds in sphere diameters per frame, comma-separated
    #[arg(long, value_name = "LIST", value_delimiter = ',', default_values_t = [0.05, 0.5, 5.0])]
    speeds: Vec<f64>,
    /// Frames per run [default: 30 up to 10^4 bodies, 10 up to 10^5, 3 above; with --quick: 10]
    #[arg(long, value_name = "F", value_parser = clap::value_parser!(u64).range(1..))]
    frames: Option<u64>,
    /// Largest n whose reference contacts come from brute force (above it: from vadop, which the
    /// core test suite proves identical to brute force); vadop-brute runs only up to it too
    #[arg(long, value_name = "N", default_value_t = 2000)]
    brute_max: usize,
    /// Pipelines to run, comma-separated [default: all]
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pipelines: Option<Vec<String>>,
    /// Seconds after which a run is stopped and recorded as timed out [default: 120; with --quick: 60]
    #[arg(long, value_name = "SECONDS")]
    timeout: Option<f64>,
    /// The core every run is pinned to with taskset [default: the last one]
    #[arg(long, value_name = "CPU")]
    cpu: Option<usize>,
    /// A small grid (n = 1000 and 2000, 10 frames) for a smoke check
    #[arg(long)]
    quick: bool,
    /// Markdown file whose peers section (between its markers) is replaced or added
    #[arg(long, value_name = "FILE", default_value = "BENCHMARKS.md")]
    output: PathBuf,
    /// Directory for the CSV and the plot
    #[arg(long, value_name = "DIR", default_value = "results/peers")]
    results: PathBuf,
    /// Run nothing: redraw the table and the plot from the CSV of an earlier run (for example
    /// results/peers/peers.csv after changing how they are presented)
    #[arg(long, value_name = "CSV")]
    render: Option<PathBuf>,
    /// Internal: run one child job instead of the benchmark
    #[arg(long, value_enum, hide = true)]
    child: Option<Child>,
    /// Internal: where a child writes (a directory for export, a contacts file otherwise)
    #[arg(long, hide = true)]
    child_out: Option<PathBuf>,
}

/// The jobs this binary runs as a child of `vadop peers`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Child {
    /// Write the trajectory file and the reference contacts.
    Export,
    /// Time one of vadop's methods and write its contacts.
    Vadop,
    Brute,
    Discrete,
}

/// Every pipeline: its name, whether it is continuous, and the program that runs it.
const PIPELINES: &[(&str, bool, Program)] = &[
    ("vadop", true, Program::Vadop(Child::Vadop)),
    ("vadop-brute", true, Program::Vadop(Child::Brute)),
    ("vadop-discrete", false, Program::Vadop(Child::Discrete)),
    ("bullet-dbvt", false, Program::Bullet),
    ("bullet-sap", false, Program::Bullet),
    ("bullet-ccd", true, Program::Bullet),
    ("fcl-dtree", false, Program::Fcl),
    ("fcl-dtree-refit", false, Program::Fcl),
    ("fcl-sap", false, Program::Fcl),
    ("fcl-ccd", true, Program::Fcl),
    ("fcl-ccd-refit", true, Program::Fcl),
    ("rapier", false, Program::Rapier),
    ("parry-ccd", true, Program::Rapier),
    ("parry-ccd-refit", true, Program::Rapier),
];

#[derive(Debug, Clone, Copy)]
enum Program {
    Vadop(Child),
    Bullet,
    Fcl,
    Rapier,
}

/// One pipeline on one (n, speed) cell.
struct Row {
    bodies: usize,
    speed: f64,
    frames: u64,
    pipeline: &'static str,
    continuous: bool,
    outcome: Result<Measured, String>,
}

struct Measured {
    median_ms: f64,
    peak_mib: f64,
    found: u64,
    missed: u64,
    false_contacts: u64,
    reference: u64,
}

pub fn run(args: &PeersArgs) -> CliResult<()> {
    if let Some(child) = args.child {
        return run_child(args, child);
    }
    let bodies = args.bodies.clone().unwrap_or(if args.quick { vec![1000, 2000] } else { vec![1000, 2000, 10_000, 100_000, 1_000_000] });
    let brute_max = args.brute_max;
    let timeout = Duration::try_from_secs_f64(args.timeout.unwrap_or(if args.quick { 60.0 } else { 120.0 }))
        .map_err(|e| format!("--timeout: {e}"))?;
    let frames_for = |n: usize| args.frames.unwrap_or(if args.quick { 10 } else if n <= 10_000 { 30 } else if n <= 100_000 { 10 } else { 3 });
    let pipelines: Vec<_> = match &args.pipelines {
        None => PIPELINES.to_vec(),
        Some(names) => names
            .iter()
            .map(|name| PIPELINES.iter().find(|p| p.0 == name).copied().ok_or(format!("unknown pipeline {name}")))
            .collect::<CliResult<_>>()?,
    };
    let existing = match std::fs::read_to_string(&args.output) {
        Ok(text) => Some(text),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(report::io_error(&args.output, e)),
    };
    std::fs::create_dir_all(&args.results).map_err(|e| report::io_error(&args.results, e))?;
    if let Some(csv) = &args.render {
        let rows = read_csv(csv)?;
        // The run that wrote the CSV pinned to --cpu, by default the last core.
        let cpu = args.cpu.unwrap_or(std::thread::available_parallelism().map_or(1, |n| n.get()) - 1);
        let section = write_outputs(args, existing.as_deref(), &rows, Some(cpu), true)?;
        return report::print(&format!("{section}\nwrote {} and {}\n", args.output.display(), args.results.display()));
    }
    let exe = std::env::current_exe().map_err(|e| format!("cannot find this program's own path: {e}"))?;
    let root = repository_root()?;

    let programs = build_peers(&root)?;
    let cpu = args.cpu.unwrap_or(std::thread::available_parallelism().map_or(1, |n| n.get()) - 1);
    let pin = Command::new("taskset").arg("--version").output().is_ok();
    if !pin {
        eprintln!("taskset not found: runs are not pinned to a core");
    }
    let scratch = std::env::temp_dir().join(format!("vadop-peers-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).map_err(|e| report::io_error(&scratch, e))?;

    let runs_per_cell = |n: usize| pipelines.iter().filter(|p| p.0 != "vadop-brute" || n <= brute_max).count() + 1;
    let total: usize = bodies.iter().map(|&n| runs_per_cell(n) * args.speeds.len()).sum();
    let mut done = 0;
    let mut rows = Vec::new();
    for &n in &bodies {
        for &speed in &args.speeds {
            let frames = frames_for(n);
            let common = vec![
                "--bodies".to_string(),
                n.to_string(),
                "--speeds".to_string(),
                speed.to_string(),
                "--frames".to_string(),
                frames.to_string(),
                "--brute-max".to_string(),
                brute_max.to_string(),
            ];
            done += 1;
            let reference_kind = if n <= brute_max { "brute force" } else { "vadop" };
            eprintln!("[{done}/{total}] n={n} speed={speed}: exporting paths and the {reference_kind} reference");
            let mut export = vec!["peers".to_string(), "--child".into(), "export".into(), "--child-out".into(), scratch.display().to_string()];
            export.extend(common.clone());
            let exported = spawn(&exe, &export, None, &scratch.join("export"), timeout * 4).and_then(|_| read_contacts(&scratch.join("reference.bin")));
            for &(name, continuous, program) in &pipelines {
                if name == "vadop-brute" && n > brute_max {
                    continue;
                }
                done += 1;
                let outcome = match &exported {
                    Err(e) => Err(format!("export failed: {e}")),
                    Ok(reference) => {
                        let contacts = scratch.join("contacts.bin");
                        let (program, arguments) = match program {
                            Program::Vadop(child) => {
                                let mut a = vec!["peers".to_string(), "--child".into(), child_name(child).into(), "--child-out".into()];
                                a.push(contacts.display().to_string());
                                a.extend(common.clone());
                                (exe.clone(), a)
                            }
                            other => {
                                let trajectory = scratch.join("trajectory.bin").display().to_string();
                                (programs.path(other), vec![name.to_string(), trajectory, contacts.display().to_string()])
                            }
                        };
                        spawn(&program, &arguments, pin.then_some(cpu), &scratch.join("run"), timeout)
                            .and_then(|stdout| measure(&stdout, &contacts, reference))
                    }
                };
                match &outcome {
                    Ok(m) => eprintln!(
                        "[{done}/{total}] n={n} speed={speed} {name}: {:.3} ms/frame, {} found, {} missed, {} false, {:.0} MiB",
                        m.median_ms, m.found, m.missed, m.false_contacts, m.peak_mib
                    ),
                    Err(e) => eprintln!("[{done}/{total}] n={n} speed={speed} {name}: {e}"),
                }
                rows.push(Row { bodies: n, speed, frames, pipeline: name, continuous, outcome });
            }
            for file in ["trajectory.bin", "reference.bin", "contacts.bin"] {
                let _ = std::fs::remove_file(scratch.join(file));
            }
            // Written after every cell, so a benchmark stopped early still leaves its rows.
            write_outputs(args, existing.as_deref(), &rows, pin.then_some(cpu), false)?;
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let section = write_outputs(args, existing.as_deref(), &rows, pin.then_some(cpu), true)?;
    report::print(&format!("{section}\nwrote {} and {}\n", args.output.display(), args.results.display()))
}

/// Writes the CSV, the markdown section and (when `plot`) the PNG; returns the section.
fn write_outputs(args: &PeersArgs, existing: Option<&str>, rows: &[Row], cpu: Option<usize>, plot: bool) -> CliResult<String> {
    write_csv(&args.results.join("peers.csv"), rows)?;
    let png = args.results.join("peers.png");
    let plotted = plot && match write_plot(rows, &args.results, &png) {
        Ok(()) => true,
        Err(e) => {
            eprintln!("no plot: {e}");
            false
        }
    };
    let section = markdown_section(rows, args.brute_max, cpu, plotted.then_some(&png));
    let merged = merge_marked_section(existing, &section, &args.output, BEGIN, END)?;
    std::fs::write(&args.output, merged).map_err(|e| report::io_error(&args.output, e))?;
    Ok(section)
}

fn child_name(child: Child) -> &'static str {
    match child {
        Child::Export => "export",
        Child::Vadop => "vadop",
        Child::Brute => "brute",
        Child::Discrete => "discrete",
    }
}

/// The directory holding `bench/peers`, searched upwards from the current directory.
fn repository_root() -> CliResult<PathBuf> {
    let here = std::env::current_dir().map_err(|e| format!("cannot read the current directory: {e}"))?;
    here.ancestors()
        .find(|dir| dir.join("bench/peers/cpp/Makefile").is_file())
        .map(Path::to_path_buf)
        .ok_or_else(|| "run `vadop peers` inside the vadop repository (bench/peers/ not found)".to_string())
}

/// Paths of the built peer programs.
struct Programs {
    bullet: PathBuf,
    fcl: PathBuf,
    rapier: PathBuf,
}

impl Programs {
    fn path(&self, program: Program) -> PathBuf {
        match program {
            Program::Bullet => self.bullet.clone(),
            Program::Fcl => self.fcl.clone(),
            Program::Rapier | Program::Vadop(_) => self.rapier.clone(),
        }
    }
}

/// Checks that the peers' libraries and tools are present, then builds the C++ and rapier peers
/// (both builds do nothing when up to date). Installing system packages is left to
/// scripts/install-peers.sh, run as root: this program only says what is missing.
fn build_peers(root: &Path) -> CliResult<Programs> {
    let runs = |program: &str| Command::new(program).arg("--version").output().is_ok();
    // Each requirement by the Debian package that brings it.
    let present = [
        ("libbullet-dev", Path::new("/usr/include/bullet/btBulletCollisionCommon.h").is_file()),
        ("libfcl-dev", Path::new("/usr/include/fcl/fcl.h").is_file()),
        ("build-essential", runs("g++") && runs("make")),
        ("pkg-config", runs("pkg-config")),
        ("gnuplot-nox", runs("gnuplot")),
    ];
    let missing: Vec<&str> = present.iter().filter(|p| !p.1).map(|p| p.0).collect();
    if !missing.is_empty() {
        return Err(format!(
            "the peers need Debian's {}, missing here: run `{}` as root (it installs them with apt-get), then run this again",
            missing.join(", "),
            root.join("scripts/install-peers.sh").display()
        ));
    }
    let cpp = root.join("bench/peers/cpp");
    eprintln!("building the Bullet and FCL peers (make -C {})", cpp.display());
    checked(Command::new("make").arg("-s").arg("-C").arg(&cpp), "make")?;
    let rapier = root.join("bench/peers/rapier");
    eprintln!("building the rapier/parry peer (cargo build --release in {})", rapier.display());
    checked(
        Command::new("cargo").args(["build", "--release", "-q", "--manifest-path"]).arg(rapier.join("Cargo.toml")),
        "cargo build of bench/peers/rapier",
    )?;
    Ok(Programs {
        bullet: cpp.join("build/peer-bullet"),
        fcl: cpp.join("build/peer-fcl"),
        rapier: rapier.join("target/release/vadop-peer-rapier"),
    })
}

fn checked(command: &mut Command, what: &str) -> CliResult<()> {
    let status = command.status().map_err(|e| format!("{what}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{what} failed ({status})"))
    }
}

/// Runs a program to completion or timeout, optionally pinned to `cpu`; returns its stdout.
fn spawn(program: &Path, arguments: &[String], cpu: Option<usize>, scratch: &Path, timeout: Duration) -> Result<String, String> {
    let (stdout_path, stderr_path) = (scratch.with_extension("stdout"), scratch.with_extension("stderr"));
    // Files, not pipes: a child writing more than a pipe holds would block until the timeout.
    let stdout = report::create_file(&stdout_path)?;
    let stderr = report::create_file(&stderr_path)?;
    let mut command = match cpu {
        Some(cpu) => {
            let mut c = Command::new("taskset");
            c.arg("-c").arg(cpu.to_string()).arg(program);
            c
        }
        None => Command::new(program),
    };
    let child = command
        .args(arguments)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(stderr)
        .spawn()
        .map_err(|e| format!("could not start {}: {e}", program.display()))?;
    let finished = finish_child(child, timeout, &stderr_path);
    let output = std::fs::read_to_string(&stdout_path).unwrap_or_default();
    let _ = std::fs::remove_file(&stdout_path);
    finished?;
    Ok(output)
}

/// The one-line JSON summary every pipeline prints.
#[derive(serde::Deserialize)]
struct RunSummary {
    frame_ms: Vec<f64>,
    peak_kib: i64,
}

/// Reads a run's summary and compares its contacts with the reference.
fn measure(stdout: &str, contacts: &Path, reference: &[[u32; 3]]) -> Result<Measured, String> {
    let line = stdout.lines().rev().find(|l| l.starts_with('{')).ok_or("printed no summary")?;
    let summary: RunSummary = serde_json::from_str(line).map_err(|e| format!("bad summary: {e}"))?;
    let mut times = summary.frame_ms;
    times.sort_by(f64::total_cmp);
    let median_ms = match times.len() {
        0 => return Err("no frames".into()),
        len if len % 2 == 1 => times[len / 2],
        len => 0.5 * (times[len / 2 - 1] + times[len / 2]),
    };
    let found = read_contacts(contacts)?;
    let (matched, missed, false_contacts) = compare(reference, &found);
    Ok(Measured { median_ms, peak_mib: summary.peak_kib as f64 / 1024.0, found: matched, missed, false_contacts, reference: reference.len() as u64 })
}

/// (in both, only in the reference, only in `found`); both sorted and free of duplicates.
fn compare(reference: &[[u32; 3]], found: &[[u32; 3]]) -> (u64, u64, u64) {
    let (mut a, mut b, mut both) = (0, 0, 0u64);
    while a < reference.len() && b < found.len() {
        match reference[a].cmp(&found[b]) {
            std::cmp::Ordering::Equal => {
                both += 1;
                a += 1;
                b += 1;
            }
            std::cmp::Ordering::Less => a += 1,
            std::cmp::Ordering::Greater => b += 1,
        }
    }
    (both, reference.len() as u64 - both, found.len() as u64 - both)
}

/// Reads (frame, i, j) u32 triples, sorted and without duplicates.
fn read_contacts(path: &Path) -> Result<Vec<[u32; 3]>, String> {
    let bytes = std::fs::read(path).map_err(|e| report::io_error(path, e))?;
    let word = |k: usize| u32::from_le_bytes([bytes[4 * k], bytes[4 * k + 1], bytes[4 * k + 2], bytes[4 * k + 3]]);
    let mut triples: Vec<[u32; 3]> = (0..bytes.len() / 12).map(|t| [word(3 * t), word(3 * t + 1), word(3 * t + 2)]).collect();
    triples.sort_unstable();
    triples.dedup();
    Ok(triples)
}

fn write_contacts(path: &Path, contacts: &[[u32; 3]]) -> CliResult<()> {
    let bytes: Vec<u8> = contacts.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes).map_err(|e| report::io_error(path, e))
}

/// A child job: export, or time one of vadop's methods.
fn run_child(args: &PeersArgs, child: Child) -> CliResult<()> {
    let (Some(&[n]), Some(&speed), Some(frames), Some(out)) =
        (args.bodies.as_deref(), args.speeds.first(), args.frames, args.child_out.as_ref())
    else {
        return Err("a child needs --bodies N --speeds S --frames F --child-out PATH".into());
    };
    let method = match child {
        Child::Export => return export(n, speed, frames, n <= args.brute_max, out),
        Child::Vadop => Method::Vadop,
        Child::Brute => Method::Brute,
        Child::Discrete => Method::Discrete,
    };
    let scene = PaperScene::new(n, PACKING, speed).build().map_err(|e| e.to_string())?;
    let config = WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() };
    let mut world = scene.world(config).map_err(|e| e.to_string())?;
    let mut contacts = Vec::new();
    let mut frame_ms = Vec::new();
    for frame in 0..frames {
        let started = Instant::now();
        let step = world.step(1.0 / FRAMES_PER_SECOND).map_err(|e| e.to_string())?;
        frame_ms.push(started.elapsed().as_secs_f64() * 1e3);
        for c in step {
            if let Touched::Body(j) = c.touched {
                contacts.push([frame as u32, c.body.min(j), c.body.max(j)]);
            }
        }
    }
    write_contacts(out, &contacts)?;
    let peak_kib = report::peak_memory_mib().map_or(-1, |m| (m * 1024.0) as i64);
    let times: Vec<String> = frame_ms.iter().map(|t| format!("{t:.6}")).collect();
    report::print(&format!("{{\"frame_ms\":[{}],\"peak_kib\":{peak_kib}}}\n", times.join(",")))
}

/// Steps the paper scene in detect mode and writes `dir`/trajectory.bin (the format is in this
/// file's doc and in bench/peers/cpp/trajectory.h) and `dir`/reference.bin, the pair contacts
/// found by brute force (`brute`) or by vadop.
fn export(n: usize, speed: f64, frames: u64, brute: bool, dir: &Path) -> CliResult<()> {
    let scene = PaperScene::new(n, PACKING, speed).build().map_err(|e| e.to_string())?;
    let dt = 1.0 / FRAMES_PER_SECOND;
    let method = if brute { Method::Brute } else { Method::Vadop };
    let mut world = scene.world(WorldConfig { method, mode: Mode::Detect, ..WorldConfig::default() }).map_err(|e| e.to_string())?;
    let mut contacts = Vec::new();
    {
        let path = dir.join("trajectory.bin");
        let mut file = BufWriter::new(report::create_file(&path)?);
        let header = [n as u64, frames];
        let floats = [dt, scene.spheres[0].radius];
        let corners = [scene.bounds.min.to_array(), scene.bounds.max.to_array()];
        let mut bytes: Vec<u8> = MAGIC.to_vec();
        bytes.extend(header.iter().flat_map(|v| v.to_le_bytes()));
        bytes.extend(floats.iter().chain(corners.iter().flatten()).flat_map(|v| v.to_le_bytes()));
        file.write_all(&bytes).map_err(|e| report::io_error(&path, e))?;
        for frame in 0..frames {
            let mut bytes = Vec::with_capacity(n * 72);
            let start: Vec<_> = world.spheres().map(|(_, s)| s).collect();
            for s in &start {
                bytes.extend(s.position.to_array().iter().chain(s.velocity.to_array().iter()).flat_map(|v| v.to_le_bytes()));
            }
            let t0 = world.time();
            let mut bounces = Vec::new();
            for c in world.step(dt).map_err(|e| e.to_string())? {
                match c.touched {
                    Touched::Body(j) => contacts.push([frame as u32, c.body.min(j), c.body.max(j)]),
                    // The contact point sits one radius out along the normal from the centre.
                    Touched::Wall(_) => bounces.push((c.body as u64, c.time - t0, c.point - c.normal * start[c.body as usize].radius)),
                }
            }
            for (_, s) in world.spheres() {
                bytes.extend(s.position.to_array().iter().flat_map(|v| v.to_le_bytes()));
            }
            bounces.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
            bytes.extend((bounces.len() as u64).to_le_bytes());
            for (body, tau, p) in bounces {
                bytes.extend(body.to_le_bytes());
                bytes.extend([tau, p.x, p.y, p.z].iter().flat_map(|v| v.to_le_bytes()));
            }
            file.write_all(&bytes).map_err(|e| report::io_error(&path, e))?;
        }
        file.flush().map_err(|e| report::io_error(&path, e))?;
    }
    contacts.sort_unstable();
    contacts.dedup();
    write_contacts(&dir.join("reference.bin"), &contacts)
}

fn write_csv(path: &Path, rows: &[Row]) -> CliResult<()> {
    let mut text = String::from("n,speed,pipeline,kind,frames,status,median_ms,found,missed,false,reference,peak_mib,time_vs_vadop\n");
    for row in rows {
        let kind = if row.continuous { "continuous" } else { "discrete" };
        let _ = match &row.outcome {
            Ok(m) => writeln!(
                text,
                "{},{},{},{kind},{},ok,{},{},{},{},{},{:.1},{}",
                row.bodies,
                row.speed,
                row.pipeline,
                row.frames,
                m.median_ms,
                m.found,
                m.missed,
                m.false_contacts,
                m.reference,
                m.peak_mib,
                ratio(rows, row).map_or(String::new(), |r| format!("{r:.3}"))
            ),
            Err(e) => writeln!(text, "{},{},{},{kind},{},{},,,,,,,", row.bodies, row.speed, row.pipeline, row.frames, e.replace(',', ";")),
        };
    }
    std::fs::write(path, text).map_err(|e| report::io_error(path, e))
}

/// Reads the rows of a CSV written by `write_csv`.
fn read_csv(path: &Path) -> CliResult<Vec<Row>> {
    let text = std::fs::read_to_string(path).map_err(|e| report::io_error(path, e))?;
    let bad = |line: usize, what: &str| format!("{}:{}: {what}", path.display(), line + 1);
    let mut rows = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 13 {
            return Err(bad(k, "expected 13 fields"));
        }
        let &(pipeline, continuous, _) = PIPELINES.iter().find(|p| p.0 == f[2]).ok_or_else(|| bad(k, "unknown pipeline"))?;
        let number = |i: usize| f[i].parse::<f64>().map_err(|_| bad(k, &format!("bad number {:?}", f[i])));
        let outcome = if f[5] == "ok" {
            Ok(Measured {
                median_ms: number(6)?,
                found: number(7)? as u64,
                missed: number(8)? as u64,
                false_contacts: number(9)? as u64,
                reference: number(10)? as u64,
                peak_mib: number(11)?,
            })
        } else {
            Err(f[5].to_string())
        };
        rows.push(Row { bodies: number(0)? as usize, speed: number(1)?, frames: number(4)? as u64, pipeline, continuous, outcome });
    }
    Ok(rows)
}

/// This row's median time divided by vadop's on the same cell.
fn ratio(rows: &[Row], row: &Row) -> Option<f64> {
    let vadop = rows.iter().find(|r| r.bodies == row.bodies && r.speed == row.speed && r.pipeline == "vadop")?;
    Some(row.outcome.as_ref().ok()?.median_ms / vadop.outcome.as_ref().ok()?.median_ms)
}

/// Median ms/frame against n, one panel per speed, one line per pipeline (gnuplot, log-log).
fn write_plot(rows: &[Row], dir: &Path, png: &Path) -> CliResult<()> {
    let mut speeds: Vec<f64> = rows.iter().map(|r| r.speed).collect();
    speeds.sort_by(f64::total_cmp);
    speeds.dedup();
    let names: Vec<&str> = PIPELINES.iter().map(|p| p.0).filter(|name| rows.iter().any(|r| r.pipeline == *name && r.outcome.is_ok())).collect();
    let data = dir.join("peers.dat");
    let mut text = String::new();
    // One gnuplot data block per (speed, pipeline), in that order, separated by two blank lines.
    for &speed in &speeds {
        for name in &names {
            let _ = writeln!(text, "# speed {speed} {name}");
            for row in rows.iter().filter(|r| r.speed == speed && r.pipeline == *name) {
                if let Ok(m) = &row.outcome {
                    let _ = writeln!(text, "{} {}", row.bodies, m.median_ms);
                }
            }
            text.push_str("\n\n");
        }
    }
    std::fs::write(&data, text).map_err(|e| report::io_error(&data, e))?;
    let mut script = format!(
        "set terminal pngcairo size {},620 font ',10'\nset output '{}'\nset multiplot layout 1,{}\n\
         set logscale xy\nset grid\nset xlabel 'bodies n'\nset ylabel 'median ms per frame'\nset key below font ',8' maxrows 4\n\
         set offsets graph 0.05, graph 0.05, 0, 0\n",
        480 * speeds.len(),
        png.display(),
        speeds.len()
    );
    for (s, speed) in speeds.iter().enumerate() {
        let _ = writeln!(script, "set title 'max speed {speed} diameters/frame'");
        let plots: Vec<String> = names
            .iter()
            .enumerate()
            .map(|(p, name)| {
                let style = if PIPELINES.iter().any(|q| q.0 == *name && q.1) { "lp pt 7" } else { "lp dt 2 pt 6" };
                let width = if *name == "vadop" { 3.0 } else { 1.5 };
                format!("'{}' index {} using 1:2 with {style} lw {width} lc rgb '{}' title '{name}'", data.display(), s * names.len() + p, colour(name))
            })
            .collect();
        let _ = writeln!(script, "plot {}", plots.join(", \\\n     "));
    }
    script.push_str("unset multiplot\n");
    let script_path = dir.join("peers.gp");
    std::fs::write(&script_path, script).map_err(|e| report::io_error(&script_path, e))?;
    checked(Command::new("gnuplot").arg(&script_path), "gnuplot")
}

/// A fixed colour per pipeline, so each reads the same in every panel: vadop's in red,
/// Bullet's in blues, FCL's in greens, rapier's in purple and brown.
fn colour(pipeline: &str) -> &'static str {
    match pipeline {
        "vadop" => "#d62728",
        "vadop-brute" => "#ff9896",
        "vadop-discrete" => "#e377c2",
        "bullet-dbvt" => "#1f77b4",
        "bullet-sap" => "#6baed6",
        "bullet-ccd" => "#08306b",
        "fcl-dtree" => "#2ca02c",
        "fcl-dtree-refit" => "#74c476",
        "fcl-sap" => "#98df8a",
        "fcl-ccd" => "#00441b",
        "fcl-ccd-refit" => "#238b45",
        "rapier" => "#9467bd",
        "parry-ccd" => "#8c564b",
        "parry-ccd-refit" => "#c49c94",
        _ => "#7f7f7f",
    }
}

fn markdown_section(rows: &[Row], brute_max: usize, cpu: Option<usize>, plot: Option<&PathBuf>) -> String {
    let mut md = String::new();
    let command: Vec<String> = std::env::args().skip(1).collect();
    let _ = writeln!(md, "{BEGIN}");
    match command.iter().position(|a| a == "--render") {
        Some(k) => {
            let csv = command.get(k + 1).map_or("", String::as_str);
            let _ = writeln!(md, "Rows measured by `vadop peers` into `{csv}`, drawn by `vadop {}`.  ", command.join(" "));
        }
        None => {
            let _ = writeln!(md, "Produced by `vadop {}`.  ", command.join(" "));
        }
    }
    let _ = writeln!(md, "Machine: {}. {}\n", machine(), cpu.map_or("Runs not pinned.".to_string(), |c| format!("Every run pinned to core {c} with taskset, one thread.")));
    let _ = writeln!(
        md,
        "Paper scene, packing fraction {PACKING}, seed 1, detect mode: every pipeline reads the same exported paths. \
         A contact is a (frame, i, j) pair that begins touching during the frame; the reference comes from vadop's \
         brute force for n <= {brute_max} and from vadop above. ms/frame is the median over frames of the detection \
         work (reading the file excluded); peak MiB is the run's VmHWM; × vadop is the median time divided by vadop's \
         on the same row group (above 1: slower than vadop).\n"
    );
    let _ = writeln!(md, "| n | speed | pipeline | kind | frames | median ms/frame | found | missed | false | peak MiB | × vadop |");
    let _ = writeln!(md, "|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for row in rows {
        let kind = if row.continuous { "continuous" } else { "discrete" };
        let cells = match &row.outcome {
            Ok(m) => format!(
                "{:.3} | {} | {} | {} | {:.1} | {}",
                m.median_ms,
                m.found,
                m.missed,
                m.false_contacts,
                m.peak_mib,
                ratio(rows, row).map_or("—".to_string(), |r| format!("{r:.2}"))
            ),
            Err(e) => format!("{} | — | — | — | — | —", e.replace('|', "/")),
        };
        let _ = writeln!(md, "| {} | {} | {} | {kind} | {} | {cells} |", row.bodies, row.speed, row.pipeline, row.frames);
    }
    let _ = writeln!(md);
    if let Some(plot) = plot {
        let _ = writeln!(md, "![median ms per frame against n]({})\n", plot.display());
    }
    let _ = writeln!(md, "Goal check, per row group (n >= 10000), from the rows above:\n");
    let mut cells: Vec<(usize, f64)> = rows.iter().map(|r| (r.bodies, r.speed)).collect();
    cells.dedup();
    for (n, speed) in cells.into_iter().filter(|c| c.0 >= 10_000) {
        let group: Vec<&Row> = rows.iter().filter(|r| r.bodies == n && r.speed == speed).collect();
        let Some(Ok(vadop)) = group.iter().find(|r| r.pipeline == "vadop").map(|r| &r.outcome) else {
            let _ = writeln!(md, "- n={n}, speed {speed}: vadop did not finish.");
            continue;
        };
        let peers = |continuous: bool| group.iter().filter(move |r| r.continuous == continuous && !r.pipeline.starts_with("vadop"));
        let slower_continuous: Vec<String> = peers(true)
            .filter_map(|r| r.outcome.as_ref().ok().filter(|m| m.median_ms <= vadop.median_ms).map(|m| format!("{} ({:.3} ms)", r.pipeline, m.median_ms)))
            .collect();
        let fastest_discrete = peers(false).filter_map(|r| r.outcome.as_ref().ok().map(|m| (r.pipeline, m.median_ms))).min_by(|a, b| a.1.total_cmp(&b.1));
        let exact = if vadop.missed == 0 && vadop.false_contacts == 0 { "exact" } else { "NOT exact" };
        let versus_continuous = if slower_continuous.is_empty() {
            "faster than every continuous peer that finished".to_string()
        } else {
            format!("NOT faster than {}", slower_continuous.join(", "))
        };
        let versus_discrete = match fastest_discrete {
            Some((name, ms)) if ms < vadop.median_ms => format!("slower than the fastest discrete peer, {name} ({ms:.3} ms, {:.2}x vadop's time)", ms / vadop.median_ms),
            Some((name, ms)) => format!("not slower than the fastest discrete peer, {name} ({ms:.3} ms)"),
            None => "no discrete peer finished".to_string(),
        };
        let _ = writeln!(md, "- n={n}, speed {speed}: vadop {:.3} ms, {exact}; {versus_continuous}; {versus_discrete}.", vadop.median_ms);
    }
    let _ = write!(md, "{END}");
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_sets_compare_and_round_trip() {
        let path = std::env::temp_dir().join(format!("vadop-peers-test-{}.bin", std::process::id()));
        write_contacts(&path, &[[1, 2, 3], [0, 5, 9], [1, 2, 3]]).unwrap();
        let read = read_contacts(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!(read, vec![[0, 5, 9], [1, 2, 3]]);
        assert_eq!(compare(&read, &[[0, 5, 9], [2, 0, 1]]), (1, 1, 1));
    }

    /// Reads the trajectory file the way the peers do and checks that each path is the polyline
    /// vadop stepped: frames chain up, bounces sit on a wall, and the start velocity leads from
    /// the start to the first knot.
    #[test]
    fn trajectory_file_describes_the_stepped_paths() {
        let dir = std::env::temp_dir().join(format!("vadop-peers-export-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // 60 bodies at 5 diameters per frame in a box about 8.6 wide: bounces in every frame.
        export(60, 5.0, 4, true, &dir).unwrap();
        let bytes = std::fs::read(dir.join("trajectory.bin")).unwrap();
        let contacts = read_contacts(&dir.join("reference.bin")).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let at = std::cell::Cell::new(8);
        let word = || {
            at.set(at.get() + 8);
            u64::from_le_bytes(bytes[at.get() - 8..at.get()].try_into().unwrap())
        };
        let float = || f64::from_bits(word());
        assert_eq!(&bytes[..8], MAGIC);
        let (n, frames) = (word() as usize, word());
        let (dt, radius) = (float(), float());
        let (low, high) = ([float(), float(), float()], [float(), float(), float()]);
        assert_eq!((n, frames, dt, radius), (60, 4, 1.0 / 30.0, 0.5));
        let mut previous_end: Option<Vec<[f64; 3]>> = None;
        let mut bounce_total = 0;
        for _ in 0..frames {
            let start: Vec<[f64; 6]> = (0..n).map(|_| std::array::from_fn(|_| float())).collect();
            let end: Vec<[f64; 3]> = (0..n).map(|_| std::array::from_fn(|_| float())).collect();
            if let Some(previous) = &previous_end {
                assert!(start.iter().zip(previous).all(|(s, e)| s[..3] == e[..]));
            }
            let count = word();
            let mut first_knot = vec![None; n];
            let mut bodies_seen = Vec::new();
            for _ in 0..count {
                let body = word() as usize;
                let (tau, p) = (float(), [float(), float(), float()]);
                assert!((0.0..dt).contains(&tau));
                let on_wall = (0..3).any(|a| (p[a] - low[a] - radius).abs() < 1e-9 || (high[a] - p[a] - radius).abs() < 1e-9);
                assert!(on_wall, "bounce of body {body} at {p:?} is on no wall");
                first_knot[body].get_or_insert((tau, p));
                bodies_seen.push(body);
            }
            assert!(bodies_seen.windows(2).all(|w| w[0] <= w[1]), "bounces sorted by body");
            for (i, s) in start.iter().enumerate() {
                let (tau, p) = first_knot[i].unwrap_or((dt, end[i]));
                assert!((0..3).all(|a| (s[a] + tau * s[3 + a] - p[a]).abs() < 1e-9), "body {i} leaves its line");
            }
            bounce_total += count;
            previous_end = Some(end);
        }
        assert_eq!(at.get(), bytes.len());
        assert!(bounce_total > 0 && !contacts.is_empty());
        assert!(contacts.iter().all(|c| (c[0] as u64) < frames && c[1] < c[2] && (c[2] as usize) < n));
    }

    #[test]
    fn sections_replace_only_between_markers() {
        let path = Path::new("B.md");
        let section = format!("{BEGIN}\nnew\n{END}");
        let text = format!("# Top\n\n{BEGIN}\nold\n{END}\n\nTail\n");
        assert_eq!(merge_marked_section(Some(&text), &section, path, BEGIN, END).unwrap(), format!("# Top\n\n{section}\n\nTail\n"));
        assert!(merge_marked_section(Some(&format!("{END}{BEGIN}")), &section, path, BEGIN, END).is_err());
    }
}
