//! The hidden `--child` mode: one measurement that must run inside the library, in a process of
//! its own so that its time, core and peak memory are its own. The suites start these through
//! the runner; each job prints its result on stdout (one JSON line, or the peers' contacts file).

use crate::peers::{plain_grid, shapes, trajectory, Scene};
use crate::speed::{candidates, retest};
use crate::CliResult;
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use vadop::Method;

#[derive(Debug, Args)]
pub struct ChildArgs {
    #[arg(long, value_enum)]
    job: Job,
    /// The peers' scene (peers-export, peers-time)
    #[arg(long, value_enum, default_value_t = Scene::Spheres)]
    scene: Scene,
    /// Bodies of the scene (packing 0.05, seed 1)
    #[arg(long)]
    bodies: usize,
    /// Its maximum speed in diameters per frame
    #[arg(long)]
    speed: f64,
    /// Frames to step (for retest: before the timed calls)
    #[arg(long, default_value_t = 1)]
    frames: u64,
    /// The method stepped (peers-time, retest)
    #[arg(long, default_value = "auto")]
    method: String,
    /// peers-export: the folder of the trajectory and reference files; peers-time and
    /// peers-plain-grid: the contacts file
    #[arg(long)]
    out: Option<PathBuf>,
    /// peers-plain-grid: the trajectory file it reads
    #[arg(long)]
    trajectory: Option<PathBuf>,
    /// peers-export: the reference comes from brute force
    #[arg(long)]
    brute: bool,
    /// retest: timed `set_velocity` calls
    #[arg(long, default_value_t = 10_000)]
    calls: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Job {
    /// Write the peers' trajectory file and the reference contacts.
    PeersExport,
    /// Time one of vadop's methods on the peers' scene and write its contacts.
    PeersTime,
    /// Run the reference plain grid over the peers' trajectory file and write its contacts.
    PeersPlainGrid,
    /// Count the body pairs whose swept boxes overlap, per frame.
    Candidates,
    /// Time `World::set_velocity` between frames.
    Retest,
}

pub fn run(args: &ChildArgs) -> CliResult<()> {
    let method = Method::from_name(&args.method).ok_or_else(|| format!("unknown method {}", args.method))?;
    let out = || args.out.clone().ok_or_else(|| "this job needs --out".to_string());
    match args.job {
        Job::PeersExport => match args.scene {
            Scene::Spheres => trajectory::export(args.bodies, args.speed, args.frames, args.brute, &out()?),
            Scene::Shapes => shapes::export(args.bodies, args.speed, args.frames, args.brute, &out()?),
        },
        Job::PeersTime => trajectory::time_method(args.scene, args.bodies, args.speed, args.frames, method, &out()?),
        Job::PeersPlainGrid => {
            let trajectory = args.trajectory.clone().ok_or("this job needs --trajectory")?;
            plain_grid::time(&trajectory, &out()?)
        }
        Job::Candidates => candidates::count(args.bodies, args.speed, args.frames),
        Job::Retest => retest::measure(args.bodies, args.speed, args.frames, method, args.calls),
    }
}
