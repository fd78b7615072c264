//! `vadop-bench peers`: vadop side by side with Bullet, FCL and rapier/parry on identical paths.
//!
//! Two scenes, each with its own section, CSV and plot: the paper's spheres, and mixed spinning
//! shapes (`--scene shapes`, [`shapes`]). Both run in detect mode (bodies pass through each
//! other), so the paths do not depend on who detects the contacts. A child steps the scene once
//! and exports the paths and the reference contact set ([`trajectory`]): found by brute force up
//! to `--brute-max` bodies and above that by the default method (which the core test suite proves
//! bit-identical to brute force). Every pipeline, vadop's own included, then runs in its own
//! child pinned to one core with a timeout, and its contacts are compared with the reference:
//! found, missed, false. Beside the libraries runs [`plain_grid`], a reference of a few hundred
//! lines (a uniform grid rebuilt every frame), so the table shows what the plainest exact broad
//! phase achieves on the same paths; it is not a product method.
//!
//! It owns the build of the peer programs (`bench/peers/cpp`, `bench/peers/rapier`; it only
//! checks that Debian's libbullet-dev and libfcl-dev are present, scripts/install-peers.sh
//! installs them), the runs, and the table, CSV and plot it writes.

pub mod plain_grid;
pub mod shapes;
pub mod trajectory;

use crate::common::{write_file, Common, Grid};
use crate::markdown::{self, Markers, RunInfo};
use crate::plots::{self, Panel, Series, Stroke};
use crate::runner::Runner;
use crate::CliResult;
use clap::{Args, ValueEnum};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use trajectory::PACKING;

/// The pipeline every other is compared with: the product's default.
const BASELINE: &str = "vadop-auto";

/// The reference pipeline: neither vadop's nor a library's, so the goal check keeps it apart
/// from the peers.
const REFERENCE: &str = "plain-grid";

/// Issue 28's goal: the default method's time at most this fraction of the fastest exact peer's.
const PEER_GOAL: f64 = 0.5;

/// The scene the pipelines detect contacts in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Scene {
    /// The paper's: equal spheres bouncing off the walls of a cube
    Spheres,
    /// Mixed shapes (spheres, cuboids, capsules, cylinders, cones, convex hulls) spinning about a
    /// principal axis, in a box whose walls none reaches
    Shapes,
}

impl Scene {
    fn name(self) -> &'static str {
        match self {
            Scene::Spheres => "spheres",
            Scene::Shapes => "shapes",
        }
    }

    /// The markers of its section in the markdown file.
    fn markers(self) -> Markers {
        match self {
            Scene::Spheres => Markers { name: "peers" },
            Scene::Shapes => Markers { name: "peers-shapes" },
        }
    }

    /// The stem of its CSV and plot in results/peers/.
    fn file_stem(self) -> &'static str {
        match self {
            Scene::Spheres => "peers",
            Scene::Shapes => "shapes",
        }
    }

    /// Why `pipeline` cannot run on this scene, if it cannot.
    fn refusal(self, pipeline: &str) -> Option<&'static str> {
        match (self, pipeline) {
            (Scene::Shapes, "vadop-discrete") => Some("vadop's discrete method handles spheres only"),
            (Scene::Shapes, REFERENCE) => {
                Some("the plain grid is a reference for spheres (its narrow phase is their closed form)")
            }
            _ => None,
        }
    }
}

#[derive(Debug, Args)]
#[command(after_help = "Defaults: --bodies 1000,2000,10000,100000,1000000 (shapes: 1000,2000,10000,100000; with \
--quick: 1000,2000, shapes 500,1000); --frames 30 up to 10^4 bodies, 10 above (with --quick: 10); --timeout 120 (with \
--quick: 60).")]
pub struct PeersArgs {
    #[command(flatten)]
    grid: Grid,
    /// The scene: its own section in the markdown file, and its own CSV and plot
    #[arg(long, value_enum, default_value_t = Scene::Spheres)]
    scene: Scene,
    /// Largest n whose reference contacts come from brute force (above it: from the default
    /// method, which the core test suite proves identical to brute force); vadop-brute runs only
    /// up to it too
    #[arg(long, value_name = "N", default_value_t = 2000)]
    brute_max: usize,
    /// Pipelines to run, comma-separated [default: all that run on the scene]
    #[arg(long, value_name = "LIST", value_delimiter = ',')]
    pipelines: Option<Vec<String>>,
    /// Run nothing: redraw the table and the plot from the CSV of an earlier run (for example
    /// results/peers/peers.csv after changing how they are presented)
    #[arg(long, value_name = "CSV")]
    render: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
}

/// Every pipeline: its name, whether it is continuous, and the program that runs it.
const PIPELINES: &[(&str, bool, Program)] = &[
    ("vadop-auto", true, Program::Vadop("auto")),
    ("vadop", true, Program::Vadop("vadop")),
    ("vadop-brute", true, Program::Vadop("brute")),
    ("vadop-discrete", false, Program::Vadop("discrete")),
    (REFERENCE, true, Program::PlainGrid),
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
    /// A child job of this binary timing one of vadop's methods.
    Vadop(&'static str),
    /// A child job of this binary running the reference grid ([`plain_grid`]) over the paths.
    PlainGrid,
    Bullet,
    Fcl,
    Rapier,
}

/// One pipeline on one (n, speed) cell.
pub struct Row {
    pub bodies: usize,
    pub speed: f64,
    frames: u64,
    pub pipeline: &'static str,
    pub continuous: bool,
    pub outcome: Result<Measured, String>,
}

pub struct Measured {
    /// Mean over frames: vadop's broad phases work in windows of several frames.
    pub mean_ms: f64,
    peak_mib: f64,
    found: u64,
    pub missed: u64,
    pub false_contacts: u64,
    reference: u64,
}

impl Row {
    /// Continuous and neither missing a contact nor adding one.
    pub fn exact(&self) -> bool {
        self.continuous && self.outcome.as_ref().is_ok_and(|m| m.missed == 0 && m.false_contacts == 0)
    }
}

pub fn run(args: &PeersArgs) -> CliResult<()> {
    args.grid.check()?;
    let common = &args.common;
    let quick = common.quick;
    let runner = Runner::new(common, common.timeout(if quick { 60.0 } else { 120.0 })?)?;
    let scene = args.scene;
    let (markdown_path, results) = (common.markdown(), common.results()?.join("peers"));
    crate::common::create_dir(&results)?;
    markdown::check(&markdown_path, scene.markers())?;
    let info = RunInfo::start(runner.cpu());
    let outputs =
        Outputs { scene, markdown: &markdown_path, results: &results, brute_max: args.brute_max, info: &info };
    if let Some(csv) = &args.render {
        let rows = read_csv(csv)?;
        let section = outputs.write(&rows, true)?;
        return crate::common::print(&format!(
            "{section}\nwrote {} and {}\n",
            markdown_path.display(),
            results.display()
        ));
    }
    let bodies = args.grid.bodies.clone().unwrap_or(match (quick, scene) {
        (true, Scene::Spheres) => vec![1000, 2000],
        // vadop-brute and the brute-force reference cost more per pair of shapes than of spheres.
        (true, Scene::Shapes) => vec![500, 1000],
        (false, Scene::Spheres) => vec![1000, 2000, 10_000, 100_000, 1_000_000],
        (false, Scene::Shapes) => vec![1000, 2000, 10_000, 100_000],
    });
    let brute_max = args.brute_max;
    let frames_for = |n: usize| {
        args.grid.frames.unwrap_or(if quick {
            10
        } else if n <= 10_000 {
            30
        } else {
            // Ten frames at n = 10^6 too (issue 28's table): over three, one window start of
            // vadop's, which may span many frames, would weigh a third of the mean.
            10
        })
    };
    let pipelines: Vec<_> = match &args.pipelines {
        None => PIPELINES.iter().filter(|p| scene.refusal(p.0).is_none()).copied().collect(),
        Some(names) => names
            .iter()
            .map(|name| {
                let pipeline = PIPELINES.iter().find(|p| p.0 == name).ok_or(format!("unknown pipeline {name}"))?;
                match scene.refusal(name) {
                    Some(why) => Err(format!("{name} cannot run on the {} scene: {why}", scene.name())),
                    None => Ok(*pipeline),
                }
            })
            .collect::<CliResult<_>>()?,
    };
    let programs = build_peers(&pipelines)?;
    let scratch = runner.scratch_file("peers");
    crate::common::create_dir(&scratch)?;
    let (trajectory, reference_file, contacts) =
        (scratch.join("trajectory.bin"), scratch.join("reference.bin"), scratch.join("contacts.bin"));

    let runs_per_cell = |n: usize| pipelines.iter().filter(|p| p.0 != "vadop-brute" || n <= brute_max).count() + 1;
    let progress =
        crate::progress::Progress::new(bodies.iter().map(|&n| runs_per_cell(n) * args.grid.speeds.len()).sum());
    let mut rows = Vec::new();
    for &n in &bodies {
        for &speed in &args.grid.speeds {
            let frames = frames_for(n);
            let common_args = |job: &str, out: &Path| -> Vec<String> {
                let values = [
                    job.to_string(),
                    scene.name().to_string(),
                    n.to_string(),
                    speed.to_string(),
                    frames.to_string(),
                    out.display().to_string(),
                ];
                ["--job", "--scene", "--bodies", "--speed", "--frames", "--out"]
                    .iter()
                    .zip(values)
                    .flat_map(|(f, v)| [f.to_string(), v])
                    .collect()
            };
            let reference_kind = if n <= brute_max { "brute force" } else { "auto" };
            let what = format!("n={n} speed={speed}: paths and the {reference_kind} reference");
            progress.start(&what);
            let mut export = common_args("peers-export", &scratch);
            if n <= brute_max {
                export.push("--brute".to_string());
            }
            let exported =
                runner.child(&export, runner.timeout * 4).and_then(|_| trajectory::read_contacts(&reference_file));
            progress.done(&match &exported {
                Ok(reference) => format!("{what}: {} pair contacts", reference.len()),
                Err(e) => format!("{what}: {e}"),
            });
            for &(name, continuous, program) in &pipelines {
                if name == "vadop-brute" && n > brute_max {
                    continue;
                }
                let what = format!("n={n} speed={speed} {name}");
                progress.start(&what);
                let outcome = match &exported {
                    Err(e) => Err(format!("export failed: {e}")),
                    Ok(reference) => {
                        let printed = match program {
                            Program::Vadop(method) => {
                                let mut job = common_args("peers-time", &contacts);
                                job.extend(["--method".to_string(), method.to_string()]);
                                runner.child(&job, runner.timeout)
                            }
                            Program::PlainGrid => {
                                let mut job = common_args("peers-plain-grid", &contacts);
                                job.extend(["--trajectory".to_string(), trajectory.display().to_string()]);
                                runner.child(&job, runner.timeout)
                            }
                            other => {
                                let arguments = [
                                    name.to_string(),
                                    trajectory.display().to_string(),
                                    contacts.display().to_string(),
                                ];
                                runner.run(&programs.path(other), &arguments, runner.timeout)
                            }
                        };
                        printed.and_then(|stdout| measure(&stdout, &contacts, reference))
                    }
                };
                progress.done(&match &outcome {
                    Ok(m) => format!(
                        "{what}: {:.3} ms/frame, {} found, {} missed, {} false, {:.0} MiB",
                        m.mean_ms, m.found, m.missed, m.false_contacts, m.peak_mib
                    ),
                    Err(e) => format!("{what}: {e}"),
                });
                rows.push(Row { bodies: n, speed, frames, pipeline: name, continuous, outcome });
            }
            for file in [&trajectory, &reference_file, &contacts] {
                let _ = std::fs::remove_file(file);
            }
            // Written after every cell, so a benchmark stopped early still leaves its rows.
            outputs.write(&rows, false)?;
        }
    }
    progress.finish();
    let section = outputs.write(&rows, true)?;
    crate::common::print(&format!("{section}\nwrote {} and {}\n", markdown_path.display(), results.display()))
}

/// Where a run's table, CSV and plot go, and what their text says about the run.
struct Outputs<'a> {
    scene: Scene,
    markdown: &'a Path,
    results: &'a Path,
    brute_max: usize,
    info: &'a RunInfo,
}

impl Outputs<'_> {
    /// Writes the CSV, the markdown section and (when `plot`) the PNG; returns the section.
    fn write(&self, rows: &[Row], plot: bool) -> CliResult<String> {
        let stem = self.scene.file_stem();
        write_csv(&self.results.join(format!("{stem}.csv")), rows)?;
        let png = self.results.join(format!("{stem}.png"));
        let plotted = plot
            && match write_plot(self.scene, rows, &png) {
                Ok(()) => true,
                Err(e) => {
                    eprintln!("no plot: {e}");
                    false
                }
            };
        let section = markdown_section(self, rows, plotted.then(|| markdown::link(self.markdown, &png)));
        markdown::write_section(self.markdown, self.scene.markers(), &section)?;
        Ok(section)
    }
}

/// The directory holding `bench/peers`, searched upwards from the current directory.
fn repository_root() -> CliResult<PathBuf> {
    let here = std::env::current_dir().map_err(|e| format!("cannot read the current directory: {e}"))?;
    here.ancestors()
        .find(|dir| dir.join("bench/peers/cpp/Makefile").is_file())
        .map(Path::to_path_buf)
        .ok_or_else(|| "run `vadop-bench peers` inside the vadop repository (bench/peers/ not found)".to_string())
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
            Program::Rapier | Program::Vadop(_) | Program::PlainGrid => self.rapier.clone(),
        }
    }
}

/// Checks that the libraries and tools of the peers among `pipelines` are present, then builds
/// the C++ and rapier peers they need (both builds do nothing when up to date), so vadop's own
/// pipelines and the reference grid run without them. Installing system packages is left to
/// scripts/install-peers.sh, run as root: this program only says what is missing.
fn build_peers(pipelines: &[(&str, bool, Program)]) -> CliResult<Programs> {
    let needs = |wanted: fn(&Program) -> bool| pipelines.iter().any(|p| wanted(&p.2));
    let peers = |p: &Program| !matches!(p, Program::Vadop(_) | Program::PlainGrid);
    // vadop's own pipelines run anywhere: the repository is looked for only when a peer runs.
    let root = if needs(peers) { repository_root()? } else { PathBuf::new() };
    let cpp = root.join("bench/peers/cpp");
    let rapier = root.join("bench/peers/rapier");
    let programs = Programs {
        bullet: cpp.join("build/peer-bullet"),
        fcl: cpp.join("build/peer-fcl"),
        rapier: rapier.join("target/release/vadop-peer-rapier"),
    };
    if needs(|p| matches!(p, Program::Bullet | Program::Fcl)) {
        check_libraries(&root)?;
        eprintln!("building the Bullet and FCL peers (make -C {})", cpp.display());
        checked(Command::new("make").arg("-s").arg("-C").arg(&cpp), "make")?;
    }
    if needs(|p| matches!(p, Program::Rapier)) {
        eprintln!("building the rapier/parry peer (cargo build --release in {})", rapier.display());
        checked(
            Command::new("cargo").args(["build", "--release", "-q", "--manifest-path"]).arg(rapier.join("Cargo.toml")),
            "cargo build of bench/peers/rapier",
        )?;
    }
    Ok(programs)
}

/// Fails, saying what to run, when a library or tool of the C++ peers is missing.
fn check_libraries(root: &Path) -> CliResult<()> {
    let runs = |program: &str| Command::new(program).arg("--version").output().is_ok();
    // Each requirement by the Debian package that brings it.
    let present = [
        ("libbullet-dev", Path::new("/usr/include/bullet/btBulletCollisionCommon.h").is_file()),
        ("libfcl-dev", Path::new("/usr/include/fcl/fcl.h").is_file()),
        ("build-essential", runs("g++") && runs("make")),
        ("pkg-config", runs("pkg-config")),
    ];
    let missing: Vec<&str> = present.iter().filter(|p| !p.1).map(|p| p.0).collect();
    if !missing.is_empty() {
        return Err(format!(
            "the peers need Debian's {}, missing here: run `{}` as root (it installs them with apt-get), then run this again",
            missing.join(", "),
            root.join("scripts/install-peers.sh").display()
        ));
    }
    Ok(())
}

fn checked(command: &mut Command, what: &str) -> CliResult<()> {
    let status = command.status().map_err(|e| format!("{what}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{what} failed ({status})"))
    }
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
    if summary.frame_ms.is_empty() {
        return Err("no frames".into());
    }
    let mean_ms = summary.frame_ms.iter().sum::<f64>() / summary.frame_ms.len() as f64;
    let found = trajectory::read_contacts(contacts)?;
    let (matched, missed, false_contacts) = compare(reference, &found);
    Ok(Measured {
        mean_ms,
        peak_mib: summary.peak_kib as f64 / 1024.0,
        found: matched,
        missed,
        false_contacts,
        reference: reference.len() as u64,
    })
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

fn write_csv(path: &Path, rows: &[Row]) -> CliResult<()> {
    let mut text = String::from(
        "n,speed,pipeline,kind,frames,status,mean_ms,found,missed,false,reference,peak_mib,time_vs_auto\n",
    );
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
                m.mean_ms,
                m.found,
                m.missed,
                m.false_contacts,
                m.reference,
                m.peak_mib,
                ratio(rows, row).map_or(String::new(), |r| format!("{r:.3}"))
            ),
            Err(e) => writeln!(
                text,
                "{},{},{},{kind},{},{},,,,,,,",
                row.bodies,
                row.speed,
                row.pipeline,
                row.frames,
                e.replace(',', ";")
            ),
        };
    }
    write_file(path, &text)
}

/// Reads the rows of a CSV written by `write_csv` (or by the former `vadop peers`, whose times
/// were medians over frames).
pub fn read_csv(path: &Path) -> CliResult<Vec<Row>> {
    let text = std::fs::read_to_string(path).map_err(|e| crate::common::io_error(path, e))?;
    let bad = |line: usize, what: &str| format!("{}:{}: {what}", path.display(), line + 1);
    let mut rows = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 13 {
            return Err(bad(k, "expected 13 fields"));
        }
        let &(pipeline, continuous, _) =
            PIPELINES.iter().find(|p| p.0 == f[2]).ok_or_else(|| bad(k, "unknown pipeline"))?;
        let number = |i: usize| f[i].parse::<f64>().map_err(|_| bad(k, &format!("bad number {:?}", f[i])));
        let outcome = if f[5] == "ok" {
            Ok(Measured {
                mean_ms: number(6)?,
                found: number(7)? as u64,
                missed: number(8)? as u64,
                false_contacts: number(9)? as u64,
                reference: number(10)? as u64,
                peak_mib: number(11)?,
            })
        } else {
            Err(f[5].to_string())
        };
        rows.push(Row {
            bodies: number(0)? as usize,
            speed: number(1)?,
            frames: number(4)? as u64,
            pipeline,
            continuous,
            outcome,
        });
    }
    Ok(rows)
}

/// This row's time divided by the default method's on the same cell.
fn ratio(rows: &[Row], row: &Row) -> Option<f64> {
    let auto = rows.iter().find(|r| r.bodies == row.bodies && r.speed == row.speed && r.pipeline == BASELINE)?;
    Some(row.outcome.as_ref().ok()?.mean_ms / auto.outcome.as_ref().ok()?.mean_ms)
}

/// Mean ms/frame against n, one panel per speed, one line per pipeline: continuous solid,
/// discrete dashed, each pipeline in the same colour in every panel.
fn write_plot(scene: Scene, rows: &[Row], png: &Path) -> CliResult<()> {
    let mut speeds: Vec<f64> = rows.iter().map(|r| r.speed).collect();
    speeds.sort_by(f64::total_cmp);
    speeds.dedup();
    let panels: Vec<Panel> = speeds
        .iter()
        .map(|&speed| Panel {
            title: format!("max speed {speed} diameters/frame"),
            x_label: "bodies n".to_string(),
            y_label: "mean ms per frame".to_string(),
            series: PIPELINES
                .iter()
                .filter_map(|&(name, continuous, _)| {
                    let points: Vec<(f64, f64)> = rows
                        .iter()
                        .filter(|r| r.speed == speed && r.pipeline == name)
                        .filter_map(|r| Some((r.bodies as f64, r.outcome.as_ref().ok()?.mean_ms)))
                        .collect();
                    let stroke = if continuous { Stroke::Solid } else { Stroke::Dashed };
                    (!points.is_empty()).then(|| Series::new(name, points).styled(colour(name), stroke))
                })
                .collect(),
        })
        .collect();
    let title = match scene {
        Scene::Spheres => "Peers: detection time per frame on identical paths",
        Scene::Shapes => "Peers, mixed spinning shapes: detection time per frame on identical paths",
    };
    plots::line_panels(png, Some(title), &panels)
}

/// A fixed colour per pipeline: vadop's in reds, the reference grid in cyan, Bullet's in blues,
/// FCL's in greens, rapier's in purple and browns.
fn colour(pipeline: &str) -> &'static str {
    match pipeline {
        "vadop-auto" => "#d62728",
        "vadop" => "#ff7f0e",
        "vadop-brute" => "#ff9896",
        "vadop-discrete" => "#e377c2",
        REFERENCE => "#17becf",
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

fn markdown_section(outputs: &Outputs, rows: &[Row], plot: Option<String>) -> String {
    let (info, brute_max) = (outputs.info, outputs.brute_max);
    let mut md = String::new();
    let _ = writeln!(md, "{}", info.header());
    if let Some(csv) = info.command().split_whitespace().skip_while(|a| *a != "--render").nth(1) {
        let _ = writeln!(md, "Rows measured by `vadop-bench peers` into `{csv}`, drawn again by the command above.\n");
    }
    let scene = match outputs.scene {
        Scene::Spheres => format!("Paper scene, packing fraction {PACKING}, seed 1"),
        Scene::Shapes => format!(
            "Mixed-shape scene: spheres, cuboids, capsules, cylinders, cones and a convex hull in equal shares, each at \
             most one unit across, packing fraction {PACKING} in the middle of a box whose walls no body reaches in the \
             run, random orientations, spins of up to {} radian per frame about a principal axis (a steady spin: \
             vadop's torque-free rotation and the peers' constant angular velocity are the same motion), seed 1",
            shapes::MAX_SPIN
        ),
    };
    let _ = writeln!(
        md,
        "{scene}, detect mode: every pipeline reads the same exported paths. \
         A contact is a (frame, i, j) pair that begins touching during the frame; the reference comes from vadop's \
         brute force for n <= {brute_max} and from the default method (auto) above. ms/frame is the mean over frames \
         of the detection work (reading the file excluded): vadop's broad phases rebuild once per window of several \
         frames, so single frames are cheap or dear, and over few frames (large n) the mean carries a whole window \
         start. Peak MiB is the run's VmHWM; × auto is the time divided by vadop-auto's (the default method) on the \
         same row group (above 1: slower than the default).\n"
    );
    if outputs.scene == Scene::Shapes {
        let _ = writeln!(
            md,
            "Each library decides touching within its own tolerance, so grazing pairs may differ: vadop within 1e-6 of \
             the pair's bounding radii (1e-9 for two spheres); parry's nonlinear cast (double precision) at its GJK \
             convergence threshold; Bullet's btContinuousConvexCollision within 0.001 length units, in single precision; \
             FCL's conservative advancement within 1e-4 of the frame in time. A pair that overlaps at the frame \
             start, separates and touches again within the frame is a contact for vadop, while the peers' casts stop \
             at the first time of impact, the frame start: they miss it. Every library has all six shapes; \
             vadop-discrete does not run (vadop's discrete method handles spheres only), nor does plain-grid (a \
             reference for spheres).\n"
        );
    } else {
        let _ = writeln!(
            md,
            "plain-grid is a reference, neither a library nor a product method: about 300 lines of this benchmark \
             (crates/vadop-bench/src/peers/plain_grid.rs) in which nothing persists between frames. Each frame it puts \
             every body's box around its whole path in the frame (f32 bounds rounded outward) into cubic cells 1.5x \
             the mean box edge by a counting sort, and tests each overlapping pair once with vadop's closed-form sphere \
             time on every straight piece of the frame. It is what the plainest exact broad phase costs on these \
             paths; the goal check below gives auto ÷ plain-grid, the default method's time over the grid's (below 1: \
             the default is faster).\n"
        );
    }
    let _ = writeln!(
        md,
        "| n | speed | pipeline | kind | frames | mean ms/frame | found | missed | false | peak MiB | × auto |"
    );
    let _ = writeln!(md, "|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for row in rows {
        let kind = if row.continuous { "continuous" } else { "discrete" };
        let cells = match &row.outcome {
            Ok(m) => format!(
                "{:.3} | {} | {} | {} | {:.1} | {}",
                m.mean_ms,
                m.found,
                m.missed,
                m.false_contacts,
                m.peak_mib,
                ratio(rows, row).map_or("—".to_string(), |r| format!("{r:.2}"))
            ),
            Err(e) => format!("{} | — | — | — | — | —", markdown::table_cell(e)),
        };
        let _ =
            writeln!(md, "| {} | {} | {} | {kind} | {} | {cells} |", row.bodies, row.speed, row.pipeline, row.frames);
    }
    let _ = writeln!(md);
    if let Some(plot) = plot {
        let _ = writeln!(md, "![mean ms per frame against n]({plot})\n");
    }
    let _ = writeln!(md, "Goal check, per row group (n >= 10000), from the rows above:\n");
    let mut cells: Vec<(usize, f64)> = rows.iter().map(|r| (r.bodies, r.speed)).collect();
    cells.dedup();
    for (n, speed) in cells.into_iter().filter(|c| c.0 >= 10_000) {
        let group: Vec<&Row> = rows.iter().filter(|r| r.bodies == n && r.speed == speed).collect();
        let Some(Ok(auto)) = group.iter().find(|r| r.pipeline == BASELINE).map(|r| &r.outcome) else {
            let _ = writeln!(md, "- n={n}, speed {speed}: vadop-auto did not finish.");
            continue;
        };
        let peers = |continuous: bool| {
            group.iter().filter(move |r| {
                r.continuous == continuous && !r.pipeline.starts_with("vadop") && r.pipeline != REFERENCE
            })
        };
        let faster_continuous: Vec<String> = peers(true)
            .filter_map(|r| {
                r.outcome
                    .as_ref()
                    .ok()
                    .filter(|m| m.mean_ms <= auto.mean_ms)
                    .map(|m| format!("{} ({:.3} ms)", r.pipeline, m.mean_ms))
            })
            .collect();
        let fastest = |rows: &mut dyn Iterator<Item = &&Row>| {
            rows.filter_map(|r| r.outcome.as_ref().ok().map(|m| (r.pipeline, m.mean_ms)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        };
        let fastest_discrete = fastest(&mut peers(false));
        let fastest_exact = fastest(&mut peers(true).filter(|r| r.exact()));
        let exact = if auto.missed == 0 && auto.false_contacts == 0 { "exact" } else { "NOT exact" };
        let versus_continuous = if faster_continuous.is_empty() {
            "faster than every continuous peer that finished".to_string()
        } else {
            format!("NOT faster than {}", faster_continuous.join(", "))
        };
        let versus_discrete = match fastest_discrete {
            Some((name, ms)) if ms < auto.mean_ms => format!(
                "slower than the fastest discrete peer, {name} ({ms:.3} ms, {:.2}x auto's time)",
                ms / auto.mean_ms
            ),
            Some((name, ms)) => format!("not slower than the fastest discrete peer, {name} ({ms:.3} ms)"),
            None => "no discrete peer finished".to_string(),
        };
        let versus_exact = match fastest_exact {
            Some((name, ms)) => format!("{:.2}x the fastest exact peer's time, {name} ({ms:.3} ms)", auto.mean_ms / ms),
            None => "no peer was exact".to_string(),
        };
        let grid = group.iter().find(|r| r.pipeline == REFERENCE).map(|r| &r.outcome);
        let versus_grid = match grid {
            Some(Ok(grid)) => {
                format!("; auto ÷ plain-grid {:.2} ({:.3} ms)", auto.mean_ms / grid.mean_ms, grid.mean_ms)
            }
            Some(Err(_)) => "; plain-grid did not finish".to_string(),
            None => String::new(),
        };
        // Issue 28's goal: exact, no slower than the plain grid, at most half the fastest exact
        // peer's time.
        let issue = match (grid, fastest_exact) {
            (Some(Ok(grid)), Some((_, peer))) => {
                let met = exact == "exact" && auto.mean_ms <= grid.mean_ms && auto.mean_ms <= PEER_GOAL * peer;
                format!(
                    "; issue 28 (exact, ≤ plain-grid, ≤ {PEER_GOAL}x the fastest exact peer): {}",
                    if met { "met" } else { "MISSED" }
                )
            }
            _ => String::new(),
        };
        let _ = writeln!(
            md,
            "- n={n}, speed {speed}: auto {:.3} ms, {exact}; {versus_continuous}; {versus_discrete}; \
             {versus_exact}{versus_grid}{issue}.",
            auto.mean_ms
        );
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contact_sets_compare() {
        assert_eq!(compare(&[[0, 5, 9], [1, 2, 3]], &[[0, 5, 9], [2, 0, 1]]), (1, 1, 1));
    }
}
