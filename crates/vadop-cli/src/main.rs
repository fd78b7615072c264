//! The `vadop` command-line tool: run the paper's scene or a scene file and report contacts,
//! accuracy and costs (`simulate`), tabulate axis pools (`pools`), and check long runs for drift
//! (`soak`). Benchmarks live in their own binary, `vadop-bench` (crates/vadop-bench).
//! This file owns argument parsing, dispatch and the single place where a failure
//! becomes an `error: <message>` line on stderr and exit code 2. It must never do a subcommand's
//! work itself, and nothing a user types may reach a panic or a backtrace: every fallible step
//! returns its message as an `Err` up to here.

mod pools;
mod report;
mod simulate;
mod soak;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Every failure is a message for the user; the CLI never needs to inspect an error's kind.
pub type CliResult<T> = Result<T, String>;

/// Exact continuous collision detection of many fast-moving bodies, spheres and spinning rigid
/// shapes, with velocity-aligned discrete oriented polytopes (VADOPs). The default method is the
/// fastest (today a grid); `--method vadop` runs the paper's.
#[derive(Debug, Parser)]
#[command(name = "vadop", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the paper's scene (or a crowd of shapes, or a scene file) and report contacts, accuracy
    /// against a reference method, the cost split per frame and memory (README.md, "Reading the
    /// summary", explains every line).
    // Boxed: its many options would make every command as large as it.
    Simulate(Box<simulate::SimulateArgs>),
    /// Tabulate axis pools: covering radius against the Fejes Tóth bound, build time, band size.
    Pools(pools::PoolsArgs),
    /// A long elastic run (10^7 contacts by default) checking after every frame that energy and
    /// momentum do not drift, no body leaves the box and no pair overlaps beyond tolerance.
    Soak(soak::SoakArgs),
}

fn main() -> ExitCode {
    // On a bad argument clap prints `error: ...` and exits with code 2; --help exits with 0.
    let cli = Cli::parse();
    let outcome = match cli.command {
        Command::Simulate(args) => simulate::run(&args),
        Command::Pools(args) => pools::run(&args),
        Command::Soak(args) => soak::run(&args),
    };
    match outcome {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}
