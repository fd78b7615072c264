//! `vadop simulate`: builds the scene and the world, steps it frame by frame (with a reference
//! method stepped alongside when asked, to count missed and extra pair contacts), streams the
//! contacts file, and hands the frames to the report. It owns the frame loop and the accuracy
//! comparison. It never validates physics input itself: the core library checks scenes, pools,
//! angles, restitution and time steps, and its messages are what the user sees. A frame that
//! fails stops the run, but what was simulated before it is still reported and written.

use crate::report::{self, Accuracy, Conservation, FrameRow, PoolInfo, RunInfo, SceneInfo, Summary};
use crate::CliResult;
use clap::{Args, ValueEnum};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::str::FromStr;
use std::time::{Duration, Instant};
use vadop::scene::{PaperScene, Scene, FRAMES_PER_SECOND};
use vadop::{Contact, Method, Mode, Touched, VadopError, World, WorldConfig};

/// Scenes up to this many bodies are checked against brute force unless told otherwise.
const DEFAULT_REFERENCE_MAX_BODIES: usize = 3000;
/// Runs shorter than this finish before a progress bar would help.
const PROGRESS_DELAY: Duration = Duration::from_secs(2);

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Scene file (JSON: {"bounds": {"min": [x,y,z], "max": [x,y,z]}, "spheres": [{"position",
    /// "velocity", "radius", "mass"}, ...]}) instead of the paper's scene
    #[arg(long, value_name = "FILE", help_heading = "Scene")]
    scene: Option<PathBuf>,
    /// Number of spheres in the paper's scene
    #[arg(long, value_name = "N", default_value_t = 1000, conflicts_with = "scene", help_heading = "Scene")]
    bodies: usize,
    /// Fraction of the box volume the spheres fill, in (0, 0.6]
    #[arg(long, value_name = "F", default_value_t = 0.05, allow_negative_numbers = true, conflicts_with = "scene", help_heading = "Scene")]
    packing: f64,
    /// Speeds are uniform in [0, S] sphere diameters per frame (at 30 frames per second)
    #[arg(long, value_name = "S", default_value_t = 0.5, allow_negative_numbers = true, conflicts_with = "scene", help_heading = "Scene")]
    max_speed: f64,
    /// Seed of the scene generator
    #[arg(long, value_name = "K", default_value_t = 1, conflicts_with = "scene", help_heading = "Scene")]
    seed: u64,
    /// Continue a run saved with --save-state for --frames more frames, bit-exactly; the
    /// world's method, mode, pool, phi and restitution come from the file
    #[arg(long, value_name = "FILE", conflicts_with_all = ["scene", "bodies", "packing", "max_speed", "seed"], help_heading = "Scene")]
    resume: Option<PathBuf>,

    /// Number of frames to step
    #[arg(long, value_name = "F", default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..), help_heading = "Run")]
    frames: u64,
    /// detect: bodies pass through each other and only bounce off the walls, so every method
    /// follows identical paths; simulate: bodies also collide with each other
    #[arg(long, value_enum, default_value_t = ModeArg::Simulate, help_heading = "Run")]
    mode: ModeArg,
    /// Where candidate pairs come from: vadop (continuous, velocity-aligned volumes), brute
    /// (continuous, every pair), discrete (overlap checks at frame instants only), or the
    /// continuous baselines swept-aabb (classic sweep and prune over swept boxes), swept-kdop (all
    /// pool axes for every body) and grid (uniform grid over swept boxes)
    #[arg(long, value_enum, default_value_t = MethodArg::Auto, help_heading = "Run")]
    method: MethodArg,
    /// Method stepped alongside on the same scene to count missed and extra pair contacts
    /// [default: brute for at most 3000 bodies unless --method is brute, else none]
    #[arg(long, value_enum, help_heading = "Run")]
    reference: Option<ReferenceArg>,

    /// Number of pool axes m, or auto to choose from the bodies' speeds
    #[arg(long, value_name = "M|auto", default_value = "auto", help_heading = "World")]
    pool: PoolSize,
    /// Alignment angle phi in degrees, at least the pool's covering radius rho [default: rho]
    #[arg(long, value_name = "DEGREES", allow_negative_numbers = true, help_heading = "World")]
    phi: Option<f64>,
    /// Coefficient of restitution of every impact, in [0, 1]
    #[arg(long, value_name = "E", default_value_t = 1.0, allow_negative_numbers = true, help_heading = "World")]
    restitution: f64,
    /// Contact duration t_c of the TC model in seconds: with restitution below 1, a contact of a
    /// body whose previous contact lies less than t_c before is elastic, which ends inelastic
    /// collapse
    #[arg(long, value_name = "SECONDS", default_value_t = vadop::collapse::DEFAULT_CONTACT_DURATION, allow_negative_numbers = true, help_heading = "World")]
    contact_duration: f64,
    /// Frame length in seconds
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0 / FRAMES_PER_SECOND, allow_negative_numbers = true, help_heading = "World")]
    dt: f64,

    /// Write one CSV row per frame (counters and the cost split in ms)
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    csv: Option<PathBuf>,
    /// Write the summary and the per-frame rows as JSON
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    json: Option<PathBuf>,
    /// Write every contact as CSV (frame, time, body, what it touched, point, normal, impulse)
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    contacts: Option<PathBuf>,
    /// Save the scene, before stepping, as a scene file
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    save_scene: Option<PathBuf>,
    /// Save the whole world after every frame (atomically: a run killed mid-way loses at most
    /// the frame in progress), to continue with --resume
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    save_state: Option<PathBuf>,
    /// Print no summary and no progress bar (errors still go to stderr)
    #[arg(long, help_heading = "Output")]
    quiet: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum MethodArg {
    Auto,
    Vadop,
    Brute,
    Discrete,
    SweptAabb,
    SweptKdop,
    Grid,
}

impl MethodArg {
    fn method(self) -> Method {
        match self {
            MethodArg::Auto => Method::Auto,
            MethodArg::Vadop => Method::Vadop,
            MethodArg::Brute => Method::Brute,
            MethodArg::Discrete => Method::Discrete,
            MethodArg::SweptAabb => Method::SweptAabb,
            MethodArg::SweptKdop => Method::SweptKdop,
            MethodArg::Grid => Method::Grid,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ModeArg {
    Detect,
    Simulate,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ReferenceArg {
    Brute,
    Vadop,
    None,
}

/// `--pool`: a number of axes, or `auto` (chosen by the world at its first step).
#[derive(Debug, Clone, Copy)]
struct PoolSize(Option<usize>);

impl FromStr for PoolSize {
    type Err = String;
    fn from_str(text: &str) -> Result<PoolSize, String> {
        if text == "auto" {
            return Ok(PoolSize(None));
        }
        // The range is the core's to check, so its message names the supported sizes.
        text.parse().map(|m| PoolSize(Some(m))).map_err(|_| format!("expected a number of axes or auto, got {text}"))
    }
}

/// The core's message, with phi in degrees as the user gave it (the core works in radians).
fn describe(error: VadopError) -> String {
    match error {
        VadopError::BadPhi { got, rho } => format!(
            "--phi {} degrees: phi must lie in [rho, 90] degrees, where rho = {:.4} degrees is the covering radius of the pool, so that every pair of bodies shares an axis",
            got.to_degrees(),
            rho.to_degrees()
        ),
        other => other.to_string(),
    }
}

pub fn run(args: &SimulateArgs) -> CliResult<()> {
    if let Some(path) = &args.resume {
        return resume(path, args);
    }
    let (scene, source) = match &args.scene {
        Some(path) => (Scene::load(path).map_err(describe)?, format!("scene file {}", path.display())),
        None => {
            let paper = PaperScene { seed: args.seed, ..PaperScene::new(args.bodies, args.packing, args.max_speed) };
            let source = format!("paper scene (seed {}, speeds up to {} diameters/frame)", args.seed, args.max_speed);
            (paper.build().map_err(describe)?, source)
        }
    };
    let config = WorldConfig {
        method: args.method.method(),
        mode: match args.mode {
            ModeArg::Detect => Mode::Detect,
            ModeArg::Simulate => Mode::Simulate,
        },
        pool_axes: args.pool.0,
        phi: args.phi.map(f64::to_radians),
        restitution: args.restitution,
        contact_duration: args.contact_duration,
    };
    let reference = match args.reference {
        Some(ReferenceArg::Brute) => Some(Method::Brute),
        Some(ReferenceArg::Vadop) => Some(Method::Vadop),
        Some(ReferenceArg::None) => None,
        // Checking brute force against itself would only double the cost.
        None => (scene.spheres.len() <= DEFAULT_REFERENCE_MAX_BODIES && config.method != Method::Brute).then_some(Method::Brute),
    };
    let world = scene.world(config).map_err(describe)?;
    let reference_world = match reference {
        Some(method) => Some(scene.world(WorldConfig { method, ..config }).map_err(describe)?),
        None => None,
    };
    run_world(world, reference_world, scene, source, args)
}

/// `--resume FILE`: the saved world, stepped on without a reference (a reference would need the
/// state it had when the world was saved).
fn resume(path: &std::path::Path, args: &SimulateArgs) -> CliResult<()> {
    if matches!(args.reference, Some(ReferenceArg::Brute | ReferenceArg::Vadop)) {
        return Err("--resume cannot be combined with --reference: the reference's state was not saved".to_string());
    }
    let world = World::load(path).map_err(describe)?;
    let scene = Scene { bounds: world.bounds(), spheres: world.spheres().map(|(_, s)| s).collect() };
    let source = format!("saved world {} at time {}", path.display(), world.time());
    run_world(world, None, scene, source, args)
}

/// Steps `world` (and `reference_world` alongside), then reports and writes the outputs.
fn run_world(world: World, reference_world: Option<World>, scene: Scene, source: String, args: &SimulateArgs) -> CliResult<()> {
    let config = world.config();
    let outputs = Outputs::open(args)?;
    if let Some(path) = &args.save_scene {
        scene.save(path).map_err(describe)?;
    }
    let info = RunInfo {
        scene: SceneInfo::of(&scene, source, args.dt),
        method: config.method.name().to_string(),
        mode: match config.mode {
            Mode::Detect => "detect",
            Mode::Simulate => "simulate",
        }
        .to_string(),
        dt: args.dt,
        restitution: config.restitution,
        frames_requested: args.frames,
    };
    // The scene is no longer needed; at a million bodies it is worth giving back before stepping.
    drop(scene);
    let outcome = step_frames(world, reference_world, args, outputs.contacts)?;

    let summary = Summary::new(
        info,
        &outcome.rows,
        outcome.pool,
        outcome.accuracy,
        outcome.conservation,
        outcome.failure.clone(),
    );
    if !args.quiet && !outcome.rows.is_empty() {
        report::print(&summary.to_string())?;
    }
    if let Some((file, path)) = outputs.csv {
        report::write_frames_csv(file, &path, &outcome.rows)?;
    }
    if let Some((file, path)) = outputs.json {
        report::write_json(file, &path, &summary, &outcome.rows)?;
    }
    match outcome.failure {
        Some(message) => Err(message),
        None => Ok(()),
    }
}

/// Output files, created before the run so that a bad path fails before any work is done.
struct Outputs {
    csv: Option<(File, PathBuf)>,
    json: Option<(File, PathBuf)>,
    contacts: Option<ContactWriter>,
}

impl Outputs {
    fn open(args: &SimulateArgs) -> CliResult<Outputs> {
        let open = |path: &Option<PathBuf>| -> CliResult<Option<(File, PathBuf)>> {
            path.as_ref().map(|p| report::create_file(p).map(|file| (file, p.clone()))).transpose()
        };
        Ok(Outputs {
            csv: open(&args.csv)?,
            json: open(&args.json)?,
            contacts: open(&args.contacts)?.map(|(file, path)| ContactWriter::new(file, path)).transpose()?,
        })
    }
}

/// The contacts CSV, streamed frame by frame because it can be far larger than memory allows.
struct ContactWriter {
    out: BufWriter<File>,
    path: PathBuf,
}

impl ContactWriter {
    fn new(file: File, path: PathBuf) -> CliResult<ContactWriter> {
        let mut writer = ContactWriter { out: BufWriter::new(file), path };
        writer.line(format_args!("frame,time,body,touched,other,point_x,point_y,point_z,normal_x,normal_y,normal_z,impulse"))?;
        Ok(writer)
    }

    fn line(&mut self, line: std::fmt::Arguments<'_>) -> CliResult<()> {
        writeln!(self.out, "{line}").map_err(|e| report::io_error(&self.path, e))
    }

    fn frame(&mut self, frame: u64, contacts: &[Contact]) -> CliResult<()> {
        for c in contacts {
            let (kind, other) = match c.touched {
                Touched::Body(id) => ("body", id.to_string()),
                Touched::Wall(wall) => ("wall", format!("{wall:?}")),
            };
            let (p, n) = (c.point, c.normal);
            self.line(format_args!(
                "{frame},{},{},{kind},{other},{},{},{},{},{},{},{}",
                c.time, c.body, p.x, p.y, p.z, n.x, n.y, n.z, c.impulse
            ))?;
        }
        Ok(())
    }

    fn finish(mut self) -> CliResult<()> {
        self.out.flush().map_err(|e| report::io_error(&self.path, e))
    }
}

/// What the frame loop produced.
struct Outcome {
    rows: Vec<FrameRow>,
    pool: Option<PoolInfo>,
    accuracy: Option<Accuracy>,
    conservation: Option<Conservation>,
    /// Why the run stopped early.
    failure: Option<String>,
}

/// Steps `world` (and `reference` alongside) for the requested frames, or until a frame fails.
fn step_frames(
    mut world: World,
    mut reference: Option<World>,
    args: &SimulateArgs,
    mut contacts_out: Option<ContactWriter>,
) -> CliResult<Outcome> {
    let simulate = world.config().mode == Mode::Simulate;
    let (kinetic_start, momentum_start) = (world.kinetic_energy(), world.momentum());
    let mut accuracy = reference.as_ref().map(|r| Accuracy {
        reference: r.config().method.name().to_string(),
        identical_paths: !simulate,
        ..Accuracy::default()
    });
    let mut rows = Vec::new();
    let mut failure = None;
    let bar = report::progress_bar(args.frames, "frames");
    let started = Instant::now();
    let mut may_reveal = !args.quiet;
    for frame in 1..=args.frames {
        let start = Instant::now();
        let contacts = match world.step(args.dt) {
            Ok(contacts) => contacts,
            Err(e) => {
                failure = Some(format!("frame {frame}: {}", describe(e)));
                break;
            }
        };
        let wall_seconds = start.elapsed().as_secs_f64();
        if let Some(out) = &mut contacts_out {
            if let Err(e) = out.frame(frame, contacts) {
                failure = Some(e);
                break;
            }
        }
        let pairs = pair_contacts(contacts);
        if let (Some(reference), Some(accuracy)) = (&mut reference, &mut accuracy) {
            match reference.step(args.dt) {
                Ok(expected) => {
                    let expected = pair_contacts(expected);
                    let (missed, extra) = differences(&expected, &pairs);
                    accuracy.reference_pairs += expected.len() as u64;
                    accuracy.missed += missed;
                    accuracy.extra += extra;
                    if missed + extra > 0 && accuracy.first_difference_frame.is_none() {
                        accuracy.first_difference_frame = Some(frame);
                    }
                }
                Err(e) => {
                    failure = Some(format!("frame {frame}: reference method: {}", describe(e)));
                    break;
                }
            }
        }
        if let Some(path) = &args.save_state {
            if let Err(e) = world.save(path) {
                failure = Some(format!("frame {frame}: {}", describe(e)));
                break;
            }
        }
        rows.push(FrameRow::new(frame, world.time(), world.stats(), wall_seconds));
        bar.inc(1);
        if may_reveal && started.elapsed() > PROGRESS_DELAY {
            report::reveal(&bar);
            may_reveal = false;
        }
    }
    bar.finish_and_clear();
    if let Some(out) = contacts_out {
        // A failed flush loses contacts, not frames: it is reported like a failed frame.
        if let Err(e) = out.finish() {
            failure.get_or_insert(e);
        }
    }

    let pool = Some(world.pool()).filter(|_| matches!(world.config().method, Method::Vadop | Method::SweptKdop)).map(|pool| {
        let rho = pool.covering_radius();
        let entries: u64 = rows.iter().map(|r| r.list_entries).sum();
        PoolInfo {
            axes: pool.len(),
            covering_radius_deg: rho.to_degrees(),
            phi_deg: world.config().phi.unwrap_or(rho).to_degrees(),
            axes_per_body: entries as f64 / (rows.len().max(1) * world.len()) as f64,
        }
    });
    let conservation = simulate.then(|| {
        let (kinetic_end, momentum_end) = (world.kinetic_energy(), world.momentum());
        Conservation {
            kinetic_start,
            kinetic_end,
            kinetic_relative_drift: (kinetic_start > 0.0).then(|| (kinetic_end - kinetic_start) / kinetic_start),
            momentum_start: momentum_start.to_array(),
            momentum_end: momentum_end.to_array(),
            momentum_change: (momentum_end - momentum_start).length(),
        }
    });
    Ok(Outcome { rows, pool, accuracy, conservation, failure })
}

/// The body-body contacts of a frame as sorted (lower id, higher id) pairs.
fn pair_contacts(contacts: &[Contact]) -> Vec<(u32, u32)> {
    let mut pairs: Vec<(u32, u32)> = contacts
        .iter()
        .filter_map(|c| match c.touched {
            Touched::Body(other) => Some((c.body.min(other), c.body.max(other))),
            Touched::Wall(_) => None,
        })
        .collect();
    pairs.sort_unstable();
    pairs
}

/// (missed, extra): entries of `expected` absent from `found` and the reverse, as multisets, so a
/// pair that touches twice in a frame must be found twice. Both inputs are sorted.
fn differences(expected: &[(u32, u32)], found: &[(u32, u32)]) -> (u64, u64) {
    let (mut i, mut j, mut missed, mut extra) = (0, 0, 0u64, 0u64);
    while i < expected.len() && j < found.len() {
        match expected[i].cmp(&found[j]) {
            std::cmp::Ordering::Less => {
                missed += 1;
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                extra += 1;
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
    }
    (missed + (expected.len() - i) as u64, extra + (found.len() - j) as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_count_multisets() {
        let expected = [(0, 1), (0, 1), (2, 3), (4, 5)];
        let found = [(0, 1), (2, 3), (6, 7)];
        assert_eq!(differences(&expected, &found), (2, 1));
        assert_eq!(differences(&found, &found), (0, 0));
    }
}
