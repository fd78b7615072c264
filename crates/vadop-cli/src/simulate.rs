//! `vadop simulate`: checks the files it will read and write, builds the scene and the world,
//! steps it frame by frame (with a reference method stepped alongside when asked, to count missed
//! and extra pair contacts), streams the contacts and the per-frame rows to their files, and
//! hands the totals to the report. It owns the frame loop, the accuracy comparison, the rules on
//! output files and the agreement of the contacts file with the saved state. It never validates
//! physics input itself: the core library checks scenes, pools, angles, restitution and time
//! steps, and its messages are what the user sees. A frame that fails stops the run, but what was
//! simulated before it is still reported and written. Nothing it keeps grows with the frames.

use crate::report::{
    self, Accuracy, Conservation, FrameRow, FrameTotals, FramesCsv, JsonReport, Motion, OutputFile, PoolInfo, RunInfo,
    SceneInfo, Summary,
};
use crate::CliResult;
use clap::{Args, ValueEnum};
use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::{Duration, Instant};
use vadop::memory;
use vadop::scene::{
    GeneratedScene, Scene, SceneLayout, ShapesScene, Velocities, DEFAULT_MAX_SPIN, FRAMES_PER_SECOND, MAX_SCENE_BODIES,
};
use vadop::{BodyHandle, Contact, Method, Mode, Touched, VadopError, World, WorldConfig};

/// Scenes up to this many moving bodies are checked against brute force unless told otherwise.
const DEFAULT_REFERENCE_MAX_BODIES: usize = 3000;
/// The same for scenes with shapes other than spheres: brute force tests every pair, and a pair
/// test of shapes costs about a hundred times one of spheres (an iterative search, not a closed
/// form), so this many take about as long a frame as 3000 spheres.
const DEFAULT_REFERENCE_MAX_SHAPE_BODIES: usize = 300;
/// Runs shorter than this finish before a progress bar would help.
const PROGRESS_DELAY: Duration = Duration::from_secs(2);

/// What `simulate --help` and `-h` end with: the rules on files and memory.
macro_rules! file_notes {
    () => {
        "\
Output files: --csv, --json and --contacts are written as the run goes, into whatever their path
names (a FIFO or /dev/stdout too). --save-scene and --save-state replace their file through a
rename, so that a killed run never leaves half a file; they refuse anything but a regular file (a
device, FIFO, socket or directory would be replaced by it). A symbolic link is followed: the file
it points to is replaced and the link stays. No two outputs may name one file, and none may
overwrite --scene or --resume, except --save-state, which saves over the state it resumed from.
Nothing is written before the first frame has stepped: a run the engine refuses (a bad --dt, an
absurd speed, bodies overlapping at the start) leaves existing files as they were.

Memory: a run that needs more memory than is available (free memory, cgroup limit, ulimit -v) is
refused before it starts; the estimate is about 640 bytes per body, twice with a reference method.
A --scene or --resume file larger than half the memory available is refused before it is read, and
a scene streamed from a FIFO or device once it has delivered that much; --resume reads regular
files only."
    };
}

#[derive(Debug, Args)]
#[command(
    after_help = concat!(file_notes!(), "\n\nThe summary's lines and the CSV's columns: see --help (or README.md, \"Reading the summary\")."),
    after_long_help = concat!(file_notes!(), "\n\n", "\
Reading the summary (README.md, \"Reading the summary\", says more):
  scene       the bodies, the box, packing (fraction of the box the moving bodies fill), the
              fastest body in its own diameters per frame (a shape's: its bounding sphere's)
  method      the method as run: auto (the default) is the fastest, today the grid;
              --method vadop runs the paper's velocity-aligned sweep and prune
  pool        vadop and swept-kdop: m axes, covering radius rho, alignment angle phi, and the
              axes each body is bounded on (mean over the frames that start a window)
  frames      frames completed of those asked for, and the time simulated
  contacts    every contact: between two moving bodies (body pairs), with static bodies, with
              walls; per frame and per wall-clock second
  accuracy    against a reference method stepped alongside (brute by default for small
              scenes): contacts it found that the run did not (missed) and the reverse (extra);
              exact in detect mode, where every method follows the same paths
  ms/frame    median, mean and p95 of c_total (the four stages, timed inside the step) and of
              the whole step call. A broad-phase window spans several frames and the frame
              that starts one pays for it, so with few frames the mean can be several times
              the median: the mean is the throughput, the median a frame inside a window
  cost split  mean ms per frame of c_update (volumes over the window), c_sort (keeping the
              axis lists sorted, or binning), c_test (candidates and their predictions) and
              c_response (impulses, rebuilds, re-tests)
  per frame   windows started; endpoint swaps (insertion-sort moves of the axis lists; grid:
              entries binned); candidate pairs; narrow tests (exact contact times, re-tests
              included); re-tests (bodies predicted again after a velocity change);
              invalidations (predictions voided by a velocity change before their time)
  rules       contacts made elastic by the TC model, or resolved by the jam rule
  memory      largest broad-phase footprint, peak resident memory of the whole process
  energy      simulate mode: relative kinetic-energy drift of an elastic frictionless run (0 up
              to rounding), or the change a lossy one was asked for; the momentum change beside
              the bodies' sum of |m v| at the start (walls and static bodies exchange momentum
              with the bodies, so the total is not kept)
  stopped     the error that ended the run early; what ran before it is still reported

CSV columns (--csv; --json holds the same rows): frame, time (end of the frame), contacts,
pair_contacts (two moving bodies), ms (c_total), update_ms, sort_ms, test_ms, response_ms,
endpoint_swaps, list_entries (broad-phase entries after the frame's last window start; 0 in a
frame that starts none), candidate_pairs, narrow_tests, invalidations, wall_ms (the whole step
call), broad_phase_bytes, windows, retests, tc_contacts, jam_contacts, contact_ends,
static_contacts (with static bodies; the rest of the contacts are with walls).")
)]
pub struct SimulateArgs {
    /// Scene file (JSON: {"bounds": {"min": [x,y,z], "max": [x,y,z]}, "spheres": [{"position",
    /// "velocity", "radius", "mass"}, ...], and for other shapes "shapes": [{"name", "shape"}, ...],
    /// "bodies": [{"shape" (a name), "position", "orientation" ([x,y,z,w]), "velocity",
    /// "angular_velocity", "mass"}, ...], "static_bodies": [{"shape", "position", "orientation"},
    /// ...]; README.md, "Scene files") instead of a generated scene
    #[arg(long, value_name = "FILE", help_heading = "Scene")]
    scene: Option<PathBuf>,
    /// Number of moving bodies of the generated scene
    #[arg(long, value_name = "N", default_value_t = 1000, conflicts_with = "scene", help_heading = "Scene")]
    bodies: usize,
    /// Fraction of the box volume the bodies fill, in (0, 0.6] (with --kind shapes their own
    /// volume: at most about 0.2 fits)
    #[arg(
        long,
        value_name = "F",
        default_value_t = 0.05,
        allow_negative_numbers = true,
        conflicts_with = "scene",
        help_heading = "Scene"
    )]
    packing: f64,
    /// Speeds are uniform in [0, S] sphere diameters per frame (at 30 frames per second); with
    /// --kind gas S is the rms speed, stream the speed of every body, heavy-tail the median speed
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.5,
        allow_negative_numbers = true,
        conflicts_with = "scene",
        help_heading = "Scene"
    )]
    max_speed: f64,
    /// The generated scene: spheres of one size with the velocities of paper (random directions,
    /// uniform speeds), gas (an equilibrium gas: Maxwell velocities, no net momentum), stream
    /// (every body within --spread of +x, as bullets, rain or a beam) or heavy-tail (Pareto speeds:
    /// a few bodies far faster); or shapes, a crowd of spheres, cuboids, capsules, cylinders, cones
    /// and convex hulls, each one diameter across, at random orientations, with uniform speeds and
    /// spins up to --spin (and a floor with --floor)
    #[arg(long, value_enum, default_value_t = KindArg::Paper, conflicts_with = "scene", help_heading = "Scene")]
    kind: KindArg,
    /// Half-angle of a stream's directions, in degrees
    #[arg(long, value_name = "DEGREES", default_value_t = 10.0, allow_negative_numbers = true, help_heading = "Scene")]
    spread: f64,
    /// Spins of --kind shapes are uniform in [0, W] radians per frame, about random axes
    #[arg(long, value_name = "W", default_value_t = DEFAULT_MAX_SPIN, allow_negative_numbers = true, help_heading = "Scene")]
    spin: f64,
    /// --kind shapes: a static floor under the crowd, a bumpy triangle mesh (the box reaches one
    /// diameter lower for it)
    #[arg(long, help_heading = "Scene")]
    floor: bool,
    /// Seed of the scene generator
    #[arg(long, value_name = "K", default_value_t = 1, conflicts_with = "scene", help_heading = "Scene")]
    seed: u64,
    /// Continue a run saved with --save-state for --frames more frames, bit-exactly; the
    /// world's method, mode, pool, phi and restitution come from the file. Frame numbers go on
    /// from the saved run's, so --dt must be the one it was saved with
    #[arg(long, value_name = "FILE", conflicts_with_all = ["scene", "bodies", "packing", "max_speed", "seed"], help_heading = "Scene")]
    resume: Option<PathBuf>,

    /// Number of frames to step
    #[arg(long, value_name = "F", default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..), help_heading = "Run")]
    frames: u64,
    /// detect: bodies pass through each other and only bounce off the walls, so every method
    /// follows identical paths; simulate: bodies also collide with each other
    #[arg(long, value_enum, default_value_t = ModeArg::Simulate, help_heading = "Run")]
    mode: ModeArg,
    /// Where candidate pairs come from: auto (the fastest, today grid), vadop (the paper's method:
    /// continuous, velocity-aligned volumes), brute
    /// (continuous, every pair), discrete (overlap checks at frame instants only), or the
    /// continuous baselines swept-aabb (classic sweep and prune over swept boxes), swept-kdop (all
    /// pool axes for every body) and grid (uniform grid over swept boxes)
    #[arg(long, value_enum, default_value_t = MethodArg::Auto, help_heading = "Run")]
    method: MethodArg,
    /// Method stepped alongside on the same scene to count missed and extra pair contacts
    /// [default: brute for at most 3000 bodies (300 in a scene with shapes other than spheres,
    /// whose pair tests cost far more) unless --method is brute, else none]
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
    /// Coulomb friction coefficient of every impact, >= 0 (0: frictionless); friction acts at the
    /// contact point, so it spins bodies up
    #[arg(long, value_name = "MU", default_value_t = 0.0, allow_negative_numbers = true, help_heading = "World")]
    friction: f64,
    /// Contact duration t_c of the TC model in seconds: with restitution below 1, a contact of a
    /// body whose previous contact lies less than t_c before is elastic, which ends inelastic
    /// collapse
    #[arg(long, value_name = "SECONDS", default_value_t = vadop::collapse::DEFAULT_CONTACT_DURATION, allow_negative_numbers = true, help_heading = "World")]
    contact_duration: f64,
    /// Detect mode: also report when each contact between bodies ends (rows `body-end` in
    /// --contacts, counted in the summary), as started and stopped events
    #[arg(long, help_heading = "World")]
    contact_ends: bool,
    /// Threads a step shares its work among [default: every core]; no more threads than cores are
    /// used (more would only wait for each other), and the results are bit-identical whatever the
    /// number
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(usize), help_heading = "World")]
    threads: Option<usize>,
    /// Frame length in seconds
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0 / FRAMES_PER_SECOND, allow_negative_numbers = true, help_heading = "World")]
    dt: f64,

    /// Write one CSV row per frame (counters and the cost split in ms)
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    csv: Option<PathBuf>,
    /// Write the summary and the per-frame rows as JSON
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    json: Option<PathBuf>,
    /// Write every contact as CSV (frame, time, body, what it touched, point, normal, impulse);
    /// with --contact-ends also the ends of contacts between bodies, as rows touching `body-end`.
    /// Bodies are numbered from 0 in scene order: a scene file's spheres, then its bodies, then its
    /// static bodies (--save-scene writes a generated scene's file). A world saved by the library
    /// after bodies were removed and added may hold a body in a reused slot: it is written as
    /// slot + 2^32 x generation, the number of its BodyHandle (the id Python uses too). With
    /// --resume an existing file is continued: rows of frames after the saved state are dropped,
    /// and the new frames' rows appended
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    contacts: Option<PathBuf>,
    /// Save the scene as it was before stepping, as a scene file, once the first frame has stepped
    /// (a regular file; links are followed)
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    save_scene: Option<PathBuf>,
    /// Save the whole world after every frame (atomically: a run killed mid-way loses at most
    /// the frame in progress), to continue with --resume. The contacts file is flushed to disk
    /// first, so it holds every contact up to the saved frame (a regular file; links are followed)
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
enum KindArg {
    Paper,
    Gas,
    Stream,
    HeavyTail,
    Shapes,
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
    let files = Files::check(args)?;
    if args.floor && args.kind != KindArg::Shapes {
        return Err("--floor lays a floor under --kind shapes only".to_string());
    }
    if let Some(path) = &args.resume {
        return resume(path, files, args);
    }
    let config = WorldConfig {
        method: args.method.method(),
        mode: match args.mode {
            ModeArg::Detect => Mode::Detect,
            ModeArg::Simulate => Mode::Simulate,
        },
        pool_axes: args.pool.0,
        phi: args.phi.map(f64::to_radians),
        restitution: args.restitution,
        friction: args.friction,
        contact_duration: args.contact_duration,
        threads: args.threads,
        contact_ends: args.contact_ends,
    };
    let (scene, source) = match &args.scene {
        Some(path) => {
            let scene = Scene::load(path).map_err(describe)?;
            let layout = scene.layout();
            check_memory(layout.count(), reference_method(args, &layout, config.method))?;
            (scene, format!("scene file {}", path.display()))
        }
        None => {
            // Before generating, so that a scene too large is refused before it is built. Only a
            // valid scene's size is worth checking: the core names bad parameters better.
            if args.bodies <= MAX_SCENE_BODIES {
                let expected = match args.kind {
                    KindArg::Shapes => SceneLayout { bodies: args.bodies, ..SceneLayout::default() },
                    _ => SceneLayout { spheres: args.bodies, ..SceneLayout::default() },
                };
                check_memory(args.bodies, reference_method(args, &expected, config.method))?;
            }
            generate(args)?
        }
    };
    let layout = scene.layout();
    let reference = reference_method(args, &layout, config.method);
    let world = scene.world(config).map_err(describe)?;
    let reference_world = match reference {
        Some(method) => Some(scene.world(WorldConfig { method, ..config }).map_err(describe)?),
        None => None,
    };
    // The scene is kept only to be saved, once the first frame has stepped (so that a run the
    // core refuses replaces no file), and dropped then: at a million bodies it is worth giving back.
    let save = files.save_scene.is_some().then_some(scene);
    run_world(world, reference_world, save, Origin { source, frames_done: 0, layout: Some(layout) }, files, args)
}

/// The scene `--kind` asks for, and where it came from, for the summary.
fn generate(args: &SimulateArgs) -> CliResult<(Scene, String)> {
    let (velocities, what) = match args.kind {
        KindArg::Paper => (
            Velocities::Uniform { max_speed: args.max_speed },
            format!("paper scene (speeds up to {} diameters/frame", args.max_speed),
        ),
        KindArg::Gas => (
            Velocities::Maxwell { rms_speed: args.max_speed },
            format!("equilibrium gas (rms speed {} diameters/frame", args.max_speed),
        ),
        KindArg::Stream => (
            Velocities::Stream { speed: args.max_speed, spread: args.spread.to_radians() },
            format!("stream ({} diameters/frame within {} degrees of +x", args.max_speed, args.spread),
        ),
        KindArg::HeavyTail => (
            Velocities::HeavyTail { median_speed: args.max_speed, tail_index: 1.5 },
            format!("heavy-tailed speeds (median {} diameters/frame, tail index 1.5", args.max_speed),
        ),
        KindArg::Shapes => {
            let shapes = ShapesScene {
                bodies: args.bodies,
                packing_fraction: args.packing,
                max_speed: args.max_speed,
                max_spin: args.spin,
                floor: args.floor,
                seed: args.seed,
            };
            let floor = if args.floor { ", on a floor mesh" } else { "" };
            let what = format!(
                "mixed shapes (speeds up to {} diameters/frame, spins up to {} rad/frame{floor}, seed {})",
                args.max_speed, args.spin, args.seed
            );
            return Ok((shapes.build().map_err(describe)?, what));
        }
    };
    let generated = GeneratedScene {
        bodies: args.bodies,
        packing_fraction: args.packing,
        velocities,
        radius: 0.5,
        seed: args.seed,
    };
    Ok((generated.build().map_err(describe)?, format!("{what}, seed {})", args.seed)))
}

/// The method stepped alongside a run of a scene of `layout`, if any.
fn reference_method(args: &SimulateArgs, layout: &SceneLayout, method: Method) -> Option<Method> {
    match args.reference {
        Some(ReferenceArg::Brute) => Some(Method::Brute),
        Some(ReferenceArg::Vadop) => Some(Method::Vadop),
        Some(ReferenceArg::None) => None,
        None => {
            let shapes = layout.bodies + layout.static_bodies > 0;
            let most = if shapes { DEFAULT_REFERENCE_MAX_SHAPE_BODIES } else { DEFAULT_REFERENCE_MAX_BODIES };
            // Checking brute force against itself would only double the cost.
            (layout.spheres + layout.bodies <= most && method != Method::Brute).then_some(Method::Brute)
        }
    }
}

/// Refuses a run whose worlds (the run's, and the reference's) cannot fit in the memory left.
fn check_memory(bodies: usize, reference: Option<Method>) -> CliResult<()> {
    let worlds = if reference.is_some() { 2 } else { 1 };
    let needed = memory::world_bytes(bodies).saturating_mul(worlds);
    let with = if reference.is_some() { " with its reference world" } else { "" };
    memory::check(needed).map_err(|shortfall| format!("a run of {bodies} bodies{with} {shortfall}"))
}

/// `--resume FILE`: the saved world, stepped on without a reference (a reference would need the
/// state it had when the world was saved), its frames numbered on from the saved run's.
fn resume(path: &Path, files: Files, args: &SimulateArgs) -> CliResult<()> {
    if matches!(args.reference, Some(ReferenceArg::Brute | ReferenceArg::Vadop)) {
        return Err("--resume cannot be combined with --reference: the reference's state was not saved".to_string());
    }
    // A saved state is a regular file (--save-state writes nothing else), and the core reads it
    // whole: a device or FIFO could deliver without end, and a file too large is refused unread.
    if std::fs::metadata(path).is_ok_and(|meta| !meta.is_file()) {
        return Err(format!("--resume {}: not a regular file, so not a state saved by --save-state", path.display()));
    }
    memory::check_input(path).map_err(|e| format!("--resume {}: {e}", path.display()))?;
    let world = World::load(path).map_err(describe)?;
    if !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(describe(VadopError::BadTimeStep(args.dt)));
    }
    let frames_done = whole_frames(world.time(), args.dt).ok_or_else(|| {
        format!(
            "--resume {}: the saved time {} is not a whole number of frames of --dt {}; resume with the --dt the run was saved with, so that frame numbers go on",
            path.display(),
            world.time(),
            args.dt
        )
    })?;
    let source = format!("saved world {} at time {} (frame {frames_done})", path.display(), world.time());
    let save = files.save_scene.is_some().then(|| Scene::from_world(&world));
    // The world's handles are its own, not a scene's entries.
    run_world(world, None, save, Origin { source, frames_done, layout: None }, files, args)
}

/// Time a frame may end off `frames * dt` in a world that added `dt` frame after frame: a
/// hundredth of a frame, plus a millionth of the time for the rounding that piles up over
/// millions of frames.
fn slack(time: f64, dt: f64) -> f64 {
    0.01 * dt + 1e-6 * time.abs()
}

/// How many frames of `dt` make `time`, when it is a whole number of them.
fn whole_frames(time: f64, dt: f64) -> Option<u64> {
    let frames = (time / dt).round();
    ((0.0..9e15).contains(&frames) && (time - frames * dt).abs() <= slack(time, dt)).then_some(frames as u64)
}

/// Whether a contact at `time` belongs to frame `frame` (numbered from 1) of `dt`.
fn in_frame(time: f64, frame: u64, dt: f64) -> bool {
    let (start, end) = ((frame.max(1) - 1) as f64 * dt, frame as f64 * dt);
    time >= start - slack(start, dt) && time <= end + slack(end, dt)
}

/// The files a run reads and writes, checked before any work is done.
struct Files {
    /// Where `--save-scene` and `--save-state` land, links followed.
    save_scene: Option<PathBuf>,
    save_state: Option<PathBuf>,
}

impl Files {
    /// No two outputs may name one file, and none may overwrite an input, except the state saved
    /// over the state resumed from. A file the core saves by renaming a new one over it must be a
    /// regular file (or not exist yet): the rename would replace a device, FIFO or socket.
    fn check(args: &SimulateArgs) -> CliResult<Files> {
        let inputs = [("--scene", &args.scene), ("--resume", &args.resume)];
        let outputs = [
            ("--csv", &args.csv),
            ("--json", &args.json),
            ("--contacts", &args.contacts),
            ("--save-scene", &args.save_scene),
            ("--save-state", &args.save_state),
        ];
        let mut seen: Vec<(&str, PathBuf)> = Vec::new();
        for (flag, path) in inputs {
            if let Some(path) = path {
                seen.push((flag, destination(path)?));
            }
        }
        for (flag, path) in outputs {
            let Some(path) = path else { continue };
            let target = destination(path)?;
            if let Some((other, _)) = seen.iter().find(|(_, seen)| *seen == target) {
                if (*other, flag) != ("--resume", "--save-state") {
                    let role = if inputs.iter().any(|(input, _)| input == other) { "reads" } else { "writes" };
                    return Err(format!(
                        "{flag} {} is the file {other} {role}: give every output a file of its own",
                        path.display()
                    ));
                }
            }
            seen.push((flag, target));
        }
        let replaced = |flag: &str, path: &Option<PathBuf>| -> CliResult<Option<PathBuf>> {
            let (Some(path), Some((_, target))) = (path, seen.iter().find(|(seen, _)| *seen == flag)) else {
                return Ok(None);
            };
            if std::fs::metadata(target).is_ok_and(|meta| !meta.is_file()) {
                return Err(format!(
                    "{flag} {}: not a regular file; saving replaces the file with a new one, which would destroy a device, FIFO, socket or directory",
                    path.display()
                ));
            }
            Ok(Some(target.clone()))
        };
        Ok(Files {
            save_scene: replaced("--save-scene", &args.save_scene)?,
            save_state: replaced("--save-state", &args.save_state)?,
        })
    }
}

/// Where a write to `path` lands: symbolic links followed (the last may point to a file not yet
/// there) and the directory made canonical, so that two spellings of one file compare equal.
fn destination(path: &Path) -> CliResult<PathBuf> {
    let mut at = path.to_path_buf();
    // The kernel's own limit on links followed in a path.
    for _ in 0..40 {
        match std::fs::symlink_metadata(&at) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let target = std::fs::read_link(&at).map_err(|e| report::io_error(path, e))?;
                // A relative target is relative to the link's directory; join keeps an absolute one.
                at = at.parent().map_or(target.clone(), |dir| dir.join(&target));
            }
            _ => {
                let Some(name) = at.file_name() else { return Ok(at) };
                let dir = at.parent().filter(|dir| !dir.as_os_str().is_empty()).unwrap_or(Path::new("."));
                return std::fs::canonicalize(dir).map(|dir| dir.join(name)).map_err(|e| report::io_error(path, e));
            }
        }
    }
    Err(format!("{}: too many levels of symbolic links", path.display()))
}

/// Where a run's world came from.
struct Origin {
    /// What the summary calls it: a generated scene, a scene file, a saved world.
    source: String,
    /// Frames stepped before: a resumed run's frame numbers go on from them.
    frames_done: u64,
    /// The scene's body lists, which name its entries in errors; none for a saved world, whose
    /// handles are its own.
    layout: Option<SceneLayout>,
}

/// Steps `world` (and `reference_world` alongside) from frame `origin.frames_done` on, streaming
/// the outputs, then reports. `scene` is what --save-scene writes, when given. Nothing is written
/// before the first frame has stepped: the core checks the time step, the speeds and the
/// overlaps at the first step, and a run it refuses must leave existing files as they were.
fn run_world(
    mut world: World,
    reference_world: Option<World>,
    scene: Option<Scene>,
    origin: Origin,
    files: Files,
    args: &SimulateArgs,
) -> CliResult<()> {
    let config = world.config();
    let mut scene = scene;
    let mut open = || -> CliResult<Outputs> {
        let outputs = Outputs::open(args, origin.frames_done)?;
        if let (Some(path), Some(scene)) = (&files.save_scene, scene.take()) {
            scene.save(path).map_err(describe)?;
        }
        Ok(outputs)
    };
    let info = RunInfo {
        scene: SceneInfo::of(&world, origin.source, args.dt)?,
        method: match config.method {
            Method::Auto => format!("auto ({})", config.method.resolve().name()),
            method => method.name().to_string(),
        },
        mode: match config.mode {
            Mode::Detect => "detect",
            Mode::Simulate => "simulate",
        }
        .to_string(),
        dt: args.dt,
        restitution: config.restitution,
        friction: config.friction,
        frames_requested: args.frames,
    };
    let start = Motion::of(&world);
    let frames = origin.frames_done + 1..=origin.frames_done + args.frames;
    let save_state = files.save_state.as_deref();
    let mut outputs = None;
    let mut outcome =
        step_frames(&mut world, reference_world, args, frames, save_state, (&mut outputs, &mut open), origin.layout);
    let Outputs { csv, json, contacts } = outputs.unwrap_or_default();
    // A failed flush loses contacts or rows, not frames: it is reported like a failed frame.
    for finished in [contacts.map(ContactWriter::finish), csv.map(FramesCsv::finish)].into_iter().flatten() {
        if let Err(e) = finished {
            outcome.failure.get_or_insert(e);
        }
    }
    let pool = Some(world.pool()).filter(|_| matches!(world.method(), Method::Vadop | Method::SweptKdop)).map(|pool| {
        let rho = pool.covering_radius();
        PoolInfo {
            axes: pool.len(),
            covering_radius_deg: rho.to_degrees(),
            phi_deg: world.config().phi.unwrap_or(rho).to_degrees(),
            axes_per_body: outcome.frames.axes_per_body(info.scene.bodies),
        }
    });
    let conservation = (config.mode == Mode::Simulate).then(|| {
        // Spins are worth reporting once anything can spin: shapes, static bodies, friction.
        let spins = info.scene.may_spin() || config.friction > 0.0;
        Conservation::new(&start, &Motion::of(&world), spins)
    });
    let summary = Summary::new(info, &outcome.frames, pool, outcome.accuracy, conservation, outcome.failure.clone());
    if !args.quiet && outcome.frames.frames > 0 {
        report::print(&summary.to_string())?;
    }
    let written = json.map_or(Ok(()), |json| json.finish(&summary));
    match outcome.failure {
        Some(message) => Err(message),
        None => written,
    }
}

/// Output files, created once the first frame has stepped (a bad directory fails before any work
/// is done, in `Files::check`).
#[derive(Default)]
struct Outputs {
    csv: Option<FramesCsv>,
    json: Option<JsonReport>,
    contacts: Option<ContactWriter>,
}

impl Outputs {
    fn open(args: &SimulateArgs, frames_done: u64) -> CliResult<Outputs> {
        let contacts = match (&args.contacts, &args.resume) {
            (Some(path), Some(_)) => Some(ContactWriter::resume(path, frames_done, args.dt)?),
            (Some(path), None) => Some(ContactWriter::create(path)?),
            (None, _) => None,
        };
        Ok(Outputs {
            csv: args.csv.as_deref().map(FramesCsv::create).transpose()?,
            json: args.json.as_deref().map(JsonReport::create).transpose()?,
            contacts,
        })
    }

    fn row(&mut self, row: &FrameRow) -> CliResult<()> {
        if let Some(csv) = &mut self.csv {
            csv.row(row)?;
        }
        match &mut self.json {
            Some(json) => json.row(row),
            None => Ok(()),
        }
    }
}

/// The contacts CSV, streamed frame by frame because it can be far larger than memory allows.
struct ContactWriter {
    file: OutputFile,
    /// A regular file, which a sync puts on the disk (a FIFO or a terminal cannot be synced).
    regular: bool,
}

impl ContactWriter {
    const HEADER: &'static str =
        "frame,time,body,touched,other,point_x,point_y,point_z,normal_x,normal_y,normal_z,impulse";

    fn create(path: &Path) -> CliResult<ContactWriter> {
        let file = report::create_file(path)?;
        ContactWriter::start(file, path, 0)
    }

    /// Writes from byte `keep` of `file` on, with a header when the file is to be empty.
    fn start(file: File, path: &Path, keep: u64) -> CliResult<ContactWriter> {
        let regular = file.metadata().is_ok_and(|m| m.is_file());
        let mut writer = ContactWriter { file: OutputFile::new(file, path), regular };
        if keep == 0 {
            writer.file.line(format_args!("{}", ContactWriter::HEADER))?;
        }
        Ok(writer)
    }

    /// The contacts file of a run resumed after `frames_done` frames of `dt`. An existing regular
    /// file is continued: its rows of later frames (written after the state was saved, and the
    /// partial row of a killed run) are dropped, so that it holds each contact exactly once.
    fn resume(path: &Path, frames_done: u64, dt: f64) -> CliResult<ContactWriter> {
        if !std::fs::metadata(path).is_ok_and(|m| m.is_file()) {
            return ContactWriter::create(path);
        }
        let io = |e: std::io::Error| report::io_error(path, e);
        let mut file = OpenOptions::new().read(true).write(true).open(path).map_err(io)?;
        let keep = ContactWriter::rows_up_to(&file, path, frames_done, dt)?;
        file.set_len(keep).map_err(io)?;
        file.seek(SeekFrom::End(0)).map_err(io)?;
        ContactWriter::start(file, path, keep)
    }

    /// The length of the header and the complete rows of frames up to `last` at the start of
    /// `file`; 0 when it holds no complete header.
    fn rows_up_to(file: &File, path: &Path, last: u64, dt: f64) -> CliResult<u64> {
        let mut reader = BufReader::new(file);
        let (mut line, mut keep, mut number) = (Vec::new(), 0u64, 0u64);
        loop {
            line.clear();
            let read = reader.read_until(b'\n', &mut line).map_err(|e| report::io_error(path, e))?;
            number += 1;
            // The end, or a row cut short by a kill.
            if read == 0 || line.last() != Some(&b'\n') {
                let header_cut_short =
                    number == 1 && format!("{}\n", ContactWriter::HEADER).as_bytes().starts_with(&line);
                return if number > 1 || header_cut_short { Ok(keep) } else { Err(not_contacts(path, number)) };
            }
            let text = std::str::from_utf8(&line[..line.len() - 1]).map_err(|_| not_contacts(path, number))?;
            if number == 1 {
                if text != ContactWriter::HEADER {
                    return Err(not_contacts(path, number));
                }
            } else {
                let mut cells = text.split(',');
                let frame: u64 = cells.next().and_then(|c| c.parse().ok()).ok_or_else(|| not_contacts(path, number))?;
                let time: f64 = cells.next().and_then(|c| c.parse().ok()).ok_or_else(|| not_contacts(path, number))?;
                if frame > last {
                    return Ok(keep);
                }
                if !in_frame(time, frame, dt) {
                    return Err(format!(
                        "--contacts {} line {number}: a contact at time {time} is not in frame {frame} of --dt {dt}, so the file was not written with the state resumed: give --contacts that run's file or a new one",
                        path.display()
                    ));
                }
            }
            keep += read as u64;
        }
    }

    /// Writes a frame's contacts and the ends of contacts, merged in time order (a start before
    /// an end at the same instant, as the engine handles them).
    fn frame(&mut self, frame: u64, contacts: &[Contact], ends: &[Contact]) -> CliResult<()> {
        let (mut starts, mut ends) = (contacts.iter().peekable(), ends.iter().peekable());
        loop {
            let (c, ended) = match (starts.peek(), ends.peek()) {
                (Some(s), Some(e)) if e.time < s.time => (ends.next(), true),
                (Some(_), _) => (starts.next(), false),
                (None, Some(_)) => (ends.next(), true),
                (None, None) => return Ok(()),
            };
            let c = c.expect("peeked");
            let (kind, other) = match c.touched {
                Touched::Body(other) => (if ended { "body-end" } else { "body" }, other.to_bits().to_string()),
                Touched::Wall(wall) => ("wall", format!("{wall:?}")),
            };
            let (body, p, n) = (c.body.to_bits(), c.point, c.normal);
            self.file.line(format_args!(
                "{frame},{},{body},{kind},{other},{},{},{},{},{},{},{}",
                c.time, p.x, p.y, p.z, n.x, n.y, n.z, c.impulse
            ))?;
        }
    }

    /// Puts every row written so far on the disk (where the file is one), so that a state saved
    /// next never runs ahead of its contacts.
    fn sync(&mut self) -> CliResult<()> {
        if self.regular {
            self.file.sync()
        } else {
            self.file.flush()
        }
    }

    fn finish(mut self) -> CliResult<()> {
        self.file.flush()
    }
}

fn not_contacts(path: &Path, line: u64) -> String {
    format!(
        "--contacts {} line {line}: not a vadop contacts file; give --contacts a contacts file or a new one",
        path.display()
    )
}

/// What the frame loop produced.
struct Outcome {
    frames: FrameTotals,
    accuracy: Option<Accuracy>,
    /// Why the run stopped early.
    failure: Option<String>,
}

/// Steps `world` (and `reference` alongside) through `frames`, or until a frame fails, writing
/// each frame's contacts and row as it completes, into the outputs `open` makes once the first
/// frame has stepped. `layout` names a scene's entries in the errors of the first step, which
/// checks the scene as a whole.
fn step_frames(
    world: &mut World,
    mut reference: Option<World>,
    args: &SimulateArgs,
    frames: std::ops::RangeInclusive<u64>,
    save_state: Option<&Path>,
    (outputs, open): (&mut Option<Outputs>, &mut dyn FnMut() -> CliResult<Outputs>),
    layout: Option<SceneLayout>,
) -> Outcome {
    let simulate = world.config().mode == Mode::Simulate;
    let mut accuracy = reference.as_ref().map(|r| Accuracy {
        reference: r.config().method.name().to_string(),
        identical_paths: !simulate,
        ..Accuracy::default()
    });
    let mut totals = FrameTotals::default();
    let mut failure = None;
    let bar = report::progress_bar(args.frames, "frames");
    let started = Instant::now();
    let mut may_reveal = !args.quiet;
    // Contacts with these are told apart from those between moving bodies.
    let statics: Vec<BodyHandle> = world.bodies().filter(|(_, b)| !b.mass.is_finite()).map(|(h, _)| h).collect();
    for frame in frames {
        let start = Instant::now();
        match world.step(args.dt) {
            Ok(_) => {}
            Err(e) => {
                // A step fails before changing anything, so a failure of the run's first step is
                // about the scene as given, not about anything a frame did: its entries name the
                // bodies.
                let e = match layout {
                    Some(layout) => layout.name_entries(e),
                    None => e,
                };
                let when =
                    if totals.frames == 0 { "before the first frame".to_string() } else { format!("frame {frame}") };
                failure = Some(format!("{when}: {}", describe(e)));
                break;
            }
        };
        let wall_seconds = start.elapsed().as_secs_f64();
        let outputs = match outputs {
            Some(outputs) => outputs,
            None => match open() {
                Ok(opened) => outputs.insert(opened),
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            },
        };
        let contacts = world.contacts();
        if let Some(out) = &mut outputs.contacts {
            if let Err(e) = out.frame(frame, contacts, world.contact_ends()) {
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
        if let Some(path) = save_state {
            // The contacts first: a state on disk must never be ahead of the contacts file.
            let synced = outputs.contacts.as_mut().map_or(Ok(()), ContactWriter::sync);
            if let Err(e) =
                synced.and_then(|()| world.save(path).map_err(|e| format!("frame {frame}: {}", describe(e))))
            {
                failure = Some(e);
                break;
            }
        }
        let is_static = |h: &BodyHandle| statics.binary_search(h).is_ok();
        let static_contacts = contacts
            .iter()
            .filter(|c| matches!(c.touched, Touched::Body(other) if is_static(&other) || is_static(&c.body)))
            .count() as u64;
        let row = FrameRow::new(frame, world.time(), world.stats(), static_contacts, wall_seconds);
        totals.add(&row);
        if let Err(e) = outputs.row(&row) {
            failure = Some(e);
            break;
        }
        bar.inc(1);
        if may_reveal && started.elapsed() > PROGRESS_DELAY {
            report::reveal(&bar);
            may_reveal = false;
        }
    }
    bar.finish_and_clear();
    Outcome { frames: totals, accuracy, failure }
}

/// The body-body contacts of a frame as sorted (lower handle, higher handle) pairs.
fn pair_contacts(contacts: &[Contact]) -> Vec<(BodyHandle, BodyHandle)> {
    let mut pairs: Vec<(BodyHandle, BodyHandle)> = contacts
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
fn differences<T: Ord>(expected: &[T], found: &[T]) -> (u64, u64) {
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
