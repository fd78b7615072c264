//! `vadop-mpi`: one vadop world split over MPI ranks, run as
//! `mpirun -np K vadop-mpi simulate ...`.
//!
//! The box is cut into K bricks balanced by body count (`bricks`); each rank steps a world over
//! its brick plus a ghost layer (`part`), hands bodies on at frame ends and copies its bodies
//! near the borders to its neighbours (`run`, over `comm`'s messages, in `wire`'s layouts); rank
//! 0 gathers the contacts and writes them in the order one process would, to the bit. Detect
//! mode only for now: docs/mpi.md says why and how simulate mode will be split.

mod bricks;
mod comm;
mod part;
mod run;
mod wire;

use clap::{Parser, Subcommand, ValueEnum};
use comm::Comm;
use glam::DVec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use run::{FrameFigures, Plan, Start};
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use vadop::scene::{GeneratedScene, Scene, SphereScene, FRAMES_PER_SECOND};
use vadop::{BodyHandle, Contact, Method, Mode, World, WorldConfig};

#[derive(Debug, Parser)]
#[command(
    name = "vadop-mpi",
    version,
    about = "One vadop world split over MPI ranks: run as `mpirun -np K vadop-mpi simulate ...`; contacts identical to `vadop simulate`"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Step a generated scene, a scene file or a saved world over all ranks (detect mode), its
    /// contacts written by rank 0 exactly as `vadop simulate --contacts` writes them
    Simulate(Args),
}

#[derive(Debug, clap::Args)]
struct Args {
    /// Scene file (spheres only; `vadop simulate --help` describes the format); every rank reads it
    #[arg(long, value_name = "FILE", conflicts_with = "resume")]
    scene: Option<PathBuf>,
    /// Continue a world saved with --save-state (by vadop-mpi on any number of ranks, or by
    /// `vadop simulate`) for --frames more frames; every rank reads it
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
    /// Number of spheres of the generated scene (every rank builds it from the seed)
    #[arg(long, value_name = "N", default_value_t = 1000)]
    bodies: usize,
    /// Fraction of the box volume the spheres fill, in (0, 0.6]
    #[arg(long, value_name = "F", default_value_t = 0.05, allow_negative_numbers = true)]
    packing: f64,
    /// Speeds in sphere diameters per frame: the largest (paper), the rms (gas), every body's
    /// (stream) or the median (heavy-tail)
    #[arg(long, value_name = "S", default_value_t = 0.5, allow_negative_numbers = true)]
    max_speed: f64,
    /// The generated scene, as `vadop simulate --kind` makes it
    #[arg(long, value_enum, default_value_t = Kind::Paper)]
    kind: Kind,
    /// Half-angle of a stream's directions, in degrees
    #[arg(long, value_name = "DEGREES", default_value_t = 10.0, allow_negative_numbers = true)]
    spread: f64,
    /// Seed of the scene generator
    #[arg(long, value_name = "K", default_value_t = 1)]
    seed: u64,
    /// Number of frames to step
    #[arg(long, value_name = "F", default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..))]
    frames: u64,
    /// detect (bodies pass through each other and bounce off the walls); simulate is refused
    /// across ranks for now, with the reason
    #[arg(long, value_enum, default_value_t = ModeArg::Detect)]
    mode: ModeArg,
    /// Where candidate pairs come from, in every rank's world (the contacts do not depend on it)
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Method::ALL.map(Method::name)), default_value = "auto")]
    method: String,
    /// Coefficient of restitution of the wall bounces, in [0, 1]
    #[arg(long, value_name = "E", default_value_t = 1.0, allow_negative_numbers = true)]
    restitution: f64,
    /// Uniform acceleration of every body, as x,y,z
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vector, allow_negative_numbers = true)]
    gravity: Option<DVec3>,
    /// Threads each rank's step shares its work among
    #[arg(long, value_name = "N", default_value_t = 1)]
    threads: usize,
    /// Frame length in seconds
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0 / FRAMES_PER_SECOND, allow_negative_numbers = true)]
    dt: f64,
    /// Width of the ghost layer each rank holds beyond its brick [default: 1.1 x (twice the
    /// fastest body's travel in a frame plus twice the largest radius)]; a body that would travel
    /// farther than it allows ends the run with an error naming it
    #[arg(long, value_name = "LENGTH")]
    ghost_width: Option<f64>,
    /// Write every contact as CSV, byte for byte as `vadop simulate --contacts` does (rank 0)
    #[arg(long, value_name = "FILE")]
    contacts: Option<PathBuf>,
    /// Write the summary and the per-frame figures (per-rank ms, bytes, ghosts) as JSON (rank 0)
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Save the whole world after every frame, as one process would (rank 0 writes it)
    #[arg(long, value_name = "FILE")]
    save_state: Option<PathBuf>,
    /// Print no summary and no progress bar
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Kind {
    Paper,
    Gas,
    Stream,
    HeavyTail,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum ModeArg {
    Detect,
    Simulate,
}

fn parse_vector(text: &str) -> Result<DVec3, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [x, y, z] = parts[..] else { return Err(format!("expected three numbers x,y,z, got {text:?}")) };
    let number = |s: &str| s.parse::<f64>().map_err(|e| format!("{s:?}: {e}"));
    Ok(DVec3::new(number(x)?, number(y)?, number(z)?))
}

fn main() {
    let Cli { command: Command::Simulate(args) } = Cli::parse();
    let Some(universe) = mpi::initialize() else {
        eprintln!("vadop-mpi: MPI could not be initialised (is this run under mpirun?)");
        std::process::exit(2);
    };
    let mut comm = Comm::new(universe.world());
    match simulate(&mut comm, &args) {
        Ok(()) => {}
        // Every rank stops here alike, before any message: told once, and ended in order.
        Err(Failure::Everywhere(message)) => {
            if comm.rank == 0 {
                eprintln!("vadop-mpi: {message}");
            }
            drop(comm);
            drop(universe);
            std::process::exit(2);
        }
        Err(Failure::Here(message)) => {
            eprintln!("vadop-mpi: {message}");
            // Time for mpirun to pass the message on before the job is torn down.
            std::thread::sleep(std::time::Duration::from_millis(300));
            // One rank's error ends every rank: none is left waiting for it.
            comm.abort(2);
        }
    }
}

/// Why a run stopped: an error every rank meets alike (bad arguments, a scene refused), or one
/// of this rank's own (its message names the rank).
enum Failure {
    Everywhere(String),
    Here(String),
}

/// The world's settings from the arguments.
fn config(args: &Args) -> WorldConfig {
    WorldConfig {
        method: Method::from_name(&args.method).expect("clap admits only the listed names"),
        mode: match args.mode {
            ModeArg::Detect => Mode::Detect,
            ModeArg::Simulate => Mode::Simulate,
        },
        restitution: args.restitution,
        gravity: args.gravity.unwrap_or_default(),
        threads: Some(args.threads),
        ..WorldConfig::default()
    }
}

/// The scene or saved world every rank starts from, and what the summary calls it.
fn start(args: &Args) -> Result<(Start, String), String> {
    if !(args.dt.is_finite() && args.dt > 0.0) {
        return Err(format!("--dt must be a finite number > 0, got {}", args.dt));
    }
    let config = config(args);
    if let Some(path) = &args.resume {
        let world = World::load(path).map_err(|e| e.to_string())?;
        let frames = (world.time() / args.dt).round();
        if (world.time() - frames * args.dt).abs() > 0.01 * args.dt + 1e-6 * world.time() {
            return Err(format!(
                "--resume {}: the saved time {} is not a whole number of frames of --dt {}",
                path.display(),
                world.time(),
                args.dt
            ));
        }
        let bodies = records(&world).map_err(|e| format!("--resume {}: {e}", path.display()))?;
        let what = format!("saved world {} at time {} (frame {frames})", path.display(), world.time());
        let start = Start {
            bounds: world.bounds(),
            config: world.config(),
            time: world.time(),
            bodies,
            frames_done: frames as u64,
        };
        return Ok((start, what));
    }
    let (scene, what) = match &args.scene {
        Some(path) => (Scene::load(path).map_err(|e| e.to_string())?, format!("scene file {}", path.display())),
        None => generate(args)?,
    };
    if !scene.bodies.is_empty() || !scene.static_bodies.is_empty() {
        return Err("scenes of shapes other than spheres are not split over ranks yet: spheres only".to_string());
    }
    let world = scene.world(config).map_err(|e| e.to_string())?;
    let bodies = records(&world)?;
    Ok((Start { bounds: world.bounds(), config, time: 0.0, bodies, frames_done: 0 }, what))
}

/// Every body of `world` with its handle as global id; the world's slots must be filled by
/// bodies of the first generation, so that a saved world keeps their ids.
fn records(world: &World) -> Result<Vec<(BodyHandle, vadop::SphereRecord)>, String> {
    let mut bodies = Vec::with_capacity(world.len());
    for (k, (handle, _)) in world.spheres().enumerate() {
        if handle != BodyHandle::from_bits(k as u64) {
            return Err(format!(
                "body {handle} holds a slot of a removed body: only worlds whose bodies fill their slots in order are split over ranks"
            ));
        }
        bodies.push((handle, world.record(handle).map_err(|e| e.to_string())?));
    }
    if bodies.len() != world.len() {
        return Err("worlds with shapes other than spheres are not split over ranks yet: spheres only".to_string());
    }
    Ok(bodies)
}

fn generate(args: &Args) -> Result<(Scene, String), String> {
    let scene = match args.kind {
        Kind::Paper => SphereScene::Paper,
        Kind::Gas => SphereScene::Gas,
        Kind::Stream => SphereScene::Stream,
        Kind::HeavyTail => SphereScene::HeavyTail,
    };
    let (velocities, what) = scene.velocities(args.max_speed, args.spread);
    let generated = GeneratedScene {
        bodies: args.bodies,
        packing_fraction: args.packing,
        velocities,
        radius: 0.5,
        seed: args.seed,
    };
    let scene = generated.build().map_err(|e| e.to_string())?;
    Ok((scene, format!("{what}, seed {})", args.seed)))
}

/// `VADOP_MPI_FAIL=RANK:FRAME`: that rank dies at the start of that frame, as a machine failing
/// mid-run would (the tests' killed rank).
fn fail_at() -> Result<Option<(usize, u64)>, String> {
    let Ok(text) = std::env::var("VADOP_MPI_FAIL") else { return Ok(None) };
    let parsed = text.split_once(':').and_then(|(rank, frame)| Some((rank.parse().ok()?, frame.parse().ok()?)));
    parsed.map(Some).ok_or_else(|| format!("VADOP_MPI_FAIL must be RANK:FRAME, got {text:?}"))
}

/// What rank 0 adds up over the frames for the summary.
#[derive(Debug, Default, serde::Serialize)]
struct Totals {
    frames: u64,
    contacts: u64,
    pair_contacts: u64,
    step_ms_max: f64,
    step_ms_mean: f64,
    exchange_ms_max: f64,
    bytes_mean: f64,
    bytes_max: u64,
    ghosts_mean: f64,
    ghosts_max: u64,
    owned_min: u64,
    owned_max: u64,
    migrated: u64,
}

impl Totals {
    fn add(&mut self, f: &FrameFigures) {
        self.frames += 1;
        self.contacts += f.contacts;
        self.pair_contacts += f.pair_contacts;
        self.step_ms_max += f.step_ms_max;
        self.step_ms_mean += f.step_ms_mean;
        self.exchange_ms_max += f.exchange_ms_max;
        self.bytes_mean += f.bytes_mean;
        self.bytes_max = self.bytes_max.max(f.bytes_max);
        self.ghosts_mean += f.ghosts_mean;
        self.ghosts_max = self.ghosts_max.max(f.ghosts_max);
        self.owned_min = if self.frames == 1 { f.owned_min } else { self.owned_min.min(f.owned_min) };
        self.owned_max = self.owned_max.max(f.owned_max);
        self.migrated += f.migrated;
    }
}

fn simulate(comm: &mut Comm, args: &Args) -> Result<(), Failure> {
    let (start, what) = start(args).map_err(Failure::Everywhere)?;
    if let Some(reason) = run::refusal(&start) {
        return Err(Failure::Everywhere(reason));
    }
    let fail_at = fail_at().map_err(Failure::Everywhere)?;
    steps(comm, args, start, what, fail_at).map_err(Failure::Here)
}

/// Steps the run and writes what rank 0 reports.
fn steps(
    comm: &mut Comm,
    args: &Args,
    start: Start,
    what: String,
    fail_at: Option<(usize, u64)>,
) -> Result<(), String> {
    let bodies = start.bodies.len();
    let root = comm.rank == 0;
    let mut contacts_file = match (&args.contacts, root) {
        (Some(path), true) => {
            let file = std::fs::File::create(path).map_err(|e| format!("--contacts {}: {e}", path.display()))?;
            let mut file = BufWriter::new(file);
            writeln!(file, "{}", Contact::CSV_HEADER).map_err(|e| e.to_string())?;
            Some(file)
        }
        _ => None,
    };
    let progress = match root && !args.quiet {
        true => ProgressBar::with_draw_target(Some(args.frames), ProgressDrawTarget::stderr()),
        false => ProgressBar::hidden(),
    };
    progress.set_style(ProgressStyle::with_template("{bar:40} frame {pos}/{len} {msg}").expect("a valid template"));
    let plan = Plan {
        frames: args.frames,
        dt: args.dt,
        ghost_width: args.ghost_width,
        save_state: args.save_state.clone(),
        fail_at,
    };
    let mut totals = Totals::default();
    let mut rows = Vec::new();
    let ranks = comm.size;
    let started = std::time::Instant::now();
    let frames_done = start.frames_done;
    let side = start.bounds.max - start.bounds.min;
    let width = run::run(comm, start, &plan, args.contacts.is_some(), |frame, contacts, figures| {
        if let Some(file) = &mut contacts_file {
            for contact in contacts {
                writeln!(file, "{}", contact.csv_row(frame, false)).map_err(|e| format!("--contacts: {e}"))?;
            }
        }
        totals.add(figures);
        rows.push(*figures);
        progress.set_position(frame - frames_done);
        progress.set_message(format!("{} contacts", totals.contacts));
        Ok(())
    })?;
    progress.finish_and_clear();
    if let Some(mut file) = contacts_file {
        file.flush().map_err(|e| format!("--contacts: {e}"))?;
    }
    if !root {
        return Ok(());
    }
    let seconds = started.elapsed().as_secs_f64();
    if let Some(path) = &args.json {
        let json = serde_json::json!({
            "scene": what,
            "ranks": ranks,
            "bodies": bodies,
            "box": side.to_array(),
            "ghost_width": width,
            "seconds": seconds,
            "summary": totals,
            "frames": rows,
        });
        std::fs::write(path, serde_json::to_string_pretty(&json).expect("plain numbers"))
            .map_err(|e| format!("--json {}: {e}", path.display()))?;
    }
    if !args.quiet {
        let per_frame = |x: f64| x / totals.frames.max(1) as f64;
        println!("scene      {what}: {bodies} spheres");
        println!(
            "ranks      {ranks} (bricks balanced by body count; {} to {} bodies each)",
            totals.owned_min, totals.owned_max
        );
        println!("frames     {} in {seconds:.2} s", totals.frames);
        println!(
            "contacts   {} ({} between bodies, {} with walls), each kept by one rank",
            totals.contacts,
            totals.pair_contacts,
            totals.contacts - totals.pair_contacts
        );
        println!(
            "ms/frame   step: slowest rank {:.3}, mean rank {:.3}; exchanges: slowest rank {:.3}",
            per_frame(totals.step_ms_max),
            per_frame(totals.step_ms_mean),
            per_frame(totals.exchange_ms_max)
        );
        println!(
            "per rank   ghost bodies {:.0} mean, {} most; bytes sent per frame {:.0} mean, {} most; {:.1} bodies handed on per frame in all",
            per_frame(totals.ghosts_mean),
            totals.ghosts_max,
            per_frame(totals.bytes_mean),
            totals.bytes_max,
            per_frame(totals.migrated as f64)
        );
    }
    Ok(())
}
