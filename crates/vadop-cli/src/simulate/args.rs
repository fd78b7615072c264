//! The arguments of `vadop simulate`: the clap struct, whose doc comments are the `--help` text
//! and whose closing notes give the rules on files and memory, the value enums with their
//! conversions to the core's types, and the parser of `--pool`. It owns what a user may type and
//! how the help reads, byte for byte. It never checks physics input (the core does, and its
//! messages name the valid ranges), never opens a file and never builds a world.

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::str::FromStr;
use vadop::scene::{DEFAULT_MAX_SPIN, FRAMES_PER_SECOND};
use vadop::Method;

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
  method      the method as run: auto (the default) is the fastest, today the grid (in
              simulate mode of spheres without gravity, the event loop);
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
  rules       contacts made elastic by the TC model, or resolved by the jam rule; under gravity
              with restitution below 1, those the rest rule changed (a body brought to rest, or
              parted from or bounced off one that does not fall)
  at rest     the same runs: bodies lying still and sliding along the floor at the end
  memory      largest broad-phase footprint, peak resident memory of the whole process
  energy      simulate mode: relative kinetic-energy drift (plus the potential energy under
              --gravity) of an elastic frictionless run (0 up to rounding), or the change a lossy one was asked for; the momentum change beside
              the bodies' sum of |m v| at the start (walls and static bodies exchange momentum
              with the bodies, so the total is not kept)
  pressure    elastic frictionless simulate runs: Z = PV/NkT = 1 + W / (2 K T) from the
              collisional virial W of the impacts between moving bodies (K the translational
              kinetic energy, T the simulated time)
  stopped     the error that ended the run early; what ran before it is still reported

CSV columns (--csv; --json holds the same rows): frame, time (end of the frame), contacts,
pair_contacts (two moving bodies), ms (c_total), update_ms, sort_ms, test_ms, response_ms,
endpoint_swaps, list_entries (broad-phase entries after the frame's last window start; 0 in a
frame that starts none), candidate_pairs, narrow_tests, invalidations, wall_ms (the whole step
call), broad_phase_bytes, windows, retests, tc_contacts, jam_contacts, contact_ends,
static_contacts (with static bodies; the rest of the contacts are with walls), pair_virial (the
collisional virial of the impacts between moving bodies, simulate mode), rest_contacts (contacts
the rest rule changed).")
)]
pub struct SimulateArgs {
    /// Scene file (JSON: {"bounds": {"min": [x,y,z], "max": [x,y,z]}, "spheres": [{"position",
    /// "velocity", "radius", "mass"}, ...], and for other shapes "shapes": [{"name", "shape"}, ...],
    /// "bodies": [{"shape" (a name), "position", "orientation" ([x,y,z,w]), "velocity",
    /// "angular_velocity", "mass"}, ...], "static_bodies": [{"shape", "position", "orientation"},
    /// ...]; README.md, "Scene files") instead of a generated scene
    #[arg(long, value_name = "FILE", help_heading = "Scene")]
    pub(super) scene: Option<PathBuf>,
    /// Number of moving bodies of the generated scene
    #[arg(long, value_name = "N", default_value_t = 1000, conflicts_with = "scene", help_heading = "Scene")]
    pub(super) bodies: usize,
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
    pub(super) packing: f64,
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
    pub(super) max_speed: f64,
    /// The generated scene: spheres of one size with the velocities of paper (random directions,
    /// uniform speeds), gas (an equilibrium gas: Maxwell velocities, no net momentum), stream
    /// (every body within --spread of +x, as bullets, rain or a beam) or heavy-tail (Pareto speeds:
    /// a few bodies far faster); pile, the paper scene falling under gravity onto the floor, with
    /// restitution 0.5, into a granular pile at rest (--gravity and --restitution override them);
    /// or shapes, a crowd of spheres, cuboids, capsules, cylinders, cones and convex hulls, each
    /// one diameter across, at random orientations, with uniform speeds and spins up to --spin (and
    /// a floor with --floor)
    #[arg(long, value_enum, default_value_t = KindArg::Paper, conflicts_with = "scene", help_heading = "Scene")]
    pub(super) kind: KindArg,
    /// Half-angle of a stream's directions, in degrees
    #[arg(long, value_name = "DEGREES", default_value_t = 10.0, allow_negative_numbers = true, help_heading = "Scene")]
    pub(super) spread: f64,
    /// Spins of --kind shapes are uniform in [0, W] radians per frame, about random axes
    #[arg(long, value_name = "W", default_value_t = DEFAULT_MAX_SPIN, allow_negative_numbers = true, help_heading = "Scene")]
    pub(super) spin: f64,
    /// --kind shapes: a static floor under the crowd, a bumpy triangle mesh (the box reaches one
    /// diameter lower for it)
    #[arg(long, help_heading = "Scene")]
    pub(super) floor: bool,
    /// Seed of the scene generator
    #[arg(long, value_name = "K", default_value_t = 1, conflicts_with = "scene", help_heading = "Scene")]
    pub(super) seed: u64,
    /// Continue a run saved with --save-state for --frames more frames, bit-exactly; the
    /// world's method, mode, pool, phi and restitution come from the file. Frame numbers go on
    /// from the saved run's, so --dt must be the one it was saved with
    #[arg(long, value_name = "FILE", conflicts_with_all = ["scene", "bodies", "packing", "max_speed", "seed"], help_heading = "Scene")]
    pub(super) resume: Option<PathBuf>,

    /// Number of frames to step
    #[arg(long, value_name = "F", default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..), help_heading = "Run")]
    pub(super) frames: u64,
    /// detect: bodies pass through each other and only bounce off the walls, so every method
    /// follows identical paths; simulate: bodies also collide with each other
    #[arg(long, value_enum, default_value_t = ModeArg::Simulate, help_heading = "Run")]
    pub(super) mode: ModeArg,
    /// Where candidate pairs come from: auto (the fastest: the grid; in simulate mode of spheres
    /// without gravity, an event loop with one scheduled event per body), vadop (the paper's method:
    /// continuous, velocity-aligned volumes), brute
    /// (continuous, every pair), discrete (overlap checks at frame instants only), or the
    /// continuous baselines swept-aabb (classic sweep and prune over swept boxes), swept-kdop (all
    /// pool axes for every body) and grid (uniform grid over swept boxes)
    #[arg(long, value_parser = method_names(), default_value = "auto", help_heading = "Run")]
    pub(super) method: Method,
    /// Method stepped alongside on the same scene to count missed and extra pair contacts
    /// [default: brute for at most 3000 bodies (300 in a scene with shapes other than spheres,
    /// whose pair tests cost far more) unless --method is brute, else none]
    #[arg(long, value_enum, help_heading = "Run")]
    pub(super) reference: Option<ReferenceArg>,

    /// Number of pool axes m, or auto to choose from the bodies' speeds
    #[arg(long, value_name = "M|auto", default_value = "auto", help_heading = "World")]
    pub(super) pool: PoolSize,
    /// Alignment angle phi in degrees, at least the pool's covering radius rho [default: rho]
    #[arg(long, value_name = "DEGREES", allow_negative_numbers = true, help_heading = "World")]
    pub(super) phi: Option<f64>,
    /// Coefficient of restitution of every impact, in [0, 1] [default: 1; 0.5 with --kind pile]
    #[arg(long, value_name = "E", allow_negative_numbers = true, help_heading = "World")]
    pub(super) restitution: Option<f64>,
    /// Coulomb friction coefficient of every impact, >= 0 (0: frictionless); friction acts at the
    /// contact point, so it spins bodies up
    #[arg(long, value_name = "MU", default_value_t = 0.0, allow_negative_numbers = true, help_heading = "World")]
    pub(super) friction: f64,
    /// Contact duration t_c of the TC model in seconds: with restitution below 1, a contact of a
    /// body whose previous contact lies less than t_c before is elastic, which ends inelastic
    /// collapse
    #[arg(long, value_name = "SECONDS", default_value_t = vadop::response::rules::DEFAULT_CONTACT_DURATION, allow_negative_numbers = true, help_heading = "World")]
    pub(super) contact_duration: f64,
    /// Uniform acceleration of every moving body, as x,y,z (e.g. 0,0,-9.81): parabolic paths,
    /// exact for every method and shape; with restitution below 1 in simulate mode bodies come
    /// to rest on the floor, on each other and on static geometry (the rest rule; spheres only,
    /// for now) [default: none; 0,0,-9.81 with --kind pile]
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vector, allow_negative_numbers = true, help_heading = "World")]
    pub(super) gravity: Option<glam::DVec3>,
    /// Periodic axes of the box, e.g. xyz or xy (the others keep their walls): a body leaving
    /// through one face comes back through the opposite one, and bodies meet across the faces;
    /// no static bodies, for now
    #[arg(long, value_name = "AXES", value_parser = parse_axes, help_heading = "World")]
    pub(super) periodic: Option<[bool; 3]>,
    /// Detect mode: also report when each contact between bodies ends (rows `body-end` in
    /// --contacts, counted in the summary), as started and stopped events
    #[arg(long, help_heading = "World")]
    pub(super) contact_ends: bool,
    /// Threads a step shares its work among [default: every core]; no more threads than cores are
    /// used (more would only wait for each other), and the results are bit-identical whatever the
    /// number
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(usize), help_heading = "World")]
    pub(super) threads: Option<usize>,
    /// Frame length in seconds
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0 / FRAMES_PER_SECOND, allow_negative_numbers = true, help_heading = "World")]
    pub(super) dt: f64,

    /// Write one CSV row per frame (counters and the cost split in ms)
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    pub(super) csv: Option<PathBuf>,
    /// Write the summary and the per-frame rows as JSON
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    pub(super) json: Option<PathBuf>,
    /// Write every contact as CSV (frame, time, body, what it touched, point, normal, impulse);
    /// with --contact-ends also the ends of contacts between bodies, as rows touching `body-end`.
    /// Bodies are numbered from 0 in scene order: a scene file's spheres, then its bodies, then its
    /// static bodies (--save-scene writes a generated scene's file). A world saved by the library
    /// after bodies were removed and added may hold a body in a reused slot: it is written as
    /// slot + 2^32 x generation, the number of its BodyHandle (the id Python uses too). With
    /// --resume an existing file is continued: rows of frames after the saved state are dropped,
    /// and the new frames' rows appended
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    pub(super) contacts: Option<PathBuf>,
    /// Save the scene as it was before stepping, as a scene file, once the first frame has stepped
    /// (a regular file; links are followed)
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    pub(super) save_scene: Option<PathBuf>,
    /// Save the whole world after every frame (atomically: a run killed mid-way loses at most
    /// the frame in progress), to continue with --resume. The contacts file is flushed to disk
    /// first, so it holds every contact up to the saved frame (a regular file; links are followed)
    #[arg(long, value_name = "FILE", help_heading = "Output")]
    pub(super) save_state: Option<PathBuf>,
    /// Print no summary and no progress bar (errors still go to stderr)
    #[arg(long, help_heading = "Output")]
    pub(super) quiet: bool,
}

/// `--method`: the core's own list of methods, by the names it gives them.
fn method_names() -> impl TypedValueParser<Value = Method> {
    PossibleValuesParser::new(Method::ALL.map(Method::name))
        .map(|name| Method::from_name(&name).expect("clap admits only the listed names"))
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum KindArg {
    Paper,
    Gas,
    Stream,
    HeavyTail,
    Pile,
    Shapes,
}

/// `--kind pile`'s gravity and restitution unless given: one-diameter balls under the Earth's
/// pull (the diameter the unit of length), half their speed kept at each impact.
pub(super) const PILE_GRAVITY: glam::DVec3 = glam::DVec3::new(0.0, 0.0, -9.81);
pub(super) const PILE_RESTITUTION: f64 = 0.5;

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum ModeArg {
    Detect,
    Simulate,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum ReferenceArg {
    Brute,
    Vadop,
    None,
}

/// `--pool`: a number of axes, or `auto` (chosen by the world at its first step).
#[derive(Debug, Clone, Copy)]
pub(super) struct PoolSize(pub(super) Option<usize>);

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

/// A vector written as three comma-separated numbers.
/// Axes named by letters, as `xyz`, `xz` or `none`.
fn parse_axes(text: &str) -> Result<[bool; 3], String> {
    let mut axes = [false; 3];
    if text == "none" {
        return Ok(axes);
    }
    for letter in text.chars() {
        let axis = "xyz"
            .find(letter)
            .ok_or_else(|| format!("expected axes among x, y and z (e.g. xyz, xy) or none, got {text:?}"))?;
        if std::mem::replace(&mut axes[axis], true) {
            return Err(format!("axis {letter} named twice in {text:?}"));
        }
    }
    if axes == [false; 3] {
        return Err("name at least one axis (e.g. xyz), or none".to_string());
    }
    Ok(axes)
}

fn parse_vector(text: &str) -> Result<glam::DVec3, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [x, y, z] = parts[..] else { return Err(format!("expected three numbers x,y,z, got {text:?}")) };
    let number = |s: &str| s.parse::<f64>().map_err(|e| format!("{s:?}: {e}"));
    Ok(glam::DVec3::new(number(x)?, number(y)?, number(z)?))
}
