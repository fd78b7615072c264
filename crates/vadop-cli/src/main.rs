//! The `vadop` command-line tool: run the paper's scene or a scene file and report contacts,
//! accuracy and costs (`simulate`), tabulate axis pools (`pools`), and benchmark the core engine
//! (`bench`). This file owns argument parsing, dispatch and the single place where a failure
//! becomes an `error: <message>` line on stderr and exit code 2. It must never do a subcommand's
//! work itself, and nothing a user types may reach a panic or a backtrace: every fallible step
//! returns its message as an `Err` up to here.

mod bench;
mod peers;
mod pools;
mod report;
mod simulate;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Every failure is a message for the user; the CLI never needs to inspect an error's kind.
pub type CliResult<T> = Result<T, String>;

/// Exact continuous collision detection of many fast-moving spheres with velocity-aligned
/// discrete oriented polytopes (VADOPs).
#[derive(Debug, Parser)]
#[command(name = "vadop", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the paper's scene (or a scene file) and report contacts, accuracy against a reference
    /// method, the cost split per frame and memory.
    Simulate(simulate::SimulateArgs),
    /// Tabulate axis pools: covering radius against the Fejes Tóth bound, build time, band size.
    Pools(pools::PoolsArgs),
    /// Benchmark vadop against the discrete and brute-force methods, each run in its own child
    /// process, and write the results into a markdown file and a CSV.
    Bench(bench::BenchArgs),
    /// Compare vadop with Bullet, FCL and rapier/parry on identical paths (builds the peers itself).
    Peers(peers::PeersArgs),
}

fn main() -> ExitCode {
    // On a bad argument clap prints `error: ...` and exits with code 2; --help exits with 0.
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Simulate(args) => simulate::run(&args),
        Command::Pools(args) => pools::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Peers(args) => peers::run(&args),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}
