//! `vadop-bench`: the benchmark harness of vadop, kept apart from the product CLI. Its suites
//! (`core`, `experiments`, `peers`, `speed`, `mpi`) run every measurement as a child process pinned to
//! one core, with a timeout and its own peak memory: the product binary's `vadop simulate --json`,
//! or this binary's hidden `--child` jobs for what must be measured inside the library. Tables
//! go between their markers in BENCHMARKS.md, CSVs and plots into results/; a `--quick` run writes
//! to target/bench-quick/ instead unless told to `--publish`.
//!
//! This file owns argument parsing, dispatch and the one place where a failure becomes an
//! `error: <message>` line and exit code 2; no suite's work happens here.

mod child;
mod common;
mod core_benchmark;
mod experiments;
mod markdown;
mod mpi;
mod peers;
mod plots;
mod progress;
mod runner;
mod speed;
mod summary;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Every failure is a message for the user.
pub type CliResult<T> = Result<T, String>;

/// Benchmarks of vadop: the core engine, the paper's experiments, the peers and the speed suite.
#[derive(Debug, Parser)]
#[command(name = "vadop-bench", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The n x speed grid in detect mode: auto and vadop against the discrete method and brute
    /// force, with missed contacts counted against brute force.
    Core(core_benchmark::CoreArgs),
    /// The paper's experiments with every method: contacts against speed, time against n, speed
    /// and pool size, the cost split, sort work, memory; CSV and plots.
    Experiments(experiments::ExperimentsArgs),
    /// vadop side by side with Bullet, FCL and rapier/parry on identical paths.
    Peers(peers::PeersArgs),
    /// Weak scaling of vadop-mpi (the world split over MPI ranks) beside one process, and a
    /// model of a billion bodies on a hundred nodes.
    Mpi(mpi::MpiArgs),
    /// Where the time goes at scale: detect-mode ms/frame against the old engine and the peers,
    /// narrow tests against swept-box overlaps, re-test cost, simulate-mode throughput, memory per
    /// body, and where each broad phase wins.
    Speed(speed::SpeedArgs),
    /// One measurement inside the library, run by the suites as a child process.
    #[command(long_flag = "child", hide = true)]
    Child(child::ChildArgs),
}

fn main() -> ExitCode {
    // On a bad argument clap prints `error: ...` and exits with code 2; --help exits with 0.
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Core(args) => core_benchmark::run(&args),
        Command::Experiments(args) => experiments::run(&args),
        Command::Peers(args) => peers::run(&args),
        Command::Speed(args) => speed::run(&args),
        Command::Mpi(args) => mpi::run(&args),
        Command::Child(args) => child::run(&args),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}
